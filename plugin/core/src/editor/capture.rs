//! Capture panel: recordings in (path field, built-in browser, dropped files), the estimator
//! on a background thread, the fit shown as in Sterling's thesis Fig. 4.5, and the actions.

use super::logic;
use super::panel::{apply_damping, PanelCtx};
use super::plot::{series_color, Axis, Plot};
use crate::params::StruckParams;
use crate::shared::{CaptureRecord, CapturedObject, Clip, EditorShared};
use egui::{self, Color32, RichText, Stroke};
use estimator::features::MAX_MIN_DECAY_PER_S;
use estimator::{EstimateReport, Method, ModelKind};
use presets::{DampingSpec, Material, SCHEMA_VERSION};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::sync::{Arc, Mutex, PoisonError};

/// One entry of the built-in file browser.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Entry {
    pub path: PathBuf,
    pub is_dir: bool,
}

/// A running analysis.
pub(super) struct Job {
    /// Progress 0..1 as `f32` bits.
    progress: Arc<AtomicU32>,
    cancel: Arc<AtomicBool>,
    result: Arc<Mutex<Option<Result<EstimateReport, String>>>>,
    files: Vec<PathBuf>,
    object: Option<CapturedObject>,
}

/// Where a background job leaves its result: `None` until done, then the samples or an error.
type JobResult = Arc<Mutex<Option<Result<Vec<f32>, String>>>>;

/// A clip being built for the A/B comparison.
pub(super) struct AbJob {
    side: super::ab::Side,
    result: JobResult,
}

/// Capture panel state.
pub(super) struct CapturePanel {
    pub files: Vec<PathBuf>,
    pub path_text: String,
    pub browse_dir: PathBuf,
    pub entries: Option<Vec<Entry>>,
    pub model: ModelKind,
    pub method: Method,
    pub recorded_object: bool,
    /// Partials decaying slower than this (1/s) are taken as steady hum (the CLI's
    /// `--min-decay`; the extractor's default 0.05, a T60 of 138 s).
    pub min_decay_per_s: f64,
    pub job: Option<Job>,
    pub message: Option<String>,
    pub save_name: String,
    pub apply_method: Option<Method>,
    /// The impact the A/B buttons play (index into the report's impacts).
    pub ab_impact: usize,
    pub ab_job: Option<AbJob>,
    /// What the last A/B button queued (for the label and the tests).
    pub ab_last: Option<(super::ab::Side, usize)>,
}

impl Default for CapturePanel {
    fn default() -> Self {
        let browse_dir = std::env::var_os("HOME")
            .map(PathBuf::from)
            .or_else(|| std::env::current_dir().ok())
            .unwrap_or_else(|| PathBuf::from("/"));
        CapturePanel {
            files: Vec::new(),
            path_text: String::new(),
            browse_dir,
            entries: None,
            model: ModelKind::Rayleigh,
            method: Method::Emg,
            recorded_object: false,
            min_decay_per_s: estimator::features::ExtractOptions::default().min_decay_per_s,
            job: None,
            message: None,
            save_name: "My material".into(),
            apply_method: None,
            ab_impact: 0,
            ab_job: None,
            ab_last: None,
        }
    }
}

/// Sub-folders (with `..` first) and `.wav` files of `dir`, folders first, by name.
pub(super) fn list_dir(dir: &Path) -> Vec<Entry> {
    let mut out: Vec<Entry> = std::fs::read_dir(dir)
        .map(|rd| {
            rd.filter_map(Result::ok)
                .filter_map(|e| {
                    let path = e.path();
                    let hidden = path.file_name().is_some_and(|n| n.to_string_lossy().starts_with('.'));
                    let is_dir = path.is_dir();
                    let wav = path.extension().is_some_and(|x| x.eq_ignore_ascii_case("wav"));
                    (!hidden && (is_dir || wav)).then_some(Entry { path, is_dir })
                })
                .collect()
        })
        .unwrap_or_default();
    out.sort_by(|a, b| b.is_dir.cmp(&a.is_dir).then_with(|| a.path.cmp(&b.path)));
    if let Some(parent) = dir.parent() {
        out.insert(0, Entry { path: parent.to_path_buf(), is_dir: true });
    }
    out
}

