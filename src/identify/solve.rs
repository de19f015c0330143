//! One least-squares fit of some knobs of one axis to the record: the axis re-simulated on
//! the record's commands, solved by [`crate::numeric::lsq`] in scaled parameters (log-factors
//! or increments) kept inside their box.

use std::cell::RefCell;
use std::sync::Arc;

use nalgebra::{DMatrix, DVector};

use super::knobs::{self, HELD_AT_START, Knob, get, set_all};
use crate::compare::Context;
use crate::machine::{AxisConfig, AxisName, MachineConfig};
use crate::numeric::lsq::{
    self, JacobianSvd, MODEL_FLOOR_SHARE, correlation_time, forward_jacobian,
};
use crate::plan::Commands;

mod memo;

use memo::Memo;

/// How far a positive value is searched from where the fit starts, as a factor either way:
/// a template is a machine of the same kind, and a flat valley must not carry the search
/// off to where nothing is seen.
const FACTOR_RANGE: f64 = 10.0;
/// The residual of a simulation that failed (m): values the model cannot run with (an
/// unstable loop) cost far more than any fit, so that the search steps back from them.
const FAILED_M: f64 = 1.0;

/// The least step from where a fit started, in its values' standard uncertainties, that
/// makes the point it ends at its own (`Fitted::own_point`). A half of the record started
/// where the fit on the whole landed and fitting its own samples moves by about the whole
/// fit's σ (the whole fit is the mean of the two halves', each √2 σ from it), some 0.7 of a
/// half's own σ. That σ is the one that scatters a half's values: the least-squares σ
/// widened by the square root of the residual's correlation time τ (in samples), as the
/// threshold is taken (`sigma_scaled`); on the raw σ a step √τ times smaller would count,
/// a few hundredths of the expected move on a residual that keeps its sign for tens of
/// samples. A step of a tenth of the scaled σ — along the valley, the other values
/// refitted — raises the residual's sum of squares by 0.01·τ of its variance per sample
/// (its spread², never below the noise's): a hundredth of what one stretch of τ correlated
/// samples carries, so of one independent sample's worth. A step below it — the search
/// stopping on its tolerance, or a rounding at 1e-300 — is nothing a held-out figure could
/// show, and the values are still the whole fit's.
const OWN_STEP_SIGMA: f64 = 0.1;

/// Step of the Jacobian's differences in the scaled parameters: large against the
/// switching instants' rounding, small against the values.
const STEP: f64 = 0.01;

/// The fits of one axis on one record.
pub struct Fit<'c, 'a> {
    ctx: &'c Context<'a>,
    template: &'c MachineConfig,
    axis: AxisName,
    offset_s: f64,
    /// The compared samples the fits use.
    mask: Vec<bool>,
    /// Costs and searches already computed on those samples.
    memo: Arc<Memo>,
    /// Where the simulations stop early: the last compared sample the fits use, and the
    /// commands up to it.
    early: Option<(usize, Commands)>,
    /// The first sample the fits use from the axis's first start from rest at the record's
    /// start on ([`Context::first_start_sample`]); none where the record does not start at
    /// rest.
    start_sample: Option<usize>,
}

/// Values fitted and their standard uncertainties (machine units), and the residual's sum
/// of squares on the samples fitted (m²).
#[derive(Clone)]
pub struct Fitted {
    pub values: Vec<f64>,
    pub sigma: Vec<f64>,
    /// What a modelling difference of [`MODEL_FLOOR_SHARE`] of the noise could move each
    /// value by, the others refitted (machine units).
    pub model_sigma: Vec<f64>,
    pub cost: f64,
    /// Whether the values are this fit's own: its search left the values it started from by
    /// at least a tenth of some machine value's σ ([`OWN_STEP_SIGMA`]; the force held at the
    /// record's start, a state of the record, not counted), or it had nothing to fit. A
    /// search that found no such step stays where it started — for a half of the record
    /// started where the fit on the whole landed, at values fitted to the other half as
    /// well.
    pub own_point: bool,
    /// What the uncertainties were computed from, for those of combinations of the values.
    spread: Option<Spread>,
}

