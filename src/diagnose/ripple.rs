//! The force ripple as a cause ([`CauseId::ForceRipple`]): a force that repeats with the
//! table's position, F = A·sin(2π·x/period + φ) (docs/model.md §5).
//!
//! Its period is the machine file's where it names one (`errors.force_ripple_period_mm`).
//! Otherwise it is chosen among the periods the drive's mechanics give a ripple — a motor
//! turn's travel and its first harmonics (unbalance and eccentricity once a turn, torque
//! ripple and cogging a few times), and the screw's lead where a gear lies between — as the
//! one whose sine and cosine in position explain most of the residual. A free scan of the
//! residual's spectrum against position is not used: a record covers a few tens of periods
//! at most, its spectrum is coarse, and a free period bends towards whatever else the model
//! misses (a bow, a drift) with nothing that ties it to the machine; a period the drive
//! gives is one a user can check and compensate.
//!
//! The amplitude and phase move the residual nearly linearly (the loop is linear but for
//! friction switching): the force's sine and cosine parts are found by least squares from
//! two simulations with a trial part added each, and the search's fit polishes them and
//! gives their uncertainties. A cyclic error in the positions recorded of the same period
//! (`CauseId::CyclicError`) is the other hypothesis: where the record explains both alike,
//! neither is named ([`cannot_tell`]).

use std::f64::consts::TAU;

use serde::Serialize;

use super::causes::{self, CauseId};
use super::locate::{Located, Variable};
use super::search::Rejected;
use crate::compare::context::Context;
use crate::machine::{AxisConfig, AxisName, MachineConfig};
use crate::numeric::two_columns::{PARALLEL, TwoColumns};
use crate::sim::AxisModel;
use crate::trace::signal::sample;

/// How many periods the travel compared must span for a period to be chosen: fewer, and a
/// sine in position is a drift or a bow as much as a ripple.
const PERIODS_SPANNED_MIN: f64 = 3.0;

/// The harmonics of a turn's travel a ripple is looked for at.
const TURN_HARMONICS: [f64; 4] = [1.0, 2.0, 3.0, 4.0];

/// How a reason begins where the record cannot tell a force ripple from an error of the
/// positions read.
pub(crate) const CANNOT_TELL: &str = "cannot tell";

/// The trial force (N) of each part in [`linear_start`]: large beside the noise's worth of
/// force, small beside friction, so that switching instants barely move.
const TRIAL_N: f64 = 10.0;

/// The period a cause that repeats with position was fitted at, and where it came from; all
/// empty for a cause that does not repeat with position.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Period {
    /// The period (mm).
    pub period_mm: Option<f64>,
    /// Where it came from.
    pub period_source: Option<PeriodSource>,
    /// Where it was chosen: the periods (mm) it was chosen among — those the drive gives
    /// that the travel compared spans three times; empty otherwise.
    pub period_chosen_among_mm: Vec<f64>,
}

/// Where a cause's period came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PeriodSource {
    /// The machine file names it.
    MachineFile,
    /// Chosen from the residual among the periods the drive gives.
    Chosen,
    /// The screw's lead: the machine file names no cyclic error's period.
    ScrewLead,
}

impl Period {
    fn from(period_mm: f64, source: PeriodSource, among_mm: Vec<f64>) -> Period {
        Period {
            period_mm: Some(period_mm),
            period_source: Some(source),
            period_chosen_among_mm: among_mm,
        }
    }

    /// The period a named `cause` acts at on `config`: the ripple's as `ripple` holds it
    /// (where the search chose or was given it), the cyclic error's from the machine file
    /// or the screw's lead; none for other causes.
    pub(crate) fn of(cause: CauseId, config: &AxisConfig, ripple: Option<&Period>) -> Period {
        match cause {
            CauseId::ForceRipple => ripple.cloned().unwrap_or_default(),
            CauseId::CyclicError => {
                let source = if config.errors.cyclic_period_mm > 0.0 {
                    PeriodSource::MachineFile
                } else {
                    PeriodSource::ScrewLead
                };
                Period::from(cyclic_period_mm(config), source, Vec::new())
            }
            _ => Period::default(),
        }
    }

