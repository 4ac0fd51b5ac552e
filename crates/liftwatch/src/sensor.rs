//! Sensor plausibility: is it the data, not the machine, that look wrong (DATA.md §4 `sensor`)?
//!
//! ```text
//! per sample:  a channel missing ≥ missing_limit_s while others report     → sensor fault
//!              speed above the motion threshold for longer than max_trip_s → speed stuck
//!              the load at door close bit-identical for stuck_load_cycles  → load cell stuck
//!              a floor change after 10 s of standstill                     → implausible
//! per trip:    the load left [min_load_pct, max_load_pct], or a voltage or speed reading left
//!              physics (above 10 kV, above 50 m/s); the trip lasted longer than any
//!              healthy trip; a fast trip that did not change the floor; a trip that started on
//!              another floor than the previous one ended                   → implausible
//! score = 0.9·score + 0.1·implausible           exponential average over ~10 trips
//! sensor = channel fault or score ≥ f;  released only when score < f/2 (hysteresis)
//! ```
//!
//! An implausible trip is not machine evidence: the risk stage never sees it.

use serde::{Deserialize, Serialize};

use crate::exact;

/// A motor voltage reading above this is no drive's (elevator drives run at up to about 1 kV):
/// the sensor or the logger is broken, and the trip is not machine evidence. It also keeps
/// squares of residuals far from overflow.
pub const MAX_PLAUSIBLE_VOLTAGE_V: f64 = 10_000.0;

/// A speed reading above this is no elevator's (the fastest run at about 20 m/s).
pub const MAX_PLAUSIBLE_SPEED_MPS: f64 = 50.0;
use crate::features::Trip;
use crate::sample::Sample;

/// Thresholds on raw samples and trips that tell a broken sensor from a broken machine.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SensorLimits {
    /// Lowest plausible load reading (percent of rated load).
    pub min_load_pct: f64,
    /// Highest plausible load reading (percent of rated load).
    pub max_load_pct: f64,
    /// A trip longer than this is implausible: the speed signal is stuck (s).
    pub max_trip_s: f64,
    /// Peak speed above which a trip must change the floor indicator (m/s).
    pub floor_change_speed_mps: f64,
    /// This many consecutive door cycles with a bit-identical load reading mean a stuck cell.
    pub stuck_load_cycles: u32,
    /// A channel missing this long while others report is a sensor fault (s); loggers drop a
    /// signal for minutes now and then, so this is an hour.
    pub missing_limit_s: f64,
    /// Fraction of recent trips (exponential average over ~10 trips) that must be implausible
    /// to report `sensor`.
    pub implausible_fraction: f64,
}

impl SensorLimits {
    /// Checks the limits a hand-edited model file could break.
    ///
    /// # Errors
    /// A message naming the first field out of range.
    pub fn validate(&self) -> std::result::Result<(), String> {
        let check = crate::error::check_range;
        check("sensor.min_load_pct", self.min_load_pct, -1000.0, 1000.0)?;
        check(
            "sensor.max_load_pct",
            self.max_load_pct,
            self.min_load_pct,
            1000.0,
        )?;
        check("sensor.max_trip_s", self.max_trip_s, 1.0, 86_400.0)?;
        check(
            "sensor.floor_change_speed_mps",
            self.floor_change_speed_mps,
            0.0,
            20.0,
        )?;
        check(
            "sensor.stuck_load_cycles",
            f64::from(self.stuck_load_cycles),
            1.0,
            1e6,
        )?;
        check("sensor.missing_limit_s", self.missing_limit_s, 1.0, 1e7)?;
        check(
            "sensor.implausible_fraction",
            self.implausible_fraction,
            0.01,
            1.0,
        )
    }
}

impl Default for SensorLimits {
    fn default() -> Self {
        SensorLimits {
            min_load_pct: -15.0,
            max_load_pct: 150.0,
            max_trip_s: 120.0,
            floor_change_speed_mps: 0.5,
            stuck_load_cycles: 20,
            missing_limit_s: 3600.0,
            implausible_fraction: 0.5,
        }
    }
}

/// Sensor plausibility from raw samples and completed trips.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SensorCheck {
    /// Last time each channel (speed, direction, voltage, load, door, floor) had a value.
    #[serde(with = "exact::array")]
    last_seen: [f64; 6],
    /// A channel has been missing longer than the limit while others report.
    missing: bool,
    /// A load reading out of range since the last completed trip.
    load_out_of_range: bool,
    /// Door state of the previous sample (NaN unknown) and the load at the last door close.
    #[serde(with = "exact")]
    door: f64,
    #[serde(with = "exact")]
    close_load: f64,
    /// Consecutive door cycles with a bit-identical load reading.
    stuck_cycles: u32,
    /// Index and arrival floor of the last reported trip.
    last_trip: Option<(u32, StateF64)>,
    /// Exponential average of the implausible flag over trips and standstill floor changes.
    #[serde(with = "exact")]
    score: f64,
    /// Since when the speed has been above the motion threshold (NaN when it is not).
    #[serde(with = "exact")]
    moving_since: f64,
    /// Since when the speed has been at or below it (NaN when it is not).
    #[serde(with = "exact")]
    still_since: f64,
    /// Last floor indicator value seen.
    #[serde(with = "exact")]
    floor: f64,
}

