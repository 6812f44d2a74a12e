//! Struck's presets: materials (damping laws), object banks (modes at strike points), their
//! JSON formats with validation on load, and the factory content.
//!
//! # Conventions
//! - λ = ωₙ² in rad²/s² (undamped angular frequency squared); frequencies in Hz only where a
//!   name says `hz`.
//! - Damping c(λ) in s⁻¹; a mode's amplitude decays as e^(−d t) with d = c/2; T60 = 6.91/d.
//! - Specific modulus γ = E/ρ in m²/s². A bank's λ⁰ were computed for its reference γ₀ and
//!   size; another material and size s give λ = (γ/γ₀) λ⁰ / s² (Ren 2013 eq. 10).
//! - Gains: surface-normal, mass-normalised mode shapes at strike points, scaled by one
//!   factor per bank so that max |gain| = 1. `gains[point][mode]`.
//! - Every JSON file carries `schema_version` ([`SCHEMA_VERSION`]); parsing checks it first,
//!   then the shape, then the values ([`Material::validate`], [`Bank::validate`]).
//!
//! # Sources
//! Materials: Ren, Yeh, Lin 2013 Table I; Sterling 2019 (PhD thesis) Tables 3.1 and 4.1.
//! Banks: analytic beam and plate solutions (Blevins 1979, Leissa 1969); see each bank's
//! `provenance`.

#![warn(missing_docs)]
mod bank;
mod damping;
mod error;
pub mod factory;
mod json;
mod material;
pub mod output;
pub mod residual;
pub mod texture;

pub use bank::{
    Bank, BankReference, DrawSurface, RecordedStrike, StrikePoint, MALLET_NAMES, MAX_BANK_MODES, MAX_BANK_POINTS,
    MAX_DRAW_TRIANGLES,
};
pub use damping::{DampingModel, DampingSpec, AUDIBLE_LAMBDA_MAX, AUDIBLE_LAMBDA_MIN, MAX_EXPONENT};
pub use error::{PresetError, Shown};

/// Largest material, bank or texture file read, bytes (512 MiB): a bank of
/// [`MAX_BANK_MODES`] modes at [`MAX_BANK_POINTS`] points is under 100 MB of JSON.
pub const MAX_PRESET_BYTES: u64 = 512 << 20;

/// The whole of the file at `path` if it holds at most `max` bytes, `None` if more (read no
/// further than `max` + 1 bytes: a device that never ends, `/dev/zero`, or a huge file of
/// another kind is not read into memory).
///
/// # Errors
/// Opening or reading the file failed.
pub fn read_capped(path: &std::path::Path, max: u64) -> std::io::Result<Option<Vec<u8>>> {
    use std::io::Read;
    let mut bytes = Vec::new();
    std::fs::File::open(path)?.take(max.saturating_add(1)).read_to_end(&mut bytes)?;
    Ok((bytes.len() as u64 <= max).then_some(bytes))
}
pub use factory::{
    factory_bank, factory_banks, factory_material, factory_materials, FACTORY_BANK_IDS, FACTORY_MATERIAL_IDS,
};
pub use json::{kebab_id, unknown_fields_note};
pub use material::{Material, RecordedMode, RecordedModes, SupportDamping};

/// Version of the JSON formats this build reads and writes.
pub const SCHEMA_VERSION: u32 = 1;
