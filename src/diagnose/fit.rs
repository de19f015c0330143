//! Fitting one cause on one axis by re-simulating.
//!
//! Point by point ([`fit_cause`]), on the residual's sum of squares:
//! 1. the best of a set of starting points (a grid for causes not linear in their
//!    parameters), each judged at the clock offset that suits it best unless the record
//!    fixed it;
//! 2. Nelder–Mead from there with the clock offset held: the hybrid model's residual is
//!    continuous in a cause's parameters but has kinks (a backlash's is V-shaped at its
//!    minimum), where a derivative-free search does not stall;
//! 3. Levenberg–Marquardt ([`crate::numeric::lsq`]) over the parameters (scaled to their
//!    typical magnitudes, inside their ranges) and, unless the measurement recorded its
//!    commands, the clock offset, for the polish and the Jacobian the uncertainties come
//!    from. Step 2's values stand when it does not improve on them.
//!
//! On statistics ([`fit_statistical`]), for an axis in stick-slip: steps 1 and 2 on the χ²
//! of [`Context::statistical_residual`], the offset held; uncertainties from its curvature.
//!
//! Bounds are kept by clamping inside the model. The Jacobian is by forward differences of
//! re-simulations for the cause's parameters (1 % of each one's scale: smaller steps would
//! see the switching instants' discontinuities, not the slope) and analytic for the offset.

use std::collections::VecDeque;
use std::sync::{Arc, Mutex};

use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;

use super::{Context, Stepping};
use crate::diagnose::causes::{self, CauseId, Param};
use crate::machine::{AxisName, MachineConfig};
use crate::numeric::golden_section;
use crate::numeric::lsq::{self, correlation_time, forward_jacobian, model_floor, uncertainties};

/// A fitted cause.
#[derive(Debug, Clone, PartialEq)]
pub struct Fitted {
    /// Parameter values (machine units).
    pub values: Vec<f64>,
    /// Their standard uncertainties (machine units).
    pub sigma: Vec<f64>,
    /// Time offset (s).
    pub offset_s: f64,
    /// Residual sum of squares over both axes (m²).
    pub rss: f64,
    /// χ² of the axis's statistical residual (for statistical fits; else NaN).
    pub chi2_stat: f64,
    /// The axis's simulated trace with the fitted cause (m).
    pub trace: Vec<f64>,
    /// The other axis's trace (m): changed too when the cause changes the program's timing.
    pub other: Vec<f64>,
}

/// The start whose residual is lowest at the clock offset that suits it best
/// ([`Model::rss_at_best_offset`]), and that offset, each start looked at one simulation
/// step per control cycle: a first look that only chooses where the fit begins, at a
/// quarter of the cost of the fit's own steps (which matters for the grids of tens of
/// starts). A single start is judged on the fit's own stepping (the simulation Nelder–Mead
/// starts from, kept): a cause with one start (a direction offset, lateral play) lags at
/// reversals as backlash does, and from the first alignment it would start off its clock.
fn best_start<'s>(
    model: &Model,
    starts: &'s [Vec<f64>],
    offset_s: f64,
) -> Option<(&'s [f64], f64)> {
    if let [only] = starts {
        let (_, offset) = model.rss_at_best_offset(model.ctx, only, offset_s);
        return Some((only.as_slice(), offset));
    }
    let screen = Context {
        stepping: Stepping::PerCycle,
        ..model.ctx.clone()
    };
    let (start, screened_s) = starts
        .iter()
        .map(|s| (model.rss_at_best_offset(&screen, s, offset_s), s))
        .min_by(|a, b| a.0.0.total_cmp(&b.0.0))
        .map(|((_, offset), s)| (s.as_slice(), offset))?;
    // The screen steps once a cycle; where the inputs vary within one (a Stribeck curve, a
    // ripple, a measuring error) its best offset is off the fit's own by part of a cycle:
    // the chosen start's offset found again on the fit's stepping (the simulation Nelder–Mead
    // starts from, kept).
    let (_, offset) = model.rss_at_best_offset(model.ctx, start, screened_s);
    Some((start, offset))
}

