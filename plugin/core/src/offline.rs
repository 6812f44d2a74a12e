//! An offline host: drives [`Struck`] (or the effect, [`crate::StruckResonator`]) through its own `activate()`, `reset()` and
//! `process()` the way a DAW does, for the command-line renderer and the tests.
//!
//! With the `assert_process_allocs` feature (and debug assertions) every `process()` call runs
//! under nice-plug's allocation assertion: an allocation in the audio path aborts the test.

use crate::{Instrument, Struck, StruckPlugin, Variant};
use nice_plug::prelude::*;
use std::collections::HashMap;

/// A note event at an absolute sample time of a render.
#[derive(Clone, Copy, Debug)]
pub struct TimedEvent {
    /// Absolute sample position.
    pub sample: u64,
    /// The event (its own `timing` is ignored and set per block).
    pub event: NoteEvent<()>,
}

/// Events sent by the plugin (voice terminations), with absolute sample positions.
pub type SentEvents = Vec<(u64, NoteEvent<()>)>;

struct Context<'a> {
    events: &'a [NoteEvent<()>],
    next: usize,
    sent: &'a mut Vec<NoteEvent<()>>,
    transport: Transport,
}

impl<V: Variant> ProcessContext<StruckPlugin<V>> for Context<'_> {
    fn plugin_api(&self) -> PluginApi {
        PluginApi::Clap
    }
    fn execute_background(&self, _task: ()) {}
    fn execute_gui(&self, _task: ()) {}
    fn transport(&self) -> &Transport {
        &self.transport
    }
    fn next_event(&mut self) -> Option<NoteEvent<()>> {
        let e = self.events.get(self.next).copied();
        self.next += 1;
        e
    }
    fn try_send_event(
        &mut self,
        event: NoteEvent<()>,
    ) -> Result<(), (NoteEvent<()>, nice_plug::context::process::SendEventError)> {
        if self.sent.len() < self.sent.capacity() {
            self.sent.push(event);
            Ok(())
        } else {
            Err((event, nice_plug::context::process::SendEventError::HostBufferFull))
        }
    }
    fn set_latency_samples(&self, _samples: u32) {}
    fn request_restart(&self) {}
    fn set_current_voice_capacity(&self, _capacity: u32) {}
}

struct Activate;
impl<V: Variant> ActivateContext<StruckPlugin<V>> for Activate {
    fn plugin_api(&self) -> PluginApi {
        PluginApi::Clap
    }
    fn execute(&self, _task: ()) {}
    fn set_latency_samples(&self, _samples: u32) {}
    fn set_current_voice_capacity(&self, _capacity: u32) {}
}

/// Sample rates the offline host runs at, Hz.
pub const SAMPLE_RATES: std::ops::RangeInclusive<f32> = 8_000.0..=768_000.0;

/// Checks that the offline host can run at `sample_rate`.
///
/// # Errors
/// [`HostError::Config`] outside [`SAMPLE_RATES`].
pub fn check_sample_rate(sample_rate: f32) -> Result<(), HostError> {
    if SAMPLE_RATES.contains(&sample_rate) {
        Ok(())
    } else {
        Err(HostError::Config(format!(
            "sample rate {sample_rate} Hz is outside {}..={} Hz",
            SAMPLE_RATES.start(),
            SAMPLE_RATES.end()
        )))
    }
}

/// Hosts one instance of the plugin offline: the instrument unless told otherwise.
pub struct OfflineHost<V: Variant = Instrument> {
    plugin: StruckPlugin<V>,
    params: HashMap<String, ParamPtr>,
    sample_rate: f32,
    max_block: usize,
    clock: u64,
    block_events: Vec<NoteEvent<()>>,
    sent: Vec<NoteEvent<()>>,
    left: Vec<f32>,
    right: Vec<f32>,
    buffer: Buffer<'static>,
    stats: RenderStats,
    /// The audio input layout is active, and its signal (left, right) from sample 0.
    input: Option<(Vec<f32>, Vec<f32>)>,
    /// The active layout has an input (the effect's always has).
    input_layout: bool,
    /// Channels of the input layout asked for: 2, or 1 for mono in and out.
    input_channels: u32,
    /// The tail the last `process()` call reported (`ProcessStatus::Tail`), samples.
    last_tail: Option<u32>,
}

