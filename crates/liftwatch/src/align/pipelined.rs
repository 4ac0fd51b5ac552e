//! Reading beside the sink: [`align_file_pipelined`] reads, parses and aligns a file on a
//! thread of its own and hands the samples to the sink on the calling thread, in batches.
//!
//! ```text
//! reader thread:  file ─ records ─ alignment ─ batches of BATCH samples ─┐ at most IN_FLIGHT
//! calling thread:                       sink.start / sink.push, in order ◄┘ batches between them
//! ```
//!
//! The sink sees the calls [`align_file`](super::align_file) makes, less the pushes of an
//! abandoned pass still waiting in a batch: `start` (again when alignment has to read the
//! file a second time; the samples of the first pass still in the reader's batch are dropped
//! there, as the restart says they are to be forgotten), then every sample in order. On a
//! machine with a second core the monitor's step and its output run while the next rows are
//! read, which was two fifths of a whole `monitor` run. An error of alignment reaches the
//! caller after every sample read before it, as it would without the thread. An error of the
//! sink stops the reader at its next batch (a reader that has just begun a sorted pass reads
//! and sorts the whole file before it sends again, so the caller may wait that long for it).

use std::io;
use std::path::Path;
use std::sync::mpsc::{sync_channel, Receiver, SyncSender};

use super::{align_reader, AlignConfig, SampleSink};
use crate::error::Error;
use crate::ingest::IngestReport;
use crate::input::Input;
use crate::sample::Sample;

/// Samples handed over at once: 4096 of 64 bytes, 256 KiB, a little over an hour at 1 Hz.
/// Large enough that the two threads meet only about 630 times in a month of data, small
/// enough to stay in the second-level cache of the core that reads it next.
const BATCH: usize = 4096;

/// Batches filled and not yet taken by the sink: the reader runs at most this far ahead (1 MiB
/// with [`BATCH`]; with the batch being filled, the one being taken and the emptied ones
/// coming back for reuse, under 3 MiB in all), so memory stays bounded whatever the file's
/// length.
const IN_FLIGHT: usize = 4;

/// What the reader sends.
enum Message {
    /// [`SampleSink::start`] with its argument.
    Start(bool),
    /// The next samples in order.
    Samples(Vec<Sample>),
}

/// Why the reader stopped early.
enum Stop {
    /// Alignment failed.
    Align(Error),
    /// The sink failed and stopped taking batches.
    SinkGone,
}

impl From<Error> for Stop {
    fn from(e: Error) -> Self {
        Stop::Align(e)
    }
}

/// The reader's sink: fills a batch and sends it when full.
struct Forward {
    to_sink: SyncSender<Message>,
    /// Emptied batches coming back, so that a run allocates a handful of them.
    spare: Receiver<Vec<Sample>>,
    batch: Vec<Sample>,
}

impl Forward {
    fn flush(&mut self) -> Result<(), Stop> {
        if self.batch.is_empty() {
            return Ok(());
        }
        let next = self
            .spare
            .try_recv()
            .unwrap_or_else(|_| Vec::with_capacity(BATCH));
        let full = std::mem::replace(&mut self.batch, next);
        self.to_sink
            .send(Message::Samples(full))
            .map_err(|_| Stop::SinkGone)
    }
}

impl SampleSink for Forward {
    type Error = Stop;

    fn start(&mut self, has_current: bool) -> Result<(), Stop> {
        self.batch.clear();
        self.to_sink
            .send(Message::Start(has_current))
            .map_err(|_| Stop::SinkGone)
    }

    fn push(&mut self, sample: &Sample) -> Result<(), Stop> {
        self.batch.push(*sample);
        if self.batch.len() >= BATCH {
            self.flush()?;
        }
        Ok(())
    }
}

