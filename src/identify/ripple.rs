//! A force ripple that repeats with the table's position (a motor's torque ripple or
//! cogging, a screw's eccentricity), fitted on top of an axis's fit where the template names
//! its period (`errors.force_ripple_period_mm`: a motor turn's travel).
//!
//! The ripple's sine and cosine parts act on the residual nearly linearly (the loop is linear
//! but for friction switching), so each is found by least squares from two simulations more,
//! with a trial ripple at phase 0° and at 90°: cheap beside the search. Each half's fit gets
//! the ripple fitted on its own samples and is scored on the other half's, like every value
//! `identify` writes; the ripple stays only where those held-out figures are better than the
//! same halves' without it by the twentieth every larger model must earn. Otherwise it is
//! listed as not determined and nothing is written.

use rayon::prelude::*;

use super::result::IdentifiedValue;
use super::round::Round;
use super::solve::Fit;
use super::verdict;
use crate::machine::AxisConfig;
use crate::numeric::units::um_from_m;

/// The keys the ripple is written under.
pub(super) const AMPLITUDE_KEY: &str = "errors.force_ripple_n";
pub(super) const PHASE_KEY: &str = "errors.force_ripple_phase_deg";

/// The trial ripple's amplitude (N): small against the forces of any table that moves, so
/// that the residual answers it linearly, large against the simulation's rounding.
const TRIAL_N: f64 = 1.0;

/// A ripple fitted on top of an axis's fit, and whether the held-out halves kept it.
pub(super) struct RippleFit {
    /// The axis's configuration with the ripple, where kept.
    pub(super) config: Option<AxisConfig>,
    /// The held-out RMS (m) of the halves' fits with their ripples.
    pub(super) held_out_with_m: f64,
    /// The amplitude and phase as values, determined or not.
    pub(super) values: [IdentifiedValue; 2],
}

/// The ripple on top of `round` (whose fit on the whole record is `whole`), scored on the
/// halves `fold` tells apart, of the halves' fits `counted` allows; none where the template
/// names no period or the axis cannot be simulated with one.
pub(super) fn on_top(
    fit: &Fit,
    round: &Round,
    whole: &AxisConfig,
    fold: &[bool],
    counted: [bool; 2],
) -> Option<RippleFit> {
    if whole.errors.force_ripple_period_mm <= 0.0 {
        return None;
    }
    let mask = fit.mask();
    let halves: Vec<_> = [(0, true), (1, false)]
        .into_par_iter()
        .map(|(h, side)| {
            let config = round.config(&round.halves[h]);
            let parts = solve(fit, &config, &|i| mask[i] && fold[i] == side)?;
            let with = fit.residual(&with_ripple(&config, parts.ab))?;
            let held_out = |i: usize| mask[i] && fold[i] != side && counted[h];
            let without = sum_of_squares(&parts.r0, held_out);
            Some((parts.ab, sum_of_squares(&with, held_out), without))
        })
        .collect::<Option<_>>()?;
    let n = (0..mask.len())
        .filter(|&i| mask[i] && counted[usize::from(fold[i])])
        .count()
        .max(1) as f64;
    let held_out_with_m = (halves.iter().map(|h| h.1).sum::<f64>() / n).sqrt();
    let held_out_without_m = (halves.iter().map(|h| h.2).sum::<f64>() / n).sqrt();
    let whole_parts = solve(fit, whole, &|i| mask[i])?;
    let kept = verdict::predicts_better(um_from_m(held_out_with_m), um_from_m(held_out_without_m));
    let values = values(whole, whole_parts.ab, [halves[0].0, halves[1].0], kept);
    Some(RippleFit {
        config: kept.then(|| with_ripple(whole, whole_parts.ab)),
        held_out_with_m,
        values,
    })
}

/// Which halves' fits a held-out figure counts: those with a point of their own where the
/// figure is the own-point one (`own`: the axis above the noise, and some half has one),
/// else both.
pub(super) fn counted(round: &Round, own: Option<Option<f64>>) -> [bool; 2] {
    match own {
        Some(Some(_)) => [round.halves[0].own_point, round.halves[1].own_point],
        _ => [true, true],
    }
}

impl RippleFit {
    /// The axis's fit with the ripple where the halves kept it: its configuration, residual
    /// and held-out figure (µm) replaced; the ripple's values added to `values` either way.
    pub(super) fn apply(
        self,
        fit: &Fit,
        written: (AxisConfig, Vec<f64>),
        values: &mut Vec<IdentifiedValue>,
        held_out_um: &mut f64,
    ) -> Option<(AxisConfig, Vec<f64>)> {
        values.extend(self.values);
        let Some(config) = self.config else {
            return Some(written);
        };
        *held_out_um = um_from_m(self.held_out_with_m);
        let residual = fit.residual(&config)?;
        Some((config, residual))
    }
}