/// Load figures of the `process()` calls an [`OfflineHost`] has made (`struck render
/// --stats`): voices and sounding modes are read from the engine after each call.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RenderStats {
    /// Samples rendered.
    pub samples: u64,
    /// Wall-clock time spent inside `process()`, s.
    pub process_s: f64,
    /// Most voices sounding after a call.
    pub peak_voices: usize,
    /// Σ voices × samples of each call (÷ `samples`: the mean).
    pub voice_samples: u64,
    /// Most sounding modes (all voices) after a call.
    pub peak_modes: usize,
    /// Σ sounding modes × samples of each call: the mode-samples the engine ran.
    pub mode_samples: u64,
    /// The host's sample rate, Hz.
    pub sample_rate: f64,
}

impl RenderStats {
    /// Mean voices over the samples rendered.
    pub fn mean_voices(&self) -> f64 {
        self.voice_samples as f64 / self.samples.max(1) as f64
    }
    /// Mean sounding modes over the samples rendered.
    pub fn mean_modes(&self) -> f64 {
        self.mode_samples as f64 / self.samples.max(1) as f64
    }
    /// Share of one core that rendering in real time at `sample_rate` would take.
    pub fn core_share(&self, sample_rate: f64) -> f64 {
        self.process_s / (self.samples as f64 / sample_rate).max(1e-12)
    }
    /// Mode-samples per second of `process()` time.
    pub fn mode_samples_per_s(&self) -> f64 {
        self.mode_samples as f64 / self.process_s.max(1e-12)
    }
}

// SAFETY: the raw parameter pointers point into `plugin`'s `Arc<StruckParams>`, which lives
// as long as the host and is only touched from the thread that owns the host.
unsafe impl Send for OfflineHost {}

/// Errors of the offline host.
#[derive(Debug, thiserror::Error)]
pub enum HostError {
    /// No parameter has this id.
    #[error("unknown parameter '{0}' (see `struck params` for the list)")]
    UnknownParam(String),
    /// The sample rate or block size cannot be used.
    #[error("{0}")]
    Config(String),
    /// A value outside the parameter's range (or a fraction for a stepped parameter).
    #[error("{id} ({name}) takes {kind} from {min} to {max}, not {value} (see `struck params`)")]
    OutOfRange {
        /// Parameter id.
        id: String,
        /// Its display name.
        name: String,
        /// The value given.
        value: f32,
        /// Lowest plain value.
        min: f32,
        /// Highest plain value.
        max: f32,
        /// "whole numbers" (integer, enum and bool parameters) or "values".
        kind: &'static str,
    },
}

impl OfflineHost {
    /// A fresh instrument activated at `sample_rate` with blocks of at most `max_block` samples.
    ///
    /// # Errors
    /// If the sample rate is outside 8 kHz..=768 kHz or `max_block` is 0 or over 65536.
    pub fn new(sample_rate: f32, max_block: usize) -> Result<Self, HostError> {
        Self::with_plugin(Struck::default(), sample_rate, max_block)
    }
}

impl<V: Variant> OfflineHost<V> {
    /// Hosts `plugin` (e.g. one whose parameters were set already).
    ///
    /// # Errors
    /// As [`OfflineHost::new`].
    pub fn with_plugin(plugin: StruckPlugin<V>, sample_rate: f32, max_block: usize) -> Result<Self, HostError> {
        check_sample_rate(sample_rate)?;
        if max_block == 0 || max_block > 65_536 {
            return Err(HostError::Config(format!("block size {max_block} is outside 1..=65536")));
        }
        let params = plugin.params().param_map().into_iter().map(|(id, ptr, _)| (id, ptr)).collect();
        let mut host = OfflineHost {
            plugin,
            params,
            sample_rate,
            max_block,
            clock: 0,
            block_events: Vec::with_capacity(4096),
            sent: Vec::with_capacity(4096),
            stats: RenderStats::default(),
            left: vec![0.0; max_block],
            right: vec![0.0; max_block],
            buffer: Buffer::default(),
            input: None,
            input_layout: false,
            input_channels: 2,
            last_tail: None,
        };
        host.activate();
        Ok(host)
    }

