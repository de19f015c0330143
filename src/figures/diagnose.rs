//! The figures of a diagnosis: measured against the nominal and the extended model around
//! where the nominal misses most, the residual before and after over time and along the
//! path, and a ballbar-style polar plot per circle — drawn as files by `diagnose --plot` and
//! inline in the HTML report.

use std::path::Path;

use super::{CirclePlot, NotDrawn};
use crate::analysis::circular::{Circle, CircularTest, radial_points};
use crate::analysis::polar_points::too_sparse_for_a_plot;
use crate::diagnose::Diagnosis;
use crate::numeric::units::{mm_from_m, um_from_m};
use crate::plot::panels::{Curve, Panel, PanelsPlot};
use crate::plot::polar::{PolarPlot, PolarTrace};

/// Every figure of a diagnosis.
pub struct DiagnoseFigures {
    /// Each axis's deviation from the command (X, Y, and Z where the diagnosis compared
    /// it): measured, nominal, extended.
    pub fit: PanelsPlot,
    /// The residual of both models over time (X, Y, Z where compared, contour).
    pub over_time: PanelsPlot,
    /// The contour residual along the path.
    pub along_path: PanelsPlot,
    /// Per full circle, its source line and its polar plot, drawn to
    /// `diagnose-polar-lineN` (`-2`, `-3`, … after it for further circles of one line: a
    /// subprogram's or a repeated block's).
    pub circles: Vec<CirclePlot>,
    /// Per full circle the record gives too few points per turn for a polar plot, its
    /// source line and why it has none.
    pub circles_not_drawn: Vec<NotDrawn>,
}

/// The polar plots of a diagnosis's circles, and the circles without one.
#[derive(Default)]
struct Polar {
    drawn: Vec<CirclePlot>,
    not_drawn: Vec<NotDrawn>,
}

impl DiagnoseFigures {
    /// The figures of a diagnosis of a record of `program_file`.
    pub(crate) fn of(d: &Diagnosis, program_file: &str) -> Self {
        let name = Path::new(program_file)
            .file_name()
            .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
        let found: Vec<String> = d
            .causes
            .iter()
            .map(|c| format!("{} on {}", c.id.as_str(), c.axis))
            .collect();
        let extended_name = if found.is_empty() {
            "extended (no cause found)".to_string()
        } else {
            format!("extended: {}", found.join(", "))
        };
        let [over_time, along_path] = residual_plots(d, &name);
        let polar = polar_plots(d, &name, &extended_name);
        DiagnoseFigures {
            fit: fit_plot(d, &name, &extended_name),
            over_time,
            along_path,
            circles: polar.drawn,
            circles_not_drawn: polar.not_drawn,
        }
    }
}

/// Half-width of the close-up around the largest miss (s).
const ZOOM_HALF_S: f64 = 0.15;

/// Most points per curve.
const PLOT_POINTS: usize = 20_000;

/// (abscissa, value) pairs, decimated, with a NaN wherever the samples jump (a stretch
/// left out) so the line breaks there.
fn curve_points(x: &[f64], t: &[f64], y: impl Fn(usize) -> f64) -> Vec<(f64, f64)> {
    let every = x.len().div_ceil(PLOT_POINTS).max(1);
    let step = t
        .windows(2)
        .map(|w| w[1] - w[0])
        .fold(f64::MAX, f64::min)
        .max(1e-9);
    let mut out = Vec::new();
    let mut last_t = f64::NAN;
    for k in (0..x.len()).step_by(every) {
        if t[k] - last_t > (every as f64 + 1.5) * step {
            out.push((x[k], f64::NAN));
        }
        out.push((x[k], y(k)));
        last_t = t[k];
    }
    out
}

/// One axis's series at the diagnosis's samples (m), and where the nominal model misses
/// it most (program time s, source line).
struct AxisSeries<'a> {
    name: &'static str,
    reference: &'a [f64],
    measured: &'a [f64],
    nominal: &'a [f64],
    extended: &'a [f64],
    worst: Option<(f64, u32)>,
}

/// X and Y, and Z where the diagnosis compared it.
fn axis_series(d: &Diagnosis) -> Vec<AxisSeries<'_>> {
    let s = &d.series;
    let mut axes: Vec<AxisSeries> = (0..2)
        .map(|a| {
            let name = ["X", "Y"][a];
            let lower = name.to_lowercase();
            AxisSeries {
                name,
                reference: &s.reference[a],
                measured: &s.measured[a],
                nominal: &s.nominal[a],
                extended: &s.extended[a],
                worst: d
                    .places
                    .iter()
                    .find(|p| p.what == lower)
                    .map(|p| (p.t_s, p.line)),
            }
        })
        .collect();
    if let Some(z) = &d.z.series {
        axes.push(AxisSeries {
            name: "Z",
            reference: &z.reference,
            measured: &z.measured,
            nominal: &z.nominal,
            extended: &z.extended,
            worst: z.worst,
        });
    }
    axes
}