/// The fit's Jacobian in its scaled parameters (decomposed once: what its uncertainties are
/// read from), with what turns its uncertainties into the reported ones.
#[derive(Clone)]
struct Spread {
    jacobian: JacobianSvd,
    noise: f64,
    /// √ of the residual's correlation time (samples).
    correlation: f64,
    /// From the statistical uncertainty to the model's floor.
    to_floor: f64,
    /// Each fitted knob's least relative uncertainty (by the Jacobian's column).
    input_floors: Vec<f64>,
    /// The knob (by index) the fit held at its start's value, which has no column.
    fixed: Option<usize>,
}

impl Spread {
    /// The Jacobian's column of knob `j`; none for the knob held fixed.
    fn column(&self, j: usize) -> Option<usize> {
        match self.fixed {
            Some(f) if j == f => None,
            Some(f) if j > f => Some(j - 1),
            _ => Some(j),
        }
    }

    /// The knob of the Jacobian's column `c`.
    fn knob(&self, c: usize) -> usize {
        match self.fixed {
            Some(f) if c >= f => c + 1,
            _ => c,
        }
    }
}

impl Fitted {
    /// The relative standard uncertainty of a product of logarithmic knobs' values, each to
    /// the power given by knob index (a ratio: 1 and −1): statistical, floored as every
    /// value's is, and the model's floor — (σ, σ_model). Infinite where nothing was fitted.
    pub(crate) fn relative_uncertainty(&self, powers: &[(usize, f64)]) -> (f64, f64) {
        let Some(s) = &self.spread else {
            return (f64::INFINITY, f64::INFINITY);
        };
        let mut w = DVector::zeros(s.jacobian.cols);
        let mut floor: f64 = 0.0;
        for &(j, power) in powers {
            let Some(c) = s.column(j).filter(|&c| c < w.len()) else {
                return (f64::INFINITY, f64::INFINITY);
            };
            w[c] = power;
            floor = floor.max(s.input_floors[c] * power.abs());
        }
        let raw = s.jacobian.combination_uncertainty(self.cost, s.noise, &w);
        ((raw * s.correlation).max(floor), raw * s.to_floor)
    }

    /// The value (by knob index) whose fit is the most correlated with value `j`'s — the
    /// one it trades with where the record does not tell them apart —, from the Jacobian's
    /// covariance (a direction the record does not see at all weighed as a thousand times
    /// less seen than the best). None where nothing was fitted or `j` is fitted alone.
    pub(crate) fn most_traded_with(&self, j: usize) -> Option<usize> {
        self.most_traded_among(j, &|_| true)
    }

    /// [`Fitted::most_traded_with`] among the values (by knob index) `among` accepts.
    pub(crate) fn most_traded_among(
        &self,
        j: usize,
        among: &dyn Fn(usize) -> bool,
    ) -> Option<usize> {
        let s = self.spread.as_ref()?;
        let j = s.column(j)?;
        let n = s.jacobian.cols;
        let (singular_values, vt) = s.jacobian.svd.as_ref()?;
        let largest = singular_values.iter().copied().fold(0.0, f64::max);
        if j >= n || largest <= 0.0 {
            return None;
        }
        // Covariance in the scaled parameters, up to a factor: V·diag(1/s²)·Vᵀ.
        let weights: Vec<f64> = singular_values
            .iter()
            .map(|&sv| sv.max(1e-3 * largest).powi(-2))
            .collect();
        let cov = |a: usize, b: usize| {
            (0..vt.nrows())
                .map(|k| weights[k] * vt[(k, a)] * vt[(k, b)])
                .sum::<f64>()
        };
        (0..n)
            .filter(|&k| k != j && among(s.knob(k)))
            .map(|k| (k, cov(j, k).abs() / (cov(j, j) * cov(k, k)).sqrt()))
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(k, _)| s.knob(k))
    }

    /// These values with knob `j` inserted at `value`, held there (not fitted: no
    /// uncertainty of this fit's).
    fn insert_fixed(&mut self, j: usize, value: f64) {
        self.values.insert(j, value);
        self.sigma.insert(j, f64::INFINITY);
        self.model_sigma.insert(j, f64::INFINITY);
        if let Some(s) = &mut self.spread {
            s.fixed = Some(j);
        }
    }
}

impl<'c, 'a> Fit<'c, 'a> {
    pub(crate) fn new(
        ctx: &'c Context<'a>,
        template: &'c MachineConfig,
        axis: AxisName,
        offset_s: f64,
    ) -> Fit<'c, 'a> {
        Fit {
            ctx,
            template,
            axis,
            offset_s,
            mask: vec![true; ctx.samples.len()],
            memo: Arc::default(),
            early: None,
            start_sample: None,
        }
        .stopping_early()
    }

