//! The second family a machine without a template is fitted as — an integrating lead-lag
//! commanding current — on a table that runs exactly that: the small table with a lead-lag
//! and an integrator on X (its gain and corners retuned away from any design the family
//! starts from) and the preset's PID on Y (the same structure, its zeros a double one),
//! recorded by the independent integrator of `common::reference` at the tables, as a scale
//! reads them, its interpolator at the preset's acceleration and jerk. A family that holds
//! the machine must reach it: it is kept over the cascade on both axes, and on X, the
//! lead-lag, it predicts the halves of the record each fit did not see to the record's
//! noise. (Y's start is the rigid mass, the screw drive's design there not starting a
//! twentieth lower: its fit is kept, twelve times better than the cascade's, but stops at
//! 0.27 µm, about five times the noise — not asserted here.)

use crate::common;

use common::identifying::lead_lag_designed_and_run;
use common::program_text;
use common::reference::{self, Recording};
use contourcheck::compare::CompareSettings;
use contourcheck::identify::{identify_loop, loop_template};
use contourcheck::machine::{AxisName, Controller};
use contourcheck::sim::MeasuredAt;
use contourcheck::trace::measured::parse_trace;

/// The record's noise per sample (µm): the reference's 0.05 µm of Gaussian noise and the
/// 0.1 µm counts' rounding, 0.1/√12, independent of each other.
fn record_noise_um() -> f64 {
    0.05_f64.hypot(0.1 / 12.0_f64.sqrt())
}

/// A model that is the machine leaves the record's noise on the held-out halves, and a
/// little of what differs between the reference and the tool's simulator (the reference's
/// own integration and interpolator, the encoder's counts on the commands' clock): within
/// twice the noise. The same family on the rigid mass alone, which lacks the screw's strain,
/// left 1.01 µm held out on X of this record, seventeen times the noise, and was not kept.
const HELD_OUT_NOISES: f64 = 2.0;

#[test]
fn a_lead_lag_table_without_a_template_is_reached_by_the_lead_lag_family() {
    let (_, truth) = lead_lag_designed_and_run();
    // Lines and a circle each way: the starts and stops strain the screw by the table's
    // inertia, the circle's quadrants reverse one axis at a time against its friction.
    let program = program_text(
        "G21 G17 G90 G94\nG0 X0 Y0\nG1 X20 F2000\nG3 X20 Y0 I-10 J0\nG2 X20 Y0 I-10 J0\n\
         G1 X0 Y10 F1200\nM2\n",
    );
    let rec = Recording {
        sample_s: 1e-4,
        noise_m: 0.05e-6,
        count_m: 0.1e-6,
        step_s: 1e-5,
        seed: 101,
        accel: truth.x.limits.max_accel_m_per_s2,
        jerk: Some(truth.x.limits.max_jerk_m_per_s3),
        ..Recording::default()
    };
    let csv = reference::record(&program, &truth.x, &truth.y, &rec);
    let measured = parse_trace(&csv, "reference.csv").unwrap();
    let start = loop_template(&measured);
    let mut settings = CompareSettings::for_machine(&start);
    settings.measured_at = MeasuredAt::Table;
    let id = identify_loop(&program, &start, &measured, &settings).unwrap();
    let noise_um = record_noise_um();
    for a in &id.axes {
        eprintln!(
            "{}: held out {:.3} µm of {:.3} µm; {}",
            a.axis, a.held_out_identified_um, a.following_error_rms_um, a.kept
        );
        assert!(a.kept.contains("integrating lead-lag"), "{}", a.kept);
        let Controller::TransferFunction(tf) = &id.machine.axis(a.axis).controller else {
            panic!(
                "{} written as {:?}",
                a.axis,
                id.machine.axis(a.axis).controller
            );
        };
        // An integrator: no constant term in the denominator.
        assert_eq!(tf.denominator.last(), Some(&0.0), "{tf:?}");
    }
    let x_held_out_um = id.axes[0].held_out_identified_um;
    assert!(
        x_held_out_um <= HELD_OUT_NOISES * noise_um,
        "X: held out {x_held_out_um} µm against the record's noise of {noise_um} µm"
    );
    // The retuned lead-lag's gain at low frequency, K·z₁·z₂/p (A/mm·s), comes back within a
    // tenth: the family holds the drive the table has, so its values are the table's.
    let x = id.machine.axis(AxisName::X);
    let (Controller::TransferFunction(found), Controller::TransferFunction(run)) =
        (&x.controller, &truth.x.controller)
    else {
        panic!("transfer functions");
    };
    let low = |c: &[f64], d: &[f64]| c[2] / d[1];
    let ratio = low(&found.numerator, &found.denominator) / low(&run.numerator, &run.denominator);
    assert!((ratio - 1.0).abs() < 0.1, "{found:?} against {run:?}");
}
