//! The search for causes: on every axis whose residual exceeds the noise, every cause of
//! the catalogue is fitted ([`super::fit`]), in parallel; the one with the strongest
//! evidence is kept if it beats the thresholds, and the search repeats on the extended
//! model.
//!
//! Evidence is the fall in the residual's sum of squares in units of the noise variance,
//! less ln n per parameter (the Bayesian information criterion with the variance known).
//! On an axis in stick-slip the model does not reproduce, the same on the χ² of the
//! residual's window statistics ([`Context::statistical_residual`]), and only causes that
//! act at low speed and reversals are tried there.

use rayon::prelude::*;
use serde::Serialize;

use super::fit::{self, Fitted};
use super::fit_starts::{initial_guess, starts};
use super::holdout::{HeldOut, JudgedOn, Validation, held_out};
use super::plausible::{Observed, implausible, undetermined};
use super::{Alternative, DiagnoseSettings, FittedParam, FoundCause, Skipped, ripple};
use crate::compare::context::Context;
use crate::compare::residual::{
    CHATTER_AVERAGE_HALF_S, averaged_rms, axis_residual, chatter_mismatch, independent_share, rms,
};
use crate::diagnose::causes::{self, CauseId, Kinematics};
use crate::machine::{AxisName, MachineConfig};
use crate::numeric::units::um_from_m;
use crate::trace::signal::sample;

/// A cause tried on an axis in the first round.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Candidate {
    /// The cause.
    pub id: CauseId,
    /// The axis.
    pub axis: AxisName,
    /// How strongly the residual shows the cause's signature before any fit (0–1).
    pub signature: f64,
    /// Evidence of the fitted cause (BIC units; `null` in JSON when the fit failed or
    /// pinned a parameter at a bound).
    pub evidence: f64,
    /// Share of the residual beyond the noise the fitted cause explains.
    pub share: f64,
}

/// What the search ends with.
pub struct Outcome {
    /// The extended machine.
    pub machine: MachineConfig,
    /// Its traces (X, Y) on the context's clock.
    pub traces: [Vec<f64>; 2],
    /// The clock offset.
    pub offset_s: f64,
    /// Causes kept, in order.
    pub found: Vec<FoundCause>,
    /// Every cause tried in the first round.
    pub candidates: Vec<Candidate>,
    /// Causes that fitted with enough evidence but were not named, and why.
    pub rejected: Vec<Rejected>,
    /// Causes not weighed on an axis whose record cannot show them, and why.
    pub not_weighed: Vec<Skipped>,
    /// Where each of X and Y was given a ripple's period, the period and its source.
    pub ripple_periods: [Option<ripple::Period>; 2],
}

/// A cause that fitted with evidence but is not named.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Rejected {
    /// The cause.
    pub id: CauseId,
    /// The axis.
    pub axis: AxisName,
    /// Its fitted parameters.
    pub params: Vec<FittedParam>,
    /// Its in-sample evidence.
    pub evidence: f64,
    /// Why it is not named: implausible values, a worse fit somewhere, or no gain on data
    /// it was not fitted on.
    pub reason: String,
    /// Whether the record shows it (stick-slip's chatter) though the extended model does not
    /// predict the record better: seen, not determined.
    pub seen: bool,
}

/// The causes whose fits take longest, longest first: a gain re-plans the waits and moves
/// both axes; Stribeck starts from a grid of 64; a dead time re-plans too; a resonance
/// starts from 25.
const LONGEST_FITS: [CauseId; 4] = [
    CauseId::KvGain,
    CauseId::Stribeck,
    CauseId::DeadTime,
    CauseId::Resonance,
];

/// A cause to fit on an axis, from these starting points.
struct Try {
    axis: AxisName,
    cause: CauseId,
    starts: Vec<Vec<f64>>,
    signature: f64,
    statistical: bool,
}

/// A fitted try with its evidence and share.
struct Scored {
    try_: Try,
    fitted: Option<Fitted>,
    evidence: f64,
    share: f64,
}

/// The model found so far, as the search's steps read it: the machine with the causes named,
/// its traces (X, Y) on the context's clock, and the clock offset.
#[derive(Clone, Copy)]
pub(crate) struct Current<'a> {
    pub(crate) machine: &'a MachineConfig,
    pub(crate) traces: &'a [Vec<f64>; 2],
    pub(crate) offset_s: f64,
}

