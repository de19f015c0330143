//! A circle's windows where the command accelerates onto the circle, or slows into its end,
//! for a long time against the loop's time constant, and where the machine's acceleration
//! holds the command below the programmed feed: the start's window against the independent
//! replica of `common::entry`, the end's against where the commands leave their speed, and
//! the circle's figures on a machine with no error sources free of both.

use contourcheck::check::{CheckRun, CheckSettings, check};
use contourcheck::gcode::{InterpretOptions, parse_program};
use contourcheck::machine::MachineConfig;
use contourcheck::plan::ProfileKind;

use crate::check::command_rows;
use crate::common::entry::{ENTRY_RESIDUE_M, ENTRY_TIME_CONSTANTS, entry_window, residue_at_m};

/// The circle's radius (m): R10 about the origin, from rest at its 0° point.
const RADIUS_M: f64 = 0.010;

/// The program: a rapid to the circle's start, then one counter-clockwise turn at `feed`.
fn program(feed: f64) -> String {
    format!("G21 G90 G17 G94\nG0 X10 Y0\nG3 X10 Y0 I-10 J0 F{feed}\nM2\n")
}

/// The default machine with no error sources on X and Y (no friction, no backlash: its
/// steady circle is the programmed one shrunk alike at every angle), each axis held to
/// `accel_m_per_s2`.
fn machine(accel_m_per_s2: f64) -> MachineConfig {
    let mut m = MachineConfig::default_preset();
    for a in [&mut m.x, &mut m.y] {
        a.friction.coulomb_coefficient = 0.0;
        a.drive.backlash_um = 0.0;
        a.limits.max_accel_m_per_s2 = accel_m_per_s2;
    }
    m
}

/// The run of `feed` on `machine`, trapezoidal speed (a constant acceleration onto the
/// circle, the ramp of the closed forms below).
fn run(feed: f64, machine: &MachineConfig) -> CheckRun {
    let src = program(feed);
    let program = parse_program(&src, "t.nc", &InterpretOptions::default()).unwrap();
    let mut settings = CheckSettings::for_machine(machine);
    settings.plan.profile = ProfileKind::Trapezoid;
    check(&program, machine, &settings).unwrap()
}

/// The band of radial deviations (m) of the axes' path about the programmed centre, over
/// the samples whose command runs on the circle's segment between `from_m` past its start
/// and `until_m` before its end: the run's own positions, not the figures under test. No
/// sample there fails (an empty band would pass any bound).
fn radial_band_m(r: &CheckRun, segment: u32, from_m: f64, until_m: f64) -> f64 {
    let rows = command_rows(&r.commands);
    let on: Vec<usize> = (0..rows.len())
        .filter(|&k| r.commands.segment[k] == segment)
        .collect();
    let mut run_m = 0.0;
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for pair in on.windows(2) {
        let (a, b) = (rows[pair[0]].1, rows[pair[1]].1);
        run_m += (b[0] - a[0]).hypot(b[1] - a[1]);
        if run_m > from_m && run_m < std::f64::consts::TAU * RADIUS_M - until_m {
            let k = pair[1];
            let radial_m = r.x.pos_m[k].hypot(r.y.pos_m[k]) - RADIUS_M;
            (lo, hi) = (lo.min(radial_m), hi.max(radial_m));
        }
    }
    assert!(
        hi >= lo,
        "no sample between {from_m} m and {until_m} m before the end"
    );
    hi - lo
}