impl CapturePanel {
    /// Adds a recording (no duplicates). `Err` says why not.
    pub fn add_file(&mut self, path: PathBuf) -> Result<(), String> {
        if !path.is_file() {
            return Err(format!("{} is not a file", path.display()));
        }
        if !path.extension().is_some_and(|x| x.eq_ignore_ascii_case("wav")) {
            return Err(format!("{} is not a .wav file", path.display()));
        }
        if !self.files.contains(&path) {
            self.files.push(path);
        }
        Ok(())
    }

    pub fn is_running(&self) -> bool {
        self.job.is_some()
    }

    /// Adds files dropped on the window (when the windowing layer delivers them).
    pub fn add_dropped_files(&mut self, dropped: Vec<PathBuf>) {
        for p in dropped {
            if let Err(e) = self.add_file(p) {
                self.message = Some(e);
            }
        }
    }

    /// Starts the estimator on a background thread; `object` is the bank the recordings were
    /// made of, if known.
    fn start(&mut self, object: Option<&presets::Bank>) {
        let object_lambdas = object.map(|b| b.lambdas.clone());
        let object_gains = object.map(presets::Bank::max_gains);
        let captured =
            object.map(|b| CapturedObject { id: b.id.clone(), specific_modulus: b.reference.specific_modulus });
        if self.job.is_some() || self.files.is_empty() {
            return;
        }
        let progress = Arc::new(AtomicU32::new(0f32.to_bits()));
        let cancel = Arc::new(AtomicBool::new(false));
        let result = Arc::new(Mutex::new(None));
        let files = self.files.clone();
        let opts = estimator::Options {
            model: self.model,
            method: self.method,
            object_lambdas,
            object_gains,
            extract: estimator::features::ExtractOptions {
                min_decay_per_s: self.min_decay_per_s.clamp(0.0, MAX_MIN_DECAY_PER_S),
                ..estimator::features::ExtractOptions::default()
            },
            ..estimator::Options::default()
        };
        let (p, c, r, f) = (progress.clone(), cancel.clone(), result.clone(), files.clone());
        let spawned = std::thread::Builder::new().name("struck-estimator".into()).spawn(move || {
            let out = estimator::estimate(&f, &opts, &|x| p.store(x.clamp(0.0, 1.0).to_bits(), Ordering::Relaxed), &c)
                .map_err(|e| e.to_string());
            *r.lock().unwrap_or_else(PoisonError::into_inner) = Some(out);
        });
        match spawned {
            Ok(_) => {
                self.message = None;
                self.job = Some(Job { progress, cancel, result, files, object: captured });
            }
            Err(e) => self.message = Some(format!("could not start the estimator: {e}")),
        }
    }

    /// Picks up a finished analysis (never blocks: `try_lock`).
    pub fn poll(&mut self, params: &StruckParams) {
        let Some(job) = &self.job else { return };
        let done = match job.result.try_lock() {
            Ok(mut g) => g.take(),
            Err(_) => None,
        };
        let Some(out) = done else { return };
        let files: Vec<String> = job.files.iter().map(|f| f.display().to_string()).collect();
        let object = job.object.clone();
        self.job = None;
        match out {
            Ok(report) => {
                self.apply_method = None;
                self.ab_impact = 0;
                let object = if report.object.is_some() { object } else { None };
                *params.capture.lock().unwrap_or_else(PoisonError::into_inner) =
                    Some(CaptureRecord { files, report, object });
            }
            Err(e) => self.message = Some(e),
        }
    }

    /// Waits for a running analysis to end and picks it up (tests, and closing the plugin).
    pub fn wait(&mut self, params: &StruckParams) {
        while self.job.is_some() {
            std::thread::sleep(std::time::Duration::from_millis(5));
            self.poll(params);
        }
    }
}

fn method_color(m: Method) -> Color32 {
    match m {
        Method::Emg => Color32::from_rgb(255, 190, 60),
        Method::Lsq => Color32::from_rgb(80, 200, 255),
        Method::Lb => Color32::from_rgb(230, 110, 230),
        Method::Ren => Color32::from_rgb(120, 230, 120),
    }
}

