//! Struck's plugin (CLAP and VST3, built with nice-plug) in two variants: the instrument
//! ([`Struck`]) and the effect ([`StruckResonator`], the object as a resonator for the track's
//! audio, issue 16). One type, [`StruckPlugin`], plays both; a [`Variant`] sets what a host
//! sees (name, identifiers, audio ports). The packages `struck` and `struck-resonator` export
//! them, one plugin per bundle.
//!
//! Glue only: parameters live in [`params`], the objects and materials in [`library`], the
//! synthesis in the `dsp` crate; [`offline`] hosts this plugin for the command line (crate
//! `struck-cli`) and the tests.

#![warn(missing_docs)]
pub mod editor;
pub mod library;
pub mod offline;
pub mod params;
pub mod resample;
pub mod residual_field;
pub mod residual_layer;
pub mod shared;
pub mod user_support;
pub mod user_texture;

use dsp::engine::{ContactParams, Engine, NoteId, SoundParams, Strike};
use dsp::ftz::DenormalGuard;
use library::Library;
use nice_plug::midi::{Channel, Key, VoiceID};
use nice_plug::prelude::*;
use params::{KeyMode, PitchReference, StruckParams, SupportMode, MAX_SUPPORT_PER_S, POSITION_POLY_MOD_ID};
use std::sync::Arc;

/// Voices in the pool (the CLAP voice capacity).
pub const MAX_VOICES: usize = 64;
/// Modes tried as the *Strongest mode* pitch reference of a note.
pub const PITCH_CANDIDATES: usize = 6;
/// Mono scratch length; longer host buffers are processed in pieces of this size.
pub const MAX_BLOCK: usize = 8192;

/// What a host sees of one variant of the plugin: names, identifiers and audio ports, and
/// what an effect does that an instrument does not (its dry path, its tail). The synthesis,
/// parameters, state and editor are the same in both.
pub trait Variant: 'static + Send + Sync {
    /// The plugin's name in hosts.
    const NAME: &'static str;
    /// The CLAP identifier.
    const CLAP_ID: &'static str;
    /// The CLAP description.
    const CLAP_DESCRIPTION: &'static str;
    /// The CLAP features (instrument or audio effect).
    const CLAP_FEATURES: &'static [ClapFeature];
    /// The VST3 class identifier.
    const VST3_CLASS_ID: [u8; 16];
    /// The VST3 subcategories.
    const VST3_SUBCATEGORIES: &'static [Vst3SubCategory];
    /// The audio ports, the first the default.
    const AUDIO_IO_LAYOUTS: &'static [AudioIOLayout];
    /// An effect keeps its input in the output (dry/wet; all of it with *Audio in* off) and
    /// reports its tail to the host.
    const EFFECT: bool;
}

/// The instrument: notes strike or hold contact; a host that offers its second layout (a
/// stereo input) also reaches *Audio in*.
pub struct Instrument;

/// The effect (*Struck Resonator*): the track's audio (stereo or mono) drives the object at
/// the contact position, for every host, since every host has effect slots. Notes still
/// strike.
pub struct Effect;

impl Variant for Instrument {
    const NAME: &'static str = "Struck";
    const CLAP_ID: &'static str = "org.struck.struck";
    const CLAP_DESCRIPTION: &'static str = "Modal synthesis of struck objects: any object, any material";
    const CLAP_FEATURES: &'static [ClapFeature] =
        &[ClapFeature::Instrument, ClapFeature::Synthesizer, ClapFeature::Stereo];
    const VST3_CLASS_ID: [u8; 16] = *b"StruckModalSynth";
    const VST3_SUBCATEGORIES: &'static [Vst3SubCategory] = &[Vst3SubCategory::Instrument, Vst3SubCategory::Synth];
    const EFFECT: bool = false;
    // The instrument (no input), and the same with a stereo input: the object as a
    // resonator for any sound (*Audio in*, issue 16), for hosts that offer the layout.
    const AUDIO_IO_LAYOUTS: &'static [AudioIOLayout] = &[
        AudioIOLayout {
            main_input_channels: None,
            main_output_channels: NonZeroU32::new(2),
            ..AudioIOLayout::const_default()
        },
        AudioIOLayout {
            main_input_channels: NonZeroU32::new(2),
            main_output_channels: NonZeroU32::new(2),
            ..AudioIOLayout::const_default()
        },
    ];
}

