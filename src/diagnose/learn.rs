//! Extending the model from the data where no catalogue cause explains the residual.
//!
//! [`super::locate`] says what the residual left on an axis follows; each answer has a term
//! of the model that can stand for it, learned without a shape given in advance:
//!
//! - **its own position** (in one place or periodically): the tool standing off where the
//!   axis's scale says it is — what a compensation table corrects. Learned as a table, the
//!   residual's mean in bins of the position, linear in between: the machine keys
//!   `errors.position_map_mm` / `_um`, added beyond the scale like the axes' squareness (see
//!   [`crate::sim::geometry`]), so the loops do not see it and it does not lag;
//! - **its own position, each direction on its own**: friction that depends on where the
//!   table is (a tight spot on a guideway) — `errors.friction_map_mm` / `_n`;
//! - **its velocity**: friction that depends on speed beyond the Coulomb, viscous and
//!   Stribeck terms — `errors.friction_speed_mm_per_min` / `_n`.
//!
//! (An offset by direction of travel needs no table: it is the catalogue's
//! `direction_offset`, which the search tries before anything is located.)
//!
//! A friction term acts inside the loops, which answer it with transients, so its table
//! cannot be read off the residual: it is fitted on the residual's sensitivities, one
//! simulation per table point (the response to a friction force is linear while the table
//! slides), with a light ridge against noise.
//!
//! How fine a table is (how many points) is chosen on held-out data: fitted on alternate
//! blocks of the record and scored on the others, the count that predicts best wins. Its
//! gain is then measured like a cause's, by re-simulating: in sample, and on each half of
//! the record with the term fitted on the other half. A term is kept only when both fall —
//! out of sample by a quarter of what the noise leaves to explain — and only with values a
//! machine could have.

use rayon::prelude::*;

use super::Context;
use super::locate::{
    Bins, Located, Predictor, Variable, finite_range, held_out_share, positions_mm,
};
use crate::machine::{AxisName, MachineConfig};
use crate::numeric::units::{m_from_mm, um_from_m};
use crate::sim::geometry::CrossTerms;
use crate::sim::{AxisModel, MeasuredAt};

/// Bin counts a position map's smoothness is chosen from.
const MAP_BIN_COUNTS: [usize; 6] = [8, 16, 32, 64, 128, 256];
/// Point counts a friction table's smoothness is chosen from.
const FRICTION_POINT_COUNTS: [usize; 4] = [16, 32, 64, 128];
/// Held-out share of the residual a located variable must predict before a term is learned.
const SMALLEST_SHARE: f64 = 0.5;
/// Share of the held-out residual's power above the noise a term must remove.
const SMALLEST_GAIN: f64 = 0.25;
/// Most friction a table may add, as a multiple of the axis's Coulomb friction: not beyond
/// a guideway near seizing. (The least keeps the friction at or above none in total:
/// [`least_friction_added_n`].)
const MOST_FRICTION_ADDED: f64 = 3.0;
/// Ridge on a friction table's least squares, relative to the mean diagonal: enough to keep
/// points the record hardly visits from swinging, far too little to bias the rest.
const RIDGE: f64 = 1e-4;

/// What kind of term was learned.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Term {
    /// An error beyond the scale by position (µm by mm).
    PositionMap,
    /// Friction by the table's position (N by mm).
    FrictionMap,
    /// Friction by the table's speed (N by mm/min).
    FrictionSpeed,
}

impl Term {
    /// The machine keys it is written as.
    pub(crate) fn keys(self) -> &'static str {
        match self {
            Term::PositionMap => "errors.position_map_mm/_um",
            Term::FrictionMap => "errors.friction_map_mm/_n",
            Term::FrictionSpeed => "errors.friction_speed_mm_per_min/_n",
        }
    }

    /// What it is, for a report.
    pub(crate) fn describe(self) -> &'static str {
        match self {
            Term::PositionMap => "position-dependent error",
            Term::FrictionMap => "position-dependent friction",
            Term::FrictionSpeed => "speed-dependent friction",
        }
    }

    /// The unit of its values.
    pub(crate) fn value_unit(self) -> &'static str {
        match self {
            Term::PositionMap => "µm",
            Term::FrictionMap | Term::FrictionSpeed => "N",
        }
    }

    /// The unit of the variable its table runs over.
    pub(crate) fn variable_unit(self) -> &'static str {
        match self {
            Term::FrictionSpeed => "mm/min",
            _ => "mm",
        }
    }
}

