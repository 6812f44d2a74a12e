//! Times the FEM bank builder on each built-in shape, with the eigensolver's phases.
//!
//! `cargo bench -p struck-fem --bench fem_timing [-- SHAPE [RESOLUTION [MODES]]]`
//! SHAPE is a kind name (`bar`, `plate`, `circular-plate`, `tube`, `bowl`, `cup`, `bell`,
//! `block`, `sphere-shell`) or `all` (default). (The factory banks are timed by
//! `cargo xtask banks`, which prints each one's time and peak memory.)
//! Prints one line per shape: corner vertices, nodes, DOFs, modes, wall seconds (total,
//! symbolic + numeric factorisation, solves, M products, orthogonalisation, Rayleigh–Ritz,
//! locking, residual check), CPU seconds of the process, shifts, Lanczos runs and steps,
//! largest basis, worst residual and peak memory. Peak memory and CPU time are
//! process-wide, so run one shape per process for exact per-shape figures.

use fem::{build_bank, eigen, BuildOptions, Material, Shape};

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

/// User + system CPU seconds of this process so far (Linux `/proc/self/stat`, 100 Hz ticks).
fn cpu_seconds() -> f64 {
    let s = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    // Fields after the command name (which is in parentheses): utime is the 12th, stime 13th.
    let rest = s.rsplit(')').next().unwrap_or("");
    let f: Vec<f64> = rest.split_whitespace().map(|x| x.parse().unwrap_or(0.0)).collect();
    (f.get(11).copied().unwrap_or(0.0) + f.get(12).copied().unwrap_or(0.0)) / 100.0
}

fn load() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .unwrap_or_default()
        .split_whitespace()
        .take(3)
        .collect::<Vec<_>>()
        .join(" ")
}

fn main() {
    // `cargo bench` adds `--bench`; flags are not ours.
    let args: Vec<String> = std::env::args().skip(1).filter(|a| !a.starts_with("--")).collect();
    let which = args.first().cloned().unwrap_or_else(|| "all".into());
    let res_override: Option<usize> = args.get(1).and_then(|s| s.parse().ok());
    let modes_override: Option<usize> = args.get(2).and_then(|s| s.parse().ok());
    let jobs: Vec<(String, Shape, Material, usize, usize, Option<f64>)> = shapes()
        .into_iter()
        .filter(|(s, _, _)| which == "all" || which == s.kind())
        .map(|(s, m, r)| (s.kind().to_string(), s, m, res_override.unwrap_or(r), modes_override.unwrap_or(200), None))
        .collect();
    println!("| object | res | vertices | nodes | DOFs | modes | f1 Hz | f_last Hz | total s | factor s (sym+num) | solve s | M s | orth s | RR s | lock s | check s | CPU s | shifts | runs | steps | basis | residual / RQ err | peak MiB | load |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for (name, shape, mat, res, modes, fmax) in jobs {
        let opts = BuildOptions {
            max_modes: modes,
            max_freq_hz: fmax,
            resolution: res,
            strike_points: 64,
            auto_resolution: false,
            accuracy: None,
        };
        let cpu0 = cpu_seconds();
        match build_bank(&name, &name, &shape, &mat, &opts, &|_, _| {}) {
            Ok((bank, r)) => {
                let p = eigen::last_profile();
                let f = bank.frequencies_hz();
                println!(
                    "| {name} | {res} | {} | {} | {} | {} | {:.1} | {:.1} | {:.1} | {:.1} ({:.1}+{:.1}) | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {} | {} | {} | {} | {:.0e} / {:.0e} | {:.0} | {} |",
                    r.vertices,
                    r.nodes,
                    r.dofs,
                    r.modes,
                    f[0],
                    f[f.len() - 1],
                    r.seconds,
                    r.factor_seconds,
                    p.symbolic_seconds,
                    p.numeric_seconds,
                    p.solve_seconds,
                    p.mass_seconds,
                    p.orth_seconds,
                    p.ritz_seconds,
                    p.lock_seconds,
                    p.check_seconds,
                    cpu_seconds() - cpu0,
                    p.shifts.len(),
                    p.runs,
                    p.steps,
                    p.max_basis,
                    p.max_residual,
                    p.max_rayleigh_error,
                    r.peak_memory_bytes.unwrap_or(0) as f64 / (1024.0 * 1024.0),
                    load()
                );
            }
            Err(e) => println!("| {name} | {res} | error: {e} |"),
        }
    }
}