impl Outcome {
    fn current(&self) -> Current<'_> {
        Current {
            machine: &self.machine,
            traces: &self.traces,
            offset_s: self.offset_s,
        }
    }
}

/// The candidate a round names, with its held-out figures and the causes that explain the
/// data almost as well.
struct Chosen {
    best: Scored,
    held_out: HeldOut,
    alternatives: Vec<Alternative>,
}

/// Searches for causes from the nominal traces `traces` at clock offset `offset_s`.
pub(crate) fn search(
    ctx: &Context,
    machine: &MachineConfig,
    settings: &DiagnoseSettings,
    traces: [Vec<f64>; 2],
    offset_s: f64,
    mut validation: Option<&mut Validation>,
) -> Outcome {
    let mut outcome = Outcome {
        machine: machine.clone(),
        traces,
        offset_s,
        found: Vec::new(),
        candidates: Vec::new(),
        rejected: Vec::new(),
        not_weighed: Vec::new(),
        ripple_periods: [None, None],
    };
    // Where the machine file names no ripple period, the one the residual shows of those
    // the drive gives: inert (no force) until a ripple is named, and not kept otherwise.
    let may_ripple = |a| super::tries_allowed(machine, settings, a, CauseId::ForceRipple);
    let now = (&outcome.traces, offset_s);
    let periods = ripple::choose_periods(ctx, &mut outcome.machine, now, &may_ripple);
    for (axis, period) in AxisName::BOTH.into_iter().zip(periods) {
        match period {
            Ok(p) => outcome.ripple_periods[axis.index()] = Some(p),
            Err(Some(reason)) => outcome.not_weighed.push(Skipped {
                id: CauseId::ForceRipple,
                axes: vec![axis],
                reason,
            }),
            Err(None) => {}
        }
    }
    let observed = AxisName::BOTH.map(|a| observed_on(ctx, a, offset_s));
    // Only an axis seen to stick is compared on statistics; one whose measurement chatters
    // is compared on them throughout.
    let sticking = AxisName::BOTH.map(|a| ctx.sticking_seen(a, offset_s));
    let mut stick_slip = AxisName::BOTH
        .map(|a| sticking[a.index()] && ctx.measured_chatter_excess(a, offset_s) > 5.0);
    for round in 0..settings.max_causes {
        let mut tries = Vec::new();
        for axis in AxisName::BOTH {
            let now = outcome.current();
            if excess_over_noise(ctx, axis, &now.traces[axis.index()], now.offset_s) < 5.0 {
                continue;
            }
            let statistical = stick_slip[axis.index()]
                || (sticking[axis.index()]
                    && ctx.chatter_excess(axis, &now.traces[axis.index()], now.offset_s) > 5.0);
            stick_slip[axis.index()] = statistical;
            let skip = |cause: CauseId| {
                !super::tries_allowed(machine, settings, axis, cause)
                    || outcome
                        .found
                        .iter()
                        .any(|f| f.axis == axis && f.id == cause)
                    || (statistical && !cause.is_local())
                    || (cause == CauseId::ForceRipple
                        && outcome.ripple_periods[axis.index()].is_none())
            };
            tries.extend(tries_on_axis(ctx, now, axis, settings, statistical, &skip));
        }
        // The longest fits first, so that two cores finish together.
        tries.sort_by_key(|t| {
            LONGEST_FITS
                .iter()
                .position(|&c| c == t.cause)
                .unwrap_or(LONGEST_FITS.len())
        });
        let scored = score(ctx, outcome.current(), tries);
        if round == 0 {
            outcome.candidates = scored.iter().map(Scored::candidate).collect();
        }
        let Some(chosen) = choose(
            ctx,
            settings,
            &mut outcome,
            &observed,
            scored,
            validation.as_deref(),
        ) else {
            break;
        };
        name(
            ctx,
            settings,
            &mut outcome,
            chosen,
            validation.as_deref_mut(),
        );
    }
    let searched = outcome.machine.clone();
    ripple::periods_kept(&mut outcome.machine, &searched, machine);
    outcome
}

impl Scored {
    fn candidate(&self) -> Candidate {
        Candidate {
            id: self.try_.cause,
            axis: self.try_.axis,
            signature: self.try_.signature,
            evidence: self.evidence,
            share: self.share,
        }
    }
}

