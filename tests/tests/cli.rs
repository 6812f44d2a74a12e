//! The command line's renderer: MIDI files, note timing and WAV output.

use struck_cli::cli::{render, RenderOptions, SoundOptions};

/// A format-0 MIDI file (96 ppq, 120 bpm): a note-on after `delay_ticks`.
fn midi_file(delay_ticks: u8, key: u8) -> Vec<u8> {
    let trk = [
        0x00,
        0xFF,
        0x51,
        0x03,
        0x07,
        0xA1,
        0x20,
        delay_ticks,
        0x90,
        key,
        100,
        0x60,
        0x80,
        key,
        0,
        0x00,
        0xFF,
        0x2F,
        0x00,
    ];
    let mut f = b"MThd\x00\x00\x00\x06\x00\x00\x00\x01\x00\x60MTrk".to_vec();
    f.extend((trk.len() as u32).to_be_bytes());
    f.extend(trk);
    f
}

#[test]
fn a_midi_file_note_starts_at_its_time_in_the_wav() {
    let dir = std::env::temp_dir();
    let mid = dir.join(format!("struck-cli-{}.mid", std::process::id()));
    let wav = dir.join(format!("struck-cli-{}.wav", std::process::id()));
    // 48 ticks at 96 ppq and 120 bpm = 0.25 s.
    std::fs::write(&mid, midi_file(48, 64)).unwrap();
    let opts = RenderOptions {
        sound: SoundOptions { sample_rate: 44_100, ..SoundOptions::default() },
        notes: None,
        midi: Some(mid.clone()),
        seconds: Some(1.0),
        block_size: 300,
        out: wav.clone(),
        normalize: None,
        gesture: Default::default(),
    };
    render(&opts).unwrap();
    let mut r = hound::WavReader::open(&wav).unwrap();
    let spec = r.spec();
    assert_eq!((spec.channels, spec.sample_rate, spec.bits_per_sample), (2, 44_100, 32));
    let x: Vec<f32> = r.samples::<f32>().map(Result::unwrap).step_by(2).collect();
    assert_eq!(x.len(), 44_100);
    let first = x.iter().position(|v| *v != 0.0).unwrap();
    // The strike lands on the note-on's sample (the sine starts one sample later).
    assert!((11_025..=11_027).contains(&first), "first sound at sample {first}");
    assert!(x[..11_025].iter().all(|v| *v == 0.0));
    let _ = std::fs::remove_file(mid);
    let _ = std::fs::remove_file(wav);
}

#[test]
fn unwritable_output_and_bad_midi_are_one_line_errors() {
    let opts = RenderOptions {
        sound: SoundOptions::default(),
        notes: Some("60:100".into()),
        midi: None,
        seconds: Some(0.1),
        block_size: 64,
        out: "/nonexistent-dir/x.wav".into(),
        normalize: None,
        gesture: Default::default(),
    };
    let e = render(&opts).unwrap_err();
    assert!(e.starts_with("cannot write /nonexistent-dir/x.wav") && !e.contains('\n'), "{e}");
    let bad = std::env::temp_dir().join(format!("struck-bad-{}.mid", std::process::id()));
    std::fs::write(&bad, b"MThd garbage").unwrap();
    let opts = RenderOptions {
        midi: Some(bad.clone()),
        notes: None,
        out: std::env::temp_dir().join("struck-never.wav"),
        ..opts
    };
    let e = render(&opts).unwrap_err();
    assert!(e.contains("not a readable MIDI file"), "{e}");
    let _ = std::fs::remove_file(bad);
}

