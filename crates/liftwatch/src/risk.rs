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
//!   z_m = (θ̂_m − θ0_m) / max(σ_m, k_m·SE_m),  z⁺_m = max(0, z_m)
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
use crate::exact;
use crate::features::{FeatureRow, Phase};
use crate::mode::FaultMode;
pub use crate::mode::N_MODES;
use crate::model::{HybridModel, PhysParams, Prediction};
use crate::residual::{PredictionCache, Residuals};

// Indices of the per-mode arrays, in the order of `crate::mode::MACHINE_MODES`.
const MOTOR: usize = FaultMode::Motor as usize;
const BRAKE: usize = FaultMode::Brake as usize;
const FRICTION: usize = FaultMode::Friction as usize;

/// The advisory threshold is never below the risk of this many consecutive trips each 0.1
/// above τ (a few busy hours).
const ADVISORY_FLOOR_TRIPS: usize = 100;

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
}

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
        };
        cfg.advisory = cfg.advisory_floor();
        cfg.alarm = 4.0 * cfg.advisory;
        cfg.advisory_modes = [cfg.advisory; N_MODES];
        cfg
    }
}

impl RiskConfig {
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
        }
        for v in self.prior_info {
            range("risk.prior_info", v, -1e30, 1e30)?;
        }
        range("risk.prior_s2", self.prior_s2, 1e-300, 1e30)?;
        range("risk.dominance", self.dominance, 1.0, 1e3)?;
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

/// Evidence of one trip: trip-mean residuals and the trip's share of the signature regression.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TripEvidence {
    /// Time of the first moving sample (s).
    pub start: f64,
    /// Time of the last moving sample (s).
    pub end: f64,
    /// Moving samples with a voltage residual.
    pub n: u32,
    /// Direction of travel: +1 up, −1 down.
    pub direction: i8,
    /// Mean of e_U over the trip's moving samples.
    pub mean_e_u: f64,
    /// Mean of e_F over the trip's moving samples.
    pub mean_e_f: f64,
    /// Mean of x·xᵀ over the samples, packed upper triangle (00, 01, 02, 11, 12, 22) (V²).
    pub xtx: [f64; 6],
    /// Mean of x·r_U over the samples (V²).
    pub xtr: [f64; N_MODES],
    /// Mean of r_U² over the samples (V²).
    pub rr: f64,
    /// False when a sensor plausibility check failed: the trip is not machine evidence.
    pub plausible: bool,
}

impl TripEvidence {
    /// True when the trip counts as machine evidence.
    pub fn usable(&self, cfg: &RiskConfig) -> bool {
        self.plausible && self.n >= cfg.min_trip_samples && self.mean_e_u.is_finite()
    }

    /// Mean squared regression residual of the trip for coefficients θ (V²).
    pub(crate) fn fit_error(&self, theta: &[f64; N_MODES]) -> f64 {
        let xtx = unpack(&self.xtx);
        let mut q = self.rr;
        for i in 0..N_MODES {
            q -= 2.0 * theta[i] * self.xtr[i];
            for j in 0..N_MODES {
                q += theta[i] * xtx[i][j] * theta[j];
            }
        }
        q.max(0.0)
    }
}

/// The friction (F_c, c) the signatures are scaled by: the fitted values, each floored at
/// half of what the elevator description makes typical.
///
/// F_c is identified only as a small difference of two large constants (Δm·g ± F_c), and c
/// hardly at all; on a small elevator the fit can put either near zero. Scaling the friction
/// signature by a near-zero force turns a few volts of noise into thousands of percent of
/// "friction drift" (seen on a 630 kg car: +3100 % ± 2800 %). The floor keeps the coefficient
/// a relative change of a friction force of realistic size.
pub fn friction_reference(model: &HybridModel) -> (f64, f64) {
    let p = &model.parameters;
    let typical = PhysParams::prior_centre(&model.elevator);
    (
        p.f_c.max(0.5 * typical.f_c),
        p.c_visc.max(0.5 * typical.c_visc),
    )
}

/// The fault-signature regressors of one moving sample (V per unit coefficient);
/// `friction` is [`friction_reference`] of `model`, computed once by the caller.
pub fn signature(
    model: &HybridModel,
    friction: (f64, f64),
    x: &FeatureRow,
    f_pred: f64,
) -> [f64; N_MODES] {
    let p = &model.parameters;
    let (f_c, c_visc) = friction;
    let phi_kd = p.phi(x.s) * p.kd;
    let s = f64::from(x.s);
    let braking = x.s == -1 || x.phase == Phase::Decelerating;
    let mut out = [0.0; N_MODES];
    out[MOTOR] = phi_kd * s * f_pred;
    out[BRAKE] = if braking { phi_kd * f_c } else { 0.0 };
    out[FRICTION] = phi_kd * (f_c + c_visc * x.v.abs());
    out
}

