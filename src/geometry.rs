//! What lies between the axes' scales and the tool: the axes' squareness and the
//! straightness of each axis's travel as the other axis sees it. The servo loops close on
//! the scales (or the motors) and never see these, so they are added to the simulated
//! positions afterwards, as the tool — and a laser, a ballbar or the part — sees them.
//!
//! On X (and alike on Y with the axes swapped):
//! - `[x.errors] squareness_urad = α`: X reads α·y more (the Y axis leans towards +X);
//! - `[x.errors] straightness_bow_um = b` over `straightness_span_mm = L`: the Y axis's
//!   travel is bowed along X, X reading −b·(2y/L)² more — its middle (y = 0) stands b
//!   towards +X from the line through the ends of the span (y = ±L/2).

use crate::machine::{AxisName, MachineConfig};

/// The terms one axis reads of the other axis's position.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CrossTerms {
    /// Squareness (rad).
    pub squareness_rad: f64,
    /// Bow of the other axis's travel (m).
    pub bow_m: f64,
    /// Half the span the bow is given over (m).
    pub half_span_m: f64,
}

impl CrossTerms {
    /// The terms of `axis` in `machine`.
    pub fn of(machine: &MachineConfig, axis: AxisName) -> CrossTerms {
        let e = &machine.axis(axis).errors;
        CrossTerms {
            squareness_rad: e.squareness_urad * 1e-6,
            bow_m: e.straightness_bow_um * 1e-6,
            half_span_m: 0.5e-3 * e.straightness_span_mm,
        }
    }

    /// Whether there are none.
    pub fn is_zero(&self) -> bool {
        self.squareness_rad == 0.0 && self.bow_m == 0.0
    }

    /// What the axis reads more with the other axis at `q` (m).
    pub fn at(&self, q: f64) -> f64 {
        let u = q / self.half_span_m;
        self.squareness_rad * q - self.bow_m * u * u
    }

    /// Adds the terms to `own`, sample by sample, from `other` (on one time grid).
    pub fn add(&self, own: &mut [f64], other: &[f64]) {
        if self.is_zero() {
            return;
        }
        for (p, &q) in own.iter_mut().zip(other) {
            *p += self.at(q);
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
