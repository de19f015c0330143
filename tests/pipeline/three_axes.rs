//! Three simulated axes, from physics: a circle in ZX on a Z with X's settings is the circle
//! in XY; a straight line in space on identical axes lags along itself only, and with one
//! axis's gain lowered leaves the path by what the two lags give; a helix takes its length
//! over the feed, within the ramps; a program and its SINUMERIK twin plan alike; a machine
//! that carries Z says where Z moves while cutting.

use contourcheck::analysis::circular::CircleFigures;
use contourcheck::check::{CheckRun, CheckSettings, check};
use contourcheck::gcode::{Dialect, InterpretOptions, Program, parse_program};
use contourcheck::machine::{MachineConfig, PlannedAxis, ZAxis};
use contourcheck::path::{Geometry, Plane};
use contourcheck::plan::{KinematicLimits, PlanConfig, plan};

fn program(text: &str) -> Program {
    parse_program(text, "t.nc", &InterpretOptions::default()).unwrap_or_else(|e| panic!("{e}"))
}

fn sinumerik(text: &str) -> Program {
    let options = InterpretOptions {
        dialect: Some(Dialect::Sinumerik),
        ..InterpretOptions::default()
    };
    parse_program(text, "t.mpf", &options).unwrap_or_else(|e| panic!("{e}"))
}

/// The preset with a Z that is X's axis: the same drive, loops, friction and limits, no
/// weight (a horizontal axis, as X).
fn z_as_x(kv_z: Option<f64>) -> MachineConfig {
    let mut m = MachineConfig::default_preset();
    let mut z = m.x.clone();
    z.lateral_shift = None;
    if let Some(kv) = kv_z {
        z.position_loop.kv_m_per_min_per_mm = kv;
    }
    m.z = ZAxis::Simulated(Box::new(z));
    m.x.lateral_shift = None;
    m
}

fn run(p: &Program, m: &MachineConfig) -> CheckRun {
    check(p, m, &CheckSettings::for_machine(m)).unwrap_or_else(|e| panic!("{e}"))
}

const G17_CIRCLES: &str = "G21 G17 G90 G94 G64 P0.005
G0 X100 Y-20 Z0
G1 Y0 F1000
G3 X100 Y0 I-100 J0
G1 Y20
G1 Y0
G2 X100 Y0 I-100 J0
G1 Y-20
M30
";

/// The same circles in ZX: X becomes Z, Y becomes X, Z becomes Y.
const G18_CIRCLES: &str = "G21 G18 G90 G94 G64 P0.005
G0 Z100 X-20 Y0
G1 X0 F1000
G3 Z100 X0 K-100 I0
G1 X20
G1 X0
G2 Z100 X0 K-100 I0
G1 X-20
M30
";

fn close(a: f64, b: f64, rel: f64, what: &str) {
    assert!(
        (a - b).abs() <= rel * a.abs().max(b.abs()),
        "{what}: {a} vs {b}"
    );
}

#[test]
fn a_circle_in_zx_on_a_z_with_xs_settings_is_the_circle_in_xy() {
    let m = z_as_x(None);
    let xy = run(&program(G17_CIRCLES), &m).result.circular;
    let zx = run(&program(G18_CIRCLES), &m).result.circular;
    assert_eq!((xy.circles.len(), zx.circles.len()), (2, 2));
    assert_eq!(zx.circles[0].plane, Plane::Zx);
    for (a, b) in xy.circles.iter().zip(&zx.circles) {
        let figures = |c: &CircleFigures| [c.g_um, c.f_min_um, c.f_max_um];
        for (what, (p, q)) in ["G", "F min", "F max"]
            .into_iter()
            .zip(figures(a).into_iter().zip(figures(b)))
        {
            // F max is a fraction of a micrometre: 1 % of the radius loss serves as its scale.
            let scale = a.f_min_um.abs();
            assert!(
                (p - q).abs() <= 0.01 * scale,
                "{what}: XY {p} µm, ZX {q} µm"
            );
        }
    }
    close(xy.pairs[0].h_um, zx.pairs[0].h_um, 0.01, "H");
}

