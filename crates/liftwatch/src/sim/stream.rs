//! Simulator: its raw telemetry as a stream of `raw.csv` text (DATA.md §1), read while it is
//! produced, so that a simulated run can go through the real ingest and alignment without a
//! file.
//!
//! ```text
//! simulator thread: raw rows → `time,signal,value` lines → chunks ─ bounded channel ─→ Read
//!                   truth rows → T (handed back by RawStream::finish)
//! ```
//!
//! The simulator runs on a background thread at most [`CHUNKS_AHEAD`] chunks of
//! [`CHUNK_BYTES`] ahead of the reader, so memory stays bounded whatever the span. Seeking
//! back to the start (the aligner reads its input again when a row comes later than its
//! reorder window) reruns the simulation from its seed, which writes the same text again.

use std::io::{self, Read, Seek, SeekFrom};
use std::sync::mpsc::{sync_channel, Receiver, SyncSender};
use std::thread::JoinHandle;

use super::logger::{push_raw_line, RAW_HEADER};
use super::{run, RawRow, SimConfig, SimSink, SimTruth, TruthRow};
use crate::error::{Error, Result};

/// Bytes of text handed over at once.
pub const CHUNK_BYTES: usize = 1 << 16;

/// Chunks the simulator may run ahead of the reader.
pub const CHUNKS_AHEAD: usize = 16;

/// The name a stream's messages give its input.
pub const STREAM_NAME: &str = "simulated raw.csv";

/// What the simulator thread hands back: the truth document and the truth sink.
type Outcome<T> = Result<(SimTruth, T)>;

/// The `raw.csv` text of one simulation, as a reader (see the module docs).
pub struct RawStream<T> {
    cfg: SimConfig,
    truth: T,
    rx: Receiver<Vec<u8>>,
    worker: Option<JoinHandle<Outcome<T>>>,
    chunk: Vec<u8>,
    pos: usize,
}

impl<T: SimSink + Clone + Send + 'static> RawStream<T> {
    /// Starts simulating `cfg`; every truth row goes to a copy of `truth` on the simulator's
    /// thread (a fresh copy when the stream is read again from the start).
    pub fn new(cfg: &SimConfig, truth: T) -> Self {
        let (rx, worker) = spawn(cfg.clone(), truth.clone());
        RawStream {
            cfg: cfg.clone(),
            truth,
            rx,
            worker: Some(worker),
            chunk: Vec::new(),
            pos: 0,
        }
    }

    /// Waits for the simulation to end (reading what the reader left) and hands back its
    /// truth document and its truth sink.
    ///
    /// # Errors
    /// Whatever the simulation failed with.
    pub fn finish(mut self) -> Outcome<T> {
        while self.rx.recv().is_ok() {}
        let worker = self
            .worker
            .take()
            .expect("a stream always has a worker until finished");
        worker.join().unwrap_or_else(|_| {
            Err(Error::io(
                STREAM_NAME,
                io::Error::other("the simulator thread panicked"),
            ))
        })
    }
}

/// Runs the simulation on its own thread, sending its text through a bounded channel.
fn spawn<T: SimSink + Send + 'static>(
    cfg: SimConfig,
    truth: T,
) -> (Receiver<Vec<u8>>, JoinHandle<Outcome<T>>) {
    let (tx, rx) = sync_channel(CHUNKS_AHEAD);
    let worker = std::thread::spawn(move || {
        let mut buf = Vec::with_capacity(CHUNK_BYTES + 64);
        buf.extend_from_slice(RAW_HEADER);
        let mut sink = Producer { tx, buf, truth };
        let doc = run(&cfg, &mut sink, &mut |_| {})?;
        let chunk = std::mem::take(&mut sink.buf);
        sink.send(chunk)?;
        Ok((doc, sink.truth))
    });
    (rx, worker)
}

