//! Exciters: the mallet's contact with the object, and a noise burst for rough strikes.
//!
//! A strike is a force pulse in time (issue 11 part 1): a half-sine of duration T, the
//! contact time, skewed by an exponential e^(−βt) so its centroid falls where a lossy
//! contact's does (see [`Mallet::skew`]), with unit area (unit impulse), so the object's
//! modes are driven by the force itself and the waveform ramps up over the contact as a real
//! strike does; its spectrum follows from it. T comes from the contact law of the mallet
//! (Hertz for the hard mallets, the power law of hammer felt for felt) with the strike speed,
//! see [`Mallet::contact_time_s`].

/// Strike speed at velocity 0, m/s (a barely touching pp stroke).
pub const SLOWEST_STRIKE_M_PER_S: f64 = 0.05;
/// Strike speed at velocity 1, m/s (fff: mallet percussion strokes reach 1–5 m/s).
pub const FASTEST_STRIKE_M_PER_S: f64 = 5.0;
/// Decades of contact stiffness the *Mallet hardness* spans around a mallet's own (0.5).
pub const HARDNESS_DECADES: f64 = 4.0;
/// Shortest and longest contact time the engine plays, s.
pub const CONTACT_RANGE_S: (f64, f64) = (1e-5, 0.05);

/// The kinds of mallet, each with its contact law.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MalletKind {
    /// Wool/felt head: stiffening power law (hammer felt).
    Felt,
    /// Hard rubber ball.
    Rubber,
    /// Hard-wood (maple) ball.
    Wood,
    /// Plastic (ABS / polycarbonate) ball, as on xylophone and glockenspiel mallets.
    Plastic,
    /// Brass ball.
    Brass,
    /// Steel ball or rod (triangle beater).
    Steel,
}

impl MalletKind {
    /// Every kind, softest first.
    pub const ALL: [MalletKind; 6] = [
        MalletKind::Felt,
        MalletKind::Rubber,
        MalletKind::Wood,
        MalletKind::Plastic,
        MalletKind::Brass,
        MalletKind::Steel,
    ];

    /// The contact law and mass of this mallet.
    ///
    /// Felt: Chaigne & Askenfelt 1994 (J. Acoust. Soc. Am. 95(2), Table I, hammer C4):
    /// F = K·uᵖ with K = 4.0 × 10⁸ N/m^p, p = 2.5, m = 10 g (felt stiffens as it is
    /// compressed, Stulov 1995, so loud strikes are much shorter). The others are Hertz
    /// contacts of a ball of radius R (Johnson, *Contact Mechanics*, 1985, §4.2 eq. 4.23:
    /// F = (4/3)·E*·√R·u^(3/2)) with handbook Young's moduli: rubber 20 MPa (hard rubber
    /// mallet, Shore ~90A), maple 1.0 GPa across the grain, ABS 2.3 GPa, brass 100 GPa,
    /// steel 200 GPa; Poisson's ratios 0.5, 0.4, 0.35, 0.34, 0.29.
    pub fn mallet(self) -> Mallet {
        match self {
            MalletKind::Felt => {
                Mallet { stiffness: 4.0e8, exponent: 2.5, mass_kg: 0.010, hertz: None, skew: 0.0 }.with_restitution(0.6)
            }
            MalletKind::Rubber => Mallet::hertz(20e6, 0.5, 0.015, 0.030).with_restitution(0.75),
            MalletKind::Wood => Mallet::hertz(1.0e9, 0.4, 0.012, 0.020).with_restitution(0.6),
            MalletKind::Plastic => Mallet::hertz(2.3e9, 0.35, 0.012, 0.025).with_restitution(0.7),
            MalletKind::Brass => Mallet::hertz(100e9, 0.34, 0.010, 0.040).with_restitution(0.8),
            MalletKind::Steel => Mallet::hertz(200e9, 0.29, 0.008, 0.030).with_restitution(0.85),
        }
    }

