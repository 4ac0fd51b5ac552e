//! Stage 3: physical features from aligned samples (paper, Sec. 4.1).
//!
//! ```text
//! v   = direction · speed                     signed velocity (m/s, + up)
//! s   = sign(v) if |v| > v_move else 0        direction of motion
//! λ   = L_ref / 100                           static load ratio, L_ref held from door close
//! a_v = (v[t+1] − v[t−1]) / (t[t+1] − t[t−1]) speed path, central difference (one sample look-ahead)
//! a_L = g·(L − L_ref)/100 / (λ + p)           load-cell inertial path, door closed, p fitted on history
//! a   = β·a_v + (1 − β)·a_L                   β by phase of travel; a = 0 at rest
//! ```
//!
//! Why a_L: the load-weighing cell sits under the platform and reads
//! `100·(m_load·(g + a) + m_platform·a)/(M_r·g)` percent, so with the door closed (load constant)
//! `L − L_ref = 100·a·(m_load + m_platform)/(M_r·g)`, i.e. the paper's `a_L = k·(L − L_ref)` with
//! `k = g/(100·(λ + p))` and `p = m_platform/M_r`. [`fit_load_cell`] identifies p on history.
//!
//! λ is the reading at standstill with the door closed (the mean of those readings since the
//! door last opened, which averages the cell's noise), held through the trip: while moving the
//! cell also feels inertia, and the raw moving reading biases the identified mass. The door
//! often closes less than a second before the start; when no door-closed standstill sample
//! falls in between, the last standstill reading (door still reported open) stands in.
//!
//! The extraction is a streaming step, [`FeatureTracker::push`], that emits the row of the sample
//! [`LAG`] steps back once its successor is known; [`extract`] is a loop over it, so a batch run
//! and a monitor that saves the tracker between two files give identical rows.
//!
//! Deviation from the paper: the paper weighs the load path more while cruising and the speed
//! path more while starting and braking. At 1 Hz the central difference is the mean acceleration
//! over a 2 s window: exact while the acceleration is constant (cruising, and the constant-
//! acceleration plateau) but blurred at the jerk corners of starting and braking, where the
//! instantaneous load-cell reading is the better witness. The defaults of
//! [`FeatureConfig::for_elevator`] therefore weigh the speed path more while cruising
//! (β = 0.95) and the load path more while accelerating or decelerating (β = 0.3).
//!
//! Deviation from the paper: β also follows the load. The cell's noise is a fixed share of the
//! rated load, so a_L is noisier the lighter the car (σ_L ∝ 1/(λ + p)); the configured β hold at
//! half load and [`FeatureConfig::beta`] rescales them as inverse-variance weights. On the
//! jerk-limited S-curve test of this module (6 × 8 trips, speed noise 0.005 m/s, load noise
//! 0.5 % of rated load) the RMS error against the true acceleration over moving samples is
//! 0.108 m/s² for the speed path, 0.119 for the load path, 0.068 fused with these defaults,
//! 0.099 with the paper's phase weighting (β 0.8 transient, 0.3 cruise) and 0.085 with its
//! fixed β = 0.7.
//!
//! Deviation from the paper: the paper's "smoothing" of Δv/Δt is the central difference itself
//! (a 2Δt box filter on a); no causal smoother is added on top because it would delay a_v
//! against the load path and the voltage.

use serde::{Deserialize, Serialize};

use crate::elevator::{Elevator, G};
use crate::error::{Error, Result};
use crate::sample::{AlignedSeries, Sample};

/// How many samples a row is held back: a_v needs the successor of its sample.
pub const LAG: usize = 1;

/// |a_v| above which a moving sample is accelerating or decelerating rather than cruising (m/s²).
pub const PHASE_ACCEL_MPS2: f64 = 0.1;

/// Two samples further apart than this (s), or out of order, are not neighbours: the speed path
/// restarts and a trip in progress is dropped.
pub const MAX_STEP_S: f64 = 10.0;

/// Load readings outside this range (percent of rated load) are treated as missing.
pub const LOAD_PLAUSIBLE_PCT: (f64, f64) = (-20.0, 200.0);

/// Largest λ reported; an overloaded car reads up to about 1.1, higher is a sensor fault.
pub const LAMBDA_MAX: f64 = 1.5;

/// |a_L| above which the moving load reading is implausible and a_L is missing (m/s²).
const A_L_MAX_MPS2: f64 = 3.0;

/// L_ref is a running mean of at most this many door-closed standstill readings.
const L_REF_WINDOW: f64 = 30.0;

/// A direction signal seen this recently (s) still tells the sign of a start without one.
const DIR_MEMORY_S: f64 = 5.0;

/// The load ratio λ at which the configured β apply; see [`FeatureConfig::beta`].
pub const BETA_REF_LAMBDA: f64 = 0.5;

/// Settings of feature extraction; saved in the model file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FeatureConfig {
    /// Rated load M_r (kg), to turn the load percentage into λ.
    pub rated_load_kg: f64,
    /// |v| above which the car counts as moving (m/s).
    pub moving_threshold_mps: f64,
    /// p of the load-cell path: platform and sling mass felt by the cell, as a fraction of M_r.
    pub load_cell_platform_ratio: f64,
    /// β while starting or braking (speed path weight), at the reference load
    /// [`BETA_REF_LAMBDA`]; [`FeatureConfig::beta`] scales it with the load.
    pub beta_transient: f64,
    /// β while cruising or at rest, at the reference load, scaled likewise.
    pub beta_cruise: f64,
}

impl FeatureConfig {
    /// Defaults for an elevator: moving above 0.05 m/s, p = 0.15 (a platform of 15 % of the
    /// rated load until [`fit_load_cell`] identifies it), β 0.3 while accelerating or
    /// decelerating and 0.95 while cruising (see the module's deviation note).
    pub fn for_elevator(e: &Elevator) -> Self {
        FeatureConfig {
            rated_load_kg: e.rated_load_kg,
            moving_threshold_mps: 0.05,
            load_cell_platform_ratio: 0.15,
            beta_transient: 0.3,
            beta_cruise: 0.95,
        }
    }