/// The simulator-side sink: raw rows become text, truth rows go to `truth`.
struct Producer<T> {
    tx: SyncSender<Vec<u8>>,
    buf: Vec<u8>,
    truth: T,
}

impl<T> Producer<T> {
    fn send(&self, chunk: Vec<u8>) -> Result<()> {
        self.tx
            .send(chunk)
            .map_err(|_| Error::io(STREAM_NAME, io::Error::other("the reader stopped")))
    }
}

impl<T: SimSink> SimSink for Producer<T> {
    fn raw(&mut self, row: RawRow) -> Result<()> {
        push_raw_line(&mut self.buf, &row);
        if self.buf.len() >= CHUNK_BYTES {
            let full = std::mem::replace(&mut self.buf, Vec::with_capacity(CHUNK_BYTES + 64));
            self.send(full)?;
        }
        Ok(())
    }

    fn truth(&mut self, row: &TruthRow) -> Result<()> {
        self.truth.truth(row)
    }
}

impl<T> Read for RawStream<T> {
    fn read(&mut self, out: &mut [u8]) -> io::Result<usize> {
        while self.pos == self.chunk.len() {
            match self.rx.recv() {
                Ok(c) => (self.chunk, self.pos) = (c, 0),
                // The simulator is done (or failed: `finish` says so).
                Err(_) => return Ok(0),
            }
        }
        let n = out.len().min(self.chunk.len() - self.pos);
        out[..n].copy_from_slice(&self.chunk[self.pos..self.pos + n]);
        self.pos += n;
        Ok(n)
    }
}

impl<T: SimSink + Clone + Send + 'static> Seek for RawStream<T> {
    /// Only back to the start: the simulation is run again.
    fn seek(&mut self, to: SeekFrom) -> io::Result<u64> {
        if to != SeekFrom::Start(0) {
            return Err(io::Error::new(
                io::ErrorKind::Unsupported,
                "a simulated stream can only be read again from the start",
            ));
        }
        let (rx, worker) = spawn(self.cfg.clone(), self.truth.clone());
        // The old simulator stops at its next send, its receiver gone.
        drop(std::mem::replace(&mut self.rx, rx));
        if let Some(old) = self.worker.replace(worker) {
            let _ = old.join();
        }
        (self.chunk, self.pos) = (Vec::new(), 0);
        Ok(0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::elevator::Elevator;

    /// A truth sink that counts.
    #[derive(Clone, Default)]
    struct Count(u64);

    impl SimSink for Count {
        fn raw(&mut self, _: RawRow) -> Result<()> {
            Ok(())
        }
        fn truth(&mut self, _: &TruthRow) -> Result<()> {
            self.0 += 1;
            Ok(())
        }
    }

    #[test]
    fn the_stream_is_the_text_of_raw_csv_and_reads_again_from_the_start() {
        let cfg = SimConfig::new(Elevator::new(1000.0, 1.6, 10), 0.05, 4);
        let out = crate::sim::simulate(&cfg).unwrap();
        let mut want = RAW_HEADER.to_vec();
        for r in &out.raw {
            push_raw_line(&mut want, r);
        }
        let mut s = RawStream::new(&cfg, Count::default());
        let mut head = vec![0; 1000];
        s.read_exact(&mut head).unwrap();
        assert_eq!(head, want[..1000]);
        s.seek(SeekFrom::Start(0)).unwrap();
        let mut text = Vec::new();
        s.read_to_end(&mut text).unwrap();
        assert!(text == want, "the text differs from the rows");
        let (doc, count) = s.finish().unwrap();
        assert_eq!(count.0, doc.summary.truth_rows);
        assert!(s_is_unsupported(&cfg));
    }

    fn s_is_unsupported(cfg: &SimConfig) -> bool {
        let mut s = RawStream::new(cfg, Count::default());
        let e = s.seek(SeekFrom::Current(1)).unwrap_err();
        s.finish().is_ok() && e.kind() == io::ErrorKind::Unsupported
    }
}
