//! The command line's work, as a library so tests and `xtask` use the same code.

/// `println!` that ignores a closed pipe (`struck modes --json | head` must not panic) and
/// keeps any other failure (a full disk behind `> file`) for [`stdout_result`].
macro_rules! outln {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        if let Err(e) = writeln!(std::io::stdout(), $($t)*) {
            $crate::cli::note_stdout_error(e);
        }
    }};
}
pub(crate) use outln;

/// The first failure writing to the standard output other than a closed pipe.
static STDOUT_ERROR: std::sync::Mutex<Option<String>> = std::sync::Mutex::new(None);

/// Keeps `e` as the standard output's failure unless one is kept or it is a closed pipe (the
/// reader, e.g. `head`, has what it wanted).
pub fn note_stdout_error(e: std::io::Error) {
    if e.kind() == std::io::ErrorKind::BrokenPipe {
        return;
    }
    if let Ok(mut kept) = STDOUT_ERROR.lock() {
        kept.get_or_insert_with(|| e.to_string());
    }
}

/// Flushes the standard output; an error if anything written to it was lost (a script must
/// not take a partial listing on a full disk for a whole one).
///
/// # Errors
/// `cannot write to the standard output: REASON`.
pub fn stdout_result() -> Result<(), String> {
    use std::io::Write as _;
    if let Err(e) = std::io::stdout().flush() {
        note_stdout_error(e);
    }
    match STDOUT_ERROR.lock().ok().and_then(|k| k.clone()) {
        Some(e) => Err(format!("cannot write to the standard output: {e}")),
        None => Ok(()),
    }
}

/// Whether a progress line (drawn with `\r`, no newline) is on stderr.
static PROGRESS_OPEN: AtomicBool = AtomicBool::new(false);

/// Draws `line` as the progress line on stderr (redrawn in place with `\r`), when stderr is
/// a terminal: in a log or a pipe the redraws would run together into one line before the
/// warnings and the error.
pub fn show_progress(line: &str) {
    use std::io::IsTerminal as _;
    if !std::io::stderr().is_terminal() {
        return;
    }
    eprint!("\r{line}");
    PROGRESS_OPEN.store(true, Ordering::Relaxed);
}

/// Ends an unfinished progress line with a newline, so that what follows (a warning, an
/// error) starts on its own line. Does nothing if no progress line is open.
pub fn end_progress_line() {
    if PROGRESS_OPEN.swap(false, Ordering::Relaxed) {
        eprintln!();
    }
}

/// Prints `warning: …` on stderr on a line of its own.
pub fn warn(message: &str) {
    end_progress_line();
    eprintln!("warning: {message}");
}

use dsp::Damping;
use nice_plug::midi::{Channel, Key, VoiceID};
use nice_plug::prelude::{Enum, NoteEvent};
use presets::Material;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use struck::library::Library;
use struck::offline::{note_off, note_on, set_timing, OfflineHost, RenderStats, TimedEvent};

/// Object, material and parameter choices shared by `modes` and `render`.
#[derive(Clone, Debug)]
pub struct SoundOptions {
    /// Object id, name or index.
    pub object: String,
    /// Material id, name, index, or path of a material JSON file.
    pub material: String,
    /// Size relative to the reference.
    pub size: Option<f32>,
    /// Default strike position.
    pub position: Option<f32>,
    /// Sample rate, Hz.
    pub sample_rate: u32,
    /// `id=value` parameter settings.
    pub set: Vec<String>,
    /// Pitch of the root key's reference mode (`--pitch`): Hz or a note name ("A4", "C#5").
    pub pitch: Option<String>,
}

impl Default for SoundOptions {
    fn default() -> Self {
        SoundOptions {
            object: "bar".into(),
            material: struck::library::DEFAULT_MATERIAL.into(),
            size: None,
            position: None,
            sample_rate: 48_000,
            set: vec![],
            pitch: None,
        }
    }
}

/// What `render` plays and where it writes.
#[derive(Clone, Debug)]
pub struct RenderOptions {
    /// Sound choices.
    pub sound: SoundOptions,
    /// `--notes` text.
    pub notes: Option<String>,
    /// `--midi` file.
    pub midi: Option<PathBuf>,
    /// Length, seconds.
    pub seconds: Option<f64>,
    /// Host block size.
    pub block_size: usize,
    /// Output WAV.
    pub out: PathBuf,
    /// `--normalize`: scale the render so its peak is this many dBFS (the output safety is
    /// then off unless set).
    pub normalize: Option<f64>,
    /// A lasting contact's gesture: excitation, texture, speed and force over time.
    pub gesture: Gesture,
}

/// `render`'s gesture options (issue 16): how held notes touch the object.
#[derive(Clone, Debug, Default)]
pub struct Gesture {
    /// `--excitation strike|scrape|slide|roll`.
    pub excitation: Option<String>,
    /// `--texture smooth|finegrit|coarsegrit|grooves|bumps`, or a texture file (.csv, .txt,
    /// .wav, .png; see `presets::texture`).
    pub texture: Option<String>,
    /// `--image-path row|spiral`: the path through a .png texture (default: its middle row).
    pub image_path: Option<String>,
    /// `--speed-curve "t:m/s,…"`: the contact speed over time (the mod wheel's way).
    pub speed_curve: Option<String>,
    /// `--force-curve "t:0..1,…"`: the normal force over time (every note's pressure).
    pub force_curve: Option<String>,
    /// `--input in.wav`: audio in (the plugin's input layout): the WAV drives the object.
    pub input: Option<PathBuf>,
    /// The render's sample rate is the input's (no `--sample-rate` was given).
    pub input_sets_rate: bool,
}

/// The `--input` WAV as (left, right, sample rate): a mono file feeds both channels, a file
/// of more channels its first two. Allocates.
///
/// # Errors
/// As [`estimator::wav::load_wav_exact`]: unreadable, corrupt, not 8–192 kHz (one line).
pub fn read_input(path: &Path) -> Result<(Vec<f32>, Vec<f32>, u32), String> {
    // The samples as they are: an analysis removes a DC offset, a render must not (it would
    // drive the object from the first sample).
    let left = estimator::wav::load_wav_exact(path, Some(0)).map_err(|e| format!("--input: {e}"))?;
    // What the reader noticed (samples far over full scale: wrong units; clipping) is said:
    // such a file drives the object as it is.
    for w in &left.warnings {
        warn(&format!("--input: {}", w.replace("the analysis uses", "the render uses")));
    }
    let right = if left.channels >= 2 {
        estimator::wav::load_wav_exact(path, Some(1)).map_err(|e| format!("--input: {e}"))?.samples
    } else {
        left.samples.clone()
    };
    Ok((left.samples, right, left.sample_rate))
}

/// Interval between the events that play a gesture's curves, samples.
pub const CURVE_STEP: u64 = 64;

