//! Z on a machine that simulates it, against a record that measured it: the residual of the
//! measured Z against the nominal model's, and the causes on Z the record supports.
//!
//! Z is compared on its own (X and Y keep their analysis as it is): where X and Y are
//! compared, on the commands that drove them — the record's own Z commands where it holds
//! X and Y commands, else the program's plan. The causes tried on Z are the ones a single
//! axis shows by itself: a position gain other than the one set, friction larger than
//! modelled, and lost motion at reversals. A vertical axis reverses differently up and down
//! by its weight alone; the nominal model carries that weight (`[z.gravity]`), so what its
//! reversals show is explained before any cause is tried, and lost motion is named only
//! where it explains more than the weight does.
//!
//! One cause is named at most, the one that explains most, and only when it stands out:
//! Z's residual above three times the record's noise, the fit cutting its sum of squares
//! by a third or more on each half of the record (alternate blocks of time) alike, the
//! fitted value one a machine could have (`plausible`) and more than three standard
//! uncertainties from the nominal one, and no other
//! cause explaining the record within a tenth as well — a record that cannot tell two causes
//! apart names neither. A cause that leaves more than a quarter of Z's residual (RMS) well
//! above the noise, at a value more than twice or less than half the set one, is not named
//! either: nothing else on Z takes what it leaves, and its value is bent towards that.
//! Where the contour is measured in space the diagnosis also takes back a cause on Z that
//! makes the contour residual worse ([`ZFindings::withdraw_cause`]), as it does on X and Y.

use serde::Serialize;

use super::causes::{self, CauseId};
use super::fit::fit_cause;
use super::fit_starts::starts;
use super::plausible::{Observed, implausible};
use super::{Context, FittedParam, Stepping};
use crate::compare::context::ZUncomparable;
use crate::compare::residual::{noise_floor, rms};
use crate::machine::{AxisConfig, AxisName, MachineConfig};
use crate::numeric::units::um_from_m;
use crate::plan::AxisCommands;
use crate::trace::recorded::{BeyondMachine, axis_beyond};

/// The causes tried on Z (those the user allows: `--causes`, `--exclude`).
pub(crate) const Z_CAUSES: [CauseId; 3] =
    [CauseId::KvGain, CauseId::CoulombFriction, CauseId::Backlash];
/// How far the commanded Z must travel over the stretch compared for it to be compared (m).
const Z_MOVES_M: f64 = 0.1e-3;
/// Z's residual must stand this many times above the noise for a cause to be sought.
const ABOVE_NOISE: f64 = 3.0;
/// The share of each half's sum of squares a cause must explain.
const EXPLAINED_SHARE: f64 = 1.0 / 3.0;
/// A fitted value this many standard uncertainties from the nominal one, at least.
const SIGMAS: f64 = 3.0;
/// A second cause whose fit leaves at most this much more than the best's is as good.
const AS_GOOD: f64 = 1.1;
/// The share of Z's residual (RMS, on either half) a cause may leave, above the noise, and
/// still be named at a value far from the set one: one cause is all Z names, so what it
/// leaves nothing else takes — and a fit that leaves a quarter of the residual while moving
/// a value far off bends that value to what it cannot explain.
const LEFT_SHARE_MAX: f64 = 0.25;
/// A value more than this factor from the set one (either way) is far from it: beyond a
/// machine file's usual mismatch (a drive re-tuned, a load estimated) of tens of per cent.
const FAR_FACTOR: f64 = 2.0;

