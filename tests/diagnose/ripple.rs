//! `diagnose`'s force ripple against records of the independent integrator of
//! `common::reference`, which pushes the table with its own ripple: the nominal machine,
//! its file naming no ripple period (the search chooses one of those the drive gives: a
//! motor turn's 4 mm travel and its harmonics, the screw's 16 mm lead and its harmonics).
//!
//! A ripple of known amplitude and phase on X is named, its values within their stated
//! uncertainties and its period the one the record was made with, said to be chosen (or the
//! machine file's, where the file names it); a record without one names none, and an axis
//! whose travel spans none of the drive's periods three times is not tried for one; a
//! record whose positions read carry a cyclic error at the period the machine file gives
//! the ripple names no ripple.

use crate::common;

use common::reference::{Cycle, Recording, record};
use common::{assert_within_k_sigma, program_text};
use contourcheck::diagnose::causes::CauseId;
use contourcheck::diagnose::report::DiagnoseReport;
use contourcheck::diagnose::ripple::PeriodSource;
use contourcheck::diagnose::{DiagnoseSettings, Diagnosis, FoundCause, diagnose};
use contourcheck::gcode::Program;
use contourcheck::machine::{AxisName, MachineConfig};
use contourcheck::trace::measured::{MeasuredTrace, parse_trace};

/// A motor turn's travel on the nominal machine's X (mm): the screw's lead through the
/// gear, 16 mm × 0.25 = 4 mm.
fn turn_mm() -> f64 {
    let x = MachineConfig::default_preset().x;
    x.drive.lead_mm * x.drive.gear_ratio
}

/// Along X and back at two feeds (a 4 mm ripple at 4.2 and 8.3 Hz), then `y_mm` along Y.
fn two_feeds_then_y(y_mm: f64) -> Program {
    program_text(&format!(
        "G21 G17 G90 G94\nG0 X0 Y0\nG1 X60 F1000\nX0 F2000\nY{y_mm} F1000\nM2\n"
    ))
}

fn two_feeds() -> Program {
    two_feeds_then_y(20.0)
}

/// The nominal machine with `ripple_x` (N, period mm, °) pushing X's table.
fn truth(ripple_x: Option<(f64, f64, f64)>) -> MachineConfig {
    let mut m = MachineConfig::default_preset();
    if let Some((amplitude, period_mm, phase_deg)) = ripple_x {
        let e = &mut m.x.errors;
        (e.force_ripple_n, e.force_ripple_period_mm) = (amplitude, period_mm);
        e.force_ripple_phase_deg = phase_deg;
    }
    m
}

/// The reference's record of `program` on `truth` (1 kHz, 0.3 µm noise), diagnosed
/// against `nominal`.
fn diagnosed(
    program: &Program,
    truth: &MachineConfig,
    nominal: &MachineConfig,
    rec: &Recording,
) -> Diagnosis {
    diagnosed_with_record(program, truth, nominal, rec).0
}

/// As [`diagnosed`], with the record read.
fn diagnosed_with_record(
    program: &Program,
    truth: &MachineConfig,
    nominal: &MachineConfig,
    rec: &Recording,
) -> (Diagnosis, MeasuredTrace) {
    let csv = record(program, &truth.x, &truth.y, rec);
    let measured = parse_trace(&csv, "reference.csv").unwrap();
    let settings = DiagnoseSettings::for_machine(nominal);
    let d = diagnose(program, nominal, &measured, &settings).unwrap();
    for c in &d.causes {
        eprintln!("named {:?} on {}: {:?}", c.id, c.axis, c.params);
    }
    for c in &d.candidates {
        eprintln!(
            "candidate {:?} on {}: evidence {:.1}",
            c.id, c.axis, c.evidence
        );
    }
    for r in &d.rejected {
        eprintln!(
            "rejected {:?} on {}: {} {:?}",
            r.id, r.axis, r.reason, r.params
        );
    }
    for l in &d.learned {
        eprintln!("learned {l:?}");
    }
    (d, measured)
}

/// The ripple every test of a known ripple hides: 5 kN at 40°, once a motor turn — about
/// 2 % of the 220 kN the drive can push (60 A through 2.34 N·m/A at 4 mm a turn), a torque
/// ripple of the size servo motors have.
/// The force ripple `d` names; the test fails with what was rejected where it names none.
fn named_ripple(d: &Diagnosis) -> &FoundCause {
    d.causes
        .iter()
        .find(|c| c.id == CauseId::ForceRipple)
        .unwrap_or_else(|| panic!("no ripple named: {:#?}", d.rejected))
}

