//! A force that repeats with the table's position (a motor's torque ripple or cogging, a
//! screw's eccentricity), fitted on top of an axis's fit where the template names its period
//! (`errors.force_ripple_period_mm`: a motor turn's travel) — without a template, at the
//! ball-screw lead whose ripple fitted on either half of the record predicts the other
//! ([`period`]).
//!
//! The ripple's sine and cosine parts act on the residual nearly linearly (the loop is linear
//! but for friction switching), so each is found by least squares from two simulations more,
//! with a trial ripple at phase 0° and at 90°: cheap beside the search. A ripple that is
//! written is not: the loop's values are then fitted again with it in place (the whole
//! record's search and each half's once more, each half's about the ripple fitted on its own
//! samples) and the ripple on top of them again: a search more for the axis, and one more
//! where the template names a ripple of its own (the loop is then also fitted without it, to
//! judge against). Each half's fit gets the ripple fitted on its own samples and is scored on
//! the other half's, like every value `identify` writes; the ripple stays only where those
//! held-out figures are better than those of the loop fitted without a ripple by the
//! twentieth every larger model must earn — judged on the first fit, and again on the one
//! made with the ripple in place.
//!
//! A cyclic error in the positions recorded of the same period is fitted alongside, as what
//! the encoder adds to the position it reads (`tie`): where it predicts the held-out halves
//! as well as the force does, the record cannot tell the two apart, and where it predicts
//! them clearly better the force is not written. A force of the position acts at the same
//! phase of it whichever way the axis moves: where the record passes a period of travel each
//! way, the ripple's phase is fitted on each direction's samples apart, and a ripple whose two
//! phases differ beyond their uncertainty is not written ([`directions`]) — an error tied to
//! time or to the program, not to the position. Whatever the outcome, the axis carries a
//! statement of it ([`RippleVerdict`]): a ripple not written is "not determined" with its
//! reason, never silently dropped.

use rayon::prelude::*;
use serde::Serialize;

use super::result::IdentifiedValue;
use super::round::Round;
use super::solve::Fit;
use super::verdict::WhileMoving;
use crate::machine::AxisConfig;
use crate::numeric::units::um_from_m;

mod columns;
mod directions;
pub(super) mod period;
mod tie;

use columns::Columns;
use directions::Directions;
use tie::Tie;

/// The keys the ripple is written under.
pub(super) const AMPLITUDE_KEY: &str = "errors.force_ripple_n";
pub(super) const PHASE_KEY: &str = "errors.force_ripple_phase_deg";

/// What the record says of the force ripple on one axis whose template names its period.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RippleVerdict {
    /// Whether the force ripple is written to the machine file (as a model's value).
    pub written: bool,
    /// The statement, one line: "force ripple: …", "not determined (<reason>)" where not
    /// written.
    pub statement: String,
    /// The held-out RMS (µm) of the loop fitted without a ripple (NaN where none was
    /// fitted) …
    pub held_out_without_um: f64,
    /// … with the force ripple …
    pub held_out_force_um: f64,
    /// … and with a cyclic error in the positions recorded of the same period in its place.
    pub held_out_encoder_um: f64,
}

/// A ripple fitted on top of an axis's fit, and whether the held-out halves kept it.
pub(super) struct RippleFit {
    /// The model written with the ripple, where the halves kept it.
    written: Option<Written>,
    /// The amplitude and phase as values, determined or not.
    values: [IdentifiedValue; 2],
    /// What the report says of it.
    pub(super) verdict: RippleVerdict,
}

/// The axis's model with the ripple written: the loop's values fitted again with it in
/// place, the ripple on top of them once more, and what the record says of that model.
struct Written {
    /// The axis's configuration with the ripple.
    config: AxisConfig,
    /// Its residual on the whole record (m).
    residual: Vec<f64>,
    /// The residuals (m) of the halves' fits with their own ripples: what the written model
    /// predicts of the samples each half did not see.
    halves_with: [Vec<f64>; 2],
    /// The loop's values fitted again with the ripple in place.
    refit: Round,
    /// The held-out RMS (m) of the halves' fits with their ripples.
    held_out_with_m: f64,
    /// Whether that model reaches the record's noise, and whether its held-out figure is
    /// shown by a half's fit with a point of its own.
    judged: Judged,
}

