//! A control's command stream placed on the program it ran: each command sample on its
//! block, found by a search that only moves forward, so that reports can name source lines
//! and rapids; and where the stream joins the program at all.
//!
//! A record seldom starts where the program does. A logger started late begins mid-block,
//! the axes already moving; a trace of a program's start begins where the machine stood —
//! at its home, say — and its first move comes from there, a path the program does not
//! describe. So the stream is placed from the first sample at which it lies on the
//! program's path and moves along it (or stands on it), and holds to it for a while after;
//! the samples before are the record's own approach. Where the path repeats (laps of a
//! circle, passes of a pocket at several depths) the first sample lies on several blocks:
//! each is followed to the record's end, and the earliest that keeps the stream within the
//! tolerance is taken.

use crate::path::{Geometry, Motion, Projection, Segment, norm3};
use crate::plan::Commands;

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

/// A command stream placed on a program.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placement {
    /// The first command sample on the program's path: 0 unless the stream begins off it
    /// (an approach from where the machine stood). The samples before it are given the
    /// segment it joins.
    pub join: usize,
    /// Whether the stream joins the path at all; where it does not, it is placed from its
    /// first sample, and `worst` says how far it strays.
    pub joined: bool,
    /// Whether it joins at the program's start: on a block before the first feed move in
    /// the plane, or at that move's start.
    pub at_program_start: bool,
    /// Where the stream lies furthest from the programmed geometry from `join` on (rapids
    /// aside); `None` for an empty stream or program.
    pub worst: Option<Departure>,
}

/// Path length beyond the distance moved that the search looks ahead (m): enough for a
/// blended corner's cut, short of the next pass of any pocket.
const LOOK_AHEAD_MARGIN_M: f64 = 0.2e-3;

/// A command slower than this stands (m/s): recorded commands' speeds are fitted and carry
/// their rounding.
const STANDING_M_PER_S: f64 = 1e-5;

/// How closely a moving stream's direction must agree with a block's to join it there
/// (cosine): a path crossing a block is not on it.
const JOIN_DIRECTION_COS: f64 = 0.9;

/// How long after joining the stream must stay on the path (s): an approach passing
/// through a block does not.
const JOIN_HOLD_S: f64 = 0.1;

/// Sets each command sample's segment (into `plan.segments`) by following the stream
/// along the program from where it joins the program's path, and says where it joins and
/// where it lies furthest from the programmed geometry. Rapids are not held to their line
/// (many controls move each axis on its own in G0); the stream is matched again where the
/// feed motion begins. The stream is placed by X and Y alone.
pub(crate) fn place_on_path(
    segs: &[Segment],
    commands: &mut Commands,
    tolerance_m: f64,
) -> Placement {
    place(Space::Xy, segs, commands, tolerance_m)
}

/// [`place_on_path`] for a stream that holds Z's commands too: where the program moves in
/// space (Z along the contour, or arcs in ZX or YZ), the stream is placed by all three
/// axes — a circle in ZX, whose XY trace runs back and forth along one line, is told from
/// its own return stroke only by Z. Where that does not place the stream on the path (a
/// record whose Z is in other coordinates) it is placed by X and Y as without Z.
pub(crate) fn place_in_space(
    segs: &[Segment],
    commands: &mut Commands,
    tolerance_m: f64,
) -> Placement {
    if segs.iter().any(Segment::is_contour_in_space) && commands.z.len() == commands.len() {
        let mut in_space = commands.clone();
        let p = place(Space::Xyz, segs, &mut in_space, tolerance_m);
        if p.joined && p.worst.is_none_or(|w| w.distance_m <= tolerance_m) {
            commands.segment = in_space.segment;
            return p;
        }
    }
    place_on_path(segs, commands, tolerance_m)
}

/// The axes a stream is placed by: X and Y, or X, Y and Z. With X and Y alone a point's Z
/// is zero and every block reaches every height.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Space {
    Xy,
    Xyz,
}

impl Space {
    fn point(self, commands: &Commands, k: usize) -> [f64; 3] {
        let z = match self {
            Space::Xy => 0.0,
            Space::Xyz => commands.z.pos_m[k],
        };
        [commands.x.pos_m[k], commands.y.pos_m[k], z]
    }

    fn velocity(self, commands: &Commands, k: usize) -> [f64; 3] {
        let z = match self {
            Space::Xy => 0.0,
            Space::Xyz => commands.z.vel_m_per_s[k],
        };
        [commands.x.vel_m_per_s[k], commands.y.vel_m_per_s[k], z]
    }

