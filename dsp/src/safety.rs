//! Output safety (issue 11 part 2): a soft clipper that leaves every sample below its
//! threshold untouched and never lets one reach past full scale.

/// Level below which the clipper is bit-transparent: −1 dBFS.
pub const SAFETY_THRESHOLD: f32 = 0.891_250_9;

/// Soft clipper: `x` itself for |x| ≤ [`SAFETY_THRESHOLD`]; above it, the excess is bent
/// by tanh into the remaining headroom, θ + (1 − θ)·tanh((|x| − θ)/(1 − θ)), which joins with
/// slope 1 (no corner) and stays below 1 (0 dBFS) for any input. NaN becomes 0.
/// Memoryless: no latency, no state. Realtime-safe.
#[inline]
pub fn soft_clip(x: f32) -> f32 {
    const T: f32 = SAFETY_THRESHOLD;
    let a = x.abs();
    if a <= T {
        return x;
    }
    if a.is_nan() {
        return 0.0;
    }
    let y = T + (1.0 - T) * ((a - T) / (1.0 - T)).tanh();
    // tanh rounds to 1.0 for large excess: y is then exactly 1.0, never above.
    y.min(1.0).copysign(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn transparent_below_and_bounded_above() {
        // Every f32 in [−θ, θ] on a fine grid passes bit for bit.
        let mut x = -SAFETY_THRESHOLD;
        while x <= SAFETY_THRESHOLD {
            assert_eq!(soft_clip(x).to_bits(), x.to_bits());
            x += 1.0e-4;
        }
        assert_eq!(soft_clip(SAFETY_THRESHOLD), SAFETY_THRESHOLD);
        for &v in &[0.9f32, 1.0, 1.5, 4.0, 1e6, f32::MAX, f32::INFINITY] {
            let y = soft_clip(v);
            assert!(y <= 1.0 && y > SAFETY_THRESHOLD, "{v} → {y}");
            assert_eq!(soft_clip(-v), -y);
        }
        assert_eq!(soft_clip(f32::NAN), 0.0);
        // Monotone and continuous with slope 1 at the threshold.
        let e = 1e-3;
        let slope = (soft_clip(SAFETY_THRESHOLD + e) - SAFETY_THRESHOLD) / e;
        assert!((slope - 1.0).abs() < 0.02, "{slope}");
        let mut last = 0.0;
        for i in 0..10_000 {
            let y = soft_clip(i as f32 * 1e-3);
            assert!(y >= last);
            last = y;
        }
    }
}
