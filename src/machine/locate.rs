//! Where a machine file's keys sit in its text, and what a mistyped key most likely meant:
//! so that every error about a key names its line and column, every unknown key comes with
//! the nearest known one, and a value of the wrong kind is explained in the file's terms.

use super::ConfigError;

/// An unknown key, where it is in the file and what was likely meant.
#[derive(Debug, Clone, PartialEq)]
pub struct UnknownKeyAt {
    /// Dotted key path.
    pub key: String,
    /// " — did you mean `…`?", or empty.
    pub hint: String,
    /// 1-based line and column in the file, where the text shows it.
    pub at: Option<(usize, usize)>,
}

impl UnknownKeyAt {
    /// An unknown key not yet located.
    pub(crate) fn new(key: &str, hint: &str) -> UnknownKeyAt {
        UnknownKeyAt {
            key: key.into(),
            hint: hint.into(),
            at: None,
        }
    }
}

impl std::fmt::Display for UnknownKeyAt {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if let Some((line, column)) = self.at {
            write!(f, "line {line}, column {column}: ")?;
        }
        write!(f, "`{}`{}", self.key, self.hint)
    }
}

/// Takes a dotted key out of a table; whether it was there.
pub(crate) fn remove_key(table: &mut toml::Table, dotted: &str) -> bool {
    let mut parts: Vec<&str> = dotted.split('.').collect();
    let Some(leaf) = parts.pop() else {
        return false;
    };
    let mut at = table;
    for part in parts {
        match at.get_mut(part) {
            Some(toml::Value::Table(inner)) => at = inner,
            _ => return false,
        }
    }
    at.remove(leaf).is_some()
}

/// The first word of the units the machine file's keys end in (`_um`, `_nm_per_a`,
/// `_kg_m2`, `_m_per_min_per_mm`): a key that is another key less such an ending was written
/// without its unit.
const UNIT_WORDS: &[&str] = &[
    "um", "mm", "m", "n", "nm", "kg", "ms", "s", "hz", "v", "a", "ohm", "mh", "deg", "urad", "ppm",
];

/// " — did you mean `…`?" when one of the fields serde's message lists as expected is close
/// to the unknown one; else empty.
pub(crate) fn did_you_mean(unknown: &str, serde_message: &str) -> String {
    let Some((_, expected)) = serde_message.split_once("expected") else {
        return String::new();
    };
    let candidates = expected.split('`').skip(1).step_by(2);
    // A key written without its unit (`backlash` for `backlash_um`, `kv` for
    // `kv_m_per_min_per_mm`) is far from it by letters, but plainly meant.
    let with_unit: Vec<&str> = candidates
        .clone()
        .filter(|c| {
            (c.strip_prefix(unknown)
                .and_then(|rest| rest.strip_prefix('_')))
            .and_then(|unit| unit.split('_').next())
            .is_some_and(|first| UNIT_WORDS.contains(&first))
        })
        .collect();
    if let [name] = with_unit.as_slice() {
        return format!(" — did you mean `{name}`? (the unit is part of the key's name)");
    }
    let best = candidates
        .map(|c| (strsim::levenshtein(unknown, c), c))
        .min_by_key(|(d, _)| *d);
    match best {
        Some((distance, name)) if distance <= (unknown.chars().count() / 3).max(2) => {
            format!(" — did you mean `{name}`?")
        }
        _ => String::new(),
    }
}

/// A deserialiser's message about a value in the machine file's own terms: a number written
/// as text is shown how to write, and the key is not repeated.
pub(crate) fn plain_words(path: &str, message: &str) -> String {
    let message = message.split("\nin `").next().unwrap_or(message).trim_end();
    let leaf = path.rsplit('.').next().unwrap_or(path);
    let Some(rest) = message.strip_prefix("invalid type: string ") else {
        return message.to_string();
    };
    if let Some((text, _)) = rest
        .split_once(", expected a sequence")
        .or_else(|| rest.split_once(", expected an array"))
    {
        // A list written as one text ("1,2,3"): its numbers, as a list.
        let numbers: Option<Vec<f64>> = text
            .trim_matches('"')
            .split([',', ';', ' '])
            .filter(|t| !t.is_empty())
            .map(|t| t.parse::<f64>().ok())
            .collect();
        let example = match numbers {
            Some(n) if !n.is_empty() => n.iter().map(f64::to_string).collect::<Vec<_>>().join(", "),
            _ => "a number, …".to_string(),
        };
        return format!(
            "must be a list of numbers, not the text {text}: write `{leaf} = [{example}]`"
        );
    }
    if !(rest.contains("f64") || rest.contains("a number") || rest.contains("integer")) {
        return message.to_string();
    }
    let text = rest.split(", expected").next().unwrap_or(rest);
    let number = text
        .trim_matches('"')
        .split_whitespace()
        .next()
        .and_then(|t| t.parse::<f64>().ok());
    let example = number.map_or("a number".to_string(), |n| n.to_string());
    // An entry of a list is written in the list, its numbers without quotes.
    let write = match leaf.split_once('[') {
        Some((list, _)) => format!("the list's entries as numbers: `{list} = [{example}, …]`"),
        None => format!("`{leaf} = {example}`"),
    };
    format!(
        "must be a number, not the text {text}: write {write} (the unit is part of the key's name)"
    )
}

impl ConfigError {
    /// The dotted key the error is about, where it is about one (the first of several
    /// unknown keys).
    pub fn key(&self) -> Option<&str> {
        match self {
            ConfigError::Missing { key, .. }
            | ConfigError::UnknownKey { key, .. }
            | ConfigError::Invalid { key, .. } => Some(key),
            ConfigError::UnknownKeys { keys, .. } => keys.first().map(|k| k.key.as_str()),
            _ => None,
        }
    }

