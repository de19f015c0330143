//! A continuous interpolator: each block on its own trapezoidal (or jerk-limited) profile,
//! stopping at every block end, evaluated at any time.

use std::cell::{Cell, RefCell};

use contourcheck::gcode::Program;
use contourcheck::path::{Geometry, Motion};

/// A block of the interpolator: its duration and its XYZ position at a time into it.
type Block = (f64, Box<dyn Fn(f64) -> [f64; 3]>);

/// A position evaluated (m), by its time's bits.
type Kept = (u64, [f64; 3]);

/// A block's distance travelled (m) at a time into it (s).
type Distance = Box<dyn Fn(f64) -> f64>;

/// A trapezoidal profile over `length` at feed `v` and `accel`: its duration and distance.
fn trapezoid(length: f64, v: f64, accel: f64) -> (f64, Distance) {
    let v = v.min((accel * length).sqrt());
    let t_acc = v / accel;
    let t_cruise = (length - v * t_acc) / v;
    let total = 2.0 * t_acc + t_cruise;
    let distance = move |t: f64| {
        if t < t_acc {
            0.5 * accel * t * t
        } else if t < t_acc + t_cruise {
            0.5 * v * t_acc + v * (t - t_acc)
        } else {
            let r = (total - t).max(0.0);
            length - 0.5 * accel * r * r
        }
    };
    (total, Box::new(distance))
}

/// The seven phases of a jerk-limited profile from rest to `v` and back, each its jerk (m/s³)
/// and duration (s): the acceleration ramps at `jerk` to `accel` (or to √(v·jerk) where the
/// feed is reached before), holds, ramps back to the feed, which is held for `cruise_s`, and
/// the same mirrored down to rest.
pub fn s_curve_phases(v: f64, accel: f64, jerk: f64, cruise_s: f64) -> [(f64, f64); 7] {
    let peak = accel.min((v * jerk).sqrt());
    // No hold where the feed comes first (its rounding below zero too).
    let (ramp, hold) = (peak / jerk, (v / peak - peak / jerk).max(0.0));
    [
        (jerk, ramp),
        (0.0, hold),
        (-jerk, ramp),
        (0.0, cruise_s),
        (-jerk, ramp),
        (0.0, hold),
        (jerk, ramp),
    ]
}

/// Distance (m), speed (m/s) and acceleration (m/s²) at `t` (s) into `phases` (jerk and
/// duration each) from rest: exact, each phase's motion a cubic, summed phase by phase; at
/// rest once they are over, whatever the rounding of the sums.
pub fn through_phases(phases: &[(f64, f64)], t: f64) -> (f64, f64, f64) {
    let (mut s, mut ds, mut dds, mut left) = (0.0, 0.0, 0.0, t.max(0.0));
    for &(j, d) in phases {
        let h = left.min(d);
        s += ds * h + dds * h * h / 2.0 + j * h * h * h / 6.0;
        ds += dds * h + j * h * h / 2.0;
        dds += j * h;
        left -= h;
    }
    if left > 0.0 {
        (s, 0.0, 0.0)
    } else {
        (s, ds, dds)
    }
}

