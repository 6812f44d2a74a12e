//! WAV input (hound): any PCM integer depth hound reads (8/16/24/32 bit) and 32-bit float,
//! any channel count, 8–192 kHz. Samples are scaled to ±1 full scale and mixed to mono
//! (mean of the channels) or one channel is picked.
//!
//! Memory bound: the file is streamed, only the mono result is kept, as `f32`, and it is cut
//! at [`MAX_SECONDS`] or [`MAX_SAMPLES`] (whichever comes first), so one file never takes more
//! than 4 × `MAX_SAMPLES` bytes = 256 MiB.

use std::fs::File;
use std::io::{self, Read as _};
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

/// A RIFF chunk's id and length from its 8-byte header.
fn chunk_header(h: [u8; 8]) -> ([u8; 4], u32) {
    ([h[0], h[1], h[2], h[3]], u32::from_le_bytes([h[4], h[5], h[6], h[7]]))
}

/// Longest `fmt ` chunk accepted (WAVE_FORMAT_EXTENSIBLE takes 40 bytes).
const MAX_FMT_LEN: u32 = 1024;

/// The stream [`open_wav`] hands to hound: a canonical header, then the file's `data` bytes.
type WavStream = io::Chain<io::Cursor<Vec<u8>>, io::Take<io::BufReader<File>>>;

/// Opens a WAV file for hound by walking its RIFF chunks itself.
///
/// hound 3.5 skips an unknown chunk by its length only, but RIFF pads every odd-sized chunk
/// with one byte (Microsoft's RIFF spec; e.g. an odd-length `LIST`/`INFO` chunk), so such a
/// file would be misread. Here every chunk before `data` is skipped with its pad byte, and
/// hound is given a minimal header (`RIFF`, `WAVE`, the file's own `fmt ` chunk, `data`)
/// followed by the file's data bytes, so hound still checks the format and decodes.
fn open_wav(path: &Path) -> Result<hound::WavReader<WavStream>, String> {
    let file = File::open(path).map_err(|e| e.to_string())?;
    let mut r = io::BufReader::new(file);
    let mut head = [0u8; 12];
    r.read_exact(&mut head).map_err(|_| "the file is shorter than a WAV header".to_string())?;
    if &head[0..4] != b"RIFF" || &head[8..12] != b"WAVE" {
        return Err("no RIFF/WAVE header: not a WAV file".into());
    }
    let mut fmt: Option<Vec<u8>> = None;
    let data_len = loop {
        let mut h = [0u8; 8];
        if r.read_exact(&mut h).is_err() {
            return Err(if fmt.is_none() { "no fmt chunk" } else { "no data chunk" }.into());
        }
        let (id, len) = chunk_header(h);
        match &id {
            b"fmt " => {
                if len > MAX_FMT_LEN {
                    return Err(format!("fmt chunk of {len} bytes is too long"));
                }
                let mut body = vec![0u8; len as usize];
                r.read_exact(&mut body).map_err(|_| "the fmt chunk is cut short".to_string())?;
                if len % 2 == 1 {
                    r.seek_relative(1).map_err(|e| e.to_string())?;
                }
                fmt = Some(body);
            }
            b"data" => {
                if fmt.is_none() {
                    return Err("the data chunk comes before the fmt chunk".into());
                }
                break len;
            }
            // Any other chunk (LIST, fact, bext, cue, …): skip it and its pad byte.
            _ => r.seek_relative(i64::from(len) + i64::from(len % 2)).map_err(|e| e.to_string())?,
        }
    };
    let fmt = fmt.unwrap_or_default();
    let fmt_len = u32::try_from(fmt.len()).unwrap_or(MAX_FMT_LEN);
    let mut header = Vec::with_capacity(28 + fmt.len());
    header.extend_from_slice(b"RIFF");
    header.extend_from_slice(&(4 + 8 + fmt_len).saturating_add(8).saturating_add(data_len).to_le_bytes());
    header.extend_from_slice(b"WAVE");
    header.extend_from_slice(b"fmt ");
    header.extend_from_slice(&fmt_len.to_le_bytes());
    header.extend_from_slice(&fmt);
    header.extend_from_slice(b"data");
    header.extend_from_slice(&data_len.to_le_bytes());
    let stream = io::Cursor::new(header).chain(r.take(u64::from(data_len)));
    hound::WavReader::new(stream).map_err(|e| e.to_string())
}

/// Reads a WAV file into a mono [`Recording`]; `channel` picks one channel (0-based), `None`
/// averages all channels.
///
/// # Errors
/// [`EstimateError::Wav`] if the file cannot be opened or decoded (corrupt, truncated header,
/// unsupported format), [`EstimateError::NonFinite`] naming the first NaN or infinite sample
/// of a float file, [`EstimateError::SampleRate`] outside 8–192 kHz,
/// [`EstimateError::NoSuchChannel`], [`EstimateError::Silent`] if it has no samples or only
/// zeros. Clipping, DC offset, very low level and truncation only add warnings.
pub fn load_wav(path: &Path, channel: Option<usize>) -> Result<Recording, EstimateError> {
    read_wav(path, channel, true)
}

/// As [`load_wav`], for playing rather than analysing: the samples exactly as in the file (no
/// DC offset removed, no level warnings), and a silent file is not an error (`struck render
/// --input`).
///
/// # Errors
/// As [`load_wav`], except [`EstimateError::Silent`].
pub fn load_wav_exact(path: &Path, channel: Option<usize>) -> Result<Recording, EstimateError> {
    read_wav(path, channel, false)
}