impl Variant for Effect {
    const NAME: &'static str = "Struck Resonator";
    const CLAP_ID: &'static str = "org.struck.resonator";
    const CLAP_DESCRIPTION: &'static str =
        "Any sound played through a struck object: modal resonator of any object, any material";
    const CLAP_FEATURES: &'static [ClapFeature] =
        &[ClapFeature::AudioEffect, ClapFeature::Filter, ClapFeature::Stereo, ClapFeature::Mono];
    const VST3_CLASS_ID: [u8; 16] = *b"StruckResonatorF";
    const VST3_SUBCATEGORIES: &'static [Vst3SubCategory] = &[Vst3SubCategory::Fx, Vst3SubCategory::Filter];
    const EFFECT: bool = true;
    // Stereo (the default) and mono; the input is mixed to mono before the object.
    const AUDIO_IO_LAYOUTS: &'static [AudioIOLayout] = &[
        AudioIOLayout {
            main_input_channels: NonZeroU32::new(2),
            main_output_channels: NonZeroU32::new(2),
            ..AudioIOLayout::const_default()
        },
        AudioIOLayout {
            main_input_channels: NonZeroU32::new(1),
            main_output_channels: NonZeroU32::new(1),
            ..AudioIOLayout::const_default()
        },
    ];
}

/// The instrument plugin.
pub type Struck = StruckPlugin<Instrument>;
/// The effect plugin.
pub type StruckResonator = StruckPlugin<Effect>;

/// The plugin, in either variant.
pub struct StruckPlugin<V: Variant> {
    variant: std::marker::PhantomData<V>,
    params: Arc<StruckParams>,
    library: Arc<Library>,
    engine: Option<Engine>,
    mono: Vec<f32>,
    sample_rate: f32,
    /// State shared with the editor: audition queue (GUI → audio) and meters (audio → GUI).
    editor_shared: Arc<shared::EditorShared>,
    /// The editor's A/B clip playing, if any.
    clip_player: shared::ClipPlayer,
    /// The last MIDI CC 74 (MPE timbre) of each channel, 0..=1: the strike position of that
    /// channel's next notes (MPE sends a note's initial timbre just before its note-on).
    channel_timbre: [Option<f32>; 16],
    /// The host activated the layout with an audio input.
    has_input: bool,
    /// The input mixed to mono, and the output gain per sample, for one chunk.
    input_mono: Vec<f32>,
    gains: Vec<f32>,
    /// The editor's audition of a lasting contact (a click holds no key): released after
    /// [`AUDITION_CONTACT_S`]; the note and the samples left.
    audition_contact: Option<(NoteId, u64)>,
    /// What the engine's residual clip was transferred for (issue 15; [`residual_layer`]).
    residual_key: Option<residual_layer::Key>,
    /// The host renders offline: a block waits for the residual its settings want.
    offline: bool,
    /// The last key an offline block waited for (it waits once per key).
    residual_waited: Option<residual_layer::Key>,
}

/// The longest tail the effect reports to its host, s.
pub const MAX_TAIL_S: f32 = 60.0;

/// How long a click on the object view keeps a lasting contact, s.
pub const AUDITION_CONTACT_S: f64 = 1.0;

impl<V: Variant> Default for StruckPlugin<V> {
    fn default() -> Self {
        StruckPlugin::with_library(Library::factory())
    }
}

impl<V: Variant> StruckPlugin<V> {
    /// An instance playing `library` (the command line uses it to play a bank file).
    pub fn with_library(library: Arc<Library>) -> Self {
        StruckPlugin {
            variant: std::marker::PhantomData,
            params: Arc::new(StruckParams::new(&library)),
            library,
            engine: None,
            mono: Vec::new(),
            sample_rate: 48_000.0,
            editor_shared: Arc::new(shared::EditorShared::default()),
            clip_player: shared::ClipPlayer::default(),
            channel_timbre: [None; 16],
            has_input: false,
            input_mono: Vec::new(),
            gains: Vec::new(),
            audition_contact: None,
            residual_key: None,
            offline: false,
            residual_waited: None,
        }
    }
}

impl<V: Variant> Drop for StruckPlugin<V> {
    fn drop(&mut self) {
        self.params.user_residual.stop_worker();
    }
}

impl<V: Variant> StruckPlugin<V> {
    /// The parameters (shared with hosts and the offline renderer).
    pub fn struck_params(&self) -> &Arc<StruckParams> {
        &self.params
    }

    /// The library this instance plays.
    pub fn library(&self) -> &Arc<Library> {
        &self.library
    }

    /// State shared with the editor (audition queue, meters).
    pub fn editor_shared(&self) -> &Arc<shared::EditorShared> {
        &self.editor_shared
    }

