//! Lowest eigenpairs of K v = λ M v by spectrum slicing with block shift-invert Lanczos.
//!
//! For each shift σ the operator Op = (K − σM)⁻¹M is self-adjoint in the M inner product;
//! its extreme eigenvalues θ = 1/(λ − σ) belong to the λ nearest σ on either side (Ericsson
//! & Ruhe 1980, "The spectral transformation Lanczos method"). K − σM is factored as LDLᵀ
//! (faer, supernodal; METIS nested dissection or AMD ordering, [`crate::ordering`], computed
//! once for all shifts); by Sylvester's law of
//! inertia the number of negative pivots is the number of eigenvalues below σ (the Sturm
//! count), which tells each run exactly how many eigenvalues it still has to find below its
//! shift and proves that none was missed (Grimes, Lewis & Simon 1994, "A shifted block
//! Lanczos algorithm for solving sparse symmetric generalized eigenproblems", §3–4).
//!
//! Each run is a block Lanczos with full reorthogonalisation: every new block is
//! M-orthogonalised against the eigenvectors already locked (deflation) and the run's
//! basis, twice (classical Gram–Schmidt, "twice is enough"), then within itself by
//! Cholesky-QR done twice; the M-images of the basis are kept so each step costs two sparse
//! M products. Converged Ritz pairs are locked and the next shift is placed beyond them
//! from the observed eigenvalue density, so no basis grows beyond a few times the number of
//! eigenvalues one slice yields. The memory of a run is bounded by its basis (two n × cap
//! blocks) instead of growing with the number of wanted modes. (A Krylov–Schur thick
//! restart, Stewart 2001, "A Krylov–Schur algorithm for large eigenproblems", would bound
//! the basis of a single shift as well but keeps the crowded θ spectrum of a far shift;
//! slicing keeps every wanted θ well separated.)

use std::cell::RefCell;
use std::time::Instant;

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::ldlt::factor::LdltRegularization;
use faer::linalg::matmul::matmul;
use faer::perm::PermRef;
use faer::sparse::linalg::cholesky::supernodal::SupernodalLdltRef;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, LdltRef, SymbolicCholesky, SymbolicCholeskyRaw,
    SymmetricOrdering,
};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Accum, Conj, Mat, MatMut, MatRef, Par, Side, Spec};

use super::assembly::{sym_csc_matvec_rows, sym_matvec_rows, System};
use super::FemError;

/// Settings of [`solve`].
pub struct EigenOptions {
    /// How many of the lowest eigenpairs are wanted (rigid modes included).
    pub nev: usize,
    /// Stop once every eigenvalue ≤ this (rad²/s²) is found, even if fewer than `nev`.
    pub lambda_max: Option<f64>,
    /// First shift σ in rad²/s² (negative: below the rigid modes).
    pub sigma: f64,
    /// Block size (vectors per operator application).
    pub block: usize,
    /// Convergence: M-norm residual ‖Op x − θx‖ ≤ tol·|θ| (plus a rounding floor).
    pub tol: f64,
    /// Largest basis of one run (memory: 16·DOFs·max_basis bytes for the basis and its
    /// M-image).
    pub max_basis: usize,
    /// Eigenvalues each shift after the first aims to converge (about half below it, half
    /// above). Fewer means more factorisations and smaller bases.
    pub slice: usize,
    /// Largest sparse factor accepted, bytes ([`MAX_FACTOR_BYTES`] for bank builds): a
    /// larger mesh is refused after the symbolic analysis, before any large allocation.
    pub max_factor_bytes: usize,
}

/// Result of [`solve`].
pub struct EigenResult {
    /// Eigenvalues λ (rad²/s²), ascending.
    pub lambdas: Vec<f64>,
    /// Mass-normalised eigenvectors, one column per eigenvalue.
    pub vectors: Mat<f64>,
    /// Number of block operator applications (factor solves with `block` right-hand sides).
    pub iterations: usize,
    /// Largest basis of one run.
    pub basis: usize,
    /// Seconds spent in sparse factorisations (symbolic and all numeric).
    pub factor_seconds: f64,
    /// The first shift σ (rad²/s²): eigenvalues far below |σ| are rigid-body modes.
    pub sigma: f64,
    /// Where the time went.
    pub profile: Profile,
}

/// Phase timings (wall seconds) and counters of one [`solve`].
#[derive(Clone, Debug, Default)]
pub struct Profile {
    /// Symbolic analysis (ordering, supernode structure), once.
    pub symbolic_seconds: f64,
    /// The fill-reducing ordering used: "nested dissection (METIS)", "AMD", or "dense" (a
    /// small system solved by the dense eigensolver).
    pub ordering: &'static str,
    /// Numeric LDLᵀ factorisations, all shifts.
    pub numeric_seconds: f64,
    /// Triangular solves (operator applications).
    pub solve_seconds: f64,
    /// Sparse M products.
    pub mass_seconds: f64,
    /// Gram–Schmidt against locked vectors and the basis, Cholesky-QR.
    pub orth_seconds: f64,
    /// Projected eigenproblems (Rayleigh–Ritz).
    pub ritz_seconds: f64,
    /// Ritz vectors of converged pairs (locking) and the final assembly.
    pub lock_seconds: f64,
    /// Final residual check ‖Kφ − λMφ‖.
    pub check_seconds: f64,
    /// Total.
    pub total_seconds: f64,
    /// Shifts used (rad²/s²), in order.
    pub shifts: Vec<f64>,
    /// Lanczos runs (several runs may share a shift).
    pub runs: usize,
    /// Block steps (operator applications).
    pub steps: usize,
    /// Orthogonalisations whose second Gram–Schmidt pass was not needed ([`KAHAN_KAPPA`]).
    pub orth_skipped: usize,
    /// Largest basis of one run.
    pub max_basis: usize,
    /// Largest relative residual ‖Kφ − λMφ‖₂ / ((|λ| + |σ₀|)‖Mφ‖₂) of the returned pairs.
    pub max_residual: f64,
    /// Largest |φᵀKφ − λ| / (|λ| + |σ₀|) of the returned (mass-normalised) pairs.
    pub max_rayleigh_error: f64,
    /// Nonzeros of the LDLᵀ factor.
    pub factor_nnz: usize,
}

thread_local! {
    static LAST_PROFILE: RefCell<Profile> = RefCell::new(Profile::default());
}

/// The profile of the last sparse [`solve`] on this thread (empty after a dense solve).
pub fn last_profile() -> Profile {
    LAST_PROFILE.with(|p| p.borrow().clone())
}

/// Largest sparse LDLᵀ factor a bank build accepts, bytes. With the Lanczos basis, the
/// matrices and the mode shapes a build then stays within 4 GiB (measured: a 118k-DOF bowl
/// has a 492 MiB factor and peaks at 2.0 GiB; a 660k-DOF block needed 17 GiB).
pub const MAX_FACTOR_BYTES: usize = 3 << 29; // 1.5 GiB

/// `STRUCK_EIGEN_DEBUG` set: one line per Lanczos run on stderr, and one with the phase
/// times of a solve that passed its residual check.
fn debug() -> bool {
    std::env::var_os("STRUCK_EIGEN_DEBUG").is_some()
}

/// The fill-reducing order of a node graph (`perm[new] = old`): METIS nested dissection
/// ([`crate::ordering`]) from [`crate::ordering::MIN_NODES`] nodes on; `None` (faer's AMD)
/// below, if METIS fails, or with `STRUCK_FEM_ORDERING=amd` in the environment (a
/// diagnostic, to compare the two).
fn node_order(adjacency: &[Vec<u32>]) -> Option<Vec<usize>> {
    if adjacency.len() < crate::ordering::MIN_NODES || std::env::var("STRUCK_FEM_ORDERING").is_ok_and(|v| v == "amd") {
        return None;
    }
    crate::ordering::nested_dissection(adjacency)
}

/// faer's ordering for a permutation with its inverse ([`crate::ordering::with_inverse`]);
/// AMD without one.
fn symmetric_ordering(perm: &Option<(Vec<usize>, Vec<usize>)>) -> SymmetricOrdering<'_, usize> {
    match perm {
        Some((fwd, inv)) => SymmetricOrdering::Custom(PermRef::new_checked(fwd, inv, fwd.len())),
        None => SymmetricOrdering::Amd,
    }
}

/// Parallelism for the numeric factorisation and the dense solver of [`dense`] (large,
/// compute-bound kernels).
fn par() -> Par {
    faer::get_global_parallelism()
}

