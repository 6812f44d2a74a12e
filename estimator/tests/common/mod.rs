//! A test-only generator (SplitMix64), separate from `estimator::synth::Rng` so that the
//! issue-10 tests make their data independently of the estimator's own synthesis code.
#![allow(dead_code)]

/// SplitMix64 → uniform [0, 1), log-uniform and normal draws.
pub struct Gen(pub u64);

impl Gen {
    pub fn u(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
    pub fn log_uniform(&mut self, a: f64, b: f64) -> f64 {
        a * (b / a).powf(self.u())
    }
    pub fn normal(&mut self) -> f64 {
        (-2.0 * self.u().max(1e-300).ln()).sqrt() * (std::f64::consts::TAU * self.u()).cos()
    }
}

/// Writes `x` as a mono 32-bit float WAV at `fs` Hz to `NAME.wav` in a folder of the system's
/// temporary directory named after `tag` and this process.
pub fn write_wav(tag: &str, name: &str, fs: f64, x: &[f64]) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("struck-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(format!("{name}.wav"));
    let spec = hound::WavSpec {
        channels: 1,
        sample_rate: fs as u32,
        bits_per_sample: 32,
        sample_format: hound::SampleFormat::Float,
    };
    let mut w = hound::WavWriter::create(&p, spec).unwrap();
    for &v in x {
        w.write_sample(v as f32).unwrap();
    }
    w.finalize().unwrap();
    p
}
