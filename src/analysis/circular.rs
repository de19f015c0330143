//! Circular-test figures in the manner of ISO 230-4 (the ballbar or grid-encoder test of two
//! interpolating axes), for every full circle a program contains in a principal plane (XY,
//! ZX or YZ; a helix is no circular test) — from any path: a prediction, a measurement, or a
//! fitted model. In another plane than XY, "X" and "Y" below stand for the plane's first
//! and second axes (ZX: Z and X; YZ: Y and Z), and the figures name their plane.
//!
//! Per circle and direction:
//! - **G, circular deviation**: the radial width of the band holding the path, about the
//!   path's own least-squares centre (the standard's minimum zone is at most this wide);
//! - **F, radial deviation**: the largest and smallest radius minus the nominal one, about the
//!   programmed centre;
//! - **reversal spikes**: at each quadrant point (0°, 90°, 180°, 270°, where one axis
//!   reverses), how far the path bulges beyond its neighbourhood (±5°–15°).
//!
//! For a pair of circles on the same centre and radius run in opposite directions:
//! - **H, circular hysteresis**: the largest radial difference between the two paths at the
//!   same angle (1° bins), about their common least-squares centre;
//! - the ballbar diagnoses, each from the shape its cause leaves on the radial deviation:
//!   squareness and scale mismatch (the ellipses both directions share, 2θ terms), servo
//!   mismatch (the diagonal ellipse that turns with the direction), straightness (the 3θ
//!   terms both share: a bow of one axis's travel seen on the other), lateral play (a step
//!   of one axis at the other's reversals, |cos θ| or |sin θ| turning sign with the
//!   direction) and lost motion (the radial step across an axis's own reversal points).

use nalgebra::{Matrix3, Vector3};
use serde::Serialize;

use crate::analysis::thinning::PeakThinned;
use crate::numeric::units::{mm_from_m, um_from_m};
use crate::path::{Geometry, Motion, Plane, Segment};

mod entry;
mod progress;
mod spikes;

use entry::Entries;
pub use entry::EntrySettling;
use progress::Progress;
use spikes::{SpikeZones, cut_by_windows, reversal_spikes, running_or_feed, step_across};

/// A full circle of the program.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Circle {
    /// Index into the plan's segments.
    pub segment: usize,
    /// Source line.
    pub line: u32,
    /// Programmed centre (m).
    pub center_m: [f64; 2],
    /// Programmed radius (m).
    pub radius_m: f64,
    /// Counter-clockwise (G3).
    pub ccw: bool,
    /// Programmed feed (m/s).
    pub feed_m_per_s: f64,
    /// The plane it lies in; its centre is in that plane's coordinates.
    pub plane: Plane,
    /// Where the plane lies along its normal (m): Z for an XY circle, Y for ZX, X for YZ.
    pub height_m: f64,
    /// Its path's length, all turns (m).
    pub length_m: f64,
    /// The polar angle of its start (and end) about the centre (rad).
    pub start_rad: f64,
}

/// The full circles among `segments`: feed arcs of constant radius, in their plane (not
/// helices), that sweep at least one whole turn.
pub(crate) fn circles(segments: &[Segment]) -> Vec<Circle> {
    segments
        .iter()
        .enumerate()
        .filter_map(|(i, s)| match s.geometry {
            Geometry::Arc(a)
                if s.motion == Motion::Feed
                    && !s.is_helix()
                    && a.sweep_rad.abs() >= std::f64::consts::TAU * (1.0 - 1e-9)
                    && (a.r_end_m - a.r_start_m).abs() <= 1e-9 =>
            {
                Some(Circle {
                    segment: i,
                    line: s.line,
                    center_m: a.center_m,
                    radius_m: a.r_start_m,
                    ccw: a.sweep_rad > 0.0,
                    feed_m_per_s: s.feed_m_per_s,
                    plane: s.plane(),
                    height_m: s.start_m[s.plane().axes()[2]],
                    length_m: a.sweep_rad.abs() * a.r_start_m,
                    start_rad: a.theta_start_rad,
                })
            }
            _ => None,
        })
        .collect()
}

/// The samples of a path on circle `c`, one of `circles` (`segment[k]` the plan segment
/// sample `k` lies nearest, `[x, y, z]` its position, m; `z` may be empty where the path has
/// no Z; `command` where it was commanded): each one's polar angle about the programmed
/// centre in the circle's plane (rad) and radial deviation from the programmed radius (m,
/// outward positive), for the samples that count toward the circle's figures
/// ([`CircleSamples::push`]) within `windows`. A circle outside XY gets none without Z.
pub(crate) fn radial_points(
    circles: &[Circle],
    c: &Circle,
    segment: &[u32],
    pos_m: [&[f64]; 3],
    command: &CommandSeries,
    windows: &CircleWindows,
) -> Vec<(f64, f64)> {
    let mut gathered = gather(circles, segment, pos_m, command, windows);
    let Some(&i) = gathered.by_segment.get(&c.segment) else {
        return Vec::new();
    };
    let lead_m = gathered.leads_m[i];
    let settled = settled(c, gathered.points.swap_remove(i), lead_m);
    settled.points.into_iter().map(|p| c.polar(p)).collect()
}

