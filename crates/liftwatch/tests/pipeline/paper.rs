//! Data made exactly by MODEL.md's equations, as an independent generator would make them:
//! an office car (loaded up from the lobby, so the load goes with the floor and the
//! direction), the paper's constant-k load cell (`load = 100·λ + a/k`, its inertial change
//! the same for every load), 2 V of voltage noise and 0.01 m/s of speed noise, sampled at
//! 1 Hz at whatever phase of a trip the second falls. The whole pipeline (features, fit)
//! gives the parameters the data determine back.

use liftwatch::model::PhysParams;
use liftwatch::rng::Rng;
use liftwatch::sample::{DAY_S, HOUR_S};
use liftwatch::{Elevator, Sample};

const G: f64 = 9.81;
/// Storey height (m).
const STOREY_M: f64 = 3.3;
/// Peak acceleration of the trips' sine-shaped acceleration phases (m/s²).
const A_MAX: f64 = 0.9;
/// The constant-k cell's inertial reading: percent of rated load per m/s² (a platform of
/// 35 % of the rated load, 100·0.35/g).
const CELL_PCT_PER_MS2: f64 = 100.0 * 0.35 / G;

/// An office car's drive, other values than the unit tests' paper-exact ones.
fn truth() -> PhysParams {
    PhysParams {
        delta_m: -470.0,
        m0: HOUR_S,
        f_c: 300.0,
        c_visc: 90.0,
        kd: 0.0048,
        ke: 182.0,
        u0: 6.5,
        alpha_down: 0.85,
        m_rope: 0.0,
        loss_asymmetry: 0.0,
    }
}

/// One trip of `distance` metres: a sine-shaped acceleration to the cruise speed, a cruise,
/// the mirror image to rest. Returns (v, a) at `t` seconds after the start (unsigned), and the
/// trip's duration.
struct Profile {
    v_c: f64,
    t_a: f64,
    t_c: f64,
}

impl Profile {
    fn new(distance: f64, rated: f64) -> Profile {
        // Accelerating to v_c takes t_a = π·v_c/(2·A_MAX) and covers v_c·t_a/2.
        let v_c = rated.min((2.0 * A_MAX * distance / std::f64::consts::PI).sqrt());
        let t_a = std::f64::consts::PI * v_c / (2.0 * A_MAX);
        let t_c = (distance - v_c * t_a) / v_c;
        Profile { v_c, t_a, t_c }
    }

    fn duration(&self) -> f64 {
        2.0 * self.t_a + self.t_c
    }

    fn at(&self, t: f64) -> (f64, f64) {
        let w = std::f64::consts::PI / self.t_a;
        let ramp = |u: f64| {
            (
                0.5 * self.v_c * (1.0 - (w * u).cos()),
                A_MAX * (w * u).sin(),
            )
        };
        if t <= 0.0 || t >= self.duration() {
            (0.0, 0.0)
        } else if t < self.t_a {
            ramp(t)
        } else if t < self.t_a + self.t_c {
            (self.v_c, 0.0)
        } else {
            let (v, a) = ramp(self.duration() - t);
            (v, -a)
        }
    }
}