/// What the diagnosis says of Z.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct ZFindings {
    /// Whether Z was compared.
    pub compared: bool,
    /// Why Z was not compared, where the record has Z; `None` where it was, or where the
    /// record has no Z (nothing to say).
    pub not_compared: Option<String>,
    /// Z's noise floor (µm): from its own residual's sample-to-sample differences, or X's
    /// and Y's where lower.
    pub noise_um: f64,
    /// RMS of Z's residual against the nominal model (µm).
    pub before_rms_um: f64,
    /// Its largest magnitude (µm).
    pub before_peak_um: f64,
    /// RMS against the extended model (the nominal one with the cause named, if any) (µm).
    pub after_rms_um: f64,
    /// Where the recorded Z commands over the stretch compared ask more than the machine
    /// file's Z allows: there the model cannot follow them, and no cause is sought.
    pub beyond_machine: Vec<BeyondMachine>,
    /// The cause named on Z, if any.
    pub cause: Option<ZCause>,
    /// Causes fitted on Z but not named, and why.
    pub not_named: Vec<ZNotNamed>,
    /// Z at the diagnosis's samples (those of `Diagnosis::series`), for plots; `None` where
    /// Z was not compared.
    #[serde(skip)]
    pub series: Option<ZSeries>,
}

/// Z at each of the diagnosis's samples: the command, the record and both models (m), NaN
/// where Z is not compared.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ZSeries {
    /// Commanded Z.
    pub reference: Vec<f64>,
    /// Measured Z.
    pub measured: Vec<f64>,
    /// The nominal model's Z.
    pub nominal: Vec<f64>,
    /// The extended model's Z (the nominal one with the cause named on Z, if any).
    pub extended: Vec<f64>,
    /// Where the nominal model misses Z most: program time (s) and source line.
    pub worst: Option<(f64, u32)>,
}

/// A cause named on Z.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ZCause {
    /// The cause.
    pub id: CauseId,
    /// Its fitted parameters.
    pub params: Vec<FittedParam>,
    /// Share of each half's sum of squares it explains (the first and the second half).
    pub explained_share: [f64; 2],
}

/// A cause fitted on Z and not named.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ZNotNamed {
    /// The cause.
    pub id: CauseId,
    /// Why not.
    pub reason: String,
}

/// One cause's fit on Z.
struct Tried {
    id: CauseId,
    values: Vec<f64>,
    sigma: Vec<f64>,
    /// Sum of squares on each half after the fit.
    halves: [f64; 2],
}

impl ZFindings {
    fn not_compared(why: &str) -> ZFindings {
        ZFindings {
            not_compared: Some(why.to_owned()),
            ..ZFindings::default()
        }
    }

    /// Takes the cause named on Z back (the machine's Z is restored by the caller): it is
    /// listed as not named, with `reason`, and the extended model's Z is the nominal one.
    pub(crate) fn withdraw_cause(&mut self, reason: String) {
        let Some(c) = self.cause.take() else {
            return;
        };
        self.not_named.insert(0, ZNotNamed { id: c.id, reason });
        self.after_rms_um = self.before_rms_um;
        if let Some(s) = &mut self.series {
            s.extended = s.nominal.clone();
        }
    }

    /// Lines for the terminal.
    pub fn describe(&self) -> Vec<String> {
        if let Some(why) = &self.not_compared {
            return vec![format!("Z: not compared: {why}")];
        }
        if !self.compared {
            return Vec::new();
        }
        let mut lines = vec![format!(
            "Z: compared with the simulated Z: residual RMS {:.2} µm (peak {:.2} µm, noise \
             {:.2} µm){}",
            self.before_rms_um,
            self.before_peak_um,
            self.noise_um,
            if self.cause.is_some() {
                format!(", {:.2} µm with the cause below", self.after_rms_um)
            } else {
                String::new()
            }
        )];
        for b in &self.beyond_machine {
            lines.push(format!(
                "  Z: the model cannot follow these commands, no cause sought: {b}"
            ));
        }
        if let Some(c) = &self.cause {
            let values: Vec<String> = c
                .params
                .iter()
                .map(|p| {
                    format!(
                        "{} = {:.4} ± {:.4} {}",
                        p.key, p.value, p.uncertainty, p.unit
                    )
                })
                .collect();
            lines.push(format!(
                "  found on Z: {} ({}), explaining {:.0} % and {:.0} % of the two halves",
                c.id.as_str(),
                values.join(", "),
                100.0 * c.explained_share[0],
                100.0 * c.explained_share[1]
            ));
        }
        for n in &self.not_named {
            lines.push(format!(
                "  not named: {} on Z ({})",
                n.id.as_str(),
                n.reason
            ));
        }
        lines
    }
}

