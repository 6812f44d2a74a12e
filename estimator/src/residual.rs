//! Ren, Yeh & Lin 2013 §6.1: the residual — what a recording holds beyond the modes a
//! material represents (the contact's click, noise, partials no mode explains) — and
//! Griffin–Lim, to turn a (transferred) residual spectrogram back into sound (issue 15,
//! parts 2 and 3, first steps).
//!
//! The represented sound is the recording's features each weighted by its match ratio
//! R(φᵢ, Φ̃) ([`crate::ren`]): a feature the material matches fully is all represented, one it
//! does not match is all residual. The weight applies to the feature's power (amplitude
//! × √R: a feature half matched leaves half its power in the residual).
//!
//! Ren subtracts power spectrograms (recording − represented, floored at 0). Struck gives each
//! feature its phase instead — a linear least-squares fit of the features' complex amplitudes
//! to the recording, their frequencies and decays fixed ([`fit_amplitudes`]) — and subtracts
//! the represented sound from the recording sample by sample; the residual's spectrogram is
//! that difference's. Measured on a recording of eight modes and a 2 ms click
//! (`tests/residual.rs`): Ren's power subtraction left 3.9 times the click's energy around the
//! attack (a strong mode and the click interfere in the mode's bins, and the floor keeps their
//! cross term), the time-domain subtraction leaves the click's.
//!
//! Spectrograms: Hann frames of [`FRAME`] samples every [`HOP`] samples (75 % overlap), the
//! first frame centred on sample 0 (the signal is zero before it), one-sided power |X|².

use crate::features::Feature;
use realfft::num_complex::Complex64 as C64;
use realfft::RealFftPlanner;

/// Frame length, samples.
pub const FRAME: usize = 1024;
/// Hop between frames, samples.
pub const HOP: usize = 256;
/// Bins per frame.
pub const BINS: usize = FRAME / 2 + 1;

/// A one-sided power spectrogram, frame-major: `power[m * BINS + k]`.
#[derive(Clone, Debug, PartialEq)]
pub struct Spectrogram {
    /// Frames.
    pub frames: usize,
    /// |X|² per frame and bin.
    pub power: Vec<f64>,
}

/// The periodic Hann window of [`FRAME`] samples.
fn hann() -> Vec<f64> {
    (0..FRAME).map(|i| 0.5 - 0.5 * (std::f64::consts::TAU * i as f64 / FRAME as f64).cos()).collect()
}

/// Number of frames that cover `len` samples (frames centred every [`HOP`] from sample 0).
pub fn frames_for(len: usize) -> usize {
    len.div_ceil(HOP) + 1
}

/// The complex STFT of `x` (Hann, centred frames), frame-major.
fn stft(x: &[f64], frames: usize) -> Vec<C64> {
    let w = hann();
    let mut planner = RealFftPlanner::<f64>::new();
    let fft = planner.plan_fft_forward(FRAME);
    let (mut buf, mut out) = (fft.make_input_vec(), fft.make_output_vec());
    let mut spec = Vec::with_capacity(frames * BINS);
    for m in 0..frames {
        let start = (m * HOP) as isize - (FRAME / 2) as isize;
        for (i, b) in buf.iter_mut().enumerate() {
            let n = start + i as isize;
            *b = if n >= 0 && (n as usize) < x.len() { x[n as usize] * w[i] } else { 0.0 };
        }
        // The buffers have the plan's lengths.
        let _ = fft.process(&mut buf, &mut out);
        spec.extend_from_slice(&out);
    }
    spec
}

