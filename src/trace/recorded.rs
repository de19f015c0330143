//! Commands a control recorded (a servo trace's commanded positions, or any other
//! interpolator's output) made into the simulator's input, and placed on the program.
//!
//! Another control interpolates on its own clock, with its own feed profile, look-ahead
//! and blending, so its command stream cannot be expected to follow our plan in time; it
//! must only follow the program's geometry. Two steps:
//!
//! 1. [`commands_from_record`]: positions resampled to the simulation's step; velocity and
//!    acceleration (the feed-forward inputs) from a local quadratic least-squares fit over
//!    a few milliseconds of the raw samples — differences of neighbouring samples would
//!    amplify the encoder's quantisation (0.1 µm at 0.1 ms is 1 mm/s of noise).
//! 2. [`place_on_path`]: each command sample located on the program's segments by a search
//!    that only moves forward, so that the report can name source lines and rapids; the
//!    largest distance from the programmed geometry is checked against a tolerance.

use crate::path::{Motion, Segment};
use crate::plan::{AxisCommands, Commands, Plan};
use crate::trace::signal::sample;

/// Half-width of the derivative fit (s): wide enough to average a 10 kHz record's
/// quantisation, short against any feed change a servo follows.
const DERIVATIVE_HALF_WIDTH_S: f64 = 3e-3;

/// Commands on a uniform step `dt_out_s` from positions recorded every `dt_in_s` (the first
/// sample at t = 0).
pub fn commands_from_record(x_m: &[f64], y_m: &[f64], dt_in_s: f64, dt_out_s: f64) -> Commands {
    let len = x_m.len().min(y_m.len());
    let n = if len == 0 {
        0
    } else {
        ((len - 1) as f64 * dt_in_s / dt_out_s).floor() as usize + 1
    };
    let half = DERIVATIVE_HALF_WIDTH_S
        .max(1.5 * dt_out_s)
        .max(1.5 * dt_in_s);
    let axis = |v: &[f64]| {
        let v = &v[..len];
        let mut out = AxisCommands {
            pos_m: Vec::with_capacity(n),
            vel_m_per_s: Vec::with_capacity(n),
            acc_m_per_s2: Vec::with_capacity(n),
        };
        for k in 0..n {
            let t = k as f64 * dt_out_s;
            let (vel, acc) = local_derivatives(v, dt_in_s, t, half);
            out.pos_m.push(sample(v, dt_in_s, t));
            out.vel_m_per_s.push(vel);
            out.acc_m_per_s2.push(acc);
        }
        out
    };
    Commands {
        dt_s: dt_out_s,
        x: axis(x_m),
        y: axis(y_m),
        z_m: vec![0.0; n],
        segment: vec![0; n],
    }
}

/// Slope and curvature at `t` of the least-squares parabola through the samples of `v`
/// (step `dt`) within ±`half` of `t`; zero where fewer than three samples lie there.
fn local_derivatives(v: &[f64], dt: f64, t: f64, half: f64) -> (f64, f64) {
    let lo = ((t - half) / dt).ceil().max(0.0) as usize;
    let hi = (((t + half) / dt).floor() as usize).min(v.len().saturating_sub(1));
    if hi < lo + 2 {
        return (0.0, 0.0);
    }
    // τ in units of `half` keeps the normal equations well conditioned.
    let mut s = [0.0f64; 5];
    let mut m = [0.0f64; 3];
    let y0 = v[lo];
    for (j, &vj) in v.iter().enumerate().take(hi + 1).skip(lo) {
        let tau = (j as f64 * dt - t) / half;
        let y = vj - y0;
        let mut p = 1.0;
        for (k, sk) in s.iter_mut().enumerate() {
            *sk += p;
            if k < 3 {
                m[k] += p * y;
            }
            p *= tau;
        }
    }
    // Normal equations of y ≈ a + b τ + c τ².
    let normal = nalgebra::Matrix3::new(s[0], s[1], s[2], s[1], s[2], s[3], s[2], s[3], s[4]);
    match normal.lu().solve(&nalgebra::Vector3::new(m[0], m[1], m[2])) {
        Some(c) => (c[1] / half, 2.0 * c[2] / (half * half)),
        None => (0.0, 0.0),
    }
}

/// Where a command stream leaves the program's geometry furthest.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Departure {
    /// Time of the command sample (s from the stream's start).
    pub t_s: f64,
    /// Source line of the nearest segment.
    pub line: u32,
    /// Distance from the programmed geometry (m).
    pub distance_m: f64,
}

