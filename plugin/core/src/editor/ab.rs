//! A/B comparison of a captured impact: the recording itself (A) against resyntheses (B),
//! played through the plugin's output by [`super::ClipPlayer`].
//!
//! - **A, recording**: the impact's segment of the WAV file, resampled to the plugin's rate
//!   (rubato's band-limited FFT resampler).
//! - **B, modes**: the impact's own modes (frequencies and amplitudes as extracted) with the
//!   decay the fitted damping law gives each of them: Ren et al. 2013 §6's comparison of a
//!   recording with its resynthesis from the estimated material.
//! - **B, modes + residual**: those modes plus the impact's residual (Ren §6.1: the
//!   recording minus the modes the fitted law represents) as the instrument plays it —
//!   its power spectrogram transferred to those modes (§6.2, here onto their fitted
//!   decays) and turned back into sound by Griffin–Lim.
//! - **B, object**: the current object struck at the current position with the fitted
//!   material, through the real engine. With the object match (recordings of this object) it
//!   plays at the matched γ/γ₀; otherwise the object's lowest mode is tuned to the impact's
//!   lowest mode.
//!
//! The B clips are scaled to the recording's peak so the comparison is about timbre and decay,
//! not level. Clips are built off the audio thread (the editor uses a worker thread).

pub use crate::resample::resample;
use dsp::engine::{Engine, NoteId, SoundParams, Strike};
use dsp::{Damping, ObjectModes};
use estimator::Feature;
use std::path::Path;

/// Longest clip, seconds.
pub const MAX_CLIP_SECONDS: f64 = 8.0;
/// Time kept before the detected onset, seconds (the onset detector fires a little late).
pub const PRE_ROLL_S: f64 = 0.005;

/// Which clip to build.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    /// The recording.
    Recording,
    /// The impact's modes with the fitted decay law.
    Modes,
    /// The impact's modes with the fitted decay law, and its transferred residual.
    ModesResidual,
    /// The current object with the fitted material.
    Object,
}

impl Side {
    /// Button label.
    pub fn label(self) -> &'static str {
        match self {
            Side::Recording => "A: recording",
            Side::Modes => "B: modes",
            Side::ModesResidual => "B: modes + residual",
            Side::Object => "B: object",
        }
    }
}

/// The impact's segment of a recording at `rate` Hz: from [`PRE_ROLL_S`] before the onset,
/// `duration_s` long (at most [`MAX_CLIP_SECONDS`]), with a 5 ms fade-out.
///
/// # Errors
/// The WAV reader's reason, or an onset past the end of the file.
pub fn recording_clip(file: &Path, onset_s: f64, duration_s: f64, rate: f32) -> Result<Vec<f32>, String> {
    // Only the clip's frames are kept (an impact in an hour-long session costs its seconds).
    let rec = estimator::wav::load_wav_window(file, None, |file_rate| {
        let sr = f64::from(file_rate);
        let start = ((onset_s - PRE_ROLL_S).max(0.0) * sr) as usize;
        start..start.saturating_add(((duration_s.clamp(0.01, MAX_CLIP_SECONDS) + PRE_ROLL_S) * sr) as usize)
    })
    .map_err(|e| e.to_string())?;
    if rec.samples.is_empty() {
        return Err(format!("{}: the impact at {onset_s:.3} s lies past the end of the file", file.display()));
    }
    let mut out = resample(&rec.samples, rec.sample_rate, rate.round() as u32)?;
    fade_out(&mut out, (0.005 * f64::from(rate)) as usize);
    Ok(out)
}

/// The impact's modes as damped sines (sine phase, as a strike starts), each decaying at
/// c(λ)/2 of `damping` (or at its measured rate with `None`), `seconds` long at `rate` Hz.
pub fn modes_clip(features: &[Feature], damping: Option<&Damping>, rate: f32, seconds: f64) -> Vec<f32> {
    let rate = f64::from(rate);
    let n = (seconds.clamp(0.0, MAX_CLIP_SECONDS) * rate) as usize;
    let mut out = vec![0.0f64; n];
    for f in features {
        if !(f.freq_hz > 0.0 && f.freq_hz < 0.5 * rate && f.amplitude.is_finite()) {
            continue;
        }
        let d = damping.map_or(f.decay_per_s, |dm| 0.5 * dm.c(f.lambda())).max(0.0);
        // Complex one-pole recursion z ← z·p, sample = a·Im z.
        let w = std::f64::consts::TAU * f.freq_hz / rate;
        let r = (-d / rate).exp();
        let (pr, pi) = (r * w.cos(), r * w.sin());
        let (mut zr, mut zi) = (f.amplitude, 0.0);
        for o in out.iter_mut() {
            *o += zi;
            let t = zr * pr - zi * pi;
            zi = zr * pi + zi * pr;
            zr = t;
            if zr.abs() + zi.abs() < 1e-9 * f.amplitude.abs() {
                break;
            }
        }
    }
    out.into_iter().map(|v| v as f32).collect()
}

