//! Lasting contact (issue 16: scrape, slide, roll) measured through the plugin's own
//! `process()` (offline host, allocation assertions on): block-size invariance, the level's
//! proportionality to the normal force, the groove rate v/s in the sound, per-note speed, and
//! the end of contact at note-off.

use nice_plug::midi::{Channel, Key, VoiceID};
use nice_plug::prelude::NoteEvent;
use struck::offline::TimedEvent;
use struck_cli::cli::{note_events, NoteSpec};
use struck_tests::*;

const SR: u32 = 48_000;

/// Excitation and texture parameter values (the enums' order).
const SCRAPE: f32 = 1.0;
const SLIDE: f32 = 2.0;
const ROLL: f32 = 3.0;
const GROOVES: f32 = 3.0;
const BUMPS: f32 = 4.0;

fn pressure(sample: u64, p: f32) -> TimedEvent {
    TimedEvent {
        sample,
        event: NoteEvent::PolyPressure {
            timing: 0,
            voice_id: VoiceID::Wildcard,
            channel: Channel::Wildcard,
            key: Key::Wildcard,
            pressure: p,
        },
    }
}

fn brightness(sample: u64, voice: i32, key: u8, value: f32) -> TimedEvent {
    TimedEvent {
        sample,
        event: NoteEvent::PolyBrightness {
            timing: 0,
            voice_id: VoiceID::ID(voice),
            channel: Channel::Number(0),
            key: Key::Number(key),
            brightness: value,
        },
    }
}

fn play(set: &[(&str, f32)], events: &[TimedEvent], seconds: f64, block: usize) -> Vec<f32> {
    let mut h = host("rect-plate", "steel-sterling-hybrid", SR, set);
    let (out, _) = h.render(events, (seconds * f64::from(SR)) as usize, block);
    assert!(out[0].iter().all(|x| x.is_finite()), "non-finite output");
    assert_eq!(out[0], out[1]);
    out[0].clone()
}

fn held(key: u8, velocity: u8, start_s: f64, held_s: f64) -> NoteSpec {
    NoteSpec { key, velocity, position: None, start_s, duration_s: Some(held_s) }
}

/// Staggered held notes of every lasting excitation, pressure changes and releases: the
/// output is the same whatever the host's block size (the contact's gains move at the
/// engine's control ticks, fixed by its clock).
#[test]
fn lasting_contacts_are_block_size_invariant() {
    for (excitation, texture) in [(SCRAPE, GROOVES), (SLIDE, BUMPS), (ROLL, BUMPS)] {
        let set = [("excite", excitation), ("texture", texture), ("speed", 0.3), ("noise", 0.3)];
        let notes = [held(60, 100, 0.0, 0.5), held(64, 80, 0.1013, 0.3), held(67, 127, 0.2331, 0.7)];
        let mut events = note_events(&notes, f64::from(SR));
        events.push(pressure(7_001, 0.4));
        events.push(pressure(19_999, 1.0));
        events.sort_by_key(|e| e.sample);
        let reference = play(&set, &events, 1.2, 512);
        assert!(rms(&reference) > 1e-3);
        for block in [1, 17, 64, 4096] {
            let y = play(&set, &events, 1.2, block);
            let worst = reference.iter().zip(&y).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
            assert!(worst <= 1e-6, "excitation {excitation}, block {block}: max difference {worst}");
        }
    }
}

/// The contact's sound is proportional to the normal force (pressure): with the strike the
/// same, out(1) − out(0) = 2·(out(½) − out(0)) to float rounding, and it is not small.
#[test]
fn the_contact_is_proportional_to_the_force() {
    let set = [("excite", SCRAPE), ("texture", GROOVES), ("speed", 0.3)];
    let notes = [held(60, 100, 0.0, 0.8)];
    let at = |p: f32| {
        let mut events = note_events(&notes, f64::from(SR));
        events.push(pressure(0, p));
        events.sort_by_key(|e| e.sample);
        play(&set, &events, 1.0, 256)
    };
    let (zero, half, full) = (at(0.0), at(0.5), at(1.0));
    let contact: Vec<f64> = full.iter().zip(&zero).map(|(a, b)| f64::from(a - b)).collect();
    let twice_half: Vec<f64> = half.iter().zip(&zero).map(|(a, b)| 2.0 * f64::from(a - b)).collect();
    let size = (contact.iter().map(|x| x * x).sum::<f64>() / contact.len() as f64).sqrt();
    let err =
        (contact.iter().zip(&twice_half).map(|(a, b)| (a - b) * (a - b)).sum::<f64>() / contact.len() as f64).sqrt();
    assert!(size > 0.3 * rms(&zero), "the contact is {size}, the strike alone {}", rms(&zero));
    assert!(err < 1e-4 * size, "not proportional: error {err} of {size}");
}

