//! The feed planner and interpolator: closed-form cycle times, commands exactly on the
//! programmed geometry, and — for random programs — no axis limit ever exceeded.

use contourcheck::gcode::{InterpretOptions, parse_program};
use contourcheck::machine::MachineConfig;
use contourcheck::plan::{Commands, KinematicLimits, Plan, PlanConfig, ProfileKind, plan, sample};
use proptest::prelude::*;

fn plan_text(src: &str, profile: ProfileKind) -> (Plan, Commands, KinematicLimits) {
    let machine = MachineConfig::default_preset();
    let program = parse_program(src, "t.nc", &InterpretOptions::default()).unwrap();
    let limits = KinematicLimits::of(&machine);
    let mut config = PlanConfig::for_machine(&machine);
    config.profile = profile;
    let p = plan(&program, &limits, &config);
    let c = sample(&p);
    (p, c, limits)
}

/// The motion's time: the program's end is an exact stop, and the in-position wait after
/// it (the position loop's settling, not the planner's business here) comes on top.
fn motion_time_s(p: &Plan) -> f64 {
    let wait = p.plans.last().unwrap().wait_s;
    assert!(wait > 0.0, "the program's end waits for the axes");
    p.total_time_s - wait
}

#[test]
fn single_move_cycle_time_matches_the_closed_forms() {
    // 100 mm at 1000 mm/min (v = 16.667 mm/s) with a = 0.5 m/s², j = 5 m/s³.
    let v = 1000.0 / 60_000.0;
    let (a, j, l) = (0.5, 5.0, 0.1);
    // Trapezoid: cruise L/v plus one ramp's time v/a.
    let (p, _, _) = plan_text("G21 F1000\nG1 X100\n", ProfileKind::Trapezoid);
    assert!(
        (motion_time_s(&p) - (l / v + v / a)).abs() < 1e-12,
        "{}",
        motion_time_s(&p)
    );
    // S-curve: v²·j < a², so each ramp is a triangular acceleration pulse of 2·√(v/j);
    // the two ramps together cost the time of one: L/v + 2√(v/j).
    let (p, _, _) = plan_text("G21 F1000\nG1 X100\n", ProfileKind::SCurve);
    assert!(
        (motion_time_s(&p) - (l / v + 2.0 * (v / j).sqrt())).abs() < 1e-12,
        "{}",
        motion_time_s(&p)
    );
    // Ideal: the paper's velocity step, L/v exactly.
    let (p, _, _) = plan_text("G21 F1000\nG1 X100\n", ProfileKind::Ideal);
    assert!((motion_time_s(&p) - l / v).abs() < 1e-12);
    // A short move never reaches F: triangular speed, T = 2·√(L/a) for the trapezoid.
    let (p, _, _) = plan_text("G21 F1000\nG1 X0.1\n", ProfileKind::Trapezoid);
    assert!(
        (motion_time_s(&p) - 2.0 * (1e-4f64 / a).sqrt()).abs() < 1e-12,
        "{}",
        motion_time_s(&p)
    );
}

#[test]
fn feed_above_the_axis_limit_is_clamped_with_a_warning() {
    let (p, c, _) = plan_text("G21 F3000\nG1 X100\n", ProfileKind::SCurve);
    assert_eq!(p.warnings.len(), 1);
    assert_eq!(p.warnings[0].line, 2);
    let peak = c.x.peaks(c.dt_s).speed_m_per_s;
    assert!((peak - 1000.0 / 60_000.0).abs() < 1e-12, "{peak}");
}

#[test]
fn sampled_commands_lie_on_the_programmed_geometry() {
    for file in [
        "circle-test.nc",
        "profile-pocket.nc",
        "cam-flange.nc",
        "cam-adaptive.nc",
    ] {
        let src = std::fs::read_to_string(format!(
            "{}/gcode-samples/{file}",
            env!("CARGO_MANIFEST_DIR")
        ))
        .unwrap();
        let (p, c, _) = plan_text(&src, ProfileKind::SCurve);
        let mut worst = 0.0f64;
        for k in 0..c.len() {
            let seg = &p.segments[c.segment[k] as usize];
            let q = [c.x.pos_m[k], c.y.pos_m[k]];
            let along = 0.5; // the projection's turn hint; every sample arc here is single-turn or checked radially
            let proj = seg.project_xy(q, along);
            let off = proj.radial_m.unwrap_or(proj.signed_distance_m).abs();
            worst = worst.max(off);
        }
        assert!(
            worst < 1e-9,
            "{file}: a command lies {worst:e} m off its segment"
        );
    }
}