    /// Display name.
    pub fn name(self) -> &'static str {
        match self {
            MalletKind::Felt => "Felt",
            MalletKind::Rubber => "Rubber",
            MalletKind::Wood => "Wood",
            MalletKind::Plastic => "Plastic",
            MalletKind::Brass => "Brass",
            MalletKind::Steel => "Steel",
        }
    }
}

/// A Hertz contact's elastic data, kept so the object's own modulus can be combined in.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HertzBall {
    /// Young's modulus of the mallet, Pa.
    pub modulus_pa: f64,
    /// Poisson's ratio of the mallet.
    pub poisson: f64,
    /// Radius of the ball, m.
    pub radius_m: f64,
}

/// A mallet: contact force F = K·uᵖ at compression u, and the moving mass.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mallet {
    /// K, N/m^p (against a rigid object).
    pub stiffness: f64,
    /// p (3/2 for Hertz).
    pub exponent: f64,
    /// Moving mass, kg.
    pub mass_kg: f64,
    /// The ball's elastic data for Hertz mallets (None: a power law of its own, felt).
    pub hertz: Option<HertzBall>,
    /// β·T of the force pulse e^(−βt)·sin(πt/T): 0 for a lossless contact (a symmetric
    /// half-sine), larger the more the contact loses (see [`with_restitution`](Self::with_restitution)).
    pub skew: f64,
}

impl Mallet {
    /// A Hertz ball of modulus `e` (Pa), Poisson's ratio `nu`, radius `r` (m), mass `m` (kg),
    /// on a rigid object.
    pub fn hertz(e: f64, nu: f64, r: f64, m: f64) -> Mallet {
        let stiffness = 4.0 / 3.0 * e / (1.0 - nu * nu) * r.sqrt();
        Mallet {
            stiffness,
            exponent: 1.5,
            mass_kg: m,
            hertz: Some(HertzBall { modulus_pa: e, poisson: nu, radius_m: r }),
            skew: 0.0,
        }
    }

