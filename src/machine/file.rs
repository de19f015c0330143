//! The machine file: read (its `base` preset, the file's keys laid over it, every key
//! checked, errors naming the key and the file's line) and written back as TOML.

use std::path::Path;

use super::{
    AxisConfig, DEFAULT_PRESET, MachineConfig, ZAxis, alternatives, base, locate, sections,
    validate,
};

impl MachineConfig {
    /// The embedded default machine.
    pub fn default_preset() -> MachineConfig {
        Self::preset(DEFAULT_PRESET).expect("the embedded default preset is valid")
    }

    /// An embedded preset by name, validated.
    pub fn preset(name: &str) -> Result<MachineConfig, ConfigError> {
        let table = base::preset_table(name, "<command line>")?;
        from_table(table, &format!("<preset {name}>"))
    }

    /// Loads a machine file: its `base` preset (default `hvmc`, or `"none"`) with the file's
    /// keys laid over it, then validated.
    pub fn load(path: &Path) -> Result<MachineConfig, ConfigError> {
        Self::load_with_warnings(path).map(|(machine, _)| machine)
    }

    /// Loads a machine file as [`MachineConfig::load`] does, with warnings: a file that
    /// gives no `base` (it starts from the default preset), values that look like a unit
    /// mixed up (0.005 µm of backlash: mm meant?).
    pub(crate) fn load_with_warnings(
        path: &Path,
    ) -> Result<(MachineConfig, Vec<String>), ConfigError> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| ConfigError::Io {
            file: file.clone(),
            message: e.to_string(),
        })?;
        let machine = Self::from_toml_str(&text, &file)?;
        // The text parsed once already; read as a table again for the keys the file gave.
        let over: toml::Table = text.parse().unwrap_or_default();
        let mut warnings = Vec::new();
        if !over.contains_key("base") {
            warnings.push(base::no_base_warning(&file));
        }
        warnings.extend(suspicious_values(&over, &text, &file));
        Ok((machine, warnings))
    }

    /// Parses a machine from TOML text; `file` names it in errors, and a `base` that names a
    /// file is found relative to its folder. A file that gives no `name` is named after
    /// itself (its file name without `.toml`), not after its base.
    pub fn from_toml_str(text: &str, file: &str) -> Result<MachineConfig, ConfigError> {
        Self::from_toml_chained(text, file, &[])
    }

    /// [`MachineConfig::from_toml_str`] for a file reached through the chain of bases
    /// `chain` (the files that named it, outermost first).
    pub(crate) fn from_toml_chained(
        text: &str,
        file: &str,
        chain: &[std::path::PathBuf],
    ) -> Result<MachineConfig, ConfigError> {
        let mut over: toml::Table =
            text.parse()
                .map_err(|e: toml::de::Error| ConfigError::Syntax {
                    file: file.to_string(),
                    message: syntax_message(text, &e),
                })?;
        let base::Base {
            mut table,
            label: base,
        } = base::resolve(over.remove("base"), file, chain).map_err(|e| {
            // A base file's errors name it, and where in it they are, already.
            if base::is_about(&e, file) {
                locate::located(e, text)
            } else {
                e
            }
        })?;
        if !over.contains_key("name")
            && !file.starts_with('<')
            && let Some(stem) = Path::new(file).file_stem()
        {
            table.insert(
                "name".into(),
                toml::Value::String(stem.to_string_lossy().into_owned()),
            );
        }
        let base_table = table.clone();
        merge(&mut table, over.clone());
        let located = |e: ConfigError| locate::located(e, text);
        alternatives::resolve(&over, &mut table, file).map_err(located)?;
        sections::resolve(&over, &base_table, &mut table, file).map_err(located)?;
        refuse_unused_keys(&over, &table, file).map_err(located)?;
        from_table(table, file)
            .map_err(|e| explain_missing(e, &base, &base_table))
            .map_err(located)
    }

    /// Checks the machine as a machine file is checked: its sections, every number in range,
    /// the values that must agree agreeing; errors name `file` and the key.
    pub(crate) fn validate(&self, file: &str) -> Result<(), ConfigError> {
        validate::validate(self, file)
    }

    /// The machine as TOML (every key its controllers read, no `base`): the cascade's gains
    /// are left out of an axis with another controller, and a velocity loop's of an axis
    /// whose drive closes none, as a file that gave them would be refused.
    pub fn to_toml(&self) -> String {
        let mut table = toml::Table::try_from(self).expect("a machine always serialises");
        let z = self.z.simulated().map(|z| ("z", z));
        for (axis, config) in [("x", &self.x), ("y", &self.y)].into_iter().chain(z) {
            let Some(toml::Value::Table(section)) = table.get_mut(axis) else {
                continue;
            };
            if !config.controller.is_cascade()
                && let Some(toml::Value::Table(position)) = section.get_mut("position_loop")
            {
                for key in [
                    "kv_m_per_min_per_mm",
                    "velocity_feedforward",
                    "accel_feedforward",
                ] {
                    position.remove(key);
                }
            }
            if !config.controller.uses_velocity_loop() {
                section.remove("velocity_loop");
            }
        }
        toml::to_string_pretty(&table).expect("a machine always serialises")
    }
}

