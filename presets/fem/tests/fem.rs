//! Validation of the FEM bank builder against beam and plate theory.
//!
//! Meshes are coarse so the whole file runs in seconds in release mode.

use fem::{self, BuildOptions, Material, Modes, Shape};

const BAR: Shape = Shape::Bar { length: 0.5, width: 0.015, thickness: 0.005 };
const BAR_RES: usize = 50;

fn quiet(_: &str, _: f32) {}

/// Euler–Bernoulli free–free βₙL (Blevins 1979 Table 8-1).
const BETA_L: [f64; 4] = [4.730_040_745, 7.853_204_624, 10.995_607_84, 14.137_165_49];

/// Indices of the bending modes in the thin (z) direction: displacement mostly along z,
/// little along y (torsion moves y by ~(t/w)² of z; bending in z only through Poisson).
fn thin_bending(modes: &Modes) -> Vec<usize> {
    (0..modes.lambdas.len())
        .filter(|&m| {
            let v = modes.mode(m);
            let (mut ux, mut uy, mut uz) = (0.0, 0.0, 0.0);
            for n in 0..v.len() / 3 {
                ux += v[3 * n] * v[3 * n];
                uy += v[3 * n + 1] * v[3 * n + 1];
                uz += v[3 * n + 2] * v[3 * n + 2];
            }
            uz / (ux + uy + uz) > 0.9 && uy / uz < 0.02
        })
        .collect()
}

fn bar_modes(res: usize, n: usize) -> (fem::TetMesh, Modes) {
    let mesh = fem::mesh_shape(&BAR, res).unwrap();
    let opts = BuildOptions { max_modes: n, resolution: res, ..BuildOptions::default() };
    let modes = fem::analyse(&mesh, &Material::STEEL, &opts, &quiet).unwrap();
    (mesh, modes)
}

fn euler_bernoulli_hz(n: usize) -> f64 {
    let Shape::Bar { length, thickness, .. } = BAR else { unreachable!() };
    let m = Material::STEEL;
    // f = (βL)²/(2πL²)·sqrt(EI/(ρA)), I/A = t²/12 for bending across the thickness.
    BETA_L[n].powi(2) / (2.0 * std::f64::consts::PI * length * length)
        * (m.young * thickness * thickness / (12.0 * m.density)).sqrt()
}

#[test]
fn bar_bending_matches_euler_bernoulli() {
    let (mesh, modes) = bar_modes(BAR_RES, 12);
    let f = modes.frequencies_hz();
    let bend = thin_bending(&modes);
    println!("bar: {} nodes, {} tets, {} dofs, {:.2} s", mesh.nodes.len(), mesh.tets.len(), modes.dofs, modes.seconds);
    println!("all modes (Hz): {:?}", f.iter().map(|x| (x * 10.0).round() / 10.0).collect::<Vec<_>>());
    println!("rigid: {:?}", modes.rigid_lambdas);
    assert!(bend.len() >= 4, "found only {} thin-direction bending modes", bend.len());
    let f1 = f[bend[0]];
    let ratios = [1.0, 2.757, 5.404, 8.933];
    for k in 0..4 {
        let fe = euler_bernoulli_hz(k);
        let fk = f[bend[k]];
        println!(
            "bend {}: FEM {:.2} Hz, Euler-Bernoulli {:.2} Hz, err {:+.3} %, ratio {:.4} vs {:.3}",
            k + 1,
            fk,
            fe,
            100.0 * (fk / fe - 1.0),
            fk / f1,
            ratios[k]
        );
        assert!((fk / fe - 1.0).abs() < 0.02, "bend {} off by {:.2} %", k + 1, 100.0 * (fk / fe - 1.0));
        assert!((fk / f1 / ratios[k] - 1.0).abs() < 0.02);
    }
    assert_eq!(modes.rigid_lambdas.len(), 6);
    let l1 = modes.lambdas[0];
    for r in &modes.rigid_lambdas {
        assert!(r.abs() < 1e-6 * l1, "rigid eigenvalue {r} not near zero (λ1 = {l1})");
    }
}

