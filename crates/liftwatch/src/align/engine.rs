//! Stage 2, the engine: per-signal buffers, the grid, interpolation, hold and gaps
//! (paper, Sec. 4.1; DATA.md §2).
//!
//! ```text
//! grid        t_k = k·Δ, exact decimal when Δ has at most 5 decimals
//! brackets    p = last reading with t_p <= t_k,  n = first with t_n >= t_k
//! continuous  x(t_k) = x_p + (x_n − x_p)·(t_k − t_p)/(t_n − t_p)
//! discrete    x(t_k) = x_p
//! gap         x(t_k) = NaN if p or n is absent or t_n − t_p > gap_limit_s
//! emit        t_k goes out once the latest time ≥ t_k + gap_limit_s + reorder_window_s
//! ```
//!
//! The engine serves the streaming and the sorted pass over a file ([`super::passes`]) and the
//! push-based [`super::Aligner`] of a service: one engine, its state owned (serialisable), the
//! sink and the name used in messages passed to each call. The sink's error comes back
//! unchanged, the engine's own (a span beyond the limit) is converted into it.

use std::collections::VecDeque;
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::{AlignConfig, SampleSink, FREE_SPAN_S, MAX_ROWS_PER_READING, MAX_SAMPLES, MAX_SPAN_S};
use crate::error::{Error, Result};
use crate::ingest::{IngestReport, Signal};
use crate::sample::Sample;

/// One reading of one signal: 16 bytes, the signal is the buffer it sits in.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub(super) struct Reading {
    /// Time (s).
    #[serde(with = "crate::exact")]
    pub(super) t: f64,
    /// Value.
    #[serde(with = "crate::exact")]
    pub(super) v: f64,
}

