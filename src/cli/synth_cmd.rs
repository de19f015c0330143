//! `contourcheck synth`: a synthetic measurement — the machine with one hidden effect runs a
//! program and is measured with noise on a clock of its own — to see what a cause looks
//! like, or to try `diagnose` on.

use std::path::PathBuf;

use clap::Args;

use super::Outcome;
use super::common::{CliError, MachineArgs, TraceArgs, load_program};
use crate::cli::output::{OutputBatch, outputs_apart};
use crate::diagnose::causes::CauseId;
use crate::diagnose::synth::{CommandStream, SynthSpec, synthesize, synthesize_recorded};
use crate::machine::{AxisName, MachineConfig};
use crate::numeric::units::{m_from_um, s_from_ms};
use crate::sim::MeasuredAt;
use crate::trace::format::ColumnMap;
use crate::trace::measured::MeasuredTrace;

/// Arguments of `synth`.
#[derive(Debug, Args)]
pub struct SynthArgs {
    /// The part program (not needed with --commands, whose stream runs instead of its plan).
    #[arg(required_unless_present = "commands")]
    pub program: Option<PathBuf>,
    /// Where to write the measurement (CSV: t_s, x_mm, y_mm[, x_cmd_mm, y_cmd_mm]).
    #[arg(long, short, value_name = "FILE")]
    pub out: PathBuf,
    #[command(flatten)]
    pub machine: MachineArgs,
    /// The hidden effect (default: none, the nominal machine); --values gives its
    /// parameters in the order `diagnose` reports them.
    #[arg(long, value_name = "CAUSE", requires = "values")]
    pub effect: Option<CauseId>,
    /// The axis it acts on.
    #[arg(long, default_value = "x", value_name = "AXIS")]
    pub axis: AxisName,
    /// Its parameter values in the machine file's units, comma-separated, in the order
    /// `diagnose` reports them (e.g. backlash: µm; stribeck: level N, velocity mm/min;
    /// cyclic_error: amplitude µm, phase °; resonance: Hz, damping ratio).
    #[arg(long, value_name = "V1,V2", value_delimiter = ',', requires = "effect")]
    pub values: Vec<f64>,
    /// Measurement noise, standard deviation (µm).
    #[arg(long, default_value_t = 0.3, value_name = "UM")]
    pub noise_um: f64,
    /// The measurement clock's reading when the program starts (s): the record begins at 0
    /// with the machine standing still until then (at most an hour).
    #[arg(long, default_value_t = 0.5, value_name = "S")]
    pub offset_s: f64,
    /// Sampling step (ms).
    #[arg(
        long,
        default_value_t = 2.0,
        value_name = "MS",
        conflicts_with = "rate_hz"
    )]
    pub sample_ms: f64,
    /// Sampling rate (Hz), instead of --sample-ms.
    #[arg(long, value_name = "HZ")]
    pub rate_hz: Option<f64>,
    /// Step of the measuring system's counts (µm), e.g. 0.1 for an encoder's 0.1 µm.
    #[arg(long, default_value_t = 0.0, value_name = "UM")]
    pub quantization_um: f64,
    /// Where the positions are read: table (linear scale), motor (encoder) or tool.
    #[arg(long, value_enum, default_value_t = MeasuredAt::Table)]
    pub measured_at: MeasuredAt,
    /// Run an external command stream instead of our plan of the program: a trace whose
    /// commanded columns (x_cmd, y_cmd — or x, y when it has no others) hold another
    /// interpolator's output. Read with --columns/--trace-profile like any trace.
    #[arg(long, value_name = "FILE")]
    pub commands: Option<PathBuf>,
    #[command(flatten)]
    pub trace: TraceArgs,
    /// Record the commanded positions too, as a CNC servo trace does.
    #[arg(long)]
    pub with_commands: bool,
    /// Write the record with these column names and units, as a control or lab system
    /// would: `t=Time[ms],x=X_ActPos[counts:0.1um],y=Y_ActPos[counts:0.1um],x_cmd=X_Traj,
    /// y_cmd=Y_Traj` (default: t_s, x_mm, y_mm, x_cmd_mm, y_cmd_mm).
    #[arg(long, value_name = "MAP")]
    pub out_columns: Option<String>,
    /// Seed of the noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

