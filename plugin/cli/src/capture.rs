//! `struck features` and `struck estimate`: the estimator on the command line (SCIENCE.md
//! §3–5). Progress goes to stderr; results are JSON.

use crate::cli::{end_progress_line, outln, show_progress, warn};
use estimator::features::MAX_MIN_DECAY_PER_S;
use presets::{output, DampingSpec, Material, SCHEMA_VERSION};
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use struck::library::Library;

/// Parses a lowercase serde name ("rayleigh", "emg", …) into an estimator enum.
fn parse_name<T: serde::de::DeserializeOwned>(what: &str, s: &str, known: &str) -> Result<T, String> {
    serde_json::from_value(serde_json::Value::String(s.to_lowercase()))
        .map_err(|_| format!("unknown {what} '{s}' (known: {known})"))
}

fn progress_printer(label: &'static str) -> impl Fn(f32) {
    let last = std::cell::Cell::new(-1i32);
    move |p: f32| {
        let pct = (p.clamp(0.0, 1.0) * 100.0) as i32;
        if pct / 5 != last.get() / 5 {
            last.set(pct);
            show_progress(&format!("{label}: {pct:3}%"));
            if pct >= 100 {
                end_progress_line();
            }
        }
    }
}

/// `struck features FILE... --json`.
///
/// # Errors
/// The estimator's one-line reason (unreadable file, silent recording, …).
pub fn features(files: &[PathBuf], channel: Option<usize>, json: bool, min_decay: Option<f64>) -> Result<(), String> {
    if files.is_empty() {
        return Err("give at least one WAV file".into());
    }
    let opts = estimator::Options { channel, extract: extract_options(min_decay)?, ..estimator::Options::default() };
    let cancel = AtomicBool::new(false);
    let report =
        estimator::extract_features(files, &opts, &progress_printer("features"), &cancel).map_err(|e| e.to_string())?;
    for w in &report.warnings {
        warn(w);
    }
    end_progress_line();
    for s in &report.skipped {
        eprintln!("skipped impact in {} at {:.3} s: {}", s.file, s.onset_s, s.reason);
    }
    if json {
        outln!("{}", serde_json::to_string_pretty(&report).map_err(|e| e.to_string())?);
    } else {
        for imp in &report.impacts {
            outln!("{} @ {:.3} s: {} features", imp.file, imp.onset_s, imp.features.len());
            for f in &imp.features {
                outln!("  {:10.2} Hz  d {:9.3} 1/s  a {:.3e}", f.freq_hz, f.decay_per_s, f.amplitude);
            }
        }
    }
    Ok(())
}

/// What `struck estimate` was asked.
pub struct EstimateArgs {
    /// Recordings.
    pub files: Vec<PathBuf>,
    /// Damping model name.
    pub model: String,
    /// Fit method name.
    pub method: String,
    /// Object the recordings were made of (id, name or index), if known.
    pub object: Option<String>,
    /// Channel to analyse (default: mix to mono).
    pub channel: Option<usize>,
    /// Material file to write.
    pub out: PathBuf,
    /// Report file to write.
    pub report: Option<PathBuf>,
    /// Keep no residual with the material.
    pub no_residual: bool,
    /// Partials decaying slower than this (1/s) are steady hum (default: the extractor's 0.05).
    pub min_decay_per_s: Option<f64>,
}

/// The feature extractor's options with `--min-decay` (1/s) if given.
///
/// # Errors
/// A decay that is not a number from 0 to under the extractor's fastest.
fn extract_options(min_decay: Option<f64>) -> Result<estimator::features::ExtractOptions, String> {
    let mut extract = estimator::features::ExtractOptions::default();
    if let Some(d) = min_decay {
        if !(d.is_finite() && (0.0..=MAX_MIN_DECAY_PER_S).contains(&d)) {
            return Err(format!("--min-decay {d}: takes a decay from 0 to {MAX_MIN_DECAY_PER_S} 1/s"));
        }
        extract.min_decay_per_s = d;
    }
    Ok(extract)
}

