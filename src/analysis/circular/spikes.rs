//! The reversal spikes of a circle's path: where they stand (kept out of the fitted
//! ellipses), how high they rise, and the lost motion stepped across them.

use nalgebra::{Matrix3, Vector3};

use super::{Circle, EntrySettling, Harmonics};
use crate::numeric::units::um_from_m;

/// How far either side of a quadrant point its reversal spike is taken to stand (degrees):
/// the spike is measured there, and the steps across it are fitted outside it.
const SPIKE_HALF_WIDTH_DEG: f64 = 3.0;
/// How many of the loops' time constants a reversal spike's tail runs on past its quadrant
/// point (the loop pushing the axis back onto its command after friction turned), and the
/// most of the circle it may take there (degrees): the ellipses are fitted outside.
const SPIKE_TAIL_TIME_CONSTANTS: f64 = 4.0;
const SPIKE_TAIL_MAX_DEG: f64 = 40.0;

/// Where a path's reversal spikes stand: from [`SPIKE_HALF_WIDTH_DEG`] before each quadrant
/// point to its tail's end past it, in the direction of travel.
#[derive(Debug, Clone, Copy)]
pub(super) struct SpikeZones {
    ccw: bool,
    tail_deg: f64,
}

impl SpikeZones {
    /// The zones of circle `c`'s path, the command running round it at `speed_m_per_s`
    /// (the programmed feed where that is no speed).
    pub(super) fn of(c: &Circle, entry: &EntrySettling, speed_m_per_s: f64) -> Self {
        let omega_tau = entry.omega_tau(c, running_or_feed(c, speed_m_per_s));
        let tail_deg = (SPIKE_TAIL_TIME_CONSTANTS * omega_tau).to_degrees();
        SpikeZones {
            ccw: c.ccw,
            // No loop known (a NaN): the spike's own width.
            tail_deg: if tail_deg.is_nan() {
                SPIKE_HALF_WIDTH_DEG
            } else {
                tail_deg.clamp(SPIKE_HALF_WIDTH_DEG, SPIKE_TAIL_MAX_DEG)
            },
        }
    }

    /// Whether the angle (degrees, about the centre) lies in a spike's zone.
    pub(super) fn contains(&self, angle_deg: f64) -> bool {
        let travel = if self.ccw { 1.0 } else { -1.0 };
        [0.0, 90.0, 180.0, 270.0].iter().any(|q| {
            let d = (angle_deg - q).rem_euclid(360.0);
            let past = travel * if d > 180.0 { d - 360.0 } else { d };
            (-SPIKE_HALF_WIDTH_DEG..=self.tail_deg).contains(&past)
        })
    }
}

/// Whether the spike at quadrant point `quadrant_deg` of circle `c` stands in or against
/// the stretches its figures leave out (degrees): the start's, past the circle's start in
/// its direction of travel, and the end's, before it (a full circle ends where it starts).
pub(super) fn cut_by_windows(
    c: &Circle,
    quadrant_deg: f64,
    [start_deg, end_deg]: [f64; 2],
) -> bool {
    let travel = if c.ccw { 1.0 } else { -1.0 };
    let d = (quadrant_deg - c.start_rad.to_degrees()).rem_euclid(360.0);
    let past = travel * if d > 180.0 { d - 360.0 } else { d };
    let window = if past >= 0.0 { start_deg } else { end_deg };
    window > 0.0 && past.abs() < window + SPIKE_HALF_WIDTH_DEG
}

/// How far the path bulges at each quadrant point beyond its neighbourhood: the largest
/// |radial deviation − the median of the ±5°–15° ring| within ±3°, signed.
pub(super) fn reversal_spikes(c: &Circle, p: &[[f64; 2]]) -> [f64; 4] {
    let polar: Vec<(f64, f64)> = p
        .iter()
        .map(|q| {
            let (dx, dy) = (q[0] - c.center_m[0], q[1] - c.center_m[1]);
            (dy.atan2(dx).to_degrees(), dx.hypot(dy) - c.radius_m)
        })
        .collect();
    let offset_from = |angle: f64, quadrant: f64| {
        let d = (angle - quadrant).rem_euclid(360.0);
        if d > 180.0 { d - 360.0 } else { d }
    };
    [0.0, 90.0, 180.0, 270.0].map(|quadrant| {
        let mut ring: Vec<f64> = polar
            .iter()
            .filter(|(a, _)| (5.0..=15.0).contains(&offset_from(*a, quadrant).abs()))
            .map(|(_, r)| *r)
            .collect();
        let near: Vec<f64> = polar
            .iter()
            .filter(|(a, _)| offset_from(*a, quadrant).abs() <= SPIKE_HALF_WIDTH_DEG)
            .map(|(_, r)| *r)
            .collect();
        if ring.len() < 4 || near.is_empty() {
            return f64::NAN;
        }
        ring.sort_by(f64::total_cmp);
        let base = ring[ring.len() / 2];
        let peak = near
            .iter()
            .map(|r| r - base)
            .max_by(|a, b| a.abs().total_cmp(&b.abs()))
            .unwrap_or(0.0);
        um_from_m(peak)
    })
}

/// The radial step (m) across the quadrant point `quadrant` (degrees) of circle `c`'s path
/// `p`, in its direction of travel: r = a + b·δ + step·[δ > 0] fitted over 3° ≤ |δ| ≤ 20°
/// (δ the angle past the point as the path travels) on what the path's smooth shape (its
/// terms up to 3θ) leaves — a large servo ellipse bends too much over 20° for a line to
/// follow; `None` with too few samples a side.
pub(super) fn step_across(
    c: &Circle,
    p: &[[f64; 2]],
    smooth: &Harmonics,
    quadrant: f64,
) -> Option<f64> {
    let travel = if c.ccw { 1.0 } else { -1.0 };
    let mut ata = Matrix3::<f64>::zeros();
    let mut atb = Vector3::<f64>::zeros();
    let (mut before, mut after) = (0usize, 0usize);
    for &q in p {
        let (angle, radial) = c.polar(q);
        let d = (angle.to_degrees() - quadrant).rem_euclid(360.0);
        let delta = travel * if d > 180.0 { d - 360.0 } else { d };
        if !(SPIKE_HALF_WIDTH_DEG..=20.0).contains(&delta.abs()) {
            continue;
        }
        let r = radial + c.radius_m - smooth.at(angle.cos(), angle.sin());
        let past = if delta > 0.0 { 1.0 } else { 0.0 };
        before += (past == 0.0) as usize;
        after += (past == 1.0) as usize;
        let row = Vector3::new(1.0, delta, past);
        ata += row * row.transpose();
        atb += row * r;
    }
    if before < 3 || after < 3 {
        return None;
    }
    ata.lu().solve(&atb).map(|s| s[2])
}

/// The speed the command runs round circle `c` at (m/s): `speed_m_per_s` where it is one,
/// else the programmed feed.
pub(super) fn running_or_feed(c: &Circle, speed_m_per_s: f64) -> f64 {
    if speed_m_per_s.is_finite() && speed_m_per_s > 0.0 {
        speed_m_per_s
    } else {
        c.feed_m_per_s
    }
}
