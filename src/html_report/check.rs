//! The page of a check: test conditions, the headline against the tolerance, the ISO 230-4
//! figures with their polar plots, the hotspots, the toolpath.

use serde::Serialize;
use serde_json::Value as Json;

use super::{Fig, HtmlError, Inputs, Made, Row, Svg, fig, file_name, render, svg};
use crate::check::CheckResult;
use crate::check::report::CheckReport;
use crate::figures::CheckFigures;
use crate::gcode::SourceFile;
use crate::path::Motion;

/// Most hotspots listed on the page (the JSON report lists them all).
const HOTSPOTS_SHOWN: usize = 20;

/// The page's view of a check.
#[derive(Serialize)]
struct CheckPage {
    title: String,
    made: Made,
    conditions: Vec<Row>,
    verdict: Verdict,
    headline: Vec<(&'static str, Fig, &'static str)>,
    circles: Vec<Vec<Fig>>,
    pairs: Vec<Vec<Fig>>,
    polar: Vec<Svg>,
    /// The circles without a polar plot: "line N: why".
    polar_not_drawn: Vec<String>,
    hotspots: Vec<Vec<Fig>>,
    hotspots_more: usize,
    toolpath: Svg,
    along_path: Svg,
    warnings: Vec<String>,
}

/// The headline's verdict against the tolerance.
#[derive(Serialize)]
struct Verdict {
    /// `pass`, `fail` or `none` (no tolerance given).
    class: &'static str,
    text: String,
    within: Fig,
}

/// The HTML report of a check: `run` and its `report` (the JSON report's figures), the
/// program's subprogram files naming lines in the plots.
pub fn check_page(
    run: &CheckResult,
    report: &CheckReport,
    sources: &[SourceFile],
    inputs: &Inputs,
) -> Result<String, HtmlError> {
    let json = serde_json::to_value(report)?;
    let figures = CheckFigures::of(run, report, sources);
    let page = CheckPage {
        title: format!(
            "Predicted contour error: {}",
            file_name(&report.program.file)
        ),
        made: Made::now(),
        conditions: conditions(run, report, inputs),
        verdict: verdict(report, &json),
        headline: headline(&json),
        circles: circle_rows(&json),
        pairs: pair_rows(&json),
        polar: figures
            .circles
            .iter()
            .map(|c| {
                svg(
                    "Radial deviation, ballbar-style (outward positive)",
                    &c.plot,
                )
            })
            .collect::<Result<_, _>>()?,
        polar_not_drawn: figures
            .circles_not_drawn
            .iter()
            .map(ToString::to_string)
            .collect(),
        hotspots: hotspot_rows(&json),
        hotspots_more: report.hotspots.len().saturating_sub(HOTSPOTS_SHOWN),
        toolpath: svg(
            "The programmed path and the predicted one, coloured by contour error; the \
             largest hotspots numbered",
            &figures.toolpath,
        )?,
        along_path: svg("Contour error along the path", &figures.along_path)?,
        warnings: crate::check::report::group_warnings(&report.warnings),
    };
    render("check.html", page)
}

/// The test conditions: program, machine, feed, sampling, planner.
fn conditions(run: &CheckResult, report: &CheckReport, inputs: &Inputs) -> Vec<Row> {
    let r = report;
    vec![
        Row {
            label: "program",
            value: format!(
                "{} ({} lines, {} blocks, {} segments)",
                r.program.file, r.program.lines, r.program.blocks, r.program.segments
            ),
        },
        Row {
            label: "machine",
            value: format!("{} — {}", r.machine.name, r.machine.description),
        },
        Row {
            label: "machine file",
            value: inputs.machine_source(&r.machine.name),
        },
        Row {
            label: "programmed feed",
            value: feeds(run),
        },
        Row {
            label: "sampling",
            value: format!(
                "interpolation cycle {} ms, simulation step {} ms",
                r.settings.interpolation_cycle_ms, r.settings.simulation_step_ms
            ),
        },
        Row {
            label: "speed profile",
            value: r.settings.profile.to_string(),
        },
        Row {
            label: "cycle",
            value: format!(
                "{:.2} s over {:.1} mm ({:.1} mm cutting)",
                r.cycle_time_s, r.path_length_mm, r.cut_length_mm
            ),
        },
    ]
}

/// The feeds of the program's feed moves (mm/min): one, or their range.
fn feeds(run: &CheckResult) -> String {
    let mut feeds: Vec<f64> = run
        .plan
        .segments
        .iter()
        .filter(|s| s.motion == Motion::Feed && s.feed_m_per_s > 0.0)
        .map(|s| crate::numeric::units::mm_per_min_from_m_per_s(s.feed_m_per_s))
        .collect();
    feeds.sort_by(f64::total_cmp);
    feeds.dedup_by(|a, b| (*a - *b).abs() < 1e-6);
    match feeds.as_slice() {
        [] => "no feed moves".into(),
        [one] => format!("F{one:.0} mm/min"),
        [lo, .., hi] => format!("F{lo:.0} to F{hi:.0} mm/min ({} feeds)", feeds.len()),
    }
}

