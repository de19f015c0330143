//! The figures of a check and of a diagnosis, built from their results for `plot` to draw:
//! as PNG and SVG files by the command line's `--plot`, inline in the HTML reports.

mod check;
mod diagnose;

pub use check::CheckFigures;
pub use diagnose::DiagnoseFigures;

/// A circle's polar plot and the name of the file `--plot` draws it to (no extension).
pub struct CirclePlot {
    /// The source line of the (first) circle drawn.
    pub line: u32,
    /// The file's name: unique among a run's plots.
    pub file: String,
    /// The plot.
    pub plot: crate::plot::polar::PolarPlot,
}

/// A circle without a polar plot: its source line and why — said alike by the HTML page
/// and by `--plot`.
pub struct NotDrawn {
    /// The circle's source line.
    pub line: u32,
    /// Why it has no plot.
    pub why: String,
}

impl std::fmt::Display for NotDrawn {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "line {}: {}", self.line, self.why)
    }
}
