//! Fill-reducing orderings of the stiffness matrix: nested dissection by METIS (Karypis &
//! Kumar 1998, "A fast and high quality multilevel scheme for partitioning irregular graphs",
//! SIAM J. Sci. Comput. 20(1); George 1973, "Nested dissection of a regular finite element
//! mesh"), computed on the node graph (three DOFs per node share one row pattern) and
//! expanded to the DOFs. On 3-D meshes nested dissection fills the factor less than the
//! minimum-degree ordering faer computes by default (AMD), and much less on the large ones.
//!
//! METIS is the C library, Apache-2.0, compiled from the vendored sources of the `metis-sys`
//! crate (a C compiler is all it needs).

/// Smallest node graph worth a nested dissection: below it AMD is as good and METIS's set-up
/// is not worth it.
pub const MIN_NODES: usize = 2_000;

/// Serialises the calls into METIS (see [`nested_dissection`]).
static METIS: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// The nested-dissection order of a graph of `adjacency.len()` nodes (each node's neighbours,
/// itself excluded, both directions present): `perm[new] = old`. `None` if METIS fails or
/// the graph is too large for its 32-bit indices.
pub fn nested_dissection(adjacency: &[Vec<u32>]) -> Option<Vec<usize>> {
    let nn = adjacency.len();
    let edges: usize = adjacency.iter().map(Vec::len).sum();
    if nn == 0 || edges >= i32::MAX as usize {
        return None;
    }
    let mut xadj: Vec<i32> = Vec::with_capacity(nn + 1);
    let mut adjncy: Vec<i32> = Vec::with_capacity(edges);
    xadj.push(0);
    for (a, nb) in adjacency.iter().enumerate() {
        adjncy.extend(nb.iter().filter(|&&b| b as usize != a).map(|&b| b as i32));
        xadj.push(adjncy.len() as i32);
    }
    let mut n = nn as i32;
    let mut options = [0i32; metis_sys::METIS_NOPTIONS as usize];
    let mut perm = vec![0i32; nn];
    let mut iperm = vec![0i32; nn];
    // One METIS call at a time in the process: its random number generator (GKlib's
    // Mersenne twister, seeded by every call) is a global C array, so two calls at once (two
    // builds, or tests in parallel) interleave their draws and get other orders (a 24³ grid
    // then filled 0.87 of AMD's factor instead of 0.80) and race on the array.
    let one_at_a_time = METIS.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    // SAFETY: the options array has METIS_NOPTIONS entries; xadj has n + 1 entries, adjncy
    // xadj[n] entries all in 0..n; perm and iperm n entries; vwgt is optional (null). METIS
    // only reads the graph and writes perm/iperm.
    let status = unsafe {
        metis_sys::METIS_SetDefaultOptions(options.as_mut_ptr());
        options[metis_sys::moptions_et_METIS_OPTION_NUMBERING as usize] = 0;
        metis_sys::METIS_NodeND(
            &mut n,
            xadj.as_mut_ptr(),
            adjncy.as_mut_ptr(),
            std::ptr::null_mut(),
            options.as_mut_ptr(),
            perm.as_mut_ptr(),
            iperm.as_mut_ptr(),
        )
    };
    drop(one_at_a_time);
    if status != metis_sys::rstatus_et_METIS_OK {
        return None;
    }
    let perm: Vec<usize> = perm.into_iter().map(|p| p as usize).collect();
    // A permutation, or nothing.
    let mut seen = vec![false; nn];
    for &p in &perm {
        if p >= nn || std::mem::replace(&mut seen[p], true) {
            return None;
        }
    }
    Some(postorder(adjacency, perm))
}

