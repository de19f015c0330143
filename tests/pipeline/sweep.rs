//! Sweeps: the paper's Table 4 trend, unstable settings flagged, mismatched gains against
//! the analytic ellipse and named as the error's cause, settings short of their stability
//! margins never ranked best (on the heavy machine and on a small one written from the
//! docs), and parallel runs identical to serial ones.

use std::f64::consts::PI;

use contourcheck::check::{CheckSettings, check, circle_tests};
use contourcheck::gcode::{InterpretOptions, Program, parse_program};
use contourcheck::machine::{AxisName, MachineConfig};
use contourcheck::plan::{PlanConfig, ProfileKind};
use contourcheck::sim::AxisModel;
use contourcheck::sim::linear::{self, Loop};
use contourcheck::sweep::{self, Dimension, Dominant, Flag, PointResult, Thresholds};

fn program(src: &str) -> Program {
    parse_program(src, "t.nc", &InterpretOptions::default()).unwrap()
}

fn kv_dim(axes: &[&str], values: Vec<f64>) -> Dimension {
    Dimension {
        name: format!("{}.kv", axes.concat()),
        keys: axes
            .iter()
            .map(|a| format!("{a}.position_loop.kv_m_per_min_per_mm"))
            .collect(),
        values,
    }
}

fn plan_config(machine: &MachineConfig, profile: ProfileKind) -> PlanConfig {
    let mut p = PlanConfig::for_machine(machine);
    p.profile = profile;
    p
}

#[test]
fn kv_sweep_follows_the_papers_table_4_trend() {
    // Table 4's experiment: X alone at 500 mm/min; the steady error is F/Kv.
    let machine = MachineConfig::default_preset();
    let p = program("G21 G90 G61\nG0 X0 Y0\nG1 X40 F500\nM2\n");
    let kvs = vec![0.7, 0.8, 0.9, 1.0, 1.1, 1.2];
    let dims = [kv_dim(&["x"], kvs.clone())];
    let points = sweep::run(
        &p,
        &machine,
        &plan_config(&machine, ProfileKind::Ideal),
        &dims,
        true,
        &|| {},
    );
    assert_eq!(points.len(), 6);
    for pt in &points {
        let PointResult::Ok { metrics, .. } = &pt.result else {
            panic!("{pt:?}")
        };
        let f_over_kv_um = 500.0 / pt.values[0]; // mm/min over m/min/mm, in µm
        assert!(
            (metrics.max_following_um[0] - f_over_kv_um).abs() < 0.005 * f_over_kv_um,
            "{pt:?}"
        );
    }
}

#[test]
fn absurd_gains_are_flagged_unstable_not_measured() {
    let machine = MachineConfig::default_preset();
    let p = program("G21 G90\nG0 X0 Y0\nG1 X10 F500\nM2\n");
    let dims = [
        kv_dim(&["x", "y"], vec![1.0, 50.0]),
        Dimension {
            name: "x.ks".into(),
            keys: vec!["x.velocity_loop.ks_nm_s_per_rad".into()],
            values: vec![16.0, 2000.0],
        },
    ];
    let points = sweep_on(&p, &machine, &dims);
    for pt in &points {
        let sane = pt.values == [1.0, 16.0];
        match (&pt.result, sane) {
            (PointResult::Ok { .. }, true) | (PointResult::Unstable { .. }, false) => {}
            other => panic!("{:?} gave {other:?}", pt.values),
        }
    }
}

/// The largest steady radial deviation of a circle whose axes respond with T_x and T_y at
/// ω: x = R|T_x| cos(u + ∠T_x), y = R|T_y| sin(u + ∠T_y), radius − R at its worst.
fn analytic_max_radial(model_x: &AxisModel, model_y: &AxisModel, r: f64, omega: f64) -> f64 {
    let f = omega / (2.0 * PI);
    let (tx, ty) = (
        linear::closed_loop(model_x, Loop::Position, f),
        linear::closed_loop(model_y, Loop::Position, f),
    );
    (0..100_000)
        .map(|i| {
            let u = 2.0 * PI * i as f64 / 100_000.0;
            let x = r * tx.norm() * (u + tx.arg()).cos();
            let y = r * ty.norm() * (u + ty.arg()).sin();
            (x.hypot(y) - r).abs()
        })
        .fold(0.0, f64::max)
}

