//! The force an axis held at rest at the record's start, as identification fits it on top of
//! an axis's values (docs/model.md §1.10): reported with its uncertainty, never written.
//!
//! A record that starts with the axis at rest starts it wherever its integral action stopped
//! against friction before the record began: a force anywhere within the friction's level at
//! rest that the record does not show until the axis first moves. Left at none, the first
//! start's transient is fitted by the machine's values — the gain, the friction, the
//! bristles bend to a state of one record. But the force also trades with whatever else
//! shapes a start (the nut's place in its gap, the bristles' stiffness, a controller unlike
//! the machine's): fitted in every search, it took the place of backlash and of the bristles
//! an independent integrator's records had, where none was held. So it comes last, like
//! every element beyond the template: on an axis whose fit (on every sample, or away from the
//! standstills) stays above the noise, that fit's values are fitted again with the force beside them — by the whole fit
//! and the half of the record that holds the first start ([`Fit::holds_start`]); the other
//! half keeps the whole fit's (fitted there it only soaks up what the model misses elsewhere
//! and runs to its bound) — and a half's fit is scored on the other half with the force
//! estimated on that half's samples where they hold the start (`Round::scored_config`): a
//! state of the record, not a value the half predicts. Each half's fit starts from the
//! ripple and the bristles' shape of its own samples where the axis's fit wrote them
//! (`half_bases`), never from the whole fit's, which has seen the other half. Kept only where
//! those values predict the held-out halves better by the twentieth every larger model must
//! earn than the same values fitted again without it, scored the same way (the force
//! estimated on each half scored): what is judged is the machine's values, which the file
//! holds. A step of the force alone does not make a half's point its own
//! (`Fitted::own_point`): its machine values are still the whole fit's.
//!
//! A fit that reaches the noise (on every sample or away from the standstills) earns no
//! force, but may owe its values to it: its values are fitted again with the force beside
//! them ([`told_apart`]), and a value that refit moves beyond its uncertainty, and beyond
//! what noise alone would, is one the record cannot tell from the force — not called
//! determined.

use rayon::prelude::*;

use super::knobs::{self, HELD_AT_START, Knob, get};
use super::result::{AxisIdentification, HeldForce};
use super::round::Round;
use super::solve::{Fit, Fitted, masked_rms};
use super::verdict::moved;
use super::{
    fitted_values, gain_per_inertia, presliding, refitted_value, ripple, verdict, within_noise,
};
use crate::machine::AxisConfig;
use crate::numeric::units::um_from_m;

/// `found` (an axis's fit on the samples `fit` uses) with its values fitted again beside the
/// force held at the record's start, where they predict the held-out halves better by a
/// twentieth than fitted again without it; else `found` as it is. Tried on a fit whose
/// held-out figure is held out, where the record starts at rest and the fit uses the axis's
/// first start, above the noise; fitted again with the force, the fit may reach the noise,
/// and whether it does is then the refit's. At the noise, [`told_apart`] instead.
///
/// `unbent` (for the fit away from the standstills: the values fitted on every sample) is a
/// second start for the refits where it is of the fit's structure: leaving out the
/// breakaways, that fit's values bend to the force the integrator carries past them, and a
/// refit from there may stay bent. Each refit keeps whichever start ends lower on the fit's
/// own samples ([`lowest_round`]).
pub(super) fn on_top(
    fit: &Fit,
    template: &AxisConfig,
    candidates: &[Knob],
    found: (AxisConfig, AxisIdentification),
    unbent: Option<&AxisConfig>,
) -> (AxisConfig, AxisIdentification) {
    let (config, id) = &found;
    let tried = !id.held_out_in_sample && fit.holds_start(&|_| true) && holds_any(fit, config);
    if !tried || id.reached {
        return found;
    }
    refitted(fit, (template, unbent), candidates, config, id).unwrap_or_else(|| {
        let (config, mut id) = found;
        id.held_at_start = Some(not_kept(fit, &config));
        (config, id)
    })
}

/// The knobs among `candidates` that `id` lists as fitted, each once, where `config`'s value
/// lies within its range (a shape's value set outside a knob's range stays as set).
fn fitted_knobs(candidates: &[Knob], config: &AxisConfig, id: &AxisIdentification) -> Vec<Knob> {
    let mut knobs: Vec<Knob> = Vec::new();
    for v in id.values.iter().filter(|v| v.fitted()) {
        let within = |k: &&Knob| k.key == v.key && (k.min..=k.max).contains(&get(config, k.key));
        if let Some(k) = candidates.iter().find(within)
            && !knobs.iter().any(|q| q.key == k.key)
        {
            knobs.push(*k);
        }
    }
    knobs
}

