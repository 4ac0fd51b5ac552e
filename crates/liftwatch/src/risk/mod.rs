//! Stage 6: time-accumulated risk, combined and per fault mode (paper, Sec. 4.2 and 5.3).
//!
//! ```text
//! per trip k (moving samples i of the trip, n_k of them):
//!   z_U = mean_i(e_U) / sqrt(a_U + b_U/n_k)     trip-mean residual over its healthy spread
//!   z_F = mean_i(e_F) / sqrt(a_F + b_F/n_k)
//!   e_trip = sqrt((z_U² + z_F²)/2)
//!   fault signatures, regressed on r_U (recursive least squares, forgetting λ = 1 − 1/H):
//!     x_motor = φ(s)·Kd·s·F_pred                coefficient = relative change of Kd
//!     x_brake = φ(s)·Kd·F_c·1[s = −1 or decel]  coefficient = brake drag / F_c
//!     x_fric  = φ(s)·Kd·(F_c + c·|v|)           coefficient = relative change of friction
//!   z_m = min((θ̂_m − θ0_m) / max(σ_m, k_m·SE_m),  ℓ_m / max(σ'_m, SE'_m)),  z⁺_m = max(0, z_m)
//!                    ℓ_m = (b_m − (A·θ0)_m)/A_mm: signature m's level alone, σ'_m its healthy RMS
//!                    σ_m: healthy spread of θ̂_m in the fit, SE_m: standard error, k_m ≤ 1 its scale
//!   c_k = ln(1 + e_trip),  c_m,k = ln(1 + z⁺_m)              compressed evidence per lens
//!   x = max(0, c − τ) per lens                               τ = μ_c + 3·σ_c of the healthy fit
//!   per mode m: x_m;  combined: x_k = max(x_trip, x_motor, x_brake, x_fric)
//!   D_k = D_{k−1} + 1 if x_k > 0 else 0                     consecutive anomalous trips
//!   R_k = γ·R_{k−1} + x_k·exp(κ·min(D_k, D_max))
//! ```
//!
//! Deviations from the paper, each for a reason the data gives:
//! - τ comes from the healthy reference stored in [`RiskConfig`], never from the recent
//!   window: a boundary μ_t + 3σ_t over the recent residuals absorbs a slow drift, which is
//!   exactly the degradation this stage exists to catch.
//! - Evidence is aggregated per trip. The 1 Hz residuals within one trip are strongly
//!   correlated (same load, same thermal state, same acceleration error), so sample-by-sample
//!   accumulation counts one disturbance ten times. A trip's mean residual is compared with the
//!   healthy spread of trip means, var = a + b/n, fitted on the healthy trips of the fit (a is
//!   the part that does not average out within a trip).
//! - D counts consecutive anomalous trips and γ decays per trip, not per second: an elevator
//!   that stands still overnight neither gathers nor forgets evidence.
//! - The voltage and force lenses are not independent (see [`crate::residual`]): they enter
//!   e_trip as the paper's root mean square, which for two nearly proportional residuals
//!   equals one lens, not the sum of two.
//! - Per-mode evidence comes from an online re-identification of three fault signatures
//!   (MODEL.md "Fault modes") rather than from residuals restricted by phase alone: the
//!   regression separates a load-proportional voltage rise (motor) from a constant one
//!   (friction) and a direction-asymmetric one (brake), and reports the drifts in physical
//!   units. One trip counts as one observation in the regression (its samples weigh 1/n each),
//!   for the same correlation reason as above. The per-mode statistics are one-sided: only a
//!   rise of Kd, friction or drag is a degradation.
//! - Thresholds are calibrated to a stated false-alarm rate by a moving-block bootstrap of the
//!   healthy trip sequence ([`crate::calibrate`]); the paper gives no rule for them.
//! - The combined risk takes, per trip, the largest excess of any lens over its own boundary,
//!   so it rises for every mode and for deviations no signature explains (mode `unknown`).
//!
//! Constants (defaults, stored in the model file): γ = 0.998 per trip (memory ~500 trips,
//! about a busy day, so the daily thermal swing of Kd does not make levels flicker),
//! κ = 0.1 and D_max = 30 trips (a persistent excess weighs e³ ≈ 20 times an isolated one),
//! H = 3000 trips of forgetting in the re-identification.
//!
//! This stage holds no calibration and does no I/O: [`RiskConfig`] arrives calibrated from
//! [`crate::calibrate`], and the tracker is a pure function of the trips it is fed.
//!
//! Known limit: the physics has no direction-dependent Coulomb friction, so the trip residuals
//! depend on the traffic mix (which floors, which direction). That widens the healthy band of
//! the direction-asymmetric brake signature most: on the simulator a drag of 0.6·F_c going down
//! is hardly separable from it within a month.