#[test]
fn mismatched_gains_distort_a_circle_by_the_analytic_amount() {
    let mut machine = MachineConfig::default_preset();
    for a in AxisName::BOTH {
        machine.axis_mut(a).friction.coulomb_coefficient = 0.0;
    }
    let src =
        "G21 G90 G64\nG0 X100 Y-30\nG1 Y0 F1000\nG3 X100 Y0 I-100 J0\nG3 X100 Y0 I-100 J0\nM2\n";
    let p = program(src);
    let omega = (1000.0 / 60_000.0) / 0.1;
    let steady_max = |m: &MachineConfig| {
        let run = check(&p, m, &CheckSettings::for_machine(m)).unwrap();
        // The second circle: long past the entry transient.
        circle_tests(&run.result)[1]
            .points
            .iter()
            .map(|q| q.1.abs())
            .fold(0.0, f64::max)
    };
    let matched = steady_max(&machine);
    let mut mismatched = machine.clone();
    mismatched.y.position_loop.kv_m_per_min_per_mm = 0.9;
    let worse = steady_max(&mismatched);
    let expected = analytic_max_radial(
        &AxisModel::from_config(&mismatched.x),
        &AxisModel::from_config(&mismatched.y),
        0.1,
        omega,
    );
    // A lag difference of (1/Kv_y − 1/Kv_x) between the axes tilts the circle into an
    // ellipse at 45°: ≈ R·ω·Δ/2 ≈ 50 µm here, far above the matched radius loss.
    assert!((expected - 55e-6).abs() < 10e-6, "{expected}");
    assert!(
        (worse - expected).abs() < 0.02 * expected,
        "{worse} vs analytic {expected}"
    );
    assert!(worse > 5.0 * matched, "{worse} vs matched {matched}");
    // And the sweep ranks the matched pair first, and names the mismatch as what makes the
    // others' error: matching the axes takes it back to the matched radius loss.
    let dims = [kv_dim(&["y"], vec![0.9, 1.0, 1.1])];
    let mut points = sweep_on(&p, &machine, &dims);
    sweep::rank(&mut points, &Thresholds::default());
    assert_eq!(points[0].values, vec![1.0]);
    for pt in &points {
        let PointResult::Ok { dominant, .. } = &pt.result else {
            panic!("{pt:?}")
        };
        let mismatched = pt.values != [1.0];
        assert_eq!(
            *dominant == Dominant::ServoMismatch,
            mismatched,
            "{:?}: {dominant:?}",
            pt.values
        );
    }
}

/// The Kv at which the X axis of `machine` turns unstable with every other setting held,
/// by bisection on its closed-loop eigenvalues.
fn edge_of_stability_kv(machine: &MachineConfig) -> f64 {
    let stable = |kv: f64| {
        let mut x = machine.x.clone();
        x.position_loop.kv_m_per_min_per_mm = kv;
        linear::check_stable(&AxisModel::from_config(&x)).is_ok()
    };
    let (mut lo, mut hi) = (0.01, 1000.0);
    assert!(stable(lo) && !stable(hi));
    for _ in 0..60 {
        let mid = (lo * hi).sqrt();
        if stable(mid) { lo = mid } else { hi = mid }
    }
    lo
}

/// `dims` swept in parallel on `machine` with its own planner settings.
fn sweep_on(p: &Program, machine: &MachineConfig, dims: &[Dimension]) -> Vec<sweep::SweepPoint> {
    sweep::run(
        p,
        machine,
        &PlanConfig::for_machine(machine),
        dims,
        true,
        &|| {},
    )
}

fn flags_of(points: &[sweep::SweepPoint], values: &[f64]) -> Vec<Flag> {
    match &points.iter().find(|q| q.values == values).unwrap().result {
        PointResult::Ok { flags, .. } => flags.clone(),
        other => panic!("{values:?}: {other:?}"),
    }
}