/// The material a capture saves: the chosen law, with its provenance, and the specific
/// modulus γ = (γ/γ₀)·γ₀ when the recordings were matched to a known object (Ren §5), so
/// *Material sets pitch* plays it at the recording's pitch on that object.
pub(super) fn captured_material(
    name: &str,
    rec: &CaptureRecord,
    fit: &estimator::FitResult,
    library: &crate::library::Library,
) -> Material {
    let names: Vec<&str> =
        rec.files.iter().map(|f| Path::new(f).file_name().and_then(|n| n.to_str()).unwrap_or(f.as_str())).collect();
    Material {
        schema_version: SCHEMA_VERSION,
        id: logic::kebab_id("captured", name),
        name: if name.trim().is_empty() { "Captured material".into() } else { name.trim().to_string() },
        provenance: format!(
            "Struck editor capture: {} fit ({}) of {} features from {} impacts in {}",
            fit.model.name(),
            fit.method.name(),
            rec.report.n_points,
            rec.report.impacts.len(),
            names.join(", ")
        ),
        specific_modulus: rec.specific_modulus(),
        damping: DampingSpec::from_damping(&fit.damping()),
        notes: rec.report.warnings.join("; "),
        support: rec.report.support_for(fit).map(|mean_c_per_s| presets::SupportDamping {
            mean_c_per_s,
            recorded_modes: rec.recorded_modes(fit, library),
        }),
        residual: capture_residual(rec, fit).unwrap_or(None),
    }
}

/// The residual of the capture's first impact for `fit` (Ren §6.1), its recording read
/// again from its file (the capture keeps no audio); `Ok(None)` without impacts.
///
/// # Errors
/// The recording cannot be read any more (one line).
pub(super) fn capture_residual(
    rec: &CaptureRecord,
    fit: &estimator::FitResult,
) -> Result<Option<presets::residual::ResidualSpectrogram>, String> {
    let Some(imp) = rec.report.impacts.first() else { return Ok(None) };
    crate::residual_layer::capture_residual(
        &rec.report,
        Path::new(&imp.file),
        None,
        &fit.damping(),
        rec.report.support_for(fit).unwrap_or(0.0),
    )
    .map_err(|e| format!("no residual kept: {e}"))
}

impl CapturePanel {
    /// Draws the panel: recordings, analysis options, results. Returns whether a user material
    /// was saved (the material panel then lists its folder again).
    pub fn show(&mut self, ui: &mut egui::Ui, cx: &PanelCtx) -> bool {
        ui.heading("Capture a material from recordings");
        let hovering = ui.ctx().input(|i| !i.raw.hovered_files.is_empty());
        if hovering {
            ui.colored_label(Color32::from_rgb(255, 190, 60), "Drop WAV files to add them");
        }
        ui.columns(2, |cols| {
            self.capture_inputs(&mut cols[0]);
            self.capture_run(&mut cols[1], cx);
        });
        ui.separator();
        self.capture_results(ui, cx)
    }

