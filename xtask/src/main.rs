//! Project tasks: `cargo xtask bundle -p struck -p struck-resonator --release` (nice-plug-xtask), plus
//! `cargo xtask demo` (bundles, then renders the demo phrase), `cargo xtask banks`
//! (regenerates the factory FEM banks) and `cargo xtask test` (installs what the tests need,
//! bundles the debug plugin into `target/test-bundled`, runs the whole test suite, the
//! third-party validators and the pedalboard VST3 host test).

use std::path::{Path, PathBuf};
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
    // The instrument and the effect (issue 16), one plugin per bundle.
    let mut args = ["bundle", "-p", "struck", "-p", "struck-resonator"].map(String::from).to_vec();
    if release {
        args.push("--release".into());
    }
    nice_plug_xtask::chdir_workspace_root().map_err(|e| e.to_string())?;
    nice_plug_xtask::main_with_args("cargo xtask", args).map_err(|e| format!("bundling failed: {e:#}"))
}

/// One factory FEM bank: id, name, shape, dims, E, ρ, ν, resolution, modes.
type FemBank = (&'static str, &'static str, &'static str, &'static str, f64, f64, f64, usize, usize);

/// The factory FEM library: id, name, shape, dims (m), E (Pa), ρ (kg/m³), ν, resolution,
/// modes. Realistic objects; materials are only the reference (any material plays on any bank).
const FEM_BANKS: &[FemBank] = &[
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

/// One factory tuned object: id, name, dims (m: the bar before the undercut, or the start of
/// the fit), ratios, the `--shape`, `--vary` and `--first-mode` of `struck bank tune` ("" and
/// 1 for an undercut bar), E, ρ, ν, resolution, modes.
type TunedBank = (
    &'static str,
    &'static str,
    &'static str,
    &'static str,
    (&'static str, &'static str, usize),
    f64,
    f64,
    f64,
    usize,
    usize,
);

/// The factory tuned bars (issue 11 part 4), built by `struck bank tune`. Wood is taken as
/// isotropic with its modulus along the grain (rosewood E ≈ 20 GPa, ρ ≈ 1050 kg/m³; Fletcher
/// & Rossing §19.2 give c_L ≈ 4.4 km/s for Honduras rosewood); the vibraphone bar is
/// aluminium.
const TUNED_BANKS: &[TunedBank] = &[
    (
        "fem-marimba-bar",
        "Marimba bar (FEM, rosewood, tuned 1:4:10)",
        "0.38,0.06,0.02",
        "1,4,10",
        ("bar", "", 1),
        20e9,
        1050.0,
        0.3,
        40,
        60,
    ),
    (
        "fem-xylophone-bar",
        "Xylophone bar (FEM, rosewood, tuned 1:3:6)",
        "0.25,0.04,0.022",
        "1,3,6",
        ("bar", "", 1),
        20e9,
        1050.0,
        0.3,
        40,
        60,
    ),
    (
        "fem-vibraphone-bar",
        "Vibraphone bar (FEM, aluminium, tuned 1:4:10)",
        "0.34,0.05,0.012",
        "1,4,10",
        ("bar", "", 1),
        69e9,
        2700.0,
        0.33,
        40,
        60,
    ),
    // A plain steel bar whose thickness is fitted to the bending partials of a real
    // glockenspiel bar (FluidR3_GM's C6, measured by tests/recordings/subspace.py).
    (
        "fem-glockenspiel-bar",
        "Glockenspiel bar (FEM, steel, a real bar's partials)",
        "0.16,0.03,0.0062",
        "1,2.7407,5.2911,8.6742,12.7096",
        ("bar", "thickness", 1),
        200e9,
        7850.0,
        0.3,
        40,
        60,
    ),
    // A brass tube closed at its top by a plug filling the bore, as real tubular bells are
    // (Rossing, Science of Percussion Instruments §5.3), whose radius and plug length are
    // fitted to bending modes 1–10 of a real tubular bell (freepats' 014_Tubular_Bells,
    // measured by tests/recordings/subspace.py). The plug lowers the low modes against the
    // rest, the radius (shear and rotary inertia) flattens the high ones; a plain tube misses
    // modes 1, 2, 9 and 10 by 17–48 cents. The 4 mm wall keeps the tube's shell
    // (ovalling) modes above its bending mode 10 (with 2.5 mm at this radius they crowd from
    // mode 9 up, one pair 9 cents from mode 9).
    (
        "fem-tubular-chime",
        "Tubular chime (FEM, brass, a real bell's partials)",
        "1.0,0.019,0.004,0.04",
        CHIME_RATIOS,
        ("plugged-tube", "outer_radius,plug", 1),
        100e9,
        8500.0,
        0.34,
        60,
        100,
    ),
];

/// Bending modes 1–10 of the freepats tubular bell over its mode 1 (159.72 Hz).
const CHIME_RATIOS: &str = "1,2.77279,5.40114,8.77686,12.79201,17.33064,22.27955,27.57050,33.08747,38.72884";

/// Regenerates `presets/factory/banks/*.json` with the FEM bank builder.
fn banks() -> Result<(), String> {
    nice_plug_xtask::chdir_workspace_root().map_err(|e| e.to_string())?;
    cargo(&["build", "--quiet", "--release", "-p", "struck-cli", "--bin", "struck"])?;
    std::fs::create_dir_all("presets/factory/banks").map_err(|e| e.to_string())?;
    let target = std::env::var("CARGO_TARGET_DIR").unwrap_or_else(|_| "target".into());
    let struck = Path::new(&target).join("release/struck");
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
    for &(id, name, dims, ratios, (shape, vary, first), e, rho, nu, res, modes) in TUNED_BANKS {
        let out = format!("presets/factory/banks/{id}.json");
        let (e, rho, nu, res, modes) =
            (e.to_string(), rho.to_string(), nu.to_string(), res.to_string(), modes.to_string());
        eprintln!("== {id}: tuned {shape} {dims}, {ratios}");
        let mut cmd = Command::new(&struck);
        cmd.args([
            "bank",
            "tune",
            "--shape",
            shape,
            "--dims",
            dims,
            "--ratios",
            ratios,
            "--young",
            &e,
            "--density",
            &rho,
        ]);
        if !vary.is_empty() {
            cmd.args(["--vary", vary, "--first-mode", &first.to_string(), "--tolerance", "15"]);
        }
        let status = cmd
            .args(["--poisson", &nu, "--resolution", &res, "--modes", &modes, "--id", id, "--name", name])
            .args(["--out", &out])
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

/// Where `cargo xtask test` puts the debug bundles it tests, apart from the release bundles
/// in `target/bundled` that `cargo xtask demo` makes for users.
const TEST_BUNDLES: &str = "target/test-bundled";

/// The features the tests' build and its bundles have: the plugins' allocation assertions.
const TEST_FEATURES: &str = "struck/assert_process_allocs,struck-resonator/assert_process_allocs";

/// The test build's cargo arguments after the subcommand: every library, binary and test
/// target of the workspace with [`TEST_FEATURES`]. `cargo build` and `cargo test` given these
/// resolve the same features, so the test run reuses every artifact of the build.
const TEST_BUILD_ARGS: [&str; 7] = ["--workspace", "--lib", "--bins", "--tests", "--features", TEST_FEATURES, "-q"];

/// Builds the workspace as the tests do (libraries and binaries too) and bundles its debug
/// plugins, allocation assertions on, into [`TEST_BUNDLES`], leaving `target/bundled` as it
/// was (nice-plug-xtask always writes there, so a release bundle found there is moved aside
/// and back). Bundling from the tests' own build (not nice-plug-xtask's `bundle -p struck`,
/// whose features unify apart from the whole workspace's) compiles every crate once.
///
/// Returns whether the workspace build succeeded: if it failed, the plugins alone are built
/// and bundled, so the validators and hosts still run (the test step then reports the
/// failure).
fn bundle_for_tests(cargo: &str) -> Result<bool, String> {
    use std::fs;
    check_target_dir(cargo)?;
    let mut build = Command::new(cargo);
    build.arg("build").args(TEST_BUILD_ARGS);
    let whole = step("cargo build (the tests' build, bundled for the hosts)", &mut build);
    if !whole {
        let mut plugins = Command::new(cargo);
        plugins.args(["build", "-p", "struck", "-p", "struck-resonator", "--features", TEST_FEATURES]);
        if !step("cargo build -p struck -p struck-resonator (bundled for the hosts)", &mut plugins) {
            return Err("the plugins do not build".into());
        }
    }
    let (bundled, kept, test) =
        (Path::new("target/bundled"), Path::new("target/bundled.kept"), Path::new(TEST_BUNDLES));
    // An earlier run stopped between the two renames: put the user's bundles back first.
    if kept.exists() && !bundled.exists() {
        fs::rename(kept, bundled).map_err(|e| format!("cannot restore target/bundled: {e}"))?;
    }
    let had = bundled.exists();
    if had {
        if kept.exists() {
            fs::remove_dir_all(kept).map_err(|e| format!("cannot clear target/bundled.kept: {e}"))?;
        }
        fs::rename(bundled, kept).map_err(|e| format!("cannot move target/bundled aside: {e}"))?;
    }
    let built = ["struck", "struck-resonator"]
        .into_iter()
        .try_for_each(|p| nice_plug_xtask::bundle(Path::new("target"), p, &[], false))
        .map_err(|e| format!("bundling the test plugin failed: {e:#}"));
    let moved = built.and_then(|()| {
        if test.exists() {
            fs::remove_dir_all(test).map_err(|e| format!("cannot clear {TEST_BUNDLES}: {e}"))?;
        }
        fs::rename(bundled, test).map_err(|e| format!("cannot move the test bundles to {TEST_BUNDLES}: {e}"))
    });
    if had {
        if bundled.exists() {
            let _ = fs::remove_dir_all(bundled);
        }
        fs::rename(kept, bundled).map_err(|e| format!("cannot restore target/bundled: {e}"))?;
    }
    moved.map(|()| whole)
}

/// Checks that cargo builds into `./target`, where the bundles, the test venv and the hosts'
/// binaries are looked for (`CARGO_TARGET_DIR` or `build.target-dir` elsewhere would bundle
/// stale libraries or none).
fn check_target_dir(cargo: &str) -> Result<(), String> {
    let out = Command::new(cargo)
        .args(["metadata", "--no-deps", "--format-version", "1"])
        .output()
        .map_err(|e| format!("cannot run cargo metadata: {e}"))?;
    let text = String::from_utf8_lossy(&out.stdout);
    let key = "\"target_directory\":\"";
    let dir = text.find(key).map(|i| &text[i + key.len()..]).and_then(|t| t.split('"').next());
    let want = std::env::current_dir().map_err(|e| e.to_string())?.join("target");
    match dir {
        Some(d) if Path::new(d) == want => Ok(()),
        Some(d) => Err(format!(
            "cargo builds into {d}, but `cargo xtask test` bundles and runs from {}: unset CARGO_TARGET_DIR (or build.target-dir)",
            want.display()
        )),
        None => Err("cargo metadata did not give the target directory".into()),
    }
}

/// Runs a command, reporting whether it succeeded (a failure to start is a failure).
/// Prints how long the step took, so CI's log says where its time goes.
fn step(name: &str, cmd: &mut Command) -> bool {
    eprintln!("+ {name}");
    let start = std::time::Instant::now();
    let ok = succeeded(name, cmd.status());
    eprintln!("xtask: {name}: {:.0} s", start.elapsed().as_secs_f64());
    ok
}

/// Whether a step's command ran and succeeded; says which of the two failed.
fn succeeded(name: &str, status: std::io::Result<std::process::ExitStatus>) -> bool {
    match status {
        Ok(s) if s.success() => true,
        Ok(s) => {
            eprintln!("xtask: {name} failed ({s})");
            false
        }
        Err(e) => {
            eprintln!("xtask: cannot run {name}: {e}");
            false
        }
    }
}

/// A step run beside the others: its output goes to a log file that [`Background::finish`]
/// prints when it is waited for, so it does not interleave with theirs.
struct Background {
    name: String,
    log: PathBuf,
    child: std::io::Result<std::process::Child>,
    start: std::time::Instant,
}

impl Background {
    fn start(name: &str, mut cmd: Command, log: &Path) -> Self {
        eprintln!("+ {name} (beside the next steps; output in {})", log.display());
        let child = std::fs::File::create(log)
            .and_then(|out| Ok((out.try_clone()?, out)))
            .and_then(|(out, err)| cmd.stdout(out).stderr(err).spawn());
        Self { name: name.into(), log: log.to_path_buf(), child, start: std::time::Instant::now() }
    }

    /// Waits for the step, prints its output and time, and returns whether it succeeded.
    fn finish(self) -> bool {
        let name = &self.name;
        eprintln!("+ {name} (waiting for it)");
        let ok = succeeded(name, self.child.and_then(|mut c| c.wait()));
        if let Ok(text) = std::fs::read_to_string(&self.log) {
            eprint!("{text}");
        }
        eprintln!(
            "xtask: {name}: {:.0} s (from its start, beside the steps before)",
            self.start.elapsed().as_secs_f64()
        );
        ok
    }
}

/// `cargo xtask test [cargo test args]`: installs what the tests need (tests/setup.sh), bundles
/// the debug plugin into [`TEST_BUNDLES`], runs every test binary of the workspace (all of
/// them, even when one fails), then the third-party validators (clap-validator and Steinberg's
/// VST3 validator, `--extensive`), the pedalboard and Ardour VST3 host tests on those bundles, and the
/// check of the FEM tests' axisymmetric references. Fails if any of these failed, after
/// running them all. `extra` goes to `cargo test` only (test names, `--` and the harness's
/// options; a feature or profile flag there would rebuild apart from the bundled build).
fn test(extra: &[String]) -> Result<(), String> {
    nice_plug_xtask::chdir_workspace_root().map_err(|e| e.to_string())?;
    if !step("tests/setup.sh", Command::new("bash").arg("tests/setup.sh")) {
        return Err("tests/setup.sh could not install what the tests need".into());
    }
    let cargo_bin = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let built = bundle_for_tests(&cargo_bin)?;
    let root = std::env::current_dir().map_err(|e| e.to_string())?;
    let clap = root.join(TEST_BUNDLES).join("Struck.clap");
    let vst3 = root.join(TEST_BUNDLES).join("Struck.vst3");
    let fx_clap = root.join(TEST_BUNDLES).join("StruckResonator.clap");
    let fx_vst3 = root.join(TEST_BUNDLES).join("StruckResonator.vst3");
    let mut failed = Vec::new();
    if !built {
        failed.push("cargo build");
    }

    // The FEM tests' independent references: the script checks itself against closed forms
    // and recomputes tests/data/axisymmetric.json (scipy, about 80 s, one thread). It runs
    // beside the test binaries, which leave a core idle much of the time (a binary runs its
    // tests two at a time, and many have one long test).
    let mut refs = Command::new(root.join("target/test-venv/bin/python"));
    refs.arg("-u")
        .arg("presets/fem/tests/reference/axisymmetric.py")
        .arg("--check")
        .arg("presets/fem/tests/data/axisymmetric.json")
        .env("OMP_NUM_THREADS", "1")
        .env("OPENBLAS_NUM_THREADS", "1");
    let background_refs =
        Background::start("FEM axisymmetric references (scipy)", refs, &root.join("target/fem-references.log"));

    let mut cargo_test = Command::new(&cargo_bin);
    cargo_test
        // Libraries, binaries and test targets (built above): the examples and the (empty)
        // doc-tests are left to clippy's `--all-targets` check, which compiles them without
        // linking.
        .args(["test", "--no-fail-fast"])
        .args(TEST_BUILD_ARGS.iter().filter(|a| **a != "-q"))
        .args(extra)
        .env("STRUCK_CLAP", &clap)
        .env("STRUCK_RESONATOR_CLAP", &fx_clap);
    if !step("cargo test --workspace --no-fail-fast --lib --bins --tests --features (test features)", &mut cargo_test) {
        failed.push("cargo test");
    }

    let validate = root.join("../shared/validators/validate");
    if validate.exists() {
        for (name, c, v3) in [("Struck", &clap, &vst3), ("StruckResonator", &fx_clap, &fx_vst3)] {
            let mut v = Command::new("bash");
            v.arg(&validate).arg(c).arg(v3).arg("--extensive");
            if !step(&format!("third-party validators on {name} (clap-validator, vst3-validator --extensive)"), &mut v)
            {
                failed.push("validators");
            }
        }
    } else if std::env::var_os("CI").is_some() {
        eprintln!("xtask: the validators are missing: expected {}", validate.display());
        failed.push("validators (missing)");
    } else {
        eprintln!("xtask: validators not found at {} (shared/ beside the checkout): skipped", validate.display());
    }

    let python = root.join("target/test-venv/bin/python");
    let mut pb = Command::new(python);
    pb.arg("tests/hosts/pedalboard_host.py").arg(&vst3).arg("target/host-renders/clap-phrase.wav").arg(&fx_vst3);
    if !step("pedalboard VST3 host test", &mut pb) {
        failed.push("pedalboard");
    }

    // The references finish before Ardour starts: Ardour's own export crash (see
    // tests/hosts/ardour_host.sh) came more often with the script loading the second core,
    // once past the test's crash budget (stop 39); on an idle machine it costs ~20 s of CI.
    if !background_refs.finish() {
        failed.push("FEM references");
    }

    // A second VST3 host, not JUCE: Ardour 7 headless (its Lua session host), both plugins:
    // a note, a click through the effect, silence, a state save and reload.
    // At most 10 minutes, whatever Ardour does (its steps have their own time limits).
    let mut ardour = Command::new("timeout");
    ardour
        .args(["-k", "10", "600", "bash", "tests/hosts/ardour_host.sh"])
        .arg(&vst3)
        .arg(&fx_vst3)
        .env("STRUCK_BIN", root.join("target/debug/struck"));
    if !step("Ardour 7 VST3 host test", &mut ardour) {
        failed.push("Ardour");
    }

    if failed.is_empty() {
        eprintln!("xtask test: all passed (cargo test, validators, pedalboard, Ardour, FEM references)");
        Ok(())
    } else {
        Err(format!("failed: {}", failed.join(", ")))
    }
}

fn run() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.first().map(String::as_str) {
        Some("demo") => {
            bundle(true)?;
            let out = args.get(1).cloned().unwrap_or_else(|| "target/struck-demo.wav".into());
            cargo(&[
                "run",
                "--quiet",
                "--release",
                "-p",
                "struck-cli",
                "--bin",
                "struck",
                "--",
                "render",
                "--out",
                &out,
            ])?;
            eprintln!(
                "bundles: target/bundled/Struck.clap, target/bundled/Struck.vst3 (instrument), \
                 target/bundled/StruckResonator.clap, target/bundled/StruckResonator.vst3 (effect); demo: {out}"
            );
            Ok(())
        }
        Some("banks") => banks(),
        Some("test") => test(&args[1..]),
        _ => nice_plug_xtask::main().map_err(|e| format!("{e:#}")),
    }
}

fn main() {
    if let Err(e) = run() {
        eprintln!("xtask: {e}");
        std::process::exit(1);
    }
}
