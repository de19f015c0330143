//! The force an axis holds at rest at a record's start (docs/model.md §1.10), estimated with
//! the machine's values fixed: a state of the record, not of the machine.
//!
//! An axis that came to rest against friction before the record began holds whatever force
//! its integral action stopped at, anywhere within the friction's level at rest, and the
//! record does not show its history. With the machine given, the force is one number: it is
//! found by a bounded search on the residual's sum of squares over the samples asked for (a
//! golden-section search; the residual's dependence on it is smooth and has one valley
//! within the bound), its standard uncertainty from the residual's slope in it (the
//! Gauss–Newton one of a one-value fit), widened for a residual whose samples are not
//! independent: what the model misses of a machine runs on over many samples, and the
//! samples count as n·(1 − ρ)/(1 + ρ) independent ones (ρ the residual's correlation from
//! one sample to the next, as for a first-order autoregressive series). Only a record that
//! starts at rest holds it; one that starts in motion or before the program leaves its
//! start's state out already.

use super::context::{Context, STILL_M_PER_S};
use super::start::StartKind;
use crate::machine::{AxisName, MachineConfig};
use crate::sim::AxisModel;

/// Golden-section steps: the bound's width shrinks by 0.618 a step, to under a
/// ten-thousandth of it — far below any uncertainty a record leaves.
const STEPS: usize = 20;

/// The force held at a record's start, as estimated.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeldAtStart {
    /// The force (N, + pushing the table towards +).
    pub force_n: f64,
    /// Its standard uncertainty (N).
    pub uncertainty_n: f64,
    /// The bound it lies within: the friction's level at rest where the axis starts, on
    /// the side it pushes towards (N).
    pub level_n: f64,
}

impl Context<'_> {
    /// The force `axis` of `machine` holds at rest at the record's start, estimated on the
    /// compared samples `use_sample` allows (by their index among the compared samples).
    /// None where the record does not start at rest, the axis's friction holds nothing at
    /// rest, no sample is used, or the axis cannot be simulated.
    pub fn held_at_start(
        &self,
        machine: &MachineConfig,
        axis: AxisName,
        offset_s: f64,
        use_sample: &dyn Fn(usize) -> bool,
    ) -> Option<HeldAtStart> {
        let search = self.held_search(machine, axis, offset_s, use_sample)?;
        let [plus, minus] = search.levels_n;
        let force_n = golden_section(&search.cost(), -minus, plus)?;
        let residual = |held_n: f64| search.residual(held_n);
        let uncertainty_n = slope_uncertainty(&residual, force_n, [-minus, plus])?;
        Some(HeldAtStart {
            force_n,
            uncertainty_n,
            level_n: if force_n < 0.0 { minus } else { plus },
        })
    }

    /// The first compared sample of `axis` at or after its command first moves from rest at
    /// the record's start: the sample whose neighbours show the force held there (before it
    /// the force stands balanced by friction and shows nothing). None where the record does
    /// not start at rest, for Z, or where the axis's command never moves within the samples.
    pub(crate) fn first_start_sample(&self, axis: AxisName, offset_s: f64) -> Option<usize> {
        if self.start.kind != StartKind::AtRest || axis == AxisName::Z {
            return None;
        }
        let velocity = &self.commands.axis(axis).vel_m_per_s;
        let begin = ((self.start.run_in_s / self.dt).round() as usize).min(velocity.len());
        let moves_s = (begin..velocity.len())
            .find(|&i| velocity[i].abs() >= STILL_M_PER_S)
            .map(|i| i as f64 * self.dt)?;
        (0..self.samples.len()).find(|&k| {
            self.compared(axis, k) && self.prog_time(self.samples[k], offset_s) >= moves_s
        })
    }

    /// [`Context::held_at_start`]'s force alone (N), without its uncertainty: what a fit's
    /// prediction of samples it did not see is scored with, where they hold the start.
    pub(crate) fn held_at_start_n(
        &self,
        machine: &MachineConfig,
        axis: AxisName,
        offset_s: f64,
        use_sample: &dyn Fn(usize) -> bool,
    ) -> Option<f64> {
        let search = self.held_search(machine, axis, offset_s, use_sample)?;
        let [plus, minus] = search.levels_n;
        golden_section(&search.cost(), -minus, plus)
    }

    /// What the held force's search needs: none where the record does not start at rest,
    /// the axis's friction holds nothing at rest, or no sample is used.
    fn held_search<'s>(
        &'s self,
        machine: &'s MachineConfig,
        axis: AxisName,
        offset_s: f64,
        use_sample: &dyn Fn(usize) -> bool,
    ) -> Option<HeldSearch<'s>> {
        if self.start.kind != StartKind::AtRest || axis == AxisName::Z {
            return None;
        }
        let x0 = self.start.first_command_m[axis.index()];
        let levels_n = AxisModel::from_config(machine.axis(axis)).rest_friction_n(x0);
        let used: Vec<usize> = (0..self.samples.len())
            .filter(|&k| self.compared(axis, k) && use_sample(k))
            .collect();
        let holds = levels_n.iter().any(|&level| level > 0.0);
        (holds && !used.is_empty()).then_some(HeldSearch {
            ctx: self,
            machine,
            axis,
            offset_s,
            used,
            levels_n,
        })
    }
}

