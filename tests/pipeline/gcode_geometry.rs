//! The interpreter's geometry against hand-computed values: every arc form, G91, G20,
//! offsets and coordinate rotation.

use std::f64::consts::{FRAC_PI_2, PI, TAU};

use contourcheck::gcode::{GcodeErrorKind, InterpretOptions, Program, parse_program};
use contourcheck::path::{Arc, Blend, Geometry, Motion, Segment};

fn run(src: &str) -> Program {
    parse_program(src, "t.nc", &InterpretOptions::default()).unwrap_or_else(|e| panic!("{e}"))
}

fn mm(v: [f64; 3]) -> [f64; 3] {
    v.map(|x| x * 1e3)
}

fn assert_close(a: f64, b: f64, tol: f64, what: &str) {
    assert!((a - b).abs() <= tol, "{what}: {a} vs {b}");
}

fn assert_point(p: [f64; 3], expect_mm: [f64; 3]) {
    let p = mm(p);
    for i in 0..3 {
        assert_close(
            p[i],
            expect_mm[i],
            1e-9,
            &format!("coordinate {i} of {p:?}"),
        );
    }
}

fn arc_of(s: &Segment) -> Arc {
    match s.geometry {
        Geometry::Arc(a) => a,
        other => panic!("not an arc: {other:?}"),
    }
}

#[test]
fn ij_arc_incremental_centre_ccw_quarter() {
    let p = run("G21 G90 G17 F100\nG0 X10 Y0\nG3 X0 Y10 I-10 J0\n");
    let a = arc_of(&p.segments[1]);
    assert_close(a.center_m[0], 0.0, 1e-15, "cx");
    assert_close(a.center_m[1], 0.0, 1e-15, "cy");
    assert_close(a.r_start_m, 0.010, 1e-15, "r");
    assert_close(a.sweep_rad, FRAC_PI_2, 1e-15, "sweep");
    assert_point(p.segments[1].end_m, [0.0, 10.0, 0.0]);
    assert_eq!(p.segments[1].line, 3);
}

#[test]
fn ij_arc_absolute_centre_with_g90_1() {
    let p = run("G21 G90 G90.1 F100\nG0 X10 Y5\nG2 X0 Y15 I0 J5\n");
    let a = arc_of(&p.segments[1]);
    assert_close(a.center_m[0], 0.0, 1e-15, "cx");
    assert_close(a.center_m[1], 0.005, 1e-15, "cy");
    // Clockwise from angle 0 to 90°: the long way, 270°.
    assert_close(a.sweep_rad, -1.5 * PI, 1e-12, "sweep");
}

#[test]
fn r_arcs_pick_the_centre_by_direction_and_sign() {
    // From (0,0) to (20,0) with |R| = 20: centre at (10, ±17.3205).
    let h = (400.0f64 - 100.0).sqrt();
    let cases = [
        ("G2", "R20", -h, -1.0), // CW minor arc: centre below the chord (right of +X)
        ("G3", "R20", h, 1.0),   // CCW minor: centre above
        ("G2", "R-20", h, -1.0), // CW major: centre above
        ("G3", "R-20", -h, 1.0), // CCW major: centre below
    ];
    for (g, r, cy, dir) in cases {
        let p = run(&format!("G21 F100\nG0 X0 Y0\n{g} X20 Y0 {r}\n"));
        let a = arc_of(&p.segments[0]);
        assert_close(a.center_m[0] * 1e3, 10.0, 1e-9, g);
        assert_close(a.center_m[1] * 1e3, cy, 1e-9, &format!("{g} {r} centre y"));
        let minor = 2.0 * (10.0f64 / 20.0).asin();
        let expected = if r.starts_with("R-") {
            TAU - minor
        } else {
            minor
        };
        assert_close(
            a.sweep_rad,
            dir * expected,
            1e-12,
            &format!("{g} {r} sweep"),
        );
    }
}

#[test]
fn full_circle_and_multi_turn_helix() {
    let p = run("G21 F100\nG0 X5 Y0 Z0\nG2 I-5 J0\nG3 X5 Y0 Z-3 I-5 J0 P3\n");
    let full = arc_of(&p.segments[1]);
    assert_close(full.sweep_rad, -TAU, 1e-15, "full circle, CW");
    let helix = &p.segments[2];
    assert_close(arc_of(helix).sweep_rad, 3.0 * TAU, 1e-12, "three turns");
    let expected = ((3.0 * TAU * 5.0f64).powi(2) + 9.0).sqrt() * 1e-3;
    assert_close(helix.length_m(), expected, 1e-15, "helix length");
    assert_point(helix.end_m, [5.0, 0.0, -3.0]);
}