/// Parses a curve "t:value,t:value,…" (seconds ascending from 0, values in `lo..=hi`).
///
/// # Errors
/// Empty, malformed, times not ascending or negative, values out of range.
pub fn parse_curve(name: &str, text: &str, lo: f64, hi: f64) -> Result<Vec<(f64, f64)>, String> {
    let mut points: Vec<(f64, f64)> = Vec::new();
    for item in text.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let bad = || format!("--{name} '{item}': expected seconds:value, e.g. \"0:0.1,1:0.5\"");
        let (t, v) = item.split_once(':').ok_or_else(bad)?;
        let t: f64 = t.trim().parse().map_err(|_| bad())?;
        let v: f64 = v.trim().parse().map_err(|_| bad())?;
        if !(t.is_finite() && t >= 0.0) {
            return Err(format!("--{name} '{item}': time {t} s is not a time from 0 on"));
        }
        if let Some(&(last, _)) = points.last() {
            if t < last {
                return Err(format!("--{name} '{item}': times must ascend ({t} s after {last} s)"));
            }
        }
        if !(v.is_finite() && v >= lo && v <= hi) {
            return Err(format!("--{name} '{item}': {v} is outside {lo}..={hi}"));
        }
        points.push((t, v));
    }
    if points.is_empty() {
        return Err(format!("--{name} holds no points"));
    }
    Ok(points)
}

/// The value of a curve at `t` s: linear between its points, held before the first and
/// after the last.
pub fn curve_at(points: &[(f64, f64)], t: f64) -> f64 {
    match points.iter().position(|&(pt, _)| pt > t) {
        None => points.last().map_or(0.0, |p| p.1),
        Some(0) => points[0].1,
        Some(i) => {
            let ((t0, v0), (t1, v1)) = (points[i - 1], points[i]);
            v0 + (v1 - v0) * (t - t0) / (t1 - t0)
        }
    }
}

/// The index of `name` among `names` (ids, case-insensitive) for `--option`.
fn choice(option: &str, names: &[&str], name: &str) -> Result<usize, String> {
    let q = name.trim().to_lowercase().replace([' ', '-', '_'], "");
    names
        .iter()
        .position(|n| *n == q)
        .ok_or_else(|| format!("--{option} '{name}': expected one of {}", names.join(", ")))
}

/// Excitation ids in the order of the plugin's *Excitation* parameter.
pub const EXCITATIONS: [&str; 4] = ["strike", "scrape", "slide", "roll"];
/// Factory texture ids in the order of the plugin's *Texture* parameter (its next value,
/// `TEXTURES.len()`, is *User file*).
pub const TEXTURES: [&str; 5] = ["smooth", "finegrit", "coarsegrit", "grooves", "bumps"];

fn find(names: &[(&str, &str)], what: &str, query: &str) -> Result<usize, String> {
    if let Ok(i) = query.parse::<usize>() {
        if i < names.len() {
            return Ok(i);
        }
    }
    let q = query.to_lowercase();
    names.iter().position(|(id, name)| id.to_lowercase() == q || name.to_lowercase() == q).ok_or_else(|| {
        format!("unknown {what} '{query}' (known: {})", names.iter().map(|(id, _)| *id).collect::<Vec<_>>().join(", "))
    })
}

/// Index of an object given by id, name or index.
///
/// # Errors
/// If no object matches.
pub fn resolve_object(lib: &Library, query: &str) -> Result<usize, String> {
    let names: Vec<(&str, &str)> = lib.banks.iter().map(|b| (b.id.as_str(), b.name.as_str())).collect();
    find(&names, "object", query)
}

/// The bank in `query` if it names a bank file (a `.json` path, or an existing file that is
/// not a listed object's id, name or index), else `None`. Warns (when `say`) about the
/// fields the file has that Struck does not read.
///
/// # Errors
/// The file cannot be read or is not a valid bank.
pub fn bank_file(lib: &Library, query: &str, say: bool) -> Result<Option<presets::Bank>, String> {
    if resolve_object(lib, query).is_ok() || !(query.ends_with(".json") || Path::new(query).is_file()) {
        return Ok(None);
    }
    load_bank(Path::new(query), say).map(Some)
}

/// Reads a bank file, warning (when `say`) about the fields it has that Struck does not read.
///
/// # Errors
/// The file cannot be read or is not a valid bank.
pub fn load_bank(path: &Path, say: bool) -> Result<presets::Bank, String> {
    let (bank, unknown) = presets::Bank::load_listing_unknown(path).map_err(|e| {
        if matches!(e, presets::PresetError::Json { .. }) && Material::load(path).is_ok() {
            format!(
                "{} is a material (a damping law), not an object (a bank of modes): give it with --material",
                path.display()
            )
        } else {
            file_error(path, &e)
        }
    })?;
    warn_unknown(path, &unknown, say);
    Ok(bank)
}

/// Reads a material file, warning (when `say`) about the fields it has that Struck does not
/// read.
///
/// # Errors
/// The file cannot be read or is not a valid material.
pub fn load_material(path: &Path, say: bool) -> Result<Material, String> {
    let (material, unknown) = Material::load_listing_unknown(path).map_err(|e| {
        if matches!(e, presets::PresetError::Json { .. }) && presets::Bank::load(path).is_ok() {
            format!(
                "{} is an object (a bank of modes), not a material (a damping law): give it with --object",
                path.display()
            )
        } else {
            file_error(path, &e)
        }
    })?;
    warn_unknown(path, &unknown, say);
    Ok(material)
}

/// A user bank (listed by id) with fields Struck does not read: says so (when `say`), as for
/// a bank file.
pub fn warn_user_bank(lib: &Library, object: usize, say: bool) {
    if let Some((_, note)) = lib.unknown_fields.iter().find(|(id, _)| say && *id == lib.banks[object].id) {
        warn(&format!("user bank {note}"));
    }
}

/// A preset file's error with the file's name (the JSON and I/O errors name it already).
fn file_error(path: &Path, e: &presets::PresetError) -> String {
    match e {
        presets::PresetError::Json { .. }
        | presets::PresetError::Io { .. }
        | presets::PresetError::Encoding { .. }
        | presets::PresetError::NotAPreset { .. } => e.to_string(),
        _ => format!("{}: {e}", path.display()),
    }
}

/// `warning: FILE: ignored N unknown fields …` when `say` and there are any.
fn warn_unknown(path: &Path, unknown: &[String], say: bool) {
    if let (true, Some(note)) = (say, presets::unknown_fields_note(unknown)) {
        warn(&format!("{}: {note}", path.display()));
    }
}

/// A factory material index, or a material read from a file.
pub enum MaterialChoice {
    /// A factory material.
    Factory(usize),
    /// A material from a JSON file, played through the *Custom* knobs.
    File(Box<Material>),
    /// The *Custom* material: the damping knobs as set (`--set dmodel=… --set alpha1=…`).
    Custom,
}

/// Resolves a material given by id, name, index or JSON file path (a file's unknown fields
/// are warned about when `say`).
///
/// # Errors
/// If nothing matches, or the file cannot be read or is not a valid material.
pub fn resolve_material(lib: &Library, query: &str, say: bool) -> Result<MaterialChoice, String> {
    // `struck materials` lists the knobs as `custom`, after the factory materials.
    if (query.eq_ignore_ascii_case("custom") || query.parse::<usize>() == Ok(lib.custom_material_index()))
        && !Path::new(query).exists()
    {
        return Ok(MaterialChoice::Custom);
    }
    let names: Vec<(&str, &str)> = lib.materials.iter().map(|m| (m.id.as_str(), m.name.as_str())).collect();
    match find(&names, "material", query) {
        Ok(i) => Ok(MaterialChoice::Factory(i)),
        Err(e) if query.ends_with(".json") || Path::new(query).exists() => {
            let _ = e;
            load_material(Path::new(query), say).map(|m| MaterialChoice::File(Box::new(m)))
        }
        Err(e) => {
            // A material in the user folder (a capture saved there), by its id or name.
            let q = query.to_lowercase();
            let user = struck::library::scan_user_materials(&struck::library::user_material_dir());
            match user
                .iter()
                .find(|u| u.material.as_ref().is_ok_and(|m| m.id.to_lowercase() == q || m.name.to_lowercase() == q))
            {
                Some(u) => load_material(&u.path, say).map(|m| MaterialChoice::File(Box::new(m))),
                None => Err(e),
            }
        }
    }
}