    /// In words: "at a period of 4.000 mm, chosen among …"; none without a period.
    pub fn describe(&self) -> Option<String> {
        let mm = self.period_mm?;
        let source = match self.period_source? {
            PeriodSource::MachineFile => "the machine file's".to_string(),
            PeriodSource::ScrewLead => "the screw's lead".to_string(),
            PeriodSource::Chosen => format!(
                "chosen among the drive's {} mm (a motor turn's travel, the screw's lead and \
                 their harmonics the travel compared spans three times)",
                mm_list(&self.period_chosen_among_mm)
            ),
        };
        Some(format!("at a period of {mm:.4} mm ({source})"))
    }
}

/// Periods (mm) as a list: "16, 8, 5.333, 4".
fn mm_list(periods_mm: &[f64]) -> String {
    let each: Vec<String> = periods_mm
        .iter()
        .map(|p| {
            let s = format!("{p:.3}");
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        })
        .collect();
    each.join(", ")
}

/// The periods (m) a ripple of `axis` is looked for at where the machine file names none: a
/// motor turn's travel and its harmonics, and the screw's lead (a screw turn) and its
/// harmonics where a gear makes it another; each once.
pub(crate) fn candidate_periods_m(axis: &AxisConfig) -> Vec<f64> {
    let turn_m = TAU * AxisModel::from_config(axis).travel_per_motor_rad();
    let lead_m = axis.drive.lead_mm * 1e-3;
    let mut turns = vec![turn_m];
    if lead_m > 0.0 && (lead_m - turn_m).abs() > 1e-6 * turn_m {
        turns.push(lead_m);
    }
    let mut periods: Vec<f64> = Vec::new();
    let harmonics = turns
        .into_iter()
        .filter(|t| t.is_finite() && *t > 0.0)
        .flat_map(|t| TURN_HARMONICS.map(|h| t / h));
    for p in harmonics {
        // A screw turn's fourth harmonic is a motor turn where the gear is 1:4.
        if periods.iter().all(|q| (p - q).abs() > 1e-6 * q) {
            periods.push(p);
        }
    }
    periods
}

/// Of `candidates` (m), those the travel over the positions `pos_m` spans
/// [`PERIODS_SPANNED_MIN`] times, and that travel (m).
pub(crate) fn spanned_m(candidates: &[f64], pos_m: &[f64]) -> (Vec<f64>, f64) {
    let finite = pos_m.iter().copied().filter(|p| p.is_finite());
    let (lo, hi) = finite.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
        (lo.min(p), hi.max(p))
    });
    let span_m = (hi - lo).max(0.0);
    let spanned = candidates
        .iter()
        .copied()
        .filter(|p| span_m >= PERIODS_SPANNED_MIN * p)
        .collect();
    (spanned, span_m)
}

/// Of `candidates` (m), the period whose sine and cosine in the positions `pos_m` explain
/// most of the residual `r`, among those the travel spans [`PERIODS_SPANNED_MIN`] times;
/// none where the travel spans none so often.
pub(crate) fn chosen_period_m(candidates: &[f64], r: &[f64], pos_m: &[f64]) -> Option<f64> {
    spanned_m(candidates, pos_m)
        .0
        .into_iter()
        .map(|p| {
            let w = TAU / p;
            let n = r.len().min(pos_m.len());
            let share = causes::explained(
                r,
                n,
                &[&|i| (w * pos_m[i]).sin(), &|i| (w * pos_m[i]).cos()],
                &|_| true,
            );
            (share, p)
        })
        .max_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, p)| p)
}

