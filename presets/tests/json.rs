//! JSON round trips, file I/O and rejection of broken input with the right error variant.

use std::path::PathBuf;

use presets::{factory_bank, factory_material, Bank, DampingModel, DampingSpec, Material, PresetError, SCHEMA_VERSION};

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("struck-presets-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

fn small_bank() -> Bank {
    let mut b = factory_bank("bar").unwrap();
    b.lambdas.truncate(3);
    b.points.truncate(2);
    b.gains.truncate(2);
    for row in &mut b.gains {
        row.truncate(3);
    }
    b.mode_labels.truncate(3);
    b.normalize_gains();
    b
}

fn invalid_field<T: std::fmt::Debug>(r: Result<T, PresetError>) -> String {
    match r {
        Err(PresetError::Invalid { field, reason }) => {
            assert!(!reason.is_empty());
            field
        }
        other => panic!("expected Invalid, got {other:?}"),
    }
}

#[test]
fn bank_and_material_round_trip() {
    for id in ["bar", "circular-plate", "rect-plate"] {
        let bank = factory_bank(id).unwrap();
        assert_eq!(Bank::from_json(&bank.to_json()).unwrap(), bank);
    }
    let m = factory_material("steel-sterling-hybrid").unwrap();
    assert_eq!(Material::from_json(&m.to_json()).unwrap(), m);
    let mut odd = factory_material("glass-ren2013").unwrap();
    odd.specific_modulus = Some(2.8e7 + 1.0 / 3.0);
    odd.damping = DampingSpec { model: DampingModel::Caughey, params: vec![0.1 + 0.2, 1e-7 / 3.0, 1e-17, 1e-25] };
    assert_eq!(Material::from_json(&odd.to_json()).unwrap(), odd);
}

#[test]
fn save_and_load_files() {
    let path = scratch("bank.json");
    let bank = small_bank();
    bank.save(&path).unwrap();
    assert_eq!(Bank::load(&path).unwrap(), bank);
    let mpath = scratch("material.json");
    let m = factory_material("wood-sterling31-caughey").unwrap();
    m.save(&mpath).unwrap();
    assert_eq!(Material::load(&mpath).unwrap(), m);
    // An invalid material is not written.
    let mut bad = m.clone();
    bad.id = String::new();
    let bad_path = scratch("bad.json");
    assert!(bad.save(&bad_path).is_err());
    assert!(!bad_path.exists());
}

#[test]
fn missing_file_is_an_io_error_naming_the_path() {
    let path = scratch("does-not-exist/nowhere.json");
    for err in [Material::load(&path).unwrap_err(), Bank::load(&path).unwrap_err()] {
        match &err {
            PresetError::Io { path: p, source } => {
                assert_eq!(p, &path);
                assert_eq!(source.kind(), std::io::ErrorKind::NotFound);
            }
            other => panic!("expected Io, got {other:?}"),
        }
        assert!(err.to_string().contains("nowhere.json"), "{err}");
    }
}

#[test]
fn broken_json_is_a_json_error_with_position() {
    let m = factory_material("glass-ren2013").unwrap().to_json();
    let truncated = &m[..m.len() / 2];
    match Material::from_json(truncated) {
        Err(PresetError::Json { line, column, what, .. }) => {
            assert!(line > 1 && column > 0);
            assert_eq!(what, "material");
        }
        other => panic!("expected Json, got {other:?}"),
    }
    // Wrong type for a field.
    let wrong = m.replace("\"rayleigh\"", "42");
    assert!(matches!(Material::from_json(&wrong), Err(PresetError::Json { .. })));
    // Unknown model name.
    let unknown = m.replace("\"rayleigh\"", "\"viscous\"");
    assert!(matches!(Material::from_json(&unknown), Err(PresetError::Json { .. })));
    // Not an object.
    assert!(matches!(Bank::from_json("[1, 2]"), Err(PresetError::Json { .. })));
    // Loading a broken file names the file.
    let path = scratch("broken.json");
    std::fs::write(&path, truncated).unwrap();
    match Material::load(&path) {
        Err(PresetError::Json { what, .. }) => assert!(what.contains("broken.json")),
        other => panic!("expected Json, got {other:?}"),
    }
}

#[test]
fn wrong_schema_version_is_reported_as_such() {
    let m = factory_material("glass-ren2013").unwrap();
    let future = m.to_json().replace("\"schema_version\": 1", "\"schema_version\": 2");
    match Material::from_json(&future) {
        Err(PresetError::SchemaVersion { found, supported }) => {
            assert_eq!((found, supported), (2, SCHEMA_VERSION))
        }
        other => panic!("expected SchemaVersion, got {other:?}"),
    }
    let mut b = small_bank();
    b.schema_version = 7;
    assert!(matches!(b.validate(), Err(PresetError::SchemaVersion { found: 7, .. })));
    assert!(matches!(Bank::from_json(&b.to_json()), Err(PresetError::SchemaVersion { found: 7, .. })));
    let missing = m.to_json().replace("\"schema_version\": 1,", "");
    assert_eq!(invalid_field(Material::from_json(&missing)), "schema_version");
}

#[test]
fn invalid_materials_name_the_field() {
    let good = factory_material("glass-ren2013").unwrap();
    let check = |f: &dyn Fn(&mut Material), field: &str| {
        let mut m = good.clone();
        f(&mut m);
        assert_eq!(invalid_field(m.validate()), field);
        // Also through JSON (NaN is written as null, which is a JSON type error instead).
        if let Err(e) = Material::from_json(&m.to_json()) {
            assert!(matches!(e, PresetError::Invalid { .. } | PresetError::Json { .. }));
        } else {
            panic!("{field}: invalid material parsed");
        }
    };
    check(&|m| m.id.clear(), "id");
    check(&|m| m.id = "Glass Ren".into(), "id");
    check(&|m| m.name = "  ".into(), "name");
    check(&|m| m.specific_modulus = Some(-1.0), "specific_modulus");
    check(&|m| m.specific_modulus = Some(0.0), "specific_modulus");
    check(&|m| m.damping.params = vec![1.0], "damping.params");
    check(&|m| m.damping.params = vec![-1.0, 1e-7], "damping.params[0]");
    check(&|m| m.damping.params = vec![1.0, f64::NAN], "damping.params[1]");
    check(&|m| m.damping = DampingSpec { model: DampingModel::Power, params: vec![1.0, 3.0] }, "damping.params[1]");
    check(
        &|m| m.damping = DampingSpec { model: DampingModel::Hybrid, params: vec![1.0, 1e-7, 0.0] },
        "damping.params[2]",
    );
    check(&|m| m.damping = DampingSpec { model: DampingModel::Caughey, params: vec![-5.0, 1e-7] }, "damping.params");
    check(
        &|m| m.support = Some(presets::SupportDamping { mean_c_per_s: -1.0, recorded_modes: None }),
        "support.mean_c_per_s",
    );
    check(
        &|m| m.support = Some(presets::SupportDamping { mean_c_per_s: 2e5, recorded_modes: None }),
        "support.mean_c_per_s",
    );
    // A valid support round-trips through JSON; a material without one writes no field.
    let mut m = good.clone();
    assert!(!m.to_json().contains("support"));
    m.support = Some(presets::SupportDamping { mean_c_per_s: 12.5, recorded_modes: None });
    assert_eq!(Material::from_json(&m.to_json()).unwrap().support_c(), 12.5);
    // Per-mode support as recorded (issue 10 part 6): every field is checked by name.
    let mode = |mode: usize, lambda: f64, extra: f64| presets::RecordedMode {
        mode,
        lambda,
        extra_c_per_s: extra,
        partials: 1,
    };
    let with_modes = |object: &str, modes: Vec<presets::RecordedMode>| {
        let object = object.to_string();
        move |m: &mut Material| {
            m.support = Some(presets::SupportDamping {
                mean_c_per_s: 3.0,
                recorded_modes: Some(presets::RecordedModes { object: object.clone(), modes: modes.clone() }),
            })
        }
    };
    check(&with_modes("Bar", vec![]), "support.recorded_modes.object");
    check(&with_modes("bar", vec![mode(2, 1e6, 1.0), mode(2, 2e6, 1.0)]), "support.recorded_modes.modes[1].mode");
    check(&with_modes("bar", vec![mode(0, 0.0, 1.0)]), "support.recorded_modes.modes[0].lambda");
    check(
        &with_modes("bar", vec![mode(0, 1e6, 1.0), mode(3, 4e6, -0.5)]),
        "support.recorded_modes.modes[1].extra_c_per_s",
    );
    check(&with_modes("bar", vec![mode(0, 1e6, f64::NAN)]), "support.recorded_modes.modes[0].extra_c_per_s");
    let mut none = mode(1, 1e6, 1.0);
    none.partials = 0;
    check(&with_modes("bar", vec![none]), "support.recorded_modes.modes[0].partials");
    let mut m = good.clone();
    with_modes("bar", vec![mode(0, 1e6, 1.5), mode(4, 9e6, 20.0), mode(9, 1e8, 7.0)])(&mut m);
    let back = Material::from_json(&m.to_json()).unwrap();
    assert_eq!(back, m);
    // Mapped onto a bank: out-of-range indices and moved eigenvalues are left out.
    let lambdas = [1e6, 2e6, 3e6, 4e6, 9.05e6];
    let (extra, skipped) = back.recorded_modes().unwrap().map_onto(&lambdas);
    assert_eq!(skipped, 2, "{extra:?}");
    assert_eq!(extra[0], 1.5);
    assert!(extra[1..].iter().all(|x| x.is_nan()), "{extra:?}");
}

#[test]
fn invalid_banks_name_the_field() {
    let good = small_bank();
    good.validate().unwrap();
    let check = |f: &dyn Fn(&mut Bank), field: &str| {
        let mut b = good.clone();
        f(&mut b);
        assert_eq!(invalid_field(b.validate()), field);
    };
    check(&|b| b.id.clear(), "id");
    check(&|b| b.lambdas[1] = f64::NAN, "lambdas[1]");
    check(&|b| b.lambdas[2] = f64::INFINITY, "lambdas[2]");
    check(&|b| b.lambdas[0] = -1.0, "lambdas[0]");
    check(&|b| b.lambdas[0] = 0.0, "lambdas[0]");
    check(&|b| b.lambdas.swap(0, 2), "lambdas[1]");
    check(&|b| b.lambdas.clear(), "lambdas");
    check(&|b| b.points.clear(), "points");
    check(&|b| b.gains.pop().map(drop).unwrap_or(()), "gains");
    check(&|b| b.gains[1].push(0.5), "gains[1]");
    check(&|b| b.gains[0][1] = f32::NAN, "gains[0][1]");
    check(&|b| b.gains[1][2] = 1.5, "gains[1][2]");
    check(&|b| b.gains.iter_mut().flatten().for_each(|g| *g = 0.0), "gains");
    check(&|b| b.mode_labels.pop().map(drop).unwrap_or(()), "mode_labels");
    check(&|b| b.points[0].xy = [1.5, 0.0], "points[0].xy");
    check(&|b| b.reference.specific_modulus = 0.0, "reference.specific_modulus");
    check(&|b| b.reference.poisson = 0.7, "reference.poisson");
    check(&|b| b.reference.size_m = f64::NAN, "reference.size_m");
    // A captured bank's recorded strike: a mallet the plugin has, hardness 0..=1, velocity 1..=127.
    let strike = |mallet: &str, hardness: f64, velocity: u8| {
        Some(presets::RecordedStrike { mallet: mallet.into(), hardness, velocity })
    };
    check(&|b| b.recorded_strike = strike("hammer", 0.5, 100), "recorded_strike.mallet");
    check(&|b| b.recorded_strike = strike("Wood", 0.5, 100), "recorded_strike.mallet");
    check(&|b| b.recorded_strike = strike("wood", 1.5, 100), "recorded_strike.hardness");
    check(&|b| b.recorded_strike = strike("wood", f64::NAN, 100), "recorded_strike.hardness");
    check(&|b| b.recorded_strike = strike("wood", 0.5, 0), "recorded_strike.velocity");
    check(&|b| b.recorded_strike = strike("wood", 0.5, 128), "recorded_strike.velocity");
    for name in presets::MALLET_NAMES {
        let mut b = good.clone();
        b.recorded_strike = strike(name, 1.0, 127);
        b.validate().unwrap();
        assert_eq!(Bank::from_json(&b.to_json()).unwrap(), b, "{name}");
    }
    // Empty mode labels are allowed.
    let mut b = good.clone();
    b.mode_labels.clear();
    b.validate().unwrap();
    // The JSON path rejects too.
    let mut b = good.clone();
    b.lambdas.swap(0, 1);
    assert_eq!(invalid_field(Bank::from_json(&b.to_json())), "lambdas[1]");
}

/// Fields a file has that this version does not read (a misspelt name, or a field of a
/// newer Struck) load as before, and are listed by path so the CLI and the editor can warn
/// (issue 10: a typo inside a recorded mode was accepted silently). Every factory material
/// and bank, written and read back, has none: reading and writing name the same fields.
#[test]
fn unknown_fields_are_listed_by_path() {
    use presets::{unknown_fields_note, RecordedMode, RecordedModes, SupportDamping};
    let mut m = factory_material("glass-ren2013").unwrap();
    m.support = Some(SupportDamping {
        mean_c_per_s: 2.0,
        recorded_modes: Some(RecordedModes {
            object: "bar".into(),
            modes: vec![RecordedMode { mode: 0, lambda: 1.0e6, extra_c_per_s: 3.0, partials: 2 }],
        }),
    });
    let clean = m.to_json();
    let (back, unknown) = Material::from_json_listing_unknown(&clean).unwrap();
    assert_eq!(back, m);
    assert!(unknown.is_empty(), "{unknown:?}");
    assert_eq!(unknown_fields_note(&unknown), None);

    let typo = |text: &str, at: &str, insert: &str| {
        assert_eq!(text.matches(at).count(), 1, "{at}");
        text.replacen(at, &format!("{insert}{at}"), 1)
    };
    let mut bad = typo(&clean, "\"name\"", "\"gama\": 1.2, ");
    bad = typo(&bad, "\"model\"", "\"parms\": [1, 2], ");
    bad = typo(&bad, "\"partials\"", "\"extra_c\": 9, ");
    let (read, unknown) = Material::from_json_listing_unknown(&bad).unwrap();
    assert_eq!(read, m, "unknown fields change nothing");
    assert_eq!(Material::from_json(&bad).unwrap(), m);
    assert_eq!(unknown, ["gama", "damping.parms", "support.recorded_modes.modes.0.extra_c"]);
    let note = unknown_fields_note(&unknown).unwrap();
    assert!(note.starts_with("ignored 3 unknown fields `gama`, `damping.parms`,"), "{note}");
    let many: Vec<String> = (0..7).map(|i| format!("f{i}")).collect();
    assert!(unknown_fields_note(&many).unwrap().contains("`f3`, and 3 more"));
    let long = unknown_fields_note(&["é".repeat(5000)]).unwrap();
    assert!(long.contains(&format!("`{}…`", "é".repeat(80))) && long.len() < 400, "{long}");

    let path = scratch("unknown-fields.json");
    std::fs::write(&path, &bad).unwrap();
    let (_, unknown) = Material::load_listing_unknown(&path).unwrap();
    assert_eq!(unknown.len(), 3);

    for b in presets::factory_banks() {
        let (back, unknown) = Bank::from_json_listing_unknown(&b.to_json()).unwrap();
        assert!(unknown.is_empty() && back == b, "{}: {unknown:?}", b.id);
    }
    for &(id, text) in presets::factory::FACTORY_FEM_BANKS {
        let (_, unknown) = Bank::from_json_listing_unknown(text).unwrap();
        assert!(unknown.is_empty(), "{id}: {unknown:?}");
    }
    for m in presets::factory_materials() {
        let (_, unknown) = Material::from_json_listing_unknown(&m.to_json()).unwrap();
        assert!(unknown.is_empty(), "{}: {unknown:?}", m.id);
    }
    // A misspelt required field: the error says it is missing and names the unknown one.
    let missing = clean.replacen("\"damping\"", "\"dampign\"", 1);
    match Material::from_json(&missing) {
        Err(PresetError::Json { message, .. }) => {
            assert!(message.contains("`damping`") && message.contains("`dampign`"), "{message}");
        }
        other => panic!("expected a JSON error, got {other:?}"),
    }
    let odd = typo(&clean, "\"name\"", "\"a\\nb\": 1, ");
    let (_, unknown) = Material::from_json_listing_unknown(&odd).unwrap();
    assert_eq!(unknown, ["a\\nb"], "one line");
    let bank = small_bank();
    let bad = typo(&bank.to_json(), "\"points\"", "\"mode_label\": [], ");
    let (_, unknown) = Bank::from_json_listing_unknown(&bad).unwrap();
    assert_eq!(unknown, ["mode_label"]);
    // A key given twice is listed once; a key with a dot is quoted (not a nested path).
    let twice = typo(&clean, "\"name\"", "\"gama\": 1, \"gama\": 2, \"a.b\": 3, ");
    let (_, unknown) = Material::from_json_listing_unknown(&twice).unwrap();
    assert_eq!(unknown, ["gama", "\"a.b\""]);
}

/// Windows editors (Notepad) start a UTF-8 file with a byte-order mark: it loads.
#[test]
fn a_preset_file_with_a_byte_order_mark_loads() {
    let m = factory_material("glass-ren2013").unwrap();
    let text = format!("\u{feff}{}", m.to_json());
    assert_eq!(Material::from_json(&text).unwrap(), m);
    let path = scratch("bom-material.json");
    std::fs::write(&path, text.as_bytes()).unwrap();
    assert_eq!(Material::load(&path).unwrap(), m);
    let b = small_bank();
    assert_eq!(Bank::from_json(&format!("\u{feff}{}", b.to_json())).unwrap(), b);
}

/// A recording or a MIDI file given where a material or bank is read is named as what it is
/// (a black-box tester: `bank info take.wav` was told to save it "as UTF-8 in your editor").
#[test]
fn a_recording_given_as_a_preset_is_named() {
    let mut wav = b"RIFF\x24\x00\x00\x00WAVEfmt ".to_vec();
    wav.extend_from_slice(&[0x10, 0, 0, 0, 1, 0, 1, 0, 0x44, 0xac, 0, 0, 0x88, 0x58, 1, 0, 2, 0, 16, 0]);
    wav.extend_from_slice(b"data\x00\x00\x00\x00");
    let mid = b"MThd\x00\x00\x00\x06\x00\x00\x00\x01\x01\xe0".to_vec();
    for (name, bytes, says) in [("take.wav", wav, "a WAV recording"), ("song.mid", mid, "a MIDI file")] {
        let path = scratch(name);
        std::fs::write(&path, &bytes).unwrap();
        for err in [Material::load(&path).unwrap_err(), Bank::load(&path).unwrap_err()] {
            let msg = err.to_string();
            assert!(matches!(err, PresetError::NotAPreset { .. }), "{name}: {msg}");
            assert!(msg.contains(name) && msg.contains(says) && msg.contains("not a material or bank"), "{msg}");
            assert!(!msg.contains("UTF-8") && !msg.contains('\n'), "{msg}");
        }
    }
}

/// A preset saved in another encoding (UTF-16 from a Windows editor, with or without its
/// byte-order mark; Latin-1) is refused with an error that names the encoding and the file,
/// not a "could not access" one (the black-box tester's finding).
#[test]
fn a_preset_file_in_another_encoding_says_so() {
    let text = factory_material("glass-ren2013").unwrap().to_json();
    let utf16: Vec<u8> = text.encode_utf16().flat_map(|u| u.to_le_bytes()).collect();
    let with_bom: Vec<u8> = [0xff, 0xfe].into_iter().chain(utf16.iter().copied()).collect();
    let latin1: Vec<u8> = text.replacen("\"name\": \"", "\"name\": \"caf\u{e9} ", 1).chars().map(|c| c as u8).collect();
    // A NUL in the middle of UTF-8 text (a damaged file): named, with its line.
    let mut damaged = text.clone().into_bytes();
    let at = damaged.iter().enumerate().filter(|(_, &b)| b == b'\n').nth(7).unwrap().0 + 3;
    damaged[at] = 0;
    for (name, bytes, says) in [
        ("utf16-bom.json", with_bom, "UTF-16"),
        ("utf16.json", utf16, "UTF-16"),
        ("latin1.json", latin1, "byte 0xe9"),
        ("nul.json", damaged, "NUL byte at offset"),
    ] {
        let path = scratch(name);
        std::fs::write(&path, &bytes).unwrap();
        for err in [Material::load(&path).unwrap_err(), Bank::load(&path).unwrap_err()] {
            let msg = err.to_string();
            assert!(matches!(err, PresetError::Encoding { .. }), "{name}: {msg}");
            assert!(msg.contains(name) && msg.contains("not UTF-8") && msg.contains(says), "{name}: {msg}");
            assert!(name != "nul.json" || msg.contains("(line 9)"), "{msg}");
            assert!(!msg.contains('\n'), "{msg}");
        }
    }
}
