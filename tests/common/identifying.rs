//! What the identify tests share: the programs fitted and predicted, the lead-lag table's
//! machine file as designed and as it ran, the independent integrator's record of a machine
//! as its motor encoders read it, and how well a machine predicts a record.

use contourcheck::check::{CheckSettings, check};
use contourcheck::diagnose::{DiagnoseSettings, diagnose};
use contourcheck::gcode::Program;
use contourcheck::identify::Identification;
use contourcheck::machine::{AxisConfig, AxisName, Controller, MachineConfig};
use contourcheck::sim::MeasuredAt;
use contourcheck::trace::measured::{MeasuredTrace, parse_trace};

use super::program_text;
use super::reference::{self, Recording};

/// A 5 s program moving both axes both ways at several feeds, with an arc.
pub fn fitted_program() -> Program {
    program_text(
        "G21 G17 G90 G94\nG0 X0 Y0\nG1 X20 F1000\nY12 F600\nG3 X8 Y12 I-6 J0 F800\n\
         G1 X0 Y0 F1000\nM2\n",
    )
}

/// Another program, for the prediction: other moves, other feeds.
pub fn other_program() -> Program {
    program_text(
        "G21 G17 G90 G94\nG0 X0 Y0\nG1 X10 Y15 F900\nX25 F500\nG2 X25 Y0 I0 J-7.5 F700\nG1 X0 F1000\nM2\n",
    )
}

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

/// The lead-lag table as designed (the template) and as it ran. Designed: the lead zero at
/// 12 Hz and its pole at 80 Hz, the integrator's zero at 5 Hz. Run: the gain 35 % higher,
/// the integrator's zero 30 % lower, the lead zero 20 % higher, the lead pole 20 % lower,
/// and more friction on X than the data sheet's.
pub fn lead_lag_designed_and_run() -> (MachineConfig, MachineConfig) {
    let template =
        MachineConfig::from_toml_str(&lead_lag_toml(45.0, 5.0, 12.0, 80.0), "t.toml").unwrap();
    let mut truth =
        MachineConfig::from_toml_str(&lead_lag_toml(60.75, 3.5, 14.4, 64.0), "truth.toml").unwrap();
    truth.x.friction.coulomb_coefficient = 0.08;
    (template, truth)
}

/// `program` on `machine` integrated by the independent reference, driven by its own
/// continuous interpolator, read at 10 kHz in 0.1 µm counts (0.05 µm of noise) with the
/// commands beside.
pub fn encoder_record(program: &Program, machine: &MachineConfig, seed: u64) -> MeasuredTrace {
    encoder_record_with_tight_spot(program, machine, seed, None)
}

/// [`encoder_record`] with a tight spot on X's guideway: (from m, to m, factor on Coulomb
/// friction).
pub fn encoder_record_with_tight_spot(
    program: &Program,
    machine: &MachineConfig,
    seed: u64,
    tight_spot_x: Option<(f64, f64, f64)>,
) -> MeasuredTrace {
    let rec = Recording {
        tight_spot_x,
        ..encoder_recording(seed)
    };
    reference_trace(program, machine, &rec)
}

/// The interpolator's path acceleration (m/s²) of [`encoder_recording`].
pub const ENCODER_RECORDING_ACCEL: f64 = 0.5;

/// How the identify tests' reference records are taken: the motor's encoder (where the
/// control reads its feedback) at 10 kHz in 0.1 µm counts with 0.05 µm of noise, the
/// integrator stepping at 10 µs, its interpolator at [`ENCODER_RECORDING_ACCEL`]; `seed`
/// for the noise. A test adds the effect it hides by struct update.
pub fn encoder_recording(seed: u64) -> Recording {
    Recording {
        sample_s: 1e-4,
        noise_m: 0.05e-6,
        count_m: 0.1e-6,
        step_s: 1e-5,
        seed,
        accel: ENCODER_RECORDING_ACCEL,
        at_feedback: true,
        ..Recording::default()
    }
}

