//! What lies between the axes' scales and the tool: the axes' squareness, the
//! straightness of each axis's travel as the other axis sees it, a position map of each
//! axis (learned from a measurement, or a compensation table's values), and the play that
//! lets the tool shift with the direction an axis last travelled. The servo loops close on
//! the scales (or the motors) and never see these, so they are added to the simulated
//! positions afterwards, as the tool — and a laser, a ballbar or the part — sees them.
//!
//! On X (and alike on Y with the axes swapped):
//! - `[x.errors] squareness_urad = α`: X reads α·y more (the Y axis leans towards +X);
//! - `[x.errors] straightness_bow_um = b` over `straightness_span_mm = L`: the Y axis's
//!   travel is bowed along X, X reading −b·(2y/L)² more — its middle (y = 0) stands b
//!   towards +X from the line through the ends of the span (y = ±L/2);
//! - `[x.errors] position_map_mm` / `position_map_um`: X reads m(x) more, linear between
//!   the points and held beyond them;
//! - `[x.errors] lateral_play_um = p`: X reads +p/2 while Y last travelled towards +Y and
//!   −p/2 while it last travelled towards −Y — a carriage shifting across its guides when
//!   the other axis's drive force turns round, a step at each of its reversals;
//! - `[x.errors] direction_offset_um = d`: X reads +d/2 while X itself last travelled
//!   towards +X, −d/2 towards −X — lost motion beyond the scale (a tool holder tilting in
//!   its play), which the loop cannot take out.
//!
//! An axis's direction turns once it has come back [`REVERSAL_M`] from its furthest point,
//! so that a standing axis's nanometre creep turns nothing; before it first moves that far
//! the play sits in its middle.

use crate::machine::{AxisName, MachineConfig};
use crate::numeric::lookup::Lookup;

/// How far an axis comes back from its furthest point before its direction counts as
/// turned (m).
pub const REVERSAL_M: f64 = 1e-6;

/// The terms one axis reads beyond its scale: of the other axis's position and direction,
/// and of its own.
#[derive(Debug, Clone, PartialEq)]
pub struct CrossTerms {
    /// Squareness (rad).
    pub squareness_rad: f64,
    /// Bow of the other axis's travel (m).
    pub bow_m: f64,
    /// Half the span the bow is given over (m).
    pub half_span_m: f64,
    /// The position map: error (m) by position (m).
    pub map: Lookup,
    /// Play across the other axis's reversals (m).
    pub lateral_play_m: f64,
    /// Offset between the axis's own two directions (m).
    pub direction_offset_m: f64,
}

impl CrossTerms {
    /// The terms of `axis` in `machine`.
    pub(crate) fn of(machine: &MachineConfig, axis: AxisName) -> CrossTerms {
        let e = &machine.axis(axis).errors;
        CrossTerms {
            squareness_rad: e.squareness_urad * 1e-6,
            bow_m: e.straightness_bow_um * 1e-6,
            half_span_m: 0.5e-3 * e.straightness_span_mm,
            map: Lookup::scaled(&e.position_map_mm, &e.position_map_um, 1e-3, 1e-6),
            lateral_play_m: e.lateral_play_um * 1e-6,
            direction_offset_m: e.direction_offset_um * 1e-6,
        }
    }

    /// Whether there are none.
    pub(crate) fn is_zero(&self) -> bool {
        self.squareness_rad == 0.0
            && self.bow_m == 0.0
            && self.map.is_empty()
            && self.lateral_play_m == 0.0
            && self.direction_offset_m == 0.0
    }

    /// What the axis reads more at `p` with the other axis at `q`, the axis's own last
    /// direction `own_dir` and the other's `other_dir` (±1, or 0 before either moved) (m).
    pub(crate) fn at(&self, p: f64, q: f64, own_dir: f64, other_dir: f64) -> f64 {
        let u = q / self.half_span_m;
        self.squareness_rad * q - self.bow_m * u * u
            + self.map.at(p)
            + 0.5 * (self.lateral_play_m * other_dir + self.direction_offset_m * own_dir)
    }

