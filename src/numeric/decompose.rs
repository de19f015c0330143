//! Eigenvalues and singular values with a bound on the work. nalgebra's plain calls iterate
//! until their sweeps converge, and a matrix holding a NaN or an infinity never converges:
//! the call would spin for ever. Every such decomposition the crate takes goes through here,
//! so a non-finite value met inside a fit (an overflowing candidate, a 0/0 in a derived
//! setting) is an answer of "none" the caller turns into an error, never a hang.

use nalgebra::{Complex, DMatrix, Dyn, SVD, Schur, SymmetricEigen};

/// Sweeps allowed per row of the matrix. A well-posed matrix needs a few per eigenvalue
/// (LAPACK allows 30); the bound is there only to end the search on one that cannot settle.
const SWEEPS_PER_ROW: usize = 100;

/// The eigenvalues of a square matrix; `None` when an entry is not finite or the sweeps do
/// not settle.
pub(crate) fn eigenvalues(m: DMatrix<f64>) -> Option<Vec<Complex<f64>>> {
    if !all_finite(&m) {
        return None;
    }
    let sweeps = SWEEPS_PER_ROW * m.nrows().max(1);
    let schur = Schur::try_new(m, f64::EPSILON, sweeps)?;
    Some(schur.complex_eigenvalues().iter().copied().collect())
}

/// The eigen-decomposition of a symmetric matrix; `None` as for [`eigenvalues`].
pub(crate) fn symmetric(m: DMatrix<f64>) -> Option<SymmetricEigen<f64, Dyn>> {
    if !all_finite(&m) {
        return None;
    }
    let sweeps = SWEEPS_PER_ROW * m.nrows().max(1);
    SymmetricEigen::try_new(m, f64::EPSILON, sweeps)
}

/// The singular value decomposition, with U and Vᵀ as asked; `None` as for [`eigenvalues`].
pub(crate) fn svd(m: DMatrix<f64>, with_u: bool, with_v_t: bool) -> Option<SVD<f64, Dyn, Dyn>> {
    if !all_finite(&m) {
        return None;
    }
    let sweeps = SWEEPS_PER_ROW * m.nrows().max(m.ncols()).max(1);
    SVD::try_new(m, with_u, with_v_t, f64::EPSILON, sweeps)
}

fn all_finite(m: &DMatrix<f64>) -> bool {
    m.iter().all(|v| v.is_finite())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_rotation_and_a_decay_have_their_known_eigenvalues() {
        // [[-1, -2], [2, -1]]: λ = −1 ± 2i.
        let m = DMatrix::from_row_slice(2, 2, &[-1.0, -2.0, 2.0, -1.0]);
        let mut l = eigenvalues(m).expect("a finite matrix has eigenvalues");
        l.sort_by(|a, b| a.im.total_cmp(&b.im));
        assert!((l[0] - Complex::new(-1.0, -2.0)).norm() < 1e-12);
        assert!((l[1] - Complex::new(-1.0, 2.0)).norm() < 1e-12);
    }

    #[test]
    fn a_matrix_holding_a_nan_or_an_infinity_has_none_and_returns() {
        // nalgebra's unbounded call spins for ever on these; here they return at once.
        for bad in [f64::NAN, f64::INFINITY] {
            let m = DMatrix::from_row_slice(3, 3, &[0.0, 1.0, 0.0, 0.0, 0.0, 1.0, -6.0, bad, -6.0]);
            assert!(eigenvalues(m.clone()).is_none());
            assert!(symmetric(m.clone()).is_none());
            assert!(svd(m, true, true).is_none());
        }
    }

    #[test]
    fn a_symmetric_matrix_has_its_known_eigenvalues() {
        // [[2, 1], [1, 2]]: 1 and 3.
        let m = DMatrix::from_row_slice(2, 2, &[2.0, 1.0, 1.0, 2.0]);
        let mut l: Vec<f64> = symmetric(m)
            .expect("finite")
            .eigenvalues
            .iter()
            .copied()
            .collect();
        l.sort_by(f64::total_cmp);
        assert!((l[0] - 1.0).abs() < 1e-12 && (l[1] - 3.0).abs() < 1e-12);
    }

    #[test]
    fn a_diagonal_matrix_has_its_entries_as_singular_values() {
        let m = DMatrix::from_row_slice(3, 2, &[3.0, 0.0, 0.0, -2.0, 0.0, 0.0]);
        let mut s: Vec<f64> = svd(m, false, true)
            .expect("finite")
            .singular_values
            .iter()
            .copied()
            .collect();
        s.sort_by(f64::total_cmp);
        assert!((s[0] - 2.0).abs() < 1e-12 && (s[1] - 3.0).abs() < 1e-12);
    }
}
