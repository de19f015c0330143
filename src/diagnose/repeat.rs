//! Residuals that come back at the same positions on every pass of an axis.
//!
//! A tight spot on a guideway, a local scale or straightness error, a damaged stretch of a
//! screw: each disturbs the axis where it is, on every pass over that place, and nowhere
//! else. Over a whole record such a bump is a few tens of milliseconds in many seconds, so
//! the record's RMS can sit at the noise while the bump stands ten noise deviations high. No
//! cause of the catalogue acts at one place, and the variables [`super::locate`] bins over
//! the whole travel dilute it; what marks it is that it repeats.
//!
//! The test: the steady stretches of an axis's travel (moving one way, away from its
//! reversals and accelerations) are its passes. Each pass's residual, less its own median
//! level, is averaged in windows of position that overlap by three quarters; a window's
//! width is at least the travel during twice the position loop's time constant, since a
//! disturbance met at a place shows in the following error over the distance the loop takes
//! to settle, ahead of the place in the direction of travel — so the same window holds it
//! on a pass towards + and on one towards −. The window means are put on one scale by the
//! spread of all of them (a robust one, the median absolute deviation): that spread is
//! what the residual's correlation makes of a mean over a window, whatever the correlation
//! is, where a noise deviation over √n would assume independent samples. A window is a
//! finding when every pass over it departs the same way (or, for an effect that acts
//! against the motion, the same way relative to the direction of travel) by at least
//! [`EACH_PASS_SIGMA`], and all together by more than chance allows over all windows tried
//! (a family-wise false-alarm probability of [`FALSE_ALARM`], at least [`LEAST_SIGMA`]).
//! Passes are far apart in time, so a correlated residual does not make them agree by
//! itself. A finding covering more than [`MOST_OF_TRAVEL`] of the windows is not local: it
//! is left to the causes and to [`super::locate`].

use super::Context;
use super::locate::{directions, finite_range, positions_mm};
use crate::machine::{AxisName, MachineConfig};
use crate::numeric::units::um_from_m;

/// A place where an axis's residual repeats on every pass.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Spot {
    /// Where the repeating windows begin (mm of the axis's position).
    pub from_mm: f64,
    /// Where they end (mm).
    pub to_mm: f64,
    /// The centre of its most significant window (mm).
    pub centre_mm: f64,
    /// The residual there, averaged over its window and the passes (µm, signed; for one
    /// that follows the direction of travel, as on passes towards +).
    pub residual_um: f64,
    /// Whether its sign follows the direction of travel (an effect against the motion)
    /// rather than the place alone.
    pub follows_direction: bool,
    /// The weakest pass's departure there, in deviations of a window's mean.
    pub weakest_pass_sigma: f64,
    /// All passes together (their departures' sum over √passes).
    pub combined_sigma: f64,
}

/// A residual that repeats at the same places on every pass of one axis.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Localized {
    /// The axis whose residual it is.
    pub axis: AxisName,
    /// Its steady passes.
    pub passes: usize,
    /// How many passed over each spot (the fewest of the spots).
    pub passes_over_spots: usize,
    /// The window width used (mm).
    pub window_mm: f64,
    /// The places, along the axis.
    pub spots: Vec<Spot>,
    /// Where two spots of opposite sign bound a stretch: its ends (mm), the centres of the
    /// two — how a stretch of higher friction or of a different scale shows.
    pub stretch_mm: Option<(f64, f64)>,
}

/// Each pass over a finding departs at least this much (deviations of a window mean).
const EACH_PASS_SIGMA: f64 = 3.0;
/// Family-wise probability that noise alone makes a finding somewhere on an axis.
const FALSE_ALARM: f64 = 1e-4;
/// The least combined departure of a finding, however few windows were tried: the
/// residual's tails are heavier than a normal law's.
const LEAST_SIGMA: f64 = 6.0;
/// A finding over more of the windows than this is not local.
const MOST_OF_TRAVEL: f64 = 0.25;
/// Windows a pass's travel is cut into at the least (the window narrows to this).
const WINDOWS_PER_TRAVEL: f64 = 60.0;
/// Least samples of a pass in a window for its mean to count.
const LEAST_SAMPLES: usize = 4;

/// The samples of one axis that make up its steady passes.
struct Passes {
    /// Position (mm), residual (m) and pass of each sample in a pass.
    position_mm: Vec<f64>,
    residual_m: Vec<f64>,
    pass: Vec<usize>,
    /// The direction of each pass (±1).
    direction: Vec<f64>,
    /// The median speed over the passes (mm/s).
    speed_mm_per_s: f64,
    /// Each pass's level: its median residual (m).
    level_m: Vec<f64>,
}