/// Where the ripple of each of X and Y acts, the search being allowed to try it
/// (`may_try`): the machine file's period, else the one of those the drive gives that the
/// residual under `traces` at `offset_s` shows most, given to `machine`. Not tried where not
/// allowed (`Err(None)`), nor where the travel compared spans none of the drive's periods
/// three times (`Err(Some(why))`): there no period is one the record can show.
pub(crate) fn choose_periods(
    ctx: &Context,
    machine: &mut MachineConfig,
    (traces, offset_s): (&[Vec<f64>; 2], f64),
    may_try: &dyn Fn(AxisName) -> bool,
) -> [Result<Period, Option<String>>; 2] {
    AxisName::BOTH.map(|a| {
        let axis = machine.axis(a);
        if !may_try(a) {
            return Err(None);
        }
        let given_mm = axis.errors.force_ripple_period_mm;
        if given_mm > 0.0 {
            return Ok(Period::from(
                given_mm,
                PeriodSource::MachineFile,
                Vec::new(),
            ));
        }
        // On the samples compared alone: the travel is the one the residual covers.
        let trace = &traces[a.index()];
        let r_all = ctx.residual(a, trace, offset_s);
        let (r, pos): (Vec<f64>, Vec<f64>) = (0..ctx.samples.len())
            .filter(|&k| ctx.compared(a, k))
            .map(|k| {
                let t = ctx.prog_time(ctx.samples[k], offset_s);
                (r_all[k], sample(trace, ctx.dt, t))
            })
            .unzip();
        let candidates = candidate_periods_m(axis);
        let (spanned, span_m) = spanned_m(&candidates, &pos);
        let Some(period_m) = chosen_period_m(&spanned, &r, &pos) else {
            let mm: Vec<f64> = candidates.iter().map(|p| p * 1e3).collect();
            return Err(Some(format!(
                "none of the periods the drive gives ({} mm) fits {PERIODS_SPANNED_MIN:.0} \
                 times into the {:.3} mm {a} travels where compared, and the machine file \
                 names none",
                mm_list(&mm),
                span_m * 1e3
            )));
        };
        machine.axis_mut(a).errors.force_ripple_period_mm = period_m * 1e3;
        let among_mm = spanned.iter().map(|p| p * 1e3).collect();
        Ok(Period::from(period_m * 1e3, PeriodSource::Chosen, among_mm))
    })
}

/// `machine`'s ripple periods as the search left them in `searched` on the axes that carry a
/// ripple, the nominal machine's elsewhere: a period chosen for a ripple not named is not
/// written.
pub(crate) fn periods_kept(
    machine: &mut MachineConfig,
    searched: &MachineConfig,
    nominal: &MachineConfig,
) {
    for a in AxisName::BOTH {
        let from = if machine.axis(a).errors.force_ripple_n > 0.0 {
            searched
        } else {
            nominal
        };
        let period_mm = from.axis(a).errors.force_ripple_period_mm;
        machine.axis_mut(a).errors.force_ripple_period_mm = period_mm;
    }
}

/// The cyclic error's period (mm) on `axis`: the machine file's, else the screw's lead.
pub(crate) fn cyclic_period_mm(axis: &AxisConfig) -> f64 {
    if axis.errors.cyclic_period_mm > 0.0 {
        axis.errors.cyclic_period_mm
    } else {
        axis.drive.lead_mm
    }
}

/// The ripple's amplitude (N) and phase (°) where it best explains the residual `r_now` of
/// `axis` under `machine` (its ripple as it is): the force a·sin(kx) + b·cos(kx) moves the
/// residual nearly linearly in (a, b), so one simulation with a trial sine part added and
/// one with a trial cosine part give each part's column, and least squares their sizes.
/// None where a trial cannot be simulated or the columns do not tell the parts apart.
pub(crate) fn linear_start(
    ctx: &Context,
    machine: &MachineConfig,
    (axis, other): (AxisName, &[f64]),
    offset_s: f64,
    r_now: &[f64],
) -> Option<Vec<f64>> {
    let now = &machine.axis(axis).errors;
    let (a0, b0) = parts(now.force_ripple_n, now.force_ripple_phase_deg);
    let column = |(a, b): (f64, f64)| -> Option<Vec<f64>> {
        let mut m = machine.clone();
        let (amplitude, phase) = amplitude_phase(a, b);
        let errors = &mut m.axis_mut(axis).errors;
        (errors.force_ripple_n, errors.force_ripple_phase_deg) = (amplitude, phase);
        let (trace, _) = ctx.simulate_pair(&m, axis, other)?;
        let r = ctx.residual(axis, &trace, offset_s);
        Some(r.iter().zip(r_now).map(|(x, y)| x - y).collect())
    };
    let (sine, cosine) = rayon::join(|| column((a0 + TRIAL_N, b0)), || column((a0, b0 + TRIAL_N)));
    let (alpha, beta) = least_squares_2(&sine?, &cosine?, r_now)?;
    let (a, b) = (a0 + alpha * TRIAL_N, b0 + beta * TRIAL_N);
    let (amplitude, phase) = amplitude_phase(a, b);
    Some(vec![amplitude, phase])
}

/// The sine and cosine parts (a, b) of A·sin(kx + φ): a = A cos φ, b = A sin φ.
fn parts(amplitude: f64, phase_deg: f64) -> (f64, f64) {
    let (s, c) = phase_deg.to_radians().sin_cos();
    (amplitude * c, amplitude * s)
}

