//! Sweep plots: error against one swept parameter (like the paper's Figs. 23–24), or a heat
//! map of the largest contour error over two.

use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

use super::labels::{along_polyline, place_labels};
use super::legend::{LegendEntry, draw_legend, legend_box};
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
    /// Parameter values flagged for their margins or damping.
    pub flagged: Vec<f64>,
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
                .margin_right(30)
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
            let first_color = color_index;
            color_index += curves.len();
            self.draw_panel(&mut chart, curves, first_color, y1)?;
        }
        Ok(())
    }
}

impl SweepLinePlot {
    /// One panel's legend (clear of its points and lines), curves, the flagged settings
    /// ringed and the unstable ones named, every label where no other is.
    fn draw_panel<DB: DrawingBackend>(
        &self,
        chart: &mut ChartContext<'_, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
        curves: &[Curve],
        first_color: usize,
        y1: f64,
    ) -> PlotResult {
        let finite = |pts: &[(f64, f64)]| -> Vec<(f64, f64)> {
            pts.iter().copied().filter(|p| p.1.is_finite()).collect()
        };
        let mut drawn_px = Vec::new();
        for (_, pts) in curves {
            let px: Vec<(i32, i32)> = finite(pts).iter().map(|p| chart.backend_coord(p)).collect();
            drawn_px.extend(along_polyline(&px));
        }
        let mut entries: Vec<LegendEntry> = curves
            .iter()
            .enumerate()
            .map(|(i, (name, _))| LegendEntry {
                text: name.clone(),
                color: series_color(first_color + i),
                width: 3,
            })
            .collect();
        if !self.flagged.is_empty() {
            entries.push(LegendEntry {
                text: "ringed: flagged (margins or damping)".into(),
                color: RED,
                width: 2,
            });
        }
        draw_legend(chart.plotting_area(), &entries, &drawn_px)?;
        let legend = legend_box(chart.plotting_area(), &entries, &drawn_px);
        for (i, (_, pts)) in curves.iter().enumerate() {
            let color = series_color(first_color + i);
            let pts = finite(pts);
            chart
                .draw_series(LineSeries::new(pts.iter().copied(), color.stroke_width(2)))
                .map_err(err)?;
            chart
                .draw_series(pts.iter().map(|&p| Circle::new(p, 4, color.filled())))
                .map_err(err)?;
            chart
                .draw_series(
                    pts.iter()
                        .filter(|p| self.flagged.contains(&p.0))
                        .map(|&p| Circle::new(p, 9, RED.stroke_width(2))),
                )
                .map_err(err)?;
        }
        let at: Vec<(f64, f64)> = self.unstable.iter().map(|&x| (x, y1 * 0.05)).collect();
        let at_px: Vec<(i32, i32)> = at.iter().map(|p| chart.backend_coord(p)).collect();
        let labels = vec!["unstable".to_string(); at.len()];
        let (xs, ys) = chart.plotting_area().get_pixel_range();
        let placed = place_labels(
            &at_px,
            &labels,
            14,
            (xs.start, ys.start, xs.end, ys.end),
            &[legend],
        );
        for (p, offset) in at.iter().zip(placed) {
            chart
                .draw_series(std::iter::once(Cross::new(*p, 6, RED.stroke_width(2))))
                .map_err(err)?;
            if let Some(offset) = offset {
                chart
                    .draw_series(std::iter::once(
                        EmptyElement::at(*p)
                            + Text::new("unstable", offset, (FONT, 14).into_font().color(&RED)),
                    ))
                    .map_err(err)?;
            }
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
    /// flagged[i][j]: the setting is flagged for its margins or damping.
    pub flagged: Vec<Vec<bool>>,
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
                let flagged = self
                    .flagged
                    .get(i)
                    .and_then(|r| r.get(j))
                    .copied()
                    .unwrap_or(false);
                draw_cell(&mut chart, (i as f64, j as f64), v / max, v, flagged)?;
            }
        }
        draw_colorbar(&bar, max, "max contour error (µm)")
    }
}

/// One cell of the heat map at `(x, y)`: its colour by `share` of the largest error, a red
/// ring where the setting is flagged, and its value (or "unstable") written in it.
fn draw_cell<DB: DrawingBackend>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    (x, y): (f64, f64),
    share: f64,
    v: f64,
    flagged: bool,
) -> PlotResult {
    let fill = if v.is_finite() {
        colormap(share).filled()
    } else {
        RGBColor(200, 200, 200).filled()
    };
    chart
        .draw_series(std::iter::once(Rectangle::new(
            [(x - 0.5, y - 0.5), (x + 0.5, y + 0.5)],
            fill,
        )))
        .map_err(err)?;
    if flagged {
        chart
            .draw_series(std::iter::once(Rectangle::new(
                [(x - 0.47, y - 0.47), (x + 0.47, y + 0.47)],
                RED.stroke_width(3),
            )))
            .map_err(err)?;
    }
    let text = match (v.is_finite(), flagged) {
        (true, false) => format!("{v:.1}"),
        (true, true) => format!("{v:.1} flagged"),
        (false, _) => "unstable".into(),
    };
    // Dark text on the light end of the colour map, light text on the dark end.
    let color = match (v.is_finite(), share > 0.6) {
        (false, _) => RED,
        (true, true) => BLACK,
        (true, false) => WHITE,
    };
    chart
        .draw_series(std::iter::once(Text::new(
            text,
            (x - 0.3, y),
            (FONT, 14).into_font().color(&color),
        )))
        .map_err(err)?;
    Ok(())
}