/// What a model written says of itself: whether its residual on the whole record reaches
/// the noise, which halves' fits its held-out figure counts, and whether one of those has
/// a point of its own (above the noise a figure from halves that found none shows nothing).
#[derive(Clone, Copy)]
struct Judged {
    reached: bool,
    counted: [bool; 2],
    shown: bool,
}

impl Judged {
    /// `round`'s halves judged as the whole record's `residual` (m) places the model.
    fn of(fit: &Fit, round: &Round, residual: &[f64]) -> Judged {
        let reached = super::within_noise(
            super::solve::masked_rms(residual, fit.mask()),
            fit.ctx().noise_sigma,
        );
        let own = [round.halves[0].own_point, round.halves[1].own_point];
        let shown = reached || own.contains(&true);
        let counted = if reached || !shown { [true, true] } else { own };
        Judged {
            reached,
            counted,
            shown,
        }
    }
}

/// Why a ripple could not be fitted at all.
type Reason = String;

/// The ripple on top of `round` (whose fit on the whole record is `whole`), scored on the
/// halves `fold` tells apart, of the halves' fits `counted` allows; none where the template
/// names no period.
pub(super) fn on_top(
    fit: &Fit,
    round: &Round,
    whole: &AxisConfig,
    fold: &[bool],
    counted: [bool; 2],
) -> Option<RippleFit> {
    let period_mm = whole.errors.force_ripple_period_mm;
    if period_mm <= 0.0 {
        return None;
    }
    Some(
        fitted(fit, round, whole, fold, counted)
            .unwrap_or_else(|reason| RippleFit::not_determined(whole, reason)),
    )
}

/// [`on_top`] where the template names a period, or why the ripple cannot be fitted.
///
/// Fitted on top of the loop's values, the ripple is judged against the same halves
/// without it. Where it is written, the loop's values are fitted again with it in place —
/// fitted without it, they had bent to explain part of it (on a record of a known ripple,
/// the gain and mass 17 % and 21 % low and the ripple per gain 12 % low; fitted again, the
/// ripple per gain within 1 % of the truth, while the gain and mass, which the record
/// trades, move further: 25 % low and at a twelfth) — and the ripple on top of those once
/// more.
fn fitted(
    fit: &Fit,
    round: &Round,
    whole: &AxisConfig,
    fold: &[bool],
    counted: [bool; 2],
) -> Result<RippleFit, Reason> {
    let period_m = whole.errors.force_ripple_period_mm * 1e-3;
    columns::travel_covers(fit, period_m)?;
    let encoder = Columns::encoder(fit, period_m);
    let bare = bare_round(fit, round, whole, fold)?;
    let first = Pass::of(fit, (round, bare.as_ref()), whole, fold, &encoder)?;
    let kept_out = |tie: &Tie| RippleFit::kept_out(whole, &first, tie, period_m);
    if let Err(tie) = judge(Tie::of(&first.figures(), counted), &first) {
        return Ok(kept_out(&tie));
    }
    // Each half's loop is fitted again about its own ripple, so that the figure it is
    // scored by has seen nothing of the other half.
    let refit = Round::fit_apart(
        fit,
        round.knobs.clone(),
        &with_ripple(whole, first.ab),
        [0, 1].map(|h| with_ripple(whole, first.halves[h].ab)),
        fold,
    )
    .ok_or("the loop's values cannot be fitted again with the ripple in place")?;
    let refit_whole = refit.config(&refit.whole);
    let second = Pass::of(fit, (&refit, None), &refit_whole, fold, &encoder)?;
    let config = with_ripple(&refit_whole, second.ab);
    let residual = fit
        .residual(&config)
        .ok_or("the axis cannot be simulated on the whole record with the ripple written")?;
    // The force is judged again as written: the refitted halves with their ripples against
    // the first pass's halves without one and with the positions' cyclic error instead.
    // The halves counted are the refit's (those with a point of their own), also for the
    // first pass's two figures, whose halves may have found none: such a half's figures
    // without a ripple and with the cyclic error are then scored on samples its values were
    // partly fitted to, lower than held out. That errs conservative: the force must beat
    // alternatives the mix flatters, never the other way.
    let judged = Judged::of(fit, &refit, &residual);
    let tie = match judge(
        Tie::of(&first.figures_with_force_of(&second), judged.counted),
        &second,
    ) {
        Ok(tie) => tie,
        Err(tie) => return Ok(kept_out(&tie)),
    };
    // Listed against `whole`: the refit's base carries the first pass's ripple, not the
    // template's.
    let values = values(whole, second.ab, second.ab_floor, second.halves_ab(), &tie);
    let mut verdict = tie.verdict(&values, first.encoder_whole, period_m);
    verdict.statement.push_str(&second.directions.clause());
    let [h0, h1] = [0, 1].map(|h| second.halves[h].with.clone());
    Ok(RippleFit {
        written: Some(Written {
            config,
            residual,
            halves_with: [h0, h1],
            refit,
            held_out_with_m: tie.force_m,
            judged,
        }),
        values,
        verdict,
    })
}

