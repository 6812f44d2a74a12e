//! WAV input: PCM integers of 8–32 bits (in 1–4 byte containers, WAVE_FORMAT_EXTENSIBLE's
//! left-justified valid bits included) and 32- or 64-bit float, any channel count, 8–192 kHz. Samples are scaled to ±1 full scale and mixed to mono
//! (mean of the channels) or one channel is picked.
//!
//! Memory bound: the file is streamed, only the mono result is kept, as `f32`, and it is cut
//! at [`MAX_SECONDS`] or [`MAX_SAMPLES`] (whichever comes first), so one file never takes more
//! than 4 × `MAX_SAMPLES` bytes = 768 MiB (files are read one at a time).

use std::fs::File;
use std::io::{self, BufRead as _, Read as _};
use std::path::{Path, PathBuf};

use crate::{EstimateError, Silence};

/// The step between integer sample values of `bits` bits, full scale ±1: 2^(1−bits).
pub fn quantisation_step(bits: u16) -> f64 {
    2f64.powi(1 - i32::from(bits.clamp(1, 64)))
}

/// Longest recording read, in seconds (one hour: a session of taps recorded in one take; issue
/// 10 names a 30-minute one, which the 15 minutes before stop 56 cut in half). Longer files are
/// truncated with a warning.
pub const MAX_SECONDS: f64 = 3600.0;
/// Most mono samples kept per file (192 Mi samples, 768 MiB of `f32`: an hour at 48 kHz,
/// 35 min at 96 kHz, 17.5 min at 192 kHz).
pub const MAX_SAMPLES: usize = 192 << 20;
/// Lowest supported sample rate, Hz.
pub const MIN_RATE: u32 = 8_000;
/// Highest supported sample rate, Hz.
pub const MAX_RATE: u32 = 192_000;

/// A decoded mono recording.
#[derive(Clone, Debug)]
pub struct Recording {
    /// Where it came from.
    pub path: PathBuf,
    /// Mono samples, full scale ±1: the whole file, or the window of [`load_wav_window`].
    pub samples: Vec<f32>,
    /// The file's frame that `samples` starts at (0 unless read through a window).
    pub start_frame: usize,
    /// Sample rate in Hz.
    pub sample_rate: u32,
    /// Channels in the file.
    pub channels: u16,
    /// Bits per sample in the file.
    pub bits_per_sample: u16,
    /// Problems that did not stop the analysis (clipping, DC offset, low level, truncation).
    pub warnings: Vec<String>,
    /// Stretches of frames `[from, to)` where a channel in use was at full scale, in time
    /// order: a value held at ±0.999 or over (the run's first sample and those that held
    /// it), or a single sample at the format's largest value (±1 for float; the largest
    /// code for integers). One such sample is a normalised file's peak; two or more in one
    /// impact are its peaks cut off (`segment::clear_of_clipping`). Also the samples at a
    /// level a channel in use is held flat at below full scale (a limiter; `HeldPeak`).
    /// Ascending and apart; frames of the file (a window's too). Empty when the float samples
    /// are not scaled to ±1 (wrong units).
    pub clipped: Vec<(usize, usize)>,
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

/// The sample layout of a WAV file's `fmt ` chunk.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Format {
    /// IEEE float samples (else two's-complement integers; 8-bit ones unsigned).
    float: bool,
    channels: u16,
    sample_rate: u32,
    /// Bytes a sample takes in the file (its container).
    bytes: usize,
    /// Bits of each sample that carry signal (left-justified in the container).
    valid_bits: u16,
}

/// Names of the WAVE format tags Struck meets but cannot decode.
fn format_name(tag: u16) -> String {
    match tag {
        0x0002 => "Microsoft ADPCM".into(),
        0x0006 => "A-law".into(),
        0x0007 => "µ-law".into(),
        0x0011 => "IMA ADPCM".into(),
        0x0050 | 0x0055 => "MPEG audio".into(),
        _ => format!("format 0x{tag:04x}"),
    }
}

/// Reads the `fmt ` chunk: PCM (tag 1), IEEE float (3) and WAVE_FORMAT_EXTENSIBLE (0xFFFE)
/// with either as its sub-format; integers of 8–32 bits in containers of 1–4 bytes (valid bits
/// under the container are left-justified, as Microsoft's spec has them, so the container sets
/// the full scale), floats of 32 or 64 bits.
fn parse_fmt(fmt: &[u8]) -> Result<Format, String> {
    if fmt.len() < 16 {
        return Err(format!("the fmt chunk has {} bytes, fewer than the 16 of any WAV", fmt.len()));
    }
    let u16_at = |i: usize| u16::from_le_bytes([fmt[i], fmt[i + 1]]);
    let mut tag = u16_at(0);
    let channels = u16_at(2);
    let sample_rate = u32::from_le_bytes([fmt[4], fmt[5], fmt[6], fmt[7]]);
    let block_align = usize::from(u16_at(12));
    let bits = u16_at(14);
    let mut valid_bits = bits;
    let extensible = tag == 0xFFFE;
    if extensible {
        if fmt.len() < 40 {
            return Err("the extensible fmt chunk is cut short".into());
        }
        // A valid-bits field of 0 (or over the container) is a writer's slip: the container counts.
        let v = u16_at(18);
        if v > 0 && v <= bits {
            valid_bits = v;
        }
        // The sub-format GUID's first two bytes are the plain format tag.
        tag = u16_at(24);
    }
    let float = match tag {
        1 => false,
        3 => true,
        t => return Err(format!("{}-encoded samples are not supported", format_name(t))),
    };
    if channels == 0 {
        return Err("the file declares 0 channels".into());
    }
    if bits == 0 {
        return Err("the file declares 0 bits per sample".into());
    }
    let bytes = usize::from(bits).div_ceil(8);
    let ch = usize::from(channels);
    // Some writers pad every sample to a wider container than its bits need (24 bits in 4
    // bytes): block_align says. Anything else that disagrees would be decoded as noise.
    let bytes = if block_align == ch * bytes {
        bytes
    } else if block_align % ch == 0 && (extensible || (bits == 24 && block_align == 4 * ch)) && block_align > ch * bytes
    {
        block_align / ch
    } else {
        return Err(format!(
            "its block size ({block_align} bytes) does not fit {channels} channel(s) of {bits}-bit samples"
        ));
    };
    match (float, bytes) {
        (false, 1..=4) | (true, 4) | (true, 8) => {}
        (false, _) => return Err(format!("{}-bit integer samples are not supported", 8 * bytes)),
        (true, _) => return Err(format!("{}-bit float samples are not supported (32 or 64 are)", 8 * bytes)),
    }
    Ok(Format { float, channels, sample_rate, bytes, valid_bits: valid_bits.min(8 * bytes as u16) })
}

impl Format {
    /// One sample from its `bytes` little-endian bytes, integers scaled so that the
    /// container's full scale is ±1.
    fn decode(&self, b: &[u8]) -> f64 {
        match (self.float, self.bytes) {
            (true, 4) => f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            (true, _) => f64::from_le_bytes([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]]),
            (false, 1) => (f64::from(b[0]) - 128.0) / 128.0,
            (false, 2) => f64::from(i16::from_le_bytes([b[0], b[1]])) / 32_768.0,
            (false, 3) => f64::from(i32::from_le_bytes([0, b[0], b[1], b[2]])) / 2_147_483_648.0,
            (false, _) => f64::from(i32::from_le_bytes([b[0], b[1], b[2], b[3]])) / 2_147_483_648.0,
        }
    }
}

/// Whether a data chunk's size is one a writer leaves when it never goes back to set it (a
/// stream or a recording still in progress): 0, or within 64 KiB of 4 GiB (0xFFFFFFFF,
/// 0xFFFFFFFC, … as streaming writers put there). The samples then run to the end of the file.
fn unset_data_len(len: u32) -> bool {
    len == 0 || len >= 0xFFFF_0000
}

/// An open WAV file positioned at its samples.
struct WavData {
    format: Format,
    reader: io::BufReader<File>,
    /// Bytes of samples to read (`None`: to the end of the input, whose size is not known).
    len: Option<u64>,
    /// Bytes the data chunk declares (`None`: unset, read to the end of the file).
    declared: Option<u64>,
    /// An RF64/BW64 file whose data size is in no `ds64` chunk (none before the samples).
    rf64_unsized: bool,
}

