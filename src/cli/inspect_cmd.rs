//! `contourcheck inspect`: what a measured trace holds and how it was read.

use std::path::PathBuf;

use clap::Args;

use super::Outcome;
use super::common::{CliError, TraceArgs};
use crate::inspect::summarise;

/// Arguments of `inspect`.
#[derive(Debug, Args)]
pub struct InspectArgs {
    /// The measured trace.
    pub trace: PathBuf,
    #[command(flatten)]
    pub columns: TraceArgs,
}

pub fn run(args: &InspectArgs) -> Result<Outcome, CliError> {
    let trace = args.columns.read(&args.trace)?;
    println!("trace     {}", trace.file);
    for line in trace.layout.describe() {
        println!("  {line}");
    }
    if trace.resampled {
        println!(
            "  irregular steps ({:.4}–{:.4} ms) resampled to the median {:.4} ms",
            trace.steps.min_s * 1e3,
            trace.steps.max_s * 1e3,
            trace.steps.median_s * 1e3
        );
    }
    print!("{}", summarise(&trace).text());
    Ok(Outcome::Ok)
}