/// Sets the *Custom* material knobs so that they reproduce `d` (exactly for Rayleigh,
/// hybrid, power law and Caughey up to order 3).
///
/// # Errors
/// If the law needs a knob beyond its range or a fourth Caughey term.
pub fn set_custom_damping(host: &mut OfflineHost, d: &Damping) -> Result<(), String> {
    let lib = host.plugin().library().clone();
    let k = host.plugin().struck_params().custom_knobs_for(d)?;
    host.set_param("material", lib.custom_material_index() as f32).map_err(|e| e.to_string())?;
    host.set_param("dmodel", k.model.to_index() as f32).map_err(|e| e.to_string())?;
    host.set_param("alpha1", k.alpha1_per_s).map_err(|e| e.to_string())?;
    host.set_param("c1k", k.damping_1k_per_s).map_err(|e| e.to_string())?;
    host.set_param("expo", k.exponent).map_err(|e| e.to_string())?;
    host.set_param("c10k", k.caughey_10k_per_s).map_err(|e| e.to_string())?;
    Ok(())
}

/// A host at the options' sample rate with object, material and parameters set.
///
/// # Errors
/// Unknown object, material or parameter; a bad `id=value`; an unusable sample rate.
pub fn configured_host(opts: &SoundOptions, max_block: usize) -> Result<OfflineHost, String> {
    configure(opts, max_block, true)
}

/// [`configured_host`], with its warnings said only when `say` (a probe host built before
/// the one that renders keeps quiet, so each is said once).
fn configure(opts: &SoundOptions, max_block: usize, say: bool) -> Result<OfflineHost, String> {
    let factory = Library::factory();
    // An object given as a bank file (`struck bank build` output) plays through a library with
    // that bank added.
    let file_bank = bank_file(&factory, &opts.object, say)?;
    let file_bank_id = file_bank.as_ref().map(|b| b.id.clone());
    let plugin = match file_bank {
        Some(bank) => struck::Struck::with_library(std::sync::Arc::new(factory.with_bank(bank))),
        None => struck::Struck::default(),
    };
    let mut host = OfflineHost::with_plugin(plugin, opts.sample_rate as f32, max_block).map_err(|e| e.to_string())?;
    let lib = host.plugin().library().clone();
    let object = match file_bank_id {
        Some(id) => lib.bank_index(&id).ok_or("internal error: the bank file's bank is not listed")?,
        None => resolve_object(&lib, &opts.object)?,
    };
    host.set_param("object", object as f32).map_err(|e| e.to_string())?;
    warn_user_bank(&lib, object, say);
    // A material file's own specific modulus (γ/γ₀ of this object), played when *Material
    // sets pitch* is on, as the plugin plays a library material's.
    let mut file_modulus = None;
    // A material file's support recorded mode by mode: its object, modes and their mapping.
    let mut held = None;
    match resolve_material(&lib, &opts.material, say)? {
        MaterialChoice::Factory(i) => host.set_param("material", i as f32).map_err(|e| e.to_string())?,
        MaterialChoice::Custom => {
            host.set_param("material", lib.custom_material_index() as f32).map_err(|e| e.to_string())?;
        }
        MaterialChoice::File(m) => {
            let d = m.damping.to_damping().map_err(|e| e.to_string())?;
            set_custom_damping(&mut host, &d)?;
            // Its recorded support damping (played when Support is As recorded, the default).
            host.set_param("csupport", m.support_c().min(2000.0) as f32).map_err(|e| e.to_string())?;
            let reference = lib.banks.get(object).map_or(0.0, |b| b.reference.specific_modulus);
            file_modulus = m.specific_modulus.filter(|&g| g > 0.0 && reference > 0.0).map(|g| g / reference);
            // Its support recorded mode by mode on its object (issue 10 part 6), played there
            // while Support is As recorded.
            let mapping = host
                .plugin_mut()
                .set_user_support(m.recorded_modes().cloned())
                .map_err(|e| format!("{}: {e}", opts.material))?;
            held = m.recorded_modes().map(|r| (r.object.clone(), r.modes.len(), mapping));
            // Its residual, if it keeps one (issue 15): the residual layer plays it.
            host.plugin_mut().set_user_residual(m.residual.clone()).map_err(|e| format!("{}: {e}", opts.material))?;
        }
    }
    if let Some(s) = opts.size {
        check_range("size", s, 0.05, 20.0)?;
        host.set_param("size", s).map_err(|e| e.to_string())?;
    }
    if let Some(p) = opts.position {
        check_range("position", p, 0.0, 1.0)?;
        host.set_param("pos", p).map_err(|e| e.to_string())?;
    }
    for kv in &opts.set {
        let (k, v) = kv.split_once('=').ok_or_else(|| format!("--set expects id=value, got '{kv}'"))?;
        host.set_param_text(k.trim(), v).map_err(|e| format!("--set {}: {e}", kv.trim()))?;
    }
    // Said once the options are set: whether the per-mode record plays.
    if let Some((recorded_on, count, mapping)) = held.filter(|_| say) {
        let p = host.plugin().struck_params();
        let as_recorded = p.support_mode.value() == struck::params::SupportMode::AsRecorded;
        if as_recorded && !p.support_at_point.value() {
            if mapping.object.is_none() {
                warn(&format!(
                    "{}: its support was recorded mode by mode on '{recorded_on}', which is not an object here (`struck objects`); each mode gets a draw from the mean",
                    opts.material
                ));
            } else if mapping.object != Some(object) {
                warn(&format!(
                    "{}: its support was recorded mode by mode on '{recorded_on}'; on this object each mode gets a draw from the mean",
                    opts.material
                ));
            } else if mapping.skipped > 0 {
                let n = lib.banks.get(object).map_or(0, |b| b.lambdas.len());
                warn(&format!(
                    "{}: {} of its {count} recorded modes are not in '{recorded_on}' as it is now (an index past its {n} modes, or an eigenvalue moved by more than 0.1 %: rebuilt?); they get a draw from the mean",
                    opts.material, mapping.skipped
                ));
            }
        } else if as_recorded {
            warn(&format!(
                "{}: held at a point, the support recorded mode by mode on '{recorded_on}' does not play",
                opts.material
            ));
        }
    }
    if let Some(ratio) = file_modulus {
        if host.plugin().struck_params().material_pitch.value() {
            let gamma = host.param("gamma").map_err(|e| e.to_string())? * ratio as f32;
            let (lo, hi) = estimator::object::PLAYABLE_GAMMA_RATIO;
            check_range("set gamma (the material file's pitch)", gamma, lo as f32, hi as f32)?;
            host.set_param("gamma", gamma).map_err(|e| e.to_string())?;
        }
    }
    if let Some(text) = &opts.pitch {
        let hz = parse_pitch(text)?;
        host.reset();
        let now = reference_pitch_hz(&mut host)?;
        let gamma = host.param("gamma").map_err(|e| e.to_string())? * ((hz / now) * (hz / now)) as f32;
        if !estimator::object::playable_gamma_ratio(f64::from(gamma)) {
            return Err(format!(
                "--pitch {text}: the object's reference mode is at {now:.2} Hz; {hz:.2} Hz needs γ/γ₀ = {gamma}, outside 0.001..=1000"
            ));
        }
        host.set_param("gamma", gamma).map_err(|e| e.to_string())?;
    }
    host.reset();
    // The residual transferred for these settings before the first note (the same on every
    // run).
    host.plugin_mut().refresh_residual();
    Ok(host)
}