/// The inverse of [`stft`] by weighted overlap-add (Hann synthesis window, normalised by
/// Σ w², so that an unmodified STFT returns its signal), `len` samples.
fn istft(spec: &[C64], frames: usize, len: usize) -> Vec<f64> {
    let w = hann();
    let mut planner = RealFftPlanner::<f64>::new();
    let ifft = planner.plan_fft_inverse(FRAME);
    let (mut buf, mut frame) = (ifft.make_input_vec(), ifft.make_output_vec());
    let (mut out, mut norm) = (vec![0.0; len], vec![0.0; len]);
    for m in 0..frames {
        buf.copy_from_slice(&spec[m * BINS..(m + 1) * BINS]);
        // A real signal's spectrum has real DC and Nyquist bins.
        buf[0].im = 0.0;
        buf[BINS - 1].im = 0.0;
        let _ = ifft.process(&mut buf, &mut frame);
        let start = (m * HOP) as isize - (FRAME / 2) as isize;
        for (i, &v) in frame.iter().enumerate() {
            let n = start + i as isize;
            if n >= 0 && (n as usize) < len {
                out[n as usize] += v / FRAME as f64 * w[i];
                norm[n as usize] += w[i] * w[i];
            }
        }
    }
    for (o, n) in out.iter_mut().zip(&norm) {
        if *n > 1e-12 {
            *o /= n;
        }
    }
    out
}

/// The power spectrogram of `x`.
pub fn power_spectrogram(x: &[f64]) -> Spectrogram {
    let frames = frames_for(x.len());
    let power = stft(x, frames).iter().map(|c| c.norm_sqr()).collect();
    Spectrogram { frames, power }
}

/// Each feature's amplitude and phase in `x` (sample 0 = the impact's start): the
/// least-squares fit of x[n] ≈ Σᵢ e^(−dᵢ n/fs)·(cᵢ cos ωᵢn + sᵢ sin ωᵢn) over the first
/// `fit_len` samples, frequencies and decays fixed, a tiny ridge (1e-9 of the diagonal's mean)
/// against near-equal features. Returns (cᵢ, sᵢ) per feature; (0, 0) for all if the system
/// is singular. Allocates; O(fit_len·(2K)²) for K features.
pub fn fit_amplitudes(x: &[f64], features: &[Feature], fs: f64, fit_len: usize) -> Vec<(f64, f64)> {
    let k = features.len();
    let n = 2 * k;
    let len = fit_len.min(x.len());
    if k == 0 || len == 0 {
        return vec![(0.0, 0.0); k];
    }
    let (mut ata, mut atb) = (vec![0.0; n * n], vec![0.0; n]);
    let mut row = vec![0.0; n];
    // Each basis pair by its own recursion (a rotating, decaying phasor).
    let steps: Vec<(f64, f64, f64)> = features
        .iter()
        .map(|f| {
            let w = std::f64::consts::TAU * f.freq_hz / fs;
            ((-f.decay_per_s / fs).exp(), w.cos(), w.sin())
        })
        .collect();
    let mut ph: Vec<(f64, f64)> = vec![(1.0, 0.0); k];
    for (t, &xt) in x[..len].iter().enumerate() {
        if t % 4096 == 0 {
            // Re-anchored now and then against round-off.
            for (p, f) in ph.iter_mut().zip(features) {
                let (w, m) =
                    (std::f64::consts::TAU * f.freq_hz / fs * t as f64, (-f.decay_per_s * t as f64 / fs).exp());
                *p = (m * w.cos(), m * w.sin());
            }
        }
        for (i, &(c, s)) in ph.iter().enumerate() {
            row[2 * i] = c;
            row[2 * i + 1] = s;
        }
        for i in 0..n {
            let ri = row[i];
            if ri == 0.0 {
                continue;
            }
            atb[i] += ri * xt;
            for j in i..n {
                ata[i * n + j] += ri * row[j];
            }
        }
        for (p, &(g, c, s)) in ph.iter_mut().zip(&steps) {
            *p = (g * (p.0 * c - p.1 * s), g * (p.0 * s + p.1 * c));
        }
    }
    for i in 0..n {
        for j in 0..i {
            ata[i * n + j] = ata[j * n + i];
        }
    }
    let ridge = 1e-9 * (0..n).map(|i| ata[i * n + i]).sum::<f64>() / n as f64;
    for i in 0..n {
        ata[i * n + i] += ridge;
    }
    if !crate::linalg::solve_small(&mut ata, &mut atb, n) {
        return vec![(0.0, 0.0); k];
    }
    (0..k).map(|i| (atb[2 * i], atb[2 * i + 1])).collect()
}