    /// The same fits on the samples `mask` allows only.
    pub(crate) fn masked(self, mask: Vec<bool>) -> Self {
        Fit {
            mask,
            memo: Arc::default(),
            ..self
        }
        .stopping_early()
    }

    /// These fits with their simulations stopped after the last sample they use that the
    /// axis's residual compares (none where that is the record's last): after it the
    /// residual is zero where the axis is not compared, whatever the model does (a hunting
    /// hold), and not read where the fits leave samples out.
    fn stopping_early(self) -> Self {
        let (ctx, axis) = (self.ctx, self.axis);
        let last = (0..ctx.samples.len())
            .rev()
            .find(|&k| self.mask[k] && ctx.compared(axis, k));
        let early = last.filter(|&k| k + 1 < ctx.samples.len()).and_then(|k| {
            let until_s = ctx.prog_time(ctx.samples[k], self.offset_s);
            Some((k, ctx.commands_until(until_s)?))
        });
        // A fit that leaves out the breakaways after standstills (`moving_samples`) starts
        // at its first sample after the start: the force held shows there too, in what the
        // integrator carries from it.
        let used = |k: usize| self.mask[k] && ctx.compared(axis, k);
        let start_sample = ctx
            .first_start_sample(axis, self.offset_s)
            .and_then(|first| (first..ctx.samples.len()).find(|&k| used(k)));
        Fit {
            early,
            start_sample,
            ..self
        }
    }

    /// Whether the samples `use_sample` allows hold the axis's first start from rest at the
    /// record's start, where the force it held there shows: only a fit of those fits that
    /// force ([`super::knobs::HELD_AT_START`]). Fitted on samples that do not hold it, it
    /// only soaks up what the model misses elsewhere and wanders to its bound.
    pub(crate) fn holds_start(&self, use_sample: &dyn Fn(usize) -> bool) -> bool {
        self.start_sample.is_some_and(use_sample)
    }

    /// The friction's levels at rest where the axis starts with `config` (N), against a push
    /// towards + and towards −: the bounds of the force held there
    /// ([`crate::sim::AxisModel::rest_friction_n`]).
    pub(crate) fn held_level_n(&self, config: &AxisConfig) -> [f64; 2] {
        let x0 = (self.ctx.start.first_command_m)
            .get(self.axis.index())
            .copied()
            .unwrap_or(0.0);
        crate::sim::AxisModel::from_config(config).rest_friction_n(x0)
    }

    /// The force held at the record's start estimated on the samples `use_sample` allows
    /// with the axis's other values at `config`'s ([`Context::held_at_start_n`]).
    pub(crate) fn held_on(
        &self,
        config: &AxisConfig,
        use_sample: &dyn Fn(usize) -> bool,
    ) -> Option<f64> {
        let mut machine = self.template.clone();
        *machine.axis_mut(self.axis) = config.clone();
        self.ctx
            .held_at_start_n(&machine, self.axis, self.offset_s, use_sample)
    }

    /// The samples the fits use.
    pub(crate) fn mask(&self) -> &[bool] {
        &self.mask
    }

    /// The record's comparison.
    pub(crate) fn ctx(&self) -> &'c Context<'a> {
        self.ctx
    }

    /// The axis fitted.
    pub(crate) fn axis(&self) -> AxisName {
        self.axis
    }

    /// The record's clock offset (s).
    pub(crate) fn offset(&self) -> f64 {
        self.offset_s
    }

    /// The axis's residual at every compared sample with its configuration `config` (m):
    /// where the simulation stopped early, NaN at the samples after it that the fits leave
    /// out and the axis compares (no fit, figure or ripple of these fits reads one).
    pub(crate) fn residual(&self, config: &AxisConfig) -> Option<Vec<f64>> {
        let mut machine = self.template.clone();
        *machine.axis_mut(self.axis) = config.clone();
        let ctx = self.ctx;
        let trace = match &self.early {
            None => ctx.simulate_axis(&machine, self.axis),
            Some((_, commands)) => ctx.simulate_axis_on(&machine, self.axis, commands),
        }?;
        let mut r = ctx.residual(self.axis, &trace, self.offset_s);
        if let Some((last, _)) = self.early {
            for (k, v) in r.iter_mut().enumerate().skip(last + 1) {
                if ctx.compared(self.axis, k) {
                    *v = f64::NAN;
                }
            }
        }
        Some(r)
    }

