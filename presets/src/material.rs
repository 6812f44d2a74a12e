//! Materials: a damping law plus, when known, the specific modulus γ = E/ρ.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::Shown;
use crate::json;
use crate::{DampingSpec, PresetError};

/// A material preset: how modes decay (`damping`) and, when known, how stiff it is for its
/// weight (`specific_modulus`, which moves a bank's pitch by sqrt(γ/γ₀), Ren 2013 eq. 10).
///
/// JSON example (`factory/materials/glass-ren2013.json`):
/// ```json
/// { "schema_version": 1, "id": "glass-ren2013", "name": "Glass (Ren 2013)",
///   "provenance": "Ren, Yeh, Lin 2013, Table I, row Glass ...", "specific_modulus": null,
///   "damping": { "model": "rayleigh", "params": [18.301, 1.4342e-7] }, "notes": "..." }
/// ```
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct Material {
    /// Format version; must equal [`crate::SCHEMA_VERSION`].
    pub schema_version: u32,
    /// Stable kebab-case identifier, e.g. `"glass-ren2013"`.
    pub id: String,
    /// Display name, e.g. `"Glass (Ren 2013)"`.
    pub name: String,
    /// Where the numbers come from (paper, table, row) and any unit conversion done.
    pub provenance: String,
    /// γ = E/ρ in m²/s², when known in SI; `None` when the source gives no usable value.
    pub specific_modulus: Option<f64>,
    /// The damping law c(λ), SI.
    pub damping: DampingSpec,
    /// Free text: caveats, unit reasoning, decay times.
    #[serde(default)]
    pub notes: String,
    /// Support damping recorded with the material (thesis §4.2.8): the extra, per-mode
    /// damping the way the recorded object was held added to the law. `None` for the free
    /// material (factory materials, unless their source states a mounting).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub support: Option<SupportDamping>,
    /// The residual of a captured material (issue 15; Ren 2013 §6.1): what one impact of the
    /// recording held beyond the modes the material represents. Absent for factory
    /// materials and captures made without it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub residual: Option<crate::residual::ResidualSpectrogram>,
}

/// Support damping as recorded: per-mode extra c drawn from an exponential distribution
/// (the exponential part of the thesis's EMG model, eq. 4.10), and, where the recordings
/// were of a known object, each matched mode's own excess (issue 10 part 6).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SupportDamping {
    /// Mean extra c over modes, s⁻¹: for a captured material, the median excess of the
    /// recorded strong partials' c over the fitted law / ln 2
    /// (`estimator::EstimateReport::support_for`).
    pub mean_c_per_s: f64,
    /// The recorded object's modes that strong partials of the recordings matched, each with
    /// its own measured excess: played on that object (*Support: As recorded*), these modes
    /// get their recorded extra damping and the others the draw from the mean. Absent when
    /// the object was not known.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub recorded_modes: Option<RecordedModes>,
}

/// The per-mode support excess of one object's modes as recorded (issue 10 part 6).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RecordedModes {
    /// Id of the object (bank) the recordings were of.
    pub object: String,
    /// The matched modes, in ascending mode index.
    pub modes: Vec<RecordedMode>,
}

/// One object mode's recorded support excess.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RecordedMode {
    /// Index of the mode in the bank.
    pub mode: usize,
    /// The bank's reference eigenvalue λ⁰ of that mode, rad²/s²: checked when the material
    /// is played, so a rebuilt bank whose modes moved does not take another mode's excess.
    pub lambda: f64,
    /// Extra c of the mode over the material's law, s⁻¹ (≥ 0): the median over the partials
    /// that matched it.
    pub extra_c_per_s: f64,
    /// How many recorded partials matched it.
    pub partials: usize,
}