/// The represented sound over `len` samples: each feature with its fitted amplitude and
/// phase (`coeffs`, from [`fit_amplitudes`]) times √R (`ratios`: power weighted by the
/// match ratio).
pub fn represented_sound(features: &[Feature], coeffs: &[(f64, f64)], ratios: &[f64], len: usize, fs: f64) -> Vec<f64> {
    let mut out = vec![0.0; len];
    for ((f, &(c, s)), &r) in features.iter().zip(coeffs).zip(ratios) {
        let scale = r.clamp(0.0, 1.0).sqrt();
        if scale == 0.0 {
            continue;
        }
        let (w, d) = (std::f64::consts::TAU * f.freq_hz / fs, f.decay_per_s / fs);
        for (t, o) in out.iter_mut().enumerate() {
            let (ph, m) = (w * t as f64, (-d * t as f64).exp());
            *o += scale * m * (c * ph.cos() + s * ph.sin());
        }
    }
    out
}

/// The residual of `x` (an impact, sample 0 at its start) once `features` weighted by their
/// match ratios are taken out: x − [`represented_sound`], the features' amplitudes and phases
/// fitted over the first `fit_len` samples. Allocates.
pub fn residual_sound(x: &[f64], features: &[Feature], ratios: &[f64], fs: f64, fit_len: usize) -> Vec<f64> {
    let coeffs = fit_amplitudes(x, features, fs, fit_len);
    let rep = represented_sound(features, &coeffs, ratios, x.len(), fs);
    x.iter().zip(&rep).map(|(a, b)| a - b).collect()
}

/// The residual of one impact of a recording by a material (law `law`, mean support damping
/// `support_c`): the impact's first `seconds` from `samples` (mono, at `fs`), its features
/// matched against themselves with the material's decays (Ren's R(φᵢ, Φ̃), [`crate::ren`]),
/// their amplitudes and phases fitted over the first half second, and the represented sound
/// taken out ([`residual_sound`]). Returns the residual and the impact's R(Φ, Φ̃).
pub fn impact_residual(
    samples: &[f32],
    fs: f64,
    imp: &crate::ImpactFeatures,
    law: &dsp::Damping,
    support_c: f64,
    seconds: f64,
) -> (Vec<f64>, f64) {
    use crate::ren::{match_ratios, Point};
    let start = ((imp.onset_s * fs).round() as usize).min(samples.len());
    let len = ((imp.duration_s.min(seconds).max(0.0) * fs) as usize).min(samples.len() - start);
    let segment: Vec<f64> = samples[start..start + len].iter().map(|&v| f64::from(v)).collect();
    let reference: Vec<Point> =
        imp.features.iter().map(|f| Point::new(f.freq_hz, f.decay_per_s, f.amplitude)).collect();
    let estimated: Vec<Point> = imp
        .features
        .iter()
        .map(|f| Point::new(f.freq_hz, 0.5 * (law.c(f.lambda()) + support_c), f.amplitude))
        .collect();
    let m = match_ratios(&reference, &estimated);
    let fit_len = len.min((0.5 * fs) as usize);
    (residual_sound(&segment, &imp.features, &m.per_reference, fs, fit_len), m.reference)
}