    /// This mallet losing energy in the contact so it rebounds at `e` times its strike speed
    /// (its coefficient of restitution, 0 < e ≤ 1): the pulse's skew β·T is set so its
    /// centroid in time is T·e/(1 + e).
    ///
    /// Why that centroid, whatever the contact law: the force F = −m·ẍ over the contact gives
    /// the impulse ∫F dt = m·(v + e·v) and the first moment ∫t·F dt = −m·[t·ẋ]₀ᵀ + m·∫ẋ dt =
    /// m·T·e·v (x is 0 at both ends), so the centroid is T·e/(1 + e): a lossless contact
    /// (e = 1) centres its force at T/2, a lossy one earlier, as the force of the loading
    /// phase outweighs the unloading's (Hunt & Crossley 1975's damped contact, and felt's
    /// hysteresis, Stulov 1995). Of e^(−βt)·sin(πt/T) the centroid is T·c(βT) with
    /// c(b) = e^(−b)/(1 + e^(−b)) + 2b/(b² + π²) (−d/db of the log of its area
    /// π(1 + e^(−b))/(b² + π²)), decreasing in b from ½; b is found by bisection.
    ///
    /// Why skew at all: a symmetric pulse's spectrum is real up to its delay and changes sign,
    /// so it has exact nulls (the half-sine's at fT = 1.5, 2.5, …). As the velocity changes T,
    /// they swept across the strong modes and left holes in a velocity sweep (−6.6 dB from
    /// velocity 113 to 125 with the felt at hardness 0 on the bar at key 60, a black-box
    /// tester's finding). The skewed pulse's spectrum has the factor |1 + e^(−b)·e^(−iωT)|,
    /// which has no zero for b > 0 (it never falls under 1 − e^(−b)), and at e ≤ 0.7 no dip is
    /// left over the main lobe.
    ///
    /// The values the kinds use are typical rebound coefficients of balls of their materials
    /// on a hard surface (steel 0.85, brass 0.8, ABS 0.7, hard rubber 0.75, hard wood 0.6, and
    /// felt 0.6 as for a felt-covered head); a measured value for mallets on bars is not
    /// known to us. Realtime-safe (no allocation; about 60 exponentials).
    pub fn with_restitution(self, e: f64) -> Mallet {
        let e = if e.is_finite() { e.clamp(0.05, 1.0) } else { 1.0 };
        let target = e / (1.0 + e);
        let (mut lo, mut hi) = (0.0f64, 60.0f64);
        if pulse_centroid(lo) <= target {
            return Mallet { skew: 0.0, ..self };
        }
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if pulse_centroid(mid) > target {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        Mallet { skew: 0.5 * (lo + hi), ..self }
    }

    /// This mallet on an object of Young's modulus `object_pa` (Poisson 0.3): the Hertz
    /// contact modulus 1/E* = (1 − ν₁²)/E₁ + (1 − ν₂²)/E₂ (Johnson eq. 4.22). Unknown (≤ 0
    /// or not finite) or felt: unchanged (the object is taken as rigid).
    pub fn on_object(self, object_pa: f64) -> Mallet {
        match self.hertz {
            Some(b) if object_pa.is_finite() && object_pa > 0.0 => {
                let e_star = 1.0 / ((1.0 - b.poisson * b.poisson) / b.modulus_pa + (1.0 - 0.09) / object_pa);
                Mallet { stiffness: 4.0 / 3.0 * e_star * b.radius_m.sqrt(), ..self }
            }
            _ => self,
        }
    }

    /// Contact time T (s) of a strike at `speed` (m/s) with the stiffness scaled by
    /// `stiffness_scale`.
    ///
    /// A mass m meeting a contact F = K·uᵖ at speed v (the object locally rigid and massive,
    /// no losses) compresses to u_max = ((p+1)·m·v² / (2K))^(1/(p+1)) and leaves after
    /// T = 2·(u_max/v)·I(p), I(p) = ∫₀¹ dx/√(1 − x^(p+1)) = √π·Γ(1 + 1/(p+1)) / Γ(1/2 + 1/(p+1))
    /// (energy conservation; for p = 3/2 this is Hertz's 2.94·u_max/v, Johnson §11.4 eq. 11.24).
    /// So T ∝ v^(−(p−1)/(p+1)): v^(−1/5) for Hertz, v^(−3/7) for felt.
    pub fn contact_time_s(&self, speed: f64, stiffness_scale: f64) -> f64 {
        let p = self.exponent;
        let k = self.stiffness * stiffness_scale;
        let v = speed.max(1e-4);
        let u_max = ((p + 1.0) * self.mass_kg * v * v / (2.0 * k)).powf(1.0 / (p + 1.0));
        let t = 2.0 * u_max / v * contact_integral(p);
        if t.is_finite() {
            t.clamp(CONTACT_RANGE_S.0, CONTACT_RANGE_S.1)
        } else {
            CONTACT_RANGE_S.1
        }
    }
}

/// The centroid of the pulse e^(−bt)·sin(πt) on [0, 1] (see [`Mallet::with_restitution`]).
pub fn pulse_centroid(b: f64) -> f64 {
    let q = (-b).exp();
    q / (1.0 + q) + 2.0 * b / (b * b + std::f64::consts::PI * std::f64::consts::PI)
}

/// I(p) = ∫₀¹ dx/√(1 − x^(p+1)) = √π·Γ(1 + 1/(p+1)) / Γ(1/2 + 1/(p+1)) (substitute
/// y = x^(p+1): a Beta function).
pub fn contact_integral(p: f64) -> f64 {
    let q = 1.0 / (p + 1.0);
    std::f64::consts::PI.sqrt() * libm::tgamma(1.0 + q) / libm::tgamma(0.5 + q)
}

/// Strike speed (m/s) of a note of `velocity` in 0..=1: exponential from
/// [`SLOWEST_STRIKE_M_PER_S`] to [`FASTEST_STRIKE_M_PER_S`], so equal velocity steps are
/// equal ratios of speed (the 40 dB of impulse a player's pp–fff spans).
#[inline]
pub fn strike_speed(velocity: f32) -> f64 {
    let v = f64::from(velocity.clamp(0.0, 1.0));
    SLOWEST_STRIKE_M_PER_S * (FASTEST_STRIKE_M_PER_S / SLOWEST_STRIKE_M_PER_S).powf(v)
}

/// Contact-stiffness factor of *Mallet hardness* `h` in 0..=1: 1 at 0.5 (the mallet as
/// made), [`HARDNESS_DECADES`] decades from end to end.
#[inline]
pub fn hardness_scale(hardness: f32) -> f64 {
    10f64.powf(HARDNESS_DECADES * (f64::from(hardness.clamp(0.0, 1.0)) - 0.5))
}

/// The amplitude A of the unit-area force pulse A·e^(−βt)·sin(at) on [0, T], a = π/T,
/// β = `skew`/T: its area is A·a·(1 + e^(−βT))/(β² + a²), so A = (β² + a²)/(a·(1 + e^(−βT)))
/// (π/2T for the half-sine).
#[inline]
pub fn pulse_amplitude(contact_s: f64, skew: f64) -> f64 {
    let (a, beta) = (std::f64::consts::PI / contact_s, skew / contact_s);
    (beta * beta + a * a) / (a * (1.0 + (-skew).exp()))
}

/// Magnitude of the unit-area force pulse's spectrum at `freq_hz` for a contact of
/// `contact_s` seconds with skew `skew` = βT ([`Mallet::skew`]; 1 at DC). The pulse
/// F(t) ∝ e^(−βt)·sin(at), a = π/T, on [0, T] has the transform
/// a·(1 + e^(−(β + iω)T)) / ((β + iω)² + a²) and the area a·(1 + e^(−βT))/(β² + a²), so
/// |P(f)| = |1 + e^(−βT)·e^(−iωT)| / (1 + e^(−βT)) · (β² + a²) / |(β + iω)² + a²|;
/// at β = 0 the half-sine's |cos(πfT)| / |1 − (2fT)²| (→ π/4 at 2fT = 1). This is what each
/// mode receives; the engine's exact discrete drive reproduces it.
#[inline]
pub fn pulse_spectrum(freq_hz: f64, contact_s: f64, skew: f64) -> f64 {
    use std::f64::consts::PI;
    let x = 2.0 * freq_hz * contact_s;
    if skew.abs() < 1e-9 {
        let den = 1.0 - x * x;
        if den.abs() < 1e-6 {
            return std::f64::consts::FRAC_PI_4;
        }
        return ((0.5 * PI * x).cos() / den).abs();
    }
    // In units of 1/T: b = βT, w = ωT = π·x, a·T = π.
    let (b, w) = (skew, PI * x);
    let q = (-b).exp();
    let (sn, cs) = w.sin_cos();
    let num = ((1.0 + q * cs).powi(2) + (q * sn).powi(2)).sqrt() / (1.0 + q);
    // (b + iw)² + π² = b² − w² + π² + 2ibw.
    let den = (b * b - w * w + PI * PI).hypot(2.0 * b * w);
    num * (b * b + PI * PI) / den
}

/// Loudness factor of a strike of `velocity` (0..=1) with `sensitivity` (0..=1): 1 for any
/// velocity at sensitivity 0; `velocity²` at sensitivity 1 (−40 dB at velocity 0.1).
#[inline]
pub fn velocity_gain(velocity: f32, sensitivity: f32) -> f32 {
    velocity.clamp(0.0, 1.0).powf(2.0 * sensitivity.clamp(0.0, 1.0))
}

/// The K-weighting filter of ITU-R BS.1770-4 (loudness, LUFS) at 48 kHz: the high shelf
/// (stage 1) and the RLB high-pass (stage 2), coefficients from Table 1 and 2 of the
/// recommendation, as `(b0, b1, b2, a1, a2)`.
pub const K_WEIGHTING_48K: [[f64; 5]; 2] = [
    [1.535_124_859_586_97, -2.691_696_189_406_38, 1.198_392_810_852_85, -1.690_659_293_182_41, 0.732_480_774_215_85],
    [1.0, -2.0, 1.0, -1.990_047_454_833_98, 0.990_072_250_366_21],
];

/// K-weighting gain (linear) at `f` Hz: the magnitude response of [`K_WEIGHTING_48K`]
/// (frequencies above 23.9 kHz, where the shelf is flat, take its value there).
#[inline]
pub fn k_weighting(f: f64) -> f64 {
    let w = 2.0 * std::f64::consts::PI * f.clamp(0.0, 23_900.0) / 48_000.0;
    let (s1, c1) = w.sin_cos();
    // Double angle: one sine/cosine per call (the engine weighs every mode of a strike).
    let (s2, c2) = (2.0 * s1 * c1, 2.0 * c1 * c1 - 1.0);
    let mut g2 = 1.0;
    for [b0, b1, b2, a1, a2] in K_WEIGHTING_48K {
        // |B(e^{jw})|² / |A(e^{jw})|² with z⁻¹ = e^{−jw}.
        let (nr, ni) = (b0 + b1 * c1 + b2 * c2, -(b1 * s1 + b2 * s2));
        let (dr, di) = (1.0 + a1 * c1 + a2 * c2, -(a1 * s1 + a2 * s2));
        g2 *= (nr * nr + ni * ni) / (dr * dr + di * di);
    }
    g2.sqrt()
}

/// A small, fast, deterministic white-noise source (xorshift32) in [−1, 1).
#[derive(Clone, Copy, Debug)]
pub struct Noise {
    state: u32,
}

impl Noise {
    /// A generator from `seed` (any value; 0 is remapped).
    pub fn new(seed: u32) -> Self {
        Noise { state: if seed == 0 { 0x9E37_79B9 } else { seed } }
    }