/// `struck estimate …`: fits the material and writes it (and the report).
///
/// The outputs are checked (writable folders, none of them an input, distinct) before the
/// analysis, and written through temporary files renamed only once both are complete: a
/// failed run leaves existing files untouched.
///
/// # Errors
/// Bad arguments, the estimator's reason, or unwritable outputs.
pub fn estimate(args: &EstimateArgs) -> Result<String, String> {
    if args.files.is_empty() {
        return Err("give at least one WAV file".into());
    }
    let model: estimator::ModelKind = parse_name("model", &args.model, "rayleigh, hybrid, power, caughey")?;
    let method: estimator::Method = parse_name("method", &args.method, "emg, lsq, lb, ren")?;
    let lib = Library::factory();
    let bank = match &args.object {
        Some(o) => match crate::cli::bank_file(&lib, o, true)? {
            Some(b) => Some(b),
            None => {
                let i = crate::cli::resolve_object(&lib, o)?;
                crate::cli::warn_user_bank(&lib, i, true);
                Some(lib.banks[i].clone())
            }
        },
        None => None,
    };
    // The outputs must be none of the inputs (recordings, a bank file) and distinct.
    let mut inputs: Vec<&Path> = args.files.iter().map(PathBuf::as_path).collect();
    if let Some(o) = args.object.as_deref().map(Path::new).filter(|p| p.is_file()) {
        inputs.push(o);
    }
    let mut outputs = vec![args.out.as_path()];
    outputs.extend(args.report.as_deref());
    output::check_distinct(&outputs).map_err(|e| e.to_string())?;
    for out in &outputs {
        output::check_output(out, &inputs, output::Kind::Json).map_err(|e| e.to_string())?;
    }
    let bank = bank.as_ref();
    let opts = estimator::Options {
        model,
        method,
        channel: args.channel,
        object_lambdas: bank.map(|b| b.lambdas.clone()),
        object_gains: bank.map(presets::Bank::max_gains),
        extract: extract_options(args.min_decay_per_s)?,
        ..estimator::Options::default()
    };
    let cancel = AtomicBool::new(false);
    let report =
        estimator::estimate(&args.files, &opts, &progress_printer("estimate"), &cancel).map_err(|e| e.to_string())?;
    for w in &report.warnings {
        warn(w);
    }
    // What was left out, as `features` says it (a tester's second file, a hum, gave nothing
    // to the fit and only the report said so).
    end_progress_line();
    for s in report.skipped.iter().filter(|s| !estimator::segment::is_precursor(&s.reason)) {
        eprintln!("skipped impact in {} at {:.3} s: {}", s.file, s.onset_s, s.reason);
    }
    for f in report.files.iter().filter(|f| f.impacts_used == 0) {
        warn(&format!(
            "{}: nothing from this file went into the fit ({} impact(s) found, none used)",
            f.file, f.impacts_found
        ));
    }
    let damping = report.damping();
    let stem = args.out.file_stem().and_then(|s| s.to_str()).unwrap_or("material");
    // (From the file's name: "a--b", "é" or "-" make no id by themselves.)
    let id = presets::kebab_id("captured", stem);
    let names: Vec<String> = args.files.iter().map(|f| f.display().to_string()).collect();
    // With a known object the fitted γ/γ₀ gives the material's specific modulus, so
    // "Material sets pitch" plays it at the recording's pitch on that object (Ren §5).
    let specific_modulus = match (bank, &report.object) {
        // (A pitch the instrument cannot play is none: the report says so.)
        (Some(b), Some(m)) if estimator::object::playable_gamma_ratio(m.gamma_ratio) => {
            Some(m.gamma_ratio * b.reference.specific_modulus)
        }
        _ => None,
    };
    // The residual of the first impact (issue 15; Ren §6.1), unless asked not to.
    let residual = if args.no_residual { None } else { capture_residual(&report, &args.files, args.channel) };
    let material = Material {
        schema_version: SCHEMA_VERSION,
        id,
        name: format!("Captured: {stem}"),
        provenance: format!(
            "Struck estimator: {} fit ({:?}) of {} features from {} impacts in {}",
            report.model,
            report.method,
            report.n_points,
            report.impacts.len(),
            names.join(", ")
        ),
        specific_modulus,
        damping: DampingSpec::from_damping(&damping),
        notes: report.warnings.join("; "),
        // The plugin plays it held as recorded by default (Support: As recorded); on the
        // recorded object, each matched mode with its own recorded excess (issue 10 part 6).
        support: report.support_c().map(|mean_c_per_s| presets::SupportDamping {
            mean_c_per_s,
            recorded_modes: bank.and_then(|b| struck::shared::recorded_modes(&report, &report.chosen, b)),
        }),
        residual,
    };
    material.validate().map_err(|e| format!("the fitted material is not valid ({e}); nothing was written"))?;
    // A captured material is played through the *Custom* material's knobs (`render
    // --material`, the editor's Apply): one they cannot hold is of no use to the plugin.
    // (The fits keep to the knobs' lower ends; a law past their upper ends — base damping
    // over 2000 s⁻¹ — is refused here rather than written and refused by `render`.)
    struck::params::StruckParams::new(&Library::factory())
        .custom_knobs_for(&damping)
        .map_err(|e| format!("the fitted law is beyond what the plugin plays ({e}); nothing was written"))?;
    // Both files are complete on disk before either replaces anything; a stream (a device, a
    // pipe) is written into first, so one that fails (`/dev/full`) leaves the files untouched.
    let mut files = vec![staged(&args.out, material.to_json().as_bytes())?];
    if let Some(path) = &args.report {
        let mut text = serde_json::to_string_pretty(&report).map_err(|e| e.to_string())?;
        text.push('\n');
        files.push(staged(path, text.as_bytes())?);
    }
    output::commit_all(files).map_err(|e| e.to_string())?;
    // Ren §5.2.2: how much of the recording the material represents (issue 15 part 1).
    let ren = report.ren_match.as_ref().map_or_else(String::new, |m| {
        format!(
            "; Ren match against its {}: R {:.2}, R~ {:.2}, product {:.2}",
            m.against, m.reference_ratio, m.estimated_ratio, m.product
        )
    });
    let ren_fit = report.ren_fit.as_ref().map_or_else(String::new, |r| {
        let emg = r.emg_hybrid.map_or_else(String::new, |e| format!(" (the EMG fit's {e:.4e})"));
        format!("; Ren's hybrid metric {:.4e}{emg} after {} evaluations", r.hybrid, r.evaluations)
    });
    let kept = material.residual.as_ref().map_or_else(String::new, |r| {
        format!("; kept the first impact's residual ({} frames, {:.1} KB)", r.frames, r.levels.len() as f64 / 1000.0)
    });
    let held = material.recorded_modes().map_or_else(String::new, |r| {
        format!("; support as recorded on {} mode by mode ({} modes matched)", r.object, r.modes.len())
    });
    let noise = report.chosen.noise_scale.map_or_else(String::new, |s| format!("; the EMG's noise {}", s.describe()));
    Ok(format!(
        "wrote {}: {} {:?} params {:?} from {} features in {} impacts{noise}{ren}{ren_fit}{kept}{held}",
        args.out.display(),
        report.model,
        report.method,
        material.damping.params,
        report.n_points,
        report.impacts.len()
    ))
}

