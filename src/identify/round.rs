//! A round of fits: some knobs fitted on the whole record and on each half, with the
//! uncertainties both give; and the rounds by which the values the record does not
//! determine go back to the template's.

use std::sync::OnceLock;

use super::knobs::{self, Knob, get, set_all};
use super::solve::{Fit, Fitted};
use super::verdict::{self, predicts_better};
use super::within_noise;
use crate::machine::AxisConfig;

/// How close to the record's noise the fit with a loose corner free must predict the
/// held-out halves for the corner to stay (besides predicting them better than with the
/// design's corner, as every larger model must): a corner the noise leaves loose is kept
/// only because the fit with it reaches the noise where the design's does not, so it must
/// reach it on the samples each half's fit did not see as well — or, where no half's search
/// left the whole fit's point, on every sample ([`compared_rms_m`] at the noise). Values
/// the record determines predict the other half to about the noise (the model's floor adds
/// a quarter of it in squares); halves that miss each other by twice it carry a systematic
/// part of √3 times the noise — the loose corner wandered with the gain on each half, and
/// the fit at the noise on every sample had it follow the noise.
const HELD_OUT_EXCESS: f64 = 2.0;

/// One half's fit scored on the samples of the other half: the residual's sum of squares
/// (m²), the samples counted, and whether the half's search found a point of its own
/// (`Fitted::own_point`; where it did not, the residual is the whole fit's, in-sample).
#[derive(Clone, Copy, Debug)]
struct HalfScore {
    ss_m2: f64,
    n: usize,
    own_point: bool,
}

/// The held-out RMS (m) of two rounds, the `larger` (more values fitted) and the
/// `smaller`, each over the same halves: those where the larger round's fit found a point
/// of its own. A half whose search stayed at the whole fit's values scores its round on
/// samples that round was fitted to; left in, it would let the larger model win on
/// samples it saw. The smaller round is scored on those same halves whether or not its own
/// fit moved there: its in-sample halves raise the bar, so the burden of proof stays on
/// the larger model (which can lose where it predicts its held-out halves better), and
/// every half the larger round does hold out counts, however badly it predicts.
///
/// Where the larger round holds out no half, both halves count for both. At the noise (the
/// corner check) that is the common case, not a leak: a half's search moves only by a step
/// of a tenth of a value's uncertainty or its search floor, which on a long clean record
/// the halves' noise does not reach, and there a fit's in-sample and held-out figures
/// differ by a few values' share of the samples. Above the noise it lets the larger
/// round's in-sample figure count (docs/identify.md says so). Refusing it there (the larger
/// round then loses to a smaller one that holds out a half) was tried: on a record without
/// the acceleration feed-forward the template has, Y's round with Coulomb friction, both its
/// halves at its whole fit's point, lost that way to the round without it, whose one moved
/// half held out 1.52 µm; the rest fitted again carried the friction as twenty times the
/// template's viscous friction and a table twenty times as heavy, and the file written
/// predicted another program worse than the template. One half held out by the smaller
/// round says no more of what the larger model predicts than the larger round's in-sample
/// pair. (Taking the larger round by its count of values, not by which is `self`, changes
/// only the corner check, and changed nothing on that record.) None where no half counts a
/// sample.
fn compared_rms_m(larger: [HalfScore; 2], smaller: [HalfScore; 2]) -> Option<(f64, f64)> {
    let rms_over = |s: &[HalfScore; 2], counted: [bool; 2]| -> Option<f64> {
        let (mut ss, mut n) = (0.0, 0usize);
        for h in (0..2).filter(|&h| counted[h]) {
            ss += s[h].ss_m2;
            n += s[h].n;
        }
        (n > 0).then(|| (ss / n as f64).sqrt())
    };
    let held_out = [0, 1].map(|h| larger[h].own_point);
    rms_over(&larger, held_out)
        .zip(rms_over(&smaller, held_out))
        .or_else(|| rms_over(&larger, [true, true]).zip(rms_over(&smaller, [true, true])))
}

