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
//! usable times spanning more than a week plus [`MAX_ROWS_PER_READING`] grid points per usable
//! reading so far (a handful of rows cannot ask for gigabytes of empty output), more than
//! [`MAX_SPAN_S`] (10 years), or more than
//! [`MAX_SAMPLES`] grid points, are refused as soon as a row shows it, before that
//! grid is produced.
//!
//! Deviation from the paper: the paper does not state its interpolation or how gaps
//! are treated; we interpolate linearly, hold discrete states and never bridge a gap
//! longer than `gap_limit_s`, because an invented value would turn into a residual.
//!
//! The files: `engine.rs` holds the per-signal buffers, the grid and the interpolation;
//! `passes.rs` the three ways through a file (stream, sort, pass through); `aligner.rs` the
//! push-based [`Aligner`] of a service, the same engine with a serialisable state; `sink.rs` the
//! receiving end, [`SampleSink`] with its own error type, and its sinks; `writer.rs` the
//! aligned CSV; `pipelined.rs` [`align_file_pipelined`], the reading on a thread of its own
//! beside a sink that has work of its own to do (the monitor's step, the aligned writer);
//! `spill.rs` [`read_spilled`], the samples in a temporary file for a reader that reads them
//! in passes without holding them (the fit).

mod aligner;
mod engine;
mod passes;
mod pipelined;
mod sink;
mod spill;
mod writer;

use std::io::{Read, Seek, SeekFrom};
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::ingest::csv::RowReader;
use crate::ingest::{IngestReport, Layout};
use crate::input::Input;
use crate::sample::{AlignedSeries, DAY_S, YEAR_S};
use passes::{pass_through, sorted_pass, stream_pass, Outcome, Plan};

pub use aligner::{Aligner, AlignerCounts};
pub use engine::Push;
pub(crate) use passes::RowStream;
pub use pipelined::align_file_pipelined;
pub use sink::{sink_fn, AlignedFileSink, FnSink, SampleSink};
pub use spill::{read_spilled, SpillSink, SpilledSeries};
pub(crate) use writer::push_sample;
pub use writer::{write_aligned, write_aligned_file, AlignedWriter};

/// Longest accepted span of usable times (s): 10 years.
pub const MAX_SPAN_S: f64 = 10.0 * YEAR_S;

/// Most grid points one input may produce: 10 years at 1 s.
pub const MAX_SAMPLES: f64 = MAX_SPAN_S;

/// Grid points one usable reading may account for beyond [`FREE_SPAN_S`]: a log has several
/// readings per second, so even a channel logged every quarter hour stays far below; a few rows
/// spanning years (an 80 KB file asking for gigabytes of empty rows) are refused.
pub const MAX_ROWS_PER_READING: f64 = 1000.0;

/// Span (s) any input may cover regardless of how few readings it has: a week.
pub const FREE_SPAN_S: f64 = 7.0 * DAY_S;

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
            why: format!("{} s is outside {lo} to {hi} s", crate::error::number(v)),
        })
    }
}

impl AlignConfig {
    /// Sets the step Δ (s).
    ///
    /// # Errors
    /// [`Error::InvalidConfig`] unless 0.001 <= `step_s` <= 86400.
    pub fn with_step(mut self, step_s: f64) -> Result<Self> {
        check_range("step_s", step_s, 1e-3, DAY_S)?;
        self.step_s = step_s;
        Ok(self)
    }

    /// Sets the gap limit (s).
    ///
    /// # Errors
    /// [`Error::InvalidConfig`] unless 0 <= `gap_limit_s` <= 86400.
    pub fn with_gap_limit(mut self, gap_limit_s: f64) -> Result<Self> {
        check_range("gap_limit_s", gap_limit_s, 0.0, DAY_S)?;
        self.gap_limit_s = gap_limit_s;
        Ok(self)
    }

    /// Sets the reorder window (s).
    ///
    /// # Errors
    /// [`Error::InvalidConfig`] unless 0 <= `reorder_window_s` <= 86400.
    pub fn with_reorder_window(mut self, reorder_window_s: f64) -> Result<Self> {
        check_range("reorder_window_s", reorder_window_s, 0.0, DAY_S)?;
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
/// results; [`Error::BadDocument`] when usable times span more than the limit; all of
/// these converted into the sink's error type, `S::Error`. Or the sink's own error,
/// unchanged. Samples already pushed before an error are not taken back.
pub fn align_reader<R: Read + Seek, S: SampleSink>(
    mut input: R,
    path: &Path,
    cfg: &AlignConfig,
    sink: &mut S,
) -> Result<IngestReport, S::Error> {
    cfg.validate()?;
    let mut plan = None;
    let mut late_line = None;
    // Measured by the pass-through attempt, kept through the passes that re-step.
    let mut input_step = f64::NAN;
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
        if report.input_step_s.is_finite() {
            input_step = report.input_step_s;
        }
        plan = Some(match outcome {
            Outcome::Done => {
                report.input_step_s = input_step;
                report.passes = pass;
                report.late_line = late_line;
                report.full_sort = matches!(p, Plan::Sorted { .. });
                return match no_data(path, &report, cfg.step_s) {
                    Some(err) => Err(err.into()),
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
/// `path` is opened by [`Input::open`]: `-` is standard input, a `.gz` name is decompressed.
///
/// # Errors
/// As [`align_reader`]; a missing file is [`Error::Io`].
pub fn align_file<S: SampleSink>(
    path: &Path,
    cfg: &AlignConfig,
    sink: &mut S,
) -> Result<IngestReport, S::Error> {
    let input = Input::open(path)?;
    let name = input.name().to_path_buf();
    align_reader(input, &name, cfg, sink)
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sample::Sample;
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
                Ok::<_, Error>(())
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
        assert_eq!(s[0].time, 20_513.0 * DAY_S + 1.0);
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
}
