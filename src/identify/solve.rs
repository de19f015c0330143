//! One least-squares fit of some knobs of one axis to the record: the axis re-simulated on
//! the record's commands, Levenberg–Marquardt in scaled parameters kept inside their box, a
//! forward-difference Jacobian (its columns in parallel), and standard uncertainties from
//! the Jacobian's singular values.

use std::cell::RefCell;

use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;

use super::knobs::{Knob, get, set_all};
use crate::diagnose::context::Context;
use crate::machine::{AxisConfig, AxisName, MachineConfig};

/// How far a positive value is searched from where the fit starts, as a factor either way:
/// a template is a machine of the same kind, and a flat valley must not carry the search
/// off to where nothing is seen.
const FACTOR_RANGE: f64 = 10.0;
/// The residual of a simulation that failed (m): values the model cannot run with (an
/// unstable loop) cost far more than any fit, so that the search steps back from them.
const FAILED_M: f64 = 1.0;
/// Most iterations of one fit, and damping tries per iteration.
const ITERATIONS: usize = 40;
const TRIES: usize = 10;
/// The least relative uncertainty of any value: the commands the model is driven with are
/// read back from the record (resampled, their velocity and acceleration fitted over a few
/// milliseconds), not the control's own, and on records of known machines that alone moved
/// a fitted mass by 0.3 % while the noise allowed 0.05 %.
const INPUT_FLOOR: f64 = 0.005;
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
}

/// Values fitted and their standard uncertainties (machine units), and the residual's sum
/// of squares on the samples fitted (m²).
pub struct Fitted {
    pub values: Vec<f64>,
    pub sigma: Vec<f64>,
    pub cost: f64,
}

impl<'c, 'a> Fit<'c, 'a> {
    pub fn new(
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
        }
    }

    /// The same fits on the samples `mask` allows only.
    pub fn masked(self, mask: Vec<bool>) -> Self {
        Fit { mask, ..self }
    }

    /// The samples the fits use.
    pub fn mask(&self) -> &[bool] {
        &self.mask
    }

    /// The record's comparison.
    pub fn ctx(&self) -> &'c Context<'a> {
        self.ctx
    }

    /// The axis fitted.
    pub fn axis(&self) -> AxisName {
        self.axis
    }

    /// The record's clock offset (s).
    pub fn offset(&self) -> f64 {
        self.offset_s
    }

    /// The axis's residual at every compared sample with its configuration `config` (m).
    pub fn residual(&self, config: &AxisConfig) -> Option<Vec<f64>> {
        let mut machine = self.template.clone();
        *machine.axis_mut(self.axis) = config.clone();
        let trace = self.ctx.simulate_axis(&machine, self.axis)?;
        Some(self.ctx.residual(self.axis, &trace, self.offset_s))
    }

    /// The residual's sum of squares over the fits' samples (m²), or none where the model
    /// cannot run.
    pub fn cost(&self, config: &AxisConfig) -> Option<f64> {
        let r = self.residual(config)?;
        Some(
            r.iter()
                .zip(&self.mask)
                .filter(|(_, m)| **m)
                .map(|(v, _)| v * v)
                .sum(),
        )
    }

    /// Fits `knobs` from `base`'s values on the samples `use_sample` allows.
    pub fn run(
        &self,
        knobs: &[Knob],
        base: &AxisConfig,
        use_sample: &(dyn Fn(usize) -> bool + Sync),
    ) -> Option<Fitted> {
        let keep: Vec<usize> = (0..self.ctx.samples.len())
            .filter(|&i| self.mask[i] && use_sample(i))
            .collect();
        Problem {
            fit: self,
            knobs,
            base,
            keep: &keep,
            cache: RefCell::new(None),
        }
        .solve()
    }

    /// `base` with `knobs` at `values`.
    pub fn config(knobs: &[Knob], base: &AxisConfig, values: &[f64]) -> AxisConfig {
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
fn values_at(knobs: &[Knob], base: &AxisConfig, p: &DVector<f64>) -> Vec<f64> {
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
        if k.logarithmic {
            (
                (-FACTOR_RANGE.ln()).max((k.min / t).ln()),
                FACTOR_RANGE.ln().min((k.max / t).ln()),
            )
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

    fn jacobian_at(&self, p: &DVector<f64>) -> Option<DMatrix<f64>> {
        let r0 = self.evaluate(p);
        // Only what is shared between threads (not the cache).
        let (fit, knobs, base, keep) = (self.fit, self.knobs, self.base, self.keep);
        let columns: Vec<Option<DVector<f64>>> = (0..p.len())
            .into_par_iter()
            .map(|j| {
                let mut q = p.clone();
                q[j] += STEP;
                let config = Fit::config(knobs, base, &values_at(knobs, base, &q));
                let full = fit.residual(&config)?;
                Some(DVector::from_iterator(
                    keep.len(),
                    keep.iter()
                        .zip(r0.iter())
                        .map(|(&i, r)| (full[i] - r) / STEP),
                ))
            })
            .collect();
        let mut jac = DMatrix::zeros(r0.len(), p.len());
        for (j, c) in columns.into_iter().enumerate() {
            jac.set_column(j, &c?);
        }
        Some(jac)
    }

    /// Levenberg–Marquardt inside the box: a step that would leave it is cut at its wall
    /// rather than followed into a clamped, flat region.
    fn solve(&self) -> Option<Fitted> {
        let n = self.knobs.len();
        let mut p = DVector::zeros(n);
        let mut r = self.evaluate(&p);
        let mut cost = r.norm_squared();
        // Nothing to fit, or no sample to fit it on (a half of a record that is all
        // standstill): the values stay, and with no sample they are undetermined.
        if n == 0 || self.keep.is_empty() {
            return Some(Fitted {
                values: values_at(self.knobs, self.base, &p),
                sigma: vec![f64::INFINITY; n],
                cost,
            });
        }
        let mut lambda = 1e-3;
        let mut jac = self.jacobian_at(&p)?;
        for _ in 0..ITERATIONS {
            let jtj = jac.transpose() * &jac;
            let g = jac.transpose() * &r;
            let floor = 1e-12 * jtj.diagonal().max();
            let mut improved = false;
            for _ in 0..TRIES {
                let mut a = jtj.clone();
                for j in 0..n {
                    a[(j, j)] += lambda * jtj[(j, j)].max(floor);
                }
                let Some(delta) = a.lu().solve(&(-&g)) else {
                    lambda *= 10.0;
                    continue;
                };
                let mut q = &p + delta;
                for j in 0..n {
                    let (lo, hi) = self.bounds(j);
                    q[j] = q[j].clamp(lo, hi);
                }
                let rq = self.evaluate(&q);
                let c = rq.norm_squared();
                if c < cost {
                    improved = (cost - c) / cost > 1e-7;
                    (p, r, cost) = (q, rq, c);
                    lambda = (lambda / 3.0).max(1e-9);
                    break;
                }
                lambda *= 4.0;
            }
            if !improved {
                break;
            }
            jac = self.jacobian_at(&p)?;
        }
        let values = values_at(self.knobs, self.base, &p);
        // Residuals that are not white (what the model misses, in stretches) carry fewer
        // independent samples than they number.
        let correlation = correlation_time(&r).sqrt();
        let sigma_scaled: Vec<f64> = scaled_uncertainties(&jac, cost, self.fit.ctx.noise_sigma)
            .into_iter()
            .map(|s| s * correlation)
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
                let from_noise = if k.logarithmic {
                    s * v
                } else {
                    s * k.scale_at(get(self.base, k.key))
                };
                from_noise.max(INPUT_FLOOR * size)
            })
            .collect();
        Some(Fitted {
            values,
            sigma,
            cost,
        })
    }
}