/// The nominal model's Z (`nominal`, as the comparison simulated it) where Z can be
/// compared against the record, else why not (`None` for a record without Z: nothing to
/// say).
fn nominal_z<'n>(
    ctx: &Context,
    machine: &MachineConfig,
    nominal: Option<&'n [f64]>,
    offset_s: f64,
) -> Result<&'n [f64], Option<&'static str>> {
    match ctx.z_comparable(machine) {
        Err(ZUncomparable::NotRecorded) => return Err(None),
        Err(ZUncomparable::Carried) => {
            return Err(Some(
                "the machine file carries Z without simulating it (give it [z.*] sections to \
                 simulate it)",
            ));
        }
        Err(ZUncomparable::NoCommand) => {
            return Err(Some(
                "the record holds X and Y commands but no Z command (record z_cmd to compare Z)",
            ));
        }
        Ok(()) => {}
    }
    let Some(nominal) = nominal else {
        return Err(Some("the nominal Z cannot be simulated on these commands"));
    };
    if ctx.command_travel_m(AxisName::Z, offset_s) < Z_MOVES_M {
        return Err(Some("Z stands over the stretch compared"));
    }
    Ok(nominal)
}

/// Z's findings: compared where `machine` simulates Z and the record measured it (`nominal`:
/// its nominal Z as the comparison simulated it), the causes of [`Z_CAUSES`] that `allowed`
/// lets be tried sought (none allowed: none sought); `machine` extended by the cause named.
pub(crate) fn diagnose_z(
    ctx: &Context,
    machine: &mut MachineConfig,
    nominal: Option<&[f64]>,
    offset_s: f64,
    allowed: &dyn Fn(&MachineConfig, CauseId) -> bool,
) -> ZFindings {
    let nominal = match nominal_z(ctx, machine, nominal, offset_s) {
        Ok(nominal) => nominal,
        Err(None) => return ZFindings::default(),
        Err(Some(why)) => return ZFindings::not_compared(why),
    };
    let r = compared_residual(ctx, nominal, offset_s);
    // Z's own noise, unless X's and Y's is lower: the same measuring system, where a Z that
    // hunts in its backlash would pass its chatter for noise.
    let noise = noise_floor(std::slice::from_ref(&r)).min(ctx.noise_m());
    let mut findings = ZFindings {
        compared: true,
        not_compared: None,
        noise_um: um_from_m(noise),
        before_rms_um: um_from_m(rms(&r)),
        before_peak_um: um_from_m(r.iter().fold(0.0f64, |m, v| m.max(v.abs()))),
        after_rms_um: um_from_m(rms(&r)),
        beyond_machine: beyond_machine(ctx, machine, offset_s),
        cause: None,
        not_named: Vec::new(),
        series: None,
    };
    let causes: Vec<CauseId> = Z_CAUSES
        .into_iter()
        .filter(|&c| allowed(machine, c))
        .collect();
    if !causes.is_empty() && findings.beyond_machine.is_empty() && rms(&r) > ABOVE_NOISE * noise {
        let before = half_sums(ctx, nominal, offset_s);
        let (tried, undetermined): (Vec<_>, Vec<_>) =
            try_causes(ctx, machine, offset_s, nominal, &causes)
                .into_iter()
                .partition(Result::is_ok);
        findings
            .not_named
            .extend(undetermined.into_iter().filter_map(Result::err).map(|id| {
                ZNotNamed {
                    id,
                    reason: "the record does not determine it: its fit runs to a bound of its \
                         range or leaves it open"
                        .to_owned(),
                }
            }));
        let tried = tried.into_iter().filter_map(Result::ok).collect();
        let observed = Observed {
            following_error_max_m: following_error_max(ctx, offset_s),
        };
        let noise_ss = half_counts(ctx, offset_s).map(|n| n * noise * noise);
        choose(&mut findings, machine, tried, before, &observed, noise_ss);
    }
    let extended = match findings.cause {
        Some(_) => ctx.simulate_axis(machine, AxisName::Z),
        None => None,
    };
    if let Some(full) = &extended {
        findings.after_rms_um = um_from_m(rms(&compared_residual(ctx, full, offset_s)));
    }
    let extended = extended.as_deref().unwrap_or(nominal);
    findings.series = Some(series_of(ctx, nominal, extended, offset_s));
    findings
}