/// A configuration error, naming the file and the key.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ConfigError {
    /// The file could not be read.
    #[error("{file}: {message}")]
    Io {
        /// File.
        file: String,
        /// OS message.
        message: String,
    },
    /// Not valid TOML.
    #[error("{file}: {message}")]
    Syntax {
        /// File.
        file: String,
        /// Parser message with line and column.
        message: String,
    },
    /// A key that must be present is not.
    #[error("{file}: missing key `{key}`{why}")]
    Missing {
        /// File.
        file: String,
        /// Dotted key path.
        key: String,
        /// Why it was not taken from the base, when that is the reason (else empty).
        why: String,
    },
    /// A key the machine does not have (a typo, usually).
    #[error("{file}: unknown key `{key}`{hint}")]
    UnknownKey {
        /// File (with the key's line and column where the file's text shows them).
        file: String,
        /// Dotted key path.
        key: String,
        /// " — did you mean `…`?", or empty.
        hint: String,
    },
    /// Several unknown keys: all of them, each where it is.
    #[error("{file}: {} unknown keys:{}", .keys.len(), .keys.iter().map(|k| format!("\n  {k}")).collect::<String>())]
    UnknownKeys {
        /// File.
        file: String,
        /// Each with where it is and what was likely meant.
        keys: Vec<locate::UnknownKeyAt>,
    },
    /// A value of the wrong type, out of range or inconsistent with another.
    #[error("{file}: key `{key}` {problem}")]
    Invalid {
        /// File.
        file: String,
        /// Dotted key path.
        key: String,
        /// What is wrong.
        problem: String,
    },
    /// `base` names no embedded preset and no machine file.
    #[error(
        "{file}: key `base`: no preset or machine file `{name}` (presets: {available}; or \"none\"){hint}"
    )]
    UnknownPreset {
        /// File.
        file: String,
        /// The name given.
        name: String,
        /// The presets there are.
        available: String,
        /// " — did you mean `…`?", where the file looked for is, or empty.
        hint: String,
    },
}

/// A key the file gives that the axis's controller structure does not read is refused, so
/// that no setting is silently without effect: the cascade's gains on another controller, a
/// velocity loop's on a drive that has none.
fn refuse_unused_keys(
    over: &toml::Table,
    merged: &toml::Table,
    file: &str,
) -> Result<(), ConfigError> {
    for axis in ["x", "y", "z"] {
        let given = |section: &str| {
            over.get(axis)
                .and_then(|a| a.get(section))
                .and_then(toml::Value::as_table)
                .map(|t| t.keys().cloned().collect::<Vec<_>>())
                .unwrap_or_default()
        };
        // The structure as the merged file names it (its own check comes later).
        let controller = merged
            .get(axis)
            .and_then(|a| a.get("controller"))
            .and_then(toml::Value::as_table);
        let field = |key: &str| {
            controller
                .and_then(|c| c.get(key))
                .and_then(toml::Value::as_str)
        };
        let structure = field("structure").unwrap_or("cascade");
        let velocity_loop = match structure {
            "cascade" => true,
            "transfer_function" => field("output") == Some("velocity"),
            _ => false,
        };
        let unused = |key: String, why: String| ConfigError::Invalid {
            file: file.into(),
            key,
            problem: format!("is not used: {why}"),
        };
        let upper = axis.to_uppercase();
        if structure != "cascade" {
            let cascade_gains = [
                "kv_m_per_min_per_mm",
                "velocity_feedforward",
                "accel_feedforward",
            ];
            if let Some(key) = given("position_loop")
                .into_iter()
                .find(|k| cascade_gains.contains(&k.as_str()))
            {
                return Err(unused(
                    format!("{axis}.position_loop.{key}"),
                    format!(
                        "the {upper} axis's controller is `{structure}`, whose gains and \
                         feed-forward are set in [{axis}.controller]; [{axis}.position_loop] \
                         gives only `feedback` and `dead_time_ms` to it"
                    ),
                ));
            }
        }
        if !velocity_loop && let Some(key) = given("velocity_loop").into_iter().next() {
            return Err(unused(
                format!("{axis}.velocity_loop.{key}"),
                format!(
                    "the {upper} axis's controller (`{structure}`) commands current, so its \
                     drive closes no velocity loop"
                ),
            ));
        }
    }
    Ok(())
}