    /// Activates the plugin again with its stereo audio input layout (2 in, 2 out), the input
    /// playing `left` and `right` from sample 0 (then silence), and resets the clock.
    /// Allocates (not in `process()`).
    pub fn set_input(&mut self, left: Vec<f32>, right: Vec<f32>) {
        self.input = Some((left, right));
        self.input_channels = 2;
        self.activate();
    }

    /// As [`set_input`](Self::set_input) with a mono layout (1 in, 1 out, the effect's
    /// second): the plugin sees one channel; renders give its output as both channels.
    ///
    /// # Errors
    /// [`HostError::Config`] if the plugin has no mono layout.
    pub fn set_input_mono(&mut self, x: Vec<f32>) -> Result<(), HostError> {
        let mono =
            StruckPlugin::<V>::AUDIO_IO_LAYOUTS.iter().any(|l| l.main_input_channels.is_some_and(|c| c.get() == 1));
        if !mono {
            return Err(HostError::Config("the plugin has no mono layout".into()));
        }
        self.input = Some((x, Vec::new()));
        self.input_channels = 1;
        self.activate();
        Ok(())
    }

    fn activate(&mut self) {
        // The default layout, or with an input the first one with that many channels.
        let layouts = StruckPlugin::<V>::AUDIO_IO_LAYOUTS;
        let channels = self.input_channels;
        let layout = if self.input.is_some() {
            layouts.iter().find(|l| l.main_input_channels.is_some_and(|c| c.get() == channels)).unwrap_or(&layouts[0])
        } else {
            &layouts[0]
        };
        let layout = *layout;
        self.input_layout = layout.main_input_channels.is_some();
        let config = BufferConfig {
            sample_rate: self.sample_rate,
            min_buffer_size: None,
            max_buffer_size: self.max_block as u32,
            process_mode: ProcessMode::Offline,
        };
        for ptr in self.params.values() {
            // SAFETY: see the Send impl; the pointer targets live parameters.
            unsafe { ptr._internal_update_smoother(self.sample_rate, true) };
        }
        self.plugin.activate(&layout, &config, &mut Activate);
        self.plugin.reset();
        self.clock = 0;
    }

    /// The hosted plugin.
    pub fn plugin(&self) -> &StruckPlugin<V> {
        &self.plugin
    }

    /// The hosted plugin, mutably (for the command line's queries that use its engine).
    pub fn plugin_mut(&mut self) -> &mut StruckPlugin<V> {
        &mut self.plugin
    }

    /// Sample rate in Hz.
    pub fn sample_rate(&self) -> f32 {
        self.sample_rate
    }

    /// The tail the last `process()` call reported, samples (`None`: it reported none, as an
    /// instrument does).
    pub fn last_tail(&self) -> Option<u32> {
        self.last_tail
    }

    /// Load figures of every `process()` call so far.
    pub fn stats(&self) -> RenderStats {
        self.stats
    }

    /// Sets a parameter by id to a plain value (clamped to its range), as a host would
    /// between blocks.
    ///
    /// # Errors
    /// If no parameter has that id.
    pub fn set_param(&mut self, id: &str, plain: f32) -> Result<(), HostError> {
        let ptr = self.params.get(id).ok_or_else(|| HostError::UnknownParam(id.to_string()))?;
        // SAFETY: see the Send impl.
        unsafe {
            let normalized = ptr.preview_normalized(plain);
            ptr._internal_set_normalized_value(normalized);
            ptr._internal_update_smoother(self.sample_rate, false);
        }
        Ok(())
    }

