//! The objects and materials the plugin offers: the factory library, computed once per
//! process (off the audio thread) and shared by every instance.

use dsp::{Damping, ObjectModes};
use presets::{Bank, Material};
use std::sync::{Arc, OnceLock};

/// Factory banks and materials, with the engine's view of them.
pub struct Library {
    /// Object banks in parameter order.
    pub banks: Vec<Bank>,
    /// Materials in parameter order (the parameter's last value, one past these, is *Custom*).
    pub materials: Vec<Material>,
    /// Each material's damping law (validated).
    pub dampings: Vec<Damping>,
}

/// The default material's id (it rings, and is a measured one).
pub const DEFAULT_MATERIAL: &str = "glass-ren2013";

impl Library {
    /// The factory library (computed on first use, then shared).
    pub fn factory() -> Arc<Library> {
        static LIB: OnceLock<Arc<Library>> = OnceLock::new();
        LIB.get_or_init(|| {
            let banks = presets::factory_banks();
            let mut materials = Vec::new();
            let mut dampings = Vec::new();
            for m in presets::factory_materials() {
                // PANIC: never; factory materials are validated by presets' tests. A bad one
                // would be skipped rather than crash a host.
                if let Ok(d) = m.damping.to_damping() {
                    materials.push(m);
                    dampings.push(d);
                }
            }
            Arc::new(Library { banks, materials, dampings })
        })
        .clone()
    }

    /// Index of the bank with `id`, if any.
    pub fn bank_index(&self, id: &str) -> Option<usize> {
        self.banks.iter().position(|b| b.id == id)
    }

    /// Index of the material with `id`, if any.
    pub fn material_index(&self, id: &str) -> Option<usize> {
        self.materials.iter().position(|m| m.id == id)
    }

    /// The material selected by default.
    pub fn default_material_index(&self) -> usize {
        self.material_index(DEFAULT_MATERIAL).unwrap_or(0)
    }

    /// Value of the material parameter that selects the *Custom* knobs.
    pub fn custom_material_index(&self) -> usize {
        self.materials.len()
    }

    /// The engine's objects, one per bank. Allocates.
    pub fn object_modes(&self) -> Vec<ObjectModes> {
        self.banks.iter().map(|b| ObjectModes::new(b.lambdas.clone(), &b.gains)).collect()
    }

    /// The specific-modulus ratio a material implies on a bank (1 when unknown).
    pub fn material_modulus_ratio(&self, material: usize, bank: usize) -> f64 {
        match (self.materials.get(material).and_then(|m| m.specific_modulus), self.banks.get(bank)) {
            (Some(g), Some(b)) if g > 0.0 && b.reference.specific_modulus > 0.0 => g / b.reference.specific_modulus,
            _ => 1.0,
        }
    }
}
