//! `contourcheck check`: the main job — predicted contour error, hotspots, reports, plots.

use std::path::{Path, PathBuf};

use clap::Args;

use super::Outcome;
use super::common::{CliError, MachineArgs, PlanningArgs, group_warnings, load_program, progress};
use crate::check::{CheckResult, CheckSettings, check_planned, circle_tests};
use crate::cli::output::OutputBatch;
use crate::gcode::SourceFile;
use crate::gcode::interp::SourceLine;
use crate::path::{Geometry, Motion};
use crate::plan::{KinematicLimits, plan_segments};
use crate::plot::along_path::AlongPathPlot;
use crate::plot::polar::{PolarPlot, PolarTrace};
use crate::plot::toolpath::{Marker, PathPoint, ToolpathPlot};
use crate::report::{CheckReport, TraceCsv, summary_text};
use crate::units::{mm_from_m, um_from_m};

/// Arguments of `check`.
#[derive(Debug, Args)]
pub struct CheckArgs {
    /// The part program.
    pub program: PathBuf,
    #[command(flatten)]
    pub machine: MachineArgs,
    #[command(flatten)]
    pub planning: PlanningArgs,
    /// Write the report as JSON (schema contourcheck.check/1, see docs/report-schema.md).
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    /// Write the run as CSV: commanded and actual positions, following and contour errors.
    #[arg(long, value_name = "FILE")]
    pub trace: Option<PathBuf>,
    /// Keep every Nth sample in the trace CSV.
    #[arg(long, default_value_t = 1, value_name = "N")]
    pub trace_every: usize,
    /// Write plots (PNG and SVG) into this directory: toolpath, contour error along the path,
    /// and a polar plot per circular test.
    #[arg(long, value_name = "DIR")]
    pub plot: Option<PathBuf>,
    /// Exit with status 1 when the predicted largest contour error exceeds this (µm).
    #[arg(long, value_name = "UM")]
    pub tolerance: Option<f64>,
    /// Hotspots listed on the terminal.
    #[arg(long, default_value_t = 10, value_name = "N")]
    pub hotspots: usize,
}

pub fn run(args: &CheckArgs) -> Result<Outcome, CliError> {
    if let Some(t) = args.tolerance
        && !(t.is_finite() && t > 0.0)
    {
        return Err(CliError::Usage(format!(
            "--tolerance {t}: must be a positive number of µm"
        )));
    }
    let machine = args.machine.load_stable()?;
    let mut settings = CheckSettings::for_machine(&machine);
    settings.plan = args.planning.config(&machine)?;
    let mut program = load_program(&args.program, &machine)?;
    // The plan takes the segments over: a long program is not held twice.
    let segments = std::mem::take(&mut program.segments);
    let planned = plan_segments(segments, &KinematicLimits::of(&machine), &settings.plan);
    // The waits at exact stops come out of the simulation: the plan's estimate sizes the bar.
    let samples = (planned.total_time_s + settings.settle_s) / planned.config.cycle_s;
    let bar = progress(2 * samples.ceil() as u64, "simulating X and Y");
    // Outputs are staged as the run goes (the trace row by row) and appear together at the
    // end, or not at all.
    let mut batch = OutputBatch::new();
    let mut trace = match &args.trace {
        Some(path) => Some((
            batch.stage_writer(path)?,
            TraceCsv::of(&program, args.trace_every),
        )),
        None => None,
    };
    let result = check_planned(
        planned,
        &machine,
        &settings,
        &|n| bar.inc(n),
        &mut |chunk, points| {
            if let Some((file, csv)) = &mut trace {
                file.write(|w| csv.write_chunk(w, chunk, points))?;
            }
            Ok::<(), CliError>(())
        },
    )?;
    bar.finish_and_clear();
    if let Some((file, _)) = trace {
        file.finish()?;
    }
    let report = CheckReport::new(&result, &settings, &program, &machine, args.tolerance);
    write_outputs(args, batch, &result, &report, &program.sources)?;
    print!("{}", summary_text(&report, args.hotspots));
    let warnings = group_warnings(&report.warnings);
    if !warnings.is_empty() {
        println!("\nwarnings");
        for w in warnings {
            println!("  {w}");
        }
    }
    Ok(match report.within_tolerance {
        Some(false) => Outcome::OverTolerance,
        _ => Outcome::Ok,
    })
}

/// Stages the report and plots beside what the run staged, then makes them all visible
/// together.
fn write_outputs(
    args: &CheckArgs,
    mut batch: OutputBatch,
    run: &CheckResult,
    report: &CheckReport,
    sources: &[SourceFile],
) -> Result<(), CliError> {
    if let Some(path) = &args.json {
        batch.stage(path, |w| report.write_json(w))?;
    }
    let mut plots = Vec::new();
    if let Some(dir) = &args.plot {
        std::fs::create_dir_all(dir).map_err(|e| CliError::Read {
            path: dir.display().to_string(),
            message: e.to_string(),
        })?;
        plots = stage_plots(&mut batch, dir, run, report, sources)?;
    }
    batch.commit()?;
    if let Some(path) = &args.json {
        println!("report: {}", path.display());
    }
    for path in plots {
        println!("plot: {}", path.display());
    }
    Ok(())
}

