//! `--method ren` (Ren, Yeh & Lin 2013 §5; issue 15 part 1): the hybrid psychoacoustic
//! metric minimised by Nelder–Mead recovers the law a recording was made with (known
//! truth: the synthesis parameters), and with a known object its specific-modulus ratio;
//! it is refused where it cannot run, and a cancelled estimate stops.

use estimator::synth::{add_noise, render, write_wav_f32, Rng};
use estimator::{estimate, fit_damping, Method, ModelKind, Options};
use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

const TAU: f64 = std::f64::consts::TAU;

/// Writes `taps` copies of the modes (f, d, a), 1.2 s apart after 0.1 s of silence, with
/// white noise 60 dB under a tap's power, to a temporary WAV.
fn session(name: &str, modes: &[(f64, f64, f64)], taps: usize, seed: u64) -> PathBuf {
    let fs = 48_000.0;
    let tap = render(modes, fs, (1.2 * fs) as usize);
    let mut x = vec![0.0; (0.1 * fs) as usize];
    for _ in 0..taps {
        x.extend_from_slice(&tap);
    }
    add_noise(&mut x, 60.0, tap.len(), &mut Rng::new(seed));
    let path = std::env::temp_dir().join(format!("struck-ren-method-{name}-{}.wav", std::process::id()));
    write_wav_f32(&path, &x, fs as u32).unwrap();
    path
}

/// Twelve partials 180 Hz–10 kHz of a Rayleigh material (α₁ = 6 s⁻¹, α₂ = 3·10⁻⁸ s), no
/// support damping: Ren's law gives each partial's decay within 3 % of the truth (at the
/// five strongest partials), and its metric is no worse than the EMG fit's.
#[test]
fn ren_recovers_the_law_of_a_recording() {
    let (a1, a2) = (6.0, 3e-8);
    let modes: Vec<(f64, f64, f64)> = (0..12)
        .map(|i| {
            let f = 180.0 * (10_000.0f64 / 180.0).powf(i as f64 / 11.0);
            let lambda = (TAU * f).powi(2);
            (f, 0.5 * (a1 + a2 * lambda), 0.4 / (1.0 + 0.5 * i as f64))
        })
        .collect();
    let path = session("law", &modes, 2, 11);
    let opts = Options { method: Method::Ren, ..Options::default() };
    let rep = estimate(std::slice::from_ref(&path), &opts, &|_| {}, &AtomicBool::new(false)).unwrap();
    let _ = std::fs::remove_file(&path);
    assert_eq!(rep.method, Method::Ren, "warnings: {:?}", rep.warnings);
    assert_eq!(rep.chosen.method, Method::Ren);
    assert!(rep.fits.iter().any(|f| f.method == Method::Emg) && rep.fits.iter().any(|f| f.method == Method::Ren));
    let law = rep.damping();
    for &(f, d, _) in modes.iter().take(5) {
        let lambda = (TAU * f).powi(2) + d * d;
        let got = 0.5 * law.c(lambda);
        assert!((got / d - 1.0).abs() < 0.03, "{f:.0} Hz: decay {got:.3} against {d:.3}; params {:?}", rep.params);
    }
    let s = rep.ren_fit.as_ref().expect("the report carries Ren's fit");
    let worst = modes
        .iter()
        .take(5)
        .map(|&(f, d, _)| (0.5 * law.c((TAU * f).powi(2) + d * d) / d - 1.0).abs())
        .fold(0.0, f64::max);
    println!("no object: params {:?}, worst decay error {:.3} %, {s:?}", rep.params, 100.0 * worst);
    assert!(s.gamma_ratio.is_none() && s.amplitude_scale.is_none());
    assert!(s.hybrid.is_finite() && s.hybrid <= s.emg_hybrid.unwrap() * 1.0001, "{s:?}");
    // Not worse than the EMG fit, so not said to be.
    assert!(!rep.warnings.iter().any(|w| w.contains("worse than the EMG fit")), "{:?}", rep.warnings);
    assert!(s.match_product > 0.9, "{s:?}");
    assert!(s.refined >= 1 && s.evaluations > s.starts, "{s:?}");
    // Ren's law is not a lower law: no support damping is derived from it.
    assert_eq!(rep.support_c(), None);
    let v = serde_json::to_value(&rep).unwrap();
    assert_eq!(v["method"], "ren");
    assert!(v["ren_fit"]["hybrid"].is_number() && v["ren_fit"]["psycho_rms_sone"].is_number());
}

