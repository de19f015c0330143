//! What a record's commands show of the control's interpolator — each axis's peak
//! velocity, acceleration and jerk and the path's peak speed — and, where the record shows
//! the control held at one, that peak as the identified machine's planning limit, so that
//! `check` plans the next program about as that control did.
//!
//! A peak is a limit only where the axis stayed at it, flat, in several stretches of the
//! record, and the template's own planner would have asked for more of it in the same
//! segments of the program, its commands read as the record's are: the moves demanded more
//! than the machine gave. A circle at one feed never asks its axes for more than its radius
//! needs; written as the limit, that peak would make every other program look gentler than
//! the machine runs it.

use serde::Serialize;

use crate::compare::Context;
use crate::machine::{AxisName, Limits, MachineConfig};
use crate::numeric::units::mm_per_min_from_m_per_s;
use crate::path::{Geometry, Motion, Segment};
use crate::trace::recorded::{DERIVATIVE_HALF_WIDTH_S, local_derivatives};

/// The interpolator's peaks in a record, per axis: X, Y, and Z where the record holds Z's
/// commands and the template simulates Z (where a limit found can be written).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Interpolator {
    /// The axes read, in the order of the per-axis lists below (X, Y, and Z where read).
    #[serde(skip)]
    pub axes: Vec<AxisName>,
    /// Peak path speed (mm/min), in space where Z is read.
    pub path_speed_mm_per_min: f64,
    /// Per axis: peak velocity (mm/min).
    pub velocity_mm_per_min: Vec<f64>,
    /// Per axis: peak velocity (mm/min) where the program moves at its feed.
    pub feed_mm_per_min: Vec<f64>,
    /// Per axis: peak velocity (mm/min) in the program's rapids.
    pub rapid_mm_per_min: Vec<f64>,
    /// Per axis, the template's limits the peaks are held against: the feed (mm/min), the
    /// rapid rate (mm/min) and the acceleration (m/s²).
    pub template_feed_mm_per_min: Vec<f64>,
    /// See `template_feed_mm_per_min`.
    pub template_rapid_mm_per_min: Vec<f64>,
    /// See `template_feed_mm_per_min`.
    pub template_accel_m_per_s2: Vec<f64>,
    /// Peak acceleration (m/s²).
    pub accel_m_per_s2: Vec<f64>,
    /// Peak jerk (m/s³): the highest level the acceleration's rate keeps for a plateau's
    /// length (`PLATEAU_S`, at least `PLATEAU_SAMPLES`), so that the short spikes of a
    /// stepped acceleration (a trapezoidal interpolator has no jerk limit) and of rounded
    /// positions are not taken for the control's jerk, however short the jerk's phases
    /// are against the record.
    pub jerk_m_per_s3: Vec<f64>,
    /// Per axis, the peak acceleration (m/s²) the template's planner gives the segments of
    /// the program the stretch compared covers: what those moves demanded. Its commands are
    /// read as the record's are, over the same window.
    pub demanded_accel_m_per_s2: Vec<f64>,
    /// The same for the jerk (m/s³): the planner's largest over those segments, however
    /// briefly it asks it.
    pub demanded_jerk_m_per_s3: Vec<f64>,
    /// Whether the record shows the acceleration held at its peak (flat for `PLATEAU_S`,
    /// in `PLATEAUS` stretches, while the path speed ramped with the axis), each in a
    /// segment whose moves demanded more: the control's limit, not only what these moves
    /// needed.
    pub accel_limited: Vec<bool>,
    /// Whether it shows the jerk held at its peak.
    pub jerk_limited: Vec<bool>,
}

/// How long a peak must be held to count as the control's limit (s), how close to it, and
/// in how many separate stretches.
const PLATEAU_S: f64 = 0.005;
const PLATEAU_SHARE: f64 = 0.98;
const PLATEAUS: usize = 2;

/// The fewest samples a plateau spans however coarse the sampling: one sample is a spike,
/// and two can be a step. A step of the acceleration (or speed) is fitted over a window
/// and differenced over one as wide ([`derive`]): at a coarse rate (400 Hz and below) its
/// rate reads as a trapezoid whose top is under two samples wide, so two neighbours can
/// share one level — a jerk "held" where the interpolator has no jerk limit at all. Three
/// in a row are a plateau no step makes.
const PLATEAU_SAMPLES: usize = 3;

