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
//! per parking: z = mean load reading while the car stood still with the door closed, from its
//!              5th minute on, after the door opened at that stop (nobody waits five minutes
//!              in a closed car they could leave: it is empty) or with the car known empty
//!              since its last parking (no door opened since);
//!              |z − z_healthy| above the limit calibrated on the training → load-cell zero drift
//! per stop:    y = median voltage of the standstill from its 5th second on (first minute)
//!              d = y − y_healthy;  u± = clip((±d − a)/σ, ±3)   a: allowance, σ: spread
//!              G± ← min(2h, max(0, G± + u± − ½))               two CUSUMs of a 1σ shift
//!              max G± ≥ h                                       → voltage sensor offset
//! score = 0.9·score + 0.1·implausible           exponential average over ~10 trips
//! sensor = channel fault or score ≥ f;  released only when score < f/2 (hysteresis)
//! channel = the one the first failing check reads (speed, load, voltage, a missing one, …)
//! ```
//!
//! An implausible trip is not machine evidence: the risk stage never sees it.
//!
//! Why the zero check: an offset of the load cell shifts every λ, and through m_eq·g the force
//! the model expects: for the voltage it looks like a change of the drive (the force-
//! proportional motor signature), and the risk named `motor` half a day into a 2 %/day drift.
//! The empty car is the one load the cell must read as about zero whatever the traffic, so its
//! reading is the witness the machine cannot fake.
//!
//! Why the rest-voltage check: an offset of the voltage sensor adds the same volts to every
//! reading, in both directions alike; on the moving samples that is nearly the friction
//! signature (a constant voltage against φ·Kd·F_c, which differs only by the drive's
//! efficiency between the directions), so the risk named `friction` or `unknown`. At a stop
//! no machine fault moves the reading: a drive off at rest reads the sensor's own zero, one
//! energised at rest reads U0 plus the holding force's resistive drop; both come back stop
//! after stop on a healthy machine, and a shift of them is the sensor's.

use std::borrow::Borrow;

use serde::{Deserialize, Serialize};

use crate::exact;
use crate::features::Trip;
use crate::ingest::Signal;
use crate::sample::{Sample, DAY_S, HOUR_S};
use crate::stats::gaussian_llr;

/// A motor voltage reading above this is no drive's (elevator drives run at up to about 1 kV):
/// the sensor or the logger is broken, and the trip is not machine evidence. It also keeps
/// squares of residuals far from overflow.
pub const MAX_PLAUSIBLE_VOLTAGE_V: f64 = 10_000.0;

/// A speed reading above this is no elevator's (the fastest run at about 20 m/s).
pub const MAX_PLAUSIBLE_SPEED_MPS: f64 = 50.0;

/// A car that has stood still with its door closed this long, after its door opened at that
/// stop, is parked, and empty: nobody waits five minutes in a closed car they could leave (s).
/// A car that stopped and never opened its door may hold people who cannot leave (a car stuck
/// between floors), so its standstill is no parking, however long, unless the car was
/// already known empty when it set off (parked, then sent home with its door shut).
pub const PARKED_S: f64 = 300.0;

/// Least readings of a parking (after [`PARKED_S`]) that make a zero reading: a minute of 1 Hz
/// readings averages the cell's noise and its 1 % steps to a few hundredths of a percent.
const PARKED_MIN_SAMPLES: u32 = 60;

/// Least parkings of a training that calibrate the zero check.
const ZERO_MIN_PARKINGS: usize = 5;

/// Parkings a monitor whose model has no healthy zero learns one from before its parked
/// readings witness anything ([`SensorCheck::learnt_zero`]): about a day of a car's idle
/// spells, so that the zero has seen the floors and hours the car parks at, not one night's.
const ZERO_LEARNT_PARKINGS: usize = 16;

/// The zero limit is this many times the largest healthy deviation of the training's parkings.
const ZERO_LIMIT_MARGIN: f64 = 1.5;

/// The zero limit is never below this (percent of rated load): one quantisation step of a
/// typical load cell, below which a shift is not a fault worth a visit.
const ZERO_LIMIT_FLOOR_PCT: f64 = 1.0;

/// The spread of the empty car's parked readings is never taken below this (percent of rated
/// load): a minute of readings of a cell with 1 % steps resolves a few hundredths of a per
/// cent, and a spread the training measured below it would make every hundredth a shift.
const ZERO_SD_FLOOR_PCT: f64 = 0.05;

/// Parkings the zero check keeps as witnesses for the risk stage's isolation (about two days
/// of a busy car, a week of a quiet one): the load cell's zero, read directly, when the
/// machine evidence cannot tell a drifting cell from the drive.
const ZERO_WITNESSES: usize = 64;

/// The parked readings since a window began decide for or against the load cell's zero when
/// their mean lies this many of its standard errors beyond the line (see the monitor's
/// witness): four, which a healthy cell passes about once in 30,000 decisions.
pub const ZERO_WITNESS_Z: f64 = 4.0;

/// Seconds of a standstill before its voltage counts as the rest reading: a drive drops the
/// brake and de-energises (or settles its holding current) within a second or two of
/// levelling, and a low-pass voltage sensor has followed within a few of its time constants.
pub const REST_SETTLE_S: f64 = 5.0;

/// Settled readings of a stop its rest reading is the median of: a minute. The median of
/// them leaves out the pre-torque of the next start (a second or two of the drive energised
/// before the car moves), and a long parking adds nothing the first minute has not said.
const REST_MAX_SAMPLES: usize = 60;

/// Fewest settled readings that make a stop's rest reading (a door cycle at 1 Hz gives more).
const REST_MIN_SAMPLES: usize = 5;

/// Fewest stops of a training that calibrate the rest-voltage check.
const REST_MIN_STOPS: usize = 20;

