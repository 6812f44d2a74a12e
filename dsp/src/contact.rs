//! Lasting contact: scrape, slide and roll across the object (issue 16; thesis §5.2.5.1 after
//! Ren, Yeh & Lin 2010, "Synthesizing contact sounds between textured models"; SCIENCE.md §7).
//!
//! A held note in a lasting excitation first strikes (the *macro* level: the first instant of
//! contact is an impact, today's exciter), then drives the same modes for as long as it is
//! held with a contact force made of two levels of surface detail:
//! - **micro**: fractal noise with a 1/f^β power spectrum. The noise is a height profile fixed
//!   along the path ([`MICRO_TEXEL_M`] per table sample), so its playback rate follows the
//!   sliding speed and its spectrum moves up with it; its level follows the normal force.
//! - **meso**: a texture (a 1-D height profile along the path). Whenever the contact moves
//!   onto a new texel, the change of the tool's normal momentum is applied as an impulse. With
//!   the geometric normal n_g = (0, 1), the texel's normal n_s ∝ (−s, 1) for its slope s and
//!   the tangential velocity v_t = (v, 0), thesis eq. 5.4, p_n = m·(−v_t·n_s / n_g·n_s)·n_g,
//!   is m·v·s·n_g: the impulse on entering a texel is m·v·(s_new − s_old), and the object takes
//!   its reaction, −m·v·Δs.
//!
//! What the tool follows depends on its shape: a point (a scraping stick or spoon edge) follows
//! the texture as it is; a flat (a sliding block) rests on the highest points under it, the
//! texture's upper envelope over its length; a ball of radius r cannot enter pits narrower
//! than its chord: it follows the upper envelope of the texture dilated by a disc of radius r
//! (morphological filtering), and an imperfect ball adds a modulation at its rotation
//! frequency v/(2πr).
//!
//! Units: the contact signal is an impulse per sample in units of the impulse of a velocity-1
//! strike (2·m·v_max, the mallet's mass rebounding from the fastest strike speed), the unit
//! the engine's strike drive uses, so the engine scales both the same way. The mass cancels:
//! a meso impulse is v·Δs / (2·v_max). The strike's pulse is heard through the modes'
//! velocity (the engine's `pickup`), a lasting contact's impulses (and audio in, and the
//! noise burst) through their deflection, Im z: the same ring for an impulse, a quarter
//! period apart; only a force slow against a mode (the contact's slow components under
//! high modes) is heard more as deflection, its quasi-static part (not measured here; the
//! contact's signal is a train of short impulses).

use crate::exciter::{Noise, FASTEST_STRIKE_M_PER_S};

/// Path length of one micro-noise table sample, m. The table's harmonics stop at a quarter of
/// its Nyquist frequency ([`MICRO_OVERSAMPLING`]), so the cubic interpolation between its
/// samples is accurate; its band then reaches v·24 kHz per m/s: 24 kHz at 1 m/s (fixed in Hz,
/// whatever the engine's sample rate; at 44.1 kHz the top of the band folds back above
/// 0.92 m/s, where the 1/f^β spectrum is 30–60 dB down).
pub const MICRO_TEXEL_M: f64 = 1.0 / 192_000.0;
/// The micro table's harmonics end at its Nyquist frequency over this factor.
pub const MICRO_OVERSAMPLING: usize = 4;
/// Length of the micro-noise table (a periodic profile of 2.7 m of path).
pub const MICRO_LEN: usize = 1 << 19;
/// Fastest contact speed the engine plays, m/s (the micro table then plays at the audio rate
/// at 48 kHz: no faster, so it never aliases there).
pub const MAX_SPEED_M_PER_S: f64 = 1.0;
/// Length of the object's strike path as the contact travels it, m, at size 1 (scaled with
/// the object's size): the bank's strike points are spread over this length.
pub const PATH_LENGTH_M: f64 = 0.25;
/// Length of a sliding flat, m.
pub const SLIDE_FLAT_M: f64 = 0.01;
/// Relative depth of the imperfect ball's modulation at its rotation frequency.
pub const BALL_ECCENTRICITY: f64 = 0.15;
/// Corner of the one-pole high-pass on the micro noise's force, Hz. The profile read where
/// the tool stands is a force that does not change while the tool stands still: played as it
/// was, a contact at speed 0 pushed the object aside by a constant amount, a DC offset of up to
/// −7 dBFS on a large object's low modes (a black-box tester's sphere shell at size 20), and a
/// slow one the sub-audio rumble of its 13–24 Hz modes. Only the force's changes sound: the
/// pressure a surface radiates follows its motion, which a static push does not cause. 20 Hz,
/// the bottom of hearing: the octave bands the power law is measured in (100 Hz up) lose under
/// 0.2 dB.
pub const MICRO_HIGHPASS_HZ: f64 = 20.0;
/// RMS impulse rate of the micro noise at full normal force, per second, in units of a
/// velocity-1 strike's impulse.
pub const MICRO_LEVEL: f64 = 16.0;
/// The contact's level against a strike's: a scrape at full force and 0.2 m/s on the factory
/// bar plays 2–8 dB under a velocity-127 strike's first 0.25 s (RMS over 0.5–1.5 s, measured
/// with `struck render`, the default wood mallet: grooves −2.8, fine grit −5.6, coarse grit
/// −7.1, bumps −7.6, smooth −7.8 dB). 6 since *Normalise level* scales the contact as an
/// ideal impulse, not as the mallet's strike (4 before: the wood mallet's level was 3.6 dB
/// over the impulse's on the bar at key 60), the same for every mallet; with it off the
/// contact and the strike keep the object's fixed scale, and the contact is 3.5 dB louder
/// against the strike than it was at 4.
pub const CONTACT_GAIN: f64 = 6.0;
/// At most this many texture samples either side of the contact are read for the envelope
/// of a flat or a ball (a wider tool reads every ⌈half-width / this⌉-th texel).
pub const MAX_ENVELOPE_HALF: i64 = 48;
/// Texel crossings handled one by one per sample; more (a texture change mid-contact)
/// resynchronise without an impulse.
const MAX_CROSSINGS: i64 = 16;