/// A jerk-limited profile over `length` at feed `v`, rest to rest ([`s_curve_phases`]), the
/// feed lowered where the block is too short to reach it: its duration and distance.
fn s_curve(length: f64, v: f64, accel: f64, jerk: f64) -> (f64, Distance) {
    // The distance to reach `v` from rest and stop again.
    let there_and_back = |v: f64| {
        let a = accel.min((v * jerk).sqrt());
        v * (v / a + a / jerk)
    };
    let mut v = v;
    if there_and_back(v) > length {
        let (mut lo, mut hi) = (0.0, v);
        for _ in 0..100 {
            let mid = 0.5 * (lo + hi);
            if there_and_back(mid) > length {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        v = lo;
    }
    let cruise = (length - there_and_back(v)) / v;
    let phases = s_curve_phases(v, accel, jerk, cruise);
    let total = phases.iter().map(|p| p.1).sum();
    let distance = move |t: f64| through_phases(&phases, t).0.min(length);
    (total, Box::new(distance))
}

/// A continuous interpolator: each block accelerates at `accel` (its acceleration stepped,
/// or ramped at a jerk: [`Trapezoids::s_curves`]), cruises at its feed and stops at its end
/// (rapids at 10 m/min); a dwell stands. Positions are exact at any time, speed and
/// acceleration along the path by differences over a microsecond.
pub struct Trapezoids {
    blocks: Vec<Block>,
    /// Total duration (s).
    pub duration_s: f64,
    /// The positions last evaluated, by the time's bits: a record's axes read the command
    /// at the same instants, and each Runge–Kutta step reads its midpoint twice, so most
    /// evaluations repeat one exactly (the same time, the same position bit for bit).
    recent: RefCell<[Option<Kept>; RECENT]>,
    /// Where the next evaluation is kept in `recent`.
    slot: Cell<usize>,
}

/// How many positions [`Trapezoids`] keeps: a step of two axes with feed-forward asks for
/// nine instants (three for each difference at three of the step's times).
const RECENT: usize = 16;

impl Trapezoids {
    pub fn new(program: &Program, accel: f64, pre_s: f64, post_s: f64) -> Trapezoids {
        Trapezoids::from_home(program, accel, pre_s, post_s, None)
    }

    /// [`Trapezoids::new`] for a machine standing at `home` (m), where given, rather than
    /// at the program's start: the program's first move runs from there — its first rapid
    /// from home to the rapid's end, or, where it begins with a feed move, a rapid from
    /// home to that move's start first. The approach is a move the program does not
    /// describe: a control starts it from wherever the machine stands.
    pub fn from_home(
        program: &Program,
        accel: f64,
        pre_s: f64,
        post_s: f64,
        home: Option<[f64; 2]>,
    ) -> Trapezoids {
        let ramp = move |length, v| trapezoid(length, v, accel);
        Trapezoids::build(program, &ramp, pre_s, post_s, home)
    }

    /// The same blocks, each on a jerk-limited profile (an S-curve): its acceleration
    /// ramps at `jerk` to at most `accel` and back, rest to rest.
    pub fn s_curves(program: &Program, accel: f64, jerk: f64, pre_s: f64, post_s: f64) -> Self {
        let ramp = move |length, v| s_curve(length, v, accel, jerk);
        Trapezoids::build(program, &ramp, pre_s, post_s, None)
    }

    /// The blocks of `program`, each moved along by `profile` (of its length and feed: its
    /// duration and the distance travelled at a time into it).
    fn build(
        program: &Program,
        profile: &dyn Fn(f64, f64) -> (f64, Distance),
        pre_s: f64,
        post_s: f64,
        home: Option<[f64; 2]>,
    ) -> Trapezoids {
        const RAPID_M_PER_S: f64 = 10.0 / 60.0;
        let mut blocks: Vec<Block> = Vec::new();
        let mut segments = program.segments.clone();
        if let Some([hx, hy]) = home {
            let first = segments[0];
            if first.motion == Motion::Rapid && matches!(first.geometry, Geometry::Line) {
                segments[0].start_m = [hx, hy, first.start_m[2]];
            } else {
                let mut approach = first;
                approach.geometry = Geometry::Line;
                approach.motion = Motion::Rapid;
                approach.start_m = [hx, hy, first.start_m[2]];
                approach.end_m = first.start_m;
                segments.insert(0, approach);
            }
        }
        let start = segments[0].start_m;
        blocks.push((pre_s, Box::new(move |_| start)));
        for seg in segments.iter().copied() {
            if let Geometry::Dwell { seconds } = seg.geometry {
                let p = seg.start_m;
                blocks.push((seconds, Box::new(move |_| p)));
                continue;
            }
            let length = seg.length_m();
            if length <= 0.0 {
                continue;
            }
            let v = if seg.motion == Motion::Rapid {
                RAPID_M_PER_S
            } else {
                seg.feed_m_per_s.min(RAPID_M_PER_S)
            };
            let (total, distance) = profile(length, v);
            blocks.push((
                total,
                Box::new(move |t| seg.eval(distance(t.clamp(0.0, total)), length).pos),
            ));
        }
        let end = segments.last().unwrap().end_m;
        blocks.push((post_s, Box::new(move |_| end)));
        let duration_s = blocks.iter().map(|b| b.0).sum();
        Trapezoids {
            blocks,
            duration_s,
            recent: RefCell::new([None; RECENT]),
            slot: Cell::new(0),
        }
    }

    /// The commanded XYZ position at `t` (m).
    pub fn position(&self, t: f64) -> [f64; 3] {
        let key = t.to_bits();
        let known = self
            .recent
            .borrow()
            .iter()
            .flatten()
            .find(|r| r.0 == key)
            .map(|r| r.1);
        known.unwrap_or_else(|| {
            let p = self.evaluated(t);
            let slot = self.slot.get();
            self.recent.borrow_mut()[slot] = Some((key, p));
            self.slot.set((slot + 1) % RECENT);
            p
        })
    }

    /// The commanded XYZ position at `t` (m), evaluated on its block.
    fn evaluated(&self, t: f64) -> [f64; 3] {
        let mut start = 0.0;
        for (k, (d, f)) in self.blocks.iter().enumerate() {
            if t < start + d || k + 1 == self.blocks.len() {
                return f((t - start).clamp(0.0, *d));
            }
            start += d;
        }
        unreachable!("the interpolator has blocks")
    }

    /// Axis `a`'s position, speed and acceleration at `t`.
    pub fn axis(&self, a: usize, t: f64) -> (f64, f64, f64) {
        const H: f64 = 1e-6;
        let (p0, p1, p2) = (
            self.position(t - H)[a],
            self.position(t)[a],
            self.position(t + H)[a],
        );
        (p1, (p2 - p0) / (2.0 * H), (p2 - 2.0 * p1 + p0) / (H * H))
    }
}
