//! Struck's parameters. IDs never change once released; units go in the names.

use crate::library::Library;
use dsp::Damping;
use nice_plug::prelude::*;
use std::sync::{Arc, Mutex};

/// Poly-modulation id of the strike position (CLAP polyphonic modulation).
pub const POSITION_POLY_MOD_ID: u32 = 0;

/// Eigenvalue of the 1 kHz reference used to express λ-dependent damping: (2π·1000)².
pub const LAMBDA_1K: f64 = (2.0 * std::f64::consts::PI * 1000.0) * (2.0 * std::f64::consts::PI * 1000.0);
/// Eigenvalue of the 10 kHz reference (Caughey's quadratic term): (2π·10000)².
pub const LAMBDA_10K: f64 = LAMBDA_1K * 100.0;

/// What the keyboard does.
#[derive(Enum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum KeyMode {
    /// Each key transposes: γ is scaled by 2^((key − root)/6), i.e. one semitone per key.
    #[id = "pitched"]
    Pitched,
    /// Keys select strike points (from the root upwards) at a fixed pitch.
    #[id = "positions"]
    Positions,
}

/// The damping law used by the *Custom* material.
#[derive(Enum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum DampingModelParam {
    /// c = α₁ + α₂ λ.
    #[id = "rayleigh"]
    Rayleigh,
    /// c = α₀ + α₁ λ + α₂ λ² (third-order Caughey series).
    #[id = "caughey"]
    Caughey,
    /// c = α₁ λ^α₂.
    #[id = "power"]
    #[name = "Power law"]
    Power,
    /// c = α₁ + α₂ λ^α₃.
    #[id = "hybrid"]
    Hybrid,
}

/// Support damping (thesis §4.2.8; issue 10 part 6): the extra, per-mode damping that the
/// way an object is held adds to the material's law.
#[derive(Enum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum SupportMode {
    /// The free material: no support damping.
    #[id = "off"]
    Off,
    /// The support damping recorded with the material (captured materials carry it; factory
    /// materials have none unless their source states a mounting).
    #[id = "recorded"]
    #[name = "As recorded"]
    AsRecorded,
    /// The amount set by *Support amount*.
    #[id = "amount"]
    Amount,
}

/// The mallet: its contact law sets how long it touches the object (issue 11 part 1).
#[derive(Enum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum MalletParam {
    /// Felt (stiffening hammer felt: loud strikes much brighter).
    #[id = "felt"]
    Felt,
    /// Hard rubber.
    #[id = "rubber"]
    Rubber,
    /// Hard wood.
    #[id = "wood"]
    Wood,
    /// Plastic.
    #[id = "plastic"]
    Plastic,
    /// Brass.
    #[id = "brass"]
    Brass,
    /// Steel.
    #[id = "steel"]
    Steel,
}

impl MalletParam {
    /// The engine's mallet kind.
    pub fn kind(self) -> dsp::exciter::MalletKind {
        use dsp::exciter::MalletKind as K;
        match self {
            MalletParam::Felt => K::Felt,
            MalletParam::Rubber => K::Rubber,
            MalletParam::Wood => K::Wood,
            MalletParam::Plastic => K::Plastic,
            MalletParam::Brass => K::Brass,
            MalletParam::Steel => K::Steel,
        }
    }
}

/// Which mode the keys tune (issue 11 part 3).
#[derive(Enum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum PitchReference {
    /// The object's lowest mode.
    #[id = "lowest"]
    #[name = "Lowest mode"]
    Lowest,
    /// The mode that rings loudest for the note (strike point, mallet and velocity included).
    #[id = "strongest"]
    #[name = "Strongest mode"]
    Strongest,
    /// The mode numbered by *Pitch mode* (the bank's labels name them, e.g. a bell's nominal).
    #[id = "chosen"]
    #[name = "Chosen mode"]
    Chosen,
}

/// How a note excites the object (issue 16).
#[derive(Enum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum ExcitationParam {
    /// A strike with the mallet, then the object rings.
    #[id = "strike"]
    Strike,
    /// A point (stick, spoon edge) dragged across the surface while the key is held.
    #[id = "scrape"]
    Scrape,
    /// A flat sliding on the surface's high points while the key is held.
    #[id = "slide"]
    Slide,
    /// A ball rolling on the surface while the key is held.
    #[id = "roll"]
    Roll,
}

impl ExcitationParam {
    /// The engine's excitation.
    pub fn excitation(self) -> dsp::contact::Excitation {
        use dsp::contact::Excitation as E;
        match self {
            ExcitationParam::Strike => E::Strike,
            ExcitationParam::Scrape => E::Scrape,
            ExcitationParam::Slide => E::Slide,
            ExcitationParam::Roll => E::Roll,
        }
    }
}