/// Fits `cause` on `axis` of `machine` point by point, from the best of `starts`
/// (parameter values in machine units) and the offset `offset_s`; the other axis keeps its
/// trace `other`.
pub(crate) fn fit_cause(
    ctx: &Context,
    machine: &MachineConfig,
    axis: AxisName,
    cause: CauseId,
    starts: &[Vec<f64>],
    offset_s: f64,
    other: &[f64],
) -> Option<Fitted> {
    let model = Model {
        ctx,
        machine,
        axis,
        cause,
        other,
        simulated: Simulated::default(),
    };
    let (start, start_offset) = best_start(&model, starts, offset_s)?;
    let (values, nm_offset, best) = model.nelder_mead_from(start, start_offset);
    let problem = Problem { model };
    let p0 = problem.model.scaled(&values, nm_offset);
    let end = lsq::minimise(&problem, p0.clone(), &problem.model.settings());
    // Nelder–Mead's values stand where Levenberg–Marquardt does not improve on them.
    let (p, rss, jacobian) = match end.filter(|e| e.cost < best) {
        Some(e) => (e.p, e.cost, Some(e.jacobian)),
        None => (p0, best, None),
    };
    let (r0, trace, other) = problem.model.evaluate(&p)?;
    let jacobian = jacobian.or_else(|| lsq::Problem::jacobian(&problem, &p, &r0));
    let params = cause.params();
    let sigma = jacobian.map_or_else(
        || vec![f64::NAN; params.len()],
        |j| problem.model.uncertainties(&j, rss, &r0),
    );
    let (values, offset_s) = problem.model.unscale(&p);
    accept(
        params,
        Fitted {
            values,
            sigma,
            offset_s,
            rss,
            chi2_stat: f64::NAN,
            trace,
            other,
        },
    )
}

/// `machine` with `cause` on `axis` at parameter values `values`.
fn with_cause(
    machine: &MachineConfig,
    axis: AxisName,
    cause: CauseId,
    values: &[f64],
) -> MachineConfig {
    let mut m = machine.clone();
    causes::apply(m.axis_mut(axis), cause, values);
    m
}

/// Fits `cause` on `axis` on the statistics of its residual (see
/// [`Context::statistical_residual`]), the offset held: the best of `starts` (evaluated side
/// by side), refined by [`surface_descent`], its uncertainties from the χ²'s curvature as
/// `uncertainty` asks.
/// Whether a statistical fit's uncertainties are worked out (a grid of simulations around
/// the best values): only when its χ² falls by at least this much from the χ² before (a fit
/// that falls short is not named, whatever its uncertainty: its uncertainties are left NaN
/// and the fit is not kept); or never (a fit whose values only serve to be scored elsewhere,
/// as on the held-out half).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Uncertainty {
    IfGainAtLeast(f64),
    Never,
}

#[allow(clippy::too_many_arguments)]
pub(crate) fn fit_statistical(
    ctx: &Context,
    machine: &MachineConfig,
    axis: AxisName,
    cause: CauseId,
    starts: &[Vec<f64>],
    offset_s: f64,
    other: &[f64],
    (before, uncertainty): (f64, Uncertainty),
) -> Option<Fitted> {
    let params = cause.params();
    let simulate =
        |values: &[f64]| ctx.simulate_axis(&with_cause(machine, axis, cause, values), axis);
    let chi2 = |values: &[f64]| {
        simulate(values).map_or(f64::INFINITY, |t| {
            ctx.statistical_residual(axis, &t, offset_s)
                .iter()
                .map(|v| v * v)
                .sum()
        })
    };
    // Stick-slip statistics depend on every slip: the starts are looked at as finely as
    // the fit, in parallel (each a simulation of the whole record; the first of equal
    // costs wins, as in order).
    let (start_cost, start) = starts
        .par_iter()
        .map(|s| (chi2(s), s))
        .collect::<Vec<_>>()
        .into_iter()
        .min_by(|a, b| a.0.total_cmp(&b.0))?;
    let (values, best) = surface_descent(start, start_cost, params, &chi2);
    let trace = simulate(&values)?;
    let n_terms = ctx.statistical_residual(axis, &trace, offset_s).len();
    let sigma = match uncertainty {
        Uncertainty::IfGainAtLeast(gain) if before - best < gain => {
            vec![f64::NAN; params.len()]
        }
        Uncertainty::Never => vec![0.0; params.len()],
        Uncertainty::IfGainAtLeast(_) => curvature_sigma(params, &values, best, n_terms, &chi2),
    };
    let sum_sq = |v: Vec<f64>| v.iter().map(|x| x * x).sum::<f64>();
    let rss = sum_sq(ctx.residual(axis, &trace, offset_s))
        + sum_sq(ctx.residual(axis.other(), other, offset_s));
    accept(
        params,
        Fitted {
            values,
            sigma,
            offset_s,
            rss,
            chi2_stat: best,
            trace,
            other: other.to_vec(),
        },
    )
}

