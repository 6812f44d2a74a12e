//! The residual layer (issue 15 part 4; Ren, Yeh & Lin 2013 §6): each strike plays the
//! residual transferred to the current object (a clip made off the audio thread, see the
//! estimator's `transfer`), with the modes and from the same sample.
//!
//! Per strike:
//! - **level** by velocity as the modes' ([`crate::exciter::velocity_gain`]): the clip is
//!   made for a strike of velocity 1;
//! - **brightness** of the mallet at that velocity: the clip holds the force spectrum of a
//!   velocity-1 strike (contact time T₁); a softer strike's longer contact Tᵥ takes off
//!   highs by the ratio of the two force spectra. Each pulse spectrum is taken
//!   as 1/(1 + (f/f_c)²) with f_c = 0.8/T (the pulse's −6 dB point: fT = 0.82 for the
//!   symmetric half-sine, 0.83–0.90 for the mallets' skewed pulses), so the ratio
//!   is (1 + (f/f₁)²)/(1 + (f/fᵥ)²): two first-order pole–zero sections (bilinear, with
//!   pre-warping), unity at DC;
//! - **pitch** with the key: the clip is made at one key's tuning (`lambda_factor`); a note
//!   on another key reads it faster or slower by the frequency ratio √(λ-factor ratio),
//!   which moves the residual's spectrum with the modes' (and its time by the inverse).
//!
//! Realtime-safe: players are a fixed array; a strike takes a free one or the one furthest
//! through its clip.

/// Residuals sounding at once.
pub const PLAYERS: usize = 16;

/// A transferred residual as the engine plays it.
#[derive(Clone, Debug, PartialEq)]
pub struct ResidualClip {
    /// Samples at the engine's rate, for a strike of velocity 1.
    pub samples: Vec<f32>,
    /// The λ factor of the strike it was made for (its key's tuning).
    pub lambda_factor: f64,
}

/// First-order pole–zero section y = b0·x + b1·x₁ − a1·y₁.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Section {
    b0: f32,
    b1: f32,
    a1: f32,
    x1: f32,
    y1: f32,
}

impl Section {
    /// (1 + s/ω_z)/(1 + s/ω_p) by the bilinear transform at `fs`, each corner pre-warped.
    fn shelf(zero_hz: f64, pole_hz: f64, fs: f64) -> Section {
        let k = 2.0 * fs;
        let warp = |f: f64| k * (std::f64::consts::PI * f.min(0.45 * fs) / fs).tan();
        let (wz, wp) = (warp(zero_hz), warp(pole_hz));
        let a0 = 1.0 + k / wp;
        Section {
            b0: ((1.0 + k / wz) / a0) as f32,
            b1: ((1.0 - k / wz) / a0) as f32,
            a1: ((1.0 - k / wp) / a0) as f32,
            x1: 0.0,
            y1: 0.0,
        }
    }

    #[inline]
    fn run(&mut self, x: f32) -> f32 {
        let y = self.b0 * x + self.b1 * self.x1 - self.a1 * self.y1;
        self.x1 = x;
        // Flushed to zero well above the denormal range.
        self.y1 = if y.abs() < 1e-20 { 0.0 } else { y };
        y
    }
}

/// One strike's residual.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Player {
    active: bool,
    /// Read position in the clip, samples, and its step per output sample.
    pos: f64,
    rate: f64,
    gain: f32,
    sections: [Section; 2],
}

/// The residual players of an engine.
#[derive(Clone, Debug, Default)]
pub struct Residuals {
    players: [Player; PLAYERS],
}

/// The corner of a force pulse's spectrum taken as 1/(1 + (f/f_c)²), × 1/T.
pub const CORNER_TIMES_CONTACT: f64 = 0.8;