/// Whether the held-out halves' verdict `tie` keeps the force `pass` fitted: `Ok` with it
/// where it does and the ripple's phase agrees between the two directions of travel, else
/// `Err` with the verdict that keeps it out (refused, with the directions' reason, where
/// the halves kept it but the phases differ).
fn judge(tie: Tie, pass: &Pass) -> Result<Tie, Tie> {
    if !tie.force_written() {
        return Err(tie);
    }
    match pass.directions.differ() {
        Some(why) => Err(tie.refused(why)),
        None => Ok(tie),
    }
}

/// Where the template names a ripple of its own, the loop's values fitted again without it,
/// from where `round` landed: what the ripple fitted is judged against (`round`, fitted with
/// the template's ripple in place, bent its values to it, and would predict the record worse
/// with it taken out than a fit made without it). A search from there may settle short of
/// the fit a template without a ripple reaches (on the integrator's record of a 12 N ripple,
/// a template's 6 N at 100° left it at 1.62 µm held out against 0.93 µm). None where the
/// template's ripple is zero: `round` is that fit.
fn bare_round(
    fit: &Fit,
    round: &Round,
    whole: &AxisConfig,
    fold: &[bool],
) -> Result<Option<Round>, Reason> {
    if whole.errors.force_ripple_n == 0.0 {
        return Ok(None);
    }
    Round::fit(
        fit,
        round.knobs.clone(),
        &with_ripple(whole, (0.0, 0.0)),
        fold,
    )
    .map(Some)
    .ok_or_else(|| "the loop's values cannot be fitted without the template's ripple".into())
}

/// The ripple fitted on top of a round: on each half's fit (on its own samples, scored on
/// the other's) and on the whole's, with the encoder's cyclic error on the whole's beside.
struct Pass {
    halves: Vec<Half>,
    ab: (f64, f64),
    /// The least-squares floor on `ab`'s uncertainty (N).
    ab_floor: f64,
    encoder_whole: Option<(f64, f64)>,
    /// The ripple's phase fitted on each direction's samples apart.
    directions: Directions,
}

