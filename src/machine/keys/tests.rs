//! The key table's own checks: floors, round trips, unique paths and units.

use super::*;
use crate::machine::MachineConfig;

/// A value near zero of a key with a floor is the key's error, naming it, not a
/// simulation that cannot run; the floor itself is read.
#[test]
fn a_value_near_zero_is_the_keys_error() {
    let floored = [
        ("hvmc", "position_loop", "kv_m_per_min_per_mm", 1e-3),
        ("hvmc", "velocity_loop", "ks_nm_s_per_rad", 1e-6),
        ("hvmc", "velocity_loop", "ts_ms", 1e-3),
        ("hvmc", "current_loop", "ki_v_per_a", 1e-6),
        ("hvmc", "current_loop", "ti_ms", 1e-3),
        ("hvmc", "current_loop", "tcf_ms", 1e-3),
        ("small-table", "amplifier", "current_bandwidth_hz", 1.0),
        ("hvmc", "motor", "ra_ohm", 1e-6),
        ("hvmc", "motor", "la_mh", 1e-3),
        ("hvmc", "motor", "kt_nm_per_a", 1e-4),
        ("hvmc", "drive", "k_theta_nm_per_rad", 1.0),
        ("hvmc", "drive", "k_m_n_per_m", 1e3),
        ("hvmc", "velocity_loop", "i_max_a", 1e-2),
        ("small-table", "amplifier", "i_max_a", 1e-2),
        ("hvmc", "current_loop", "u_max_v", 1.0),
        ("hvmc", "limits", "max_feed_mm_per_min", 1.0),
    ];
    let file = |base: &str, section: &str, key: &str, value: f64| {
        let text = format!("base = \"{base}\"\nname = \"m\"\n[x.{section}]\n{key} = {value:e}\n");
        MachineConfig::from_toml_str(&text, "m.toml")
    };
    for (base, section, key, floor) in floored {
        for near_zero in [1e-200, 0.5 * floor] {
            let e = file(base, section, key, near_zero)
                .expect_err(key)
                .to_string();
            let named = format!("m.toml:4:1: key `x.{section}.{key}` must lie between");
            assert!(e.starts_with(&named), "{e}");
        }
        assert!(file(base, section, key, floor).is_ok(), "{key} at {floor}");
    }
}

/// The floors on the current limits, the voltage limit and the state feedback's position
/// gain sit where the built-in machines' physics says no axis works: below the current that
/// carries the table's Coulomb friction through the screw and the motor, below the back-EMF
/// at the axis's highest cutting feed, and at a position gain whose error to command that
/// current exceeds the axis's whole travel. Each machine's own values lie above its need.
#[test]
fn the_floors_lie_where_the_built_in_machines_physics_says_no_axis_works() {
    let floor = |path: &str| match axis_key(path).expect(path).rule {
        Rule::Range(lo, _) => lo,
        rule => panic!("{path}: {rule:?} has no floor"),
    };
    for preset in ["hvmc", "small-table"] {
        let m = MachineConfig::preset(preset).unwrap();
        for (name, a) in [("x", &m.x), ("y", &m.y)] {
            let d = &a.drive;
            let friction_n = a.friction.coulomb_coefficient * d.table_mass_kg * 9.80665;
            // The screw's torque F·P/(2π); the motor turns 1/i_t times as fast and gives i_t
            // of it.
            let lead_m = d.lead_mm * 1e-3;
            let motor_nm = friction_n * lead_m / std::f64::consts::TAU * d.gear_ratio;
            let current_a = motor_nm / a.motor.kt_nm_per_a;
            let at = format!("{preset} {name}");
            for key in ["velocity_loop.i_max_a", "amplifier.i_max_a"] {
                assert!(floor(key) < current_a, "{at}: {key} against {current_a} A");
                if let Some(limit) = get(a, key) {
                    assert!(limit > current_a, "{at}: {key} {limit} A");
                }
            }
            let [lo, hi] = a.limits.travel_mm.expect("a travel");
            let error_mm = current_a / floor("controller.position_gain_a_per_mm");
            assert!(error_mm > hi - lo, "{at}: {error_mm} mm");
            if let (Some(ke), Some(u_max)) =
                (a.motor.ke_v_s_per_rad, get(a, "current_loop.u_max_v"))
            {
                let feed_m_s = a.limits.max_feed_mm_per_min / 60e3;
                let motor_rad_s = feed_m_s / lead_m * std::f64::consts::TAU / d.gear_ratio;
                let back_emf_v = ke * motor_rad_s;
                assert!(
                    floor("current_loop.u_max_v") < back_emf_v,
                    "{at}: {back_emf_v} V"
                );
                assert!(u_max > back_emf_v, "{at}: {u_max} V");
            }
        }
    }
}

#[test]
fn every_key_reads_back_what_was_set() {
    for preset in ["hvmc", "small-table"] {
        let mut m = MachineConfig::preset(preset).unwrap();
        for (i, k) in AXIS_KEYS.iter().enumerate() {
            let v = 1.0 + i as f64;
            if k.get(&m.x).is_some() {
                assert!(set(&mut m.x, k.path, v), "{}", k.path);
                assert_eq!(get(&m.x, k.path), Some(v), "{}", k.path);
            } else {
                assert!(!set(&mut m.x, k.path, v), "{} set where absent", k.path);
            }
        }
    }
    let mut x = MachineConfig::default_preset().x;
    assert_eq!(get(&x, "drive.backlsh_um"), None);
    assert!(!set(&mut x, "drive.backlsh_um", 1.0));
}

#[test]
fn paths_are_unique_and_every_machine_path_resolves() {
    let paths = machine_paths();
    let mut sorted = paths.clone();
    sorted.sort();
    sorted.dedup();
    assert_eq!(sorted.len(), paths.len());
    let mut m = MachineConfig::default_preset();
    for p in &paths {
        match set_on_machine(&mut m, p, 1.5) {
            Ok(()) => assert_eq!(get_on_machine(&m, p), Some(1.5), "{p}"),
            Err(e) => assert!(
                matches!(e, SetError::Absent | SetError::Unused(_)),
                "{p}: {e}"
            ),
        }
    }
    assert_eq!(
        set_on_machine(&mut m, "x.drive.nope", 1.0),
        Err(SetError::Unknown)
    );
}

#[test]
fn every_machine_path_has_its_unit_and_the_causes_look_up_the_same() {
    for p in machine_paths() {
        assert!(unit_on_machine(&p).is_some(), "{p}");
    }
    assert_eq!(unit_on_machine("x.drive.backlash_um"), Some("µm"));
    assert_eq!(unit_on_machine("z.limits.max_accel_m_per_s2"), Some("m/s²"));
    assert_eq!(unit_on_machine("interpolation.cycle_ms"), Some("ms"));
    assert_eq!(unit_on_machine("y.drive.gear_ratio"), Some(""));
    assert_eq!(unit_on_machine("x.drive.nope"), None);
    assert_eq!(axis_unit("position_loop.kv_m_per_min_per_mm"), "m/min/mm");
}

#[test]
fn a_cascade_gain_is_not_set_on_another_controller() {
    let mut m = MachineConfig::preset("small-table").unwrap();
    assert_eq!(
        set_on_machine(&mut m, "x.position_loop.kv_m_per_min_per_mm", 2.0),
        Err(SetError::Unused(Needs::Cascade))
    );
}
