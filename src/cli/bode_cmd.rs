//! `contourcheck bode`: the three closed loops' frequency responses.

use std::path::PathBuf;

use clap::Args;

use super::Outcome;
use super::common::{AxisArg, CliError, MachineArgs, write_plot};
use crate::plot::bode::{BodeCurve, BodePlot};
use crate::sim::AxisModel;
use crate::sim::linear::{self, Loop};

/// Arguments of `bode`.
#[derive(Debug, Args)]
pub struct BodeArgs {
    #[command(flatten)]
    pub machine: MachineArgs,
    #[command(flatten)]
    pub axis: AxisArg,
    /// Write magnitude and phase of the closed loops to this PNG or SVG.
    #[arg(long, value_name = "FILE")]
    pub plot: Option<PathBuf>,
}

pub fn run(args: &BodeArgs) -> Result<Outcome, CliError> {
    let machine = args.machine.load()?;
    let model = AxisModel::from_config(machine.axis(args.axis.axis));
    println!(
        "{} axis of {} — linearised (friction as viscous only, nut in contact)",
        args.axis.axis, machine.name
    );
    println!(
        "loop       crossover  phase margin  closed −3 dB  closed −10°  gain at crossover/100"
    );
    for l in Loop::ALL {
        let f = linear::loop_figures(&model, l);
        let low = linear::closed_loop(&model, l, f.crossover_hz / 100.0);
        println!(
            "{:<9} {:>8.2} Hz {:>11.1}° {:>10.2} Hz {:>9.2} Hz {:>10.2} dB",
            l.name(),
            f.crossover_hz,
            f.phase_margin_deg,
            f.bandwidth_3db_hz,
            f.phase_10deg_hz,
            20.0 * low.norm().log10()
        );
    }
    if let Some(m) = linear::least_damped(&model) {
        println!(
            "least damped closed-loop mode: {:.1} Hz, damping ratio {:.3}",
            m.frequency_hz, m.damping
        );
    }
    if let Some(path) = &args.plot {
        let freqs = linear::log_space(0.1, 10_000.0, 60);
        let curves = Loop::ALL
            .iter()
            .map(|&l| BodeCurve {
                label: format!("{} loop", l.name()),
                points: linear::bode(&model, l, &freqs, false),
            })
            .collect();
        let title = format!("Closed loops, {} axis of {}", args.axis.axis, machine.name);
        write_plot(path, &BodePlot { title, curves })?;
        println!("plot: {}", path.display());
    }
    Ok(Outcome::Ok)
}
