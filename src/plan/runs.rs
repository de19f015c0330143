//! Runs: consecutive segments planned under one speed profile, as a control's look-ahead
//! plans across the short blocks a CAM system writes.
//!
//! A CAM program approximates curves by chords of a fraction of a millimetre, and splits
//! long moves into many. Planned block by block, each junction of such a polygon would be a
//! corner — a speed dip and zero acceleration at every block boundary — and the machine
//! would crawl where it really moves at the programmed feed. So a junction whose polygon
//! vertex lies within the blend tolerance of a smooth curve through the neighbouring
//! vertices (sagitta min(L)·θ/8 ≤ tolerance: a chord vertex, or a tangent junction) joins
//! its segments into a run. The run is one profile over its whole length, its speed limited
//! as an arc's would be by the curvature the vertices stand for (radius min(L)/θ, or, where
//! the rounding of very short chords makes one vertex's turn meaningless, the circle through
//! the vertices around it: the circle the chords were cut from), and a run ends where the
//! segments' own limits change markedly, so that one tight spot does not slow a long run.
//!
//! Runs are a planning notion only: every segment keeps its own geometry, and the commands
//! follow the polygon exactly.

use super::profile::Dynamics;
use super::{KinematicLimits, PlanConfig, ProfileKind, SegmentLimits};
use crate::path::{Blend, Geometry, Motion, Segment, dot3};

/// A run of segments `first..=last` and the limits of its common profile.
#[derive(Debug, Clone, Copy)]
pub(super) struct Run {
    pub first: usize,
    pub last: usize,
    pub limits: SegmentLimits,
    /// The highest speed limit among its members (m/s): with `limits.v_max`, the lowest,
    /// it keeps a run's members within one band of limits.
    v_top: f64,
    /// The same for the path acceleration (m/s²).
    accel_top: f64,
}

/// A run's members' speed limits (their own, and their junctions') lie within this ratio
/// of each other: where limits drift — a spiral tightening — a run ends and the next
/// begins, rather than one run slowing to its tightest member's limit.
const LIMIT_RATIO: f64 = 0.9;
/// The same for their path accelerations: a run accelerates as its weakest member allows.
const ACCEL_RATIO: f64 = 0.5;

/// Groups the segments into runs; every segment is in exactly one, in order.
pub(super) fn form_runs(
    segments: &[Segment],
    seg_limits: &[SegmentLimits],
    limits: &KinematicLimits,
    config: &PlanConfig,
) -> Vec<Run> {
    let mut runs: Vec<Run> = Vec::new();
    for (i, lim) in seg_limits.iter().enumerate() {
        let joined = match runs.last_mut() {
            Some(run) if run.last + 1 == i => smooth_junction_speed(segments, i, limits, config)
                .and_then(|v_junction| {
                    let turn =
                        turning_axes(&segments[i - 1], &segments[i]).unwrap_or([true, true, false]);
                    extend(run, lim, (v_junction, turn), config, limits)
                }),
            _ => None,
        };
        match joined {
            Some(extended) => *runs.last_mut().expect("joined a run") = extended,
            None => runs.push(Run {
                first: i,
                last: i,
                limits: *lim,
                v_top: lim.v_max,
                accel_top: lim.dynamics.accel,
            }),
        }
    }
    runs
}

/// The run extended by one segment through a smooth junction, if their limits agree.
fn extend(
    run: &Run,
    next: &SegmentLimits,
    (v_junction, turning): (f64, [bool; 3]),
    config: &PlanConfig,
    limits: &KinematicLimits,
) -> Option<Run> {
    let v_next = next.v_max.min(v_junction);
    let (v_low, v_top) = (run.limits.v_max.min(v_next), run.v_top.max(v_next));
    let accel_top = run.accel_top.max(next.dynamics.accel);
    if v_low < LIMIT_RATIO * v_top {
        return None;
    }
    let mut dynamics = Dynamics {
        accel: run.limits.dynamics.accel.min(next.dynamics.accel),
        jerk: run.limits.dynamics.jerk.min(next.dynamics.jerk),
    };
    if v_junction.is_finite() {
        // The path turns at this junction: the tangential acceleration shares the axes it
        // turns on with the centripetal, as on an arc.
        dynamics = curved(dynamics, turning, limits, config);
    }
    if dynamics.accel < ACCEL_RATIO * accel_top {
        return None;
    }
    Some(Run {
        first: run.first,
        last: run.last + 1,
        limits: SegmentLimits {
            length: run.limits.length + next.length,
            v_max: v_low,
            dynamics,
        },
        v_top,
        accel_top,
    })
}

/// Tangential dynamics on a curved path turning on the axes `turning`: √(1 − η²) of their
/// acceleration, half their jerk.
fn curved(
    d: Dynamics,
    turning: [bool; 3],
    limits: &KinematicLimits,
    config: &PlanConfig,
) -> Dynamics {
    let (accel, jerk) = turn_limits(limits, turning);
    let eta = config.arc_normal_share;
    Dynamics {
        accel: d.accel.min((1.0 - eta * eta).sqrt() * accel),
        jerk: d.jerk.min(0.5 * jerk),
    }
}

