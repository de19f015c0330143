//! Hotspots: the places along a run where the contour error matters, each with its G-code
//! line, position, time, magnitude and cause.
//!
//! Causes are found from events, not guessed from the error curve: an axis reversal (the
//! commanded velocity of X or Y changes sign during a cut — a quadrant crossing on a circle),
//! labelled backlash when the nut actually crossed its gap there; a corner (a junction whose
//! tangent turns by more than a few degrees); a feed change between blocks; stick-slip (an
//! axis switching between stick and slip repeatedly while moving slowly). Each event opens a
//! window — from just before it to a few position-loop time constants after — and the
//! hotspot is the largest contour error in it. Overlapping windows merge into one hotspot;
//! the global maximum is always reported; the list is ranked by magnitude.

use serde::Serialize;

use crate::contour::ContourSeries;
use crate::machine::AxisName;
use crate::path::{Motion, dot3};
use crate::plan::{Commands, Plan};
use crate::sim::AxisTrace;

/// Why the contour error peaks here.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, PartialOrd, Ord)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Cause {
    /// The axis's nut crossed its backlash gap at a reversal.
    Backlash {
        /// Axis.
        axis: AxisName,
    },
    /// An axis reversed (quadrant crossing): friction and the loop's lag spike the error.
    AxisReversal {
        /// Axis.
        axis: AxisName,
    },
    /// A corner of the path.
    Corner,
    /// A change of programmed feed.
    SpeedChange,
    /// The axes still settling into the exact-stop window when the next block starts (after
    /// a rapid or a G61 stop).
    Settling,
    /// Repeated stick and slip at low speed.
    StickSlip {
        /// Axis.
        axis: AxisName,
    },
    /// The steady lag of the axes (radius loss on arcs, unequal gains on lines): the error
    /// here is no larger than just before the event that flagged the place.
    SteadyLag,
    /// The run's largest error, away from any of the events above.
    GlobalMaximum,
}

impl Cause {
    /// Which cause names a merged window: the most specific one.
    fn priority(&self) -> u8 {
        match self {
            Cause::Backlash { .. } => 6,
            Cause::StickSlip { .. } => 5,
            Cause::Corner => 4,
            Cause::Settling => 3,
            Cause::AxisReversal { .. } => 2,
            Cause::SpeedChange => 1,
            Cause::SteadyLag | Cause::GlobalMaximum => 0,
        }
    }
}

impl Cause {
    /// A short label for tables and plots.
    pub fn label(&self) -> String {
        match self {
            Cause::Backlash { axis } => format!("{axis} backlash at reversal"),
            Cause::AxisReversal { axis } => format!("{axis} reversal"),
            Cause::Corner => "corner".into(),
            Cause::SpeedChange => "feed change".into(),
            Cause::Settling => "settling after exact stop".into(),
            Cause::SteadyLag => "steady lag".into(),
            Cause::StickSlip { axis } => format!("{axis} stick-slip"),
            Cause::GlobalMaximum => "global maximum".into(),
        }
    }
}

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
    /// Source line of the nearest block.
    pub line: u32,
    /// Signed contour error at the peak (µm).
    pub error_um: f64,
    /// How far the error departs from its level just before the event (µm): the size of
    /// the spike or jump, as opposed to the steady lag it sits on.
    pub excess_um: f64,
    /// Cause.
    pub cause: Cause,
}

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
}

impl HotspotConfig {
    /// Defaults for a position-loop gain `kv_per_s` (1/s).
    pub fn for_kv(kv_per_s: f64) -> Self {
        HotspotConfig {
            before_s: 0.02,
            after_s: 5.0 / kv_per_s,
            corner_deg: 3.0,
            slow_m_per_s: 20.0 / 60_000.0,
            stick_slip_toggles: 4,
        }
    }
}

/// Everything the detector looks at.
pub struct RunView<'a> {
    /// The plan (segments and timing).
    pub plan: &'a Plan,
    /// The commands.
    pub commands: &'a Commands,
    /// X and Y traces.
    pub traces: [&'a AxisTrace; 2],
    /// Backlash of X and Y (m).
    pub backlash_m: [f64; 2],
    /// The contour error.
    pub contour: &'a ContourSeries,
}

struct Event {
    sample: usize,
    cause: Cause,
}