/// The repeating residual of each axis that has one, with `traces` the model's final traces.
pub(crate) fn localize(
    ctx: &Context,
    machine: &MachineConfig,
    traces: &[Vec<f64>; 2],
    offset_s: f64,
    event_window_s: f64,
) -> Vec<Localized> {
    AxisName::BOTH
        .into_iter()
        .filter_map(|axis| {
            let passes = passes_of(ctx, axis, traces, offset_s, event_window_s)?;
            let kv_per_s = machine.axis(axis).position_loop.kv_m_per_min_per_mm * 1e3 / 60.0;
            find_spots(axis, &passes, kv_per_s)
        })
        .collect()
}

/// The steady passes of `axis`: compared samples away from its events, moving one way; a
/// pass ends where the direction changes or a sample is left out.
fn passes_of(
    ctx: &Context,
    axis: AxisName,
    traces: &[Vec<f64>; 2],
    offset_s: f64,
    event_window_s: f64,
) -> Option<Passes> {
    let residual = ctx.residual(axis, &traces[axis.index()], offset_s);
    let x = positions_mm(ctx, &traces[axis.index()], offset_s);
    let c = ctx.commands.axis(axis);
    let own: Vec<(f64, f64, f64)> = ctx
        .sample_times(offset_s)
        .iter()
        .map(|&t| {
            let k = ((t / ctx.dt).round().max(0.0) as usize).min(c.pos_m.len().saturating_sub(1));
            (c.pos_m[k], c.vel_m_per_s[k], c.acc_m_per_s2[k])
        })
        .collect();
    let direction = directions(&own);
    let (_, near_event) = ctx.event_masks(axis, offset_s, event_window_s);
    let mut p = Passes {
        position_mm: Vec::new(),
        residual_m: Vec::new(),
        pass: Vec::new(),
        direction: Vec::new(),
        speed_mm_per_s: 0.0,
        level_m: Vec::new(),
    };
    let mut speeds = Vec::new();
    let mut open = false;
    for k in 0..residual.len() {
        let steady = ctx.compared(axis, k) && !near_event[k] && direction[k].is_finite();
        if !steady || (open && p.direction.last() != Some(&direction[k])) {
            open = false;
        }
        if !steady {
            continue;
        }
        if !open {
            p.direction.push(direction[k]);
            open = true;
        }
        p.position_mm.push(x[k]);
        p.residual_m.push(residual[k]);
        p.pass.push(p.direction.len() - 1);
        speeds.push(own[k].1.abs() * 1e3);
    }
    if p.direction.len() < 2 {
        return None;
    }
    speeds.sort_by(f64::total_cmp);
    p.speed_mm_per_s = speeds[speeds.len() / 2];
    p.level_m = pass_levels(&p);
    Some(p)
}

/// One pass's mean departure in one window: (pass, mean less the pass's level (m), samples).
type WindowMeans = Vec<(usize, f64, usize)>;

/// The spots of one axis's passes, if any window repeats.
fn find_spots(axis: AxisName, p: &Passes, kv_per_s: f64) -> Option<Localized> {
    let (lo, hi) = finite_range(&p.position_mm);
    let settle_mm = 2.0 * p.speed_mm_per_s / kv_per_s.max(1e-3);
    let width = settle_mm.max((hi - lo) / WINDOWS_PER_TRAVEL);
    if hi - lo <= 2.0 * width || !width.is_finite() {
        return None;
    }
    let step = width / 4.0;
    let starts: Vec<f64> = (0..)
        .map(|j| lo + j as f64 * step)
        .take_while(|&a| a + width <= hi + step)
        .collect();
    let windows: Vec<WindowMeans> = starts
        .iter()
        .map(|&a| window_means(p, a, a + width))
        .collect();
    let scale = robust_scale(&windows)?;
    let threshold = combined_threshold(2 * windows.len());
    let judged: Vec<Option<Judged>> = windows
        .iter()
        .map(|w| judge(w, &p.direction, scale, threshold))
        .collect();
    let hits = judged.iter().filter(|j| j.is_some()).count();
    if hits == 0 || hits as f64 > MOST_OF_TRAVEL * windows.len() as f64 {
        return None;
    }
    let spots = merge(&starts, width, &judged);
    let passes_over_spots = judged.iter().flatten().map(|j| j.passes).min()?;
    let stretch_mm = match spots.as_slice() {
        [a, b]
            if a.residual_um * b.residual_um < 0.0
                && a.follows_direction == b.follows_direction =>
        {
            Some((a.centre_mm, b.centre_mm))
        }
        _ => None,
    };
    Some(Localized {
        axis,
        passes: p.direction.len(),
        passes_over_spots,
        window_mm: width,
        spots,
        stretch_mm,
    })
}

