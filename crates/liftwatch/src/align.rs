//! Stage 2: alignment of multi-source readings to one uniform step (paper, Sec. 4.1:
//! "resampling, interpolation, and state synchronisation under a unified time step";
//! DATA.md §2).
//!
//! ```text
//! grid        t_k = k·Δ,  k = ceil(t_first/Δ) .. floor(t_last/Δ)      (Δ = step_s)
//! brackets    p = last reading of the signal with t_p <= t_k,  n = first with t_n >= t_k
//! continuous  x(t_k) = x_p + (x_n − x_p)·(t_k − t_p)/(t_n − t_p)      speed, voltage, load, current
//! discrete    x(t_k) = x_p                                            direction, door, floor (held)
//! gap         x(t_k) = missing (NaN) if p or n is absent or t_n − t_p > gap_limit_s
//! duplicates  readings of one signal at one time: mean (continuous), last in file order (discrete)
//! ```
//!
//! A reading exactly on a grid time is taken as it is (p = n). Missing raw values
//! (empty, `NaN`) carry no information and are not readings: the neighbours bracket
//! across them, still subject to the gap limit.
//!
//! Streaming. Readings go into one time-sorted buffer per signal (16-byte records); grid
//! point t_k is produced once the latest time seen is past `t_k + gap_limit_s +
//! reorder_window_s`, so rows up to the reorder window out of order are sorted in, and
//! memory stays bounded by the window, not by the file. A row that arrives too late
//! (earlier than `t_k + gap_limit_s` of a grid point already produced) is not dropped:
//! the file is read a second time, all readings are kept in memory as 16-byte records,
//! sorted (stable, so "last in file order" still holds) and aligned; the sink is told to
//! start over ([`SampleSink::start`]). A `current` reading that first appears after
//! samples were produced without a `current` column also restarts, streaming again.
//! An aligned-layout input whose step is already `step_s` is passed through as it is;
//! any other aligned input is re-stepped by the same machinery, each column a signal.
//!
//! Limits: times beyond ±[`MAX_ABS_TIME_S`](crate::ingest::MAX_ABS_TIME_S) are bad rows (see [`crate::ingest::time`]);
//! usable times spanning more than [`MAX_SPAN_S`] (10 years), or more than
//! [`MAX_SAMPLES`] grid points, are refused as soon as a row shows it, before that
//! grid is produced.
//!
//! Deviation from the paper: the paper does not state its interpolation or how gaps
//! are treated; we interpolate linearly, hold discrete states and never bridge a gap
//! longer than `gap_limit_s`, because an invented value would turn into a residual.

use std::collections::VecDeque;
use std::fs::File;
use std::io::{self, BufWriter, Read, Seek, SeekFrom, Write};
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::ingest::csv::RowReader;
use crate::ingest::{IngestReport, Layout, Signal};
use crate::sample::{AlignedSeries, Sample};

/// Longest accepted span of usable times (s): 10 years.
pub const MAX_SPAN_S: f64 = 10.0 * 365.25 * 86_400.0;

/// Most grid points one input may produce: 10 years at 1 s.
pub const MAX_SAMPLES: f64 = MAX_SPAN_S;

/// The header of an aligned file (DATA.md §2); `,current` follows when present.
pub const ALIGNED_HEADER: &str = "time,speed,direction,voltage,load,door,floor";

/// Settings of alignment. Build with [`AlignConfig::default`] and the `with_*` methods,
/// which refuse values out of range.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct AlignConfig {
    /// Δ: the uniform step of the output (s), 0.001 to 86400.
    pub step_s: f64,
    /// Longest distance between the two readings bracketing a grid time that is still
    /// interpolated or held (s), 0 to 86400; longer gaps stay empty.
    pub gap_limit_s: f64,
    /// How far out of time order a row may come and still be sorted in while streaming
    /// (s), 0 to 86400; a later row makes the file be sorted in memory.
    pub reorder_window_s: f64,
}

impl Default for AlignConfig {
    fn default() -> Self {
        AlignConfig {
            step_s: 1.0,
            gap_limit_s: 5.0,
            reorder_window_s: 600.0,
        }
    }
}

fn check_range(field: &'static str, v: f64, lo: f64, hi: f64) -> Result<()> {
    if v.is_finite() && (lo..=hi).contains(&v) {
        Ok(())
    } else {
        Err(Error::InvalidConfig {
            field,
            why: format!("{v} s is outside {lo} to {hi} s"),
        })
    }
}

impl AlignConfig {
    /// Sets the step Δ (s).
    ///
    /// # Errors
    /// [`Error::InvalidConfig`] unless 0.001 <= `step_s` <= 86400.
    pub fn with_step(mut self, step_s: f64) -> Result<Self> {
        check_range("step_s", step_s, 1e-3, 86_400.0)?;
        self.step_s = step_s;
        Ok(self)
    }

    /// Sets the gap limit (s).
    ///
    /// # Errors
    /// [`Error::InvalidConfig`] unless 0 <= `gap_limit_s` <= 86400.
    pub fn with_gap_limit(mut self, gap_limit_s: f64) -> Result<Self> {
        check_range("gap_limit_s", gap_limit_s, 0.0, 86_400.0)?;
        self.gap_limit_s = gap_limit_s;
        Ok(self)
    }

