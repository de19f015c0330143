//! `contourcheck identify`: a machine file fitted to a record with its commands, starting
//! from a template (a preset or a file).

use std::path::PathBuf;

use clap::Args;

use super::Outcome;
use super::common::{CliError, PlanningArgs, TraceArgs, spinner};
use super::common::{program_or_commands_path, warn_beyond_machine};
use crate::cli::output::{OutputBatch, outputs_apart, write_json};
use crate::compare::CompareSettings;
use crate::identify::identify;
use crate::identify::report::{IdentifyReport, machine_file, summary_text};
use crate::numeric::units::m_from_um;
use crate::sim::MeasuredAt;

/// Arguments of `identify`.
#[derive(Debug, Args)]
pub struct IdentifyArgs {
    /// The part program the record ran (without it, the path the record's commands drew).
    pub program: Option<PathBuf>,
    /// The record: time, measured X and Y and the commanded X and Y (the commands are
    /// required: identification compares what the axes did with what they were told).
    #[arg(long, value_name = "FILE")]
    pub measured: PathBuf,
    #[command(flatten)]
    pub trace: TraceArgs,
    /// Where to start: a machine file, or a preset's name (`hvmc`, `small-table`). Its
    /// controller structure is kept; the controller's gains (and a transfer function's real
    /// corners), the mass, friction and dead time are fitted. `none`: no template — a model
    /// of each axis's loop from command to position (a cascade, or an integrating lead-lag
    /// commanding current), of the family and order the record's held-out halves choose,
    /// whose values describe the loop rather than the machine's parts.
    #[arg(long, value_name = "FILE|PRESET", default_value = "hvmc")]
    pub template: PathBuf,
    /// Write the identified machine here (a machine file `check` and `diagnose` take).
    #[arg(long, short, value_name = "FILE")]
    pub out: PathBuf,
    /// Write the identification as JSON.
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    /// Write a one-page HTML report (self-contained, printable on A4): the template's values
    /// against the identified ones with their uncertainties, the residuals and the held-out
    /// figure.
    #[arg(long, value_name = "FILE.html")]
    pub report: Option<PathBuf>,
    #[command(flatten)]
    pub planning: PlanningArgs,
    /// How far recorded commands may lie from the programmed geometry (µm).
    #[arg(long, default_value_t = 25.0, value_name = "UM")]
    pub command_tolerance_um: f64,
    /// Where the measurement read the positions: a linear scale on the table, the motor's
    /// encoder, or at the tool (laser, ballbar). The model is compared at that point.
    #[arg(long, value_enum, default_value_t = MeasuredAt::Table)]
    pub measured_at: MeasuredAt,
}

pub(crate) fn run(args: &IdentifyArgs) -> Result<Outcome, CliError> {
    // `none`: no template — a model of each loop, started from the record itself.
    let inputs = [
        ("the program", args.program.as_deref()),
        ("--measured", Some(args.measured.as_path())),
        ("--template", Some(args.template.as_path())),
        ("--trace-profile", args.trace.trace_profile.as_deref()),
    ];
    let outputs = [
        ("--out", Some(args.out.as_path())),
        ("--json", args.json.as_deref()),
        ("--report", args.report.as_deref()),
    ];
    outputs_apart(&inputs, &outputs)?;
    let without_template = args.template.as_os_str() == "none";
    let measured = args.trace.read(&args.measured)?;
    let template = if without_template {
        crate::identify::loop_template(&measured)
    } else {
        super::common::MachineArgs {
            machine: Some(args.template.clone()),
        }
        .load_given_as("--template")?
    };
    eprintln!(
        "{}: {}",
        measured.file,
        measured.layout.describe().join("\n  ")
    );
    let program = program_or_commands_path(args.program.as_deref(), &measured, &template)?;
    warn_beyond_machine(&measured, &template);
    if !(args.command_tolerance_um.is_finite() && args.command_tolerance_um > 0.0) {
        return Err(CliError::Usage(format!(
            "--command-tolerance-um {}: must be a number > 0",
            args.command_tolerance_um
        )));
    }
    let mut settings = CompareSettings::for_machine(&template);
    settings.check.plan = args.planning.config(&template)?;
    settings.command_tolerance_m = m_from_um(args.command_tolerance_um);
    settings.measured_at = args.measured_at;
    let bar = spinner("identifying");
    let id = if without_template {
        crate::identify::identify_loop(&program, &template, &measured, &settings)?
    } else {
        identify(&program, &template, &measured, &settings)?
    };
    bar.finish_and_clear();
    let program_file = program.file.clone();
    let mut batch = OutputBatch::new();
    let machine_text = machine_file(&id, &template, &program_file);
    batch.stage(&args.out, |w| w.write_all(machine_text.as_bytes()))?;
    let report = IdentifyReport::new(&id, &program_file, &template.name);
    if let Some(path) = &args.json {
        batch.stage(path, |w| write_json(w, &report))?;
    }
    if let Some(path) = &args.report {
        let inputs = crate::html_report::Inputs {
            machine_file: (!without_template && args.template.exists())
                .then(|| args.template.display().to_string()),
        };
        let page = crate::html_report::identify_page(&report, &inputs)?;
        batch.stage(path, |w| w.write_all(page.as_bytes()))?;
    }
    batch.commit()?;
    print!("{}", summary_text(&id, &template));
    println!("machine written to {}", args.out.display());
    Ok(Outcome::Ok)
}