/// Values the file gives that are possible but far more likely a unit mixed up: each with
/// its place and what it would be in the unit probably meant.
fn suspicious_values(over: &toml::Table, text: &str, file: &str) -> Vec<String> {
    let mut warnings = Vec::new();
    for axis in ["x", "y", "z"] {
        let value = |section: &str, key: &str| {
            over.get(axis)
                .and_then(|a| a.get(section))
                .and_then(|s| s.get(key))
                .and_then(|v| v.as_float().or_else(|| v.as_integer().map(|i| i as f64)))
        };
        let mut warn = |section: &str, key: &str, why: String| {
            let dotted = format!("{axis}.{section}.{key}");
            let at =
                locate::find_key(text, &dotted).map_or(String::new(), |(l, c)| format!(":{l}:{c}"));
            warnings.push(format!("{file}{at}: {dotted} {why}"));
        };
        if let Some(b) = value("drive", "backlash_um")
            && b > 0.0
            && b < 0.1
        {
            warn(
                "drive",
                "backlash_um",
                format!(
                    "= {b} µm is below any machine's backlash: if mm were meant, write \
                     backlash_um = {}",
                    b * 1e3
                ),
            );
        }
        if let Some(kv) = value("position_loop", "kv_m_per_min_per_mm")
            && kv > 10.0
        {
            warn(
                "position_loop",
                "kv_m_per_min_per_mm",
                format!(
                    "= {kv} m/min/mm is far above a machine tool's position gain (0.3–5): if \
                     1/s were meant, write kv_m_per_min_per_mm = {:.3}",
                    kv / (1000.0 / 60.0)
                ),
            );
        }
    }
    warnings
}

/// Lays `over` onto `base`, table by table; values in `over` win.
fn merge(base: &mut toml::Table, over: toml::Table) {
    for (key, value) in over {
        match (base.get_mut(&key), value) {
            (Some(toml::Value::Table(b)), toml::Value::Table(o)) => merge(b, o),
            (_, v) => {
                base.insert(key, v);
            }
        }
    }
}

/// A missing key in a section the base does not have: the file gave part of a section
/// (an optional one, as `[y.lateral_shift]` on `hvmc`) that has nothing to be laid over.
fn explain_missing(e: ConfigError, base: &str, base_table: &toml::Table) -> ConfigError {
    let ConfigError::Missing { file, key, why } = e else {
        return e;
    };
    let Some((section, _)) = key.rsplit_once('.') else {
        return ConfigError::Missing { file, key, why };
    };
    let mut at = Some(base_table);
    for part in section.split('.') {
        at = at.and_then(|t| t.get(part)).and_then(|v| v.as_table());
    }
    let carried_z = base_table
        .get("z")
        .and_then(|z| z.as_table())
        .is_some_and(|z| z.keys().all(|k| k == "limits"));
    let why = if key.starts_with("z.") && carried_z && base != "none" {
        format!(
            " (the base `{base}` carries Z without simulating it: a section of Z beyond \
             [z.limits] makes it a simulated axis, whose sections the file then gives whole — \
             or start from a base that simulates Z, as `hvmc`)"
        )
    } else if at.is_none() && base != "none" {
        format!(
            " (the base `{base}` has no [{section}], so a file that adds it gives all its keys)"
        )
    } else {
        why
    };
    ConfigError::Missing { file, key, why }
}