/// How a note excites the object.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Excitation {
    /// A strike (the mallet's force pulse), then the object rings freely.
    #[default]
    Strike,
    /// A point (a stick, a spoon's edge) dragged across the surface while the note is held.
    Scrape,
    /// A flat ([`SLIDE_FLAT_M`] long) sliding on the surface's high points.
    Slide,
    /// A ball rolling on the surface.
    Roll,
}

impl Excitation {
    /// Every excitation.
    pub const ALL: [Excitation; 4] = [Excitation::Strike, Excitation::Scrape, Excitation::Slide, Excitation::Roll];

    /// Display name.
    pub fn name(self) -> &'static str {
        match self {
            Excitation::Strike => "Strike",
            Excitation::Scrape => "Scrape",
            Excitation::Slide => "Slide",
            Excitation::Roll => "Roll",
        }
    }

    /// Whether a held note keeps contact (everything but a strike).
    pub fn is_lasting(self) -> bool {
        self != Excitation::Strike
    }

    /// β of the micro noise's 1/f^β spectrum: a point scrapes the finest detail (pink, β = 1);
    /// a flat averages it (β = 1.5); a ball cannot enter the finest pits (brown, β = 2).
    pub fn micro_beta(self) -> f64 {
        match self {
            Excitation::Strike | Excitation::Scrape => 1.0,
            Excitation::Slide => 1.5,
            Excitation::Roll => 2.0,
        }
    }
}

/// The factory surface textures.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TextureKind {
    /// No meso detail: the micro noise alone.
    Smooth,
    /// Fine grit: white heights, 40 µm texels, ±3 µm.
    #[default]
    FineGrit,
    /// Coarse grit: white heights, 0.25 mm texels, ±30 µm.
    CoarseGrit,
    /// Evenly spaced V grooves, 2 mm apart, 1 mm wide and 0.3 mm deep (a guiro, a ribbed bottle).
    Grooves,
    /// Random raised-cosine bumps (0.1–0.3 mm high, 1.5 mm wide) about 8 mm apart.
    Bumps,
    /// The user's profile (the engine's [`set_user_texture`](crate::engine::Engine::set_user_texture));
    /// smooth until one is given. Not in [`TextureKind::ALL`] (the factory textures).
    User,
}

impl TextureKind {
    /// Every factory texture (not [`TextureKind::User`]).
    pub const ALL: [TextureKind; 5] =
        [TextureKind::Smooth, TextureKind::FineGrit, TextureKind::CoarseGrit, TextureKind::Grooves, TextureKind::Bumps];