/// Sums the samples of one trip into a [`TripEvidence`].
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TripAccumulator {
    #[serde(with = "exact")]
    start: f64,
    #[serde(with = "exact")]
    end: f64,
    n: u32,
    n_f: u32,
    up: u32,
    down: u32,
    #[serde(with = "exact")]
    sum_e_u: f64,
    #[serde(with = "exact")]
    sum_e_f: f64,
    #[serde(with = "exact::array")]
    xtx: [f64; 6],
    #[serde(with = "exact::array")]
    xtr: [f64; N_MODES],
    #[serde(with = "exact")]
    rr: f64,
}

impl TripAccumulator {
    /// Adds one moving sample with its prediction and residuals; standstill samples and
    /// samples without a voltage residual are ignored. `friction` is
    /// [`friction_reference`] of `model`.
    pub fn push(
        &mut self,
        model: &HybridModel,
        friction: (f64, f64),
        x: &FeatureRow,
        p: &Prediction,
        r: &Residuals,
    ) {
        if x.s == 0 || !r.r_u.is_finite() {
            return;
        }
        if self.n == 0 {
            self.start = x.time;
        }
        self.end = x.time;
        self.n += 1;
        if x.s > 0 {
            self.up += 1;
        } else {
            self.down += 1;
        }
        self.sum_e_u += r.e_u;
        if r.e_f.is_finite() {
            self.sum_e_f += r.e_f;
            self.n_f += 1;
        }
        let sig = signature(model, friction, x, p.f_pred);
        let mut k = 0;
        for i in 0..N_MODES {
            self.xtr[i] += sig[i] * r.r_u;
            for j in i..N_MODES {
                self.xtx[k] += sig[i] * sig[j];
                k += 1;
            }
        }
        self.rr += r.r_u * r.r_u;
    }

    /// Moving samples so far.
    pub fn len(&self) -> u32 {
        self.n
    }

    /// True before the first moving sample.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// The trip's evidence (means over its samples), or `None` for a trip without samples;
    /// resets the accumulator.
    pub fn finish(&mut self, plausible: bool) -> Option<TripEvidence> {
        let a = std::mem::take(self);
        if a.n == 0 {
            return None;
        }
        let n = f64::from(a.n);
        Some(TripEvidence {
            start: a.start,
            end: a.end,
            n: a.n,
            direction: if a.up >= a.down { 1 } else { -1 },
            mean_e_u: a.sum_e_u / n,
            mean_e_f: if a.n_f > 0 {
                a.sum_e_f / f64::from(a.n_f)
            } else {
                f64::NAN
            },
            xtx: a.xtx.map(|v| v / n),
            xtr: a.xtr.map(|v| v / n),
            rr: a.rr / n,
            plausible,
        })
    }
}

/// The healthy trips of a training set, for [`crate::calibrate::calibrate`]: residuals of `rows`
/// with `model`, summed per trip (trips as marked by [`FeatureRow::trip`]). Plausibility of
/// the raw sensors is not checked here: training data are healthy by assumption.
pub fn trip_evidence(model: &HybridModel, rows: &[FeatureRow]) -> Vec<TripEvidence> {
    let mut out = Vec::new();
    let mut acc = TripAccumulator::default();
    let mut cache = PredictionCache::default();
    let friction = friction_reference(model);
    let mut open: Option<u32> = None;
    for x in rows {
        if x.trip != open {
            out.extend(acc.finish(true));
            open = x.trip;
        }
        if x.s != 0 && crate::residual::applicable(x) {
            let p = cache.predict(model, x);
            let r = Residuals::from_prediction(model, x, &p);
            acc.push(model, friction, x, &p, &r);
        }
    }
    out.extend(acc.finish(true));
    out
}

fn unpack(p: &[f64; 6]) -> [[f64; 3]; 3] {
    [[p[0], p[1], p[2]], [p[1], p[3], p[4]], [p[2], p[4], p[5]]]
}

