//! Struck's offline estimator: from recordings of a struck object to its material damping.
//!
//! Pipeline: WAV ([`load_wav`]) → impact segmentation ([`segment`]) → modal features per
//! impact ([`features`], Ren et al. 2013 §4, Sterling thesis §4.2.2) → (λ, c) points →
//! damping fit ([`fit_damping`]: EMG / LSQ / LB, thesis §4.2.3–4.2.6) → optional known-object
//! match ([`object`], Ren §5).
//!
//! Conventions: frequencies in Hz (`freq_hz`) or rad/s (ω); a feature decays as e^(−d t) with
//! d = `decay_per_s` in s⁻¹; λ = ω_d² + d² in rad²/s²; c = 2d in s⁻¹ (thesis eq. 4.2);
//! damping parameters in SI units as in `dsp::Damping`. Spectra in [`features`] are one-sided
//! real FFTs, unnormalised, bin k at k·fs/M Hz.
//!
//! Memory: each file is streamed and kept only as mono `f32`, at most an hour and
//! 192 Mi samples (768 MiB; [`wav::MAX_SAMPLES`]), one file at a time; longer files are
//! truncated with a warning.
//! Files are processed one at a time, so peak memory is one file plus per-impact work
//! buffers (a few × the impact length in `f64`, impacts are at most
//! `SegmentOptions::max_impact_s` = 6 s by default).
//!
//! Everything here allocates and may take seconds: run it on a background thread. Inputs
//! and outputs are `Send`; progress is reported through a callback (0..1) and a shared
//! `AtomicBool` cancels between impacts and inside long loops.

#![warn(missing_docs)]

pub mod error;
pub mod features;
pub mod fit;
pub mod linalg;
pub mod object;
pub mod optim;
pub mod psycho;
pub mod ren;
pub mod ren_fit;
pub mod residual;
pub mod segment;
#[doc(hidden)]
pub mod synth;
pub mod transfer;
pub mod wav;

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};

use serde::{Deserialize, Serialize};

pub use error::{EstimateError, Silence};
pub use features::{ExtractOptions, Feature, ImpactFit};
pub use fit::{fit_damping, fit_damping_weighted, FitParams, FitResult, Method, ModelKind};
pub use object::{ModeSupport, ObjectMatch};
pub use segment::SegmentOptions;
pub use wav::Recording;

/// What to estimate and how. `Default`: Rayleigh, EMG, all channels mixed, no object.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Options {
    /// Damping model to fit.
    pub model: ModelKind,
    /// Fitting method whose result is the chosen one.
    pub method: Method,
    /// Channel to analyse (0-based); `None` mixes all channels to mono.
    pub channel: Option<usize>,
    /// Reference eigenvalues λᵢ⁰ (rad²/s²) of the recorded object's bank, if known.
    pub object_lambdas: Option<Vec<f64>>,
    /// Per-mode gains of that bank (same order), for the amplitude scale.
    pub object_gains: Option<Vec<f64>>,
    /// Segmentation thresholds.
    pub segment: SegmentOptions,
    /// Feature-extraction thresholds.
    pub extract: ExtractOptions,
}

/// Features of one impact. Serialises as
/// `{"file", "onset_s", "features": [{"freq_hz", "decay_per_s", "amplitude"}], …}`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ImpactFeatures {
    /// The file it came from.
    pub file: String,
    /// Where its analysis starts in the file, s: the strike's onset, or past a precursor or a
    /// gradual attack (a fade-in) that the report's warnings name.
    pub onset_s: f64,
    /// Modal features (one per partial), strongest first.
    pub features: Vec<Feature>,
    /// The partials' other members (onsets, beating twins the record cannot resolve, fast
    /// first stages, weak floors), strongest first: in the report and for resynthesis, not in
    /// the damping fits ([`features::group_partials`]).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub components: Vec<Feature>,
    /// Length of the analysed segment, s.
    pub duration_s: f64,
    /// Peak frame power over the noise floor, dB.
    pub snr_db: f64,
    /// Fraction of the segment's power explained by the fitted modes.
    pub explained_power: f64,
    /// Residual power over the noise floor (≈ 1 when only noise is left).
    pub residual_to_noise: f64,
    /// Spectral peaks whose local fit was rejected.
    pub rejected_peaks: usize,
    /// Isolated one-sample spikes repaired before the analysis ([`features::repair_clicks`]).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub repaired_clicks: usize,
    /// The peak search stopped early: its rejected fits used up
    /// [`features::REJECT_BUDGET_BINS`] (a broadband burst inside the ring); the features
    /// found before are kept.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub search_stopped: bool,
}

fn is_zero(n: &usize) -> bool {
    *n == 0
}

/// An impact that was found but not analysed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SkippedImpact {
    /// The file.
    pub file: String,
    /// Onset time, s.
    pub onset_s: f64,
    /// Why it was skipped, and what to do.
    pub reason: String,
}

/// Per-file summary.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FileSummary {
    /// The file.
    pub file: String,
    /// Sample rate, Hz.
    pub sample_rate: u32,
    /// Channels in the file.
    pub channels: u16,
    /// Duration analysed, s.
    pub duration_s: f64,
    /// Noise floor, dBFS (power of the quietest 10 % of 5 ms frames).
    pub noise_floor_db: f64,
    /// Impacts detected.
    pub impacts_found: usize,
    /// Impacts analysed.
    pub impacts_used: usize,
}

/// Output of [`extract_features`].
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct FeaturesReport {
    /// Every analysed impact, in file and time order.
    pub impacts: Vec<ImpactFeatures>,
    /// Impacts found but skipped.
    pub skipped: Vec<SkippedImpact>,
    /// Per-file summaries.
    pub files: Vec<FileSummary>,
    /// Problems that did not stop the analysis.
    pub warnings: Vec<String>,
}

impl FeaturesReport {
    /// All features as (λ, c) points (rad²/s², s⁻¹).
    pub fn points(&self) -> Vec<(f64, f64)> {
        self.impacts.iter().flat_map(|i| i.features.iter().map(|f| (f.lambda(), f.c()))).collect()
    }