/// One axis's held force searched on some samples with the machine given.
struct HeldSearch<'s> {
    ctx: &'s Context<'s>,
    machine: &'s MachineConfig,
    axis: AxisName,
    offset_s: f64,
    /// The compared samples used (by index).
    used: Vec<usize>,
    /// The friction's levels at rest where the axis starts against a push towards + and
    /// towards − (N): the bounds.
    levels_n: [f64; 2],
}

impl HeldSearch<'_> {
    /// The residual at the samples used with the axis holding `held_n` (N).
    fn residual(&self, held_n: f64) -> Option<Vec<f64>> {
        let trace = self
            .ctx
            .simulate_axis_holding(self.machine, self.axis, held_n)?;
        let r = self.ctx.residual(self.axis, &trace, self.offset_s);
        Some(self.used.iter().map(|&k| r[k]).collect())
    }

    /// The residual's sum of squares as a function of the force held.
    fn cost(&self) -> impl Fn(f64) -> Option<f64> + '_ {
        |held_n| Some(self.residual(held_n)?.iter().map(|v| v * v).sum())
    }
}

/// The minimum of `cost` on [lo, hi] by golden-section search (the ends included: a force
/// at the bound is a table on the verge of breaking away, a state it can be in).
fn golden_section(cost: &dyn Fn(f64) -> Option<f64>, lo: f64, hi: f64) -> Option<f64> {
    let ratio = (5f64.sqrt() - 1.0) / 2.0;
    let (mut a, mut b) = (lo, hi);
    let mut c = b - ratio * (b - a);
    let mut d = a + ratio * (b - a);
    let (mut fc, mut fd) = (cost(c)?, cost(d)?);
    for _ in 0..STEPS {
        if fc <= fd {
            (b, d, fd) = (d, c, fc);
            c = b - ratio * (b - a);
            fc = cost(c)?;
        } else {
            (a, c, fc) = (c, d, fd);
            d = a + ratio * (b - a);
            fd = cost(d)?;
        }
    }
    let inside = if fc <= fd { (c, fc) } else { (d, fd) };
    // The ends are where a force pinned at the bound is found.
    let ends = [(lo, cost(lo)?), (hi, cost(hi)?)];
    let best = ends
        .into_iter()
        .chain([inside])
        .min_by(|p, q| p.1.total_cmp(&q.1))?;
    Some(best.0)
}

/// The standard uncertainty (N) of a one-value least-squares fit at `force_n`: the
/// residual's RMS over the root of the sum of its squared slopes, the slope taken by
/// central difference over a thousandth of the larger bound of `[low_n, high_n]` (one-sided
/// at a bound), widened by √((1 + ρ)/(1 − ρ)) for the residual's correlation ρ between
/// neighbouring samples.
fn slope_uncertainty(
    residual: &dyn Fn(f64) -> Option<Vec<f64>>,
    force_n: f64,
    [low_n, high_n]: [f64; 2],
) -> Option<f64> {
    let step = 1e-3 * high_n.max(-low_n);
    let up = (force_n + step).min(high_n);
    let down = (force_n - step).max(low_n);
    let (r_up, r_down, r) = (residual(up)?, residual(down)?, residual(force_n)?);
    let slope_ss: f64 = r_up
        .iter()
        .zip(&r_down)
        .map(|(u, d)| ((u - d) / (up - down)).powi(2))
        .sum();
    let dof = r.len().saturating_sub(1).max(1) as f64;
    let ss = r.iter().map(|v| v * v).sum::<f64>();
    let variance = ss / dof;
    let rho = if ss > 0.0 {
        let lagged: f64 = r.windows(2).map(|w| w[0] * w[1]).sum();
        (lagged / ss).clamp(0.0, 0.9999)
    } else {
        0.0
    };
    let widening = ((1.0 + rho) / (1.0 - rho)).sqrt();
    Some(if slope_ss > 0.0 {
        widening * (variance / slope_ss).sqrt()
    } else {
        f64::INFINITY
    })
}