#[test]
fn matrices_symmetric_mass_positive_modes_orthonormal() {
    let (mesh, modes) = bar_modes(20, 10);
    let sys = fem::assemble(&mesh, &Material::STEEL).unwrap();
    let n = sys.n;
    // Symmetry of K and M entry by entry (both triangles are stored).
    let get = |val: &[f64], r: usize, c: usize| -> f64 {
        let rows = &sys.row_idx[sys.col_ptr[c]..sys.col_ptr[c + 1]];
        rows.binary_search(&r).map(|p| val[sys.col_ptr[c] + p]).unwrap_or(0.0)
    };
    let (mut kmax, mut masym, mut kasym) = (0.0f64, 0.0f64, 0.0f64);
    for c in 0..n {
        for p in sys.col_ptr[c]..sys.col_ptr[c + 1] {
            let r = sys.row_idx[p];
            kmax = kmax.max(sys.k[p].abs());
            kasym = kasym.max((sys.k[p] - get(&sys.k, c, r)).abs());
            masym = masym.max((sys.m[p] - get(&sys.m, c, r)).abs());
        }
    }
    assert!(kasym <= 1e-12 * kmax, "K asymmetric by {kasym}");
    assert!(masym == 0.0, "M asymmetric by {masym}");
    // M positive definite: its Cholesky exists (faer) and xᵀMx > 0 for random x; total mass.
    let total: f64 = {
        // uᵀMu for a unit rigid translation in x = total mass.
        let mut u = vec![0.0; n];
        for i in (0..n).step_by(3) {
            u[i] = 1.0;
        }
        let mut y = vec![0.0; n];
        fem::assembly::sym_matvec_rows(&sys, &sys.m, &u, &mut y, 1);
        u.iter().zip(&y).map(|(a, b)| a * b).sum()
    };
    let expect = 0.5 * 0.015 * 0.005 * Material::STEEL.density;
    assert!((total / expect - 1.0).abs() < 1e-10, "mass {total} vs {expect}");
    let llt = {
        use faer::sparse::{SparseColMat, SymbolicSparseColMat};
        let sym = SymbolicSparseColMat::<usize>::new_checked(n, n, sys.col_ptr.clone(), None, sys.row_idx.clone());
        SparseColMat::<usize, f64>::new(sym, sys.m.clone()).sp_cholesky(faer::Side::Lower)
    };
    assert!(llt.is_ok(), "M is not positive definite");
    // Mass-orthonormality and K-diagonality of the modes.
    let nm = modes.lambdas.len();
    let mut worst_m = 0.0f64;
    let mut worst_k = 0.0f64;
    for i in 0..nm {
        let (mut mi, mut ki) = (vec![0.0; n], vec![0.0; n]);
        fem::assembly::sym_matvec_rows(&sys, &sys.m, modes.mode(i), &mut mi, 1);
        fem::assembly::sym_matvec_rows(&sys, &sys.k, modes.mode(i), &mut ki, 1);
        for j in 0..nm {
            let vj = modes.mode(j);
            let m: f64 = vj.iter().zip(&mi).map(|(a, b)| a * b).sum();
            let k: f64 = vj.iter().zip(&ki).map(|(a, b)| a * b).sum();
            let target = if i == j { 1.0 } else { 0.0 };
            worst_m = worst_m.max((m - target).abs());
            worst_k = worst_k.max((k - target * modes.lambdas[i]).abs() / modes.lambdas[nm - 1]);
        }
    }
    println!("max |ΦᵀMΦ − I| = {worst_m:.2e}, max |ΦᵀKΦ − Λ|/λmax = {worst_k:.2e}");
    assert!(worst_m < 1e-8, "modes not M-orthonormal: {worst_m}");
    assert!(worst_k < 1e-8, "modes not K-orthogonal: {worst_k}");
    // Exactly six rigid modes, far below the first elastic one.
    assert_eq!(modes.rigid_lambdas.len(), 6);
    assert!(modes.rigid_lambdas.iter().all(|r| r.abs() < 1e-6 * modes.lambdas[0]));
}

