//! The figures of a check: the toolpath coloured by contour error, the error along the path,
//! and a ballbar-style polar plot per circular test — drawn as files by `check --plot` and
//! inline in the HTML report.

use super::{CirclePlot, NotDrawn};
use crate::analysis::polar_points::too_sparse_for_a_plot;
use crate::check::report::CheckReport;
use crate::check::{CheckResult, CircleTest, circle_tests};
use crate::gcode::SourceFile;
use crate::gcode::interp::SourceLine;
use crate::numeric::units::{mm_from_m, um_from_m};
use crate::path::{Geometry, Motion};
use crate::plot::along_path::AlongPathPlot;
use crate::plot::polar::{PolarPlot, PolarTrace};
use crate::plot::toolpath::{Marker, PathPoint, ToolpathPlot};

/// Every figure of a check.
pub struct CheckFigures {
    /// The programmed and the predicted path seen from above (XY), coloured by contour
    /// error, hotspots marked.
    pub toolpath: ToolpathPlot,
    /// Where Z is simulated and the program cuts while moving Z: the path from the front
    /// (XZ) and the side (YZ), each with the file name it is drawn to.
    pub side_views: Vec<(&'static str, ToolpathPlot)>,
    /// The contour error against the path length.
    pub along_path: AlongPathPlot,
    /// One polar plot per circle (both directions on one plot where the program runs
    /// both), drawn to `circle-N`: N the circle's number among all the program's circles
    /// in order, whether drawn or not.
    pub circles: Vec<CirclePlot>,
    /// The circles whose path gives too few points per turn for a polar plot: each one's
    /// line and why it has none.
    pub circles_not_drawn: Vec<NotDrawn>,
}

impl CheckFigures {
    /// The figures of a run; `sources` names the lines of subprograms' own files.
    pub(crate) fn of(run: &CheckResult, report: &CheckReport, sources: &[SourceFile]) -> Self {
        // A line as the plots label it: `29`, or `BOSS.SPF:8` in a subprogram's file.
        let at = |line: u32| SourceLine::among(sources, line).short();
        let name = std::path::Path::new(&report.program.file)
            .file_name()
            .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
        let figure = |view: &View| toolpath_figure(run, &name, report, &at, view);
        let (circles, circles_not_drawn) = polar_figures(run, &name, &at);
        CheckFigures {
            toolpath: figure(&FROM_ABOVE),
            side_views: side_views(run)
                .iter()
                .map(|view| (view.file, figure(view)))
                .collect(),
            along_path: along_path_figure(run, &name, &at),
            circles,
            circles_not_drawn,
        }
    }
}

/// A view of the toolpath: the axes it shows (indices into X, Y, Z) and the file it goes to.
struct View {
    axes: [usize; 2],
    file: &'static str,
}

const FROM_ABOVE: View = View {
    axes: [0, 1],
    file: "toolpath",
};

/// The views besides the one from above: where Z is simulated and moves along the contour
/// (not only in plunges), from the front (XZ) and the side (YZ).
fn side_views(run: &CheckResult) -> Vec<View> {
    let cuts_in_z = run.plan.segments.iter().any(|s| s.cuts_in_space());
    if run.summary.z_following_error_m.is_none() || !cuts_in_z {
        return Vec::new();
    }
    vec![
        View {
            axes: [0, 2],
            file: "toolpath-xz",
        },
        View {
            axes: [1, 2],
            file: "toolpath-yz",
        },
    ]
}

/// Programmed feed moves as polylines (mm) in `view`.
fn programmed_polylines(run: &CheckResult, view: &View) -> Vec<Vec<(f64, f64)>> {
    let [h, v] = view.axes;
    let seen = |p: [f64; 3]| (mm_from_m(p[h]), mm_from_m(p[v]));
    run.plan
        .segments
        .iter()
        .filter(|s| s.motion == Motion::Feed)
        .map(|s| match s.geometry {
            Geometry::Arc(a) => {
                let n = ((a.sweep_rad.abs() / 0.02).ceil() as usize).max(2);
                (0..=n)
                    .map(|i| seen(s.point_at_param(i as f64 / n as f64)))
                    .collect()
            }
            _ => vec![seen(s.start_m), seen(s.end_m)],
        })
        .collect()
}

fn toolpath_figure(
    run: &CheckResult,
    name: &str,
    report: &CheckReport,
    at: &dyn Fn(u32) -> String,
    view: &View,
) -> ToolpathPlot {
    let [h, v] = view.axes;
    let actual = run
        .plot
        .iter()
        .map(|p| {
            let q = [p.pos_m[0], p.pos_m[1], p.z_m];
            PathPoint {
                x_mm: mm_from_m(q[h]),
                y_mm: mm_from_m(q[v]),
                error_um: um_from_m(p.error_m.abs()),
            }
        })
        .collect();
    let markers = run
        .hotspots
        .iter()
        .take(10)
        .enumerate()
        .map(|(i, spot)| {
            let q = [spot.x_mm, spot.y_mm, spot.z_mm.unwrap_or(f64::NAN)];
            Marker {
                x_mm: q[h],
                y_mm: q[v],
                label: format!("{}: L{}", i + 1, at(spot.line)),
            }
        })
        .collect();
    let names = ["X", "Y", "Z"];
    ToolpathPlot {
        title: format!(
            "{name}: predicted contour error on {} (max {:.2} µm)",
            report.machine.name, report.contour_error_um.max
        ),
        programmed: programmed_polylines(run, view),
        actual,
        markers,
        axes: [names[h], names[v]],
    }
}

fn along_path_figure(run: &CheckResult, name: &str, at: &dyn Fn(u32) -> String) -> AlongPathPlot {
    let points = run
        .plot
        .iter()
        .map(|p| (mm_from_m(p.path_s_m), um_from_m(p.error_m)))
        .collect();
    let markers = run
        .hotspots
        .iter()
        .take(10)
        .enumerate()
        .map(|(i, h)| (h.path_mm, h.error_um, format!("{}: L{}", i + 1, at(h.line))))
        .collect();
    AlongPathPlot {
        title: format!("{name}: contour error along the path"),
        points,
        markers,
    }
}

/// The run's circles, both directions of one circle (the same plane, height, centre and
/// radius) together, in the program's order.
fn circle_groups(run: &CheckResult) -> Vec<Vec<CircleTest>> {
    let mut groups: Vec<Vec<CircleTest>> = Vec::new();
    for c in circle_tests(run) {
        match groups
            .iter_mut()
            .find(|g| g[0].circle.is_same_circle(&c.circle))
        {
            Some(g) => g.push(c),
            None => groups.push(vec![c]),
        }
    }
    groups
}

/// One polar plot per circle, both directions together when the program runs the same
/// circle both ways, numbered as the circles come (a number is kept by a circle drawn
/// after one that is not); and each direction whose path gives too few points per turn
/// for a plot, with why.
fn polar_figures(
    run: &CheckResult,
    name: &str,
    at: &dyn Fn(u32) -> String,
) -> (Vec<CirclePlot>, Vec<NotDrawn>) {
    let mut not_drawn = Vec::new();
    let mut drawn = Vec::new();
    for (number, group) in circle_groups(run).into_iter().enumerate() {
        let group: Vec<CircleTest> = group
            .into_iter()
            .filter(|c| match too_sparse_for_a_plot(&c.points) {
                Some(why) => {
                    not_drawn.push(NotDrawn {
                        line: c.circle.line,
                        why,
                    });
                    false
                }
                None => true,
            })
            .collect();
        if let Some(first) = group.first() {
            drawn.push(CirclePlot {
                line: first.circle.line,
                file: format!("circle-{}", number + 1),
                plot: polar_figure(run, &group, name, at),
            });
        }
    }
    (drawn, not_drawn)
}

/// The polar plot of one circle's directions `g` (at least one).
fn polar_figure(
    run: &CheckResult,
    g: &[CircleTest],
    name: &str,
    at: &dyn Fn(u32) -> String,
) -> PolarPlot {
    let c = &g[0].circle;
    let r = c.radius_m;
    let [.., normal] = c.plane.axes().map(|i| ['X', 'Y', 'Z'][i]);
    PolarPlot {
        title: format!(
            "{name}: circular test R{:.1} mm, centre ({:.1}, {:.1}) mm, {} at {normal} {:.1} mm \
             — radial deviation",
            mm_from_m(r),
            mm_from_m(c.center_m[0]),
            mm_from_m(c.center_m[1]),
            c.plane.name(),
            mm_from_m(c.height_m)
        ),
        radius_mm: mm_from_m(r),
        traces: g
            .iter()
            .map(|c| PolarTrace {
                label: format!(
                    "{} (line {})",
                    if c.circle.ccw {
                        "counter-clockwise"
                    } else {
                        "clockwise"
                    },
                    at(c.circle.line)
                ),
                points: c.points.iter().map(|&(a, d)| (a, um_from_m(d))).collect(),
                width: 2,
                g_um: run
                    .circular
                    .circles
                    .iter()
                    .find(|f| f.segment == c.circle.segment)
                    .map(|f| f.g_um),
            })
            .collect(),
    }
}