    /// Each point's standard uncertainty of c (s⁻¹): 2 × the feature's `sigma_decay_per_s`
    /// (c = 2d), in the order of [`Self::points`].
    pub fn point_sigmas(&self) -> Vec<f64> {
        self.impacts.iter().flat_map(|i| i.features.iter().map(|f| 2.0 * f.sigma_decay_per_s)).collect()
    }
}

/// Rayleigh against hybrid by BIC (lower is better).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ModelComparison {
    /// EMG Rayleigh fit.
    pub rayleigh: FitResult,
    /// EMG hybrid fit (None if it failed).
    pub hybrid: Option<FitResult>,
    /// The recommended model.
    pub recommended: ModelKind,
    /// BIC(hybrid) − BIC(Rayleigh); negative favours hybrid.
    pub delta_bic: Option<f64>,
}

/// Output of [`estimate`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EstimateReport {
    /// Every analysed impact with its features.
    pub impacts: Vec<ImpactFeatures>,
    /// Impacts found but skipped.
    pub skipped: Vec<SkippedImpact>,
    /// Per-file summaries.
    pub files: Vec<FileSummary>,
    /// Chosen model name ("rayleigh", "hybrid", "power", "caughey").
    pub model: String,
    /// Chosen method.
    pub method: Method,
    /// Chosen fit's parameters in SI units (`dsp::Damping` conventions).
    pub params: Vec<f64>,
    /// The chosen fit.
    pub chosen: FitResult,
    /// Fits of every method (EMG, LSQ, LB) for the chosen model; failed ones are absent.
    pub fits: Vec<FitResult>,
    /// Rayleigh vs hybrid (EMG) comparison.
    pub comparison: Option<ModelComparison>,
    /// Known-object match, if `object_lambdas` was given.
    pub object: Option<ObjectMatch>,
    /// Number of (λ, c) points fitted.
    pub n_points: usize,
    /// Problems that did not stop the analysis.
    pub warnings: Vec<String>,
    /// Ren §5.2.2's match ratios of the recording by the fitted material (issue 15 part 1):
    /// how much of each impact the material represents. Absent in reports written before.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ren_match: Option<ren::RenMatch>,
    /// What Ren's optimiser found (`method` "ren" only; issue 15 part 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ren_fit: Option<ren_fit::RenFitSummary>,
    /// The known object's modes the strong partials matched, each with its own support
    /// excess over the chosen law ([`EstimateReport::support_by_mode`]; what a material of
    /// this capture records as `support.recorded_modes`). Empty without an object.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub recorded_modes: Vec<ModeSupport>,
}

/// Largest support damping a capture stores (mean extra c, s⁻¹; the plugin's range).
pub const MAX_SUPPORT_C: f64 = 2000.0;

impl EstimateReport {
    /// The chosen damping law.
    pub fn damping(&self) -> dsp::Damping {
        self.chosen.damping()
    }
    /// The chosen fit's support damping ([`Self::support_for`]), at most [`MAX_SUPPORT_C`].
    pub fn support_c(&self) -> Option<f64> {
        self.support_for(&self.chosen)
    }

    /// Support damping as recorded (thesis §4.2.8), for playing the material held the way
    /// the object was: the mean of the exponential excess of c over `fit`'s law (s⁻¹),
    /// estimated from the impacts' strong partials — within 20 dB of the strongest 10 ms
    /// after the strike, the ones that are heard ringing — as median / ln 2 (the median of
    /// an exponential is its mean × ln 2; robust to the few partials a beat or the strike
    /// leaves far above the law). Not the EMG's 1/η: that is over every feature, and the
    /// many weak, fast ones (onset residue, noise fits) would make the held object sound
    /// far more damped than its recorded partials (issue 10 part 6). `None` for LSQ fits
    /// (their curve runs through the points) and without partials.
    pub fn support_for(&self, fit: &FitResult) -> Option<f64> {
        support_of(&self.impacts, fit)
    }

    /// Support damping as recorded mode by mode, for recordings of a known object (issue 10
    /// part 6; [`object::support_by_mode`]): the object's modes (`lambdas0`, `gains0` as
    /// given in [`Options`]) that the recordings' strong partials matched at the fitted
    /// pitch, each with its own excess over `fit`'s law. Empty without an object match or
    /// for a fit that is not a lower law (as [`Self::support_for`]).
    pub fn support_by_mode(&self, fit: &FitResult, lambdas0: &[f64], gains0: Option<&[f64]>) -> Vec<ModeSupport> {
        match self.object.as_ref().filter(|o| o.matched > 0) {
            Some(o) if fit.is_lower_law() => object::support_by_mode(
                self.impacts.iter().map(|i| i.features.as_slice()),
                &fit.damping(),
                lambdas0,
                gains0,
                o.gamma_ratio,
            ),
            _ => Vec::new(),
        }
    }
}

/// [`EstimateReport::support_for`] of `impacts`.
fn support_of(impacts: &[ImpactFeatures], fit: &FitResult) -> Option<f64> {
    if !fit.is_lower_law() {
        return None;
    }
    let law = fit.damping();
    let mut excess = Vec::new();
    for imp in impacts {
        let heard = |f: &Feature| f.amplitude * (-0.01 * f.decay_per_s).exp();
        let amax = imp.features.iter().map(heard).fold(0.0f64, f64::max);
        for f in imp.features.iter().filter(|f| heard(f) >= 0.1 * amax) {
            excess.push((f.c() - law.c(f.lambda())).max(0.0));
        }
    }
    if excess.is_empty() {
        return None;
    }
    excess.sort_by(f64::total_cmp);
    let n = excess.len();
    let median = if n % 2 == 1 { excess[n / 2] } else { 0.5 * (excess[n / 2 - 1] + excess[n / 2]) };
    Some((median / std::f64::consts::LN_2).min(MAX_SUPPORT_C))
}