/// Parallelism for the small per-step kernels (CholQR, the projected problem's products,
/// faer's triangular solves for odd block sizes): too small per call for a thread pool to
/// pay off; measured on the shared 2-core machine, rayon made them 2–4× slower.
const STEP_PAR: Par = Par::Seq;

/// Parallelism for a Gram–Schmidt product against `x` (the locked vectors or the basis):
/// the whole thread pool from [`ORTH_PAR_ENTRIES`] entries on. These products read the
/// whole basis twice per pass and are bound by memory bandwidth, which a second thread
/// raises (stop 39, quiet machine, the 180k-DOF bowl, two cores: orthogonalisation 26 →
/// 17.6 s with the rest of the solver unchanged).
fn orth_par(x: MatRef<'_, f64>) -> Par {
    if x.nrows() * x.ncols() >= ORTH_PAR_ENTRIES {
        par()
    } else {
        Par::Seq
    }
}

/// See [`orth_par`]: 32 MiB of basis.
const ORTH_PAR_ENTRIES: usize = 1 << 22;

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

/// Computes the lowest eigenpairs of K v = λ M v (dense below [`DENSE_MAX`] DOFs, else
/// [`solve_sliced`]).
///
/// # Errors
/// [`FemError::Factorization`] if K − σM cannot be factored (an invalid mesh or material),
/// [`FemError::NotConverged`] if the wanted modes are not found within the run limit.
pub fn solve(sys: &System, opts: &EigenOptions, progress: &dyn Fn(&str, f32)) -> Result<EigenResult, FemError> {
    if sys.n <= DENSE_MAX {
        return dense(sys, opts);
    }
    solve_sliced(sys, opts, progress)
}

/// Up to this many DOFs the problem is solved densely (a Krylov basis would be most of the
/// space anyway).
pub const DENSE_MAX: usize = 1200;

/// Dense shift-invert solve: K − σM = LLᵀ, C = L⁻¹ML⁻ᵀ, C y = θ y with θ = 1/(λ − σ),
/// v = L⁻ᵀy/√θ (mass-normalised). Accurate for the lowest λ (the largest θ).
///
/// # Errors
/// [`FemError::Factorization`] if K − σM is not positive definite.
pub fn dense(sys: &System, opts: &EigenOptions) -> Result<EigenResult, FemError> {
    let n = sys.n;
    let sigma = opts.sigma;
    let t0 = Instant::now();
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
        profile: Profile { ordering: "dense", ..Profile::default() },
    })
}

/// Sparse M products on column-major blocks through a reused row-major buffer (the kernel
/// gathers the values of a row from one cache line).
///
/// The consistent mass matrix of an isotropic solid couples only equal directions at two
/// nodes, with the same value for x, y and z: M = Mₛ ⊗ I₃, Mₛ the scalar mass matrix of the
/// nodes (ρ∫NᵢNⱼ). When the assembled M has that structure (checked entry by entry) the
/// product runs on Mₛ with the three directions of a node as 3·b right-hand sides: a ninth of
/// the matrix entries to read.
struct Mass<'a> {
    sys: &'a System,
    /// Mₛ in compressed columns (full pattern, rows sorted): `None` if M is not Mₛ ⊗ I₃.
    nodal: Option<Nodal>,
    xr: Vec<f64>,
    yr: Vec<f64>,
}

/// The scalar node mass matrix Mₛ (compressed columns, both triangles).
struct Nodal {
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    val: Vec<f64>,
}

impl Nodal {
    /// Mₛ from the DOF-level M if M = Mₛ ⊗ I₃ exactly (cross-direction entries zero, the
    /// three directions' entries equal), else `None`.
    fn from_system(sys: &System) -> Option<Nodal> {
        if sys.n % 3 != 0 {
            return None;
        }
        let nn = sys.n / 3;
        let mut col_ptr = Vec::with_capacity(nn + 1);
        let mut row_idx = Vec::new();
        let mut val = Vec::new();
        col_ptr.push(0);
        for a in 0..nn {
            for d in 0..3 {
                let c = 3 * a + d;
                let mut kept = 0;
                for p in sys.col_ptr[c]..sys.col_ptr[c + 1] {
                    let r = sys.row_idx[p];
                    let v = sys.m[p];
                    if r % 3 != d {
                        if v != 0.0 {
                            return None;
                        }
                        continue;
                    }
                    if d == 0 {
                        row_idx.push(r / 3);
                        val.push(v);
                    } else {
                        // The same entry as direction x's (same row node, same position).
                        let q = col_ptr[a] + kept;
                        if row_idx.get(q) != Some(&(r / 3)) || val[q] != v {
                            return None;
                        }
                    }
                    kept += 1;
                }
                if d > 0 && kept != row_idx.len() - col_ptr[a] {
                    return None;
                }
            }
            col_ptr.push(row_idx.len());
        }
        Some(Nodal { col_ptr, row_idx, val })
    }
}

impl<'a> Mass<'a> {
    fn new(sys: &'a System) -> Mass<'a> {
        Mass { sys, nodal: Nodal::from_system(sys), xr: Vec::new(), yr: Vec::new() }
    }

    /// out = M w.
    fn apply(&mut self, w: MatRef<'_, f64>, mut out: MatMut<'_, f64>, prof: &mut Profile) {
        let t = Instant::now();
        let (n, b) = (w.nrows(), w.ncols());
        self.xr.resize(n * b, 0.0);
        self.yr.resize(n * b, 0.0);
        // Row-major: DOF r's b values at r·b, so node a's three directions (DOFs 3a..3a+3)
        // are the 3·b values at 3a·b, as the nodal product wants them.
        to_rows(w, None, &mut self.xr);
        match &self.nodal {
            Some(nd) => sym_csc_matvec_rows(&nd.col_ptr, &nd.row_idx, &nd.val, &self.xr, &mut self.yr, 3 * b),
            None => sym_matvec_rows(self.sys, &self.sys.m, &self.xr, &mut self.yr, b),
        }
        from_rows(out.as_mut(), 0, None, &self.yr);
        prof.mass_seconds += t.elapsed().as_secs_f64();
    }
}

/// Rows per task of [`to_rows`] and [`from_rows`]: a block of fewer rows is copied by one
/// thread (the copies are bound by memory; a second core raises the bandwidth).
const COPY_SPLIT_ROWS: usize = 1 << 16;

/// `xr[i·b + c] = x[(src[i], c)]` (or `x[(i, c)]` without `src`): a column-major block
/// gathered into row-major order, `b` values per row.
fn to_rows(x: MatRef<'_, f64>, src: Option<&[usize]>, xr: &mut [f64]) {
    fn go(x: MatRef<'_, f64>, row0: usize, src: Option<&[usize]>, xr: &mut [f64]) {
        let b = x.ncols();
        let rows = xr.len() / b.max(1);
        if rows > COPY_SPLIT_ROWS {
            let (top, bottom) = xr.split_at_mut(rows / 2 * b);
            rayon::join(|| go(x, row0, src, top), || go(x, row0 + rows / 2, src, bottom));
            return;
        }
        for c in 0..b {
            let col = x.col(c);
            for i in 0..rows {
                let r = src.map_or(row0 + i, |s| s[row0 + i]);
                xr[i * b + c] = col[r];
            }
        }
    }
    go(x, 0, src, &mut xr[..x.nrows() * x.ncols()]);
}

/// `x[(i, c)] = xr[src[row0 + i]·b + c]` (or row `row0 + i` without `src`): the inverse of
/// [`to_rows`].
fn from_rows(x: MatMut<'_, f64>, row0: usize, src: Option<&[usize]>, xr: &[f64]) {
    let (n, b) = (x.nrows(), x.ncols());
    if n > COPY_SPLIT_ROWS {
        let (top, bottom) = x.split_at_row_mut(n / 2);
        rayon::join(|| from_rows(top, row0, src, xr), || from_rows(bottom, row0 + n / 2, src, xr));
        return;
    }
    let mut x = x;
    for c in 0..b {
        let mut col = x.as_mut().col_mut(c);
        for i in 0..n {
            let r = src.map_or(row0 + i, |s| s[row0 + i]);
            col[i] = xr[r * b + c];
        }
    }
}

/// Sparse LDLᵀ of K − σM on a symbolic structure shared by all shifts.
pub struct Factor<'a> {
    sys: &'a System,
    symbolic: SymbolicCholesky<usize>,
    values: Vec<f64>,
    shifted: Vec<f64>,
    sigma: f64,
    /// Number of negative pivots = eigenvalues below σ (Sylvester's law of inertia).
    negative: usize,
    /// Row-major right-hand sides of [`Factor::solve`], reused.
    rows: RefCell<Vec<f64>>,
    /// The elimination tree's cut for the row solves (fixed by the symbolic factor).
    tree: Option<crate::trisolve::TreeSplit>,
}