/// The λ factor that puts `modes`' lowest mode (scaled by `modulus_ratio`) at the lowest of
/// `features`, or 1 when there is nothing to match.
pub fn tuning_factor(modes: &ObjectModes, modulus_ratio: f64, features: &[Feature]) -> f64 {
    let lowest =
        features.iter().map(Feature::lambda).filter(|l| l.is_finite() && *l > 0.0).fold(f64::INFINITY, f64::min);
    match modes.lambdas().first() {
        Some(&l0) if lowest.is_finite() && l0 > 0.0 && modulus_ratio > 0.0 => lowest / (l0 * modulus_ratio),
        _ => 1.0,
    }
}

/// The object struck once with `params` and `strike`, through the engine (one voice),
/// `seconds` long at `rate` Hz.
pub fn object_clip(modes: &ObjectModes, params: SoundParams, strike: Strike, rate: f32, seconds: f64) -> Vec<f32> {
    let n = (seconds.clamp(0.0, MAX_CLIP_SECONDS) * f64::from(rate)) as usize;
    let mut engine = Engine::new(vec![modes.clone()], 1, f64::from(rate));
    engine.set_params(params);
    engine.set_object(0);
    engine.reset();
    engine.note_on(NoteId { voice_id: Some(-1), channel: 0, key: 60 }, strike);
    let mut out = vec![0.0f32; n];
    for chunk in out.chunks_mut(512) {
        engine.render(chunk);
    }
    out
}

/// The impact's residual as the instrument plays it, at `req.rate`: the recording minus
/// the modes the fitted law represents over its first [`presets::residual::SECONDS`]
/// ([`estimator::residual::read_impact_residual`]), its power spectrogram transferred from the
/// recorded modes onto the same modes with the fitted decays (c(λ)/2) and reconstructed by
/// Griffin–Lim ([`estimator::transfer`]).
///
/// # Errors
/// The recording cannot be read.
pub fn residual_clip(req: &AbRequest) -> Result<Vec<f32>, String> {
    use estimator::transfer::{transfer, Mode, Source};
    let imp = estimator::ImpactFeatures {
        file: req.file.display().to_string(),
        onset_s: req.onset_s,
        features: req.features.clone(),
        components: Vec::new(),
        duration_s: req.duration_s,
        snr_db: 0.0,
        explained_power: 0.0,
        residual_to_noise: 0.0,
        rejected_peaks: 0,
        repaired_clicks: 0,
        search_stopped: false,
    };
    // (Only the impact's stretch of the file is read.)
    let (x, _, rec) =
        estimator::residual::read_impact_residual(&req.file, None, &imp, &req.damping, 0.0, presets::residual::SECONDS)
            .map_err(|e| e.to_string())?;
    let fs = f64::from(rec.sample_rate);
    let spec = estimator::residual::power_spectrogram(&x);
    let mode = |f: &Feature, d: f64| Mode { freq_hz: f.freq_hz, decay_per_s: d, amplitude: f.amplitude.abs() };
    let source: Vec<Mode> = req.features.iter().map(|f| mode(f, f.decay_per_s)).collect();
    let target: Vec<Mode> = req.features.iter().map(|f| mode(f, 0.5 * req.damping.c(f.lambda()))).collect();
    let src = Source { power: &spec.power, frames: spec.frames, sample_rate: fs, modes: &source };
    let t = transfer(&mut estimator::residual::Stft::<f32>::new(), &src, &target, fs, 1);
    let y: Vec<f32> = t.signal.iter().map(|&v| v as f32).collect();
    resample(&y, rec.sample_rate, req.rate.round() as u32)
}

/// Peak absolute sample.
pub fn peak(x: &[f32]) -> f32 {
    x.iter().fold(0.0f32, |m, v| m.max(v.abs()))
}