/// Checks every per-axis limit on a sampled program (see `plan` module docs for the rules:
/// continuous values within the limits; at junctions one extra cycle's worth of velocity or
/// acceleration step).
fn assert_within_limits(p: &Plan, c: &Commands, limits: &KinematicLimits, profile: ProfileKind) {
    let t = c.dt_s;
    let tol = 1e-9;
    for (i, axis) in [&c.x, &c.y].into_iter().enumerate() {
        let lim = &limits.axes[i];
        for k in 0..axis.len() {
            let v = axis.vel_m_per_s[k].abs();
            let a = axis.acc_m_per_s2[k].abs();
            assert!(
                v <= lim.rapid_m_per_s * (1.0 + tol),
                "axis {i} speed {v} at sample {k}"
            );
            let seg = &p.segments[c.segment[k] as usize];
            if seg.motion == contourcheck::path::Motion::Feed {
                assert!(
                    v <= lim.max_feed_m_per_s * (1.0 + tol) + 1e-12,
                    "axis {i} feed {v} at {k}"
                );
            }
            if profile != ProfileKind::Ideal {
                assert!(
                    a <= lim.accel_m_per_s2 * (1.0 + tol) + 1e-12,
                    "axis {i} accel {a} at {k}"
                );
            }
        }
        if profile == ProfileKind::Ideal {
            continue;
        }
        for k in 1..axis.len() {
            let crossing = c.segment[k] != c.segment[k - 1];
            let factor = if crossing { 2.0 } else { 1.0 };
            let dv = (axis.vel_m_per_s[k] - axis.vel_m_per_s[k - 1]).abs();
            assert!(
                dv <= factor * lim.accel_m_per_s2 * t * (1.0 + 1e-6) + 1e-12,
                "axis {i}: velocity step {dv} between samples {} and {k} (junction: {crossing})",
                k - 1
            );
            if profile == ProfileKind::SCurve {
                let da = (axis.acc_m_per_s2[k] - axis.acc_m_per_s2[k - 1]).abs();
                assert!(
                    da <= factor * lim.jerk_m_per_s3 * t * (1.0 + 1e-6) + 1e-12,
                    "axis {i}: acceleration step {da} between samples {} and {k} (junction: {crossing})",
                    k - 1
                );
            }
        }
    }
}

#[test]
fn samples_respect_the_limits() {
    for file in [
        "circle-test.nc",
        "square.nc",
        "profile-pocket.nc",
        "cam-flange.nc",
        "cam-adaptive.nc",
    ] {
        let src = std::fs::read_to_string(format!(
            "{}/gcode-samples/{file}",
            env!("CARGO_MANIFEST_DIR")
        ))
        .unwrap();
        for profile in [ProfileKind::SCurve, ProfileKind::Trapezoid] {
            let (p, c, limits) = plan_text(&src, profile);
            assert_within_limits(&p, &c, &limits, profile);
        }
    }
}

/// A random program: lines and arcs (both directions, both forms), feeds above and below
/// the axis limit, exact stop and blending, rapids.
fn random_program() -> impl Strategy<Value = String> {
    let step = prop_oneof![
        (-20.0..20.0f64, -20.0..20.0f64, 10.0..3000.0f64)
            .prop_map(|(x, y, f)| format!("G1 X{x:.3} Y{y:.3} F{f:.0}")),
        (-20.0..20.0f64, -20.0..20.0f64).prop_map(|(x, y)| format!("G0 X{x:.3} Y{y:.3}")),
        (
            prop::bool::ANY,
            -20.0..20.0f64,
            -20.0..20.0f64,
            0.5..30.0f64,
            prop::bool::ANY
        )
            .prop_map(|(cw, x, y, r, major)| {
                let r = if major { -r } else { r };
                format!("{} X{x:.3} Y{y:.3} R{r:.3}", if cw { "G2" } else { "G3" })
            }),
        (prop::bool::ANY, -5.0..5.0f64, -5.0..5.0f64)
            .prop_map(|(cw, i, j)| format!("{} I{i:.3} J{j:.3}", if cw { "G2" } else { "G3" })),
        prop::sample::select(vec![
            "G61".to_string(),
            "G64".to_string(),
            "G64 P0.05".to_string()
        ]),
    ];
    prop::collection::vec(step, 1..12)
        .prop_map(|steps| format!("G21 G90 F500\n{}\nM2\n", steps.join("\n")))
}

