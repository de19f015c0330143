//! Feed planning: the path speed over the whole program, within every axis's limits.
//!
//! 1. Each segment gets a speed limit (programmed F, clamped to the axes' feed limits; on
//!    arcs also the centripetal acceleration v²/R and, for S-curves, the jerk v³/R² of the
//!    rotating acceleration) and the tangential acceleration and jerk its direction allows.
//! 2. Each junction gets a speed limit: zero under exact stop (G61), at dwells and at program
//!    stops; under G64 the lowest of grbl's junction-deviation speed for the blend tolerance
//!    and the interpolation-cycle rule — a corner's per-axis velocity jump may be at most
//!    what the axis could do in one cycle (a·T, or j·T² for S-curves), and for S-curves a
//!    curvature jump's per-axis acceleration step at most j·T.
//!    Consecutive blocks joined smoothly — a CAM polygon's vertices, tangent arcs, collinear
//!    splits — form a run (see `runs`) planned as one segment, so the junction rules apply
//!    only between runs.
//! 3. A backward and a forward pass over the whole program bring every junction speed down
//!    to what the neighbouring runs can reach (look-ahead over the whole program).
//! 4. Each run gets the fastest ramp–cruise–ramp profile between its junction speeds, and
//!    each of its segments the slice of it over its own length.
//!
//! Profiles start and end every run with zero path acceleration, so the only acceleration
//! steps are those of curvature (and, for trapezoids, of the ramps themselves).

pub mod execute;
pub mod profile;
mod runs;
pub mod sample;

use crate::gcode::{Program, Warning};
use crate::machine::{Limits, MachineConfig};
use crate::numeric::units::{
    m_from_mm, m_per_s_from_mm_per_min, mm_per_min_from_m_per_s, s_from_ms,
};
use crate::path::{Blend, Geometry, Motion, Segment, dot3};
use profile::{Dynamics, SegmentProfile, reachable_speed};

pub use crate::sim::AxisCommands;
pub use sample::{AxisPeaks, Commands, Sampler, sample};

/// The shape of the speed profile.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ProfileKind {
    /// Acceleration-limited (trapezoidal speed).
    Trapezoid,
    /// Jerk-limited (S-curve speed).
    SCurve,
    /// The programmed feed from the first instant, no acceleration limit: the velocity-step
    /// inputs of the paper's experiments.
    Ideal,
}

impl std::fmt::Display for ProfileKind {
    /// As on the command line: `trapezoid`, `s-curve`, `ideal`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            ProfileKind::Trapezoid => "trapezoid",
            ProfileKind::SCurve => "s-curve",
            ProfileKind::Ideal => "ideal",
        })
    }
}

impl std::str::FromStr for ProfileKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "trapezoid" => Ok(ProfileKind::Trapezoid),
            "s-curve" | "scurve" => Ok(ProfileKind::SCurve),
            "ideal" => Ok(ProfileKind::Ideal),
            _ => Err(format!("unknown profile '{s}' (trapezoid, s-curve, ideal)")),
        }
    }
}

/// The control's in-position check: after an exact stop (an RS274/NGC rapid, a G61 block)
/// the next block starts only when every axis's following error is within the window.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InPosition {
    /// Exact-stop window (m).
    pub window_m: f64,
    /// Position-loop gain of X, Y and Z (1/s), for the first-order estimate of their lag;
    /// infinite for an axis that is carried, not simulated (it arrives with its command).
    pub kv_per_s: [f64; 3],
}

impl InPosition {
    /// The loops' time scales the wait estimate uses, X, Y and Z (1/s): the cascade's Kv,
    /// or another controller's closed-loop bandwidth (the simulated waits re-time it).
    pub(crate) fn kv_per_s_of(machine: &MachineConfig) -> [f64; 3] {
        let kv = |a: &crate::machine::AxisConfig| {
            crate::sim::linear::equivalent_kv_per_s(&crate::sim::AxisModel::from_config(a))
        };
        [
            kv(&machine.x),
            kv(&machine.y),
            machine.z.simulated().map_or(f64::INFINITY, kv),
        ]
    }

