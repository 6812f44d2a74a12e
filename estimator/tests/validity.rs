//! Fits are always physically valid and say when they did not converge (issue 10, parts 2
//! and 5). The point sets are made here by a simple generator, independent of the
//! estimator's own synthesis code.

use estimator::{fit_damping, Method, ModelKind};

mod common;
use common::Gen;

/// (λ, c) points of a glass-plate-like session: Rayleigh material (α₁, α₂), 24 modes from
/// 400 Hz to 17 kHz, 20 impacts each exciting a mode with probability 0.7, exponential
/// support damping (mean `extra` s⁻¹), 2 % Gaussian jitter, and the fast high modes
/// (above 15 kHz) extracted 5–40 % too low, as measured on such sets (issue 10).
fn glass_points(seed: u64, alpha: (f64, f64), extra: f64) -> (Vec<(f64, f64)>, Vec<f64>) {
    let mut g = Gen(seed);
    let mut freqs: Vec<f64> = (0..21).map(|_| 400.0 * (17_000.0f64 / 400.0).powf(g.u())).collect();
    freqs.extend([15_600.0, 16_300.0, 16_900.0]);
    let lambdas: Vec<f64> = freqs.iter().map(|f| (std::f64::consts::TAU * f).powi(2)).collect();
    let mut pts = Vec::new();
    for _ in 0..20 {
        for (&f, &l) in freqs.iter().zip(&lambdas) {
            if g.u() < 0.7 {
                let ct = alpha.0 + alpha.1 * l;
                let mut c = ct + -extra * (1.0 - g.u()).ln() + 0.02 * ct * g.normal();
                if f > 15_000.0 {
                    c *= 0.6 + 0.35 * g.u();
                }
                pts.push((l, c.max(0.05)));
            }
        }
    }
    (pts, lambdas)
}

fn validate(model: ModelKind, params: &[f64]) -> Result<(), presets::PresetError> {
    let d = estimator::fit::to_damping(model, params);
    let m = presets::Material {
        schema_version: presets::SCHEMA_VERSION,
        id: "captured".into(),
        name: "Captured".into(),
        provenance: "test".into(),
        specific_modulus: None,
        damping: presets::DampingSpec::from_damping(&d),
        notes: String::new(),
        support: None,
        residual: None,
    };
    m.validate()
}

const MODELS: [ModelKind; 4] = [ModelKind::Rayleigh, ModelKind::Caughey, ModelKind::Power, ModelKind::Hybrid];
const METHODS: [Method; 3] = [Method::Emg, Method::Lsq, Method::Lb];

