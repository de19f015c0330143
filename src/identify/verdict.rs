//! How a fit is judged: by what it predicts of the record's held-out halves, against the
//! template and against the plain regression of [`super::baseline`] — not by the record's
//! noise, which no model of a real machine reaches — and where the residual it leaves is
//! largest, so that a user knows what the written model misses.

use serde::Serialize;

use super::AxisIdentification;
use super::round::Round;
use super::solve::Fit;
use crate::compare::Context;
use crate::machine::{AxisConfig, AxisName};
use crate::numeric::units::um_from_m;

/// How much better on the held-out halves a model with more values fitted must predict than
/// one with fewer to be kept over it — by more than a twentieth —: a fit over the template,
/// a corner free over the design's, a higher order of a loop model, a round's loose values
/// over the round with them put back, the nonlinear parts on top. One rule for all.
pub(crate) const HELD_OUT_GAIN: f64 = 0.95;
/// How long around a start, stop or reversal of the command counts as "at" it (s).
const NEAR_EVENT_S: f64 = 0.05;
/// Share of the peak acceleration above which the command counts as accelerating, and of
/// the peak speed below which it counts as standing.
const ACCELERATING_SHARE: f64 = 0.1;
const STANDING_SHARE: f64 = 0.01;

/// Where a residual is largest: the kind of motion whose samples it is largest at, by RMS.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Place {
    /// Within 50 ms of the command starting, stopping or reversing.
    StartsStopsReversals,
    /// While the command accelerates.
    Accelerating,
    /// At steady speed.
    SteadySpeed,
    /// Where the command stands.
    Standstill,
}

impl Place {
    const ALL: [Place; 4] = [
        Place::StartsStopsReversals,
        Place::Accelerating,
        Place::SteadySpeed,
        Place::Standstill,
    ];

    /// In words, after "largest".
    pub(crate) fn describe(self) -> &'static str {
        match self {
            Place::StartsStopsReversals => "at starts, stops and reversals",
            Place::Accelerating => "while accelerating",
            Place::SteadySpeed => "at steady speed",
            Place::Standstill => "at standstill",
        }
    }
}

/// A fit on every sample scored on the samples while its axis moves (away from the
/// standstills, where an axis with integral action hunts): the held-out figures there,
/// beside the whole record's.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WhileMoving {
    /// The template's residual on those samples (µm RMS).
    pub held_out_template_um: f64,
    /// Each half's fit scored on the other half's samples among them (µm RMS).
    pub held_out_identified_um: f64,
    /// The following error's RMS on them (µm).
    pub following_error_rms_um: f64,
    /// `held_out_identified_um` as a share of it.
    pub held_out_share: f64,
}

impl AxisIdentification {
    /// The held-out figures the axis is judged by, as (the template's, the fit's, the
    /// following error's, the fit's share of it) in µm: the whole record's, or those while
    /// moving where it is judged on them.
    pub fn judged_held_out(&self) -> (f64, f64, f64, f64) {
        match (&self.while_moving, self.judged_while_moving) {
            (Some(m), true) => (
                m.held_out_template_um,
                m.held_out_identified_um,
                m.following_error_rms_um,
                m.held_out_share,
            ),
            _ => (
                self.held_out_template_um,
                self.held_out_identified_um,
                self.following_error_rms_um,
                self.held_out_share,
            ),
        }
    }
}

/// How far above the noise a fit at the noise may predict its held-out halves and count as
/// reaching it whatever the template predicts: values the record determines predict the
/// other half to about the noise (the model's floor adds a quarter of it in squares);
/// halves that miss each other by twice it carry a systematic part of √3 times the noise.
const HALVES_EXCESS: f64 = 2.0;

/// Whether a fit at the noise (`noise_um`) on every sample is kept and written: where its
/// halves predict each other within [`HALVES_EXCESS`] of the noise (its values determined),
/// or better than the template predicts them by the twentieth a fit must earn over it; else
/// where they do so while moving — and then it is judged by its held-out figures while
/// moving (`while_moving`, beside the whole record's): at standstill an axis that hunts
/// follows a limit cycle whose phase no model times, each half's fit its own way. Whichever
/// figure keeps it, where its halves miss each other there by more than [`HALVES_EXCESS`]
/// of the noise the record has not pinned its values down: they are written because they
/// predict, loose (`IdentifiedValue::loose`: neither determined nor measurements), and the
/// fit is not counted as reaching the noise. Otherwise it has not reached the noise: marked
/// so, it is judged as a fit above it (the fit while moving, and what each predicts).
pub(crate) fn judged_while_moving(id: &mut AxisIdentification, noise_um: f64) -> bool {
    let held_out = id.held_out_identified_um;
    if held_out <= HALVES_EXCESS * noise_um {
        return true;
    }
    if predicts_better(held_out, id.held_out_template_um) {
        id.better_than_template = true;
        written_loose(id);
        return true;
    }
    let Some(moving) = id.while_moving.as_ref() else {
        id.reached = false;
        return false;
    };
    if !predicts_better(moving.held_out_identified_um, moving.held_out_template_um) {
        id.reached = false;
        return false;
    }
    id.judged_while_moving = true;
    id.better_than_template = true;
    if moving.held_out_identified_um > HALVES_EXCESS * noise_um {
        written_loose(id);
    }
    true
}

