//! The residual layer's state (issue 15; see [`crate::residual_layer`]): the *Custom*
//! material's residual kept with the project, the key a transfer is made for, the transfer
//! itself ([`make_clip`]) and the lock-free way of its clips to the audio thread.

use crossbeam_queue::ArrayQueue;
use dsp::engine::{Engine, SoundParams, Strike};
use dsp::residual::ResidualClip;
use nice_plug::params::persist::PersistentField;
use presets::residual::ResidualSpectrogram;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;

/// Longest an offline render waits for a transfer, ms.
pub const OFFLINE_WAIT_MS: u64 = 2_000;
/// How often the worker looks for changed settings while no residual is set, ms.
pub const IDLE_POLL_MS: u64 = 100;
/// How often the worker looks for changed settings, ms.
pub const POLL_MS: u64 = 15;
/// The transfer's phase seed (a transfer is repeatable).
const SEED: u64 = 1;

/// What a transferred residual depends on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Key {
    /// The residual's generation (each set source is a new one).
    pub generation: u64,
    /// The recorded per-mode support's generation
    /// ([`crate::user_support::UserSupportField::generation`]).
    pub support_generation: u64,
    /// Object index.
    pub object: usize,
    /// The controls that shape the target modes (the others at their defaults).
    pub sound: SoundParams,
    /// A velocity-1 strike at the root key.
    pub strike: Strike,
    /// Sample rate, Hz.
    pub sample_rate: f32,
}

/// The residual transferred to `key`'s modes as the engine plays them (`engine` predicts
/// them; any engine on the same objects), `None` if the source does not decode or no mode
/// rings. Allocates; one transfer (18 ms for a 1 s residual in the bench).
pub fn make_clip(engine: &Engine, source: &ResidualSpectrogram, key: &Key) -> Option<Box<ResidualClip>> {
    use estimator::transfer::{transfer, Mode, Source};
    if source.frame as usize != estimator::residual::FRAME || source.hop as usize != estimator::residual::HOP {
        return None;
    }
    let power = source.to_power().ok()?;
    let src_modes: Vec<Mode> = source
        .modes
        .iter()
        .map(|m| Mode { freq_hz: m.freq_hz, decay_per_s: m.decay_per_s, amplitude: m.amplitude })
        .collect();
    let target: Vec<Mode> = engine
        .predict_modes_with(key.sound, key.object, key.strike)
        .into_iter()
        .map(|(f, d, a)| Mode { freq_hz: f, decay_per_s: d, amplitude: f64::from(a) })
        .collect();
    if target.is_empty() {
        return None;
    }
    let src = Source {
        power: &power,
        frames: source.frames as usize,
        sample_rate: f64::from(source.sample_rate),
        modes: &src_modes,
    };
    // At the recording's rate (its spectrogram's frames and bins keep their meaning), then
    // resampled to the engine's.
    let t = transfer(&mut estimator::residual::Stft::<f32>::new(), &src, &target, src.sample_rate, SEED);
    let at_source: Vec<f32> = t.signal.iter().map(|&v| if v.is_finite() { v as f32 } else { 0.0 }).collect();
    let samples = crate::resample::resample(&at_source, source.sample_rate, key.sample_rate.round() as u32).ok()?;
    Some(Box::new(ResidualClip { samples, lambda_factor: key.strike.lambda_factor }))
}

/// A transferred clip on its way to the audio thread, with the key it was made for.
type Handoff = (Key, Option<Box<ResidualClip>>);

/// The worker thread: its stop flag and handle.
struct Worker {
    stop: Arc<AtomicBool>,
    handle: JoinHandle<()>,
}

/// The *Custom* material's residual, kept with the project, and its transfers' way to the
/// audio thread.
pub struct ResidualField {
    /// The residual as saved with the project.
    source: Mutex<Option<ResidualSpectrogram>>,
    /// The residual's generation, 0 with none (read by the audio thread, never locked).
    generation: AtomicU64,
    /// Generations handed out so far.
    counter: AtomicU64,
    /// The audio thread handed back a clip made for settings already left.
    discarded: AtomicBool,
    /// Worker → audio thread: transferred clips with their keys.
    pending: ArrayQueue<Handoff>,
    /// Audio thread → worker: clips no longer played, freed by the worker.
    done: ArrayQueue<Box<ResidualClip>>,
    worker: Mutex<Option<Worker>>,
}

impl Default for ResidualField {
    fn default() -> Self {
        ResidualField {
            source: Mutex::new(None),
            generation: AtomicU64::new(0),
            counter: AtomicU64::new(0),
            discarded: AtomicBool::new(false),
            pending: ArrayQueue::new(4),
            done: ArrayQueue::new(8),
            worker: Mutex::new(None),
        }
    }
}

impl ResidualField {
    /// The residual kept (a copy).
    pub fn source(&self) -> Option<ResidualSpectrogram> {
        self.source.lock().ok().and_then(|s| s.clone())
    }

