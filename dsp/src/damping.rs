//! Damping models: the viscous damping coefficient c(λ) of a mode, in s⁻¹, as a function of
//! its undamped eigenvalue λ = ωₙ² in rad²/s² (Sterling thesis §2.1.2–2.1.4, §3.2, §4.2.1;
//! SCIENCE.md §2). All models are proportional (generalised proportional damping), so the
//! modes stay real and decoupled.

/// Highest Caughey order supported (number of series terms).
pub const MAX_CAUGHEY_TERMS: usize = 4;

/// The exponents of the power and hybrid laws the plugin plays: its *Exponent* knob's range,
/// which the estimator's fits keep to (a captured material must load into the *Custom*
/// material's knobs).
pub const EXPONENT_RANGE: (f64, f64) = (0.05, 2.0);

/// A damping law c(λ). Every coefficient is in SI units so that c comes out in s⁻¹:
/// λ is in rad²/s², so a term αⱼ λʲ has αⱼ in s⁻¹·(s²)ʲ = s^(2j−1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Damping {
    /// c = α₁ + α₂ λ (α₁ in s⁻¹, α₂ in s). Ren et al. 2013 call them α and β.
    Rayleigh {
        /// Mass-proportional term α₁, s⁻¹.
        alpha1: f64,
        /// Stiffness-proportional term α₂, s.
        alpha2: f64,
    },
    /// c = Σⱼ αⱼ λʲ, j = 0..order (Caughey series; Rayleigh is order 2).
    Caughey {
        /// Coefficients α₀, α₁, … (unused entries are zero).
        coeffs: [f64; MAX_CAUGHEY_TERMS],
        /// Number of terms used, 1..=`MAX_CAUGHEY_TERMS`.
        order: usize,
    },
    /// c = α₁ λ^α₂ (power law, thesis §3.2).
    Power {
        /// Scale α₁, s^(2α₂−1).
        alpha1: f64,
        /// Exponent α₂, usually in (0, 1].
        alpha2: f64,
    },
    /// c = α₁ + α₂ λ^α₃ (hybrid GPD, thesis §4.2.1). α₃ = 1 is Rayleigh, α₁ = 0 power law.
    Hybrid {
        /// Constant term α₁, s⁻¹.
        alpha1: f64,
        /// Scale α₂, s^(2α₃−1).
        alpha2: f64,
        /// Exponent α₃.
        alpha3: f64,
    },
}

impl Damping {
    /// The damping coefficient c(λ) in s⁻¹ for an eigenvalue λ in rad²/s².
    ///
    /// # Realtime safety
    /// Pure arithmetic; no allocation.
    #[inline]
    pub fn c(&self, lambda: f64) -> f64 {
        match *self {
            Damping::Rayleigh { alpha1, alpha2 } => alpha1 + alpha2 * lambda,
            Damping::Caughey { coeffs, order } => {
                // Horner's scheme over λ.
                let n = order.clamp(1, MAX_CAUGHEY_TERMS);
                coeffs[..n].iter().rev().fold(0.0, |acc, &a| acc * lambda + a)
            }
            Damping::Power { alpha1, alpha2 } => alpha1 * lambda.max(0.0).powf(alpha2),
            Damping::Hybrid { alpha1, alpha2, alpha3 } => alpha1 + alpha2 * lambda.max(0.0).powf(alpha3),
        }
    }

    /// The same law with every c multiplied by `k` (a "decay scale" control).
    pub fn scaled(&self, k: f64) -> Damping {
        match *self {
            Damping::Rayleigh { alpha1, alpha2 } => Damping::Rayleigh { alpha1: alpha1 * k, alpha2: alpha2 * k },
            Damping::Caughey { coeffs, order } => Damping::Caughey { coeffs: coeffs.map(|a| a * k), order },
            Damping::Power { alpha1, alpha2 } => Damping::Power { alpha1: alpha1 * k, alpha2 },
            Damping::Hybrid { alpha1, alpha2, alpha3 } => {
                Damping::Hybrid { alpha1: alpha1 * k, alpha2: alpha2 * k, alpha3 }
            }
        }
    }

    /// Which law this is.
    pub fn model(&self) -> DampingModel {
        match self {
            Damping::Rayleigh { .. } => DampingModel::Rayleigh,
            Damping::Caughey { .. } => DampingModel::Caughey,
            Damping::Power { .. } => DampingModel::Power,
            Damping::Hybrid { .. } => DampingModel::Hybrid,
        }
    }

    /// Short lowercase name of the model ("rayleigh", "caughey", "power", "hybrid").
    pub fn model_name(&self) -> &'static str {
        self.model().name()
    }
}

/// Which damping law, without its coefficients: the one list of laws the presets (JSON
/// `"model"`), the estimator (the family it fits) and the engine share. Serialised in
/// lowercase with the `serde` feature.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "lowercase"))]
pub enum DampingModel {
    /// c = α₁ + α₂ λ.
    #[default]
    Rayleigh,
    /// c = Σⱼ αⱼ λʲ (Caughey series).
    Caughey,
    /// c = α₁ λ^α₂ (power law).
    Power,
    /// c = α₁ + α₂ λ^α₃ (hybrid).
    Hybrid,
}

impl DampingModel {
    /// Every law.
    pub const ALL: [DampingModel; 4] =
        [DampingModel::Rayleigh, DampingModel::Caughey, DampingModel::Power, DampingModel::Hybrid];

    /// Lowercase name, as in JSON.
    pub fn name(self) -> &'static str {
        match self {
            DampingModel::Rayleigh => "rayleigh",
            DampingModel::Caughey => "caughey",
            DampingModel::Power => "power",
            DampingModel::Hybrid => "hybrid",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn models_agree_where_they_coincide() {
        let ray = Damping::Rayleigh { alpha1: 3.0, alpha2: 2e-7 };
        let hyb = Damping::Hybrid { alpha1: 3.0, alpha2: 2e-7, alpha3: 1.0 };
        let cau = Damping::Caughey { coeffs: [3.0, 2e-7, 0.0, 0.0], order: 2 };
        for lambda in [0.0, 1e3, 4e7, 1.6e10] {
            let c = ray.c(lambda);
            assert!((hyb.c(lambda) - c).abs() <= 1e-12 * c.abs().max(1.0));
            assert!((cau.c(lambda) - c).abs() <= 1e-12 * c.abs().max(1.0));
        }
        let pow = Damping::Power { alpha1: 2e-3, alpha2: 0.5 };
        // c = α₁ sqrt(λ) = α₁ ω.
        assert!((pow.c(1e6) - 2.0).abs() < 1e-12);
    }

    #[test]
    fn caughey_third_order_uses_all_terms() {
        let d = Damping::Caughey { coeffs: [1.0, 2.0, 3.0, 99.0], order: 3 };
        assert_eq!(d.c(2.0), 1.0 + 4.0 + 12.0);
    }
}
