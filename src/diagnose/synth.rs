//! Synthetic measurements: a "true" machine — a nominal one plus one hidden effect from the
//! catalogue — runs a program, and its trace is written as a user's measurement would be:
//! sampled on the measurement's own clock (offset from the program's), with noise.
//!
//! The control's waits at exact stops are the planner's estimate, the timeline `diagnose`
//! compares on ([`crate::check::plan_commands`]), not the simulated in-position checks of
//! `check`.
//!
//! Users run it to see what each cause looks like; the tests use it to hide an effect and
//! ask `diagnose` to find it from what a user would have.

use std::io::Write;

use rand::SeedableRng;
use rand_distr::{Distribution, Normal};

use crate::check::{CheckSettings, plan_commands};
use crate::diagnose::causes::{self, CauseId};
use crate::gcode::Program;
use crate::machine::{AxisConfig, AxisName, MachineConfig};
use crate::plan::Commands;
use crate::sim::{AxisModel, MeasuredAt, SimError, simulate};
use crate::trace::format::{ColumnMap, Signal, Unit};
use crate::trace::recorded::commands_from_record;
use crate::trace::signal::sample;

/// What to hide and how to measure it.
#[derive(Debug, Clone, PartialEq)]
pub struct SynthSpec {
    /// The hidden effect: cause, axis and its parameter values (machine units); `None` for
    /// a control run of the nominal machine.
    pub effect: Option<(CauseId, AxisName, Vec<f64>)>,
    /// Standard deviation of the measurement noise (m).
    pub noise_m: f64,
    /// The measurement's clock reads this much when the program starts (s).
    pub offset_s: f64,
    /// Sampling step of the measurement (s).
    pub sample_s: f64,
    /// Record the commanded positions too (as a CNC servo trace does).
    pub with_commands: bool,
    /// Seed of the noise.
    pub seed: u64,
    /// An external command stream to run instead of our plan of the program (another
    /// interpolator's output: other timing, other profile); the program then only names
    /// the geometry.
    pub commands: Option<CommandStream>,
    /// Step of the measuring system's counts (m); 0 for none.
    pub quantization_m: f64,
    /// Where the measurement reads the positions.
    pub measured_at: MeasuredAt,
}

/// Commanded positions another interpolator produced, on its own uniform clock.
#[derive(Debug, Clone, PartialEq)]
pub struct CommandStream {
    /// Sampling step (s).
    pub dt_s: f64,
    /// Commanded X (m).
    pub x_m: Vec<f64>,
    /// Commanded Y (m).
    pub y_m: Vec<f64>,
}

impl Default for SynthSpec {
    fn default() -> Self {
        SynthSpec {
            effect: None,
            noise_m: 0.3e-6,
            offset_s: 0.0,
            sample_s: 0.002,
            with_commands: false,
            seed: 1,
            commands: None,
            quantization_m: 0.0,
            measured_at: MeasuredAt::Table,
        }
    }
}

/// A synthetic measurement.
#[derive(Debug, Clone)]
pub struct Synthetic {
    /// The true machine.
    pub machine: MachineConfig,
    /// Rows: measurement time (s), actual X and Y (m), commanded X and Y (m).
    pub rows: Vec<[f64; 5]>,
    /// Whether the commanded positions are part of the measurement.
    pub with_commands: bool,
}

/// `cause` with `values` hidden in `axis`. A ripple needs a period: where the machine file
/// names none, a motor turn's travel (the period diagnose looks at first), so the record
/// holds what was asked for.
fn hide(axis: &mut AxisConfig, cause: CauseId, values: &[f64]) {
    causes::apply(axis, cause, values);
    if cause == CauseId::ForceRipple && axis.errors.force_ripple_period_mm <= 0.0 {
        let turn_m = super::ripple::candidate_periods_m(axis).first().copied();
        axis.errors.force_ripple_period_mm = turn_m.unwrap_or(f64::NAN) * 1e3;
    }
}

/// Runs `program` on `nominal` with the hidden effect and measures it; where the spec holds
/// a recorded command stream (`spec.commands`), that runs instead, as
/// [`synthesize_recorded`] runs it, and the program plays no part.
pub fn synthesize(
    program: &Program,
    nominal: &MachineConfig,
    spec: &SynthSpec,
) -> Result<Synthetic, SimError> {
    if let Some(stream) = &spec.commands {
        return synthesize_recorded(stream, nominal, spec);
    }
    let machine = with_hidden_effect(nominal, spec);
    let settings = CheckSettings::for_machine(&machine);
    let (_, planned) = plan_commands(program, &machine, &settings)?;
    measure(machine, &settings, &planned, None, spec)
}

/// Runs another interpolator's command stream `stream` on `nominal` with the hidden effect
/// and measures it: no program is planned (the stream is taken to the machine's
/// interpolation cycle; `spec.commands` is not read).
pub fn synthesize_recorded(
    stream: &CommandStream,
    nominal: &MachineConfig,
    spec: &SynthSpec,
) -> Result<Synthetic, SimError> {
    let machine = with_hidden_effect(nominal, spec);
    let settings = CheckSettings::for_machine(&machine);
    let cycle_s = settings.plan.cycle_s;
    let commands = commands_from_record(&stream.x_m, &stream.y_m, stream.dt_s, cycle_s);
    measure(machine, &settings, &commands, Some(stream), spec)
}