/// A CAM-style polyline: short chords (10 µm to 1 mm) turning by random small and large
/// angles, some collinear splits, at random feeds.
fn random_polyline() -> impl Strategy<Value = String> {
    let chord = (0.01..1.0f64, -0.3..0.3f64, prop::bool::weighted(0.1));
    (
        prop::collection::vec(chord, 2..400),
        100.0..3000.0f64,
        prop::bool::ANY,
    )
        .prop_map(|(chords, feed, sharp)| {
            let (mut x, mut y, mut heading) = (0.0f64, 0.0f64, 0.0f64);
            let mut out = format!("G21 G90 G64 F{feed:.0}\nG1 X0 Y0\n");
            for (length, turn, corner) in chords {
                // Now and then a real corner, else the gentle turns of a sampled curve.
                heading += if corner && sharp {
                    6.0 * turn
                } else {
                    0.05 * turn
                };
                x += length * heading.cos();
                y += length * heading.sin();
                out.push_str(&format!("X{x:.4} Y{y:.4}\n"));
            }
            out
        })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// Runs of short segments planned as one profile keep every axis within its limits,
    /// the turns at their vertices included.
    #[test]
    fn short_segment_runs_never_exceed_an_axis_limit(src in random_polyline(), scurve in prop::bool::ANY) {
        let profile = if scurve { ProfileKind::SCurve } else { ProfileKind::Trapezoid };
        let (p, c, limits) = plan_text(&src, profile);
        assert_within_limits(&p, &c, &limits, profile);
    }

    #[test]
    fn the_planner_never_exceeds_an_axis_limit(src in random_program(), scurve in prop::bool::ANY) {
        let Ok(program) = parse_program(&src, "r.nc", &InterpretOptions::default()) else {
            return Ok(()); // radius too small for the chord, etc.
        };
        let profile = if scurve { ProfileKind::SCurve } else { ProfileKind::Trapezoid };
        let machine = MachineConfig::default_preset();
        let limits = KinematicLimits::of(&machine);
        let mut config = PlanConfig::for_machine(&machine);
        config.profile = profile;
        let p = plan(&program, &limits, &config);
        let c = sample(&p);
        assert_within_limits(&p, &c, &limits, profile);
        // The plan ends where the program ends.
        let end = program.segments.last().map(|s| s.end_m);
        if let Some(end) = end {
            prop_assert!((c.x.pos_m[c.len() - 1] - end[0]).abs() < 1e-12);
            prop_assert!((c.y.pos_m[c.len() - 1] - end[1]).abs() < 1e-12);
        }
    }
}

/// Regression: during the in-position wait after an exact stop the ideal profile's sampled
/// command held x_ref but kept v_ref = F (a zero-duration ramp evaluated at its end gave
/// its start speed). The simulator integrates x_ref + v_ref·τ + a_ref·τ²/2 inside each
/// cycle, so the held command became a sawtooth on average F·T/2 ahead of the programme.
///
/// The invariant that catches it: each cycle's polynomial must arrive where the next sample
/// starts, except at the few instants where the profile itself jumps (the ideal profile's
/// velocity steps, the trapezoid's acceleration steps).
#[test]
fn each_cycle_of_the_command_arrives_where_the_next_one_starts() {
    // Ramp and reverse with exact stops: F1000 out, wait, back.
    let src = "G21 G61 F1000\nG1 X20\nG1 X0\nG1 X20\n";
    let f = 1000.0 / 60_000.0;
    for profile in [
        ProfileKind::Ideal,
        ProfileKind::Trapezoid,
        ProfileKind::SCurve,
    ] {
        let (p, c, limits) = plan_text(src, profile);
        let dt = c.dt_s;
        let (a_max, j_max) = (limits.axes[0].accel_m_per_s2, limits.axes[0].jerk_m_per_s3);
        // What a smooth profile may miss by within one cycle, and what counts as a jump.
        let (smooth, jumps_allowed) = match profile {
            // Velocity steps: two per segment, each missing by at most F·T.
            ProfileKind::Ideal => (1e-12, 2 * p.segments.len()),
            // Acceleration steps: four per segment, each missing by at most a·T²/2.
            ProfileKind::Trapezoid => (1e-12, 4 * p.segments.len()),
            // Jerk-limited: a cubic, missed by at most j·T³/6 per cycle.
            ProfileKind::SCurve => (j_max * dt.powi(3) / 6.0 * 1.01, 0),
        };
        let cap = match profile {
            ProfileKind::Ideal => f * dt * 1.0001,
            _ => a_max * dt * dt / 2.0 * 1.0001 + smooth,
        };
        let x = &c.x;
        let mut jumps = 0;
        for k in 0..c.len() - 1 {
            let arrives = x.pos_m[k] + x.vel_m_per_s[k] * dt + 0.5 * x.acc_m_per_s2[k] * dt * dt;
            let miss = (arrives - x.pos_m[k + 1]).abs();
            assert!(miss <= cap, "{profile}: cycle {k} misses by {miss:e} m");
            if miss > smooth {
                jumps += 1;
            }
        }
        assert!(
            jumps <= jumps_allowed,
            "{profile}: {jumps} cycles whose polynomial misses the next sample"
        );
        // And a standing command stands: zero velocity and acceleration while held.
        for k in 1..c.len() {
            if x.pos_m[k] == x.pos_m[k - 1] {
                assert_eq!((x.vel_m_per_s[k - 1], x.acc_m_per_s2[k - 1]), (0.0, 0.0));
            }
        }
    }
}

