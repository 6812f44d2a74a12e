//! Glitches inside a ring (issue 10, black-box tester's slow files): a one-sample spike (a
//! sample library's glitch, a dropped sample) in a bell's ring made the peak search fit and
//! reject ~900 peaks (31 s for a 3 s file that takes under 1 s clean) and lose two partials; a
//! 1 ms DC step did the same with ~1,400. The spike is repaired before the search
//! ([`estimator::features::repair_clicks`]); what the repair does not cover stops on the
//! rejected-fit budget ([`estimator::features::REJECT_BUDGET_BINS`]) with a warning. Signals
//! come from direct evaluation of a e^(−dt) sin(2πft) written here, not `estimator::synth`.

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

use estimator::features::repair_clicks;
use estimator::{extract_features, FeaturesReport, Options};

mod common;
use common::Gen;

/// A bell's six partials (Hz, s⁻¹, amplitude).
const BELL: [(f64, f64, f64); 6] = [
    (420.0, 2.0, 0.25),
    (1003.0, 5.0, 0.2),
    (1770.0, 9.0, 0.15),
    (2630.0, 14.0, 0.12),
    (3900.0, 20.0, 0.1),
    (5600.0, 28.0, 0.08),
];
const FS: f64 = 44_100.0;
const T0: f64 = 0.2;

/// The bell struck at `T0`, 2.5 s, white noise σ = 1e-4 (≈ 70 dB under the strike's peak).
fn bell(seed: u64) -> Vec<f64> {
    let n = (2.5 * FS) as usize;
    let mut g = Gen(seed);
    let mut x: Vec<f64> = (0..n).map(|_| 1e-4 * g.normal()).collect();
    let i0 = (T0 * FS) as usize;
    for &(f, d, a) in &BELL {
        for (i, v) in x.iter_mut().enumerate().skip(i0) {
            let t = (i - i0) as f64 / FS;
            *v += a * (-d * t).exp() * (std::f64::consts::TAU * f * t).sin();
        }
    }
    x
}

fn write(name: &str, x: &[f64]) -> PathBuf {
    common::write_wav("glitch", name, FS, x)
}

fn features(p: &PathBuf) -> FeaturesReport {
    extract_features(std::slice::from_ref(p), &Options::default(), &|_| {}, &AtomicBool::new(false)).unwrap()
}

/// Each partial of the bell: (frequency, decay) of the feature within 0.2 % of it, if any.
fn partials(r: &FeaturesReport) -> Vec<Option<(f64, f64)>> {
    assert!((r.impacts[0].onset_s - T0).abs() < 0.01, "{:?}", r.impacts[0].onset_s);
    BELL.iter()
        .map(|&(f, _, _)| {
            r.impacts[0]
                .features
                .iter()
                .find(|x| (x.freq_hz / f - 1.0).abs() < 2e-3)
                .map(|x| (x.freq_hz, x.decay_per_s))
        })
        .collect()
}

/// A one-sample spike of 0.03 at 1.0 s (the ring's amplitude there ≈ 0.08): repaired and
/// reported; every partial found with the decay of the clean file (within 0.5 %) and of the
/// truth (within 3 %); the search rejects no more peaks than on the clean file (before the
/// repair: ~900 against ~40, two partials lost).
#[test]
fn a_one_sample_spike_in_a_ring_is_repaired() {
    let clean = bell(7);
    let mut spiked = clean.clone();
    let at = (1.0 * FS) as usize;
    spiked[at] += 0.03;
    let rc = features(&write("clean", &clean));
    let rs = features(&write("spike", &spiked));
    assert_eq!((rc.impacts.len(), rs.impacts.len()), (1, 1));
    let (ic, is) = (&rc.impacts[0], &rs.impacts[0]);
    assert_eq!(ic.repaired_clicks, 0, "clean file: {:?}", rc.warnings);
    assert_eq!(is.repaired_clicks, 1);
    assert!(!ic.search_stopped && !is.search_stopped);
    let w: Vec<_> = rs.warnings.iter().filter(|w| w.contains("one-sample click")).collect();
    assert_eq!(w.len(), 1, "{:?}", rs.warnings);
    assert!(w[0].contains("1.0000 s"), "{}", w[0]);
    assert!(!rc.warnings.iter().any(|w| w.contains("click")), "{:?}", rc.warnings);
    assert!(
        is.rejected_peaks <= ic.rejected_peaks + 5,
        "rejected peaks: {} with the spike, {} clean",
        is.rejected_peaks,
        ic.rejected_peaks
    );
    for ((c, s), &(f, d, _)) in partials(&rc).iter().zip(partials(&rs)).zip(&BELL) {
        let (c, s) = (c.unwrap_or_else(|| panic!("{f} Hz clean")), s.unwrap_or_else(|| panic!("{f} Hz spiked")));
        assert!((s.1 / c.1 - 1.0).abs() < 5e-3, "{f} Hz: decay {} spiked, {} clean", s.1, c.1);
        assert!((s.1 / d - 1.0).abs() < 0.03, "{f} Hz: decay {} spiked, true {d}", s.1);
    }
}

