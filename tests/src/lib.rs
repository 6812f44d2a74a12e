//! The shared offline harness of Struck's cross-crate tests: render through the plugin's own
//! `process()` (see `struck::offline`) and measure the result.

use std::f64::consts::PI;
use struck::offline::OfflineHost;
use struck_cli::cli::{configured_host, note_events, NoteSpec, SoundOptions};

/// A configured host (object, material, parameters) at `sample_rate`.
///
/// # Panics
/// If the options are invalid (a test bug).
pub fn host(object: &str, material: &str, sample_rate: u32, set: &[(&str, f32)]) -> OfflineHost {
    let opts = SoundOptions {
        object: object.into(),
        material: material.into(),
        sample_rate,
        set: set.iter().map(|(k, v)| format!("{k}={v}")).collect(),
        ..SoundOptions::default()
    };
    configured_host(&opts, 4096).expect("valid options")
}

/// Renders `notes` for `seconds` in blocks of `block`, returning the left channel (both
/// channels are checked to be equal and finite).
pub fn render(host: &mut OfflineHost, notes: &[NoteSpec], seconds: f64, block: usize) -> Vec<f32> {
    let sr = f64::from(host.sample_rate());
    let events = note_events(notes, sr);
    let (out, _) = host.render(&events, (seconds * sr).round() as usize, block);
    assert!(out[0].iter().all(|x| x.is_finite()), "non-finite output");
    assert_eq!(out[0], out[1], "channels differ");
    out[0].clone()
}

/// One note at time 0.
pub fn note(key: u8, velocity: u8, position: Option<f32>) -> NoteSpec {
    NoteSpec { key, velocity, position, start_s: 0.0, duration_s: None }
}

/// Complex demodulation of `x` at `freq_hz` over `[start, start + len)` samples with a
/// Blackman–Harris window: ≈ the complex amplitude of a component near that frequency, with
/// leakage from components more than 4 bins (4·fs/len Hz) away below −92 dB.
pub fn demodulate(x: &[f32], sample_rate: f64, freq_hz: f64, start: usize, len: usize) -> (f64, f64) {
    let (a0, a1, a2, a3) = (0.35875, 0.48829, 0.14128, 0.01168);
    let w = 2.0 * PI * freq_hz / sample_rate;
    let (mut re, mut im, mut norm) = (0.0, 0.0, 0.0);
    for n in 0..len {
        let t = n as f64 / (len - 1) as f64;
        let win = a0 - a1 * (2.0 * PI * t).cos() + a2 * (4.0 * PI * t).cos() - a3 * (6.0 * PI * t).cos();
        let k = start + n;
        let v = f64::from(x[k]) * win;
        let ph = w * k as f64;
        re += v * ph.cos();
        im -= v * ph.sin();
        norm += win;
    }
    (re / norm, im / norm)
}

/// Measures a damped sinusoid's frequency (Hz) and decay rate (s⁻¹) near `freq_hz` from the
/// phase advance and magnitude ratio of two demodulations `gap` samples apart: for
/// A·e^{(−d+iω)t}, shifting the window by Δ multiplies the result by e^{(−d+i(ω−ω̂))Δ}.
pub fn measure_mode(x: &[f32], sample_rate: f64, freq_hz: f64, start: usize, len: usize, gap: usize) -> (f64, f64) {
    let (r1, i1) = demodulate(x, sample_rate, freq_hz, start, len);
    let (r2, i2) = demodulate(x, sample_rate, freq_hz, start + gap, len);
    let dt = gap as f64 / sample_rate;
    // Phase of z2·conj(z1); the carrier phase was referenced to absolute time, so the
    // residual rotation is (ω − ω̂)·Δ.
    let re = r2 * r1 + i2 * i1;
    let im = i2 * r1 - r2 * i1;
    let dphi = im.atan2(re);
    let f = freq_hz + dphi / (2.0 * PI * dt);
    let m1 = (r1 * r1 + i1 * i1).sqrt();
    let m2 = (r2 * r2 + i2 * i2).sqrt();
    (f, (m1 / m2).ln() / dt)
}

/// Amplitude (peak of the sinusoid) of the component at `freq_hz` in the window.
pub fn amplitude(x: &[f32], sample_rate: f64, freq_hz: f64, start: usize, len: usize) -> f64 {
    let (r, i) = demodulate(x, sample_rate, freq_hz, start, len);
    2.0 * (r * r + i * i).sqrt()
}

/// Root-mean-square level.
pub fn rms(x: &[f32]) -> f64 {
    (x.iter().map(|v| f64::from(*v).powi(2)).sum::<f64>() / x.len().max(1) as f64).sqrt()
}

