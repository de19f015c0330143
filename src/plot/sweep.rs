//! Sweep plots: error against one swept parameter (like the paper's Figs. 23–24), or a heat
//! map of the largest contour error over two.

use plotters::coord::Shift;
use plotters::prelude::*;

use super::toolpath::{colormap, draw_colorbar};
use super::{FONT, Figure, PlotResult, err, series_color};

/// One curve: its name and points (x, y; y is NaN where the setting was unstable).
pub type Curve = (String, Vec<(f64, f64)>);

/// Error curves over one parameter, in panels that share the parameter axis.
pub struct SweepLinePlot {
    /// Title.
    pub title: String,
    /// X-axis label.
    pub x_label: String,
    /// Panels: y-axis label and its curves.
    pub panels: Vec<(String, Vec<Curve>)>,
    /// Parameter values flagged unstable.
    pub unstable: Vec<f64>,
}

impl Figure for SweepLinePlot {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> PlotResult {
        let root = root.titled(&self.title, (FONT, 26)).map_err(err)?;
        let xs = || {
            self.panels
                .iter()
                .flat_map(|p| p.1.iter().flat_map(|c| c.1.iter().map(|q| q.0)))
                .chain(self.unstable.iter().copied())
        };
        let (x0, x1) = xs().fold((f64::MAX, f64::MIN), |(a, b), x| (a.min(x), b.max(x)));
        let pad = 0.05 * (x1 - x0).max(1e-9);
        let areas = root.split_evenly((self.panels.len().max(1), 1));
        let mut color_index = 0;
        for ((y_label, curves), area) in self.panels.iter().zip(areas.iter()) {
            let y1 = curves
                .iter()
                .flat_map(|c| c.1.iter().map(|p| p.1))
                .filter(|y| y.is_finite())
                .fold(0.0, f64::max);
            let mut chart = ChartBuilder::on(area)
                .margin(12)
                .x_label_area_size(40)
                .y_label_area_size(80)
                .build_cartesian_2d((x0 - pad)..(x1 + pad), 0.0..(y1 * 1.12).max(1e-3))
                .map_err(err)?;
            chart
                .configure_mesh()
                .x_desc(self.x_label.as_str())
                .y_desc(y_label.as_str())
                .label_style((FONT, 14))
                .axis_desc_style((FONT, 16))
                .draw()
                .map_err(err)?;
            for (name, pts) in curves {
                let color = series_color(color_index);
                color_index += 1;
                let finite: Vec<(f64, f64)> =
                    pts.iter().copied().filter(|p| p.1.is_finite()).collect();
                chart
                    .draw_series(LineSeries::new(
                        finite.iter().copied(),
                        color.stroke_width(2),
                    ))
                    .map_err(err)?
                    .label(name.clone())
                    .legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 24, y)], color.stroke_width(3))
                    });
                chart
                    .draw_series(finite.iter().map(|&p| Circle::new(p, 4, color.filled())))
                    .map_err(err)?;
            }
            for &x in &self.unstable {
                chart
                    .draw_series(std::iter::once(Text::new(
                        "unstable",
                        (x, y1 * 0.05),
                        (FONT, 14).into_font().color(&RED),
                    )))
                    .map_err(err)?;
            }
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::UpperRight)
                .label_font((FONT, 14))
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .draw()
                .map_err(err)?;
        }
        Ok(())
    }
}

/// A heat map of one figure over two parameters; NaN cells are unstable.
pub struct SweepHeatMap {
    /// Title.
    pub title: String,
    /// Axis labels.
    pub labels: (String, String),
    /// Values of the first and second parameter.
    pub axes: (Vec<f64>, Vec<f64>),
    /// cells[i][j]: first parameter's i-th value, second's j-th (µm, NaN = unstable).
    pub cells: Vec<Vec<f64>>,
}

impl Figure for SweepHeatMap {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> PlotResult {
        let root = root.titled(&self.title, (FONT, 26)).map_err(err)?;
        let (w, _) = root.dim_in_pixel();
        let (main, bar) = root.split_horizontally(w - 150);
        let (a, b) = (&self.axes.0, &self.axes.1);
        let max = self
            .cells
            .iter()
            .flatten()
            .copied()
            .filter(|v| v.is_finite())
            .fold(0.0, f64::max)
            .max(1e-6);
        let mut chart = ChartBuilder::on(&main)
            .margin(15)
            .x_label_area_size(45)
            .y_label_area_size(75)
            .build_cartesian_2d(-0.5..(a.len() as f64 - 0.5), -0.5..(b.len() as f64 - 0.5))
            .map_err(err)?;
        let fmt_a = |x: &f64| {
            a.get(x.round() as usize)
                .map_or(String::new(), |v| format!("{v}"))
        };
        let fmt_b = |y: &f64| {
            b.get(y.round() as usize)
                .map_or(String::new(), |v| format!("{v}"))
        };
        chart
            .configure_mesh()
            .disable_mesh()
            .x_labels(a.len())
            .y_labels(b.len())
            .x_label_formatter(&fmt_a)
            .y_label_formatter(&fmt_b)
            .x_desc(self.labels.0.as_str())
            .y_desc(self.labels.1.as_str())
            .label_style((FONT, 15))
            .axis_desc_style((FONT, 17))
            .draw()
            .map_err(err)?;
        for (i, row) in self.cells.iter().enumerate() {
            for (j, &v) in row.iter().enumerate() {
                let (x, y) = (i as f64, j as f64);
                let fill = if v.is_finite() {
                    colormap(v / max).filled()
                } else {
                    RGBColor(200, 200, 200).filled()
                };
                chart
                    .draw_series(std::iter::once(Rectangle::new(
                        [(x - 0.5, y - 0.5), (x + 0.5, y + 0.5)],
                        fill,
                    )))
                    .map_err(err)?;
                let text = if v.is_finite() {
                    format!("{v:.1}")
                } else {
                    "unstable".into()
                };
                let color = if v.is_finite() && v / max > 0.6 {
                    BLACK
                } else {
                    WHITE
                };
                let color = if v.is_finite() { color } else { RED };
                chart
                    .draw_series(std::iter::once(Text::new(
                        text,
                        (x - 0.3, y),
                        (FONT, 14).into_font().color(&color),
                    )))
                    .map_err(err)?;
            }
        }
        draw_colorbar(&bar, max, "max contour error (µm)")
    }
}