impl Residuals {
    /// Starts a strike's residual: `gain` (velocity and level), `rate` (frequency ratio of
    /// its key to the clip's), and the mallet's contact times of this strike and of the
    /// velocity-1 strike the clip holds. Realtime-safe.
    pub fn start(&mut self, gain: f32, rate: f64, contact_s: f64, contact_ref_s: f64, fs: f64) {
        if !(gain.is_finite() && gain > 0.0 && rate.is_finite() && rate > 0.0) {
            return;
        }
        let slot = match self.players.iter().position(|p| !p.active) {
            Some(i) => i,
            None => {
                let mut oldest = 0;
                for (i, p) in self.players.iter().enumerate() {
                    if p.pos > self.players[oldest].pos {
                        oldest = i;
                    }
                }
                oldest
            }
        };
        let corner = |t: f64| CORNER_TIMES_CONTACT / t.max(1e-7);
        let (f1, fv) = (corner(contact_ref_s), corner(contact_s.max(contact_ref_s)));
        let s = Section::shelf(f1, fv, fs);
        self.players[slot] = Player { active: true, pos: 0.0, rate, gain, sections: [s, s] };
    }

    /// Silences every residual. Realtime-safe.
    pub fn clear(&mut self) {
        for p in &mut self.players {
            p.active = false;
        }
    }

    /// Whether a residual sounds.
    pub fn any(&self) -> bool {
        self.players.iter().any(|p| p.active)
    }

    /// Samples until every residual has ended (the longest left, read at its rate).
    pub fn samples_left(&self, clip: Option<&ResidualClip>) -> u32 {
        let Some(c) = clip else { return 0 };
        self.players
            .iter()
            .filter(|p| p.active)
            .map(|p| ((c.samples.len() as f64 - p.pos).max(0.0) / p.rate).ceil() as u32)
            .max()
            .unwrap_or(0)
    }

    /// Adds every sounding residual into `out`, read from `clip` (`None`: they end).
    /// Realtime-safe.
    pub fn render(&mut self, clip: Option<&ResidualClip>, out: &mut [f32]) {
        let Some(clip) = clip else {
            self.clear();
            return;
        };
        let x = &clip.samples;
        let last = x.len().saturating_sub(1) as f64;
        for p in self.players.iter_mut().filter(|p| p.active) {
            for o in out.iter_mut() {
                if p.pos >= last {
                    p.active = false;
                    break;
                }
                let i = p.pos as usize;
                let frac = (p.pos - i as f64) as f32;
                let v = x[i] + frac * (x[i + 1] - x[i]);
                let u = p.sections[0].run(v);
                let y = p.sections[1].run(u);
                *o += p.gain * y;
                p.pos += p.rate;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One shelf section: unity at DC, and the analog magnitude |(1 + jf/f_z)/(1 + jf/f_p)| at
    /// 500 Hz.
    #[test]
    fn the_shelf_has_its_analog_response() {
        let fs = 48_000.0;
        let (fz, fp) = (4_000.0, 1_000.0);
        let mut s = Section::shelf(fz, fp, fs);
        // DC: a step settles at 1.
        let mut y = 0.0;
        for _ in 0..20_000 {
            y = s.run(1.0);
        }
        assert!((y - 1.0).abs() < 1e-4, "{y}");
        // 500 Hz: |(1 + j f/fz)/(1 + j f/fp)| (pre-warping keeps it within 0.1 % here).
        let f = 500.0;
        let mut s = Section::shelf(fz, fp, fs);
        let mut peak = 0.0f32;
        for n in 0..96_000 {
            let v = s.run((std::f64::consts::TAU * f * f64::from(n) / fs).sin() as f32);
            if n > 48_000 {
                peak = peak.max(v.abs());
            }
        }
        let want = ((1.0 + (f / fz).powi(2)) / (1.0 + (f / fp).powi(2))).sqrt();
        assert!((f64::from(peak) / want - 1.0).abs() < 2e-3, "{peak} vs {want}");
    }

    /// A clip read at rate 1 with equal contact times comes back sample for sample × gain.
    #[test]
    fn a_velocity_one_strike_plays_the_clip_as_made() {
        let clip = ResidualClip { samples: (0..100).map(|i| (i as f32 * 0.37).sin()).collect(), lambda_factor: 1.0 };
        let mut r = Residuals::default();
        r.start(0.5, 1.0, 1e-3, 1e-3, 48_000.0);
        let mut out = vec![0.0; 120];
        r.render(Some(&clip), &mut out[..50]);
        r.render(Some(&clip), &mut out[50..]);
        for i in 0..99 {
            assert!((out[i] - 0.5 * clip.samples[i]).abs() < 1e-5, "{i}");
        }
        assert!(out[100..].iter().all(|&v| v == 0.0));
        assert!(!r.any());
    }
}
