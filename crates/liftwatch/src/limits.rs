//! Every bound on what an input may cost, in one place, each with its reason. A hostile or
//! broken file meets one of these and gets a one-line error instead of exhausting memory.
//!
//! ```text
//! model file        ≤ 16 MiB   a model is ~20 KiB (370 weights, settings, a thinned history)
//! monitor state     ≤ 1 MiB    a state is ~2 KiB
//! elevator.toml     ≤ 64 KiB   a description is a few lines
//! ```

use std::io::Read;
use std::path::Path;

use crate::error::{Error, Result};

/// Largest model file read (bytes).
pub const MAX_MODEL_BYTES: u64 = 16 << 20;

/// Largest monitor state file read (bytes).
pub const MAX_STATE_BYTES: u64 = 1 << 20;

/// Largest elevator description read (bytes).
pub const MAX_TOML_BYTES: u64 = 64 << 10;

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
        let _ = std::fs::remove_dir_all(&dir);
    }
}