/// The surface texture a lasting contact runs over.
#[derive(Enum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum TextureParam {
    /// No texture: the fine (fractal) noise alone.
    #[id = "smooth"]
    Smooth,
    /// Fine grit.
    #[id = "finegrit"]
    #[name = "Fine grit"]
    FineGrit,
    /// Coarse grit.
    #[id = "coarsegrit"]
    #[name = "Coarse grit"]
    CoarseGrit,
    /// Evenly spaced grooves (2 mm apart at scale 1), as on a guiro or a ribbed bottle.
    #[id = "grooves"]
    Grooves,
    /// Random bumps.
    #[id = "bumps"]
    Bumps,
    /// The user's texture file (loaded in the editor or with `render --texture FILE`).
    #[id = "user"]
    #[name = "User file"]
    User,
}

impl TextureParam {
    /// The engine's texture.
    pub fn kind(self) -> dsp::contact::TextureKind {
        use dsp::contact::TextureKind as T;
        match self {
            TextureParam::Smooth => T::Smooth,
            TextureParam::FineGrit => T::FineGrit,
            TextureParam::CoarseGrit => T::CoarseGrit,
            TextureParam::Grooves => T::Grooves,
            TextureParam::Bumps => T::Bumps,
            TextureParam::User => T::User,
        }
    }
}

/// Where a lasting contact moves along the strike path.
#[derive(Enum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum ContactDirection {
    /// Towards the path's end (position 1).
    #[id = "forward"]
    Forward,
    /// Towards the path's start (position 0).
    #[id = "backward"]
    Backward,
    /// Across the path: the contact stays at the strike position while it slides (round a
    /// bowl's rim or a bell's, along a bar's length when its points run across it).
    #[id = "across"]
    Across,
}

/// What a lasting contact does at the strike path's ends.
#[derive(Enum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum PathEnds {
    /// Turns back.
    #[id = "bounce"]
    Bounce,
    /// Goes round (a rim, a ring): from one end on at the other.
    #[id = "wrap"]
    Wrap,
}

/// Most modes *Pitch mode* can choose from.
pub const MAX_PITCH_MODE: i32 = 256;

/// Window size the editor first opens at, logical points `[width, height]`.
pub const DEFAULT_EDITOR_SIZE: [u32; 2] = [1040, 720];

/// Largest support damping the plugin plays (mean extra c, s⁻¹): the range of *Custom
/// support* and *Support amount*; a library material's recorded value is clamped to it.
pub const MAX_SUPPORT_PER_S: f64 = 2000.0;

