//! Standard MIDI files to note events for the offline renderer (via the `midly` crate).

use nice_plug::midi::{Channel, Key, VoiceID};
use nice_plug::prelude::NoteEvent;
use struck::offline::TimedEvent;

/// Reads the note-ons, note-offs, channel and polyphonic pressure, CC 1 (mod wheel: a lasting
/// contact's speed), CC 64 (sustain pedal), CC 74, CC 120 (All Sound Off) and CC 123 (All
/// Notes Off) of every track of a MIDI file, honouring tempo changes, as events at absolute
/// samples of `sample_rate`.
///
/// # Errors
/// A one-line reason if the bytes are not a MIDI file this can read (SMPTE timing is
/// supported; the file must be format 0 or 1), are corrupt (midly's `strict` checks: a track
/// cut short, a bad event, a wrong track count), or hold no note.
pub fn read_midi(bytes: &[u8], sample_rate: f64) -> Result<Vec<TimedEvent>, String> {
    let smf = midly::Smf::parse(bytes).map_err(|e| format!("not a readable MIDI file: {e}"))?;
    // Seconds per tick: from the header (SMPTE) or from tempo events (metrical).
    let (ppq, smpte_tick) = match smf.header.timing {
        midly::Timing::Metrical(t) if t.as_int() == 0 => {
            return Err("the header's time division is 0 ticks per quarter note: the file gives no timing".into())
        }
        midly::Timing::Metrical(t) => (f64::from(t.as_int()), None),
        midly::Timing::Timecode(_, 0) => {
            return Err("the header's SMPTE time division has 0 ticks per frame: the file gives no timing".into())
        }
        midly::Timing::Timecode(fps, sub) => (1.0, Some(1.0 / (f64::from(fps.as_f32()) * f64::from(sub)))),
    };
    // Merge all tracks into one list of (tick, order, kind).
    let mut all: Vec<(u64, usize, midly::TrackEventKind)> = Vec::new();
    for track in &smf.tracks {
        let mut tick = 0u64;
        for ev in track {
            tick += u64::from(ev.delta.as_int());
            all.push((tick, all.len(), ev.kind));
        }
    }
    all.sort_by_key(|&(t, o, _)| (t, o));
    let mut out = Vec::new();
    let mut us_per_beat = 500_000.0f64;
    let (mut last_tick, mut seconds) = (0u64, 0.0f64);
    for (tick, _, kind) in all {
        let dt = (tick - last_tick) as f64;
        seconds += smpte_tick.unwrap_or(us_per_beat * 1e-6 / ppq) * dt;
        last_tick = tick;
        let sample = (seconds * sample_rate).round() as u64;
        match kind {
            midly::TrackEventKind::Meta(midly::MetaMessage::Tempo(t)) if t.as_int() == 0 => {
                return Err(format!("a tempo event at tick {tick} sets 0 microseconds per beat (no finite tempo)"))
            }
            midly::TrackEventKind::Meta(midly::MetaMessage::Tempo(t)) => us_per_beat = f64::from(t.as_int()),
            midly::TrackEventKind::Midi { channel, message } => {
                let ch = channel.as_int();
                let channel = Channel::Number(ch);
                let event = match message {
                    midly::MidiMessage::NoteOn { key, vel } if vel.as_int() > 0 => Some(NoteEvent::NoteOn {
                        timing: 0,
                        voice_id: VoiceID::Wildcard,
                        channel,
                        key: Key::Number(key.as_int()),
                        velocity: f32::from(vel.as_int()) / 127.0,
                    }),
                    midly::MidiMessage::NoteOn { key, .. } | midly::MidiMessage::NoteOff { key, .. } => {
                        Some(NoteEvent::NoteOff {
                            timing: 0,
                            voice_id: VoiceID::Wildcard,
                            channel,
                            key: Key::Number(key.as_int()),
                            velocity: 0.0,
                        })
                    }
                    midly::MidiMessage::ChannelAftertouch { vel } => Some(NoteEvent::MidiChannelPressure {
                        timing: 0,
                        channel: ch,
                        pressure: f32::from(vel.as_int()) / 127.0,
                    }),
                    midly::MidiMessage::Aftertouch { key, vel } => Some(NoteEvent::PolyPressure {
                        timing: 0,
                        voice_id: VoiceID::Wildcard,
                        channel,
                        key: Key::Number(key.as_int()),
                        pressure: f32::from(vel.as_int()) / 127.0,
                    }),
                    midly::MidiMessage::Controller { controller, value }
                        if matches!(controller.as_int(), 1 | 64 | 74 | 120 | 121 | 123) =>
                    {
                        Some(NoteEvent::MidiCC {
                            timing: 0,
                            channel: ch,
                            cc: controller.as_int(),
                            value: f32::from(value.as_int()) / 127.0,
                        })
                    }
                    // −1..1 (centre 0x2000 exactly 0) to the plugin's 0..1 (centre 0.5).
                    midly::MidiMessage::PitchBend { bend } => {
                        Some(NoteEvent::MidiPitchBend { timing: 0, channel: ch, value: 0.5 * (bend.as_f32() + 1.0) })
                    }
                    _ => None,
                };
                if let Some(event) = event {
                    out.push(TimedEvent { sample, event });
                }
            }
            _ => {}
        }
    }
    if !out.iter().any(|e| matches!(e.event, NoteEvent::NoteOn { .. })) {
        return Err("the MIDI file holds no notes (no note-on event in any track)".into());
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A hand-assembled format-0 file: 96 ppq, tempo 120 bpm → 0.5 s per beat.
    #[test]
    fn reads_notes_at_tempo() {
        let mut trk = vec![];
        trk.extend([0x00, 0xFF, 0x51, 0x03, 0x07, 0xA1, 0x20]); // tempo 500000 µs
        trk.extend([0x00, 0x90, 60, 100]); // note on at 0
        trk.extend([0x60, 0x80, 60, 0]); // note off after 96 ticks = 0.5 s
        trk.extend([0x00, 0xFF, 0x2F, 0x00]);
        let mut f = b"MThd\x00\x00\x00\x06\x00\x00\x00\x01\x00\x60MTrk".to_vec();
        f.extend((trk.len() as u32).to_be_bytes());
        f.extend(trk);
        let ev = read_midi(&f, 48_000.0).unwrap();
        assert_eq!(ev.len(), 2);
        assert_eq!(ev[0].sample, 0);
        assert_eq!(ev[1].sample, 24_000);
        assert!(matches!(ev[1].event, NoteEvent::NoteOff { .. }));
        assert!(read_midi(b"not midi", 48_000.0).is_err());
    }

    /// A header division of 0 ticks per beat or a tempo of 0 µs per beat gives no timing:
    /// refused, not every note put at 0 s.
    #[test]
    fn refuses_a_zero_division_or_tempo() {
        let file = |division: u8, tempo: [u8; 3]| {
            let mut trk = vec![0x00, 0xFF, 0x51, 0x03];
            trk.extend(tempo);
            trk.extend([0x00, 0x90, 60, 100, 0x60, 0x80, 60, 0, 0x60, 0x90, 62, 100, 0x00, 0xFF, 0x2F, 0x00]);
            let mut f = b"MThd\x00\x00\x00\x06\x00\x00\x00\x01\x00".to_vec();
            f.push(division);
            f.extend(b"MTrk");
            f.extend((trk.len() as u32).to_be_bytes());
            f.extend(trk);
            f
        };
        let ok = read_midi(&file(0x60, [0x07, 0xA1, 0x20]), 48_000.0).unwrap();
        assert_eq!(ok.last().unwrap().sample, 48_000, "the second note at 192 ticks = 1 s");
        let e = read_midi(&file(0, [0x07, 0xA1, 0x20]), 48_000.0).unwrap_err();
        assert!(e.contains("0 ticks per quarter note"), "{e}");
        let e = read_midi(&file(0x60, [0, 0, 0]), 48_000.0).unwrap_err();
        assert!(e.contains("0 microseconds per beat"), "{e}");
    }

    /// The gestures of a lasting contact: poly aftertouch (force) and the mod wheel (speed)
    /// arrive as pressure and CC 1 on their note and channel; a pitch bend as the plugin's
    /// 0..1 (0x3000 of 0..0x3FFF is 0.75).
    #[test]
    fn reads_aftertouch_and_the_mod_wheel() {
        let mut trk = vec![];
        trk.extend([0x00, 0x91, 62, 90]); // note on, channel 2
        trk.extend([0x30, 0xA1, 62, 127]); // poly aftertouch 127 after 48 ticks (0.25 s)
        trk.extend([0x00, 0xB1, 1, 64]); // mod wheel 64
        trk.extend([0x00, 0xE1, 0x00, 0x60]); // pitch bend 0x3000: half way up
        trk.extend([0x30, 0x81, 62, 0]);
        trk.extend([0x00, 0xFF, 0x2F, 0x00]);
        let mut f = b"MThd\x00\x00\x00\x06\x00\x00\x00\x01\x00\x60MTrk".to_vec();
        f.extend((trk.len() as u32).to_be_bytes());
        f.extend(trk);
        let ev = read_midi(&f, 48_000.0).unwrap();
        assert_eq!(ev.len(), 5);
        assert_eq!(ev[1].sample, 12_000);
        assert!(matches!(
            ev[1].event,
            NoteEvent::PolyPressure { channel: Channel::Number(1), key: Key::Number(62), pressure, .. } if pressure == 1.0
        ));
        assert!(matches!(ev[2].event, NoteEvent::MidiCC { channel: 1, cc: 1, value, .. } if value == 64.0 / 127.0));
        assert!(matches!(ev[3].event, NoteEvent::MidiPitchBend { channel: 1, value, .. } if value == 0.75));
    }
}