impl Pass {
    /// On `round`'s fits; without a ripple (and with the positions' cyclic error instead)
    /// on `bare`'s where given ([`bare_round`]), else on `round`'s with its ripple zero.
    fn of(
        fit: &Fit,
        (round, bare): (&Round, Option<&Round>),
        whole: &AxisConfig,
        fold: &[bool],
        encoder: &Columns,
    ) -> Result<Pass, Reason> {
        let mask = fit.mask();
        let bare_residual = |config: AxisConfig| {
            fit.residual(&config)
                .ok_or("the axis cannot be simulated without the template's ripple")
        };
        let halves: Vec<Half> = [(0, true), (1, false)]
            .into_par_iter()
            .map(|(h, side)| {
                let config = round.half_config(h);
                let bare = bare.map(|b| bare_residual(b.half_config(h))).transpose()?;
                let own = |i: usize| mask[i] && fold[i] == side;
                let held_out = |i: usize| mask[i] && fold[i] != side;
                Half::fitted(fit, (&config, bare), encoder, own, held_out)
            })
            .collect::<Result<_, _>>()?;
        let parts = Columns::force(fit, whole)?;
        let ab = parts.solve(&|i| mask[i])?;
        let ab_floor = parts.least_squares_sigma(&|i| mask[i], ab);
        let period_m = whole.errors.force_ripple_period_mm * 1e-3;
        let directions = Directions::of(fit, &parts, fold, period_m);
        let bare_whole = bare
            .map(|b| bare_residual(b.config(&b.whole)))
            .transpose()?;
        let encoder_whole = encoder
            .on(bare_whole.as_ref().unwrap_or(&parts.r0))
            .solve(&|i| mask[i])
            .ok();
        Ok(Pass {
            halves,
            ab,
            ab_floor,
            encoder_whole,
            directions,
        })
    }

    fn halves_ab(&self) -> [(f64, f64); 2] {
        [self.halves[0].ab, self.halves[1].ab]
    }

    /// Each half's held-out sums of squares — without a ripple, with the force, with the
    /// positions' cyclic error — and how many samples they are over.
    fn figures(&self) -> [([f64; 3], usize); 2] {
        [0, 1].map(|h| (self.halves[h].held_out, self.halves[h].n))
    }

    /// [`Pass::figures`] with the force's of `refitted` (the loop fitted again with the
    /// ripple, on the same halves).
    fn figures_with_force_of(&self, refitted: &Pass) -> [([f64; 3], usize); 2] {
        let mut figures = self.figures();
        for (f, r) in figures.iter_mut().zip(&refitted.halves) {
            f.0[1] = r.held_out[1];
        }
        figures
    }
}

/// One half's fit with a ripple fitted on its own samples: the residual it leaves
/// everywhere (m) with the force, and the sums of squares on the samples it did not see —
/// without a ripple, with the force, with the positions' cyclic error instead — with how
/// many there are.
struct Half {
    ab: (f64, f64),
    with: Vec<f64>,
    held_out: [f64; 3],
    n: usize,
}

impl Half {
    /// The force fitted on top of `config`; the figures without it and with the positions'
    /// cyclic error instead on `bare` (the residual of the half's fit made without a ripple)
    /// where given, else on `config`'s with its ripple zero.
    fn fitted(
        fit: &Fit,
        (config, bare): (&AxisConfig, Option<Vec<f64>>),
        encoder: &Columns,
        own: impl Fn(usize) -> bool + Sync,
        held_out: impl Fn(usize) -> bool,
    ) -> Result<Half, Reason> {
        let parts = Columns::force(fit, config)?;
        let ab = parts.solve(&own)?;
        let with = fit
            .residual(&with_ripple(config, ab))
            .ok_or("the axis cannot be simulated with the ripple fitted to a half")?;
        let bare = bare.unwrap_or_else(|| parts.r0.clone());
        let encoder_ab = encoder.on(&bare).solve(&own)?;
        let corrected = encoder.corrected(&bare, encoder_ab);
        let n = (0..with.len()).filter(|&i| held_out(i)).count();
        Ok(Half {
            ab,
            held_out: [
                sum_of_squares(&bare, &held_out),
                sum_of_squares(&with, &held_out),
                sum_of_squares(&corrected, &held_out),
            ],
            with,
            n,
        })
    }
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
    /// Not fitted, for `reason`: the template's values stay, listed as not determined.
    fn not_determined(template: &AxisConfig, reason: Reason) -> RippleFit {
        let values = values(template, (0.0, 0.0), 0.0, [(0.0, 0.0); 2], &Tie::none());
        RippleFit {
            written: None,
            values,
            verdict: RippleVerdict {
                written: false,
                statement: format!("force ripple: not determined ({reason})"),
                held_out_without_um: f64::NAN,
                held_out_force_um: f64::NAN,
                held_out_encoder_um: f64::NAN,
            },
        }
    }

