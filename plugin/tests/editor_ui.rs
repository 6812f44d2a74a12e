//! The real editor UI driven headlessly with egui_kittest: the same `EditorUi::ui` the plugin
//! window draws, with a `ParamSetter` over a recording GUI context instead of the host's.
//!
//! With the `editor-screenshots` feature (`cargo test -p struck --test editor_ui --features
//! editor-screenshots`), screenshots of the main views go to
//! `$CARGO_TARGET_TMPDIR/editor-screenshots/` when a wgpu adapter is available (on Linux:
//! Mesa's lavapipe, package `mesa-vulkan-drivers`); without one they are skipped with a note,
//! and the tests still run. The tests' build leaves the feature off (no test looks at them).

// PANIC: in these tests each `expect` is an assertion; its message names what was missing.

use egui_kittest::kittest::Queryable;
use egui_kittest::Harness;
use nice_plug::prelude::*;
use std::path::PathBuf;
use std::sync::Arc;
use struck::editor::testing::{Gesture, RecordingContext};
use struck::editor::{EditorUi, Tab};
use struck::Struck;

/// A file dropped on the window (what the windowing layer hands egui).
#[derive(Debug)]
struct Dropped(PathBuf);
impl egui::DroppedFile for Dropped {
    fn path(&self) -> &std::path::Path {
        &self.0
    }
    fn bytes(&self) -> Result<Vec<u8>, String> {
        std::fs::read(&self.0).map_err(|e| e.to_string())
    }
}

struct State {
    ui: EditorUi,
    ctx: Arc<RecordingContext>,
}

fn harness(plugin: &Struck) -> Harness<'static, State> {
    harness_sized(plugin, 720.0)
}

/// A harness `height` points tall (the capture results need more than the default window).
fn harness_sized(plugin: &Struck, height: f32) -> Harness<'static, State> {
    let params = plugin.struck_params().clone();
    let ctx = Arc::new(RecordingContext::new(params.clone()));
    let ui = EditorUi::new(params, plugin.library().clone(), plugin.editor_shared().clone());
    Harness::builder().with_size([1040.0, height]).build_ui_state(
        |ui, s: &mut State| {
            let setter = ParamSetter::new(&*s.ctx);
            s.ui.ui(ui, &setter);
        },
        State { ui, ctx },
    )
}

fn tmp(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("struck-editor-test-{}-{name}", std::process::id()))
}

/// Saves a screenshot if a renderer is available; never fails the test.
#[cfg(feature = "editor-screenshots")]
fn screenshot(h: &mut Harness<'_, State>, name: &str) {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("editor-screenshots");
    let _ = std::fs::create_dir_all(&dir);
    let out = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| h.render()));
    match out {
        Ok(Ok(img)) => {
            let path = dir.join(format!("{name}.png"));
            match img.save(&path) {
                Ok(()) => println!("screenshot: {}", path.display()),
                Err(e) => println!("screenshot {name} not saved: {e}"),
            }
        }
        Ok(Err(e)) => println!("screenshot {name} skipped: no renderer ({e})"),
        Err(_) => println!("screenshot {name} skipped: the wgpu renderer panicked (no adapter?)"),
    }
}

