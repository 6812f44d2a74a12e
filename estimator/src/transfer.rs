//! Ren, Yeh & Lin 2013 §6.2 (Algorithm 1): the residual of one recorded impact, transferred
//! to another object, size, material or strike point under the guidance of the modes
//! (issue 15 part 3).
//!
//! Ren's per-mode transform H_{i,j} takes the source mode φᵢˢ = (fᵢˢ, dᵢˢ, aᵢˢ) to its paired
//! target mode φⱼᵗ and acts on the residual's power spectrogram in the mode's band (from the
//! midpoint with the mode below to the midpoint with the mode above) exactly as it acts on
//! the mode's own power spectrogram:
//! 1. *shift* the band's frequencies from fᵢˢ to fⱼᵗ;
//! 2. *stretch* time by the ratio of the decays (the source's frame at τ = t·dⱼᵗ/dᵢˢ lands
//!    at t, so a mode decaying twice as fast in the target makes its residual twice as
//!    short);
//! 3. *scale* the intensity by A = P_modalᵗ / P_modalˢ'', the target mode's power
//!    spectrogram over the shifted and stretched source mode's;
//!
//! then stitches the bands and reconstructs a signal from the power spectrogram with
//! Griffin–Lim ([`crate::residual::griffin_lim_with`]).
//!
//! Choices where the paper is silent, and why:
//! - **Band map.** Inside a band Struck maps frequency piecewise linearly through the mode
//!   centres (the band's lower half [midpoint, fᵢˢ] onto [midpoint, fⱼᵗ], its upper half
//!   likewise), so the midpoints map onto midpoints and the stitched bands neither overlap
//!   nor leave holes when source and target bands differ in width. It is a shift at the
//!   centre; below the first mode it is f·f₀ᵗ/f₀ˢ, above the last f·f_Nᵗ/f_Nˢ, so a uniformly
//!   scaled object scales the whole residual by the same factor (Ren's natural
//!   correspondence, tested to 1 %).
//! - **Pixel scale.** A mode's power in a frame is a²·e^(−2dt) times the window's response
//!   around its centre. Once stretched, both decays agree, and the band map puts centre on
//!   centre, so the ratio of the two modal spectrograms on the mode's ridge is (aⱼᵗ/aᵢˢ)²
//!   in every frame: Fig. 8's height scaling. Struck scales by that ratio; it does not
//!   divide the two window responses off the ridge, which would only notch the residual
//!   around each mode (the band map widens the source's peak, not the residual's physics).
//! - **Stitching.** Between two mode centres the power and time ratios blend in logs from
//!   one pair's to the next instead of switching at the midpoint, so the stitched
//!   spectrogram has no steps at the band edges.
//! - **Pairing.** Ren pairs modes by their natural correspondence when the target is the
//!   source object scaled, and otherwise pairs the N_dominant modes of largest energy
//!   (a²/4d, a damped sinusoid's) on each side from low to high frequency ([`pairs`]).
//!   Struck takes a target as the source scaled when each dominant source mode has a
//!   target mode at one common frequency ratio (within 1 %); a recording's features against
//!   an object's modes pair by dominance. A pair's power ratio is kept within ±20 dB of all pairs' together: when
//!   the two dominant sets differ, a mode paired with a far weaker one must not blow its
//!   band up.
//! - **Stretch limits.** The decay ratio is kept within [1/[`MAX_STRETCH`], [`MAX_STRETCH`]]:
//!   a click stretched further is no longer a click.

use crate::residual::{griffin_lim_with, PhaseReconstruction, Spectrogram, Stft, BINS, FRAME, HOP};

/// Most mode pairs (Ren's N_dominant).
pub const DOMINANT: usize = 12;
/// Largest time stretch or compression of a band.
pub const MAX_STRETCH: f64 = 4.0;
/// Longest transferred residual, s.
pub const MAX_SECONDS: f64 = 2.0;
/// Largest departure of one pair's power ratio from all pairs' (±20 dB).
const MAX_PAIR_RATIO: f64 = 100.0;

/// A mode as the transfer sees it: frequency (Hz), decay rate d (s⁻¹, the envelope
/// e^(−dt)), amplitude (any consistent unit on each side).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mode {
    /// Frequency, Hz.
    pub freq_hz: f64,
    /// Decay rate, s⁻¹.
    pub decay_per_s: f64,
    /// Amplitude.
    pub amplitude: f64,
}

