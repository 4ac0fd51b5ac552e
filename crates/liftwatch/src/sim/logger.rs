//! Simulator: sensor clocks, dropouts and the control-cabinet logger that writes raw telemetry
//! (DATA.md §1), and the aligned series of that telemetry (DATA.md §2) with the truth beside it.
//!
//! ```text
//! sample k of a signal:  t_k = t_0 + φ + k·P·(1 + ppm·1e-6) + clamp(N(0, σ_j), ±0.2 s)
//! dropouts:               Poisson, `dropouts_per_day` per signal, each silent for 1-15 min
//! logging order:          rows are buffered per signal and flushed every 1-4 s, one signal after
//!                         the other, so rows of different signals are mildly out of order
//! ```
//!
//! Each signal has its own clock (phase φ uniform in one period, a rate error of up to ±100
//! ppm, jitter of tens of ms), like a logger that polls independent devices. About one row in
//! 50 000 is repeated, as a logger that re-sends after a timeout does.

use std::collections::VecDeque;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use crate::align::{push_sample, AlignConfig, RowStream, SampleSink};
use crate::error::{Error, Result};
use crate::rng::Rng;
use crate::sample::{Sample, DAY_S};
use crate::text::push_fixed;

use super::TruthRow;

pub use crate::ingest::Signal;

/// The signals the simulator logs, in the order of its per-signal arrays (their
/// [`Signal::index`]): every signal of DATA.md §1 but the optional `current`, which it does
/// not simulate.
pub const SIMULATED: [Signal; 6] = [
    Signal::Speed,
    Signal::Direction,
    Signal::Voltage,
    Signal::Load,
    Signal::Door,
    Signal::Floor,
];

/// Decimals written for a value of `signal` (enough for its quantisation step).
fn decimals(signal: Signal) -> usize {
    match signal {
        Signal::Speed => 3,
        Signal::Voltage | Signal::Current => 2,
        Signal::Load => 1,
        Signal::Direction | Signal::Door | Signal::Floor => 0,
    }
}

/// One raw telemetry row: `time,signal,value`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RawRow {
    /// Sampling instant (s).
    pub time: f64,
    /// Which signal.
    pub signal: Signal,
    /// The reading.
    pub value: f64,
}

/// Silent intervals of one sensor, drawn as a Poisson process; queried with rising times.
#[derive(Clone, Debug)]
pub(crate) struct Dropouts {
    rng: Rng,
    rate_per_s: f64,
    start: f64,
    end: f64,
}

impl Dropouts {
    pub(crate) fn new(mut rng: Rng, per_day: f64, from: f64) -> Self {
        let rate_per_s = per_day.max(0.0) / DAY_S;
        let (start, end) = Self::draw(&mut rng, rate_per_s, from);
        Dropouts {
            rng,
            rate_per_s,
            start,
            end,
        }
    }

    fn draw(rng: &mut Rng, rate: f64, from: f64) -> (f64, f64) {
        if rate <= 0.0 {
            return (f64::INFINITY, f64::INFINITY);
        }
        let start = from + rng.exponential(1.0 / rate);
        (start, start + rng.uniform(60.0, 900.0))
    }

    /// True when the sensor is silent at `t` (times must not go backwards by more than jitter).
    pub(crate) fn silent(&mut self, t: f64) -> bool {
        while t >= self.end {
            let (s, e) = Self::draw(&mut self.rng, self.rate_per_s, self.end);
            self.start = s;
            self.end = e;
        }
        t >= self.start
    }
}

/// The sampling clock of one sensor.
#[derive(Clone, Debug)]
pub(crate) struct SensorClock {
    rng: Rng,
    origin: f64,
    period: f64,
    jitter_s: f64,
    k: u64,
    /// The next sampling instant (s).
    pub(crate) next: f64,
    /// When this sensor is silent.
    pub(crate) dropouts: Dropouts,
}

impl SensorClock {
    pub(crate) fn new(
        mut rng: Rng,
        start: f64,
        ppm: f64,
        jitter_s: f64,
        dropouts_per_day: f64,
    ) -> Self {
        let origin = start + rng.uniform(0.0, 1.0);
        let dropouts = Dropouts::new(rng.fork(), dropouts_per_day, start);
        let mut c = SensorClock {
            rng,
            origin,
            period: 1.0 + ppm * 1e-6,
            jitter_s,
            k: 0,
            next: 0.0,
            dropouts,
        };
        c.next = c.instant();
        c
    }

    fn instant(&mut self) -> f64 {
        let j = (self.jitter_s * self.rng.normal()).clamp(-0.2, 0.2);
        (self.origin + self.k as f64 * self.period + j).max(self.next)
    }

    /// Moves to the following sampling instant.
    pub(crate) fn advance(&mut self) {
        self.k += 1;
        self.next = self.instant();
    }
}

