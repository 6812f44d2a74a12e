//! `struck`: list objects and materials, show the modes a strike sounds, and render notes
//! offline through the plugin's own `process()`.

use clap::error::ErrorKind;
use clap::{CommandFactory, Parser, Subcommand};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use struck_cli::cli::{self, RenderOptions, SoundOptions};

#[derive(Parser)]
#[command(name = "struck", version, about = "Struck: modal synthesis of struck objects (offline tools)")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// List the objects (mode banks).
    Objects {
        /// Machine-readable output.
        #[arg(long)]
        json: bool,
    },
    /// List the materials.
    Materials {
        /// Machine-readable output.
        #[arg(long)]
        json: bool,
    },
    /// List the plugin's parameters (ids usable with `render --set`).
    Params {
        /// Machine-readable output.
        #[arg(long)]
        json: bool,
    },
    /// The modes a strike would sound.
    // Negative values are values (`--poisson -0.2`, `--seconds -1`), not unknown options.
    #[command(allow_negative_numbers = true)]
    Modes {
        #[command(flatten)]
        sound: SoundArgs,
        /// MIDI key (Pitched key mode transposes from the root note).
        #[arg(long, default_value_t = 60, value_parser = clap::value_parser!(u8).range(0..=127))]
        note: u8,
        /// MIDI velocity 1..=127.
        #[arg(long, default_value_t = 100, value_parser = clap::value_parser!(u8).range(1..=127))]
        velocity: u8,
        /// Machine-readable output.
        #[arg(long)]
        json: bool,
    },
    /// Extract the impacts and modal features of recordings (WAV).
    #[command(allow_negative_numbers = true)]
    Features {
        /// WAV files.
        #[arg(required = true)]
        files: Vec<PathBuf>,
        /// Analyse this channel only (default: mix to mono).
        #[arg(long)]
        channel: Option<usize>,
        /// Machine-readable output ({"impacts": [...]}).
        #[arg(long)]
        json: bool,
    },
    /// Estimate a material (damping law) from recordings of a struck object.
    #[command(allow_negative_numbers = true)]
    Estimate {
        /// WAV files.
        #[arg(required = true)]
        files: Vec<PathBuf>,
        /// Damping model: rayleigh, hybrid, power, caughey.
        #[arg(long, default_value = "rayleigh")]
        model: String,
        /// Fit method: emg (maximum likelihood), lsq, lb.
        #[arg(long, default_value = "emg")]
        method: String,
        /// The object recorded (id, name, index or bank JSON file): also fits γ/γ₀ (pitch).
        #[arg(long)]
        object: Option<String>,
        /// Analyse this channel only (default: mix to mono).
        #[arg(long)]
        channel: Option<usize>,
        /// Material JSON to write.
        #[arg(long)]
        out: PathBuf,
        /// Report JSON to write (features, every fit, warnings).
        #[arg(long)]
        report: Option<PathBuf>,
    },
    /// Build mode banks by FEM, or show a bank.
    Bank {
        #[command(subcommand)]
        command: BankCommand,
    },
    /// Render notes to a WAV file through the plugin's process().
    #[command(allow_negative_numbers = true)]
    Render {
        #[command(flatten)]
        sound: SoundArgs,
        /// Notes "key:velocity@position+start_seconds~held_seconds", comma separated;
        /// `@position`, `+start` and `~held` are optional (position: the strike-position
        /// parameter; start: 0; held: until the end, so the release damping is heard after it).
        #[arg(long)]
        notes: Option<String>,
        /// A standard MIDI file to play (with or instead of --notes).
        #[arg(long)]
        midi: Option<PathBuf>,
        /// Length in seconds (default: until the sound has decayed under −90 dBFS, at most
        /// 60 s after the last note). A tail cut while sounding is faded out over 10 ms.
        #[arg(long)]
        seconds: Option<f64>,
        /// Scale the render so its peak is at DBFS (default −1; the output safety is off for
        /// it unless set with --set safety=1).
        #[arg(long, value_name = "DBFS", num_args = 0..=1, default_missing_value = "-1")]
        normalize: Option<f64>,
        /// Host block size in samples.
        #[arg(long, default_value_t = 512)]
        block_size: usize,
        /// Print the render's load: peak and mean voices and sounding modes, the time spent in
        /// process(), the share of one core it means in real time, and mode-samples per second.
        #[arg(long)]
        stats: bool,
        /// Output WAV (32-bit float, stereo).
        #[arg(long)]
        out: PathBuf,
    },
}

