//! Ren, Yeh & Lin 2013 §5.2.2: the feature-domain metric — how well one set of modal
//! features (frequency, decay, energy) is matched by another, in a space where distances
//! follow what listeners tell apart (issue 15 part 1).
//!
//! Each feature φ = (f, d) is mapped to (X, Y) = (Z(f)/[`BARK_UNIT`], (1/d)/[`DURATION_UNIT_S`])
//! (Ren eqs. 21–22: frequency as critical-band rate Z in Bark, damping as the duration 1/d,
//! so short bursts that cannot be told apart are close); two features match by
//! k = exp(−½·D²), D their Euclidean distance there (eq. 20). Then (eqs. 23–26):
//! - the point-to-set match ratio R(φᵢ, Φ̃) = Σⱼ ũᵢⱼ·k(φᵢ, φ̃ⱼ) / Σⱼ ũᵢⱼ, with
//!   ũᵢⱼ = w̃ⱼ·k(φᵢ, φ̃ⱼ): the energy-weighted mean score of the estimated features, each
//!   counted as much as it is near (so one coincident feature gives 1, a lone one at distance
//!   D gives k(D), and far features neither help nor hurt);
//! - the set-to-set ratios R(Φ, Φ̃) = Σᵢ wᵢ·R(φᵢ, Φ̃)/Σᵢ wᵢ and, the other way round,
//!   R̃(Φ, Φ̃), with w the features' energies a²/(2d);
//! - the match ratio product R·R̃ (Ren's Π_MRP is its negative, for minimisation).
//!
//! Ren's Appendix B (the constants and the exact form of k and the weights) is not in the
//! seed text; the choices here are Struck's and are stated: [`BARK_UNIT`] 0.25 Bark (a
//! quarter of a critical band) and [`DURATION_UNIT_S`] 0.1 s of 1/e time are one unit of
//! distance, where the score has fallen to e^(−½) ≈ 0.61.

/// Critical-band rate per unit of the frequency axis, Bark.
pub const BARK_UNIT: f64 = 0.25;
/// 1/e time per unit of the damping axis, s.
pub const DURATION_UNIT_S: f64 = 0.1;

use crate::{EstimateReport, Options};
use serde::{Deserialize, Serialize};

/// Critical-band rate of `f_hz`, Bark (Zwicker & Terhardt 1980:
/// 13·atan(0.00076 f) + 3.5·atan((f/7500)²); within 0.2 Bark of Zwicker's band edges).
pub fn bark(f_hz: f64) -> f64 {
    13.0 * (0.00076 * f_hz).atan() + 3.5 * (f_hz / 7500.0).powi(2).atan()
}

/// One modal feature as the metric sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Point {
    /// Frequency, Hz.
    pub freq_hz: f64,
    /// Decay rate d, s⁻¹ (amplitude ∝ e^(−d t)); > 0.
    pub decay_per_s: f64,
    /// Weight: the feature's energy a²/(2d) (see [`Point::new`]).
    pub weight: f64,
}

impl Point {
    /// A feature of peak amplitude `amplitude`, weighted by its energy a²/(2d).
    pub fn new(freq_hz: f64, decay_per_s: f64, amplitude: f64) -> Point {
        let d = decay_per_s.max(1e-6);
        Point { freq_hz, decay_per_s: d, weight: amplitude * amplitude / (2.0 * d) }
    }

    /// Coordinates in the metric's space (Ren eqs. 21–22).
    fn xy(&self) -> (f64, f64) {
        (bark(self.freq_hz) / BARK_UNIT, 1.0 / (self.decay_per_s.max(1e-6) * DURATION_UNIT_S))
    }
}

/// The point-to-point match score k(a, b) = exp(−½·D²) (Ren eq. 20's distance D), in 0..=1.
pub fn score(a: &Point, b: &Point) -> f64 {
    let ((xa, ya), (xb, yb)) = (a.xy(), b.xy());
    let d2 = (xa - xb).powi(2) + (ya - yb).powi(2);
    (-0.5 * d2).exp()
}

