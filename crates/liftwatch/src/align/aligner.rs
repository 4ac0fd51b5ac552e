//! Stage 2, push-based: the [`Aligner`] of a service, which owns its state and gets its readings
//! one by one from batches that arrive over time (paper, Sec. 4.3: online analysis).
//!
//! ```text
//! push(signal, t, v, sink)   late (t ≤ t_k + gap of a sample out)    → Push::Late, dropped
//!                            (signal, t) pending already             → Push::Duplicate, dropped
//!                            span beyond the limit                   → Push::OutOfSpan, dropped
//!                            more than the window after every time  → Push::Held, until
//!                              taken                                     JUMP_CONFIRM readings
//!                                                                        follow it (sorted in)
//!                                                                        or JUMP_REJECT go on at
//!                                                                        the old times (dropped)
//!                            otherwise sorted in; grid points out once t_max ≥ t_k + gap + window
//! flush(sink)                the rest of the grid (end of data for good)
//! ```
//!
//! The same [`Engine`] as the passes over a file, so a stream whose rows are never later than
//! the reorder window gives the samples `align` gives. Two differences a service cannot avoid:
//! a file reads itself again and sorts when a row comes too late, a service has nothing to
//! read again, so the row is counted and dropped; and a reading at a (signal, time) already
//! pending is a re-sent one (at-least-once delivery), dropped instead of averaged in, so a
//! batch delivered twice changes nothing. An exact repeat of a row, as a logger re-sends it,
//! gives the same sample either way (the mean of two equal values is the value).
//!
//! The state ([`Aligner`] itself) is serde-serialisable, every float through [`crate::exact`]
//! (the bounds start at ±∞), so a service checkpoints it beside the monitor state and resumes
//! bit for bit.

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::engine::{Engine, Push};
use super::{AlignConfig, SampleSink};
use crate::error::Result;
use crate::ingest::Signal;

/// What the aligner dropped and why: the counters a service reports.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct AlignerCounts {
    /// Readings sorted in.
    pub taken: u64,
    /// Readings older than the reorder window ([`Push::Late`]), dropped.
    pub late: u64,
    /// Readings at a (signal, time) already pending ([`Push::Duplicate`]), dropped.
    pub duplicate: u64,
    /// `current` readings after samples without it ([`Push::LateCurrent`]), dropped.
    pub late_current: u64,
    /// Readings beyond the span limit ([`Push::OutOfSpan`]), dropped.
    pub out_of_span: u64,
    /// Readings held as a jump ([`Push::Held`]) that later readings did not follow: clock
    /// glitches, dropped.
    #[serde(default)]
    pub glitches: u64,
    /// Aligned samples produced.
    pub samples: u64,
}

/// The push-based aligner: readings in as they arrive, aligned samples out to a sink passed to
/// each call. See the module docs.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Aligner {
    engine: Engine,
    counts: AlignerCounts,
    /// Readings of a jump beyond the reorder window, in arrival order, not yet confirmed.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    held: Vec<HeldReading>,
    /// Readings taken at the old times since the jump was held.
    #[serde(default, skip_serializing_if = "is_zero")]
    against: u32,
}

/// A reading held while its jump is unconfirmed.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
struct HeldReading {
    sig: Signal,
    #[serde(with = "crate::exact")]
    t: f64,
    #[serde(with = "crate::exact")]
    v: f64,
}

fn is_zero(n: &u32) -> bool {
    *n == 0
}

/// Readings at or after a held jump that confirm it: a logger back after a pause brings
/// several signals at once, a glitch is one reading (a gateway's clock, a flipped bit).
const JUMP_CONFIRM: usize = 3;

/// Readings at the old times after a held jump that make it a glitch: ten seconds of a logger
/// of six signals at 1 Hz. One glitch taken had moved the clock to itself and made every
/// later reading late, acknowledged and dropped, until real time caught up.
const JUMP_REJECT: u32 = 60;

/// Most readings held at once: far-off readings that never confirm one another are no jump.
const MAX_HELD: usize = 64;

/// The name alignment errors carry for a stream (there is no file).
const STREAM_NAME: &str = "telemetry stream";

impl Aligner {
    /// An empty aligner with these settings.
    ///
    /// # Errors
    /// [`crate::Error::InvalidConfig`] for a setting out of range.
    pub fn new(cfg: &AlignConfig) -> Result<Self> {
        cfg.validate()?;
        Ok(Aligner {
            engine: Engine::new(cfg, false),
            counts: AlignerCounts::default(),
            held: Vec::new(),
            against: 0,
        })
    }

    /// The step Δ of the samples produced (s).
    pub fn step_s(&self) -> f64 {
        self.engine.step()
    }