fn from_table(mut table: toml::Table, file: &str) -> Result<MachineConfig, ConfigError> {
    // A simulated Z is read apart, so that its errors name its keys as X's and Y's do.
    let z_table = take_simulated_z(&mut table);
    // Every unknown key is reported at once: each is taken out and the rest read again.
    let mut unknown = Vec::new();
    check_z_limits(&mut table, file, z_table.is_none().then_some(&mut unknown))?;
    let machine = read_table::<MachineConfig>(table, file, "", &mut unknown)?;
    let z = match z_table {
        Some(t) => read_table::<AxisConfig>(t, file, "z", &mut unknown)?.map(Some),
        None => Some(None),
    };
    match (machine, z, unknown.len()) {
        (Some(mut machine), Some(z), 0) => {
            if let Some(z) = z {
                machine.z = ZAxis::Simulated(Box::new(z));
            }
            validate::validate(&machine, file)?;
            Ok(machine)
        }
        (.., 1) => {
            let only = unknown.remove(0);
            Err(ConfigError::UnknownKey {
                file: file.into(),
                key: only.key,
                hint: only.hint,
            })
        }
        _ => Err(ConfigError::UnknownKeys {
            file: file.into(),
            keys: unknown,
        }),
    }
}

/// Takes `[z]` out of `table` where it gives more than `limits` (a simulated Z), leaving
/// its limits (or an empty `[z]`, whose missing limits the reading then names).
fn take_simulated_z(table: &mut toml::Table) -> Option<toml::Table> {
    let z = table.get("z")?.as_table()?;
    if z.keys().all(|k| k == "limits") {
        return None;
    }
    let z = z.clone();
    let mut planned = toml::Table::new();
    if let Some(limits) = z.get("limits") {
        planned.insert("limits".into(), limits.clone());
    }
    table.insert("z".into(), toml::Value::Table(planned));
    Some(z)
}

/// Reads Z's limits (all a carried Z has; a simulated Z's stay in the machine's table too)
/// apart, so that their errors name the key with its line as every other section's do:
/// read within the machine, an axis that is either carried or simulated only knows it is
/// `z`. Their unknown keys are taken out, and noted in `unknown` where given (a simulated
/// Z's are noted when its own section is read).
fn check_z_limits(
    table: &mut toml::Table,
    file: &str,
    unknown: Option<&mut Vec<locate::UnknownKeyAt>>,
) -> Result<(), ConfigError> {
    let Some(z) = table.get("z").and_then(|z| z.as_table()).cloned() else {
        return Ok(());
    };
    let mut found = Vec::new();
    read_table::<super::PlannedAxis>(z, file, "z", &mut found)?;
    for key in &found {
        locate::remove_key(table, &key.key);
    }
    if let Some(unknown) = unknown {
        unknown.extend(found);
    }
    Ok(())
}

/// Reads `table` (the file's `prefix` section, or the whole machine when empty) as a `T`.
/// An unknown key is taken out, noted in `unknown` and the rest read again; `None` when any
/// was found (what else is wrong may follow from them), an error when something else is
/// wrong and no unknown key came first.
fn read_table<T: serde::de::DeserializeOwned>(
    mut table: toml::Table,
    file: &str,
    prefix: &str,
    unknown: &mut Vec<locate::UnknownKeyAt>,
) -> Result<Option<T>, ConfigError> {
    loop {
        match serde_path_to_error::deserialize::<_, T>(toml::Value::Table(table.clone())) {
            Ok(value) => return Ok(unknown.is_empty().then_some(value)),
            Err(e) => {
                let (path, message) = within_tagged_section(&table, e);
                let error = classify_serde_error(file, &prefixed(prefix, &path), &message);
                if let ConfigError::UnknownKey { key, hint, .. } = &error
                    && unknown.len() < 100
                    && locate::remove_key(&mut table, unprefixed(prefix, key))
                {
                    unknown.push(locate::UnknownKeyAt::new(key, hint));
                    continue;
                }
                if unknown.is_empty() {
                    return Err(error);
                }
                return Ok(None);
            }
        }
    }
}