/// A CAM system splits moves and cuts curves into chords; the control's look-ahead plans
/// through them. 100 mm split into 100,000 collinear 1 µm blocks take as long as one block,
/// and a circle of 0.1 mm chords as long as the G3 circle it was cut from.
#[test]
fn short_blocks_are_planned_through_like_the_curve_they_sample() {
    let mut split = String::from("G21 G90 G64 F1000\nG1 X0 Y0\n");
    for i in 1..=100_000 {
        split.push_str(&format!("X{:.3}\n", i as f64 * 0.001));
    }
    for profile in [ProfileKind::SCurve, ProfileKind::Trapezoid] {
        let (whole, _, _) = plan_text("G21 G90 G64 F1000\nG1 X0 Y0\nX100\n", profile);
        let (pieces, _, _) = plan_text(&split, profile);
        // The motion to the microsecond (the in-position estimate after it integrates
        // block by block, so its rounding differs).
        assert!(
            (motion_time_s(&pieces) - motion_time_s(&whole)).abs() < 1e-6,
            "{profile}: {} s in pieces, {} s whole",
            motion_time_s(&pieces),
            motion_time_s(&whole)
        );
        assert_chords_take_the_arcs_time(0.1, profile);
    }
}

/// An R50 circle cut into chords of `chord_mm` (written to 0.1 µm) takes the time of the G3
/// circle within 1 %.
fn assert_chords_take_the_arcs_time(chord_mm: f64, profile: ProfileKind) {
    let (arc, _, _) = plan_text(&circle_program(None), profile);
    let (chords, _, _) = plan_text(&circle_program(Some(chord_mm)), profile);
    let expected_chords = (2.0 * std::f64::consts::PI * 50.0 / chord_mm).round() as usize;
    assert_eq!(
        chords.segments.len(),
        expected_chords + 1,
        "the chords and the rapid"
    );
    let ratio = chords.total_time_s / arc.total_time_s;
    assert!(
        (ratio - 1.0).abs() < 0.01,
        "{profile}, {chord_mm} mm chords: {} s, arc {} s",
        chords.total_time_s,
        arc.total_time_s
    );
}

/// CAM output rounds its points: an R50 circle cut into 12 µm chords and written to 0.1 µm
/// turns each vertex by up to 8 mrad of rounding against the curve's 0.24 mrad, yet it is
/// the circle, and a control's look-ahead runs it at the circle's speed.
#[test]
fn rounded_micro_chords_are_planned_like_the_curve() {
    for profile in [ProfileKind::SCurve, ProfileKind::Trapezoid] {
        assert_chords_take_the_arcs_time(0.012, profile);
    }
}

/// An R50 circle at F1000 from (50, 0): one G3, or chords of `chord_mm`.
pub fn circle_program(chord_mm: Option<f64>) -> String {
    let mut src = String::from("G21 G90 G64\nG0 X50 Y0\nG1 F1000\n");
    match chord_mm {
        None => src.push_str("G3 X50 Y0 I-50 J0\n"),
        Some(c) => {
            let n = (2.0 * std::f64::consts::PI * 50.0 / c).round() as usize;
            for i in 1..=n {
                let a = 2.0 * std::f64::consts::PI * i as f64 / n as f64;
                src.push_str(&format!("X{:.4} Y{:.4}\n", 50.0 * a.cos(), 50.0 * a.sin()));
            }
        }
    }
    src
}

