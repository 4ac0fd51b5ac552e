//! Simulator: passenger traffic by time of day (office building).
//!
//! ```text
//! calls/h(h) = k·(2 + 14·day(h) + 45·N(h; 8.5, 0.4) + 30·N(h; 12.5, 0.45) + 40·N(h; 17.5, 0.4))
//! day(h)     = logistic((h − 7)/0.3)·logistic((19.5 − h)/0.5)      working-hours plateau
//! N(h; μ, σ) = exp(−(h − μ)²/(2σ²))                                 up-peak, lunch, down-peak
//! weekend    = ×0.25
//! group size = 1 + Poisson(max(0, 0.12·M_r/75 − 1)·(1 + peak(h)))   passengers of N(75, 12) kg
//! ```
//!
//! Calls are a non-homogeneous Poisson process (thinning). A call is a group waiting at one
//! landing for one direction: from the lobby upwards (dominant in the up-peak), from an upper
//! floor to the lobby (dominant in the down-peak), both at lunch, or between upper floors.
//! Group sizes are set so that, with the empty repositioning trips of a single car, the mean
//! load over moving time lands inside the ISO 25745-2 range of average car loads (4.5-11 % of
//! rated); 4 % of calls bring goods (a trolley of 100 kg to half the rated load) so that the
//! load varies enough for identification, as it does in a real building.

use crate::rng::Rng;
use crate::sample::{DAY_S, HOUR_S};

/// Mean passenger mass (kg), ISO 25745-2 and EN 81-20 use 75 kg.
pub const PASSENGER_KG: f64 = 75.0;

/// A group of passengers waiting at a landing.
#[derive(Clone, Debug, PartialEq)]
pub struct Call {
    /// Arrival time (s).
    pub time: f64,
    /// Landing index (0 = lobby).
    pub origin: usize,
    /// Each passenger (or trolley): destination landing index and mass (kg).
    pub riders: Vec<(usize, f64)>,
}

impl Call {
    /// +1 when the group travels up, −1 down.
    pub fn direction(&self) -> i8 {
        match self.riders.first() {
            Some(&(d, _)) if d < self.origin => -1,
            _ => 1,
        }
    }
}

/// Generator of calls in time order.
#[derive(Clone, Debug)]
pub struct Traffic {
    rng: Rng,
    floors: usize,
    rated_load_kg: f64,
    scale: f64,
    t: f64,
    peak_rate: f64,
}

/// Gaussian bump of hour `h` around `mu`.
fn bump(h: f64, mu: f64, sigma: f64) -> f64 {
    (-(h - mu) * (h - mu) / (2.0 * sigma * sigma)).exp()
}

/// Logistic step.
fn logistic(x: f64) -> f64 {
    1.0 / (1.0 + (-x).exp())
}

/// Hour of day (0-24) of time `t` (s, 0 = Monday midnight).
pub fn hour_of(t: f64) -> f64 {
    (t / HOUR_S).rem_euclid(24.0)
}

/// Calls per hour at time `t` for traffic scale 1.
pub fn calls_per_hour(t: f64) -> f64 {
    let h = hour_of(t);
    let day = logistic((h - 7.0) / 0.3) * logistic((19.5 - h) / 0.5);
    let rate = 2.0
        + 14.0 * day
        + 45.0 * bump(h, 8.5, 0.4)
        + 30.0 * bump(h, 12.5, 0.45)
        + 40.0 * bump(h, 17.5, 0.4);
    let weekday = (t / DAY_S).floor().rem_euclid(7.0);
    if weekday >= 5.0 {
        0.25 * rate
    } else {
        rate
    }
}

impl Traffic {
    /// Calls for a building of `floors` landings and a car of `rated_load_kg`, from time `start_s`.
    pub fn new(rng: Rng, floors: usize, rated_load_kg: f64, scale: f64, start_s: f64) -> Self {
        // Upper bound of calls_per_hour, for thinning.
        let peak_rate = scale * (2.0 + 14.0 + 45.0 + 30.0 + 40.0);
        Traffic {
            rng,
            floors: floors.max(2),
            rated_load_kg,
            scale,
            t: start_s,
            peak_rate,
        }
    }

    /// The next call after the previous one.
    pub fn next_call(&mut self) -> Call {
        loop {
            self.t += self.rng.exponential(HOUR_S / self.peak_rate);
            if self
                .rng
                .chance(self.scale * calls_per_hour(self.t) / self.peak_rate)
            {
                break;
            }
        }
        self.make_call(self.t)
    }

