//! The least squares of two columns: r ≈ α·u + β·v, solved from the normal equations'
//! five sums. A ripple's or a cyclic error's sine and cosine parts are fitted this way, in
//! the diagnosis and in the identification alike. Where the two columns act alike the pair
//! (α, β) is not fixed by the data — any point on a ridge fits — and the answer is none,
//! never a NaN or a pair of huge opposite values.

/// A correlation within a hair of ±1 (|cos| ≥ 1 − 5·10⁻¹³): the determinant Σu²·Σv² − (Σuv)²
/// at most 10⁻¹² of Σu²·Σv². A caller that needs no stricter bound passes this one.
pub(crate) const PARALLEL: f64 = 1.0 - 5e-13;

/// The sums Σu², Σuv, Σv², Σur, Σvr and Σr² over the samples added, and their count.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct TwoColumns {
    uu: f64,
    uv: f64,
    vv: f64,
    ur: f64,
    vr: f64,
    rr: f64,
    n: usize,
}

impl TwoColumns {
    /// The sums over the samples `i` of `u`, `v` and `r` that `keep(i)` allows.
    pub(crate) fn over(u: &[f64], v: &[f64], r: &[f64], keep: impl Fn(usize) -> bool) -> Self {
        let mut sums = TwoColumns::default();
        for (i, ((&x, &y), &z)) in u.iter().zip(v).zip(r).enumerate() {
            if keep(i) {
                sums.add(x, y, z);
            }
        }
        sums
    }

    /// One sample more: the columns' values `u` and `v` and the target `r` there.
    pub(crate) fn add(&mut self, u: f64, v: f64, r: f64) {
        self.uu += u * u;
        self.uv += u * v;
        self.vv += v * v;
        self.ur += u * r;
        self.vr += v * r;
        self.rr += r * r;
        self.n += 1;
    }

    /// The cosine of the angle between the two columns, Σuv / √(Σu²·Σv²): ±1 where one is a
    /// multiple of the other, NaN where either is zero or not finite.
    pub(crate) fn correlation(&self) -> f64 {
        self.uv / (self.uu * self.vv).sqrt()
    }

    /// The (α, β) that make Σ (r − α·u − β·v)² least; none where the columns' correlation
    /// exceeds `max_correlation` in size (they act too much alike for the data to set α and
    /// β apart), where either column is zero, or where a sum is not finite.
    pub(crate) fn solve(&self, max_correlation: f64) -> Option<(f64, f64)> {
        let det = self.determinant();
        let correlation = self.correlation();
        if !det.is_finite()
            || det <= 0.0
            || correlation.is_nan()
            || correlation.abs() > max_correlation
        {
            return None;
        }
        Some((
            (self.ur * self.vv - self.vr * self.uv) / det,
            (self.vr * self.uu - self.ur * self.uv) / det,
        ))
    }

    /// Σ (r − α·u − β·v)²: what the pair (α, β) leaves, from the sums alone (never below 0,
    /// which rounding could otherwise give at an exact fit).
    pub(crate) fn left(&self, alpha: f64, beta: f64) -> f64 {
        (self.rr - 2.0 * (alpha * self.ur + beta * self.vr)
            + alpha * alpha * self.uu
            + 2.0 * alpha * beta * self.uv
            + beta * beta * self.vv)
            .max(0.0)
    }

    /// The least-squares standard deviation of (α, β) along the direction the data fixes
    /// worst: √(s²·λ_max), s² = what (α, β) leave over n − 2 (at least 1) degrees of freedom
    /// and λ_max the largest eigenvalue of the normal matrix's inverse. It holds for
    /// independent errors; correlated ones make it a floor.
    pub(crate) fn worst_sigma(&self, alpha: f64, beta: f64) -> f64 {
        let variance = self.left(alpha, beta) / (self.n.saturating_sub(2).max(1) as f64);
        // The inverse's largest eigenvalue is the normal matrix's largest over its determinant.
        let largest = 0.5 * ((self.uu + self.vv) + (self.uu - self.vv).hypot(2.0 * self.uv))
            / self.determinant();
        (variance * largest).sqrt()
    }