/// Parses `--pitch`: a frequency in Hz ("523.25", "523.25Hz") or a note name with octave
/// ("A4" = 440 Hz, "C#5", "Eb3", "c4").
///
/// # Errors
/// Anything else, or a frequency outside 1 Hz..=24 kHz.
pub fn parse_pitch(text: &str) -> Result<f64, String> {
    let t = text.trim();
    let bad = || format!("--pitch '{text}': expected Hz (e.g. 523.25) or a note name with octave (e.g. C5, F#3, Bb4)");
    let hz = if let Ok(v) = t.trim_end_matches("Hz").trim_end_matches("hz").trim().parse::<f64>() {
        v
    } else {
        let mut chars = t.chars();
        let letter = chars.next().ok_or_else(bad)?.to_ascii_uppercase();
        let base = match letter {
            'C' => 0,
            'D' => 2,
            'E' => 4,
            'F' => 5,
            'G' => 7,
            'A' => 9,
            'B' => 11,
            _ => return Err(bad()),
        };
        let rest = chars.as_str();
        let (shift, octave) = match rest.chars().next() {
            Some('#') | Some('♯') => (1, &rest[rest.chars().next().map_or(0, char::len_utf8)..]),
            Some('b') | Some('♭') => (-1, &rest[rest.chars().next().map_or(0, char::len_utf8)..]),
            _ => (0, rest),
        };
        let octave: i32 = octave.parse().map_err(|_| bad())?;
        let midi = 12 * (octave + 1) + base + shift;
        440.0 * 2f64.powf((f64::from(midi) - 69.0) / 12.0)
    };
    if !(hz.is_finite() && (1.0..=24_000.0).contains(&hz)) {
        return Err(format!("--pitch '{text}': {hz} Hz is outside 1..=24000 Hz"));
    }
    Ok(hz)
}

/// Frequency (Hz) at which the root key's reference mode (*Pitch reference*) sounds now.
fn reference_pitch_hz(host: &mut OfflineHost) -> Result<f64, String> {
    let plugin = host.plugin_mut();
    let params = plugin.struck_params().clone();
    let root = params.root_note.value().clamp(0, 127) as u8;
    let mut strike = plugin.strike_for(root, 1.0);
    plugin.tune_to_strongest(root, &mut strike);
    let lib = plugin.library().clone();
    let bank = lib.banks.get(params.object.value().max(0) as usize).ok_or("no object")?;
    let engine = plugin.engine().ok_or("the plugin did not activate")?;
    let p = engine.params();
    let scale = p.modulus_ratio * strike.lambda_factor / (p.size * p.size);
    // The reference mode: the one tuned to the root (the chosen or strongest), else the lowest.
    let mode = match params.pitch_reference.value() {
        struck::params::PitchReference::Chosen => (params.pitch_mode.value() - 1).max(0) as usize,
        struck::params::PitchReference::Strongest if params.key_tuning.value() => {
            let w = 2.0 * std::f64::consts::PI * 440.0 * 2f64.powf((f64::from(root) - 69.0) / 12.0);
            (0..bank.lambdas.len())
                .min_by(|&a, &b| {
                    (bank.lambdas[a] * strike.lambda_factor - w * w)
                        .abs()
                        .total_cmp(&(bank.lambdas[b] * strike.lambda_factor - w * w).abs())
                })
                .unwrap_or(0)
        }
        _ => 0,
    }
    .min(bank.lambdas.len().saturating_sub(1));
    Ok((bank.lambdas[mode] * scale).sqrt() / (2.0 * std::f64::consts::PI))
}

fn check_range(name: &str, v: f32, lo: f32, hi: f32) -> Result<(), String> {
    if v.is_finite() && (lo..=hi).contains(&v) {
        Ok(())
    } else {
        Err(format!("--{name} {v} is outside {lo}..={hi}"))
    }
}

/// One parsed `--notes` entry.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NoteSpec {
    /// MIDI key.
    pub key: u8,
    /// MIDI velocity 1..=127.
    pub velocity: u8,
    /// Strike position 0..=1, if given.
    pub position: Option<f32>,
    /// Start time, seconds.
    pub start_s: f64,
    /// How long the key is held (`~seconds`), if given; else until the render ends.
    pub duration_s: Option<f64>,
}

/// Parses `"60:100@0.25,67:80@0.5+1.0~0.5"` (key:velocity@position+start_seconds~held_seconds;
/// `@…`, `+…` and `~…` optional).
///
/// # Errors
/// A message naming the bad entry and what is expected.
pub fn parse_notes(text: &str) -> Result<Vec<NoteSpec>, String> {
    let bad = |entry: &str, why: &str| {
        format!(
            "bad note '{entry}': {why} (expected key:velocity@position+start_seconds~held_seconds, e.g. 60:100@0.25+0.5~1)"
        )
    };
    // `--notes` takes values that start with "-" (so "-1:100" meets the key's range check):
    // an option there is a missing value ("--notes --out x.wav").
    if text.trim_start().starts_with("--") {
        return Err(format!("--notes needs its notes before the next option (found '{}')", text.trim()));
    }
    let mut out = Vec::new();
    for entry in text.split(',').map(str::trim).filter(|e| !e.is_empty()) {
        let (rest, held) = match entry.split_once('~') {
            Some((a, b)) => (a, Some(b)),
            None => (entry, None),
        };
        let duration_s = match held {
            Some(d) => {
                let d: f64 = d.trim().parse().map_err(|_| bad(entry, "held time must be seconds > 0"))?;
                if !(d.is_finite() && d > 0.0) {
                    return Err(bad(entry, "held time must be seconds > 0"));
                }
                Some(d)
            }
            None => None,
        };
        let (rest, start) = match rest.split_once('+') {
            Some((a, b)) => (a, Some(b)),
            None => (rest, None),
        };
        let (rest, pos) = match rest.split_once('@') {
            Some((a, b)) => (a, Some(b)),
            None => (rest, None),
        };
        let (k, v) = rest.split_once(':').ok_or_else(|| bad(entry, "missing ':' between key and velocity"))?;
        let key: u8 = k.trim().parse().map_err(|_| bad(entry, "key must be 0..=127"))?;
        if key > 127 {
            return Err(bad(entry, "key must be 0..=127"));
        }
        let velocity: u8 = v.trim().parse().map_err(|_| bad(entry, "velocity must be 1..=127"))?;
        if !(1..=127).contains(&velocity) {
            return Err(bad(entry, "velocity must be 1..=127"));
        }
        let position = match pos {
            Some(p) => {
                let p: f32 = p.trim().parse().map_err(|_| bad(entry, "position must be a number in 0..=1"))?;
                if !(0.0..=1.0).contains(&p) {
                    return Err(bad(entry, "position must be in 0..=1"));
                }
                Some(p)
            }
            None => None,
        };
        let start_s = match start {
            Some(s) => {
                let s: f64 = s.trim().parse().map_err(|_| bad(entry, "start must be seconds ≥ 0"))?;
                if !(s.is_finite() && s >= 0.0) {
                    return Err(bad(entry, "start must be seconds ≥ 0"));
                }
                s
            }
            None => 0.0,
        };
        out.push(NoteSpec { key, velocity, position, start_s, duration_s });
    }
    if out.is_empty() {
        return Err("--notes holds no notes".into());
    }
    Ok(out)
}