    /// Plays `file` as the user texture (*Texture* = User file) and keeps it with the project.
    /// Not for the audio thread (allocates; setters queue the texture for it, see [`user_texture`]).
    ///
    /// # Errors
    /// A profile the engine refuses (one line).
    pub fn set_user_texture(&mut self, file: presets::texture::TextureFile) -> Result<(), String> {
        self.params.user_texture.set_file(Some(file))?;
        if let Some(e) = self.engine.as_mut() {
            self.params.user_texture.apply(e);
        }
        Ok(())
    }

    /// Sets (or clears) the *Custom* material's support damping recorded mode by mode (a
    /// captured material's `support.recorded_modes`), kept with the project and played on
    /// its object while *Support* is *As recorded*. Not for the audio thread.
    ///
    /// # Errors
    /// A recorded support that does not validate.
    pub fn set_user_support(
        &mut self,
        support: Option<presets::RecordedModes>,
    ) -> Result<user_support::SupportMapping, String> {
        let mapping = self.params.user_support.set_source(support)?;
        if let Some(e) = self.engine.as_mut() {
            self.params.user_support.apply(e);
        }
        Ok(mapping)
    }

    /// Keeps `residual` as the *Custom* material's residual (with the project); it plays
    /// once transferred (at once with [`refresh_residual`](Self::refresh_residual), else by
    /// the worker within milliseconds). Not for the audio thread.
    ///
    /// # Errors
    /// A residual that does not validate (one line).
    pub fn set_user_residual(
        &mut self,
        residual: Option<presets::residual::ResidualSpectrogram>,
    ) -> Result<(), String> {
        self.params.user_residual.set_source(residual)
    }

    /// Transfers the residual for the current settings now, on this thread, and plays it
    /// from the next strike (the command line, after setting parameters). Not for the audio
    /// thread (allocates; one transfer: 18 ms for a 1 s residual in the bench).
    pub fn refresh_residual(&mut self) {
        let wanted = self.wanted_residual(self.sound_params());
        if let Some(e) = self.engine.as_mut() {
            self.params.user_residual.refresh(e, wanted, &mut self.residual_key);
        }
    }

    /// The residual transfer the current settings (`sp`: their sound parameters) want.
    /// Realtime-safe.
    fn wanted_residual(&self, sp: SoundParams) -> Option<residual_layer::Key> {
        residual_layer::wanted_key(
            &self.params,
            &self.library,
            sp,
            self.sample_rate,
            self.params.user_residual.generation(),
        )
    }

    /// The engine, once activated.
    pub fn engine(&self) -> Option<&Engine> {
        self.engine.as_ref()
    }

    /// Index of the selected object, clamped to the library.
    fn object_index(&self) -> usize {
        object_index_of(&self.params, &self.library)
    }

    /// The engine controls from the current parameter values. Realtime-safe.
    pub fn sound_params(&self) -> SoundParams {
        sound_params_of(&self.params, &self.library)
    }

    /// How a note-on of `key` strikes: per-key λ factor and position by key mode.
    pub fn strike_for(&self, key: u8, velocity: f32) -> Strike {
        strike_for_of(&self.params, &self.library, key, velocity)
    }

    /// With *Pitch reference* = *Strongest mode* (Pitched keys, *Keys tune the object*):
    /// retunes `strike` so that the object's strongest mode sounds at `key`'s equal-tempered
    /// pitch. The strongest mode is the one heard loudest (see `Engine::strongest_mode`) when
    /// it sounds at the root key, chosen once for all keys so the keyboard transposes one
    /// mode (no jumps between neighbouring keys). Which mode is loudest depends on the tuning
    /// (the mallet's spectrum falls with frequency), so the choice must hold at its own
    /// tuning: the candidates are the modes heard loudest with the lowest mode at the root,
    /// and the first candidate that is still the loudest once tuned to the root is chosen; if
    /// none is, the candidate with the largest share of the loudest at its own tuning.
    /// Realtime-safe (at most 2·[`PITCH_CANDIDATES`] + 1 passes over the modes).
    pub fn tune_to_strongest(&mut self, key: u8, strike: &mut Strike) {
        let p = &self.params;
        if p.key_mode.value() != KeyMode::Pitched
            || !p.key_tuning.value()
            || p.pitch_reference.value() != PitchReference::Strongest
        {
            return;
        }
        let root = p.root_note.value().clamp(0, 127) as u8;
        let object = self.object_index();
        let (Some(bank), Some(engine)) = (self.library.banks.get(object), self.engine.as_mut()) else { return };
        let omega = |k: u8| 2.0 * std::f64::consts::PI * 440.0 * 2f64.powf((f64::from(k) - 69.0) / 12.0);
        let factor = |m: usize, k: u8| bank.lambdas.get(m).map(|&l| omega(k) * omega(k) / l);
        let Some(lowest_at_root) = factor(0, root) else { return };
        let at_root = Strike { lambda_factor: lowest_at_root, ..*strike };
        let mut candidates = [0usize; PITCH_CANDIDATES];
        let found = engine.loudest_modes(object, at_root, &mut candidates);
        let mut best = (f64::NEG_INFINITY, None);
        for &k in &candidates[..found] {
            let Some(f) = factor(k, root) else { continue };
            let trial = Strike { lambda_factor: f, ..*strike };
            if engine.strongest_mode(object, trial) == Some(k) {
                best = (f64::INFINITY, Some(k));
                break;
            }
            let share = engine.heard_share(object, trial, k);
            if share > best.0 {
                best = (share, Some(k));
            }
        }
        if let Some(f) = best.1.and_then(|k| factor(k, key)) {
            strike.lambda_factor = f;
        }
    }