/// The readings of one signal not yet behind the grid, and the last one that is.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub(super) struct Track {
    pub(super) pending: VecDeque<Reading>,
    prev: Option<Reading>,
    #[serde(with = "crate::exact")]
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

    /// True when a reading at exactly time `t` is pending (a re-sent reading, for a service).
    pub(super) fn has_pending_at(&self, t: f64) -> bool {
        let pos = self.pending.partition_point(|x| x.t < t);
        self.pending.get(pos).is_some_and(|r| r.t == t)
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
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
struct Grid {
    #[serde(with = "crate::exact")]
    step: f64,
    #[serde(with = "crate::exact")]
    units: f64,
    #[serde(with = "crate::exact")]
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

/// The error for usable times spanning more than the limit.
pub(super) fn span_error(path: &Path, lo: f64, hi: f64, step: f64) -> Error {
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

/// The longest span of usable times at this step (s).
pub(super) fn max_span(step: f64) -> f64 {
    MAX_SPAN_S.min(MAX_SAMPLES * step)
}

/// What a reading did to the aligner.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Push {
    /// Sorted in; it will shape the samples around its time.
    Taken,
    /// Earlier than the grid already produced allows (older than the reorder window): a file
    /// is read again and sorted, a service counts and drops it.
    Late,
    /// The first `current` reading after samples without `current` went out: a file restarts
    /// with the column, a service counts and drops it.
    LateCurrent,
    /// ([`super::Aligner`] only) a reading of this signal at exactly this time is pending
    /// already: a re-sent reading, dropped, so that a batch delivered twice changes nothing.
    Duplicate,
    /// ([`super::Aligner`] only) its time would stretch the span of usable times beyond the
    /// limit (a clock jump): dropped.
    OutOfSpan,
    /// ([`super::Aligner`] only) more than the reorder window after every time taken: held
    /// until later readings confirm the jump (then sorted in) or go on at the old times (then
    /// dropped as a clock glitch).
    Held,
}

/// The alignment machinery shared by the streaming and the sorted pass over a file and by the
/// push-based [`super::Aligner`]: everything it carries from one reading to the next, owned and
/// serialisable (the floats through [`crate::exact`]: the bounds start at ±∞).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub(super) struct Engine {
    grid: Grid,
    #[serde(with = "crate::exact")]
    gap: f64,
    #[serde(with = "crate::exact")]
    window: f64,
    pub(super) tracks: [Track; 7],
    #[serde(with = "crate::exact")]
    t_min: f64,
    #[serde(with = "crate::exact")]
    t_max: f64,
    #[serde(with = "crate::exact")]
    max_span: f64,
    /// Usable readings taken so far (the span they may cover grows with them).
    #[serde(with = "crate::exact")]
    readings: f64,
    next_k: Option<i64>,
    /// The latest time must reach this before the next grid point can go out.
    #[serde(with = "crate::exact")]
    next_emit_at: f64,
    /// Readings at or before this time would change a sample already produced.
    #[serde(with = "crate::exact")]
    pub(super) late_bound: f64,
    pub(super) has_current: bool,
    pub(super) started: bool,
    pub(super) samples: u64,
    samples_with_gaps: u64,
    duplicates: u64,
    reordered: u64,
}

impl Engine {
    pub(super) fn new(cfg: &AlignConfig, has_current: bool) -> Self {
        Engine {
            grid: Grid::new(cfg.step_s),
            gap: cfg.gap_limit_s,
            window: cfg.reorder_window_s,
            tracks: Signal::ALL.map(Track::new),
            t_min: f64::INFINITY,
            t_max: f64::NEG_INFINITY,
            max_span: max_span(cfg.step_s),
            readings: 0.0,
            next_k: None,
            next_emit_at: f64::NEG_INFINITY,
            late_bound: f64::NEG_INFINITY,
            has_current,
            started: false,
            samples: 0,
            samples_with_gaps: 0,
            duplicates: 0,
            reordered: 0,
        }
    }

    /// The step Δ (s).
    pub(super) fn step(&self) -> f64 {
        self.grid.step
    }

    /// The reorder window (s).
    pub(super) fn window(&self) -> f64 {
        self.window
    }

    /// Widens the known time range to `t`, refusing a span beyond the limit; `path` names the
    /// input in the message. Nothing changes on an error.
    pub(super) fn widen(&mut self, t: f64, path: &Path) -> Result<()> {
        let (lo, hi) = (self.t_min.min(t), self.t_max.max(t));
        if hi - lo > self.max_span {
            return Err(span_error(path, lo, hi, self.grid.step));
        }
        let readings = self.readings + 1.0;
        let allowed = FREE_SPAN_S + MAX_ROWS_PER_READING * readings * self.grid.step;
        if hi - lo > allowed {
            return Err(Error::BadDocument {
                path: path.to_path_buf(),
                what: "telemetry log",
                why: format!(
                    "{readings:.0} readings span {:.0} s (from {} to {}): too few to fill that span (a week plus {MAX_ROWS_PER_READING:.0} steps per reading); split the log at the gap, or drop a row whose time is far off",
                    hi - lo,
                    crate::error::number(lo),
                    crate::error::number(hi)
                ),
            });
        }
        self.readings = readings;
        self.t_min = lo;
        self.t_max = hi;
        Ok(())
    }

    /// Streams one reading of a file in, producing every grid point it makes certain.
    pub(super) fn push<S: SampleSink>(
        &mut self,
        sig: Signal,
        t: f64,
        v: f64,
        path: &Path,
        sink: &mut S,
    ) -> Result<Push, S::Error> {
        if let Some(refused) = self.refusal(sig, t) {
            return Ok(refused);
        }
        self.widen(t, path)?;
        self.take(sig, t, v, sink)
    }

    /// Why a reading cannot be sorted in (late, or a late `current`), or `None`; a first
    /// `current` before any sample went out switches the column on.
    pub(super) fn refusal(&mut self, sig: Signal, t: f64) -> Option<Push> {
        if t <= self.late_bound {
            return Some(Push::Late);
        }
        if sig == Signal::Current && !self.has_current {
            if self.started {
                return Some(Push::LateCurrent);
            }
            self.has_current = true;
        }
        None
    }

    /// Sorts a reading whose time [`Engine::widen`] accepted in and produces every grid point
    /// it makes certain.
    pub(super) fn take<S: SampleSink>(
        &mut self,
        sig: Signal,
        t: f64,
        v: f64,
        sink: &mut S,
    ) -> Result<Push, S::Error> {
        let (reordered, dup) = self.tracks[sig.index()].insert(Reading { t, v });
        self.reordered += u64::from(reordered);
        self.duplicates += u64::from(dup);
        if self.t_max >= self.next_emit_at {
            self.emit_through(self.t_max - self.window, sink)?;
        }
        Ok(Push::Taken)
    }

    /// Produces grid points t_k with t_k + gap <= `limit` and t_k <= the latest time.
    fn emit_through<S: SampleSink>(&mut self, limit: f64, sink: &mut S) -> Result<(), S::Error> {
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
            self.emit(g, sink)?;
            self.next_k = Some(k + 1);
        }
    }

    /// Produces grid point `g` and hands it to the sink, starting the sink first.
    fn emit<S: SampleSink>(&mut self, g: f64, sink: &mut S) -> Result<(), S::Error> {
        if !self.started {
            sink.start(self.has_current)?;
            self.started = true;
        }
        let mut s = Sample::missing(g);
        for (sig, track) in Signal::ALL.into_iter().zip(self.tracks.iter_mut()) {
            sig.set(&mut s, track.value_at(g, self.gap));
        }
        self.samples += 1;
        self.samples_with_gaps += u64::from(has_gap(&s));
        self.late_bound = g + self.gap;
        sink.push(&s)
    }

    /// Produces the rest of the grid, through the last usable time.
    pub(super) fn flush<S: SampleSink>(&mut self, sink: &mut S) -> Result<(), S::Error> {
        self.emit_through(f64::INFINITY, sink)
    }

    /// Copies the counts and the time range into `report`.
    pub(super) fn report_into(&self, report: &mut IngestReport) {
        report.samples = self.samples;
        report.samples_with_gaps = self.samples_with_gaps;
        report.duplicate_timestamps = self.duplicates;
        report.rows_reordered = self.reordered;
        if self.t_min <= self.t_max {
            report.time_range = (self.t_min, self.t_max);
        }
    }

    /// The time range of the usable readings taken, `None` before the first.
    pub(super) fn time_range(&self) -> Option<(f64, f64)> {
        (self.t_min <= self.t_max).then_some((self.t_min, self.t_max))
    }
}

/// True when one of the six core signals (all but `current`) is missing.
pub(super) fn has_gap(s: &Sample) -> bool {
    ![s.speed, s.direction, s.voltage, s.load, s.door, s.floor]
        .iter()
        .all(|v| v.is_finite())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pending_readings_stay_within_the_window() {
        // 6 signals at 1 Hz for a day: the buffers hold about (window + gap) s of
        // readings, whatever the length of the input.
        let cfg = AlignConfig::default().with_reorder_window(60.0).unwrap();
        let mut sink = Vec::new();
        let path = Path::new("t");
        let mut engine = Engine::new(&cfg, false);
        let mut most = 0;
        for k in 0..86_400 {
            for sig in &Signal::ALL[..6] {
                let t = f64::from(k) + 0.1 * sig.index() as f64;
                assert!(matches!(
                    engine.push(*sig, t, 1.0, path, &mut sink).unwrap(),
                    Push::Taken
                ));
            }
            most = most.max(engine.tracks.iter().map(|t| t.pending.len()).max().unwrap());
        }
        engine.flush(&mut sink).unwrap();
        assert!(most <= 60 + 5 + 2, "{most} readings pending in one signal");
        assert_eq!(sink.len(), 86_400);
    }
}
