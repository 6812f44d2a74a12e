//! The residual of a captured material (issue 15 part 2; Ren, Yeh & Lin 2013 §6.1): what one
//! impact of the recording held beyond the modes the material represents, as a log-power
//! spectrogram, with the recorded modes it belongs to (the source of a later transfer, §6.2).
//!
//! Compact on purpose (a material file stays a few tens of KB): one byte per cell, the level
//! in dB below the spectrogram's top in steps of [`STEP_DB`] (255 = [`FLOOR_STEPS`] steps or
//! more below: nothing), the cells base64-encoded frame by frame. At 48 kHz, 1024-sample frames
//! every 256 samples and the first [`SECONDS`] s, that is 66 × 513 cells: 33,858 bytes, 45 KB
//! of base64.

use crate::error::PresetError;
use base64::Engine as _;
use serde::{Deserialize, Serialize};

/// Level step of the stored cells, dB.
pub const STEP_DB: f64 = 0.5;
/// Cells at or below this many steps under the top are stored as empty (255).
pub const FLOOR_STEPS: u8 = 255;
/// Length of the impact a capture keeps, s.
pub const SECONDS: f64 = 0.35;
/// Most cells a residual may hold (a 10 s, 2049-bin spectrogram is far beyond it).
pub const MAX_CELLS: usize = 1 << 22;

/// One of the recorded modes the residual belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ResidualMode {
    /// Frequency, Hz.
    pub freq_hz: f64,
    /// Decay rate d, s⁻¹.
    pub decay_per_s: f64,
    /// Peak amplitude at the impact's start, full scale.
    pub amplitude: f64,
}

/// A residual power spectrogram as stored with a material.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ResidualSpectrogram {
    /// Sample rate of the recording, Hz.
    pub sample_rate: u32,
    /// Frame length (Hann), samples; bins = frame/2 + 1.
    pub frame: u32,
    /// Hop between frames, samples (the first frame is centred on the impact's start).
    pub hop: u32,
    /// Frames stored.
    pub frames: u32,
    /// The level of the strongest cell, dB (10·log10 of |X|²).
    pub top_db: f64,
    /// Each cell's level as steps of [`STEP_DB`] below `top_db` (255: nothing), frame-major,
    /// base64 (standard alphabet, padded).
    pub levels: String,
    /// The recorded modes of that impact (its features), strongest first.
    pub modes: Vec<ResidualMode>,
}

impl ResidualSpectrogram {
    /// Bins per frame.
    pub fn bins(&self) -> usize {
        self.frame as usize / 2 + 1
    }

    /// Stores `power` (|X|², frame-major, `frames` × `frame/2 + 1`), quantised.
    ///
    /// # Panics
    /// If `power`'s length is not `frames × (frame/2 + 1)`.
    pub fn from_power(
        power: &[f64],
        frames: usize,
        sample_rate: u32,
        frame: u32,
        hop: u32,
        modes: Vec<ResidualMode>,
    ) -> ResidualSpectrogram {
        let bins = frame as usize / 2 + 1;
        assert_eq!(power.len(), frames * bins, "spectrogram size");
        let top = power.iter().copied().filter(|p| p.is_finite()).fold(0.0f64, f64::max);
        let top_db = if top > 0.0 { 10.0 * top.log10() } else { -300.0 };
        let cells: Vec<u8> = power
            .iter()
            .map(|&p| {
                if !(p.is_finite() && p > 0.0) {
                    return FLOOR_STEPS;
                }
                let steps = ((top_db - 10.0 * p.log10()) / STEP_DB).round();
                if steps >= f64::from(FLOOR_STEPS) {
                    FLOOR_STEPS
                } else {
                    steps.max(0.0) as u8
                }
            })
            .collect();
        ResidualSpectrogram {
            sample_rate,
            frame,
            hop,
            frames: frames as u32,
            top_db,
            levels: base64::engine::general_purpose::STANDARD.encode(cells),
            modes,
        }
    }

    /// The power spectrogram back (|X|², frame-major; empty cells 0).
    ///
    /// # Errors
    /// As [`ResidualSpectrogram::validate`].
    pub fn to_power(&self) -> Result<Vec<f64>, PresetError> {
        let cells = self.cells()?;
        Ok(cells
            .iter()
            .map(|&b| if b == FLOOR_STEPS { 0.0 } else { 10f64.powf((self.top_db - STEP_DB * f64::from(b)) / 10.0) })
            .collect())
    }

    fn cells(&self) -> Result<Vec<u8>, PresetError> {
        let bad = |why: String| PresetError::invalid("residual.levels", why);
        if self.levels.len() > MAX_CELLS / 3 * 4 + 4 {
            return Err(bad(format!("{} characters, more than a residual may hold", self.levels.len())));
        }
        let cells = base64::engine::general_purpose::STANDARD
            .decode(&self.levels)
            .map_err(|e| bad(format!("not base64 ({e})")))?;
        let want = self.frames as usize * self.bins();
        if cells.len() != want {
            return Err(bad(format!(
                "{} cells, but frames × bins is {} × {} = {want}",
                cells.len(),
                self.frames,
                self.bins()
            )));
        }
        Ok(cells)
    }

