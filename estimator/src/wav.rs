//! WAV input (hound): any PCM integer depth hound reads (8/16/24/32 bit) and 32-bit float,
//! any channel count, 8–192 kHz. Samples are scaled to ±1 full scale and mixed to mono
//! (mean of the channels) or one channel is picked.
//!
//! Memory bound: the file is streamed, only the mono result is kept, as `f32`, and it is cut
//! at [`MAX_SECONDS`] or [`MAX_SAMPLES`] (whichever comes first), so one file never takes more
//! than 4 × `MAX_SAMPLES` bytes = 256 MiB.

use std::path::{Path, PathBuf};

use crate::EstimateError;

/// Longest recording read, in seconds (15 minutes). Longer files are truncated with a warning.
pub const MAX_SECONDS: f64 = 900.0;
/// Most mono samples kept per file (64 Mi samples, 256 MiB of `f32`; 5.8 min at 192 kHz).
pub const MAX_SAMPLES: usize = 64 << 20;
/// Lowest supported sample rate, Hz.
pub const MIN_RATE: u32 = 8_000;
/// Highest supported sample rate, Hz.
pub const MAX_RATE: u32 = 192_000;

/// A decoded mono recording.
#[derive(Clone, Debug)]
pub struct Recording {
    /// Where it came from.
    pub path: PathBuf,
    /// Mono samples, full scale ±1.
    pub samples: Vec<f32>,
    /// Sample rate in Hz.
    pub sample_rate: u32,
    /// Channels in the file.
    pub channels: u16,
    /// Bits per sample in the file.
    pub bits_per_sample: u16,
    /// Problems that did not stop the analysis (clipping, DC offset, low level, truncation).
    pub warnings: Vec<String>,
}

impl Recording {
    /// Duration in seconds.
    pub fn duration_s(&self) -> f64 {
        self.samples.len() as f64 / f64::from(self.sample_rate)
    }
}

/// Reads a WAV file into a mono [`Recording`]; `channel` picks one channel (0-based), `None`
/// averages all channels.
///
/// # Errors
/// [`EstimateError::Wav`] if the file cannot be opened or decoded (corrupt, truncated header,
/// unsupported format), [`EstimateError::SampleRate`] outside 8–192 kHz,
/// [`EstimateError::NoSuchChannel`], [`EstimateError::Silent`] if it has no samples or only
/// zeros. Clipping, DC offset, very low level and truncation only add warnings.
pub fn load_wav(path: &Path, channel: Option<usize>) -> Result<Recording, EstimateError> {
    let wav_err = |reason: String| EstimateError::Wav { path: path.to_path_buf(), reason };
    let reader = hound::WavReader::open(path).map_err(|e| wav_err(e.to_string()))?;
    let spec = reader.spec();
    if !(MIN_RATE..=MAX_RATE).contains(&spec.sample_rate) {
        return Err(EstimateError::SampleRate { path: path.to_path_buf(), sample_rate: spec.sample_rate });
    }
    let channels = usize::from(spec.channels.max(1));
    if let Some(ch) = channel {
        if ch >= channels {
            return Err(EstimateError::NoSuchChannel { path: path.to_path_buf(), channel: ch, channels });
        }
    }
    let max_frames = ((MAX_SECONDS * f64::from(spec.sample_rate)) as usize).min(MAX_SAMPLES);
    let total_frames = reader.duration() as usize;
    let mut warnings = Vec::new();
    if total_frames > max_frames {
        warnings.push(format!(
            "{}: only the first {:.0} s of {:.0} s were analysed (length limit); split long sessions into several files",
            path.display(),
            max_frames as f64 / f64::from(spec.sample_rate),
            total_frames as f64 / f64::from(spec.sample_rate)
        ));
    }
    let mut mono = Vec::with_capacity(total_frames.min(max_frames));
    let mut acc = 0.0f64;
    let mut idx = 0usize;
    let mut clipped = 0usize;
    let mut seen = 0usize;
    let mut push = |v: f64, mono: &mut Vec<f32>| -> bool {
        if v.abs() >= 0.999 {
            clipped += 1;
        }
        seen += 1;
        let ch = idx % channels;
        idx += 1;
        match channel {
            Some(c) if c == ch => mono.push(v as f32),
            Some(_) => {}
            None => {
                acc += v;
                if ch + 1 == channels {
                    mono.push((acc / channels as f64) as f32);
                    acc = 0.0;
                }
            }
        }
        mono.len() < max_frames || ch + 1 != channels
    };
    let mut decode_error = None;
    match spec.sample_format {
        hound::SampleFormat::Float => {
            let mut r = reader;
            for s in r.samples::<f32>() {
                match s {
                    Ok(v) => {
                        if !push(f64::from(v), &mut mono) {
                            break;
                        }
                    }
                    Err(e) => {
                        decode_error = Some(e.to_string());
                        break;
                    }
                }
            }
        }
        hound::SampleFormat::Int => {
            let scale = 1.0 / f64::from(1u32 << (spec.bits_per_sample.clamp(8, 32) - 1)).max(1.0);
            let scale = if spec.bits_per_sample >= 32 { 1.0 / 2_147_483_648.0 } else { scale };
            let mut r = reader;
            for s in r.samples::<i32>() {
                match s {
                    Ok(v) => {
                        if !push(f64::from(v) * scale, &mut mono) {
                            break;
                        }
                    }
                    Err(e) => {
                        decode_error = Some(e.to_string());
                        break;
                    }
                }
            }
        }
    }
    if let Some(reason) = decode_error {
        if mono.is_empty() {
            return Err(wav_err(reason));
        }
        warnings.push(format!(
            "{}: the data ends early ({reason}); {} samples were read, the file may be truncated",
            path.display(),
            mono.len()
        ));
    }
    if mono.is_empty() || mono.iter().all(|&v| v == 0.0) {
        return Err(EstimateError::Silent { path: path.to_path_buf() });
    }
    let n = mono.len() as f64;
    let mean = mono.iter().map(|&v| f64::from(v)).sum::<f64>() / n;
    let peak = mono.iter().fold(0.0f64, |m, &v| m.max(f64::from(v).abs()));
    let clip_fraction = clipped as f64 / seen.max(1) as f64;
    if clipped >= 3 {
        warnings.push(format!(
            "{}: {} samples ({:.3} %) are at full scale (clipping); lower the recording gain, clipped taps bias the damping",
            path.display(),
            clipped,
            100.0 * clip_fraction
        ));
    }
    if mean.abs() > 0.01 {
        warnings.push(format!(
            "{}: DC offset {:.3} of full scale was removed; check the microphone/interface",
            path.display(),
            mean
        ));
    }
    if peak < 0.01 {
        warnings.push(format!(
            "{}: very low level (peak {:.1} dBFS); raise the gain or move the microphone closer",
            path.display(),
            20.0 * peak.log10()
        ));
    }
    // Remove the DC offset: a constant would otherwise show up as a zero-frequency "mode".
    if mean != 0.0 {
        for v in &mut mono {
            *v = (f64::from(*v) - mean) as f32;
        }
    }
    Ok(Recording {
        path: path.to_path_buf(),
        samples: mono,
        sample_rate: spec.sample_rate,
        channels: spec.channels,
        bits_per_sample: spec.bits_per_sample,
        warnings,
    })
}
