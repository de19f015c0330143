//! A chart's legend, drawn in the corner its data leaves free ([`labels::best_corner`]) and
//! before the data, so that no point or line is ever hidden behind it.

use plotters::coord::CoordTranslate;
use plotters::prelude::*;

use super::labels::{self, PixelBox};
use super::{FONT, PlotResult, err};

/// One legend entry: its text, and the colour and width of its line.
pub struct LegendEntry {
    /// Text.
    pub text: String,
    /// Line colour.
    pub color: RGBColor,
    /// Line width (px).
    pub width: u32,
}

/// Font size of legends (px).
pub const LEGEND_FONT_PX: u32 = 14;

/// The box (backend px) a legend of `entries` takes on `plot` (a chart's plotting area)
/// clear of `points_px` (backend px) where a corner is.
pub(crate) fn legend_box<DB: DrawingBackend, CT: CoordTranslate>(
    plot: &DrawingArea<DB, CT>,
    entries: &[LegendEntry],
    points_px: &[(i32, i32)],
) -> PixelBox {
    let (xs, ys) = plot.get_pixel_range();
    let chart = (xs.start, ys.start, xs.end, ys.end);
    let texts: Vec<String> = entries.iter().map(|e| e.text.clone()).collect();
    labels::best_corner(
        chart,
        labels::legend_size(&texts, LEGEND_FONT_PX),
        points_px,
    )
}

/// Draws the legend of `entries` on `plot` in the box [`legend_box`] gives.
pub(crate) fn draw_legend<DB: DrawingBackend, CT: CoordTranslate>(
    plot: &DrawingArea<DB, CT>,
    entries: &[LegendEntry],
    points_px: &[(i32, i32)],
) -> PlotResult {
    if entries.is_empty() {
        return Ok(());
    }
    let b = legend_box(plot, entries, points_px);
    draw_legend_in(plot, entries, b)
}

/// Draws the legend of `entries` in the box `b` (backend px, as [`legend_box`] gives it) on
/// `area`: inside a chart's plotting area, or on the area around it, beside the chart.
pub(crate) fn draw_legend_in<DB: DrawingBackend, CT: CoordTranslate>(
    area: &DrawingArea<DB, CT>,
    entries: &[LegendEntry],
    b: PixelBox,
) -> PlotResult {
    let (xs, ys) = area.get_pixel_range();
    let area = area.strip_coord_spec();
    // The area draws in its own pixels, from its top-left.
    let (x0, y0) = (b.0 - xs.start, b.1 - ys.start);
    let (x1, y1) = (b.2 - xs.start, b.3 - ys.start);
    area.draw(&Rectangle::new(
        [(x0, y0), (x1, y1)],
        WHITE.mix(0.85).filled(),
    ))
    .map_err(err)?;
    area.draw(&Rectangle::new([(x0, y0), (x1, y1)], BLACK.stroke_width(1)))
        .map_err(err)?;
    let row = LEGEND_FONT_PX as i32 + 8;
    for (i, e) in entries.iter().enumerate() {
        let y = y0 + 8 + row * i as i32;
        let mid = y + LEGEND_FONT_PX as i32 / 2;
        area.draw(&PathElement::new(
            vec![(x0 + 10, mid), (x0 + 34, mid)],
            e.color.stroke_width(e.width.max(2)),
        ))
        .map_err(err)?;
        area.draw(&Text::new(
            e.text.clone(),
            (x0 + 44, y),
            (FONT, LEGEND_FONT_PX).into_font(),
        ))
        .map_err(err)?;
    }
    Ok(())
}
