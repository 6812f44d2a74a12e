//! Known object (Ren et al. 2013 §5, simplified): given a bank's reference eigenvalues λᵢ⁰,
//! find the specific-modulus ratio r = γ/γ₀ (λᵢ = r λᵢ⁰, Ren eq. 10) that best aligns the
//! bank's predicted modes with the extracted features, and an amplitude scale (Ren eq. 11).
//!
//! Simplification of Ren's Π_hybrid: instead of the psychoacoustic spectrogram metric we
//! score r by a soft count of matched features (log-frequency distance within ~1 %),
//! weighted by feature amplitude, searched over every (feature, bank mode) alignment as Ren's
//! starting points; the best r is then refined by a weighted mean of the log mismatches of
//! the matched pairs.
//!
//! A few recorded partials can also be "explained" by an object scaled far down, its dense
//! upper modes absorbing them (issue 10: a glockenspiel matched with the lowest mode at
//! 13.7 Hz). So a scale is penalised for every audible mode of the object that it puts below
//! the recording's lowest strong partial without a recorded feature there (a struck object's
//! low modes ring unless the strike sits on their node), for every strong partial it puts
//! below the object's lowest mode (nothing rings there), and for strong object modes inside
//! the recorded range that nothing matches; the candidates include aligning the lowest strong
//! partial with each of the object's lowest modes.

use serde::{Deserialize, Serialize};

use crate::features::Feature;

/// The specific-modulus ratios γ/γ₀ the instrument plays (its *Stiffness γ/γ₀* parameter):
/// a pitch fit outside them (the object's pitch scaled more than ~32× down or up) says the
/// recordings are not of that object, and a material carrying that pitch could not be played.
pub const PLAYABLE_GAMMA_RATIO: (f64, f64) = (0.001, 1000.0);

/// Whether `gamma_ratio` is a pitch the instrument can play ([`PLAYABLE_GAMMA_RATIO`]).
pub fn playable_gamma_ratio(gamma_ratio: f64) -> bool {
    (PLAYABLE_GAMMA_RATIO.0..=PLAYABLE_GAMMA_RATIO.1).contains(&gamma_ratio)
}

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
    /// RMS log-frequency mismatch of matched pairs, weighted by what each rings (the root
    /// of its energy over the first second), cents.
    pub rms_cents: f64,
    /// The recording's lowest strong partial (within 20 dB of the strongest in the root of
    /// its energy over the first second: an onset's fast component is not one), Hz.
    #[serde(default)]
    pub lowest_partial_hz: f64,
    /// The object's lowest audible mode at the fitted scale, Hz.
    #[serde(default)]
    pub object_lowest_hz: f64,
    /// Audible object modes below the lowest strong partial that no recorded feature
    /// matches (0 when the object's lowest mode is the recording's lowest partial).
    #[serde(default)]
    pub unmatched_modes_below: usize,
    /// Strong object modes (gain within 20 dB of the strongest) inside the recorded range
    /// that no recorded feature matches.
    #[serde(default)]
    pub unmatched_strong_modes: usize,
}

/// Relative frequency tolerance of a match.
const TOL: f64 = 0.01;
/// Score lost per audible object mode left unmatched below the lowest strong partial (the
/// score is the matched fraction weighted by what each feature rings, at most 1): such a
/// mode sounds a pitch the recording does not have. At 0.15, a xylophone's third partial
/// 3 % off the bar's 1 : 3 : 6 (FluidR3 key 83: 4290 Hz on 740) was worth leaving the bar's
/// lowest mode unmatched an octave and a fifth under the fundamental; at 0.3 the 20 tuned
/// bars of `tests/recordings` have their lowest mode within a semitone of the sample's
/// pitch on 19 (15 with amplitude weights and 0.15, 18 with these weights and 0.15).
const PENALTY_BELOW: f64 = 0.3;
/// Score lost per strong object mode left unmatched inside the recorded range.
const PENALTY_STRONG: f64 = 0.03;
/// A feature within this many dB of the strongest is a strong partial.
const STRONG_DB: f64 = 20.0;
/// A feature within this many dB of the strongest accounts for an object mode.
const HEARD_DB: f64 = 30.0;
/// Features are weighed by the root of their energy over this many seconds (`match_impl`).
const RING_S: f64 = 1.0;