/// The residual of `report`'s first impact as kept with its material
/// ([`struck::residual_layer::capture_residual`]; `None` without impacts).
///
/// A recording that cannot be read again keeps no residual (with a warning).
fn capture_residual(
    report: &estimator::EstimateReport,
    files: &[PathBuf],
    channel: Option<usize>,
) -> Option<presets::residual::ResidualSpectrogram> {
    let imp = report.impacts.first()?;
    // The report names the file as displayed (lossily for a name that is not UTF-8): read
    // back the input it names, not the name (a black-box tester's non-UTF-8 file name cost
    // the residual).
    let path = files
        .iter()
        .find(|f| f.display().to_string() == imp.file)
        .map_or_else(|| PathBuf::from(&imp.file), Clone::clone);
    struck::residual_layer::capture_residual(
        report,
        &path,
        channel,
        &report.damping(),
        report.support_c().unwrap_or(0.0),
    )
    .unwrap_or_else(|e| {
        warn(&format!("no residual kept: {e}"));
        None
    })
}

/// What `struck residual` was asked.
pub struct ResidualArgs {
    /// The recording.
    pub file: PathBuf,
    /// The material whose modes represent it.
    pub material: PathBuf,
    /// The WAV to write.
    pub out: PathBuf,
    /// Which impact, from 1.
    pub impact: usize,
    /// At most this much of the impact, s.
    pub seconds: f64,
    /// Analyse this channel only (default: mix to mono).
    pub channel: Option<usize>,
    /// `--min-decay` (1/s): partials decaying slower are steady hum (default 0.05).
    pub min_decay_per_s: Option<f64>,
}