/// The quantisation of the analysed signal (full scale ±1): its step and the least noise
/// power per sample it carries. The file's step is q = 2^(1−bits) ([`wav::quantisation_step`];
/// 1/128 at 8 bits; float files count at their container's 32 or 64 bits: negligible); the
/// mean of N channels moves in steps of q/N (a mode in one channel of a stereo file is half as
/// loud in the mix, and so is its step). The error is q²/12 per sample (Widrow & Kollár,
/// *Quantization Noise*, 2008, ch. 4), q²/12/N in the mix for independent errors (for
/// identical channels N times more; the one-step amplitude floor covers those). At 8 bits
/// (q²/12 = 5·10⁻⁶, −53 dB) it sets the floor a feature must clear: without it a file of
/// digital silence around the strike reads as noiseless and the quantisation error of the
/// ringing as modes.
fn quantisation(rec: &wav::Recording, channel: Option<usize>) -> (f64, f64) {
    let mixed = if channel.is_some() { 1.0 } else { f64::from(rec.channels.max(1)) };
    let q = wav::quantisation_step(rec.bits_per_sample);
    (q / mixed, q * q / 12.0 / mixed)
}

/// Strikes inside impacts (`Segmentation::restrikes`) each get a warning up to this many per
/// file; more (a roll) get one line.
const MAX_RESTRIKE_WARNINGS: usize = 3;

/// Partials of an impact compared with the other impacts' ([`shared_partials`]): its
/// strongest this many.
const SHARED_TOP: usize = 5;
/// ... found in another impact within this share of their frequency. A mode's frequency is
/// precise to far better, even in a woodblock's 50–90 ms impacts (σ 0.02–0.3 Hz at
/// 0.8–4.9 kHz in `tests/segment.rs`' `noise_bursts_are_said_to_share_no_partials`); a noise burst's "partials" are not (σ 2–20 Hz), and
/// widening the window by σ let them meet by chance as often as not.
const SHARED_TOL: f64 = 0.002;
/// ... against chance: the same count for frequencies moved by these shares (dense features
/// meet some by chance: five low-passed noise bursts of 78 features each share 9 of their
/// 25 strongest at 0.2 %, and 4 a few per cent off them; a bar struck four times at
/// different points 20 of 20: `noise_bursts_are_said_to_share_no_partials`). The warning
/// asks for more shared than half-way from chance to all.
const SHARED_CHANCE_SHIFTS: [f64; 6] = [-0.029, -0.019, -0.011, 0.011, 0.019, 0.029];

/// How many of the impacts' strongest partials (`SHARED_TOP` of each) another impact also
/// has, within `SHARED_TOL`; how many would by chance (the mean of the same count at
/// frequencies `SHARED_CHANCE_SHIFTS` off, where no mode is); and of how many. A struck
/// object rings at the same frequencies at every strike (its modes), wherever it is struck
/// (a strike near a mode's node weakens it, the other strikes excite it). Noise, or taps on
/// different objects, do not. All 0 for fewer than two impacts with features.
fn shared_partials(impacts: &[ImpactFeatures]) -> (usize, f64, usize) {
    let with: Vec<&ImpactFeatures> = impacts.iter().filter(|i| !i.features.is_empty()).collect();
    if with.len() < 2 {
        return (0, 0.0, 0);
    }
    // Each impact's strongest frequencies, once.
    let tops: Vec<Vec<f64>> = with
        .iter()
        .map(|imp| {
            let mut top: Vec<&Feature> = imp.features.iter().collect();
            top.sort_by(|a, b| b.amplitude.total_cmp(&a.amplitude));
            top.into_iter().take(SHARED_TOP).map(|f| f.freq_hz).collect()
        })
        .collect();
    let count = |shift: f64| {
        let mut n = 0;
        for (i, top) in tops.iter().enumerate() {
            for &f in top {
                let at = f * (1.0 + shift);
                let near = |g: &Feature| (g.freq_hz - at).abs() <= SHARED_TOL * at;
                if with.iter().enumerate().any(|(j, o)| j != i && o.features.iter().any(near)) {
                    n += 1;
                }
            }
        }
        n
    };
    let total = tops.iter().map(Vec::len).sum();
    let chance = SHARED_CHANCE_SHIFTS.iter().map(|&s| count(s) as f64).sum::<f64>() / SHARED_CHANCE_SHIFTS.len() as f64;
    (count(0.0), chance, total)
}

/// Reads a WAV file to mono. See [`wav::load_wav`].
///
/// # Errors
/// As [`wav::load_wav`].
pub fn load_wav(path: &Path, channel: Option<usize>) -> Result<Recording, EstimateError> {
    wav::load_wav(path, channel)
}

/// A frequency for a message: "40 Hz", "950 Hz", "12.6 kHz".
fn hz(f: f64) -> String {
    if f < 1000.0 {
        format!("{f:.0} Hz")
    } else {
        format!("{:.1} kHz", f / 1000.0)
    }
}

