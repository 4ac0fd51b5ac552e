//! The one error type of the library.
//!
//! Messages are lowercase, end without a period, name the file, line or field and say
//! what was expected. Bad *rows* are not errors: ingest counts them in an
//! [`IngestReport`](crate::ingest::IngestReport).

use std::path::PathBuf;

/// Everything that can go wrong in the library.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A file could not be opened, read or written.
    #[error("{}: {err}", .path.display())]
    Io {
        /// The file concerned.
        path: PathBuf,
        /// The operating-system error. In the message, and deliberately not a chained cause
        /// (thiserror would chain a field named `source`), so a one-line `{:#}` print states it once.
        err: std::io::Error,
    },
    /// The header matches neither the raw nor the aligned layout.
    #[error("{}: unknown layout, expected header `time,signal,value` or `time,speed,direction,voltage,load,door,floor`", .path.display())]
    UnknownLayout {
        /// The file concerned.
        path: PathBuf,
    },
    /// The file is empty or holds no usable row.
    #[error("{}: no usable data: {}", .path.display(), clip(.why))]
    NoData {
        /// The file concerned.
        path: PathBuf,
        /// What was found instead.
        why: String,
    },
    /// A configuration value is out of its range.
    #[error("invalid setting `{field}`: {}", clip(.why))]
    InvalidConfig {
        /// The setting's name.
        field: &'static str,
        /// What was expected.
        why: String,
    },
    /// The elevator description could not be read.
    #[error("{}: {}", .path.display(), clip(.why))]
    Elevator {
        /// The file concerned.
        path: PathBuf,
        /// What is wrong.
        why: String,
    },
    /// Fitting needs enough samples with |v| above the motion threshold.
    #[error("too little moving data to fit: {moving_s:.0} s moving in {trips} trips, need {need_s:.0} s in {need_trips} trips")]
    TooLittleMotion {
        /// Seconds of motion found.
        moving_s: f64,
        /// Trips found.
        trips: usize,
        /// Seconds of motion needed.
        need_s: f64,
        /// Trips needed.
        need_trips: usize,
    },
    /// The data cannot determine the model (no standstill, constant load, one direction, ...).
    #[error("cannot fit: {}", clip(.0))]
    Unidentifiable(String),
    /// The model file was written by a format this build does not read.
    #[error("{}: model format version {found} is not supported (this build reads {supported})", .path.display())]
    ModelVersion {
        /// The model file.
        path: PathBuf,
        /// The version found in the file.
        found: u32,
        /// The version this build reads.
        supported: u32,
    },
    /// The model or state file is not a valid document of its kind.
    #[error("{}: not a valid {what}: {}", .path.display(), clip(.why))]
    BadDocument {
        /// The file concerned.
        path: PathBuf,
        /// What kind of document was expected.
        what: &'static str,
        /// The parser's complaint.
        why: String,
    },
    /// A monitor state belongs to another model or is out of sequence.
    #[error("state does not fit: {}", clip(.0))]
    StateMismatch(String),
}

/// The library's result type.
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// Wraps an I/O error with the path it concerns.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            err: source,
        }
    }
}

/// The longest explanation an error message carries (characters): a parser's complaint can
/// quote its input, and a hostile input can be megabytes long; one line stays readable.
pub const MAX_WHY_CHARS: usize = 240;

/// `why` cut to [`MAX_WHY_CHARS`] characters, with `…` where it was cut, and on one line.
pub fn clip(why: &str) -> String {
    let one_line: String = why
        .chars()
        .map(|c| if c.is_control() { ' ' } else { c })
        .take(MAX_WHY_CHARS + 1)
        .collect();
    if one_line.chars().count() > MAX_WHY_CHARS {
        let mut cut: String = one_line.chars().take(MAX_WHY_CHARS).collect();
        cut.push('…');
        cut
    } else {
        one_line
    }
}

/// `Ok` when `v` is finite and within `lo..=hi`, else a message naming `field` and the range:
/// the one range check of every settings validation.
///
/// # Errors
/// The message, for the caller to wrap in its own error.
pub fn check_range(field: &str, v: f64, lo: f64, hi: f64) -> std::result::Result<(), String> {
    if v.is_finite() && (lo..=hi).contains(&v) {
        Ok(())
    } else {
        Err(format!(
            "`{field}` = {} is out of range, expected {} to {}",
            number(v),
            number(lo),
            number(hi)
        ))
    }
}

/// Longest plain rendering of a number in a message; a longer one (`1e308` has 309 digits)
/// is written in exponent form, so the range after it still fits in the line.
const MAX_PLAIN_NUMBER_CHARS: usize = 20;

/// `v` as `{}` writes it when that is short, else as `{:e}`.
pub fn number(v: f64) -> String {
    let plain = v.to_string();
    if plain.len() <= MAX_PLAIN_NUMBER_CHARS {
        plain
    } else {
        format!("{v:e}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_long_complaint_is_cut_to_one_short_line() {
        let long = format!("bad value `{}`\nsecond line", "x".repeat(10_000));
        let err = Error::BadDocument {
            path: "m.json".into(),
            what: "liftwatch model",
            why: long,
        };
        let text = err.to_string();
        assert!(text.chars().count() < MAX_WHY_CHARS + 60, "{}", text.len());
        assert!(!text.contains('\n') && text.ends_with('…'));
        assert_eq!(clip("short"), "short");
    }

    #[test]
    fn ranges_refuse_non_finite_and_outside_values() {
        assert!(check_range("kd", 0.5, 0.0, 1.0).is_ok());
        for v in [f64::NAN, f64::INFINITY, -1.0, 1e308] {
            let msg = check_range("kd", v, 0.0, 1.0).unwrap_err();
            assert!(msg.starts_with("`kd` ="), "{msg}");
            assert!(msg.ends_with("expected 0 to 1"), "{msg}");
        }
        let tiny = check_range("s", 1e-308, 1e-9, 1.0).unwrap_err();
        assert_eq!(
            tiny,
            "`s` = 1e-308 is out of range, expected 0.000000001 to 1"
        );
    }
}