/// The allowance of the rest-voltage check is never below this share of the drive's voltage
/// at rated speed (U0 + Ke·v_rated): the accuracy of a 1 % class voltage transducer, below
/// which an offset is within the sensor's own specification.
pub const REST_ALLOWANCE_FRAC: f64 = 0.01;

/// The spread σ the rest readings are judged in is never below this share of the allowance:
/// a drive off at rest may read the very same quantised value stop after stop (σ = 0), and a
/// shift past the allowance by three tenths of it then counts as three σ, the clip.
const REST_SD_FLOOR_FRAC: f64 = 0.1;

/// Threshold of the rest-voltage CUSUMs (log-likelihood ratio): ln(160 000), an elevator-year
/// of stops of a busy car, so by Wald's bound (ARL0 ≥ e^h) a healthy sensor is flagged less
/// than once a year even before the allowance, which keeps healthy increments below zero.
/// A shift well past the allowance gains 2.5 a stop (clip 3 − ½) and is flagged at the fifth.
pub const REST_H: f64 = 12.0;

/// A stop's standardised excess enters the rest-voltage CUSUMs clipped to ±3, as a trip's
/// score enters the risk stage's: one odd stop (a reading during a re-levelling) cannot make
/// a fault alone.
const REST_CLIP: f64 = 3.0;

/// One stop's settled voltage readings: the one accumulator of the rest-voltage check, run on
/// the training by [`SensorLimits::calibrate_rest_voltage`] and on every sample by
/// [`SensorCheck`].
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RestVoltage {
    /// Since when the car has stood still (None while it moves).
    since: Option<StateF64>,
    /// Settled readings of this stop, at most [`REST_MAX_SAMPLES`].
    readings: Vec<f64>,
}

impl RestVoltage {
    /// Takes one sample (`thr` the motion threshold, m/s); returns the stop's rest reading
    /// (V) when this sample ends a stop that gave enough settled readings.
    pub fn push(&mut self, x: &Sample, thr: f64) -> Option<f64> {
        if !x.speed.is_finite() {
            // A dropout of the speed says nothing about motion: the stop is not trusted.
            *self = RestVoltage::default();
            return None;
        }
        if x.speed > thr {
            let out = (self.readings.len() >= REST_MIN_SAMPLES)
                .then(|| crate::stats::median(&self.readings));
            *self = RestVoltage::default();
            return out;
        }
        let since = self.since.get_or_insert(StateF64(x.time)).0;
        if x.time - since >= REST_SETTLE_S
            && x.voltage.is_finite()
            && self.readings.len() < REST_MAX_SAMPLES
        {
            self.readings.push(x.voltage);
        }
        None
    }
}

/// The empty car's load readings while parked: the one accumulator of the zero check, run on
/// the training by [`SensorLimits::calibrate_load_zero`] and on every sample by [`SensorCheck`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Parking {
    /// Since when the car has stood still with the door closed (NaN when it does not).
    #[serde(with = "exact")]
    since: f64,
    /// Sum and count of the load readings after [`PARKED_S`].
    #[serde(with = "exact")]
    sum: f64,
    n: u32,
    /// Whether the door has opened since the car last moved: only then could whoever rode
    /// have left. A state written before this was kept takes it as opened, as it counted then.
    #[serde(default = "opened_before")]
    opened: bool,
    /// Whether the car is known to be empty: it stood parked past [`PARKED_S`] and its door
    /// has not opened since, so nobody can have boarded, however far it moved (a car sent
    /// home to the lobby with its door shut parks there empty).
    #[serde(default)]
    empty: bool,
}

fn opened_before() -> bool {
    true
}

impl Parking {
    /// Nothing seen yet.
    pub fn new() -> Self {
        Parking {
            since: f64::NAN,
            sum: 0.0,
            n: 0,
            opened: false,
            empty: false,
        }
    }

    /// Takes one sample (`thr` the motion threshold, m/s); returns the mean load reading of a
    /// parking (percent) when this sample ends one that lasted long enough.
    pub fn push(&mut self, x: &Sample, thr: f64) -> Option<f64> {
        let still = x.speed.is_finite() && x.speed <= thr;
        let closed = x.door.is_finite() && x.door < 0.5;
        if !(still && closed && (self.opened || self.empty)) {
            let out = (self.n >= PARKED_MIN_SAMPLES).then(|| self.sum / f64::from(self.n));
            // Motion closes the way out; an open door at a standstill opens it. A speed
            // reading missing leaves it as it was. An open door, or one not read, may have
            // let someone in.
            let opened = if x.speed > thr {
                false
            } else {
                self.opened || (still && x.door >= 0.5)
            };
            *self = Parking {
                opened,
                empty: self.empty && closed,
                ..Parking::new()
            };
            return out;
        }
        if self.since.is_nan() {
            self.since = x.time;
        }
        if x.time - self.since >= PARKED_S && x.load.is_finite() {
            self.sum += x.load;
            self.n = self.n.saturating_add(1);
            self.empty = true;
        }
        None
    }

    /// The car is out of service: the stop under way is no parking, and the car is not known
    /// empty until its door has opened again after it moves. Who stands in a car out of
    /// service is not the empty car: technicians and their tools on a maintenance visit, or a
    /// rider who boarded as it was switched off (on a simulated 630 kg car, 4 h at 14 % of
    /// rated load read as a drift of the cell's zero).
    pub fn void(&mut self) {
        *self = Parking::new();
    }
}

