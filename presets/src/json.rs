//! Shared JSON plumbing: version check before typed parsing, file I/O with paths in errors.

use std::path::Path;

use serde::de::DeserializeOwned;
use serde::Serialize;

use crate::{PresetError, SCHEMA_VERSION};

/// Parses `s` as a `T`, checking `schema_version` first so that a file from another
/// format version reports [`PresetError::SchemaVersion`] rather than a confusing field error.
/// The fields `T` does not read are appended to `unknown` as JSON paths (`damping.parms`,
/// `support.recorded_modes.modes.2.extra`), each once. A UTF-8 byte-order mark at the start
/// (Windows editors write one) is skipped.
pub(crate) fn parse<T: DeserializeOwned>(s: &str, what: &str, unknown: &mut Vec<String>) -> Result<T, PresetError> {
    let s = s.strip_prefix('\u{feff}').unwrap_or(s);
    let value: serde_json::Value = serde_json::from_str(s).map_err(|e| PresetError::json(what, &e))?;
    let Some(object) = value.as_object() else {
        return Err(PresetError::Json {
            what: what.to_string(),
            line: 1,
            column: 1,
            message: "expected a JSON object `{ ... }` at the top level".to_string(),
        });
    };
    match object.get("schema_version") {
        None => {
            return Err(PresetError::invalid(
                "schema_version",
                format!("missing; add \"schema_version\": {SCHEMA_VERSION}"),
            ))
        }
        Some(v) => match v.as_u64() {
            Some(found) if found == u64::from(SCHEMA_VERSION) => {}
            Some(found) => {
                let found = u32::try_from(found).map_err(|_| {
                    PresetError::invalid("schema_version", format!("{found} is not a valid version number"))
                })?;
                return Err(PresetError::SchemaVersion { found, supported: SCHEMA_VERSION });
            }
            None => {
                return Err(PresetError::invalid(
                    "schema_version",
                    format!("must be a whole number, found {v}; use {SCHEMA_VERSION}"),
                ))
            }
        },
    }
    // Parse again from the text (not from `value`) so that errors keep their line and column.
    let mut de = serde_json::Deserializer::from_str(s);
    // (A key given twice is listed once.)
    let mut seen = std::collections::HashSet::new();
    let mut note = |path: &serde_ignored::Path| {
        let p = json_path(path);
        if seen.insert(p.clone()) {
            unknown.push(p);
        }
    };
    let value = serde_ignored::deserialize(&mut de, |path| note(&path));
    let value = value.map_err(|e| {
        // A misspelt required field is missing *and* unknown: say both.
        let mut err = PresetError::json(what, &e);
        if let (PresetError::Json { message, .. }, Some(note)) = (&mut err, unknown_fields_note(unknown)) {
            message.push_str(&format!(" ({note})"));
        }
        err
    })?;
    de.end().map_err(|e| PresetError::json(what, &e))?;
    Ok(value)
}

/// `path` as dotted JSON keys and indices (`support.recorded_modes.modes.0.extra`): the
/// `Option`s and newtypes it passes through are not written.
fn json_path(path: &serde_ignored::Path) -> String {
    use serde_ignored::Path;
    let (parent, own) = match path {
        Path::Root => return String::new(),
        Path::Seq { parent, index } => (parent, index.to_string()),
        // (A key with a quote, a backslash or a control character is escaped: one line; one
        // that is empty or holds a dot is quoted, so it does not read as a nested path.)
        Path::Map { parent, key } if key.is_empty() || key.contains('.') => {
            (parent, format!("\"{}\"", key.escape_debug()))
        }
        Path::Map { parent, key } => (parent, key.escape_debug().to_string()),
        Path::Some { parent } | Path::NewtypeStruct { parent } | Path::NewtypeVariant { parent } => {
            return json_path(parent)
        }
    };
    let head = json_path(parent);
    if head.is_empty() {
        own
    } else {
        format!("{head}.{own}")
    }
}

/// One line on the fields a preset file has that this version does not read (None if none):
/// the first few paths and how many more.
pub fn unknown_fields_note(unknown: &[String]) -> Option<String> {
    const SHOWN: usize = 4;
    let (first, rest) = unknown.split_at(unknown.len().min(SHOWN));
    // (A path longer than 80 characters is cut: the line stays readable.)
    let cut = |p: &String| match p.char_indices().nth(80) {
        Some((i, _)) => format!("`{}…`", &p[..i]),
        None => format!("`{p}`"),
    };
    let mut list: Vec<String> = first.iter().map(cut).collect();
    if !rest.is_empty() {
        list.push(format!("and {} more", rest.len()));
    }
    (!unknown.is_empty()).then(|| {
        format!(
            "ignored {} unknown field{} {} (a misspelt name, or a field of a newer Struck)",
            unknown.len(),
            if unknown.len() == 1 { "" } else { "s" },
            list.join(", ")
        )
    })
}

