//! Where a residual that no catalogue cause explains lives.
//!
//! A real machine always has some effect nobody listed. Rather than force a catalogue cause
//! onto it, the residual left after the search is tested against the variables an effect
//! can hang on: the position of either axis (a guideway's bump, a straightness error of one
//! axis seen on the other), the axis's velocity and acceleration, the direction of travel,
//! the time (a drift), and a period in position other than the screw lead. Each variable
//! gets a piecewise-constant model — the residual's mean in bins of the variable, or a sine
//! and cosine for a period — fitted on half of the record and scored on the other half
//! (alternate seconds, and then the other way round): the share of the residual's variance
//! it predicts there. Only a share found on data the bins were not fitted on counts, so a
//! variable with many bins cannot explain noise by fitting it.
//!
//! The variable with the largest share names where the residual lives, with the interval
//! where its binned mean is largest — "position on X between 20 and 40 mm, +6 µm".

use super::Context;
use crate::machine::AxisName;
use crate::numeric::two_columns::{PARALLEL, TwoColumns};
use crate::numeric::units::um_from_m;
use crate::trace::signal::sample;

/// A variable a residual can hang on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Variable {
    /// The commanded position of an axis.
    Position(AxisName),
    /// The axis's own position, each direction of travel on its own: an effect that acts
    /// against the motion where the axis is (friction at a tight spot).
    PositionByDirection(AxisName),
    /// The axis's commanded velocity (signed).
    Velocity,
    /// The axis's commanded acceleration.
    Acceleration,
    /// The direction the axis travels.
    Direction,
    /// The time into the program.
    Time,
    /// A period in the axis's position.
    Period,
}

impl Variable {
    /// Its name for a report.
    pub(crate) fn describe(self) -> String {
        match self {
            Variable::Position(a) => format!("position on {a}"),
            Variable::PositionByDirection(a) => format!("position on {a} by direction of travel"),
            Variable::Velocity => "velocity".into(),
            Variable::Acceleration => "acceleration".into(),
            Variable::Direction => "direction of travel".into(),
            Variable::Time => "time".into(),
            Variable::Period => "a period in position".into(),
        }
    }

    /// Decimals its interval is shown with.
    pub(crate) fn decimals(self) -> usize {
        match self {
            Variable::Position(_)
            | Variable::PositionByDirection(_)
            | Variable::Period
            | Variable::Time => 1,
            Variable::Velocity | Variable::Direction => 0,
            Variable::Acceleration => 4,
        }
    }

    /// The unit its interval is given in.
    pub(crate) fn unit(self) -> &'static str {
        match self {
            Variable::Position(_) | Variable::PositionByDirection(_) | Variable::Period => "mm",
            Variable::Velocity => "mm/min",
            Variable::Acceleration => "m/s²",
            Variable::Direction => "",
            Variable::Time => "s",
        }
    }
}

/// Where one axis's unexplained residual lives.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Located {
    /// The axis whose residual it is.
    pub axis: AxisName,
    /// The residual's RMS (µm).
    pub residual_rms_um: f64,
    /// The variable that predicts most of it on held-out data, if any predicts a quarter.
    pub variable: Option<Variable>,
    /// The share of the residual's variance it predicts there (0–1).
    pub share: f64,
    /// Where the residual's binned mean is largest, in the variable's unit: the bins around
    /// the largest that reach half of it (for a period: the period itself, twice).
    pub interval: Option<(f64, f64)>,
    /// The binned mean there, signed (µm); for a period, its amplitude.
    pub peak_um: f64,
}

/// Bins of a continuous variable.
const BINS: usize = 64;
/// Held-out share below which a variable is not named.
const SMALLEST_SHARE: f64 = 0.25;
/// How much more of the residual time must explain than the best variable before it.
const TIME_MARGIN: f64 = 0.1;
/// Bins of the time: only a slow drift (warm-up, a clock) is looked for; finer bins would
/// fit every event of the program as a moment of its own.
const TIME_BINS: usize = 8;

/// Locates the residual of each axis whose residual stands out from the noise (χ² excess
/// over five standard deviations) with `traces` the model's final traces.
pub(crate) fn locate(ctx: &Context, traces: &[Vec<f64>; 2], offset_s: f64) -> Vec<Located> {
    AxisName::BOTH
        .into_iter()
        .filter_map(|axis| {
            let residual = ctx.residual(axis, &traces[axis.index()], offset_s);
            stands_out(&residual, ctx.compared_count(axis), ctx.noise_sigma)
                .then(|| locate_axis(ctx, axis, traces, &residual, offset_s))
        })
        .collect()
}