    /// The same for the axes controlled by the cascade (their Kv, cheap); none for others.
    pub(crate) fn kv_per_s_of_cascades(machine: &MachineConfig) -> [Option<f64>; 3] {
        let kv = |a: &crate::machine::AxisConfig| {
            a.controller
                .is_cascade()
                .then(|| crate::sim::AxisModel::from_config(a).kv_per_s())
        };
        [
            kv(&machine.x),
            kv(&machine.y),
            machine.z.simulated().map_or(Some(f64::INFINITY), kv),
        ]
    }
}

/// Planner settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlanConfig {
    /// Profile shape.
    pub profile: ProfileKind,
    /// Interpolation cycle T (s): the command sample period.
    pub cycle_s: f64,
    /// Corner tolerance under G64 without P (m).
    pub default_blend_tolerance_m: f64,
    /// Share η of an axis's acceleration an arc may spend on centripetal acceleration; the
    /// tangential acceleration gets √(1 − η²) so that the vector sum stays within the limit.
    pub arc_normal_share: f64,
    /// Path (tangential) acceleration and jerk limits beside the axes' (m/s², m/s³;
    /// infinite: none).
    pub path_dynamics: Dynamics,
    /// In-position check at exact stops (`None`: the next block starts as soon as the
    /// interpolator stops).
    pub in_position: Option<InPosition>,
}

impl PlanConfig {
    /// The settings for `seg`: the profile the program switched to for it (SINUMERIK
    /// `SOFT`: S-curve, `BRISK`: trapezoid) in place of the planner's, which holds where the
    /// program switched none and where it is the ideal profile (the paper's velocity steps).
    pub(crate) fn for_segment(&self, seg: &Segment) -> PlanConfig {
        let profile = match (self.profile, seg.jerk_limited) {
            (ProfileKind::Ideal, _) | (_, None) => self.profile,
            (_, Some(true)) => ProfileKind::SCurve,
            (_, Some(false)) => ProfileKind::Trapezoid,
        };
        PlanConfig { profile, ..*self }
    }

    /// The settings for the junction of `a` and `b`: jerk limited where either side is.
    pub(crate) fn for_junction(&self, a: &Segment, b: &Segment) -> PlanConfig {
        let (ca, cb) = (self.for_segment(a), self.for_segment(b));
        if cb.profile == ProfileKind::SCurve {
            cb
        } else {
            ca
        }
    }

    /// Defaults for a machine: its interpolation cycle, centripetal share and path limits,
    /// S-curve profiles, 10 µm corner tolerance.
    pub fn for_machine(machine: &MachineConfig) -> PlanConfig {
        PlanConfig {
            profile: ProfileKind::SCurve,
            cycle_s: s_from_ms(machine.interpolation.cycle_ms),
            default_blend_tolerance_m: m_from_mm(0.01),
            arc_normal_share: machine.interpolation.arc_normal_share,
            path_dynamics: Dynamics {
                accel: machine
                    .interpolation
                    .path_accel_m_per_s2
                    .unwrap_or(f64::INFINITY),
                jerk: machine
                    .interpolation
                    .path_jerk_m_per_s3
                    .unwrap_or(f64::INFINITY),
            },
            in_position: Some(InPosition {
                window_m: m_from_mm(machine.interpolation.in_position_window_mm),
                kv_per_s: InPosition::kv_per_s_of(machine),
            }),
        }
    }
}

/// Kinematic limits of one axis in SI units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisLimits {
    /// Cutting feed limit (m/s).
    pub max_feed_m_per_s: f64,
    /// Rapid rate (m/s).
    pub rapid_m_per_s: f64,
    /// Acceleration limit (m/s²).
    pub accel_m_per_s2: f64,
    /// Jerk limit (m/s³).
    pub jerk_m_per_s3: f64,
}

impl From<&Limits> for AxisLimits {
    fn from(l: &Limits) -> Self {
        AxisLimits {
            max_feed_m_per_s: m_per_s_from_mm_per_min(l.max_feed_mm_per_min),
            rapid_m_per_s: m_per_s_from_mm_per_min(l.rapid_mm_per_min),
            accel_m_per_s2: l.max_accel_m_per_s2,
            jerk_m_per_s3: l.max_jerk_m_per_s3,
        }
    }
}