/// Z's command, record and models at the context's samples, NaN where Z is not compared,
/// and where the nominal model misses most.
fn series_of(ctx: &Context, nominal: &[f64], extended: &[f64], offset_s: f64) -> ZSeries {
    let times = ctx.sample_times(offset_s);
    let keep = |k: usize, v: f64| {
        if ctx.compared(AxisName::Z, k) {
            v
        } else {
            f64::NAN
        }
    };
    let at = |trace: &[f64]| -> Vec<f64> {
        let v = ctx.at_samples(trace, offset_s);
        v.into_iter().enumerate().map(|(k, v)| keep(k, v)).collect()
    };
    let measured: Vec<f64> = ctx
        .measured_at_samples(AxisName::Z)
        .into_iter()
        .enumerate()
        .map(|(k, v)| keep(k, v))
        .collect();
    let nominal = at(nominal);
    let worst = (0..times.len())
        .filter(|&k| measured[k].is_finite() && nominal[k].is_finite())
        .max_by(|&a, &b| {
            let miss = |k: usize| (measured[k] - nominal[k]).abs();
            miss(a).total_cmp(&miss(b))
        })
        .map(|k| {
            let cycle = (times[k] / ctx.dt).round().max(0.0) as usize;
            let last = ctx.commands.segment.len().saturating_sub(1);
            let segment = ctx
                .commands
                .segment
                .get(cycle.min(last))
                .copied()
                .unwrap_or(0);
            (times[k], ctx.plan.segments[segment as usize].line)
        });
    ZSeries {
        reference: (0..times.len())
            .map(|k| keep(k, ctx.command_at(AxisName::Z, times[k]).0))
            .collect(),
        measured,
        nominal,
        extended: at(extended),
        worst,
    }
}

/// The residual of Z at its compared samples only.
fn compared_residual(ctx: &Context, trace: &[f64], offset_s: f64) -> Vec<f64> {
    ctx.residual(AxisName::Z, trace, offset_s)
        .into_iter()
        .enumerate()
        .filter(|&(k, _)| ctx.compared(AxisName::Z, k))
        .map(|(_, v)| v)
        .collect()
}

/// Where Z's recorded commands over its compared samples ask more than `machine`'s Z allows
/// (its rapid rate, acceleration limit, the acceleration its drive's current gives); none
/// for the program's own plan, which keeps to them.
fn beyond_machine(ctx: &Context, machine: &MachineConfig, offset_s: f64) -> Vec<BeyondMachine> {
    if ctx.fixed_offset.is_none() {
        return Vec::new();
    }
    let times = ctx.sample_times(offset_s);
    let compared: Vec<usize> = (0..times.len())
        .filter(|&k| ctx.compared(AxisName::Z, k))
        .map(|k| ((times[k] / ctx.dt).round().max(0.0) as usize).min(ctx.commands.z.len()))
        .collect();
    let (Some(&from), Some(&to)) = (compared.first(), compared.last()) else {
        return Vec::new();
    };
    let c = &ctx.commands.z;
    let stretch = AxisCommands {
        pos_m: c.pos_m[from..to].to_vec(),
        vel_m_per_s: c.vel_m_per_s[from..to].to_vec(),
        acc_m_per_s2: c.acc_m_per_s2[from..to].to_vec(),
    };
    let mut found = axis_beyond(AxisName::Z, machine.axis(AxisName::Z), &stretch, ctx.dt);
    for b in &mut found {
        b.t_s += from as f64 * ctx.dt + offset_s;
    }
    found
}

