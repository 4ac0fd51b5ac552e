//! Stage 3: physical features from aligned samples (paper, Sec. 4.1).
//!
//! ```text
//! v   = direction · speed                     signed velocity (m/s, + up)
//! s   = sign(v) if |v| > v_move else 0        direction of motion
//! λ   = L_ref / 100                           static load ratio, L_ref held from door close
//! a_v = (v[t+1] − v[t−1]) / (t[t+1] − t[t−1]) speed path, central difference (one sample look-ahead)
//! a_L = g·(L − L_ref)/100 / (k·λ + p)         load-cell inertial path, door closed, k and p fitted on history
//! a   = β·a_v + (1 − β)·a_L                   β by phase of travel; a = 0 at rest
//! ```
//!
//! Why a_L: the load-weighing cell sits under the platform and reads
//! `100·(m_load·(g + a) + m_platform·a)/(M_r·g)` percent, so with the door closed (load constant)
//! `L − L_ref = 100·a·(m_load + m_platform)/(M_r·g)`, i.e. the paper's `a_L = k_L·(L − L_ref)` with
//! `k_L = g/(100·(λ + p))` and `p = m_platform/M_r`. Not every cell is built that way: a cell that
//! weighs the ropes' tension at the hitch, or a controller that reports a filtered or
//! compensated load, may feel the inertia of a fixed mass only, the paper's constant `k_L`. The
//! law therefore carries a load gain k, `k·λ + p` (1 under the platform, 0 for the paper's
//! constant-k_L cell), and [`fit_load_cell`] identifies k and p on history when the loads of the
//! training vary enough to tell them apart, p alone with k = 1 otherwise.
//!
//! λ is the reading at standstill with the door closed (the mean of those readings since the
//! door last opened, which averages the cell's noise), held through the trip: while moving the
//! cell also feels inertia, and the raw moving reading biases the identified mass. The door
//! often closes less than a second before the start; when no door-closed standstill sample
//! falls in between, the last standstill reading (door still reported open) stands in.
//!
//! The extraction is a streaming step, [`FeatureTracker::push`], that emits the row of the sample
//! [`LAG`] steps back once its successor is known; [`rows`] is a loop over it and [`extract`]
//! collects that, so a batch run, the fit (which keeps only some of the rows) and a monitor
//! that saves the tracker between two files give identical rows.
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
//!
//! The files: `tracker.rs` is the streaming step [`FeatureTracker`] and `pre.rs` what it keeps
//! of a sample on arrival; `accel.rs` the two acceleration paths, the phase and the fusion;
//! `trips.rs` the one trip segmenter and [`Trip`]; `load_cell.rs` the fit of p,
//! [`fit_load_cell`]; `exact.rs` the exact serde of the tracker's floats.

mod accel;
mod load_cell;
mod pre;
#[cfg(test)]
mod testkit;
mod tracker;
mod trips;

use serde::{Deserialize, Serialize};

use crate::elevator::Elevator;
use crate::error::{Error, Result};
use crate::sample::{AlignedSeries, Sample};

pub use load_cell::fit_load_cell;
pub use tracker::FeatureTracker;
pub use trips::Trip;

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
    /// k of the load-cell path: how much of the load's own inertia the cell feels (1 for a
    /// cell under the platform, 0 for the paper's constant-k_L cell); see
    /// [`FeatureConfig::inertial_mass_ratio`]. Models before it existed mean 1.
    #[serde(default = "unit_load_gain")]
    pub load_cell_load_gain: f64,
    /// β while starting or braking (speed path weight), at the reference load
    /// [`BETA_REF_LAMBDA`]; [`FeatureConfig::beta`] scales it with the load.
    pub beta_transient: f64,
    /// β while cruising or at rest, at the reference load, scaled likewise.
    pub beta_cruise: f64,
}

/// The load gain of a cell under the platform, and of models written before k existed.
fn unit_load_gain() -> f64 {
    1.0
}

impl FeatureConfig {
    /// k·λ + p: the mass, as a fraction of M_r, whose inertia the load cell feels with a load
    /// ratio λ in the car; the one place of the cell's inertial law.
    pub fn inertial_mass_ratio(&self, lambda: f64) -> f64 {
        self.load_cell_load_gain * lambda + self.load_cell_platform_ratio
    }