/// A two-sample pulse of 0.1 at 1.0 s is no one-sample click (nothing repaired) and is
/// broadband: the search stops on its rejected-fit budget and says so (before the budget: a
/// 1 ms DC step in a real bell's ring, 1,396 rejected peaks and 45 s), and the bell's six
/// partials keep their decays within 3 %. Steps (1 ms DC offsets) are not repaired either.
#[test]
fn a_broadband_burst_in_a_ring_stops_the_search_and_says_so() {
    let mut x = bell(8);
    let at = (1.0 * FS) as usize;
    x[at] += 0.1;
    x[at + 1] += 0.1;
    let r = features(&write("pulse", &x));
    let imp = &r.impacts[0];
    assert_eq!(imp.repaired_clicks, 0);
    assert!(imp.search_stopped, "{} rejected peaks", imp.rejected_peaks);
    assert!(r.warnings.iter().any(|w| w.contains("peak search stopped")), "{:?}", r.warnings);
    for (p, &(f, d, _)) in partials(&r).iter().zip(&BELL) {
        let p = p.unwrap_or_else(|| panic!("{f} Hz not found"));
        assert!((p.1 / d - 1.0).abs() < 0.03, "{f} Hz: decay {}, true {d}", p.1);
    }
    let mut y = bell(9);
    y[at..at + 44].iter_mut().for_each(|v| *v += 0.01);
    let r = features(&write("step", &y));
    assert!(r.impacts.iter().all(|i| i.repaired_clicks == 0), "{:?}", r.warnings);
}

/// The detector itself: a spike on noise is found at its sample and repaired to within the
/// noise; nothing is repaired in strikes with sharp attacks (sine and cosine phase, partials
/// up to 18 kHz at 44.1 kHz, a 300 s⁻¹ woodblock), a step, white noise, or a 16-bit quiet
/// tail of a few quantisation steps, nor in a quiet 16-bit ring that decays into sparse
/// ±1 LSB samples with no noise floor to scale them.
#[test]
fn the_click_detector_finds_spikes_and_only_spikes() {
    let mut g = Gen(11);
    let n = 20_000;
    let noise: Vec<f64> = (0..n).map(|_| 1e-3 * g.normal()).collect();
    let mut x = noise.clone();
    x[5000] += 0.05;
    assert_eq!(repair_clicks(&mut x, 1e-6), vec![5000]);
    assert!((x[5000] - noise[5000]).abs() < 5e-3, "{} vs {}", x[5000], noise[5000]);

    let strike = |phase: f64, parts: &[(f64, f64, f64)]| {
        let mut x = noise.clone();
        for &(f, d, a) in parts {
            for (i, v) in x.iter_mut().enumerate().skip(3000) {
                let t = (i - 3000) as f64 / FS;
                *v += a * (-d * t).exp() * (std::f64::consts::TAU * f * t + phase).sin();
            }
        }
        x
    };
    let high = [(440.0, 3.0, 0.3), (6100.0, 40.0, 0.2), (12_500.0, 200.0, 0.2), (18_000.0, 600.0, 0.3)];
    let wood = [(800.0, 300.0, 0.5), (2300.0, 450.0, 0.3)];
    let mut step = noise.clone();
    step[9000..].iter_mut().for_each(|v| *v += 0.2);
    let mut cases = vec![
        ("sine-phase strike", strike(0.0, &high)),
        ("cosine-phase strike", strike(std::f64::consts::FRAC_PI_2, &high)),
        ("cosine-phase woodblock", strike(std::f64::consts::FRAC_PI_2, &wood)),
        ("step", step),
        ("noise", noise.clone()),
    ];
    // A quiet tail in 16 bits: a 300 Hz partial at 3 LSB plus 1 LSB dither, quantised.
    let lsb = 1.0 / 32768.0;
    cases.push((
        "16-bit tail",
        (0..n)
            .map(|i| {
                let v = 3.0 * lsb * (std::f64::consts::TAU * 300.0 * i as f64 / FS).sin() + lsb * g.normal();
                (v / lsb).round() * lsb
            })
            .collect(),
    ));
    // A quiet strike in 16 bits whose ring decays into digital silence, with a dither of 0.2
    // LSB rms: the tail is zeros with a ±1 LSB sample here and there, which stand alone like
    // spikes over a local scale of 0. Estimated from such a tail the noise variance is 0, and
    // the strike's peak (0.02) puts −60 dB under one step.
    let mut quiet = vec![0.0; n];
    for (i, v) in quiet.iter_mut().enumerate() {
        let t = i as f64 / FS;
        let ring = 0.02 * (-40.0 * t).exp() * (std::f64::consts::TAU * 520.0 * t).sin();
        *v = ((ring + 0.2 * lsb * g.normal()) / lsb).round() * lsb;
    }
    let blips = quiet[n / 2..].iter().filter(|v| **v != 0.0).count();
    assert!((10..2000).contains(&blips), "{blips} nonzero samples in the quiet tail");
    cases.push(("16-bit quiet tail, no noise floor", quiet));
    for (name, mut x) in cases {
        let nv = match name {
            "16-bit tail" => lsb * lsb / 12.0,
            "16-bit quiet tail, no noise floor" => 0.0,
            _ => 1e-6,
        };
        let before = x.clone();
        assert_eq!(repair_clicks(&mut x, nv), Vec::<usize>::new(), "{name}");
        assert_eq!(x, before, "{name}");
    }
}
