//! Learning from measurements: where the prediction is wrong, which physical cause that is,
//! the model extended and fitted with it, and how much better it then predicts.
//!
//! 1. Simulate the nominal machine on the program's commands (or on the commands the
//!    measurement recorded) and align the measurement's clock to the program's.
//! 2. The residual, measured − simulated, per axis: its RMS, its RMS in windows around the
//!    axis's events (reversals, accelerations — where local causes live), its peaks.
//! 3. The noise floor from the measurement itself: the spread of the residual's sample-to-
//!    sample differences (model errors are smooth at the sampling rate; noise is not).
//! 4. On every axis whose residual exceeds the noise, fit every cause of the catalogue
//!    ([`causes`]) by re-simulation ([`fit`]), jointly with the clock offset. A cause is
//!    kept when its evidence — the fall in residual sum of squares in units of the noise
//!    variance, less ln n per parameter (BIC with the variance known) — exceeds
//!    [`DiagnoseSettings::evidence`]; the strongest is kept first, then the search repeats
//!    on the extended model.

/// The catalogue of causes the diagnosis fits and synthetic records hide.
pub(crate) mod cause_text;
pub mod causes;
pub mod circular;
pub mod compensation;
pub mod fit;
mod fit_starts;
pub mod holdout;
pub mod learn;
pub mod locate;
pub mod plausible;
pub mod repeat;
pub mod report;
pub mod ripple;
pub mod search;
mod summary;
pub mod synth;
pub mod table;
pub mod table_verdict;
pub mod z_axis;

use serde::Serialize;

use crate::analysis::circular::{Circle, circles};
use crate::compare::residual;
pub use crate::compare::residual::{AxisResidual, ResidualStats};
pub use crate::compare::start::{Coverage, StartKind};
pub use crate::compare::{CompareError, CompareSettings, Context, Stepping};
use crate::compare::{Comparison, compare, require_motion};
use crate::gcode::Program;
use crate::machine::{AxisName, MachineConfig, ZAxis};
use crate::numeric::units::um_from_m;
use crate::sim::MeasuredAt;
use crate::trace::measured::MeasuredTrace;
use crate::trace::recorded::BeyondMachine;
use causes::{CauseId, CauseSet};
pub use circular::{CircleLeftOut, CircularComparison};
pub use holdout::{HeldOut, HeldOutMeasure, JudgedOn};
pub use search::{Candidate, Rejected};
use summary::Summary;
use z_axis::ZSeries;

/// Settings of a diagnosis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DiagnoseSettings {
    /// How the record is placed on the program and compared with the model.
    pub compare: CompareSettings,
    /// Evidence a cause needs to be kept (BIC units; 10 is "very strong").
    pub evidence: f64,
    /// Share of the residual beyond the noise a further cause must explain (0–1): a model
    /// error the catalogue does not hold leaves a residual that any cause trims a little,
    /// with evidence to spare on a long record.
    pub min_share: f64,
    /// Most causes named.
    pub max_causes: usize,
    /// Half-width of the event windows (s).
    pub event_window_s: f64,
    /// The causes the search may try.
    pub causes: CauseSet,
}

impl DiagnoseSettings {
    /// Defaults for a machine.
    pub fn for_machine(machine: &MachineConfig) -> Self {
        DiagnoseSettings {
            compare: CompareSettings::for_machine(machine),
            evidence: 10.0,
            min_share: 0.1,
            max_causes: 3,
            event_window_s: 0.3,
            causes: CauseSet::ALL,
        }
    }
}

/// Why a diagnosis could not be made: only where the record cannot be compared with the
/// program — once it can, a diagnosis always has an answer, if only "nothing found".
pub type DiagnoseError = CompareError;

/// A fitted parameter as reported.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FittedParam {
    /// Machine key below the axis, e.g. `drive.backlash_um`.
    pub key: String,
    /// Unit.
    pub unit: String,
    /// Fitted value.
    pub value: f64,
    /// Standard uncertainty.
    pub uncertainty: f64,
}

/// A cause found in the measurement.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FoundCause {
    /// Its id from the fixed vocabulary.
    pub id: CauseId,
    /// The axis.
    pub axis: AxisName,
    /// Fitted parameters.
    pub params: Vec<FittedParam>,
    /// The period it acts at, for a cause that repeats with position.
    pub period: ripple::Period,
    /// Evidence (BIC units) when it was added, fitted on the whole record.
    pub evidence: f64,
    /// Fitted on half of the record and judged on the other half.
    pub held_out: HeldOut,
    /// Whether it was fitted on the statistics of stick-slip chatter rather than point by
    /// point.
    pub statistical: bool,
    /// The axis's residual before adding it.
    pub before: AxisResidual,
    /// After.
    pub after: AxisResidual,
    /// Other causes that explain the data almost as well (the data barely tell them apart).
    pub alternatives: Vec<Alternative>,
}