    /// Fitted, but the held-out halves (`tie`) did not keep it: the template's values stay.
    fn kept_out(whole: &AxisConfig, first: &Pass, tie: &Tie, period_m: f64) -> RippleFit {
        let values = values(whole, first.ab, first.ab_floor, first.halves_ab(), tie);
        let verdict = tie.verdict(&values, first.encoder_whole, period_m);
        RippleFit {
            written: None,
            values,
            verdict,
        }
    }

    /// The axis's fit with the ripple where the halves kept it: its configuration, residual,
    /// held-out figure (µm) and the loop's values (fitted again with the ripple, against
    /// `template`) replaced; the ripple's values added to `values` either way.
    pub(super) fn apply(
        &self,
        written: (AxisConfig, Vec<f64>),
        values: &mut Vec<IdentifiedValue>,
        (held_out_um, template): (&mut f64, &AxisConfig),
    ) -> (AxisConfig, Vec<f64>) {
        let Some(w) = &self.written else {
            values.extend(self.values.iter().cloned());
            return written;
        };
        // The knobs of the round fitted again; those the record did not determine stay the
        // template's, as listed.
        for refitted in super::fitted_values(&w.refit.knobs, &w.refit, &w.config, template) {
            if let Some(v) = values.iter_mut().find(|v| v.key == refitted.key) {
                *v = super::refitted_value(v, refitted, &w.refit.knobs);
            }
        }
        values.extend(self.values.iter().cloned());
        *held_out_um = um_from_m(w.held_out_with_m);
        (w.config.clone(), w.residual.clone())
    }
}

/// Whether the model written reaches the record's noise and whether its held-out figure is
/// shown by a half's fit with a point of its own: those of the loop fitted again with the
/// ripple where one is written, else `before` (of the fit without it).
pub(super) fn judged(ripple: Option<&RippleFit>, before: (bool, bool)) -> (bool, bool) {
    ripple
        .and_then(|r| r.written.as_ref())
        .map_or(before, |w| (w.judged.reached, w.judged.shown))
}

/// The round the loop's values written come from: the one fitted again with the ripple
/// where one is written, else `round`. Figures derived from those values (the gain per
/// inertia) are taken from it, so that they agree with the machine file written.
pub(super) fn loop_round<'a>(ripple: Option<&'a RippleFit>, round: &'a Round) -> &'a Round {
    ripple
        .and_then(|r| r.written.as_ref())
        .map_or(round, |w| &w.refit)
}

/// Where the axis could not be fitted at all and its template names a ripple's period: the
/// ripple is not determined either (none where the template names no period).
pub(super) fn unfitted(template: &AxisConfig) -> Option<RippleVerdict> {
    (template.errors.force_ripple_period_mm > 0.0).then(not_fitted)
}

/// The ripple of an axis whose fit is not written: not determined.
pub(super) fn not_fitted() -> RippleVerdict {
    RippleVerdict {
        written: false,
        statement: "force ripple: not determined (the axis's fit is not written)".to_string(),
        held_out_without_um: f64::NAN,
        held_out_force_um: f64::NAN,
        held_out_encoder_um: f64::NAN,
    }
}