/// Inverse of a symmetric positive-definite 3×3 matrix by Cholesky; `None` when it is not.
fn spd_inverse(p: &[f64; 6]) -> Option<[[f64; 3]; 3]> {
    let a = unpack(p);
    let scale = (a[0][0] + a[1][1] + a[2][2]) / 3.0;
    if !(scale.is_finite() && scale > 0.0) {
        return None;
    }
    let mut l = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..=i {
            let mut s = a[i][j];
            for k in 0..j {
                s -= l[i][k] * l[j][k];
            }
            if i == j {
                if s <= 1e-10 * scale {
                    return None;
                }
                l[i][i] = s.sqrt();
            } else {
                l[i][j] = s / l[j][j];
            }
        }
    }
    // Invert L (lower triangular), then A⁻¹ = L⁻ᵀ·L⁻¹.
    let mut li = [[0.0; 3]; 3];
    for i in 0..3 {
        li[i][i] = 1.0 / l[i][i];
        for j in 0..i {
            let mut s = 0.0;
            for k in j..i {
                s -= l[i][k] * li[k][j];
            }
            li[i][j] = s / l[i][i];
        }
    }
    let mut inv = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            inv[i][j] = (i.max(j)..3).map(|k| li[k][i] * li[k][j]).sum();
        }
    }
    Some(inv)
}

/// Recursive least squares with exponential forgetting, on per-trip normal equations.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Rls {
    /// Forgetting-weighted Σ XᵀX (packed upper triangle).
    #[serde(with = "exact::array")]
    pub a: [f64; 6],
    /// Forgetting-weighted Σ Xᵀr.
    #[serde(with = "exact::array")]
    pub b: [f64; N_MODES],
}

impl Rls {
    /// A regression that starts from the healthy prior: information `prior_info` at θ0.
    pub fn with_prior(cfg: &RiskConfig) -> Self {
        let a = cfg.prior_info;
        let m = unpack(&a);
        let mut b = [0.0; N_MODES];
        for i in 0..N_MODES {
            b[i] = (0..N_MODES).map(|j| m[i][j] * cfg.healthy_coef[j]).sum();
        }
        Rls { a, b }
    }

    /// Forgets by `forget`, then adds one trip.
    pub fn update(&mut self, t: &TripEvidence, forget: f64) {
        for k in 0..6 {
            self.a[k] = forget * self.a[k] + t.xtx[k];
        }
        for k in 0..N_MODES {
            self.b[k] = forget * self.b[k] + t.xtr[k];
        }
    }

    /// θ̂ and the variances s²·(A⁻¹)_jj, or `None` while the signatures are not separable yet.
    pub fn estimate(&self, s2: f64) -> Option<([f64; N_MODES], [f64; N_MODES])> {
        let inv = spd_inverse(&self.a)?;
        let mut theta = [0.0; N_MODES];
        let mut var = [0.0; N_MODES];
        for i in 0..N_MODES {
            theta[i] = (0..N_MODES).map(|j| inv[i][j] * self.b[j]).sum();
            var[i] = s2 * inv[i][i];
        }
        Some((theta, var))
    }
}

/// One accumulator R with its duration D.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Accumulator {
    /// R: the risk (1).
    #[serde(with = "exact")]
    pub r: f64,
    /// D: consecutive anomalous trips.
    pub d: u32,
}

impl Accumulator {
    /// One trip: x = max(0, c − τ), D, R = γ·R + x·exp(κ·min(D, D_max)); returns x.
    pub fn step(&mut self, c: f64, tau: f64, cfg: &RiskConfig) -> f64 {
        let x = excess(c, tau);
        self.add(x, cfg);
        x
    }

    /// One trip with its excess x ≥ 0 already formed: D, R = γ·R + x·exp(κ·min(D, D_max)).
    pub fn add(&mut self, x: f64, cfg: &RiskConfig) {
        self.d = if x > 0.0 { self.d.saturating_add(1) } else { 0 };
        let gain = (cfg.kappa * f64::from(self.d).min(cfg.d_max_trips)).exp();
        self.r = cfg.gamma * self.r + x * gain;
    }
}

/// x = max(0, c − τ), zero for a missing c.
pub(crate) fn excess(c: f64, tau: f64) -> f64 {
    if c.is_finite() {
        (c - tau).max(0.0)
    } else {
        0.0
    }
}