/// What the figures of the one circle of run `r` leave out and keep, against the replica
/// (loops of time constant `tau_s`, the command running round at `v` m/s): the replica
/// finds that speed from the commands; the start's window leaves the replica's own residue
/// under 0.1 µm and ends short of the replica's window by at most what the code may read
/// early, or a sample's step past it. Each finds where the command reached its speed its own
/// way: the replica where every step's is within 0.1 % of the speed half a turn on, the code
/// where its speeds over two loop time constants agree to 0.1 %, which a ramp at v/T_a ending
/// u into the older of the two passes once (v/T_a)·u²/(2τ) ≤ 0.1 % of v: it reads at most
/// u = √(0.002·τ·T_a) before the ramp's end, u·v of path (T_a = 2·read/v from rest), and
/// counts at least the replica's time constants from there (more of the lag still to
/// build). The end's as [`end_window_m`] says. Past the windows the path's radial band is
/// what the transient leaves, 0.2 µm for both its sides, and G with it: no out-of-roundness
/// on a machine with none. Returns the replica's residue at `at_m` of path.
fn assert_window(r: &CheckRun, tau_s: f64, v: f64, at_m: f64) -> f64 {
    let f = r.result.circular.circles[0];
    let segment = f.segment as u32;
    let rows = command_rows(&r.commands);
    let on = |k: usize, _: [f64; 2]| r.commands.segment[k] == segment;
    let w = entry_window(&rows, on, RADIUS_M, true, [tau_s; 2]).unwrap();
    assert!((w.speed_m_per_s - v).abs() < 1e-3 * v, "{w:?}");
    let residue_m = |at_m: f64| residue_at_m(&rows, on, (RADIUS_M, true, v), [tau_s; 2], at_m);
    let start_m = f.start_left_out_deg.to_radians() * RADIUS_M;
    assert!(
        residue_m(start_m) <= ENTRY_RESIDUE_M,
        "{}",
        residue_m(start_m)
    );
    let step_m = v * r.commands.dt_s;
    let ramp_s = 2.0 * w.read_m / v;
    let early_m = (2.0 * 1e-3 * tau_s * ramp_s).sqrt() * v;
    assert!(
        start_m > w.start_m - early_m && start_m < w.start_m + step_m,
        "{start_m} {w:?}"
    );
    let end_m = f.end_left_out_deg.to_radians() * RADIUS_M;
    let [shortest_m, longest_m] = end_window_m(&rows, segment, r, tau_s, v);
    assert!(
        end_m > (1.0 - 1e-3) * shortest_m && end_m < (1.0 + 1e-3) * longest_m,
        "{end_m} m against {shortest_m}..{longest_m} m: {f:?}"
    );
    let band_m = radial_band_m(r, segment, start_m, end_m);
    assert!(band_m < 2.0 * ENTRY_RESIDUE_M, "{band_m}");
    assert!(f.g_um < 2.0 * ENTRY_RESIDUE_M * 1e6, "{f:?}");
    residue_m(at_m)
}

/// The path the end's window should leave out (m), shortest and longest: five time
/// constants at `v`, or where longer the path from the last step of the commands run at `v`
/// (within 0.1 %) to the circle's end — the loops' lag changes only once the command slows,
/// and the code finds that over its last two loop time constants agreeing, so up to one time
/// constant and a step of path before it.
fn end_window_m(
    rows: &[(f64, [f64; 2])],
    segment: u32,
    r: &CheckRun,
    tau_s: f64,
    v: f64,
) -> [f64; 2] {
    let on: Vec<usize> = (0..rows.len())
        .filter(|&k| r.commands.segment[k] == segment)
        .collect();
    let (mut run_m, mut steady_until_m) = (0.0, 0.0);
    for pair in on.windows(2) {
        let ((t0, a), (t1, b)) = (rows[pair[0]], rows[pair[1]]);
        let step_m = (b[0] - a[0]).hypot(b[1] - a[1]);
        run_m += step_m;
        if step_m / (t1 - t0) > (1.0 - 1e-3) * v {
            steady_until_m = run_m;
        }
    }
    let slowing_m = run_m - steady_until_m;
    let five_m = ENTRY_TIME_CONSTANTS * tau_s * v;
    let step_m = v * r.commands.dt_s;
    [
        five_m.max(slowing_m),
        five_m.max(slowing_m + tau_s * v + step_m),
    ]
}

