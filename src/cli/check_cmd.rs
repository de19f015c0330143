//! `contourcheck check`: the main job — predicted contour error, hotspots, reports, plots.

use std::path::{Path, PathBuf};

use clap::Args;

use super::Outcome;
use super::check_text::{TraceCsv, summary_text};
use super::common::{CliError, MachineArgs, PlanningArgs, load_program, not_drawn_notes, progress};
use crate::check::report::{CheckReport, group_warnings};
use crate::check::{CheckResult, CheckSettings, check_planned};
use crate::cli::output::{OutputBatch, outputs_apart, write_json};
use crate::figures::CheckFigures;
use crate::gcode::SourceFile;
use crate::plan::{KinematicLimits, plan_segments};

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
    /// Write a one-page HTML report (self-contained, printable on A4): test conditions,
    /// verdict against --tolerance, circular-test figures and polar plots, hotspots, toolpath.
    #[arg(long, value_name = "FILE.html")]
    pub report: Option<PathBuf>,
    /// Keep every Nth sample in the trace CSV (with --trace).
    #[arg(long, default_value_t = 1, value_name = "N", requires = "trace")]
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

pub(crate) fn run(args: &CheckArgs) -> Result<Outcome, CliError> {
    if let Some(t) = args.tolerance
        && !(t.is_finite() && t > 0.0)
    {
        return Err(CliError::Usage(format!(
            "--tolerance {t}: must be a positive number of µm"
        )));
    }
    if args.trace_every == 0 {
        return Err(CliError::Usage(
            "--trace-every 0: keep every Nth sample, N at least 1".into(),
        ));
    }
    outputs_apart(
        &[
            ("the program", Some(&args.program)),
            ("--machine", args.machine.machine.as_deref()),
        ],
        &[
            ("--json", args.json.as_deref()),
            ("--trace", args.trace.as_deref()),
            ("--report", args.report.as_deref()),
        ],
    )?;
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
        batch.stage(path, |w| write_json(w, &report))?;
    }
    if let Some(path) = &args.report {
        let inputs = args.machine.report_inputs();
        let page = crate::html_report::check_page(run, report, sources, &inputs)?;
        batch.stage(path, |w| w.write_all(page.as_bytes()))?;
    }
    let (mut plots, mut not_drawn) = (Vec::new(), Vec::new());
    if let Some(dir) = &args.plot {
        std::fs::create_dir_all(dir).map_err(|e| CliError::Read {
            path: dir.display().to_string(),
            message: e.to_string(),
        })?;
        (plots, not_drawn) = stage_plots(&mut batch, dir, run, report, sources)?;
    }
    batch.commit()?;
    for path in [&args.json, &args.report].into_iter().flatten() {
        println!("report: {}", path.display());
    }
    for path in plots {
        println!("plot: {}", path.display());
    }
    for note in not_drawn {
        println!("{note}");
    }
    Ok(())
}

fn stage_plots(
    batch: &mut OutputBatch,
    dir: &Path,
    run: &CheckResult,
    report: &CheckReport,
    sources: &[SourceFile],
) -> Result<(Vec<std::path::PathBuf>, Vec<String>), CliError> {
    let figures = CheckFigures::of(run, report, sources);
    let footer = super::common::run_footer(
        &report.machine.name,
        &report.program.file,
        &run.plan.segments,
        run.plan.config.cycle_s,
    );
    let mut written = Vec::new();
    for ext in ["png", "svg"] {
        let path = dir.join(format!("toolpath.{ext}"));
        batch.stage_with_path(&path, |p| {
            crate::plot::render(p, &figures.toolpath, &footer)
        })?;
        written.push(path);
        for (file, view) in &figures.side_views {
            let path = dir.join(format!("{file}.{ext}"));
            batch.stage_with_path(&path, |p| crate::plot::render(p, view, &footer))?;
            written.push(path);
        }
        let path = dir.join(format!("contour-along-path.{ext}"));
        batch.stage_with_path(&path, |p| {
            crate::plot::render(p, &figures.along_path, &footer)
        })?;
        written.push(path);
        for c in &figures.circles {
            let path = dir.join(format!("{}.{ext}", c.file));
            batch.stage_with_path(&path, |p| crate::plot::render(p, &c.plot, &footer))?;
            written.push(path);
        }
    }
    Ok((written, not_drawn_notes(&figures.circles_not_drawn)))
}