/// A parameter pinned at a bound, or one the data cannot determine, is no identification.
/// Phases come back within (−180°, 180°].
fn accept(params: &[Param], mut f: Fitted) -> Option<Fitted> {
    wrap_phases(params, &mut f.values);
    let pinned = params.iter().zip(&f.values).any(|(q, v)| {
        let span = (q.max - q.min).abs().max(1.0);
        ((*v - q.min).abs() <= 1e-9 * span && q.min > 0.0) || (*v - q.max).abs() <= 1e-9 * span
    });
    (!pinned && f.sigma.iter().all(|s| s.is_finite())).then_some(f)
}

/// The search moves a phase freely (its range is wide so that no bound stops it), so a
/// phase found at 400° is written as the 40° it means.
fn wrap_phases(params: &[Param], values: &mut [f64]) {
    for (p, v) in params.iter().zip(values) {
        if p.key.ends_with("_phase_deg") {
            *v = 180.0 - (180.0 - *v).rem_euclid(360.0);
        }
    }
}

/// Standard uncertainties of a statistical fit from the curvature of its χ² (a −2
/// log-likelihood) around the minimum `best` over `n_terms` terms.
///
/// The χ² of chatter statistics is rough: a slightly different friction gives another
/// realisation of the slips, and χ² jumps by tens between neighbouring points. A curvature
/// from three points would measure that jitter, so a quadratic is fitted by least squares to
/// a grid spanning ±20 % of each value, and its Hessian — all of it, since parameters that
/// trade off (Stribeck level against velocity) lie along a valley only the inverse shows —
/// gives the covariance 2·H⁻¹. Where the fit leaves more χ² than its degrees of freedom, the
/// spreads the terms were scaled by were too small, and the covariance grows by that ratio
/// (Birge's ratio); the jitter of χ² about the quadratic widens it further. NaN only when
/// the quadratic cannot be fitted.
fn curvature_sigma(
    params: &[Param],
    values: &[f64],
    best: f64,
    n_terms: usize,
    objective: &(dyn Fn(&[f64]) -> f64 + Sync),
) -> Vec<f64> {
    let n = params.len();
    let h: Vec<f64> = params
        .iter()
        .zip(values)
        .map(|(q, v)| 0.1 * v.abs().max(0.05 * q.scale))
        .collect();
    // Five levels a parameter: 25 points for the catalogue's two-parameter causes.
    let levels = [-2.0, -1.0, 0.0, 1.0, 2.0];
    let design = grid_of(n, &levels);
    let chi2: Vec<f64> = design
        .par_iter()
        .map(|u| {
            if u.iter().all(|&u| u == 0.0) {
                best
            } else {
                let v: Vec<f64> = values
                    .iter()
                    .zip(u)
                    .zip(&h)
                    .map(|((v, u), h)| v + u * h)
                    .collect();
                objective(&v)
            }
        })
        .collect();
    let Some((hessian, jitter)) = quadratic_fit(&design, &chi2) else {
        return vec![f64::NAN; n];
    };
    let birge = (best / (n_terms as f64 - n as f64).max(1.0)).max(1.0);
    // The jitter: how far χ² scatters about the quadratic. Points whose smooth χ² differ by
    // less than that cannot be ranked, so the minimum found may lie anywhere the smooth χ²
    // rises by less than the jitter: its variance adds to the statistical one (2·jitter/H
    // beside 2·birge/H).
    let level = birge + jitter;
    let Some(eigen) = crate::numeric::decompose::symmetric(hessian) else {
        return vec![f64::NAN; n];
    };
    // Along a direction in which χ² does not rise by 2·birge within the grid (flat, or
    // falling: a valley the data leave open), the data only say the value is not pinned
    // within the grid: its half-width stands for the uncertainty there.
    let half_width = levels[levels.len() - 1];
    let variance_in_steps: Vec<f64> = eigen
        .eigenvalues
        .iter()
        .map(|&curvature| {
            let variance = 2.0 * level / curvature;
            if curvature > 0.0 && variance < half_width * half_width {
                variance
            } else {
                half_width * half_width
            }
        })
        .collect();
    (0..n)
        .map(|j| {
            let steps_sq: f64 = (0..n)
                .map(|i| eigen.eigenvectors[(j, i)].powi(2) * variance_in_steps[i])
                .sum();
            h[j] * steps_sq.sqrt()
        })
        .collect()
}

