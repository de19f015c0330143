//! `identify` on records of machines the test hides — the heavy preset with other gains,
//! mass and friction, and the small table (a PID on a current amplifier, and state feedback)
//! with other mechanics — driven by a foreign interpolator's commands (no look-ahead,
//! trapezoids, stops at every block end, its own clock), recorded at 10 kHz in 0.1 µm counts
//! with the commands beside. The values the record determines must come back within four of
//! their stated uncertainties, and the identified machine must predict a second program's
//! record, not used in the fit, to within 2 % of its following error (or the record's noise,
//! where an axis with integral action follows closer than that). The small table is also
//! recorded by the independent integrator of `common::reference` — neither the tool's
//! simulator nor its interpolator — and identified from that record alike.

use crate::common;

use common::identifying::{
    self, encoder_record, fitted_program, gain_per_inertia, hidden_value,
    lead_lag_designed_and_run, lead_lag_toml, other_program, predicted,
};
use common::reference::{self, Recording};
use common::{assert_within_k_sigma, foreign_commands, program_text};
use contourcheck::compare::CompareSettings;
use contourcheck::diagnose::synth::{SynthSpec, synthesize};
use contourcheck::gcode::Program;
use contourcheck::identify::{
    AxisIdentification, Identification, IdentifyError, identify, identify_loop, loop_template,
};
use contourcheck::machine::{AxisConfig, AxisName, Controller, MachineConfig};
use contourcheck::sim::MeasuredAt;
use contourcheck::trace::measured::{MeasuredTrace, parse_trace};

/// How a record of a hidden machine is made, and where it reads the position.
#[derive(Clone, Copy)]
struct Recorder {
    make: fn(&Program, &MachineConfig, u64) -> MeasuredTrace,
    at: MeasuredAt,
}

/// The tool's own simulator fed the foreign interpolator's commands, read at the table.
const TOOL: Recorder = Recorder {
    make: record,
    at: MeasuredAt::Table,
};

/// The independent reference, read where the control reads (the small table's motor
/// encoders).
const REFERENCE: Recorder = Recorder {
    make: encoder_record,
    at: MeasuredAt::Motor,
};

/// The independent reference on a machine that reads a linear scale (the heavy preset): the
/// control's feedback is the table's position.
const REFERENCE_AT_SCALE: Recorder = Recorder {
    make: encoder_record,
    at: MeasuredAt::Table,
};

/// `program` on `machine`, driven by the foreign interpolator, as a 10 kHz servo trace.
fn record(program: &Program, machine: &MachineConfig, seed: u64) -> MeasuredTrace {
    let spec = SynthSpec {
        commands: Some(foreign_commands(program, 0.5, 1e-4, 0.2)),
        with_commands: true,
        sample_s: 1e-4,
        quantization_m: 0.1e-6,
        noise_m: 0.05e-6,
        offset_s: 0.13,
        seed,
        ..SynthSpec::default()
    };
    let mut csv = Vec::new();
    synthesize(program, machine, &spec)
        .unwrap()
        .write_csv(&mut csv)
        .unwrap();
    parse_trace(std::str::from_utf8(&csv).unwrap(), "trace.csv").unwrap()
}

/// How `machine` predicts another program's record of `truth` (seeded `seed`): per axis,
/// the residual RMS and the record's following-error RMS (µm).
fn predicts_other_program(
    truth: &MachineConfig,
    machine: &MachineConfig,
    seed: u64,
    recorder: Recorder,
) -> Vec<(AxisName, f64, f64)> {
    let other = other_program();
    predicted(
        &other,
        machine,
        &(recorder.make)(&other, truth, seed),
        recorder.at,
    )
}