    /// Sets a parameter like [`set_param`](Self::set_param), but refuses a value outside its
    /// range (or not a whole number for an integer, enum or bool parameter) instead of
    /// clamping it: for values typed by a user.
    ///
    /// # Errors
    /// [`HostError::UnknownParam`], [`HostError::OutOfRange`].
    pub fn set_param_checked(&mut self, id: &str, plain: f32) -> Result<(), HostError> {
        let ptr = self.params.get(id).ok_or_else(|| HostError::UnknownParam(id.to_string()))?;
        // SAFETY: see the Send impl.
        let (a, b, stepped, name) =
            unsafe { (ptr.preview_plain(0.0), ptr.preview_plain(1.0), ptr.step_count().is_some(), ptr.name()) };
        let (min, max) = (a.min(b), a.max(b));
        // Ranges are computed in f32: allow their last bit of rounding at the ends.
        let slack = (max - min).abs() * 1e-6;
        let inside = plain.is_finite() && plain >= min - slack && plain <= max + slack;
        if !inside || (stepped && plain.fract() != 0.0) {
            let kind = if stepped { "whole numbers" } else { "values" };
            return Err(HostError::OutOfRange {
                id: id.to_string(),
                name: name.to_string(),
                value: plain,
                min,
                max,
                kind,
            });
        }
        self.set_param(id, plain.clamp(min, max))
    }

    /// Sets a parameter from text typed by a user: a number (as
    /// [`set_param_checked`](Self::set_param_checked)), or one of a stepped parameter's
    /// options by name, compared without case, spaces, hyphens or underscores ("off",
    /// "as-recorded", "Amount"; "on"/"off" for a switch).
    ///
    /// # Errors
    /// [`HostError::UnknownParam`], [`HostError::OutOfRange`] for a number outside the range,
    /// [`HostError::Config`] naming the options for a name that is none of them.
    pub fn set_param_text(&mut self, id: &str, text: &str) -> Result<(), HostError> {
        let text = text.trim();
        if let Ok(v) = text.parse::<f32>() {
            return self.set_param_checked(id, v);
        }
        let ptr = *self.params.get(id).ok_or_else(|| HostError::UnknownParam(id.to_string()))?;
        let key = |s: &str| s.chars().filter(|c| c.is_alphanumeric()).flat_map(char::to_lowercase).collect::<String>();
        let wanted = key(text);
        // SAFETY: see the Send impl.
        let (steps, name) = unsafe { (ptr.step_count(), ptr.name().to_string()) };
        // A choice's own parser first (the object and material take ids and prefixes); not a
        // switch's, which takes any unknown text for off.
        if steps.is_some_and(|n| n > 1) {
            // SAFETY: see the Send impl.
            if let Some(normalized) = unsafe { ptr.string_to_normalized_value(text) } {
                // SAFETY: see the Send impl.
                let plain = unsafe { ptr.preview_plain(normalized) };
                return self.set_param_checked(id, plain);
            }
        }
        let mut names = Vec::new();
        if let Some(steps) = steps.filter(|&n| n > 0 && n <= 4096) {
            for i in 0..=steps {
                let normalized = i as f32 / steps as f32;
                // SAFETY: see the Send impl.
                let (label, plain) =
                    unsafe { (ptr.normalized_value_to_string(normalized, false), ptr.preview_plain(normalized)) };
                let on_off = match (steps, i) {
                    (1, 0) if label.eq_ignore_ascii_case("off") || label.eq_ignore_ascii_case("false") => "off",
                    (1, 1) if label.eq_ignore_ascii_case("on") || label.eq_ignore_ascii_case("true") => "on",
                    _ => "",
                };
                if key(&label) == wanted || (!on_off.is_empty() && wanted == on_off) {
                    return self.set_param_checked(id, plain);
                }
                names.push(label);
            }
        }
        Err(HostError::Config(if names.is_empty() {
            format!("{id} ({name}) takes a number, not '{text}' (see `struck params`)")
        } else {
            let more = if names.len() > 12 { format!(", … ({} in all)", names.len()) } else { String::new() };
            names.truncate(12);
            format!("{id} ({name}) takes a number or one of: {}{more}; not '{text}'", names.join(", "))
        }))
    }

