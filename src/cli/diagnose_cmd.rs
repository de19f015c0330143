//! `contourcheck diagnose`: what the model gets wrong against a measurement, the cause, the
//! fitted extension and the gain — for a measured trace of a program, or for a table of
//! steady following errors.

use std::path::{Path, PathBuf};

use clap::Args;

use super::Outcome;
use super::common::program_or_commands_path;
use super::common::{CliError, MachineArgs, PlanningArgs, TraceArgs, not_drawn_notes, spinner};
use crate::cli::output::{OutputBatch, outputs_apart, write_json};
use crate::diagnose::causes::{CauseId, CauseSet};
use crate::diagnose::report::{DiagnoseReport, machine_file};
use crate::diagnose::table::diagnose_table;
use crate::diagnose::{DiagnoseSettings, Diagnosis, diagnose_validated};
use crate::figures::DiagnoseFigures;
use crate::machine::MachineConfig;
use crate::numeric::units::m_from_um;
use crate::sim::MeasuredAt;
use crate::trace::measured::{MeasuredTrace, read_table};

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
    /// Write a one-page HTML report (self-contained, printable on A4): the record, the
    /// verdict, the causes ranked by their share of the residual with uncertainties and what
    /// to do, the circular-test figures, the plots.
    #[arg(long, value_name = "FILE.html")]
    pub report: Option<PathBuf>,
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

pub(crate) fn run(args: &DiagnoseArgs) -> Result<Outcome, CliError> {
    if !(args.evidence.is_finite() && args.evidence >= 0.0) {
        return Err(CliError::Usage(format!(
            "--evidence {}: must be a number ≥ 0",
            args.evidence
        )));
    }
    let mut inputs = vec![
        ("the program", args.program.as_deref()),
        ("--machine", args.machine.machine.as_deref()),
        ("--table", args.table.as_deref()),
        ("--trace-profile", args.trace.trace_profile.as_deref()),
    ];
    inputs.extend(
        args.measured
            .iter()
            .map(|m| ("--measured", Some(m.as_path()))),
    );
    // The files a compensation folder will hold are outputs too.
    let tables = (args.write_compensation.as_deref())
        .map(|dir| ["compensation.csv", "x.comp", "y.comp"].map(|name| dir.join(name)));
    let mut outputs = vec![
        ("--json", args.json.as_deref()),
        ("--report", args.report.as_deref()),
        ("--write-machine", args.write_machine.as_deref()),
    ];
    outputs.extend(
        tables
            .iter()
            .flatten()
            .map(|t| ("--write-compensation", Some(t.as_path()))),
    );
    outputs_apart(&inputs, &outputs)?;
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
    // Where the commands ask more than the machine allows is said once, in the report (from
    // where the model follows them), not also here.
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
        batch.stage(path, |w| write_json(w, &report))?;
    }
    if let Some(path) = &args.report {
        let page = crate::html_report::diagnose_page(d, &report, &args.machine.report_inputs())?;
        batch.stage(path, |w| w.write_all(page.as_bytes()))?;
    }
    if let Some(path) = &args.write_machine {
        let text = machine_file(&d.machine, d, program_file, &measured.file);
        batch.stage(path, |w| w.write_all(text.as_bytes()))?;
    }
    let mut compensation_note = None;
    if let Some(dir) = &args.write_compensation {
        compensation_note = Some(stage_compensation(&mut batch, dir, &d.machine)?);
    }
    let mut not_drawn = Vec::new();
    if let Some(dir) = &args.plot {
        std::fs::create_dir_all(dir).map_err(|e| CliError::Read {
            path: dir.display().to_string(),
            message: e.to_string(),
        })?;
        not_drawn = stage_plots(&mut batch, dir, d, program_file, footer)?;
    }
    let written = batch.destinations();
    batch.commit()?;
    print!("{report}");
    if let Some(note) = compensation_note {
        println!("{note}");
    }
    for path in written {
        println!("wrote {}", path.display());
    }
    for note in not_drawn {
        println!("{note}");
    }
    Ok(())
}

