//! A built-in shape against its independent axisymmetric reference (issue 14, item 2):
//! tests/data/axisymmetric.json, written by tests/reference/axisymmetric.py.
//!
//! `cargo run --release -p struck-fem --example axisymmetric -- CASE [RESOLUTION LAYERS]`
//! CASE: disc | bowl. Without RESOLUTION, the bank builder's automatic choice
//! (`fem::choose_mesh`). Prints the mesh, time and peak memory, then the first 20 elastic
//! modes' errors against the reference (mode by mode) and the builder's own estimate of
//! that error (`fem::discretisation_error`, two more solves).

use std::time::Instant;

use fem::{analyse, mesh_shape_layers, BuildOptions};

#[path = "../tests/support/reference.rs"]
mod reference;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let name = args.first().map(String::as_str).unwrap_or("bowl");
    let r = reference::reference(name);
    let (res, layers) = match (args.get(1), args.get(2)) {
        (Some(a), Some(b)) => (a.parse().expect("RESOLUTION"), b.parse().expect("LAYERS")),
        _ => {
            let m = fem::choose_mesh(&r.shape).expect("a mesh within the budget");
            (m.resolution, m.layers)
        }
    };
    let t0 = Instant::now();
    let mesh = mesh_shape_layers(&r.shape, res, layers).expect("mesh");
    let opts = BuildOptions { max_modes: 24, resolution: res, ..BuildOptions::default() };
    let modes = analyse(&mesh, &r.material, &opts, &|_, _| {}).expect("solve");
    let secs = t0.elapsed().as_secs_f64();
    let freqs: Vec<f64> = modes.lambdas.iter().take(20).map(|l| l.sqrt() / (2.0 * std::f64::consts::PI)).collect();
    let errs = reference::errors(&freqs, &r.frequencies_hz);
    let worst = errs.iter().fold(0.0f64, |m, e| m.max(e.abs()));
    let mut sorted: Vec<f64> = errs.iter().map(|e| e.abs()).collect();
    sorted.sort_by(f64::total_cmp);
    println!(
        "{name}: resolution {res}, {layers} layer(s), {} DOFs, {secs:.1} s, peak {:.2} GiB",
        modes.dofs,
        fem::peak_memory_bytes().unwrap_or(0) as f64 / (1u64 << 30) as f64
    );
    println!("errors %: {}", errs.iter().map(|e| format!("{:+.3}", 100.0 * e)).collect::<Vec<_>>().join(" "));
    println!("max {:.3} %, median {:.3} %", 100.0 * worst, 100.0 * sorted[sorted.len() / 2]);
    let density = fem::MeshDensity { resolution: res, layers };
    match fem::discretisation_error(&r.shape, &r.material, density, &modes.frequencies_hz()) {
        Ok(e) => println!("estimated error {:.3} % ({})", 100.0 * e.relative, e.method),
        Err(e) => println!("no error estimate: {e}"),
    }
}
