//! What the identify tests share: the lead-lag table's machine file, and the independent
//! integrator's record of it as its motor encoders read it.

use contourcheck::gcode::Program;
use contourcheck::machine::MachineConfig;
use contourcheck::trace::measured::{MeasuredTrace, parse_trace};

use super::reference::{self, Recording};

/// The small table with a lead-lag controller and an integrator on X,
/// `gain·(s + 2π·z₁)(s + 2π·z₂) / (s·(s + 2π·p))`, on a current amplifier, its corners in Hz;
/// no acceleration feed-forward on either axis.
pub fn lead_lag_toml(gain: f64, z1_hz: f64, z2_hz: f64, p_hz: f64) -> String {
    let [a, b, c] = [z1_hz, z2_hz, p_hz].map(|hz| std::f64::consts::TAU * hz);
    format!(
        "base = \"small-table\"\n[x.controller]\nstructure = \"transfer_function\"\n\
         numerator = [{gain}, {}, {}]\ndenominator = [1.0, {c}, 0.0]\noutput = \"current\"\n\
         accel_feedforward = 0.0\n[y.controller]\naccel_feedforward = 0.0\n",
        gain * (a + b),
        gain * a * b
    )
}

/// `program` on `machine` integrated by the independent reference, driven by its own
/// continuous interpolator, read at 10 kHz in 0.1 µm counts (0.05 µm of noise) with the
/// commands beside.
pub fn encoder_record(program: &Program, machine: &MachineConfig, seed: u64) -> MeasuredTrace {
    let rec = Recording {
        sample_s: 1e-4,
        noise_m: 0.05e-6,
        count_m: 0.1e-6,
        step_s: 1e-5,
        seed,
        accel: 0.5,
        tight_spot_x: None,
        at_feedback: true,
        ..Recording::default()
    };
    let csv = reference::record(program, &machine.x, &machine.y, &rec);
    parse_trace(&csv, "reference.csv").unwrap()
}
