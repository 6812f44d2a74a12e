//! Known object (Ren et al. 2013 §5, simplified): given a bank's reference eigenvalues λᵢ⁰,
//! find the specific-modulus ratio r = γ/γ₀ (λᵢ = r λᵢ⁰, Ren eq. 10) that best aligns the
//! bank's predicted modes with the extracted features, and an amplitude scale (Ren eq. 11).
//!
//! Simplification of Ren's Π_hybrid: instead of the psychoacoustic spectrogram metric we
//! score r by a soft count of matched features (log-frequency distance within ~1 %),
//! weighted by feature amplitude, searched over every (feature, bank mode) alignment as Ren's
//! starting points; the best r is then refined by a weighted mean of the log mismatches of
//! the matched pairs.

use serde::{Deserialize, Serialize};

use crate::features::Feature;

/// Result of matching a known object's modes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ObjectMatch {
    /// Specific-modulus ratio γ/γ₀ (scale on λ).
    pub gamma_ratio: f64,
    /// Amplitude scale σ: matched feature amplitude ≈ σ × bank gain (gain 1 if not given).
    pub amplitude_scale: f64,
    /// Features matched to a bank mode within 1 %.
    pub matched: usize,
    /// Features considered.
    pub features: usize,
    /// Amplitude-weighted RMS log-frequency mismatch of matched pairs, cents.
    pub rms_cents: f64,
}

/// Relative frequency tolerance of a match.
const TOL: f64 = 0.01;

/// Matches `features` to bank eigenvalues `lambdas0` (rad²/s²); `gains0` are optional
/// per-mode gains for the amplitude scale. Returns `None` when either list is empty.
pub fn match_object(features: &[Feature], lambdas0: &[f64], gains0: Option<&[f64]>) -> Option<ObjectMatch> {
    let mut bank: Vec<(f64, usize)> = lambdas0
        .iter()
        .enumerate()
        .filter(|(_, &l)| l > 0.0 && l.is_finite())
        .map(|(i, &l)| (0.5 * l.ln(), i))
        .collect();
    if bank.is_empty() || features.is_empty() {
        return None;
    }
    bank.sort_by(|a, b| a.0.total_cmp(&b.0));
    // ln ω of each feature (ω² = λ); weight by amplitude.
    let feats: Vec<(f64, f64)> = features.iter().map(|f| (0.5 * f.lambda().ln(), f.amplitude)).collect();
    let wsum: f64 = feats.iter().map(|f| f.1).sum::<f64>().max(1e-300);
    let tol = (1.0 + TOL).ln();
    // Nearest bank mode (in ln ω) to `v`.
    let nearest = |v: f64| -> (f64, usize) {
        let i = bank.partition_point(|b| b.0 < v);
        let mut best = (f64::INFINITY, 0);
        for j in [i.wrapping_sub(1), i] {
            if let Some(b) = bank.get(j) {
                let dd = (v - b.0).abs();
                if dd < best.0 {
                    best = (dd, b.1);
                }
            }
        }
        best
    };
    let score = |half_ln_r: f64| -> f64 {
        feats
            .iter()
            .map(|&(lw, a)| {
                let (dd, _) = nearest(lw - half_ln_r);
                a * (-(dd / tol).powi(2) * 0.5).exp()
            })
            .sum::<f64>()
            / wsum
    };
    // Candidates: align each of the strongest features with each of the lowest bank modes.
    let mut order: Vec<usize> = (0..feats.len()).collect();
    order.sort_by(|&a, &b| feats[b].1.total_cmp(&feats[a].1));
    let mut best = (f64::NEG_INFINITY, 0.0);
    for &fi in order.iter().take(12) {
        for b in bank.iter().take(64) {
            let h = feats[fi].0 - b.0;
            let s = score(h);
            if s > best.0 {
                best = (s, h);
            }
        }
    }
    // Refine: weighted mean log mismatch of matched pairs, a few times.
    let mut h = best.1;
    for _ in 0..5 {
        let (mut num, mut den) = (0.0, 0.0);
        for &(lw, a) in &feats {
            let i = bank.partition_point(|b| b.0 < lw - h);
            for j in [i.wrapping_sub(1), i] {
                if let Some(b) = bank.get(j) {
                    if (lw - h - b.0).abs() < tol {
                        num += a * (lw - b.0);
                        den += a;
                    }
                }
            }
        }
        if den > 0.0 {
            h = num / den;
        }
    }
    let (mut matched, mut ss, mut wm, mut ag, mut gg) = (0, 0.0, 0.0, 0.0, 0.0);
    for &(lw, a) in &feats {
        let (dd, bi) = nearest(lw - h);
        if dd < tol {
            matched += 1;
            ss += a * dd * dd;
            wm += a;
            let g = gains0.and_then(|g| g.get(bi)).copied().unwrap_or(1.0).abs();
            ag += a * g;
            gg += g * g;
        }
    }
    Some(ObjectMatch {
        gamma_ratio: (2.0 * h).exp(),
        amplitude_scale: if gg > 0.0 { ag / gg } else { 0.0 },
        matched,
        features: feats.len(),
        rms_cents: if wm > 0.0 { (ss / wm).sqrt() * 1200.0 / std::f64::consts::LN_2 } else { 0.0 },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_modulus_ratio() {
        let l0: Vec<f64> = [1.0, 2.76, 5.40, 8.93, 13.3, 18.6]
            .iter()
            .map(|k| k * (std::f64::consts::TAU * 300.0f64).powi(2))
            .collect();
        let r = 1.37;
        let feats: Vec<Feature> = l0
            .iter()
            .take(5)
            .map(|l| Feature {
                freq_hz: (r * l).sqrt() / std::f64::consts::TAU * 1.001,
                decay_per_s: 3.0,
                amplitude: 0.1,
            })
            .chain([Feature { freq_hz: 777.0, decay_per_s: 50.0, amplitude: 0.05 }])
            .collect();
        let m = match_object(&feats, &l0, None).unwrap();
        assert!((m.gamma_ratio / r - 1.0).abs() < 0.005, "{m:?}");
        assert_eq!(m.matched, 5);
    }
}