/// Bytes the sparse LDLᵀ factor of `mesh`'s stiffness matrix would take, estimated from the
/// node graph (three DOFs per node: 9 values per node-factor entry) with the same ordering
/// ([`node_order`]), without assembling: cheap enough to choose a resolution before building.
///
/// # Errors
/// [`FemError::Factorization`] if the symbolic analysis fails.
pub fn factor_bytes_estimate(mesh: &crate::TetMesh) -> Result<f64, FemError> {
    let nn = mesh.nodes.len();
    let mut adj: Vec<Vec<u32>> = vec![Vec::new(); nn];
    for t in &mesh.tets {
        for &a in t {
            adj[a as usize].extend_from_slice(t);
        }
    }
    let mut col_ptr = Vec::with_capacity(nn + 1);
    let mut row_idx = Vec::new();
    col_ptr.push(0usize);
    for a in adj.iter_mut() {
        a.sort_unstable();
        a.dedup();
        row_idx.extend(a.iter().map(|&b| b as usize));
        col_ptr.push(row_idx.len());
    }
    let pattern = SymbolicSparseColMatRef::new_checked(nn, nn, &col_ptr, None, &row_idx);
    let perm = node_order(&adj).map(crate::ordering::with_inverse);
    let symbolic = factorize_symbolic_cholesky(pattern, Side::Lower, symmetric_ordering(&perm), Default::default())
        .map_err(|e| FemError::Factorization(format!("symbolic analysis failed ({e:?}); out of memory?")))?;
    Ok(9.0 * symbolic.len_val() as f64 * 8.0)
}

impl<'a> Factor<'a> {
    fn new(sys: &'a System, max_bytes: usize, prof: &mut Profile) -> Result<Self, FemError> {
        let t = Instant::now();
        let n = sys.n;
        let pattern = SymbolicSparseColMatRef::new_checked(n, n, &sys.col_ptr, None, &sys.row_idx);
        // Supernodal always: the inertia is read off the diagonal blocks.
        let params = CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
            ..Default::default()
        };
        // The node graph of the DOF pattern (full, both triangles; a node's three DOFs share
        // one column pattern): the rows 3b of column 3a.
        let nodes: Vec<Vec<u32>> = (0..n / 3)
            .map(|a| {
                sys.row_idx[sys.col_ptr[3 * a]..sys.col_ptr[3 * a + 1]]
                    .iter()
                    .filter(|&&r| r % 3 == 0 && r / 3 != a)
                    .map(|&r| (r / 3) as u32)
                    .collect()
            })
            .collect();
        let perm = node_order(&nodes).map(|p| crate::ordering::dof_permutation(&p));
        drop(nodes);
        prof.ordering = if perm.is_some() { "nested dissection (METIS)" } else { "AMD" };
        let symbolic = factorize_symbolic_cholesky(pattern, Side::Lower, symmetric_ordering(&perm), params)
            .map_err(|e| FemError::Factorization(format!("symbolic analysis failed ({e:?}); out of memory?")))?;
        let len = symbolic.len_val();
        prof.symbolic_seconds += t.elapsed().as_secs_f64();
        prof.factor_nnz = len;
        let bytes = len as f64 * 8.0;
        if debug() {
            eprintln!("eigen: {n} DOFs, sparse factor {len} values ({:.0} MiB)", bytes / f64::from(1 << 20));
        }
        // Refuse before allocating: the fill of the factor grows much faster than the mesh.
        if bytes > max_bytes as f64 {
            return Err(FemError::Mesh(format!(
                "the mesh is too large: {n} DOFs, whose sparse factor would take {:.2} GiB (limit {:.2} GiB, to keep the build within 4 GiB); coarsen the mesh or lower --resolution",
                bytes / f64::from(1 << 30),
                max_bytes as f64 / f64::from(1 << 30)
            )));
        }
        let tree = match symbolic.raw() {
            SymbolicCholeskyRaw::Supernodal(sym) => Some(crate::trisolve::TreeSplit::of(sym)),
            SymbolicCholeskyRaw::Simplicial(_) => None,
        };
        Ok(Factor {
            sys,
            symbolic,
            tree,
            values: vec![0.0; len],
            shifted: vec![0.0; sys.k.len()],
            sigma: f64::NAN,
            negative: 0,
            rows: RefCell::new(Vec::new()),
        })
    }

    /// Factors K − σM; a shift that hits a zero pivot is moved by a relative 1e-7.
    fn factor(&mut self, sigma: f64, prof: &mut Profile) -> Result<(), FemError> {
        let t = Instant::now();
        let mut s = sigma;
        for attempt in 0..4 {
            for (o, (k, m)) in self.shifted.iter_mut().zip(self.sys.k.iter().zip(&self.sys.m)) {
                *o = k - s * m;
            }
            let n = self.sys.n;
            let pattern = SymbolicSparseColMatRef::new_checked(n, n, &self.sys.col_ptr, None, &self.sys.row_idx);
            let a = SparseColMatRef::new(pattern, &self.shifted);
            let mut buf = MemBuffer::new(self.symbolic.factorize_numeric_ldlt_scratch::<f64>(par(), Spec::default()));
            let r = self.symbolic.factorize_numeric_ldlt(
                &mut self.values,
                a,
                Side::Lower,
                LdltRegularization::default(),
                par(),
                MemStack::new(&mut buf),
                Spec::default(),
            );
            match r {
                Ok(_) => {
                    self.sigma = s;
                    self.negative = self.inertia();
                    prof.numeric_seconds += t.elapsed().as_secs_f64();
                    prof.shifts.push(s);
                    return Ok(());
                }
                Err(e) if attempt == 3 => {
                    return Err(FemError::Factorization(format!(
                        "LDL^T of K - sigma*M failed at sigma = {s:e} ({e:?}); the mesh may be degenerate or the material invalid"
                    )))
                }
                Err(_) => s += 1e-7 * s.abs().max(1.0) * (attempt + 1) as f64,
            }
        }
        unreachable_factor()
    }

    fn inertia(&self) -> usize {
        match self.symbolic.raw() {
            SymbolicCholeskyRaw::Supernodal(s) => {
                let l = SupernodalLdltRef::new(s, &self.values);
                (0..s.n_supernodes())
                    .map(|i| {
                        let v = l.supernode(i).val();
                        (0..v.ncols()).filter(|&j| v[(j, j)] < 0.0).count()
                    })
                    .sum()
            }
            SymbolicCholeskyRaw::Simplicial(s) => {
                let f = s.factor();
                (0..f.ncols())
                    .filter(|&j| {
                        let rows = &f.row_idx()[f.col_ptr()[j]..f.col_ptr()[j + 1]];
                        rows.iter().position(|&r| r == j).is_some_and(|p| self.values[f.col_ptr()[j] + p] < 0.0)
                    })
                    .count()
            }
        }
    }

    /// K − σM of `sys` factored as a bank build does (nested dissection in postorder,
    /// supernodal LDLᵀ), with no size limit: for benches and tests of the solves.
    ///
    /// # Errors
    /// As the build's factorisation.
    pub fn at(sys: &'a System, sigma: f64) -> Result<Factor<'a>, FemError> {
        let mut prof = Profile::default();
        let mut f = Factor::new(sys, usize::MAX, &mut prof)?;
        f.factor(sigma, &mut prof)?;
        Ok(f)
    }

    /// Eigenvalues below the shift (negative pivots).
    pub fn negative_pivots(&self) -> usize {
        self.negative
    }

    /// The row-major solver of [`crate::trisolve`] on this factor with its permutation
    /// (`fwd[new] = old`, `inv[old] = new`), if the factor is supernodal and ordered.
    pub fn row_solver(&self) -> Option<(crate::trisolve::RowSolver<'_>, &[usize], &[usize])> {
        match (self.symbolic.raw(), self.symbolic.perm(), self.tree) {
            (SymbolicCholeskyRaw::Supernodal(sym), Some(perm), Some(tree)) => {
                let (fwd, inv) = perm.arrays();
                Some((crate::trisolve::RowSolver::with_split(sym, &self.values, tree), fwd, inv))
            }
            _ => None,
        }
    }

    /// x ← (K − σM)⁻¹ x by faer's solve (by columns), the reference for [`Factor::apply_inverse`].
    pub fn apply_inverse_faer(&self, x: MatMut<'_, f64>) {
        let mut buf = MemBuffer::new(self.symbolic.solve_in_place_scratch::<f64>(x.ncols(), STEP_PAR));
        LdltRef::new(&self.symbolic, &self.values).solve_in_place_with_conj(
            Conj::No,
            x,
            STEP_PAR,
            MemStack::new(&mut buf),
        );
    }

    /// x ← (K − σM)⁻¹ x as the Lanczos steps do it: by rows ([`crate::trisolve`], the
    /// permutation applied while copying in and out) for the block sizes it takes, else by
    /// faer's solve.
    pub fn apply_inverse(&self, mut x: MatMut<'_, f64>) {
        let (n, b) = (x.nrows(), x.ncols());
        match self.row_solver() {
            Some((solver, fwd, inv)) if crate::trisolve::RowSolver::BLOCKS.contains(&b) => {
                let mut xr = self.rows.borrow_mut();
                xr.resize(n * b, 0.0);
                to_rows(x.as_ref(), Some(fwd), &mut xr);
                solver.solve_permuted(&mut xr, b);
                from_rows(x.as_mut(), 0, Some(inv), &xr);
            }
            _ => self.apply_inverse_faer(x),
        }
    }

    /// x ← (K − σM)⁻¹ x, timed.
    fn solve(&self, x: MatMut<'_, f64>, prof: &mut Profile) {
        let t = Instant::now();
        self.apply_inverse(x);
        prof.solve_seconds += t.elapsed().as_secs_f64();
    }
}