#[test]
fn bar_converges_when_refined() {
    let fe = euler_bernoulli_hz(3);
    let mut errs = Vec::new();
    for res in [12, 24, 48] {
        let (_, modes) = bar_modes(res, 10);
        let f = modes.frequencies_hz();
        let bend = thin_bending(&modes);
        let e = (f[bend[3]] / fe - 1.0).abs();
        println!("res {res}: bend 4 {:.2} Hz, error {:.4} %", f[bend[3]], 100.0 * e);
        errs.push(e);
    }
    assert!(errs[1] < errs[0] && errs[2] <= errs[1] + 2e-4, "no convergence: {errs:?}");
    assert!(errs[2] < 0.005);
}

#[test]
fn strike_at_a_mode_node_gives_near_zero_gain() {
    let (mesh, modes) = bar_modes(BAR_RES, 12);
    let bend = thin_bending(&modes);
    let Shape::Bar { length: l, width: w, thickness: t } = BAR else { unreachable!() };
    // Free–free beam nodes (Blevins 1979 Table 8-1): mode 1 at x/L = 0.2242, mode 2 at 0.5.
    // (The end point sits just inside the top face so the top face, not the end face, is hit.)
    let pts = [[0.2242 * l, 0.5 * w, t], [0.5 * l, 0.5 * w, t], [1e-4 * l, 0.5 * w, t], [0.1321 * l, 0.5 * w, t]];
    let g = fem::strike_gains(&mesh, &modes, &pts);
    let (b1, b2) = (bend[0], bend[1]);
    println!(
        "mode 1: node {:.3e}, end {:.3e}; mode 2: node {:.3e}, end {:.3e}",
        g[0][b1], g[2][b1], g[1][b2], g[2][b2]
    );
    assert!(g[0][b1].abs() < 0.01 * g[2][b1].abs());
    assert!(g[1][b2].abs() < 0.01 * g[2][b2].abs());
    assert!(g[3][b2].abs() < 0.01 * g[2][b2].abs());
    // And the centre is an antinode of mode 1 (gain about 0.6 of the end's, opposite sign).
    assert!((g[1][b1] / g[2][b1] + 0.607).abs() < 0.02, "{}", g[1][b1] / g[2][b1]);
}

#[test]
fn bar_bank_is_valid() {
    let opts = BuildOptions {
        max_modes: 16,
        max_freq_hz: None,
        resolution: 30,
        strike_points: 64,
        auto_resolution: false,
        accuracy: None,
    };
    let (bank, report) = fem::build_bank("fem-bar", "FEM bar", &BAR, &Material::STEEL, &opts, &quiet).unwrap();
    bank.validate().unwrap();
    assert_eq!(bank.num_modes(), 16);
    assert_eq!(bank.num_points(), 64);
    assert_eq!(report.rigid_eigenvalues.len(), 6);
    let back = presets::Bank::from_json(&bank.to_json()).unwrap();
    assert_eq!(back.lambdas, bank.lambdas);
    // Neighbouring strike points are close (path order).
    for p in bank.points.windows(2) {
        let d: f32 = (0..3).map(|i| (p[0].position_m[i] - p[1].position_m[i]).powi(2)).sum::<f32>().sqrt();
        assert!(d < 0.02, "strike points {d} m apart");
    }
    // Frequency limit: only modes below it.
    let opts = BuildOptions {
        max_modes: 50,
        max_freq_hz: Some(600.0),
        resolution: 30,
        strike_points: 64,
        auto_resolution: false,
        accuracy: None,
    };
    let (bank, _) = fem::build_bank("fem-bar", "FEM bar", &BAR, &Material::STEEL, &opts, &quiet).unwrap();
    let f = bank.frequencies_hz();
    println!("modes below 600 Hz: {f:?}");
    assert!(f.iter().all(|&x| x <= 600.0) && f.len() >= 4);
}