/// The dotted path of a reading error and its message, within the section it names where
/// that section is read whole by a tag (`[axis.controller]`'s `structure`): the key in it
/// that is wrong, not the section.
fn within_tagged_section(
    table: &toml::Table,
    e: serde_path_to_error::Error<toml::de::Error>,
) -> (String, String) {
    let path = e.path().to_string();
    let message = e.inner().to_string();
    let section = path.split('.').try_fold(table, |t, k| t.get(k)?.as_table());
    match section {
        Some(section) if path.ends_with("controller") => {
            match super::controller::error_within(section) {
                // A missing key's path is the section's own (`.`).
                Some((inner, message)) if inner != "." => (format!("{path}.{inner}"), message),
                Some((_, message)) => (path, message),
                None => (path, message),
            }
        }
        _ => (path, message),
    }
}

/// A path within the `prefix` section as the file names it.
fn prefixed(prefix: &str, path: &str) -> String {
    match (prefix, path) {
        ("", _) => path.to_string(),
        (_, "" | ".") => prefix.to_string(),
        _ => format!("{prefix}.{path}"),
    }
}

/// The file's dotted key within the `prefix` section.
fn unprefixed<'a>(prefix: &str, key: &'a str) -> &'a str {
    if prefix.is_empty() {
        return key;
    }
    key.strip_prefix(prefix)
        .and_then(|k| k.strip_prefix('.'))
        .unwrap_or(key)
}

fn classify_serde_error(file: &str, path: &str, message: &str) -> ConfigError {
    // serde_path_to_error's path ends at the unknown key itself but at the parent of a
    // missing one.
    let join = |leaf: &str| {
        if path.is_empty() || path == "." {
            leaf.to_string()
        } else if path == leaf || path.ends_with(&format!(".{leaf}")) {
            path.to_string()
        } else {
            format!("{path}.{leaf}")
        }
    };
    let quoted = message.split('`').nth(1).unwrap_or("").to_string();
    if message.starts_with("missing field") {
        ConfigError::Missing {
            file: file.into(),
            key: join(&quoted),
            why: String::new(),
        }
    } else if message.starts_with("unknown field") {
        ConfigError::UnknownKey {
            file: file.into(),
            key: join(&quoted),
            hint: locate::did_you_mean(&quoted, message),
        }
    } else {
        ConfigError::Invalid {
            file: file.into(),
            key: path.to_string(),
            problem: locate::plain_words(path, message),
        }
    }
}

