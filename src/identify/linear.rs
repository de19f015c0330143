//! A first estimate of a current-commanding transfer-function controller and the table it
//! drives, from the record in one linear least-squares solve: where the search by
//! re-simulation starts when the template's controller is tens of percent off.
//!
//! Re-simulation compares trajectories, and a lead-lag controller's residual over its gain
//! and corners has valleys a search from the design's corners stays in. The equation the
//! record obeys is, by contrast, linear in the controller's coefficients. With the current
//! amplifier a lag τ and the drive rigid, the current the controller commands is
//!
//! ```text
//! u = (τ·s + 1)·(M·s²x + b·s·x + F_c·sgn v) / k     (k = K_t / (r·i_t): force per ampere)
//! D(s)·u = N(s)·e                                     (the controller: e the error in mm)
//! ```
//!
//! so `D(s)·(τs + 1)·(M s²x + b s x + F_c sgn v) = k·N(s)·e`, linear in the coefficients of N
//! and D — the classic equation-error method. The derivatives are taken through one
//! state-variable filter 1/(s + λ)ⁿ applied to every signal alike, which leaves the equation
//! as it was and keeps the record's noise from being differentiated.
//!
//! Two things the equation cannot give, the template does:
//!
//! - **The scale.** The equation is homogeneous in the drive's inertia M and the controller:
//!   the loop sees only their ratio, and a rigid drive tells no rotor from table. M is the
//!   template's (the rotor's and screw's inertia with the table's mass), and the gain found
//!   is relative to it; the fit by re-simulation then moves both, and says how far the
//!   record tells them apart.
//! - **The friction.** Only the rows where the command has slid for a while are used (the
//!   filter's memory is shorter), so the standstills' sticking never enters; but there the
//!   friction is nearly constant, and an integrating controller's D(s) has no constant
//!   term: its level drops out of the equation. Left free it only follows the noise, so it
//!   is the template's, and the grid over it that follows finds it.
//!
//! What the rigid-drive equation leaves out (the screw's compliance, the bias of an equation
//! error from the noise) the fit by re-simulation settles; this only has to land in its
//! valley. On the lead-lag table of the tests, recorded by an independent integrator, it
//! finds the corners 20–30 % off the design within 1 % and the gain within 1 %.

use nalgebra::{DMatrix, DVector};

use super::Sliding;
use super::knobs::{Knob, TF_GAIN_KEY, corner_of, corners, get, set_all};
use super::solve::Fit;
use crate::machine::{AxisConfig, Controller, ControllerOutput};
use crate::numeric::decompose;
use crate::numeric::poly;
use crate::numeric::units::mm_from_m;
use crate::sim::AxisModel;
use crate::trace::signal::sample;

/// The state-variable filter's corner (Hz): near the position loops' crossover, where the
/// record says most about the controller.
const FILTER_HZ: f64 = 30.0;
/// How far from the template an estimate may land and still be taken (a factor either way,
/// as the fit by re-simulation searches).
const PLAUSIBLE_FACTOR: f64 = 10.0;

/// `template` with what the record's equation says of its controller: the gain, and the
/// corners where they are among `knobs` (the fit frees them). None where the structure is
/// not one this applies to (a current-commanding transfer function in s on a current
/// amplifier), or the estimate is not a controller the search would reach (a corner in the
/// right half-plane or grouped otherwise than the template's, a value ten times off).
pub(super) fn first_estimate(
    fit: &Fit,
    knobs: &[Knob],
    template: &AxisConfig,
) -> Option<AxisConfig> {
    let Controller::TransferFunction(tf) = &template.controller else {
        return None;
    };
    if tf.output != ControllerOutput::Current || tf.sample_ms != 0.0 {
        return None;
    }
    let model = AxisModel::from_config(template);
    let drive = Drive {
        tau: model.amplifier_tau?,
        force_per_amp: model.kt / model.travel_per_motor_rad(),
        mass_kg: model.mass_at_table_kg(),
        viscous_n_s_per_m: model.f_v,
        coulomb_n: model.f_c,
        accel_feedforward: model.ka,
    };
    let corners_free = knobs.iter().any(Knob::is_corner);
    let shape = Shape::of(&tf.numerator, &tf.denominator, corners_free)?;
    let solved = solve(&Signals::read(fit, template)?, &shape, &drive)?;
    let mut keys: Vec<&'static str> = vec![TF_GAIN_KEY];
    let mut values: Vec<f64> = vec![solved.low_frequency_gain()];
    for k in knobs.iter().filter(|k| k.is_corner()) {
        keys.push(k.key);
        values.push(corner_of_estimate(
            &solved,
            &tf.numerator,
            &tf.denominator,
            k.key,
        )?);
    }
    let within_reach = keys.iter().zip(&values).all(|(key, value)| {
        let was = get(template, key);
        value.is_finite() && *value < PLAUSIBLE_FACTOR * was && *value > was / PLAUSIBLE_FACTOR
    });
    if !within_reach {
        return None;
    }
    let mut estimate = template.clone();
    set_all(&mut estimate, &keys, &values);
    Some(estimate)
}