/// The loops' time constant on the machines here: 1/Kv of Kv = 1 m/min/mm (s).
const TAU_S: f64 = 0.06;

/// From rest at F1000 (v = 16.67 mm/s) under an acceleration that takes T_a = 5τ to reach
/// it (τ = 1/Kv = 60 ms; the arc's tangential share √(1 − 0.5²) of each axis's): the loop's
/// lag is still building over the ramp. Read where the command sets off, the transient is
/// the whole steady lag, A = Rω²τ²/(1 + ω²τ²) = 99.0 µm radial and D = Rωτ/(1 + ω²τ²) =
/// 990 µm along the path (ωτ = 0.1), and (A + n·ωτ·D)·e⁻ⁿ = 0.1 µm after n = 9.22 time
/// constants, 9.22 mm of path from the set-off at the feed. A ramp of x = T_a/τ leaves
/// 2·sinh(x/2)/x of that residue there instead, 2.4 times it at x = 5: 0.24 µm, more than a
/// ballbar's step — the replica, following the ramp, finds over 0.1 µm there. Read where
/// the command runs at its speed, the window covers it ([`assert_window`]).
#[test]
fn a_long_acceleration_onto_a_circle_is_left_out_until_it_has_settled() {
    let v = 1000.0 / 60_000.0;
    let accel = v / (5.0 * TAU_S) / (1.0 - 0.25f64).sqrt();
    let m = machine(accel);
    let kv_per_s = m.x.position_loop.kv_m_per_min_per_mm * 1000.0 / 60.0;
    assert!((1.0 / kv_per_s - TAU_S).abs() < 1e-12);
    // The window read at the set-off (above), from rest at the programmed feed.
    let wt = v / RADIUS_M * TAU_S;
    let (a_m, d_m) = (
        RADIUS_M * wt * wt / (1.0 + wt * wt),
        RADIUS_M * wt / (1.0 + wt * wt),
    );
    let mut n: f64 = 50.0;
    for _ in 0..200 {
        n = ((a_m + n * wt * d_m) / ENTRY_RESIDUE_M).ln();
    }
    assert!((n - 9.22).abs() < 0.01, "{n}");
    let residue_m = assert_window(&run(1000.0, &m), TAU_S, v, n * TAU_S * v);
    assert!(residue_m > ENTRY_RESIDUE_M, "{residue_m}");
}

/// At F1000 on R10 under an acceleration a of 0.03125 m/s² each axis, the arc's centripetal
/// share holds the command to v²/R ≤ 0.5·a: v = √(0.5·a·R) = 12.5 mm/s, F750. The window
/// counts its time constants at that speed: five before the end are 5τ·v = 3.75 mm of path
/// (21.5°), not the 5 mm (28.6°) the programmed feed would give; the start's as the replica
/// works it out at that speed ([`assert_window`]).
#[test]
fn a_circle_held_below_its_feed_counts_its_window_at_the_speed_it_runs() {
    let accel = 0.03125;
    let v = (0.5 * accel * RADIUS_M).sqrt();
    assert!((v - 0.75 * 1000.0 / 60_000.0).abs() < 1e-12);
    assert_window(&run(1000.0, &machine(accel)), TAU_S, v, 0.0);
}

