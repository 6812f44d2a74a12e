//! Exciters: the force a mallet puts into the object, and a noise burst for rough strikes.

/// Contact time in seconds of the softest mallet (hardness 0: felt).
pub const SOFTEST_CONTACT_S: f64 = 8e-3;
/// Contact time in seconds of the hardest mallet (hardness 1: steel on steel).
pub const HARDEST_CONTACT_S: f64 = 5e-5;

/// Contact time of a mallet of `hardness` in 0..=1 struck at `velocity` in (0, 1].
///
/// Hardness interpolates logarithmically between [`SOFTEST_CONTACT_S`] and
/// [`HARDEST_CONTACT_S`]. A faster strike shortens the contact as Hertzian contact does
/// (contact time ∝ v^(−1/5), Johnson, *Contact Mechanics*, §11.4), which brightens loud notes.
pub fn contact_time_s(hardness: f32, velocity: f32) -> f64 {
    let h = f64::from(hardness.clamp(0.0, 1.0));
    let t0 = SOFTEST_CONTACT_S * (HARDEST_CONTACT_S / SOFTEST_CONTACT_S).powf(h);
    t0 * f64::from(velocity.clamp(0.05, 1.0)).powf(-0.2)
}

/// Magnitude of the force pulse's spectrum at `freq_hz`, normalised to 1 at DC, for a
/// contact of `contact_s` seconds.
///
/// A half-sine pulse of duration T has |P(f)| = |cos(πfT)| / |1 − (2fT)²|: flat below
/// 1/(2T) and falling as 1/f² above. Real contacts are not exactly half-sine, so its nulls
/// are not heard; we use the smooth envelope 1 / (1 + (2fT)²), which has the same corner
/// and the same asymptote.
#[inline]
pub fn pulse_spectrum(freq_hz: f64, contact_s: f64) -> f64 {
    let x = 2.0 * freq_hz * contact_s;
    1.0 / (1.0 + x * x)
}

/// Loudness factor of a strike of `velocity` (0..=1) with `sensitivity` (0..=1): 1 for any
/// velocity at sensitivity 0; `velocity²` at sensitivity 1 (−40 dB at velocity 0.1).
#[inline]
pub fn velocity_gain(velocity: f32, sensitivity: f32) -> f32 {
    velocity.clamp(0.0, 1.0).powf(2.0 * sensitivity.clamp(0.0, 1.0))
}

/// A small, fast, deterministic white-noise source (xorshift32) in [−1, 1).
#[derive(Clone, Copy, Debug)]
pub struct Noise {
    state: u32,
}

impl Noise {
    /// A generator from `seed` (any value; 0 is remapped).
    pub fn new(seed: u32) -> Self {
        Noise { state: if seed == 0 { 0x9E37_79B9 } else { seed } }
    }

    /// The next sample in [−1, 1).
    #[inline]
    pub fn next_sample(&mut self) -> f32 {
        let mut x = self.state;
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        self.state = x;
        // Top 24 bits as a float in [0, 1), mapped to [−1, 1).
        (x >> 8) as f32 * (2.0 / 16_777_216.0) - 1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn harder_and_faster_is_shorter() {
        assert!(contact_time_s(1.0, 1.0) < contact_time_s(0.5, 1.0));
        assert!(contact_time_s(0.5, 1.0) < contact_time_s(0.5, 0.2));
        assert!((contact_time_s(0.0, 1.0) - SOFTEST_CONTACT_S).abs() < 1e-12);
    }

    #[test]
    fn pulse_spectrum_has_half_sine_corner() {
        let t = 1e-3;
        assert_eq!(pulse_spectrum(0.0, t), 1.0);
        assert!((pulse_spectrum(500.0, t) - 0.5).abs() < 1e-12);
        // 1/f² asymptote, within 1 % a decade above the corner.
        let f = 5000.0;
        assert!((pulse_spectrum(f, t) * (2.0 * f * t).powi(2) - 1.0).abs() < 0.01);
    }

    #[test]
    fn noise_is_zero_mean_and_bounded() {
        let mut n = Noise::new(1);
        let mut sum = 0.0f64;
        for _ in 0..100_000 {
            let x = n.next_sample();
            assert!((-1.0..1.0).contains(&x));
            sum += f64::from(x);
        }
        assert!((sum / 100_000.0).abs() < 0.01);
    }
}