// Three-by-three matrices and per-mode arrays read best with explicit indices.
#![allow(clippy::needless_range_loop)]

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::mode::FaultMode;
pub use crate::mode::N_MODES;

mod evidence;
pub mod sequential;
mod tracker;

pub(crate) use evidence::{
    evidence_predictions, mat_vec, spd_inverse, trip_evidence_from, unpack, PACKED_DIAG,
};
pub use evidence::{
    friction_reference, heating_reference, signature, trip_evidence, DriftScale, HeatEvidence,
    HeatInput, Heating, TripAccumulator, TripEvidence, Winding, DEFAULT_WINDING_TAU_S, HEAT_LAG,
    N_HEAT,
};
pub use sequential::{Decision, Sequential, SequentialConfig};
pub(crate) use tracker::{excess, PreparedTrip};
pub use tracker::{Accumulator, RiskTracker, Rls, TripAssessment};

#[cfg(test)]
pub(crate) mod tests;

// Indices of the per-mode arrays, in the order of `crate::mode::MACHINE_MODES`.
const MOTOR: usize = FaultMode::Motor as usize;
const BRAKE: usize = FaultMode::Brake as usize;
const FRICTION: usize = FaultMode::Friction as usize;

/// The advisory threshold is never below the risk of this many consecutive trips each 0.1
/// above τ (a few busy hours).
const ADVISORY_FLOOR_TRIPS: usize = 100;

/// Risk settings: accumulator constants and the healthy reference, calibrated by the fit.
///
/// [`RiskConfig::default`] holds uncalibrated textbook values (unit-normal healthy
/// statistics); a model written by `fit` carries the output of [`crate::calibrate::calibrate`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RiskConfig {
    /// γ: decay of R per trip (1).
    pub gamma: f64,
    /// κ: duration gain per consecutive anomalous trip (1).
    pub kappa: f64,
    /// D_max: cap of the duration, in trips.
    pub d_max_trips: f64,
    /// H: forgetting horizon of the re-identification, in trips (λ = 1 − 1/H).
    pub forgetting_trips: f64,
    /// Trips with fewer moving samples carrying both residuals are not evidence (re-levelling).
    pub min_trip_samples: u32,
    /// (a, b) of the healthy variance of a trip-mean e_U: var = a + b/n.
    pub trip_spread_u: [f64; 2],
    /// (a, b) of the healthy variance of a trip-mean e_F.
    pub trip_spread_f: [f64; 2],
    /// θ0: healthy signature coefficients (motor, brake, friction) the drifts are measured from.
    pub healthy_coef: [f64; N_MODES],
    /// Healthy standard deviation of the re-identified coefficients after warm-up: estimation
    /// noise and healthy wander (the thermal drift of the winding resistance shows here).
    pub drift_sd: [f64; N_MODES],
    /// k: the healthy spread of the coefficients over their mean nominal standard error,
    /// at most 1. The nominal errors count each trip as one observation, which overstates
    /// them when the residuals within a trip are not fully correlated; k scales them to what
    /// the healthy data show, while they still grow where the data are thinner than in the fit.
    pub se_scale: [f64; N_MODES],
    /// Healthy standard deviation, after warm-up, of each signature's level alone in the
    /// long memory ([`Rls::alone`]), which the per-mode lenses read; `None` in models
    /// calibrated before, whose lenses read the joint drifts against `drift_sd`.
    #[serde(default)]
    pub lens_sd: Option<[f64; N_MODES]>,
    /// Prior information of the re-identification (packed upper triangle of XᵀX, healthy).
    pub prior_info: [f64; 6],
    /// Healthy variance of the per-trip regression residual (V²).
    pub prior_s2: f64,
    /// τ of the trip-level evidence c = ln(1 + e_trip).
    pub tau: f64,
    /// τ of each mode.
    pub tau_modes: [f64; N_MODES],
    /// Combined risk at which the level becomes advisory.
    pub advisory: f64,
    /// Combined risk at which the level becomes alarm.
    pub alarm: f64,
    /// Per-mode risk the healthy bootstrap reaches once in the simulated years (attribution scale).
    pub advisory_modes: [f64; N_MODES],
    /// Hysteresis: a level is left only when risk falls below this fraction of its threshold.
    pub release_ratio: f64,
    /// A mode is named only when its scaled risk is this many times the runner-up's.
    pub dominance: f64,
    /// The winding's healthy temperature response ([`Winding`]): every trip's evidence is
    /// taken without it before the risk stage sees it. Models fitted before it was kept (whose
    /// `heating` of fixed lags is not read) take none out.
    #[serde(default)]
    pub winding: Winding,
    /// The sequential decision ([`sequential`]); absent in models fitted before it existed,
    /// which then decide from R alone.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sequential: Option<SequentialConfig>,
}

