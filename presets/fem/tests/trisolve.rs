//! The shift-invert solves of the bank builder (`fem::trisolve`, by rows, the elimination
//! tree's halves on two threads) against the matrix itself: the residual of K − σM applied
//! to the answer, computed from the assembled K and M, not from the factor.

use faer::Mat;
use fem::{assembly, eigen::Factor, Material, Shape};

/// max |(K − σM) x − b| / (max |K − σM| · max |x|) for the columns of `x` and `b`.
fn residual(sys: &assembly::System, sigma: f64, x: &Mat<f64>, b: &Mat<f64>) -> f64 {
    let (n, k) = (x.nrows(), x.ncols());
    let xr: Vec<f64> = (0..n).flat_map(|i| (0..k).map(move |c| (i, c))).map(|(i, c)| x[(i, c)]).collect();
    let mut kx = vec![0.0; n * k];
    let mut mx = vec![0.0; n * k];
    assembly::sym_matvec_rows(sys, &sys.k, &xr, &mut kx, k);
    assembly::sym_matvec_rows(sys, &sys.m, &xr, &mut mx, k);
    let a_max = sys.k.iter().zip(&sys.m).map(|(k, m)| (k - sigma * m).abs()).fold(0.0, f64::max);
    let x_max = xr.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    let mut worst = 0.0f64;
    for i in 0..n {
        for c in 0..k {
            worst = worst.max((kx[i * k + c] - sigma * mx[i * k + c] - b[(i, c)]).abs());
        }
    }
    worst / (a_max * x_max)
}

#[test]
fn row_solves_satisfy_the_shifted_system() {
    // A bowl big enough for the nested-dissection ordering (≥ 2000 nodes), shifted into its
    // spectrum (K − σM indefinite, as every shift after the first is).
    let mesh = fem::mesh_shape(&Shape::Bowl { radius: 0.08, wall: 0.004 }, 14).unwrap();
    let sys = fem::assemble(&mesh, &Material::GLASS).unwrap();
    assert!(sys.n / 3 >= fem::ordering::MIN_NODES, "{} nodes", sys.n / 3);
    let sigma = 1.0e10;
    // Two threads whatever the machine (the split is only taken with two or more).
    let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
    pool.install(|| solves_in_pool(&sys, sigma));
}

fn solves_in_pool(sys: &assembly::System, sigma: f64) {
    let factor = Factor::at(sys, sigma).unwrap();
    assert!(factor.negative_pivots() > 20, "σ should lie inside the spectrum");
    let (solver, _, _) = factor.row_solver().expect("supernodal, ordered");
    assert!(solver.is_split(), "the postordered nested dissection should split into two halves");
    let mut s = 0x9E37_79B9_7F4A_7C15u64;
    // Block 3 is not a row-solver size: it checks the fallback to faer's solve.
    for b in [3, 4, 8, 16] {
        let rhs = Mat::from_fn(sys.n, b, |_, _| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        });
        let mut x = rhs.clone();
        factor.apply_inverse(x.as_mut());
        let r = residual(sys, sigma, &x, &rhs);
        let mut xf = rhs.clone();
        factor.apply_inverse_faer(xf.as_mut());
        let rf = residual(sys, sigma, &xf, &rhs);
        let diff = (&x - &xf).norm_max() / xf.norm_max();
        println!("{} DOFs, block {b}: residual {r:.1e} (faer {rf:.1e}), difference from faer {diff:.1e}", sys.n);
        assert!(r < 1e-13, "block {b}: residual {r:e}");
        assert!(r < 10.0 * rf.max(1e-16), "block {b}: residual {r:e} against faer's {rf:e}");
    }
    // The split solve and the one-thread solve in supernode order agree.
    let b = 8;
    let mut x1 = vec![0.0; sys.n * b];
    for (i, v) in x1.iter_mut().enumerate() {
        *v = ((i * 7919) % 1009) as f64 / 1009.0 - 0.5;
    }
    let mut x2 = x1.clone();
    solver.solve_permuted(&mut x1, b);
    solver.solve_permuted_sequential(&mut x2, b);
    let scale = x2.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    let worst = x1.iter().zip(&x2).fold(0.0f64, |a, (p, q)| a.max((p - q).abs()));
    assert!(worst <= 1e-10 * scale, "split and sequential solves differ by {worst:e} (scale {scale:e})");
}