fn unreachable_factor() -> Result<(), FemError> {
    Err(FemError::Factorization("internal error: shift retry loop exited".into()))
}

/// Converged eigenpairs, M-orthonormal columns of `vecs` (first `len` in use).
struct Locked {
    lambdas: Vec<f64>,
    vecs: Mat<f64>,
}

impl Locked {
    fn len(&self) -> usize {
        self.lambdas.len()
    }
    fn view(&self) -> MatRef<'_, f64> {
        self.vecs.as_ref().subcols(0, self.len())
    }
    fn count_below(&self, x: f64) -> usize {
        self.lambdas.iter().filter(|&&l| l < x).count()
    }
    /// Adds a pair; when full, the largest eigenvalue gives way to a smaller one.
    fn push(&mut self, lambda: f64, v: MatRef<'_, f64>) {
        let slot = if self.len() < self.vecs.ncols() {
            self.lambdas.push(lambda);
            self.len() - 1
        } else {
            let (imax, lmax) =
                self.lambdas
                    .iter()
                    .copied()
                    .enumerate()
                    .fold((0, f64::MIN), |a, (i, l)| if l > a.1 { (i, l) } else { a });
            if lambda >= lmax {
                return;
            }
            self.lambdas[imax] = lambda;
            imax
        };
        self.vecs.as_mut().col_mut(slot).copy_from(v.col(0));
    }
}

/// W ← W − Φ(ΦᵀZ) − V(VᵀZ) with Z = MW kept current; returns the V coefficients.
/// The first pass uses a fresh Z; after it Z is recomputed, so the second pass ("twice is
/// enough"; run only where the first cancelled a column to under 1/[`KAHAN_KAPPA`] of its
/// M-norm) works from exact inner products; its small correction is carried into Z through
/// the stored M-image of V (the Φ part of that correction is at rounding level and dropped).
///
/// (Both passes include Φ. Leaving Φ out of the first pass, since W = Op X has only rounding
/// along Φ, was tried at stop 39 and dropped: a locked eigenvalue near the shift has the
/// largest θ, so what one pass leaves along it grows about tenfold per step, to 99 % of W
/// within ten steps on the 180k-DOF bowl.)
fn orthogonalise(
    mass: &mut Mass<'_>,
    locked: MatRef<'_, f64>,
    v: MatRef<'_, f64>,
    mv: MatRef<'_, f64>,
    w: &mut Mat<f64>,
    z: &mut Mat<f64>,
    prof: &mut Profile,
) -> Mat<f64> {
    let b = w.ncols();
    let mut total = Mat::<f64>::zeros(v.ncols(), b);
    let before = m_norms_sq(w.as_ref(), z.as_ref());
    for pass in 0..2 {
        if pass == 1 {
            // Kahan's "twice is enough" (Parlett, The Symmetric Eigenvalue Problem, §6-9):
            // one classical Gram–Schmidt pass that keeps ‖w′‖ ≥ ‖w‖/κ leaves w′ orthogonal
            // to about κ·ε; only a column the pass cancelled more than that needs a second.
            let after = m_norms_sq(w.as_ref(), z.as_ref());
            if before.iter().zip(&after).all(|(b, a)| *a * KAHAN_KAPPA * KAHAN_KAPPA >= *b) {
                prof.orth_skipped += 1;
                break;
            }
        }
        let t = Instant::now();
        if locked.ncols() > 0 {
            subtract_projection(locked, w, z.as_ref());
        }
        if v.ncols() > 0 {
            let c = subtract_projection(v, w, z.as_ref());
            if pass == 1 {
                matmul(z.as_mut(), Accum::Add, mv, c.as_ref(), -1.0, orth_par(mv));
            }
            total += &c;
        }
        prof.orth_seconds += t.elapsed().as_secs_f64();
        if pass == 0 {
            mass.apply(w.as_ref(), z.as_mut(), prof);
        }
    }
    total
}

/// κ of the second-pass test in [`orthogonalise`]: a column kept at least a tenth of its
/// M-norm is orthogonal to about 10ε after one pass. In the shift-invert steps one pass
/// keeps 30–60 % of each column, so the second pass (which DGKS's stricter η = 1/√2 asks for
/// almost every step) is rarely run: on the 616k-DOF bowl (remeshed to 180k DOFs,
/// 200 modes) orthogonalisation 14.5 → 6.2 s, the same 102 steps, eigenvalues equal to
/// 8·10⁻¹² and strike gains to 2·10⁻⁶ (within pairs 2·10⁻⁶ apart) of the two-pass solve.
const KAHAN_KAPPA: f64 = 10.0;

/// Squared M-norms of W's columns, with Z = MW.
fn m_norms_sq(w: MatRef<'_, f64>, z: MatRef<'_, f64>) -> Vec<f64> {
    (0..w.ncols()).map(|j| w.col(j).iter().zip(z.col(j).iter()).map(|(a, b)| a * b).sum()).collect()
}

/// W ← W − X(XᵀZ) for M-orthonormal columns X, with Z = MW; returns the coefficients XᵀZ
/// (one classical Gram–Schmidt projection).
fn subtract_projection(x: MatRef<'_, f64>, w: &mut Mat<f64>, z: MatRef<'_, f64>) -> Mat<f64> {
    let mut c = Mat::<f64>::zeros(x.ncols(), w.ncols());
    matmul(c.as_mut(), Accum::Replace, x.transpose(), z, 1.0, orth_par(x));
    matmul(w.as_mut(), Accum::Add, x, c.as_ref(), -1.0, orth_par(x));
    c
}

/// Cholesky-QR in the M inner product with Z = MW: W = Q R, QᵀMQ = I, R upper triangular;
/// Z is transformed alongside. `None` if W is (numerically) rank deficient.
fn chol_qr(w: &mut Mat<f64>, z: &mut Mat<f64>) -> Option<Mat<f64>> {
    let b = w.ncols();
    let mut g = Mat::<f64>::zeros(b, b);
    matmul(g.as_mut(), Accum::Replace, w.transpose(), z.as_ref(), 1.0, STEP_PAR);
    // G = L Lᵀ (scalar Cholesky of a b × b matrix), R = Lᵀ.
    let mut l = Mat::<f64>::zeros(b, b);
    for j in 0..b {
        let gjj = g[(j, j)];
        let mut d = gjj;
        for p in 0..j {
            d -= l[(j, p)] * l[(j, p)];
        }
        if !(d > 1e-13 * gjj.abs()) || !(gjj > 0.0) {
            return None;
        }
        let d = d.sqrt();
        l[(j, j)] = d;
        for i in j + 1..b {
            let mut s = 0.5 * (g[(i, j)] + g[(j, i)]);
            for p in 0..j {
                s -= l[(i, p)] * l[(j, p)];
            }
            l[(i, j)] = s / d;
        }
    }
    // W ← W R⁻¹ and Z ← Z R⁻¹ in place: Rᵀ Xᵀ = Wᵀ with Rᵀ = L lower triangular.
    for x in [w, z] {
        faer::linalg::triangular_solve::solve_lower_triangular_in_place(
            l.as_ref(),
            x.as_mut().transpose_mut(),
            STEP_PAR,
        );
    }
    Some(l.transpose().to_owned())
}

