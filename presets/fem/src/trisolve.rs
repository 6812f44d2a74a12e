//! Solves with a supernodal LDLᵀ factor for a block of right-hand sides stored by rows.
//!
//! The shift-invert Lanczos of [`crate::eigen`] applies (K − σM)⁻¹ to blocks of 8–16 vectors
//! about a hundred times per build. faer's solve keeps the block by columns, so every row a
//! supernode updates or reads costs one cache line per right-hand side; here a row's `B`
//! values are adjacent (one cache line for B = 8) and the fill-reducing permutation is applied
//! while the block is copied in and out. The arithmetic is the textbook supernodal one
//! (Ng & Peyton 1993, "Block sparse Cholesky algorithms on advanced uniprocessor computers";
//! Davis 2006, *Direct Methods for Sparse Linear Systems* §4.8): for each supernode in order,
//! a unit lower triangular solve on its diagonal block and an update of the rows below it;
//! then the diagonal D; then the same backwards with Lᵀ.
//!
//! The two halves of a nested-dissection ordering are independent until their separator: the
//! elimination tree's subtrees are solved on the thread pool (forward: each subtree's updates
//! to rows outside it go to a private buffer, added before the separator is solved;
//! backward: the subtrees only read the rows above them, which are final).

use faer::linalg::matmul::matmul;
use faer::linalg::triangular_solve::{solve_unit_lower_triangular_in_place, solve_unit_upper_triangular_in_place};
use faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky;
use faer::{Accum, MatMut, MatRef, Par};

/// Supernodes with more entries than this (columns × rows below, or columns²) use faer's
/// dense kernels; smaller ones a plain loop (faer's dispatch costs more than their
/// arithmetic). The solve is bound by reading the factor, so the choice matters little.
const DENSE_ENTRIES: usize = 4096;

/// A supernodal LDLᵀ factor (faer's structure and values) prepared for row-major solves.
pub struct RowSolver<'a> {
    sym: &'a SymbolicSupernodalCholesky<usize>,
    values: &'a [f64],
    /// The elimination tree cut in two independent halves and the part above them.
    split: Option<Split>,
}

/// Supernodes `0..b` and `b..t` are two sets of whole subtrees of the elimination tree
/// (supernodes are in postorder, so a subtree is a contiguous range); `t..` is the part above
/// them (the top separators). Rows split the same way at `rows_b`, `rows_t`.
#[derive(Clone, Copy, Debug)]
struct Split {
    b: usize,
    t: usize,
    rows_b: usize,
    rows_t: usize,
}

/// Where the elimination tree of a symbolic factor is cut for the two-thread solve (or that
/// it is not), see [`RowSolver`].
#[derive(Clone, Copy, Debug)]
pub struct TreeSplit(Option<Split>);

impl TreeSplit {
    /// The cut of `sym`'s elimination tree.
    pub fn of(sym: &SymbolicSupernodalCholesky<usize>) -> TreeSplit {
        TreeSplit(split(sym))
    }
}

/// Rows `own0..` of the block held mutably (`own`), and the rows `far0..` that lie beyond them.
struct View<'x, F> {
    own: &'x mut [f64],
    own0: usize,
    far: F,
    far0: usize,
}