/// Every point of an `n`-dimensional grid with `levels` on each axis.
fn grid_of(n: usize, levels: &[f64]) -> Vec<Vec<f64>> {
    let mut design = vec![Vec::new()];
    for _ in 0..n {
        design = design
            .into_iter()
            .flat_map(|d: Vec<f64>| {
                levels.iter().map(move |&l| {
                    let mut d = d.clone();
                    d.push(l);
                    d
                })
            })
            .collect();
    }
    design
}

/// The quadratic c + Σ bⱼuⱼ + ½ Σⱼ Hⱼⱼuⱼ² + Σⱼ<ₖ Hⱼₖuⱼuₖ fitted by least squares to the
/// values `y` at the points `design`: its Hessian H, and the jitter — the spread of the
/// values about it. None when it cannot be fitted.
fn quadratic_fit(design: &[Vec<f64>], y: &[f64]) -> Option<(DMatrix<f64>, f64)> {
    let n = design.first().map_or(0, Vec::len);
    let (a, coefficients) = quadratic_system(design, y)?;
    let quadratic_terms = quadratic_terms(n);
    let mut hessian = DMatrix::<f64>::zeros(n, n);
    for (c, &(j, k)) in quadratic_terms.iter().enumerate() {
        hessian[(j, k)] = coefficients[1 + n + c];
        hessian[(k, j)] = coefficients[1 + n + c];
    }
    let y = DVector::from_column_slice(y);
    let columns = a.ncols();
    let jitter =
        ((&y - &a * &coefficients).norm_squared() / (design.len() - columns).max(1) as f64).sqrt();
    Some((hessian, jitter))
}

/// The quadratic's coefficients: constant, linear, then the quadratic terms in the order of
/// [`quadratic_terms`].
fn quadratic_coefficients(design: &[Vec<f64>], y: &[f64]) -> Option<DVector<f64>> {
    quadratic_system(design, y).map(|(_, c)| c)
}

/// The (j, k), k ≤ j, of the quadratic terms of `n` variables.
fn quadratic_terms(n: usize) -> Vec<(usize, usize)> {
    (0..n).flat_map(|j| (0..=j).map(move |k| (j, k))).collect()
}

/// The least-squares system of the quadratic: its design matrix and solution.
fn quadratic_system(design: &[Vec<f64>], y: &[f64]) -> Option<(DMatrix<f64>, DVector<f64>)> {
    let n = design.first().map_or(0, Vec::len);
    let quadratic_terms = quadratic_terms(n);
    let columns = 1 + n + quadratic_terms.len();
    let mut a = DMatrix::<f64>::zeros(design.len(), columns);
    for (row, u) in design.iter().enumerate() {
        a[(row, 0)] = 1.0;
        for j in 0..n {
            a[(row, 1 + j)] = u[j];
        }
        for (c, &(j, k)) in quadratic_terms.iter().enumerate() {
            a[(row, 1 + n + c)] = if j == k {
                0.5 * u[j] * u[j]
            } else {
                u[j] * u[k]
            };
        }
    }
    let y = DVector::from_column_slice(y);
    let coefficients = crate::numeric::decompose::svd(a.clone(), true, true)?
        .solve(&y, 1e-12)
        .ok()?;
    Some((a, coefficients))
}