    fn handle_event(&mut self, event: NoteEvent<()>) {
        let lasting = self.params.excitation.value() != params::ExcitationParam::Strike;
        // The channel's last MPE timbre (CC 74): the next note's strike position, or in a
        // lasting excitation its speed.
        let timbre = |channel: &Channel, timbre: &[Option<f32>; 16]| {
            channel.number().and_then(|c| timbre.get(usize::from(c))).copied().flatten()
        };
        let strike = match &event {
            NoteEvent::NoteOn { key: Key::Number(key), velocity, channel, .. } => {
                let mut strike = self.strike_for(*key, *velocity);
                if let Some(position) = timbre(channel, &self.channel_timbre).filter(|_| !lasting) {
                    strike.position = position;
                }
                self.tune_to_strongest(*key, &mut strike);
                Some(strike)
            }
            _ => None,
        };
        let speed_of = |x: f32| f64::from(x.clamp(0.0, 1.0)) * dsp::contact::MAX_SPEED_M_PER_S;
        let initial_speed = match &event {
            // Used once: MPE sends it before each note (a knob's CC 74 does not stick).
            NoteEvent::NoteOn { channel, .. } if lasting => {
                channel.number().and_then(|c| self.channel_timbre.get_mut(usize::from(c))).and_then(Option::take)
            }
            _ => None,
        };
        let Some(engine) = self.engine.as_mut() else { return };
        // nice-plug's identifiers may be wildcards; the engine's NoteId::ANY matches all.
        let note = |voice_id: VoiceID, channel: Channel, key: Key| NoteId {
            voice_id: voice_id.id(),
            channel: channel.number().unwrap_or(NoteId::ANY),
            key: key.number().unwrap_or(NoteId::ANY),
        };
        match event {
            NoteEvent::NoteOn { voice_id, channel, key, .. } => {
                if let Some(s) = strike {
                    engine.note_on(note(voice_id, channel, key), s);
                    // MPE sends a note's initial timbre (its speed here) before its note-on.
                    if let Some(v) = initial_speed {
                        engine.set_note_speed(note(voice_id, channel, key), speed_of(v));
                    }
                }
            }
            NoteEvent::NoteOff { voice_id, channel, key, .. } => engine.note_off(note(voice_id, channel, key)),
            NoteEvent::Choke { voice_id, channel, key, .. } => engine.choke(note(voice_id, channel, key)),
            NoteEvent::PolyPressure { voice_id, channel, key, pressure, .. } => {
                engine.set_pressure(note(voice_id, channel, key), pressure)
            }
            // CLAP brightness expression / MPE timbre → the note's contact speed in a lasting
            // excitation, else its strike position.
            NoteEvent::PolyBrightness { voice_id, channel, key, brightness, .. } => {
                if lasting {
                    engine.set_note_speed(note(voice_id, channel, key), speed_of(brightness))
                } else {
                    engine.set_note_position(note(voice_id, channel, key), brightness)
                }
            }
            // The mod wheel sets the contact speed of every note without its own (0..1 of the
            // fastest), in place of *Contact speed*, from now on.
            NoteEvent::MidiCC { cc: 1, value, .. } => engine.set_wheel_speed(Some(speed_of(value))),
            NoteEvent::MidiCC { channel, cc: 74, value, .. } if lasting => {
                if let Some(slot) = self.channel_timbre.get_mut(usize::from(channel)) {
                    *slot = Some(value);
                }
                engine.set_note_speed(NoteId { voice_id: None, channel, key: NoteId::ANY }, speed_of(value))
            }
            NoteEvent::MidiChannelPressure { channel, pressure, .. } => engine.set_channel_pressure(channel, pressure),
            // Pitch bend: the channel's notes, sounding and to come, by up to *Pitch bend
            // range* either way (0.5 is none; 14-bit MIDI's centre 8192 may arrive as 8192/16383).
            NoteEvent::MidiPitchBend { channel, value, .. } => {
                let x = 2.0 * value - 1.0;
                engine.set_pitch_bend(channel, if x.abs() < 1.0 / 8192.0 { 0.0 } else { x })
            }
            // CLAP's per-note tuning expression, semitones.
            NoteEvent::PolyTuning { voice_id, channel, key, tuning, .. } => {
                engine.set_note_tuning(note(voice_id, channel, key), tuning)
            }
            // Channel mode messages: All Sound Off (CC 120) silences the channel's voices at
            // once, All Notes Off (CC 123) releases them (they ring on, damped by the
            // release damping, as after their note-offs).
            NoteEvent::MidiCC { channel, cc: 120, .. } => {
                engine.choke(NoteId { voice_id: None, channel, key: NoteId::ANY })
            }
            NoteEvent::MidiCC { channel, cc: 123, .. } => {
                engine.note_off(NoteId { voice_id: None, channel, key: NoteId::ANY })
            }
            // The sustain pedal: note-offs wait for it to come up (a damper pedal).
            NoteEvent::MidiCC { channel, cc: 64, value, .. } => engine.set_sustain(channel, value >= 0.5),
            // Reset All Controllers lifts the pedal and centres the pitch bend.
            NoteEvent::MidiCC { channel, cc: 121, .. } => {
                engine.set_sustain(channel, false);
                engine.set_pitch_bend(channel, 0.0);
            }
            // MPE timbre (CC 74) on a member channel → strike position of that channel's sounding
            // notes, and of its next ones.
            NoteEvent::MidiCC { channel, cc: 74, value, .. } => {
                if let Some(slot) = self.channel_timbre.get_mut(usize::from(channel)) {
                    *slot = Some(value);
                }
                engine.set_note_position(NoteId { voice_id: None, channel, key: NoteId::ANY }, value)
            }
            NoteEvent::PolyModulation {
                voice_id, poly_modulation_id: POSITION_POLY_MOD_ID, normalized_offset, ..
            } => {
                // The position range is linear 0..1, so the normalised offset is the offset.
                engine.set_position_offset(voice_id, normalized_offset)
            }
            _ => {}
        }
    }
}