/// Buffers rows per signal and releases them in bursts, one signal after another.
#[derive(Clone, Debug)]
pub(crate) struct RawLogger {
    rng: Rng,
    buffers: [VecDeque<RawRow>; 6],
    next_flush: f64,
}

impl RawLogger {
    pub(crate) fn new(mut rng: Rng, start: f64) -> Self {
        let next_flush = start + rng.uniform(1.0, 4.0);
        RawLogger {
            rng,
            buffers: Default::default(),
            next_flush,
        }
    }

    pub(crate) fn push(&mut self, row: RawRow) {
        let b = &mut self.buffers[row.signal.index()];
        b.push_back(row);
        if self.rng.chance(2e-5) {
            b.push_back(row);
        }
    }

    /// Releases every burst due by time `t` to `out`.
    pub(crate) fn flush_until(
        &mut self,
        t: f64,
        out: &mut impl FnMut(RawRow) -> Result<()>,
    ) -> Result<()> {
        while self.next_flush <= t {
            let cut = self.next_flush;
            for b in &mut self.buffers {
                let n = b.partition_point(|r| r.time < cut);
                for r in b.drain(..n) {
                    out(r)?;
                }
            }
            self.next_flush += self.rng.uniform(1.0, 4.0);
        }
        Ok(())
    }

    /// Releases everything still buffered.
    pub(crate) fn flush_all(&mut self, out: &mut impl FnMut(RawRow) -> Result<()>) -> Result<()> {
        for b in &mut self.buffers {
            for r in b.drain(..) {
                out(r)?;
            }
        }
        Ok(())
    }
}

/// Writes `raw.csv` (DATA.md §1): `time,signal,value`, numeric seconds, in logging order.
pub struct RawCsvWriter {
    path: PathBuf,
    out: BufWriter<File>,
    line: Vec<u8>,
    /// Rows written so far.
    pub rows: u64,
}

impl RawCsvWriter {
    /// Creates the file and writes the header.
    ///
    /// # Errors
    /// [`Error::Io`] when the file cannot be created or written.
    pub fn create(path: &Path) -> Result<Self> {
        let file = File::create(path).map_err(|e| Error::io(path, e))?;
        let mut out = BufWriter::with_capacity(1 << 20, file);
        out.write_all(RAW_HEADER).map_err(|e| Error::io(path, e))?;
        Ok(RawCsvWriter {
            path: path.into(),
            out,
            line: Vec::with_capacity(64),
            rows: 0,
        })
    }

    /// Writes one row; a non-finite value is written as an empty field.
    ///
    /// # Errors
    /// [`Error::Io`] when writing fails.
    pub fn write(&mut self, r: &RawRow) -> Result<()> {
        self.line.clear();
        push_raw_line(&mut self.line, r);
        self.out
            .write_all(&self.line)
            .map_err(|e| Error::io(&self.path, e))?;
        self.rows += 1;
        Ok(())
    }

    /// Flushes the file.
    ///
    /// # Errors
    /// [`Error::Io`] when flushing fails.
    pub fn finish(mut self) -> Result<u64> {
        self.out.flush().map_err(|e| Error::io(&self.path, e))?;
        Ok(self.rows)
    }
}

/// The header of `raw.csv`, with its line end.
pub const RAW_HEADER: &[u8] = b"time,signal,value\n";

/// Appends one `raw.csv` line: time in ms, the signal's name, the value at the signal's
/// resolution (empty when not finite), a line end.
pub fn push_raw_line(out: &mut Vec<u8>, r: &RawRow) {
    push_fixed(out, r.time, 3);
    out.push(b',');
    out.extend_from_slice(r.signal.name().as_bytes());
    out.push(b',');
    push_fixed(out, r.value, decimals(r.signal));
    out.push(b'\n');
}

/// Columns of `aligned.csv`: DATA.md §2 then the simulator's truth.
pub const ALIGNED_HEADER: [&str; 15] = [
    "time",
    "speed",
    "direction",
    "voltage",
    "load",
    "door",
    "floor",
    "v_true",
    "accel_true",
    "pos_true",
    "load_true",
    "force_true",
    "voltage_true",
    "kd_true",
    "severity",
];

/// Writes `aligned.csv` (DATA.md §2): what the one aligner of [`crate::align`] makes of the
/// raw rows as [`RawCsvWriter`] writes them, i.e. what `liftwatch align` writes for `raw.csv`
/// (same samples, same text), each row followed by the truth at its grid instant.
///
/// The raw rows go in as a reader of `raw.csv` gets them back (their written text parsed), in
/// logging order, through the streaming pass of a file; the truth rows in time order. A grid
/// point of the log with no truth row gets empty truth fields; a truth second outside the log's
/// grid (before its first reading, after its last) has no row. Memory stays bounded by the
/// aligner's reorder window.
pub struct AlignedCsvWriter {
    stream: RawAligner,
    join: Join,
}

