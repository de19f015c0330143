//! SINUMERIK 840D programs: the same contour written in both dialects gives the same path, and
//! what the dialect front end does not read is refused at its line and column.

use contourcheck::gcode::{Dialect, InterpretOptions, Program, parse_program};
use contourcheck::path::Geometry;

fn parse(text: &str, file: &str) -> Program {
    parse_program(text, file, &InterpretOptions::default())
        .unwrap_or_else(|e| panic!("{file}: {e}"))
}

/// A contour with lines and arcs both ways, by centre and by radius, absolute and
/// incremental: RS274/NGC writes it one way, the SINUMERIK program the other wherever the
/// dialect allows.
const RS274: &str = "G21 G17 G90 G94 G64 P0.05
G0 X0 Y0
G1 X40 F1000
G3 X50 Y10 I0 J10
G1 Y30
G2 X40 Y40 R-10
G91 G1 X-30
G90 G3 X0 Y30 I0 J-10
G61 G1 Y0
M2
";

const SINUMERIK: &str = "%_N_CONTOUR_MPF
;$PATH=/_N_MPF_DIR
N10 G710 G17 G90 G94 ; metric, feeds in mm/min
N20 G641 ADIS=0.05 DEF REAL SIDE=40
N25 R1=10
N30 G0 X=0 Y0 MSG(\"contour\")
N40 G1 X=SIDE F=100*R1
N50 G3 X=SIDE+R1 Y=R1 CR=R1
N60 G1 Y30
N70 G2 X40 Y40 I=IC(-10) J0
N80 G1 X=IC(-30)
N90 G3 X0 Y30 I=AC(10) J=AC(30)
N100 G60 G1 Y0
N110 M30
";

#[test]
fn the_same_contour_in_both_dialects_gives_the_same_path() {
    let a = parse(RS274, "contour.ngc");
    let b = parse(SINUMERIK, "contour.mpf");
    assert_eq!(a.segments.len(), b.segments.len());
    for (sa, sb) in a.segments.iter().zip(&b.segments) {
        for k in 0..3 {
            assert!(
                (sa.start_m[k] - sb.start_m[k]).abs() < 1e-9,
                "{sa:?}\n{sb:?}"
            );
            assert!((sa.end_m[k] - sb.end_m[k]).abs() < 1e-9, "{sa:?}\n{sb:?}");
        }
        assert_eq!(sa.motion, sb.motion);
        assert_eq!(sa.blend, sb.blend, "line {}", sb.line);
        assert!((sa.feed_m_per_s - sb.feed_m_per_s).abs() < 1e-12);
        match (sa.geometry, sb.geometry) {
            (Geometry::Arc(x), Geometry::Arc(y)) => {
                assert!((x.center_m[0] - y.center_m[0]).abs() < 1e-9, "{x:?}\n{y:?}");
                assert!((x.center_m[1] - y.center_m[1]).abs() < 1e-9, "{x:?}\n{y:?}");
            }
            (Geometry::Line, Geometry::Line) => {}
            (x, y) => panic!("{x:?} against {y:?}"),
        }
    }
}

#[test]
fn the_dialect_is_told_from_the_file_or_named() {
    // `G710` alone marks a SINUMERIK program; named, the dialect holds whatever the file.
    let text = "N10 G710 G90\nN20 G1 X10 F500\nM30\n";
    assert_eq!(Dialect::of("part.nc", text), Dialect::Sinumerik);
    assert_eq!(parse(text, "part.nc").segments.len(), 1);
    let as_rs274 = InterpretOptions {
        dialect: Some(Dialect::Rs274),
        ..InterpretOptions::default()
    };
    let err = parse_program(text, "part.nc", &as_rs274)
        .unwrap_err()
        .to_string();
    assert!(err.contains("G710"), "{err}");
}

#[test]
fn what_the_dialect_front_end_does_not_read_is_refused_at_its_line() {
    let text = "%_N_P_MPF\nN10 G710 G90\nN20 CASE R1 OF 1 GOTOF A DEFAULT GOTOF B\nN30 G1 X=$AA_IW[X] F100\nN40 ROTS X30 Y45\n\
                N50 CYCLE72(\"C1\")\nN60 ASPLINE X1 Y2\nN70 G41 X5\nN80 L123 P2\nN90 CIP X1 Y1 I1=2 J1=3\nM30\n";
    let err = parse_program(text, "p.mpf", &InterpretOptions::default())
        .unwrap_err()
        .to_string();
    for (place, word) in [
        ("p.mpf:3:5", "CASE"),
        ("p.mpf:4:10", "$AA_IW"),
        ("p.mpf:5:5", "ROTS"),
        ("p.mpf:6:5", "CYCLE72"),
        ("p.mpf:7:5", "ASPLINE"),
        ("p.mpf:8:5", "G41"),
        ("p.mpf:9:5", "L123"),
        ("p.mpf:10:5", "CIP"),
    ] {
        assert!(
            err.contains(&format!("{place}: {word}")),
            "{place} {word}:\n{err}"
        );
    }
}

#[test]
fn a_frame_places_the_workpiece_as_the_program_would_place_it_by_hand() {
    // A 40 × 20 rectangle and an arc, written in the workpiece's coordinates under
    // TRANS X100 Y50 and AROT RPL=30; in RS274/NGC, the same corners turned and shifted.
    let place = |x: f64, y: f64| {
        let (s, c) = 30f64.to_radians().sin_cos();
        (100.0 + c * x - s * y, 50.0 + s * x + c * y)
    };
    let sinumerik = "N10 G710 G17 G90 G94 G64\nN20 G0 X0 Y0 Z0\nN30 TRANS X100 Y50\n\
                     N40 AROT RPL=30\nN50 G1 X40 Y0 F800\nN60 Y20\nN70 G3 X20 Y40 I-20 J0\n\
                     N80 G1 X=IC(-20)\nN90 G91 Y-40\nN100 TRANS\nN110 G90 G1 X0 Y0\nN120 M30\n";
    let corners = [
        (40.0, 0.0),
        (40.0, 20.0),
        (20.0, 40.0),
        (0.0, 40.0),
        (0.0, 0.0),
    ];
    let p: Vec<(f64, f64)> = corners.iter().map(|&(x, y)| place(x, y)).collect();
    let (ci, cj) = {
        let (s, c) = 30f64.to_radians().sin_cos();
        (c * -20.0, s * -20.0)
    };
    let rs274 = format!(
        "G21 G17 G90 G94 G64\nG0 X0 Y0 Z0\nG1 X{:.9} Y{:.9} F800\nX{:.9} Y{:.9}\n\
         G3 X{:.9} Y{:.9} I{ci:.9} J{cj:.9}\nG1 X{:.9} Y{:.9}\nX{:.9} Y{:.9}\nX0 Y0\nM2\n",
        p[0].0, p[0].1, p[1].0, p[1].1, p[2].0, p[2].1, p[3].0, p[3].1, p[4].0, p[4].1
    );
    let a = parse(&rs274, "framed.ngc");
    let b = parse(sinumerik, "framed.mpf");
    assert_eq!(a.segments.len(), b.segments.len());
    for (sa, sb) in a.segments.iter().zip(&b.segments) {
        for k in 0..2 {
            assert!((sa.end_m[k] - sb.end_m[k]).abs() < 1e-9, "{sa:?}\n{sb:?}");
        }
    }
}

#[test]
fn loops_jumps_and_conditions_run_as_the_control_runs_them() {
    // Three strokes by FOR, a fourth by WHILE, one skipped by GOTOF, one chosen by IF/ELSE:
    // the same six lines as written out by hand.
    let sinumerik = "%_N_LOOPS_MPF\nN10 G710 G90 G17 G94 G64 DEF INT I\nN20 G0 X0 Y0 Z0\n\
                     N30 FOR I=1 TO 3\nN40 G1 X=10*I Y=I F500\nN50 ENDFOR\nN60 R1=4\n\
                     N70 WHILE R1<5\nN80 G1 X=10*R1 Y=R1\nN90 R1=R1+1\nN100 ENDWHILE\n\
                     N110 GOTOF SKIP\nN120 G1 X999\nSKIP: IF R1==5\nN140 G1 X50 Y5\nN150 ELSE\n\
                     N160 G1 X777\nN170 ENDIF\nN180 REPEAT\nN190 R1=R1+1\nN200 UNTIL R1>=7\n\
                     N210 G1 X=10*R1 Y=R1\nN220 M30\n";
    let rs274 = "G21 G90 G17 G94 G64\nG0 X0 Y0 Z0\nG1 X10 Y1 F500\nG1 X20 Y2\nG1 X30 Y3\n\
                 G1 X40 Y4\nG1 X50 Y5\nG1 X70 Y7\nM2\n";
    let a = parse(rs274, "loops.ngc");
    let b = parse(sinumerik, "loops.mpf");
    let ends = |p: &Program| p.segments.iter().map(|s| s.end_m).collect::<Vec<_>>();
    assert_eq!(ends(&a), ends(&b));
    // A loop that never ends is an error, not a hang.
    let forever = "N10 G710 G90\nN20 LOOP\nN30 ENDLOOP\nM30\n";
    let err = parse_program(forever, "forever.mpf", &InterpretOptions::default())
        .unwrap_err()
        .to_string();
    assert!(err.contains("does not end"), "{err}");
}

/// The segments' end points, rounded to the nanometre.
fn ends_nm(p: &Program) -> Vec<[i64; 3]> {
    p.segments
        .iter()
        .map(|s| s.end_m.map(|v| (v * 1e9).round() as i64))
        .collect()
}

#[test]
fn subprograms_of_the_same_file_run_with_their_parameters_and_repetitions() {
    // An archive as the control writes it: the main program, then its subprograms, each
    // under its own header. POCK takes a depth (defaulted) and an offset; L100 steps Y by
    // an R-parameter it shares with the caller; its own DEF variable ends with it.
    let archive = "%_N_MAIN_MPF\n;$PATH=/_N_WKS_DIR/_N_PART_WPD\nN10 G710 G90 G17 G94 G64\n\
                   N20 G0 X0 Y0 Z5\nN30 R10=0\nN40 POCK(, 20)\nN50 L100 P3\nN60 POCK(4, 40)\n\
                   N70 CALL \"POCK\"\nN80 G0 Z50\nN90 M30\n\
                   %_N_POCK_SPF\n;$PATH=/_N_WKS_DIR/_N_PART_WPD\nPROC POCK(REAL DEPTH=2, REAL AT) SAVE\n\
                   N10 G1 Z=-DEPTH F300\nN20 G1 X=AT+10 Y=R10\nN30 G0 Z5\nN40 RET\n\
                   %_N_L100_SPF\nN10 DEF REAL STEP=5\nN20 R10=R10+STEP\nN30 G1 X=IC(1) Y=R10 F600\nN40 M17\n\
                   %_N_MAIN_INI\nR1=5\n";
    let written_out = "G21 G90 G17 G94 G64\nG0 X0 Y0 Z5\n\
                       G1 Z-2 F300\nG1 X30 Y0\nG0 Z5\n\
                       G1 X31 Y5 F600\nG1 X32 Y10\nG1 X33 Y15\n\
                       G1 Z-4 F300\nG1 X50 Y15\nG0 Z5\n\
                       G1 Z-2\nG1 X10 Y15\nG0 Z5\nG0 Z50\nM2\n";
    let a = parse(written_out, "by-hand.ngc");
    let b = parse(archive, "part.arc.mpf");
    assert_eq!(ends_nm(&a), ends_nm(&b));
    // Each move keeps the line it was written on: the subprogram's, in the same file.
    assert_eq!(b.segments[1].line, 15, "POCK's first move");
    assert_eq!(b.segments[4].line, 22, "L100's move");
    // The INI section is not a program: said, not silently passed over.
    assert!(
        b.warnings
            .iter()
            .any(|w| w.line == 24 && w.message.contains("MAIN_INI is not a program")),
        "{:?}",
        b.warnings
    );
}

#[test]
fn subprograms_from_the_programs_folder_are_named_with_their_own_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let main = "N10 G710 G90 G17 G94\nN20 G0 X0 Y5\nN30 L1 P2\nN40 SIDE\nN50 M30\n";
    std::fs::write(dir.path().join("MAIN.MPF"), main).unwrap();
    std::fs::write(
        dir.path().join("L1.SPF"),
        "; one step\nG91 G1 X10 F500\nG90\nM17\n",
    )
    .unwrap();
    std::fs::write(dir.path().join("side.spf"), "G1 Y20 F500\nRET\n").unwrap();
    let options = InterpretOptions {
        subprogram_folder: Some(dir.path().to_path_buf()),
        ..InterpretOptions::default()
    };
    let p = parse_program(main, "MAIN.MPF", &options).unwrap();
    let ends: Vec<[i64; 3]> = ends_nm(&p);
    let mm = |x: i64, y: i64| [x * 1_000_000, y * 1_000_000, 0];
    assert_eq!(ends[1..], [mm(10, 5), mm(20, 5), mm(20, 20)]);
    let l1 = p.source_line(p.segments[1].line);
    assert!(l1.file.unwrap().ends_with("L1.SPF"), "{l1}");
    assert_eq!(l1.line, 2);
    let side = p.source_line(p.segments[3].line);
    assert!(side.file.unwrap().ends_with("side.spf"), "{side}");
    assert_eq!(side.line, 1);
    assert_eq!(p.source_line(p.segments[0].line).file, None);

    // An error in a subprogram's file names that file and line (once, though the
    // subprogram runs twice); one in its structure also stops the call, named at the call;
    // a call of one that is not there names the call.
    std::fs::write(dir.path().join("L1.SPF"), "G1 X10 F500\nG1 X=Q7\nM17\n").unwrap();
    let err = parse_program(main, "MAIN.MPF", &options)
        .unwrap_err()
        .to_string();
    assert_eq!(err.matches("L1.SPF:2:6: Q7").count(), 1, "{err}");
    std::fs::write(dir.path().join("L1.SPF"), "G1 X10 F500\nENDIF\nM17\n").unwrap();
    let err = parse_program(main, "MAIN.MPF", &options)
        .unwrap_err()
        .to_string();
    assert!(err.contains("L1.SPF:2:"), "{err}");
    assert!(
        err.contains("MAIN.MPF:3:5: L1: the subprogram does not run"),
        "{err}"
    );
    let err = parse_program("G710\nN10 NOSUCH(1)\nM30\n", "m.mpf", &options)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("m.mpf:2:5: NOSUCH: neither a SINUMERIK command this reads nor a subprogram"),
        "{err}"
    );
}