/// Index of the selected object, clamped to `library`.
pub fn object_index_of(p: &StruckParams, library: &Library) -> usize {
    (p.object.value().max(0) as usize).min(library.banks.len().saturating_sub(1))
}

/// The engine controls from the current parameter values. Realtime-safe.
pub fn sound_params_of(p: &StruckParams, library: &Library) -> SoundParams {
    let material = p.material.value().max(0) as usize;
    let damping = library.dampings.get(material).copied().unwrap_or_else(|| p.custom_damping());
    let mut modulus = f64::from(p.modulus_ratio.value());
    if p.material_pitch.value() {
        modulus *= library.material_modulus_ratio(material, object_index_of(p, library));
    }
    let support_c = match p.support_mode.value() {
        SupportMode::Off => 0.0,
        SupportMode::AsRecorded => library
            .materials
            .get(material)
            .map_or_else(|| f64::from(p.custom_support_per_s.value()), presets::Material::support_c),
        SupportMode::Amount => f64::from(p.support_amount_per_s.value()),
    }
    .clamp(0.0, MAX_SUPPORT_PER_S);
    // The object's Young's modulus as played, E = γ·ρ (the bank's reference density),
    // for the Hertz contact of a hard mallet on it.
    let object_modulus = library
        .banks
        .get(object_index_of(p, library))
        .map_or(0.0, |b| b.reference.specific_modulus * modulus * b.reference.density);
    SoundParams {
        mallet: p.mallet.value().kind().mallet().on_object(object_modulus),
        normalize: p.normalize_level.value(),
        variation: p.variation.value(),
        damping,
        decay_scale: f64::from(p.decay_scale.value()),
        modulus_ratio: modulus,
        size: f64::from(p.size.value()),
        hardness: p.hardness.value(),
        noise: p.noise.value(),
        velocity_sensitivity: p.velocity_sensitivity.value(),
        release_damping: f64::from(p.release_damping_per_s.value()),
        pressure_damping: f64::from(p.pressure_damping_per_s.value()),
        quality_db: p.quality_db.value(),
        support_c,
        support_point: p.support_at_point.value().then(|| p.support_point.value()),
        // The Custom material's support recorded mode by mode (a captured material of a known
        // object), played on that object.
        recorded_support: p.support_mode.value() == SupportMode::AsRecorded
            && p.material.value().max(0) as usize >= library.custom_material_index(),
        contact: ContactParams {
            excitation: p.excitation.value().excitation(),
            speed_mps: f64::from(p.contact_speed.value()),
            texture: p.texture.value().kind(),
            texture_scale: f64::from(p.texture_scale.value()),
            ball_radius_m: 1e-3 * f64::from(p.ball_radius_mm.value()),
            direction: match p.contact_direction.value() {
                params::ContactDirection::Forward => 1.0,
                params::ContactDirection::Backward => -1.0,
                params::ContactDirection::Across => 0.0,
            },
            wrap: p.path_ends.value() == params::PathEnds::Wrap,
        },
        residual_gain: if p.residual.value() { util::db_to_gain(p.residual_level_db.value()) } else { 0.0 },
    }
}

