//! The checks between values, each against the physics it stands for: a bound computed here
//! from the model's own equations, a file just beyond it refused naming the key, one just
//! within it read.

use crate::machine::MachineConfig;

/// `text` read as a machine file, or its error's text.
fn read(text: &str) -> Result<MachineConfig, String> {
    MachineConfig::from_toml_str(text, "m.toml").map_err(|e| e.to_string())
}

#[test]
fn a_rapid_the_axis_cannot_brake_from_within_its_travel_is_read() {
    // A short Z at 40 m/min braking at 1 m/s² needs v²/(2a) = 222 mm, more than its 100 mm
    // of travel: the planner never reaches that rapid there, and the file is a real machine's.
    let v: f64 = 40.0 / 60.0;
    let braking_m = v * v / 2.0;
    assert!(braking_m > 0.1);
    let short = read(
        "base = \"small-table\"\n[z.limits]\nrapid_mm_per_min = 40000.0\n\
         max_feed_mm_per_min = 10000.0\nmax_accel_m_per_s2 = 1.0\ntravel_mm = [-100.0, 0.0]\n",
    );
    assert!(short.is_ok(), "{short:?}");
}

#[test]
fn a_beam_bent_by_a_hundredth_of_its_length_by_its_holder_is_refused() {
    // The model's sag, F·a²·b²/(3·l·EI) at a = b = l/2, is F·l³/(48·EI): the heavy machine's
    // 4 m beam under its 50 kN holder reaches l/100 at EI = 100·F·l²/48.
    let (l, f) = (4.0, 5.0e4);
    let (a, b) = (l / 2.0, l / 2.0);
    let ei_at = |sag: f64| f * a * a * b * b / (3.0 * l * sag);
    let least = ei_at(l / 100.0);
    let at = |ei: f64| {
        read(&format!(
            "base = \"hvmc\"\n[x.lateral_shift]\nbending_stiffness_n_m2 = {ei:e}\n"
        ))
    };
    let e = at(0.9 * least).expect_err("bends too far");
    assert!(
        e.contains("key `x.lateral_shift.bending_stiffness_n_m2` is "),
        "{e}"
    );
    assert!(at(1.1 * least).is_ok(), "{:?}", at(1.1 * least).err());
}

#[test]
fn friction_tables_that_take_the_friction_below_zero_are_refused_naming_the_entry() {
    // hvmc's X: f_c = 0.010 · 6000 kg · 9.81 m/s² = 588.6 N sliding, 1.13 times that at rest.
    let f_c = 0.010 * 6000.0 * 9.81;
    let with = |section: &str| read(&format!("base = \"hvmc\"\n[x.errors]\n{section}"));
    let map = |n: f64| {
        with(&format!(
            "friction_map_mm = [-500.0, 0.0, 500.0]\nfriction_map_n = [0.0, {n}, 0.0]\n"
        ))
    };
    // A looser stretch down to no friction at all is a guideway; 1 N further is not.
    assert!(map(-(f_c - 0.5)).is_ok(), "{:?}", map(-(f_c - 0.5)).err());
    let e = map(-(f_c + 1.0)).expect_err("friction below zero");
    assert!(
        e.contains("m.toml:4:1: key `x.errors.friction_map_n`"),
        "{e}"
    );
    assert!(e.contains("x.errors.friction_map_n[1] = -589.6 N"), "{e}");
    assert!(e.contains("leaves -1.0 N"), "{e}");
    // A speed curve alone, and one that goes below zero only with the map's loose spot.
    let speed = |n: f64| {
        format!("friction_speed_mm_per_min = [0.0, 100.0]\nfriction_speed_n = [0.0, {n}]\n")
    };
    let e = with(&speed(-1000.0)).expect_err("friction below zero");
    assert!(e.contains("x.errors.friction_speed_n[1] = -1000 N"), "{e}");
    let half = 0.5 * f_c + 1.0;
    assert!(with(&speed(-half)).is_ok());
    let both = format!(
        "friction_map_mm = [-500.0, 500.0]\nfriction_map_n = [{}, 0.0]\n{}",
        -half,
        speed(-half)
    );
    let e = with(&both).expect_err("together below zero");
    assert!(
        e.contains("key `x.errors.friction_speed_n`")
            && e.contains("with x.errors.friction_map_n[0]"),
        "{e}"
    );
}

#[test]
fn a_level_near_rest_towards_minus_needs_bristles_and_a_guideways_range() {
    let bristles = "[x.friction]\ncoulomb_coefficient = 0.1\nstatic_to_coulomb = 0.7\n\
                    viscous_n_s_per_m = 200.0\nbristle_stiffness_n_per_um = 50.0\n\
                    bristle_damping_n_s_per_m = 10000.0\nstribeck_velocity_mm_per_min = 600.0\n";
    let with = |extra: &str| read(&format!("base = \"small-table\"\n{bristles}{extra}"));
    let read_back = with("static_to_coulomb_negative = 1.4\n").unwrap();
    assert_eq!(read_back.x.friction.static_to_coulomb_negative, Some(1.4));
    // Towards − as towards +, a tenth of Coulomb's at least: below it no guideway holds.
    let low = with("static_to_coulomb_negative = 0.05\n").unwrap_err();
    assert!(
        low.contains("x.friction.static_to_coulomb_negative"),
        "{low}"
    );
    // Without bristles there is no level near rest by direction to give: refused, not ignored.
    let stuck = read(
        "base = \"small-table\"\n[x.friction]\ncoulomb_coefficient = 0.1\n\
         static_to_coulomb = 1.3\nviscous_n_s_per_m = 200.0\nstatic_to_coulomb_negative = 1.4\n",
    )
    .unwrap_err();
    assert!(
        stuck.contains("x.friction.static_to_coulomb_negative"),
        "{stuck}"
    );
    assert!(stuck.contains("bristle_stiffness"), "{stuck}");
    // A Stribeck excess sets the level near rest both ways: with a level towards − as well,
    // the file says two things of it.
    let both = read(&format!(
        "base = \"small-table\"\n{}stribeck_level_n = 20.0\nstatic_to_coulomb_negative = 1.4\n",
        bristles.replace("static_to_coulomb = 0.7", "static_to_coulomb = 1.0")
    ))
    .unwrap_err();
    assert!(
        both.contains("x.friction.static_to_coulomb_negative"),
        "{both}"
    );
    assert!(both.contains("stribeck_level_n"), "{both}");
}