impl Default for Parking {
    /// As [`Parking::new`]: no parking under way (a state written before the zero check).
    fn default() -> Self {
        Parking::new()
    }
}

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
    /// The empty car's healthy reading (a parked car's, [`Parking`]; percent of rated load); `None` when
    /// the training was too short to calibrate it, or for models written before the check.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub load_zero_pct: Option<f64>,
    /// Largest plausible deviation of the empty car's reading from `load_zero_pct` (percent).
    #[serde(default = "default_zero_limit")]
    pub load_zero_limit_pct: f64,
    /// Healthy spread of the empty car's parked readings (percent; robust, at least
    /// `ZERO_SD_FLOOR_PCT`); 0 in models written before it was kept (no witness then).
    #[serde(default)]
    pub load_zero_sd_pct: f64,
    /// The healthy rest reading of the voltage ([`RestVoltage`], V); `None` when the training
    /// had too few stops, or for models written before the check.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rest_voltage_v: Option<f64>,
    /// Allowance a: a stop's reading within it of `rest_voltage_v` is healthy (V).
    #[serde(default)]
    pub rest_voltage_allowance_v: f64,
    /// Spread σ the excess over the allowance is counted in (V).
    #[serde(default)]
    pub rest_voltage_sd_v: f64,
}

fn default_zero_limit() -> f64 {
    ZERO_LIMIT_FLOOR_PCT
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
        check("sensor.max_trip_s", self.max_trip_s, 1.0, DAY_S)?;
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
        )?;
        if let Some(z) = self.load_zero_pct {
            check("sensor.load_zero_pct", z, -1000.0, 1000.0)?;
        }
        check(
            "sensor.load_zero_limit_pct",
            self.load_zero_limit_pct,
            0.01,
            1000.0,
        )?;
        check(
            "sensor.load_zero_sd_pct",
            self.load_zero_sd_pct,
            0.0,
            1000.0,
        )?;
        if let Some(u) = self.rest_voltage_v {
            check("sensor.rest_voltage_v", u, -1e4, 1e4)?;
            check(
                "sensor.rest_voltage_allowance_v",
                self.rest_voltage_allowance_v,
                1e-6,
                1e4,
            )?;
            check(
                "sensor.rest_voltage_sd_v",
                self.rest_voltage_sd_v,
                1e-9,
                1e4,
            )?;
        }
        Ok(())
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
            missing_limit_s: HOUR_S,
            implausible_fraction: 0.5,
            load_zero_pct: None,
            load_zero_limit_pct: ZERO_LIMIT_FLOOR_PCT,
            load_zero_sd_pct: 0.0,
            rest_voltage_v: None,
            rest_voltage_allowance_v: 0.0,
            rest_voltage_sd_v: 0.0,
        }
    }
}

impl SensorLimits {
    /// Calibrates the load-cell zero check on healthy samples (`thr` the motion threshold):
    /// the median of the parked readings, and a limit of `ZERO_LIMIT_MARGIN` times their
    /// largest deviation from it, at least `ZERO_LIMIT_FLOOR_PCT`. A training with fewer
    /// than `ZERO_MIN_PARKINGS` parkings leaves the check off.
    pub fn calibrate_load_zero<S: Borrow<Sample>>(
        &mut self,
        samples: impl IntoIterator<Item = S>,
        thr: f64,
    ) {
        let mut parking = Parking::new();
        let readings: Vec<f64> = samples
            .into_iter()
            .filter_map(|x| parking.push(x.borrow(), thr))
            .collect();
        if readings.len() < ZERO_MIN_PARKINGS {
            self.load_zero_pct = None;
            return;
        }
        let (reference, limit) = healthy_range(&readings, ZERO_LIMIT_FLOOR_PCT);
        self.load_zero_pct = Some(reference);
        self.load_zero_limit_pct = limit;
        self.load_zero_sd_pct = parked_spread(&readings);
    }

    /// Calibrates the rest-voltage check on healthy samples (`thr` the motion threshold,
    /// `rated_voltage_v` the drive's voltage at rated speed): the median of the stops' rest
    /// readings; the allowance `ZERO_LIMIT_MARGIN` times their largest deviation from it,
    /// at least [`REST_ALLOWANCE_FRAC`] of the rated voltage; σ their robust spread, at least
    /// `REST_SD_FLOOR_FRAC` of the allowance. A training with fewer than
    /// `REST_MIN_STOPS` stops leaves the check off.
    pub fn calibrate_rest_voltage<S: Borrow<Sample>>(
        &mut self,
        samples: impl IntoIterator<Item = S>,
        thr: f64,
        rated_voltage_v: f64,
    ) {
        let mut rest = RestVoltage::default();
        let readings: Vec<f64> = samples
            .into_iter()
            .filter_map(|x| rest.push(x.borrow(), thr))
            .collect();
        let floor = REST_ALLOWANCE_FRAC * rated_voltage_v.abs();
        if readings.len() < REST_MIN_STOPS || floor.is_nan() || floor <= 0.0 {
            self.rest_voltage_v = None;
            return;
        }
        let (reference, allowance) = healthy_range(&readings, floor);
        let spread = crate::stats::robust_sigma(readings.iter().copied());
        self.rest_voltage_v = Some(reference);
        self.rest_voltage_allowance_v = allowance;
        self.rest_voltage_sd_v = spread.max(REST_SD_FLOOR_FRAC * allowance);
    }
}

/// The healthy reference of a witness's `readings` (their median) and how far from it a
/// reading may lie: [`ZERO_LIMIT_MARGIN`] times their largest deviation, at least `floor`.
fn healthy_range(readings: &[f64], floor: f64) -> (f64, f64) {
    let reference = crate::stats::median(readings);
    let widest = readings
        .iter()
        .map(|y| (y - reference).abs())
        .fold(0.0, f64::max);
    (reference, (ZERO_LIMIT_MARGIN * widest).max(floor))
}

/// The healthy spread of parked readings (percent): robust, at least [`ZERO_SD_FLOOR_PCT`].
fn parked_spread(readings: &[f64]) -> f64 {
    crate::stats::robust_sigma(readings.iter().copied()).max(ZERO_SD_FLOOR_PCT)
}

