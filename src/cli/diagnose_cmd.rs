//! `contourcheck diagnose`: what the model gets wrong against a measurement, the cause, the
//! fitted extension and the gain — for a measured trace of a program, or for a table of
//! steady following errors.

use std::path::{Path, PathBuf};

use clap::Args;

use super::Outcome;
use super::common::{CliError, MachineArgs, PlanningArgs, TraceArgs, spinner};
use super::common::{program_or_commands_path, warn_beyond_machine};
use crate::analysis::circular::radial_points;
use crate::causes::{CauseId, CauseSet};
use crate::cli::output::OutputBatch;
use crate::diagnose::report::{DiagnoseReport, machine_file};
use crate::diagnose::table::diagnose_table;
use crate::diagnose::{DiagnoseSettings, Diagnosis, diagnose_validated};
use crate::machine::MachineConfig;
use crate::plot::panels::{Curve, Panel, PanelsPlot};
use crate::plot::polar::{PolarPlot, PolarTrace};
use crate::sim::MeasuredAt;
use crate::trace::measured::{MeasuredTrace, read_table};
use crate::units::{m_from_um, mm_from_m, um_from_m};

/// Arguments of `diagnose`.
#[derive(Debug, Args)]
pub struct DiagnoseArgs {
    /// The part program the measurement ran (not needed with --table; without it, a record
    /// with its commands is compared with the path those commands drew).
    pub program: Option<PathBuf>,
    /// Measured trace: a table of time, measured X and Y and optionally the commanded X
    /// and Y — `t_s,x_mm,y_mm,x_cmd_mm,y_cmd_mm`, or a control's or lab's export (see
    /// --columns). Given twice, the causes are fitted on the first record and judged on
    /// the second (another run of the same program), instead of on a held-out half.
    #[arg(long, value_name = "FILE", conflicts_with = "table")]
    pub measured: Vec<PathBuf>,
    #[command(flatten)]
    pub trace: TraceArgs,
    /// Table of steady following errors instead of a trace: CSV with `table, axis,
    /// feed_mm_per_min, kv_m_per_min_per_mm, ks_nm_s_per_rad, following_error_mm` (the
    /// paper's Tables 3–5 ship as data/paper-tables.csv).
    #[arg(long, value_name = "FILE")]
    pub table: Option<PathBuf>,
    #[command(flatten)]
    pub machine: MachineArgs,
    #[command(flatten)]
    pub planning: PlanningArgs,
    /// Write the diagnosis as JSON (schema contourcheck.diagnose/1, or
    /// contourcheck.diagnose-table/1 with --table; see docs/report-schema.md).
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    /// Write the extended machine as a machine file for check, sweep and diagnose.
    #[arg(long, value_name = "FILE")]
    pub write_machine: Option<PathBuf>,
    /// Write the extended machine's static errors (measuring errors, a learned position
    /// map, backlash) as compensation tables into this directory: `compensation.csv`
    /// (axis, position, offsets forward and reverse) and LinuxCNC compensation files
    /// `x.comp`, `y.comp` (COMP_FILE_TYPE = 1, mm).
    #[arg(long, value_name = "DIR")]
    pub write_compensation: Option<PathBuf>,
    /// Write plots (PNG and SVG) into this directory: measured vs nominal vs extended, and
    /// the residual before and after over time and along the path.
    #[arg(long, value_name = "DIR")]
    pub plot: Option<PathBuf>,
    /// Most causes named.
    #[arg(long, default_value_t = 3, value_name = "N")]
    pub max_causes: usize,
    /// Evidence a cause needs (BIC units: 10 is very strong).
    #[arg(long, default_value_t = 10.0, value_name = "X")]
    pub evidence: f64,
    /// Align each stretch between standstills on its own clock, for a control whose
    /// in-position waits or dwells differ from the plan's and a measurement without
    /// recorded commands (the free offsets absorb part of any gain error or lag).
    #[arg(long)]
    pub align_stretches: bool,
    /// Where the measurement read the positions: a linear scale on the table, the motor's
    /// encoder, or at the tool (laser, ballbar). Causes the point cannot see are not tried.
    #[arg(long, value_enum, default_value_t = MeasuredAt::Table)]
    pub measured_at: MeasuredAt,
    /// Try only these causes (comma-separated ids, e.g. backlash,kv_gain).
    #[arg(long, value_name = "LIST", value_delimiter = ',')]
    pub causes: Vec<CauseId>,
    /// Never try these causes (comma-separated ids).
    #[arg(long, value_name = "LIST", value_delimiter = ',')]
    pub exclude: Vec<CauseId>,
    /// How far recorded commands may lie from the programmed geometry (µm): corner blending
    /// and another interpolator's chords stay within it.
    #[arg(long, default_value_t = 25.0, value_name = "UM")]
    pub command_tolerance_um: f64,
}