/// Finds the hotspots of a run, ranked by |error|, at most `max` of them.
pub fn find_hotspots(run: &RunView, cfg: &HotspotConfig, max: usize) -> Vec<Hotspot> {
    let mut events = reversal_events(run);
    events.extend(junction_events(run, cfg));
    events.extend(stick_slip_events(run, cfg));
    events.sort_by_key(|e| e.sample);
    let dt = run.commands.dt_s;
    let (before, after) = (
        (cfg.before_s / dt).ceil() as usize,
        (cfg.after_s / dt).ceil() as usize,
    );
    let n = run.contour.error_m.len();
    // Merge overlapping windows; the earliest event names the merged hotspot, except that
    // backlash outranks a plain reversal at the same place.
    let mut windows: Vec<(usize, usize, Cause)> = Vec::new();
    for e in events {
        let (lo, hi) = (
            e.sample.saturating_sub(before),
            (e.sample + after).min(n.saturating_sub(1)),
        );
        match windows.last_mut() {
            Some(w) if lo <= w.1 => {
                w.1 = w.1.max(hi);
                if e.cause.priority() > w.2.priority() {
                    w.2 = e.cause;
                }
            }
            _ => windows.push((lo, hi, e.cause)),
        }
    }
    let mut spots: Vec<Hotspot> = windows
        .iter()
        .filter_map(|&(lo, hi, cause)| {
            let k = peak_in(run, lo, hi)?;
            let mut h = hotspot(run, k, cause);
            h.excess_um = (h.error_um - level_before(run, lo, before.max(1) * 5) * 1e6).abs();
            // No spike above the local level: the place is flagged by an event, but its error
            // is the axes' steady lag.
            if h.excess_um < 0.1 * h.error_um.abs() && !matches!(cause, Cause::Backlash { .. }) {
                h.cause = Cause::SteadyLag;
            }
            Some(h)
        })
        .collect();
    if let Some((k, _)) = run.contour.max_abs()
        && !windows.iter().any(|&(lo, hi, _)| (lo..=hi).contains(&k))
    {
        spots.push(hotspot(run, k, Cause::GlobalMaximum));
    }
    spots.retain(|h| h.error_um.is_finite());
    spots.sort_by(|a, b| b.error_um.abs().total_cmp(&a.error_um.abs()));
    spots.truncate(max);
    spots
}

/// Median contour error over the `span` cutting samples before `k` (m); 0 when none.
fn level_before(run: &RunView, k: usize, span: usize) -> f64 {
    let mut v: Vec<f64> = run.contour.error_m[k.saturating_sub(span)..k]
        .iter()
        .copied()
        .filter(|e| e.is_finite())
        .collect();
    if v.is_empty() {
        return 0.0;
    }
    let mid = v.len() / 2;
    *v.select_nth_unstable_by(mid, f64::total_cmp).1
}

fn peak_in(run: &RunView, lo: usize, hi: usize) -> Option<usize> {
    (lo..=hi)
        .filter(|&k| run.contour.error_m[k].is_finite())
        .max_by(|&a, &b| {
            run.contour.error_m[a]
                .abs()
                .total_cmp(&run.contour.error_m[b].abs())
        })
}

fn hotspot(run: &RunView, k: usize, cause: Cause) -> Hotspot {
    // The block being executed when the error peaks.
    let seg = run.commands.segment[k] as usize;
    Hotspot {
        sample: k,
        t_s: run.commands.time_s(k),
        x_mm: run.traces[0].pos_m[k] * 1e3,
        y_mm: run.traces[1].pos_m[k] * 1e3,
        line: run.plan.segments.get(seg).map_or(0, |s| s.line),
        error_um: run.contour.error_m[k] * 1e6,
        excess_um: (run.contour.error_m[k] * 1e6).abs(),
        cause,
    }
}

fn cutting(run: &RunView, k: usize) -> bool {
    run.plan.segments[run.commands.segment[k] as usize].motion == Motion::Feed
}