    fn norm(self, v: [f64; 3]) -> f64 {
        match self {
            Space::Xy => v[0].hypot(v[1]),
            Space::Xyz => norm3(v),
        }
    }

    fn distance(self, a: [f64; 3], b: [f64; 3]) -> f64 {
        self.norm([a[0] - b[0], a[1] - b[1], a[2] - b[2]])
    }

    fn project(self, seg: &Segment, q: [f64; 3], u_hint: f64) -> Projection {
        match self {
            Space::Xy => seg.project_xy([q[0], q[1]], u_hint),
            Space::Xyz => seg.project_in_space(q, u_hint),
        }
    }

    /// The length of a segment's path as the stream sees it.
    fn length(self, seg: &Segment) -> f64 {
        match self {
            Space::Xy => seg.xy_length_m(),
            Space::Xyz => seg.length_m(),
        }
    }

    /// A segment's unit tangent at the foot point of `q` (parameter `u`); `None` where it
    /// has no extent.
    fn tangent(self, seg: &Segment, q: [f64; 3], u: f64) -> Option<[f64; 3]> {
        match self {
            Space::Xy => xy_tangent(seg, [q[0], q[1]]).map(|t| [t[0], t[1], 0.0]),
            Space::Xyz => {
                let h = 1e-6;
                let (a, b) = (
                    seg.point_at_param((u - h).max(0.0)),
                    seg.point_at_param((u + h).min(1.0)),
                );
                let d = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
                let l = norm3(d);
                (l > 0.0).then(|| d.map(|v| v / l))
            }
        }
    }

    /// A segment's extent, `[min, max]` per axis (an XY arc's whole circle; any height
    /// where Z is not placed by).
    fn extent(self, seg: &Segment) -> [[f64; 2]; 3] {
        match self {
            Space::Xy => {
                let b = xy_box(seg);
                [
                    [b[0], b[1]],
                    [b[2], b[3]],
                    [f64::NEG_INFINITY, f64::INFINITY],
                ]
            }
            Space::Xyz => seg.extent_m(),
        }
    }
}

fn place(space: Space, segs: &[Segment], commands: &mut Commands, tolerance_m: f64) -> Placement {
    if segs.is_empty() || commands.is_empty() {
        return Placement {
            join: 0,
            joined: true,
            at_program_start: true,
            worst: None,
        };
    }
    let boxes: Vec<[[f64; 2]; 3]> = segs.iter().map(|s| space.extent(s)).collect();
    let n = commands.len();
    let (join, start, joined) = match find_join(space, segs, &boxes, commands, tolerance_m) {
        Some((join, start)) => (join, start, true),
        // Placed from its first sample, on the nearest block: the departure names where
        // it strays.
        None => (
            0,
            nearest_segment(space, segs, space.point(commands, 0)),
            false,
        ),
    };
    // A stream whose samples before the join all lie where it joins stood there from its
    // first sample (it set off between two samples, too fast to join at the first): no
    // approach comes before it.
    let joined_at = space.point(commands, join);
    let stood_there =
        (0..join).all(|k| space.distance(space.point(commands, k), joined_at) <= tolerance_m);
    let join = if stood_there { 0 } else { join };
    let at_program_start = at_program_start(space, segs, start, space.point(commands, join));
    let mut segment = std::mem::take(&mut commands.segment);
    let worst = follow(space, segs, commands, (join, start), n, Some(&mut segment));
    segment[..join].fill(start as u32);
    commands.segment = segment;
    Placement {
        join,
        joined,
        at_program_start,
        worst,
    }
}

/// How close to the first feed move's start a stream must join to join at the program's
/// start (m).
const AT_START_M: f64 = 0.1e-3;

/// Whether `q` on segment `j` lies at the program's start: `j` comes before the first feed
/// move the stream sees, or is that move and `q` lies at its start.
fn at_program_start(space: Space, segs: &[Segment], j: usize, q: [f64; 3]) -> bool {
    let first_feed = segs
        .iter()
        .position(|s| s.motion == Motion::Feed && space.length(s) > 0.0);
    first_feed.is_none_or(|f| {
        let mut s = segs[f].start_m;
        if space == Space::Xy {
            s[2] = 0.0;
        }
        j < f || (j == f && space.distance(q, s) < AT_START_M)
    })
}