    /// The file as given and the 1-based line and column the error points to, where the
    /// file's text shows them (see [`located`]; a syntax error's from the TOML parser).
    pub fn place(&self) -> (&str, Option<(usize, usize)>) {
        let file = match self {
            ConfigError::Io { file, .. }
            | ConfigError::Syntax { file, .. }
            | ConfigError::Missing { file, .. }
            | ConfigError::UnknownKey { file, .. }
            | ConfigError::UnknownKeys { file, .. }
            | ConfigError::Invalid { file, .. }
            | ConfigError::UnknownPreset { file, .. } => file.as_str(),
        };
        match self {
            ConfigError::UnknownKeys { file, keys } => (file, keys.first().and_then(|k| k.at)),
            ConfigError::Syntax { file, message } => (file, syntax_place(message)),
            _ => split_place(file),
        }
    }
}

/// `m.toml:3:1` → (`m.toml`, (3, 1)), as [`located`] writes a place.
fn split_place(file: &str) -> (&str, Option<(usize, usize)>) {
    let mut parts = file.rsplitn(3, ':');
    let (column, line, name) = (parts.next(), parts.next(), parts.next());
    match (name, line.map(str::parse), column.map(str::parse)) {
        (Some(name), Some(Ok(line)), Some(Ok(column))) => (name, Some((line, column))),
        _ => (file, None),
    }
}

/// `line 2, column 9: …`, as a syntax error's message starts.
fn syntax_place(message: &str) -> Option<(usize, usize)> {
    let rest = message.strip_prefix("line ")?;
    let (line, rest) = rest.split_once(", column ")?;
    let (column, _) = rest.split_once(':')?;
    Some((line.parse().ok()?, column.parse().ok()?))
}

/// The error with the line and column of its key in the file's `text`, where the text shows
/// it: `m.toml:3:1: key …`.
pub(crate) fn located(e: ConfigError, text: &str) -> ConfigError {
    // An entry of a list (`travel_mm[0]`) is where the list is set.
    let at = |file: String, key: &str| match find_key(text, key.split('[').next().unwrap_or(key)) {
        Some((line, column)) => format!("{file}:{line}:{column}"),
        None => file,
    };
    match e {
        ConfigError::Invalid { file, key, problem } => ConfigError::Invalid {
            file: at(file, &key),
            key,
            problem,
        },
        ConfigError::UnknownKey { file, key, hint } => ConfigError::UnknownKey {
            file: at(file, &key),
            key,
            hint,
        },
        ConfigError::UnknownKeys { file, mut keys } => {
            for k in &mut keys {
                k.at = find_key(text, &k.key);
            }
            // In the file's order (they are found section by section); unplaced ones last.
            keys.sort_by_key(|k| k.at.unwrap_or((usize::MAX, 0)));
            ConfigError::UnknownKeys { file, keys }
        }
        other => other,
    }
}

/// The 1-based line and column where `dotted` is set (or, for a table, opened) in a TOML
/// text: keys under `[section]` headers, dotted keys, quoted keys.
pub(crate) fn find_key(text: &str, dotted: &str) -> Option<(usize, usize)> {
    let unquote = |s: &str| -> String {
        s.split('.')
            .map(|p| p.trim().trim_matches('"').trim_matches('\''))
            .collect::<Vec<_>>()
            .join(".")
    };
    let mut section = String::new();
    for (i, line) in text.lines().enumerate() {
        let code = line.split('#').next().unwrap_or("");
        let trimmed = code.trim_start();
        let indent = code.len() - trimmed.len();
        if let Some(header) = trimmed.strip_prefix('[') {
            let header = header.trim_start_matches('[');
            let name = header.split(']').next().unwrap_or("");
            section = unquote(name);
            if section == dotted {
                return Some((i + 1, indent + 1));
            }
            continue;
        }
        let Some((lhs, _)) = trimmed.split_once('=') else {
            continue;
        };
        let key = unquote(lhs);
        let full = if section.is_empty() {
            key
        } else {
            format!("{section}.{key}")
        };
        if full == dotted {
            return Some((i + 1, code[..indent].chars().count() + 1));
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_are_found_under_headers_and_as_dotted_keys() {
        let text = "base = \"hvmc\"\n[x.drive]\n  backlsh_um = 5\n[y]\nposition_loop.kv = 1\n";
        assert_eq!(find_key(text, "x.drive.backlsh_um"), Some((3, 3)));
        assert_eq!(find_key(text, "y.position_loop.kv"), Some((5, 1)));
        assert_eq!(find_key(text, "x.drive"), Some((2, 1)));
        assert_eq!(find_key(text, "x.motor"), None);
    }

    #[test]
    fn the_nearest_expected_field_is_suggested() {
        let message = "unknown field `backlsh_um`, expected one of `lead_mm`, `backlash_um`";
        assert_eq!(
            did_you_mean("backlsh_um", message),
            " — did you mean `backlash_um`?"
        );
        assert_eq!(did_you_mean("colour", message), "");
    }

    #[test]
    fn a_number_written_as_text_is_shown_how_to_write() {
        let words = plain_words(
            "x.drive.backlash_um",
            "invalid type: string \"5 um\", expected f64\nin `x.drive.backlash_um`",
        );
        assert_eq!(
            words,
            "must be a number, not the text \"5 um\": write `backlash_um = 5` (the unit is part \
             of the key's name)"
        );
    }
}