    /// Sets the reorder window (s).
    ///
    /// # Errors
    /// [`Error::InvalidConfig`] unless 0 <= `reorder_window_s` <= 86400.
    pub fn with_reorder_window(mut self, reorder_window_s: f64) -> Result<Self> {
        check_range("reorder_window_s", reorder_window_s, 0.0, 86_400.0)?;
        self.reorder_window_s = reorder_window_s;
        Ok(self)
    }

    /// Checks every field, for a config built by hand or read from a file.
    ///
    /// # Errors
    /// [`Error::InvalidConfig`] naming the first field out of range.
    pub fn validate(&self) -> Result<()> {
        AlignConfig::default()
            .with_step(self.step_s)?
            .with_gap_limit(self.gap_limit_s)?
            .with_reorder_window(self.reorder_window_s)
            .map(|_| ())
    }
}

/// Receives aligned samples in time order.
pub trait SampleSink {
    /// Called before the first sample. A second call means the input had to be read
    /// again (a row came later than the reorder window, or `current` appeared late):
    /// everything pushed before must be forgotten. `has_current` says whether the
    /// series carries the optional `current` signal.
    ///
    /// # Errors
    /// Whatever the sink cannot do; alignment stops with it.
    fn start(&mut self, has_current: bool) -> Result<()>;

    /// Receives the next sample; times increase by the step.
    ///
    /// # Errors
    /// Whatever the sink cannot do; alignment stops with it.
    fn push(&mut self, sample: &Sample) -> Result<()>;
}

impl SampleSink for Vec<Sample> {
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

impl<A, B> SampleSink for FnSink<A, B>
where
    A: FnMut(bool) -> Result<()>,
    B: FnMut(&Sample) -> Result<()>,
{
    fn start(&mut self, has_current: bool) -> Result<()> {
        (self.on_start)(has_current)
    }

    fn push(&mut self, sample: &Sample) -> Result<()> {
        (self.on_sample)(sample)
    }
}

/// A sink from closures: `on_start(has_current)` (which must reset the consumer when
/// called again) and `on_sample(sample)`.
pub fn sink_fn<A, B>(on_start: A, on_sample: B) -> FnSink<A, B>
where
    A: FnMut(bool) -> Result<()>,
    B: FnMut(&Sample) -> Result<()>,
{
    FnSink {
        on_start,
        on_sample,
    }
}

/// One reading of one signal: 16 bytes, the signal is the buffer it sits in.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Reading {
    t: f64,
    v: f64,
}

/// The readings of one signal not yet behind the grid, and the last one that is.
struct Track {
    pending: VecDeque<Reading>,
    prev: Option<Reading>,
    max_t: f64,
    continuous: bool,
}

impl Track {
    fn new(sig: Signal) -> Self {
        Track {
            pending: VecDeque::new(),
            prev: None,
            max_t: f64::NEG_INFINITY,
            continuous: sig.is_continuous(),
        }
    }

    /// Sorts a reading in; returns (reordered, duplicate).
    fn insert(&mut self, r: Reading) -> (bool, bool) {
        if r.t >= self.max_t {
            let dup = r.t == self.max_t;
            self.max_t = r.t;
            self.pending.push_back(r);
            (false, dup)
        } else {
            // `<=` keeps equal times in file order, which "last wins" relies on.
            let pos = self.pending.partition_point(|x| x.t <= r.t);
            let dup = pos > 0 && self.pending[pos - 1].t == r.t;
            self.pending.insert(pos, r);
            (true, dup)
        }
    }

    /// The first group of equal-time readings merged: mean or last.
    fn merged_front(&self) -> Option<(Reading, usize)> {
        let first = *self.pending.front()?;
        let (mut sum, mut last, mut n) = (0.0, first.v, 0usize);
        for r in self.pending.iter().take_while(|r| r.t == first.t) {
            sum += r.v;
            last = r.v;
            n += 1;
        }
        let v = if self.continuous {
            sum / n as f64
        } else {
            last
        };
        Some((Reading { t: first.t, v }, n))
    }

    /// The value at grid time `g`; readings at or before `g` become `prev`.
    fn value_at(&mut self, g: f64, gap: f64) -> f64 {
        while self.pending.front().is_some_and(|r| r.t <= g) {
            let (merged, n) = self.merged_front().expect("front exists");
            self.pending.drain(..n);
            self.prev = Some(merged);
        }
        let Some(p) = self.prev else { return f64::NAN };
        if p.t == g {
            return p.v;
        }
        let Some((n, _)) = self.merged_front() else {
            return f64::NAN;
        };
        if n.t - p.t > gap {
            f64::NAN
        } else if self.continuous {
            p.v + (n.v - p.v) * (g - p.t) / (n.t - p.t)
        } else {
            p.v
        }
    }
}

/// Grid times t_k = k·Δ, computed as an exact decimal when Δ has at most 5 decimals,
/// so that `0.1 · 3` is written `0.3`.
#[derive(Clone, Copy, Debug)]
struct Grid {
    step: f64,
    units: f64,
    scale: f64,
}