/// Orthonormalises W (with Z = MW) against `locked` and `v`, then within itself (CholQR
/// twice). Returns (V coefficients C, R) with W_in − V C − Φ(…) = W_out R, or `None` on
/// rank deficiency.
#[allow(clippy::too_many_arguments)]
fn orthonormalise(
    mass: &mut Mass<'_>,
    locked: MatRef<'_, f64>,
    v: MatRef<'_, f64>,
    mv: MatRef<'_, f64>,
    w: &mut Mat<f64>,
    z: &mut Mat<f64>,
    prof: &mut Profile,
) -> Option<(Mat<f64>, Mat<f64>)> {
    let c = orthogonalise(mass, locked, v, mv, w, z, prof);
    let t = Instant::now();
    let r = (|| {
        let r1 = chol_qr(w, z)?;
        let r2 = chol_qr(w, z)?;
        let mut r = Mat::<f64>::zeros(r1.nrows(), r1.ncols());
        matmul(r.as_mut(), Accum::Replace, r2.as_ref(), r1.as_ref(), 1.0, Par::Seq);
        Some(r)
    })();
    prof.orth_seconds += t.elapsed().as_secs_f64();
    r.map(|r| (c, r))
}

/// What one Lanczos run at a fixed shift must achieve.
struct Goal {
    /// Eigenvalues below σ not yet locked (from the Sturm count).
    need_below: usize,
    /// Contiguous eigenvalues above σ wanted.
    want_above: usize,
    /// The chain above σ may stop once it passes this eigenvalue.
    lambda_stop: f64,
    /// Initial basis allocation (a multiple of the block size).
    cap: usize,
    /// Largest basis (memory limit).
    cap_max: usize,
}

/// What a run found (already locked).
struct RunOut {
    /// Converged eigenvalues below σ.
    below: usize,
    /// Unconverged Ritz values above the chain, ascending (estimates for the next shift).
    ritz_above: Vec<f64>,
}

#[allow(clippy::too_many_arguments)]
fn run(
    fac: &Factor<'_>,
    mass: &mut Mass<'_>,
    locked: &mut Locked,
    goal: &Goal,
    block: usize,
    tol: f64,
    seed: &mut u64,
    prof: &mut Profile,
) -> Result<RunOut, FemError> {
    let n = fac.sys.n;
    let b = block;
    let mut cap = goal.cap.min(goal.cap_max);
    let sigma = fac.sigma;
    prof.runs += 1;
    // The basis grows in place up to its memory limit: the capacity is reserved (address
    // space only; pages are touched as columns are added), so growing copies nothing (a
    // copy of V and MV cost the 180k-DOF bowl 3.6 s and held both copies at once).
    let mut v = Mat::<f64>::with_capacity(n, goal.cap_max.max(cap));
    let mut mv = Mat::<f64>::with_capacity(n, goal.cap_max.max(cap));
    v.resize_with(n, cap, |_, _| 0.0);
    mv.resize_with(n, cap, |_, _| 0.0);
    let mut h = Mat::<f64>::zeros(cap + b, cap);

    let fresh = |mass: &mut Mass<'_>,
                 locked: &Locked,
                 v: MatRef<'_, f64>,
                 mv: MatRef<'_, f64>,
                 seed: &mut u64,
                 prof: &mut Profile| {
        for _ in 0..20 {
            let mut w = random_block(n, b, *seed);
            *seed += 1;
            let mut z = Mat::<f64>::zeros(n, b);
            mass.apply(w.as_ref(), z.as_mut(), prof);
            if orthonormalise(mass, locked.view(), v, mv, &mut w, &mut z, prof).is_some() {
                return Some((w, z));
            }
        }
        None
    };
    let no_room =
        |k: usize| FemError::NotConverged { converged: 0, wanted: goal.need_below + goal.want_above, basis: k };
    let (w, z) = fresh(mass, locked, v.as_ref().subcols(0, 0), mv.as_ref().subcols(0, 0), seed, prof)
        .ok_or_else(|| no_room(0))?;
    v.as_mut().subcols_mut(0, b).copy_from(&w);
    mv.as_mut().subcols_mut(0, b).copy_from(&z);
    let mut k = b;
    let mut last_check = 0;
    loop {
        // W = Op X_last = (K − σM)⁻¹ (M X_last); the M-image is stored.
        let mut w = mv.as_ref().subcols(k - b, b).to_owned();
        fac.solve(w.as_mut(), prof);
        prof.steps += 1;
        let mut z = Mat::<f64>::zeros(n, b);
        mass.apply(w.as_ref(), z.as_mut(), prof);
        let res = orthonormalise(
            mass,
            locked.view(),
            v.as_ref().subcols(0, k),
            mv.as_ref().subcols(0, k),
            &mut w,
            &mut z,
            prof,
        );
        let r = match res {
            Some((c, r)) => {
                h.as_mut().submatrix_mut(0, k - b, k, b).copy_from(&c);
                r
            }
            None => {
                // Invariant subspace: continue with fresh directions, coupled by zero.
                let (fw, fz) = fresh(mass, locked, v.as_ref().subcols(0, k), mv.as_ref().subcols(0, k), seed, prof)
                    .ok_or_else(|| no_room(k))?;
                w = fw;
                z = fz;
                Mat::zeros(b, b)
            }
        };
        h.as_mut().submatrix_mut(k, k - b, b, b).copy_from(&r);

        if k + b > cap && cap + b <= goal.cap_max {
            // Not there yet: grow the basis (keeping all work) up to the memory limit.
            let new_cap = (cap + cap / 2).div_ceil(b) * b;
            let new_cap = new_cap.min(goal.cap_max / b * b);
            v.resize_with(n, new_cap, |_, _| 0.0);
            mv.resize_with(n, new_cap, |_, _| 0.0);
            let mut h2 = Mat::<f64>::zeros(new_cap + b, new_cap);
            h2.as_mut().submatrix_mut(0, 0, k + b, k).copy_from(h.as_ref().submatrix(0, 0, k + b, k));
            (h, cap) = (h2, new_cap);
        }
        let full = k + b > cap;
        let min_k = (goal.need_below + goal.want_above + b).min(cap);
        if full || (k >= min_k && k >= last_check + (k / 8).max(2 * b)) {
            last_check = k;
            let t = Instant::now();
            let hs = Mat::from_fn(k, k, |i, j| 0.5 * (h[(i, j)] + h[(j, i)]));
            let eig = hs.self_adjoint_eigen(Side::Lower).map_err(|e| {
                FemError::Factorization(format!("dense eigensolver failed on the projected matrix: {e:?}"))
            })?;
            let s = eig.S().column_vector();
            let u = eig.U();
            let theta_max = (0..k).map(|i| s[i].abs()).fold(0.0, f64::max);
            // Residual of Ritz pair i: ‖R · U[k−b..k, i]‖ (M-norm, since the next block is
            // M-orthonormal). Rounding leaves a floor of about ε‖Op‖ under every residual.
            let conv: Vec<bool> = (0..k)
                .map(|i| {
                    let mut res2 = 0.0;
                    for rr in 0..b {
                        let mut acc = 0.0;
                        for cc in 0..b {
                            acc += r[(rr, cc)] * u[(k - b + cc, i)];
                        }
                        res2 += acc * acc;
                    }
                    // The floor may at most double the tolerance: a pair far from σ
                    // (|θ| ≪ θ_max) must not pass on rounding alone.
                    let floor = (1e3 * f64::EPSILON * theta_max).min(tol * s[i].abs());
                    s[i] != 0.0 && res2.sqrt() <= tol * s[i].abs() + floor
                })
                .collect();
            // θ ascending: negative θ (λ below σ) first, positive θ descending = λ ascending.
            let below: Vec<usize> = (0..k).filter(|&i| s[i] < 0.0 && conv[i]).collect();
            let mut chain = Vec::new();
            let mut first_unconv = k;
            for i in (0..k).rev() {
                if s[i] <= 0.0 {
                    break;
                }
                if !conv[i] {
                    first_unconv = i;
                    break;
                }
                chain.push(i);
            }
            let lam = |i: usize| sigma + 1.0 / s[i];
            let chain_done = chain.len() >= goal.want_above || chain.last().is_some_and(|&i| lam(i) > goal.lambda_stop);
            prof.ritz_seconds += t.elapsed().as_secs_f64();
            if (below.len() >= goal.need_below && chain_done) || full {
                prof.max_basis = prof.max_basis.max(k);
                let t = Instant::now();
                // Lock every converged pair (also those above the chain): each is a true
                // eigenpair, and deflating it speeds up the next run at this shift.
                let sel: Vec<usize> = (0..k).filter(|&i| conv[i]).collect();
                let y = Mat::from_fn(k, sel.len(), |i, j| u[(i, sel[j])]);
                let mut phi = Mat::<f64>::zeros(n, sel.len());
                matmul(
                    phi.as_mut(),
                    Accum::Replace,
                    v.as_ref().subcols(0, k),
                    y.as_ref(),
                    1.0,
                    orth_par(v.as_ref().subcols(0, k)),
                );
                for (j, &i) in sel.iter().enumerate() {
                    locked.push(lam(i), phi.as_ref().subcols(j, 1));
                }
                prof.lock_seconds += t.elapsed().as_secs_f64();
                let ritz_above = if first_unconv < k {
                    (0..=first_unconv).rev().filter(|&i| s[i] > 0.0).map(lam).collect()
                } else {
                    Vec::new()
                };
                return Ok(RunOut { below: below.len(), ritz_above });
            }
        }
        v.as_mut().subcols_mut(k, b).copy_from(&w);
        mv.as_mut().subcols_mut(k, b).copy_from(&z);
        k += b;
    }
}

