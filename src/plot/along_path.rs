//! Contour error along the path length, with the hotspots marked.

use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

use super::labels::place_labels;
use super::{FONT, Figure, PlotResult, err, series_color};

/// Font size of the hotspots' labels (px).
const LABEL_FONT_PX: u32 = 14;

/// The figure.
pub struct AlongPathPlot {
    /// Title.
    pub title: String,
    /// (path length mm, signed contour error µm); NaN error breaks the line (rapids).
    pub points: Vec<(f64, f64)>,
    /// (path length mm, error µm, label) of the hotspots.
    pub markers: Vec<(f64, f64, String)>,
}

impl Figure for AlongPathPlot {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> PlotResult {
        let root = root.titled(&self.title, (FONT, 26)).map_err(err)?;
        let finite = || self.points.iter().filter(|p| p.1.is_finite());
        let s_max = self
            .points
            .iter()
            .map(|p| p.0)
            .fold(0.0, f64::max)
            .max(1e-3);
        let (lo, hi) = finite().fold((0.0f64, 0.0f64), |(a, b), p| (a.min(p.1), b.max(p.1)));
        let pad = 0.08 * (hi - lo).max(1e-3);
        let mut chart = ChartBuilder::on(&root)
            .margin(15)
            .x_label_area_size(45)
            .y_label_area_size(75)
            .build_cartesian_2d(0.0..s_max, (lo - pad)..(hi + pad))
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc("path length (mm)")
            .y_desc("contour error (µm, + left of travel)")
            .label_style((FONT, 15))
            .axis_desc_style((FONT, 17))
            .draw()
            .map_err(err)?;
        // One line per stretch of cutting: rapids (NaN) break it.
        let color = series_color(0);
        for run in self
            .points
            .split(|p| !p.1.is_finite())
            .filter(|r| r.len() > 1)
        {
            chart
                .draw_series(LineSeries::new(run.iter().copied(), color.stroke_width(2)))
                .map_err(err)?;
        }
        chart
            .draw_series(LineSeries::new([(0.0, 0.0), (s_max, 0.0)], BLACK.mix(0.5)))
            .map_err(err)?;
        let rings: Vec<((f64, f64), &str)> = self
            .markers
            .iter()
            .map(|(s, e, label)| ((*s, *e), label.as_str()))
            .collect();
        draw_labelled_rings(&mut chart, &rings, 6, LABEL_FONT_PX)
    }
}

/// Red rings at `rings`' points (chart coordinates), each labelled where its label overlaps
/// no other label and no ring and stays inside the chart, in the order given (the most
/// important first); a label with no free place is left out, its ring stays.
pub(super) fn draw_labelled_rings<DB: DrawingBackend>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    rings: &[((f64, f64), &str)],
    radius_px: i32,
    font_px: u32,
) -> PlotResult {
    let at_px: Vec<(i32, i32)> = rings.iter().map(|(p, _)| chart.backend_coord(p)).collect();
    let labels: Vec<String> = rings.iter().map(|(_, l)| l.to_string()).collect();
    let (xs, ys) = chart.plotting_area().get_pixel_range();
    let placed = place_labels(
        &at_px,
        &labels,
        font_px,
        (xs.start, ys.start, xs.end, ys.end),
        &[],
    );
    for ((at, label), offset) in rings.iter().zip(placed) {
        chart
            .draw_series(std::iter::once(Circle::new(
                *at,
                radius_px,
                RED.stroke_width(2),
            )))
            .map_err(err)?;
        if let Some(offset) = offset {
            chart
                .draw_series(std::iter::once(
                    EmptyElement::at(*at)
                        + Text::new(
                            label.to_string(),
                            offset,
                            (FONT, font_px).into_font().color(&RED),
                        ),
                ))
                .map_err(err)?;
        }
    }
    Ok(())
}
