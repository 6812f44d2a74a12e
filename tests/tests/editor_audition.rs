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

#[test]
fn an_ab_clip_plays_sample_exact_and_comes_back_to_the_gui_for_freeing() {
    use struck::editor::Clip;
    // Allocation assertions are on in OfflineHost's process(): the player must not free.
    let mut h = OfflineHost::new(SR, 100).expect("host");
    h.set_param("gain", 0.0).expect("gain");
    h.reset();
    let shared = h.plugin().editor_shared().clone();
    assert_eq!(shared.sample_rate(), SR, "activate() publishes the sample rate");
    let clip: Vec<f32> = (0..1_000).map(|i| ((i as f32) * 0.01).sin() * 0.5).collect();
    shared.play_clip(Clip::new(clip.clone())).expect("queued");
    let (out, _) = h.render(&[], 1_500, 100);
    // The clip starts at the next block and is added before the 0 dB output gain: exact.
    assert_eq!(&out[0][..1_000], &clip[..], "clip samples changed on the way out");
    assert!(out[0][1_000..].iter().all(|v| *v == 0.0));
    assert_eq!(out[0], out[1]);
    assert!(!shared.clip_playing.load(std::sync::atomic::Ordering::Relaxed));
    // Handed back, not freed on the audio thread.
    assert_eq!(shared.clips_done.len(), 1);
    assert_eq!(shared.reclaim_clips(), 1);

    // A new clip replaces one playing; Stop silences at the next block.
    shared.play_clip(Clip::new(vec![0.25; 10_000])).expect("queued");
    let (a, _) = h.render(&[], 300, 100);
    assert!(a[0].iter().all(|v| *v == 0.25));
    shared.play_clip(Clip::new(vec![-0.5; 10_000])).expect("queued");
    let (b, _) = h.render(&[], 300, 100);
    assert!(b[0].iter().all(|v| *v == -0.5), "the new clip did not replace the old");
    assert_eq!(shared.clips_done.len(), 1, "the replaced clip went back");
    shared.stop_clip();
    let (c, _) = h.render(&[], 300, 100);
    assert!(c[0].iter().all(|v| *v == 0.0), "stop did not silence");
    assert_eq!(shared.reclaim_clips(), 2);

    // With the return queue full the player takes no new clip (it would have to free one).
    for _ in 0..struck::editor::CLIP_RETURN {
        shared.clips_done.push(Clip::new(Vec::new())).expect("room");
    }
    // (0.75: below the output safety's −1 dBFS threshold, where it is bit-transparent.)
    shared.clips.push(Clip::new(vec![0.75; 100])).expect("room");
    let (d, _) = h.render(&[], 100, 100);
    assert!(d[0].iter().all(|v| *v == 0.0));
    assert_eq!(shared.clips.len(), 1, "the clip waits until the GUI frees the returned ones");
    shared.reclaim_clips();
    let (e, _) = h.render(&[], 100, 100);
    assert!(e[0].iter().all(|v| *v == 0.75));
}

/// A click on the object view holds no key: in a lasting excitation its contact is released
/// after `AUDITION_CONTACT_S`; while it lasts the editor is told where the contact is.
#[test]
fn an_audition_of_a_lasting_contact_ends_by_itself() {
    let mut h = OfflineHost::new(SR, 256).expect("host");
    h.set_param("excite", 1.0).expect("scrape");
    h.set_param("release", 60.0).expect("release");
    h.reset();
    let shared = h.plugin().editor_shared().clone();
    assert_eq!(shared.contact(), None);
    assert!(shared.audition(Audition { key: 60, velocity: 0.8, position: 0.25, serial: 1 }));
    let held = (struck::AUDITION_CONTACT_S * f64::from(SR)) as usize;
    let (out, _) = h.render(&[], held - 2_560, 256);
    let position = shared.contact().expect("a contact is sounding");
    assert!((0.0..=1.0).contains(&position) && position != 0.25, "the contact moved: {position}");
    let during = peak(&out[0][held / 2..]);
    let (after, _) = h.render(&[], SR as usize, 256);
    assert!(during > 1e-3 && peak(&after[0][SR as usize / 2..]) < 1e-4 * during);
    assert_eq!(shared.contact(), None);
    assert_eq!(shared.meters().0, 0, "the voice ended");
}