#[test]
fn a_subprogram_that_calls_itself_stops_at_the_controls_depth() {
    let text = "%_N_M_MPF\nG710 G90\nDOWN\nM30\n%_N_DOWN_SPF\nG91 G1 X1 F100\nDOWN\nRET\n";
    let err = parse_program(text, "m.mpf", &InterpretOptions::default())
        .unwrap_err()
        .to_string();
    assert!(err.contains("program levels"), "{err}");
    // With a condition the recursion ends: four levels, four moves.
    let text = "%_N_M_MPF\nG710 G90 G0 X0 Y0\nR1=0\nDOWN\nM30\n%_N_DOWN_SPF\nG91 G1 X1 F100\n\
                R1=R1+1\nIF R1<4 GOTOF AGAIN\nRET\nAGAIN:\nDOWN\nRET\n";
    let p = parse(text, "m.mpf");
    assert_eq!(p.segments.len(), 4);
    assert!((p.segments[3].end_m[0] - 0.004).abs() < 1e-12);
}

#[test]
fn cycle832_rounds_corners_within_its_tolerance_as_g642_does() {
    let blends = |text: &str| {
        parse(text, "hsc.mpf")
            .segments
            .iter()
            .map(|s| s.blend)
            .collect::<Vec<_>>()
    };
    let by_cycle = blends(
        "G710 G90 G0 X0 Y0\nCYCLE832(0.02, _FINISH, 1)\nG1 X10 F900\nY10\nCYCLE832(0.1, _ROUGH)\n\
         X0\nY0\nCYCLE832()\nX10\nY10\nM30\n",
    );
    let by_codes = blends(
        "G710 G90 G0 X0 Y0\nG642 CTOL=0.02\nG1 X10 F900\nY10\nCTOL=0.1\nX0\nY0\nG64\nX10\nY10\nM30\n",
    );
    assert_eq!(by_cycle, by_codes);
    let p = parse(
        "G710\nCYCLE832(0.02, _FINISH, 1)\nG1 X1 F100\nM30\n",
        "w.mpf",
    );
    assert!(
        p.warnings
            .iter()
            .any(|w| w.line == 2 && w.message.contains("compressor")),
        "{:?}",
        p.warnings
    );
}

