//! What a record's commands show of the control's interpolator — each axis's peak
//! velocity, acceleration and jerk and the path's peak speed — and, where the record shows
//! the control held at one, that peak as the identified machine's planning limit, so that
//! `check` plans the next program about as that control did.
//!
//! A peak is a limit only where the axis stayed at it, flat, in several stretches of the
//! record, and the template's own planner would have asked for more on the same program:
//! the moves demanded more than the machine gave. A circle at one feed never asks its
//! axes for more than its radius needs; written as the limit, that peak would make every
//! other program look gentler than the machine runs it.

use serde::Serialize;

use crate::compare::Context;
use crate::machine::{AxisName, MachineConfig};
use crate::numeric::units::mm_per_min_from_m_per_s;
use crate::plan::{AxisCommands, Commands};

/// The interpolator's peaks in a record, per axis: X, Y, and Z where the record holds Z's
/// commands and the template simulates Z (where a limit found can be written).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Interpolator {
    /// Peak path speed (mm/min), in space where Z is read.
    pub path_speed_mm_per_min: f64,
    /// Per axis: peak velocity (mm/min).
    pub velocity_mm_per_min: Vec<f64>,
    /// Peak acceleration (m/s²).
    pub accel_m_per_s2: Vec<f64>,
    /// Peak jerk (m/s³): the 99.5th percentile of the acceleration's rate, so that the
    /// single cycles of a stepped acceleration (a trapezoidal interpolator has no jerk
    /// limit) are not taken for the control's jerk.
    pub jerk_m_per_s3: Vec<f64>,
    /// Per axis, the peak acceleration (m/s²) and jerk (m/s³) the template's planner gives
    /// the same program: what the moves demanded.
    pub demanded_accel_m_per_s2: Vec<f64>,
    /// The same for the jerk.
    pub demanded_jerk_m_per_s3: Vec<f64>,
    /// Whether the record shows the acceleration held at its peak (flat for `PLATEAU_S`,
    /// in `PLATEAUS` stretches) where the moves demanded more: the control's limit, not
    /// only what these moves needed.
    pub accel_limited: Vec<bool>,
    /// Whether it shows the jerk held at its peak.
    pub jerk_limited: Vec<bool>,
}

/// How long a peak must be held to count as the control's limit (s), how close to it, and
/// in how many separate stretches.
const PLATEAU_S: f64 = 0.005;
const PLATEAU_SHARE: f64 = 0.98;
const PLATEAUS: usize = 2;

/// How much the path speed must change over a plateau (a share of its peak) for the
/// plateau to be the interpolator ramping at its limit: a circle's centripetal peak comes at
/// constant speed, whatever the limit.
const RAMPING_SHARE: f64 = 0.01;

/// Whether |v| stays within `PLATEAU_SHARE` of `peak` for `PLATEAU_S` in `PLATEAUS`
/// separate stretches while the path speed `speed` (sampled alike) changes, and the moves
/// `demanded` more than the peak.
fn held_at(v: &[f64], peak: f64, demanded: f64, dt: f64, speed: &[f64]) -> bool {
    let need = (PLATEAU_S / dt).ceil() as usize;
    let top = speed.iter().fold(0.0f64, |m, s| m.max(s.abs()));
    let (mut run, mut stretches) = (0usize, 0usize);
    for (k, x) in v.iter().enumerate() {
        run = if peak > 0.0 && x.abs() >= PLATEAU_SHARE * peak {
            run + 1
        } else {
            0
        };
        let ramping = |k: usize| {
            let (a, b) = (speed.get(k + 1 - need), speed.get(k));
            matches!((a, b), (Some(a), Some(b)) if (b - a).abs() > RAMPING_SHARE * top)
        };
        if run == need && ramping(k) {
            stretches += 1;
        }
    }
    stretches >= PLATEAUS && peak < PLATEAU_SHARE * demanded
}