/// The zero a monitor learns from its first parkings when its model has none: their readings
/// while fewer than [`ZERO_LEARNT_PARKINGS`], then, computed once, their median and spread as
/// the training would have calibrated them ([`SensorLimits::calibrate_load_zero`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
enum LearntZero {
    /// The parkings' readings so far (percent).
    Learning(Vec<StateF64>),
    /// Their median and spread (percent).
    Learnt { zero: StateF64, sd: StateF64 },
}

impl Default for LearntZero {
    fn default() -> Self {
        LearntZero::Learning(Vec::new())
    }
}

impl LearntZero {
    /// Nothing learnt yet.
    fn is_empty(&self) -> bool {
        matches!(self, LearntZero::Learning(v) if v.is_empty())
    }

    /// The zero of `readings`.
    fn of(readings: &[StateF64]) -> Self {
        let readings: Vec<f64> = readings.iter().map(|z| z.0).collect();
        LearntZero::Learnt {
            zero: StateF64(crate::stats::median(&readings)),
            sd: StateF64(parked_spread(&readings)),
        }
    }
}

/// Sensor plausibility from raw samples and completed trips.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SensorCheck {
    /// Last time each channel (speed, direction, voltage, load, door, floor) had a value.
    #[serde(with = "exact::array")]
    last_seen: [f64; 6],
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
    /// The parking in progress, for the zero check.
    #[serde(default)]
    parking: Parking,
    /// The empty car's reading has left its healthy range.
    #[serde(default)]
    zero_drift: bool,
    /// The last [`ZERO_WITNESSES`] parkings: when each ended and its reading's deviation from
    /// the healthy zero (percent).
    #[serde(default)]
    zero_witnesses: std::collections::VecDeque<(StateF64, StateF64)>,
    /// The zero a model without a healthy one (a training too short to park in, such as the
    /// paper's busy 3 hours) has the witnesses read against ([`SensorCheck::learnt_zero`]).
    /// Left out of the state while nothing is learnt, so a model with a trained zero saves the
    /// state it saved before.
    #[serde(default, skip_serializing_if = "LearntZero::is_empty")]
    zero_learnt: LearntZero,
    /// The stop in progress, for the rest-voltage check.
    #[serde(default)]
    rest: RestVoltage,
    /// The rest-voltage CUSUMs G+ (reading up) and G− (down).
    #[serde(default, with = "exact::array")]
    rest_g: [f64; 2],
    /// The channel missing longer than the limit while others report, if any.
    #[serde(default)]
    missing_channel: Option<Signal>,
    /// The channel behind the last implausible trip.
    #[serde(default)]
    implausible_channel: Option<Signal>,
    /// The channel a reading out of physics came from since the last completed trip.
    #[serde(default)]
    out_of_range_channel: Option<Signal>,
    /// Since the last completed trip the floor changed while the speed read standstill (the
    /// standstill check has blamed the speed): the car travelled without the speed showing
    /// it, so a floor that differs at the next trip's start is the same failure, the speed's,
    /// not a second one of the floor's. Left out of the state while false.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    travel_unseen: bool,
}

