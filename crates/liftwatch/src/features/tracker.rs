//! Stage 3, the streaming step: [`FeatureTracker::push`] takes one aligned sample and returns
//! the row of the sample [`LAG`](super::LAG) steps back (paper, Sec. 4.1).
//!
//! ```text
//! sample k   -> Pre_k (v, s, load, door)         direction memory, L_ref running mean
//! row k−1    =  f(Pre_{k−2}, Pre_{k−1}, Pre_k)   a_v, λ, a_L, phase, a, trip
//! L_ref      = mean of ≤ 30 door-closed readings at |v| ≤ 0.2·v_move since the door opened
//! λ          = L_ref/100 held through the trip, clamped to [0, λ_max]
//! ```
//!
//! The tracker's fields are shared with `trips.rs`, the segmenter that advances with each row.
//! The state serialises field by field, floats as exact strings ([`super::exact`]); a
//! monitor saves it between two files.

use serde::{Deserialize, Serialize};

use super::accel;
use super::pre::{follows, Door, Pre};
use super::trips::{Trip, TripAcc};
use super::{FeatureConfig, FeatureRow, LAMBDA_MAX, LOAD_PLAUSIBLE_PCT};
use crate::exact;
use crate::sample::Sample;

/// L_ref is a running mean of at most this many door-closed standstill readings.
const L_REF_WINDOW: f64 = 30.0;

/// A direction signal seen this recently (s) still tells the sign of a start without one.
const DIR_MEMORY_S: f64 = 5.0;

/// With the door signal missing, a standstill load reading this far (percent of rated load)
/// from the running mean starts a new mean: riders boarded or left. One rider of 75 kg is
/// 4.7 % of the largest car in scope (1600 kg) and 12 % of the smallest (630 kg), while a load
/// cell at rest reads within a few tenths of a percent; a change smaller than this mixes into
/// the mean by less than this.
const LOAD_STEP_PCT: f64 = 2.0;