impl Grid {
    fn new(step: f64) -> Self {
        for d in 0..=5 {
            let scale = 10f64.powi(d);
            let x = step * scale;
            if (x - x.round()).abs() < 1e-9 * x.max(1.0) {
                return Grid {
                    step,
                    units: x.round(),
                    scale,
                };
            }
        }
        Grid {
            step,
            units: 0.0,
            scale: 0.0,
        }
    }

    fn time(&self, k: i64) -> f64 {
        // |k·units| <= 1e10 s · 1e5 < 2^53: the product is an exact integer.
        if self.units > 0.0 {
            k as f64 * self.units / self.scale
        } else {
            k as f64 * self.step
        }
    }

    fn first_k(&self, t: f64) -> i64 {
        let k = (t / self.step).ceil() as i64;
        if self.time(k - 1) >= t {
            k - 1
        } else {
            k
        }
    }
}

fn span_error(path: &Path, lo: f64, hi: f64, step: f64) -> Error {
    Error::BadDocument {
        path: path.to_path_buf(),
        what: "telemetry log",
        why: format!(
            "usable times span {:.0} s (from {lo} to {hi}), more than the limit of {:.0} s \
             (10 years, and at most {MAX_SAMPLES:.0} samples at the {step} s step)",
            hi - lo,
            max_span(step)
        ),
    }
}

fn max_span(step: f64) -> f64 {
    MAX_SPAN_S.min(MAX_SAMPLES * step)
}

/// What a reading did to the engine.
enum Push {
    Taken,
    /// Earlier than the grid already produced allows.
    Late,
    /// The first `current` reading after samples without `current` went out.
    LateCurrent,
}

/// The alignment machinery shared by the streaming and the sorted pass.
struct Engine<'a, S: SampleSink> {
    grid: Grid,
    gap: f64,
    window: f64,
    tracks: [Track; 7],
    t_min: f64,
    t_max: f64,
    max_span: f64,
    next_k: Option<i64>,
    /// The latest time must reach this before the next grid point can go out.
    next_emit_at: f64,
    /// Readings at or before this time would change a sample already produced.
    late_bound: f64,
    has_current: bool,
    started: bool,
    sink: &'a mut S,
    path: &'a Path,
    samples: u64,
    samples_with_gaps: u64,
    duplicates: u64,
    reordered: u64,
}

impl<'a, S: SampleSink> Engine<'a, S> {
    fn new(cfg: &AlignConfig, path: &'a Path, sink: &'a mut S, has_current: bool) -> Self {
        Engine {
            grid: Grid::new(cfg.step_s),
            gap: cfg.gap_limit_s,
            window: cfg.reorder_window_s,
            tracks: Signal::ALL.map(Track::new),
            t_min: f64::INFINITY,
            t_max: f64::NEG_INFINITY,
            max_span: max_span(cfg.step_s),
            next_k: None,
            next_emit_at: f64::NEG_INFINITY,
            late_bound: f64::NEG_INFINITY,
            has_current,
            started: false,
            sink,
            path,
            samples: 0,
            samples_with_gaps: 0,
            duplicates: 0,
            reordered: 0,
        }
    }

    /// Widens the known time range to `t`, refusing a span beyond the limit.
    fn widen(&mut self, t: f64) -> Result<()> {
        let (lo, hi) = (self.t_min.min(t), self.t_max.max(t));
        if hi - lo > self.max_span {
            return Err(span_error(self.path, lo, hi, self.grid.step));
        }
        self.t_min = lo;
        self.t_max = hi;
        Ok(())
    }

    /// Streams one reading in, producing every grid point it makes certain.
    fn push(&mut self, sig: Signal, t: f64, v: f64) -> Result<Push> {
        if t <= self.late_bound {
            return Ok(Push::Late);
        }
        if sig == Signal::Current && !self.has_current {
            if self.started {
                return Ok(Push::LateCurrent);
            }
            self.has_current = true;
        }
        self.widen(t)?;
        let (reordered, dup) = self.tracks[sig.index()].insert(Reading { t, v });
        self.reordered += u64::from(reordered);
        self.duplicates += u64::from(dup);
        if self.t_max >= self.next_emit_at {
            self.emit_through(self.t_max - self.window)?;
        }
        Ok(Push::Taken)
    }

    /// Produces grid points t_k with t_k + gap <= `limit` and t_k <= the latest time.
    fn emit_through(&mut self, limit: f64) -> Result<()> {
        if !self.t_min.is_finite() {
            return Ok(());
        }
        loop {
            let k = self.next_k.unwrap_or_else(|| self.grid.first_k(self.t_min));
            let g = self.grid.time(k);
            if g > self.t_max || g + self.gap > limit {
                self.next_emit_at = g + self.gap + self.window;
                return Ok(());
            }
            self.emit(g)?;
            self.next_k = Some(k + 1);
        }
    }