impl Mode {
    /// Energy of the damped sinusoid a·e^(−dt)·sin(ωt): a²/(4d).
    fn energy(&self) -> f64 {
        self.amplitude * self.amplitude / (4.0 * self.decay_per_s.max(1e-3))
    }

    fn usable(&self, nyquist: f64) -> bool {
        self.freq_hz.is_finite()
            && self.freq_hz > 0.0
            && self.freq_hz < nyquist
            && self.decay_per_s.is_finite()
            && self.decay_per_s > 0.0
            && self.amplitude.is_finite()
            && self.amplitude != 0.0
    }
}

/// The source of a transfer: a residual power spectrogram ([`crate::residual`]'s grid:
/// [`FRAME`]-sample Hann frames every [`HOP`] samples, the first centred on the impact) at
/// `sample_rate`, and the recorded modes it belongs to.
#[derive(Clone, Debug)]
pub struct Source<'a> {
    /// |X|², frame-major, `frames` × [`BINS`].
    pub power: &'a [f64],
    /// Frames.
    pub frames: usize,
    /// Sample rate of the recording, Hz.
    pub sample_rate: f64,
    /// The recorded modes.
    pub modes: &'a [Mode],
}

/// One band of the transfer: the target mode's band and how it reads the source.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pair {
    /// The source mode.
    pub source: Mode,
    /// The target mode.
    pub target: Mode,
}

/// Ren's DetermineModePairs. When the target is the source scaled — each of the
/// [`DOMINANT`] source modes of largest energy has a target mode at one common frequency
/// ratio, within 1 % — the natural correspondence: each of those with its counterpart.
/// Otherwise the [`DOMINANT`] modes of largest energy on each side (those below each side's
/// Nyquist frequency), each side sorted by frequency, paired in order.
pub fn pairs(source: &[Mode], source_nyquist: f64, target: &[Mode], target_nyquist: f64) -> Vec<Pair> {
    let by_energy = |modes: &[Mode], nyquist: f64| {
        let mut m: Vec<Mode> = modes.iter().copied().filter(|m| m.usable(nyquist)).collect();
        m.sort_by(|a, b| b.energy().total_cmp(&a.energy()));
        m
    };
    let (mut s, mut t) = (by_energy(source, source_nyquist), by_energy(target, target_nyquist));
    if s.is_empty() || t.is_empty() {
        return Vec::new();
    }
    let n = DOMINANT.min(s.len()).min(t.len());
    // The natural correspondence: a scale k (tried from the strongest source mode to each
    // target mode) under which every dominant source mode has its counterpart.
    let mut t_freq: Vec<Mode> = t.clone();
    t_freq.sort_by(|a, b| a.freq_hz.total_cmp(&b.freq_hz));
    let counterpart = |f: f64| -> Option<Mode> {
        let i = t_freq.partition_point(|m| m.freq_hz < f);
        [i.wrapping_sub(1), i]
            .into_iter()
            .filter_map(|j| t_freq.get(j))
            .filter(|m| (m.freq_hz / f - 1.0).abs() < 0.01)
            .min_by(|a, b| (a.freq_hz - f).abs().total_cmp(&(b.freq_hz - f).abs()))
            .copied()
    };
    for cand in &t_freq {
        let k = cand.freq_hz / s[0].freq_hz;
        let matched: Option<Vec<Pair>> =
            s[..n].iter().map(|m| counterpart(m.freq_hz * k).map(|c| Pair { source: *m, target: c })).collect();
        if let Some(mut p) = matched {
            p.sort_by(|a, b| a.source.freq_hz.total_cmp(&b.source.freq_hz));
            // One target mode per source mode.
            if p.windows(2).all(|w| w[0].target.freq_hz < w[1].target.freq_hz) {
                return p;
            }
        }
    }
    s.truncate(n);
    t.truncate(n);
    s.sort_by(|a, b| a.freq_hz.total_cmp(&b.freq_hz));
    t.sort_by(|a, b| a.freq_hz.total_cmp(&b.freq_hz));
    s.into_iter().zip(t).map(|(source, target)| Pair { source, target }).collect()
}

