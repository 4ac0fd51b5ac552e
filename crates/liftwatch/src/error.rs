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
    #[error("{}: no usable data: {why}", .path.display())]
    NoData {
        /// The file concerned.
        path: PathBuf,
        /// What was found instead.
        why: String,
    },
    /// A configuration value is out of its range.
    #[error("invalid setting `{field}`: {why}")]
    InvalidConfig {
        /// The setting's name.
        field: &'static str,
        /// What was expected.
        why: String,
    },
    /// The elevator description could not be read.
    #[error("{}: {why}", .path.display())]
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
    #[error("cannot fit: {0}")]
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
    #[error("{}: not a valid {what}: {why}", .path.display())]
    BadDocument {
        /// The file concerned.
        path: PathBuf,
        /// What kind of document was expected.
        what: &'static str,
        /// The parser's complaint.
        why: String,
    },
    /// A monitor state belongs to another model or is out of sequence.
    #[error("state does not fit: {0}")]
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