/// How much the path's counterpart must change over a plateau, as a share of the axis's
/// own change, for the plateau to be the interpolator ramping at its limit: along a line
/// the path speed changes at least as much as any of its axes' speeds, while a circle's
/// centripetal peak comes at constant path speed, whatever the limit. Judged on the axis's
/// own change, never on the record's top speed: a fast move of another axis elsewhere in
/// the record does not hide this axis's ramps.
const RAMPING_SHARE: f64 = 0.5;

/// How much more than the axis's own change the path's may be for the plateau to be this
/// axis's limit (√2, a hair over for rounding): the axis then carries at least half of the
/// path's change in squares, more than any other axis. Along a line every axis ramps with
/// the path, each by its direction's share, so the plateau of an axis that moves less than
/// another is that other axis's limit scaled down (a line 60 mm in X and 20 mm in Y held at
/// X's 0.5 m/s² gives Y a flat 0.17 m/s²), not its own. An axis whose own limit binds
/// while it carries the smaller share is missed by this — its template's limit is kept —,
/// never written wrong.
const DOMINANT_PATH_SHARE: f64 = std::f64::consts::SQRT_2 * 1.02;

/// One axis's series judged for a plateau: `held` (its acceleration, or the rate of it)
/// and `own` the series `held` is the rate of (its velocity, or its acceleration), `path`
/// the path's counterpart of `own` (the path speed, or its rate), `demand` the largest the
/// template's planner asks of `held` in the segment of the program each sample belongs to
/// (its commands read as the record's, over the same window) and `given` the largest the
/// record gave in that segment, all sampled every `dt`.
struct Series<'a> {
    held: &'a [f64],
    own: &'a [f64],
    path: &'a [f64],
    demand: &'a [f64],
    given: &'a [f64],
    dt: f64,
}

/// Whether `s.held` stays flat at `peak` — within `PLATEAU_SHARE` of it either way — for
/// `PLATEAU_S` (and at least `PLATEAU_SAMPLES`) in `PLATEAUS` separate stretches across
/// which the path ramped with the axis, each in a segment whose moves demanded more than
/// the record gave there (and more than the peak). A spike through the peak's level (a
/// stepped acceleration's rate) is not flat there; where the planner asks no more in the
/// same segment than the record gave, that is what the move needed, not a limit.
///
/// Every plateau's length of every flat run is judged, not only the first: a run that starts
/// where the demand or the path's ramp is not yet shown (a segment's first samples) counts
/// where further on it is, once per run.
fn held_at(s: &Series, peak: f64) -> bool {
    let need = plateau_samples(s.dt);
    let change = |v: &[f64], k: usize| match (v.get(k + 1 - need), v.get(k)) {
        (Some(a), Some(b)) => (b - a).abs(),
        _ => 0.0,
    };
    let flat = |x: f64| x.abs() >= PLATEAU_SHARE * peak && x.abs() * PLATEAU_SHARE <= peak;
    let demanded =
        |k: usize| (k + 1 - need..=k).all(|j| peak.max(s.given[j]) < PLATEAU_SHARE * s.demand[j]);
    let ramping = |k: usize| {
        let (own, path) = (change(s.own, k), change(s.path, k));
        own > 0.0 && path >= RAMPING_SHARE * own && path <= DOMINANT_PATH_SHARE * own
    };
    let (mut run, mut counted, mut stretches) = (0usize, false, 0usize);
    for (k, x) in s.held.iter().enumerate() {
        run = if peak > 0.0 && flat(*x) { run + 1 } else { 0 };
        counted &= run > 0;
        if !counted
            && run >= need
            && k < s.demand.len().min(s.given.len())
            && demanded(k)
            && ramping(k)
        {
            counted = true;
            stretches += 1;
        }
    }
    stretches >= PLATEAUS
}

/// The samples a plateau spans at a sampling step of `dt` (s).
fn plateau_samples(dt: f64) -> usize {
    ((PLATEAU_S / dt).ceil() as usize).max(PLATEAU_SAMPLES)
}

/// The highest magnitude `v` keeps over `need` samples in a row (the largest of the
/// windows' least magnitudes); where `v` is shorter, its least magnitude.
fn held_peak(v: &[f64], need: usize) -> f64 {
    let need = need.clamp(1, v.len().max(1));
    // The window's least magnitude by a queue of candidates, increasing from its front.
    let mut queue = std::collections::VecDeque::<usize>::new();
    let mut best = 0.0f64;
    for (k, x) in v.iter().enumerate() {
        while queue.back().is_some_and(|&j| v[j].abs() >= x.abs()) {
            queue.pop_back();
        }
        queue.push_back(k);
        if queue.front().is_some_and(|&j| j + need <= k) {
            queue.pop_front();
        }
        if k + 1 >= need
            && let Some(&j) = queue.front()
        {
            best = best.max(v[j].abs());
        }
    }
    best
}