/// A and φ (°) of a·sin(kx) + b·cos(kx) = A·sin(kx + φ).
fn amplitude_phase(a: f64, b: f64) -> (f64, f64) {
    (a.hypot(b), b.atan2(a).to_degrees())
}

/// The (α, β) that make r + α·u + β·v least in squares, over the samples where all three
/// are finite; none where u and v are (nearly) parallel.
fn least_squares_2(u: &[f64], v: &[f64], r: &[f64]) -> Option<(f64, f64)> {
    let finite = |i: usize| u[i].is_finite() && v[i].is_finite() && r[i].is_finite();
    let (alpha, beta) = TwoColumns::over(u, v, r, finite).solve(PARALLEL)?;
    // The pair that cancels r is the fit of −r.
    Some((-alpha, -beta))
}

/// The evidence of a cyclic error of period `period_m` added to the positions recorded on
/// `axis`, against the residual `r` of the model so far: an error of the positions read
/// only, which the record shows as it is — least squares on the sine and cosine of the
/// position measured, no simulation. Counted as the search counts a fit's
/// ([`causes::evidence`]): on the same samples (the axis's compared ones, the other axis
/// unchanged), in the same noise variances, on the independent share of what it leaves, less
/// ln n for each of its two values with n `values_counted`, the fits' own count — so that
/// the two hypotheses are weighed in one currency.
pub(crate) fn positions_read_evidence(
    ctx: &Context,
    axis: AxisName,
    r: &[f64],
    period_m: f64,
    values_counted: f64,
) -> f64 {
    let x = ctx.measured_axis(axis);
    let n = r.len().min(ctx.samples.len());
    let compared: Vec<bool> = (0..n)
        .map(|j| ctx.compared(axis, j) && r[j].is_finite())
        .collect();
    let positions: Vec<f64> = (0..n).map(|j| x[ctx.samples[j]]).collect();
    let read = Read {
        positions_m: &positions,
        compared: &compared,
        period_m,
    };
    read.evidence(&r[..n], ctx.noise_sigma, values_counted)
}

/// A cyclic error of the positions read, as a hypothesis on a residual: the positions
/// measured, the samples compared, the period.
struct Read<'a> {
    positions_m: &'a [f64],
    compared: &'a [bool],
    period_m: f64,
}

impl Read<'_> {
    /// The evidence of the error against `r` (see [`positions_read_evidence`]), noise of
    /// standard deviation `sigma_m`; −∞ where its sine and cosine cannot be told apart.
    fn evidence(&self, r: &[f64], sigma_m: f64, values_counted: f64) -> f64 {
        let k = TAU / self.period_m;
        let kept = |j: usize, v: f64| if self.compared[j] { v } else { 0.0 };
        let column = |f: fn(f64) -> f64| -> Vec<f64> {
            let x = self.positions_m.iter().enumerate();
            x.map(|(j, &x)| kept(j, f(k * x))).collect()
        };
        let (sine, cosine) = (column(f64::sin), column(f64::cos));
        let r: Vec<f64> = r.iter().enumerate().map(|(j, &v)| kept(j, v)).collect();
        let Some((alpha, beta)) = least_squares_2(&sine, &cosine, &r) else {
            return f64::NEG_INFINITY;
        };
        let left: Vec<f64> = (0..r.len())
            .map(|j| r[j] + alpha * sine[j] + beta * cosine[j])
            .collect();
        let squares = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>();
        let gain = (squares(&r) - squares(&left)) / (sigma_m * sigma_m);
        causes::evidence(gain, &left, 2, values_counted)
    }
}