#[test]
fn the_840d_sample_is_its_subprogram_written_out_twice() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/gcode-samples/boss-840d.mpf");
    let sample = std::fs::read_to_string(path).unwrap();
    let p = parse(&sample, "boss-840d.mpf");
    // The same boss by hand: the frame's shift added, the two depths written out.
    let mut by_hand = String::from("G21 G17 G90 G94 G54\nG64 P0.01\nG0 X15 Y20 Z5\n");
    for depth in [-2, -4] {
        by_hand += &format!(
            "G0 X15 Y20\nG1 Z{depth} F300\nG1 X92 F800\nG3 X100 Y28 R8\nG1 Y62\n\
             G3 X92 Y70 R8\nG1 X28\nG3 X20 Y62 R8\nG1 Y28\nG3 X28 Y20 R8\nG0 Z5\n"
        );
    }
    by_hand += "G0 Z50\nM2\n";
    let q = parse(&by_hand, "boss.ngc");
    assert_eq!(ends_nm(&p), ends_nm(&q));
    // The cuts blend alike; the 840D's rapids keep the path mode (G642 from CYCLE832), where
    // RS274/NGC's stop — all but the program's last move, which stops in both.
    use contourcheck::path::{Blend, Motion};
    let blends = |p: &Program, motion: Motion| {
        p.segments[..p.segments.len() - 1]
            .iter()
            .filter(|s| s.motion == motion)
            .map(|s| s.blend)
            .collect::<Vec<_>>()
    };
    assert_eq!(blends(&p, Motion::Feed), blends(&q, Motion::Feed));
    assert!(
        blends(&p, Motion::Rapid)
            .iter()
            .all(|&b| b == blends(&p, Motion::Feed)[0])
    );
    assert!(
        blends(&q, Motion::Rapid)
            .iter()
            .all(|&b| b == Blend::ExactStop)
    );
    // Every cut is written in the subprogram (lines 22–33 of the file).
    for s in p.segments.iter().filter(|s| s.motion == Motion::Feed) {
        assert!((22..=33).contains(&s.line), "line {}", s.line);
    }
}

