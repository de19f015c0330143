//! contourcheck predicts how far a heavy CNC machining centre will stray from the programmed
//! contour, from the part program and a model of the machine's servo-feed axes; and, given a
//! measurement of the machine, finds what the prediction gets wrong and fits the model.
//!
//! The pipeline, one module per stage: [`gcode`] (parse and interpret) → [`path`] (exact
//! geometry) → [`plan`] (feed planning and interpolation) → [`sim`] (each axis's servo and
//! mechanics) → [`analysis`] (contour error, hotspots, circular tests) → [`check`]; measured
//! records come in through [`trace`] and are explained by [`diagnose`] and [`identify`].
//! `ARCHITECTURE.md` gives the layers and the invariants.
//!
//! The entry points are re-exported here, with their settings, results and errors: they are
//! the library's public interface (the Python package `python/` uses them alone), where the
//! modules' own items may change with the code. Check a program on the embedded machine, then hide
//! a cause in a synthetic record of it and let the diagnosis find it:
//!
//! ```
//! use contourcheck::{
//!     CheckSettings, DiagnoseSettings, InterpretOptions, MachineConfig, check, diagnose,
//!     parse_program, parse_trace,
//! };
//! use contourcheck::diagnose::causes::CauseId;
//! use contourcheck::machine::AxisName;
//! use contourcheck::diagnose::synth::{SynthSpec, synthesize};
//!
//! let text = "G21 G90 G17 G94\nG0 X0 Y0\nG1 X40 F1000\nY40\nX0\nY0\nM2\n";
//! let program = parse_program(text, "square.nc", &InterpretOptions::default())?;
//! let machine = MachineConfig::default_preset();
//!
//! // The prediction: at 1000 mm/min and Kv = 1 m/min/mm the axes lag by F/Kv = 1 mm, and the
//! // path stays within micrometres of the square.
//! let run = check(&program, &machine, &CheckSettings::for_machine(&machine))?;
//! let lag_mm = run.result.summary.max_following_error_cutting_m[0] * 1e3;
//! assert!((lag_mm - 1.0).abs() < 0.01, "{lag_mm}");
//!
//! // A record of the machine with 10 µm of backlash on Y, read as a user's CSV would be.
//! let spec = SynthSpec {
//!     effect: Some((CauseId::Backlash, AxisName::Y, vec![10.0])),
//!     with_commands: true,
//!     ..SynthSpec::default()
//! };
//! let mut csv = Vec::new();
//! synthesize(&program, &machine, &spec)?.write_csv(&mut csv)?;
//! let record = parse_trace(std::str::from_utf8(&csv)?, "record.csv")?;
//! let found = diagnose(&program, &machine, &record, &DiagnoseSettings::for_machine(&machine))?;
//! assert_eq!(found.causes[0].id, CauseId::Backlash);
//! assert!((found.causes[0].params[0].value - 10.0).abs() < 1.0);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

#![deny(missing_docs)]

pub mod analysis;
pub mod check;
#[cfg(feature = "cli")]
pub mod cli;
pub mod compare;
pub mod diagnose;
#[cfg(feature = "html-report")]
pub mod figures;
pub mod gcode;
#[cfg(feature = "html-report")]
pub mod html_report;
pub mod identify;
pub mod machine;
pub mod numeric;
pub mod path;
pub mod plan;
#[cfg(feature = "html-report")]
pub mod plot;
pub mod sim;
pub mod sweep;
pub mod trace;
#[cfg(feature = "cli")]
pub mod validate;

pub use check::envelope::{EnvelopeError, check_fits};
pub use check::report::CheckReport;
pub use check::{CheckRun, CheckSettings, check};
pub use compare::{CompareError, CompareSettings};
pub use diagnose::causes::{CauseId, CauseSet};
pub use diagnose::report::DiagnoseReport;
pub use diagnose::{DiagnoseError, DiagnoseSettings, Diagnosis, diagnose, diagnose_validated};
pub use gcode::{Dialect, GcodeErrors, InterpretOptions, Program, parse_program};
#[cfg(feature = "html-report")]
pub use html_report::{
    HtmlError, Inputs as ReportInputs, check_page, diagnose_page, identify_page,
};
pub use identify::report::IdentifyReport;
pub use identify::{Identification, IdentifyError, identify, identify_loop, loop_template};
pub use machine::{AxisName, ConfigError, MachineConfig, PRESETS};
pub use plan::ProfileKind;
pub use sim::{AxisModel, MeasuredAt, SimConfig, SimError, simulate};
pub use sweep::{
    Dimension, PointResult, SweepInputError, SweepPoint, Thresholds as SweepThresholds,
    rank as rank_sweep,
};
pub use sweep::{resolve_key, run as run_sweep};
pub use trace::format::ColumnMap;
pub use trace::measured::{
    MeasuredError, MeasuredTrace, parse_trace, parse_trace_with, read_trace, read_trace_with,
};
pub use trace::recorded::program_from_commands;