// Parsed once per run: the size difference between the variants does not matter.
#[allow(clippy::large_enum_variant)]
#[derive(Subcommand)]
enum BankCommand {
    /// Modal analysis (10-node tetrahedra) of a built-in shape or a mesh file into a bank.
    #[command(allow_negative_numbers = true)]
    Build {
        /// Built-in shape: bar, plate, block, circular-plate, tube, bowl, cup, bell, sphere-shell.
        #[arg(long, conflicts_with = "mesh", required_unless_present = "mesh")]
        shape: Option<String>,
        /// The shape's dimensions in metres, comma separated, in the order given by
        /// `struck bank shapes` (e.g. bar: length,width,thickness).
        #[arg(long, requires = "shape", allow_hyphen_values = true)]
        dims: Option<String>,
        /// A mesh file: Gmsh .msh 2.2/4.1 ASCII tetrahedra, or a closed surface in .obj or
        /// .stl (ASCII or binary), which is voxelised (see --resolution).
        #[arg(long)]
        mesh: Option<PathBuf>,
        /// Factor from the mesh file's units to metres (e.g. 0.001 for millimetres; default 1).
        #[arg(long, requires = "mesh")]
        scale: Option<f64>,
        /// Number of modes (above the six rigid ones).
        #[arg(long, default_value_t = 100)]
        modes: usize,
        /// Keep only modes below this frequency (Hz).
        #[arg(long)]
        max_freq: Option<f64>,
        /// Young's modulus, Pa.
        #[arg(long, default_value_t = 200e9)]
        young: f64,
        /// Density, kg/m³.
        #[arg(long, default_value_t = 7850.0)]
        density: f64,
        /// Poisson's ratio.
        #[arg(long, default_value_t = 0.3)]
        poisson: f64,
        /// Mesh resolution: elements along the largest dimension (built-in shapes; default: the
        /// finest within the build budget of about 100,000 DOFs and a 1.5 GiB factor, e.g. 95
        /// for a 0.4 m bar, 15 for a cube), or voxels along the longest side (.obj/.stl; default:
        /// the highest giving about 3000 vertices, e.g. 16 for a sphere, 60 for a rod of length 10
        /// diameters).
        #[arg(long)]
        resolution: Option<usize>,
        /// Number of strike points.
        #[arg(long, default_value_t = 64)]
        points: usize,
        /// Bank id (kebab-case; default from the output file name).
        #[arg(long)]
        id: Option<String>,
        /// Display name (default: the id).
        #[arg(long)]
        name: Option<String>,
        /// Output bank JSON.
        #[arg(long)]
        out: PathBuf,
    },
    /// Tune a bar or a tube so that its bending modes stand at --ratios, then build its bank.
    /// A bar without --vary gets an undercut (thin-beam start, then Newton's method on the
    /// FEM); with --vary, or a tube, the named dimensions are fitted (Gauss–Newton on the FEM).
    #[command(allow_negative_numbers = true)]
    Tune {
        /// The shape to tune: bar (an undercut is cut from its underside unless --vary is
        /// given) or tube.
        #[arg(long, default_value = "bar")]
        shape: String,
        /// The shape's dimensions in metres (`struck bank shapes`): for the undercut, the bar
        /// before it (length,width,thickness); otherwise the start of the fit.
        #[arg(long)]
        dims: String,
        /// Target ratios of successive bending modes to the first, e.g. 1,4,10 (marimba,
        /// vibraphone) or 1,3,6 (xylophone); an undercut takes three, --vary two or more.
        #[arg(long)]
        ratios: String,
        /// Dimensions to fit instead of cutting an undercut, by name (e.g. thickness for a
        /// glockenspiel bar; outer_radius or length,outer_radius for a tube; default for a
        /// tube: outer_radius).
        #[arg(long)]
        vary: Option<String>,
        /// The bending mode (1 = lowest) the ratios are of: 1,r2,… are modes K, K+1, ….
        #[arg(long, default_value_t = 1)]
        first_mode: usize,
        /// With --vary (or a tube): fail if a ratio stays further than this from its target,
        /// cents.
        #[arg(long, default_value_t = 5.0)]
        tolerance: f64,
        /// Flatness of the undercut's bottom: thickness ∝ 1 − depth·(1 − |u|^exponent).
        #[arg(long, default_value_t = 4.0)]
        exponent: f64,
        /// Number of modes of the bank.
        #[arg(long, default_value_t = 100)]
        modes: usize,
        /// Young's modulus, Pa.
        #[arg(long, default_value_t = 200e9)]
        young: f64,
        /// Density, kg/m³.
        #[arg(long, default_value_t = 7850.0)]
        density: f64,
        /// Poisson's ratio.
        #[arg(long, default_value_t = 0.3)]
        poisson: f64,
        /// Mesh resolution: elements along the length.
        #[arg(long, default_value_t = 40)]
        resolution: usize,
        /// Number of strike points.
        #[arg(long, default_value_t = 64)]
        points: usize,
        /// Bank id (kebab-case; default from the output file name).
        #[arg(long)]
        id: Option<String>,
        /// Display name (default: the id).
        #[arg(long)]
        name: Option<String>,
        /// Output bank JSON.
        #[arg(long)]
        out: PathBuf,
    },
    /// Summarise a bank JSON file (validates it).
    Info {
        /// Bank JSON file.
        bank: PathBuf,
        /// Machine-readable output.
        #[arg(long)]
        json: bool,
    },
    /// List the built-in shapes and their dimension order.
    Shapes,
}