/// The one aligner of [`crate::align`] (its streaming pass of a file, [`RowStream`]) fed with
/// the simulator's raw rows as a reader of `raw.csv` gets them back: their written text parsed,
/// in logging order. What it releases is what `liftwatch align` makes of `raw.csv`, so every
/// consumer of a simulated log (`aligned.csv`, the evaluation's training and monitoring) sees
/// the interpolation error a real log carries, not the sensors read at the grid instant.
/// Memory stays bounded by the aligner's reorder window.
pub(crate) struct RawAligner {
    stream: RowStream,
    text: Vec<u8>,
}

impl RawAligner {
    /// An empty stream with the default alignment settings, as `align` uses for `raw.csv`.
    ///
    /// # Errors
    /// [`Error::InvalidConfig`] should the default settings be invalid.
    pub(crate) fn new() -> Result<Self> {
        Ok(RawAligner {
            stream: RowStream::new(&AlignConfig::default(), Path::new("raw.csv"))?,
            text: Vec::with_capacity(32),
        })
    }

    /// Takes one raw row, in logging order; grid points it makes certain go to `sink`.
    ///
    /// # Errors
    /// The sink's error; a row later than the reorder window (the logger stays well inside it).
    pub(crate) fn push<S: SampleSink>(&mut self, r: &RawRow, sink: &mut S) -> Result<(), S::Error> {
        // The reading as a reader of raw.csv gets it: its line as written (one formatter,
        // `push_raw_line`), the time and value fields parsed as ingest parses them.
        self.text.clear();
        push_raw_line(&mut self.text, r);
        let line = self.text.strip_suffix(b"\n").unwrap_or(&self.text);
        let mut fields = line.split(|&b| b == b',');
        let read = |f: Option<&[u8]>| f.and_then(crate::text::parse_f64).filter(|x| x.is_finite());
        let t = read(fields.next());
        let v = read(fields.nth(1));
        let (Some(t), Some(v)) = (t, v) else {
            return Ok(());
        };
        self.stream.push(r.signal, t, v, sink)
    }

    /// The rest of the grid: the end of the log.
    ///
    /// # Errors
    /// The sink's error.
    pub(crate) fn flush<S: SampleSink>(&mut self, sink: &mut S) -> Result<(), S::Error> {
        self.stream.flush(sink)
    }
}

/// The receiving end of the aligner: samples joined with the truth rows and written.
struct Join {
    path: PathBuf,
    out: BufWriter<File>,
    line: String,
    bytes: Vec<u8>,
    samples: VecDeque<Sample>,
    truth: VecDeque<TruthRow>,
    rows: u64,
}

impl Join {
    /// Writes every row whose match is decided; at the `end`, everything left.
    fn drain(&mut self, end: bool) -> Result<()> {
        loop {
            match (self.samples.front(), self.truth.front()) {
                (Some(s), Some(t)) if s.time == t.sample.time => {
                    let (s, t) = (*s, *t);
                    self.write(&s, Some(&t))?;
                    self.samples.pop_front();
                    self.truth.pop_front();
                }
                // Both come in time order: a sample before the next truth row has none, a truth
                // row before the next sample is no grid point of the log.
                (Some(s), Some(t)) if s.time < t.sample.time => {
                    let s = *s;
                    self.write(&s, None)?;
                    self.samples.pop_front();
                }
                (Some(_), Some(_)) => {
                    self.truth.pop_front();
                }
                (Some(s), None) if end => {
                    let s = *s;
                    self.write(&s, None)?;
                    self.samples.pop_front();
                }
                (None, Some(_)) if end => {
                    self.truth.pop_front();
                }
                _ => return Ok(()),
            }
        }
    }

    fn write(&mut self, s: &Sample, t: Option<&TruthRow>) -> Result<()> {
        self.line.clear();
        push_sample(&mut self.line, s);
        let truth = t.map_or([f64::NAN; 8], |r| {
            [
                r.v_true,
                r.accel_true,
                r.pos_true,
                r.load_true,
                r.force_true,
                r.voltage_true,
                r.kd_true,
                r.severity,
            ]
        });
        self.bytes.clear();
        self.bytes.extend_from_slice(self.line.as_bytes());
        for (v, dec) in truth.into_iter().zip([4, 4, 3, 4, 1, 3, 7, 4]) {
            self.bytes.push(b',');
            push_fixed(&mut self.bytes, v, dec);
        }
        self.bytes.push(b'\n');
        self.out
            .write_all(&self.bytes)
            .map_err(|e| Error::io(&self.path, e))?;
        self.rows += 1;
        Ok(())
    }
}

impl SampleSink for Join {
    type Error = Error;

