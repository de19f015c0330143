//! The toolpath seen along one axis (in XY, or from the front or the side for a path in
//! 3-D), coloured by the contour error, with a colour bar and the hotspots marked by rank
//! and G-code line. Equal scales on both axes of the view.

use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

use super::{FONT, Figure, PlotResult, err};

/// A sample of the actual path, in the view's coordinates.
#[derive(Debug, Clone, Copy)]
pub struct PathPoint {
    /// Actual position along the view's horizontal axis (X in the XY view) (mm).
    pub x_mm: f64,
    /// Actual position along its vertical axis (mm).
    pub y_mm: f64,
    /// |contour error| (µm); NaN while not cutting.
    pub error_um: f64,
}

/// A marked place, in the view's coordinates.
#[derive(Debug, Clone)]
pub struct Marker {
    /// Along the view's horizontal axis (mm).
    pub x_mm: f64,
    /// Along its vertical axis (mm).
    pub y_mm: f64,
    /// Label, e.g. "1: L13".
    pub label: String,
}

/// The figure.
pub struct ToolpathPlot {
    /// Title.
    pub title: String,
    /// The programmed path as polylines (mm), rapids excluded.
    pub programmed: Vec<Vec<(f64, f64)>>,
    /// The actual path.
    pub actual: Vec<PathPoint>,
    /// Hotspots.
    pub markers: Vec<Marker>,
    /// The view's axes, horizontal and vertical (`["X", "Y"]` seen from above).
    pub axes: [&'static str; 2],
}

/// A perceptually ordered colour map (viridis, five anchors) for t in [0, 1].
pub(crate) fn colormap(t: f64) -> RGBColor {
    const ANCHORS: [(f64, f64, f64); 5] = [
        (68.0, 1.0, 84.0),
        (59.0, 82.0, 139.0),
        (33.0, 145.0, 140.0),
        (94.0, 201.0, 98.0),
        (253.0, 231.0, 37.0),
    ];
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let x = t * (ANCHORS.len() - 1) as f64;
    let i = (x.floor() as usize).min(ANCHORS.len() - 2);
    let f = x - i as f64;
    let (a, b) = (ANCHORS[i], ANCHORS[i + 1]);
    let mix = |p: f64, q: f64| (p + (q - p) * f).round() as u8;
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

impl Figure for ToolpathPlot {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> PlotResult {
        let root = root.titled(&self.title, (FONT, 26)).map_err(err)?;
        let (w, _) = root.dim_in_pixel();
        let (main, bar) = root.split_horizontally(w - 150);
        let e_max = self
            .actual
            .iter()
            .map(|p| p.error_um)
            .filter(|e| e.is_finite())
            .fold(0.0, f64::max)
            .max(1e-3);
        let points = self.programmed.iter().flatten().copied().chain(
            self.actual
                .iter()
                .filter(|q| q.error_um.is_finite())
                .map(|q| (q.x_mm, q.y_mm)),
        );
        let mut chart = xy_chart(&main, points, None)?;
        chart
            .configure_mesh()
            .x_desc(format!("{} (mm)", self.axes[0]))
            .y_desc(format!("{} (mm)", self.axes[1]))
            .label_style((FONT, 15))
            .axis_desc_style((FONT, 17))
            .light_line_style(WHITE.mix(0.0))
            .draw()
            .map_err(err)?;
        for poly in &self.programmed {
            chart
                .draw_series(LineSeries::new(
                    poly.iter().copied(),
                    BLACK.mix(0.25).stroke_width(1),
                ))
                .map_err(err)?;
        }
        let segments = self
            .actual
            .windows(2)
            .filter(|w| w[1].error_um.is_finite())
            .map(|w| {
                let color = colormap(w[1].error_um / e_max);
                PathElement::new(
                    vec![(w[0].x_mm, w[0].y_mm), (w[1].x_mm, w[1].y_mm)],
                    color.stroke_width(3),
                )
            });
        chart.draw_series(segments).map_err(err)?;
        let at_px: Vec<(i32, i32)> = self
            .markers
            .iter()
            .map(|m| chart.backend_coord(&(m.x_mm, m.y_mm)))
            .collect();
        let labels: Vec<String> = self.markers.iter().map(|m| m.label.clone()).collect();
        let placed = place_labels(&at_px, &labels);
        for (m, offset) in self.markers.iter().zip(&placed) {
            chart
                .draw_series(std::iter::once(Circle::new(
                    (m.x_mm, m.y_mm),
                    7,
                    RED.stroke_width(2),
                )))
                .map_err(err)?;
            if let Some((dx, dy)) = *offset {
                chart
                    .draw_series(std::iter::once(
                        EmptyElement::at((m.x_mm, m.y_mm))
                            + Text::new(
                                m.label.clone(),
                                (dx, dy),
                                (FONT, LABEL_FONT_PX).into_font().color(&RED),
                            ),
                    ))
                    .map_err(err)?;
            }
        }
        draw_colorbar(&bar, e_max, "|contour error| (µm)")
    }
}

/// A chart in XY (mm) on `area`, equal scale on both axes, covering `points`, with
/// `caption` above it if given.
pub(crate) fn xy_chart<'a, DB: DrawingBackend + 'a>(
    area: &'a DrawingArea<DB, Shift>,
    points: impl Iterator<Item = (f64, f64)>,
    caption: Option<&str>,
) -> Result<ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>, String> {
    let (x0, x1, y0, y1) = equal_aspect_bounds(points, area);
    let mut builder = ChartBuilder::on(area);
    if let Some(text) = caption {
        builder.caption(text, (FONT, 18));
    }
    builder
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(err)
}

/// Axis ranges with equal mm per pixel on X and Y, covering `points` with a margin, for a
/// chart on `area` with the label areas the plots here give it.
fn equal_aspect_bounds<DB: DrawingBackend>(
    points: impl Iterator<Item = (f64, f64)>,
    area: &DrawingArea<DB, Shift>,
) -> (f64, f64, f64, f64) {
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for (x, y) in points.filter(|(x, y)| x.is_finite() && y.is_finite()) {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    if x0 > x1 {
        return (-1.0, 1.0, -1.0, 1.0);
    }
    let (w_px, h_px) = area.dim_in_pixel();
    let (w_px, h_px) = (
        (w_px as f64 - 115.0).max(1.0),
        (h_px as f64 - 75.0).max(1.0),
    );
    let span = ((x1 - x0) / w_px).max((y1 - y0) / h_px).max(1e-6) * 1.08;
    let (cx, cy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
    (
        cx - span * w_px / 2.0,
        cx + span * w_px / 2.0,
        cy - span * h_px / 2.0,
        cy + span * h_px / 2.0,
    )
}

/// A vertical colour bar from 0 to `max`.
pub(crate) fn draw_colorbar<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    max: f64,
    label: &str,
) -> PlotResult {
    let mut chart = ChartBuilder::on(area)
        .margin_top(40)
        .margin_bottom(60)
        .margin_right(10)
        .y_label_area_size(75)
        .build_cartesian_2d(0.0..1.0, 0.0..max)
        .map_err(err)?;
    chart
        .configure_mesh()
        .disable_x_mesh()
        .disable_x_axis()
        .y_desc(label)
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 15))
        .draw()
        .map_err(err)?;
    let steps = 100;
    chart
        .draw_series((0..steps).map(|i| {
            let (a, b) = (
                max * i as f64 / steps as f64,
                max * (i + 1) as f64 / steps as f64,
            );
            Rectangle::new(
                [(0.0, a), (1.0, b)],
                colormap((i as f64 + 0.5) / steps as f64).filled(),
            )
        }))
        .map_err(err)?;
    Ok(())
}

/// Label text height and a generous width per character (px), for placing labels apart.
const LABEL_FONT_PX: i32 = 15;
const LABEL_CHAR_PX: i32 = 9;

/// The box a label takes at a marker drawn at `at` with the label's top-left at `offset`.
fn label_box(at: (i32, i32), offset: (i32, i32), label: &str) -> (i32, i32, i32, i32) {
    let w = LABEL_CHAR_PX * label.chars().count() as i32;
    let (x, y) = (at.0 + offset.0, at.1 + offset.1);
    (x, y, x + w, y + LABEL_FONT_PX + 2)
}

fn overlap(a: (i32, i32, i32, i32), b: (i32, i32, i32, i32)) -> bool {
    a.0 < b.2 && b.0 < a.2 && a.1 < b.3 && b.1 < a.3
}

/// Where each marker's label goes (its top-left offset from the marker, px), in rank order:
/// the first of a few places around the marker that overlaps no label already placed and no
/// marker; `None` where every place is taken — that label is left out (thinned), its marker
/// stays.
pub(crate) fn place_labels(at_px: &[(i32, i32)], labels: &[String]) -> Vec<Option<(i32, i32)>> {
    let marker_box = |p: (i32, i32)| (p.0 - 8, p.1 - 8, p.0 + 8, p.1 + 8);
    let mut taken: Vec<(i32, i32, i32, i32)> = Vec::new();
    at_px
        .iter()
        .zip(labels)
        .map(|(&at, label)| {
            let w = LABEL_CHAR_PX * label.chars().count() as i32;
            let h = LABEL_FONT_PX + 2;
            let candidates = [
                (10, -h - 4),
                (10, 6),
                (-w - 10, -h - 4),
                (-w - 10, 6),
                (10, -2 * h - 8),
                (-w - 10, h + 10),
                (-w / 2, -2 * h - 8),
                (-w / 2, h + 10),
            ];
            let free = candidates.into_iter().find(|&offset| {
                let b = label_box(at, offset, label);
                !taken.iter().any(|&t| overlap(b, t))
                    && !at_px.iter().any(|&p| overlap(b, marker_box(p)))
            });
            if let Some(offset) = free {
                taken.push(label_box(at, offset, label));
            }
            free
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_of_clustered_markers_never_overlap() {
        // Ten hotspots, eight of them within a few pixels of one another (a corner hit
        // twice, the steady lag all round a circle).
        let at: Vec<(i32, i32)> = (0..10)
            .map(|i| {
                if i < 8 {
                    (400 + 3 * i, 300 + 2 * i)
                } else {
                    (100 * i, 50)
                }
            })
            .collect();
        let labels: Vec<String> = (0..10)
            .map(|i| format!(" {}: L{}", i + 1, 13 + i))
            .collect();
        let placed = place_labels(&at, &labels);
        let boxes: Vec<_> = placed
            .iter()
            .zip(&at)
            .zip(&labels)
            .filter_map(|((o, &a), l)| o.map(|o| label_box(a, o, l)))
            .collect();
        for (i, a) in boxes.iter().enumerate() {
            for b in &boxes[i + 1..] {
                assert!(!overlap(*a, *b), "{a:?} overlaps {b:?}");
            }
        }
        // The first ranks are always labelled; the far ones too.
        assert!(placed[0].is_some() && placed[1].is_some());
        assert!(placed[8].is_some() && placed[9].is_some());
    }
}
