//! The residual layer (issue 15 part 4; Ren, Yeh & Lin 2013 §6): a captured material's
//! residual, transferred to the object as played and handed to the audio thread.
//!
//! - **Where it comes from.** A captured material file keeps the residual of its first
//!   impact ([`presets::residual::ResidualSpectrogram`], made by [`capture_residual`]). Loaded
//!   into the *Custom* material (editor, command line), it is kept with the project as
//!   [`ResidualField`]. Factory materials carry none: their laws come from published tables,
//!   not from recordings Struck holds.
//! - **When it is transferred.** Whenever what the residual depends on changes: the object,
//!   its size and pitch, the material's law and support, the mallet and its hardness, the
//!   strike position, the sample rate or the residual itself ([`Key`]). The target modes are those a velocity-1 strike at the root
//!   key rings (`Engine::predict_modes_with`), the transfer is the estimator's
//!   ([`estimator::transfer`], Griffin–Lim included), run by a worker thread that looks for
//!   changes every [`POLL_MS`] ms, never by the audio thread.
//! - **How it reaches the audio thread.** Each clip goes through a lock-free queue with the
//!   key it was made for; the audio thread takes it only if that is still the wanted key
//!   (a clip made for settings already left is freed, never played), and hands the clip it
//!   replaces back for the worker to free. Until a new clip arrives (one transfer, about
//!   10 ms), strikes play the last one. With the layer off, a factory material or no
//!   residual, strikes play none (the clip is kept for when the settings come back).
//! - **Rates.** The transfer runs at the recording's sample rate; its result is resampled
//!   to the engine's (rubato), so the residual's level and band are the same at any host
//!   rate.
//! - **Offline.** Activation and [`crate::StruckPlugin::refresh_residual`] transfer at once on
//!   the calling thread, so a render plays the residual from its first note, the same on
//!   every run (the transfer's phases are seeded). A host rendering offline
//!   (`ProcessMode::Offline`) that changes a setting between blocks gets the block held
//!   until the worker delivers (at most [`OFFLINE_WAIT_MS`] ms once per key), so offline
//!   renders never depend on the worker's timing.

use crate::library::Library;
use crate::params::StruckParams;
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
/// How often the worker looks for changed settings, ms.
pub const POLL_MS: u64 = 15;
/// The transfer's phase seed (a transfer is repeatable).
const SEED: u64 = 1;

/// What a transferred residual depends on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Key {
    /// The residual's generation (each set source is a new one).
    pub generation: u64,
    /// Object index.
    pub object: usize,
    /// The controls that shape the target modes (the others at their defaults).
    pub sound: SoundParams,
    /// A velocity-1 strike at the root key.
    pub strike: Strike,
    /// Sample rate, Hz.
    pub sample_rate: f32,
}

/// The key the current settings want, `None` when no residual should play (layer off, not
/// the *Custom* material, no residual, no sample rate yet). Realtime-safe.
pub fn wanted_key(p: &StruckParams, library: &Library, sample_rate: f32, generation: u64) -> Option<Key> {
    if !p.residual.value()
        || p.material.value().max(0) as usize != library.custom_material_index()
        || generation == 0
        || !(sample_rate > 0.0)
    {
        return None;
    }
    let full = crate::sound_params_of(p, library);
    let sound = SoundParams {
        damping: full.damping,
        decay_scale: full.decay_scale,
        modulus_ratio: full.modulus_ratio,
        size: full.size,
        mallet: full.mallet,
        hardness: full.hardness,
        quality_db: full.quality_db,
        support_c: full.support_c,
        support_point: full.support_point,
        normalize: full.normalize,
        ..SoundParams::default()
    };
    let root = p.root_note.value().clamp(0, 127) as u8;
    let strike = crate::strike_for_of(p, library, root, 1.0);
    Some(Key { generation, object: crate::object_index_of(p, library), sound, strike, sample_rate })
}

/// The residual transferred to `key`'s modes as the engine plays them (`engine` predicts
/// them; any engine on the same objects), `None` if the source does not decode or no mode
/// rings. Allocates; about 10 ms for the 0.35 s a capture keeps.
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
    let samples = crate::editor::ab::resample(&at_source, source.sample_rate, key.sample_rate.round() as u32).ok()?;
    Some(Box::new(ResidualClip { samples, lambda_factor: key.strike.lambda_factor }))
}

/// The residual of `report`'s first impact as a captured material keeps it: the first
/// [`presets::residual::SECONDS`] of the impact minus the modes the material (`law`, mean
/// support damping `support_c`) represents ([`estimator::residual::impact_residual`], Ren
/// §6.1), as a quantised log-power spectrogram with the impact's features. `samples` is the
/// recording the report was made from (mono, at `sample_rate`). `None` without impacts.
pub fn capture_residual(
    report: &estimator::EstimateReport,
    samples: &[f32],
    sample_rate: u32,
    law: &dsp::Damping,
    support_c: f64,
) -> Option<ResidualSpectrogram> {
    let imp = report.impacts.first()?;
    let (x, _) = estimator::residual::impact_residual(
        samples,
        f64::from(sample_rate),
        imp,
        law,
        support_c,
        presets::residual::SECONDS,
    );
    let spec = estimator::residual::power_spectrogram(&x);
    let modes = imp
        .features
        .iter()
        .map(|f| presets::residual::ResidualMode {
            freq_hz: f.freq_hz,
            decay_per_s: f.decay_per_s,
            amplitude: f.amplitude,
        })
        .collect();
    Some(ResidualSpectrogram::from_power(
        &spec.power,
        spec.frames,
        sample_rate,
        estimator::residual::FRAME as u32,
        estimator::residual::HOP as u32,
        modes,
    ))
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
    fn free_done(&self) {
        while self.done.pop().is_some() {}
    }

    /// Hands `clip` to the audio thread (dropping the oldest waiting one if the queue is
    /// full). Not for the audio thread.
    fn offer(&self, key: Key, clip: Option<Box<ResidualClip>>) {
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

    /// Starts the worker thread if it is not running: it transfers whenever the wanted key
    /// changes. Not for the audio thread.
    pub fn start_worker(
        &self,
        params: Arc<StruckParams>,
        library: Arc<Library>,
        sample_rate: Arc<dyn Fn() -> f32 + Send + Sync>,
    ) {
        let Ok(mut slot) = self.worker.lock() else { return };
        if slot.is_some() {
            return;
        }
        let stop = Arc::new(AtomicBool::new(false));
        let flag = stop.clone();
        let spawned = std::thread::Builder::new().name("struck-residual".into()).spawn(move || {
            let mut engine: Option<(f32, Engine)> = None;
            let mut last: Option<Option<Key>> = None;
            while !flag.load(Ordering::Acquire) {
                let field = &params.user_residual;
                field.free_done();
                let fs = sample_rate();
                let wanted = wanted_key(&params, &library, fs, field.generation());
                if last != Some(wanted) {
                    if let (Some(k), Some(src)) = (wanted, field.source()) {
                        if engine.as_ref().is_none_or(|(rate, _)| *rate != fs) {
                            engine = Some((fs, Engine::new(library.object_modes(), 1, f64::from(fs))));
                        }
                        if let Some((_, e)) = engine.as_ref() {
                            field.offer(k, make_clip(e, &src, &k));
                        }
                    }
                    last = Some(wanted);
                }
                std::thread::sleep(std::time::Duration::from_millis(POLL_MS));
            }
        });
        if let Ok(handle) = spawned {
            *slot = Some(Worker { stop, handle });
        }
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