/// Limits of the X, Y and Z axes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KinematicLimits {
    /// X, Y, Z.
    pub axes: [AxisLimits; 3],
}

impl KinematicLimits {
    /// The machine's limits.
    pub fn of(machine: &MachineConfig) -> Self {
        KinematicLimits {
            axes: [
                (&machine.x.limits).into(),
                (&machine.y.limits).into(),
                machine.z.limits().into(),
            ],
        }
    }
}

/// The plan of one segment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SegmentPlan {
    /// Start time (s) from the program start.
    pub t_start_s: f64,
    /// Path length (m).
    pub length_m: f64,
    /// Speed at the start (m/s).
    pub v_entry: f64,
    /// Speed at the end (m/s).
    pub v_exit: f64,
    /// Speed limit of the segment's run (m/s).
    pub v_limit: f64,
    /// Path dynamics of the segment's run.
    pub dynamics: Dynamics,
    /// Duration of the motion (s).
    pub duration_s: f64,
    /// Standing time after the motion: the in-position wait at an exact stop (s).
    pub wait_s: f64,
    /// The run's profile this segment's motion is a part of.
    pub slice: ProfileSlice,
}

/// Where a segment lies in the speed profile of its run (see `runs`): the profile's length
/// and end speeds, and the distance and time from its start to the segment's start. A
/// segment planned alone is the whole of its profile.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProfileSlice {
    /// The run's length (m).
    pub run_length_m: f64,
    /// Speed at the run's start (m/s).
    pub run_v_entry: f64,
    /// Speed at the run's end (m/s).
    pub run_v_exit: f64,
    /// Distance from the run's start to the segment's start (m).
    pub s_offset_m: f64,
    /// Time from the run's start to the segment's start (s).
    pub t_offset_s: f64,
}

/// A segment's motion: its run's profile seen from the segment's start.
#[derive(Debug, Clone, Copy)]
pub struct SegmentMotion {
    profile: SegmentProfile,
    s_offset_m: f64,
    t_offset_s: f64,
}

impl SegmentMotion {
    /// Distance along the segment (m), path speed (m/s) and path acceleration (m/s²) at
    /// `tau` seconds after the segment's start.
    pub fn eval(&self, tau: f64) -> (f64, f64, f64) {
        let (s, v, a) = self.profile.eval(tau + self.t_offset_s);
        (s - self.s_offset_m, v, a)
    }
}

impl SegmentPlan {
    /// Time from this segment's start to the next one's (s).
    pub(crate) fn span_s(&self) -> f64 {
        self.duration_s + self.wait_s
    }

    /// Rebuilds the motion (cheap; profiles are not stored, to keep plans small).
    pub fn motion(&self) -> SegmentMotion {
        SegmentMotion {
            profile: SegmentProfile::plan(
                self.slice.run_v_entry,
                self.slice.run_v_exit,
                self.v_limit,
                self.slice.run_length_m,
                self.dynamics,
            ),
            s_offset_m: self.slice.s_offset_m,
            t_offset_s: self.slice.t_offset_s,
        }
    }

    /// The motion of this segment when `previous` is the one before it: the same profile
    /// seen from a later offset while both lie in one run (a run's members follow each
    /// other, and only its first starts at offset zero), else rebuilt.
    pub(crate) fn motion_after(&self, previous: &SegmentMotion) -> SegmentMotion {
        if self.slice.s_offset_m > 0.0 {
            SegmentMotion {
                s_offset_m: self.slice.s_offset_m,
                t_offset_s: self.slice.t_offset_s,
                ..*previous
            }
        } else {
            self.motion()
        }
    }
}

/// A planned program: the path and the timing of each segment.
#[derive(Debug, Clone)]
pub struct Plan {
    /// The path (dwells included).
    pub segments: Vec<Segment>,
    /// One plan per segment.
    pub plans: Vec<SegmentPlan>,
    /// Total time (s).
    pub total_time_s: f64,
    /// Planner warnings (clamped feeds).
    pub warnings: Vec<Warning>,
    /// The settings used.
    pub config: PlanConfig,
}

impl Plan {
    /// Total path length (m), rapids included.
    pub(crate) fn path_length_m(&self) -> f64 {
        self.plans.iter().map(|p| p.length_m).sum()
    }