/// The residual's integrated correlation time in samples, 1 + 2 Σ ρₖ over the lags until
/// the correlation first falls below a twentieth: 1 for white noise, the length of the
/// stretches over which it keeps its sign where the model misses something.
fn correlation_time(r: &DVector<f64>) -> f64 {
    const LONGEST_LAG: usize = 500;
    let n = r.len();
    let mean = r.mean();
    let var = r.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n.max(1) as f64;
    if var.is_nan() || var <= 0.0 {
        return 1.0;
    }
    let mut tau = 1.0;
    for lag in 1..LONGEST_LAG.min(n / 4) {
        let rho = (0..n - lag)
            .map(|i| (r[i] - mean) * (r[i + lag] - mean))
            .sum::<f64>()
            / (n as f64 * var);
        if rho < 0.05 {
            break;
        }
        tau += 2.0 * rho;
    }
    tau
}

/// Standard uncertainties of the scaled parameters: the diagonal of s²(JᵀJ)⁺ through the
/// Jacobian's singular values, over every direction (one the record barely sees makes the
/// values along it uncertain, as it should), with s the residual's spread per degree of
/// freedom and never below the record's noise.
fn scaled_uncertainties(jac: &DMatrix<f64>, cost: f64, noise: f64) -> Vec<f64> {
    let (rows, n) = jac.shape();
    let spread = (cost / (rows as f64 - n as f64).max(1.0)).sqrt().max(noise);
    let svd = jac.clone().svd(false, true);
    let Some(vt) = svd.v_t else {
        return vec![f64::INFINITY; n];
    };
    (0..n)
        .map(|j| {
            svd.singular_values
                .iter()
                .enumerate()
                .map(|(k, &s)| {
                    if s > 0.0 {
                        (vt[(k, j)] * spread / s).powi(2)
                    } else if vt[(k, j)] != 0.0 {
                        f64::INFINITY
                    } else {
                        0.0
                    }
                })
                .sum::<f64>()
                .sqrt()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn white_noise_has_no_correlation_time_and_a_drift_has_a_long_one() {
        // A fixed pseudo-random sequence (a linear congruential generator), and a slow sine.
        let mut state = 12345u64;
        let white = DVector::from_fn(4000, |_, _| {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        });
        assert!((correlation_time(&white) - 1.0).abs() < 0.2);
        let slow = DVector::from_fn(4000, |i, _| (i as f64 / 200.0).sin());
        assert!(correlation_time(&slow) > 50.0);
    }

    #[test]
    fn uncertainties_follow_the_singular_values() {
        // Two columns: one seen strongly, one barely; the noise 1.
        let jac = DMatrix::from_row_slice(3, 2, &[10.0, 0.0, 0.0, 0.001, 0.0, 0.0]);
        let s = scaled_uncertainties(&jac, 0.0, 1.0);
        assert!(
            (s[0] - 0.1).abs() < 1e-12 && (s[1] - 1000.0).abs() < 1e-6,
            "{s:?}"
        );
        // A column of zeros: not seen at all.
        let jac = DMatrix::from_row_slice(3, 2, &[1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
        assert!(scaled_uncertainties(&jac, 0.0, 1.0)[1].is_infinite());
    }
}