/// The largest magnitude in `v`.
fn peak(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

/// The rate of `a` sampled every `dt`.
fn rate(a: &[f64], dt: f64) -> Vec<f64> {
    a.windows(2).map(|w| (w[1] - w[0]) / dt).collect()
}

/// The peak jerk of the acceleration `a`: the 99.5th percentile of its rate.
fn jerk(a: &[f64], dt: f64) -> f64 {
    let mut rates: Vec<f64> = rate(a, dt).iter().map(|r| r.abs()).collect();
    rates.sort_by(f64::total_cmp);
    rates
        .get(((rates.len() as f64) * 0.995) as usize)
        .copied()
        .unwrap_or(0.0)
}

/// The axes whose peaks a record shows: X and Y, and Z where the record holds its commands
/// and `template` simulates it.
fn axes_read(ctx: &Context, template: &MachineConfig) -> Vec<AxisName> {
    let z = ctx.z_comparable(template).is_ok();
    AxisName::BOTH
        .into_iter()
        .chain(z.then_some(AxisName::Z))
        .collect()
}

/// The peaks of the context's commands, and what `template`'s planner demands on the same
/// program.
pub(crate) fn read(ctx: &Context, template: &MachineConfig) -> Interpolator {
    let read = axes_read(ctx, template);
    let commands = |c: &Commands| -> Vec<AxisCommands> {
        read.iter()
            .map(|a| match a {
                AxisName::X => c.x.clone(),
                AxisName::Y => c.y.clone(),
                AxisName::Z => c.z.clone(),
            })
            .collect()
    };
    let axes = commands(&ctx.commands);
    let planned = crate::plan::sample(&ctx.plan);
    let demanded = commands(&planned);
    let plan_dt = planned.dt_s;
    let demanded_accel: Vec<f64> = demanded.iter().map(|a| peak(&a.acc_m_per_s2)).collect();
    let demanded_jerk: Vec<f64> = demanded
        .iter()
        .map(|a| jerk(&a.acc_m_per_s2, plan_dt))
        .collect();
    let accel: Vec<f64> = axes.iter().map(|a| peak(&a.acc_m_per_s2)).collect();
    let jerks: Vec<f64> = axes.iter().map(|a| jerk(&a.acc_m_per_s2, ctx.dt)).collect();
    // The path speed over the axes read (a plunge of Z alone ramps it too).
    let speed: Vec<f64> = (0..axes[0].vel_m_per_s.len())
        .map(|k| {
            axes.iter()
                .map(|a| a.vel_m_per_s.get(k).map_or(0.0, |v| v * v))
                .sum::<f64>()
                .sqrt()
        })
        .collect();
    Interpolator {
        path_speed_mm_per_min: mm_per_min_from_m_per_s(peak(&speed)),
        velocity_mm_per_min: axes
            .iter()
            .map(|a| mm_per_min_from_m_per_s(peak(&a.vel_m_per_s)))
            .collect(),
        accel_limited: (0..axes.len())
            .map(|i| {
                held_at(
                    &axes[i].acc_m_per_s2,
                    accel[i],
                    demanded_accel[i],
                    ctx.dt,
                    &speed,
                )
            })
            .collect(),
        jerk_limited: (0..axes.len())
            .map(|i| {
                let rates = rate(&axes[i].acc_m_per_s2, ctx.dt);
                held_at(&rates, jerks[i], demanded_jerk[i], ctx.dt, &speed)
            })
            .collect(),
        accel_m_per_s2: accel,
        jerk_m_per_s3: jerks,
        demanded_accel_m_per_s2: demanded_accel,
        demanded_jerk_m_per_s3: demanded_jerk,
    }
}

/// The peaks as the machine's acceleration and jerk limits where the record shows them held
/// (rounded up to three significant digits); elsewhere the moves did not reach the control's
/// limits and the template's stay.
pub(crate) fn write_limits(machine: &mut MachineConfig, interpolator: &Interpolator) {
    let axes = AxisName::BOTH.into_iter().chain([AxisName::Z]);
    for (i, axis) in axes.take(interpolator.accel_limited.len()).enumerate() {
        let limits = &mut machine.axis_mut(axis).limits;
        if interpolator.accel_limited[i] {
            limits.max_accel_m_per_s2 = round_up(interpolator.accel_m_per_s2[i]);
        }
        if interpolator.jerk_limited[i] {
            limits.max_jerk_m_per_s3 = round_up(interpolator.jerk_m_per_s3[i]);
        }
    }
}

/// Rounded up to three significant digits.
fn round_up(v: f64) -> f64 {
    let e = 10f64.powf(v.abs().log10().floor() - 2.0);
    (v / e).ceil() * e
}

#[cfg(test)]
mod tests {
    use super::{held_at, round_up};

    #[test]
    fn a_limit_is_a_peak_held_in_several_stretches_where_more_was_demanded() {
        let dt = 1e-3;
        // Two stretches of 20 ms at 0.5 m/s² between ramps, where the planner would have
        // asked for 2: held.
        let plateaus: Vec<f64> = (0..120)
            .map(|k| {
                if (20..40).contains(&k) || (80..100).contains(&k) {
                    0.5
                } else {
                    0.01 * k as f64 % 0.3
                }
            })
            .collect();
        // The path speed ramps through each plateau (the acceleration's integral).
        let ramp: Vec<f64> = plateaus
            .iter()
            .scan(0.0, |v, a| {
                *v += a * dt;
                Some(*v)
            })
            .collect();
        assert!(held_at(&plateaus, 0.5, 2.0, dt, &ramp));
        // The same where the planner gives 0.5 itself: the moves asked no more.
        assert!(!held_at(&plateaus, 0.5, 0.5, dt, &ramp));
        // At constant path speed (a circle's centripetal peaks): not a limit.
        assert!(!held_at(&plateaus, 0.5, 2.0, dt, &[0.1; 120]));
        // One stretch only: not.
        let once: Vec<f64> = plateaus
            .iter()
            .enumerate()
            .map(|(k, v)| if k < 60 { *v } else { 0.1 })
            .collect();
        assert!(!held_at(&once, 0.5, 2.0, dt, &ramp));
        // A single-sample spike: not.
        let spike: Vec<f64> = (0..60).map(|k| if k == 30 { 0.5 } else { 0.1 }).collect();
        assert!(!held_at(&spike, 0.5, 2.0, dt, &ramp));
    }

    #[test]
    fn limits_round_up_to_three_digits() {
        assert_eq!(round_up(0.49981), 0.5);
        assert!((round_up(1234.5) - 1240.0).abs() < 1e-9);
    }
}