/// On the heavy machine the position gain is limited by the table ringing on its screw:
/// each setting's gain margin is its distance to the edge of stability, read off the
/// closed-loop eigenvalues; one below the threshold is flagged and ranked after every
/// healthy setting, whatever its contour error — and Kv 1.4, near the edge, also takes
/// most of the table mode's damping (ζ 0.015 of its 0.05).
#[test]
fn a_setting_short_of_its_margins_is_never_ranked_best() {
    let machine = MachineConfig::default_preset();
    let p = program(
        "G21 G90 G17 G94\nG0 X0 Y-50\nG1 X50 Y-50 F3000\nG3 X50 Y50 I0 J50\n\
         G3 X50 Y-50 I0 J-50\nG1 X100 Y-50\nM2\n",
    );
    let dims = [kv_dim(&["x", "y"], vec![1.0, 1.2, 1.4])];
    let mut points = sweep_on(&p, &machine, &dims);
    let edge = edge_of_stability_kv(&machine);
    for pt in &points {
        let PointResult::Ok { health, .. } = &pt.result else {
            panic!("{pt:?}")
        };
        let gm = health.least(Loop::Position, |m| m.gain_margin_db).unwrap();
        let by_eigenvalues = 20.0 * (edge / pt.values[0]).log10();
        assert!(
            (gm - by_eigenvalues).abs() < 0.02,
            "{gm} against {by_eigenvalues}"
        );
    }
    // Against 3 dB and ζ 0.02: Kv 1.0 (5.0 dB, the table mode left at ζ 0.030 of its
    // 0.05) and 1.2 (3.4 dB, ζ 0.022) pass, 1.4 (2.1 dB, ζ 0.015) does not.
    let lenient = Thresholds {
        min_gain_margin_db: 3.0,
        min_damping: 0.02,
        ..Thresholds::default()
    };
    sweep::rank(&mut points, &lenient);
    assert!(flags_of(&points, &[1.0]).is_empty() && flags_of(&points, &[1.2]).is_empty());
    let flags = flags_of(&points, &[1.4]);
    assert!(
        flags
            .iter()
            .any(|f| matches!(f, Flag::GainMargin { which: Loop::Position, db, .. } if *db < 3.0))
            && flags
                .iter()
                .any(|f| matches!(f, Flag::PoorDamping { damping, .. } if *damping < 0.016)),
        "{flags:?}"
    );
    assert_eq!(points.last().unwrap().values, vec![1.4]);
    // Judged on its contour error alone it would rank before Kv 1.0.
    let place = |points: &[sweep::SweepPoint], kv: f64| {
        points.iter().position(|q| q.values == vec![kv]).unwrap()
    };
    let by_error = Thresholds {
        min_phase_margin_deg: 0.0,
        min_gain_margin_db: 0.0,
        min_damping: 0.0,
    };
    sweep::rank(&mut points, &by_error);
    assert!(place(&points, 1.4) < place(&points, 1.0));
    // Against the 6 dB engineers ask for, every one of them is short (the preset's own Kv
    // of 1 has 5 dB).
    sweep::rank(&mut points, &Thresholds::default());
    assert!(points.iter().all(|q| !q.result.is_healthy()));
}

/// Sweeping X alone on the heavy machine leaves Y at the preset's Kv of 1, whose gain
/// margin — its distance to Y's own edge of stability, by the closed-loop eigenvalues — is
/// below 6 dB: every setting is short by that same figure, none is crowned, and what they
/// share is said once. X's own margin at Kv 0.6 is
/// ample.
#[test]
fn a_shortfall_every_setting_shares_is_named_once() {
    let machine = MachineConfig::default_preset();
    let p = program("G21 G90 G17 G94\nG0 X0 Y0\nG1 X40 F2000\nG1 Y40\nM2\n");
    let dims = [kv_dim(&["x"], vec![0.6, 0.8])];
    let mut points = sweep_on(&p, &machine, &dims);
    sweep::rank(&mut points, &Thresholds::default());
    assert!(points.iter().all(|q| !q.result.is_healthy()), "{points:?}");
    let mut as_x = machine.clone();
    as_x.x = machine.y.clone();
    let y_db =
        20.0 * (edge_of_stability_kv(&as_x) / machine.y.position_loop.kv_m_per_min_per_mm).log10();
    assert!(y_db < 6.0, "{y_db}");
    let shared = sweep::shared_shortfall(&points).unwrap();
    assert_eq!(shared.len(), 1, "{shared:?}");
    let Flag::GainMargin {
        axis: AxisName::Y,
        which: Loop::Position,
        db,
    } = shared[0]
    else {
        panic!("{shared:?}")
    };
    assert!((db - y_db).abs() < 0.02, "{db} against {y_db}");
    // Y's table mode is left at more than half the damping its screw alone gives it: the
    // machine's, not the setting's doing, and not flagged however far below 0.05 it lies.
    // (The screw's axial mode alone is damped by the file's ζ_m, 0.05: the loop leaves it
    // at 0.030.)
    let (_, axial_zeta) = table_mode(&machine.y);
    let alone = machine.y.drive.zeta_m;
    assert!(
        axial_zeta < 0.05 && axial_zeta > 0.5 * alone,
        "{axial_zeta} of {alone}"
    );
    // X at Kv 0.6 is flagged for Y alone; a laxer rule crowns a setting, and nothing is
    // shared then.
    let x_db = 20.0 * (edge_of_stability_kv(&machine) / 0.6).log10();
    assert!(x_db > 6.0, "{x_db}");
    assert_eq!(flags_of(&points, &[0.6]), shared);
    let lax = Thresholds {
        min_gain_margin_db: 3.0,
        min_damping: 0.02,
        ..Thresholds::default()
    };
    sweep::rank(&mut points, &lax);
    assert!(points[0].result.is_healthy());
    assert_eq!(sweep::shared_shortfall(&points), None);
}