/// The statistics of one trip before accumulation.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct TripStatistics {
    /// c = ln(1 + e_trip), the compressed trip-level evidence.
    pub(crate) c: f64,
    /// c_m = ln(1 + z⁺_m) per mode.
    pub(crate) c_modes: [f64; N_MODES],
    /// e_trip itself.
    pub(crate) e_trip: f64,
}

/// What the tracker concluded after one trip.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TripAssessment {
    /// e_trip: the trip-mean residual magnitude over its healthy spread (1).
    #[serde(with = "exact")]
    pub e_trip: f64,
    /// Combined risk R.
    #[serde(with = "exact")]
    pub risk: f64,
    /// Per-mode risks (motor, brake, friction).
    #[serde(with = "exact::array")]
    pub risk_modes: [f64; N_MODES],
    /// Re-identified signature coefficients minus θ0 (motor, brake, friction; relative units).
    #[serde(with = "exact::array")]
    pub drift: [f64; N_MODES],
    /// Standard errors of the drifts.
    #[serde(with = "exact::array")]
    pub drift_se: [f64; N_MODES],
    /// One-sided drift statistics z⁺ (motor, brake, friction).
    #[serde(with = "exact::array")]
    pub z: [f64; N_MODES],
}

/// The risk state of one elevator: re-identification, accumulators and the last assessment.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RiskTracker {
    rls: Rls,
    #[serde(with = "exact")]
    s2: f64,
    combined: Accumulator,
    modes: [Accumulator; N_MODES],
    /// Trips taken as machine evidence so far.
    pub trips: u64,
    /// The latest assessment.
    pub last: TripAssessment,
}

impl RiskTracker {
    /// A tracker at the healthy reference of `cfg`, with no risk accumulated.
    pub fn new(cfg: &RiskConfig) -> Self {
        RiskTracker {
            rls: Rls::with_prior(cfg),
            s2: cfg.prior_s2,
            combined: Accumulator::default(),
            modes: [Accumulator::default(); N_MODES],
            trips: 0,
            last: TripAssessment::default(),
        }
    }

    /// Updates the re-identification with one trip and forms its statistics.
    pub(crate) fn statistics(&mut self, cfg: &RiskConfig, t: &TripEvidence) -> TripStatistics {
        let forget = cfg.forgetting();
        // The regression residual variance, tracked with the same horizon, from the error
        // of the estimate before this trip (a prediction error, so a fault inflates it late).
        if let Some((theta, _)) = self.rls.estimate(1.0) {
            self.s2 = forget * self.s2 + (1.0 - forget) * t.fit_error(&theta);
        }
        self.rls.update(t, forget);
        let n = f64::from(t.n.max(1));
        let z_u = t.mean_e_u / (cfg.trip_spread_u[0] + cfg.trip_spread_u[1] / n).sqrt();
        let z_f = t.mean_e_f / (cfg.trip_spread_f[0] + cfg.trip_spread_f[1] / n).sqrt();
        let e_trip = if z_f.is_finite() {
            ((z_u * z_u + z_f * z_f) / 2.0).sqrt()
        } else {
            z_u.abs()
        };
        let e = if e_trip.is_finite() { e_trip } else { 0.0 };
        let mut c_modes = [0.0; N_MODES];
        let a = &mut self.last;
        a.e_trip = e_trip;
        if let Some((theta, var)) = self.rls.estimate(self.s2) {
            for m in 0..N_MODES {
                a.drift[m] = theta[m] - cfg.healthy_coef[m];
                a.drift_se[m] = var[m].sqrt();
                // Never less than the healthy spread, never less than the current standard
                // error scaled as in the fit (large while the data are thin, e.g. one
                // direction only).
                let z = a.drift[m] / (cfg.se_scale[m] * a.drift_se[m]).max(cfg.drift_sd[m]);
                a.z[m] = z.max(0.0);
                c_modes[m] = a.z[m].ln_1p();
            }
        } else {
            a.drift = [f64::NAN; N_MODES];
            a.drift_se = [f64::NAN; N_MODES];
            a.z = [0.0; N_MODES];
        }
        TripStatistics {
            c: e.ln_1p(),
            c_modes,
            e_trip,
        }
    }