/// Spectral centroid (Hz) of `x` by a direct DFT over `bins` log-spaced frequencies
/// from 20 Hz to Nyquist (power-weighted).
pub fn spectral_centroid(x: &[f32], sample_rate: f64) -> f64 {
    let len = x.len().min(16384);
    let mut num = 0.0;
    let mut den = 0.0;
    let bins = 400;
    for b in 0..bins {
        let f = 20.0 * ((sample_rate / 2.0 * 0.95) / 20.0f64).powf(b as f64 / (bins - 1) as f64);
        let a = amplitude(x, sample_rate, f, 0, len);
        // Log-spaced bins: weight by bin width ∝ f.
        num += f * a * a * f;
        den += a * a * f;
    }
    num / den
}

/// Cents between two frequencies.
pub fn cents(a: f64, b: f64) -> f64 {
    1200.0 * (a / b).log2()
}

/// K-weighted RMS of `x` at 48 kHz: the two biquads of ITU-R BS.1770-4 run over the
/// samples (the recommendation's own procedure, independent of the engine's per-mode sum),
/// then the root mean square.
///
/// # Panics
/// If `sample_rate` is not 48 kHz (the recommendation's coefficients are for 48 kHz).
pub fn k_weighted_rms(x: &[f32], sample_rate: f64) -> f64 {
    assert_eq!(sample_rate, 48_000.0, "BS.1770 coefficients are for 48 kHz");
    let mut y: Vec<f64> = x.iter().map(|v| f64::from(*v)).collect();
    for [b0, b1, b2, a1, a2] in dsp::exciter::K_WEIGHTING_48K {
        let (mut x1, mut x2, mut y1, mut y2) = (0.0, 0.0, 0.0, 0.0);
        for v in y.iter_mut() {
            let out = b0 * *v + b1 * x1 + b2 * x2 - a1 * y1 - a2 * y2;
            (x2, x1, y2, y1) = (x1, *v, y1, out);
            *v = out;
        }
    }
    (y.iter().map(|v| v * v).sum::<f64>() / y.len().max(1) as f64).sqrt()
}

/// Peak absolute sample.
pub fn peak(x: &[f32]) -> f32 {
    x.iter().fold(0.0f32, |m, v| m.max(v.abs()))
}

/// dB of a linear ratio.
pub fn db(x: f64) -> f64 {
    20.0 * x.log10()
}

/// A mode as the science says it must ring, computed without the engine: frequency (Hz) and
/// decay rate (s⁻¹).
#[derive(Clone, Copy, Debug)]
pub struct ExpectedMode {
    /// f = √(λ s)/2π.
    pub freq_hz: f64,
    /// d = c(λ s)/2 with the material file's Rayleigh law c = α₁ + α₂λ (Ren 2013 eq. 6).
    pub decay_per_s: f64,
}

/// Every mode of factory bank `object` played at MIDI `key` with the default *Keys tune the
/// object* (the lowest mode at the key's equal-tempered pitch, A4 = 440 Hz: λ scale
/// s = (2π f_key)²/λ₀) and factory material `material`, whose file must hold a Rayleigh law.
/// Read from the bank's λ and the material's JSON file, not from the engine: the independent
/// truth the process tests compare the rendered sound with.
///
/// # Panics
/// If the bank or the material file is missing or not Rayleigh (a test bug).
pub fn expected_modes(object: &str, material: &str, key: u8) -> Vec<ExpectedMode> {
    let lib = struck::library::Library::factory();
    let bank = &lib.banks[lib.bank_index(object).expect("factory bank")];
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../presets/factory/materials")
        .join(format!("{material}.json"));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).expect("material file")).expect("material JSON");
    assert_eq!(json["damping"]["model"], "rayleigh", "{material}: not a Rayleigh material");
    let p = &json["damping"]["params"];
    let (alpha1, alpha2) = (p[0].as_f64().expect("alpha1"), p[1].as_f64().expect("alpha2"));
    let lambda0 = bank.lambdas.iter().copied().fold(f64::INFINITY, f64::min);
    let f_key = 440.0 * 2f64.powf((f64::from(key) - 69.0) / 12.0);
    let scale = (2.0 * PI * f_key).powi(2) / lambda0;
    bank.lambdas
        .iter()
        .map(|&l| ExpectedMode {
            freq_hz: (l * scale).sqrt() / (2.0 * PI),
            decay_per_s: 0.5 * (alpha1 + alpha2 * l * scale),
        })
        .collect()
}

/// The expected mode nearest `freq_hz`, and its distance in cents.
///
/// # Panics
/// If `modes` is empty.
pub fn nearest_expected(modes: &[ExpectedMode], freq_hz: f64) -> (ExpectedMode, f64) {
    let m = modes
        .iter()
        .copied()
        .min_by(|a, b| cents(a.freq_hz, freq_hz).abs().total_cmp(&cents(b.freq_hz, freq_hz).abs()))
        .expect("modes");
    (m, cents(m.freq_hz, freq_hz))
}