/// A term learned on one axis.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Learned {
    /// The axis.
    pub axis: AxisName,
    /// What was learned.
    pub term: Term,
    /// Points in its table.
    pub points: usize,
    /// Where it is largest, in the variable's unit ([`Term::variable_unit`]): the points
    /// around the largest that reach half of it. None for a periodic error.
    pub interval: Option<(f64, f64)>,
    /// Its period (mm), for a periodic error.
    pub period_mm: Option<f64>,
    /// Its largest value, signed, in [`Term::value_unit`].
    pub peak: f64,
    /// The axis's residual RMS before and after, over the whole record (µm).
    pub rms_before_um: f64,
    /// After.
    pub rms_after_um: f64,
    /// The same on each half of the record with the term fitted on the other half (µm).
    pub held_out_before_um: f64,
    /// After.
    pub held_out_after_um: f64,
}

/// The machine extended by a term on the located axis, its traces, and what was learned —
/// when the located variable has a term that stands for it, and the term, fitted on half
/// the record, predicts the other half.
pub(crate) fn learn(
    ctx: &Context,
    machine: &MachineConfig,
    traces: &[Vec<f64>; 2],
    offset_s: f64,
    located: &Located,
) -> Option<(MachineConfig, [Vec<f64>; 2], Learned)> {
    if located.share < SMALLEST_SHARE {
        return None;
    }
    let axis = located.axis;
    let learner = Learner {
        ctx,
        machine,
        traces,
        offset_s,
        axis,
        residual: ctx.residual(axis, &traces[axis.index()], offset_s),
        fold: ctx.axis_halves(axis, offset_s),
    };
    // Terms beyond the scale read nothing behind a motor encoder.
    let beyond_scale_seen = ctx.measured_at != MeasuredAt::Motor;
    match located.variable? {
        Variable::Position(a) if a == axis && beyond_scale_seen => learner.position_map(located),
        Variable::Period if beyond_scale_seen => learner.position_map(located),
        Variable::PositionByDirection(_) => learner.friction_table(Term::FrictionMap),
        Variable::Velocity => learner.friction_table(Term::FrictionSpeed),
        _ => None,
    }
}

/// What every learner works from.
struct Learner<'c, 'a> {
    ctx: &'c Context<'a>,
    machine: &'c MachineConfig,
    traces: &'c [Vec<f64>; 2],
    offset_s: f64,
    axis: AxisName,
    /// The axis's residual at the compared samples (m).
    residual: Vec<f64>,
    /// Which half each compared sample belongs to; none where the axis is not compared.
    fold: Vec<Option<bool>>,
}

/// The machine with a term fitted on the samples a predicate allows.
type Extension<'f> = dyn Fn(&dyn Fn(usize) -> bool) -> Option<MachineConfig> + Sync + 'f;

/// A term's gain, re-simulated (m).
struct Gain {
    rms_before: f64,
    rms_after: f64,
    held_out_before: f64,
    held_out_after: f64,
}

impl Learner<'_, '_> {
    /// The entries of a per-sample series at the samples the axis is compared at.
    fn compared(&self, v: &[f64]) -> Vec<f64> {
        v.iter()
            .zip(&self.fold)
            .filter(|(_, f)| f.is_some())
            .map(|(v, _)| *v)
            .collect()
    }