/// A descent over the cause's parameters on a rough objective (stick-slip statistics), by
/// quadratic surfaces: around the best point so far a 3ⁿ grid spanning ±20 % of each value
/// (at least 5 % of its scale) is evaluated in parallel, a quadratic fitted to it, and its
/// minimum — within one and a half steps of the centre — tried; the best point of all is the
/// next centre, on a grid half as wide. Three rounds. A quadratic through many points
/// averages the objective's jitter, where a simplex's steps follow it, and a round's
/// simulations run side by side. Returns the best values and their cost.
fn surface_descent(
    start: &[f64],
    start_cost: f64,
    params: &[Param],
    cost: &(dyn Fn(&[f64]) -> f64 + Sync),
) -> (Vec<f64>, f64) {
    const ROUNDS: usize = 3;
    let n = params.len();
    let clamp = |v: Vec<f64>| -> Vec<f64> {
        v.iter()
            .zip(params)
            .map(|(x, q)| x.clamp(q.min, q.max))
            .collect()
    };
    let mut best = (start.to_vec(), start_cost);
    let mut h: Vec<f64> = params
        .iter()
        .zip(start)
        .map(|(q, v)| 0.2 * v.abs().max(0.25 * q.scale))
        .collect();
    let design = grid_of(n, &[-1.0, 0.0, 1.0]);
    for _ in 0..ROUNDS {
        let centre = best.0.clone();
        let point = |u: &[f64]| -> Vec<f64> {
            clamp(
                centre
                    .iter()
                    .zip(u)
                    .zip(&h)
                    .map(|((c, u), h)| c + u * h)
                    .collect(),
            )
        };
        let costs: Vec<f64> = design
            .par_iter()
            .map(|u| {
                if u.iter().all(|&u| u == 0.0) {
                    best.1
                } else {
                    cost(&point(u))
                }
            })
            .collect();
        let mut candidates: Vec<(Vec<f64>, f64)> = design
            .iter()
            .zip(&costs)
            .map(|(u, &c)| (point(u), c))
            .collect();
        if let Some(u) = quadratic_minimum(&design, &costs, 1.5) {
            let p = point(&u);
            let c = cost(&p);
            candidates.push((p, c));
        }
        if let Some(b) = candidates
            .into_iter()
            .filter(|c| c.1.is_finite())
            .min_by(|a, b| a.1.total_cmp(&b.1))
            && b.1 < best.1
        {
            best = b;
        }
        h.iter_mut().for_each(|h| *h *= 0.5);
    }
    best
}

/// The minimum of the quadratic fitted to `y` at the points `design` (in steps), when it
/// has one (a positive definite Hessian), each coordinate clamped to ±`within`.
fn quadratic_minimum(design: &[Vec<f64>], y: &[f64], within: f64) -> Option<Vec<f64>> {
    if y.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let n = design.first().map_or(0, Vec::len);
    let (hessian, _) = quadratic_fit(design, y)?;
    let gradient = quadratic_gradient(design, y)?;
    let eigen = crate::numeric::decompose::symmetric(hessian.clone())?;
    if eigen.eigenvalues.iter().any(|&l| l <= 0.0) {
        return None;
    }
    let step = hessian.lu().solve(&(-gradient))?;
    Some((0..n).map(|j| step[j].clamp(-within, within)).collect())
}

/// The linear coefficients (the gradient at the centre) of the quadratic fitted as in
/// [`quadratic_fit`].
fn quadratic_gradient(design: &[Vec<f64>], y: &[f64]) -> Option<DVector<f64>> {
    let n = design.first().map_or(0, Vec::len);
    let coefficients = quadratic_coefficients(design, y)?;
    Some(DVector::from_iterator(
        n,
        (0..n).map(|j| coefficients[1 + j]),
    ))
}

/// Nelder–Mead over the cause's parameters (scaled) from `start`; returns the best values
/// and their cost.
fn nelder_mead(
    start: &[f64],
    start_cost: f64,
    params: &[Param],
    cost: &dyn Fn(&[f64]) -> f64,
) -> (Vec<f64>, f64) {
    use argmin::core::{CostFunction, Error, Executor, State};
    use argmin::solver::neldermead::NelderMead;
    struct Scaled<'a> {
        params: &'a [Param],
        cost: &'a dyn Fn(&[f64]) -> f64,
    }
    impl Scaled<'_> {
        fn values(&self, p: &[f64]) -> Vec<f64> {
            self.params
                .iter()
                .zip(p)
                .map(|(q, v)| (v * q.scale).clamp(q.min, q.max))
                .collect()
        }
    }
    impl CostFunction for Scaled<'_> {
        type Param = Vec<f64>;
        type Output = f64;
        fn cost(&self, p: &Vec<f64>) -> Result<f64, Error> {
            Ok((self.cost)(&self.values(p)))
        }
    }
    let x0: Vec<f64> = params.iter().zip(start).map(|(q, v)| v / q.scale).collect();
    // A simplex spanning a fifth of each parameter's value (at least 5 % of its scale); the
    // clock offset's is a reading, not a size (0.5 s of record before the program), so a
    // quarter of its scale.
    let mut simplex = vec![x0.clone()];
    for j in 0..x0.len() {
        let mut v = x0.clone();
        v[j] += if params[j].key == OFFSET_KEY {
            0.25
        } else {
            (0.2 * x0[j].abs()).max(0.05)
        };
        simplex.push(v);
    }
    let scaled = Scaled { params, cost };
    let solver = NelderMead::new(simplex)
        .with_sd_tolerance(1e-9)
        .expect("a valid tolerance");
    let result = Executor::new(Scaled { params, cost }, solver)
        .configure(|s| s.max_iters(60))
        .run();
    match result {
        Ok(r) => match (r.state().get_best_param(), r.state().get_best_cost()) {
            (Some(p), c) if c < start_cost => (scaled.values(p), c),
            _ => (start.to_vec(), start_cost),
        },
        Err(_) => (start.to_vec(), start_cost),
    }
}