/// Each axis's deviation from the command, measured and by both models, around where the
/// nominal model misses most, and beneath it the miss itself (model − measured) at its own
/// scale: a 6 µm miss on a 500 µm following error is invisible on the deviation's.
fn fit_plot(d: &Diagnosis, name: &str, extended_name: &str) -> PanelsPlot {
    PanelsPlot {
        title: format!("{name}: measured against the nominal and the extended model"),
        x_label: "program time (s)".into(),
        panels: axis_series(d)
            .iter()
            .flat_map(|a| fit_panels(&d.series.t_s, a, extended_name))
            .collect(),
    }
}

/// One axis's two panels of the fit figure.
fn fit_panels(t: &[f64], a: &AxisSeries, extended_name: &str) -> [Panel; 2] {
    let keep: Vec<usize> = match a.worst {
        Some((t_worst, _)) => (0..t.len())
            .filter(|&k| (t[k] - t_worst).abs() <= ZOOM_HALF_S)
            .collect(),
        None => (0..t.len()).collect(),
    };
    let tk: Vec<f64> = keep.iter().map(|&k| t[k]).collect();
    let series = |value: &dyn Fn(usize) -> f64| curve_points(&tk, &tk, |j| value(keep[j]));
    let dev = |model: &[f64]| series(&|k| um_from_m(model[k] - a.reference[k]));
    let miss = |model: &[f64]| series(&|k| um_from_m(model[k] - a.measured[k]));
    let curve = |name: &str, points, color, width| Curve {
        name: name.to_string(),
        points,
        color,
        width,
    };
    let axis = a.name;
    let caption = match a.worst {
        Some((t_s, line)) => format!(
            "{axis} axis: position − command around t = {t_s:.2} s (line {line}), where the nominal model misses most"
        ),
        None => format!("{axis} axis: position − command"),
    };
    [
        Panel {
            caption,
            y_label: "µm".into(),
            curves: vec![
                curve("measured", dev(a.measured), None, 3),
                curve("nominal model", dev(a.nominal), Some(1), 2),
                curve(extended_name, dev(a.extended), Some(0), 2),
            ],
        },
        Panel {
            caption: format!("{axis} axis there: model − measured"),
            y_label: "µm".into(),
            curves: vec![
                curve("nominal model", miss(a.nominal), Some(1), 2),
                curve(extended_name, miss(a.extended), Some(0), 2),
            ],
        },
    ]
}

/// The residual of both models over time (X, Y, Z where compared, contour) and along the
/// path (contour).
fn residual_plots(d: &Diagnosis, name: &str) -> [PanelsPlot; 2] {
    let s = &d.series;
    let t = &s.t_s;
    let residual_panel = |caption: String,
                          before: &dyn Fn(usize) -> f64,
                          after: &dyn Fn(usize) -> f64,
                          x: &[f64]| Panel {
        caption,
        y_label: "residual (µm)".into(),
        curves: vec![
            Curve {
                name: "nominal model".into(),
                points: curve_points(x, t, before),
                color: None,
                width: 1,
            },
            Curve {
                name: "extended model".into(),
                points: curve_points(x, t, after),
                color: Some(0),
                width: 1,
            },
        ],
    };
    let axis_residual = |a: usize| {
        residual_panel(
            format!(
                "{} axis: measured − model (RMS {:.3} → {:.3} µm)",
                ["X", "Y"][a],
                [d.before.x, d.before.y][a].rms_um,
                [d.after.x, d.after.y][a].rms_um
            ),
            &|k| um_from_m(s.measured[a][k] - s.nominal[a][k]),
            &|k| um_from_m(s.measured[a][k] - s.extended[a][k]),
            t,
        )
    };
    let contour_caption = format!(
        "contour error{}: measured − model (RMS {:.3} → {:.3} µm)",
        if s.contour_in_space { " in space" } else { "" },
        d.before.contour.rms_um,
        d.after.contour.rms_um
    );
    let contour_before = |k: usize| um_from_m(s.contour_residual[0][k]);
    let contour_after = |k: usize| um_from_m(s.contour_residual[1][k]);
    let mut panels = vec![axis_residual(0), axis_residual(1)];
    if let Some(z) = &d.z.series {
        panels.push(residual_panel(
            format!(
                "Z axis: measured − model (RMS {:.3} → {:.3} µm)",
                d.z.before_rms_um, d.z.after_rms_um
            ),
            &|k| um_from_m(z.measured[k] - z.nominal[k]),
            &|k| um_from_m(z.measured[k] - z.extended[k]),
            t,
        ));
    }
    panels.push(residual_panel(
        contour_caption.clone(),
        &contour_before,
        &contour_after,
        t,
    ));
    let over_time = PanelsPlot {
        title: format!("{name}: residual before and after the extension, over time"),
        x_label: "program time (s)".into(),
        panels,
    };
    let path_mm: Vec<f64> = s.path_s_m.iter().map(|&v| mm_from_m(v)).collect();
    let along_path = PanelsPlot {
        title: format!("{name}: contour-error residual along the path"),
        x_label: "path length (mm)".into(),
        panels: vec![residual_panel(
            contour_caption,
            &contour_before,
            &contour_after,
            &path_mm,
        )],
    };
    [over_time, along_path]
}

