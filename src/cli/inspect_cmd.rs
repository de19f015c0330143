//! `contourcheck inspect`: what a measured trace holds and how it was read.

use std::path::PathBuf;

use clap::Args;

use super::Outcome;
use super::common::{CliError, TraceArgs, write_plots_into};
use crate::numeric::units::{mm_from_m, um_from_m};
use crate::plot::panels::{Curve, Panel, PanelsPlot};
use crate::plot::xy::{Beside, XyPlot};
use crate::trace::inspect::summarise;
use crate::trace::measured::MeasuredTrace;

/// Arguments of `inspect`.
#[derive(Debug, Args)]
pub struct InspectArgs {
    /// The measured trace.
    pub trace: PathBuf,
    #[command(flatten)]
    pub columns: TraceArgs,
    /// Write a one-page plot into this directory, as inspect.png and .svg: positions over
    /// time, following errors when the commands were recorded, and the path in XY.
    #[arg(long, value_name = "DIR")]
    pub plot: Option<PathBuf>,
}

pub(crate) fn run(args: &InspectArgs) -> Result<Outcome, CliError> {
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
    if let Some(held) = trace.held {
        println!(
            "  the logger repeats each reading for {} rows: read at its own step of {:.4} ms",
            held.period,
            trace.dt_s * 1e3
        );
    }
    print!("{}", summarise(&trace).text());
    if let Some(path) = &args.plot {
        let record = std::path::Path::new(&trace.file)
            .file_name()
            .map_or_else(|| trace.file.clone(), |n| n.to_string_lossy().into_owned());
        let footer = crate::plot::Footer::new("").sampling(format!(
            "record {record} sampled at {} Hz",
            (10.0 / trace.dt_s).round() / 10.0
        ));
        write_plots_into(path, "inspect", &overview(&trace), &footer)?;
    }
    Ok(Outcome::Ok)
}

/// Samples drawn per curve: enough for a page, however long the record.
const POINTS: usize = 4000;

/// Positions (measured, and commanded where recorded) and following errors over time,
/// beside the path in XY.
fn overview(trace: &MeasuredTrace) -> Beside<PanelsPlot, XyPlot> {
    let every = trace.len().div_ceil(POINTS).max(1);
    let curve = |name: &str, color: Option<usize>, value: &dyn Fn(usize) -> f64| Curve {
        name: name.into(),
        points: (0..trace.len())
            .step_by(every)
            .map(|k| (trace.time_s(k), value(k)))
            .collect(),
        color,
        width: if color.is_some() { 1 } else { 3 },
    };
    // The commands as wide grey references under the measured positions.
    let mut positions = Vec::new();
    let mut panels = Vec::new();
    if let Some([xc, yc]) = &trace.commands {
        positions.push(curve("commanded", None, &|k| mm_from_m(xc[k])));
        positions.push(curve("", None, &|k| mm_from_m(yc[k])));
        panels.push(Panel {
            caption: "following error (command − measured)".into(),
            y_label: "error (µm)".into(),
            curves: vec![
                curve("X", Some(0), &|k| um_from_m(xc[k] - trace.x_m[k])),
                curve("Y", Some(1), &|k| um_from_m(yc[k] - trace.y_m[k])),
            ],
        });
    }
    positions.push(curve("X measured", Some(0), &|k| mm_from_m(trace.x_m[k])));
    positions.push(curve("Y measured", Some(1), &|k| mm_from_m(trace.y_m[k])));
    panels.insert(
        0,
        Panel {
            caption: "positions".into(),
            y_label: "position (mm)".into(),
            curves: positions,
        },
    );
    Beside {
        left: PanelsPlot {
            title: format!("{}: what the trace holds", trace.file),
            x_label: "trace time (s)".into(),
            panels,
        },
        right: xy_path(trace, every),
        left_share: 0.62,
    }
}

/// The measured path in XY over the commanded one where recorded.
fn xy_path(trace: &MeasuredTrace, every: usize) -> XyPlot {
    let path = |name: &str, color: Option<usize>, x: &[f64], y: &[f64]| Curve {
        name: name.into(),
        points: (0..trace.len())
            .step_by(every)
            .map(|k| (mm_from_m(x[k]), mm_from_m(y[k])))
            .collect(),
        color,
        width: if color.is_some() { 1 } else { 3 },
    };
    let mut curves = Vec::new();
    if let Some([xc, yc]) = &trace.commands {
        curves.push(path("commanded", None, xc, yc));
    }
    curves.push(path("measured", Some(0), &trace.x_m, &trace.y_m));
    XyPlot {
        caption: "path".into(),
        curves,
    }
}