/// The strongest of the `scored` candidates with enough evidence and share that can exist
/// on the machine, does not make either axis worse and holds on data it was not fitted on;
/// those passed over are added to the outcome's rejected with the reason.
fn choose(
    ctx: &Context,
    settings: &DiagnoseSettings,
    outcome: &mut Outcome,
    observed: &[Observed; 2],
    scored: Vec<Scored>,
    validation: Option<&Validation>,
) -> Option<Chosen> {
    let mut eligible: Vec<Scored> = scored
        .into_iter()
        .filter(|s| {
            s.fitted.is_some() && s.evidence >= settings.evidence && s.share >= settings.min_share
        })
        .collect();
    eligible.sort_by(|a, b| b.evidence.total_cmp(&a.evidence));
    let rivals: Vec<_> = eligible
        .iter()
        .map(|s| (s.try_.cause, s.try_.axis, s.evidence))
        .collect();
    let mut eligible = eligible.into_iter();
    let mut chosen = None;
    for s in eligible.by_ref() {
        let told = |s: &Scored| {
            let margin = (0.01 * s.evidence).max(settings.evidence);
            let axis = s.try_.axis;
            let config = outcome.machine.axis(axis);
            let read = (s.try_.cause == CauseId::ForceRipple).then(|| {
                let r = ctx.residual(axis, &outcome.traces[axis.index()], outcome.offset_s);
                let period_m = config.errors.force_ripple_period_mm * 1e-3;
                let n = 2.0 * ctx.samples.len() as f64;
                ripple::positions_read_evidence(ctx, axis, &r, period_m, n)
            });
            let fit = (s.try_.cause, axis, s.evidence);
            ripple::cannot_tell(fit, config, (&rivals, read), margin).map_or(Ok(()), Err)
        };
        let judged = told(&s)
            .and_then(|()| judge(ctx, settings, outcome.current(), observed, &s, validation));
        match judged {
            Ok(held_out) => {
                chosen = Some((s, held_out));
                break;
            }
            Err(reason) => {
                let (id, axis) = (s.try_.cause, s.try_.axis);
                if !outcome
                    .rejected
                    .iter()
                    .any(|r| r.id == id && r.axis == axis)
                {
                    let fitted = s.fitted.as_ref().expect("filtered on a fit");
                    outcome.rejected.push(Rejected {
                        id,
                        axis,
                        params: fitted_params(id, fitted),
                        evidence: s.evidence,
                        seen: reason.starts_with(SEEN_NOT_DETERMINED),
                        reason,
                    });
                }
            }
        }
    }
    let (best, held_out) = chosen?;
    // Causes that explain the data almost as well: within 1 % of the evidence (at least
    // the threshold's worth), the data barely tell them apart.
    let margin = (0.01 * best.evidence).max(settings.evidence);
    let alternatives = eligible
        .filter(|s| s.evidence >= best.evidence - margin)
        .map(|s| Alternative {
            id: s.try_.cause,
            axis: s.try_.axis,
            evidence: s.evidence,
            params: fitted_params(s.try_.cause, s.fitted.as_ref().expect("filtered on a fit")),
            told_apart_by: s.try_.cause.told_apart_from(best.try_.cause).to_string(),
        })
        .collect();
    Some(Chosen {
        best,
        held_out,
        alternatives,
    })
}

/// Names the chosen cause: the outcome's machine, traces and offset take it on, with the
/// axis's residual figures before and after.
fn name(
    ctx: &Context,
    settings: &DiagnoseSettings,
    outcome: &mut Outcome,
    chosen: Chosen,
    validation: Option<&mut Validation>,
) {
    let Chosen {
        best,
        held_out,
        alternatives,
    } = chosen;
    let (axis, cause) = (best.try_.axis, best.try_.cause);
    let fitted = best.fitted.expect("filtered on a fit");
    let (_, event) = ctx.event_masks(axis, outcome.offset_s, settings.event_window_s);
    // On the samples the axis is compared at.
    let kept: Vec<usize> = (0..ctx.samples.len())
        .filter(|&k| ctx.compared(axis, k))
        .collect();
    let pick = |v: &[f64]| -> Vec<f64> { kept.iter().map(|&k| v[k]).collect() };
    let meas = pick(&ctx.measured_at_samples(axis));
    let event: Vec<bool> = kept.iter().map(|&k| event[k]).collect();
    let residual_of = |trace: &[f64], offset: f64| {
        axis_residual(
            &meas,
            &pick(&ctx.at_samples(trace, offset)),
            &event,
            ctx.sample_dt_s,
            ctx.noise_sigma,
        )
    };
    let before = residual_of(&outcome.traces[axis.index()], outcome.offset_s);
    causes::apply(outcome.machine.axis_mut(axis), cause, &fitted.values);
    if let Some(v) = validation {
        v.accept(&outcome.machine);
    }
    outcome.traces[axis.index()] = fitted.trace.clone();
    outcome.traces[axis.other().index()] = fitted.other.clone();
    outcome.offset_s = fitted.offset_s;
    let ripple_period = outcome.ripple_periods[axis.index()].as_ref();
    outcome.found.push(FoundCause {
        id: cause,
        axis,
        params: fitted_params(cause, &fitted),
        period: ripple::Period::of(cause, outcome.machine.axis(axis), ripple_period),
        evidence: best.evidence,
        held_out,
        statistical: best.try_.statistical,
        before,
        after: residual_of(&outcome.traces[axis.index()], outcome.offset_s),
        alternatives,
    });
}