/// A long straight move in space at F1000 on `m`; the samples in its steady middle.
fn line_3d(m: &MachineConfig) -> (CheckRun, Vec<usize>, [f64; 3]) {
    let p = program("G21 G90 G94 G64\nG0 X0 Y0 Z0\nG1 X300 Y200 Z-150 F1000\nM30\n");
    let r = run(&p, m);
    let l = (300f64 * 300.0 + 200.0 * 200.0 + 150.0 * 150.0).sqrt();
    let t = [300.0 / l, 200.0 / l, -150.0 / l];
    let feed = 1000.0 / 60_000.0;
    let c = &r.commands;
    let steady: Vec<usize> = (0..c.len())
        .filter(|&k| {
            let speed = (c.x.vel_m_per_s[k].powi(2)
                + c.y.vel_m_per_s[k].powi(2)
                + c.z.vel_m_per_s[k].powi(2))
            .sqrt();
            // At the feed, and for 2 s already (30 time constants of the loops).
            (speed - feed).abs() < 1e-12 && k >= 1000 && {
                let back = k - 1000;
                (c.x.vel_m_per_s[back] - feed * t[0]).abs() < 1e-12
            }
        })
        .collect();
    assert!(steady.len() > 5000, "{} steady samples", steady.len());
    (r, steady, t)
}

#[test]
fn a_line_in_space_on_three_identical_axes_lags_along_itself_only() {
    let (r, steady, _) = line_3d(&z_as_x(None));
    let worst = steady
        .iter()
        .map(|&k| r.contour.error_m[k].abs())
        .fold(0.0, f64::max);
    // Each axis lags v_i/Kv: the lag vector is the velocity over Kv, along the path.
    assert!(worst < 1e-8, "steady contour error {worst:e} m");
}

#[test]
fn a_line_in_space_with_z_slower_leaves_the_path_by_the_lags_difference() {
    let (kv, kv_z) = (1000.0 / 60.0, 0.8 * 1000.0 / 60.0);
    let (r, steady, t) = line_3d(&z_as_x(Some(0.8)));
    // The actual point lags the command by e_i = v_i/Kv_i; its distance from the line is
    // e's part across the path.
    let feed = 1000.0 / 60_000.0;
    let e = [feed * t[0] / kv, feed * t[1] / kv, feed * t[2] / kv_z];
    let along: f64 = (0..3).map(|i| e[i] * t[i]).sum();
    let normal = (0..3)
        .map(|i| (e[i] - along * t[i]).powi(2))
        .sum::<f64>()
        .sqrt();
    for &k in steady.iter().step_by(97) {
        close(
            r.contour.error_m[k].abs(),
            normal,
            0.01,
            "steady normal deviation",
        );
        // The difference is Z's alone: it lies in the vertical plane of the path, across
        // the working plane, not beside the path in it.
        close(r.contour.across_m[k].abs(), normal, 0.01, "across");
        assert!(r.contour.in_plane_m[k].abs() < 0.01 * normal);
    }
}

