//! Speed of the estimator: EMG fits and feature extraction (figures in the README).
//!
//! `cargo bench -p struck-estimator`.

use criterion::{criterion_group, criterion_main, Criterion};
use estimator::synth::{add_noise, mixture_modes, render, Rng};
use estimator::{fit_damping, ExtractOptions, Method, ModelKind};
use std::hint::black_box;
use std::sync::atomic::AtomicBool;

/// `n` (λ, c) points: Rayleigh material plus exponential support damping and 3 % noise.
fn points(n: usize, seed: u64) -> Vec<(f64, f64)> {
    let mut rng = Rng::new(seed);
    (0..n)
        .map(|_| {
            let f = rng.log_uniform(100.0, 15_000.0);
            let lambda = (std::f64::consts::TAU * f).powi(2);
            let c = 6.0 + 4e-8 * lambda;
            (lambda, c * (1.0 + 0.03 * rng.normal()) + rng.exponential(0.2 * c))
        })
        .collect()
}

fn fits(c: &mut Criterion) {
    let mut g = c.benchmark_group("fit");
    for n in [1_000usize, 10_000] {
        let p = points(n, 7);
        for (model, name) in [(ModelKind::Rayleigh, "rayleigh"), (ModelKind::Hybrid, "hybrid")] {
            g.bench_function(format!("EMG {name}, {n} points"), |b| {
                b.iter(|| fit_damping(black_box(&p), model, Method::Emg).unwrap())
            });
        }
        // As `estimate` fits: each point with its own uncertainty (here 3 % of c).
        let sig: Vec<f64> = p.iter().map(|q| 0.03 * q.1).collect();
        g.bench_function(format!("EMG rayleigh weighted, {n} points"), |b| {
            b.iter(|| {
                estimator::fit_damping_weighted(black_box(&p), Some(&sig), ModelKind::Rayleigh, Method::Emg).unwrap()
            })
        });
        g.bench_function(format!("LSQ rayleigh, {n} points"), |b| {
            b.iter(|| fit_damping(black_box(&p), ModelKind::Rayleigh, Method::Lsq).unwrap())
        });
    }
    g.finish();
}

fn extraction(c: &mut Criterion) {
    let mut g = c.benchmark_group("features");
    g.sample_size(10);
    let fs = 48_000.0;
    let mut rng = Rng::new(3);
    let modes = mixture_modes(&mut rng);
    let mut x = render(&modes, fs, 48_000);
    let noise_var = add_noise(&mut x, 40.0, 48_000, &mut rng);
    let x32: Vec<f32> = x.iter().map(|v| *v as f32).collect();
    let cancel = AtomicBool::new(false);
    let opts = ExtractOptions::default();
    g.bench_function("30-mode 1 s impact at 48 kHz, 40 dB SNR", |b| {
        b.iter(|| estimator::features::extract_impact(black_box(&x32), fs, noise_var, &opts, &cancel).unwrap())
    });
    // A roll: strikes of one five-mode object every 25–40 ms for 2 s (merged into impacts
    // whose peaks are no single damped sinusoids: most fits are rejected).
    let roll_modes = [(523.0, 4.0), (1400.0, 9.0), (2700.0, 15.0), (4460.0, 24.0), (6600.0, 35.0)];
    let mut roll = vec![0.0; 96_000];
    let mut t = 0.1;
    while t < 1.9 {
        let at = (t * fs) as usize;
        let gain = 0.5 + 0.5 * rng.uniform();
        let modes: Vec<(f64, f64, f64)> =
            roll_modes.iter().enumerate().map(|(k, &(f, d))| (f, d, gain * 0.2 / (k + 1) as f64)).collect();
        for (o, v) in roll[at..].iter_mut().zip(render(&modes, fs, 96_000 - at)) {
            *o += v;
        }
        t += 0.025 + 0.015 * rng.uniform();
    }
    add_noise(&mut roll, 60.0, 96_000, &mut rng);
    let path = std::env::temp_dir().join(format!("struck-bench-roll-{}.wav", std::process::id()));
    estimator::synth::write_wav_f32(&path, &roll, 48_000).unwrap();
    let files = vec![path.clone()];
    let all = estimator::Options::default();
    g.bench_function("features of a 2 s roll, strikes 25-40 ms apart (48 kHz file)", |b| {
        b.iter(|| estimator::extract_features(black_box(&files), &all, &|_| {}, &cancel).unwrap())
    });
    g.finish();
    let _ = std::fs::remove_file(path);
}

/// The whole pipeline (read, segment, extract, fit) on one WAV of 20 taps at 48 kHz.
fn pipeline(c: &mut Criterion) {
    let mut g = c.benchmark_group("pipeline");
    g.sample_size(10);
    let mut rng = Rng::new(20);
    let (x, _) = estimator::synth::render_session(&mut rng, (5.0, 3e-8), 20, 48_000.0, 40.0);
    let path = std::env::temp_dir().join(format!("struck-bench-20-taps-{}.wav", std::process::id()));
    estimator::synth::write_wav_f32(&path, &x, 48_000).unwrap();
    let files = vec![path.clone()];
    let cancel = AtomicBool::new(false);
    let opts = estimator::Options::default();
    g.bench_function("estimate: 20 taps in one 48 kHz file (EMG Rayleigh)", |b| {
        b.iter(|| estimator::estimate(black_box(&files), &opts, &|_| {}, &cancel).unwrap())
    });
    // Ren's method (issue 15): the same analysis, then Ren §5.3's optimiser on the first
    // four taps' loudness images and features.
    let ren = estimator::Options { method: estimator::Method::Ren, ..estimator::Options::default() };
    g.bench_function("estimate: 20 taps in one 48 kHz file (Ren Rayleigh)", |b| {
        b.iter(|| {
            let r = estimator::estimate(black_box(&files), &ren, &|_| {}, &cancel).unwrap();
            assert_eq!(r.method, estimator::Method::Ren);
            r
        })
    });
    g.finish();
    let _ = std::fs::remove_file(path);
}

/// Ren §6.2's residual transfer (issue 15): a 1 s residual (a decaying noise burst over
/// 1–8 kHz) from twelve recorded modes to twelve target modes a fifth up with other decays,
/// Griffin–Lim included, at 48 kHz, on one core.
fn transfer(c: &mut Criterion) {
    use estimator::residual::{power_spectrogram, Stft};
    use estimator::transfer::{transfer, Source};
    let fs = 48_000.0;
    let (x, source, target) = estimator::transfer::transfer_workload();
    let spec = power_spectrogram(&x);
    let src = Source { power: &spec.power, frames: spec.frames, sample_rate: fs, modes: &source };
    let mut plan = Stft::<f32>::new();
    let t = transfer(&mut plan, &src, &target, fs, 1);
    println!("transfer of a 1 s residual: {} iterations, spectral convergence {:.3}", t.iterations, t.convergence);
    c.bench_function("transfer, 1 s residual", |b| b.iter(|| transfer(&mut plan, black_box(&src), &target, fs, 1)));
}

criterion_group!(benches, fits, extraction, pipeline, transfer);
criterion_main!(benches);
