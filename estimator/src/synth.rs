//! Synthetic signals and a seeded PRNG for tests, validation and benchmarks.
//! Public so the example binary and integration tests share it; not part of the stable API.

/// SplitMix64: small, fast, seeded, good enough for test data.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    /// A generator from a seed.
    pub fn new(seed: u64) -> Self {
        Self(seed ^ 0x9E37_79B9_7F4A_7C15)
    }
    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
    /// Uniform in [a, b).
    pub fn range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.uniform()
    }
    /// Log-uniform in [a, b).
    pub fn log_uniform(&mut self, a: f64, b: f64) -> f64 {
        (a.ln() + (b.ln() - a.ln()) * self.uniform()).exp()
    }
    /// Standard normal (Box–Muller).
    pub fn normal(&mut self) -> f64 {
        let u = self.uniform().max(1e-300);
        let v = self.uniform();
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }
    /// Exponential with the given mean.
    pub fn exponential(&mut self, mean: f64) -> f64 {
        -mean * (1.0 - self.uniform()).ln()
    }
}

/// Renders Σ aᵢ e^(−dᵢ t) sin(2π fᵢ t) for `n` samples at `fs` Hz (f64 accumulation).
pub fn render(modes: &[(f64, f64, f64)], fs: f64, n: usize) -> Vec<f64> {
    let mut out = vec![0.0; n];
    for &(f, d, a) in modes {
        let w = std::f64::consts::TAU * f / fs;
        let decay = (-d / fs).exp();
        // Recursion on a rotating phasor, re-anchored every 4096 samples.
        let (mut re, mut im) = (a, 0.0);
        let (c, s) = (w.cos() * decay, w.sin() * decay);
        for (i, o) in out.iter_mut().enumerate() {
            if i % 4096 == 0 {
                let t = i as f64;
                let m = a * (-d * t / fs).exp();
                re = m * (w * t).cos();
                im = m * (w * t).sin();
            }
            *o += im;
            let nre = re * c - im * s;
            im = re * s + im * c;
            re = nre;
        }
    }
    out
}

/// Adds white Gaussian noise at `snr_db` relative to the signal's mean power over the
/// first `ref_len` samples.
pub fn add_noise(x: &mut [f64], snr_db: f64, ref_len: usize, rng: &mut Rng) -> f64 {
    let m = ref_len.min(x.len()).max(1);
    let p = x[..m].iter().map(|v| v * v).sum::<f64>() / m as f64;
    let sigma = (p / 10f64.powf(snr_db / 10.0)).sqrt();
    for v in x.iter_mut() {
        *v += sigma * rng.normal();
    }
    sigma * sigma
}

/// Writes a mono 32-bit float WAV file.
pub fn write_wav_f32(path: &std::path::Path, x: &[f64], fs: u32) -> Result<(), hound::Error> {
    let spec =
        hound::WavSpec { channels: 1, sample_rate: fs, bits_per_sample: 32, sample_format: hound::SampleFormat::Float };
    let mut w = hound::WavWriter::create(path, spec)?;
    for &v in x {
        w.write_sample(v as f32)?;
    }
    w.finalize()
}

/// Mean relative errors of one method at one number of sounds (thesis §4.3.3 table row).
#[derive(Clone, Copy, Debug, Default)]
pub struct ValidationRow {
    /// Mean |α̂₁ − α₁|/α₁.
    pub alpha1: f64,
    /// Mean |α̂₂ − α₂|/α₂.
    pub alpha2: f64,
    /// Mean over draws of mean_i |c_fit(λᵢ) − c_true(λᵢ)|/c_true(λᵢ).
    pub curve: f64,
    /// Draws whose fit failed.
    pub failures: usize,
}

