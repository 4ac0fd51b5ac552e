//! A file's aligned samples spilled to disk as they are aligned, for a reader that reads them
//! more than once without holding them: the fit ([`crate::sample::History`]), whose passes
//! over a month's log held 64 bytes a sample in memory.
//!
//! ```text
//! sample      time, speed, direction, voltage, load, door, floor, current: 8 × f64, little-endian
//! file        a temporary file in the directory the caller names (the CLI's: the model's, on
//!             a disk, where /tmp may be memory), removed from the directory as soon as it is
//!             open, so that nothing is left behind when the process ends, however it ends
//! read        each pass from the first sample, CHUNK_SAMPLES at a time, bit for bit as pushed
//! ```

use std::fs::File;
use std::io::{self, BufWriter, Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;

use super::{align_file, AlignConfig, SampleSink};
use crate::error::{Error, Result};
use crate::ingest::IngestReport;
use crate::sample::{History, Sample};

/// Bytes of one spilled sample: its eight signals as `f64`.
const SAMPLE_BYTES: usize = 64;

/// Samples read back at a time: 256 KiB, 633 reads for a pass over 30 days at 1 Hz.
const CHUNK_SAMPLES: usize = 4096;

/// Numbers the spill files of one process apart.
static NEXT_SPILL: AtomicU64 = AtomicU64::new(0);

/// The receiving end that writes each sample to the spill file; [`SpillSink::finish`] turns it
/// into the [`SpilledSeries`] it holds.
pub struct SpillSink {
    out: BufWriter<File>,
    /// Where the file was created (gone from its directory on Unix once open).
    path: PathBuf,
    /// Samples written since the last start.
    len: u64,
    /// Times of the first and the last of them (s), NaN before the first.
    first_time: f64,
    last_time: f64,
}

impl SpillSink {
    /// A sink writing to a new temporary file in `dir`.
    ///
    /// # Errors
    /// [`Error::Io`] when `dir` cannot take a file.
    pub fn new_in(dir: &Path) -> Result<SpillSink> {
        let n = NEXT_SPILL.fetch_add(1, Ordering::Relaxed);
        let path = dir.join(format!(".liftwatch-spill.{}.{n}.tmp", std::process::id()));
        let file = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .create_new(true)
            .open(&path)
            // The directory is what the caller named and what is wrong: missing, read-only.
            .map_err(|e| Error::io(dir, e))?;
        // Open files outlive their name on Unix: removed now, the spill cannot outlive the
        // process. Elsewhere the name goes when the series is dropped.
        #[cfg(unix)]
        std::fs::remove_file(&path).map_err(|e| Error::io(&path, e))?;
        Ok(SpillSink {
            out: BufWriter::with_capacity(CHUNK_SAMPLES * SAMPLE_BYTES, file),
            path,
            len: 0,
            first_time: f64::NAN,
            last_time: f64::NAN,
        })
    }

    /// The spilled series at step `step_s`: the file flushed, ready to be read.
    ///
    /// # Errors
    /// [`Error::Io`] when the last samples cannot be written.
    pub fn finish(self, step_s: f64) -> Result<SpilledSeries> {
        let path = self.path;
        let file = self
            .out
            .into_inner()
            .map_err(|e| Error::io(&path, e.into_error()))?;
        Ok(SpilledSeries {
            file: Mutex::new(file),
            path,
            step_s,
            len: self.len,
            first_time: self.first_time,
            last_time: self.last_time,
        })
    }

    fn io(&self, e: io::Error) -> Error {
        Error::io(&self.path, e)
    }
}

impl SampleSink for SpillSink {
    type Error = Error;

    fn start(&mut self, _has_current: bool) -> Result<()> {
        // Read again from the start: what was spilled is forgotten.
        self.out.flush().map_err(|e| self.io(e))?;
        let file = self.out.get_mut();
        let rewound = file.set_len(0).and_then(|()| file.seek(SeekFrom::Start(0)));
        rewound.map_err(|e| self.io(e))?;
        self.len = 0;
        self.first_time = f64::NAN;
        self.last_time = f64::NAN;
        Ok(())
    }

    fn push(&mut self, x: &Sample) -> Result<()> {
        let mut bytes = [0u8; SAMPLE_BYTES];
        for (slot, v) in bytes.chunks_exact_mut(8).zip(fields(x)) {
            slot.copy_from_slice(&v.to_le_bytes());
        }
        self.out.write_all(&bytes).map_err(|e| self.io(e))?;
        if self.len == 0 {
            self.first_time = x.time;
        }
        self.last_time = x.time;
        self.len += 1;
        Ok(())
    }
}

/// A sample's signals in the spill's order; [`Reader`] takes them back in the same order.
fn fields(x: &Sample) -> [f64; 8] {
    [
        x.time,
        x.speed,
        x.direction,
        x.voltage,
        x.load,
        x.door,
        x.floor,
        x.current,
    ]
}

/// Aligned samples in a temporary file, read back in passes ([`History`]).
#[derive(Debug)]
pub struct SpilledSeries {
    /// Locked for a pass: two passes at once would move each other's position.
    file: Mutex<File>,
    /// Where it was created, for the messages of its errors.
    path: PathBuf,
    /// The uniform step (s).
    step_s: f64,
    /// Samples in the file, and the times of the first and the last (s).
    len: u64,
    first_time: f64,
    last_time: f64,
}

impl SpilledSeries {
    /// Number of samples.
    pub fn len(&self) -> u64 {
        self.len
    }

    /// True when there is no sample.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Duration covered (s), zero for fewer than two samples.
    pub fn duration_s(&self) -> f64 {
        if self.len < 2 {
            0.0
        } else {
            self.last_time - self.first_time
        }
    }

    /// Time of the last sample (s), NaN without any.
    pub fn last_time(&self) -> f64 {
        self.last_time
    }
}

impl History for SpilledSeries {
    fn step_s(&self) -> f64 {
        self.step_s
    }

    fn read(&self, read: &mut dyn FnMut(&mut dyn Iterator<Item = Sample>)) -> Result<()> {
        // A pass that panicked left the file at some position; the next one seeks anyway.
        let mut file = self
            .file
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        file.seek(SeekFrom::Start(0))
            .map_err(|e| Error::io(&self.path, e))?;
        let mut samples = Reader {
            file: &mut file,
            left: self.len,
            chunk: vec![0u8; CHUNK_SAMPLES * SAMPLE_BYTES],
            filled: 0,
            at: 0,
            error: None,
        };
        read(&mut samples);
        match samples.error {
            Some(e) => Err(Error::io(&self.path, e)),
            None => Ok(()),
        }
    }
}

#[cfg(not(unix))]
impl Drop for SpilledSeries {
    fn drop(&mut self) {
        // Its name was kept where an open file cannot lose it; best effort, as a temporary.
        let _ = std::fs::remove_file(&self.path);
    }
}

/// One pass's iterator: the samples of the chunk read last, then the next chunk; an I/O
/// error ends the pass and is kept for [`History::read`] to return. It gives no size hint:
/// told the count, `TrainingRows` reserves room for every row, and on 30 days at 1 Hz that
/// raised the fit's peak resident memory from 70 to 80 MB, at the same time (measured; the
/// allocator's doing, not traced further).
struct Reader<'a> {
    file: &'a mut File,
    /// Samples not yet read from the file.
    left: u64,
    chunk: Vec<u8>,
    /// Bytes of `chunk` read, and the next sample's offset in it.
    filled: usize,
    at: usize,
    error: Option<io::Error>,
}

