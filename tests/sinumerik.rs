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
    let text = "%_N_P_MPF\nN10 G710 G90\nN20 CASE R1 OF 1 GOTOF A DEFAULT GOTOF B\nN30 G1 X=$AA_IW[X] F100\nN40 MIRROR X0\n\
                N50 CYCLE72(\"C1\")\nN60 ASPLINE X1 Y2\nN70 G41 X5\nN80 L123 P2\nM30\n";
    let err = parse_program(text, "p.mpf", &InterpretOptions::default())
        .unwrap_err()
        .to_string();
    for (place, word) in [
        ("p.mpf:3:5", "CASE"),
        ("p.mpf:4:10", "$AA_IW"),
        ("p.mpf:5:5", "MIRROR"),
        ("p.mpf:6:5", "CYCLE72"),
        ("p.mpf:7:5", "ASPLINE"),
        ("p.mpf:8:5", "G41"),
        ("p.mpf:9:5", "L123"),
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