/// Synthetic validation on (λ, c) points, after Sterling thesis §4.3.3: per draw a random
/// material (Rayleigh α₁ log-uniform in [2, 30] s⁻¹, α₂ in [5e-9, 2e-7] s), an object of 40
/// modes (f log-uniform in [150, 12000] Hz) with 10 supports of random strength; each sound
/// strikes a random subset of modes (each with probability 0.6), picks one support, adds to
/// each mode exponential support damping (mean = strength × mean material c, strength
/// uniform in [0.05, 0.5]) and Gaussian extraction error (3 % of c). Returns rows for
/// (EMG, LSQ, LB) averaged over `draws`.
pub fn validate_points(n_sounds: usize, draws: usize, seed: u64) -> [ValidationRow; 3] {
    use crate::{fit_damping, Method, ModelKind};
    let mut rng = Rng::new(seed);
    let mut rows = [ValidationRow::default(); 3];
    let mut counts = [0usize; 3];
    for _ in 0..draws {
        let a1 = rng.log_uniform(2.0, 30.0);
        let a2 = rng.log_uniform(5e-9, 2e-7);
        let lambdas: Vec<f64> =
            (0..40).map(|_| (std::f64::consts::TAU * rng.log_uniform(150.0, 12_000.0)).powi(2)).collect();
        let ctrue = |l: f64| a1 + a2 * l;
        let cmean = lambdas.iter().map(|&l| ctrue(l)).sum::<f64>() / lambdas.len() as f64;
        let supports: Vec<f64> = (0..10).map(|_| rng.range(0.05, 0.5)).collect();
        let mut pts = Vec::new();
        for _ in 0..n_sounds {
            let s = supports[(rng.uniform() * 10.0) as usize % 10];
            for &l in &lambdas {
                if rng.uniform() < 0.6 {
                    let c = ctrue(l) + rng.exponential(s * cmean) + 0.03 * ctrue(l) * rng.normal();
                    pts.push((l, c.max(1e-3)));
                }
            }
        }
        for (mi, m) in [Method::Emg, Method::Lsq, Method::Lb].into_iter().enumerate() {
            match fit_damping(&pts, ModelKind::Rayleigh, m) {
                Ok(f) => {
                    rows[mi].alpha1 += (f.params[0] / a1 - 1.0).abs();
                    rows[mi].alpha2 += (f.params[1] / a2 - 1.0).abs();
                    rows[mi].curve +=
                        pts.iter().map(|&(l, _)| (f.c(l) / ctrue(l) - 1.0).abs()).sum::<f64>() / pts.len() as f64;
                    counts[mi] += 1;
                }
                Err(_) => rows[mi].failures += 1,
            }
        }
    }
    for (r, &c) in rows.iter_mut().zip(&counts) {
        let c = c.max(1) as f64;
        r.alpha1 /= c;
        r.alpha2 /= c;
        r.curve /= c;
    }
    rows
}

/// Ren et al. 2013 §4 accuracy test: `trials` single damped sinusoids, f log-uniform in
/// [20, 20000] Hz, d log-uniform in [0.1, 1000] s⁻¹, a = 0.5, 1 s at 44.1 kHz, f32 samples;
/// `snr_db` adds white noise relative to the sinusoid's power over its first 1/d seconds
/// (at most 1 s). Returns (mean rel. freq error, mean rel. decay error, worst freq, worst
/// decay, trials without a feature).
pub fn ren_test(trials: usize, seed: u64, snr_db: Option<f64>) -> (f64, f64, f64, f64, usize) {
    use crate::features::{extract_impact, ExtractOptions};
    let fs = 44_100.0;
    let n = 44_100;
    let mut rng = Rng::new(seed);
    let cancel = std::sync::atomic::AtomicBool::new(false);
    let opts = ExtractOptions { min_decay_per_s: 0.0, min_freq_hz: 1.0, ..Default::default() };
    let (mut ef, mut ed, mut wf, mut wd, mut missing) = (0.0, 0.0, 0.0f64, 0.0f64, 0);
    for _ in 0..trials {
        let f = rng.log_uniform(20.0, 20_000.0);
        let d = rng.log_uniform(0.1, 1000.0);
        let mut x = render(&[(f, d, 0.5)], fs, n);
        let nv = match snr_db {
            Some(s) => add_noise(&mut x, s, ((fs / d) as usize).clamp(16, n), &mut rng),
            None => 0.0,
        };
        let xf: Vec<f32> = x.iter().map(|&v| v as f32).collect();
        // PANIC: the flag is never set here.
        let fit = extract_impact(&xf, fs, nv, &opts, &cancel).expect("not cancelled");
        let best = fit.features.iter().min_by(|a, b| (a.freq_hz - f).abs().total_cmp(&(b.freq_hz - f).abs()));
        match best {
            Some(b) => {
                let rf = (b.freq_hz / f - 1.0).abs();
                let rd = (b.decay_per_s / d - 1.0).abs();
                ef += rf;
                ed += rd;
                wf = wf.max(rf);
                wd = wd.max(rd);
            }
            None => missing += 1,
        }
    }
    let k = (trials - missing).max(1) as f64;
    (ef / k, ed / k, wf, wd, missing)
}

/// Random 30-mode impact: f log-uniform in [100, 15000] Hz, Rayleigh damping c = 4 + 1.5e-8 λ,
/// amplitude log-uniform in [0.005, 0.1]. Returns (f, d, a) per mode.
pub fn mixture_modes(rng: &mut Rng) -> Vec<(f64, f64, f64)> {
    (0..30)
        .map(|_| {
            let f: f64 = rng.log_uniform(100.0, 15_000.0);
            let lambda = (std::f64::consts::TAU * f).powi(2);
            let c = 4.0 + 1.5e-8 * lambda;
            let d = 0.5 * c;
            (f, d, rng.log_uniform(0.005, 0.1))
        })
        .collect()
}