    /// Checks every setting against its range.
    ///
    /// # Errors
    /// [`Error::InvalidConfig`] naming the first setting out of range.
    pub fn validate(&self) -> Result<()> {
        let check = |field: &'static str, v: f64, lo: f64, hi: f64| {
            if v.is_finite() && (lo..=hi).contains(&v) {
                Ok(())
            } else {
                Err(Error::InvalidConfig {
                    field,
                    why: format!("{v} is out of range, expected {lo} to {hi}"),
                })
            }
        };
        check("rated_load_kg", self.rated_load_kg, 1.0, 100_000.0)?;
        check("moving_threshold_mps", self.moving_threshold_mps, 1e-4, 1.0)?;
        check(
            "load_cell_platform_ratio",
            self.load_cell_platform_ratio,
            0.01,
            2.0,
        )?;
        check("beta_transient", self.beta_transient, 0.0, 1.0)?;
        check("beta_cruise", self.beta_cruise, 0.0, 1.0)
    }

    /// β for a phase of travel and a load ratio λ: the weight of the speed path in the fused
    /// acceleration.
    ///
    /// The configured β holds at the reference load [`BETA_REF_LAMBDA`]. The load cell's noise is
    /// a fixed share of the rated load, so the noise of a_L scales as 1/(λ + p); read as an
    /// inverse-variance weight, β = σ_L²/(σ_L² + σ_v²), the configured value fixes the ratio
    /// σ_v/σ_L at the reference load and the weight at λ follows:
    /// `β(λ) = 1 / (1 + (1/β_ref − 1)·((λ + p)/(λ_ref + p))²)`. β = 0 and β = 1 stay fixed;
    /// without λ the configured value is used.
    pub fn beta(&self, phase: Phase, lambda: f64) -> f64 {
        let beta_ref = match phase {
            Phase::Accelerating | Phase::Decelerating => self.beta_transient,
            Phase::Cruising | Phase::Standstill => self.beta_cruise,
        };
        if !lambda.is_finite() || beta_ref <= 0.0 || beta_ref >= 1.0 {
            return beta_ref;
        }
        let p = self.load_cell_platform_ratio;
        let scale = (lambda + p) / (BETA_REF_LAMBDA + p);
        1.0 / (1.0 + (1.0 / beta_ref - 1.0) * scale * scale)
    }
}

/// Phase of travel of one sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Phase {
    /// Not moving.
    Standstill,
    /// Speeding up.
    Accelerating,
    /// Near constant speed.
    Cruising,
    /// Slowing down.
    Decelerating,
}

/// Features of one aligned sample. `NaN` marks a value that cannot be computed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FeatureRow {
    /// Time (s).
    pub time: f64,
    /// v: signed car velocity (m/s, + up).
    pub v: f64,
    /// s: direction of motion, +1 up, −1 down, 0 at rest (|v| below the threshold).
    pub s: i8,
    /// λ: static load ratio (0..1 of rated load), held from the last door close.
    pub lambda: f64,
    /// a_v: acceleration from the speed path (m/s²).
    pub a_v: f64,
    /// a_L: acceleration from the load-cell path (m/s²), NaN while not applicable.
    pub a_l: f64,
    /// a: fused acceleration (m/s²).
    pub a: f64,
    /// U: measured motor voltage (V).
    pub voltage: f64,
    /// Floor indicator (1-based), NaN when missing: the car's position for the rope imbalance.
    pub floor: f64,
    /// Phase of travel.
    pub phase: Phase,
    /// Index of the trip this sample belongs to, if moving.
    pub trip: Option<u32>,
}

/// One trip: from the first moving sample after a standstill to the last before the next.
///
/// A trip cut by a gap (missing speed, a time jump, the end of the data) is not reported; its
/// rows keep the index, so reported indices can skip numbers.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Trip {
    /// Index of the trip, counted from 0 in the order the trips start.
    pub index: u32,
    /// Time of the first moving sample (s).
    pub start_time: f64,
    /// Time of the last moving sample (s).
    pub end_time: f64,
    /// Direction: +1 up, −1 down, the sign of the net displacement.
    pub direction: i8,
    /// Floor indicator at the standstill before the trip (NaN when missing).
    pub from_floor: f64,
    /// Floor indicator at the standstill after the trip (NaN when missing).
    pub to_floor: f64,
    /// λ: static load ratio held through the trip (NaN when no standstill reading preceded it).
    pub load_ratio: f64,
    /// Largest |v| in the trip (m/s).
    pub peak_speed: f64,
    /// Distance travelled, ∫|v|dt by the trapezoid rule from standstill to standstill (m).
    pub distance_m: f64,
    /// Number of moving samples.
    pub samples: u32,
}

/// The features of a whole series.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Features {
    /// One row per input sample, in the same order.
    pub rows: Vec<FeatureRow>,
    /// The complete trips, in order.
    pub trips: Vec<Trip>,
}

/// Serde for the f64 fields of the tracker state: written as the shortest decimal that parses
/// back to the same bits (a string, so that NaN survives JSON and no parser rounds it),
/// read from that string, a number or null (NaN).
mod exact {
    use serde::{Deserialize, Deserializer, Serializer};

    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Repr {
        Text(String),
        Number(f64),
    }

    pub fn serialize<S: Serializer>(x: &f64, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&format!("{x:?}"))
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
        match Option::<Repr>::deserialize(d)? {
            None => Ok(f64::NAN),
            Some(Repr::Number(x)) => Ok(x),
            Some(Repr::Text(t)) => t
                .parse()
                .map_err(|_| serde::de::Error::custom(format!("`{t}` is not a number"))),
        }
    }
}

/// Door state of a sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
enum Door {
    Closed,
    Open,
    Unknown,
}

/// One sample, preprocessed on arrival: what the rows need of it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
struct Pre {
    #[serde(with = "exact")]
    time: f64,
    /// Speed magnitude (m/s), NaN when missing.
    #[serde(with = "exact")]
    speed: f64,
    /// Signed velocity, NaN when the speed or its sign is missing.
    #[serde(with = "exact")]
    v: f64,
    s: i8,
    /// Load reading (percent), NaN when missing or implausible.
    #[serde(with = "exact")]
    load: f64,
    door: Door,
    #[serde(with = "exact")]
    floor: f64,
    #[serde(with = "exact")]
    voltage: f64,
}

impl Pre {
    /// Velocity as a neighbour in a difference: 0 at rest, so that standstill noise is not
    /// read as acceleration at the start and end of a trip.
    fn v_boundary(&self) -> f64 {
        if self.s == 0 && self.v.is_finite() {
            0.0
        } else {
            self.v
        }
    }

    /// True when the sample has a known velocity and is at rest.
    fn at_rest(&self) -> bool {
        self.v.is_finite() && self.s == 0
    }
}

/// True when `b` directly follows `a` in time.
fn follows(a: &Pre, b: &Pre) -> bool {
    let dt = b.time - a.time;
    dt > 0.0 && dt <= MAX_STEP_S
}

/// A trip in progress.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
struct TripAcc {
    index: u32,
    #[serde(with = "exact")]
    start_time: f64,
    /// L_ref held from the standstill before the start (percent), NaN when unknown.
    #[serde(with = "exact")]
    l_ref: f64,
    #[serde(with = "exact")]
    from_floor: f64,
    #[serde(with = "exact")]
    last_floor: f64,
    #[serde(with = "exact")]
    peak_speed: f64,
    #[serde(with = "exact")]
    distance_m: f64,
    /// ∫v dt, whose sign is the direction.
    #[serde(with = "exact")]
    displacement_m: f64,
    samples: u32,
}