/// A lasting contact does not build up without bound on low, lightly damped modes
/// (`dsp::engine::MAX_CONTACT_ENERGY`): a black-box tester found a scrape of the sphere shell
/// at *Size* 20 (modes at 13–25 Hz, steel: T60 5.8 s) at −2 dBFS RMS with +9 dBFS peaks, 23 dB
/// over size 1, with *Normalise level* on. Held 4 s at velocity 127 (safety off), its last 2 s
/// stay within 2 dB of the ceiling's −14 dBFS RMS and still sound (over −30 dBFS); the
/// ceiling leaves the plate at size 1 alone (trim 1 after 2 s of a scrape, a slide and a roll).
#[test]
fn a_lasting_contact_on_low_lightly_damped_modes_stays_under_its_ceiling() {
    let notes = [held(60, 127, 0.0, 4.0)];
    let events = note_events(&notes, f64::from(SR));
    for excitation in [SCRAPE, ROLL] {
        let set = [("excite", excitation), ("size", 20.0), ("safety", 0.0)];
        let mut h = host("fem-sphere-shell", "steel-sterling-hybrid", SR, &set);
        let (out, _) = h.render(&events, 4 * SR as usize, 512);
        assert!(out[0].iter().all(|x| x.is_finite()));
        let tail = &out[0][2 * SR as usize..];
        let level = db(rms(tail));
        let trim = h.plugin().engine().expect("active").contact_trim().expect("a contact sounds");
        println!("excitation {excitation}: last 2 s at {level:.1} dBFS RMS, trim {trim:.3}");
        assert!((-30.0..=-12.0).contains(&level), "excitation {excitation}: {level:.1} dBFS RMS");
    }
    for excitation in [SCRAPE, SLIDE, ROLL] {
        let set = [("excite", excitation), ("speed", 1.0), ("safety", 0.0)];
        let mut h = host("rect-plate", "steel-sterling-hybrid", SR, &set);
        h.render(&note_events(&[held(60, 127, 0.0, 3.0)], f64::from(SR)), 2 * SR as usize, 512);
        let trim = h.plugin().engine().expect("active").contact_trim().expect("a contact sounds");
        assert_eq!(trim, 1.0, "excitation {excitation}");
    }
}

/// A tool held still on the object adds no DC: a scrape or a roll at speed 0 on the sphere
/// shell at size 20 (modes from 13 Hz) rings on from its strike with a mean under −60 dBFS
/// over its last 2 s (a black-box tester measured a −12 dBFS offset for the scrape and −7 for
/// the roll: the force the profile had where the tool stood, played as a constant push).
#[test]
fn a_tool_held_still_adds_no_dc() {
    let notes = [held(60, 127, 0.0, 4.0)];
    let events = note_events(&notes, f64::from(SR));
    for excitation in [SCRAPE, ROLL] {
        let set = [("excite", excitation), ("size", 20.0), ("speed", 0.0), ("safety", 0.0)];
        let mut h = host("fem-sphere-shell", "steel-sterling-hybrid", SR, &set);
        let (out, _) = h.render(&events, 4 * SR as usize, 512);
        let tail = &out[0][2 * SR as usize..];
        let mean = tail.iter().map(|&x| f64::from(x)).sum::<f64>() / tail.len() as f64;
        println!("excitation {excitation}: mean {:.1} dBFS, RMS {:.1} dBFS", db(mean.abs()), db(rms(tail)));
        assert!(db(mean.abs()) < -60.0, "excitation {excitation}: DC at {:.1} dBFS", db(mean.abs()));
    }
}

/// Frequency (Hz) of the strongest line between `lo` and `hi` in the spectrum of x²
/// (the energy envelope), over `x[start..]`, zero-padded to 2¹⁸ points.
fn envelope_line(x: &[f32], start: usize, lo: f64, hi: f64) -> f64 {
    use rustfft::num_complex::Complex;
    let n = 1 << 18;
    let seg = &x[start..];
    let mean = seg.iter().map(|v| f64::from(v * v)).sum::<f64>() / seg.len() as f64;
    let mut buf: Vec<Complex<f64>> = (0..n)
        .map(|i| {
            let v = seg.get(i).map_or(0.0, |v| f64::from(v * v) - mean);
            let w = if i < seg.len() {
                0.5 - 0.5 * (2.0 * std::f64::consts::PI * i as f64 / seg.len() as f64).cos()
            } else {
                0.0
            };
            Complex::new(v * w, 0.0)
        })
        .collect();
    rustfft::FftPlanner::new().plan_fft_forward(n).process(&mut buf);
    let df = f64::from(SR) / n as f64;
    let (a, b) = ((lo / df) as usize, (hi / df) as usize);
    let k = (a..b).max_by(|&i, &j| buf[i].norm().total_cmp(&buf[j].norm())).unwrap();
    // Parabolic interpolation of the peak.
    let (y0, y1, y2) = (buf[k - 1].norm(), buf[k].norm(), buf[k + 1].norm());
    (k as f64 + 0.5 * (y0 - y2) / (y0 - 2.0 * y1 + y2)) * df
}