/// The points of a circle its figures come from.
struct Settled {
    points: Vec<[f64; 2]>,
    /// How far past its start and before its end they leave out (degrees).
    left_out_deg: [f64; 2],
    /// Whether they include the loops' settling at the start and end: its windows left too
    /// few points between them, so every point counts.
    settling_included: bool,
}

/// A circle's points the figures come from: those taken once the loops had settled into
/// the circle, away from its start and end by `lead_m` of commanded path; all of them where
/// those are too few for figures (the circle too short or too sparsely sampled for its
/// loops' settling) — then the figures hold the settling, and say so.
fn settled(c: &Circle, points: PeakThinned<Point>, lead_m: [f64; 2]) -> Settled {
    let all = points.into_points();
    let within: Vec<[f64; 2]> = (all.iter())
        .filter(|p| runs_within(c, p.2, lead_m))
        .map(|p| p.0)
        .collect();
    if within.len() >= MIN_SAMPLES {
        Settled {
            points: within,
            left_out_deg: lead_m.map(|m| (m / c.radius_m).to_degrees()),
            settling_included: false,
        }
    } else {
        Settled {
            // Only windows asked for leave settling out: without them every point is the
            // circle's own (the first, at its start, merely falls on the window's edge).
            settling_included: lead_m.iter().any(|&m| m > 0.0) && within.len() < all.len(),
            points: all.into_iter().map(|p| p.0).collect(),
            left_out_deg: [0.0; 2],
        }
    }
}

/// A point of a path on a circle: where (m), its radial deviation (m), and the path its
/// command had run along the circle then (m), which says whether the loops had settled
/// into the circle there once its windows are known (the end's only after the command has
/// left it).
type Point = ([f64; 2], f64, f64);

/// Where and when a sample was commanded: the plan segment the command lies on, the
/// commanded X, Y and Z (m), and the program time (s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Commanded {
    pub(crate) segment: u32,
    pub(crate) pos_m: [f64; 3],
    pub(crate) t_s: f64,
}

impl Commanded {
    /// Where sample `i` of `commands` is commanded, at program time `t_s`.
    pub(crate) fn of(commands: &crate::plan::Commands, i: usize, t_s: f64) -> Self {
        let at = |a: &crate::plan::AxisCommands| a.pos_m[i];
        Commanded {
            segment: commands.segment[i],
            pos_m: [at(&commands.x), at(&commands.y), at(&commands.z)],
            t_s,
        }
    }
}

/// The commands of a path's samples, axis by axis; `z` may be empty (Z stands).
#[derive(Debug, Clone, Copy)]
pub(crate) struct CommandSeries<'a> {
    pub(crate) segment: &'a [u32],
    pub(crate) pos_m: [&'a [f64]; 3],
}

impl CommandSeries<'_> {
    /// Sample `k`'s command, without its time: the circles' windows are given
    /// ([`CircleWindows`]), and the loops' model that reads the time is not run.
    fn at(&self, k: usize) -> Commanded {
        Commanded {
            segment: self.segment[k],
            pos_m: self.pos_m.map(|v| v.get(k).copied().unwrap_or(0.0)),
            t_s: f64::NAN,
        }
    }
}

/// Whether a command that has run `run_m` along circle `c` lies between `lead_m[0]` past its
/// start and `lead_m[1]` before its end (none left out there where that is zero).
fn runs_within(c: &Circle, run_m: f64, lead_m: [f64; 2]) -> bool {
    run_m > lead_m[0] && (lead_m[1] == 0.0 || run_m < c.length_m - lead_m[1])
}

/// Sample `k` of a path given axis by axis, NaN on an axis that has none there.
fn position(pos_m: [&[f64]; 3], k: usize) -> [f64; 3] {
    pos_m.map(|v| v.get(k).copied().unwrap_or(f64::NAN))
}

impl Circle {
    /// Whether `other` runs round the same circle as this one, in either direction: the same
    /// plane at the same height, the same centre and radius (to a nanometre).
    pub fn is_same_circle(&self, other: &Circle) -> bool {
        const SAME_M: f64 = 1e-9;
        self.plane == other.plane
            && (self.height_m - other.height_m).abs() < SAME_M
            && (self.radius_m - other.radius_m).abs() < SAME_M
            && (self.center_m[0] - other.center_m[0]).hypot(self.center_m[1] - other.center_m[1])
                < SAME_M
    }

    /// A point's polar angle about the programmed centre (rad) and its radial deviation from
    /// the programmed radius (m, outward positive).
    pub(crate) fn polar(&self, p: [f64; 2]) -> (f64, f64) {
        let (dx, dy) = (p[0] - self.center_m[0], p[1] - self.center_m[1]);
        (dy.atan2(dx), dx.hypot(dy) - self.radius_m)
    }
}

