//! Stage 3, the one trip segmenter (paper, Sec. 4.1).
//!
//! ```text
//! start     c moving (s ≠ 0) right after a known standstill p;  L_ref, from_floor fixed
//! advance   distance += ½·(|v_p| + |v_c|)·Δt,  displacement += ½·(v_p + v_c)·Δt,  peak = max |v|
//! end       n a known standstill: the trip is complete, direction = sign(displacement)
//! drop      n missing, not contiguous (gap, time jump) or the end of data: no trip reported
//! ```
//!
//! Every consumer (features, the load-cell fit, the monitor, the report) takes its trips from
//! here. The segmenter advances with each row of [`FeatureTracker`] and keeps its state in the
//! tracker's fields, so that it is saved and resumed with it.

use serde::{Deserialize, Serialize};

use super::pre::Pre;
use super::{FeatureTracker, LAMBDA_MAX, MAX_STEP_S};
use crate::exact;

/// One trip: from the first moving sample after a standstill to the last before the next.
///
/// A trip cut by a gap (missing speed, a time jump, the end of the data) is not reported; its
/// rows keep the index, so reported indices can skip numbers.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
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

/// A trip in progress.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub(super) struct TripAcc {
    /// Index of the trip.
    pub(super) index: u32,
    #[serde(with = "exact")]
    start_time: f64,
    /// L_ref held from the standstill before the start (percent), NaN when unknown.
    #[serde(with = "exact")]
    pub(super) l_ref: f64,
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

impl TripAcc {
    /// The complete trip, its last moving sample `c` followed by the standstill `n`: the
    /// trapezoid to `n` closes distance and displacement.
    fn end(&self, c: &Pre, n: &Pre) -> Trip {
        let speed = c.v.abs();
        let dt = n.time - c.time;
        let distance_m = self.distance_m + 0.5 * speed * dt;
        let displacement_m = self.displacement_m + 0.5 * c.v * dt;
        Trip {
            index: self.index,
            start_time: self.start_time,
            end_time: c.time,
            direction: if displacement_m >= 0.0 { 1 } else { -1 },
            from_floor: self.from_floor,
            to_floor: if n.floor.is_finite() {
                n.floor
            } else {
                self.last_floor
            },
            load_ratio: if self.l_ref.is_finite() {
                (self.l_ref / 100.0).clamp(0.0, LAMBDA_MAX)
            } else {
                f64::NAN
            },
            peak_speed: self.peak_speed,
            distance_m,
            samples: self.samples,
        }
    }
}

impl FeatureTracker {
    /// Trip segmentation at the held sample `c`: starts a trip when `c` moves right after a
    /// known standstill `p`, ends it when `n` is a known standstill, drops it at a gap.
    /// Returns the trip `c` belongs to (its state after `c`).
    pub(super) fn advance_trip(
        &mut self,
        p: Option<&Pre>,
        c: &Pre,
        n: Option<&Pre>,
    ) -> Option<TripAcc> {
        if c.s == 0 {
            // Only reachable after a gap dropped the look-ahead; nothing to continue.
            self.trip = None;
            return None;
        }
        let speed = c.v.abs();
        if self.trip.is_none() {
            let p = p.filter(|p| p.at_rest())?;
            self.trip = Some(TripAcc {
                index: self.next_trip,
                start_time: c.time,
                l_ref: self.start_reference(c.time),
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
                self.ended = Some(t.end(c, n));
                self.trip = None;
            }
            Some(n) if n.v.is_finite() => {}
            // The next sample is missing or the data ends: the trip cannot be completed.
            _ => self.trip = None,
        }
        Some(snapshot)
    }

    /// L_ref (percent) of a trip starting at `time`: the door-closed standstill mean, else the
    /// last standstill reading if within [`MAX_STEP_S`], else NaN.
    fn start_reference(&self, time: f64) -> f64 {
        // The door often closes less than a second before the start, so at 1 Hz there may
        // be no door-closed standstill reading: then the last standstill reading (door
        // still reading open or closing, riders already aboard) stands in.
        if self.ref_n > 0.0 {
            self.ref_mean
        } else if (0.0..=MAX_STEP_S).contains(&(time - self.rest_load_time)) {
            self.rest_load
        } else {
            f64::NAN
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::testkit::{config, day, equal_row, same_row};
    use super::super::{extract, FeatureRow, Phase};
    use crate::sample::Sample;

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
}