/// Finds the impacts in `files` and extracts each one's modal features.
/// `progress` receives 0..1; `cancel` stops the work between impacts and inside the
/// extraction loop.
///
/// # Errors
/// The first file that cannot be read ([`EstimateError::Wav`], [`EstimateError::Silent`], …),
/// [`EstimateError::NoImpacts`] if no file holds an impact, [`EstimateError::NoUsableImpacts`]
/// if impacts were found but every one was skipped, [`EstimateError::Cancelled`].
pub fn extract_features(
    files: &[PathBuf],
    opts: &Options,
    progress: &dyn Fn(f32),
    cancel: &AtomicBool,
) -> Result<FeaturesReport, EstimateError> {
    let mut report = FeaturesReport::default();
    let nfiles = files.len().max(1);
    let mut first_silent = None;
    for (fi, path) in files.iter().enumerate() {
        if cancel.load(Ordering::Relaxed) {
            return Err(EstimateError::Cancelled);
        }
        let name = path.display().to_string();
        if let Some(first) = files[..fi].iter().find(|f| presets::output::same_file(f, path)) {
            report.warnings.push(format!("{name} is the same file as {}: read once", first.display()));
            continue;
        }
        let rec = match load_wav(path, opts.channel) {
            // A silent file among others is skipped like one with no impact in it.
            Err(e @ EstimateError::Silent { .. }) if files.len() > 1 => {
                report.warnings.push(format!("{e}; skipped"));
                first_silent.get_or_insert(e);
                continue;
            }
            r => r?,
        };
        report.warnings.extend(rec.warnings.iter().cloned());
        let fs = f64::from(rec.sample_rate);
        let seg = segment::segment(&rec.samples, fs, &opts.segment);
        // Each impact cut at the strikes inside it that re-excited the object
        // (`Segmentation::cuts`): no analysed stretch mixes two such strikes.
        let (pieces, cut_short) = seg.pieces(fs, opts.segment.min_impact_s);
        // A clipped stretch is left out of its piece's analysis (`segment::clear_of_clipping`).
        let min_len = (opts.segment.min_impact_s * fs) as usize;
        let (pieces, clipped, clipped_through) = segment::clear_of_clipping(pieces, &rec.clipped, min_len);
        for (s, n) in &clipped_through {
            report.skipped.push(SkippedImpact {
                file: name.clone(),
                onset_s: s.start as f64 / fs,
                reason: format!(
                    "clipped ({n} clipped samples) with no stretch of {:.0} ms without clipping (its clipping's harmonics would be fitted as modes); lower the recording gain",
                    1e3 * opts.segment.min_impact_s
                ),
            });
        }
        if !clipped.is_empty() {
            let at: Vec<String> = clipped
                .iter()
                .take(5)
                .map(|c| format!("{:.3} s ({} clipped)", c.start as f64 / fs, c.samples))
                .collect();
            report.warnings.push(format!(
                "{name}: {} impact(s) clipped (at {}{}): each is analysed over its longest stretch without clipping{}",
                clipped.len(),
                at.join(", "),
                if clipped.len() > 5 { ", …" } else { "" },
                match clipped.first() {
                    Some(c) if c.from > c.start =>
                        format!(" (the first from {:.3} s, after its last clipped sample)", c.from as f64 / fs),
                    Some(c) => format!(" (the first up to {:.3} s)", c.to as f64 / fs),
                    None => String::new(),
                }
            ));
        }
        for (s, reason) in seg.skipped.iter().chain(&cut_short) {
            report.skipped.push(SkippedImpact {
                file: name.clone(),
                onset_s: s.start as f64 / fs,
                reason: reason.clone(),
            });
        }
        let (quant_step, quant_var) = quantisation(&rec, opts.channel);
        let extract =
            ExtractOptions { min_amplitude: opts.extract.min_amplitude.max(quant_step), ..opts.extract.clone() };
        let nimp = pieces.len().max(1);
        let mut used = 0;
        // Partials left out as contact noise in this file's impacts: count, band, and which
        // impacts (by their index in `pieces`); the impacts kept, by the same index.
        let mut contact = (0usize, f64::INFINITY, 0.0f64);
        let mut contact_in = std::collections::BTreeSet::new();
        let mut kept = Vec::new();
        for (ii, s) in pieces.iter().enumerate() {
            if cancel.load(Ordering::Relaxed) {
                return Err(EstimateError::Cancelled);
            }
            let noise_var = s.noise_var.max(quant_var);
            let fit = features::extract_impact(&rec.samples[s.start..s.end], fs, noise_var, &extract, cancel)?;
            let at = s.start as f64 / fs;
            if !fit.repaired_clicks.is_empty() {
                let times: Vec<String> = fit
                    .repaired_clicks
                    .iter()
                    .take(5)
                    .map(|&i| format!("{:.4} s", (s.start + i) as f64 / fs))
                    .collect();
                report.warnings.push(format!(
                    "{name}: repaired {} isolated one-sample click(s) in the impact at {at:.3} s (at {}{}); a glitch or dropped sample in the file",
                    fit.repaired_clicks.len(),
                    times.join(", "),
                    if fit.repaired_clicks.len() > 5 { ", …" } else { "" }
                ));
            }
            if fit.search_stopped {
                report.warnings.push(format!(
                    "{name}: the impact at {at:.3} s: the peak search stopped after {} rejected peaks (a click, crackle or broadband burst inside the ring?); {} features kept",
                    fit.rejected_peaks,
                    fit.features.len()
                ));
            }
            let steady = |hz: &[f64]| -> String {
                let list: Vec<String> = hz.iter().take(3).map(|f| format!("{f:.1} Hz")).collect();
                format!(
                    "{}{} decay{} slower than {} 1/s (a T60 over {:.0} s) and {} taken as steady hum; for an object that rings that long, lower the minimum decay (--min-decay)",
                    list.join(", "),
                    if hz.len() > 3 { ", …" } else { "" },
                    if hz.len() == 1 { "s" } else { "" },
                    extract.min_decay_per_s,
                    1000f64.ln() / extract.min_decay_per_s.max(1e-300),
                    if hz.len() == 1 { "was" } else { "were" }
                )
            };
            if !fit.steady_hz.is_empty() && !fit.features.is_empty() {
                report.warnings.push(format!(
                    "{name}: the impact at {at:.3} s: {} {}",
                    if fit.steady_hz.len() == 1 {
                        "a partial as strong as any kept,"
                    } else {
                        "partials as strong as any kept,"
                    },
                    steady(&fit.steady_hz)
                ));
            }
            if let (Some(lo), Some(hi)) = (fit.contact_noise.first(), fit.contact_noise.last()) {
                contact = (contact.0 + fit.contact_noise.len(), contact.1.min(lo.freq_hz), contact.2.max(hi.freq_hz));
                contact_in.insert(ii);
            }
            if fit.features.is_empty() {
                report.skipped.push(SkippedImpact {
                    file: name.clone(),
                    onset_s: s.start as f64 / fs,
                    reason: if fit.steady_hz.is_empty() {
                        "no modal features found (noise or a dull thud); tap a freely ringing object".into()
                    } else {
                        // A hum in the room under a thud, or an object that rings for minutes.
                        format!(
                            "no modal features found (noise or a dull thud; tap a freely ringing object): {}",
                            steady(&fit.steady_hz)
                        )
                    },
                });
            } else {
                used += 1;
                kept.push(ii);
                report.impacts.push(ImpactFeatures {
                    file: name.clone(),
                    onset_s: s.start as f64 / fs,
                    features: fit.features,
                    components: fit.components,
                    duration_s: (s.end - s.start) as f64 / fs,
                    snr_db: s.snr_db,
                    explained_power: fit.explained_power,
                    residual_to_noise: fit.residual_to_noise,
                    rejected_peaks: fit.rejected_peaks,
                    repaired_clicks: fit.repaired_clicks.len(),
                    search_stopped: fit.search_stopped,
                });
            }
            progress((fi as f32 + (ii + 1) as f32 / nimp as f32) / nfiles as f32);
        }
        // Brief partials that no other tap of this recording repeats are contact noise too.
        let first = report.impacts.len() - kept.len();
        let mine = &mut report.impacts[first..];
        let lists: Vec<&[Feature]> = mine.iter().map(|m| m.features.as_slice()).collect();
        let unrepeated = features::unrepeated_brief(&lists);
        for ((imp, flags), &ii) in mine.iter_mut().zip(&unrepeated).zip(&kept) {
            let mut k = 0;
            imp.features.retain(|f| {
                let out = flags[k];
                k += 1;
                if out {
                    contact = (contact.0 + 1, contact.1.min(f.freq_hz), contact.2.max(f.freq_hz));
                    contact_in.insert(ii);
                }
                !out
            });
        }
        // An impact of nothing but such partials is a click, not a strike of the object.
        let mut k = first;
        while k < report.impacts.len() {
            if report.impacts[k].features.is_empty() {
                let imp = report.impacts.remove(k);
                used -= 1;
                report.skipped.push(SkippedImpact {
                    file: name.clone(),
                    onset_s: imp.onset_s,
                    reason: "only brief partials that no other tap repeats (a click or the contact's noise, not the object ringing)"
                        .into(),
                });
            } else {
                k += 1;
            }
        }
        if contact.0 > 0 {
            report.warnings.push(format!(
                "{name}: {} brief partial(s) at {} in {} impact(s) are the strike's contact noise (a click), not modes: they overlap into a broadband burst or no other tap repeats them; left out (they stay in the residual)",
                contact.0,
                if contact.1 == contact.2 { hz(contact.1) } else { format!("{}–{}", hz(contact.1), hz(contact.2)) },
                contact_in.len()
            ));
        }
        // The strike an impact starts with: its onset, before a gradual attack was left out
        // (the strikes inside it count from where its analysis starts).
        let strike_at = |start: usize| seg.attacks.iter().find(|a| a.1 == start).map_or(start, |a| a.0);
        for &(onset, from) in &seg.attacks {
            report.warnings.push(format!(
                "{name}: the sound at {:.3} s rises gradually (a fade-in, a swell or a soft mallet's long contact): analysed from {:.3} s, where it rings freely",
                onset as f64 / fs,
                from as f64 / fs
            ));
        }
        for &(start, fall, to) in &seg.fades {
            report.warnings.push(format!(
                "{name}: the sound at {:.3} s falls away faster than it rang from {:.3} s on (a fade-out, a gate or a hand damping it): analysed up to {:.3} s",
                strike_at(start) as f64 / fs,
                fall as f64 / fs,
                to as f64 / fs
            ));
        }
        if !seg.noise_steps.is_empty() {
            let times: Vec<String> =
                seg.noise_steps.iter().take(5).map(|&i| format!("{:.2} s", i as f64 / fs)).collect();
            report.warnings.push(format!(
                "{name}: the background noise starts or changes {} time(s) (at {}{}); not taken as taps",
                seg.noise_steps.len(),
                times.join(", "),
                if seg.noise_steps.len() > 5 { ", …" } else { "" }
            ));
        }
        if seg.restrikes.len() <= MAX_RESTRIKE_WARNINGS {
            for &(at, start) in &seg.restrikes {
                let onset = strike_at(start);
                let after = at.saturating_sub(onset) as f64 / fs;
                // Cut where the strike re-excited the object (`Segmentation::cuts`).
                let what = if seg.cuts.contains(&at) {
                    // (Said as what the report shows: the part after the cut is an impact of
                    // its own at the strike's time; a tester read "not taken as an onset"
                    // beside that impact as a contradiction.)
                    format!(
                        "the impact is cut there, each part of {:.0} ms or more analysed alone as an impact of its own (the strike's part from {:.3} s; shorter ones are listed as skipped), its start mixed with the ring before it",
                        1e3 * opts.segment.min_impact_s,
                        at as f64 / fs
                    )
                } else {
                    "analysed with it (the ring only fell there, as where a sound stops, so it is not cut: the two decays mix)".to_string()
                };
                report.warnings.push(if after < opts.segment.min_gap_s {
                    format!(
                        "{name}: a second strike {:.0} ms after the one at {:.3} s, inside the {:.0} ms minimum gap between taps (a bounce or a flam): {what}; leave more time between taps",
                        1e3 * after,
                        onset as f64 / fs,
                        1e3 * opts.segment.min_gap_s
                    )
                } else {
                    format!(
                        "{name}: a strike {:.0} ms after the onset at {:.3} s, inside its ring (not found as an onset of its own: in antiphase to the ring, too soon after another, or much softer than the ring): {what}; leave more time between taps",
                        1e3 * after,
                        onset as f64 / fs
                    )
                });
            }
        } else {
            // A roll or a tremolo: one line. The spacing is each strike's distance from the
            // strike before it (an onset or another of these).
            let mut events: Vec<usize> = seg.impacts.iter().map(|i| strike_at(i.start)).collect();
            events.extend(seg.restrikes.iter().map(|r| r.0));
            events.sort_unstable();
            let spacing: Vec<f64> = seg
                .restrikes
                .iter()
                .filter_map(|&(at, _)| events.iter().rev().find(|&&e| e < at).map(|&e| (at - e) as f64 / fs))
                .collect();
            let (lo, hi) = spacing.iter().fold((f64::INFINITY, 0.0f64), |(a, b), &v| (a.min(v), b.max(v)));
            // "each 25 ms", not "each 25–25 ms".
            let (lo_ms, hi_ms) = ((1e3 * lo).round(), (1e3 * hi).round());
            let each = if lo_ms == hi_ms { format!("{lo_ms:.0}") } else { format!("{lo_ms:.0}–{hi_ms:.0}") };
            let cut = seg.restrikes.iter().filter(|r| seg.cuts.contains(&r.0)).count();
            let mut how = Vec::new();
            if cut > 0 {
                how.push(format!(
                    "the impacts are cut at the {cut} where the ring rose (parts under {:.0} ms left out)",
                    1e3 * opts.segment.min_impact_s
                ));
            }
            if cut < seg.restrikes.len() {
                how.push(format!(
                    "the other {} are analysed with the strike before (their decays mix)",
                    seg.restrikes.len() - cut
                ));
            }
            report.warnings.push(format!(
                "{name}: {} strikes fell inside impacts (a roll, a tremolo or bounces: each {each} ms after the strike before it, from {:.2} s to {:.2} s): {}; leave more time between taps",
                seg.restrikes.len(),
                seg.restrikes[0].0 as f64 / fs,
                seg.restrikes[seg.restrikes.len() - 1].0 as f64 / fs,
                how.join("; ")
            ));
        }
        if seg.impacts.is_empty() {
            report.warnings.push(format!("{name}: no impacts found; taps must rise well above the background noise"));
        }
        report.files.push(FileSummary {
            file: name,
            sample_rate: rec.sample_rate,
            channels: rec.channels,
            duration_s: rec.duration_s(),
            noise_floor_db: 10.0 * seg.noise_var.max(1e-30).log10(),
            // A strike's precursor is part of it, not an impact of its own.
            // Every strike once: each piece and each part cut short starts at one.
            impacts_found: pieces.len()
                + cut_short.len()
                + seg.skipped.iter().filter(|s| !segment::is_precursor(&s.1)).count(),
            impacts_used: used,
        });
        progress((fi + 1) as f32 / nfiles as f32);
    }
    // Fewer shared than half-way from chance to all ([`shared_partials`]).
    let (shared, chance, strongest) = shared_partials(&report.impacts);
    if strongest > 0 && (shared as f64 - chance) < 0.5 * (strongest as f64 - chance) {
        report.warnings.push(format!(
            "the impacts share only {shared} of their {strongest} strongest partials (within {:.1} %; {chance:.0} would by chance): each strike rang at other frequencies. Taps on different objects of one material are fine; taps on one object ring at its modes every time, so these are not modes (noise bursts, rattles) and a material fitted to them means little",
            100.0 * SHARED_TOL
        ));
    }
    if report.impacts.is_empty() {
        // Found but all skipped (too short, too quiet, no mode rings): say why, not "none".
        if let Some(s) = report.skipped.iter().find(|s| !segment::is_precursor(&s.reason)) {
            return Err(EstimateError::NoUsableImpacts {
                files: files.len(),
                found: report.files.iter().map(|f| f.impacts_found).sum(),
                file: s.file.clone(),
                onset_s: s.onset_s,
                reason: s.reason.clone(),
            });
        }
        // Every file read was silent: say why, not "no impacts found".
        if let Some(e) = first_silent.filter(|_| report.files.is_empty()) {
            return Err(e);
        }
        // The warnings would be lost with the report (a truncated file's "data ends early").
        // (Not each file's own "no impacts found": the error says it.)
        let also: Vec<&str> =
            report.warnings.iter().map(String::as_str).filter(|w| !w.contains("no impacts found")).collect();
        let also =
            if also.is_empty() { String::new() } else { format!(" (also: {})", also.join("; ").replace('\n', " ")) };
        return Err(EstimateError::NoImpacts { files: files.len(), also });
    }
    Ok(report)
}