/// Whether a residual's χ² over the noise exceeds its expectation (`compared` samples) by
/// five deviations.
fn stands_out(residual: &[f64], compared: usize, sigma: f64) -> bool {
    let n = compared as f64;
    let chi2 = residual.iter().map(|v| v * v).sum::<f64>() / (sigma * sigma).max(1e-30);
    n > 0.0 && (chi2 - n) / (2.0 * n).sqrt() > 5.0
}

/// An axis's commanded position, velocity and acceleration at each compared sample (SI).
fn commands_at_samples(ctx: &Context, axis: AxisName, times: &[f64]) -> Vec<(f64, f64, f64)> {
    let c = ctx.commands.axis(axis);
    times
        .iter()
        .map(|&t| {
            let k = ((t / ctx.dt).round().max(0.0) as usize).min(c.pos_m.len().saturating_sub(1));
            (c.pos_m[k], c.vel_m_per_s[k], c.acc_m_per_s2[k])
        })
        .collect()
}

/// Where an axis is at each compared sample by its simulated `trace` (mm): errors of
/// position follow the axis, not its command, which leads it by the following error — a
/// millimetre at 1 m/min, as much as a short period.
pub(super) fn positions_mm(ctx: &Context, trace: &[f64], offset_s: f64) -> Vec<f64> {
    ctx.sample_times(offset_s)
        .iter()
        .map(|&t| sample(trace, ctx.dt, t) * 1e3)
        .collect()
}

/// The samples' values of every candidate variable, then the best of them.
fn locate_axis(
    ctx: &Context,
    axis: AxisName,
    traces: &[Vec<f64>; 2],
    residual: &[f64],
    offset_s: f64,
) -> Located {
    let times = ctx.sample_times(offset_s);
    let own = commands_at_samples(ctx, axis, &times);
    let fold = ctx.axis_halves(axis, offset_s);
    let x = positions_mm(ctx, &traces[axis.index()], offset_s);
    let continuous: Vec<(Variable, Vec<f64>)> = vec![
        (Variable::Position(axis), x.clone()),
        (
            Variable::Position(axis.other()),
            positions_mm(ctx, &traces[axis.other().index()], offset_s),
        ),
        (Variable::Velocity, own.iter().map(|c| c.1 * 6e4).collect()),
        (Variable::Acceleration, own.iter().map(|c| c.2).collect()),
        (Variable::Time, times.clone()),
    ];
    let mut best = Located {
        axis,
        residual_rms_um: um_from_m(rms(&residual
            .iter()
            .zip(&fold)
            .filter(|(_, f)| f.is_some())
            .map(|(r, _)| *r)
            .collect::<Vec<f64>>())),
        variable: None,
        share: 0.0,
        interval: None,
        peak_um: 0.0,
    };
    let mut consider =
        |variable: Variable, share: f64, interval: Option<(f64, f64)>, peak_m: f64| {
            // A variable must do clearly better to displace an earlier one: on a circle the
            // acceleration is the position over again, and position is the plainer answer.
            // Time most clearly of all: its few coarse bins line up with a short program's
            // strokes and so stand in for whatever changes from stroke to stroke; only a
            // drift no per-sample variable explains is one of time.
            let margin = if variable == Variable::Time {
                TIME_MARGIN
            } else {
                0.02
            };
            if share > best.share + margin {
                best.share = share;
                best.variable = (share >= SMALLEST_SHARE).then_some(variable);
                best.interval = interval;
                best.peak_um = um_from_m(peak_m);
            }
        };
    for (variable, z) in &continuous {
        let count = if *variable == Variable::Time {
            TIME_BINS
        } else {
            BINS
        };
        let bins = Bins::over(z, count);
        let share = held_out_share(residual, &fold, |train| bins.fit(z, residual, train));
        let (interval, peak) = bins.fit(z, residual, &|_| true).largest();
        consider(*variable, share, interval, peak);
    }
    // Direction: two bins by the sign of a velocity clearly off zero. After velocity, which
    // at one feed says the same: a lag proportional to velocity is the likelier cause.
    let direction = directions(&own);
    let bins = Bins::fixed(-1.5, 1.5, 2);
    let share = held_out_share(residual, &fold, |train| {
        bins.fit(&direction, residual, train)
    });
    let (_, peak) = bins.fit(&direction, residual, &|_| true).largest();
    consider(Variable::Direction, share, None, peak);
    let (share, interval, peak) = by_direction_fit(&x, &direction, residual, &fold);
    consider(Variable::PositionByDirection(axis), share, interval, peak);
    if let Some((share, period, amplitude)) = periodic_fit(&x, residual, &fold) {
        consider(Variable::Period, share, Some((period, period)), amplitude);
    }
    best
}