/// Largest heating coefficient β a model may carry (see [`Winding::beta`]).
pub const MAX_HEATING: f64 = 10.0;

/// Range of the winding time constant the calibration searches and a model may carry (s):
/// 5 min to 8 h, well beyond the 30-60 min of traction machines (MODEL.md) on both sides, so
/// that the search never pins an unusual machine to an end.
pub const MIN_WINDING_TAU_S: f64 = 300.0;
/// See [`MIN_WINDING_TAU_S`].
pub const MAX_WINDING_TAU_S: f64 = 28_800.0;

impl Default for RiskConfig {
    fn default() -> Self {
        let mut cfg = RiskConfig {
            gamma: 0.998,
            kappa: 0.1,
            d_max_trips: 30.0,
            forgetting_trips: 3000.0,
            min_trip_samples: 3,
            trip_spread_u: [0.05, 1.0],
            trip_spread_f: [0.05, 1.0],
            healthy_coef: [0.0; N_MODES],
            drift_sd: [0.02, 0.05, 0.05],
            se_scale: [1.0; N_MODES],
            lens_sd: None,
            prior_info: [0.0; 6],
            prior_s2: 1.0,
            // μ + 3σ of c = ln(1 + |z|) for a unit-normal z.
            tau: 1.5,
            tau_modes: [1.5; N_MODES],
            advisory: 0.0,
            alarm: 0.0,
            advisory_modes: [0.0; N_MODES],
            release_ratio: 0.5,
            dominance: 1.5,
            winding: Winding::default(),
            sequential: None,
        };
        cfg.advisory = cfg.advisory_floor();
        cfg.alarm = 4.0 * cfg.advisory;
        cfg.advisory_modes = [cfg.advisory; N_MODES];
        cfg
    }
}

impl RiskConfig {
    /// What mode `m`'s joint drift of standard error `se` is divided by in its lens: never
    /// less than the healthy spread, never less than the standard error scaled as in the fit
    /// (large while the data are thin, e.g. one direction only).
    pub fn joint_scale(&self, m: usize, se: f64) -> f64 {
        (self.se_scale[m] * se).max(self.drift_sd[m])
    }

    /// What mode `m`'s level alone of standard error `se` is divided by in its lens: never
    /// less than its healthy spread (`lens_sd`, when the model has it).
    pub fn alone_scale(&self, m: usize, se: f64) -> f64 {
        self.lens_sd.map_or(se, |sd| se.max(sd[m]))
    }

    /// λ = 1 − 1/H: the forgetting factor of the re-identification per trip.
    pub fn forgetting(&self) -> f64 {
        1.0 - 1.0 / self.forgetting_trips.max(1.0)
    }

    /// R of an excess `x` on every trip, after the duration gain has saturated:
    /// x·exp(κ·D_max)/(1 − γ).
    pub fn steady_state(&self, x: f64) -> f64 {
        x * (self.kappa * self.d_max_trips).exp() / (1.0 - self.gamma)
    }

    /// The lowest advisory threshold: the risk of 100 consecutive trips (a few busy hours)
    /// each 0.1 above τ. Without it, very clean healthy data would put the threshold near zero
    /// and a short run of unlucky trips, which a week of training data may never show, would
    /// raise an advisory; a degradation that matters persists far longer than 100 trips.
    pub fn advisory_floor(&self) -> f64 {
        let mut acc = Accumulator::default();
        for _ in 0..ADVISORY_FLOOR_TRIPS {
            acc.step(0.1, 0.0, self);
        }
        acc.r
    }