fn verdict(report: &CheckReport, json: &Json) -> Verdict {
    let max = report.contour_error_um.max;
    let within = fig(json, "within_tolerance", 0);
    match (report.tolerance_um, report.within_tolerance) {
        (Some(t), Some(true)) => Verdict {
            class: "pass",
            text: format!(
                "PASS: the predicted largest contour error, {max:.2} µm, is within the tolerance of {t} µm"
            ),
            within,
        },
        (Some(t), _) => Verdict {
            class: "fail",
            text: format!(
                "FAIL: the predicted largest contour error, {max:.2} µm, exceeds the tolerance of {t} µm"
            ),
            within,
        },
        (None, _) => Verdict {
            class: "none",
            text: format!("No tolerance given: the predicted largest contour error is {max:.2} µm"),
            within,
        },
    }
}

/// The headline figures: (what, figure, unit).
fn headline(json: &Json) -> Vec<(&'static str, Fig, &'static str)> {
    vec![
        (
            "largest contour error",
            fig(json, "contour_error_um.max", 2),
            "µm",
        ),
        (
            "RMS contour error",
            fig(json, "contour_error_um.rms", 2),
            "µm",
        ),
        (
            "… at line",
            fig(json, "contour_error_um.max_at.line", 0),
            "",
        ),
        (
            "… at time",
            fig(json, "contour_error_um.max_at.t_s", 3),
            "s",
        ),
        ("… at X", fig(json, "contour_error_um.max_at.x_mm", 3), "mm"),
        ("… at Y", fig(json, "contour_error_um.max_at.y_mm", 3), "mm"),
        ("tolerance", fig(json, "tolerance_um", 2), "µm"),
        (
            "settling (XY while only Z moves)",
            fig(json, "positioning_error_um.max", 2),
            "µm",
        ),
        (
            "X following error while cutting",
            fig(json, "following_error_um.x.max_cutting", 1),
            "µm",
        ),
        (
            "Y following error while cutting",
            fig(json, "following_error_um.y.max_cutting", 1),
            "µm",
        ),
        ("cycle time", fig(json, "cycle_time_s", 2), "s"),
    ]
}

/// One row per circle: line, plane, direction, radius, G, F, the four reversal spikes, and
/// whether the figures hold the loops' settling.
fn circle_rows(json: &Json) -> Vec<Vec<Fig>> {
    let n = json["circular_test"]["circles"]
        .as_array()
        .map_or(0, Vec::len);
    (0..n)
        .map(|i| {
            let f = |field: &str, d| fig(json, &format!("circular_test.circles[{i}].{field}"), d);
            let mut row = vec![
                f("line", 0),
                f("plane", 0),
                f("direction", 0),
                f("radius_mm", 1),
                f("g_um", 2),
                f("f_max_um", 2),
                f("f_min_um", 2),
            ];
            row.extend((0..4).map(|k| f(&format!("reversal_spikes_um[{k}]"), 1)));
            // Where the windows left too few samples, G holds the loops' settling.
            row.push(f("settling_included", 0));
            row
        })
        .collect()
}

/// One row per pair of opposite circles: H and the ballbar's error terms.
fn pair_rows(json: &Json) -> Vec<Vec<Fig>> {
    let n = json["circular_test"]["pairs"]
        .as_array()
        .map_or(0, Vec::len);
    (0..n)
        .map(|i| {
            let f = |field: &str, d| fig(json, &format!("circular_test.pairs[{i}].{field}"), d);
            vec![
                f("ccw_line", 0),
                f("cw_line", 0),
                f("h_um", 2),
                f("g_both_um", 2),
                f("squareness_urad", 1),
                f("servo_mismatch_ms", 2),
                f("scale_mismatch_ppm", 1),
                f("backlash_x_um", 2),
                f("backlash_y_um", 2),
            ]
        })
        .collect()
}

/// The largest hotspots: rank, line, block, time, X, Y, error, spike, cause.
fn hotspot_rows(json: &Json) -> Vec<Vec<Fig>> {
    let n = json["hotspots"].as_array().map_or(0, Vec::len);
    (0..n.min(HOTSPOTS_SHOWN))
        .map(|i| {
            let f = |field: &str, d| fig(json, &format!("hotspots[{i}].{field}"), d);
            vec![
                f("rank", 0),
                f("line", 0),
                f("block_number", 0),
                f("t_s", 3),
                f("x_mm", 3),
                f("y_mm", 3),
                f("error_um", 2),
                f("excess_um", 2),
                f("label", 0),
            ]
        })
        .collect()
}
