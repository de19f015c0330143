//! What lies between the axes' scales and the tool: the axes' squareness, the
//! straightness of each axis's travel as the other axis sees it, and a position map of
//! each axis (learned from a measurement, or a compensation table's values). The servo loops close on
//! the scales (or the motors) and never see these, so they are added to the simulated
//! positions afterwards, as the tool — and a laser, a ballbar or the part — sees them.
//!
//! On X (and alike on Y with the axes swapped):
//! - `[x.errors] squareness_urad = α`: X reads α·y more (the Y axis leans towards +X);
//! - `[x.errors] straightness_bow_um = b` over `straightness_span_mm = L`: the Y axis's
//!   travel is bowed along X, X reading −b·(2y/L)² more — its middle (y = 0) stands b
//!   towards +X from the line through the ends of the span (y = ±L/2);
//! - `[x.errors] position_map_mm` / `position_map_um`: X reads m(x) more, linear between
//!   the points and held beyond them.

use crate::machine::{AxisName, MachineConfig};

/// The terms one axis reads beyond its scale: of the other axis's position, and of its own.
#[derive(Debug, Clone, PartialEq)]
pub struct CrossTerms {
    /// Squareness (rad).
    pub squareness_rad: f64,
    /// Bow of the other axis's travel (m).
    pub bow_m: f64,
    /// Half the span the bow is given over (m).
    pub half_span_m: f64,
    /// The position map: (position m, error m), positions increasing.
    pub map: Vec<(f64, f64)>,
}

impl CrossTerms {
    /// The terms of `axis` in `machine`.
    pub fn of(machine: &MachineConfig, axis: AxisName) -> CrossTerms {
        let e = &machine.axis(axis).errors;
        CrossTerms {
            squareness_rad: e.squareness_urad * 1e-6,
            bow_m: e.straightness_bow_um * 1e-6,
            half_span_m: 0.5e-3 * e.straightness_span_mm,
            map: e
                .position_map_mm
                .iter()
                .zip(&e.position_map_um)
                .map(|(&p, &v)| (p * 1e-3, v * 1e-6))
                .collect(),
        }
    }

    /// Whether there are none.
    pub fn is_zero(&self) -> bool {
        self.squareness_rad == 0.0 && self.bow_m == 0.0 && self.map.is_empty()
    }

    /// What the axis reads more at `p` with the other axis at `q` (m).
    pub fn at(&self, p: f64, q: f64) -> f64 {
        let u = q / self.half_span_m;
        self.squareness_rad * q - self.bow_m * u * u + self.map_at(p)
    }

    /// The position map at `p` (m).
    pub fn map_at(&self, p: f64) -> f64 {
        let m = &self.map;
        match m.partition_point(|&(at, _)| at <= p) {
            _ if m.is_empty() => 0.0,
            0 => m[0].1,
            i if i == m.len() => m[i - 1].1,
            i => {
                let ((p0, e0), (p1, e1)) = (m[i - 1], m[i]);
                e0 + (e1 - e0) * (p - p0) / (p1 - p0)
            }
        }
    }

    /// Adds the terms to `own`, sample by sample, from `other` (on one time grid).
    pub fn add(&self, own: &mut [f64], other: &[f64]) {
        if self.is_zero() {
            return;
        }
        for (p, &q) in own.iter_mut().zip(other) {
            *p += self.at(*p, q);
        }
    }
}

/// Both axes' positions at the tool from their positions at the scales.
pub fn to_tool(machine: &MachineConfig, x: &mut [f64], y: &mut [f64]) {
    let (tx, ty) = (
        CrossTerms::of(machine, AxisName::X),
        CrossTerms::of(machine, AxisName::Y),
    );
    if tx.is_zero() && ty.is_zero() {
        return;
    }
    let x_scale = x.to_vec();
    tx.add(x, y);
    ty.add(y, &x_scale);
}