/// Full estimate: features of every impact in `files`, then every method's fit of
/// `opts.model`, the Rayleigh/hybrid comparison and, if `opts.object_lambdas` is set, the
/// known-object match. The chosen fit is `opts.method`'s.
///
/// # Errors
/// As [`extract_features`], plus [`EstimateError::TooFewFeatures`] and the chosen method's
/// fit errors ([`fit_damping`]).
pub fn estimate(
    files: &[PathBuf],
    opts: &Options,
    progress: &dyn Fn(f32),
    cancel: &AtomicBool,
) -> Result<EstimateReport, EstimateError> {
    let feats = extract_features(files, opts, &|p| progress(0.9 * p), cancel)?;
    let points = feats.points();
    // Every fit weighs each point by its own uncertainty (issue 10 part 3).
    let sigmas = feats.point_sigmas();
    let fit_damping =
        |p: &[(f64, f64)], model: ModelKind, method: Method| fit::fit_damping_weighted(p, Some(&sigmas), model, method);
    let mut warnings = feats.warnings.clone();
    // Ren's method starts from the EMG fit, and falls back to it.
    let primary = if opts.method == Method::Ren { Method::Emg } else { opts.method };
    // Every method's fit of the requested model; if the chosen method cannot fit it, fall
    // back (same method with the Rayleigh law, then the Rayleigh lower bound) and say why:
    // an analysis is never thrown away for want of a fit.
    let fit_all =
        |model: ModelKind, warnings: &mut Vec<String>| -> Result<(Vec<FitResult>, Option<FitResult>), EstimateError> {
            let mut fits = Vec::new();
            let mut chosen = Err(EstimateError::Cancelled);
            for m in [Method::Emg, Method::Lsq, Method::Lb] {
                if cancel.load(Ordering::Relaxed) {
                    return Err(EstimateError::Cancelled);
                }
                match fit_damping(&points, model, m) {
                    Ok(f) => {
                        if m == primary {
                            chosen = Ok(f.clone());
                        }
                        fits.push(f);
                    }
                    Err(e) if m == primary => chosen = Err(e),
                    Err(e) => warnings.push(format!("{} {} fit failed: {e}", m.name(), model.name())),
                }
            }
            match chosen {
                Ok(c) => Ok((fits, Some(c))),
                Err(e) => {
                    warnings.push(format!(
                        "the {} {} fit failed ({e}); the material uses a fallback fit",
                        primary.name(),
                        model.name()
                    ));
                    Ok((fits, None))
                }
            }
        };
    let (mut fits, mut chosen) = fit_all(opts.model, &mut warnings)?;
    progress(0.93);
    if chosen.is_none() && opts.model != ModelKind::Rayleigh {
        // The requested model's other fits stay in the report beside the fallback's.
        let (more, c) = fit_all(ModelKind::Rayleigh, &mut warnings)?;
        fits.extend(more);
        chosen = c;
    }
    if chosen.is_none() && primary != Method::Lb {
        chosen = fits.iter().find(|f| f.method == Method::Lb).cloned();
    }
    progress(0.96);
    let chosen = match chosen {
        Some(c) => c,
        // Nothing at all could be fitted: too few or degenerate points, or bad input; the
        // Rayleigh EMG error says which.
        None => {
            return Err(fit_damping(&points, ModelKind::Rayleigh, primary)
                .err()
                .unwrap_or(EstimateError::TooFewFeatures { found: points.len(), needed: 4 }))
        }
    };
    if opts.method != Method::Ren {
        say_chosen(&chosen, opts, &mut warnings);
    }
    let comparison = match fit_damping(&points, ModelKind::Rayleigh, Method::Emg) {
        Ok(ray) => {
            let hyb = fit_damping(&points, ModelKind::Hybrid, Method::Emg).ok();
            let delta = hyb.as_ref().and_then(|h| Some(h.bic? - ray.bic?));
            let recommended = if delta.is_some_and(|d| d < 0.0) { ModelKind::Hybrid } else { ModelKind::Rayleigh };
            Some(ModelComparison { rayleigh: ray, hybrid: hyb, recommended, delta_bic: delta })
        }
        Err(_) => None,
    };
    if let Some(w) = comparison.as_ref().and_then(|c| worse_than_compared(&chosen, c)) {
        warnings.push(w);
    }
    let all: Vec<Feature> = feats.impacts.iter().flat_map(|i| i.features.iter().copied()).collect();
    let object =
        opts.object_lambdas.as_deref().and_then(|l| object::match_object(&all, l, opts.object_gains.as_deref()));
    // Ren's method (§5): from the EMG fit of the chosen law (and the object match), on the
    // recordings themselves.
    let mut chosen = chosen;
    let mut object = object;
    let mut ren_fit = None;
    if opts.method == Method::Ren {
        if cancel.load(Ordering::Relaxed) {
            return Err(EstimateError::Cancelled);
        }
        match ren_fit_of(files, opts, &feats.impacts, &fits, &chosen, object.as_ref(), cancel) {
            Ok((fit, summary)) => {
                if let (Some(l), Some(g)) = (opts.object_lambdas.as_deref(), summary.gamma_ratio) {
                    object = object::match_object_at(&all, l, opts.object_gains.as_deref(), g).map(|mut o| {
                        o.amplitude_scale = summary.amplitude_scale.unwrap_or(o.amplitude_scale);
                        o
                    });
                }
                fits.push(fit.clone());
                chosen = fit;
                ren_fit = Some(summary);
            }
            Err(EstimateError::Cancelled) => return Err(EstimateError::Cancelled),
            Err(e) => warnings
                .push(format!("the ren {} fit failed ({e}); the material uses a fallback fit", chosen.model.name())),
        }
    }
    if opts.method == Method::Ren {
        say_chosen(&chosen, opts, &mut warnings);
    }
    if opts.object_lambdas.is_some() && object.as_ref().is_none_or(|o| o.matched == 0) {
        warnings.push(
            "the object's modes did not match any recorded feature; check that the right object was chosen".into(),
        );
    }
    if let Some(o) = object.as_ref().filter(|o| o.matched > 0) {
        if !object::playable_gamma_ratio(o.gamma_ratio) {
            warnings.push(format!(
                "the pitch fit puts the object's lowest mode at {:.1} Hz, its pitch scaled {:.0}× {} (γ/γ₀ = {:.3e}, outside the {}–{} the instrument plays): the recordings are not of this object; the material keeps no pitch of its own",
                o.object_lowest_hz,
                if o.gamma_ratio < 1.0 { o.gamma_ratio.sqrt().recip() } else { o.gamma_ratio.sqrt() },
                if o.gamma_ratio < 1.0 { "down" } else { "up" },
                o.gamma_ratio,
                object::PLAYABLE_GAMMA_RATIO.0,
                object::PLAYABLE_GAMMA_RATIO.1
            ));
        }
        if o.unmatched_modes_below > 0 || o.unmatched_strong_modes > 0 {
            warnings.push(format!(
                "the object matches the recording only in part: at the fitted pitch (lowest mode {:.1} Hz, lowest recorded partial {:.1} Hz) {} of its modes below the recording's lowest partial and {} strong ones inside its range have no recorded partial; check that the right object was chosen",
                o.object_lowest_hz, o.lowest_partial_hz, o.unmatched_modes_below, o.unmatched_strong_modes
            ));
        }
    }
    progress(1.0);
    let mut report = EstimateReport {
        impacts: feats.impacts,
        skipped: feats.skipped,
        files: feats.files,
        model: chosen.model.name().to_string(),
        method: chosen.method,
        params: chosen.params.clone(),
        n_points: points.len(),
        chosen,
        fits,
        comparison,
        object,
        warnings,
        ren_match: None,
        ren_fit,
        recorded_modes: Vec::new(),
    };
    report.ren_match = ren::ren_match(&report, opts);
    if let Some(lambdas) = opts.object_lambdas.as_deref() {
        report.recorded_modes = report.support_by_mode(&report.chosen, lambdas, opts.object_gains.as_deref());
    }
    Ok(report)
}