    /// A position map: the residual's binned means over the axis's position.
    fn position_map(&self, located: &Located) -> Option<(MachineConfig, [Vec<f64>; 2], Learned)> {
        let z = positions_mm(self.ctx, &self.traces[self.axis.index()], self.offset_s);
        let r = &self.residual;
        let share = |n: usize| {
            let bins = Bins::over(&z, n);
            held_out_share(r, &self.fold, |train| bins.fit(&z, r, train))
        };
        // Each count's held-out share once (not again in every comparison).
        let (count, _) = MAP_BIN_COUNTS
            .into_iter()
            .map(|n| (n, share(n)))
            .max_by(|a, b| a.1.total_cmp(&b.1))?;
        let bins = Bins::over(&z, count);
        let table = |use_sample: &dyn Fn(usize) -> bool| bins.fit(&z, r, use_sample).centres();
        let extended = |use_sample: &dyn Fn(usize) -> bool| {
            Some(with_position_map(
                self.machine,
                self.axis,
                &table(use_sample),
            ))
        };
        let whole = table(&|_| true);
        let whole_machine = with_position_map(self.machine, self.axis, &whole);
        let periodic = located.variable == Some(Variable::Period);
        let learned = Learned {
            axis: self.axis,
            term: Term::PositionMap,
            points: whole.len(),
            interval: (!periodic).then_some(located.interval).flatten(),
            period_mm: periodic.then(|| located.interval.map(|i| i.0)).flatten(),
            peak: um_from_m(largest(&whole)),
            ..self.blank(Term::PositionMap)
        };
        self.keep_if_it_gains(whole_machine, &extended, learned)
    }

    /// A friction table over the table's position or speed, fitted on sensitivities.
    fn friction_table(&self, term: Term) -> Option<(MachineConfig, [Vec<f64>; 2], Learned)> {
        let model = AxisModel::from_config(self.machine.axis(self.axis));
        let f_c = model.f_c.max(10.0);
        let z = self.variable_of(term);
        let (lo, hi) = finite_range(&z);
        if lo.partial_cmp(&hi) != Some(std::cmp::Ordering::Less) {
            return None;
        }
        let candidates: Vec<Sensitivities> = FRICTION_POINT_COUNTS
            .into_iter()
            .filter_map(|n| self.sensitivities(term, lo, hi, n, f_c))
            .collect();
        // Each candidate's held-out share once (a fit over the record per half).
        let (_, best) = candidates
            .iter()
            .map(|s| {
                let share = held_out_share(&self.residual, &self.fold, |train| {
                    s.fit(&self.residual, train)
                });
                (share, s)
            })
            .max_by(|a, b| a.0.total_cmp(&b.0))?;
        let table = |use_sample: &dyn Fn(usize) -> bool| {
            let fit = best.fit(&self.residual, use_sample);
            best.at
                .iter()
                .copied()
                .zip(fit.coefficients)
                .collect::<Vec<(f64, f64)>>()
        };
        let whole = table(&|_| true);
        let errors = &self.machine.axis(self.axis).errors;
        let (least, most) = (
            least_friction_added_n(&model, term, errors),
            MOST_FRICTION_ADDED * f_c,
        );
        if whole.iter().any(|&(_, f)| f < least || f > most) {
            return None;
        }
        let extended = |use_sample: &dyn Fn(usize) -> bool| {
            Some(with_friction_table(
                self.machine,
                self.axis,
                term,
                &table(use_sample),
            ))
        };
        let learned = Learned {
            axis: self.axis,
            term,
            points: whole.len(),
            interval: around_largest(&whole),
            peak: largest(&whole),
            ..self.blank(term)
        };
        let whole_machine = with_friction_table(self.machine, self.axis, term, &whole);
        self.keep_if_it_gains(whole_machine, &extended, learned)
    }

    /// The variable a friction table runs over, at each compared sample: the table's
    /// position (mm) or the commanded speed (mm/min).
    fn variable_of(&self, term: Term) -> Vec<f64> {
        match term {
            Term::FrictionSpeed => {
                let c = self.ctx.commands.axis(self.axis);
                self.ctx
                    .samples
                    .iter()
                    .map(|&i| {
                        let t = self.ctx.prog_time(i, self.offset_s);
                        let k = ((t / self.ctx.dt).round().max(0.0) as usize)
                            .min(c.vel_m_per_s.len().saturating_sub(1));
                        c.vel_m_per_s.get(k).map_or(f64::NAN, |v| v.abs() * 6e4)
                    })
                    .collect()
            }
            _ => positions_mm(self.ctx, &self.traces[self.axis.index()], self.offset_s),
        }
    }