/// The point-to-set match ratio R(φ, Φ̃) (Ren eq. 24, with ũ = w̃·k): 0 for an empty set.
pub fn point_to_set(p: &Point, set: &[Point]) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for q in set {
        let k = score(p, q);
        num += q.weight * k * k;
        den += q.weight * k;
    }
    if den > 0.0 {
        num / den
    } else {
        0.0
    }
}

/// Ren's match ratios between a reference set (the recording's features) and an estimated
/// one (the modes a material plays).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MatchRatios {
    /// R(Φ, Φ̃): how much of the reference the estimate represents (eq. 23).
    pub reference: f64,
    /// R̃(Φ, Φ̃): how much of the estimate the reference backs (eq. 25).
    pub estimated: f64,
    /// R·R̃ (eq. 26 without its sign).
    pub product: f64,
    /// R(φᵢ, Φ̃) of each reference feature, in its order.
    pub per_reference: Vec<f64>,
}

/// The match ratios of `reference` by `estimated` (Ren eqs. 23–26). Allocates. Each
/// feature's coordinates are computed once (the metric's cost is then the N·M scores).
pub fn match_ratios(reference: &[Point], estimated: &[Point]) -> MatchRatios {
    let xy = |s: &[Point]| -> Vec<(f64, f64, f64)> {
        s.iter()
            .map(|p| {
                let (x, y) = p.xy();
                (x, y, p.weight)
            })
            .collect()
    };
    let (rc, ec) = (xy(reference), xy(estimated));
    // R(p, set) of eq. 24 from precomputed coordinates.
    let to_set = |p: &(f64, f64, f64), set: &[(f64, f64, f64)]| {
        let (mut num, mut den) = (0.0, 0.0);
        for q in set {
            let d2 = (p.0 - q.0).powi(2) + (p.1 - q.1).powi(2);
            // exp(−½·D²) is 0 in f64 past D² ≈ 1490; skip those.
            if d2 < 1500.0 {
                let k = (-0.5 * d2).exp();
                num += q.2 * k * k;
                den += q.2 * k;
            }
        }
        if den > 0.0 {
            num / den
        } else {
            0.0
        }
    };
    let per_reference: Vec<f64> = rc.iter().map(|p| to_set(p, &ec)).collect();
    let mean = |ratios: &mut dyn Iterator<Item = (f64, f64)>| {
        let (mut num, mut den) = (0.0, 0.0);
        for (w, r) in ratios {
            num += w * r;
            den += w;
        }
        if den > 0.0 {
            num / den
        } else {
            0.0
        }
    };
    let r = mean(&mut rc.iter().zip(&per_reference).map(|(p, &r)| (p.2, r)));
    let r_est = mean(&mut ec.iter().map(|q| (q.2, to_set(q, &rc))));
    MatchRatios { reference: r, estimated: r_est, product: r * r_est, per_reference }
}

/// Ren's match of each impact of a capture by the material it gave (issue 15 part 1): how
/// much of the recording the fitted material represents, in the estimate report.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RenMatch {
    /// What the recording is matched against: `"object"` (the known object's modes at the
    /// fitted γ, each with its bank gain × the fitted amplitude scale) or `"own modes"` (each
    /// recorded partial's frequency and amplitude with the decay the material gives it).
    pub against: String,
    /// Mean over impacts of R(Φ, Φ̃).
    pub reference_ratio: f64,
    /// Mean over impacts of R̃(Φ, Φ̃).
    pub estimated_ratio: f64,
    /// Mean over impacts of R·R̃.
    pub product: f64,
    /// Per impact, in the report's order.
    pub impacts: Vec<ImpactMatch>,
}

/// Ren's match of one impact.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ImpactMatch {
    /// R(Φ, Φ̃).
    pub reference_ratio: f64,
    /// R̃(Φ, Φ̃).
    pub estimated_ratio: f64,
    /// R(φᵢ, Φ̃) of each feature, in the impact's order (§6.1 weighs the represented sound
    /// by these).
    pub feature_ratios: Vec<f64>,
}

/// The decay the material plays at λ: d = (c(λ) + S)/2, its law plus the mean support
/// damping `support_c` (what *Support: as recorded* adds on average).
fn played_decay(law: &dsp::Damping, support_c: f64, lambda: f64) -> f64 {
    0.5 * (law.c(lambda) + support_c)
}