/// Ballbar-style: each full circle's radial deviation in its plane, measured and by both
/// models, with its source line; a circle the record gives no points on is not drawn, and
/// one it gives too few per turn for a plot is listed with why.
fn polar_plots(d: &Diagnosis, name: &str, extended_name: &str) -> Polar {
    let s = &d.series;
    let z = d.z.series.as_ref();
    let none: &[f64] = &[];
    let mut polar = Polar::default();
    for (i, c) in d.circles.iter().enumerate() {
        // The figures of this circle, the same plan segment, where the path has them.
        let g_of = |test: &CircularTest| {
            test.circles
                .iter()
                .find(|f| f.segment == c.segment)
                .map(|f| f.g_um)
        };
        let trace = |label: &str, xy: &[Vec<f64>; 2], z: Option<&Vec<f64>>, width: u32, g_um| {
            let pos_m = [&xy[0][..], &xy[1][..], z.map_or(none, |z| z)];
            PolarTrace {
                label: label.to_string(),
                width,
                g_um,
                points: radial_points(
                    &d.circles,
                    c,
                    &s.segment,
                    pos_m,
                    &s.commands(),
                    &d.circular.windows,
                )
                .into_iter()
                .map(|(a, r)| (a, um_from_m(r)))
                .collect(),
            }
        };
        let circular = &d.circular;
        let measured = trace(
            "measured",
            &s.measured,
            z.map(|z| &z.measured),
            1,
            g_of(&circular.measured),
        );
        if measured.points.is_empty() {
            continue;
        }
        if let Some(why) = too_sparse_for_a_plot(&measured.points) {
            polar.not_drawn.push(NotDrawn { line: c.line, why });
            continue;
        }
        let traces = vec![
            measured,
            trace(
                "nominal model",
                &s.nominal,
                z.map(|z| &z.nominal),
                2,
                g_of(&circular.nominal),
            ),
            trace(
                extended_name,
                &s.extended,
                z.map(|z| &z.extended),
                2,
                g_of(&circular.extended),
            ),
        ];
        // Every earlier circle of the line counts, drawn or not: a name stays with its circle.
        let before = d.circles[..i].iter().filter(|o| o.line == c.line).count();
        polar.drawn.push(CirclePlot {
            line: c.line,
            file: polar_file(c.line, before),
            plot: PolarPlot {
                title: polar_title(name, c),
                radius_mm: mm_from_m(c.radius_m),
                traces,
            },
        });
    }
    polar
}

/// The file a circle of `line` is drawn to, after `before` others of the same line.
fn polar_file(line: u32, before: usize) -> String {
    match before {
        0 => format!("diagnose-polar-line{line}"),
        n => format!("diagnose-polar-line{line}-{}", n + 1),
    }
}

/// A polar plot's title: the file, the circle's line, direction, plane and radius.
fn polar_title(name: &str, c: &Circle) -> String {
    format!(
        "{name}: line {} ({}{}) R{:.1} mm — radial deviation",
        c.line,
        if c.ccw {
            "counter-clockwise"
        } else {
            "clockwise"
        },
        if c.plane.is_xy() {
            String::new()
        } else {
            format!(", in {} ({})", c.plane.name(), c.plane.gcode())
        },
        mm_from_m(c.radius_m)
    )
}

#[cfg(test)]
mod tests {
    use super::polar_file;

    #[test]
    fn circles_of_one_line_are_drawn_to_files_of_their_own() {
        // A block run twice (a loop, a subprogram called twice) makes two circles of one
        // line: the first keeps the line's name, the next ones are counted after it.
        let names: Vec<String> = (0..3).map(|before| polar_file(13, before)).collect();
        assert_eq!(
            names,
            [
                "diagnose-polar-line13",
                "diagnose-polar-line13-2",
                "diagnose-polar-line13-3"
            ]
        );
        assert_eq!(polar_file(16, 0), "diagnose-polar-line16");
    }
}