fn read_wav(path: &Path, channel: Option<usize>, analysis: bool) -> Result<Recording, EstimateError> {
    let wav_err = |reason: String| EstimateError::Wav { path: path.to_path_buf(), reason };
    let reader = open_wav(path).map_err(wav_err)?;
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
            for (k, s) in r.samples::<f32>().enumerate() {
                match s {
                    Ok(v) if !v.is_finite() => {
                        let frame = k / channels;
                        return Err(EstimateError::NonFinite {
                            path: path.to_path_buf(),
                            frame,
                            channel: k % channels,
                            seconds: frame as f64 / f64::from(spec.sample_rate),
                            value: v,
                        });
                    }
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
    if mono.is_empty() || (analysis && mono.iter().all(|&v| v == 0.0)) {
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
    if analysis && mean.abs() > 0.01 {
        warnings.push(format!(
            "{}: DC offset {:.3} of full scale was removed; check the microphone/interface",
            path.display(),
            mean
        ));
    }
    if analysis && peak < 0.01 {
        warnings.push(format!(
            "{}: very low level (peak {:.1} dBFS); raise the gain or move the microphone closer",
            path.display(),
            20.0 * peak.log10()
        ));
    }
    // Remove the DC offset: a constant would otherwise show up as a zero-frequency "mode".
    if analysis && mean != 0.0 {
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A 16-bit PCM WAV with `chunks` between `fmt ` and `data`, each padded to even size.
    fn pcm16(rate: u32, chunks: &[(&[u8; 4], &[u8])], samples: &[i16]) -> Vec<u8> {
        let mut body = b"WAVE".to_vec();
        let mut chunk = |id: &[u8; 4], payload: &[u8]| {
            body.extend_from_slice(id);
            body.extend((payload.len() as u32).to_le_bytes());
            body.extend_from_slice(payload);
            if payload.len() % 2 == 1 {
                body.push(0);
            }
        };
        let mut fmt = vec![1, 0, 1, 0];
        fmt.extend(rate.to_le_bytes());
        fmt.extend((2 * rate).to_le_bytes());
        fmt.extend([2, 0, 16, 0]);
        chunk(b"fmt ", &fmt);
        for (id, payload) in chunks {
            chunk(id, payload);
        }
        chunk(b"data", &samples.iter().flat_map(|s| s.to_le_bytes()).collect::<Vec<u8>>());
        let mut f = b"RIFF".to_vec();
        f.extend((body.len() as u32).to_le_bytes());
        f.extend(body);
        f
    }

    fn scratch(name: &str, bytes: &[u8]) -> PathBuf {
        let p = std::env::temp_dir().join(format!("struck-wav-{}-{name}.wav", std::process::id()));
        std::fs::write(&p, bytes).unwrap();
        p
    }

    #[test]
    fn odd_sized_chunks_are_skipped_with_their_pad_byte() {
        let samples: Vec<i16> = (0..4800).map(|i| ((i * 37 % 2000) as i16 - 1000) * 8).collect();
        let plain = scratch("plain", &pcm16(48_000, &[], &samples));
        // Odd-sized LIST and `fact` chunks (the pad byte after each is not counted in its size).
        let chunks: [(&[u8; 4], &[u8]); 2] =
            [(b"LIST", b"INFOINAM\x05\x00\x00\x00bell"), (b"fact", b"\x40\x12\x00\x00\x07")];
        let odd = scratch("odd", &pcm16(48_000, &chunks, &samples));
        let a = load_wav(&plain, None).unwrap();
        let b = load_wav(&odd, None).unwrap();
        assert_eq!(b.samples.len(), 4800);
        assert_eq!(a.samples, b.samples);
        let mean = samples.iter().map(|&s| f64::from(s)).sum::<f64>() / 4800.0 / 32768.0;
        assert!((f64::from(b.samples[10]) - (f64::from(samples[10]) / 32768.0 - mean)).abs() < 1e-6);
        let _ = std::fs::remove_file(plain);
        let _ = std::fs::remove_file(odd);
    }

    #[test]
    fn broken_layouts_are_wav_errors() {
        let samples = [100i16; 64];
        let good = pcm16(48_000, &[], &samples);
        // `data` before `fmt `, a missing data chunk, a foreign RIFF type.
        let mut data_first = b"RIFF\x00\x00\x00\x00WAVEdata\x02\x00\x00\x00\x01\x00".to_vec();
        data_first.extend_from_slice(&good[12..]);
        let no_data = good[..12 + 8 + 16].to_vec();
        let mut avi = good.clone();
        avi[8..12].copy_from_slice(b"AVI ");
        for (name, bytes, says) in [
            ("data-first", data_first, "before the fmt chunk"),
            ("no-data", no_data, "no data chunk"),
            ("avi", avi, "not a WAV file"),
            ("short", b"RIFF".to_vec(), "shorter than a WAV header"),
        ] {
            let p = scratch(name, &bytes);
            match load_wav(&p, None) {
                Err(EstimateError::Wav { reason, .. }) => assert!(reason.contains(says), "{name}: {reason}"),
                other => panic!("{name}: {other:?}"),
            }
            let _ = std::fs::remove_file(p);
        }
    }
}