#[test]
fn inches_scale_everything_including_feed_and_centres() {
    let p = run("G20 G90\nF10\nG0 X1 Y0\nG3 X0 Y1 I-1 J0\n");
    let a = arc_of(&p.segments[1]);
    assert_close(a.r_start_m, 0.0254, 1e-15, "radius");
    assert_close(
        p.segments[1].feed_m_per_s,
        10.0 * 25.4 / 60_000.0,
        1e-15,
        "feed",
    );
    assert_point(p.segments[1].end_m, [0.0, 25.4, 0.0]);
    // Within one block F is executed before G20/G21 (RS274/NGC's order), and a unit change
    // keeps the feed in force physically the same, as LinuxCNC does: F10 here is 10 mm/min.
    let p = run("G21\nG20 F10\nG1 X1\n");
    assert_close(
        p.segments[0].feed_m_per_s,
        10.0 / 60_000.0,
        1e-18,
        "same-block F",
    );
}

#[test]
fn incremental_moves_accumulate() {
    let p = run("G21 G91 F100\nG1 X10 Y5\nX-3 Y2\nG90 X0 Y0\n");
    assert_point(p.segments[0].end_m, [10.0, 5.0, 0.0]);
    assert_point(p.segments[1].end_m, [7.0, 7.0, 0.0]);
    assert_point(p.segments[2].end_m, [0.0, 0.0, 0.0]);
}

#[test]
fn g92_and_rotated_coordinate_system() {
    // G92 makes the current point (10, 10) read as (0, 0).
    let p = run("G21 F100\nG0 X10 Y10\nG92 X0 Y0\nG1 X5 Y0\n");
    assert_point(p.segments[1].end_m, [15.0, 10.0, 0.0]);
    // G10 L2 P1 R90 rotates G54 by 90°: program +X runs along machine +Y.
    let p = run("G21 F100\nG10 L2 P1 X100 Y0 R90\nG54 G0 X0 Y0\nG1 X10 Y0\nG3 X0 Y10 I-10 J0\n");
    assert_point(p.segments[0].end_m, [100.0, 0.0, 0.0]);
    assert_point(p.segments[1].end_m, [100.0, 10.0, 0.0]);
    let a = arc_of(&p.segments[2]);
    assert_close(a.center_m[0], 0.100, 1e-15, "rotated centre x");
    assert_close(a.center_m[1], 0.0, 1e-15, "rotated centre y");
    assert_point(p.segments[2].end_m, [90.0, 0.0, 0.0]);
}

#[test]
fn modes_feed_and_blending_are_carried() {
    let p = run("G21 F600\nG0 X1\nG64 P0.02 G1 X2\nG61 X3\nG4 P1.5\n");
    assert_eq!(p.segments[0].motion, Motion::Rapid);
    assert_eq!(
        p.segments[1].blend,
        Blend::Continuous {
            tolerance_m: Some(0.02e-3),
            naive_cam_m: None,
        }
    );
    assert_eq!(p.segments[2].blend, Blend::ExactStop);
    assert_eq!(p.segments[3].geometry, Geometry::Dwell { seconds: 1.5 });
    assert_close(p.segments[1].feed_m_per_s, 0.01, 1e-15, "F600 = 10 mm/s");
}

#[test]
fn arc_radius_tolerance_follows_linuxcnc() {
    // End radius 0.02 mm off: within the 0.0283 mm tolerance, kept as a slight spiral.
    let p = run("G21 F100\nG0 X10 Y0\nG3 X-10.02 Y0 I-10 J0\n");
    let a = arc_of(&p.segments[1]);
    assert_close(a.r_end_m - a.r_start_m, 0.02e-3, 1e-12, "spiral");
    // 0.05 mm off on a 10 mm radius: beyond 0.0283 mm and 0.1 %: refused.
    let e = parse_program(
        "G21 F100\nG0 X10 Y0\nG3 X-10.05 Y0 I-10 J0\n",
        "t.nc",
        &Default::default(),
    )
    .unwrap_err();
    assert!(
        matches!(e.first().kind, GcodeErrorKind::ArcRadiusMismatch { .. }),
        "{e}"
    );
    assert_eq!((e.first().pos.line, e.first().pos.column), (3, 4));
    // 0.05 mm off on a 100 mm radius: within 0.1 %, accepted.
    assert!(
        parse_program(
            "G21 F100\nG0 X100 Y0\nG3 X-100.05 Y0 I-100 J0\n",
            "t.nc",
            &Default::default()
        )
        .is_ok()
    );
}