    /// The residual's sum of squares over the fits' samples (m²), or none where the model
    /// cannot run.
    pub(crate) fn cost(&self, config: &AxisConfig) -> Option<f64> {
        self.memo.cost(config, || {
            let r = self.residual(config)?;
            Some(
                r.iter()
                    .zip(&self.mask)
                    .filter(|(_, m)| **m)
                    .map(|(v, _)| v * v)
                    .sum(),
            )
        })
    }

    /// Fits `knobs` from `base` on every sample the fits use: the residual's sum of squares
    /// and the configuration the search ended at.
    pub(crate) fn searched(&self, knobs: &[Knob], base: &AxisConfig) -> Option<(f64, AxisConfig)> {
        let (cost, values) = self.memo.search(knobs, base, || {
            self.run(knobs, base, &|_| true).map(|f| (f.cost, f.values))
        })?;
        Some((cost, Fit::config(knobs, base, &values)))
    }

    /// Fits `knobs` from `base`'s values on the samples `use_sample` allows. The force held
    /// at the record's start stays at `base`'s where those samples do not hold the start
    /// ([`Fit::holds_start`]): reported with no uncertainty of its own, it is not this fit's.
    pub(crate) fn run(
        &self,
        knobs: &[Knob],
        base: &AxisConfig,
        use_sample: &(dyn Fn(usize) -> bool + Sync),
    ) -> Option<Fitted> {
        let held = knobs.iter().position(|k| k.key == HELD_AT_START.key);
        match held {
            Some(j) if !self.holds_start(&|k| self.mask[k] && use_sample(k)) => {
                let mut free = knobs.to_vec();
                free.remove(j);
                let mut fitted = self.run_all(&free, base, use_sample)?;
                fitted.insert_fixed(j, get(base, HELD_AT_START.key));
                Some(fitted)
            }
            _ => self.run_all(knobs, base, use_sample),
        }
    }

    /// Fits every one of `knobs` from `base`'s values on the samples `use_sample` allows.
    fn run_all(
        &self,
        knobs: &[Knob],
        base: &AxisConfig,
        use_sample: &(dyn Fn(usize) -> bool + Sync),
    ) -> Option<Fitted> {
        let keep: Vec<usize> = (0..self.ctx.samples.len())
            .filter(|&i| self.mask[i] && use_sample(i))
            .collect();
        self.memo.run(knobs, base, &keep, || {
            Problem {
                fit: self,
                knobs,
                base,
                keep: &keep,
                cache: RefCell::new(None),
            }
            .solve()
        })
    }

    /// `base` with `knobs` at `values`.
    pub(crate) fn config(knobs: &[Knob], base: &AxisConfig, values: &[f64]) -> AxisConfig {
        let mut c = base.clone();
        let keys: Vec<&str> = knobs.iter().map(|k| k.key).collect();
        set_all(&mut c, &keys, values);
        c
    }
}

/// One fit: parameters are log-factors on `base`'s values (logarithmic knobs) or increments
/// in units of the knob's scale.
struct Problem<'f, 'c, 'a> {
    fit: &'f Fit<'c, 'a>,
    knobs: &'f [Knob],
    base: &'f AxisConfig,
    keep: &'f [usize],
    /// The last residual evaluated, by its parameters.
    cache: RefCell<Option<(DVector<f64>, DVector<f64>)>>,
}

/// Machine values of `knobs` at parameters `p` about `base`, within their ranges.
pub(crate) fn values_at(knobs: &[Knob], base: &AxisConfig, p: &DVector<f64>) -> Vec<f64> {
    knobs
        .iter()
        .zip(p.iter())
        .map(|(k, &u)| {
            let t = get(base, k.key);
            let v = if k.logarithmic {
                t * u.exp()
            } else {
                t + u * k.scale_at(t)
            };
            v.clamp(k.min, k.max)
        })
        .collect()
}

