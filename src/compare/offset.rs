//! A record in other coordinates than its program's: the constant offset — a work offset
//! such as G54 — that puts the record's commands on the program's path, found only to tell
//! the user what to pass (`--work-offset`), never applied unasked.
//!
//! Two readings, the cheap one first: the centres of the two ranges of travel (a record of
//! the whole program), and, for a record of part of it — one that starts at the machine's
//! home or ends within a block —, each place the commands stand still paired with each
//! point of the program where a block starts or ends.

use super::CompareSettings;
use crate::path::Motion;
use crate::plan::{Commands, Plan};
use crate::trace::measured::MeasuredTrace;
use crate::trace::placement::place_on_path;
use crate::trace::recorded::commands_from_record;

/// Commands that stay within this of where they stood stand (m): recorded commands of a
/// standing axis repeat their value, up to the control's own rounding.
const STANDING_SPREAD_M: f64 = 1e-7;
/// A command sample faster than this moves (m/s): above the rounding of a standing axis's
/// fitted speed.
const MOVING_M_PER_S: f64 = 1e-5;
/// The shortest standstill read as a stop (s): longer than a sample's jitter at any rate a
/// control records at, shorter than any dwell a program or a spindle start holds.
const MIN_STOP_S: f64 = 0.02;
/// How many stops and program points are paired at most: a record's first stops and the
/// program's first points are where a record of its start lies, and the bound keeps an
/// error's hint quick on a long program.
const MAX_STOPS: usize = 24;
const MAX_POINTS: usize = 200;
/// How many of the best-scored offsets are placed on the program at most.
const MAX_PLACED: usize = 16;
/// How far the commands move from a stop before their direction is read (m): past a
/// control's rounding, short of a block's length.
const DIRECTION_M: f64 = 0.05e-3;
/// Two stops or program points closer than this are one place (m).
const SAME_PLACE_M: f64 = 1e-6;

/// A work offset that puts a record on its program (mm, as the user gives it).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Offset {
    pub mm: [f64; 2],
    /// Whether the record, so shifted, joins the program at its start …
    pub at_program_start: bool,
    /// … and at which of its samples (resampled to the plan's step): the earlier, the more
    /// of the record lies on the program.
    pub join: usize,
}

/// The constant offsets by which a record's commands may run beside the program: each
/// puts them on the program's path within the tolerance. Empty where none does; more than
/// one where the record cannot tell which (a record of a program's start whose few moves
/// in the plane the program makes at several places).
pub(super) fn work_offsets(
    plan: &Plan,
    planned: &Commands,
    measured: &MeasuredTrace,
    dt: f64,
    settings: &CompareSettings,
) -> Vec<Offset> {
    let Some([xc, yc]) = measured.commands.as_ref() else {
        return Vec::new();
    };
    let centred = [
        centre(xc) - centre(&planned.x.pos_m),
        centre(yc) - centre(&planned.y.pos_m),
    ];
    if centred.iter().all(|o| o.is_finite())
        && let Some(offset) = places(plan, measured, dt, settings, centred)
    {
        return vec![offset];
    }
    offsets_from_stops(plan, measured, dt, settings)
}

/// The midpoint of a range of travel (m).
fn centre(v: &[f64]) -> f64 {
    let (lo, hi) = v
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &x| {
            (l.min(x), h.max(x))
        });
    0.5 * (lo + hi)
}

/// The offset `offset` (m), where the record's commands shifted back by it join the
/// program's path and from there stay on it within the tolerance (rapids aside, as a control
/// runs them its own way), with some of its moving samples on the program's feed blocks: a
/// stream placed on rapids only has none of the program's cutting on it.
fn places(
    plan: &Plan,
    measured: &MeasuredTrace,
    dt: f64,
    settings: &CompareSettings,
    offset: [f64; 2],
) -> Option<Offset> {
    let [xc, yc] = measured.commands.as_ref()?;
    let shift = |v: &[f64], o: f64| v.iter().map(|p| p - o).collect::<Vec<f64>>();
    let mut shifted = commands_from_record(
        &shift(xc, offset[0]),
        &shift(yc, offset[1]),
        measured.dt_s,
        dt,
    );
    let placed = place_on_path(&plan.segments, &mut shifted, settings.command_tolerance_m);
    let on_path = placed
        .worst
        .is_none_or(|w| w.distance_m <= settings.command_tolerance_m);
    if !(placed.joined && on_path) {
        return None;
    }
    let on_feed = (placed.join..shifted.segment.len()).any(|k| {
        let feed = plan
            .segments
            .get(shifted.segment[k] as usize)
            .is_some_and(|seg| seg.motion == Motion::Feed);
        let speed = shifted.x.vel_m_per_s[k].hypot(shifted.y.vel_m_per_s[k]);
        feed && speed > MOVING_M_PER_S
    });
    on_feed.then_some(Offset {
        mm: offset.map(|v| v * 1e3),
        at_program_start: placed.at_program_start,
        join: placed.join,
    })
}

