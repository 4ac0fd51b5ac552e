//! Simulator: the doors' behaviour and outages, what an owner asks about first.
//!
//! ```text
//! door cycle  opening·w(t), open dwell, closing·w(t);   w(t) = 1 + DOOR_SLOW_GAIN·σ_door(t)
//! reopening   after the door shut: with p(t) = p_field + REOPEN_GAIN·σ_door(t) it opens again
//!             0.5-3 s later (a lock that fails to make, a safety edge touched), short dwell,
//!             closing again; repeats with the same p
//! σ_door(t)   the ramp of crate::sim::scenario (step, linear, exponential) from the onset
//! out of service   at start_s the car finishes its door cycle and stands, door open or closed
//!                  (drawn), for duration_s; calls wait or are dropped; then service resumes
//! stuck       the first trip at or after start_s stops between two landings (the midpoint
//!             of the landing gap half-way along the trip), door closed, for duration_s; a
//!             rescue run then takes the car to the next landing and the door opens
//! ```
//!
//! Numbers and where they come from:
//! - `p_field` 3 %: door-reopening counters of field controllers show a few percent of door
//!   cycles reopened (late passengers, a hand in the safety edge), so a healthy car already
//!   reopens; the `ideal` doors of the default never do (except the real second cycle for a
//!   group waiting at the same landing), and keep every earlier run byte-identical;
//! - `DOOR_SLOW_GAIN` 0.6: a worn door operator (slipping belt, dry track, weak motor) that
//!   takes 60 % longer to open and close, about 1.5 s + 1.7 s on catalogue timings: two or
//!   three seconds on cycles of 7-15 s that vary by as much with the riders;
//! - `REOPEN_GAIN` 0.12: at full wear 15 % of cycles reopen, a door technician's "it keeps
//!   bouncing" (a misaligned lock or a dirty sill);
//! - stuck 20-60 min: the time a technician or the fire service needs to free a trapped car
//!   (EN 81-28's alarm is answered, not the rescue done, within minutes).
//!
//! Randomness: the doors draw from their own stream (seed-derived), so a run with `ideal`
//! doors and no outage draws exactly what it drew before these existed.

use crate::sample::DAY_S;
use serde::{Deserialize, Serialize};

use super::scenario::Ramp;
use crate::error::{Error, Result};

/// Share of door cycles a healthy door reopens in the field (see the module docs).
pub const FIELD_REOPEN_PROBABILITY: f64 = 0.03;

/// Relative lengthening of the door's opening and closing at full wear (σ = 1).
pub const DOOR_SLOW_GAIN: f64 = 0.6;

/// Added reopening probability at full wear (σ = 1).
pub const REOPEN_GAIN: f64 = 0.12;

/// Salt of the doors' random stream: `seed ^ DOOR_STREAM_SALT` seeds it, so the main stream's
/// draws stay those of a run without door behaviour.
pub const DOOR_STREAM_SALT: u64 = 0x646f_6f72_7765_6172;

/// How the doors behave.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum DoorBehaviour {
    /// Catalogue timings, no reopening (the default; runs before doors were modelled).
    #[default]
    Ideal,
    /// Catalogue timings and the field's reopenings ([`FIELD_REOPEN_PROBABILITY`]).
    Field,
    /// The field's doors, slowing and reopening more from `onset_s`.
    Slowing {
        /// Onset of the wear (s).
        onset_s: f64,
        /// Shape of its growth.
        ramp: Ramp,
        /// Full wear from here (s).
        full_at_s: f64,
        /// Wear at full, as a multiple of the default effect.
        severity: f64,
    },
}

impl DoorBehaviour {
    /// Slowing doors; the timing checked as [`super::Scenario::new`] checks it.
    ///
    /// # Errors
    /// [`Error::InvalidConfig`] for times that are not finite or out of order, or a negative
    /// severity.
    pub fn slowing(onset_s: f64, ramp: Ramp, full_at_s: f64, severity: f64) -> Result<Self> {
        let full_at_s = super::scenario::ramp_timing(
            ("door onset", "full wear"),
            onset_s,
            ramp,
            full_at_s,
            severity,
        )?;
        Ok(DoorBehaviour::Slowing {
            onset_s,
            ramp,
            full_at_s,
            severity,
        })
    }

    /// True for the default doors (no draws from the doors' stream).
    pub fn is_ideal(&self) -> bool {
        matches!(self, DoorBehaviour::Ideal)
    }

    /// σ_door(t): the wear at `t` (0 unless slowing and after the onset).
    pub fn wear_at(&self, t: f64) -> f64 {
        let DoorBehaviour::Slowing {
            onset_s,
            ramp,
            full_at_s,
            severity,
        } = *self
        else {
            return 0.0;
        };
        if t < onset_s {
            return 0.0;
        }
        if t >= full_at_s || full_at_s <= onset_s {
            return severity;
        }
        let u = (t - onset_s) / (full_at_s - onset_s);
        severity
            * match ramp {
                Ramp::Step => 1.0,
                Ramp::Linear => u,
                Ramp::Exponential => ((3.0 * u).exp() - 1.0) / (3.0f64.exp() - 1.0),
            }
    }

    /// Multiplier of the opening and closing times at `t`.
    pub fn slow_factor(&self, t: f64) -> f64 {
        1.0 + DOOR_SLOW_GAIN * self.wear_at(t)
    }

    /// Probability that the door reopens after shutting at `t`.
    pub fn reopen_probability(&self, t: f64) -> f64 {
        match self {
            DoorBehaviour::Ideal => 0.0,
            _ => (FIELD_REOPEN_PROBABILITY + REOPEN_GAIN * self.wear_at(t)).min(0.9),
        }
    }
}

/// The kind of an outage: the one the monitor names ([`crate::operation::OutageKind`]), so the
/// simulator's truth and the monitor's events speak one vocabulary.
pub use crate::operation::OutageKind;

/// An outage to simulate.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct OutagePlan {
    /// Which outage.
    pub kind: OutageKind,
    /// When it is due (s): the car stops at the next occasion at or after it.
    pub start_s: f64,
    /// How long the car stays unavailable (s).
    pub duration_s: f64,
}

impl OutagePlan {
    /// Checks the timing.
    ///
    /// # Errors
    /// [`Error::InvalidConfig`] for a start that is not finite or a duration not in
    /// (0, 30 days].
    pub fn validate(&self) -> Result<()> {
        if !self.start_s.is_finite() {
            return Err(Error::InvalidConfig {
                field: "outage start",
                why: format!("{} must be finite", self.start_s),
            });
        }
        if !(self.duration_s > 0.0 && self.duration_s <= 30.0 * DAY_S) {
            return Err(Error::InvalidConfig {
                field: "outage duration",
                why: format!("{} s must be above 0 and at most 30 days", self.duration_s),
            });
        }
        Ok(())
    }
}

/// An outage as it happened, for `truth.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct OutageTruth {
    /// Which outage.
    pub kind: OutageKind,
    /// When the car stopped serving: the end of its last door cycle, or the stuck car's stop (s).
    pub start_s: f64,
    /// When it moved again (s).
    pub end_s: f64,
    /// Whether the door stood open.
    pub door_open: bool,
    /// Where the car stood: a landing (1-based), or the two landings it stood between.
    pub position: String,
}