/// A known object (a free bar's first eight bending modes, Euler–Bernoulli ratios, with
/// gains) recorded at γ/γ₀ = 1.37 with amplitude scale 0.3: Ren's fit puts γ/γ₀ within
/// 0.5 % (4 cents) of the truth and the law's decays within 5 % at the strong modes.
#[test]
fn ren_recovers_gamma_and_the_law_with_a_known_object() {
    let ratios = [1.0, 2.756, 5.404, 8.933, 13.345, 18.638, 24.815, 31.877];
    let gains = [1.0, 0.8, 0.6, 0.5, 0.4, 0.3, 0.25, 0.2];
    let base = TAU * 260.0;
    let lambdas0: Vec<f64> = ratios.iter().map(|r| (r * base).powi(2)).collect();
    let (gamma, sigma, a1, a2) = (1.37, 0.3, 3.0, 6e-8);
    let modes: Vec<(f64, f64, f64)> = lambdas0
        .iter()
        .zip(gains)
        .map(|(l0, g)| {
            let lambda = gamma * l0;
            let d = 0.5 * (a1 + a2 * lambda);
            ((lambda - d * d).sqrt() / TAU, d, sigma * g)
        })
        .filter(|m| m.0 < 20_000.0)
        .collect();
    let path = session("object", &modes, 2, 12);
    let opts = Options {
        method: Method::Ren,
        object_lambdas: Some(lambdas0.clone()),
        object_gains: Some(gains.to_vec()),
        ..Options::default()
    };
    let rep = estimate(std::slice::from_ref(&path), &opts, &|_| {}, &AtomicBool::new(false)).unwrap();
    let _ = std::fs::remove_file(&path);
    assert_eq!(rep.method, Method::Ren, "warnings: {:?}", rep.warnings);
    let s = rep.ren_fit.as_ref().unwrap();
    let g = s.gamma_ratio.unwrap();
    assert!((g / gamma - 1.0).abs() < 0.005, "γ/γ₀ {g} against {gamma}: {s:?}");
    let scale = s.amplitude_scale.unwrap();
    assert!((scale / sigma - 1.0).abs() < 0.15, "σ {scale} against {sigma}");
    // The report's object match is Ren's γ.
    let o = rep.object.as_ref().unwrap();
    assert!((o.gamma_ratio / g - 1.0).abs() < 1e-12 && o.matched >= 5, "{o:?}");
    let law = rep.damping();
    println!("object: γ/γ₀ {g:.5}, σ {scale:.4}, params {:?}, {s:?}", rep.params);
    for &(f, d, _) in modes.iter().take(4) {
        let lambda = (TAU * f).powi(2) + d * d;
        let got = 0.5 * law.c(lambda);
        assert!((got / d - 1.0).abs() < 0.05, "{f:.0} Hz: decay {got:.3} against {d:.3}; params {:?}", rep.params);
    }
}

/// Ren's method fits sound, not points: `fit_damping` refuses it with a one-line reason.
#[test]
fn ren_is_refused_on_bare_points() {
    let pts: Vec<(f64, f64)> = (1..20).map(|i| ((TAU * 100.0 * i as f64).powi(2), 2.0 + 0.1 * i as f64)).collect();
    let e = fit_damping(&pts, ModelKind::Rayleigh, Method::Ren).unwrap_err().to_string();
    assert!(e.contains("ren") && e.contains("estimate") && !e.contains('\n'), "{e}");
    assert_eq!(serde_json::to_string(&Method::Ren).unwrap(), "\"ren\"");
}

/// Cancelling while Ren's optimiser runs (the flag set once the EMG fits are done, at 96 %)
/// stops the estimate with `Cancelled`, not with an EMG material.
#[test]
fn a_cancelled_ren_estimate_stops() {
    let modes: Vec<(f64, f64, f64)> = (0..8).map(|i| (300.0 * (1.0 + i as f64), 3.0 + i as f64, 0.3)).collect();
    let path = session("cancel", &modes, 2, 13);
    let opts = Options { method: Method::Ren, ..Options::default() };
    let cancel = AtomicBool::new(false);
    let progress = |p: f32| {
        if p >= 0.96 {
            cancel.store(true, std::sync::atomic::Ordering::Relaxed);
        }
    };
    let r = estimate(std::slice::from_ref(&path), &opts, &progress, &cancel);
    let _ = std::fs::remove_file(&path);
    assert!(matches!(r, Err(estimator::EstimateError::Cancelled)), "{:?}", r.map(|r| r.method));
}