/// Ren's fit ([`ren_fit::fit_ren`]) of `chosen`'s law: the first impacts' recordings read
/// again from `files` (each file once), started from the fits of that law in `fits`.
fn ren_fit_of(
    files: &[PathBuf],
    opts: &Options,
    impacts: &[ImpactFeatures],
    fits: &[FitResult],
    chosen: &FitResult,
    object: Option<&ObjectMatch>,
    cancel: &AtomicBool,
) -> Result<(FitResult, ren_fit::RenFitSummary), EstimateError> {
    let points: Vec<(f64, f64)> = impacts.iter().flat_map(|i| i.features.iter().map(|f| (f.lambda(), f.c()))).collect();
    let used = &impacts[..impacts.len().min(ren_fit::MAX_IMPACTS)];
    // Each impact's stretch of its file: from its onset, its duration up to the sound image's.
    let stretch = |imp: &ImpactFeatures, fs: f64| residual::impact_stretch(imp, fs, psycho::IMAGE_SECONDS);
    // Each file read once, keeping only the frames from its first used impact's start to its
    // last one's end (a few seconds of a long session, not all of it: `wav::load_wav_window`).
    let mut recordings: Vec<(String, Recording)> = Vec::new();
    for imp in used {
        if recordings.iter().all(|r| r.0 != imp.file) {
            let path = files
                .iter()
                .find(|p| p.display().to_string() == imp.file)
                .cloned()
                .unwrap_or_else(|| PathBuf::from(&imp.file));
            let window = |rate: u32| {
                let spans = used.iter().filter(|i| i.file == imp.file).map(|i| stretch(i, f64::from(rate)));
                let (start, end) = spans.fold((usize::MAX, 0), |(a, b), s| (a.min(s.start), b.max(s.end)));
                start..end
            };
            recordings.push((imp.file.clone(), wav::load_wav_window(&path, opts.channel, window)?));
        }
    }
    let segments: Vec<ren_fit::Segment> = used
        .iter()
        .map(|imp| {
            let Some(r) = recordings.iter().find(|r| r.0 == imp.file).map(|r| &r.1) else {
                return ren_fit::Segment { samples: Vec::new(), sample_rate: 48_000.0 };
            };
            let fs = f64::from(r.sample_rate);
            let span = stretch(imp, fs);
            let start = span.start.saturating_sub(r.start_frame).min(r.samples.len());
            let end = span.end.saturating_sub(r.start_frame).min(r.samples.len()).max(start);
            ren_fit::Segment { samples: r.samples[start..end].iter().map(|&v| f64::from(v)).collect(), sample_rate: fs }
        })
        .collect();
    let starts: Vec<FitResult> =
        fits.iter().filter(|f| f.model == chosen.model && f.method != Method::Lsq).cloned().collect();
    let known = opts.object_lambdas.as_deref().map(|lambdas| ren_fit::KnownObject {
        lambdas,
        gains: opts.object_gains.as_deref(),
        matched: object.filter(|o| o.matched > 0),
    });
    // The EMG fit's support damping as recorded (EstimateReport::support_for).
    let emg_support = fits
        .iter()
        .find(|f| f.model == chosen.model && f.method == Method::Emg)
        .and_then(|f| support_of(impacts, f))
        .unwrap_or(0.0);
    ren_fit::fit_ren(
        &ren_fit::RenInput {
            impacts: used,
            segments: &segments,
            model: chosen.model,
            starts: &starts,
            object: known,
            points: &points,
            emg_support_c: emg_support,
        },
        cancel,
    )
}

