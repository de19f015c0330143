//! The figures of a check and of a diagnosis, built from their results for `plot` to draw:
//! as PNG and SVG files by the command line's `--plot`, inline in the HTML reports.

mod check;
mod diagnose;

pub use check::CheckFigures;
pub use diagnose::DiagnoseFigures;
