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
    ///
    /// The factory's, the damping knobs (`custom`) and the user folder's ($STRUCK_USER_DIR,
    /// else ~/.local/share/struck/materials on Linux), which `--material` takes by id or name.
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
        /// Partials decaying slower than this (1/s) are taken as steady hum [default: 0.05, a
        /// T60 of 138 s]; lower it for an object that rings for minutes.
        #[arg(long)]
        min_decay: Option<f64>,
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
        /// Fit method: emg (maximum likelihood), lsq, lb, ren (Ren 2013 §5: the psychoacoustic
        /// metric on the recordings, by Nelder–Mead).
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
        /// Keep no residual with the material (by default the first impact's residual, Ren
        /// §6.1, is kept: about 45 KB at 48 kHz).
        #[arg(long)]
        no_residual: bool,
        /// Partials decaying slower than this (1/s) are taken as steady hum [default: 0.05, a
        /// T60 of 138 s]; lower it for an object that rings for minutes.
        #[arg(long)]
        min_decay: Option<f64>,
    },
    /// Write a recording's residual for listening (Ren 2013 §6.1): what remains of one impact
    /// once the modes the material represents are taken out (the click of contact, noise).
    #[command(allow_negative_numbers = true)]
    Residual {
        /// The recording (WAV).
        file: PathBuf,
        /// The material whose modes represent the recording: a JSON file (e.g. from `struck
        /// estimate`) or a factory material's id, name or index.
        #[arg(long)]
        material: PathBuf,
        /// The residual WAV to write (32-bit float, the recording's rate).
        #[arg(long)]
        out: PathBuf,
        /// Which impact of the recording, from 1.
        #[arg(long, default_value_t = 1)]
        impact: usize,
        /// At most this much of the impact, s.
        #[arg(long, default_value_t = 2.0)]
        seconds: f64,
        /// Analyse this channel only (default: mix to mono), as given to `estimate`.
        #[arg(long)]
        channel: Option<usize>,
        /// Partials decaying slower than this (1/s) are taken as steady hum [default: 0.05]; give
        /// the value the material was estimated with.
        #[arg(long)]
        min_decay: Option<f64>,
    },
    /// Build mode banks by FEM or from a recording, or show a bank's summary (`bank info`).
    Bank {
        #[command(subcommand)]
        command: struck_cli::banks::BankCommand,
    },
    /// Render notes to a WAV file through the plugin's process().
    #[command(allow_negative_numbers = true)]
    Render {
        #[command(flatten)]
        sound: SoundArgs,
        /// Notes "key:velocity@position+start_seconds~held_seconds", comma separated;
        /// `@position`, `+start` and `~held` are optional (position: the strike-position
        /// parameter; start: 0; held: until the end, so the release damping is heard after it).
        // A value starting with "-" ("-1:100") is the notes' (their own range check says what
        // is wrong), not an unknown option.
        #[arg(long, allow_hyphen_values = true)]
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
        /// How held notes excite the object: strike (default), or a lasting contact while
        /// held: scrape, slide, roll (the *Excitation* parameter).
        #[arg(long, value_name = "strike|scrape|slide|roll")]
        excitation: Option<String>,
        /// The surface a lasting contact runs over: smooth, finegrit, coarsegrit, grooves, bumps,
        /// or a texture file (.csv/.txt heights in mm, .wav, .png; see the README).
        #[arg(long)]
        texture: Option<String>,
        /// The path through a .png texture: its middle row (default) or a spiral from the
        /// centre out, as a record's groove.
        #[arg(long, value_name = "row|spiral")]
        image_path: Option<String>,
        /// Contact speed over time, "seconds:m/s,…" (e.g. "0:0.1,1:0.5,2:0"; linear between
        /// points, held outside; 0..=1 m/s). Sent as the mod wheel.
        #[arg(long, value_name = "T:V,…", allow_hyphen_values = true)]
        speed_curve: Option<String>,
        /// Normal force over time, "seconds:0..1,…" (linear between points). Sent as every
        /// note's pressure; without it a note's force is its velocity.
        #[arg(long, value_name = "T:V,…", allow_hyphen_values = true)]
        force_curve: Option<String>,
        /// Audio in: this WAV drives the object at the strike position (moving at the contact
        /// speed; `--set drywet=…` mixes the input back in), rendered at its sample rate.
        #[arg(long, value_name = "WAV")]
        input: Option<PathBuf>,
    },
}

