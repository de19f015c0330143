//! The force an axis holds at rest at a record's start (docs/model.md §1.10), estimated with
//! the machine's values fixed, and fitted by `identify` beside them: records of the lead-lag
//! table made by the independent integrator, X's integrator standing at the start with a
//! known force or with none.

use crate::common;

use common::identifying::{
    encoder_recording, file_gives_what_is_said, fitted_program, gain_per_inertia, hidden_value,
    reference_trace,
};
use common::reference::Recording;
use contourcheck::compare::{CompareSettings, Comparison, HeldAtStart, Stepping, compare};
use contourcheck::identify::{Identification, identify};
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

/// The lead-lag table as it ran, recorded at its motors with X holding 0.6 of its friction's
/// level at rest towards − (−18.4 N), identified from its design. Fitted holding nothing,
/// X's values bend to the start (the fit on every sample stays at 0.46 µm held out, eight
/// times the noise); fitted again with the force beside them, they reach the record's noise:
/// the force is kept, within two uncertainties of the force held, and the values the file
/// holds come back to the run's — each within twice its uncertainty (Coulomb friction
/// 22.3 ± 2.0 N of 23.5, the controller's corners within a few percent), the gain and the
/// table's mass, which trade, as their ratio — while the file holds no force at the start.
///
/// Not on every record of this table: of five noise seeds tried, three keep the force
/// (seed 3 at −14.8 ± 2.3 N, 11 at −16.3 ± 2.5 N, this one's 13 at −17.3 ± 2.8 N: within two
/// uncertainties of the force held, which is what is asserted); on the other two the fit away
/// from the standstills, its values bent, reaches the noise first (seed 7: Coulomb friction
/// 36 of 23.5 N) or is written without the force, which its refit from either start does not
/// better by a twentieth there (seed 5), and the force is not tried or not kept
/// (docs/identify.md).
#[test]
fn identification_keeps_the_force_held_at_the_start_and_writes_none() {
    let (template, truth) = common::identifying::lead_lag_designed_and_run();
    let level = AxisModel::from_config(&truth.x).f_s;
    let held = -0.6 * level;
    let id = identified_holding(&template, &truth, held, 13);
    let x = &id.axes[0];
    let h = x.held_at_start.expect("the force tried on X");
    assert!(h.kept && h.determined && !h.at_level, "{h:?}");
    assert!(
        (h.force_n - held).abs() <= 2.0 * h.uncertainty_n && h.uncertainty_n < 0.25 * held.abs(),
        "{h:?} against {held} N"
    );
    assert_eq!(id.machine.x.held_at_start_n, 0.0);
    // Every value the file holds within twice its uncertainty of the run's — but the gain and
    // the table's mass, which trade along their ratio: that ratio instead.
    for v in x.values.iter().filter(|v| v.fitted()) {
        if v.key == "controller.gain" || v.key == "drive.table_mass_kg" {
            continue;
        }
        let run = hidden_value(&truth.x, v.key);
        assert!(
            (v.value - run).abs() <= 2.0 * v.uncertainty,
            "{v:?} against {run}"
        );
    }
    let ratio = x
        .gain_per_inertia
        .as_ref()
        .expect("a current-commanding controller");
    let run = gain_per_inertia(&truth.x, ratio.gain);
    assert!(
        (ratio.value - run).abs() <= 2.0 * ratio.uncertainty,
        "{ratio:?} against {run}"
    );
    // The fit's residual holds the force; the file does not, and without it X's values
    // leave the start's transient (the fit holding nothing stayed at eight times the noise):
    // the report states what the file gives, and the file, run as `diagnose` runs it, gives
    // that.
    let said_um = x
        .file_rms_um
        .expect("the file's figure said beside the fit's");
    assert!(said_um > 1.05 * x.rms_identified_um, "{x:?}");
    let program = fitted_program();
    let rec = Recording {
        held_x_n: held,
        ..encoder_recording(13)
    };
    let measured = reference_trace(&program, &truth, &rec);
    file_gives_what_is_said(&id, &template, &program, &measured, MeasuredAt::Motor);
}

/// The lead-lag table as it ran with X holding `held_n` (N) at its start, recorded at its
/// motors with the noise of `seed`, identified from `template`.
fn identified_holding(
    template: &MachineConfig,
    truth: &MachineConfig,
    held_n: f64,
    seed: u64,
) -> Identification {
    let program = fitted_program();
    let rec = Recording {
        held_x_n: held_n,
        ..encoder_recording(seed)
    };
    let measured = reference_trace(&program, truth, &rec);
    let mut settings = CompareSettings::for_machine(template);
    settings.measured_at = MeasuredAt::Motor;
    identify(&program, template, &measured, &settings).unwrap()
}