/// A cause that explains the record almost as well as the one named: the record cannot
/// tell them apart, and the named one is not more likely than this one.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Alternative {
    /// The cause.
    pub id: CauseId,
    /// The axis.
    pub axis: AxisName,
    /// Its evidence.
    pub evidence: f64,
    /// Its fitted parameters.
    pub params: Vec<FittedParam>,
    /// What record would tell it from the named cause.
    pub told_apart_by: String,
}

/// A cause the search did not try, and why.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Skipped {
    /// The cause.
    pub id: CauseId,
    /// The axes it was not tried on.
    pub axes: Vec<AxisName>,
    /// Why.
    pub reason: String,
}

/// A standstill the control held longer (or shorter) than planned.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ExtraWait {
    /// Source line of the block the standstill follows.
    pub line: u32,
    /// Extra time (ms; negative: shorter).
    pub extra_ms: f64,
}

/// Where the residual is largest.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Place {
    /// Axis or "contour".
    pub what: String,
    /// Time on the program's clock (s): the clock of the diagnosis's series and plots.
    pub t_s: f64,
    /// Time on the record's clock (s): where a user finds it in the record, as the stretch
    /// compared is stated.
    pub t_record_s: f64,
    /// Measured X (mm).
    pub x_mm: f64,
    /// Measured Y (mm).
    pub y_mm: f64,
    /// Measured Z (mm), where the contour is measured in space.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub z_mm: Option<f64>,
    /// Source line of the block being executed.
    pub line: u32,
    /// Residual there (µm).
    pub residual_um: f64,
}

/// Series for plots, one entry per residual sample.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Series {
    /// Program time (s).
    pub t_s: Vec<f64>,
    /// Path length of the nearest point (m).
    pub path_s_m: Vec<f64>,
    /// Commanded X, Y (m).
    pub reference: [Vec<f64>; 2],
    /// Measured X, Y (m).
    pub measured: [Vec<f64>; 2],
    /// Nominal model's X, Y (m).
    pub nominal: [Vec<f64>; 2],
    /// Extended model's X, Y (m).
    pub extended: [Vec<f64>; 2],
    /// Contour error residual before and after (m).
    pub contour_residual: [Vec<f64>; 2],
    /// Whether the contour error is measured in space (with Z) on the blocks that move Z
    /// along the contour or lie in ZX or YZ; else in X and Y alone.
    pub contour_in_space: bool,
    /// The plan segment nearest each measured sample.
    pub segment: Vec<u32>,
    /// The plan segment each sample's command lies on.
    pub command_segment: Vec<u32>,
    /// Commanded Z (m).
    pub reference_z: Vec<f64>,
}

impl Series {
    /// Where each sample was commanded, for the circles' figures.
    pub(crate) fn commands(&self) -> crate::analysis::circular::CommandSeries<'_> {
        crate::analysis::circular::CommandSeries {
            segment: &self.command_segment,
            pos_m: [&self.reference[0], &self.reference[1], &self.reference_z],
        }
    }
}