/// Without the `editor-screenshots` feature: nothing (the views are still drawn and queried).
#[cfg(not(feature = "editor-screenshots"))]
fn screenshot(_: &mut Harness<'_, State>, _: &str) {}

/// The object view's picture of the current object (`editor/drawing.rs`).
fn picture(plugin: &Struck) -> struck::editor::drawing::ObjectDrawing {
    let bank = &plugin.library().banks[plugin.struck_params().object.value() as usize];
    struck::editor::drawing::object_drawing(bank)
}

/// Screen position of strike point `i` of the current object in the object view (the
/// mapping of `editor/object.rs`: the picture fitted into the view less a 12 px margin and a
/// 22 px label line, centred, y up).
fn point_on_screen(h: &Harness<'_, State>, plugin: &Struck, i: usize) -> egui::Pos2 {
    let rect = h.get_by_label("Object view").rect();
    let area = egui::Rect::from_min_max(rect.min + egui::vec2(12.0, 22.0), rect.max - egui::vec2(12.0, 12.0));
    let pic = picture(plugin);
    let scale = (area.width() / pic.size[0]).min(area.height() / pic.size[1]);
    let q = pic.points[i];
    let c = area.center();
    egui::pos2(c.x + (q[0] - 0.5 * pic.size[0]) * scale, c.y - (q[1] - 0.5 * pic.size[1]) * scale)
}

/// A strike point the camera sees whose drawing position no other point shares.
fn distinct_point(plugin: &Struck, avoid: usize) -> usize {
    let pic = picture(plugin);
    let n = pic.points.len();
    (0..n)
        .rev()
        .find(|&i| i != avoid && pic.visible[i] && pic.points.iter().filter(|p| **p == pic.points[i]).count() == 1)
        .expect("a distinct strike point")
}

#[test]
fn clicking_a_strike_point_sets_the_position_and_strikes() {
    let plugin = Struck::default();
    let mut h = harness(&plugin);
    h.run_steps(2);
    screenshot(&mut h, "play");
    let n = plugin.library().banks[0].points.len();
    let k = distinct_point(&plugin, usize::MAX);
    let at = point_on_screen(&h, &plugin, k);
    h.hover_at(at);
    h.run_steps(1);
    h.drag_at(at);
    h.run_steps(2);
    h.drop_at(at);
    h.run_steps(2);

    let want = k as f32 / (n - 1) as f32;
    let got = plugin.struck_params().strike_position.value();
    assert!((got - want).abs() < 1e-6, "position {got}, expected point {k} of {n} = {want}");
    let ctx = h.state().ctx.clone();
    let g = ctx.gestures();
    assert_eq!(g.first(), Some(&Gesture::Begin("pos".into())), "{g:?}");
    assert_eq!(g.last(), Some(&Gesture::End("pos".into())), "{g:?}");
    assert!(ctx.gestures_well_formed(), "{g:?}");
    // One strike queued for the audio thread, at that position.
    let a = plugin.editor_shared().audition.pop().expect("an audition note was queued");
    assert!((a.position - want).abs() < 1e-6);
    assert!(a.velocity > 0.0 && a.key == 60);
    assert!(plugin.editor_shared().audition.pop().is_none(), "one click, one strike");
}

/// A right click on a strike point holds the object there (issue 10 part 6): *Support point*
/// becomes that point and *Held at a point* turns on, each as one host gesture, and since the
/// default glass records no support damping, *Support* becomes *Amount*; the strike position
/// does not move and nothing strikes.
#[test]
fn right_clicking_a_point_holds_the_object_there() {
    let plugin = Struck::default();
    let mut h = harness(&plugin);
    h.run_steps(2);
    let n = plugin.library().banks[0].points.len();
    let k = distinct_point(&plugin, usize::MAX);
    let at = point_on_screen(&h, &plugin, k);
    let position = plugin.struck_params().strike_position.value();
    h.hover_at(at);
    h.run_steps(1);
    for pressed in [true, false] {
        h.input_mut().events.push(egui::Event::PointerButton {
            pos: at,
            button: egui::PointerButton::Secondary,
            pressed,
            modifiers: egui::Modifiers::NONE,
        });
        h.run_steps(1);
    }
    h.run_steps(1);
    let p = plugin.struck_params();
    let want = k as f32 / (n - 1) as f32;
    assert!((p.support_point.value() - want).abs() < 1e-6, "support {} vs point {k} = {want}", p.support_point.value());
    assert!(p.support_at_point.value());
    assert_eq!(p.support_mode.value(), struck::params::SupportMode::Amount);
    assert_eq!(p.strike_position.value(), position, "a right click does not strike");
    assert!(plugin.editor_shared().audition.pop().is_none(), "a right click does not strike");
    let ctx = h.state().ctx.clone();
    let g = ctx.gestures();
    assert!(g.contains(&Gesture::Begin("supportpt".into())) && g.contains(&Gesture::End("supportat".into())), "{g:?}");
    assert!(ctx.gestures_well_formed(), "{g:?}");
}

#[test]
fn dragging_across_points_is_one_gesture_striking_each_point() {
    let plugin = Struck::default();
    let mut h = harness(&plugin);
    h.run_steps(2);
    let a = distinct_point(&plugin, usize::MAX);
    let b = distinct_point(&plugin, a);
    let (pa, pb) = (point_on_screen(&h, &plugin, a), point_on_screen(&h, &plugin, b));
    h.hover_at(pa);
    h.run_steps(1);
    h.drag_at(pa);
    h.run_steps(1);
    for t in 1..=4 {
        h.hover_at(pa + (pb - pa) * (t as f32 / 4.0));
        h.run_steps(1);
    }
    h.drop_at(pb);
    h.run_steps(2);
    let g = h.state().ctx.gestures();
    assert_eq!(g.iter().filter(|x| matches!(x, Gesture::Begin(_))).count(), 1, "{g:?}");
    assert!(h.state().ctx.gestures_well_formed(), "{g:?}");
    let n = plugin.library().banks[0].points.len();
    assert!((plugin.struck_params().strike_position.value() - b as f32 / (n - 1) as f32).abs() < 1e-6);
    let mut strikes = 0;
    while plugin.editor_shared().audition.pop().is_some() {
        strikes += 1;
    }
    assert!(strikes >= 2, "{strikes} strikes");
}

#[test]
fn a_param_slider_changes_its_parameter_through_a_gesture() {
    let plugin = Struck::default();
    let mut h = harness(&plugin);
    h.run_steps(2);
    let before = plugin.struck_params().noise.value();
    let rect = h.get_by_label("Noise slider").rect();
    let at = egui::pos2(rect.left() + 0.6 * rect.width().min(170.0), rect.center().y);
    h.hover_at(at);
    h.run_steps(1);
    h.drag_at(at);
    h.run_steps(1);
    h.drop_at(at);
    h.run_steps(2);
    let after = plugin.struck_params().noise.value();
    assert!((after - before).abs() > 0.1, "noise {before} → {after}");
    let g = h.state().ctx.gestures();
    assert!(g.contains(&Gesture::Begin("noise".into())), "{g:?}");
    assert!(g.iter().any(|x| matches!(x, Gesture::Set(id, _) if id == "noise")), "{g:?}");
}

#[test]
fn choosing_a_material_from_the_list_sets_the_material_parameter() {
    let plugin = Struck::default();
    let mut h = harness(&plugin);
    h.run_steps(2);
    h.get_by_role_and_label(egui::accesskit::Role::ComboBox, "Material").click();
    h.run_steps(2);
    h.get_by_label("Custom (the knobs below)").click_accesskit();
    h.run_steps(2);
    let custom = plugin.library().custom_material_index() as i32;
    assert_eq!(plugin.struck_params().material.value(), custom);
    assert!(h.state().ctx.gestures_well_formed());
}

/// A user material with a field Struck does not read loads into *Custom* and the panel says
/// which field was ignored (issue 10: a misspelt field played its default silently).
#[test]
fn a_user_material_with_a_misspelt_field_loads_and_says_so() {
    let dir = tmp("user-materials-typo");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("user folder");
    let mut m = presets::factory_material("wood-ren2013").expect("wood");
    m.name = "My wood".into();
    let text = m.to_json().replacen("\"name\"", "\"gama\": 1.2, \"name\"", 1);
    std::fs::write(dir.join("my-wood.json"), text).expect("write");
    let plugin = Struck::default();
    let mut h = harness(&plugin);
    h.state_mut().ui.user_material_dir = Some(dir.clone());
    h.run_steps(1);
    // (The first frame listed the default folder.)
    h.get_by_label("Rescan").click();
    h.run_steps(2);
    h.get_by_role_and_label(egui::accesskit::Role::ComboBox, "Material").click();
    h.run_steps(2);
    h.get_by_label("My wood").click_accesskit();
    h.run_steps(2);
    let custom = plugin.library().custom_material_index() as i32;
    assert_eq!(plugin.struck_params().material.value(), custom);
    let _ = h.get_by_label_contains("my-wood.json: ignored 1 unknown field `gama`");
    let _ = std::fs::remove_dir_all(&dir);
}

fn render_taps(name: &str) -> PathBuf {
    let wav = tmp(name);
    let opts = struck_cli::cli::RenderOptions {
        sound: struck_cli::cli::SoundOptions {
            object: "circular-plate".into(),
            material: "steel-sterling-rayleigh".into(),
            ..Default::default()
        },
        notes: Some("48:110@0.1,55:110@0.45+1.5,50:120@0.8+3".into()),
        midi: None,
        seconds: Some(4.5),
        block_size: 512,
        out: wav.clone(),
        normalize: None,
        gesture: Default::default(),
    };
    struck_cli::cli::render(&opts).expect("render the taps");
    wav
}

#[test]
fn files_arrive_by_path_field_browser_and_drop_and_a_capture_applies_and_persists() {
    let plugin = Struck::default();
    let wav = render_taps("taps.wav");
    let mut h = harness_sized(&plugin, 1100.0);
    h.state_mut().ui.tab = Tab::Capture;
    h.run_steps(2);
    screenshot(&mut h, "capture-empty");

    // A bad path is refused with a reason.
    h.get_by_label("Recording path").type_text("/nonexistent/x.wav");
    h.run_steps(1);
    h.get_by_label("Add").click();
    h.run_steps(2);
    assert!(h.state().ui.capture_files().is_empty());
    assert!(h.state().ui.capture_message().is_some_and(|m| m.contains("not a file")));

    // A dropped file is added.
    h.input_mut().dropped_files.push(Arc::new(Dropped(wav.clone())));
    h.run_steps(2);
    assert_eq!(h.state().ui.capture_files(), std::slice::from_ref(&wav));
    // The same file again through the path field: no duplicate.
    h.get_by_label("Recording path").type_text(&wav.display().to_string());
    h.run_steps(1);
    h.get_by_label("Add").click();
    h.run_steps(2);
    assert_eq!(h.state().ui.capture_files(), std::slice::from_ref(&wav));

    // Analyse on the background thread, then pick up the result.
    h.get_by_label("Analyse").click();
    h.run_steps(2);
    h.state_mut().ui.wait_for_capture();
    h.run_steps(3);
    assert!(h.state().ui.capture_message().is_none(), "{:?}", h.state().ui.capture_message());
    let params = plugin.struck_params().clone();
    {
        let cap = params.capture.lock().expect("capture lock");
        let rec = cap.as_ref().expect("a capture result");
        assert!(!rec.report.impacts.is_empty() && rec.report.fits.len() >= 2);
        assert_eq!(rec.files, [wav.display().to_string()]);
    }
    screenshot(&mut h, "capture-results");

    // Apply: Custom material with the fitted law, one closed gesture per parameter.
    h.state().ctx.clear();
    h.get_by_label("Apply").click();
    h.run_steps(2);
    assert_eq!(params.material.value(), plugin.library().custom_material_index() as i32);
    let g = h.state().ctx.gestures();
    for id in ["material", "dmodel", "alpha1", "c1k", "expo", "c10k"] {
        assert_eq!(g.iter().filter(|x| **x == Gesture::Begin(id.into())).count(), 1, "{id}: {g:?}");
    }
    assert!(h.state().ctx.gestures_well_formed(), "{g:?}");
    let fitted = params.capture.lock().expect("lock").as_ref().expect("capture").report.damping();
    let played = plugin.sound_params().damping;
    let l = (std::f64::consts::TAU * 1000.0f64).powi(2);
    assert!((played.c(l) / fitted.c(l) - 1.0).abs() < 1e-3, "{played:?} vs {fitted:?}");

    // The capture is part of the plugin state: a fresh instance loading it shows it.
    let fields = params.serialize_fields();
    assert!(fields.contains_key("capture"));
    let other = Struck::default();
    other.struck_params().deserialize_fields(&fields);
    assert_eq!(*other.struck_params().capture.lock().expect("lock"), *params.capture.lock().expect("lock"));
    let mut h2 = harness(&other);
    h2.state_mut().ui.tab = Tab::Capture;
    h2.run_steps(2);
    let _ = h2.get_by_label("Capture scatter");
    let _ = std::fs::remove_file(&wav);
}

#[test]
fn save_material_writes_a_loadable_user_preset() {
    // Separate user folder for this test.
    let dir = tmp("user-materials");
    let plugin = Struck::default();
    let wav = render_taps("taps-save.wav");
    let mut h = harness_sized(&plugin, 1100.0);
    h.state_mut().ui.user_material_dir = Some(dir.clone());
    h.state_mut().ui.tab = Tab::Capture;
    h.state_mut().ui.add_capture_file(wav.clone()).expect("add");
    h.run_steps(1);
    h.get_by_label("Analyse").click();
    h.run_steps(1);
    h.state_mut().ui.wait_for_capture();
    h.run_steps(2);
    // A law the Custom knobs cannot hold (base damping over their 2000 1/s) is not saved: a
    // user material loads into those knobs, and this one would be refused when chosen.
    let params = plugin.struck_params();
    let analysed = params.capture.lock().expect("lock").clone().expect("a capture");
    let mut beyond = analysed.clone();
    for f in beyond.report.fits.iter_mut().chain(std::iter::once(&mut beyond.report.chosen)) {
        f.params[0] = 5000.0;
    }
    *params.capture.lock().expect("lock") = Some(beyond);
    h.run_steps(1);
    h.get_by_label("Save material").click();
    h.run_steps(2);
    let m = h.state().ui.capture_message().unwrap_or_default().to_string();
    assert!(m.starts_with("not saved: ") && m.contains("outside the plugin's range"), "{m}");
    assert!(std::fs::read_dir(&dir).map_or(true, |mut d| d.next().is_none()), "a file was written");
    *params.capture.lock().expect("lock") = Some(analysed);
    h.run_steps(1);
    h.get_by_label("Save material").click();
    h.run_steps(2);
    let files: Vec<_> =
        std::fs::read_dir(&dir).expect("user folder").filter_map(Result::ok).map(|e| e.path()).collect();
    assert_eq!(files.len(), 1, "{files:?}");
    let m = presets::Material::load(&files[0]).expect("a valid material");
    assert!(m.id.starts_with("captured-") && m.provenance.contains("taps-save.wav"), "{m:?}");
    let _ = std::fs::remove_dir_all(&dir);
    let _ = std::fs::remove_file(&wav);
}

/// An object that rings for minutes (a singing bowl: five partials decaying at 0.01–0.04 1/s,
/// a Rayleigh law) is hum to the extractor's default minimum decay (0.05 1/s, thesis §4.2.2):
/// the panel says so, and with its *Minimum decay* field at 0.005 the analysis finds the five
/// partials and the law they were written with (α₁ within 5 %).
#[test]
fn the_minimum_decay_field_captures_an_object_that_rings_for_minutes() {
    let wav = tmp("min-decay-bowl.wav");
    let spec = hound::WavSpec {
        channels: 1,
        sample_rate: 44_100,
        bits_per_sample: 32,
        sample_format: hound::SampleFormat::Float,
    };
    let mut w = hound::WavWriter::create(&wav, spec).expect("create");
    let partials = [(440.0, 0.4), (1187.0, 0.2), (2213.0, 0.12), (3490.0, 0.08), (5011.0, 0.05)];
    let decay = |f: f64| 0.01 + 0.03 * (f / 5011.0f64).powi(2);
    for i in 0..8 * 44_100 {
        let t = f64::from(i) / 44_100.0;
        let x: f64 =
            partials.iter().map(|&(f, a)| a * (-decay(f) * t).exp() * (std::f64::consts::TAU * f * t).sin()).sum();
        w.write_sample(x as f32).expect("write");
    }
    w.finalize().expect("finalize");
    let plugin = Struck::default();
    let mut h = harness_sized(&plugin, 1100.0);
    h.state_mut().ui.tab = Tab::Capture;
    h.state_mut().ui.add_capture_file(wav.clone()).expect("add");
    h.run_steps(2);
    h.get_by_label("Analyse").click();
    h.run_steps(1);
    h.state_mut().ui.wait_for_capture();
    h.run_steps(2);
    let m = h.state().ui.capture_message().unwrap_or_default().to_string();
    assert!(m.contains("steady hum") && m.contains("440.0 Hz"), "{m}");

    h.get_by_label("Minimum decay, 1/s").set_value_accesskit(0.005);
    h.run_steps(2);
    h.get_by_label("Analyse").click();
    h.run_steps(1);
    h.state_mut().ui.wait_for_capture();
    h.run_steps(2);
    assert!(h.state().ui.capture_message().is_none(), "{:?}", h.state().ui.capture_message());
    let params = plugin.struck_params().clone();
    let cap = params.capture.lock().expect("capture lock");
    let rec = cap.as_ref().expect("a capture result");
    let feats = &rec.report.impacts[0].features;
    for (f, _) in partials {
        let hit = feats.iter().find(|x| (x.freq_hz / f - 1.0).abs() < 1e-3);
        let d = hit.unwrap_or_else(|| panic!("{f} Hz not found: {feats:?}")).decay_per_s;
        assert!((d / decay(f) - 1.0).abs() < 0.05, "{f} Hz decays at {d} 1/s, want {}", decay(f));
    }
    // Rayleigh: c = 2d = α₁ + α₂λ, so α₁ = 2 · 0.01 1/s.
    let alpha1 = rec.report.damping().c(0.0);
    assert!((alpha1 / 0.02 - 1.0).abs() < 0.05, "alpha1 {alpha1}");
    drop(cap);
    let _ = std::fs::remove_file(&wav);
}

/// Frequency of the strongest DTFT peak between `lo` and `hi` (0.35-cent steps), Hann
/// windowed: a weak partial next to strong ones (the plate's lowest mode at a strike point
/// near its node is 36 dB under the strongest) is otherwise pulled by their sidelobes.
fn strongest_between(x: &[f32], rate: f64, lo: f64, hi: f64) -> f64 {
    let n = x.len() as f64;
    let w: Vec<f64> = x
        .iter()
        .enumerate()
        .map(|(i, v)| f64::from(*v) * (0.5 - 0.5 * (std::f64::consts::TAU * i as f64 / n).cos()))
        .collect();
    let mut best = (0.0, lo);
    let mut f = lo;
    while f < hi {
        let (mut re, mut im) = (0.0, 0.0);
        for (i, v) in w.iter().enumerate() {
            let ph = std::f64::consts::TAU * f * i as f64 / rate;
            re += v * ph.cos();
            im += v * ph.sin();
        }
        if re * re + im * im > best.0 {
            best = (re * re + im * im, f);
        }
        f *= 1.0002;
    }
    best.1
}

#[test]
fn ab_plays_the_recording_and_resyntheses_and_a_known_object_gives_gamma() {
    let dir = tmp("user-materials-ab");
    let plugin = Struck::default();
    let lib = plugin.library().clone();
    let plate = lib.bank_index("circular-plate").expect("circular plate");
    // Two taps of key 48: with "Keys tune the object" the plate's lowest mode sounds at C3.
    let wav = tmp("taps-ab.wav");
    let opts = struck_cli::cli::RenderOptions {
        sound: struck_cli::cli::SoundOptions {
            object: "circular-plate".into(),
            material: "steel-sterling-rayleigh".into(),
            ..Default::default()
        },
        notes: Some("48:110@0.1,48:120@0.8+1.5".into()),
        midi: None,
        seconds: Some(3.5),
        block_size: 512,
        out: wav.clone(),
        normalize: None,
        gesture: Default::default(),
    };
    struck_cli::cli::render(&opts).expect("render the taps");
    let mut h = harness_sized(&plugin, 1100.0);
    h.state_mut().ui.user_material_dir = Some(dir.clone());
    {
        let setter = ParamSetter::new(&*h.state().ctx);
        let p = plugin.struck_params();
        setter.begin_set_parameter(&p.object);
        setter.set_parameter(&p.object, plate as i32);
        setter.end_set_parameter(&p.object);
    }
    h.state_mut().ui.tab = Tab::Capture;
    h.state_mut().ui.add_capture_file(wav.clone()).expect("add");
    h.run_steps(2);
    h.get_by_label(&format!("Recordings are of the current object ({})", lib.banks[plate].name)).click();
    h.run_steps(1);
    h.get_by_label("Analyse").click();
    h.run_steps(1);
    h.state_mut().ui.wait_for_capture();
    h.run_steps(2);
    let params = plugin.struck_params().clone();
    let (impact, gamma) = {
        let cap = params.capture.lock().expect("lock");
        let rec = cap.as_ref().expect("a capture");
        let o = rec.object.as_ref().expect("the object is recorded with the capture");
        assert_eq!(o.id, "circular-plate");
        (rec.report.impacts[0].clone(), rec.specific_modulus().expect("γ from the object match"))
    };
    // γ/γ₀ = (f_C3 / f₁)²: the key put the lowest mode at C3.
    let l0 = lib.banks[plate].lambdas[0];
    let f1 = l0.sqrt() / std::f64::consts::TAU;
    let f_c3 = 440.0 * 2f64.powf((48.0 - 69.0) / 12.0);
    let want = (f_c3 / f1).powi(2) * lib.banks[plate].reference.specific_modulus;
    assert!((gamma / want - 1.0).abs() < 0.005, "γ {gamma} vs {want}");

    // A: the recording's own samples (48 kHz file, 48 kHz plugin: no resampling).
    let shared = plugin.editor_shared().clone();
    h.get_by_label("A: recording").click();
    h.run_steps(1);
    h.state_mut().ui.wait_for_ab();
    let a = shared.clips.pop().expect("the recording clip was queued");
    let file: Vec<f32> = hound::WavReader::open(&wav)
        .expect("wav")
        .into_samples::<f32>()
        .step_by(2)
        .map(|s| s.expect("sample"))
        .collect();
    let start = ((impact.onset_s - struck::editor::ab::PRE_ROLL_S) * 48_000.0) as usize;
    assert!(a.samples().len() > 24_000, "{} samples", a.samples().len());
    // The reader removes the file's DC offset (a constant); otherwise the samples are the file's.
    let dc = a.samples()[0] - file[start];
    assert!(dc.abs() < 1e-3, "offset {dc}");
    let worst = a.samples()[..20_000].iter().zip(&file[start..]).fold(0.0f32, |m, (x, y)| m.max((x - y - dc).abs()));
    assert!(worst < 1e-6, "the A clip is not the recording's impact (onset {} s): off by {worst}", impact.onset_s);
    let peak = |x: &[f32]| x.iter().fold(0.0f32, |m, v| m.max(v.abs()));

    // B on the object: same length and peak, lowest mode at the recording's pitch (matched γ).
    h.get_by_label("B: object").click();
    h.run_steps(1);
    h.state_mut().ui.wait_for_ab();
    let b = shared.clips.pop().expect("the object clip was queued");
    assert_eq!(b.samples().len(), a.samples().len());
    assert!((peak(b.samples()) / peak(a.samples()) - 1.0).abs() < 1e-4);
    let n = 24_000;
    let fa = strongest_between(&a.samples()[..n], 48_000.0, f_c3 * 0.97, f_c3 * 1.03);
    let fb = strongest_between(&b.samples()[..n], 48_000.0, f_c3 * 0.97, f_c3 * 1.03);
    assert!((1200.0 * (fb / fa).log2()).abs() < 3.0, "A {fa} Hz, B {fb} Hz");

    // B from the impact's modes: same length and peak.
    h.get_by_label("B: modes").click();
    h.run_steps(1);
    h.state_mut().ui.wait_for_ab();
    let m = shared.clips.pop().expect("the modes clip was queued");
    assert_eq!(m.samples().len(), a.samples().len());
    assert!((peak(m.samples()) / peak(a.samples()) - 1.0).abs() < 1e-4);
    let fm = strongest_between(&m.samples()[..n], 48_000.0, f_c3 * 0.97, f_c3 * 1.03);
    assert!((1200.0 * (fm / fa).log2()).abs() < 3.0, "A {fa} Hz, modes {fm} Hz");

    // The saved material carries γ, so "Material sets pitch" plays it at the recorded pitch.
    h.get_by_label("Save material").click();
    h.run_steps(2);
    let files: Vec<_> =
        std::fs::read_dir(&dir).expect("user folder").filter_map(Result::ok).map(|e| e.path()).collect();
    let saved = presets::Material::load(&files[0]).expect("a valid material");
    assert!((saved.specific_modulus.expect("γ saved") / want - 1.0).abs() < 0.005);
    // And its support recorded mode by mode on the plate (issue 10 part 6): the plate's
    // modes the taps' strong partials matched, each at the bank's λ⁰.
    let recorded = saved.recorded_modes().expect("the support is recorded mode by mode");
    assert_eq!(recorded.object, "circular-plate");
    assert!(!recorded.modes.is_empty());
    for m in &recorded.modes {
        assert_eq!(m.lambda, lib.banks[plate].lambdas[m.mode]);
        assert!(m.extra_c_per_s >= 0.0 && m.partials >= 1, "{m:?}");
    }
    // Apply hands it to the Custom material, kept with the project.
    h.get_by_label("Apply").click();
    h.run_steps(2);
    let kept = params.user_support.source().expect("Apply keeps the per-mode support");
    assert_eq!(kept.object, "circular-plate");
    assert_eq!(kept.modes.len(), recorded.modes.len());
    let _ = std::fs::remove_dir_all(&dir);
    let _ = std::fs::remove_file(&wav);
}

/// Issue 11 part 6: the T60 plot (the damping curve the audio uses) is whole on screen, above
/// the status line, at the default 1040 × 720 window and at smaller and larger heights; the
/// controls of issue 11 (mallet, variation, pitch reference, level normalisation, output
/// safety) are in the editor.
#[test]
fn the_t60_plot_is_whole_on_screen_and_the_new_controls_are_there() {
    let plugin = Struck::default();
    for height in [720.0f32, 600.0, 900.0] {
        let mut h = harness_sized(&plugin, height);
        h.run_steps(2);
        // The plot itself takes no input (no bounds in the accessibility tree): it is drawn
        // between the material chooser and the *Custom damping law* header, so both being on
        // screen, above the status line, puts the whole plot on screen.
        assert!(h.query_by_label("T60 curve").is_some(), "{height}: no T60 plot");
        let above = h.get_by_label("Rescan").rect();
        let below = h.get_by_label("Custom damping law").rect();
        let status = h.get_by_label_contains("Sounding modes").rect();
        println!("{height}: chooser {above:?}, header {below:?}, status {status:?}");
        assert!(above.top() >= 0.0, "{height}: the material chooser is off screen: {above:?}");
        assert!(
            below.bottom() <= status.top(),
            "{height}: the plot runs under the status line ({below:?}, {status:?})"
        );
        assert!(
            below.top() - above.bottom() >= 170.0,
            "{height}: no room for the plot between {above:?} and {below:?}"
        );
        if height == 720.0 {
            screenshot(&mut h, "play-t60");
        }
    }
    let h = harness(&plugin);
    for name in ["Mallet", "Variation", "Pitch reference", "Pitch mode", "Normalise level", "Output safety"] {
        h.get_by_label(&format!("{name} slider"));
    }
}

/// Issue 16: the lasting contact's controls are in the editor, with a hint on how held keys
/// play once the excitation is not a strike.
#[test]
fn the_excitation_controls_are_there() {
    let plugin = Struck::default();
    let mut h = harness(&plugin);
    h.run_steps(2);
    for name in [
        "Excitation",
        "Contact speed",
        "Texture",
        "Texture scale",
        "Ball radius",
        "Contact direction",
        "Path ends",
        "Audio in",
        "Dry/wet",
    ] {
        h.get_by_label(&format!("{name} slider"));
    }
    assert!(h.query_by_label_contains("Held keys keep contact").is_none());
    ParamSetter::new(&*h.state().ctx)
        .set_parameter(&plugin.struck_params().excitation, struck::params::ExcitationParam::Scrape);
    h.run_steps(2);
    assert!(h.query_by_label_contains("Held keys keep contact").is_some());
    screenshot(&mut h, "excitation");
}

/// Issue 16: a texture file loads through the field: kept with the project, queued for the
/// audio thread, *Texture* set to User file; a bad path is refused with its reason.
#[test]
fn a_texture_file_loads_from_the_editor() {
    let plugin = Struck::default();
    // Tall enough that the excitation controls are on screen (clicks need them there).
    let mut h = harness_sized(&plugin, 1600.0);
    h.run_steps(2);
    let bad = tmp("missing.csv");
    h.get_by_label("Texture file path");
    h.state_mut().ui.set_texture_path(&bad.display().to_string());
    h.run_steps(1);
    h.get_by_label("Load texture").click();
    h.run_steps(2);
    assert!(h.state().ui.texture_message().is_some_and(|m| m.contains("cannot read")));
    assert!(!plugin.struck_params().user_texture.is_set());
    let good = tmp("ribs.csv");
    std::fs::write(&good, "texel_mm = 0.5\n0 0 0 -0.2 -0.4 -0.2\n").unwrap();
    // The field holds the bad path: replace it.
    h.state_mut().ui.set_texture_path(&good.display().to_string());
    h.run_steps(1);
    h.get_by_label("Load texture").click();
    h.run_steps(2);
    assert_eq!(plugin.struck_params().texture.value(), struck::params::TextureParam::User);
    let saved = plugin.struck_params().user_texture.file().expect("kept with the project");
    assert_eq!(saved.heights_m.len(), 6);
    assert!(h.state().ui.texture_message().is_some_and(|m| m.contains("6 texels of 0.500 mm")));
    let _ = std::fs::remove_file(good);
}

/// Issue 16: a texture file dropped on the *Play* view loads (a recording dropped on
/// *Capture* is added there instead); with *Spiral through an image* an image is read along
/// its spiral: π·R² texels for an inscribed circle of radius R pixels, against its width for
/// the middle row.
#[test]
fn a_dropped_image_loads_as_the_texture_row_or_spiral() {
    let plugin = Struck::default();
    let mut h = harness_sized(&plugin, 1600.0);
    h.run_steps(2);
    let png = tmp("disc.png");
    image::GrayImage::from_fn(201, 201, |x, y| image::Luma([((x * 7 + y * 13) % 256) as u8])).save(&png).unwrap();
    h.input_mut().dropped_files.push(Arc::new(Dropped(png.clone())));
    h.run_steps(2);
    let row = plugin.struck_params().user_texture.file().expect("the dropped image is the texture");
    assert_eq!(row.heights_m.len(), 201);
    assert_eq!(plugin.struck_params().texture.value(), struck::params::TextureParam::User);
    assert!(h.state().ui.capture_files().is_empty(), "a drop on Play is not a recording");
    h.get_by_label_contains("Spiral through an image").click();
    h.run_steps(1);
    h.input_mut().dropped_files.push(Arc::new(Dropped(png.clone())));
    h.run_steps(2);
    let spiral = plugin.struck_params().user_texture.file().expect("the spiral texture");
    let expected = std::f64::consts::PI * 100.0 * 100.0;
    assert!(
        (spiral.heights_m.len() as f64 / expected - 1.0).abs() < 0.01,
        "{} texels, expected {expected:.0}",
        spiral.heights_m.len()
    );
    let _ = std::fs::remove_file(png);
}

/// Issue 11 part 6: the object view draws the object itself — its surface from the bank,
/// shaded — with the strike path on it. For every factory object: something is painted, the
/// strike points the camera sees lie on the painted picture, flat objects show every point
/// (they are on the top face), solids at least a third (the front of the path); the picture
/// of the analytic plate has the proportions of a box a × b × h seen from 55° above (width
/// a, height b·sin 55° + h·cos 55°), and the much thinner bar is stretched to 0.12.
#[test]
fn the_object_view_draws_each_object_with_its_strike_path_on_it() {
    use struck::editor::drawing::{distance_to_picture, object_drawing, FLAT_ELEVATION, MIN_ASPECT};
    let plugin = Struck::default();
    let lib = plugin.library();
    // The factory objects (a user's own banks in the library may carry no surface).
    for bank in &presets::factory_banks() {
        let pic = object_drawing(bank);
        assert!(pic.facets.len() >= 4, "{}: {} facets painted", bank.id, pic.facets.len());
        let seen: Vec<usize> = (0..pic.points.len()).filter(|&i| pic.visible[i]).collect();
        let flat = bank.id.contains("bar") || bank.id.contains("plate") || bank.id == "fem-block";
        let share = seen.len() as f64 / pic.points.len() as f64;
        println!(
            "{:22} {:5} facets, {:3}/{:3} points seen, picture {:.3} x {:.3}",
            bank.id,
            pic.facets.len(),
            seen.len(),
            pic.points.len(),
            pic.size[0],
            pic.size[1]
        );
        assert!(
            share >= if flat { 1.0 } else { 0.33 },
            "{}: {:.0} % of the strike points seen",
            bank.id,
            100.0 * share
        );
        for &i in &seen {
            // On the picture, or within 2 % of its size of it (a point on a curved surface can
            // lie just outside the coarse drawing's silhouette).
            let d = distance_to_picture(&pic, pic.points[i]);
            assert!(d <= 0.02, "{}: seen strike point {i} is {d:.3} off the picture", bank.id);
        }
        if bank.id == "bar" || bank.id == "rect-plate" {
            let d = &bank.reference.dimensions_m;
            let e = f64::from(FLAT_ELEVATION).to_radians();
            let want = ((d[1] * e.sin() + d[2] * e.cos()) / d[0]).max(f64::from(MIN_ASPECT));
            let got = f64::from(pic.size[1] / pic.size[0]);
            assert!((got / want - 1.0).abs() < 0.01, "{} picture aspect {got} vs {want}", bank.id);
        }
    }
    // Screenshots of a few objects.
    for id in ["fem-bowl", "fem-bell", "fem-marimba-bar", "fem-tube"] {
        let Some(i) = lib.banks.iter().position(|b| b.id == id) else { continue };
        let mut h = harness(&plugin);
        ParamSetter::new(&*h.state().ctx).set_parameter(&plugin.struck_params().object, i as i32);
        h.run_steps(2);
        screenshot(&mut h, &format!("object-{id}"));
    }
}