/// A fit on the samples while moving, judged as [`judged_while_moving`] judges one on every
/// sample where it reached the noise: it keeps reaching it only where its halves predict
/// each other within [`HALVES_EXCESS`] of the noise.
pub(crate) fn judged(
    (config, mut id): (AxisConfig, AxisIdentification),
    noise_um: f64,
) -> (AxisConfig, AxisIdentification) {
    if id.reached {
        judged_while_moving(&mut id, noise_um);
    }
    (config, id)
}

/// Whether a value's `shift` between a fit and the same fit with one more value free counts
/// as a move the record makes, not its noise: beyond the value's reported `uncertainty` in
/// the fit with fewer values, and beyond twice `freer_sigma`, its statistical uncertainty in
/// the fit with more. Noise alone moves a value by √(σ_freer² − σ_fit²) once one more value
/// trades with it, never above σ_freer, so it passes this at most about one time in twenty
/// whatever the trade (`held::tests` counts it).
pub(crate) fn moved(shift: f64, uncertainty: f64, freer_sigma: f64) -> bool {
    shift > uncertainty && shift > 2.0 * freer_sigma
}

/// A fit whose halves miss each other by more than the noise allows, written because it
/// predicts: not reaching the noise, and none of its values determined or measured.
fn written_loose(id: &mut AxisIdentification) {
    id.reached = false;
    for v in id.values.iter_mut().filter(|v| v.determined) {
        v.determined = false;
        v.measured = false;
        v.loose = true;
    }
}

/// The template's and `round`'s held-out residuals and the following error on the samples
/// `fit` compares while the axis moves: `template_residual` is the template's.
pub(crate) fn while_moving(
    fit: &Fit,
    round: &Round,
    fold: &[bool],
    template_residual: &[f64],
) -> Option<WhileMoving> {
    let (ctx, axis, offset) = (fit.ctx(), fit.axis(), fit.offset());
    let mask: Vec<bool> = super::moving_samples(ctx, axis, offset)
        .iter()
        .zip(fit.mask())
        .map(|(a, b)| *a && *b)
        .collect();
    let identified = round.held_out_rms_on(fit, fold, &mask)?;
    let template = super::solve::masked_rms(template_residual, &mask);
    let following = super::following_error_rms(ctx, axis, offset, &mask);
    let [template, identified, following] = [template, identified, following].map(um_from_m);
    Some(WhileMoving {
        held_out_template_um: template,
        held_out_identified_um: identified,
        following_error_rms_um: following,
        held_out_share: identified / following,
    })
}

/// Whether a model that predicts the held-out halves to `more_rms` (RMS; more values
/// fitted) is kept over one that predicts them to `fewer_rms` (in the same unit, µm or m):
/// by [`HELD_OUT_GAIN`].
pub(crate) fn predicts_better(more_rms: f64, fewer_rms: f64) -> bool {
    more_rms < HELD_OUT_GAIN * fewer_rms
}

/// The kind of motion at each command period of `axis`.
fn places(ctx: &Context, axis: AxisName) -> Vec<Place> {
    let c = ctx.commands.axis(axis);
    let peak_v = c.vel_m_per_s.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let peak_a = c.acc_m_per_s2.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let direction: Vec<i8> = c
        .vel_m_per_s
        .iter()
        .map(|v| {
            if v.abs() <= STANDING_SHARE * peak_v {
                0
            } else if *v > 0.0 {
                1
            } else {
                -1
            }
        })
        .collect();
    // Periods within NEAR_EVENT_S of a change of direction (standing counts as one).
    let reach = (NEAR_EVENT_S / ctx.dt).ceil() as usize;
    let mut near = vec![false; direction.len()];
    for k in 1..direction.len() {
        if direction[k] != direction[k - 1] {
            let (lo, hi) = (k.saturating_sub(reach), (k + reach).min(direction.len()));
            near[lo..hi].iter_mut().for_each(|n| *n = true);
        }
    }
    (0..direction.len())
        .map(|k| {
            if near[k] {
                Place::StartsStopsReversals
            } else if direction[k] == 0 {
                Place::Standstill
            } else if c.acc_m_per_s2[k].abs() > ACCELERATING_SHARE * peak_a {
                Place::Accelerating
            } else {
                Place::SteadySpeed
            }
        })
        .collect()
}