/// How a note-on of `key` strikes: per-key λ factor and position by key mode.
pub fn strike_for_of(p: &StruckParams, library: &Library, key: u8, velocity: f32) -> Strike {
    let root = p.root_note.value();
    let base = p.strike_position.value();
    match p.key_mode.value() {
        // One semitone per key: pitch ∝ sqrt(λ), so λ scales by 2^(1/6) per key.
        KeyMode::Pitched => Strike {
            velocity,
            position: base,
            lambda_factor: params::key_lambda_factor(p, library.banks.get(object_index_of(p, library)), key),
        },
        KeyMode::Positions => {
            let points = library.banks.get(object_index_of(p, library)).map_or(1, |b| b.points.len()).max(1) as i32;
            let idx = (i32::from(key) - root).rem_euclid(points);
            let position = if points > 1 { idx as f32 / (points - 1) as f32 } else { 0.0 };
            Strike { velocity, position, lambda_factor: 1.0 }
        }
    }
}

impl<V: Variant> Plugin for StruckPlugin<V> {
    const NAME: &'static str = V::NAME;
    const VENDOR: &'static str = "Struck developers";
    const URL: &'static str = env!("CARGO_PKG_HOMEPAGE");
    const EMAIL: &'static str = "struck@example.invalid";
    const VERSION: &'static str = env!("CARGO_PKG_VERSION");

    const AUDIO_IO_LAYOUTS: &'static [AudioIOLayout] = V::AUDIO_IO_LAYOUTS;
    const MIDI_INPUT: MidiConfig = MidiConfig::MidiCCs;
    const SAMPLE_ACCURATE_AUTOMATION: bool = false;

    type SysExMessage = ();
    type BackgroundTask = ();
    type Editor = editor::StruckEditor;

    fn params(&self) -> Arc<dyn Params> {
        self.params.clone()
    }

    fn editor(&mut self, _async_executor: AsyncExecutor<Self>) -> Option<Self::Editor> {
        Some(editor::StruckEditor::new(self.params.clone(), self.library.clone(), self.editor_shared.clone()))
    }

    fn activate(
        &mut self,
        layout: &AudioIOLayout,
        config: &BufferConfig,
        context: &mut impl ActivateContext<Self>,
    ) -> bool {
        self.has_input = layout.main_input_channels.is_some();
        self.sample_rate = config.sample_rate;
        self.offline = config.process_mode == ProcessMode::Offline;
        self.residual_waited = None;
        self.editor_shared.sample_rate.store(config.sample_rate.to_bits(), std::sync::atomic::Ordering::Relaxed);
        let rebuild = self.engine.as_ref().is_none_or(|e| e.sample_rate() != f64::from(config.sample_rate));
        if rebuild {
            self.engine = Some(Engine::new(self.library.object_modes(), MAX_VOICES, f64::from(config.sample_rate)));
        }
        // The project's user texture (not on the audio thread: activation may allocate).
        if let Some(e) = self.engine.as_mut() {
            self.params.user_texture.restore(e);
            self.params.user_support.restore(e);
        }
        // The residual for the settings as they are, then a worker for their changes.
        self.refresh_residual();
        let shared = self.editor_shared.clone();
        residual_layer::start_worker(self.params.clone(), self.library.clone(), Arc::new(move || shared.sample_rate()));
        let max = (config.max_buffer_size as usize).clamp(1, MAX_BLOCK);
        if self.mono.len() < max {
            self.mono = vec![0.0; max];
        }
        if self.input_mono.len() < self.mono.len() {
            self.input_mono = vec![0.0; self.mono.len()];
            self.gains = vec![0.0; self.mono.len()];
        }
        context.set_current_voice_capacity(MAX_VOICES as u32);
        true
    }

    fn reset(&mut self) {
        self.channel_timbre = [None; 16];
        self.audition_contact = None;
        let sp = self.sound_params();
        let object = self.object_index();
        if let Some(e) = self.engine.as_mut() {
            e.set_params(sp);
            e.set_object(object);
            e.reset();
        }
    }