/// The outcome of a diagnosis.
#[derive(Debug, Clone)]
pub struct Diagnosis {
    /// Offset of the measurement's clock: measured time = program time + this (s).
    pub offset_s: f64,
    /// The measurement's noise floor (standard deviation, µm).
    pub noise_floor_um: f64,
    /// Causes found, in the order they were added (empty: no significant cause).
    pub causes: Vec<FoundCause>,
    /// Every cause tried in the first round, with its signature and evidence.
    pub candidates: Vec<Candidate>,
    /// Residuals of the nominal model.
    pub before: ResidualStats,
    /// Residuals of the extended model.
    pub after: ResidualStats,
    /// Where the nominal model's residual is largest.
    pub places: Vec<Place>,
    /// The extended machine.
    pub machine: MachineConfig,
    /// Series for plots.
    pub series: Series,
    /// Number of residual samples per axis.
    pub samples: usize,
    /// The measurement's sampling step (s).
    pub sample_step_s: f64,
    /// With stretches aligned on their own: how much longer than planned the control stood
    /// after a block (source line, extra ms).
    pub extra_waits: Vec<ExtraWait>,
    /// Where the measurement read the positions.
    pub measured_at: MeasuredAt,
    /// Causes not tried, and why.
    pub skipped: Vec<Skipped>,
    /// Causes that fitted but are not named, and why.
    pub rejected: Vec<Rejected>,
    /// Without recorded commands: how much later the record's second half runs than its
    /// first under one clock offset (ms) — the plan's timing error against the machine.
    pub timing_drift_ms: Option<f64>,
    /// Where the recorded commands ask more of an axis than the machine file allows (its
    /// rapid rate, acceleration limit or drive current): there the model cannot follow.
    pub beyond_machine: Vec<BeyondMachine>,
    /// Whether the rapids were compared too (a record with its commands that is mostly
    /// rapids; otherwise they are left out).
    pub rapids_compared: bool,
    /// Per axis (X, Y), the time left out of its point-by-point residual because it held
    /// still while the nominal model hunts there (s); see `Context::hunting_holds`.
    pub hunting_left_out_s: [f64; 2],
    /// Whether any cause could be tried at all (`--max-causes 0`, or every cause excluded
    /// or unseen, leaves none).
    pub searched: bool,
    /// Circular-test figures (ISO 230-4) of the program's full circles: measured, by the
    /// nominal model and by the extended one.
    pub circular: CircularComparison,
    /// The program's full circles (for polar plots of the series).
    pub circles: Vec<Circle>,
    /// Where the residual the extended model leaves lives, per axis whose residual still
    /// stands out from the noise.
    pub unexplained: Vec<locate::Located>,
    /// Terms learned from the residual where no catalogue cause explained it (position
    /// maps), part of `machine`.
    pub learned: Vec<learn::Learned>,
    /// Which stretch of the program was compared, and how the record's start was set.
    pub coverage: Coverage,
    /// Residuals the extended model leaves that repeat at the same places on every pass of
    /// an axis, however small the record's RMS.
    pub localized: Vec<repeat::Localized>,
    /// Z, where the record measured it: compared where the machine simulates Z, with the
    /// cause it shows (part of `machine`).
    pub z: z_axis::ZFindings,
}

/// Diagnoses a measurement of `program` on `machine`.
pub fn diagnose(
    program: &Program,
    machine: &MachineConfig,
    measured: &MeasuredTrace,
    settings: &DiagnoseSettings,
) -> Result<Diagnosis, DiagnoseError> {
    diagnose_validated(program, machine, measured, None, settings)
}

/// [`diagnose`] with a second record of the program, `validation`, on which every cause
/// fitted on `measured` is judged instead of on a held-out half of `measured` itself.
pub fn diagnose_validated(
    program: &Program,
    machine: &MachineConfig,
    measured: &MeasuredTrace,
    validation: Option<&MeasuredTrace>,
    settings: &DiagnoseSettings,
) -> Result<Diagnosis, DiagnoseError> {
    let mut validation = validation
        .map(|v| holdout::Validation::new(program, machine, v, &settings.compare))
        .transpose()?;
    let on = &settings.compare;
    let Comparison {
        ctx,
        offset_s,
        nominal,
        nominal_z,
    } = compare(program, machine, measured, on, Stepping::Full)?;
    require_motion(&ctx, machine, offset_s)?;
    let window_s = settings.event_window_s;
    let models = Models {
        nominal: &nominal,
        nominal_z: nominal_z.as_deref(),
        offset_s,
        window_s,
        z: None,
    };
    let mut outcome = searched(&ctx, machine, settings, &models, validation.as_mut());
    // Z's cause is sought on Z's own commands and record, whatever X's and Y's are.
    let z_set = outcome.machine.z.clone();
    let mut z = z_axis::diagnose_z(
        &ctx,
        &mut outcome.machine,
        models.nominal_z,
        outcome.offset_s,
        &|m, c| settings.max_causes > 0 && tries_allowed(m, settings, AxisName::Z, c),
    );
    let mut summary = judged_on_the_contour(&ctx, machine, &mut outcome, &models, &mut z, &z_set);
    let models = Models {
        z: z.series.as_ref(),
        ..models
    };
    search::one_seen_per_axis(&mut outcome.rejected);
    // What no cause explains: where it lives, and, where a term of the model can stand for
    // that variable, the term learned from it.
    let mut unexplained = locate::locate(&ctx, &outcome.traces, outcome.offset_s);
    let learned = if settings.max_causes > 0 {
        learn_unexplained(&ctx, &mut outcome, &unexplained)
    } else {
        Vec::new()
    };
    if !learned.is_empty() {
        summary = models.summarize(&ctx, &outcome);
        unexplained = locate::locate(&ctx, &outcome.traces, outcome.offset_s);
    }
    let localized = repeat::localize(
        &ctx,
        &outcome.machine,
        &outcome.traces,
        outcome.offset_s,
        window_s,
    );
    Ok(Diagnosis {
        unexplained,
        learned,
        localized,
        skipped: skipped_causes(machine, settings, z.compared, &outcome.not_weighed),
        searched: settings.max_causes > 0
            && CauseId::ALL.into_iter().any(|c| {
                AxisName::BOTH
                    .into_iter()
                    .any(|a| tries_allowed(machine, settings, a, c))
            }),
        beyond_machine: beyond_machine_compared(measured, machine, &ctx, outcome.offset_s),
        ..assemble(&ctx, machine, outcome, summary, z)
    })
}

