//! Hotspots: the places along a run where the contour error matters, each with its G-code
//! line, position, time, magnitude and cause.
//!
//! Causes are found from events, not guessed from the error curve: an axis reversal (the
//! commanded velocity of X or Y changes sign during a cut — a quadrant crossing on a circle)
//! or start from rest (an axis that stood longer than its loop takes to settle starts
//! again), labelled backlash when the nut actually crossed its gap there; a corner (a
//! junction whose tangent turns by more than a few degrees); a feed change between blocks;
//! stick-slip (an axis switching between stick and slip repeatedly while moving slowly).
//! Each event opens a window — from just before it to a few position-loop time constants
//! after — and the hotspot is the largest contour error in it. Overlapping windows merge
//! into one hotspot. A window whose peak does not stand out from the error just before it
//! is a plateau, named by the steady effect that explains it (servo mismatch, backlash
//! offset, steady lag: [`hotspot_cause`](super::hotspot_cause)); so is the largest error
//! where it lies outside every window. Rows of one plateau are merged with their extent
//! ([`hotspot_merge`](super::hotspot_merge)); the list is ranked by magnitude.
//!
//! The finder takes a run sample by sample and keeps only the last couple of seconds: an
//! event is known at most a little over a second after its sample (a reversal's backlash
//! once the nut has had half a second to cross its gap, a stick-slip episode once its
//! second of toggles is complete), so windows are opened, merged and closed that long
//! behind the newest sample, whatever the run's length.

use std::cmp::Reverse;
use std::collections::{BinaryHeap, VecDeque};

use serde::Serialize;

pub use super::hotspot_cause::{AxisSteady, Cause};
use super::hotspot_cause::{junction_cause, plateau_cause};
pub use super::hotspot_merge::Extent;
use crate::machine::AxisName;
use crate::path::{Motion, Segment};
use crate::plan::Plan;

/// One hotspot.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Hotspot {
    /// Sample index of the peak.
    pub sample: usize,
    /// Time of the peak (s).
    pub t_s: f64,
    /// Actual X at the peak (mm).
    pub x_mm: f64,
    /// Actual Y at the peak (mm).
    pub y_mm: f64,
    /// Actual Z at the peak (mm), where Z is simulated.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub z_mm: Option<f64>,
    /// Source line of the nearest block.
    pub line: u32,
    /// Signed contour error at the peak (µm).
    pub error_um: f64,
    /// Path length of the peak's foot point from the program start (mm).
    #[serde(skip)]
    pub path_mm: f64,
    /// How far the error departs from its level just before the event (µm): the size of
    /// the spike or jump, as opposed to the steady lag it sits on.
    pub excess_um: f64,
    /// Cause.
    pub cause: Cause,
    /// The stretch the row stands for where near-identical rows of one plateau were merged
    /// into it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub extent: Option<Extent>,
    /// The stretch of uninterrupted cutting the peak lies on (for merging).
    #[serde(skip)]
    pub stretch: u32,
}

impl Hotspot {
    /// The cause as tables give it, with the extent of a merged plateau: `steady lag (4
    /// places, t 53.5–72.4 s)`.
    pub(crate) fn label(&self) -> String {
        match self.extent {
            Some(e) if e.places > 1 => format!(
                "{} ({} places, t {:.1}–{:.1} s)",
                self.cause.label(),
                e.places,
                e.from_t_s,
                e.to_t_s
            ),
            _ => self.cause.label(),
        }
    }
}

/// The smallest contour error a hotspot can have (µm): below it the report would list
/// places whose error rounds to nothing.
pub const HOTSPOT_FLOOR_UM: f64 = 0.05;

/// Hotspot detection settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HotspotConfig {
    /// Window before an event (s).
    pub before_s: f64,
    /// Window after an event (s); by default five position-loop time constants.
    pub after_s: f64,
    /// Tangent turn that makes a junction a corner (degrees).
    pub corner_deg: f64,
    /// Below this axis speed a stick–slip toggle counts toward stick-slip (m/s).
    pub slow_m_per_s: f64,
    /// Toggles within a second that make an episode stick-slip.
    pub stick_slip_toggles: usize,
    /// Whether Z is simulated: its events count, hotspots give its position and corners
    /// turn in space on blocks measured in space.
    pub with_z: bool,
}

