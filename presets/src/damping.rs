//! The JSON form of a damping law ([`DampingSpec`]) and its validation.
//!
//! Conventions (SCIENCE.md §2, Sterling thesis §2.1.2–2.1.4, §3.2, §4.2.1): λ = ωₙ² in rad²/s²,
//! c(λ) in s⁻¹, modal decay rate d = c/2 in s⁻¹, T60 = ln(1000)/d ≈ 6.91/d in s.

use serde::{Deserialize, Serialize};

use dsp::damping::MAX_CAUGHEY_TERMS;
use dsp::Damping;

use crate::error::Shown;
use crate::PresetError;

/// Lowest eigenvalue checked for c(λ) ≥ 0: (2π · 20 Hz)² rad²/s².
pub const AUDIBLE_LAMBDA_MIN: f64 = (TWO_PI * 20.0) * (TWO_PI * 20.0);
/// Highest eigenvalue checked for c(λ) ≥ 0: (2π · 24 kHz)² rad²/s².
pub const AUDIBLE_LAMBDA_MAX: f64 = (TWO_PI * 24_000.0) * (TWO_PI * 24_000.0);
/// Largest accepted power-law / hybrid exponent (c ∝ λ² already means T60 ∝ f⁻⁴).
pub const MAX_EXPONENT: f64 = 2.0;

const TWO_PI: f64 = 2.0 * std::f64::consts::PI;

/// Which damping law a [`DampingSpec`] uses (the engine's list, serialised in lowercase):
/// `rayleigh` params `[α1 (s⁻¹), α2 (s)]` (Ren 2013's α, β); `caughey` `[α0, α1, …]`, 1 to 4
/// terms, αⱼ in s^(2j−1); `power` `[α1, α2]`, α₂ in (0, 2] (thesis eq. 3.4); `hybrid`
/// `[α1, α2, α3]`, α₃ in (0, 2] (thesis eq. 4.1).
pub use dsp::DampingModel;

/// A damping law as stored in JSON: `{"model": "rayleigh", "params": [alpha1, alpha2]}`.
///
/// All params are SI, so that c(λ) comes out in s⁻¹ with λ in rad²/s²:
/// - `rayleigh` `[α1 (s⁻¹), α2 (s)]`: c = α1 + α2 λ
/// - `caughey` `[α0, α1, …]` (1..=4 terms): c = Σ αj λ^j
/// - `power` `[α1, α2]`: c = α1 λ^α2
/// - `hybrid` `[α1, α2, α3]`: c = α1 + α2 λ^α3
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct DampingSpec {
    /// The law.
    pub model: DampingModel,
    /// Its coefficients, SI, in the order given for [`DampingModel`].
    pub params: Vec<f64>,
}

impl DampingSpec {
    /// Rayleigh damping c = α1 + α2 λ (α1 in s⁻¹, α2 in s).
    pub fn rayleigh(alpha1: f64, alpha2: f64) -> Self {
        DampingSpec { model: DampingModel::Rayleigh, params: vec![alpha1, alpha2] }
    }

    /// Checks the spec and converts it to the engine's [`dsp::Damping`].
    ///
    /// # Errors
    /// [`PresetError::Invalid`] naming `damping.params` or `damping.params[i]` when:
    /// the number of params is wrong for the model; a param is NaN or infinite; a Rayleigh,
    /// power or hybrid coefficient is negative; an exponent is outside (0, 2]; or c(λ) is
    /// negative or not finite anywhere in the audible range
    /// [`AUDIBLE_LAMBDA_MIN`]..=[`AUDIBLE_LAMBDA_MAX`] (20 Hz to 24 kHz).
    pub fn to_damping(&self) -> Result<Damping, PresetError> {
        let p = &self.params;
        let name = self.model.name();
        let count = |expected: &str| {
            PresetError::invalid(
                "damping.params",
                format!("the {name} model takes {expected} params, found {}", p.len()),
            )
        };
        for (i, &a) in p.iter().enumerate() {
            if !a.is_finite() {
                return Err(PresetError::invalid(
                    format!("damping.params[{i}]"),
                    format!("must be a finite number, found {}", Shown(a)),
                ));
            }
        }
        let non_negative = |i: usize, what: &str| -> Result<(), PresetError> {
            if p[i] < 0.0 {
                Err(PresetError::invalid(
                    format!("damping.params[{i}]"),
                    format!(
                        "{what} of the {name} model must be >= 0 (negative damping makes modes grow), found {}",
                        Shown(p[i])
                    ),
                ))
            } else {
                Ok(())
            }
        };
        let exponent = |i: usize| -> Result<(), PresetError> {
            if p[i] > 0.0 && p[i] <= MAX_EXPONENT {
                Ok(())
            } else {
                Err(PresetError::invalid(
                    format!("damping.params[{i}]"),
                    format!("the {name} exponent must be in (0, {MAX_EXPONENT}], found {}", Shown(p[i])),
                ))
            }
        };
        let damping = match self.model {
            DampingModel::Rayleigh => {
                if p.len() != 2 {
                    return Err(count("2 ([alpha1 (1/s), alpha2 (s)])"));
                }
                non_negative(0, "alpha1")?;
                non_negative(1, "alpha2")?;
                Damping::Rayleigh { alpha1: p[0], alpha2: p[1] }
            }
            DampingModel::Caughey => {
                if p.is_empty() || p.len() > MAX_CAUGHEY_TERMS {
                    return Err(count(&format!("1 to {MAX_CAUGHEY_TERMS} ([alpha0, alpha1, ...])")));
                }
                let mut coeffs = [0.0; MAX_CAUGHEY_TERMS];
                coeffs[..p.len()].copy_from_slice(p);
                Damping::Caughey { coeffs, order: p.len() }
            }
            DampingModel::Power => {
                if p.len() != 2 {
                    return Err(count("2 ([alpha1, alpha2])"));
                }
                non_negative(0, "alpha1")?;
                exponent(1)?;
                Damping::Power { alpha1: p[0], alpha2: p[1] }
            }
            DampingModel::Hybrid => {
                if p.len() != 3 {
                    return Err(count("3 ([alpha1, alpha2, alpha3])"));
                }
                non_negative(0, "alpha1")?;
                non_negative(1, "alpha2")?;
                exponent(2)?;
                Damping::Hybrid { alpha1: p[0], alpha2: p[1], alpha3: p[2] }
            }
        };
        check_audible_range(&damping)?;
        Ok(damping)
    }

