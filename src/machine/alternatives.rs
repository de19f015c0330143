//! Friction given in absolute units. The model takes friction as the paper states it — a
//! Coulomb coefficient of the table's weight, a static-to-Coulomb ratio, a viscous
//! coefficient at the table — but a small axis is measured otherwise: a drag force in N at
//! the table, or a drag torque in N·m at the motor, read off the drive's current. A machine
//! file may give any one of a quantity's spellings; on loading, the others are converted to
//! the model's key with the file's own mass, lead and gear ratio, so that the friction
//! force does not depend on a guessed mass.
//!
//! | model's key | alternatives |
//! |---|---|
//! | `coulomb_coefficient` | `coulomb_n` (N at the table), `coulomb_nm_at_motor` |
//! | `static_to_coulomb` | `static_n`, `static_nm_at_motor` (breakaway) |
//! | `viscous_n_s_per_m` | `viscous_nm_s_per_rad_at_motor` |
//!
//! A torque at the motor acts at the table as T·2π/(i_t·P) (lead P, screw turns per motor
//! turn i_t; losses in the screw are taken as part of the friction); a viscous torque per
//! rad/s as b·(2π/(i_t·P))².

use super::ConfigError;
use crate::numeric::units::GRAVITY_M_PER_S2;

/// How an alternative key's value becomes the model's.
#[derive(Clone, Copy)]
enum Spelling {
    /// A force at the table (N).
    TableForce,
    /// A torque at the motor (N·m).
    MotorTorque,
    /// A viscous torque at the motor (N·m·s/rad).
    MotorViscous,
}

/// The model's key and its alternatives, in the order they are resolved (the static ratio
/// needs the Coulomb force).
const GROUPS: [(&str, &[(&str, Spelling)]); 3] = [
    (
        "coulomb_coefficient",
        &[
            ("coulomb_n", Spelling::TableForce),
            ("coulomb_nm_at_motor", Spelling::MotorTorque),
        ],
    ),
    (
        "static_to_coulomb",
        &[
            ("static_n", Spelling::TableForce),
            ("static_nm_at_motor", Spelling::MotorTorque),
        ],
    ),
    (
        "viscous_n_s_per_m",
        &[("viscous_nm_s_per_rad_at_motor", Spelling::MotorViscous)],
    ),
];

/// Resolves the friction keys `user` (the file as written) gives in absolute units in
/// `merged` (the file laid over its base): each becomes the model's key, replacing the
/// base's value of it. Two spellings of one quantity in the file are an error.
pub(crate) fn resolve(
    user: &toml::Table,
    merged: &mut toml::Table,
    file: &str,
) -> Result<(), ConfigError> {
    for axis in ["x", "y", "z"] {
        let Some(given) = section(user, axis, "friction") else {
            continue;
        };
        for (model_key, alternatives) in GROUPS {
            let spelled: Vec<(&str, Spelling)> = alternatives
                .iter()
                .copied()
                .filter(|(k, _)| given.contains_key(*k))
                .collect();
            let key = |k: &str| format!("{axis}.friction.{k}");
            match spelled.as_slice() {
                [] => {}
                [(alt, _)] if given.contains_key(model_key) => {
                    return Err(invalid(
                        file,
                        &key(alt),
                        format!("and `{}` say the same thing: give one", key(model_key)),
                    ));
                }
                [(alt, spelling)] => {
                    let value = number(merged, axis, "friction", alt, file)?;
                    if !(value.is_finite() && value >= 0.0) {
                        return Err(invalid(file, &key(alt), format!("= {value}: must be ≥ 0")));
                    }
                    let converted = to_model(merged, axis, model_key, value, *spelling, file)?;
                    let friction = section_mut(merged, axis, "friction");
                    friction.remove(*alt);
                    friction.insert(model_key.into(), toml::Value::Float(converted));
                }
                [(first, _), (second, _), ..] => {
                    return Err(invalid(
                        file,
                        &key(first),
                        format!("and `{}` say the same thing: give one", key(second)),
                    ));
                }
            }
        }
    }
    Ok(())
}

/// The model's value for `value` given in `spelling`.
fn to_model(
    merged: &toml::Table,
    axis: &str,
    model_key: &str,
    value: f64,
    spelling: Spelling,
    file: &str,
) -> Result<f64, ConfigError> {
    let drive = |k: &str| number(merged, axis, "drive", k, file);
    // Table travel per motor radian (m/rad).
    let travel_per_rad = || -> Result<f64, ConfigError> {
        Ok(drive("gear_ratio")? * drive("lead_mm")? * 1e-3 / std::f64::consts::TAU)
    };
    let force_n = match spelling {
        Spelling::TableForce => value,
        Spelling::MotorTorque => value / travel_per_rad()?,
        Spelling::MotorViscous => return Ok(value / travel_per_rad()?.powi(2)),
    };
    let weight_n = drive("table_mass_kg")? * GRAVITY_M_PER_S2;
    Ok(match model_key {
        "coulomb_coefficient" => force_n / weight_n,
        // static_to_coulomb: the breakaway force over the Coulomb force just resolved.
        _ => {
            let coulomb_n =
                number(merged, axis, "friction", "coulomb_coefficient", file)? * weight_n;
            if coulomb_n <= 0.0 {
                return Err(invalid(
                    file,
                    &format!("{axis}.friction.static_n"),
                    "needs a Coulomb friction above zero to be a ratio of".into(),
                ));
            }
            force_n / coulomb_n
        }
    })
}

fn section<'t>(table: &'t toml::Table, axis: &str, name: &str) -> Option<&'t toml::Table> {
    table.get(axis)?.as_table()?.get(name)?.as_table()
}

fn section_mut<'t>(table: &'t mut toml::Table, axis: &str, name: &str) -> &'t mut toml::Table {
    let axis_table = table
        .entry(axis)
        .or_insert_with(|| toml::Value::Table(toml::Table::new()));
    let axis_table = axis_table
        .as_table_mut()
        .expect("an axis is a table once the file has a section in it");
    axis_table
        .entry(name)
        .or_insert_with(|| toml::Value::Table(toml::Table::new()))
        .as_table_mut()
        .expect("a section is a table once the file has keys in it")
}

/// A number at `axis.name.key` of `table`, or an error naming the key.
fn number(
    table: &toml::Table,
    axis: &str,
    name: &str,
    key: &str,
    file: &str,
) -> Result<f64, ConfigError> {
    let path = format!("{axis}.{name}.{key}");
    match section(table, axis, name).and_then(|s| s.get(key)) {
        None => Err(ConfigError::Missing {
            file: file.into(),
            key: path,
            why: " (needed to convert friction given in absolute units)".into(),
        }),
        Some(toml::Value::Float(v)) => Ok(*v),
        Some(toml::Value::Integer(v)) => Ok(*v as f64),
        Some(other) => Err(invalid(
            file,
            &path,
            format!("must be a number, not {other}"),
        )),
    }
}

fn invalid(file: &str, key: &str, problem: String) -> ConfigError {
    ConfigError::Invalid {
        file: file.into(),
        key: key.into(),
        problem,
    }
}