/// A point in the widest relative gap between consecutive values of `sorted` (ascending)
/// near index `i`, so a shift there keeps K − σM well away from singular.
fn gap_point(sorted: &[f64], i: usize) -> f64 {
    let mut best = (f64::MIN, 0.5 * (sorted[i] + sorted[i + 1]));
    for j in i..(i + 4).min(sorted.len() - 1) {
        let g = (sorted[j + 1] - sorted[j]) / sorted[j].abs().max(1e-300);
        if g > best.0 {
            best = (g, 0.5 * (sorted[j] + sorted[j + 1]));
        }
        if g > 1e-3 {
            break;
        }
    }
    best.1
}

/// Spectrum slicing: a sequence of shifts σ₀ < σ₁ < …, each verified by its Sturm count
/// (Grimes, Lewis & Simon 1994), with a block shift-invert Lanczos run per shift that locks
/// what it converges. Used by [`solve`] above [`DENSE_MAX`] DOFs; public so tests can force
/// it on small meshes.
///
/// # Errors
/// As [`solve`].
pub fn solve_sliced(sys: &System, opts: &EigenOptions, progress: &dyn Fn(&str, f32)) -> Result<EigenResult, FemError> {
    let t0 = Instant::now();
    let mut prof = Profile::default();
    let plan = SlicePlan::new(sys.n, opts)?;
    let fac = Factor::new(sys, opts.max_factor_bytes, &mut prof)?;
    let mut sl = Slicing::new(sys, fac, plan, prof);
    progress("factorise", 0.0);
    sl.fac.factor(opts.sigma, &mut sl.prof)?;
    progress("eigen", 0.0);
    loop {
        let at = sl.at_shift();
        match sl.next_step(&at) {
            Step::Done => break,
            Step::Run { want_above } => {
                sl.run_here(&at, want_above, t0)?;
                progress("eigen", (sl.locked.len() as f32 / plan.nev as f32).min(1.0));
            }
            Step::Advance => sl.advance(&at)?,
        }
    }
    let Slicing { fac, locked, mut prof, .. } = sl;
    let t = Instant::now();
    let pairs = lowest_pairs(&locked, &plan, sys.n);
    drop(locked);
    drop(fac);
    prof.lock_seconds += t.elapsed().as_secs_f64();
    let pairs = check_and_refine(sys, pairs, opts.sigma, plan.b, &mut prof, t0)?;
    if debug() {
        eprintln!(
            "eigen: {:.1} s: symbolic {:.1}, numeric {:.1} ({} shifts), solves {:.1}, M {:.1}, orth {:.1}, Ritz {:.1}, lock {:.1}, check {:.1}; {} steps, {} second Gram–Schmidt passes skipped",
            prof.total_seconds,
            prof.symbolic_seconds,
            prof.numeric_seconds,
            prof.shifts.len(),
            prof.solve_seconds,
            prof.mass_seconds,
            prof.orth_seconds,
            prof.ritz_seconds,
            prof.lock_seconds,
            prof.check_seconds,
            prof.steps,
            prof.orth_skipped
        );
    }
    LAST_PROFILE.with(|p| *p.borrow_mut() = prof.clone());
    Ok(EigenResult {
        lambdas: pairs.lambdas,
        vectors: pairs.vectors,
        iterations: prof.steps,
        basis: prof.max_basis,
        factor_seconds: prof.symbolic_seconds + prof.numeric_seconds,
        sigma: opts.sigma,
        profile: prof,
    })
}

/// The sizes of a spectrum-slicing solve, fixed by the options and the problem size.
#[derive(Clone, Copy)]
struct SlicePlan {
    /// Block size.
    b: usize,
    /// Eigenpairs wanted (at most half the DOFs).
    nev: usize,
    /// Largest eigenvalue wanted (∞ for none).
    lmax: f64,
    /// Largest basis of one run (a multiple of the block size).
    cap_max: usize,
    /// Eigenvalues each shift after the first aims at.
    slice: usize,
    /// Most Lanczos runs in all.
    max_runs: usize,
    /// Convergence tolerance of the Ritz pairs.
    tol: f64,
}

impl SlicePlan {
    /// The plan for `n` DOFs; an error if they are too few for the block size or the modes.
    fn new(n: usize, opts: &EigenOptions) -> Result<SlicePlan, FemError> {
        let b = opts.block.clamp(1, n.max(1));
        let nev = opts.nev.min(n / 2);
        let lmax = opts.lambda_max.unwrap_or(f64::INFINITY);
        let cap_max = (opts.max_basis.min(n / 2) / b * b).max(4 * b);
        if 4 * b > n / 2 || nev == 0 {
            return Err(FemError::Mesh(format!(
                "the mesh has only {n} degrees of freedom; too few for {} modes, use a finer resolution",
                opts.nev
            )));
        }
        let slice = opts.slice.max(2 * b);
        let max_runs = 8 + 4 * nev.div_ceil(slice / 2);
        Ok(SlicePlan { b, nev, lmax, cap_max, slice, max_runs, tol: opts.tol })
    }
}

/// Which kind of shift the slicing is at.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Phase {
    /// The first shift, below the whole spectrum.
    First,
    /// A shift placed beyond the locked eigenvalues from their observed density.
    Advancing,
    /// A verification shift just above the last wanted eigenvalue: only what its Sturm count
    /// says lies below it is still to be found.
    Verifying,
}

/// The Sturm count at the current shift against what is locked.
struct AtShift {
    /// The shift σ (rad²/s²).
    sigma: f64,
    /// Eigenvalues below σ (negative pivots of K − σM).
    nu: usize,
    /// Locked eigenvalues below σ.
    below: usize,
    /// Eigenvalues below σ not yet locked.
    need: usize,
}

/// What to do at the current shift.
enum Step {
    /// Every wanted eigenvalue is locked.
    Done,
    /// A Lanczos run at this shift, also after `want_above` eigenvalues above it.
    Run {
        /// Contiguous eigenvalues above σ wanted.
        want_above: usize,
    },
    /// Everything below σ is locked: move the shift up.
    Advance,
}

/// The state of a spectrum-slicing solve between Lanczos runs.
struct Slicing<'a> {
    /// The solve's sizes.
    plan: SlicePlan,
    /// LDLᵀ of K − σM at the current shift.
    fac: Factor<'a>,
    /// M products.
    mass: Mass<'a>,
    /// Converged eigenpairs.
    locked: Locked,
    /// Timings and counters.
    prof: Profile,
    /// Seed of the next random start block.
    seed: u64,
    /// Which kind of shift σ is.
    phase: Phase,
    /// Whether a run was made at the current shift.
    ran_here: bool,
    /// What the latest run found.
    last: Option<RunOut>,
    /// Consecutive runs that found nothing.
    stalls: usize,
}