/// One circle's figures (µm).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CircleFigures {
    /// The plan segment of the circle: what tells two circles apart where one source line
    /// runs twice (a subprogram called twice), and pairs a circle's figures across paths.
    #[serde(skip)]
    pub segment: usize,
    /// Source line of the circle.
    pub line: u32,
    /// The plane of the circle (`XY`, `ZX`, `YZ`).
    pub plane: Plane,
    /// Where the plane lies along its normal (mm): Z for an XY circle, Y for ZX, X for YZ.
    /// Two circles of one line at different heights (a subprogram called at two depths)
    /// are told apart by it.
    pub height_mm: f64,
    /// `ccw` or `cw`.
    pub direction: &'static str,
    /// Programmed radius (mm).
    pub radius_mm: f64,
    /// Circular deviation G about the least-squares centre.
    pub g_um: f64,
    /// Largest radial deviation F from the programmed circle.
    pub f_max_um: f64,
    /// Smallest (most inward) radial deviation.
    pub f_min_um: f64,
    /// Reversal spike heights at 0°, 90°, 180° and 270° (outward positive); NaN where the
    /// path has too few samples there.
    pub reversal_spikes_um: [f64; 4],
    /// The path's ellipse along the diagonals, as an angle (µrad): the radial deviation's
    /// sin 2θ term b as 2b/R. A squareness error α of Y to X (X reading α·y more) gives α;
    /// a lag of Y behind X gives one whose sign turns with the direction of travel.
    pub diagonal_ellipse_urad: f64,
    /// The path's ellipse along the axes (ppm): the cos 2θ term a as 2a/R, the X scale
    /// reading longer than the Y scale by that much.
    pub scale_mismatch_ppm: f64,
    /// Samples the figures come from.
    pub samples: usize,
    /// How far past its start (degrees of the circle) the figures begin: the commanded path
    /// the loops need to settle into the circle, longer where the commands set off on it
    /// with the loops carrying a lag unlike the circle's own (from rest, straight from a
    /// rapid); left out as a ballbar's overshoot arc is.
    pub start_left_out_deg: f64,
    /// How far before its end (degrees) the figures stop: from where the command last ran
    /// round it at its steady speed (its slowing into the end changes the loops' lag), and
    /// at least five of the loops' time constants at the speed the start's window was read
    /// at (the programmed feed where none was found); at most a quarter turn.
    pub end_left_out_deg: f64,
    /// Whether the figures hold the loops' settling at the circle's start and end: the
    /// windows above left fewer points between them than figures need (a circle too short
    /// or too sparsely sampled for its loops' settling, or a record holding too little of
    /// it), so every point counts and nothing is left out. G then is the path's own band,
    /// not the steady deviation a ballbar's figures describe.
    pub settling_included: bool,
}

/// The hysteresis of a pair of circles run in opposite directions (µm).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Hysteresis {
    /// Line of the counter-clockwise circle.
    pub ccw_line: u32,
    /// The plane of the pair (the `x`/`y` figures are its first and second axes'), written
    /// for every pair as for every circle.
    pub plane: Plane,
    /// Line of the clockwise circle.
    pub cw_line: u32,
    /// Circular hysteresis H.
    pub h_um: f64,
    /// Bidirectional circular deviation: the band holding both paths about their common
    /// least-squares centre.
    pub g_both_um: f64,
    /// Squareness of Y to X (µrad, X reading α·y more): the diagonal ellipse both
    /// directions share.
    pub squareness_urad: f64,
    /// Servo mismatch (ms, Y lagging X positive): the diagonal ellipse that turns with the
    /// direction, over the circle's angular speed at the speed the command runs round it
    /// (the programmed feed or less) — the difference of the axes' lags, as from different
    /// position gains.
    pub servo_mismatch_ms: f64,
    /// Scale mismatch (ppm, X reading longer): the ellipse along the axes both share.
    pub scale_mismatch_ppm: f64,
    /// Straightness of Y's travel seen on X, as `[x.errors] straightness_bow_um` over the
    /// circle's diameter (µm): the cos 3θ term both directions share, times 4.
    pub straightness_x_um: f64,
    /// Straightness of X's travel seen on Y over the diameter (µm): the sin 3θ term, times −4.
    pub straightness_y_um: f64,
    /// Lateral play of X across Y's reversals, as `[x.errors] lateral_play_um` (µm): the
    /// |cos θ| term of the counter-clockwise less the clockwise path.
    pub lateral_play_x_um: f64,
    /// Lateral play of Y across X's reversals (µm): the |sin θ| term of that difference,
    /// negated.
    pub lateral_play_y_um: f64,
    /// Lost motion of X (µm, lagging positive): the radial step across X's reversal points
    /// (0°, 180°) in the direction of travel, outside ±3° of them (where the reversal spike
    /// stands) and within 20°, less the path's local slope; the mean of both points and
    /// directions.
    pub backlash_x_um: f64,
    /// Lost motion of Y across its reversal points (90°, 270°) (µm).
    pub backlash_y_um: f64,
}