    fn make_call(&mut self, t: f64) -> Call {
        let h = hour_of(t);
        let w_up = 1.0 + 6.0 * bump(h, 8.5, 0.5) + 2.0 * bump(h, 13.2, 0.4);
        let w_down = 1.0 + 6.0 * bump(h, 17.5, 0.5) + 2.0 * bump(h, 12.2, 0.4);
        let w_inter = 1.5;
        let peak = bump(h, 8.5, 0.5) + bump(h, 17.5, 0.5) + 0.5 * bump(h, 12.5, 0.5);
        let extra_mean = (0.12 * self.rated_load_kg / PASSENGER_KG - 1.0).max(0.0) * (1.0 + peak);
        let n = 1 + poisson(&mut self.rng, extra_mean);
        let top = self.floors - 1;
        let pick = self.rng.uniform(0.0, w_up + w_down + w_inter);
        let upper = |rng: &mut Rng| 1 + rng.below(top as u64) as usize;
        let (origin, dests): (usize, Vec<usize>) = if pick < w_up {
            (0, (0..n).map(|_| upper(&mut self.rng)).collect())
        } else if pick < w_up + w_down {
            (upper(&mut self.rng), vec![0; n])
        } else {
            let o = upper(&mut self.rng);
            let mut d = upper(&mut self.rng);
            if d == o {
                d = if o == top { o - 1 } else { o + 1 };
            }
            (o, vec![d; n])
        };
        let mut total = 0.0;
        let mut riders = Vec::with_capacity(n + 1);
        for d in dests {
            let m = (PASSENGER_KG + 12.0 * self.rng.normal()).clamp(35.0, 130.0);
            if total + m > self.rated_load_kg {
                break;
            }
            total += m;
            riders.push((d, m));
        }
        if self.rng.chance(0.04) {
            let goods = self
                .rng
                .uniform(100.0, (0.5 * self.rated_load_kg).max(101.0));
            if total + goods <= self.rated_load_kg {
                let d = riders
                    .first()
                    .map_or(if origin == 0 { top } else { 0 }, |r| r.0);
                riders.push((d, goods));
            }
        }
        if riders.is_empty() {
            riders.push((
                if origin == 0 { top } else { 0 },
                PASSENGER_KG.min(self.rated_load_kg),
            ));
        }
        Call {
            time: t,
            origin,
            riders,
        }
    }
}

/// Poisson draw (Knuth), adequate for the small means used here.
fn poisson(rng: &mut Rng, mean: f64) -> usize {
    if mean <= 0.0 {
        return 0;
    }
    let limit = (-mean).exp();
    let mut k = 0;
    let mut p = rng.next_f64();
    while p > limit && k < 200 {
        k += 1;
        p *= rng.next_f64();
    }
    k
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn peaks_are_busier_than_the_night() {
        let day = DAY_S * 2.0;
        assert!(calls_per_hour(day + 8.5 * HOUR_S) > 10.0 * calls_per_hour(day + 3.0 * HOUR_S));
        assert!(calls_per_hour(day + 12.5 * HOUR_S) > calls_per_hour(day + 10.5 * HOUR_S));
        assert!(calls_per_hour(day + 17.5 * HOUR_S) > calls_per_hour(day + 15.0 * HOUR_S));
        assert!(
            calls_per_hour(5.0 * DAY_S + 8.5 * HOUR_S) < 0.3 * calls_per_hour(day + 8.5 * HOUR_S)
        );
    }

    #[test]
    fn up_peak_calls_start_at_the_lobby_and_down_peak_calls_end_there() {
        let mut t = Traffic::new(Rng::new(5), 12, 1000.0, 1.0, 0.0);
        let (mut up_from_lobby, mut up_n, mut down_to_lobby, mut down_n) = (0, 0, 0, 0);
        for _ in 0..20_000 {
            let c = t.next_call();
            let h = hour_of(c.time);
            assert!(c.riders.iter().all(|&(d, _)| d != c.origin && d < 12));
            assert!(c.riders.iter().map(|r| r.1).sum::<f64>() <= 1000.0);
            if (8.0..9.0).contains(&h) {
                up_n += 1;
                up_from_lobby += usize::from(c.origin == 0);
            }
            if (17.0..18.0).contains(&h) {
                down_n += 1;
                down_to_lobby += usize::from(c.riders[0].0 == 0);
            }
        }
        assert!(
            up_from_lobby as f64 > 0.6 * up_n as f64,
            "{up_from_lobby}/{up_n}"
        );
        assert!(
            down_to_lobby as f64 > 0.6 * down_n as f64,
            "{down_to_lobby}/{down_n}"
        );
    }
}