/// A preset type stored as one JSON file ([`crate::Bank`], [`crate::Material`]): parsed,
/// loaded and saved the same way, each with its own [`PresetFile::validate`].
pub(crate) trait PresetFile: Serialize + DeserializeOwned {
    /// Checks every field.
    fn validate(&self) -> Result<(), PresetError>;
}

/// Parses `s` as a `T` ([`parse`]) and validates it; `what` names the source in errors.
/// Unknown fields are appended to `unknown` ([`parse`]).
pub(crate) fn parse_valid<T: PresetFile>(s: &str, what: &str, unknown: &mut Vec<String>) -> Result<T, PresetError> {
    let value: T = parse(s, what, unknown)?;
    value.validate()?;
    Ok(value)
}

/// Reads, parses and validates a preset file; errors name `path`; unknown fields are
/// appended to `unknown` ([`parse`]).
pub(crate) fn load<T: PresetFile>(path: &Path, unknown: &mut Vec<String>) -> Result<T, PresetError> {
    let text = read(path)?;
    parse_valid(&text, &path.display().to_string(), unknown)
}

/// Validates `value`, then writes it as pretty JSON to `path` ([`write`]).
pub(crate) fn save<T: PresetFile>(value: &T, path: &Path) -> Result<(), PresetError> {
    value.validate()?;
    write(path, &to_pretty(value))
}

/// Pretty JSON with a trailing newline.
pub(crate) fn to_pretty<T: Serialize>(value: &T) -> String {
    // PANIC: our types have only string map keys and no fallible Serialize impls, so
    // serde_json cannot fail here (non-finite floats serialise as `null`).
    let mut s = serde_json::to_string_pretty(value).expect("preset types always serialise");
    s.push('\n');
    s
}

/// Reads a whole file, mapping failure to [`PresetError::Io`] with the path, a recording or
/// MIDI file to [`PresetError::NotAPreset`], and text that is not UTF-8 (or holds a NUL
/// byte: damaged) to [`PresetError::Encoding`] saying what it looks like.
pub(crate) fn read(path: &Path) -> Result<String, PresetError> {
    let bytes = crate::read_capped(path, crate::MAX_PRESET_BYTES)
        .map_err(|source| PresetError::Io { path: path.to_path_buf(), source })?
        .ok_or(PresetError::TooLarge { path: path.to_path_buf(), max: crate::MAX_PRESET_BYTES })?;
    if let Some(found) = crate::output::binary_kind(&bytes) {
        return Err(PresetError::NotAPreset { path: path.to_path_buf(), found });
    }
    // UTF-16 or UTF-32 of ASCII text without a byte-order mark is valid UTF-8 (NUL bytes
    // between the characters): a NUL in the first two bytes is never JSON.
    if bytes.len() >= 2 && (bytes[0] == 0 || bytes[1] == 0) {
        let found = "it looks like UTF-16 or UTF-32: NUL bytes between the characters".to_string();
        return Err(PresetError::Encoding { path: path.to_path_buf(), found });
    }
    let text = String::from_utf8(bytes).map_err(|e| {
        let b = e.as_bytes();
        let at = e.utf8_error().valid_up_to();
        let found = if b.starts_with(&[0, 0, 0xfe, 0xff]) || b.starts_with(&[0xff, 0xfe, 0, 0]) {
            "it is UTF-32".to_string()
        } else if b.starts_with(&[0xfe, 0xff]) || b.starts_with(&[0xff, 0xfe]) {
            "it is UTF-16".to_string()
        } else {
            format!("byte 0x{:02x} at offset {at} is not UTF-8; Latin-1 or another 8-bit encoding?", b[at])
        };
        PresetError::Encoding { path: path.to_path_buf(), found }
    })?;
    // A NUL byte is never JSON (in a string it must be escaped): a damaged file (a crash
    // mid-write by another program, a disk error) or a binary one, which serde would report
    // as a "control character" somewhere.
    if let Some(at) = text.bytes().position(|b| b == 0) {
        let line = 1 + text.as_bytes()[..at].iter().filter(|&&b| b == b'\n').count();
        let found = format!("a NUL byte at offset {at} (line {line}): the file is damaged or not text");
        return Err(PresetError::Encoding { path: path.to_path_buf(), found });
    }
    Ok(text)
}