#[test]
fn scaled_and_mirrored_frames_scale_radii_and_turn_arcs_round() {
    // SCALE doubles the workpiece; MIRROR X0 (replacing it) mirrors X, which turns the
    // workpiece's clockwise arcs counter-clockwise — also a modal arc's block that names
    // no G code; AMIRROR X0 mirrors back, and the program's G2 holds again.
    let sinumerik = "N10 G710 G90 G17 G94 G64\nN20 G0 X0 Y0 Z0\nN30 SCALE X2 Y2\n\
                     N40 G1 X10 F500\nN50 G3 X20 Y10 CR=10\nN60 G2 X30 Y20 I10 J0\n\
                     N70 MIRROR X0\nN80 G1 X-70\nN90 G2 X-80 Y50 I0 J10\nN100 X-90 Y40 I-10 J0\n\
                     N110 AMIRROR X0\nN120 X100 Y50 I0 J10\nN130 M30\n";
    let rs274 = "G21 G90 G17 G94 G64\nG0 X0 Y0 Z0\nG1 X20 F500\nG3 X40 Y20 R20\n\
                 G2 X60 Y40 I20 J0\nG1 X70 Y40\nG3 X80 Y50 I0 J10\nX90 Y40 I10 J0\n\
                 G2 X100 Y50 I0 J10\nM2\n";
    let a = parse(rs274, "by-hand.ngc");
    let b = parse(sinumerik, "frames.mpf");
    assert_eq!(ends_nm(&a), ends_nm(&b));
    let arcs = |p: &Program| {
        p.segments
            .iter()
            .filter_map(|s| match s.geometry {
                Geometry::Arc(arc) => Some((
                    (arc.sweep_rad * 1e9).round() as i64,
                    (arc.center_m[0] * 1e9).round() as i64,
                    (arc.center_m[1] * 1e9).round() as i64,
                )),
                _ => None,
            })
            .collect::<Vec<_>>()
    };
    assert_eq!(arcs(&a), arcs(&b));
    assert_eq!(arcs(&b).len(), 5);
    // An arc under a scale that differs on X and Y is an ellipse: refused at its block.
    let err = parse_program(
        "G710 G90 G0 X0 Y0 Z0\nSCALE X2 Y3\nG2 X10 Y0 I5 J0 F100\nM30\n",
        "ellipse.mpf",
        &InterpretOptions::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(
        err.contains("ellipse.mpf:3:4: G2: an arc under a scale"),
        "{err}"
    );
}

#[test]
fn arcs_by_opening_angle_are_the_arcs_by_centre() {
    // AR= with the end point (a quarter, then three quarters the long way), and with the
    // centre (a half turn clockwise).
    let sinumerik = "G710 G90 G17 G94\nG0 X10 Y0 Z0\nG3 X0 Y10 AR=90 F500\n\
                     G2 X10 Y0 AR=270\nG2 I-5 J0 AR=180\nM30\n";
    let rs274 = "G21 G90 G17 G94\nG0 X10 Y0 Z0\nG3 X0 Y10 I-10 J0 F500\n\
                 G2 X10 Y0 I10 J0\nG2 X0 Y0 I-5 J0\nM2\n";
    let a = parse(rs274, "by-centre.ngc");
    let b = parse(sinumerik, "by-angle.mpf");
    assert_eq!(ends_nm(&a), ends_nm(&b));
    for (x, y) in a.segments.iter().zip(&b.segments) {
        match (x.geometry, y.geometry) {
            (Geometry::Arc(p), Geometry::Arc(q)) => {
                assert!((p.sweep_rad - q.sweep_rad).abs() < 1e-9, "{p:?} {q:?}");
                assert!((p.center_m[0] - q.center_m[0]).abs() < 1e-9, "{p:?} {q:?}");
                assert!((p.center_m[1] - q.center_m[1]).abs() < 1e-9, "{p:?} {q:?}");
            }
            (Geometry::Line, Geometry::Line) => {}
            other => panic!("{other:?}"),
        }
    }
    let err = parse_program(
        "G710 G0 X0 Y0\nG2 X5 Y5 I5 J0 AR=90 F100\n",
        "ar.mpf",
        &InterpretOptions::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("ar.mpf:2:"), "{err}");
}

#[test]
fn brisk_and_soft_switch_the_paths_acceleration_profile() {
    use contourcheck::machine::MachineConfig;
    use contourcheck::plan::{KinematicLimits, PlanConfig, ProfileKind, plan, sample};
    // Under the planner's S-curves, a BRISK move ramps its acceleration in one cycle; after
    // SOFT the next move's acceleration ramps within the jerk limit again.
    let text = "G710 G90 G17 G94 G60\nG0 X0 Y0\nBRISK\nG1 X50 F1000\nSOFT\nG1 X100\nM30\n";
    let program = parse(text, "profiles.mpf");
    assert_eq!(program.segments[0].jerk_limited, Some(false));
    assert_eq!(program.segments[1].jerk_limited, Some(true));
    let machine = MachineConfig::default_preset();
    let limits = KinematicLimits::of(&machine);
    let mut config = PlanConfig::for_machine(&machine);
    config.profile = ProfileKind::SCurve;
    let commands = sample(&plan(&program, &limits, &config));
    let jerk_limit = limits.axes[0].jerk_m_per_s3;
    let peak_jerk = |segment: u32| {
        let a = &commands.x.acc_m_per_s2;
        (1..a.len())
            .filter(|&k| commands.segment[k] == segment && commands.segment[k - 1] == segment)
            .map(|k| ((a[k] - a[k - 1]) / commands.dt_s).abs())
            .fold(0.0, f64::max)
    };
    assert!(peak_jerk(0) > 5.0 * jerk_limit, "BRISK: {}", peak_jerk(0));
    assert!(peak_jerk(1) <= 1.01 * jerk_limit, "SOFT: {}", peak_jerk(1));
}

#[test]
fn case_jumps_to_the_branch_of_its_value() {
    // R1 = 2 picks the second branch; R1 = 7 the default; a value without a branch and
    // without a default goes on.
    let program = |r1: f64| {
        format!(
            "G710 G90 G17 G94 G0 X0 Y0\nR1={r1}\nCASE (R1) OF 1 GOTOF ONE 2 GOTOF TWO DEFAULT GOTOF OTHER\n\
             ONE: G1 X10 F500\nGOTOF END\nTWO: G1 X20 F500\nGOTOF END\nOTHER: G1 X30 F500\nEND: M30\n"
        )
    };
    let end_x = |r1: f64| {
        let p = parse(&program(r1), "case.mpf");
        (p.segments.last().unwrap().end_m[0] * 1e3).round()
    };
    assert_eq!(end_x(1.0), 10.0);
    assert_eq!(end_x(2.0), 20.0);
    assert_eq!(end_x(7.0), 30.0);
    let no_default = "G710 G90 G0 X0 Y0\nR1=5\nCASE(R1) OF 1 GOTOF AA\nG1 X40 F500\nAA: M30\n";
    let p = parse(no_default, "case.mpf");
    assert!((p.segments.last().unwrap().end_m[0] - 0.04).abs() < 1e-12);
}

#[test]
fn rapids_keep_the_continuous_path_mode_as_the_840d_does() {
    use contourcheck::machine::MachineConfig;
    use contourcheck::path::Blend;
    use contourcheck::plan::{KinematicLimits, PlanConfig, plan};
    let tolerance_mm = |b: Blend| match b {
        Blend::ExactStop => None,
        Blend::Continuous { tolerance_m, .. } => Some(tolerance_m.map(|t| t * 1e3)),
    };
    let blends = |text: &str, file: &str| {
        parse(text, file)
            .segments
            .iter()
            .map(|s| tolerance_mm(s.blend))
            .collect::<Vec<_>>()
    };
    // G641 rounds rapids by ADISPOS and feed moves by ADIS; G642 rapids by CTOLG0 (CTOL
    // where none is set); under G60, or with G9 in its block, a rapid stops.
    let rounded = "G710 G90 G641 ADIS=0.05 ADISPOS=0.5\nG0 X10\nY10\nG1 X0 F1000\nY0\n\
                   G642 CTOL=0.02\nG0 X10\nCTOLG0=0.2\nY10\nG1 X0\nG9 G0 Y0\nG60 X10\nY10\nM30\n";
    let close = |got: Option<Option<f64>>, want: Option<f64>| match (got, want) {
        (Some(Some(g)), Some(w)) => (g - w).abs() < 1e-9,
        (None, None) => true,
        _ => false,
    };
    let got = blends(rounded, "rounded.mpf");
    let want = [
        Some(0.5),
        Some(0.5),
        Some(0.05),
        Some(0.05),
        Some(0.02),
        Some(0.2),
        Some(0.02),
        None,
        None,
        None,
    ];
    assert_eq!(got.len(), want.len(), "{got:?}");
    for (k, (&g, &w)) in got.iter().zip(&want).enumerate() {
        assert!(close(g, w), "segment {k}: {g:?}, want {w:?} (all {got:?})");
    }
    // The same rapids in RS274/NGC each end in an exact stop.
    let rs274 = blends(
        "G21 G90 G64 P0.5\nG0 X10\nY10\nG1 X0 F1000\nM2\n",
        "rapids.ngc",
    );
    assert_eq!(rs274[..2], [None, None]);

    // Planned: the 840D runs through from one rapid into the next at the rapid rate, where
    // RS274/NGC stops in between.
    let machine = MachineConfig::default_preset();
    let limits = KinematicLimits::of(&machine);
    let config = PlanConfig::for_machine(&machine);
    let planned = |text: &str, file: &str| plan(&parse(text, file), &limits, &config);
    let siemens = planned("G710 G90 G64\nG0 X100\nX200\nM30\n", "l.mpf");
    let rs = planned("G21 G90 G64\nG0 X100\nX200\nM2\n", "l.ngc");
    let rapid_m_per_s = limits.axes[0].rapid_m_per_s;
    let corner_speed = |p: &contourcheck::plan::Plan| {
        let first = &p.plans[0];
        first.motion().eval(first.duration_s).1
    };
    assert!(
        corner_speed(&rs) < 1e-9,
        "RS274 corner {}",
        corner_speed(&rs)
    );
    assert!(
        (corner_speed(&siemens) - rapid_m_per_s).abs() < 1e-6,
        "840D {} m/s, rapid {rapid_m_per_s} m/s",
        corner_speed(&siemens)
    );
    assert!(
        siemens.total_time_s < rs.total_time_s - 0.01,
        "840D {} s, RS274 {} s",
        siemens.total_time_s,
        rs.total_time_s
    );
}

#[test]
fn an_increment_after_a_frame_change_also_travels_the_offset() {
    // The 840D's default (FRAME_OFFSET_INCR_PROG = 1): X=IC(1) after TRANS X100 goes from
    // the last programmed X1 to X2 of the new frame, 102 in the program's coordinates; in
    // G91 alike, and again after the frame is reset.
    let p = parse(
        "G710 G90 G1 F1000 X1 Y0 Z0\nTRANS X100\nX=IC(1)\nX=IC(2)\nTRANS\nG91 X3\nG90 Y5\nM30\n",
        "incr.mpf",
    );
    let xs: Vec<f64> = p.segments.iter().map(|s| s.end_m[0] * 1e3).collect();
    let want = [1.0, 102.0, 104.0, 7.0, 7.0];
    assert_eq!(xs.len(), want.len(), "{xs:?}");
    for (x, w) in xs.iter().zip(want) {
        assert!((x - w).abs() < 1e-9, "{xs:?}");
    }
}

#[test]
fn what_cam_posts_write_around_the_path_is_read() {
    // Rotary axes homed in a rapid, CYCLE800() switching a swivel off, FNORM, SETMS, a
    // labelled block number, blanks around '=' and operators, DIV, a comparison assigned.
    let text = "N10 DEF REAL _X_HOME, _Y_HOME\nN20 _X_HOME = 10 _Y_HOME=20\n\
                N30 G17 G710 G94 G90 FNORM\nN40 SUPA G0 X=_X_HOME Y=_Y_HOME A=0 C=0\n\
                N50 CYCLE800()\nN60 SETMS(1)\nN70 R1 = (7 DIV 2) * 10 + 1\n\
                N80 R2 = R1 >= 31\nN90 G1 F500 X = R1 + R2 Y=20\nN100 GOTOF 120\n\
                N110 X0\nN120 LAST_1: Y0\nN130 M30\nN140 GOTOB LAST_1\n";
    let p = parse(text, "post.mpf");
    let ends: Vec<[f64; 2]> = p
        .segments
        .iter()
        .map(|s| [s.end_m[0] * 1e3, s.end_m[1] * 1e3])
        .collect();
    assert_eq!(ends, [[10.0, 20.0], [32.0, 20.0], [32.0, 0.0]], "{ends:?}");
    let said = |what: &str| p.warnings.iter().any(|w| w.message.contains(what));
    assert!(
        said("rotary axis") && said("CYCLE800()"),
        "{:?}",
        p.warnings
    );
    // A rotary axis turning during a cut, and a swivel plane selected, are refused.
    for (text, line, word) in [
        ("G710 G1 F100 X10 C90\nM30\n", 1, "C"),
        (
            "G710 CYCLE800(1,\"TABLE\",0,57,0,0,0,0,0,0,0,0,0,1)\nM30\n",
            1,
            "CYCLE800",
        ),
    ] {
        let e = parse_program(text, "r.mpf", &InterpretOptions::default()).unwrap_err();
        let first = &e.0[0];
        assert_eq!(first.pos.line, line, "{first}");
        assert!(
            matches!(&first.kind, contourcheck::gcode::GcodeErrorKind::Unsupported { word: w, .. } if w.starts_with(word)),
            "{first}"
        );
    }
}

/// 840D programming manual, "Inch/metric dimensioning": G70/G71 switch the geometric data
/// alone, the feed staying in the basic system (metric here); G700/G710 switch the feed
/// too. X1 is 25.4 mm under either inch code; F10 is 10 mm/min under G70, 254 mm/min
/// (10 inch/min) under G700, and back to 10 mm/min under G710 and G71.
#[test]
fn g70_switches_the_geometry_to_inch_and_g700_the_feed_too() {
    let mm_per_min = |v_m_per_s: f64| v_m_per_s * 60_000.0;
    for (code, feed_mm_per_min) in [("G70", 10.0), ("G700", 254.0)] {
        let p = parse(&format!("G90 G17\n{code}\nG1 X1 Y0 F10\nM30\n"), "u.mpf");
        let s = &p.segments[0];
        assert!((s.end_m[0] - 0.0254).abs() < 1e-12, "{code}: {:?}", s.end_m);
        assert!(
            (mm_per_min(s.feed_m_per_s) - feed_mm_per_min).abs() < 1e-9,
            "{code}: {} mm/min",
            mm_per_min(s.feed_m_per_s)
        );
    }
    let back = parse(
        "G90 G17\nG700\nG1 X1 F10\nG710\nG1 X2 F10\nG700 G1 X3\nG71\nG1 X4 F10\nM30\n",
        "u.mpf",
    );
    let feeds: Vec<f64> = back
        .segments
        .iter()
        .map(|s| mm_per_min(s.feed_m_per_s))
        .collect();
    let ends: Vec<f64> = back.segments.iter().map(|s| s.end_m[0] * 1e3).collect();
    for (got, want) in feeds.iter().zip([254.0, 10.0, 10.0, 10.0]) {
        assert!((got - want).abs() < 1e-9, "{feeds:?}");
    }
    for (got, want) in ends.iter().zip([25.4, 2.0, 76.2, 4.0]) {
        assert!((got - want).abs() < 1e-9, "{ends:?}");
    }
}

/// `G601`/`G602` choose the fine or the coarse exact-stop window on the 840D; there being one
/// window in the machine file, both read as the exact stop they qualify: the same path and
/// the same exact stops as without them.
#[test]
fn exact_stop_window_codes_are_read() {
    let plain = parse("G90 G17 G710 G60\nG1 X10 F1000\nY10\nM30\n", "w.mpf");
    for code in ["G601", "G602"] {
        let p = parse(
            &format!("G90 G17 G710 G60 {code}\nG1 X10 F1000\n{code} Y10\nM30\n"),
            "w.mpf",
        );
        assert_eq!(p.segments, plain.segments, "{code}");
    }
}
