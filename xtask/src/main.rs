//! Project tasks: `cargo xtask bundle struck --release` (nice-plug-xtask), plus
//! `cargo xtask demo` (bundles, then renders the demo phrase), `cargo xtask banks`
//! (regenerates the factory FEM banks) and `cargo xtask test`
//! (bundles the debug CLAP for the host test, then runs the whole test suite).

use std::process::Command;

fn cargo(args: &[&str]) -> Result<(), String> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    eprintln!("+ cargo {}", args.join(" "));
    let status = Command::new(cargo).args(args).status().map_err(|e| format!("cannot run cargo: {e}"))?;
    if status.success() {
        Ok(())
    } else {
        Err(format!("cargo {} failed ({status})", args.join(" ")))
    }
}

fn bundle(release: bool) -> Result<(), String> {
    let mut args = vec!["bundle".to_string(), "struck".to_string()];
    if release {
        args.push("--release".into());
    }
    nice_plug_xtask::chdir_workspace_root().map_err(|e| e.to_string())?;
    nice_plug_xtask::main_with_args("cargo xtask", args).map_err(|e| format!("bundling failed: {e:#}"))
}

/// The factory FEM library: id, name, shape, dims (m), E (Pa), ρ (kg/m³), ν, resolution,
/// modes. Realistic objects; materials are only the reference (any material plays on any bank).
const FEM_BANKS: &[(&str, &str, &str, &str, f64, f64, f64, usize, usize)] = &[
    ("fem-bar", "Bar (FEM, aluminium 30 cm)", "bar", "0.3,0.04,0.01", 69e9, 2700.0, 0.33, 36, 100),
    ("fem-plate", "Plate (FEM, steel 40 × 30 cm)", "plate", "0.4,0.3,0.004", 200e9, 7850.0, 0.3, 28, 100),
    (
        "fem-circular-plate",
        "Circular plate (FEM, brass Ø 30 cm)",
        "circular-plate",
        "0.15,0.003",
        105e9,
        8600.0,
        0.34,
        28,
        100,
    ),
    ("fem-tube", "Tube / chime (FEM, aluminium 60 cm)", "tube", "0.6,0.016,0.0015", 69e9, 2700.0, 0.33, 40, 100),
    ("fem-bowl", "Bowl (FEM, glass Ø 16 cm)", "bowl", "0.08,0.004", 70e9, 2500.0, 0.22, 24, 100),
    ("fem-cup", "Cup (FEM, porcelain)", "cup", "0.04,0.09,0.003", 100e9, 2400.0, 0.22, 18, 80),
    ("fem-bell", "Bell (FEM, bronze Ø 20 cm)", "bell", "0.1,0.14,0.006", 105e9, 8600.0, 0.34, 16, 80),
    ("fem-block", "Block / tile (FEM, wood-like)", "block", "0.2,0.08,0.05", 12e9, 650.0, 0.3, 12, 60),
    ("fem-sphere-shell", "Sphere shell (FEM, steel Ø 20 cm)", "sphere-shell", "0.1,0.004", 200e9, 7850.0, 0.3, 16, 80),
];

/// Regenerates `presets/factory/banks/*.json` with the FEM bank builder.
fn banks() -> Result<(), String> {
    nice_plug_xtask::chdir_workspace_root().map_err(|e| e.to_string())?;
    cargo(&["build", "--quiet", "--release", "-p", "struck", "--bin", "struck"])?;
    std::fs::create_dir_all("presets/factory/banks").map_err(|e| e.to_string())?;
    let target = std::env::var("CARGO_TARGET_DIR").unwrap_or_else(|_| "target".into());
    let struck = std::path::Path::new(&target).join("release/struck");
    let mut failed = Vec::new();
    for &(id, name, shape, dims, e, rho, nu, res, modes) in FEM_BANKS {
        let out = format!("presets/factory/banks/{id}.json");
        let (e, rho, nu, res, modes) =
            (e.to_string(), rho.to_string(), nu.to_string(), res.to_string(), modes.to_string());
        eprintln!("== {id}: {shape} {dims}");
        let status = Command::new(&struck)
            .args([
                "bank",
                "build",
                "--shape",
                shape,
                "--dims",
                dims,
                "--young",
                &e,
                "--density",
                &rho,
                "--poisson",
                &nu,
            ])
            .args([
                "--resolution",
                &res,
                "--modes",
                &modes,
                "--max-freq",
                "20000",
                "--points",
                "64",
                "--id",
                id,
                "--name",
                name,
                "--out",
                &out,
            ])
            .status()
            .map_err(|e| format!("cannot run struck: {e}"))?;
        if !status.success() {
            failed.push(id);
        }
    }
    if failed.is_empty() {
        Ok(())
    } else {
        Err(format!("banks that failed to build: {}", failed.join(", ")))
    }
}

fn run() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.first().map(String::as_str) {
        Some("demo") => {
            bundle(true)?;
            let out = args.get(1).cloned().unwrap_or_else(|| "target/struck-demo.wav".into());
            cargo(&["run", "--quiet", "--release", "-p", "struck", "--bin", "struck", "--", "render", "--out", &out])?;
            eprintln!("bundles: target/bundled/Struck.clap, target/bundled/Struck.vst3; demo: {out}");
            Ok(())
        }
        Some("banks") => banks(),
        Some("test") => {
            // The CLAP host test loads the debug bundle built with allocation assertions.
            nice_plug_xtask::chdir_workspace_root().map_err(|e| e.to_string())?;
            nice_plug_xtask::main_with_args(
                "cargo xtask",
                ["bundle", "struck", "--features", "assert_process_allocs"].map(String::from),
            )
            .map_err(|e| format!("bundling the test plugin failed: {e:#}"))?;
            // SAFETY: single-threaded at this point; the variable is read by the child.
            unsafe {
                std::env::set_var(
                    "STRUCK_CLAP",
                    std::env::current_dir().map_err(|e| e.to_string())?.join("target/bundled/Struck.clap"),
                )
            };
            let mut test = vec!["test", "--workspace"];
            test.extend(args[1..].iter().map(String::as_str));
            cargo(&test)
        }
        _ => nice_plug_xtask::main().map_err(|e| format!("{e:#}")),
    }
}

fn main() {
    if let Err(e) = run() {
        eprintln!("xtask: {e}");
        std::process::exit(1);
    }
}