impl Problem<'_, '_, '_> {
    /// The parameters' box: a factor of `FACTOR_RANGE` either way for positive values, the
    /// knob's range for increments.
    fn bounds(&self, j: usize) -> (f64, f64) {
        let k = &self.knobs[j];
        let t = get(self.base, k.key);
        if k.key == HELD_AT_START.key {
            // Within the friction's level at rest: beyond it the table would have slid.
            let [plus, minus] = self.fit.held_level_n(self.base);
            let s = k.scale_at(t);
            ((-minus - t).min(0.0) / s, (plus - t).max(0.0) / s)
        } else if k.logarithmic {
            // A corner stays where the controller's own period lets it be placed and the
            // record can place it: the interpolation cycle is not the controller's period.
            // It never rises above that, but one the design put higher keeps its place (the
            // search may lower it): the box must hold the start, not move it before any
            // search.
            let max = if k.is_corner() {
                let ceiling = knobs::corner_ceiling_of(self.base, self.fit.ctx.measured.dt_s);
                k.max.min(ceiling.max(t))
            } else {
                k.max
            };
            let lower = (-FACTOR_RANGE.ln()).max((k.min / t).ln());
            (lower, FACTOR_RANGE.ln().min((max / t).ln()).max(lower))
        } else {
            let s = k.scale_at(t);
            ((k.min - t) / s, (k.max - t) / s)
        }
    }

    fn config(&self, p: &DVector<f64>) -> AxisConfig {
        Fit::config(self.knobs, self.base, &values_at(self.knobs, self.base, p))
    }

    fn evaluate(&self, p: &DVector<f64>) -> DVector<f64> {
        if let Some((at, r)) = self.cache.borrow().as_ref()
            && at == p
        {
            return r.clone();
        }
        let full = self
            .fit
            .residual(&self.config(p))
            .unwrap_or_else(|| vec![FAILED_M; self.fit.ctx.samples.len()]);
        let r = DVector::from_iterator(self.keep.len(), self.keep.iter().map(|&i| full[i]));
        *self.cache.borrow_mut() = Some((p.clone(), r.clone()));
        r
    }

    /// Levenberg–Marquardt inside the box, then the uncertainties in machine units.
    fn solve(&self) -> Option<Fitted> {
        let n = self.knobs.len();
        let settings = lsq::Settings::with_bounds((0..n).map(|j| self.bounds(j)).collect());
        let end = lsq::minimise(self, DVector::zeros(n), &settings)?;
        let values = values_at(self.knobs, self.base, &end.p);
        // Nothing to fit, or no sample to fit it on (a half of a record that is all
        // standstill): the values stay, and with no sample they are undetermined.
        if n == 0 || self.keep.is_empty() {
            return Some(Fitted {
                values,
                sigma: vec![f64::INFINITY; n],
                model_sigma: vec![f64::INFINITY; n],
                cost: end.cost,
                own_point: n == 0,
                spread: None,
            });
        }
        // Residuals that are not white (what the model misses, in stretches) carry fewer
        // independent samples than they number.
        let correlation = correlation_time(&end.residuals).sqrt();
        let noise = self.fit.ctx.noise_sigma;
        let jacobian = JacobianSvd::of(&end.jacobian);
        let raw = jacobian.uncertainties(end.cost, noise);
        let sigma_scaled: Vec<f64> = raw.iter().map(|s| s * correlation).collect();
        let floors: Vec<f64> = self.knobs.iter().map(|k| k.input_floor).collect();
        // On the widened σ, the one a half's values scatter by ([`OWN_STEP_SIGMA`]).
        let own_point = machine_stepped(self.knobs, end.p.as_slice(), &sigma_scaled, &floors);
        // The statistical uncertainty answers a rise of the residual's sum of squares by one
        // spread²; the model's floor, by the number of samples times its own square (the
        // samples' correlation cancels between the two).
        let rows = self.keep.len() as f64;
        let spread = (end.cost / (rows - n as f64).max(1.0)).sqrt().max(noise);
        let to_floor = MODEL_FLOOR_SHARE * noise * rows.sqrt() / spread;
        let in_units = |k: &Knob, s: f64, v: f64| {
            if k.logarithmic {
                s * v
            } else {
                s * k.scale_at(get(self.base, k.key))
            }
        };
        let model_sigma = self
            .knobs
            .iter()
            .zip(&raw)
            .zip(&values)
            .map(|((k, s), v)| in_units(k, s * to_floor, *v))
            .collect();
        let sigma = self
            .knobs
            .iter()
            .zip(&sigma_scaled)
            .zip(&values)
            .map(|((k, s), v)| {
                let size = if k.logarithmic {
                    v.abs()
                } else {
                    k.scale_at(*v)
                };
                in_units(k, *s, *v).max(k.input_floor * size)
            })
            .collect();
        Some(Fitted {
            values,
            sigma,
            model_sigma,
            cost: end.cost,
            own_point,
            spread: Some(Spread {
                jacobian,
                noise,
                correlation,
                to_floor,
                input_floors: floors,
                fixed: None,
            }),
        })
    }
}

