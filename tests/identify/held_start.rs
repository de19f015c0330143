//! The force an axis holds at rest at a record's start (docs/model.md §1.10), estimated with
//! the machine's values fixed: records of the lead-lag table made by the independent
//! integrator, X's integrator standing at the start with a known force or with none.

use crate::common;

use common::identifying::{encoder_recording, fitted_program, reference_trace};
use common::reference::Recording;
use contourcheck::compare::{CompareSettings, Comparison, HeldAtStart, Stepping, compare};
use contourcheck::machine::{AxisName, MachineConfig};
use contourcheck::sim::{AxisModel, MeasuredAt};

/// The lead-lag table as it ran, recorded at its motor encoders (10 kHz, 0.1 µm counts)
/// with X holding `held_n` (N) at its start; the force estimated on the whole record with
/// the machine's values given.
fn estimated(machine: &MachineConfig, held_n: f64) -> HeldAtStart {
    let program = fitted_program();
    let rec = Recording {
        held_x_n: held_n,
        ..encoder_recording(7)
    };
    let measured = reference_trace(&program, machine, &rec);
    let mut settings = CompareSettings::for_machine(machine);
    settings.measured_at = MeasuredAt::Motor;
    let Comparison { ctx, offset_s, .. } =
        compare(&program, machine, &measured, &settings, Stepping::Full).unwrap();
    ctx.held_at_start(machine, AxisName::X, offset_s, &|_| true)
        .expect("a record that starts at rest")
}

/// X holding 0.6 of its friction's level at rest towards −, and the same run holding none
/// (the same noise). What the tool's integration and the reference's differ by (the
/// commands a cycle apart against a continuous interpolator) pulls both estimates alike:
/// their difference is the force held, within the two estimates' uncertainties; the one of
/// the record holding nothing lies within a fiftieth of the level of zero — nothing a model
/// of the machine would carry — and an estimate is determined to a tenth of the level.
#[test]
fn a_force_held_at_the_start_is_recovered_and_none_is_found_where_none_is_held() {
    let (_, truth) = common::identifying::lead_lag_designed_and_run();
    let level = AxisModel::from_config(&truth.x).f_s;
    let held = -0.6 * level;
    let found = estimated(&truth, held);
    let none = estimated(&truth, 0.0);
    assert_eq!(found.level_n, level);
    let both = found.uncertainty_n.hypot(none.uncertainty_n);
    assert!(
        (found.force_n - none.force_n - held).abs() < 3.0 * both,
        "{found:?} and {none:?} against {held} N"
    );
    assert!(none.force_n.abs() < 0.02 * level, "{none:?}");
    for e in [found, none] {
        assert!(e.uncertainty_n < 0.1 * level, "{e:?}: determined");
    }
}