/// Identifies `truth` from `template` on the fitted program's record, checks every
/// determined value against the truth and the held-out halves, and that the keys in
/// `must_see` are determined; then predicts the other program's record.
fn identified_and_predicting(
    template: &MachineConfig,
    truth: &MachineConfig,
    must_see: &[&str],
    seed: u64,
    recorder: Recorder,
) -> Identification {
    let mut settings = CompareSettings::for_machine(template);
    settings.measured_at = recorder.at;
    let program = fitted_program();
    let id = identify(
        &program,
        template,
        &(recorder.make)(&program, truth, seed),
        &settings,
    )
    .unwrap();
    for a in &id.axes {
        assert_determined_values_are_the_truths(a, truth.axis(a.axis));
        assert_must_see_determined(a, must_see);
        // Down to the record's noise, and as well on the half each fit did not see.
        assert!(a.rms_identified_um < 1.5 * id.noise_um, "{a:?}");
        assert!(a.held_out_identified_um < 1.5 * id.noise_um, "{a:?}");
        // Better than the template, unless that was at the noise already.
        assert!(
            a.held_out_identified_um < a.held_out_template_um.max(1.1 * id.noise_um),
            "{a:?}"
        );
    }
    for key in must_see {
        let key = key.split_once(':').map_or(*key, |(_, k)| k);
        assert!(
            id.axes
                .iter()
                .any(|a| a.values.iter().any(|v| v.key == key)),
            "{key} is fitted on neither axis"
        );
    }
    // The identified machine predicts a program it was not fitted on.
    for (axis, residual_um, following_rms_um) in
        predicts_other_program(truth, &id.machine, seed + 1, recorder)
    {
        // An axis with integral action follows to a few µm: there the record's noise is the
        // floor.
        assert!(
            residual_um <= (0.02 * following_rms_um).max(1.5 * id.noise_um),
            "{axis}: residual {} µm against a following error of {following_rms_um} µm",
            residual_um
        );
    }
    id
}

/// That every value `a` determined, and the gain per inertia where the gain and the mass
/// trade along it, lies within four of its stated uncertainties of the hidden axis's.
fn assert_determined_values_are_the_truths(a: &AxisIdentification, hidden: &AxisConfig) {
    for v in a.values.iter().filter(|v| v.determined) {
        let what = format!("{}: {}", a.axis, v.key);
        let want = hidden_value(hidden, v.key);
        assert_within_k_sigma(&what, want, v.value, v.uncertainty, 4.0);
    }
    // The ratio the loop depends on, where the gain and the mass trade along it.
    if let Some(r) = &a.gain_per_inertia {
        let what = format!("{}: {} per inertia", a.axis, r.gain);
        let want = gain_per_inertia(hidden, r.gain);
        assert_within_k_sigma(&what, want, r.value, r.uncertainty, 4.0);
    }
}

/// That each key of `must_see` that `a` has is determined: on each axis, or on the one
/// named (`x:controller.zero_1_hz`).
fn assert_must_see_determined(a: &AxisIdentification, must_see: &[&str]) {
    for key in must_see {
        let (only, key) = match key.split_once(':') {
            Some((axis, key)) => (Some(axis), key),
            None => (None, *key),
        };
        if only.is_some_and(|axis| !axis.eq_ignore_ascii_case(&a.axis.to_string())) {
            continue;
        }
        if let Some(v) = a.values.iter().find(|v| v.key == key) {
            assert!(v.determined, "{}: {key} not determined: {v:?}", a.axis);
        }
    }
}

/// The heavy preset as it ran: other gains, a heavier X table with more friction, a slower
/// velocity integrator and more damping on Y.
fn heavy_retuned() -> MachineConfig {
    let mut truth = MachineConfig::default_preset();
    truth.x.position_loop.kv_m_per_min_per_mm = 0.9;
    truth.x.drive.table_mass_kg = 7500.0;
    truth.x.friction.coulomb_coefficient = 0.015;
    truth.y.position_loop.kv_m_per_min_per_mm = 0.8;
    truth.y.velocity_loop.as_mut().unwrap().ts_ms = 15.0;
    truth.y.friction.viscous_n_s_per_m = 6000.0;
    truth
}

#[test]
fn a_hidden_cascade_is_identified_from_the_heavy_template_and_predicts_another_program() {
    identified_and_predicting(
        &MachineConfig::default_preset(),
        &heavy_retuned(),
        &[
            "position_loop.kv_m_per_min_per_mm",
            "velocity_loop.ts_ms",
            "drive.table_mass_kg",
            "friction.coulomb_n",
        ],
        81,
        TOOL,
    );
}

#[test]
fn a_hidden_cascade_recorded_by_an_independent_integrator_is_identified() {
    // The heavy preset's cascade with other gains, mass and friction, integrated by the
    // reference (its own current loop, screw and nut, friction by a sticking test) under its
    // own continuous trapezoids and read at the scale: neither the tool's simulator nor its
    // interpolator made the record.
    identified_and_predicting(
        &MachineConfig::default_preset(),
        &heavy_retuned(),
        &["position_loop.kv_m_per_min_per_mm", "drive.table_mass_kg"],
        85,
        REFERENCE_AT_SCALE,
    );
}