#[test]
fn circular_plate_matches_kirchhoff() {
    // Leissa 1969 §2.2 / Table 2.x for ν = 0.33: λ² of the free circular plate.
    let (a, h) = (0.1, 0.002);
    let shape = Shape::CircularPlate { radius: a, thickness: h };
    let mat = Material { young: 69e9, density: 2700.0, poisson: 0.33 };
    let opts = BuildOptions {
        max_modes: 9,
        max_freq_hz: None,
        resolution: 28,
        strike_points: 64,
        auto_resolution: false,
        accuracy: None,
    };
    let mesh = fem::mesh_shape(&shape, opts.resolution).unwrap();
    let modes = fem::analyse(&mesh, &mat, &opts, &quiet).unwrap();
    let f = modes.frequencies_hz();
    let d = mat.young * h.powi(3) / (12.0 * (1.0 - mat.poisson.powi(2)));
    let kirchhoff = |l2: f64| l2 / (a * a) * (d / (mat.density * h)).sqrt() / (2.0 * std::f64::consts::PI);
    println!("plate: {} nodes, {} dofs, {:.2} s; modes {:?}", mesh.nodes.len(), modes.dofs, modes.seconds, f);
    // Expected order: (2,0)×2, (0,1), (3,0)×2, (1,1)×2.
    let expect = [(0, 5.262), (1, 5.262), (2, 9.069), (3, 12.244), (4, 12.244), (5, 20.513), (6, 20.513)];
    for &(i, l2) in &expect {
        let fk = kirchhoff(l2);
        println!(
            "mode {i}: FEM {:.1} Hz, Kirchhoff {:.1} Hz, err {:+.2} %, ratio err {:+.2} %",
            f[i],
            fk,
            100.0 * (f[i] / fk - 1.0),
            100.0 * (f[i] / f[0] / (l2 / 5.262) - 1.0)
        );
        assert!((f[i] / f[0] / (l2 / 5.262) - 1.0).abs() < 0.03);
        assert!((f[i] / fk - 1.0).abs() < 0.03);
    }
}

#[test]
fn other_shapes_mesh_and_solve() {
    let mat = Material::STEEL;
    let shapes = [
        Shape::Tube { length: 0.3, outer_radius: 0.015, wall: 0.002 },
        Shape::Bowl { radius: 0.08, wall: 0.004 },
        Shape::SphereShell { radius: 0.05, wall: 0.004 },
        Shape::Cup { radius: 0.04, height: 0.08, wall: 0.004 },
        Shape::Bell { radius: 0.1, height: 0.15, wall: 0.008 },
        Shape::Block { length: 0.1, width: 0.07, height: 0.03 },
    ];
    for s in &shapes {
        let opts = BuildOptions {
            max_modes: 10,
            max_freq_hz: None,
            resolution: 10,
            strike_points: 64,
            auto_resolution: false,
            accuracy: None,
        };
        let t = std::time::Instant::now();
        let (bank, r) =
            fem::build_bank("x", "x", s, &mat, &opts, &quiet).unwrap_or_else(|e| panic!("{}: {e}", s.kind()));
        println!(
            "{}: {} nodes, {} modes, {:.2} s, f = {:?}",
            s.kind(),
            r.nodes,
            bank.num_modes(),
            t.elapsed().as_secs_f64(),
            bank.frequencies_hz().iter().map(|f| f.round()).collect::<Vec<_>>()
        );
        bank.validate().unwrap();
    }
}

#[test]
fn bad_inputs_are_errors() {
    let bad = Shape::Bar { length: -1.0, width: 0.01, thickness: 0.01 };
    assert!(matches!(fem::mesh_shape(&bad, 10), Err(fem::FemError::InvalidShape { .. })));
    let m = Material { young: 1e9, density: 1000.0, poisson: 0.6 };
    let opts = BuildOptions::default();
    assert!(matches!(fem::build_bank("a", "a", &BAR, &m, &opts, &quiet), Err(fem::FemError::InvalidMaterial(_))));
    assert!(fem::read_gmsh("hello").is_err());
    // Moduli and densities no struck solid has are typing errors (a black-box tester's
    // `--young 1e-300`, `--density 1e308`), named in a short line; the real range passes.
    for (young, density, says) in [
        (1e-300, 1000.0, "Young's modulus"),
        (1e14, 1000.0, "Young's modulus"),
        (1e9, 1e308, "density"),
        (1e9, 0.5, "density"),
    ] {
        let e = Material { young, density, poisson: 0.3 }.validate().unwrap_err().to_string();
        assert!(e.contains(says) && e.len() < 200, "{e}");
    }
    for (young, density) in [(1e5, 30.0), (1.2e12, 3500.0), (200e9, 22_590.0), (1e6, 1.0)] {
        Material { young, density, poisson: 0.3 }.validate().unwrap();
    }
}