/// The figures of every circle, and of every opposite pair.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct CircularTest {
    /// Per circle.
    pub circles: Vec<CircleFigures>,
    /// Per pair of circles on the same centre and radius in opposite directions.
    pub pairs: Vec<Hysteresis>,
}

/// Fewest samples on a circle for figures worth stating.
pub(crate) const MIN_SAMPLES: usize = 36;
/// The circular-test figures of a path: `segment[k]` is the plan segment sample `k` lies
/// nearest to (as the contour search found it), `[x, y, z]` its position (m), `command`
/// where it was commanded. Each circle is measured in its own plane; `z` may be empty (a
/// path without Z), and a circle in ZX or YZ then gets no figures.
pub(crate) fn circular_test(
    circles: &[Circle],
    segment: &[u32],
    pos_m: [&[f64]; 3],
    command: &CommandSeries,
    windows: &CircleWindows,
) -> CircularTest {
    gather(circles, segment, pos_m, command, windows).test().0
}

/// A path's samples on `circles` (as [`circular_test`] takes them), each circle's figures
/// from within `windows`.
fn gather(
    circles: &[Circle],
    segment: &[u32],
    pos_m: [&[f64]; 3],
    command: &CommandSeries,
    windows: &CircleWindows,
) -> CircleSamples {
    let mut gathered = CircleSamples::new(circles.to_vec(), windows.entry);
    gathered.windows_given = true;
    let leads = gathered
        .leads_m
        .iter_mut()
        .zip(&mut gathered.speeds_m_per_s);
    for (c, (lead_m, speed_m_per_s)) in gathered.circles.iter().zip(leads) {
        (*lead_m, *speed_m_per_s) = (windows.by_segment.get(&c.segment))
            .copied()
            .unwrap_or(([0.0; 2], c.feed_m_per_s));
    }
    for (k, &s) in segment.iter().enumerate() {
        gathered.push(s, position(pos_m, k), command.at(k));
    }
    gathered
}

/// The commanded path each circle's figures leave out at its start and end (m), by plan
/// segment, with the speed the command runs round it at (m/s), which the windows were read
/// at and the reversal spikes' tails and the servo mismatch are reckoned at: worked out from
/// the program's commands alone ([`CircleWindows::of`]), so that every path compared on them
/// — a measurement, a model's prediction — leaves out the same.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CircleWindows {
    by_segment: std::collections::HashMap<usize, ([f64; 2], f64)>,
    /// The loops they were worked out for, which also set how far the reversal spikes run.
    entry: EntrySettling,
}

impl CircleWindows {
    /// The windows of `circles` as the loops of `entry` settle into them under `commands`
    /// (the program's, on its clock, from its start), the first `run_in` of which only
    /// move the loops' model: a run-in put before a record's first command, which the
    /// control never gave (its path is no part of a circle's, though it carries the
    /// first command's segment).
    pub(crate) fn of(
        circles: &[Circle],
        commands: &crate::plan::Commands,
        run_in: usize,
        entry: EntrySettling,
    ) -> Self {
        let mut gathered = CircleSamples::new(circles.to_vec(), entry);
        for i in 0..commands.len() {
            let command = Commanded::of(commands, i, commands.time_s(i));
            if i < run_in {
                gathered.run_in(command);
            } else {
                // No position: only the commands are followed.
                gathered.push(command.segment, [f64::NAN; 3], command);
            }
        }
        gathered.close_windows();
        CircleWindows {
            by_segment: (gathered.circles.iter())
                .zip(gathered.leads_m.into_iter().zip(gathered.speeds_m_per_s))
                .map(|(c, lead)| (c.segment, lead))
                .collect(),
            entry,
        }
    }
}

/// Points kept per circle before a long one is thinned (each kept point then the farthest
/// from the programmed radius among its neighbours, so that F and the spikes survive): two
/// minutes of samples at a 2 ms cycle.
const MAX_POINTS: usize = 1 << 16;

/// A circle with the path's points on it.
#[derive(Debug, Clone, PartialEq)]
pub struct CirclePath {
    /// The programmed circle.
    pub circle: Circle,
    /// The path's points on it (m), thinned when the circle is long.
    pub points_m: Vec<[f64; 2]>,
}

/// The samples of a path on each full circle, gathered as they come.
#[derive(Debug, Clone, Default)]
pub struct CircleSamples {
    circles: Vec<Circle>,
    /// Index into `circles` by plan segment.
    by_segment: std::collections::HashMap<usize, usize>,
    /// Points kept per circle: (position m, radial deviation m).
    points: Vec<PeakThinned<Point>>,
    /// How far the command has run along each circle.
    progress: Vec<Progress>,
    /// The commanded path left out at each circle's start and end (m); set once the
    /// command runs at its own speed on the circle, from the entry transient there, the
    /// end's widened once every sample is in ([`CircleSamples::close_windows`]).
    leads_m: Vec<[f64; 2]>,
    /// The speed the command runs round each circle at (m/s), where its windows were read:
    /// the programmed feed until it is found, and where it is not.
    speeds_m_per_s: Vec<f64>,
    /// The loops' settling the leads come from.
    entry: EntrySettling,
    /// Their first-order model following the commands, and the commands' speed on each
    /// circle, which the entry transient is read from.
    entries: Entries,
    /// Whether the windows are given rather than worked out here.
    windows_given: bool,
}