/// All parameters.
#[derive(Params)]
pub struct StruckParams {
    /// Index of the object (bank) new notes play.
    #[id = "object"]
    pub object: IntParam,
    /// Index of the factory material; the last value is *Custom* (the damping knobs below).
    #[id = "material"]
    pub material: IntParam,
    /// Damping law of the *Custom* material.
    #[id = "dmodel"]
    pub damping_model: EnumParam<DampingModelParam>,
    /// Custom material: constant damping α₁ (s⁻¹), the part of c that is the same for all modes.
    #[id = "alpha1"]
    pub alpha1_per_s: FloatParam,
    /// Custom material: the λ-dependent part of c at 1 kHz (s⁻¹). Sets α₂ = this / λ₁ₖ^exponent.
    #[id = "c1k"]
    pub damping_1k_per_s: FloatParam,
    /// Custom material: exponent of λ for the power-law and hybrid models.
    #[id = "expo"]
    pub exponent: FloatParam,
    /// Custom material: Caughey's quadratic term expressed as its c at 10 kHz (s⁻¹).
    #[id = "c10k"]
    pub caughey_10k_per_s: FloatParam,
    /// Custom material: its recorded support damping, the mean extra c (s⁻¹) over modes
    /// (a captured material's `support.mean_c_per_s`; set with the other Custom knobs when a
    /// material is applied or loaded, and kept when the knobs are then turned by hand).
    #[id = "csupport"]
    pub custom_support_per_s: FloatParam,
    /// Support damping: off, as recorded with the material, or the chosen amount.
    #[id = "support"]
    pub support_mode: EnumParam<SupportMode>,
    /// Support damping when *Support* is *Amount*: mean extra c (s⁻¹) over modes.
    #[id = "supportamt"]
    pub support_amount_per_s: FloatParam,
    /// The support damping goes to the modes that move where the object is held (*Support
    /// point*), not to each mode by its random draw.
    #[id = "supportat"]
    pub support_at_point: BoolParam,
    /// Where the object is held, 0..1 along the strike path (with *Held at a point*).
    #[id = "supportpt"]
    pub support_point: FloatParam,
    /// Multiplies every damping coefficient (all materials): below 1 rings longer.
    #[id = "dscale"]
    pub decay_scale: FloatParam,
    /// Specific modulus relative to the object's reference material, γ/γ₀. Pitch ∝ sqrt(γ/γ₀).
    #[id = "gamma"]
    pub modulus_ratio: FloatParam,
    /// When on, the material's own specific modulus (if known) also sets the pitch.
    #[id = "matpitch"]
    pub material_pitch: BoolParam,
    /// Key at which the object sounds at its set pitch (Pitched) or the first strike point
    /// (Positions).
    #[id = "root"]
    pub root_note: IntParam,
    /// Pitched mode: when on, the object's lowest mode sounds at each key's equal-tempered
    /// pitch (A4 = 440 Hz) before γ/γ₀ and size; when off, the root key plays the object's
    /// physical reference pitch.
    #[id = "keytune"]
    pub key_tuning: BoolParam,
    /// Keyboard mode.
    #[id = "keymode"]
    pub key_mode: EnumParam<KeyMode>,
    /// Size relative to the object's reference dimensions (λ ∝ 1/size²).
    #[id = "size"]
    pub size: FloatParam,
    /// Where the object is struck, 0..=1 along the bank's strike points.
    #[id = "pos"]
    pub strike_position: FloatParam,
    /// The mallet (contact law, mass).
    #[id = "mallet"]
    pub mallet: EnumParam<MalletParam>,
    /// Mallet hardness: its contact stiffness, 50 % as made, ±1.5 decades at 0 and 100 %.
    #[id = "hard"]
    pub hardness: FloatParam,
    /// Per-strike variation of position, force and contact time (0: exact repeats).
    #[id = "variation"]
    pub variation: FloatParam,
    /// Which mode the keys tune (Pitched mode with *Keys tune the object*).
    #[id = "pitchref"]
    pub pitch_reference: EnumParam<PitchReference>,
    /// The mode tuned when *Pitch reference* is *Chosen mode*, 1 = lowest.
    #[id = "pitchmode"]
    pub pitch_mode: IntParam,
    /// Semitones a full MIDI pitch bend moves the notes of its channel, either way (2 as
    /// most keyboards; 48 for MPE's member channels).
    #[id = "bendrange"]
    pub bend_range: IntParam,
    /// Every strike at the same reference loudness (objects, sizes, keys, materials and the
    /// mallet change timbre, not level); off: the physical level of a unit impulse.
    #[id = "levelnorm"]
    pub normalize_level: BoolParam,
    /// A soft clipper on the output: transparent below −1 dBFS, never above 0 dBFS.
    #[id = "safety"]
    pub output_safety: BoolParam,
    /// Share of the strike delivered as a noise burst (rough strikes).
    #[id = "noise"]
    pub noise: FloatParam,
    /// How much velocity changes loudness.
    #[id = "velsens"]
    pub velocity_sensitivity: FloatParam,
    /// Extra decay rate d added at note-off ("hand on the object"), s⁻¹; 0 lets notes ring.
    #[id = "release"]
    pub release_damping_per_s: FloatParam,
    /// Extra decay rate d at full per-note pressure, s⁻¹.
    #[id = "pressdamp"]
    pub pressure_damping_per_s: FloatParam,
    /// Modes more than this many dB below a strike's strongest are not rendered.
    #[id = "quality"]
    pub quality_db: FloatParam,
    /// Output gain.
    #[id = "gain"]
    pub gain_db: FloatParam,
    /// How notes excite the object: a strike, or a lasting contact while the key is held.
    #[id = "excite"]
    pub excitation: EnumParam<ExcitationParam>,
    /// Sliding speed of a lasting contact, m/s (the mod wheel, MPE slide or per-note
    /// brightness set it too).
    #[id = "speed"]
    pub contact_speed: FloatParam,
    /// The surface texture of a lasting contact.
    #[id = "texture"]
    pub texture: EnumParam<TextureParam>,
    /// Multiplies the texture's spacing and depth (coarser, same slopes).
    #[id = "texscale"]
    pub texture_scale: FloatParam,
    /// Radius of the rolling ball, mm.
    #[id = "ball"]
    pub ball_radius_mm: FloatParam,
    /// Where a lasting contact first moves.
    #[id = "contactdir"]
    pub contact_direction: EnumParam<ContactDirection>,
    /// What a lasting contact does at the path's ends.
    #[id = "contactends"]
    pub path_ends: EnumParam<PathEnds>,
    /// With the host's audio-input layout: the input drives the object at the strike
    /// position (moving like a lasting contact at *Contact speed*).
    #[id = "audioin"]
    pub audio_in: BoolParam,
    /// Audio in: share of the object's sound in the output (the rest is the input, dry).
    #[id = "drywet"]
    pub dry_wet: FloatParam,
    /// The residual layer (issue 15; Ren 2013 §6): strikes also play the captured
    /// recording's residual transferred to the object as played, when the material has one
    /// (the *Custom* material loaded from a captured material file).
    #[id = "residual"]
    pub residual: BoolParam,
    /// Level of the residual layer, dB (0: as the recording held it beside its modes).
    #[id = "residuallevel"]
    pub residual_level_db: FloatParam,
    /// Editor window size in logical points `[width, height]`, so it reopens at that size.
    #[persist = "editor-size"]
    pub editor_size: Mutex<[u32; 2]>,
    /// The editor's last capture (features and fits, no audio), so reopening shows it.
    #[persist = "capture"]
    pub capture: Mutex<Option<crate::shared::CaptureRecord>>,
    /// The user's texture (*Texture* = User file), kept with the project.
    #[persist = "user-texture"]
    pub user_texture: crate::user_texture::UserTextureField,
    /// The *Custom* material's residual (from the captured material file it was loaded
    /// from), kept with the project.
    #[persist = "user-residual"]
    pub user_residual: crate::residual_field::ResidualField,
    /// The *Custom* material's support damping recorded mode by mode (from the captured
    /// material it was loaded from), kept with the project.
    #[persist = "user-support"]
    pub user_support: crate::user_support::UserSupportField,
}

