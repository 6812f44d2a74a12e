//! The editor's computations, free of egui so they can be unit-tested: T60 curves, strike
//! points, the mode-gain chart and what the parameters currently mean.
//!
//! Units: frequencies in Hz, λ in rad²/s², c and d in s⁻¹ (d = c/2), T60 in s.

use crate::library::Library;
use crate::params::StruckParams;
use dsp::Damping;
use presets::Bank;
use std::f64::consts::TAU;

/// ln(1000): a mode decaying as e^(−d t) falls by 60 dB after ln(1000)/d seconds.
pub const LN_1000: f64 = 6.907_755_278_982_137;
/// Lowest frequency the editor's plots show, Hz.
pub const F_MIN_HZ: f64 = 20.0;
/// Highest frequency the editor's plots show, Hz.
pub const F_MAX_HZ: f64 = 20_000.0;

/// T60 in s of a mode at `freq_hz` under `damping` scaled by `decay_scale` (the plugin's
/// *Decay scale*): d = c(λ)/2 with λ = (2π f)², T60 = ln(1000)/d. Infinite when c ≤ 0.
/// The engine evaluates the same law on the mode's undamped λ (`Engine::predict_modes`).
pub fn t60_s(damping: &Damping, decay_scale: f64, freq_hz: f64) -> f64 {
    let omega = TAU * freq_hz;
    let c = damping.scaled(decay_scale).c(omega * omega);
    if c > 0.0 && c.is_finite() {
        LN_1000 / (0.5 * c)
    } else {
        f64::INFINITY
    }
}

/// `n` points `(freq_hz, T60 s)` log-spaced from `f_lo` to `f_hi` (both included).
pub fn t60_curve(damping: &Damping, decay_scale: f64, f_lo: f64, f_hi: f64, n: usize) -> Vec<(f64, f64)> {
    let n = n.max(2);
    let (a, b) = (f_lo.ln(), f_hi.ln());
    (0..n)
        .map(|i| {
            let f = (a + (b - a) * i as f64 / (n - 1) as f64).exp();
            (f, t60_s(damping, decay_scale, f))
        })
        .collect()
}

/// The damping law the audio plays now: the selected factory material's, or the *Custom*
/// knobs' (mirrors `Struck::sound_params`).
pub fn current_damping(params: &StruckParams, library: &Library) -> Damping {
    let material = params.material.value().max(0) as usize;
    library.dampings.get(material).copied().unwrap_or_else(|| params.custom_damping())
}

/// Index of the selected object, clamped to the library (`None` for an empty library).
pub fn object_index(params: &StruckParams, library: &Library) -> Option<usize> {
    let n = library.banks.len();
    (n > 0).then(|| (params.object.value().max(0) as usize).min(n - 1))
}

/// Index of the strike point nearest to `p` (drawing coordinates, [0, 1]²).
pub fn nearest_point(points: &[[f32; 2]], p: [f32; 2]) -> Option<usize> {
    points
        .iter()
        .enumerate()
        .map(|(i, q)| (i, (q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2)))
        .filter(|(_, d)| d.is_finite())
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(i, _)| i)
}

/// Strike position (0..=1 along the path) of point `index` of `n`: index/(n−1).
pub fn position_of_point(index: usize, n: usize) -> f32 {
    if n > 1 {
        index.min(n - 1) as f32 / (n - 1) as f32
    } else {
        0.0
    }
}

/// Drawing coordinates of strike position `position` (linear between neighbouring points,
/// as `Bank::gains_at` interpolates the gains).
pub fn point_at_position(points: &[[f32; 2]], position: f32) -> Option<[f32; 2]> {
    let n = points.len();
    if n == 0 {
        return None;
    }
    let t = if position.is_finite() { position.clamp(0.0, 1.0) } else { 0.0 } * (n - 1) as f32;
    let i = (t.floor() as usize).min(n.saturating_sub(2));
    let frac = if n == 1 { 0.0 } else { t - i as f32 };
    let (a, b) = (points[i], points[(i + 1).min(n - 1)]);
    Some([a[0] + (b[0] - a[0]) * frac, a[1] + (b[1] - a[1]) * frac])
}

pub use crate::library::user_material_dir;
pub use crate::params::key_lambda_factor;

/// Total λ scale of a note of `key` on the selected object: (γ/γ₀)·(material's γ when
/// *Material sets pitch*)·key factor / size² (SCIENCE.md §1, Ren 2013 eq. 10).
pub fn lambda_scale(params: &StruckParams, library: &Library, key: u8) -> f64 {
    let object = object_index(params, library);
    let bank = object.and_then(|i| library.banks.get(i));
    let mut modulus = f64::from(params.modulus_ratio.value());
    if params.material_pitch.value() {
        modulus *= library.material_modulus_ratio(params.material.value().max(0) as usize, object.unwrap_or(0));
    }
    let size = f64::from(params.size.value());
    modulus * key_lambda_factor(params, bank, key) / (size * size)
}