/// The heavy preset with play in X's nut and more static friction on Y than its template
/// has: the cascade's values alone leave the reversals unexplained, and the nonlinear parts
/// are fitted on top.
fn heavy_with_play_and_sticking() -> MachineConfig {
    let mut truth = MachineConfig::default_preset();
    truth.x.position_loop.kv_m_per_min_per_mm = 0.9;
    truth.x.drive.backlash_um = 6.0;
    truth.y.position_loop.kv_m_per_min_per_mm = 0.8;
    truth.y.friction.static_to_coulomb = 2.5;
    truth
}

#[test]
fn backlash_and_static_friction_the_template_lacks_are_identified_on_top() {
    identified_and_predicting(
        &MachineConfig::default_preset(),
        &heavy_with_play_and_sticking(),
        &[
            "x:drive.backlash_um",
            "y:friction.static_to_coulomb",
            "position_loop.kv_m_per_min_per_mm",
        ],
        88,
        TOOL,
    );
}

#[test]
fn play_and_sticking_recorded_by_an_independent_integrator_are_identified_on_top() {
    // The same machine integrated by the reference (its nut a spring through the gap, its
    // friction by a sticking test) under its own trapezoids, read at the scale.
    identified_and_predicting(
        &MachineConfig::default_preset(),
        &heavy_with_play_and_sticking(),
        &["x:drive.backlash_um", "y:friction.static_to_coulomb"],
        89,
        REFERENCE_AT_SCALE,
    );
}

/// The small table as designed (the template: a PID on X, state feedback on Y, both on
/// current amplifiers) and as it ran: other gains — X's 40 % higher, Y's position gain 35 %
/// lower, its speed gain 33 % higher and its integral gain half again — other table masses
/// (X 50 % heavier, Y lighter) and more friction than the data sheet's. (X without
/// acceleration feed-forward: fed the acceleration the record's commands are read back to,
/// the foreign interpolator's steps smoothed, a fit with it came out 13 % off — see
/// docs/identify.md.)
fn small_table_designed_and_run() -> (MachineConfig, MachineConfig) {
    let template = MachineConfig::from_toml_str(
        "base = \"small-table\"\n[x.controller]\naccel_feedforward = 0.0\n\
         [y.controller]\nstructure = \"state_feedback\"\nposition_gain_a_per_mm = 40.0\n\
         integral_gain_a_per_mm_s = 1000.0\nvelocity_gain_a_s_per_mm = 0.3\n\
         velocity_feedforward = 1.0\naccel_feedforward = 1.0\n",
        "template.toml",
    )
    .unwrap();
    let mut truth = template.clone();
    let Controller::TransferFunction(tf) = &mut truth.x.controller else {
        panic!("the preset's X is a transfer function");
    };
    tf.numerator.iter_mut().for_each(|c| *c *= 1.4);
    truth.x.drive.table_mass_kg = 45.0;
    truth.x.friction.coulomb_coefficient = 0.08;
    truth.x.friction.viscous_n_s_per_m = 400.0;
    let Controller::StateFeedback(sf) = &mut truth.y.controller else {
        panic!("Y is state feedback");
    };
    sf.position_gain_a_per_mm = 26.0;
    sf.velocity_gain_a_s_per_mm = 0.4;
    sf.integral_gain_a_per_mm_s = 1500.0;
    truth.y.drive.table_mass_kg = 40.0;
    truth.y.friction.coulomb_coefficient = 0.14;
    (template, truth)
}

/// Identifies the small table from `recorder`'s record: the gains of both controllers are
/// determined, and the torque constant (which scales every gain) is said to be kept.
fn small_table_identified(recorder: Recorder, seed: u64) {
    let (template, truth) = small_table_designed_and_run();
    let id = identified_and_predicting(
        &template,
        &truth,
        &["friction.coulomb_n", "drive.table_mass_kg"],
        seed,
        recorder,
    );
    let x_gain = id.axes[0]
        .values
        .iter()
        .find(|v| v.key == "controller.gain")
        .unwrap();
    assert!(x_gain.determined, "{x_gain:?}");
    let y_gain = id.axes[1]
        .values
        .iter()
        .find(|v| v.key == "controller.position_gain_a_per_mm")
        .unwrap();
    assert!(y_gain.determined, "{y_gain:?}");
    assert!(
        id.axes[0].kept.starts_with("motor.kt_nm_per_a"),
        "{}",
        id.axes[0].kept
    );
}