/// Streaming feature extraction: one aligned sample in, the row of the previous sample out.
///
/// Its state is a few samples and a trip in progress, (de)serialisable so that a monitor can
/// stop after one file and resume on the next with exactly the rows of one run. The floats of
/// the state serialise as exact decimal strings (NaN included).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FeatureTracker {
    cfg: FeatureConfig,
    /// The sample before the held one.
    prev: Option<Pre>,
    /// The held sample, whose row waits for its successor.
    cur: Option<Pre>,
    /// Sign of the last moving sample, 0 after a standstill or a missing speed.
    motion_sign: i8,
    /// Last nonzero direction signal and when it was seen.
    last_dir: i8,
    #[serde(with = "exact")]
    last_dir_time: f64,
    /// Floor indicator at the last standstill.
    #[serde(with = "exact")]
    rest_floor: f64,
    /// Running mean of door-closed standstill load readings (percent), NaN when none.
    #[serde(with = "exact")]
    ref_mean: f64,
    /// Number of readings in the mean, capped at the window.
    #[serde(with = "exact")]
    ref_n: f64,
    /// The last load reading at standstill whatever the door, and its time: the reference
    /// when no door-closed reading came between the door closing and the start.
    #[serde(with = "exact")]
    rest_load: f64,
    #[serde(with = "exact")]
    rest_load_time: f64,
    trip: Option<TripAcc>,
    next_trip: u32,
    /// The trip ended by the last row returned; not part of the saved state (take it first).
    #[serde(skip)]
    ended: Option<Trip>,
}

impl FeatureTracker {
    /// A tracker with nothing seen yet.
    pub fn new(cfg: FeatureConfig) -> Self {
        FeatureTracker {
            cfg,
            prev: None,
            cur: None,
            motion_sign: 0,
            last_dir: 0,
            last_dir_time: f64::NAN,
            rest_floor: f64::NAN,
            ref_mean: f64::NAN,
            ref_n: 0.0,
            rest_load: f64::NAN,
            rest_load_time: f64::NAN,
            trip: None,
            next_trip: 0,
            ended: None,
        }
    }

    /// The settings in use.
    pub fn config(&self) -> &FeatureConfig {
        &self.cfg
    }

    /// Feeds one aligned sample; returns the row of the sample LAG (=1) steps back once its
    /// successor is known.
    pub fn push(&mut self, s: &Sample) -> Option<FeatureRow> {
        let next = self.preprocess(s);
        // A start whose direction signal comes a sample late: the successor's sign tells it.
        if let Some(c) = self.cur.as_mut() {
            if c.v.is_nan() && c.speed.is_finite() && next.s != 0 && follows(c, &next) {
                c.v = f64::from(next.s) * c.speed;
                c.s = next.s;
            }
        }
        let row = self.cur.map(|c| self.row(self.prev, c, Some(next)));
        self.prev = self.cur;
        self.cur = Some(next);
        row
    }

    /// End of data for good: returns the rows still held (computed without look-ahead).
    /// A trip still running is dropped; the tracker starts afresh afterwards, trip indices
    /// continuing.
    pub fn finish(&mut self) -> Vec<FeatureRow> {
        let rows = self
            .cur
            .map(|c| self.row(self.prev, c, None))
            .into_iter()
            .collect();
        let next_trip = self.next_trip;
        let ended = self.ended.take();
        *self = FeatureTracker {
            next_trip,
            ended,
            ..FeatureTracker::new(self.cfg.clone())
        };
        rows
    }

    /// The trip that ended with the last row returned, if any (call after push/finish).
    pub fn take_trip(&mut self) -> Option<Trip> {
        self.ended.take()
    }

    /// Signed velocity, door and load of a sample on arrival; updates the direction memory and
    /// the door-close load reference.
    ///
    /// The sign comes from the direction signal; when it is missing or 0 while the car moves,
    /// from (in this order) the previous moving sample, a direction signal seen within
    /// [`DIR_MEMORY_S`], the floor indicator's change since the last standstill; failing these,
    /// [`FeatureTracker::push`] takes the sign of the successor once it arrives (the direction
    /// signal, held by the alignment, often turns a sample after the speed). With none of them
    /// the velocity is missing. At rest an unknown sign does not matter (|v| is below the
    /// threshold) and +1 is used.
    fn preprocess(&mut self, x: &Sample) -> Pre {
        let thr = self.cfg.moving_threshold_mps;
        let speed = if x.speed.is_finite() {
            x.speed.abs()
        } else {
            f64::NAN
        };
        let dir_signal: i8 = match x.direction {
            d if d > 0.5 => 1,
            d if d < -0.5 => -1,
            _ => 0,
        };
        if dir_signal != 0 {
            self.last_dir = dir_signal;
            self.last_dir_time = x.time;
        }
        let moving = speed > thr;
        let floor = if x.floor.is_finite() {
            x.floor
        } else {
            f64::NAN
        };
        let sign: i8 = if dir_signal != 0 {
            dir_signal
        } else if !moving {
            if self.motion_sign != 0 {
                self.motion_sign
            } else {
                1
            }
        } else if self.motion_sign != 0 {
            self.motion_sign
        } else if self.last_dir != 0 && (x.time - self.last_dir_time).abs() <= DIR_MEMORY_S {
            self.last_dir
        } else {
            let df = floor - self.rest_floor;
            if df > 0.5 {
                1
            } else if df < -0.5 {
                -1
            } else {
                0
            }
        };
        let v = if !speed.is_finite() || sign == 0 {
            f64::NAN
        } else {
            f64::from(sign) * speed
        };
        let s = if v.is_finite() && v.abs() > thr {
            sign
        } else {
            0
        };
        self.motion_sign = s;
        if v.is_finite() && s == 0 && floor.is_finite() {
            self.rest_floor = floor;
        }
        let door = match x.door {
            d if d > 0.5 => Door::Open,
            d if d.is_finite() => Door::Closed,
            _ => Door::Unknown,
        };
        let (lo, hi) = LOAD_PLAUSIBLE_PCT;
        let load = if x.load.is_finite() && (lo..=hi).contains(&x.load) {
            x.load
        } else {
            f64::NAN
        };
        // The reference: readings at true standstill (well below the motion threshold, so not
        // the first instant of a start) with the door not known to be open; an open door
        // means the load is changing and the mean restarts.
        let still = speed.is_finite() && speed <= 0.2 * thr && load.is_finite();
        if still {
            self.rest_load = load;
            self.rest_load_time = x.time;
        }
        if door == Door::Open {
            self.ref_mean = f64::NAN;
            self.ref_n = 0.0;
        } else if still {
            self.ref_n = (self.ref_n + 1.0).min(L_REF_WINDOW);
            let m = if self.ref_mean.is_finite() {
                self.ref_mean
            } else {
                load
            };
            self.ref_mean = m + (load - m) / self.ref_n;
        }
        Pre {
            time: x.time,
            speed,
            v,
            s,
            load,
            door,
            floor,
            voltage: x.voltage,
        }
    }

