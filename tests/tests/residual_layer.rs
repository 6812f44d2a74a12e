//! The residual layer (issue 15 part 4) through the plugin's own `process()`: a material file
//! keeping a residual — a known click (60 partials from 1.5 to 4 kHz under a 5 ms decay),
//! stored against the very modes the object rings, so the transfer is the identity — plays
//! that click with each strike, from the strike's sample, the same in every block size;
//! softer strikes play it quieter and darker; the layer off, or a factory material, plays
//! none; and the worker thread transfers again when the object changes.

use struck_cli::cli::{predicted_modes, NoteSpec, SoundOptions};
use struck_tests::*;

const SR: u32 = 48_000;
const OBJECT: &str = "circular-plate";

/// The click, 0.35 s at 48 kHz.
fn click() -> Vec<f64> {
    let mut rng = estimator::synth::Rng::new(3);
    let parts: Vec<(f64, f64, f64)> = (0..60)
        .map(|_| (1500.0 + 2500.0 * rng.uniform(), std::f64::consts::TAU * rng.uniform(), rng.uniform()))
        .collect();
    (0..16_800)
        .map(|k| {
            let t = f64::from(k) / f64::from(SR);
            let s: f64 = parts.iter().map(|&(f, ph, a)| a * (std::f64::consts::TAU * f * t + ph).sin()).sum();
            0.01 * s * (-t / 0.005).exp()
        })
        .collect()
}

/// A material file (glass's law) keeping the click as its residual, against the modes a
/// velocity-127 strike at the root key rings on the object. Returns its path.
fn material_with_residual(dir: &std::path::Path) -> String {
    let o = SoundOptions { object: OBJECT.into(), material: "glass-ren2013".into(), ..SoundOptions::default() };
    let modes = predicted_modes(&o, 60, 127).unwrap();
    let spec = estimator::residual::power_spectrogram(&click());
    let residual = presets::residual::ResidualSpectrogram::from_power(
        &spec.power,
        spec.frames,
        SR,
        estimator::residual::FRAME as u32,
        estimator::residual::HOP as u32,
        modes
            .iter()
            .map(|&(f, d, a)| presets::residual::ResidualMode {
                freq_hz: f,
                decay_per_s: d,
                amplitude: f64::from(a.abs()),
            })
            .collect(),
    );
    let mut m = presets::factory_materials().into_iter().find(|m| m.id == "glass-ren2013").unwrap();
    m.id = "glass-with-click".into();
    m.residual = Some(residual);
    let path = dir.join("glass-with-click.json");
    m.save(&path).unwrap();
    path.to_string_lossy().into_owned()
}

