//! The error type of every fallible function in this crate.

use std::path::PathBuf;

/// Why a material or bank could not be read, written or accepted.
///
/// Every variant carries the data needed to fix the problem, and its message says what to do.
#[derive(Debug, thiserror::Error)]
pub enum PresetError {
    /// Reading a file failed.
    #[error("could not access preset file `{}`: {source}. Check that the path exists and that Struck may access it", path.display())]
    Io {
        /// The file that was being read or written.
        path: PathBuf,
        /// The underlying I/O error.
        #[source]
        source: std::io::Error,
    },

    /// The file is larger than any preset ([`crate::MAX_PRESET_BYTES`]): another kind of
    /// file, or a device that never ends (`/dev/zero`); not read into memory.
    #[error("preset file `{}` is larger than {} MiB, more than any material or bank; give the material or bank file itself", path.display(), max >> 20)]
    TooLarge {
        /// The file.
        path: PathBuf,
        /// The largest size read, bytes.
        max: u64,
    },

    /// The file is a recording or another known binary kind, not a preset (a black-box
    /// tester: `bank info take.wav` was told to save the WAV "as UTF-8 in your editor").
    #[error("`{}` is {found}, not a material or bank (JSON): give the preset file itself (`struck estimate` and `struck bank capture` write one from a recording)", path.display())]
    NotAPreset {
        /// The file that was read.
        path: PathBuf,
        /// What it is ("a WAV recording", "a MIDI file").
        found: &'static str,
    },

    /// The file was read but is not UTF-8 text (a UTF-16 file from a Windows editor, a
    /// Latin-1 one, a damaged one with NUL bytes).
    #[error("preset file `{}` is not UTF-8 text ({found}). Save it as UTF-8 in your editor, or re-export the preset from Struck", path.display())]
    Encoding {
        /// The file that was read.
        path: PathBuf,
        /// What it looks like instead, and where the first byte that is not UTF-8 is.
        found: String,
    },

    /// Writing a file failed (nothing was replaced).
    #[error(transparent)]
    Output(#[from] crate::output::OutputError),

    /// The text is not valid JSON, or does not have the shape of a material or bank.
    #[error("{what} is not a valid preset: {message} (line {line}, column {column}). Fix the JSON there, or re-export the preset from Struck")]
    Json {
        /// What was being parsed: "material", "bank", or a file path.
        what: String,
        /// 1-based line of the error (0 if unknown).
        line: usize,
        /// 1-based column of the error (0 if unknown).
        column: usize,
        /// serde_json's description of the problem, without the position.
        message: String,
    },

    /// The file was written for another version of the preset format.
    #[error("preset schema_version {found} is not supported: this build of Struck reads schema_version {supported}. Use a Struck version that matches the file, or re-export the preset")]
    SchemaVersion {
        /// The `schema_version` found in the file.
        found: u32,
        /// The version this build reads ([`crate::SCHEMA_VERSION`]).
        supported: u32,
    },

    /// The JSON parsed, but a value is out of range or inconsistent.
    #[error("invalid `{field}`: {reason}")]
    Invalid {
        /// Path of the offending field, e.g. `lambdas[3]` or `damping.params[2]`.
        field: String,
        /// What is wrong and what is expected.
        reason: String,
    },
}

impl PresetError {
    /// Shorthand for [`PresetError::Invalid`].
    pub(crate) fn invalid(field: impl Into<String>, reason: impl Into<String>) -> Self {
        PresetError::Invalid { field: field.into(), reason: reason.into() }
    }

    /// A [`PresetError::Json`] from a serde_json error, with the position split out.
    pub(crate) fn json(what: &str, e: &serde_json::Error) -> Self {
        let full = e.to_string();
        // serde_json appends " at line L column C"; the position has its own fields.
        let suffix = format!(" at line {} column {}", e.line(), e.column());
        let message = full.strip_suffix(&suffix).unwrap_or(&full).to_string();
        PresetError::Json { what: what.to_string(), line: e.line(), column: e.column(), message }
    }
}

/// A number as a message shows it: as Rust prints it from 10⁻⁴ to 10⁹ (and 0), in
/// scientific notation outside (a black-box tester's 1e308 was echoed with its 308 digits).
#[derive(Clone, Copy, Debug)]
pub struct Shown(pub f64);

impl std::fmt::Display for Shown {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let a = self.0.abs();
        if !self.0.is_finite() || a == 0.0 || (1e-4..1e9_f64).contains(&a) {
            write!(f, "{}", self.0)
        } else {
            write!(f, "{:e}", self.0)
        }
    }
}