#[test]
fn a_small_table_whose_gains_are_not_the_designed_ones_is_identified() {
    small_table_identified(TOOL, 91);
}

#[test]
fn state_feedback_far_from_its_design_is_identified() {
    // Y's position gain under half the design's, its speed gain twice and its integral gain
    // two and a half times.
    let (template, mut truth) = small_table_designed_and_run();
    let Controller::StateFeedback(sf) = &mut truth.y.controller else {
        panic!("Y is state feedback");
    };
    sf.position_gain_a_per_mm = 18.0;
    sf.velocity_gain_a_s_per_mm = 0.6;
    sf.integral_gain_a_per_mm_s = 2500.0;
    identified_and_predicting(
        &template,
        &truth,
        &[
            "y:controller.position_gain_a_per_mm",
            "y:controller.velocity_gain_a_s_per_mm",
            "y:controller.integral_gain_a_per_mm_s",
        ],
        71,
        TOOL,
    );
}

#[test]
fn a_small_table_recorded_by_an_independent_integrator_is_predicted_as_its_truth_predicts_it() {
    // Neither the tool's simulator nor its interpolator made these records (the reference's
    // motor encoder, first-order amplifier, sticking friction and continuous trapezoids).
    // Identified from one program's record, the machine predicts another program's record
    // as well as the hidden machine itself does, and better than the design. Y follows to
    // five times the noise and its fit trades the gains, friction and mass along a direction
    // the record hardly sees (docs/identify.md): not measurements.
    let (template, truth) = small_table_designed_and_run();
    let program = fitted_program();
    let mut settings = CompareSettings::for_machine(&template);
    settings.measured_at = REFERENCE.at;
    let measured = encoder_record(&program, &truth, 92);
    let id = identify(&program, &template, &measured, &settings).unwrap();
    for a in &id.axes {
        for v in a.values.iter().filter(|v| v.measured) {
            let what = format!("{}: {} (measured)", a.axis, v.key);
            let hidden = hidden_value(truth.axis(a.axis), v.key);
            assert_within_k_sigma(&what, hidden, v.value, v.uncertainty, 4.0);
        }
    }
    let y = &id.axes[1];
    let y_gain = y
        .values
        .iter()
        .find(|v| v.key == "controller.position_gain_a_per_mm");
    assert!(!y_gain.unwrap().measured, "{y:?}");
    assert_hunting_x_is_loose_and_says_so(&id, &template);
    assert_loose_x_within_what_is_stated(&id.axes[0], truth.axis(AxisName::X));
    // Another program's record (one, for the three machines).
    let other = other_program();
    let measured = encoder_record(&other, &truth, 93);
    let found = predicted(&other, &id.machine, &measured, REFERENCE.at);
    let hidden = predicted(&other, &truth, &measured, REFERENCE.at);
    let design = predicted(&other, &template, &measured, REFERENCE.at);
    for ((f, h), d) in found.iter().zip(&hidden).zip(&design) {
        assert!(
            f.1 <= 1.1 * h.1 && f.1 < d.1,
            "{f:?}: the hidden {h:?}, the design {d:?}"
        );
    }
}

/// X's integral action hunts about each stop, a limit cycle whose phase no model times:
/// its fit reaches the noise on every sample, its halves miss each other about tenfold there,
/// and it is judged on the samples while moving. There too they miss each other by more
/// than twice the noise (systematically by √3 times it at least): the record leaves its
/// values loose, and none reads as a measurement, though they predict.
fn assert_hunting_x_is_loose_and_says_so(id: &Identification, template: &MachineConfig) {
    let x = &id.axes[0];
    let moving = x.while_moving.as_ref().unwrap();
    eprintln!("X: whole record {x:?}; noise {:.3} µm", id.noise_um);
    assert!(x.judged_while_moving && x.rms_identified_um < 1.1 * id.noise_um);
    assert!(
        moving.held_out_identified_um > 2.0 * id.noise_um,
        "{moving:?}"
    );
    assert!(!x.reached && x.values.iter().all(|v| !v.measured), "{x:?}");
    // Nor determined: each value fitted is written loose, and says so wherever it is shown
    // (the report's JSON and the machine file's header, which the HTML page's status shares).
    assert!(
        x.values
            .iter()
            .all(|v| !v.determined && (v.loose == v.fitted())),
        "{x:?}"
    );
    let header = id.machine_file(template, "fitted.nc");
    let gain = header
        .lines()
        .find(|l| l.starts_with("#   X.controller.gain ="))
        .unwrap();
    assert!(
        gain.contains("the record's halves leave it loose"),
        "{gain}"
    );
    let json = serde_json::to_value(x).unwrap();
    assert_eq!(json["values"][0]["loose"], true, "{json}");
    assert_eq!(json["values"][0]["determined"], false, "{json}");
}