/// The fit's model: `cause` on `axis` of `machine`, the other axis's trace `other` kept
/// unless the cause changes the program's timing. Shared between the Jacobian's threads.
struct Model<'a> {
    ctx: &'a Context<'a>,
    machine: &'a MachineConfig,
    axis: AxisName,
    cause: CauseId,
    other: &'a [f64],
    simulated: Simulated,
}

/// A fit's latest simulations of its own record, by timeline, stepping and parameter values.
/// The same values come back: Nelder–Mead tries points that differ in the clock offset alone
/// (which moves the residual, not the simulation), Levenberg–Marquardt starts where
/// Nelder–Mead ended, and the fit's trace is read where the solver last was. On one record's
/// timeline a simulation depends on its machine and stepping only, so the one kept is the one
/// that would be run.
#[derive(Default)]
struct Simulated(Mutex<VecDeque<(SimulatedAt, Arc<Pair>)>>);

/// Timeline, stepping and parameter values (bit for bit).
type SimulatedAt = (Timeline, Stepping, Vec<u64>);

/// What a simulation of the model's own record was run on: how many commands drive it and
/// where the program starts on them. The record itself is not in the key: only contexts over
/// the measurement the model's context borrows (for the model's life) are kept or looked up;
/// a context over any other record is simulated each time. Not in the key either: the
/// simulator settings, waits and start of a context over the same record — a fit's contexts
/// are its own and a clone of it at another stepping.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Timeline {
    command_samples: usize,
    program_start_s: u64,
}

impl Timeline {
    fn of(on: &Context) -> Self {
        Timeline {
            command_samples: on.commands.x.len(),
            program_start_s: on.program_start_s.to_bits(),
        }
    }
}

/// This axis's trace, and the other axis's where the cause changed it (else the fit's own).
struct Pair {
    trace: Vec<f64>,
    other: Option<Vec<f64>>,
}

/// How many simulations a fit keeps: a simplex's points and a Jacobian's columns.
const SIMULATIONS_KEPT: usize = 16;

/// The fit as a least-squares problem. The solver asks for the residuals and then the
/// Jacobian at the same point: the model's kept simulations serve the second.
struct Problem<'a> {
    model: Model<'a>,
}

/// Residuals, this axis's trace, the other axis's trace.
type Evaluation = (DVector<f64>, Vec<f64>, Vec<f64>);

/// The clock offset's name among a Nelder–Mead search's parameters.
const OFFSET_KEY: &str = "offset";

/// How far from the first alignment a start's own clock offset is looked for (s): as far as
/// the held-out halves' offsets are.
const START_OFFSET_REACH_S: f64 = super::holdout::OFFSET_SEARCH_S;

/// Step of the Jacobian's differences in scaled parameters: 1 % of each one's scale.
const STEP: f64 = 1e-2;