    /// Whether a residual is kept.
    pub fn is_set(&self) -> bool {
        self.source.lock().is_ok_and(|s| s.is_some())
    }

    /// The current residual's generation (0: none; each set residual has its own).
    /// Realtime-safe (an atomic load).
    pub fn generation(&self) -> u64 {
        self.generation.load(Ordering::Acquire)
    }

    /// Keeps `source` with the project (`None`: no residual); the next transfer uses it.
    /// Not for the audio thread.
    ///
    /// # Errors
    /// A residual that does not validate (nothing changes).
    pub fn set_source(&self, source: Option<ResidualSpectrogram>) -> Result<(), String> {
        if let Some(s) = &source {
            s.validate().map_err(|e| e.to_string())?;
        }
        let generation = if source.is_some() { self.counter.fetch_add(1, Ordering::AcqRel) + 1 } else { 0 };
        if let Ok(mut slot) = self.source.lock() {
            *slot = source;
        }
        self.generation.store(generation, Ordering::Release);
        Ok(())
    }

    /// Frees the clips the audio thread handed back. Not for the audio thread.
    pub fn free_done(&self) {
        while self.done.pop().is_some() {}
    }

    /// Hands `clip` to the audio thread (dropping the oldest waiting one if the queue is
    /// full). Not for the audio thread.
    pub fn offer(&self, key: Key, clip: Option<Box<ResidualClip>>) {
        let mut item = (key, clip);
        for _ in 0..8 {
            match self.pending.push(item) {
                Ok(()) => return,
                Err(back) => {
                    item = back;
                    let _ = self.pending.pop();
                }
            }
        }
    }

    /// Gives `engine` the clip `wanted` needs if it has arrived (clips made for another key
    /// are handed back unplayed). With `wanted` `None` nothing changes: the caller silences
    /// the layer, and the clip is there again if the same settings come back. `current` is
    /// the key of the engine's clip, kept by the caller.
    ///
    /// # Realtime safety
    /// Lock-free queue operations only; nothing is allocated or freed (a clip is taken only
    /// while the return queue has room for what it replaces).
    pub fn apply(&self, engine: &mut Engine, wanted: Option<Key>, current: &mut Option<Key>) {
        let hand_back = |clip: Option<Box<ResidualClip>>| {
            if let Some(c) = clip {
                if let Err(c) = self.done.push(c) {
                    std::mem::forget(c); // unreachable: room is checked first
                }
            }
        };
        let Some(want) = wanted else { return };
        while self.done.len() + 2 <= self.done.capacity() {
            let Some((key, clip)) = self.pending.pop() else { break };
            if key == want {
                hand_back(engine.set_residual(clip));
                *current = Some(key);
            } else {
                hand_back(clip);
                // The worker may take this key for delivered: it makes the wanted one again.
                self.discarded.store(true, Ordering::Release);
            }
        }
    }

    /// Transfers at once for `wanted` and plays the result in `engine` (activation, the
    /// command line). Allocates.
    pub fn refresh(&self, engine: &mut Engine, wanted: Option<Key>, current: &mut Option<Key>) {
        self.free_done();
        let clip = match (wanted, self.source()) {
            (Some(k), Some(src)) => make_clip(engine, &src, &k),
            _ => None,
        };
        drop(engine.set_residual(clip));
        *current = wanted;
    }

    /// Installs a running worker (its stop flag and handle); `false` if one runs already
    /// (the caller then stops the new one). Not for the audio thread.
    pub fn install_worker(&self, stop: Arc<AtomicBool>, handle: JoinHandle<()>) -> bool {
        let Ok(mut slot) = self.worker.lock() else { return false };
        if slot.is_some() {
            return false;
        }
        *slot = Some(Worker { stop, handle });
        true
    }

    /// Whether the audio thread handed back an outdated clip since the last call (the
    /// worker then transfers for the wanted settings again, even if it made them before).
    pub fn take_discarded(&self) -> bool {
        self.discarded.swap(false, Ordering::AcqRel)
    }

    /// Whether a worker runs.
    pub fn has_worker(&self) -> bool {
        self.worker.lock().is_ok_and(|w| w.is_some())
    }

    /// Stops the worker thread and waits for it. Not for the audio thread.
    pub fn stop_worker(&self) {
        let worker = self.worker.lock().ok().and_then(|mut w| w.take());
        if let Some(w) = worker {
            w.stop.store(true, Ordering::Release);
            let _ = w.handle.join();
        }
    }
}

impl<'a> PersistentField<'a, Option<ResidualSpectrogram>> for ResidualField {
    fn set(&self, new_value: Option<ResidualSpectrogram>) {
        // A saved state with a residual that does not validate loads without one.
        if self.set_source(new_value).is_err() {
            let _ = self.set_source(None);
        }
    }

    fn map<F, R>(&self, f: F) -> R
    where
        F: Fn(&Option<ResidualSpectrogram>) -> R,
    {
        match self.source.lock() {
            Ok(g) => f(&g),
            Err(p) => f(&p.into_inner()),
        }
    }
}
