//! Ren §5.2.2's match ratios in the estimate report (issue 15 part 1): a recording made with
//! a known Rayleigh law is well represented by the material the estimator fits to it, and
//! far less by a material that damps twice as fast.

use estimator::ren::{match_ratios, Point};
use estimator::synth::{add_noise, render, write_wav_f32, Rng};
use estimator::{estimate, Options};
use std::sync::atomic::AtomicBool;

#[test]
fn the_fitted_material_represents_its_recording_and_a_wrong_one_does_not() {
    let fs = 48_000.0;
    let (a1, a2) = (4.0, 2e-8);
    // Ten partials 150 Hz–9 kHz, each decaying at the law's d = (α₁ + α₂λ)/2, three taps.
    let modes: Vec<(f64, f64, f64)> = (0..10)
        .map(|i| {
            let f = 150.0 * 60f64.powf(i as f64 / 9.0);
            let lambda = (std::f64::consts::TAU * f).powi(2);
            (f, 0.5 * (a1 + a2 * lambda), 0.5 / (1.0 + i as f64))
        })
        .collect();
    let tap = render(&modes, fs, (1.5 * fs) as usize);
    let mut x = vec![0.0; (0.1 * fs) as usize];
    for _ in 0..3 {
        x.extend_from_slice(&tap);
    }
    let mut rng = Rng::new(3);
    add_noise(&mut x, 60.0, tap.len(), &mut rng);
    let path = std::env::temp_dir().join(format!("struck-ren-{}.wav", std::process::id()));
    write_wav_f32(&path, &x, fs as u32).unwrap();
    let rep = estimate(std::slice::from_ref(&path), &Options::default(), &|_| {}, &AtomicBool::new(false)).unwrap();
    let _ = std::fs::remove_file(&path);
    let m = rep.ren_match.as_ref().expect("the report carries Ren's match");
    assert_eq!(m.against, "own modes");
    assert_eq!(m.impacts.len(), rep.impacts.len());
    for (imp, r) in rep.impacts.iter().zip(&m.impacts) {
        assert_eq!(imp.features.len(), r.feature_ratios.len());
    }
    // The same features against a material with twice the law's c.
    let wrong: Vec<f64> = rep
        .impacts
        .iter()
        .map(|imp| {
            let reference: Vec<Point> =
                imp.features.iter().map(|f| Point::new(f.freq_hz, f.decay_per_s, f.amplitude)).collect();
            let estimated: Vec<Point> =
                imp.features.iter().map(|f| Point::new(f.freq_hz, a1 + a2 * f.lambda(), f.amplitude)).collect();
            match_ratios(&reference, &estimated).product
        })
        .collect();
    let wrong = wrong.iter().sum::<f64>() / wrong.len() as f64;
    println!(
        "Ren match product: fitted material {:.3} (R {:.3}, R~ {:.3}); twice the damping {wrong:.3}",
        m.product, m.reference_ratio, m.estimated_ratio
    );
    assert!(m.product > 0.9, "fitted: {m:?}");
    assert!(wrong < 0.5 * m.product, "twice the damping: {wrong}");
    let v = serde_json::to_value(&rep).unwrap();
    assert!(v["ren_match"]["product"].is_number() && v["ren_match"]["impacts"][0]["feature_ratios"].is_array());
}