/// Says in `warnings` when the chosen fit is not the one asked for, then the chosen fit's own
/// warnings.
fn say_chosen(chosen: &FitResult, opts: &Options, warnings: &mut Vec<String>) {
    if chosen.model != opts.model || chosen.method != opts.method {
        warnings.push(format!(
            "using the {} {} fit instead of {} {}",
            chosen.method.name(),
            chosen.model.name(),
            opts.method.name(),
            opts.model.name()
        ));
    }
    warnings.extend(chosen.warnings.iter().cloned());
    if chosen.method == Method::Lb {
        warnings.push(LB_WARNING.into());
    }
}

/// BIC by which an EMG fit of another model must trail the compared Rayleigh/hybrid fits to
/// be warned about (10: very strong evidence, Kass & Raftery 1995).
pub const MUCH_WORSE_BIC: f64 = 10.0;

/// A warning when the chosen EMG fit, of a model the comparison does not hold (power law,
/// Caughey), explains the points far worse than the compared Rayleigh or hybrid law (a
/// black-box tester's power-law fits of Rayleigh recordings were 83–99 % off at the lowest
/// mode with no word: a power law has no constant term).
fn worse_than_compared(chosen: &FitResult, cmp: &ModelComparison) -> Option<String> {
    if chosen.method != Method::Emg || matches!(chosen.model, ModelKind::Rayleigh | ModelKind::Hybrid) {
        return None;
    }
    let own = chosen.bic?;
    // (Only fits of the same points compare: each EMG leaves out points far above its own law.)
    let (best, name) = [Some(&cmp.rayleigh), cmp.hybrid.as_ref()]
        .into_iter()
        .flatten()
        .filter(|f| f.n_points == chosen.n_points)
        .filter_map(|f| f.bic.map(|b| (b, f.model)))
        .min_by(|a, b| a.0.total_cmp(&b.0))?;
    (own - best > MUCH_WORSE_BIC).then(|| {
        format!(
            "the {} law explains these recordings far worse than the {} law (BIC higher by {:.0}): its damping may be far off at some frequencies, the lowest modes most likely; --model {} fits them better",
            chosen.model.name(),
            name.name(),
            own - best,
            name.name()
        )
    })
}

/// Said whenever the lower-bound fit is the material's: by construction it runs along the
/// least damped points (thesis §4.2.3), so it is a bound, not an estimate (a clean render of
/// a known Rayleigh material gave α₂ 4.1·10⁻⁸ for a true 6.9·10⁻⁸ without a word).
pub const LB_WARNING: &str = "the lower-bound fit runs along the least damped partials (thesis §4.2.3): a bound, not an estimate, so the material rings longer than the recording; the EMG fit (--method emg) is the estimate";