/// An f64 that serialises exactly, for tuples.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
struct StateF64(#[serde(with = "exact")] f64);

impl SensorCheck {
    /// A check that has seen nothing yet.
    pub fn new() -> Self {
        SensorCheck {
            last_seen: [f64::NAN; 6],
            load_out_of_range: false,
            door: f64::NAN,
            close_load: f64::NAN,
            stuck_cycles: 0,
            last_trip: None,
            score: 0.0,
            moving_since: f64::NAN,
            still_since: f64::NAN,
            floor: f64::NAN,
            parking: Parking::new(),
            zero_drift: false,
            zero_witnesses: std::collections::VecDeque::new(),
            zero_learnt: LearntZero::default(),
            rest: RestVoltage::default(),
            rest_g: [0.0; 2],
            missing_channel: None,
            implausible_channel: None,
            out_of_range_channel: None,
            travel_unseen: false,
        }
    }

    /// True while the empty car's reading is out of its healthy range: the load cell's zero
    /// has drifted.
    pub fn load_zero_drift(&self) -> bool {
        self.zero_drift
    }

    /// True while the voltage's rest reading has shifted: the voltage sensor is offset.
    pub fn voltage_offset(&self) -> bool {
        self.rest_g[0].max(self.rest_g[1]) >= REST_H
    }

    /// The car is out of service (an outage the monitor concluded): its stop is no parking
    /// ([`Parking::void`]).
    pub fn out_of_service(&mut self) {
        self.parking.void();
    }

    /// Takes one sample into the zero check: a parking that ends sets or clears the drift.
    fn zero_check(&mut self, x: &Sample, cfg: &SensorLimits, thr: f64) {
        let Some(z) = self.parking.push(x, thr) else {
            return;
        };
        let reference = match cfg.load_zero_pct {
            Some(reference) => {
                self.zero_drift = (z - reference).abs() > cfg.load_zero_limit_pct;
                reference
            }
            None => match &mut self.zero_learnt {
                LearntZero::Learnt { zero, .. } => zero.0,
                LearntZero::Learning(readings) => {
                    if z.is_finite() {
                        readings.push(StateF64(z));
                    }
                    if readings.len() >= ZERO_LEARNT_PARKINGS {
                        self.zero_learnt = LearntZero::of(readings);
                    }
                    return;
                }
            },
        };
        // `while`: a state file may hold more than the bound (written by hand, or by a
        // build with another); it shrinks back at the next parking.
        while self.zero_witnesses.len() >= ZERO_WITNESSES {
            self.zero_witnesses.pop_front();
        }
        self.zero_witnesses
            .push_back((StateF64(x.time), StateF64(z - reference)));
    }

    /// The zero and spread (percent) of the first [`ZERO_LEARNT_PARKINGS`] parkings this
    /// check saw ([`LearntZero`]); `None` until there were as many. Only a model without a
    /// healthy zero uses it, and only for the witnesses: the parked readings then tell a zero
    /// that moved during a window from one that stayed, though not where the healthy zero was
    /// (a cell already off when monitoring began reads as its own zero).
    fn learnt_zero(&self) -> Option<(f64, f64)> {
        match self.zero_learnt {
            LearntZero::Learnt { zero, sd } => Some((zero.0, sd.0)),
            LearntZero::Learning(_) => None,
        }
    }

    /// When the newest parking witness ended, as bits (None before the first): it changes
    /// exactly when the witnesses do.
    pub fn newest_zero_witness(&self) -> Option<u64> {
        self.zero_witnesses.back().map(|(t, _)| t.0.to_bits())
    }

    /// The empty car's parked readings that ended after `since`: their mean deviation from the
    /// healthy zero and its standard error from the healthy spread (percent), or, for a model
    /// without a healthy zero, from the zero and spread of the first parkings monitored
    /// (`learnt_zero`); `None` when there were none or there is no spread to judge them by.
    pub fn load_zero_shift(&self, cfg: &SensorLimits, since: f64) -> Option<(f64, f64)> {
        // A learnt zero is the median of a few parkings, with an error of its own beside the
        // witnesses' (a median's variance is π/2 times a mean's): both go into the standard
        // error. A training's zero, the median of days of parkings, is taken as exact.
        let (sd, reference_var) = match cfg.load_zero_pct {
            Some(_) => (cfg.load_zero_sd_pct, 0.0),
            None => {
                let sd = self.learnt_zero()?.1;
                let k = ZERO_LEARNT_PARKINGS as f64;
                (sd, std::f64::consts::FRAC_PI_2 * sd * sd / k)
            }
        };
        // NaN or 0 (a model written before the spread was kept): no witness.
        if sd.is_nan() || sd <= 0.0 {
            return None;
        }
        let (sum, n) = self
            .zero_witnesses
            .iter()
            .filter(|(t, _)| t.0 >= since)
            .fold((0.0, 0u32), |(s, n), (_, d)| (s + d.0, n + 1));
        (n > 0).then(|| {
            let n = f64::from(n);
            (sum / n, (sd * sd / n + reference_var).sqrt())
        })
    }

    /// Takes one sample into the rest-voltage check: a stop that ends moves its two CUSUMs.
    /// They are capped at 2h, so a repaired sensor is released within a few tens of stops.
    fn rest_check(&mut self, x: &Sample, cfg: &SensorLimits, thr: f64) {
        let reading = self.rest.push(x, thr);
        let (Some(y), Some(reference)) = (reading, cfg.rest_voltage_v) else {
            return;
        };
        let d = y - reference;
        for (g, side) in self.rest_g.iter_mut().zip([d, -d]) {
            let u = ((side - cfg.rest_voltage_allowance_v) / cfg.rest_voltage_sd_v)
                .clamp(-REST_CLIP, REST_CLIP);
            *g = (*g + gaussian_llr(1.0, u)).clamp(0.0, 2.0 * REST_H);
        }
    }

    /// Counts one implausible or plausible observation into the score.
    fn observe(&mut self, plausible: bool) {
        self.score = 0.9 * self.score + 0.1 * f64::from(u8::from(!plausible));
    }

    /// Looks at one raw sample; `thr` is the motion threshold (m/s).
    pub fn sample(&mut self, x: &Sample, cfg: &SensorLimits, thr: f64) {
        self.zero_check(x, cfg, thr);
        self.rest_check(x, cfg, thr);
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
                self.implausible_channel = Some(Signal::Speed);
                self.travel_unseen = true;
            }
            self.floor = x.floor;
        }
        let ch = [x.speed, x.direction, x.voltage, x.load, x.door, x.floor];
        let any = ch.iter().any(|v| v.is_finite());
        let mut missing = None;
        for ((seen, v), signal) in self.last_seen.iter_mut().zip(ch).zip(Signal::ALL) {
            if v.is_finite() || seen.is_nan() {
                *seen = x.time;
            } else if any && x.time - *seen >= cfg.missing_limit_s {
                missing = missing.or(Some(signal));
            }
        }
        // A gap of every channel is the logger's, not a sensor's: it neither sets nor clears.
        if any {
            self.missing_channel = missing;
        }
        let load_bad =
            x.load.is_finite() && !(cfg.min_load_pct..=cfg.max_load_pct).contains(&x.load);
        let voltage_bad = x.voltage.abs() > MAX_PLAUSIBLE_VOLTAGE_V;
        let speed_bad = x.speed.abs() > MAX_PLAUSIBLE_SPEED_MPS;
        if load_bad || voltage_bad || speed_bad {
            // Named for the load cell, its first use; any channel out of physics counts.
            self.load_out_of_range = true;
            let channel = if load_bad {
                Signal::Load
            } else if voltage_bad {
                Signal::Voltage
            } else {
                Signal::Speed
            };
            self.out_of_range_channel.get_or_insert(channel);
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

    /// The channel a condition independent of trips says is broken, if any.
    fn channel_fault(&self, cfg: &SensorLimits, time: f64) -> Option<Signal> {
        if self.missing_channel.is_some() {
            return self.missing_channel;
        }
        if time - self.moving_since > cfg.max_trip_s {
            return Some(Signal::Speed);
        }
        if self.stuck_cycles >= cfg.stuck_load_cycles || self.zero_drift {
            return Some(Signal::Load);
        }
        self.voltage_offset().then_some(Signal::Voltage)
    }

    /// The channel the `sensor` verdict at `time` is about: the one a channel check finds
    /// broken, else, while implausible trips hold the verdict (the release level of
    /// [`SensorCheck::verdict`]), the one behind the last of them; None when no sensor check
    /// holds it.
    pub fn channel(&self, cfg: &SensorLimits, time: f64) -> Option<Signal> {
        self.channel_fault(cfg, time)
            .or((self.score >= 0.5 * cfg.implausible_fraction)
                .then_some(self.implausible_channel)
                .flatten())
    }

    /// Judges a completed trip: true when it is plausible machine evidence.
    pub fn trip(&mut self, t: &Trip, cfg: &SensorLimits, floor_height: f64) -> bool {
        // With the cell's zero off, every λ and so every expected force is off; with the
        // voltage's, every residual: not evidence.
        let mut failed = None;
        if std::mem::take(&mut self.load_out_of_range) {
            failed = self.out_of_range_channel.take().or(Some(Signal::Load));
        }
        if self.zero_drift {
            failed = failed.or(Some(Signal::Load));
        }
        if self.voltage_offset() {
            failed = failed.or(Some(Signal::Voltage));
        }
        if t.end_time - t.start_time > cfg.max_trip_s {
            failed = failed.or(Some(Signal::Speed));
        }
        let floors_known = t.from_floor.is_finite() && t.to_floor.is_finite();
        if floors_known
            && t.peak_speed >= cfg.floor_change_speed_mps
            && t.distance_m >= 0.7 * floor_height
            && t.from_floor == t.to_floor
        {
            failed = failed.or(Some(Signal::Floor));
        }
        if let Some((index, StateF64(to))) = self.last_trip {
            if index.wrapping_add(1) == t.index
                && to.is_finite()
                && t.from_floor.is_finite()
                && to != t.from_floor
            {
                // The car leaves from another floor than it last arrived at: the floor reading
                // jumped, or the car travelled while the speed did not show it.
                failed = failed.or(Some(if self.travel_unseen {
                    Signal::Speed
                } else {
                    Signal::Floor
                }));
            }
        }
        self.travel_unseen = false;
        self.last_trip = Some((t.index, StateF64(t.to_floor)));
        let ok = failed.is_none();
        if failed.is_some() {
            self.implausible_channel = failed;
        }
        self.observe(ok);
        ok
    }

    /// Whether the `sensor` override is on after a sample at `time`, given whether it was on
    /// (`active`): on for a channel fault or a majority of implausible recent trips, released
    /// only when the implausible share falls below half that fraction, the same hysteresis as
    /// the machine levels.
    pub fn verdict(&self, cfg: &SensorLimits, time: f64, active: bool) -> bool {
        let fault =
            self.channel_fault(cfg, time).is_some() || self.score >= cfg.implausible_fraction;
        let release = active && self.score >= 0.5 * cfg.implausible_fraction;
        fault || release
    }
}

impl Default for SensorCheck {
    fn default() -> Self {
        SensorCheck::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A day of 1 Hz samples: every hour a 2-minute trip with 40 % load (door open around it),
    /// then the car parks for the rest of the hour; the cell reads `offset` on top of the truth.
    fn day(start: f64, offset_pct: f64, noise_seed: u64) -> Vec<Sample> {
        let mut rng = crate::rng::Rng::new(noise_seed);
        (0..86_400)
            .map(|k| {
                let t = start + f64::from(k);
                let s = k % 3600;
                let (speed, door, load) = match s {
                    0..=29 => (0.0, 1.0, 40.0),
                    30..=149 => (1.5, 0.0, 40.0),
                    150..=179 => (0.0, 1.0, 0.0),
                    _ => (0.0, 0.0, 0.0),
                };
                let reading = load + offset_pct + 0.5 * rng.normal();
                Sample {
                    time: t,
                    speed,
                    direction: 0.0,
                    voltage: 0.0,
                    load: reading.round(),
                    door,
                    floor: 1.0,
                    current: f64::NAN,
                }
            })
            .collect()
    }

    #[test]
    fn a_parked_car_reads_the_empty_cars_load_and_a_shifted_zero_is_a_sensor_fault() {
        let mut limits = SensorLimits::default();
        limits.calibrate_load_zero(day(0.0, 0.0, 1), 0.05);
        let z = limits
            .load_zero_pct
            .expect("24 parkings calibrate the check");
        assert!(z.abs() < 0.2, "the empty car reads {z} %");
        assert_eq!(limits.load_zero_limit_pct, ZERO_LIMIT_FLOOR_PCT);

        let watch = |offset: f64| {
            let mut check = SensorCheck::new();
            let mut flagged = false;
            for x in day(DAY_S, offset, 2) {
                check.sample(&x, &limits, 0.05);
                flagged |= check.load_zero_drift();
            }
            (flagged, check.verdict(&limits, 2.0 * DAY_S, false))
        };
        // The 40 % passengers of every trip never count; a healthy zero stays quiet.
        assert_eq!(watch(0.0), (false, false));
        // A cell 2 % off (1.5 % rounds to 2 % half the time) is a sensor fault at once.
        assert_eq!(watch(2.0), (true, true));
        assert_eq!(watch(-2.0), (true, true));
    }

    #[test]
    fn a_car_stuck_with_its_passengers_is_no_parking_until_its_door_has_opened() {
        let mut limits = SensorLimits::default();
        limits.calibrate_load_zero(day(0.0, 0.0, 1), 0.05);
        // A day as `day`'s; then 25 % board, the car stops between floors, door closed, for
        // an hour; freed, it opens its door, lets them out and parks empty for an hour; then
        // it is sent home with its door shut and parks there, empty, for another.
        let mut samples = day(DAY_S, 0.0, 2);
        let (t0, like) = (2.0 * DAY_S, samples[0]);
        let at = |k: u32, speed: f64, door: f64, load: f64| Sample {
            time: t0 + f64::from(k),
            speed,
            door,
            load,
            ..like
        };
        samples.extend((0..30).map(|k| at(k, 0.0, 1.0, 25.0)));
        samples.extend((30..90).map(|k| at(k, 1.5, 0.0, 25.0)));
        let stuck = samples.len();
        samples.extend((90..3690).map(|k| at(k, 0.0, 0.0, 25.0)));
        let freed = samples.len();
        samples.extend((3690..3720).map(|k| at(k, 0.0, 1.0, 0.0)));
        samples.extend((3720..7320).map(|k| at(k, 0.0, 0.0, 0.0)));
        samples.extend((7320..7380).map(|k| at(k, 1.5, 0.0, 0.0)));
        let home = samples.len();
        samples.extend((7380..10_980).map(|k| at(k, 0.0, 0.0, 0.0)));
        samples.push(at(10_980, 1.5, 0.0, 0.0));

        let mut check = SensorCheck::new();
        let mut drift_at = None;
        let mut witnessed = Vec::new();
        for (i, x) in samples.iter().enumerate() {
            check.sample(x, &limits, 0.05);
            if check.load_zero_drift() && drift_at.is_none() {
                drift_at = Some(i);
            }
            let newest = check.newest_zero_witness().map(f64::from_bits);
            if newest.is_some_and(|t| t > t0 && witnessed.last() != Some(&t)) {
                witnessed.push(newest.unwrap_or(f64::NAN));
            }
        }
        // The hour with people aboard reads 25 %: counted as a parking, it was a zero drift the
        // moment the door opened. The empty hour after it is a witness, and so is the hour at
        // home, where the car arrived with its door shut, empty since its last parking.
        assert_eq!(
            drift_at, None,
            "the trapped riders read as the empty car's zero"
        );
        assert_eq!(
            witnessed,
            [samples[home - 60].time, samples[samples.len() - 1].time],
            "the empty hour after the rescue and the hour at home"
        );

        // Without the door's opening, the same hour is no parking either way.
        let mut parking = Parking::new();
        let ends: Vec<f64> = samples[stuck - 90..freed]
            .iter()
            .chain([&at(3690, 1.5, 0.0, 25.0)])
            .filter_map(|x| parking.push(x, 0.05))
            .collect();
        assert!(ends.is_empty(), "{ends:?}");
    }

    /// A car that arrives, opens its door, takes a rider (14 %) and then stands out of
    /// service for four hours, door closed: a parking by its door, but once the monitor has
    /// concluded the outage it is no witness, and the car is not known empty after it until
    /// its door opens again; the next parking with an opened door is one.
    #[test]
    fn a_car_out_of_service_is_no_parking() {
        let at = |t: f64, speed: f64, door: f64, load: f64| Sample {
            time: t,
            speed,
            direction: 0.0,
            voltage: 0.0,
            load,
            door,
            floor: 1.0,
            current: f64::NAN,
        };
        let mut p = Parking::new();
        let mut ends = Vec::new();
        let mut run = |p: &mut Parking, from: u32, to: u32, speed: f64, door: f64, load: f64| {
            for k in from..to {
                ends.extend(p.push(&at(f64::from(k), speed, door, load), 0.05));
            }
        };
        run(&mut p, 0, 10, 0.0, 1.0, 14.0);
        run(&mut p, 10, 3000, 0.0, 0.0, 14.0);
        p.void(); // the outage is concluded
        run(&mut p, 3000, 14_400, 0.0, 0.0, 14.0);
        run(&mut p, 14_400, 14_460, 1.5, 0.0, 14.0);
        run(&mut p, 14_460, 18_060, 0.0, 0.0, 14.0);
        run(&mut p, 18_060, 18_070, 0.0, 1.0, 0.0);
        run(&mut p, 18_070, 21_670, 0.0, 0.0, 0.0);
        run(&mut p, 21_670, 21_680, 1.5, 0.0, 0.0);
        assert_eq!(ends, [0.0], "only the parking after the door opened again");
    }

    #[test]
    fn the_parked_readings_witness_a_zero_shift_below_the_limit() {
        let mut limits = SensorLimits::default();
        limits.calibrate_load_zero(day(0.0, 0.0, 1), 0.05);
        assert!(limits.load_zero_sd_pct >= ZERO_SD_FLOOR_PCT);
        let witness = |offset: f64, since: f64| {
            let mut check = SensorCheck::new();
            for x in day(DAY_S, offset, 2) {
                check.sample(&x, &limits, 0.05);
            }
            (
                check.load_zero_drift(),
                check.load_zero_shift(&limits, since),
            )
        };
        // 0.4 % is inside the limit, no verdict, but the day's parkings read it plainly.
        let (flagged, shift) = witness(0.4, 0.0);
        let (pct, se) = shift.expect("24 parkings");
        assert!(!flagged);
        assert!(
            (pct - 0.4).abs() < 0.1 && pct >= ZERO_WITNESS_Z * se,
            "{pct} ± {se} %"
        );
        let (_, shift) = witness(0.0, 0.0);
        let (pct, se) = shift.expect("24 parkings");
        assert!(pct.abs() < ZERO_WITNESS_Z * se, "healthy: {pct} ± {se} %");
        // Only the parkings after `since` are witnesses.
        assert_eq!(witness(0.4, 3.0 * DAY_S).1, None);
        // Three days of parkings keep the last ZERO_WITNESSES, also from an oversized state.
        let mut check = SensorCheck::new();
        let stale = (StateF64(0.0), StateF64(5.0));
        check
            .zero_witnesses
            .extend(std::iter::repeat(stale).take(3 * ZERO_WITNESSES));
        for d in 1..4u32 {
            for x in day(f64::from(d) * DAY_S, 0.0, d.into()) {
                check.sample(&x, &limits, 0.05);
            }
        }
        assert_eq!(check.zero_witnesses.len(), ZERO_WITNESSES);
        assert!(check.zero_witnesses.iter().all(|(t, _)| t.0 > DAY_S));
    }

    #[test]
    fn without_a_trained_zero_the_first_parkings_monitored_are_the_witnesses_zero() {
        // A training too short to park in leaves the model no zero. The monitor learns one
        // from its first ZERO_LEARNT_PARKINGS parkings (the first 16 hours of `day`), and the
        // parkings after that witness a zero that moves: 0.4 % from the second day on reads
        // 0.4 %, beyond ZERO_WITNESS_Z standard errors, the learnt zero's own error included;
        // a zero that stays reads within them. No limit is judged without a trained zero.
        let limits = SensorLimits::default();
        assert_eq!(limits.load_zero_pct, None);
        let witness = |offset: f64| {
            let mut check = SensorCheck::new();
            for x in day(DAY_S, 0.0, 2).iter().take(10 * 3600) {
                check.sample(x, &limits, 0.05);
            }
            assert_eq!(
                check.load_zero_shift(&limits, 0.0),
                None,
                "10 parkings learn no zero"
            );
            for x in day(DAY_S + 10.0 * HOUR_S, 0.0, 3).iter().take(14 * 3600) {
                check.sample(x, &limits, 0.05);
            }
            for x in day(2.0 * DAY_S, offset, 4) {
                check.sample(&x, &limits, 0.05);
            }
            assert!(!check.load_zero_drift());
            check
                .load_zero_shift(&limits, 2.0 * DAY_S)
                .expect("a day of parkings after the learnt zero")
        };
        let (pct, se) = witness(0.4);
        assert!(
            (pct - 0.4).abs() < 0.1 && pct >= ZERO_WITNESS_Z * se,
            "{pct} ± {se} %"
        );
        let (pct, se) = witness(0.0);
        assert!(pct.abs() < ZERO_WITNESS_Z * se, "healthy: {pct} ± {se} %");
    }

    /// `stops` stops of 1 Hz samples: 15 s at speed, then a standstill of 8-60 s. At rest the
    /// drive reads `rest_v` (with 1 V of noise, quantised to 0.5 V) and, when it is off at
    /// rest (`pre_torque`), 40 V of pre-torque for a second either side of the motion; from
    /// stop `offset_from` on, the sensor reads 25 V high.
    fn stops(
        n: usize,
        rest_v: f64,
        pre_torque: bool,
        offset_from: usize,
        seed: u64,
    ) -> Vec<Sample> {
        let mut rng = crate::rng::Rng::new(seed);
        let mut out = Vec::new();
        let mut t = 0.0;
        for k in 0..n {
            let offset = if k >= offset_from { 25.0 } else { 0.0 };
            let still = 8 + rng.below(53) as usize;
            for i in 0..15 + still {
                let moving = i < 15;
                let held = pre_torque && (i == 15 || i + 1 == 15 + still);
                let u = if moving {
                    300.0
                } else if held {
                    40.0
                } else {
                    rest_v
                };
                let reading = (2.0 * (u + offset + rng.normal())).round() / 2.0;
                out.push(Sample {
                    time: t,
                    speed: if moving { 1.5 } else { 0.0 },
                    direction: 0.0,
                    voltage: reading.max(0.0),
                    load: 0.0,
                    door: 0.0,
                    floor: 1.0,
                    current: f64::NAN,
                });
                t += 1.0;
            }
        }
        out
    }

    #[test]
    fn a_shifted_rest_voltage_is_a_voltage_sensor_offset_within_a_few_stops() {
        for (rest_v, pre_torque) in [(0.3, true), (11.0, false)] {
            let mut limits = SensorLimits::default();
            limits.calibrate_rest_voltage(
                stops(300, rest_v, pre_torque, usize::MAX, 1),
                0.05,
                350.0,
            );
            let reference = limits
                .rest_voltage_v
                .expect("300 stops calibrate the check");
            assert!(
                (reference - rest_v).abs() < 0.5,
                "rest reading {reference} V"
            );
            // The allowance is the 1 % class of a 350 V drive: the healthy stops sit well inside.
            assert!((limits.rest_voltage_allowance_v - 3.5).abs() < 1e-9);

            // (stop at which it is first flagged, flagged at the end, channel at the end)
            let watch = |offset_from: usize| {
                let mut check = SensorCheck::new();
                let mut first = None;
                let mut stop = 0;
                let mut was_moving = false;
                let xs = stops(2000, rest_v, pre_torque, offset_from, 2);
                for x in &xs {
                    let moving = x.speed > 0.05;
                    stop += usize::from(moving && !was_moving);
                    was_moving = moving;
                    check.sample(x, &limits, 0.05);
                    if check.voltage_offset() && first.is_none() {
                        first = Some(stop);
                    }
                }
                let end = xs.last().unwrap().time;
                (first, check.channel(&limits, end))
            };
            // 2000 healthy stops: never flagged.
            assert_eq!(watch(usize::MAX), (None, None), "rest {rest_v} V");
            // 25 V from stop 1000 on: flagged at the fifth stop the offset shows in (the stop
            // counted here is the trip that ends the standstill), named the voltage channel.
            let (first, channel) = watch(1000);
            let first = first.expect("the offset is flagged");
            assert!((1000..=1006).contains(&first), "flagged at stop {first}");
            assert_eq!(channel, Some(Signal::Voltage));
        }
    }

    #[test]
    fn a_short_training_leaves_the_zero_check_off() {
        let mut limits = SensorLimits::default();
        limits.calibrate_load_zero(&day(0.0, 0.0, 1)[..3 * 3600], 0.05);
        assert_eq!(limits.load_zero_pct, None);
        let mut check = SensorCheck::new();
        for x in day(DAY_S, 5.0, 2) {
            check.sample(&x, &limits, 0.05);
        }
        assert!(!check.load_zero_drift());
    }
}