/// [`align_file`](super::align_file), with the reading on a thread of its own beside `sink`
/// (the module's notes): the same samples, the same report, the same errors; a sink that
/// has a pass restarted is spared the pushes it would have forgotten.
///
/// # Errors
/// As [`align_file`](super::align_file): alignment's errors, converted, and the sink's own.
pub fn align_file_pipelined<S: SampleSink>(
    path: &Path,
    cfg: &AlignConfig,
    sink: &mut S,
) -> Result<IngestReport, S::Error> {
    let (to_sink, from_reader) = sync_channel(IN_FLIGHT);
    let (to_reader, spare) = sync_channel(IN_FLIGHT + 1);
    std::thread::scope(|scope| {
        let reader = scope.spawn(move || {
            let mut forward = Forward {
                to_sink,
                spare,
                batch: Vec::with_capacity(BATCH),
            };
            let input = Input::open(path)?;
            let name = input.name().to_path_buf();
            let aligned = align_reader(input, &name, cfg, &mut forward);
            // The samples read before an error reach the sink before it, as without the thread.
            forward.flush()?;
            aligned
        });
        let mut failed = None;
        for message in &from_reader {
            let taken = match message {
                Message::Start(has_current) => sink.start(has_current),
                Message::Samples(mut batch) => {
                    let pushed = batch.iter().try_for_each(|s| sink.push(s));
                    batch.clear();
                    // The reader may have finished: a batch nobody reuses is just freed.
                    let _ = to_reader.try_send(batch);
                    pushed
                }
            };
            if let Err(e) = taken {
                failed = Some(e);
                break;
            }
        }
        // A reader still sending finds no one taking its batches and stops.
        drop(from_reader);
        let read = reader
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic));
        match (failed, read) {
            (Some(e), _) => Err(e),
            (None, Ok(report)) => Ok(report),
            (None, Err(Stop::Align(e))) => Err(e.into()),
            // The sink took every batch the reader sent, so the reader cannot have found it
            // gone; said as an error of the input rather than assumed away.
            (None, Err(Stop::SinkGone)) => Err(Error::io(
                path,
                io::Error::new(io::ErrorKind::BrokenPipe, "the samples stopped being taken"),
            )
            .into()),
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::align::align_file;
    use crate::error::Result;
    use crate::input::tests::scratch;

    /// A sink that keeps what the contract says it holds (the samples since the last
    /// start), counts the starts, and fails at a chosen sample.
    #[derive(Default)]
    struct Calls {
        log: Vec<String>,
        starts: usize,
        fail_at: Option<usize>,
        pushed: usize,
    }

    impl SampleSink for Calls {
        type Error = Error;

        fn start(&mut self, has_current: bool) -> Result<()> {
            self.log.clear();
            self.starts += 1;
            self.log.push(format!("start {has_current}"));
            Ok(())
        }

        fn push(&mut self, s: &Sample) -> Result<()> {
            if self.fail_at == Some(self.pushed) {
                return Err(Error::InvalidConfig {
                    field: "sink",
                    why: "full".into(),
                });
            }
            self.pushed += 1;
            // Debug prints each float's shortest round-trip text: equal texts, equal values.
            self.log.push(format!("{s:?}"));
            Ok(())
        }
    }

    /// Whether two sinks hold the same calls, saying where they part when they do not
    /// (without printing thousands of them).
    fn same_calls(one: &Calls, two: &Calls) -> std::result::Result<(), String> {
        let differ = one.log.iter().zip(&two.log).position(|(a, b)| a != b);
        if differ.is_some() || one.log.len() != two.log.len() || one.starts != two.starts {
            return Err(format!(
                "first difference at {differ:?} of {} and {} calls, {} and {} starts",
                one.log.len(),
                two.log.len(),
                one.starts,
                two.starts
            ));
        }
        Ok(())
    }

    fn write(dir: &Path, name: &str, text: &str) -> std::path::PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    /// A raw log of `n` seconds with a bad row, `current` appearing half-way (a restart) and
    /// a row later than the reorder window at the end (the file is read again, sorted: a
    /// restart of its own).
    fn raw_log(n: usize) -> String {
        let mut s = String::from("time,signal,value\n");
        for k in 0..n {
            let t = k as f64;
            s += &format!(
                "{t},speed,{}\n{t},voltage,{}\n",
                (k % 7) as f64 * 0.1,
                5.0 + t
            );
            s += &format!("{t},direction,1\n{t},load,10\n{t},door,0\n{t},floor,3\n");
            if k == 10 {
                s += "oops,speed,1\n";
            }
            if k == n / 2 {
                s += &format!("{t},current,12\n");
            }
        }
        s += "3.5,speed,0.2\n";
        s
    }

    #[test]
    fn the_sink_sees_the_calls_and_the_report_of_one_thread() {
        let dir = scratch("pipelined-calls");
        let cfg = AlignConfig::default().with_reorder_window(60.0).unwrap();
        // Longer than a batch, so that samples are waiting in one when a restart comes.
        let raw = write(&dir, "raw.csv", &raw_log(3 * BATCH + 500));
        let mut aligned = String::from("time,speed,direction,voltage,load,door,floor\n");
        for k in 0..2 * BATCH + 17 {
            aligned += &format!("{k},0.5,1,{},10,0,2\n", k % 13);
        }
        let aligned = write(&dir, "aligned.csv", &aligned);
        for (path, restarted) in [(raw, true), (aligned, false)] {
            let (mut one, mut two) = (Calls::default(), Calls::default());
            let a = align_file(&path, &cfg, &mut one).unwrap();
            let b = align_file_pipelined(&path, &cfg, &mut two).unwrap();
            assert!(one.log.len() > 2 * BATCH, "{}", one.log.len());
            same_calls(&one, &two).unwrap();
            assert_eq!(format!("{a:?}"), format!("{b:?}"));
            assert_eq!(two.starts > 1, restarted, "{}", path.display());
            // A restart came with first-pass samples waiting in a batch: dropped unsent.
            assert_eq!(two.pushed < one.pushed, restarted, "{}", path.display());
        }
    }

    #[test]
    fn an_error_of_either_side_comes_back_as_it_would_without_the_thread() {
        let dir = scratch("pipelined-errors");
        let cfg = AlignConfig::default();
        let mut text = String::from("time,speed,direction,voltage,load,door,floor\n");
        for k in 0..3 * BATCH {
            text += &format!("{k},0,0,5,10,0,2\n");
        }
        let path = write(&dir, "a.csv", &text);
        // The sink fails in the second batch: its error, and nothing pushed after it.
        let (mut one, mut two) = (Calls::default(), Calls::default());
        one.fail_at = Some(BATCH + 5);
        two.fail_at = Some(BATCH + 5);
        let a = align_file(&path, &cfg, &mut one).unwrap_err().to_string();
        let b = align_file_pipelined(&path, &cfg, &mut two)
            .unwrap_err()
            .to_string();
        assert_eq!(a, b);
        same_calls(&one, &two).unwrap();
        // An input that breaks off after more than a batch (a truncated gzip file): every
        // sample read before the break reaches the sink, then the same error.
        let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
        std::io::Write::write_all(&mut gz, text.as_bytes()).unwrap();
        let bytes = gz.finish().unwrap();
        let cut = dir.join("cut.csv.gz");
        std::fs::write(&cut, &bytes[..bytes.len() * 2 / 3]).unwrap();
        let (mut one, mut two) = (Calls::default(), Calls::default());
        let a = align_file(&cut, &cfg, &mut one).unwrap_err().to_string();
        let b = align_file_pipelined(&cut, &cfg, &mut two)
            .unwrap_err()
            .to_string();
        assert_eq!(a, b);
        assert!(
            one.pushed > BATCH,
            "{} samples before the break",
            one.pushed
        );
        same_calls(&one, &two).unwrap();
        // A file that is not there, and one with no usable row.
        write(&dir, "empty.csv", "time,signal,value\nx,speed,1\n");
        for name in ["missing.csv", "empty.csv"] {
            let p = dir.join(name);
            let a = align_file(&p, &cfg, &mut Calls::default()).unwrap_err();
            let b = align_file_pipelined(&p, &cfg, &mut Calls::default()).unwrap_err();
            assert_eq!(a.to_string(), b.to_string());
        }
    }
}
