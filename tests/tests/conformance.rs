//! What hosts and the CLAP validator require of `process()` and the parameters, measured
//! through the plugin's own entry points (offline host, allocation assertions on):
//! output events in time order and inside the block whatever the block sizes, steals and
//! chokes; `reset()` repeats a render bit for bit; every parameter's text round-trips.

use nice_plug::midi::{Channel, Key, VoiceID};
use nice_plug::prelude::*;
use struck::offline::TimedEvent;
use struck_tests::*;

const SR: u32 = 48_000;

/// A small deterministic generator (xorshift32), so the test needs no crate and repeats.
struct Rng(u32);
impl Rng {
    fn next(&mut self) -> u32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 17;
        self.0 ^= self.0 << 5;
        self.0
    }
    fn below(&mut self, n: u32) -> u32 {
        self.next() % n
    }
}

/// 400 notes on few keys and ids, with note-offs, chokes and retriggers, faster than the
/// 64 voices can hold them: every kind of voice ending (silence, steal, choke) happens.
fn busy_events(rng: &mut Rng, total: u64) -> Vec<TimedEvent> {
    let mut events = Vec::new();
    for i in 0..400u32 {
        let sample = u64::from(rng.below(total as u32 - 1));
        let key = 36 + rng.below(40) as u8;
        let id = VoiceID::ID(rng.below(90) as i32);
        let ch = Channel::Number(0);
        let event = match i % 5 {
            3 => NoteEvent::NoteOff { timing: 0, voice_id: id, channel: ch, key: Key::Number(key), velocity: 0.0 },
            4 => NoteEvent::Choke { timing: 0, voice_id: id, channel: ch, key: Key::Number(key) },
            _ => NoteEvent::NoteOn {
                timing: 0,
                voice_id: id,
                channel: ch,
                key: Key::Number(key),
                velocity: (1 + rng.below(127)) as f32 / 127.0,
            },
        };
        events.push(TimedEvent { sample, event });
    }
    events.sort_by_key(|e| e.sample);
    events
}

#[test]
fn voice_endings_are_sent_in_time_order_inside_each_block() {
    let mut rng = Rng(0x5EED_1234);
    // Short decays so voices also end by themselves inside blocks.
    let mut h = host("rect-plate", "wood-ren2013", SR, &[("noise", 0.3)]);
    let total = 2 * u64::from(SR);
    let events = busy_events(&mut rng, total);
    let (mut start, mut next, mut sent_total, mut steals_or_chokes) = (0u64, 0usize, 0usize, 0usize);
    while start < total {
        // Block sizes 1..=4096, random, as clap-validator's random-block-size test sends.
        let n = u64::from(1 + rng.below(4096)).min(total - start);
        let from = next;
        while next < events.len() && events[next].sample < start + n {
            next += 1;
        }
        let (_, sent) = h.render(&events[from..next], n as usize, n as usize);
        let mut last = start;
        for (at, e) in &sent {
            assert!(matches!(e, NoteEvent::VoiceTerminated { .. }), "unexpected output event {e:?}");
            assert!((start..start + n).contains(at), "event at {at} outside the block {start}..{}", start + n);
            assert!(*at >= last, "event at {at} after one at {last} in block {start}..{}", start + n);
            last = *at;
            // An ending exactly at an input event's sample is a steal or a choke.
            steals_or_chokes += usize::from(events[from..next].iter().any(|ev| ev.sample == *at));
        }
        sent_total += sent.len();
        start += n;
    }
    // The test is only meaningful if voices did end, by steal/choke and by themselves.
    assert!(sent_total > 40, "only {sent_total} voice endings");
    assert!(steals_or_chokes > 10 && steals_or_chokes < sent_total, "{steals_or_chokes} of {sent_total}");
}

