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
//!   changes every [`POLL_MS`] ms ([`IDLE_POLL_MS`] while no residual is set), never by the audio thread.
//! - **How it reaches the audio thread.** Each clip goes through a lock-free queue with the
//!   key it was made for; the audio thread takes it only if that is still the wanted key
//!   (a clip made for settings already left is freed, never played), and hands the clip it
//!   replaces back for the worker to free. Until a new clip arrives (one transfer:
//!   18 ms for a 1 s residual in the bench), strikes play the last one. With the layer off, a factory material or no
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
pub use crate::residual_field::{make_clip, Key, ResidualField, IDLE_POLL_MS, OFFLINE_WAIT_MS, POLL_MS};
use dsp::engine::{Engine, SoundParams};
use presets::residual::ResidualSpectrogram;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// The key the current settings want, `None` when no residual should play (layer off, not
/// the *Custom* material, no residual, no sample rate yet). Realtime-safe.
/// `full` is [`crate::sound_params_of`] for `p` (the caller has it already).
pub fn wanted_key(
    p: &StruckParams,
    library: &Library,
    full: SoundParams,
    sample_rate: f32,
    generation: u64,
) -> Option<Key> {
    if !p.residual.value()
        || p.material.value().max(0) as usize != library.custom_material_index()
        || generation == 0
        || !(sample_rate > 0.0)
    {
        return None;
    }
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
        recorded_support: full.recorded_support,
        normalize: full.normalize,
        ..SoundParams::default()
    };
    let root = p.root_note.value().clamp(0, 127) as u8;
    let strike = crate::strike_for_of(p, library, root, 1.0);
    Some(Key {
        generation,
        support_generation: p.user_support.generation(),
        object: crate::object_index_of(p, library),
        sound,
        strike,
        sample_rate,
    })
}

/// The residual of `report`'s first impact as a captured material keeps it: the first
/// [`presets::residual::SECONDS`] of the impact minus the modes the material (`law`, mean
/// support damping `support_c`) represents ([`estimator::residual::read_impact_residual`], Ren
/// §6.1), as a quantised log-power spectrogram with the impact's features. `path` is the
/// recording the report was made from (`channel` as the estimate read it); only the impact's
/// stretch of it is read ([`estimator::residual::read_impact_residual`]). `None` without
/// impacts.
///
/// # Errors
/// The recording cannot be read.
pub fn capture_residual(
    report: &estimator::EstimateReport,
    path: &std::path::Path,
    channel: Option<usize>,
    law: &dsp::Damping,
    support_c: f64,
) -> Result<Option<ResidualSpectrogram>, estimator::EstimateError> {
    let Some(imp) = report.impacts.first() else { return Ok(None) };
    let (x, _, rec) =
        estimator::residual::read_impact_residual(path, channel, imp, law, support_c, presets::residual::SECONDS)?;
    let sample_rate = rec.sample_rate;
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
    Ok(Some(ResidualSpectrogram::from_power(
        &spec.power,
        spec.frames,
        sample_rate,
        estimator::residual::FRAME as u32,
        estimator::residual::HOP as u32,
        modes,
    )))
}

/// Starts the worker thread if it is not running: it transfers whenever the wanted key
/// changes. Not for the audio thread.
pub fn start_worker(params: Arc<StruckParams>, library: Arc<Library>, sample_rate: Arc<dyn Fn() -> f32 + Send + Sync>) {
    if params.user_residual.has_worker() {
        return;
    }
    let params_for_slot = params.clone();
    let stop = Arc::new(AtomicBool::new(false));
    let flag = stop.clone();
    let spawned = std::thread::Builder::new().name("struck-residual".into()).spawn(move || {
        let mut engine: Option<(f32, Engine)> = None;
        let mut last: Option<Option<Key>> = None;
        while !flag.load(Ordering::Acquire) {
            let field = &params.user_residual;
            field.free_done();
            let fs = sample_rate();
            let wanted =
                wanted_key(&params, &library, crate::sound_params_of(&params, &library), fs, field.generation());
            if field.take_discarded() {
                last = None;
            }
            if last != Some(wanted) {
                if let (Some(k), Some(src)) = (wanted, field.source()) {
                    if engine.as_ref().is_none_or(|(rate, _)| *rate != fs) {
                        engine = Some((fs, Engine::new(library.object_modes(), 1, f64::from(fs))));
                    }
                    if let Some((_, e)) = engine.as_mut() {
                        // The modes decay as the audio thread's engine plays them.
                        params.user_support.install(e);
                        field.offer(k, make_clip(e, &src, &k));
                    }
                }
                last = Some(wanted);
            }
            // Without a residual (the common case) it looks less often: an instance that
            // plays none costs a wake-up every 100 ms, not every 15.
            let idle = params.user_residual.generation() == 0;
            std::thread::sleep(std::time::Duration::from_millis(if idle { IDLE_POLL_MS } else { POLL_MS }));
        }
    });
    if let Ok(handle) = spawned {
        if !params_for_slot.user_residual.install_worker(stop.clone(), handle) {
            stop.store(true, Ordering::Release);
        }
    }
}