/// Position by direction: the positions travelled towards − are shifted past those
/// travelled towards +, so that one set of bins holds both ways apart. The held-out share,
/// the interval of the largest bin (unshifted) and its value.
fn by_direction_fit(
    x: &[f64],
    direction: &[f64],
    residual: &[f64],
    fold: &[Option<bool>],
) -> (f64, Option<(f64, f64)>, f64) {
    let (lo, hi) = finite_range(x);
    let shift = 2.0 * (hi - lo) + 1.0;
    let by_direction: Vec<f64> = x
        .iter()
        .zip(direction)
        .map(|(&p, &d)| if d > 0.0 { p } else { p + shift * d.abs() })
        .collect();
    let bins = Bins::fixed(lo, lo + 2.0 * shift, 4 * BINS);
    let share = held_out_share(residual, fold, |train| {
        bins.fit(&by_direction, residual, train)
    });
    let (interval, peak) = bins.fit(&by_direction, residual, &|_| true).largest();
    let unshifted = interval.map(|(a, b)| {
        if a >= lo + shift {
            (a - shift, b - shift)
        } else {
            (a, b)
        }
    });
    (share, unshifted, peak)
}

/// A period in position: sine and cosine of 2πx/p, over a logarithmic grid of periods and
/// then finely around the best of it — over a long travel a period a per cent off drifts
/// out of phase. The held-out share, the period (mm) and the amplitude; none over less than
/// 4 mm of travel.
fn periodic_fit(x: &[f64], residual: &[f64], fold: &[Option<bool>]) -> Option<(f64, f64, f64)> {
    let span = x.iter().fold(f64::NEG_INFINITY, |a, &b| a.max(b))
        - x.iter().fold(f64::INFINITY, |a, &b| a.min(b));
    if span <= 4.0 {
        return None;
    }
    let share_at = |period: f64| {
        held_out_share(residual, fold, |train| {
            Sinusoid::fit(x, residual, period, train)
        })
    };
    let grid = (0..48).map(|k| (span / 2.0).powf(k as f64 / 47.0));
    let coarse = grid
        .map(|p| (p, share_at(p)))
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .map_or(1.0, |(p, _)| p);
    let (period, share) = (0..=60)
        .map(|k| coarse * (0.94 + 0.002 * k as f64))
        .map(|p| (p, share_at(p)))
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .unwrap_or((coarse, 0.0));
    let amplitude = Sinusoid::fit(x, residual, period, &|_| true).amplitude();
    Some((share, period, amplitude))
}

/// The direction each sample's command travels (±1), NaN where it is not clearly moving.
pub(super) fn directions(own: &[(f64, f64, f64)]) -> Vec<f64> {
    let moving = own.iter().map(|c| c.1.abs()).fold(0.0, f64::max) * 0.02;
    own.iter()
        .map(|c| {
            if c.1 > moving {
                1.0
            } else if c.1 < -moving {
                -1.0
            } else {
                f64::NAN
            }
        })
        .collect()
}

/// The least and largest finite values.
pub(super) fn finite_range(z: &[f64]) -> (f64, f64) {
    z.iter()
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
            (l.min(v), h.max(v))
        })
}

/// A model of the residual fitted on some samples that predicts any sample.
pub(super) trait Predictor {
    fn predict(&self, i: usize) -> Option<f64>;
}

/// The share of variance a model predicts on each half when fitted on the other, both
/// ways. `fit` gets which samples it may use.
pub(super) fn held_out_share<P: Predictor>(
    residual: &[f64],
    fold: &[Option<bool>],
    fit: impl Fn(&dyn Fn(usize) -> bool) -> P,
) -> f64 {
    let (mut unexplained, mut total) = (0.0, 0.0);
    for side in [true, false] {
        let model = fit(&|i| fold[i] == Some(side));
        let scored: Vec<usize> = (0..residual.len())
            .filter(|&i| fold[i] == Some(!side))
            .collect();
        let mean = scored.iter().map(|&i| residual[i]).sum::<f64>() / scored.len().max(1) as f64;
        for &i in &scored {
            let r = residual[i] - mean;
            let e = model.predict(i).map_or(r, |p| residual[i] - p);
            unexplained += e * e;
            total += r * r;
        }
    }
    if total > 0.0 {
        (1.0 - unexplained / total).max(0.0)
    } else {
        0.0
    }
}

/// Equal-width bins of a variable.
pub(super) struct Bins {
    lo: f64,
    width: f64,
    count: usize,
}

impl Bins {
    /// `count` bins over the finite values of `z`.
    pub(super) fn over(z: &[f64], count: usize) -> Bins {
        let (lo, hi) = finite_range(z);
        if lo < hi {
            Bins::fixed(lo, hi, count)
        } else {
            Bins::fixed(0.0, 1.0, 1)
        }
    }