/// RMS of `values` over the samples `mask` allows (in their unit); zero where it allows none.
pub(crate) fn masked_rms(values: &[f64], mask: &[bool]) -> f64 {
    let (ss, n) = values
        .iter()
        .zip(mask)
        .filter(|(_, m)| **m)
        .fold((0.0, 0usize), |(s, n), (v, _)| (s + v * v, n + 1));
    (ss / n.max(1) as f64).sqrt()
}

/// Whether a fit's step `p` from where it started (scaled parameters) leaves it by at least
/// [`OWN_STEP_SIGMA`] of some value's standard uncertainty there (`sigma_scaled`, in the
/// same units, floored at the knob's least relative uncertainty `floors`). A value the fit
/// does not determine (an infinite or undefined σ) cannot make the point its own.
fn stepped_beyond_noise(p: &[f64], sigma_scaled: &[f64], floors: &[f64]) -> bool {
    p.iter()
        .zip(sigma_scaled.iter().zip(floors))
        .any(|(u, (s, floor))| s.is_finite() && u.abs() >= OWN_STEP_SIGMA * s.max(*floor))
}

/// [`stepped_beyond_noise`] on the machine's values among `knobs` alone: the force held at
/// the record's start ([`HELD_AT_START`]) is a state of the record, not a value of the
/// machine, and a half whose only step is that force has found no values of its own — the
/// machine's are still where the fit on the whole landed.
fn machine_stepped(knobs: &[Knob], p: &[f64], sigma_scaled: &[f64], floors: &[f64]) -> bool {
    let machine: Vec<usize> = (0..knobs.len())
        .filter(|&j| knobs[j].key != HELD_AT_START.key)
        .collect();
    let of = |v: &[f64]| -> Vec<f64> { machine.iter().map(|&j| v[j]).collect() };
    stepped_beyond_noise(&of(p), &of(sigma_scaled), &of(floors))
}