/// Glass plate, Rayleigh material with fast high modes extracted too low: the case that gave
/// α₁ = −32 and "alpha1 of the rayleigh model must be >= 0". Every model × method now fits,
/// and the presets crate's material validation accepts every result.
#[test]
fn every_fit_passes_material_validation_on_glass_sets() {
    let mut failures = Vec::new();
    for seed in 0..12u64 {
        // α₁ small against the high modes' c (≈ 800 s⁻¹ at 16.9 kHz), so a curve pulled down
        // by the low high modes crosses zero at low λ without the constraints.
        let a1 = [0.5, 2.0, 8.0][seed as usize % 3];
        let (pts, _) = glass_points(100 + seed, (a1, 7e-8), 3.0);
        for model in MODELS {
            for method in METHODS {
                match fit_damping(&pts, model, method) {
                    Ok(f) => {
                        if let Err(e) = validate(model, &f.params) {
                            failures.push(format!("seed {seed} {model:?} {method:?} {:?}: {e}", f.params));
                        }
                        assert!(estimator::fit::check_physical(model, &f.params).is_ok());
                        // A fit on a bound says so.
                        assert_eq!(f.active_bounds.is_empty(), f.warnings.iter().all(|w| !w.contains("is active")));
                    }
                    Err(e) => failures.push(format!("seed {seed} {model:?} {method:?}: fit failed: {e}")),
                }
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// Points that pull an unconstrained fit below zero (a falling cloud: c decreasing with λ,
/// as very low extracted high modes make it): the constrained fits end on the bound
/// α₂ = 0 exactly, converged, valid, and report the active bound as a warning.
#[test]
fn falling_points_end_on_the_bound_and_say_so() {
    let mut g = Gen(7);
    let pts: Vec<(f64, f64)> = (0..200)
        .map(|_| {
            let f = 200.0 * (100.0f64).powf(g.u());
            let l = (std::f64::consts::TAU * f).powi(2);
            (l, (40.0 - 1.5e-8 * l).max(1.0) + 2.0 * g.u())
        })
        .collect();
    // The unconstrained least-squares line has a negative slope.
    let n = pts.len() as f64;
    let (mx, my) = (pts.iter().map(|p| p.0).sum::<f64>() / n, pts.iter().map(|p| p.1).sum::<f64>() / n);
    let slope =
        pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum::<f64>() / pts.iter().map(|p| (p.0 - mx).powi(2)).sum::<f64>();
    assert!(slope < 0.0);
    for method in METHODS {
        let f = fit_damping(&pts, ModelKind::Rayleigh, method).unwrap();
        assert_eq!(f.params[1], 0.0, "{method:?}: {:?}", f.params);
        assert!(f.params[0] > 0.0);
        // Never silently unconverged: EMG on this cloud (uniform, unskewed scatter) heads for
        // the Gaussian limit η → ∞, where it may stop at its cap, and then it says so.
        assert!(
            f.converged || (method == Method::Emg && f.warnings.iter().any(|w| w.contains("without converging"))),
            "{method:?} {f:#?}"
        );
        assert!(f.active_bounds.iter().any(|b| b == "alpha2 >= 0"), "{method:?}: {:?}", f.active_bounds);
        assert!(f.warnings.iter().any(|w| w.contains("alpha2 >= 0")), "{method:?}: {:?}", f.warnings);
        validate(ModelKind::Rayleigh, &f.params).unwrap();
    }
    // Caughey: c(λ) ≥ 0 over 20 Hz–24 kHz although the points fall steeply.
    for method in METHODS {
        let f = fit_damping(&pts, ModelKind::Caughey, method).unwrap();
        validate(ModelKind::Caughey, &f.params).unwrap();
        let d = f.damping();
        let lmax = (std::f64::consts::TAU * 24_000.0f64).powi(2);
        assert!(d.c(lmax) >= -1e-9 * (f.params[2] * lmax * lmax).abs(), "{method:?}: {:?}", f.params);
    }
}

/// One clip's five partials (the real-clip case of issue 10): the EMG likelihood is largest
/// as σ → 0, which used to run the optimiser into its iteration cap (2 × 100) and return the
/// lower-bound curve as if converged. Now σ stops at its floor: the fit converges in few
/// iterations (its search and the polishes of the two relative noise scales, `NoiseScale`)
/// and warns that it follows the least-damped points.
#[test]
fn emg_on_a_few_partials_converges_and_warns() {
    // Glockenspiel-like: partials at 1, 2.76, 5.4, 8.9, 13.3 × 880 Hz, T60 from 1.4 s down.
    let pts: Vec<(f64, f64)> = [(880.0, 4.9), (2430.0, 9.0), (4750.0, 21.0), (7830.0, 30.0), (11700.0, 52.0)]
        .iter()
        .map(|&(f, c)| ((std::f64::consts::TAU * f).powi(2), c))
        .collect();
    let f = fit_damping(&pts, ModelKind::Rayleigh, Method::Emg).unwrap();
    eprintln!("{f:#?}");
    assert!(f.converged, "{f:?}");
    assert!(f.iterations < 100, "iterations {}", f.iterations);
    assert!(f.active_bounds.iter().any(|b| b.starts_with("sigma")), "{:?}", f.active_bounds);
    assert!(f.warnings.iter().any(|w| w.contains("least-damped")), "{:?}", f.warnings);
    // The curve lies under (or on) every point, as a lower-bound fit does.
    assert!(pts.iter().all(|&(l, c)| f.c(l) <= c * 1.01));
}

/// A well-posed EMG set (2,000 points, Rayleigh + exponential + Gaussian) converges to an
/// interior optimum in few Newton iterations (the search and three polishes), with no bound
/// active and no warning; its noise is the thesis's, absolute, and so is the fit's.
#[test]
fn emg_on_a_rich_set_converges_inside() {
    let mut g = Gen(42);
    let pts: Vec<(f64, f64)> = (0..2000)
        .map(|_| {
            let l = (std::f64::consts::TAU * 100.0 * 100.0f64.powf(g.u())).powi(2);
            (l, 6.0 + 4e-8 * l + 0.5 * g.normal() - 3.0 * (1.0 - g.u()).ln())
        })
        .collect();
    for model in MODELS {
        let f = fit_damping(&pts, model, Method::Emg).unwrap();
        eprintln!("{model:?}: its {} active {:?} params {:?}", f.iterations, f.active_bounds, f.params);
        assert!(f.converged, "{model:?}");
        assert!(f.iterations <= 200, "{model:?}: {} iterations", f.iterations);
        assert_eq!(f.noise_scale, Some(estimator::fit::NoiseScale::Absolute), "{model:?}");
        assert!(!f.active_bounds.iter().any(|b| b.starts_with("sigma") || b.starts_with("eta")), "{model:?}");
        if model != ModelKind::Power {
            // The law is in the model's family (the power law cannot follow c = α₁ + α₂λ).
            let err = (f.c(1e8) / (6.0 + 4e-8 * 1e8) - 1.0).abs();
            assert!(err < 0.05, "{model:?}: {err}");
        }
    }
}

/// The same glass sets, Rayleigh: damping-curve error at the object's modes (mean of
/// |c_fit/c_true − 1|). The fast high modes extracted too low are what the outlier component
/// and the constraints are for. EMG is below LSQ on every set, within 4 % on average and
/// within the 10 % on every set (measured 2.3 % and 7.9 %; LSQ 155 %, LB 28 %). The
/// relative-spread noise scale explains these sets best (2 % jitter in proportion to c); until
/// stop 57 its better basin, away from σ's floor, was missed on 7 of 12 sets (6.3 % mean, set 7
/// 31 %).
#[test]
fn emg_ahead_of_lsq_on_glass_sets() {
    let mut rows = Vec::new();
    for seed in 0..12u64 {
        let a1 = [0.5, 2.0, 8.0][seed as usize % 3];
        let truth = |l: f64| a1 + 7e-8 * l;
        let (pts, lambdas) = glass_points(100 + seed, (a1, 7e-8), 3.0);
        let err = |m: Method| {
            let f = fit_damping(&pts, ModelKind::Rayleigh, m).unwrap();
            lambdas.iter().map(|&l| (f.c(l) / truth(l) - 1.0).abs()).sum::<f64>() / lambdas.len() as f64
        };
        rows.push((seed, err(Method::Emg), err(Method::Lsq), err(Method::Lb)));
    }
    let mean = |i: usize| rows.iter().map(|r| [r.1, r.2, r.3][i]).sum::<f64>() / rows.len() as f64;
    eprintln!("glass sets curve error: EMG {:.3} LSQ {:.3} LB {:.3}; per set {rows:.3?}", mean(0), mean(1), mean(2));
    assert!(mean(0) <= 0.04, "EMG mean curve error {}", mean(0));
    for &(seed, emg, lsq, _) in &rows {
        assert!(emg <= 0.10, "seed {seed}: EMG {emg}");
        assert!(emg < 0.5 * lsq, "seed {seed}: EMG {emg} vs LSQ {lsq}");
    }
}

/// Part 3: the same glass sets with each point's uncertainty given as the extractor gives
/// it, a Cramér–Rao bound: at equal amplitude and noise σ_d/d = 2/√SNR with SNR ∝ 1/d, so
/// σ_c ∝ c·√c (here 2 % at the median c). The fast high modes are then the uncertain ones
/// (their extraction bias is not told to the fit). The heteroscedastic EMG's curve error at
/// the object's modes on every set, against the weighted LSQ.
#[test]
fn weighted_emg_on_glass_sets() {
    let mut rows = Vec::new();
    for seed in 0..12u64 {
        let a1 = [0.5, 2.0, 8.0][seed as usize % 3];
        let truth = |l: f64| a1 + 7e-8 * l;
        let (pts, lambdas) = glass_points(100 + seed, (a1, 7e-8), 3.0);
        let mut cs: Vec<f64> = pts.iter().map(|p| p.1).collect();
        cs.sort_by(f64::total_cmp);
        let med = cs[cs.len() / 2];
        let sig: Vec<f64> = pts.iter().map(|p| 0.02 * p.1 * (p.1 / med).sqrt()).collect();
        let err = |m: Method| {
            let f = estimator::fit_damping_weighted(&pts, Some(&sig), ModelKind::Rayleigh, m).unwrap();
            lambdas.iter().map(|&l| (f.c(l) / truth(l) - 1.0).abs()).sum::<f64>() / lambdas.len() as f64
        };
        rows.push((seed, err(Method::Emg), err(Method::Lsq)));
    }
    let worst = rows.iter().fold(0.0f64, |m, r| m.max(r.1));
    let mean = rows.iter().map(|r| r.1).sum::<f64>() / rows.len() as f64;
    eprintln!("weighted glass sets curve error: EMG mean {mean:.3} worst {worst:.3}; per set {rows:.3?}");
    assert!(mean <= 0.05, "EMG mean curve error {mean}");
    // The target: ≤ 10 % on every set.
    assert!(worst <= 0.10, "EMG worst set {worst}");
    for &(seed, emg, lsq) in &rows {
        assert!(emg < lsq, "seed {seed}: EMG {emg} vs LSQ {lsq}");
    }
}

/// Decays that scatter in proportion to their size (a black-box tester's sets, stop 56): a
/// glass plate's 13 modes, 523 Hz–16.9 kHz, a Rayleigh law from 10.8 to 878 s⁻¹, 20 impacts,
/// each decay 3 % off (Gaussian) plus support damping drawn from an exponential of mean 7 %
/// of the mode's own, each point's extraction uncertainty 0.3 %. The thesis's EMG, one σ and
/// η for every point, let the fast high modes set them, and the law at the slow low modes
/// hardly mattered: α₁ came out 17–25 % low (the lowest mode 15–23 % under-damped, LSQ 5–6 %
/// off everywhere). The fit now also runs the EMG with its noise relative to the law
/// (`NoiseScale`), keeps it for its likelihood, and is within 2 % on average over the modes
/// and 3 % at its worst mode (measured 0.3–0.8 % and 0.5–1.3 %), ahead of the weighted LSQ
/// (5.2–6.7 %) on both on every set; on the thesis's
/// absolute noise it keeps the absolute scale (`emg_on_a_rich_set_converges_inside`).
#[test]
fn emg_follows_decays_that_scatter_in_proportion() {
    let freqs =
        [523.0, 987.0, 1512.0, 2296.0, 3150.0, 4410.0, 5620.0, 7080.0, 8930.0, 10710.0, 12640.0, 14530.0, 16900.0];
    let lam = |f: f64| (std::f64::consts::TAU * f).powi(2);
    let law = |l: f64| 2.0 * (10.0 + 7.7e-8 * l);
    for seed in 0..6u64 {
        let mut g = Gen(700 + seed);
        let (mut pts, mut sig) = (Vec::new(), Vec::new());
        for _ in 0..20 {
            for &f in &freqs {
                let c = law(lam(f));
                let v = c * (1.0 + 0.03 * g.normal()) - 0.07 * c * (1.0 - g.u()).ln();
                pts.push((lam(f), v));
                sig.push(0.003 * v);
            }
        }
        // (mean over the modes, worst mode) of |c_fit/c_true − 1|.
        let err = |m: Method| {
            let f = estimator::fit_damping_weighted(&pts, Some(&sig), ModelKind::Rayleigh, m).unwrap();
            let e: Vec<f64> = freqs.iter().map(|&fr| (f.c(lam(fr)) / law(lam(fr)) - 1.0).abs()).collect();
            (e.iter().sum::<f64>() / e.len() as f64, e.iter().fold(0.0f64, |a, &b| a.max(b)), f)
        };
        let ((emg, emg_worst, f), (lsq, lsq_worst, _)) = (err(Method::Emg), err(Method::Lsq));
        eprintln!(
            "seed {seed}: EMG mean {emg:.4} worst {emg_worst:.4} ({:?}), LSQ mean {lsq:.4} worst {lsq_worst:.4}",
            f.noise_scale
        );
        assert_eq!(f.noise_scale, Some(estimator::fit::NoiseScale::Relative), "seed {seed}");
        assert!(emg < 0.02 && emg_worst < 0.03, "seed {seed}: EMG mean {emg}, worst mode {emg_worst}");
        assert!(emg < lsq && emg_worst < lsq_worst, "seed {seed}: EMG {emg} / {emg_worst} vs LSQ {lsq} / {lsq_worst}");
    }
}

/// A clean Caughey law (all terms > 0) is recovered by every method: c within 1 % from
/// 100 Hz to 15 kHz. The LB fit searched a₂ of either sign with (a₀, a₁) free, found most of
/// that range infeasible and fell back on the Rayleigh line (a black-box tester's clean set:
/// [0, α₂, 0], 0.03 s⁻¹ at 211 Hz for 1.04, no bound said); it now searches a₂ ≥ 0 with
/// a₀, a₁ ≥ 0, the terms the plugin's *Custom* knobs play. And a damping that falls with
/// frequency is fitted with every Caughey term ≥ 0 (flat), the bound said.
#[test]
fn caughey_fits_keep_every_term_non_negative_and_find_a_clean_law() {
    let law = |l: f64| 2.0 + 2e-8 * l + 1e-17 * l * l;
    let lam = |f: f64| (std::f64::consts::TAU * f).powi(2);
    let pts: Vec<(f64, f64)> =
        (0..30).map(|i| lam(100.0 * 150f64.powf(i as f64 / 29.0))).map(|l| (l, law(l))).collect();
    for method in METHODS {
        let f = fit_damping(&pts, ModelKind::Caughey, method).unwrap();
        for hz in [100.0, 500.0, 2000.0, 8000.0, 15_000.0] {
            let (got, want) = (f.damping().c(lam(hz)), law(lam(hz)));
            assert!((got / want - 1.0).abs() < 0.01, "{method:?} at {hz} Hz: {got} for {want} ({:?})", f.params);
        }
    }
    let mut g = Gen(3);
    let falling: Vec<(f64, f64)> = (0..120)
        .map(|_| {
            let f = 200.0 * 60f64.powf(g.u());
            (lam(f), 30.0 * (f / 200.0).powf(-0.3) * (1.0 + 0.05 * g.normal()))
        })
        .collect();
    for method in METHODS {
        let f = fit_damping(&falling, ModelKind::Caughey, method).unwrap();
        assert!(f.params.iter().all(|&p| p >= 0.0), "{method:?}: {:?}", f.params);
        assert!(
            f.warnings.iter().any(|w| w.contains("alpha2 >= 0") || w.contains("alpha3 >= 0")),
            "{method:?}: {:?}",
            f.warnings
        );
    }
    // A rising (Rayleigh) damping whose best Caughey λ² term is a little negative is not said
    // to fall with frequency (a black-box tester's wood bar was): the warning names the λ² term.
    let mut g = Gen(8);
    let rising: Vec<(f64, f64)> = (0..200)
        .map(|_| {
            let l = lam(300.0 * 50f64.powf(g.u()));
            (l, (39.0 + 5e-8 * l) * (1.0 + 0.03 * g.normal()) - 2e-19 * l * l)
        })
        .collect();
    let f = fit_damping(&rising, ModelKind::Caughey, Method::Lsq).unwrap();
    assert_eq!(f.active_bounds, ["alpha3 >= 0"], "{:?}", f.params);
    assert!(f.params[1] > 0.0);
    let w: Vec<&String> = f.warnings.iter().filter(|w| w.contains("alpha3 >= 0")).collect();
    assert!(w.len() == 1 && w[0].contains("negative λ² term") && !w[0].contains("falls"), "{w:?}");
}
