//! What a record's commands show of the control's interpolator — each axis's peak
//! velocity, acceleration and jerk and the path's peak speed — and those peaks as the
//! identified machine's planning limits, so that `check` plans the next program about as
//! that control did.

use serde::Serialize;

use crate::compare::Context;
use crate::machine::{AxisName, MachineConfig};
use crate::units::mm_per_min_from_m_per_s;

/// The interpolator's peaks in a record.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Interpolator {
    /// Peak path speed (mm/min).
    pub path_speed_mm_per_min: f64,
    /// Per axis (X, Y): peak velocity (mm/min).
    pub velocity_mm_per_min: [f64; 2],
    /// Peak acceleration (m/s²).
    pub accel_m_per_s2: [f64; 2],
    /// Peak jerk (m/s³): the 99.5th percentile of the acceleration's rate, so that the
    /// single cycles of a stepped acceleration (a trapezoidal interpolator has no jerk
    /// limit) are not taken for the control's jerk.
    pub jerk_m_per_s3: [f64; 2],
    /// Whether the record shows the acceleration held at its peak (for `PLATEAU_S`): the
    /// control's limit, not only what these moves needed.
    pub accel_limited: [bool; 2],
    /// Whether it shows the jerk held at its peak.
    pub jerk_limited: [bool; 2],
}

/// How long a peak must be held to count as the control's limit (s), and how close to it.
const PLATEAU_S: f64 = 0.005;
const PLATEAU_SHARE: f64 = 0.98;

/// Whether |v| stays within `PLATEAU_SHARE` of `peak` for `PLATEAU_S` somewhere.
fn held_at(v: &[f64], peak: f64, dt: f64) -> bool {
    let need = (PLATEAU_S / dt).ceil() as usize;
    let mut run = 0usize;
    for x in v {
        run = if peak > 0.0 && x.abs() >= PLATEAU_SHARE * peak {
            run + 1
        } else {
            0
        };
        if run >= need {
            return true;
        }
    }
    false
}

/// The peaks of the context's commands.
pub fn read(ctx: &Context) -> Interpolator {
    let c = &ctx.commands;
    let axes = [&c.x, &c.y];
    let peak = |v: &[f64]| v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let rate = |a: &[f64]| -> Vec<f64> { a.windows(2).map(|w| (w[1] - w[0]) / ctx.dt).collect() };
    let jerk = |a: &[f64]| {
        let mut rates: Vec<f64> = rate(a).iter().map(|r| r.abs()).collect();
        rates.sort_by(f64::total_cmp);
        rates
            .get(((rates.len() as f64) * 0.995) as usize)
            .copied()
            .unwrap_or(0.0)
    };
    let accel = axes.map(|a| peak(&a.acc_m_per_s2));
    let jerks = axes.map(|a| jerk(&a.acc_m_per_s2));
    let path =
        c.x.vel_m_per_s
            .iter()
            .zip(&c.y.vel_m_per_s)
            .fold(0.0f64, |m, (vx, vy)| m.max(vx.hypot(*vy)));
    Interpolator {
        path_speed_mm_per_min: mm_per_min_from_m_per_s(path),
        velocity_mm_per_min: axes.map(|a| mm_per_min_from_m_per_s(peak(&a.vel_m_per_s))),
        accel_m_per_s2: accel,
        jerk_m_per_s3: jerks,
        accel_limited: [0, 1].map(|i| held_at(&axes[i].acc_m_per_s2, accel[i], ctx.dt)),
        jerk_limited: [0, 1].map(|i| held_at(&rate(&axes[i].acc_m_per_s2), jerks[i], ctx.dt)),
    }
}

/// The peaks as the machine's acceleration and jerk limits where the record shows them held
/// (rounded up to three significant digits); elsewhere the moves did not reach the control's
/// limits and the template's stay.
pub(crate) fn write_limits(machine: &mut MachineConfig, interpolator: &Interpolator) {
    for axis in AxisName::BOTH {
        let i = axis.index();
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
    fn a_limit_is_a_peak_held() {
        let dt = 1e-3;
        // 20 ms at 0.5 m/s² between ramps: held. A single-sample spike: not.
        let plateau: Vec<f64> = (0..60)
            .map(|k| {
                if (20..40).contains(&k) {
                    0.5
                } else {
                    0.01 * k as f64 % 0.3
                }
            })
            .collect();
        assert!(held_at(&plateau, 0.5, dt));
        let spike: Vec<f64> = (0..60).map(|k| if k == 30 { 0.5 } else { 0.1 }).collect();
        assert!(!held_at(&spike, 0.5, dt));
    }

    #[test]
    fn limits_round_up_to_three_digits() {
        assert_eq!(round_up(0.49981), 0.5);
        assert!((round_up(1234.5) - 1240.0).abs() < 1e-9);
    }
}
