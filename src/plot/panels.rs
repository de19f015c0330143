//! Stacked panels of curves over an abscissa of the same kind (time or path length), each
//! with its own range, ordinate and legend (beside it, never over its data): measured
//! against modelled traces, residuals before and after.

use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

use super::labels::{along_polyline, legend_size};
use super::legend::{LEGEND_FONT_PX, LegendEntry, draw_legend, draw_legend_in};
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
        // Every panel keeps the same room for its legend, so that their abscissas line up;
        // none where a legend would not fit beside its chart (a long one in a short panel, or
        // one wider than a third of the figure): those legends go inside, where they cover
        // fewest of the curves.
        let sizes: Vec<(i32, i32)> = self
            .panels
            .iter()
            .map(|p| legend_size_of(&legend_entries(&p.curves)))
            .collect();
        let fits = areas.first().is_none_or(|a| {
            let (w, h) = a.dim_in_pixel();
            sizes.iter().all(|&(lw, lh)| {
                3 * (lw + 2 * LEGEND_GAP_PX) <= w as i32 && lh + PANEL_FRAME_PX <= h as i32
            })
        });
        let legend_w = if fits {
            sizes.iter().map(|s| s.0).max().unwrap_or(0)
        } else {
            0
        };
        for (panel, area) in self.panels.iter().zip(areas.iter()) {
            // Each panel spans its own curves (one may be a close-up).
            let (x0, x1) = panel
                .curves
                .iter()
                .flat_map(|c| c.points.iter())
                .fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.0), b.max(p.0)));
            let range = if x0 < x1 { (x0, x1) } else { (0.0, 1.0) };
            draw_panel(panel, area, range, &self.x_label, legend_w)?;
        }
        Ok(())
    }
}

/// The gap (px) between a panel's chart and the legend beside it.
const LEGEND_GAP_PX: i32 = 10;
/// A panel's height (px) not in its chart's plotting area: caption, margins, abscissa labels.
const PANEL_FRAME_PX: i32 = 90;

/// The size (px) of the legend of `entries`.
fn legend_size_of(entries: &[LegendEntry]) -> (i32, i32) {
    if entries.is_empty() {
        return (0, 0);
    }
    let texts: Vec<String> = entries.iter().map(|e| e.text.clone()).collect();
    legend_size(&texts, LEGEND_FONT_PX)
}

/// One panel, its legend beside the chart on the right (`legend_w` px kept for it): a
/// residual or a trace fills its panel from end to end and edge to edge, leaving no corner
/// a legend could take without hiding data.
fn draw_panel<DB: DrawingBackend>(
    panel: &Panel,
    area: &DrawingArea<DB, Shift>,
    (x0, x1): (f64, f64),
    x_label: &str,
    legend_w: i32,
) -> PlotResult {
    let ys = panel
        .curves
        .iter()
        .flat_map(|c| c.points.iter().map(|p| p.1))
        .filter(|y| y.is_finite());
    let (lo, hi) = ys.fold((f64::MAX, f64::MIN), |(a, b), y| (a.min(y), b.max(y)));
    let (lo, hi) = if lo <= hi { (lo, hi) } else { (-1.0, 1.0) };
    let pad = 0.08 * (hi - lo).max(1e-3);
    let room = if legend_w > 0 {
        legend_w + 2 * LEGEND_GAP_PX
    } else {
        10
    };
    let mut chart = ChartBuilder::on(area)
        .caption(&panel.caption, (FONT, 18))
        .margin(10)
        .margin_right(room)
        .x_label_area_size(40)
        .y_label_area_size(75)
        .build_cartesian_2d(x0..x1, (lo - pad)..(hi + pad))
        .map_err(err)?;
    // A label every 20 px at most: plotters' ten labels ran together in a short panel
    // (fewer than five can leave a symmetric range with 0 alone).
    let (_, plot_h) = chart.plotting_area().dim_in_pixel();
    let y_labels = (plot_h as usize / 20).clamp(5, 10);
    chart
        .configure_mesh()
        .y_labels(y_labels)
        .x_desc(x_label)
        .y_desc(panel.y_label.as_str())
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 15))
        .draw()
        .map_err(err)?;
    if legend_w == 0 {
        return draw_curves(&mut chart, &panel.curves);
    }
    draw_lines(&mut chart, &panel.curves)?;
    let entries = legend_entries(&panel.curves);
    if entries.is_empty() {
        return Ok(());
    }
    let (w, h) = legend_size_of(&entries);
    let (xs, ys) = chart.plotting_area().get_pixel_range();
    let left = xs.end + LEGEND_GAP_PX;
    draw_legend_in(area, &entries, (left, ys.start, left + w, ys.start + h))
}

/// A curve's colour and line width: its series colour, or light grey for a reference.
fn style_of(curve: &Curve) -> (RGBColor, u32) {
    match curve.color {
        Some(i) => (series_color(i), curve.width),
        None => (RGBColor(150, 150, 150), curve.width),
    }
}

/// A curve's pieces of two points or more, broken where its ordinate is NaN.
fn pieces(curve: &Curve) -> Vec<Vec<(f64, f64)>> {
    curve
        .points
        .split(|p| !p.1.is_finite())
        .filter(|r| r.len() > 1)
        .map(|r| r.to_vec())
        .collect()
}

/// One legend entry per curve, however many pieces it is drawn in; none for a curve without
/// a name (a second curve of an entry already made) or without a piece to draw.
fn legend_entries(curves: &[Curve]) -> Vec<LegendEntry> {
    curves
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
        .collect()
}