impl RecordedModes {
    /// Each mode's extra c for `lambdas` (the bank of [`Self::object`]), `NaN` where the
    /// material records none: entries whose index is out of range or whose λ⁰ differs from
    /// the bank's by more than 0.1 % are left out. Also returns how many were left out.
    /// Allocates.
    pub fn map_onto(&self, lambdas: &[f64]) -> (Vec<f64>, usize) {
        let mut out = vec![f64::NAN; lambdas.len()];
        let mut skipped = 0;
        for m in &self.modes {
            match lambdas.get(m.mode) {
                Some(&l) if (l / m.lambda - 1.0).abs() <= 1e-3 => out[m.mode] = m.extra_c_per_s,
                _ => skipped += 1,
            }
        }
        (out, skipped)
    }
}

impl Material {
    /// Parses a material from JSON and validates it.
    ///
    /// # Errors
    /// [`PresetError::Json`] for malformed JSON or missing/mistyped fields,
    /// [`PresetError::SchemaVersion`] for another format version, and
    /// [`PresetError::Invalid`] for values [`Material::validate`] rejects.
    pub fn from_json(s: &str) -> Result<Material, PresetError> {
        json::parse_valid(s, "material", &mut Vec::new())
    }

    /// [`Material::from_json`], and the fields the text has that this version does not read (JSON
    /// paths such as `damping.parms`: a misspelt name, or a field of a newer Struck), which
    /// `from_json` ignores ([`crate::unknown_fields_note`] words them for a warning).
    ///
    /// # Errors
    /// As [`Material::from_json`].
    pub fn from_json_listing_unknown(s: &str) -> Result<(Material, Vec<String>), PresetError> {
        let mut unknown = Vec::new();
        json::parse_valid(s, "material", &mut unknown).map(|v| (v, unknown))
    }

    /// Pretty-printed JSON (with a trailing newline). Does not validate.
    pub fn to_json(&self) -> String {
        json::to_pretty(self)
    }

    /// Reads and validates a material file.
    ///
    /// # Errors
    /// [`PresetError::Io`] naming `path` if it cannot be read; otherwise as
    /// [`Material::from_json`], with the path in [`PresetError::Json`]'s `what`.
    pub fn load(path: &Path) -> Result<Material, PresetError> {
        json::load(path, &mut Vec::new())
    }

    /// [`Material::load`], and the fields the file has that this version does not read
    /// ([`Material::from_json_listing_unknown`]).
    ///
    /// # Errors
    /// As [`Material::load`].
    pub fn load_listing_unknown(path: &Path) -> Result<(Material, Vec<String>), PresetError> {
        let mut unknown = Vec::new();
        json::load(path, &mut unknown).map(|v| (v, unknown))
    }

    /// Validates, then writes pretty JSON to `path` (through a temporary file and a rename).
    ///
    /// # Errors
    /// [`PresetError::Invalid`] / [`PresetError::SchemaVersion`] if the material is invalid
    /// (nothing is written), [`PresetError::Output`] naming `path` if writing fails (an
    /// existing file is then untouched).
    pub fn save(&self, path: &Path) -> Result<(), PresetError> {
        json::save(self, path)
    }

    /// Checks every field.
    ///
    /// # Errors
    /// [`PresetError::SchemaVersion`] if `schema_version` is not [`crate::SCHEMA_VERSION`];
    /// [`PresetError::Invalid`] naming the field for: an id that is not kebab-case, a blank
    /// name, a `specific_modulus` that is not finite and > 0, or a damping law that
    /// [`DampingSpec::to_damping`] rejects.
    pub fn validate(&self) -> Result<(), PresetError> {
        json::check_version(self.schema_version)?;
        json::check_id(&self.id)?;
        json::check_name(&self.name)?;
        if let Some(g) = self.specific_modulus {
            if !(g.is_finite() && g > 0.0) {
                return Err(PresetError::invalid(
                    "specific_modulus",
                    format!(
                        "must be finite and > 0 (E/rho in m^2/s^2, e.g. 2.6e7 for steel), or null if unknown; found {}",
                        Shown(g)
                    ),
                ));
            }
        }
        self.damping.to_damping()?;
        if let Some(r) = &self.residual {
            r.validate()?;
        }
        if let Some(sd) = &self.support {
            if !(sd.mean_c_per_s.is_finite() && (0.0..=1e5).contains(&sd.mean_c_per_s)) {
                return Err(PresetError::invalid(
                    "support.mean_c_per_s",
                    format!(
                        "must be finite and in 0..=100000 (1/s, mean extra damping c over modes); found {}",
                        Shown(sd.mean_c_per_s)
                    ),
                ));
            }
            if let Some(r) = &sd.recorded_modes {
                r.validate()?;
            }
        }
        Ok(())
    }

