//! Capture round trip: a material played by the plugin (through `process()`, written as a
//! WAV like a recording) is recovered by the estimator, and bad material files are refused.

use std::path::PathBuf;
use struck_cli::capture::{estimate, EstimateArgs};
use struck_cli::cli::{render, RenderOptions, SoundOptions};

fn tmp(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("struck-test-{}-{name}", std::process::id()))
}

#[test]
fn estimator_recovers_the_material_the_plugin_played() {
    let wav = tmp("taps.wav");
    let opts = RenderOptions {
        // Struck with a steel beater, as a capture session should be: a short contact
        // excites the high modes the stiffness term is measured on.
        sound: SoundOptions {
            object: "circular-plate".into(),
            material: "steel-sterling-rayleigh".into(),
            set: vec!["mallet=5".into()],
            ..SoundOptions::default()
        },
        // Taps far enough apart to decay into silence, at different strike points and keys.
        notes: Some("48:110@0.1,55:110@0.45+2.5,50:120@0.8+5".into()),
        midi: None,
        seconds: Some(7.5),
        block_size: 512,
        out: wav.clone(),
        normalize: None,
        gesture: Default::default(),
    };
    render(&opts).unwrap();
    let out = tmp("material.json");
    let report = tmp("report.json");
    let args = EstimateArgs {
        files: vec![wav.clone()],
        model: "rayleigh".into(),
        method: "emg".into(),
        object: None,
        channel: None,
        out: out.clone(),
        report: Some(report.clone()),
        no_residual: false,
    };
    estimate(&args).unwrap();
    let m = presets::Material::load(&out).unwrap();
    let got = m.to_damping().unwrap();
    let truth = presets::factory_material("steel-sterling-rayleigh").unwrap().to_damping().unwrap();
    // What the ear hears: the damping curve over the plate's audible modes.
    let mut worst = 0.0f64;
    for f in [300.0, 1000.0, 3000.0] {
        let l = (2.0 * std::f64::consts::PI * f).powi(2);
        worst = worst.max((got.c(l) / truth.c(l) - 1.0).abs());
    }
    assert!(worst < 0.15, "damping curve off by {:.1} %: {got:?} vs {truth:?}", worst * 100.0);
    let rep: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    assert!(rep["impacts"].as_array().is_some_and(|a| !a.is_empty()));
    for p in [wav, out, report] {
        let _ = std::fs::remove_file(p);
    }
}

#[test]
fn broken_material_files_are_refused_with_the_field_named() {
    let bad = tmp("bad.json");
    std::fs::write(&bad, r#"{"schema_version":1,"id":"x","name":"x","provenance":"t","specific_modulus":null,"damping":{"model":"rayleigh","params":[-5.0, 1e-7]}}"#).unwrap();
    let opts = SoundOptions { material: bad.display().to_string(), ..SoundOptions::default() };
    let err = struck_cli::cli::configured_host(&opts, 64).err().expect("a negative damping must be refused");
    assert!(err.contains("damping"), "{err}");
    std::fs::write(&bad, "{ not json").unwrap();
    let err = struck_cli::cli::configured_host(&opts, 64).err().expect("broken JSON must be refused");
    assert!(err.to_lowercase().contains("json") || err.contains("line"), "{err}");
    let _ = std::fs::remove_file(bad);
}

#[test]
fn bad_note_syntax_and_unknown_objects_are_clear_errors() {
    assert!(struck_cli::cli::parse_notes("60:100@0.3,61").unwrap_err().contains("'61'"));
    assert!(struck_cli::cli::parse_notes("60:0").unwrap_err().contains("velocity"));
    assert!(struck_cli::cli::parse_notes("60:100@1.5").unwrap_err().contains("position"));
    let n = struck_cli::cli::parse_notes("60:100@0.25,67:80@0.5+1.0").unwrap();
    assert_eq!((n[1].key, n[1].velocity, n[1].position, n[1].start_s), (67, 80, Some(0.5), 1.0));
    let opts = SoundOptions { object: "teapot".into(), ..SoundOptions::default() };
    assert!(struck_cli::cli::configured_host(&opts, 64).err().unwrap().contains("unknown object 'teapot'"));
}
