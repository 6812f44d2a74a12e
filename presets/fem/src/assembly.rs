//! Sparse assembly of the global stiffness K and consistent mass M on one shared pattern.
//!
//! Storage: compressed sparse columns holding both triangles (rows sorted), DOF 3·node + axis.

use super::element::{lame, ElementKit};
use super::mesh::TetMesh;
use super::{FemError, Material};

/// A symmetric sparse pattern (both triangles stored) with K and M values on it.
#[derive(Clone)]
pub struct System {
    /// Number of DOFs (3 per node).
    pub n: usize,
    /// Column pointers (n + 1).
    pub col_ptr: Vec<usize>,
    /// Row indices, sorted within each column.
    pub row_idx: Vec<usize>,
    /// Stiffness values, N/m.
    pub k: Vec<f64>,
    /// Mass values, kg.
    pub m: Vec<f64>,
}

/// Assembles K and M for `mesh` and `material`.
///
/// # Errors
/// [`FemError::Mesh`] if an element is inverted or degenerate.
pub fn assemble(mesh: &TetMesh, material: &Material) -> Result<System, FemError> {
    let nn = mesh.nodes.len();
    // Node adjacency from the elements.
    let mut adj: Vec<Vec<u32>> = vec![Vec::new(); nn];
    for t in &mesh.tets {
        for &a in t {
            adj[a as usize].extend_from_slice(t);
        }
    }
    for a in adj.iter_mut() {
        a.sort_unstable();
        a.dedup();
    }
    let n = 3 * nn;
    let mut col_ptr = Vec::with_capacity(n + 1);
    col_ptr.push(0usize);
    // Start of each node's first column.
    let mut node_base = vec![0usize; nn];
    for (a, nb) in adj.iter().enumerate() {
        node_base[a] = *col_ptr.last().unwrap_or(&0);
        for _ in 0..3 {
            let last = *col_ptr.last().unwrap_or(&0);
            col_ptr.push(last + 3 * nb.len());
        }
    }
    let nnz = col_ptr[n];
    let mut row_idx = Vec::with_capacity(nnz);
    for nb in &adj {
        for _ in 0..3 {
            for &b in nb {
                let b = b as usize;
                row_idx.extend_from_slice(&[3 * b, 3 * b + 1, 3 * b + 2]);
            }
        }
    }
    let mut k = vec![0.0; nnz];
    let mut m = vec![0.0; nnz];
    let (lambda, mu) = lame(material.young, material.poisson);
    let kit = ElementKit::new();
    let mut ke = [[0.0; 30]; 30];
    let mut me = [[0.0; 10]; 10];
    for (e, t) in mesh.tets.iter().enumerate() {
        let x: [[f64; 3]; 10] = std::array::from_fn(|i| mesh.nodes[t[i] as usize]);
        if kit.matrices(&x, lambda, mu, material.density, &mut ke, &mut me).is_none() {
            return Err(FemError::Mesh(format!(
                "element {e} is inverted or degenerate (det J <= 0); check the mesh or use a finer resolution"
            )));
        }
        // Columns of node a; position of node b within a's neighbour list.
        for (ia, &a) in t.iter().enumerate() {
            let a = a as usize;
            let nb = &adj[a];
            let stride = 3 * nb.len();
            for (ib, &b) in t.iter().enumerate() {
                let pos = match nb.binary_search(&b) {
                    Ok(p) => p,
                    Err(_) => unreachable_pattern(),
                };
                for i in 0..3 {
                    // Column 3a+i, rows 3b..3b+3.
                    let base = node_base[a] + i * stride + 3 * pos;
                    for j in 0..3 {
                        k[base + j] += ke[3 * ib + j][3 * ia + i];
                    }
                    m[base + i] += me[ib][ia];
                }
            }
        }
    }
    Ok(System { n, col_ptr, row_idx, k, m })
}

// The pattern was built from the same element lists, so every (a, b) pair is present.
fn unreachable_pattern() -> usize {
    panic!("internal error: FEM sparsity pattern is missing an element pair")
}

/// y = A x for a symmetric matrix in [`System`] storage with values `val`, applied to `b`
/// vectors stored row-major (`x[r * b + k]`). Parallel over columns on rayon's pool (the
/// threads faer's factorisations use; none is spawned per product).
pub fn sym_matvec_rows(sys: &System, val: &[f64], x: &[f64], y: &mut [f64], b: usize) {
    sym_csc_matvec_rows(&sys.col_ptr, &sys.row_idx, val, x, y, b);
}

/// y = A x for a symmetric matrix in compressed columns (both triangles, `col_ptr`,
/// `row_idx`, `val`), applied to `b` vectors stored row-major, as [`sym_matvec_rows`].
pub fn sym_csc_matvec_rows(col_ptr: &[usize], row_idx: &[usize], val: &[f64], x: &[f64], y: &mut [f64], b: usize) {
    use rayon::prelude::*;
    let n = col_ptr.len() - 1;
    let threads = rayon::current_num_threads().clamp(1, 8);
    let chunk = n.div_ceil(threads).max(1);
    y.par_chunks_mut(chunk * b).enumerate().for_each(|(ci, yc)| {
        let c0 = ci * chunk;
        for (lc, out) in yc.chunks_mut(b).enumerate() {
            let c = c0 + lc;
            out.fill(0.0);
            // Symmetric: row c of A·x = column c dotted with x.
            for p in col_ptr[c]..col_ptr[c + 1] {
                let v = val[p];
                let r = row_idx[p];
                for (o, &xv) in out.iter_mut().zip(&x[r * b..r * b + b]) {
                    *o += v * xv;
                }
            }
        }
    });
}