impl<'a> RowSolver<'a> {
    /// The solver for `sym` with numeric `values` (faer's layout: each supernode's columns
    /// stored by columns, diagonal block first, the diagonal holding D).
    ///
    /// # Panics
    /// If `values` does not match `sym`.
    pub fn new(sym: &'a SymbolicSupernodalCholesky<usize>, values: &'a [f64]) -> RowSolver<'a> {
        RowSolver::with_split(sym, values, TreeSplit::of(sym))
    }

    /// As [`RowSolver::new`] with the cut of the tree already made ([`TreeSplit::of`] the same
    /// `sym`): it depends only on the symbolic factor, so one cut serves every shift.
    ///
    /// # Panics
    /// If `values` does not match `sym`.
    pub fn with_split(sym: &'a SymbolicSupernodalCholesky<usize>, values: &'a [f64], tree: TreeSplit) -> RowSolver<'a> {
        assert_eq!(values.len(), sym.len_val(), "values do not match the symbolic factor");
        RowSolver { sym, values, split: tree.0 }
    }

    /// Dimension.
    pub fn n(&self) -> usize {
        self.sym.nrows()
    }

    /// Whether solves run the two halves of the elimination tree on the thread pool.
    pub fn is_split(&self) -> bool {
        self.split.is_some()
    }

    /// The block sizes [`RowSolver::solve_permuted`] takes.
    pub const BLOCKS: [usize; 3] = [4, 8, 16];

    /// x ← (L D Lᵀ)⁻¹ x for `x` in the factor's (permuted) order, row-major with `b` values
    /// per row.
    ///
    /// # Panics
    /// If `b` is not one of [`RowSolver::BLOCKS`] or `x` is not n × b.
    pub fn solve_permuted(&self, x: &mut [f64], b: usize) {
        self.solve_any(x, b, true);
    }

    /// The same, by one thread in supernode order (a reference for the split solve).
    ///
    /// # Panics
    /// As [`RowSolver::solve_permuted`].
    pub fn solve_permuted_sequential(&self, x: &mut [f64], b: usize) {
        self.solve_any(x, b, false);
    }

    fn solve_any(&self, x: &mut [f64], b: usize, split: bool) {
        assert_eq!(x.len(), self.n() * b, "right-hand side of the wrong size");
        match (b, split) {
            (4, true) => self.solve_b::<4>(x),
            (8, true) => self.solve_b::<8>(x),
            (16, true) => self.solve_b::<16>(x),
            (4, false) => self.sequential::<4>(x),
            (8, false) => self.sequential::<8>(x),
            (16, false) => self.sequential::<16>(x),
            _ => panic!("block of {b} right-hand sides: only {:?}", Self::BLOCKS),
        }
    }

    fn sequential<const B: usize>(&self, x: &mut [f64]) {
        let ns = self.sym.n_supernodes();
        let n = self.n();
        let mut tmp = Vec::new();
        let mut v = View { own: x, own0: 0, far: &mut [] as &mut [f64], far0: n };
        for s in 0..ns {
            self.forward::<B>(s, &mut v, &mut tmp);
        }
        self.diagonal::<B>(0..ns, v.own, 0);
        let mut v = View { own: v.own, own0: 0, far: &[] as &[f64], far0: n };
        for s in (0..ns).rev() {
            self.backward::<B>(s, &mut v, &mut tmp);
        }
    }

    fn solve_b<const B: usize>(&self, x: &mut [f64]) {
        let Some(sp) = self.split else {
            return self.sequential::<B>(x);
        };
        let ns = self.sym.n_supernodes();
        let n = self.n();
        let (xa, rest) = x.split_at_mut(sp.rows_b * B);
        let (xb, xt) = rest.split_at_mut((sp.rows_t - sp.rows_b) * B);
        // Forward: each half's updates of the rows above it go to its own buffer.
        let mut far_a = vec![0.0; xt.len()];
        let mut far_b = vec![0.0; xt.len()];
        rayon::join(
            || {
                let mut tmp = Vec::new();
                let mut v = View { own: &mut *xa, own0: 0, far: &mut far_a[..], far0: sp.rows_t };
                for s in 0..sp.b {
                    self.forward::<B>(s, &mut v, &mut tmp);
                }
                self.diagonal::<B>(0..sp.b, v.own, 0);
            },
            || {
                let mut tmp = Vec::new();
                let mut v = View { own: &mut *xb, own0: sp.rows_b, far: &mut far_b[..], far0: sp.rows_t };
                for s in sp.b..sp.t {
                    self.forward::<B>(s, &mut v, &mut tmp);
                }
                self.diagonal::<B>(sp.b..sp.t, v.own, sp.rows_b);
            },
        );
        for ((o, a), b) in xt.iter_mut().zip(&far_a).zip(&far_b) {
            *o += a + b;
        }
        let mut tmp = Vec::new();
        let mut v = View { own: &mut *xt, own0: sp.rows_t, far: &mut [] as &mut [f64], far0: n };
        for s in sp.t..ns {
            self.forward::<B>(s, &mut v, &mut tmp);
        }
        self.diagonal::<B>(sp.t..ns, v.own, sp.rows_t);
        let mut v = View { own: v.own, own0: sp.rows_t, far: &[] as &[f64], far0: n };
        for s in (sp.t..ns).rev() {
            self.backward::<B>(s, &mut v, &mut tmp);
        }
        // Backward: the halves only read the rows above them, now final.
        let xt: &[f64] = xt;
        rayon::join(
            || {
                let mut tmp = Vec::new();
                let mut v = View { own: &mut *xa, own0: 0, far: xt, far0: sp.rows_t };
                for s in (0..sp.b).rev() {
                    self.backward::<B>(s, &mut v, &mut tmp);
                }
            },
            || {
                let mut tmp = Vec::new();
                let mut v = View { own: &mut *xb, own0: sp.rows_b, far: xt, far0: sp.rows_t };
                for s in (sp.b..sp.t).rev() {
                    self.backward::<B>(s, &mut v, &mut tmp);
                }
            },
        );
    }

    /// Supernode `s`: its first column, its width, the rows below its diagonal block and its
    /// values ((w + p) × w, by columns).
    fn node(&self, s: usize) -> (usize, usize, &'a [usize], &'a [f64]) {
        let c0 = self.sym.supernode_begin()[s];
        let w = self.sym.supernode_end()[s] - c0;
        let pat = self.sym.supernode(s).pattern();
        let ptr = self.sym.col_ptr_for_val();
        (c0, w, pat, &self.values[ptr[s]..ptr[s + 1]])
    }

    /// Forward step of supernode `s`: solve its diagonal block, then subtract its columns'
    /// contribution from the rows below (in `v.own`, or beyond it in `v.far`).
    fn forward<const B: usize>(&self, s: usize, v: &mut View<'_, &mut [f64]>, tmp: &mut Vec<f64>) {
        let (c0, w, pat, l) = self.node(s);
        let ld = w + pat.len();
        let p = pat.len();
        let (head, tail) = v.own.split_at_mut((c0 + w - v.own0) * B);
        let top = &mut head[(c0 - v.own0) * B..];
        if w * w > DENSE_ENTRIES {
            let lt = MatRef::from_column_major_slice_with_stride(l, w, w, ld);
            solve_unit_lower_triangular_in_place(lt, MatMut::from_row_major_slice_mut(top, w, B), Par::Seq);
        } else {
            for j in 0..w {
                let (done, rest) = top.split_at_mut((j + 1) * B);
                let xj: &[f64; B] = done[j * B..].try_into().expect("row");
                let col = &l[j * ld + j + 1..j * ld + w];
                for (row, &a) in rest.chunks_exact_mut(B).zip(col) {
                    axpy::<B>(row, -a, xj);
                }
            }
        }
        if p == 0 {
            return;
        }
        tmp.clear();
        tmp.resize(p * B, 0.0);
        if w * p > DENSE_ENTRIES {
            let lb = MatRef::from_column_major_slice_with_stride(&l[w..], p, w, ld);
            let xt = MatRef::from_row_major_slice(&*top, w, B);
            matmul(MatMut::from_row_major_slice_mut(tmp, p, B), Accum::Replace, lb, xt, 1.0, Par::Seq);
        } else {
            for j in 0..w {
                let xj: &[f64; B] = top[j * B..(j + 1) * B].try_into().expect("row");
                let col = &l[j * ld + w..(j + 1) * ld];
                for (row, &a) in tmp.chunks_exact_mut(B).zip(col) {
                    axpy::<B>(row, a, xj);
                }
            }
        }
        let base = c0 + w;
        let own_end = v.own0 + head.len() / B + tail.len() / B;
        for (&r, t) in pat.iter().zip(tmp.chunks_exact(B)) {
            let row = if r < own_end {
                &mut tail[(r - base) * B..(r - base + 1) * B]
            } else {
                &mut v.far[(r - v.far0) * B..(r - v.far0 + 1) * B]
            };
            axpy::<B>(row, -1.0, t.try_into().expect("row"));
        }
    }

    /// x ← D⁻¹ x on the columns of supernodes `range` (`x` holds rows `x0..`).
    fn diagonal<const B: usize>(&self, range: std::ops::Range<usize>, x: &mut [f64], x0: usize) {
        for s in range {
            let (c0, w, pat, l) = self.node(s);
            let ld = w + pat.len();
            for j in 0..w {
                let d = 1.0 / l[j * ld + j];
                for o in &mut x[(c0 + j - x0) * B..(c0 + j - x0 + 1) * B] {
                    *o *= d;
                }
            }
        }
    }

    /// Backward step of supernode `s`: subtract the rows below (already solved; in `v.own`
    /// or beyond it in `v.far`) from its columns, then solve its diagonal block transposed.
    fn backward<const B: usize>(&self, s: usize, v: &mut View<'_, &[f64]>, tmp: &mut Vec<f64>) {
        let (c0, w, pat, l) = self.node(s);
        let ld = w + pat.len();
        let p = pat.len();
        let (head, tail) = v.own.split_at_mut((c0 + w - v.own0) * B);
        let own_end = v.own0 + (head.len() + tail.len()) / B;
        let top = &mut head[(c0 - v.own0) * B..];
        if p > 0 {
            let base = c0 + w;
            tmp.clear();
            for &r in pat {
                let row = if r < own_end {
                    &tail[(r - base) * B..(r - base + 1) * B]
                } else {
                    &v.far[(r - v.far0) * B..(r - v.far0 + 1) * B]
                };
                tmp.extend_from_slice(row);
            }
            if w * p > DENSE_ENTRIES {
                let lb = MatRef::from_column_major_slice_with_stride(&l[w..], p, w, ld);
                let xb = MatRef::from_row_major_slice(&tmp[..], p, B);
                matmul(MatMut::from_row_major_slice_mut(top, w, B), Accum::Add, lb.transpose(), xb, -1.0, Par::Seq);
            } else {
                for j in 0..w {
                    let col = &l[j * ld + w..(j + 1) * ld];
                    let mut acc = [0.0; B];
                    for (row, &a) in tmp.chunks_exact(B).zip(col) {
                        axpy::<B>(&mut acc, a, row.try_into().expect("row"));
                    }
                    axpy::<B>(&mut top[j * B..(j + 1) * B], -1.0, &acc);
                }
            }
        }
        if w * w > DENSE_ENTRIES {
            let lt = MatRef::from_column_major_slice_with_stride(l, w, w, ld);
            solve_unit_upper_triangular_in_place(lt.transpose(), MatMut::from_row_major_slice_mut(top, w, B), Par::Seq);
        } else {
            for j in (0..w).rev() {
                let (left, right) = top.split_at_mut((j + 1) * B);
                let col = &l[j * ld + j + 1..j * ld + w];
                let mut acc = [0.0; B];
                for (row, &a) in right.chunks_exact(B).zip(col) {
                    axpy::<B>(&mut acc, a, row.try_into().expect("row"));
                }
                axpy::<B>(&mut left[j * B..], -1.0, &acc);
            }
        }
    }
}