/// Recovery statistics of [`mixture_stats`].
#[derive(Clone, Copy, Debug, Default)]
pub struct MixtureStats {
    /// Features within 0.5 % of a true mode / all features.
    pub precision: f64,
    /// True modes with a feature within 0.5 % / all true modes.
    pub recall: f64,
    /// Mean relative damping error of recovered modes.
    pub decay_err_mean: f64,
    /// Median relative damping error of recovered modes.
    pub decay_err_median: f64,
    /// Mean relative frequency error of recovered modes.
    pub freq_err_mean: f64,
    /// Mean extraction time per impact, s.
    pub seconds_per_impact: f64,
}

/// Precision/recall over `impacts` random 30-mode impacts (1 s at `fs`) with white noise at
/// `snr_db` relative to the impact's mean power.
pub fn mixture_stats(snr_db: f64, impacts: usize, seed: u64, fs: f64) -> MixtureStats {
    use crate::features::{extract_impact, ExtractOptions};
    let n = fs as usize;
    let mut rng = Rng::new(seed);
    let cancel = std::sync::atomic::AtomicBool::new(false);
    let opts = ExtractOptions::default();
    let (mut tp, mut nfeat, mut ntrue, mut ferr) = (0usize, 0usize, 0usize, 0.0);
    let mut derr = Vec::new();
    let mut secs = 0.0;
    for _ in 0..impacts {
        let modes = mixture_modes(&mut rng);
        let mut x = render(&modes, fs, n);
        let nv = add_noise(&mut x, snr_db, n, &mut rng);
        let xf: Vec<f32> = x.iter().map(|&v| v as f32).collect();
        let t0 = std::time::Instant::now();
        // PANIC: the flag is never set here.
        let fit = extract_impact(&xf, fs, nv, &opts, &cancel).expect("not cancelled");
        secs += t0.elapsed().as_secs_f64();
        nfeat += fit.features.len();
        ntrue += modes.len();
        for m in &modes {
            // The strongest feature within 0.5 % stands for the mode.
            let near = fit.features.iter().filter(|f| (f.freq_hz / m.0 - 1.0).abs() < 0.005);
            if let Some(f) = near.max_by(|a, b| a.amplitude.total_cmp(&b.amplitude)) {
                tp += 1;
                derr.push((f.decay_per_s / m.1 - 1.0).abs());
                ferr += (f.freq_hz / m.0 - 1.0).abs();
            }
        }
    }
    let mean = derr.iter().sum::<f64>() / derr.len().max(1) as f64;
    derr.sort_by(f64::total_cmp);
    MixtureStats {
        precision: (tp as f64 / nfeat.max(1) as f64).min(1.0),
        recall: tp as f64 / ntrue.max(1) as f64,
        decay_err_mean: mean,
        decay_err_median: derr.get(derr.len() / 2).copied().unwrap_or(f64::NAN),
        freq_err_mean: ferr / tp.max(1) as f64,
        seconds_per_impact: secs / impacts.max(1) as f64,
    }
}

/// A tapping session on one synthetic object: 20 modes (f log-uniform in [200, 8000] Hz),
/// Rayleigh material (α₁, α₂), `taps` taps 0.7 s apart after 0.2 s of noise; each tap excites
/// each mode with probability 0.7 (amplitude log-uniform in [0.01, 0.1]) and adds
/// exponential support damping to c (mean uniform in [1, 6] s⁻¹ per tap); white noise
/// `snr_db` under the session's mean power. Returns (samples, λ of the modes).
pub fn render_session(rng: &mut Rng, alpha: (f64, f64), taps: usize, fs: f64, snr_db: f64) -> (Vec<f64>, Vec<f64>) {
    let lambdas: Vec<f64> = (0..20).map(|_| (std::f64::consts::TAU * rng.log_uniform(200.0, 8000.0)).powi(2)).collect();
    let gap = (0.7 * fs) as usize;
    let lead = (0.2 * fs) as usize;
    let mut x = vec![0.0; lead + taps * gap];
    for t in 0..taps {
        let extra_mean = rng.range(1.0, 6.0);
        let mut modes = Vec::new();
        for &l in &lambdas {
            if rng.uniform() < 0.7 {
                let c = alpha.0 + alpha.1 * l + rng.exponential(extra_mean);
                let d = 0.5 * c;
                modes.push(((l - d * d).sqrt() / std::f64::consts::TAU, d, rng.log_uniform(0.01, 0.1)));
            }
        }
        let y = render(&modes, fs, gap);
        for (i, v) in y.iter().enumerate() {
            x[lead + t * gap + i] += v;
        }
    }
    let len = x.len();
    add_noise(&mut x, snr_db, len, rng);
    (x, lambdas)
}