    /// Pushes one reading, handing every grid point it makes certain to `sink`; a reading that
    /// cannot be taken is counted and dropped (see [`Push`]).
    ///
    /// # Errors
    /// Only the sink's own error; nothing the reading does is an error.
    pub fn push<S: SampleSink>(
        &mut self,
        sig: Signal,
        t: f64,
        v: f64,
        sink: &mut S,
    ) -> Result<Push, S::Error> {
        // A jump beyond the reorder window is held until later readings say what it is.
        let window = self.engine.window();
        let beyond = self
            .engine
            .time_range()
            .is_some_and(|(_, hi)| t > hi + window);
        if beyond {
            if self.held.len() >= MAX_HELD {
                // Scattered far-off readings that never confirm one another: the oldest goes.
                self.held.remove(0);
                self.counts.glitches += 1;
            }
            self.held.push(HeldReading { sig, t, v });
            let near = |h: &HeldReading| (h.t - t).abs() <= window;
            if self.held.iter().filter(|h| near(h)).count() < JUMP_CONFIRM {
                return Ok(Push::Held);
            }
            // Confirmed: the readings of this jump go in in their order, this one last; held
            // readings of another time were glitches.
            let held = std::mem::take(&mut self.held);
            self.against = 0;
            let (jump, other): (Vec<HeldReading>, Vec<HeldReading>) =
                held.into_iter().partition(|h| near(h));
            self.counts.glitches += other.len() as u64;
            let (last, rest) = jump.split_last().expect("this reading is near itself");
            for h in rest {
                self.take_one(h.sig, h.t, h.v, sink)?;
            }
            return self.take_one(last.sig, last.t, last.v, sink);
        }
        if !self.held.is_empty() {
            self.against += 1;
            if self.against >= JUMP_REJECT {
                self.counts.glitches += self.held.len() as u64;
                self.held.clear();
                self.against = 0;
            }
        }
        self.take_one(sig, t, v, sink)
    }

    /// The reading through the engine, counted.
    fn take_one<S: SampleSink>(
        &mut self,
        sig: Signal,
        t: f64,
        v: f64,
        sink: &mut S,
    ) -> Result<Push, S::Error> {
        let before = self.engine.samples;
        let outcome = match self.engine.refusal(sig, t) {
            Some(refused) => refused,
            None if self.engine.tracks[sig.index()].has_pending_at(t) => Push::Duplicate,
            None if self.engine.widen(t, Path::new(STREAM_NAME)).is_err() => Push::OutOfSpan,
            None => self.engine.take(sig, t, v, sink)?,
        };
        let c = &mut self.counts;
        match outcome {
            Push::Taken => c.taken += 1,
            Push::Late => c.late += 1,
            Push::Duplicate => c.duplicate += 1,
            Push::LateCurrent => c.late_current += 1,
            Push::OutOfSpan => c.out_of_span += 1,
            Push::Held => {}
        }
        c.samples += self.engine.samples - before;
        Ok(outcome)
    }

    /// Produces the rest of the grid, through the last usable time: the end of the data for
    /// good (a service that goes on never calls it).
    ///
    /// # Errors
    /// The sink's error.
    pub fn flush<S: SampleSink>(&mut self, sink: &mut S) -> Result<(), S::Error> {
        // A jump nothing confirmed by the end is a glitch.
        self.counts.glitches += self.held.len() as u64;
        self.held.clear();
        self.against = 0;
        let before = self.engine.samples;
        self.engine.flush(sink)?;
        self.counts.samples += self.engine.samples - before;
        Ok(())
    }

    /// What was taken, dropped and produced so far.
    pub fn counts(&self) -> AlignerCounts {
        self.counts
    }

    /// The time range of the readings taken, `None` before the first.
    pub fn time_range(&self) -> Option<(f64, f64)> {
        self.engine.time_range()
    }

