//! What the audio thread and the editor share, in one module both sides import (the audio
//! path does not import the editor): the audition queue (GUI → audio strikes), the meters
//! (audio → GUI), and clip playback for the A/B comparison (clips built and freed on the GUI
//! side, only read on the audio thread), and the last capture's record the parameters persist.

use crossbeam_queue::ArrayQueue;
use dsp::engine::NoteId;
use estimator::EstimateReport;
use serde::{Deserialize, Serialize};
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};

/// Capacity of the audition queue (clicks faster than the audio thread drains are dropped).
pub const AUDITION_QUEUE: usize = 64;
/// Number of distinct voice ids auditions cycle through, so quick clicks overlap.
const AUDITION_VOICES: i32 = 16;
/// Clips waiting to be played (GUI → audio). A new clip replaces the one playing.
pub const CLIP_QUEUE: usize = 2;
/// Clips handed back for freeing (audio → GUI). The audio thread takes a new clip only while
/// this queue has room, so it never has to drop (free) one itself.
pub const CLIP_RETURN: usize = 4;

/// A mono clip the editor plays through the plugin's output: the A/B comparison of a
/// recording and its resynthesis. Built and freed on the GUI side; the audio thread only
/// reads it.
#[derive(Debug)]
pub struct Clip {
    samples: Vec<f32>,
    pos: usize,
}

impl Clip {
    /// A clip of these samples (at the plugin's sample rate, full scale ±1).
    pub fn new(samples: Vec<f32>) -> Box<Clip> {
        Box::new(Clip { samples, pos: 0 })
    }

    /// The samples.
    pub fn samples(&self) -> &[f32] {
        &self.samples
    }

    fn finished(&self) -> bool {
        self.pos >= self.samples.len()
    }
}

/// The audio thread's side of clip playback (owned by the plugin).
#[derive(Debug, Default)]
pub struct ClipPlayer {
    current: Option<Box<Clip>>,
}

impl ClipPlayer {
    /// Picks up a new clip or a stop request, then adds the clip's next `out.len()` samples
    /// to `out`.
    ///
    /// # Realtime safety
    /// Lock-free queue operations and a copy; a clip is never freed here: finished or replaced
    /// clips go back to the GUI through [`EditorShared::clips_done`], and a new clip is taken
    /// only while that queue has room.
    pub fn mix(&mut self, shared: &EditorShared, out: &mut [f32]) {
        if shared.stop_clip.swap(false, Ordering::Relaxed) {
            if let Some(c) = self.current.as_mut() {
                c.pos = c.samples.len();
            }
        }
        if !shared.clips_done.is_full() {
            if let Some(new) = shared.clips.pop() {
                if let Some(old) = self.current.replace(new) {
                    // Room was checked above and only this thread pushes.
                    if let Err(old) = shared.clips_done.push(old) {
                        std::mem::forget(old); // unreachable: never free on the audio thread
                    }
                }
            }
        }
        if let Some(c) = self.current.as_mut() {
            let n = out.len().min(c.samples.len() - c.pos.min(c.samples.len()));
            for (o, s) in out[..n].iter_mut().zip(&c.samples[c.pos..c.pos + n]) {
                *o += *s;
            }
            c.pos += n;
        }
        if self.current.as_ref().is_some_and(|c| c.finished()) {
            if let Some(c) = self.current.take() {
                // Full return queue: keep the (silent) clip and hand it back next block.
                if let Err(c) = shared.clips_done.push(c) {
                    self.current = Some(c);
                }
            }
        }
        shared.clip_playing.store(self.current.as_ref().is_some_and(|c| !c.finished()), Ordering::Relaxed);
    }
}

/// A strike requested by the editor, played at the start of the next audio block.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Audition {
    /// Key whose tuning the strike uses (as a MIDI note-on of this key would).
    pub key: u8,
    /// Velocity 0..=1.
    pub velocity: f32,
    /// Strike position 0..=1 along the bank's strike points.
    pub position: f32,
    /// Sequence number (the editor counts clicks); picks the audition voice id.
    pub serial: u32,
}

impl Audition {
    /// The engine note id: negative voice ids (which hosts never use) mark auditions.
    pub fn note(&self) -> NoteId {
        let slot = (self.serial % AUDITION_VOICES as u32) as i32;
        NoteId { voice_id: Some(-1 - slot), channel: 0, key: self.key }
    }
}

/// Whether `note` is one of the editor's auditions (not to be reported to the host).
pub fn is_audition(note: &NoteId) -> bool {
    note.voice_id.is_some_and(|v| v < 0)
}

/// State shared between the plugin's audio thread and the editor.
pub struct EditorShared {
    /// GUI → audio: strikes to play. `push`/`pop` are lock-free and do not allocate.
    pub audition: ArrayQueue<Audition>,
    /// Audio → GUI: sounding voices at the end of the last block.
    pub active_voices: AtomicU32,
    /// Audio → GUI: modes rendered over all voices at the end of the last block.
    pub active_modes: AtomicU32,
    /// GUI → audio: clips to play (see [`ClipPlayer`]).
    pub clips: ArrayQueue<Box<Clip>>,
    /// Audio → GUI: clips finished or replaced, to be freed by the GUI.
    pub clips_done: ArrayQueue<Box<Clip>>,
    /// GUI → audio: stop the clip playing.
    pub stop_clip: AtomicBool,
    /// Audio → GUI: a clip is sounding.
    pub clip_playing: AtomicBool,
    /// Audio → GUI: the sample rate of the last activation, Hz (`f32` bits; 0 before).
    pub sample_rate: AtomicU32,

    /// Audio → GUI: where the newest lasting contact is on the strike path (`f32` bits of
    /// 0..=1; NaN when none).
    pub contact_position: AtomicU32,
}

