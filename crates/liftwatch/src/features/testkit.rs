//! Test fixtures of stage 3: a simulated day of jerk-limited S-curve trips sampled at 1 Hz,
//! with the true acceleration and load ratio beside each sample.
//!
//! ```text
//! a(t)   jerk 1 m/s³, |a| <= 0.8 m/s², |v| <= 1.75 m/s, integrated at 50 Hz
//! L      = 100·(λ·g + (k·λ + p)·a)/g + N(0, 0.5 %)    the load cell; k = 1 under the platform
//! speed  = |v| + N(0, 0.005 m/s)
//! ```

use super::{FeatureConfig, FeatureRow};
use crate::elevator::{Elevator, G};
use crate::rng::Rng;
use crate::sample::{AlignedSeries, Sample};

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
pub(super) struct Day {
    pub(super) series: AlignedSeries,
    pub(super) a_true: Vec<f64>,
    pub(super) lambda_true: Vec<f64>,
}

/// Simulates the legs `(to_floor, λ)` from floor 1: door open 6 s (the load changes), door
/// closed 4 s, the S-curve trip, 3 s at rest; the load cell reads
/// `100·(λ·(g + a) + p·a)/g` plus noise. Samples at 1 Hz with a random phase.
pub(super) fn day(legs: &[(u32, f64)], p: f64, seed: u64) -> Day {
    day_with_cell(legs, 1.0, p, seed)
}

/// [`day`] with a load cell of load gain `k`: it reads `100·(λ·g + (k·λ + p)·a)/g` plus noise
/// (k = 0 is the paper's constant-k_L cell).
pub(super) fn day_with_cell(legs: &[(u32, f64)], k_gain: f64, p: f64, seed: u64) -> Day {
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
        let inertial = (k_gain * lam[k] + p) * a[k];
        let load = 100.0 * (lam[k] * G + inertial) / G + LOAD_NOISE_PCT * rng.normal();
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

pub(super) fn config() -> FeatureConfig {
    FeatureConfig::for_elevator(&Elevator::new(1000.0, 1.75, 20))
}

/// A varied day: short and long trips both ways, empty to heavy.
pub(super) const LEGS: [(u32, f64); 8] = [
    (6, 0.4),
    (3, 0.1),
    (12, 0.7),
    (11, 0.3),
    (1, 0.5),
    (2, 0.05),
    (9, 0.9),
    (4, 0.2),
];

pub(super) fn rms(e: impl Iterator<Item = f64>) -> f64 {
    let (s, n) = e.fold((0.0, 0usize), |(s, n), x| (s + x * x, n + 1));
    (s / n as f64).sqrt()
}

/// True when two rows are the same bit for bit (NaN equals NaN).
pub(super) fn same_row(a: &FeatureRow, b: &FeatureRow) -> bool {
    let bits =
        |r: &FeatureRow| [r.time, r.v, r.lambda, r.a_v, r.a_l, r.a, r.voltage].map(f64::to_bits);
    bits(a) == bits(b) && a.s == b.s && a.phase == b.phase && a.trip == b.trip
}

/// True when two rows are equal as numbers (NaN equals NaN, −0 equals 0): the sign of v at
/// rest is arbitrary when the direction is unknown.
pub(super) fn equal_row(a: &FeatureRow, b: &FeatureRow) -> bool {
    let nums = |r: &FeatureRow| [r.time, r.v, r.lambda, r.a_v, r.a_l, r.a, r.voltage];
    let same = nums(a)
        .iter()
        .zip(nums(b))
        .all(|(x, y)| *x == y || (x.is_nan() && y.is_nan()));
    same && a.s == b.s && a.phase == b.phase && a.trip == b.trip
}

/// `n` legs between random floors of a 20-floor building with random loads.
pub(super) fn random_legs(n: usize, seed: u64) -> Vec<(u32, f64)> {
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