/// Each pass's mean residual between `from` and `to` mm less its level (its median over the
/// pass's samples), where it has enough samples there.
fn window_means(p: &Passes, from: f64, to: f64) -> WindowMeans {
    let mut sum = vec![0.0; p.direction.len()];
    let mut count = vec![0usize; p.direction.len()];
    for ((&x, &r), &k) in p.position_mm.iter().zip(&p.residual_m).zip(&p.pass) {
        if x >= from && x < to {
            sum[k] += r;
            count[k] += 1;
        }
    }
    (0..p.direction.len())
        .filter(|&k| count[k] >= LEAST_SAMPLES)
        .map(|k| (k, sum[k] / count[k] as f64 - p.level_m[k], count[k]))
        .collect()
}

/// Each pass's median residual (m).
fn pass_levels(p: &Passes) -> Vec<f64> {
    let mut by_pass: Vec<Vec<f64>> = vec![Vec::new(); p.direction.len()];
    for (&r, &k) in p.residual_m.iter().zip(&p.pass) {
        by_pass[k].push(r);
    }
    by_pass
        .into_iter()
        .map(|mut v| {
            v.sort_by(f64::total_cmp);
            v.get(v.len() / 2).copied().unwrap_or(0.0)
        })
        .collect()
}

/// The scale of a window mean times √samples: 1.4826 median absolute values over every pass
/// and window (the level is already taken off).
fn robust_scale(windows: &[WindowMeans]) -> Option<f64> {
    let mut v: Vec<f64> = windows
        .iter()
        .flatten()
        .map(|&(_, m, n)| (m * (n as f64).sqrt()).abs())
        .collect();
    if v.len() < 8 {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let s = 1.4826 * v[v.len() / 2];
    (s > 0.0).then_some(s)
}

/// The combined departure that noise exceeds with probability [`FALSE_ALARM`] over `tests`
/// one-sided tests, at least [`LEAST_SIGMA`]: z where the normal law's tail bound
/// φ(z)/z (above the tail itself, so on the safe side) is the probability each test may
/// have, by fixed-point iteration of z = √(2 ln(1 / (p z √(2π)))).
fn combined_threshold(tests: usize) -> f64 {
    let p = FALSE_ALARM / tests.max(1) as f64;
    let mut z = 4.0_f64;
    for _ in 0..50 {
        z = (2.0 * (1.0 / (p * z * std::f64::consts::TAU.sqrt())).ln())
            .max(1.0)
            .sqrt();
    }
    z.max(LEAST_SIGMA)
}

/// A window where every pass departs alike.
#[derive(Debug, Clone, Copy)]
struct Judged {
    passes: usize,
    weakest: f64,
    combined: f64,
    mean_m: f64,
    follows_direction: bool,
}

/// Whether the passes over one window repeat: by place, or by place and direction, the
/// stronger of the two.
fn judge(w: &WindowMeans, direction: &[f64], scale: f64, threshold: f64) -> Option<Judged> {
    if w.len() < 2 {
        return None;
    }
    [false, true]
        .into_iter()
        .filter_map(|follows_direction| {
            let sign = |k: usize| if follows_direction { direction[k] } else { 1.0 };
            let z: Vec<f64> = w
                .iter()
                .map(|&(k, m, n)| sign(k) * m * (n as f64).sqrt() / scale)
                .collect();
            let combined = z.iter().sum::<f64>() / (z.len() as f64).sqrt();
            let weakest = z
                .iter()
                .fold(f64::INFINITY, |a, &b| a.min(b * combined.signum()));
            let weight: usize = w.iter().map(|e| e.2).sum();
            let mean_m = w
                .iter()
                .map(|&(k, m, n)| sign(k) * m * n as f64)
                .sum::<f64>()
                / weight.max(1) as f64;
            (weakest >= EACH_PASS_SIGMA && combined.abs() >= threshold).then_some(Judged {
                passes: w.len(),
                weakest,
                combined: combined.abs(),
                mean_m,
                follows_direction,
            })
        })
        .max_by(|a, b| a.combined.total_cmp(&b.combined))
}

/// Overlapping and touching windows that repeat alike, as spots.
fn merge(starts: &[f64], width: f64, judged: &[Option<Judged>]) -> Vec<Spot> {
    let mut spots: Vec<Spot> = Vec::new();
    for (a, j) in starts.iter().zip(judged) {
        let Some(j) = j else { continue };
        let spot = Spot {
            from_mm: *a,
            to_mm: a + width,
            centre_mm: a + 0.5 * width,
            residual_um: um_from_m(j.mean_m),
            follows_direction: j.follows_direction,
            weakest_pass_sigma: j.weakest,
            combined_sigma: j.combined,
        };
        match spots.last_mut() {
            Some(last)
                if *a <= last.to_mm
                    && last.follows_direction == j.follows_direction
                    && last.residual_um * spot.residual_um > 0.0 =>
            {
                last.to_mm = spot.to_mm;
                if spot.combined_sigma > last.combined_sigma {
                    *last = Spot {
                        from_mm: last.from_mm,
                        ..spot
                    };
                }
            }
            _ => spots.push(spot),
        }
    }
    spots
}
