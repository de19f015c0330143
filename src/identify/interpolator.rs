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
use crate::plan::AxisCommands;

/// The interpolator's peaks in a record, per axis: X, Y, and Z where the record holds Z's
/// commands and the template simulates Z (where a limit found can be written).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Interpolator {
    /// The axes read, in the order of the per-axis lists below (X, Y, and Z where read).
    #[serde(skip)]
    pub axes: Vec<AxisName>,
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
    /// in `PLATEAUS` stretches, while the path speed ramped with the axis) where the moves
    /// demanded more: the control's limit, not only what these moves needed.
    pub accel_limited: Vec<bool>,
    /// Whether it shows the jerk held at its peak.
    pub jerk_limited: Vec<bool>,
}

/// How long a peak must be held to count as the control's limit (s), how close to it, and
/// in how many separate stretches.
const PLATEAU_S: f64 = 0.005;
const PLATEAU_SHARE: f64 = 0.98;
const PLATEAUS: usize = 2;

/// The fewest samples a plateau spans however coarse the sampling: one sample is a spike,
/// and only two show how the path speed changed across the plateau.
const PLATEAU_SAMPLES: usize = 2;

/// How much the path's counterpart must change over a plateau, as a share of the axis's
/// own change, for the plateau to be the interpolator ramping at its limit: along a line
/// the path speed changes at least as much as any of its axes' speeds, while a circle's
/// centripetal peak comes at constant path speed, whatever the limit. Judged on the axis's
/// own change, never on the record's top speed: a fast move of another axis elsewhere in
/// the record does not hide this axis's ramps.
const RAMPING_SHARE: f64 = 0.5;

/// One axis's series judged for a plateau: `held` (its acceleration, or the rate of it)
/// and `own` the series `held` is the rate of (its velocity, or its acceleration), and
/// `path` the path's counterpart of `own` (the path speed, or its rate), all sampled every
/// `dt`.
struct Series<'a> {
    held: &'a [f64],
    own: &'a [f64],
    path: &'a [f64],
    dt: f64,
}