#[derive(clap::Args)]
struct SoundArgs {
    /// Object id, name or index (`struck objects`), or a bank JSON file (`struck bank build`).
    #[arg(long, default_value = "bar")]
    object: String,
    /// Material id, name or index (`struck materials`), or a material JSON file.
    #[arg(long, default_value = struck::library::DEFAULT_MATERIAL)]
    material: String,
    /// Size relative to the object's reference dimensions.
    #[arg(long)]
    size: Option<f32>,
    /// Strike position 0..=1 along the object's strike points.
    #[arg(long)]
    position: Option<f32>,
    /// Sample rate in Hz.
    #[arg(long, default_value_t = 48_000)]
    sample_rate: u32,
    /// Set any parameter: `--set id=value` (plain units; repeatable; see `struck params`).
    #[arg(long = "set", value_name = "ID=VALUE")]
    set: Vec<String>,
    /// Play the object at this pitch: the root key's reference mode (parameter *Pitch
    /// reference*) sounds at HZ or NOTE ("523.25", "C5", "F#3"), by setting γ/γ₀.
    #[arg(long, value_name = "HZ|NOTE")]
    pitch: Option<String>,
}

impl SoundArgs {
    fn options(&self) -> SoundOptions {
        SoundOptions {
            object: self.object.clone(),
            material: self.material.clone(),
            size: self.size,
            position: self.position,
            sample_rate: self.sample_rate,
            set: self.set.clone(),
            pitch: self.pitch.clone(),
        }
    }
}

fn run(cli: Cli) -> Result<(), String> {
    match cli.command {
        Command::Objects { json } => cli::print_objects(json),
        Command::Materials { json } => cli::print_materials(json),
        Command::Params { json } => cli::print_params(json),
        Command::Modes { sound, note, velocity, json } => cli::print_modes(&sound.options(), note, velocity, json),
        Command::Bank { command } => struck_cli::banks::run(command.into()),
        Command::Features { files, channel, json } => struck_cli::capture::features(&files, channel, json),
        Command::Estimate { files, model, method, object, channel, out, report } => {
            let summary = struck_cli::capture::estimate(&struck_cli::capture::EstimateArgs {
                files,
                model,
                method,
                object,
                channel,
                out,
                report,
            })?;
            eprintln!("{summary}");
            Ok(())
        }
        Command::Render { sound, notes, midi, seconds, normalize, block_size, stats, out } => {
            let opts = RenderOptions {
                sound: sound.options(),
                notes,
                midi: midi.as_deref().map(Path::to_path_buf),
                seconds,
                block_size,
                out,
                normalize,
            };
            let (summary, load) = cli::render_with_stats(&opts)?;
            eprintln!("{summary}");
            if stats {
                eprintln!("{}", cli::stats_line(&load, f64::from(opts.sound.sample_rate)));
            }
            Ok(())
        }
    }
}