impl lsq::Problem for Problem<'_, '_, '_> {
    fn residuals(&self, p: &DVector<f64>) -> Option<DVector<f64>> {
        Some(self.evaluate(p))
    }

    fn jacobian(&self, p: &DVector<f64>, r0: &DVector<f64>) -> Option<DMatrix<f64>> {
        // Only what is shared between threads (not the cache).
        let (fit, knobs, base, keep) = (self.fit, self.knobs, self.base, self.keep);
        let bounds: Vec<(f64, f64)> = (0..p.len()).map(|j| self.bounds(j)).collect();
        forward_jacobian(p, r0, &bounds, STEP, p.len(), &|q| {
            let full = fit.residual(&Fit::config(knobs, base, &values_at(knobs, base, q)))?;
            Some(DVector::from_iterator(
                keep.len(),
                keep.iter().map(|&i| full[i]),
            ))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_masked_rms_counts_only_the_samples_allowed() {
        // √((3² + 4²) / 2) = √12.5; the 100 left out.
        let rms = masked_rms(&[3.0, 100.0, 4.0], &[true, false, true]);
        assert!((rms - 12.5f64.sqrt()).abs() < 1e-12, "{rms}");
        assert_eq!(masked_rms(&[3.0, 4.0], &[false, false]), 0.0);
    }

    /// A fit of three knobs whose Jacobian's columns are independent, with knob `fixed`
    /// inserted at 7.0 as a fixed one: four values.
    fn with_fixed(fixed: usize) -> Fitted {
        let jacobian =
            DMatrix::from_row_slice(3, 3, &[1.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 4.0]);
        let mut f = Fitted {
            values: vec![1.0, 2.0, 3.0],
            sigma: vec![0.1; 3],
            model_sigma: vec![0.01; 3],
            cost: 1.0,
            own_point: true,
            spread: Some(Spread {
                jacobian: JacobianSvd::of(&jacobian),
                noise: 1.0,
                correlation: 1.0,
                to_floor: 1.0,
                input_floors: vec![0.0; 3],
                fixed: None,
            }),
        };
        f.insert_fixed(fixed, 7.0);
        f
    }

    #[test]
    fn a_knob_held_fixed_has_no_column_and_the_others_keep_theirs() {
        for fixed in 0..4 {
            let f = with_fixed(fixed);
            assert_eq!(f.values.len(), 4);
            assert_eq!(f.values[fixed], 7.0);
            assert!(f.sigma[fixed].is_infinite() && f.model_sigma[fixed].is_infinite());
            let s = f.spread.as_ref().unwrap();
            assert_eq!(s.column(fixed), None);
            // Every other knob maps to a column and back to itself, in order.
            let others: Vec<usize> = (0..4).filter(|&j| j != fixed).collect();
            for (c, &j) in others.iter().enumerate() {
                assert_eq!(s.column(j), Some(c), "fixed {fixed}, knob {j}");
                assert_eq!(s.knob(c), j, "fixed {fixed}, column {c}");
            }
            // A combination of the fixed knob has no uncertainty of this fit's.
            assert!(f.relative_uncertainty(&[(fixed, 1.0)]).0.is_infinite());
            // The columns' scales (1, 2, 4) show through the mapping: the knob of the column
            // scaled 4 is the best seen, so its uncertainty is the least.
            let last = others[2];
            let first = others[0];
            assert!(
                f.relative_uncertainty(&[(last, 1.0)]).0
                    < f.relative_uncertainty(&[(first, 1.0)]).0
            );
        }
    }

    #[test]
    fn only_a_step_of_a_tenth_of_sigma_makes_a_point_its_own() {
        let floor = [1e-4];
        // A step rounded off the start, however small, is not a point of the fit's own.
        assert!(!stepped_beyond_noise(&[1e-300], &[0.02], &floor));
        assert!(!stepped_beyond_noise(&[-0.0019], &[0.02], &floor));
        // A tenth of σ = 0.02 is 0.002: from there on, either way.
        assert!(stepped_beyond_noise(&[0.002], &[0.02], &floor));
        assert!(stepped_beyond_noise(&[-0.015], &[0.02], &floor));
        // One value of two moved far enough suffices.
        assert!(stepped_beyond_noise(
            &[1e-9, 0.05],
            &[0.02, 0.3],
            &[1e-4; 2]
        ));
        assert!(!stepped_beyond_noise(
            &[1e-9, 0.02],
            &[0.02, 0.3],
            &[1e-4; 2]
        ));
        // A σ below the knob's floor (1e-3) counts as the floor: 1e-5 is no step.
        assert!(!stepped_beyond_noise(&[1e-5], &[1e-7], &[1e-3]));
        // A value the fit does not determine moves nothing of its own.
        assert!(!stepped_beyond_noise(&[0.5], &[f64::INFINITY], &floor));
        assert!(!stepped_beyond_noise(&[0.5], &[f64::NAN], &floor));
    }

    #[test]
    fn a_step_of_the_held_force_alone_makes_no_point_its_own() {
        let gain = crate::identify::knobs::for_axis(&MachineConfig::default_preset().x)[0];
        assert_ne!(gain.key, HELD_AT_START.key);
        let knobs = [gain, HELD_AT_START];
        let (sigma, floors) = ([0.02, 0.02], [1e-4, 1e-4]);
        // The force stepped by ten of its σ, the machine's value by nothing: not its own.
        assert!(!machine_stepped(&knobs, &[1e-9, 0.2], &sigma, &floors));
        // The same step of the machine's value is (a tenth of σ = 0.002 is enough).
        assert!(machine_stepped(&knobs, &[0.002, 0.0], &sigma, &floors));
        assert!(machine_stepped(&knobs, &[0.002, 0.2], &sigma, &floors));
        // Knobs in the other order: the force's column is left out wherever it lies.
        let swapped = [HELD_AT_START, gain];
        assert!(!machine_stepped(&swapped, &[0.2, 1e-9], &sigma, &floors));
        assert!(machine_stepped(&swapped, &[0.0, -0.003], &sigma, &floors));
    }
}
