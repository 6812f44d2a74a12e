//! Feature-extraction accuracy (Ren et al. 2013 §4 test, and multi-mode mixtures).

use std::sync::atomic::AtomicBool;

use estimator::features::{extract_impact, ExtractOptions};
use estimator::synth::{add_noise, render, Rng};

/// Ren §4: 100 single damped sinusoids, f log-uniform in [20, 20000] Hz, d log-uniform in
/// [0.1, 1000] s⁻¹, 44.1 kHz, 1 s, f32 samples (quantisation noise ≈ −150 dB), no other noise.
#[test]
fn ren_single_sinusoids() {
    let fs = 44_100.0;
    let n = 44_100;
    let mut rng = Rng::new(2013);
    let cancel = AtomicBool::new(false);
    let opts = ExtractOptions { min_decay_per_s: 0.0, min_freq_hz: 1.0, ..Default::default() };
    let (mut ef, mut ed, mut worst_f, mut worst_d) = (0.0, 0.0, 0.0f64, 0.0f64);
    let trials = 100;
    for t in 0..trials {
        let f = rng.log_uniform(20.0, 20_000.0);
        let d = rng.log_uniform(0.1, 1000.0);
        let x: Vec<f32> = render(&[(f, d, 0.5)], fs, n).iter().map(|&v| v as f32).collect();
        let fit = extract_impact(&x, fs, 0.0, &opts, &cancel).unwrap();
        let best = fit.features.iter().min_by(|a, b| (a.freq_hz - f).abs().total_cmp(&(b.freq_hz - f).abs()));
        let Some(best) = best else { panic!("trial {t}: no feature for f={f} d={d}: {fit:?}") };
        let rf = (best.freq_hz / f - 1.0).abs();
        let rd = (best.decay_per_s / d - 1.0).abs();
        if rf > 1e-3 || rd > 1e-2 {
            eprintln!("trial {t}: f={f:.3} d={d:.4} -> f={:.3} d={:.4} a={:.4} ({} feats)", best.freq_hz, best.decay_per_s, best.amplitude, fit.features.len());
        }
        ef += rf;
        ed += rd;
        worst_f = worst_f.max(rf);
        worst_d = worst_d.max(rd);
    }
    ef /= trials as f64;
    ed /= trials as f64;
    eprintln!("ren: mean rel err f {:.3e} ({:.5} %), d {:.3e} ({:.4} %); worst f {worst_f:.2e} d {worst_d:.2e}", ef, 100.0 * ef, ed, 100.0 * ed);
    assert!(ef < 0.00040, "mean frequency error {ef}");
    assert!(ed < 0.0053, "mean damping error {ed}");
}

/// One 30-mode impact with Rayleigh damping: returns (modes (f, d, a), signal).
fn mixture(rng: &mut Rng, fs: f64, n: usize) -> Vec<(f64, f64, f64)> {
    let (a1, a2) = (4.0, 1.5e-8);
    (0..30)
        .map(|_| {
            let f: f64 = rng.log_uniform(100.0, 15_000.0);
            let lambda = (std::f64::consts::TAU * f).powi(2);
            let d = 0.5 * (a1 + a2 * lambda);
            let _ = (fs, n);
            (f, d, rng.log_uniform(0.005, 0.1))
        })
        .collect()
}

/// Precision/recall (match within 0.5 % in frequency) and mean relative damping error of
/// matched modes, over `impacts` random 30-mode impacts at `snr_db`.
pub fn mixture_stats(snr_db: f64, impacts: usize, seed: u64) -> (f64, f64, f64, f64) {
    let fs = 44_100.0;
    let n = 44_100;
    let mut rng = Rng::new(seed);
    let cancel = AtomicBool::new(false);
    let opts = ExtractOptions::default();
    let (mut tp, mut nfeat, mut ntrue, mut derr, mut dn) = (0usize, 0usize, 0usize, 0.0, 0usize);
    let mut dmed = Vec::new();
    for _ in 0..impacts {
        let modes = mixture(&mut rng, fs, n);
        let mut x = render(&modes, fs, n);
        let nv = add_noise(&mut x, snr_db, n, &mut rng);
        let xf: Vec<f32> = x.iter().map(|&v| v as f32).collect();
        let fit = extract_impact(&xf, fs, nv, &opts, &cancel).unwrap();
        nfeat += fit.features.len();
        if std::env::var("DEBUG_MIX").is_ok() {
            for f in &fit.features {
                if !modes.iter().any(|m| (f.freq_hz / m.0 - 1.0).abs() < 0.005) {
                    let near = modes.iter().min_by(|a, b| (a.0 - f.freq_hz).abs().total_cmp(&(b.0 - f.freq_hz).abs())).unwrap();
                    eprintln!("spurious {f:?} nearest true {near:?}");
                }
            }
            eprintln!("explained {} res/noise {} fitted {} rejected {}", fit.explained_power, fit.residual_to_noise, fit.fitted_modes, fit.rejected_peaks);
        }
        ntrue += modes.len();
        for m in &modes {
            if let Some(f) = fit.features.iter().find(|f| (f.freq_hz / m.0 - 1.0).abs() < 0.005) {
                tp += 1;
                let e = (f.decay_per_s / m.1 - 1.0).abs();
                derr += e;
                dn += 1;
                dmed.push(e);
            }
        }
    }
    let precision = fit_precision(&mut rng, tp, nfeat);
    dmed.sort_by(f64::total_cmp);
    (precision, tp as f64 / ntrue as f64, derr / dn.max(1) as f64, dmed.get(dmed.len() / 2).copied().unwrap_or(f64::NAN))
}

fn fit_precision(_: &mut Rng, tp: usize, nfeat: usize) -> f64 {
    (tp as f64 / nfeat.max(1) as f64).min(1.0)
}

#[test]
fn mixtures_40db_and_20db() {
    for (snr, min_p, min_r, max_med) in [(40.0, 0.7, 0.9, 0.02), (20.0, 0.8, 0.8, 0.05)] {
        let (p, r, mean_d, med_d) = mixture_stats(snr, 4, 7 + snr as u64);
        eprintln!("mixture {snr} dB: precision {p:.3} recall {r:.3} damping err mean {:.2} % median {:.2} %", 100.0 * mean_d, 100.0 * med_d);
        assert!(p >= min_p && r >= min_r && med_d <= max_med, "{snr} dB: p {p} r {r} median d err {med_d}");
    }
}