    fn emit(&mut self, g: f64) -> Result<()> {
        if !self.started {
            self.sink.start(self.has_current)?;
            self.started = true;
        }
        let mut s = Sample::missing(g);
        for (sig, track) in Signal::ALL.into_iter().zip(self.tracks.iter_mut()) {
            sig.set(&mut s, track.value_at(g, self.gap));
        }
        self.samples += 1;
        self.samples_with_gaps += u64::from(has_gap(&s));
        self.late_bound = g + self.gap;
        self.sink.push(&s)
    }

    /// Produces the rest of the grid, through the last usable time.
    fn flush(&mut self) -> Result<()> {
        self.emit_through(f64::INFINITY)
    }

    fn report_into(&self, report: &mut IngestReport) {
        report.samples = self.samples;
        report.samples_with_gaps = self.samples_with_gaps;
        report.duplicate_timestamps = self.duplicates;
        report.rows_reordered = self.reordered;
        if self.t_min <= self.t_max {
            report.time_range = (self.t_min, self.t_max);
        }
    }
}

/// True when one of the six core signals (all but `current`) is missing.
fn has_gap(s: &Sample) -> bool {
    ![s.speed, s.direction, s.voltage, s.load, s.door, s.floor]
        .iter()
        .all(|v| v.is_finite())
}

/// How one pass over the file ended.
enum Outcome {
    Done,
    /// Aligned input whose step is not the configured one.
    NonUniform,
    /// A row older than the reorder window, at this line.
    Late(u64),
    /// `current` appeared after samples without it went out.
    LateCurrent,
}

/// How to read the file in one pass.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Plan {
    PassThrough,
    Stream { has_current: bool },
    Sorted { has_current: bool },
}

fn stream_pass<R: Read, S: SampleSink>(
    rows: &mut RowReader<R>,
    cfg: &AlignConfig,
    sink: &mut S,
    has_current: bool,
    report: &mut IngestReport,
) -> Result<Outcome> {
    let path = rows.path().to_path_buf();
    let mut engine = Engine::new(cfg, &path, sink, has_current);
    let mut outcome = Outcome::Done;
    rows.for_each_reading(report, |t, sig, v, line| match engine.push(sig, t, v)? {
        Push::Taken => Ok(ControlFlow::Continue(())),
        Push::Late => {
            outcome = Outcome::Late(line);
            Ok(ControlFlow::Break(()))
        }
        Push::LateCurrent => {
            outcome = Outcome::LateCurrent;
            Ok(ControlFlow::Break(()))
        }
    })?;
    if matches!(outcome, Outcome::Done) {
        engine.flush()?;
    }
    engine.report_into(report);
    Ok(outcome)
}

fn sorted_pass<R: Read, S: SampleSink>(
    rows: &mut RowReader<R>,
    cfg: &AlignConfig,
    sink: &mut S,
    has_current: bool,
    report: &mut IngestReport,
) -> Result<Outcome> {
    let path = rows.path().to_path_buf();
    let mut engine = Engine::new(cfg, &path, sink, has_current);
    let mut data: [Vec<Reading>; 7] = Default::default();
    let mut max_t = [f64::NEG_INFINITY; 7];
    let mut reordered = 0u64;
    rows.for_each_reading(report, |t, sig, v, _| {
        engine.widen(t)?;
        let i = sig.index();
        reordered += u64::from(t < max_t[i]);
        max_t[i] = max_t[i].max(t);
        data[i].push(Reading { t, v });
        Ok(ControlFlow::Continue(()))
    })?;
    let mut duplicates = 0u64;
    for (sig, mut readings) in Signal::ALL.into_iter().zip(data) {
        // Stable: equal times stay in file order for "last wins".
        readings.sort_by(|a, b| a.t.total_cmp(&b.t));
        duplicates += readings.windows(2).filter(|w| w[0].t == w[1].t).count() as u64;
        engine.has_current |= sig == Signal::Current && !readings.is_empty();
        engine.tracks[sig.index()].pending = VecDeque::from(readings);
    }
    engine.flush()?;
    engine.report_into(report);
    report.duplicate_timestamps = duplicates;
    report.rows_reordered = reordered;
    Ok(Outcome::Done)
}

/// Aligned input at the configured step: every row goes out as it is.
fn pass_through<R: Read, S: SampleSink>(
    rows: &mut RowReader<R>,
    cfg: &AlignConfig,
    sink: &mut S,
    report: &mut IngestReport,
) -> Result<Outcome> {
    let has_current = rows.has_current_column();
    let path = rows.path().to_path_buf();
    let tolerance = 1e-3 * cfg.step_s;
    let (mut first, mut prev) = (f64::NAN, f64::NAN);
    let mut outcome = Outcome::Done;
    let (mut samples, mut with_gaps) = (0u64, 0u64);
    rows.for_each_row(report, |s, _| {
        if prev.is_nan() {
            first = s.time;
            sink.start(has_current)?;
        } else if (s.time - prev - cfg.step_s).abs() > tolerance {
            outcome = Outcome::NonUniform;
            return Ok(ControlFlow::Break(()));
        }
        if s.time - first > max_span(cfg.step_s) {
            return Err(span_error(&path, first, s.time, cfg.step_s));
        }
        prev = s.time;
        samples += 1;
        with_gaps += u64::from(has_gap(s));
        sink.push(s)?;
        Ok(ControlFlow::Continue(()))
    })?;
    report.samples = samples;
    report.samples_with_gaps = with_gaps;
    if samples > 0 {
        report.time_range = (first, prev);
    }
    Ok(outcome)
}

