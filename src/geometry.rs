//! What lies between the axes' scales and the tool: the axes' squareness. The servo loops
//! close on the scales (or the motors) and never see it, so it is added to the simulated
//! positions afterwards, as the tool — and a laser, a ballbar or the part — sees them.
//!
//! `[x.errors] squareness_urad = α` makes X read α·y more (the Y axis leans towards +X);
//! the same key on Y makes Y read α·x more.

use crate::machine::{AxisName, MachineConfig};

/// The squareness term of `axis` (rad): how much of the other axis's position it reads.
pub fn squareness_rad(machine: &MachineConfig, axis: AxisName) -> f64 {
    machine.axis(axis).errors.squareness_urad * 1e-6
}

/// Adds `alpha_rad` times `other` to `own`, sample by sample (the two on one time grid).
pub fn add_squareness(alpha_rad: f64, own: &mut [f64], other: &[f64]) {
    if alpha_rad == 0.0 {
        return;
    }
    for (p, q) in own.iter_mut().zip(other) {
        *p += alpha_rad * q;
    }
}

/// Both axes' positions at the tool from their positions at the scales.
pub fn to_tool(machine: &MachineConfig, x: &mut [f64], y: &mut [f64]) {
    let (ax, ay) = (
        squareness_rad(machine, AxisName::X),
        squareness_rad(machine, AxisName::Y),
    );
    if ay != 0.0 {
        // Y's term uses X at the scale: apply it before X changes.
        add_squareness(ay, y, x);
    }
    if ax != 0.0 {
        let y_scale: Vec<f64> = if ay != 0.0 {
            y.iter().zip(x.iter()).map(|(v, u)| v - ay * u).collect()
        } else {
            y.to_vec()
        };
        add_squareness(ax, x, &y_scale);
    }
}