/// `struck residual FILE --material M --out R.wav` (Ren 2013 §6.1; issue 15): the impact's
/// features, each weighted by how well the material's modes match it (Ren's R(φᵢ, Φ̃),
/// against the recording's own partials with the material's decays, its law plus its mean
/// support damping), with their phases fitted to the recording, make the represented sound;
/// the residual is the recording minus it ([`estimator::residual`]), written as a WAV (the
/// output is checked first and written through a temporary file).
///
/// # Errors
/// Bad arguments, an unreadable recording or material, no such impact, unwritable output.
pub fn residual(args: &ResidualArgs) -> Result<String, String> {
    if !(args.seconds.is_finite() && args.seconds > 0.0) {
        return Err(format!("--seconds {}: must be a positive number of seconds", args.seconds));
    }
    if args.impact == 0 {
        return Err("--impact counts from 1".into());
    }
    let inputs = [args.file.as_path(), args.material.as_path()];
    output::check_output(&args.out, &inputs, output::Kind::Wav).map_err(|e| e.to_string())?;
    // A factory material by id, name or index (as `render --material` takes), or a file.
    let lib = Library::factory();
    let material = match args.material.to_str() {
        Some(query) if !args.material.is_file() => match crate::cli::resolve_material(&lib, query, true)? {
            crate::cli::MaterialChoice::Factory(i) => lib.materials[i].clone(),
            crate::cli::MaterialChoice::File(m) => *m,
            crate::cli::MaterialChoice::Custom => return Err(
                "`custom` is the plugin's damping knobs, not a material: give a factory material or a material file"
                    .into(),
            ),
        },
        // A file (any path, UTF-8 or not).
        _ => crate::cli::load_material(&args.material, true)?,
    };
    let law = material.damping.to_damping().map_err(|e| format!("{}: {e}", args.material.display()))?;
    let support = material.support_c();
    let cancel = AtomicBool::new(false);
    let opts = estimator::Options {
        channel: args.channel,
        extract: extract_options(args.min_decay_per_s)?,
        ..estimator::Options::default()
    };
    let feats =
        estimator::extract_features(std::slice::from_ref(&args.file), &opts, &progress_printer("features"), &cancel)
            .map_err(|e| e.to_string())?;
    end_progress_line();
    let n = feats.impacts.len();
    let imp = feats
        .impacts
        .get(args.impact - 1)
        .ok_or_else(|| format!("--impact {}: the recording has {n} analysed impact(s)", args.impact))?;
    // (Only the impact's stretch is read: an impact in an hour-long session costs its seconds.)
    let (x, r, rec) =
        estimator::residual::read_impact_residual(&args.file, args.channel, imp, &law, support, args.seconds)
            .map_err(|e| e.to_string())?;
    let fs = f64::from(rec.sample_rate);
    let len = x.len();
    let energy = |v: &[f64]| v.iter().map(|s| s * s).sum::<f64>();
    let recorded = energy(&rec.samples[..len].iter().map(|&v| f64::from(v)).collect::<Vec<_>>());
    let share = energy(&x) / recorded.max(f64::MIN_POSITIVE);
    let spec = hound::WavSpec {
        channels: 1,
        sample_rate: rec.sample_rate,
        bits_per_sample: 32,
        sample_format: hound::SampleFormat::Float,
    };
    let mut bytes = std::io::Cursor::new(Vec::new());
    {
        let mut w = hound::WavWriter::new(&mut bytes, spec).map_err(|e| e.to_string())?;
        for v in &x {
            w.write_sample(*v as f32).map_err(|e| e.to_string())?;
        }
        w.finalize().map_err(|e| e.to_string())?;
    }
    output::write_atomically(&args.out, bytes.get_ref()).map_err(|e| e.to_string())?;
    Ok(format!(
        "wrote {}: impact {} of {n} at {:.3} s, {:.3} s; Ren match R {:.2}; the residual holds {:.1} % of the recording's energy",
        args.out.display(),
        args.impact,
        imp.onset_s,
        len as f64 / fs,
        r,
        100.0 * share
    ))
}

/// `bytes` written to a temporary file for `path`, not yet committed.
fn staged(path: &Path, bytes: &[u8]) -> Result<output::AtomicFile, String> {
    let mut f = output::AtomicFile::create(path).map_err(|e| e.to_string())?;
    f.write_all(bytes).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    Ok(f)
}

