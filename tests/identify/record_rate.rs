//! A controller's corner above what half of its record's Nyquist frequency would allow: a
//! lead tuned on the machine to 36–400 Hz, run in continuous time by the independent
//! integrator of `common::reference`, its trace logged at 1 kHz — a quarter of that rate is
//! 250 Hz, below the pole. The record's sampling is not the controller's period: the search
//! for the pole is not cut off there, and the pole the record shows is found.

use crate::common;

use common::identifying::{
    encoder_recording, fitted_program, print_x_held_out, reference_trace, x_corners_hz,
};
use common::reference::Recording;
use contourcheck::compare::CompareSettings;
use contourcheck::identify::identify;

use crate::hard_searches::lead_lag;
use contourcheck::sim::MeasuredAt;

#[test]
fn a_corner_above_a_quarter_of_the_records_rate_is_not_cut_off_there() {
    // Designed: the integrator's zero at 5 Hz, the lead from 12 to 80 Hz. Run: the lead from
    // 36 to 400 Hz, the gain raised to keep the crossover near 37 Hz (|C| there falls by
    // |j37 + 240| / |j37 + 400| ≈ 0.6 against the 240 Hz pole that 90 carried).
    let template = lead_lag(45.0, [5.0, 12.0, 80.0], 600.0);
    let run = [5.0 / 3.0, 36.0, 400.0];
    let truth = lead_lag(150.0, run, 200.0);
    let mut settings = CompareSettings::for_machine(&template);
    settings.measured_at = MeasuredAt::Motor;
    let program = fitted_program();
    let rec = Recording {
        sample_s: 1e-3,
        ..encoder_recording(43)
    };
    let measured = reference_trace(&program, &truth, &rec);
    let id = identify(&program, &template, &measured, &settings).unwrap();
    print_x_held_out(&id);
    let (zeros, poles) = x_corners_hz(&id);
    // Half of the 1 kHz record's Nyquist frequency is 250 Hz: a search bounded there could
    // write no pole above it. The machine's is at 400 Hz.
    let pole = poles[0];
    assert!(
        (pole / 400.0 - 1.0).abs() < 0.2,
        "pole {pole} Hz, zeros {zeros:?} Hz (the machine's 400 Hz)"
    );
}