/// Ren's match of every impact of `report` by its chosen material: against the known
/// object's modes when the object was given and matched (`object_lambdas`/`object_gains` of
/// the options; at the fitted γ and amplitude scale, the audible ones: 20 Hz up to 20 kHz or
/// Nyquist, within 60 dB of the strongest), else against the recording's own partials with
/// the material's decays. `None` without impacts. Allocates.
pub fn ren_match(report: &EstimateReport, opts: &Options) -> Option<RenMatch> {
    if report.impacts.is_empty() {
        return None;
    }
    let law = report.damping();
    let support = report.support_c().unwrap_or(0.0);
    let nyquist = report.files.iter().map(|f| f64::from(f.sample_rate) / 2.0).fold(f64::INFINITY, f64::min);
    let top = nyquist.min(20_000.0);
    let object_modes: Option<Vec<Point>> = match (&report.object, opts.object_lambdas.as_deref()) {
        (Some(o), Some(lambdas)) if o.matched > 0 => {
            let gain = |j: usize| opts.object_gains.as_deref().and_then(|g| g.get(j)).copied().unwrap_or(1.0).abs();
            let mut modes: Vec<Point> = lambdas
                .iter()
                .enumerate()
                .filter_map(|(j, &l)| {
                    let lambda = l * o.gamma_ratio;
                    let d = played_decay(&law, support, lambda);
                    let w2 = lambda - d * d;
                    (w2 > 0.0 && d > 0.0)
                        .then(|| Point::new(w2.sqrt() / std::f64::consts::TAU, d, o.amplitude_scale * gain(j)))
                })
                .filter(|p| (20.0..=top).contains(&p.freq_hz))
                .collect();
            let peak = modes.iter().map(|p| p.weight).fold(0.0, f64::max);
            modes.retain(|p| p.weight >= 1e-6 * peak);
            Some(modes)
        }
        _ => None,
    };
    let impacts: Vec<ImpactMatch> = report
        .impacts
        .iter()
        .map(|imp| {
            let reference: Vec<Point> =
                imp.features.iter().map(|f| Point::new(f.freq_hz, f.decay_per_s, f.amplitude)).collect();
            let own: Vec<Point>;
            let estimated = match &object_modes {
                Some(m) => m.as_slice(),
                None => {
                    own = imp
                        .features
                        .iter()
                        .map(|f| Point::new(f.freq_hz, played_decay(&law, support, f.lambda()), f.amplitude))
                        .collect();
                    own.as_slice()
                }
            };
            let m = match_ratios(&reference, estimated);
            ImpactMatch { reference_ratio: m.reference, estimated_ratio: m.estimated, feature_ratios: m.per_reference }
        })
        .collect();
    let n = impacts.len() as f64;
    let mean = |f: &dyn Fn(&ImpactMatch) -> f64| impacts.iter().map(f).sum::<f64>() / n;
    Some(RenMatch {
        against: if object_modes.is_some() { "object" } else { "own modes" }.into(),
        reference_ratio: mean(&|m| m.reference_ratio),
        estimated_ratio: mean(&|m| m.estimated_ratio),
        product: mean(&|m| m.reference_ratio * m.estimated_ratio),
        impacts,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Zwicker's critical-band edges (Zwicker 1961; Zwicker & Fastl, Psychoacoustics, Table
    /// 6.1): the band z ends at these frequencies; the closed form is within 0.25 Bark.
    #[test]
    fn bark_follows_zwickers_band_edges() {
        let edges = [
            100.0, 200.0, 300.0, 400.0, 510.0, 630.0, 770.0, 920.0, 1080.0, 1270.0, 1480.0, 1720.0, 2000.0, 2320.0,
            2700.0, 3150.0, 3700.0, 4400.0, 5300.0, 6400.0, 7700.0, 9500.0, 12000.0, 15500.0,
        ];
        for (i, &f) in edges.iter().enumerate() {
            let z = bark(f);
            assert!((z - (i + 1) as f64).abs() < 0.25, "{f} Hz: {z} Bark, band edge {}", i + 1);
        }
    }

    /// Identical sets match fully; a lone estimated feature one unit away on the duration axis
    /// (1/e time 1.0 s against 1.1 s) scores e^(−½), and so does a quarter Bark away (1 kHz
    /// against the frequency a quarter Bark higher); far features (10 kHz, or a 10× shorter
    /// decay) score nothing.
    #[test]
    fn match_scores_follow_the_distance_in_bark_and_duration() {
        let a = [Point::new(1000.0, 1.0, 1.0), Point::new(3000.0, 5.0, 0.5)];
        let same = match_ratios(&a, &a);
        assert!((same.reference - 1.0).abs() < 1e-12 && (same.estimated - 1.0).abs() < 1e-12, "{same:?}");
        let half = (-0.5f64).exp();
        let longer = Point::new(1000.0, 1.0 / 1.1, 1.0);
        assert!((score(&a[0], &longer) - half).abs() < 1e-9);
        // The frequency a quarter Bark above 1 kHz, by bisection on the closed form.
        let (mut lo, mut hi) = (1000.0, 2000.0);
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if bark(mid) < bark(1000.0) + 0.25 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let higher = Point::new(lo, 1.0, 1.0);
        assert!((score(&a[0], &higher) - half).abs() < 1e-9);
        assert!((point_to_set(&a[0], &[higher]) - half).abs() < 1e-9);
        assert!(score(&a[0], &Point::new(10_000.0, 1.0, 1.0)) < 1e-100);
        assert!(score(&a[0], &Point::new(1000.0, 10.0, 1.0)) < 1e-10);
    }

    /// `match_ratios` (coordinates computed once) equals eqs. 23–25 written out with
    /// [`point_to_set`] and [`score`], on random sets.
    #[test]
    fn match_ratios_equal_the_point_by_point_definition() {
        let mut rng = crate::synth::Rng::new(5);
        for _ in 0..20 {
            let mut set = |n: usize| -> Vec<Point> {
                (0..n)
                    .map(|_| {
                        Point::new(rng.log_uniform(50.0, 15_000.0), rng.log_uniform(0.5, 300.0), rng.range(0.01, 1.0))
                    })
                    .collect()
            };
            let (a, b) = (set(12), set(30));
            let m = match_ratios(&a, &b);
            let wsum = |s: &[Point]| s.iter().map(|p| p.weight).sum::<f64>();
            let r: f64 = a.iter().map(|p| p.weight * point_to_set(p, &b)).sum::<f64>() / wsum(&a);
            let r_est: f64 = b.iter().map(|q| q.weight * point_to_set(q, &a)).sum::<f64>() / wsum(&b);
            assert!(
                (m.reference - r).abs() <= 1e-12 * r.max(1e-300)
                    && (m.estimated - r_est).abs() <= 1e-12 * r_est.max(1e-300),
                "{m:?} vs {r}, {r_est}"
            );
            for (p, v) in a.iter().zip(&m.per_reference) {
                assert!((v - point_to_set(p, &b)).abs() <= 1e-12);
            }
        }
    }

    /// Ren's normalisation: estimated modes no recording backs lower R̃ (the estimate's side)
    /// and leave R (the recording's side) as it was; a reference feature nothing matches
    /// lowers R by its share of the energy.
    #[test]
    fn unmatched_features_lower_only_their_own_sides_ratio() {
        let reference = [Point::new(500.0, 2.0, 1.0), Point::new(1500.0, 4.0, 1.0)];
        let mut estimated = reference.to_vec();
        estimated.push(Point::new(8000.0, 2.0, 1.0));
        let m = match_ratios(&reference, &estimated);
        assert!((m.reference - 1.0).abs() < 1e-9, "{m:?}");
        let w = |p: &Point| p.weight;
        let share = (w(&reference[0]) + w(&reference[1])) / (w(&reference[0]) + w(&reference[1]) + w(&estimated[2]));
        assert!((m.estimated - share).abs() < 1e-9, "{} vs {share}", m.estimated);
        let lone = match_ratios(&reference, &reference[..1]);
        let first = w(&reference[0]) / (w(&reference[0]) + w(&reference[1]));
        assert!((lone.reference - first).abs() < 1e-9, "{} vs {first}", lone.reference);
        assert_eq!(lone.per_reference.len(), 2);
        assert!(lone.per_reference[1] < 1e-9);
        assert_eq!(match_ratios(&reference, &[]).product, 0.0);
    }
}
