//! The limits `identify` writes without a template (`--template none`), read from a record
//! of the independent reference (`common::reference`: its own integrator and a jerk-limited
//! interpolator, neither the tool's simulator nor its planner) on the heavy preset.
//!
//! The no-template model starts from a small table's limits (3 m/s², 100 m/s³, feeds to
//! 5000 mm/min, ±150 mm of travel); the record's own commands must replace what they
//! disprove or show held, so that the written machine plans other programs as the
//! machine runs them.

use crate::common;

use common::reference::{Recording, record};
use common::{identifying, program_text};
use contourcheck::check::{CheckSettings, check};
use contourcheck::compare::CompareSettings;
use contourcheck::identify::{identify, identify_loop, loop_template};
use contourcheck::machine::{AxisName, MachineConfig};
use contourcheck::sim::MeasuredAt;
use contourcheck::trace::measured::parse_trace;

/// The interpolator's jerk and acceleration in the record (the heavy preset's own).
const JERK: f64 = 5.0;
const ACCEL: f64 = 0.5;
/// The fast moves' feed (mm/min): beyond the no-template model's 5000.
const FAST: f64 = 6000.0;

/// A 10 mm square at F1000, then a line out to X180 and back at F6000.
///
/// At F1000 (16.7 mm/s) each start and stop ramps the acceleration at 5 m/s³ to
/// √(v·jerk) = 0.289 m/s² and back: the jerk held for 58 ms four times a move, where the
/// no-template planner asks 100 m/s³. Each ramp to speed takes 2·√(v/jerk) = 0.115 s and
/// v·0.115 s / 2 = 0.96 mm: a 10 mm side reaches the feed and holds it for 8 mm, as a longer
/// one would (the fit re-simulates the whole record: a side three times as long held the
/// feed for 28 mm against 8, 3.5 times the time). At F6000 (100 mm/s) √(v·jerk) = 0.71 m/s²
/// exceeds 0.5: the acceleration is held at 0.5 for v/a − a/j = 0.1 s in each of the four ramps,
/// where the no-template planner asks more; and X reaches 180 mm, beyond ±150 mm.
const RECORDED: &str = "G21 G17 G90 G94\nG0 X0 Y0\nG1 X10 F1000\nY10\nX0\nY0\n\
                        G1 X180 F6000\nG1 X0\nM2\n";

/// The same square alone: the program predicted.
const SQUARE: &str = "G21 G17 G90 G94\nG0 X0 Y0\nG1 X10 F1000\nY10\nX0\nY0\nM2\n";

#[test]
fn without_a_template_the_records_jerk_accel_feed_and_travel_are_written() {
    let truth = MachineConfig::default_preset();
    let program = program_text(RECORDED);
    let rec = Recording {
        sample_s: 2e-3,
        accel: ACCEL,
        jerk: Some(JERK),
        step_s: 1e-5,
        ..Recording::default()
    };
    let csv = record(&program, &truth.x, &truth.y, &rec);
    let measured = parse_trace(&csv, "s-curves.csv").unwrap();
    let start = loop_template(&measured);
    let mut settings = CompareSettings::for_machine(&start);
    settings.measured_at = MeasuredAt::Table;
    // X reaches 180 mm: no travel of the model's own refuses the record.
    let id = identify_loop(&program, &start, &measured, &settings).unwrap();
    let i = &id.interpolator;
    for (k, axis) in AxisName::BOTH.into_iter().enumerate() {
        let limits = &id.machine.axis(axis).limits;
        assert_eq!(limits.travel_mm, None, "{axis}");
        // The record's jerk, held below the planner's 100 m/s³, is the limit written. The
        // commands are written to 0.1 nm (±0.05 nm of rounding) every 2 ms: their second
        // difference is off by at most 4 · 0.05 nm / (2 ms)² = 5e-5 m/s², the jerk (its
        // change over two samples) by at most 2 · 5e-5 / 4 ms = 0.025 m/s³; the file rounds
        // up to three digits: 0.01 more.
        let read_within = 0.025;
        assert!(i.jerk_limited[k], "{axis}: {i:?}");
        assert!(
            (i.jerk_m_per_s3[k] - JERK).abs() <= read_within,
            "{axis}: {i:?}"
        );
        let written = limits.max_jerk_m_per_s3;
        assert!(
            written >= JERK - read_within && written <= JERK + read_within + 0.01,
            "{axis}: jerk written {written} m/s³: {i:?}"
        );
    }
    // X's fast moves hold 0.5 m/s² and run at 6000 mm/min: both written, the feed at
    // least the record's (the template's 5000 it disproves).
    let x = &id.machine.x.limits;
    assert!(i.accel_limited[0], "{i:?}");
    assert!((x.max_accel_m_per_s2 - ACCEL).abs() <= 0.01, "{x:?}");
    assert!(
        x.max_feed_mm_per_min >= 0.995 * FAST && x.rapid_mm_per_min >= x.max_feed_mm_per_min,
        "{x:?}: {i:?}"
    );
    // The square planned by the written machine: within a tenth of the machine's own
    // contour error.
    let square = program_text(SQUARE);
    identifying::predicts_contour_within_a_tenth(&square, &id.machine, &truth);
}