#[derive(clap::Args)]
struct SoundArgs {
    /// Object id, name or index (`struck objects`), or a bank JSON file (`struck bank build`).
    #[arg(long, default_value = "bar")]
    object: String,
    /// Material id, name or index (`struck materials`), a material JSON file, or `custom`:
    /// the damping knobs as `--set` sets them.
    #[arg(long, default_value = struck::library::DEFAULT_MATERIAL)]
    material: String,
    /// Size relative to the object's reference dimensions.
    #[arg(long)]
    size: Option<f32>,
    /// Strike position 0..=1 along the object's strike points.
    #[arg(long)]
    position: Option<f32>,
    /// Sample rate in Hz (default 48000; `render --input`: the input's).
    #[arg(long)]
    sample_rate: Option<u32>,
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
            sample_rate: self.sample_rate.unwrap_or(48_000),
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
        Command::Bank { command } => struck_cli::banks::run(command),
        Command::Features { files, channel, json, min_decay } => {
            struck_cli::capture::features(&files, channel, json, min_decay)
        }
        Command::Estimate { files, model, method, object, channel, out, report, no_residual, min_decay } => {
            let summary = struck_cli::capture::estimate(&struck_cli::capture::EstimateArgs {
                files,
                model,
                method,
                object,
                channel,
                out,
                report,
                no_residual,
                min_decay_per_s: min_decay,
            })?;
            eprintln!("{summary}");
            Ok(())
        }
        Command::Residual { file, material, out, impact, seconds, channel, min_decay } => {
            let summary = struck_cli::capture::residual(&struck_cli::capture::ResidualArgs {
                file,
                material,
                out,
                impact,
                seconds,
                channel,
                min_decay_per_s: min_decay,
            })?;
            eprintln!("{summary}");
            Ok(())
        }
        Command::Render {
            sound,
            notes,
            midi,
            seconds,
            normalize,
            block_size,
            stats,
            out,
            excitation,
            texture,
            image_path,
            speed_curve,
            force_curve,
            input,
        } => {
            let input_sets_rate = sound.sample_rate.is_none();
            let opts = RenderOptions {
                sound: sound.options(),
                notes,
                midi: midi.as_deref().map(Path::to_path_buf),
                seconds,
                block_size,
                out,
                normalize,
                gesture: struck_cli::cli::Gesture {
                    excitation,
                    texture,
                    image_path,
                    speed_curve,
                    force_curve,
                    input,
                    input_sets_rate,
                },
            };
            let (summary, load) = cli::render_with_stats(&opts)?;
            eprintln!("{summary}");
            if stats {
                eprintln!("{}", cli::stats_line(&load, load.sample_rate));
            }
            Ok(())
        }
    }
}

fn main() -> ExitCode {
    // Ctrl-C (or a kill) during a long render or build removes the unfinished output's
    // temporary file; the destination is untouched either way.
    presets::output::install_interrupt_cleanup();
    let args: Vec<std::ffi::OsString> = std::env::args_os().collect();
    // `--notes` takes values that start with "-" ("-1:100" meets the key's range check), so
    // an option right after it would be taken as its value.
    if let Some(i) = args.iter().position(|a| a == "--notes") {
        if let Some(next) = args.get(i + 1).and_then(|a| a.to_str()).filter(|a| a.starts_with("--")) {
            return fail(&format!("--notes needs its notes before the next option (found '{next}')"));
        }
    }
    let cli = match Cli::try_parse_from(help_of_help(args)) {
        Ok(cli) => cli,
        Err(e) => match e.kind() {
            // `--help` and `--version` are not errors: clap prints them to stdout.
            ErrorKind::DisplayHelp | ErrorKind::DisplayVersion => {
                let _ = e.print();
                return ExitCode::SUCCESS;
            }
            // `struck` or `struck bank` alone: clap would print the whole help as an error.
            ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand => return fail(&missing_subcommand(&e)),
            ErrorKind::InvalidUtf8 => {
                return fail(&format!(
                    "an argument is not UTF-8 text (a file name in another encoding?): rename the file or give its name in UTF-8 (see `{} --help`)",
                    command_path()
                ))
            }
            _ => return fail(&clap_one_line(&e)),
        },
    };
    let result = run(cli).and_then(|()| cli::stdout_result());
    cli::end_progress_line();
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => fail(&e),
    }
}

/// `struck help --help` (or `struck bank help -h`): clap's generated `help` subcommand takes
/// only subcommand names, so it refused its own `--help`; it is read as `struck --help`
/// (`struck bank --help`), whose text describes `help` too. Anything else is left as given.
fn help_of_help(mut args: Vec<std::ffi::OsString>) -> Vec<std::ffi::OsString> {
    let mut cmd = Cli::command();
    for i in 1..args.len() {
        let Some(arg) = args[i].to_str() else { break };
        if arg == "help" && args.get(i + 1).is_some_and(|a| a == "--help" || a == "-h") {
            args.remove(i);
            break;
        }
        let Some(sub) = cmd.find_subcommand(arg).cloned() else { break };
        cmd = sub;
    }
    args
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
    // (`args_os`: a file name that is not UTF-8 is an argument too; `args` panics on it.)
    for arg in std::env::args_os().skip(1) {
        let Some(sub) = arg.to_str().and_then(|a| cmd.find_subcommand(a)).cloned() else {
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