/// Opens a WAV file and walks its RIFF chunks to the samples: every chunk before `data`
/// (LIST, fact, bext, cue, …) is skipped with its pad byte (RIFF pads every odd-sized chunk,
/// Microsoft's RIFF spec), the `fmt ` chunk is read, and a data size that was never set or that
/// runs past the end of the file stops at the end of the file.
fn open_wav(path: &Path) -> Result<WavData, EstimateError> {
    let wav_err = |reason: String| EstimateError::Wav { path: path.to_path_buf(), reason };
    let open_err = |e: io::Error| EstimateError::Open { path: path.to_path_buf(), reason: e.to_string() };
    let meta = std::fs::metadata(path).map_err(open_err)?;
    if meta.is_dir() {
        return Err(EstimateError::Open { path: path.to_path_buf(), reason: "it is a folder, not a file".into() });
    }
    let file = File::open(path).map_err(open_err)?;
    // A pipe (`<(cat a.wav)`, /dev/stdin) has no size: it is read to its end.
    let size = meta.is_file().then_some(meta.len());
    let mut r = io::BufReader::new(file);
    let mut head = [0u8; 12];
    r.read_exact(&mut head).map_err(|_| wav_err("the file is shorter than a WAV header".into()))?;
    // RF64 and BW64 (EBU Tech 3306, ITU-R BS.2088): a WAV over 4 GiB, as field recorders and
    // DAWs write long takes; its sizes are in a `ds64` chunk, the 32-bit ones set to 0xFFFFFFFF.
    let rf64 = matches!(&head[0..4], b"RF64" | b"BW64") && &head[8..12] == b"WAVE";
    if !rf64 && (&head[0..4] != b"RIFF" || &head[8..12] != b"WAVE") {
        return Err(wav_err(if &head[0..4] == b"RIFX" {
            "big-endian (RIFX) WAV files are not supported".into()
        } else {
            "no RIFF/WAVE header: not a WAV file".into()
        }));
    }
    let mut pos = 12u64;
    let mut fmt: Option<Vec<u8>> = None;
    // The data size of an RF64 file's `ds64` chunk.
    let mut ds64_data: Option<u64> = None;
    let rf64_unsized;
    let data_len = loop {
        let mut h = [0u8; 8];
        if r.read_exact(&mut h).is_err() {
            return Err(wav_err(if fmt.is_none() { "no fmt chunk" } else { "no data chunk" }.into()));
        }
        pos += 8;
        let (id, len) = chunk_header(h);
        match &id {
            b"fmt " => {
                if len > MAX_FMT_LEN {
                    return Err(wav_err(format!("fmt chunk of {len} bytes is too long")));
                }
                let mut body = vec![0u8; len as usize];
                r.read_exact(&mut body).map_err(|_| wav_err("the fmt chunk is cut short".into()))?;
                pos += u64::from(len);
                fmt = Some(body);
                if len % 2 == 1 {
                    skip_pad(&mut r, &mut pos);
                }
            }
            b"ds64" if rf64 => {
                // riffSize, dataSize, sampleCount (u64 each), then a table of other chunks'
                // sizes (12 bytes an entry) this reader needs not: read past it.
                if len < 24 {
                    return Err(wav_err(format!("ds64 chunk of {len} bytes (an RF64 file's sizes need 24)")));
                }
                let mut body = [0u8; 24];
                r.read_exact(&mut body).map_err(|_| wav_err("the ds64 chunk is cut short".into()))?;
                let rest = u64::from(len) - 24;
                let skipped =
                    io::copy(&mut (&mut r).take(rest), &mut io::sink()).map_err(|e| wav_err(e.to_string()))?;
                if skipped < rest {
                    return Err(wav_err("the ds64 chunk is cut short".into()));
                }
                pos += u64::from(len);
                let mut size = [0u8; 8];
                size.copy_from_slice(&body[8..16]);
                ds64_data = Some(u64::from_le_bytes(size));
                if len % 2 == 1 {
                    skip_pad(&mut r, &mut pos);
                }
            }
            b"data" => {
                if fmt.is_none() {
                    return Err(wav_err("the data chunk comes before the fmt chunk".into()));
                }
                // An RF64 data chunk's size is in its ds64 chunk.
                rf64_unsized = rf64 && len == u32::MAX && ds64_data.is_none_or(|d| d == 0);
                break match ds64_data {
                    Some(d) if len == u32::MAX && d > 0 => Some(d),
                    _ => (!unset_data_len(len)).then_some(u64::from(len)),
                };
            }
            // Any other chunk: skip it and its pad byte.
            _ => {
                let skip = u64::from(len);
                if size.is_some_and(|size| pos + skip > size) {
                    let id = String::from_utf8_lossy(&id).trim().to_string();
                    return Err(wav_err(format!(
                        "no data chunk (a '{id}' chunk of {len} bytes at byte {} runs past the end of the file)",
                        pos - 8
                    )));
                }
                // Read past (a pipe cannot seek).
                let skipped =
                    io::copy(&mut (&mut r).take(skip), &mut io::sink()).map_err(|e| wav_err(e.to_string()))?;
                if skipped < skip {
                    return Err(wav_err("no data chunk".into()));
                }
                pos += skip;
                if len % 2 == 1 {
                    skip_pad(&mut r, &mut pos);
                }
            }
        }
    };
    let format = parse_fmt(&fmt.unwrap_or_default()).map_err(wav_err)?;
    let declared = data_len;
    // Samples of unset size end where chunks written after them (LIST, id3, cue, …) begin.
    let end = match (declared, size) {
        (None, Some(size)) => {
            let (end, before) = trailing_chunks_start(path, pos, size);
            // One-byte frames (8-bit mono) are the only ones a pad byte can complete: an odd
            // count of them is followed by a zero pad byte (RIFF pads odd-sized chunks, before
            // the chunks after it or at the end), which would read as a sample at full scale,
            // −1.0. Wider frames drop the partial frame.
            let pad = format.channels == 1 && format.bytes == 1 && (end - pos) % 2 == 0 && before == Some(0);
            if pad {
                end - 1
            } else {
                end
            }
        }
        _ => size.unwrap_or(u64::MAX),
    };
    let left = size.map(|_| end.saturating_sub(pos));
    let len = match (declared, left) {
        (Some(d), Some(l)) => Some(d.min(l)),
        (d, l) => d.or(l),
    };
    Ok(WavData { format, reader: r, len, declared, rf64_unsized })
}

/// Least samples of one value at the waveform's peak that make it "held" there.
const HELD_RUN: usize = 2;
/// Least such runs at that one value that make it a clip's level: a struck object's ring
/// decays, so its peak value comes once (a slow peak may hold a 16-bit code for two or
/// three samples); a clip or a limiter holds many peaks at one level.
const HELD_RUNS: usize = 3;
/// Longest run counted, s: a peak clipped however hard lasts under half its period (20 ms
/// at 25 Hz); a longer run is a constant (a padding, a test signal), not a peak.
const HELD_MAX_S: f64 = 0.02;

/// One channel's peak values as it is read, for a level it is held flat at: its largest
/// (and, apart, its smallest) value so far and the runs `[from, to)` of frames at exactly
/// that value, from [`HELD_RUN`] samples up to `max_run` long (a longer run is a constant).
/// Kept per channel in use, so that a channel limited below full scale is found in a
/// stereo mix whose other channel is not (the mix is not flat there). Its memory is the runs
/// at the peak value only: a new peak starts them again.
#[derive(Clone, Debug)]
struct HeldPeak {
    /// +1 for the largest value, −1 for the smallest.
    sign: f64,
    /// `sign` × the extreme value so far (0 before any sample over it).
    level: f64,
    runs: Vec<(usize, usize)>,
    /// The frame the run at `level` now being read started at.
    open: Option<usize>,
    max_run: usize,
}

impl HeldPeak {
    fn new(sign: f64, max_run: usize) -> Self {
        Self { sign, level: 0.0, runs: Vec::new(), open: None, max_run }
    }

    fn push(&mut self, frame: usize, v: f64) {
        let x = self.sign * v;
        if x > self.level {
            self.level = x;
            self.runs.clear();
            self.open = Some(frame);
        } else if x == self.level {
            self.open.get_or_insert(frame);
        } else {
            self.close(frame);
        }
    }

    fn close(&mut self, frame: usize) {
        if let Some(a) = self.open.take() {
            if frame - a <= self.max_run {
                self.runs.push((a, frame));
            }
        }
    }

    /// The samples were rescaled by `k` (exact: a power of two).
    fn rescale(&mut self, k: f64) {
        self.level *= k;
    }

    /// The level (a magnitude) and every run at it, if [`HELD_RUNS`] or more of them are
    /// [`HELD_RUN`] samples long or longer and the level is at least −26 dBFS: clipped or
    /// limited there, at full scale or under it (then every sample at that value was cut
    /// off, a peak that only touched the level too).
    fn finish(mut self, end: usize) -> Option<(f64, Vec<(usize, usize)>)> {
        self.close(end);
        let held = self.runs.iter().filter(|r| r.1 - r.0 >= HELD_RUN).count() >= HELD_RUNS;
        (self.level >= 0.05 && held).then_some((self.level, self.runs))
    }
}

/// Chunk ids written after the samples by recorders and editors (metadata, markers, loops;
/// matched in either case).
const TRAILING_IDS: [&[u8; 4]; 36] = [
    b"LIST", b"id3 ", b"ID3 ", b"cue ", b"smpl", b"inst", b"bext", b"iXML", b"axml", b"acid", b"fact", b"JUNK",
    b"PAD ", b"_PMX", b"cart", b"umid", b"DISP", b"PEAK", b"labl", b"note", b"ltxt", b"plst", b"SyLp", b"afsp",
    b"minf", b"elm1", b"regn", b"ovwf", b"levl", b"link", b"chna", b"adtl", b"FLLR", b"DGDA", b"ResU", b"LGWV",
];

/// Most bytes searched for chunks after samples of unset size (the end of the file).
const TRAILING_SEARCH: u64 = 16 << 20;