/// The reference's record `rec` of `program` on `machine`'s X and Y, read as a user's file.
pub fn reference_trace(
    program: &Program,
    machine: &MachineConfig,
    rec: &Recording,
) -> MeasuredTrace {
    let csv = reference::record(program, &machine.x, &machine.y, rec);
    parse_trace(&csv, "reference.csv").unwrap()
}

/// How `machine` predicts `measured`, a record of `program` read at `at`: per axis (X, Y)
/// the residual RMS and the record's following-error RMS (µm).
pub fn predicted(
    program: &Program,
    machine: &MachineConfig,
    measured: &MeasuredTrace,
    at: MeasuredAt,
) -> Vec<(AxisName, f64, f64)> {
    let mut settings = DiagnoseSettings::for_machine(machine);
    settings.max_causes = 0;
    settings.compare.measured_at = at;
    let d = diagnose(program, machine, measured, &settings).unwrap();
    AxisName::BOTH
        .iter()
        .map(|&axis| {
            let commanded = &measured.commands.as_ref().unwrap()[axis.index()];
            let (actual, residual) = if axis == AxisName::X {
                (&measured.x_m, d.before.x.rms_um)
            } else {
                (&measured.y_m, d.before.y.rms_um)
            };
            let squares: f64 = commanded
                .iter()
                .zip(actual)
                .map(|(c, m)| (c - m).powi(2))
                .sum();
            let following_rms_um = 1e6 * (squares / commanded.len() as f64).sqrt();
            (axis, residual, following_rms_um)
        })
        .collect()
}

/// That the machine file `id` writes from `template`, read back and run on `measured` as
/// `diagnose` runs a machine file (every sample compared, the file's own hunting holds left
/// out, no force held at the start), leaves on X and Y the residual the identification
/// states the file gives — its `file_rms_um` where it states one, else the fit's own — to a
/// twentieth: a user who runs the file sees the figure they were told.
pub fn file_gives_what_is_said(
    id: &Identification,
    template: &MachineConfig,
    program: &Program,
    measured: &MeasuredTrace,
    at: MeasuredAt,
) {
    let text = id.machine_file(template, "program.nc");
    let file = MachineConfig::from_toml_str(&text, "identified.toml").unwrap();
    for (axis, residual_um, _) in predicted(program, &file, measured, at) {
        let a = &id.axes[axis.index()];
        let said_um = a.file_rms_um.unwrap_or(a.rms_identified_um);
        assert!(
            (residual_um - said_um).abs() <= 0.05 * said_um,
            "{axis:?}: the file leaves {residual_um:.4} µm RMS, the identification says \
             {said_um:.4} µm (the fit's {:.4} µm)",
            a.rms_identified_um
        );
    }
}

/// The value a key has on the hidden axis.
pub fn hidden_value(hidden: &AxisConfig, key: &str) -> f64 {
    match key {
        "friction.coulomb_n" => {
            hidden.friction.coulomb_coefficient * hidden.drive.table_mass_kg * 9.81
        }
        "position_loop.kv_m_per_min_per_mm" => hidden.position_loop.kv_m_per_min_per_mm,
        "position_loop.velocity_feedforward" => hidden.position_loop.velocity_feedforward,
        "velocity_loop.ts_ms" => hidden.velocity_loop.as_ref().unwrap().ts_ms,
        "drive.table_mass_kg" => hidden.drive.table_mass_kg,
        "friction.viscous_n_s_per_m" => hidden.friction.viscous_n_s_per_m,
        "position_loop.dead_time_ms" => hidden.position_loop.dead_time_ms,
        "controller.zero_1_hz" | "controller.zero_2_hz" | "controller.pole_1_hz" => {
            let Controller::TransferFunction(tf) = &hidden.controller else {
                panic!("{key}");
            };
            let p = if key.contains("zero") {
                &tf.numerator
            } else {
                &tf.denominator
            };
            corners_hz(p)[usize::from(key.contains("_2_"))]
        }
        // The gain at low frequency: the lowest-order coefficients' ratio.
        "controller.gain" => match &hidden.controller {
            Controller::TransferFunction(tf) => {
                let last = |c: &[f64]| *c.iter().rev().find(|v| **v != 0.0).unwrap();
                last(&tf.numerator) / last(&tf.denominator)
            }
            other => panic!("{other:?}"),
        },
        other => {
            contourcheck::machine::keys::get(hidden, other).unwrap_or_else(|| panic!("{other}"))
        }
    }
}