/// Why `cause` — the force ripple or the cyclic error — on `axis` is not named though it
/// fits with `evidence`: where the other of the two, at the same period, fits the record
/// with evidence within `margin` of it or more (`rivals`: the evidence of each cause fitted
/// on each axis this round; for the ripple also `positions_read`, the evidence of a cyclic
/// error of the positions recorded at its period, [`positions_read_evidence`]), the record
/// cannot tell a force pushing the table from an error of the positions read, and naming
/// either would be a guess.
pub(crate) fn cannot_tell(
    (cause, axis, evidence): (CauseId, AxisName, f64),
    config: &AxisConfig,
    (rivals, positions_read): (&[(CauseId, AxisName, f64)], Option<f64>),
    margin: f64,
) -> Option<String> {
    if let Some(read) =
        positions_read.filter(|&e| cause == CauseId::ForceRipple && e >= evidence - margin)
    {
        return Some(format!(
            "{CANNOT_TELL}: a cyclic error in the positions recorded of the ripple's period \
             ({:.4} mm) explains the record as well or better (evidence {read:.1} against \
             {evidence:.1}); told apart by {}",
            config.errors.force_ripple_period_mm,
            cause.told_apart_from(CauseId::CyclicError)
        ));
    }
    let other = match cause {
        CauseId::ForceRipple => CauseId::CyclicError,
        CauseId::CyclicError => CauseId::ForceRipple,
        _ => return None,
    };
    let (ripple_mm, cyclic_mm) = (
        config.errors.force_ripple_period_mm,
        cyclic_period_mm(config),
    );
    if (ripple_mm - cyclic_mm).abs() > 1e-6 * cyclic_mm {
        return None;
    }
    let (_, _, rival) = rivals
        .iter()
        .find(|(c, a, e)| *c == other && *a == axis && *e >= evidence - margin)?;
    Some(format!(
        "{CANNOT_TELL}: {} of the same period ({cyclic_mm:.4} mm) explains the record as well or \
         better (evidence {rival:.1} against {evidence:.1}); told apart by {}",
        match other {
            CauseId::CyclicError => "a cyclic error in the positions recorded",
            _ => "a force ripple pushing the table",
        },
        cause.told_apart_from(other)
    ))
}

/// Whether the residual `located` finds periodic in position repeats at the period of a
/// ripple or cyclic error its axis's record could not tell apart (`rejected` as
/// [`CANNOT_TELL`]; the ripple's period in `periods`, X and Y): a position map learned there
/// would adopt the error of the positions read, the one hypothesis the record cannot back.
pub(crate) fn untold_period(
    located: &Located,
    rejected: &[Rejected],
    periods: &[Option<Period>; 2],
) -> bool {
    let axis = located.axis;
    let untold = rejected.iter().any(|r| {
        r.axis == axis
            && matches!(r.id, CauseId::ForceRipple | CauseId::CyclicError)
            && r.reason.starts_with(CANNOT_TELL)
    });
    let period_mm = periods
        .get(axis.index())
        .and_then(|p| p.as_ref()?.period_mm);
    match (located.variable, located.interval, period_mm) {
        (Some(Variable::Period), Some((found_mm, _)), Some(p)) if untold => {
            (found_mm / p - 1.0).abs() < UNTOLD_PERIOD_TOLERANCE
        }
        _ => false,
    }
}

/// How near a period found in the residual must lie to one the record could not tell a
/// force from an error of the positions read at to be taken for it: the residual's period
/// is found on a grid of a few per cent.
const UNTOLD_PERIOD_TOLERANCE: f64 = 0.05;