pub(crate) fn run(args: &SynthArgs) -> Result<Outcome, CliError> {
    let effect = hidden_effect(args)?;
    let sample_ms = checked_measurement(args)?;
    let inputs = [
        ("the program", args.program.as_deref()),
        ("--commands", args.commands.as_deref()),
        ("--machine", args.machine.machine.as_deref()),
        ("--trace-profile", args.trace.trace_profile.as_deref()),
    ];
    outputs_apart(&inputs, &[("--out", Some(args.out.as_path()))])?;
    let layout = args
        .out_columns
        .as_deref()
        .map(ColumnMap::parse)
        .transpose()
        .map_err(|e| CliError::Usage(format!("--out-columns: {e}")))?;
    let machine = args.machine.load_stable()?;
    let commands = match &args.commands {
        Some(path) => Some(command_stream(&args.trace.read(path)?)),
        None => None,
    };
    let spec = SynthSpec {
        effect,
        noise_m: m_from_um(args.noise_um),
        offset_s: args.offset_s,
        sample_s: s_from_ms(sample_ms),
        with_commands: args.with_commands || commands.is_some(),
        seed: args.seed,
        commands,
        quantization_m: m_from_um(args.quantization_um),
        measured_at: args.measured_at,
    };
    let synthetic = match (&spec.commands, &args.program) {
        (Some(stream), program) => {
            if let Some(program) = program {
                eprintln!(
                    "warning: {} is not run: the stream of --commands runs in its place",
                    program.display()
                );
            }
            synthesize_recorded(stream, &machine, &spec)?
        }
        (None, Some(program)) => synthesize(&load_program(program, &machine)?, &machine, &spec)?,
        (None, None) => {
            return Err(CliError::Usage(
                "give the PROGRAM to run, or --commands FILE".into(),
            ));
        }
    };
    let mut batch = OutputBatch::new();
    batch.stage(&args.out, |w| match &layout {
        Some(layout) => synthetic.write_csv_as(w, layout),
        None => synthetic.write_csv(w),
    })?;
    batch.commit()?;
    println!(
        "wrote {}: {} samples every {} ms, noise {} µm, clock offset {} s; {}",
        args.out.display(),
        synthetic.rows.len(),
        sample_ms,
        args.noise_um,
        args.offset_s,
        describe_hidden(&spec.effect, &synthetic.machine)
    );
    Ok(Outcome::Ok)
}

/// The effect to hide, its values checked against the cause's parameters.
fn hidden_effect(args: &SynthArgs) -> Result<Option<(CauseId, AxisName, Vec<f64>)>, CliError> {
    let Some(cause) = args.effect else {
        return Ok(None);
    };
    let wanted = cause.params().len();
    if args.values.len() != wanted {
        let keys: Vec<&str> = cause.params().iter().map(|p| p.key).collect();
        return Err(CliError::Usage(format!(
            "--values: {} takes {wanted} value(s): {}",
            cause.as_str(),
            keys.join(", ")
        )));
    }
    for (p, v) in cause.params().iter().zip(&args.values) {
        if !(v.is_finite() && (p.min..=p.max).contains(v)) {
            return Err(CliError::Usage(format!(
                "--values: {} = {v} lies outside {}..{}",
                p.key, p.min, p.max
            )));
        }
    }
    Ok(Some((cause, args.axis, args.values.clone())))
}

/// The longest standstill recorded before the program starts (s).
const MAX_OFFSET_S: f64 = 3600.0;

/// The measurement's settings checked; its sampling period (ms).
fn checked_measurement(args: &SynthArgs) -> Result<f64, CliError> {
    let usage = |text: String| Err(CliError::Usage(text));
    if !(args.noise_um.is_finite() && args.noise_um >= 0.0) {
        return usage(format!("--noise-um {}: must be ≥ 0", args.noise_um));
    }
    let sample_ms = match args.rate_hz {
        Some(hz) if hz.is_finite() && (10.0..=20_000.0).contains(&hz) => 1e3 / hz,
        Some(hz) => return usage(format!("--rate-hz {hz}: must lie between 10 and 20000")),
        None => args.sample_ms,
    };
    if !(sample_ms.is_finite() && (0.05..=100.0).contains(&sample_ms)) {
        return usage(format!(
            "--sample-ms {sample_ms}: must lie between 0.05 and 100"
        ));
    }
    if !(args.quantization_um.is_finite() && (0.0..=100.0).contains(&args.quantization_um)) {
        return usage(format!(
            "--quantization-um {}: must lie between 0 and 100",
            args.quantization_um
        ));
    }
    // The standstill before the program is recorded sample by sample: a day of it at 2 ms
    // is 43 million rows no one asked for.
    if !(args.offset_s.is_finite() && (0.0..=MAX_OFFSET_S).contains(&args.offset_s)) {
        return usage(format!(
            "--offset-s {}: must lie between 0 and {MAX_OFFSET_S} s (the record stands still \
             from 0 until the program starts)",
            args.offset_s
        ));
    }
    Ok(sample_ms)
}

/// What was hidden, in words.
fn describe_hidden(
    effect: &Option<(CauseId, AxisName, Vec<f64>)>,
    truth: &MachineConfig,
) -> String {
    match effect {
        None => "nothing hidden (the nominal machine)".to_string(),
        Some((cause, axis, values)) => {
            let params: Vec<String> = cause
                .params()
                .iter()
                .zip(values)
                .map(|(p, v)| format!("{} = {v} {}", p.key, p.unit).trim_end().to_string())
                .collect();
            let mut params = params;
            if *cause == CauseId::ForceRipple {
                let period_mm = truth.axis(*axis).errors.force_ripple_period_mm;
                params.push(format!("errors.force_ripple_period_mm = {period_mm} mm"));
            }
            format!("{} on {axis}: {}", cause.as_str(), params.join(", "))
        }
    }
}

/// The commanded positions of a trace (its measured ones when it recorded no others).
fn command_stream(trace: &MeasuredTrace) -> CommandStream {
    let [x, y] = trace
        .commands
        .clone()
        .unwrap_or_else(|| [trace.x_m.clone(), trace.y_m.clone()]);
    CommandStream {
        dt_s: trace.dt_s,
        x_m: x,
        y_m: y,
    }
}