#[test]
fn a_helix_takes_its_length_over_the_feed_within_the_ramps() {
    let p = program("G21 G17 G90 G94 G61\nG0 X50 Y0 Z0\nG2 X50 Y0 Z-20 I-50 J0 P4 F600\nM30\n");
    let m = MachineConfig::default_preset();
    let planned = plan(&p, &KinematicLimits::of(&m), &PlanConfig::for_machine(&m));
    let helix = planned
        .segments
        .iter()
        .position(|s| matches!(s.geometry, Geometry::Arc(_)))
        .expect("a helix");
    let length = ((std::f64::consts::TAU * 0.05 * 4.0).powi(2) + 0.02f64.powi(2)).sqrt();
    let feed = 600.0 / 60_000.0;
    let sp = &planned.plans[helix];
    assert!((sp.length_m - length).abs() < 1e-12, "{} m", sp.length_m);
    // A jerk-limited ramp from rest to v costs at most v/a + a/j beyond the time at v.
    let d = sp.dynamics;
    let ramp = feed / d.accel + d.accel / d.jerk;
    let t = sp.duration_s;
    assert!(
        t >= length / feed && t <= length / feed + ramp,
        "{t} s for {} s of cruise and {ramp} s of ramps",
        length / feed
    );
    // And the feed is the speed along the helix: at the cruise, the 3-D speed is F.
    let c = contourcheck::plan::sample(&planned);
    let k = ((sp.t_start_s + sp.duration_s / 2.0) / c.dt_s) as usize;
    let speed =
        (c.x.vel_m_per_s[k].powi(2) + c.y.vel_m_per_s[k].powi(2) + c.z.vel_m_per_s[k].powi(2))
            .sqrt();
    assert!((speed - feed).abs() < 1e-12, "{speed} m/s");
}

#[test]
fn a_program_and_its_sinumerik_twin_plan_the_same_path_in_space() {
    // Three turns of a helix down 12 mm, a quarter circle in ZX (G18, from Z towards X) and
    // one in YZ (G19, clockwise from Y towards −Z); the 840D gives the turns with TURN= and
    // the quarters by opening angle and by radius. Its rapid keeps the path mode in force
    // (G64), where RS274/NGC's stops exactly: G9 makes the twin's rapid stop as well.
    let rs274 = program(
        "G21 G90 G94 G64\nG17 G0 X50 Y0 Z5\nG1 Z0 F300\n\
         G2 X50 Y0 Z-12 I-50 J0 P3 F600\n\
         G18 G3 Z-22 X40 K0 I-10\nG19 G2 Y-10 Z-12 J0 K10\nG17 G1 X0 Y0 Z60\nM30\n",
    );
    let twin = sinumerik(
        "N10 G710 G90 G94 G64\nN20 G17 G0 X50 Y0 Z5 G9\nN30 G1 Z0 F300\n\
         N40 G2 X50 Y0 Z-12 I-50 J0 TURN=2 F600\n\
         N50 G18 G3 Z-22 X40 AR=90\nN60 G19 G2 Y-10 Z-12 CR=10\nN70 G17 G1 X0 Y0 Z60\nN80 M30\n",
    );
    let m = MachineConfig::default_preset();
    let cfg = PlanConfig::for_machine(&m);
    let (a, b) = (
        plan(&rs274, &KinematicLimits::of(&m), &cfg),
        plan(&twin, &KinematicLimits::of(&m), &cfg),
    );
    assert_eq!(a.segments.len(), b.segments.len());
    let planes: Vec<Plane> = a
        .segments
        .iter()
        .filter(|s| matches!(s.geometry, Geometry::Arc(_)))
        .map(|s| s.plane())
        .collect();
    assert_eq!(planes, [Plane::Xy, Plane::Zx, Plane::Yz]);
    for (s, t) in a.segments.iter().zip(&b.segments) {
        assert_eq!(s.plane(), t.plane());
        for i in 0..3 {
            assert!((s.start_m[i] - t.start_m[i]).abs() < 1e-12);
            assert!((s.end_m[i] - t.end_m[i]).abs() < 1e-12);
        }
        if let (Geometry::Arc(p), Geometry::Arc(q)) = (s.geometry, t.geometry) {
            assert!((p.sweep_rad - q.sweep_rad).abs() < 1e-12, "{p:?} {q:?}");
            assert!((p.center_m[0] - q.center_m[0]).abs() < 1e-12, "{p:?} {q:?}");
            assert!((p.center_m[1] - q.center_m[1]).abs() < 1e-12, "{p:?} {q:?}");
            assert!((p.r_start_m - 0.01).abs() < 1e-12 || (p.r_start_m - 0.05).abs() < 1e-12);
        }
    }
    // The quarter in ZX runs from Z towards X about (Z −12, X 40): through Z −12 − 10·sin 45°.
    let zx = &a.segments[3];
    let mid = zx.eval(zx.length_m() / 2.0, zx.length_m()).pos;
    let h = 0.01 * std::f64::consts::FRAC_1_SQRT_2;
    assert!((mid[2] - (-0.012 - h)).abs() < 1e-12 && (mid[0] - (0.040 + h)).abs() < 1e-12);
    assert!((a.total_time_s - b.total_time_s).abs() < 1e-9);
}