    /// The next sample in [−1, 1).
    #[inline]
    pub fn next_sample(&mut self) -> f32 {
        let mut x = self.state;
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        self.state = x;
        // Top 24 bits as a float in [0, 1), mapped to [−1, 1).
        (x >> 8) as f32 * (2.0 / 16_777_216.0) - 1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The closed-form contact time against a direct integration of m·ü = −K·uᵖ (RK4 with a
    /// small step, contact ends when u returns to 0), for every mallet at three speeds.
    #[test]
    fn contact_time_matches_an_integration_of_the_contact_law() {
        for kind in MalletKind::ALL {
            let m = kind.mallet();
            for v in [0.1, 1.0, 4.0] {
                let t_closed = m.contact_time_s(v, 1.0);
                let dt = t_closed / 200_000.0;
                let acc = |u: f64| if u > 0.0 { -m.stiffness * u.powf(m.exponent) / m.mass_kg } else { 0.0 };
                let (mut u, mut w, mut t) = (0.0f64, v, 0.0f64);
                loop {
                    let (k1u, k1w) = (w, acc(u));
                    let (k2u, k2w) = (w + 0.5 * dt * k1w, acc(u + 0.5 * dt * k1u));
                    let (k3u, k3w) = (w + 0.5 * dt * k2w, acc(u + 0.5 * dt * k2u));
                    let (k4u, k4w) = (w + dt * k3w, acc(u + dt * k3u));
                    let un = u + dt / 6.0 * (k1u + 2.0 * k2u + 2.0 * k3u + k4u);
                    w += dt / 6.0 * (k1w + 2.0 * k2w + 2.0 * k3w + k4w);
                    if un <= 0.0 && t > 0.0 {
                        // Linear interpolation of the crossing.
                        t += dt * u / (u - un);
                        break;
                    }
                    u = un;
                    t += dt;
                }
                assert!((t / t_closed - 1.0).abs() < 1e-4, "{kind:?} at {v} m/s: {t} vs {t_closed}");
            }
        }
    }

    /// Hertz's constant: I(3/2) · 2 = 2.943 (Johnson eq. 11.24 gives T = 2.94 u_max / v).
    #[test]
    fn hertz_constant_is_johnsons() {
        assert!((2.0 * contact_integral(1.5) - 2.943).abs() < 1e-3);
        // p = 1 is a linear spring: half a period, T = π√(m/K) → 2·I(1) = π.
        assert!((2.0 * contact_integral(1.0) - std::f64::consts::PI).abs() < 1e-12);
    }

    #[test]
    fn mallets_are_ordered_and_plausible() {
        let times: Vec<f64> = MalletKind::ALL.iter().map(|k| k.mallet().contact_time_s(1.0, 1.0)).collect();
        // Felt 1–5 ms, steel under 0.1 ms (Chaigne & Doutaut 1997 measured 0.5–1 ms for
        // xylophone mallets, shorter on metal).
        assert!(times[0] > 1e-3 && times[0] < 5e-3, "{times:?}");
        assert!(times[5] < 1e-4, "{times:?}");
        for w in times.windows(2) {
            assert!(w[0] > w[1], "softest first: {times:?}");
        }
        // A soft object lengthens a hard mallet's contact; felt ignores it.
        let steel = MalletKind::Steel.mallet();
        assert!(steel.on_object(3e9).contact_time_s(1.0, 1.0) > 2.0 * steel.contact_time_s(1.0, 1.0));
        let felt = MalletKind::Felt.mallet();
        assert_eq!(felt.on_object(3e9), felt);
    }

    #[test]
    fn pulse_spectrum_is_the_half_sines() {
        let t = 1e-3;
        assert_eq!(pulse_spectrum(0.0, t, 0.0), 1.0);
        // Null at 2fT = 3 (f = 1.5 kHz), π/4 at the removable singularity 2fT = 1.
        assert!(pulse_spectrum(1500.0, t, 0.0) < 1e-12);
        assert!((pulse_spectrum(500.0, t, 0.0) - std::f64::consts::FRAC_PI_4).abs() < 1e-9);
        assert!((pulse_spectrum(500.0 * (1.0 + 1e-5), t, 0.0) - std::f64::consts::FRAC_PI_4).abs() < 1e-4);
        // Direct numerical Fourier transform of the unit-area pulse e^(−βt)·sin(πt/T) at a
        // few frequencies, symmetric and skewed (steel's 0.86, felt's 2.76 and beyond), and
        // the skewed formula's limit as β → 0.
        for skew in [0.0, 1e-7, 0.5, 0.86, 2.76, 8.0] {
            assert!((pulse_spectrum(0.0, t, skew) - 1.0).abs() < 1e-12, "DC at {skew}");
            for f in [100.0, 500.0, 700.0, 1500.0, 2345.0, 9000.0] {
                let n = 100_000;
                let (mut re, mut im, mut area) = (0.0, 0.0, 0.0);
                for i in 0..n {
                    let tt = (i as f64 + 0.5) * t / n as f64;
                    let x = (-skew * tt / t).exp() * (std::f64::consts::PI * tt / t).sin() * t / n as f64;
                    area += x;
                    re += x * (2.0 * std::f64::consts::PI * f * tt).cos();
                    im += x * (2.0 * std::f64::consts::PI * f * tt).sin();
                }
                let mag = (re * re + im * im).sqrt() / area;
                assert!((mag - pulse_spectrum(f, t, skew)).abs() < 1e-6, "{f} Hz at skew {skew}: {mag}");
            }
        }
    }

    /// The restitution's centroid rule against a direct integration of a lossy contact: a
    /// Hunt–Crossley contact m·ẍ = −K·xᵖ·(1 + μ·ẋ) (RK4, the damping μ chosen, the rebound
    /// speed measured) has its force's centroid at T·e/(1 + e) with e the measured rebound
    /// ratio; the skewed pulse of that e has the same centroid (numerical quadrature, not the
    /// closed form the bisection uses); and the kinds' pulses are skewed in the order of
    /// their losses.
    #[test]
    fn a_lossy_contact_centres_its_force_where_the_skew_does() {
        for (p, mu) in [(1.5, 0.0), (1.5, 0.3), (1.5, 1.2), (2.5, 0.5), (2.5, 2.0)] {
            let (m, k, v0) = (1.0f64, 1.0f64, 1.0f64);
            let acc = |x: f64, v: f64| if x > 0.0 { -k * x.powf(p) * (1.0 + mu * v).max(0.0) / m } else { 0.0 };
            let dt = 1e-5;
            let (mut x, mut v, mut t) = (0.0f64, v0, 0.0f64);
            let (mut imp, mut moment) = (0.0f64, 0.0f64);
            loop {
                let f0 = -m * acc(x, v);
                let (k1x, k1v) = (v, acc(x, v));
                let (k2x, k2v) = (v + 0.5 * dt * k1v, acc(x + 0.5 * dt * k1x, v + 0.5 * dt * k1v));
                let (k3x, k3v) = (v + 0.5 * dt * k2v, acc(x + 0.5 * dt * k2x, v + 0.5 * dt * k2v));
                let (k4x, k4v) = (v + dt * k3v, acc(x + dt * k3x, v + dt * k3v));
                let xn = x + dt / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x);
                let vn = v + dt / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
                let f1 = -m * acc(xn.max(0.0), vn);
                // Trapezoid sums of the force and of t·force.
                imp += 0.5 * dt * (f0 + f1);
                moment += 0.5 * dt * (t * f0 + (t + dt) * f1);
                if xn <= 0.0 && t > 0.0 {
                    t += dt * x / (x - xn);
                    v = vn;
                    break;
                }
                (x, v) = (xn, vn);
                t += dt;
            }
            let e = -v / v0;
            let centroid = moment / imp / t;
            assert!((centroid - e / (1.0 + e)).abs() < 2e-3, "p {p} μ {mu}: centroid {centroid}, e {e}");
            let skew = MalletKind::Felt.mallet().with_restitution(e).skew;
            let n = 200_000;
            let (mut a, mut c) = (0.0, 0.0);
            for i in 0..n {
                let s = (i as f64 + 0.5) / n as f64;
                let f = (-skew * s).exp() * (std::f64::consts::PI * s).sin();
                a += f;
                c += s * f;
            }
            assert!((c / a - centroid).abs() < 2e-3, "p {p} μ {mu}: skewed {} vs {centroid}", c / a);
        }
        let skews: Vec<f64> = MalletKind::ALL.iter().map(|k| k.mallet().skew).collect();
        assert!(skews.iter().all(|&s| s > 0.5 && s < 4.0), "{skews:?}");
        assert!(skews[5] < skews[4] && skews[4] < skews[1] && skews[1] < skews[3] && skews[3] < skews[2], "{skews:?}");
        assert_eq!(MalletKind::Steel.mallet().with_restitution(1.0).skew, 0.0);
    }

    /// No holes: the skewed pulses of the kinds never dip deep between two frequencies the
    /// way the half-sine's nulls do. Over fT in 0..4 (the main lobe and the first side
    /// lobes), |P| at any frequency is at most 7 dB above its value at any lower frequency
    /// (the symmetric half-sine: unbounded, nulls).
    #[test]
    fn the_kinds_pulses_have_no_nulls() {
        let rise = |skew: f64| {
            let mut lowest = f64::INFINITY;
            let mut worst = 0.0f64;
            for i in 0..=4000 {
                let p = pulse_spectrum(i as f64 * 1e-3, 1.0, skew);
                lowest = lowest.min(p);
                worst = worst.max(20.0 * (p / lowest).log10());
            }
            worst
        };
        assert!(rise(0.0) > 60.0, "the half-sine's nulls: {}", rise(0.0));
        for kind in MalletKind::ALL {
            let r = rise(kind.mallet().skew);
            println!("{kind:?}: skew {:.3}, largest rise {r:.2} dB", kind.mallet().skew);
            assert!(r < 7.0, "{kind:?}: {r:.1} dB");
        }
        // Felt and wood (e = 0.6): no dip at all over the main lobe and the first side lobes.
        assert!(rise(MalletKind::Felt.mallet().skew) < 0.1);
    }

    /// BS.1770-4: the −0.691 dB in its loudness formula cancels the K-filter's gain at
    /// 997 Hz; and the closed-form response equals the two biquads run in time on a sine
    /// (steady-state amplitude), from 20 Hz to 20 kHz.
    #[test]
    fn k_weighting_is_bs1770s_filter() {
        assert!((20.0 * k_weighting(997.0).log10() - 0.691).abs() < 0.005, "{}", 20.0 * k_weighting(997.0).log10());
        for f in [20.0, 38.0, 100.0, 500.0, 1500.0, 4000.0, 10_000.0, 20_000.0] {
            let n = 96_000;
            let mut x: Vec<f64> =
                (0..n).map(|i| (2.0 * std::f64::consts::PI * f * i as f64 / 48_000.0).sin()).collect();
            for [b0, b1, b2, a1, a2] in K_WEIGHTING_48K {
                let (mut x1, mut x2, mut y1, mut y2) = (0.0, 0.0, 0.0, 0.0);
                for v in x.iter_mut() {
                    let y = b0 * *v + b1 * x1 + b2 * x2 - a1 * y1 - a2 * y2;
                    (x2, x1, y2, y1) = (x1, *v, y1, y);
                    *v = y;
                }
            }
            // Steady-state amplitude: √2 × RMS over the second second (sample peaks would
            // miss the crest at high frequencies).
            let amp = (2.0 * x[n / 2..].iter().map(|v| v * v).sum::<f64>() / (n / 2) as f64).sqrt();
            assert!((amp / k_weighting(f) - 1.0).abs() < 2e-3, "{f} Hz: {amp} vs {}", k_weighting(f));
        }
    }

    #[test]
    fn faster_is_shorter_and_felt_stiffens_most() {
        let felt = MalletKind::Felt.mallet();
        let wood = MalletKind::Wood.mallet();
        let ratio = |m: &Mallet| m.contact_time_s(0.2, 1.0) / m.contact_time_s(2.0, 1.0);
        // T ∝ v^(−(p−1)/(p+1)): 10^(3/7) for felt, 10^(1/5) for Hertz.
        assert!((ratio(&felt) - 10f64.powf(3.0 / 7.0)).abs() < 1e-9);
        assert!((ratio(&wood) - 10f64.powf(0.2)).abs() < 1e-9);
        assert!(strike_speed(1.0) > strike_speed(0.5) && (strike_speed(0.0) - SLOWEST_STRIKE_M_PER_S).abs() < 1e-12);
        assert!((hardness_scale(0.5) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn noise_is_zero_mean_and_bounded() {
        let mut n = Noise::new(1);
        let mut sum = 0.0f64;
        for _ in 0..100_000 {
            let x = n.next_sample();
            assert!((-1.0..1.0).contains(&x));
            sum += f64::from(x);
        }
        assert!((sum / 100_000.0).abs() < 0.01);
    }
}