/// The order `perm` (`perm[new] = old`) with its elimination tree put in postorder: the same
/// nonzeros in L, but every subtree of the tree a contiguous range of columns ending at its
/// root (faer's grouping of columns into supernodes, and so the stored factor, can differ by
/// a few per cent: 109.4M → 111.1M values on a 197k-DOF bowl) (Liu 1990, "The role of elimination trees in sparse factorization",
/// SIAM J. Matrix Anal. Appl. 11(1), §3–4). Nested dissection alone does not give that when
/// a half is in pieces; [`crate::trisolve`] needs it to solve the two halves apart.
pub fn postorder(adjacency: &[Vec<u32>], perm: Vec<usize>) -> Vec<usize> {
    const NONE: usize = usize::MAX;
    let n = perm.len();
    let mut inv = vec![0usize; n];
    for (new, &old) in perm.iter().enumerate() {
        inv[old] = new;
    }
    // Elimination tree of the permuted graph (Liu's algorithm with path compression).
    let mut parent = vec![NONE; n];
    let mut ancestor = vec![NONE; n];
    for j in 0..n {
        for &b in &adjacency[perm[j]] {
            let mut r = inv[b as usize];
            if r >= j {
                continue;
            }
            while ancestor[r] != NONE && ancestor[r] != j {
                let next = ancestor[r];
                ancestor[r] = j;
                r = next;
            }
            if ancestor[r] == NONE {
                ancestor[r] = j;
                parent[r] = j;
            }
        }
    }
    // Children in increasing order (a linked list built backwards), then a depth-first walk.
    let mut head = vec![NONE; n];
    let mut next = vec![NONE; n];
    for j in (0..n).rev() {
        if parent[j] != NONE {
            next[j] = head[parent[j]];
            head[parent[j]] = j;
        }
    }
    let mut order = Vec::with_capacity(n);
    let mut stack = Vec::new();
    for root in (0..n).filter(|&j| parent[j] == NONE) {
        stack.push(root);
        while let Some(&top) = stack.last() {
            let child = head[top];
            if child == NONE {
                order.push(top);
                stack.pop();
            } else {
                head[top] = next[child];
                stack.push(child);
            }
        }
    }
    order.into_iter().map(|j| perm[j]).collect()
}

/// A permutation (`fwd[new] = old`) with its inverse (`inv[old] = new`), as faer takes it.
pub fn with_inverse(fwd: Vec<usize>) -> (Vec<usize>, Vec<usize>) {
    let mut inv = vec![0; fwd.len()];
    for (new, &old) in fwd.iter().enumerate() {
        inv[old] = new;
    }
    (fwd, inv)
}