/// The largest |commanded − measured| Z over its compared samples (m).
fn following_error_max(ctx: &Context, offset_s: f64) -> f64 {
    let measured = ctx.measured_at_samples(AxisName::Z);
    ctx.sample_times(offset_s)
        .iter()
        .zip(measured)
        .enumerate()
        .filter(|&(k, _)| ctx.compared(AxisName::Z, k))
        .map(|(_, (&t, m))| (ctx.command_at(AxisName::Z, t).0 - m).abs())
        .fold(0.0, f64::max)
}

/// Z's sum of squares on each half of the record (alternate blocks of time).
fn half_sums(ctx: &Context, trace: &[f64], offset_s: f64) -> [f64; 2] {
    let halves = ctx.axis_halves(AxisName::Z, offset_s);
    let r = ctx.residual(AxisName::Z, trace, offset_s);
    let mut sums = [0.0; 2];
    for (v, h) in r.iter().zip(halves) {
        if let Some(first) = h {
            sums[usize::from(!first)] += v * v;
        }
    }
    sums
}

/// How many of Z's compared samples each half of the record holds.
fn half_counts(ctx: &Context, offset_s: f64) -> [f64; 2] {
    let mut counts = [0.0; 2];
    for first in ctx.axis_halves(AxisName::Z, offset_s).into_iter().flatten() {
        counts[usize::from(!first)] += 1.0;
    }
    counts
}

/// Each of `causes` fitted on Z, side by side; `Err` for one whose fit determined nothing
/// (a value run to its bound, or one the record leaves open).
fn try_causes(
    ctx: &Context,
    machine: &MachineConfig,
    offset_s: f64,
    nominal: &[f64],
    causes: &[CauseId],
) -> Vec<Result<Tried, CauseId>> {
    use rayon::prelude::*;
    // Z is fitted on the program's clock as X and Y placed it.
    let fit_ctx = Context {
        stepping: Stepping::PerCycleWhereExact,
        fixed_offset: ctx.fixed_offset.or(Some(offset_s)),
        ..ctx.clone()
    };
    let axis = machine.axis(AxisName::Z);
    causes
        .par_iter()
        .filter_map(|&id| {
            let current: Vec<f64> = id
                .params()
                .iter()
                .map(|p| causes::get(axis, p.key))
                .collect();
            let guess = match id {
                CauseId::Backlash => vec![2.0],
                _ => current.clone(),
            };
            let f = fit_cause(
                &fit_ctx,
                machine,
                AxisName::Z,
                id,
                &starts(id, guess, &current),
                offset_s,
                nominal,
            );
            let Some(f) = f else {
                return Some(Err(id));
            };
            let mut m = machine.clone();
            causes::apply(m.axis_mut(AxisName::Z), id, &f.values);
            let trace = ctx.simulate_axis(&m, AxisName::Z)?;
            Some(Ok(Tried {
                id,
                values: f.values,
                sigma: f.sigma,
                halves: half_sums(ctx, &trace, offset_s),
            }))
        })
        .collect()
}

