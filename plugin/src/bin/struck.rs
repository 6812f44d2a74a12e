//! `struck`: list objects and materials, show the modes a strike sounds, and render notes
//! offline through the plugin's own `process()`.

use clap::{Parser, Subcommand};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use struck::cli::{self, RenderOptions, SoundOptions};

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
    Modes {
        #[command(flatten)]
        sound: SoundArgs,
        /// MIDI key (Pitched key mode transposes from the root note).
        #[arg(long, default_value_t = 60)]
        note: u8,
        /// MIDI velocity 1..=127.
        #[arg(long, default_value_t = 100)]
        velocity: u8,
        /// Machine-readable output.
        #[arg(long)]
        json: bool,
    },
    /// Extract the impacts and modal features of recordings (WAV).
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
    Render {
        #[command(flatten)]
        sound: SoundArgs,
        /// Notes "key:velocity@position+start_seconds", comma separated; `@position` and
        /// `+start` are optional (position: the strike-position parameter; start: 0).
        #[arg(long)]
        notes: Option<String>,
        /// A standard MIDI file to play (with or instead of --notes).
        #[arg(long)]
        midi: Option<PathBuf>,
        /// Length in seconds (default: until 3 s after the last note starts).
        #[arg(long)]
        seconds: Option<f64>,
        /// Host block size in samples.
        #[arg(long, default_value_t = 512)]
        block_size: usize,
        /// Output WAV (32-bit float, stereo).
        #[arg(long)]
        out: PathBuf,
    },
}

#[derive(Subcommand)]
enum BankCommand {
    /// Modal analysis (10-node tetrahedra) of a built-in shape or a mesh file into a bank.
    Build {
        /// Built-in shape: bar, plate, block, circular-plate, tube, bowl, cup, bell, sphere-shell.
        #[arg(long, conflicts_with = "mesh", required_unless_present = "mesh")]
        shape: Option<String>,
        /// The shape's dimensions in metres, comma separated, in the order given by
        /// `struck bank shapes` (e.g. bar: length,width,thickness).
        #[arg(long, requires = "shape")]
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
        /// Mesh resolution: elements along the largest dimension (built-in shapes, default
        /// 40), or voxels along the longest side (.obj/.stl; default: the highest giving
        /// about 3000 vertices, e.g. 16 for a sphere, 60 for a rod of length 10 diameters).
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
        }
    }
}

fn run(cli: Cli) -> Result<(), String> {
    match cli.command {
        Command::Objects { json } => cli::print_objects(json),
        Command::Materials { json } => cli::print_materials(json),
        Command::Params { json } => cli::print_params(json),
        Command::Modes { sound, note, velocity, json } => cli::print_modes(&sound.options(), note, velocity, json),
        Command::Bank { command } => struck::banks::run(command.into()),
        Command::Features { files, channel, json } => struck::capture::features(&files, channel, json),
        Command::Estimate { files, model, method, object, channel, out, report } => {
            let summary = struck::capture::estimate(&struck::capture::EstimateArgs {
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
        Command::Render { sound, notes, midi, seconds, block_size, out } => {
            let opts = RenderOptions {
                sound: sound.options(),
                notes,
                midi: midi.as_deref().map(Path::to_path_buf),
                seconds,
                block_size,
                out,
            };
            let summary = cli::render(&opts)?;
            eprintln!("{summary}");
            Ok(())
        }
    }
}

impl From<BankCommand> for struck::banks::BankCommand {
    fn from(c: BankCommand) -> Self {
        use struck::banks::BankCommand as B;
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
            BankCommand::Info { bank, json } => B::Info { bank, json },
            BankCommand::Shapes => B::Shapes,
        }
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("struck: error: {e}");
            ExitCode::FAILURE
        }
    }
}