fn stage_plots(
    batch: &mut OutputBatch,
    dir: &Path,
    run: &CheckResult,
    report: &CheckReport,
    sources: &[SourceFile],
) -> Result<Vec<std::path::PathBuf>, CliError> {
    // A line as the plots label it: `29`, or `BOSS.SPF:8` in a subprogram's file.
    let at = |line: u32| SourceLine::among(sources, line).short();
    let name = Path::new(&report.program.file)
        .file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    let toolpaths: Vec<(&str, ToolpathPlot)> = views(run)
        .into_iter()
        .map(|view| (view.file, toolpath_figure(run, &name, report, &at, &view)))
        .collect();
    let along = along_path_figure(run, &name, &at);
    let circles = polar_figures(run, &name, &at);
    let mut written = Vec::new();
    for ext in ["png", "svg"] {
        for (file, toolpath) in &toolpaths {
            let path = dir.join(format!("{file}.{ext}"));
            batch.stage_with_path(&path, |p| crate::plot::render(p, toolpath))?;
            written.push(path);
        }
        let path = dir.join(format!("contour-along-path.{ext}"));
        batch.stage_with_path(&path, |p| crate::plot::render(p, &along))?;
        written.push(path);
        for (i, c) in circles.iter().enumerate() {
            let path = dir.join(format!("circle-{}.{ext}", i + 1));
            batch.stage_with_path(&path, |p| crate::plot::render(p, c))?;
            written.push(path);
        }
    }
    Ok(written)
}

/// A view of the toolpath: the axes it shows (indices into X, Y, Z) and the file it goes to.
struct View {
    axes: [usize; 2],
    file: &'static str,
}

/// The toolpath's views: from above (XY) always; where Z is simulated and the program cuts
/// while moving Z, also from the front (XZ) and the side (YZ).
fn views(run: &CheckResult) -> Vec<View> {
    let mut views = vec![View {
        axes: [0, 1],
        file: "toolpath",
    }];
    let cuts_in_z = run.plan.segments.iter().any(|s| {
        s.motion == Motion::Feed && !s.is_dwell() && {
            let [_, _, [z0, z1]] = s.extent_m();
            z1 > z0
        }
    });
    if run.summary.z_following_error_m.is_some() && cuts_in_z {
        views.push(View {
            axes: [0, 2],
            file: "toolpath-xz",
        });
        views.push(View {
            axes: [1, 2],
            file: "toolpath-yz",
        });
    }
    views
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
                label: format!(" {}: L{}", i + 1, at(spot.line)),
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
        .map(|(i, h)| {
            (
                h.path_mm,
                h.error_um,
                format!(" {}: L{}", i + 1, at(h.line)),
            )
        })
        .collect();
    AlongPathPlot {
        title: format!("{name}: contour error along the path"),
        points,
        markers,
    }
}

/// One polar plot per circle, both directions together when the program runs the same
/// circle both ways.
fn polar_figures(run: &CheckResult, name: &str, at: &dyn Fn(u32) -> String) -> Vec<PolarPlot> {
    let mut groups: Vec<Vec<crate::check::CircleTest>> = Vec::new();
    for c in circle_tests(run) {
        let same = |g: &Vec<crate::check::CircleTest>| {
            let a = &g[0];
            (a.center_m[0] - c.center_m[0]).hypot(a.center_m[1] - c.center_m[1]) < 1e-6
                && (a.radius_m - c.radius_m).abs() < 1e-6
        };
        match groups.iter_mut().find(|g| same(g)) {
            Some(g) => g.push(c),
            None => groups.push(vec![c]),
        }
    }
    groups
        .into_iter()
        .map(|g| {
            let r = g[0].radius_m;
            PolarPlot {
                title: format!(
                    "{name}: circular test R{:.1} mm, centre ({:.1}, {:.1}) — radial deviation",
                    mm_from_m(r),
                    mm_from_m(g[0].center_m[0]),
                    mm_from_m(g[0].center_m[1])
                ),
                radius_mm: mm_from_m(r),
                traces: g
                    .iter()
                    .map(|c| PolarTrace {
                        label: format!(
                            "{} (line {})",
                            if c.ccw {
                                "counter-clockwise"
                            } else {
                                "clockwise"
                            },
                            at(c.line)
                        ),
                        points: c.points.iter().map(|&(a, d)| (a, um_from_m(d))).collect(),
                        width: 2,
                        g_um: run
                            .circular
                            .circles
                            .iter()
                            .find(|f| f.line == c.line)
                            .map(|f| f.g_um),
                    })
                    .collect(),
            }
        })
        .collect()
}