/// The offsets that pair a stop of the record's commands with a point of the program and
/// put the most stops on the program's points (in space, where the record holds Z's
/// commands: a record's stops before and after a Z move tell apart the places of a program
/// where the same move in the plane starts), of those that place the record's moving samples
/// on the program's feed blocks; those that join it at the program's start first, the
/// earliest join first. Empty where none does; more than one where the record cannot tell
/// them apart.
fn offsets_from_stops(
    plan: &Plan,
    measured: &MeasuredTrace,
    dt: f64,
    settings: &CompareSettings,
) -> Vec<Offset> {
    let Some([xc, yc]) = measured.commands.as_ref() else {
        return Vec::new();
    };
    let zc = measured.z_cmd_m.as_deref();
    let stops = stops(xc, yc, zc, measured.dt_s);
    let points = program_points(plan, zc.is_some());
    let tolerance = settings.command_tolerance_m;
    let mut scored = plane_offsets_scored(&stops, &points, tolerance);
    scored.sort_by_key(|s| std::cmp::Reverse(s.0));
    let mut found: Vec<(usize, Offset)> = Vec::new();
    // The placements are the costly part: the best-scored candidates only, so that a record
    // no offset puts on the program is refused as quickly as one without stops.
    for (score, offset) in scored.into_iter().take(MAX_PLACED) {
        if found.first().is_some_and(|&(best, _)| score < best) {
            break;
        }
        if let Some(placed) = places(plan, measured, dt, settings, offset) {
            found.push((score, placed));
        }
    }
    let mut offsets: Vec<Offset> = found.into_iter().map(|(_, o)| o).collect();
    offsets.sort_by_key(|o| (!o.at_program_start, o.join));
    offsets
}

/// Each offset in the plane that pairs a stop with a program point the record leaves or
/// reaches as the program does (offsets within the
/// tolerance of one another are one), with the most stops any of its offsets in space puts
/// on the program's points: a program that passes one place in the plane at several heights
/// (its start, a clearance, a plunge) pairs it with each, and the right height counts.
fn plane_offsets_scored(
    stops: &[Stop],
    points: &[Point],
    tolerance_m: f64,
) -> Vec<(usize, [f64; 2])> {
    let mut scored: Vec<(usize, [f64; 2])> = Vec::new();
    for stop in stops {
        for point in points.iter().filter(|p| stop.moves_as(p)) {
            let offset = [0, 1, 2].map(|i| stop.at[i] - point.at[i]);
            let plane = [offset[0], offset[1]];
            let score = stops_on_points(stops, points, offset, tolerance_m);
            match scored
                .iter_mut()
                .find(|(_, o)| near(*o, plane, tolerance_m))
            {
                Some(entry) => entry.0 = entry.0.max(score),
                None => scored.push((score, plane)),
            }
        }
    }
    scored
}

/// How many of `stops`, shifted back by `offset`, lie on one of the program's `points` and
/// leave it (or, the record's last, reach it) the way one of the program's blocks there does.
fn stops_on_points(stops: &[Stop], points: &[Point], offset: [f64; 3], tolerance_m: f64) -> usize {
    stops
        .iter()
        .filter(|s| {
            points.iter().any(|p| {
                (0..3).all(|i| (s.at[i] - offset[i] - p.at[i]).abs() <= tolerance_m)
                    && s.moves_as(p)
            })
        })
        .count()
}

/// Cosine above which two directions are one: a block's and the record's, within about 25°
/// (a rapid the control blends leaves its corner obliquely).
const SAME_DIRECTION_COS: f64 = 0.9;

/// A place where the record's commands stand still (m), with the directions they arrive
/// from and leave in (unit vectors; `None` at the record's ends).
#[derive(Debug, Clone, PartialEq)]
struct Stop {
    at: [f64; 3],
    arrival: Option<[f64; 3]>,
    departure: Option<[f64; 3]>,
}