/// The axes the path turns on at the junction of `a` and `b`: where the tangent changes or
/// either side curves; `None` where it does neither.
fn turning_axes(a: &Segment, b: &Segment) -> Option<[bool; 3]> {
    let (t_in, t_out) = (a.end_tangent(), b.start_tangent());
    let (k_in, k_out) = (a.end_curvature(), b.start_curvature());
    let turning = [0, 1, 2].map(|i| {
        (t_out[i] - t_in[i]).abs() > 1e-12 || k_in[i].abs() > 1e-12 || k_out[i].abs() > 1e-12
    });
    turning.contains(&true).then(|| xy_together(turning))
}

/// X and Y are taken together wherever either turns, as the planner always has for curves
/// in XY; Z joins them where it turns too.
fn xy_together(turning: [bool; 3]) -> [bool; 3] {
    let xy = turning[0] || turning[1];
    [xy, xy, turning[2]]
}

/// The lowest acceleration and jerk limits among the axes a curve turns on (m/s², m/s³).
fn turn_limits(limits: &KinematicLimits, turning: [bool; 3]) -> (f64, f64) {
    limits
        .axes
        .iter()
        .zip(turning)
        .filter(|(_, on)| *on)
        .fold((f64::INFINITY, f64::INFINITY), |(a, j), (l, _)| {
            (a.min(l.accel_m_per_s2), j.min(l.jerk_m_per_s3))
        })
}

/// The speed limit through the junction before segment `i` when it is smooth enough to be
/// planned through (infinite when the path does not turn there); `None` for a corner, and
/// wherever the control stops or the profile kind has no look-ahead to speak of.
pub(super) fn smooth_junction_speed(
    segments: &[Segment],
    i: usize,
    limits: &KinematicLimits,
    config: &PlanConfig,
) -> Option<f64> {
    let (a, b) = (&segments[i - 1], &segments[i]);
    let config = &config.for_junction(a, b);
    let continuous = matches!(a.blend, Blend::Continuous { .. });
    let feeds = a.motion == Motion::Feed && b.motion == Motion::Feed;
    if config.profile == ProfileKind::Ideal || a.is_dwell() || b.is_dwell() || !continuous || !feeds
    {
        return None;
    }
    let (t_in, t_out) = (a.end_tangent(), b.start_tangent());
    let theta = dot3(t_in, t_out).clamp(-1.0, 1.0).acos();
    let mut v = curvature_jump_speed(a, b, limits, config);
    if theta > 1e-9 {
        let shorter = a.length_m().min(b.length_m());
        // LinuxCNC's G64 Q names this tolerance; otherwise the blend tolerance (P) serves.
        let tolerance = match a.blend {
            Blend::Continuous {
                naive_cam_m: Some(q),
                ..
            } => q,
            Blend::Continuous {
                tolerance_m: Some(p),
                ..
            } => p,
            _ => config.default_blend_tolerance_m,
        };
        if shorter * theta / 8.0 > tolerance {
            return None;
        }
        let mut radius = shorter / theta;
        let turning = xy_together([0, 1, 2].map(|i| (t_out[i] - t_in[i]).abs() > 1e-12));
        if arc_speed(radius, turning, limits, config) < a.feed_m_per_s.max(b.feed_m_per_s) {
            // The vertex alone would slow the feed: see whether it is only the rounding of
            // short chords' end points.
            radius = chord_radius(segments, i, tolerance).unwrap_or(radius);
        }
        v = v.min(arc_speed(radius, turning, limits, config));
        // The commands turn at the vertex within one cycle: each axis's velocity step there
        // stays within what its acceleration gives in a cycle. (A corner under S-curves is
        // held to a cycle's jerk, j·T²; at a chord vertex that would stop a CAM polygon to
        // a crawl for steps smaller than the ramps it would cost.)
        for i in 0..3 {
            let jump = (t_out[i] - t_in[i]).abs();
            if jump > 1e-12 {
                v = v.min(limits.axes[i].accel_m_per_s2 * config.cycle_s / jump);
            }
        }
    }
    Some(v)
}

/// Chord vertices followed on each side of a vertex to find the curve it lies on, at most.
const CURVE_CHORDS: usize = 64;
/// Path length followed on each side (m): enough that the rounding of the vertices (0.1 µm
/// or 1 µm, as a CAM system writes them) tilts the chords over it by less than the curve
/// turns.
const CURVE_SPAN_M: f64 = 0.5e-3;

