//! Evidence from data a fit did not see. A cause fitted on the whole record always lowers
//! its residual a little — on a real machine, by bending towards an effect the catalogue
//! lacks. Before a cause is named it is fitted again on half of the record (alternate
//! blocks of it) and judged on the other half: an extension that describes the machine
//! predicts the unseen half better; one that only absorbs model error does not.
//!
//! Given a second record of the program ([`Validation`]), that record is the unseen data
//! instead: every cause is fitted on the whole first record and judged on the second, which
//! the fits never see.

use super::search::Current;
use super::{DiagnoseError, fit};
use crate::compare::residual::{chatter_mismatch, independent_share};
use crate::compare::{CompareSettings, Comparison, Context, Stepping, compare};
use crate::diagnose::causes::{self, CauseId};
use crate::gcode::Program;
use crate::machine::{AxisName, MachineConfig};
use crate::numeric::golden_section;
use crate::trace::measured::MeasuredTrace;

/// Pieces the quiet time is cut into at most: long against a servo's transients.
const BLOCKS: usize = 8;

/// The data a cause was judged on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum JudgedOn {
    /// The half of the record the cause was not refitted on.
    OtherHalf,
    /// A second record of the program, never fitted on.
    SecondRecord,
}

/// How a cause fitted on one half predicts the other (or on one record, a second).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct HeldOut {
    /// What it was judged on.
    pub judged_on: JudgedOn,
    /// The fall in the held-out half's residual sum of squares, in noise variances, counted
    /// on independent samples (for a stick-slip axis: the fall of its statistics' χ²).
    pub evidence: f64,
    /// The axis's residual on the held-out half before the cause (µm), by `measure`.
    pub rms_before_um: f64,
    /// After, with the values fitted on the other half (µm).
    pub rms_after_um: f64,
    /// The samples of the axis the two figures are over: the held-out half's (or the second
    /// record's) it compares, which may be few where the axis holds still most of the time.
    pub samples: usize,
    /// What the two figures measure: the RMS residual, or for a cause fitted on stick-slip
    /// statistics the RMS mismatch of chatter amplitude per window (point by point a model
    /// that chatters as the machine does, out of phase, scores worse than one that does not).
    pub measure: HeldOutMeasure,
}

/// The measure of [`HeldOut`]'s figures.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum HeldOutMeasure {
    /// The RMS residual.
    Rms,
    /// The RMS mismatch of chatter amplitude per 0.25 s window.
    ChatterMismatch,
}

impl HeldOutMeasure {
    /// The figures' name in a sentence (`RMS 1.2 → 0.8 µm`).
    pub(crate) fn words(self) -> &'static str {
        match self {
            HeldOutMeasure::Rms => "RMS",
            HeldOutMeasure::ChatterMismatch => "chatter amplitude mismatch",
        }
    }
}

/// The compared samples in two halves, as positions among them: what the context's masks
/// are indexed by ([`Context::keeping`] takes a half), `near_event` holding one entry per
/// compared sample and `reversal` marking those of them near a reversal. The record is cut
/// into stretches — each window around an event of the axis (a reversal, an acceleration)
/// on its own, the quiet time between them in pieces of at most an eighth of the record —
/// and the events alternate between the halves, as do the quiet pieces, and the reversals
/// among themselves: a cause that lives at reversals has reversals in both halves. Windows
/// that run together (an axis that accelerates all along a circle is near an event
/// throughout) are cut too, into pieces of `window_len` samples, one window: taken whole,
/// such a run would give one half all of the axis's motion and the other only its
/// standstills. A reversal within such a run is a stretch of its own, counted with the
/// reversals: by the run's pieces, every reversal of a circle test could fall in one half.
fn halves(near_event: &[bool], reversal: &[bool], window_len: usize) -> (Vec<usize>, Vec<usize>) {
    let class = |k: usize| match (reversal.get(k).copied().unwrap_or(false), near_event[k]) {
        (true, _) => 2,
        (false, true) => 1,
        (false, false) => 0,
    };
    let longest = [
        (near_event.len() / BLOCKS).max(1),
        window_len.max(1),
        window_len.max(1),
    ];
    let (mut first, mut second) = (Vec::new(), Vec::new());
    let mut counts = [0usize; 3];
    let mut run_len = 0usize;
    for k in 0..near_event.len() {
        let c = class(k);
        let starts_run = k == 0 || class(k - 1) != c || run_len >= longest[c];
        if starts_run {
            counts[c] += 1;
            run_len = 0;
        }
        run_len += 1;
        if counts[c] % 2 == 1 {
            first.push(k);
        } else {
            second.push(k);
        }
    }
    (first, second)
}