/// Cuts the elimination tree of `sym` in two sets of whole subtrees of about equal work (the
/// factor's values) and the part above them, or `None` if the supernodes are not in
/// postorder, only one thread is available, or no cut leaves each half a quarter of the work.
fn split(sym: &SymbolicSupernodalCholesky<usize>) -> Option<Split> {
    let ns = sym.n_supernodes();
    if ns < 4 || rayon::current_num_threads() < 2 {
        return None;
    }
    let begin = sym.supernode_begin();
    let end = sym.supernode_end();
    let mut owner = vec![0usize; sym.nrows()];
    for s in 0..ns {
        owner[begin[s]..end[s]].fill(s);
    }
    // The parent is the supernode of the first row below the diagonal block.
    let parent: Vec<usize> =
        (0..ns).map(|s| sym.supernode(s).pattern().first().map_or(usize::MAX, |&r| owner[r])).collect();
    drop(owner);
    let ptr = sym.col_ptr_for_val();
    // Subtree sizes and work; postorder means each subtree is the range ending at its root.
    let mut count = vec![1usize; ns];
    let mut work: Vec<usize> = (0..ns).map(|s| ptr[s + 1] - ptr[s]).collect();
    let mut first: Vec<usize> = (0..ns).collect();
    for s in 0..ns {
        let p = parent[s];
        if p == usize::MAX {
            continue;
        }
        if p <= s {
            return None;
        }
        count[p] += count[s];
        work[p] += work[s];
        first[p] = first[p].min(first[s]);
    }
    if (0..ns).any(|s| s + 1 - first[s] != count[s]) {
        return None;
    }
    let mut children = vec![Vec::new(); ns];
    let mut roots = Vec::new();
    for s in 0..ns {
        match parent[s] {
            usize::MAX => roots.push(s),
            p => children[p].push(s),
        }
    }
    // From the root down the chain of single children to the first branching; the top is the
    // chain (for a forest, nothing).
    let kids = if roots.len() > 1 {
        roots
    } else {
        let mut node = *roots.first()?;
        while children[node].len() == 1 {
            node = children[node][0];
        }
        std::mem::take(&mut children[node])
    };
    // In postorder (checked above) the kids' subtrees are consecutive ranges from supernode
    // 0, and the top follows them.
    let last = *kids.last()?;
    if kids.len() < 2 {
        return None;
    }
    let total: usize = kids.iter().map(|&c| work[c]).sum();
    // Cut after child i: the first half is the subtrees of kids[..=i].
    let mut acc = 0;
    let mut best: Option<(usize, usize)> = None;
    for (i, &c) in kids.iter().enumerate().take(kids.len() - 1) {
        acc += work[c];
        let worse = acc.max(total - acc);
        if best.is_none_or(|(_, w)| worse < w) {
            best = Some((i, worse));
        }
    }
    let (i, worse) = best?;
    if worse * 4 > total * 3 {
        return None;
    }
    let b = kids[i] + 1;
    let top = last + 1;
    Some(Split { b, t: top, rows_b: begin[b], rows_t: if top < ns { begin[top] } else { sym.nrows() } })
}

/// y ← y + a·x on one row of `B` values.
#[inline(always)]
fn axpy<const B: usize>(y: &mut [f64], a: f64, x: &[f64; B]) {
    let y: &mut [f64; B] = y.try_into().expect("row");
    for k in 0..B {
        y[k] += a * x[k];
    }
}