    /// Display name.
    pub fn name(self) -> &'static str {
        match self {
            TextureKind::Smooth => "Smooth",
            TextureKind::FineGrit => "Fine grit",
            TextureKind::CoarseGrit => "Coarse grit",
            TextureKind::Grooves => "Grooves",
            TextureKind::Bumps => "Bumps",
            TextureKind::User => "User",
        }
    }

    /// Spacing of the grooves at texture scale 1, m (the period of [`TextureKind::Grooves`]).
    pub const GROOVE_SPACING_M: f64 = 2e-3;

    /// The profile. Allocates (built once, off the audio thread).
    pub fn texture(self) -> Texture {
        let white = |n: usize, amp: f64, seed: u32| {
            let mut r = Noise::new(seed);
            (0..n).map(|_| amp * f64::from(r.next_sample())).collect::<Vec<f64>>()
        };
        match self {
            TextureKind::Smooth | TextureKind::User => Texture { heights: vec![0.0; 2], texel_m: 1e-3 },
            TextureKind::FineGrit => Texture { heights: white(4096, 3e-6, 0xF1E), texel_m: 40e-6 },
            TextureKind::CoarseGrit => Texture { heights: white(4096, 30e-6, 0xC0A), texel_m: 250e-6 },
            TextureKind::Grooves => {
                // 8 texels of 0.25 mm per groove: 4 of land, then a V 1 mm wide, 0.3 mm deep.
                let d = 0.3e-3;
                let groove = [0.0, 0.0, 0.0, 0.0, 0.0, -0.5 * d, -d, -0.5 * d];
                Texture { heights: groove.to_vec(), texel_m: Self::GROOVE_SPACING_M / 8.0 }
            }
            TextureKind::Bumps => {
                let (n, texel) = (4096usize, 0.1e-3);
                let mut h = vec![0.0; n];
                let mut r = Noise::new(0xB0B);
                let mut u = || 0.5 * (f64::from(r.next_sample()) + 1.0);
                // Exponential gaps with an 8 mm mean (at least the bump's width).
                let width = 15usize;
                let mut at = 0.0;
                loop {
                    at += (-(1.0 - u()).ln() * 8e-3 / texel).max(width as f64);
                    if at as usize + width >= n {
                        break;
                    }
                    let height = 0.1e-3 + 0.2e-3 * u();
                    for k in 0..=width {
                        let x = k as f64 / width as f64;
                        h[at as usize + k] += height * 0.5 * (1.0 - (2.0 * std::f64::consts::PI * x).cos());
                    }
                }
                Texture { heights: h, texel_m: texel }
            }
        }
    }
}

/// A periodic 1-D height profile along the contact path.
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    heights: Vec<f64>,
    texel_m: f64,
}

impl Texture {
    /// A profile of `heights` (m, periodic), one per `texel_m` of path.
    ///
    /// # Errors
    /// Fewer than 2 heights, a height that is not finite, or a texel that is not a positive
    /// length.
    pub fn new(heights: Vec<f64>, texel_m: f64) -> Result<Texture, String> {
        if heights.len() < 2 {
            return Err(format!("a texture needs at least 2 heights, got {}", heights.len()));
        }
        if let Some(i) = heights.iter().position(|h| !h.is_finite()) {
            return Err(format!("texture height {i} is not a number"));
        }
        if !(texel_m.is_finite() && texel_m > 0.0) {
            return Err(format!("texel length {texel_m} m is not a positive length"));
        }
        Ok(Texture { heights, texel_m })
    }

    /// Number of texels in one period.
    pub fn len(&self) -> usize {
        self.heights.len()
    }

    /// Whether the profile is empty (never: [`Texture::new`] needs 2 heights).
    pub fn is_empty(&self) -> bool {
        self.heights.is_empty()
    }

    /// Length of one texel, m.
    pub fn texel_m(&self) -> f64 {
        self.texel_m
    }

    /// Height of texel `i` (any integer: the profile repeats), m.
    #[inline]
    pub fn height(&self, i: i64) -> f64 {
        self.heights[i.rem_euclid(self.heights.len() as i64) as usize]
    }
}

/// A periodic fractal noise table with a 1/f^β power spectrum and unit RMS.
#[derive(Clone, Debug)]
pub struct FractalNoise {
    table: Vec<f32>,
    beta: f64,
}

impl FractalNoise {
    /// A table of [`MICRO_LEN`] samples: every harmonic k of the period up to
    /// N / (2·[`MICRO_OVERSAMPLING`]) gets amplitude k^(−β/2) and a random phase (seeded: the
    /// same table on every run), DC and the rest none; inverse FFT, scaled to unit RMS.
    /// Allocates.
    pub fn new(beta: f64, seed: u32) -> Self {
        use realfft::num_complex::Complex;
        let n = MICRO_LEN;
        let mut planner = realfft::RealFftPlanner::<f64>::new();
        let ifft = planner.plan_fft_inverse(n);
        let mut spectrum = ifft.make_input_vec();
        let mut rng = Noise::new(seed);
        for (k, bin) in spectrum.iter_mut().enumerate() {
            if k == 0 || k > n / (2 * MICRO_OVERSAMPLING) {
                *bin = Complex::new(0.0, 0.0);
                continue;
            }
            let phase = std::f64::consts::PI * f64::from(rng.next_sample());
            let a = (k as f64).powf(-0.5 * beta);
            *bin = Complex::new(a * phase.cos(), a * phase.sin());
        }
        let mut out = ifft.make_output_vec();
        // The input and output lengths match the plan: this cannot fail.
        if ifft.process(&mut spectrum, &mut out).is_err() {
            out.fill(0.0);
        }
        let rms = (out.iter().map(|x| x * x).sum::<f64>() / n as f64).sqrt();
        let s = if rms > 0.0 { 1.0 / rms } else { 0.0 };
        FractalNoise { table: out.iter().map(|x| (x * s) as f32).collect(), beta }
    }