/// Not measurements, but the machine's values within what the report states of them:
/// each value fitted on X lies within twice its standard uncertainty of the hidden one
/// (a standard uncertainty that holds covers the truth at that width about 19 times in
/// 20; here the gain and the mass land 1.5 of theirs low, along their ratio), and the
/// gain over the whole inertia, which the record determines, within one.
fn assert_loose_x_within_what_is_stated(x: &AxisIdentification, hidden_x: &AxisConfig) {
    for v in x.values.iter().filter(|v| v.fitted()) {
        let what = format!("X: {} (loose)", v.key);
        let want = hidden_value(hidden_x, v.key);
        assert_within_k_sigma(&what, want, v.value, v.uncertainty, 2.0);
    }
    assert!(x.values.iter().filter(|v| v.fitted()).count() >= 4, "{x:?}");
    let ratio = x.gain_per_inertia.as_ref().unwrap();
    let what = format!("X: {} per inertia", ratio.gain);
    let want = gain_per_inertia(hidden_x, ratio.gain);
    assert_within_k_sigma(&what, want, ratio.value, ratio.uncertainty, 1.0);
}

#[test]
fn a_record_without_commands_or_with_a_still_axis_says_what_it_lacks() {
    let template = MachineConfig::default_preset();
    let settings = CompareSettings::for_machine(&template);
    let program = fitted_program();
    let mut no_commands = encoder_record(&program, &template, 83);
    no_commands.commands = None;
    let err = identify(&program, &template, &no_commands, &settings).unwrap_err();
    assert!(matches!(err, IdentifyError::NoCommands { .. }), "{err}");
    assert!(err.to_string().contains("commanded positions"), "{err}");
    // A record of X alone (a reversal test of one axis): X is identified, Y is said to
    // have nothing to identify it from, its template's values written.
    let x_only = program_text("G21 G17 G90 G94\nG0 X0 Y0\nG1 X20 F1000\nX0\nM2\n");
    let id = identify(
        &x_only,
        &template,
        &encoder_record(&x_only, &template, 84),
        &settings,
    )
    .unwrap();
    let (x, y) = (&id.axes[0], &id.axes[1]);
    assert!(
        x.too_little.is_none() && x.values.iter().any(|v| v.fitted()),
        "{x:?}"
    );
    let why = y.too_little.as_deref().unwrap_or_else(|| panic!("{y:?}"));
    assert!(why.contains("commanded to move 0.0 µm"), "{why}");
    assert!(!y.reached && !y.better_than_template, "{y:?}");
    assert_eq!(id.machine.y, template.y);
    // Neither axis moving: nothing to identify.
    let still = program_text("G21 G17 G90 G94\nG0 X0 Y0\nG4 P1\nM2\n");
    let err = identify(
        &still,
        &template,
        &encoder_record(&still, &template, 85),
        &settings,
    )
    .unwrap_err();
    assert!(matches!(err, IdentifyError::StillAxes { .. }), "{err}");
    assert!(err.to_string().contains("moves an axis"), "{err}");
}

