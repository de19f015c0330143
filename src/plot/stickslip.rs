//! Time–displacement curves at low feeds, like the paper's Figs. 29–30: the table's
//! position against the commanded ramp, one panel per feed.

use plotters::coord::Shift;
use plotters::prelude::*;

use super::{FONT, Figure, PlotResult, err, series_color};

/// One feed's run.
pub struct StickSlipCurve {
    /// Panel title, e.g. "3 mm/min — stick-slip (max slip 1.37 µm)".
    pub label: String,
    /// (time s, table position µm).
    pub table_um: Vec<(f64, f64)>,
    /// (time s, commanded position µm).
    pub command_um: Vec<(f64, f64)>,
}

/// The figure.
pub struct StickSlipPlot {
    /// Title.
    pub title: String,
    /// Panels.
    pub curves: Vec<StickSlipCurve>,
}

impl Figure for StickSlipPlot {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> PlotResult {
        let root = root.titled(&self.title, (FONT, 28)).map_err(err)?;
        let n = self.curves.len().max(1);
        let cols = if n > 3 { 2 } else { 1 };
        let rows = n.div_ceil(cols);
        let panels = root.split_evenly((rows, cols));
        for (i, (c, area)) in self.curves.iter().zip(panels.iter()).enumerate() {
            let t_min = c.table_um.first().map_or(0.0, |p| p.0);
            let t_max = c.table_um.last().map_or(1.0, |p| p.0).max(t_min + 1e-6);
            let values = || c.command_um.iter().chain(&c.table_um).map(|p| p.1);
            let y_min = values().fold(f64::MAX, f64::min).min(0.0);
            let y_max = values().fold(f64::MIN, f64::max).max(y_min + 1e-3);
            let pad = 0.05 * (y_max - y_min);
            // The caption shrinks to its panel's width (a glyph about 0.55 of the font's
            // size wide): at 18 px the longer verdicts ran off both sides of a half-width
            // panel.
            let (width_px, _) = area.dim_in_pixel();
            let glyphs = c.label.chars().count().max(1) as f64;
            let caption_px = (0.95 * f64::from(width_px) / (0.55 * glyphs)).clamp(10.0, 18.0);
            let mut chart = ChartBuilder::on(area)
                .caption(&c.label, (FONT, caption_px))
                .margin(10)
                .x_label_area_size(40)
                .y_label_area_size(60)
                .build_cartesian_2d(t_min..t_max, (y_min - pad)..(y_max + pad))
                .map_err(err)?;
            chart
                .configure_mesh()
                .x_desc("time (s)")
                .y_desc("position (µm)")
                .label_style((FONT, 14))
                .axis_desc_style((FONT, 15))
                .draw()
                .map_err(err)?;
            chart
                .draw_series(LineSeries::new(
                    c.command_um.iter().copied(),
                    BLACK.mix(0.4).stroke_width(1),
                ))
                .map_err(err)?
                .label("command")
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK.mix(0.4)));
            let color = series_color(i);
            chart
                .draw_series(LineSeries::new(
                    c.table_um.iter().copied(),
                    color.stroke_width(2),
                ))
                .map_err(err)?
                .label("table")
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
                });
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::UpperLeft)
                .label_font((FONT, 13))
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .draw()
                .map_err(err)?;
        }
        Ok(())
    }
}