/// Writes `text` to `path` through a temporary file in the same folder and a rename
/// ([`crate::output::AtomicFile`]), so that a failed or interrupted write never leaves a
/// half-written preset behind nor truncates the old one.
pub(crate) fn write(path: &Path, text: &str) -> Result<(), PresetError> {
    crate::output::check_kind(path, crate::output::Kind::Json)?;
    Ok(crate::output::write_atomically(path, text.as_bytes())?)
}

/// An id that [`check_id`] accepts, from free text (a file name, a typed name): lowercase
/// ASCII letters and digits, every other run of characters one hyphen, after `prefix` (with
/// a hyphen; `prefix` alone if the text has no letters or digits; may be empty), at most 64
/// characters. Empty only if both are.
pub fn kebab_id(prefix: &str, text: &str) -> String {
    let raw: String = text.to_lowercase().chars().map(|c| if c.is_ascii_alphanumeric() { c } else { '-' }).collect();
    let mut id: String = prefix.to_string();
    for part in raw.split('-').filter(|p| !p.is_empty()) {
        if !id.is_empty() {
            id.push('-');
        }
        id.push_str(part);
    }
    id.chars().take(64).collect::<String>().trim_end_matches('-').to_string()
}

/// Checks that `id` is non-empty kebab-case: `a-z`, `0-9` and single inner hyphens.
pub(crate) fn check_id(id: &str) -> Result<(), PresetError> {
    // (At most 64 characters of it: a tester's 100,000-character id was echoed whole.)
    let shown: String = id.chars().take(64).collect();
    let shown = if shown.len() < id.len() {
        format!("{shown:?}… ({} characters)", id.chars().count())
    } else {
        format!("{id:?}")
    };
    let bad = |reason: &str| {
        PresetError::invalid("id", format!("{reason} (found {shown}); use kebab-case like \"glass-ren2013\""))
    };
    if id.is_empty() {
        return Err(bad("must not be empty"));
    }
    if id.len() > 64 {
        return Err(bad("must be at most 64 characters"));
    }
    if !id.bytes().all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'-') {
        return Err(bad("may contain only lowercase letters a-z, digits and '-'"));
    }
    if id.starts_with('-') || id.ends_with('-') || id.contains("--") {
        return Err(bad("hyphens must separate words"));
    }
    Ok(())
}

/// Checks `schema_version` of an already-parsed value.
pub(crate) fn check_version(found: u32) -> Result<(), PresetError> {
    if found == SCHEMA_VERSION {
        Ok(())
    } else {
        Err(PresetError::SchemaVersion { found, supported: SCHEMA_VERSION })
    }
}

/// Checks that `name` is not blank.
pub(crate) fn check_name(name: &str) -> Result<(), PresetError> {
    if name.trim().is_empty() {
        Err(PresetError::invalid("name", "must not be empty; give a display name like \"Glass (Ren 2013)\""))
    } else {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Ids made from file names a user may give (`struck estimate --out a--b.json` failed
    /// after the whole analysis with "invalid `id`"): every one passes `check_id`.
    #[test]
    fn ids_from_any_text_pass_the_id_check() {
        let long = "x".repeat(63) + "-y";
        let cases = [
            ("captured", "a--b", "captured-a-b"),
            ("captured", "é", "captured"),
            ("captured", "-", "captured"),
            ("captured", "Steel Plate (2)", "captured-steel-plate-2"),
            ("captured", "--Glass__Bowl--", "captured-glass-bowl"),
            ("", "My  Bank!", "my-bank"),
            ("", "a-2", "a-2"),
            ("", long.as_str(), &"x".repeat(63)),
        ];
        for (prefix, text, want) in cases {
            let id = kebab_id(prefix, text);
            assert_eq!(id, want, "{prefix:?} {text:?}");
            check_id(&id).unwrap_or_else(|e| panic!("{text:?} -> {id:?}: {e}"));
        }
        assert_eq!(kebab_id("", "é-!"), "");
    }

    /// A refused id is quoted up to 64 characters (a tester's 100,000-character id made a
    /// 100 KB error line).
    #[test]
    fn a_refused_id_is_quoted_short() {
        let e = check_id(&"X".repeat(100_000)).unwrap_err().to_string();
        assert!(e.len() < 400 && e.contains("… (100000 characters)"), "{} chars: {}", e.len(), &e[..200]);
        let e = check_id("Glass").unwrap_err().to_string();
        assert!(e.contains("(found \"Glass\")"), "{e}");
    }
}
