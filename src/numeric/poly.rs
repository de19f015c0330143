//! Polynomials by their roots: the roots of a real polynomial (the eigenvalues of its
//! companion matrix), and the polynomial back from its roots and leading coefficient. A
//! transfer function's zeros and poles are fitted this way, each moved while the others stay.

use nalgebra::{Complex, DMatrix};

/// The roots of `c[0]·sⁿ + c[1]·sⁿ⁻¹ + … + c[n]` (leading zeros dropped); none for a
/// constant, and none where a coefficient is not finite.
pub(crate) fn roots(coefficients: &[f64]) -> Vec<Complex<f64>> {
    let c: Vec<f64> = coefficients
        .iter()
        .copied()
        .skip_while(|v| *v == 0.0)
        .collect();
    let n = c.len().saturating_sub(1);
    if n == 0 {
        return Vec::new();
    }
    // Companion matrix: its characteristic polynomial is the monic one.
    let mut m = DMatrix::<f64>::zeros(n, n);
    for j in 0..n {
        m[(0, j)] = -c[j + 1] / c[0];
    }
    for i in 1..n {
        m[(i, i - 1)] = 1.0;
    }
    super::decompose::eigenvalues(m).unwrap_or_default()
}

/// The real polynomial `leading · Π (s − r)` over `roots` (complex ones in conjugate pairs),
/// highest power first.
pub(crate) fn from_roots(leading: f64, roots: &[Complex<f64>]) -> Vec<f64> {
    let mut p = vec![Complex::new(leading, 0.0)];
    for &r in roots {
        let mut next = vec![Complex::new(0.0, 0.0); p.len() + 1];
        for (i, &a) in p.iter().enumerate() {
            next[i] += a;
            next[i + 1] -= a * r;
        }
        p = next;
    }
    p.iter().map(|v| v.re).collect()
}

/// The roots grouped where they repeat (within `relative` of each other's size): each
/// distinct root once, with how often it occurs. A double root found as a pair split by
/// rounding (a tiny imaginary part) is one real root twice.
pub(crate) fn distinct(roots: &[Complex<f64>], relative: f64) -> Vec<(Complex<f64>, usize)> {
    let mut out: Vec<(Complex<f64>, usize)> = Vec::new();
    for &r in roots {
        let tolerance = relative * r.norm();
        match out.iter_mut().find(|(q, _)| (*q - r).norm() <= tolerance) {
            // The root repeated is their mean (a pair split by rounding sits about it).
            Some((q, k)) => {
                *q = (*q * (*k as f64) + r) / (*k as f64 + 1.0);
                *k += 1;
            }
            None => out.push((r, 1)),
        }
    }
    for (q, _) in &mut out {
        if q.im.abs() <= relative * q.norm() {
            q.im = 0.0;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn roots_and_back() {
        // 2 (s + 1)(s + 3)(s² + 2 s + 5): roots −1, −3, −1 ± 2i.
        let p = from_roots(
            2.0,
            &[
                Complex::new(-1.0, 0.0),
                Complex::new(-3.0, 0.0),
                Complex::new(-1.0, 2.0),
                Complex::new(-1.0, -2.0),
            ],
        );
        let want = [2.0, 12.0, 32.0, 52.0, 30.0];
        for (a, b) in p.iter().zip(want) {
            assert!((a - b).abs() < 1e-12, "{p:?}");
        }
        let r = roots(&p);
        for want in [(-3.0, 0.0), (-1.0, 0.0), (-1.0, 2.0), (-1.0, -2.0)] {
            let want = Complex::new(want.0, want.1);
            assert!(
                r.iter().any(|q| (q - want).norm() < 1e-9),
                "{want} in {r:?}"
            );
        }
        assert!(roots(&[0.0, 5.0]).is_empty());
    }

    #[test]
    fn a_double_root_is_one_root_twice() {
        // (s + 62.5)²: found as two roots a rounding apart.
        let r = roots(&[1.0, 125.0, 3906.25]);
        let d = distinct(&r, 1e-4);
        assert_eq!(d.len(), 1, "{d:?}");
        assert_eq!(d[0].1, 2);
        assert!((d[0].0.re + 62.5).abs() < 1e-3 && d[0].0.im == 0.0);
        // A conjugate pair stays a pair.
        let d = distinct(&roots(&[1.0, 2.0, 5.0]), 1e-4);
        assert_eq!(d.len(), 2, "{d:?}");
    }
}