/// Scales `x` so its peak is `target` (no change for a silent clip).
pub fn match_peak(x: &mut [f32], target: f32) {
    let p = peak(x);
    if p > 0.0 && target.is_finite() && target > 0.0 {
        let g = target / p;
        for v in x.iter_mut() {
            *v *= g;
        }
    }
}

/// Linear fade over the last `n` samples.
fn fade_out(x: &mut [f32], n: usize) {
    let n = n.min(x.len());
    let len = x.len();
    for i in 0..n {
        x[len - n + i] *= (n - i) as f32 / n as f32;
    }
}

/// Everything needed to build the B clips of one impact, captured on the GUI thread.
#[derive(Clone)]
pub struct AbRequest {
    /// Which clip.
    pub side: Side,
    /// The recording.
    pub file: std::path::PathBuf,
    /// The impact's onset and length in the file, s.
    pub onset_s: f64,
    /// Length of the analysed segment, s.
    pub duration_s: f64,
    /// The impact's features.
    pub features: Vec<Feature>,
    /// The fitted damping law.
    pub damping: Damping,
    /// The current object and the sound controls (for [`Side::Object`]).
    pub object: ObjectModes,
    /// Sound controls with the fitted damping.
    pub params: SoundParams,
    /// Strike position 0..1.
    pub position: f32,
    /// γ/γ₀ from the object match, if the recordings are of this object.
    pub gamma_ratio: Option<f64>,
    /// Output rate, Hz.
    pub rate: f32,
}

