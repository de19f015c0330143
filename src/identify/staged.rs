//! Where the final fit starts. The residual over the values identification fits has valleys
//! a local search stays in, so the search is staged: the record's own equation solved
//! linearly where it applies (`linear`); the gains alone (on the cascade the lag dominates
//! the residual and hides the rest; a feed-forward and a dead time give the same steady
//! lag, and only the transients fitted later tell them apart); the nonlinear parts scanned
//! one by one; a coarse grid over the values that trade with each other through the
//! standstills and reversals; then a local fit of the loop and friction from the grid's
//! best few points.

use rayon::prelude::*;

use super::knobs::{
    BACKLASH_KEY, COULOMB_KEY, INTEGRAL_TIME_KEY, KV_KEY, Knob, MASS_KEY, SF_INTEGRAL_KEY,
    SF_POSITION_KEY, SF_VELOCITY_KEY, STATIC_KEY, TF_GAIN_KEY, VISCOUS_KEY, get, set_all,
};
use super::solve::Fit;
use super::{linear, scanned, starts};
use crate::machine::AxisConfig;

/// Factors on the values so far that the grid tries, and how many of its best points the
/// local fit starts from.
const GRID_FACTORS: [f64; 5] = [0.5, 0.7, 1.0, 1.4, 2.0];
const GRID_STARTS: usize = 3;
/// Coulomb friction's steps on the grid: geometric, from 1/span to span times the value so
/// far.
const FRICTION_STEPS: usize = 13;
const FRICTION_SPAN: f64 = 2.0;
/// The values the grid spans, where the axis's knobs have them.
const GRID_KEYS: [&str; 4] = [COULOMB_KEY, INTEGRAL_TIME_KEY, MASS_KEY, SF_INTEGRAL_KEY];
/// The values fitted first, alone.
const GAIN_KEYS: [&str; 4] = [KV_KEY, TF_GAIN_KEY, SF_POSITION_KEY, SF_VELOCITY_KEY];
/// The values the local fits from the grid's best points free.
const DYNAMICS_KEYS: [&str; 15] = [
    KV_KEY,
    TF_GAIN_KEY,
    SF_POSITION_KEY,
    SF_VELOCITY_KEY,
    SF_INTEGRAL_KEY,
    INTEGRAL_TIME_KEY,
    MASS_KEY,
    COULOMB_KEY,
    VISCOUS_KEY,
    BACKLASH_KEY,
    STATIC_KEY,
    "controller.zero_1_hz",
    "controller.zero_2_hz",
    "controller.pole_1_hz",
    "controller.pole_2_hz",
];

/// Where the final fit of `knobs` starts from `template`: the staged search below from the
/// record's equation solved linearly where that gives a controller that explains the record
/// better than the template; else from each of the best few trial starts (`starts`), the
/// one whose search ends lowest.
pub(super) fn start(fit: &Fit, knobs: &[Knob], template: &AxisConfig) -> AxisConfig {
    let from = match estimated(fit, knobs, template) {
        Some(estimate) => vec![estimate],
        None => starts::candidates(fit, knobs, template),
    };
    let first = from[0].clone();
    from.par_iter()
        .map(|s| searched_from(fit, knobs, s))
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map_or(first, |(_, c)| c)
}

/// The gains fitted alone from `template`, the nonlinear parts scanned, the grid, and the
/// local fits from its best points: the cost and the configuration the best landed on.
fn searched_from(fit: &Fit, knobs: &[Knob], template: &AxisConfig) -> (f64, AxisConfig) {
    let mut after_gain = gains_fitted(fit, knobs, template);
    // The nonlinear parts, each scanned on its own: play and sticking change the reversals
    // by steps that a local search from the template's value (none) does not see past.
    for knob in knobs {
        if let Some((_, c)) = scanned(fit, &after_gain, knob.key) {
            after_gain = c;
        }
    }
    let mut scored = grid(fit, knobs, &after_gain);
    scored.truncate(GRID_STARTS);
    let dynamics = pick(knobs, &DYNAMICS_KEYS);
    scored
        .par_iter()
        .filter_map(|(_, from)| fitted_from(fit, from, &dynamics))
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .unwrap_or_else(|| {
            let cost = fit.cost(&after_gain).unwrap_or(f64::INFINITY);
            (cost, after_gain)
        })
}

/// The record's own equation solved linearly, where it applies and explains the record
/// better than the template does: a controller tens of percent off its design has valleys
/// between it and the machine that the fits by re-simulation would stay in.
fn estimated(fit: &Fit, knobs: &[Knob], template: &AxisConfig) -> Option<AxisConfig> {
    let cost = |c: &AxisConfig| fit.cost(c).unwrap_or(f64::INFINITY);
    linear::first_estimate(fit, knobs, template).filter(|e| cost(e) < cost(template))
}

/// `from` with its gains fitted alone.
fn gains_fitted(fit: &Fit, knobs: &[Knob], from: &AxisConfig) -> AxisConfig {
    let gains = pick(knobs, &GAIN_KEYS);
    if gains.is_empty() {
        return from.clone();
    }
    fitted_from(fit, from, &gains).map_or_else(|| from.clone(), |(_, c)| c)
}

/// The grid's points about `centre`, each simulated, best first.
fn grid(fit: &Fit, knobs: &[Knob], centre: &AxisConfig) -> Vec<(f64, AxisConfig)> {
    let keys: Vec<&str> = GRID_KEYS
        .into_iter()
        .filter(|k| knobs.iter().any(|q| q.key == *k))
        .collect();
    let values: Vec<f64> = keys.iter().map(|k| get(centre, k)).collect();
    let mut points: Vec<Vec<f64>> = vec![Vec::new()];
    for key in &keys {
        let factors = grid_factors(key);
        points = points
            .into_iter()
            .flat_map(|p| {
                factors.iter().map(move |&f| {
                    let mut q = p.clone();
                    q.push(f);
                    q
                })
            })
            .collect();
    }
    let mut scored: Vec<(f64, AxisConfig)> = points
        .par_iter()
        .filter_map(|factors| {
            let mut c = centre.clone();
            let at: Vec<f64> = values.iter().zip(factors).map(|(v, f)| v * f).collect();
            set_all(&mut c, &keys, &at);
            Some((fit.cost(&c)?, c))
        })
        .collect();
    scored.sort_by(|a, b| a.0.total_cmp(&b.0));
    scored
}

/// The factors the grid tries on one value. Friction's valley is narrow (a tenth off, and
/// the breakaways come at other times): it gets the finer steps.
fn grid_factors(key: &str) -> Vec<f64> {
    if key == COULOMB_KEY {
        (0..FRICTION_STEPS)
            .map(|i| FRICTION_SPAN.powf(2.0 * i as f64 / (FRICTION_STEPS - 1) as f64 - 1.0))
            .collect()
    } else {
        GRID_FACTORS.to_vec()
    }
}

/// The knobs among `keys`.
fn pick(knobs: &[Knob], keys: &[&str]) -> Vec<Knob> {
    knobs
        .iter()
        .copied()
        .filter(|k| keys.contains(&k.key))
        .collect()
}

/// `staged` fitted from `from`: the cost and the configuration it landed on.
fn fitted_from(fit: &Fit, from: &AxisConfig, staged: &[Knob]) -> Option<(f64, AxisConfig)> {
    fit.searched(staged, from)
}
