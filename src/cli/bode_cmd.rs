//! `contourcheck bode`: the three closed loops' frequency responses.

use std::path::PathBuf;

use clap::Args;

use super::Outcome;
use super::common::{AxisArg, CliError, MachineArgs, write_plots_into};
use crate::machine::{AxisConfig, AxisName};
use crate::plot::bode::{BodeCurve, BodePlot};
use crate::sim::AxisModel;
use crate::sim::linear;

/// Arguments of `bode`.
#[derive(Debug, Args)]
pub struct BodeArgs {
    #[command(flatten)]
    pub machine: MachineArgs,
    #[command(flatten)]
    pub axis: AxisArg,
    /// Write magnitude and phase of the closed loops into this directory, as
    /// bode-<axis>.png and .svg.
    #[arg(long, value_name = "DIR")]
    pub plot: Option<PathBuf>,
}

pub fn run(args: &BodeArgs) -> Result<Outcome, CliError> {
    let machine = args.machine.load()?;
    let config = machine.axis(args.axis.axis);
    let model = AxisModel::from_config(config);
    println!(
        "{} axis of {} — linearised (friction as viscous only, nut in contact)",
        args.axis.axis, machine.name
    );
    println!(
        "loop       crossover  phase margin  closed −3 dB  closed −10°  gain at crossover/100"
    );
    print_loop_table(&model);
    print_least_damped(&model, config, args.axis.axis);
    // The figures of an unstable loop are shown (they tell where it went wrong), but the
    // setting is an error.
    linear::check_stable(&model).map_err(|e| e.on_axis(args.axis.axis.letter(), None))?;
    if let Some(path) = &args.plot {
        let freqs = linear::log_space(0.1, 10_000.0, 60);
        let curves = linear::loops(&model)
            .into_iter()
            .map(|l| BodeCurve {
                label: format!("{} loop", l.name()),
                points: linear::bode(&model, l, &freqs, false),
            })
            .collect();
        let title = format!("Closed loops, {} axis of {}", args.axis.axis, machine.name);
        let stem = format!("bode-{}", args.axis.axis.as_str());
        write_plots_into(path, &stem, &BodePlot { title, curves })?;
    }
    Ok(Outcome::Ok)
}

/// Each loop's crossover, phase margin, closed-loop bandwidths and low-frequency gain.
fn print_loop_table(model: &AxisModel) {
    let mut missing = false;
    for l in linear::loops(model) {
        let f = linear::loop_figures(model, l);
        let low = linear::closed_loop(model, l, f.crossover_hz / 100.0);
        let mut cell = |v: f64, width: usize, decimals: usize, unit: &str| {
            if v.is_finite() {
                // Slow loops (a tiny Kv) keep their significant digits.
                let slow = unit == " Hz" && v.abs() < 0.1 && v != 0.0;
                let decimals = if slow { 5 } else { decimals };
                format!("{v:>width$.decimals$}{unit}")
            } else {
                missing = true;
                format!("{:>w$}", "—", w = width + unit.chars().count())
            }
        };
        println!(
            "{:<9} {} {} {} {} {}",
            l.name(),
            cell(f.crossover_hz, 8, 2, " Hz"),
            cell(f.phase_margin_deg, 11, 1, "°"),
            cell(f.bandwidth_3db_hz, 10, 2, " Hz"),
            cell(f.phase_10deg_hz, 9, 2, " Hz"),
            cell(20.0 * low.norm().log10(), 10, 2, " dB"),
        );
    }
    if missing {
        println!("— : the loop does not reach that point between 0.1 mHz and 100 kHz");
    }
}

/// The least damped closed-loop mode and, where it grows, why the margins miss it and the
/// gain that would be stable.
fn print_least_damped(model: &AxisModel, config: &AxisConfig, axis: AxisName) {
    if let Some(m) = linear::least_damped(model) {
        println!(
            "least damped closed-loop mode: {:.1} Hz, damping ratio {:.3}",
            m.frequency_hz, m.damping
        );
        if m.damping < 0.0 {
            // The margins are read where each loop's gain first crosses 0 dB; a mode far
            // above that crossing grows unseen by them — say so beside them.
            println!(
                "  UNSTABLE: this mode grows. The phase margins above are read at each loop's \
                 crossover; a mode at {:.1} Hz lies beyond them (the closed loops' magnitude peaks \
                 there).",
                m.frequency_hz
            );
            if let Some(kv_max) = linear::largest_stable_kv(config) {
                println!(
                    "  With the other settings held, {}.position_loop.kv_m_per_min_per_mm (here \
                     {}) is stable below {kv_max:.3} m/min/mm.",
                    axis.as_str(),
                    config.position_loop.kv_m_per_min_per_mm
                );
            }
        }
    }
}