/// What `struck bank capture` was asked.
pub struct BankCaptureArgs {
    /// The recording.
    pub file: PathBuf,
    /// Which impact, from 1.
    pub impact: usize,
    /// Channel to analyse (default: the mix).
    pub channel: Option<usize>,
    /// At most this many modes, the strongest.
    pub modes: usize,
    /// Keep partials within this many dB of the strongest.
    pub range_db: f64,
    /// Keep partials whose quality factor Q = πf/d is at least this.
    pub min_q: f64,
    /// Keep partials below the strongest-energy one only within this many dB of its energy.
    pub below_db: f64,
    /// Partials decaying slower than this (1/s) are steady hum (default: the extractor's 0.05).
    pub min_decay_per_s: Option<f64>,
    /// Young's modulus (Pa) and density (kg/m³) of the recorded object.
    pub young: f64,
    /// Density, kg/m³.
    pub density: f64,
    /// Poisson's ratio.
    pub poisson: f64,
    /// The object's size, m (what *Size* 1 means).
    pub size_m: f64,
    /// The strike that made the recording, divided out when the bank is played (`None`:
    /// the amplitudes are played as mode shapes).
    pub recorded_strike: Option<presets::RecordedStrike>,
    /// Bank id and name.
    pub id: String,
    /// Display name.
    pub name: String,
    /// The bank JSON to write.
    pub out: PathBuf,
}

/// `--recorded-mallet`, `--recorded-hardness`, `--recorded-velocity` as the bank's
/// `recorded_strike` (`none`: no strike divided out).
///
/// # Errors
/// An unknown mallet or a hardness outside 0..=1 (one line).
pub fn recorded_strike(mallet: &str, hardness: f64, velocity: u8) -> Result<Option<presets::RecordedStrike>, String> {
    let mallet = mallet.trim().to_lowercase();
    if mallet == "none" {
        return Ok(None);
    }
    let strike = presets::RecordedStrike { mallet, hardness, velocity };
    strike.validate().map_err(|e| {
        format!("--recorded-mallet/--recorded-hardness/--recorded-velocity: {e} (or --recorded-mallet none)")
    })?;
    Ok(Some(strike))
}

/// Most modes `struck bank capture` keeps.
pub const MAX_CAPTURED_MODES: usize = 256;