fn temp_dir(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("struck-residual-layer-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn energy(x: &[f32]) -> f64 {
    x.iter().map(|&v| f64::from(v) * f64::from(v)).sum()
}

fn diff(a: &[f32], b: &[f32]) -> Vec<f32> {
    a.iter().zip(b).map(|(x, y)| x - y).collect()
}

/// The residual layer alone: `notes` on the object with `material` at `rate` with `set`,
/// minus the same with the layer off, `seconds` long in blocks of `block`.
fn layer_of(
    material: &str,
    rate: u32,
    set: &[(&str, f32)],
    notes: &[NoteSpec],
    seconds: f64,
    block: usize,
) -> Vec<f32> {
    let on = render(&mut host(OBJECT, material, rate, set), notes, seconds, block);
    let mut quiet = set.to_vec();
    quiet.push(("residual", 0.0));
    let off = render(&mut host(OBJECT, material, rate, &quiet), notes, seconds, block);
    diff(&on, &off)
}

#[test]
fn each_strike_plays_the_residual_from_its_sample() {
    let dir = temp_dir("strike");
    let material = material_with_residual(&dir);
    let start_s = 0.1013;
    let notes = [NoteSpec { key: 60, velocity: 127, position: None, start_s, duration_s: None }];
    let layer = layer_of(&material, SR, &[], &notes, 0.6, 512);
    let at = (start_s * f64::from(SR)).round() as usize;
    let first = layer.iter().position(|&v| v != 0.0).unwrap();
    let c: Vec<f32> = click().iter().map(|&v| v as f32).collect();
    let (e_layer, e_click) = (energy(&layer), energy(&c));
    let early = energy(&layer[at..at + 2880]); // 60 ms
    println!(
        "layer starts at sample {first} (note at {at}); energy {e_layer:.4e} vs the click's {e_click:.4e}; \
         {:.1} % in the first 60 ms; centroid {:.0} Hz vs the click's {:.0} Hz",
        100.0 * early / e_layer,
        spectral_centroid(&layer[at..], f64::from(SR)),
        spectral_centroid(&c, f64::from(SR))
    );
    assert_eq!(first, at, "the residual starts with its strike");
    assert!((e_layer / e_click - 1.0).abs() < 0.3, "energy {e_layer} vs {e_click}");
    assert!(early > 0.9 * e_layer);
    let (cl, cc) = (spectral_centroid(&layer[at..], f64::from(SR)), spectral_centroid(&c, f64::from(SR)));
    assert!((cl / cc - 1.0).abs() < 0.05, "centroid {cl} vs {cc}");
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn the_residual_layer_is_the_same_in_every_block_size() {
    let dir = temp_dir("blocks");
    let material = material_with_residual(&dir);
    let notes = [
        NoteSpec { key: 60, velocity: 127, position: Some(0.3), start_s: 0.0, duration_s: None },
        NoteSpec { key: 67, velocity: 90, position: None, start_s: 0.0513, duration_s: None },
        NoteSpec { key: 60, velocity: 110, position: None, start_s: 0.2001, duration_s: None },
    ];
    let reference = render(&mut host(OBJECT, &material, SR, &[]), &notes, 0.5, 512);
    let without = render(&mut host(OBJECT, &material, SR, &[("residual", 0.0)]), &notes, 0.5, 512);
    assert!(energy(&diff(&reference, &without)) > 1e-3 * energy(&reference), "the layer plays");
    for block in [1, 17, 4096] {
        let y = render(&mut host(OBJECT, &material, SR, &[]), &notes, 0.5, block);
        let worst = reference.iter().zip(&y).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
        assert!(worst <= 1e-6, "block {block}: max difference {worst}");
    }
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn softer_strikes_play_a_quieter_darker_residual() {
    let dir = temp_dir("velocity");
    let material = material_with_residual(&dir);
    let layer = |velocity: u8| {
        let n = [NoteSpec { key: 60, velocity, position: None, start_s: 0.0, duration_s: None }];
        layer_of(&material, SR, &[("hard", 0.9)], &n, 0.3, 256)
    };
    let (loud, soft) = (layer(127), layer(50));
    let contact = |v: f32| {
        let h = host(OBJECT, &material, SR, &[("hard", 0.9)]);
        h.plugin().engine().unwrap().contact_time_s(v)
    };
    println!("contact times: {:.3} ms at 127, {:.3} ms at 50", 1e3 * contact(1.0), 1e3 * contact(50.0 / 127.0));
    let g = dsp::exciter::velocity_gain(50.0 / 127.0, 0.7);
    let ratio = energy(&soft) / energy(&loud);
    let (cl, cs) = (spectral_centroid(&loud, f64::from(SR)), spectral_centroid(&soft, f64::from(SR)));
    println!("velocity 50 vs 127: energy × {ratio:.4} (velocity gain² {:.4}); centroid {cs:.0} vs {cl:.0} Hz", g * g);
    // The velocity's gain, and the shelf takes off a little more (it never adds).
    assert!(ratio <= f64::from(g * g) * 1.001 && ratio > 0.3 * f64::from(g * g), "energy × {ratio}");
    assert!(cs < 0.99 * cl, "darker: {cs} vs {cl}");
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn no_residual_plays_with_the_layer_off_or_a_factory_material() {
    let dir = temp_dir("off");
    let material = material_with_residual(&dir);
    let n = [note(60, 127, None)];
    let plain = render(&mut host(OBJECT, "glass-ren2013", SR, &[]), &n, 0.3, 512);
    // The file's law through the Custom knobs, the layer off: the modes only.
    let off = render(&mut host(OBJECT, &material, SR, &[("residual", 0.0)]), &n, 0.3, 512);
    let worst = plain.iter().zip(&off).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
    assert!(worst < 1e-4, "layer off: {worst}");
    // A factory material after the file: its residual stays with the Custom material.
    let mut h = host(OBJECT, &material, SR, &[]);
    let glass = h.plugin().library().materials.iter().position(|m| m.id == "glass-ren2013").unwrap();
    h.set_param("material", glass as f32).unwrap();
    let factory = render(&mut h, &n, 0.3, 512);
    assert_eq!(factory, plain);
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn the_worker_transfers_again_when_the_object_changes() {
    let dir = temp_dir("worker");
    let material = material_with_residual(&dir);
    // The hardest mallet: its spectrum is flat over the click's band, so the transfer's
    // pixel scale is the same at both sizes and the move is the scale's alone.
    let mut h = host(OBJECT, &material, SR, &[("hard", 1.0)]);
    let before = h.plugin().engine().and_then(|e| e.residual()).map(|c| c.samples.clone()).expect("a clip");
    h.set_param("size", 0.7).unwrap();
    let mut changed = None;
    for _ in 0..400 {
        let _ = render(&mut h, &[], 0.01, 480);
        let now = h.plugin().engine().and_then(|e| e.residual()).map(|c| c.samples.clone());
        if now.as_ref().is_some_and(|c| *c != before) {
            changed = now;
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    let after = changed.expect("the worker delivered a new clip within 4 s");
    // 0.7× the size: every mode 1/0.7 higher; the click's spectrum follows.
    let (c0, c1) = (spectral_centroid(&before, f64::from(SR)), spectral_centroid(&after, f64::from(SR)));
    println!("size 0.7: residual centroid {c0:.0} → {c1:.0} Hz (× {:.3}; modes × {:.3})", c1 / c0, 1.0 / 0.7);
    assert!((c1 / c0 * 0.7 - 1.0).abs() < 0.05, "{c1} vs {c0}");
    let _ = std::fs::remove_dir_all(dir);
}

/// An octave up the keyboard reads the residual twice as fast: its spectrum moves up an
/// octave with the modes'.
#[test]
fn a_key_an_octave_up_plays_the_residual_an_octave_up() {
    let dir = temp_dir("key");
    let material = material_with_residual(&dir);
    let layer = |key: u8| {
        let n = [NoteSpec { key, velocity: 127, position: None, start_s: 0.0, duration_s: None }];
        layer_of(&material, SR, &[], &n, 0.3, 256)
    };
    let (c60, c72) = (spectral_centroid(&layer(60), f64::from(SR)), spectral_centroid(&layer(72), f64::from(SR)));
    println!("residual centroid: key 60 {c60:.0} Hz, key 72 {c72:.0} Hz (× {:.4})", c72 / c60);
    // Linear interpolation, no anti-aliasing: reading faster folds a little of the top back.
    assert!((c72 / c60 / 2.0 - 1.0).abs() < 0.05, "{c72} vs {c60}");
    let _ = std::fs::remove_dir_all(dir);
}

/// The host's sample rate does not change the residual's level or band: at 96 kHz the
/// layer of a 48 kHz capture has the same energy per second (within 1 dB) and centroid
/// (within 3 %).
#[test]
fn the_residual_sounds_the_same_at_any_host_rate() {
    let dir = temp_dir("rates");
    let material = material_with_residual(&dir);
    let layer = |rate: u32| layer_of(&material, rate, &[], &[note(60, 127, None)], 0.3, 256);
    let (a, b) = (layer(48_000), layer(96_000));
    let (ea, eb) = (energy(&a) / 48_000.0, energy(&b) / 96_000.0);
    let (ca, cb) = (spectral_centroid(&a, 48_000.0), spectral_centroid(&b, 96_000.0));
    println!("48 kHz: {ea:.4e} J/s-units, centroid {ca:.0} Hz; 96 kHz: {eb:.4e}, centroid {cb:.0} Hz");
    assert!((10.0 * (eb / ea).log10()).abs() < 1.0, "{eb} vs {ea}");
    assert!((cb / ca - 1.0).abs() < 0.03, "{cb} vs {ca}");
    let _ = std::fs::remove_dir_all(dir);
}