/// The closed-loop mode the table's axial mode (41 Hz on its screw alone) becomes: the
/// oscillatory eigenvalue of the whole linearised axis between 30 and 45 Hz, (Hz, damping).
fn table_mode(axis: &contourcheck::machine::AxisConfig) -> (f64, f64) {
    let modes: Vec<_> = linear::closed_loop_modes(&AxisModel::from_config(axis))
        .into_iter()
        .filter(|m| (30.0..45.0).contains(&m.frequency_hz) && m.damping < 0.999)
        .collect();
    assert!(!modes.is_empty(), "{modes:?}");
    (modes[0].frequency_hz, modes[0].damping)
}

/// `sweep`'s loop damping over Kv 0.50–1.50 in steps of 0.01 on the heavy machine: at every
/// gain it is the table mode's damping, read off the axis's closed-loop eigenvalues, with
/// its frequency — never a better damped mode in its place while the table mode's damping
/// is above some share of the mechanics' — so between neighbouring gains it changes no more
/// than ten times that mode's mean slope over the range allows.
#[test]
fn sweep_loop_damping_follows_the_table_mode_continuously() {
    let base = MachineConfig::default_preset();
    let at = |kv: f64| {
        let mut m = base.clone();
        m.x.position_loop.kv_m_per_min_per_mm = kv;
        m.y.position_loop.kv_m_per_min_per_mm = kv;
        m
    };
    let kvs: Vec<f64> = (50..=150).map(|i| f64::from(i) / 100.0).collect();
    let (first, last) = (table_mode(&at(0.5).x).1, table_mode(&at(1.5).x).1);
    let bound = 10.0 * (first - last).abs() * 0.01;
    let mut previous: Option<f64> = None;
    for &kv in &kvs {
        let m = at(kv);
        let health = sweep::health::health(&m);
        let (x, y) = (table_mode(&m.x), table_mode(&m.y));
        let (hz, zeta) = if y.1 < x.1 { y } else { x };
        assert!(
            (health.loop_damping - zeta).abs() < 1e-9,
            "Kv {kv}: {health:?} against {zeta}"
        );
        let (_, at_hz) = health.loop_damping_at.unwrap();
        assert!((at_hz - hz).abs() < 1e-6, "Kv {kv}: {at_hz} against {hz}");
        if let Some(p) = previous {
            assert!(
                (health.loop_damping - p).abs() <= bound,
                "Kv {kv}: {p} → {}",
                health.loop_damping
            );
        }
        previous = Some(health.loop_damping);
    }
}

/// A small mill written from docs/machine-file.md (docs/examples/small-mill.toml): the
/// heavy machine's drive on a 200 kg table, with a lighter motor.
fn small_mill() -> MachineConfig {
    MachineConfig::load(std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/docs/examples/small-mill.toml"
    )))
    .unwrap()
}