#[test]
fn gmsh_two_cubes_and_disconnected_mesh() {
    // A unit cube of 5 tetrahedra, 0.1 m.
    let cube = |off: f64, id0: usize| -> (String, String) {
        let mut n = String::new();
        let c = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]];
        for (i, p) in c.iter().enumerate() {
            n += &format!("{} {} {} {}\n", id0 + i + 1, 0.1 * p[0] as f64 + off, 0.1 * p[1] as f64, 0.1 * p[2] as f64);
        }
        let t = [[0, 1, 3, 4], [1, 2, 3, 6], [1, 4, 5, 6], [3, 4, 6, 7], [1, 3, 4, 6]];
        let mut e = String::new();
        for (i, tt) in t.iter().enumerate() {
            e += &format!(
                "{} 4 2 0 1 {} {} {} {}\n",
                id0 + i + 1,
                tt[0] + id0 + 1,
                tt[1] + id0 + 1,
                tt[2] + id0 + 1,
                tt[3] + id0 + 1
            );
        }
        (n, e)
    };
    let (n1, e1) = cube(0.0, 0);
    let text =
        format!("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n8\n{n1}$EndNodes\n$Elements\n5\n{e1}$EndElements\n");
    let mesh = fem::read_gmsh(&text).unwrap();
    assert_eq!(mesh.tets.len(), 5);
    assert!((mesh.volume() - 1e-3).abs() < 1e-12);
    let opts = BuildOptions {
        max_modes: 4,
        max_freq_hz: None,
        resolution: 2,
        strike_points: 8,
        auto_resolution: false,
        accuracy: None,
    };
    let modes = fem::analyse(&mesh, &Material::STEEL, &opts, &quiet).unwrap();
    assert_eq!(modes.rigid_lambdas.len(), 6);
    // Two separate cubes: twelve zero eigenvalues (more than six), which must be reported.
    let (n2, e2) = cube(0.5, 8);
    let text = format!(
        "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n16\n{n1}{n2}$EndNodes\n$Elements\n10\n{e1}{e2}$EndElements\n"
    );
    let mesh = fem::read_gmsh(&text).unwrap();
    let r = fem::analyse(&mesh, &Material::STEEL, &opts, &quiet);
    assert!(matches!(r, Err(fem::FemError::RigidModes { found, .. }) if found > 6), "{r:?}");
}

/// Eigen options as `fem::analyse` uses them, with a small slice to force several shifts.
fn sliced_options(nev: usize, sigma: f64) -> fem::eigen::EigenOptions {
    fem::eigen::EigenOptions {
        nev,
        lambda_max: None,
        sigma,
        block: 8,
        tol: 1e-8,
        max_basis: 320,
        slice: 16,
        max_factor_bytes: fem::eigen::MAX_FACTOR_BYTES,
    }
}