    /// The spec of an engine damping law (inverse of [`DampingSpec::to_damping`]).
    pub fn from_damping(d: &Damping) -> Self {
        match *d {
            Damping::Rayleigh { alpha1, alpha2 } => {
                DampingSpec { model: DampingModel::Rayleigh, params: vec![alpha1, alpha2] }
            }
            Damping::Caughey { coeffs, order } => DampingSpec {
                model: DampingModel::Caughey,
                params: coeffs[..order.clamp(1, MAX_CAUGHEY_TERMS)].to_vec(),
            },
            Damping::Power { alpha1, alpha2 } => {
                DampingSpec { model: DampingModel::Power, params: vec![alpha1, alpha2] }
            }
            Damping::Hybrid { alpha1, alpha2, alpha3 } => {
                DampingSpec { model: DampingModel::Hybrid, params: vec![alpha1, alpha2, alpha3] }
            }
        }
    }
}

/// Checks c(λ) ≥ 0 and finite over the audible range.
///
/// Rayleigh, power and hybrid laws with non-negative coefficients are monotone, so their
/// ends suffice; a Caughey polynomial can dip in between, so it is also evaluated at its
/// stationary points (exact for up to 4 terms, whose derivative is at most quadratic) and on
/// a log-spaced grid as a guard.
fn check_audible_range(d: &Damping) -> Result<(), PresetError> {
    let mut lambdas = vec![AUDIBLE_LAMBDA_MIN, AUDIBLE_LAMBDA_MAX];
    if let Damping::Caughey { coeffs, order } = *d {
        const GRID: usize = 256;
        let ratio = AUDIBLE_LAMBDA_MAX / AUDIBLE_LAMBDA_MIN;
        lambdas.extend((1..GRID).map(|i| AUDIBLE_LAMBDA_MIN * ratio.powf(i as f64 / GRID as f64)));
        // c'(λ) = a1 + 2 a2 λ + 3 a3 λ² (terms beyond `order` are zero).
        let (a, b, c) = (
            if order > 3 { 3.0 * coeffs[3] } else { 0.0 },
            if order > 2 { 2.0 * coeffs[2] } else { 0.0 },
            if order > 1 { coeffs[1] } else { 0.0 },
        );
        lambdas.extend(quadratic_roots(a, b, c).into_iter().flatten());
    }
    for lambda in lambdas {
        if !(AUDIBLE_LAMBDA_MIN..=AUDIBLE_LAMBDA_MAX).contains(&lambda) {
            continue;
        }
        let c = d.c(lambda);
        // Allow round-off relative to the size of the individual terms.
        let scale = d_abs_terms(d, lambda);
        if !c.is_finite() || c < -1e-12 * scale {
            let f_hz = lambda.sqrt() / TWO_PI;
            return Err(PresetError::invalid(
                "damping.params",
                format!(
                    "c(lambda) = {c:.4e} 1/s at {f_hz:.1} Hz (lambda = {lambda:.4e} rad^2/s^2); damping must be finite and >= 0 from 20 Hz to 24 kHz"
                ),
            ));
        }
    }
    Ok(())
}

/// Σ |term| of c(λ), the scale of its round-off.
fn d_abs_terms(d: &Damping, lambda: f64) -> f64 {
    match *d {
        Damping::Caughey { coeffs, order } => coeffs[..order.clamp(1, MAX_CAUGHEY_TERMS)]
            .iter()
            .enumerate()
            .map(|(j, a)| (a * lambda.powi(j as i32)).abs())
            .sum(),
        _ => d.c(lambda).abs(),
    }
}