    fn determinant(&self) -> f64 {
        self.uu * self.vv - self.uv * self.uv
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// u = (1, 0, 1), v = (0, 1, 1), r = (1, 2, 4), worked by hand: Σu² = Σv² = 2, Σuv = 1,
    /// Σur = 5, Σvr = 6, Σr² = 21. The normal equations 2α + β = 5, α + 2β = 6 give α = 4/3,
    /// β = 7/3; the residual is (−1/3, −1/3, 1/3), its sum of squares 1/3.
    fn worked() -> ([f64; 3], [f64; 3], [f64; 3]) {
        ([1.0, 0.0, 1.0], [0.0, 1.0, 1.0], [1.0, 2.0, 4.0])
    }

    #[test]
    fn three_samples_give_the_pair_worked_by_hand() {
        let (u, v, r) = worked();
        let sums = TwoColumns::over(&u, &v, &r, |_| true);
        let (alpha, beta) = sums.solve(0.99).expect("the columns differ");
        assert!((alpha - 4.0 / 3.0).abs() < 1e-15, "{alpha}");
        assert!((beta - 7.0 / 3.0).abs() < 1e-15, "{beta}");
        assert!((sums.left(alpha, beta) - 1.0 / 3.0).abs() < 1e-14);
        // Nothing fitted leaves all of Σr².
        assert!((sums.left(0.0, 0.0) - 21.0).abs() < 1e-14);
        // The columns' angle: cos = 1 / √(2·2) = 1/2.
        assert!((sums.correlation() - 0.5).abs() < 1e-15);
    }

    #[test]
    fn the_worst_direction_s_sigma_is_worked_by_hand() {
        // Normal matrix [[2, 1], [1, 2]]: eigenvalues 1 and 3, so its inverse's largest is 1.
        // One degree of freedom (3 − 2) leaves s² = 1/3: σ = √(1/3).
        let (u, v, r) = worked();
        let sums = TwoColumns::over(&u, &v, &r, |_| true);
        let sigma = sums.worst_sigma(4.0 / 3.0, 7.0 / 3.0);
        assert!((sigma - (1.0f64 / 3.0).sqrt()).abs() < 1e-14, "{sigma}");
    }

    #[test]
    fn a_sine_and_a_cosine_over_whole_periods_are_found_apart() {
        // Over whole periods sin and cos are orthogonal with Σ = n/2 each: r = 3 sin − 2 cos
        // gives α = 3, β = −2 exactly, whatever the phase grid.
        let n = 64;
        let k = std::f64::consts::TAU / 16.0;
        let u: Vec<f64> = (0..n).map(|i| (k * i as f64).sin()).collect();
        let v: Vec<f64> = (0..n).map(|i| (k * i as f64).cos()).collect();
        let r: Vec<f64> = (0..n).map(|i| 3.0 * u[i] - 2.0 * v[i]).collect();
        let sums = TwoColumns::over(&u, &v, &r, |_| true);
        assert!(sums.correlation().abs() < 1e-12);
        let (alpha, beta) = sums.solve(0.99).unwrap();
        assert!((alpha - 3.0).abs() < 1e-12 && (beta + 2.0).abs() < 1e-12);
        assert!(sums.left(alpha, beta) < 1e-20);
    }

    #[test]
    fn samples_left_out_do_not_count() {
        // The worked three samples and a fourth, wild one that `keep` leaves out.
        let (u, v, r) = worked();
        let (u, v, r) = (
            [u[0], u[1], u[2], 1.0],
            [v[0], v[1], v[2], -1.0],
            [r[0], r[1], r[2], 1e6],
        );
        let sums = TwoColumns::over(&u, &v, &r, |i| i < 3);
        let (alpha, beta) = sums.solve(0.99).unwrap();
        assert!((alpha - 4.0 / 3.0).abs() < 1e-15 && (beta - 7.0 / 3.0).abs() < 1e-15);
    }

    #[test]
    fn columns_that_act_alike_give_none_not_nan() {
        let (u, v, r) = worked();
        // One column twice: correlation 1, determinant 0.
        assert_eq!(TwoColumns::over(&u, &u, &r, |_| true).solve(0.99), None);
        // A multiple, of the opposite sign: correlation −1.
        let minus: Vec<f64> = u.iter().map(|x| -2.0 * x).collect();
        assert_eq!(TwoColumns::over(&u, &minus, &r, |_| true).solve(0.99), None);
        // A zero column: the correlation is 0/0.
        assert_eq!(
            TwoColumns::over(&u, &[0.0; 3], &r, |_| true).solve(0.99),
            None
        );
        // No samples at all.
        assert_eq!(TwoColumns::over(&u, &v, &r, |_| false).solve(0.99), None);
        // A non-finite value.
        let bad = [1.0, f64::NAN, 0.0];
        assert_eq!(TwoColumns::over(&u, &bad, &r, |_| true).solve(0.99), None);
    }

    #[test]
    fn the_correlation_bound_is_the_caller_s() {
        // Worked columns at cos = 1/2: allowed under 0.6, refused under 0.4.
        let (u, v, r) = worked();
        let sums = TwoColumns::over(&u, &v, &r, |_| true);
        assert!(sums.solve(0.6).is_some());
        assert_eq!(sums.solve(0.4), None);
    }
}