impl Default for EditorShared {
    fn default() -> Self {
        EditorShared {
            audition: ArrayQueue::new(AUDITION_QUEUE),
            active_voices: AtomicU32::new(0),
            active_modes: AtomicU32::new(0),
            clips: ArrayQueue::new(CLIP_QUEUE),
            clips_done: ArrayQueue::new(CLIP_RETURN),
            stop_clip: AtomicBool::new(false),
            clip_playing: AtomicBool::new(false),
            sample_rate: AtomicU32::new(0),

            contact_position: AtomicU32::new(f32::NAN.to_bits()),
        }
    }
}

impl EditorShared {
    /// Stores the meters.
    ///
    /// # Realtime safety
    /// Two relaxed atomic stores.
    pub fn store_meters(&self, voices: usize, modes: usize) {
        self.active_voices.store(voices.min(u32::MAX as usize) as u32, Ordering::Relaxed);
        self.active_modes.store(modes.min(u32::MAX as usize) as u32, Ordering::Relaxed);
    }

    /// Stores where the newest lasting contact is (`None`: no contact).
    ///
    /// # Realtime safety
    /// One relaxed atomic store.
    pub fn store_contact(&self, position: Option<f32>) {
        self.contact_position.store(position.unwrap_or(f32::NAN).to_bits(), Ordering::Relaxed);
    }

    /// Where the newest lasting contact is on the strike path, if one is sounding.
    pub fn contact(&self) -> Option<f32> {
        Some(f32::from_bits(self.contact_position.load(Ordering::Relaxed))).filter(|p| p.is_finite())
    }

    /// `(active voices, active modes)` as last stored.
    pub fn meters(&self) -> (u32, u32) {
        (self.active_voices.load(Ordering::Relaxed), self.active_modes.load(Ordering::Relaxed))
    }

    /// Queues a strike; `false` if the queue is full (the strike is dropped).
    pub fn audition(&self, a: Audition) -> bool {
        self.audition.push(a).is_ok()
    }

    /// Frees the clips the audio thread handed back (GUI side); returns how many.
    pub fn reclaim_clips(&self) -> usize {
        let mut n = 0;
        while self.clips_done.pop().is_some() {
            n += 1;
        }
        n
    }

    /// Queues a clip to play from the next audio block on, replacing the one playing (GUI
    /// side). `Err` gives the clip back if the queue is full.
    pub fn play_clip(&self, clip: Box<Clip>) -> Result<(), Box<Clip>> {
        self.reclaim_clips();
        self.clips.push(clip)
    }

    /// Asks the audio thread to stop the clip playing.
    pub fn stop_clip(&self) {
        self.stop_clip.store(true, Ordering::Relaxed);
    }

    /// The sample rate the plugin was last activated at (48 kHz before any activation).
    pub fn sample_rate(&self) -> f32 {
        let sr = f32::from_bits(self.sample_rate.load(Ordering::Relaxed));
        if sr.is_finite() && sr > 0.0 {
            sr
        } else {
            48_000.0
        }
    }
}

/// The last capture, persisted with the plugin state: the files' names and the estimator's
/// report (features and fits, no audio).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CaptureRecord {
    /// The recordings analysed.
    pub files: Vec<String>,
    /// What the estimator found.
    pub report: EstimateReport,
    /// The object the recordings were matched to (its bank id and reference specific
    /// modulus γ₀), when "Recordings are of the current object" was on.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub object: Option<CapturedObject>,
}

/// The known object of a capture.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CapturedObject {
    /// Bank id.
    pub id: String,
    /// The bank's reference specific modulus γ₀ (m²/s²).
    pub specific_modulus: f64,
}

/// The support damping recorded mode by mode on `bank` (issue 10 part 6;
/// [`EstimateReport::support_by_mode`]) for a material of `fit`, when the recordings were
/// matched to that bank; `None` when no mode matched.
pub fn recorded_modes(
    report: &EstimateReport,
    fit: &estimator::FitResult,
    bank: &presets::Bank,
) -> Option<presets::RecordedModes> {
    let gains = bank.max_gains();
    let modes: Vec<presets::RecordedMode> = report
        .support_by_mode(fit, &bank.lambdas, Some(&gains))
        .into_iter()
        .map(|m| presets::RecordedMode {
            mode: m.mode,
            lambda: m.lambda,
            extra_c_per_s: m.extra_c_per_s.min(estimator::MAX_SUPPORT_C),
            partials: m.partials,
        })
        .collect();
    (!modes.is_empty()).then(|| presets::RecordedModes { object: bank.id.clone(), modes })
}

impl CaptureRecord {
    /// The support damping recorded mode by mode on the capture's object, for `fit`
    /// ([`recorded_modes`]), when "Recordings are of the current object" was on and that
    /// object is in `library`.
    pub fn recorded_modes(
        &self,
        fit: &estimator::FitResult,
        library: &crate::library::Library,
    ) -> Option<presets::RecordedModes> {
        let object = self.object.as_ref()?;
        let bank = &library.banks[library.bank_index(&object.id)?];
        recorded_modes(&self.report, fit, bank)
    }

    /// γ = (γ/γ₀)·γ₀ from the object match, if there was one and it is usable (a pitch the
    /// instrument plays: [`estimator::object::PLAYABLE_GAMMA_RATIO`]).
    pub fn specific_modulus(&self) -> Option<f64> {
        match (&self.object, &self.report.object) {
            (Some(o), Some(m))
                if estimator::object::playable_gamma_ratio(m.gamma_ratio) && o.specific_modulus > 0.0 =>
            {
                Some(m.gamma_ratio * o.specific_modulus)
            }
            _ => None,
        }
    }
}
