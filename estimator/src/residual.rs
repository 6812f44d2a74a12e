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
use realfft::num_complex::{Complex, Complex32 as C32, Complex64 as C64};
use realfft::num_traits::Float;
use realfft::{FftNum, RealFftPlanner};

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

/// FFT plans, window and work buffers for [`FRAME`]-sample STFTs, made once and reused (an
/// iterative phase reconstruction runs hundreds of transforms).
/// In `f64` for analysis, in `f32` for Griffin–Lim (twice the speed; its error is far
/// below a reconstruction's).
pub struct Stft<T: FftNum + Float = f64> {
    window: Vec<T>,
    forward: std::sync::Arc<dyn realfft::RealToComplex<T>>,
    inverse: std::sync::Arc<dyn realfft::ComplexToReal<T>>,
    time: Vec<T>,
    freq: Vec<Complex<T>>,
    scratch_fwd: Vec<Complex<T>>,
    scratch_inv: Vec<Complex<T>>,
    /// 1 / (FRAME·Σ w²) per sample of the last inverse's length, and its frame count.
    norm: Vec<T>,
    norm_frames: usize,
}

impl<T: FftNum + Float> Default for Stft<T> {
    fn default() -> Self {
        Stft::new()
    }
}

impl<T: FftNum + Float> Stft<T> {
    /// Plans for [`FRAME`] samples.
    pub fn new() -> Stft<T> {
        let mut planner = RealFftPlanner::<T>::new();
        let forward = planner.plan_fft_forward(FRAME);
        let inverse = planner.plan_fft_inverse(FRAME);
        Stft {
            window: hann().into_iter().map(|w| T::from_f64(w).unwrap_or_else(T::zero)).collect(),
            time: forward.make_input_vec(),
            freq: forward.make_output_vec(),
            scratch_fwd: forward.make_scratch_vec(),
            scratch_inv: inverse.make_scratch_vec(),
            forward,
            inverse,
            norm: Vec::new(),
            norm_frames: 0,
        }
    }

    /// The complex STFT of `x` (Hann, centred frames) into `spec` (frame-major, `frames` ×
    /// [`BINS`]).
    pub fn forward(&mut self, x: &[T], frames: usize, spec: &mut Vec<Complex<T>>) {
        spec.clear();
        for m in 0..frames {
            let start = (m * HOP) as isize - (FRAME / 2) as isize;
            let first = (-start).max(0) as usize;
            let last = (x.len() as isize - start).clamp(0, FRAME as isize) as usize;
            self.time.fill(T::zero());
            for i in first..last.max(first) {
                self.time[i] = x[(start + i as isize) as usize] * self.window[i];
            }
            // The buffers have the plan's lengths.
            let _ = self.forward.process_with_scratch(&mut self.time, &mut self.freq, &mut self.scratch_fwd);
            spec.extend_from_slice(&self.freq);
        }
    }

    /// The inverse of [`Stft::forward`] by weighted overlap-add (Hann synthesis window,
    /// normalised by Σ w², so that an unmodified STFT returns its signal) into `out` (its
    /// length is the signal's).
    pub fn inverse(&mut self, spec: &[Complex<T>], frames: usize, out: &mut [T]) {
        let len = out.len();
        out.fill(T::zero());
        if self.norm.len() != len || self.norm_frames != frames {
            // 1 / Σ w² per sample, for this length (the same for every inverse of it).
            let mut norm = vec![0.0f64; len];
            let window = hann();
            for m in 0..frames {
                let start = (m * HOP) as isize - (FRAME / 2) as isize;
                for (i, w) in window.iter().enumerate() {
                    let n = start + i as isize;
                    if n >= 0 && (n as usize) < len {
                        norm[n as usize] += w * w;
                    }
                }
            }
            self.norm =
                norm.into_iter()
                    .map(|n| {
                        if n > 1e-12 {
                            T::from_f64(1.0 / (n * FRAME as f64)).unwrap_or_else(T::zero)
                        } else {
                            T::zero()
                        }
                    })
                    .collect();
            self.norm_frames = frames;
        }
        for m in 0..frames {
            self.freq.copy_from_slice(&spec[m * BINS..(m + 1) * BINS]);
            // A real signal's spectrum has real DC and Nyquist bins.
            self.freq[0].im = T::zero();
            self.freq[BINS - 1].im = T::zero();
            let _ = self.inverse.process_with_scratch(&mut self.freq, &mut self.time, &mut self.scratch_inv);
            let start = (m * HOP) as isize - (FRAME / 2) as isize;
            let first = (-start).max(0) as usize;
            let last = (len as isize - start).clamp(0, FRAME as isize) as usize;
            for i in first..last {
                let o = &mut out[(start + i as isize) as usize];
                *o = *o + self.time[i] * self.window[i];
            }
        }
        for (o, &n) in out.iter_mut().zip(&self.norm) {
            *o = *o * n;
        }
    }
}

