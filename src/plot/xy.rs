//! Curves in the XY plane at equal scale — a measured path over its commanded one — and a
//! page of two figures side by side.

use plotters::coord::Shift;
use plotters::prelude::*;

use super::panels::{Curve, draw_curves};
use super::toolpath::xy_chart;
use super::{FONT, Figure, PlotResult, err};

/// Paths in XY (mm), equal scale on both axes.
pub struct XyPlot {
    /// Caption above the chart.
    pub caption: String,
    /// Curves of (x mm, y mm), drawn in order (later on top).
    pub curves: Vec<Curve>,
}

impl Figure for XyPlot {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> PlotResult {
        let area = root.margin(40, 10, 10, 10);
        let points = self.curves.iter().flat_map(|c| c.points.iter().copied());
        let mut chart = xy_chart(&area, points, Some(&self.caption))?;
        chart
            .configure_mesh()
            .x_labels(5)
            .y_labels(9)
            .x_desc("X (mm)")
            .y_desc("Y (mm)")
            .label_style((FONT, 14))
            .axis_desc_style((FONT, 15))
            .draw()
            .map_err(err)?;
        draw_curves(&mut chart, &self.curves)
    }
}

/// Two figures on one page, the left taking `left_share` of the width.
pub struct Beside<A, B> {
    /// Left figure.
    pub left: A,
    /// Right figure.
    pub right: B,
    /// Share of the width for the left figure (0–1).
    pub left_share: f64,
}

impl<A: Figure, B: Figure> Figure for Beside<A, B> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> PlotResult {
        let (w, _) = root.dim_in_pixel();
        let split = (w as f64 * self.left_share.clamp(0.1, 0.9)).round() as u32;
        let (left, right) = root.split_horizontally(split);
        self.left.draw(&left)?;
        self.right.draw(&right)
    }
}
