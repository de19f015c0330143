//! The toolpath seen along one axis (in XY, or from the front or the side for a path in
//! 3-D), coloured by the contour error, with a colour bar and the hotspots marked by rank
//! and G-code line. Equal scales on both axes of the view.

use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

use super::along_path::draw_labelled_rings;
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
        let rings: Vec<((f64, f64), &str)> = self
            .markers
            .iter()
            .map(|m| ((m.x_mm, m.y_mm), m.label.as_str()))
            .collect();
        draw_labelled_rings(&mut chart, &rings, 7, LABEL_FONT_PX)?;
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

/// Font size of the hotspots' labels (px).
const LABEL_FONT_PX: u32 = 15;