/// `days` of an office car at 1 Hz from MODEL.md's equations with parameters `p`.
fn office(e: &Elevator, p: &PhysParams, days: f64, seed: u64) -> Vec<Sample> {
    let mut rng = Rng::new(seed);
    let mut out = Vec::new();
    let (mut t, mut floor, mut lambda) = (0.0f64, 0usize, 0.0f64);
    let mut emit =
        |rng: &mut Rng, time: f64, v: f64, a: f64, lambda: f64, door: bool, floor: f64| {
            let s = if v.abs() > 1e-9 { v.signum() } else { 0.0 };
            let phi = if s < 0.0 { p.alpha_down } else { 1.0 };
            let m_eq = p.delta_m + lambda * e.rated_load_kg;
            let m_tot = p.m0 + lambda * e.rated_load_kg;
            let force = m_tot * a + m_eq * G + p.f_c * s + p.c_visc * v;
            let u = p.u0 + p.ke * v.abs() + phi * p.kd * force * s;
            out.push(Sample {
                time,
                speed: if s == 0.0 {
                    0.0
                } else {
                    (v.abs() + 0.01 * rng.normal()).max(0.0)
                },
                direction: s,
                voltage: u + 2.0 * rng.normal(),
                load: 100.0 * lambda + a * s.abs() * CELL_PCT_PER_MS2 + 0.5 * rng.normal(),
                door: if door { 1.0 } else { 0.0 },
                floor: floor + 1.0,
                current: f64::NAN,
            });
        };
    while t < days * DAY_S {
        let hour = (t / HOUR_S) % 24.0;
        // Office hours call every half to two minutes, the night every quarter hour or so.
        let gap = if (7.0..19.0).contains(&hour) {
            rng.uniform(30.0, 120.0)
        } else {
            rng.uniform(600.0, 1800.0)
        };
        // The car stands with its door shut, then opens for the passengers.
        let dwell_end = t + gap;
        while t < dwell_end {
            let door = dwell_end - t < 8.0;
            emit(&mut rng, t, 0.0, 0.0, lambda, door, floor as f64);
            t += 1.0;
        }
        // Where to: from the lobby a loaded car goes up; above it, the car mostly returns
        // nearly empty, sometimes carries a group down or between floors.
        let (to, load) = if floor == 0 {
            (
                1 + (rng.uniform(0.0, (e.floors - 1) as f64) as usize),
                rng.uniform(0.3, 0.9),
            )
        } else if rng.uniform(0.0, 1.0) < 0.6 {
            (0, rng.uniform(0.0, 0.1))
        } else if rng.uniform(0.0, 1.0) < 0.5 {
            (0, rng.uniform(0.2, 0.7))
        } else {
            let f = rng.uniform(1.0, (e.floors - 1) as f64) as usize;
            (if f == floor { 0 } else { f }, rng.uniform(0.0, 0.3))
        };
        lambda = load;
        // Door shut for two seconds, then the trip, started at any phase of the second.
        for _ in 0..2 {
            emit(&mut rng, t, 0.0, 0.0, lambda, false, floor as f64);
            t += 1.0;
        }
        let start = t - rng.uniform(0.0, 1.0);
        let dir = if to > floor { 1.0 } else { -1.0 };
        let profile = Profile::new(
            (to as f64 - floor as f64).abs() * STOREY_M,
            e.rated_speed_mps,
        );
        while t < start + profile.duration() {
            let (v, a) = profile.at(t - start);
            let travelled = (t - start) / profile.duration();
            let shown = floor as f64 + (to as f64 - floor as f64) * travelled;
            emit(&mut rng, t, dir * v, dir * a, lambda, false, shown.round());
            t += 1.0;
        }
        floor = to;
    }
    out
}

#[test]
fn paper_exact_office_data_with_a_constant_k_cell_give_the_determined_parameters_back() {
    let e = Elevator::new(1000.0, 1.75, 26);
    let p = truth();
    let out = crate::fitted(office(&e, &p, 1.0, 7), &e, "a day of office traffic");
    let m = &out.model;
    let got = m.hybrid.parameters;
    println!("truth {p:?}\nfit   {got:?}");
    let f_c = m
        .summary
        .parameters
        .iter()
        .find(|r| r.name == "f_c")
        .expect("F_c reported");
    println!(
        "f_c {:.0} ± {:?} N (corrected for the speed noise {:?}), true {}",
        got.f_c, f_c.std_error, f_c.corrected, p.f_c
    );

    // The paper's cell is recognised: its inertial reading does not grow with the load.
    let f = &m.features;
    assert!(f.load_cell_load_gain < 0.15, "k {}", f.load_cell_load_gain);
    assert!(
        (f.load_cell_platform_ratio - 0.35).abs() < 0.03,
        "p {}",
        f.load_cell_platform_ratio
    );
    // What the data determine comes back within 2 % (measured on seeds 7-10: Δm 0.1-1.1 %,
    // M0 0.8-1.8 %, Kd 0.4-0.9 %, U0 0.7-1.0 %, α_down 0.4-1.7 %, Ke + Kd·c 0.5-0.7 %; the
    // corrected values: Δm 0.3-0.6 %, M0 0.5-2.0 %, Kd 0.3-0.8 %, U0 0.5-0.9 %, Ke + Kd·c
    // 0.02-0.21 %, α_down 0.4-1.7 %).
    let rel = |a: f64, b: f64| (a - b).abs() / b.abs();
    for ((name, fitted), (_, true_value)) in got.determined().into_iter().zip(p.determined()) {
        assert!(
            rel(fitted, true_value) < 0.02,
            "{name}: got {fitted}, want {true_value} ({:.2} %)",
            100.0 * rel(fitted, true_value)
        );
    }
    // F_c, a small difference of large terms, within two of its reported standard errors
    // once the speed reading's noise is taken out (seeds 7-10: 427, 210, 316, 355 N against
    // 300, ± 75-89 N; 1.6 standard errors at most). The value the model predicts with is the
    // plain least squares', 2.1-2.7 times the truth (618-803 N, 3.6-5.7 standard errors):
    // the 0.01 m/s of speed noise attenuates Ke, and what Ke·|v| loses while cruising
    // Kd·F_c makes up (README, Method, Identifiability).
    let se = f_c.std_error.expect("F_c has a standard error");
    let corrected = f_c.corrected.expect("a corrected F_c");
    assert!(
        (corrected - p.f_c).abs() < 2.0 * se,
        "corrected f_c {corrected} ± {se} against {}",
        p.f_c
    );
    // The speed noise is measured on the cruising samples: 0.01 m/s.
    let sv = m.summary.speed_noise_mps;
    assert!((sv - 0.01).abs() < 0.0015, "speed noise {sv}");
}