/// Stages the compensation tables of `machine` into `dir`; says what was written.
fn stage_compensation(
    batch: &mut OutputBatch,
    dir: &Path,
    machine: &crate::machine::MachineConfig,
) -> Result<String, CliError> {
    use crate::diagnose::compensation::{
        compensation, cyclic_errors_left_out, gaps_behind_a_scale, linuxcnc_file, neutral_csv,
    };
    let tables = compensation(machine);
    // A gap the loop takes out needs no entry; say why it is missing from the table.
    let mut left_out: String = gaps_behind_a_scale(machine)
        .iter()
        .map(|(axis, gap_um)| {
            format!(
                "\n  {axis}'s {gap_um:.2} µm backlash needs no entry: its loop closes on a linear \
                 scale beyond the gap and holds the table where the scale reads, so an offset \
                 would move the table by it"
            )
        })
        .collect();
    for (axis, why) in cyclic_errors_left_out(machine) {
        left_out.push_str(&format!("\n  {axis}: {why}"));
    }
    if tables.is_empty() {
        return Ok(format!(
            "compensation: nothing to compensate (no measuring error or map, no backlash \
             before the loop's feedback){left_out}"
        ));
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
    let mut not_written = String::new();
    for t in &tables {
        let name = format!("{}.comp", t.axis.to_string().to_lowercase());
        match linuxcnc_file(t) {
            Ok(text) => {
                batch.stage(&dir.join(&name), |w| w.write_all(text.as_bytes()))?;
                written.push(name);
            }
            Err(why) => {
                let stale = if dir.join(&name).exists() {
                    format!("; the {name} there is an earlier run's and no longer matches")
                } else {
                    String::new()
                };
                not_written.push_str(&format!("\n  {name} not written: {why}{stale}"));
            }
        }
    }
    Ok(format!(
        "compensation: {} in {}{not_written}{left_out}",
        written.join(", "),
        dir.display()
    ))
}

fn run_table(
    args: &DiagnoseArgs,
    path: &Path,
    machine: &crate::machine::MachineConfig,
) -> Result<Outcome, CliError> {
    if args.write_machine.is_some()
        || args.plot.is_some()
        || args.write_compensation.is_some()
        || args.report.is_some()
    {
        return Err(CliError::Usage(
            "--write-machine, --write-compensation, --plot and --report apply to traces, not \
             to --table"
                .into(),
        ));
    }
    let rows = read_table(path)?;
    let file = path.display().to_string();
    let bar = spinner("fitting the table");
    let d = diagnose_table(
        machine,
        &rows,
        &crate::sim::SimConfig::default(),
        args.evidence,
    )
    .map_err(|source| CliError::Table {
        file: file.clone(),
        source,
    })?;
    bar.finish_and_clear();
    if let Some(json) = &args.json {
        let mut batch = OutputBatch::new();
        batch.stage(json, |w| {
            write_json(w, &d.json_document(&file, &machine.name))
        })?;
        batch.commit()?;
    }
    print!("{}", d.summary_text(&file, &machine.name));
    Ok(Outcome::Ok)
}

fn stage_plots(
    batch: &mut OutputBatch,
    dir: &Path,
    d: &Diagnosis,
    program_file: &str,
    footer: &crate::plot::Footer,
) -> Result<Vec<String>, CliError> {
    let figures = DiagnoseFigures::of(d, program_file);
    for ext in ["png", "svg"] {
        for c in &figures.circles {
            batch.stage_with_path(&dir.join(format!("{}.{ext}", c.file)), |p| {
                crate::plot::render(p, &c.plot, footer)
            })?;
        }
        batch.stage_with_path(&dir.join(format!("diagnose-fit.{ext}")), |p| {
            crate::plot::render(p, &figures.fit, footer)
        })?;
        batch.stage_with_path(&dir.join(format!("diagnose-residual-time.{ext}")), |p| {
            crate::plot::render(p, &figures.over_time, footer)
        })?;
        batch.stage_with_path(&dir.join(format!("diagnose-residual-path.{ext}")), |p| {
            crate::plot::render(p, &figures.along_path, footer)
        })?;
    }
    Ok(not_drawn_notes(&figures.circles_not_drawn))
}
