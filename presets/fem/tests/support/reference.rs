//! The independent axisymmetric references (tests/data/axisymmetric.json, written by
//! tests/reference/axisymmetric.py: 3-D elasticity by Fourier harmonics on the meridian
//! section, scipy) and the comparison of a solve with them.

use fem::{Material, Shape};

/// One reference: the built-in shape and material it was solved for, and its lowest elastic
/// frequencies with their multiplicity (a mode of harmonic n ≥ 1 twice).
pub struct Reference {
    pub shape: Shape,
    pub material: Material,
    pub frequencies_hz: Vec<f64>,
}

/// The reference named `name` ("disc" or "bowl").
pub fn reference(name: &str) -> Reference {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/axisymmetric.json"))
        .expect("read tests/data/axisymmetric.json");
    let all: serde_json::Value = serde_json::from_str(&text).expect("parse axisymmetric.json");
    let r = &all[name];
    let num = |v: &serde_json::Value| v.as_f64().expect("a number");
    let dims: Vec<f64> = r["dims"].as_array().expect("dims").iter().map(num).collect();
    let shape = match r["shape"].as_str().expect("shape") {
        "circular-plate" => Shape::CircularPlate { radius: dims[0], thickness: dims[1] },
        "bowl" => Shape::Bowl { radius: dims[0], wall: dims[1] },
        other => panic!("no shape {other} in the references"),
    };
    let material =
        Material { young: num(&r["young_pa"]), density: num(&r["density_kg_m3"]), poisson: num(&r["poisson"]) };
    let frequencies_hz = r["frequencies_hz"].as_array().expect("frequencies").iter().map(num).collect();
    Reference { shape, material, frequencies_hz }
}

/// Relative errors of `freqs` (ascending, elastic) against the reference, mode by mode: the
/// reference lists each mode with its multiplicity, so a missing or doubled mode shows.
pub fn errors(freqs: &[f64], reference: &[f64]) -> Vec<f64> {
    assert!(freqs.len() <= reference.len(), "{} modes, the reference has {}", freqs.len(), reference.len());
    freqs.iter().zip(reference).map(|(&f, &r)| (f - r) / r).collect()
}