/// The largest magnitude in `v`.
fn peak(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

/// The axes whose peaks a record shows: X and Y, and Z where the record holds its commands
/// and `template` simulates it.
fn axes_read(ctx: &Context, template: &MachineConfig) -> Vec<AxisName> {
    let z = ctx.z_comparable(template).is_ok();
    AxisName::BOTH
        .into_iter()
        .chain(z.then_some(AxisName::Z))
        .collect()
}

/// How much jerk (m/s³) the rounding of recorded positions may put into the peaks read:
/// the window the positions are differentiated over widens until a step of their
/// resolution, over its cube, stays below this.
const JERK_FROM_ROUNDING_M_PER_S3: f64 = 0.01;
/// Differences of recorded positions smaller than this (m) are the arithmetic's, not a
/// resolution.
const LEAST_RESOLUTION_M: f64 = 1e-12;
/// How many steps of the smallest size show it to be the positions' resolution.
const RESOLUTION_STEPS: usize = 10;

/// The half-width (s) the recorded positions are differentiated over: the derivative fit's
/// own (wide enough for a 10 kHz record, at least one sample each side), widened where
/// the positions are rounded to a resolution coarse enough that its steps would read as
/// jerk.
fn half_width_s(positions: &[&[f64]], dt: f64) -> f64 {
    let rounding =
        resolution_m(positions).map_or(0.0, |q| (q / JERK_FROM_ROUNDING_M_PER_S3).cbrt());
    DERIVATIVE_HALF_WIDTH_S.max(1.5 * dt).max(rounding)
}

/// The resolution the positions are rounded to (m), where they show one: their smallest
/// step, taken by many of their steps (an encoder's count as the axis creeps). Positions
/// written to more digits than they move by in a sample show none.
fn resolution_m(positions: &[&[f64]]) -> Option<f64> {
    let steps: Vec<f64> = positions
        .iter()
        .flat_map(|p| p.windows(2).map(|w| (w[1] - w[0]).abs()))
        .filter(|d| *d > LEAST_RESOLUTION_M)
        .collect();
    let q = steps.iter().copied().fold(f64::INFINITY, f64::min);
    let at_q = steps.iter().filter(|d| **d < 1.5 * q).count();
    (q.is_finite() && at_q >= RESOLUTION_STEPS.max(steps.len() / 100)).then_some(q)
}

/// One axis's recorded commands differentiated at every sample: velocity (m/s),
/// acceleration (m/s²), and jerk (m/s³) — the acceleration's change across the window it
/// was fitted over, so that a step of it (a trapezoidal interpolator) reads as a spike no
/// wider than the window (at most two samples on its top: see [`PLATEAU_SAMPLES`]), not as
/// a plateau.
struct Derived {
    vel: Vec<f64>,
    acc: Vec<f64>,
    jerk: Vec<f64>,
}

fn derive(pos: &[f64], dt: f64, half: f64) -> Derived {
    let (vel, acc): (Vec<f64>, Vec<f64>) = (0..pos.len())
        .map(|k| local_derivatives(pos, dt, k as f64 * dt, half))
        .unzip();
    let m = ((half / dt).floor() as usize).max(1);
    let jerk = (0..acc.len())
        .map(|k| match (k.checked_sub(m), acc.get(k + m)) {
            (Some(lo), Some(hi)) => (hi - acc[lo]) / (2.0 * m as f64 * dt),
            _ => 0.0,
        })
        .collect();
    Derived { vel, acc, jerk }
}

/// The path speed over the axes' `vel` and `acc` and its rate (the path's acceleration
/// along its direction, v·a/|v|, or |a| where the path stands), per sample.
fn path_speed_and_rate(axes: &[(&[f64], &[f64])]) -> (Vec<f64>, Vec<f64>) {
    let n = axes.iter().map(|a| a.0.len()).min().unwrap_or(0);
    (0..n)
        .map(|k| {
            let (vv, va, aa) = axes.iter().fold((0.0, 0.0, 0.0), |(vv, va, aa), a| {
                let (v, acc) = (a.0[k], a.1[k]);
                (vv + v * v, va + v * acc, aa + acc * acc)
            });
            let speed: f64 = vv.sqrt();
            let along = if speed > 1e-9 { va / speed } else { aa.sqrt() };
            (speed, along)
        })
        .unzip()
}

/// The record's samples compared (first to last), and for each the segment of the program
/// it belongs to (none past the commands' end).
fn stretch(ctx: &Context, offset_s: f64) -> (std::ops::RangeInclusive<usize>, Vec<Option<usize>>) {
    let (first, last) = match (ctx.samples.first(), ctx.samples.last()) {
        (Some(&a), Some(&b)) => (a, b),
        _ => (0, 0),
    };
    let c = &ctx.commands;
    let segments = (first..=last)
        .map(|i| {
            let t = ctx.prog_time(i, offset_s);
            let k = (t / c.dt_s).round().clamp(0.0, (c.len().max(1) - 1) as f64) as usize;
            c.segment.get(k).map(|&s| s as usize)
        })
        .collect();
    (first..=last, segments)
}

/// Whether the program moves at its feed in `segment` (else at its rapid rate, or stands
/// after one): the move's own kind, as the program gives it.
fn at_feed(ctx: &Context, segment: Option<usize>) -> bool {
    segment
        .and_then(|s| ctx.plan.segments.get(s))
        .is_none_or(|s| s.motion == Motion::Feed)
}

/// Whether `segment` moves `axis`: a line or a helix whose end differs from its start
/// along it, or an arc in a plane holding it.
fn moves(segment: &Segment, axis: AxisName) -> bool {
    let a = axis.index();
    let along = (segment.end_m[a] - segment.start_m[a]).abs() > MOVED_M;
    match segment.geometry {
        Geometry::Line => along,
        Geometry::Arc(_) => along || segment.plane.axes()[..2].contains(&a),
        Geometry::Dwell { .. } => false,
    }
}

/// A move shorter than this along an axis does not move it (m).
const MOVED_M: f64 = 1e-9;

/// Per sample of the stretch, the segment of the program `axis` moves in there: the
/// segment the sample is placed on where that moves the axis; else the last one before it
/// that does (the axis still finishing that move: a rapid of Z before the plane's path
/// joins the program is placed on the first block of that path), or the first after.
/// Its move's kind (rapid or feed) is the one the axis's speed there is counted under.
fn axis_segments(ctx: &Context, axis: AxisName, placed: &[Option<usize>]) -> Vec<Option<usize>> {
    let segs = &ctx.plan.segments;
    // Per segment of the program, the one the axis moves in there, by one pass each way.
    let mut last = None;
    let before: Vec<Option<usize>> = (0..segs.len())
        .map(|j| {
            last = if moves(&segs[j], axis) { Some(j) } else { last };
            last
        })
        .collect();
    let mut next = None;
    let mut after: Vec<Option<usize>> = (0..segs.len())
        .rev()
        .map(|j| {
            next = if moves(&segs[j], axis) { Some(j) } else { next };
            next
        })
        .collect();
    after.reverse();
    placed
        .iter()
        .map(|&p| {
            let s = p.filter(|&s| s < segs.len())?;
            before[s].or(after[s]).or(Some(s))
        })
        .collect()
}

/// The record's own commands of `axes`, over its whole length.
fn recorded<'m>(ctx: &'m Context, axes: &[AxisName]) -> Vec<&'m [f64]> {
    let m = ctx.measured;
    let empty: &[f64] = &[];
    axes.iter()
        .map(|&a| match (a, &m.commands) {
            (AxisName::Z, _) => m.z_cmd_m.as_deref().unwrap_or(empty),
            (_, Some(c)) => c[a.index()].as_slice(),
            (_, None) => empty,
        })
        .collect()
}