    /// The row of the held sample `c` from its neighbours; advances the trip segmentation.
    fn row(&mut self, p: Option<Pre>, c: Pre, n: Option<Pre>) -> FeatureRow {
        let p = p.filter(|p| follows(p, &c) && p.v.is_finite());
        let n = n.filter(|n| follows(&c, n));
        let n_v = n.filter(|n| n.v.is_finite());
        let a_v = if !c.v.is_finite() {
            f64::NAN
        } else {
            match (p, n_v) {
                (Some(p), Some(n)) => (n.v_boundary() - p.v_boundary()) / (n.time - p.time),
                (Some(p), None) => (c.v_boundary() - p.v_boundary()) / (c.time - p.time),
                (None, Some(n)) => (n.v_boundary() - c.v_boundary()) / (n.time - c.time),
                (None, None) => f64::NAN,
            }
        };
        let trip = self.advance_trip(p, &c, n);
        let held_ref = trip.as_ref().map_or(f64::NAN, |t| t.l_ref);
        let lambda = if c.s != 0 {
            held_ref / 100.0
        } else if self.ref_n > 0.0 {
            self.ref_mean / 100.0
        } else {
            c.load / 100.0
        };
        let lambda = if lambda.is_finite() {
            lambda.clamp(0.0, LAMBDA_MAX)
        } else {
            f64::NAN
        };
        let a_l = if c.s != 0 && c.door == Door::Closed && lambda.is_finite() {
            let a = G * (c.load - held_ref) / 100.0 / (lambda + self.cfg.load_cell_platform_ratio);
            if a.abs() <= A_L_MAX_MPS2 {
                a
            } else {
                f64::NAN
            }
        } else {
            f64::NAN
        };
        let phase = if !c.at_rest() && c.v.is_finite() {
            let along = a_v * f64::from(c.s);
            if along > PHASE_ACCEL_MPS2 {
                Phase::Accelerating
            } else if along < -PHASE_ACCEL_MPS2 {
                Phase::Decelerating
            } else {
                Phase::Cruising
            }
        } else {
            Phase::Standstill
        };
        let a = if !c.v.is_finite() {
            f64::NAN
        } else if phase == Phase::Standstill {
            0.0
        } else {
            let beta = self.cfg.beta(phase, lambda);
            match (a_v.is_finite(), a_l.is_finite()) {
                (true, true) => beta * a_v + (1.0 - beta) * a_l,
                (true, false) => a_v,
                (false, true) => a_l,
                (false, false) => f64::NAN,
            }
        };
        FeatureRow {
            time: c.time,
            v: c.v,
            s: c.s,
            lambda,
            a_v,
            a_l,
            a,
            voltage: c.voltage,
            floor: c.floor,
            phase,
            trip: trip.map(|t| t.index),
        }
    }

    /// Trip segmentation at the held sample `c`: starts a trip when `c` moves right after a
    /// known standstill `p`, ends it when `n` is a known standstill, drops it at a gap.
    /// Returns the trip `c` belongs to (its state after `c`).
    fn advance_trip(&mut self, p: Option<Pre>, c: &Pre, n: Option<Pre>) -> Option<TripAcc> {
        if c.s == 0 {
            // Only reachable after a gap dropped the look-ahead; nothing to continue.
            self.trip = None;
            return None;
        }
        let speed = c.v.abs();
        if self.trip.is_none() {
            let p = p.filter(Pre::at_rest)?;
            // The door often closes less than a second before the start, so at 1 Hz there may
            // be no door-closed standstill reading: then the last standstill reading (door
            // still reading open or closing, riders already aboard) stands in.
            let l_ref = if self.ref_n > 0.0 {
                self.ref_mean
            } else if (0.0..=MAX_STEP_S).contains(&(c.time - self.rest_load_time)) {
                self.rest_load
            } else {
                f64::NAN
            };
            self.trip = Some(TripAcc {
                index: self.next_trip,
                start_time: c.time,
                l_ref,
                from_floor: if p.floor.is_finite() {
                    p.floor
                } else {
                    c.floor
                },
                last_floor: c.floor,
                peak_speed: 0.0,
                distance_m: 0.0,
                displacement_m: 0.0,
                samples: 0,
            });
            self.next_trip += 1;
        }
        let t = self
            .trip
            .as_mut()
            .expect("a trip was started above when none was running");
        // The trapezoid from the previous sample; a trip always has a contiguous predecessor
        // (it started after one, and a gap ends it).
        if let Some(p) = p {
            let dt = c.time - p.time;
            t.distance_m += 0.5 * (p.v_boundary().abs() + speed) * dt;
            t.displacement_m += 0.5 * (p.v_boundary() + c.v) * dt;
        }
        t.peak_speed = t.peak_speed.max(speed);
        t.samples += 1;
        if c.floor.is_finite() {
            t.last_floor = c.floor;
        }
        let snapshot = t.clone();
        match n {
            Some(n) if n.at_rest() => {
                let dt = n.time - c.time;
                let distance_m = t.distance_m + 0.5 * speed * dt;
                let displacement_m = t.displacement_m + 0.5 * c.v * dt;
                self.ended = Some(Trip {
                    index: t.index,
                    start_time: t.start_time,
                    end_time: c.time,
                    direction: if displacement_m >= 0.0 { 1 } else { -1 },
                    from_floor: t.from_floor,
                    to_floor: if n.floor.is_finite() {
                        n.floor
                    } else {
                        t.last_floor
                    },
                    load_ratio: if t.l_ref.is_finite() {
                        (t.l_ref / 100.0).clamp(0.0, LAMBDA_MAX)
                    } else {
                        f64::NAN
                    },
                    peak_speed: t.peak_speed,
                    distance_m,
                    samples: t.samples,
                });
                self.trip = None;
            }
            Some(n) if n.v.is_finite() => {}
            // The next sample is missing or the data ends: the trip cannot be completed.
            _ => self.trip = None,
        }
        Some(snapshot)
    }
}

/// Features of a whole series: a loop over [`FeatureTracker`], nothing else.
pub fn extract(series: &AlignedSeries, cfg: &FeatureConfig) -> Features {
    let mut tracker = FeatureTracker::new(cfg.clone());
    let mut out = Features {
        rows: Vec::with_capacity(series.len()),
        trips: Vec::new(),
    };
    for s in &series.samples {
        if let Some(row) = tracker.push(s) {
            out.rows.push(row);
        }
        out.trips.extend(tracker.take_trip());
    }
    out.rows.extend(tracker.finish());
    out.trips.extend(tracker.take_trip());
    out
}