/// `nominal` with the spec's hidden effect.
fn with_hidden_effect(nominal: &MachineConfig, spec: &SynthSpec) -> MachineConfig {
    let mut machine = nominal.clone();
    if let Some((cause, axis, values)) = &spec.effect {
        hide(machine.axis_mut(*axis), *cause, values);
    }
    machine
}

/// `commands` run on `machine` and measured as the spec says; the record's commands are
/// `recorded`'s own values where given, else `commands` sampled.
fn measure(
    machine: MachineConfig,
    settings: &CheckSettings,
    commands: &Commands,
    recorded: Option<&CommandStream>,
    spec: &SynthSpec,
) -> Result<Synthetic, SimError> {
    let traces = [AxisName::X, AxisName::Y].map(|a| {
        let c = if a == AxisName::X {
            &commands.x
        } else {
            &commands.y
        };
        simulate(
            &AxisModel::from_config(machine.axis(a)),
            c,
            commands.dt_s,
            &settings.sim,
        )
    });
    let [x, y] = traces;
    let (mut x, mut y) = (
        x?.into_read_at(spec.measured_at),
        y?.into_read_at(spec.measured_at),
    );
    // The axes' geometry lies beyond the scales: the tool and the table see it, a motor
    // encoder does not.
    if spec.measured_at != MeasuredAt::Motor {
        crate::sim::geometry::to_tool(&machine, &mut x, &mut y);
    }
    let read = |v: f64| {
        if spec.quantization_m > 0.0 {
            (v / spec.quantization_m).round() * spec.quantization_m
        } else {
            v
        }
    };
    let mut rng = rand::rngs::StdRng::seed_from_u64(spec.seed);
    let noise = Normal::new(0.0, spec.noise_m.max(0.0)).expect("a non-negative standard deviation");
    let duration = commands.duration_s() + spec.offset_s.max(0.0);
    let n = (duration / spec.sample_s).floor() as usize + 1;
    let rows = (0..n)
        .map(|k| {
            let t_meas = k as f64 * spec.sample_s;
            let t = t_meas - spec.offset_s;
            let (xc, yc) = match recorded {
                // Recorded commands are the control's own values, not a resampling of them.
                Some(s) => (sample(&s.x_m, s.dt_s, t), sample(&s.y_m, s.dt_s, t)),
                None => (
                    sample(&commands.x.pos_m, commands.dt_s, t),
                    sample(&commands.y.pos_m, commands.dt_s, t),
                ),
            };
            [
                t_meas,
                read(sample(&x, commands.dt_s, t) + noise.sample(&mut rng)),
                read(sample(&y, commands.dt_s, t) + noise.sample(&mut rng)),
                xc,
                yc,
            ]
        })
        .collect();
    Ok(Synthetic {
        machine,
        rows,
        with_commands: spec.with_commands,
    })
}

impl Synthetic {
    /// Writes the measurement as CSV (`t_s,x_mm,y_mm`, and `x_cmd_mm,y_cmd_mm` when the
    /// commands are recorded).
    pub fn write_csv(&self, w: &mut dyn Write) -> std::io::Result<()> {
        let ours = ColumnMap::parse(
            "t=t_s[s],x=x_mm[mm],y=y_mm[mm],x_cmd=x_cmd_mm[mm],y_cmd=y_cmd_mm[mm]",
        )
        .expect("the tool's own layout is a valid mapping");
        self.write_csv_as(w, &ours)
    }

    /// Writes the measurement as CSV with the columns of `layout` — header names and units
    /// as a control or lab system would write them (`t=Time[ms],x=X_ActPos[counts:0.1um]…`);
    /// signals the layout leaves out are not written, nor the commands when they are not
    /// recorded. Values carry 0.1 nm (positions) and 1 µs (time) in any unit; counts are
    /// whole numbers.
    pub fn write_csv_as(&self, w: &mut dyn Write, layout: &ColumnMap) -> std::io::Result<()> {
        let columns: Vec<(usize, &str, Unit)> = Signal::ALL
            .into_iter()
            .enumerate()
            .filter(|(k, _)| self.with_commands || *k < 3)
            // A synthetic record holds X and Y (rows of time, X, Y and their commands).
            .filter(|(_, signal)| !signal.is_z())
            .filter_map(|(k, signal)| {
                let spec = layout.get(signal)?;
                let unit = spec.unit.unwrap_or(Unit {
                    to_si: if signal.is_time() { 1.0 } else { 1e-3 },
                    label: "",
                });
                Some((k, spec.name.as_str(), unit))
            })
            .collect();
        let mut out = csv::Writer::from_writer(w);
        out.write_record(columns.iter().map(|c| c.1))?;
        for r in &self.rows {
            out.write_record(columns.iter().map(|&(k, _, unit)| {
                let resolution_si = if k == 0 { 1e-6 } else { 1e-10 };
                in_unit(r[k], unit, resolution_si)
            }))?;
        }
        out.flush()
    }
}

/// `value_si` in `unit` to `resolution_si` (whole counts for a count unit).
fn in_unit(value_si: f64, unit: Unit, resolution_si: f64) -> String {
    let v = value_si / unit.to_si;
    if unit.is_count() {
        // Adding zero turns a rounded -0 into 0, as a counter would show it.
        return format!("{}", v.round() + 0.0);
    }
    // The margin keeps an exact power of ten (1 s / 1 µs) from rounding up a place.
    let decimals = ((unit.to_si / resolution_si).log10() - 1e-9)
        .ceil()
        .max(0.0) as usize;
    format!("{v:.decimals$}")
}