/// [`on_top`]'s fit with the force, where it predicts the held-out halves better.
fn refitted(
    fit: &Fit,
    (template, unbent): (&AxisConfig, Option<&AxisConfig>),
    candidates: &[Knob],
    config: &AxisConfig,
    id: &AxisIdentification,
) -> Option<(AxisConfig, AxisIdentification)> {
    let (ctx, axis, offset) = (fit.ctx(), fit.axis(), fit.offset());
    // The controller's knobs as the fit's configuration has it (a family of its own, where
    // written without a template), besides the template's.
    let mut all = candidates.to_vec();
    all.extend(knobs::for_axis(config));
    let values = fitted_knobs(&all, config, id);
    let mut knobs = values.clone();
    knobs.push(HELD_AT_START);
    let fold = ctx.halves(offset);
    let bases = half_bases(fit, config, id, &fold)?;
    let starts: Vec<AxisConfig> = std::iter::once(config.clone())
        .chain(unbent_start(config, unbent, &values))
        .collect();
    // The values fitted again without the force too, from the same starts: both rounds'
    // halves scored with the force estimated on the half scored, so that what is compared is
    // what the machine's values predict, not what a value fitted on the samples scored takes.
    let (with_force, without) = rayon::join(
        || lowest_round(fit, knobs, &starts, &bases, &fold),
        || lowest_round(fit, values.clone(), &starts, &bases, &fold),
    );
    let ((round, base), without) = (with_force?, without?.0.estimating_held());
    let (with_m, without_m) = round.held_out_against(&without, fit, &fold)?;
    // And the values as the file holds them (no force at any start) must predict the held-out
    // halves no worse than those written before: that figure is the axis's, on the footing of
    // every other candidate's and the template's.
    let held_out_um = um_from_m(round.held_out_holding_none(fit, &fold)?);
    if !verdict::predicts_better(with_m, without_m) || held_out_um > id.held_out_identified_um {
        return None;
    }
    let written = round.config(&round.whole);
    let residual = fit.residual(&written)?;
    let mask = fit.mask();
    let mut with = id.clone();
    for v in fitted_values(&values, &round, &written, template) {
        if let Some(slot) = with.values.iter_mut().find(|s| s.key == v.key) {
            *slot = refitted_value(slot, v, &round.knobs);
        }
    }
    with.rms_identified_um = um_from_m(masked_rms(&residual, mask));
    // The fit refitted with the force is the one whose residual is said: whether it reaches
    // the record's noise is its own, not the fit's before.
    with.reached = within_noise(with.rms_identified_um, um_from_m(ctx.noise_sigma));
    with.held_out_identified_um = held_out_um;
    with.held_out_share = held_out_um / with.following_error_rms_um;
    with.better_than_template = verdict::predicts_better(held_out_um, with.held_out_template_um);
    with.largest_at = verdict::largest_at(ctx, axis, offset, &residual, mask);
    with.gain_per_inertia = gain_per_inertia(&round, config);
    with.held_at_start = reported(fit, &round, (&base, &written)).map(|h| HeldForce {
        held_out_with_um: um_from_m(with_m),
        held_out_refit_um: um_from_m(without_m),
        ..h
    });
    if id.while_moving.is_some() {
        let template_residual = fit.residual(template)?;
        with.while_moving = verdict::while_moving(fit, &round, &fold, &template_residual);
    }
    Some((written, with))
}