/// The demo phrase played when `render` gets no notes.
pub fn demo_notes() -> Vec<NoteSpec> {
    let n = |key, velocity, position, start_s| NoteSpec {
        key,
        velocity,
        position: Some(position),
        start_s,
        duration_s: None,
    };
    vec![
        n(60, 100, 0.15, 0.0),
        n(67, 80, 0.45, 0.35),
        n(64, 90, 0.3, 0.7),
        n(72, 110, 0.1, 1.05),
        n(48, 120, 0.2, 1.6),
        n(55, 90, 0.6, 1.6),
        n(79, 70, 0.8, 2.2),
        n(60, 127, 0.05, 2.6),
    ]
}

/// Note events of `notes` at `sample_rate`: a note-on, plus a brightness expression at the
/// same sample when the note has its own position (CLAP's way of per-note timbre).
pub fn note_events(notes: &[NoteSpec], sample_rate: f64) -> Vec<TimedEvent> {
    let mut ev = Vec::new();
    for (i, n) in notes.iter().enumerate() {
        let sample = (n.start_s * sample_rate).round() as u64;
        let voice_id = VoiceID::ID(i as i32);
        let mut on = note_on(n.key, f32::from(n.velocity) / 127.0);
        if let NoteEvent::NoteOn { voice_id: v, .. } = &mut on {
            *v = voice_id;
        }
        ev.push(TimedEvent { sample, event: on });
        if let Some(d) = n.duration_s {
            let mut off = note_off(n.key);
            if let NoteEvent::NoteOff { voice_id: v, .. } = &mut off {
                *v = voice_id;
            }
            ev.push(TimedEvent { sample: ((n.start_s + d) * sample_rate).round() as u64, event: off });
        }
        if let Some(p) = n.position {
            ev.push(TimedEvent {
                sample,
                event: NoteEvent::PolyBrightness {
                    timing: 0,
                    voice_id,
                    channel: Channel::Number(0),
                    key: Key::Number(n.key),
                    brightness: p,
                },
            });
        }
    }
    ev.sort_by_key(|e| e.sample);
    ev
}

/// Bytes of a 32-bit float stereo frame.
const WAV_FRAME_BYTES: u64 = 8;
/// Largest WAV header hound writes (RIFF, WAVE_FORMAT_EXTENSIBLE `fmt `, `data` header): 68
/// bytes, of which the RIFF size field counts all but the first 8.
const WAV_HEADER_BYTES_COUNTED: u64 = 60;

/// Largest MIDI file read, bytes (64 MiB: a long orchestral file is a few megabytes).
pub const MAX_MIDI_BYTES: u64 = 64 << 20;

/// Frames of the longest stereo 32-bit float WAV: its RIFF size field (a `u32`) must hold the
/// data and the header.
pub const MAX_WAV_FRAMES: u64 = (u32::MAX as u64 - WAV_HEADER_BYTES_COUNTED) / WAV_FRAME_BYTES;

/// The files a render reads (`--midi`, and `--object` / `--material` given as files): the
/// output must be none of them.
fn render_inputs(opts: &RenderOptions) -> Vec<PathBuf> {
    let mut inputs: Vec<PathBuf> = opts.midi.iter().chain(&opts.gesture.input).cloned().collect();
    if let Some(t) = opts.gesture.texture.as_deref().filter(|t| Path::new(t).is_file()) {
        inputs.push(PathBuf::from(t));
    }
    for q in [&opts.sound.object, &opts.sound.material] {
        if Path::new(q).is_file() {
            inputs.push(PathBuf::from(q));
        }
    }
    inputs
}

