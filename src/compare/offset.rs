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

/// Commands that move less than this between samples stand (m): recorded commands of a
/// standing axis repeat their value, up to the control's own rounding.
const STANDING_STEP_M: f64 = 1e-7;
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
const MAX_POINTS: usize = 400;
/// Two offsets closer than this are one (m).
const SAME_OFFSET_M: f64 = 1e-6;

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
        && places(plan, measured, dt, settings, centred).is_some_and(|(n, _, _)| n > 0)
    {
        return vec![Offset {
            mm: centred.map(|v| v * 1e3),
            at_program_start: true,
            join: 0,
        }];
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

/// How many of the record's moving command samples, shifted back by `offset`, lie on the
/// program's feed blocks, if from where they join the path they stay on it within the
/// tolerance (rapids aside, as a control runs them its own way), and whether they join it
/// at the program's start. A stream placed only on rapids has none of the program's cutting
/// on it: zero.
fn places(
    plan: &Plan,
    measured: &MeasuredTrace,
    dt: f64,
    settings: &CompareSettings,
    offset: [f64; 2],
) -> Option<(usize, bool, usize)> {
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
    let feed_samples = (placed.join..shifted.segment.len())
        .filter(|&k| {
            let feed = plan
                .segments
                .get(shifted.segment[k] as usize)
                .is_some_and(|seg| seg.motion == Motion::Feed);
            let speed = shifted.x.vel_m_per_s[k].hypot(shifted.y.vel_m_per_s[k]);
            feed && speed > MOVING_M_PER_S
        })
        .count();
    Some((feed_samples, placed.at_program_start, placed.join))
}

/// The offsets that pair a stop of the record's commands with a point of the program and
/// put the most stops on the program's points (in space, where the record holds Z's
/// commands: a record's stops before and after a Z move tell apart the places of a program
/// where the same move in the plane starts), of those that place the record's moving samples
/// on the program's feed blocks, those that join it at the program's start first, the
/// earliest join first. Empty
/// where none does; more than one where the record cannot tell them apart.
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
    let mut scored: Vec<(usize, [f64; 2])> = Vec::new();
    for stop in &stops {
        for point in &points {
            let offset = [0, 1, 2].map(|i| stop[i] - point[i]);
            let plane = [offset[0], offset[1]];
            if scored.iter().any(|(_, o)| same(*o, plane)) {
                continue;
            }
            scored.push((stops_on_points(&stops, &points, offset, tolerance), plane));
        }
    }
    scored.sort_by_key(|s| std::cmp::Reverse(s.0));
    let mut found = Vec::new();
    for (score, offset) in scored {
        if found.first().is_some_and(|&(best, _)| score < best) {
            break;
        }
        if let Some((n, at_program_start, join)) = places(plan, measured, dt, settings, offset)
            && n > 0
        {
            found.push((
                score,
                Offset {
                    mm: offset.map(|v| v * 1e3),
                    at_program_start,
                    join,
                },
            ));
        }
    }
    let mut offsets: Vec<Offset> = found.into_iter().map(|(_, o)| o).collect();
    offsets.sort_by_key(|o| (!o.at_program_start, o.join));
    offsets
}

/// How many of `stops`, shifted back by `offset`, lie on one of the program's `points`.
fn stops_on_points(
    stops: &[[f64; 3]],
    points: &[[f64; 3]],
    offset: [f64; 3],
    tolerance_m: f64,
) -> usize {
    stops
        .iter()
        .filter(|s| {
            points
                .iter()
                .any(|p| (0..3).all(|i| (s[i] - offset[i] - p[i]).abs() <= tolerance_m))
        })
        .count()
}

fn same(a: [f64; 2], b: [f64; 2]) -> bool {
    (a[0] - b[0]).abs() < SAME_OFFSET_M && (a[1] - b[1]).abs() < SAME_OFFSET_M
}

/// Where the commands stand still for at least [`MIN_STOP_S`] (m; Z zero where the record
/// holds no Z), each place once, in the order the record reaches them; at most
/// [`MAX_STOPS`].
fn stops(xc: &[f64], yc: &[f64], zc: Option<&[f64]>, dt_s: f64) -> Vec<[f64; 3]> {
    let n = xc
        .len()
        .min(yc.len())
        .min(zc.map_or(usize::MAX, <[f64]>::len));
    let at = |k: usize| [xc[k], yc[k], zc.map_or(0.0, |z| z[k])];
    // Samples spanning MIN_STOP_S: its intervals and one.
    let min_len = ((MIN_STOP_S / dt_s).ceil() as usize + 1).max(3);
    let mut found: Vec<[f64; 3]> = Vec::new();
    let mut run_start = 0;
    for k in 1..=n {
        let moved = k == n || {
            let (a, b) = (at(k - 1), at(k));
            (0..3).any(|i| (b[i] - a[i]).abs() > STANDING_STEP_M)
        };
        if !moved {
            continue;
        }
        let here = at(k - 1);
        let long_enough = k - run_start >= min_len && here.iter().all(|v| v.is_finite());
        let new = !found
            .iter()
            .any(|f| (0..3).all(|i| (f[i] - here[i]).abs() < SAME_OFFSET_M));
        if long_enough && new {
            found.push(here);
        }
        run_start = k;
        if found.len() == MAX_STOPS {
            break;
        }
    }
    found
}

/// The program's points where a block starts or ends (m; Z zero unless `with_z`), each
/// once, in the program's order; at most [`MAX_POINTS`].
fn program_points(plan: &Plan, with_z: bool) -> Vec<[f64; 3]> {
    let mut points: Vec<[f64; 3]> = Vec::new();
    for seg in &plan.segments {
        for p in [seg.start_m, seg.end_m] {
            let p = [p[0], p[1], if with_z { p[2] } else { 0.0 }];
            let new = !points
                .iter()
                .any(|q| (0..3).all(|i| (q[i] - p[i]).abs() < SAME_OFFSET_M));
            if points.len() < MAX_POINTS && new {
                points.push(p);
            }
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
        assert_eq!(
            stops(&x, &y, None, dt),
            vec![[0.0, 0.0, 0.0], [2.0, 1.0, 0.0]]
        );
        // Standing only as long as a sample's jitter: no stop.
        assert!(stops(&[0.0, 0.0, 1.0], &[0.0, 0.0, 1.0], None, dt).is_empty());
        // A Z move at a standing place in the plane ends one stop and begins another.
        let z = [
            5.0, 5.0, 5.0, 5.0, 5.0, 5.0, 5.0, 5.0, 5.0, 5.0, 5.0, 5.0, 5.0, 5.0, 4.0, 4.0,
        ];
        let mut x = x;
        let mut y = y;
        x[14..].fill(0.0);
        y[14..].fill(0.0);
        // (Z falls at the 15th sample: the origin at Z 5 stood 20 ms; Z 4 only 10 ms.)
        assert_eq!(
            stops(&x, &y, Some(&z), dt),
            vec![[0.0, 0.0, 5.0], [2.0, 1.0, 5.0]]
        );
    }
}