    /// Mean support damping recorded with the material, s⁻¹ (0 for the free material).
    pub fn support_c(&self) -> f64 {
        self.support.as_ref().map_or(0.0, |s| s.mean_c_per_s)
    }

    /// The per-mode support excess recorded with the material, if its object was known.
    pub fn recorded_modes(&self) -> Option<&RecordedModes> {
        self.support.as_ref().and_then(|s| s.recorded_modes.as_ref())
    }

    /// The engine damping law.
    ///
    /// # Errors
    /// As [`DampingSpec::to_damping`].
    pub fn to_damping(&self) -> Result<dsp::Damping, PresetError> {
        self.damping.to_damping()
    }

    /// Reverberation time T60 = ln(1000)/d in s of a mode at `freq_hz` (d = c/2, λ ≈ ω²).
    /// Infinite when c = 0. Returns `None` if the damping law is invalid.
    pub fn t60_s(&self, freq_hz: f64) -> Option<f64> {
        let d = self.damping.to_damping().ok()?;
        let omega = 2.0 * std::f64::consts::PI * freq_hz;
        Some(1000f64.ln() / (0.5 * d.c(omega * omega)))
    }
}

impl RecordedModes {
    /// Checks the object id and every mode.
    ///
    /// # Errors
    /// [`PresetError::Invalid`] naming the field: an object id that is not kebab-case, mode
    /// indices not strictly ascending, a λ⁰ that is not finite and > 0, no partials, an extra
    /// c that is not finite and in 0..=100000 s⁻¹.
    pub fn validate(&self) -> Result<(), PresetError> {
        json::check_id(&self.object).map_err(|e| match e {
            PresetError::Invalid { reason, .. } => PresetError::invalid("support.recorded_modes.object", reason),
            e => e,
        })?;
        let mut last = None;
        for (i, m) in self.modes.iter().enumerate() {
            let field = |f: &str| format!("support.recorded_modes.modes[{i}].{f}");
            if last.is_some_and(|l| m.mode <= l) {
                return Err(PresetError::invalid(
                    field("mode"),
                    format!("mode indices must ascend; found {} after {}", m.mode, last.unwrap_or(0)),
                ));
            }
            last = Some(m.mode);
            if !(m.lambda.is_finite() && m.lambda > 0.0) {
                return Err(PresetError::invalid(
                    field("lambda"),
                    format!("must be finite and > 0 (rad^2/s^2); found {}", Shown(m.lambda)),
                ));
            }
            if m.partials == 0 {
                return Err(PresetError::invalid(
                    field("partials"),
                    "must be at least 1 (the recorded partials matched to the mode)",
                ));
            }
            if !(m.extra_c_per_s.is_finite() && (0.0..=1e5).contains(&m.extra_c_per_s)) {
                return Err(PresetError::invalid(
                    field("extra_c_per_s"),
                    format!("must be finite and in 0..=100000 (1/s); found {}", Shown(m.extra_c_per_s)),
                ));
            }
        }
        Ok(())
    }
}

impl json::PresetFile for Material {
    fn validate(&self) -> Result<(), PresetError> {
        Material::validate(self)
    }
}
