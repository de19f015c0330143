//! The numeric keys of an axis that the rest of the tool reads and writes by name — what the
//! cause catalogue fits, what identification fits — in one table: each key's path below the
//! axis, its unit, and how to read and set it. A key spelt wrong anywhere is found by the
//! tests that run every name through this table, not by a panic in a fit.

use super::AxisConfig;

/// One numeric key of an axis.
pub struct AxisKey {
    /// Path below the axis, as in the machine file: `drive.backlash_um`.
    pub path: &'static str,
    /// Its unit, as the machine file gives it (empty for a ratio).
    pub unit: &'static str,
    get: fn(&AxisConfig) -> Option<f64>,
    set: fn(&mut AxisConfig, f64) -> bool,
}

macro_rules! key {
    ($path:literal, $unit:literal, |$a:ident| $field:expr) => {
        AxisKey {
            path: $path,
            unit: $unit,
            get: |$a: &AxisConfig| Some($field),
            set: |$a: &mut AxisConfig, v: f64| {
                $field = v;
                true
            },
        }
    };
}

/// Every key the tool reads and writes by name.
pub const AXIS_KEYS: &[AxisKey] = &[
    key!("drive.backlash_um", "µm", |a| a.drive.backlash_um),
    key!("drive.table_mass_kg", "kg", |a| a.drive.table_mass_kg),
    key!("friction.coulomb_coefficient", "", |a| a
        .friction
        .coulomb_coefficient),
    key!("friction.viscous_n_s_per_m", "N·s/m", |a| a
        .friction
        .viscous_n_s_per_m),
    key!("friction.stribeck_level_n", "N", |a| a
        .friction
        .stribeck_level_n),
    key!("friction.stribeck_velocity_mm_per_min", "mm/min", |a| a
        .friction
        .stribeck_velocity_mm_per_min),
    key!("position_loop.kv_m_per_min_per_mm", "m/min/mm", |a| a
        .position_loop
        .kv_m_per_min_per_mm),
    key!("position_loop.velocity_feedforward", "", |a| a
        .position_loop
        .velocity_feedforward),
    key!("position_loop.dead_time_ms", "ms", |a| a
        .position_loop
        .dead_time_ms),
    key!("errors.cyclic_amplitude_um", "µm", |a| a
        .errors
        .cyclic_amplitude_um),
    key!("errors.cyclic_phase_deg", "°", |a| a
        .errors
        .cyclic_phase_deg),
    key!("errors.scale_error_ppm", "ppm", |a| a
        .errors
        .scale_error_ppm),
    key!("errors.resonance_hz", "Hz", |a| a.errors.resonance_hz),
    key!("errors.resonance_damping", "", |a| a
        .errors
        .resonance_damping),
    key!("errors.squareness_urad", "µrad", |a| a
        .errors
        .squareness_urad),
    key!("errors.straightness_bow_um", "µm", |a| a
        .errors
        .straightness_bow_um),
    key!("errors.lateral_play_um", "µm", |a| a
        .errors
        .lateral_play_um),
    key!("errors.direction_offset_um", "µm", |a| a
        .errors
        .direction_offset_um),
    // The velocity loop is optional (a current amplifier has none): read as absent there.
    AxisKey {
        path: "velocity_loop.ts_ms",
        unit: "ms",
        get: |a| a.velocity_loop.as_ref().map(|v| v.ts_ms),
        set: |a, v| match a.velocity_loop.as_mut() {
            Some(l) => {
                l.ts_ms = v;
                true
            }
            None => false,
        },
    },
];

/// The key of that path, if the table has it.
pub fn axis_key(path: &str) -> Option<&'static AxisKey> {
    AXIS_KEYS.iter().find(|k| k.path == path)
}

/// A key's value on an axis; `None` for a key not in the table or a section the axis does
/// not have.
pub fn get(axis: &AxisConfig, path: &str) -> Option<f64> {
    axis_key(path).and_then(|k| (k.get)(axis))
}

/// Sets a key on an axis; whether it could (the key is in the table and its section there).
pub fn set(axis: &mut AxisConfig, path: &str, value: f64) -> bool {
    axis_key(path).is_some_and(|k| (k.set)(axis, value))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::machine::MachineConfig;

    #[test]
    fn every_key_reads_back_what_was_set() {
        let mut x = MachineConfig::default_preset().x;
        for (i, k) in AXIS_KEYS.iter().enumerate() {
            let v = 1.0 + i as f64;
            assert!(set(&mut x, k.path, v), "{}", k.path);
            assert_eq!(get(&x, k.path), Some(v), "{}", k.path);
        }
        assert_eq!(get(&x, "drive.backlsh_um"), None);
        assert!(!set(&mut x, "drive.backlsh_um", 1.0));
    }
}