/// A template whose controller is not the machine's (full acceleration feed-forward where the
/// machine has none), on a record of the independent integrator: no fit of that structure
/// reaches the noise, so nothing is reported as a measurement; a loop model written in its
/// place (`structure_compared`) describes the loop, not the parts. The machine written is the fit where it
/// predicts the held-out halves better than the template (by a twentieth), its values a
/// model's; otherwise the template's values stay (NOT IDENTIFIED). (One of the binary's
/// longest searches: named to sort first in this file, see `main.rs`.)
#[test]
fn a_controller_unlike_the_templates_measures_nothing() {
    let truth = MachineConfig::from_toml_str(
        "base = \"small-table\"\n[x.controller]\naccel_feedforward = 0.0\n\
         [y.controller]\naccel_feedforward = 0.0\n",
        "truth.toml",
    )
    .unwrap();
    let template = MachineConfig::preset("small-table").unwrap();
    let program = fitted_program();
    let mut settings = CompareSettings::for_machine(&template);
    settings.measured_at = REFERENCE.at;
    let id = identify(
        &program,
        &template,
        &encoder_record(&program, &truth, 95),
        &settings,
    )
    .unwrap();
    // Another program's record, to judge what is written on data it was not fitted on.
    let other = other_program();
    let measured = encoder_record(&other, &truth, 96);
    let found = predicted(&other, &id.machine, &measured, REFERENCE.at);
    let design = predicted(&other, &template, &measured, REFERENCE.at);
    for a in &id.axes {
        // The template's structure cannot reach the noise. Where the loop model fitted from
        // the record alone is written in its place (the structure left more than a tenth of
        // the following error and the loop model predicts better by a quarter), that may:
        // its values describe the loop, and none reads as a measurement either way.
        match &a.structure_compared {
            // What it writes is judged below on another program's record, as any fit is.
            Some(c) if c.written => eprintln!("{}: {c:?}", a.axis),
            _ => {
                assert!(!a.reached, "{a:?}");
                assert!(a.rms_identified_um > 10.0 * id.noise_um, "{a:?}");
            }
        }
        assert!(a.values.iter().all(|v| !v.measured), "{a:?}");
        let written = id.machine.axis(a.axis);
        let (f, d) = (found[a.axis.index()].1, design[a.axis.index()].1);
        eprintln!(
            "{}: another program: written {f:.3} µm, the template {d:.3} µm; {a:?}",
            a.axis
        );
        // What is written — the fit as a model where it predicted its own record's held-out
        // halves better than the template, else the template — predicts another program's
        // record no worse than the template, on both axes. (A held-out figure counts only a
        // half's fit that left where the fit on the whole landed. Y's fit while moving, its
        // table eight times as heavy as the template's, had neither half's search find a
        // step from there: its "held-out" residual, half the template's, was the whole fit's
        // own, and it predicted another program's record a third worse than the template,
        // 1.99 against 1.51 µm; half of X's was the same, 2.40 against 2.46 µm.)
        assert!(f <= d, "{}: {f} µm against the template's {d} µm", a.axis);
        if !a.better_than_template {
            assert!(
                a.values
                    .iter()
                    .all(|v| !v.fitted() && v.value == v.template),
                "{a:?}"
            );
            // The machine's parts are the template's; the interpolator's limits are what the
            // record showed (the reference's trapezoids hold 0.5 m/s² where the template's
            // planner asked for more).
            let kept = template.axis(a.axis);
            assert_eq!(
                (&written.controller, &written.drive, &written.friction),
                (&kept.controller, &kept.drive, &kept.friction)
            );
        }
    }
}

/// Identifies the lead-lag table from `recorder`'s record: the gain and both zeros are
/// determined on X; returns the identification and the hidden machine.
fn lead_lag_identified(recorder: Recorder, seed: u64) -> (Identification, MachineConfig) {
    let (template, truth) = lead_lag_designed_and_run();
    let id = identified_and_predicting(
        &template,
        &truth,
        &[
            "controller.gain",
            "x:controller.zero_1_hz",
            "x:controller.zero_2_hz",
        ],
        seed,
        recorder,
    );
    // The machine written holds the controller found, in the template's structure: the same
    // orders, an integrator still at 0.
    let Controller::TransferFunction(found) = &id.machine.x.controller else {
        panic!("a transfer function");
    };
    assert_eq!(found.denominator[2], 0.0);
    (id, truth)
}

#[test]
fn a_lead_lag_controllers_gain_and_corners_are_identified() {
    let (id, truth) = lead_lag_identified(TOOL, 93);
    let (Controller::TransferFunction(found), Controller::TransferFunction(run)) =
        (&id.machine.x.controller, &truth.x.controller)
    else {
        panic!("a transfer function");
    };
    for (a, b) in found.numerator.iter().zip(&run.numerator) {
        assert!(
            (a / b - 1.0).abs() < 0.05,
            "{:?} against {:?}",
            found.numerator,
            run.numerator
        );
    }
}