/// The held-out figures while moving (`without`: of the fit without the ripple) of the model
/// written: with the halves' ripples where one is kept.
pub(super) fn while_moving(
    ripple: Option<&RippleFit>,
    fit: &Fit,
    fold: &[bool],
    without: WhileMoving,
) -> WhileMoving {
    let Some(halves) = ripple
        .and_then(|r| r.written.as_ref())
        .map(|w| &w.halves_with)
    else {
        return without;
    };
    let moving = super::moving_samples(fit.ctx(), fit.axis(), fit.offset());
    let (mut ss, mut n) = (0.0, 0usize);
    for (r, side) in halves.iter().zip([true, false]) {
        let held_out = |i: usize| moving[i] && fit.mask()[i] && fold[i] != side;
        for i in (0..r.len()).filter(|&i| held_out(i)) {
            ss += r[i] * r[i];
            n += 1;
        }
    }
    let identified = um_from_m((ss / n.max(1) as f64).sqrt());
    WhileMoving {
        held_out_identified_um: identified,
        held_out_share: identified / without.following_error_rms_um,
        ..without
    }
}

/// Where the template's values are written for the axis in place of its fit, no ripple is:
/// a statement that says one is written is turned into why not.
pub(super) fn not_written(verdict: &mut Option<RippleVerdict>) {
    if let Some(v) = verdict.as_mut().filter(|v| v.written) {
        v.written = false;
        v.statement = "force ripple: not determined (the axis's fit is not written: the \
                       template's values stay)"
            .to_string();
    }
}