    /// β of the table.
    pub fn beta(&self) -> f64 {
        self.beta
    }

    /// The table value at fractional index `x` (periodic), Catmull–Rom cubic interpolation.
    #[inline]
    pub fn at(&self, x: f64) -> f64 {
        let n = self.table.len();
        let xf = x.floor();
        let t = x - xf;
        let i = (xf as i64).rem_euclid(n as i64) as usize;
        let get = |k: usize| f64::from(self.table[k % n]);
        let (p0, p1, p2, p3) = (get(i + n - 1), get(i), get(i + 1), get(i + 2));
        let a = 0.5 * (-p0 + 3.0 * p1 - 3.0 * p2 + p3);
        let b = 0.5 * (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3);
        let c = 0.5 * (p2 - p0);
        ((a * t + b) * t + c) * t + p1
    }
}

/// The tool's shape, which filters the texture it follows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Tool {
    /// A point: the texture as it is.
    Point,
    /// A flat of this half-length, m: the texture's upper envelope over it.
    Flat(f64),
    /// A ball of this radius, m: the upper envelope of the texture dilated by the disc.
    Ball(f64),
}

impl Tool {
    /// The tool of `excitation` with a ball of `ball_radius_m`.
    pub fn of(excitation: Excitation, ball_radius_m: f64) -> Tool {
        match excitation {
            Excitation::Strike | Excitation::Scrape => Tool::Point,
            Excitation::Slide => Tool::Flat(0.5 * SLIDE_FLAT_M),
            Excitation::Roll => Tool::Ball(ball_radius_m.max(1e-5)),
        }
    }
}

/// What the contact runs over, shared by every voice: the texture at its scale, the tool,
/// the micro noise, the path's ends and the sample rate.
#[derive(Clone, Copy, Debug)]
pub struct Surface<'a> {
    /// The texture.
    pub texture: &'a Texture,
    /// Multiplies the texture's texel length and heights (its slopes are kept).
    pub scale: f64,
    /// The tool.
    pub tool: Tool,
    /// The micro noise.
    pub noise: &'a FractalNoise,
    /// Length of the strike path, m.
    pub path_m: f64,
    /// At the path's ends: wrap round (true) or bounce back (false).
    pub wrap: bool,
    /// Sample rate, Hz.
    pub fs: f64,
    /// The micro noise's high-pass pole at `fs` ([`HighPass::pole`] of [`MICRO_HIGHPASS_HZ`]).
    pub micro_highpass_r: f64,
}

impl Surface<'_> {
    /// Height of the path the tool's contact follows at texel `i`, m (the texture filtered by
    /// the tool's shape; see the module documentation).
    pub fn path_height(&self, i: i64) -> f64 {
        let w = self.texture.texel_m * self.scale;
        let h = |k: i64| self.texture.height(k) * self.scale;
        let envelope = |half_m: f64, profile: &dyn Fn(f64) -> f64| {
            let half = (half_m / w).floor() as i64;
            let stride = (half + MAX_ENVELOPE_HALF - 1).max(1) / MAX_ENVELOPE_HALF.max(1);
            let stride = stride.max(1);
            let mut best = f64::NEG_INFINITY;
            let mut k = -half;
            while k <= half {
                best = best.max(h(i + k) + profile(k as f64 * w));
                k += stride;
            }
            // Always include the texel itself.
            best.max(h(i) + profile(0.0))
        };
        match self.tool {
            Tool::Point => h(i),
            Tool::Flat(half) => envelope(half, &|_| 0.0),
            Tool::Ball(r) => envelope(r, &|u: f64| (r * r - u * u).max(0.0).sqrt() - r),
        }
    }

    fn texel_w(&self) -> f64 {
        self.texture.texel_m * self.scale
    }
}

/// One voice's contact: where it is on the path and on the texture, and the micro noise's
/// phase. Realtime-safe, no allocation.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ContactState {
    /// Distance travelled, m: the coordinate of the texture and the micro noise (they lie
    /// along the path the tool travels).
    odometer_m: f64,
    /// Current texel and the path's heights at it and at the next.
    texel: i64,
    height: f64,
    next_height: f64,
    /// Texel length the texel index was computed with (a texture or scale change resyncs).
    texel_w: f64,
    /// Offset into the micro noise table (from the voice's seed).
    micro_offset: f64,
    /// Position along the strike path, 0..=1, and direction of travel (±1).
    position: f64,
    direction: f64,
    /// The tool's rotation angle (a ball), rad.
    angle: f64,
    /// The micro noise's high-pass ([`MICRO_HIGHPASS_HZ`]), from the first value read (it
    /// starts at rest there: the strike is the contact's onset, not a step of the profile).
    micro_hp: Option<HighPass>,
}