    /// Readings at or before this time come too late (−∞ before the first sample).
    pub fn late_bound(&self) -> f64 {
        self.engine.late_bound
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sample::Sample;
    use std::io::Cursor;

    /// A raw log of the six core signals at 1 Hz with jitter, as rows.
    fn rows(n: u32) -> Vec<(Signal, f64, f64)> {
        let mut out = Vec::new();
        for k in 0..n {
            for sig in &Signal::ALL[..6] {
                let t = f64::from(k) + 0.13 * sig.index() as f64;
                let v = (f64::from(k) * 0.1 + sig.index() as f64).sin().abs();
                out.push((*sig, t, v));
            }
        }
        out
    }

    fn csv(rows: &[(Signal, f64, f64)]) -> String {
        let mut s = String::from("time,signal,value\n");
        for (sig, t, v) in rows {
            s.push_str(&format!("{t:?},{},{v:?}\n", sig.name()));
        }
        s
    }

    fn file_samples(rows: &[(Signal, f64, f64)], cfg: &AlignConfig) -> Vec<Sample> {
        let mut out = Vec::new();
        let text = csv(rows);
        super::super::align_reader(Cursor::new(text), Path::new("t"), cfg, &mut out).unwrap();
        out
    }

    /// An aligner fed `rows` one by one and flushed, with the samples it produced.
    fn pushed(rows: &[(Signal, f64, f64)], cfg: &AlignConfig) -> (Aligner, Vec<Sample>) {
        let mut a = Aligner::new(cfg).unwrap();
        let mut out: Vec<Sample> = Vec::new();
        for (sig, t, v) in rows {
            a.push(*sig, *t, *v, &mut out).unwrap();
        }
        a.flush(&mut out).unwrap();
        (a, out)
    }

    /// `out` is what the pass over a file of `rows` gives.
    fn assert_same_as_file(out: &[Sample], rows: &[(Signal, f64, f64)], cfg: &AlignConfig) {
        let want = file_samples(rows, cfg);
        assert_eq!(out.len(), want.len());
        for (x, y) in out.iter().zip(&want) {
            assert_eq!(format!("{x:?}"), format!("{y:?}"));
        }
    }

    #[test]
    fn pushed_readings_give_the_samples_of_the_file_pass() {
        let cfg = AlignConfig::default().with_reorder_window(30.0).unwrap();
        let rows = rows(600);
        let (_, out) = pushed(&rows, &cfg);
        assert_same_as_file(&out, &rows, &cfg);
    }

    #[test]
    fn a_batch_sent_twice_and_a_state_round_trip_change_nothing() {
        let cfg = AlignConfig::default().with_reorder_window(30.0).unwrap();
        let rows = rows(600);
        let mut a = Aligner::new(&cfg).unwrap();
        let mut out: Vec<Sample> = Vec::new();
        for (i, chunk) in rows.chunks(60).enumerate() {
            // Every third batch is delivered twice; every batch goes through a saved state.
            let times = if i % 3 == 0 { 2 } else { 1 };
            for _ in 0..times {
                for (sig, t, v) in chunk {
                    a.push(*sig, *t, *v, &mut out).unwrap();
                }
            }
            let json = serde_json::to_string(&a).unwrap();
            a = serde_json::from_str(&json).unwrap();
        }
        a.flush(&mut out).unwrap();
        assert_same_as_file(&out, &rows, &cfg);
        let c = a.counts();
        assert_eq!(c.taken, rows.len() as u64);
        let resent = rows.chunks(60).step_by(3).map(<[_]>::len).sum::<usize>();
        assert_eq!(c.duplicate + c.late, resent as u64, "{c:?}");
    }

    #[test]
    fn a_reading_older_than_the_window_is_counted_and_dropped() {
        let cfg = AlignConfig::default().with_reorder_window(10.0).unwrap();
        let mut a = Aligner::new(&cfg).unwrap();
        let mut out: Vec<Sample> = Vec::new();
        for k in 0..100 {
            a.push(Signal::Speed, f64::from(k), 1.0, &mut out).unwrap();
        }
        assert_eq!(
            a.push(Signal::Speed, 3.5, 2.0, &mut out).unwrap(),
            Push::Late
        );
        assert_eq!(
            a.push(Signal::Speed, 1e12, 2.0, &mut out).unwrap(),
            Push::Held
        );
        assert_eq!(a.counts().late, 1);
        a.flush(&mut out).unwrap();
        assert_eq!(
            a.counts().glitches,
            1,
            "a jump nothing confirmed is a glitch"
        );
    }

    #[test]
    fn a_lone_reading_far_ahead_is_a_glitch_and_changes_no_sample() {
        let cfg = AlignConfig::default().with_reorder_window(30.0).unwrap();
        let rows = rows(600);
        let mut a = Aligner::new(&cfg).unwrap();
        let mut out: Vec<Sample> = Vec::new();
        for (i, (sig, t, v)) in rows.iter().enumerate() {
            if i == 1000 {
                // A gateway's clock glitch: one reading 100 days ahead, through a checkpoint.
                assert_eq!(
                    a.push(Signal::Speed, 8.64e6, 0.0, &mut out).unwrap(),
                    Push::Held
                );
                a = serde_json::from_str(&serde_json::to_string(&a).unwrap()).unwrap();
            }
            a.push(*sig, *t, *v, &mut out).unwrap();
        }
        a.flush(&mut out).unwrap();
        assert_same_as_file(&out, &rows, &cfg);
        let c = a.counts();
        assert_eq!((c.glitches, c.late, c.taken), (1, 0, rows.len() as u64));
    }

    #[test]
    fn a_logger_back_after_a_pause_is_a_jump_confirmed_and_taken() {
        let cfg = AlignConfig::default().with_reorder_window(30.0).unwrap();
        let mut rows = rows(300);
        let later: Vec<_> = rows
            .iter()
            .map(|&(sig, t, v)| (sig, t + 5000.0, v))
            .collect();
        rows.extend(later);
        let (a, out) = pushed(&rows, &cfg);
        assert_same_as_file(&out, &rows, &cfg);
        let c = a.counts();
        assert_eq!((c.glitches, c.taken), (0, rows.len() as u64));
    }
}