/// The radius of the curve that the chords around vertex `i` (the start of segment `i`) were
/// cut from: the circle through the vertices up to [`CURVE_SPAN_M`] before and after it, as
/// long as every vertex between lies on that circle within the blend `tolerance_m` (m). On
/// chords of a few µm the rounding of the end points turns each vertex by more than the
/// curve does, so a single vertex's turn says little about the curve — the run would crawl
/// where a control, which fits its path through many blocks (a compressor, G64 blending),
/// moves at the feed. `None` when the neighbours are not planar line chords.
fn chord_radius(segments: &[Segment], i: usize, tolerance_m: f64) -> Option<f64> {
    let is_chord = |s: &Segment| {
        matches!(s.geometry, Geometry::Line)
            && s.motion == Motion::Feed
            && (s.end_m[2] - s.start_m[2]).abs() < 1e-12
    };
    let joined = |s: &Segment| matches!(s.blend, Blend::Continuous { .. });
    let vertex = |j: usize| [segments[j].start_m[0], segments[j].start_m[1]];
    let end_of = |j: usize| [segments[j].end_m[0], segments[j].end_m[1]];
    // Vertices reachable backward (segments i-1, i-2, … chords joined at their ends) and
    // forward (segments i, i+1, …), within the span.
    let (mut back, mut span) = (0, 0.0);
    while back < CURVE_CHORDS && i > back && span < CURVE_SPAN_M {
        let s = &segments[i - back - 1];
        if !is_chord(s) || !joined(s) {
            break;
        }
        span += s.length_m();
        back += 1;
    }
    let (mut ahead, mut span) = (0, 0.0);
    while ahead < CURVE_CHORDS && i + ahead < segments.len() && span < CURVE_SPAN_M {
        let s = &segments[i + ahead];
        if !is_chord(s) || (ahead > 0 && !joined(&segments[i + ahead - 1])) {
            break;
        }
        span += s.length_m();
        ahead += 1;
    }
    if back == 0 || ahead == 0 {
        return None;
    }
    // Point k of the window: -back..=ahead around the vertex.
    let point = |k: isize| {
        if k <= 0 {
            vertex((i as isize + k) as usize)
        } else {
            end_of(i + k as usize - 1)
        }
    };
    // Widen the window by doubling while its vertices stay on one circle (or line).
    let mut radius = None;
    let mut reach = 1usize;
    loop {
        let (lo, hi) = (-(reach.min(back) as isize), reach.min(ahead) as isize);
        let (first, last) = (point(lo), point(hi));
        let circle = circumcircle(first, point(0), last);
        let off_curve = |p: [f64; 2]| match circle {
            Some((c, r)) => ((p[0] - c[0]).hypot(p[1] - c[1]) - r).abs(),
            None => {
                let (dx, dy) = (last[0] - first[0], last[1] - first[1]);
                ((p[0] - first[0]) * dy - (p[1] - first[1]) * dx).abs() / dx.hypot(dy)
            }
        };
        if (lo + 1..hi).any(|k| off_curve(point(k)) > tolerance_m) {
            break;
        }
        radius = Some(circle.map_or(f64::INFINITY, |c| c.1));
        if reach >= back.max(ahead) {
            break;
        }
        reach *= 2;
    }
    radius
}

/// The circle through three points: centre and radius (m); `None` when they are collinear.
fn circumcircle(p: [f64; 2], q: [f64; 2], r: [f64; 2]) -> Option<([f64; 2], f64)> {
    let (bx, by) = (q[0] - p[0], q[1] - p[1]);
    let (cx, cy) = (r[0] - p[0], r[1] - p[1]);
    let d = 2.0 * (bx * cy - by * cx);
    let scale = (bx * bx + by * by).max(cx * cx + cy * cy);
    if d.abs() <= 1e-12 * scale {
        return None;
    }
    let (b2, c2) = (bx * bx + by * by, cx * cx + cy * cy);
    let ux = (cy * b2 - by * c2) / d;
    let uy = (bx * c2 - cx * b2) / d;
    Some(([p[0] + ux, p[1] + uy], ux.hypot(uy)))
}

/// The speed limit of a circle of radius `r` (m) turning on the axes `turning`: centripetal
/// acceleration within η·a and, for S-curves, the rotating acceleration's jerk within j/4 —
/// the arc rules of the segment limits.
fn arc_speed(r: f64, turning: [bool; 3], limits: &KinematicLimits, config: &PlanConfig) -> f64 {
    let (a, j) = turn_limits(limits, turning);
    let mut v = (config.arc_normal_share * a * r).sqrt();
    if config.profile == ProfileKind::SCurve {
        v = v.min((0.25 * j * r * r).cbrt());
    }
    v
}

/// For S-curves: a step of curvature (a line meeting an arc tangentially) steps each
/// axis's acceleration by v²·Δκ, which must stay within one cycle's jerk.
fn curvature_jump_speed(
    a: &Segment,
    b: &Segment,
    limits: &KinematicLimits,
    config: &PlanConfig,
) -> f64 {
    if config.profile != ProfileKind::SCurve {
        return f64::INFINITY;
    }
    let (k_in, k_out) = (a.end_curvature(), b.start_curvature());
    (0..3)
        .filter_map(|i| {
            let step = (k_out[i] - k_in[i]).abs();
            (step > 1e-12).then(|| (limits.axes[i].jerk_m_per_s3 * config.cycle_s / step).sqrt())
        })
        .fold(f64::INFINITY, f64::min)
}