/// Fits `cause` on `axis` on half of the record, starting from the whole record's values
/// `values`, and scores it on the other half against the current traces.
pub(crate) fn held_out(
    ctx: &Context,
    now: Current,
    axis: AxisName,
    cause: CauseId,
    values: &[f64],
    statistical: bool,
    event_window_s: f64,
) -> Option<HeldOut> {
    let Current {
        machine: current,
        traces,
        offset_s,
    } = now;
    let (reversal, near_event) = ctx.event_masks(axis, offset_s, event_window_s);
    // A window spans the event's time on either side of it; one sample more for where its
    // ends fall between samples, so that a window on its own is never cut.
    let window_len = (2.0 * event_window_s / ctx.sample_dt_s).ceil() + 1.0;
    let window_len = if window_len.is_finite() {
        window_len as usize
    } else {
        1
    };
    let (fit_on, judge_on) = halves(&near_event, &reversal, window_len);
    let (train, test) = (ctx.keeping(&fit_on), ctx.keeping(&judge_on));
    let other = &traces[axis.other().index()];
    let starts = [values.to_vec()];
    let fitted = if statistical {
        // Its values are only scored on the other half: no uncertainties.
        let never = (f64::NAN, fit::Uncertainty::Never);
        fit::fit_statistical(
            &train, current, axis, cause, &starts, offset_s, other, never,
        )
    } else {
        fit::fit_cause(&train, current, axis, cause, &starts, offset_s, other)
    }?;
    Some(judged(
        &test,
        JudgedOn::OtherHalf,
        axis,
        statistical,
        (traces, offset_s),
        ([&fitted.trace, &fitted.other], fitted.offset_s),
    ))
}

/// How much better `after` (this axis's and the other's traces, clock offset) predicts
/// `test`'s samples than `before`: the fall of the residual sum of squares over both axes
/// in noise variances, counted on independent samples (for a stick-slip axis, the fall of
/// its statistics' χ²), with the axis's RMS before and after.
fn judged(
    test: &Context,
    judged_on: JudgedOn,
    axis: AxisName,
    statistical: bool,
    before: (&[Vec<f64>; 2], f64),
    after: ([&[f64]; 2], f64),
) -> HeldOut {
    let sum_sq = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>();
    let (this, other) = (axis.index(), axis.other().index());
    let (b_traces, b_offset) = before;
    let ([a_this, a_other], a_offset) = after;
    let res_before = test.residual(axis, &b_traces[this], b_offset);
    let res_after = test.residual(axis, a_this, a_offset);
    let evidence = if statistical {
        let chi2 =
            |trace: &[f64], offset: f64| sum_sq(&test.statistical_residual(axis, trace, offset));
        chi2(&b_traces[this], b_offset) - chi2(a_this, a_offset)
    } else {
        let other_before = test.residual(axis.other(), &b_traces[other], b_offset);
        let other_after = test.residual(axis.other(), a_other, a_offset);
        let gain =
            sum_sq(&res_before) + sum_sq(&other_before) - sum_sq(&res_after) - sum_sq(&other_after);
        gain / (test.noise_sigma * test.noise_sigma) * independent_share(&res_after)
    };
    // Over the samples the axis's residual holds: those it leaves out (hunting holds, the
    // run-in) are zeros in it, and counted they would dilute the figure towards nothing.
    let samples = test.compared_count(axis);
    let compared = samples.max(1) as f64;
    let rms = |v: &[f64]| (sum_sq(v) / compared).sqrt() * 1e6;
    let (rms_before_um, rms_after_um, measure) = if statistical {
        let mismatch = |trace: &[f64], offset: f64| {
            1e6 * chatter_mismatch(
                &test.measured_at_samples(axis),
                &test.at_samples(trace, offset),
                test.sample_dt_s,
                test.noise_sigma,
            )
        };
        (
            mismatch(&b_traces[this], b_offset),
            mismatch(a_this, a_offset),
            HeldOutMeasure::ChatterMismatch,
        )
    } else {
        (rms(&res_before), rms(&res_after), HeldOutMeasure::Rms)
    };
    HeldOut {
        judged_on,
        evidence,
        rms_before_um,
        rms_after_um,
        samples,
        measure,
    }
}

