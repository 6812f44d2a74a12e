//! Times the FEM bank builder on each built-in shape at a realistic resolution.
//!
//! `cargo run -p struck-presets --release --example fem_timing [-- SHAPE [RESOLUTION [MODES]]]`
//! SHAPE is a kind name (`bar`, `plate`, `circular-plate`, `tube`, `bowl`, `cup`, `bell`,
//! `block`, `sphere-shell`) or `all` (default). Prints one line per shape: corner vertices,
//! nodes, DOFs, modes, seconds (total and factorisation), Lanczos steps, peak memory.
//! Peak memory is the process high-water mark, so run one shape per process for exact
//! per-shape figures.

use presets::fem::{build_bank, BuildOptions, Material, Shape};

fn shapes() -> Vec<(Shape, Material, usize)> {
    vec![
        (Shape::Bar { length: 0.4, width: 0.04, thickness: 0.02 }, Material::ALUMINIUM, 60),
        (Shape::Plate { length: 0.4, width: 0.3, thickness: 0.003 }, Material::STEEL, 50),
        (Shape::CircularPlate { radius: 0.2, thickness: 0.002 }, Material::BRONZE, 60),
        (Shape::Tube { length: 0.8, outer_radius: 0.016, wall: 0.0015 }, Material::ALUMINIUM, 80),
        (Shape::Bowl { radius: 0.1, wall: 0.004 }, Material::BRONZE, 40),
        (Shape::Cup { radius: 0.04, height: 0.1, wall: 0.003 }, Material::GLASS, 24),
        (Shape::Bell { radius: 0.15, height: 0.25, wall: 0.012 }, Material::BRONZE, 16),
        (Shape::Block { length: 0.2, width: 0.08, height: 0.05 }, Material::STEEL, 20),
        (Shape::SphereShell { radius: 0.08, wall: 0.004 }, Material::STEEL, 20),
    ]
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let which = args.first().cloned().unwrap_or_else(|| "all".into());
    let res_override: Option<usize> = args.get(1).and_then(|s| s.parse().ok());
    let modes: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(200);
    println!("| shape | resolution | vertices | nodes | DOFs | modes | f1 Hz | f_last Hz | total s | factor s | Lanczos steps | basis | peak MiB |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for (shape, mat, res) in shapes() {
        if which != "all" && which != shape.kind() {
            continue;
        }
        let res = res_override.unwrap_or(res);
        let opts = BuildOptions { max_modes: modes, max_freq_hz: None, resolution: res, strike_points: 64 };
        match build_bank(shape.kind(), shape.kind(), &shape, &mat, &opts, &|_, _| {}) {
            Ok((bank, r)) => {
                let f = bank.frequencies_hz();
                println!(
                    "| {} | {} | {} | {} | {} | {} | {:.1} | {:.1} | {:.1} | {:.1} | {} | {} | {:.0} |",
                    shape.kind(),
                    res,
                    r.vertices,
                    r.nodes,
                    r.dofs,
                    r.modes,
                    f[0],
                    f[f.len() - 1],
                    r.seconds,
                    r.factor_seconds,
                    r.iterations,
                    r.basis,
                    r.peak_memory_bytes.unwrap_or(0) as f64 / (1024.0 * 1024.0)
                );
            }
            Err(e) => println!("| {} | {} | error: {e} |", shape.kind(), res),
        }
    }
}
