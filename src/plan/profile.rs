//! One-dimensional motion along the path: velocity changes with bounded acceleration (and,
//! for S-curves, bounded jerk), starting and ending with zero acceleration.
//!
//! A jerk-limited change from v0 to v1 has a symmetric acceleration pulse: jerk up for t_j,
//! constant acceleration for t_a, jerk down for t_j. Its mean velocity is (v0 + v1)/2, which
//! gives the closed forms for distance and for the highest speed reachable in a distance.

/// Acceleration and jerk available along the path. `jerk = ∞` gives trapezoidal profiles,
/// `accel = ∞` the ideal (instantaneous) ones.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Dynamics {
    /// Path acceleration limit (m/s²).
    pub accel: f64,
    /// Path jerk limit (m/s³).
    pub jerk: f64,
}

/// A velocity change from `v0` to `v1` (m/s) with zero acceleration at both ends.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ramp {
    v0: f64,
    v1: f64,
    /// Duration of each jerk phase (s).
    t_j: f64,
    /// Duration of the constant-acceleration phase (s).
    t_a: f64,
    /// Signed peak acceleration (m/s²).
    a_peak: f64,
}

impl Ramp {
    /// The fastest change from `v0` to `v1` within the dynamics.
    pub(crate) fn new(v0: f64, v1: f64, d: Dynamics) -> Ramp {
        let dv = (v1 - v0).abs();
        let sign = if v1 >= v0 { 1.0 } else { -1.0 };
        if dv == 0.0 || d.accel.is_infinite() {
            return Ramp {
                v0,
                v1,
                t_j: 0.0,
                t_a: 0.0,
                a_peak: 0.0,
            };
        }
        if d.jerk.is_infinite() {
            return Ramp {
                v0,
                v1,
                t_j: 0.0,
                t_a: dv / d.accel,
                a_peak: sign * d.accel,
            };
        }
        if dv * d.jerk >= d.accel * d.accel {
            // The acceleration limit is reached: a plateau between two jerk phases.
            let t_j = d.accel / d.jerk;
            Ramp {
                v0,
                v1,
                t_j,
                t_a: dv / d.accel - t_j,
                a_peak: sign * d.accel,
            }
        } else {
            // A triangular acceleration pulse.
            let t_j = (dv / d.jerk).sqrt();
            Ramp {
                v0,
                v1,
                t_j,
                t_a: 0.0,
                a_peak: sign * d.jerk * t_j,
            }
        }
    }

    /// Duration (s).
    pub(crate) fn duration(&self) -> f64 {
        2.0 * self.t_j + self.t_a
    }

    /// Distance covered (m).
    pub(crate) fn distance(&self) -> f64 {
        0.5 * (self.v0 + self.v1) * self.duration()
    }

    /// Distance, velocity and acceleration at time `t` ∈ [0, duration] from the start.
    pub(crate) fn eval(&self, t: f64) -> (f64, f64, f64) {
        let (v0, a) = (self.v0, self.a_peak);
        // At and after the end the ramp has arrived: the target speed, no acceleration. (An
        // instantaneous ramp of the ideal profile has zero duration, and its phase formulas
        // below would still give the start speed there.)
        if t >= self.duration() {
            return (self.distance(), self.v1, 0.0);
        }
        let t = t.max(0.0);
        let tj = self.t_j;
        let j = if tj > 0.0 { a / tj } else { 0.0 };
        // End of the first jerk phase.
        let (s1, v1) = (v0 * tj + j * tj.powi(3) / 6.0, v0 + 0.5 * a * tj);
        if t < tj {
            return (v0 * t + j * t.powi(3) / 6.0, v0 + 0.5 * j * t * t, j * t);
        }
        let tau = t - tj;
        if tau < self.t_a {
            return (s1 + v1 * tau + 0.5 * a * tau * tau, v1 + a * tau, a);
        }
        let (s2, v2) = (
            s1 + v1 * self.t_a + 0.5 * a * self.t_a.powi(2),
            v1 + a * self.t_a,
        );
        let tau = tau - self.t_a;
        (
            s2 + v2 * tau + 0.5 * a * tau * tau - j * tau.powi(3) / 6.0,
            v2 + a * tau - 0.5 * j * tau * tau,
            a - j * tau,
        )
    }
}

/// Distance needed to change speed from `v0` to `v1` (m).
pub(crate) fn ramp_distance(v0: f64, v1: f64, d: Dynamics) -> f64 {
    Ramp::new(v0, v1, d).distance()
}

