//! `--plot` and the circles it draws no polar plot of: `check` says which and why, as the
//! HTML page does, and the circles it draws keep their numbers in the program's order.
//!
//! Two circles at 300 mm/min (5 mm/s) on a control interpolating every 20 ms: each cycle
//! moves the path 0.1 mm. Round R 0.5 mm that is 0.2 rad, 11.5°, a step: 2π·0.5 / 0.1 =
//! 31.4 points per turn at full feed, fewer than one every 10°, and the servo's start, which
//! lags the command and goes round slower, only adds shorter steps (at most 36 — else a
//! plot). Round R 20 mm it is 0.29°: 1257 per turn, drawn.

use crate::common;

use common::cli::{read_json, run_ok, text};
use common::stated_points_per_turn;

const PROGRAM: &str = "G21 G90 G94 G17\nG0 X0.5 Y0\nG3 X0.5 Y0 I-0.5 J0 F300\nG0 X20 Y0\n\
                       G3 X20 Y0 I-20 J0 F300\nM2\n";

#[test]
fn check_plot_says_why_a_circle_has_no_polar_plot_and_numbers_the_others_in_order() {
    let dir = tempfile::tempdir().unwrap();
    let (program, plots) = (dir.path().join("two.nc"), dir.path().join("plots"));
    std::fs::write(&program, PROGRAM).unwrap();
    let o = run_ok(&[
        "check",
        program.to_str().unwrap(),
        "--cycle-ms",
        "20",
        "--plot",
        plots.to_str().unwrap(),
    ]);
    let out = text(&o.stdout);
    // Full feed's points per turn on the small circle: the circumference over a cycle's path.
    let per_turn_at_feed = std::f64::consts::TAU * 0.5 / (300.0 / 60.0 * 0.020);
    let note = out
        .lines()
        .find_map(|l| l.strip_prefix("plot: circle of line 3: no polar plot: "))
        .unwrap_or_else(|| panic!("no word on the small circle:\n{out}"));
    let per_turn = stated_points_per_turn(note);
    assert!(
        per_turn >= per_turn_at_feed.round() && per_turn < 36.0,
        "{per_turn} per turn, {per_turn_at_feed:.1} at full feed"
    );
    assert!(note.contains("fewer than 36 (one every 10°)"), "{note}");
    assert!(!out.contains("circle of line 5"), "{out}");
    // The large circle is the program's second: drawn as circle-2, and nothing as circle-1.
    let files: Vec<String> = std::fs::read_dir(&plots)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with("circle-"))
        .collect();
    let mut files = files;
    files.sort();
    assert_eq!(files, ["circle-2.png", "circle-2.svg"]);
    let svg = std::fs::read_to_string(plots.join("circle-2.svg")).unwrap();
    assert!(
        svg.contains("R20.0 mm"),
        "circle-2 is not the R 20 mm circle"
    );
}

/// Three circles of R 10 mm about the origin of their plane's coordinates: in XY at Z 0, in
/// ZX (about Z 0, X 0) at Y 0, and in XY again at Z −5. Each in-plane centre and radius is
/// the same; the circles are not: three polar plots, each titled with its plane and height.
const ONE_FIGURE_THREE_CIRCLES: &str = "G21 G90 G94 G17\nG0 X10 Y0 Z0\n\
                                        G3 X10 Y0 I-10 J0 F1000\n\
                                        G18 G3 X10 Z0 I-10 K0\n\
                                        G17 G0 Z-5\n\
                                        G3 X10 Y0 I-10 J0\nM2\n";

#[test]
fn check_plot_draws_circles_of_other_planes_or_heights_apart() {
    let dir = tempfile::tempdir().unwrap();
    let (program, plots) = (dir.path().join("three.nc"), dir.path().join("plots"));
    let json = dir.path().join("report.json");
    std::fs::write(&program, ONE_FIGURE_THREE_CIRCLES).unwrap();
    run_ok(&[
        "check",
        program.to_str().unwrap(),
        "--plot",
        plots.to_str().unwrap(),
        "--json",
        json.to_str().unwrap(),
    ]);
    // The report names each circle's plane and height as the program placed them.
    let report = read_json(&json);
    let places: Vec<(String, f64)> = report["circular_test"]["circles"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| {
            let plane = c["plane"].as_str().unwrap().to_owned();
            (plane, c["height_mm"].as_f64().unwrap())
        })
        .collect();
    let expected = [("XY", 0.0), ("ZX", 0.0), ("XY", -5.0)];
    assert_eq!(places.len(), 3, "{places:?}");
    for ((plane, height), (want_plane, want_height)) in places.iter().zip(expected) {
        assert!(
            plane == want_plane && (height - want_height).abs() < 1e-9,
            "{places:?}"
        );
    }
    let mut files: Vec<String> = std::fs::read_dir(&plots)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with("circle-") && n.ends_with(".svg"))
        .collect();
    files.sort();
    assert_eq!(files, ["circle-1.svg", "circle-2.svg", "circle-3.svg"]);
    let svg = |n: u32| std::fs::read_to_string(plots.join(format!("circle-{n}.svg"))).unwrap();
    for (n, place, line) in [
        (1, "XY at Z 0.0 mm", 3),
        (2, "ZX at Y 0.0 mm", 4),
        (3, "XY at Z -5.0 mm", 6),
    ] {
        let drawn = svg(n);
        assert!(
            drawn.contains("R10.0 mm") && drawn.contains(place),
            "circle-{n} is not the circle {place}"
        );
        // One direction each: the line it runs on, and no other.
        assert_eq!(drawn.matches("(line ").count(), 1, "circle-{n}");
        assert!(drawn.contains(&format!("(line {line})")), "circle-{n}");
    }
}