#[test]
fn a_lead_lag_table_recorded_by_an_independent_integrator_is_found_from_its_design() {
    // The record's own equation, solved linearly, puts the search next to the controller
    // that ran; from the design's corners alone it stopped at twice the noise. The corners
    // come back within 5 %; the gain and the table's mass trade along the loop's one ratio
    // (the record hardly tells a rotor from a table), which comes back within 5 % while
    // each alone is a model's value.
    let (id, truth) = lead_lag_identified(REFERENCE, 93);
    let x = &id.axes[0];
    assert!(x.reached, "{x:?}");
    for key in [
        "controller.zero_1_hz",
        "controller.zero_2_hz",
        "controller.pole_1_hz",
    ] {
        let v = x.values.iter().find(|v| v.key == key).unwrap();
        let hidden = hidden_value(&truth.x, key);
        assert!(
            v.determined && (v.value / hidden - 1.0).abs() < 0.05,
            "{key}: {v:?}, hidden {hidden}"
        );
    }
    assert!(x.gain_per_inertia.is_some(), "{x:?}");
    let ratio = gain_per_inertia(&id.machine.x, "controller.gain")
        / gain_per_inertia(&truth.x, "controller.gain");
    assert!(
        (ratio - 1.0).abs() < 0.05,
        "gain per inertia {ratio} of the hidden"
    );
}

#[test]
fn a_lead_lag_controller_far_from_its_design_is_found_from_it() {
    // The gain twice the design's, the integrator's zero halved, the lead zero half again
    // higher and its pole 40 % lower, recorded by the independent integrator: the linear
    // first estimate's reach, where the design's corners are no start for a local search.
    let template =
        MachineConfig::from_toml_str(&lead_lag_toml(45.0, 5.0, 12.0, 80.0), "t.toml").unwrap();
    let mut truth =
        MachineConfig::from_toml_str(&lead_lag_toml(75.0, 2.5, 18.0, 50.0), "truth.toml").unwrap();
    truth.x.friction.coulomb_coefficient = 0.08;
    let id = identified_and_predicting(
        &template,
        &truth,
        &[
            "x:controller.gain",
            "x:controller.zero_1_hz",
            "x:controller.zero_2_hz",
            "x:controller.pole_1_hz",
        ],
        72,
        REFERENCE,
    );
    for v in id.axes[0].values.iter().filter(|v| v.key.ends_with("_hz")) {
        let hidden = hidden_value(&truth.x, v.key);
        assert!(
            (v.value / hidden - 1.0).abs() < 0.05,
            "{v:?}, hidden {hidden}"
        );
    }
    // Y ran as designed: its template explains the record to the noise, and values fitted to
    // it predicted the held-out halves worse (0.071 against 0.063 µm): the template stays.
    let y = &id.axes[1];
    assert!(y.template_holds && y.reached, "{y:?}");
    let (found, run) = (&id.machine.y, &truth.y);
    assert_eq!(
        (&found.controller, &found.drive, &found.friction),
        (&run.controller, &run.drive, &run.friction)
    );
}

/// A machine the user has no template for — a lead-lag X and a PID Y on current amplifiers,
/// neither a cascade — recorded by the independent integrator, gets a model of each loop
/// from the record alone: it predicts the halves of
/// the record each fit did not see to within 15 % of their following error, another
/// program's record to within 30 %, and says that it describes the loop rather than the
/// machine's parts; Y's is the integrating lead-lag on current it runs. (One of the binary's longest searches: named to sort second in this
/// file, see `main.rs`.)
#[test]
fn a_controller_with_no_template_gets_a_loop_model_that_predicts_the_machine() {
    let mut truth =
        MachineConfig::from_toml_str(&lead_lag_toml(60.75, 3.5, 14.4, 64.0), "truth.toml").unwrap();
    truth.x.friction.coulomb_coefficient = 0.12;
    truth.y.drive.table_mass_kg = 70.0;
    let program = fitted_program();
    let measured = encoder_record(&program, &truth, 97);
    let start = loop_template(&measured);
    let mut settings = CompareSettings::for_machine(&start);
    settings.measured_at = REFERENCE.at;
    let id = identify_loop(&program, &start, &measured, &settings).unwrap();
    for a in &id.axes {
        eprintln!(
            "{}: held out {:.3} µm of {:.3} µm; {}",
            a.axis, a.held_out_identified_um, a.following_error_rms_um, a.kept
        );
    }
    y_is_the_lead_lag_it_runs(&id.axes[1], &id.machine.y);
    // What is written (as `identify --out` writes it: on no preset) reads back as the
    // model found.
    let text = format!("base = \"none\"\n{}", id.machine.to_toml());
    let back = MachineConfig::from_toml_str(&text, "loop.toml").unwrap();
    assert_eq!((&back.x, &back.y), (&id.machine.x, &id.machine.y));
    for a in &id.axes {
        assert!(a.kept.starts_with("no template"), "{}", a.kept);
        // The table has no force repeating with position: no ball-screw lead is taken for
        // one, and the report says so.
        assert!(
            a.force_ripple
                .as_ref()
                .is_some_and(|r| !r.written && r.statement.starts_with("force ripple: none found")),
            "{}: {:?}",
            a.axis,
            a.force_ripple
        );
        assert_eq!(id.machine.axis(a.axis).errors.force_ripple_n, 0.0);
        assert!(
            a.held_out_identified_um <= 0.15 * a.following_error_rms_um,
            "{}: held out {} µm against a following error of {} µm",
            a.axis,
            a.held_out_identified_um,
            a.following_error_rms_um
        );
    }
    for (axis, residual_um, following_rms_um) in
        predicts_other_program(&truth, &id.machine, 98, REFERENCE)
    {
        // Another program, with other stops and hunting: within 30 % (X measured 25 %).
        assert!(
            residual_um <= 0.3 * following_rms_um,
            "{axis}: residual {} µm against a following error of {following_rms_um} µm",
            residual_um
        );
    }
}