impl HotspotConfig {
    /// Defaults for a position-loop gain `kv_per_s` (1/s).
    pub(crate) fn for_kv(kv_per_s: f64) -> Self {
        HotspotConfig {
            before_s: 0.02,
            after_s: 5.0 / kv_per_s,
            corner_deg: 3.0,
            slow_m_per_s: 20.0 / 60_000.0,
            stick_slip_toggles: 4,
            with_z: false,
        }
    }
}

/// What the finder is told about one sample of a run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunSample {
    /// Time (s).
    pub t_s: f64,
    /// Actual X and Y (m).
    pub pos_m: [f64; 2],
    /// Actual Z (m).
    pub z_m: f64,
    /// Contour error (m), NaN while not cutting.
    pub error_m: f64,
    /// Path length of the contour error's foot point (m).
    pub path_s_m: f64,
    /// The plan segment being commanded.
    pub segment: u32,
    /// Commanded X, Y and Z velocity (m/s).
    pub cmd_vel_m_per_s: [f64; 3],
    /// Commanded X, Y and Z acceleration (m/s²).
    pub cmd_acc_m_per_s2: [f64; 3],
    /// X, Y and Z mode codes ([`crate::sim::Mode::code`]); Z's is read only where Z is
    /// simulated.
    pub mode: [u8; 3],
}

/// A place in a run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunPlace {
    /// Sample index.
    pub sample: usize,
    /// Time (s).
    pub t_s: f64,
    /// Actual X and Y (m).
    pub pos_m: [f64; 2],
    /// Source line of the block being executed.
    pub line: u32,
}

/// A sample as the finder keeps it.
#[derive(Debug, Clone, Copy)]
struct Kept {
    k: usize,
    t_s: f64,
    pos_m: [f64; 2],
    z_m: f64,
    error_m: f64,
    path_s_m: f64,
    line: u32,
    mode: [u8; 3],
    cmd_vel: [f64; 3],
    stretch: u32,
}

/// A reversal or start from rest waiting to learn whether the nut crosses its gap.
#[derive(Debug, Clone, Copy)]
struct Reversal {
    k: usize,
    axis: AxisName,
    gap_crossed: bool,
    /// The axis had stood still (a start from rest, not a reversal in motion).
    from_rest: bool,
}

/// An event's window, while it may still grow.
#[derive(Debug, Clone, Copy)]
struct Window {
    hi: usize,
    cause: Cause,
    /// The contour error's level just before the window (m).
    level_m: f64,
    /// The largest |error| so far and where.
    peak: Option<Kept>,
    /// The error at the window's last cutting sample so far (m): where a plateau the event
    /// stepped into goes on.
    tail_m: f64,
    /// Samples before this one (from the window's start on) are in `peak`.
    scanned_to: usize,
}

/// A plateau row followed past its event's window, for as long as the error stays on the
/// level it stepped to, so that the row holds the plateau's largest error rather than the
/// window's share of it.
#[derive(Debug, Clone)]
struct Follow {
    spot: Hotspot,
    /// The cause of the event that flagged it: the row's again if the level does not last.
    event_cause: Cause,
    /// The sample of the window's peak, where the level is first reached.
    from_k: usize,
    /// The plateau goes on while the error, of this sign, stays above this (m).
    floor_m: f64,
    /// The level before the window the spike is measured from (m).
    level_m: f64,
    /// Samples before this one are followed.
    scanned_to: usize,
}

/// Stick-slip toggles of one axis waiting for their second to complete.
#[derive(Debug, Clone, Default)]
struct Toggles {
    pending: VecDeque<usize>,
    /// Toggles up to here belong to an episode already reported.
    skip_until: Option<usize>,
}

/// Finds the hotspots of a run given sample by sample.
#[derive(Debug, Clone)]
pub struct HotspotFinder {
    cfg: HotspotConfig,
    max: usize,
    axes: [AxisSteady; 3],
    /// Window before and after an event, the level's span, half a second, a second
    /// (samples).
    before: usize,
    after: usize,
    level_span: usize,
    half_second: usize,
    second: usize,
    /// An event is known at most this many samples after its own.
    delay: usize,
    /// Samples taken so far.
    n: usize,
    recent: VecDeque<Kept>,
    last_sign: [f64; 3],
    /// Since when each axis's command has stood still (sample; before the run, the axes
    /// stood), while it does.
    still_since: [Option<i64>; 3],
    /// The current stretch of uninterrupted cutting.
    stretch: u32,
    reversals: Vec<Reversal>,
    next_junction: usize,
    toggles: [Toggles; 3],
    events: BinaryHeap<Reverse<(usize, u64, Cause)>>,
    event_seq: u64,
    open: Option<Window>,
    follow: Option<Follow>,
    spots: Vec<Hotspot>,
    largest: Option<Kept>,
    /// The error's level just before the largest (m), for its spike.
    largest_level_m: f64,
    largest_window_peak_m: f64,
}