impl CircleSamples {
    /// Gathers the samples on `circles`, each from where the loops of `entry` have settled
    /// into it.
    pub(crate) fn new(circles: Vec<Circle>, entry: EntrySettling) -> Self {
        CircleSamples {
            leads_m: circles.iter().map(|c| [entry.lead_m(c); 2]).collect(),
            speeds_m_per_s: circles.iter().map(|c| c.feed_m_per_s).collect(),
            entry,
            by_segment: circles
                .iter()
                .enumerate()
                .map(|(i, c)| (c.segment, i))
                .collect(),
            points: circles
                .iter()
                .map(|_| PeakThinned::new(MAX_POINTS, |p: &Point| p.1.abs()))
                .collect(),
            progress: vec![Progress::default(); circles.len()],
            entries: Entries::default(),
            windows_given: false,
            circles,
        }
    }

    /// Takes a command the loops' model follows and no circle counts (a run-in).
    fn run_in(&mut self, command: Commanded) {
        if !self.windows_given {
            (self.entries.lag).advance(self.entry.time_constant_s, command.t_s, command.pos_m);
        }
    }

    /// Takes a sample at `pos_m` (X, Y, Z) lying nearest plan segment `segment`, commanded
    /// at `command`. It counts toward a circle while its command runs along that circle
    /// ([`Progress`]) and the path lies nearest that circle (or another pass round the
    /// same one: two circles of one centre and radius are equally near, to the rounding).
    pub(crate) fn push(&mut self, segment: u32, pos_m: [f64; 3], command: Commanded) {
        let working_out = !self.windows_given;
        if working_out {
            (self.entries.lag).advance(self.entry.time_constant_s, command.t_s, command.pos_m);
        }
        let on = self.by_segment.get(&(command.segment as usize)).copied();
        if working_out {
            self.entries.on_circle(on);
        }
        let Some(i) = on else {
            return;
        };
        let c = self.circles[i];
        self.progress[i].advance(&c, command);
        if working_out {
            let entered =
                (self.entries).enter(i, (&self.entry, &c), command, self.progress[i].run_m);
            if let Some((lead_m, speed_m_per_s)) = entered {
                (self.leads_m[i], self.speeds_m_per_s[i]) = (lead_m, speed_m_per_s);
            }
        }
        let pos_m = self.circles[i].plane.coords(pos_m);
        let nearest_on_it = segment as usize == c.segment
            || (self.by_segment.get(&(segment as usize)))
                .is_some_and(|&j| self.circles[j].is_same_circle(&c));
        if !self.progress[i].is_within(&c, [0.0; 2]) || !nearest_on_it {
            return;
        }
        let run_m = self.progress[i].run_m.unwrap_or(0.0);
        if pos_m[0].is_finite() && pos_m[1].is_finite() {
            let radial = self.circles[i].polar(pos_m).1;
            self.points[i].push((pos_m, radial, run_m));
        }
    }

    /// Each circle's end window where the command slowed into its end
    /// ([`Entries::end_lead_m`]), now that every sample is in; given windows stay as given.
    fn close_windows(&mut self) {
        if self.windows_given {
            return;
        }
        for (i, c) in self.circles.iter().enumerate() {
            self.leads_m[i][1] = self.entries.end_lead_m(i, c, self.leads_m[i][1]);
        }
    }

    /// The figures of every circle with enough samples and of every opposite pair, and the
    /// circles with the points they come from.
    pub(crate) fn test(mut self) -> (CircularTest, Vec<CirclePath>) {
        self.close_windows();
        let mut out = CircularTest::default();
        let mut kept: Vec<(Circle, Vec<[f64; 2]>, f64)> = Vec::new();
        let entry = self.entry;
        let gathered = (self.circles.into_iter())
            .zip(self.points)
            .zip(self.leads_m.into_iter().zip(self.speeds_m_per_s));
        for ((c, p), (lead_m, speed_m_per_s)) in gathered {
            let Settled {
                points,
                left_out_deg: [left_out_deg, end_left_out_deg],
                settling_included,
            } = settled(&c, p, lead_m);
            if points.len() >= MIN_SAMPLES {
                let zones = SpikeZones::of(&c, &entry, speed_m_per_s);
                let mut f = figures(&c, &points, zones);
                f.start_left_out_deg = left_out_deg;
                f.end_left_out_deg = end_left_out_deg;
                f.settling_included = settling_included;
                // A quadrant point whose neighbourhood the left-out start and end cut into
                // has no spike the points can measure.
                for (q, spike) in f.reversal_spikes_um.iter_mut().enumerate() {
                    if cut_by_windows(&c, 90.0 * q as f64, [left_out_deg, end_left_out_deg]) {
                        *spike = f64::NAN;
                    }
                }
                out.circles.push(f);
                kept.push((c, points, speed_m_per_s));
            }
        }
        for (i, (a, pa, va)) in kept.iter().enumerate() {
            let partner = kept[i + 1..]
                .iter()
                .find(|(b, _, _)| b.ccw != a.ccw && b.is_same_circle(a));
            if let Some((b, pb, vb)) = partner {
                let (ccw, cw) = if a.ccw {
                    ((a, pa, *va), (b, pb, *vb))
                } else {
                    ((b, pb, *vb), (a, pa, *va))
                };
                out.pairs.push(hysteresis(ccw, cw, &entry));
            }
        }
        let paths = kept
            .into_iter()
            .map(|(circle, points_m, _)| CirclePath { circle, points_m })
            .collect();
        (out, paths)
    }
}