    /// Takes one trip of machine evidence (callers pass only plausible trips) and returns the
    /// updated assessment.
    pub fn push(&mut self, cfg: &RiskConfig, t: &TripEvidence) -> TripAssessment {
        if !t.usable(cfg) {
            return self.last;
        }
        let s = self.statistics(cfg, t);
        // The combined risk takes the largest excess of any lens over its own boundary, so it
        // rises for any mode and for trip-level deviations no signature explains.
        let mut x = excess(s.c, cfg.tau);
        for m in 0..N_MODES {
            let xm = excess(s.c_modes[m], cfg.tau_modes[m]);
            self.modes[m].add(xm, cfg);
            x = x.max(xm);
        }
        self.combined.add(x, cfg);
        self.trips += 1;
        self.last.risk = self.combined.r;
        self.last.risk_modes = [self.modes[0].r, self.modes[1].r, self.modes[2].r];
        self.last
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::residual::tests::{row, test_model};
    use crate::rng::Rng;

    /// A fault or drift as a voltage residual added to each moving sample.
    pub(crate) type Injection<'a> = &'a dyn Fn(f64, &[f64; N_MODES]) -> f64;

    /// Synthetic trips: S-shaped speed profile, random load and direction, white noise of
    /// σ_U on the voltage, a daily ±3 % swing of Kd (thermal), plus `fault(t, signature)`.
    pub(crate) fn synthetic_trips(
        model: &HybridModel,
        seed: u64,
        days: f64,
        t0: f64,
        fault: Injection,
    ) -> Vec<TripEvidence> {
        let mut rng = Rng::new(seed);
        let mut out = Vec::new();
        let mut t = t0;
        let sigma = model.scales.sigma_u_v;
        let friction = friction_reference(model);
        while t < t0 + days * 86_400.0 {
            t += rng.uniform(60.0, 400.0);
            let s = if rng.uniform(0.0, 1.0) < 0.5 {
                1.0
            } else {
                -1.0
            };
            let lambda = rng.uniform(0.0, 0.9);
            let cruise = (rng.uniform(1.0, 14.0)) as usize;
            let mut acc = TripAccumulator::default();
            let profile: Vec<(f64, f64, Phase)> = [
                (0.6, 0.8, Phase::Accelerating),
                (1.4, 0.6, Phase::Accelerating),
            ]
            .into_iter()
            .chain(std::iter::repeat((1.75, 0.0, Phase::Cruising)).take(cruise))
            .chain([
                (1.3, -0.6, Phase::Decelerating),
                (0.5, -0.8, Phase::Decelerating),
            ])
            .collect();
            for (i, (speed, acc_mag, phase)) in profile.into_iter().enumerate() {
                let time = t + i as f64;
                let mut x = row(model, time, s * speed, lambda, s * acc_mag, 0.0);
                x.phase = phase;
                let p = model.predict(&x);
                let sig = signature(model, friction, &x, p.f_pred);
                let thermal =
                    0.03 * (2.0 * std::f64::consts::PI * time / 86_400.0).sin() * sig[MOTOR];
                x.voltage += thermal + fault(time, &sig) + sigma * rng.normal();
                let p = model.predict(&x);
                let r = Residuals::from_prediction(model, &x, &p);
                acc.push(model, friction, &x, &p, &r);
            }
            out.extend(acc.finish(true));
            t += 20.0;
        }
        out
    }

    #[test]
    fn inverse_of_a_spd_matrix_is_exact() {
        let p = [4.0, 1.0, 0.5, 3.0, 0.2, 2.0];
        let inv = spd_inverse(&p).unwrap();
        let a = unpack(&p);
        for i in 0..3 {
            for j in 0..3 {
                let v: f64 = (0..3).map(|k| a[i][k] * inv[k][j]).sum();
                assert!((v - f64::from(u8::from(i == j))).abs() < 1e-12);
            }
        }
        assert!(
            spd_inverse(&[1.0, 1.0, 0.0, 1.0, 0.0, 1.0]).is_none(),
            "singular"
        );
    }

    #[test]
    fn regression_recovers_injected_coefficients() {
        let m = test_model();
        let trips = synthetic_trips(&m, 3, 2.0, 0.0, &|_, x| {
            0.10 * x[MOTOR] + 0.25 * x[FRICTION] + 0.5 * x[BRAKE]
        });
        let mut rls = Rls::default();
        for t in &trips {
            rls.update(t, 1.0);
        }
        let (theta, _) = rls.estimate(1.0).unwrap();
        // The thermal swing averages out over two whole days.
        assert!((theta[MOTOR] - 0.10).abs() < 0.01, "{theta:?}");
        assert!((theta[FRICTION] - 0.25).abs() < 0.05, "{theta:?}");
        assert!((theta[BRAKE] - 0.5).abs() < 0.1, "{theta:?}");
    }
}