    /// The program line whose block runs (or waits) at `t_s`; the last one after the end.
    pub(crate) fn line_at(&self, t_s: f64) -> Option<u32> {
        let after = self.plans.partition_point(|p| p.t_start_s <= t_s);
        self.segments.get(after.saturating_sub(1)).map(|s| s.line)
    }

    /// The same motion under another in-position check (another gain, another window),
    /// each segment's estimated wait lengthened by `extra_wait_s[i]` (shortened when
    /// negative, never below zero; missing entries are zero): only the waits, and with them
    /// the start times, change.
    pub(crate) fn with_waits(&self, in_position: Option<InPosition>, extra_wait_s: &[f64]) -> Plan {
        let mut p = self.clone();
        p.config.in_position = in_position;
        let mut t = 0.0;
        for i in 0..p.plans.len() {
            p.plans[i].t_start_s = t;
            let planned = match &in_position {
                Some(ip) if ends_in_exact_stop(&p.segments, i) => {
                    in_position_wait(&p.segments, &p.plans, i, ip)
                }
                _ => 0.0,
            };
            p.plans[i].wait_s = (planned + extra_wait_s.get(i).copied().unwrap_or(0.0)).max(0.0);
            t += p.plans[i].span_s();
        }
        p.total_time_s = t;
        p
    }
}

/// Limits a segment imposes on itself (or a run on its common profile).
#[derive(Debug, Clone, Copy)]
struct SegmentLimits {
    length: f64,
    v_max: f64,
    dynamics: Dynamics,
}

/// Plans a program on a machine.
pub fn plan(program: &Program, limits: &KinematicLimits, config: &PlanConfig) -> Plan {
    plan_segments(program.segments.clone(), limits, config)
}

/// Plans a list of segments.
pub(crate) fn plan_segments(
    segments: Vec<Segment>,
    limits: &KinematicLimits,
    config: &PlanConfig,
) -> Plan {
    let mut warnings = FeedWarnings::default();
    let seg_limits: Vec<SegmentLimits> = segments
        .iter()
        .map(|s| segment_limits(s, limits, config, &mut warnings))
        .collect();
    let runs = runs::form_runs(&segments, &seg_limits, limits, config);
    let mut junction = junction_limits(&segments, &runs, limits, config);
    look_ahead(&segments, &runs, &mut junction);
    let mut plans: Vec<SegmentPlan> = Vec::with_capacity(segments.len());
    let mut t = 0.0;
    for (k, run) in runs.iter().enumerate() {
        let lim = &run.limits;
        let (v_entry, v_exit) = (junction[k], junction[k + 1]);
        let profile = SegmentProfile::plan(v_entry, v_exit, lim.v_max, lim.length, lim.dynamics);
        let (mut s_offset_m, mut t_offset_s) = (0.0, 0.0);
        for i in run.first..=run.last {
            let length_m = seg_limits[i].length;
            let t_end = match segments[i].geometry {
                Geometry::Dwell { seconds } => seconds,
                _ if i == run.last => profile.duration(),
                _ => profile.time_at_distance(s_offset_m + length_m),
            };
            plans.push(SegmentPlan {
                t_start_s: t,
                length_m,
                v_entry: profile.eval(t_offset_s).1,
                v_exit: profile.eval(t_end).1,
                v_limit: lim.v_max,
                dynamics: lim.dynamics,
                duration_s: t_end - t_offset_s,
                wait_s: 0.0,
                slice: ProfileSlice {
                    run_length_m: lim.length,
                    run_v_entry: v_entry,
                    run_v_exit: v_exit,
                    s_offset_m,
                    t_offset_s,
                },
            });
            if let Some(ip) = &config.in_position
                && ends_in_exact_stop(&segments, i)
            {
                plans[i].wait_s = in_position_wait(&segments, &plans, i, ip);
            }
            t += plans[i].span_s();
            s_offset_m += length_m;
            t_offset_s = t_end;
        }
    }
    Plan {
        segments,
        plans,
        total_time_s: t,
        warnings: warnings.finish(),
        config: *config,
    }
}