/// Renders per the options and writes the WAV; returns a one-line summary and the load
/// figures of the final pass's `process()` calls.
///
/// The WAV is streamed to disk block by block (memory stays bounded whatever the length),
/// into a temporary file in the output's folder that replaces `out` only once complete: a
/// failed render leaves an existing `out` untouched.
///
/// # Errors
/// Bad options, an unreadable, corrupt or empty MIDI file, a WAV over 4 GiB, an output that
/// is one of the inputs or cannot be written.
pub fn render_with_stats(opts: &RenderOptions) -> Result<(String, RenderStats), String> {
    if opts.block_size == 0 || opts.block_size > 65_536 {
        return Err(format!("--block-size {} is outside 1..=65536", opts.block_size));
    }
    let input = match &opts.gesture.input {
        Some(path) => Some(read_input(path)?),
        None => None,
    };
    let mut owned = opts.clone();
    if let Some((_, _, rate)) = &input {
        if opts.gesture.input_sets_rate {
            owned.sound.sample_rate = *rate;
        } else if *rate != opts.sound.sample_rate {
            return Err(format!(
                "--input is {rate} Hz but --sample-rate is {} Hz: leave --sample-rate out to render at the input's rate",
                opts.sound.sample_rate
            ));
        }
    }
    let opts = &owned;
    let input_len = input.as_ref().map_or(0, |(l, _, _)| l.len());
    struck::offline::check_sample_rate(opts.sound.sample_rate as f32).map_err(|e| e.to_string())?;
    let sr = f64::from(opts.sound.sample_rate);
    let mut events = Vec::new();
    if let Some(text) = &opts.notes {
        events.extend(note_events(&parse_notes(text)?, sr));
    }
    if let Some(path) = &opts.midi {
        let bytes = presets::read_capped(path, MAX_MIDI_BYTES)
            .map_err(|e| format!("cannot read {}: {e}", path.display()))?
            .ok_or_else(|| {
                format!(
                    "{}: larger than {} MiB, more than any MIDI file; give the .mid file itself",
                    path.display(),
                    MAX_MIDI_BYTES >> 20
                )
            })?;
        events.extend(crate::midi_file::read_midi(&bytes, sr).map_err(|e| format!("{}: {e}", path.display()))?);
    }
    if opts.notes.is_none() && opts.midi.is_none() && input.is_none() {
        events = note_events(&demo_notes(), sr);
    }
    events.sort_by_key(|e| e.sample);
    let last = (events.last().map_or(0, |e| e.sample) as f64 / sr).max(input_len as f64 / sr);
    // Without --seconds: until the output has stayed under −90 dBFS for 0.1 s after the last
    // event, at most MAX_TAIL_S later.
    let auto = opts.seconds.is_none();
    let seconds = opts.seconds.unwrap_or(last + MAX_TAIL_S);
    if !(seconds.is_finite() && seconds > 0.0 && seconds <= 3600.0) {
        return Err(if auto {
            format!("the notes and input last until {last:.1} s (with the tail, {seconds:.1} s), over the render limit of 3600 s")
        } else if seconds.abs() < 1e6 {
            format!("--seconds {seconds} is outside (0, 3600]")
        } else {
            // A huge value in scientific notation, not three hundred digits.
            format!("--seconds {seconds:e} is outside (0, 3600]")
        });
    }
    if let Some(n) = opts.normalize {
        if !(n.is_finite() && (-60.0..=0.0).contains(&n)) {
            return Err(format!("--normalize {n} is outside -60..=0 dBFS"));
        }
    }
    let total = (seconds * sr).round() as usize;
    if total == 0 {
        return Err(format!("--seconds {seconds:e} is shorter than one sample at {} Hz", opts.sound.sample_rate));
    }
    // WAV sizes are 32-bit: refuse now rather than write a wrapped (corrupt) header later.
    if total as u64 > MAX_WAV_FRAMES && !auto {
        let bytes = total as u64 * WAV_FRAME_BYTES + WAV_HEADER_BYTES_COUNTED + 8;
        return Err(format!(
            "the WAV would be {:.2} GiB ({seconds} s at {} Hz, stereo 32-bit float) but WAV files stop at 4 GiB; render at most {:.0} s at this rate",
            bytes as f64 / f64::from(1u32 << 30),
            opts.sound.sample_rate,
            (MAX_WAV_FRAMES as f64 / sr).floor()
        ));
    }
    let total = total.min(MAX_WAV_FRAMES as usize);
    // Notes still held at the end are released there (hosts do the same on stop).
    let mut offs: Vec<TimedEvent> = events
        .iter()
        .filter_map(|e| match e.event {
            NoteEvent::NoteOn { key: Key::Number(k), .. } => {
                Some(TimedEvent { sample: total as u64, event: note_off(k) })
            }
            _ => None,
        })
        .collect();
    events.append(&mut offs);
    for e in &mut events {
        set_timing(&mut e.event, 0);
    }
    let last_event = events.iter().filter(|e| e.sample < total as u64).map(|e| e.sample).max().unwrap_or(0) as usize;
    // With an input, the render goes on at least until the input has played.
    let last_event = last_event.max(input_len.min(total));
    // Check the output before spending time rendering.
    let inputs = render_inputs(opts);
    let input_refs: Vec<&Path> = inputs.iter().map(PathBuf::as_path).collect();
    presets::output::check_not_input(&opts.out, &input_refs).map_err(|e| e.to_string())?;
    presets::output::check_kind(&opts.out, presets::output::Kind::Wav).map_err(|e| e.to_string())?;
    let mut sound = opts.sound.clone();
    // --normalize measures the plugin's own peak: the output safety would bend it.
    if opts.normalize.is_some() && !sound.set.iter().any(|kv| kv.trim_start().starts_with("safety")) {
        sound.set.push("safety=0".into());
    }
    let g = &opts.gesture;
    if let Some(e) = &g.excitation {
        sound.set.push(format!("excite={}", choice("excitation", &EXCITATIONS, e)?));
    }
    let mut user_texture = None;
    let image_path = match g.image_path.as_deref() {
        None => presets::texture::ImagePath::Row,
        Some(p) => {
            let is_png = g
                .texture
                .as_deref()
                .and_then(|t| Path::new(t).extension())
                .is_some_and(|x| x.eq_ignore_ascii_case("png"));
            if !is_png {
                return Err("--image-path applies to a .png texture (--texture FILE.png)".into());
            }
            presets::texture::ImagePath::parse(p).map_err(|e| format!("--image-path: {e}"))?
        }
    };
    if let Some(t) = &g.texture {
        let index = match choice("texture", &TEXTURES, t) {
            Ok(i) => i,
            // Not a factory texture's name: a texture file (its extension says which format).
            Err(_) if Path::new(t).extension().is_some() || Path::new(t).is_file() => {
                user_texture = Some(
                    struck::user_texture::load_texture_file(Path::new(t), image_path)
                        .map_err(|e| format!("--texture: {e}"))?,
                );
                TEXTURES.len()
            }
            Err(e) => return Err(format!("{e}, or a texture file (.csv, .txt, .wav, .png)")),
        };
        sound.set.push(format!("texture={index}"));
    }
    // A configured host with the render's input and user texture (its warnings said when
    // `say`: once per render).
    let configured = |sound: &SoundOptions, say: bool| -> Result<OfflineHost, String> {
        let mut host = configure(sound, opts.block_size, say)?;
        if let Some(f) = &user_texture {
            host.plugin_mut().set_user_texture(f.clone())?;
        }
        if let Some((l, r, _)) = &input {
            host.set_input(l.clone(), r.clone());
        }
        Ok(host)
    };
    let probe = configure(&sound, opts.block_size, false)?;
    if probe.param("excite").map_err(|e| e.to_string())? >= 1.0 {
        // In a lasting excitation the brightness expression sets a note's speed: a note's
        // own position goes as the position's polyphonic modulation instead.
        let base = probe.param("pos").map_err(|e| e.to_string())?;
        for e in &mut events {
            if let NoteEvent::PolyBrightness { voice_id: VoiceID::ID(id), brightness, .. } = e.event {
                e.event = NoteEvent::PolyModulation {
                    timing: 0,
                    voice_id: id,
                    poly_modulation_id: struck::params::POSITION_POLY_MOD_ID,
                    normalized_offset: brightness - base,
                };
            }
        }
    }
    drop(probe);
    let mut curves = Vec::new();
    if let Some(text) = &g.speed_curve {
        let max = dsp::contact::MAX_SPEED_M_PER_S;
        let c = parse_curve("speed-curve", text, 0.0, max)?;
        curves.push((c, true, max));
    }
    if let Some(text) = &g.force_curve {
        curves.push((parse_curve("force-curve", text, 0.0, 1.0)?, false, 1.0));
    }
    for (points, speed, max) in &curves {
        for sample in (0..total as u64).step_by(CURVE_STEP as usize) {
            let v = (curve_at(points, sample as f64 / sr) / max) as f32;
            let event = if *speed {
                NoteEvent::MidiCC { timing: 0, channel: 0, cc: 1, value: v }
            } else {
                NoteEvent::PolyPressure {
                    timing: 0,
                    voice_id: VoiceID::Wildcard,
                    channel: Channel::Wildcard,
                    key: Key::Wildcard,
                    pressure: v,
                }
            };
            events.push(TimedEvent { sample, event });
        }
    }
    events.sort_by_key(|e| e.sample);
    let ending = Ending { auto, total, last_event, fade: (FADE_S * sr).round() as usize };
    // --normalize: a first pass finds the peak (and the length); the render is deterministic,
    // so the second pass, scaled, is the same audio.
    let (gain, length) = match opts.normalize {
        Some(target) => {
            let mut host = configured(&sound, true)?;
            let pass = render_pass(&mut host, &events, opts.block_size, &ending, 1.0, |_, _| Ok(()))
                .map_err(|e: hound::Error| e.to_string())?;
            if pass.peak <= 0.0 {
                return Err("--normalize: the render is silent".into());
            }
            (10f32.powf(target as f32 / 20.0) / pass.peak, Some(pass.length))
        }
        None => (1.0, None),
    };
    let ending = Ending { auto: auto && length.is_none(), total: length.unwrap_or(total), ..ending };
    let mut host = configured(&sound, opts.normalize.is_none())?;
    let mut file = presets::output::AtomicFile::create(&opts.out).map_err(|e| e.to_string())?;
    let spec = hound::WavSpec {
        channels: 2,
        sample_rate: opts.sound.sample_rate,
        bits_per_sample: 32,
        sample_format: hound::SampleFormat::Float,
    };
    let write_err = |e: hound::Error| format!("cannot write {}: {e}", opts.out.display());
    let mut writer = hound::WavWriter::new(&mut file, spec).map_err(write_err)?;
    let pass = render_pass(&mut host, &events, opts.block_size, &ending, gain, |l, r| {
        writer.write_sample(l)?;
        writer.write_sample(r)
    })
    .map_err(write_err)?;
    let stats = host.stats();
    writer.finalize().map_err(write_err)?;
    file.commit().map_err(|e| e.to_string())?;
    if pass.peak > 1.0 {
        warn(&format!(
            "the render clips: its peak is {:+.1} dBFS (turn the output safety on, lower the gain, or use --normalize)",
            20.0 * pass.peak.log10()
        ));
    }
    // A render that holds none of its notes says why, rather than leave a silent file.
    let late =
        events.iter().filter(|e| matches!(e.event, NoteEvent::NoteOn { .. }) && e.sample >= total as u64).count();
    if late > 0 {
        warn(&format!(
            "{late} note(s) start at or after the end of the render ({:.3} s): they are not heard",
            total as f64 / sr
        ));
    }
    let played = events.iter().any(|e| matches!(e.event, NoteEvent::NoteOn { .. }) && e.sample < total as u64);
    if played && input_len == 0 && pass.peak < 1e-6 {
        warn(&if stats.peak_modes == 0 {
            format!(
                "the render is silent: no mode of the object sounded at these keys (all above {:.0} Hz, the Nyquist frequency at {} Hz); try another key, size or sample rate",
                sr / 2.0,
                opts.sound.sample_rate
            )
        } else {
            format!(
                "the render is silent (peak {:.1} dBFS): check the gain and the notes' velocities",
                20.0 * pass.peak.max(1e-12).log10()
            )
        });
    }
    let lib = host.plugin().library().clone();
    let p = host.plugin().struck_params();
    let obj = lib.banks.get(p.object.value() as usize).map_or("?", |b| b.name.as_str());
    // A material file plays through the *Custom* knobs: named by its own name and as given
    // (its path, or a user material's id or name).
    let mat = match resolve_material(&lib, &opts.sound.material, false) {
        Ok(MaterialChoice::File(m)) => format!("{} ({})", m.name, opts.sound.material),
        _ => lib.materials.get(p.material.value() as usize).map_or("Custom", |m| m.name.as_str()).to_string(),
    };
    let mut notes = String::new();
    if pass.faded {
        notes += ", last 10 ms faded out";
    }
    if gain != 1.0 {
        notes += &format!(", normalised by {:+.1} dB", 20.0 * gain.log10());
    }
    let summary = format!(
        "wrote {} ({:.2} s, {} Hz, peak {:.1} dBFS{notes}): {} notes on {obj}, {mat}",
        opts.out.display(),
        pass.length as f64 / sr,
        opts.sound.sample_rate,
        20.0 * pass.peak.max(1e-12).log10(),
        events.iter().filter(|e| matches!(e.event, NoteEvent::NoteOn { .. })).count()
    );
    Ok((summary, stats))
}

