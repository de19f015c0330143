//! A transfer-function controller as states the simulator can integrate exactly: the
//! controllable canonical realisation of C(s), after taking a discrete C(z) to continuous
//! time by the inverse bilinear map.
//!
//! The controller's states live in the axis's state vector, in the places of the current
//! loop's filters and integrals, which a drive with a current amplifier does not have (see
//! `model.rs`): so the position controller is part of each mode's linear dynamics and keeps
//! the simulator exact, with no extra cost per step.

use crate::machine::{ControllerOutput, TransferFunction};

/// The most controller states an axis has room for, by what the controller commands: a
/// velocity-mode drive keeps its velocity integral.
pub(crate) fn max_order(output: ControllerOutput) -> usize {
    match output {
        ControllerOutput::Current => 4,
        ControllerOutput::Velocity => 3,
    }
}

/// ẋ = A x + B e, y = C x + D e, with e the position error (mm) and y the controller's
/// output in the machine file's unit (A, or m/min). A is the companion matrix of the monic
/// denominator (last row −a₀ … −aₙ₋₁), B the last unit vector.
#[derive(Debug, Clone, PartialEq)]
pub struct Realisation {
    /// Denominator coefficients a₀ … aₙ₋₁ of sⁿ + aₙ₋₁sⁿ⁻¹ + … + a₀.
    pub den: Vec<f64>,
    /// Output weights c₀ … cₙ₋₁ on the states.
    pub c: Vec<f64>,
    /// Direct feedthrough.
    pub d: f64,
}

impl Realisation {
    /// Number of states.
    pub(crate) fn order(&self) -> usize {
        self.den.len()
    }

    /// Row `i` of A as (state index, coefficient) pairs.
    pub(crate) fn a_row(&self, i: usize) -> Vec<(usize, f64)> {
        let n = self.order();
        if i + 1 < n {
            vec![(i + 1, 1.0)]
        } else {
            self.den.iter().enumerate().map(|(j, &a)| (j, -a)).collect()
        }
    }

    /// B's entry for state `i`.
    pub(crate) fn b(&self, i: usize) -> f64 {
        if i + 1 == self.order() { 1.0 } else { 0.0 }
    }

    /// C(s) at a complex frequency (for tests and checks).
    #[cfg(test)]
    pub(crate) fn response(&self, s: nalgebra::Complex<f64>) -> nalgebra::Complex<f64> {
        // With the companion form, C(sI − A)⁻¹B = (Σ cᵢ sⁱ)/(sⁿ + Σ aᵢ sⁱ).
        let poly = |coefficients: &[f64], lead: f64| {
            let mut value = nalgebra::Complex::new(lead, 0.0);
            for &a in coefficients.iter().rev() {
                value = value * s + a;
            }
            value
        };
        let den = poly(&self.den, 1.0);
        let num = self
            .c
            .iter()
            .rev()
            .fold(nalgebra::Complex::new(0.0, 0.0), |acc, &c| acc * s + c);
        num / den + self.d
    }
}

/// The realisation of a machine file's transfer function, or what makes it impossible.
pub(crate) fn realise(tf: &TransferFunction) -> Result<Realisation, String> {
    let (mut num, mut den) = (trimmed(&tf.numerator), trimmed(&tf.denominator));
    if den.is_empty() {
        return Err("is zero: a controller divides by it".into());
    }
    if tf.sample_ms > 0.0 {
        let n = (num.len().max(den.len())) - 1;
        let half_period_s = 0.5e-3 * tf.sample_ms;
        num = trimmed(&continuous_from_discrete(&num, n, half_period_s));
        den = trimmed(&continuous_from_discrete(&den, n, half_period_s));
        if den.len() < n + 1 {
            return Err(format!(
                "has a pole at z = −1 (a sign flip every sample): it has no continuous \
                 equivalent, and no position controller needs it (sample_ms = {})",
                tf.sample_ms
            ));
        }
    }
    if num.len() > den.len() {
        return Err(format!(
            "is of degree {} and the numerator of degree {}: the controller would be improper \
             (a derivative without a filter pole)",
            den.len() - 1,
            num.len() - 1
        ));
    }
    let order = den.len() - 1;
    let limit = max_order(tf.output);
    if order > limit {
        return Err(format!(
            "is of degree {order}: a controller commanding {} has room for {limit} states",
            match tf.output {
                ControllerOutput::Current => "current",
                ControllerOutput::Velocity => "a velocity-mode drive",
            }
        ));
    }
    // Monic denominator; the numerator's part of degree n is the feedthrough.
    let lead = den[0];
    let den: Vec<f64> = den.iter().map(|a| a / lead).collect();
    let mut num: Vec<f64> = num.iter().map(|b| b / lead).collect();
    while num.len() < den.len() {
        num.insert(0, 0.0);
    }
    let d = num[0];
    // Highest first → lowest first, less the feedthrough's share of the denominator.
    let c: Vec<f64> = (0..order)
        .map(|i| num[order - i] - d * den[order - i])
        .collect();
    let a: Vec<f64> = (0..order).map(|i| den[order - i]).collect();
    Ok(Realisation { den: a, c, d })
}