/// `found`, a fit judged at the record's noise without the force (`id.reached`, after
/// `verdict::judged`), where the force could take the place of its values: those fitted
/// again with it beside them (on the fit's samples, from its values and from `unbent`'s, the
/// lower kept). Started from the fit's own values, the refit explains those samples at least
/// as well — the noise it reaches is no evidence; what it says is where else the values can
/// stand. A determined value it moves beyond its uncertainty, by more than the noise alone
/// moves a value that trades with one more free one ([`moved_values`]), is one the record
/// cannot tell from a force held at its start — two hypotheses it does not decide —: not
/// determined alone, traded with the force, its uncertainty widened to the move; the force is
/// reported beside it, not kept (the values written stay the fit's: the file holds no
/// force). Else `found` as it is. Only where the record starts at rest, the fit uses the
/// axis's first start and the friction holds a force at rest.
pub(super) fn told_apart(
    fit: &Fit,
    unbent: Option<&AxisConfig>,
    candidates: &[Knob],
    found: (AxisConfig, AxisIdentification),
) -> (AxisConfig, AxisIdentification) {
    let (config, id) = &found;
    let tried = id.reached
        && id.held_at_start.is_none()
        && !id.held_out_in_sample
        && fit.holds_start(&|_| true)
        && holds_any(fit, config);
    if !tried {
        return found;
    }
    let mut all = candidates.to_vec();
    all.extend(knobs::for_axis(config));
    let values = fitted_knobs(&all, config, id);
    let mut knobs = values.clone();
    knobs.push(HELD_AT_START);
    let starts: Vec<AxisConfig> = std::iter::once(config.clone())
        .chain(unbent_start(config, unbent, &values))
        .collect();
    let lowest = starts
        .par_iter()
        .filter_map(|s| Some((fit.run(&knobs, s, &|_| true)?, s)))
        .min_by(|a, b| a.0.cost.total_cmp(&b.0.cost));
    let Some((with, start)) = lowest else {
        return found;
    };
    let moved = moved_values(&knobs, &with, id);
    if moved.is_empty() {
        return found;
    }
    let (config, mut id) = found;
    for v in &mut id.values {
        if let Some((_, shift)) = moved.iter().find(|(key, _)| *key == v.key) {
            v.uncertainty = v.uncertainty.max(*shift);
            v.determined = false;
            v.measured = false;
            v.traded_with = Some(HELD_AT_START.key);
        }
    }
    let refit = Fit::config(&knobs, start, &with.values);
    let p = knobs.len() - 1;
    let (force_n, level_n, at_level) = within_level(fit, &refit, start);
    id.held_at_start = Some(HeldForce {
        force_n,
        level_n,
        uncertainty_n: match at_level {
            true => f64::INFINITY,
            false => with.sigma[p].max(with.model_sigma[p]),
        },
        at_level,
        told_apart_from_values: false,
        ..not_kept(fit, &config)
    });
    (config, id)
}

/// The keys of `id`'s determined values that `with` (`knobs`' values fitted again beside the
/// force, on the same samples) moves beyond their uncertainty, with each move. Both fits see
/// the same noise: their difference is what the force takes, plus what noise alone moves a
/// value by once one more value trades with it — a spread of √(σ_with² − σ_fit²), the two
/// fits' statistical uncertainties, never above σ_with —, so a move counts only beyond
/// twice σ_with too, which noise alone passes at most about one time in twenty whatever
/// the trade (the value's reported uncertainty holds the model's floor, no measure of noise).
fn moved_values(
    knobs: &[Knob],
    with: &Fitted,
    id: &AxisIdentification,
) -> Vec<(&'static str, f64)> {
    id.values
        .iter()
        .filter(|v| v.determined && v.uncertainty.is_finite())
        .filter_map(|v| {
            let p = knobs.iter().position(|k| k.key == v.key)?;
            let shift = (with.values[p] - v.value).abs();
            moved(shift, v.uncertainty, with.sigma[p]).then_some((v.key, shift))
        })
        .collect()
}

/// `knobs` fitted on the whole record from each of `starts`, and their round (each half's
/// fit made about its own base of `bases`) from where the whole fit that ends lowest on the
/// fit's own samples landed — never chosen by a held-out figure —, with that point. One
/// start: its round, from it.
fn lowest_round(
    fit: &Fit,
    knobs: Vec<Knob>,
    starts: &[AxisConfig],
    bases: &[AxisConfig; 2],
    fold: &[bool],
) -> Option<(Round, AxisConfig)> {
    let start = match starts {
        [one] => one.clone(),
        _ => {
            starts
                .par_iter()
                .filter_map(|s| {
                    let whole = fit.run(&knobs, s, &|_| true)?;
                    Some((whole.cost, Fit::config(&knobs, s, &whole.values)))
                })
                .min_by(|a, b| a.0.total_cmp(&b.0))?
                .1
        }
    };
    let round = Round::fit_apart(fit, knobs, &start, bases.clone(), fold)?;
    Some((round, start))
}

/// The start at `unbent`'s values of `knobs` (the values fitted on every sample), the rest
/// `config`'s (the fit's ripple, bristles and values not fitted), where `unbent` is of
/// `config`'s structure (its controller and knobs) and its values differ; none otherwise.
fn unbent_start(
    config: &AxisConfig,
    unbent: Option<&AxisConfig>,
    knobs: &[Knob],
) -> Option<AxisConfig> {
    let unbent = unbent?;
    let keys = |c: &AxisConfig| -> Vec<&str> { knobs::for_axis(c).iter().map(|k| k.key).collect() };
    let same = std::mem::discriminant(&unbent.controller)
        == std::mem::discriminant(&config.controller)
        && keys(unbent) == keys(config);
    let values: Vec<f64> = knobs.iter().map(|k| get(unbent, k.key)).collect();
    let differ = knobs
        .iter()
        .zip(&values)
        .any(|(k, v)| get(config, k.key) != *v);
    (same && differ).then(|| Fit::config(knobs, config, &values))
}