/// `config` with its ripple fitted again on the samples `own` allows alone, about its other
/// values: where a half's fit starts from a whole fit with a ripple written, the ripple that
/// half's own samples give (as this stage starts each half's refit from its own), so that the
/// figure the half is scored by has seen nothing of the other half's. Why not, where the
/// ripple cannot be fitted there.
pub(super) fn own_ripple(
    fit: &Fit,
    config: &AxisConfig,
    own: &(dyn Fn(usize) -> bool + Sync),
) -> Result<AxisConfig, Reason> {
    let ab = Columns::force(fit, config)?.solve(own)?;
    Ok(with_ripple(config, ab))
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

/// The uncertainty of a ripple the two halves found, `(a, b)` each: half their vectors'
/// distance, but not below the least-squares `floor` (N) of the whole's fit (two halves can
/// land close by chance), as the amplitude's (N), and the phase's (°) that follows from it —
/// the largest turn a vector of that length moves the whole's by, all of 180° where it is as
/// long as the whole's itself.
fn spread(whole: (f64, f64), floor: f64, halves: [(f64, f64); 2]) -> (f64, f64) {
    let ((a0, b0), (a1, b1)) = (halves[0], halves[1]);
    let sigma = (0.5 * (a0 - a1).hypot(b0 - b1)).max(floor);
    let amplitude = whole.0.hypot(whole.1);
    let phase_deg = if sigma < amplitude {
        (sigma / amplitude).asin().to_degrees()
    } else {
        180.0
    };
    (sigma, phase_deg)
}

/// The amplitude and phase fitted on the whole record, with their spread between the halves
/// as their uncertainty (a ripple the halves place apart is not known better than that),
/// `floor` (N) the least it can be.
/// Written, they are a model's values, never determined: the record fixes the force only
/// per unit of the fitted mass (which trades with the gain), and a cyclic error in the
/// positions recorded of the same period, read by the loop, could be what the table has (`Tie::trades`). Not
/// written, the template's values stay, not determined.
fn values(
    template: &AxisConfig,
    whole: (f64, f64),
    floor: f64,
    halves: [(f64, f64); 2],
    tie: &Tie,
) -> [IdentifiedValue; 2] {
    let kept = tie.force_written();
    let (amplitude_sigma, phase_sigma) = spread(whole, floor, halves);
    let value = |key, unit, template: f64, fitted: f64, sigma: f64| IdentifiedValue {
        key,
        unit,
        template,
        value: if kept { fitted } else { template },
        uncertainty: if kept { sigma } else { f64::NAN },
        determined: false,
        measured: false,
        traded_with: None,
        loose: false,
        complex_pair: None,
    };
    let mut amplitude = value(
        AMPLITUDE_KEY,
        "N",
        template.errors.force_ripple_n,
        whole.0.hypot(whole.1),
        amplitude_sigma,
    );
    let mut phase = value(
        PHASE_KEY,
        "°",
        template.errors.force_ripple_phase_deg,
        whole.1.atan2(whole.0).to_degrees(),
        phase_sigma,
    );
    if kept {
        let (amplitude_trade, phase_trade) = tie.trades();
        amplitude.traded_with = Some(amplitude_trade);
        phase.traded_with = Some(phase_trade);
    }
    [amplitude, phase]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::machine::MachineConfig;

    /// The small table's X axis, its template naming a 2.5 mm period and a 5 N ripple at 30°.
    fn template() -> AxisConfig {
        let mut axis = MachineConfig::preset("small-table").unwrap().x;
        axis.errors.force_ripple_period_mm = 2.5;
        axis.errors.force_ripple_n = 5.0;
        axis.errors.force_ripple_phase_deg = 30.0;
        axis
    }

    /// Two halves of 100 held-out samples each: 2 µm RMS without a ripple, `force_um` with
    /// the force, 2 µm with the positions' cyclic error in its place.
    fn tie_with_force(force_um: f64) -> Tie {
        let ss = |um: f64| 100.0 * (um * 1e-6_f64).powi(2);
        let half = ([ss(2.0), ss(force_um), ss(2.0)], 100);
        Tie::of(&[half, half], [true, true])
    }

    /// A pass whose only say is the ripple's phase each way.
    fn pass_with(directions: Directions) -> Pass {
        Pass {
            halves: Vec::new(),
            ab: (0.0, 0.0),
            ab_floor: 0.0,
            encoder_whole: None,
            directions,
        }
    }

    fn statement(tie: &Tie) -> String {
        let values = values(&template(), (0.0, 0.0), 0.0, [(0.0, 0.0); 2], tie);
        tie.verdict(&values, None, 2.5e-3).statement
    }

    #[test]
    fn the_force_is_kept_only_where_the_halves_keep_it_and_its_phase_agrees_both_ways() {
        // 1 µm held out with the force against 2 µm without it and with the cyclic error:
        // better by far more than a twentieth on each half. The phases 40 ± 2° moving + and
        // 44 ± 2° moving − lie 4° apart, within three of their combined 2√2 = 2.83°: kept.
        let agree = Directions::Compared {
            plus: (40.0, 2.0),
            minus: (44.0, 2.0),
        };
        let kept = judge(tie_with_force(1.0), &pass_with(agree.clone()))
            .unwrap_or_else(|t| panic!("kept out: {}", statement(&t)));
        assert!(kept.force_written());
        // Where the phases were not compared (too little travel one way), that alone keeps
        // nothing out.
        let unknown = Directions::NotCompared("moving − the axis travels too little".into());
        assert!(judge(tie_with_force(1.0), &pass_with(unknown)).is_ok());
        // 130° against 40°: 90° apart, beyond 3 × 2.83° = 8.5°: kept out, for that reason.
        let differ = Directions::Compared {
            plus: (40.0, 2.0),
            minus: (130.0, 2.0),
        };
        kept_out_saying(
            tie_with_force(1.0),
            differ,
            "force ripple: not determined (the phase differs between directions",
        );
        // 1.95 µm against 2 µm is 2.5 % better, short of the twentieth: kept out however the
        // phases agree, with what the halves said.
        kept_out_saying(
            tie_with_force(1.95),
            agree,
            "force ripple: not determined (the held-out halves predict no better",
        );
    }

    /// `judge` keeps the force out, and the statement shown begins with `begins`.
    fn kept_out_saying(tie: Tie, directions: Directions, begins: &str) {
        let out = judge(tie, &pass_with(directions))
            .err()
            .unwrap_or_else(|| panic!("kept where it should say: {begins}"));
        assert!(!out.force_written());
        let said = statement(&out);
        assert!(said.starts_with(begins), "{said}");
    }

    #[test]
    fn a_ripple_that_cannot_be_simulated_is_dropped_with_its_reason_and_the_fit_stays() {
        let template = template();
        let reason = "the axis cannot be simulated on the whole record with the ripple written";
        let dropped = RippleFit::not_determined(&template, reason.to_string());
        // The fit without the ripple, as it was before: its configuration, residual and
        // held-out figure are what stays.
        let mut fit_config = template.clone();
        fit_config.drive.table_mass_kg *= 1.5;
        let residual = vec![1e-6, -2e-6, 3e-6];
        let mut held_out_um = 0.7;
        let mut values = Vec::new();
        let (config, kept) = dropped.apply(
            (fit_config.clone(), residual.clone()),
            &mut values,
            (&mut held_out_um, &template),
        );
        assert_eq!(config, fit_config);
        assert_eq!(kept, residual);
        assert_eq!(held_out_um, 0.7);
        // Said so, with the reason: not written, the template's values listed as they are.
        let v = &dropped.verdict;
        assert!(!v.written, "{v:?}");
        assert_eq!(
            v.statement,
            format!("force ripple: not determined ({reason})")
        );
        assert!(v.held_out_force_um.is_nan() && v.held_out_without_um.is_nan());
        let [amplitude, phase] =
            [AMPLITUDE_KEY, PHASE_KEY].map(|key| values.iter().find(|x| x.key == key).expect(key));
        assert_eq!((amplitude.value, phase.value), (5.0, 30.0));
        assert!(
            !amplitude.fitted() && !phase.fitted(),
            "{amplitude:?} {phase:?}"
        );
        assert!(amplitude.uncertainty.is_nan() && phase.uncertainty.is_nan());
    }

    #[test]
    fn an_axis_not_fitted_says_its_ripple_is_not_determined_and_why() {
        let v = unfitted(&template()).expect("the template names a period");
        assert!(!v.written);
        assert_eq!(
            v.statement,
            "force ripple: not determined (the axis's fit is not written)"
        );
        // A template that names no period has no ripple to speak of.
        let mut none = template();
        none.errors.force_ripple_period_mm = 0.0;
        assert_eq!(unfitted(&none), None);
        // A ripple written on a fit whose values are then not written is taken back.
        let mut written = Some(RippleVerdict {
            written: true,
            statement: "force ripple: 5 N".to_string(),
            ..v.clone()
        });
        not_written(&mut written);
        let w = written.unwrap();
        assert!(!w.written);
        assert!(
            w.statement
                .starts_with("force ripple: not determined (the axis's fit is not written"),
            "{}",
            w.statement
        );
    }

    #[test]
    fn the_halves_spread_is_measured_on_the_vector_and_the_phase_follows_from_it() {
        // Two halves that find the same amplitude (10 N) a quarter turn apart: their
        // amplitudes agree, their vectors (10, 0) and (0, 10) lie √200 apart; half of it,
        // 7.07 N, against the whole's 10 N turns the phase by asin(0.707) = 45°.
        let (sigma, phase) = spread((7.0711, 7.0711), 0.0, [(10.0, 0.0), (0.0, 10.0)]);
        assert!((sigma - 50f64.sqrt()).abs() < 1e-9, "{sigma}");
        assert!((phase - 45.0).abs() < 1e-3, "{phase}");
        // Halves apart by more than the whole's length: the phase is not known at all.
        let (_, phase) = spread((1.0, 0.0), 0.0, [(5.0, 0.0), (-5.0, 0.0)]);
        assert_eq!(phase, 180.0);
        // Halves that agree by chance: the floor stands, and a floor of half the whole's
        // length turns the phase by asin(0.5) = 30°.
        let (sigma, phase) = spread((4.0, 0.0), 2.0, [(4.0, 0.0), (4.0, 0.0)]);
        assert_eq!(sigma, 2.0);
        assert!((phase - 30.0).abs() < 1e-9, "{phase}");
    }
}