impl Model<'_> {
    /// Both axes' residual sum of squares on `on` at parameter values and an offset.
    fn rss_on(&self, on: &Context, values: &[f64], offset: f64) -> f64 {
        let sum_sq = |v: Vec<f64>| v.iter().map(|x| x * x).sum::<f64>();
        self.pair_on(on, values).map_or(f64::INFINITY, |p| {
            let other = match self.axis {
                // Z is fitted on its own residual.
                AxisName::Z => 0.0,
                _ => sum_sq(on.residual(self.axis.other(), self.other_of(&p), offset)),
            };
            sum_sq(on.residual(self.axis, &p.trace, offset)) + other
        })
    }

    /// Both axes' residual sum of squares on `on` at parameter values, at the clock offset
    /// within [`START_OFFSET_REACH_S`] of `offset` that suits them best (at `offset` itself
    /// where the record fixed it), and that offset. The offset is fitted with the values, so
    /// a start is judged where the fit would take it: a cause's lag has pulled the first
    /// alignment off (backlash delays every reversal, and the aligner takes part of it as
    /// the clock's), and judged at that alignment, a start that makes up for it looks better
    /// than the one that removes it. Only the sampling moves, no simulation.
    fn rss_at_best_offset(&self, on: &Context, values: &[f64], offset: f64) -> (f64, f64) {
        let held = self.rss_on(on, values, offset);
        if !self.fits_offset() || !held.is_finite() {
            return (held, offset);
        }
        let at = |o: f64| self.rss_on(on, values, o);
        let o = golden_section(
            offset - START_OFFSET_REACH_S,
            offset + START_OFFSET_REACH_S,
            1e-6,
            &at,
        );
        match at(o) {
            c if c < held => (c, o),
            _ => (held, offset),
        }
    }

    /// The traces of `machine` with the cause at `values` on `on`: kept from this fit, or
    /// simulated (and kept when `on` is over the model's own record).
    fn pair_on(&self, on: &Context, values: &[f64]) -> Option<Arc<Pair>> {
        let own_record = std::ptr::eq(on.measured, self.ctx.measured);
        let at: SimulatedAt = (
            Timeline::of(on),
            on.stepping,
            values.iter().map(|v| v.to_bits()).collect(),
        );
        if own_record {
            let kept = self.simulated.0.lock().unwrap_or_else(|e| e.into_inner());
            if let Some((_, p)) = kept.iter().find(|(k, _)| *k == at) {
                return Some(p.clone());
            }
        }
        let m = with_cause(self.machine, self.axis, self.cause, values);
        let (trace, other) = on.simulate_pair(&m, self.axis, self.other)?;
        let pair = Arc::new(Pair {
            trace,
            other: match other {
                std::borrow::Cow::Borrowed(_) => None,
                std::borrow::Cow::Owned(o) => Some(o),
            },
        });
        if !own_record {
            return Some(pair);
        }
        let mut kept = self.simulated.0.lock().unwrap_or_else(|e| e.into_inner());
        if kept.len() == SIMULATIONS_KEPT {
            kept.pop_front();
        }
        kept.push_back((at, pair.clone()));
        Some(pair)
    }

    /// The other axis's trace in `pair`.
    fn other_of<'p>(&'p self, pair: &'p Pair) -> &'p [f64] {
        pair.other.as_deref().unwrap_or(self.other)
    }

    /// Nelder–Mead from `start` and `offset_s`: the values, the offset and their residual
    /// sum of squares. The offset belongs to the search (in units of 2 ms) unless the record
    /// fixed it, or parameters would bend to make up for a first alignment that a lag (a
    /// gain error, a dead time) has pulled off.
    fn nelder_mead_from(&self, start: &[f64], offset_s: f64) -> (Vec<f64>, f64, f64) {
        let params = self.cause.params();
        let n = params.len();
        let mut search: Vec<Param> = params.to_vec();
        let mut start_point = start.to_vec();
        if self.fits_offset() {
            search.push(Param {
                key: OFFSET_KEY,
                unit: "s",
                scale: 2e-3,
                min: -1e6,
                max: 1e6,
            });
            start_point.push(offset_s);
        }
        let offset_of = |v: &[f64]| if self.fits_offset() { v[n] } else { offset_s };
        let cost = |v: &[f64]| self.rss_on(self.ctx, &v[..n], offset_of(v));
        let start_cost = self.rss_on(self.ctx, start, offset_s);
        let (point, best) = nelder_mead(&start_point, start_cost, &search, &cost);
        (point[..n].to_vec(), offset_of(&point), best)
    }

    /// Whether the clock offset is fitted (it is known when the record has its commands).
    fn fits_offset(&self) -> bool {
        self.ctx.fixed_offset.is_none()
    }

    /// The parameters' box in scaled units; the offset is free.
    fn settings(&self) -> lsq::Settings {
        let mut bounds: Vec<(f64, f64)> = self
            .cause
            .params()
            .iter()
            .map(|q| (q.min / q.scale, q.max / q.scale))
            .collect();
        if self.fits_offset() {
            bounds.push((f64::NEG_INFINITY, f64::INFINITY));
        }
        lsq::Settings::with_bounds(bounds)
    }

    fn scaled(&self, values: &[f64], offset: f64) -> DVector<f64> {
        let mut p: Vec<f64> = self
            .cause
            .params()
            .iter()
            .zip(values)
            .map(|(q, v)| v / q.scale)
            .collect();
        if self.fits_offset() {
            p.push(offset / self.ctx.dt);
        }
        DVector::from_vec(p)
    }

    fn unscale(&self, p: &DVector<f64>) -> (Vec<f64>, f64) {
        let params = self.cause.params();
        let values = params
            .iter()
            .enumerate()
            .map(|(i, q)| (p[i] * q.scale).clamp(q.min, q.max))
            .collect();
        let offset = match self.ctx.fixed_offset {
            Some(o) => o,
            None => p[params.len()] * self.ctx.dt,
        };
        (values, offset)
    }

    /// This axis's trace and the other's at parameter values.
    fn simulate(&self, values: &[f64]) -> Option<(Vec<f64>, Vec<f64>)> {
        let p = self.pair_on(self.ctx, values)?;
        Some((p.trace.clone(), self.other_of(&p).to_vec()))
    }

    /// Residuals (both axes), this axis's trace and the other's at scaled parameters `p`.
    fn evaluate(&self, p: &DVector<f64>) -> Option<Evaluation> {
        let (values, offset) = self.unscale(p);
        let (trace, other) = self.simulate(&values)?;
        let r = self.residual_with(&trace, &other, offset);
        Some((r, trace, other))
    }

    /// The residual's axes and their traces: X and Y together, Z (a vertical axis the record
    /// has) on its own.
    fn traces<'b>(&self, trace: &'b [f64], other: &'b [f64]) -> Vec<(AxisName, &'b [f64])> {
        match self.axis {
            AxisName::X => vec![(AxisName::X, trace), (AxisName::Y, other)],
            AxisName::Y => vec![(AxisName::X, other), (AxisName::Y, trace)],
            AxisName::Z => vec![(AxisName::Z, trace)],
        }
    }

    fn residual_with(&self, trace: &[f64], other: &[f64], offset: f64) -> DVector<f64> {
        let r: Vec<f64> = self
            .traces(trace, other)
            .into_iter()
            .flat_map(|(a, t)| self.ctx.residual(a, t, offset))
            .collect();
        DVector::from_vec(r)
    }

    /// The offset's column, analytic: r = measured − sim(t − offset), so ∂r/∂offset =
    /// sim'(t − offset), per command period.
    fn offset_column(&self, p: &DVector<f64>, trace: &[f64], other: &[f64]) -> DVector<f64> {
        let (_, offset) = self.unscale(p);
        let d: Vec<f64> = self
            .traces(trace, other)
            .into_iter()
            .flat_map(|(_, t)| self.ctx.residual_rate(t, offset))
            .map(|v| v * self.ctx.dt)
            .collect();
        DVector::from_vec(d)
    }

    /// Standard uncertainties of the cause's parameters from the Jacobian `jac`, in machine
    /// units: the residual's variance per degree of freedom, widened by its correlation time
    /// (a smooth residual holds fewer independent samples than it numbers), and never below
    /// the model's floor — what a modelling difference of half the noise could move them by,
    /// as identification allows: the model is not the machine.
    fn uncertainties(&self, jac: &DMatrix<f64>, rss: f64, residual: &DVector<f64>) -> Vec<f64> {
        let correlation = correlation_time(residual).sqrt();
        let floor = model_floor(
            jac,
            self.ctx.noise_sigma,
            self.ctx.compared_count(self.axis),
        );
        uncertainties(jac, rss, 0.0)
            .into_iter()
            .zip(floor)
            .zip(self.cause.params())
            .map(|((s, f), q)| (s * correlation).max(f) * q.scale)
            .collect()
    }
}

impl lsq::Problem for Problem<'_> {
    fn residuals(&self, p: &DVector<f64>) -> Option<DVector<f64>> {
        self.model.evaluate(p).map(|(r, _, _)| r)
    }

    fn jacobian(&self, p: &DVector<f64>, r0: &DVector<f64>) -> Option<DMatrix<f64>> {
        let model = &self.model;
        let n = model.cause.params().len();
        let bounds = model.settings().bounds;
        let mut jac = forward_jacobian(p, r0, &bounds, STEP, n, &|q| {
            model.evaluate(q).map(|(r, _, _)| r)
        })?;
        if model.fits_offset() {
            let (_, trace, other) = model.evaluate(p)?;
            jac.set_column(n, &model.offset_column(p, &trace, &other));
        }
        Some(jac)
    }
}

#[cfg(test)]
mod tests;