/// The target's residual power spectrogram (the [`crate::residual`] grid at `sample_rate`):
/// Algorithm 1's shift, stretch and pixel scale per pair, stitched. With no pair (no mode on
/// one side) the source plays as recorded (resampled to the target rate).
pub fn transfer_spectrogram(src: &Source<'_>, pairs: &[Pair], sample_rate: f64) -> Spectrogram {
    let (fs_s, fs_t) = (src.sample_rate, sample_rate);
    let bin_s = fs_s / FRAME as f64;
    let bin_t = fs_t / FRAME as f64;
    let hop_s = HOP as f64 / fs_s;
    let hop_t = HOP as f64 / fs_t;
    let src_seconds = src.frames.saturating_sub(1) as f64 * hop_s;
    // Per band: time ratio (source time per target time) and amplitude ratio.
    let ratio = |p: &Pair| (p.target.decay_per_s / p.source.decay_per_s).clamp(1.0 / MAX_STRETCH, MAX_STRETCH);
    let longest = pairs.iter().map(|p| 1.0 / ratio(p)).fold(1.0f64, f64::max);
    let seconds = (src_seconds * longest).min(MAX_SECONDS);
    let frames = (seconds / hop_t).ceil() as usize + 1;
    let mut power = vec![0.0; frames * BINS];
    // The source power at a fractional frame and bin (bilinear; zero outside).
    let at = |frame: f64, bin: f64| -> f64 {
        if !(frame >= 0.0 && bin >= 0.0) {
            return 0.0;
        }
        let (m0, k0) = (frame.floor() as usize, bin.floor() as usize);
        if m0 >= src.frames || k0 >= BINS {
            return 0.0;
        }
        let (fm, fk) = (frame - m0 as f64, bin - k0 as f64);
        let p = |m: usize, k: usize| if m < src.frames && k < BINS { src.power[m * BINS + k] } else { 0.0 };
        (1.0 - fm) * ((1.0 - fk) * p(m0, k0) + fk * p(m0, k0 + 1))
            + fm * ((1.0 - fk) * p(m0 + 1, k0) + fk * p(m0 + 1, k0 + 1))
    };
    if pairs.is_empty() {
        for m in 0..frames {
            let frame = m as f64 * hop_t / hop_s;
            for k in 0..BINS {
                power[m * BINS + k] = at(frame, k as f64 * bin_t / bin_s);
            }
        }
        return Spectrogram { frames, power };
    }
    let n = pairs.len();
    // A pair's power ratio within ±20 dB of all pairs' together: a mode paired with one far
    // weaker or stronger (the dominant sets differ) must not blow its band up or empty it.
    let overall = pairs.iter().map(|p| p.target.amplitude.powi(2)).sum::<f64>()
        / pairs.iter().map(|p| p.source.amplitude.powi(2)).sum::<f64>();
    // Per pair, in logs: the source frequency, the power ratio and the time ratio.
    let log_amp: Vec<f64> = pairs
        .iter()
        .map(|p| {
            (p.target.amplitude / p.source.amplitude)
                .powi(2)
                .clamp(overall / MAX_PAIR_RATIO, overall * MAX_PAIR_RATIO)
                .ln()
        })
        .collect();
    let log_ratio: Vec<f64> = pairs.iter().map(|p| ratio(p).ln()).collect();
    // For a target frequency: the source frequency (the map through the mode centres), and
    // the power and time ratios, blended between the two pairs around it.
    let transform = |f: f64| -> (f64, f64, f64) {
        let (first, last) = (&pairs[0], &pairs[n - 1]);
        if f <= first.target.freq_hz {
            return (f * first.source.freq_hz / first.target.freq_hz, log_amp[0].exp(), log_ratio[0].exp());
        }
        if f >= last.target.freq_hz {
            return (f * last.source.freq_hz / last.target.freq_hz, log_amp[n - 1].exp(), log_ratio[n - 1].exp());
        }
        let j = pairs.partition_point(|p| p.target.freq_hz <= f).clamp(1, n - 1);
        let (a, b) = (&pairs[j - 1], &pairs[j]);
        let u = (f - a.target.freq_hz) / (b.target.freq_hz - a.target.freq_hz);
        let blend = |x: &[f64]| ((1.0 - u) * x[j - 1] + u * x[j]).exp();
        (a.source.freq_hz + u * (b.source.freq_hz - a.source.freq_hz), blend(&log_amp), blend(&log_ratio))
    };
    for k in 0..BINS {
        let (fs, scale, r) = transform(k as f64 * bin_t);
        let bin = fs / bin_s;
        for m in 0..frames {
            let frame = m as f64 * hop_t * r / hop_s;
            power[m * BINS + k] = scale * at(frame, bin);
        }
    }
    Spectrogram { frames, power }
}