impl HotspotFinder {
    /// A finder keeping at most `max` hotspots, for a run sampled every `dt_s` on axes
    /// whose steady lag, offset and backlash are `axes` (X, Y, Z; Z's read only where
    /// `cfg.with_z`).
    pub(crate) fn new(cfg: HotspotConfig, axes: [AxisSteady; 3], dt_s: f64, max: usize) -> Self {
        let samples = |s: f64| (s / dt_s).ceil() as usize;
        let (before, after) = (samples(cfg.before_s), samples(cfg.after_s));
        let (half_second, second) = ((0.5 / dt_s) as usize, (1.0 / dt_s) as usize);
        HotspotFinder {
            cfg,
            max,
            axes,
            before,
            after,
            level_span: before.max(1) * 5,
            half_second,
            second,
            delay: (second + half_second + 3).max(after + 1),
            n: 0,
            recent: VecDeque::new(),
            last_sign: [0.0; 3],
            still_since: [Some(-(after as i64)); 3],
            stretch: 0,
            reversals: Vec::new(),
            next_junction: 1,
            toggles: Default::default(),
            events: BinaryHeap::new(),
            event_seq: 0,
            open: None,
            follow: None,
            spots: Vec::new(),
            largest: None,
            largest_level_m: 0.0,
            largest_window_peak_m: 0.0,
        }
    }

    /// Takes the next sample of the run.
    pub(crate) fn push(&mut self, plan: &Plan, s: &RunSample) {
        let k = self.n;
        let seg = s.segment as usize;
        let cutting = plan.segments[seg].motion == Motion::Feed;
        let prev = self.recent.back().copied();
        let prev_mode = prev.map(|p| p.mode);
        self.note_junctions(&plan.segments, plan, seg, k);
        // Leaving the contour (a rapid, a plunge) ends a stretch too.
        if !s.error_m.is_finite() && prev.is_some_and(|p| p.error_m.is_finite()) {
            self.stretch += 1;
        }
        let kept = Kept {
            k,
            t_s: s.t_s,
            pos_m: s.pos_m,
            z_m: s.z_m,
            error_m: s.error_m,
            path_s_m: s.path_s_m,
            line: plan.segments.get(seg).map_or(0, |g| g.line),
            mode: s.mode,
            // Z's speed counts towards a plateau's cause only where Z is simulated.
            cmd_vel: if self.cfg.with_z {
                s.cmd_vel_m_per_s
            } else {
                [s.cmd_vel_m_per_s[0], s.cmd_vel_m_per_s[1], 0.0]
            },
            stretch: self.stretch,
        };
        if s.error_m.is_finite()
            && self
                .largest
                .is_none_or(|m| s.error_m.abs() > m.error_m.abs())
        {
            self.largest = Some(kept);
            self.largest_level_m = level_before(&self.recent, k, self.level_span);
        }
        self.recent.push_back(kept);
        self.n += 1;
        self.note_reversals(s, k, cutting);
        if let Some(prev) = prev_mode {
            self.note_toggles(s, prev, k, cutting);
        }
        self.settle(false);
    }

    /// The largest |contour error| so far (m), and where it is (the first such place).
    pub(crate) fn largest(&self) -> Option<(f64, RunPlace)> {
        self.largest.map(|m| {
            let place = RunPlace {
                sample: m.k,
                t_s: m.t_s,
                pos_m: m.pos_m,
                line: m.line,
            };
            (m.error_m.abs(), place)
        })
    }

    /// The hotspots of the whole run, ranked by |error|.
    pub(crate) fn finish(mut self) -> Vec<Hotspot> {
        self.settle(true);
        if let Some(m) = self.largest
            && m.error_m.abs() > self.largest_window_peak_m
        {
            // Outside every window: a plateau, named by what explains it there.
            let cause = plateau_cause(m.error_m, m.cmd_vel, &self.axes);
            let mut h = hotspot(&m, cause, self.cfg.with_z);
            h.excess_um = (m.error_m - self.largest_level_m).abs() * 1e6;
            self.spots.push(h);
        }
        self.rank();
        self.spots
    }

