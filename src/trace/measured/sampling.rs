//! A trace's clock: a plausible step in a plausible unit, the steps recorded, a logger's
//! held readings told from measurements, irregular sampling resampled to the median step.

use crate::trace::format::{self, Mapped};

/// A logger that writes rows faster than it reads the positions repeats each reading until
/// the next: new values arrive only on rows `phase + k·period`. The repeats are not
/// measurements — kept, they would read as an axis standing still for the hold and then
/// jumping, which is what stick-slip looks like.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeldRows {
    /// Rows per reading.
    pub period: usize,
    /// The first row that carried a reading.
    pub phase: usize,
}

/// The recorded sampling steps (s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepStats {
    /// Median step.
    pub median_s: f64,
    /// RMS deviation from the median (the clock's jitter).
    pub jitter_rms_s: f64,
    /// Shortest and longest step.
    pub min_s: f64,
    /// Longest step.
    pub max_s: f64,
}

impl StepStats {
    pub(super) fn of(t: &[f64], median_s: f64) -> StepStats {
        let steps = t.windows(2).map(|w| w[1] - w[0]);
        let n = (t.len() - 1) as f64;
        StepStats {
            median_s,
            jitter_rms_s: (steps.clone().map(|d| (d - median_s).powi(2)).sum::<f64>() / n).sqrt(),
            min_s: steps.clone().fold(f64::INFINITY, f64::min),
            max_s: steps.fold(0.0, f64::max),
        }
    }
}

/// The plausible range of a trace's sampling step (s): 1 µs (a fast lab system) to 50 ms
/// (20 Hz, below which no servo error can be seen); a record of a millisecond clock read as
/// seconds falls above it unless sampled faster than 20 kHz.
const PLAUSIBLE_STEP_S: (f64, f64) = (1e-6, 0.05);

/// The longest plausible record (s): a day.
const PLAUSIBLE_DURATION_S: f64 = 86_400.0;

/// The steps a clock of unknown unit is taken to count in only when exactly one unit gives
/// one of them (s): 10 µs (100 kHz) to 50 ms. Narrower than [`PLAUSIBLE_STEP_S`], so that an
/// integer millisecond clock at 1 kHz is not also read as a 1 MHz one in µs.
const INFERRED_STEP_S: (f64, f64) = (1e-5, 0.05);

/// The time column in seconds and its median step. A clock whose header states no unit and
/// whose step is implausible in seconds is read in the one unit that makes it plausible
/// (a lab's `Time` in ms at 10 kHz steps by 0.1), and the mapping says so; where no unit or
/// several would do, the error asks for the unit.
pub(super) fn plausible_clock(t: Vec<f64>, time: &mut Mapped) -> Result<(Vec<f64>, f64), String> {
    let dt = median_step(&t);
    let why = match check_time_plausible(dt, &t, time) {
        Ok(()) => return Ok((t, dt)),
        Err(why) => why,
    };
    if time.unit_from != "default" {
        return Err(why);
    }
    let duration = t[t.len() - 1] - t[0];
    let (lo, hi) = INFERRED_STEP_S;
    let candidates: Vec<format::Unit> = format::time_units()
        .filter(|u| {
            let scale = u.to_si / time.unit.to_si;
            (lo..hi).contains(&(dt * scale)) && duration * scale <= PLAUSIBLE_DURATION_S
        })
        .collect();
    let [unit] = candidates.as_slice() else {
        return Err(why);
    };
    let scale = unit.to_si / time.unit.to_si;
    time.unit = *unit;
    time.unit_from = "sampling step: the only unit giving a plausible one";
    Ok((t.into_iter().map(|v| v * scale).collect(), dt * scale))
}

/// A sampling step no measuring system has is a time column read in the wrong unit.
fn check_time_plausible(dt: f64, t: &[f64], time: &Mapped) -> Result<(), String> {
    let (lo, hi) = PLAUSIBLE_STEP_S;
    let duration = t[t.len() - 1] - t[0];
    if (lo..hi).contains(&dt) && duration <= PLAUSIBLE_DURATION_S {
        return Ok(());
    }
    Err(format!(
        "time column '{}' read in {}: a sampling step of {dt:e} s and a record of {duration:e} s \
         are implausible (steps lie between {lo:e} and {hi} s, records within a day); state \
         the unit, e.g. \
         --columns t={}[ms],…",
        time.header,
        time.unit.label,
        time.header
            .split(['[', '('])
            .next()
            .unwrap_or(&time.header)
            .trim()
    ))
}

/// The rows of a logger that holds its readings, if the record is one: the rows whose
/// positions (all columns, bit for bit) differ from the row before lie, all but one in a
/// hundred, on one grid of `period` ≥ 2 rows, and there are enough of them to tell — at
/// least 50 new readings and a tenth of the grid's slots. Two axes moving at their own
/// speeds change on the same grid of rows only when the logger holds them; a record in
/// which nothing changes is no evidence either way. (The stray hundredth allows for a
/// logger that once reads a row late.)
pub(super) fn held_rows(cols: &[Vec<f64>]) -> Option<HeldRows> {
    const FEWEST_READINGS: usize = 50;
    let n = cols[0].len();
    let differs = |i: usize| {
        cols.iter()
            .filter(|c| !c.is_empty())
            .any(|c| c[i].to_bits() != c[i - 1].to_bits())
    };
    let fresh: Vec<usize> = (1..n).filter(|&i| differs(i)).collect();
    if fresh.len() < FEWEST_READINGS {
        return None;
    }
    let period = most_common(fresh.windows(2).map(|w| w[1] - w[0]))?;
    if period < 2 {
        return None;
    }
    let phase = most_common(fresh.iter().map(|i| i % period))?;
    let on_grid = fresh.iter().filter(|&&i| i % period == phase).count();
    let slots = (n - phase) / period;
    (on_grid * 100 >= fresh.len() * 99 && on_grid * 10 >= slots)
        .then_some(HeldRows { period, phase })
}

/// The value met most often (the smallest among equals).
fn most_common(values: impl Iterator<Item = usize>) -> Option<usize> {
    let mut counts = std::collections::BTreeMap::new();
    for v in values {
        *counts.entry(v).or_insert(0usize) += 1;
    }
    counts
        .into_iter()
        .max_by(|a, b| a.1.cmp(&b.1).then(b.0.cmp(&a.0)))
        .map(|(v, _)| v)
}

/// The rows of `v` that carry readings.
pub(super) fn keep_readings(v: &[f64], held: HeldRows) -> Vec<f64> {
    if v.is_empty() {
        return Vec::new();
    }
    v.iter()
        .skip(held.phase)
        .step_by(held.period)
        .copied()
        .collect()
}

fn median_step(t: &[f64]) -> f64 {
    let mut d: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    let mid = d.len() / 2;
    *d.select_nth_unstable_by(mid, f64::total_cmp).1
}

/// Linear interpolation of (t, v) onto t0 + k·dt up to the last time.
pub(super) fn resample(t: &[f64], v: &[f64], dt: f64) -> Vec<f64> {
    let n = ((t[t.len() - 1] - t[0]) / dt).floor() as usize + 1;
    let mut out = Vec::with_capacity(n);
    let mut j = 0;
    for k in 0..n {
        let tk = t[0] + k as f64 * dt;
        while j + 2 < t.len() && t[j + 1] < tk {
            j += 1;
        }
        let f = ((tk - t[j]) / (t[j + 1] - t[j])).clamp(0.0, 1.0);
        out.push(v[j] + (v[j + 1] - v[j]) * f);
    }
    out
}