    /// A parameter's plain value.
    ///
    /// # Errors
    /// If no parameter has that id.
    pub fn param(&self, id: &str) -> Result<f32, HostError> {
        let ptr = self.params.get(id).ok_or_else(|| HostError::UnknownParam(id.to_string()))?;
        // SAFETY: see the Send impl.
        Ok(unsafe { ptr.unmodulated_plain_value() })
    }

    /// Clears the plugin's voices and restarts the clock (as a host's transport reset).
    pub fn reset(&mut self) {
        self.plugin.reset();
        self.clock = 0;
    }

    /// Renders `num_samples` samples in blocks of `block_size` (the last may be shorter),
    /// applying `events` (sorted by sample) at their exact samples. Returns the stereo output
    /// and the events the plugin sent.
    pub fn render(
        &mut self,
        events: &[TimedEvent],
        num_samples: usize,
        block_size: usize,
    ) -> ([Vec<f32>; 2], SentEvents) {
        let mut out = [Vec::with_capacity(num_samples), Vec::with_capacity(num_samples)];
        let Ok(sent) = self.render_blocks(events, num_samples, block_size, |l, r| {
            out[0].extend_from_slice(l);
            out[1].extend_from_slice(r);
            Ok::<(), std::convert::Infallible>(())
        });
        (out, sent)
    }

    /// As [`render`](Self::render), but hands each block's left and right samples to `sink`
    /// instead of keeping them, so memory stays bounded by the block size whatever the length
    /// (the command line's `render` streams to disk this way). Stops at the first error of
    /// `sink`. Returns the events the plugin sent.
    ///
    /// # Errors
    /// The first error `sink` returns.
    pub fn render_blocks<E>(
        &mut self,
        events: &[TimedEvent],
        num_samples: usize,
        block_size: usize,
        mut sink: impl FnMut(&[f32], &[f32]) -> Result<(), E>,
    ) -> Result<SentEvents, E> {
        let block_size = block_size.clamp(1, self.max_block);
        let mut sent_all = Vec::new();
        let mut ev = 0;
        let mut pos = 0;
        while pos < num_samples {
            let n = block_size.min(num_samples - pos);
            let start = self.clock;
            self.block_events.clear();
            while ev < events.len() && events[ev].sample < start + n as u64 {
                let mut e = events[ev].event;
                set_timing(&mut e, events[ev].sample.saturating_sub(start) as u32);
                self.block_events.push(e);
                ev += 1;
            }
            self.process_block(n);
            sink(&self.left[..n], &self.right[..n])?;
            sent_all.extend(self.sent.drain(..).map(|e| (start + u64::from(e.timing()), e)));
            pos += n;
        }
        Ok(sent_all)
    }

