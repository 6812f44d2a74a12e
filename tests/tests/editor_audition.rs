//! The editor's link to the audio thread, through the plugin's own `process()` with
//! allocation assertions on: a queued audition strikes at the block start, the meters report
//! it, the host is not told about the audition's voice ending, and the result matches a MIDI
//! note-on of the same key and strike position.

// PANIC: in these tests each `expect` is an assertion.

use struck::editor::Audition;
use struck::offline::{OfflineHost, TimedEvent};

const SR: f32 = 48_000.0;

fn peak(x: &[f32]) -> f32 {
    x.iter().fold(0.0f32, |m, v| m.max(v.abs()))
}

#[test]
fn an_audition_plays_like_a_note_and_meters_follow() {
    let mut h = OfflineHost::new(SR, 256).expect("host");
    h.set_param("pos", 0.25).expect("pos");
    h.set_param("release", 0.0).expect("release");
    h.reset();
    let shared = h.plugin().editor_shared().clone();
    assert_eq!(shared.meters(), (0, 0));
    assert!(shared.audition(Audition { key: 60, velocity: 0.8, position: 0.25, serial: 1 }));
    let (out, _) = h.render(&[], 4_800, 256);
    assert!(peak(&out[0]) > 1e-3, "the audition made no sound");
    assert!(shared.audition.is_empty(), "process() drained the queue");
    let (voices, modes) = shared.meters();
    assert_eq!(voices, 1);
    assert!(modes > 0);

    // Same strike as a MIDI note of key 60 at the same position: same sound.
    let mut m = OfflineHost::new(SR, 256).expect("host");
    m.set_param("pos", 0.25).expect("pos");
    m.set_param("release", 0.0).expect("release");
    m.reset();
    let on = struck::offline::note_on(60, 0.8);
    let (midi, _) = m.render(&[TimedEvent { sample: 0, event: on }], 4_800, 256);
    let diff = out[0].iter().zip(&midi[0]).fold(0.0f32, |d, (a, b)| d.max((a - b).abs()));
    assert!(diff < 1e-4 * peak(&midi[0]).max(1e-6), "audition vs MIDI note differ by {diff}");

    // Ring out with a short decay: the voice ends, the meters fall, no VoiceTerminated sent.
    h.set_param("dscale", 20.0).expect("dscale");
    let (_, sent) = h.render(&[], 5 * SR as usize, 256);
    assert!(sent.is_empty(), "the host was told about an audition voice: {sent:?}");
    assert_eq!(shared.meters(), (0, 0));
}

#[test]
fn a_full_queue_drops_strikes_without_blocking() {
    let h = OfflineHost::new(SR, 64).expect("host");
    let shared = h.plugin().editor_shared().clone();
    let mut queued = 0;
    for i in 0..(struck::editor::AUDITION_QUEUE as u32 + 10) {
        if shared.audition(Audition { key: 60, velocity: 0.5, position: 0.5, serial: i }) {
            queued += 1;
        }
    }
    assert_eq!(queued, struck::editor::AUDITION_QUEUE);
}