/// Builds the clip `req` asks for (the recording is read for every side: its length and peak
/// set the B clips').
///
/// # Errors
/// The recording cannot be read.
pub fn build(req: &AbRequest) -> Result<Vec<f32>, String> {
    let rec = recording_clip(&req.file, req.onset_s, req.duration_s, req.rate)?;
    let seconds = rec.len() as f64 / f64::from(req.rate);
    let pre = (PRE_ROLL_S * f64::from(req.rate)) as usize;
    let mut b = match req.side {
        Side::Recording => return Ok(rec),
        Side::Modes => modes_clip(&req.features, Some(&req.damping), req.rate, seconds),
        Side::ModesResidual => {
            let mut b = modes_clip(&req.features, Some(&req.damping), req.rate, seconds);
            let r = residual_clip(req)?;
            for (o, v) in b.iter_mut().zip(r) {
                *o += v;
            }
            b
        }
        Side::Object => {
            let mut p = req.params;
            p.damping = req.damping;
            p.decay_scale = 1.0;
            p.size = 1.0;
            p.release_damping = 0.0;
            p.pressure_damping = 0.0;
            let (modulus, factor) = match req.gamma_ratio {
                Some(g) if g.is_finite() && g > 0.0 => (g, 1.0),
                _ => (1.0, tuning_factor(&req.object, 1.0, &req.features)),
            };
            p.modulus_ratio = modulus;
            object_clip(
                &req.object,
                p,
                Strike { velocity: 0.8, position: req.position, lambda_factor: factor },
                req.rate,
                seconds,
            )
        }
    };
    // Line the B onset up with the recording's (which starts PRE_ROLL_S early).
    b.splice(0..0, std::iter::repeat_n(0.0, pre.min(b.len())));
    b.truncate(rec.len());
    match_peak(&mut b, peak(&rec));
    fade_out(&mut b, (0.005 * f64::from(req.rate)) as usize);
    Ok(b)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Frequency of the strongest bin by a zero-padded DFT scan around `guess` (Hz).
    fn tone_freq(x: &[f32], rate: f64, guess: f64) -> f64 {
        let mut best = (0.0, guess);
        let mut f = guess * 0.98;
        while f < guess * 1.02 {
            let (mut re, mut im) = (0.0, 0.0);
            for (i, v) in x.iter().enumerate() {
                let ph = std::f64::consts::TAU * f * i as f64 / rate;
                re += f64::from(*v) * ph.cos();
                im += f64::from(*v) * ph.sin();
            }
            let m = re * re + im * im;
            if m > best.0 {
                best = (m, f);
            }
            f += guess * 0.0001;
        }
        best.1
    }

    fn cents(a: f64, b: f64) -> f64 {
        1200.0 * (a / b).log2()
    }

    #[test]
    fn resampling_keeps_pitch_and_length() {
        for (from, to) in [(44_100u32, 48_000u32), (96_000, 48_000), (48_000, 44_100)] {
            let x: Vec<f32> = (0..from as usize / 4)
                .map(|i| (std::f64::consts::TAU * 1000.0 * i as f64 / f64::from(from)).sin() as f32)
                .collect();
            let y = resample(&x, from, to).unwrap();
            let want = x.len() as f64 * f64::from(to) / f64::from(from);
            assert!((y.len() as f64 - want).abs() <= 2.0, "{from}->{to}: {} samples, want {want}", y.len());
            let mid = &y[y.len() / 4..3 * y.len() / 4];
            let f = tone_freq(mid, f64::from(to), 1000.0);
            assert!(cents(f, 1000.0).abs() < 1.0, "{from}->{to}: {f} Hz");
            // Amplitude kept (band-limited resampling of an in-band tone).
            assert!((peak(mid) - 1.0).abs() < 0.01, "{from}->{to}: peak {}", peak(mid));
            // The delay is removed: the sine starts at zero crossing going up, as the input.
            // Phase of the 1 kHz tone in the output against the input's (0 at sample 0).
            let period = f64::from(to) / 1000.0;
            let (mut re, mut im) = (0.0, 0.0);
            for (i, v) in y.iter().enumerate().take(20 * period as usize).skip(480) {
                let ph = std::f64::consts::TAU * i as f64 / period;
                re += f64::from(*v) * ph.cos();
                im += f64::from(*v) * ph.sin();
            }
            // sin(ωt − φ) correlates as (re, im) ∝ (−sin φ, cos φ).
            let lag = (-re).atan2(im) / std::f64::consts::TAU * period;
            assert!(lag.abs() < 1.0, "{from}->{to}: output lags by {lag:.2} samples");
        }
    }

    #[test]
    fn modes_clip_rings_at_the_feature_and_decays_by_the_law() {
        let rate = 48_000.0f32;
        let f = Feature { freq_hz: 440.0, decay_per_s: 3.0, amplitude: 0.5, ..Default::default() };
        // A law giving c = 2·7 at this λ: Rayleigh with α₁ only.
        let damping = Damping::Rayleigh { alpha1: 14.0, alpha2: 0.0 };
        let x = modes_clip(&[f], Some(&damping), rate, 1.0);
        assert_eq!(x.len(), 48_000);
        let rms = |a: &[f32]| (a.iter().map(|v| f64::from(*v).powi(2)).sum::<f64>() / a.len() as f64).sqrt();
        // Amplitude ratio between 0.1 s and 0.6 s windows: e^(−7·0.5).
        let (a, b) = (rms(&x[4_800..9_600]), rms(&x[28_800..33_600]));
        let d = (a / b).ln() / 0.5;
        assert!((d - 7.0).abs() < 0.07, "decay {d}");
        let fr = tone_freq(&x[..24_000], 48_000.0, 440.0);
        assert!(cents(fr, 440.0).abs() < 1.0, "{fr} Hz");
        assert!((peak(&x) - 0.5).abs() < 0.01);
        // Without a law the measured decay is kept.
        let y = modes_clip(&[f], None, rate, 1.0);
        let d = (rms(&y[4_800..9_600]) / rms(&y[28_800..33_600])).ln() / 0.5;
        assert!((d - 3.0).abs() < 0.03, "decay {d}");
    }

    #[test]
    fn object_clip_is_tuned_to_the_impact() {
        let modes = ObjectModes::new(
            vec![(std::f64::consts::TAU * 100.0).powi(2), (std::f64::consts::TAU * 276.0).powi(2)],
            &[vec![1.0, 0.5]],
        );
        let feats = [
            Feature { freq_hz: 523.0, decay_per_s: 2.0, amplitude: 0.3, ..Default::default() },
            Feature { freq_hz: 1500.0, decay_per_s: 4.0, amplitude: 0.1, ..Default::default() },
        ];
        let k = tuning_factor(&modes, 1.0, &feats);
        let p = SoundParams { damping: Damping::Rayleigh { alpha1: 1.0, alpha2: 0.0 }, ..SoundParams::default() };
        let x = object_clip(&modes, p, Strike { velocity: 0.8, position: 0.0, lambda_factor: k }, 48_000.0, 0.5);
        let f = tone_freq(&x[2_400..], 48_000.0, 523.0);
        // λ includes d², so the damped frequency sits a hair lower than 523 Hz.
        assert!(cents(f, 523.0).abs() < 1.0, "{f} Hz");
    }

    /// Log-spectral distance, dB, over the first `frames` frames (each side floored 100 dB
    /// under the reference's strongest cell).
    fn lsd(a: &[f32], reference: &[f32], frames: usize) -> f64 {
        use estimator::residual::{power_spectrogram, BINS};
        let f = |x: &[f32]| power_spectrogram(&x.iter().map(|&v| f64::from(v)).collect::<Vec<f64>>());
        let (pa, pr) = (f(a), f(reference));
        let floor = pr.power.iter().copied().fold(0.0, f64::max) * 1e-10;
        let db = |p: f64| 10.0 * (p + floor).log10();
        let cells = frames * BINS;
        ((0..cells).map(|i| (db(pa.power[i]) - db(pr.power[i])).powi(2)).sum::<f64>() / cells as f64).sqrt()
    }

    /// Ren §6's claim, on the editor's own A/B path: a recording of six modes and a contact
    /// click (partials from 1.5 to 4 kHz under a 5 ms decay); "B: modes + residual" is
    /// closer to it over the attack than "B: modes" (log-spectral distance).
    #[test]
    fn modes_and_residual_are_closer_to_the_recording_than_modes_alone() {
        let (rate, fs) = (48_000u32, 48_000.0);
        let law = Damping::Rayleigh { alpha1: 4.0, alpha2: 2e-8 };
        let feats: Vec<Feature> = (0..6)
            .map(|i| {
                let f = 300.0 * 20f64.powf(f64::from(i) / 5.0);
                let d = 0.5 * law.c((std::f64::consts::TAU * f).powi(2));
                Feature { freq_hz: f, decay_per_s: d, amplitude: 0.3 / (1.0 + f64::from(i)), ..Default::default() }
            })
            .collect();
        let onset = 4_800usize;
        let mut rng = estimator::synth::Rng::new(3);
        let parts: Vec<(f64, f64, f64)> = (0..60)
            .map(|_| (1500.0 + 2500.0 * rng.uniform(), std::f64::consts::TAU * rng.uniform(), rng.uniform()))
            .collect();
        let x: Vec<f32> = (0..fs as usize)
            .map(|n| {
                if n < onset {
                    return 0.0;
                }
                let t = (n - onset) as f64 / fs;
                let modes: f64 = feats
                    .iter()
                    .map(|f| f.amplitude * (-f.decay_per_s * t).exp() * (std::f64::consts::TAU * f.freq_hz * t).sin())
                    .sum();
                let click: f64 =
                    parts.iter().map(|&(f, ph, a)| a * (std::f64::consts::TAU * f * t + ph).sin()).sum::<f64>()
                        * (-t / 0.005).exp();
                (modes + 0.01 * click) as f32
            })
            .collect();
        let dir = std::env::temp_dir().join(format!("struck-ab-residual-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("struck.wav");
        let spec = hound::WavSpec {
            channels: 1,
            sample_rate: rate,
            bits_per_sample: 32,
            sample_format: hound::SampleFormat::Float,
        };
        let mut w = hound::WavWriter::create(&file, spec).unwrap();
        for v in &x {
            w.write_sample(*v).unwrap();
        }
        w.finalize().unwrap();
        let req = |side| AbRequest {
            side,
            file: file.clone(),
            onset_s: onset as f64 / fs,
            duration_s: 0.5,
            features: feats.clone(),
            damping: law,
            object: ObjectModes::new(vec![1e6], &[vec![1.0]]),
            params: SoundParams::default(),
            position: 0.5,
            gamma_ratio: None,
            rate: 48_000.0,
        };
        let rec = build(&req(Side::Recording)).unwrap();
        let modes = build(&req(Side::Modes)).unwrap();
        let both = build(&req(Side::ModesResidual)).unwrap();
        let frames = 10; // the first 50 ms of the clip (5 ms pre-roll)
        let (alone, with) = (lsd(&modes, &rec, frames), lsd(&both, &rec, frames));
        println!("A/B log-spectral distance over the attack: modes {alone:.2} dB, modes + residual {with:.2} dB");
        assert!(with < 0.8 * alone, "{with} vs {alone}");
        let _ = std::fs::remove_dir_all(dir);
    }

    #[test]
    fn match_peak_scales_to_the_target() {
        let mut x = vec![0.1, -0.4, 0.2];
        match_peak(&mut x, 0.8);
        assert!((peak(&x) - 0.8).abs() < 1e-6);
        assert!((x[0] - 0.2).abs() < 1e-6);
        let mut z = vec![0.0; 4];
        match_peak(&mut z, 1.0);
        assert_eq!(z, vec![0.0; 4]);
    }
}