    /// The residual's change per newton of friction added at each of `n` points over
    /// `lo..hi` (a hat function each), by simulation.
    fn sensitivities(
        &self,
        term: Term,
        lo: f64,
        hi: f64,
        n: usize,
        probe_n: f64,
    ) -> Option<Sensitivities> {
        let at: Vec<f64> = (0..n)
            .map(|k| lo + (hi - lo) * k as f64 / (n - 1) as f64)
            .collect();
        let columns: Option<Vec<Vec<f64>>> = (0..n)
            .into_par_iter()
            .map(|k| {
                let hat: Vec<(f64, f64)> = at
                    .iter()
                    .enumerate()
                    .map(|(j, &p)| (p, if j == k { probe_n } else { 0.0 }))
                    .collect();
                let probed = with_friction_table(self.machine, self.axis, term, &hat);
                let trace = self.ctx.simulate_axis(&probed, self.axis)?;
                let after = self.ctx.residual(self.axis, &trace, self.offset_s);
                Some(
                    self.residual
                        .iter()
                        .zip(&after)
                        .map(|(b, a)| (b - a) / probe_n)
                        .collect(),
                )
            })
            .collect();
        Some(Sensitivities {
            at,
            columns: columns?,
        })
    }

    /// A Learned with its axis and term, before its table and gain are filled in.
    fn blank(&self, term: Term) -> Learned {
        Learned {
            axis: self.axis,
            term,
            points: 0,
            interval: None,
            period_mm: None,
            peak: 0.0,
            rms_before_um: 0.0,
            rms_after_um: 0.0,
            held_out_before_um: 0.0,
            held_out_after_um: 0.0,
        }
    }

    /// Re-simulates the machine extended by the term fitted on the whole record, `whole`, and
    /// the one `extended` gives for each half (fitted on the other half); keeps the term when
    /// the residual falls both in and out of sample.
    fn keep_if_it_gains(
        &self,
        whole: MachineConfig,
        extended: &Extension,
        mut learned: Learned,
    ) -> Option<(MachineConfig, [Vec<f64>; 2], Learned)> {
        let trace = self.ctx.simulate_axis(&whole, self.axis)?;
        let after = self.ctx.residual(self.axis, &trace, self.offset_s);
        let (mut before_ss, mut after_ss, mut n) = (0.0, 0.0, 0usize);
        for side in [true, false] {
            let half_machine = extended(&|i| self.fold[i] == Some(side))?;
            let half_trace = self.ctx.simulate_axis(&half_machine, self.axis)?;
            let half_after = self.ctx.residual(self.axis, &half_trace, self.offset_s);
            for i in (0..self.residual.len()).filter(|&i| self.fold[i] == Some(!side)) {
                before_ss += self.residual[i] * self.residual[i];
                after_ss += half_after[i] * half_after[i];
                n += 1;
            }
        }
        let gain = Gain {
            rms_before: rms(&self.compared(&self.residual)),
            rms_after: rms(&self.compared(&after)),
            held_out_before: (before_ss / n.max(1) as f64).sqrt(),
            held_out_after: (after_ss / n.max(1) as f64).sqrt(),
        };
        // A term must take a real part of what the noise leaves to explain out of data it
        // was not fitted on, not merely nudge it.
        let excess = gain.held_out_before.powi(2) - self.ctx.noise_sigma.powi(2);
        let taken = gain.held_out_before.powi(2) - gain.held_out_after.powi(2);
        if excess <= 0.0 || taken < SMALLEST_GAIN * excess || gain.rms_after >= gain.rms_before {
            return None;
        }
        learned.rms_before_um = um_from_m(gain.rms_before);
        learned.rms_after_um = um_from_m(gain.rms_after);
        learned.held_out_before_um = um_from_m(gain.held_out_before);
        learned.held_out_after_um = um_from_m(gain.held_out_after);
        let mut traces = self.traces.clone();
        traces[self.axis.index()] = trace;
        Some((whole, traces, learned))
    }
}

/// The residual's change per unit of each table point's value, at the compared samples.
struct Sensitivities {
    /// The points (in the variable's unit).
    at: Vec<f64>,
    /// One column per point.
    columns: Vec<Vec<f64>>,
}