/// The DOF permutation (`fwd[new] = old`, and its inverse) of a node order, three DOFs per
/// node kept together.
pub fn dof_permutation(node_perm: &[usize]) -> (Vec<usize>, Vec<usize>) {
    with_inverse(node_perm.iter().flat_map(|&p| [3 * p, 3 * p + 1, 3 * p + 2]).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    use faer::perm::PermRef;
    use faer::sparse::linalg::cholesky::{
        factorize_symbolic_cholesky, CholeskySymbolicParams, SymbolicCholeskyRaw, SymmetricOrdering,
    };
    use faer::sparse::linalg::SupernodalThreshold;
    use faer::sparse::SymbolicSparseColMatRef;
    use faer::Side;

    /// A 3-D grid graph (7-point stencil), `w`³ nodes.
    fn grid(w: usize) -> Vec<Vec<u32>> {
        let id = |x: usize, y: usize, z: usize| ((z * w + y) * w + x) as u32;
        let mut adj = vec![Vec::new(); w * w * w];
        for z in 0..w {
            for y in 0..w {
                for x in 0..w {
                    let a = id(x, y, z);
                    for b in [
                        (x + 1 < w).then(|| id(x + 1, y, z)),
                        (y + 1 < w).then(|| id(x, y + 1, z)),
                        (z + 1 < w).then(|| id(x, y, z + 1)),
                    ]
                    .into_iter()
                    .flatten()
                    {
                        adj[a as usize].push(b);
                        adj[b as usize].push(a);
                    }
                }
            }
        }
        adj
    }

    /// Entries of the Cholesky factor of the graph's matrix (self loops added) under an
    /// ordering.
    fn factor_len(adj: &[Vec<u32>], ordering: SymmetricOrdering<'_, usize>) -> usize {
        let n = adj.len();
        let (col_ptr, rows) = pattern(adj);
        let pattern = SymbolicSparseColMatRef::new_checked(n, n, &col_ptr, None, &rows);
        factorize_symbolic_cholesky(pattern, Side::Lower, ordering, Default::default()).unwrap().len_val()
    }

    /// On a 3-D grid (the graph of a solid mesh) nested dissection fills the factor less
    /// than faer's AMD, and its DOF expansion is a permutation that keeps each node's three
    /// DOFs together.
    #[test]
    fn nested_dissection_fills_a_3d_grid_less_than_minimum_degree() {
        let adj = grid(24);
        let perm = nested_dissection(&adj).expect("METIS orders a grid");
        let (fwd, inv) = with_inverse(perm.clone());
        let nd = factor_len(&adj, SymmetricOrdering::Custom(PermRef::new_checked(&fwd, &inv, perm.len())));
        let amd = factor_len(&adj, SymmetricOrdering::Amd);
        println!("24^3 grid: factor entries nested dissection {nd}, AMD {amd}");
        assert!((nd as f64) < 0.85 * amd as f64, "nested dissection {nd} vs AMD {amd}");
        let (fwd, inv) = dof_permutation(&perm);
        let mut sorted = fwd.clone();
        sorted.sort_unstable();
        assert!(sorted.iter().enumerate().all(|(i, &d)| i == d), "not a permutation of the DOFs");
        assert!(fwd.iter().enumerate().all(|(new, &old)| inv[old] == new));
        assert_eq!(fwd[..3], [3 * perm[0], 3 * perm[0] + 1, 3 * perm[0] + 2]);
    }

    /// The graph's pattern (self loops added), compressed columns.
    fn pattern(adj: &[Vec<u32>]) -> (Vec<usize>, Vec<usize>) {
        let mut col_ptr = vec![0usize];
        let mut rows = Vec::new();
        for (a, nb) in adj.iter().enumerate() {
            let mut c: Vec<usize> = nb.iter().map(|&b| b as usize).chain([a]).collect();
            c.sort_unstable();
            rows.extend(c);
            col_ptr.push(rows.len());
        }
        (col_ptr, rows)
    }

    /// Entries of the (simplicial) Cholesky factor under `order`, and whether every subtree
    /// of its elimination tree is a contiguous range of columns, the tree read off faer's
    /// factor pattern (a column's parent is its first row below the diagonal).
    fn fill_and_contiguity(adj: &[Vec<u32>], order: &[usize]) -> (usize, bool) {
        let n = adj.len();
        let (col_ptr, rows) = pattern(adj);
        let pattern = SymbolicSparseColMatRef::new_checked(n, n, &col_ptr, None, &rows);
        let (fwd, inv) = with_inverse(order.to_vec());
        let params = CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SIMPLICIAL,
            ..Default::default()
        };
        let ord = SymmetricOrdering::Custom(PermRef::new_checked(&fwd, &inv, n));
        let sym = factorize_symbolic_cholesky(pattern, Side::Lower, ord, params).unwrap();
        let SymbolicCholeskyRaw::Simplicial(s) = sym.raw() else { panic!("not simplicial") };
        let l = s.factor();
        let parent: Vec<Option<usize>> = (0..n)
            .map(|j| l.row_idx()[l.col_ptr()[j]..l.col_ptr()[j + 1]].iter().copied().filter(|&r| r > j).min())
            .collect();
        let mut size = vec![1usize; n];
        let mut first: Vec<usize> = (0..n).collect();
        for j in 0..n {
            if let Some(p) = parent[j] {
                size[p] += size[j];
                first[p] = first[p].min(first[j]);
            }
        }
        (sym.len_val(), (0..n).all(|j| j + 1 - first[j] == size[j]))
    }

    /// Putting an order's elimination tree in postorder keeps the factor's fill and makes
    /// every subtree contiguous (what the two-thread solve needs), also for an order far
    /// from one; nested dissection's order comes out in postorder.
    #[test]
    fn postorder_keeps_the_fill_and_makes_subtrees_contiguous() {
        let adj = grid(12);
        let n = adj.len();
        // 577 is prime, so i·577 mod 1728 visits every node: a scrambled order.
        let scrambled: Vec<usize> = (0..n).map(|i| (i * 577) % n).collect();
        let (fill, contiguous) = fill_and_contiguity(&adj, &scrambled);
        assert!(!contiguous, "the scrambled order should not be a postorder (the check would prove nothing)");
        let post = postorder(&adj, scrambled);
        let mut sorted = post.clone();
        sorted.sort_unstable();
        assert!(sorted.iter().enumerate().all(|(i, &p)| i == p), "not a permutation");
        let (fill_post, contiguous) = fill_and_contiguity(&adj, &post);
        assert_eq!(fill_post, fill, "postorder changed the fill");
        assert!(contiguous, "subtrees not contiguous after postorder");
        let nd = nested_dissection(&adj).unwrap();
        assert!(fill_and_contiguity(&adj, &nd).1, "nested dissection not in postorder");
    }
}