#[test]
fn spectrum_slicing_matches_dense_solver() {
    // A small block (dense-size mesh) solved both ways: several shifts with Sturm checks
    // against the dense shift-invert solver.
    let shape = Shape::Block { length: 0.1, width: 0.07, height: 0.03 };
    let mesh = fem::mesh_shape(&shape, 4).unwrap();
    let sys = fem::assemble(&mesh, &Material::STEEL).unwrap();
    assert!(sys.n > 200 && sys.n <= fem::eigen::DENSE_MAX, "{} DOFs", sys.n);
    let sigma = -1e-2 * Material::STEEL.specific_modulus() / (0.1f64.powi(2) + 0.07f64.powi(2) + 0.03f64.powi(2));
    let opts = sliced_options(46, sigma);
    let dense = fem::eigen::dense(&sys, &opts).unwrap();
    let sliced = fem::eigen::solve_sliced(&sys, &opts, &quiet).unwrap();
    let p = fem::eigen::last_profile();
    println!(
        "{} DOFs; shifts {:?}; runs {}; steps {}; one-pass orthogonalisations {}",
        sys.n, p.shifts, p.runs, p.steps, p.orth_skipped
    );
    assert!(p.shifts.len() >= 3, "expected several shifts, got {:?}", p.shifts);
    // Most steps take one Gram–Schmidt pass (Kahan's test), and the pairs must still
    // match the dense solver and be M-orthonormal below.
    assert!(2 * p.orth_skipped >= p.steps, "{} of {} steps took one pass", p.orth_skipped, p.steps);
    assert_eq!(sliced.lambdas.len(), 46);
    let lmax = dense.lambdas[45];
    for (i, (a, b)) in sliced.lambdas.iter().zip(&dense.lambdas).enumerate() {
        // Rigid modes (≈ 0) against the largest; elastic ones relative to themselves.
        let scale = if i < 6 { lmax } else { b.abs() };
        assert!((a - b).abs() <= 1e-8 * scale, "mode {i}: sliced {a} vs dense {b}");
    }
    // M-orthonormality of the sliced vectors.
    let n = sys.n;
    let v = &sliced.vectors;
    let mut worst = 0.0f64;
    for i in 0..46 {
        let x: Vec<f64> = (0..n).map(|r| v[(r, i)]).collect();
        let mut mx = vec![0.0; n];
        fem::assembly::sym_matvec_rows(&sys, &sys.m, &x, &mut mx, 1);
        for j in 0..46 {
            let d: f64 = (0..n).map(|r| v[(r, j)] * mx[r]).sum();
            worst = worst.max((d - if i == j { 1.0 } else { 0.0 }).abs());
        }
    }
    println!("max |ΦᵀMΦ − I| = {worst:.1e}");
    assert!(worst <= 1e-8);
}

#[test]
fn chunky_block_converges_all_requested_modes() {
    // The case the single-shift solver could not finish: many modes of a chunky solid.
    // Small mesh, small slices, so several shifts are needed.
    let shape = Shape::Block { length: 0.2, width: 0.08, height: 0.05 };
    let mesh = fem::mesh_shape(&shape, 8).unwrap();
    let sys = fem::assemble(&mesh, &Material::STEEL).unwrap();
    let sigma = -1e-2 * Material::STEEL.specific_modulus() / (0.2f64.powi(2) + 0.08f64.powi(2) + 0.05f64.powi(2));
    let r = fem::eigen::solve_sliced(&sys, &sliced_options(86, sigma), &quiet).unwrap();
    let p = fem::eigen::last_profile();
    println!(
        "{} DOFs, {} shifts, {} runs, {} steps, RQ err {:.1e}",
        sys.n,
        p.shifts.len(),
        p.runs,
        p.steps,
        p.max_rayleigh_error
    );
    assert_eq!(r.lambdas.len(), 86);
    assert!(r.lambdas.windows(2).all(|w| w[0] <= w[1]));
    assert!(p.shifts.len() >= 3);
    assert!(p.max_rayleigh_error < 1e-9);
    // Sturm count at the last shift agrees with what was found (checked inside); and the
    // modes agree with the full build path.
    let opts = BuildOptions {
        max_modes: 80,
        max_freq_hz: None,
        resolution: 8,
        strike_points: 16,
        auto_resolution: false,
        accuracy: None,
    };
    let modes = fem::analyse(&mesh, &Material::STEEL, &opts, &quiet).unwrap();
    assert_eq!(modes.lambdas.len(), 80);
    for (a, b) in modes.lambdas.iter().zip(&r.lambdas[6..]) {
        assert!((a - b).abs() <= 1e-8 * b, "{a} vs {b}");
    }
}

#[test]
fn a_mesh_whose_factor_exceeds_the_memory_limit_is_refused_before_factoring() {
    let shape = Shape::Block { length: 0.2, width: 0.08, height: 0.05 };
    let mesh = fem::mesh_shape(&shape, 8).unwrap();
    let sys = fem::assemble(&mesh, &Material::STEEL).unwrap();
    let sigma = -1e-2 * Material::STEEL.specific_modulus() / (0.2f64.powi(2) + 0.08f64.powi(2) + 0.05f64.powi(2));
    // The same solve passes with the build's limit (see chunky_block_converges_all_requested_modes)
    // and is refused, with the factor's size, under a 1 MiB limit.
    let mut opts = sliced_options(20, sigma);
    opts.max_factor_bytes = 1 << 20;
    let e = match fem::eigen::solve_sliced(&sys, &opts, &quiet) {
        Ok(_) => panic!("a 1 MiB factor limit was not enforced"),
        Err(e) => e.to_string(),
    };
    assert!(e.contains("too large") && e.contains("GiB") && e.contains(&format!("{} DOFs", sys.n)), "{e}");
}