/// A signal of `len` samples whose power spectrogram approximates `target`: Griffin–Lim
/// (1984) with Perraudin, Balazs & Søndergaard's momentum (the fast Griffin–Lim, 2013,
/// α = 0.99): from phases drawn with `seed`, impose the target magnitudes, take the
/// phases of the STFT of the inverse, and step on past the new estimate by α of the change.
/// Stops when the spectral convergence ‖|STFT(x)| − |X|‖ / ‖X‖ improves by less than 0.1 % of
/// itself over 10 iterations, or after `max_iterations`. Returns the signal and the final
/// spectral convergence.
pub fn griffin_lim(target: &Spectrogram, len: usize, max_iterations: usize, seed: u64) -> (Vec<f64>, f64) {
    const ALPHA: f64 = 0.99;
    let mag: Vec<f64> = target.power.iter().map(|p| p.max(0.0).sqrt()).collect();
    let total = mag.iter().map(|m| m * m).sum::<f64>().sqrt();
    if total <= 0.0 {
        return (vec![0.0; len], 0.0);
    }
    let frames = target.frames;
    let mut rng = crate::synth::Rng::new(seed);
    let project = |s: &mut [C64]| {
        for (c, &m) in s.iter_mut().zip(&mag) {
            let n = c.norm();
            *c = if n > 0.0 { *c * (m / n) } else { C64::new(m, 0.0) };
        }
    };
    let mut t: Vec<C64> = mag.iter().map(|&m| C64::from_polar(m, std::f64::consts::TAU * rng.uniform())).collect();
    let mut prev = t.clone();
    let mut x = istft(&t, frames, len);
    let (mut err, mut best) = (f64::INFINITY, (x.clone(), f64::INFINITY));
    let mut checkpoint = f64::INFINITY;
    for i in 0..max_iterations.max(1) {
        let mut c = stft(&x, frames);
        err = c.iter().zip(&mag).map(|(c, m)| (c.norm() - m).powi(2)).sum::<f64>().sqrt() / total;
        if err < best.1 {
            best = (x.clone(), err);
        }
        if i % 10 == 9 {
            if checkpoint - err < 1e-3 * err {
                break;
            }
            checkpoint = err;
        }
        project(&mut c);
        for ((tn, cn), pn) in t.iter_mut().zip(&c).zip(prev.iter_mut()) {
            *tn = cn + (cn - *pn) * ALPHA;
            *pn = *cn;
        }
        x = istft(&t, frames, len);
    }
    let _ = err;
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The STFT and its inverse are exact inverses (weighted overlap-add with Σ w²).
    #[test]
    fn stft_and_its_inverse_return_the_signal() {
        let mut rng = crate::synth::Rng::new(5);
        let x: Vec<f64> = (0..5000).map(|_| rng.normal()).collect();
        let frames = frames_for(x.len());
        let y = istft(&stft(&x, frames), frames, x.len());
        let worst = x.iter().zip(&y).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        assert!(worst < 1e-9, "{worst}");
    }

    /// Parseval for one frame: a sinusoid of amplitude a on a bin centre gives a power of
    /// (a·Σw/2)² = (a·FRAME/4)² at that bin (the periodic Hann window sums to FRAME/2).
    #[test]
    fn a_bin_centred_sinusoid_has_the_closed_form_power() {
        let (k, a) = (40usize, 0.3);
        let x: Vec<f64> =
            (0..8192).map(|n| a * (std::f64::consts::TAU * (k * n) as f64 / FRAME as f64).sin()).collect();
        let s = power_spectrogram(&x);
        let m = 10; // a frame well inside the signal
        let want = (a * FRAME as f64 / 4.0).powi(2);
        let got = s.power[m * BINS + k];
        assert!((got / want - 1.0).abs() < 1e-9, "{got} vs {want}");
    }

    /// Griffin–Lim on the spectrogram of a real signal (two glides and a decaying noise
    /// burst) converges: its spectral convergence falls below 0.1 and well under its start.
    #[test]
    fn griffin_lim_converges_on_a_consistent_spectrogram() {
        let fs = 48_000.0;
        let mut rng = crate::synth::Rng::new(9);
        let x: Vec<f64> = (0..24_000)
            .map(|n| {
                let t = n as f64 / fs;
                let burst = if n < 2_400 { 0.3 * rng.normal() * (-t * 200.0).exp() } else { 0.0 };
                0.2 * (std::f64::consts::TAU * (300.0 + 400.0 * t) * t).sin() * (-3.0 * t).exp() + burst
            })
            .collect();
        let target = power_spectrogram(&x);
        let (_, first) = griffin_lim(&target, x.len(), 1, 1);
        let (y, sc) = griffin_lim(&target, x.len(), 200, 1);
        assert!(sc < 0.1 && sc < 0.5 * first, "spectral convergence {sc} (after one iteration {first})");
        let e = |v: &[f64]| v.iter().map(|s| s * s).sum::<f64>();
        assert!((e(&y) / e(&x) - 1.0).abs() < 0.1, "energy {} vs {}", e(&y), e(&x));
    }
}
