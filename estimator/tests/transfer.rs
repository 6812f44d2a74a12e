//! Ren 2013 §6.2's residual transfer (issue 15 part 3), measured against what the transfer
//! must do by construction of the test signals, not by its own formulas:
//! - a uniformly scaled object (every mode's frequency × k) scales the residual's spectrum
//!   by k: the spectral centroid of the transferred residual, as resynthesised by
//!   Griffin–Lim, is k times the source's within 1 %;
//! - target modes that decay twice as fast halve the residual's duration;
//! - transferred back to the recording's own modes, modes + residual are closer to the
//!   recording than the modes alone (log-spectral distance), on a recording with a known
//!   click.

use estimator::psycho::{psycho_distance, PsychoSpace};
use estimator::residual::{power_spectrogram, residual_sound, Spectrogram, Stft, BINS, HOP};
use estimator::synth::{render, Rng};
use estimator::transfer::{transfer, transfer_spectrogram, Mode, Source};

const FS: f64 = 48_000.0;

/// Six modes from 300 Hz to 6 kHz: (f, d, a).
fn modes() -> Vec<(f64, f64, f64)> {
    (0..6)
        .map(|i| (300.0 * 20f64.powf(f64::from(i) / 5.0), 8.0 + 3.0 * f64::from(i), 0.3 / (1.0 + f64::from(i))))
        .collect()
}

fn as_modes(m: &[(f64, f64, f64)]) -> Vec<Mode> {
    m.iter().map(|&(f, d, a)| Mode { freq_hz: f, decay_per_s: d, amplitude: a }).collect()
}

/// A contact's noise: 60 random partials from 1.5 to 4 kHz under a 5 ms decay.
fn burst(n: usize, seed: u64) -> Vec<f64> {
    let mut rng = Rng::new(seed);
    let parts: Vec<(f64, f64, f64)> = (0..60)
        .map(|_| (1500.0 + 2500.0 * rng.uniform(), std::f64::consts::TAU * rng.uniform(), rng.uniform()))
        .collect();
    (0..n)
        .map(|k| {
            let t = k as f64 / FS;
            let s: f64 = parts.iter().map(|&(f, ph, a)| a * (std::f64::consts::TAU * f * t + ph).sin()).sum();
            0.02 * s * (-t / 0.005).exp()
        })
        .collect()
}

/// Power-weighted mean frequency of a spectrogram, Hz.
fn centroid(s: &Spectrogram, fs: f64) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for m in 0..s.frames {
        for k in 0..BINS {
            let p = s.power[m * BINS + k];
            num += p * k as f64 * fs / 1024.0;
            den += p;
        }
    }
    num / den
}

/// Energy-weighted mean time of a signal, s.
fn mean_time(x: &[f64]) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for (n, v) in x.iter().enumerate() {
        num += v * v * n as f64 / FS;
        den += v * v;
    }
    num / den
}

#[test]
fn a_scaled_object_scales_the_residual_spectrum() {
    let src_modes = as_modes(&modes());
    let residual = burst(16_800, 3);
    let spec = power_spectrogram(&residual);
    let src = Source { power: &spec.power, frames: spec.frames, sample_rate: FS, modes: &src_modes };
    let c0 = centroid(&spec, FS);
    let mut plan = Stft::<f32>::new();
    for k in [0.8, 1.25] {
        let target: Vec<Mode> = src_modes.iter().map(|m| Mode { freq_hz: m.freq_hz * k, ..*m }).collect();
        let t = transfer(&mut plan, &src, &target, FS, 1);
        let c_spec = centroid(&transfer_spectrogram(&src, &t.pairs, FS), FS);
        let c_sig = centroid(&power_spectrogram(&t.signal), FS);
        println!(
            "k {k}: centroid {c0:.1} Hz → spectrogram {c_spec:.1} ({:.4}), signal {c_sig:.1} ({:.4}); \
             Griffin–Lim {} iterations, spectral convergence {:.3}",
            c_spec / c0 / k,
            c_sig / c0 / k,
            t.iterations,
            t.convergence
        );
        assert_eq!(t.pairs.len(), 6);
        assert!((c_spec / c0 / k - 1.0).abs() < 0.01, "spectrogram centroid ratio {}", c_spec / c0);
        assert!((c_sig / c0 / k - 1.0).abs() < 0.01, "signal centroid ratio {}", c_sig / c0);
    }
}

