//! A ballbar-style polar plot of a circular test (ISO 230-4): the radial deviation around
//! the nominal circle, magnified, for both directions of travel.

use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

use super::{FONT, Figure, PlotResult, err, series_color};

/// One direction's trace.
pub struct PolarTrace {
    /// Legend label, e.g. "counter-clockwise (line 13)".
    pub label: String,
    /// (angle rad, radial deviation µm).
    pub points: Vec<(f64, f64)>,
    /// Line width (px): 1 for noisy measured data, whose zig-zags a wider line's joins
    /// would draw as spikes.
    pub width: u32,
    /// The circle's G (µm), as the report gives it, for the legend.
    pub g_um: Option<f64>,
}

/// The figure.
pub struct PolarPlot {
    /// Title.
    pub title: String,
    /// Nominal radius (mm), for the caption.
    pub radius_mm: f64,
    /// Traces.
    pub traces: Vec<PolarTrace>,
}

/// Radius of the nominal circle in plot units; deviations are drawn around it.
const NOMINAL: f64 = 1.0;
/// The largest deviation is drawn this far from the nominal circle.
const SPAN: f64 = 0.45;
/// Where the rings' labels stand (degrees): off the quadrants, whose reversal spikes reach
/// the outer rings.
const LABEL_DEG: f64 = 67.5;

/// A round number of µm per grid ring for deviations up to `max_um`.
fn ring_step(max_um: f64) -> f64 {
    let raw = (max_um / 2.0).max(1e-3);
    let mag = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * mag)
}

/// The polar chart, in plot units.
type PolarChart<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// The nominal circle and `rings` rings either side, `ring` plot units and `step_um` apart,
/// labelled with their deviation.
fn draw_rings<DB: DrawingBackend>(
    chart: &mut PolarChart<'_, DB>,
    rings: i64,
    ring: f64,
    step_um: f64,
) -> PlotResult {
    let circle = |r: f64| {
        (0..=360).map(move |d| {
            let a = (d as f64).to_radians();
            (r * a.cos(), r * a.sin())
        })
    };
    for i in -rings..=rings {
        let r = NOMINAL + i as f64 * ring;
        let style = if i == 0 {
            BLACK.stroke_width(2)
        } else {
            BLACK.mix(0.2).stroke_width(1)
        };
        chart
            .draw_series(LineSeries::new(circle(r), style))
            .map_err(err)?;
        if i != 0 {
            // Between the spokes at 45° and 90°: a circle's reversal spikes stand at the
            // quadrants, where a label on the spoke sat on the trace.
            let label = format!("{:+} µm", i as f64 * step_um);
            let at = LABEL_DEG.to_radians();
            chart
                .draw_series(std::iter::once(Text::new(
                    label,
                    (r * at.cos(), r * at.sin()),
                    (FONT, 12).into_font().color(&BLACK.mix(0.6)),
                )))
                .map_err(err)?;
        }
    }
    Ok(())
}

/// Spokes every 45°, labelled with their angle.
fn draw_spokes<DB: DrawingBackend>(chart: &mut PolarChart<'_, DB>) -> PlotResult {
    for d in (0..360).step_by(45) {
        let a = (d as f64).to_radians();
        let (r0, r1) = (NOMINAL - SPAN, NOMINAL + SPAN);
        chart
            .draw_series(LineSeries::new(
                [(r0 * a.cos(), r0 * a.sin()), (r1 * a.cos(), r1 * a.sin())],
                BLACK.mix(0.2),
            ))
            .map_err(err)?;
        let (lx, ly) = ((r1 + 0.07) * a.cos(), (r1 + 0.07) * a.sin());
        chart
            .draw_series(std::iter::once(Text::new(
                format!("{d}°"),
                (lx - 0.05, ly),
                (FONT, 14),
            )))
            .map_err(err)?;
    }
    Ok(())
}

impl PolarPlot {
    /// The legend: the nominal radius, the grid, and each trace with its figures — F about
    /// the programmed centre, G about the path's own, as the report gives them, so that
    /// legend and text agree.
    fn legend_lines(&self, step_um: f64) -> Vec<(String, RGBColor)> {
        std::iter::once((format!("nominal radius {:.3} mm", self.radius_mm), BLACK))
            .chain(std::iter::once((
                format!("grid: {step_um} µm per ring"),
                BLACK,
            )))
            .chain(self.traces.iter().enumerate().flat_map(|(i, t)| {
                let (lo, hi) = t
                    .points
                    .iter()
                    .fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.1), b.max(p.1)));
                let g = t.g_um.map_or(String::new(), |g| format!(", G {g:.2} µm"));
                [
                    (t.label.clone(), series_color(i)),
                    (format!("  F {hi:+.2} / {lo:+.2} µm{g}"), series_color(i)),
                ]
            }))
            .collect()
    }
}

impl Figure for PolarPlot {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> PlotResult {
        let root = root.titled(&self.title, (FONT, 26)).map_err(err)?;
        let (w, h) = root.dim_in_pixel();
        let (plot, legend) = root.split_horizontally(w.min(h + 60));
        let max_um = self
            .traces
            .iter()
            .flat_map(|t| t.points.iter().map(|p| p.1.abs()))
            .fold(0.0, f64::max);
        let step = ring_step(max_um);
        let rings = (max_um / step).ceil().max(1.0);
        let scale = SPAN / (rings * step); // plot units per µm
        let lim = NOMINAL + SPAN + 0.12;
        let mut chart = ChartBuilder::on(&plot)
            .margin(20)
            .build_cartesian_2d(-lim..lim, -lim..lim)
            .map_err(err)?;
        draw_rings(&mut chart, rings as i64, step * scale, step)?;
        draw_spokes(&mut chart)?;
        // Wider lines first: a thin measured trace drawn under a model's wider line that
        // follows it vanished, legend and all.
        let mut order: Vec<usize> = (0..self.traces.len()).collect();
        order.sort_by_key(|&i| std::cmp::Reverse(self.traces[i].width));
        for i in order {
            let t = &self.traces[i];
            let pts = t.points.iter().map(|&(a, dev)| {
                let r = NOMINAL + dev * scale;
                (r * a.cos(), r * a.sin())
            });
            chart
                .draw_series(LineSeries::new(pts, series_color(i).stroke_width(t.width)))
                .map_err(err)?;
        }
        let mut y = 40;
        let lines = self.legend_lines(step);
        for (text, color) in lines {
            legend
                .draw(&Text::new(
                    text,
                    (10, y),
                    (FONT, 17).into_font().color(&color),
                ))
                .map_err(err)?;
            y += 28;
        }
        Ok(())
    }
}