/// G, F, the reversal spikes and the ellipses of one circle's points.
fn figures(c: &Circle, p: &[[f64; 2]], zones: SpikeZones) -> CircleFigures {
    let center = least_squares_center(p).unwrap_or(c.center_m);
    let (lo, hi) = radial_range(p, center, 0.0);
    let (f_min, f_max) = radial_range(p, c.center_m, c.radius_m);
    let h = harmonics(p, center, zones);
    let (along_axes, along_diagonals) = (h.cos2(), h.sin2());
    CircleFigures {
        segment: c.segment,
        line: c.line,
        plane: c.plane,
        height_mm: mm_from_m(c.height_m),
        direction: if c.ccw { "ccw" } else { "cw" },
        radius_mm: mm_from_m(c.radius_m),
        g_um: um_from_m(hi - lo),
        f_max_um: um_from_m(f_max),
        f_min_um: um_from_m(f_min),
        reversal_spikes_um: reversal_spikes(c, p),
        diagonal_ellipse_urad: 2.0 * along_diagonals / c.radius_m * 1e6,
        scale_mismatch_ppm: 2.0 * along_axes / c.radius_m * 1e6,
        samples: p.len(),
        start_left_out_deg: 0.0,
        end_left_out_deg: 0.0,
        settling_included: false,
    }
}

/// The radial deviation's 2θ and 3θ terms (m).
#[derive(Debug, Clone, Copy, Default)]
struct Harmonics {
    /// Constant, cos θ, sin θ, cos 2θ, sin 2θ, cos 3θ, sin 3θ.
    coef: [f64; 7],
}

impl Harmonics {
    /// The basis at the angle whose cosine and sine are `c`, `s` (multiple angles by their
    /// identities: no trigonometry per point).
    fn basis(c: f64, s: f64) -> nalgebra::SVector<f64, 7> {
        nalgebra::SVector::<f64, 7>::from([
            1.0,
            c,
            s,
            c * c - s * s,
            2.0 * c * s,
            c * (4.0 * c * c - 3.0),
            s * (3.0 - 4.0 * s * s),
        ])
    }

    /// The fitted radius at the angle whose cosine and sine are `c`, `s`.
    fn at(&self, c: f64, s: f64) -> f64 {
        Harmonics::basis(c, s)
            .iter()
            .zip(&self.coef)
            .map(|(b, k)| b * k)
            .sum()
    }

    fn cos2(&self) -> f64 {
        self.coef[3]
    }
    fn sin2(&self) -> f64 {
        self.coef[4]
    }
    fn cos3(&self) -> f64 {
        self.coef[5]
    }
    fn sin3(&self) -> f64 {
        self.coef[6]
    }
}

/// The radius about `center` up to its 3θ terms, fitted by least squares (the once-per-turn
/// terms take up a centre slightly off) outside the reversal spikes' `zones`: four spikes
/// of one height cancel in the 2θ terms, but a circle whose start or end is left out keeps
/// three, and friction's spikes would read as an ellipse of their own (tens of ppm on a
/// small circle).
fn harmonics(p: &[[f64; 2]], center: [f64; 2], zones: SpikeZones) -> Harmonics {
    let mut ata = nalgebra::SMatrix::<f64, 7, 7>::zeros();
    let mut atb = nalgebra::SVector::<f64, 7>::zeros();
    for q in p {
        let (dx, dy) = (q[0] - center[0], q[1] - center[1]);
        let r = dx.hypot(dy);
        if r == 0.0 || zones.contains(dy.atan2(dx).to_degrees()) {
            continue;
        }
        let row = Harmonics::basis(dx / r, dy / r);
        ata += row * row.transpose();
        atb += row * r;
    }
    Harmonics {
        coef: ata.lu().solve(&atb).map_or([0.0; 7], |c| c.into()),
    }
}

/// The smallest and largest distance from `center`, less `radius` (m).
fn radial_range(p: &[[f64; 2]], center: [f64; 2], radius: f64) -> (f64, f64) {
    p.iter()
        .map(|q| (q[0] - center[0]).hypot(q[1] - center[1]) - radius)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), r| {
            (l.min(r), h.max(r))
        })
}

