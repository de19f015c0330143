//! Stacked panels of curves over an abscissa of the same kind (time or path length), each
//! with its own range, ordinate and legend: measured against modelled traces, residuals before and after.

use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

use super::labels::along_polyline;
use super::legend::{LegendEntry, draw_legend};
use super::{FONT, Figure, PlotResult, err, series_color};

/// One curve. A NaN ordinate breaks the line (a stretch left out, a rapid).
pub struct Curve {
    /// Legend entry.
    pub name: String,
    /// (abscissa, ordinate).
    pub points: Vec<(f64, f64)>,
    /// Colour index ([`series_color`]); `None` for a light grey reference curve.
    pub color: Option<usize>,
    /// Line width (px).
    pub width: u32,
}

/// One panel.
pub struct Panel {
    /// Caption above the panel.
    pub caption: String,
    /// Ordinate label with its unit.
    pub y_label: String,
    /// Curves, drawn in order (later on top).
    pub curves: Vec<Curve>,
}

/// The figure.
pub struct PanelsPlot {
    /// Title.
    pub title: String,
    /// Abscissa label with its unit.
    pub x_label: String,
    /// Panels, top to bottom.
    pub panels: Vec<Panel>,
}

impl Figure for PanelsPlot {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> PlotResult {
        let root = root.titled(&self.title, (FONT, 26)).map_err(err)?;
        let areas = root.split_evenly((self.panels.len().max(1), 1));
        for (panel, area) in self.panels.iter().zip(areas.iter()) {
            // Each panel spans its own curves (one may be a close-up).
            let (x0, x1) = panel
                .curves
                .iter()
                .flat_map(|c| c.points.iter())
                .fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.0), b.max(p.0)));
            let range = if x0 < x1 { (x0, x1) } else { (0.0, 1.0) };
            draw_panel(panel, area, range, &self.x_label)?;
        }
        Ok(())
    }
}

fn draw_panel<DB: DrawingBackend>(
    panel: &Panel,
    area: &DrawingArea<DB, Shift>,
    (x0, x1): (f64, f64),
    x_label: &str,
) -> PlotResult {
    let ys = panel
        .curves
        .iter()
        .flat_map(|c| c.points.iter().map(|p| p.1))
        .filter(|y| y.is_finite());
    let (lo, hi) = ys.fold((f64::MAX, f64::MIN), |(a, b), y| (a.min(y), b.max(y)));
    let (lo, hi) = if lo <= hi { (lo, hi) } else { (-1.0, 1.0) };
    let pad = 0.08 * (hi - lo).max(1e-3);
    let mut chart = ChartBuilder::on(area)
        .caption(&panel.caption, (FONT, 18))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(75)
        .build_cartesian_2d(x0..x1, (lo - pad)..(hi + pad))
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc(x_label)
        .y_desc(panel.y_label.as_str())
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 15))
        .draw()
        .map_err(err)?;
    draw_curves(&mut chart, &panel.curves)
}

/// Draws the legend (where it covers fewest of the curves) and `curves` on `chart`, each
/// broken where its ordinate is NaN.
pub(super) fn draw_curves<'a, DB: DrawingBackend + 'a>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    curves: &[Curve],
) -> PlotResult {
    let style_of = |curve: &Curve| match curve.color {
        Some(i) => (series_color(i), curve.width),
        None => (RGBColor(150, 150, 150), curve.width),
    };
    let pieces = |curve: &'_ Curve| {
        curve
            .points
            .split(|p| !p.1.is_finite())
            .filter(|r| r.len() > 1)
            .map(|r| r.to_vec())
            .collect::<Vec<_>>()
    };
    let mut drawn_px = Vec::new();
    for curve in curves {
        for piece in pieces(curve) {
            let px: Vec<(i32, i32)> = piece.iter().map(|p| chart.backend_coord(p)).collect();
            drawn_px.extend(along_polyline(&px));
        }
    }
    // One legend entry per curve, however many pieces it is drawn in; none for a curve
    // without a name (a second curve of an entry already made).
    let entries: Vec<LegendEntry> = curves
        .iter()
        .filter(|c| !c.name.is_empty() && !pieces(c).is_empty())
        .map(|c| {
            let (color, width) = style_of(c);
            LegendEntry {
                text: c.name.clone(),
                color,
                width,
            }
        })
        .collect();
    draw_legend(chart.plotting_area(), &entries, &drawn_px)?;
    for curve in curves {
        let (color, width) = style_of(curve);
        for piece in pieces(curve) {
            chart
                .draw_series(LineSeries::new(piece, color.stroke_width(width)))
                .map_err(err)?;
        }
    }
    Ok(())
}
