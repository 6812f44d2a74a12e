//! Times one shift-invert operator application, (K − σM)⁻¹ on a block of right-hand sides,
//! with faer's supernodal LDLᵀ solve (by columns) and with [`fem::trisolve::RowSolver`] (by
//! rows, the elimination tree's two halves on the thread pool), and checks that both give
//! the same answer.
//!
//! `cargo bench -p struck-fem --bench trisolve_timing [-- RESOLUTION [BLOCK [REPS]]]`: a glass
//! bowl (R 80 mm, wall 4 mm; resolution 44 ≈ 200k DOFs by default), σ near its 100th mode.

use std::time::Instant;

use faer::Mat;
use fem::{assembly, eigen::Factor, mesh_shape, Material, Shape};

fn main() {
    let args: Vec<usize> = std::env::args().skip(1).filter_map(|a| a.parse().ok()).collect();
    let res = args.first().copied().unwrap_or(44);
    let b = args.get(1).copied().unwrap_or(8);
    let reps = args.get(2).copied().unwrap_or(10).max(1);
    let mesh = mesh_shape(&Shape::Bowl { radius: 0.08, wall: 0.004 }, res).expect("mesh");
    let sys = assembly::assemble(&mesh, &Material::GLASS).expect("assembly");
    let n = sys.n;
    let t = Instant::now();
    let factor = Factor::at(&sys, 2.0e10).expect("factor");
    let factor_s = t.elapsed().as_secs_f64();
    let mut s = 0x2545_F491_4F6C_DD1Du64;
    let x0 = Mat::from_fn(n, b, |_, _| {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    });
    let time = |f: &dyn Fn(&mut Mat<f64>)| {
        let mut x = x0.clone();
        let t = Instant::now();
        for _ in 0..reps {
            x.copy_from(&x0);
            f(&mut x);
        }
        (x, t.elapsed().as_secs_f64() / reps as f64)
    };
    let (xf, faer_s) = time(&|x| factor.apply_inverse_faer(x.as_mut()));
    let (xr, rows_s) = time(&|x| factor.apply_inverse(x.as_mut()));
    let split = factor.row_solver().is_some_and(|(r, _, _)| r.is_split());
    let diff = (&xr - &xf).norm_max() / xf.norm_max();
    println!(
        "bowl res {res}: {n} DOFs, factor in {factor_s:.2} s; block {b}: faer {:.1} ms, rows {:.1} ms ({:.2}×, tree split: {split}); max difference {diff:.1e}",
        faer_s * 1e3,
        rows_s * 1e3,
        faer_s / rows_s,
    );
    assert!(diff < 1e-8, "the two solves differ");
}
