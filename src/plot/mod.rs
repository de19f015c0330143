//! Plots with plotters: PNG or SVG by the file's extension, axes labelled with units, text
//! in an embedded font (DejaVu Sans) so that nothing depends on the system's fonts.

pub mod along_path;
pub mod bode;
pub mod footer;
pub mod labels;
pub mod legend;
pub mod panels;
pub mod polar;
pub mod stickslip;
pub mod sweep;
pub mod toolpath;
pub mod xy;

#[cfg(feature = "cli")]
use std::path::Path;
use std::sync::Once;

use plotters::coord::Shift;
use plotters::prelude::*;

pub use footer::Footer;

/// Pixel size of every plot.
pub const SIZE: (u32, u32) = (1200, 800);

/// Font family name used throughout.
pub const FONT: &str = "sans-serif";

static FONT_ONCE: Once = Once::new();

/// Makes the embedded font available to the bitmap backend (once per process).
pub(crate) fn register_font() {
    FONT_ONCE.call_once(|| {
        // The embedded font is a valid TTF; failure would only mean text is not drawn.
        let _ = plotters::style::register_font(FONT, FontStyle::Normal, dejavu::sans::regular());
        let _ = plotters::style::register_font(FONT, FontStyle::Bold, dejavu::sans::bold());
    });
}

/// A plotting failure.
pub type PlotResult = Result<(), String>;

/// Something that can be drawn on any plotters backend.
pub trait Figure {
    /// Draws the figure on `root`.
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> PlotResult;
}

#[cfg(feature = "cli")]
/// Draws a figure into a PNG or SVG at `path` (chosen by extension; none means PNG), with
/// `footer` along its foot: no plot is written without the conditions it was made under.
pub(crate) fn render(path: &Path, figure: &impl Figure, footer: &Footer) -> PlotResult {
    register_font();
    let ext = path.extension().map(|e| e.to_string_lossy().to_lowercase());
    let svg = match ext.as_deref() {
        Some("svg") => true,
        None | Some("png") => false,
        Some(other) => {
            return Err(format!(
                "a plot is written as .png or .svg, and '.{other}' is neither"
            ));
        }
    };
    // Open the file first, so that a missing directory or a read-only place reads like
    // any other I/O error rather than as the image encoder's.
    std::fs::File::create(path).map_err(err)?;
    if svg {
        let root = SVGBackend::new(path, SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        figure.draw(&footer::draw_footer(&root, footer)?)?;
        root.present().map_err(err)
    } else {
        let root = BitMapBackend::new(path, SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        figure.draw(&footer::draw_footer(&root, footer)?)?;
        root.present().map_err(err)
    }
}

/// Draws a figure as SVG text, for a page to hold inline.
pub(crate) fn svg_text(figure: &impl Figure) -> Result<String, String> {
    register_font();
    let mut text = String::new();
    {
        let root = SVGBackend::with_string(&mut text, SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        figure.draw(&root)?;
        root.present().map_err(err)?;
    }
    Ok(text)
}

/// Turns any plotters error into text.
pub(crate) fn err<E: std::fmt::Display>(e: E) -> String {
    e.to_string()
}

/// A distinguishable colour for series `i`.
pub(crate) fn series_color(i: usize) -> RGBColor {
    const COLORS: [RGBColor; 8] = [
        RGBColor(31, 119, 180),
        RGBColor(214, 39, 40),
        RGBColor(44, 160, 44),
        RGBColor(148, 103, 189),
        RGBColor(255, 127, 14),
        RGBColor(23, 190, 207),
        RGBColor(140, 86, 75),
        RGBColor(127, 127, 127),
    ];
    COLORS[i % COLORS.len()]
}
