//! What dominates a setting's largest contour error, in the words a servo engineer tunes
//! by: a mismatch of the axes' lags, lag at corners, overshoot, backlash spikes, ringing.
//!
//! Read from the run, not guessed from the gains: the largest hotspot's cause (found from
//! the commands there, [`crate::analysis::hotspot`]) names the place; the run's overshoot
//! past standing commands and the error's ripple about its own moving average say whether
//! the axes' own motion — running past a stop, oscillating — makes the error instead.

use serde::Serialize;

use crate::analysis::hotspot::Cause;
use crate::check::CheckRun;
use crate::machine::{AxisName, MachineConfig};
use crate::sim::AxisModel;
use crate::sim::linear::{check_stable, equivalent_kv_per_s};

use super::Metrics;

/// What dominates a setting's largest contour error.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Dominant {
    /// The axes' lags differ: the path is tilted or distorted by the difference.
    ServoMismatch,
    /// The axes' lag cutting the corners.
    LagAtCorners,
    /// An axis running past a stop.
    Overshoot,
    /// The error oscillates about its own mean: a loop ringing.
    Ringing,
    /// Backlash crossed at reversals.
    BacklashSpikes {
        /// Axis.
        axis: AxisName,
    },
    /// Half the backlash offsetting a stretch (a semi-closed loop).
    BacklashOffset {
        /// Axis.
        axis: AxisName,
    },
    /// Friction and lag where an axis reverses.
    ReversalSpikes {
        /// Axis.
        axis: AxisName,
    },
    /// Lag building up and static friction breaking where an axis starts from rest.
    StartFromRest {
        /// Axis.
        axis: AxisName,
    },
    /// The loops' steady lag (radius loss on arcs).
    SteadyLag,
    /// Settling into the exact-stop window.
    Settling,
    /// Stick-slip at low speed.
    StickSlip {
        /// Axis.
        axis: AxisName,
    },
    /// A change of programmed feed.
    FeedChange,
    /// No contour error worth naming.
    Nothing,
}

impl Dominant {
    /// A few words for tables.
    #[cfg(feature = "cli")]
    pub(crate) fn label(&self) -> String {
        match self {
            Dominant::ServoMismatch => "servo mismatch between axes".into(),
            Dominant::LagAtCorners => "lag at corners".into(),
            Dominant::Overshoot => "overshoot".into(),
            Dominant::Ringing => "ringing".into(),
            Dominant::BacklashSpikes { axis } => format!("{axis} backlash spikes"),
            Dominant::BacklashOffset { axis } => format!("{axis} backlash offset"),
            Dominant::ReversalSpikes { axis } => format!("{axis} reversal spikes"),
            Dominant::StartFromRest { axis } => format!("{axis} start from rest"),
            Dominant::SteadyLag => "steady lag".into(),
            Dominant::Settling => "settling at exact stops".into(),
            Dominant::StickSlip { axis } => format!("{axis} stick-slip"),
            Dominant::FeedChange => "feed change".into(),
            Dominant::Nothing => "—".into(),
        }
    }
}

/// Share of the largest contour error the axes' overshoot past a stop must reach to be
/// what dominates it.
const OVERSHOOT_SHARE: f64 = 0.5;

/// Share of the largest contour error the error's ripple about its moving average (RMS)
/// must reach: a ringing loop's error swings about its mean over whole stretches, where a
/// spike at a corner moves the RMS little.
const RIPPLE_SHARE: f64 = 0.2;

/// The axes' position gains (or, for other controllers, closed-loop bandwidths) differing
/// by more than this share are worth asking whether their mismatch makes the error.
const MISMATCH_SHARE: f64 = 0.05;

/// What dominates the largest contour error of `run` with figures `m` on `machine`;
/// `max_error_um` runs the program on another machine and gives its largest contour error
/// (µm), to ask whether matching the axes would take most of the error away.
pub(crate) fn dominant(
    run: &CheckRun,
    m: &Metrics,
    machine: &MachineConfig,
    max_error_um: &dyn Fn(&MachineConfig) -> Option<f64>,
) -> Dominant {
    let Some(top) = run.result.hotspots.first() else {
        return Dominant::Nothing;
    };
    let max = m.max_contour_um;
    if max.is_nan() || max <= 0.0 {
        return Dominant::Nothing;
    }
    if m.ripple_um >= RIPPLE_SHARE * max {
        return Dominant::Ringing;
    }
    if m.overshoot_um >= OVERSHOOT_SHARE * max {
        return Dominant::Overshoot;
    }
    // A plateau's mismatch is read off the commands where it is (the hotspot's cause); a
    // transient's — a corner, a start — is asked of a run with the axes matched, where the
    // lags differ by enough to make half the error at the program's speed.
    if !top.cause.is_plateau()
        && let Some(matched) = matched(machine, run, max)
        && max_error_um(&matched).is_some_and(|e| e < 0.5 * max)
    {
        return Dominant::ServoMismatch;
    }
    match top.cause {
        Cause::Backlash { axis } => Dominant::BacklashSpikes { axis },
        Cause::BacklashOffset { axis } => Dominant::BacklashOffset { axis },
        Cause::AxisReversal { axis } => Dominant::ReversalSpikes { axis },
        Cause::StartFromRest { axis } => Dominant::StartFromRest { axis },
        Cause::Corner => Dominant::LagAtCorners,
        Cause::ServoMismatch => Dominant::ServoMismatch,
        Cause::SteadyLag => Dominant::SteadyLag,
        Cause::Settling => Dominant::Settling,
        Cause::StickSlip { axis } => Dominant::StickSlip { axis },
        Cause::SpeedChange => Dominant::FeedChange,
    }
}

/// The machine with the faster axis given the slower axis's controller (its loops, their
/// gains and the amplifier), where the axes' gains differ enough that the difference of
/// their time constants, at the run's fastest path speed, could make half of `max_um`;
/// `None` otherwise, or where the slower axis's controller is not stable on the other
/// axis's mechanics.
fn matched(machine: &MachineConfig, run: &CheckRun, max_um: f64) -> Option<MachineConfig> {
    let [kx, ky] =
        [&machine.x, &machine.y].map(|a| equivalent_kv_per_s(&AxisModel::from_config(a)));
    let (vx, vy) = (&run.commands.x.vel_m_per_s, &run.commands.y.vel_m_per_s);
    let fastest = vx
        .iter()
        .zip(vy)
        .map(|(a, b)| a.hypot(*b))
        .fold(0.0, f64::max);
    let reach_um = fastest * (1.0 / kx - 1.0 / ky).abs() * 1e6;
    if (kx - ky).abs() <= MISMATCH_SHARE * kx.max(ky) || reach_um < 0.5 * max_um {
        return None;
    }
    let (slow, fast) = if kx < ky {
        (AxisName::X, AxisName::Y)
    } else {
        (AxisName::Y, AxisName::X)
    };
    let from = machine.axis(slow).clone();
    let mut m = machine.clone();
    let to = m.axis_mut(fast);
    to.controller = from.controller;
    to.position_loop = from.position_loop;
    to.velocity_loop = from.velocity_loop;
    to.current_loop = from.current_loop;
    to.amplifier = from.amplifier;
    m.validate("<matched>").ok()?;
    check_stable(&AxisModel::from_config(m.axis(fast))).ok()?;
    Some(m)
}