pub fn run(args: &DiagnoseArgs) -> Result<Outcome, CliError> {
    if !(args.evidence.is_finite() && args.evidence >= 0.0) {
        return Err(CliError::Usage(format!(
            "--evidence {}: must be a number ≥ 0",
            args.evidence
        )));
    }
    let machine = args.machine.load_stable()?;
    if let Some(table) = &args.table {
        return run_table(args, table, &machine);
    }
    let [measured_path, second @ ..] = &args.measured[..] else {
        return Err(CliError::Usage(
            "diagnose needs --measured TRACE.csv (and the program it ran), or --table TABLE.csv"
                .into(),
        ));
    };
    if second.len() > 1 {
        return Err(CliError::Usage(
            "--measured: one record to fit on and at most one to judge on".into(),
        ));
    }
    let read = |path: &PathBuf| -> Result<_, CliError> {
        let m = args.trace.read(path)?;
        eprintln!("{}: {}", m.file, m.layout.describe().join("\n  "));
        Ok(m)
    };
    let measured = read(measured_path)?;
    let program = program_or_commands_path(args.program.as_deref(), &measured, &machine)?;
    warn_beyond_machine(&measured, &machine);
    let validation = second.first().map(read).transpose()?;
    let settings = settings_of(args, &machine)?;
    let bar = spinner("fitting causes");
    let d = diagnose_validated(
        &program,
        &machine,
        &measured,
        validation.as_ref(),
        &settings,
    )?;
    bar.finish_and_clear();
    let footer = crate::plot::Footer::new(&machine.name)
        .program(&program.file)
        .feed(super::common::feed_text(&program.segments))
        .sampling(format!(
            "record sampled at {} Hz",
            (10.0 / measured.dt_s).round() / 10.0
        ));
    write_outputs(args, &d, &program.file, &measured, &machine, &footer)?;
    Ok(Outcome::Ok)
}

/// The diagnosis's settings from the flags.
fn settings_of(args: &DiagnoseArgs, machine: &MachineConfig) -> Result<DiagnoseSettings, CliError> {
    let mut settings = DiagnoseSettings::for_machine(machine);
    settings.compare.check.plan = args.planning.config(machine)?;
    settings.max_causes = args.max_causes;
    settings.evidence = args.evidence;
    settings.compare.align_stretches = args.align_stretches;
    settings.compare.measured_at = args.measured_at;
    settings.causes = if args.causes.is_empty() {
        CauseSet::ALL
    } else {
        CauseSet::of(&args.causes)
    }
    .without(&args.exclude);
    if !(args.command_tolerance_um.is_finite() && args.command_tolerance_um > 0.0) {
        return Err(CliError::Usage(format!(
            "--command-tolerance-um {}: must be a number > 0",
            args.command_tolerance_um
        )));
    }
    settings.compare.command_tolerance_m = m_from_um(args.command_tolerance_um);
    Ok(settings)
}

/// Writes what the flags ask for (whole or not at all), then prints the summary and what
/// was written.
fn write_outputs(
    args: &DiagnoseArgs,
    d: &Diagnosis,
    program_file: &str,
    measured: &MeasuredTrace,
    machine: &MachineConfig,
    footer: &crate::plot::Footer,
) -> Result<(), CliError> {
    let report = DiagnoseReport::new(d, program_file, measured, machine);
    let mut batch = OutputBatch::new();
    if let Some(path) = &args.json {
        batch.stage(path, |w| report.write_json(w))?;
    }
    if let Some(path) = &args.write_machine {
        let text = machine_file(&d.machine, d, program_file, &measured.file);
        batch.stage(path, |w| w.write_all(text.as_bytes()))?;
    }
    let mut compensation_note = None;
    if let Some(dir) = &args.write_compensation {
        compensation_note = Some(stage_compensation(&mut batch, dir, &d.machine)?);
    }
    if let Some(dir) = &args.plot {
        std::fs::create_dir_all(dir).map_err(|e| CliError::Read {
            path: dir.display().to_string(),
            message: e.to_string(),
        })?;
        stage_plots(&mut batch, dir, d, program_file, footer)?;
    }
    let written = batch.destinations();
    batch.commit()?;
    print!("{}", report.summary_text());
    if let Some(note) = compensation_note {
        println!("{note}");
    }
    for path in written {
        println!("wrote {}", path.display());
    }
    Ok(())
}