/// The half-width (s) the record's `positions` are differentiated over in the stretch
/// `range` (see [`half_width_s`]).
fn stretch_half_width_s(
    positions: &[&[f64]],
    range: &std::ops::RangeInclusive<usize>,
    dt: f64,
) -> f64 {
    let cut: Vec<&[f64]> = positions
        .iter()
        .map(|p| p.get(range.clone()).unwrap_or_default())
        .collect();
    half_width_s(&cut, dt)
}

/// The recorded `positions` differentiated over `half` (s) over the whole record (so that
/// the stretch's ends are fitted on both sides), cut to the stretch `range`.
fn derive_stretch(
    positions: &[&[f64]],
    range: std::ops::RangeInclusive<usize>,
    dt: f64,
    half: f64,
) -> Vec<Derived> {
    let len = positions.iter().map(|p| p.len()).min().unwrap_or(0);
    let range = *range.start()..(range.end() + 1).min(len);
    positions
        .iter()
        .map(|p| {
            let d = derive(&p[..len], dt, half);
            let cut = |v: Vec<f64>| v.get(range.clone()).unwrap_or_default().to_vec();
            Derived {
                vel: cut(d.vel),
                acc: cut(d.acc),
                jerk: cut(d.jerk),
            }
        })
        .collect()
}

