//! Where a machine file starts: its `base` — an embedded preset, `"none"` (every key given
//! by the file), or another machine file, named by a path relative to the file that names
//! it, which may start from another in turn. A chain is resolved file by file, each loaded
//! and validated as a machine of its own; a chain that comes back to a file it has passed is
//! refused with the chain named. A file that gives no `base` starts from the default preset,
//! and is warned about; a `base` that names nothing gets the preset it is nearest to.

use std::path::{Path, PathBuf};

use super::{ConfigError, DEFAULT_PRESET, MachineConfig, PRESETS};

/// The most files a chain of bases may pass through.
const MAX_CHAIN: usize = 16;

/// What a file's `base` resolved to: the table its keys are laid over, and how to name it.
pub(crate) struct Base {
    /// The base's keys (empty for `"none"`).
    pub table: toml::Table,
    /// The base as messages name it: `hvmc`, `none`, or the base file's path.
    pub label: String,
}

/// Resolves `value` (the file's `base`, taken out of its table) for the machine file `file`,
/// whose chain of bases so far is `chain` (the files that named this one, outermost first).
pub(crate) fn resolve(
    value: Option<toml::Value>,
    file: &str,
    chain: &[PathBuf],
) -> Result<Base, ConfigError> {
    let name = match value {
        None => {
            return Ok(Base {
                table: preset_table(DEFAULT_PRESET, file)?,
                label: DEFAULT_PRESET.to_string(),
            });
        }
        Some(toml::Value::String(s)) => s,
        Some(other) => {
            return Err(ConfigError::Invalid {
                file: file.to_string(),
                key: "base".into(),
                problem: format!("must be a preset's name or a machine file's path, not {other}"),
            });
        }
    };
    let table = if name == "none" {
        toml::Table::new()
    } else if PRESETS.iter().any(|(n, _)| *n == name) {
        preset_table(&name, file)?
    } else {
        file_table(&name, file, chain)?
    };
    Ok(Base { table, label: name })
}

/// The keys of base file `name`, relative to the folder of `file`: loaded as a machine of
/// its own (its own base resolved relative to it), then written out whole.
fn file_table(name: &str, file: &str, chain: &[PathBuf]) -> Result<toml::Table, ConfigError> {
    let folder = Path::new(file).parent().unwrap_or(Path::new(""));
    let path = folder.join(name);
    if !path.is_file() {
        return Err(unknown_base(name, file, &path));
    }
    let canonical = path.canonicalize().unwrap_or_else(|_| path.clone());
    let here = Path::new(file)
        .canonicalize()
        .unwrap_or_else(|_| PathBuf::from(file));
    let passed: Vec<PathBuf> = chain.iter().cloned().chain([here]).collect();
    if passed.contains(&canonical) || passed.len() > MAX_CHAIN {
        let names: Vec<String> = passed
            .iter()
            .chain([&canonical])
            .map(|p| p.display().to_string())
            .collect();
        return Err(ConfigError::Invalid {
            file: file.to_string(),
            key: "base".into(),
            problem: format!(
                "makes a chain of bases that {}: {}",
                if passed.len() > MAX_CHAIN {
                    "runs on too long"
                } else {
                    "comes back to a file it passed"
                },
                names.join(" → ")
            ),
        });
    }
    let text = std::fs::read_to_string(&path).map_err(|e| ConfigError::Io {
        file: path.display().to_string(),
        message: e.to_string(),
    })?;
    let machine = MachineConfig::from_toml_chained(&text, &path.display().to_string(), &passed)?;
    Ok(toml::Table::try_from(&machine).expect("a machine always serialises"))
}

/// A `base` that is neither a preset nor a file: the presets there are and, where the name
/// is near one, the one likely meant.
fn unknown_base(name: &str, file: &str, looked_at: &Path) -> ConfigError {
    let presets: Vec<&str> = PRESETS.iter().map(|(n, _)| *n).collect();
    let nearest = presets
        .iter()
        .map(|p| (strsim::damerau_levenshtein(name, p), *p))
        .min_by_key(|(d, _)| *d)
        .filter(|(d, p)| *d <= 2.max(p.len() / 4));
    let path_like = name.ends_with(".toml") || name.contains('/') || name.contains('\\');
    let hint = match nearest {
        Some((_, p)) if !path_like => format!(" — did you mean `{p}`?"),
        _ if path_like => format!(" (no file at {})", looked_at.display()),
        _ => String::new(),
    };
    ConfigError::UnknownPreset {
        file: file.to_string(),
        name: name.to_string(),
        available: presets.join(", "),
        hint,
    }
}

/// An embedded preset's keys.
pub(crate) fn preset_table(name: &str, file: &str) -> Result<toml::Table, ConfigError> {
    let Some((_, text)) = PRESETS.iter().find(|(n, _)| *n == name) else {
        return Err(unknown_base(name, file, Path::new(name)));
    };
    Ok(text.parse().expect("embedded presets are valid TOML"))
}

/// Whether error `e` is about the file `file` itself (to be located in its text), rather
/// than about a base file further down its chain (located in that file's already).
pub(crate) fn is_about(e: &ConfigError, file: &str) -> bool {
    e.place().0 == file
}

/// The warning for a file that gives no `base`.
pub(crate) fn no_base_warning(file: &str) -> String {
    format!(
        "{file} gives no `base`: its keys are laid over the preset `{DEFAULT_PRESET}`; write \
         base = \"{DEFAULT_PRESET}\" to say so, or name another preset, a machine file, or \
         \"none\" to give every key"
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_misspelt_preset_is_met_with_the_one_meant() {
        let e = resolve(Some(toml::Value::String("hmvc".into())), "m.toml", &[])
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("did you mean `hvmc`?"), "{e}");
        let e = resolve(
            Some(toml::Value::String("small_table".into())),
            "m.toml",
            &[],
        )
        .err()
        .unwrap()
        .to_string();
        assert!(e.contains("did you mean `small-table`?"), "{e}");
        let e = resolve(
            Some(toml::Value::String("shop/mill.toml".into())),
            "m.toml",
            &[],
        )
        .err()
        .unwrap()
        .to_string();
        assert!(e.contains("no file at shop/mill.toml"), "{e}");
        let absent = resolve(None, "m.toml", &[]).ok().unwrap();
        assert_eq!(absent.label, "hvmc");
    }
}