    /// One `process()` call of `n` samples with `block_events`, into `left`/`right`.
    fn process_block(&mut self, n: usize) {
        if let Some((l, r)) = &self.input {
            // The input layout: the host's buffers hold the input (in place, as hosts do).
            let at = |x: &[f32], i: usize| x.get(self.clock as usize + i).copied().unwrap_or(0.0);
            for i in 0..n {
                self.left[i] = at(l, i);
                self.right[i] = at(r, i);
            }
        } else if self.input_layout {
            // An input port with nothing connected: silence.
            self.left[..n].fill(0.0);
            self.right[..n].fill(0.0);
        } else {
            // Garbage in the host's buffers must not leak out: the plugin writes every sample.
            self.left[..n].fill(f32::NAN);
            self.right[..n].fill(f32::NAN);
        }
        let (left, right) = (&mut self.left[..n], &mut self.right[..n]);
        // SAFETY: the slices live until the end of this function, where `buffer` is cleared
        // again before they are touched; the 'static lifetime never escapes this call.
        unsafe {
            let l: &'static mut [f32] = std::mem::transmute::<&mut [f32], &'static mut [f32]>(left);
            let r: &'static mut [f32] = std::mem::transmute::<&mut [f32], &'static mut [f32]>(right);
            let mono = self.input.is_some() && self.input_channels == 1;
            self.buffer.set_slices(n, |slices| {
                slices.clear();
                slices.push(l);
                if !mono {
                    slices.push(r);
                }
            });
        }
        let mut aux = AuxiliaryBuffers { inputs: &mut [], outputs: &mut [] };
        let mut ctx = Context {
            events: &self.block_events,
            next: 0,
            sent: &mut self.sent,
            transport: Transport::new(self.sample_rate),
        };
        let plugin = &mut self.plugin;
        let buffer = &mut self.buffer;
        let t0 = std::time::Instant::now();
        let mut tail = None;
        run_guarded(|| {
            if let ProcessStatus::Tail(n) = plugin.process(buffer, &mut aux, &mut ctx) {
                tail = Some(n);
            }
        });
        self.last_tail = tail;
        self.stats.process_s += t0.elapsed().as_secs_f64();
        // SAFETY: drop the borrowed slices (no allocation: capacity is kept).
        unsafe { self.buffer.set_slices(0, |slices| slices.clear()) };
        if self.input.is_some() && self.input_channels == 1 {
            // Mono: the one channel is both of the render's.
            self.right[..n].copy_from_slice(&self.left[..n]);
        }
        self.clock += n as u64;
        if let Some(engine) = self.plugin.engine() {
            let (voices, modes) = (engine.active_voices(), engine.active_modes());
            let st = &mut self.stats;
            st.sample_rate = f64::from(self.sample_rate);
            st.samples += n as u64;
            st.peak_voices = st.peak_voices.max(voices);
            st.peak_modes = st.peak_modes.max(modes);
            st.voice_samples += (voices * n) as u64;
            st.mode_samples += (modes * n) as u64;
        }
    }
}

/// Runs `f` under nice-plug's allocation assertion when it is enabled.
fn run_guarded(f: impl FnOnce()) {
    #[cfg(all(debug_assertions, feature = "assert_process_allocs"))]
    nice_assert_no_alloc::assert_no_alloc(f);
    #[cfg(not(all(debug_assertions, feature = "assert_process_allocs")))]
    f();
}

/// Sets the `timing` field of any note event.
pub fn set_timing(e: &mut NoteEvent<()>, t: u32) {
    match e {
        NoteEvent::NoteOn { timing, .. }
        | NoteEvent::NoteOff { timing, .. }
        | NoteEvent::Choke { timing, .. }
        | NoteEvent::VoiceTerminated { timing, .. }
        | NoteEvent::PolyModulation { timing, .. }
        | NoteEvent::MonoAutomation { timing, .. }
        | NoteEvent::PolyPressure { timing, .. }
        | NoteEvent::PolyVolume { timing, .. }
        | NoteEvent::PolyPan { timing, .. }
        | NoteEvent::PolyTuning { timing, .. }
        | NoteEvent::PolyVibrato { timing, .. }
        | NoteEvent::PolyExpression { timing, .. }
        | NoteEvent::PolyBrightness { timing, .. }
        | NoteEvent::MidiChannelPressure { timing, .. }
        | NoteEvent::MidiPitchBend { timing, .. }
        | NoteEvent::MidiCC { timing, .. }
        | NoteEvent::MidiProgramChange { timing, .. } => *timing = t,
        _ => {}
    }
}

/// A note-on event (timing is set by the host).
pub fn note_on(key: u8, velocity: f32) -> NoteEvent<()> {
    NoteEvent::NoteOn {
        timing: 0,
        voice_id: nice_plug::midi::VoiceID::Wildcard,
        channel: nice_plug::midi::Channel::Number(0),
        key: nice_plug::midi::Key::Number(key),
        velocity,
    }
}

/// A note-off event (timing is set by the host).
pub fn note_off(key: u8) -> NoteEvent<()> {
    NoteEvent::NoteOff {
        timing: 0,
        voice_id: nice_plug::midi::VoiceID::Wildcard,
        channel: nice_plug::midi::Channel::Number(0),
        key: nice_plug::midi::Key::Number(key),
        velocity: 0.0,
    }
}