/// What the template's planner demands of one axis, per segment of the program: its largest
/// acceleration (m/s²) and jerk (m/s³) there, its commands read as the record's are
/// (differentiated over the same half-width, the jerk over the same window).
struct Demand {
    accel: Vec<f64>,
    jerk: Vec<f64>,
}

/// Per axis of `axes`, what the template's planner (the context's plan) demands of it,
/// its commands differentiated over `half` (s) as the record's are.
fn demands(ctx: &Context, axes: &[AxisName], half: f64) -> Vec<Demand> {
    let planned = crate::plan::sample(&ctx.plan);
    let n = ctx.plan.segments.len();
    axes.iter()
        .map(|&a| {
            let d = derive(&planned.axis(a).pos_m, planned.dt_s, half);
            let mut demand = Demand {
                accel: vec![0.0; n],
                jerk: vec![0.0; n],
            };
            for (k, &s) in planned.segment.iter().enumerate() {
                if let (Some(acc), Some(jerk)) = (demand.accel.get_mut(s as usize), d.jerk.get(k)) {
                    *acc = acc.max(d.acc[k].abs());
                    demand.jerk[s as usize] = demand.jerk[s as usize].max(jerk.abs());
                }
            }
            demand
        })
        .collect()
}

/// The peak of `vel` (mm/min) over the samples whose `feed` is `on_feed` (the program
/// at its feed, or in a rapid).
fn peak_speed(vel: &[f64], feed: &[bool], on_feed: bool) -> f64 {
    let v: Vec<f64> = vel
        .iter()
        .zip(feed.iter().chain(std::iter::repeat(&true)))
        .filter(|(_, f)| **f == on_feed)
        .map(|(v, _)| *v)
        .collect();
    mm_per_min_from_m_per_s(peak(&v))
}

/// Per sample of the stretch, the value of `per_segment` for the segment it belongs to.
fn on_samples(per_segment: &[f64], segments: &[Option<usize>]) -> Vec<f64> {
    segments
        .iter()
        .map(|s| s.and_then(|s| per_segment.get(s)).copied().unwrap_or(0.0))
        .collect()
}

/// Per sample of the stretch, the largest magnitude of `v` over the samples in the same
/// segment (of those on `segments`).
fn segment_peaks(v: &[f64], segments: &[Option<usize>]) -> Vec<f64> {
    let n = segments.iter().flatten().max().map_or(0, |s| s + 1);
    let mut per_segment = vec![0.0f64; n];
    for (x, s) in v.iter().zip(segments) {
        if let Some(m) = s.and_then(|s| per_segment.get_mut(s)) {
            *m = m.max(x.abs());
        }
    }
    on_samples(&per_segment, segments)
}