/// `struck bank capture`: a bank of the recorded object's own modes (Ren et al. 2013 §6: the
/// recording's modes, played with any material): the partials Struck extracts from one impact
/// (frequency, decay → λ = ω² + d², the undamped eigenvalue), the strongest `modes` within
/// `range_db` of the strongest, in ascending λ, at one strike point with gains = their
/// amplitudes. Keys then tune the lowest of them; `estimate --object` with this bank records
/// each mode's support as recorded, so the object and its material both come from the
/// recordings. Writes through a temporary file; never over the recording.
///
/// # Errors
/// An unreadable recording, no impact (or fewer than `impact`), no partial, bad options, an
/// output that is the input or cannot be written (one line each).
pub fn bank_from_recording(args: &BankCaptureArgs) -> Result<String, String> {
    if !(1..=MAX_CAPTURED_MODES).contains(&args.modes) {
        return Err(format!("--modes {}: takes 1 to {MAX_CAPTURED_MODES}", args.modes));
    }
    if !(args.range_db.is_finite() && args.range_db > 0.0 && args.range_db <= 120.0) {
        return Err(format!("--range-db {}: takes a level above 0 and at most 120 dB", args.range_db));
    }
    if !(args.min_q.is_finite() && args.min_q >= 0.0 && args.min_q <= 1e4) {
        return Err(format!("--min-q {}: takes a quality factor from 0 to 10000", args.min_q));
    }
    if !(args.below_db.is_finite() && args.below_db >= 0.0 && args.below_db <= 200.0) {
        return Err(format!("--below-db {}: takes a level from 0 to 200 dB", args.below_db));
    }
    if !(args.size_m.is_finite() && args.size_m > 0.0 && args.size_m <= 100.0) {
        return Err(format!("--size {}: takes metres above 0 and at most 100", args.size_m));
    }
    if args.impact == 0 {
        return Err("--impact counts from 1".into());
    }
    let material = fem::Material { young: args.young, density: args.density, poisson: args.poisson };
    material.validate().map_err(|e| e.to_string())?;
    warn_material_units(&material);
    output::check_output(&args.out, &[args.file.as_path()], output::Kind::Json).map_err(|e| e.to_string())?;
    let opts = estimator::Options {
        channel: args.channel,
        extract: extract_options(args.min_decay_per_s)?,
        ..estimator::Options::default()
    };
    let cancel = AtomicBool::new(false);
    let feats =
        estimator::extract_features(std::slice::from_ref(&args.file), &opts, &progress_printer("capture"), &cancel)
            .map_err(|e| e.to_string())?;
    for w in &feats.warnings {
        warn(w);
    }
    let n = feats.impacts.len();
    let imp = feats.impacts.get(args.impact - 1).ok_or_else(|| {
        format!("{}: --impact {}, but the recording holds {n} impact(s)", args.file.display(), args.impact)
    })?;
    let (kept, dropped) = choose_modes(&imp.features, args);
    if kept.is_empty() {
        return Err(format!(
            "{}: impact {} holds no partial to make a mode of (none rings with Q >= {} within {} dB of the strongest)",
            args.file.display(),
            args.impact,
            args.min_q,
            args.range_db
        ));
    }
    let amax = kept.iter().fold(0.0f64, |m, f| m.max(f.amplitude));
    let file_name =
        args.file.file_name().map_or_else(|| args.file.display().to_string(), |s| s.to_string_lossy().into());
    let bank = presets::Bank {
        schema_version: SCHEMA_VERSION,
        id: args.id.clone(),
        name: args.name.clone(),
        description: format!(
            "The modes of a recorded object: {} partials of the impact at {:.3} s of {file_name}, at the one point it was struck. Its size {} m and material (E {:.3e} Pa, density {} kg/m^3) are as given when captured, for the mallet's contact and the pitch of a captured material.",
            kept.len(),
            imp.onset_s,
            args.size_m,
            args.young,
            args.density
        ),
        provenance: format!(
            "struck bank capture: partials extracted from {} (impact {}, within {} dB of the strongest, Q >= {}, below the strongest-energy partial only within {} dB of its energy, at most {})",
            args.file.display(),
            args.impact,
            args.range_db,
            args.min_q,
            args.below_db,
            args.modes
        ),
        reference: presets::BankReference {
            specific_modulus: args.young / args.density,
            poisson: args.poisson,
            density: args.density,
            dimensions_m: vec![args.size_m],
            size_m: args.size_m,
        },
        lambdas: kept.iter().map(|f| f.lambda()).collect(),
        points: vec![presets::StrikePoint {
            label: "as recorded".into(),
            xy: [0.5, 0.5],
            position_m: [0.0, 0.0, 0.0],
        }],
        gains: vec![kept.iter().map(|f| (f.amplitude / amax) as f32).collect()],
        mode_labels: kept.iter().map(|f| format!("{:.2} Hz", f.freq_hz)).collect(),
        surface: None,
        recorded_strike: args.recorded_strike.clone(),
    };
    bank.save(&args.out).map_err(|e| e.to_string())?;
    let mut said = format!(
        "wrote {}: {} modes of {file_name}'s impact {} (at {:.3} s), {:.1} Hz to {:.1} Hz",
        args.out.display(),
        kept.len(),
        args.impact,
        imp.onset_s,
        kept[0].freq_hz,
        kept[kept.len() - 1].freq_hz
    );
    if let Some(s) = &args.recorded_strike {
        said.push_str(&format!(
            "; played with a {} mallet at hardness {} and velocity {}, it sounds the recorded balance (that strike is divided out)",
            s.mallet, s.hardness, s.velocity
        ));
    }
    if dropped.low_q + dropped.below > 0 {
        said.push_str(&format!(
            "; left out {} partial(s) with Q under {} and {} below the strongest-energy one ({:.1} Hz) more than {} dB under its energy",
            dropped.low_q, args.min_q, dropped.below, dropped.pitch_hz, args.below_db
        ));
    }
    Ok(said)
}

/// What [`choose_modes`] left out, to say so.
struct Dropped {
    /// Partials under the Q floor.
    low_q: usize,
    /// Partials below the strongest-energy partial, too weak.
    below: usize,
    /// The strongest-energy partial's frequency, Hz.
    pitch_hz: f64,
}