/// The fitted values as reported parameters.
fn fitted_params(cause: CauseId, fitted: &Fitted) -> Vec<FittedParam> {
    cause
        .params()
        .iter()
        .zip(fitted.values.iter().zip(&fitted.sigma))
        .map(|(p, (v, s))| FittedParam {
            key: p.key.to_string(),
            unit: p.unit.to_string(),
            value: *v,
            uncertainty: *s,
        })
        .collect()
}

/// What the measurement shows of an axis: its largest following error.
fn observed_on(ctx: &Context, axis: AxisName, offset_s: f64) -> Observed {
    let meas = ctx.measured_at_samples(axis);
    let following_error_max_m = ctx
        .samples
        .iter()
        .zip(&meas)
        .map(|(&i, m)| (ctx.command_at(axis, ctx.prog_time(i, offset_s)).0 - m).abs())
        .fold(0.0, f64::max);
    Observed {
        following_error_max_m,
    }
}

/// How much a residual RMS may grow before it counts as worse: a cause on one axis moves
/// the shared clock offset, and the other axis's residual with it, by a hair.
pub(crate) const WORSE_TOLERANCE: f64 = 0.005;

/// Whether a candidate may be named: its values plausible on the machine, neither axis's
/// whole-record RMS worse, and a gain on data it was not fitted on (the second record when
/// there is one, else the half of the record it was not refitted on). The held-out figures
/// when it may; the reason when not.
fn judge(
    ctx: &Context,
    settings: &DiagnoseSettings,
    now: Current,
    observed: &[Observed; 2],
    s: &Scored,
    validation: Option<&Validation>,
) -> Result<HeldOut, String> {
    let current = now.machine;
    let (axis, cause) = (s.try_.axis, s.try_.cause);
    let fitted = s.fitted.as_ref().ok_or("no fit")?;
    if let Some(why) = implausible(
        cause,
        &fitted.values,
        current.axis(axis),
        &observed[axis.index()],
    ) {
        return Err(format!("fits, but implausible: {why}"));
    }
    if let Some(why) = undetermined(cause, &fitted.values, &fitted.sigma) {
        return Err(why);
    }
    if let Some(why) = worse_somewhere(ctx, now, s.try_.statistical, axis, fitted) {
        return Err(why);
    }
    if !s.try_.statistical
        && let Some(why) = evidence_at_the_start(ctx, settings, now, axis, fitted)
    {
        return Err(why);
    }
    let held = match validation {
        Some(v) => v
            .judge(current, axis, cause, &fitted.values, s.try_.statistical)
            .ok_or("the extended machine cannot run the second record")?,
        None => held_out(
            ctx,
            now,
            axis,
            cause,
            &fitted.values,
            s.try_.statistical,
            settings.event_window_s,
        )
        .ok_or("the fit on half of the record failed")?,
    };
    if held.evidence < settings.evidence {
        let unseen = match held.judged_on {
            JudgedOn::OtherHalf => "the half of the record it was not fitted on",
            JudgedOn::SecondRecord => "the second record",
        };
        if held.samples == 0 {
            // The cause cannot be judged, so it is not named: say that, rather than that it
            // failed "over the 0 samples".
            return Err(format!(
                "fits, but {unseen} compares no sample of {}: it cannot be judged on data it \
                 was not fitted on",
                axis.letter()
            ));
        }
        return Err(format!(
            "fits, but does not hold on {unseen} (held-out evidence {:.1}; its {} there, over \
             the {} samples of {} compared, {:.3} → {:.3} µm)",
            held.evidence,
            held.measure.words(),
            held.samples,
            axis.letter(),
            held.rms_before_um,
            held.rms_after_um
        ));
    }
    Ok(held)
}