/// Sign changes of an axis's commanded velocity during cuts — also across a standstill,
/// since the nut must cross its gap and static friction must break however long the axis
/// stood (where a reversal coincides with a corner, the corner names the place).
fn reversal_events(run: &RunView) -> Vec<Event> {
    let mut out = Vec::new();
    let c = run.commands;
    for axis in AxisName::BOTH {
        let v = if axis == AxisName::X {
            &c.x.vel_m_per_s
        } else {
            &c.y.vel_m_per_s
        };
        let mut last_sign = 0.0;
        for (k, &vk) in v.iter().enumerate() {
            // Ignore the speed noise of a standing axis.
            if vk.abs() < 1e-9 {
                continue;
            }
            let sign = vk.signum();
            if last_sign != 0.0 && sign != last_sign && cutting(run, k) {
                let cause = if run.backlash_m[axis.index()] > 0.0
                    && gap_crossed(run.traces[axis.index()], k, run)
                {
                    Cause::Backlash { axis }
                } else {
                    Cause::AxisReversal { axis }
                };
                out.push(Event { sample: k, cause });
            }
            last_sign = sign;
        }
    }
    out
}

/// Whether the nut was free in its gap shortly after sample `k`.
fn gap_crossed(trace: &AxisTrace, k: usize, run: &RunView) -> bool {
    let until = (k + (0.5 / run.commands.dt_s) as usize).min(trace.mode.len());
    trace.mode[k.saturating_sub(2)..until]
        .iter()
        .any(|&m| (m % 9) / 3 == 1)
}

/// Corners and feed changes at segment junctions.
fn junction_events(run: &RunView, cfg: &HotspotConfig) -> Vec<Event> {
    let segs = &run.plan.segments;
    let cos_limit = cfg.corner_deg.to_radians().cos();
    let mut out = Vec::new();
    let mut k = 0;
    let c = run.commands;
    for i in 1..segs.len() {
        let (a, b) = (&segs[i - 1], &segs[i]);
        // First sample on segment i.
        while k < c.len() && (c.segment[k] as usize) < i {
            k += 1;
        }
        if k >= c.len() {
            break;
        }
        if b.motion == Motion::Feed && !b.is_dwell() && run.plan.plans[i - 1].wait_s > 0.0 {
            out.push(Event {
                sample: k,
                cause: Cause::Settling,
            });
            continue;
        }
        if a.motion != Motion::Feed || b.motion != Motion::Feed || a.is_dwell() || b.is_dwell() {
            continue;
        }
        let (ta, tb) = (a.end_tangent(), b.start_tangent());
        let xy = |t: [f64; 3]| {
            let n = t[0].hypot(t[1]);
            if n > 1e-9 {
                [t[0] / n, t[1] / n, 0.0]
            } else {
                [0.0; 3]
            }
        };
        let (ta, tb) = (xy(ta), xy(tb));
        let turned = ta != [0.0; 3] && tb != [0.0; 3] && dot3(ta, tb) < cos_limit;
        if turned {
            out.push(Event {
                sample: k,
                cause: Cause::Corner,
            });
        } else if (a.feed_m_per_s - b.feed_m_per_s).abs()
            > 0.05 * a.feed_m_per_s.max(b.feed_m_per_s)
        {
            out.push(Event {
                sample: k,
                cause: Cause::SpeedChange,
            });
        }
    }
    out
}

/// Episodes of repeated stick/slip toggles while an axis moves slowly.
fn stick_slip_events(run: &RunView, cfg: &HotspotConfig) -> Vec<Event> {
    let mut out = Vec::new();
    let dt = run.commands.dt_s;
    let second = (1.0 / dt) as usize;
    for axis in AxisName::BOTH {
        let trace = run.traces[axis.index()];
        let v = if axis == AxisName::X {
            &run.commands.x.vel_m_per_s
        } else {
            &run.commands.y.vel_m_per_s
        };
        let stuck = |k: usize| trace.mode[k] % 3 == 2;
        let mut toggles: Vec<usize> = Vec::new();
        for (k, vk) in v.iter().enumerate().take(trace.mode.len()).skip(1) {
            let slow = vk.abs() > 0.0 && vk.abs() < cfg.slow_m_per_s;
            if slow && cutting(run, k) && stuck(k) != stuck(k - 1) {
                toggles.push(k);
            }
        }
        // An episode: enough toggles within one second; one event per episode.
        let mut i = 0;
        while i < toggles.len() {
            let j = toggles[i..]
                .iter()
                .take_while(|&&t| t - toggles[i] <= second)
                .count();
            if j >= cfg.stick_slip_toggles {
                out.push(Event {
                    sample: toggles[i],
                    cause: Cause::StickSlip { axis },
                });
                // Skip the rest of this episode.
                let end = toggles[i + j - 1];
                while i < toggles.len() && toggles[i] <= end + second {
                    i += 1;
                }
            } else {
                i += 1;
            }
        }
    }
    out
}
