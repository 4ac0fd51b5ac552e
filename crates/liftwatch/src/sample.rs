//! The unit that flows between stages: one aligned sample of all signals.
//!
//! Missing values are `NaN`: an aligned file's empty field, a gap longer than the
//! alignment limit, a sensor that dropped out. Every later stage checks with
//! [`f64::is_finite`] before using a field.

use serde::{Deserialize, Serialize};

use crate::error::Result;

/// Seconds in an hour. Every time in the pipeline is in seconds of the data clock (DATA.md
/// §2), so the hour and the day are named once, here, for every stage that counts in them.
pub const HOUR_S: f64 = 3600.0;

/// Seconds in a day of the data clock: Unix time's day, without leap seconds.
pub const DAY_S: f64 = 24.0 * HOUR_S;

/// Days in a Julian year, the year of rates per elevator-year.
pub const YEAR_DAYS: f64 = 365.25;

/// Seconds in a Julian year ([`YEAR_DAYS`] days).
pub const YEAR_S: f64 = YEAR_DAYS * DAY_S;

/// Signals of one aligned instant (DATA.md §2). `NaN` marks a missing value.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Sample {
    /// Time (s).
    pub time: f64,
    /// Car speed magnitude from the encoder (m/s, >= 0).
    pub speed: f64,
    /// Travel direction from the controller: 1 up, -1 down, 0 none.
    pub direction: f64,
    /// Traction motor voltage magnitude (V).
    pub voltage: f64,
    /// Load-weighing sensor, tare removed (percent of rated load).
    pub load: f64,
    /// Door: 1 open or opening, 0 closed.
    pub door: f64,
    /// Floor indicator, 1-based.
    pub floor: f64,
    /// Motor current (A), usually absent.
    pub current: f64,
}

impl Sample {
    /// A sample at `time` with every signal missing.
    pub fn missing(time: f64) -> Self {
        Sample {
            time,
            speed: f64::NAN,
            direction: f64::NAN,
            voltage: f64::NAN,
            load: f64::NAN,
            door: f64::NAN,
            floor: f64::NAN,
            current: f64::NAN,
        }
    }
}

/// A uniformly stepped series of samples (DATA.md §2): the output of alignment.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AlignedSeries {
    /// The uniform step (s).
    pub step_s: f64,
    /// The samples, in time order, `step_s` apart.
    pub samples: Vec<Sample>,
}

/// An aligned history that can be read more than once, each time from its first sample: what
/// the fit reads ([`crate::fit::fit`]), in a few passes, where holding a long log's samples
/// would cost 64 bytes each. An [`AlignedSeries`] in memory is one; a file's samples spilled to
/// disk as they were aligned (`align::read_spilled`) are another.
pub trait History {
    /// The uniform step (s).
    fn step_s(&self) -> f64;

    /// Gives `read` every sample in time order, from the first; each call reads them anew.
    ///
    /// # Errors
    /// What the store fails with when it is read.
    fn read(&self, read: &mut dyn FnMut(&mut dyn Iterator<Item = Sample>)) -> Result<()>;
}

/// One pass over `history`: `f` over its samples, and what `f` returns.
///
/// # Errors
/// As [`History::read`].
pub fn pass<R>(
    history: &(impl History + ?Sized),
    f: impl FnOnce(&mut dyn Iterator<Item = Sample>) -> R,
) -> Result<R> {
    let mut f = Some(f);
    let mut out = None;
    history.read(&mut |samples| out = f.take().map(|f| f(samples)))?;
    // A store that never called `read` holds no sample: `f` sees an empty pass.
    Ok(match (out, f) {
        (Some(out), _) => out,
        (None, Some(f)) => f(&mut std::iter::empty()),
        (None, None) => unreachable!("`f` ran, so it returned"),
    })
}

impl History for AlignedSeries {
    fn step_s(&self) -> f64 {
        self.step_s
    }

    fn read(&self, read: &mut dyn FnMut(&mut dyn Iterator<Item = Sample>)) -> Result<()> {
        read(&mut self.samples.iter().copied());
        Ok(())
    }
}

impl AlignedSeries {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.samples.len()
    }

    /// True when there is no sample.
    pub fn is_empty(&self) -> bool {
        self.samples.is_empty()
    }

    /// Duration covered (s), zero for fewer than two samples.
    pub fn duration_s(&self) -> f64 {
        match (self.samples.first(), self.samples.last()) {
            (Some(a), Some(b)) => b.time - a.time,
            _ => 0.0,
        }
    }
}
