//! The page of a diagnosis: the record and the machine, the verdict, the residual before
//! and after, the causes ranked by their share of the residual with their uncertainties and
//! what to do, the circular-test figures measured and by both models, and the plots.

use serde::Serialize;
use serde_json::Value as Json;

use super::{
    Fig, HtmlError, Inputs, Made, Row, Svg, decimals_for, fig, file_name, lookup, render, svg,
};
use crate::analysis::circular::CircularTest;
use crate::diagnose::Diagnosis;
use crate::diagnose::cause_text::{next_step, strength};
use crate::diagnose::circular::CircularComparison;
use crate::diagnose::report::{CauseReport, DiagnoseReport};
use crate::figures::DiagnoseFigures;
use crate::machine::Feedback;

/// The page's view of a diagnosis.
#[derive(Serialize)]
struct DiagnosePage {
    title: String,
    made: Made,
    conditions: Vec<Row>,
    verdict: String,
    residual: Vec<(&'static str, Vec<Fig>)>,
    causes: Vec<CauseView>,
    rejected: Vec<String>,
    /// What the record says of the residual no named cause took (the text summary's lines).
    left: Vec<String>,
    /// Z against its simulation, where the record has Z (the text summary's lines).
    z: Vec<String>,
    circles: Vec<Vec<Fig>>,
    /// The circles without figures: "line N (plane): no figures: why".
    circles_left_out: Vec<String>,
    /// Where the nominal model's residual is largest: what, t, X, Y, (Z,) line, µm.
    places: Vec<Vec<Fig>>,
    /// Whether the places give Z (the contour measured in space).
    places_z: bool,
    fit: Svg,
    over_time: Svg,
    polar: Vec<Svg>,
    /// The circles without a polar plot: "line N: why".
    polar_not_drawn: Vec<String>,
}

/// A named cause as the page shows it.
#[derive(Serialize)]
struct CauseView {
    rank: usize,
    id: Fig,
    axis: Fig,
    /// (key, value, uncertainty, unit) of each fitted value.
    params: Vec<(String, Fig, Fig, String)>,
    share: Fig,
    held_out: [Fig; 2],
    strength: String,
    what_to_do: String,
    alternatives: Vec<String>,
}

/// The HTML report of a diagnosis `d` and its JSON `report`.
pub fn diagnose_page(
    d: &Diagnosis,
    report: &DiagnoseReport,
    inputs: &Inputs,
) -> Result<String, HtmlError> {
    let json = serde_json::to_value(report)?;
    let figures = DiagnoseFigures::of(d, &report.program);
    let (places, places_z) = place_rows(&json);
    let page = DiagnosePage {
        title: format!(
            "Diagnosis of {} against {}",
            file_name(&report.measured.file),
            file_name(&report.program)
        ),
        made: Made::now(),
        conditions: conditions(report, inputs),
        verdict: report.verdict.clone(),
        residual: residual_rows(&json),
        causes: ranked_causes(report, &json),
        rejected: report
            .rejected
            .iter()
            .map(|r| format!("{} on {}: {}", r.id.as_str(), r.axis, r.reason))
            .collect(),
        left: report.residual_findings(),
        z: report
            .z
            .describe()
            .iter()
            .map(|l| l.trim().to_string())
            .collect(),
        circles: circle_rows(&report.circular_test, &json),
        circles_left_out: report
            .circular_test
            .left_out
            .iter()
            .map(ToString::to_string)
            .collect(),
        places,
        places_z,
        fit: svg(
            "Each axis's position − command around where the nominal model misses most: \
             measured, nominal and extended model",
            &figures.fit,
        )?,
        over_time: svg(
            "The residual (measured − model) before and after the extension",
            &figures.over_time,
        )?,
        polar: figures
            .circles
            .iter()
            .map(|c| {
                svg(
                    format!("Circle of line {}: radial deviation", c.line),
                    &c.plot,
                )
            })
            .collect::<Result<_, _>>()?,
        polar_not_drawn: figures
            .circles_not_drawn
            .iter()
            .map(ToString::to_string)
            .collect(),
    };
    render("diagnose.html", page)
}

fn conditions(r: &DiagnoseReport, inputs: &Inputs) -> Vec<Row> {
    let m = &r.measured;
    vec![
        Row {
            label: "program",
            value: r.program.clone(),
        },
        Row {
            label: "record",
            value: format!(
                "{} ({} samples every {:.4} ms{}; measured at the {}{})",
                m.file,
                m.samples,
                m.sample_step_s * 1e3,
                if m.resampled { ", resampled" } else { "" },
                m.measured_at.as_str(),
                if m.commands_recorded {
                    ", with its commands"
                } else {
                    ", without commands: the plan's"
                }
            ),
        },
        Row {
            label: "machine",
            value: r.machine.clone(),
        },
        Row {
            label: "machine file",
            value: inputs.machine_source(&r.machine),
        },
        Row {
            label: "noise floor",
            value: format!(
                "{:.3} µm; {} samples compared",
                r.noise_floor_um, m.samples_compared
            ),
        },
        Row {
            label: "clock offset",
            value: format!(
                "{:.4} s (record time = program time + this)",
                r.clock_offset_s
            ),
        },
    ]
}

/// The residual's RMS of the nominal and the extended model and the gain, per axis and for
/// the contour.
fn residual_rows(json: &Json) -> Vec<(&'static str, Vec<Fig>)> {
    let contour = match lookup(json, "residual.contour_in_space") {
        Some(Json::Bool(true)) => "contour (in space)",
        _ => "contour",
    };
    [("X", "x"), ("Y", "y"), (contour, "contour")]
        .into_iter()
        .map(|(label, k)| {
            (
                label,
                vec![
                    fig(json, &format!("residual.nominal.{k}.rms_um"), 3),
                    fig(json, &format!("residual.extended.{k}.rms_um"), 3),
                    fig(json, &format!("residual.gain_percent.{k}.rms"), 0),
                ],
            )
        })
        .collect()
}

/// The named causes, the largest share of its axis's residual first.
fn ranked_causes(r: &DiagnoseReport, json: &Json) -> Vec<CauseView> {
    let mut order: Vec<usize> = (0..r.causes.len()).collect();
    order.sort_by(|&a, &b| {
        r.causes[b]
            .gain_percent
            .rms
            .total_cmp(&r.causes[a].gain_percent.rms)
    });
    order
        .into_iter()
        .enumerate()
        .map(|(rank, i)| {
            let c = &r.causes[i];
            cause_view(rank + 1, i, c, r.feedback_of(c.axis), json)
        })
        .collect()
}

fn cause_view(
    rank: usize,
    i: usize,
    c: &CauseReport,
    feedback: Option<Feedback>,
    json: &Json,
) -> CauseView {
    let at = |field: &str| format!("causes[{i}].{field}");
    let params = c
        .params
        .iter()
        .enumerate()
        .map(|(k, p)| {
            let decimals = decimals_for(p.uncertainty);
            (
                p.key.clone(),
                fig(json, &at(&format!("params[{k}].value")), decimals),
                fig(json, &at(&format!("params[{k}].uncertainty")), decimals),
                p.unit.to_string(),
            )
        })
        .collect();
    CauseView {
        rank,
        id: fig(json, &at("id"), 0),
        axis: fig(json, &at("axis"), 0),
        params,
        share: fig(json, &at("gain_percent.rms"), 0),
        held_out: [
            fig(json, &at("held_out.rms_before_um"), 3),
            fig(json, &at("held_out.rms_after_um"), 3),
        ],
        strength: strength(c),
        what_to_do: next_step(c, feedback),
        alternatives: c
            .alternatives
            .iter()
            .map(|a| {
                format!(
                    "or {} on {}: this record cannot tell them apart; {} would",
                    a.id.as_str(),
                    a.axis,
                    a.told_apart_by
                )
            })
            .collect(),
    }
}

/// Per place of a large residual: what, time, X, Y, Z where given, line, residual; and
/// whether the rows give Z (any place does: the contour measured in space).
fn place_rows(json: &Json) -> (Vec<Vec<Fig>>, bool) {
    let places = json["places"].as_array().map_or(&[][..], Vec::as_slice);
    let with_z = places.iter().any(|p| p.get("z_mm").is_some());
    let rows = (0..places.len())
        .map(|i| {
            let f = |field: &str, d| fig(json, &format!("places[{i}].{field}"), d);
            let mut row = vec![f("what", 0), f("t_record_s", 3), f("x_mm", 3), f("y_mm", 3)];
            if with_z {
                row.push(f("z_mm", 3));
            }
            row.extend([f("line", 0), f("residual_um", 3)]);
            row
        })
        .collect();
    (rows, with_z)
}

/// Per circle measured: line, plane, and G measured, by the nominal and by the extended
/// model — each model's figures of the same circle (the same plan segment), found by that
/// circle and not by its place in the list: a circle a model's path gives too few samples
/// on is missing from that model's list alone, and its row shows "—" there.
fn circle_rows(c: &CircularComparison, json: &Json) -> Vec<Vec<Fig>> {
    let at = |model: &str, test: &CircularTest, segment: usize, field: &str, d| match test
        .circles
        .iter()
        .position(|f| f.segment == segment)
    {
        Some(i) => fig(
            json,
            &format!("circular_test.{model}.circles[{i}].{field}"),
            d,
        ),
        None => Fig::missing(),
    };
    c.measured
        .circles
        .iter()
        .map(|m| {
            let measured = |field: &str, d| at("measured", &c.measured, m.segment, field, d);
            vec![
                measured("line", 0),
                measured("plane", 0),
                measured("direction", 0),
                measured("radius_mm", 1),
                measured("g_um", 2),
                at("nominal", &c.nominal, m.segment, "g_um", 2),
                at("extended", &c.extended, m.segment, "g_um", 2),
                measured("f_min_um", 2),
                measured("f_max_um", 2),
            ]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::circle_rows;
    use crate::analysis::circular::{CircleFigures, CircularTest};
    use crate::diagnose::circular::CircularComparison;
    use crate::path::Plane;

    /// The figures of the circle of plan segment `segment` at line `line`, with G `g_um`.
    fn circle(segment: usize, line: u32, g_um: f64) -> CircleFigures {
        CircleFigures {
            segment,
            line,
            plane: Plane::Xy,
            height_mm: 0.0,
            direction: "ccw",
            radius_mm: 10.0,
            g_um,
            f_max_um: 1.0,
            f_min_um: -1.0,
            reversal_spikes_um: [0.0; 4],
            diagonal_ellipse_urad: 0.0,
            scale_mismatch_ppm: 0.0,
            samples: 100,
            start_left_out_deg: 0.0,
            end_left_out_deg: 0.0,
            settling_included: false,
        }
    }

    fn test(circles: Vec<CircleFigures>) -> CircularTest {
        CircularTest {
            circles,
            pairs: Vec::new(),
        }
    }

    #[test]
    fn each_row_shows_one_circle_s_figures_though_a_model_lacks_one() {
        // Two circles measured; the nominal model's path gives the first too few samples
        // (it is missing from its list alone), and one line runs twice (a subprogram called
        // twice): the rows pair by circle, not by place in the lists.
        let c = CircularComparison {
            measured: test(vec![circle(3, 12, 5.0), circle(7, 12, 6.0)]),
            nominal: test(vec![circle(7, 12, 16.0)]),
            extended: test(vec![circle(3, 12, 25.0), circle(7, 12, 26.0)]),
            windows: Default::default(),
            left_out: Vec::new(),
        };
        let json = serde_json::json!({ "circular_test": c });
        let rows = circle_rows(&c, &json);
        let g: Vec<[&str; 3]> = rows
            .iter()
            .map(|r| [&r[4].text[..], &r[5].text[..], &r[6].text[..]])
            .collect();
        assert_eq!(
            g,
            [["5.00", "—", "25.00"], ["6.00", "16.00", "26.00"]],
            "{rows:?}"
        );
        // The missing figure has no key to read back; the others their own.
        assert!(rows[0][5].key.is_empty());
        assert_eq!(rows[1][5].key, "circular_test.nominal.circles[0].g_um");
        assert_eq!(rows[1][6].key, "circular_test.extended.circles[1].g_um");
        // The plane's cell carries its value for sorting and filters.
        assert_eq!((&rows[0][1].value[..], &rows[0][1].text[..]), ("XY", "XY"));
    }
}