#[test]
fn every_refused_construct_names_line_and_column() {
    let cases: [(&str, u32, u32); 14] = [
        ("G21\nG18 G2 X1 Z1 J1 F10\n", 2, 14),
        ("G21 F10\nG41 D1 G1 X10\n", 2, 1),
        ("G21 F10\n  G81 X1 Y1 Z-1 R1\n", 2, 3),
        ("G21\nG93 G1 X1 F1\n", 2, 1),
        ("G21\nG1 X#1 F10\n", 2, 5),
        ("G21\nO100 sub\n", 2, 1),
        ("G21\nO<sub> call\n", 2, 1),
        ("G21\nG1 X1 A5 F10\n", 2, 7),
        ("G21\nG68 X0 Y0 R30\n", 2, 1),
        ("G21 F10\nG10 L2 P1 R30\nG5.2 X1 Y1\n", 3, 1),
        ("G21\nG33 X1 K1\n", 2, 1),
        ("G21\nG1 X1 @2\n", 2, 7),
        ("G21\nG1 X1 F10 (unclosed\n", 2, 11),
        ("G21\nG1 X1 G0 Y1\n", 2, 7),
    ];
    for (src, line, col) in cases {
        let e = parse_program(src, "bad.nc", &Default::default()).unwrap_err();
        let first = e.first();
        assert_eq!(
            (first.pos.line, first.pos.column),
            (line, col),
            "{src:?}: {first}"
        );
        assert!(
            first
                .to_string()
                .starts_with(&format!("bad.nc:{line}:{col}: ")),
            "{first}"
        );
    }
}

#[test]
fn all_wrong_blocks_are_reported() {
    let src = "G21 F10\nG1 X1 A1\nG1 X2\nG41 X3\nG1 X4\nG1 Y#2\n";
    let e = parse_program(src, "t.nc", &Default::default()).unwrap_err();
    let lines: Vec<u32> = e.0.iter().map(|x| x.pos.line).collect();
    assert_eq!(lines, vec![2, 4, 6]);
}

#[test]
fn warnings_for_badly_conditioned_and_nearly_closed_arcs() {
    let p = run(
        "G21 F100\nG0 X0 Y0\nG2 X20 Y0.01 R10.0000001\nG0 X10 Y0\nG3 X10.0002 Y0.0001 I-10 J0\n",
    );
    assert_eq!(p.warnings.len(), 2, "{:?}", p.warnings);
    assert_eq!(p.warnings[0].line, 3);
    assert!(p.warnings[0].message.contains("near a half circle"));
    assert_eq!(p.warnings[1].line, 5);
    assert!(p.warnings[1].message.contains("nearly coincide"));
    // An exact half circle of R10: 1 µm off the chord's half moves the centre by
    // √(2 · 10 mm · 0.001 mm) = 0.141 mm, a finite figure (it said "inf").
    let p = run("G21 F100\nG0 X0 Y0\nG2 X20 Y0 R10\n");
    let message = &p.warnings[0].message;
    assert!(message.contains("moves it by 141 µm"), "{message}");
}

/// Block numbers are kept by source line, so that reports can show N40 beside line 4.
#[test]
fn block_numbers_are_kept_by_line() {
    let p = run("G21 G90 G17\nN10 G0 X0 Y0\n\nN40 G1 X10 F600\nG1 Y10\nN60 M2\n");
    assert_eq!(p.block_number(2), Some(10));
    assert_eq!(p.block_number(4), Some(40));
    assert_eq!(p.block_number(5), None);
    assert_eq!(p.block_number(6), Some(60));
}

/// RS274/NGC: a program opened by a `%` line ends at the next `%` line. What follows is not
/// run; lines there with words are named in a warning, as after M2, and blank or comment
/// lines are not. A `%` that does not open the program (words before it) demarcates nothing.
#[test]
fn a_percent_demarcated_program_ends_at_its_closing_percent() {
    let body = "G21 G90\nG1 X10 Y0 F100\n%\n";
    let ends = |p: &Program| p.segments.last().map(|s| mm(s.end_m));
    let after = run(&format!("(header)\n\n%\n{body}G1 X20 Y20\nG1 X30\n"));
    assert_eq!(after.segments.len(), 1);
    assert_point(after.segments[0].end_m, [10.0, 0.0, 0.0]);
    let said: Vec<&str> = after.warnings.iter().map(|w| w.message.as_str()).collect();
    assert!(
        said.iter()
            .any(|m| m.starts_with("2 block(s)") && m.contains("closing %")),
        "{said:?}"
    );
    let quiet = run(&format!("%\n{body}(done)\n\n; end\n"));
    assert_eq!(ends(&quiet), Some([10.0, 0.0, 0.0]));
    assert!(quiet.warnings.is_empty(), "{:?}", quiet.warnings);
    // After M2 the program has ended already: the blocks between are counted once.
    let m2 = run(&format!(
        "%\n{}M2\nG1 X5\n%\nG1 X7\n",
        &body[..body.len() - 2]
    ));
    assert_eq!(m2.segments.len(), 1);
    assert!(
        m2.warnings[0].message.starts_with("2 block(s)"),
        "{:?}",
        m2.warnings
    );
    // Words before the first `%`: it opened nothing, and the program runs to its end.
    let unopened = run("G21 G90\n%\nG1 X10 Y0 F100\n%\nG1 X20 Y0\n");
    assert_eq!(ends(&unopened), Some([20.0, 0.0, 0.0]));
}