/// Where chunks written after samples of unset size begin, in a file of `size` bytes whose
/// samples start at byte `data_start`: the first offset in the file's last 16 MiB where a chain
/// of known chunks ([`TRAILING_IDS`], each with its declared size and pad byte, the last pad
/// optional) ends exactly at the end of the file. Samples that happen to spell an id are not
/// taken for one: their "size" would also have to land exactly on the next chunk or the end.
/// The end of the samples (the file's end if there is no chain, or if the file cannot be
/// read again) and the last byte before it, if the search read it.
fn trailing_chunks_start(path: &Path, data_start: u64, size: u64) -> (u64, Option<u8>) {
    use std::io::{Seek as _, SeekFrom};
    let from = data_start.max(size.saturating_sub(TRAILING_SEARCH));
    let mut tail = Vec::new();
    let read = File::open(path).and_then(|mut file| {
        file.seek(SeekFrom::Start(from))?;
        file.take(size - from).read_to_end(&mut tail)
    });
    if read.is_err() {
        return (size, None);
    }
    let n = tail.len();
    // Ids as written or in the other case (`list`, `junk`: writers differ).
    let known =
        |at: usize| tail.get(at..at + 4).is_some_and(|id| TRAILING_IDS.iter().any(|k| k.eq_ignore_ascii_case(id)));
    // chains[at]: a chain of known chunks starting at `at` ends exactly at the end. Worked out
    // from the end, each offset once (a walk from every offset was quadratic in a tail of
    // many small chunks that misses the end).
    let mut chains = vec![false; n];
    for at in (0..n.saturating_sub(7)).rev() {
        if !known(at) {
            continue;
        }
        let len = u32::from_le_bytes([tail[at + 4], tail[at + 5], tail[at + 6], tail[at + 7]]) as usize;
        let next = at + 8 + len;
        chains[at] = if next == n || (len % 2 == 1 && next + 1 == n) {
            true
        } else {
            let next = if len % 2 == 1 && !known(next) { next + 1 } else { next };
            next < n && chains[next]
        };
    }
    let at = chains.iter().position(|&c| c).unwrap_or(n);
    (from + at as u64, at.checked_sub(1).map(|b| tail[b]))
}

/// Steps over the pad byte after an odd-sized chunk (RIFF pads every odd-sized chunk with one
/// byte), unless the writer left it out: the byte is then the first of the next chunk's id
/// (the bytes after it cannot start an id, and it and the next three can). Looks ahead in the
/// read buffer only; at a buffer's end it takes the byte as the pad.
fn skip_pad(r: &mut io::BufReader<File>, pos: &mut u64) {
    let id = |b: &[u8]| b[0].is_ascii_alphanumeric() && b.iter().all(|c| (0x20..=0x7e).contains(c));
    let Ok(buf) = r.fill_buf() else {
        return;
    };
    let unpadded = buf.len() >= 9 && buf[0] != 0 && !id(&buf[1..5]) && id(&buf[0..4]);
    if !unpadded && !buf.is_empty() {
        r.consume(1);
        *pos += 1;
    }
}