impl<'a> Slicing<'a> {
    /// The state before the first shift is factored.
    fn new(sys: &'a System, fac: Factor<'a>, plan: SlicePlan, prof: Profile) -> Slicing<'a> {
        Slicing {
            plan,
            fac,
            mass: Mass::new(sys),
            locked: Locked { lambdas: Vec::new(), vecs: Mat::zeros(sys.n, plan.nev + plan.slice) },
            prof,
            seed: 1,
            phase: Phase::First,
            ran_here: false,
            last: None,
            stalls: 0,
        }
    }

    /// The Sturm count at the current shift and how much of it is locked.
    fn at_shift(&self) -> AtShift {
        let sigma = self.fac.sigma;
        let nu = self.fac.negative;
        let below = self.locked.count_below(sigma);
        AtShift { sigma, nu, below, need: nu.saturating_sub(below) }
    }

    /// Stop, run at this shift, or move on.
    fn next_step(&self, at: &AtShift) -> Step {
        let p = &self.plan;
        // A verification shift sits just above the last wanted eigenvalue.
        if at.need == 0 && (at.nu >= p.nev || at.sigma >= p.lmax || self.phase == Phase::Verifying) {
            return Step::Done;
        }
        let want_above = match self.phase {
            Phase::Verifying => 0,
            // The first shift sits below the whole spectrum (one-sided): take the rigid
            // modes and the first few elastic ones, enough to measure the density.
            Phase::First => (p.slice / 2).min(p.nev - at.nu + 2),
            Phase::Advancing => (p.slice / 2).min(p.nev.saturating_sub(at.nu) + 2),
        };
        if at.need > 0 || (!self.ran_here && want_above > 0) {
            Step::Run { want_above }
        } else {
            Step::Advance
        }
    }

    /// One Lanczos run at the current shift, locking what converges.
    ///
    /// # Errors
    /// [`FemError::NotConverged`] past the run limit or after three runs that found nothing.
    fn run_here(&mut self, at: &AtShift, want_above: usize, t0: Instant) -> Result<(), FemError> {
        let p = self.plan;
        let (b, need) = (p.b, at.need);
        if self.prof.runs >= p.max_runs {
            return Err(FemError::NotConverged {
                converged: self.locked.count_below(p.lmax).min(p.nev),
                wanted: p.nev,
                basis: self.prof.max_basis,
            });
        }
        // Eigenvalues as close above σ as the needed ones below converge alongside them;
        // the basis grows past this first allocation if needed.
        let cap = ((5 * (need + want_above.max(need)) / 2 + 4 * b).div_ceil(b) * b).clamp(6 * b, p.cap_max);
        let goal = Goal { need_below: need, want_above, lambda_stop: p.lmax, cap, cap_max: p.cap_max };
        let before = self.locked.len();
        let out = run(&self.fac, &mut self.mass, &mut self.locked, &goal, b, p.tol, &mut self.seed, &mut self.prof)?;
        if debug() {
            eprintln!(
                "eigen: run {} sigma {:.4e} nu {} locked-below {} need {need} want {want_above} cap {cap} -> found below {} locked {} ritz_above {:?} steps {} t {:.1}s",
                self.prof.runs, at.sigma, at.nu, at.below, out.below, self.locked.len(), &out.ritz_above[..out.ritz_above.len().min(3)], self.prof.steps, t0.elapsed().as_secs_f64()
            );
        }
        self.stalls = if self.locked.len() == before && out.below == 0 { self.stalls + 1 } else { 0 };
        if self.stalls >= 3 {
            return Err(FemError::NotConverged {
                converged: self.locked.len().min(p.nev),
                wanted: p.nev,
                basis: self.prof.max_basis,
            });
        }
        self.ran_here = true;
        self.last = Some(out);
        Ok(())
    }

    /// Everything below σ is locked: places the next shift beyond the locked chain (a
    /// verification shift once the wanted eigenvalues are in it) and factors there.
    ///
    /// # Errors
    /// [`FemError::NotConverged`] if the shift would not move up; as [`Factor::factor`].
    fn advance(&mut self, at: &AtShift) -> Result<(), FemError> {
        let p = self.plan;
        let out = self.last.take().unwrap_or(RunOut { below: 0, ritz_above: Vec::new() });
        let mut above: Vec<f64> = self.locked.lambdas.iter().copied().filter(|&l| l >= at.sigma).collect();
        above.sort_by(f64::total_cmp);
        // The chain's end: locked values above σ that lie below the first unconverged Ritz
        // value are complete as far as this run can tell (the next Sturm count checks it).
        let r_min = out.ritz_above.first().copied().unwrap_or(f64::INFINITY);
        let chain: Vec<f64> = above.iter().copied().filter(|&l| l < r_min).collect();
        let verify = at.nu + chain.len() > p.nev || chain.last().is_some_and(|&l| l >= p.lmax);
        let next = if verify {
            verification_shift(&chain, r_min, at, &p)
        } else if chain.len() >= 4 {
            density_shift(&chain, &out.ritz_above, p.slice)
        } else {
            let u = chain.last().copied().unwrap_or(at.sigma);
            u + (u - at.sigma).abs().max(at.sigma.abs())
        };
        if !(next > at.sigma) {
            return Err(FemError::NotConverged {
                converged: self.locked.len().min(p.nev),
                wanted: p.nev,
                basis: self.prof.max_basis,
            });
        }
        self.phase = if verify { Phase::Verifying } else { Phase::Advancing };
        self.ran_here = false;
        self.fac.factor(next, &mut self.prof)
    }
}

/// A verification shift between the last wanted eigenvalue of the locked `chain` above σ
/// and the next one (or the first unconverged Ritz value `r_min`).
fn verification_shift(chain: &[f64], r_min: f64, at: &AtShift, p: &SlicePlan) -> f64 {
    let c = chain.len();
    let idx = (p.nev - at.nu - 1).min(c - 1);
    let idx = match chain.iter().position(|&l| l > p.lmax) {
        Some(0) => usize::MAX,
        Some(q) if q - 1 < idx => q - 1,
        _ => idx,
    };
    if idx == usize::MAX {
        // Every eigenvalue up to λ_max lies below σ or in the gap before the chain.
        0.5 * (at.sigma + chain[0])
    } else if idx + 1 < c {
        gap_point(chain, idx)
    } else if r_min.is_finite() {
        0.5 * (chain[idx] + r_min)
    } else {
        chain[idx] + 1e-3 * chain[idx].abs()
    }
}

/// The next shift from the density of the upper half of the locked `chain` (at least four
/// values), so about half a slice lies between the chain's end and the shift.
fn density_shift(chain: &[f64], ritz_above: &[f64], slice: usize) -> f64 {
    let c = chain.len();
    let u = chain[c - 1];
    let lo = chain[c / 2];
    let rho = (c - c / 2 - 1).max(1) as f64 / (u - lo).max(1e-300);
    let target = u + 0.5 * slice as f64 / rho;
    // Prefer the midpoint of the widest Ritz-value gap near the target, so σ stays
    // well away from every eigenvalue (a σ inside a near-degenerate pair would make
    // K − σM nearly singular).
    let mut est: Vec<f64> = ritz_above.iter().copied().filter(|&l| l > u).collect();
    est.insert(0, u);
    let mut best = target;
    let mut widest = 0.0;
    for win in est.windows(2) {
        let m = 0.5 * (win[0] + win[1]);
        if (m - target).abs() < 0.25 * (target - u) && win[1] - win[0] > widest {
            widest = win[1] - win[0];
            best = m;
        }
    }
    best
}

/// Eigenvalues with one eigenvector per column.
struct Pairs {
    /// Eigenvalues λ (rad²/s²), ascending.
    lambdas: Vec<f64>,
    /// Mass-normalised eigenvectors.
    vectors: Mat<f64>,
}

/// The lowest locked pairs, ascending: up to the first past λ_max, at most `nev`.
fn lowest_pairs(locked: &Locked, p: &SlicePlan, n: usize) -> Pairs {
    let mut order: Vec<usize> = (0..locked.len()).collect();
    order.sort_by(|&i, &j| locked.lambdas[i].total_cmp(&locked.lambdas[j]));
    let want = order
        .iter()
        .take_while(|&&i| locked.lambdas[i] <= p.lmax)
        .count()
        .saturating_add(1)
        .min(p.nev)
        .min(order.len());
    let lambdas: Vec<f64> = order[..want].iter().map(|&i| locked.lambdas[i]).collect();
    let mut vectors = Mat::<f64>::zeros(n, want);
    for (j, &i) in order[..want].iter().enumerate() {
        vectors.as_mut().col_mut(j).copy_from(locked.vecs.col(i));
    }
    Pairs { lambdas, vectors }
}