/// An f64 that serialises exactly, for tuples.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
struct StateF64(#[serde(with = "exact")] f64);

impl SensorCheck {
    /// A check that has seen nothing yet.
    pub fn new() -> Self {
        SensorCheck {
            last_seen: [f64::NAN; 6],
            missing: false,
            load_out_of_range: false,
            door: f64::NAN,
            close_load: f64::NAN,
            stuck_cycles: 0,
            last_trip: None,
            score: 0.0,
            moving_since: f64::NAN,
            still_since: f64::NAN,
            floor: f64::NAN,
        }
    }

    /// Counts one implausible or plausible observation into the score.
    fn observe(&mut self, plausible: bool) {
        self.score = 0.9 * self.score + 0.1 * f64::from(u8::from(!plausible));
    }

    /// Looks at one raw sample; `thr` is the motion threshold (m/s).
    pub fn sample(&mut self, x: &Sample, cfg: &SensorLimits, thr: f64) {
        if x.speed.is_finite() {
            if x.speed > thr {
                self.still_since = f64::NAN;
                if self.moving_since.is_nan() {
                    self.moving_since = x.time;
                }
            } else {
                self.moving_since = f64::NAN;
                if self.still_since.is_nan() {
                    self.still_since = x.time;
                }
            }
        } else {
            // A dropout of the speed signal is a gap, not a stuck reading.
            self.moving_since = f64::NAN;
            self.still_since = f64::NAN;
        }
        if x.floor.is_finite() {
            // The indicator may settle a few seconds after the car stops; a change after 10 s
            // of standstill is a floor change without speed (a stuck or dead speed signal).
            if self.floor.is_finite() && x.floor != self.floor && x.time - self.still_since > 10.0 {
                self.observe(false);
            }
            self.floor = x.floor;
        }
        let ch = [x.speed, x.direction, x.voltage, x.load, x.door, x.floor];
        let any = ch.iter().any(|v| v.is_finite());
        let mut missing = false;
        for (seen, v) in self.last_seen.iter_mut().zip(ch) {
            if v.is_finite() || seen.is_nan() {
                *seen = x.time;
            } else if any && x.time - *seen >= cfg.missing_limit_s {
                missing = true;
            }
        }
        // A gap of every channel is the logger's, not a sensor's: it neither sets nor clears.
        if any {
            self.missing = missing;
        }
        let load_bad =
            x.load.is_finite() && !(cfg.min_load_pct..=cfg.max_load_pct).contains(&x.load);
        let voltage_bad = x.voltage.abs() > MAX_PLAUSIBLE_VOLTAGE_V;
        let speed_bad = x.speed.abs() > MAX_PLAUSIBLE_SPEED_MPS;
        if load_bad || voltage_bad || speed_bad {
            // Named for the load cell, its first use; any channel out of physics counts.
            self.load_out_of_range = true;
        }
        if x.door.is_finite() {
            let closing = self.door > 0.5 && x.door < 0.5;
            if closing && x.load.is_finite() {
                if x.load.to_bits() == self.close_load.to_bits() {
                    self.stuck_cycles = self.stuck_cycles.saturating_add(1);
                } else {
                    self.stuck_cycles = 0;
                }
                self.close_load = x.load;
            }
            self.door = x.door;
        }
    }

    /// True while a condition independent of trips says a sensor is broken.
    fn channel_fault(&self, cfg: &SensorLimits, time: f64) -> bool {
        let speed_stuck = time - self.moving_since > cfg.max_trip_s;
        self.missing || speed_stuck || self.stuck_cycles >= cfg.stuck_load_cycles
    }

    /// Judges a completed trip: true when it is plausible machine evidence.
    pub fn trip(&mut self, t: &Trip, cfg: &SensorLimits, floor_height: f64) -> bool {
        let mut ok = !std::mem::take(&mut self.load_out_of_range);
        ok &= t.end_time - t.start_time <= cfg.max_trip_s;
        let floors_known = t.from_floor.is_finite() && t.to_floor.is_finite();
        if floors_known
            && t.peak_speed >= cfg.floor_change_speed_mps
            && t.distance_m >= 0.7 * floor_height
        {
            ok &= t.from_floor != t.to_floor;
        }
        if let Some((index, StateF64(to))) = self.last_trip {
            if index.wrapping_add(1) == t.index && to.is_finite() && t.from_floor.is_finite() {
                ok &= to == t.from_floor;
            }
        }
        self.last_trip = Some((t.index, StateF64(t.to_floor)));
        self.observe(ok);
        ok
    }

    /// Whether the `sensor` override is on after a sample at `time`, given whether it was on
    /// (`active`): on for a channel fault or a majority of implausible recent trips, released
    /// only when the implausible share falls below half that fraction, the same hysteresis as
    /// the machine levels.
    pub fn verdict(&self, cfg: &SensorLimits, time: f64, active: bool) -> bool {
        let fault = self.channel_fault(cfg, time) || self.score >= cfg.implausible_fraction;
        let release = active && self.score >= 0.5 * cfg.implausible_fraction;
        fault || release
    }
}

impl Default for SensorCheck {
    fn default() -> Self {
        SensorCheck::new()
    }
}