/// Names the best cause that stands out, if the record tells it from the others; the rest
/// are listed with why they are not named. `before` is Z's sum of squares on each half
/// against the nominal model, `noise_ss` the noise's.
fn choose(
    findings: &mut ZFindings,
    machine: &mut MachineConfig,
    tried: Vec<Tried>,
    before: [f64; 2],
    observed: &Observed,
    noise_ss: [f64; 2],
) {
    let axis = machine.axis(AxisName::Z).clone();
    let share = |t: &Tried| [0, 1].map(|h| 1.0 - t.halves[h] / before[h].max(f64::MIN_POSITIVE));
    let why_not = |t: &Tried| -> Option<String> {
        let s = share(t);
        if s.iter().any(|&s| s < EXPLAINED_SHARE) {
            return Some(format!(
                "explains {:.0} % and {:.0} % of the two halves, less than {:.0} % of each",
                100.0 * s[0],
                100.0 * s[1],
                100.0 * EXPLAINED_SHARE
            ));
        }
        if let Some(why) = implausible(t.id, &t.values, &axis, observed) {
            return Some(why);
        }
        if let Some(why) = leaves_too_much(t, &axis, before, noise_ss) {
            return Some(why);
        }
        t.id.params().iter().enumerate().find_map(|(i, p)| {
            let nominal = causes::get(&axis, p.key);
            ((t.values[i] - nominal).abs() < SIGMAS * t.sigma[i]).then(|| {
                format!(
                    "{} = {:.4} ± {:.4} {}, within {SIGMAS} uncertainties of the nominal {:.4}",
                    p.key, t.values[i], t.sigma[i], p.unit, nominal
                )
            })
        })
    };
    let total = |t: &Tried| t.halves[0] + t.halves[1];
    let mut standing: Vec<&Tried> = tried.iter().filter(|t| why_not(t).is_none()).collect();
    standing.sort_by(|a, b| total(a).total_cmp(&total(b)));
    let tie = match standing.as_slice() {
        [best, second, ..] if total(second) <= AS_GOOD * total(best) => Some(second.id),
        _ => None,
    };
    let named = standing.first().filter(|_| tie.is_none()).map(|t| t.id);
    for t in &tried {
        if Some(t.id) == named {
            findings.cause = Some(ZCause {
                id: t.id,
                params: params_of(t),
                explained_share: share(t),
            });
            causes::apply(machine.axis_mut(AxisName::Z), t.id, &t.values);
            continue;
        }
        let reason = why_not(t).unwrap_or_else(|| match (tie, standing.first()) {
            (Some(_), Some(best)) if [best.id, tie.unwrap_or(best.id)].contains(&t.id) => format!(
                "{} and {} explain the record alike: {}",
                best.id.as_str(),
                tie.unwrap_or(best.id).as_str(),
                best.id.told_apart_from(tie.unwrap_or(best.id))
            ),
            _ => "another cause explains more".to_owned(),
        });
        findings.not_named.push(ZNotNamed { id: t.id, reason });
    }
}

/// Why a cause is not named for what it leaves: more than [`LEFT_SHARE_MAX`] of Z's
/// residual (RMS) on either half, well above the noise (`noise_ss`: the noise's sum of
/// squares on each half), at a value [`FAR_FACTOR`] or more from the set one (or any value
/// where the set one is zero).
fn leaves_too_much(
    t: &Tried,
    axis: &AxisConfig,
    before: [f64; 2],
    noise_ss: [f64; 2],
) -> Option<String> {
    let left = [0, 1].map(|h| (t.halves[h] / before[h].max(f64::MIN_POSITIVE)).sqrt());
    let above_noise = (0..2).any(|h| t.halves[h] > ABOVE_NOISE * ABOVE_NOISE * noise_ss[h]);
    let worst = left[0].max(left[1]);
    if worst <= LEFT_SHARE_MAX || !above_noise {
        return None;
    }
    t.id.params().iter().enumerate().find_map(|(i, p)| {
        let set = causes::get(axis, p.key);
        let ratio = (t.values[i] / set).abs();
        let far = set == 0.0 || !(1.0 / FAR_FACTOR..=FAR_FACTOR).contains(&ratio);
        far.then(|| {
            format!(
                "not determined: {} = {:.4} ± {:.4} {} (set {:.4}) leaves {:.0} % of Z's \
                 residual (RMS) well above its noise — the record holds what this cause \
                 cannot explain, and the value is bent towards it",
                p.key,
                t.values[i],
                t.sigma[i],
                p.unit,
                set,
                100.0 * worst
            )
        })
    })
}

fn params_of(t: &Tried) -> Vec<FittedParam> {
    t.id.params()
        .iter()
        .zip(t.values.iter().zip(&t.sigma))
        .map(|(p, (&value, &uncertainty))| FittedParam {
            key: p.key.to_owned(),
            unit: p.unit.to_owned(),
            value,
            uncertainty,
        })
        .collect()
}