/// Why the fit makes either axis worse than the current model, if it does: its whole-record
/// residual RMS, or, on an axis in stick-slip fitted on statistics, its chatter mismatch.
fn worse_somewhere(
    ctx: &Context,
    now: Current,
    statistical: bool,
    axis: AxisName,
    fitted: &Fitted,
) -> Option<String> {
    let Current {
        traces, offset_s, ..
    } = now;
    for a in AxisName::BOTH {
        let new = if a == axis {
            &fitted.trace
        } else {
            &fitted.other
        };
        // On an axis in stick-slip no model times the slips, and point by point a model
        // that chatters as the machine does scores worse than one that does not chatter
        // at all: there the measure is the mismatch of chatter amplitude per window.
        let chatter = statistical && a == axis;
        let what = if chatter {
            "chatter amplitude mismatch"
        } else {
            "residual RMS"
        };
        let measure = |trace: &[f64], offset: f64| {
            if chatter {
                chatter_mismatch(
                    &ctx.measured_at_samples(a),
                    &ctx.at_samples(trace, offset),
                    ctx.sample_dt_s,
                    ctx.noise_sigma,
                )
            } else {
                rms(&ctx.residual(a, trace, offset))
            }
        };
        let (before, after) = (
            measure(&traces[a.index()], offset_s),
            measure(new, fitted.offset_s),
        );
        if after > before * (1.0 + WORSE_TOLERANCE) {
            return Some(format!(
                "fits, but makes the {a} {what} worse ({:.3} → {:.3} µm)",
                um_from_m(before),
                um_from_m(after),
            ));
        }
        // Nor may a chattering model's slower part drift from the machine: the residual
        // averaged over a statistical window (the slips' phase averaged out) must not grow
        // beyond what the noise left in that average moves it.
        if chatter {
            let averaged = |trace: &[f64], offset: f64| {
                let r = ctx.residual(a, trace, offset);
                averaged_rms(&r, ctx.sample_dt_s, CHATTER_AVERAGE_HALF_S)
            };
            let (before, after) = (
                averaged(&traces[a.index()], offset_s),
                averaged(new, fitted.offset_s),
            );
            let window = 2.0 * CHATTER_AVERAGE_HALF_S / ctx.sample_dt_s + 1.0;
            let noise_left = ctx.noise_sigma / window.sqrt();
            if after > before * (1.0 + WORSE_TOLERANCE) + noise_left {
                return Some(format!(
                    "fits the chatter, but makes the {a} residual averaged over {:.2} s worse \
                     ({:.3} → {:.3} µm)",
                    2.0 * CHATTER_AVERAGE_HALF_S,
                    um_from_m(before),
                    um_from_m(after),
                ));
            }
            if let Some(why) = worse_point_by_point(ctx, a, (&traces[a.index()], offset_s), fitted)
            {
                return Some(why);
            }
        }
    }
    None
}

/// What a reason for not naming a cause begins with when the record shows it but the
/// extended model does not predict the record better: seen, not determined.
pub const SEEN_NOT_DETERMINED: &str = "seen, not determined: ";

/// One cause seen, not determined, per axis: the one with the most evidence. The others
/// fitted the same chatter less well and are not said to be seen.
pub(crate) fn one_seen_per_axis(rejected: &mut [Rejected]) {
    for axis in AxisName::BOTH {
        let strongest = rejected
            .iter()
            .filter(|r| r.seen && r.axis == axis)
            .map(|r| r.evidence)
            .fold(f64::NEG_INFINITY, f64::max);
        for r in rejected.iter_mut().filter(|r| r.seen && r.axis == axis) {
            if r.evidence < strongest {
                r.seen = false;
                r.reason = format!(
                    "fits the chatter with less evidence than the cause seen on {axis}, and \
                     predicts {axis} no better point by point"
                );
            }
        }
    }
}

