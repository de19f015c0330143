//! The least squares of a ripple's sine and cosine parts: how the residual changes per unit
//! of each (its columns), and the parts that explain it best, where the record tells them
//! apart.

use rayon::prelude::*;

use super::{Reason, with_ripple};
use crate::identify::solve::Fit;
use crate::machine::AxisConfig;
use crate::numeric::two_columns::TwoColumns;
use crate::numeric::units::mm_from_m;

/// The trial ripple's amplitude (N): small against the forces of any table that moves, so
/// that the residual answers it linearly, large against the simulation's rounding.
const TRIAL_N: f64 = 1.0;

/// The largest correlation of the sine and cosine columns a fit is made with. Beyond it the
/// two parts trade: a ripple seen over a short stretch of its period, or only where the
/// loop answers both alike, is explained by any of a ridge of (a, b) pairs, and the
/// amplitude and phase picked on it would be the noise's.
const MAX_CORRELATION: f64 = 0.99;

/// The residual without a ripple (m) and its change per unit of the ripple's sine and cosine
/// parts.
pub(super) struct Parts {
    pub(super) r0: Vec<f64>,
    s: Vec<f64>,
    c: Vec<f64>,
}

/// How the residual changes per unit of a ripple's sine and cosine parts, where that does
/// not depend on the fit (an encoder's error, added to what it reads).
pub(super) struct Columns {
    s: Vec<f64>,
    c: Vec<f64>,
}

impl Columns {
    /// The force ripple's columns on `config` (per newton), from two simulations with a
    /// trial ripple at 0° and at 90° beside the one without.
    pub(super) fn force(fit: &Fit, config: &AxisConfig) -> Result<Parts, Reason> {
        let r0 = fit
            .residual(&with_ripple(config, (0.0, 0.0)))
            .ok_or("the axis cannot be simulated with a trial ripple")?;
        Self::force_beside(fit, config, r0)
    }

    /// [`Columns::force`] beside `r0`, the residual of `config` without a ripple (which
    /// does not depend on the period): the two trial simulations only.
    pub(super) fn force_beside(
        fit: &Fit,
        config: &AxisConfig,
        r0: Vec<f64>,
    ) -> Result<Parts, Reason> {
        let runs: Vec<Vec<f64>> = [(TRIAL_N, 0.0), (0.0, TRIAL_N)]
            .into_par_iter()
            .map(|ab| fit.residual(&with_ripple(config, ab)))
            .collect::<Option<_>>()
            .ok_or("the axis cannot be simulated with a trial ripple")?;
        let [r1, r2] = <[Vec<f64>; 2]>::try_from(runs)
            .map_err(|_| "the trial ripple's simulations did not all return".to_string())?;
        let column =
            |r: &[f64]| -> Vec<f64> { r.iter().zip(&r0).map(|(a, b)| (a - b) / TRIAL_N).collect() };
        let (s, c) = (column(&r1), column(&r2));
        Ok(Parts { r0, s, c })
    }

    /// A cyclic error of the encoder, e·sin(2π·x/period + φ) = a·sin(k·x) + b·cos(k·x) (m)
    /// added to the position read: the simulation corrected on its output, so each part
    /// takes its sine or cosine of the position off the residual at every sample compared.
    /// (The loop reads the error too; above its crossover it cannot follow it, and the
    /// record shows the error as it is.)
    pub(super) fn encoder(fit: &Fit, period_m: f64) -> Columns {
        let ctx = fit.ctx();
        let axis = fit.axis();
        let x = ctx.measured_axis(axis);
        let k = std::f64::consts::TAU / period_m;
        let (s, c) = ctx
            .samples
            .iter()
            .enumerate()
            .map(|(j, &i)| {
                if ctx.compared(axis, j) {
                    let (sin, cos) = (k * x[i]).sin_cos();
                    (-sin, -cos)
                } else {
                    (0.0, 0.0)
                }
            })
            .unzip();
        Columns { s, c }
    }

    /// These columns on the residual `r0`.
    pub(super) fn on(&self, r0: &[f64]) -> Parts {
        Parts {
            r0: r0.to_vec(),
            s: self.s.clone(),
            c: self.c.clone(),
        }
    }