/// In a sweep over both axes' K_v and K_s (in that order): every setting with a
/// position-loop phase margin under 30° is flagged, and every setting's gain margin is its
/// distance to the edge of stability of its own K_s.
fn assert_margins_flagged_and_by_eigenvalues(
    points: &[sweep::SweepPoint],
    machine: &MachineConfig,
) {
    for q in points {
        let PointResult::Ok { health, flags, .. } = &q.result else {
            continue;
        };
        let pm = health
            .least(Loop::Position, |m| m.phase_margin_deg)
            .unwrap();
        if pm < 30.0 {
            assert!(
                flags.iter().any(|f| matches!(f, Flag::PhaseMargin { .. })),
                "{:?}: {pm}° not flagged",
                q.values
            );
        }
        // Each setting's gain margin against the edge of stability of its own K_s.
        let mut at_ks = machine.clone();
        at_ks.x.velocity_loop.as_mut().unwrap().ks_nm_s_per_rad = q.values[1];
        let by_eigenvalues = 20.0 * (edge_of_stability_kv(&at_ks) / q.values[0]).log10();
        let gm = health.least(Loop::Position, |m| m.gain_margin_db).unwrap();
        assert!(
            (gm - by_eigenvalues).abs() < 0.05,
            "{:?}: {gm} against {by_eigenvalues}",
            q.values
        );
    }
}

/// Comparing gains on the small machine: the stiffest position gain on the softest
/// velocity loop (Kv 40, K_s 4) makes the smallest contour error — and rings, its position
/// loop left with a phase margin near 12°. Every setting below 30° is flagged, and the
/// setting crowned has its margins; a setting's gain margin is its distance to the edge of
/// stability, read off the closed-loop eigenvalues.
#[test]
fn the_small_machines_sweep_crowns_a_setting_with_margins() {
    let machine = small_mill();
    let src = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/gcode-samples/square.nc"
    ))
    .unwrap();
    let dims = [
        kv_dim(&["x", "y"], vec![6.0, 10.0, 20.0, 40.0]),
        Dimension {
            name: "xy.ks".into(),
            keys: ["x", "y"]
                .map(|a| format!("{a}.velocity_loop.ks_nm_s_per_rad"))
                .into(),
            values: vec![4.0, 16.0],
        },
    ];
    let mut points = sweep_on(&program(&src), &machine, &dims);
    let stiffest = [40.0, 4.0];
    let error = |q: &sweep::SweepPoint| match &q.result {
        PointResult::Ok { metrics, .. } => metrics.max_contour_um,
        _ => f64::INFINITY,
    };
    let by_error = points
        .iter()
        .min_by(|a, b| error(a).total_cmp(&error(b)))
        .unwrap();
    assert_eq!(by_error.values, stiffest);
    sweep::rank(&mut points, &Thresholds::default());
    assert_margins_flagged_and_by_eigenvalues(&points, &machine);
    let flags = flags_of(&points, &stiffest);
    assert!(
        flags.iter().any(
            |f| matches!(f, Flag::PhaseMargin { which: Loop::Position, deg, .. } if *deg < 15.0)
        ),
        "{flags:?}"
    );
    let PointResult::Ok {
        health, dominant, ..
    } = &points.iter().find(|q| q.values == stiffest).unwrap().result
    else {
        unreachable!()
    };
    assert_eq!(*dominant, Dominant::Ringing, "{health:?}");
    // The setting crowned is healthy, with every loop's margins.
    let best = &points[0];
    assert!(best.result.is_healthy(), "{best:?}");
    let PointResult::Ok { health, .. } = &best.result else {
        unreachable!()
    };
    for m in health.margins.iter().flat_map(|a| &a.loops) {
        assert!(
            m.phase_margin_deg >= 30.0 && m.gain_margin_db >= 6.0,
            "{m:?}"
        );
    }
    assert_ne!(best.values, stiffest);
}

#[test]
fn parallel_sweeps_equal_serial_ones() {
    let machine = MachineConfig::default_preset();
    let src = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/gcode-samples/profile-pocket.nc"
    ))
    .unwrap();
    let p = program(&src);
    let dims = [
        kv_dim(&["x", "y"], vec![0.8, 1.0, 1.2]),
        Dimension {
            name: "x.backlash_um".into(),
            keys: vec!["x.drive.backlash_um".into()],
            values: vec![0.0, 8.0],
        },
    ];
    let plan = PlanConfig::for_machine(&machine);
    let parallel = sweep::run(&p, &machine, &plan, &dims, true, &|| {});
    let serial = sweep::run(&p, &machine, &plan, &dims, false, &|| {});
    assert_eq!(parallel, serial);
    assert_eq!(parallel.len(), 6);
}