/// Why a cause fitted on stick-slip statistics is only seen, if it is: it matches the
/// chatter, but no model times the slips, and point by point — the whole-record RMS the
/// report states — it predicts the axis worse than the model without it. A cause that
/// worsens the fit is never named.
fn worse_point_by_point(
    ctx: &Context,
    a: AxisName,
    (trace, offset_s): (&[f64], f64),
    fitted: &Fitted,
) -> Option<String> {
    let before = rms(&ctx.residual(a, trace, offset_s));
    let after = rms(&ctx.residual(a, &fitted.trace, fitted.offset_s));
    (after > before * (1.0 + WORSE_TOLERANCE)).then(|| {
        format!(
            "{SEEN_NOT_DETERMINED}its chatter matches the record's, but no model times the \
             slips: point by point it predicts {a} worse (residual RMS {:.3} → {:.3} µm), so \
             its values are not determined",
            um_from_m(before),
            um_from_m(after),
        )
    })
}

/// How long after the comparison's first sample a cause's evidence must not all lie (s):
/// there the model's state is least known — a record begun in motion, after an approach,
/// or cut from a longer trace — and a cause fitted to it only mends the start.
const START_S: f64 = 1.0;

/// Why a fit's evidence cannot be trusted for where it lies, if it cannot: what it gains
/// on the samples after the comparison's first [`START_S`] falls short of the evidence
/// threshold (counted as [`score`] counts it). A cause seen only there is a misalignment.
fn evidence_at_the_start(
    ctx: &Context,
    settings: &DiagnoseSettings,
    now: Current,
    axis: AxisName,
    fitted: &Fitted,
) -> Option<String> {
    let times = ctx.sample_times(now.offset_s);
    let from = times.first()? + START_S;
    let late: Vec<usize> = (0..times.len()).filter(|&k| times[k] >= from).collect();
    let late_of = |r: Vec<f64>| -> Vec<f64> { late.iter().map(|&k| r[k]).collect() };
    let sum_sq = |r: &[f64]| r.iter().map(|v| v * v).sum::<f64>();
    let new_trace = |a: AxisName| {
        if a == axis {
            &fitted.trace
        } else {
            &fitted.other
        }
    };
    let (mut before, mut after) = (0.0, 0.0);
    for a in AxisName::BOTH {
        before += sum_sq(&late_of(ctx.residual(
            a,
            &now.traces[a.index()],
            now.offset_s,
        )));
        after += sum_sq(&late_of(ctx.residual(a, new_trace(a), fitted.offset_s)));
    }
    let evidence = if late.is_empty() {
        f64::NEG_INFINITY
    } else {
        let own = late_of(ctx.residual(axis, &fitted.trace, fitted.offset_s));
        let n = 2.0 * late.len() as f64;
        (before - after) / (ctx.noise_sigma * ctx.noise_sigma) * independent_share(&own)
            - fitted.values.len() as f64 * n.ln()
    };
    (evidence < settings.evidence).then(|| {
        let rest = if late.is_empty() {
            "nothing is compared after it".to_string()
        } else {
            format!("evidence on the rest {evidence:.1}")
        };
        format!(
            "fits, but its evidence lies in the comparison's first {START_S:.0} s, where the \
             model's start is least known ({rest})"
        )
    })
}

/// How far an axis's residual exceeds the noise: its sum of squares beyond n σ², in
/// standard deviations of that χ². Only an axis above a few is worth fitting.
fn excess_over_noise(ctx: &Context, axis: AxisName, trace: &[f64], offset_s: f64) -> f64 {
    let r = ctx.residual(axis, trace, offset_s);
    let n = ctx.compared_count(axis) as f64;
    let sigma2 = ctx.noise_sigma * ctx.noise_sigma;
    (r.iter().map(|v| v * v).sum::<f64>() / sigma2 - n) / (2.0 * n).sqrt()
}

