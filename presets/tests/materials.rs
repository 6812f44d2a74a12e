//! Factory materials: validity, and decay times that catch a wrong unit conversion.

use presets::{factory_material, factory_materials, DampingModel, FACTORY_MATERIAL_IDS};

#[test]
fn every_factory_material_is_valid() {
    let materials = factory_materials();
    let ids: Vec<&str> = materials.iter().map(|m| m.id.as_str()).collect();
    assert_eq!(ids, FACTORY_MATERIAL_IDS);
    let mut seen = std::collections::HashSet::new();
    for m in &materials {
        m.validate().unwrap();
        assert!(seen.insert(m.id.clone()), "duplicate id {}", m.id);
        assert!(!m.provenance.is_empty() && m.provenance.contains("Table"), "{}: provenance must cite a table", m.id);
        assert_eq!(factory_material(&m.id).as_ref(), Some(m));
    }
    assert!(factory_material("unobtainium").is_none());
    for model in [DampingModel::Rayleigh, DampingModel::Caughey, DampingModel::Power, DampingModel::Hybrid] {
        assert!(materials.iter().any(|m| m.damping.model == model), "no {model:?} material");
    }
}

#[test]
fn decay_times_are_plausible() {
    println!("{:<36} {:>12} {:>12} {:>12}", "T60 (s)", "200 Hz", "1 kHz", "5 kHz");
    for m in factory_materials() {
        let t: Vec<f64> = [200.0, 1000.0, 5000.0].iter().map(|&f| m.t60_s(f).unwrap()).collect();
        println!("{:<36} {:>12.4} {:>12.4} {:>12.4}", m.id, t[0], t[1], t[2]);
        // A unit slip (e.g. λ in Hz², or a ×10⁻⁷ header missed) moves these by orders of magnitude.
        assert!((0.005..=60.0).contains(&t[1]), "{}: T60 at 1 kHz = {} s", m.id, t[1]);
        assert!((1e-5..=300.0).contains(&t[0]) && (1e-5..=300.0).contains(&t[2]), "{}: {t:?}", m.id);
    }
    // Ordering that any listener knows: glass and steel ring longer than wood and plastic.
    let t1k = |id: &str| factory_material(id).unwrap().t60_s(1000.0).unwrap();
    assert!(t1k("glass-sterling-rayleigh") > 5.0 * t1k("wood-sterling-rayleigh"));
    assert!(t1k("steel-sterling-hybrid") > 5.0 * t1k("plastic-sterling-hybrid"));
    assert!(t1k("metal-ren2013") > 5.0 * t1k("wood-ren2013"));
    assert!(t1k("glass-ren2013") > 2.0 * t1k("plastic-ren2013"));
}

#[test]
fn ren_table_values_are_stored_in_si() {
    let wood = factory_material("wood-ren2013").unwrap();
    assert_eq!(wood.damping.params, vec![2.1364, 3.0828e-6]);
    // Thesis §4.3: porcelain hybrid gives d = 20 at 10 kHz (d = 12 with α₃ = 1).
    let p = factory_material("porcelain-sterling-hybrid").unwrap().to_damping().unwrap();
    let lambda = (2.0 * std::f64::consts::PI * 1e4f64).powi(2);
    let d = p.c(lambda) / 2.0;
    assert!((d - 20.0).abs() < 1.0, "d = {d}");
}