/// The error for a file that produced nothing, saying why.
fn no_data(path: &Path, r: &IngestReport, step: f64) -> Option<Error> {
    let why = if r.rows_read == 0 {
        "only a header, no data rows".to_string()
    } else if r.values_used == 0 {
        let mut why = format!(
            "none of the {} rows holds a usable value ({} bad rows, {} missing values, {} rows of unknown signals)",
            r.rows_read,
            r.bad_rows,
            r.missing_values,
            r.unknown_rows()
        );
        if let Some(first) = &r.first_bad_reason {
            why.push_str(&format!("; {first}"));
        }
        why
    } else if r.samples == 0 {
        format!(
            "usable times {} to {} s hold no multiple of the {step} s step",
            r.time_range.0, r.time_range.1
        )
    } else {
        return None;
    };
    Some(Error::NoData {
        path: path.to_path_buf(),
        why,
    })
}

/// Aligns a telemetry file of either layout, streaming samples to `sink` in time order.
/// Memory is bounded by the reorder window unless the file needs the in-memory sort
/// (see the module docs); `input` is read again from the start when that happens.
/// `path` names the input in messages.
///
/// # Errors
/// [`Error::InvalidConfig`] for a bad `cfg`; [`Error::Io`] on a read error;
/// [`Error::UnknownLayout`]; [`Error::NoData`] when no usable row or no grid point
/// results; [`Error::BadDocument`] when usable times span more than the limit; or the
/// sink's error. Samples already pushed before an error are not taken back.
pub fn align_reader<R: Read + Seek, S: SampleSink>(
    mut input: R,
    path: &Path,
    cfg: &AlignConfig,
    sink: &mut S,
) -> Result<IngestReport> {
    cfg.validate()?;
    let mut plan = None;
    let mut late_line = None;
    // At most four passes: pass-through, re-step, restart for `current`, full sort.
    let mut pass = 0;
    loop {
        pass += 1;
        if pass > 1 {
            input
                .seek(SeekFrom::Start(0))
                .map_err(|e| Error::io(path, e))?;
        }
        let mut rows = RowReader::new(&mut input, path)?;
        let current_column = rows.has_current_column();
        let p = *plan.get_or_insert(match rows.layout() {
            Layout::Aligned => Plan::PassThrough,
            Layout::Raw => Plan::Stream { has_current: false },
        });
        let mut report = IngestReport::new(rows.layout());
        let outcome = match p {
            Plan::PassThrough => pass_through(&mut rows, cfg, sink, &mut report)?,
            Plan::Stream { has_current } => {
                stream_pass(&mut rows, cfg, sink, has_current, &mut report)?
            }
            Plan::Sorted { has_current } => {
                sorted_pass(&mut rows, cfg, sink, has_current, &mut report)?
            }
        };
        plan = Some(match outcome {
            Outcome::Done => {
                report.passes = pass;
                report.late_line = late_line;
                report.full_sort = matches!(p, Plan::Sorted { .. });
                return match no_data(path, &report, cfg.step_s) {
                    Some(err) => Err(err),
                    None => Ok(report),
                };
            }
            Outcome::NonUniform => Plan::Stream {
                has_current: current_column,
            },
            Outcome::Late(line) => {
                late_line.get_or_insert(line);
                Plan::Sorted {
                    has_current: current_column,
                }
            }
            Outcome::LateCurrent => Plan::Stream { has_current: true },
        });
    }
}

/// Aligns the telemetry file at `path`, streaming samples to `sink`; see [`align_reader`].
///
/// # Errors
/// As [`align_reader`]; a missing file is [`Error::Io`].
pub fn align_file<S: SampleSink>(
    path: &Path,
    cfg: &AlignConfig,
    sink: &mut S,
) -> Result<IngestReport> {
    let file = File::open(path).map_err(|e| Error::io(path, e))?;
    align_reader(file, path, cfg, sink)
}

/// Reads and aligns the telemetry file at `path` (either layout) into memory.
///
/// # Errors
/// As [`align_reader`].
pub fn read_series(path: &Path, cfg: &AlignConfig) -> Result<(AlignedSeries, IngestReport)> {
    let mut samples = Vec::new();
    let report = align_file(path, cfg, &mut samples)?;
    Ok((
        AlignedSeries {
            step_s: cfg.step_s,
            samples,
        },
        report,
    ))
}

/// Appends a value compactly: empty for NaN, rounded to 1e-6 below 1e9, no `-0`.
fn push_number(line: &mut String, v: f64) {
    use std::fmt::Write as _;
    if !v.is_finite() {
        return;
    }
    let r = if v.abs() < 1e9 {
        (v * 1e6).round() / 1e6
    } else {
        v
    };
    let r = if r == 0.0 { 0.0 } else { r };
    let _ = write!(line, "{r}");
}