/// The same run on the noise of seed 7, where X's fit away from the standstills reaches the
/// record's noise holding no force, its values bent to the start's (without the force there,
/// its Coulomb friction came out at 36.3 ± 6.2 N of the run's 23.5, called measured). Fitted
/// again with the force beside them, the values move: the record cannot tell the bend from
/// the force, and no value it moves may be called a measurement. Whatever is said measured
/// lies within two of its uncertainties of the run's, the gain and the table's mass too; the
/// Coulomb force is traded with the force held, its uncertainty widened to cover the run's.
#[test]
fn a_fit_that_bends_to_a_held_force_reports_nothing_it_bends_as_measured() {
    let (template, truth) = common::identifying::lead_lag_designed_and_run();
    let level = AxisModel::from_config(&truth.x).f_s;
    let id = identified_holding(&template, &truth, -0.6 * level, 7);
    let x = &id.axes[0];
    for v in x.values.iter().filter(|v| v.measured) {
        let run = hidden_value(&truth.x, v.key);
        assert!(
            (v.value - run).abs() <= 2.0 * v.uncertainty,
            "{v:?} against {run}: said measured"
        );
    }
    // The force that takes the bend's place is reported beside the values it moves — Coulomb's
    // among them, which no longer reads as the machine's — never kept nor written.
    let h = x.held_at_start.expect("the force tried on X");
    assert!(!h.told_apart_from_values && !h.kept, "{h:?}");
    let coulomb = x.values.iter().find(|v| v.key == "friction.coulomb_n");
    let coulomb = coulomb.expect("Coulomb's force fitted");
    assert_eq!(coulomb.traded_with, Some("held_at_start_n"), "{coulomb:?}");
    let run = hidden_value(&truth.x, coulomb.key);
    assert!(
        (coulomb.value - run).abs() <= 2.0 * coulomb.uncertainty,
        "{coulomb:?} against {run}"
    );
    assert_eq!(id.machine.x.held_at_start_n, 0.0);
}

/// The same run holding no force at its start (seed 13's noise): X's fit reaches the record's
/// noise and is asked, as every fit at the noise is, whether a force held at the start could
/// take its values' place. None is held, so what the refit with the force moves them by is the
/// noise's alone, which the criterion passes about once in twenty for the values most tied to
/// the force: none is traded with the force, no force is reported that the record does not
/// hold, and every value said measured lies within two of its uncertainties of the run's.
///
/// The record leaves the lead's pole loose here (the run's 64 Hz, the design's 80): put back to
/// the design's, it takes the values it trades with along — the upper zero lands near 16 Hz
/// where the run has 14.4 and the fit with the pole free had it —, and those are not called
/// measured: fitted about a template's value, not the machine's.
#[test]
fn a_record_holding_no_force_keeps_its_measured_values() {
    let (template, truth) = common::identifying::lead_lag_designed_and_run();
    let id = identified_holding(&template, &truth, 0.0, 13);
    let x = &id.axes[0];
    assert!(x.reached, "{x:?}");
    for v in x.values.iter().filter(|v| v.fitted()) {
        assert_ne!(v.traded_with, Some("held_at_start_n"), "{v:?}");
    }
    let measured: Vec<_> = x.values.iter().filter(|v| v.measured).collect();
    assert!(!measured.is_empty(), "{x:?}");
    for v in measured {
        let run = hidden_value(&truth.x, v.key);
        assert!(
            (v.value - run).abs() <= 2.0 * v.uncertainty,
            "{v:?} against {run}: said measured"
        );
    }
    let value = |key: &str| x.values.iter().find(|v| v.key == key).expect(key);
    let pole = value("controller.pole_1_hz");
    assert!(!pole.determined && pole.value == pole.template, "{pole:?}");
    // The values the pole's put-back moved: traded with it, their uncertainty widened to the
    // move, which brings the run's within two of it.
    for key in ["controller.zero_2_hz", "friction.coulomb_n"] {
        let v = value(key);
        assert_eq!(v.traded_with, Some("controller.pole_1_hz"), "{v:?}");
        let run = hidden_value(&truth.x, key);
        assert!(
            (v.value - run).abs() <= 2.0 * v.uncertainty,
            "{v:?} against {run}"
        );
    }
    if let Some(h) = &x.held_at_start {
        assert!(h.told_apart_from_values && !h.kept, "{h:?}");
    }
    assert_eq!(id.machine.x.held_at_start_n, 0.0);
}
