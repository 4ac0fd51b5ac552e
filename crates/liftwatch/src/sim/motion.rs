//! Simulator: jerk-limited S-curve travel between two landings.
//!
//! ```text
//! seven segments: +j, 0, −j, cruise, −j, 0, +j   (jerk j, acceleration ≤ a_max, speed ≤ v_max)
//! accelerating from 0 to v_p takes T(v_p) = v_p/a_max + a_max/j   if v_p·j ≥ a_max²
//!                                        = 2·sqrt(v_p/j)          otherwise (a never reaches a_max)
//! and covers v_p·T(v_p)/2 (the profile is point-symmetric), so a trip of length D without cruise
//! needs v_p·T(v_p) = D; with cruise at v_max it lasts D/v_max + T(v_max).
//! ```
//!
//! The profile is exact (piecewise cubic in time), so the simulator can evaluate it at any
//! sensor instant: that is finer than any fixed internal rate. Short trips solve for the peak
//! speed v_p < v_max by bisection; they never reach rated speed, as in a real building where a
//! one-floor hop (3-4 m) is shorter than the 5 m or so needed to reach 1.75 m/s.

/// A jerk-limited travel profile over a distance, in the travel direction (distance ≥ 0).
#[derive(Clone, Debug, PartialEq)]
pub struct SCurve {
    /// Duration of each of the seven segments (s).
    durations: [f64; 7],
    /// Jerk in each segment (m/s³).
    jerks: [f64; 7],
    /// Distance, speed and acceleration at the start of each segment.
    starts: [(f64, f64, f64); 7],
    /// Peak speed reached (m/s).
    peak_speed: f64,
    /// Distance travelled (m).
    distance: f64,
}

/// Distance, speed and acceleration along the travel direction at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Kinematics {
    /// Distance from the start (m).
    pub distance: f64,
    /// Speed along the travel direction (m/s, ≥ 0).
    pub speed: f64,
    /// Acceleration along the travel direction (m/s²).
    pub accel: f64,
}