    fn start(&mut self, _has_current: bool) -> Result<()> {
        Ok(())
    }

    fn push(&mut self, sample: &Sample) -> Result<()> {
        self.samples.push_back(*sample);
        self.drain(false)
    }
}

impl AlignedCsvWriter {
    /// Creates the file and writes the header [`ALIGNED_HEADER`].
    ///
    /// # Errors
    /// [`Error::Io`] when the file cannot be created or written.
    pub fn create(path: &Path) -> Result<Self> {
        let file = File::create(path).map_err(|e| Error::io(path, e))?;
        let mut out = BufWriter::with_capacity(1 << 20, file);
        out.write_all(ALIGNED_HEADER.join(",").as_bytes())
            .and_then(|()| out.write_all(b"\n"))
            .map_err(|e| Error::io(path, e))?;
        Ok(AlignedCsvWriter {
            stream: RawAligner::new()?,
            join: Join {
                path: path.into(),
                out,
                line: String::with_capacity(96),
                bytes: Vec::with_capacity(192),
                samples: VecDeque::new(),
                truth: VecDeque::new(),
                rows: 0,
            },
        })
    }

    /// Takes one raw row as it is written to `raw.csv`, in logging order.
    ///
    /// # Errors
    /// [`Error::Io`] when writing fails.
    pub fn raw(&mut self, r: &RawRow) -> Result<()> {
        self.stream.push(r, &mut self.join)
    }

    /// Takes the truth of one grid second, in time order.
    ///
    /// # Errors
    /// [`Error::Io`] when writing fails.
    pub fn truth(&mut self, r: &TruthRow) -> Result<()> {
        self.join.truth.push_back(*r);
        self.join.drain(false)
    }

    /// Aligns the rest of the log, writes it and flushes the file; returns the rows written.
    ///
    /// # Errors
    /// [`Error::Io`] when writing fails.
    pub fn finish(mut self) -> Result<u64> {
        self.stream.flush(&mut self.join)?;
        self.join.drain(true)?;
        let Join {
            mut out,
            path,
            rows,
            ..
        } = self.join;
        out.flush().map_err(|e| Error::io(&path, e))?;
        Ok(rows)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clock_ticks_about_once_a_second_in_order() {
        let mut c = SensorClock::new(Rng::new(1), 100.0, 50.0, 0.03, 0.0);
        let first = c.next;
        assert!((100.0..101.2).contains(&first));
        let mut prev = first;
        for _ in 0..1000 {
            c.advance();
            assert!(
                c.next >= prev && c.next - prev < 1.5,
                "{prev} -> {}",
                c.next
            );
            prev = c.next;
        }
        assert!(((prev - first) / 1000.0 - 1.0).abs() < 1e-3);
    }

    #[test]
    fn dropouts_last_minutes_and_come_at_the_declared_rate() {
        let mut d = Dropouts::new(Rng::new(2), 4.0, 0.0);
        let days = 50.0;
        let (mut silent_s, mut starts, mut was) = (0.0, 0, false);
        let mut t = 0.0;
        while t < days * DAY_S {
            let s = d.silent(t);
            silent_s += if s { 1.0 } else { 0.0 };
            starts += usize::from(s && !was);
            was = s;
            t += 1.0;
        }
        let per_day = starts as f64 / days;
        assert!((2.5..5.5).contains(&per_day), "{per_day}");
        let mean_len = silent_s / starts as f64;
        assert!((300.0..700.0).contains(&mean_len), "{mean_len}");
    }

    #[test]
    fn logger_keeps_each_signal_in_order_and_disorder_bounded() {
        let mut l = RawLogger::new(Rng::new(4), 0.0);
        let mut out = Vec::new();
        for k in 0..300 {
            for s in SIMULATED {
                l.push(RawRow {
                    time: f64::from(k) + 0.1 * s.index() as f64,
                    signal: s,
                    value: 0.0,
                });
            }
            l.flush_until(f64::from(k) + 1.0, &mut |r| {
                out.push(r);
                Ok(())
            })
            .unwrap();
        }
        l.flush_all(&mut |r| {
            out.push(r);
            Ok(())
        })
        .unwrap();
        assert!(out.len() >= 1800);
        let mut max_back = 0.0f64;
        let mut latest = f64::NEG_INFINITY;
        for s in SIMULATED {
            let times: Vec<f64> = out
                .iter()
                .filter(|r| r.signal == s)
                .map(|r| r.time)
                .collect();
            assert!(times.windows(2).all(|w| w[0] <= w[1]));
        }
        for r in &out {
            max_back = max_back.max(latest - r.time);
            latest = latest.max(r.time);
        }
        assert!(
            max_back > 0.0,
            "rows of different signals interleave out of order"
        );
        assert!(max_back < 4.5, "{max_back}");
    }
}