/// The centre of the circle that fits the points best (algebraic least squares: the
/// circle x² + y² + D x + E y + F = 0 with the smallest squared residual, which for a
/// path within micrometres of a circle is the geometric best fit to far below them).
/// Coordinates are taken about the points' mean, for conditioning.
fn least_squares_center(p: &[[f64; 2]]) -> Option<[f64; 2]> {
    let n = p.len() as f64;
    let mean = [
        p.iter().map(|q| q[0]).sum::<f64>() / n,
        p.iter().map(|q| q[1]).sum::<f64>() / n,
    ];
    let mut ata = Matrix3::<f64>::zeros();
    let mut atb = Vector3::<f64>::zeros();
    for q in p {
        let (x, y) = (q[0] - mean[0], q[1] - mean[1]);
        let row = Vector3::new(x, y, 1.0);
        ata += row * row.transpose();
        atb += row * -(x * x + y * y);
    }
    let s = ata.lu().solve(&atb)?;
    Some([mean[0] - 0.5 * s[0], mean[1] - 0.5 * s[1]])
}

/// H, the bidirectional G, squareness and servo mismatch of two opposite circles, each with
/// its points and the speed the command runs round it at (m/s).
fn hysteresis(
    ccw: (&Circle, &Vec<[f64; 2]>, f64),
    cw: (&Circle, &Vec<[f64; 2]>, f64),
    entry: &EntrySettling,
) -> Hysteresis {
    let zones = |(c, _, speed_m_per_s): (&Circle, &Vec<[f64; 2]>, f64)| {
        SpikeZones::of(c, entry, speed_m_per_s)
    };
    let terms = |run: (&Circle, &Vec<[f64; 2]>, f64)| {
        let (c, p) = (run.0, run.1);
        harmonics(p, least_squares_center(p).unwrap_or(c.center_m), zones(run))
    };
    let (h_ccw, h_cw) = (terms(ccw), terms(cw));
    // Each ellipse as 2·term/R: along the axes, along the diagonals.
    let r = ccw.0.radius_m;
    let (s_ccw, t_ccw) = (2.0 * h_ccw.cos2() / r, 2.0 * h_ccw.sin2() / r);
    let (s_cw, t_cw) = (2.0 * h_cw.cos2() / r, 2.0 * h_cw.sin2() / r);
    // A lag Δτ of Y behind X tilts the ellipse by −ω·Δτ counter-clockwise and +ω'·Δτ
    // clockwise (ω, ω' = v/R at the speed v each runs at, which a feed override or the
    // acceleration on a small radius holds below the feed); squareness tilts both alike.
    let omega_sum = [ccw, cw]
        .map(|(c, _, speed_m_per_s)| running_or_feed(c, speed_m_per_s) / c.radius_m)
        .iter()
        .sum::<f64>();
    let both: Vec<[f64; 2]> = ccw.1.iter().chain(cw.1.iter()).copied().collect();
    let center = least_squares_center(&both).unwrap_or(ccw.0.center_m);
    let (lo, hi) = radial_range(&both, center, 0.0);
    // Mean radius per 1° bin of each direction.
    let bins = |p: &[[f64; 2]]| {
        let mut sum = vec![(0.0, 0usize); 360];
        for q in p {
            let (dx, dy) = (q[0] - center[0], q[1] - center[1]);
            let bin = (dy.atan2(dx).to_degrees().rem_euclid(360.0) as usize).min(359);
            sum[bin].0 += dx.hypot(dy);
            sum[bin].1 += 1;
        }
        sum
    };
    let (a, b) = (bins(ccw.1), bins(cw.1));
    // The counter-clockwise path's radius less the clockwise one's, per degree.
    let difference: Vec<(f64, f64)> = a
        .iter()
        .zip(&b)
        .enumerate()
        .filter(|(_, (x, y))| x.1 > 0 && y.1 > 0)
        .map(|(deg, (x, y))| {
            let theta = (deg as f64 + 0.5).to_radians();
            (theta, x.0 / x.1 as f64 - y.0 / y.1 as f64)
        })
        .collect();
    let h = difference.iter().map(|d| d.1.abs()).fold(0.0, f64::max);
    let (play_x, play_y) = lateral_play(&difference);
    // Each path's smooth shape about the programmed centre, which the steps are taken on.
    let paths = [ccw, cw].map(|run| (run.0, run.1, harmonics(run.1, run.0.center_m, zones(run))));
    let lost_motion = |quadrants: [f64; 2]| {
        let steps: Vec<f64> = paths
            .iter()
            .flat_map(|(c, p, smooth)| quadrants.map(|q| step_across(c, p, smooth, q)))
            .flatten()
            .collect();
        steps.iter().sum::<f64>() / steps.len().max(1) as f64
    };
    Hysteresis {
        ccw_line: ccw.0.line,
        plane: ccw.0.plane,
        cw_line: cw.0.line,
        h_um: um_from_m(h),
        g_both_um: um_from_m(hi - lo),
        squareness_urad: 0.5 * (t_ccw + t_cw) * 1e6,
        scale_mismatch_ppm: 0.5 * (s_ccw + s_cw) * 1e6,
        servo_mismatch_ms: if omega_sum > 0.0 {
            (t_cw - t_ccw) / omega_sum * 1e3
        } else {
            f64::NAN
        },
        straightness_x_um: um_from_m(2.0 * (h_ccw.cos3() + h_cw.cos3())),
        straightness_y_um: um_from_m(-2.0 * (h_ccw.sin3() + h_cw.sin3())),
        lateral_play_x_um: um_from_m(play_x),
        lateral_play_y_um: um_from_m(play_y),
        backlash_x_um: um_from_m(lost_motion([0.0, 180.0])),
        backlash_y_um: um_from_m(lost_motion([90.0, 270.0])),
    }
}

