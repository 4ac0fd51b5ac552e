//! Stage 2, the passes over a file: streaming, the in-memory sort, and pass-through of
//! aligned input already at the step (paper, Sec. 4.1; DATA.md §2).
//!
//! ```text
//! stream        readings sorted in per signal, t_k out once t_max ≥ t_k + gap + window
//! sorted        all readings kept as 16-byte records, stable sort per signal, then the grid
//! pass-through  aligned rows at |t_i − t_{i−1} − Δ| <= 0.001·Δ go out as they are
//! ```
//!
//! Each pass ends with an [`Outcome`]; [`super::align_reader`] picks the next [`Plan`] from it.

use std::collections::VecDeque;
use std::io::Read;
use std::ops::ControlFlow;

use super::engine::{has_gap, max_span, span_error, Engine, Push, Reading};
use super::{AlignConfig, SampleSink};
use crate::error::Result;
use crate::ingest::csv::RowReader;
use crate::ingest::{IngestReport, Signal};

/// How one pass over the file ended.
pub(super) enum Outcome {
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
pub(super) enum Plan {
    /// Aligned input at the step: rows go out as they are.
    PassThrough,
    /// Stream with the reorder window.
    Stream {
        /// Whether the series carries `current` from the start.
        has_current: bool,
    },
    /// Keep every reading, sort, then align.
    Sorted {
        /// Whether the series carries `current`.
        has_current: bool,
    },
}

/// One streaming pass: readings through the engine; stops at a row too late for the window
/// or at a `current` arriving after samples without it.
pub(super) fn stream_pass<R: Read, S: SampleSink>(
    rows: &mut RowReader<R>,
    cfg: &AlignConfig,
    sink: &mut S,
    has_current: bool,
    report: &mut IngestReport,
) -> Result<Outcome, S::Error> {
    let path = rows.path().to_path_buf();
    let mut engine = Engine::new(cfg, has_current);
    let mut outcome = Outcome::Done;
    rows.for_each_reading::<S::Error>(report, |t, sig, v, line| {
        match engine.push(sig, t, v, &path, sink)? {
            Push::Taken => Ok(ControlFlow::Continue(())),
            Push::Late => {
                outcome = Outcome::Late(line);
                Ok(ControlFlow::Break(()))
            }
            Push::LateCurrent => {
                outcome = Outcome::LateCurrent;
                Ok(ControlFlow::Break(()))
            }
            // Engine::push returns neither: a file keeps duplicates (mean or last) and fails on
            // a span beyond the limit.
            Push::Duplicate | Push::OutOfSpan | Push::Held => Ok(ControlFlow::Continue(())),
        }
    })?;
    if matches!(outcome, Outcome::Done) {
        engine.flush(sink)?;
    }
    engine.report_into(report);
    Ok(outcome)
}

/// The streaming pass fed row by row by the writer of the file instead of read from it: the
/// simulator aligns the raw rows it logs, as they are written, into the aligned series it writes
/// beside them. Same engine, same rules (duplicates averaged or last, gaps left empty) as
/// [`stream_pass`] reading that file back, so the samples are those `align` makes of it.
pub(crate) struct RowStream {
    engine: Engine,
    path: std::path::PathBuf,
}

impl RowStream {
    /// An empty stream of the file `path` (named in messages).
    ///
    /// # Errors
    /// [`crate::Error::InvalidConfig`] for a bad `cfg`.
    pub(crate) fn new(cfg: &AlignConfig, path: &std::path::Path) -> Result<Self> {
        cfg.validate()?;
        Ok(RowStream {
            engine: Engine::new(cfg, false),
            path: path.to_path_buf(),
        })
    }

    /// One reading, as a reader of the file gets it, in file order; grid points it makes
    /// certain go to `sink`.
    ///
    /// # Errors
    /// The sink's error; [`crate::Error::BadDocument`] for a span beyond the limit or a row
    /// later than the reorder window (which a file would have sorted in a second pass: a
    /// writer feeding this stream must keep its rows within the window).
    pub(crate) fn push<S: SampleSink>(
        &mut self,
        sig: Signal,
        t: f64,
        v: f64,
        sink: &mut S,
    ) -> Result<(), S::Error> {
        match self.engine.push(sig, t, v, &self.path, sink)? {
            Push::Late | Push::LateCurrent => Err(crate::Error::BadDocument {
                path: self.path.clone(),
                what: "telemetry log",
                why: format!(
                    "a {} row at {t} s comes later than the reorder window allows",
                    sig.name()
                ),
            }
            .into()),
            Push::Taken | Push::Duplicate | Push::OutOfSpan | Push::Held => Ok(()),
        }
    }

    /// The rest of the grid: the end of the file.
    ///
    /// # Errors
    /// The sink's error.
    pub(crate) fn flush<S: SampleSink>(&mut self, sink: &mut S) -> Result<(), S::Error> {
        self.engine.flush(sink)
    }
}

/// One pass that keeps every reading in memory, sorts each signal (stable) and aligns.
pub(super) fn sorted_pass<R: Read, S: SampleSink>(
    rows: &mut RowReader<R>,
    cfg: &AlignConfig,
    sink: &mut S,
    has_current: bool,
    report: &mut IngestReport,
) -> Result<Outcome, S::Error> {
    let path = rows.path().to_path_buf();
    let mut engine = Engine::new(cfg, has_current);
    let mut data: [Vec<Reading>; 7] = Default::default();
    let mut max_t = [f64::NEG_INFINITY; 7];
    let mut reordered = 0u64;
    rows.for_each_reading::<S::Error>(report, |t, sig, v, _| {
        engine.widen(t, &path)?;
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
    engine.flush(sink)?;
    engine.report_into(report);
    report.duplicate_timestamps = duplicates;
    report.rows_reordered = reordered;
    Ok(Outcome::Done)
}

/// Aligned input at the configured step: every row goes out as it is.
pub(super) fn pass_through<R: Read, S: SampleSink>(
    rows: &mut RowReader<R>,
    cfg: &AlignConfig,
    sink: &mut S,
    report: &mut IngestReport,
) -> Result<Outcome, S::Error> {
    let has_current = rows.has_current_column();
    let path = rows.path().to_path_buf();
    let tolerance = 1e-3 * cfg.step_s;
    let (mut first, mut prev) = (f64::NAN, f64::NAN);
    let mut outcome = Outcome::Done;
    let (mut samples, mut with_gaps) = (0u64, 0u64);
    let mut input_step = f64::NAN;
    rows.for_each_row::<S::Error>(report, |s, _| {
        if prev.is_nan() {
            first = s.time;
            sink.start(has_current)?;
        } else {
            if samples == 1 {
                input_step = s.time - first;
            }
            if (s.time - prev - cfg.step_s).abs() > tolerance {
                outcome = Outcome::NonUniform;
                return Ok(ControlFlow::Break(()));
            }
        }
        if s.time - first > max_span(cfg.step_s) {
            return Err(span_error(&path, first, s.time, cfg.step_s).into());
        }
        prev = s.time;
        samples += 1;
        with_gaps += u64::from(has_gap(s));
        sink.push(s)?;
        Ok(ControlFlow::Continue(()))
    })?;
    report.samples = samples;
    report.samples_with_gaps = with_gaps;
    report.input_step_s = input_step;
    if samples > 0 {
        report.time_range = (first, prev);
    }
    Ok(outcome)
}