/// Distance of a ramp between `v_low` and `v_high ≥ v_low` (either direction: the distance is
/// symmetric) and its derivative with respect to `v_high`.
fn ramp_distance_slope(v_low: f64, v_high: f64, d: Dynamics) -> (f64, f64) {
    let dv = (v_high - v_low).max(0.0);
    let sum = v_low + v_high;
    if d.jerk.is_infinite() {
        return (sum * dv / (2.0 * d.accel), v_high / d.accel);
    }
    if dv * d.jerk >= d.accel * d.accel {
        let t = dv / d.accel + d.accel / d.jerk;
        return (0.5 * sum * t, 0.5 * t + sum / (2.0 * d.accel));
    }
    if dv == 0.0 {
        return (0.0, f64::INFINITY);
    }
    let root = (dv / d.jerk).sqrt();
    (sum * root, root + sum / (2.0 * (dv * d.jerk).sqrt()))
}

/// The highest peak speed in [`floor`, `v_max`] whose ramp up from `v_entry` and down to
/// `v_exit` fit in `length`: Newton's method on the distance needed, kept inside a bracket
/// [feasible, infeasible] that every iterate narrows, with bisection when a Newton step
/// would leave it (as it does near the floor, where the slope is infinite).
fn peak_speed(v_entry: f64, v_exit: f64, floor: f64, v_max: f64, length: f64, d: Dynamics) -> f64 {
    let (mut lo, mut hi) = (floor, v_max); // lo feasible (caller's guarantee), hi not
    let mut x = 0.5 * (lo + hi);
    for _ in 0..80 {
        let (up, up_slope) = ramp_distance_slope(v_entry, x, d);
        let (down, down_slope) = ramp_distance_slope(v_exit, x, d);
        let excess = up + down - length;
        if excess <= 0.0 {
            lo = x
        } else {
            hi = x
        }
        if hi - lo <= 1e-13 * hi {
            break;
        }
        let newton = x - excess / (up_slope + down_slope);
        // Converging from the feasible side (the distance is concave in the peak speed, so
        // Newton approaches the root from below) the bracket's upper end never moves.
        if excess <= 0.0 && (newton - x).abs() <= 1e-13 * x {
            break;
        }
        x = if newton > lo && newton < hi {
            newton
        } else {
            0.5 * (lo + hi)
        };
    }
    lo
}

/// The highest speed reachable from `v0` by accelerating over `length` (m).
pub(crate) fn reachable_speed(v0: f64, length: f64, d: Dynamics) -> f64 {
    if d.accel.is_infinite() {
        return f64::INFINITY;
    }
    if length <= 0.0 {
        return v0;
    }
    if d.jerk.is_infinite() {
        return (v0 * v0 + 2.0 * d.accel * length).sqrt();
    }
    let (a, j) = (d.accel, d.jerk);
    let plateau_dv = a * a / j;
    // With a plateau: L = (2 v0 + dv)/2 · (dv/a + a/j), a quadratic in dv.
    let b = 2.0 * v0 + plateau_dv;
    let c = 2.0 * v0 * plateau_dv - 2.0 * length * a;
    let dv_plateau = 0.5 * (-b + (b * b - 4.0 * c).sqrt());
    if dv_plateau >= plateau_dv {
        return v0 + dv_plateau;
    }
    // Triangular pulse: L = (2 v0 + dv)·√(dv/j). With w = √dv: w³ + 2 v0 w − L√j = 0,
    // a depressed cubic with one real root (Cardano), polished by Newton.
    let (p, q) = (2.0 * v0, -length * j.sqrt());
    let disc = (q * q / 4.0 + p * p * p / 27.0).sqrt();
    let mut w = (-q / 2.0 + disc).cbrt() + (-q / 2.0 - disc).cbrt();
    for _ in 0..3 {
        let f = w * w * w + p * w + q;
        let df = 3.0 * w * w + p;
        if df > 0.0 {
            w -= f / df;
        }
    }
    v0 + w.max(0.0).powi(2)
}

/// Speed profile of one segment: a ramp up to `v_peak`, a cruise, a ramp down.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SegmentProfile {
    up: Ramp,
    cruise_s: f64,
    v_peak: f64,
    down: Ramp,
}

impl SegmentProfile {
    /// The fastest profile over `length` from `v_entry` to `v_exit` not exceeding `v_max`.
    /// The caller guarantees that the exit speed is reachable (the planner's passes do).
    pub(crate) fn plan(v_entry: f64, v_exit: f64, v_max: f64, length: f64, d: Dynamics) -> Self {
        let needed = |vp: f64| ramp_distance(v_entry, vp, d) + ramp_distance(vp, v_exit, d);
        let floor = v_entry.max(v_exit);
        let v_peak = if v_max <= floor || needed(v_max) <= length {
            v_max.max(floor)
        } else {
            peak_speed(v_entry, v_exit, floor, v_max, length, d)
        };
        let up = Ramp::new(v_entry, v_peak, d);
        let down = Ramp::new(v_peak, v_exit, d);
        let rest = (length - up.distance() - down.distance()).max(0.0);
        let cruise_s = if v_peak > 0.0 { rest / v_peak } else { 0.0 };
        SegmentProfile {
            up,
            cruise_s,
            v_peak,
            down,
        }
    }