/// Grooves 2 mm apart scraped at v are heard as v/s clicks a second: the line of the
/// output's energy envelope is at v/s within 1 % (a heavily damped object, so each click
/// dies before the next). The speed set per note (brightness / MPE slide) overrides the
/// parameter.
#[test]
fn grooves_are_heard_at_speed_over_spacing() {
    let spacing = 2e-3;
    for (param, per_note) in [(0.25f32, None), (0.8, Some(0.35f32))] {
        let set = [("excite", SCRAPE), ("texture", GROOVES), ("speed", param), ("dscale", 20.0)];
        let mut events = note_events(&[held(60, 60, 0.0, 2.5)], f64::from(SR));
        if let Some(v) = per_note {
            // note_events numbers its notes' voices from 0.
            events.push(brightness(0, 0, 60, v / dsp::contact::MAX_SPEED_M_PER_S as f32));
            events.sort_by_key(|e| e.sample);
        }
        let x = play(&set, &events, 2.5, 512);
        let v = f64::from(per_note.unwrap_or(param));
        let expected = v / spacing;
        let f = envelope_line(&x, SR as usize / 2, 0.5 * expected, 1.5 * expected);
        assert!((f / expected - 1.0).abs() < 0.01, "{v} m/s: clicks at {f:.2} Hz, expected {expected:.2}");
    }
}

/// A note-off ends the contact: the object then rings freely, damped by the release damping,
/// and the voice ends.
#[test]
fn a_note_off_ends_the_contact() {
    let set = [("excite", SCRAPE), ("texture", BUMPS), ("speed", 0.4), ("release", 60.0)];
    let mut h = host("rect-plate", "steel-sterling-hybrid", SR, &set);
    let events = note_events(&[held(60, 100, 0.0, 0.5)], f64::from(SR));
    let (out, sent) = h.render(&events, 2 * SR as usize, 512);
    let x = &out[0];
    let sr = SR as usize;
    let during = rms(&x[sr / 5..sr / 2]);
    let after = rms(&x[sr..3 * sr / 2]);
    assert!(during > 1e-3 && after < 1e-4 * during, "during {during}, after {after}");
    assert!(sent.iter().any(|(_, e)| matches!(e, NoteEvent::VoiceTerminated { .. })), "the voice did not end");
}

/// A note released at its own note-on's sample only strikes: no contact is left running, the
/// voice ends.
#[test]
fn a_note_released_at_once_only_strikes() {
    let set = [("excite", SCRAPE), ("texture", BUMPS), ("speed", 0.4), ("release", 60.0)];
    let mut h = host("rect-plate", "steel-sterling-hybrid", SR, &set);
    let events = note_events(&[held(60, 100, 0.0, 0.0)], f64::from(SR));
    let (_, sent) = h.render(&events, 4 * SR as usize, 512);
    assert!(sent.iter().any(|(_, e)| matches!(e, NoteEvent::VoiceTerminated { .. })), "the voice did not end");
}

/// The mod wheel sets the contact speed at its event's sample: the same wheel moves give the
/// same output whatever the host's block size.
#[test]
fn the_mod_wheel_moves_the_contact_sample_accurately() {
    let set = [("excite", SCRAPE), ("texture", GROOVES)];
    let mut events = note_events(&[held(60, 100, 0.0, 0.9)], f64::from(SR));
    for (sample, value) in [(1_001u64, 0.1f32), (9_333, 0.6), (20_017, 0.3)] {
        events.push(TimedEvent { sample, event: NoteEvent::MidiCC { timing: 0, channel: 0, cc: 1, value } });
    }
    events.sort_by_key(|e| e.sample);
    let reference = play(&set, &events, 1.0, 512);
    for block in [1, 37, 4096] {
        assert_eq!(play(&set, &events, 1.0, block), reference, "block {block}");
    }
    // The wheel did move the contact: the same render without it differs.
    let still = play(&set, &note_events(&[held(60, 100, 0.0, 0.9)], f64::from(SR)), 1.0, 512);
    assert_ne!(still, reference);
}

