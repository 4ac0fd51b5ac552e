//! Stage 3, acceleration: the speed path, the load-cell path, the phase and their fusion
//! (paper, Sec. 4.1).
//!
//! ```text
//! a_v = (v[t+1] − v[t−1]) / (t[t+1] − t[t−1])   central difference, one-sided at an edge;
//!                                                 a neighbour at rest counts as v = 0
//! a_L = g·(L − L_ref)/100 / (k·λ + p)             moving, door closed; NaN if |a_L| > 3 m/s²
//! phase   standstill | accelerating (a_v·s > 0.1) | decelerating (a_v·s < −0.1) | cruising
//! β(λ) = 1 / (1 + (1/β_ref − 1)·((k·λ + p)/(k·λ_ref + p))²)
//! a   = β·a_v + (1 − β)·a_L, the one path present alone, 0 at rest
//! ```
//!
//! Deviation from the paper: β weighs the speed path more while cruising and follows the load
//! (see the stage's notes in [`super`]).

use super::pre::{Door, Pre};
use super::{FeatureConfig, Phase, BETA_REF_LAMBDA, PHASE_ACCEL_MPS2};
use crate::elevator::G;

/// |a_L| above which the moving load reading is implausible and a_L is missing (m/s²).
pub(super) const A_L_MAX_MPS2: f64 = 3.0;

impl FeatureConfig {
    /// β for a phase of travel and a load ratio λ: the weight of the speed path in the fused
    /// acceleration.
    ///
    /// The configured β holds at the reference load [`BETA_REF_LAMBDA`]. The load cell's noise is
    /// a fixed share of the rated load, so the noise of a_L scales as 1/(k·λ + p); read as an
    /// inverse-variance weight, β = σ_L²/(σ_L² + σ_v²), the configured value fixes the ratio
    /// σ_v/σ_L at the reference load and the weight at λ follows:
    /// `β(λ) = 1 / (1 + (1/β_ref − 1)·((k·λ + p)/(k·λ_ref + p))²)`. β = 0 and β = 1 stay fixed;
    /// without λ the configured value is used.
    pub fn beta(&self, phase: Phase, lambda: f64) -> f64 {
        let beta_ref = match phase {
            Phase::Accelerating | Phase::Decelerating => self.beta_transient,
            Phase::Cruising | Phase::Standstill => self.beta_cruise,
        };
        if !lambda.is_finite() || beta_ref <= 0.0 || beta_ref >= 1.0 {
            return beta_ref;
        }
        let scale = self.inertial_mass_ratio(lambda) / self.inertial_mass_ratio(BETA_REF_LAMBDA);
        1.0 / (1.0 + (1.0 / beta_ref - 1.0) * scale * scale)
    }
}

/// a_v of the held sample `c`: the central difference over its neighbours `p` and `n` (both
/// contiguous and with a known velocity), one-sided when one is missing; NaN without either
/// or without a velocity of `c`.
pub(super) fn speed_path(p: Option<&Pre>, c: &Pre, n: Option<&Pre>) -> f64 {
    if !c.v.is_finite() {
        return f64::NAN;
    }
    match (p, n) {
        (Some(p), Some(n)) => (n.v_boundary() - p.v_boundary()) / (n.time - p.time),
        (Some(p), None) => (c.v_boundary() - p.v_boundary()) / (c.time - p.time),
        (None, Some(n)) => (n.v_boundary() - c.v_boundary()) / (n.time - c.time),
        (None, None) => f64::NAN,
    }
}

/// a_L of the held sample `c`, moving with the door closed: the load-cell law with the trip's
/// reference `held_ref` (percent), λ and the cell's inertial law of `cfg`; NaN otherwise or
/// when implausible.
pub(super) fn load_path(cfg: &FeatureConfig, c: &Pre, held_ref: f64, lambda: f64) -> f64 {
    if c.s != 0 && c.door == Door::Closed && lambda.is_finite() {
        let a = G * (c.load - held_ref) / 100.0 / cfg.inertial_mass_ratio(lambda);
        if a.abs() <= A_L_MAX_MPS2 {
            a
        } else {
            f64::NAN
        }
    } else {
        f64::NAN
    }
}

/// The phase of travel of `c` from a_v along its direction of motion.
pub(super) fn phase(c: &Pre, a_v: f64) -> Phase {
    if !c.at_rest() && c.v.is_finite() {
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
    }
}

/// The fused acceleration a: 0 at rest, β-weighted when both paths are known, the one known
/// path alone otherwise; NaN without a velocity of `c`.
pub(super) fn fuse(
    cfg: &FeatureConfig,
    c: &Pre,
    phase: Phase,
    lambda: f64,
    a_v: f64,
    a_l: f64,
) -> f64 {
    if !c.v.is_finite() {
        f64::NAN
    } else if phase == Phase::Standstill {
        0.0
    } else {
        let beta = cfg.beta(phase, lambda);
        match (a_v.is_finite(), a_l.is_finite()) {
            (true, true) => beta * a_v + (1.0 - beta) * a_l,
            (true, false) => a_v,
            (false, true) => a_l,
            (false, false) => f64::NAN,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::testkit::{config, day, rms, LEGS};
    use super::super::{extract, FeatureRow};
    use super::*;

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
}