/// The residual without a ripple and the ripple's sine and cosine parts (N) that explain it
/// best on the samples `use_sample` allows.
struct Parts {
    r0: Vec<f64>,
    ab: (f64, f64),
}

fn solve(
    fit: &Fit,
    config: &AxisConfig,
    use_sample: &(dyn Fn(usize) -> bool + Sync),
) -> Option<Parts> {
    let runs: Vec<Vec<f64>> = [None, Some((TRIAL_N, 0.0)), Some((0.0, TRIAL_N))]
        .into_par_iter()
        .map(|ab| match ab {
            None => fit.residual(&with_ripple(config, (0.0, 0.0))),
            Some(ab) => fit.residual(&with_ripple(config, ab)),
        })
        .collect::<Option<_>>()?;
    let r0 = &runs[0];
    // The residual's change per newton of each part: its columns of the least squares.
    let column =
        |r: &[f64]| -> Vec<f64> { r.iter().zip(r0).map(|(a, b)| (a - b) / TRIAL_N).collect() };
    let (s, c) = (column(&runs[1]), column(&runs[2]));
    let (mut ss, mut sc, mut cc, mut sr, mut cr) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for i in (0..r0.len()).filter(|&i| use_sample(i)) {
        ss += s[i] * s[i];
        sc += s[i] * c[i];
        cc += c[i] * c[i];
        sr += s[i] * r0[i];
        cr += c[i] * r0[i];
    }
    let det = ss * cc - sc * sc;
    if det.is_nan() || det <= 0.0 {
        return None;
    }
    // Minimising Σ (r0 + a·s + b·c)².
    let a = -(cc * sr - sc * cr) / det;
    let b = -(ss * cr - sc * sr) / det;
    Some(Parts {
        r0: runs.into_iter().next()?,
        ab: (a, b),
    })
}

/// `config` with the ripple a·sin(k·x) + b·cos(k·x) = A·sin(k·x + φ) (N), A = |(a, b)|,
/// φ = atan2(b, a).
fn with_ripple(config: &AxisConfig, (a, b): (f64, f64)) -> AxisConfig {
    let mut c = config.clone();
    c.errors.force_ripple_n = a.hypot(b);
    c.errors.force_ripple_phase_deg = b.atan2(a).to_degrees();
    c
}

fn sum_of_squares(r: &[f64], use_sample: impl Fn(usize) -> bool) -> f64 {
    (0..r.len())
        .filter(|&i| use_sample(i))
        .map(|i| r[i] * r[i])
        .sum()
}

/// The amplitude and phase fitted on the whole record, each with half the halves'
/// disagreement as its uncertainty (a ripple the halves place apart is not known better than
/// that). Kept, they are written as a model's values, never as determined: the record fixes
/// the force only per unit of the fitted mass (which trades with the gain), and a cyclic
/// error of the encoder at the same period predicts the record nearly as well (on the course
/// table's record within the halves' spread), so which of the two the table has is not
/// known from the record. Not kept, the template's values stay, not determined.
fn values(
    template: &AxisConfig,
    whole: (f64, f64),
    halves: [(f64, f64); 2],
    kept: bool,
) -> [IdentifiedValue; 2] {
    let amplitude = |(a, b): (f64, f64)| a.hypot(b);
    let phase_deg = |(a, b): (f64, f64)| b.atan2(a).to_degrees();
    let amplitude_sigma = 0.5 * (amplitude(halves[0]) - amplitude(halves[1])).abs();
    let turn = (phase_deg(halves[0]) - phase_deg(halves[1]) + 540.0).rem_euclid(360.0) - 180.0;
    let phase_sigma = 0.5 * turn.abs();
    let value = |key, unit, template: f64, fitted: f64, sigma: f64, traded| IdentifiedValue {
        key,
        unit,
        template,
        value: if kept { fitted } else { template },
        uncertainty: if kept { sigma } else { f64::NAN },
        determined: false,
        measured: false,
        traded_with: kept.then_some(traded),
        loose: false,
        complex_pair: None,
    };
    [
        value(
            AMPLITUDE_KEY,
            "N",
            template.errors.force_ripple_n,
            amplitude(whole),
            amplitude_sigma,
            "drive.table_mass_kg (the record fixes the force per mass) and with a cyclic \
             encoder error of the same period",
        ),
        value(
            PHASE_KEY,
            "°",
            template.errors.force_ripple_phase_deg,
            phase_deg(whole),
            phase_sigma,
            "a cyclic encoder error of the same period (the record does not tell a force \
             from it)",
        ),
    ]
}