    /// Sign changes of an axis's commanded velocity during cuts, and starts after it stood
    /// still: a start from rest where it stood longer than the window after an event (five
    /// of the loop's time constants: its lag has gone), a reversal otherwise — also across a
    /// brief stop, since the nut must cross its gap and static friction must break however
    /// short the stop (where either coincides with a corner, the corner names the place).
    fn note_reversals(&mut self, s: &RunSample, k: usize, cutting: bool) {
        for &axis in self.event_axes() {
            let a = axis.index();
            let v = s.cmd_vel_m_per_s[a];
            // Ignore the speed noise of a standing axis.
            if v.abs() < 1e-9 {
                if s.cmd_acc_m_per_s2[a].abs() < 1e-9 {
                    self.still_since[a].get_or_insert(k as i64);
                }
                continue;
            }
            let rested = self.still_since[a]
                .take()
                .is_some_and(|since| k as i64 - since >= self.after as i64);
            let sign = v.signum();
            let last = self.last_sign[a];
            if cutting && (rested || (last != 0.0 && sign != last)) {
                // Whether the nut is free in its gap from two samples before on.
                let gap_crossed = self
                    .recent
                    .iter()
                    .rev()
                    .take(3)
                    .any(|p| nut_free(p.mode[a]));
                self.reversals.push(Reversal {
                    k,
                    axis,
                    gap_crossed,
                    from_rest: rested,
                });
            }
            self.last_sign[a] = sign;
        }
    }

    /// Corners, feed changes and settling at the junctions the run has just passed.
    fn note_junctions(&mut self, segments: &[Segment], plan: &Plan, seg: usize, k: usize) {
        while self.next_junction < segments.len() && seg >= self.next_junction {
            let i = self.next_junction;
            self.next_junction += 1;
            let cause = junction_cause(segments, plan, i, &self.cfg);
            let (a, b) = (&segments[i - 1], &segments[i]);
            if matches!(cause, Some(Cause::Corner | Cause::Settling))
                || a.motion != b.motion
                || a.is_dwell()
                || b.is_dwell()
            {
                self.stretch += 1;
            }
            if let Some(cause) = cause {
                self.event(k, cause);
            }
        }
    }

    /// Stick/slip toggles while an axis moves slowly in a cut.
    fn note_toggles(&mut self, s: &RunSample, prev_mode: [u8; 3], k: usize, cutting: bool) {
        for &axis in self.event_axes() {
            let a = axis.index();
            let v = s.cmd_vel_m_per_s[a].abs();
            let slow = v > 0.0 && v < self.cfg.slow_m_per_s;
            if slow && cutting && stuck(s.mode[a]) != stuck(prev_mode[a]) {
                self.toggles[a].pending.push_back(k);
            }
        }
    }