/// Lateral play of X and of Y (m) from the counter-clockwise less the clockwise radius
/// (angle rad, m): X's play p adds p·|cos θ| to it and Y's play q takes q·|sin θ| from it,
/// fitted together with a constant and the sin 2θ term a servo mismatch leaves.
fn lateral_play(difference: &[(f64, f64)]) -> (f64, f64) {
    let mut ata = nalgebra::SMatrix::<f64, 4, 4>::zeros();
    let mut atb = nalgebra::SVector::<f64, 4>::zeros();
    for &(theta, d) in difference {
        let row = nalgebra::SVector::<f64, 4>::new(
            1.0,
            (2.0 * theta).sin(),
            theta.cos().abs(),
            theta.sin().abs(),
        );
        ata += row * row.transpose();
        atb += row * d;
    }
    match ata.lu().solve(&atb) {
        Some(c) if difference.len() >= 90 => (c[2], -c[3]),
        _ => (f64::NAN, f64::NAN),
    }
}

impl CircularTest {
    /// The figures as text, one circle a line, prefixed with `label` (e.g. "predicted").
    pub(crate) fn text(&self) -> String {
        let mut s = String::new();
        for c in &self.circles {
            let spikes: Vec<String> = c
                .reversal_spikes_um
                .iter()
                .map(|v| {
                    if v.is_finite() {
                        format!("{v:+.1}")
                    } else {
                        "—".into()
                    }
                })
                .collect();
            s.push_str(&format!(
                "  line {:>4} {:<3} R{:<8} {}G {:>7.2} µm   F {:+.2} / {:+.2} µm   reversal spikes 0/90/180/270°: {} µm{}\n",
                c.line,
                c.direction,
                // To the µm, as the plots give it: the arc's end-point rounding is no radius.
                format!("{}", (c.radius_mm * 1e3).round() / 1e3),
                plane_label(c.plane),
                c.g_um,
                c.f_max_um,
                c.f_min_um,
                spikes.join(" "),
                if c.settling_included {
                    SETTLING_INCLUDED_TEXT.to_string()
                } else {
                    left_out_text(c.start_left_out_deg, c.end_left_out_deg)
                }
            ));
        }
        for p in &self.pairs {
            let [a, b, _] = p.plane.axes().map(|i| ['X', 'Y', 'Z'][i]);
            s.push_str(&format!(
                "  lines {} and {}{}: hysteresis H {:.2} µm, both directions G {:.2} µm, squareness \
                 {:+.1} µrad, servo mismatch {:+.2} ms, scale mismatch {:+.1} ppm\n    \
                 straightness {a}/{b} {:+.2} / {:+.2} µm, lateral play {a}/{b} {:+.2} / {:+.2} µm, \
                 backlash {a}/{b} {:+.2} / {:+.2} µm\n",
                p.ccw_line,
                p.cw_line,
                if p.plane.is_xy() {
                    String::new()
                } else {
                    format!(" ({} plane, {})", p.plane.name(), p.plane.gcode())
                },
                p.h_um,
                p.g_both_um,
                p.squareness_urad,
                p.servo_mismatch_ms,
                p.scale_mismatch_ppm,
                p.straightness_x_um,
                p.straightness_y_um,
                p.lateral_play_x_um,
                p.lateral_play_y_um,
                p.backlash_x_um,
                p.backlash_y_um
            ));
        }
        s
    }
}

/// What a circle's line says where its figures hold the loops' settling.
const SETTLING_INCLUDED_TEXT: &str =
    "   (its start and end counted: too few samples between the loops' settling to leave it out)";

/// What a circle's line says of the arcs its figures leave out at its start and end (deg):
/// one angle where both are alike, both where the start's is longer (a table that set off
/// on the circle far off it); nothing where none is left out.
fn left_out_text(start_deg: f64, end_deg: f64) -> String {
    if start_deg <= 0.05 {
        String::new()
    } else if (start_deg - end_deg).abs() < 0.05 {
        format!("   ({start_deg:.1}° at its start and end left out: the loops settling)")
    } else {
        format!(
            "   ({start_deg:.1}° at its start and {end_deg:.1}° at its end left out: the loops settling)"
        )
    }
}

/// A circle's plane as its figures' line names it: nothing for XY, `ZX (G18) ` otherwise.
fn plane_label(plane: Plane) -> String {
    if plane.is_xy() {
        String::new()
    } else {
        format!("{} ({}) ", plane.name(), plane.gcode())
    }
}

#[cfg(test)]
mod tests;