/// How far the clock offset of a record without its commands is searched around its
/// alignment when a cause is judged on it (s): a dead time or a gain shifts the best one.
pub(super) const OFFSET_SEARCH_S: f64 = 0.02;

/// A second record of the program, on which every cause fitted on the first is judged.
#[derive(Clone)]
pub struct Validation<'a> {
    ctx: Context<'a>,
    /// Both axes under the model found so far, and the record's clock offset.
    traces: [Vec<f64>; 2],
    offset_s: f64,
}

impl<'a> Validation<'a> {
    /// Aligns the second record with the program and simulates the nominal machine on it.
    pub(crate) fn new(
        program: &Program,
        machine: &MachineConfig,
        measured: &'a MeasuredTrace,
        settings: &CompareSettings,
    ) -> Result<Self, DiagnoseError> {
        // Used during the search only, at its resolution.
        let Comparison {
            ctx,
            offset_s,
            nominal: traces,
            ..
        } = compare(
            program,
            machine,
            measured,
            settings,
            Stepping::PerCycleWhereExact,
        )?;
        let mut v = Validation {
            ctx,
            traces,
            offset_s,
        };
        v.offset_s = v.best_offset(&v.traces.clone());
        crate::compare::require_motion(&v.ctx, machine, v.offset_s)?;
        Ok(v)
    }

    /// The record's clock offset that fits `traces` best (fixed when it recorded its
    /// commands).
    fn best_offset(&self, traces: &[Vec<f64>; 2]) -> f64 {
        if self.ctx.fixed_offset.is_some() {
            return self.offset_s;
        }
        let sum_sq = |offset: f64| {
            AxisName::BOTH
                .iter()
                .map(|&a| {
                    let r = self.ctx.residual(a, &traces[a.index()], offset);
                    r.iter().map(|x| x * x).sum::<f64>()
                })
                .sum::<f64>()
        };
        let o = self.offset_s;
        golden_section(o - OFFSET_SEARCH_S, o + OFFSET_SEARCH_S, 1e-5, &sum_sq)
    }

    /// Judges `cause` with `values` on `axis` of `current` on this record; `None` when the
    /// extended machine cannot be simulated on it.
    pub(crate) fn judge(
        &self,
        current: &MachineConfig,
        axis: AxisName,
        cause: CauseId,
        values: &[f64],
        statistical: bool,
    ) -> Option<HeldOut> {
        let mut extended = current.clone();
        causes::apply(extended.axis_mut(axis), cause, values);
        let (this, other) =
            self.ctx
                .simulate_pair(&extended, axis, &self.traces[axis.other().index()])?;
        let mut after = self.traces.clone();
        after[axis.index()] = this;
        after[axis.other().index()] = other.into_owned();
        let offset = self.best_offset(&after);
        Some(judged(
            &self.ctx,
            JudgedOn::SecondRecord,
            axis,
            statistical,
            (&self.traces, self.offset_s),
            ([&after[0], &after[1]], offset),
        ))
    }

    /// Takes the machine found so far as the model to judge the next cause against.
    pub(crate) fn accept(&mut self, current: &MachineConfig) {
        for a in AxisName::BOTH {
            if let Some(t) = self.ctx.simulate_axis(current, a) {
                self.traces[a.index()] = t;
            }
        }
        self.offset_s = self.best_offset(&self.traces.clone());
    }
}

#[cfg(test)]
mod tests {
    use super::halves;
    use crate::compare::{CompareSettings, context};
    use crate::diagnose::synth::{SynthSpec, synthesize};
    use crate::gcode::{InterpretOptions, parse_program};
    use crate::machine::{AxisName, MachineConfig};
    use crate::trace::measured::parse_trace;