/// Y's PID with its derivative filter, K·(s + ω_z)²/(s·(s + ω_p)), is an integrator cascaded
/// with a lead-lag on a current amplifier: the second family without a template, which holds
/// Y's machine but for the screw's and coupling's compliance (its first mode near 700 Hz,
/// far above the loop's 40 Hz crossover) and the reference's own integration and
/// interpolation. It is kept, and predicts the held-out halves to within 5 % of the
/// following error: the record's noise alone (0.05 µm, and 0.1 µm counts' 0.029 µm) is 1.6 %
/// of Y's 3.6 µm, and the cascade, which lacks the integrating controller's shape, is kept
/// only where it predicts better by a twentieth.
fn y_is_the_lead_lag_it_runs(y: &AxisIdentification, written: &AxisConfig) {
    assert!(y.kept.contains("integrating lead-lag"), "{}", y.kept);
    let Controller::TransferFunction(tf) = &written.controller else {
        panic!("Y written as {:?}", written.controller);
    };
    // An integrator: no constant term in the denominator.
    assert_eq!(tf.denominator.last(), Some(&0.0), "{tf:?}");
    assert!(
        y.held_out_identified_um <= 0.05 * y.following_error_rms_um,
        "held out {} µm against a following error of {} µm",
        y.held_out_identified_um,
        y.following_error_rms_um
    );
}

/// The heavy preset with X's Kv at 0.93, identified from a circle recorded by the
/// independent integrator (its own trapezoids at the preset's 0.5 m/s², read at the scale
/// at 1 kHz), predicts the contour error of a 100 mm square at F3000 — moves that ask far
/// more of the interpolator than the circle did — within a tenth of what the machine itself
/// gives: the circle's peaks are not written as the machine's limits.
#[test]
fn limits_a_circle_never_reached_stay_the_templates_and_a_square_is_predicted() {
    let mut truth = MachineConfig::default_preset();
    truth.x.position_loop.kv_m_per_min_per_mm = 0.93;
    let template = MachineConfig::default_preset();
    let circle = program_text("G21 G17 G90 G94\nG0 X5 Y0\nG3 X5 Y0 I-5 J0 F1000\nM2\n");
    let rec = Recording {
        sample_s: 1e-3,
        noise_m: 0.05e-6,
        count_m: 0.1e-6,
        step_s: 1e-5,
        seed: 61,
        accel: 0.5,
        tight_spot_x: None,
        at_feedback: true,
        ..Recording::default()
    };
    let csv = reference::record(&circle, &truth.x, &truth.y, &rec);
    let measured = parse_trace(&csv, "circle.csv").unwrap();
    let mut settings = CompareSettings::for_machine(&template);
    settings.measured_at = REFERENCE_AT_SCALE.at;
    let id = identify(&circle, &template, &measured, &settings).unwrap();
    for axis in AxisName::BOTH {
        let (written, hidden) = (&id.machine.axis(axis).limits, &truth.axis(axis).limits);
        assert_eq!(
            written.max_jerk_m_per_s3, hidden.max_jerk_m_per_s3,
            "{axis}"
        );
        assert_eq!(
            written.max_accel_m_per_s2, hidden.max_accel_m_per_s2,
            "{axis}"
        );
    }
    let square = program_text("G21 G17 G90 G94\nG0 X0 Y0\nG1 X100 F3000\nY100\nX0\nY0\nM2\n");
    identifying::predicts_contour_within_a_tenth(&square, &id.machine, &truth);
}