/// Writes aligned samples as CSV (DATA.md §2): the header, then one row per sample,
/// empty fields for missing values.
pub struct AlignedWriter<W: Write> {
    out: W,
    with_current: bool,
    line: String,
}

impl<W: Write> AlignedWriter<W> {
    /// Writes the header (with `,current` when `with_current`).
    ///
    /// # Errors
    /// The writer's error.
    pub fn new(mut out: W, with_current: bool) -> io::Result<Self> {
        let tail = if with_current { ",current\n" } else { "\n" };
        out.write_all(ALIGNED_HEADER.as_bytes())?;
        out.write_all(tail.as_bytes())?;
        Ok(AlignedWriter {
            out,
            with_current,
            line: String::with_capacity(128),
        })
    }

    /// Writes one sample.
    ///
    /// # Errors
    /// The writer's error.
    pub fn write(&mut self, s: &Sample) -> io::Result<()> {
        use std::fmt::Write as _;
        self.line.clear();
        // Times are written as the grid gives them (no rounding), `-0` as `0`.
        let t = if s.time == 0.0 { 0.0 } else { s.time };
        let _ = write!(self.line, "{t}");
        for v in [s.speed, s.direction, s.voltage, s.load, s.door, s.floor] {
            self.line.push(',');
            push_number(&mut self.line, v);
        }
        if self.with_current {
            self.line.push(',');
            push_number(&mut self.line, s.current);
        }
        self.line.push('\n');
        self.out.write_all(self.line.as_bytes())
    }

    /// Flushes and gives the writer back.
    ///
    /// # Errors
    /// The writer's error on flush.
    pub fn finish(mut self) -> io::Result<W> {
        self.out.flush()?;
        Ok(self.out)
    }
}

/// Writes `samples` as an aligned CSV; the `current` column appears when any sample has one.
///
/// # Errors
/// The writer's error.
pub fn write_aligned<W: Write>(out: W, samples: &[Sample]) -> io::Result<()> {
    let with_current = samples.iter().any(|s| s.current.is_finite());
    let mut w = AlignedWriter::new(BufWriter::new(out), with_current)?;
    for s in samples {
        w.write(s)?;
    }
    w.finish()?.flush()
}