/// Streaming feature extraction: one aligned sample in, the row of the previous sample out.
///
/// Its state is a few samples and a trip in progress, (de)serialisable so that a monitor can
/// stop after one file and resume on the next with exactly the rows of one run. The floats of
/// the state serialise as exact decimal strings (NaN included).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FeatureTracker {
    pub(super) cfg: FeatureConfig,
    /// The sample before the held one.
    pub(super) prev: Option<Pre>,
    /// The held sample, whose row waits for its successor.
    pub(super) cur: Option<Pre>,
    /// Sign of the last moving sample, 0 after a standstill or a missing speed.
    pub(super) motion_sign: i8,
    /// Last nonzero direction signal and when it was seen.
    pub(super) last_dir: i8,
    #[serde(with = "exact")]
    pub(super) last_dir_time: f64,
    /// Floor indicator at the last standstill.
    #[serde(with = "exact")]
    pub(super) rest_floor: f64,
    /// Running mean of door-closed standstill load readings (percent), NaN when none.
    #[serde(with = "exact")]
    pub(super) ref_mean: f64,
    /// Number of readings in the mean, capped at the window.
    #[serde(with = "exact")]
    pub(super) ref_n: f64,
    /// The last load reading at standstill whatever the door, and its time: the reference
    /// when no door-closed reading came between the door closing and the start.
    #[serde(with = "exact")]
    pub(super) rest_load: f64,
    #[serde(with = "exact")]
    pub(super) rest_load_time: f64,
    pub(super) trip: Option<TripAcc>,
    pub(super) next_trip: u32,
    /// The trip ended by the last row returned; not part of the saved state (take it first).
    #[serde(skip)]
    pub(super) ended: Option<Trip>,
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
        let mut row = FeatureRow::MISSING;
        self.push_into(s, &mut row).then_some(row)
    }

    /// [`FeatureTracker::push`] into `out`: true when a row was written there. The row is
    /// built in its place, not moved out of an `Option` (the monitor's per-sample path: a
    /// copy of a row just stored field by field stalls on every sample).
    pub fn push_into(&mut self, s: &Sample, out: &mut FeatureRow) -> bool {
        let next = self.preprocess(s);
        // A start whose direction signal comes a sample late: the successor's sign tells it.
        if let Some(c) = self.cur.as_mut() {
            if c.v.is_nan() && c.speed.is_finite() && next.s != 0 && follows(c, &next) {
                c.v = f64::from(next.s) * c.speed;
                c.s = next.s;
            }
        }
        let held = self.cur;
        if let Some(c) = held {
            // `next` by reference: it was just stored field by field, and a copy of it (as a
            // by-value argument) read it back in 16-byte pieces, a store-forwarding stall.
            let prev = self.prev;
            self.row_into(prev.as_ref(), &c, Some(&next), out);
        }
        self.prev = self.cur;
        self.cur = Some(next);
        held.is_some()
    }

    /// End of data for good: returns the rows still held (computed without look-ahead).
    /// A trip still running is dropped; the tracker starts afresh afterwards, trip indices
    /// continuing.
    pub fn finish(&mut self) -> Vec<FeatureRow> {
        let rows = self
            .cur
            .map(|c| {
                let mut row = FeatureRow::MISSING;
                let prev = self.prev;
                self.row_into(prev.as_ref(), &c, None, &mut row);
                row
            })
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
        let sign = self.sign(dir_signal, moving, floor, x.time);
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
        self.update_load_reference(speed, load, door, x.time);
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

    /// The sign of motion of a sample, in the order of [`FeatureTracker::preprocess`]: the
    /// direction signal, the previous moving sample, the direction memory, the floor change;
    /// 0 when none tells it while moving.
    fn sign(&self, dir_signal: i8, moving: bool, floor: f64, time: f64) -> i8 {
        if dir_signal != 0 {
            dir_signal
        } else if !moving {
            if self.motion_sign != 0 {
                self.motion_sign
            } else {
                1
            }
        } else if self.motion_sign != 0 {
            self.motion_sign
        } else if self.last_dir != 0 && (time - self.last_dir_time).abs() <= DIR_MEMORY_S {
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
        }
    }

    /// Updates the load reference: the last standstill reading and the running mean of
    /// door-closed standstill readings, restarted whenever the door is open. With the door
    /// signal missing (a dropout, or a log without it) nothing says when riders changed, so
    /// the mean restarts at each new standstill (the sample before this one, still held in
    /// `cur`, was not at rest) and at each step of the reading beyond [`LOAD_STEP_PCT`]:
    /// without that, one mean ran across several stops and held a trip's λ at a quarter of
    /// its load.
    fn update_load_reference(&mut self, speed: f64, load: f64, door: Door, time: f64) {
        // The reference: readings at true standstill (well below the motion threshold, so not
        // the first instant of a start) with the door not known to be open; an open door
        // means the load is changing and the mean restarts.
        let rest_speed = 0.2 * self.cfg.moving_threshold_mps;
        let still = speed.is_finite() && speed <= rest_speed && load.is_finite();
        let new_stop = !self.cur.is_some_and(|c| c.speed <= rest_speed);
        if still {
            self.rest_load = load;
            self.rest_load_time = time;
        }
        let riders_changed = door == Door::Unknown
            && still
            && (new_stop || (load - self.ref_mean).abs() > LOAD_STEP_PCT);
        if door == Door::Open || riders_changed {
            self.ref_mean = f64::NAN;
            self.ref_n = 0.0;
        }
        if door != Door::Open && still {
            self.ref_n = (self.ref_n + 1.0).min(L_REF_WINDOW);
            let m = if self.ref_mean.is_finite() {
                self.ref_mean
            } else {
                load
            };
            self.ref_mean = m + (load - m) / self.ref_n;
        }
    }

    /// The row of the held sample `c` from its neighbours; advances the trip segmentation.
    fn row_into(&mut self, p: Option<&Pre>, c: &Pre, n: Option<&Pre>, out: &mut FeatureRow) {
        let p = p.filter(|p| follows(p, c) && p.v.is_finite());
        let n = n.filter(|n| follows(c, n));
        let a_v = accel::speed_path(p, c, n.filter(|n| n.v.is_finite()));
        let trip = self.advance_trip(p, c, n);
        let held_ref = trip.as_ref().map_or(f64::NAN, |t| t.l_ref);
        let lambda = self.lambda(c, held_ref);
        let a_l = accel::load_path(&self.cfg, c, held_ref, lambda);
        let phase = accel::phase(c, a_v);
        let a = accel::fuse(&self.cfg, c, phase, lambda, a_v, a_l);
        let (d2v, d2u) = match (p, n) {
            (Some(p), Some(n)) => (
                p.v - 2.0 * c.v + n.v,
                p.voltage - 2.0 * c.voltage + n.voltage,
            ),
            _ => (f64::NAN, f64::NAN),
        };
        // Field by field into its place (the pattern names every field, so a new one cannot
        // be left out): a row built aside and copied in was read back in 16-byte pieces just
        // after its 8-byte stores, a store-forwarding stall on every sample (a third of this
        // function's time in `perf`).
        let FeatureRow {
            time: o_time,
            v: o_v,
            s: o_s,
            lambda: o_lambda,
            a_v: o_a_v,
            a_l: o_a_l,
            a: o_a,
            d2v: o_d2v,
            d2u: o_d2u,
            voltage: o_voltage,
            floor: o_floor,
            phase: o_phase,
            trip: o_trip,
        } = out;
        *o_time = c.time;
        *o_v = c.v;
        *o_s = c.s;
        *o_lambda = lambda;
        *o_a_v = a_v;
        *o_a_l = a_l;
        *o_a = a;
        *o_d2v = d2v;
        *o_d2u = d2u;
        *o_voltage = c.voltage;
        *o_floor = c.floor;
        *o_phase = phase;
        *o_trip = trip.map(|t| t.index);
    }

    /// λ of the held sample `c`: while moving the trip's L_ref (`held_ref`), at rest the
    /// running door-closed mean, failing that the reading itself; clamped to [0, λ_max].
    fn lambda(&self, c: &Pre, held_ref: f64) -> f64 {
        let lambda = if c.s != 0 {
            held_ref / 100.0
        } else if self.ref_n > 0.0 {
            self.ref_mean / 100.0
        } else {
            c.load / 100.0
        };
        if lambda.is_finite() {
            lambda.clamp(0.0, LAMBDA_MAX)
        } else {
            f64::NAN
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::extract;
    use super::super::testkit::{config, day, same_row, LEGS};
    use super::*;

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
    fn without_a_door_signal_each_trip_carries_its_own_load() {
        // Riders change at every stop; the door channel is missing for the whole day, as in
        // a dropout or a log without it. Each trip's λ must still be the load it carried, not
        // a mean run across the stops before it (the empty second trip read 0.28 before).
        let legs = [
            (8, 0.4),
            (3, 0.0),
            (12, 0.25),
            (2, 0.6),
            (9, 0.05),
            (1, 0.3),
        ];
        let mut d = day(&legs, 0.15, 5);
        for s in &mut d.series.samples {
            s.door = f64::NAN;
        }
        let f = extract(&d.series, &config());
        assert_eq!(f.trips.len(), legs.len());
        for (t, (_, lambda)) in f.trips.iter().zip(legs) {
            // A mean of a few readings of 0.5 % noise: within 1 % of rated load.
            assert!(
                (t.load_ratio - lambda).abs() < 0.01,
                "trip {} carried {lambda}, read {}",
                t.index,
                t.load_ratio
            );
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
}
