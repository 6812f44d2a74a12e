//! Factory banks: measured properties against the analytic sources.

use std::f64::consts::PI;
use std::time::Instant;

use presets::factory::{bar_bank, circular_plate_bank, free_circular_plate_roots, rect_plate_bank};
use presets::{factory_bank, factory_banks, Bank, FACTORY_BANK_IDS};

fn mode_index(bank: &Bank, label: &str) -> usize {
    bank.mode_labels.iter().position(|l| l == label).unwrap_or_else(|| panic!("{}: no mode {label}", bank.id))
}

#[test]
fn factory_banks_are_valid_ordered_and_rich() {
    // The analytic banks come first; the embedded FEM banks are checked below.
    let banks: Vec<Bank> = factory_banks().into_iter().take(FACTORY_BANK_IDS.len()).collect();
    let ids: Vec<&str> = banks.iter().map(|b| b.id.as_str()).collect();
    assert_eq!(ids, FACTORY_BANK_IDS);
    for bank in &banks {
        bank.validate().unwrap();
        assert_eq!(factory_bank(&bank.id).as_ref(), Some(bank));
        assert!(bank.num_points() >= 16, "{}: {} points", bank.id, bank.num_points());
        assert!(bank.lambdas.windows(2).all(|w| w[0] <= w[1]), "{}: λ not ascending", bank.id);
        let freqs = bank.frequencies_hz();
        let sounding = (0..bank.num_modes())
            .filter(|&m| freqs[m] < 20_000.0 && bank.gains.iter().any(|row| row[m].abs() > 1e-4))
            .count();
        let max = bank.gains.iter().flatten().fold(0.0f32, |a, g| a.max(g.abs()));
        println!(
            "{}: {} modes ({} sounding below 20 kHz), {} points, f1 = {:.2} Hz, f_last = {:.0} Hz",
            bank.id,
            bank.num_modes(),
            sounding,
            bank.num_points(),
            freqs[0],
            freqs[freqs.len() - 1]
        );
        assert!(sounding >= 100, "{}: only {sounding} sounding modes below 20 kHz", bank.id);
        assert!((max - 1.0).abs() < 1e-6, "{}: max |gain| = {max}", bank.id);
        assert_eq!(bank.mode_labels.len(), bank.num_modes());
    }
    assert!(factory_bank("drum").is_none());
}

#[test]
fn factory_banks_are_fast() {
    for id in FACTORY_BANK_IDS {
        let t = Instant::now();
        let bank = factory_bank(id).unwrap();
        let ms = t.elapsed().as_secs_f64() * 1e3;
        println!("{id}: built in {ms:.1} ms ({} modes)", bank.num_modes());
        // The budget is 50 ms in release; this test profile is only lightly optimised.
        assert!(ms < 1000.0, "{id} took {ms} ms");
    }
}

#[test]
fn bar_bending_ratios_and_fundamental() {
    let bank = bar_bank();
    let f = bank.frequencies_hz();
    let bend: Vec<f64> = (1..=4).map(|k| f[mode_index(&bank, &format!("bend {k}"))]).collect();
    for (k, expected) in [(1, 2.757), (2, 5.404), (3, 8.933)] {
        let ratio = bend[k] / bend[0];
        assert!((ratio / expected - 1.0).abs() < 1e-3, "bend {}/bend 1 = {ratio}, expected {expected}", k + 1);
    }
    // f₁ = (β₁L)²/(2π L²) sqrt(EI/(ρA)), I = w t³/12, A = w t.
    let r = &bank.reference;
    let (l, w, t) = (r.dimensions_m[0], r.dimensions_m[1], r.dimensions_m[2]);
    let e = r.specific_modulus * r.density;
    let f1 = 4.730_040_7f64.powi(2) / (2.0 * PI * l * l) * (e * w * t.powi(3) / 12.0 / (r.density * w * t)).sqrt();
    assert!((bend[0] / f1 - 1.0).abs() < 1e-6, "f1 = {} Hz, formula {f1} Hz", bend[0]);
    println!("bar f1 = {:.3} Hz", bend[0]);
    assert!((f1 - 15.7).abs() < 0.1);
}

#[test]
fn bar_antisymmetric_mode_is_silent_at_the_centre_and_torsion_sounds() {
    let bank = bar_bank();
    let centre = bank.num_points() - 1;
    assert!((bank.points[centre].position_m[0] - 0.5).abs() < 1e-6, "last point is the bar centre");
    let bend2 = mode_index(&bank, "bend 2");
    let bend1 = mode_index(&bank, "bend 1");
    assert!(bank.gains[centre][bend2].abs() < 1e-5, "bend 2 at centre: {}", bank.gains[centre][bend2]);
    assert!(bank.gains[centre][bend1].abs() > 0.1);
    // Torsion modes are excited by the off-centreline strike line, at the end most of all.
    let tors1 = mode_index(&bank, "torsion 1");
    assert!(bank.gains[0][tors1].abs() > 0.1, "torsion 1 at the end: {}", bank.gains[0][tors1]);
    let n_torsion = bank.mode_labels.iter().filter(|l| l.starts_with("torsion")).count();
    let n_bend = bank.mode_labels.iter().filter(|l| l.starts_with("bend")).count();
    println!("bar: {n_bend} bending + {n_torsion} torsion modes");
    assert!(n_torsion > 20 && n_bend > 20);
}