    /// Checks every field.
    ///
    /// # Errors
    /// [`PresetError::Invalid`] naming the field: a sample rate outside 8–192 kHz, a frame
    /// that is not a power of two in 64..=8192, a hop outside 1..=frame, a non-finite top, more
    /// than [`MAX_CELLS`] cells, levels that do not decode to frames × bins cells, or a mode
    /// with a non-finite or negative value.
    pub fn validate(&self) -> Result<(), PresetError> {
        if !(8_000..=192_000).contains(&self.sample_rate) {
            return Err(PresetError::invalid(
                "residual.sample_rate",
                format!("must be 8000..=192000 Hz, found {}", self.sample_rate),
            ));
        }
        if !(self.frame.is_power_of_two() && (64..=8192).contains(&self.frame)) {
            return Err(PresetError::invalid(
                "residual.frame",
                format!("must be a power of two in 64..=8192, found {}", self.frame),
            ));
        }
        if !(1..=self.frame).contains(&self.hop) {
            return Err(PresetError::invalid(
                "residual.hop",
                format!("must be 1..={}, found {}", self.frame, self.hop),
            ));
        }
        if !self.top_db.is_finite() {
            return Err(PresetError::invalid(
                "residual.top_db",
                format!("must be finite, found {}", crate::Shown(self.top_db)),
            ));
        }
        if self.frames as usize * self.bins() > MAX_CELLS {
            return Err(PresetError::invalid(
                "residual.frames",
                format!("{} frames of {} bins are more than a residual may hold", self.frames, self.bins()),
            ));
        }
        self.cells()?;
        for (i, m) in self.modes.iter().enumerate() {
            let ok = [m.freq_hz, m.decay_per_s, m.amplitude].iter().all(|v| v.is_finite() && *v >= 0.0);
            if !ok {
                return Err(PresetError::invalid(
                    format!("residual.modes[{i}]"),
                    format!("freq_hz, decay_per_s and amplitude must be finite and >= 0, found {m:?}"),
                ));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A spectrogram survives storage to within a quarter of a step (0.25 dB) in every cell
    /// above the floor, cells under it come back empty, and the stored size is the closed
    /// form: ⌈cells/3⌉·4 base64 characters.
    #[test]
    fn stored_levels_round_trip_within_a_quarter_step() {
        let (frames, frame) = (7usize, 64u32);
        let bins = 33;
        let power: Vec<f64> = (0..frames * bins).map(|i| 10f64.powf(-(((i * 37) % 200) as f64) / 10.0)).collect();
        let r = ResidualSpectrogram::from_power(&power, frames, 48_000, frame, 16, vec![]);
        r.validate().unwrap();
        assert_eq!(r.levels.len(), (frames * bins).div_ceil(3) * 4);
        let back = r.to_power().unwrap();
        for (p, q) in power.iter().zip(&back) {
            let below = 10.0 * (power.iter().fold(0.0f64, |m, &x| m.max(x)) / p).log10();
            if below < STEP_DB * f64::from(FLOOR_STEPS) - 1.0 {
                assert!((10.0 * (q / p).log10()).abs() <= 0.25 + 1e-9, "{p} -> {q}");
            } else if below > STEP_DB * f64::from(FLOOR_STEPS) + 1.0 {
                assert_eq!(*q, 0.0);
            }
        }
    }

    /// Bad fields are refused with the field named.
    #[test]
    fn bad_residuals_are_refused_naming_the_field() {
        let good = ResidualSpectrogram::from_power(&[1.0; 2 * 33], 2, 48_000, 64, 16, vec![]);
        let cases: Vec<(ResidualSpectrogram, &str)> = vec![
            (ResidualSpectrogram { sample_rate: 4_000, ..good.clone() }, "residual.sample_rate"),
            (ResidualSpectrogram { frame: 100, ..good.clone() }, "residual.frame"),
            (ResidualSpectrogram { hop: 0, ..good.clone() }, "residual.hop"),
            (ResidualSpectrogram { top_db: f64::NAN, ..good.clone() }, "residual.top_db"),
            (ResidualSpectrogram { frames: 3, ..good.clone() }, "residual.levels"),
            (ResidualSpectrogram { levels: "*not base64*".into(), ..good.clone() }, "residual.levels"),
            (
                ResidualSpectrogram {
                    modes: vec![ResidualMode { freq_hz: f64::INFINITY, decay_per_s: 1.0, amplitude: 1.0 }],
                    ..good.clone()
                },
                "residual.modes[0]",
            ),
        ];
        for (r, field) in cases {
            let e = r.validate().unwrap_err().to_string();
            assert!(e.contains(field), "{field}: {e}");
        }
    }
}