/// The fits of some knobs on the whole record and on each half.
pub(super) struct Round {
    pub(super) knobs: Vec<Knob>,
    pub(super) whole: Fitted,
    pub(super) halves: [Fitted; 2],
    /// Standard uncertainties: the Jacobian's, widened to half the halves' disagreement —
    /// a fit that lands elsewhere on each half (a valley of the hybrid model's residual,
    /// a value traded against another) is not known better than that, however sharp the
    /// local curvature.
    pub(super) sigma: Vec<f64>,
    /// The values the round was fitted about (those of the knobs not fitted in it).
    base: AxisConfig,
    /// Those each half's fit was made about: the round's `base` but where a half carries
    /// values of its own fitted on its samples alone ([`Round::fit_apart`]).
    half_bases: [AxisConfig; 2],
    /// Each half's fit simulated over the whole record (the residual at every compared
    /// sample), about the round's own `base`: every held-out figure of the round reads
    /// these, simulated once — no call can ask them about another base.
    halves_simulated: OnceLock<Option<[Vec<f64>; 2]>>,
    /// Whether a half's fit is scored with the force held at the record's start estimated on
    /// the half scored ([`Round::scored_config`]): a round that fits that force, or one
    /// compared with such a round on the same footing.
    estimates_held: bool,
    /// Values this round fits that moved when a value the record left loose was put back to
    /// the template's in an earlier round at the noise ([`Round::put_back`]): each with the
    /// key put back and how far it moved. Fitted about the template's value of a knob they
    /// trade with, they are not determined alone.
    put_back_trades: Vec<PutBackTrade>,
}

/// A value that moved beyond what noise explains when `with` was put back to the template's.
#[derive(Clone, Copy, Debug)]
struct PutBackTrade {
    key: &'static str,
    with: &'static str,
    shift: f64,
}

impl Round {
    pub(super) fn fit(
        fit: &Fit,
        knobs: Vec<Knob>,
        base: &AxisConfig,
        fold: &[bool],
    ) -> Option<Round> {
        Round::fit_apart(fit, knobs, base, [base.clone(), base.clone()], fold)
    }

    /// [`Round::fit`] with each half's fit made about `half_bases` (the first half's samples
    /// are those `fold` marks): values fitted on a half's own samples beforehand (a ripple)
    /// stay its own, so that its held-out figure has not seen the other half's.
    ///
    /// The force held at the record's start ([`knobs::HELD_AT_START`]), where among the
    /// knobs, is fitted by the whole fit and the half that holds the start; the other half
    /// keeps the whole fit's ([`Fit::run`]).
    pub(super) fn fit_apart(
        fit: &Fit,
        knobs: Vec<Knob>,
        base: &AxisConfig,
        half_bases: [AxisConfig; 2],
        fold: &[bool],
    ) -> Option<Round> {
        let whole = fit.run(&knobs, base, &|_| true)?;
        // Each half's fit starts where the whole record's landed: their difference then
        // measures how far the halves pull the values apart, not which valley a search
        // from further off happens to fall into on one of them.
        let landed = |b: &AxisConfig| Fit::config(&knobs, b, &whole.values);
        let (a, b) = rayon::join(
            || fit.run(&knobs, &landed(&half_bases[0]), &|i| fold[i]),
            || fit.run(&knobs, &landed(&half_bases[1]), &|i| !fold[i]),
        );
        let (a, b) = (a?, b?);
        let sigma = (0..knobs.len())
            .map(|j| whole.sigma[j].max(0.5 * (a.values[j] - b.values[j]).abs()))
            .collect();
        let estimates_held = knobs.iter().any(|k| k.key == knobs::HELD_AT_START.key);
        Some(Round {
            knobs,
            whole,
            halves: [a, b],
            sigma,
            base: base.clone(),
            half_bases,
            estimates_held,
            halves_simulated: OnceLock::new(),
            put_back_trades: Vec::new(),
        })
    }

    /// `knobs` fitted from `start`, then those the record does not determine put back to
    /// the template's values and the rest fitted again (until all left are determined).
    /// Returns the last round and the values it was fitted about.
    ///
    /// A corner put back is the design's, and the design's is a guess the record can refute:
    /// where the fit with the corner free reached the noise, the fit with the design's corner
    /// does not, and the fit with the corner kept (the rest that is undetermined put back)
    /// predicts the held-out halves within twice the noise and better than it by more than a
    /// twentieth, the record excludes the design's value even though it leaves the corner
    /// looser than its 5 % — the corner stays where the fit put it, a model's value (not a
    /// measurement). (Where the halves' fits of a loose corner wander with the gain and
    /// predict each other worse, or miss each other by more than twice the noise, it goes
    /// back.)
    pub(super) fn fit_determined(
        fit: &Fit,
        knobs: &[Knob],
        start: &AxisConfig,
        template: &AxisConfig,
        fold: &[bool],
    ) -> Option<(Round, AxisConfig)> {
        let base = start.clone();
        let round = Round::fit(fit, knobs.to_vec(), &base, fold)?;
        Round::settled(fit, (round, base), template, fold, &[])
    }