#[test]
fn a_bank_file_given_as_the_object_plays_like_the_listed_bank() {
    let dir = std::env::temp_dir();
    let pid = std::process::id();
    // The factory bar saved as a user's bank file under another id.
    let lib = struck::library::Library::factory();
    let mut bank = lib.banks[lib.bank_index("bar").unwrap()].clone();
    bank.id = "my-bar".into();
    bank.name = "My bar".into();
    let file = dir.join(format!("struck-cli-bank-{pid}.json"));
    bank.save(&file).unwrap();
    let run = |object: &str, name: &str| {
        let wav = dir.join(format!("struck-cli-bank-{pid}-{name}.wav"));
        let opts = RenderOptions {
            sound: SoundOptions { object: object.into(), ..SoundOptions::default() },
            notes: Some("60:100@0.3".into()),
            midi: None,
            seconds: Some(0.5),
            block_size: 256,
            out: wav.clone(),
            normalize: None,
            gesture: Default::default(),
        };
        render(&opts).map(|_| {
            let x: Vec<f32> = hound::WavReader::open(&wav).unwrap().samples::<f32>().map(Result::unwrap).collect();
            let _ = std::fs::remove_file(&wav);
            x
        })
    };
    let from_file = run(file.to_str().unwrap(), "file").unwrap();
    let listed = run("bar", "listed").unwrap();
    assert!(from_file.iter().any(|v| *v != 0.0));
    assert!(from_file == listed, "the bank file does not play like the same bank listed");

    // Missing and broken bank files are one-line errors naming the problem.
    let e = run("/nonexistent/bank.json", "missing").unwrap_err();
    assert!(e.contains("/nonexistent/bank.json") && !e.contains('\n'), "{e}");
    std::fs::write(&file, "{\"schema_version\": 1, \"id\": \"x\"").unwrap();
    let e = run(file.to_str().unwrap(), "broken").unwrap_err();
    assert!(!e.contains('\n') && !e.is_empty(), "{e}");
    let _ = std::fs::remove_file(&file);
}

/// A closed OBJ box (0.2 × 0.03 × 0.02 m, outward triangles).
fn box_obj() -> String {
    let (l, w, h) = (0.2, 0.03, 0.02);
    let mut s = String::new();
    for x in [0.0, l] {
        for y in [0.0, w] {
            for z in [0.0, h] {
                s += &format!("v {x} {y} {z}\n");
            }
        }
    }
    let v = |x: usize, y: usize, z: usize| x * 4 + y * 2 + z + 1;
    let quads = [
        [v(0, 0, 0), v(0, 0, 1), v(0, 1, 1), v(0, 1, 0)],
        [v(1, 0, 0), v(1, 1, 0), v(1, 1, 1), v(1, 0, 1)],
        [v(0, 0, 0), v(1, 0, 0), v(1, 0, 1), v(0, 0, 1)],
        [v(0, 1, 0), v(0, 1, 1), v(1, 1, 1), v(1, 1, 0)],
        [v(0, 0, 0), v(0, 1, 0), v(1, 1, 0), v(1, 0, 0)],
        [v(0, 0, 1), v(1, 0, 1), v(1, 1, 1), v(0, 1, 1)],
    ];
    for q in quads {
        s += &format!("f {} {} {} {}\n", q[0], q[1], q[2], q[3]);
    }
    s
}