    /// Checks the settings a hand-edited model file could break: every number finite and in a
    /// range where the tracker means something (an absurd τ or threshold would make the
    /// monitor blind, or in alarm from the first trip).
    ///
    /// # Errors
    /// [`Error::InvalidConfig`] naming the first field out of range.
    pub fn validate(&self) -> Result<()> {
        let bad = |field, why: &str| {
            Err(Error::InvalidConfig {
                field,
                why: why.into(),
            })
        };
        if !(self.gamma > 0.0 && self.gamma < 1.0) {
            return bad("risk.gamma", "expected 0 < γ < 1");
        }
        if !(self.kappa >= 0.0 && self.kappa < 1.0) {
            return bad("risk.kappa", "expected 0 <= κ < 1");
        }
        if !(self.d_max_trips >= 0.0 && self.d_max_trips <= 1000.0) {
            return bad("risk.d_max_trips", "expected 0 to 1000 trips");
        }
        if !(10.0..=1e9).contains(&self.forgetting_trips) {
            return bad("risk.forgetting_trips", "expected at least 10 trips");
        }
        if !(self.advisory > 0.0 && self.alarm >= self.advisory && self.alarm <= MAX_RISK) {
            return bad("risk.alarm", "expected 0 < advisory <= alarm <= 1e12");
        }
        if !(self.release_ratio > 0.0 && self.release_ratio < 1.0) {
            return bad("risk.release_ratio", "expected between 0 and 1");
        }
        let range = |field: &'static str, v: f64, lo: f64, hi: f64| {
            crate::error::check_range(field, v, lo, hi)
                .map_err(|why| Error::InvalidConfig { field, why })
        };
        // c = ln(1 + e) of a healthy trip lies within a few units; τ beyond 50 means e^50.
        range("risk.tau", self.tau, 0.0, MAX_TAU)?;
        for (&t, &a) in self.tau_modes.iter().zip(&self.advisory_modes) {
            range("risk.tau_modes", t, 0.0, MAX_TAU)?;
            range("risk.advisory_modes", a, f64::MIN_POSITIVE, MAX_RISK)?;
        }
        for v in self.trip_spread_u.iter().chain(&self.trip_spread_f) {
            range("risk.trip_spread", *v, 0.0, MAX_SPREAD)?;
        }
        if self.trip_spread_u.iter().sum::<f64>() <= 0.0
            || self.trip_spread_f.iter().sum::<f64>() <= 0.0
        {
            return bad("risk.trip_spread", "expected a positive healthy spread");
        }
        for m in 0..N_MODES {
            range(
                "risk.healthy_coef",
                self.healthy_coef[m],
                -MAX_COEF,
                MAX_COEF,
            )?;
            range("risk.drift_sd", self.drift_sd[m], 1e-9, MAX_COEF)?;
            range("risk.se_scale", self.se_scale[m], 1e-3, 1e3)?;
            if let Some(sd) = &self.lens_sd {
                range("risk.lens_sd", sd[m], 1e-9, MAX_COEF)?;
            }
        }
        for v in self.prior_info {
            range("risk.prior_info", v, -1e30, 1e30)?;
        }
        // An information matrix (XᵀX, packed 00 01 02 11 12 22): no negative diagonal and no
        // correlation beyond one, or the re-identification starts from a prior that is none.
        let [a00, a01, a02, a11, a12, a22] = self.prior_info;
        for d in [a00, a11, a22] {
            range("risk.prior_info (diagonal)", d, 0.0, 1e30)?;
        }
        for (off, p, q) in [(a01, a00, a11), (a02, a00, a22), (a12, a11, a22)] {
            if off * off > p * q * (1.0 + 1e-9) {
                return Err(Error::InvalidConfig {
                    field: "risk.prior_info",
                    why: format!(
                        "off-diagonal {} exceeds what its diagonal allows ({} and {}): not an information matrix",
                        crate::error::number(off),
                        crate::error::number(p),
                        crate::error::number(q)
                    ),
                });
            }
        }
        range("risk.prior_s2", self.prior_s2, 1e-300, 1e30)?;
        // Copper gains 0.39 %/K; β = 10 would be a winding 2,500 K over ambient at H = 1.
        let w = &self.winding;
        range(
            "risk.winding.tau_s",
            w.tau_s,
            MIN_WINDING_TAU_S,
            MAX_WINDING_TAU_S,
        )?;
        for k in 0..N_HEAT {
            range("risk.winding.beta", w.beta[k], -MAX_HEATING, MAX_HEATING)?;
            range("risk.winding.beta_se", w.beta_se[k], 0.0, 1e3)?;
        }
        range("risk.winding.beta", w.steady_rise(), 0.0, MAX_HEATING)?;
        for level in w.levels.iter().flatten() {
            range("risk.winding.levels", *level, -MAX_COEF, MAX_COEF)?;
        }
        range("risk.dominance", self.dominance, 1.0, 1e3)?;
        if let Some(seq) = &self.sequential {
            seq.validate().map_err(|why| Error::InvalidConfig {
                field: "risk.sequential",
                why,
            })?;
        }
        range(
            "risk.min_trip_samples",
            f64::from(self.min_trip_samples),
            1.0,
            1e4,
        )?;
        Ok(())
    }
}

/// Highest risk threshold a model may carry: far above anything a bootstrap sets (thousands),
/// far below where the accumulator loses its resolution.
const MAX_RISK: f64 = 1e12;

/// Highest boundary τ of c = ln(1 + e): e^50 is no residual any sensor can produce.
const MAX_TAU: f64 = 50.0;

/// Highest healthy variance of a trip-mean scaled residual (its units are σ²).
const MAX_SPREAD: f64 = 1e6;

/// Largest signature coefficient or drift (relative units: 1e3 is a thousandfold change).
const MAX_COEF: f64 = 1e3;