/// The first sample at which the stream joins the program, and the segment it joins: the
/// sample lies on a segment (within the tolerance), standing or moving along it, and the
/// stream followed from there stays within the tolerance for [`JOIN_HOLD_S`]. Of the
/// segments it could join there (a path that repeats), the earliest that keeps the whole
/// stream within the tolerance, else the one that keeps it closest.
fn find_join(
    space: Space,
    segs: &[Segment],
    boxes: &[[[f64; 2]; 3]],
    commands: &Commands,
    tolerance_m: f64,
) -> Option<(usize, usize)> {
    let n = commands.len();
    let hold = ((JOIN_HOLD_S / commands.dt_s).ceil() as usize).max(1);
    for k in 0..n {
        let q = space.point(commands, k);
        let v = space.velocity(commands, k);
        let candidates: Vec<usize> = (0..segs.len())
            .filter(|&j| within_box(&boxes[j], q, tolerance_m))
            .filter(|&j| joins_at(space, &segs[j], q, v, tolerance_m))
            .filter(|&j| {
                follow(space, segs, commands, (k, j), (k + hold).min(n), None)
                    .is_none_or(|w| w.distance_m <= tolerance_m)
            })
            .collect();
        if candidates.is_empty() {
            continue;
        }
        if candidates.len() == 1 {
            return Some((k, candidates[0]));
        }
        // A path that repeats: the earliest block that keeps the whole stream on the path.
        let scored: Vec<(usize, f64)> = candidates
            .iter()
            .map(|&j| {
                let worst =
                    follow(space, segs, commands, (k, j), n, None).map_or(0.0, |w| w.distance_m);
                (j, worst)
            })
            .collect();
        let chosen = scored
            .iter()
            .find(|(_, w)| *w <= tolerance_m)
            .or_else(|| scored.iter().min_by(|a, b| a.1.total_cmp(&b.1)))
            .map(|(j, _)| *j)?;
        return Some((k, chosen));
    }
    None
}

/// Whether a stream at `q` moving at `v` joins segment `seg` there: it lies on it (within
/// the tolerance), and stands, or moves along a feed block's direction.
fn joins_at(space: Space, seg: &Segment, q: [f64; 3], v: [f64; 3], tolerance_m: f64) -> bool {
    let p = space.project(seg, q, 0.5);
    if p.signed_distance_m.abs() > tolerance_m {
        return false;
    }
    let speed = space.norm(v);
    if speed < STANDING_M_PER_S {
        return true;
    }
    if seg.motion == Motion::Rapid {
        return false;
    }
    space
        .tangent(seg, q, p.u)
        .is_some_and(|t| (t[0] * v[0] + t[1] * v[1] + t[2] * v[2]) / speed >= JOIN_DIRECTION_COS)
}

/// The unit tangent of a segment's XY path at the foot point of `q`; `None` where it has no
/// XY extent.
fn xy_tangent(seg: &Segment, q: [f64; 2]) -> Option<[f64; 2]> {
    match seg.geometry {
        Geometry::Line => {
            let d = [seg.end_m[0] - seg.start_m[0], seg.end_m[1] - seg.start_m[1]];
            let l = d[0].hypot(d[1]);
            (l > 0.0).then(|| [d[0] / l, d[1] / l])
        }
        Geometry::Arc(a) => {
            let rel = [q[0] - a.center_m[0], q[1] - a.center_m[1]];
            let r = rel[0].hypot(rel[1]);
            (r > 0.0).then(|| {
                let s = a.sweep_rad.signum();
                [-s * rel[1] / r, s * rel[0] / r]
            })
        }
        Geometry::Dwell { .. } => None,
    }
}

/// A segment's XY extent: [x_min, x_max, y_min, y_max] (an arc's whole circle).
fn xy_box(seg: &Segment) -> [f64; 4] {
    match seg.geometry {
        Geometry::Arc(a) => {
            let r = a.r_start_m.max(a.radius_at(1.0));
            [
                a.center_m[0] - r,
                a.center_m[0] + r,
                a.center_m[1] - r,
                a.center_m[1] + r,
            ]
        }
        _ => [
            seg.start_m[0].min(seg.end_m[0]),
            seg.start_m[0].max(seg.end_m[0]),
            seg.start_m[1].min(seg.end_m[1]),
            seg.start_m[1].max(seg.end_m[1]),
        ],
    }
}

fn within_box(b: &[[f64; 2]; 3], q: [f64; 3], margin: f64) -> bool {
    b.iter()
        .zip(q)
        .all(|(r, v)| v >= r[0] - margin && v <= r[1] + margin)
}