    fn fixed(lo: f64, hi: f64, count: usize) -> Bins {
        Bins {
            lo,
            width: (hi - lo) / count as f64,
            count,
        }
    }

    fn index(&self, v: f64) -> Option<usize> {
        v.is_finite()
            .then(|| (((v - self.lo) / self.width).floor().max(0.0) as usize).min(self.count - 1))
    }

    /// The residual's mean per bin over the samples `use_sample` allows.
    pub(super) fn fit<'z>(
        &'z self,
        z: &'z [f64],
        residual: &[f64],
        use_sample: &dyn Fn(usize) -> bool,
    ) -> BinnedMeans<'z> {
        let mut sum = vec![0.0; self.count];
        let mut n = vec![0usize; self.count];
        for (i, (&v, &r)) in z.iter().zip(residual).enumerate() {
            if let Some(b) = self.index(v).filter(|_| use_sample(i)) {
                sum[b] += r;
                n[b] += 1;
            }
        }
        // A bin needs a few samples to say anything.
        let means = sum
            .iter()
            .zip(&n)
            .map(|(s, &k)| (k >= 5).then(|| s / k as f64))
            .collect();
        BinnedMeans {
            bins: self,
            z,
            means,
        }
    }
}

/// The residual's mean per bin.
pub(super) struct BinnedMeans<'z> {
    bins: &'z Bins,
    z: &'z [f64],
    means: Vec<Option<f64>>,
}

impl Predictor for BinnedMeans<'_> {
    /// Linear between the means at the bins' centres (where both neighbours have one), so
    /// that a smooth effect is not cut into steps.
    fn predict(&self, i: usize) -> Option<f64> {
        let v = self.z[i];
        let b = self.bins.index(v)?;
        let own = self.means[b]?;
        let centre = self.bins.lo + (b as f64 + 0.5) * self.bins.width;
        let toward = if v >= centre {
            b + 1
        } else {
            b.wrapping_sub(1)
        };
        match self.means.get(toward).copied().flatten() {
            Some(next) => Some(own + (next - own) * (v - centre).abs() / self.bins.width),
            None => Some(own),
        }
    }
}

impl BinnedMeans<'_> {
    /// (bin centre, mean) of every bin with a mean.
    pub(super) fn centres(&self) -> Vec<(f64, f64)> {
        self.means
            .iter()
            .enumerate()
            .filter_map(|(b, m)| m.map(|m| (self.bins.lo + (b as f64 + 0.5) * self.bins.width, m)))
            .collect()
    }

    /// The bins around the one of largest |mean| whose means keep its sign and reach half
    /// of it, as an interval of the variable, and that largest mean.
    fn largest(&self) -> (Option<(f64, f64)>, f64) {
        let Some((peak_bin, peak)) = self
            .means
            .iter()
            .enumerate()
            .filter_map(|(b, m)| m.map(|m| (b, m)))
            .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
        else {
            return (None, 0.0);
        };
        let strong =
            |b: usize| self.means[b].is_some_and(|m| m * peak > 0.0 && m.abs() >= 0.5 * peak.abs());
        let (mut first, mut last) = (peak_bin, peak_bin);
        while first > 0 && strong(first - 1) {
            first -= 1;
        }
        while last + 1 < self.bins.count && strong(last + 1) {
            last += 1;
        }
        let edge = |b: usize| self.bins.lo + b as f64 * self.bins.width;
        (Some((edge(first), edge(last + 1))), peak)
    }
}

/// a·sin(2πx/p) + b·cos(2πx/p) fitted by least squares.
struct Sinusoid<'x> {
    x: &'x [f64],
    period: f64,
    a: f64,
    b: f64,
}

impl<'x> Sinusoid<'x> {
    fn fit(
        x: &'x [f64],
        residual: &[f64],
        period: f64,
        use_sample: &dyn Fn(usize) -> bool,
    ) -> Sinusoid<'x> {
        let w = std::f64::consts::TAU / period;
        let mut sums = TwoColumns::default();
        for (i, (&xi, &r)) in x.iter().zip(residual).enumerate() {
            if use_sample(i) {
                let (s, c) = (w * xi).sin_cos();
                sums.add(s, c, r);
            }
        }
        // Where the period's sine and cosine cannot be told apart, no sinusoid.
        let (a, b) = sums.solve(PARALLEL).unwrap_or((0.0, 0.0));
        Sinusoid { x, period, a, b }
    }

    fn amplitude(&self) -> f64 {
        self.a.hypot(self.b)
    }
}

impl Predictor for Sinusoid<'_> {
    fn predict(&self, i: usize) -> Option<f64> {
        let (s, c) = (std::f64::consts::TAU / self.period * self.x[i]).sin_cos();
        Some(self.a * s + self.b * c)
    }
}

fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt()
}
