//! Bode plots of the three loops, like the paper's Figs. 26–28: magnitude over phase, log
//! frequency axis, one colour per loop.

use plotters::coord::Shift;
use plotters::prelude::*;

use super::{FONT, Figure, PlotResult, err, series_color};

/// One loop's response: (frequency Hz, magnitude dB, phase °).
pub struct BodeCurve {
    /// Legend label.
    pub label: String,
    /// Points.
    pub points: Vec<(f64, f64, f64)>,
}

/// The figure: a title and the curves.
pub struct BodePlot {
    /// Title.
    pub title: String,
    /// Curves.
    pub curves: Vec<BodeCurve>,
}

impl Figure for BodePlot {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> PlotResult {
        let root = root.titled(&self.title, (FONT, 28)).map_err(err)?;
        let (upper, lower) = root.split_vertically(root.dim_in_pixel().1 / 2);
        let firsts = self.curves.iter().flat_map(|c| c.points.first());
        let f_min = firsts.map(|p| p.0).fold(f64::MAX, f64::min);
        let lasts = self.curves.iter().flat_map(|c| c.points.last());
        let f_max = lasts.map(|p| p.0).fold(f64::MIN, f64::max);
        let (mag_lo, mag_hi) = bounds(
            self.curves
                .iter()
                .flat_map(|c| c.points.iter().map(|p| p.1)),
            -60.0,
            10.0,
        );
        let (ph_lo, ph_hi) = bounds(
            self.curves
                .iter()
                .flat_map(|c| c.points.iter().map(|p| p.2)),
            -270.0,
            10.0,
        );
        for (area, (lo, hi), label, pick) in [
            (&upper, (mag_lo, mag_hi), "magnitude (dB)", 1usize),
            (&lower, (ph_lo, ph_hi), "phase (°)", 2usize),
        ] {
            let mut chart = ChartBuilder::on(area)
                .margin(12)
                .x_label_area_size(45)
                .y_label_area_size(70)
                .build_cartesian_2d((f_min..f_max).log_scale(), lo..hi)
                .map_err(err)?;
            chart
                .configure_mesh()
                .x_desc("frequency (Hz)")
                .y_desc(label)
                .label_style((FONT, 16))
                .axis_desc_style((FONT, 18))
                .draw()
                .map_err(err)?;
            for (i, c) in self.curves.iter().enumerate() {
                let color = series_color(i);
                let values = c
                    .points
                    .iter()
                    .map(|p| (p.0, if pick == 1 { p.1 } else { p.2 }));
                let stretches = inside_stretches(values, lo, hi);
                for (k, stretch) in stretches.into_iter().enumerate() {
                    let series = chart
                        .draw_series(LineSeries::new(stretch, color.stroke_width(2)))
                        .map_err(err)?;
                    if pick == 1 && k == 0 {
                        series.label(c.label.clone()).legend(move |(x, y)| {
                            PathElement::new(vec![(x, y), (x + 24, y)], color.stroke_width(3))
                        });
                    }
                }
            }
            if pick == 1 && mag_lo <= -60.0 {
                chart
                    .draw_series(std::iter::once(Text::new(
                        "below −60 dB: not drawn",
                        (f_max / 30.0, mag_lo + 0.04 * (mag_hi - mag_lo)),
                        (FONT, 15).into_font(),
                    )))
                    .map_err(err)?;
            }
            if pick == 1 {
                chart
                    .configure_series_labels()
                    .position(SeriesLabelPosition::LowerLeft)
                    .label_font((FONT, 16))
                    .background_style(WHITE.mix(0.8))
                    .border_style(BLACK)
                    .draw()
                    .map_err(err)?;
            }
        }
        Ok(())
    }
}

/// The stretches of `values` (frequency, value) inside [lo, hi], each its own line: values
/// beyond the axis are left out, not drawn along its edge where they would read as data.
fn inside_stretches(
    values: impl Iterator<Item = (f64, f64)>,
    lo: f64,
    hi: f64,
) -> Vec<Vec<(f64, f64)>> {
    let mut stretches: Vec<Vec<(f64, f64)>> = vec![Vec::new()];
    for (f, v) in values {
        if (lo..=hi).contains(&v) {
            stretches.last_mut().expect("one stretch").push((f, v));
        } else if !stretches.last().expect("one stretch").is_empty() {
            stretches.push(Vec::new());
        }
    }
    stretches.retain(|s| !s.is_empty());
    stretches
}

/// Range of the values, widened a little and clamped to [floor, ceiling].
fn bounds(values: impl Iterator<Item = f64>, floor: f64, ceiling: f64) -> (f64, f64) {
    let (lo, hi) = values.fold((f64::MAX, f64::MIN), |(a, b), v| (a.min(v), b.max(v)));
    let span = (hi - lo).max(1.0);
    (
        (lo - 0.05 * span).max(floor),
        (hi + 0.05 * span).min(ceiling),
    )
}