/// The segment nearest `q`.
fn nearest_segment(space: Space, segs: &[Segment], q: [f64; 3]) -> usize {
    let distance = |j: usize| space.project(&segs[j], q, 0.5).signed_distance_m.abs();
    (0..segs.len())
        .min_by(|&a, &b| distance(a).total_cmp(&distance(b)))
        .unwrap_or(0)
}

/// Follows the stream from sample `from` on segment `start` up to sample `to`, writing each
/// sample's segment into `segment` where given; the sample where it lies furthest from a
/// feed segment (or from a rapid of Z alone, whose X and Y stand).
fn follow(
    space: Space,
    segs: &[Segment],
    commands: &Commands,
    (from, start): (usize, usize),
    to: usize,
    mut segment: Option<&mut [u32]>,
) -> Option<Departure> {
    let mut current = start;
    // Mid-arc, a hint at either end would put the foot point beyond it.
    let mut u = space
        .project(&segs[current], space.point(commands, from), 0.5)
        .u;
    let mut worst: Option<Departure> = None;
    let mut last = space.point(commands, from);
    for k in from..to {
        let q = space.point(commands, k);
        let moved = space.distance(q, last);
        last = q;
        let (j, proj) = best_ahead(space, segs, (current, u), q, moved + LOOK_AHEAD_MARGIN_M);
        current = j;
        u = proj.u;
        if let Some(s) = segment.as_deref_mut() {
            s[k] = j as u32;
        }
        // A rapid's axes may each move on their own, off its line, but one of Z alone holds
        // X and Y where they are: a stream that moves there has left the program. (A rapid
        // of no length at all, such as a program's first `G0` to where the axes stand, is a
        // rapid like any other: the record may still be arriving there.)
        let z_alone = segs[j].xy_length_m() == 0.0 && segs[j].length_m() > 0.0;
        if segs[j].motion == Motion::Rapid && !z_alone {
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

/// The segment nearest `q` among the current one (at parameter `u`) and those starting
/// within `window` of path length ahead (all of a chain of rapids, and the feed segment
/// after it, while in a rapid). Ties go to the later segment: a path that doubles back on
/// itself is followed onto the return stroke.
fn best_ahead(
    space: Space,
    segs: &[Segment],
    (current, u): (usize, f64),
    q: [f64; 3],
    window: f64,
) -> (usize, Projection) {
    let mut best = (current, space.project(&segs[current], q, u));
    let mut ahead = (1.0 - u) * space.length(&segs[current]);
    let mut in_rapids = segs[current].motion == Motion::Rapid;
    let mut j = current + 1;
    while j < segs.len() && (ahead <= window || in_rapids) {
        let p = space.project(&segs[j], q, 0.0);
        if p.signed_distance_m.abs() <= best.1.signed_distance_m.abs() + 1e-9 {
            best = (j, p);
        }
        // A chain of rapids is searched to its end and one segment beyond.
        in_rapids = in_rapids && segs[j].motion == Motion::Rapid;
        ahead += space.length(&segs[j]);
        j += 1;
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gcode::{InterpretOptions, parse_program};
    use crate::trace::recorded::commands_from_record;

    fn segments(text: &str) -> Vec<Segment> {
        parse_program(text, "t.nc", &InterpretOptions::default())
            .unwrap()
            .segments
    }

    /// Commands at 1 kHz along `points(t)` (m) for `seconds`, resampled to 2 ms.
    fn stream(seconds: f64, points: impl Fn(f64) -> [f64; 2]) -> Commands {
        let n = (seconds / 1e-3) as usize;
        let (x, y): (Vec<f64>, Vec<f64>) = (0..n)
            .map(|k| {
                let p = points(k as f64 * 1e-3);
                (p[0], p[1])
            })
            .unzip();
        commands_from_record(&x, &y, 1e-3, 2e-3)
    }

    const TWO_LAPS: &str =
        "G21 G90 G17\nG0 X30 Y0\nG3 X30 Y0 I-30 J0 F1000\nG3 X30 Y0 I-30 J0\nM2\n";

    #[test]
    fn a_stream_begun_mid_lap_joins_at_its_first_sample_on_the_first_lap() {
        let segs = segments(TWO_LAPS);
        // Counter-clockwise at 1000 mm/min from 200° on, for 1.3 laps.
        let w = (1000.0 / 60.0) / 30.0;
        let mut c = stream(15.0, |t| {
            let a = 200f64.to_radians() + w * t;
            [0.03 * a.cos(), 0.03 * a.sin()]
        });
        let p = place_on_path(&segs, &mut c, 25e-6);
        assert_eq!((p.join, p.joined), (0, true), "{p:?}");
        assert!(p.worst.unwrap().distance_m < 1e-6, "{p:?}");
        assert_eq!(segs[c.segment[0] as usize].line, 3);
        assert_eq!(segs[*c.segment.last().unwrap() as usize].line, 4);
    }

    #[test]
    fn an_approach_from_home_is_left_before_the_join() {
        let segs = segments("G21 G90 G17\nG0 X0 Y0\nG1 X60 F1000\nY60\nM2\n");
        // Standing at (200, -50) mm for 0.5 s, a straight rapid to the origin in 1 s that
        // crosses the first feed line's extension, standing 0.3 s, then along X at 1000 mm/min.
        let mut c = stream(4.0, |t| {
            let home = [0.2, -0.05];
            if t < 0.5 {
                home
            } else if t < 1.5 {
                let f = t - 0.5;
                [home[0] * (1.0 - f), home[1] * (1.0 - f)]
            } else if t < 1.8 {
                [0.0, 0.0]
            } else {
                [(t - 1.8) * 1000.0 / 60.0 * 1e-3, 0.0]
            }
        });
        let p = place_on_path(&segs, &mut c, 25e-6);
        assert!(p.joined, "{p:?}");
        let join_s = p.join as f64 * c.dt_s;
        assert!((1.49..=1.52).contains(&join_s), "joined at {join_s} s");
        assert!(p.worst.unwrap().distance_m < 1e-6, "{p:?}");
    }

    #[test]
    fn a_circle_in_zx_is_placed_by_z_where_its_xy_trace_folds_back() {
        let segs =
            segments("G21 G90 G18\nG0 X20 Y0 Z0\nG1 X10 F1000\nG2 X10 Z0 I-10 K0\nG1 X20\nM2\n");
        // G2 in ZX turns clockwise in the plane's (Z, X) coordinates: from the start at
        // X10 Z0 (90° from Z) the angle falls, so Z climbs first: X = 10 cos ωt,
        // Z = 10 sin ωt (mm) at 1000 mm/min; then out along X to X20. X and Y alone pass
        // every X between −10 and 10 mm twice, and the lead-out's X the circle's start.
        let (r, v) = (0.01, 1000.0 / 60.0 * 1e-3);
        let (w, lap_s) = (v / r, std::f64::consts::TAU * r / v);
        let at = |t: f64| {
            if t < lap_s {
                [r * (w * t).cos(), 0.0, r * (w * t).sin()]
            } else {
                [(r + v * (t - lap_s)).min(2.0 * r), 0.0, 0.0]
            }
        };
        let n = 5000;
        let p: Vec<[f64; 3]> = (0..n).map(|k| at(k as f64 * 1e-3)).collect();
        let axis = |i: usize| p.iter().map(|q| q[i]).collect::<Vec<f64>>();
        let mut c = commands_from_record(&axis(0), &axis(1), 1e-3, 2e-3);
        c.z = commands_from_record(&axis(2), &axis(2), 1e-3, 2e-3).x;
        let mut xy_only = c.clone();
        let placed = place_in_space(&segs, &mut c, 25e-6);
        assert!(placed.joined, "{placed:?}");
        assert!(placed.worst.unwrap().distance_m < 1e-6, "{placed:?}");
        for (k, &j) in c.segment.iter().enumerate() {
            let t = k as f64 * c.dt_s;
            let line = segs[j as usize].line;
            if t < lap_s - 0.01 {
                assert_eq!(line, 4, "t = {t} s");
            } else if t > lap_s + 0.01 {
                assert_eq!(line, 5, "t = {t} s");
            }
        }
        // By X and Y alone the circle's return stroke is taken for another block (its
        // first half, the lead-out): the stream leaves the path by millimetres and would be
        // refused as a record of another program.
        let by_xy = place_on_path(&segs, &mut xy_only, 25e-6);
        assert!(by_xy.worst.unwrap().distance_m > 1e-3, "{by_xy:?}");
    }

    #[test]
    fn a_stream_crossing_a_block_does_not_join_it() {
        let segs = segments("G21 G90 G17\nG0 X0 Y0\nG1 X0 Y60 F1000\nM2\n");
        // Across the Y line at right angles, never along it.
        let mut c = stream(2.0, |t| [-0.05 + 0.05 * t, 0.03]);
        let p = place_on_path(&segs, &mut c, 25e-6);
        assert!(!p.joined, "{p:?}");
        assert!(p.worst.unwrap().distance_m > 1e-3, "{p:?}");
    }
}