#[test]
fn reset_then_the_same_input_gives_the_same_output() {
    let mut rng = Rng(77);
    let mut h = host("circular-plate", "metal-ren2013", SR, &[("noise", 0.5)]);
    let total = u64::from(SR);
    let events = busy_events(&mut rng, total);
    let (first, sent_first) = h.render(&events, total as usize, 333);
    // Something is still ringing, so a missing reset would show.
    assert!(h.plugin().engine().unwrap().active_voices() > 0);
    h.reset();
    let (second, sent_second) = h.render(&events, total as usize, 333);
    assert!(first[0].iter().any(|&x| x != 0.0));
    assert_eq!(first[0], second[0], "output after reset() differs");
    let times = |s: &[(u64, NoteEvent<()>)]| s.iter().map(|(t, _)| *t).collect::<Vec<_>>();
    assert_eq!(times(&sent_first), times(&sent_second));
}

/// Every parameter's value → text → value → text → value round trip, as clap-validator's
/// param-conversions test does it, over the whole range (with and without the unit, as the
/// CLAP and VST3 wrappers ask).
#[test]
fn every_parameter_round_trips_through_its_text() {
    let h = host("bar", "glass-ren2013", SR, &[]);
    let params = h.plugin().struck_params().clone();
    for (id, ptr, _) in params.param_map() {
        // SAFETY: the pointers point into `params`, alive for this whole loop.
        let (steps, name) = unsafe { (ptr.step_count(), ptr.name().to_string()) };
        let count = steps.map_or(500, |s| s.max(1));
        for k in 0..=count {
            let v = k as f32 / count as f32;
            for unit in [true, false] {
                // SAFETY: as above.
                unsafe {
                    let text = ptr.normalized_value_to_string(v, unit);
                    let back = ptr
                        .string_to_normalized_value(&text)
                        .unwrap_or_else(|| panic!("{id} ({name}): text '{text}' of {v} is not understood"));
                    let again = ptr.normalized_value_to_string(back, unit);
                    assert_eq!(text, again, "{id} ({name}): {v} → '{text}' → {back} → '{again}'");
                    assert_eq!(ptr.string_to_normalized_value(&again), Some(back), "{id}: '{again}'");
                }
            }
        }
    }
}

/// What a user types into a host's parameter field.
#[test]
fn typed_parameter_values_are_understood() {
    let h = host("bar", "glass-ren2013", SR, &[]);
    let params = h.plugin().struck_params().clone();
    let map: std::collections::HashMap<String, ParamPtr> =
        params.param_map().into_iter().map(|(id, p, _)| (id, p)).collect();
    let plain = |id: &str, text: &str| -> Option<f32> {
        let p = map[id];
        // SAFETY: the pointers point into `params`, alive in this test.
        unsafe { p.string_to_normalized_value(text).map(|v| p.preview_plain(v)) }
    };
    let close = |a: Option<f32>, b: f32| a.is_some_and(|a| (a - b).abs() <= 1e-4 * b.abs().max(1.0));
    assert!(close(plain("size", "0.05"), 0.05));
    assert!(close(plain("size", "×0.05"), 0.05));
    assert!(close(plain("size", "x2"), 2.0));
    // Size: pitch ∝ 1/size, so +12 semitones is half the size.
    assert!(close(plain("size", "+12 st"), 0.5));
    // Stiffness: pitch ∝ sqrt(γ), so +12 semitones is 4× the stiffness.
    assert!(close(plain("gamma", "+12 st"), 4.0));
    assert!(close(plain("gain", "-12 dB"), -12.0));
    assert!(close(plain("gain", "-12dB"), -12.0));
    assert!(close(plain("gain", "-12"), -12.0));
    assert!(close(plain("release", "40 1/s"), 40.0));
    assert!(close(plain("pos", "25%"), 0.25));
    assert!(plain("gain", "loud").is_none());
    // Names: a material by a word of its name, an object by its id or name, "Custom".
    let lib = h.plugin().library().clone();
    let material = plain("material", "glass").expect("'glass' names a material") as usize;
    assert!(lib.materials[material].name.to_lowercase().contains("glass"));
    assert_eq!(plain("material", "custom"), Some(lib.materials.len() as f32));
    let object = plain("object", "circular-plate").expect("an object id") as usize;
    assert_eq!(lib.banks[object].id, "circular-plate");
    assert!(plain("object", "no such object").is_none());
}