/// A one-pole high-pass (DC blocker), y[n] = x[n] − x[n−1] + r·y[n−1], flushed to exact zero
/// under a floor: the lasting contact's micro force and the audio input go through it, so
/// only their changes push the modes (see [`MICRO_HIGHPASS_HZ`]). Realtime-safe.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct HighPass {
    last: f64,
    y: f64,
}

impl HighPass {
    /// Its pole r for a corner of `corner_hz` at `sample_rate`: 1 − 2π·f/fs, e^(−2π·f/fs)
    /// within 4·10⁻⁶ for 20 Hz at 44.1 kHz.
    pub fn pole(corner_hz: f64, sample_rate: f64) -> f64 {
        1.0 - std::f64::consts::TAU * corner_hz / sample_rate
    }

    /// At rest on the value `x` (its first output is 0 if `x` comes again).
    pub fn at_rest_on(x: f64) -> Self {
        HighPass { last: x, y: 0.0 }
    }

    /// The next output for input `x` with pole `r`; an output under `floor` is exactly 0.
    #[inline]
    pub fn next(&mut self, x: f64, r: f64, floor: f64) -> f64 {
        let y = x - self.last + r * self.y;
        self.last = x;
        self.y = if y.abs() < floor { 0.0 } else { y };
        self.y
    }
}

impl ContactState {
    /// A contact starting at `position` (0..=1 along the strike path) moving in `direction`
    /// along it (1: towards its end, −1: towards its start, 0: across it, staying at
    /// `position`: round a rim, along a ring), with the micro noise read from an offset drawn
    /// from `seed`.
    pub fn start(position: f32, direction: f64, seed: u32, surface: &Surface) -> Self {
        let mut r = Noise::new(seed);
        let micro_offset = 0.5 * (f64::from(r.next_sample()) + 1.0) * MICRO_LEN as f64;
        let mut s = ContactState {
            micro_offset,
            position: f64::from(position.clamp(0.0, 1.0)),
            direction: direction.clamp(-1.0, 1.0),
            ..Default::default()
        };
        s.resync(surface);
        s
    }

    fn resync(&mut self, surface: &Surface) {
        let w = surface.texel_w();
        self.texel_w = w;
        self.texel = (self.odometer_m / w).floor() as i64;
        self.height = surface.path_height(self.texel);
        self.next_height = surface.path_height(self.texel + 1);
    }

    /// Position along the strike path, 0..=1.
    pub fn position(&self) -> f32 {
        self.position as f32
    }

    /// Distance travelled, m.
    pub fn odometer_m(&self) -> f64 {
        self.odometer_m
    }

    /// The position after moving `distance_m` more along the path (wrapping or bouncing at
    /// the ends), without moving: for the gains at the next control tick.
    pub fn position_after(&self, distance_m: f64, surface: &Surface) -> f32 {
        let (p, _) = advance_position(self.position, self.direction, distance_m / surface.path_m, surface.wrap);
        p as f32
    }

    /// Moves the contact on by one sample at `speed` (m/s) along the path, without the
    /// texture or the micro noise (the audio input's contact: its force is the input).
    #[inline]
    pub fn travel(&mut self, surface: &Surface, speed: f64) {
        let dx = speed.clamp(0.0, MAX_SPEED_M_PER_S) / surface.fs;
        self.odometer_m += dx;
        (self.position, self.direction) =
            advance_position(self.position, self.direction, dx / surface.path_m, surface.wrap);
    }