    fn capture_inputs(&mut self, ui: &mut egui::Ui) {
        let c = self;
        ui.label(RichText::new("Recordings").strong());
        let mut remove = None;
        for (i, f) in c.files.iter().enumerate() {
            ui.horizontal(|ui| {
                if ui.small_button("x").on_hover_text("Remove").clicked() {
                    remove = Some(i);
                }
                ui.label(f.file_name().map_or_else(|| f.display().to_string(), |n| n.to_string_lossy().into_owned()))
                    .on_hover_text(f.display().to_string());
            });
        }
        if let Some(i) = remove {
            c.files.remove(i);
        }
        if c.files.is_empty() {
            ui.label(RichText::new("None yet: type a path, browse, or drop WAV files here.").weak());
        }
        ui.horizontal(|ui| {
            let edit = ui
                .add(egui::TextEdit::singleline(&mut c.path_text).hint_text("/path/to/taps.wav").desired_width(220.0))
                .accessible_name("Recording path");
            let enter = edit.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter));
            if ui.button("Add").clicked() || enter {
                let path = PathBuf::from(c.path_text.trim());
                match c.add_file(path) {
                    Ok(()) => {
                        c.path_text.clear();
                        c.message = None;
                    }
                    Err(e) => c.message = Some(e),
                }
            }
        });
        egui::CollapsingHeader::new("Browse").default_open(true).show(ui, |ui| {
            ui.label(RichText::new(c.browse_dir.display().to_string()).weak());
            if c.entries.is_none() {
                c.entries = Some(list_dir(&c.browse_dir));
            }
            let mut go = None;
            let mut add = None;
            egui::ScrollArea::vertical().id_salt("browser").max_height(160.0).show(ui, |ui| {
                for (i, e) in c.entries.iter().flatten().enumerate() {
                    let name = if i == 0 && c.browse_dir.parent() == Some(e.path.as_path()) {
                        ".. (up)".to_string()
                    } else {
                        let n = e
                            .path
                            .file_name()
                            .map_or_else(|| e.path.display().to_string(), |n| n.to_string_lossy().into_owned());
                        if e.is_dir {
                            format!("{n}/")
                        } else {
                            n
                        }
                    };
                    if ui.selectable_label(false, name).clicked() {
                        if e.is_dir {
                            go = Some(e.path.clone());
                        } else {
                            add = Some(e.path.clone());
                        }
                    }
                }
            });
            if let Some(d) = go {
                c.browse_dir = d;
                c.entries = None;
            }
            if let Some(f) = add {
                if let Err(e) = c.add_file(f) {
                    c.message = Some(e);
                }
            }
        });
    }

    fn capture_run(&mut self, ui: &mut egui::Ui, cx: &PanelCtx) {
        let lib = cx.library;
        let object = logic::object_index(cx.params, lib);
        let c = self;
        ui.label(RichText::new("Analysis").strong());
        egui::Grid::new("capture-options").num_columns(2).show(ui, |ui| {
            ui.label("Damping model");
            egui::ComboBox::from_id_salt("capture-model").selected_text(c.model.name()).show_ui(ui, |ui| {
                for m in [ModelKind::Rayleigh, ModelKind::Hybrid, ModelKind::Power, ModelKind::Caughey] {
                    ui.selectable_value(&mut c.model, m, m.name());
                }
            });
            ui.end_row();
            ui.label("Chosen fit");
            egui::ComboBox::from_id_salt("capture-method").selected_text(c.method.name()).show_ui(ui, |ui| {
                for m in [Method::Emg, Method::Lsq, Method::Lb, Method::Ren] {
                    ui.selectable_value(&mut c.method, m, m.name());
                }
            });
            ui.end_row();
            ui.label("Minimum decay");
            ui.add(
                egui::DragValue::new(&mut c.min_decay_per_s)
                    .range(0.0..=MAX_MIN_DECAY_PER_S)
                    .speed(0.001)
                    .max_decimals(3)
                    .suffix(" 1/s"),
            )
            .accessible_name("Minimum decay, 1/s")
            .on_hover_text(
                "Partials decaying slower than this are taken as steady hum (0.05 1/s: a T60 of 138 s); \
                 lower it for an object that rings for minutes",
            );
            ui.end_row();
        });
        if let Some(o) = object {
            ui.checkbox(
                &mut c.recorded_object,
                format!("Recordings are of the current object ({})", lib.banks[o].name),
            );
        }
        let running = c.job.is_some();
        ui.horizontal(|ui| {
            let analyse = ui.add_enabled(!running && !c.files.is_empty(), egui::Button::new("Analyse"));
            if analyse.clicked() {
                let bank = if c.recorded_object { object.map(|o| &lib.banks[o]) } else { None };
                c.start(bank);
            }
            if ui.add_enabled(running, egui::Button::new("Cancel")).clicked() {
                if let Some(j) = &c.job {
                    j.cancel.store(true, Ordering::Relaxed);
                }
            }
        });
        if let Some(j) = &c.job {
            let p = f32::from_bits(j.progress.load(Ordering::Relaxed));
            ui.add(egui::ProgressBar::new(p).show_percentage().animate(true));
        }
        if let Some(m) = &c.message {
            ui.colored_label(Color32::from_rgb(255, 170, 60), m.as_str());
        }
    }

    /// The last capture's report, its fits, A/B, Apply and Save; returns whether a material was
    /// saved.
    fn capture_results(&mut self, ui: &mut egui::Ui, cx: &PanelCtx) -> bool {
        let params = cx.params.clone();
        let mut saved = false;
        // GUI thread only (and the host's state save, on this same thread): never the audio.
        let guard = params.capture.lock().unwrap_or_else(PoisonError::into_inner);
        let Some(rec) = guard.as_ref() else {
            ui.label(RichText::new("No capture yet.").weak());
            return false;
        };
        let r = &rec.report;
        ui.label(RichText::new("Results").strong());
        let recommended = r.comparison.as_ref().map(|c| {
            let bic = c.delta_bic.map_or(String::new(), |d| format!(" (ΔBIC hybrid − Rayleigh = {d:.1})"));
            format!("recommended model: {}{bic}", c.recommended.name())
        });
        ui.label(format!(
            "{} features from {} impacts in {} file(s); chosen {} fit of {}; {}",
            r.n_points,
            r.impacts.len(),
            r.files.len(),
            r.method.name(),
            r.model,
            recommended.unwrap_or_else(|| "no model comparison".into())
        ));
        if let Some(o) = &r.object {
            ui.label(format!("object match: {o:?}"));
        }
        egui::CollapsingHeader::new(format!("Impacts per file ({} skipped)", r.skipped.len()))
            .default_open(false)
            .show(ui, |ui| {
                egui::Grid::new("capture-files").striped(true).show(ui, |ui| {
                    ui.label("file");
                    ui.label("found");
                    ui.label("used");
                    ui.label("noise floor");
                    ui.end_row();
                    for f in &r.files {
                        ui.label(
                            Path::new(&f.file).file_name().map_or(f.file.clone(), |n| n.to_string_lossy().into_owned()),
                        );
                        ui.label(f.impacts_found.to_string());
                        ui.label(f.impacts_used.to_string());
                        ui.label(format!("{:.1} dBFS", f.noise_floor_db));
                        ui.end_row();
                    }
                });
                for s in &r.skipped {
                    ui.label(format!("skipped {} @ {:.3} s: {}", s.file, s.onset_s, s.reason));
                }
            });
        for w in &r.warnings {
            ui.colored_label(Color32::from_rgb(255, 170, 60), format!("warning: {w}"));
        }

        // (λ, c) scatter coloured by impact, and the fitted curves (thesis Fig. 4.5).
        let pts: Vec<(f64, f64, usize)> = r
            .impacts
            .iter()
            .enumerate()
            .flat_map(|(i, imp)| imp.features.iter().map(move |f| (f.lambda(), f.c(), i)))
            .filter(|p| p.0 > 0.0 && p.1 > 0.0)
            .collect();
        let (lmin, lmax) = pts.iter().fold((f64::INFINITY, 0.0f64), |(a, b), p| (a.min(p.0), b.max(p.0)));
        let (cmin, cmax) = pts.iter().fold((f64::INFINITY, 0.0f64), |(a, b), p| (a.min(p.1), b.max(p.1)));
        if pts.is_empty() {
            ui.label("No (λ, c) points with c > 0 to plot.");
        } else {
            let x = Axis::log(lmin / 2.0, lmax * 2.0);
            let y = Axis::log(cmin / 3.0, cmax * 3.0);
            let (plot, _, painter) = Plot::show(ui, 260.0, x, y, "λ (rad²/s²)", "c (1/s)", "Capture scatter");
            for &(l, c, i) in &pts {
                plot.dot(&painter, l, c, 2.5, series_color(i, r.impacts.len()));
            }
            for f in &r.fits {
                let n = 120;
                let curve: Vec<(f64, f64)> = (0..n)
                    .map(|k| {
                        let l = ((x.lo.ln()) + (x.hi.ln() - x.lo.ln()) * f64::from(k) / f64::from(n - 1)).exp();
                        (l, f.c(l))
                    })
                    .collect();
                let width = if f.method == r.method { 2.5 } else { 1.5 };
                plot.line(&painter, &curve, Stroke::new(width, method_color(f.method)));
            }
            ui.horizontal(|ui| {
                for f in &r.fits {
                    ui.colored_label(method_color(f.method), format!("— {}", f.method.name()));
                }
                ui.label(RichText::new("dots: features, one colour per impact").weak());
            });
        }

        // Parameters with their standard errors, one row per method.
        egui::Grid::new("capture-fits").striped(true).show(ui, |ui| {
            ui.label("fit");
            ui.label("parameters ± standard error (SI)");
            ui.label("σ");
            ui.label("noise");
            ui.label("BIC");
            ui.end_row();
            for f in &r.fits {
                let sel = self.apply_method.unwrap_or(r.method) == f.method;
                if ui.selectable_label(sel, f.method.name()).on_hover_text("Use this fit for Apply and Save").clicked()
                {
                    self.apply_method = Some(f.method);
                }
                let ps: Vec<String> = f
                    .params
                    .iter()
                    .zip(f.std_errors.iter().chain(std::iter::repeat(&None)))
                    .map(|(v, e)| match e {
                        Some(e) => format!("{v:.4e} ± {e:.2e}"),
                        None => format!("{v:.4e}"),
                    })
                    .collect();
                ui.label(ps.join(", "));
                ui.label(format!("{:.3}", f.sigma));
                ui.label(f.noise_scale.map_or("–", |s| s.describe()));
                ui.label(f.bic.map_or("–".into(), |b| format!("{b:.1}")));
                ui.end_row();
            }
        });

        let method = self.apply_method.unwrap_or(r.method);
        let fit = r.fits.iter().find(|f| f.method == method).unwrap_or(&r.chosen).clone();
        let rec = rec.clone();
        drop(guard);
        self.ab_row(ui, cx, &rec, &fit);
        ui.horizontal(|ui| {
            if ui
                .button("Apply")
                .on_hover_text("Set the Custom material to this fit (one host gesture per parameter)")
                .clicked()
            {
                let custom = cx.library.custom_material_index();
                let support = rec.report.support_for(&fit).unwrap_or(0.0);
                match apply_damping(&params, custom, cx.setter, &fit.damping(), support) {
                    Ok(()) => {
                        // Its support recorded mode by mode on the recorded object (issue 10
                        // part 6); none of an earlier capture's if it cannot be kept.
                        let recorded = rec.report.support_for(&fit).and(rec.recorded_modes(&fit, cx.library));
                        let held = params.user_support.set_source(recorded).map(|m| m.modes);
                        if held.is_err() {
                            let _ = params.user_support.set_source(None);
                        }
                        // The capture's residual goes with its law (issue 15).
                        let kept = capture_residual(&rec, &fit)
                            .and_then(|r| params.user_residual.set_source(r).map(|()| params.user_residual.is_set()));
                        if kept.is_err() {
                            // No residual for this law: none of an earlier one either.
                            let _ = params.user_residual.set_source(None);
                        }
                        let mut message = match kept {
                            Ok(true) => {
                                format!("applied the {} fit and its residual to the Custom material", fit.method.name())
                            }
                            Ok(false) => format!("applied the {} fit to the Custom material", fit.method.name()),
                            Err(e) => format!("applied the {} fit to the Custom material; {e}", fit.method.name()),
                        };
                        match held {
                            Ok(0) => {}
                            Ok(n) => message += &format!(", with the support of {n} modes as recorded"),
                            Err(e) => message += &format!("; no per-mode support kept: {e}"),
                        }
                        self.message = Some(message);
                    }
                    Err(e) => self.message = Some(e),
                }
            }
            ui.add(egui::TextEdit::singleline(&mut self.save_name).desired_width(160.0));
            let dir = cx.material_dir.to_path_buf();
            if ui.button("Save material").on_hover_text(format!("Write a user material to {}", dir.display())).clicked()
            {
                let m = captured_material(&self.save_name, &rec, &fit, cx.library);
                let path = dir.join(format!("{}.json", m.id));
                // A user material loads into the Custom knobs: one they cannot hold would be
                // written only to be refused when chosen (as `struck estimate` refuses it).
                let out = params
                    .custom_knobs_for(&fit.damping())
                    .map_err(|e| {
                        format!("not saved: the {} fit is beyond what the plugin plays ({e})", fit.method.name())
                    })
                    .and_then(|_| {
                        std::fs::create_dir_all(&dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))
                    })
                    .and_then(|()| m.save(&path).map_err(|e| e.to_string()));
                self.message = Some(match out {
                    Ok(()) => format!("saved {}", path.display()),
                    Err(e) => e,
                });
                saved = true;
            }
            if ui.button("Clear").on_hover_text("Forget this capture").clicked() {
                *params.capture.lock().unwrap_or_else(PoisonError::into_inner) = None;
            }
        });
        saved
    }

    /// A/B: pick an impact, play the recording or a resynthesis of it (built on a worker
    /// thread, played by the audio thread's clip player).
    fn ab_row(&mut self, ui: &mut egui::Ui, cx: &PanelCtx, rec: &CaptureRecord, fit: &estimator::FitResult) {
        let impacts = &rec.report.impacts;
        if impacts.is_empty() {
            return;
        }
        let c = self;
        c.ab_impact = c.ab_impact.min(impacts.len() - 1);
        let name = |i: usize| {
            let imp = &impacts[i];
            let file = Path::new(&imp.file).file_name().map_or(imp.file.clone(), |n| n.to_string_lossy().into_owned());
            format!("{file} @ {:.2} s ({} modes)", imp.onset_s, imp.features.len())
        };
        let mut clicked = None;
        ui.horizontal(|ui| {
            ui.label(RichText::new("A/B").strong());
            egui::ComboBox::from_id_salt("ab-impact").selected_text(name(c.ab_impact)).show_ui(ui, |ui| {
                for i in 0..impacts.len() {
                    ui.selectable_value(&mut c.ab_impact, i, name(i));
                }
            });
            let busy = c.ab_job.is_some();
            for side in [
                super::ab::Side::Recording,
                super::ab::Side::Modes,
                super::ab::Side::ModesResidual,
                super::ab::Side::Object,
            ] {
                let hint = match side {
                    super::ab::Side::Recording => "Play this impact of the recording",
                    super::ab::Side::Modes => "Play the impact's own modes with the fitted decay law",
                    super::ab::Side::ModesResidual => {
                        "Play the impact's own modes with the fitted decay law and its residual (contact, noise), \
                         transferred as the instrument plays it"
                    }
                    super::ab::Side::Object => "Strike the current object with the fitted material",
                };
                if ui.add_enabled(!busy, egui::Button::new(side.label())).on_hover_text(hint).clicked() {
                    clicked = Some(side);
                }
            }
            if ui.button("Stop").clicked() {
                cx.shared.stop_clip();
            }
            if cx.shared.clip_playing.load(Ordering::Relaxed) {
                ui.label(RichText::new("playing").weak());
            }
        });
        let Some(side) = clicked else { return };
        let imp = &impacts[c.ab_impact];
        let lib = cx.library;
        let Some(o) = logic::object_index(cx.params, lib) else { return };
        let bank = &lib.banks[o];
        // The recorded object's γ/γ₀ plays it at the recording's pitch only on that object.
        let gamma_ratio = match (&rec.object, &rec.report.object) {
            (Some(ob), Some(m)) if ob.id == bank.id => Some(m.gamma_ratio),
            _ => None,
        };
        let p = cx.params;
        let req = super::ab::AbRequest {
            side,
            file: PathBuf::from(&imp.file),
            onset_s: imp.onset_s,
            duration_s: imp.duration_s,
            features: imp.features.clone(),
            damping: fit.damping(),
            object: crate::library::engine_object(bank),
            params: dsp::engine::SoundParams {
                hardness: p.hardness.value(),
                noise: p.noise.value(),
                velocity_sensitivity: p.velocity_sensitivity.value(),
                quality_db: p.quality_db.value(),
                ..dsp::engine::SoundParams::default()
            },
            position: p.strike_position.value(),
            gamma_ratio,
            rate: cx.shared.sample_rate(),
        };
        let result = Arc::new(Mutex::new(None));
        let r = result.clone();
        let spawned = std::thread::Builder::new().name("struck-ab".into()).spawn(move || {
            let out = super::ab::build(&req);
            *r.lock().unwrap_or_else(PoisonError::into_inner) = Some(out);
        });
        match spawned {
            Ok(_) => {
                c.ab_job = Some(AbJob { side, result });
                c.ab_last = Some((side, c.ab_impact));
            }
            Err(e) => c.message = Some(format!("could not start the A/B clip: {e}")),
        }
    }

    /// Hands a finished A/B clip to the audio thread and frees the clips it returned
    /// (never blocks: `try_lock`).
    pub fn poll_ab(&mut self, shared: &EditorShared) {
        shared.reclaim_clips();
        let Some(job) = &self.ab_job else { return };
        let done = match job.result.try_lock() {
            Ok(mut g) => g.take(),
            Err(_) => None,
        };
        let Some(out) = done else { return };
        let side = job.side;
        self.ab_job = None;
        match out {
            Ok(samples) => {
                if shared.play_clip(Clip::new(samples)).is_err() {
                    self.message = Some("the audio thread is not taking clips (is the plugin processing?)".into());
                } else if self.message.as_deref().is_some_and(|m| m.starts_with("A/B")) {
                    self.message = None;
                }
            }
            Err(e) => self.message = Some(format!("A/B {}: {e}", side.label())),
        }
    }

    /// Whether an A/B clip is being built.
    pub fn ab_busy(&self) -> bool {
        self.ab_job.is_some()
    }

    /// Waits for the A/B clip being built and queues it (for tests).
    pub fn wait_for_ab(&mut self, shared: &EditorShared) {
        while self.ab_job.is_some() {
            std::thread::sleep(std::time::Duration::from_millis(5));
            self.poll_ab(shared);
        }
    }
}