/// The preset with its Z carried (planned, not simulated), as before the preset had a Z.
fn z_carried() -> MachineConfig {
    let mut m = MachineConfig::default_preset();
    m.z = ZAxis::Carried(PlannedAxis {
        limits: m.z.limits().clone(),
    });
    m
}

#[test]
fn simulating_a_standing_z_leaves_the_xy_circles_as_they_were() {
    // X and Y do not feel Z: a program cut at one depth has the same figures whether Z is
    // simulated (holding its weight at rest) or carried — blocks at one height are measured
    // in X and Y either way.
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/gcode-samples/circle-test.nc"
    ))
    .unwrap();
    let p = program(&text);
    let (simulated, carried) = (
        run(&p, &MachineConfig::default_preset()).result,
        run(&p, &z_carried()).result,
    );
    assert_eq!(simulated.circular.circles.len(), 2);
    assert_eq!(
        simulated.summary.max_contour_error_m,
        carried.summary.max_contour_error_m
    );
    assert_eq!(
        simulated.summary.rms_contour_error_m,
        carried.summary.rms_contour_error_m
    );
    assert_eq!(simulated.summary.max_components_m, None);
    let spots = |r: &contourcheck::check::CheckResult| -> Vec<(u32, f64)> {
        r.hotspots.iter().map(|h| (h.line, h.error_um)).collect()
    };
    assert_eq!(spots(&simulated), spots(&carried));
    for (a, b) in simulated
        .circular
        .circles
        .iter()
        .zip(&carried.circular.circles)
    {
        for (p, q) in [
            (a.g_um, b.g_um),
            (a.f_min_um, b.f_min_um),
            (a.f_max_um, b.f_max_um),
        ] {
            assert!((p - q).abs() < 1e-6, "{p} µm against {q} µm");
        }
    }
    // The radius loss of a Kv = 1 /min loop at F1000 on R100 is the paper's ~5 µm.
    assert!((carried.circular.circles[0].f_min_um + 5.07).abs() < 0.01);
    // The simulated Z holds still under its weight while the circles are cut: its largest
    // following error while cutting is its lag in the plunge at F500, v/Kv = 500 µm.
    let [cutting, _] = simulated.summary.z_following_error_m.expect("Z simulated");
    assert!((cutting - 500e-6).abs() < 5e-6, "{cutting:e} m");
    assert!(carried.summary.z_following_error_m.is_none());
}

#[test]
fn a_machine_that_carries_z_names_the_lines_where_z_moves_along_the_contour() {
    // Line 3 plunges (Z alone: no contour), line 4 is a helix and line 5 a slope: both move
    // Z along the contour, which a machine without a simulated Z cannot follow.
    let p = program(
        "G21 G17 G90 G94 G64\nG0 X10 Y0 Z5\nG1 Z0 F300\nG2 X10 Y0 Z-2 I-10 J0 F600\n\
         G1 X20 Y5 Z-3\nG1 X30\nM30\n",
    );
    let small = MachineConfig::preset("small-table").unwrap();
    assert!(!small.simulates_z());
    let warned: Vec<u32> = run(&p, &small)
        .result
        .plan
        .warnings
        .iter()
        .filter(|w| w.message.contains("carries Z"))
        .map(|w| w.line)
        .collect();
    assert_eq!(warned, [4, 5]);
    // The preset simulates Z: nothing to warn.
    let hvmc = run(&p, &MachineConfig::default_preset()).result;
    assert!(
        !hvmc
            .plan
            .warnings
            .iter()
            .any(|w| w.message.contains("carries Z"))
    );
}