/// Values of the *Custom* material knobs (plain units) that reproduce a damping law.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CustomKnobs {
    /// Damping model.
    pub model: DampingModelParam,
    /// `alpha1`, s⁻¹.
    pub alpha1_per_s: f32,
    /// `c1k`, s⁻¹.
    pub damping_1k_per_s: f32,
    /// `expo`.
    pub exponent: f32,
    /// `c10k`, s⁻¹.
    pub caughey_10k_per_s: f32,
}

type ValueToString<T> = Arc<dyn Fn(T) -> String + Send + Sync>;
type StringToValue<T> = Arc<dyn Fn(&str) -> Option<T> + Send + Sync>;

fn object_name(lib: &Arc<Library>) -> ValueToString<i32> {
    let lib = lib.clone();
    Arc::new(move |v| lib.banks.get(v as usize).map_or_else(|| format!("#{v}"), |b| b.name.clone()))
}

fn material_name(lib: &Arc<Library>) -> ValueToString<i32> {
    let lib = lib.clone();
    Arc::new(move |v| lib.materials.get(v as usize).map_or_else(|| CUSTOM.to_string(), |m| m.name.clone()))
}

/// Name of the material parameter's last value.
const CUSTOM: &str = "Custom";

/// Picks an entry of a list by what a user or host typed: its index, its exact name or id
/// (any case), else the first whose name or id starts with the text, else the first that
/// contains it.
fn pick(text: &str, entries: &[(&str, &str)]) -> Option<i32> {
    let t = text.trim().to_lowercase();
    if t.is_empty() {
        return None;
    }
    if let Ok(i) = t.trim_start_matches('#').parse::<i32>() {
        return (0..entries.len() as i32).contains(&i).then_some(i);
    }
    let exact = entries.iter().position(|(name, id)| name.to_lowercase() == t || id.to_lowercase() == t);
    let starts = || entries.iter().position(|(name, id)| name.to_lowercase().starts_with(&t) || id.starts_with(&t));
    let contains =
        || entries.iter().position(|(name, id)| name.to_lowercase().contains(&t) || id.to_lowercase().contains(&t));
    exact.or_else(starts).or_else(contains).map(|i| i as i32)
}

fn object_from_name(lib: &Arc<Library>) -> StringToValue<i32> {
    let lib = lib.clone();
    Arc::new(move |s| {
        let entries: Vec<(&str, &str)> = lib.banks.iter().map(|b| (b.name.as_str(), b.id.as_str())).collect();
        pick(s, &entries)
    })
}

fn material_from_name(lib: &Arc<Library>) -> StringToValue<i32> {
    let lib = lib.clone();
    Arc::new(move |s| {
        let mut entries: Vec<(&str, &str)> = lib.materials.iter().map(|m| (m.name.as_str(), m.id.as_str())).collect();
        entries.push((CUSTOM, "custom"));
        pick(s, &entries)
    })
}

