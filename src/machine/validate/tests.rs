//! The checks between values, each against the physics it stands for: a bound computed here
//! from the model's own equations, a file just beyond it refused naming the key, one just
//! within it read.

use crate::machine::MachineConfig;

/// `text` read as a machine file, or its error's text.
fn read(text: &str) -> Result<MachineConfig, String> {
    MachineConfig::from_toml_str(text, "m.toml").map_err(|e| e.to_string())
}

/// The small table's X with `limits` (TOML lines) replacing its own.
fn small_table_x(limits: &str) -> Result<MachineConfig, String> {
    read(&format!("base = \"small-table\"\n[x.limits]\n{limits}\n"))
}

#[test]
fn an_acceleration_that_cannot_stop_the_rapid_within_the_travel_is_refused() {
    // From v braking at a constant a the axis runs v²/(2a): over its 400 mm of travel the
    // small table's X, at its rapid of 10 m/min, needs at least v²/(2·0.4 m).
    let v = 10.0 / 60.0;
    let travel_m = 0.4;
    let least = v * v / (2.0 * travel_m);
    let at = |a: f64| small_table_x(&format!("max_accel_m_per_s2 = {a:e}"));
    let e = at(0.9 * least).expect_err("brakes too weakly");
    assert!(e.contains("key `x.limits.max_accel_m_per_s2` is "), "{e}");
    assert!(at(1.1 * least).is_ok(), "{:?}", at(1.1 * least).err());
}

#[test]
fn a_jerk_that_cannot_stop_the_rapid_within_the_travel_is_refused() {
    // Braking ramped up at j and straight back down, never reaching the 3 m/s² limit: the
    // deceleration peaks at √(v·j) after √(v/j), the speed falls symmetrically over 2√(v/j),
    // the distance is v·√(v/j). Over 400 mm the jerk must be at least v³/(0.4 m)².
    let v: f64 = 10.0 / 60.0;
    let (travel_m, accel) = (0.4, 3.0);
    let least = v.powi(3) / (travel_m * travel_m);
    assert!((v * least).sqrt() < accel, "the limit is never reached");
    let at = |j: f64| small_table_x(&format!("max_jerk_m_per_s3 = {j:e}"));
    let e = at(0.9 * least).expect_err("ramps too slowly");
    assert!(e.contains("key `x.limits.max_jerk_m_per_s3` is "), "{e}");
    assert!(at(1.1 * least).is_ok(), "{:?}", at(1.1 * least).err());
    // Without a travel, nothing is asked of the braking.
    let unbounded = read(
        "base = \"small-table\"\n[z.limits]\nmax_jerk_m_per_s3 = 0.02\nmax_accel_m_per_s2 = 0.002\n",
    );
    assert!(unbounded.is_ok(), "{unbounded:?}");
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