#[test]
fn circular_plate_lambdas_match_leissa() {
    // Leissa 1969 Table 2.5, ν = 0.33: λ² = ω a² sqrt(ρh/D) for (m,n) = (2,0), (0,1), (3,0), (1,1).
    let roots = free_circular_plate_roots(0.33, 10.0);
    for (k, expected) in [5.251, 9.076, 12.23, 20.52].into_iter().enumerate() {
        let got = roots[k].x * roots[k].x;
        assert!((got / expected - 1.0).abs() < 0.005, "root {k}: {got} vs {expected}");
    }
    // And the bank's own λ (ν = 0.33 reference) follows ω = λ²/a² sqrt(D/(ρh)).
    let bank = circular_plate_bank();
    let r = &bank.reference;
    let (a, h) = (r.dimensions_m[0], r.dimensions_m[1]);
    let e = r.specific_modulus * r.density;
    let kappa = (e * h * h / (12.0 * (1.0 - r.poisson * r.poisson) * r.density)).sqrt();
    for (label, l2) in [("(m,n)=(2,0)", 5.251), ("(m,n)=(0,1)", 9.076), ("(m,n)=(3,0)", 12.23), ("(m,n)=(1,1)", 20.52)]
    {
        let omega = bank.lambdas[mode_index(&bank, label)].sqrt();
        let got = omega * a * a / kappa;
        assert!((got / l2 - 1.0).abs() < 0.005, "{label}: {got} vs {l2}");
    }
    // At the centre only axisymmetric modes move.
    for (m, label) in bank.mode_labels.iter().enumerate() {
        if !label.starts_with("(m,n)=(0,") {
            assert!(bank.gains[0][m].abs() < 1e-6, "{label} moves at the centre");
        }
    }
}

#[test]
fn rect_plate_follows_the_navier_formula() {
    let bank = rect_plate_bank();
    let r = &bank.reference;
    let (a, b, h) = (r.dimensions_m[0], r.dimensions_m[1], r.dimensions_m[2]);
    let e = r.specific_modulus * r.density;
    let kappa = (e * h * h / (12.0 * (1.0 - r.poisson * r.poisson) * r.density)).sqrt();
    for (m, n) in [(1, 1), (2, 1), (1, 2), (3, 3)] {
        let omega = PI * PI * ((m * m) as f64 / (a * a) + (n * n) as f64 / (b * b)) * kappa;
        let i = mode_index(&bank, &format!("(m,n)=({m},{n})"));
        assert!((bank.lambdas[i] / (omega * omega) - 1.0).abs() < 1e-12);
    }
    assert_eq!(bank.mode_labels[0], "(m,n)=(1,1)");
    // At the centre (last point) modes with an even m or n are silent.
    let centre = bank.num_points() - 1;
    let i22 = mode_index(&bank, "(m,n)=(2,2)");
    assert!(bank.gains[centre][i22].abs() < 1e-6);
}

#[test]
fn gains_at_interpolates_between_points() {
    let bank = bar_bank();
    let n = bank.num_modes();
    let mut out = vec![f32::NAN; n];
    bank.gains_at(0.0, &mut out);
    assert_eq!(out, bank.gains[0]);
    bank.gains_at(1.0, &mut out);
    assert_eq!(out, bank.gains[bank.num_points() - 1]);
    let step = 1.0 / (bank.num_points() - 1) as f32;
    bank.gains_at(2.5 * step, &mut out);
    for (m, &g) in out.iter().enumerate() {
        let mid = 0.5 * (bank.gains[2][m] + bank.gains[3][m]);
        assert!((g - mid).abs() < 1e-5);
    }
}

#[test]
fn embedded_fem_banks_parse_validate_and_are_listed() {
    use presets::factory::FACTORY_FEM_BANKS;
    assert!(FACTORY_FEM_BANKS.len() >= 8);
    let all = presets::factory_banks();
    assert_eq!(all.len(), 3 + FACTORY_FEM_BANKS.len());
    for (id, json) in FACTORY_FEM_BANKS {
        let b = presets::Bank::from_json(json).unwrap_or_else(|e| panic!("{id}: {e}"));
        assert_eq!(&b.id, id);
        assert!(b.num_points() >= 64, "{id}: {} points", b.num_points());
        assert!(b.num_modes() >= 10, "{id}: {} modes", b.num_modes());
        assert!(b.provenance.contains("FEM"), "{id}");
        assert_eq!(presets::factory_bank(id).as_ref(), Some(&b));
        // Compact enough to ship: well under 1 MB per bank.
        assert!(json.len() < 1_000_000, "{id}: {} bytes", json.len());
    }
}