impl Iterator for Reader<'_> {
    type Item = Sample;

    fn next(&mut self) -> Option<Sample> {
        if self.at == self.filled {
            if self.left == 0 || self.error.is_some() {
                return None;
            }
            let take = self.left.min(CHUNK_SAMPLES as u64) as usize;
            let bytes = &mut self.chunk[..take * SAMPLE_BYTES];
            if let Err(e) = self.file.read_exact(bytes) {
                self.error = Some(e);
                return None;
            }
            self.left -= take as u64;
            self.filled = bytes.len();
            self.at = 0;
        }
        let bytes = &self.chunk[self.at..self.at + SAMPLE_BYTES];
        self.at += SAMPLE_BYTES;
        let mut f = [0.0; 8];
        for (v, b) in f.iter_mut().zip(bytes.chunks_exact(8)) {
            let mut le = [0u8; 8];
            le.copy_from_slice(b);
            *v = f64::from_le_bytes(le);
        }
        let [time, speed, direction, voltage, load, door, floor, current] = f;
        Some(Sample {
            time,
            speed,
            direction,
            voltage,
            load,
            door,
            floor,
            current,
        })
    }
}

/// Reads and aligns the telemetry file at `path` (either layout) into a spill in `dir`: as
/// [`super::read_series`], holding no sample in memory.
///
/// # Errors
/// As [`super::align_reader`], and [`Error::Io`] when the temporary file cannot be written.
pub fn read_spilled(
    path: &Path,
    cfg: &AlignConfig,
    dir: &Path,
) -> Result<(SpilledSeries, IngestReport)> {
    let mut sink = SpillSink::new_in(dir)?;
    let report = align_file(path, cfg, &mut sink)?;
    Ok((sink.finish(cfg.step_s)?, report))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sample::{pass, AlignedSeries};

    fn odd_samples(n: usize) -> Vec<Sample> {
        (0..n)
            .map(|i| Sample {
                time: 1.5e9 + i as f64,
                speed: if i % 3 == 0 { f64::NAN } else { 0.1 * i as f64 },
                direction: -0.0,
                voltage: f64::from_bits(0x7ff8_0000_0000_0001 + i as u64),
                load: f64::MIN_POSITIVE / 3.0,
                door: f64::INFINITY,
                floor: i as f64,
                current: f64::NAN,
            })
            .collect()
    }

    fn bits(x: &Sample) -> [u64; 8] {
        fields(x).map(f64::to_bits)
    }

    #[test]
    fn every_pass_gives_back_the_samples_bit_for_bit() {
        // Across a chunk's edge, with NaN payloads, -0, subnormals and infinities.
        let samples = odd_samples(CHUNK_SAMPLES + 7);
        let mut sink = SpillSink::new_in(&std::env::temp_dir()).unwrap();
        sink.start(false).unwrap();
        sink.push(&samples[0]).unwrap();
        // A restart forgets what was pushed before it.
        sink.start(false).unwrap();
        for x in &samples {
            sink.push(x).unwrap();
        }
        let spilled = sink.finish(1.0).unwrap();
        assert_eq!(spilled.len(), samples.len() as u64);
        assert_eq!(spilled.duration_s(), (samples.len() - 1) as f64);
        let want: Vec<[u64; 8]> = samples.iter().map(bits).collect();
        for _ in 0..2 {
            let got: Vec<[u64; 8]> = pass(&spilled, |s| s.map(|x| bits(&x)).collect()).unwrap();
            assert_eq!(got, want);
        }
        // A pass that stops early leaves the next one whole.
        assert_eq!(pass(&spilled, |s| s.take(3).count()).unwrap(), 3);
        assert_eq!(pass(&spilled, |s| s.count()).unwrap(), samples.len());
        let memory = AlignedSeries {
            step_s: 1.0,
            samples,
        };
        let got: Vec<[u64; 8]> = pass(&memory, |s| s.map(|x| bits(&x)).collect()).unwrap();
        assert_eq!(got, want);
    }

    #[test]
    fn a_spilled_file_is_the_series_read_into_memory() {
        let dir = std::env::temp_dir().join(format!("lw-spill-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("raw.csv");
        let mut text = String::from("time,signal,value\n");
        for i in 0..50 {
            let t = 100.0 + 0.7 * f64::from(i);
            text.push_str(&format!(
                "{t},speed,{}\n{t},voltage,{}\n",
                0.01 * f64::from(i),
                i
            ));
        }
        std::fs::write(&path, text).unwrap();
        let cfg = AlignConfig::default();
        let (series, _) = super::super::read_series(&path, &cfg).unwrap();
        let (spilled, _) = read_spilled(&path, &cfg, &dir).unwrap();
        assert_eq!(spilled.len(), series.len() as u64);
        assert_eq!(spilled.duration_s(), series.duration_s());
        let want: Vec<[u64; 8]> = series.samples.iter().map(bits).collect();
        let got: Vec<[u64; 8]> = pass(&spilled, |s| s.map(|x| bits(&x)).collect()).unwrap();
        assert_eq!(got, want);
        // Nothing of the spill is left in its directory, even while it is read.
        #[cfg(unix)]
        assert!(!spilled.path.exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