/// Writes `samples` as an aligned CSV file at `path` (replacing it).
///
/// # Errors
/// [`Error::Io`] naming `path`.
pub fn write_aligned_file(path: &Path, samples: &[Sample]) -> Result<()> {
    let file = File::create(path).map_err(|e| Error::io(path, e))?;
    write_aligned(file, samples).map_err(|e| Error::io(path, e))
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
    use std::io::Cursor;

    fn align_text(text: &str, cfg: &AlignConfig) -> Result<(Vec<Sample>, IngestReport)> {
        let mut out = Vec::new();
        let report = align_reader(
            Cursor::new(text.as_bytes()),
            Path::new("t.csv"),
            cfg,
            &mut out,
        )?;
        Ok((out, report))
    }

    fn raw(rows: &[(f64, &str, f64)]) -> String {
        let mut s = String::from("time,signal,value\n");
        for (t, sig, v) in rows {
            s.push_str(&format!("{t},{sig},{v}\n"));
        }
        s
    }

    fn times(samples: &[Sample]) -> Vec<f64> {
        samples.iter().map(|s| s.time).collect()
    }

    #[test]
    fn bad_settings_fail_when_built() {
        assert!(AlignConfig::default().with_step(0.0).is_err());
        assert!(AlignConfig::default().with_step(f64::NAN).is_err());
        assert!(AlignConfig::default().with_gap_limit(-1.0).is_err());
        assert!(AlignConfig::default()
            .with_reorder_window(f64::INFINITY)
            .is_err());
        assert!(AlignConfig::default().with_step(0.5).is_ok());
        let bad = AlignConfig {
            step_s: -1.0,
            ..AlignConfig::default()
        };
        assert!(matches!(
            bad.validate(),
            Err(Error::InvalidConfig {
                field: "step_s",
                ..
            })
        ));
    }

    #[test]
    fn continuous_is_interpolated_and_discrete_held() {
        let text = raw(&[
            (0.5, "speed", 1.0),
            (2.5, "speed", 3.0),
            (0.5, "floor", 4.0),
            (2.5, "floor", 5.0),
        ]);
        let (s, _) = align_text(&text, &AlignConfig::default()).unwrap();
        assert_eq!(times(&s), vec![1.0, 2.0]);
        assert_eq!((s[0].speed, s[1].speed), (1.5, 2.5));
        assert_eq!((s[0].floor, s[1].floor), (4.0, 4.0));
        assert!(s[0].voltage.is_nan());
    }

    #[test]
    fn gap_longer_than_limit_stays_empty() {
        let cfg = AlignConfig::default().with_gap_limit(5.0).unwrap();
        let text = raw(&[
            (0.0, "speed", 0.0),
            (6.0, "speed", 6.0),
            (9.0, "speed", 9.0),
        ]);
        let (s, _) = align_text(&text, &cfg).unwrap();
        assert_eq!(times(&s), (0..=9).map(f64::from).collect::<Vec<_>>());
        assert_eq!(s[0].speed, 0.0);
        assert!(
            s[1..6].iter().all(|x| x.speed.is_nan()),
            "6 s gap must not be bridged"
        );
        assert_eq!(s[6].speed, 6.0);
        assert_eq!(s[7].speed, 7.0);
        assert_eq!(s[9].speed, 9.0);
    }

    #[test]
    fn reading_on_the_grid_is_taken_as_is_even_when_isolated() {
        let text = raw(&[(10.0, "load", 42.0), (100.0, "load", 7.0)]);
        let (s, r) = align_text(&text, &AlignConfig::default()).unwrap();
        assert_eq!(s.len(), 91);
        assert_eq!((s[0].load, s[90].load), (42.0, 7.0));
        assert!(s[1..90].iter().all(|x| x.load.is_nan()));
        assert_eq!(r.samples_with_gaps, 91);
    }

    #[test]
    fn duplicates_average_continuous_and_keep_last_discrete() {
        let text = raw(&[
            (1.0, "voltage", 100.0),
            (1.0, "voltage", 110.0),
            (1.0, "door", 0.0),
            (1.0, "door", 1.0),
            (2.0, "voltage", 120.0),
            (2.0, "door", 1.0),
        ]);
        let (s, r) = align_text(&text, &AlignConfig::default()).unwrap();
        assert_eq!((s[0].voltage, s[0].door), (105.0, 1.0));
        assert_eq!(r.duplicate_timestamps, 2);
    }

    #[test]
    fn rows_within_the_window_are_reordered_in_one_pass() {
        let mut rows: Vec<(f64, &str, f64)> = (0..50)
            .map(|i| (f64::from(i), "speed", f64::from(i)))
            .collect();
        rows.swap(10, 13);
        rows.swap(30, 31);
        let (s, r) = align_text(&raw(&rows), &AlignConfig::default()).unwrap();
        assert_eq!(r.passes, 1);
        assert!(!r.full_sort);
        // 13 before 11, 12, 10 (three rows) and 31 before 30 (one row).
        assert_eq!(r.rows_reordered, 4);
        assert!(s.iter().all(|x| x.speed == x.time));
    }

    #[test]
    fn late_row_triggers_full_sort_and_is_still_used() {
        let mut rows: Vec<(f64, &str, f64)> = (0..100)
            .map(|i| (f64::from(i), "speed", f64::from(i) * 0.5))
            .collect();
        let early = rows.remove(5);
        rows.push(early);
        let cfg = AlignConfig::default().with_reorder_window(10.0).unwrap();
        let (s, r) = align_text(&raw(&rows), &cfg).unwrap();
        assert!(r.full_sort);
        assert_eq!(r.passes, 2);
        assert_eq!(r.late_line, Some(101));
        assert_eq!(r.rows_used, 100);
        assert_eq!(s.len(), 100);
        assert_eq!(s[5].speed, 2.5);
        assert!(s.iter().all(|x| x.speed == x.time * 0.5));
    }

    #[test]
    fn current_appearing_late_restarts_with_its_column() {
        let mut rows: Vec<(f64, &str, f64)> =
            (0..40).map(|i| (f64::from(i), "speed", 1.0)).collect();
        rows.push((39.0, "current", 8.0));
        let cfg = AlignConfig::default().with_reorder_window(2.0).unwrap();
        let sink = std::cell::RefCell::new(Vec::new());
        let mut starts = Vec::new();
        let mut fsink = sink_fn(
            |c| {
                starts.push(c);
                sink.borrow_mut().clear();
                Ok(())
            },
            |s: &Sample| {
                sink.borrow_mut().push(*s);
                Ok(())
            },
        );
        let text = raw(&rows);
        let r = align_reader(
            Cursor::new(text.as_bytes()),
            Path::new("t"),
            &cfg,
            &mut fsink,
        )
        .unwrap();
        let sink = sink.into_inner();
        assert_eq!(starts, vec![false, true]);
        assert_eq!(r.passes, 2);
        assert!(!r.full_sort);
        assert_eq!(sink.len(), 40);
        assert_eq!(sink[39].current, 8.0);
    }

    #[test]
    fn crlf_and_bom_are_accepted() {
        let text = "\u{feff}time,signal,value\r\n0,speed,1\r\n1,speed,2\r\n";
        let (s, r) = align_text(text, &AlignConfig::default()).unwrap();
        assert_eq!(r.bad_rows, 0);
        assert_eq!(
            s.iter().map(|x| x.speed).collect::<Vec<_>>(),
            vec![1.0, 2.0]
        );
    }

    #[test]
    fn rfc3339_times_align_on_unix_seconds() {
        let text = "time,signal,value\n2026-03-01T00:00:00.5Z,speed,1\n2026-03-01T01:00:01.5+01:00,speed,2\n";
        let (s, _) = align_text(text, &AlignConfig::default()).unwrap();
        assert_eq!(s.len(), 1);
        assert_eq!(s[0].time, 20_513.0 * 86_400.0 + 1.0);
        assert_eq!(s[0].speed, 1.5);
    }

    #[test]
    fn decimal_steps_give_decimal_times() {
        let cfg = AlignConfig::default().with_step(0.1).unwrap();
        let (s, _) = align_text(&raw(&[(0.0, "speed", 0.0), (1.0, "speed", 1.0)]), &cfg).unwrap();
        assert_eq!(s.len(), 11);
        assert_eq!(s[3].time, 0.3);
        assert!((s[3].speed - 0.3).abs() < 1e-12);
    }

    #[test]
    fn span_beyond_ten_years_is_refused_before_any_sample() {
        let text = raw(&[
            (0.0, "speed", 1.0),
            (1.0, "speed", 1.0),
            (9e9, "speed", 1.0),
        ]);
        let mut out = Vec::new();
        let err = align_reader(
            Cursor::new(text.as_bytes()),
            Path::new("t"),
            &AlignConfig::default(),
            &mut out,
        )
        .unwrap_err();
        assert!(err.to_string().contains("10 years"), "{err}");
        assert!(out.is_empty());
    }

    #[test]
    fn no_usable_row_is_no_data() {
        for text in [
            "time,signal,value\n",
            "time,signal,value\n1,speed,x\n2,speed,NaN\n3,temp,1\n",
            "time,signal,value\n1e300,speed,1\ninf,speed,1\n",
            "time,signal,value\n0.2,speed,1\n0.4,speed,1\n",
        ] {
            let err = align_text(text, &AlignConfig::default()).unwrap_err();
            assert!(matches!(err, Error::NoData { .. }), "{text}: {err}");
        }
    }

    #[test]
    fn aligned_input_at_the_step_passes_through_unchanged() {
        let text = "time,speed,direction,voltage,load,door,floor,current\n\
                    5,0,0,,10,1,1,\n6,0.5,1,300,10,0,1,2\n7,1,1,310,10,0,1,3\n";
        let (s, r) = align_text(text, &AlignConfig::default()).unwrap();
        assert_eq!(r.layout, Layout::Aligned);
        assert_eq!(r.passes, 1);
        assert_eq!(times(&s), vec![5.0, 6.0, 7.0]);
        assert!(s[0].voltage.is_nan());
        assert_eq!(s[2].current, 3.0);
        let mut written = Vec::new();
        write_aligned(&mut written, &s).unwrap();
        assert_eq!(String::from_utf8(written).unwrap(), text);
    }

    #[test]
    fn aligned_input_at_another_step_is_restepped() {
        let text = "time,speed,direction,voltage,load,door,floor\n0,0,1,1,1,1,1\n2,2,1,1,1,0,1\n4,4,1,1,1,0,1\n";
        let (s, r) = align_text(text, &AlignConfig::default()).unwrap();
        assert_eq!(r.passes, 2);
        assert_eq!(times(&s), vec![0.0, 1.0, 2.0, 3.0, 4.0]);
        assert_eq!(s[1].speed, 1.0);
        assert_eq!(s[1].door, 1.0);
        assert_eq!(s[3].door, 0.0);
    }

    #[test]
    fn writer_leaves_missing_fields_empty_and_rounds() {
        let mut s = Sample::missing(3.0);
        s.speed = 1.0 / 3.0;
        s.floor = 2.0;
        s.direction = -0.0;
        let mut out = Vec::new();
        write_aligned(&mut out, &[s]).unwrap();
        assert_eq!(
            String::from_utf8(out).unwrap(),
            format!("{ALIGNED_HEADER}\n3,0.333333,0,,,,2\n")
        );
    }

    #[test]
    fn pending_readings_stay_within_the_window() {
        // 6 signals at 1 Hz for a day: the buffers hold about (window + gap) s of
        // readings, whatever the length of the input.
        let cfg = AlignConfig::default().with_reorder_window(60.0).unwrap();
        let mut sink = Vec::new();
        let path = Path::new("t");
        let mut engine = Engine::new(&cfg, path, &mut sink, false);
        let mut most = 0;
        for k in 0..86_400 {
            for sig in &Signal::ALL[..6] {
                let t = f64::from(k) + 0.1 * sig.index() as f64;
                assert!(matches!(engine.push(*sig, t, 1.0).unwrap(), Push::Taken));
            }
            most = most.max(engine.tracks.iter().map(|t| t.pending.len()).max().unwrap());
        }
        engine.flush().unwrap();
        assert!(most <= 60 + 5 + 2, "{most} readings pending in one signal");
        assert_eq!(sink.len(), 86_400);
    }

    #[test]
    fn aligned_input_with_a_bad_row_keeps_every_good_row() {
        let text = "time,speed,direction,voltage,load,door,floor\n\
                    0,0,1,1,1,0,1\n1,1,1,1,1,0,1\nbad,9,9,9,9,9,9\n2,2,1,1,1,0,1\n3,3,1,1,1,0,1\n";
        let (s, r) = align_text(text, &AlignConfig::default()).unwrap();
        assert_eq!(r.bad_rows, 1);
        assert_eq!(r.rows_used, 4);
        assert_eq!(times(&s), vec![0.0, 1.0, 2.0, 3.0]);
        assert_eq!(
            s.iter().map(|x| x.speed).collect::<Vec<_>>(),
            vec![0.0, 1.0, 2.0, 3.0]
        );
    }

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
