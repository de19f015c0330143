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
//! as an arc's would be by the curvature the vertices stand for (radius min(L)/θ: the
//! circle the chords were cut from), and a run ends where the segments' own limits change
//! markedly, so that one tight spot does not slow a long run.
//!
//! Runs are a planning notion only: every segment keeps its own geometry, and the commands
//! follow the polygon exactly.

use super::profile::Dynamics;
use super::{KinematicLimits, PlanConfig, ProfileKind, SegmentLimits};
use crate::path::{Blend, Motion, Segment, dot3};

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
            Some(run) if run.last + 1 == i => {
                smooth_junction_speed(&segments[i - 1], &segments[i], limits, config)
                    .and_then(|v_junction| extend(run, lim, v_junction, config, limits))
            }
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
    v_junction: f64,
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
        // The path turns at this junction: the tangential acceleration shares the axes with
        // the centripetal, as on an arc.
        dynamics = curved(dynamics, limits, config);
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

/// Tangential dynamics on a curved path: √(1 − η²) of the acceleration, half the jerk.
fn curved(d: Dynamics, limits: &KinematicLimits, config: &PlanConfig) -> Dynamics {
    let [x, y, _] = limits.axes;
    let eta = config.arc_normal_share;
    Dynamics {
        accel: d
            .accel
            .min((1.0 - eta * eta).sqrt() * x.accel_m_per_s2.min(y.accel_m_per_s2)),
        jerk: d.jerk.min(0.5 * x.jerk_m_per_s3.min(y.jerk_m_per_s3)),
    }
}

/// The speed limit through the junction between `a` and `b` when it is smooth enough to be
/// planned through (infinite when the path does not turn there); `None` for a corner, and
/// wherever the control stops or the profile kind has no look-ahead to speak of.
pub(super) fn smooth_junction_speed(
    a: &Segment,
    b: &Segment,
    limits: &KinematicLimits,
    config: &PlanConfig,
) -> Option<f64> {
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
        v = v.min(arc_speed(shorter / theta, limits, config));
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

/// The speed limit of a circle of radius `r` (m) in XY: centripetal acceleration within η·a
/// and, for S-curves, the rotating acceleration's jerk within j/4 — the arc rules of the
/// segment limits.
fn arc_speed(r: f64, limits: &KinematicLimits, config: &PlanConfig) -> f64 {
    let [x, y, _] = limits.axes;
    let a = x.accel_m_per_s2.min(y.accel_m_per_s2);
    let mut v = (config.arc_normal_share * a * r).sqrt();
    if config.profile == ProfileKind::SCurve {
        let j = x.jerk_m_per_s3.min(y.jerk_m_per_s3);
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