/// A motion segment the control stops exactly after: when it is in exact-stop mode (as the
/// interpreter marks the rapids of a dialect whose rapids stop), before a dwell or program
/// stop (RS274/NGC: a dwell begins once the axes are in position; a program stop holds
/// them until restarted, at least an exact stop), and at the program's end (the program is
/// done when the axes are in position).
pub(crate) fn ends_in_exact_stop(segments: &[Segment], i: usize) -> bool {
    let seg = &segments[i];
    let before_dwell = segments.get(i + 1).is_some_and(Segment::is_dwell);
    let program_end = i + 1 == segments.len();
    !seg.is_dwell() && (program_end || before_dwell || seg.blend == Blend::ExactStop)
}

/// How long the axes need after segment `i` to come within the window: each axis's lag at
/// the stop from the first-order position loop, e(T) = ∫ v(τ) e^{−Kv (T − τ)} dτ over the
/// last few time constants of motion, then decaying as e^{−Kv t}.
fn in_position_wait(segments: &[Segment], plans: &[SegmentPlan], i: usize, ip: &InPosition) -> f64 {
    let t_stop = plans[i].t_start_s + plans[i].duration_s;
    let mut wait = 0.0f64;
    // A carried axis (infinite gain) arrives with its command.
    let simulated = ip
        .kv_per_s
        .iter()
        .enumerate()
        .filter(|(_, kv)| kv.is_finite());
    for (axis, &kv) in simulated {
        let horizon = 8.0 / kv;
        let mut lag = 0.0;
        let mut j = i;
        loop {
            let (seg, sp) = (&segments[j], &plans[j]);
            let from = (t_stop - horizon - sp.t_start_s).max(0.0);
            if !seg.is_dwell() && sp.duration_s > from {
                let profile = sp.motion();
                let steps = (((sp.duration_s - from) / 1e-3).ceil() as usize).max(1);
                let h = (sp.duration_s - from) / steps as f64;
                for k in 0..steps {
                    let tau = from + (k as f64 + 0.5) * h;
                    let (s, v, _) = profile.eval(tau);
                    let tangent = seg.eval(s.clamp(0.0, sp.length_m), sp.length_m).tangent[axis];
                    lag += tangent * v * (-kv * (t_stop - sp.t_start_s - tau)).exp() * h;
                }
            }
            if j == 0 || sp.t_start_s <= t_stop - horizon {
                break;
            }
            j -= 1;
        }
        if lag.abs() > ip.window_m {
            wait = wait.max((lag.abs() / ip.window_m).ln() / kv);
        }
    }
    wait
}

/// Collects clamped-feed warnings, one per source line, capped.
#[derive(Default)]
struct FeedWarnings {
    list: Vec<Warning>,
    more: usize,
    last_line: u32,
}

impl FeedWarnings {
    const CAP: usize = 20;

    fn clamped(&mut self, line: u32, feed: f64, limit: f64, axis: char) {
        if line == self.last_line {
            return;
        }
        self.last_line = line;
        if self.list.len() == Self::CAP {
            self.more += 1;
            return;
        }
        self.list.push(Warning {
            line,
            message: format!(
                "programmed feed {:.0} mm/min exceeds what the {axis} axis allows on this move; \
                 clamped to {:.0} mm/min",
                mm_per_min_from_m_per_s(feed),
                mm_per_min_from_m_per_s(limit)
            ),
        });
    }

    fn finish(mut self) -> Vec<Warning> {
        if self.more > 0 {
            self.list.push(Warning {
                line: 0,
                message: format!("{} more moves had their feed clamped", self.more),
            });
        }
        self.list
    }
}

const AXIS_NAMES: [char; 3] = ['X', 'Y', 'Z'];