impl Sensitivities {
    /// The values at the points that explain the residual best (ridge least squares) over
    /// the samples `use_sample` allows.
    fn fit(&self, residual: &[f64], use_sample: &dyn Fn(usize) -> bool) -> LinearFit<'_> {
        let n = self.columns.len();
        let mut ata = nalgebra::DMatrix::<f64>::zeros(n, n);
        let mut atb = nalgebra::DVector::<f64>::zeros(n);
        for i in (0..residual.len()).filter(|&i| use_sample(i)) {
            for a in 0..n {
                let sa = self.columns[a][i];
                atb[a] += sa * residual[i];
                for b in a..n {
                    ata[(a, b)] += sa * self.columns[b][i];
                }
            }
        }
        for a in 0..n {
            for b in 0..a {
                ata[(a, b)] = ata[(b, a)];
            }
        }
        let ridge = RIDGE * ata.trace() / n as f64;
        for a in 0..n {
            ata[(a, a)] += ridge.max(1e-300);
        }
        let coefficients = ata
            .cholesky()
            .map(|c| c.solve(&atb).iter().copied().collect())
            .unwrap_or_else(|| vec![0.0; n]);
        LinearFit {
            columns: &self.columns,
            coefficients,
        }
    }
}

/// A friction table's prediction of the residual, to first order.
struct LinearFit<'s> {
    columns: &'s [Vec<f64>],
    coefficients: Vec<f64>,
}

impl Predictor for LinearFit<'_> {
    fn predict(&self, i: usize) -> Option<f64> {
        Some(
            self.columns
                .iter()
                .zip(&self.coefficients)
                .map(|(s, c)| s[i] * c)
                .sum(),
        )
    }
}

/// `machine` with the table `points` ((mm, m) of the residual) added to the position map of
/// `axis` (to a map it already has, taken at the new points).
fn with_position_map(
    machine: &MachineConfig,
    axis: AxisName,
    points: &[(f64, f64)],
) -> MachineConfig {
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

/// `machine` with the friction table `points` ((mm or mm/min, N)) as `axis`'s friction map
/// or friction-speed table.
fn with_friction_table(
    machine: &MachineConfig,
    axis: AxisName,
    term: Term,
    points: &[(f64, f64)],
) -> MachineConfig {
    let mut m = machine.clone();
    let errors = &mut m.axis_mut(axis).errors;
    let (at, values) = match term {
        Term::FrictionSpeed => (
            &mut errors.friction_speed_mm_per_min,
            &mut errors.friction_speed_n,
        ),
        _ => (&mut errors.friction_map_mm, &mut errors.friction_map_n),
    };
    *at = points.iter().map(|p| p.0).collect();
    *values = points.iter().map(|p| p.1).collect();
    m
}

/// The least a learned friction table of `term` may add (N): friction never pushes the
/// table, so the static level with a position map, and the sliding level with the position
/// map and the speed curve together (the other table as the machine has it), stay at or
/// above zero — as validation asks of a machine file.
fn least_friction_added_n(model: &AxisModel, term: Term, errors: &crate::machine::Errors) -> f64 {
    let lowest = |v: &[f64]| v.iter().copied().fold(0.0f64, f64::min);
    match term {
        Term::FrictionSpeed => -(model.f_c + lowest(&errors.friction_map_n)).max(0.0),
        _ => -(model.f_c + lowest(&errors.friction_speed_n))
            .min(model.f_s)
            .max(0.0),
    }
}

/// The value of largest magnitude in a table, signed.
fn largest(points: &[(f64, f64)]) -> f64 {
    points
        .iter()
        .map(|p| p.1)
        .max_by(|a, b| a.abs().total_cmp(&b.abs()))
        .unwrap_or(0.0)
}

/// The points around the largest whose values keep its sign and reach half of it, as an
/// interval of the table's variable.
fn around_largest(points: &[(f64, f64)]) -> Option<(f64, f64)> {
    let peak = largest(points);
    let k = points.iter().position(|p| p.1 == peak)?;
    let strong = |j: usize| points[j].1 * peak > 0.0 && points[j].1.abs() >= 0.5 * peak.abs();
    let (mut first, mut last) = (k, k);
    while first > 0 && strong(first - 1) {
        first -= 1;
    }
    while last + 1 < points.len() && strong(last + 1) {
        last += 1;
    }
    Some((points[first].0, points[last].0))
}

fn rms(r: &[f64]) -> f64 {
    (r.iter().map(|v| v * v).sum::<f64>() / r.len().max(1) as f64).sqrt()
}
