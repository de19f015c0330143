//! Bode plots of the loops, like the paper's Figs. 26–28: magnitude over phase, log
//! frequency axis, one colour per loop; each loop's resonance peak, phase margin and gain
//! margin marked on its curves, the axes fitted to the data so that no peak is cut.

use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

use super::labels::{PixelBox, along_polyline, place_labels};
use super::legend::{LegendEntry, draw_legend, legend_box};
use super::{FONT, Figure, PlotResult, err, series_color};

/// One loop's response: (frequency Hz, magnitude dB, phase °).
pub struct BodeCurve {
    /// Legend label.
    pub label: String,
    /// Points.
    pub points: Vec<(f64, f64, f64)>,
    /// Marks on this curve.
    pub marks: Vec<BodeMark>,
}

/// A figure marked on a curve at a frequency: on the magnitude (a peak) or the phase (a
/// margin read at that frequency).
pub struct BodeMark {
    /// Where (Hz).
    pub freq_hz: f64,
    /// On the phase panel rather than the magnitude one.
    pub on_phase: bool,
    /// Text, e.g. `PM 62.7°`.
    pub label: String,
}

/// The figure: a title and the curves.
pub struct BodePlot {
    /// Title.
    pub title: String,
    /// Curves.
    pub curves: Vec<BodeCurve>,
}

/// Below this the magnitude is not drawn: a closed loop falls without end above its
/// bandwidth, and the plot is about where it does not.
const MAGNITUDE_FLOOR_DB: f64 = -60.0;

/// Font size of the marks' labels (px).
const MARK_FONT_PX: u32 = 14;

type BodeChart<'a, DB> = ChartContext<'a, DB, Cartesian2d<LogCoord<f64>, RangedCoordf64>>;

impl Figure for BodePlot {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> PlotResult {
        let root = root.titled(&self.title, (FONT, 26)).map_err(err)?;
        let (upper, lower) = root.split_vertically(root.dim_in_pixel().1 / 2);
        let firsts = self.curves.iter().flat_map(|c| c.points.first());
        let f_min = firsts.map(|p| p.0).fold(f64::MAX, f64::min);
        let lasts = self.curves.iter().flat_map(|c| c.points.last());
        let f_max = lasts.map(|p| p.0).fold(f64::MIN, f64::max);
        let values = |pick: usize| {
            self.curves.iter().flat_map(move |c| {
                c.points
                    .iter()
                    .map(move |p| if pick == 1 { p.1 } else { p.2 })
            })
        };
        let magnitude = fitted(values(1), MAGNITUDE_FLOOR_DB);
        let phase = fitted(values(2), f64::NEG_INFINITY);
        for (area, range, label, pick) in [
            (&upper, magnitude, "magnitude (dB)", 1usize),
            (&lower, phase, "phase (°)", 2usize),
        ] {
            let mut chart = ChartBuilder::on(area)
                .margin(12)
                // Room for the last frequency's tick label, centred on the axis's end.
                .margin_right(40)
                .x_label_area_size(45)
                .y_label_area_size(70)
                .build_cartesian_2d((f_min..f_max).log_scale(), range.0..range.1)
                .map_err(err)?;
            chart
                .configure_mesh()
                .x_desc("frequency (Hz)")
                .y_desc(label)
                .label_style((FONT, 16))
                .axis_desc_style((FONT, 18))
                .draw()
                .map_err(err)?;
            self.draw_panel(&mut chart, range, pick)?;
        }
        Ok(())
    }
}

impl BodePlot {
    /// One panel's curves (`pick` 1: magnitude, 2: phase), the legend (magnitude panel)
    /// and the marks, labelled where no label overlaps another or the legend.
    fn draw_panel<DB: DrawingBackend>(
        &self,
        chart: &mut BodeChart<'_, DB>,
        (lo, hi): (f64, f64),
        pick: usize,
    ) -> PlotResult {
        let value = |p: &(f64, f64, f64)| if pick == 1 { p.1 } else { p.2 };
        let mut drawn_px = Vec::new();
        let stretches: Vec<Vec<Vec<(f64, f64)>>> = self
            .curves
            .iter()
            .map(|c| inside_stretches(c.points.iter().map(|p| (p.0, value(p))), lo, hi))
            .collect();
        for s in stretches.iter().flatten() {
            let px: Vec<(i32, i32)> = s.iter().map(|p| chart.backend_coord(p)).collect();
            drawn_px.extend(along_polyline(&px));
        }
        let entries: Vec<LegendEntry> = self
            .curves
            .iter()
            .enumerate()
            .map(|(i, c)| LegendEntry {
                text: c.label.clone(),
                color: series_color(i),
                width: 3,
            })
            .collect();
        let mut avoid: Vec<PixelBox> = Vec::new();
        if pick == 1 {
            draw_legend(chart.plotting_area(), &entries, &drawn_px)?;
            avoid.push(legend_box(chart.plotting_area(), &entries, &drawn_px));
        }
        for (i, stretches) in stretches.iter().enumerate() {
            for stretch in stretches {
                chart
                    .draw_series(LineSeries::new(
                        stretch.iter().copied(),
                        series_color(i).stroke_width(2),
                    ))
                    .map_err(err)?;
            }
        }
        if pick == 1 && lo <= MAGNITUDE_FLOOR_DB {
            let (xs, ys) = chart.plotting_area().get_pixel_range();
            let at = (xs.end - 230, ys.end - 24);
            avoid.push(super::labels::text_box(at, "below −60 dB: not drawn", 15));
            chart
                .plotting_area()
                .strip_coord_spec()
                .draw(&Text::new(
                    "below −60 dB: not drawn",
                    (at.0 - xs.start, at.1 - ys.start),
                    (FONT, 15).into_font(),
                ))
                .map_err(err)?;
        }
        self.draw_marks(chart, pick, &avoid)
    }