/// The servo mismatch of a pair of R10 circles (counter-clockwise, then clockwise) held to
/// v = √(0.5·a·R) = 12.5 mm/s at F1000, X's Kv 0.9 against Y's 1.0. A first-order loop of
/// time constant τ follows the circle at ω = v/R with amplitude R/√(1 + ω²τ²) and phase lag
/// φ = atan(ωτ); the axes' phases differing by φy − φx tilt each path's ellipse, its sin 2θ
/// radius term being −½·√((Ax² + Ay²)/2)·sin(φy − φx) counter-clockwise and the opposite
/// clockwise, and the figure divides the two directions' tilts (2·term/R) by 2ω: Y lags X
/// by (√((Ax² + Ay²)/2)/R)·sin(φy − φx)/ω, −6.60 ms here (τx = 66.7 ms, τy = 60 ms; the
/// 1/Kv difference to ω²τ²). Read at the programmed feed's ω the same tilt gives 0.75 of
/// it, −4.95 ms.
#[test]
fn a_pair_held_below_its_feed_shows_the_servo_mismatch_at_the_speed_it_runs() {
    let accel = 0.03125;
    let v = (0.5 * accel * RADIUS_M).sqrt();
    let mut m = machine(accel);
    m.x.position_loop.kv_m_per_min_per_mm = 0.9;
    let tau_s = [0.9, 1.0].map(|kv: f64| 60.0 / (kv * 1000.0));
    let omega = v / RADIUS_M;
    let phase = tau_s.map(|t| (omega * t).atan());
    let amplitude_m = tau_s.map(|t| RADIUS_M / (1.0 + (omega * t).powi(2)).sqrt());
    let mean_m = (0.5 * (amplitude_m[0].powi(2) + amplitude_m[1].powi(2))).sqrt();
    let expected_ms = 1e3 * mean_m / RADIUS_M * (phase[1] - phase[0]).sin() / omega;
    assert!((expected_ms + 6.60).abs() < 0.01, "{expected_ms}");
    let src = "G21 G90 G17 G94\nG0 X10 Y0\nG3 X10 Y0 I-10 J0 F1000\nG2 X10 Y0 I-10 J0 F1000\nM2\n";
    let program = parse_program(src, "t.nc", &InterpretOptions::default()).unwrap();
    let mut settings = CheckSettings::for_machine(&m);
    settings.plan.profile = ProfileKind::Trapezoid;
    let r = check(&program, &m, &settings).unwrap();
    let pairs = &r.result.circular.pairs;
    assert_eq!(pairs.len(), 1, "{:?}", r.result.circular);
    let got_ms = pairs[0].servo_mismatch_ms;
    assert!(
        (got_ms - expected_ms).abs() < 0.01 * expected_ms.abs(),
        "{got_ms} ms against {expected_ms} ms"
    );
}

/// On R10 under an acceleration a of 0.00823 m/s² each axis, the command runs round at v =
/// √(0.5·a·R) = 6.415 mm/s (F385 of F1000) and slows into its end at the arc's tangential
/// share a·√(1 − 0.5²): T_d = v/(a·√0.75) = 15τ, 7.5τ·v = 2.89 mm of path (16.5°), half as
/// long again as the five time constants (1.92 mm, 11.0°) the end leaves out at least. The
/// loop's lag shrinks as the command slows, which within those five moves the path off its
/// steady circle by more than the 0.2 µm the windows hold the figures to: the end's window
/// reaches back to where the command last ran at v ([`end_window_m`]), and the band within
/// the windows is the steady circle's.
#[test]
fn a_long_deceleration_into_a_circles_end_is_left_out() {
    let t_d = 15.0 * TAU_S;
    let accel = 0.5 * RADIUS_M / (0.75 * t_d * t_d);
    let v = (0.5 * accel * RADIUS_M).sqrt();
    assert!((v - 6.415e-3).abs() < 0.001e-3, "{v}");
    assert!((v / (accel * 0.75f64.sqrt()) - t_d).abs() < 1e-9);
    let r = run(1000.0, &machine(accel));
    let f = r.result.circular.circles[0];
    let five_m = ENTRY_TIME_CONSTANTS * TAU_S * v;
    let start_m = f.start_left_out_deg.to_radians() * RADIUS_M;
    // Within five time constants alone the slowing moves the path off its circle.
    let band_m = radial_band_m(&r, f.segment as u32, start_m, five_m);
    assert!(band_m > 2.0 * ENTRY_RESIDUE_M, "{band_m}");
    assert_window(&r, TAU_S, v, 0.0);
    assert!(
        f.end_left_out_deg.to_radians() * RADIUS_M > 0.5 * v * t_d,
        "{f:?}"
    );
}