#[test]
fn faster_target_decays_shorten_the_residual() {
    let src_modes = as_modes(&modes());
    // A residual that lasts: the burst under a 40 ms decay.
    let residual: Vec<f64> = burst(16_800, 5)
        .iter()
        .enumerate()
        .map(|(n, v)| v * (n as f64 / FS / 0.005 - n as f64 / FS / 0.04).exp())
        .collect();
    let spec = power_spectrogram(&residual);
    let src = Source { power: &spec.power, frames: spec.frames, sample_rate: FS, modes: &src_modes };
    let mut plan = Stft::<f32>::new();
    let same = transfer(&mut plan, &src, &src_modes, FS, 1);
    let faster: Vec<Mode> = src_modes.iter().map(|m| Mode { decay_per_s: 2.0 * m.decay_per_s, ..*m }).collect();
    let fast = transfer(&mut plan, &src, &faster, FS, 1);
    let (t0, t1, t2) = (mean_time(&residual), mean_time(&same.signal), mean_time(&fast.signal));
    println!("mean time: source {t0:.4} s, same modes {t1:.4} s, decays × 2 {t2:.4} s");
    assert!((t1 / t0 - 1.0).abs() < 0.1, "{t1} vs {t0}");
    assert!((t2 / t1 - 0.5).abs() < 0.05, "{t2} vs {t1}");
}

/// Log-spectral distance, dB: the RMS over cells of the difference of the two spectrograms
/// in dB, each floored 100 dB under the reference's strongest cell.
fn lsd(a: &Spectrogram, reference: &Spectrogram, frames: usize) -> f64 {
    let top = reference.power.iter().copied().fold(0.0, f64::max);
    let floor = top * 1e-10;
    let db = |p: f64| 10.0 * (p + floor).log10();
    let cells = frames * BINS;
    let sum: f64 = (0..cells).map(|i| (db(a.power[i]) - db(reference.power[i])).powi(2)).sum();
    (sum / cells as f64).sqrt()
}

#[test]
fn transferred_to_its_own_modes_the_residual_brings_the_recording_back() {
    let n = 16_800; // 0.35 s, as a capture keeps
    let m = modes();
    let modal = render(&m, FS, n);
    let click = burst(n, 11);
    let recording: Vec<f64> = modal.iter().zip(&click).map(|(a, b)| a + b).collect();
    let features: Vec<estimator::Feature> = m
        .iter()
        .map(|&(f, d, a)| estimator::Feature { freq_hz: f, decay_per_s: d, amplitude: a, ..Default::default() })
        .collect();
    let r = residual_sound(&recording, &features, &[1.0; 6], FS, n);
    let spec = power_spectrogram(&r);
    let src_modes = as_modes(&m);
    let src = Source { power: &spec.power, frames: spec.frames, sample_rate: FS, modes: &src_modes };
    let t = transfer(&mut Stft::<f32>::new(), &src, &src_modes, FS, 7);
    let with: Vec<f64> = modal.iter().zip(t.signal.iter().chain(std::iter::repeat(&0.0))).map(|(a, b)| a + b).collect();
    let rec = power_spectrogram(&recording);
    // The attack: the first 40 ms, where the click is.
    let frames = (0.04 * FS / HOP as f64) as usize;
    let (alone, both) = (lsd(&power_spectrogram(&modal), &rec, frames), lsd(&power_spectrogram(&with), &rec, frames));
    println!("log-spectral distance over the attack: modes alone {alone:.2} dB, modes + residual {both:.2} dB");
    assert!(both < 0.5 * alone, "{both} vs {alone}");
    // Ren's image-domain metric (§5.2.1, eq. 19: loudness in half-Bark bands) over the whole
    // 0.35 s, both images calibrated by the recording's.
    let space = PsychoSpace::new(FS);
    let frames = space.frames_for(0.35);
    let image = |x: &[f64]| space.image_of_signal(x, frames);
    let reference = image(&recording);
    let scale = PsychoSpace::calibration(&reference);
    let loud = |img: &estimator::psycho::BandImage| {
        let mut out = Vec::new();
        space.loudness(img, scale, &mut out);
        out
    };
    let r = loud(&reference);
    let (alone, both) = (psycho_distance(&loud(&image(&modal)), &r), psycho_distance(&loud(&image(&with)), &r));
    println!("Ren's psycho metric over 0.35 s: modes alone {alone:.4} sone², modes + residual {both:.4} sone²");
    assert!(both < 0.25 * alone, "{both} vs {alone}");
}