impl SCurve {
    /// The profile covering `distance` (m) with limits `v_max` (m/s), `a_max` (m/s²), `jerk` (m/s³).
    ///
    /// Non-positive or non-finite inputs give an empty profile of zero duration.
    pub fn new(distance: f64, v_max: f64, a_max: f64, jerk: f64) -> Self {
        let empty = SCurve {
            durations: [0.0; 7],
            jerks: [0.0; 7],
            starts: [(0.0, 0.0, 0.0); 7],
            peak_speed: 0.0,
            distance: 0.0,
        };
        if !(distance > 0.0 && v_max > 0.0 && a_max > 0.0 && jerk > 0.0 && distance.is_finite()) {
            return empty;
        }
        let t_acc = |v: f64| {
            if v * jerk >= a_max * a_max {
                v / a_max + a_max / jerk
            } else {
                2.0 * (v / jerk).sqrt()
            }
        };
        let (peak, cruise) = if v_max * t_acc(v_max) <= distance {
            (v_max, (distance - v_max * t_acc(v_max)) / v_max)
        } else {
            // v·T(v) grows monotonically with v: bisection converges to the peak speed.
            let (mut lo, mut hi) = (0.0, v_max);
            for _ in 0..80 {
                let mid = 0.5 * (lo + hi);
                if mid * t_acc(mid) < distance {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            (0.5 * (lo + hi), 0.0)
        };
        let (tj, tc) = if peak * jerk >= a_max * a_max {
            (a_max / jerk, peak / a_max - a_max / jerk)
        } else {
            ((peak / jerk).sqrt(), 0.0)
        };
        let durations = [tj, tc, tj, cruise, tj, tc, tj];
        let jerks = [jerk, 0.0, -jerk, 0.0, -jerk, 0.0, jerk];
        let mut starts = [(0.0, 0.0, 0.0); 7];
        let mut state = (0.0, 0.0, 0.0);
        for i in 0..7 {
            starts[i] = state;
            state = advance(state, jerks[i], durations[i]);
        }
        SCurve {
            durations,
            jerks,
            starts,
            peak_speed: peak,
            distance,
        }
    }

    /// Total duration (s).
    pub fn duration(&self) -> f64 {
        self.durations.iter().sum()
    }

    /// Peak speed reached (m/s).
    pub fn peak_speed(&self) -> f64 {
        self.peak_speed
    }

    /// Distance covered (m).
    pub fn distance(&self) -> f64 {
        self.distance
    }

    /// The state `t` seconds after the start; before the start at rest at 0, after the end at
    /// rest at the full distance (exactly, so that the car stops level with the landing).
    pub fn at(&self, t: f64) -> Kinematics {
        if t <= 0.0 || self.distance <= 0.0 {
            return Kinematics {
                distance: 0.0,
                speed: 0.0,
                accel: 0.0,
            };
        }
        let mut rest = t;
        for i in 0..7 {
            if rest < self.durations[i] {
                let (p, v, a) = advance(self.starts[i], self.jerks[i], rest);
                return Kinematics {
                    distance: p.min(self.distance),
                    speed: v.max(0.0),
                    accel: a,
                };
            }
            rest -= self.durations[i];
        }
        Kinematics {
            distance: self.distance,
            speed: 0.0,
            accel: 0.0,
        }
    }
}

/// Integrates constant jerk `j` over `dt` from (distance, speed, acceleration).
fn advance((p, v, a): (f64, f64, f64), j: f64, dt: f64) -> (f64, f64, f64) {
    (
        p + v * dt + a * dt * dt / 2.0 + j * dt * dt * dt / 6.0,
        v + a * dt + j * dt * dt / 2.0,
        a + j * dt,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn limits_hold(c: &SCurve, v_max: f64, a_max: f64, jerk: f64) {
        let n = 4000;
        let dt = c.duration() / f64::from(n);
        let mut prev = c.at(0.0);
        for k in 1..=n {
            let s = c.at(f64::from(k) * dt);
            assert!(s.speed <= v_max + 1e-9, "speed {} above {v_max}", s.speed);
            assert!(
                s.accel.abs() <= a_max + 1e-9,
                "accel {} above {a_max}",
                s.accel
            );
            assert!((s.accel - prev.accel).abs() / dt <= jerk * (1.0 + 1e-6) + 1e-9);
            assert!(
                s.distance + 1e-12 >= prev.distance,
                "the car never backs up"
            );
            prev = s;
        }
    }

    #[test]
    fn long_trip_cruises_at_rated_speed_within_limits() {
        let c = SCurve::new(60.0, 1.75, 0.8, 1.0);
        assert!((c.peak_speed() - 1.75).abs() < 1e-12);
        limits_hold(&c, 1.75, 0.8, 1.0);
        let end = c.at(c.duration() - 1e-9);
        assert!((end.distance - 60.0).abs() < 1e-6);
        assert!(end.speed < 1e-6);
        // Cruise: D/v + T(v) with T = v/a + a/j.
        assert!((c.duration() - (60.0 / 1.75 + 1.75 / 0.8 + 0.8)).abs() < 1e-9);
    }

    #[test]
    fn short_trip_never_reaches_rated_speed_and_stops_at_the_landing() {
        for d in [0.5, 3.0, 4.2] {
            let c = SCurve::new(d, 2.0, 0.9, 1.2);
            assert!(
                c.peak_speed() < 2.0 * 0.99,
                "{d} m peaked at {}",
                c.peak_speed()
            );
            limits_hold(&c, 2.0, 0.9, 1.2);
            let end = c.at(c.duration() + 1.0);
            assert_eq!(end.distance, d);
            let near = c.at(c.duration() - 1e-9);
            assert!((near.distance - d).abs() < 1e-6, "{d}: {}", near.distance);
        }
    }

    #[test]
    fn degenerate_distance_gives_an_empty_profile() {
        assert_eq!(SCurve::new(0.0, 1.0, 1.0, 1.0).duration(), 0.0);
        assert_eq!(SCurve::new(f64::NAN, 1.0, 1.0, 1.0).at(1.0).distance, 0.0);
    }
}