    /// Moves on by one sample at `speed` (m/s, ≥ 0) with normal force `force` (0..=1) and
    /// returns the sample's impulse on the object (see the module documentation for units).
    #[inline]
    pub fn next(&mut self, surface: &Surface, speed: f64, force: f64) -> f32 {
        let v = speed.clamp(0.0, MAX_SPEED_M_PER_S);
        let dx = v / surface.fs;
        if self.texel_w != surface.texel_w() {
            self.resync(surface);
        }
        self.odometer_m += dx;
        (self.position, self.direction) =
            advance_position(self.position, self.direction, dx / surface.path_m, surface.wrap);
        // Meso: an impulse at each texel entered (thesis eq. 5.4).
        let w = self.texel_w;
        let to = (self.odometer_m / w).floor() as i64;
        let mut meso = 0.0;
        if to - self.texel > MAX_CROSSINGS {
            self.resync(surface);
        } else {
            while self.texel < to {
                let old = (self.next_height - self.height) / w;
                self.texel += 1;
                self.height = self.next_height;
                self.next_height = surface.path_height(self.texel + 1);
                let new = (self.next_height - self.height) / w;
                meso -= v * (new - old);
            }
        }
        // Micro: the fractal profile read at the distance travelled, high-passed (see
        // MICRO_HIGHPASS_HZ; flushed under 1e-30, so a stopped tool's force ends in exact
        // zeros, not denormals).
        let raw = surface.noise.at(self.micro_offset + self.odometer_m / MICRO_TEXEL_M);
        let hp = self.micro_hp.get_or_insert(HighPass::at_rest_on(raw));
        let micro = MICRO_LEVEL / surface.fs * hp.next(raw, surface.micro_highpass_r, 1e-30);
        let mut u = CONTACT_GAIN * force * (micro + meso / (2.0 * FASTEST_STRIKE_M_PER_S));
        if let Tool::Ball(r) = surface.tool {
            self.angle = (self.angle + dx / r) % std::f64::consts::TAU;
            u *= 1.0 + BALL_ECCENTRICITY * self.angle.cos();
        }
        u as f32
    }
}

