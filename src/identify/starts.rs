//! Where the search over a transfer function's corners may start. A controller on a real
//! machine can sit several times off its design — tuned on the machine after it was designed
//! — and the residual over its corners has valleys between: a local search from the design
//! stays in the first, and the record's equation solved linearly (`linear`) does not always
//! give a controller to start from (a real table's record gave a complex pair where the
//! design has two real zeros). So the corners are tried on a coarse grid of factors on the
//! design's, each one on its own, by re-simulating the record: every candidate keeps the
//! controller's gain at the design's loop crossover (the loop stays where the design put
//! it), then has its gain fitted alone, and is scored by the residual left. The local
//! search then starts from the best few. A candidate's corners keep the design's order (a
//! lead stays a lead), so that the candidates are controllers of the structure the user
//! wrote rather than others.

use nalgebra::Complex;
use rayon::prelude::*;

use super::knobs::{Knob, TF_GAIN_KEY, get, set_all};
use super::solve::Fit;
use crate::machine::{AxisConfig, Controller, TransferFunction};
use crate::sim::AxisModel;
use crate::sim::linear::Loop;
use crate::sim::margins::loop_margins;

/// Factors on each of the design's corners that the candidates take: a controller tuned
/// on the machine up to four times off its design either way is within a factor √2 of one.
const CORNER_FACTORS: [f64; 5] = [0.25, 0.5, 1.0, 2.0, 4.0];
/// How many of the best candidates the local search starts from.
const CORNER_STARTS: usize = 2;

/// The starts of the search over `knobs` from `design`, best first: where the corners of a
/// transfer function are free, at most [`CORNER_STARTS`] of the candidates (the design
/// among them) by the residual their gain fitted alone leaves; else just the design.
pub(super) fn candidates(fit: &Fit, knobs: &[Knob], design: &AxisConfig) -> Vec<AxisConfig> {
    let corners: Vec<&'static str> = knobs
        .iter()
        .filter(|k| k.is_corner())
        .map(|k| k.key)
        .collect();
    let Some(gain) = knobs.iter().find(|k| k.key == TF_GAIN_KEY) else {
        return vec![design.clone()];
    };
    if corners.is_empty() {
        return vec![design.clone()];
    }
    let at_hz = crossover_hz(design).unwrap_or_else(|| {
        // Without a crossover, the middle of the design's corners.
        let logs: f64 = corners.iter().map(|k| get(design, k).ln()).sum();
        (logs / corners.len() as f64).exp()
    });
    let mut pool: Vec<AxisConfig> = vec![design.clone()];
    pool.extend(
        factor_sets(corners.len())
            .into_iter()
            .filter_map(|f| scaled(design, &corners, &f, at_hz))
            .filter(|c| c != design),
    );
    let mut scored: Vec<(f64, AxisConfig)> = pool
        .par_iter()
        .filter_map(|c| fit.searched(std::slice::from_ref(gain), c))
        .filter(|(cost, _)| cost.is_finite())
        .collect();
    scored.sort_by(|a, b| a.0.total_cmp(&b.0));
    scored.truncate(CORNER_STARTS);
    if scored.is_empty() {
        return vec![design.clone()];
    }
    scored.into_iter().map(|(_, c)| c).collect()
}

/// Every combination of [`CORNER_FACTORS`] on `n` corners.
fn factor_sets(n: usize) -> Vec<Vec<f64>> {
    (0..n).fold(vec![Vec::new()], |sets, _| {
        sets.into_iter()
            .flat_map(|s| {
                CORNER_FACTORS.iter().map(move |&f| {
                    let mut t = s.clone();
                    t.push(f);
                    t
                })
            })
            .collect()
    })
}

/// `design` with its `corners` at `factors` times the design's, where they keep the
/// design's order, with the gain set so that the controller's magnitude at `at_hz` is the
/// design's.
fn scaled(
    design: &AxisConfig,
    corners: &[&'static str],
    factors: &[f64],
    at_hz: f64,
) -> Option<AxisConfig> {
    let was: Vec<f64> = corners.iter().map(|k| get(design, k)).collect();
    let now: Vec<f64> = was.iter().zip(factors).map(|(v, f)| v * f).collect();
    let same_order = (0..was.len()).all(|i| {
        (0..was.len()).all(|j| (was[i] < was[j]) == (now[i] < now[j]) || was[i] == was[j])
    });
    if !same_order || now.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let mut c = design.clone();
    set_all(&mut c, corners, &now);
    let ratio = magnitude(design, at_hz)? / magnitude(&c, at_hz)?;
    let gain = get(&c, TF_GAIN_KEY) * ratio;
    set_all(&mut c, &[TF_GAIN_KEY], &[gain]);
    gain.is_finite().then_some(c)
}

/// The design's position-loop crossover (Hz), where its loop has one.
fn crossover_hz(design: &AxisConfig) -> Option<f64> {
    loop_margins(&AxisModel::from_config(design), Loop::Position).crossover_hz
}

/// |C(j·2π·f)| of an axis's transfer-function controller.
fn magnitude(axis: &AxisConfig, hz: f64) -> Option<f64> {
    let Controller::TransferFunction(tf) = &axis.controller else {
        return None;
    };
    let m = response(tf, hz).norm();
    (m.is_finite() && m > 0.0).then_some(m)
}

fn response(tf: &TransferFunction, hz: f64) -> Complex<f64> {
    let s = Complex::new(0.0, std::f64::consts::TAU * hz);
    let eval = |c: &[f64]| c.iter().fold(Complex::new(0.0, 0.0), |acc, &v| acc * s + v);
    eval(&tf.numerator) / eval(&tf.denominator)
}
