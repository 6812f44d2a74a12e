//! Lowest eigenpairs of K v = λ M v by block shift-invert Lanczos with full
//! reorthogonalisation.
//!
//! The operator Op = (K − σM)⁻¹M is self-adjoint in the M inner product; its largest
//! eigenvalues θ = 1/(λ − σ) belong to the λ nearest σ from above (Ericsson & Ruhe 1980,
//! "The spectral transformation Lanczos method"; Grimes, Lewis & Simon 1994 for the block
//! form). σ < 0 keeps K − σM positive definite despite the six rigid modes (λ = 0), so a
//! sparse Cholesky (faer, supernodal, AMD ordering) factors it once. Every new block is
//! M-orthogonalised against the whole basis twice (classical Gram–Schmidt, "twice is
//! enough") and within itself by Cholesky-QR done twice, so the basis V is M-orthonormal to
//! rounding and the Ritz vectors V·y are mass-normalised by construction.

use faer::linalg::matmul::matmul;
use faer::linalg::solvers::Solve;
use faer::sparse::{SparseColMat, SymbolicSparseColMat};
use faer::{Accum, Mat, MatMut, MatRef, Par, Side};

use super::assembly::{sym_matvec_rows, System};
use super::FemError;

/// Settings of [`solve`].
pub struct EigenOptions {
    /// How many of the lowest eigenpairs are wanted (rigid modes included).
    pub nev: usize,
    /// Stop once every eigenvalue ≤ this (rad²/s²) is converged, even if fewer than `nev`.
    pub lambda_max: Option<f64>,
    /// Shift σ in rad²/s² (negative).
    pub sigma: f64,
    /// Block size (vectors per operator application).
    pub block: usize,
    /// Convergence: residual ‖Op x − θx‖_M ≤ tol·(θ + 10⁻³·θ_max) (θ_max ≈ ‖Op‖ = 1/|σ|).
    /// The shift is moved once if the first elastic mode turns out far above |σ|.
    pub tol: f64,
    /// Largest basis size (memory: 8·DOFs·max_basis bytes).
    pub max_basis: usize,
}

/// Result of [`solve`].
pub struct EigenResult {
    /// Eigenvalues λ (rad²/s²), ascending.
    pub lambdas: Vec<f64>,
    /// Mass-normalised eigenvectors, one column per eigenvalue.
    pub vectors: Mat<f64>,
    /// Number of block operator applications (factor solves with `block` right-hand sides).
    pub iterations: usize,
    /// Final basis size.
    pub basis: usize,
    /// Seconds spent in the sparse Cholesky factorisation.
    pub factor_seconds: f64,
    /// The shift σ finally used (rad²/s²).
    pub sigma: f64,
}

fn par() -> Par {
    faer::get_global_parallelism()
}

/// M·W for a block W (n × b).
fn mul_m(sys: &System, w: MatRef<'_, f64>) -> Mat<f64> {
    let (n, b) = (w.nrows(), w.ncols());
    let mut xr = vec![0.0; n * b];
    for c in 0..b {
        for r in 0..n {
            xr[r * b + c] = w[(r, c)];
        }
    }
    let mut y = vec![0.0; n * b];
    sym_matvec_rows(sys, &sys.m, &xr, &mut y, b);
    Mat::from_fn(n, b, |r, c| y[r * b + c])
}