/// The causes worth trying on one axis, with their starting points and signatures.
fn tries_on_axis(
    ctx: &Context,
    now: Current,
    axis: AxisName,
    settings: &DiagnoseSettings,
    statistical: bool,
    skip: &dyn Fn(CauseId) -> bool,
) -> Vec<Try> {
    let Current {
        machine: current,
        traces,
        offset_s,
    } = now;
    let trace = &traces[axis.index()];
    let r = ctx.residual(axis, trace, offset_s);
    // Where the axis actually is (the current model): position-dependent errors follow it,
    // not the command, which leads it by the lag.
    let (pos, vel): (Vec<f64>, Vec<f64>) = ctx
        .samples
        .iter()
        .map(|&i| {
            let t = ctx.prog_time(i, offset_s);
            (sample(trace, ctx.dt, t), ctx.command_at(axis, t).1)
        })
        .unzip();
    let other_pos: Vec<f64> = ctx
        .samples
        .iter()
        .map(|&i| {
            sample(
                &traces[axis.other().index()],
                ctx.dt,
                ctx.prog_time(i, offset_s),
            )
        })
        .collect();
    let (reversal, _) = ctx.event_masks(axis, offset_s, settings.event_window_s);
    let ax = current.axis(axis);
    let period_mm = ripple::cyclic_period_mm(ax);
    let ripple_period_mm = match ax.errors.force_ripple_period_mm {
        p if p > 0.0 => p,
        _ => period_mm,
    };
    let kin = Kinematics {
        pos_m: &pos,
        vel_m_per_s: &vel,
        near_reversal: &reversal,
        dt_s: ctx.sample_dt_s,
        cyclic_period_m: period_mm * 1e-3,
        ripple_period_m: ripple_period_mm * 1e-3,
        other_pos_m: &other_pos,
    };
    CauseId::ALL
        .into_iter()
        .filter(|&c| !skip(c))
        .map(|cause| {
            let now: Vec<f64> = cause
                .params()
                .iter()
                .map(|p| causes::get(ax, p.key))
                .collect();
            let guess = match cause {
                CauseId::ForceRipple => {
                    let other = &traces[axis.other().index()];
                    ripple::linear_start(ctx, current, (axis, other), offset_s, &r)
                        .unwrap_or_else(|| now.clone())
                }
                _ => initial_guess(cause, ax, &r, &kin),
            };
            Try {
                axis,
                cause,
                starts: starts(cause, guess, &now),
                signature: causes::signature(cause, &r, &kin),
                statistical,
            }
        })
        .collect()
}

/// Fits every try in parallel and scores it against the current traces.
fn score(ctx: &Context, now: Current, tries: Vec<Try>) -> Vec<Scored> {
    let Current {
        machine: current,
        traces,
        offset_s,
    } = now;
    let sigma2 = ctx.noise_sigma * ctx.noise_sigma;
    let rss_now: f64 = AxisName::BOTH
        .iter()
        .map(|&a| {
            ctx.residual(a, &traces[a.index()], offset_s)
                .iter()
                .map(|v| v * v)
                .sum::<f64>()
        })
        .sum();
    let n_total = 2.0 * ctx.samples.len() as f64;
    tries
        .into_par_iter()
        .map(|t| {
            let other = &traces[t.axis.other().index()];
            let k = t.cause.params().len();
            let (fitted, evidence, share) = if t.statistical {
                let chi2 = |trace: &[f64]| {
                    ctx.statistical_residual(t.axis, trace, offset_s)
                        .iter()
                        .map(|v| v * v)
                        .sum::<f64>()
                };
                let before = chi2(&traces[t.axis.index()]);
                let m = ctx
                    .statistical_residual(t.axis, &traces[t.axis.index()], offset_s)
                    .len() as f64;
                // Uncertainties only for a fit that can be named: one whose χ² falls by
                // less than its penalty never is.
                let needed = fit::Uncertainty::IfGainAtLeast(k as f64 * m.ln());
                let fitted = fit::fit_statistical(
                    ctx,
                    current,
                    t.axis,
                    t.cause,
                    &t.starts,
                    offset_s,
                    other,
                    (before, needed),
                );
                let gain = fitted
                    .as_ref()
                    .map_or(f64::NEG_INFINITY, |f| before - f.chi2_stat);
                (fitted, gain - k as f64 * m.ln(), gain / (before - m))
            } else {
                let fitted =
                    fit::fit_cause(ctx, current, t.axis, t.cause, &t.starts, offset_s, other);
                let gain = fitted
                    .as_ref()
                    .map_or(f64::NEG_INFINITY, |f| (rss_now - f.rss) / sigma2);
                // Evidence is counted on independent samples; the share is what the fit
                // explains of the residual beyond the noise, however smooth the rest.
                let left = fitted
                    .as_ref()
                    .map_or_else(Vec::new, |f| ctx.residual(t.axis, &f.trace, f.offset_s));
                let evidence = causes::evidence(gain, &left, k, n_total);
                let excess = rss_now / sigma2 - n_total;
                (fitted, evidence, gain / excess)
            };
            Scored {
                try_: t,
                fitted,
                evidence,
                share,
            }
        })
        .collect()
}