/// Draws the legend (where it covers fewest of the curves) and `curves` on `chart`, each
/// broken where its ordinate is NaN.
pub(super) fn draw_curves<'a, DB: DrawingBackend + 'a>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    curves: &[Curve],
) -> PlotResult {
    let mut drawn_px = Vec::new();
    for curve in curves {
        for piece in pieces(curve) {
            let px: Vec<(i32, i32)> = piece.iter().map(|p| chart.backend_coord(p)).collect();
            drawn_px.extend(along_polyline(&px));
        }
    }
    draw_legend(chart.plotting_area(), &legend_entries(curves), &drawn_px)?;
    draw_lines(chart, curves)
}

/// Draws `curves` on `chart`, each broken where its ordinate is NaN.
fn draw_lines<'a, DB: DrawingBackend + 'a>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    curves: &[Curve],
) -> PlotResult {
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The value of attribute `name` in one SVG element's text.
    fn attr(element: &str, name: &str) -> Option<String> {
        let at = element.find(&format!(" {name}=\""))? + name.len() + 3;
        Some(element[at..].split('"').next()?.to_string())
    }

    /// Residuals that fill their panels — noise about zero from end to end, as a model's
    /// residual over a whole record is — leave no corner free: every legend (the translucent
    /// box, 0.85 opaque) lies beside its chart, with no point of any curve inside it.
    #[test]
    fn a_legend_beside_panels_that_fill_their_charts_hides_no_data() {
        let noise = |seed: u64| -> Vec<(f64, f64)> {
            (0..4000)
                .map(|k| {
                    let v = ((k as u64 * 2_654_435_761 + seed) % 1000) as f64 / 500.0 - 1.0;
                    (k as f64 * 1e-3, v)
                })
                .collect()
        };
        let panel = |caption: &str| Panel {
            caption: caption.into(),
            y_label: "residual (µm)".into(),
            curves: vec![
                Curve {
                    name: "nominal model".into(),
                    points: noise(7),
                    color: None,
                    width: 1,
                },
                Curve {
                    name: "extended model".into(),
                    points: noise(11).into_iter().map(|(t, v)| (t, 0.5 * v)).collect(),
                    color: Some(0),
                    width: 1,
                },
            ],
        };
        let plot = PanelsPlot {
            title: "residual over time".into(),
            x_label: "program time (s)".into(),
            panels: vec![panel("X"), panel("Y"), panel("contour")],
        };
        let svg = crate::plot::svg_text(&plot).unwrap();
        let legends = legend_boxes(&svg);
        assert_eq!(legends.len(), 3, "one legend a panel");
        let points: Vec<(f64, f64)> = svg
            .split('<')
            .filter(|e| e.starts_with("polyline"))
            .filter_map(|e| attr(e, "points"))
            .filter(|p| p.split_whitespace().count() > 2)
            .flat_map(|p| {
                p.split_whitespace()
                    .map(|xy| {
                        let (x, y) = xy.split_once(',').unwrap();
                        (x.parse().unwrap(), y.parse().unwrap())
                    })
                    .collect::<Vec<_>>()
            })
            .collect();
        assert!(points.len() > 1000, "{}", points.len());
        for [x, y, w, h] in legends {
            let inside = points
                .iter()
                .filter(|&&(px, py)| px >= x && px <= x + w && py >= y && py <= y + h)
                .count();
            assert_eq!(inside, 0, "legend at ({x}, {y}) covers {inside} points");
        }
    }

    /// The legends' boxes (the translucent rectangles, 0.85 opaque) of an SVG figure: x, y,
    /// width, height in px, top to bottom as drawn.
    fn legend_boxes(svg: &str) -> Vec<[f64; 4]> {
        svg.split('<')
            .filter(|e| e.starts_with("rect") && attr(e, "opacity").as_deref() == Some("0.85"))
            .map(|e| ["x", "y", "width", "height"].map(|n| attr(e, n).unwrap().parse().unwrap()))
            .collect()
    }

    /// Six short panels of twelve named curves each: a legend of twelve rows (14 px text,
    /// some 22 px a row) is taller than a sixth of the figure, and beside its chart it would
    /// run into the panels below. Each is drawn inside its own panel instead.
    #[test]
    fn a_legend_taller_than_its_panel_stays_within_the_panel() {
        let curve = |i: usize| Curve {
            name: format!("setting {i}"),
            points: (0..50).map(|k| (k as f64, (k * i) as f64)).collect(),
            color: Some(i),
            width: 1,
        };
        let panel = |caption: &str| Panel {
            caption: caption.into(),
            y_label: "µm".into(),
            curves: (0..12).map(curve).collect(),
        };
        let plot = PanelsPlot {
            title: "many settings".into(),
            x_label: "s".into(),
            panels: ["a", "b", "c", "d", "e", "f"]
                .into_iter()
                .map(panel)
                .collect(),
        };
        let legends = legend_boxes(&crate::plot::svg_text(&plot).unwrap());
        assert_eq!(legends.len(), 6, "one legend a panel");
        let (width, height) = (crate::plot::SIZE.0 as f64, crate::plot::SIZE.1 as f64);
        // Panel k spans at most [k·H/6, (k+1)·H/6 + the title's height] (the title, under
        // 60 px, is taken off the top before the panels share the rest).
        for (k, [x, y, w, h]) in legends.into_iter().enumerate() {
            let band = height / 6.0;
            assert!(x >= 0.0 && x + w <= width, "legend {k} at x {x}, {w} wide");
            assert!(
                y >= k as f64 * band && y + h <= (k + 1) as f64 * band + 60.0,
                "legend {k} spans {y}..{} px, its panel {}..{} px",
                y + h,
                k as f64 * band,
                (k + 1) as f64 * band + 60.0
            );
        }
    }
}