/// toml's message, reduced to "line L, column C: …".
fn syntax_message(text: &str, e: &toml::de::Error) -> String {
    match e.span() {
        Some(span) => {
            let before = &text[..span.start.min(text.len())];
            let line = before.matches('\n').count() + 1;
            let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
            format!("line {line}, column {column}: {}", e.message())
        }
        None => e.message().to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::super::{AxisConfig, PRESETS};
    use super::*;

    #[test]
    fn preset_loads_and_round_trips() {
        let m = MachineConfig::default_preset();
        assert_eq!(m.x.position_loop.kv_m_per_min_per_mm, 1.0);
        assert!(m.x.lateral_shift.is_some() && m.y.lateral_shift.is_none());
        let again = MachineConfig::from_toml_str(&format!("base = \"none\"\n{}", m.to_toml()), "t")
            .unwrap();
        assert_eq!(again, m);
    }

    #[test]
    fn every_preset_round_trips_and_refuses_keys_its_controller_does_not_read() {
        for (name, _) in PRESETS {
            let m = MachineConfig::preset(name).unwrap();
            let again =
                MachineConfig::from_toml_str(&format!("base = \"none\"\n{}", m.to_toml()), "t")
                    .unwrap();
            assert_eq!(again, m, "{name}");
        }
        let e = MachineConfig::from_toml_str(
            "base = \"small-table\"\n[x.position_loop]\nkv_m_per_min_per_mm = 2.0\n",
            "m.toml",
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.starts_with("m.toml:3:1: key `x.position_loop.kv_m_per_min_per_mm` is not used"),
            "{e}"
        );
        let e = MachineConfig::from_toml_str(
            "base = \"small-table\"\n[y.velocity_loop]\nts_ms = 5.0\n",
            "m.toml",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("closes no velocity loop"), "{e}");
    }

    #[test]
    fn a_unit_mixed_up_is_warned_about_with_the_likely_value() {
        let text =
            "[x.drive]\nbacklash_um = 0.005\n[y.position_loop]\nkv_m_per_min_per_mm = 16.7\n";
        let warnings = suspicious_values(&text.parse().unwrap(), text, "m.toml");
        assert_eq!(warnings.len(), 2, "{warnings:?}");
        assert!(warnings[0].starts_with("m.toml:2:1: x.drive.backlash_um = 0.005 µm"));
        assert!(warnings[0].ends_with("backlash_um = 5"), "{}", warnings[0]);
        assert!(
            warnings[1].ends_with("kv_m_per_min_per_mm = 1.002"),
            "{}",
            warnings[1]
        );
    }

    #[test]
    fn every_unknown_key_is_reported_at_once_with_its_line() {
        let text = "base = \"hvmc\"\n[x.drive]\nbacklsh_um = 5.0\n[y.position_loop]\n\
                    kv_m_per_mim_per_mm = 1.0\n";
        let e = MachineConfig::from_toml_str(text, "m.toml")
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "m.toml: 2 unknown keys:\n  line 3, column 1: `x.drive.backlsh_um` — did you mean \
             `backlash_um`?\n  line 5, column 1: `y.position_loop.kv_m_per_mim_per_mm` — did \
             you mean `kv_m_per_min_per_mm`?"
        );
        // Listed in the file's order, whatever order the sections are read in.
        let text = "[y.drive]\nbacklsh_um = 5.0\n[x.drive]\nbacklsh_um = 5.0\n";
        let e = MachineConfig::from_toml_str(text, "m.toml")
            .unwrap_err()
            .to_string();
        let (y_at, x_at) = (e.find("`y.drive").unwrap(), e.find("`x.drive").unwrap());
        assert!(y_at < x_at, "{e}");
        let e = MachineConfig::from_toml_str("[x.drive]\nbacklash_um = \"5 um\"\n", "m.toml")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("m.toml:2:1:") && e.contains("write `backlash_um = 5`"),
            "{e}"
        );
    }

    /// The error of a key within a controller section, which is read whole by its
    /// `structure`, names that key at its own line, not the section at its header.
    #[test]
    fn a_controller_key_in_error_is_named_at_its_line() {
        let error = |body: &str| {
            let text = format!("base = \"small-table\"\n[x.controller]\n{body}");
            MachineConfig::from_toml_str(&text, "m.toml")
                .unwrap_err()
                .to_string()
        };
        let e = error("output = \"voltage\"\n");
        assert!(
            e.starts_with("m.toml:3:1: key `x.controller.output` unknown variant"),
            "{e}"
        );
        let e = error("numerator = \"1,2,3\"\n");
        assert!(
            e.starts_with("m.toml:3:1: key `x.controller.numerator`"),
            "{e}"
        );
        assert!(e.ends_with("write `numerator = [1, 2, 3]`"), "{e}");
        let e = error(
            "structure = \"state_feedback\"\nvelocity_gain_a_s_per_mm = 1.0\n\
             position_gain_a_per_mm = \"x\"\n",
        );
        assert!(
            e.starts_with("m.toml:5:1: key `x.controller.position_gain_a_per_mm`"),
            "{e}"
        );
        let e = error("structure = \"state_feedback\"\nvelocity_gain_a_s_per_mm = 1.0\n");
        assert!(
            e.contains("missing key `x.controller.position_gain_a_per_mm`"),
            "{e}"
        );
    }

    /// A travel whose two ends are equal is named as such; an entry of the list written as
    /// text is shown written in the list, at the list's line.
    #[test]
    fn a_travel_without_length_or_of_text_says_what_is_wrong() {
        let error = |travel: &str| {
            let text = format!("base = \"small-table\"\n[x.limits]\ntravel_mm = {travel}\n");
            MachineConfig::from_toml_str(&text, "m.toml")
                .unwrap_err()
                .to_string()
        };
        let e = error("[0.0, 0.0]");
        assert!(
            e.contains("its two ends are equal") && !e.contains("come first"),
            "{e}"
        );
        assert!(error("[5.0, 0.0]").contains("the lowest position must come first"));
        let e = error("[\"a\", \"b\"]");
        assert!(
            e.starts_with("m.toml:3:1: key `x.limits.travel_mm[0]`"),
            "{e}"
        );
        assert!(e.contains("`travel_mm = [a number, …]`"), "{e}");
    }

    #[test]
    fn a_carried_z_names_its_keys_with_their_line() {
        // small-table's Z is carried: its limits alone.
        let text = "base = \"small-table\"\n[z.limits]\nmax_feed_mm_per_min = \"fast\"\n";
        let e = MachineConfig::from_toml_str(text, "z.toml")
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("z.toml:3:1: key `z.limits.max_feed_mm_per_min`"),
            "{e}"
        );
        let text = "base = \"small-table\"\n[z.limits]\nmax_fed_mm_per_min = 100.0\n";
        let e = MachineConfig::from_toml_str(text, "z.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("`z.limits.max_fed_mm_per_min`"), "{e}");
        assert!(e.contains("did you mean `max_feed_mm_per_min`"), "{e}");
        // hvmc's Z is simulated: the same, and its unknown keys said once.
        let text = "base = \"hvmc\"\n[z.limits]\nrapid_mm_per_min = [1]\n";
        let e = MachineConfig::from_toml_str(text, "z.toml")
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("z.toml:3:1: key `z.limits.rapid_mm_per_min`"),
            "{e}"
        );
        let text = "base = \"hvmc\"\n[z.limits]\nrapd_mm_per_min = 100.0\n";
        let e = MachineConfig::from_toml_str(text, "z.toml")
            .unwrap_err()
            .to_string();
        assert_eq!(e.matches("rapd_mm_per_min").count(), 1, "{e}");
    }

    #[test]
    fn a_file_overrides_only_what_it_names() {
        let m = MachineConfig::from_toml_str("[x.drive]\nbacklash_um = 12.5\n", "m.toml").unwrap();
        assert_eq!(m.x.drive.backlash_um, 12.5);
        assert_eq!(m.y.drive.backlash_um, 0.0);
        assert_eq!(m.x.drive.lead_mm, 16.0);
    }

    #[test]
    fn errors_name_the_key_and_the_file() {
        let e = MachineConfig::from_toml_str("[x.drive]\nbacklash_um = -1.0\n", "m.toml");
        assert_eq!(
            e.unwrap_err().to_string(),
            "m.toml:2:1: key `x.drive.backlash_um` must not be negative (got -1)"
        );
        let e = MachineConfig::from_toml_str("[x.drive]\nbaklash_um = 1.0\n", "m.toml");
        assert_eq!(
            e.unwrap_err().to_string(),
            "m.toml:2:1: unknown key `x.drive.baklash_um` — did you mean `backlash_um`?"
        );
        // A key written without its unit is pointed to the key with it.
        for (text, meant) in [
            ("[x.drive]\nbacklash = 12.0\n", "backlash_um"),
            ("[y.position_loop]\nkv = 1.0\n", "kv_m_per_min_per_mm"),
        ] {
            let e = MachineConfig::from_toml_str(text, "m.toml")
                .unwrap_err()
                .to_string();
            assert!(
                e.contains(&format!("did you mean `{meant}`? (the unit is part")),
                "{e}"
            );
        }
        // A key less a word that is no unit is not said to lack its unit.
        let e = MachineConfig::from_toml_str("[x.drive]\ngear = 2.0\n", "m.toml")
            .unwrap_err()
            .to_string();
        assert!(!e.contains("the unit is part"), "{e}");
        // A carried Z given a section of a simulated one says which it is and what to do.
        let text = "base = \"small-table\"\n[z.gravity]\ncounterbalance_n = 100\n";
        let e = MachineConfig::from_toml_str(text, "m.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("carries Z without simulating it"), "{e}");
        let e = MachineConfig::from_toml_str("base = \"none\"\nname = \"a\"\n", "m.toml");
        assert!(matches!(e.unwrap_err(), ConfigError::Missing { .. }));
        // A mass no table has (its dynamics would overflow the simulation) is the key's error.
        let e = MachineConfig::from_toml_str("[y.drive]\ntable_mass_kg = 1e-200\n", "m.toml");
        let e = e.unwrap_err().to_string();
        assert!(
            e.starts_with("m.toml:2:1: key `y.drive.table_mass_kg` must lie between 0.001 and 1e6"),
            "{e}"
        );
        let e = MachineConfig::from_toml_str("[x.motor]\nra_ohm = \"a\"\n", "m.toml");
        assert!(e.unwrap_err().to_string().contains("x.motor.ra_ohm"));
        let e = MachineConfig::from_toml_str("[x.motor\n", "m.toml");
        assert!(
            e.unwrap_err()
                .to_string()
                .starts_with("m.toml: line 1, column")
        );
    }

    /// Friction force at the table (N) as the model will use it.
    fn coulomb_force_n(a: &AxisConfig) -> f64 {
        a.friction.coulomb_coefficient
            * a.drive.table_mass_kg
            * crate::numeric::units::GRAVITY_M_PER_S2
    }

    #[test]
    fn friction_in_absolute_units_is_the_same_force_whatever_the_mass() {
        let light =
            "[x.drive]\ntable_mass_kg = 80.0\n[x.friction]\ncoulomb_n = 150.0\nstatic_n = 200.0\n";
        let m = MachineConfig::from_toml_str(light, "m.toml").unwrap();
        assert!((coulomb_force_n(&m.x) - 150.0).abs() < 1e-9);
        assert!((m.x.friction.static_to_coulomb - 200.0 / 150.0).abs() < 1e-12);
        // The other axis keeps the base's coefficient.
        assert_eq!(m.y.friction.coulomb_coefficient, 0.010);
        let heavy = light.replace("80.0", "6000.0");
        let m = MachineConfig::from_toml_str(&heavy, "m.toml").unwrap();
        assert!((coulomb_force_n(&m.x) - 150.0).abs() < 1e-9);
        // At the motor: 2 N·m through a 16 mm lead at 1:4 pushes with 2·2π/(0.25·0.016) N.
        let motor =
            "[x.friction]\ncoulomb_nm_at_motor = 2.0\nviscous_nm_s_per_rad_at_motor = 0.01\n";
        let m = MachineConfig::from_toml_str(motor, "m.toml").unwrap();
        let travel_per_rad = 0.25 * 0.016 / std::f64::consts::TAU;
        assert!((coulomb_force_n(&m.x) - 2.0 / travel_per_rad).abs() < 1e-6);
        assert!((m.x.friction.viscous_n_s_per_m - 0.01 / travel_per_rad.powi(2)).abs() < 1e-6);
        // Written out, the machine carries the model's keys and reads back the same.
        let again = MachineConfig::from_toml_str(&format!("base = \"none\"\n{}", m.to_toml()), "t")
            .unwrap();
        assert_eq!(again, m);
    }

    #[test]
    fn a_partial_section_the_base_has_on_the_other_axis_is_completed_from_it() {
        // hvmc has a beam on X only: a partial one on Y takes the rest from X's.
        let m = MachineConfig::from_toml_str("[y.lateral_shift]\nbeam_length_m = 3.0\n", "m.toml")
            .unwrap();
        let (x, y) = (m.x.lateral_shift.unwrap(), m.y.lateral_shift.unwrap());
        assert_eq!(y.beam_length_m, 3.0);
        assert_eq!(y.bending_stiffness_n_m2, x.bending_stiffness_n_m2);
        assert_eq!(y.holder_at_zero_m, x.holder_at_zero_m);
        assert_eq!(x.beam_length_m, 4.0);
    }

    #[test]
    fn friction_said_twice_or_a_partial_new_section_is_refused_with_the_key() {
        let both = "[x.friction]\ncoulomb_coefficient = 0.01\ncoulomb_n = 150.0\n";
        let e = MachineConfig::from_toml_str(both, "m.toml")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("x.friction.coulomb_n") && e.contains("give one"),
            "{e}"
        );
        let negative = "[y.friction]\ncoulomb_n = -3.0\n";
        let e = MachineConfig::from_toml_str(negative, "m.toml")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("y.friction.coulomb_n") && e.contains("≥ 0"),
            "{e}"
        );
        // The small table has no beam at all: part of one cannot be laid over anything.
        let partial = "base = \"small-table\"\n[y.lateral_shift]\nbeam_length_m = 3.0\n";
        let e = MachineConfig::from_toml_str(partial, "m.toml")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("missing key `y.lateral_shift.")
                && e.contains("the base `small-table` has no [y.lateral_shift]"),
            "{e}"
        );
    }
}