    /// The position map at `p` (m).
    pub(crate) fn map_at(&self, p: f64) -> f64 {
        self.map.at(p)
    }

    /// Adds the terms to `own`, sample by sample in time order, from `other` (on one time
    /// grid, both at the scales).
    pub(crate) fn add(&self, own: &mut [f64], other: &[f64]) {
        if self.is_zero() {
            return;
        }
        let mut travel = [Travel::default(), Travel::default()];
        for (p, &q) in own.iter_mut().zip(other) {
            let dirs = [travel[0].direction(*p), travel[1].direction(q)];
            *p += self.at(*p, q, dirs[0], dirs[1]);
        }
    }
}

/// The direction an axis last travelled, from its positions in time order.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Travel {
    /// Where it started, then its furthest point in the present direction (m).
    extreme: Option<f64>,
    /// +1, −1, or 0 before it first moved.
    dir: f64,
}

impl Travel {
    /// Takes the next position (m); returns the direction the axis last travelled.
    pub(crate) fn direction(&mut self, p: f64) -> f64 {
        let extreme = *self.extreme.get_or_insert(p);
        let beyond = (p - extreme) * self.dir;
        if beyond > 0.0 {
            self.extreme = Some(p);
        } else if (p - extreme).abs() > REVERSAL_M && (self.dir == 0.0 || beyond < 0.0) {
            self.dir = (p - extreme).signum();
            self.extreme = Some(p);
        }
        self.dir
    }
}

/// Reads both axes at the tool, sample by sample in time order (keeping each axis's
/// direction between calls).
#[derive(Debug, Clone)]
pub struct ToolReader {
    terms: [CrossTerms; 2],
    travel: [Travel; 2],
}

impl ToolReader {
    /// A reader for `machine`'s axes, both not yet moved.
    pub(crate) fn new(machine: &MachineConfig) -> ToolReader {
        ToolReader {
            terms: AxisName::BOTH.map(|a| CrossTerms::of(machine, a)),
            travel: Default::default(),
        }
    }

    /// Whether the tool reads just what the scales do.
    pub(crate) fn is_zero(&self) -> bool {
        self.terms.iter().all(CrossTerms::is_zero)
    }

    /// Both axes at the tool from both at the scales (m), the next sample in time.
    pub(crate) fn read(&mut self, scale: [f64; 2]) -> [f64; 2] {
        let dirs = [
            self.travel[0].direction(scale[0]),
            self.travel[1].direction(scale[1]),
        ];
        let [tx, ty] = &self.terms;
        [
            scale[0] + tx.at(scale[0], scale[1], dirs[0], dirs[1]),
            scale[1] + ty.at(scale[1], scale[0], dirs[1], dirs[0]),
        ]
    }
}

/// Both axes' positions at the tool from their positions at the scales.
pub(crate) fn to_tool(machine: &MachineConfig, x: &mut [f64], y: &mut [f64]) {
    let mut reader = ToolReader::new(machine);
    if reader.is_zero() {
        return;
    }
    for (px, py) in x.iter_mut().zip(y.iter_mut()) {
        [*px, *py] = reader.read([*px, *py]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn direction_turns_only_past_the_threshold() {
        let mut t = Travel::default();
        let dirs: Vec<f64> = [0.0, 0.5e-6, 2e-6, 5e-6, 4.5e-6, 3.9e-6, 3.0e-6, 10e-6]
            .into_iter()
            .map(|p| t.direction(p))
            .collect();
        assert_eq!(dirs, [0.0, 0.0, 1.0, 1.0, 1.0, -1.0, -1.0, 1.0]);
    }

    #[test]
    fn lateral_play_steps_at_the_other_axis_reversals() {
        let mut m = MachineConfig::default_preset();
        m.x.errors.lateral_play_um = 8.0;
        let mut x = vec![0.0; 5];
        let mut y = vec![0.0, 1e-3, 2e-3, 1e-3, 0.0];
        to_tool(&m, &mut x, &mut y);
        let um: Vec<f64> = x.iter().map(|v| (v * 1e6).round()).collect();
        assert_eq!(um, [0.0, 4.0, 4.0, -4.0, -4.0]);
    }
}