/// The drive as the equation sees it: rigid, behind a first-order current amplifier.
struct Drive {
    /// The amplifier's time constant (s).
    tau: f64,
    /// Force at the table per ampere, K_t/(r·i_t) (N/A).
    force_per_amp: f64,
    /// The whole drive's inertia as a mass at the table, the template's (kg).
    mass_kg: f64,
    /// Viscous friction, the template's (N·s/m).
    viscous_n_s_per_m: f64,
    /// Coulomb friction, the template's (N).
    coulomb_n: f64,
    /// Share of the accelerating current fed forward.
    accel_feedforward: f64,
}

/// The controller's polynomials normalised to a monic denominator, and which of their
/// coefficients the solve frees: with the corners free, every one the template has (its
/// integrators, zero coefficients, stay zero); with them fixed, only the numerator's scale.
struct Shape {
    /// Numerator by power (index p: coefficient of sᵖ), over the denominator's leading one.
    numerator: Vec<f64>,
    /// Monic denominator by power.
    denominator: Vec<f64>,
    /// Whether the coefficients are free (else only the numerator's scale).
    free: bool,
}

impl Shape {
    fn of(numerator: &[f64], denominator: &[f64], free: bool) -> Option<Shape> {
        let lead = *denominator.iter().find(|c| **c != 0.0)?;
        let by_power = |c: &[f64]| -> Vec<f64> {
            let first = c.iter().position(|v| *v != 0.0).unwrap_or(c.len());
            c[first..].iter().rev().map(|v| v / lead).collect()
        };
        let (numerator, denominator) = (by_power(numerator), by_power(denominator));
        if numerator.is_empty() || denominator.len() < numerator.len() {
            return None;
        }
        Some(Shape {
            numerator,
            denominator,
            free,
        })
    }

    /// The denominator's degree.
    fn order(&self) -> usize {
        self.denominator.len() - 1
    }

    /// Powers of the denominator below its leading one that the solve frees.
    fn free_poles(&self) -> Vec<usize> {
        if !self.free {
            return Vec::new();
        }
        (0..self.order())
            .filter(|&p| self.denominator[p] != 0.0)
            .collect()
    }

    /// Powers of the numerator the solve frees (all that are there, with the corners free).
    fn free_zeros(&self) -> Vec<usize> {
        (0..self.numerator.len())
            .filter(|&p| self.numerator[p] != 0.0)
            .collect()
    }
}

/// The record's signals on its own clock, with the samples the equation is written at.
struct Signals {
    /// Sample period (s).
    h: f64,
    /// Measured position, from the first sample (m).
    position_m: Vec<f64>,
    /// Position error as the controller sees it (mm).
    error_mm: Vec<f64>,
    /// The sliding direction: the commanded speed's sign, 0 standing.
    direction: Vec<f64>,
    /// Commanded acceleration (m/s²), for the feed-forward.
    accel_m_per_s2: Vec<f64>,
    /// Samples the equation is written at: the command moving for a while.
    rows: Vec<bool>,
}

