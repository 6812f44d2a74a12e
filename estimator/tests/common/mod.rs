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