/// The planner's keys swept plan each setting with its own value. A line of 40 mm at F1000
/// on the heavy machine (Kv 1 m/min/mm, no feed-forward: a steady following error of
/// v/Kv): with a path acceleration of 0.005 m/s² the line cannot reach the feed — it peaks
/// below √(a·L) = 14.1 mm/s, a following error of about 14.1 / 16.67 = 0.85 mm (the
/// acceleration's own lag, a/Kv² = 18 µm, within the 5 % allowed) —, with 0.4 m/s² it
/// reaches 16.67 mm/s and lags 1.0 mm. And each row of a swept interpolation cycle is what
/// `check` gives on the machine with that cycle written in.
#[test]
fn the_planners_keys_swept_plan_each_setting_with_its_own_value() {
    // The preset has no path acceleration limit of its own: the sweep gives it one.
    let machine = MachineConfig::default_preset();
    assert_eq!(machine.interpolation.path_accel_m_per_s2, None);
    let line = program("G21 G90 G61\nG0 X0 Y0\nG1 X40 F1000\nM2\n");
    let accel = Dimension {
        name: "interpolation.path_accel_m_per_s2".into(),
        keys: vec!["interpolation.path_accel_m_per_s2".into()],
        values: vec![0.005, 0.4],
    };
    let points = sweep_on(&line, &machine, &[accel]);
    let following_x_um = |a: f64| match &points.iter().find(|q| q.values == [a]).unwrap().result {
        PointResult::Ok { metrics, .. } => metrics.max_following_um[0],
        other => panic!("{a}: {other:?}"),
    };
    let kv_per_s = 1000.0 / 60.0;
    // √(a·L) in mm/s (a in m/s², L in mm: √(1e3·a·L)), over Kv, in µm.
    let reachable_um = (1e3 * 0.005_f64 * 40.0).sqrt() / kv_per_s * 1e3;
    // A triangular profile peaks at √(a·L) exactly; the jerk's ramps take a little off it.
    let slow = following_x_um(0.005);
    assert!(
        slow < 1.05 * reachable_um && slow > 0.85 * reachable_um,
        "{slow} µm against {reachable_um} µm"
    );
    let fast = following_x_um(0.4);
    let steady_um = (1000.0 / 60.0) / kv_per_s * 1e3;
    assert!(
        (fast - steady_um).abs() < 0.01 * steady_um,
        "{fast} µm against {steady_um} µm"
    );

    let circle = program("G21 G90 G17 G61\nG0 X10 Y0\nG3 X10 Y0 I-10 J0 F3000\nM2\n");
    let cycle = Dimension {
        name: "interpolation.cycle_ms".into(),
        keys: vec!["interpolation.cycle_ms".into()],
        values: vec![2.0, 20.0],
    };
    for point in sweep_on(&circle, &machine, &[cycle]) {
        let PointResult::Ok { metrics, .. } = &point.result else {
            panic!("{point:?}")
        };
        let mut own = machine.clone();
        own.interpolation.cycle_ms = point.values[0];
        let run = check(&circle, &own, &CheckSettings::for_machine(&own)).unwrap();
        let checked_um = 1e6 * run.result.summary.max_contour_error_m;
        assert!(
            (metrics.max_contour_um - checked_um).abs() < 1e-9 * checked_um.max(1.0),
            "cycle {} ms: swept {} µm, checked {checked_um} µm",
            point.values[0],
            metrics.max_contour_um
        );
    }
}

/// Z's gain swept on the heavy machine, which simulates Z: a setting that makes Z unstable
/// is flagged on Z (it was said of X), and a stable one runs.
#[test]
fn an_unstable_z_is_flagged_on_z() {
    let machine = MachineConfig::default_preset();
    let p = program("G21 G90\nG0 X0 Y0 Z0\nG1 X10 Z-2 F500\nM2\n");
    let dims = [Dimension {
        name: "z.kv".into(),
        keys: vec!["z.position_loop.kv_m_per_min_per_mm".into()],
        values: vec![1.0, 10.0],
    }];
    let points = sweep_on(&p, &machine, &dims);
    // Z's edge by the closed-loop eigenvalues, its loops read as X's.
    let edge = {
        let mut as_x = machine.clone();
        as_x.x = machine.axis(AxisName::Z).clone();
        edge_of_stability_kv(&as_x)
    };
    assert!(edge > 1.0 && edge < 10.0, "{edge}");
    for q in &points {
        match (&q.result, q.values[0] > edge) {
            (PointResult::Unstable { axis, .. }, true) => assert_eq!(*axis, AxisName::Z),
            (PointResult::Ok { .. }, false) => {}
            (other, _) => panic!("{:?}: {other:?}", q.values),
        }
    }
}