/// The first number in `text` (after an optional `×`, `x` or `*`), e.g. "-12 dB" → −12,
/// "0.050x" → 0.05, "4.0 1/s" → 4.
fn leading_number(text: &str) -> Option<f32> {
    let t = text.trim().trim_start_matches(['×', '*', 'x', 'X']).trim_start();
    let end = t
        .char_indices()
        .find(|&(i, c)| {
            !(c.is_ascii_digit() || c == '.' || ((c == '-' || c == '+') && (i == 0 || t[..i].ends_with(['e', 'E']))))
                && !((c == 'e' || c == 'E') && i > 0)
        })
        .map_or(t.len(), |(i, _)| i);
    let number = t[..end].trim_end_matches(['e', 'E']);
    number.parse::<f32>().ok().filter(|v| v.is_finite())
}

/// `v` with `digits` significant digits and at most `max_decimals` decimals, so that text →
/// value → text gives back the same text at `f32` precision, as hosts and clap-validator
/// check (a fixed 3 decimals on a value of thousands asks for 7 significant digits, more
/// than the parameter's normalised ↔ plain mapping keeps; on ×0.0012 it keeps too few).
fn significant(v: f32, digits: i32, max_decimals: i32) -> String {
    fn format(v: f32, digits: i32, max_decimals: i32) -> String {
        if v == 0.0 || !v.is_finite() {
            return format!("{:.1}", 0.0);
        }
        let decimals = (digits - 1 - v.abs().log10().floor() as i32).clamp(0, max_decimals) as usize;
        format!("{v:.decimals$}")
    }
    // Round once, then format the rounded value by its own magnitude (999.96 → "1000").
    let rounded: f32 = format(v, digits, max_decimals).parse().unwrap_or(v);
    format(rounded, digits, max_decimals)
}

/// Formats with 4 significant digits (at most 3 decimals); see [`significant`].
fn v2s_significant(digits: i32) -> ValueToString<f32> {
    Arc::new(move |v| significant(v, digits, 3))
}

/// Parses a plain number with an optional unit ("-12 dB", "-12dB", "-12", "40 1/s").
fn s2v_number() -> StringToValue<f32> {
    Arc::new(leading_number)
}

/// Formats a multiplier as "0.5000x": a number with a suffix that hosts which read a
/// parameter's text as a number take (pedalboard strips "x", "%", "dB"…; a leading "×" or a
/// "(+12.0 st)" after it made it list the values as text, so `p.size = 2.0` was refused).
fn multiplier() -> ValueToString<f32> {
    Arc::new(|v| format!("{}x", significant(v, 4, 5)))
}

/// Parses what [`multiplier`] writes, a bare multiplier ("0.05", "×0.05", "0.05x"), or a
/// pitch change alone ("+12 st", "-7st"), the inverse of the semitone law.
fn s2v_ratio_or_semitones(sqrt_law: bool) -> StringToValue<f32> {
    Arc::new(move |s| {
        let t = s.trim();
        let st = t.trim_end_matches(|c: char| c.is_whitespace() || c == ')');
        if !t.starts_with(['×', '*', 'x', 'X', '(']) && st.ends_with("st") {
            let semis = leading_number(st.trim_end_matches("st").trim_start_matches('('))?;
            return Some(if sqrt_law { 2f32.powf(semis / 6.0) } else { 2f32.powf(-semis / 12.0) });
        }
        leading_number(t)
    })
}

