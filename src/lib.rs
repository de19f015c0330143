//! contourcheck predicts how far a heavy CNC machining centre will stray from the programmed
//! contour, from the part program and a model of the machine's servo-feed axes.
//!
//! The pipeline, one module per stage: [`gcode`] (parse and interpret) → [`path`] (exact
//! geometry) → [`plan`] (feed planning and interpolation) → … See `ARCHITECTURE.md`.

#![deny(missing_docs)]

pub mod analysis;
pub mod causes;
pub mod check;
pub mod circular;
pub mod cli;
pub mod compensation;
pub mod contour;
pub mod diagnose;
pub mod envelope;
pub mod execute;
pub mod gcode;
pub mod geometry;
pub mod hotspot;
pub mod identify;
pub mod inspect;
pub mod lookup;
pub mod machine;
pub mod mat5;
pub mod measured;
pub mod output;
pub mod path;
pub mod plan;
pub mod plot;
pub mod recorded;
pub mod report;
pub mod signal;
pub mod sim;
pub mod sweep;
pub mod synth;
pub mod thinning;
pub mod trace_format;
pub mod trace_halscope;
pub mod trace_mat;
pub mod units;
pub mod validate;
