//! A force that repeats with the table's position (`errors.force_ripple_*`: a motor's
//! torque ripple, a screw's eccentricity) against the loop's own response to a force,
//! computed here from the transfer functions alone: the rigid body 1/(M s² + b s) closed by
//! an integrating lead-lag on a current amplifier.

use std::f64::consts::TAU;

use contourcheck::machine::MachineConfig;
use contourcheck::plan::AxisCommands;
use contourcheck::sim::{AxisModel, SimConfig, simulate};
use nalgebra::Complex;

/// The table: 172 kg and 1400 N·s/m at the table, 308 N/A, the controller
/// K·(s + z1)(s + z2)/(s·(s + p)) in A/mm with K = 11.7 A/mm, zeros at 7.7 and 10.9 Hz and
/// its pole at 44 Hz (a ball-screw table's loop with its crossover near 20 Hz), on an ideal
/// amplifier. No Coulomb friction: the loop is linear.
const MASS_KG: f64 = 172.0;
const VISCOUS_N_S_PER_M: f64 = 1400.0;
const KT_N_PER_A: f64 = 308.2;
const GAIN_A_PER_MM: f64 = 11.7;
const CORNERS_HZ: [f64; 3] = [7.7, 10.9, 44.0];

fn table(ripple_n: f64, period_mm: f64, phase_deg: f64) -> MachineConfig {
    let [z1, z2, p] = CORNERS_HZ.map(|f| TAU * f);
    let k = GAIN_A_PER_MM;
    let text = format!(
        "base = \"small-table\"\n[x.drive]\nkind = \"linear_motor\"\ntable_mass_kg = {MASS_KG}\n\
         [x.motor]\nkt_nm_per_a = {KT_N_PER_A}\n\
         [x.friction]\ncoulomb_coefficient = 0.0\nviscous_n_s_per_m = {VISCOUS_N_S_PER_M}\n\
         [x.amplifier]\ncurrent_bandwidth_hz = 100000.0\n\
         [x.controller]\nstructure = \"transfer_function\"\n\
         numerator = [{}, {}, {}]\ndenominator = [1.0, {p}, 0.0]\noutput = \"current\"\n\
         [x.errors]\nforce_ripple_n = {ripple_n}\nforce_ripple_period_mm = {period_mm}\n\
         force_ripple_phase_deg = {phase_deg}\n",
        k,
        k * (z1 + z2),
        k * z1 * z2,
    );
    MachineConfig::from_toml_str(&text, "ripple-table.toml").unwrap()
}

/// |x(jω)/F(jω)| (m/N): how far a force at ω moves the table against its loop,
/// P/(1 + P·C) with P = 1/(M s² + b s) and C = K_t·C_A (N/m).
fn loop_compliance_m_per_n(omega: f64) -> f64 {
    let s = Complex::new(0.0, omega);
    let [z1, z2, p] = CORNERS_HZ.map(|f| TAU * f);
    let c = GAIN_A_PER_MM * 1e3 * KT_N_PER_A * (s + z1) * (s + z2) / (s * (s + p));
    let plant = 1.0 / (MASS_KG * s * s + VISCOUS_N_S_PER_M * s);
    (plant / (1.0 + plant * c)).norm()
}

/// The following error (m) at 10 kHz of a ramp at `v_m_per_s` for `seconds`.
fn following_errors(machine: &MachineConfig, v_m_per_s: f64, seconds: f64) -> Vec<f64> {
    let model = AxisModel::from_config(&machine.x);
    let dt = 1e-4;
    let n = (seconds / dt) as usize;
    let trace = simulate(
        &model,
        &AxisCommands::ramp(0.0, v_m_per_s, dt, n),
        dt,
        &SimConfig::default(),
    )
    .unwrap();
    (0..n).map(|k| trace.following_error_m(k)).collect()
}

#[test]
fn a_ripple_moves_the_running_table_by_its_loop_compliance_at_the_ripple_frequency() {
    // 10 N every 10 mm at 100 mm/s: 10 Hz, near the loop's least damped poles (14.7 Hz).
    // After 1.2 s the start's transient (its slowest pole decays at 12.6/s) is gone; the
    // last 0.3 s hold three periods of the ripple.
    for (period_mm, v) in [(10.0, 0.1), (10.0, 0.2), (5.0, 0.1)] {
        let e = following_errors(&table(10.0, period_mm, 30.0), v, 1.5);
        let tail = &e[12_000..];
        let (lo, hi) = tail
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &x| {
                (l.min(x), h.max(x))
            });
        let got_m = 0.5 * (hi - lo);
        let omega = TAU * v / (period_mm * 1e-3);
        let want_m = 10.0 * loop_compliance_m_per_n(omega);
        assert!(
            (got_m / want_m - 1.0).abs() < 0.01,
            "{period_mm} mm at {v} m/s: {:.3} µm, the loop's compliance gives {:.3} µm",
            got_m * 1e6,
            want_m * 1e6
        );
    }
}

#[test]
fn without_a_ripple_the_running_table_does_not_oscillate_and_a_ripple_needs_its_period() {
    let e = following_errors(&table(0.0, 0.0, 0.0), 0.1, 1.5);
    let tail = &e[12_000..];
    let spread = tail.iter().fold(0.0f64, |m, &x| m.max((x - tail[0]).abs()));
    assert!(spread < 1e-9, "{spread:e} m");
    let text = "base = \"small-table\"\n[x.errors]\nforce_ripple_n = 5.0\n";
    let err = MachineConfig::from_toml_str(text, "no-period.toml").unwrap_err();
    assert!(
        err.to_string().contains("errors.force_ripple_period_mm"),
        "{err}"
    );
}