    /// A part of the compared samples leaves out exactly the samples the whole record left
    /// out among those it keeps. The masks are indexed by position among the compared
    /// samples: a half that took them over as they were would read the first half of them
    /// for its own, and a hold in the record's last fifth would reach neither half.
    #[test]
    fn a_late_hold_reaches_each_half_at_its_own_samples() {
        let machine = MachineConfig::default_preset();
        let text = "G21 G90 G17 G94\nG0 X0 Y0\nG1 X30 Y-10 F1200\nM2\n";
        let program = parse_program(text, "line.nc", &InterpretOptions::default()).unwrap();
        let mut csv = Vec::new();
        synthesize(&program, &machine, &SynthSpec::default())
            .unwrap()
            .write_csv(&mut csv)
            .unwrap();
        let measured = parse_trace(&String::from_utf8(csv).unwrap(), "line.csv").unwrap();
        let settings = CompareSettings::for_machine(&machine);
        let (mut ctx, _) = context(&program, &machine, &measured, &settings).unwrap();
        let n = ctx.samples.len();
        assert!(n >= 80, "{n} samples");
        // Left out by construction: X holds in the record's last fifth, Y has not settled
        // in its first tenth; Z leaves nothing out.
        let held = |k: usize| 5 * k >= 4 * n;
        let unsettled = |k: usize| 10 * k < n;
        ctx.holding[AxisName::X.index()] = (0..n).map(held).collect();
        ctx.unsettled[AxisName::Y.index()] = (0..n).map(unsettled).collect();
        // Quiet throughout: pieces of an eighth of the record alternate, so the last fifth
        // (from 0.8 of it) lies partly in the 7th piece and wholly over the 8th.
        let (first, second) = halves(&vec![false; n], &[], 1);
        for positions in [&first, &second] {
            let part = ctx.keeping(positions);
            assert_eq!(part.samples.len(), positions.len());
            for (j, &k) in positions.iter().enumerate() {
                assert_eq!(part.samples[j], ctx.samples[k]);
                assert_eq!(part.compared(AxisName::X, j), !held(k), "X at {k} of {n}");
                assert_eq!(part.compared(AxisName::Y, j), !unsettled(k), "Y at {k}");
            }
            let own_holds = positions.iter().filter(|&&k| held(k)).count();
            assert!(own_holds > 0, "the late hold reaches both halves");
            assert_eq!(
                part.compared_count(AxisName::X),
                positions.len() - own_holds
            );
            assert!(part.holding[AxisName::Z.index()].is_empty());
        }
        // A position beyond the samples is no sample of the part.
        assert_eq!(ctx.keeping(&[0, n, n + 7]).samples, vec![ctx.samples[0]]);
    }

    /// Windows around events that run together are cut one window long and alternate, so
    /// both halves see the axis move; a window on its own stays whole in one half.
    #[test]
    fn a_run_of_events_is_shared_between_the_halves_and_a_lone_window_is_not_cut() {
        // 800 samples near an event from 100 to 700: six windows of 100 run together.
        let near: Vec<bool> = (0..800).map(|k| (100..700).contains(&k)).collect();
        let (first, second) = halves(&near, &[], 100);
        let events = |half: &[usize]| half.iter().filter(|&&k| near[k]).count();
        assert_eq!((events(&first), events(&second)), (300, 300));
        assert_eq!(first.len() + second.len(), 800);
        // Two lone windows of 100 samples: one in each half, each whole.
        let lone: Vec<bool> = (0..800)
            .map(|k| (100..200).contains(&k) || (400..500).contains(&k))
            .collect();
        let (first, second) = halves(&lone, &[], 100);
        assert!((100..200).all(|k| first.contains(&k)));
        assert!((400..500).all(|k| second.contains(&k)));
        // Two reversals in one run of events, four windows apart (its pieces would give
        // both to one half): one in each half, each whole.
        let reversal: Vec<bool> = (0..800)
            .map(|k| (140..200).contains(&k) || (540..600).contains(&k))
            .collect();
        let (first, second) = halves(&near, &reversal, 100);
        let whole_in =
            |half: &[usize], r: std::ops::Range<usize>| r.clone().all(|k| half.contains(&k));
        assert!(whole_in(&first, 140..200) && whole_in(&second, 540..600));
        assert_eq!(first.len() + second.len(), 800);
    }
}