/// Checks the pairs on the original problem and replaces each λ by its Rayleigh quotient,
/// keeping ascending order; records the check in `prof`.
///
/// # Errors
/// [`FemError::Factorization`] if a Rayleigh quotient is off by 1e-4 or more.
fn check_and_refine(
    sys: &System,
    pairs: Pairs,
    sigma0: f64,
    b: usize,
    prof: &mut Profile,
    t0: Instant,
) -> Result<Pairs, FemError> {
    // Residual check on the original problem (guards the unpivoted LDLᵀ of indefinite
    // K − σM: an inaccurate solve would show here).
    let t = Instant::now();
    let check = residual(sys, &pairs.lambdas, pairs.vectors.as_ref(), sigma0.abs(), b);
    prof.max_residual = check.residual;
    prof.max_rayleigh_error = check.rayleigh_error;
    prof.check_seconds = t.elapsed().as_secs_f64();
    prof.total_seconds = t0.elapsed().as_secs_f64();
    // A relative error of 1e-4 in λ is 0.09 cents: beyond it the factorisation was broken.
    // Below it, each λ is replaced by its Rayleigh quotient φᵀKφ/φᵀMφ, whose error is
    // second order in the eigenvector's (Parlett, The Symmetric Eigenvalue Problem, §4.6).
    let rq = check.rayleigh_error;
    if !(rq < 1e-4) {
        return Err(FemError::Factorization(format!(
            "eigenpairs failed the Rayleigh-quotient check ({rq:.1e}); the shifted factorisation was inaccurate, try another resolution"
        )));
    }
    let refined: Vec<f64> = pairs.lambdas.iter().zip(&check.corrections).map(|(l, d)| l + d).collect();
    // Keep ascending order (a near-degenerate pair may swap by the correction).
    let mut order: Vec<usize> = (0..refined.len()).collect();
    order.sort_by(|&i, &j| refined[i].total_cmp(&refined[j]));
    let lambdas: Vec<f64> = order.iter().map(|&i| refined[i]).collect();
    let vectors = pairs.vectors;
    let vectors = if order.iter().enumerate().all(|(k, &i)| k == i) {
        vectors
    } else {
        Mat::from_fn(vectors.nrows(), order.len(), |r, j| vectors[(r, order[j])])
    };
    Ok(Pairs { lambdas, vectors })
}

/// What [`residual`] measured.
struct Check {
    /// Largest ‖Kφ − λMφ‖₂ / ((|λ| + s)‖Mφ‖₂).
    residual: f64,
    /// Largest |φᵀKφ − λ·φᵀMφ| / (|λ| + s).
    rayleigh_error: f64,
    /// Per column, the Rayleigh-quotient correction φᵀ(K − λM)φ / φᵀMφ.
    corrections: Vec<f64>,
}

/// Over all columns: the largest ‖Kφ − λMφ‖₂ / ((|λ| + s)‖Mφ‖₂) and the largest
/// |φᵀKφ − λ·φᵀMφ| / (|λ| + s) (the Rayleigh quotient; an inaccurate factorisation would
/// move it at first order, a merely unconverged vector only at second order).
/// Also returns, per column, the Rayleigh-quotient correction φᵀ(K − λM)φ / φᵀMφ.
fn residual(sys: &System, lambdas: &[f64], phi: MatRef<'_, f64>, s: f64, b: usize) -> Check {
    use rayon::prelude::*;
    let n = sys.n;
    // One block of columns: (residual, Rayleigh error, corrections, lines for the debug log).
    let block = |c0: usize| {
        let bb = b.min(lambdas.len() - c0);
        let mut x = vec![0.0; n * bb];
        let mut kx = vec![0.0; n * bb];
        let mut mx = vec![0.0; n * bb];
        for c in 0..bb {
            for r in 0..n {
                x[r * bb + c] = phi[(r, c0 + c)];
            }
        }
        sym_matvec_rows(sys, &sys.k, &x, &mut kx, bb);
        sym_matvec_rows(sys, &sys.m, &x, &mut mx, bb);
        let (mut worst, mut worst_rq) = (0.0f64, 0.0f64);
        let mut corrections = vec![0.0; bb];
        let mut log = Vec::new();
        for c in 0..bb {
            let l = lambdas[c0 + c];
            let (mut rr, mut mm, mut q, mut xm) = (0.0, 0.0, 0.0, 0.0);
            for r in 0..n {
                let d = kx[r * bb + c] - l * mx[r * bb + c];
                rr += d * d;
                mm += mx[r * bb + c] * mx[r * bb + c];
                q += x[r * bb + c] * d;
                xm += x[r * bb + c] * mx[r * bb + c];
            }
            if xm > 0.0 {
                corrections[c] = q / xm;
            }
            let res = rr.sqrt() / ((l.abs() + s) * mm.sqrt()).max(1e-300);
            worst = worst.max(res);
            worst_rq = worst_rq.max(q.abs() / (l.abs() + s));
            if q.abs() / (l.abs() + s) > 1e-9 {
                log.push(format!(
                    "eigen: check pair {} lambda {l:.6e} rq err {:.1e} residual {res:.1e}",
                    c0 + c,
                    q.abs() / (l.abs() + s)
                ));
            }
        }
        (worst, worst_rq, corrections, log)
    };
    let starts: Vec<usize> = (0..lambdas.len()).step_by(b.max(1)).collect();
    // Each block reads K and M once (bound by memory): both cores for big problems, in
    // column order either way (the result does not depend on the threads).
    let blocks: Vec<_> = if n * lambdas.len() >= ORTH_PAR_ENTRIES {
        starts.par_iter().map(|&c0| block(c0)).collect()
    } else {
        starts.iter().map(|&c0| block(c0)).collect()
    };
    let mut check = Check { residual: 0.0, rayleigh_error: 0.0, corrections: Vec::with_capacity(lambdas.len()) };
    for (worst, worst_rq, corrections, log) in blocks {
        check.residual = check.residual.max(worst);
        check.rayleigh_error = check.rayleigh_error.max(worst_rq);
        check.corrections.extend(corrections);
        if debug() {
            for line in log {
                eprintln!("{line}");
            }
        }
    }
    check
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Material, Shape};

    /// The assembled mass matrix of an isotropic solid is Mₛ ⊗ I₃, so the nodal product is
    /// taken and gives the full product's answer; a matrix without that structure is
    /// refused (the full product is used).
    #[test]
    fn nodal_mass_product_matches_the_full_one_and_refuses_other_matrices() {
        let mesh = crate::mesh_shape(&Shape::Bar { length: 0.2, width: 0.02, thickness: 0.01 }, 12).unwrap();
        let sys = crate::assemble(&mesh, &Material::STEEL).unwrap();
        let nodal = Nodal::from_system(&sys).expect("an isotropic solid's M is Mₛ ⊗ I₃");
        let b = 8;
        let x: Vec<f64> = (0..sys.n * b).map(|i| ((i * 7919) % 1013) as f64 / 1013.0 - 0.5).collect();
        let mut full = vec![0.0; sys.n * b];
        let mut fast = vec![0.0; sys.n * b];
        sym_matvec_rows(&sys, &sys.m, &x, &mut full, b);
        sym_csc_matvec_rows(&nodal.col_ptr, &nodal.row_idx, &nodal.val, &x, &mut fast, 3 * b);
        let scale = full.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        let worst = full.iter().zip(&fast).fold(0.0f64, |a, (p, q)| a.max((p - q).abs()));
        assert!(worst <= 1e-14 * scale, "nodal product differs by {worst:e} (scale {scale:e})");
        // A cross-direction entry (x at one node coupled with y at another).
        let mut cross = sys.clone();
        let p = (cross.col_ptr[0]..cross.col_ptr[1]).find(|&p| cross.row_idx[p] % 3 == 1).unwrap();
        cross.m[p] = 1e-9;
        assert!(Nodal::from_system(&cross).is_none(), "a coupling of x with y was accepted");
        // The y direction's entries differing from x's (an anisotropic mass).
        let mut aniso = sys.clone();
        let p = (aniso.col_ptr[1]..aniso.col_ptr[2]).find(|&p| aniso.row_idx[p] % 3 == 1).unwrap();
        aniso.m[p] *= 1.5;
        assert!(Nodal::from_system(&aniso).is_none(), "an anisotropic mass was accepted");
    }
}
