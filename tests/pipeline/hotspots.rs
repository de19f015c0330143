//! Hotspots named by what the commands do there, each cause on a run built to show it, with
//! the size expected from the physics: an axis starting from rest against one reversing in
//! motion, a corner, the radius loss of a circle (one row per circle, the largest error
//! named by it), half a semi-closed axis's backlash offsetting a line, and unequal gains
//! offsetting one.

use std::f64::consts::PI;

use contourcheck::analysis::hotspot::{Cause, Hotspot};
use contourcheck::check::{CheckRun, CheckSettings, check};
use contourcheck::gcode::{InterpretOptions, parse_program};
use contourcheck::machine::{AxisName, Feedback, MachineConfig};
use contourcheck::sim::AxisModel;
use contourcheck::sim::linear::{self, Loop};

fn run(src: &str, machine: &MachineConfig) -> CheckRun {
    let program = parse_program(src, "t.nc", &InterpretOptions::default()).unwrap();
    check(&program, machine, &CheckSettings::for_machine(machine)).unwrap()
}

fn sample(name: &str) -> String {
    std::fs::read_to_string(format!(
        "{}/gcode-samples/{name}",
        env!("CARGO_MANIFEST_DIR")
    ))
    .unwrap()
}

/// Angle of a hotspot on the test circle about the origin (degrees, −180..180).
fn angle_deg(h: &Hotspot) -> f64 {
    h.y_mm.atan2(h.x_mm).to_degrees()
}

fn near(a: f64, target: f64) -> bool {
    ((a - target + 180.0).rem_euclid(360.0) - 180.0).abs() < 5.0
}

/// A heavy machine with no Coulomb friction: its errors are its loops' and its play's.
fn frictionless() -> MachineConfig {
    let mut m = MachineConfig::default_preset();
    for a in AxisName::BOTH {
        m.axis_mut(a).friction.coulomb_coefficient = 0.0;
    }
    m
}

/// The circular test on the small table: PID position control leaves no steady lag, and
/// friction spikes the error where an axis's command passes through zero. X stands on the
/// lead-in line before each circle, so at 0° it starts from rest; at 180° its velocity
/// changes sign while moving, as Y's does at 90° and 270°.
#[test]
fn an_axis_starting_from_rest_is_told_from_one_reversing() {
    let r = run(
        &sample("circle-test.nc"),
        &MachineConfig::preset("small-table").unwrap(),
    );
    let spots = &r.result.hotspots;
    let x_start = Cause::StartFromRest { axis: AxisName::X };
    let x_reversal = Cause::AxisReversal { axis: AxisName::X };
    let y_reversal = Cause::AxisReversal { axis: AxisName::Y };
    for line in [13, 16] {
        let on: Vec<&Hotspot> = spots.iter().filter(|h| h.line == line).collect();
        let cause_near = |deg: f64| {
            on.iter()
                .filter(|h| near(angle_deg(h), deg))
                .map(|h| h.cause)
                .collect::<Vec<_>>()
        };
        assert_eq!(cause_near(0.0), vec![x_start], "line {line}: {on:#?}");
        assert_eq!(cause_near(180.0), vec![x_reversal], "line {line}: {on:#?}");
        assert_eq!(cause_near(90.0), vec![y_reversal], "line {line}: {on:#?}");
        assert_eq!(cause_near(-90.0), vec![y_reversal], "line {line}: {on:#?}");
    }
    // Spikes, each well above the plateau it stands on (there is none to speak of).
    for h in spots.iter().filter(|h| h.cause != Cause::SteadyLag) {
        assert!(
            h.excess_um > 5.0 && h.excess_um > 0.9 * h.error_um.abs(),
            "{h:?}"
        );
    }
}

#[test]
fn the_corners_of_a_square_are_named_corners() {
    let r = run(&sample("square.nc"), &MachineConfig::default_preset());
    let corners: Vec<(f64, f64)> = r
        .result
        .hotspots
        .iter()
        .filter(|h| h.cause == Cause::Corner)
        .map(|h| (h.x_mm, h.y_mm))
        .collect();
    // The square's three corners passed under G64 (the last side ends in an exact stop),
    // each where the path turns, a lag's length into the new side at most.
    for (x, y) in [(100.0, 0.0), (100.0, 100.0), (0.0, 100.0)] {
        assert!(
            corners
                .iter()
                .any(|c| (c.0 - x).abs() < 1.0 && (c.1 - y).abs() < 1.0),
            "no corner at ({x}, {y}): {:#?}",
            r.result.hotspots
        );
    }
    assert_eq!(r.result.hotspots[0].cause, Cause::Corner);
}

