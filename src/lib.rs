//! contourcheck predicts how far a heavy CNC machining centre will stray from the programmed
//! contour, from the part program and a model of the machine's servo-feed axes.
//!
//! The pipeline, one module per stage: [`gcode`] (parse and interpret) → [`path`] (exact
//! geometry) → [`plan`] (feed planning and interpolation) → … See `ARCHITECTURE.md`.

#![deny(missing_docs)]

pub mod analysis;
pub mod causes;
pub mod check;
#[cfg(feature = "cli")]
pub mod cli;
pub mod compensation;
pub mod diagnose;
pub mod envelope;
pub mod execute;
pub mod gcode;
pub mod geometry;
pub mod identify;
pub mod lookup;
pub mod machine;
pub mod path;
pub mod plan;
#[cfg(feature = "cli")]
pub mod plot;
pub mod report;
pub mod sim;
pub mod sweep;
pub mod synth;
pub mod trace;
pub mod units;
pub mod validate;