/// A point where blocks of the program end or start (m), with their directions there.
#[derive(Debug, Clone, PartialEq)]
struct Point {
    at: [f64; 3],
    incoming: Vec<[f64; 3]>,
    outgoing: Vec<[f64; 3]>,
}

impl Stop {
    /// Whether the record leaves this stop as a block leaves `point` — or, where it does not
    /// leave it (the record ends there), reaches it as a block reaches `point`; a stop the
    /// record neither reaches nor leaves matches on its place alone.
    fn moves_as(&self, point: &Point) -> bool {
        let agrees = |d: [f64; 3], dirs: &[[f64; 3]]| {
            dirs.iter()
                .any(|e| (0..3).map(|i| d[i] * e[i]).sum::<f64>() > SAME_DIRECTION_COS)
        };
        match (self.departure, self.arrival) {
            (Some(d), _) => agrees(d, &point.outgoing),
            (None, Some(a)) => agrees(a, &point.incoming),
            (None, None) => true,
        }
    }
}

/// The unit vector from `from` to `to`, `None` where they coincide.
fn direction(from: [f64; 3], to: [f64; 3]) -> Option<[f64; 3]> {
    let d = [0, 1, 2].map(|i| to[i] - from[i]);
    let n = (0..3).map(|i| d[i] * d[i]).sum::<f64>().sqrt();
    (n > 0.0 && n.is_finite()).then(|| d.map(|v| v / n))
}

/// Whether two offsets in the plane lie within `tolerance_m` of each other.
fn near(a: [f64; 2], b: [f64; 2], tolerance_m: f64) -> bool {
    (a[0] - b[0]).abs() <= tolerance_m && (a[1] - b[1]).abs() <= tolerance_m
}

/// Where the commands stand still for at least [`MIN_STOP_S`] (m; Z zero where the record
/// holds no Z), each place once, in the order the record reaches them; at most
/// [`MAX_STOPS`].
fn stops(xc: &[f64], yc: &[f64], zc: Option<&[f64]>, dt_s: f64) -> Vec<Stop> {
    let n = xc
        .len()
        .min(yc.len())
        .min(zc.map_or(usize::MAX, <[f64]>::len));
    let at = |k: usize| [xc[k], yc[k], zc.map_or(0.0, |z| z[k])];
    // Samples spanning MIN_STOP_S: its intervals and one.
    let min_len = ((MIN_STOP_S / dt_s).ceil() as usize + 1).max(3);
    let mut runs: Vec<(usize, usize)> = Vec::new();
    let mut run_start = 0;
    for k in 1..=n {
        // A run stands while every sample stays by its first: a creep, however slow at
        // whatever rate it is sampled, leaves it.
        let moved = k == n || {
            let (first, here) = (at(run_start), at(k));
            (0..3).any(|i| (here[i] - first[i]).abs() > STANDING_SPREAD_M)
        };
        if !moved {
            continue;
        }
        let here = at(k - 1);
        let long_enough = k - run_start >= min_len && here.iter().all(|v| v.is_finite());
        let new = !runs.iter().any(|&(_, end)| {
            let f = at(end);
            (0..3).all(|i| (f[i] - here[i]).abs() < SAME_PLACE_M)
        });
        if long_enough && new {
            runs.push((run_start, k - 1));
        }
        run_start = k;
        if runs.len() == MAX_STOPS {
            break;
        }
    }
    // Where the commands came from and go to: the first sample a direction's length away.
    let away = |from: usize, step: isize| {
        let origin = at(from);
        let mut k = from as isize + step;
        while k >= 0 && (k as usize) < n {
            let p = at(k as usize);
            if (0..3)
                .map(|i| (p[i] - origin[i]).powi(2))
                .sum::<f64>()
                .sqrt()
                >= DIRECTION_M
            {
                return direction(origin, p).map(|d| d.map(|v| v * step.signum() as f64));
            }
            k += step;
        }
        None
    };
    runs.iter()
        .map(|&(first, last)| Stop {
            at: at(last),
            arrival: away(first, -1),
            departure: away(last, 1),
        })
        .collect()
}

