//! Stage 3, one sample on arrival: what the rows need of it (paper, Sec. 4.1).
//!
//! ```text
//! speed  = |speed|, NaN when missing
//! v      = sign · speed               sign from the direction signal or the tracker's memory
//! s      = sign(v) if |v| > v_move else 0
//! load   = L if L in LOAD_PLAUSIBLE_PCT else NaN
//! door   open (> 0.5), closed, unknown
//! ```
//!
//! [`FeatureTracker`](super::FeatureTracker) builds a [`Pre`] per sample and keeps the last
//! two; neighbours are [`follows`] when their times differ by (0, [`MAX_STEP_S`]] seconds.

use serde::{Deserialize, Serialize};

use super::MAX_STEP_S;
use crate::exact;

/// Door state of a sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub(super) enum Door {
    /// The door reads closed (a finite value of 0.5 or below).
    Closed,
    /// The door reads open (above 0.5).
    Open,
    /// The door signal is missing.
    Unknown,
}

/// One sample, preprocessed on arrival: what the rows need of it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub(super) struct Pre {
    /// Time (s).
    #[serde(with = "exact")]
    pub(super) time: f64,
    /// Speed magnitude (m/s), NaN when missing.
    #[serde(with = "exact")]
    pub(super) speed: f64,
    /// Signed velocity, NaN when the speed or its sign is missing.
    #[serde(with = "exact")]
    pub(super) v: f64,
    /// Direction of motion: ±1 moving, 0 at rest.
    pub(super) s: i8,
    /// Load reading (percent), NaN when missing or implausible.
    #[serde(with = "exact")]
    pub(super) load: f64,
    /// Door state.
    pub(super) door: Door,
    /// Floor indicator, NaN when missing.
    #[serde(with = "exact")]
    pub(super) floor: f64,
    /// Motor voltage U (V).
    #[serde(with = "exact")]
    pub(super) voltage: f64,
}

impl Pre {
    /// Velocity as a neighbour in a difference: 0 at rest, so that standstill noise is not
    /// read as acceleration at the start and end of a trip.
    pub(super) fn v_boundary(&self) -> f64 {
        if self.s == 0 && self.v.is_finite() {
            0.0
        } else {
            self.v
        }
    }

    /// True when the sample has a known velocity and is at rest.
    pub(super) fn at_rest(&self) -> bool {
        self.v.is_finite() && self.s == 0
    }
}

/// True when `b` directly follows `a` in time.
pub(super) fn follows(a: &Pre, b: &Pre) -> bool {
    let dt = b.time - a.time;
    dt > 0.0 && dt <= MAX_STEP_S
}