    /// The axes whose events count: X and Y, and Z where it is simulated.
    fn event_axes(&self) -> &'static [AxisName] {
        if self.cfg.with_z {
            &AxisName::ALL
        } else {
            &AxisName::BOTH
        }
    }

    fn event(&mut self, sample: usize, cause: Cause) {
        self.events.push(Reverse((sample, self.event_seq, cause)));
        self.event_seq += 1;
    }

    /// Decides what can be decided, opens and closes windows, and forgets old samples;
    /// `at_end`: the run is complete.
    fn settle(&mut self, at_end: bool) {
        self.decide_reversals(at_end);
        for &axis in self.event_axes() {
            self.decide_episodes(axis, at_end);
        }
        while let Some(&Reverse((sample, _, cause))) = self.events.peek() {
            if !at_end && sample + self.delay >= self.n {
                break;
            }
            self.events.pop();
            self.window_for(sample, cause);
        }
        if let Some(w) = &mut self.open {
            scan(w, &self.recent);
        }
        if at_end && let Some(w) = self.open.take() {
            self.close(w);
        }
        self.follow_plateau(at_end);
        self.forget_old();
    }

    /// Follows the plateau row along the samples kept, to where the error leaves its level,
    /// the stretch ends or the run does; then the row is final.
    fn follow_plateau(&mut self, at_end: bool) {
        let Some(f) = &mut self.follow else {
            return;
        };
        let Some(front) = self.recent.front() else {
            return;
        };
        let sign = f.spot.error_um.signum();
        let mut ended = at_end;
        let from = f.scanned_to.max(front.k);
        for p in self.recent.range(from - front.k..) {
            let on = p.error_m.is_finite()
                && p.stretch == f.spot.stretch
                && p.error_m * sign >= f.floor_m;
            if !on {
                ended = true;
                break;
            }
            if p.error_m.abs() * 1e6 > f.spot.error_um.abs() {
                let mut h = hotspot(p, f.spot.cause, self.cfg.with_z);
                h.excess_um = (p.error_m - f.level_m).abs() * 1e6;
                f.spot = h;
            }
            f.scanned_to = p.k + 1;
        }
        if ended && let Some(f) = self.follow.take() {
            self.end_follow(f);
        }
    }

    /// A followed row is final: a plateau where the level lasted as long as an event's
    /// window at least, else a spike that only decays slowly (an integrator winding its
    /// current back) — the event's.
    fn end_follow(&mut self, f: Follow) {
        let mut spot = f.spot;
        if f.scanned_to.saturating_sub(f.from_k) < self.before + self.after {
            spot.cause = f.event_cause;
        }
        self.largest_window_peak_m = self.largest_window_peak_m.max(spot.error_um.abs() * 1e-6);
        self.push_spot(spot);
    }

    fn push_spot(&mut self, h: Hotspot) {
        self.spots.push(h);
        if self.spots.len() > 2 * self.max + 64 {
            self.rank();
        }
    }

    /// A reversal is backlash when the nut was free in its gap within half a second.
    fn decide_reversals(&mut self, at_end: bool) {
        let newest = self.recent.back().map(|p| p.mode);
        let (n, half) = (self.n, self.half_second);
        let mut decided = Vec::new();
        self.reversals.retain_mut(|r| {
            if let Some(mode) = newest
                && nut_free(mode[r.axis.index()])
            {
                r.gap_crossed = true;
            }
            let done = at_end || n >= r.k + half;
            if done {
                decided.push(*r);
            }
            !done
        });
        for r in decided {
            let cause = if self.axes[r.axis.index()].backlash_m > 0.0 && r.gap_crossed {
                Cause::Backlash { axis: r.axis }
            } else if r.from_rest {
                Cause::StartFromRest { axis: r.axis }
            } else {
                Cause::AxisReversal { axis: r.axis }
            };
            self.event(r.k, cause);
        }
    }

    /// An episode: enough toggles within one second; one event per episode.
    fn decide_episodes(&mut self, axis: AxisName, at_end: bool) {
        let (second, needed) = (self.second, self.cfg.stick_slip_toggles);
        let newest = self.n.saturating_sub(1);
        let mut found = Vec::new();
        let t = &mut self.toggles[axis.index()];
        while let Some(&t0) = t.pending.front() {
            // Every toggle within the second after t0 must be known.
            if !at_end && newest < t0 + second {
                break;
            }
            t.pending.pop_front();
            if t.skip_until.is_some_and(|u| t0 <= u) {
                continue;
            }
            let within: Vec<usize> = std::iter::once(t0)
                .chain(t.pending.iter().copied())
                .take_while(|&k| k - t0 <= second)
                .collect();
            if within.len() >= needed {
                found.push(t0);
                t.skip_until = within.last().map(|&end| end + second);
            }
        }
        for k in found {
            self.event(k, Cause::StickSlip { axis });
        }
    }

    /// Opens a window for an event, or merges it into the open one; the earliest event names
    /// a merged window, except that a more specific cause outranks it.
    fn window_for(&mut self, sample: usize, cause: Cause) {
        let lo = sample.saturating_sub(self.before);
        let hi = sample + self.after;
        if let Some(w) = &mut self.open
            && lo <= w.hi
        {
            w.hi = w.hi.max(hi);
            if cause.priority() > w.cause.priority() {
                w.cause = cause;
            }
            return;
        }
        if let Some(w) = self.open.take() {
            self.close(w);
        }
        self.open = Some(Window {
            hi,
            cause,
            level_m: level_before(&self.recent, lo, self.level_span),
            peak: None,
            tail_m: f64::NAN,
            scanned_to: lo,
        });
    }

    /// A window whose extent is final becomes a hotspot at its largest error.
    fn close(&mut self, mut w: Window) {
        scan(&mut w, &self.recent);
        let Some(peak) = w.peak else {
            return;
        };
        self.largest_window_peak_m = self.largest_window_peak_m.max(peak.error_m.abs());
        let mut h = hotspot(&peak, w.cause, self.cfg.with_z);
        h.excess_um = (h.error_um - w.level_m * 1e6).abs();
        // No spike above the local level before, or none falling back from the level it
        // stepped to (the error at the window's end still within a tenth of the peak): the
        // place is flagged by an event, but its error is a plateau, named by the steady
        // effect that explains it.
        let flat_before = h.excess_um < 0.1 * h.error_um.abs();
        let stays = w.tail_m * peak.error_m > 0.0 && w.tail_m.abs() >= 0.9 * peak.error_m.abs();
        if !(flat_before || stays) || matches!(w.cause, Cause::Backlash { .. }) {
            self.push_spot(h);
            return;
        }
        h.cause = plateau_cause(peak.error_m, peak.cmd_vel, &self.axes);
        if !stays {
            self.push_spot(h);
            return;
        }
        // The level goes on past the window: follow it, to its largest error and to tell a
        // plateau from a slow spike.
        if let Some(f) = self.follow.take() {
            self.end_follow(f);
        }
        self.follow = Some(Follow {
            event_cause: w.cause,
            from_k: peak.k,
            floor_m: 0.9 * peak.error_m.abs(),
            level_m: w.level_m,
            scanned_to: w.scanned_to,
            spot: h,
        });
    }

    /// Keeps the largest `max` hotspots, ranked, the rows of one plateau merged.
    fn rank(&mut self) {
        super::hotspot_merge::merge_plateaus(&mut self.spots);
        // A place worth naming stands out: not below 0.05 µm (the report's resolution is
        // 0.01 µm) nor below 1 % of the largest error.
        let largest = self
            .spots
            .iter()
            .map(|h| h.error_um.abs())
            .filter(|e| e.is_finite())
            .fold(0.0, f64::max);
        let floor_um = HOTSPOT_FLOOR_UM.max(0.01 * largest);
        self.spots
            .retain(|h| h.error_um.is_finite() && h.error_um.abs() >= floor_um);
        self.spots
            .sort_by(|a, b| b.error_um.abs().total_cmp(&a.error_um.abs()));
        self.spots.truncate(self.max);
    }

    /// Drops samples no window, level or reversal can need any more.
    fn forget_old(&mut self) {
        // Events still to come lie at most `delay` samples back; their windows and levels
        // reach `before + level_span` further.
        let mut keep_from = self
            .n
            .saturating_sub(self.delay + self.before + self.level_span + 3);
        if let Some(w) = &self.open {
            keep_from = keep_from.min(w.scanned_to);
        }
        if let Some(f) = &self.follow {
            keep_from = keep_from.min(f.scanned_to);
        }
        while self.recent.front().is_some_and(|p| p.k < keep_from) {
            self.recent.pop_front();
        }
    }
}

