//! Which samples an axis is compared on: away from its standstills (where an axis with
//! integral action and friction hunts on a limit cycle no model times), and the following
//! error over them — the yardstick of every held-out figure.

use crate::compare::Context;
use crate::machine::AxisName;

/// How long after a standstill the record is compared, and the speed (a share of the
/// axis's peak) below which a command counts as standing.
const SETTLE_S: f64 = 0.1;
const MOVING_SHARE: f64 = 0.01;

/// Samples at which the axis's command has been moving for `SETTLE_S` and still moves:
/// away from the standstills, where an axis with integral action and friction hunts about
/// its target on a limit cycle whose phase no model times (as stick-slip), and from the
/// breakaways that follow them, which inherit that phase.
pub(super) fn moving_samples(ctx: &Context, axis: AxisName, offset: f64) -> Vec<bool> {
    let sliding = Sliding::of(ctx, axis);
    ctx.samples
        .iter()
        .map(|&i| sliding.settled_at(ctx, ctx.prog_time(i, offset)))
        .collect()
}

/// An axis's commands as sliding: per command period, the direction it is told to move
/// (−1, +1; 0 below `MOVING_SHARE` of its peak speed), and whether it has moved for
/// `SETTLE_S` without standing.
pub(super) struct Sliding {
    direction: Vec<f64>,
    settled: Vec<bool>,
}

impl Sliding {
    pub(super) fn of(ctx: &Context, axis: AxisName) -> Sliding {
        let c = ctx.commands.axis(axis);
        let peak = c.vel_m_per_s.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let settle = (SETTLE_S / ctx.dt).ceil() as usize;
        let direction: Vec<f64> = c
            .vel_m_per_s
            .iter()
            .map(|v| {
                if v.abs() > MOVING_SHARE * peak {
                    v.signum()
                } else {
                    0.0
                }
            })
            .collect();
        let mut run = 0usize;
        let settled = direction
            .iter()
            .map(|d| {
                run = if *d != 0.0 { run + 1 } else { 0 };
                run > settle
            })
            .collect();
        Sliding { direction, settled }
    }

    /// The command period at program time `t` (s), where the commands have one.
    fn period(ctx: &Context, t: f64) -> Option<usize> {
        let k = (t / ctx.dt).round();
        (k >= 0.0).then_some(k as usize)
    }

    /// Whether the command at `t` has slid for `SETTLE_S`.
    pub(super) fn settled_at(&self, ctx: &Context, t: f64) -> bool {
        Self::period(ctx, t).is_some_and(|k| self.settled.get(k).copied().unwrap_or(false))
    }

    /// The commanded direction at `t` (0 standing or beyond the commands).
    pub(super) fn direction_at(&self, ctx: &Context, t: f64) -> f64 {
        Self::period(ctx, t).map_or(0.0, |k| self.direction.get(k).copied().unwrap_or(0.0))
    }
}

/// RMS of commanded − measured over the compared samples `mask` allows (m): the samples the
/// held-out residuals are counted on (those left out for hunting among them, where every
/// model's residual is zero).
pub(super) fn following_error_rms(
    ctx: &Context,
    axis: AxisName,
    offset: f64,
    mask: &[bool],
) -> f64 {
    let measured = ctx.measured_at_samples(axis);
    let (mut ss, mut n) = (0.0, 0usize);
    for (k, (&i, m)) in ctx.samples.iter().zip(measured).enumerate() {
        if !mask.get(k).copied().unwrap_or(false) {
            continue;
        }
        let e = ctx.command_at(axis, ctx.prog_time(i, offset)).0 - m;
        if e.is_finite() {
            ss += e * e;
            n += 1;
        }
    }
    (ss / n.max(1) as f64).sqrt()
}