impl StruckParams {
    /// Parameters for the objects and materials of `lib`.
    pub fn new(lib: &Arc<Library>) -> Self {
        let default_material = lib.default_material_index() as i32;
        StruckParams {
            object: IntParam::new("Object", 0, IntRange::Linear { min: 0, max: lib.banks.len().max(1) as i32 - 1 })
                .with_value_to_string(object_name(lib))
                .with_string_to_value(object_from_name(lib)),
            material: IntParam::new(
                "Material",
                default_material,
                IntRange::Linear { min: 0, max: lib.materials.len() as i32 },
            )
            .with_value_to_string(material_name(lib))
            .with_string_to_value(material_from_name(lib)),
            damping_model: EnumParam::new("Damping model", DampingModelParam::Rayleigh),
            alpha1_per_s: FloatParam::new(
                "Base damping α₁",
                5.0,
                FloatRange::Skewed { min: 0.0, max: 2000.0, factor: FloatRange::skew_factor(-2.5) },
            )
            .with_unit(" 1/s")
            .with_value_to_string(v2s_significant(4))
            .with_string_to_value(s2v_number()),
            damping_1k_per_s: FloatParam::new(
                "Damping at 1 kHz",
                4.0,
                FloatRange::Skewed { min: 0.0, max: 5000.0, factor: FloatRange::skew_factor(-2.5) },
            )
            .with_unit(" 1/s")
            .with_value_to_string(v2s_significant(4))
            .with_string_to_value(s2v_number()),
            exponent: FloatParam::new(
                "Exponent",
                1.0,
                FloatRange::Linear {
                    min: dsp::damping::EXPONENT_RANGE.0 as f32,
                    max: dsp::damping::EXPONENT_RANGE.1 as f32,
                },
            )
            .with_value_to_string(formatters::v2s_f32_rounded(3))
            .with_string_to_value(s2v_number()),
            caughey_10k_per_s: FloatParam::new(
                "Caughey c at 10 kHz",
                0.0,
                FloatRange::Skewed { min: 0.0, max: 1e5, factor: FloatRange::skew_factor(-2.5) },
            )
            .with_unit(" 1/s")
            .with_value_to_string(v2s_significant(4))
            .with_string_to_value(s2v_number()),
            custom_support_per_s: FloatParam::new(
                "Custom support",
                0.0,
                FloatRange::Skewed { min: 0.0, max: 2000.0, factor: FloatRange::skew_factor(-2.0) },
            )
            .with_unit(" 1/s")
            .with_value_to_string(v2s_significant(4))
            .with_string_to_value(s2v_number()),
            support_mode: EnumParam::new("Support", SupportMode::AsRecorded),
            support_amount_per_s: FloatParam::new(
                "Support amount",
                10.0,
                FloatRange::Skewed { min: 0.0, max: 2000.0, factor: FloatRange::skew_factor(-2.0) },
            )
            .with_unit(" 1/s")
            .with_value_to_string(v2s_significant(4))
            .with_string_to_value(s2v_number()),
            support_at_point: BoolParam::new("Held at a point", false),
            // 0.45: on the factory bar's path (an end at 0, the centre at 1) the fundamental's
            // node at 0.224 of the length, where bars are held.
            support_point: FloatParam::new("Support point", 0.45, FloatRange::Linear { min: 0.0, max: 1.0 })
                .with_value_to_string(formatters::v2s_f32_percentage(0))
                .with_string_to_value(formatters::s2v_f32_percentage())
                .with_unit("%"),
            decay_scale: FloatParam::new(
                "Decay scale",
                1.0,
                FloatRange::Skewed { min: 0.05, max: 20.0, factor: FloatRange::skew_factor(-2.0) },
            )
            .with_value_to_string(multiplier())
            .with_string_to_value(s2v_number()),
            modulus_ratio: FloatParam::new(
                "Stiffness γ/γ₀",
                1.0,
                FloatRange::Skewed {
                    min: estimator::object::PLAYABLE_GAMMA_RATIO.0 as f32,
                    max: estimator::object::PLAYABLE_GAMMA_RATIO.1 as f32,
                    factor: FloatRange::skew_factor(-2.6),
                },
            )
            .with_value_to_string(multiplier())
            .with_string_to_value(s2v_ratio_or_semitones(true)),
            material_pitch: BoolParam::new("Material sets pitch", false),
            root_note: IntParam::new("Root note", 60, IntRange::Linear { min: 0, max: 127 }),
            key_tuning: BoolParam::new("Keys tune the object", true),
            key_mode: EnumParam::new("Key mode", KeyMode::Pitched),
            size: FloatParam::new(
                "Size",
                1.0,
                FloatRange::Skewed { min: 0.05, max: 20.0, factor: FloatRange::skew_factor(-2.0) },
            )
            .with_value_to_string(multiplier())
            .with_string_to_value(s2v_ratio_or_semitones(false)),
            strike_position: FloatParam::new("Strike position", 0.3, FloatRange::Linear { min: 0.0, max: 1.0 })
                .with_poly_modulation_id(POSITION_POLY_MOD_ID)
                .with_value_to_string(formatters::v2s_f32_percentage(1))
                .with_unit("%")
                .with_string_to_value(formatters::s2v_f32_percentage()),
            mallet: EnumParam::new("Mallet", MalletParam::Wood),
            hardness: FloatParam::new("Mallet hardness", 0.5, FloatRange::Linear { min: 0.0, max: 1.0 })
                .with_value_to_string(formatters::v2s_f32_percentage(0))
                .with_unit("%")
                .with_string_to_value(formatters::s2v_f32_percentage()),
            variation: FloatParam::new("Variation", 0.0, FloatRange::Linear { min: 0.0, max: 1.0 })
                .with_value_to_string(formatters::v2s_f32_percentage(0))
                .with_unit("%")
                .with_string_to_value(formatters::s2v_f32_percentage()),
            pitch_reference: EnumParam::new("Pitch reference", PitchReference::Lowest),
            pitch_mode: IntParam::new("Pitch mode", 1, IntRange::Linear { min: 1, max: MAX_PITCH_MODE }),
            bend_range: IntParam::new("Pitch bend range", 2, IntRange::Linear { min: 0, max: 48 }).with_unit(" st"),
            normalize_level: BoolParam::new("Normalise level", true),
            output_safety: BoolParam::new("Output safety", true),
            noise: FloatParam::new("Noise", 0.0, FloatRange::Linear { min: 0.0, max: 1.0 })
                .with_value_to_string(formatters::v2s_f32_percentage(0))
                .with_unit("%")
                .with_string_to_value(formatters::s2v_f32_percentage()),
            velocity_sensitivity: FloatParam::new(
                "Velocity sensitivity",
                0.7,
                FloatRange::Linear { min: 0.0, max: 1.0 },
            )
            .with_value_to_string(formatters::v2s_f32_percentage(0))
            .with_unit("%")
            .with_string_to_value(formatters::s2v_f32_percentage()),
            release_damping_per_s: FloatParam::new(
                "Release damping",
                0.0,
                FloatRange::Skewed { min: 0.0, max: 500.0, factor: FloatRange::skew_factor(-2.0) },
            )
            .with_unit(" 1/s")
            .with_value_to_string(v2s_significant(4))
            .with_string_to_value(s2v_number()),
            pressure_damping_per_s: FloatParam::new(
                "Pressure damping",
                40.0,
                FloatRange::Skewed { min: 0.0, max: 500.0, factor: FloatRange::skew_factor(-2.0) },
            )
            .with_unit(" 1/s")
            .with_value_to_string(v2s_significant(4))
            .with_string_to_value(s2v_number()),
            quality_db: FloatParam::new("Quality", 60.0, FloatRange::Linear { min: 12.0, max: 120.0 })
                .with_unit(" dB")
                .with_value_to_string(formatters::v2s_f32_rounded(0))
                .with_string_to_value(s2v_number()),
            gain_db: FloatParam::new("Gain", 0.0, FloatRange::Linear { min: -60.0, max: 12.0 })
                .with_smoother(SmoothingStyle::Linear(20.0))
                .with_unit(" dB")
                .with_value_to_string(formatters::v2s_f32_rounded(1))
                .with_string_to_value(s2v_number()),
            excitation: EnumParam::new("Excitation", ExcitationParam::Strike),
            contact_speed: FloatParam::new(
                "Contact speed",
                0.2,
                FloatRange::Skewed {
                    min: 0.0,
                    max: dsp::contact::MAX_SPEED_M_PER_S as f32,
                    factor: FloatRange::skew_factor(-1.5),
                },
            )
            .with_unit(" m/s")
            .with_value_to_string(v2s_significant(3))
            .with_string_to_value(s2v_number()),
            texture: EnumParam::new("Texture", TextureParam::FineGrit),
            texture_scale: FloatParam::new(
                "Texture scale",
                1.0,
                FloatRange::Skewed { min: 0.1, max: 10.0, factor: FloatRange::skew_factor(-2.0) },
            )
            .with_value_to_string(v2s_significant(3))
            .with_string_to_value(s2v_number()),
            ball_radius_mm: FloatParam::new(
                "Ball radius",
                10.0,
                FloatRange::Skewed { min: 1.0, max: 100.0, factor: FloatRange::skew_factor(-2.0) },
            )
            .with_unit(" mm")
            .with_value_to_string(v2s_significant(3))
            .with_string_to_value(s2v_number()),
            contact_direction: EnumParam::new("Contact direction", ContactDirection::Forward),
            path_ends: EnumParam::new("Path ends", PathEnds::Bounce),
            audio_in: BoolParam::new("Audio in", true),
            dry_wet: FloatParam::new("Dry/wet", 1.0, FloatRange::Linear { min: 0.0, max: 1.0 })
                .with_value_to_string(formatters::v2s_f32_percentage(0))
                .with_unit("%")
                .with_string_to_value(formatters::s2v_f32_percentage()),
            residual: BoolParam::new("Residual", true),
            residual_level_db: FloatParam::new("Residual level", 0.0, FloatRange::Linear { min: -40.0, max: 12.0 })
                .with_unit(" dB")
                .with_value_to_string(formatters::v2s_f32_rounded(1))
                .with_string_to_value(s2v_number()),
            editor_size: Mutex::new(DEFAULT_EDITOR_SIZE),
            capture: Mutex::new(None),
            user_texture: Default::default(),
            user_residual: Default::default(),
            user_support: crate::user_support::UserSupportField::new(lib.clone()),
        }
    }