/// The small circle of the samples (R10 at F800, once each way) on the heavy preset with X's
/// Kv at 1.2 m/min/mm instead of 1.0, recorded by the independent reference at 2 ms with its
/// commands and 0.05 µm of noise, identified from the preset.
///
/// The circle never asks for more than its radius needs: X's centripetal peak is
/// v²/r = (13.3 mm/s)²/10 mm = 0.018 m/s², its jerk v³/r² = 0.024 m/s³, far below the
/// preset's 0.5 m/s² and 5 m/s³; the moves out of the circle (the rapid to its start) lie
/// outside the stretch compared. No limit may come out below the preset's: written, it would
/// slow the next program. And at steady feed the following error of a proportional position
/// loop is v/Kv = 13.3 mm/s / 20 s⁻¹ = 0.667 mm: the written machine's largest while cutting
/// within 1 % of the machine's is Kv within 1 % (0.012 m/min/mm), its feed not capped.
#[test]
fn a_circle_at_one_feed_writes_its_gain_and_no_limit_below_the_templates() {
    let template = MachineConfig::default_preset();
    let mut truth = template.clone();
    truth.x.position_loop.kv_m_per_min_per_mm = 1.2;
    let program = common::sample_program("small-circle.nc");
    let rec = Recording {
        sample_s: 2e-3,
        noise_m: 0.05e-6,
        step_s: 1e-5,
        seed: 38,
        ..Recording::default()
    };
    let csv = record(&program, &truth.x, &truth.y, &rec);
    let measured = parse_trace(&csv, "small-circle.csv").unwrap();
    let mut settings = CompareSettings::for_machine(&template);
    settings.measured_at = MeasuredAt::Table;
    let id = identify(&program, &template, &measured, &settings).unwrap();
    let kv = id.axes[0]
        .values
        .iter()
        .find(|v| v.key == "position_loop.kv_m_per_min_per_mm")
        .expect("X's Kv fitted");
    assert!(kv.determined, "{kv:?}");
    common::assert_within_k_sigma("X Kv", 1.2, kv.value, kv.uncertainty, 3.0);
    let i = &id.interpolator;
    for axis in AxisName::BOTH {
        let (written, preset) = (&id.machine.axis(axis).limits, &template.axis(axis).limits);
        let pairs = [
            (
                "acceleration",
                written.max_accel_m_per_s2,
                preset.max_accel_m_per_s2,
            ),
            ("jerk", written.max_jerk_m_per_s3, preset.max_jerk_m_per_s3),
            (
                "feed",
                written.max_feed_mm_per_min,
                preset.max_feed_mm_per_min,
            ),
            ("rapid", written.rapid_mm_per_min, preset.rapid_mm_per_min),
        ];
        for (what, w, p) in pairs {
            assert!(
                w >= p,
                "{axis} {what}: written {w}, the preset's {p}: {i:?}"
            );
        }
    }
    let fe_um = |machine: &MachineConfig| {
        let run = check(&program, machine, &CheckSettings::for_machine(machine)).unwrap();
        run.result.summary.max_following_error_cutting_m[0] * 1e6
    };
    let (predicted, actual) = (fe_um(&id.machine), fe_um(&truth));
    assert!(
        (predicted - actual).abs() <= 0.01 * actual,
        "X following error while cutting: written machine {predicted:.1} µm, the machine {actual:.1} µm"
    );
}

/// Two long lines at F480 (8 mm/s) on the heavy preset, recorded by the independent
/// reference at 2 ms behind its interpolator holding a jerk of 20 m/s³, identified from
/// the preset with its jerk limit raised to 100 m/s³ (a template that allows more than
/// the machine gave).
///
/// Each start and stop ramps the acceleration at the jerk to √(v·j) = 0.4 m/s² (below the
/// 0.5 m/s² limit) and back, each ramp √(v/j) = 20 ms long: 80 ms a move, against 20 s of
/// constant feed along 160 mm — 0.4 % of the samples, fewer than the top half per cent of
/// them. The jerk is still held in eight stretches where the template's planner asked
/// more: it is the limit written.
#[test]
fn a_jerk_held_in_short_phases_of_long_moves_at_constant_feed_is_the_limit() {
    let jerk = 20.0;
    let truth = MachineConfig::default_preset();
    let mut template = truth.clone();
    for axis in AxisName::BOTH {
        template.axis_mut(axis).limits.max_jerk_m_per_s3 = 100.0;
    }
    let program = program_text("G21 G17 G90 G94\nG0 X0 Y0\nG1 X160 F480\nG1 X0\nM2\n");
    let rec = Recording {
        sample_s: 2e-3,
        noise_m: 0.05e-6,
        accel: ACCEL,
        jerk: Some(jerk),
        step_s: 1e-5,
        seed: 39,
        ..Recording::default()
    };
    let csv = record(&program, &truth.x, &truth.y, &rec);
    let measured = parse_trace(&csv, "long-lines.csv").unwrap();
    let mut settings = CompareSettings::for_machine(&template);
    settings.measured_at = MeasuredAt::Table;
    let id = identify(&program, &template, &measured, &settings).unwrap();
    let i = &id.interpolator;
    // As in the square's record above: commands to 0.1 nm every 2 ms read the jerk within
    // 0.025 m/s³; the file rounds up to three digits (0.1 at 20 m/s³).
    let read_within = 0.025;
    assert!(i.jerk_limited[0], "{i:?}");
    assert!((i.jerk_m_per_s3[0] - jerk).abs() <= read_within, "{i:?}");
    let written = id.machine.x.limits.max_jerk_m_per_s3;
    assert!(
        written >= jerk - read_within && written <= jerk + read_within + 0.1,
        "X: jerk written {written} m/s³: {i:?}"
    );
}
