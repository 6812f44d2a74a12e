//! Prints the validation tables and timings for RESULTS.md:
//! `cargo run --release -p struck-estimator --example validate`.

use std::time::Instant;

use estimator::features::{extract_impact, ExtractOptions};
use estimator::synth::{
    add_noise, mixture_modes, mixture_stats, ren_test, render, render_session, validate_points, write_wav_f32, Rng,
};
use estimator::{estimate, fit_damping, Method, ModelKind, Options};

fn main() {
    println!("## Ren §4 single-sinusoid test (100 draws)");
    for (label, snr, seed) in
        [("noiseless (f32)", None, 2013), ("60 dB SNR", Some(60.0), 2014), ("40 dB SNR", Some(40.0), 2015)]
    {
        let (ef, ed, wf, wd, miss) = ren_test(100, seed, snr);
        println!("{label:16} mean rel err f {:.2e} ({:.5} %), d {:.2e} ({:.4} %); worst f {wf:.1e} d {wd:.1e}; missing {miss}", ef, 100.0 * ef, ed, 100.0 * ed);
    }

    println!("\n## 30-mode mixtures, 1 s at 44.1 kHz (20 impacts each)");
    for snr in [40.0, 20.0] {
        let s = mixture_stats(snr, 20, 100 + snr as u64, 44_100.0);
        println!(
            "{snr} dB: precision {:.3} recall {:.3} | recovered: damping err mean {:.2} % median {:.2} %, freq err mean {:.4} % | {:.0} ms/impact",
            s.precision, s.recall, 100.0 * s.decay_err_mean, 100.0 * s.decay_err_median, 100.0 * s.freq_err_mean, 1e3 * s.seconds_per_impact
        );
    }

    println!("\n## Thesis §4.3.3 synthetic validation (Rayleigh, 30 draws per N): mean relative error");
    println!("| N | EMG α1 | EMG α2 | EMG curve | LSQ α1 | LSQ α2 | LSQ curve | LB α1 | LB α2 | LB curve |");
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for n in [1usize, 2, 5, 10, 20, 40] {
        let [e, l, b] = validate_points(n, 30, 4330 + n as u64);
        println!(
            "| {n} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} |",
            e.alpha1, e.alpha2, e.curve, l.alpha1, l.alpha2, l.curve, b.alpha1, b.alpha2, b.curve
        );
    }

    println!("\n## Audio-level check: WAV session -> estimate() (Rayleigh, 40 dB SNR, 5 draws)");
    println!("| taps | points | EMG curve | LSQ curve | LB curve | EMG α1 | EMG α2 |");
    println!("|---|---|---|---|---|---|---|");
    let dir = std::env::temp_dir().join(format!("struck-validate-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for taps in [5usize, 20] {
        let mut rng = Rng::new(900 + taps as u64);
        let (mut ce, mut cl, mut cb, mut e1, mut e2, mut pts) = (0.0, 0.0, 0.0, 0.0, 0.0, 0usize);
        let draws = 5;
        for i in 0..draws {
            let (a1, a2) = (rng.log_uniform(2.0, 15.0), rng.log_uniform(1e-8, 1e-7));
            let (x, lambdas) = render_session(&mut rng, (a1, a2), taps, 48_000.0, 40.0);
            let path = dir.join(format!("s{taps}-{i}.wav"));
            write_wav_f32(&path, &x, 48_000).unwrap();
            let cancel = std::sync::atomic::AtomicBool::new(false);
            let rep = estimate(&[path], &Options::default(), &|_| {}, &cancel).unwrap();
            let curve = |f: &estimator::FitResult| {
                lambdas.iter().map(|&l| (f.c(l) / (a1 + a2 * l) - 1.0).abs()).sum::<f64>() / lambdas.len() as f64
            };
            let get = |m: Method| rep.fits.iter().find(|f| f.method == m).unwrap();
            ce += curve(get(Method::Emg));
            cl += curve(get(Method::Lsq));
            cb += curve(get(Method::Lb));
            e1 += (rep.params[0] / a1 - 1.0).abs();
            e2 += (rep.params[1] / a2 - 1.0).abs();
            pts += rep.n_points;
        }
        let k = draws as f64;
        println!(
            "| {taps} | {} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} |",
            pts / draws,
            ce / k,
            cl / k,
            cb / k,
            e1 / k,
            e2 / k
        );
    }
    let _ = std::fs::remove_dir_all(&dir);

    println!("\n## Timings (this machine, release)");
    for n in [1_000usize, 10_000] {
        let mut rng = Rng::new(n as u64);
        let truth = dsp::Damping::Rayleigh { alpha1: 8.0, alpha2: 5e-8 };
        let pts: Vec<(f64, f64)> = (0..n)
            .map(|_| {
                let l = (std::f64::consts::TAU * rng.log_uniform(100.0, 10_000.0)).powi(2);
                (l, truth.c(l) + 0.5 * rng.normal() + rng.exponential(6.0))
            })
            .collect();
        for model in [ModelKind::Rayleigh, ModelKind::Hybrid] {
            let reps = if n > 5000 { 10 } else { 50 };
            let mut best = f64::INFINITY;
            let mut its = 0;
            for _ in 0..reps {
                let t = Instant::now();
                its = fit_damping(&pts, model, Method::Emg).unwrap().iterations;
                best = best.min(t.elapsed().as_secs_f64());
            }
            println!(
                "EMG {model:?} fit of {n} points: {:.2} ms, best of {reps} ({its} optimiser iterations over all starts)",
                1e3 * best
            );
        }
    }
    // The build machine is shared: report the minimum and the median of repeated runs.
    let fs = 48_000.0;
    let mut rng = Rng::new(5);
    let cancel = std::sync::atomic::AtomicBool::new(false);
    let mut times = Vec::new();
    for _ in 0..10 {
        let modes = mixture_modes(&mut rng);
        let mut x = render(&modes, fs, 48_000);
        let nv = add_noise(&mut x, 40.0, 48_000, &mut rng);
        let xf: Vec<f32> = x.iter().map(|&v| v as f32).collect();
        let mut best = f64::INFINITY;
        for _ in 0..3 {
            let t = Instant::now();
            let _ = extract_impact(&xf, fs, nv, &ExtractOptions::default(), &cancel).unwrap();
            best = best.min(t.elapsed().as_secs_f64());
        }
        times.push(best);
    }
    times.sort_by(f64::total_cmp);
    println!(
        "feature extraction, 1 s 30-mode impact at 48 kHz, 40 dB SNR: median {:.0} ms, fastest {:.0} ms, slowest {:.0} ms (10 impacts, best of 3 runs each)",
        1e3 * times[5],
        1e3 * times[0],
        1e3 * times[9]
    );
}