/// What each half's fits start from besides the values fitted ([`Round::fit_apart`]; the
/// first half's samples are those `fold` marks): `config` with, where the axis's fit `id`
/// wrote them, the bristles' shape and the ripple that half's own samples give. Started
/// from the whole fit's, a half's held-out figure would have seen the other half's samples.
/// None where a half's cannot be simulated.
fn half_bases(
    fit: &Fit,
    config: &AxisConfig,
    id: &AxisIdentification,
    fold: &[bool],
) -> Option<[AxisConfig; 2]> {
    let bristles = id.presliding.as_ref().is_some_and(|p| p.written);
    let ripple = id.force_ripple.as_ref().is_some_and(|r| r.written);
    let mask = fit.mask();
    let base = |h: usize| -> Option<AxisConfig> {
        let own = |k: usize| mask[k] && fold[k] == (h == 0);
        let mut c = config.clone();
        if bristles {
            c = presliding::own_shape(fit, &c, &own)?;
        }
        if ripple {
            c = ripple::own_ripple(fit, &c, &own).ok()?;
        }
        Some(c)
    };
    let (first, second) = rayon::join(|| base(0), || base(1));
    Some([first?, second?])
}

/// The force held at the start as `round` (which fits it, from `base`) put it into `config`.
/// At the friction's level at rest (of either: the search's bound is `base`'s) the record
/// bounds it from one side only: no uncertainty, not determined.
fn reported(
    fit: &Fit,
    round: &Round,
    (base, config): (&AxisConfig, &AxisConfig),
) -> Option<HeldForce> {
    let p = round
        .knobs
        .iter()
        .position(|k| k.key == HELD_AT_START.key)?;
    let (force_n, level_n, at_level) = within_level(fit, config, base);
    // The half without the start kept the whole fit's force: the halves' difference is the
    // start half's step from it whole, not half of two halves' independent spread.
    let apart = (round.halves[0].values[p] - round.halves[1].values[p]).abs();
    let uncertainty_n = if at_level {
        f64::INFINITY
    } else {
        round.whole.sigma[p]
            .max(round.whole.model_sigma[p])
            .max(apart)
    };
    Some(HeldForce {
        force_n,
        uncertainty_n,
        level_n,
        determined: HELD_AT_START.determines(uncertainty_n, force_n),
        at_level,
        kept: true,
        held_out_with_um: f64::NAN,
        held_out_refit_um: f64::NAN,
        told_apart_from_values: true,
    })
}

/// Where [`on_top`] tried the force and did not keep it: none, said so.
fn not_kept(fit: &Fit, config: &AxisConfig) -> HeldForce {
    HeldForce {
        force_n: 0.0,
        uncertainty_n: f64::NAN,
        level_n: weaker_level_n(fit, config),
        determined: false,
        at_level: false,
        kept: false,
        held_out_with_um: f64::NAN,
        held_out_refit_um: f64::NAN,
        told_apart_from_values: true,
    }
}

/// `config` as written: the force a record's start held is that record's, not the machine's.
pub(super) fn unwritten(mut config: AxisConfig) -> AxisConfig {
    config.held_at_start_n = 0.0;
    config
}

/// Whether friction holds the axis at its start with `config` either way.
fn holds_any(fit: &Fit, config: &AxisConfig) -> bool {
    fit.held_level_n(config).iter().any(|&level| level > 0.0)
}

/// The weaker of the friction's levels at rest at the start with `config` (N): a force held
/// there that friction kept lies within it whichever way it pushes.
fn weaker_level_n(fit: &Fit, config: &AxisConfig) -> f64 {
    let [plus, minus] = fit.held_level_n(config);
    plus.min(minus)
}

