//! Stage 2, the receiving end: [`SampleSink`] and the sinks the library provides
//! (paper, Sec. 4.1; DATA.md §2).
//!
//! ```text
//! start(has_current)   before the first sample; again = forget everything, the input is re-read
//! push(sample)         t_k in increasing order, one per grid point
//! ```
//!
//! A sink has its own error type, as ripgrep's `Sink` does: alignment's own errors are
//! converted into it (`From<liftwatch::Error>`), and the sink's errors come back from
//! [`super::align_reader`] unchanged, so a caller never wraps its errors as I/O errors.

use std::fs::File;
use std::io::{self, BufWriter, Seek, SeekFrom};
use std::path::{Path, PathBuf};

use super::writer::AlignedWriter;
use crate::error::{Error, Result};
use crate::sample::Sample;

/// Receives aligned samples in time order.
///
/// The sink names its own error type, as ripgrep's `Sink` does with `type Error: SinkError`.
/// Alignment fails with the sink's error unchanged, and turns its own failures (an unreadable
/// file, no data, a span beyond the limit) into it through `From<liftwatch::Error>`: a sink
/// in the library uses [`Error`], one in an application can use its own (`anyhow::Error`
/// qualifies).
pub trait SampleSink {
    /// What the sink fails with; alignment's own errors convert into it.
    type Error: From<Error>;

    /// Called before the first sample. A second call means the input had to be read
    /// again (a row came later than the reorder window, or `current` appeared late):
    /// everything pushed before must be forgotten. `has_current` says whether the
    /// series carries the optional `current` signal.
    ///
    /// # Errors
    /// Whatever the sink cannot do; alignment stops with it.
    fn start(&mut self, has_current: bool) -> Result<(), Self::Error>;

    /// Receives the next sample; times increase by the step.
    ///
    /// # Errors
    /// Whatever the sink cannot do; alignment stops with it.
    fn push(&mut self, sample: &Sample) -> Result<(), Self::Error>;
}

impl SampleSink for Vec<Sample> {
    type Error = Error;

    fn start(&mut self, _has_current: bool) -> Result<()> {
        self.clear();
        Ok(())
    }

    fn push(&mut self, sample: &Sample) -> Result<()> {
        self.push(*sample);
        Ok(())
    }
}

/// A sink made of two closures, see [`sink_fn`].
pub struct FnSink<A, B> {
    on_start: A,
    on_sample: B,
}

impl<A, B, E> SampleSink for FnSink<A, B>
where
    A: FnMut(bool) -> Result<(), E>,
    B: FnMut(&Sample) -> Result<(), E>,
    E: From<Error>,
{
    type Error = E;

    fn start(&mut self, has_current: bool) -> Result<(), E> {
        (self.on_start)(has_current)
    }

    fn push(&mut self, sample: &Sample) -> Result<(), E> {
        (self.on_sample)(sample)
    }
}

/// A sink from closures: `on_start(has_current)` (which must reset the consumer when
/// called again) and `on_sample(sample)`. Both fail with the same error type `E`, the
/// sink's; closures that never fail name it where they return, e.g. `Ok::<_, Error>(())`.
pub fn sink_fn<A, B, E>(on_start: A, on_sample: B) -> FnSink<A, B>
where
    A: FnMut(bool) -> Result<(), E>,
    B: FnMut(&Sample) -> Result<(), E>,
    E: From<Error>,
{
    FnSink {
        on_start,
        on_sample,
    }
}

/// A [`SampleSink`] writing an aligned CSV file; a restart truncates the file.
pub struct AlignedFileSink {
    path: PathBuf,
    file: Option<File>,
    writer: Option<AlignedWriter<BufWriter<File>>>,
}

impl AlignedFileSink {
    /// Creates (or truncates) the file at `path`; nothing is written before `start`.
    ///
    /// # Errors
    /// [`Error::Io`] naming `path`.
    pub fn create(path: &Path) -> Result<Self> {
        let file = File::create(path).map_err(|e| Error::io(path, e))?;
        Ok(AlignedFileSink {
            path: path.to_path_buf(),
            file: Some(file),
            writer: None,
        })
    }

    /// The file, its writer flushed and taken apart when there is one.
    fn take_file(&mut self) -> Result<File> {
        if let Some(w) = self.writer.take() {
            let buf = w.finish().map_err(|e| Error::io(&self.path, e))?;
            return buf
                .into_inner()
                .map_err(|e| Error::io(&self.path, e.into_error()));
        }
        self.file.take().ok_or_else(|| {
            Error::io(
                &self.path,
                io::Error::other("file closed after an earlier error"),
            )
        })
    }

    /// Flushes everything to disk.
    ///
    /// # Errors
    /// [`Error::Io`] naming the file.
    pub fn finish(mut self) -> Result<()> {
        let file = self.take_file()?;
        file.sync_all().map_err(|e| Error::io(&self.path, e))
    }
}

impl SampleSink for AlignedFileSink {
    type Error = Error;

    fn start(&mut self, has_current: bool) -> Result<()> {
        let restart = self.writer.is_some();
        let mut file = self.take_file()?;
        let io = |e| Error::io(&self.path, e);
        if restart {
            file.set_len(0).map_err(io)?;
            file.seek(SeekFrom::Start(0)).map_err(io)?;
        }
        let buf = BufWriter::with_capacity(1 << 16, file);
        self.writer = Some(AlignedWriter::new(buf, has_current).map_err(io)?);
        Ok(())
    }

    fn push(&mut self, sample: &Sample) -> Result<()> {
        match &mut self.writer {
            Some(w) => w.write(sample).map_err(|e| Error::io(&self.path, e)),
            None => Err(Error::io(
                &self.path,
                io::Error::other("sample before start"),
            )),
        }
    }
}
#[cfg(test)]
mod tests {
    use super::*;
    use crate::align::ALIGNED_HEADER;

    #[test]
    fn file_sink_restart_truncates() {
        let dir = std::env::temp_dir().join(format!("liftwatch-align-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("sink.csv");
        let mut sink = AlignedFileSink::create(&path).unwrap();
        sink.start(false).unwrap();
        for i in 0..100 {
            sink.push(&Sample::missing(f64::from(i))).unwrap();
        }
        sink.start(true).unwrap();
        sink.push(&Sample::missing(7.0)).unwrap();
        sink.finish().unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert_eq!(text, format!("{ALIGNED_HEADER},current\n7,,,,,,,\n"));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