    /// Duration (s).
    pub(crate) fn duration(&self) -> f64 {
        self.up.duration() + self.cruise_s + self.down.duration()
    }

    /// When the profile has covered `distance` (m): the inverse of its distance, which never
    /// decreases (at the cruise in closed form, on the ramps by bisection).
    pub(crate) fn time_at_distance(&self, distance: f64) -> f64 {
        let (t_up, s_up) = (self.up.duration(), self.up.distance());
        let s_cruise_end = s_up + self.v_peak * self.cruise_s;
        if distance >= s_up && distance <= s_cruise_end && self.v_peak > 0.0 {
            return t_up + (distance - s_up) / self.v_peak;
        }
        let (mut lo, mut hi) = if distance < s_up {
            (0.0, t_up)
        } else {
            (t_up + self.cruise_s, self.duration())
        };
        for _ in 0..64 {
            let mid = 0.5 * (lo + hi);
            if self.eval(mid).0 < distance {
                lo = mid
            } else {
                hi = mid
            }
        }
        0.5 * (lo + hi)
    }

    /// Distance, speed and acceleration along the path at time `t` from the segment start.
    pub(crate) fn eval(&self, t: f64) -> (f64, f64, f64) {
        let t_up = self.up.duration();
        if t < t_up {
            return self.up.eval(t);
        }
        let s_up = self.up.distance();
        let t = t - t_up;
        if t < self.cruise_s {
            return (s_up + self.v_peak * t, self.v_peak, 0.0);
        }
        let (s, v, a) = self.down.eval(t - self.cruise_s);
        (s_up + self.v_peak * self.cruise_s + s, v, a)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const S: Dynamics = Dynamics {
        accel: 0.5,
        jerk: 5.0,
    };

    #[test]
    fn ramp_ends_at_its_target_with_zero_acceleration() {
        for (v0, v1) in [(0.0, 0.0167), (0.1, 0.0), (0.0, 0.2), (0.05, 0.3)] {
            let r = Ramp::new(v0, v1, S);
            let (s, v, a) = r.eval(r.duration());
            assert!((v - v1).abs() < 1e-15, "{v} vs {v1}");
            assert!(a.abs() < 1e-12);
            assert!((s - r.distance()).abs() < 1e-15);
        }
    }

    #[test]
    fn reachable_speed_inverts_ramp_distance() {
        for d in [
            S,
            Dynamics {
                accel: 0.5,
                jerk: f64::INFINITY,
            },
        ] {
            for &v0 in &[0.0, 0.001, 0.02, 0.3] {
                for &l in &[1e-6, 1e-3, 0.01, 0.5, 3.0] {
                    let v1 = reachable_speed(v0, l, d);
                    let back = ramp_distance(v0, v1, d);
                    assert!(
                        (back - l).abs() < 1e-12 * (1.0 + l),
                        "v0 {v0} L {l}: {back}"
                    );
                }
            }
        }
    }

    #[test]
    fn peak_speed_fills_the_length_exactly() {
        for d in [
            S,
            Dynamics {
                accel: 0.5,
                jerk: f64::INFINITY,
            },
            Dynamics {
                accel: 0.05,
                jerk: 5.0,
            },
        ] {
            for &(v0, v1, extra) in &[
                (0.0, 0.0, 1e-4),
                (0.01, 0.0, 1e-6),
                (0.002, 0.015, 2e-3),
                (0.1, 0.1, 0.02),
            ] {
                let l = ramp_distance(v0, v1, d) + extra;
                let vmax = 10.0;
                let floor = f64::max(v0, v1);
                let vp = peak_speed(v0, v1, floor, vmax, l, d);
                let used = ramp_distance(v0, vp, d) + ramp_distance(vp, v1, d);
                assert!(used <= l, "infeasible: {used} > {l}");
                assert!(l - used < 1e-12, "{d:?} {v0} {v1} {l}: wasted {}", l - used);
            }
        }
    }

    #[test]
    fn trapezoid_single_move_matches_closed_form() {
        // 100 mm at 1 m/s max with 0.5 m/s²: triangular (no cruise), T = 2·√(L/a).
        let d = Dynamics {
            accel: 0.5,
            jerk: f64::INFINITY,
        };
        let p = SegmentProfile::plan(0.0, 0.0, 1.0, 0.1, d);
        assert!((p.duration() - 2.0 * (0.1f64 / 0.5).sqrt()).abs() < 1e-12);
    }
}
