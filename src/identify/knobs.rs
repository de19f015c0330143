//! The values identification fits, as keys of the machine file: which ones, by controller
//! structure, how each is searched (a factor on a positive value, or an increment in units of
//! its scale) and within what range.

use crate::machine::{AxisConfig, Controller};
use crate::units::GRAVITY_M_PER_S2;

/// A value of an axis that identification fits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Knob {
    /// Key below the axis, as in the machine file (`friction.coulomb_n` for the Coulomb
    /// force, written back as the coefficient).
    pub key: &'static str,
    /// Unit as shown.
    pub unit: &'static str,
    /// Searched as a factor on its value (a positive value) rather than an increment.
    pub logarithmic: bool,
    /// For increments: the least scale of a step, and the yardstick of "not determined"
    /// (the value itself, where larger).
    pub least_scale: f64,
    /// Range the value is kept in.
    pub min: f64,
    /// Upper end.
    pub max: f64,
}

impl Knob {
    /// The scale of an increment about `value`.
    pub(crate) fn scale_at(&self, value: f64) -> f64 {
        value.abs().max(self.least_scale)
    }
}

const KV: Knob = Knob {
    key: "position_loop.kv_m_per_min_per_mm",
    unit: "m/min/mm",
    logarithmic: true,
    least_scale: 0.0,
    min: 0.01,
    max: 100.0,
};
const VELOCITY_FEEDFORWARD: Knob = Knob {
    key: "position_loop.velocity_feedforward",
    unit: "",
    logarithmic: false,
    least_scale: 0.1,
    min: 0.0,
    max: 1.2,
};
const INTEGRAL_TIME: Knob = Knob {
    key: "velocity_loop.ts_ms",
    unit: "ms",
    logarithmic: true,
    least_scale: 0.0,
    min: 0.1,
    max: 1e4,
};
const MASS: Knob = Knob {
    key: "drive.table_mass_kg",
    unit: "kg",
    logarithmic: true,
    least_scale: 0.0,
    min: 0.1,
    max: 1e6,
};
const VISCOUS: Knob = Knob {
    key: "friction.viscous_n_s_per_m",
    unit: "N·s/m",
    logarithmic: false,
    least_scale: 100.0,
    min: 0.0,
    max: 1e8,
};
const DEAD_TIME: Knob = Knob {
    key: "position_loop.dead_time_ms",
    unit: "ms",
    logarithmic: false,
    least_scale: 1.0,
    min: 0.0,
    max: 100.0,
};
const COULOMB: Knob = Knob {
    key: "friction.coulomb_n",
    unit: "N",
    logarithmic: false,
    least_scale: 10.0,
    min: 0.0,
    max: 1e6,
};

/// The keys of the cascade's position gain, the velocity integral time, the mass and the
/// Coulomb force, as the search refers to them.
pub const KV_KEY: &str = KV.key;
pub const INTEGRAL_TIME_KEY: &str = INTEGRAL_TIME.key;
pub const MASS_KEY: &str = MASS.key;
pub const COULOMB_KEY: &str = COULOMB.key;
pub const VISCOUS_KEY: &str = VISCOUS.key;

/// What is fitted on an axis with `controller`. The cascade's own gains (Kv, the velocity
/// integral time, the feed-forward) with the mechanics; another controller's gains are the
/// user's settings, and only the mechanics and the dead time are fitted. The velocity
/// loop's gain K_s is never fitted: it and the mass act on the trace almost only through
/// their ratio, so it is taken from the template (the control's setting) and the mass and
/// friction are found relative to it.
pub(crate) fn for_controller(controller: &Controller) -> Vec<Knob> {
    match controller {
        Controller::Cascade => vec![
            KV,
            VELOCITY_FEEDFORWARD,
            INTEGRAL_TIME,
            MASS,
            VISCOUS,
            DEAD_TIME,
            COULOMB,
        ],
        _ => vec![MASS, VISCOUS, DEAD_TIME, COULOMB],
    }
}

/// A knob's value on an axis (the Coulomb friction as a force at the table; the others
/// through the machine's key table).
pub fn get(axis: &AxisConfig, key: &str) -> f64 {
    match key {
        "friction.coulomb_n" => {
            axis.friction.coulomb_coefficient * axis.drive.table_mass_kg * GRAVITY_M_PER_S2
        }
        other => crate::machine::keys::get(axis, other).unwrap_or(f64::NAN),
    }
}

/// Sets `keys` on an axis to `values`. The Coulomb force stays the force it was (fitted or
/// not) whatever mass is set with it: the machine file holds it as a share of the weight.
pub(crate) fn set_all(axis: &mut AxisConfig, keys: &[&str], values: &[f64]) {
    let mut coulomb_n = get(axis, "friction.coulomb_n");
    for (&key, &v) in keys.iter().zip(values) {
        if key == "friction.coulomb_n" {
            coulomb_n = v;
        } else {
            crate::machine::keys::set(axis, key, v);
        }
    }
    axis.friction.coulomb_coefficient = coulomb_n / (axis.drive.table_mass_kg * GRAVITY_M_PER_S2);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::machine::MachineConfig;

    #[test]
    fn every_knob_is_a_machine_key_or_the_coulomb_force() {
        let x = MachineConfig::default_preset().x;
        for controller in [
            Controller::Cascade,
            MachineConfig::preset("small-table").unwrap().x.controller,
        ] {
            for k in for_controller(&controller) {
                assert!(
                    k.key == "friction.coulomb_n"
                        || crate::machine::keys::axis_key(k.key).is_some(),
                    "{}",
                    k.key
                );
                assert!(get(&x, k.key).is_finite(), "{}", k.key);
            }
        }
    }

    #[test]
    fn a_fitted_mass_keeps_the_coulomb_force() {
        let mut x = MachineConfig::default_preset().x;
        let force = get(&x, COULOMB_KEY);
        set_all(&mut x, &[MASS_KEY], &[7500.0]);
        assert!((get(&x, COULOMB_KEY) - force).abs() < 1e-9);
        set_all(&mut x, &[COULOMB_KEY, MASS_KEY], &[1000.0, 5000.0]);
        assert!((get(&x, COULOMB_KEY) - 1000.0).abs() < 1e-9);
        assert_eq!(x.drive.table_mass_kg, 5000.0);
    }

    #[test]
    fn another_controllers_gains_are_the_users() {
        let small = MachineConfig::preset("small-table").unwrap();
        let keys: Vec<&str> = for_controller(&small.x.controller)
            .iter()
            .map(|k| k.key)
            .collect();
        assert!(
            !keys.contains(&KV_KEY) && keys.contains(&MASS_KEY),
            "{keys:?}"
        );
    }
}
