//! The estimator's small dense linear algebra (row-major `n × n` slices, n ≲ 20): the
//! LM and Newton steps, the KKT systems of the constrained fits, the covariance of a fit.
//! Hand-written because the systems are tiny and solved in inner loops; each routine is
//! tested against closed-form results below.

/// Solves a small dense system A x = b (row-major `a`, n × n; the solution replaces `b`) by
/// Gaussian elimination with partial pivoting (an LU; callers pass symmetric positive
/// definite normal matrices, but any non-singular A works). False if A is singular.
pub fn solve_small(a: &mut [f64], b: &mut [f64], n: usize) -> bool {
    for col in 0..n {
        let mut piv = col;
        for r in col + 1..n {
            if a[r * n + col].abs() > a[piv * n + col].abs() {
                piv = r;
            }
        }
        if a[piv * n + col].abs() < 1e-300 {
            return false;
        }
        if piv != col {
            for c in 0..n {
                a.swap(col * n + c, piv * n + c);
            }
            b.swap(col, piv);
        }
        for r in col + 1..n {
            let f = a[r * n + col] / a[col * n + col];
            for c in col..n {
                a[r * n + c] -= f * a[col * n + c];
            }
            b[r] -= f * b[col];
        }
    }
    for col in (0..n).rev() {
        let mut s = b[col];
        for c in col + 1..n {
            s -= a[col * n + c] * b[c];
        }
        b[col] = s / a[col * n + col];
    }
    b.iter().all(|v| v.is_finite())
}

/// Cholesky factorisation in place (lower triangle); false if not positive definite.
pub fn cholesky(a: &mut [f64], n: usize) -> bool {
    for j in 0..n {
        let mut d = a[j * n + j];
        for k in 0..j {
            d -= a[j * n + k] * a[j * n + k];
        }
        if d.is_nan() || d <= 0.0 || !d.is_finite() {
            return false;
        }
        let d = d.sqrt();
        a[j * n + j] = d;
        for i in j + 1..n {
            let mut s = a[i * n + j];
            for k in 0..j {
                s -= a[i * n + k] * a[j * n + k];
            }
            a[i * n + j] = s / d;
        }
    }
    true
}

/// Inverse of a small matrix (row-major `h`, n × n), column by column with [`solve_small`];
/// `None` if singular.
pub fn invert(h: &[f64], n: usize) -> Option<Vec<f64>> {
    let mut inv = vec![0.0; n * n];
    for c in 0..n {
        let mut a = h.to_vec();
        let mut b = vec![0.0; n];
        b[c] = 1.0;
        if !solve_small(&mut a, &mut b, n) {
            return None;
        }
        for r in 0..n {
            inv[r * n + c] = b[r];
        }
    }
    Some(inv)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `solve_small` against a known solution: the 4 × 4 Hilbert matrix (condition ≈ 1.6e4,
    /// symmetric positive definite) and a non-symmetric system needing a row swap; a singular
    /// matrix is refused.
    #[test]
    fn solve_small_finds_known_solutions_and_refuses_singular_systems() {
        let n = 4;
        let x_true = [1.0, -2.0, 3.0, 0.5];
        let hilbert: Vec<f64> = (0..n * n).map(|k| 1.0 / ((k / n + k % n + 1) as f64)).collect();
        let swap = vec![0.0, 2.0, 1.0, 3.0, 1.0, 1.0, 0.0, 2.0, 4.0, 0.0, 1.0, 1.0, 2.0, 3.0, 5.0, 0.0];
        for (a0, tol) in [(hilbert, 1e-9), (swap, 1e-12)] {
            let mut b: Vec<f64> = (0..n).map(|r| (0..n).map(|c| a0[r * n + c] * x_true[c]).sum()).collect();
            let mut a = a0.clone();
            assert!(solve_small(&mut a, &mut b, n));
            for (got, want) in b.iter().zip(x_true) {
                assert!((got - want).abs() < tol, "{b:?}");
            }
        }
        let mut singular = vec![1.0, 2.0, 2.0, 4.0];
        let mut b = vec![1.0, 2.0];
        assert!(!solve_small(&mut singular, &mut b, 2));
    }

    /// `cholesky` returns the known factor of A = L Lᵀ built from a chosen L, and refuses an
    /// indefinite and a singular matrix.
    #[test]
    fn cholesky_recovers_a_known_factor_and_refuses_indefinite_matrices() {
        let n = 3;
        let l = [[2.0, 0.0, 0.0], [-1.0, 3.0, 0.0], [0.5, 1.5, 1.0]];
        let mut a: Vec<f64> = (0..n * n).map(|k| (0..n).map(|m| l[k / n][m] * l[k % n][m]).sum()).collect();
        assert!(cholesky(&mut a, n));
        for r in 0..n {
            for c in 0..=r {
                assert!((a[r * n + c] - l[r][c]).abs() < 1e-14, "{a:?}");
            }
        }
        let mut indefinite = vec![1.0, 2.0, 2.0, 1.0];
        assert!(!cholesky(&mut indefinite, 2));
        let mut singular = vec![1.0, 1.0, 1.0, 1.0];
        assert!(!cholesky(&mut singular, 2));
    }

    /// `invert` of the 3 × 3 Hilbert matrix equals its known integer inverse
    /// [[9, −36, 30], [−36, 192, −180], [30, −180, 180]]; a singular matrix gives `None`.
    #[test]
    fn invert_matches_the_hilbert_matrix_known_inverse() {
        let n = 3;
        let h: Vec<f64> = (0..n * n).map(|k| 1.0 / ((k / n + k % n + 1) as f64)).collect();
        let want = [9.0, -36.0, 30.0, -36.0, 192.0, -180.0, 30.0, -180.0, 180.0];
        let inv = invert(&h, n).expect("the Hilbert matrix is invertible");
        for (got, want) in inv.iter().zip(want) {
            assert!((got - want).abs() < 1e-10 * want.abs().max(1.0), "{inv:?}");
        }
        assert!(invert(&[1.0, 2.0, 2.0, 4.0], 2).is_none());
    }
}