fn known() -> (f64, f64, f64) {
    (5000.0, turn_mm(), 40.0)
}

#[test]
fn a_ripple_of_known_amplitude_and_phase_is_named_with_its_values() {
    let nominal = MachineConfig::default_preset();
    let (d, measured) = diagnosed_with_record(
        &two_feeds(),
        &truth(Some(known())),
        &nominal,
        &Recording::default(),
    );
    let found = named_ripple(&d);
    assert_eq!(found.axis, AxisName::X);
    let (amplitude, period_mm, phase_deg) = known();
    let [a, phase] = [0, 1].map(|i| &found.params[i]);
    assert_eq!(a.key, "errors.force_ripple_n");
    assert_eq!(phase.key, "errors.force_ripple_phase_deg");
    assert_within_k_sigma("amplitude (N)", amplitude, a.value, a.uncertainty, 3.0);
    // The phase is known modulo a turn.
    let off = (phase.value - phase_deg + 180.0).rem_euclid(360.0) - 180.0;
    assert_within_k_sigma(
        "phase (°)",
        phase_deg,
        phase_deg + off,
        phase.uncertainty,
        3.0,
    );
    // A phase known only to tens of degrees would pass any kσ test.
    assert!(phase.uncertainty < 10.0, "{phase:?}");
    // The machine written carries the period the search chose: the motor turn's.
    let written = &d.machine.x.errors;
    assert!(
        (written.force_ripple_period_mm - period_mm).abs() < 1e-9,
        "{written:?}"
    );
    // Y, which has none, carries no ripple nor a period chosen for one.
    assert_eq!(d.machine.y.errors.force_ripple_n, 0.0);
    assert_eq!(d.machine.y.errors.force_ripple_period_mm, 0.0);
    assert!(d.after.x.rms_um <= 1.2 * d.noise_floor_um, "{:?}", d.after);
    // The period is stated with the cause, and that it was chosen, among the drive's
    // periods X's 60 mm spans three times: a turn's 4 mm and the screw's 16 mm lead, each
    // over 1 to 4 (16 / 4 is the turn again) — all seven.
    let p = &found.period;
    assert_eq!(p.period_source, Some(PeriodSource::Chosen), "{p:?}");
    assert!((p.period_mm.unwrap() - period_mm).abs() < 1e-9, "{p:?}");
    let lead_mm = nominal.x.drive.lead_mm;
    let mut among: Vec<f64> = [period_mm, lead_mm]
        .iter()
        .flat_map(|t| [1.0, 2.0, 3.0, 4.0].map(|h| t / h))
        .collect();
    among.sort_by(f64::total_cmp);
    among.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
    let mut listed = p.period_chosen_among_mm.clone();
    listed.sort_by(f64::total_cmp);
    assert_eq!(listed.len(), among.len(), "{listed:?} against {among:?}");
    assert!(listed.iter().zip(&among).all(|(a, b)| (a - b).abs() < 1e-9));
    // In the JSON and on the cause's line of the report.
    let report = DiagnoseReport::new(&d, "two_feeds.nc", &measured, &nominal);
    let json = serde_json::to_value(&report).unwrap();
    let k = d
        .causes
        .iter()
        .position(|c| c.id == CauseId::ForceRipple)
        .unwrap();
    let cause = &json["causes"][k];
    assert!(
        (cause["period_mm"].as_f64().unwrap() - period_mm).abs() < 1e-9,
        "{cause}"
    );
    assert_eq!(cause["period_source"], "chosen");
    let text = report.to_string();
    let line = text
        .lines()
        .find(|l| l.contains("force_ripple on X:"))
        .unwrap_or_else(|| panic!("{text}"));
    assert!(
        line.contains(&format!("at a period of {period_mm:.4} mm (chosen among")),
        "{line}"
    );
}

#[test]
fn a_ripple_at_the_period_the_machine_file_names_says_so() {
    let mut nominal = MachineConfig::default_preset();
    nominal.x.errors.force_ripple_period_mm = turn_mm();
    let d = diagnosed(
        &two_feeds(),
        &truth(Some(known())),
        &nominal,
        &Recording::default(),
    );
    let found = named_ripple(&d);
    let p = &found.period;
    assert_eq!(p.period_source, Some(PeriodSource::MachineFile), "{p:?}");
    assert_eq!(p.period_mm, Some(turn_mm()));
    assert!(p.period_chosen_among_mm.is_empty(), "{p:?}");
}

