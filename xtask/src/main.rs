//! Project tasks: `cargo xtask bundle struck --release` (nice-plug-xtask), plus
//! `cargo xtask demo` (bundles, then renders the demo phrase) and `cargo xtask test`
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
        Some("test") => {
            // The CLAP host test loads the debug bundle built with allocation assertions.
            nice_plug_xtask::chdir_workspace_root().map_err(|e| e.to_string())?;
            nice_plug_xtask::main_with_args("cargo xtask", ["bundle", "struck", "--features", "assert_process_allocs"].map(String::from))
                .map_err(|e| format!("bundling the test plugin failed: {e:#}"))?;
            // SAFETY: single-threaded at this point; the variable is read by the child.
            unsafe { std::env::set_var("STRUCK_CLAP", std::env::current_dir().map_err(|e| e.to_string())?.join("target/bundled/Struck.clap")) };
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