/// Speed change per step (m/s) below which a moving sample counts as cruising for
/// [`fit_load_cell`]: a point where the acceleration is about zero.
const ANCHOR_DV_MPS: f64 = 0.03;

/// Smallest speed change (m/s) of a segment that [`fit_load_cell`] uses.
const SEGMENT_MIN_DV_MPS: f64 = 0.2;

/// Trips that must contribute to [`fit_load_cell`].
const FIT_MIN_TRIPS: usize = 5;

/// Seconds of motion that [`fit_load_cell`] needs.
const FIT_MIN_MOVING_S: f64 = 60.0;

/// Least-squares fit of the load-cell platform ratio p on history (moving, door closed, valid
/// samples); returns `cfg` with p replaced, clamped to [0.01, 2].
///
/// ```text
/// g·(L − L_ref)/100 = (λ + p)·a                      door closed, load constant
/// S = ∫ g·(L − L_ref)/100 dt  over a segment  = (λ + p)·Δv
/// S − λ·Δv = p·Δv                                     one equation per segment, p by least squares
/// ```
///
/// Segments run between points where the acceleration is about zero: the standstills around a
/// complete trip and its cruising samples; S is the trapezoid sum of the 1 Hz readings.
/// The standstill rows count with their own reading: the car may creep below the motion
/// threshold there. Deviation from a pointwise regression `(L − L_ref)·g/100 − a_v·λ = a_v·p`:
/// a_v is the 2 s mean of the acceleration, L a point reading, and regressing one on the other
/// biased p by +65 % on jerk-limited trips (prototype); the integrals of both sides over whole
/// acceleration and braking phases agree, and p comes back within about ±0.005 from 40 trips
/// (measured in the tests).
///
/// # Errors
/// [`Error::InvalidConfig`] for invalid settings; [`Error::TooLittleMotion`] when fewer than
/// 5 complete door-closed trips reach a cruising speed or there is less than 60 s of motion
/// (callers that can live with the default p keep `cfg`); [`Error::Unidentifiable`] when the
/// equations do not determine p.
pub fn fit_load_cell(series: &AlignedSeries, cfg: &FeatureConfig) -> Result<FeatureConfig> {
    cfg.validate()?;
    let f = extract(series, cfg);
    let rows = &f.rows;
    let p_now = cfg.load_cell_platform_ratio;
    let complete: std::collections::HashSet<u32> = f.trips.iter().map(|t| t.index).collect();
    let moving_s: f64 = rows
        .windows(2)
        .filter(|w| w[1].s != 0 && (0.0..=MAX_STEP_S).contains(&(w[1].time - w[0].time)))
        .map(|w| w[1].time - w[0].time)
        .sum();
    // z = g·(L − L_ref)/100 of a moving row, recovered exactly from a_L.
    let z_moving = |r: &FeatureRow| r.a_l * (r.lambda + p_now);
    let (mut num, mut den, mut used_trips) = (0.0, 0.0, 0usize);
    let mut i = 1;
    while i < rows.len() {
        let Some(k) = rows[i]
            .trip
            .filter(|k| complete.contains(k) && rows[i - 1].trip != Some(*k))
        else {
            i += 1;
            continue;
        };
        // A complete trip ends on a row followed by a standstill row.
        let (start, lambda) = (i - 1, rows[i].lambda);
        let mut end = i;
        while end + 1 < rows.len() && rows[end + 1].trip == Some(k) {
            end += 1;
        }
        i = end + 1;
        if end + 1 >= rows.len() {
            break;
        }
        // The standstill before, the cruising samples, the standstill after.
        let anchors: Vec<usize> = std::iter::once(start)
            .chain((start + 2..end).filter(|&j| {
                (rows[j + 1].v - rows[j].v).abs() < ANCHOR_DV_MPS
                    && (rows[j].v - rows[j - 1].v).abs() < ANCHOR_DV_MPS
            }))
            .chain(std::iter::once(end + 1))
            .collect();
        // z over the trip and its two standstills. At a standstill row the car may already
        // (or still) be creeping below the threshold: its reading counts too, against the
        // trip's L_ref recovered from a moving row; a standstill without a door-closed reading
        // counts as a = 0.
        let l_ref = (start + 1..=end)
            .find(|&j| rows[j].a_l.is_finite())
            .map_or(f64::NAN, |j| {
                series.samples[j].load - 100.0 * z_moving(&rows[j]) / G
            });
        let z_rest = |j: usize| {
            let x = &series.samples[j];
            let z = G * (x.load - l_ref) / 100.0;
            if x.door <= 0.5 && z.is_finite() && z.abs() <= A_L_MAX_MPS2 {
                z
            } else {
                0.0
            }
        };
        let z = |j: usize| {
            if rows[j].s == 0 {
                z_rest(j)
            } else {
                z_moving(&rows[j])
            }
        };
        let mut used = false;
        for w in anchors.windows(2) {
            let (a, b) = (w[0], w[1]);
            let dv = rows[b].v - rows[a].v;
            if dv.abs() < SEGMENT_MIN_DV_MPS || !lambda.is_finite() {
                continue;
            }
            if rows[a..=b].iter().any(|r| r.s != 0 && !r.a_l.is_finite()) {
                continue;
            }
            let s_int: f64 = (a..b)
                .map(|j| 0.5 * (z(j) + z(j + 1)) * (rows[j + 1].time - rows[j].time))
                .sum();
            let y = s_int - lambda * dv;
            num += dv * y;
            den += dv * dv;
            used = true;
        }
        used_trips += usize::from(used);
    }
    if used_trips < FIT_MIN_TRIPS || moving_s < FIT_MIN_MOVING_S {
        return Err(Error::TooLittleMotion {
            moving_s,
            trips: used_trips,
            need_s: FIT_MIN_MOVING_S,
            need_trips: FIT_MIN_TRIPS,
        });
    }
    let p = num / den;
    if !p.is_finite() {
        return Err(Error::Unidentifiable(
            "the load-cell equations do not determine the platform ratio p".into(),
        ));
    }
    Ok(FeatureConfig {
        load_cell_platform_ratio: p.clamp(0.01, 2.0),
        ..cfg.clone()
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    /// Step of the simulated truth (s): 50 Hz.
    const DT: f64 = 0.02;
    /// Floor height (m).
    const H: f64 = 3.0;
    /// Load-cell noise (percent of rated load, one standard deviation).
    const LOAD_NOISE_PCT: f64 = 0.5;
    /// Encoder speed noise (m/s, one standard deviation).
    const SPEED_NOISE_MPS: f64 = 0.005;

    /// Acceleration of a jerk-limited S-curve trip over `distance` (m) at 50 Hz: jerk 1 m/s³,
    /// at most 0.8 m/s² and 1.75 m/s, the peak speed lowered until the trip fits.
    fn s_curve(distance: f64) -> Vec<f64> {
        let (v_max, a_max, jerk): (f64, f64, f64) = (1.75, 0.8, 1.0);
        // Ramp time, plateau time and distance of speeding up to `vp` and back down.
        let phases = |vp: f64| {
            let tj = (a_max / jerk).min((vp / jerk).sqrt());
            let ta = (vp / (jerk * tj) - tj).max(0.0);
            (tj, ta, vp * (2.0 * tj + ta))
        };
        let (mut lo, mut hi) = (0.0, v_max);
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if phases(mid).2 > distance {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        let (tj, ta, d) = phases(lo);
        let tc = (distance - d) / lo;
        let steps = |t: f64| (t / DT).round() as usize;
        let plan = [
            (tj, jerk),
            (ta, 0.0),
            (tj, -jerk),
            (tc, 0.0),
            (tj, -jerk),
            (ta, 0.0),
            (tj, jerk),
        ];
        let mut a = vec![0.0];
        for (t, j) in plan {
            for _ in 0..steps(t) {
                let last = *a.last().expect("starts with one value");
                a.push(last + j * DT);
            }
        }
        // The ramps are whole steps, so the last value is zero up to rounding.
        *a.last_mut().expect("not empty") = 0.0;
        a
    }

    /// A day of travel at 1 Hz and the true acceleration at each sample.
    struct Day {
        series: AlignedSeries,
        a_true: Vec<f64>,
        lambda_true: Vec<f64>,
    }

    /// Simulates the legs `(to_floor, λ)` from floor 1: door open 6 s (the load changes), door
    /// closed 4 s, the S-curve trip, 3 s at rest; the load cell reads
    /// `100·(λ·(g + a) + p·a)/g` plus noise. Samples at 1 Hz with a random phase.
    fn day(legs: &[(u32, f64)], p: f64, seed: u64) -> Day {
        let mut rng = Rng::new(seed);
        let (mut a, mut door, mut lam, mut dir) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let mut floor = 1u32;
        let mut lambda = legs.first().map_or(0.0, |l| l.1);
        let rest = |n_s: f64,
                    open: bool,
                    l: f64,
                    a: &mut Vec<f64>,
                    door: &mut Vec<bool>,
                    lam: &mut Vec<f64>,
                    dir: &mut Vec<i8>| {
            for _ in 0..(n_s / DT) as usize {
                a.push(0.0);
                door.push(open);
                lam.push(l);
                dir.push(0);
            }
        };
        for &(to, l) in legs {
            rest(3.0, true, lambda, &mut a, &mut door, &mut lam, &mut dir);
            lambda = l;
            rest(3.0, true, lambda, &mut a, &mut door, &mut lam, &mut dir);
            rest(4.0, false, lambda, &mut a, &mut door, &mut lam, &mut dir);
            let sign: i8 = if to > floor { 1 } else { -1 };
            for x in s_curve(f64::from(to.abs_diff(floor)) * H) {
                a.push(f64::from(sign) * x);
                door.push(false);
                lam.push(lambda);
                dir.push(sign);
            }
            rest(3.0, false, lambda, &mut a, &mut door, &mut lam, &mut dir);
            floor = to;
        }
        // Integrate speed and position.
        let (mut v, mut x) = (vec![0.0; a.len()], vec![0.0; a.len()]);
        for k in 1..a.len() {
            v[k] = v[k - 1] + 0.5 * (a[k - 1] + a[k]) * DT;
            x[k] = x[k - 1] + 0.5 * (v[k - 1] + v[k]) * DT;
        }
        let offset = rng.uniform(0.0, 1.0);
        let mut out = Day {
            series: AlignedSeries {
                step_s: 1.0,
                samples: Vec::new(),
            },
            a_true: Vec::new(),
            lambda_true: Vec::new(),
        };
        let mut t = offset;
        while ((t / DT).round() as usize) < a.len() {
            let k = (t / DT).round() as usize;
            let speed = if v[k].abs() > 1e-9 {
                (v[k].abs() + SPEED_NOISE_MPS * rng.normal()).max(0.0)
            } else {
                0.0
            };
            let load = 100.0 * (lam[k] * (G + a[k]) + p * a[k]) / G + LOAD_NOISE_PCT * rng.normal();
            out.series.samples.push(Sample {
                time: t,
                speed,
                direction: f64::from(dir[k]),
                voltage: 200.0 + 150.0 * v[k].abs(),
                load,
                door: if door[k] { 1.0 } else { 0.0 },
                floor: (x[k] / H).round() + 1.0,
                current: f64::NAN,
            });
            out.a_true.push(a[k]);
            out.lambda_true.push(lam[k]);
            t += 1.0;
        }
        out
    }

    fn config() -> FeatureConfig {
        FeatureConfig::for_elevator(&Elevator::new(1000.0, 1.75, 20))
    }

    /// A varied day: short and long trips both ways, empty to heavy.
    const LEGS: [(u32, f64); 8] = [
        (6, 0.4),
        (3, 0.1),
        (12, 0.7),
        (11, 0.3),
        (1, 0.5),
        (2, 0.05),
        (9, 0.9),
        (4, 0.2),
    ];

    fn rms(e: impl Iterator<Item = f64>) -> f64 {
        let (s, n) = e.fold((0.0, 0usize), |(s, n), x| (s + x * x, n + 1));
        (s / n as f64).sqrt()
    }

    /// True when two rows are the same bit for bit (NaN equals NaN).
    fn same_row(a: &FeatureRow, b: &FeatureRow) -> bool {
        let bits = |r: &FeatureRow| {
            [r.time, r.v, r.lambda, r.a_v, r.a_l, r.a, r.voltage].map(f64::to_bits)
        };
        bits(a) == bits(b) && a.s == b.s && a.phase == b.phase && a.trip == b.trip
    }

    /// True when two rows are equal as numbers (NaN equals NaN, −0 equals 0): the sign of v at
    /// rest is arbitrary when the direction is unknown.
    fn equal_row(a: &FeatureRow, b: &FeatureRow) -> bool {
        let nums = |r: &FeatureRow| [r.time, r.v, r.lambda, r.a_v, r.a_l, r.a, r.voltage];
        let same = nums(a)
            .iter()
            .zip(nums(b))
            .all(|(x, y)| *x == y || (x.is_nan() && y.is_nan()));
        same && a.s == b.s && a.phase == b.phase && a.trip == b.trip
    }

    #[test]
    fn fused_acceleration_beats_the_speed_path_on_an_s_curve() {
        let cfg = config();
        // The paper's weighting, fixed β not scaled with the load: 0.8 starting and braking,
        // 0.3 cruising; and its single fixed β = 0.7.
        let paper = |r: &FeatureRow, beta_t: f64, beta_c: f64| {
            let beta = if r.phase == Phase::Cruising {
                beta_c
            } else {
                beta_t
            };
            beta * r.a_v + (1.0 - beta) * r.a_l
        };
        let mut e: [Vec<f64>; 5] = Default::default();
        for seed in 1..=6 {
            let d = day(&LEGS, cfg.load_cell_platform_ratio, seed);
            for (r, a) in extract(&d.series, &cfg).rows.iter().zip(&d.a_true) {
                if r.s != 0 && r.a_l.is_finite() {
                    for (k, x) in [r.a_v, r.a_l, r.a, paper(r, 0.8, 0.3), paper(r, 0.7, 0.7)]
                        .into_iter()
                        .enumerate()
                    {
                        e[k].push(x - a);
                    }
                }
            }
        }
        let [rv, rl, rf, rp, r7] = e.map(|e| rms(e.into_iter()));
        // Measured (seeds 1-6, 8 trips each): speed path 0.108 m/s², load path 0.119, fused
        // 0.068, paper's phase β 0.099, paper's fixed β = 0.7 0.085.
        println!(
            "rms error of a (m/s²) over moving samples: speed path {rv:.4}, load path {rl:.4}, fused {rf:.4}, \
             paper's phase β (0.8/0.3) {rp:.4}, paper's fixed β 0.7 {r7:.4}"
        );
        assert!(rf < rv, "fused {rf} should beat the speed path {rv}");
        assert!(
            rf < rp && rf < r7,
            "the default β {rf} should beat the paper's {rp} and {r7}"
        );
    }

    #[test]
    fn lambda_is_the_door_close_reading_not_the_moving_reading() {
        let d = day(&[(8, 0.6), (2, 0.2)], 0.15, 7);
        let f = extract(&d.series, &config());
        let mut worst_raw: f64 = 0.0;
        for ((r, s), lam) in f.rows.iter().zip(&d.series.samples).zip(&d.lambda_true) {
            if r.trip.is_some() {
                // The mean of 4 door-closed readings: within 4 σ of 0.5 % / √4.
                assert!(
                    (r.lambda - lam).abs() < 0.01,
                    "λ {} at t {} should be {lam}",
                    r.lambda,
                    r.time
                );
                worst_raw = worst_raw.max((s.load / 100.0 - lam).abs());
            }
        }
        // The moving reading is off by the inertia: (λ + p)·a/g ≈ 0.75·0.8/9.81 ≈ 0.06.
        assert!(
            worst_raw > 0.04,
            "the raw moving reading should be biased, worst {worst_raw}"
        );
        assert_eq!(f.trips.len(), 2);
        assert!(
            (f.trips[0].load_ratio - 0.6).abs() < 0.01
                && (f.trips[1].load_ratio - 0.2).abs() < 0.01
        );
    }

    /// `n` legs between random floors of a 20-floor building with random loads.
    fn random_legs(n: usize, seed: u64) -> Vec<(u32, f64)> {
        let mut rng = Rng::new(seed);
        let mut floor = 1u32;
        (0..n)
            .map(|_| {
                let mut to = floor;
                while to == floor {
                    to = 1 + rng.below(20) as u32;
                }
                floor = to;
                (to, rng.uniform(0.0, 0.9))
            })
            .collect()
    }

    #[test]
    fn fit_load_cell_recovers_a_known_platform_ratio() {
        // Measured on 6 seeds of 40 trips: within −7 % to +3 % for p = 0.15, −4 % to +1 % for
        // 0.3 and 0.6 (an absolute error of about 0.005).
        for (p_true, seed) in [(0.15, 101), (0.3, 102), (0.6, 103)] {
            let d = day(&random_legs(40, seed), p_true, seed);
            let start = FeatureConfig {
                load_cell_platform_ratio: 0.4,
                ..config()
            };
            let fitted = fit_load_cell(&d.series, &start).expect("40 trips are enough");
            let p = fitted.load_cell_platform_ratio;
            println!(
                "load-cell platform ratio: true {p_true}, fitted {p:.4} ({:+.1} %)",
                100.0 * (p / p_true - 1.0)
            );
            assert!(
                (p / p_true - 1.0).abs() < 0.1,
                "fitted p {p} should be within 10 % of {p_true}"
            );
            assert_eq!(fitted.beta_cruise, start.beta_cruise);
        }
    }

    #[test]
    fn fit_load_cell_refuses_too_little_data() {
        let d = day(&[(8, 0.6), (2, 0.2)], 0.15, 3);
        let err = fit_load_cell(&d.series, &config()).expect_err("two trips are too few");
        assert!(
            matches!(err, Error::TooLittleMotion { trips: 2, .. }),
            "{err}"
        );
    }

    #[test]
    fn trips_are_segmented_with_direction_and_floors() {
        let d = day(&[(6, 0.3), (2, 0.5), (3, 0.0)], 0.15, 5);
        let f = extract(&d.series, &config());
        assert_eq!(f.rows.len(), d.series.len());
        let summary: Vec<(i8, f64, f64)> = f
            .trips
            .iter()
            .map(|t| (t.direction, t.from_floor, t.to_floor))
            .collect();
        assert_eq!(summary, vec![(1, 1.0, 6.0), (-1, 6.0, 2.0), (1, 2.0, 3.0)]);
        for (t, metres) in f.trips.iter().zip([15.0, 12.0, 3.0]) {
            assert!(
                (t.distance_m - metres).abs() < 0.05 * metres,
                "trip {} covered {} m, not {metres}",
                t.index,
                t.distance_m
            );
            assert!(t.peak_speed <= 1.75 + 0.02 && t.end_time > t.start_time);
        }
        assert!(
            f.trips[0].peak_speed > 1.7,
            "a 15 m trip reaches rated speed"
        );
        // Rows carry their trip; the rows of a trip are its moving samples.
        for t in &f.trips {
            let n = f.rows.iter().filter(|r| r.trip == Some(t.index)).count();
            assert_eq!(n as u32, t.samples);
        }
        assert!(f
            .rows
            .iter()
            .all(|r| (r.s == 0) == (r.phase == Phase::Standstill)));
        assert!(f.rows.iter().filter(|r| r.s == 0).all(|r| r.a == 0.0));
    }

    #[test]
    fn gaps_create_no_trip_and_no_spike() {
        let mut d = day(&[(6, 0.3), (2, 0.5)], 0.15, 9);
        let first_moving = d
            .series
            .samples
            .iter()
            .position(|s| s.speed > 0.05)
            .expect("the day moves");
        // A gap at rest before the first trip, and one in the middle of the second trip.
        for s in &mut d.series.samples[3..8] {
            *s = Sample::missing(s.time);
        }
        let second = d
            .series
            .samples
            .iter()
            .rposition(|s| s.speed > 1.0)
            .expect("the second trip cruises");
        for s in &mut d.series.samples[second - 2..second] {
            s.speed = f64::NAN;
        }
        let f = extract(&d.series, &config());
        assert!(first_moving > 8);
        assert_eq!(
            f.trips.len(),
            1,
            "only the first trip is complete: {:?}",
            f.trips
        );
        assert_eq!((f.trips[0].from_floor, f.trips[0].to_floor), (1.0, 6.0));
        assert!(f.rows[3..8]
            .iter()
            .all(|r| r.trip.is_none() && r.v.is_nan() && r.a.is_nan()));
        // After the gap the car is moving: no trip starts mid-motion, and no spike.
        let after = &f.rows[second..];
        let resumed = after.iter().take_while(|r| r.s != 0);
        assert!(
            resumed.clone().count() > 0
                && resumed
                    .clone()
                    .all(|r| r.trip.is_none() && r.lambda.is_nan())
        );
        for r in f.rows.iter().filter(|r| r.a_v.is_finite()) {
            assert!(r.a_v.abs() < 1.2, "a_v spike {} at {}", r.a_v, r.time);
        }
    }

    #[test]
    fn a_time_jump_in_a_trip_drops_it_without_a_spike() {
        let mut d = day(&[(6, 0.3), (2, 0.5)], 0.15, 13);
        let k = d
            .series
            .samples
            .iter()
            .position(|s| s.speed > 1.0)
            .expect("the first trip cruises");
        // Two files glued together: the clock jumps back a minute in the middle of the trip.
        for s in &mut d.series.samples[k..] {
            s.time -= 60.0;
        }
        let f = extract(&d.series, &config());
        assert_eq!(f.rows.len(), d.series.len());
        assert_eq!(
            f.trips.len(),
            1,
            "only the second trip is complete: {:?}",
            f.trips
        );
        assert_eq!((f.trips[0].from_floor, f.trips[0].to_floor), (6.0, 2.0));
        assert!(f
            .rows
            .iter()
            .filter(|r| r.a_v.is_finite())
            .all(|r| r.a_v.abs() < 1.2));
    }

    #[test]
    fn a_missing_direction_in_motion_keeps_the_sign_of_the_trip() {
        let mut d = day(&[(1 + 7, 0.3), (1, 0.3)], 0.15, 4);
        let f_ref = extract(&d.series, &config());
        for s in d.series.samples.iter_mut().filter(|s| s.speed > 1.0) {
            s.direction = if s.time as u64 % 2 == 0 {
                f64::NAN
            } else {
                0.0
            };
        }
        let f = extract(&d.series, &config());
        assert_eq!(f.trips, f_ref.trips);
        assert!(f.rows.iter().zip(&f_ref.rows).all(|(a, b)| same_row(a, b)));
    }

    #[test]
    fn a_direction_signal_a_sample_late_still_starts_the_trip() {
        let mut d = day(&[(5, 0.3), (2, 0.3)], 0.15, 8);
        let f_ref = extract(&d.series, &config());
        let starts: Vec<usize> = (1..d.series.len())
            .filter(|&k| d.series.samples[k].speed > 0.05 && d.series.samples[k - 1].speed <= 0.05)
            .collect();
        assert_eq!(starts.len(), 2);
        for k in starts {
            d.series.samples[k].direction = 0.0;
            d.series.samples[k - 1].direction = 0.0;
        }
        let f = extract(&d.series, &config());
        assert_eq!(f.trips, f_ref.trips);
        // The standstill row before such a start has no look-ahead for a_v (its successor's
        // sign is not known yet); its a is 0 all the same.
        for (a, b) in f.rows.iter().zip(&f_ref.rows) {
            let b = if b.s == 0 {
                FeatureRow { a_v: a.a_v, ..*b }
            } else {
                *b
            };
            assert!(equal_row(a, &b), "{a:?} != {b:?}");
        }
    }

    #[test]
    fn an_implausible_load_reading_is_missing() {
        let mut d = day(&[(6, 0.3)], 0.15, 2);
        let k = d
            .series
            .samples
            .iter()
            .position(|s| s.speed > 1.0)
            .expect("the trip cruises");
        d.series.samples[k].load = 400.0;
        d.series.samples[k + 1].load = 60.0;
        let f = extract(&d.series, &config());
        assert!(f.rows[k].a_l.is_nan() && f.rows[k + 1].a_l.is_nan());
        assert_eq!(f.rows[k].a, f.rows[k].a_v);
        assert_eq!(f.trips.len(), 1);
    }

    #[test]
    fn split_and_resume_gives_exactly_the_rows_of_one_run() {
        let d = day(&LEGS, 0.15, 21);
        let whole = extract(&d.series, &config());
        let mid_trip = d
            .series
            .samples
            .iter()
            .position(|s| s.speed > 1.0)
            .expect("a trip cruises");
        for split in [
            1,
            2,
            mid_trip,
            mid_trip + 1,
            d.series.len() / 2,
            d.series.len() - 1,
        ] {
            let (mut rows, mut trips) = (Vec::new(), Vec::new());
            let mut tracker = FeatureTracker::new(config());
            for s in &d.series.samples[..split] {
                rows.extend(tracker.push(s));
                trips.extend(tracker.take_trip());
            }
            let state = serde_json::to_string(&tracker).expect("the state serialises");
            assert!(
                state.len() < 2000,
                "the state should be small, not {} bytes",
                state.len()
            );
            let mut tracker: FeatureTracker =
                serde_json::from_str(&state).expect("the state reads back");
            for s in &d.series.samples[split..] {
                rows.extend(tracker.push(s));
                trips.extend(tracker.take_trip());
            }
            rows.extend(tracker.finish());
            assert_eq!(rows.len(), whole.rows.len());
            for (a, b) in rows.iter().zip(&whole.rows) {
                assert!(same_row(a, b), "split at {split}: {a:?} != {b:?}");
            }
            assert_eq!(trips, whole.trips, "split at {split}");
        }
    }

    #[test]
    fn state_reads_numbers_and_nulls_too() {
        let mut tracker = FeatureTracker::new(config());
        tracker.push(&Sample::missing(0.0));
        let json = serde_json::to_string(&tracker)
            .expect("serialises")
            .replace("\"NaN\"", "null");
        let back: FeatureTracker = serde_json::from_str(&json).expect("null reads as NaN");
        assert!(back.cur.expect("one sample held").v.is_nan());
        assert!(serde_json::from_str::<FeatureTracker>(&json.replace("null", "\"fast\"")).is_err());
    }

    #[test]
    fn settings_out_of_range_are_refused() {
        assert!(config().validate().is_ok());
        let bad = FeatureConfig {
            beta_cruise: 1.5,
            ..config()
        };
        assert!(matches!(
            bad.validate(),
            Err(Error::InvalidConfig {
                field: "beta_cruise",
                ..
            })
        ));
    }
}