/// The program's points where a block starts or ends (m; Z zero unless `with_z`), each
/// once, in the program's order, with the directions of the blocks that reach and leave them;
/// at most [`MAX_POINTS`].
fn program_points(plan: &Plan, with_z: bool) -> Vec<Point> {
    let flat = |p: [f64; 3]| [p[0], p[1], if with_z { p[2] } else { 0.0 }];
    let mut points: Vec<Point> = Vec::new();
    for seg in plan.segments.iter().filter(|s| !s.is_dwell()) {
        let ends = [
            (seg.start_m, seg.start_tangent(), false),
            (seg.end_m, seg.end_tangent(), true),
        ];
        for (p, tangent, incoming) in ends {
            let (p, tangent) = (flat(p), direction([0.0; 3], flat(tangent)));
            let found = points
                .iter()
                .position(|q| (0..3).all(|i| (q.at[i] - p[i]).abs() < SAME_PLACE_M));
            let index = match found {
                Some(k) => k,
                None if points.len() < MAX_POINTS => {
                    points.push(Point {
                        at: p,
                        incoming: Vec::new(),
                        outgoing: Vec::new(),
                    });
                    points.len() - 1
                }
                None => continue,
            };
            let point = &mut points[index];
            let dirs = if incoming {
                &mut point.incoming
            } else {
                &mut point.outgoing
            };
            dirs.extend(tangent);
        }
    }
    points
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stops_are_the_standstills_long_enough_each_place_once() {
        // 10 ms a sample: 3 samples (20 ms) standing at the origin, a move, 2 samples
        // (10 ms: too short) standing at (1, 0.5), a move, then 5 samples at (2, 1), and
        // back to the origin, where the stop is not listed twice.
        let dt = 0.01;
        let x = [
            0.0, 0.0, 0.0, 0.5, 1.0, 1.0, 1.5, 2.0, 2.0, 2.0, 2.0, 2.0, 1.0, 0.0, 0.0, 0.0,
        ];
        let y = [
            0.0, 0.0, 0.0, 0.2, 0.5, 0.5, 0.8, 1.0, 1.0, 1.0, 1.0, 1.0, 0.5, 0.0, 0.0, 0.0,
        ];
        let found = stops(&x, &y, None, dt);
        let places: Vec<[f64; 3]> = found.iter().map(|s| s.at).collect();
        assert_eq!(places, vec![[0.0, 0.0, 0.0], [2.0, 1.0, 0.0]]);
        // The first stop is left towards (0.5, 0.2) — the first sample 0.05 mm away —, the
        // second reached from (1.5, 0.8) and left back towards (1, 0.5).
        let unit = |v: [f64; 3]| {
            let n = (v[0] * v[0] + v[1] * v[1]).sqrt();
            [v[0] / n, v[1] / n, 0.0]
        };
        let close = |got: Option<[f64; 3]>, want: [f64; 3]| {
            let got = got.expect("a direction");
            assert!(
                (0..3).all(|i| (got[i] - want[i]).abs() < 1e-12),
                "{got:?} {want:?}"
            );
        };
        assert_eq!(found[0].arrival, None);
        close(found[0].departure, unit([0.5, 0.2, 0.0]));
        close(found[1].arrival, unit([0.5, 0.2, 0.0]));
        close(found[1].departure, unit([-1.0, -0.5, 0.0]));
        // Standing only as long as a sample's jitter: no stop.
        assert!(stops(&[0.0, 0.0, 1.0], &[0.0, 0.0, 1.0], None, dt).is_empty());
    }

    #[test]
    fn a_stop_matches_a_point_the_record_leaves_as_a_block_does() {
        let point = Point {
            at: [0.0; 3],
            incoming: vec![[0.0, 1.0, 0.0]],
            outgoing: vec![[1.0, 0.0, 0.0]],
        };
        let stop = |arrival, departure| Stop {
            at: [0.0; 3],
            arrival,
            departure,
        };
        // Leaving along +X as the block does; 30° off is another direction.
        assert!(stop(None, Some([1.0, 0.0, 0.0])).moves_as(&point));
        let c = 30f64.to_radians().cos();
        let s = 30f64.to_radians().sin();
        assert!(!stop(None, Some([c, s, 0.0])).moves_as(&point));
        // The record's last stop, reached along +Y as the block reaches it.
        assert!(stop(Some([0.0, 1.0, 0.0]), None).moves_as(&point));
        assert!(!stop(Some([1.0, 0.0, 0.0]), None).moves_as(&point));
    }
}