/// The peaks of the record's own commands over the stretch compared (differentiated at the
/// record's own rate), and what `template`'s planner demands of the same segments.
pub(crate) fn read(ctx: &Context, template: &MachineConfig, offset_s: f64) -> Interpolator {
    let read = axes_read(ctx, template);
    let dt = ctx.measured.dt_s;
    let positions = recorded(ctx, &read);
    let (range, placed) = stretch(ctx, offset_s);
    let segments: Vec<Vec<Option<usize>>> = read
        .iter()
        .map(|&a| axis_segments(ctx, a, &placed))
        .collect();
    let half = stretch_half_width_s(&positions, &range, dt);
    let derived = derive_stretch(&positions, range, dt, half);
    let demands = demands(ctx, &read, half);
    let accel: Vec<f64> = derived.iter().map(|d| peak(&d.acc)).collect();
    // The jerk's peak over its plateaus: a percentile over every sample missed the jerk's
    // phases where long moves at constant feed outnumber them.
    let jerks: Vec<f64> = derived
        .iter()
        .map(|d| held_peak(&d.jerk, plateau_samples(dt)))
        .collect();
    // The path over the axes read (a plunge of Z alone ramps it too).
    let pairs: Vec<(&[f64], &[f64])> = derived.iter().map(|d| (&d.vel[..], &d.acc[..])).collect();
    let (speed, along) = path_speed_and_rate(&pairs);
    let held = |i: usize, jerk: bool| {
        let (d, demand, segments) = (&derived[i], &demands[i], &segments[i]);
        let demand = on_samples(if jerk { &demand.jerk } else { &demand.accel }, segments);
        let held = if jerk { &d.jerk } else { &d.acc };
        let s = Series {
            held,
            own: if jerk { &d.acc } else { &d.vel },
            path: if jerk { &along } else { &speed },
            demand: &demand,
            given: &segment_peaks(held, segments),
            dt,
        };
        held_at(&s, if jerk { jerks[i] } else { accel[i] })
    };
    let speeds = |on_feed: bool| -> Vec<f64> {
        derived
            .iter()
            .zip(&segments)
            .map(|(d, segments)| {
                let feed: Vec<bool> = segments.iter().map(|&s| at_feed(ctx, s)).collect();
                peak_speed(&d.vel, &feed, on_feed)
            })
            .collect()
    };
    let demanded = |jerk: bool| -> Vec<f64> {
        demands
            .iter()
            .zip(&segments)
            .map(|(d, s)| peak(&on_samples(if jerk { &d.jerk } else { &d.accel }, s)))
            .collect()
    };
    let limits: Vec<&Limits> = read.iter().map(|&a| &template.axis(a).limits).collect();
    Interpolator {
        path_speed_mm_per_min: mm_per_min_from_m_per_s(peak(&speed)),
        velocity_mm_per_min: derived
            .iter()
            .map(|d| mm_per_min_from_m_per_s(peak(&d.vel)))
            .collect(),
        feed_mm_per_min: speeds(true),
        rapid_mm_per_min: speeds(false),
        accel_limited: (0..read.len()).map(|i| held(i, false)).collect(),
        jerk_limited: (0..read.len()).map(|i| held(i, true)).collect(),
        accel_m_per_s2: accel,
        jerk_m_per_s3: jerks,
        demanded_accel_m_per_s2: demanded(false),
        demanded_jerk_m_per_s3: demanded(true),
        template_feed_mm_per_min: limits.iter().map(|l| l.max_feed_mm_per_min).collect(),
        template_rapid_mm_per_min: limits.iter().map(|l| l.rapid_mm_per_min).collect(),
        template_accel_m_per_s2: limits.iter().map(|l| l.max_accel_m_per_s2).collect(),
        axes: read,
    }
}

/// How far beyond a template's limit a record's peak must go to disprove it: the peaks are
/// fitted and carry the fit's rounding.
const BEYOND_SHARE: f64 = 1.01;

/// Whether a record's `peak` goes beyond the template's `limit`.
pub(crate) fn beyond(peak: f64, limit: f64) -> bool {
    peak > BEYOND_SHARE * limit
}

/// The peaks as the machine's acceleration and jerk limits where the record shows them held
/// (rounded up to three significant digits); elsewhere the moves did not reach the control's
/// limits and the template's stay — except where the record went beyond them: a limit the
/// record disproves is raised to its peak (speeds at feed and at rapid, and the
/// acceleration).
pub(crate) fn write_limits(machine: &mut MachineConfig, interpolator: &Interpolator) {
    let i = interpolator;
    for (k, &axis) in i.axes.iter().enumerate() {
        let limits = &mut machine.axis_mut(axis).limits;
        if i.accel_limited[k] || beyond(i.accel_m_per_s2[k], limits.max_accel_m_per_s2) {
            limits.max_accel_m_per_s2 = round_up(i.accel_m_per_s2[k]);
        }
        if i.jerk_limited[k] {
            limits.max_jerk_m_per_s3 = round_up(i.jerk_m_per_s3[k]);
        }
        if beyond(i.feed_mm_per_min[k], limits.max_feed_mm_per_min) {
            limits.max_feed_mm_per_min = round_up(i.feed_mm_per_min[k]);
        }
        if beyond(i.rapid_mm_per_min[k], limits.rapid_mm_per_min) {
            limits.rapid_mm_per_min = round_up(i.rapid_mm_per_min[k]);
        }
        // A rapid no slower than the fastest feed, as every control has it.
        limits.rapid_mm_per_min = limits.rapid_mm_per_min.max(limits.max_feed_mm_per_min);
    }
}

/// Rounded up to three significant digits.
fn round_up(v: f64) -> f64 {
    let e = 10f64.powf(v.abs().log10().floor() - 2.0);
    // A peak read a rounding above a round value is that value.
    (v / e * (1.0 - 1e-9)).ceil() * e
}

#[cfg(test)]
mod tests {
    use super::{Series, derive, half_width_s, held_at, held_peak, plateau_samples, round_up};

