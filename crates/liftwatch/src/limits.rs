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

/// A reader that fails on a line longer than [`MAX_LINE_BYTES`], so that a file without line
/// breaks cannot make a CSV reader buffer it whole.
#[derive(Debug)]
pub struct LineBounded<R> {
    inner: R,
    /// Bytes since the last `\n`.
    run: u64,
}

impl<R> LineBounded<R> {
    /// Wraps `inner`.
    pub fn new(inner: R) -> Self {
        LineBounded { inner, run: 0 }
    }

    /// The wrapped reader.
    pub fn into_inner(self) -> R {
        self.inner
    }
}

impl<R: Read> Read for LineBounded<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        let chunk = &buf[..n];
        // Only the first and the last line of a chunk can be long: find their ends.
        let (head, tail) = match (
            chunk.iter().position(|&b| b == b'\n'),
            chunk.iter().rposition(|&b| b == b'\n'),
        ) {
            (Some(first), Some(last)) => (self.run + first as u64, (n - last - 1) as u64),
            _ => (self.run + n as u64, self.run + n as u64),
        };
        if head.max(tail) > MAX_LINE_BYTES {
            return Err(std::io::Error::new(
                std::io::ErrorKind::InvalidData,
                format!("a line longer than {} KiB", MAX_LINE_BYTES >> 10),
            ));
        }
        self.run = tail;
        Ok(n)
    }
}

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
    fn walk(v: &serde_json::Value, at: &str, max: usize) -> std::result::Result<(), String> {
        let too_long =
            |what: &str, n: usize| format!("{what} of {n} characters, expected at most {max}");
        match v {
            serde_json::Value::String(s) if s.chars().count() > max => {
                Err(too_long(&format!("`{at}` is a string"), s.chars().count()))
            }
            serde_json::Value::Array(items) => items
                .iter()
                .enumerate()
                .try_for_each(|(i, item)| walk(item, &format!("{at}[{i}]"), max)),
            serde_json::Value::Object(fields) => fields.iter().try_for_each(|(key, item)| {
                if key.chars().count() > max {
                    let whose = if at.is_empty() {
                        "the document".to_string()
                    } else {
                        format!("`{at}`")
                    };
                    return Err(too_long(&format!("{whose} has a key"), key.chars().count()));
                }
                let at = if at.is_empty() {
                    key.clone()
                } else {
                    format!("{at}.{key}")
                };
                walk(item, &at, max)
            }),
            _ => Ok(()),
        }
    }
    walk(value, "", max_chars)
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
    fn an_endless_line_is_refused_and_short_lines_pass() {
        let mut endless = LineBounded::new(std::io::repeat(b'7'));
        let mut sink = Vec::new();
        let err = std::io::copy(&mut endless, &mut sink).unwrap_err();
        assert!(err.to_string().contains("longer than 1024 KiB"), "{err}");
        assert!(sink.len() as u64 <= 2 * MAX_LINE_BYTES);
        let text = "time,signal,value\n1,speed,0.5\n".repeat(100_000);
        let mut ok = LineBounded::new(text.as_bytes());
        let mut out = Vec::new();
        std::io::copy(&mut ok, &mut out).unwrap();
        assert_eq!(out.len(), text.len());
    }

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
