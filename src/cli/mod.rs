//! Command-line interface: raw flags (clap) are turned into validated settings, the library
//! does the work, and results are printed. Exit status: 0 ok, 1 prediction over tolerance,
//! 2 error.

mod bode_cmd;
mod check_cmd;
mod check_text;
mod common;
mod diagnose_cmd;
mod identify_cmd;
mod inspect_cmd;
pub(crate) mod output;
mod plan_cmd;
mod stickslip_cmd;
mod sweep_cmd;
mod synth_cmd;
mod validate_cmd;

use std::process::ExitCode;

use clap::{ArgMatches, CommandFactory, FromArgMatches, Parser, Subcommand};

pub use common::CliError;

/// contourcheck: predicts a CNC machine's contour error from a part program.
#[derive(Debug, Parser)]
#[command(name = "contourcheck", version, about, long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
    /// The part program's dialect; by default told from the file (`.mpf`/`.spf`, a
    /// `%_N_…_MPF` header or SINUMERIK codes: sinumerik; else rs274).
    #[arg(long, global = true, value_enum)]
    dialect: Option<crate::gcode::Dialect>,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Predict a program's contour error: where, how much and why.
    Check(check_cmd::CheckArgs),
    /// Parse and plan a program: blocks, path length, cycle time, peak axis dynamics.
    Plan(plan_cmd::PlanArgs),
    /// Frequency responses of the current, velocity and position loops.
    Bode(bode_cmd::BodeArgs),
    /// Stick-slip at low feeds (the paper's criterion) and the critical velocity.
    Stickslip(stickslip_cmd::StickSlipArgs),
    /// Compare gain (or any numeric machine) settings on a program: ranked, plotted.
    Sweep(sweep_cmd::SweepArgs),
    /// Every comparison with the paper, side by side.
    Validate(validate_cmd::ValidateArgs),
    /// Learn from a measurement: where the model is wrong, the cause, the fitted extension.
    Diagnose(diagnose_cmd::DiagnoseArgs),
    /// Fit a machine file to a record with its commands, from a template.
    Identify(identify_cmd::IdentifyArgs),
    /// A synthetic measurement of a machine with one hidden effect.
    Synth(synth_cmd::SynthArgs),
    /// What a measured trace holds: columns found, sampling, motion, quantisation, lag.
    Inspect(inspect_cmd::InspectArgs),
}

/// What a run ended with.
pub enum Outcome {
    /// Success.
    Ok,
    /// The prediction exceeded the tolerance the user set.
    OverTolerance,
}

/// Parses the process arguments, runs the command and returns the exit status.
pub fn main() -> ExitCode {
    crate::cli::output::remove_staged_on_interrupt();
    let matches = Cli::command().get_matches();
    let cli = Cli::from_arg_matches(&matches).unwrap_or_else(|e| e.exit());
    match run(cli, &matches) {
        Ok(Outcome::Ok) => ExitCode::SUCCESS,
        Ok(Outcome::OverTolerance) => ExitCode::from(1),
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(2)
        }
    }
}

fn run(cli: Cli, matches: &ArgMatches) -> Result<Outcome, CliError> {
    if let Some(dialect) = cli.dialect {
        common::set_dialect(dialect);
    }
    match cli.command {
        Command::Sweep(args) => {
            let sub = matches
                .subcommand_matches("sweep")
                .expect("the sweep subcommand's matches");
            sweep_cmd::run(&args, sub)
        }
        Command::Check(args) => check_cmd::run(&args),
        Command::Plan(args) => plan_cmd::run(&args),
        Command::Bode(args) => bode_cmd::run(&args),
        Command::Stickslip(args) => stickslip_cmd::run(&args),
        Command::Validate(args) => validate_cmd::run(&args),
        Command::Diagnose(args) => diagnose_cmd::run(&args),
        Command::Identify(args) => identify_cmd::run(&args),
        Command::Synth(args) => synth_cmd::run(&args),
        Command::Inspect(args) => inspect_cmd::run(&args),
    }
}