/// Coefficients without leading zeros.
fn trimmed(coefficients: &[f64]) -> Vec<f64> {
    let first = coefficients.iter().position(|&c| c != 0.0);
    first.map_or_else(Vec::new, |i| coefficients[i..].to_vec())
}

/// p(z) of degree ≤ n (highest first) under z = (1 + sT/2)/(1 − sT/2), times (1 − sT/2)ⁿ:
/// Σ pₖ (1 + sT/2)ᵏ (1 − sT/2)ⁿ⁻ᵏ, highest power of s first.
fn continuous_from_discrete(p: &[f64], n: usize, half_period_s: f64) -> Vec<f64> {
    let plus = [half_period_s, 1.0];
    let minus = [-half_period_s, 1.0];
    let mut out = vec![0.0; n + 1];
    let degree = p.len() - 1;
    for (i, &coefficient) in p.iter().enumerate() {
        let k = degree - i;
        let mut term = vec![coefficient];
        for _ in 0..k {
            term = multiply(&term, &plus);
        }
        for _ in 0..n - k {
            term = multiply(&term, &minus);
        }
        for (o, t) in out.iter_mut().zip(&term) {
            *o += t;
        }
    }
    out
}

/// Product of two polynomials, highest power first.
fn multiply(a: &[f64], b: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; a.len() + b.len() - 1];
    for (i, x) in a.iter().enumerate() {
        for (j, y) in b.iter().enumerate() {
            out[i + j] += x * y;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Complex;

    fn tf(num: &[f64], den: &[f64], sample_ms: f64) -> TransferFunction {
        TransferFunction {
            numerator: num.to_vec(),
            denominator: den.to_vec(),
            output: ControllerOutput::Current,
            sample_ms,
            velocity_feedforward: 0.0,
            accel_feedforward: 0.0,
        }
    }

    #[test]
    fn the_realisation_has_the_transfer_functions_response() {
        // A lead-lag with an integrator: 40·(s + 50)(s + 200) / (s (s + 1500)).
        let num = [40.0, 40.0 * 250.0, 40.0 * 10_000.0];
        let den = [1.0, 1500.0, 0.0];
        let r = realise(&tf(&num, &den, 0.0)).unwrap();
        assert_eq!(r.order(), 2);
        for f_hz in [0.3, 10.0, 240.0, 5000.0] {
            let s = Complex::new(0.0, std::f64::consts::TAU * f_hz);
            let want = (s + 50.0) * (s + 200.0) * 40.0 / (s * (s + 1500.0));
            let got = r.response(s);
            assert!(
                (got - want).norm() < 1e-9 * want.norm(),
                "{f_hz} Hz: {got} vs {want}"
            );
        }
    }

    #[test]
    fn a_discrete_controller_maps_back_to_the_one_tustin_made_it_from() {
        // PI 2 + 30/s, discretised by Tustin at 1 ms: C(z) = (a z − b)/(z − 1) with
        // a = 2 + 30·T/2, b = 2 − 30·T/2.
        let t = 1e-3;
        let (a, b) = (2.0 + 15.0 * t, 2.0 - 15.0 * t);
        let r = realise(&tf(&[a, -b], &[1.0, -1.0], 1.0)).unwrap();
        assert_eq!(r.order(), 1);
        assert!(
            r.den[0].abs() < 1e-12,
            "integrator kept at s = 0: {:?}",
            r.den
        );
        assert!(
            (r.d - 2.0).abs() < 1e-12 && (r.c[0] - 30.0).abs() < 1e-9,
            "{r:?}"
        );
    }

    #[test]
    fn impossible_controllers_say_why() {
        let e = realise(&tf(&[1.0, 0.0], &[1.0], 0.0)).unwrap_err();
        assert!(e.contains("improper"), "{e}");
        let e = realise(&tf(&[1.0], &[0.0, 0.0], 0.0)).unwrap_err();
        assert!(e.contains("is zero"), "{e}");
        let e = realise(&tf(&[1.0], &[1.0, 1.0], 1.0)).unwrap_err();
        assert!(e.contains("z = −1"), "{e}");
        let e = realise(&tf(&[1.0], &[1.0, 1.0, 1.0, 1.0, 1.0, 1.0], 0.0)).unwrap_err();
        assert!(e.contains("room for 4"), "{e}");
    }
}