/// The causes the search finds from the nominal model's X and Y traces at the comparison's
/// clock offset, their traces confirmed at full resolution.
fn searched(
    ctx: &Context,
    machine: &MachineConfig,
    settings: &DiagnoseSettings,
    models: &Models,
    validation: Option<&mut holdout::Validation<'_>>,
) -> search::Outcome {
    // The search's many fits simulate one step per cycle where that gives the same trace.
    let search_ctx = Context {
        stepping: Stepping::PerCycleWhereExact,
        ..ctx.clone()
    };
    let mut outcome = search::search(
        &search_ctx,
        machine,
        settings,
        models.nominal.clone(),
        models.offset_s,
        validation,
    );
    if !outcome.found.is_empty() {
        for a in AxisName::BOTH {
            if let Some(t) = ctx.simulate_axis(&outcome.machine, a) {
                outcome.traces[a.index()] = t;
            }
        }
    }
    outcome
}

/// Where the recorded commands ask more of an axis than the machine file allows, from where
/// the model follows them: after an approach from where the machine stood that it is not
/// driven by, only from the join on.
fn beyond_machine_compared(
    measured: &MeasuredTrace,
    machine: &MachineConfig,
    ctx: &Context,
    offset_s: f64,
) -> Vec<BeyondMachine> {
    let coverage = ctx.coverage(offset_s);
    if coverage.start == StartKind::BeforeProgram && !coverage.approach_simulated {
        measured.beyond_machine_from(machine, coverage.approach_s)
    } else {
        measured.beyond_machine(machine)
    }
}

/// The extended model must not predict the contour worse than the nominal one: the last
/// causes go until it does not. The figures of what stays.
fn keep_contour_no_worse(
    ctx: &Context,
    machine: &MachineConfig,
    outcome: &mut search::Outcome,
    models: &Models,
) -> Summary {
    loop {
        let summary = models.summarize(ctx, outcome);
        // Point by point, the whole-record RMS the report states, for every cause: one
        // fitted on stick-slip statistics too (which no model times) is not named if it
        // predicts the contour worse.
        let [before_r, after_r] = &summary.series.contour_residual;
        let (b, a) = (contour_rms_um(ctx, before_r), contour_rms_um(ctx, after_r));
        if a <= b * (1.0 + search::WORSE_TOLERANCE) || outcome.found.is_empty() {
            return summary;
        }
        let seen = if outcome.found.last().is_some_and(|c| c.statistical) {
            search::SEEN_NOT_DETERMINED
        } else {
            ""
        };
        let reason =
            format!("{seen}fits, but makes the contour residual worse ({b:.3} → {a:.3} µm RMS)");
        drop_last_cause(ctx, machine, outcome, models.nominal, reason);
    }
}

/// The whole-record RMS of a contour residual, point by point, where it is defined (µm).
fn contour_rms_um(ctx: &Context, r: &[f64]) -> f64 {
    let finite: Vec<f64> = r.iter().copied().filter(|v| v.is_finite()).collect();
    um_from_m(residual::averaged_rms(&finite, ctx.sample_dt_s, 0.0))
}