/// `config`'s force held at the start, within the friction's level at rest on its side
/// (towards + where it pushes towards +); that level (N); and whether the force lies at it —
/// at the search's bound, the lower of that level and the one at `start`, where the search
/// began: bounded from one side only.
fn within_level(fit: &Fit, config: &AxisConfig, start: &AxisConfig) -> (f64, f64, bool) {
    let [plus, minus] = fit.held_level_n(config);
    let force_n = config.held_at_start_n.clamp(-minus, plus);
    let side = |[plus, minus]: [f64; 2]| if force_n < 0.0 { minus } else { plus };
    let level_n = side([plus, minus]);
    let bound_n = level_n.min(side(fit.held_level_n(start)));
    (force_n, level_n, force_n.abs() >= bound_n * (1.0 - 1e-6))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};

    /// A straight-line fit of one value `a` on a regressor, alone and again beside a second
    /// regressor whose true weight is zero (a force the record does not hold) and which
    /// correlates with the first by `rho`, on unit noise: noise alone moves `a` between the
    /// two fits by a spread of √(σ₂² − σ₁²) ≤ σ₂, so it passes twice σ₂ at most about one
    /// time in twenty (a normal's two-sided 4.6 %), however close the trade. The value's
    /// uncertainty is taken as its statistical one, the least the tool reports (its model's
    /// floor only widens it): the worst case. Counted over 4,000 records for each of four
    /// correlations, under 6 % (the count's own scatter is 0.3 %); a move counted beyond the
    /// value's uncertainty alone passes 18 % at a correlation of 0.7.
    #[test]
    fn noise_alone_counts_as_a_move_at_most_about_once_in_twenty() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(11);
        let mut normal = || -> f64 { StandardNormal.sample(&mut rng) };
        let n = 200;
        for rho in [0.3_f64, 0.7, 0.9, 0.99] {
            let u: Vec<f64> = (0..n).map(|_| normal()).collect();
            let w: Vec<f64> = u
                .iter()
                .map(|&ui| rho * ui + (1.0 - rho * rho).sqrt() * normal())
                .collect();
            let dot = |x: &[f64], y: &[f64]| -> f64 { x.iter().zip(y).map(|(a, b)| a * b).sum() };
            let (uu, ww, uw) = (dot(&u, &u), dot(&w, &w), dot(&u, &w));
            let det = uu * ww - uw * uw;
            let (sigma_1, sigma_2) = (uu.recip().sqrt(), (ww / det).sqrt());
            let trials = 4000;
            let mut moves = 0;
            for _ in 0..trials {
                let y: Vec<f64> = u.iter().map(|&ui| ui + normal()).collect();
                let (uy, wy) = (dot(&u, &y), dot(&w, &y));
                let alone = uy / uu;
                let beside = (ww * uy - uw * wy) / det;
                if moved((beside - alone).abs(), sigma_1, sigma_2) {
                    moves += 1;
                }
            }
            let share = moves as f64 / trials as f64;
            assert!(share < 0.06, "correlation {rho}: {share}");
        }
    }

    /// A shift beyond both bounds counts; one within the value's own uncertainty, or within
    /// twice the refit's, does not.
    #[test]
    fn a_move_counts_only_beyond_both_bounds() {
        assert!(moved(3.0, 1.0, 1.0));
        assert!(!moved(0.9, 1.0, 0.1));
        assert!(!moved(1.5, 1.0, 1.0));
    }
    use crate::machine::{Controller, MachineConfig};

    #[test]
    fn the_second_start_takes_the_values_fitted_on_every_sample_where_the_structure_is_one() {
        let config = MachineConfig::preset("small-table").unwrap().x;
        let keys = [knobs::TF_GAIN_KEY, knobs::MASS_KEY];
        let chosen: Vec<Knob> = knobs::for_axis(&config)
            .into_iter()
            .filter(|k| keys.contains(&k.key))
            .collect();
        assert_eq!(chosen.len(), 2);
        // Fitted on every sample: a gain half as high again and a table twice as heavy, and a
        // ripple the fit away from the standstills does not have.
        let mut unbent = config.clone();
        let values = [1.5 * get(&config, keys[0]), 2.0 * get(&config, keys[1])];
        knobs::set_all(&mut unbent, &keys, &values);
        unbent.errors.force_ripple_n = 7.0;
        let start = unbent_start(&config, Some(&unbent), &chosen).expect("one structure");
        for (key, value) in keys.iter().zip(values) {
            let got = get(&start, key);
            assert!(
                (got - value).abs() <= 1e-12 * value,
                "{key}: {got} against {value}"
            );
        }
        // What the refit does not fit stays the fit's own.
        assert_eq!(start.errors.force_ripple_n, config.errors.force_ripple_n);
        // The same values, or none given: no second start.
        assert!(unbent_start(&config, Some(&config), &chosen).is_none());
        assert!(unbent_start(&config, None, &chosen).is_none());
        // Another controller's values mean other things: no start from them.
        let mut other = unbent.clone();
        other.controller = Controller::Cascade;
        assert!(unbent_start(&config, Some(&other), &chosen).is_none());
    }
}