/// One bar of the mode chart.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ModeBar {
    /// Undamped frequency sqrt(λ)/(2π), Hz.
    pub freq_hz: f64,
    /// Mode-shape gain at the strike position (signed; the chart shows |gain|).
    pub gain: f32,
}

/// The modes of `bank` at strike `position` with every λ scaled by `lambda_scale`: what the
/// object view's bar chart shows (the mode shapes, before the mallet's spectrum and the
/// quality threshold; for a bank captured from a recording, the recorded amplitudes with the
/// recording's strike divided out, as the engine plays them:
/// [`crate::library::recorded_strike_factors`]).
pub fn mode_bars(bank: &Bank, position: f32, lambda_scale: f64) -> Vec<ModeBar> {
    let mut gains = vec![0.0f32; bank.num_modes()];
    bank.gains_at(position, &mut gains);
    if let Some(k) = crate::library::recorded_strike_factors(bank) {
        gains.iter_mut().zip(k).for_each(|(g, k)| *g = (f64::from(*g) * k) as f32);
    }
    bank.lambdas
        .iter()
        .zip(gains)
        .map(|(&l, gain)| ModeBar { freq_hz: (l * lambda_scale).max(0.0).sqrt() / TAU, gain })
        .collect()
}

/// A `Material::id`-safe kebab-case id from free text (at most 64 characters).
pub fn kebab_id(prefix: &str, text: &str) -> String {
    presets::kebab_id(prefix, text)
}

#[cfg(test)]
// PANIC: in these tests each `expect` is an assertion.
mod tests {
    use super::*;
    use crate::params::DampingModelParam;
    use crate::Struck;
    use nice_plug::prelude::Param;

    #[test]
    fn t60_matches_the_rayleigh_formula() {
        let d = Damping::Rayleigh { alpha1: 10.0, alpha2: 1e-7 };
        for f in [50.0, 440.0, 1000.0, 8000.0] {
            let l = (TAU * f) * (TAU * f);
            let want = LN_1000 / (0.5 * (10.0 + 1e-7 * l));
            let got = t60_s(&d, 1.0, f);
            assert!((got / want - 1.0).abs() < 1e-12, "{f} Hz: {got} vs {want}");
            // Decay scale 2 damps twice as fast: half the T60.
            assert!((t60_s(&d, 2.0, f) / (want / 2.0) - 1.0).abs() < 1e-12);
        }
        assert!(t60_s(&Damping::Rayleigh { alpha1: 0.0, alpha2: 0.0 }, 1.0, 100.0).is_infinite());
    }

    #[test]
    fn t60_curve_spans_the_range_log_spaced_and_falls_for_rayleigh() {
        let d = Damping::Rayleigh { alpha1: 5.0, alpha2: 4e-8 };
        let c = t60_curve(&d, 1.0, F_MIN_HZ, F_MAX_HZ, 61);
        assert_eq!(c.len(), 61);
        assert!((c[0].0 - 20.0).abs() < 1e-9 && (c[60].0 - 20_000.0).abs() < 1e-6);
        // Log spacing: constant ratio between neighbours.
        let r = c[1].0 / c[0].0;
        assert!(c.windows(2).all(|w| (w[1].0 / w[0].0 / r - 1.0).abs() < 1e-9));
        assert!(c.windows(2).all(|w| w[1].1 <= w[0].1));
    }

    #[test]
    fn t60_curve_follows_the_custom_knobs_like_the_audio() {
        let plugin = Struck::default();
        let p = plugin.struck_params();
        let lib = plugin.library();
        // The default material is a factory one: the curve is that material's law.
        assert_eq!(current_damping(p, lib), plugin.sound_params().damping);
        let d = current_damping(p, lib);
        let f = 1000.0;
        let want = LN_1000 / (0.5 * d.c((TAU * f).powi(2)));
        assert!((t60_s(&d, 1.0, f) / want - 1.0).abs() < 1e-12);
    }