/// Path length beyond the distance moved that the search looks ahead (m): enough for a
/// blended corner's cut, short of the next pass of any pocket.
const LOOK_AHEAD_MARGIN_M: f64 = 0.2e-3;

/// Sets each command sample's segment (into `plan.segments`) by following the stream along
/// the program, and returns the sample where the stream lies furthest from the programmed
/// geometry. Rapids are not held to their line (many controls move each axis on its own
/// in G0); the stream is matched again where the feed motion begins.
pub fn place_on_path(plan: &Plan, commands: &mut Commands) -> Option<Departure> {
    let segs = &plan.segments;
    if segs.is_empty() || commands.is_empty() {
        return None;
    }
    let n = commands.len();
    let point = |k: usize| [commands.x.pos_m[k], commands.y.pos_m[k]];
    let mut current = first_segment(segs, point(0));
    let mut u = segs[current].project_xy(point(0), 0.0).u;
    let mut worst: Option<Departure> = None;
    let mut last = point(0);
    for k in 0..n {
        let q = point(k);
        let moved = (q[0] - last[0]).hypot(q[1] - last[1]);
        last = q;
        let (j, proj) = best_ahead(segs, current, u, q, moved + LOOK_AHEAD_MARGIN_M);
        current = j;
        u = proj.u;
        commands.segment[k] = j as u32;
        if segs[j].motion == Motion::Rapid {
            continue;
        }
        let d = proj.signed_distance_m.abs();
        if worst.is_none_or(|w| d > w.distance_m) {
            worst = Some(Departure {
                t_s: k as f64 * commands.dt_s,
                line: segs[j].line,
                distance_m: d,
            });
        }
    }
    worst
}

/// The first segment the stream's first point lies on (to 1 µm), else the nearest one.
fn first_segment(segs: &[Segment], q: [f64; 2]) -> usize {
    let distance = |j: usize| segs[j].project_xy(q, 0.0).signed_distance_m.abs();
    (0..segs.len())
        .find(|&j| distance(j) < 1e-6)
        .unwrap_or_else(|| {
            (0..segs.len())
                .min_by(|&a, &b| distance(a).total_cmp(&distance(b)))
                .unwrap_or(0)
        })
}

/// The segment nearest `q` among the current one and those starting within `window` of
/// path length ahead (all of a chain of rapids, and the feed segment after it, while in a
/// rapid). Ties go to the later segment: a path that doubles back on itself is followed
/// onto the return stroke.
fn best_ahead(
    segs: &[Segment],
    current: usize,
    u: f64,
    q: [f64; 2],
    window: f64,
) -> (usize, crate::path::Projection) {
    let mut best = (current, segs[current].project_xy(q, u));
    let mut ahead = (1.0 - u) * segs[current].xy_length_m();
    let mut in_rapids = segs[current].motion == Motion::Rapid;
    let mut j = current + 1;
    while j < segs.len() && (ahead <= window || in_rapids) {
        let p = segs[j].project_xy(q, 0.0);
        if p.signed_distance_m.abs() <= best.1.signed_distance_m.abs() + 1e-9 {
            best = (j, p);
        }
        // A chain of rapids is searched to its end and one segment beyond.
        in_rapids = in_rapids && segs[j].motion == Motion::Rapid;
        ahead += segs[j].xy_length_m();
        j += 1;
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn derivatives_of_a_quantised_parabola_are_close_to_the_truth() {
        // x = 0.5·a·t² at 10 kHz with 0.1 µm counts; a = 2 m/s².
        let dt = 1e-4;
        let q = 1e-7;
        let x: Vec<f64> = (0..20_000)
            .map(|i| {
                let t = i as f64 * dt;
                (t * t / q).round() * q
            })
            .collect();
        let c = commands_from_record(&x, &x, dt, 2e-3);
        for k in 10..c.len() - 10 {
            let t = k as f64 * 2e-3;
            assert!((c.x.vel_m_per_s[k] - 2.0 * t).abs() < 2e-5, "{k}");
            assert!((c.x.acc_m_per_s2[k] - 2.0).abs() < 0.02, "{k}");
        }
    }

    #[test]
    fn three_samples_give_central_differences() {
        let x = [0.0, 1.0, 4.0];
        let (v, a) = local_derivatives(&x, 1.0, 1.0, 1.5);
        assert!((v - 2.0).abs() < 1e-12 && (a - 2.0).abs() < 1e-12);
    }
}
