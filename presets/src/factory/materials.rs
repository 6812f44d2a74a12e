//! Factory materials: JSON files in `presets/factory/materials/`, embedded at compile time.
//!
//! Order (stable): Ren 2013 Table I (wood, plastic, metal, glass, porcelain); Sterling thesis
//! Table 4.1, Rayleigh then hybrid for each of porcelain, travertine, wood, steel, plastic,
//! glass; Sterling thesis Table 3.1, Rayleigh, Caughey and power law for each of plastic bowl,
//! plastic scoop, porcelain, wood, aluminum. All parameters are SI (see each file's
//! `provenance` and `notes` for the unit reasoning).

use crate::Material;

/// Embedded factory material files, in [`factory_materials`] order.
const FILES: &[(&str, &str)] = &[
    ("wood-ren2013", include_str!("../../factory/materials/wood-ren2013.json")),
    ("plastic-ren2013", include_str!("../../factory/materials/plastic-ren2013.json")),
    ("metal-ren2013", include_str!("../../factory/materials/metal-ren2013.json")),
    ("glass-ren2013", include_str!("../../factory/materials/glass-ren2013.json")),
    ("porcelain-ren2013", include_str!("../../factory/materials/porcelain-ren2013.json")),
    ("porcelain-sterling-rayleigh", include_str!("../../factory/materials/porcelain-sterling-rayleigh.json")),
    ("porcelain-sterling-hybrid", include_str!("../../factory/materials/porcelain-sterling-hybrid.json")),
    ("travertine-sterling-rayleigh", include_str!("../../factory/materials/travertine-sterling-rayleigh.json")),
    ("travertine-sterling-hybrid", include_str!("../../factory/materials/travertine-sterling-hybrid.json")),
    ("wood-sterling-rayleigh", include_str!("../../factory/materials/wood-sterling-rayleigh.json")),
    ("wood-sterling-hybrid", include_str!("../../factory/materials/wood-sterling-hybrid.json")),
    ("steel-sterling-rayleigh", include_str!("../../factory/materials/steel-sterling-rayleigh.json")),
    ("steel-sterling-hybrid", include_str!("../../factory/materials/steel-sterling-hybrid.json")),
    ("plastic-sterling-rayleigh", include_str!("../../factory/materials/plastic-sterling-rayleigh.json")),
    ("plastic-sterling-hybrid", include_str!("../../factory/materials/plastic-sterling-hybrid.json")),
    ("glass-sterling-rayleigh", include_str!("../../factory/materials/glass-sterling-rayleigh.json")),
    ("glass-sterling-hybrid", include_str!("../../factory/materials/glass-sterling-hybrid.json")),
    ("plastic-bowl-sterling31-rayleigh", include_str!("../../factory/materials/plastic-bowl-sterling31-rayleigh.json")),
    ("plastic-bowl-sterling31-caughey", include_str!("../../factory/materials/plastic-bowl-sterling31-caughey.json")),
    ("plastic-bowl-sterling31-power", include_str!("../../factory/materials/plastic-bowl-sterling31-power.json")),
    (
        "plastic-scoop-sterling31-rayleigh",
        include_str!("../../factory/materials/plastic-scoop-sterling31-rayleigh.json"),
    ),
    ("plastic-scoop-sterling31-caughey", include_str!("../../factory/materials/plastic-scoop-sterling31-caughey.json")),
    ("plastic-scoop-sterling31-power", include_str!("../../factory/materials/plastic-scoop-sterling31-power.json")),
    ("porcelain-sterling31-rayleigh", include_str!("../../factory/materials/porcelain-sterling31-rayleigh.json")),
    ("porcelain-sterling31-caughey", include_str!("../../factory/materials/porcelain-sterling31-caughey.json")),
    ("porcelain-sterling31-power", include_str!("../../factory/materials/porcelain-sterling31-power.json")),
    ("wood-sterling31-rayleigh", include_str!("../../factory/materials/wood-sterling31-rayleigh.json")),
    ("wood-sterling31-caughey", include_str!("../../factory/materials/wood-sterling31-caughey.json")),
    ("wood-sterling31-power", include_str!("../../factory/materials/wood-sterling31-power.json")),
    ("aluminum-sterling31-rayleigh", include_str!("../../factory/materials/aluminum-sterling31-rayleigh.json")),
    ("aluminum-sterling31-caughey", include_str!("../../factory/materials/aluminum-sterling31-caughey.json")),
    ("aluminum-sterling31-power", include_str!("../../factory/materials/aluminum-sterling31-power.json")),
];

/// Ids of the factory materials, in [`factory_materials`] order.
pub const FACTORY_MATERIAL_IDS: &[&str] = &[
    "wood-ren2013",
    "plastic-ren2013",
    "metal-ren2013",
    "glass-ren2013",
    "porcelain-ren2013",
    "porcelain-sterling-rayleigh",
    "porcelain-sterling-hybrid",
    "travertine-sterling-rayleigh",
    "travertine-sterling-hybrid",
    "wood-sterling-rayleigh",
    "wood-sterling-hybrid",
    "steel-sterling-rayleigh",
    "steel-sterling-hybrid",
    "plastic-sterling-rayleigh",
    "plastic-sterling-hybrid",
    "glass-sterling-rayleigh",
    "glass-sterling-hybrid",
    "plastic-bowl-sterling31-rayleigh",
    "plastic-bowl-sterling31-caughey",
    "plastic-bowl-sterling31-power",
    "plastic-scoop-sterling31-rayleigh",
    "plastic-scoop-sterling31-caughey",
    "plastic-scoop-sterling31-power",
    "porcelain-sterling31-rayleigh",
    "porcelain-sterling31-caughey",
    "porcelain-sterling31-power",
    "wood-sterling31-rayleigh",
    "wood-sterling31-caughey",
    "wood-sterling31-power",
    "aluminum-sterling31-rayleigh",
    "aluminum-sterling31-caughey",
    "aluminum-sterling31-power",
];

fn parse(id: &str, text: &str) -> Material {
    // PANIC: the embedded files are fixed at compile time and every one is parsed and
    // validated by the `every_factory_material_is_valid` test.
    Material::from_json(text).unwrap_or_else(|e| panic!("factory material {id} is invalid: {e}"))
}

/// All factory materials, parsed and validated, in the stable order documented above.
///
/// # Panics
/// Never in a tested build (the embedded files are checked by this crate's tests).
pub fn factory_materials() -> Vec<Material> {
    FILES.iter().map(|(id, text)| parse(id, text)).collect()
}

/// The factory material with this id, or `None`.
pub fn factory_material(id: &str) -> Option<Material> {
    FILES.iter().find(|(i, _)| *i == id).map(|(i, text)| parse(i, text))
}