    /// Defaults for an elevator: moving above 0.05 m/s, p = 0.15 (a platform of 15 % of the
    /// rated load until [`fit_load_cell`] identifies it), β 0.3 while accelerating or
    /// decelerating and 0.95 while cruising (see the module's deviation note).
    pub fn for_elevator(e: &Elevator) -> Self {
        FeatureConfig {
            rated_load_kg: e.rated_load_kg,
            moving_threshold_mps: 0.05,
            load_cell_platform_ratio: 0.15,
            load_cell_load_gain: 1.0,
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
        check("load_cell_load_gain", self.load_cell_load_gain, 0.0, 2.0)?;
        check("beta_transient", self.beta_transient, 0.0, 1.0)?;
        check("beta_cruise", self.beta_cruise, 0.0, 1.0)
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
    /// Δ²v: the second difference of v over the sample's neighbours (m/s), NaN without both:
    /// how far linear interpolation between ≈1 Hz readings of their own clocks can err here
    /// (|Δ²v|/8), the weight of the sample in the fit and the evidence
    /// ([`crate::model::train::interpolation_weight_of`]).
    pub d2v: f64,
    /// Δ²U: the second difference of the measured voltage over the same neighbours (V), NaN
    /// without both: the voltage reading's own interpolation error (|Δ²U|/8), largest where
    /// the drive's force changes (the brake lift, the jerk phases) and so with the load.
    pub d2u: f64,
    /// U: measured motor voltage (V).
    pub voltage: f64,
    /// Floor indicator (1-based), NaN when missing: the car's position for the rope imbalance.
    pub floor: f64,
    /// Phase of travel.
    pub phase: Phase,
    /// Index of the trip this sample belongs to, if moving.
    pub trip: Option<u32>,
}

impl FeatureRow {
    /// A row of nothing at time NaN: the place a tracker writes its next row into.
    pub const MISSING: FeatureRow = FeatureRow {
        time: f64::NAN,
        v: f64::NAN,
        s: 0,
        lambda: f64::NAN,
        a_v: f64::NAN,
        a_l: f64::NAN,
        a: f64::NAN,
        d2v: f64::NAN,
        d2u: f64::NAN,
        voltage: f64::NAN,
        floor: f64::NAN,
        phase: Phase::Standstill,
        trip: None,
    };
}

/// The features of a whole series.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Features {
    /// One row per input sample, in the same order.
    pub rows: Vec<FeatureRow>,
    /// The complete trips, in order.
    pub trips: Vec<Trip>,
}

/// Features of a whole series: [`rows`] collected.
pub fn extract(series: &AlignedSeries, cfg: &FeatureConfig) -> Features {
    let mut out = Features {
        rows: Vec::with_capacity(series.len()),
        trips: Vec::new(),
    };
    for (row, trip) in rows(series.samples.iter().copied(), cfg) {
        out.rows.push(row);
        out.trips.extend(trip);
    }
    out
}

/// The features of aligned `samples` one row at a time, each with the trip it ended (if any):
/// a loop over [`FeatureTracker`], nothing else. For callers that keep less than every row
/// (the fit keeps the moving ones, [`crate::model::train::TrainingRows`]) or read the samples
/// in passes ([`crate::sample::History`]).
pub fn rows<I: Iterator<Item = Sample>>(samples: I, cfg: &FeatureConfig) -> Rows<I> {
    Rows {
        samples,
        tracker: FeatureTracker::new(cfg.clone()),
        held: None,
    }
}

/// The iterator of [`rows`].
pub struct Rows<I> {
    /// The samples not yet pushed.
    samples: I,
    /// The streaming step the samples go through.
    tracker: FeatureTracker,
    /// The rows the tracker held at the end of the data, once it was told so.
    held: Option<std::vec::IntoIter<FeatureRow>>,
}

impl<I: Iterator<Item = Sample>> Iterator for Rows<I> {
    type Item = (FeatureRow, Option<Trip>);

    fn next(&mut self) -> Option<Self::Item> {
        for s in self.samples.by_ref() {
            if let Some(row) = self.tracker.push(&s) {
                return Some((row, self.tracker.take_trip()));
            }
        }
        let held = match &mut self.held {
            Some(held) => held,
            None => self.held.insert(self.tracker.finish().into_iter()),
        };
        let row = held.next()?;
        Some((row, self.tracker.take_trip()))
    }

    /// At most a row per sample: the samples to come, and the one the tracker holds.
    fn size_hint(&self) -> (usize, Option<usize>) {
        let held = self.held.as_ref().map_or(1, ExactSizeIterator::len);
        let samples = self.samples.size_hint().1;
        (0, samples.and_then(|n| n.checked_add(held)))
    }
}

#[cfg(test)]
mod tests {
    use super::testkit::config;
    use super::*;

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