/// Without a resolution the mesh is chosen by the build budget ([`fem::choose_resolution`]):
/// a slender steel bar gets enough elements across its section that its first torsion mode is
/// within 0.2 % of Saint-Venant's closed form (1.7 % sharp at the old fixed resolution 40,
/// two elements across), and a 5 cm cube, which at 40 elements per side needed an 80 GiB
/// factor, fits the budget.
#[test]
fn the_automatic_resolution_keeps_torsion_in_tune_and_cubes_solvable() {
    let steel = Material { young: 200e9, density: 7850.0, poisson: 0.3 };
    let (l, a) = (0.4, 0.02);
    let bar = Shape::Bar { length: l, width: a, thickness: a };
    let opts = BuildOptions { max_modes: 12, auto_resolution: true, ..BuildOptions::default() };
    let (bank, report) = fem::build_bank("bar", "Bar", &bar, &steel, &opts, &quiet).unwrap();
    assert!(report.dofs <= fem::AUTO_DOFS, "{} DOFs", report.dofs);
    // Saint-Venant torsion of a square section (Timoshenko & Goodier, Theory of Elasticity
    // §109): J = 0.1406 a⁴, polar moment Ip = a⁴/6; free-free f₁ = (1/2L)·√(G J/(ρ Ip)).
    let g = steel.young / (2.0 * (1.0 + steel.poisson));
    let f_torsion = (g * 0.1406 * 6.0 / steel.density).sqrt() / (2.0 * l);
    let f = bank.frequencies_hz();
    let nearest = f.iter().copied().min_by(|x, y| (x - f_torsion).abs().total_cmp(&(y - f_torsion).abs())).unwrap();
    let err = nearest / f_torsion - 1.0;
    assert!(err.abs() < 0.002, "torsion {nearest:.1} Hz vs Saint-Venant {f_torsion:.1} Hz ({:+.3} %)", 100.0 * err);
    // The recorded error estimate is of the size of the error measured against the closed
    // form (Saint-Venant's J itself is exact to the 4 digits used).
    let est = report.error_estimate.expect("an automatic resolution records its error estimate");
    println!("bar: torsion error {:+.4} %, estimate {:.4} %", 100.0 * err, 100.0 * est);
    assert!(est >= 0.3 * err.abs() && est < 0.005, "estimate {est:.2e} vs measured {err:.2e}");
    assert!(bank.provenance.contains("estimated discretisation error"), "{}", bank.provenance);
    // The budget's factor estimate (node graph × 9) against the factor a solve of the chosen
    // mesh makes.
    let mesh = fem::mesh_shape(&bar, fem::choose_resolution(&bar).unwrap()).unwrap();
    fem::analyse(&mesh, &steel, &BuildOptions { max_modes: 4, ..BuildOptions::default() }, &quiet).unwrap();
    let real = fem::eigen::last_profile().factor_nnz as f64 * 8.0;
    let estimate = fem::eigen::factor_bytes_estimate(&mesh).unwrap();
    // The estimate orders the mesh's node graph, the solve the node graph it reads off the
    // assembled DOF pattern: both by nested dissection, so they agree closely.
    assert_eq!(fem::eigen::last_profile().ordering, "nested dissection (METIS)");
    assert!((estimate / real - 1.0).abs() < 0.15, "factor estimate {estimate:.3e} B vs {real:.3e} B");
    println!("bar: factor estimate {estimate:.3e} B, real {real:.3e} B");

    let cube = Shape::Block { length: 0.05, width: 0.05, height: 0.05 };
    let r = fem::choose_resolution(&cube).unwrap();
    let mesh = fem::mesh_shape(&cube, r).unwrap();
    assert!(r >= 8 && 3 * mesh.nodes.len() <= fem::AUTO_DOFS, "cube at resolution {r}: {} nodes", mesh.nodes.len());
    let bytes = fem::eigen::factor_bytes_estimate(&mesh).unwrap();
    println!(
        "cube: resolution {r}, {} DOFs, factor estimate {:.2} GiB",
        3 * mesh.nodes.len(),
        bytes / f64::from(1 << 30)
    );
    assert!(bytes <= fem::eigen::MAX_FACTOR_BYTES as f64, "{:.2} GiB", bytes / f64::from(1 << 30));
}