    /// A trapezoidal ramp of one axis: `a` (m/s²) for `ramp` samples from rest, cruise,
    /// and the same down, twice; its velocity and acceleration every `dt`.
    fn two_trapezoids(a: f64, ramp: usize, dt: f64) -> (Vec<f64>, Vec<f64>) {
        let one: Vec<f64> = [vec![0.0; 5], vec![a; ramp], vec![0.0; 10], vec![-a; ramp]].concat();
        let acc = [one.clone(), one, vec![0.0; 5]].concat();
        let vel = acc
            .iter()
            .scan(0.0, |v, x| {
                *v += x * dt;
                Some(*v)
            })
            .collect();
        (vel, acc)
    }

    #[test]
    fn a_limit_is_a_peak_held_in_several_stretches_where_more_was_demanded() {
        let dt = 1e-3;
        // Two moves ramping at 0.5 m/s² for 20 ms, where the planner would have asked
        // for 2: held. Along a line the path speed is the axis's own over the cosine of
        // its angle: here the axis moves alone.
        let (vel, acc) = two_trapezoids(0.5, 20, dt);
        let (two, half) = (vec![2.0; acc.len()], vec![0.5; acc.len()]);
        let along = |path| Series {
            held: &acc,
            own: &vel,
            path,
            demand: &two,
            given: &half,
            dt,
        };
        assert!(held_at(&along(&vel), 0.5));
        // On a line at 30° to the axis: the path speed 1/cos 30° = 1.155 times the axis's,
        // the other axis moving half as fast as the path: this axis carries the ramp.
        let at_30: Vec<f64> = vel.iter().map(|v| v / 30f64.to_radians().cos()).collect();
        assert!(held_at(&along(&at_30), 0.5));
        // At 60°: the path speed twice the axis's, the other axis ramping at cos 30° of
        // the path, 1.7 times this one's — its limit held this axis's flat, not this one's.
        let twice: Vec<f64> = vel.iter().map(|v| 2.0 * v).collect();
        assert!(!held_at(&along(&twice), 0.5));
        // The same where the planner gives 0.5 itself: the moves asked no more.
        let s = Series {
            demand: &half,
            ..along(&vel)
        };
        assert!(!held_at(&s, 0.5));
        // Where the record itself gave 2 elsewhere in the same segments (a stepped
        // acceleration's rate passing through the plateau's level): the planner asked no
        // more than the record gave there.
        let s = Series {
            given: &two,
            ..along(&vel)
        };
        assert!(!held_at(&s, 0.5));
        // Where it asks more only where the first ramp is: one stretch, not a limit.
        let first: Vec<f64> = (0..acc.len())
            .map(|k| if k < 30 { 2.0 } else { 0.5 })
            .collect();
        let s = Series {
            demand: &first,
            ..along(&vel)
        };
        assert!(!held_at(&s, 0.5));
        // At constant path speed (a circle's centripetal peaks): not a limit.
        let constant = vec![0.1; vel.len()];
        assert!(!held_at(&along(&constant), 0.5));
        // One stretch only (the first ramp up): not.
        let once: Vec<f64> = acc
            .iter()
            .enumerate()
            .map(|(k, v)| if k < 25 { *v } else { 0.1 })
            .collect();
        let s = Series {
            held: &once,
            ..along(&vel)
        };
        assert!(!held_at(&s, 0.5));
        // A single-sample spike: not.
        let spike: Vec<f64> = (0..60).map(|k| if k == 30 { 0.5 } else { 0.1 }).collect();
        let s = Series {
            held: &spike,
            ..along(&vel)
        };
        assert!(!held_at(&s, 0.5));
        // Ramps at 0.5 are no plateau at 0.25: that level is crossed, not held.
        assert!(!held_at(&along(&vel), 0.25));
    }

    #[test]
    fn a_fast_move_of_another_axis_does_not_hide_a_slow_axis_ramps() {
        // The axis ramps at 0.2 m/s² to 16.7 mm/s (1000 mm/min, 83 ms) twice; elsewhere
        // in the record another axis runs at 10 m/min, the path's top speed. Over a 5 ms
        // plateau the path speed changes by 1 mm/s, 0.6 % of that top: the axis's own
        // change is the measure, and the ramps are the limit.
        let dt = 1e-3;
        let (vel, acc) = two_trapezoids(0.2, 83, dt);
        let mut path = vel.clone();
        path.extend([10.0 / 60.0; 50]);
        let demand = vec![0.3; acc.len()];
        let s = Series {
            held: &acc,
            own: &vel,
            path: &path,
            demand: &demand,
            given: &vec![0.2; acc.len()],
            dt,
        };
        assert!(held_at(&s, 0.2));
    }