fn plan_on(src: &str, profile: ProfileKind, machine: &MachineConfig) -> Plan {
    let program = parse_program(src, "t.nc", &InterpretOptions::default()).unwrap();
    let mut config = PlanConfig::for_machine(machine);
    config.profile = profile;
    plan(&program, &KinematicLimits::of(machine), &config)
}

/// An arc too tight for the feed runs at its centripetal limit v = √(η·a·R), η the machine's
/// `interpolation.arc_normal_share` (trapezoid: no jerk term).
#[test]
fn an_arc_runs_at_its_centripetal_limit() {
    let mut machine = MachineConfig::default_preset();
    let (a, r) = (0.5, 0.5e-3);
    for share in [0.5, 0.8] {
        machine.interpolation.arc_normal_share = share;
        let p = plan_on(
            "G21 G90 G64 F1000\nG0 X0.5 Y0\nG1 X0.5 Y0\nG3 X0.5 Y0 I-0.5 J0\n",
            ProfileKind::Trapezoid,
            &machine,
        );
        let arc = p.plans.last().unwrap();
        let expected = (share * a * r).sqrt();
        assert!(
            (arc.v_limit - expected).abs() < 1e-12,
            "η {share}: {} vs {expected}",
            arc.v_limit
        );
    }
}

/// A path acceleration limit below the axes' sets the ramps: a single move takes
/// L/v + v/a_path.
#[test]
fn a_path_acceleration_limit_sets_the_ramps() {
    let mut machine = MachineConfig::default_preset();
    machine.interpolation.path_accel_m_per_s2 = Some(0.2);
    let p = plan_on("G21 F1000\nG1 X100\n", ProfileKind::Trapezoid, &machine);
    let v = 1000.0 / 60_000.0;
    assert!((motion_time_s(&p) - (0.1 / v + v / 0.2)).abs() < 1e-12);
    // Above the axes' limit it changes nothing.
    machine.interpolation.path_accel_m_per_s2 = Some(5.0);
    let p = plan_on("G21 F1000\nG1 X100\n", ProfileKind::Trapezoid, &machine);
    assert!((motion_time_s(&p) - (0.1 / v + v / 0.5)).abs() < 1e-12);
}

/// A 90° corner between two long lines under trapezoids: each axis's velocity jumps by the
/// whole junction speed within one cycle, so the speed is a·T = 1 mm/s (below grbl's
/// junction deviation √(a·δ·sin(θ/2)/(1 − sin(θ/2))) = 3.5 mm/s for δ = 10 µm).
#[test]
fn a_corner_runs_at_its_junction_speed() {
    let p = plan_on(
        "G21 G64 F1000\nG1 X50\nG1 Y50\n",
        ProfileKind::Trapezoid,
        &MachineConfig::default_preset(),
    );
    let junction = p.plans[0].v_exit;
    assert!((junction - 0.5 * 0.002).abs() < 1e-12, "{junction}");
    assert!((p.plans[1].v_entry - junction).abs() < 1e-15);
}

/// LinuxCNC's G64 Q ("naive CAM" tolerance) sets how far chord vertices may stand off a
/// smooth curve and still be planned through; P alone sets it otherwise. 2 mm chords of an
/// R50 circle stand 10 µm off it: within Q 0.05 mm, beyond P 0.001 mm.
#[test]
fn g64_q_sets_which_chord_vertices_are_planned_through() {
    let chords = |modes: &str| {
        let mut src = format!("G21 G90 {modes}\nG0 X50 Y0\nG1 F1000\n");
        let n = (2.0 * std::f64::consts::PI * 50.0 / 2.0).round() as usize;
        for i in 1..=n {
            let a = 2.0 * std::f64::consts::PI * i as f64 / n as f64;
            src.push_str(&format!("X{:.4} Y{:.4}\n", 50.0 * a.cos(), 50.0 * a.sin()));
        }
        motion_time_s(&plan_text(&src, ProfileKind::SCurve).0)
    };
    let arc = motion_time_s(&plan_text(&circle_program(None), ProfileKind::SCurve).0);
    let with_q = chords("G64 P0.001 Q0.05");
    let p_only = chords("G64 P0.001");
    assert!(
        (with_q / arc - 1.0).abs() < 0.02,
        "Q: {with_q} s vs arc {arc} s"
    );
    assert!(p_only > 1.2 * arc, "P only: {p_only} s vs arc {arc} s");
}
