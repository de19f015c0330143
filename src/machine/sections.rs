//! Sections that exclude one another. A machine file is laid over its base key by key, but a
//! few sections say the same thing in two ways, and a file that gives one means the base's
//! other not to apply:
//!
//! - `[axis.amplifier]` (an ideal current amplifier) or `[axis.current_loop]` (the modelled
//!   current loop): a file giving one drops the base's other; giving both is an error.
//! - `[axis.controller]` naming a `structure` replaces the base's controller whole (a
//!   transfer function's coefficients do not mix with state-feedback gains), and a structure
//!   without a velocity loop of its own drops the base's `velocity_loop` unless the file
//!   gives one.
//!
//! And a section the base has on one axis only (`hvmc`'s beam, `[x.lateral_shift]`) may be
//! given in part on the other: the keys it leaves out come from the base's other axis, so a
//! file says only how this axis differs.

use super::ConfigError;

/// Optional sections a partial one of which is completed from the base's other axis.
const COMPLETED_FROM_OTHER_AXIS: [&str; 2] = ["lateral_shift", "amplifier"];

/// Applies the rules above to `merged` (the file laid over `base`), from what `user` (the
/// file as written) gives.
pub(crate) fn resolve(
    user: &toml::Table,
    base: &toml::Table,
    merged: &mut toml::Table,
    file: &str,
) -> Result<(), ConfigError> {
    for (axis, other) in [("x", "y"), ("y", "x")] {
        complete_from_other_axis(user, base, merged, axis, other);
    }
    for axis in ["x", "y", "z"] {
        let Some(given) = user.get(axis).and_then(|v| v.as_table()) else {
            continue;
        };
        let Some(merged_axis) = merged.get_mut(axis).and_then(|v| v.as_table_mut()) else {
            continue;
        };
        exclusive(
            given,
            merged_axis,
            ("amplifier", "current_loop"),
            axis,
            file,
        )?;
        if let Some(controller) = given.get("controller").and_then(|v| v.as_table())
            && controller.contains_key("structure")
        {
            merged_axis.insert("controller".into(), toml::Value::Table(controller.clone()));
            let own_velocity_loop = matches!(
                (
                    controller.get("structure").and_then(|v| v.as_str()),
                    controller.get("output").and_then(|v| v.as_str()),
                ),
                (Some("cascade"), _) | (Some("transfer_function"), Some("velocity"))
            );
            if !own_velocity_loop && !given.contains_key("velocity_loop") {
                merged_axis.remove("velocity_loop");
            }
        }
    }
    Ok(())
}

/// Fills the keys a partial section leaves out from the base's other axis, where the base
/// has no such section on this axis.
fn complete_from_other_axis(
    user: &toml::Table,
    base: &toml::Table,
    merged: &mut toml::Table,
    axis: &str,
    other: &str,
) {
    let section_of = |t: &toml::Table, a: &str, name: &str| -> Option<toml::Table> {
        t.get(a)?.as_table()?.get(name)?.as_table().cloned()
    };
    for name in COMPLETED_FROM_OTHER_AXIS {
        if section_of(user, axis, name).is_none() || section_of(base, axis, name).is_some() {
            continue;
        }
        let Some(template) = section_of(base, other, name) else {
            continue;
        };
        let Some(section) = merged
            .get_mut(axis)
            .and_then(|v| v.as_table_mut())
            .and_then(|t| t.get_mut(name))
            .and_then(|v| v.as_table_mut())
        else {
            continue;
        };
        for (key, value) in template {
            section.entry(key).or_insert(value);
        }
    }
}

/// Of two sections saying one thing, keeps the one the file gives.
fn exclusive(
    given: &toml::Table,
    merged_axis: &mut toml::Table,
    (a, b): (&str, &str),
    axis: &str,
    file: &str,
) -> Result<(), ConfigError> {
    match (given.contains_key(a), given.contains_key(b)) {
        (true, true) => Err(ConfigError::Invalid {
            file: file.to_string(),
            key: format!("{axis}.{a}"),
            problem: format!("and [{axis}.{b}] both describe the current control: give one"),
        }),
        (true, false) => {
            merged_axis.remove(b);
            Ok(())
        }
        (false, true) => {
            merged_axis.remove(a);
            Ok(())
        }
        (false, false) => Ok(()),
    }
}