/// X's and Y's causes and Z's judged together on the contour. Z's cause is found on Z's own
/// record, so X's and Y's stay only where, with Z's extended model, the contour is predicted
/// no worse than by the nominal model; then Z's cause stays only where it predicts the
/// contour no worse than Z's nominal model with what stays of theirs. Judged one axis after
/// the other against the nominal model instead, two right causes on the axes of one plane
/// (both gains low on a ZX circle) would each predict the contour worse alone: neither
/// would be named. Where Z's cause goes, the machine's Z is `z_set` again and X's and Y's
/// causes are judged anew with Z's nominal model.
fn judged_on_the_contour(
    ctx: &Context,
    machine: &MachineConfig,
    outcome: &mut search::Outcome,
    models: &Models,
    z: &mut z_axis::ZFindings,
    z_set: &ZAxis,
) -> Summary {
    let summary = keep_contour_no_worse(ctx, machine, outcome, &models.with_z(z.series.as_ref()));
    if z.cause.is_none() || !summary.series.contour_in_space {
        return summary;
    }
    let nominal_z = z.series.clone().map(|mut s| {
        s.extended = s.nominal.clone();
        s
    });
    let without = models.with_z(nominal_z.as_ref()).summarize(ctx, outcome);
    let (b, a) = (
        contour_rms_um(ctx, &without.series.contour_residual[1]),
        contour_rms_um(ctx, &summary.series.contour_residual[1]),
    );
    if a <= b * (1.0 + search::WORSE_TOLERANCE) {
        return summary;
    }
    outcome.machine.z = z_set.clone();
    z.withdraw_cause(format!(
        "fits, but makes the contour residual in space worse ({b:.3} → {a:.3} µm RMS)"
    ));
    keep_contour_no_worse(ctx, machine, outcome, &models.with_z(z.series.as_ref()))
}

/// Extends the outcome's model with a term learned from each unexplained residual that one
/// can stand for; what was learned.
fn learn_unexplained(
    ctx: &Context,
    outcome: &mut search::Outcome,
    unexplained: &[locate::Located],
) -> Vec<learn::Learned> {
    let mut learned = Vec::new();
    for u in unexplained {
        if ripple::untold_period(u, &outcome.rejected, &outcome.ripple_periods) {
            continue;
        }
        if let Some((extended, traces, l)) =
            learn::learn(ctx, &outcome.machine, &outcome.traces, outcome.offset_s, u)
        {
            outcome.machine = extended;
            outcome.traces = traces;
            learned.push(l);
        }
    }
    learned
}

/// The diagnosis from the search's outcome, its figures and Z's findings (the circles'
/// settling from the nominal `machine`'s loops); the caller adds what needs the settings and
/// the rest of the nominal machine.
fn assemble(
    ctx: &Context,
    machine: &MachineConfig,
    outcome: search::Outcome,
    summary: Summary,
    z: z_axis::ZFindings,
) -> Diagnosis {
    // With recorded commands the simulation runs on the measurement's clock; the program
    // starts where the recorded commands start to move, less the plan's standing start.
    let program_start = if ctx.fixed_offset.is_some() {
        outcome.offset_s + ctx.program_start_s
    } else {
        outcome.offset_s
    };
    Diagnosis {
        offset_s: program_start,
        noise_floor_um: um_from_m(ctx.noise_sigma),
        causes: outcome.found,
        candidates: outcome.candidates,
        before: summary.before,
        after: summary.after,
        places: summary.places,
        machine: outcome.machine,
        circular: circular::circular_comparison(ctx, machine, &summary.series, &z),
        series: summary.series,
        samples: ctx.samples.len(),
        sample_step_s: ctx.measured.dt_s,
        extra_waits: ctx
            .extra_wait_s
            .iter()
            .enumerate()
            .filter(|(_, w)| **w != 0.0)
            .map(|(i, w)| ExtraWait {
                line: ctx.plan.segments[i].line,
                extra_ms: w * 1e3,
            })
            .collect(),
        measured_at: ctx.measured_at,
        rejected: outcome.rejected,
        timing_drift_ms: ctx.timing_drift_s.map(|s| s * 1e3),
        beyond_machine: Vec::new(),
        rapids_compared: ctx.rapids_compared,
        hunting_left_out_s: AxisName::BOTH.map(|a| ctx.hunting_left_out_s(a)),
        circles: circles(&ctx.plan.segments),
        coverage: Coverage {
            z_compared: z.compared,
            ..ctx.coverage(outcome.offset_s)
        },
        z,
        unexplained: Vec::new(),
        learned: Vec::new(),
        localized: Vec::new(),
        skipped: Vec::new(),
        searched: false,
    }
}

