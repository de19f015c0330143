//! Extending the model from the data where no catalogue cause explains the residual.
//!
//! When the residual left on an axis follows that axis's own position, in one place or
//! periodically ([`super::locate`]), it is what a compensation table corrects: the tool
//! standing off where the axis's scale says it is. That error is learned as a table — the
//! residual's mean in bins of the position, linear in between — and becomes the machine
//! keys `errors.position_map_mm` / `errors.position_map_um`, which `check`, `diagnose` and
//! `synth` add beyond the scales like the axes' squareness (see [`crate::geometry`]): the
//! loops do not see it, so it does not lag.
//!
//! How smooth the table is (how many bins) is chosen on held-out data: the bins are fitted
//! on alternate blocks of the record and scored on the others, and the count that predicts
//! best wins. Its gain is then measured like a cause's, by re-simulating: in sample, and on
//! each half of the record with the table fitted on the other half.
//!
//! The map adds to the reading at the tool or table just what it holds, so the residual's
//! binned mean is the map; behind a motor encoder it reads nothing, and nothing is learned.

use super::Context;
use super::locate::{Bins, Located, Variable, halves, held_out_share, positions_mm};
use crate::geometry::CrossTerms;
use crate::machine::{AxisName, MachineConfig};
use crate::units::{m_from_mm, um_from_m};

/// Bin counts the table's smoothness is chosen from.
const BIN_COUNTS: [usize; 6] = [8, 16, 32, 64, 128, 256];
/// Held-out share of the residual a table must predict to be learned.
const SMALLEST_SHARE: f64 = 0.5;

/// A position map learned on one axis.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Learned {
    /// The axis.
    pub axis: AxisName,
    /// Points in the table.
    pub points: usize,
    /// Where its error is largest (mm), as the residual's location gave it (for an error
    /// in one place).
    pub interval_mm: Option<(f64, f64)>,
    /// Its period (mm), for a periodic error.
    pub period_mm: Option<f64>,
    /// The largest error in the table (µm, signed as the residual).
    pub peak_um: f64,
    /// The axis's residual RMS before and after, over the whole record (µm).
    pub rms_before_um: f64,
    /// After.
    pub rms_after_um: f64,
    /// The same on each half of the record with the table fitted on the other half (µm).
    pub held_out_before_um: f64,
    /// After.
    pub held_out_after_um: f64,
}

/// The machine extended by a position map on the located axis, its traces, and what was
/// learned — when the residual follows that axis's own position and a table fitted on half
/// the record predicts the other half.
pub fn position_map(
    ctx: &Context,
    machine: &MachineConfig,
    traces: &[Vec<f64>; 2],
    offset_s: f64,
    located: &Located,
) -> Option<(MachineConfig, [Vec<f64>; 2], Learned)> {
    let axis = located.axis;
    // A residual that follows the axis's own position, in one place or periodically.
    let follows_own_position = matches!(
        located.variable,
        Some(Variable::Position(a)) if a == axis
    ) || located.variable == Some(Variable::Period);
    // The map lies beyond the scale, and beyond a motor encoder: there it reads nothing.
    if !follows_own_position
        || located.share < SMALLEST_SHARE
        || ctx.measured_at == crate::sim::MeasuredAt::Motor
    {
        return None;
    }
    let residual = ctx.residual(axis, &traces[axis.index()], offset_s);
    let z = positions_mm(ctx, &traces[axis.index()], offset_s);
    let fold = halves(ctx, offset_s);
    // Smoothness: the bin count that predicts the held-out blocks best.
    let count = BIN_COUNTS.into_iter().max_by(|&a, &b| {
        let share = |n: usize| {
            let bins = Bins::over(&z, n);
            held_out_share(&residual, &fold, |train| bins.fit(&z, &residual, train))
        };
        share(a).total_cmp(&share(b))
    })?;
    let bins = Bins::over(&z, count);
    let table = |use_sample: &dyn Fn(usize) -> bool| bins.fit(&z, &residual, use_sample).centres();
    let whole = table(&|_| true);
    let extended = with_map(machine, axis, &whole);
    let trace = ctx.simulate_axis(&extended, axis)?;
    let rms = |r: &[f64]| (r.iter().map(|v| v * v).sum::<f64>() / r.len().max(1) as f64).sqrt();
    let after = ctx.residual(axis, &trace, offset_s);
    // Held out: the table fitted on one half, re-simulated, scored on the other.
    let (mut before_ss, mut after_ss, mut n) = (0.0, 0.0, 0usize);
    for side in [true, false] {
        let half_table = table(&|i| fold[i] == side);
        let half_machine = with_map(machine, axis, &half_table);
        let half_trace = ctx.simulate_axis(&half_machine, axis)?;
        let half_after = ctx.residual(axis, &half_trace, offset_s);
        for i in (0..residual.len()).filter(|&i| fold[i] != side) {
            before_ss += residual[i] * residual[i];
            after_ss += half_after[i] * half_after[i];
            n += 1;
        }
    }
    let held_out_before = (before_ss / n.max(1) as f64).sqrt();
    let held_out_after = (after_ss / n.max(1) as f64).sqrt();
    if held_out_after >= held_out_before || rms(&after) >= rms(&residual) {
        return None;
    }
    let peak = whole
        .iter()
        .map(|p| p.1)
        .max_by(|a, b| a.abs().total_cmp(&b.abs()))
        .unwrap_or(0.0);
    let learned = Learned {
        axis,
        points: whole.len(),
        interval_mm: (located.variable != Some(Variable::Period))
            .then_some(located.interval)
            .flatten(),
        period_mm: (located.variable == Some(Variable::Period))
            .then(|| located.interval.map(|i| i.0))
            .flatten(),
        peak_um: um_from_m(peak),
        rms_before_um: um_from_m(rms(&residual)),
        rms_after_um: um_from_m(rms(&after)),
        held_out_before_um: um_from_m(held_out_before),
        held_out_after_um: um_from_m(held_out_after),
    };
    let mut traces = traces.clone();
    traces[axis.index()] = trace;
    Some((extended, traces, learned))
}

/// `machine` with the table `points` ((mm, m) of the residual) added to the position map of
/// `axis` (to a map it already has, taken at the new points).
fn with_map(machine: &MachineConfig, axis: AxisName, points: &[(f64, f64)]) -> MachineConfig {
    let mut m = machine.clone();
    let existing = CrossTerms::of(&m, axis);
    let errors = &mut m.axis_mut(axis).errors;
    errors.position_map_um = points
        .iter()
        .map(|&(p, e)| um_from_m(existing.map_at(m_from_mm(p)) + e))
        .collect();
    errors.position_map_mm = points.iter().map(|p| p.0).collect();
    m
}
