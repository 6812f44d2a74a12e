//! Errors of the estimator. Every variant carries the data needed to act on it, and every
//! message says what to do.

use std::path::PathBuf;

/// Why an estimate could not be produced.
#[derive(Debug, thiserror::Error)]
pub enum EstimateError {
    /// The file could not be opened or decoded as WAV.
    #[error("{path}: cannot read as WAV ({reason}); export the recording as a PCM or float WAV file")]
    Wav {
        /// The file.
        path: PathBuf,
        /// What the decoder said.
        reason: String,
    },
    /// The file cannot be opened (missing, a folder, no permission).
    #[error("{path}: cannot open ({reason})")]
    Open {
        /// The file.
        path: PathBuf,
        /// What the system said.
        reason: String,
    },
    /// The WAV file holds no samples, or only digital silence.
    #[error("{path}: {}", why.message())]
    Silent {
        /// The file.
        path: PathBuf,
        /// Which kind of silence.
        why: Silence,
    },
    /// The requested channel does not exist.
    #[error("{path}: channel {channel} requested but the file has {channels} channel(s); channels count from 0")]
    NoSuchChannel {
        /// The file.
        path: PathBuf,
        /// Requested channel (0-based).
        channel: usize,
        /// Channels in the file.
        channels: usize,
    },
    /// Sample rate outside 8–192 kHz.
    #[error("{path}: sample rate {sample_rate} Hz is not supported; resample to between 8 and 192 kHz")]
    SampleRate {
        /// The file.
        path: PathBuf,
        /// The file's rate in Hz.
        sample_rate: u32,
    },
    /// A float WAV holds a NaN or infinite sample.
    #[error("{path}: sample {frame} of channel {channel} ({seconds:.3} s) is {value}; the file is damaged or was written by a faulty program, so re-export or re-record it")]
    NonFinite {
        /// The file.
        path: PathBuf,
        /// Index of the first such frame (0-based).
        frame: usize,
        /// Its channel (0-based).
        channel: usize,
        /// Its time from the start, seconds.
        seconds: f64,
        /// The value: NaN, inf or -inf.
        value: f32,
    },
    /// No impact could be found in any file.
    #[error("no impacts found in {files} file(s); record taps well above the background noise, with a short silence between them{also}")]
    NoImpacts {
        /// Number of files searched.
        files: usize,
        /// What reading them warned of (a file whose data ends early, …), as
        /// " (also: …; …)", or empty: the error is then the only line the user sees.
        also: String,
    },
    /// Impacts were found, but none could be used (each one's reason is in the report's
    /// skipped list; the first is named here).
    #[error(
        "no usable impacts in {files} file(s): {found} found, none kept (e.g. {file} at {onset_s:.3} s: {reason})"
    )]
    NoUsableImpacts {
        /// Number of files searched.
        files: usize,
        /// Impacts found (skipped ones included, precursors not).
        found: usize,
        /// The first skipped impact's file, onset and reason.
        file: String,
        /// Its onset, s.
        onset_s: f64,
        /// Why it was skipped.
        reason: String,
    },
    /// Too few (λ, c) points for the requested model.
    #[error("found {found} usable mode feature(s) but the fit needs at least {needed}; {}", if *needed > 4 {
        "record more taps or choose a model with fewer parameters (rayleigh)"
    } else {
        "record more taps, struck where more modes ring (away from the middle and the edges)"
    })]
    TooFewFeatures {
        /// Features available.
        found: usize,
        /// Features needed.
        needed: usize,
    },
    /// Input points contain NaN, infinities, or non-positive λ.
    #[error("invalid input point {index}: (λ = {lambda}, c = {c}); λ must be > 0 and both finite")]
    InvalidPoint {
        /// Index in the input slice.
        index: usize,
        /// λ in rad²/s².
        lambda: f64,
        /// c in 1/s.
        c: f64,
    },
    /// Every point has the same λ, so no curve can be fitted.
    #[error("all {n} features have the same frequency; record taps at several places so more modes ring")]
    Degenerate {
        /// Number of points.
        n: usize,
    },
    /// The optimiser failed to produce finite parameters.
    #[error("the {method} fit did not converge ({reason}); try the lsq method or another model")]
    NoConvergence {
        /// Method name.
        method: &'static str,
        /// Details.
        reason: String,
    },
    /// The caller set the cancel flag.
    #[error("cancelled")]
    Cancelled,
}

/// Why a recording counts as silent ([`EstimateError::Silent`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Silence {
    /// The data chunk holds no whole sample.
    NoSamples,
    /// Every sample is zero.
    Zeros,
    /// The channels are not silent but cancel out when mixed to mono (one is the other
    /// inverted).
    ChannelsCancel,
}

impl Silence {
    fn message(self) -> &'static str {
        match self {
            Silence::NoSamples => "the file holds no samples (empty, or its writer never finished it); export it again",
            Silence::Zeros => {
                "the recording is silent; check the input level and that the right file/channel was chosen"
            }
            Silence::ChannelsCancel => {
                "the channels cancel each other out when mixed to mono (one is the other inverted); pick one channel (--channel 0)"
            }
        }
    }
}
