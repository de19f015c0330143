//! Why the contour error peaks at a place, told apart by the commands there: a junction's
//! turn (corner), a change of feed, an exact stop's settling, an axis whose command changes
//! sign (reversal) or starts after standing (start from rest), the nut crossing its gap
//! (backlash), stick-slip; and, where the error is a plateau rather than a spike, which
//! steady effect makes it — the axes' lags differing (servo mismatch), half a semi-closed
//! axis's backlash offsetting the table (backlash offset), or the loops' lag itself (steady
//! lag: the radius loss of an arc).

use serde::Serialize;

use crate::machine::AxisName;
use crate::path::{Motion, Segment, dot3};
use crate::plan::Plan;

use super::hotspot::HotspotConfig;

/// Why the contour error peaks here.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, PartialOrd, Ord)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Cause {
    /// The axis's nut crossed its backlash gap at a reversal.
    Backlash {
        /// Axis.
        axis: AxisName,
    },
    /// An axis reversed while moving (a quadrant crossing, a brief stop at a turn): friction
    /// and the loop's lag spike the error.
    AxisReversal {
        /// Axis.
        axis: AxisName,
    },
    /// An axis started after standing still (longer than its loop takes to settle): its lag
    /// builds up and static friction breaks away.
    StartFromRest {
        /// Axis.
        axis: AxisName,
    },
    /// A corner of the path.
    Corner,
    /// A change of programmed feed.
    SpeedChange,
    /// The axes still settling into the exact-stop window when the next block starts (after
    /// a rapid or a G61 stop).
    Settling,
    /// Repeated stick and slip at low speed.
    StickSlip {
        /// Axis.
        axis: AxisName,
    },
    /// The axes' steady lags differ: the path is offset (a line) or distorted (an arc)
    /// across the direction of travel by their difference.
    ServoMismatch,
    /// Half of a semi-closed axis's backlash offsets the table from the motor the loop
    /// reads, on the side it trails.
    BacklashOffset {
        /// Axis.
        axis: AxisName,
    },
    /// The loops' steady lag (the radius loss of an arc): the error here is a plateau, no
    /// larger than just before the event that flagged the place.
    SteadyLag,
}

impl Cause {
    /// Which cause names a merged window: the most specific one.
    pub(crate) fn priority(&self) -> u8 {
        match self {
            Cause::Backlash { .. } => 6,
            Cause::StickSlip { .. } => 5,
            Cause::Corner => 4,
            Cause::Settling => 3,
            Cause::AxisReversal { .. } | Cause::StartFromRest { .. } => 2,
            Cause::SpeedChange => 1,
            Cause::SteadyLag | Cause::ServoMismatch | Cause::BacklashOffset { .. } => 0,
        }
    }

    /// Whether the cause is a plateau of the error along a stretch rather than a spike at
    /// an event: rows of one stretch with it are one place.
    pub(crate) fn is_plateau(&self) -> bool {
        matches!(
            self,
            Cause::SteadyLag | Cause::ServoMismatch | Cause::BacklashOffset { .. }
        )
    }

    /// A short label for tables and plots.
    pub(crate) fn label(&self) -> String {
        match self {
            Cause::Backlash { axis } => format!("{axis} backlash at reversal"),
            Cause::AxisReversal { axis } => format!("{axis} reversal"),
            Cause::StartFromRest { axis } => format!("{axis} start from rest"),
            Cause::Corner => "corner".into(),
            Cause::SpeedChange => "feed change".into(),
            Cause::Settling => "settling after exact stop".into(),
            Cause::SteadyLag => "steady lag".into(),
            Cause::ServoMismatch => "servo mismatch".into(),
            Cause::BacklashOffset { axis } => format!("{axis} backlash offset"),
            Cause::StickSlip { axis } => format!("{axis} stick-slip"),
        }
    }
}

/// What an axis adds to the error of a stretch it moves along steadily, from its model.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AxisSteady {
    /// Steady following error per unit speed (s): 1/Kv for a proportional position loop,
    /// (1 − k_f)/Kv with velocity feed-forward, 0 with integral action.
    pub lag_s: f64,
    /// How far the table trails what the loop reads while the axis moves (m): half the
    /// backlash where the loop reads the motor, none where it reads the table.
    pub offset_m: f64,
    /// The nut's whole play (m).
    pub backlash_m: f64,
}

/// A steady effect must explain at least this share of a plateau's error to name it.
const EXPLAINS: f64 = 0.5;