#[test]
fn bank_build_from_an_obj_surface_then_render_it() {
    use struck_cli::banks::{run, BankCommand, BankOutput, MaterialArgs};
    let dir = std::env::temp_dir();
    let pid = std::process::id();
    let obj = dir.join(format!("struck-cli-box-{pid}.obj"));
    std::fs::write(&obj, box_obj()).unwrap();
    let bank_file = dir.join(format!("struck-cli-box-{pid}.json"));
    let build = |mesh: std::path::PathBuf| BankCommand::Build {
        shape: None,
        dims: None,
        mesh: Some(mesh),
        scale: None,
        mesher: None,
        no_remesh: false,
        modes: 12,
        max_freq: None,
        material: MaterialArgs { young: 200e9, density: 7850.0, poisson: 0.3 },
        resolution: Some(40),
        accuracy: None,
        output: BankOutput { points: 64, id: None, name: None, out: bank_file.clone() },
    };
    run(build(obj.clone())).unwrap();
    let bank = presets::Bank::load(&bank_file).unwrap();
    assert_eq!(bank.lambdas.len(), 12);
    assert!(bank.points.len() >= 64);
    // First bending mode across the 2 cm thickness against Euler–Bernoulli (free–free,
    // β₁L = 4.730): 4 voxels through the thickness at resolution 40 keep it within 5 %.
    let (l, h, e, rho) = (0.2f64, 0.02f64, 200e9f64, 7850.0f64);
    let f_eb = 4.730f64.powi(2) / (2.0 * std::f64::consts::PI * l * l) * (e * h * h / (12.0 * rho)).sqrt();
    let f1 = bank.lambdas[0].sqrt() / std::f64::consts::TAU;
    assert!((f1 / f_eb - 1.0).abs() < 0.05, "f1 {f1:.1} Hz vs Euler–Bernoulli {f_eb:.1} Hz");

    // The bank file plays.
    let wav = dir.join(format!("struck-cli-box-{pid}.wav"));
    let opts = RenderOptions {
        sound: SoundOptions { object: bank_file.display().to_string(), ..SoundOptions::default() },
        notes: Some("60:100".into()),
        midi: None,
        seconds: Some(0.3),
        block_size: 128,
        out: wav.clone(),
        normalize: None,
        gesture: Default::default(),
    };
    render(&opts).unwrap();
    let x: Vec<f32> = hound::WavReader::open(&wav).unwrap().samples::<f32>().map(Result::unwrap).collect();
    assert!(x.iter().any(|v| v.abs() > 1e-3));

    // An open surface is refused with the reason.
    let open = dir.join(format!("struck-cli-open-{pid}.obj"));
    // Without its bottom face (z = 0) the box is open.
    let text = box_obj().replacen("f 1 3 7 5\n", "", 1);
    assert_ne!(text, box_obj());
    std::fs::write(&open, text).unwrap();
    let e = run(build(open.clone())).unwrap_err();
    assert!(e.contains("not closed"), "{e}");
    for f in [obj, open, bank_file, wav] {
        let _ = std::fs::remove_file(f);
    }
}

/// `--set` takes a stepped parameter's option by name, as the README writes it
/// (`--set support=off`), without case, spaces or hyphens; a switch takes on/off; a name that
/// is no option is refused naming the options.
#[test]
fn set_takes_options_by_name() {
    let host = |set: &[&str]| {
        let opts = SoundOptions { set: set.iter().map(|s| s.to_string()).collect(), ..SoundOptions::default() };
        struck_cli::cli::configured_host(&opts, 64)
    };
    let value = |set: &[&str], id: &str| host(set).expect("valid options").param(id).expect("param");
    assert_eq!(value(&["support=off"], "support"), 0.0);
    assert_eq!(value(&["support=As recorded"], "support"), 1.0);
    assert_eq!(value(&["support=as-recorded"], "support"), 1.0);
    assert_eq!(value(&["support=AMOUNT"], "support"), 2.0);
    assert_eq!(value(&["support=2"], "support"), 2.0);
    assert_eq!(value(&["keytune=off"], "keytune"), 0.0);
    assert_eq!(value(&["keytune=on"], "keytune"), 1.0);
    // The object and material by id, through their own parsers.
    let lib = struck::library::Library::factory();
    assert_eq!(value(&["object=fem-bar"], "object"), lib.bank_index("fem-bar").expect("fem-bar") as f32);
    assert_eq!(value(&["material=wood-ren2013"], "material"), lib.material_index("wood-ren2013").expect("wood") as f32);
    let err = host(&["support=sideways"]).err().expect("no such option");
    assert!(err.contains("Off") && err.contains("As recorded") && err.contains("Amount"), "{err}");
    let err = host(&["size=big"]).err().expect("not a number");
    assert!(err.contains("takes a number"), "{err}");
    assert!(host(&["support=7"]).is_err());
}