    #[test]
    fn the_nearest_point_of_a_click() {
        let pts = [[0.1, 0.5], [0.3, 0.5], [0.5, 0.5], [0.9, 0.9]];
        assert_eq!(nearest_point(&pts, [0.0, 0.0]), Some(0));
        assert_eq!(nearest_point(&pts, [0.32, 0.4]), Some(1));
        assert_eq!(nearest_point(&pts, [0.41, 0.5]), Some(2));
        assert_eq!(nearest_point(&pts, [1.0, 1.0]), Some(3));
        assert_eq!(nearest_point(&[], [0.5, 0.5]), None);
        assert_eq!(position_of_point(0, 4), 0.0);
        assert_eq!(position_of_point(3, 4), 1.0);
        assert!((position_of_point(1, 4) - 1.0 / 3.0).abs() < 1e-7);
        assert_eq!(position_of_point(0, 1), 0.0);
        // The highlighted marker sits on the point a position names, and halfway between two.
        assert_eq!(point_at_position(&pts, position_of_point(2, 4)), Some([0.5, 0.5]));
        let mid = point_at_position(&pts, 0.5 / 3.0).expect("points");
        assert!((mid[0] - 0.2).abs() < 1e-6 && (mid[1] - 0.5).abs() < 1e-6);
    }

    #[test]
    fn clicking_each_factory_point_selects_it() {
        let lib = Library::factory();
        for b in &lib.banks {
            let pts: Vec<[f32; 2]> = b.points.iter().map(|p| p.xy).collect();
            for (i, p) in pts.iter().enumerate() {
                let hit = nearest_point(&pts, *p).expect("points");
                // Duplicate drawing positions are allowed; the hit must be at the same place.
                assert_eq!(pts[hit], *p, "{}: point {i}", b.id);
            }
        }
    }

    #[test]
    fn key_law_matches_the_plugin() {
        let plugin = Struck::default();
        let p = plugin.struck_params();
        let lib = plugin.library();
        let bank = object_index(p, lib).map(|i| &lib.banks[i]);
        for key in [36u8, 60, 61, 84] {
            let want = plugin.strike_for(key, 0.5).lambda_factor;
            let got = key_lambda_factor(p, bank, key);
            assert!((got / want - 1.0).abs() < 1e-12, "key {key}: {got} vs {want}");
        }
    }

    #[test]
    fn mode_bars_scale_frequencies_by_sqrt_lambda_scale() {
        let lib = Library::factory();
        let bank = &lib.banks[0];
        let a = mode_bars(bank, 0.3, 1.0);
        let b = mode_bars(bank, 0.3, 4.0);
        assert_eq!(a.len(), bank.num_modes());
        for (x, y) in a.iter().zip(&b) {
            assert!((y.freq_hz / x.freq_hz - 2.0).abs() < 1e-9);
            assert_eq!(x.gain, y.gain);
        }
        let mut g = vec![0.0; bank.num_modes()];
        bank.gains_at(0.3, &mut g);
        assert!(a.iter().zip(&g).all(|(m, g)| m.gain == *g));
    }

    #[test]
    fn knob_mapping_round_trips_every_model() {
        let p = StruckParams::new(&Library::factory());
        let laws = [
            Damping::Rayleigh { alpha1: 18.301, alpha2: 1.4342e-7 },
            Damping::Hybrid { alpha1: 3.0, alpha2: 2e-4, alpha3: 0.6 },
            Damping::Power { alpha1: 5e-3, alpha2: 0.45 },
            Damping::Caughey { coeffs: [2.0, 1e-7, 1e-20, 0.0], order: 3 },
        ];
        for d in laws {
            let k = p.custom_knobs_for(&d).expect("in range");
            // Set the knobs as the editor does (plain values), then read the law back.
            let set = |param: &nice_plug::prelude::FloatParam, v: f32| {
                // SAFETY: the pointer targets `p`, alive here; this is the host's own setter.
                unsafe { param.as_ptr()._internal_set_normalized_value(param.preview_normalized(v)) };
            };
            // SAFETY: as above.
            unsafe {
                p.damping_model.as_ptr()._internal_set_normalized_value(p.damping_model.preview_normalized(k.model))
            };
            set(&p.alpha1_per_s, k.alpha1_per_s);
            set(&p.damping_1k_per_s, k.damping_1k_per_s);
            set(&p.exponent, k.exponent);
            set(&p.caughey_10k_per_s, k.caughey_10k_per_s);
            let back = p.custom_damping();
            for f in [100.0, 1000.0, 5000.0] {
                let l = (TAU * f) * (TAU * f);
                assert!((back.c(l) / d.c(l) - 1.0).abs() < 1e-3, "{d:?} → {k:?} → {back:?} at {f} Hz");
            }
            assert_eq!(p.damping_model.value(), k.model);
        }
        assert_eq!(
            p.custom_knobs_for(&Damping::Rayleigh { alpha1: 1e6, alpha2: 0.0 }).map(|k| k.model),
            Err("base damping α₁ (1/s) = 1000000 is outside the plugin's range 0..=2000".into())
        );
        let _ = DampingModelParam::Rayleigh;
    }

    #[test]
    fn ids_are_kebab_case() {
        assert_eq!(kebab_id("captured", "My Glass  Bowl!"), "captured-my-glass-bowl");
        assert_eq!(kebab_id("captured", "!!"), "captured");
    }
}