/// Whether `s.held` stays within `PLATEAU_SHARE` of `peak` for `PLATEAU_S` (and at least
/// `PLATEAU_SAMPLES`) in `PLATEAUS` separate stretches across which the path ramped with
/// the axis, and the moves `demanded` more than the peak.
fn held_at(s: &Series, peak: f64, demanded: f64) -> bool {
    let need = ((PLATEAU_S / s.dt).ceil() as usize).max(PLATEAU_SAMPLES);
    let change = |v: &[f64], k: usize| match (v.get(k + 1 - need), v.get(k)) {
        (Some(a), Some(b)) => (b - a).abs(),
        _ => 0.0,
    };
    let (mut run, mut stretches) = (0usize, 0usize);
    for (k, x) in s.held.iter().enumerate() {
        run = if peak > 0.0 && x.abs() >= PLATEAU_SHARE * peak {
            run + 1
        } else {
            0
        };
        if run == need {
            let own = change(s.own, k);
            if own > 0.0 && change(s.path, k) >= RAMPING_SHARE * own {
                stretches += 1;
            }
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

/// The path speed over `axes` and its rate (the path's acceleration along its direction,
/// v·a/|v|, or |a| where the path stands), per sample.
fn path_speed_and_rate(axes: &[&AxisCommands]) -> (Vec<f64>, Vec<f64>) {
    let n = axes.iter().map(|a| a.vel_m_per_s.len()).min().unwrap_or(0);
    (0..n)
        .map(|k| {
            let (vv, va, aa) = axes.iter().fold((0.0, 0.0, 0.0), |(vv, va, aa), a| {
                let (v, acc) = (a.vel_m_per_s[k], a.acc_m_per_s2[k]);
                (vv + v * v, va + v * acc, aa + acc * acc)
            });
            let speed: f64 = vv.sqrt();
            let along = if speed > 1e-9 { va / speed } else { aa.sqrt() };
            (speed, along)
        })
        .unzip()
}

/// The peaks of the context's commands, and what `template`'s planner demands on the same
/// program.
pub(crate) fn read(ctx: &Context, template: &MachineConfig) -> Interpolator {
    let read = axes_read(ctx, template);
    let axes: Vec<&AxisCommands> = read.iter().map(|&a| ctx.commands.axis(a)).collect();
    let planned = crate::plan::sample(&ctx.plan);
    let demanded: Vec<&AxisCommands> = read.iter().map(|&a| planned.axis(a)).collect();
    let demanded_accel: Vec<f64> = demanded.iter().map(|a| peak(&a.acc_m_per_s2)).collect();
    let demanded_jerk: Vec<f64> = demanded
        .iter()
        .map(|a| jerk(&a.acc_m_per_s2, planned.dt_s))
        .collect();
    let accel: Vec<f64> = axes.iter().map(|a| peak(&a.acc_m_per_s2)).collect();
    let jerks: Vec<f64> = axes.iter().map(|a| jerk(&a.acc_m_per_s2, ctx.dt)).collect();
    // The path over the axes read (a plunge of Z alone ramps it too).
    let (speed, along) = path_speed_and_rate(&axes);
    let accel_limited = axes.iter().enumerate().map(|(i, a)| {
        let s = Series {
            held: &a.acc_m_per_s2,
            own: &a.vel_m_per_s,
            path: &speed,
            dt: ctx.dt,
        };
        held_at(&s, accel[i], demanded_accel[i])
    });
    let jerk_limited = axes.iter().enumerate().map(|(i, a)| {
        let s = Series {
            held: &rate(&a.acc_m_per_s2, ctx.dt),
            own: &a.acc_m_per_s2,
            path: &along,
            dt: ctx.dt,
        };
        held_at(&s, jerks[i], demanded_jerk[i])
    });
    Interpolator {
        path_speed_mm_per_min: mm_per_min_from_m_per_s(peak(&speed)),
        velocity_mm_per_min: axes
            .iter()
            .map(|a| mm_per_min_from_m_per_s(peak(&a.vel_m_per_s)))
            .collect(),
        accel_limited: accel_limited.collect(),
        jerk_limited: jerk_limited.collect(),
        accel_m_per_s2: accel,
        jerk_m_per_s3: jerks,
        demanded_accel_m_per_s2: demanded_accel,
        demanded_jerk_m_per_s3: demanded_jerk,
        axes: read,
    }
}

/// The peaks as the machine's acceleration and jerk limits where the record shows them held
/// (rounded up to three significant digits); elsewhere the moves did not reach the control's
/// limits and the template's stay.
pub(crate) fn write_limits(machine: &mut MachineConfig, interpolator: &Interpolator) {
    for (i, &axis) in interpolator.axes.iter().enumerate() {
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
    use super::{Series, held_at, round_up};

    /// A trapezoidal ramp of one axis: `a` (m/s²) for `ramp` samples from rest, cruise,
    /// and the same down, twice; its velocity and acceleration every `dt`.
    fn two_trapezoids(a: f64, ramp: usize, dt: f64) -> (Vec<f64>, Vec<f64>) {
        let one: Vec<f64> = [vec![0.0; 5], vec![a; ramp], vec![0.0; 10], vec![-a; ramp]].concat();
        let acc = [one.clone(), one, vec![0.0; 5]].concat();
        let vel = acc
            .iter()
            .scan(0.0, |v, x| {
                *v += x * dt;
                Some(*v)
            })
            .collect();
        (vel, acc)
    }

    #[test]
    fn a_limit_is_a_peak_held_in_several_stretches_where_more_was_demanded() {
        let dt = 1e-3;
        // Two moves ramping at 0.5 m/s² for 20 ms, where the planner would have asked
        // for 2: held. Along a line the path speed is the axis's own over the cosine of
        // its angle: here the axis moves alone.
        let (vel, acc) = two_trapezoids(0.5, 20, dt);
        let along = |path| Series {
            held: &acc,
            own: &vel,
            path,
            dt,
        };
        assert!(held_at(&along(&vel), 0.5, 2.0));
        // On a line at 60° to the axis: the path speed twice the axis's.
        let twice: Vec<f64> = vel.iter().map(|v| 2.0 * v).collect();
        assert!(held_at(&along(&twice), 0.5, 2.0));
        // The same where the planner gives 0.5 itself: the moves asked no more.
        assert!(!held_at(&along(&vel), 0.5, 0.5));
        // At constant path speed (a circle's centripetal peaks): not a limit.
        let constant = vec![0.1; vel.len()];
        assert!(!held_at(&along(&constant), 0.5, 2.0));
        // One stretch only (the first ramp up): not.
        let once: Vec<f64> = acc
            .iter()
            .enumerate()
            .map(|(k, v)| if k < 25 { *v } else { 0.1 })
            .collect();
        let s = Series {
            held: &once,
            ..along(&vel)
        };
        assert!(!held_at(&s, 0.5, 2.0));
        // A single-sample spike: not.
        let spike: Vec<f64> = (0..60).map(|k| if k == 30 { 0.5 } else { 0.1 }).collect();
        let s = Series {
            held: &spike,
            ..along(&vel)
        };
        assert!(!held_at(&s, 0.5, 2.0));
    }

    #[test]
    fn a_fast_move_of_another_axis_does_not_hide_a_slow_axis_ramps() {
        // The axis ramps at 0.2 m/s² to 16.7 mm/s (1000 mm/min, 83 ms) twice; elsewhere
        // in the record another axis runs at 10 m/min, the path's top speed. Over a 5 ms
        // plateau the path speed changes by 1 mm/s, 0.6 % of that top: the axis's own
        // change is the measure, and the ramps are the limit.
        let dt = 1e-3;
        let (vel, acc) = two_trapezoids(0.2, 83, dt);
        let mut path = vel.clone();
        path.extend([10.0 / 60.0; 50]);
        let s = Series {
            held: &acc,
            own: &vel,
            path: &path,
            dt,
        };
        assert!(held_at(&s, 0.2, 0.3));
    }

    #[test]
    fn at_coarse_sampling_a_plateau_still_needs_two_samples() {
        // Sampled every 20 ms (50 Hz): 5 ms is less than a sample, yet one sample at the
        // peak is no plateau; two are, with the path speed's change across them.
        let dt = 0.02;
        let (vel, acc) = two_trapezoids(0.2, 5, dt);
        let s = Series {
            held: &acc,
            own: &vel,
            path: &vel,
            dt,
        };
        assert!(held_at(&s, 0.2, 0.3));
        let spikes: Vec<f64> = (0..40)
            .map(|k| if k % 10 == 3 { 0.2 } else { 0.0 })
            .collect();
        let s = Series { held: &spikes, ..s };
        assert!(!held_at(&s, 0.2, 0.3));
    }

    #[test]
    fn limits_round_up_to_three_digits() {
        assert_eq!(round_up(0.49981), 0.5);
        assert!((round_up(1234.5) - 1240.0).abs() < 1e-9);
    }
}