impl Signals {
    fn read(fit: &Fit, template: &AxisConfig) -> Option<Signals> {
        let ctx = fit.ctx();
        let axis = fit.axis();
        let measured = ctx.measured_axis(axis);
        let n = measured.len();
        let h = ctx.measured.dt_s;
        if n < 100 || h.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            return None;
        }
        let commands = ctx.commands.axis(axis);
        let dead_s = template.position_loop.dead_time_ms * 1e-3;
        // A row once the command has slid as long as identification's "compared while
        // moving" asks — several times the filter's memory, n/λ.
        let sliding = Sliding::of(ctx, axis);
        let origin = measured[0];
        let (mut position_m, mut error_mm, mut direction, mut accel_m_per_s2, mut rows) = (
            Vec::with_capacity(n),
            Vec::with_capacity(n),
            Vec::with_capacity(n),
            Vec::with_capacity(n),
            Vec::with_capacity(n),
        );
        for (i, &x) in measured.iter().enumerate() {
            let t = ctx.prog_time(i, fit.offset()) - dead_s;
            let x_ref = sample(&commands.pos_m, ctx.dt, t);
            let a_ref = sample(&commands.acc_m_per_s2, ctx.dt, t);
            if !(x.is_finite() && x_ref.is_finite() && a_ref.is_finite()) {
                return None;
            }
            position_m.push(x - origin);
            error_mm.push(mm_from_m(x_ref - x));
            direction.push(sliding.direction_at(ctx, t));
            accel_m_per_s2.push(a_ref);
            rows.push(sliding.settled_at(ctx, t));
        }
        Some(Signals {
            h,
            position_m,
            error_mm,
            direction,
            accel_m_per_s2,
            rows,
        })
    }
}

/// What the solve found: the controller's polynomials (monic denominator, by power).
struct Solved {
    numerator: Vec<f64>,
    denominator: Vec<f64>,
}

impl Solved {
    /// The ratio of the lowest-order coefficients that are not zero, as the knob measures
    /// the gain.
    fn low_frequency_gain(&self) -> f64 {
        let lowest = |c: &[f64]| c.iter().copied().find(|v| *v != 0.0).unwrap_or(f64::NAN);
        lowest(&self.numerator) / lowest(&self.denominator)
    }
}

/// The equation's unknowns, in the order of the regression's columns.
#[derive(Clone, Copy, PartialEq, Debug)]
enum Unknown {
    /// The denominator's coefficient of sᵖ.
    Pole(usize),
    /// The numerator's coefficient of sᵖ.
    Zero(usize),
    /// The whole numerator's scale, its shape the template's.
    Scale,
}

/// The record's signals through the state-variable filter 1/(s + λ)ⁿ with their
/// derivatives, and the drive they are read through.
struct Filtered<'d> {
    x: Vec<Vec<f64>>,
    sgn: Vec<Vec<f64>>,
    e: Vec<Vec<f64>>,
    a: Vec<Vec<f64>>,
    drive: &'d Drive,
}

