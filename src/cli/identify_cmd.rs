//! `contourcheck identify`: a machine file fitted to a record with its commands, starting
//! from a template (a preset or a file).

use std::fmt::Write as _;
use std::path::PathBuf;

use clap::Args;

use super::Outcome;
use super::common::{CliError, PlanningArgs, TraceArgs, spinner};
use super::common::{program_or_commands_path, warn_beyond_machine};
use crate::cli::output::OutputBatch;
use crate::compare::CompareSettings;
use crate::identify::{Identification, IdentifiedValue, identify};
use crate::machine::MachineConfig;
use crate::units::m_from_um;

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
    /// of each axis's loop from command to position, of the order the record's held-out
    /// halves choose, whose values describe the loop rather than the machine's parts.
    #[arg(long, value_name = "FILE|PRESET", default_value = "hvmc")]
    pub template: PathBuf,
    /// Write the identified machine here (a machine file `check` and `diagnose` take).
    #[arg(long, short, value_name = "FILE")]
    pub out: PathBuf,
    /// Write the identification as JSON.
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    #[command(flatten)]
    pub planning: PlanningArgs,
    /// How far recorded commands may lie from the programmed geometry (µm).
    #[arg(long, default_value_t = 25.0, value_name = "UM")]
    pub command_tolerance_um: f64,
}

pub fn run(args: &IdentifyArgs) -> Result<Outcome, CliError> {
    // `none`: no template — a model of each loop, started from the record itself.
    let without_template = args.template.as_os_str() == "none";
    let measured = args.trace.read(&args.measured)?;
    let template = if without_template {
        crate::identify::loop_template(&measured)
    } else {
        super::common::MachineArgs {
            machine: Some(args.template.clone()),
        }
        .load()?
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
    if let Some(path) = &args.json {
        let report = Report {
            schema: "contourcheck.identify/1",
            program: &program_file,
            template: &template.name,
            identification: &id,
        };
        batch.stage(path, |w| {
            serde_json::to_writer_pretty(&mut *w, &report).map_err(std::io::Error::other)?;
            w.write_all(b"\n")
        })?;
    }
    batch.commit()?;
    print!("{}", summary(&id, &template));
    println!("machine written to {}", args.out.display());
    Ok(Outcome::Ok)
}

/// The JSON report (docs/report-schema.md).
#[derive(serde::Serialize)]
struct Report<'a> {
    schema: &'static str,
    program: &'a str,
    template: &'a str,
    #[serde(flatten)]
    identification: &'a Identification,
}

/// A value for the table: fitted with its uncertainty (said so where that is not a
/// measurement), or the template's.
fn shown(v: &IdentifiedValue) -> String {
    match (v.determined, v.measured) {
        (true, true) => format!("{} ± {}", sig(v.value), sig(v.uncertainty)),
        (true, false) => format!(
            "{} ± {} (a model's value, not a measurement)",
            sig(v.value),
            sig(v.uncertainty)
        ),
        (false, _) => format!("{} (not determined: the template's)", sig(v.value)),
    }
}

/// Four significant digits.
fn sig(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let digits = (3 - v.abs().log10().floor() as i32).clamp(0, 9) as usize;
    format!("{v:.digits$}")
}

/// The identification as the terminal shows it.
pub fn summary(id: &Identification, template: &MachineConfig) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "identified from {} (template {}; record noise {:.3} µm)",
        id.file, template.name, id.noise_um
    );
    for line in id.coverage.describe() {
        let _ = writeln!(s, "{line}");
    }
    for a in &id.axes {
        let _ = writeln!(
            s,
            "\n{} axis: residual {:.3} → {:.3} µm RMS{} (following error {:.1} µm); held out \
             {:.3} → {:.3} µm",
            a.axis,
            a.rms_template_um,
            a.rms_identified_um,
            if a.moving_only {
                ", compared while moving: the axis hunts at standstill"
            } else {
                ""
            },
            a.following_error_rms_um,
            a.held_out_template_um,
            a.held_out_identified_um
        );
        if !a.reached {
            let _ = writeln!(
                s,
                "  NOT IDENTIFIED: the best fit stays at {:.3} µm against the record's noise of \
                 {:.3} µm — the template's controller or settings are not this machine's (or it \
                 has effects `diagnose` looks for); the template's values are kept",
                a.rms_identified_um, id.noise_um
            );
        }
        if a.template_holds {
            let _ = writeln!(
                s,
                "  the template explains the record to its noise, and values fitted to it \
                 predict its held-out halves worse than the template does: the template's \
                 values stay"
            );
        }
        if a.values.iter().all(|v| !v.determined) {
            let _ = writeln!(
                s,
                "  the record determines none of {}'s values: what it compares (above) does not \
                 move them beyond their uncertainty; the template's are written",
                a.axis
            );
        }
        let _ = writeln!(s, "  {:<38} {:>14}  identified", "key", "template");
        for v in &a.values {
            let _ = writeln!(
                s,
                "  {:<38} {:>14}  {} {}",
                v.key,
                sig(v.template),
                shown(v),
                v.unit
            );
        }
        if let Some(r) = &a.gain_per_inertia {
            let _ = writeln!(
                s,
                "  {} per inertia: {} ± {} per kg, of {:.1} kg at the table (rotor, screw and \
                 table) — what the record determines where the gain and the mass trade",
                r.gain,
                sig(r.value),
                sig(r.uncertainty),
                r.inertia_kg
            );
        }
        if a.kept.starts_with("no template") {
            let _ = writeln!(s, "  {}", a.kept);
        } else {
            let _ = writeln!(s, "  kept from the template: {}", a.kept);
        }
    }
    let i = &id.interpolator;
    let limit = |value: f64, unit: &str, held: bool| {
        if held {
            format!("{value:.3} {unit} (held: written as the limit)")
        } else {
            format!("{value:.3} {unit} (not held: the template's limit stays)")
        }
    };
    let _ = writeln!(
        s,
        "\ninterpolator: path speed up to {:.0} mm/min",
        i.path_speed_mm_per_min
    );
    for (k, axis) in ["X", "Y"].iter().enumerate() {
        let _ = writeln!(
            s,
            "  {axis}: up to {:.0} mm/min, acceleration {}, jerk {}",
            i.velocity_mm_per_min[k],
            limit(i.accel_m_per_s2[k], "m/s²", i.accel_limited[k]),
            limit(i.jerk_m_per_s3[k], "m/s³", i.jerk_limited[k]),
        );
    }
    s
}

/// The identified machine as a machine file, its values and their uncertainties in the
/// header.
fn machine_file(id: &Identification, template: &MachineConfig, program_file: &str) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# {} identified from {program_file} against {}.",
        template.name, id.file
    );
    for a in &id.axes {
        for v in &a.values {
            let _ = writeln!(s, "#   {}.{} = {} {}", a.axis, v.key, shown(v), v.unit);
        }
        if let Some(r) = &a.gain_per_inertia {
            let _ = writeln!(
                s,
                "#   {}.{} per inertia = {} ± {} per kg (of {:.1} kg)",
                a.axis,
                r.gain,
                sig(r.value),
                sig(r.uncertainty),
                r.inertia_kg
            );
        }
    }
    let _ = writeln!(s, "base = \"none\"\n");
    s.push_str(&id.machine.to_toml());
    s
}