    /// The rounds of [`Round::fit_determined`] from `round`, the corners `refuted` kept
    /// fitted. Where putting a loose corner back leaves the noise, both ways are followed to
    /// their end and the corner kept only where that way predicts the held-out halves within
    /// twice the noise, and better than the design's way by more than a twentieth.
    fn settled(
        fit: &Fit,
        (mut round, mut base): (Round, AxisConfig),
        template: &AxisConfig,
        fold: &[bool],
        refuted: &[&'static str],
    ) -> Option<(Round, AxisConfig)> {
        loop {
            // Above the noise the model is not the machine: a corner only the model's floor
            // leaves loose stays where the fit put it (`Knob::stays_fitted`).
            let reached = round.reaches_noise(fit);
            let undetermined: Vec<&'static str> = round
                .undetermined(!reached)
                .into_iter()
                .filter(|k| !refuted.contains(k))
                .collect();
            if undetermined.is_empty() || round.knobs.is_empty() {
                return Some((round, base));
            }
            let next = round.put_back(fit, &base, &undetermined, template, fold)?;
            // Above the noise the fit is judged by what it predicts: values the record
            // leaves loose (a gain and a mass trading along their ratio) stay only where
            // the round that has them predicts the held-out halves better than the rest
            // fitted again without them, by the twentieth every larger model must earn.
            // Put back one round after another regardless, they left the template's values
            // predicting the record several times worse than the round that had them. The
            // loose values kept are marked traded (`Round::traded_with`).
            if !reached && round.predicts_better_than(&next.0, fit, fold) {
                return Some((round, base));
            }
            let corners: Vec<&'static str> = undetermined
                .iter()
                .copied()
                .filter(|k| knobs::corner_of(k).is_some())
                .collect();
            if !reached || corners.is_empty() || next.0.reaches_noise(fit) {
                (round, base) = next;
                continue;
            }
            // The design's corners leave the noise: the other way keeps them where the fit
            // put them and puts back only the rest.
            let design_way = Round::settled(fit, next, template, fold, refuted)?;
            let rest: Vec<&'static str> = undetermined
                .into_iter()
                .filter(|k| !corners.contains(k))
                .collect();
            let kept = if rest.is_empty() {
                Some((round, base))
            } else {
                round.put_back(fit, &base, &rest, template, fold)
            };
            let refuted: Vec<&'static str> = refuted.iter().copied().chain(corners).collect();
            let kept_way = kept.and_then(|k| Round::settled(fit, k, template, fold, &refuted));
            // Held-out figures, so twice the noise ([`HELD_OUT_EXCESS`]) and not
            // `within_noise`'s tenth above it, which is for a fit on its own samples: a
            // half's fit scored on samples it did not see carries their noise as well.
            let noise_m = fit.ctx().noise_sigma;
            return Some(match kept_way {
                Some(k)
                    if k.0.held_out_against(&design_way.0, fit, fold).is_some_and(
                        |(free_m, design_m)| {
                            free_m <= HELD_OUT_EXCESS * noise_m && predicts_better(free_m, design_m)
                        },
                    ) =>
                {
                    k
                }
                _ => design_way,
            });
        }
    }

    /// `keys` of this round put back to `template`'s values in `base` and the other knobs
    /// fitted again about it: the new round and its base.
    fn put_back(
        &self,
        fit: &Fit,
        base: &AxisConfig,
        keys: &[&'static str],
        template: &AxisConfig,
        fold: &[bool],
    ) -> Option<(Round, AxisConfig)> {
        let mut base = base.clone();
        let values: Vec<f64> = keys.iter().map(|k| get(template, k)).collect();
        set_all(&mut base, keys, &values);
        let kept = self
            .knobs
            .iter()
            .copied()
            .filter(|k| !keys.contains(&k.key))
            .collect();
        let mut round = Round::fit(fit, kept, &base, fold)?;
        round.put_back_trades = self.trades_after_putting_back(&round, keys, fit);
        Some((round, base))
    }

    /// The values of `next` (this round with `keys` put back to the template's) that trade
    /// with a key put back: those of this round's trades still fitted, and — where this round
    /// reaches the noise, so that its values are the record's and `next`'s would be called
    /// measurements — each value `next` moves from this round's beyond what noise explains
    /// ([`verdict::moved`]: beyond its uncertainty in `next`, the model's floor included, and
    /// twice its statistical one here). The template's value of a loose corner can lie as
    /// far from the machine's as the record leaves it loose, and the values that trade with
    /// it follow it there: a lead-lag table whose pole the record put at 64 ± 12 Hz, put back
    /// to its design's 80 Hz, took its upper zero from 14.5 ± 0.6 Hz (the run's 14.4) to
    /// 16.2 ± 0.4 Hz and still reached the noise.
    fn trades_after_putting_back(
        &self,
        next: &Round,
        keys: &[&'static str],
        fit: &Fit,
    ) -> Vec<PutBackTrade> {
        let position = |r: &Round, key: &str| r.knobs.iter().position(|k| k.key == key);
        let mut trades: Vec<PutBackTrade> = self
            .put_back_trades
            .iter()
            .filter(|t| position(next, t.key).is_some())
            .copied()
            .collect();
        if !self.reaches_noise(fit) {
            return trades;
        }
        for (p, knob) in next.knobs.iter().enumerate() {
            let Some(q) = position(self, knob.key) else {
                continue;
            };
            let shift = (next.whole.values[p] - self.whole.values[q]).abs();
            let uncertainty = next.sigma[p].max(next.whole.model_sigma[p]);
            if !verdict::moved(shift, uncertainty, self.whole.sigma[q]) {
                continue;
            }
            // The key put back it trades with most in this round, where both were free.
            let put_back = |o: usize| keys.contains(&self.knobs[o].key);
            let traded = self.whole.most_traded_among(q, &put_back);
            let Some(with) = traded.map(|o| self.knobs[o].key).or(keys.first().copied()) else {
                continue;
            };
            match trades.iter_mut().find(|t| t.key == knob.key) {
                Some(t) => t.shift = t.shift.max(shift),
                None => trades.push(PutBackTrade {
                    key: knob.key,
                    with,
                    shift,
                }),
            }
        }
        trades
    }

    /// Whether this round predicts the held-out halves better than `other` (with fewer
    /// values): by the twentieth of [`predicts_better`], on the halves this round holds out
    /// ([`Round::held_out_against`]).
    fn predicts_better_than(&self, other: &Round, fit: &Fit, fold: &[bool]) -> bool {
        self.held_out_against(other, fit, fold)
            .is_some_and(|(this_m, that_m)| predicts_better(this_m, that_m))
    }

    /// This round's and `other`'s (with fewer values) held-out RMS (m), each over the same
    /// halves ([`compared_rms_m`]): those where this round's fits found a point of their own,
    /// else both halves. None where either round's halves cannot be simulated or no half
    /// counts a sample.
    pub(super) fn held_out_against(
        &self,
        other: &Round,
        fit: &Fit,
        fold: &[bool],
    ) -> Option<(f64, f64)> {
        let this = self.half_scores(fit, fold)?;
        let that = other.half_scores(fit, fold)?;
        compared_rms_m(this, that)
    }

    /// Each half's fit scored on the other half's samples (of those `fit` compares).
    fn half_scores(&self, fit: &Fit, fold: &[bool]) -> Option<[HalfScore; 2]> {
        let score = |h: usize| -> Option<HalfScore> {
            let (ss_m2, n) = self.half_held_out(fit, fold, fit.mask(), h)?;
            Some(HalfScore {
                ss_m2,
                n,
                own_point: self.halves[h].own_point,
            })
        };
        Some([score(0)?, score(1)?])
    }

    /// Where knob `key` stays fitted though the record does not determine it alone (its
    /// uncertainty beyond half of itself: kept because putting it back predicts the
    /// held-out halves worse), the knob it trades with most; none for a value the record
    /// determines, or one not fitted in this round.
    pub(super) fn traded_with(&self, key: &str) -> Option<&'static str> {
        let p = self.knobs.iter().position(|k| k.key == key)?;
        if let Some(t) = self.put_back_trades.iter().find(|t| t.key == key) {
            return Some(t.with);
        }
        if self.knobs[p].stays_fitted(self.sigma[p], self.whole.values[p]) {
            return None;
        }
        let other = self.whole.most_traded_with(p)?;
        Some(match self.knobs[other].key {
            // A state of the record, not a key of the machine file.
            k if k == knobs::HELD_AT_START.key => "the force held at the record's start",
            k => k,
        })
    }

    /// How far `key` moved when a value it trades with was put back to the template's
    /// ([`Round::put_back`]); none where it did not move beyond what noise explains.
    pub(super) fn put_back_shift(&self, key: &str) -> Option<f64> {
        let t = self.put_back_trades.iter().find(|t| t.key == key)?;
        Some(t.shift)
    }

    /// This round, its halves scored with the force held at the record's start estimated on
    /// each half scored, as a round that fits it is: the footing a round without that force
    /// is compared with one that has it on. Before any figure of it is read.
    pub(super) fn estimating_held(mut self) -> Round {
        self.estimates_held = true;
        self
    }

    /// The RMS residual (m) of each half's fit on the other half's samples (of those `fit`
    /// compares): how well this round predicts what it did not see.
    pub(super) fn held_out_rms(&self, fit: &Fit, fold: &[bool]) -> Option<f64> {
        self.held_out_rms_on(fit, fold, fit.mask())
    }

    /// [`Round::held_out_rms`] on the samples `mask` allows.
    pub(super) fn held_out_rms_on(&self, fit: &Fit, fold: &[bool], mask: &[bool]) -> Option<f64> {
        self.held_out_of(fit, fold, mask, false)
    }

    /// [`Round::held_out_rms`] of the halves' fits that found a point of their own only
    /// (`Fitted::own_point`): a half's search that found no step stayed where the fit on the
    /// whole landed, at values fitted to the other half as well, and its residual there is
    /// not held out. None where neither half's is: the round has no held-out figure.
    pub(super) fn held_out_rms_own(&self, fit: &Fit, fold: &[bool]) -> Option<f64> {
        self.held_out_of(fit, fold, fit.mask(), true)
    }

    /// The round's held-out figure (µm) as a fit written as a model is judged by: at the
    /// record's noise (`reached`) both halves' fits, above it those with a point of their own
    /// only ([`Round::held_out_rms_own`]). None where above the noise neither half has one,
    /// or the halves cannot be simulated.
    pub(super) fn held_out_shown_um(&self, fit: &Fit, fold: &[bool], reached: bool) -> Option<f64> {
        let own = (!reached).then(|| self.held_out_rms_own(fit, fold));
        if own == Some(None) {
            return None;
        }
        super::held_out::figure(own, || self.held_out_rms(fit, fold))
    }

    fn held_out_of(&self, fit: &Fit, fold: &[bool], mask: &[bool], own: bool) -> Option<f64> {
        let (mut ss, mut n) = (0.0, 0usize);
        for h in (0..2).filter(|&h| !own || self.halves[h].own_point) {
            let (s, m) = self.half_held_out(fit, fold, mask, h)?;
            ss += s;
            n += m;
        }
        (n > 0 || !own).then(|| (ss / n.max(1) as f64).sqrt())
    }

    /// Half `h`'s fit on the other half's samples that `mask` allows: the residual's sum of
    /// squares (m²) and the samples counted. Both halves are simulated once, on first ask.
    pub(super) fn half_held_out(
        &self,
        fit: &Fit,
        fold: &[bool],
        mask: &[bool],
        h: usize,
    ) -> Option<(f64, usize)> {
        let simulated = self.halves_simulated.get_or_init(|| {
            let first = fit.residual(&self.scored_config(fit, fold, 0))?;
            let second = fit.residual(&self.scored_config(fit, fold, 1))?;
            Some([first, second])
        });
        let r = &simulated.as_ref()?[h];
        let side = h == 0;
        let (mut ss, mut n) = (0.0, 0usize);
        for i in (0..r.len()).filter(|&i| fold[i] != side && mask[i]) {
            ss += r[i] * r[i];
            n += 1;
        }
        Some((ss, n))
    }

    /// This round's held-out RMS (m) with each half's fit holding no force at the record's
    /// start, as a machine file holds its values: over the halves whose fits found a point of
    /// their own. None where no half has one (the figure would be in-sample) or no sample
    /// counts.
    pub(super) fn held_out_holding_none(&self, fit: &Fit, fold: &[bool]) -> Option<f64> {
        let (mut ss, mut n) = (0.0, 0usize);
        for h in (0..2).filter(|&h| self.halves[h].own_point) {
            let mut config = self.half_config(h);
            config.held_at_start_n = 0.0;
            let r = fit.residual(&config)?;
            let side = h == 0;
            for i in (0..r.len()).filter(|&i| fold[i] != side && fit.mask()[i]) {
                ss += r[i] * r[i];
                n += 1;
            }
        }
        (n > 0).then(|| (ss / n as f64).sqrt())
    }

    /// Half `h`'s fit as it is scored on the other half: where this round estimates the force
    /// held at the record's start (`estimates_held`) and the other half holds the start, that force estimated on the
    /// other half's samples with the half's machine values fixed — a state of the record,
    /// which the half's own samples did not show, while the machine's values are what is
    /// scored.
    fn scored_config(&self, fit: &Fit, fold: &[bool], h: usize) -> AxisConfig {
        let mut config = self.half_config(h);
        let scored = |k: usize| fold[k] != (h == 0) && fit.mask()[k];
        if self.estimates_held
            && fit.holds_start(&scored)
            && let Some(held_n) = fit.held_on(&config, &scored)
        {
            config.held_at_start_n = held_n;
        }
        config
    }

    /// Whether the fit on the whole record reaches the record's noise.
    fn reaches_noise(&self, fit: &Fit) -> bool {
        let samples = fit.mask().iter().filter(|m| **m).count().max(1);
        within_noise(
            (self.whole.cost / samples as f64).sqrt(),
            fit.ctx().noise_sigma,
        )
    }

    /// The knobs whose uncertainty leaves them undetermined.
    fn undetermined(&self, above_noise: bool) -> Vec<&'static str> {
        self.knobs
            .iter()
            .zip(&self.sigma)
            .zip(&self.whole.values)
            .filter(|((k, s), v)| {
                !if above_noise {
                    k.stays_fitted(**s, **v)
                } else {
                    k.determines(**s, **v)
                }
            })
            .map(|((k, _), _)| k.key)
            .collect()
    }

    /// The round's base with the values of one of its fits.
    pub(super) fn config(&self, fitted: &Fitted) -> AxisConfig {
        Fit::config(&self.knobs, &self.base, &fitted.values)
    }

    /// Half `h`'s fit (0: the samples the fold marks) about its own base.
    pub(super) fn half_config(&self, h: usize) -> AxisConfig {
        Fit::config(&self.knobs, &self.half_bases[h], &self.halves[h].values)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A half's fit that predicts the other half's `n` samples to `rms_um` (µm).
    fn half(rms_um: f64, n: usize, own_point: bool) -> HalfScore {
        let rms_m = rms_um * 1e-6;
        HalfScore {
            ss_m2: rms_m * rms_m * n as f64,
            n,
            own_point,
        }
    }

    fn um((a, b): (f64, f64)) -> (f64, f64) {
        (a * 1e6, b * 1e6)
    }

    /// Both rounds' figures (µm), where some half counts a sample.
    fn um_of(figures: Option<(f64, f64)>) -> (f64, f64) {
        um(figures.expect("some half counts a sample"))
    }

    fn close((a, b): (f64, f64), (x, y): (f64, f64)) -> bool {
        (a - x).abs() < 1e-9 && (b - y).abs() < 1e-9
    }

    #[test]
    fn both_halves_held_out_by_both_rounds_count_weighted_by_their_samples() {
        // 100 samples at 1 µm and 300 at 3 µm: √((100·1 + 300·9) / 400) = √7 µm.
        let this = [half(1.0, 100, true), half(3.0, 300, true)];
        let that = [half(2.0, 100, true), half(2.0, 300, true)];
        let got = um_of(compared_rms_m(this, that));
        assert!(close(got, (7f64.sqrt(), 2.0)), "{got:?}");
    }

    #[test]
    fn the_halves_the_larger_round_holds_out_count_for_both() {
        // The smaller round's second half stayed at the whole fit's values (0.5 µm
        // in-sample); the larger round holds out both halves, so both count for both:
        // √((1 + 9) / 2) = √5 µm and √((4 + 0.25) / 2) = √2.125 µm.
        let larger = [half(1.0, 100, true), half(3.0, 100, true)];
        let smaller = [half(2.0, 100, true), half(0.5, 100, false)];
        let got = um_of(compared_rms_m(larger, smaller));
        assert!(close(got, (5f64.sqrt(), 2.125f64.sqrt())), "{got:?}");
        // Roles swapped: the larger round holds out the first half only, and both rounds
        // are scored there (2 µm against 1 µm).
        let got = um_of(compared_rms_m(smaller, larger));
        assert!(close(got, (2.0, 1.0)), "{got:?}");
        // Each round holds out the half the other does not: the larger is scored on its
        // own held-out half, the smaller on the same samples, in-sample for it (3 against
        // 0.5 µm).
        let larger = [half(1.0, 100, false), half(3.0, 100, true)];
        let smaller = [half(2.0, 100, true), half(0.5, 100, false)];
        let got = um_of(compared_rms_m(larger, smaller));
        assert!(close(got, (3.0, 0.5)), "{got:?}");
    }

    #[test]
    fn a_half_the_larger_round_predicts_badly_is_never_left_out() {
        // The larger round predicts its second half to 13 µm; the smaller round's second
        // half stayed at the whole fit. Scored on the first half alone the larger would
        // win (1 against 2 µm); over both it reads √((1 + 169) / 2) = √85 µm against
        // √((4 + 0.25) / 2) µm and loses.
        let larger = [half(1.0, 100, true), half(13.0, 100, true)];
        let smaller = [half(2.0, 100, true), half(0.5, 100, false)];
        let (a, b) = compared_rms_m(larger, smaller).unwrap();
        assert!(close(um((a, b)), (85f64.sqrt(), 2.125f64.sqrt())));
        assert!(!predicts_better(a, b));
    }

    #[test]
    fn where_the_larger_round_holds_out_no_half_both_halves_count() {
        // Its halves both stayed at the whole fit (1 and 3 µm in-sample); the smaller
        // round's second half holds out 0.5 µm: √((1 + 9) / 2) = √5 and
        // √((4 + 0.25) / 2) = √2.125 µm.
        let larger = [half(1.0, 100, false), half(3.0, 100, false)];
        let smaller = [half(2.0, 100, false), half(0.5, 100, true)];
        let got = um_of(compared_rms_m(larger, smaller));
        assert!(close(got, (5f64.sqrt(), 2.125f64.sqrt())), "{got:?}");
        // A held-out half that counts no sample (the mask leaves none) holds out nothing.
        let empty = [half(1.0, 0, true), half(3.0, 100, false)];
        let other = [half(2.0, 0, true), half(1.0, 100, false)];
        let got = um_of(compared_rms_m(empty, other));
        assert!(close(got, (3.0, 1.0)), "{got:?}");
        // No half counts a sample: no figure at all, never a perfect one.
        let nothing = [half(1.0, 0, true), half(1.0, 0, false)];
        assert!(compared_rms_m(nothing, nothing).is_none());
    }

    #[test]
    fn a_round_better_only_on_a_half_it_was_fitted_to_loses() {
        // Its first half predicts the second to 2.0 µm; its second half stayed at the
        // whole fit's values, 0.1 µm on samples it was fitted to. Over both halves it
        // reads √((4 + 0.01) / 2) = 1.416 µm, under 0.95 × 1.5 = 1.425 µm of the other
        // round whose halves both moved: it would win.
        let this = [half(2.0, 100, true), half(0.1, 100, false)];
        let that = [half(1.5, 100, true), half(1.5, 100, true)];
        let both = |s: &[HalfScore; 2]| {
            let ss: f64 = s.iter().map(|h| h.ss_m2).sum();
            (ss / 200.0).sqrt()
        };
        assert!(predicts_better(both(&this), both(&that)));
        // On the one half it holds out it predicts 2.0 against 1.5 µm: it loses.
        let (a, b) = compared_rms_m(this, that).unwrap();
        assert!(close(um((a, b)), (2.0, 1.5)), "{:?}", um((a, b)));
        assert!(!predicts_better(a, b));
        // The burden of proof: were the other round the larger, it would be scored on
        // both halves it holds out (1.5 µm) against this round's 1.416 µm, its in-sample
        // half included, and lose too, though it predicts held-out data better.
        let (a, b) = compared_rms_m(that, this).unwrap();
        assert!(
            close(um((a, b)), (1.5, 2.005f64.sqrt())),
            "{:?}",
            um((a, b))
        );
        assert!(!predicts_better(a, b));
    }
}
