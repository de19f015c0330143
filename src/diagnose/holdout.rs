//! Evidence from data a fit did not see. A cause fitted on the whole record always lowers
//! its residual a little — on a real machine, by bending towards an effect the catalogue
//! lacks. Before a cause is named it is fitted again on half of the record (alternate
//! blocks of it) and judged on the other half: an extension that describes the machine
//! predicts the unseen half better; one that only absorbs model error does not.

use super::causes::CauseId;
use super::context::Context;
use super::fit;
use super::residual::independent_share;
use crate::machine::{AxisName, MachineConfig};

/// Pieces the quiet time is cut into at most: long against a servo's transients.
const BLOCKS: usize = 8;

/// How a cause fitted on one half predicts the other.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct HeldOut {
    /// The fall in the held-out half's residual sum of squares, in noise variances, counted
    /// on independent samples (for a stick-slip axis: the fall of its statistics' χ²).
    pub evidence: f64,
    /// The axis's RMS residual on the held-out half before the cause (µm).
    pub rms_before_um: f64,
    /// After, with the values fitted on the other half (µm).
    pub rms_after_um: f64,
}

/// The compared samples in two halves. The record is cut into stretches — each window
/// around an event of the axis (a reversal, an acceleration) on its own, the quiet time
/// between them in pieces of at most an eighth of the record — and the events alternate
/// between the halves, as do the quiet pieces: a cause that lives at reversals has
/// reversals in both halves.
fn halves(ctx: &Context, near_event: &[bool]) -> (Vec<usize>, Vec<usize>) {
    let longest = (ctx.samples.len() / BLOCKS).max(1);
    let (mut first, mut second) = (Vec::new(), Vec::new());
    let mut counts = [0usize; 2];
    let mut run_len = 0usize;
    for (k, &i) in ctx.samples.iter().enumerate() {
        let event = near_event[k];
        let starts_run = k == 0 || near_event[k - 1] != event || (!event && run_len >= longest);
        if starts_run {
            counts[event as usize] += 1;
            run_len = 0;
        }
        run_len += 1;
        if counts[event as usize] % 2 == 1 {
            first.push(i);
        } else {
            second.push(i);
        }
    }
    (first, second)
}

/// Fits `cause` on `axis` on half of the record, starting from the whole record's values
/// `values`, and scores it on the other half against the current traces.
#[allow(clippy::too_many_arguments)]
pub fn held_out(
    ctx: &Context,
    current: &MachineConfig,
    traces: &[Vec<f64>; 2],
    offset_s: f64,
    axis: AxisName,
    cause: CauseId,
    values: &[f64],
    statistical: bool,
    event_window_s: f64,
) -> Option<HeldOut> {
    let (_, near_event) = ctx.event_masks(axis, offset_s, event_window_s);
    let (fit_on, judge_on) = halves(ctx, &near_event);
    let mut train = ctx.clone();
    train.samples = fit_on;
    let mut test = ctx.clone();
    test.samples = judge_on;
    let other = &traces[axis.other().index()];
    let starts = [values.to_vec()];
    let fitted = if statistical {
        fit::fit_statistical(&train, current, axis, cause, &starts, offset_s, other)
    } else {
        fit::fit_cause(&train, current, axis, cause, &starts, offset_s, other)
    }?;
    let sum_sq = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>();
    let before = test.residual(axis, &traces[axis.index()], offset_s);
    let after = test.residual(axis, &fitted.trace, fitted.offset_s);
    let evidence = if statistical {
        let chi2 =
            |trace: &[f64], offset: f64| sum_sq(&test.statistical_residual(axis, trace, offset));
        chi2(&traces[axis.index()], offset_s) - chi2(&fitted.trace, fitted.offset_s)
    } else {
        let other_before = test.residual(axis.other(), other, offset_s);
        let other_after = test.residual(axis.other(), &fitted.other, fitted.offset_s);
        let gain = sum_sq(&before) + sum_sq(&other_before) - sum_sq(&after) - sum_sq(&other_after);
        gain / (ctx.noise_sigma * ctx.noise_sigma) * independent_share(&after)
    };
    let rms = |v: &[f64]| (sum_sq(v) / v.len().max(1) as f64).sqrt() * 1e6;
    Some(HeldOut {
        evidence,
        rms_before_um: rms(&before),
        rms_after_um: rms(&after),
    })
}