/// The largest force the axis's drive can put on the table (N): its current limit through
/// the motor's torque constant and the travel per motor radian; none where the file gives
/// no finite one.
pub(crate) fn peak_force_n(axis: &AxisConfig) -> Option<f64> {
    let model = AxisModel::from_config(axis);
    let peak = model.i_max * model.kt / model.travel_per_motor_rad();
    (peak.is_finite() && peak > 0.0).then_some(peak)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_peak_force_is_the_current_limit_through_the_torque_constant_and_the_turn() {
        // The nominal machine's X: 60 A × 2.34 N·m/A over 16 mm × 0.25 / 2π of travel per
        // motor radian = 140.4 N·m / 0.6366 mm = 220.5 kN.
        let x = MachineConfig::default_preset().x;
        let expected = 60.0 * 2.34 / (16e-3 * 0.25 / TAU);
        let peak = peak_force_n(&x).unwrap();
        assert!(
            (peak / expected - 1.0).abs() < 1e-9,
            "{peak} against {expected}"
        );
    }

    #[test]
    fn two_trial_columns_give_the_parts_back() {
        // r = −(2·u − 3·v): the parts that cancel it are α = 2, β = −3.
        let u: Vec<f64> = (0..50).map(|i| (0.3 * i as f64).sin()).collect();
        let v: Vec<f64> = (0..50).map(|i| (0.3 * i as f64).cos() + 0.1).collect();
        let r: Vec<f64> = u
            .iter()
            .zip(&v)
            .map(|(x, y)| -(2.0 * x - 3.0 * y))
            .collect();
        let (alpha, beta) = least_squares_2(&u, &v, &r).unwrap();
        assert!((alpha - 2.0).abs() < 1e-9 && (beta + 3.0).abs() < 1e-9);
        // Parallel columns tell nothing apart.
        assert!(least_squares_2(&u, &u, &r).is_none());
        // 12 N at 40°: a = 12 cos 40°, b = 12 sin 40°, and back.
        let (a, b) = parts(12.0, 40.0);
        assert!((a - 9.1925).abs() < 1e-4 && (b - 7.7135).abs() < 1e-4);
        let (amplitude, phase) = amplitude_phase(a, b);
        assert!((amplitude - 12.0).abs() < 1e-12 && (phase - 40.0).abs() < 1e-12);
    }

    #[test]
    fn the_period_chosen_is_the_one_in_the_residual_and_spanned_often_enough() {
        // Positions over 60 mm; a residual at 5 mm of period.
        let pos: Vec<f64> = (0..6000).map(|i| i as f64 * 1e-5).collect();
        let r: Vec<f64> = pos.iter().map(|x| (TAU * x / 5e-3 + 0.4).sin()).collect();
        let candidates = [20e-3, 10e-3, 20e-3 / 3.0, 5e-3];
        assert_eq!(chosen_period_m(&candidates, &r, &pos), Some(5e-3));
        // Over 12 mm only the shorter periods are spanned three times.
        let short = &pos[..1200];
        assert_eq!(chosen_period_m(&[20e-3, 10e-3], &r[..1200], short), None);
    }

    #[test]
    fn the_candidates_are_a_turns_travel_and_its_harmonics() {
        let m = MachineConfig::default_preset();
        let lead_m = m.x.drive.lead_mm * 1e-3 * m.x.drive.gear_ratio;
        let c = candidate_periods_m(&m.x);
        assert!((c[0] - lead_m).abs() < 1e-12 * lead_m, "{c:?} {lead_m}");
        assert!((c[3] - lead_m / 4.0).abs() < 1e-12 * lead_m, "{c:?}");
        // A 16 mm lead behind a 1:4 gear: its fourth harmonic is the 4 mm turn, listed once.
        let expected_mm = [4.0, 2.0, 4.0 / 3.0, 1.0, 16.0, 8.0, 16.0 / 3.0];
        assert_eq!(c.len(), expected_mm.len(), "{c:?}");
        for (got, want) in c.iter().zip(expected_mm) {
            assert!((got * 1e3 - want).abs() < 1e-9, "{c:?}");
        }
    }

    #[test]
    fn evidence_counts_the_gain_on_the_independent_share_less_ln_n_per_value() {
        // A white residual left (lag-one correlation clamped at 0) counts all of the gain:
        // 1000 − 2 ln 100 = 990.790.
        let white: Vec<f64> = (0..100)
            .map(|i| if i % 2 == 0 { 1.0 } else { -1.0 })
            .collect();
        let e = causes::evidence(1000.0, &white, 2, 100.0);
        assert!((e - 990.790).abs() < 1e-3, "{e}");
        // A constant one of 10 samples: ρ = 9/10, (1 − ρ)/(1 + ρ) = 1/19.
        let e = causes::evidence(1000.0, &[3e-6; 10], 1, 100.0);
        assert!((e - (1000.0 / 19.0 - 100f64.ln())).abs() < 1e-9, "{e}");
    }

    /// Positions 10 µm apart over 20 mm; a residual of a 2 µm sine of 1 mm period in them
    /// on a constant 1 µm the sine does not explain.
    fn sine_on_a_constant() -> (Vec<f64>, Vec<f64>) {
        let x: Vec<f64> = (0..2000).map(|j| j as f64 * 10e-6).collect();
        let r = x
            .iter()
            .map(|x| 2e-6 * (TAU * x / 1e-3).sin() + 1e-6)
            .collect();
        (x, r)
    }

    #[test]
    fn an_error_of_the_positions_read_is_counted_as_a_fit_is() {
        let (x, r) = sine_on_a_constant();
        let compared = vec![true; x.len()];
        let read = Read {
            positions_m: &x,
            compared: &compared,
            period_m: 1e-3,
        };
        // The sine is taken out whole (20 whole periods: the constant is orthogonal to it):
        // a gain of (2 µm)² × 1000 / (0.1 µm)² = 400 000 noise variances. What it leaves is
        // the constant, whose lag-one correlation over 2000 samples is 1999/2000: counted on
        // 1/3999 of it. Less ln n for each of two values, n = 4000 (both axes' samples).
        let expected = 400_000.0 / 3999.0 - 2.0 * 4000f64.ln();
        let e = read.evidence(&r, 0.1e-6, 4000.0);
        assert!(
            (e - expected).abs() < 1e-6 * expected,
            "{e} against {expected}"
        );
        // Counted on every sample as before, it would have read 600 000 less the same ln n:
        // four thousand times the fit's currency.
        assert!(e < 100.0, "{e}");
        // Samples not compared count neither in the gain nor in what is left: the first
        // period left out (however large there), 19 periods and 1900 samples remain.
        let mut kept = compared.clone();
        let mut far = r.clone();
        for j in 0..100 {
            (kept[j], far[j]) = (false, 1e-3);
        }
        let read = Read {
            compared: &kept,
            ..read
        };
        let expected = 380_000.0 / 3799.0 - 2.0 * 4000f64.ln();
        let e = read.evidence(&far, 0.1e-6, 4000.0);
        assert!(
            (e - expected).abs() < 1e-6 * expected,
            "{e} against {expected}"
        );
    }

    #[test]
    fn no_position_map_is_learned_at_a_period_the_record_could_not_tell() {
        let located = |axis, period_mm: f64| Located {
            axis,
            residual_rms_um: 1.5,
            variable: Some(Variable::Period),
            share: 0.6,
            interval: Some((period_mm, period_mm)),
            peak_um: 2.0,
        };
        let rejected = |reason: &str| Rejected {
            id: CauseId::ForceRipple,
            axis: AxisName::X,
            params: Vec::new(),
            evidence: 4000.0,
            reason: reason.to_string(),
            seen: false,
        };
        let periods = [
            Some(Period::from(4.0, PeriodSource::Chosen, vec![4.0])),
            None,
        ];
        let untold = [rejected("cannot tell: a cyclic error …")];
        assert!(untold_period(
            &located(AxisName::X, 4.03),
            &untold,
            &periods
        ));
        // Another period (12 % off), another axis, or a ripple rejected for another reason
        // leave the map to be learned.
        assert!(!untold_period(
            &located(AxisName::X, 4.5),
            &untold,
            &periods
        ));
        assert!(!untold_period(
            &located(AxisName::Y, 4.0),
            &untold,
            &periods
        ));
        let other = [rejected(
            "no gain on the half of the record it was not fitted on",
        )];
        assert!(!untold_period(&located(AxisName::X, 4.0), &other, &periods));
        // A map over the position, not a period, is not this case.
        let mut by_position = located(AxisName::X, 4.0);
        by_position.variable = Some(Variable::Position(AxisName::X));
        assert!(!untold_period(&by_position, &untold, &periods));
    }

    #[test]
    fn a_ripple_and_a_cyclic_error_of_one_period_explained_alike_are_not_told_apart() {
        let mut x = MachineConfig::default_preset().x;
        x.errors.force_ripple_period_mm = x.drive.lead_mm;
        let rivals = [
            (CauseId::CyclicError, AxisName::X, 995.0),
            (CauseId::ForceRipple, AxisName::X, 1000.0),
        ];
        let ripple = (CauseId::ForceRipple, AxisName::X, 1000.0);
        let why = cannot_tell(ripple, &x, (&rivals, None), 10.0).expect("within the margin");
        assert!(why.starts_with("cannot tell"), "{why}");
        let cyclic = (CauseId::CyclicError, AxisName::X, 995.0);
        assert!(cannot_tell(cyclic, &x, (&rivals, None), 10.0).is_some());
        // Beyond the margin the record tells them apart.
        assert!(cannot_tell(ripple, &x, (&rivals, None), 4.0).is_none());
        // At another period, so does it …
        x.errors.force_ripple_period_mm = x.drive.lead_mm / 3.0;
        assert!(cannot_tell(ripple, &x, (&rivals, None), 10.0).is_none());
        // … but not where an error of the positions read at the ripple's own period
        // explains the record as well, or better.
        for read in [991.0, 2000.0] {
            let why = cannot_tell(ripple, &x, (&rivals, Some(read)), 10.0).unwrap();
            assert!(why.contains("positions recorded"), "{why}");
        }
        assert!(cannot_tell(ripple, &x, (&rivals, Some(989.0)), 10.0).is_none());
    }
}