/// Reads until `buf` is full or the input ends; the bytes read.
fn read_full(r: &mut impl io::Read, buf: &mut [u8]) -> io::Result<usize> {
    let mut n = 0;
    while n < buf.len() {
        match r.read(&mut buf[n..]) {
            Ok(0) => break,
            Ok(k) => n += k,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(n)
}

/// A mono mix whose peak is this many dB under the loudest channel's is channels that
/// cancel ([`Silence::ChannelsCancel`]).
const CANCEL_DB: f64 = 40.0;

/// Reads a WAV file into a mono [`Recording`]; `channel` picks one channel (0-based), `None`
/// averages all channels.
///
/// # Errors
/// [`EstimateError::Open`] if the file cannot be opened, [`EstimateError::Wav`] if it cannot
/// be decoded (corrupt, truncated header, unsupported format), [`EstimateError::NonFinite`]
/// naming the first NaN or infinite sample of a float file, [`EstimateError::SampleRate`]
/// outside 8–192 kHz, [`EstimateError::NoSuchChannel`], [`EstimateError::Silent`] if it has
/// no samples or only zeros (or channels that cancel out in the mono mix). Clipping, DC
/// offset, very low level, samples far beyond full scale and truncation only add warnings.
pub fn load_wav(path: &Path, channel: Option<usize>) -> Result<Recording, EstimateError> {
    read_wav(path, channel, true, None)
}

/// As [`load_wav`], keeping only the frames in `window(sample_rate)` (clipped to the file;
/// empty past its end): the file is read through as by [`load_wav`], with the same errors,
/// warnings and DC offset (measured on the whole file, bit for bit), so a few seconds of an
/// hour-long session take a few seconds' memory (the editor's A/B clips, a capture's
/// residual). [`Recording::start_frame`] is the window's first frame.
///
/// # Errors
/// As [`load_wav`].
pub fn load_wav_window(
    path: &Path,
    channel: Option<usize>,
    window: impl Fn(u32) -> std::ops::Range<usize>,
) -> Result<Recording, EstimateError> {
    read_wav(path, channel, true, Some(&window))
}

/// As [`load_wav`], for playing rather than analysing: the samples exactly as in the file (no
/// DC offset removed, no level warnings), and a silent file is not an error (`struck render
/// --input`).
///
/// # Errors
/// As [`load_wav`], except [`EstimateError::Silent`].
pub fn load_wav_exact(path: &Path, channel: Option<usize>) -> Result<Recording, EstimateError> {
    read_wav(path, channel, false, None)
}

/// Peak above which float samples are taken to be in the wrong units (e.g. integer counts
/// written as floats): 4× (12 dB) over full scale, far beyond any float overshoot.
const WRONG_UNITS_PEAK: f64 = 4.0;

/// Running measures of the mono mix over every frame read, so that a windowed read keeps
/// only its window yet measures the file as a whole read does: its peak and the mean of its
/// recorded part (without the constant padding at either end), as the same sums in the same
/// order.
struct MonoStats {
    /// Frames seen.
    n: usize,
    /// The first value, and the first frame that differs from it.
    head: f32,
    first_diff: Option<usize>,
    /// Sums of the values from frame 0 and from `first_diff`.
    sum: f64,
    sum_from_diff: f64,
    /// The constant run the values end in so far: its value, first frame, and both sums
    /// before it.
    run_value: f32,
    run_start: usize,
    sums_before_run: (f64, f64),
    /// Largest magnitude.
    peak: f64,
}

impl MonoStats {
    fn new() -> Self {
        MonoStats {
            n: 0,
            head: 0.0,
            first_diff: None,
            sum: 0.0,
            sum_from_diff: 0.0,
            run_value: 0.0,
            run_start: 0,
            sums_before_run: (0.0, 0.0),
            peak: 0.0,
        }
    }

    fn push(&mut self, v: f32) {
        let i = self.n;
        if i == 0 {
            self.head = v;
            self.run_value = v;
        } else {
            if self.first_diff.is_none() && v != self.head {
                self.first_diff = Some(i);
            }
            if v != self.run_value {
                self.run_value = v;
                self.run_start = i;
                self.sums_before_run = (self.sum, self.sum_from_diff);
            }
        }
        let x = f64::from(v);
        self.sum += x;
        if self.first_diff.is_some() {
            self.sum_from_diff += x;
        }
        self.peak = self.peak.max(x.abs());
        self.n += 1;
    }

    /// Every value scaled by `k`, a power of two (exact).
    fn rescale(&mut self, k: f64) {
        let f = |v: f32| (f64::from(v) * k) as f32;
        self.head = f(self.head);
        self.run_value = f(self.run_value);
        self.sum *= k;
        self.sum_from_diff *= k;
        self.sums_before_run = (self.sums_before_run.0 * k, self.sums_before_run.1 * k);
        self.peak *= k;
    }

    /// The mean of the recorded part: digital silence (a constant: exact zeros, or an
    /// offset) that an editor padded the take with before or after it is no part of the
    /// recording, so neither of its offset: measured on the recorded part only, a padded
    /// take reads as the take itself (a woodblock padded with 1 s of zeros kept its ring 79
    /// dB under its peak off centre, which gave 1226 Hz at 84 s⁻¹ instead of 40). (Runs of at
    /// least `run` frames: a ring that starts or ends on a zero sample is all recording. A
    /// recorded part under 1/20 of `rate` frames is a click, not a take with an offset: its
    /// own mean is its shape, a one-sided pulse, so the whole file's is taken.)
    fn recorded_mean(&self, run: usize, rate: usize) -> f64 {
        let len = self.n;
        let first = self.first_diff.filter(|&i| i >= run).unwrap_or(0);
        // The last frame that differs from the last value, plus one (all of them when none does).
        let last = if self.run_start == 0 { len } else { self.run_start };
        let last = if len - last >= run { last } else { len };
        let recorded = first..last.max(first);
        if recorded.len() * 20 < rate {
            return self.sum / len.max(1) as f64;
        }
        let sum = match (first > 0, last < len) {
            (false, false) => self.sum,
            (false, true) => self.sums_before_run.0,
            (true, false) => self.sum_from_diff,
            (true, true) => self.sums_before_run.1,
        };
        sum / recorded.len() as f64
    }
}

fn read_wav(
    path: &Path,
    channel: Option<usize>,
    analysis: bool,
    window: Option<&dyn Fn(u32) -> std::ops::Range<usize>>,
) -> Result<Recording, EstimateError> {
    let WavData { format, mut reader, len, declared, rf64_unsized } = open_wav(path)?;
    let spec = format;
    if !(MIN_RATE..=MAX_RATE).contains(&spec.sample_rate) {
        return Err(EstimateError::SampleRate { path: path.to_path_buf(), sample_rate: spec.sample_rate });
    }
    let keep = window.map_or(0..usize::MAX, |w| w(spec.sample_rate));
    let channels = usize::from(spec.channels);
    if let Some(ch) = channel {
        if ch >= channels {
            return Err(EstimateError::NoSuchChannel { path: path.to_path_buf(), channel: ch, channels });
        }
    }
    let frame_bytes = channels * spec.bytes;
    let max_frames = ((MAX_SECONDS * f64::from(spec.sample_rate)) as usize).min(MAX_SAMPLES);
    let total_frames = len.map(|len| usize::try_from(len / frame_bytes as u64).unwrap_or(usize::MAX));
    let mut warnings = Vec::new();
    if rf64_unsized {
        warnings.push(format!(
            "{}: an RF64/BW64 file without the ds64 chunk that holds its sizes (the recorder may have stopped before finishing it): the samples were read to the end of the file",
            path.display()
        ));
    }
    let seconds = |frames: usize| frames as f64 / f64::from(spec.sample_rate);
    if let Some(total) = total_frames.filter(|&t| t > max_frames) {
        warnings.push(format!(
            "{}: only the first {:.0} s of {:.0} s were analysed (length limit); split long sessions into several files",
            path.display(),
            seconds(max_frames),
            seconds(total)
        ));
    }
    let frames = total_frames.unwrap_or(max_frames).min(max_frames);
    // A pipe's length is unknown: grow as it is read.
    let kept = frames.min(keep.end).saturating_sub(keep.start);
    let mut mono = Vec::with_capacity(if total_frames.is_some() { kept } else { kept.min(1 << 20) });
    let mut stats = MonoStats::new();
    let (mut clipped, mut seen, mut peak_any) = (0usize, 0usize, 0.0f64);
    let mut clip_runs: Vec<(usize, usize)> = Vec::new();
    // An integer format's largest magnitude (its positive full-scale code; −1 is over it).
    let full_code = 1.0 - 1.5 / f64::from(1u32 << (spec.valid_bits.clamp(2, 32) - 1).min(31));
    // Each channel's previous sample (clipping is a value held).
    let mut prev = vec![f64::NAN; channels];
    // Each channel's largest and smallest values and where they are held (a limiter).
    let max_run = (HELD_MAX_S * f64::from(spec.sample_rate)) as usize;
    let mut peaks: Vec<[HeldPeak; 2]> =
        (0..channels).map(|_| [HeldPeak::new(1.0, max_run), HeldPeak::new(-1.0, max_run)]).collect();
    // Whole frames at a time, 64 KiB or so per read.
    let per_read = (65_536 / frame_bytes).max(1);
    let mut buf = vec![0u8; per_read * frame_bytes];
    let mut done = 0usize;
    let mut short_read = None;
    // Valid bits under the container: left-justified (low bits zero) as Microsoft's spec has
    // them, or right-justified (sign-extended) as some writers put them (hound's 24-in-4): the
    // first samples that are not zero tell, and right-justified ones are scaled up by the
    // bits in between.
    let pad_bits = if spec.float { 0 } else { 8 * spec.bytes as u32 - u32::from(spec.valid_bits) };
    let mut justified: Option<f64> = (pad_bits == 0).then_some(1.0);
    while done < frames {
        let want = per_read.min(frames - done);
        let got = match read_full(&mut reader, &mut buf[..want * frame_bytes]) {
            Ok(n) => n / frame_bytes,
            Err(e) => {
                short_read = Some(e.to_string());
                0
            }
        };
        // Right-justified samples are sign-extended from the valid bits, so they lie within
        // ±2^(valid − 1): samples over that fill the container (its valid bits were declared
        // wrong: 16-bit audio marked 12) and read at its full scale.
        let samples = || buf[..got * frame_bytes].chunks_exact(spec.bytes);
        let over_valid = || {
            let limit = 1.0 / f64::from(1u32 << pad_bits);
            samples().any(|b| spec.decode(b).abs() > limit)
        };
        if justified.is_none() {
            let low = |b: &[u8]| b.iter().rev().fold(0u32, |a, &x| (a << 8) | u32::from(x)) & ((1 << pad_bits) - 1);
            if samples().any(|b| low(b) != 0) {
                justified = Some(if over_valid() { 1.0 } else { f64::from(1u32 << pad_bits) });
            } else if samples().any(|b| b.iter().any(|&x| x != 0)) {
                justified = Some(1.0);
            }
        } else if justified != Some(1.0) && over_valid() {
            // Taken as right-justified on a quiet start, then a louder stretch fills the
            // container: what was read is rescaled to it (exact: a power of two), and none
            // of it clipped (all of it was under 2^(valid − 1) of the container).
            let k = 1.0 / f64::from(1u32 << pad_bits);
            for v in &mut mono {
                *v = (f64::from(*v) * k) as f32;
            }
            stats.rescale(k);
            peak_any *= k;
            peaks.iter_mut().flatten().for_each(|p| p.rescale(k));
            clipped = 0;
            clip_runs.clear();
            justified = Some(1.0);
        }
        let gain = justified.unwrap_or(1.0);
        for (f, frame) in buf[..got * frame_bytes].chunks_exact(frame_bytes).enumerate() {
            let mut acc = 0.0f64;
            for (ch, b) in frame.chunks_exact(spec.bytes).enumerate() {
                let v = spec.decode(b) * gain;
                if !v.is_finite() {
                    let frame = done + f;
                    return Err(EstimateError::NonFinite {
                        path: path.to_path_buf(),
                        frame,
                        channel: ch,
                        seconds: seconds(frame),
                        value: v as f32,
                    });
                }
                // Clipped: held at full scale or over, at its channel's previous value (clipped
                // at ±1, or clipped and then raised). A peak that merely reaches it is not (a
                // float file peaking at 1.09 holds its peaks; one sample at 0.9995 is a peak).
                let held = prev.get(ch).is_some_and(|&p| p == v);
                let in_use = channel.is_none_or(|c| c == ch);
                if v.abs() >= 0.999 && held {
                    clipped += 1;
                }
                // A held value: a run from the sample that first reached it (this frame's
                // predecessor) through this frame; a sample at the format's largest value
                // (not a float over it, which holds its peak): a run of one.
                let extreme = if spec.float { (v.abs() - 1.0).abs() <= 1e-7 } else { v.abs() >= full_code };
                if in_use && (v.abs() >= 0.999 && held || extreme) {
                    let frame = done + f;
                    let from = if held { frame.saturating_sub(1) } else { frame };
                    match clip_runs.last_mut() {
                        Some(r) if held && r.1 >= from => *r = (r.0.min(from), r.1.max(frame + 1)),
                        Some(r) if r.1 > frame => {}
                        _ => clip_runs.push((from, frame + 1)),
                    }
                }
                if let Some(p) = prev.get_mut(ch) {
                    *p = v;
                }
                if in_use {
                    if let Some(pk) = peaks.get_mut(ch) {
                        pk.iter_mut().for_each(|p| p.push(done + f, v));
                    }
                }
                seen += 1;
                peak_any = peak_any.max(v.abs());
                match channel {
                    Some(c) if c == ch => acc = v,
                    Some(_) => {}
                    None => acc += v,
                }
            }
            let m = if channel.is_none() { (acc / channels as f64) as f32 } else { acc as f32 };
            stats.push(m);
            if keep.contains(&(done + f)) {
                mono.push(m);
            }
        }
        done += got;
        if got < want {
            // The end of the input (of a pipe: its normal end).
            if total_frames.is_some() && short_read.is_none() {
                short_read = Some("the file ends there".into());
            }
            break;
        }
    }
    if total_frames.is_none() && done == max_frames {
        warnings.push(format!(
            "{}: only the first {:.0} s were analysed (length limit); split long sessions into several files",
            path.display(),
            seconds(max_frames)
        ));
    }
    let cut_short = declared.is_some_and(|d| len.is_some_and(|len| d > len)) || short_read.is_some();
    if cut_short && stats.n > 0 {
        warnings.push(format!(
            "{}: the data ends early ({} of {} bytes); {} samples were read, the file may be truncated",
            path.display(),
            done * frame_bytes,
            declared.or(len).unwrap_or(0),
            stats.n
        ));
    }
    if stats.n == 0 {
        return Err(EstimateError::Silent { path: path.to_path_buf(), why: Silence::NoSamples });
    }
    let peak = stats.peak;
    if analysis {
        // Channels that cancel: one the other inverted, exactly or not to the last bit (an
        // integer −32768 has no +32768; a dither or a gain of 0.999 on one side). The mix's
        // peak is `CANCEL_DB` under the loudest channel's, where a recording's channels,
        // however they differ, add up to about the louder one.
        let why =
            if channel.is_none() && channels > 1 && peak_any > 0.0 && peak < peak_any * 10f64.powf(-CANCEL_DB / 20.0) {
                Some(Silence::ChannelsCancel)
            } else {
                (peak == 0.0).then_some(Silence::Zeros)
            };
        if let Some(why) = why {
            return Err(EstimateError::Silent { path: path.to_path_buf(), why });
        }
    }
    let mean = stats.recorded_mean((spec.sample_rate as usize / 1000).max(1), spec.sample_rate as usize);
    let clip_fraction = clipped as f64 / seen.max(1) as f64;
    let wrong_units = spec.float && peak_any > WRONG_UNITS_PEAK;
    if wrong_units {
        warnings.push(format!(
            "{}: float samples reach {}× full scale (±1): the file is not scaled to ±1 (wrong units?); the analysis uses the samples as they are",
            path.display(),
            if peak_any < 1e6 { format!("{peak_any:.0}") } else { format!("{peak_any:.1e}") }
        ));
    } else if clipped >= 3 {
        warnings.push(format!(
            "{}: {} samples ({:.3} %) are at full scale (clipping); lower the recording gain (clipped stretches are left out of the analysis where enough of their impact is left)",
            path.display(),
            clipped,
            100.0 * clip_fraction
        ));
    }
    if analysis && mean.abs() > 0.01 * if wrong_units { peak } else { 1.0 } {
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
    // Integer samples that use few steps of their scale: the quantiser's error is then a
    // large part of the ring (modes under one step are dropped by the extraction). Counted
    // in the loudest channel (a silent channel halves the mix, not the steps recorded).
    let step = quantisation_step(spec.valid_bits);
    if analysis && !spec.float && peak_any > 0.0 && peak_any < 32.0 * step {
        warnings.push(format!(
            "{}: its peak is only {:.0} steps of its {}-bit scale; modes under one step are lost and the quietest decays are unreliable: record or export at more bits or a higher level",
            path.display(),
            peak_any / step,
            spec.valid_bits
        ));
    }
    // Clipped or limited below full scale (an interface's limiter, an editor's clip at
    // −0.2 dB): a channel in use held flat at its own peak level. Each channel apart: a
    // stereo take whose one channel went through a limiter is not flat in the mix. In a mix,
    // only at a level within 6 dB of the loudest channel's peak: the limited channel is the
    // hot one, and a quieter channel's steady tone (a test tone, a hum without noise) holds
    // its top code at every peak.
    let mut below = (0usize, 0.0f64, Vec::new());
    let least = if channels > 1 && channel.is_none() { 0.5 * peak_any } else { 0.0 };
    for (ch, pk) in peaks.into_iter().enumerate() {
        let found = pk.into_iter().filter_map(|p| p.finish(done)).filter(|&(level, _)| !wrong_units && level >= least);
        for (level, runs) in found {
            if level < 0.999 {
                below.0 += runs.len();
                below.1 = below.1.max(level);
                below.2.push(ch + 1);
            }
            clip_runs.extend(runs);
        }
    }
    if analysis && below.0 > 0 {
        below.2.dedup();
        let which = if channels > 1 && channel.is_none() {
            let list: Vec<String> = below.2.iter().map(ToString::to_string).collect();
            format!(" (channel {} of {channels})", list.join(" and "))
        } else {
            String::new()
        };
        warnings.push(format!(
            "{}: the waveform{which} is held flat at its peak level ({:.1} dBFS) in {} places: clipped or limited below full scale; lower the gain before the limiter (those stretches are left out of the analysis where enough of their impact is left)",
            path.display(),
            20.0 * below.1.log10(),
            below.0
        ));
    }
    clip_runs.sort_unstable();
    // Ascending and apart: one run where the two rules (or two channels' held values)
    // found overlapping stretches.
    let mut merged: Vec<(usize, usize)> = Vec::with_capacity(clip_runs.len());
    for r in clip_runs {
        match merged.last_mut() {
            Some(m) if r.0 < m.1 => m.1 = m.1.max(r.1),
            _ => merged.push(r),
        }
    }
    let clip_runs = merged;
    // Remove the DC offset: a constant would otherwise show up as a zero-frequency "mode".
    if analysis && mean != 0.0 {
        // (From every sample: the padding stays constant, digital silence at the take's
        // offset, and meets the take where it did.)
        for v in &mut mono {
            *v = (f64::from(*v) - mean) as f32;
        }
    }
    Ok(Recording {
        path: path.to_path_buf(),
        samples: mono,
        start_frame: keep.start.min(stats.n),
        sample_rate: spec.sample_rate,
        channels: spec.channels,
        bits_per_sample: spec.valid_bits,
        warnings,
        clipped: if wrong_units { Vec::new() } else { clip_runs },
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
        // The same without the pad bytes, as buggy writers leave them out.
        let mut nopad = b"WAVE".to_vec();
        nopad.extend_from_slice(&pcm16(48_000, &[], &samples)[12..12 + 24]);
        for (id, payload) in chunks {
            nopad.extend_from_slice(id);
            nopad.extend((payload.len() as u32).to_le_bytes());
            nopad.extend_from_slice(payload);
        }
        nopad.extend_from_slice(&pcm16(48_000, &[], &samples)[12 + 24..]);
        let mut f = b"RIFF".to_vec();
        f.extend((nopad.len() as u32).to_le_bytes());
        f.extend(nopad);
        let nopad = scratch("nopad", &f);
        assert_eq!(load_wav(&nopad, None).unwrap().samples.len(), 4800);
        let _ = std::fs::remove_file(nopad);
        let a = load_wav(&plain, None).unwrap();
        let b = load_wav(&odd, None).unwrap();
        assert_eq!(b.samples.len(), 4800);
        assert_eq!(a.samples, b.samples);
        let mean = samples.iter().map(|&s| f64::from(s)).sum::<f64>() / 4800.0 / 32768.0;
        assert!((f64::from(b.samples[10]) - (f64::from(samples[10]) / 32768.0 - mean)).abs() < 1e-6);
        let _ = std::fs::remove_file(plain);
        let _ = std::fs::remove_file(odd);
    }

    /// Stereo where one channel is the other inverted (the black-box tester's L = −R) mixes
    /// to almost nothing: 16-bit −32768 has no +32768, so the mix is not all zeros, and it
    /// went to the analysis ("no modal features … a dull thud"). Now the channels-cancel
    /// error, whose hint is `--channel 0`; one channel read alone is fine, and a stereo file
    /// whose right channel is silent (its mix 6 dB under the left) loads.
    #[test]
    fn channels_that_nearly_cancel_say_so() {
        let x = tone(4800);
        let l: Vec<i16> = x.iter().map(|v| (v * 65_536.0).round().clamp(-32_768.0, 32_767.0) as i16).collect();
        let inverted: Vec<u8> = l.iter().flat_map(|&v| [v, v.saturating_neg()]).flat_map(i16::to_le_bytes).collect();
        let p = scratch("l-minus-r", &wav_bytes(&fmt_body(1, 2, 48_000, 16, None), &inverted, None));
        match load_wav(&p, None) {
            Err(e @ EstimateError::Silent { why: Silence::ChannelsCancel, .. }) => {
                assert!(e.to_string().contains("--channel 0"), "{e}");
            }
            other => panic!("{:?}", other.map(|r| r.warnings)),
        }
        assert_eq!(load_wav(&p, Some(1)).unwrap().samples.len(), 4800);
        let _ = std::fs::remove_file(p);
        let one_side: Vec<u8> = l.iter().flat_map(|&v| [v, 0]).flat_map(i16::to_le_bytes).collect();
        let p = scratch("left-only", &wav_bytes(&fmt_body(1, 2, 48_000, 16, None), &one_side, None));
        assert_eq!(load_wav(&p, None).unwrap().samples.len(), 4800);
        let _ = std::fs::remove_file(p);
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

    /// A take padded with digital silence (zeros, or a constant) before and after reads as the
    /// take itself: its offset is measured on the recorded part (the padding stays constant).
    #[test]
    fn digital_silence_padding_changes_no_sample_of_the_take() {
        let take: Vec<f64> =
            tone(4800).iter().enumerate().map(|(i, v)| v * (-(i as f64) / 900.0).exp() + 0.003).collect();
        let bytes = |x: &[f64]| x.iter().flat_map(|v| (*v as f32).to_le_bytes()).collect::<Vec<u8>>();
        let fmt = fmt_body(3, 1, 48_000, 32, None);
        let a = scratch("take", &wav_bytes(&fmt, &bytes(&take), None));
        let plain = load_wav(&a, None).unwrap();
        let _ = std::fs::remove_file(a);
        // Zeros, or a constant (an offset the editor's padding kept), before and after.
        for (before, after) in [(0.0, 0.0), (0.01, -0.002)] {
            let mut padded = vec![before; 48_000];
            padded.extend(&take);
            padded.extend(vec![after; 12_000]);
            let b = scratch("take-padded", &wav_bytes(&fmt, &bytes(&padded), None));
            let p = load_wav(&b, None).unwrap();
            let _ = std::fs::remove_file(b);
            assert_eq!(&p.samples[48_000..48_000 + take.len()], &plain.samples[..], "padded with {before}, {after}");
            // The padding is still digital silence (constant), at the take's offset taken out.
            let (head, tail) = (p.samples[0], p.samples[p.samples.len() - 1]);
            assert!(p.samples[..48_000].iter().all(|&v| v == head));
            assert!(p.samples[48_000 + take.len()..].iter().all(|&v| v == tail));
        }
        // The offset was taken out (0.003 plus the ring's own mean).
        let mean = plain.samples.iter().map(|&v| f64::from(v)).sum::<f64>() / take.len() as f64;
        assert!(mean.abs() < 1e-6, "{mean}");
    }

    /// A window of a file reads as the same frames of the whole file, bit for bit, with its
    /// warnings and clipped stretches: a padded take with an offset (measured on the whole
    /// take, 0.02 here, and taken out of the window), a quiet start that reads as
    /// right-justified samples until a loud stretch rescales it, stereo mixed and one channel
    /// picked; clipped to the file, empty past its end.
    #[test]
    fn a_window_reads_the_same_frames_as_the_whole_file() {
        let take: Vec<f64> =
            tone(48_000).iter().enumerate().map(|(i, v)| v * (-(i as f64) / 9_000.0).exp() + 0.02).collect();
        let mut padded = vec![0.0; 14_400];
        padded.extend(&take);
        padded.extend(vec![0.0; 9_600]);
        let pcm = |x: &[f64]| x.iter().flat_map(|v| ((v * 32_767.0).round() as i16).to_le_bytes()).collect::<Vec<u8>>();
        let quiet: Vec<f64> = (0..96_000).map(|i| 0.01 * (0.37 * i as f64).sin() * (0.011 * i as f64).cos()).collect();
        let rescaled: Vec<f64> = quiet.iter().chain(&tone(48_000)).copied().collect();
        let stereo: Vec<f64> = take.iter().zip(tone(48_000)).flat_map(|(a, b)| [*a, 0.7 * b]).collect();
        let cases = [
            ("window-padded", wav_bytes(&fmt_body(1, 1, 48_000, 16, None), &pcm(&padded), None), None),
            ("window-rescaled", wav_bytes(&fmt_body(1, 1, 48_000, 16, Some(12)), &pcm(&rescaled), None), None),
            ("window-stereo", wav_bytes(&fmt_body(1, 2, 48_000, 16, None), &pcm(&stereo), None), None),
            ("window-stereo-right", wav_bytes(&fmt_body(1, 2, 48_000, 16, None), &pcm(&stereo), None), Some(1)),
        ];
        for (name, bytes, channel) in cases {
            let p = scratch(name, &bytes);
            let whole = load_wav(&p, channel).unwrap();
            let n = whole.samples.len();
            if name == "window-padded" {
                // The offset of the take alone came out (an independent check of the mean).
                assert!(whole.warnings.iter().any(|w| w.contains("DC offset 0.020")), "{:?}", whole.warnings);
                let mid = f64::from(whole.samples[14_400 + 40_000]);
                assert!((mid - (take[40_000] - 0.02)).abs() < 2e-4, "{mid}");
            }
            if name == "window-rescaled" {
                // Read at full scale after the rescale (its mean is under 1e-5).
                let worst =
                    whole.samples.iter().zip(&rescaled).map(|(a, b)| (f64::from(*a) - b).abs()).fold(0.0, f64::max);
                assert!(worst < 1e-4, "{worst}");
            }
            for (a, b) in [(0, n), (0, 100), (1_000, 30_000), (n - 10, n + 500), (n + 5, n + 10), (700, 700)] {
                let w = load_wav_window(&p, channel, |rate| {
                    assert_eq!(rate, 48_000);
                    a..b
                })
                .unwrap();
                let (lo, hi) = (a.min(n), b.min(n));
                let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<u32>>();
                assert_eq!(bits(&w.samples), bits(&whole.samples[lo..hi]), "{name} {a}..{b}");
                assert_eq!(w.start_frame, lo, "{name}");
                assert_eq!(w.warnings, whole.warnings, "{name}");
                assert_eq!(w.clipped, whole.clipped, "{name}");
            }
            let _ = std::fs::remove_file(p);
        }
    }

    /// The running mean of the recorded part equals the mean over the whole buffer as it was
    /// computed before windows (written out again here as the reference), bit for bit: padding
    /// before, after, both or neither, runs under and over the minimum, a constant file, a
    /// rescale of everything read so far partway through.
    #[test]
    fn the_running_mean_is_the_whole_buffers_mean() {
        fn reference(mono: &[f32], run: usize, rate: usize) -> f64 {
            let (head, tail) = (mono[0], mono[mono.len() - 1]);
            let first = mono.iter().position(|&v| v != head).filter(|&i| i >= run).unwrap_or(0);
            let last = mono.iter().rposition(|&v| v != tail).map_or(mono.len(), |i| i + 1);
            let last = if mono.len() - last >= run { last } else { mono.len() };
            let recorded = first..last.max(first);
            let recorded = if recorded.len() * 20 < rate { 0..mono.len() } else { recorded };
            let n = recorded.len().max(1) as f64;
            mono[recorded].iter().map(|&v| f64::from(v)).sum::<f64>() / n
        }
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        for case in 0..2_000 {
            let r = next();
            let mut pad = |bits: u64| if r >> bits & 1 == 1 { (next() % 40) as usize } else { 0 };
            let (before, after) = (pad(0), pad(1));
            let body = if case % 97 == 0 { 0 } else { 1 + (next() % 200) as usize };
            let (head, tail) = ((next() % 3) as f32 * 0.25 - 0.25, (next() % 3) as f32 * 0.25 - 0.25);
            let mut mono: Vec<f32> = vec![head; before];
            mono.extend((0..body).map(|_| ((next() % 2001) as f32 - 1000.0) / 1024.0 + 0.01));
            mono.extend(vec![tail; after]);
            if mono.is_empty() {
                continue;
            }
            let (run, rate) = (1 + (next() % 12) as usize, 20 + (next() % 3000) as usize);
            // A rescale by a power of two after `cut` values (as a quiet start read as
            // right-justified samples is rescaled once a loud stretch shows).
            let cut = (next() as usize) % (mono.len() + 1);
            let k = 1.0 / 16.0;
            let mut stats = MonoStats::new();
            for &v in &mono[..cut] {
                stats.push(v);
            }
            stats.rescale(k);
            for v in &mut mono[..cut] {
                *v = (f64::from(*v) * k) as f32;
            }
            for &v in &mono[cut..] {
                stats.push(v);
            }
            let (got, want) = (stats.recorded_mean(run, rate), reference(&mono, run, rate));
            assert_eq!(got.to_bits(), want.to_bits(), "case {case}: {got} vs {want} ({before}, {body}, {after})");
            let peak = mono.iter().fold(0.0f64, |m, &v| m.max(f64::from(v).abs()));
            assert_eq!(stats.peak, peak, "case {case}");
        }
    }

    /// A lone click in digital silence (a 2 ms one-sided pulse in 0.5 s of zeros) keeps its
    /// shape and gets no DC warning: under 50 ms is no take, its mean is the file's.
    #[test]
    fn a_lone_click_in_silence_is_not_an_offset() {
        let mut x = vec![0.0f64; 24_000];
        for v in &mut x[12_000..12_096] {
            *v = 0.5;
        }
        let bytes: Vec<u8> = x.iter().flat_map(|v| (*v as f32).to_le_bytes()).collect();
        let p = scratch("click", &wav_bytes(&fmt_body(3, 1, 48_000, 32, None), &bytes, None));
        let r = load_wav(&p, None).unwrap();
        let _ = std::fs::remove_file(p);
        assert!(!r.warnings.iter().any(|w| w.contains("DC offset")), "{:?}", r.warnings);
        // The file's mean (0.002) came out, not the click's (0.5).
        assert!((f64::from(r.samples[12_000]) - (0.5 - 0.002)).abs() < 1e-6, "{}", r.samples[12_000]);
    }

    /// RF64 (EBU Tech 3306) and BW64: the sizes in the `ds64` chunk, the 32-bit ones at
    /// 0xFFFFFFFF; read as the same samples in a plain WAV (a chunk after the samples is not
    /// read as samples: the ds64 size ends them). A black-box tester's RF64 file was "not a
    /// WAV file".
    #[test]
    fn rf64_files_are_read() {
        let samples: Vec<i16> = (0..4801).map(|i| ((i * 53 % 3000) as i16 - 1500) * 9).collect();
        let plain = pcm16(44_100, &[], &samples);
        let want = load_wav(&scratch("rf64-plain", &plain), None).unwrap().samples;
        let data: Vec<u8> = samples.iter().flat_map(|s| s.to_le_bytes()).collect();
        for magic in [b"RF64", b"BW64"] {
            let mut f = magic.to_vec();
            f.extend(u32::MAX.to_le_bytes());
            f.extend_from_slice(b"WAVEds64");
            // With a table of one entry (a chunk id and its 64-bit size).
            f.extend(40u32.to_le_bytes());
            let riff_size = 4 + 48 + 24 + 8 + data.len() + 8 + 4;
            f.extend((riff_size as u64).to_le_bytes());
            f.extend((data.len() as u64).to_le_bytes());
            f.extend((samples.len() as u64).to_le_bytes());
            f.extend(1u32.to_le_bytes());
            f.extend_from_slice(b"zzzz");
            f.extend(4u64.to_le_bytes());
            // fmt and the rest as the plain file has them, the data size unset.
            f.extend_from_slice(&plain[12..12 + 8 + 16]);
            f.extend_from_slice(b"data");
            f.extend(u32::MAX.to_le_bytes());
            f.extend_from_slice(&data);
            // A chunk the reader does not know after the samples: only the ds64 size ends them.
            f.extend_from_slice(b"zzzz");
            f.extend(4u32.to_le_bytes());
            f.extend([0x7f; 4]);
            let p = scratch("rf64", &f);
            let got = load_wav(&p, None).unwrap_or_else(|e| panic!("{}: {e}", String::from_utf8_lossy(magic)));
            assert_eq!(got.samples, want, "{}", String::from_utf8_lossy(magic));
            assert!(got.warnings.is_empty(), "{:?}", got.warnings);
            let _ = std::fs::remove_file(p);
        }
    }

    /// An RF64 file whose recorder never wrote the ds64 chunk (the 32-bit sizes at
    /// 0xFFFFFFFF and nothing to say the real ones): the samples are read to the end of the
    /// file, as a plain WAV's of unset size, and the warning says why.
    #[test]
    fn rf64_without_ds64_is_read_to_the_end_and_said() {
        let samples: Vec<i16> = (0..4801).map(|i| ((i * 37 % 2000) as i16 - 1000) * 11).collect();
        let plain = pcm16(48_000, &[], &samples);
        let want = load_wav(&scratch("rf64-nods-plain", &plain), None).unwrap().samples;
        let mut f = b"RF64".to_vec();
        f.extend(u32::MAX.to_le_bytes());
        f.extend_from_slice(b"WAVE");
        f.extend_from_slice(&plain[12..12 + 8 + 16]);
        f.extend_from_slice(b"data");
        f.extend(u32::MAX.to_le_bytes());
        f.extend(samples.iter().flat_map(|s| s.to_le_bytes()));
        let p = scratch("rf64-nods", &f);
        let got = load_wav(&p, None).unwrap();
        let _ = std::fs::remove_file(p);
        assert_eq!(got.samples, want);
        assert!(got.warnings.iter().any(|w| w.contains("without the ds64 chunk")), "{:?}", got.warnings);
    }

    /// A WAV file of `fmt` (the chunk's body) and `data` bytes, the data chunk declaring
    /// `data_len` (its true length if `None`).
    fn wav_bytes(fmt: &[u8], data: &[u8], data_len: Option<u32>) -> Vec<u8> {
        let mut f = b"RIFF\0\0\0\0WAVEfmt ".to_vec();
        f.extend((fmt.len() as u32).to_le_bytes());
        f.extend_from_slice(fmt);
        f.extend_from_slice(b"data");
        f.extend(data_len.unwrap_or(data.len() as u32).to_le_bytes());
        f.extend_from_slice(data);
        let riff = (f.len() - 8) as u32;
        f[4..8].copy_from_slice(&riff.to_le_bytes());
        f
    }

    /// A `fmt ` body: plain (`valid` = None) or WAVE_FORMAT_EXTENSIBLE with `valid` bits.
    fn fmt_body(tag: u16, channels: u16, rate: u32, container_bits: u16, valid: Option<u16>) -> Vec<u8> {
        let align = channels * container_bits / 8;
        let mut b = Vec::new();
        b.extend(if valid.is_some() { 0xFFFEu16 } else { tag }.to_le_bytes());
        b.extend(channels.to_le_bytes());
        b.extend(rate.to_le_bytes());
        b.extend((rate * u32::from(align)).to_le_bytes());
        b.extend(align.to_le_bytes());
        b.extend(container_bits.to_le_bytes());
        if let Some(v) = valid {
            b.extend(22u16.to_le_bytes());
            b.extend(v.to_le_bytes());
            b.extend(4u32.to_le_bytes()); // channel mask
            b.extend(tag.to_le_bytes());
            b.extend([0x00, 0x00, 0x00, 0x00, 0x10, 0x00, 0x80, 0x00, 0x00, 0xaa, 0x00, 0x38, 0x9b, 0x71]);
        }
        b
    }

    /// A 440 Hz tone of peak 0.5 (the truth the decoders are checked against).
    fn tone(n: usize) -> Vec<f64> {
        (0..n).map(|i| 0.5 * (2.0 * std::f64::consts::PI * 440.0 * i as f64 / 48_000.0).sin()).collect()
    }

    /// Loads `bytes` exactly (no DC removal) and compares with `x` within `tol`.
    fn check_exact(name: &str, bytes: &[u8], x: &[f64], tol: f64) -> Recording {
        let p = scratch(name, bytes);
        let r = load_wav_exact(&p, None).unwrap_or_else(|e| panic!("{name}: {e}"));
        let _ = std::fs::remove_file(p);
        assert_eq!(r.samples.len(), x.len(), "{name}");
        let worst = r.samples.iter().zip(x).map(|(a, b)| (f64::from(*a) - b).abs()).fold(0.0, f64::max);
        assert!(worst < tol, "{name}: worst error {worst}");
        r
    }

    #[test]
    fn extensible_and_64_bit_float_files_read_at_full_scale() {
        let x = tone(4800);
        // 24 valid bits left-justified in 32-bit containers (pro-audio interfaces write these).
        let data: Vec<u8> = x.iter().flat_map(|v| (((v * 8_388_608.0).round() as i32) << 8).to_le_bytes()).collect();
        let r = check_exact("ext24in32", &wav_bytes(&fmt_body(1, 1, 48_000, 32, Some(24)), &data, None), &x, 1e-6);
        assert_eq!(r.bits_per_sample, 24);
        // The same right-justified (sign-extended, as hound writes 24 bits in 4 bytes), plain
        // PCM and extensible.
        let data: Vec<u8> = x.iter().flat_map(|v| ((v * 8_388_608.0).round() as i32).to_le_bytes()).collect();
        let mut plain = fmt_body(1, 1, 48_000, 32, None);
        plain[14] = 24;
        check_exact("right24in32", &wav_bytes(&plain, &data, None), &x, 1e-6);
        check_exact("ext-right24in32", &wav_bytes(&fmt_body(1, 1, 48_000, 32, Some(24)), &data, None), &x, 1e-6);
        // 16-bit audio whose header says 12 valid bits (a black-box tester's file): its low
        // bits are not zero, but its samples fill the container, so they are not
        // right-justified 12-bit ones (read 16× too loud, with a false clipping warning).
        let data: Vec<u8> = x.iter().flat_map(|v| ((v * 32_768.0).round() as i16).to_le_bytes()).collect();
        check_exact("16-marked-12", &wav_bytes(&fmt_body(1, 1, 48_000, 16, Some(12)), &data, None), &x, 1e-4);
        // The same after a second of quiet room noise (−40 dBFS, under 2^11 of 2^15: the first
        // 64 KiB alone would pass for right-justified 12-bit samples).
        let quiet: Vec<f64> = (0..48_000).map(|i| 0.01 * (0.37 * i as f64).sin() * (0.011 * i as f64).cos()).collect();
        let y: Vec<f64> = quiet.iter().chain(&x).copied().collect();
        let data: Vec<u8> = y.iter().flat_map(|v| ((v * 32_768.0).round() as i16).to_le_bytes()).collect();
        let r =
            check_exact("quiet-16-marked-12", &wav_bytes(&fmt_body(1, 1, 48_000, 16, Some(12)), &data, None), &y, 1e-4);
        assert!(!r.warnings.iter().any(|w| w.contains("clip")), "{:?}", r.warnings);
        // A block size that fits no layout of the samples (16-bit mono in 3-byte blocks).
        let mut odd = fmt_body(1, 1, 48_000, 16, None);
        odd[12] = 3;
        let p = scratch("odd-align", &wav_bytes(&odd, &[0; 300], None));
        let e = load_wav(&p, None).unwrap_err().to_string();
        let _ = std::fs::remove_file(p);
        assert!(e.contains("block size (3 bytes)"), "{e}");
        // 20 valid bits in 24-bit containers.
        let data: Vec<u8> = x
            .iter()
            .flat_map(|v| {
                let s = ((v * 524_288.0).round() as i32) << 12;
                let b = s.to_le_bytes();
                [b[1], b[2], b[3]]
            })
            .collect();
        check_exact("ext20in24", &wav_bytes(&fmt_body(1, 1, 48_000, 24, Some(20)), &data, None), &x, 1e-5);
        // 64-bit float, plain and extensible.
        let data: Vec<u8> = x.iter().flat_map(|v| v.to_le_bytes()).collect();
        check_exact("f64", &wav_bytes(&fmt_body(3, 1, 48_000, 64, None), &data, None), &x, 1e-7);
        check_exact("extf64", &wav_bytes(&fmt_body(3, 1, 48_000, 64, Some(64)), &data, None), &x, 1e-7);
        // 8-bit unsigned (128 is zero).
        let data: Vec<u8> = x.iter().map(|v| (128.0 + v * 128.0).round() as u8).collect();
        check_exact("u8", &wav_bytes(&fmt_body(1, 1, 48_000, 8, None), &data, None), &x, 1.0 / 128.0);
    }

    #[test]
    fn unset_and_overlong_data_sizes_read_to_the_end_of_the_file() {
        let x = tone(4800);
        let data: Vec<u8> = x.iter().flat_map(|v| ((v * 32_767.0).round() as i16).to_le_bytes()).collect();
        let fmt = fmt_body(1, 1, 48_000, 16, None);
        for (name, declared) in [("unset-ffff", u32::MAX), ("unset-fffc", 0xFFFF_FFFC), ("unset-0", 0)] {
            let r = check_exact(name, &wav_bytes(&fmt, &data, Some(declared)), &x, 1e-4);
            assert!(r.warnings.is_empty(), "{name}: {:?}", r.warnings);
        }
        // Chunks written after samples of unset size (as a recorder adds its metadata on
        // stopping) end the samples: an odd-sized LIST with its pad, then an id3 without one.
        let mut list = b"LIST".to_vec();
        list.extend(13u32.to_le_bytes());
        list.extend_from_slice(b"INFOISFT\x01\0\0\0x\0");
        let mut id3 = b"id3 ".to_vec();
        id3.extend(5u32.to_le_bytes());
        id3.extend_from_slice(b"ID3\x04\0");
        for (name, tail) in [("list", list.clone()), ("list-id3", [list.clone(), id3.clone()].concat()), ("id3", id3)] {
            for declared in [u32::MAX, 0] {
                let bytes = [wav_bytes(&fmt, &data, Some(declared)), tail.clone()].concat();
                check_exact(&format!("trailing-{name}-{declared}"), &bytes, &x, 1e-4);
            }
        }
        // Samples that spell a chunk id are samples: "LIST" with a size that lands nowhere.
        let mut spelled = data.clone();
        spelled[100..108].copy_from_slice(b"LIST\x10\0\0\0");
        let bytes = wav_bytes(&fmt, &spelled, Some(u32::MAX));
        let p = scratch("spelled-list", &bytes);
        let r = load_wav_exact(&p, None).unwrap();
        let _ = std::fs::remove_file(p);
        assert_eq!(r.samples.len(), x.len());
        // 8-bit mono, an odd count of samples: the data's pad byte before the LIST is no sample.
        let odd = &x[..4799];
        let data8: Vec<u8> = odd.iter().map(|v| (128.0 + v * 127.0).round() as u8).collect();
        let bytes =
            [wav_bytes(&fmt_body(1, 1, 48_000, 8, None), &data8, Some(u32::MAX)), vec![0], list.clone()].concat();
        check_exact("trailing-after-pad-8-bit", &bytes, odd, 1.0 / 100.0);
        // … and at the end of the file, with no chunk after it.
        let bytes = [wav_bytes(&fmt_body(1, 1, 48_000, 8, None), &data8, Some(0)), vec![0]].concat();
        check_exact("pad-at-the-end-8-bit", &bytes, odd, 1.0 / 100.0);
        // Ids in the other case and less common ones, odd-sized without their pad byte.
        for id in [b"list", b"afsp", b"Junk"] {
            let mut chunk = id.to_vec();
            chunk.extend(5u32.to_le_bytes());
            chunk.extend_from_slice(b"abcde");
            let bytes = [wav_bytes(&fmt, &data, Some(u32::MAX)), chunk].concat();
            check_exact(&format!("trailing-{}", String::from_utf8_lossy(id)), &bytes, &x, 1e-4);
        }
        // 65,536 empty JUNK chunks that miss the end by two bytes: samples, and the search is
        // linear (a walk from every offset took minutes).
        let junk: Vec<u8> = b"JUNK\0\0\0\0".repeat(1 << 16);
        let mut tail_data = data.clone();
        tail_data.extend_from_slice(&junk);
        tail_data.extend_from_slice(&[0, 0]);
        let bytes = wav_bytes(&fmt, &tail_data, Some(u32::MAX));
        let p = scratch("junk-misses-the-end", &bytes);
        let r = load_wav_exact(&p, None).unwrap();
        let _ = std::fs::remove_file(p);
        assert_eq!(r.samples.len(), tail_data.len() / 2);
        let r = check_exact("overlong", &wav_bytes(&fmt, &data, Some(2 * data.len() as u32)), &x, 1e-4);
        assert!(r.warnings.iter().any(|w| w.contains("truncated")), "{:?}", r.warnings);
    }

    #[test]
    fn what_cannot_be_read_says_why_in_one_line() {
        let fmt = fmt_body(1, 1, 48_000, 16, None);
        let cases: [(&str, Vec<u8>, &str); 5] = [
            ("no-samples", wav_bytes(&fmt, &[], None), "holds no samples"),
            ("alaw", wav_bytes(&fmt_body(6, 1, 48_000, 8, None), &[1, 2, 3], None), "A-law-encoded samples"),
            ("f16", wav_bytes(&fmt_body(3, 1, 48_000, 16, None), &[1, 2], None), "16-bit float"),
            ("rifx", b"RIFX\0\0\0\0WAVE".to_vec(), "big-endian"),
            (
                "antiphase",
                wav_bytes(
                    &fmt_body(1, 2, 48_000, 16, None),
                    &tone(480)
                        .iter()
                        .flat_map(|v| {
                            let s = (v * 32_767.0).round() as i16;
                            [s.to_le_bytes(), (-s).to_le_bytes()].concat()
                        })
                        .collect::<Vec<u8>>(),
                    None,
                ),
                "--channel 0",
            ),
        ];
        for (name, bytes, says) in cases {
            let p = scratch(name, &bytes);
            let e = load_wav(&p, None).unwrap_err().to_string();
            let _ = std::fs::remove_file(p);
            assert!(e.contains(says) && !e.contains('\n'), "{name}: {e}");
        }
        let folder = std::env::temp_dir();
        let e = load_wav(&folder, None).unwrap_err();
        assert!(matches!(e, EstimateError::Open { .. }) && e.to_string().contains("folder"), "{e}");
        let e = load_wav(&folder.join("struck-no-such-file.wav"), None).unwrap_err();
        assert!(matches!(e, EstimateError::Open { .. }) && !e.to_string().contains("export"), "{e}");
    }

    #[test]
    fn float_samples_in_the_wrong_units_are_named() {
        let x = tone(4800);
        let data: Vec<u8> = x.iter().flat_map(|v| ((v * 32_768.0) as f32).to_le_bytes()).collect();
        let p = scratch("units", &wav_bytes(&fmt_body(3, 1, 48_000, 32, None), &data, None));
        let r = load_wav(&p, None).unwrap();
        let _ = std::fs::remove_file(p);
        assert!(r.warnings.iter().any(|w| w.contains("wrong units")), "{:?}", r.warnings);
        assert!(!r.warnings.iter().any(|w| w.contains("clipping")), "{:?}", r.warnings);
    }

    /// A float file peaking a little over full scale (1.09) is not clipped (float holds its
    /// peaks); one held at ±1 is, and one clipped and then raised (held at ±1.12).
    #[test]
    fn float_over_full_scale_is_not_clipping_but_float_held_at_one_is() {
        let x = tone(4800);
        let peak = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let over: Vec<u8> = x.iter().flat_map(|v| ((v / peak * 1.09) as f32).to_le_bytes()).collect();
        let held: Vec<u8> = x.iter().flat_map(|v| ((v / peak * 1.5).clamp(-1.0, 1.0) as f32).to_le_bytes()).collect();
        let raised: Vec<u8> =
            x.iter().flat_map(|v| ((v / peak * 1.5).clamp(-1.0, 1.0) as f32 * 1.12).to_le_bytes()).collect();
        for (name, data, clipping) in [("over", over, false), ("held", held, true), ("raised", raised, true)] {
            let p = scratch(name, &wav_bytes(&fmt_body(3, 1, 48_000, 32, None), &data, None));
            let r = load_wav(&p, None).unwrap();
            let _ = std::fs::remove_file(p);
            assert_eq!(r.warnings.iter().any(|w| w.contains("clipping")), clipping, "{name}: {:?}", r.warnings);
        }
    }

    #[test]
    fn a_pad_byte_that_is_not_zero_is_still_a_pad_byte() {
        let samples: Vec<i16> = (0..480).map(|i| (i * 53 % 4000) as i16 - 2000).collect();
        let mut f = pcm16(48_000, &[(b"LIST", b"INFOINAM\x05\x00\x00\x00bells")], &samples);
        // The odd LIST chunk's pad byte (after its 17 bytes), written as a letter or a space.
        let pad = 12 + 24 + 8 + 17;
        assert_eq!(f[pad], 0);
        for b in [b'x', b' ', b'a'] {
            f[pad] = b;
            let p = scratch(&format!("pad-{b}"), &f);
            let r = load_wav_exact(&p, None).unwrap_or_else(|e| panic!("pad {b}: {e}"));
            let _ = std::fs::remove_file(p);
            assert_eq!(r.samples.len(), 480);
            assert!((f64::from(r.samples[7]) - f64::from(samples[7]) / 32_768.0).abs() < 1e-9);
        }
    }

    #[cfg(unix)]
    #[test]
    fn a_pipe_is_read_to_its_end() {
        let x = tone(48_000);
        let data: Vec<u8> = x.iter().flat_map(|v| ((v * 32_767.0).round() as i16).to_le_bytes()).collect();
        // An odd chunk before the data (skipped by reading: a pipe cannot seek).
        let mut bytes = b"RIFF\0\0\0\0WAVE".to_vec();
        bytes.extend_from_slice(b"fmt ");
        let fmt = fmt_body(1, 1, 48_000, 16, None);
        bytes.extend((fmt.len() as u32).to_le_bytes());
        bytes.extend_from_slice(&fmt);
        bytes.extend_from_slice(b"junk\x03\x00\x00\x00abc\x00");
        bytes.extend_from_slice(b"data");
        bytes.extend((data.len() as u32).to_le_bytes());
        bytes.extend_from_slice(&data);
        let fifo = std::env::temp_dir().join(format!("struck-wav-{}-pipe.wav", std::process::id()));
        let _ = std::fs::remove_file(&fifo);
        if !std::process::Command::new("mkfifo").arg(&fifo).status().is_ok_and(|s| s.success()) {
            eprintln!("mkfifo is not available: skipped");
            return;
        }
        let writer = {
            let fifo = fifo.clone();
            std::thread::spawn(move || std::fs::write(fifo, bytes).unwrap())
        };
        let r = load_wav_exact(&fifo, None).unwrap();
        writer.join().unwrap();
        let _ = std::fs::remove_file(&fifo);
        assert_eq!(r.samples.len(), 48_000);
        assert!(r.warnings.is_empty(), "{:?}", r.warnings);
        let worst = r.samples.iter().zip(&x).map(|(a, b)| (f64::from(*a) - b).abs()).fold(0.0, f64::max);
        assert!(worst < 1e-4, "{worst}");
    }
}