/// `render --stats`: the load of a render in one line.
pub fn stats_line(stats: &RenderStats, sample_rate: f64) -> String {
    format!(
        "stats: voices peak {} mean {:.1}; sounding modes peak {} mean {:.0}; process() {:.3} s for {:.2} s of audio = {:.2} % of one core; {:.3e} mode-samples/s",
        stats.peak_voices,
        stats.mean_voices(),
        stats.peak_modes,
        stats.mean_modes(),
        stats.process_s,
        stats.samples as f64 / sample_rate,
        100.0 * stats.core_share(sample_rate),
        stats.mode_samples_per_s()
    )
}

/// Renders `opts` to its WAV file (see [`render_with_stats`]); returns the summary line.
///
/// # Errors
/// As [`render_with_stats`].
pub fn render(opts: &RenderOptions) -> Result<String, String> {
    render_with_stats(opts).map(|(summary, _)| summary)
}

/// Longest tail rendered after the last event when `render` has no `--seconds`, s.
pub const MAX_TAIL_S: f64 = 60.0;
/// The level under which a render without `--seconds` ends (−90 dBFS).
pub const END_LEVEL: f32 = 3.162_277_7e-5;
/// How long the output must stay under [`END_LEVEL`] before the render ends, s.
pub const END_HOLD_S: f64 = 0.1;
/// Fade-out applied to a render cut while still sounding, s.
pub const FADE_S: f64 = 0.01;

/// Where a render ends: at `total` frames (auto: earlier, once quiet after `last_event`).
struct Ending {
    auto: bool,
    total: usize,
    last_event: usize,
    fade: usize,
}

/// What a render pass produced.
struct Pass {
    peak: f32,
    length: usize,
    faded: bool,
}

/// Why a pass stopped early.
enum Stop<E> {
    Quiet,
    Sink(E),
}

/// One render pass: blocks through the plugin, scaled by `gain`, faded over the last
/// `fade` frames when it runs to `total` and the `fade` frames before were above −90 dBFS, each frame
/// handed to `sink`; ends early when `auto` and quiet.
fn render_pass<E>(
    host: &mut OfflineHost,
    events: &[TimedEvent],
    block_size: usize,
    ending: &Ending,
    gain: f32,
    mut sink: impl FnMut(f32, f32) -> Result<(), E>,
) -> Result<Pass, E> {
    let sr = f64::from(host.sample_rate());
    let hold = (END_HOLD_S * sr).round() as usize;
    let (mut peak, mut pos, mut quiet_since, mut faded, mut recent) = (0.0f32, 0usize, 0usize, false, 0.0f32);
    let fade_start = ending.total.saturating_sub(ending.fade);
    let result = host.render_blocks(events, ending.total, block_size, |left, right| {
        for (&l, &r) in left.iter().zip(right) {
            let (mut l, mut r) = (l * gain, r * gain);
            if pos + ending.fade >= fade_start && pos < fade_start {
                recent = recent.max(l.abs()).max(r.abs());
            }
            if pos >= fade_start && ending.fade > 0 {
                // Faded when the 10 ms before it still sounded.
                if pos == fade_start && recent > END_LEVEL {
                    faded = true;
                }
                if faded {
                    // Raised-cosine fade to 0 at the last frame.
                    let x = (pos - fade_start) as f32 / ending.fade as f32;
                    let g = 0.5 * (1.0 + (std::f32::consts::PI * x).cos());
                    (l, r) = (l * g, r * g);
                }
            }
            let a = l.abs().max(r.abs());
            peak = peak.max(a);
            if a > END_LEVEL {
                quiet_since = pos + 1;
            }
            sink(l, r).map_err(Stop::Sink)?;
            pos += 1;
            if ending.auto && pos > ending.last_event && pos - quiet_since.max(ending.last_event) >= hold {
                return Err(Stop::Quiet);
            }
        }
        Ok(())
    });
    match result {
        Ok(_) | Err(Stop::Quiet) => Ok(Pass { peak, length: pos, faded }),
        Err(Stop::Sink(e)) => Err(e),
    }
}

