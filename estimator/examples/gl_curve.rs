//! Griffin–Lim's spectral convergence against its iterations on a transferred residual
//! (issue 15: the iteration count the transfer runs is chosen from this).
//!
//! `cargo run --release -p struck-estimator --example gl_curve [residual.wav ...]`: each
//! WAV (mono) is taken as a source residual; without files, a decaying noise burst.

use estimator::residual::{griffin_lim_with, power_spectrogram, Stft};
use estimator::transfer::{pairs, transfer_spectrogram, Source};

fn main() {
    let fs = 48_000.0;
    let mut signals: Vec<(String, Vec<f64>, f64)> = Vec::new();
    for path in std::env::args().skip(1) {
        match estimator::wav::load_wav_exact(std::path::Path::new(&path), None) {
            Ok(r) => signals.push((path, r.samples.iter().map(|&v| f64::from(v)).collect(), f64::from(r.sample_rate))),
            Err(e) => eprintln!("{path}: {e}"),
        }
    }
    if signals.is_empty() {
        signals.push(("noise burst, 1 s".into(), estimator::transfer::transfer_workload().0, fs));
    }
    let (_, source, target) = estimator::transfer::transfer_workload();
    let mut plan = Stft::<f32>::new();
    for (name, x, rate) in signals {
        let spec = power_spectrogram(&x);
        let src = Source { power: &spec.power, frames: spec.frames, sample_rate: rate, modes: &source };
        let p = pairs(&source, rate / 2.0, &target, fs / 2.0);
        for (label, s) in [("as recorded", spec.clone()), ("transferred", transfer_spectrogram(&src, &p, fs))] {
            let len = (s.frames - 1) * estimator::residual::HOP;
            let row: Vec<String> = [1usize, 5, 10, 16, 24, 32, 48, 64, 100]
                .iter()
                .map(|&n| {
                    let t = std::time::Instant::now();
                    let r = griffin_lim_with(&mut plan, &s, len, n, 1);
                    format!("{n}: {:.3} ({:.0} ms)", r.convergence, t.elapsed().as_secs_f64() * 1e3)
                })
                .collect();
            println!("{name}, {label}: {}", row.join(", "));
        }
    }
}