fn segment_limits(
    seg: &Segment,
    limits: &KinematicLimits,
    config: &PlanConfig,
    warnings: &mut FeedWarnings,
) -> SegmentLimits {
    let config = &config.for_segment(seg);
    let length = seg.length_m();
    let mut caps = Caps {
        seg,
        limits,
        warnings,
        v_max: seg.feed_m_per_s,
        accel: f64::INFINITY,
        jerk: f64::INFINITY,
    };
    match seg.geometry {
        Geometry::Dwell { .. } => {}
        Geometry::Line => {
            for i in 0..3 {
                let share = (seg.end_m[i] - seg.start_m[i]).abs() / length;
                caps.axis_share(i, share);
            }
        }
        Geometry::Arc(arc) => {
            let [first, second, normal] = seg.plane().axes();
            let f_plane = arc.in_plane_length_m() / length;
            if f_plane > 1e-12 {
                caps.arc_plane([first, second], f_plane, arc.min_radius_m(), config);
            }
            caps.axis_share(normal, seg.normal_travel_m().abs() / length);
        }
    }
    let accel = caps.accel.min(config.path_dynamics.accel);
    let jerk = caps.jerk.min(config.path_dynamics.jerk);
    let dynamics = match config.profile {
        ProfileKind::Ideal => Dynamics {
            accel: f64::INFINITY,
            jerk: f64::INFINITY,
        },
        ProfileKind::Trapezoid => Dynamics {
            accel,
            jerk: f64::INFINITY,
        },
        ProfileKind::SCurve => Dynamics { accel, jerk },
    };
    SegmentLimits {
        length,
        v_max: caps.v_max,
        dynamics,
    }
}

/// A segment's speed, acceleration and jerk caps as the axes' limits lower them.
struct Caps<'a> {
    seg: &'a Segment,
    limits: &'a KinematicLimits,
    warnings: &'a mut FeedWarnings,
    v_max: f64,
    accel: f64,
    jerk: f64,
}

impl Caps<'_> {
    /// The axis's speed limit for the segment's motion (rapid or feed).
    fn axis_speed(&self, i: usize) -> f64 {
        match self.seg.motion {
            Motion::Rapid => self.limits.axes[i].rapid_m_per_s,
            Motion::Feed => self.limits.axes[i].max_feed_m_per_s,
        }
    }

    /// Lowers the speed to `cap`, warning where that cuts the programmed feed.
    fn clamp_speed(&mut self, cap: f64, axis: usize) {
        if cap < self.v_max {
            let seg = self.seg;
            if seg.motion == Motion::Feed && seg.feed_m_per_s > cap {
                self.warnings
                    .clamped(seg.line, seg.feed_m_per_s, cap, AXIS_NAMES[axis]);
            }
            self.v_max = cap;
        }
    }

    /// Axis `i` carries `share` of the path's motion: its limits over that share.
    fn axis_share(&mut self, i: usize, share: f64) {
        if share > 1e-12 {
            let axis = self.limits.axes[i];
            self.clamp_speed(self.axis_speed(i) / share, i);
            self.accel = self.accel.min(axis.accel_m_per_s2 / share);
            self.jerk = self.jerk.min(axis.jerk_m_per_s3 / share);
        }
    }

    /// An arc's part in its plane (the axes `plane`), `f_xy` of the path's motion, on the
    /// smallest radius `r`: the slower axis's speed, the centripetal acceleration within its
    /// share of the limit and, with jerk limits, the rotating acceleration's jerk.
    fn arc_plane(&mut self, plane: [usize; 2], f_xy: f64, r: f64, config: &PlanConfig) {
        let [x, y] = plane.map(|i| self.limits.axes[i]);
        let a_xy = x.accel_m_per_s2.min(y.accel_m_per_s2);
        let j_xy = x.jerk_m_per_s3.min(y.jerk_m_per_s3);
        let eta = config.arc_normal_share;
        let (vx, vy) = (self.axis_speed(plane[0]), self.axis_speed(plane[1]));
        let (axis, v_axis) = if vx <= vy {
            (plane[0], vx)
        } else {
            (plane[1], vy)
        };
        self.clamp_speed(v_axis / f_xy, axis);
        if config.profile != ProfileKind::Ideal {
            // Centripetal acceleration (v f_xy)²/R within η·a.
            self.v_max = self.v_max.min((eta * a_xy * r).sqrt() / f_xy);
        }
        self.accel = self.accel.min((1.0 - eta * eta).sqrt() * a_xy / f_xy);
        if config.profile == ProfileKind::SCurve {
            // The rotating centripetal acceleration's jerk v³/R² within j/4.
            self.v_max = self.v_max.min((0.25 * j_xy * r * r).cbrt() / f_xy);
            // The cross term 3·v·a_t/R within j/4, and the tangential jerk within j/2.
            self.accel = self
                .accel
                .min(0.25 * j_xy * r / (3.0 * self.v_max.max(1e-12) * f_xy * f_xy));
            self.jerk = self.jerk.min(0.5 * j_xy / f_xy);
        }
    }
}