/// The complex STFT of `x` (Hann, centred frames), frame-major.
fn stft(x: &[f64], frames: usize) -> Vec<C64> {
    let mut spec = Vec::with_capacity(frames * BINS);
    Stft::<f64>::new().forward(x, frames, &mut spec);
    spec
}

/// The inverse of [`stft`], `len` samples.
#[cfg(test)]
fn istft(spec: &[C64], frames: usize, len: usize) -> Vec<f64> {
    let mut out = vec![0.0; len];
    Stft::<f64>::new().inverse(spec, frames, &mut out);
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

/// The frames of its file [`read_impact_residual`] takes of the impact `imp` at `fs` Hz: from
/// its onset, its analysed duration but at most `seconds` (not clipped to the file).
pub fn impact_stretch(imp: &crate::ImpactFeatures, fs: f64, seconds: f64) -> std::ops::Range<usize> {
    let start = (imp.onset_s * fs).round() as usize;
    start..start.saturating_add((imp.duration_s.min(seconds).max(0.0) * fs) as usize)
}

/// The residual of one impact of a recording by a material (law `law`, mean support damping
/// `support_c`): the impact's first `seconds` read from the WAV file at `path` (`channel` as
/// in [`crate::load_wav`]; only that stretch, [`impact_stretch`], is kept in memory by
/// [`crate::wav::load_wav_window`], so an impact in an hour-long session costs its own
/// seconds), its features matched against themselves with the material's decays (Ren's
/// R(φᵢ, Φ̃), [`crate::ren`]), their amplitudes and phases fitted over the first half second,
/// and the represented sound taken out ([`residual_sound`]). Returns the residual, the
/// impact's R(Φ, Φ̃) and the stretch as read.
///
/// # Errors
/// The file cannot be read ([`crate::load_wav`]'s errors).
pub fn read_impact_residual(
    path: &std::path::Path,
    channel: Option<usize>,
    imp: &crate::ImpactFeatures,
    law: &dsp::Damping,
    support_c: f64,
    seconds: f64,
) -> Result<(Vec<f64>, f64, crate::Recording), crate::EstimateError> {
    use crate::ren::{match_ratios, Point};
    let rec = crate::wav::load_wav_window(path, channel, |rate| impact_stretch(imp, f64::from(rate), seconds))?;
    let fs = f64::from(rec.sample_rate);
    let len = rec.samples.len();
    let segment: Vec<f64> = rec.samples.iter().map(|&v| f64::from(v)).collect();
    let reference: Vec<Point> =
        imp.features.iter().map(|f| Point::new(f.freq_hz, f.decay_per_s, f.amplitude)).collect();
    let estimated: Vec<Point> = imp
        .features
        .iter()
        .map(|f| Point::new(f.freq_hz, 0.5 * (law.c(f.lambda()) + support_c), f.amplitude))
        .collect();
    let m = match_ratios(&reference, &estimated);
    let fit_len = len.min((0.5 * fs) as usize);
    Ok((residual_sound(&segment, &imp.features, &m.per_reference, fs, fit_len), m.reference, rec))
}

/// A signal of `len` samples whose power spectrogram approximates `target`: Griffin–Lim
/// (1984) with Perraudin, Balazs & Søndergaard's momentum (the fast Griffin–Lim, 2013,
/// α = 0.99): from phases drawn with `seed`, impose the target magnitudes, take the
/// phases of the STFT of the inverse, and step on past the new estimate by α of the change.
/// Stops when the spectral convergence ‖|STFT(x)| − |X|‖ / ‖X‖ improves by less than 0.1 % of
/// itself over 10 iterations, or after `max_iterations`. Returns the signal and the final
/// spectral convergence.
pub fn griffin_lim(target: &Spectrogram, len: usize, max_iterations: usize, seed: u64) -> (Vec<f64>, f64) {
    let r = griffin_lim_with(&mut Stft::<f32>::new(), target, len, max_iterations, seed);
    (r.signal, r.convergence)
}

/// What [`griffin_lim_with`] returns.
#[derive(Clone, Debug)]
pub struct PhaseReconstruction {
    /// The signal.
    pub signal: Vec<f64>,
    /// Its spectral convergence ‖|STFT(x)| − |X|‖ / ‖X‖ against the target.
    pub convergence: f64,
    /// Iterations run.
    pub iterations: usize,
}

/// [`griffin_lim`] with the caller's plans (reused across calls), in `f32`.
pub fn griffin_lim_with(
    plan: &mut Stft<f32>,
    target: &Spectrogram,
    len: usize,
    max_iterations: usize,
    seed: u64,
) -> PhaseReconstruction {
    const ALPHA: f32 = 0.99;
    let mag: Vec<f32> = target.power.iter().map(|p| p.max(0.0).sqrt() as f32).collect();
    let total = target.power.iter().map(|p| p.max(0.0)).sum::<f64>().sqrt();
    if total <= 0.0 || len == 0 {
        return PhaseReconstruction { signal: vec![0.0; len], convergence: 0.0, iterations: 0 };
    }
    let frames = target.frames;
    let mut rng = crate::synth::Rng::new(seed);
    let mut t: Vec<C32> =
        mag.iter().map(|&m| C32::from_polar(m, (std::f64::consts::TAU * rng.uniform()) as f32)).collect();
    let mut prev = t.clone();
    let mut x = vec![0.0f32; len];
    plan.inverse(&t, frames, &mut x);
    let mut c = Vec::with_capacity(t.len());
    let (mut best, mut best_err) = (x.clone(), f64::INFINITY);
    let mut checkpoint = f64::INFINITY;
    let mut iterations = 0;
    for i in 0..max_iterations.max(1) {
        plan.forward(&x, frames, &mut c);
        // One pass: the error of this estimate, the projection on the target magnitudes and
        // the momentum step.
        let mut sq = 0.0f64;
        for (((tn, cn), pn), &m) in t.iter_mut().zip(c.iter_mut()).zip(prev.iter_mut()).zip(&mag) {
            // |c| without hypot's care for overflow (|c|² is far inside f32's range here).
            let n = (cn.re * cn.re + cn.im * cn.im).sqrt();
            sq += f64::from((n - m) * (n - m));
            *cn = if n > 0.0 { *cn * (m / n) } else { C32::new(m, 0.0) };
            *tn = *cn + (*cn - *pn) * ALPHA;
            *pn = *cn;
        }
        let err = sq.sqrt() / total;
        if err < best_err {
            best.copy_from_slice(&x);
            best_err = err;
        }
        if i % 10 == 9 {
            if checkpoint - err < 1e-3 * err {
                break;
            }
            checkpoint = err;
        }
        plan.inverse(&t, frames, &mut x);
        iterations = i + 1;
    }
    PhaseReconstruction { signal: best.into_iter().map(f64::from).collect(), convergence: best_err, iterations }
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