/// The partials of one impact that become the bank's modes, in ascending λ.
///
/// A mode of the bank rings with the material's damping, not with the partial's own, so only
/// partials that ring are modes: Q = πf/d ≥ `min_q` (5 by default: a loss factor of at most
/// 0.2; the rumble under the note that the extractor also fits comes out at Q 1–4, the
/// mallet's thump at 8–20, real modes of wood at 15–150 and of metal far above). And keys
/// tune the lowest mode, so a partial below the one that carries most energy (a²/2d, the pitch the recording is
/// heard at) is kept only within `below_db` (20 dB) of its energy: on the 48 clips of tuned
/// bars, tines and pans in `tests/recordings` (FluidR3 and FreePats, whose samples state
/// their pitch), the captured bank's lowest mode is then the sample's note within a semitone
/// on 44 (on 5 when every partial within `range_db` was kept: 18–81 Hz partials at Q 1–2
/// under a kalimba's 348 Hz, up to 18× too sharp once tuned; `tests/recordings/capture.py`).
/// Of what is left, the `modes` strongest in amplitude within `range_db` of the strongest
/// that rings.
fn choose_modes<'a>(
    features: &'a [estimator::Feature],
    args: &BankCaptureArgs,
) -> (Vec<&'a estimator::Feature>, Dropped) {
    let q = |f: &estimator::Feature| std::f64::consts::PI * f.freq_hz / f.decay_per_s.max(f64::MIN_POSITIVE);
    let mut kept: Vec<&estimator::Feature> =
        features.iter().filter(|f| f.amplitude > 0.0 && f.lambda() > 0.0 && f.decay_per_s >= 0.0).collect();
    let n = kept.len();
    kept.retain(|f| q(f) >= args.min_q);
    let low_q = n - kept.len();
    let amax = kept.iter().fold(0.0f64, |m, f| m.max(f.amplitude));
    let floor = amax * 10f64.powf(-args.range_db / 20.0);
    kept.retain(|f| f.amplitude >= floor);
    let energy = |f: &estimator::Feature| f.amplitude * f.amplitude / (2.0 * f.decay_per_s.max(f64::MIN_POSITIVE));
    let pitch = kept.iter().copied().max_by(|a, b| energy(a).total_cmp(&energy(b)));
    let pitch_hz = pitch.map_or(0.0, |p| p.freq_hz);
    let n = kept.len();
    if let Some(p) = pitch {
        let e_floor = energy(p) * 10f64.powf(-args.below_db / 10.0);
        kept.retain(|f| f.freq_hz >= p.freq_hz || energy(f) >= e_floor);
    }
    let below = n - kept.len();
    kept.sort_by(|a, b| b.amplitude.total_cmp(&a.amplitude));
    kept.truncate(args.modes);
    kept.sort_by(|a, b| a.lambda().total_cmp(&b.lambda()));
    // Two partials at one λ would be one mode (the bank's eigenvalues ascend strictly).
    kept.dedup_by(|b, a| b.lambda() <= a.lambda());
    (kept, Dropped { low_q, below, pitch_hz })
}

/// Young's moduli under this (Pa) are softer than any solid an object is struck for (soft
/// rubber ≈ 1 MPa; the softest foams 0.1 MPa): most likely GPa or MPa typed as Pa.
const SOFTEST_YOUNG_PA: f64 = 1e5;
/// Densities under this (kg/m³) are lighter than solid foams (≈ 30 kg/m³ and up; aerogels
/// are ≈ 1–100): most likely g/cm³ typed as kg/m³.
const LIGHTEST_DENSITY: f64 = 20.0;

/// Warns about a modulus or a density in the wrong units (`bank build`, `bank tune`,
/// `bank capture`).
pub(crate) fn warn_material_units(m: &fem::Material) {
    if m.young < SOFTEST_YOUNG_PA {
        warn(&format!(
                "--young {} Pa is softer than any struck solid (soft rubber is about 1e6 Pa): --young takes pascals (steel 200e9, glass 63e9, oak 11e9)",
                m.young
            ));
    }
    if m.density < LIGHTEST_DENSITY {
        warn(&format!(
                "--density {} kg/m³ is lighter than any solid but an aerogel: --density takes kg/m³ (steel 7850, glass 2500, water 1000), not g/cm³",
                m.density
            ));
    }
}
