//! The strike's contact noise (issue 10; a black-box tester's finding): a mallet's click, a
//! few milliseconds of broadband noise at the start of each strike, was decomposed by the
//! mode search into dozens of brief, overlapping damped sinusoids per impact (46 at
//! 2.7–23 kHz for a 2 ms burst 40 dB under the ring), and the damping fit took them as
//! modes: the fitted Rayleigh law's α₂ came out 57 % low. Such runs are now left out
//! ([`estimator::features::contact_noise`]) and named in a warning. The recordings are
//! written here by direct evaluation of a·e^(−dt)·sin(2πft + φ), not `estimator::synth`, and
//! the truth is the law they were written with.

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

use estimator::features::{contact_noise, Feature};
use estimator::{estimate, extract_features, Options};

mod common;
use common::Gen;

const FS: f64 = 48_000.0;
/// The law the taps are written with: c = α₁ + α₂λ, d = c/2 (thesis §4.2.2).
const ALPHA: (f64, f64) = (10.0, 2e-7);
const PARTIALS: [f64; 6] = [300.0, 700.0, 1300.0, 2100.0, 3200.0, 4500.0];

/// Four taps 1.5 s apart, each the six partials with random phases, normalised to a peak of
/// 0.3, plus a Hann-windowed white-noise burst of `burst_ms` whose peak is `burst_db` under
/// the ring's; white noise σ = 1e-5 (≈ 90 dB under).
fn taps(name: &str, burst_ms: f64, burst_db: f64) -> PathBuf {
    let mut g = Gen(7);
    let len = (1.5 * FS) as usize;
    let lead = (0.2 * FS) as usize;
    let mut x: Vec<f64> = (0..lead + 4 * len).map(|_| 1e-5 * g.normal()).collect();
    for k in 0..4 {
        let phases: Vec<f64> = PARTIALS.iter().map(|_| std::f64::consts::TAU * g.u()).collect();
        let ring: Vec<f64> = (0..len)
            .map(|i| {
                let t = i as f64 / FS;
                PARTIALS
                    .iter()
                    .zip(&phases)
                    .map(|(&f, &p)| {
                        let d = 0.5 * (ALPHA.0 + ALPHA.1 * (std::f64::consts::TAU * f).powi(2));
                        (-d * t).exp() * (std::f64::consts::TAU * f * t + p).sin()
                    })
                    .sum()
            })
            .collect();
        let peak = ring.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let n = (burst_ms * 1e-3 * FS) as usize;
        let mut burst: Vec<f64> = (0..n)
            .map(|i| g.normal() * (0.5 - 0.5 * (std::f64::consts::TAU * (i + 1) as f64 / (n + 1) as f64).cos()))
            .collect();
        let bpeak = burst.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for b in &mut burst {
            *b *= 10f64.powf(burst_db / 20.0) / bpeak;
        }
        let at = lead + k * len;
        for i in 0..len {
            x[at + i] += 0.3 * (ring[i] / peak + burst.get(i).copied().unwrap_or(0.0));
        }
    }
    common::write_wav("contact", name, FS, &x)
}

/// A 2 ms click 40 dB and 20 dB under the ring: the fitted law within 1 % of the one the
/// taps were written with (before: α₂ 8.6e-8 for 2e-7 at −40 dB), every partial found, and
/// the warning names the contact noise. Measured: α₁ 9.996 / 10.000, α₂ 2.0000e-7 / 1.996e-7.
#[test]
fn a_mallets_click_is_not_taken_for_modes() {
    for (name, db) in [("click-40", -40.0), ("click-20", -20.0)] {
        let p = taps(name, 2.0, db);
        let cancel = AtomicBool::new(false);
        let feats = extract_features(std::slice::from_ref(&p), &Options::default(), &|_| {}, &cancel).unwrap();
        assert_eq!(feats.impacts.len(), 4, "{name}");
        for imp in &feats.impacts {
            for f in PARTIALS {
                assert!(imp.features.iter().any(|x| (x.freq_hz / f - 1.0).abs() < 1e-3), "{name}: {f} Hz lost");
            }
        }
        let r = estimate(std::slice::from_ref(&p), &Options::default(), &|_| {}, &cancel).unwrap();
        let (a1, a2) = (r.params[0], r.params[1]);
        eprintln!("{name}: {a1} {a2:e} points {} warnings {:?}", r.n_points, r.warnings);
        assert!(
            feats.warnings.iter().any(|w| w.contains("contact noise") && w.contains("4 impact(s)")),
            "{name}: {:?}",
            feats.warnings
        );
        assert!((a1 / ALPHA.0 - 1.0).abs() < 0.01, "{name}: alpha1 {a1} for {}", ALPHA.0);
        assert!((a2 / ALPHA.1 - 1.0).abs() < 0.01, "{name}: alpha2 {a2:e} for {:e}", ALPHA.1);
        let _ = std::fs::remove_file(&p);
    }
    let _ = std::fs::remove_dir(std::env::temp_dir().join(format!("struck-contact-{}", std::process::id())));
}

fn feature(freq_hz: f64, decay_per_s: f64) -> Feature {
    Feature { freq_hz, decay_per_s, amplitude: 1e-3, ..Feature::default() }
}

/// The rule itself: a run of four or more brief partials (d ≥ 300 s⁻¹), each within the sum
/// of its and its neighbour's bandwidth d/π of the next, is contact noise; three are not, a
/// brief mode alone is not, slow partials between brief ones neither join nor break a run.
#[test]
fn runs_of_brief_overlapping_partials_are_contact_noise() {
    // 1,000 s⁻¹ each: bandwidths 318 Hz, so 600 Hz apart overlap (600 < 637), 700 Hz do not.
    let run: Vec<Feature> = (0..5).map(|i| feature(5000.0 + 600.0 * f64::from(i), 1000.0)).collect();
    assert_eq!(contact_noise(&run), vec![true; 5]);
    let spaced: Vec<Feature> = (0..5).map(|i| feature(5000.0 + 700.0 * f64::from(i), 1000.0)).collect();
    assert_eq!(contact_noise(&spaced), vec![false; 5]);
    assert_eq!(contact_noise(&run[..3]), vec![false; 3]);
    // Below the brief decay, the same spacing in Hz overlaps as much but is no run.
    let slow: Vec<Feature> = (0..5).map(|i| feature(5000.0 + 50.0 * f64::from(i), 299.0)).collect();
    assert_eq!(contact_noise(&slow), vec![false; 5]);
    // A slow partial inside the run, out of order: the brief ones are found, it is kept.
    let mut mixed = run.clone();
    mixed.insert(2, feature(5900.0, 5.0));
    mixed.reverse();
    let got = contact_noise(&mixed);
    for (f, n) in mixed.iter().zip(&got) {
        assert_eq!(*n, f.decay_per_s >= 300.0, "{f:?}");
    }
}