/// Deterministic pseudo-random block (xorshift64*), values in (−1, 1).
fn random_block(n: usize, b: usize, seed: u64) -> Mat<f64> {
    let mut s = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    Mat::from_fn(n, b, |_, _| {
        s ^= s >> 12;
        s ^= s << 25;
        s ^= s >> 27;
        let v = s.wrapping_mul(0x2545_F491_4F6C_DD1D);
        (v >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    })
}

/// W ← W − V(VᵀMW), twice; adds the coefficients into `h` (k × b) if given.
fn orthogonalise(sys: &System, v: MatRef<'_, f64>, w: &mut Mat<f64>, mut h: Option<MatMut<'_, f64>>) {
    if v.ncols() == 0 {
        return;
    }
    for _ in 0..2 {
        let z = mul_m(sys, w.as_ref());
        let mut c = Mat::<f64>::zeros(v.ncols(), w.ncols());
        matmul(c.as_mut(), Accum::Replace, v.transpose(), z.as_ref(), 1.0, par());
        matmul(w.as_mut(), Accum::Add, v, c.as_ref(), -1.0, par());
        if let Some(h) = h.as_mut() {
            for j in 0..c.ncols() {
                for i in 0..c.nrows() {
                    h[(i, j)] += c[(i, j)];
                }
            }
        }
    }
}

/// Cholesky-QR in the M inner product: W = Q R with QᵀMQ = I, R upper triangular (b × b).
/// `None` if W is (numerically) rank deficient.
fn chol_qr(sys: &System, w: &mut Mat<f64>) -> Option<Mat<f64>> {
    let b = w.ncols();
    let z = mul_m(sys, w.as_ref());
    let mut g = Mat::<f64>::zeros(b, b);
    matmul(g.as_mut(), Accum::Replace, w.transpose(), z.as_ref(), 1.0, par());
    // G = L Lᵀ, R = Lᵀ.
    let mut l = Mat::<f64>::zeros(b, b);
    for j in 0..b {
        let mut d = g[(j, j)];
        for p in 0..j {
            d -= l[(j, p)] * l[(j, p)];
        }
        if !(d > 1e-13 * g[(j, j)].abs()) || !(g[(j, j)] > 0.0) {
            return None;
        }
        let d = d.sqrt();
        l[(j, j)] = d;
        for i in j + 1..b {
            let mut s = g[(i, j)];
            for p in 0..j {
                s -= l[(i, p)] * l[(j, p)];
            }
            l[(i, j)] = s / d;
        }
    }
    // Q = W L⁻ᵀ, column by column: Q[:, c] = (W[:, c] − Σ_{p<c} Q[:, p] L[c][p]) / L[c][c].
    let n = w.nrows();
    for c in 0..b {
        for p in 0..c {
            let f = l[(c, p)];
            for r in 0..n {
                let q = w[(r, p)];
                w[(r, c)] -= f * q;
            }
        }
        let d = l[(c, c)];
        for r in 0..n {
            w[(r, c)] /= d;
        }
    }
    Some(Mat::from_fn(b, b, |i, j| l[(j, i)]))
}

/// M-orthonormalises W against `v` and within itself (CholQR twice). Returns R with
/// W_in − V C = W_out R, or `None` on rank deficiency.
fn orthonormalise(sys: &System, v: MatRef<'_, f64>, w: &mut Mat<f64>, h: Option<MatMut<'_, f64>>) -> Option<Mat<f64>> {
    orthogonalise(sys, v, w, h);
    let r1 = chol_qr(sys, w)?;
    let r2 = chol_qr(sys, w)?;
    let mut r = Mat::<f64>::zeros(r1.nrows(), r1.ncols());
    matmul(r.as_mut(), Accum::Replace, r2.as_ref(), r1.as_ref(), 1.0, Par::Seq);
    Some(r)
}

/// Computes the lowest eigenpairs of K v = λ M v.
///
/// # Errors
/// [`FemError::Factorization`] if K − σM is not positive definite (an invalid mesh or
/// material), [`FemError::NotConverged`] if the basis limit is reached first.
pub fn solve(sys: &System, opts: &EigenOptions, progress: &dyn Fn(&str, f32)) -> Result<EigenResult, FemError> {
    if sys.n <= DENSE_MAX {
        return dense(sys, opts);
    }
    match lanczos(sys, opts, opts.sigma, true, progress)? {
        Outcome::Done(r) => Ok(r),
        Outcome::Reshift(sigma) => match lanczos(sys, opts, sigma, false, progress)? {
            Outcome::Done(r) => Ok(r),
            Outcome::Reshift(_) => Err(FemError::Factorization("internal error: second shift requested".into())),
        },
    }
}

/// Up to this many DOFs the problem is solved densely (a Krylov basis would be most of the
/// space anyway).
pub const DENSE_MAX: usize = 1200;

/// Dense shift-invert solve: K − σM = LLᵀ, C = L⁻¹ML⁻ᵀ, C y = θ y with θ = 1/(λ − σ),
/// v = L⁻ᵀy/√θ (mass-normalised). Accurate for the lowest λ (the largest θ).
fn dense(sys: &System, opts: &EigenOptions) -> Result<EigenResult, FemError> {
    let n = sys.n;
    let sigma = opts.sigma;
    let t0 = std::time::Instant::now();
    let mut a = Mat::<f64>::zeros(n, n);
    let mut m = Mat::<f64>::zeros(n, n);
    for c in 0..n {
        for p in sys.col_ptr[c]..sys.col_ptr[c + 1] {
            a[(sys.row_idx[p], c)] = sys.k[p] - sigma * sys.m[p];
            m[(sys.row_idx[p], c)] = sys.m[p];
        }
    }
    let llt = a.llt(Side::Lower).map_err(|e| {
        FemError::Factorization(format!("K - sigma*M is not positive definite ({e:?}); the mesh is degenerate"))
    })?;
    let l = llt.L();
    // C = L⁻¹ M L⁻ᵀ: solve L X = M, then L C = Xᵀ (C symmetric).
    faer::linalg::triangular_solve::solve_lower_triangular_in_place(l, m.as_mut(), par());
    let mut c = m.transpose().to_owned();
    faer::linalg::triangular_solve::solve_lower_triangular_in_place(l, c.as_mut(), par());
    let cs = Mat::from_fn(n, n, |i, j| 0.5 * (c[(i, j)] + c[(j, i)]));
    let eig = cs
        .self_adjoint_eigen(Side::Lower)
        .map_err(|e| FemError::Factorization(format!("dense eigensolver failed: {e:?}")))?;
    let s = eig.S().column_vector();
    // θ ascending; wanted = largest θ first.
    let lam = |i: usize| sigma + 1.0 / s[n - 1 - i];
    let mut want = opts.nev.min(n);
    if let Some(lmax) = opts.lambda_max {
        want = want.min((0..n).take_while(|&i| s[n - 1 - i] > 0.0 && lam(i) <= lmax).count() + 1).min(n);
    }
    let u = eig.U();
    let mut y = Mat::from_fn(n, want, |r, j| u[(r, n - 1 - j)] / s[n - 1 - j].sqrt());
    faer::linalg::triangular_solve::solve_upper_triangular_in_place(l.transpose(), y.as_mut(), par());
    Ok(EigenResult {
        lambdas: (0..want).map(lam).collect(),
        vectors: y,
        iterations: 0,
        basis: n,
        factor_seconds: t0.elapsed().as_secs_f64(),
        sigma,
    })
}

enum Outcome {
    Done(EigenResult),
    /// The first elastic eigenvalue lies far above |σ| (slow convergence): start again with
    /// this shift.
    Reshift(f64),
}

/// Number of rigid-body modes expected below the first elastic one.
const RIGID: usize = 6;

fn lanczos(
    sys: &System,
    opts: &EigenOptions,
    sigma: f64,
    probe: bool,
    progress: &dyn Fn(&str, f32),
) -> Result<Outcome, FemError> {
    let n = sys.n;
    let t0 = std::time::Instant::now();
    let shifted: Vec<f64> = sys.k.iter().zip(&sys.m).map(|(k, m)| k - sigma * m).collect();
    let symbolic = SymbolicSparseColMat::<usize>::new_checked(n, n, sys.col_ptr.clone(), None, sys.row_idx.clone());
    let a = SparseColMat::<usize, f64>::new(symbolic, shifted);
    let llt = a.sp_cholesky(Side::Lower).map_err(|e| {
        FemError::Factorization(format!(
            "sparse Cholesky of K - sigma*M failed ({e:?}); the mesh may be degenerate or the material invalid"
        ))
    })?;
    drop(a);
    let factor_seconds = t0.elapsed().as_secs_f64();
    progress("factorised", 0.0);

    let b = opts.block.clamp(1, n.max(1));
    let cap = (opts.max_basis.min(n.saturating_sub(b)) / b * b).max(2 * b);
    if cap > n {
        return Err(FemError::Mesh(format!(
            "the mesh has only {n} degrees of freedom; too few for {} modes, use a finer resolution",
            opts.nev
        )));
    }
    let nev = opts.nev.min(cap - b);
    let mut v = Mat::<f64>::zeros(n, cap);
    let mut h = Mat::<f64>::zeros(cap + b, cap);

    let mut w = random_block(n, b, 1);
    let mut seed = 2;
    loop {
        if orthonormalise(sys, v.as_ref().subcols(0, 0), &mut w, None).is_some() {
            break;
        }
        w = random_block(n, b, seed);
        seed += 1;
    }
    v.as_mut().subcols_mut(0, b).copy_from(w.as_ref());
    let mut k = b;
    let mut iterations = 0;
    let mut last_check = 0;
    loop {
        // W = Op X_last.
        let mut w = mul_m(sys, v.as_ref().subcols(k - b, b));
        llt.solve_in_place(w.as_mut());
        iterations += 1;
        let r = {
            let hcol = h.as_mut().submatrix_mut(0, k - b, k, b);
            orthonormalise(sys, v.as_ref().subcols(0, k), &mut w, Some(hcol))
        };
        let r = match r {
            Some(r) => r,
            None => {
                // Invariant subspace found: continue with fresh random directions; the
                // coupling to them is zero.
                loop {
                    let mut fresh = random_block(n, b, seed);
                    seed += 1;
                    if orthonormalise(sys, v.as_ref().subcols(0, k), &mut fresh, None).is_some() {
                        w = fresh;
                        break;
                    }
                    if seed > 50 {
                        return Err(FemError::NotConverged { converged: 0, wanted: nev, basis: k });
                    }
                }
                Mat::zeros(b, b)
            }
        };
        h.as_mut().submatrix_mut(k, k - b, b, b).copy_from(r.as_ref());
        progress("eigen", (k as f32 / cap as f32).min(1.0));

        // Rayleigh–Ritz costs O(k³): check at ~10 % growth of the basis, not every block.
        if (k >= nev + b && k >= last_check + (k / 10).max(b)) || k + b > cap {
            last_check = k;
            // Rayleigh–Ritz on the symmetric part of the projected operator.
            let hs = Mat::from_fn(k, k, |i, j| 0.5 * (h[(i, j)] + h[(j, i)]));
            let eig = hs.self_adjoint_eigen(Side::Lower).map_err(|e| {
                FemError::Factorization(format!("dense eigensolver failed on the projected matrix: {e:?}"))
            })?;
            let s = eig.S().column_vector();
            let u = eig.U();
            // θ ascending from faer; the wanted λ are the largest θ.
            let order: Vec<usize> = (0..k).rev().collect();
            let lam = |i: usize| sigma + 1.0 / s[order[i]];
            let mut want = nev;
            if let Some(lmax) = opts.lambda_max {
                let below = (0..k).take_while(|&i| s[order[i]] > 0.0 && lam(i) <= lmax).count();
                want = want.min(below + 1);
            }
            // Residuals are measured against the largest θ (‖Op‖): rounding puts a floor of
            // about ε·‖Op‖ under every residual, so a test relative to each θᵢ could never
            // pass for modes far above the shift.
            let theta_max = s[order[0]].abs();
            // Shift check (once, early): the convergence rate depends on the spacing of the
            // θᵢ; with the first elastic λ far above |σ| all the wanted θ crowd near zero.
            if probe && k >= 3 * b && want > RIGID {
                let l_el = lam(RIGID);
                if l_el.is_finite() && l_el > 30.0 * sigma.abs() {
                    return Ok(Outcome::Reshift(-0.3 * l_el));
                }
            }
            let mut converged = 0;
            for i in 0..want {
                let col = order[i];
                let theta = s[col];
                let mut res2 = 0.0;
                for rr in 0..b {
                    let mut acc = 0.0;
                    for cc in 0..b {
                        acc += r[(rr, cc)] * u[(k - b + cc, col)];
                    }
                    res2 += acc * acc;
                }
                if theta > 0.0 && res2.sqrt() <= opts.tol * theta + 1e-3 * opts.tol * theta_max {
                    converged += 1;
                } else {
                    break;
                }
            }
            if converged >= want {
                let sel: Vec<usize> = order[..want].to_vec();
                let y = Mat::from_fn(k, want, |i, j| u[(i, sel[j])]);
                let mut phi = Mat::<f64>::zeros(n, want);
                matmul(phi.as_mut(), Accum::Replace, v.as_ref().subcols(0, k), y.as_ref(), 1.0, par());
                let lambdas = (0..want).map(lam).collect();
                return Ok(Outcome::Done(EigenResult {
                    lambdas,
                    vectors: phi,
                    iterations,
                    basis: k,
                    factor_seconds,
                    sigma,
                }));
            }
            if k + b > cap {
                return Err(FemError::NotConverged { converged, wanted: want, basis: k });
            }
        }
        v.as_mut().subcols_mut(k, b).copy_from(w.as_ref());
        k += b;
    }
}