/// The radius loss of a linear axis on a circle: a plateau all round it. The events that
/// flag it (the quadrants, the start) give one row per circle, holding the largest error
/// — the run's — named by its cause, with the stretch it covers.
#[test]
fn a_circles_radius_loss_is_one_row_per_circle_holding_the_largest_error() {
    let machine = frictionless();
    let r = run(&sample("circle-test.nc"), &machine);
    let (r_mm, feed) = (100.0, 1000.0);
    let omega = (feed / 60_000.0) / (r_mm * 1e-3);
    let t = linear::closed_loop(
        &AxisModel::from_config(&machine.x),
        Loop::Position,
        omega / (2.0 * PI),
    );
    let loss_um = r_mm * 1e3 * (1.0 - t.norm());
    let spots = &r.result.hotspots;
    for line in [13, 16] {
        let rows: Vec<&Hotspot> = spots.iter().filter(|h| h.line == line).collect();
        assert_eq!(rows.len(), 1, "line {line}: {spots:#?}");
        let h = rows[0];
        assert_eq!(h.cause, Cause::SteadyLag);
        assert!(
            (h.error_um.abs() / loss_um - 1.0).abs() < 0.02,
            "{h:?} against {loss_um}"
        );
        // The four quadrants at least, over most of the circle's 37.7 s.
        let e = h.extent.unwrap();
        assert!(e.places >= 4 && e.to_t_s - e.from_t_s > 25.0, "{e:?}");
    }
    let max_um = r.result.summary.max_contour_error_m * 1e6;
    assert!(
        (spots[0].error_um.abs() - max_um).abs() < 1e-9,
        "{:?} against {max_um}",
        spots[0]
    );
}

/// A semi-closed X axis reads its motor: the table trails the screw by half the play, and
/// by the spring's give under the friction it drags, f/K_M, on the side it is pushed from.
/// Moving on along a 45° line in the direction it last moved (no gap to cross), the table
/// is that far behind in X all the way: (b/2 + f/K_M)·sin 45° across the line. With the
/// loop closed on a scale there is no such offset.
#[test]
fn half_the_play_of_a_semi_closed_axis_offsets_a_line() {
    let b_um = 20.0;
    let mut machine = MachineConfig::default_preset();
    machine.x.drive.backlash_um = b_um;
    machine.x.position_loop.feedback = Feedback::MotorEncoder;
    let src = "G21 G90 G64\nG0 X0 Y0\nG1 X10 F1000\nG4 P1\nG1 X60 Y50\nM2\n";
    let r = run(src, &machine);
    // Coulomb (c·M·g) and viscous friction at the X speed, against the axial stiffness.
    let v_x = 1000.0 / 60_000.0 * (PI / 4.0).cos();
    let drag_n = 0.01 * 6000.0 * 9.81 + 3000.0 * v_x;
    let expected_um = (0.5 * b_um + drag_n / 3.6e8 * 1e6) * (PI / 4.0).sin();
    // Along the middle of the line the error is that offset.
    let middle: Vec<f64> = (0..r.contour.error_m.len())
        .filter(|&k| r.commands.x.pos_m[k] > 0.02 && r.commands.x.pos_m[k] < 0.05)
        .map(|k| r.contour.error_m[k] * 1e6)
        .collect();
    assert!(middle.len() > 1000);
    for e in &middle {
        assert!(
            (e.abs() / expected_um - 1.0).abs() < 0.005,
            "{e} against {expected_um}"
        );
    }
    let offset: Vec<&Hotspot> = r
        .result
        .hotspots
        .iter()
        .filter(|h| h.cause == Cause::BacklashOffset { axis: AxisName::X })
        .collect();
    assert_eq!(offset.len(), 1, "{:#?}", r.result.hotspots);
    assert_eq!(offset[0].line, 5);
    assert!(
        offset[0].error_um.abs() >= 0.99 * expected_um,
        "{:?}",
        offset[0]
    );
    machine.x.position_loop.feedback = Feedback::LinearScale;
    let closed = run(src, &machine);
    assert!(
        closed
            .result
            .hotspots
            .iter()
            .all(|h| !matches!(h.cause, Cause::BacklashOffset { .. })),
        "{:#?}",
        closed.result.hotspots
    );
}

/// Y lagging more than X (Kv 0.9 against 1.0 m/min/mm) on a 45° line: the lags differ by
/// F·(1/Kv_y − 1/Kv_x) along Y, half of it across the line — 55.6 µm at F1000 — named as
/// the mismatch it is; with equal gains nothing is left across the line to name.
#[test]
fn unequal_gains_offsetting_a_line_are_named_a_servo_mismatch() {
    let mut machine = frictionless();
    machine.y.position_loop.kv_m_per_min_per_mm = 0.9;
    let src = "G21 G90 G64\nG0 X0 Y0\nG1 X100 Y100 F1000\nM2\n";
    let r = run(src, &machine);
    let v = 1000.0 / 60_000.0;
    let lag = |kv: f64| 1.0 / (kv * 1000.0 / 60.0);
    let expected_um = v * 0.5 * (lag(0.9) - lag(1.0)) * 1e6;
    let top = &r.result.hotspots[0];
    assert_eq!(top.cause, Cause::ServoMismatch, "{:#?}", r.result.hotspots);
    assert!(
        (top.error_um.abs() / expected_um - 1.0).abs() < 0.01,
        "{top:?} against {expected_um}"
    );
    let matched = run(src, &frictionless());
    assert!(
        matched
            .result
            .hotspots
            .iter()
            .all(|h| h.cause != Cause::ServoMismatch),
        "{:#?}",
        matched.result.hotspots
    );
}