/// Speed limit at each run boundary: index k is the start of run k; the last entry is the
/// program end.
fn junction_limits(
    segments: &[Segment],
    runs: &[runs::Run],
    limits: &KinematicLimits,
    config: &PlanConfig,
) -> Vec<f64> {
    let n = runs.len();
    let mut v = vec![0.0; n + 1];
    for k in 1..n {
        let (a, b) = (&segments[runs[k - 1].last], &segments[runs[k].first]);
        if a.is_dwell() || b.is_dwell() || a.blend == Blend::ExactStop {
            continue;
        }
        let cap = runs[k - 1].limits.v_max.min(runs[k].limits.v_max);
        v[k] = if config.profile == ProfileKind::Ideal {
            cap
        } else {
            // A smooth junction between runs whose limits differ: the curve's own limit;
            // otherwise a corner.
            let through = runs::smooth_junction_speed(segments, runs[k].first, limits, config)
                .unwrap_or_else(|| corner_speed(a, b, limits, config));
            cap.min(through)
        };
    }
    v
}

/// The corner rules of the module documentation for the junction between `a` and `b`.
fn corner_speed(a: &Segment, b: &Segment, limits: &KinematicLimits, config: &PlanConfig) -> f64 {
    let config = &config.for_junction(a, b);
    let (t_in, t_out) = (a.end_tangent(), b.start_tangent());
    let jerk_limited = config.profile == ProfileKind::SCurve;
    let t = config.cycle_s;
    let mut v = f64::INFINITY;
    // Per-axis velocity jump within one interpolation cycle.
    for i in 0..3 {
        let jump = (t_out[i] - t_in[i]).abs();
        if jump > 1e-12 {
            let ax = &limits.axes[i];
            let budget = if jerk_limited {
                ax.jerk_m_per_s3 * t * t
            } else {
                ax.accel_m_per_s2 * t
            };
            v = v.min(budget / jump);
        }
    }
    // grbl's junction deviation: a virtual arc tangent to both moves that stays within the
    // tolerance of the corner.
    let tolerance = match a.blend {
        Blend::Continuous {
            tolerance_m: Some(tol),
            ..
        } => tol,
        _ => config.default_blend_tolerance_m,
    };
    let cos_inner = -dot3(t_in, t_out);
    if cos_inner > -1.0 + 1e-12 {
        let sin_half = (0.5 * (1.0 - cos_inner)).max(0.0).sqrt();
        let a_min = limits
            .axes
            .iter()
            .map(|l| l.accel_m_per_s2)
            .fold(f64::INFINITY, f64::min);
        if sin_half < 1.0 - 1e-12 {
            v = v.min((a_min * tolerance * sin_half / (1.0 - sin_half)).sqrt());
        }
    }
    // S-curves: the acceleration step of a curvature jump within one cycle's jerk.
    if jerk_limited {
        let (k_in, k_out) = (a.end_curvature(), b.start_curvature());
        for i in 0..3 {
            let step = (k_out[i] - k_in[i]).abs();
            if step > 1e-12 {
                v = v.min((limits.axes[i].jerk_m_per_s3 * t / step).sqrt());
            }
        }
    }
    v
}

/// Backward then forward pass over the runs: every junction speed reachable from its
/// neighbours.
fn look_ahead(segments: &[Segment], runs: &[runs::Run], v: &mut [f64]) {
    let n = runs.len();
    for k in (0..n).rev() {
        let lim = &runs[k].limits;
        if segments[runs[k].first].is_dwell() {
            continue;
        }
        v[k] = v[k].min(reachable_speed(v[k + 1], lim.length, lim.dynamics));
    }
    for k in 0..n {
        let lim = &runs[k].limits;
        if segments[runs[k].first].is_dwell() {
            continue;
        }
        v[k + 1] = v[k + 1].min(reachable_speed(v[k], lim.length, lim.dynamics));
    }
}