    #[test]
    fn at_coarse_sampling_a_plateau_still_needs_two_samples() {
        // Sampled every 20 ms (50 Hz): 5 ms is less than a sample, yet one sample at the
        // peak is no plateau; two are, with the path speed's change across them.
        let dt = 0.02;
        let (vel, acc) = two_trapezoids(0.2, 5, dt);
        let demand = vec![0.3; acc.len()];
        let s = Series {
            held: &acc,
            own: &vel,
            path: &vel,
            demand: &demand,
            given: &vec![0.2; acc.len()],
            dt,
        };
        assert!(held_at(&s, 0.2));
        let spikes: Vec<f64> = (0..40)
            .map(|k| if k % 10 == 3 { 0.2 } else { 0.0 })
            .collect();
        let s = Series { held: &spikes, ..s };
        assert!(!held_at(&s, 0.2));
    }

    #[test]
    fn a_plateau_whose_first_samples_were_not_demanded_counts_further_on() {
        // Each ramp's first three samples lie where the planner asks no more than the
        // record gave (0.5); from the fourth on it asks 2. A plateau is 5 samples at 1 ms:
        // the first window of each ramp is not demanded, the ones after it are.
        let dt = 1e-3;
        let (vel, acc) = two_trapezoids(0.5, 20, dt);
        assert_eq!(plateau_samples(dt), 5);
        let starts = [5, 35, 60, 90];
        let demand: Vec<f64> = (0..acc.len())
            .map(|k| {
                if starts.iter().any(|&s| (s..s + 3).contains(&k)) {
                    0.5
                } else {
                    2.0
                }
            })
            .collect();
        let s = Series {
            held: &acc,
            own: &vel,
            path: &vel,
            demand: &demand,
            given: &vec![0.5; acc.len()],
            dt,
        };
        assert!(held_at(&s, 0.5));
    }

    #[test]
    fn the_jerks_peak_is_its_plateau_however_long_the_record_around_it() {
        // 20 s at 1 kHz; the jerk held at 5 m/s³ for 20 ms four times: 80 of 20 000
        // samples, 0.4 % — below the top half per cent a percentile would read. Single
        // samples at 50 m/s³ (a stepped acceleration's, or rounding's) are no plateau.
        let dt = 1e-3;
        let mut jerk = vec![0.0; 20_000];
        for (n, start) in [1000, 6000, 11_000, 16_000].into_iter().enumerate() {
            let sign = if n % 2 == 0 { 1.0 } else { -1.0 };
            jerk[start..start + 20].fill(sign * 5.0);
            jerk[start + 500] = 50.0;
        }
        let need = plateau_samples(dt);
        assert_eq!(held_peak(&jerk, need), 5.0);
        // Two samples at 50 next to each other are no 5 ms plateau either.
        jerk[3000] = 50.0;
        jerk[3001] = 50.0;
        assert_eq!(held_peak(&jerk, need), 5.0);
        // A plateau of 5 samples of 7 is.
        jerk[8000..8005].fill(-7.0);
        assert_eq!(held_peak(&jerk, need), 7.0);
        // A record shorter than a plateau: its least magnitude.
        assert_eq!(held_peak(&[3.0, -2.0], need), 2.0);
        assert_eq!(held_peak(&[], need), 0.0);
    }

    #[test]
    fn a_stepped_acceleration_at_a_coarse_rate_holds_no_jerk() {
        // A trapezoidal interpolator (no jerk limit) logged at 50 Hz: the acceleration
        // steps 0 -> 1 m/s² midway between two samples, holds for a second and steps back.
        // Its true jerk is unbounded at the steps and zero elsewhere: the derived jerk may
        // spike there but must keep no level over a plateau, else the step is read as a
        // jerk limit of about Δa/(2·dt) = 25 m/s³.
        let dt = 0.02;
        let t_step = [0.51, 1.51];
        let pos: Vec<f64> = (0..150)
            .map(|k| {
                let t = k as f64 * dt;
                let ramp = |t0: f64| (t - t0).max(0.0).powi(2) / 2.0;
                ramp(t_step[0]) - ramp(t_step[1])
            })
            .collect();
        let half = half_width_s(&[&pos[..]], dt);
        let d = derive(&pos, dt, half);
        let need = plateau_samples(dt);
        let step_rate = 1.0 / (2.0 * dt);
        assert!(
            held_peak(&d.jerk, need) < 0.5 * step_rate,
            "{} of {step_rate} m/s³: {:?}",
            held_peak(&d.jerk, need),
            &d.jerk[20..32]
        );
    }

    #[test]
    fn limits_round_up_to_three_digits() {
        assert_eq!(round_up(0.49981), 0.5);
        assert!((round_up(1234.5) - 1240.0).abs() < 1e-9);
    }
}