/// Moves `position` by `step` (fraction of the path) in `direction`, wrapping or bouncing.
#[inline]
fn advance_position(position: f64, direction: f64, step: f64, wrap: bool) -> (f64, f64) {
    let mut p = position + direction * step;
    let mut dir = direction;
    if wrap {
        p = p.rem_euclid(1.0);
    } else {
        // Reflect at 0 and 1 (a step is far shorter than the path).
        for _ in 0..4 {
            if p > 1.0 {
                p = 2.0 - p;
                dir = -dir;
            } else if p < 0.0 {
                p = -p;
                dir = -dir;
            } else {
                break;
            }
        }
        p = p.clamp(0.0, 1.0);
    }
    (p, dir)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn surface<'a>(texture: &'a Texture, noise: &'a FractalNoise, tool: Tool) -> Surface<'a> {
        Surface {
            texture,
            scale: 1.0,
            tool,
            noise,
            path_m: PATH_LENGTH_M,
            wrap: false,
            fs: 48_000.0,
            micro_highpass_r: HighPass::pole(MICRO_HIGHPASS_HZ, 48_000.0),
        }
    }

    /// Power of `x` per octave band [f, 2f) by a periodogram (Hann window, averaged segments).
    fn octave_power(x: &[f64], fs: f64, bands: &[f64]) -> Vec<f64> {
        use realfft::RealFftPlanner;
        let n = 1 << 14;
        let fft = RealFftPlanner::<f64>::new().plan_fft_forward(n);
        let mut acc = vec![0.0; n / 2 + 1];
        let win: Vec<f64> =
            (0..n).map(|i| 0.5 - 0.5 * (2.0 * std::f64::consts::PI * i as f64 / n as f64).cos()).collect();
        for seg in x.chunks_exact(n) {
            let mut buf: Vec<f64> = seg.iter().zip(&win).map(|(a, w)| a * w).collect();
            let mut spec = fft.make_output_vec();
            fft.process(&mut buf, &mut spec).unwrap();
            for (a, s) in acc.iter_mut().zip(&spec) {
                *a += s.norm_sqr();
            }
        }
        bands
            .iter()
            .map(|&f| {
                let (lo, hi) = ((f * n as f64 / fs) as usize, (2.0 * f * n as f64 / fs) as usize);
                acc[lo..hi].iter().sum::<f64>()
            })
            .collect()
    }

    /// The micro noise, played by a moving contact on a smooth surface, has the 1/f^β power
    /// law: power per octave changes by (1 − β)·3.01 dB per octave (an octave holds twice the
    /// bins, each f^−β), within 1 dB, for each tool's β, at two speeds; the band moves with
    /// the speed (same law, the table fixed along the path).
    #[test]
    fn micro_noise_follows_its_power_law() {
        let smooth = TextureKind::Smooth.texture();
        let bands = [100.0, 200.0, 400.0, 800.0, 1600.0, 3200.0];
        for (excitation, beta) in [(Excitation::Scrape, 1.0), (Excitation::Slide, 1.5), (Excitation::Roll, 2.0)] {
            assert_eq!(excitation.micro_beta(), beta);
            let noise = FractalNoise::new(beta, 7);
            // The ball's rotation modulation is a separate test; a point tool here.
            let s = surface(&smooth, &noise, Tool::Point);
            for speed in [0.3, 0.9] {
                let mut c = ContactState::start(0.5, 1.0, 3, &s);
                let x: Vec<f64> = (0..(1 << 19)).map(|_| f64::from(c.next(&s, speed, 1.0))).collect();
                let p = octave_power(&x, 48_000.0, &bands);
                for w in p.windows(2) {
                    let step = 10.0 * (w[1] / w[0]).log10();
                    let expected = (1.0 - beta) * 10.0 * 2f64.log10();
                    assert!(
                        (step - expected).abs() < 1.0,
                        "β {beta} at {speed} m/s: {step:.2} dB/octave, expected {expected:.2}"
                    );
                }
            }
        }
    }

    /// A tool standing still pushes with a constant force, which does not sound: at speed 0
    /// the contact's force is exactly zero from its first sample, on every tool and texture
    /// (it was the profile's value there, a DC push), and at a slow 1 cm/s its mean over
    /// 10 s is under 1 % of its RMS (the profile's slow wander is high-passed away).
    #[test]
    fn a_standing_tool_makes_no_force() {
        let noise = FractalNoise::new(1.0, 7);
        for kind in [TextureKind::Smooth, TextureKind::Grooves, TextureKind::CoarseGrit] {
            let texture = kind.texture();
            for tool in [Tool::Point, Tool::Flat(SLIDE_FLAT_M), Tool::Ball(0.01)] {
                let s = surface(&texture, &noise, tool);
                let mut c = ContactState::start(0.3, 1.0, 5, &s);
                assert!((0..48_000).all(|_| c.next(&s, 0.0, 1.0) == 0.0), "{kind:?} {tool:?}");
                let mut c = ContactState::start(0.3, 1.0, 5, &s);
                let x: Vec<f64> = (0..480_000).map(|_| f64::from(c.next(&s, 0.01, 1.0))).collect();
                let mean = x.iter().sum::<f64>() / x.len() as f64;
                let rms = (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt();
                assert!(rms > 0.0 && mean.abs() < 0.01 * rms, "{kind:?} {tool:?}: mean {mean:e}, RMS {rms:e}");
            }
        }
    }

    /// Grooves s apart, crossed at speed v, give impulses v/s times a second: the impulse
    /// train's period is s/v within 1 %, and each impulse is the closed form −v·Δs/(2·v_max).
    #[test]
    fn grooves_give_impulses_at_speed_over_spacing() {
        let grooves = TextureKind::Grooves.texture();
        let silent = FractalNoise { table: vec![0.0; MICRO_LEN], beta: 1.0 };
        for (speed, scale) in [(0.2, 1.0), (0.37, 1.0), (0.5, 2.5)] {
            let s = Surface { scale, ..surface(&grooves, &silent, Tool::Point) };
            let mut c = ContactState::start(0.0, 1.0, 1, &s);
            let mut impulses = Vec::new();
            for n in 0..48_000 {
                let u = c.next(&s, speed, 1.0);
                if u != 0.0 {
                    impulses.push((n as f64, f64::from(u)));
                }
            }
            // Three impulses per groove: into the V (slope 0 → −0.6), at its bottom
            // (−0.6 → +0.6), out of it (+0.6 → 0); the object takes −v·Δs / (2·v_max).
            let slope = 0.3e-3 / 0.5e-3;
            let unit = CONTACT_GAIN * speed / (2.0 * FASTEST_STRIKE_M_PER_S);
            for (k, &(_, u)) in impulses.iter().enumerate().take(9) {
                let expected = match k % 3 {
                    0 => slope * unit,
                    1 => -2.0 * slope * unit,
                    _ => slope * unit,
                };
                assert!((u / expected - 1.0).abs() < 1e-4, "impulse {k}: {u} vs {expected}");
            }
            let grooves_crossed = (impulses.len() - 1) / 3;
            assert!(grooves_crossed > 30, "{} impulses", impulses.len());
            let period = (impulses[3 * grooves_crossed].0 - impulses[0].0) / grooves_crossed as f64;
            let expected = TextureKind::GROOVE_SPACING_M * scale / speed * 48_000.0;
            assert!((period / expected - 1.0).abs() < 0.01, "{speed} m/s x{scale}: {period} vs {expected}");
        }
    }

    /// A ball rolls over pits narrower than its chord: on a profile of narrow pits between
    /// flat lands, a point follows the pits and a ball of radius r whose chord at the pit's
    /// depth is wider than the pit stays on the lands (its path dips by the closed-form sag
    /// r − √(r² − (b/2)²) at most, b the pit's width); a wide pit it does enter.
    #[test]
    fn a_rolling_ball_bridges_pits_narrower_than_its_chord() {
        let w = 0.1e-3;
        let depth = 1e-3;
        // A 0.5 mm pit (5 texels) and a 20 mm pit (200 texels) in 10 cm of land.
        let mut h = vec![0.0; 1000];
        for x in &mut h[100..105] {
            *x = -depth;
        }
        for x in &mut h[500..700] {
            *x = -depth;
        }
        let tex = Texture::new(h, w).unwrap();
        let noise = FractalNoise::new(1.0, 1);
        let r = 4e-3;
        let ball = surface(&tex, &noise, Tool::Ball(r));
        let point = surface(&tex, &noise, Tool::Point);
        // The narrow pit: the ball's centre dips by the sag over a chord of the pit's width
        // (plus one texel: the lands' edges are a texel apart from the pit's).
        let b = 6.0 * w;
        let sag = r - (r * r - (0.5 * b) * (0.5 * b)).sqrt();
        let narrow = (98..108).map(|i| ball.path_height(i)).fold(f64::INFINITY, f64::min);
        assert!(narrow >= -sag - 1e-12 && sag < 0.05 * depth, "narrow pit: ball dips {narrow} (sag {sag})");
        assert_eq!(point.path_height(102), -depth);
        // The wide pit: the ball reaches its floor in the middle.
        assert!((ball.path_height(600) + depth).abs() < 1e-12, "wide pit: {}", ball.path_height(600));
    }

    /// The ball's imperfection modulates the contact at its rotation frequency v/(2πr).
    #[test]
    fn an_imperfect_ball_modulates_at_its_rotation_frequency() {
        let smooth = TextureKind::Smooth.texture();
        let noise = FractalNoise::new(2.0, 5);
        let (r, v) = (5e-3, 0.4);
        let s = surface(&smooth, &noise, Tool::Ball(r));
        let p = surface(&smooth, &noise, Tool::Point);
        let (mut a, mut b) = (ContactState::start(0.3, 1.0, 9, &s), ContactState::start(0.3, 1.0, 9, &p));
        // The ratio of the two is the modulation 1 + ε·cos(v t / r), per sample (NaN where the
        // force is too small to divide by: the first sample, where the high-passed micro
        // force starts at rest, among them).
        let mut ratio = Vec::new();
        for _ in 0..24_000 {
            let (x, y) = (a.next(&s, v, 1.0), b.next(&p, v, 1.0));
            ratio.push(if y.abs() > 1e-7 { f64::from(x / y) } else { f64::NAN });
        }
        let max = ratio.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        let min = ratio.iter().cloned().fold(f64::INFINITY, f64::min);
        assert!((max - 1.0 - BALL_ECCENTRICITY).abs() < 1e-3 && (min - 1.0 + BALL_ECCENTRICITY).abs() < 1e-3);
        // First maximum after the start (angle 2π): one rotation period 2πr/v.
        let period = 2.0 * std::f64::consts::PI * r / v * 48_000.0;
        let peak = (1..ratio.len() - 1)
            .filter(|&i| (i as f64) > 0.5 * period)
            .find(|&i| ratio[i] >= ratio[i - 1] && ratio[i] >= ratio[i + 1])
            .unwrap() as f64;
        assert!((peak + 1.0 - period).abs() < 2.0, "peak at {peak}, period {period}");
    }

    /// The contact travels the path at the speed: bouncing back at the ends, or wrapping.
    #[test]
    fn the_contact_travels_the_path_at_its_speed() {
        let smooth = TextureKind::Smooth.texture();
        let noise = FractalNoise::new(1.0, 1);
        let s = surface(&smooth, &noise, Tool::Point);
        let mut c = ContactState::start(0.8, 1.0, 1, &s);
        // 0.1 m/s for 1 s = 0.1 m = 0.4 of the path: up to 1, back to 0.8.
        for _ in 0..48_000 {
            c.next(&s, 0.1, 1.0);
        }
        assert!((c.position() - 0.8).abs() < 1e-4 && c.direction < 0.0, "{}", c.position());
        assert!((c.odometer_m() - 0.1).abs() < 1e-9);
        let w = Surface { wrap: true, ..s };
        let mut c = ContactState::start(0.8, 1.0, 1, &w);
        for _ in 0..48_000 {
            c.next(&w, 0.1, 1.0);
        }
        assert!((c.position() - 0.2).abs() < 1e-4, "{}", c.position());
        assert!((c.position_after(0.025, &w) - 0.3).abs() < 1e-4);
        // Across the path: the position stays, the texture still passes.
        let mut c = ContactState::start(0.35, 0.0, 1, &s);
        for _ in 0..48_000 {
            c.next(&s, 0.1, 1.0);
        }
        assert_eq!(c.position(), 0.35);
        assert!((c.odometer_m() - 0.1).abs() < 1e-9);
    }

    #[test]
    fn a_texture_needs_finite_heights_and_a_length() {
        assert!(Texture::new(vec![0.0], 1e-3).is_err());
        assert!(Texture::new(vec![0.0, f64::NAN], 1e-3).is_err());
        assert!(Texture::new(vec![0.0, 1.0], 0.0).is_err());
        assert!(Texture::new(vec![0.0, 1.0], 1e-3).is_ok());
    }
}
