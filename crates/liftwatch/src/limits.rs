//! Every bound on what an input may cost, in one place, each with its reason. A hostile or
//! broken file meets one of these and gets a one-line error instead of exhausting memory.
//!
//! ```text
//! model file        ≤ 16 MiB   a model is ~20 KiB (370 weights, settings, a thinned history)
//! monitor state     ≤ 1 MiB    a state is ~2 KiB
//! elevator.toml     ≤ 64 KiB   a description is a few lines
//! a telemetry line  ≤ 1 MiB    a row is under 200 bytes (an endless line, /dev/zero, is refused)
//! a model's string  ≤ 1000 chars   the longest is a parameter's name, ~30 characters
//! ```
//! The aligner bounds its output by its input (see [`crate::align::MAX_ROWS_PER_READING`]).

use std::io::Read;
use std::path::Path;

use crate::error::{Error, Result};

/// Largest model file read (bytes).
pub const MAX_MODEL_BYTES: u64 = 16 << 20;

/// Largest monitor state file read (bytes).
pub const MAX_STATE_BYTES: u64 = 1 << 20;

/// Largest elevator description read (bytes).
pub const MAX_TOML_BYTES: u64 = 64 << 10;

/// Longest line of a telemetry file (bytes).
pub const MAX_LINE_BYTES: u64 = 1 << 20;

/// Bytes a telemetry reader skips in search of the end of a line longer than
/// [`MAX_LINE_BYTES`] before it gives up: a log cut short by a crash ends in a few MiB of NUL
/// bytes, which is a bad row; 64 MiB without a line break (`/dev/zero`) is no text log.
pub const MAX_SKIPPED_BYTES: u64 = 64 << 20;

/// Longest string (value or key) a model file may hold: its strings are names, units and
/// choices of a few dozen characters; a longer one is a corrupted or hostile file, and would
/// otherwise be quoted into messages and reports.
pub const MAX_STRING_CHARS: usize = 1000;

/// The first string in `value` (a value or an object key) longer than `max_chars`, as a
/// one-line complaint naming where it is, e.g. `` `fit.parameters[0].name` ``.
///
/// # Errors
/// The complaint.
pub fn check_strings(
    value: &serde_json::Value,
    max_chars: usize,
) -> std::result::Result<(), String> {
    let too_long =
        |what: &str, n: usize| format!("{what} of {n} characters, expected at most {max_chars}");
    walk_json(value, "", &mut |at, place| match place {
        JsonPlace::Leaf(serde_json::Value::String(s)) if s.chars().count() > max_chars => {
            Err(too_long(&format!("`{at}` is a string"), s.chars().count()))
        }
        JsonPlace::Key(key) if key.chars().count() > max_chars => {
            let whose = if at.is_empty() {
                "the document".to_string()
            } else {
                format!("`{at}`")
            };
            Err(too_long(&format!("{whose} has a key"), key.chars().count()))
        }
        _ => Ok(()),
    })
}

/// A place of a JSON document as [`walk_json`] visits it: a key of an object, or a value that
/// holds no other (a string, number, boolean or null).
#[derive(Clone, Copy, Debug)]
pub enum JsonPlace<'a> {
    /// A key of the object at the path.
    Key(&'a str),
    /// The value at the path.
    Leaf(&'a serde_json::Value),
}

/// Visits every key and leaf of `value` in document order with its path (`a.b[2]`; `at` is
/// the path of `value` itself, empty for a whole document), until `f` fails: the one walk of
/// the documents' checks (strings too long here, a monitor state's non-finite sums).
///
/// # Errors
/// The first error of `f`.
pub fn walk_json<E>(
    value: &serde_json::Value,
    at: &str,
    f: &mut impl FnMut(&str, JsonPlace<'_>) -> std::result::Result<(), E>,
) -> std::result::Result<(), E> {
    match value {
        serde_json::Value::Array(items) => items
            .iter()
            .enumerate()
            .try_for_each(|(i, item)| walk_json(item, &format!("{at}[{i}]"), f)),
        serde_json::Value::Object(fields) => fields.iter().try_for_each(|(key, item)| {
            f(at, JsonPlace::Key(key))?;
            let at = if at.is_empty() {
                key.clone()
            } else {
                format!("{at}.{key}")
            };
            walk_json(item, &at, f)
        }),
        leaf => f(at, JsonPlace::Leaf(leaf)),
    }
}

/// Reads the whole of a small document, refusing one longer than `max_bytes` before reading
/// it all (the size is checked on the bytes read, so a FIFO or a growing file is bounded too).
///
/// # Errors
/// [`Error::Io`] when it cannot be read; [`Error::BadDocument`] when it is too large.
pub fn read_bounded(path: &Path, max_bytes: u64, what: &'static str) -> Result<Vec<u8>> {
    let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let mut bytes = Vec::new();
    file.take(max_bytes + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| Error::io(path, e))?;
    if bytes.len() as u64 > max_bytes {
        return Err(Error::BadDocument {
            path: path.into(),
            what,
            why: format!(
                "larger than {} KiB, the most a {what} can need",
                max_bytes >> 10
            ),
        });
    }
    Ok(bytes)
}

/// [`read_bounded`] as UTF-8 text.
///
/// # Errors
/// As [`read_bounded`]; [`Error::BadDocument`] when it is not UTF-8.
pub fn read_bounded_text(path: &Path, max_bytes: u64, what: &'static str) -> Result<String> {
    String::from_utf8(read_bounded(path, max_bytes, what)?).map_err(|_| Error::BadDocument {
        path: path.into(),
        what,
        why: "not UTF-8 text".into(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_document_over_its_bound_is_refused_without_reading_it_all() {
        let err = read_bounded(Path::new("/dev/zero"), 1 << 10, "monitor state").unwrap_err();
        assert!(err.to_string().contains("larger than 1 KiB"), "{err}");
        let dir = std::env::temp_dir().join(format!("lw-limits-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("m.json");
        std::fs::write(&f, "{}").unwrap();
        assert_eq!(read_bounded_text(&f, 2, "model").unwrap(), "{}");
        assert!(read_bounded_text(&f, 1, "model").is_err());
        let doc = serde_json::json!({"fit": {"parameters": [{"name": "x".repeat(11)}]}});
        assert!(check_strings(&doc, 11).is_ok());
        let err = check_strings(&doc, 10).unwrap_err();
        assert_eq!(
            err,
            "`fit.parameters[0].name` is a string of 11 characters, expected at most 10"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