/// What [`transfer`] returns.
#[derive(Clone, Debug)]
pub struct Transferred {
    /// The target residual, at the target rate.
    pub signal: Vec<f64>,
    /// The pairs that guided it.
    pub pairs: Vec<Pair>,
    /// Griffin–Lim's spectral convergence against the transferred spectrogram.
    pub convergence: f64,
    /// Iterations run.
    pub iterations: usize,
}

/// Griffin–Lim iterations the transfer runs: Ren's 10 (§6.2.2). Measured on transferred
/// residuals (`examples/gl_curve.rs`, README *Residual*), the spectral convergence is 0.20
/// after 10 iterations, 0.18 after 16 and 0.15 after 32: each doubling past 10 buys little
/// and costs the double.
pub const ITERATIONS: usize = 10;

/// Algorithm 1 whole: pairs, the transferred power spectrogram, and a signal with it
/// (`plan` reused across calls; `seed` fixes the first phases, so a transfer is
/// repeatable). Allocates; milliseconds (README).
pub fn transfer(plan: &mut Stft<f32>, src: &Source<'_>, target: &[Mode], sample_rate: f64, seed: u64) -> Transferred {
    let pairs = pairs(src.modes, 0.5 * src.sample_rate, target, 0.5 * sample_rate);
    let spec = transfer_spectrogram(src, &pairs, sample_rate);
    let len = (spec.frames.saturating_sub(1)) * HOP;
    let PhaseReconstruction { signal, convergence, iterations } = griffin_lim_with(plan, &spec, len, ITERATIONS, seed);
    Transferred { signal, pairs, convergence, iterations }
}

/// The transfer workload of the bench and `examples/gl_curve.rs`: a 1 s noise burst under a
/// 0.15 s decay at 48 kHz (seed 4), twelve source modes 200 Hz × 1.4ᵏ, and twelve target
/// modes a fifth up, decaying 1.3 times as fast, half as loud.
#[doc(hidden)]
pub fn transfer_workload() -> (Vec<f64>, Vec<Mode>, Vec<Mode>) {
    let fs = 48_000.0;
    let mut rng = crate::synth::Rng::new(4);
    let x = (0..48_000).map(|n| rng.normal() * (-(n as f64) / fs / 0.15).exp()).collect();
    let source: Vec<Mode> = (0..12)
        .map(|i| Mode { freq_hz: 200.0 * 1.4f64.powi(i), decay_per_s: 5.0 + 2.0 * f64::from(i), amplitude: 0.1 })
        .collect();
    let target = source
        .iter()
        .map(|m| Mode { freq_hz: 1.5 * m.freq_hz, decay_per_s: 1.3 * m.decay_per_s, amplitude: 0.05 })
        .collect();
    (x, source, target)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Pairing by dominance: no common frequency ratio, so the [`DOMINANT`]-limited strongest
    /// modes on each side (here three: the target has three), in frequency order.
    #[test]
    fn pairs_take_the_dominant_modes_in_frequency_order() {
        let m = |f: f64, a: f64| Mode { freq_hz: f, decay_per_s: 10.0, amplitude: a };
        let source = [m(100.0, 2.0), m(300.0, 1.0), m(200.0, 0.001), m(250.0, 1.0)];
        let target = [m(150.0, 1.0), m(450.0, 1.0), m(700.0, 1.0)];
        let p = pairs(&source, 24_000.0, &target, 24_000.0);
        let got: Vec<(f64, f64)> = p.iter().map(|p| (p.source.freq_hz, p.target.freq_hz)).collect();
        assert_eq!(got, [(100.0, 150.0), (250.0, 450.0), (300.0, 700.0)]);
    }

    /// Pairing by correspondence: a target that is the source × 1.3 (plus weak modes of its
    /// own in between) pairs each source mode with its counterpart.
    #[test]
    fn a_scaled_target_pairs_by_correspondence() {
        let m = |f: f64, a: f64| Mode { freq_hz: f, decay_per_s: 10.0, amplitude: a };
        let source: Vec<Mode> = (1..=5).map(|i| m(100.0 * f64::from(i).powf(1.7), 1.0 / f64::from(i))).collect();
        let mut target: Vec<Mode> = source.iter().map(|s| m(1.3 * s.freq_hz, 0.5 * s.amplitude)).collect();
        target.extend([m(200.0, 0.9), m(700.0, 0.8)]);
        let p = pairs(&source, 24_000.0, &target, 24_000.0);
        assert_eq!(p.len(), 5);
        for q in &p {
            assert!((q.target.freq_hz / q.source.freq_hz - 1.3).abs() < 1e-12, "{q:?}");
        }
    }
}