#[test]
fn a_record_without_a_ripple_names_none_and_writes_no_period() {
    // Y travels 2 mm: less than three times the shortest period the drive gives (a turn's
    // 4 mm over 4 = 1 mm), so no ripple on Y is tried and the report says why.
    let nominal = MachineConfig::default_preset();
    let program = two_feeds_then_y(2.0);
    let d = diagnosed(&program, &truth(None), &nominal, &Recording::default());
    assert!(
        d.causes.iter().all(|c| c.id != CauseId::ForceRipple),
        "{:?}",
        d.causes
    );
    for a in [&d.machine.x, &d.machine.y] {
        assert_eq!(a.errors.force_ripple_n, 0.0);
        assert_eq!(a.errors.force_ripple_period_mm, 0.0);
    }
    let not_tried = d
        .skipped
        .iter()
        .find(|s| s.id == CauseId::ForceRipple)
        .unwrap_or_else(|| panic!("{:#?}", d.skipped));
    assert_eq!(not_tried.axes, [AxisName::Y], "{not_tried:?}");
    assert!(not_tried.reason.contains("fits 3 times"), "{not_tried:?}");
    let ripples_on = |a| {
        d.candidates
            .iter()
            .any(|c| c.id == CauseId::ForceRipple && c.axis == a)
    };
    assert!(!ripples_on(AxisName::Y), "{:?}", d.candidates);
}

#[test]
fn a_cyclic_error_of_the_positions_read_at_the_ripples_period_is_not_named_a_ripple() {
    // The machine file puts the ripple at the positions' cyclic period: a motor turn's. The
    // record holds no force ripple, but the scale the control reads X by reads 2 µm too far
    // at 4 mm of period, and the record is what the control read.
    let mut nominal = MachineConfig::default_preset();
    nominal.x.errors.force_ripple_period_mm = turn_mm();
    nominal.x.errors.cyclic_period_mm = turn_mm();
    let rec = Recording {
        encoder_error_x: Cycle {
            amplitude: 2e-6,
            period_m: turn_mm() * 1e-3,
            phase_rad: 0.7,
        },
        at_feedback: true,
        ..Recording::default()
    };
    let d = diagnosed(&two_feeds(), &truth(None), &nominal, &rec);
    let named: Vec<CauseId> = d.causes.iter().map(|c| c.id).collect();
    assert!(!named.contains(&CauseId::ForceRipple), "{named:?}");
    assert_eq!(d.machine.x.errors.force_ripple_n, 0.0);
    // The ripple explains this record well (a sine of the period the file gives), so it is
    // weighed, and it is said why it is not named: the read error explains it as well.
    let r = d
        .rejected
        .iter()
        .find(|r| r.id == CauseId::ForceRipple)
        .expect("the force ripple is weighed and rejected with its reason");
    assert!(r.reason.starts_with("cannot tell"), "{}", r.reason);
}

/// `synth` hides a force ripple on a machine whose file names no period at a motor turn's
/// travel (16 mm lead × 0.25 gear = 4 mm), and the record holds it: X moves away from the
/// nominal machine's record, Y (no ripple) does not.
#[test]
fn synth_hides_a_ripple_at_a_motor_turn_where_the_file_names_no_period() {
    use contourcheck::diagnose::synth::{SynthSpec, synthesize};
    let nominal = MachineConfig::default_preset();
    assert_eq!(nominal.x.errors.force_ripple_period_mm, 0.0);
    let quiet = SynthSpec {
        noise_m: 0.0,
        ..SynthSpec::default()
    };
    let hidden = SynthSpec {
        effect: Some((CauseId::ForceRipple, AxisName::X, vec![2000.0, 30.0])),
        ..quiet.clone()
    };
    let plain = synthesize(&two_feeds(), &nominal, &quiet).unwrap();
    let rippled = synthesize(&two_feeds(), &nominal, &hidden).unwrap();
    assert_eq!(rippled.machine.x.errors.force_ripple_period_mm, turn_mm());
    let largest = |col: usize| {
        plain
            .rows
            .iter()
            .zip(&rippled.rows)
            .map(|(a, b)| (a[col] - b[col]).abs())
            .fold(0.0f64, f64::max)
    };
    // A 2 kN ripple on the nominal X moves it by micrometres; Y is the same run.
    assert!(largest(1) > 0.5e-6, "X moved {} m", largest(1));
    assert_eq!(largest(2), 0.0);
}
