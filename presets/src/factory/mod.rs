//! Factory content: materials from the seed papers' tables (embedded JSON) and analytic
//! object banks computed at call time.

mod analytic;
mod bar;
pub(crate) mod bessel;
mod circular_plate;
mod materials;
mod rect_plate;

pub use bar::bar_bank;
pub use circular_plate::{circular_plate_bank, free_circular_plate_roots, CircularPlateRoot};
pub use materials::{factory_material, factory_materials, FACTORY_MATERIAL_IDS};
pub use rect_plate::rect_plate_bank;

use std::sync::OnceLock;

use crate::Bank;

pub use analytic::FACTORY_MAX_FREQ_HZ;

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

/// All factory banks: the analytic `"bar"`, `"circular-plate"`, `"rect-plate"`, then the
/// embedded FEM banks ([`FACTORY_FEM_BANKS`]). An embedded bank that fails to parse is left
/// out (a test checks that all of them parse).
///
/// They are computed and parsed once per process and cloned from then on: every plugin
/// instance asks for them when it activates, and building them (Bessel roots, JSON) was
/// about half of an activation (perf, a debug test build).
pub fn factory_banks() -> Vec<Bank> {
    static BANKS: OnceLock<Vec<Bank>> = OnceLock::new();
    BANKS
        .get_or_init(|| {
            let mut banks = vec![bar_bank(), circular_plate_bank(), rect_plate_bank()];
            banks.extend(FACTORY_FEM_BANKS.iter().filter_map(|(_, json)| Bank::from_json(json).ok()));
            banks
        })
        .clone()
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