impl<'d> Filtered<'d> {
    fn of(signals: &Signals, order: usize, drive: &'d Drive) -> Filtered<'d> {
        let lambda = std::f64::consts::TAU * FILTER_HZ;
        let through = |u: &[f64]| filtered(u, order, lambda, signals.h);
        Filtered {
            x: through(&signals.position_m),
            sgn: through(&signals.direction),
            e: through(&signals.error_mm),
            a: through(&signals.accel_m_per_s2),
            drive,
        }
    }

    /// sᵠ of the force on the drive (filtered): accelerating it and pushing its friction.
    fn force(&self, q: usize, i: usize) -> f64 {
        let d = self.drive;
        d.mass_kg * self.x[q + 2][i]
            + d.viscous_n_s_per_m * self.x[q + 1][i]
            + d.coulomb_n * self.sgn[q][i]
    }

    /// sᵖ of what the controller commands (filtered): the current for that force, the
    /// amplifier's lag undone, less the current fed forward.
    fn current(&self, p: usize, i: usize) -> f64 {
        let d = self.drive;
        (d.tau * self.force(p + 1, i) + self.force(p, i)
            - d.accel_feedforward * d.mass_kg * self.a[p][i])
            / d.force_per_amp
    }
}

/// Solves the record's equation for the controller.
fn solve(signals: &Signals, shape: &Shape, drive: &Drive) -> Option<Solved> {
    let n = shape.order();
    // The highest derivative: sⁿ·(τs + 1)·s²x.
    let f = Filtered::of(signals, n + 4, drive);
    let free_poles = shape.free_poles();
    let fixed_poles: Vec<(usize, f64)> = (0..=n)
        .filter(|p| !free_poles.contains(p))
        .map(|p| (p, shape.denominator[p]))
        .filter(|(_, c)| *c != 0.0)
        .collect();
    let mut unknowns: Vec<Unknown> = free_poles.iter().map(|&p| Unknown::Pole(p)).collect();
    if shape.free {
        unknowns.extend(shape.free_zeros().into_iter().map(Unknown::Zero));
    } else {
        unknowns.push(Unknown::Scale);
    }
    let rows: Vec<usize> = (0..signals.rows.len())
        .filter(|&i| signals.rows[i])
        .collect();
    if rows.len() < 10 * unknowns.len() {
        return None;
    }
    let column = |u: Unknown, i: usize| -> f64 {
        match u {
            Unknown::Pole(p) => f.current(p, i),
            Unknown::Zero(p) => -f.e[p][i],
            Unknown::Scale => -shape
                .numerator
                .iter()
                .enumerate()
                .map(|(p, c)| c * f.e[p][i])
                .sum::<f64>(),
        }
    };
    let rhs = |i: usize| -> f64 {
        -fixed_poles
            .iter()
            .map(|&(p, c)| c * f.current(p, i))
            .sum::<f64>()
    };
    let theta = least_squares(&rows, unknowns.len(), |i, c| column(unknowns[c], i), rhs)?;
    let value = |u: Unknown| unknowns.iter().position(|q| *q == u).map(|c| theta[c]);
    let mut denominator = shape.denominator.clone();
    for &p in &free_poles {
        denominator[p] = value(Unknown::Pole(p))?;
    }
    let numerator = if shape.free {
        let mut c = vec![0.0; shape.numerator.len()];
        for p in shape.free_zeros() {
            c[p] = value(Unknown::Zero(p))?;
        }
        c
    } else {
        let scale = value(Unknown::Scale)?;
        shape.numerator.iter().map(|c| c * scale).collect()
    };
    Some(Solved {
        numerator,
        denominator,
    })
}

/// The least-squares solution of `entry(row, column)·θ = rhs(row)` over `rows`, solved in
/// unit-norm columns (their sizes differ by orders of magnitude); none where a column is
/// empty or the solve fails.
fn least_squares(
    rows: &[usize],
    columns: usize,
    entry: impl Fn(usize, usize) -> f64,
    rhs: impl Fn(usize) -> f64,
) -> Option<Vec<f64>> {
    let mut m = DMatrix::<f64>::zeros(rows.len(), columns);
    let mut b = DVector::<f64>::zeros(rows.len());
    for (r, &i) in rows.iter().enumerate() {
        for c in 0..columns {
            m[(r, c)] = entry(i, c);
        }
        b[r] = rhs(i);
    }
    let norms: Vec<f64> = (0..columns).map(|c| m.column(c).norm()).collect();
    if norms.iter().any(|v| !(v.is_finite() && *v > 0.0)) {
        return None;
    }
    for (c, norm) in norms.iter().enumerate() {
        m.column_mut(c).unscale_mut(*norm);
    }
    let theta = decompose::svd(m, true, true)?.solve(&b, 1e-12).ok()?;
    Some((0..columns).map(|c| theta[c] / norms[c]).collect())
}

/// The corner `key` names, read from the solved polynomials with the template's grouping of
/// roots: a corner the template repeats (a double zero, moving as one) is the geometric mean
/// of as many solved roots; a complex pair there counts by its modulus. None where a root is
/// not in the left half-plane or the roots do not group as the template's do.
fn corner_of_estimate(
    solved: &Solved,
    numerator: &[f64],
    denominator: &[f64],
    key: &str,
) -> Option<f64> {
    let (zero, k) = corner_of(key)?;
    let (template, found) = if zero {
        (numerator, &solved.numerator)
    } else {
        (denominator, &solved.denominator)
    };
    // The template's roots as the knobs name them: its real left-half-plane ones, lowest
    // first, with their multiplicities; its integrators exactly at zero.
    let (groups, real) = corners(template);
    let integrators: usize = groups
        .iter()
        .filter(|g| g.0.norm() == 0.0)
        .map(|g| g.1)
        .sum();
    let multiplicities: Vec<usize> = real.iter().map(|&i| groups[i].1).collect();
    // The solved polynomial's roots, highest power first for `poly`, its integrators (the
    // template's, kept exactly at zero) left out.
    let by_descending: Vec<f64> = found.get(integrators..)?.iter().rev().copied().collect();
    let mut roots = poly::roots(&by_descending);
    if roots.len() != multiplicities.iter().sum::<usize>() || roots.iter().any(|r| r.re >= 0.0) {
        return None;
    }
    roots.sort_by(|a, b| a.norm().total_cmp(&b.norm()));
    let mut next = 0;
    for (i, &multiplicity) in multiplicities.iter().enumerate() {
        let group = &roots[next..next + multiplicity];
        next += multiplicity;
        let complex = group.iter().any(|r| r.im.abs() > 1e-9 * r.norm());
        if complex && multiplicity == 1 {
            return None;
        }
        if i == k {
            let log_mean = group.iter().map(|r| r.norm().ln()).sum::<f64>() / multiplicity as f64;
            return Some(log_mean.exp() / std::f64::consts::TAU);
        }
    }
    None
}

/// `u` through 1/(s + λ)ⁿ and its first n − 1 derivatives: `out[j][i]` is sʲ/(s + λ)ⁿ·u at
/// sample i, integrated by fourth-order Runge–Kutta with `u` linear between samples,
/// starting at rest at `u`'s first value.
fn filtered(u: &[f64], order: usize, lambda: f64, h: f64) -> Vec<Vec<f64>> {
    // (s + λ)ⁿ = Σ c_j sʲ: the companion form's last row.
    let mut c = vec![1.0];
    for _ in 0..order {
        let mut next = vec![0.0; c.len() + 1];
        for (j, v) in c.iter().enumerate() {
            next[j] += lambda * v;
            next[j + 1] += v;
        }
        c = next;
    }
    let derivative = |z: &[f64], input: f64, dz: &mut [f64]| {
        dz[..order - 1].copy_from_slice(&z[1..order]);
        dz[order - 1] = input - (0..order).map(|j| c[j] * z[j]).sum::<f64>();
    };
    let mut z = vec![0.0; order];
    z[0] = u.first().copied().unwrap_or(0.0) / c[0];
    let mut out = vec![Vec::with_capacity(u.len()); order];
    let (mut k1, mut k2, mut k3, mut k4) = (
        vec![0.0; order],
        vec![0.0; order],
        vec![0.0; order],
        vec![0.0; order],
    );
    let mut tmp = vec![0.0; order];
    // One step per sample: λ·h is a few hundredths at a servo trace's rates, where the
    // fourth-order error is far below the record's counts.
    for i in 0..u.len() {
        for (j, v) in z.iter().enumerate() {
            out[j].push(*v);
        }
        let (from, to) = (u[i], u.get(i + 1).copied().unwrap_or(u[i]));
        let middle = 0.5 * (from + to);
        derivative(&z, from, &mut k1);
        for j in 0..order {
            tmp[j] = z[j] + 0.5 * h * k1[j];
        }
        derivative(&tmp, middle, &mut k2);
        for j in 0..order {
            tmp[j] = z[j] + 0.5 * h * k2[j];
        }
        derivative(&tmp, middle, &mut k3);
        for j in 0..order {
            tmp[j] = z[j] + h * k3[j];
        }
        derivative(&tmp, to, &mut k4);
        for j in 0..order {
            z[j] += h / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j]);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_filter_differentiates_a_ramp_and_a_parabola() {
        // Through 1/(s + λ)ⁿ a ramp's first filtered derivative settles at slope/λⁿ and its
        // second at zero; a parabola's second at its curvature/λⁿ.
        let (h, lambda, order) = (1e-4, 200.0, 5);
        let t: Vec<f64> = (0..20_000).map(|i| i as f64 * h).collect();
        let ramp: Vec<f64> = t.iter().map(|t| 3.0 * t).collect();
        let parabola: Vec<f64> = t.iter().map(|t| 0.5 * 4.0 * t * t).collect();
        let f = filtered(&ramp, order, lambda, h);
        let scale = lambda.powi(order as i32);
        let last = t.len() - 1;
        assert!(
            (f[1][last] * scale - 3.0).abs() < 1e-6,
            "{}",
            f[1][last] * scale
        );
        assert!((f[2][last] * scale).abs() < 1e-6);
        let f = filtered(&parabola, order, lambda, h);
        assert!(
            (f[2][last] * scale - 4.0).abs() < 1e-6,
            "{}",
            f[2][last] * scale
        );
        assert!((f[3][last] * scale).abs() < 1e-5);
    }
}