/// Matches `features` to bank eigenvalues `lambdas0` (rad²/s²); `gains0` are optional
/// per-mode gains (e.g. the largest |gain| over the strike points) for the amplitude scale
/// and to tell audible modes (gain within 40 dB of the largest) from silent ones. Returns
/// `None` when either list is empty.
pub fn match_object(features: &[Feature], lambdas0: &[f64], gains0: Option<&[f64]>) -> Option<ObjectMatch> {
    match_impl(features, lambdas0, gains0, None)
}

/// The match of `features` by the bank at the given specific-modulus ratio `gamma_ratio`
/// (no search): matched features, mismatch and unmatched modes there, and the amplitude
/// scale of the matched pairs ([`match_object`]'s report of another fit's γ, e.g. Ren's).
pub fn match_object_at(
    features: &[Feature],
    lambdas0: &[f64],
    gains0: Option<&[f64]>,
    gamma_ratio: f64,
) -> Option<ObjectMatch> {
    (gamma_ratio > 0.0 && gamma_ratio.is_finite())
        .then(|| match_impl(features, lambdas0, gains0, Some(0.5 * gamma_ratio.ln())))
        .flatten()
}

fn match_impl(
    features: &[Feature],
    lambdas0: &[f64],
    gains0: Option<&[f64]>,
    fixed: Option<f64>,
) -> Option<ObjectMatch> {
    let gmax = gains0.map_or(1.0, |g| g.iter().fold(0.0f64, |m, v| m.max(v.abs())));
    let gain = |i: usize| gains0.and_then(|g| g.get(i)).map_or(1.0, |v| v.abs() / gmax.max(1e-300));
    let mut bank: Vec<(f64, usize)> = lambdas0
        .iter()
        .enumerate()
        .filter(|&(i, &l)| l > 0.0 && l.is_finite() && gain(i) >= 0.01)
        .map(|(i, &l)| (0.5 * l.ln(), i))
        .collect();
    if bank.is_empty() || features.is_empty() {
        return None;
    }
    bank.sort_by(|a, b| a.0.total_cmp(&b.0));
    // ln ω of each feature (ω² = λ), weighted by what it rings: the root of its energy over
    // the first second, a·√((1 − e^(−2d))/4d). The pitch a listener hears is the long-ringing
    // partials'; by amplitude at the strike, an onset's fast components (a marimba's 656 Hz
    // at d = 125 s⁻¹ under its 740 Hz fundamental; FluidR3 key 83) outweighed them and the
    // fit put the bar's second mode on the fundamental, two octaves down.
    let ringing = |f: &Feature| {
        let d = f.decay_per_s.max(0.0);
        let e = if d * RING_S < 1e-9 { RING_S / 2.0 } else { -(-2.0 * d * RING_S).exp_m1() / (4.0 * d) };
        f.amplitude * e.sqrt()
    };
    let feats: Vec<(f64, f64)> = features.iter().map(|f| (0.5 * f.lambda().ln(), ringing(f))).collect();
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
    // Strong partials and the recorded range (ln ω).
    let amax = feats.iter().fold(0.0f64, |m, f| m.max(f.1));
    let strong_min = amax * 10f64.powf(-STRONG_DB / 20.0);
    let low = feats.iter().filter(|f| f.1 >= strong_min).fold(f64::INFINITY, |m, f| m.min(f.0));
    let high = feats.iter().filter(|f| f.1 >= strong_min).fold(f64::NEG_INFINITY, |m, f| m.max(f.0));
    let strong_feats: Vec<f64> = feats.iter().filter(|f| f.1 >= strong_min).map(|f| f.0).collect();
    // A mode "has a feature" when a partial within 30 dB of the strongest is there (weak
    // features — onset residue, noise fits — are everywhere in a dense range).
    let heard_min = amax * 10f64.powf(-HEARD_DB / 20.0);
    let mut feat_sorted: Vec<f64> = feats.iter().filter(|f| f.1 >= heard_min).map(|f| f.0).collect();
    feat_sorted.sort_by(f64::total_cmp);
    let has_feature = |v: f64| {
        let i = feat_sorted.partition_point(|&x| x < v - tol);
        feat_sorted.get(i).is_some_and(|&x| x <= v + tol)
    };
    // Object modes the scale `h` leaves unmatched: audible ones below the lowest strong
    // partial, strong ones inside the recorded range.
    let unmatched = |h: f64| -> (usize, usize) {
        let (mut below, mut strong) = (0, 0);
        for &(lb, i) in &bank {
            let v = lb + h;
            if v < low - tol && !has_feature(v) {
                below += 1;
            } else if v >= low - tol && v <= high + tol && gain(i) >= 0.1 && !has_feature(v) {
                strong += 1;
            }
        }
        (below, strong)
    };
    let score = |half_ln_r: f64| -> f64 {
        let matched = feats
            .iter()
            .map(|&(lw, a)| {
                let (dd, _) = nearest(lw - half_ln_r);
                a * (-(dd / tol).powi(2) * 0.5).exp()
            })
            .sum::<f64>()
            / wsum;
        let (below, strong) = unmatched(half_ln_r);
        // Strong partials below the object's lowest audible mode: nothing can ring there. One
        // is evidence enough, and more are no more: a bank captured from the recording holds
        // its strongest modes, not every partial under them, and counted one by one, six
        // partials 17–19 dB down pulled a bank captured from the recording itself 16 semitones
        // down (a black-box tester's clips: 7 of 38 own banks more than half a semitone off,
        // 2 now). (Weighed by their level instead, a tubular bell's one partial 14 dB down
        // under a wrong scale was too cheap: the chime's lowest mode went from the bell's
        // 160 Hz to 505 Hz.)
        let under = strong_feats.iter().any(|&lw| lw < bank[0].0 + half_ln_r - tol);
        matched - PENALTY_BELOW * (below + usize::from(under)) as f64 - PENALTY_STRONG * strong as f64
    };
    let h = fixed.unwrap_or_else(|| {
        // Candidates: align each of the strongest features with each of the lowest bank modes,
        // and the lowest strong partial with each of them.
        let mut order: Vec<usize> = (0..feats.len()).collect();
        order.sort_by(|&a, &b| feats[b].1.total_cmp(&feats[a].1));
        let mut best = (f64::NEG_INFINITY, 0.0);
        let lows = order.iter().take(12).map(|&fi| feats[fi].0).chain([low]);
        for lw in lows {
            for b in bank.iter().take(64) {
                let h = lw - b.0;
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
        h
    });
    let (mut matched, mut ss, mut wm, mut ag, mut gg) = (0, 0.0, 0.0, 0.0, 0.0);
    for (&(lw, w), f) in feats.iter().zip(features) {
        let (dd, bi) = nearest(lw - h);
        if dd < tol {
            matched += 1;
            ss += w * dd * dd;
            wm += w;
            let g = gains0.and_then(|g| g.get(bi)).copied().unwrap_or(1.0).abs();
            ag += f.amplitude * g;
            gg += g * g;
        }
    }
    let (below, strong) = unmatched(h);
    Some(ObjectMatch {
        gamma_ratio: (2.0 * h).exp(),
        amplitude_scale: if gg > 0.0 { ag / gg } else { 0.0 },
        matched,
        features: feats.len(),
        rms_cents: if wm > 0.0 { (ss / wm).sqrt() * 1200.0 / std::f64::consts::LN_2 } else { 0.0 },
        lowest_partial_hz: low.exp() / std::f64::consts::TAU,
        object_lowest_hz: (bank[0].0 + h).exp() / std::f64::consts::TAU,
        unmatched_modes_below: below,
        unmatched_strong_modes: strong,
    })
}

/// One object mode's support excess as recorded (issue 10 part 6;
/// [`support_by_mode`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ModeSupport {
    /// Index of the mode in the bank.
    pub mode: usize,
    /// The bank's reference eigenvalue λ⁰ of the mode, rad²/s².
    pub lambda: f64,
    /// Median over the matched partials of their c above the law at their λ, s⁻¹ (≥ 0).
    pub extra_c_per_s: f64,
    /// Recorded partials matched to the mode.
    pub partials: usize,
}

/// Tolerance in ln ω (0.2 %, 3.5 cents) within which bank modes are one degenerate set: an
/// axisymmetric object's mode pairs, split by the mesh by up to ~0.14 % in the factory FEM
/// banks, which no recording resolves (a 1 s partial's frequency resolution is ~1 Hz, 0.2 %
/// at 500 Hz): a partial matched to one is matched to all of them.
const DEGENERATE: f64 = 2e-3;

/// The support damping of each of the object's modes as recorded (thesis §4.2.8's excess
/// over the material's law, mode by mode; issue 10 part 6): every strong partial of each
/// impact (within 20 dB of the impact's strongest 10 ms after the strike, as
/// `EstimateReport::support_for` takes them) is matched to the nearest audible bank mode at
/// the fitted scale `gamma_ratio` (λ = γ/γ₀·λ⁰) within 1 % in frequency (a degenerate set of
/// modes all take it); a mode's excess is the median over its partials of
/// max(0, c − law(λ)). `gains0` (each mode's largest |gain|) leaves out silent modes, as the
/// match does. Modes no partial matched are not listed; the result ascends in mode index.
pub fn support_by_mode<'a>(
    impacts: impl IntoIterator<Item = &'a [Feature]>,
    law: &dsp::Damping,
    lambdas0: &[f64],
    gains0: Option<&[f64]>,
    gamma_ratio: f64,
) -> Vec<ModeSupport> {
    if !(gamma_ratio > 0.0 && gamma_ratio.is_finite()) {
        return Vec::new();
    }
    let gmax = gains0.map_or(1.0, |g| g.iter().fold(0.0f64, |m, v| m.max(v.abs())));
    let audible = |i: usize| gains0.and_then(|g| g.get(i)).map_or(1.0, |v| v.abs() / gmax.max(1e-300)) >= 0.01;
    let h = 0.5 * gamma_ratio.ln();
    let mut bank: Vec<(f64, usize)> = lambdas0
        .iter()
        .enumerate()
        .filter(|&(i, &l)| l > 0.0 && l.is_finite() && audible(i))
        .map(|(i, &l)| (0.5 * l.ln() + h, i))
        .collect();
    bank.sort_by(|a, b| a.0.total_cmp(&b.0));
    if bank.is_empty() {
        return Vec::new();
    }
    let tol = (1.0 + TOL).ln();
    let mut excess: Vec<Vec<f64>> = vec![Vec::new(); lambdas0.len()];
    for features in impacts {
        let heard = |f: &Feature| f.amplitude * (-0.01 * f.decay_per_s).exp();
        let amax = features.iter().map(heard).fold(0.0f64, f64::max);
        for f in features.iter().filter(|f| heard(f) >= 0.1 * amax && f.lambda() > 0.0) {
            let v = 0.5 * f.lambda().ln();
            let i = bank.partition_point(|b| b.0 < v);
            let Some(&(bv, _)) = [i.wrapping_sub(1), i]
                .iter()
                .filter_map(|&j| bank.get(j))
                .min_by(|a, b| (a.0 - v).abs().total_cmp(&(b.0 - v).abs()))
            else {
                continue;
            };
            if (bv - v).abs() > tol {
                continue;
            }
            let e = (f.c() - law.c(f.lambda())).max(0.0);
            let lo = bank.partition_point(|b| b.0 < bv - DEGENERATE);
            for &(_, m) in bank[lo..].iter().take_while(|b| b.0 <= bv + DEGENERATE) {
                excess[m].push(e);
            }
        }
    }
    excess
        .into_iter()
        .enumerate()
        .filter(|(_, e)| !e.is_empty())
        .map(|(mode, mut e)| {
            e.sort_by(f64::total_cmp);
            let n = e.len();
            let median = if n % 2 == 1 { e[n / 2] } else { 0.5 * (e[n / 2 - 1] + e[n / 2]) };
            ModeSupport { mode, lambda: lambdas0[mode], extra_c_per_s: median, partials: n }
        })
        .collect()
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
                ..Default::default()
            })
            .chain([Feature { freq_hz: 777.0, decay_per_s: 50.0, amplitude: 0.05, ..Default::default() }])
            .collect();
        let m = match_object(&feats, &l0, None).unwrap();
        assert!((m.gamma_ratio / r - 1.0).abs() < 0.005, "{m:?}");
        assert_eq!(m.matched, 5);
        assert_eq!(m.unmatched_modes_below, 0);
    }

    /// Issue 10 part 6: each bank mode's excess is the median over the strong partials matched
    /// to it (truth set here: c = law + excess); a degenerate pair takes its partial's excess
    /// on both modes; weak partials (≥ 20 dB down), partials more than 1 % from every mode and
    /// silent modes are left out.
    #[test]
    fn support_by_mode_takes_each_matched_modes_median_excess() {
        use dsp::Damping;
        let law = Damping::Rayleigh { alpha1: 2.0, alpha2: 1e-8 };
        let base = std::f64::consts::TAU * 200.0;
        // Modes 0..5; 2 and 3 a degenerate pair split by 0.05 % (as a mesh splits them); 5
        // silent.
        let l0: Vec<f64> = [1.0, 2.7, 4.1, 4.1 * 1.0005, 6.3, 8.0].iter().map(|k: &f64| (k * base).powi(2)).collect();
        let gains = [1.0, 0.8, 0.5, 0.5, 0.6, 1e-4];
        let r: f64 = 1.21;
        let feature = |k: usize, excess: f64, amplitude: f64, detune: f64| {
            let lambda = r * l0[k] * detune * detune;
            let c = law.c(lambda) + excess;
            Feature {
                freq_hz: (lambda - 0.25 * c * c).sqrt() / std::f64::consts::TAU,
                decay_per_s: 0.5 * c,
                amplitude,
                ..Default::default()
            }
        };
        let impacts: Vec<Vec<Feature>> = vec![
            vec![
                feature(0, 1.0, 1.0, 1.0),
                feature(1, 10.0, 0.5, 1.002),
                feature(2, 4.0, 0.4, 1.0),
                feature(4, 0.0, 0.3, 0.999),
                // 1.5 % above mode 4: no mode's.
                feature(4, 50.0, 0.3, 1.015),
                // Mode 5 is silent.
                feature(5, 9.0, 0.3, 1.0),
                // 26 dB down: not a strong partial.
                feature(1, 99.0, 0.05, 1.0),
            ],
            vec![feature(0, 3.0, 1.0, 1.0), feature(1, 12.0, 0.6, 1.0)],
            vec![feature(0, 2.0, 1.0, 1.0), feature(1, 20.0, 0.6, 0.998)],
        ];
        let got = support_by_mode(impacts.iter().map(Vec::as_slice), &law, &l0, Some(&gains), r);
        let by_mode: Vec<(usize, f64, usize)> = got.iter().map(|m| (m.mode, m.extra_c_per_s, m.partials)).collect();
        let want = [(0, 2.0, 3), (1, 12.0, 3), (2, 4.0, 1), (3, 4.0, 1), (4, 0.0, 1)];
        assert_eq!(by_mode.len(), want.len(), "{got:?}");
        for ((m, e, n), (wm, we, wn)) in by_mode.iter().zip(want) {
            assert_eq!((*m, *n), (wm, wn), "{got:?}");
            assert!((e - we).abs() < 1e-6, "mode {m}: excess {e} vs {we}");
        }
        assert_eq!(got[2].lambda, l0[2]);
        // No fitted scale, no match.
        assert!(support_by_mode(impacts.iter().map(Vec::as_slice), &law, &l0, Some(&gains), f64::NAN).is_empty());
    }

    /// Issue 10: three partials of a free bar (1 : 2.756 : 5.404, Euler–Bernoulli) matched
    /// against a plate-like object with dense modes (Kirchhoff circular plate, free edge:
    /// 1 : 1.73 : 2.33 : 3.91 : 4.11 : 6.30 : 6.71 : 7.05 …, then a dense tail). Without the
    /// constraint the dense tail absorbs the partials with the plate scaled far down; the fit
    /// must put the object's lowest mode within a semitone of the lowest partial.
    #[test]
    fn few_partials_do_not_pull_the_object_far_down() {
        let mut ratios = vec![1.0, 1.73, 2.33, 3.91, 4.11, 6.30, 6.71, 7.05];
        // Dense upper modes, spaced ~0.6 % apart from 8 to 120.
        let mut v = 8.0;
        while v < 120.0 {
            ratios.push(v);
            v *= 1.006;
        }
        let base = std::f64::consts::TAU * 100.0;
        let l0: Vec<f64> = ratios.iter().map(|k| (k * base).powi(2)).collect();
        let f1 = 523.0;
        let feats: Vec<Feature> = [(1.0, 0.5), (2.756, 0.3), (5.404, 0.2)]
            .iter()
            .map(|&(k, a)| Feature { freq_hz: f1 * k, decay_per_s: 2.0, amplitude: a, ..Default::default() })
            .collect();
        let m = match_object(&feats, &l0, None).unwrap();
        let semitones = 12.0 * (m.object_lowest_hz / f1).log2();
        assert!(semitones.abs() <= 1.0, "object's lowest mode {semitones:.1} semitones from the lowest partial: {m:?}");
        assert!((m.lowest_partial_hz / f1 - 1.0).abs() < 1e-6, "{m:?}");
        assert_eq!(m.unmatched_modes_below, 0, "{m:?}");
    }

    /// Issue 10 part 5 on a real recording: FluidR3's marimba sample "F# 6" (740 Hz; the
    /// sixteen strongest features `struck features` finds in `wood-marimba-fluid-83` of
    /// `tests/recordings`, frequency, decay, amplitude) against a marimba bar tuned
    /// 1 : 4 : 10 (the instrument's tuning; higher modes of a free bar beyond). The fundamental
    /// rings at d = 7; the onset's components around it (656 Hz at d = 125, 762 Hz at 94, …)
    /// are strong at the strike but die within 30 ms. By amplitude they outweighed it, a
    /// 656 Hz "strong partial" lay under the bar's lowest mode, and the fit put the bar's
    /// second mode on the fundamental: its lowest mode at 185 Hz, two octaves down. Weighed
    /// by what they ring, the lowest mode is the fundamental (within a semitone).
    #[test]
    fn a_real_marimbas_onset_does_not_put_the_bar_two_octaves_down() {
        let recorded = [
            (739.3, 7.0, 1.150),
            (656.5, 124.7, 0.335),
            (761.8, 94.3, 0.271),
            (3281.4, 1334.0, 0.221),
            (1131.0, 635.7, 0.172),
            (646.7, 91.7, 0.106),
            (3193.0, 297.7, 0.097),
            (592.0, 271.2, 0.066),
            (1814.0, 414.9, 0.064),
            (798.9, 87.3, 0.059),
            (677.4, 64.7, 0.053),
            (702.5, 65.7, 0.048),
            (3146.9, 260.3, 0.047),
            (3322.4, 438.7, 0.045),
            (3100.5, 197.5, 0.034),
            (823.6, 124.1, 0.032),
        ];
        let feats: Vec<Feature> = recorded
            .iter()
            .map(|&(freq_hz, decay_per_s, amplitude)| Feature { freq_hz, decay_per_s, amplitude, ..Default::default() })
            .collect();
        let base = std::f64::consts::TAU * 100.0;
        let ratios = [1.0, 4.0, 10.0, 17.6, 27.2, 38.8];
        let l0: Vec<f64> = ratios.iter().map(|k| (k * base).powi(2)).collect();
        let gains = [1.0, 0.7, 0.5, 0.4, 0.3, 0.25];
        let m = match_object(&feats, &l0, Some(&gains)).unwrap();
        let cents = 1200.0 * (m.object_lowest_hz / 740.0).log2();
        assert!(cents.abs() <= 100.0, "the bar's lowest mode {cents:.0} cents from the sample's 740 Hz: {m:?}");
        assert_eq!(m.unmatched_modes_below, 0, "{m:?}");
    }

    /// A bank captured from the recording itself (`struck bank capture`: its 48 strongest
    /// partials) is fitted at its own pitch, γ/γ₀ = 1, by construction. The
    /// features of a real recording (a black-box tester's clip of a struck kitchen object,
    /// FoxDot's CC0 sample `ikea7`, 81 features as `struck features` gave them) with the bank
    /// the capture took from them: six weak, slow partials under the bank's lowest mode
    /// (601 Hz; 70–582 Hz, 17–19 dB under the strongest in what they ring) each cost the true
    /// scale a penalty of its own, so the fit put the bank 15.8 semitones down. Now within a
    /// few cents (1.2: the refinement also averages a 49th feature within 1 % of a mode).
    #[test]
    fn a_bank_captured_from_the_recording_fits_at_its_own_pitch() {
        // (f Hz, d 1/s, amplitude) of the impact, strongest first.
        const FEATURES: [(f64, f64, f64); 81] = [
            (7789.82, 649.103, 1.912e-01),
            (2858.05, 23.209, 1.811e-01),
            (1272.80, 7.832, 1.253e-01),
            (2567.94, 50.778, 1.245e-01),
            (2927.69, 54.202, 1.167e-01),
            (2054.59, 46.477, 1.135e-01),
            (4914.28, 59.490, 1.060e-01),
            (3200.24, 61.972, 1.014e-01),
            (1964.80, 15.349, 8.948e-02),
            (2431.93, 17.819, 8.702e-02),
            (1000.57, 13.323, 8.297e-02),
            (1200.74, 5.855, 8.102e-02),
            (1643.67, 6.300, 7.595e-02),
            (2119.56, 27.343, 7.379e-02),
            (6746.38, 107.978, 7.208e-02),
            (7244.99, 317.979, 7.110e-02),
            (2765.04, 43.270, 7.038e-02),
            (3264.56, 24.397, 6.953e-02),
            (2356.12, 34.806, 6.658e-02),
            (1378.89, 6.895, 6.618e-02),
            (864.54, 5.012, 6.254e-02),
            (1945.75, 32.845, 6.174e-02),
            (4472.91, 47.187, 6.107e-02),
            (3169.39, 75.054, 6.025e-02),
            (5346.50, 51.645, 5.949e-02),
            (601.21, 2.777, 5.625e-02),
            (6975.36, 149.758, 4.970e-02),
            (5587.88, 48.701, 4.817e-02),
            (5870.18, 120.177, 4.791e-02),
            (2319.12, 27.345, 4.038e-02),
            (7833.12, 109.917, 3.943e-02),
            (3806.22, 31.026, 3.930e-02),
            (2172.30, 32.981, 3.839e-02),
            (2523.95, 14.975, 3.757e-02),
            (1497.10, 9.513, 3.492e-02),
            (5433.67, 53.505, 3.464e-02),
            (2154.33, 9.056, 3.369e-02),
            (2470.56, 109.732, 3.354e-02),
            (1408.83, 5.682, 3.348e-02),
            (923.87, 5.387, 3.244e-02),
            (6041.97, 93.901, 3.019e-02),
            (5079.33, 17.747, 3.007e-02),
            (6270.57, 68.427, 2.990e-02),
            (6849.25, 76.654, 2.753e-02),
            (8499.26, 90.335, 2.738e-02),
            (8052.12, 156.001, 2.553e-02),
            (3881.65, 41.969, 2.490e-02),
            (1144.54, 4.835, 2.410e-02),
            (6147.70, 44.304, 2.403e-02),
            (4030.58, 15.725, 2.362e-02),
            (506.30, 36.842, 2.329e-02),
            (4852.59, 34.929, 2.155e-02),
            (818.35, 3.162, 2.133e-02),
            (3322.23, 14.452, 2.094e-02),
            (1917.35, 6.733, 2.002e-02),
            (7414.09, 68.828, 1.996e-02),
            (4007.95, 28.533, 1.917e-02),
            (7947.83, 84.249, 1.882e-02),
            (1552.12, 12.599, 1.845e-02),
            (3126.81, 24.161, 1.820e-02),
            (5192.69, 30.237, 1.780e-02),
            (2828.02, 33.555, 1.726e-02),
            (684.37, 3.803, 1.721e-02),
            (1715.10, 6.192, 1.688e-02),
            (1681.40, 11.549, 1.616e-02),
            (1666.31, 10.707, 1.568e-02),
            (466.39, 10.119, 1.542e-02),
            (381.47, 6.751, 1.456e-02),
            (581.82, 5.902, 1.406e-02),
            (2694.13, 11.728, 1.035e-02),
            (1213.27, 3.829, 9.807e-03),
            (888.95, 5.285, 9.275e-03),
            (203.04, 6.536, 8.709e-03),
            (155.82, 1.833, 8.665e-03),
            (69.60, 1.748, 8.214e-03),
            (265.40, 6.292, 8.092e-03),
            (207.81, 8.215, 7.578e-03),
            (750.16, 3.718, 7.518e-03),
            (290.61, 3.430, 6.979e-03),
            (415.37, 1.065, 6.764e-03),
            (1360.17, 3.684, 6.174e-03),
        ];
        // The features the capture kept, in ascending λ.
        const BANK: [usize; 48] = [
            25, 20, 39, 10, 47, 11, 2, 19, 38, 34, 12, 21, 8, 5, 13, 36, 32, 29, 18, 9, 37, 33, 3, 16, 1, 4, 23, 7, 17,
            31, 46, 22, 6, 41, 24, 35, 27, 28, 40, 42, 14, 43, 26, 15, 0, 30, 45, 44,
        ];
        let feats: Vec<Feature> = FEATURES
            .iter()
            .map(|&(freq_hz, decay_per_s, amplitude)| Feature { freq_hz, decay_per_s, amplitude, ..Default::default() })
            .collect();
        let l0: Vec<f64> = BANK.iter().map(|&i| feats[i].lambda()).collect();
        let gains: Vec<f64> = BANK.iter().map(|&i| feats[i].amplitude).collect();
        let m = match_object(&feats, &l0, Some(&gains)).unwrap();
        let cents = 600.0 * m.gamma_ratio.log2();
        assert!(cents.abs() < 5.0, "fitted {cents:.1} cents off the bank's own pitch: {m:?}");
    }

    /// The pitch fit weighs features by what they ring over 1 s, so an almost undamped one (a
    /// mains hum fitted at d = 0.1 s⁻¹) weighs up to 17 dB more than a partial of the same
    /// amplitude at d = 30: a hum at 50–120 Hz 15 dB or more under the bar's fundamental
    /// (739 Hz, d 7; partials at 4× and 10×) must not become the object's lowest mode.
    /// (Measured limit: at 10 dB under, 60 or 100 Hz is taken as the lowest mode.)
    #[test]
    fn a_mains_hum_under_the_strike_does_not_set_the_pitch() {
        for (hum_hz, hum_db) in [(50.0, -30.0), (60.0, -20.0), (100.0, -15.0), (120.0, -15.0), (50.0, -15.0)] {
            let recorded = [
                (739.3, 7.0, 1.0),
                (2957.0, 18.0, 0.5),
                (7393.0, 40.0, 0.25),
                (hum_hz, 0.1, 10f64.powf(hum_db / 20.0)),
            ];
            let feats: Vec<Feature> = recorded
                .iter()
                .map(|&(freq_hz, decay_per_s, amplitude)| Feature {
                    freq_hz,
                    decay_per_s,
                    amplitude,
                    ..Default::default()
                })
                .collect();
            let base = std::f64::consts::TAU * 100.0;
            let l0: Vec<f64> = [1.0, 4.0, 10.0, 17.6, 27.2, 38.8].iter().map(|k| (k * base).powi(2)).collect();
            let m = match_object(&feats, &l0, Some(&[1.0, 0.7, 0.5, 0.4, 0.3, 0.25])).unwrap();
            let cents = 1200.0 * (m.object_lowest_hz / 739.3).log2();
            assert!(cents.abs() <= 100.0, "hum {hum_hz} Hz {hum_db} dB: lowest mode {cents:.0} cents off: {m:?}");
        }
    }
}