impl From<BankCommand> for struck_cli::banks::BankCommand {
    fn from(c: BankCommand) -> Self {
        use struck_cli::banks::BankCommand as B;
        match c {
            BankCommand::Build {
                shape,
                dims,
                mesh,
                scale,
                modes,
                max_freq,
                young,
                density,
                poisson,
                resolution,
                points,
                id,
                name,
                out,
            } => B::Build {
                shape,
                dims,
                mesh,
                scale,
                modes,
                max_freq,
                young,
                density,
                poisson,
                resolution,
                points,
                id,
                name,
                out,
            },
            BankCommand::Tune {
                shape,
                dims,
                ratios,
                vary,
                first_mode,
                tolerance,
                exponent,
                modes,
                young,
                density,
                poisson,
                resolution,
                points,
                id,
                name,
                out,
            } => B::Tune {
                shape,
                dims,
                ratios,
                vary,
                first_mode,
                tolerance,
                exponent,
                modes,
                young,
                density,
                poisson,
                resolution,
                points,
                id,
                name,
                out,
            },
            BankCommand::Info { bank, json } => B::Info { bank, json },
            BankCommand::Shapes => B::Shapes,
        }
    }
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => match e.kind() {
            // `--help` and `--version` are not errors: clap prints them to stdout.
            ErrorKind::DisplayHelp | ErrorKind::DisplayVersion => {
                let _ = e.print();
                return ExitCode::SUCCESS;
            }
            // `struck` or `struck bank` alone: clap would print the whole help as an error.
            ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand => return fail(&missing_subcommand(&e)),
            _ => return fail(&clap_one_line(&e)),
        },
    };
    let result = run(cli);
    cli::end_progress_line();
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => fail(&e),
    }
}

/// Prints `struck: error: MESSAGE` as one line on stderr (after ending any progress line)
/// and returns the failure exit code (1).
fn fail(message: &str) -> ExitCode {
    cli::end_progress_line();
    let one: Vec<&str> = message.lines().map(str::trim).filter(|l| !l.is_empty()).collect();
    eprintln!("struck: error: {}", one.join("; "));
    ExitCode::FAILURE
}

/// The command the user typed, e.g. `struck bank build`: the subcommand names among the
/// arguments, followed down clap's command tree.
fn command_path() -> String {
    let mut cmd = Cli::command();
    let mut path = vec!["struck".to_string()];
    for arg in std::env::args().skip(1) {
        let Some(sub) = cmd.find_subcommand(&arg).cloned() else {
            continue;
        };
        path.push(sub.get_name().to_string());
        cmd = sub;
    }
    path.join(" ")
}

/// "missing subcommand" in one line, listing the subcommands from clap's help text.
fn missing_subcommand(e: &clap::Error) -> String {
    let text = e.render().to_string();
    let names: Vec<&str> = text
        .lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| l.split_whitespace().next())
        .filter(|n| *n != "help")
        .collect();
    format!("missing subcommand (one of: {}; see `{} --help`)", names.join(", "), command_path())
}

/// clap's error in one line: its first line, then its context lines (the missing arguments,
/// `tip: …`) joined with "; ", without the usage block, and where to read more.
fn clap_one_line(e: &clap::Error) -> String {
    let text = e.render().to_string();
    let mut lines = text.lines().take_while(|l| !l.starts_with("Usage:")).map(str::trim).filter(|l| !l.is_empty());
    let first = lines.next().unwrap_or("invalid arguments");
    let first = first.strip_prefix("error: ").unwrap_or(first).trim_end_matches(':');
    let context: Vec<&str> = lines.filter(|l| !l.starts_with("For more information")).collect();
    let message = if context.is_empty() { first.to_string() } else { format!("{first}: {}", context.join("; ")) };
    format!("{message} (see `{} --help`)", command_path())
}