/// Takes the last cause off the outcome (with `reason`), and rebuilds its machine and
/// traces from the nominal one and the causes left.
fn drop_last_cause(
    ctx: &Context,
    nominal_machine: &MachineConfig,
    outcome: &mut search::Outcome,
    nominal: &[Vec<f64>; 2],
    reason: String,
) {
    let Some(last) = outcome.found.pop() else {
        return;
    };
    // Z's cause is judged on its own (`judged_on_the_contour`): it stays.
    let mut machine = MachineConfig {
        z: outcome.machine.z.clone(),
        ..nominal_machine.clone()
    };
    for c in &outcome.found {
        let values: Vec<f64> = c.params.iter().map(|p| p.value).collect();
        causes::apply(machine.axis_mut(c.axis), c.id, &values);
    }
    ripple::periods_kept(&mut machine, &outcome.machine, nominal_machine);
    let traces = AxisName::BOTH.map(|a| ctx.simulate_axis(&machine, a));
    outcome.traces = match traces {
        [Some(x), Some(y)] => [x, y],
        _ => nominal.clone(),
    };
    outcome.machine = machine;
    outcome.rejected.push(Rejected {
        id: last.id,
        axis: last.axis,
        params: last.params,
        evidence: last.evidence,
        seen: reason.starts_with(search::SEEN_NOT_DETERMINED),
        reason,
    });
}

/// Why the search may not try `cause` on `axis` (left out by the user, or unseen where
/// the record was measured); `None` when it may.
fn skip_reason(
    machine: &MachineConfig,
    settings: &DiagnoseSettings,
    axis: AxisName,
    cause: CauseId,
) -> Option<String> {
    if !settings.causes.contains(cause) {
        return Some("left out by --causes/--exclude".into());
    }
    if let Some(why) = cause.inapplicable_to(machine.axis(axis)) {
        return Some(why.into());
    }
    cause
        .unseen_at(
            settings.compare.measured_at,
            machine.axis(axis).position_loop.feedback,
        )
        .map(|r| {
            format!(
                "measured at the {}: {r}",
                settings.compare.measured_at.as_str()
            )
        })
}

/// Whether the search may try `cause` on `axis`.
pub(crate) fn tries_allowed(
    machine: &MachineConfig,
    settings: &DiagnoseSettings,
    axis: AxisName,
    cause: CauseId,
) -> bool {
    skip_reason(machine, settings, axis, cause).is_none()
}

/// The causes not tried, with the reason, axes merged where the reason is the same; on Z
/// too where it was compared (`z_compared`), among the causes tried on Z; then those the
/// search did not weigh on an axis whose record cannot show them (`not_weighed`).
fn skipped_causes(
    machine: &MachineConfig,
    settings: &DiagnoseSettings,
    z_compared: bool,
    not_weighed: &[Skipped],
) -> Vec<Skipped> {
    let mut out: Vec<Skipped> = Vec::new();
    for cause in CauseId::ALL {
        let on_z = z_compared && z_axis::Z_CAUSES.contains(&cause);
        let axes = AxisName::BOTH
            .into_iter()
            .chain(on_z.then_some(AxisName::Z));
        for axis in axes {
            let Some(reason) = skip_reason(machine, settings, axis, cause) else {
                continue;
            };
            match out.iter_mut().find(|s| s.id == cause && s.reason == reason) {
                Some(s) => s.axes.push(axis),
                None => out.push(Skipped {
                    id: cause,
                    axes: vec![axis],
                    reason,
                }),
            }
        }
    }
    out.extend_from_slice(not_weighed);
    out
}

/// What the search and a summary compare the record with besides the extended model's X
/// and Y: the nominal model's traces and the comparison's clock offset, the event window,
/// and Z at the samples where compared (the contour is then measured in space).
#[derive(Clone, Copy)]
struct Models<'a> {
    /// The nominal model's X and Y (m).
    nominal: &'a [Vec<f64>; 2],
    /// Its Z, where Z can be compared (m): simulated once, by the comparison.
    nominal_z: Option<&'a [f64]>,
    /// The clock offset the comparison found (s).
    offset_s: f64,
    /// Half-width of the event windows (s).
    window_s: f64,
    /// Z at the samples, where compared.
    z: Option<&'a ZSeries>,
}

impl<'a> Models<'a> {
    /// These models with `z` as Z.
    fn with_z(&self, z: Option<&'a ZSeries>) -> Self {
        Models { z, ..*self }
    }

    /// The summary of the outcome's extended X and Y against the record.
    fn summarize(&self, ctx: &Context, outcome: &search::Outcome) -> Summary {
        summary::summarize(
            ctx,
            self.nominal,
            &outcome.traces,
            outcome.offset_s,
            self.window_s,
            self.z,
        )
    }
}