/// Which steady effect makes a plateau of contour error `error_m` where the axes are
/// commanded at `vel` (X, Y, Z; m/s, Z's 0 where Z is carried or stands): the axes' lag
/// difference, a semi-closed axis's backlash offset, or (neither explaining half of it) the
/// loops' lag.
///
/// Each is read across the direction of travel u (the error lies across it): the lags put
/// the tool at −τ_a·v_a on each axis, and what of that is not along u is the part their
/// difference leaves across the path — in the plane |v|·u_x·u_y·(τ_x − τ_y); an offset b/2
/// against an axis's motion along its unit vector e_a leaves (b_a/2)·√(1 − u_a²) across it.
pub(crate) fn plateau_cause(error_m: f64, vel: [f64; 3], axes: &[AxisSteady; 3]) -> Cause {
    let speed = crate::path::norm3(vel);
    if speed.is_nan() || speed <= 0.0 || !error_m.is_finite() {
        return Cause::SteadyLag;
    }
    let u = vel.map(|v| v / speed);
    let lag = [0, 1, 2].map(|a| axes[a].lag_s * vel[a]);
    let along = dot3(lag, u);
    let mismatch = crate::path::norm3([0, 1, 2].map(|a| lag[a] - along * u[a]));
    let offsets = [0, 1, 2].map(|a| axes[a].offset_m * (1.0 - u[a] * u[a]).max(0.0).sqrt());
    let (axis, offset) =
        AxisName::ALL
            .into_iter()
            .zip(offsets)
            .fold((AxisName::X, 0.0), |best, (axis, o)| {
                if o > best.1 { (axis, o) } else { best }
            });
    let e = error_m.abs();
    if mismatch >= EXPLAINS * e && mismatch >= offset {
        Cause::ServoMismatch
    } else if offset >= EXPLAINS * e {
        Cause::BacklashOffset { axis }
    } else {
        Cause::SteadyLag
    }
}

/// What the junction before segment `i` is: settling after an exact stop, a corner, a feed
/// change, or nothing worth a window.
pub(crate) fn junction_cause(
    segs: &[Segment],
    plan: &Plan,
    i: usize,
    cfg: &HotspotConfig,
) -> Option<Cause> {
    let (a, b) = (&segs[i - 1], &segs[i]);
    if b.motion == Motion::Feed && !b.is_dwell() && plan.plans[i - 1].wait_s > 0.0 {
        return Some(Cause::Settling);
    }
    if a.motion != Motion::Feed || b.motion != Motion::Feed || a.is_dwell() || b.is_dwell() {
        return None;
    }
    // A corner is where the tool's path turns: in space where Z is simulated and either
    // block is measured in space (it moves Z along the contour), else in XY (a plunge is no
    // corner of the XY contour, as the error next to it is measured in XY).
    let in_space = cfg.with_z && (a.is_contour_in_space() || b.is_contour_in_space());
    let xy = |t: [f64; 3]| {
        if in_space {
            let n = crate::path::norm3(t);
            return if n > 1e-9 { t.map(|v| v / n) } else { [0.0; 3] };
        }
        let n = t[0].hypot(t[1]);
        if n > 1e-9 {
            [t[0] / n, t[1] / n, 0.0]
        } else {
            [0.0; 3]
        }
    };
    let (ta, tb) = (xy(a.end_tangent()), xy(b.start_tangent()));
    let cos_limit = cfg.corner_deg.to_radians().cos();
    if ta != [0.0; 3] && tb != [0.0; 3] && dot3(ta, tb) < cos_limit {
        Some(Cause::Corner)
    } else if (a.feed_m_per_s - b.feed_m_per_s).abs() > 0.05 * a.feed_m_per_s.max(b.feed_m_per_s) {
        Some(Cause::SpeedChange)
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const LAG: AxisSteady = AxisSteady {
        lag_s: 0.06,
        offset_m: 0.0,
        backlash_m: 0.0,
    };

    #[test]
    fn a_plateau_is_named_by_the_effect_that_explains_it() {
        let v = 1000.0 / 60_000.0;
        let diagonal = [v / 2f64.sqrt(), v / 2f64.sqrt(), 0.0];
        // Equal lags leave nothing across a line: whatever is there is not theirs.
        assert_eq!(plateau_cause(5e-6, diagonal, &[LAG; 3]), Cause::SteadyLag);
        // Y lagging 1/0.9 − 1 of X's 60 ms: v·½·Δτ = 55.6 µm across a 45° line.
        let slow_y = AxisSteady {
            lag_s: 0.06 / 0.9,
            ..LAG
        };
        let across = v * 0.5 * (0.06 / 0.9 - 0.06);
        assert!((across - 55.6e-6).abs() < 0.1e-6);
        assert_eq!(
            plateau_cause(across, diagonal, &[LAG, slow_y, LAG]),
            Cause::ServoMismatch
        );
        // Along an axis the mismatch leaves nothing.
        assert_eq!(
            plateau_cause(5e-6, [v, 0.0, 0.0], &[LAG, slow_y, LAG]),
            Cause::SteadyLag
        );
        // Half of 20 µm of play on X, semi-closed, across a 45° line: 10·√½ µm.
        let play_x = AxisSteady {
            offset_m: 10e-6,
            backlash_m: 20e-6,
            ..LAG
        };
        assert_eq!(
            plateau_cause(7.07e-6, diagonal, &[play_x, LAG, LAG]),
            Cause::BacklashOffset { axis: AxisName::X }
        );
        // Standing axes have no plateau to name.
        assert_eq!(
            plateau_cause(1e-6, [0.0, 0.0, 0.0], &[play_x, LAG, LAG]),
            Cause::SteadyLag
        );
    }
}