    /// `r0` with the parts `(a, b)` applied.
    pub(super) fn corrected(&self, r0: &[f64], (a, b): (f64, f64)) -> Vec<f64> {
        (0..r0.len())
            .map(|i| r0[i] + a * self.s[i] + b * self.c[i])
            .collect()
    }
}

#[cfg(test)]
impl Parts {
    /// Parts given outright: the residual without a ripple and its columns.
    pub(super) fn given(r0: Vec<f64>, s: Vec<f64>, c: Vec<f64>) -> Parts {
        Parts { r0, s, c }
    }
}

impl Parts {
    /// The sine and cosine parts that minimise Σ (r0 + a·s + b·c)² on the samples
    /// `use_sample` allows; not where the two columns act alike (`MAX_CORRELATION`).
    pub(super) fn solve(
        &self,
        use_sample: &(dyn Fn(usize) -> bool + Sync),
    ) -> Result<(f64, f64), Reason> {
        let sums = self.sums(use_sample);
        let Some((alpha, beta)) = sums.solve(MAX_CORRELATION) else {
            return Err(format!(
                "its sine and cosine parts act alike on the samples (correlation {:.3}): the \
                 record cannot place its phase",
                sums.correlation()
            ));
        };
        // The parts cancel the residual: they are the fit of −r0.
        Ok((-alpha, -beta))
    }

    /// How much the parts `(a, b)` lower the residual's sum of squares (m²) on the samples
    /// `use_sample` allows.
    pub(super) fn gain(
        &self,
        use_sample: &(dyn Fn(usize) -> bool + Sync),
        (a, b): (f64, f64),
    ) -> f64 {
        (0..self.r0.len())
            .filter(|&i| use_sample(i))
            .map(|i| {
                let left = self.r0[i] + a * self.s[i] + b * self.c[i];
                self.r0[i] * self.r0[i] - left * left
            })
            .sum()
    }

    /// [`Parts::gain`] as a share of the residual's energy on the same samples (0 where they
    /// hold none, or where either is not finite: no gain is claimed from a failed number).
    pub(super) fn share_gained(
        &self,
        use_sample: &(dyn Fn(usize) -> bool + Sync),
        ab: (f64, f64),
    ) -> f64 {
        let energy: f64 = (0..self.r0.len())
            .filter(|&i| use_sample(i))
            .map(|i| self.r0[i] * self.r0[i])
            .sum();
        let share = self.gain(use_sample, ab) / energy;
        if energy > 0.0 && share.is_finite() {
            share
        } else {
            0.0
        }
    }

    /// The least-squares standard deviation (N) of the parts `(a, b)` fitted on the samples
    /// `use_sample` allows, along the direction the record fixes worst. The samples' errors
    /// are correlated, so this is a floor on the uncertainty, not all of it.
    pub(super) fn least_squares_sigma(
        &self,
        use_sample: &(dyn Fn(usize) -> bool + Sync),
        (a, b): (f64, f64),
    ) -> f64 {
        self.sums(use_sample).worst_sigma(-a, -b)
    }

    /// The normal equations' sums on the samples `use_sample` allows.
    fn sums(&self, use_sample: &(dyn Fn(usize) -> bool + Sync)) -> TwoColumns {
        TwoColumns::over(&self.s, &self.c, &self.r0, use_sample)
    }
}

/// Whether the axis travels at least a period on the samples the fit compares: over less,
/// a sine and a cosine of the position are nearly a line and a constant, which the loop's
/// own values explain as well, and the ripple's amplitude and phase trade without end.
pub(super) fn travel_covers(fit: &Fit, period_m: f64) -> Result<(), Reason> {
    let ctx = fit.ctx();
    let x = ctx.measured_axis(fit.axis());
    let (lo, hi) = ctx
        .samples
        .iter()
        .zip(fit.mask())
        .filter(|(_, m)| **m)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), (&i, _)| {
            (lo.min(x[i]), hi.max(x[i]))
        });
    if hi - lo >= period_m {
        return Ok(());
    }
    Err(format!(
        "the axis travels {:.3} mm on the samples compared, less than one period of {:.3} mm",
        mm_from_m((hi - lo).max(0.0)),
        mm_from_m(period_m)
    ))
}
