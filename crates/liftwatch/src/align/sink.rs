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

use std::io;
use std::path::{Path, PathBuf};

use super::writer::AlignedWriter;
use crate::error::{Error, Result};
use crate::output::AtomicFile;
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

/// A [`SampleSink`] writing an aligned CSV file through the one atomic writer
/// ([`AtomicFile`]): a restart rewrites it from the start, and the file appears at its path
/// only when [`AlignedFileSink::finish`] commits it, so a failed run leaves no partial file.
pub struct AlignedFileSink {
    state: FileState,
}

/// Where the sink is: before the first `start`, writing, or broken by an earlier error.
enum FileState {
    Fresh(AtomicFile),
    Writing(AlignedWriter<AtomicFile>),
    Broken(PathBuf),
}

impl AlignedFileSink {
    /// Starts a write of `path`; nothing is written before `start`.
    ///
    /// # Errors
    /// [`Error::Io`] naming `path`.
    pub fn create(path: &Path) -> Result<Self> {
        Ok(AlignedFileSink {
            state: FileState::Fresh(AtomicFile::create_data(path)?),
        })
    }

    /// The file, its writer flushed and taken apart when there is one.
    fn take_file(&mut self) -> Result<AtomicFile> {
        let path = match &self.state {
            FileState::Fresh(f) => f.path().to_path_buf(),
            FileState::Writing(w) => w.get_ref().path().to_path_buf(),
            FileState::Broken(p) => p.clone(),
        };
        match std::mem::replace(&mut self.state, FileState::Broken(path.clone())) {
            FileState::Fresh(f) => Ok(f),
            FileState::Writing(w) => w.finish().map_err(|e| Error::io(&path, e)),
            FileState::Broken(p) => Err(Error::io(
                &p,
                io::Error::other("not written after an earlier error"),
            )),
        }
    }

    /// Flushes everything to disk and moves the file into place.
    ///
    /// # Errors
    /// [`Error::Io`] naming the file.
    pub fn finish(mut self) -> Result<()> {
        self.take_file()?.commit()
    }
}

impl SampleSink for AlignedFileSink {
    type Error = Error;

    fn start(&mut self, has_current: bool) -> Result<()> {
        let restart = matches!(self.state, FileState::Writing(_));
        let mut file = self.take_file()?;
        if restart {
            file.restart()?;
        }
        let path = file.path().to_path_buf();
        let w = AlignedWriter::new(file, has_current).map_err(|e| Error::io(&path, e))?;
        self.state = FileState::Writing(w);
        Ok(())
    }

    fn push(&mut self, sample: &Sample) -> Result<()> {
        match &mut self.state {
            FileState::Writing(w) => w
                .write(sample)
                .map_err(|e| Error::io(w.get_ref().path(), e)),
            FileState::Fresh(f) => Err(Error::io(
                f.path(),
                io::Error::other("a sample before the start of the series"),
            )),
            FileState::Broken(p) => Err(Error::io(
                &*p,
                io::Error::other("not written after an earlier error"),
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