    /// The *Custom* knob values that reproduce `d` (exactly for Rayleigh, hybrid, power law
    /// and Caughey up to order 3): the inverse of [`custom_damping`](Self::custom_damping).
    /// Shared by the command line (`--material file.json`) and the editor's *Apply*.
    ///
    /// # Errors
    /// If the law needs a knob beyond its range or a fourth Caughey term.
    pub fn custom_knobs_for(&self, d: &Damping) -> Result<CustomKnobs, String> {
        let (model, a1, c1k, e, c10k) = match *d {
            Damping::Rayleigh { alpha1, alpha2 } => (DampingModelParam::Rayleigh, alpha1, alpha2 * LAMBDA_1K, 1.0, 0.0),
            Damping::Hybrid { alpha1, alpha2, alpha3 } => {
                (DampingModelParam::Hybrid, alpha1, alpha2 * LAMBDA_1K.powf(alpha3), alpha3, 0.0)
            }
            Damping::Power { alpha1, alpha2 } => {
                (DampingModelParam::Power, 0.0, alpha1 * LAMBDA_1K.powf(alpha2), alpha2, 0.0)
            }
            Damping::Caughey { coeffs, order } => {
                if order > 3 && coeffs[3] != 0.0 {
                    return Err("the plugin's Custom material plays Caughey series up to order 3".into());
                }
                (DampingModelParam::Caughey, coeffs[0], coeffs[1] * LAMBDA_1K, 1.0, coeffs[2] * LAMBDA_10K * LAMBDA_10K)
            }
        };
        let check = |name: &str, v: f64, param: &FloatParam| -> Result<f32, String> {
            let v = v as f32;
            let (lo, hi) = (param.preview_plain(0.0), param.preview_plain(1.0));
            if !(lo..=hi).contains(&v) {
                return Err(format!("{name} = {v} is outside the plugin's range {lo}..={hi}"));
            }
            Ok(v)
        };
        Ok(CustomKnobs {
            model,
            alpha1_per_s: check("base damping α₁ (1/s)", a1, &self.alpha1_per_s)?,
            damping_1k_per_s: check("damping at 1 kHz (1/s)", c1k, &self.damping_1k_per_s)?,
            exponent: check("exponent", e, &self.exponent)?,
            caughey_10k_per_s: check("Caughey c at 10 kHz (1/s)", c10k, &self.caughey_10k_per_s)?,
        })
    }