/// A user texture (issue 16): ribs every 3 mm from a CSV profile, scraped at 0.3 m/s, are
/// heard as 100 clicks a second (1 %); the texture is kept with the project: a new instance
/// given the saved state plays it identically.
#[test]
fn a_user_texture_plays_and_is_kept_with_the_project() {
    use nice_plug::prelude::Params;
    let dir = std::env::temp_dir().join(format!("struck-user-texture-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let csv = dir.join("ribs.csv");
    std::fs::write(&csv, "# 3 mm ribs\ntexel_mm = 0.5\n0 0 0 -0.2 -0.4 -0.2\n").unwrap();
    let file = presets::texture::TextureFile::load(&csv).unwrap();
    let set = [("excite", SCRAPE), ("texture", 5.0), ("speed", 0.3), ("dscale", 20.0)];
    let mut h = host("rect-plate", "steel-sterling-hybrid", SR, &set);
    h.plugin_mut().set_user_texture(file).unwrap();
    let events = note_events(&[held(60, 60, 0.0, 2.5)], f64::from(SR));
    let (out, _) = h.render(&events, (2.5 * f64::from(SR)) as usize, 512);
    let f = envelope_line(&out[0], SR as usize / 2, 50.0, 150.0);
    assert!((f / 100.0 - 1.0).abs() < 0.01, "clicks at {f:.2} Hz, expected 100");
    // The saved state brings the texture into a new instance.
    let state = h.plugin().struck_params().serialize_fields();
    assert!(state.contains_key("user-texture"));
    let restored = struck::Struck::default();
    restored.struck_params().deserialize_fields(&state);
    let mut r = struck::offline::OfflineHost::with_plugin(restored, SR as f32, 512).unwrap();
    for (k, v) in set {
        r.set_param(k, v).unwrap();
    }
    r.set_param("object", 2.0).unwrap();
    r.set_param("material", h.param("material").unwrap()).unwrap();
    r.reset();
    h.reset();
    let a = h.render(&events, SR as usize, 512).0;
    let b = r.render(&events, SR as usize, 512).0;
    assert_eq!(a, b, "the restored instance plays differently");
    // A state loaded into a running instance (a host loading a preset) changes its texture
    // at the next block: back to none (smooth), the clicks are gone.
    let mut empty = h.plugin().struck_params().serialize_fields();
    empty.insert("user-texture".into(), "null".into());
    h.plugin().struck_params().deserialize_fields(&empty);
    h.reset();
    let c = h.render(&events, SR as usize, 512).0;
    assert_ne!(c, a, "the loaded state did not reach the engine");
    assert!(!h.plugin().struck_params().user_texture.is_set());
    let _ = std::fs::remove_dir_all(dir);
}

/// A lasting contact's level does not follow the mallet: its force is a train of short
/// impulses, not the mallet's pulse, so *Normalise level* scales it as an ideal impulse
/// would be. With the mallet's own level it was raised by what the mallet's pulse takes from
/// the ring: a black-box tester's felt at hardness 0 rolling on the bell at key 96 peaked at
/// +36.6 dBFS with the safety off. Roll and scrape on the bell (glass) and the bar (wood),
/// keys 60 and 96, pressure 1: the contact's part (the output less the same note's strike
/// alone, pressure 0) has the same RMS within 0.5 dB for felt and rubber at hardness 0, wood
/// at 0.5 and steel at 1, and the whole note stays under 0 dBFS with the safety off.
#[test]
fn a_lasting_contact_is_as_loud_whatever_the_mallet() {
    for (object, material) in [("fem-bell", "glass-ren2013"), ("bar", "wood-ren2013")] {
        for excitation in [ROLL, SCRAPE] {
            for key in [60u8, 96] {
                let mut levels = vec![];
                for (mallet, hard) in [(0.0f32, 0.0f32), (1.0, 0.0), (2.0, 0.5), (5.0, 1.0)] {
                    let set =
                        [("excite", excitation), ("mallet", mallet), ("hard", hard), ("speed", 0.3), ("safety", 0.0)];
                    let run = |p: f32| {
                        let mut events = note_events(&[held(key, 100, 0.0, 0.8)], f64::from(SR));
                        events.push(pressure(0, p));
                        events.sort_by_key(|e| e.sample);
                        let mut h = host(object, material, SR, &set);
                        let (out, _) = h.render(&events, SR as usize, 512);
                        out[0].clone()
                    };
                    let (full, zero) = (run(1.0), run(0.0));
                    let what = format!("{object} excitation {excitation} key {key} mallet {mallet} hardness {hard}");
                    assert!(peak(&full) <= 1.0, "{what}: peaks at {:+.1} dBFS", db(f64::from(peak(&full))));
                    let contact: Vec<f32> = full.iter().zip(&zero).map(|(a, b)| a - b).collect();
                    levels.push((db(rms(&contact)), what));
                }
                let (lo, hi) = levels.iter().fold((f64::MAX, f64::MIN), |(a, b), l| (a.min(l.0), b.max(l.0)));
                println!("{}: contact {lo:.2}…{hi:.2} dB", levels[0].1);
                assert!(hi - lo <= 0.5, "{levels:?}");
            }
        }
    }
}