/// Real roots of a x² + b x + c = 0 (also handles a = 0).
fn quadratic_roots(a: f64, b: f64, c: f64) -> [Option<f64>; 2] {
    if a == 0.0 {
        return [if b != 0.0 { Some(-c / b) } else { None }, None];
    }
    let disc = b * b - 4.0 * a * c;
    if disc < 0.0 {
        return [None, None];
    }
    // Numerically stable form (no cancellation between -b and sqrt(disc)).
    let q = -0.5 * (b + b.signum() * disc.sqrt());
    let r1 = q / a;
    let r2 = if q != 0.0 { c / q } else { r1 };
    [Some(r1), Some(r2)]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(model: DampingModel, params: &[f64]) -> DampingSpec {
        DampingSpec { model, params: params.to_vec() }
    }

    fn invalid_field(r: Result<Damping, PresetError>) -> String {
        match r {
            Err(PresetError::Invalid { field, .. }) => field,
            other => panic!("expected Invalid, got {other:?}"),
        }
    }

    /// A huge number in a message is shown in scientific notation, not with its 308 digits;
    /// an everyday one as written.
    #[test]
    fn messages_show_huge_numbers_briefly() {
        let e = spec(DampingModel::Rayleigh, &[-1e308, 0.0]).to_damping().unwrap_err().to_string();
        assert!(e.contains("found -1e308") && e.len() < 200, "{e}");
        let e = spec(DampingModel::Rayleigh, &[-2.5, 0.0]).to_damping().unwrap_err().to_string();
        assert!(e.contains("found -2.5"), "{e}");
        assert_eq!(Shown(1.5e-7).to_string(), "1.5e-7");
        assert_eq!(Shown(0.0).to_string(), "0");
    }

    #[test]
    fn round_trips_every_model_through_dsp() {
        for s in [
            spec(DampingModel::Rayleigh, &[2.0, 1e-7]),
            spec(DampingModel::Caughey, &[280.0, -3.6e-7, 2.0e-15]),
            spec(DampingModel::Caughey, &[5.0]),
            spec(DampingModel::Power, &[1.13, 0.3]),
            spec(DampingModel::Hybrid, &[3.9, 5.2e-9, 1.027]),
        ] {
            let d = s.to_damping().unwrap();
            assert_eq!(DampingSpec::from_damping(&d), s);
            assert_eq!(d.model_name(), s.model.name());
        }
    }

    #[test]
    fn rejects_bad_params_naming_the_field() {
        assert_eq!(invalid_field(spec(DampingModel::Rayleigh, &[1.0]).to_damping()), "damping.params");
        assert_eq!(invalid_field(spec(DampingModel::Hybrid, &[1.0, 1e-7]).to_damping()), "damping.params");
        assert_eq!(invalid_field(spec(DampingModel::Caughey, &[]).to_damping()), "damping.params");
        assert_eq!(invalid_field(spec(DampingModel::Caughey, &[1.0; 5]).to_damping()), "damping.params");
        assert_eq!(invalid_field(spec(DampingModel::Rayleigh, &[f64::NAN, 1e-7]).to_damping()), "damping.params[0]");
        assert_eq!(
            invalid_field(spec(DampingModel::Rayleigh, &[1.0, f64::INFINITY]).to_damping()),
            "damping.params[1]"
        );
        assert_eq!(invalid_field(spec(DampingModel::Rayleigh, &[-1.0, 1e-7]).to_damping()), "damping.params[0]");
        assert_eq!(invalid_field(spec(DampingModel::Power, &[1.0, 0.0]).to_damping()), "damping.params[1]");
        assert_eq!(invalid_field(spec(DampingModel::Power, &[1.0, 2.5]).to_damping()), "damping.params[1]");
        assert_eq!(invalid_field(spec(DampingModel::Hybrid, &[1.0, 1e-7, -0.5]).to_damping()), "damping.params[2]");
    }

    #[test]
    fn rejects_caughey_that_dips_negative_between_the_ends() {
        // c = 100 − 2.2e-7 λ + 1e-16 λ²: positive at both ends of the audible range, but its
        // minimum at λ = 1.1e9 (≈ 5.3 kHz) is 100 − 242 + 121 = −21 s⁻¹. With −1.8e-7 the
        // minimum (at λ = 9e8) is +19 s⁻¹ and the law is accepted.
        let s = spec(DampingModel::Caughey, &[100.0, -2.2e-7, 1e-16]);
        let d = s.to_damping();
        assert_eq!(invalid_field(d), "damping.params");
        assert!(spec(DampingModel::Caughey, &[100.0, -1.8e-7, 1e-16]).to_damping().is_ok());
    }

    #[test]
    fn rejects_overflowing_damping() {
        let s = spec(DampingModel::Caughey, &[0.0, 0.0, 0.0, 1e290]);
        assert_eq!(invalid_field(s.to_damping()), "damping.params");
    }
}