/// Stages the compensation tables of `machine` into `dir`; says what was written.
fn stage_compensation(
    batch: &mut OutputBatch,
    dir: &Path,
    machine: &crate::machine::MachineConfig,
) -> Result<String, CliError> {
    use crate::compensation::{compensation, linuxcnc_file, neutral_csv};
    let tables = compensation(machine);
    if tables.is_empty() {
        return Ok(
            "compensation: nothing to compensate (no measuring error, map or backlash)".into(),
        );
    }
    std::fs::create_dir_all(dir).map_err(|e| CliError::Read {
        path: dir.display().to_string(),
        message: e.to_string(),
    })?;
    let csv = neutral_csv(&tables);
    batch.stage(&dir.join("compensation.csv"), |w| {
        w.write_all(csv.as_bytes())
    })?;
    let mut written = vec!["compensation.csv".to_string()];
    for t in &tables {
        let name = format!("{}.comp", t.axis.to_string().to_lowercase());
        let text = linuxcnc_file(t);
        batch.stage(&dir.join(&name), |w| w.write_all(text.as_bytes()))?;
        written.push(name);
    }
    Ok(format!(
        "compensation: {} in {}",
        written.join(", "),
        dir.display()
    ))
}

fn run_table(
    args: &DiagnoseArgs,
    path: &Path,
    machine: &crate::machine::MachineConfig,
) -> Result<Outcome, CliError> {
    if args.write_machine.is_some() || args.plot.is_some() || args.write_compensation.is_some() {
        return Err(CliError::Usage(
            "--write-machine, --write-compensation and --plot apply to traces, not to --table"
                .into(),
        ));
    }
    let rows = read_table(path)?;
    let bar = spinner("fitting the table");
    let d = diagnose_table(
        machine,
        &rows,
        &crate::sim::SimConfig::default(),
        args.evidence,
    )?;
    bar.finish_and_clear();
    let file = path.display().to_string();
    if let Some(json) = &args.json {
        let mut batch = OutputBatch::new();
        batch.stage(json, |w| d.write_json(w, &file, &machine.name))?;
        batch.commit()?;
    }
    print!("{}", d.summary_text(&file, &machine.name));
    Ok(Outcome::Ok)
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

fn stage_plots(
    batch: &mut OutputBatch,
    dir: &Path,
    d: &Diagnosis,
    program_file: &str,
    footer: &crate::plot::Footer,
) -> Result<(), CliError> {
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
    let fit = fit_plot(d, &name, &extended_name);
    let [over_time, along_path] = residual_plots(d, &name);
    let polar = polar_plots(d, &name, &extended_name);
    for ext in ["png", "svg"] {
        for (c, figure) in d.circles.iter().zip(&polar) {
            batch.stage_with_path(
                &dir.join(format!("diagnose-polar-line{}.{ext}", c.line)),
                |p| crate::plot::render(p, figure, footer),
            )?;
        }
        batch.stage_with_path(&dir.join(format!("diagnose-fit.{ext}")), |p| {
            crate::plot::render(p, &fit, footer)
        })?;
        batch.stage_with_path(&dir.join(format!("diagnose-residual-time.{ext}")), |p| {
            crate::plot::render(p, &over_time, footer)
        })?;
        batch.stage_with_path(&dir.join(format!("diagnose-residual-path.{ext}")), |p| {
            crate::plot::render(p, &along_path, footer)
        })?;
    }
    Ok(())
}

/// Each axis's deviation from the command, measured and by both models, around where the
/// nominal model misses most, and beneath it the miss itself (model − measured) at its own
/// scale: a 6 µm miss on a 500 µm following error is invisible on the deviation's.
fn fit_plot(d: &Diagnosis, name: &str, extended_name: &str) -> PanelsPlot {
    let s = &d.series;
    let t = &s.t_s;
    let panels = |a: usize| {
        let axis = ["x", "y"][a];
        let worst = d.places.iter().find(|p| p.what == axis);
        let keep: Vec<usize> = match worst {
            Some(p) => (0..t.len())
                .filter(|&k| (t[k] - p.t_s).abs() <= ZOOM_HALF_S)
                .collect(),
            None => (0..t.len()).collect(),
        };
        let tk: Vec<f64> = keep.iter().map(|&k| t[k]).collect();
        let series = |value: &dyn Fn(usize) -> f64| curve_points(&tk, &tk, |j| value(keep[j]));
        let dev = |model: &[f64]| series(&|k| um_from_m(model[k] - s.reference[a][k]));
        let miss = |model: &[f64]| series(&|k| um_from_m(model[k] - s.measured[a][k]));
        let curve = |name: &str, points, color, width| Curve {
            name: name.to_string(),
            points,
            color,
            width,
        };
        let upper = axis.to_uppercase();
        let caption = match worst {
            Some(p) => format!(
                "{upper} axis: position − command around t = {:.2} s (line {}), where the nominal model misses most",
                p.t_s, p.line
            ),
            None => format!("{upper} axis: position − command"),
        };
        [
            Panel {
                caption,
                y_label: "µm".into(),
                curves: vec![
                    curve("measured", dev(&s.measured[a]), None, 3),
                    curve("nominal model", dev(&s.nominal[a]), Some(1), 2),
                    curve(extended_name, dev(&s.extended[a]), Some(0), 2),
                ],
            },
            Panel {
                caption: format!("{upper} axis there: model − measured"),
                y_label: "µm".into(),
                curves: vec![
                    curve("nominal model", miss(&s.nominal[a]), Some(1), 2),
                    curve(extended_name, miss(&s.extended[a]), Some(0), 2),
                ],
            },
        ]
    };
    PanelsPlot {
        title: format!("{name}: measured against the nominal and the extended model"),
        x_label: "program time (s)".into(),
        panels: panels(0).into_iter().chain(panels(1)).collect(),
    }
}

/// The residual of both models over time (X, Y, contour) and along the path (contour).
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
        "contour error: measured − model (RMS {:.3} → {:.3} µm)",
        d.before.contour.rms_um, d.after.contour.rms_um
    );
    let contour_before = |k: usize| um_from_m(s.contour_residual[0][k]);
    let contour_after = |k: usize| um_from_m(s.contour_residual[1][k]);
    let over_time = PanelsPlot {
        title: format!("{name}: residual before and after the extension, over time"),
        x_label: "program time (s)".into(),
        panels: vec![
            axis_residual(0),
            axis_residual(1),
            residual_panel(contour_caption.clone(), &contour_before, &contour_after, t),
        ],
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

/// Ballbar-style: each full circle's radial deviation, measured and by both models.
fn polar_plots(d: &Diagnosis, name: &str, extended_name: &str) -> Vec<PolarPlot> {
    let s = &d.series;
    d.circles
        .iter()
        .map(|c| {
            let g_of = |test: &crate::analysis::circular::CircularTest| {
                test.circles
                    .iter()
                    .find(|f| f.line == c.line)
                    .map(|f| f.g_um)
            };
            let trace = |label: &str, xy: &[Vec<f64>; 2], width: u32, g_um| PolarTrace {
                label: label.to_string(),
                width,
                g_um,
                points: radial_points(c, &s.segment, &xy[0], &xy[1])
                    .into_iter()
                    .map(|(a, r)| (a, um_from_m(r)))
                    .collect(),
            };
            PolarPlot {
                title: format!(
                    "{name}: line {} ({}) R{:.1} mm — radial deviation",
                    c.line,
                    if c.ccw {
                        "counter-clockwise"
                    } else {
                        "clockwise"
                    },
                    mm_from_m(c.radius_m)
                ),
                radius_mm: mm_from_m(c.radius_m),
                traces: vec![
                    trace("measured", &s.measured, 1, g_of(&d.circular.measured)),
                    trace("nominal model", &s.nominal, 2, g_of(&d.circular.nominal)),
                    trace(extended_name, &s.extended, 2, g_of(&d.circular.extended)),
                ],
            }
        })
        .collect()
}