/// Where `residual` (at the context's compared samples, zero where not compared) is
/// largest among the samples `mask` allows; none without samples.
pub(crate) fn largest_at(
    ctx: &Context,
    axis: AxisName,
    offset_s: f64,
    residual: &[f64],
    mask: &[bool],
) -> Option<Place> {
    let places = places(ctx, axis);
    let mut sums = [(0.0f64, 0usize); 4];
    for (k, &i) in ctx.samples.iter().enumerate() {
        if !(mask.get(k).copied().unwrap_or(false) && ctx.compared(axis, k)) {
            continue;
        }
        let period = (ctx.prog_time(i, offset_s) / ctx.dt).round();
        let place = if period >= 0.0 {
            places.get(period as usize).copied()
        } else {
            None
        };
        let place = place.unwrap_or(Place::Standstill);
        let slot = Place::ALL.iter().position(|p| *p == place).unwrap_or(3);
        sums[slot].0 += residual[k] * residual[k];
        sums[slot].1 += 1;
    }
    Place::ALL
        .iter()
        .zip(sums)
        .filter(|(_, (_, n))| *n > 0)
        .map(|(p, (ss, n))| (*p, (ss / n as f64).sqrt()))
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(p, _)| p)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::IdentifiedValue;

    #[test]
    fn a_fit_is_written_where_it_predicts_better_by_a_twentieth() {
        assert!(predicts_better(11.0, 128.0));
        assert!(predicts_better(0.94, 1.0));
        assert!(!predicts_better(0.96, 1.0));
        assert!(!predicts_better(1.2, 1.0));
    }

    #[test]
    fn halves_that_miss_each_other_leave_values_loose_on_the_whole_record_too() {
        let noise_um = 0.06;
        // At the noise on every sample; its halves predict each other to 0.2 µm, 3.3 times
        // the noise (beyond the 2 that determined values reach), a fifth of the template's
        // 1.0 µm: written as a model, but no value is determined.
        let mut id = AxisIdentification::scored(1.0, 0.2);
        id.rms_identified_um = noise_um;
        id.values = vec![IdentifiedValue::fitted_gain(false)];
        assert!(judged_while_moving(&mut id, noise_um));
        assert!(!id.reached && id.better_than_template && !id.judged_while_moving);
        let v = &id.values[0];
        assert!(v.loose && !v.determined && !v.measured, "{v:?}");
        let said = super::super::report::verdict(&id, noise_um).expect("a verdict");
        assert!(said.contains("more than twice the noise"), "{said}");
        assert!(!said.contains("while moving"), "{said}");
        // The same halves of a fit that stays above the noise on every sample (0.2 µm, 3.3
        // times it): the model lacks something, and its loose value is said as well.
        id.rms_identified_um = 0.2;
        let said = super::super::report::verdict(&id, noise_um).expect("a verdict");
        assert!(!said.contains("follows the record to its noise"), "{said}");
        assert!(
            said.contains("lacks something") && said.contains("loose"),
            "{said}"
        );
        // Within twice the noise (0.11 µm), the same value stays determined and reached.
        let mut close = AxisIdentification::scored(1.0, 0.11);
        close.values = vec![IdentifiedValue::fitted_gain(false)];
        assert!(judged_while_moving(&mut close, noise_um));
        assert!(close.reached && close.values[0].determined && !close.values[0].loose);
        // Better than the template by less than a twentieth (0.97 against 1.0), with nothing
        // while moving: not kept, not reached, and nothing is determined by it.
        let mut barely = AxisIdentification::scored(1.0, 0.97);
        barely.values = vec![IdentifiedValue::fitted_gain(false)];
        assert!(!judged_while_moving(&mut barely, noise_um));
        assert!(!barely.reached);
    }

    #[test]
    fn a_fit_while_moving_at_the_noise_is_held_to_its_halves_as_well() {
        let noise_um = 0.06;
        // Reached on the moving samples, its halves 0.2 µm apart (3.3 times the noise):
        // not reached, its value loose; 0.1 µm apart (within twice it): as it was.
        let config = crate::machine::MachineConfig::default_preset().x;
        for (apart_um, pinned) in [(0.2, false), (0.1, true)] {
            let mut id = AxisIdentification::scored(1.0, apart_um);
            id.moving_only = true;
            id.values = vec![IdentifiedValue::fitted_gain(false)];
            let (_, id) = judged((config.clone(), id), noise_um);
            assert_eq!(id.reached, pinned, "{apart_um} µm");
            assert_eq!(id.values[0].determined, pinned, "{apart_um} µm");
            assert_eq!(id.values[0].loose, !pinned, "{apart_um} µm");
        }
    }
}