    fn process(
        &mut self,
        buffer: &mut Buffer,
        _aux: &mut AuxiliaryBuffers,
        context: &mut impl ProcessContext<Self>,
    ) -> ProcessStatus {
        let _ftz = DenormalGuard::new();
        let total = buffer.samples();
        let outputs = buffer.as_slice();
        let ready = self.engine.is_some() && !self.mono.is_empty() && self.input_mono.len() >= self.mono.len();
        // Audio in: the buffers hold the input until each chunk has read it.
        let take_input = ready && self.has_input && self.params.audio_in.value();
        // The input stays in the output (dry/wet): with *Audio in*, and always in the effect.
        let mix_input = take_input || (ready && self.has_input && V::EFFECT);
        // Every sample of every block is written, silence included.
        if !mix_input {
            for ch in outputs.iter_mut() {
                ch.fill(0.0);
            }
        }
        if !ready {
            return ProcessStatus::Normal;
        }
        let mut sp = self.sound_params();
        let wanted = self.wanted_residual(sp);
        if wanted.is_none() {
            // Layer off, not the Custom material or no residual: strikes play none (a clip
            // the engine holds stays for when the settings come back).
            sp.residual_gain = 0.0;
        }
        let object = self.object_index();
        let input_position = self.params.strike_position.value();
        let bend_range = self.params.bend_range.value() as f32;
        if let Some(e) = self.engine.as_mut() {
            e.set_params(sp);
            e.set_object(object);
            e.set_audio_input(take_input, input_position);
            e.set_bend_range(bend_range);
        }
        // A user texture set since the last block (editor, command line, a loaded state).
        if let Some(e) = self.engine.as_mut() {
            self.params.user_texture.apply(e);
            self.params.user_support.apply(e);
        }
        // The residual transferred for the settings as they are, once the worker has it (an
        // offline render waits for it, once per key: sleeping allocates nothing).
        if let Some(e) = self.engine.as_mut() {
            let field = &self.params.user_residual;
            field.apply(e, wanted, &mut self.residual_key);
            if self.offline && wanted.is_some() && self.residual_key != wanted && self.residual_waited != wanted {
                self.residual_waited = wanted;
                let deadline =
                    std::time::Instant::now() + std::time::Duration::from_millis(residual_layer::OFFLINE_WAIT_MS);
                while std::time::Instant::now() < deadline {
                    std::thread::sleep(std::time::Duration::from_millis(1));
                    field.apply(e, wanted, &mut self.residual_key);
                    if self.residual_key == wanted {
                        break;
                    }
                }
            }
        }
        // Editor auditions (clicks on the object view): lock-free pops, no allocation.
        while let Some(a) = self.editor_shared.audition.pop() {
            let mut strike = self.strike_for(a.key, a.velocity);
            strike.position = a.position;
            self.tune_to_strongest(a.key, &mut strike);
            if let Some(e) = self.engine.as_mut() {
                e.note_on(a.note(), strike);
                if sp.contact.excitation.is_lasting() {
                    // A new audition's contact replaces the last one's.
                    if let Some((old, _)) = self.audition_contact {
                        e.note_off(old);
                    }
                    self.audition_contact = Some((a.note(), (AUDITION_CONTACT_S * self.sample_rate as f64) as u64));
                }
            }
        }
        if let Some((note, left)) = self.audition_contact {
            if left <= total as u64 {
                self.audition_contact = None;
                if let Some(e) = self.engine.as_mut() {
                    e.note_off(note);
                }
            } else {
                self.audition_contact = Some((note, left - total as u64));
            }
        }

        let mut next = context.next_event();
        let mut start = 0;
        while start < total {
            let len = (total - start).min(self.mono.len());
            self.mono[..len].fill(0.0);
            if take_input {
                // The input's channels mixed to mono.
                let scale = 1.0 / outputs.len().max(1) as f32;
                self.input_mono[..len].fill(0.0);
                for ch in outputs.iter() {
                    for (m, &x) in self.input_mono[..len].iter_mut().zip(&ch[start..start + len]) {
                        *m += if x.is_finite() { x * scale } else { 0.0 };
                    }
                }
            }
            let mut pos = 0;
            loop {
                // Apply every event due at `pos` (late ones at once), then render to the next.
                while let Some(ev) = next {
                    if ev.timing() as usize > start + pos {
                        break;
                    }
                    self.handle_event(ev);
                    next = context.next_event();
                }
                let until = next.map_or(len, |ev| (ev.timing() as usize).saturating_sub(start).min(len));
                if until > pos {
                    if let Some(e) = self.engine.as_mut() {
                        if take_input {
                            e.render_input(&self.input_mono[pos..until], &mut self.mono[pos..until]);
                        } else {
                            e.render(&mut self.mono[pos..until]);
                        }
                        e.drain_terminated(|t| {
                            // The host never saw the editor's audition notes.
                            if shared::is_audition(&t.note) {
                                return;
                            }
                            let _ = context.try_send_event(NoteEvent::VoiceTerminated {
                                timing: (start + pos) as u32 + t.offset,
                                voice_id: t.note.voice_id.map_or(VoiceID::Wildcard, VoiceID::ID),
                                channel: Channel::Number(t.note.channel),
                                key: Key::Number(t.note.key),
                            });
                        });
                    }
                    pos = until;
                }
                if pos >= len {
                    break;
                }
            }
            // The editor's A/B clip, if one is playing (before the output gain, like the voices).
            self.clip_player.mix(&self.editor_shared, &mut self.mono[..len]);
            let safety = self.params.output_safety.value();
            let gain = &self.params.gain_db.smoothed;
            let finish = |x: f32, g: f32| {
                let s = x * g;
                // Never pass NaN or infinities to the host.
                let s = if s.is_finite() { s } else { 0.0 };
                if safety {
                    dsp::safety::soft_clip(s)
                } else {
                    s
                }
            };
            if mix_input {
                // Dry/wet per channel, in place over the input: out = w·modes + (1 − w)·in.
                // The effect with *Audio in* off passes its input whole, as a bypassed
                // resonator would (notes still play on top).
                let w = if take_input { self.params.dry_wet.value() } else { 1.0 };
                let dry_share = if take_input { 1.0 - w } else { 1.0 };
                for g in &mut self.gains[..len] {
                    *g = util::db_to_gain_fast(gain.next());
                }
                for ch in outputs.iter_mut() {
                    for ((o, &x), &g) in
                        ch[start..start + len].iter_mut().zip(&self.mono[..len]).zip(&self.gains[..len])
                    {
                        let dry = if o.is_finite() { *o } else { 0.0 };
                        *o = finish(w * x + dry_share * dry, g);
                    }
                }
                start += len;
                continue;
            }
            let Some((first, rest)) = outputs.split_first_mut() else {
                start += len;
                continue;
            };
            let first = &mut first[start..start + len];
            if gain.is_smoothing() {
                for (o, &x) in first.iter_mut().zip(&self.mono[..len]) {
                    *o = finish(x, util::db_to_gain_fast(gain.next()));
                }
            } else {
                // A settled gain is the same value at every sample (what `next()` would
                // return): converted once, not per sample.
                let g = util::db_to_gain_fast(gain.next());
                for (o, &x) in first.iter_mut().zip(&self.mono[..len]) {
                    *o = finish(x, g);
                }
            }
            for ch in rest.iter_mut() {
                ch[start..start + len].copy_from_slice(first);
            }
            start += len;
        }
        // Events past the end of the buffer (hosts should not send them) are applied now.
        while let Some(ev) = next {
            self.handle_event(ev);
            next = context.next_event();
        }
        if let Some(e) = self.engine.as_ref() {
            // Voices played by notes; the modes include the audio input's.
            self.editor_shared.store_meters(e.note_voices(), e.active_modes());
            self.editor_shared.store_contact(e.contact_position());
            if V::EFFECT {
                // An effect's host may stop calling it once its input is silent: the object
                // rings on for its slowest sounding mode's T60 (at most a minute).
                // Silent: the host may put it to sleep (CLAP continues on any tail).
                let tail = e.tail_samples((MAX_TAIL_S * self.sample_rate) as u32);
                return if tail > 0 { ProcessStatus::Tail(tail) } else { ProcessStatus::Normal };
            }
        }
        ProcessStatus::Normal
    }
}

impl<V: Variant> ClapPlugin for StruckPlugin<V> {
    const CLAP_ID: &'static str = V::CLAP_ID;
    const CLAP_DESCRIPTION: Option<&'static str> = Some(V::CLAP_DESCRIPTION);
    const CLAP_MANUAL_URL: Option<&'static str> = None;
    const CLAP_SUPPORT_URL: Option<&'static str> = None;
    const CLAP_FEATURES: &'static [ClapFeature] = V::CLAP_FEATURES;
    const CLAP_POLY_MODULATION_CONFIG: Option<PolyModulationConfig> =
        Some(PolyModulationConfig { max_voice_capacity: MAX_VOICES as u32, supports_overlapping_voices: true });
}

impl<V: Variant> Vst3Plugin for StruckPlugin<V> {
    const VST3_CLASS_ID: [u8; 16] = V::VST3_CLASS_ID;
    const VST3_SUBCATEGORIES: &'static [Vst3SubCategory] = V::VST3_SUBCATEGORIES;
}
