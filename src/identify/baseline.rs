//! What a model of the machine must beat: the following error regressed on what the axis
//! was told — the command's velocity, acceleration, jerk and direction, and a constant —
//! fitted on alternate blocks of the record and scored on the others. Five numbers an axis
//! that know nothing of the machine; a physical model that predicts the held-out blocks no
//! better than they do has not earned its parameters.

use nalgebra::{DMatrix, DVector, SMatrix, SVector};
use serde::Serialize;

use crate::compare::Context;
use crate::machine::AxisName;
use crate::numeric::decompose;
use crate::numeric::units::um_from_m;
use crate::trace::signal::sample;

/// Length of the alternate blocks the regression is fitted and scored on (s).
const BLOCK_S: f64 = 0.1;
/// Columns: velocity, acceleration, jerk, direction, constant.
const COLUMNS: usize = 5;
/// Below this share of its peak speed the command counts as standing (no direction).
const STANDING_SHARE: f64 = 0.01;

/// The regression's figure on one axis.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Baseline {
    /// RMS of the following error the regression leaves on the blocks it was not fitted on
    /// (µm).
    pub held_out_um: f64,
    /// That as a share of the following error's RMS on the same samples.
    pub share: f64,
}

/// One compared sample: the regressors and the following error.
struct Row {
    x: [f64; COLUMNS],
    error_m: f64,
    block_even: bool,
    moving: bool,
}

/// The regression baseline of `axis` on the compared samples `mask` allows.
pub(crate) fn regression(ctx: &Context, axis: AxisName, offset_s: f64, mask: &[bool]) -> Baseline {
    let rows = rows(ctx, axis, offset_s, mask);
    let (mut left, mut total, mut n) = (0.0, 0.0, 0usize);
    for even in [true, false] {
        // Fitted on the moving samples of one set of blocks, scored on the other set.
        let Some(theta) = fit(rows.iter().filter(|r| r.block_even == even && r.moving)) else {
            continue;
        };
        for r in rows.iter().filter(|r| r.block_even != even) {
            let predicted: f64 = r.x.iter().zip(theta.iter()).map(|(a, b)| a * b).sum();
            left += (r.error_m - predicted).powi(2);
            total += r.error_m * r.error_m;
            n += 1;
        }
    }
    if n == 0 || total <= 0.0 {
        return Baseline {
            held_out_um: f64::NAN,
            share: f64::NAN,
        };
    }
    Baseline {
        held_out_um: um_from_m((left / n as f64).sqrt()),
        share: (left / total).sqrt(),
    }
}

/// The regressors at each compared sample of `axis`, from the commands at its instant.
fn rows(ctx: &Context, axis: AxisName, offset_s: f64, mask: &[bool]) -> Vec<Row> {
    let c = ctx.commands.axis(axis);
    let dt = ctx.dt;
    let peak = c.vel_m_per_s.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let measured = ctx.measured_axis(axis);
    ctx.samples
        .iter()
        .enumerate()
        .filter(|&(k, _)| mask.get(k).copied().unwrap_or(false))
        .filter_map(|(_, &i)| {
            let t = ctx.prog_time(i, offset_s);
            let (position, velocity) = ctx.command_at(axis, t);
            let accel = sample(&c.acc_m_per_s2, dt, t);
            let jerk = (sample(&c.acc_m_per_s2, dt, t + dt) - sample(&c.acc_m_per_s2, dt, t - dt))
                / (2.0 * dt);
            let moving = velocity.abs() > STANDING_SHARE * peak;
            let direction = if moving { velocity.signum() } else { 0.0 };
            let error_m = position - measured[i];
            let x = [velocity, accel, jerk, direction, 1.0];
            (error_m.is_finite() && x.iter().all(|v| v.is_finite())).then_some(Row {
                x,
                error_m,
                block_even: (t / BLOCK_S).floor().rem_euclid(2.0) == 0.0,
                moving,
            })
        })
        .collect()
}

/// Least squares through the normal equations in columns scaled to unit size; none with
/// too few rows.
fn fit<'r>(rows: impl Iterator<Item = &'r Row>) -> Option<SVector<f64, COLUMNS>> {
    let rows: Vec<&Row> = rows.collect();
    if rows.len() < 10 * COLUMNS {
        return None;
    }
    let mut scale = [0.0f64; COLUMNS];
    for r in &rows {
        for (s, v) in scale.iter_mut().zip(r.x) {
            *s += v * v;
        }
    }
    // A column that is zero throughout (no jerk in a record of steps) is left out.
    let scale: Vec<f64> = scale.iter().map(|s| s.sqrt()).collect();
    let mut normal = SMatrix::<f64, COLUMNS, COLUMNS>::zeros();
    let mut rhs = SVector::<f64, COLUMNS>::zeros();
    for r in &rows {
        let x = SVector::<f64, COLUMNS>::from_fn(|j, _| {
            if scale[j] > 0.0 {
                r.x[j] / scale[j]
            } else {
                0.0
            }
        });
        normal += x * x.transpose();
        rhs += x * r.error_m;
    }
    let normal = DMatrix::from_column_slice(COLUMNS, COLUMNS, normal.as_slice());
    let rhs = DVector::from_column_slice(rhs.as_slice());
    let solved = decompose::svd(normal, true, true)?
        .solve(&rhs, 1e-12)
        .ok()?;
    Some(SVector::from_fn(|j, _| {
        if scale[j] > 0.0 {
            solved[j] / scale[j]
        } else {
            0.0
        }
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_lag_proportional_to_speed_is_predicted_on_the_other_blocks() {
        // e = 0.02 s · v + 1 µm · direction, sampled at 1 kHz over 2 s of two sines.
        let rows: Vec<Row> = (0..2000)
            .map(|k| {
                let t = k as f64 * 1e-3;
                let v = 0.05 * (3.0 * t).sin() + 0.02 * (7.0 * t).sin();
                let a = 0.15 * (3.0 * t).cos() + 0.14 * (7.0 * t).cos();
                let j = -0.45 * (3.0 * t).sin() - 0.98 * (7.0 * t).sin();
                Row {
                    x: [v, a, j, v.signum(), 1.0],
                    error_m: 0.02 * v + 1e-6 * v.signum(),
                    block_even: (t / BLOCK_S).floor().rem_euclid(2.0) == 0.0,
                    moving: true,
                }
            })
            .collect();
        let theta = fit(rows.iter().filter(|r| r.block_even)).unwrap();
        assert!((theta[0] - 0.02).abs() < 1e-9, "{theta:?}");
        assert!((theta[3] - 1e-6).abs() < 1e-12, "{theta:?}");
    }
}