/// Whether an axis's nut is free in its backlash gap in mode `code`.
fn nut_free(code: u8) -> bool {
    (code % 9) / 3 == 1
}

/// Whether an axis sticks in mode `code`.
fn stuck(code: u8) -> bool {
    code % 3 == 2
}

/// Advances a window's peak over the samples kept up to its end.
fn scan(w: &mut Window, recent: &VecDeque<Kept>) {
    let Some(front) = recent.front() else {
        return;
    };
    let from = w.scanned_to.max(front.k);
    for p in recent.range(from - front.k..).take_while(|p| p.k <= w.hi) {
        if p.error_m.is_finite() && w.peak.is_none_or(|m| p.error_m.abs() > m.error_m.abs()) {
            w.peak = Some(*p);
        }
        if p.error_m.is_finite() {
            w.tail_m = p.error_m;
        }
        w.scanned_to = p.k + 1;
    }
}

/// Median contour error over the `span` cutting samples before `k` (m); 0 when none.
fn level_before(recent: &VecDeque<Kept>, k: usize, span: usize) -> f64 {
    let mut v: Vec<f64> = recent
        .iter()
        .filter(|p| p.k + span >= k && p.k < k && p.error_m.is_finite())
        .map(|p| p.error_m)
        .collect();
    if v.is_empty() {
        return 0.0;
    }
    let mid = v.len() / 2;
    *v.select_nth_unstable_by(mid, f64::total_cmp).1
}

fn hotspot(p: &Kept, cause: Cause, with_z: bool) -> Hotspot {
    Hotspot {
        sample: p.k,
        t_s: p.t_s,
        x_mm: p.pos_m[0] * 1e3,
        y_mm: p.pos_m[1] * 1e3,
        z_mm: with_z.then_some(p.z_m * 1e3),
        // The block being executed when the error peaks.
        line: p.line,
        error_um: p.error_m * 1e6,
        path_mm: p.path_s_m * 1e3,
        excess_um: (p.error_m * 1e6).abs(),
        cause,
        extent: None,
        stretch: p.stretch,
    }
}