    /// Each curve's marks on this panel: a ring on the curve and its label beside it.
    fn draw_marks<DB: DrawingBackend>(
        &self,
        chart: &mut BodeChart<'_, DB>,
        pick: usize,
        avoid: &[PixelBox],
    ) -> PlotResult {
        let on_curve: Vec<((f64, f64), String, usize)> = self
            .curves
            .iter()
            .enumerate()
            .flat_map(|(i, c)| {
                c.marks
                    .iter()
                    .filter(move |m| m.on_phase == (pick == 2))
                    .filter_map(move |m| {
                        let v = value_at(&c.points, m.freq_hz, pick)?;
                        Some(((m.freq_hz, v), m.label.clone(), i))
                    })
            })
            .collect();
        let at_px: Vec<(i32, i32)> = on_curve.iter().map(|m| chart.backend_coord(&m.0)).collect();
        let labels: Vec<String> = on_curve.iter().map(|m| m.1.clone()).collect();
        let (xs, ys) = chart.plotting_area().get_pixel_range();
        let bounds = (xs.start, ys.start, xs.end, ys.end);
        let placed = place_labels(&at_px, &labels, MARK_FONT_PX, bounds, avoid);
        for ((point, label, i), offset) in on_curve.iter().zip(placed) {
            let color = series_color(*i);
            chart
                .draw_series(std::iter::once(Circle::new(
                    *point,
                    6,
                    color.stroke_width(2),
                )))
                .map_err(err)?;
            if let Some(offset) = offset {
                chart
                    .draw_series(std::iter::once(
                        EmptyElement::at(*point)
                            + Text::new(
                                label.clone(),
                                offset,
                                (FONT, MARK_FONT_PX).into_font().color(&color),
                            ),
                    ))
                    .map_err(err)?;
            }
        }
        Ok(())
    }
}

/// The curve's magnitude (`pick` 1) or phase (2) at `freq_hz`, linear between its points
/// in log frequency; `None` outside them.
fn value_at(points: &[(f64, f64, f64)], freq_hz: f64, pick: usize) -> Option<f64> {
    let value = |p: &(f64, f64, f64)| if pick == 1 { p.1 } else { p.2 };
    let i = points.iter().position(|p| p.0 >= freq_hz)?;
    if i == 0 {
        return (points[0].0 == freq_hz).then(|| value(&points[0]));
    }
    let (a, b) = (&points[i - 1], &points[i]);
    let t = (freq_hz.ln() - a.0.ln()) / (b.0.ln() - a.0.ln());
    Some(value(a) + t * (value(b) - value(a)))
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

/// The axis range for `values`: all of them with a margin of a tenth of their span above
/// and below (a peak is never cut), but not below `floor`.
fn fitted(values: impl Iterator<Item = f64>, floor: f64) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::MAX, f64::MIN), |(a, b), v| (a.min(v), b.max(v)));
    if lo > hi {
        return (-1.0, 1.0);
    }
    let lo = lo.max(floor);
    let span = (hi - lo).max(1.0);
    ((lo - 0.1 * span).max(floor), hi + 0.1 * span)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_axes_hold_the_whole_peak() {
        // A resonance 14 dB above a loop that falls to −200 dB: the axis keeps the peak
        // with room above it, and stops at the floor below.
        let (lo, hi) = fitted([0.0, 14.0, -3.0, -200.0].into_iter(), MAGNITUDE_FLOOR_DB);
        assert!(hi > 14.0 && lo == MAGNITUDE_FLOOR_DB, "{lo} {hi}");
        let (lo, hi) = fitted([-10.0, -400.0].into_iter(), f64::NEG_INFINITY);
        assert!(lo < -400.0 && hi > -10.0);
        let curve = [(1.0, 0.0, -10.0), (10.0, 10.0, -100.0)];
        let mid = value_at(&curve, 10f64.sqrt(), 1).unwrap();
        assert!((mid - 5.0).abs() < 1e-12);
        assert_eq!(value_at(&curve, 20.0, 1), None);
    }
}