/// A resolution too fine for the shape is refused before the mesh is built (a bar at
/// resolution 2000 would have 27 million corner vertices and took 1.6 TB before it was
/// counted), and the resolution the error names does mesh within the limit while one finer
/// does not.
#[test]
fn a_resolution_too_fine_is_refused_before_meshing_with_the_finest_that_fits() {
    let limit = fem::MAX_IMPORT_VERTICES;
    for shape in [
        Shape::Bar { length: 0.3, width: 0.03, thickness: 0.01 },
        Shape::CircularPlate { radius: 0.1, thickness: 0.003 },
        Shape::Bowl { radius: 0.08, wall: 0.004 },
        // The tubular chime: only the section's solid cells are meshed (the bore above the
        // plug is not), and the guard counts them exactly.
        Shape::PluggedTube { length: 1.0, outer_radius: 0.0193, wall: 0.004, plug: 0.0413 },
    ] {
        let err = fem::mesh_shape(&shape, 2000).expect_err("a 2000-element resolution was meshed").to_string();
        let at_most: usize = err
            .rsplit("at most ")
            .next()
            .and_then(|t| t.trim().parse().ok())
            .unwrap_or_else(|| panic!("no resolution named in {err:?}"));
        let fits = fem::mesh_shape(&shape, at_most).expect("the named resolution is refused");
        assert!(fits.corners <= limit, "{} corner vertices at the named resolution {at_most}", fits.corners);
        assert!(fem::mesh_shape(&shape, at_most + 1).is_err(), "resolution {} also fits: {err}", at_most + 1);
    }
    let err = fem::mesh_shape(&Shape::Bar { length: 0.3, width: 0.03, thickness: 0.01 }, 1_000_000).unwrap_err();
    assert!(err.to_string().contains("too fine"), "{err}");
}

/// A wall too thick is refused with the limit of its own shape (a tube's said "a quarter of
/// the radius" while it takes anything thinner than the radius).
#[test]
fn a_wall_too_thick_names_its_shapes_limit() {
    let msg = |s: Shape| s.validate().unwrap_err().to_string();
    assert!(
        msg(Shape::Tube { length: 0.6, outer_radius: 0.016, wall: 0.016 }).contains("thinner than the outer radius")
    );
    assert!(Shape::Tube { length: 0.6, outer_radius: 0.016, wall: 0.0159 }.validate().is_ok());
    assert!(msg(Shape::Bowl { radius: 0.08, wall: 0.05 }).contains("under half the radius"));
    assert!(msg(Shape::Cup { radius: 0.04, height: 0.1, wall: 0.011 })
        .contains("a quarter of the radius and of the height"));
}

/// Dimensions in the wrong units are refused before meshing: a 1,000 km bar ("element 0
/// has (nearly) zero volume" before) and a 1 nm plate (a failed factorisation before); an
/// undercut bar's ratios (depth, cut, exponent) are not taken for lengths.
#[test]
fn dimensions_out_of_any_object_are_refused_with_their_reason() {
    let e = Shape::Bar { length: 1e6, width: 0.03, thickness: 0.01 }.validate().unwrap_err().to_string();
    assert!(e.contains("at most 100"), "{e}");
    let e = Shape::Plate { length: 0.3, width: 0.03, thickness: 1e-9 }.validate().unwrap_err().to_string();
    assert!(e.contains("check the units"), "{e}");
    let undercut =
        Shape::UndercutBar { length: 0.4, width: 0.05, thickness: 0.02, depth: 0.0001, cut: 0.5, exponent: 16.0 };
    assert!(undercut.validate().is_ok());
}