    /// The *Custom* material's damping law from the knobs (exact reparametrisation: α₂ is
    /// chosen so that the λ-dependent part of c equals the knob at λ₁ₖ = (2π·1 kHz)²).
    pub fn custom_damping(&self) -> Damping {
        let a1 = f64::from(self.alpha1_per_s.value());
        let c1k = f64::from(self.damping_1k_per_s.value());
        let e = f64::from(self.exponent.value());
        match self.damping_model.value() {
            DampingModelParam::Rayleigh => Damping::Rayleigh { alpha1: a1, alpha2: c1k / LAMBDA_1K },
            DampingModelParam::Caughey => Damping::Caughey {
                coeffs: [
                    a1,
                    c1k / LAMBDA_1K,
                    f64::from(self.caughey_10k_per_s.value()) / (LAMBDA_10K * LAMBDA_10K),
                    0.0,
                ],
                order: 3,
            },
            DampingModelParam::Power => Damping::Power { alpha1: c1k / LAMBDA_1K.powf(e), alpha2: e },
            DampingModelParam::Hybrid => Damping::Hybrid { alpha1: a1, alpha2: c1k / LAMBDA_1K.powf(e), alpha3: e },
        }
    }
}

/// The λ factor a note-on of `key` gets (the one place: the plugin's `strike_for` and the
/// editor call it): in *Pitched* mode one semitone per key from the root, or with *Keys tune
/// the object* the reference mode (the lowest, or the chosen one of *Pitch reference*; the
/// strongest starts from the lowest and is refined with the engine) at the key's
/// equal-tempered pitch; 1 in *Positions* mode.
pub fn key_lambda_factor(params: &StruckParams, bank: Option<&presets::Bank>, key: u8) -> f64 {
    match params.key_mode.value() {
        KeyMode::Pitched => {
            let semis = if params.key_tuning.value() {
                let mode = match params.pitch_reference.value() {
                    PitchReference::Lowest | PitchReference::Strongest => 0,
                    PitchReference::Chosen => (params.pitch_mode.value() - 1).max(0) as usize,
                };
                let f1 = bank
                    .and_then(|b| b.lambdas.get(mode.min(b.lambdas.len().saturating_sub(1))))
                    .map_or(1.0, |l| l.sqrt() / std::f64::consts::TAU);
                let f_key = 440.0 * 2f64.powf((f64::from(key) - 69.0) / 12.0);
                12.0 * (f_key / f1).log2()
            } else {
                f64::from(i32::from(key) - params.root_note.value())
            };
            2f64.powf(semis / 6.0)
        }
        KeyMode::Positions => 1.0,
    }
}
