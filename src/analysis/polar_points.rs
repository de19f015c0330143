//! Whether a circle's points make a polar plot: how many points a path gives per turn,
//! from the angle step it typically goes round in — so that a gap in a record (one large
//! step) does not pass for a sparse circle, nor a standstill (no step) for a dense one.

/// Fewest points per turn for a polar plot: one every 10°. The plot is read for the
/// reversal spikes, which stand within 5°–15° of the quadrant points; points farther apart
/// than 10° leave that band empty on one side or the other of a quadrant point, and the
/// plot draws a polygon whose corners are the samples, not the machine.
pub(crate) const MIN_POINTS_PER_TURN: f64 = 36.0;

/// How many points a path gives per turn of a circle while it goes round: a turn over the
/// angle step it typically takes (angle rad, points in the order taken) — the step at the
/// median of the angle travelled, so that half the angle is gone round in steps at least that
/// long and half in steps at most that long. A standstill's samples (all at one angle) add
/// no angle and no resolution; one gap in a dense record (a single long step) is one step
/// among many and leaves the typical step as it was. Zero for points that do not go round.
pub(crate) fn points_per_turn(points: &[(f64, f64)]) -> f64 {
    use std::f64::consts::{PI, TAU};
    let mut steps: Vec<f64> = points
        .windows(2)
        .map(|w| ((w[1].0 - w[0].0 + PI).rem_euclid(TAU) - PI).abs())
        .collect();
    let travelled: f64 = steps.iter().sum();
    // A non-finite angle (a NaN sample) gives no resolution, not an unbounded one.
    if !travelled.is_finite() || travelled <= 0.0 {
        return 0.0;
    }
    steps.sort_by(f64::total_cmp);
    let mut gone = 0.0;
    let typical = steps
        .iter()
        .find(|s| {
            gone += **s;
            gone >= 0.5 * travelled
        })
        .copied()
        .unwrap_or(travelled);
    TAU / typical
}

/// Why a circle's points make no polar plot, if they do not: fewer than
/// [`MIN_POINTS_PER_TURN`].
pub(crate) fn too_sparse_for_a_plot(points: &[(f64, f64)]) -> Option<String> {
    let per_turn = points_per_turn(points);
    (per_turn < MIN_POINTS_PER_TURN).then(|| {
        format!(
            "no polar plot: {} points, {per_turn:.0} per turn, fewer than {MIN_POINTS_PER_TURN:.0} \
             (one every 10°): the reversal spikes, 5°–15° from the quadrant points, would fall \
             between them",
            points.len()
        )
    })
}

#[cfg(test)]
mod tests {
    use super::{points_per_turn, too_sparse_for_a_plot};

    /// One sample every `step` degrees from `from`, `n` of them, clockwise where `step` < 0
    /// (angle wrapped to ±180°, radius 0).
    fn spaced_from(from: f64, step: f64, n: usize) -> Vec<(f64, f64)> {
        (0..n)
            .map(|k| {
                let a = (from + k as f64 * step).to_radians();
                (a.sin().atan2(a.cos()), 0.0)
            })
            .collect()
    }

    fn spaced(step: f64, n: usize) -> Vec<(f64, f64)> {
        spaced_from(0.0, step, n)
    }

    #[test]
    fn points_per_turn_is_a_turn_over_the_typical_angle_step() {
        // Every 10° round one turn: 36 per turn, enough; every 12°: 30, too few.
        assert!((points_per_turn(&spaced(10.0, 36)) - 36.0).abs() < 1e-9);
        assert!(too_sparse_for_a_plot(&spaced(10.0, 36)).is_none());
        assert!((points_per_turn(&spaced(-12.0, 30)) - 30.0).abs() < 1e-9);
        let why = too_sparse_for_a_plot(&spaced(-12.0, 30)).unwrap();
        assert!(why.contains("30 per turn, fewer than 36"), "{why}");
        // 40 points over two turns (every 18°): 20 per turn, though more than 36 in all.
        assert!((points_per_turn(&spaced(18.0, 40)) - 20.0).abs() < 1e-9);
        assert!(too_sparse_for_a_plot(&spaced(18.0, 40)).is_some());
        // A standstill at the end (20 samples at its last angle) adds no resolution.
        let mut then_stands = spaced(-12.0, 30);
        then_stands.extend([then_stands[29]; 20]);
        assert!((points_per_turn(&then_stands) - 30.0).abs() < 1e-9);
        // One point, or points that stand: none.
        assert_eq!(points_per_turn(&spaced(10.0, 1)), 0.0);
        assert_eq!(points_per_turn(&spaced(0.0, 50)), 0.0);
    }

    #[test]
    fn one_gap_in_a_dense_circle_leaves_its_plot() {
        // A turn sampled every 0.5° (720 per turn) whose record misses 40° after 100°:
        // 639 steps of 0.5° and one of 40.5°. The points still lie every 0.5° wherever
        // there are any: 720 per turn, a plot.
        let mut gap = spaced(0.5, 201);
        gap.extend(spaced_from(140.5, 0.5, 440));
        let per_turn = points_per_turn(&gap);
        assert!((per_turn - 720.0).abs() < 1e-6, "{per_turn}");
        assert!(too_sparse_for_a_plot(&gap).is_none());
        // A record that keeps 60° and 30° of the turn, 240° apart (the wrapped step 120°):
        // most of the angle gone round is the gap, no plot.
        let mut most_missing = spaced(0.5, 121);
        most_missing.extend(spaced_from(300.0, 0.5, 61));
        assert!(too_sparse_for_a_plot(&most_missing).is_some());
    }

    #[test]
    fn a_nan_angle_makes_no_plot() {
        // A NaN sample among dense points: its steps are NaN, so the turn's resolution is
        // unknown — refused, never taken for an unbounded number of points per turn.
        let mut points = spaced(1.0, 360);
        points[100].0 = f64::NAN;
        assert_eq!(points_per_turn(&points), 0.0);
        assert!(too_sparse_for_a_plot(&points).is_some());
    }
}