/// Prints the object list.
///
/// # Errors
/// Never (kept for symmetry with the other commands).
pub fn print_objects(json: bool) -> Result<(), String> {
    let lib = Library::factory();
    for e in &lib.load_errors {
        warn(&format!("user bank {e}"));
    }
    if json {
        let v: Vec<_> = lib
            .banks
            .iter()
            .enumerate()
            .map(|(i, b)| {
                let f = b.frequencies_hz();
                serde_json::json!({
                    "index": i, "id": b.id, "name": b.name, "description": b.description, "provenance": b.provenance,
                    "modes": b.num_modes(), "strike_points": b.num_points(),
                    "lowest_hz": f.first(), "highest_hz": f.last(),
                })
            })
            .collect();
        outln!("{}", serde_json::to_string_pretty(&v).map_err(|e| e.to_string())?);
    } else {
        for (i, b) in lib.banks.iter().enumerate() {
            let f = b.frequencies_hz();
            outln!(
                "{i:2}  {:16} {:28} {:4} modes, {:3} points, {:.1}–{:.0} Hz",
                b.id,
                b.name,
                b.num_modes(),
                b.num_points(),
                f.first().copied().unwrap_or(0.0),
                f.last().copied().unwrap_or(0.0)
            );
        }
    }
    Ok(())
}

/// Prints the material list.
///
/// # Errors
/// Never.
pub fn print_materials(json: bool) -> Result<(), String> {
    let lib = Library::factory();
    // The user folder's materials (captures saved there): `--material` takes their id or name.
    let dir = struck::library::user_material_dir();
    let user = struck::library::scan_user_materials(&dir);
    if json {
        let mut v: Vec<_> = lib
            .materials
            .iter()
            .enumerate()
            .map(|(i, m)| serde_json::json!({"index": i, "id": m.id, "name": m.name, "provenance": m.provenance, "specific_modulus": m.specific_modulus, "damping": m.damping}))
            .collect();
        v.extend(user.iter().map(|u| match &u.material {
            Ok(m) => serde_json::json!({"user": true, "path": u.path, "id": m.id, "name": m.name, "provenance": m.provenance, "specific_modulus": m.specific_modulus, "damping": m.damping}),
            Err(e) => serde_json::json!({"user": true, "path": u.path, "error": e}),
        }));
        outln!("{}", serde_json::to_string_pretty(&v).map_err(|e| e.to_string())?);
    } else {
        let row = |index: &str, id: &str, name: &str, d: &Damping| {
            let t60 = |f: f64| 6.91 / (0.5 * d.c((2.0 * std::f64::consts::PI * f).powi(2)));
            format!(
                "{index:>2}  {id:28} {name:30} T60 {:6.2} s @200 Hz, {:6.3} s @1 kHz, {:6.3} s @5 kHz",
                t60(200.0),
                t60(1000.0),
                t60(5000.0)
            )
        };
        for (i, (m, d)) in lib.materials.iter().zip(&lib.dampings).enumerate() {
            outln!("{}", row(&i.to_string(), &m.id, &m.name, d));
        }
        outln!("{:2}  custom                       (the damping knobs)", lib.custom_material_index());
        if !user.is_empty() {
            outln!("user materials in {} (by id or name; played through the damping knobs):", dir.display());
            for u in &user {
                let file = u.path.file_name().map_or_else(String::new, |f| f.to_string_lossy().into_owned());
                match u.material.as_ref().map(|m| (m, m.damping.to_damping())) {
                    Ok((m, Ok(d))) => outln!("{}  ({file})", row("", &m.id, &m.name, &d)),
                    Ok((_, Err(e))) => outln!("    {file}: {e}"),
                    Err(e) => outln!("    {file}: {e}"),
                }
            }
        }
    }
    Ok(())
}

/// Prints the parameter list.
///
/// # Errors
/// Never.
pub fn print_params(json: bool) -> Result<(), String> {
    let plugin = struck::Struck::default();
    let params = nice_plug::prelude::Plugin::params(&plugin);
    let mut rows = Vec::new();
    for (id, ptr, _) in params.param_map() {
        // SAFETY: the pointers target `params`, alive for this whole function.
        let (name, def, lo, hi, shown, steps) = unsafe {
            (
                ptr.name().to_string(),
                ptr.default_plain_value(),
                ptr.preview_plain(0.0),
                ptr.preview_plain(1.0),
                ptr.normalized_value_to_string(ptr.default_normalized_value(), true),
                ptr.step_count(),
            )
        };
        // A short choice's options and a switch's by name (`--set support=off` takes them;
        // the objects and materials are listed by `struck objects` and `struck materials`).
        let options: Vec<String> = match steps {
            Some(n) if (1..=8).contains(&n) => (0..=n)
                // SAFETY: as above.
                .map(|i| unsafe { ptr.normalized_value_to_string(i as f32 / n as f32, false) })
                .collect(),
            _ => Vec::new(),
        };
        rows.push((id, name, def, lo, hi, shown, options));
    }
    if json {
        let v: Vec<_> = rows
            .iter()
            .map(|(id, n, d, lo, hi, s, o)| {
                serde_json::json!({"id": id, "name": n, "default": d, "min": lo, "max": hi, "default_text": s, "options": o})
            })
            .collect();
        outln!("{}", serde_json::to_string_pretty(&v).map_err(|e| e.to_string())?);
    } else {
        for (id, n, d, lo, hi, s, o) in rows {
            let o = if o.is_empty() { String::new() } else { format!("  options: {}", o.join(" | ")) };
            outln!("{id:10} {n:24} default {d:<10} range {lo}..={hi}  ({s}){o}");
        }
    }
    Ok(())
}

/// Prints the modes a strike would sound.
///
/// # Errors
/// As [`configured_host`].
pub fn print_modes(opts: &SoundOptions, note: u8, velocity: u8, json: bool) -> Result<(), String> {
    let modes = predicted_modes(opts, note, velocity)?;
    if modes.is_empty() {
        // An empty table is an answer, not an error; but say why the strike would be silent.
        warn(&format!(
            "no mode sounds at key {note}: every mode is over Nyquist ({} Hz at this sample rate) or does not ring (lower the key or raise --size)",
            opts.sample_rate / 2
        ));
    }
    if json {
        let v: Vec<_> = modes
            .iter()
            .map(|&(f, d, a)| serde_json::json!({"freq_hz": f, "decay_per_s": d, "gain": a, "t60_s": 6.91 / d}))
            .collect();
        outln!("{}", serde_json::to_string_pretty(&v).map_err(|e| e.to_string())?);
    } else {
        outln!("{:>12} {:>12} {:>10} {:>12}", "freq_hz", "decay_per_s", "t60_s", "gain");
        for (f, d, a) in modes {
            outln!("{f:12.3} {d:12.4} {:10.3} {a:12.6}", 6.91 / d);
        }
    }
    Ok(())
}

/// `(freq_hz, decay_per_s, gain)` of the modes a note would sound, as the engine computes them.
///
/// # Errors
/// As [`configured_host`], or a key above 127.
pub fn predicted_modes(opts: &SoundOptions, note: u8, velocity: u8) -> Result<Vec<(f64, f64, f32)>, String> {
    if note > 127 || velocity == 0 || velocity > 127 {
        return Err("--note must be 0..=127 and --velocity 1..=127".into());
    }
    let mut host = configured_host(opts, 64)?;
    let plugin = host.plugin_mut();
    let mut strike = plugin.strike_for(note, f32::from(velocity) / 127.0);
    if let Some(p) = opts.position {
        strike.position = p;
    }
    // The tuning the note gets when played (Pitch reference: Strongest mode).
    plugin.tune_to_strongest(note, &mut strike);
    let engine = plugin.engine().ok_or("the plugin did not activate")?;
    Ok(engine.predict_modes(engine.object(), strike))
}
