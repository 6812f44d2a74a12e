//! Factory content: materials from the seed papers' tables (embedded JSON) and analytic
//! object banks computed at call time.

mod bar;
pub(crate) mod bessel;
mod circular_plate;
mod materials;
mod rect_plate;

pub use bar::bar_bank;
pub use circular_plate::{circular_plate_bank, free_circular_plate_roots, CircularPlateRoot};
pub use materials::{factory_material, factory_materials, FACTORY_MATERIAL_IDS};
pub use rect_plate::rect_plate_bank;

use crate::{Bank, BankReference, DrawSurface, StrikePoint, SCHEMA_VERSION};

/// Factory banks keep every mode whose frequency at the reference is at or below this, Hz.
pub const FACTORY_MAX_FREQ_HZ: f64 = 20_000.0;

/// Ids of the analytic factory banks, first in the order of [`factory_banks`].
pub const FACTORY_BANK_IDS: [&str; 3] = ["bar", "circular-plate", "rect-plate"];

/// The factory FEM banks, built by `cargo xtask banks` (the FEM bank builder, crate `struck-fem`)
/// and embedded as JSON: id and text, in the order [`factory_banks`] lists them.
pub const FACTORY_FEM_BANKS: &[(&str, &str)] = &[
    ("fem-bar", include_str!("../../factory/banks/fem-bar.json")),
    ("fem-plate", include_str!("../../factory/banks/fem-plate.json")),
    ("fem-circular-plate", include_str!("../../factory/banks/fem-circular-plate.json")),
    ("fem-tube", include_str!("../../factory/banks/fem-tube.json")),
    ("fem-bowl", include_str!("../../factory/banks/fem-bowl.json")),
    ("fem-cup", include_str!("../../factory/banks/fem-cup.json")),
    ("fem-bell", include_str!("../../factory/banks/fem-bell.json")),
    ("fem-block", include_str!("../../factory/banks/fem-block.json")),
    ("fem-sphere-shell", include_str!("../../factory/banks/fem-sphere-shell.json")),
    // Tuned bars (issue 11 part 4), built by `struck bank tune` (see `cargo xtask banks`).
    ("fem-marimba-bar", include_str!("../../factory/banks/fem-marimba-bar.json")),
    ("fem-xylophone-bar", include_str!("../../factory/banks/fem-xylophone-bar.json")),
    ("fem-vibraphone-bar", include_str!("../../factory/banks/fem-vibraphone-bar.json")),
    // A glockenspiel bar and a tubular chime fitted to real instruments' partials.
    ("fem-glockenspiel-bar", include_str!("../../factory/banks/fem-glockenspiel-bar.json")),
    ("fem-tubular-chime", include_str!("../../factory/banks/fem-tubular-chime.json")),
];

/// All factory banks: the analytic `"bar"`, `"circular-plate"`, `"rect-plate"` (computed now,
/// a few milliseconds each in a release build), then the embedded FEM banks
/// ([`FACTORY_FEM_BANKS`]). An embedded bank that fails to parse is left out (a test checks
/// that all of them parse).
pub fn factory_banks() -> Vec<Bank> {
    let mut banks = vec![bar_bank(), circular_plate_bank(), rect_plate_bank()];
    banks.extend(FACTORY_FEM_BANKS.iter().filter_map(|(_, json)| Bank::from_json(json).ok()));
    banks
}

/// The factory bank with this id (analytic banks computed now), or `None` for an unknown id.
pub fn factory_bank(id: &str) -> Option<Bank> {
    match id {
        "bar" => Some(bar_bank()),
        "circular-plate" => Some(circular_plate_bank()),
        "rect-plate" => Some(rect_plate_bank()),
        _ => FACTORY_FEM_BANKS.iter().find(|(i, _)| *i == id).and_then(|(_, json)| Bank::from_json(json).ok()),
    }
}

/// One analytic mode before sorting: eigenvalue, label, and (unnormalised, but mass-
/// normalised in SI) surface-normal shape value at each strike point.
pub(crate) struct Mode {
    pub lambda: f64,
    pub label: String,
    pub shape: Vec<f64>,
}

/// Metadata of a factory bank.
pub(crate) struct BankInfo {
    pub id: &'static str,
    pub name: &'static str,
    pub description: String,
    pub provenance: String,
    pub reference: BankReference,
    /// The object's drawing, in the frame of the strike points' `position_m`.
    pub surface: DrawSurface,
}

/// Sorts modes by λ, drops those above [`FACTORY_MAX_FREQ_HZ`], transposes to
/// `gains[point][mode]` and scales all gains by one factor so that max |gain| = 1.
pub(crate) fn assemble(info: BankInfo, points: Vec<StrikePoint>, mut modes: Vec<Mode>) -> Bank {
    let lambda_max = (2.0 * std::f64::consts::PI * FACTORY_MAX_FREQ_HZ).powi(2);
    modes.retain(|m| m.lambda > 0.0 && m.lambda <= lambda_max);
    modes.sort_by(|a, b| a.lambda.total_cmp(&b.lambda));
    let max = modes.iter().flat_map(|m| m.shape.iter()).fold(0.0f64, |acc, g| acc.max(g.abs()));
    let scale = if max > 0.0 { 1.0 / max } else { 1.0 };
    let gains = (0..points.len()).map(|p| modes.iter().map(|m| (m.shape[p] * scale) as f32).collect()).collect();
    Bank {
        schema_version: SCHEMA_VERSION,
        id: info.id.to_string(),
        name: info.name.to_string(),
        description: info.description,
        provenance: info.provenance,
        reference: info.reference,
        lambdas: modes.iter().map(|m| m.lambda).collect(),
        points,
        gains,
        mode_labels: modes.into_iter().map(|m| m.label).collect(),
        surface: Some(info.surface),
    }
}

/// Composite Simpson rule of `f` over [a, b] with `n` (even) intervals.
pub(crate) fn simpson(a: f64, b: f64, n: usize, mut f: impl FnMut(f64) -> f64) -> f64 {
    let n = n + n % 2;
    let h = (b - a) / n as f64;
    let mut sum = f(a) + f(b);
    for k in 1..n {
        let w = if k % 2 == 1 { 4.0 } else { 2.0 };
        sum += w * f(a + h * k as f64);
    }
    sum * h / 3.0
}