/// A current-commanding controller's gain `key` over the whole drive's inertia as a mass at
/// the table (per kg): what a rigid drive's loop depends on.
pub fn gain_per_inertia(axis: &AxisConfig, key: &str) -> f64 {
    let lead_m = axis.drive.lead_mm * 1e-3 / std::f64::consts::TAU;
    let rotating_kg = (axis.motor.jm_kg_m2 + axis.drive.js_kg_m2) / (lead_m * lead_m);
    hidden_value(axis, key) / (rotating_kg + axis.drive.table_mass_kg)
}

/// The corners (Hz, lowest first) of a quadratic `a·s² + b·s + c` given as `[a, b, c]`: its
/// two roots' magnitudes, or the one of `b·s + c` (a = 0) or of `a·s² + b·s` (c = 0, the
/// integrator's root at 0 not counted). Complex roots give NaN: no corners to compare.
pub fn corners_hz(coefficients: &[f64]) -> Vec<f64> {
    let (a, b, c) = (coefficients[0], coefficients[1], coefficients[2]);
    let mut hz: Vec<f64> = if a == 0.0 || c == 0.0 {
        vec![(if a == 0.0 { c / b } else { b / a }) / std::f64::consts::TAU]
    } else {
        let d = (b * b - 4.0 * a * c).sqrt();
        vec![(b - d) / (2.0 * a), (b + d) / (2.0 * a)]
            .into_iter()
            .map(|w| w / std::f64::consts::TAU)
            .collect()
    };
    hz.sort_by(f64::total_cmp);
    hz
}

/// Prints X's held-out figures of `id` — the fit's, as a share of the following error, the
/// template's and the record's noise — and its values, for the log of a test that fails.
pub fn print_x_held_out(id: &Identification) {
    let x = &id.axes[0];
    eprintln!(
        "X: held out {:.3} µm ({:.1} % of the following error), template {:.3} µm, noise \
         {:.3} µm; {:?}",
        x.held_out_identified_um,
        100.0 * x.held_out_share,
        x.held_out_template_um,
        id.noise_um,
        x.values
    );
}

/// The zeros' and the poles' corners (Hz, lowest first) of the transfer function `id` wrote
/// for X, printed for the log; panics where X's controller is not a transfer function.
#[track_caller]
pub fn x_corners_hz(id: &Identification) -> (Vec<f64>, Vec<f64>) {
    let Controller::TransferFunction(found) = &id.machine.x.controller else {
        panic!("X: a transfer function, not {:?}", id.machine.x.controller);
    };
    let (zeros, poles) = (corners_hz(&found.numerator), corners_hz(&found.denominator));
    eprintln!("X: zeros {zeros:?} Hz, poles {poles:?} Hz");
    (zeros, poles)
}

/// A machine written by an identification predicts `program`'s largest contour error within
/// a tenth of what the machine recorded (`truth`) gives: the use a file is written for.
#[track_caller]
pub fn predicts_contour_within_a_tenth(
    program: &Program,
    written: &MachineConfig,
    truth: &MachineConfig,
) {
    let contour_um = |machine: &MachineConfig| {
        let run = check(program, machine, &CheckSettings::for_machine(machine)).unwrap();
        run.result.summary.max_contour_error_m * 1e6
    };
    let (predicted, actual) = (contour_um(written), contour_um(truth));
    assert!(
        (predicted - actual).abs() <= 0.1 * actual,
        "{}: identified machine {predicted:.2} µm, the machine {actual:.2} µm",
        program.file
    );
}
