//! The circles on the HTML pages: each circle's row names its plane with a value a filter
//! can read, and a circle a record gives too few points per turn for a polar plot gets the
//! reason instead of a polygon drawn from its samples; `diagnose --plot` says the same on
//! the terminal.
//!
//! The record is the independent reference's (`common::reference`): two circles at
//! 3000 mm/min sampled at 50 Hz, as a SINUMERIK trace is. Round R 10 mm the path runs
//! 62.8 mm, 63 samples per turn at full feed: drawn. Round R 3 mm it runs 18.8 mm, 19
//! samples per turn at full feed; the ramps from and to rest and the servo's catch-up after
//! the command stops add shorter steps, but at 0.5 m/s² the ramps take 2.5 mm each and the
//! full feed most of the angle: the typical step is the full feed's, 19 per turn, fewer than
//! one every 10°, not drawn.

use crate::common;

use common::cli::{run_ok, text};
use common::diagnosing::diagnose_nominal;
use common::reference::{Recording, record};
use common::{program_text, stated_points_per_turn};
use contourcheck::diagnose::report::DiagnoseReport;
use contourcheck::machine::MachineConfig;
use contourcheck::trace::measured::parse_trace;
use contourcheck::{ReportInputs, diagnose_page};

const PROGRAM: &str = "G21 G90 G17 G94\nG0 X10 Y0\nG3 X10 Y0 I-10 J0 F3000\nG0 X3 Y0\n\
                       G3 X3 Y0 I-3 J0\nM2\n";

/// Samples per turn of a circle of `radius_mm` run at `feed_mm_per_min` from and to rest,
/// sampled every `dt_s`: at full feed, and at most, with the interpolator's ramps at `accel`
/// m/s² and the servo's catch-up after the command stops (time constant `tau_s`, its steps
/// above a tenth of the largest for ln 10 of it).
fn samples_per_turn(
    radius_mm: f64,
    feed_mm_per_min: f64,
    dt_s: f64,
    accel: f64,
    tau_s: f64,
) -> [f64; 2] {
    let (length, v) = (
        std::f64::consts::TAU * radius_mm * 1e-3,
        feed_mm_per_min / 60e3,
    );
    let command_s = (length - v * v / accel) / v + 2.0 * v / accel;
    [length / v / dt_s, (command_s + tau_s * 10f64.ln()) / dt_s]
}

#[test]
fn a_circle_sampled_too_sparsely_has_no_polar_plot_and_says_why() {
    let program = program_text(PROGRAM);
    let machine = MachineConfig::default_preset();
    let rec = Recording {
        sample_s: 0.02,
        ..Recording::default()
    };
    let csv = record(&program, &machine.x, &machine.y, &rec);
    let measured = parse_trace(&csv, "reference-50hz.csv").unwrap();
    let d = diagnose_nominal(&program, &measured);
    let report = DiagnoseReport::new(&d, "circles.nc", &measured, &machine);
    let page = diagnose_page(&d, &report, &ReportInputs::default()).unwrap();
    // The position loop's time constant, 1/Kv.
    let tau_s = 60.0 / (1000.0 * machine.x.position_loop.kv_m_per_min_per_mm);
    let [large, _] = samples_per_turn(10.0, 3000.0, 0.02, rec.accel, tau_s);
    let [small_cruise, small] = samples_per_turn(3.0, 3000.0, 0.02, rec.accel, tau_s);
    assert!(large > 36.0 && small < 36.0, "{large} {small}");
    // The large circle is drawn, its figures' plane readable; the small one is not drawn.
    assert!(
        page.contains("Circle of line 3: radial deviation"),
        "no plot of the large circle"
    );
    assert!(
        !page.contains("Circle of line 5: radial deviation"),
        "the small circle drawn"
    );
    assert!(
        page.contains("data-key=\"circular_test.measured.circles[0].plane\" data-value=\"XY\">XY<"),
        "the plane cell has no value"
    );
    // Its reason, with its points per turn between the full feed's and the ramps'.
    let note = page
        .split("Circle of line 5: no polar plot: ")
        .nth(1)
        .unwrap_or_else(|| panic!("no reason for the small circle"));
    let per_turn = stated_points_per_turn(note);
    assert!(
        // Shown to the unit.
        (per_turn - small_cruise).abs() <= 0.5,
        "{per_turn} per turn, {small_cruise:.1} expected"
    );
    assert!(note.contains("fewer than 36 (one every 10°)"), "{note}");
    assert!(
        !page.contains("Circle of line 3: no polar plot"),
        "{large:.1} per turn refused"
    );
}

/// The same record handed to `diagnose --plot` as a user hands it over: the terminal says
/// which circle has no polar plot and why, in the words and figures of the page, and the
/// plot files are the drawn circle's only.
#[test]
fn diagnose_plot_says_why_the_sparse_circle_has_no_polar_plot() {
    let program = program_text(PROGRAM);
    let machine = MachineConfig::default_preset();
    let rec = Recording {
        sample_s: 0.02,
        ..Recording::default()
    };
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name).to_string_lossy().into_owned();
    std::fs::write(p("circles.nc"), PROGRAM).unwrap();
    std::fs::write(
        p("reference-50hz.csv"),
        record(&program, &machine.x, &machine.y, &rec),
    )
    .unwrap();
    let o = run_ok(&[
        "diagnose",
        &p("circles.nc"),
        "--measured",
        &p("reference-50hz.csv"),
        "--plot",
        &p("plots"),
    ]);
    let out = text(&o.stdout);
    let tau_s = 60.0 / (1000.0 * machine.x.position_loop.kv_m_per_min_per_mm);
    let [small_cruise, _] = samples_per_turn(3.0, 3000.0, 0.02, rec.accel, tau_s);
    let note = out
        .lines()
        .find_map(|l| l.strip_prefix("plot: circle of line 5: no polar plot: "))
        .unwrap_or_else(|| panic!("no word on the small circle:\n{out}"));
    let per_turn = stated_points_per_turn(note);
    assert!(
        (per_turn - small_cruise).abs() <= 0.5,
        "{per_turn} per turn, {small_cruise:.1} expected"
    );
    assert!(note.contains("fewer than 36 (one every 10°)"), "{note}");
    assert!(!out.contains("circle of line 3: no polar plot"), "{out}");
    let polar: Vec<String> = std::fs::read_dir(p("plots"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with("diagnose-polar"))
        .collect();
    assert!(
        !polar.is_empty() && polar.iter().all(|n| n.starts_with("diagnose-polar-line3.")),
        "{polar:?}"
    );
}
