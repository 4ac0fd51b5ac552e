//! Stage 6, the decision: sequential change detection along the known fault signatures
//! (CUSUM for a change of known direction, Basseville & Nikiforov, "Detection of Abrupt
//! Changes", ch. 7-8), at several change sizes at once.
//!
//! ```text
//! per usable trip k, per mode m (signature x_m, trip means as in the regression):
//!   score_m = mean(x_m·r_U) − (mean(x·xᵀ)·θ0)_m      healthy mean 0: θ0 pooled over the fit
//!   info_m  = mean(x_m²)
//!   healthy var(score_m) = s²_m·info_m                s²_m = Σ score² / Σ info on the fit
//! one CUSUM per mode m and size δ = ν_j·se_m         se_m = s_m/√(mean info_m): one trip's SE
//!   u = clip(score_m/(s_m·√info_m), ±3),  ν = δ·√info_m/s_m
//!   smallest size: score_m − z·se0_m·info_m in place of score_m
//!                                                   se0_m: θ0's error as a new day's level
//!                                                   (the training's day spread and the fitted
//!                                                   parameters' own error), z = REFERENCE_Z
//!   G ← max(0, G + ν·u − ν²/2)                     log-likelihood ratio of a drift δ along x_m
//!   a CUSUM at 0 forgets its window; above 0 it sums the window's score (3) and x·xᵀ (6)
//! crossing: G ≥ h_mj                                  h calibrated (crate::calibrate)
//! beside them, per mode, the window-limited GLR of a change of unknown size (Lai, 1995):
//!   windows of the last n ∈ {20, 30, 50} trips holding the information of 20 mean trips,
//!   S = Σ clip(score, ±3 sd), z² = S²/(Σ v + f_n·W²), S > 0
//!                                                   v = a·info + b: a trip's own variance,
//!                                                   f_n: the wander between windows of n
//!   crossing: max over n of z² ≥ h_m                  h_m calibrated with the CUSUMs'
//!   (it raises an advisory once it has stood an hour: crate::alarm::GLR_HOLD_S)
//! ratio   = max over m, j of G_mj/h_mj and z²_m/h_m  ≥ 1: the decision says "changed"
//! mode    = argmax_m z_m on the crossing window, one signature alone, against the noise and
//!           the healthy wander together (V = s²_m·W + (B/n)·W·Σ_w·W, n the window's trips,
//!           B = WANDER_BLOCK_TRIPS, Σ_w the joint wander of the fit's blocks):
//!             z_m² = (a_mᵀ·S)²/(a_mᵀ·W·e_m),  a_m = V⁻¹·W·e_m   (= S_m²/(s²_m·W_mm) at Σ_w = 0)
//!           named when z_best² − z_second² ≥ 2·ln(ISOLATION_ODDS), else unknown;
//!           brake against friction (the two best): brake when z² of the two jointly less
//!           z² of friction alone ≥ 2·ln(ISOLATION_ODDS), with a positive drag (same V);
//!           beside the three, the load cell's zero: z_L = S_L/(s_L·√W_LL) of either sign,
//!           S_L = Σ (mean x_load·r_U − mean x_load·xᵀ·θ0 − θ_L·mean x_load²),
//!           named `sensor` when z_L² − z_best² ≥ 2·ln(ISOLATION_ODDS), z_best the machine's
//!           on the noise alone (the cell's score has no wander measured beside it)
//! drift   = the window's level now: θ + β·τ_end from Σ over the window of
//!           (1, τ)ᵀ(1, τ) ⊗ x·xᵀ · (θ, β) = Σ (1, τ) ⊗ score,  τ = days since the window began
//!           (all three signatures jointly), SE² = (var of θ + β·τ_end)·max s² + wander² + se0²;
//!           a window shorter than SLOPE_MIN_DAYS: W⁻¹·S, the mean of its trips since the
//!           likeliest change point, argmax over suffixes k of the last RECENT_TRIPS trips of
//!           S_k²/W_k along the named mode's signature (else the leading CUSUM's), taken when
//!           it beats the whole window's by 2·s²·ln(ISOLATION_ODDS);
//!           the named mode's own drift from its signature alone (the same line, 2×2; while
//!           none is named, the mode with the largest z², the one the window leans to),
//!           SE² = var·s²_m + wander²_m + se0²_m; the other two each alone on what it leaves
//!           of the window's mean, S − W·e_m·S_m/W_mm
//!                                                   wander: healthy sd between blocks of 50 trips;
//!                                                   se0: θ0's error, as in the smallest size
//! ```
//!
//! Why CUSUM beside the accumulated risk R: R compresses each trip's evidence by ln(1 + z)
//! and floors its threshold at 100 trips of excess, so a large step waits as long as a small
//! ramp; and the re-identification behind the per-mode lenses forgets over 3000 trips, so a
//! step shows in it only as k/3000 of its size after k trips. A CUSUM tuned to a size δ is the
//! fastest detector of that size at a given false-alarm rate (Lorden's optimality): with
//! sizes of one eighth and one half of one trip's standard error, a step of a few standard
//! errors is flagged within about ten trips, and a slow ramp by the small size once its mean
//! exceeds it. The drift is estimated on the trips the crossing CUSUM holds as changed, not
//! on the long memory, so it is the size of the change, not a lagged fraction of it; and it is
//! the level the window's line reaches at its last trip, not the window's mean, which on a
//! ramp is half of it (the mean of a window that began with the ramp; measured on the
//! evaluation: the demo's Kd read +3.1 % at the alarm against +6.4 %). For a step the slope is
//! zero within its error and the level is the mean's, with about twice its standard error.
//!
//! Why the load cell's zero is a hypothesis of the isolation: an offset Δλ of the load cell
//! moves the expected force by Q·(g + a)·Δλ on every trip, so the voltage residual is
//! −φ·Kd·s·Q·(g + a)·Δλ: a constant force in the direction of travel, which the motor
//! signature φ·Kd·s·F resembles wherever the cars run mostly lighter than the counterweight
//! (F < 0 on most trips; over the moving samples of a simulated 1000 kg car the two
//! correlate at −0.9). A drifting cell then crossed the motor CUSUM a few tenths of a day
//! before the parked zero check could see it (its floor is 1 % of the rated load), and was
//! named `motor` on every car. Weighed as a fourth signature, what the load dependence of the
//! residual tells apart is told apart by the same odds as the machine modes; where it cannot,
//! the parked readings decide (the monitor's witness). It takes no part in detection: the
//! CUSUMs watch the machine; a zero drift the machine evidence does not show is the zero
//! check's.
//!
//! Why the healthy wander is in the isolation: a healthy elevator's three coefficients do not
//! only scatter trip by trip, they wander together for hours along the directions its traffic
//! mix and the fit's small errors move them (on the field-like evaluation's 630 kg car, Kd
//! −1 %, friction −4 % and the drag +50 N came and went together over the days). Weighed
//! against the trips' noise alone, a window that drifted that way is strong evidence for
//! whichever signature it leans to, and a small fault on top of it was named by the wander:
//! six of that car's ten machine faults on the first advisory, and three more on the others.
//! Weighed against the wander as well, the same windows leave two modes within the odds
//! (`unknown`), and the monitor waits for the change to name itself
//! ([`crate::alarm::UNNAMED_RATIO`]). The blocks wander independently, so a window of n
//! trips carries B/n of one block's wander (all of it within one block): a long window is
//! decided by its noise again.
//!
//! Why a GLR beside the CUSUMs: see [`glr`]; in short, the CUSUMs' thresholds are set by
//! healthy hours that wander together, and where that wander is a sizeable share of a trip's
//! error they wait for as much evidence on a large step as on a small one.
//!
//! Isolation is by the likelihood of each signature alone: a friction rise also moves the
//! motor score (the signatures are not orthogonal), but less than it moves its own. (Isolating
//! on the joint drifts instead named fewer modes at the first advisory on the evaluation:
//! motor 14/15, friction 11/15, brake 5/15 against 14, 14 and 5, as the short windows of an
//! early decision leave the joint estimate wide.)

// Per-mode arrays read best with explicit indices.
#![allow(clippy::needless_range_loop)]

use crate::sample::DAY_S;
use serde::{Deserialize, Serialize};

use super::evidence::{mat_vec, pack, spd_inverse, unpack, PACKED_DIAG};
use super::{TripEvidence, N_MODES};
use crate::exact;
use crate::linalg::SquareMatrix;
use crate::mode::{FaultMode, MACHINE_MODES};

/// Change sizes of the CUSUM bank, in standard errors of one trip's single-signature
/// estimate. ν = 1/8 catches a slow ramp once its mean passes an eighth of a trip's noise
/// (about 2·h·64 trips: days to weeks); ν = 1/2 a step within h/(ν·u − ν²/2) trips, about ten
/// for a step beyond the clip. No larger size: with the clip, a CUSUM of size ν gains at
/// most ν·3 − ν²/2 per trip, and at ν = 1/2 that is 1.375, so no fewer than about ten trips
/// (h ≈ 14) ever make a decision. A size of 2 decided from four or five odd trips; on the
/// evaluation all four of its false advisories came that way (windows of 4-7 trips).
pub const SIZES: [f64; N_SIZES] = [0.125, 0.5];

/// Number of change sizes in the bank.
pub const N_SIZES: usize = 2;

/// A trip's standardised score u = score/(s·√info) enters the CUSUMs clipped to ±3: one
/// trip's evidence is bounded the way a Huber estimator bounds it, so a few odd trips (a
/// re-levelling, a passenger jumping, a dropout at a trip's edge) cannot outweigh the many a
/// real degradation gives. A change of up to 3 standard errors per trip passes unclipped.
/// The GLR ([`glr`]) clips each trip's score to the same bound of its own sd: at twice the
/// bound, runs of five to ten odd trips on a busy morning (5 to 17 standard errors each)
/// crossed it on healthy days.
pub const CLIP: f64 = 3.0;

pub use crate::stats::gaussian_llr;

/// A mode is named when its signature alone explains the window this many times more likely
/// than the runner-up's: 20 to 1, a conventional "strong" likelihood ratio.
pub const ISOLATION_ODDS: f64 = 20.0;

/// Calibrated settings of the sequential decision, stored in the model file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SequentialConfig {
    /// θ0: signature coefficients pooled over the healthy trips (least squares on all of them).
    pub theta0: [f64; N_MODES],
    /// s²_m: healthy variance of a trip's score per unit information (V²).
    pub s2: [f64; N_MODES],
    /// Mean healthy information of a trip per mode (V²): se_m = √(s²_m/info_m).
    pub info: [f64; N_MODES],
    /// h: crossing thresholds per mode and size (log-likelihood ratio units).
    pub h: [[f64; N_SIZES]; N_MODES],
    /// Healthy wander of a coefficient between blocks of [`WANDER_BLOCK_TRIPS`] trips beyond
    /// what their noise explains (the daily thermal swing of Kd shows here); it is added to
    /// the standard error of every window drift, which no number of trips averages away.
    pub wander: [f64; N_MODES],
    /// Standard error of θ0 as the healthy level of a day the training did not see, per mode
    /// (coefficient units): the noise of the pooled estimate plus the spread between whole
    /// days over their number, and the fitted parameters' own error, which the training's
    /// residuals cannot show ([`crate::calibrate::fit_error_along_signatures`]). A CUSUM
    /// counts only what a trip shows beyond [`REFERENCE_Z`] of it, so an elevator whose
    /// healthy level sits a little off the training's (three days cannot pin it) does not
    /// pile up a false change over weeks; every drift's standard error includes it
    /// ([`SequentialConfig::floor_var`]: models fitted before the fit's error was part of it
    /// report their drifts with this wider error too, without a refit). 0 in models fitted
    /// before it was kept, whose CUSUMs then behave as before.
    #[serde(default)]
    pub reference_se: [f64; N_MODES],
    /// The load-cell zero's healthy reference, for the isolation; `None` in models fitted
    /// before it was kept, which then weigh the machine modes alone.
    #[serde(default)]
    pub load: Option<LoadReference>,
    /// Σ_w: the healthy wander of the three coefficients jointly between blocks of
    /// [`WANDER_BLOCK_TRIPS`] trips beyond their noise (packed covariance, coefficient units²;
    /// measured by [`SequentialConfig::reference`] from at least [`MIN_WANDER_BLOCKS`]
    /// blocks). The isolation weighs a window against it: a
    /// healthy elevator's coefficients wander together along the directions its traffic and
    /// winding move them, and a window that moved that way is weak evidence for any one mode.
    /// `None` in models fitted before it was kept, whose isolation weighs the trips' noise alone.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wander_cov: Option<[f64; 6]>,
    /// Thresholds of the window-limited GLR per mode (z², [`Sequential::glr`]), calibrated
    /// with the CUSUMs' by the same bootstrap; `None` in models fitted before it was kept,
    /// which decide by the CUSUMs alone.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub glr_h: Option<[f64; N_MODES]>,
    /// A trip's healthy score variance as the GLR weighs it, per mode: a·info + b
    /// ([`SequentialConfig::trip_variance`]); `None` in models fitted before it was kept,
    /// whose GLR takes s²·info.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub trip_var: Option<[[f64; 2]; N_MODES]>,
    /// The healthy wander of each signature's level between windows of each of the GLR's
    /// lengths, beyond their noise (sd, coefficient units; [`SequentialConfig::glr_wander`]);
    /// `None` in models fitted before it was kept, whose GLR takes [`SequentialConfig::wander`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub glr_wander: Option<[[f64; GLR_N]; N_MODES]>,
}

/// The healthy level and noise of the load-cell zero's score (the isolation's fourth
/// hypothesis), measured on the training like θ0 and s² of the signatures.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LoadReference {
    /// θ_L: what the healthy residual, left over by the three signatures, projects on x_load
    /// (per unit λ).
    pub theta: f64,
    /// s²_L: healthy variance of a trip's load score per unit information (V²).
    pub s2: f64,
}

impl LoadReference {
    /// A trip's load score: mean x_load·r_U less what θ0 and θ_L explain (V² per unit λ).
    fn score(&self, theta0: &[f64; N_MODES], t: &TripEvidence) -> f64 {
        let l = &t.load;
        l.lr - (0..N_MODES).map(|m| l.xm[m] * theta0[m]).sum::<f64>() - l.ll * self.theta
    }

    /// The reference of healthy `trips` around `theta0`; `None` when the trips carry no load
    /// regressor (evidence written before it was kept) or no noise.
    fn measure(theta0: &[f64; N_MODES], trips: &[TripEvidence]) -> Option<LoadReference> {
        let mut r = LoadReference {
            theta: 0.0,
            s2: 0.0,
        };
        let (s, ll) = trips.iter().fold((0.0, 0.0), |(s, ll), t| {
            (s + r.score(theta0, t), ll + t.load.ll)
        });
        if !(ll > 0.0 && s.is_finite()) {
            return None;
        }
        r.theta = s / ll;
        let ss: f64 = trips.iter().map(|t| r.score(theta0, t).powi(2)).sum();
        r.s2 = ss / ll;
        (r.s2 > 0.0 && r.s2.is_finite()).then_some(r)
    }
}

/// Standard errors of the reference θ0 a trip's score must exceed before a CUSUM counts it:
/// two, a one-sided 98 % bound on how far the healthy level of a new day may sit from the
/// training's.
pub const REFERENCE_Z: f64 = 2.0;

/// The size whose CUSUM counts only what lies beyond θ0's error: the smallest, whose windows
/// run for days and weeks, long enough to pile up a small error of the reference into a
/// "change". The larger size decides on tens to a few hundred trips, within a day, where the
/// healthy wander of the training sets its threshold (the bootstrap) and the reference's error
/// is a small part of the noise; an allowance there lowered its bootstrap threshold by more
/// than it took from a new day's excursions (3-day trainings on the evaluation: four false
/// advisories of the size 1/2 on the 40-floor car).
pub const REFERENCE_SIZE: usize = 0;

/// Trips per block when the healthy wander is measured: a few busy hours, short against the
/// daily thermal cycle, long enough for a block's noise to be small.
pub const WANDER_BLOCK_TRIPS: usize = 50;

/// Fewest blocks the joint wander Σ_w is measured from: a 3×3 covariance from fewer is mostly
/// the sampling error of its six entries (relative error about √(2/n): 45 % at ten blocks).
/// A 3-day training gives 30-40 blocks; the paper's 3 hours (80-200 trips) give none, and
/// isolate on the trips' noise alone, as models before Σ_w did.
pub const MIN_WANDER_BLOCKS: usize = 10;

/// Passes of the reweighted least squares of a trip's variance
/// ([`SequentialConfig::trip_variance`]): the weights come from the previous pass's fit, and
/// a fit of two coefficients settles in a few.
const TRIP_VARIANCE_PASSES: usize = 4;

impl SequentialConfig {
    /// What no number of a window's trips averages away from its drift's variance, mode `m`
    /// (coefficient units²): the healthy wander between blocks of trips, and the error of θ0
    /// itself as the level of a period after the training ([`SequentialConfig::reference_se`]),
    /// which every drift is measured from.
    pub fn floor_var(&self, m: usize) -> f64 {
        self.wander[m] * self.wander[m] + self.reference_se[m] * self.reference_se[m]
    }

    /// The largest of the three healthy noise factors s²_m: the conservative one for a
    /// joint fit of the signatures.
    pub fn largest_s2(&self) -> f64 {
        self.s2.iter().fold(0.0f64, |a, &b| a.max(b))
    }

    /// se_m: the standard error of one mean trip's coefficient along signature `m`, the unit
    /// of the CUSUMs' sizes (coefficient units).
    pub fn trip_se(&self, m: usize) -> f64 {
        (self.s2[m] / self.info[m]).sqrt()
    }

    /// δ of mode `m`, size `j`, in coefficient units.
    pub fn delta(&self, m: usize, j: usize) -> f64 {
        SIZES[j] * self.trip_se(m)
    }

    /// Checks a hand-edited model: every number finite, variances and thresholds positive.
    ///
    /// # Errors
    /// A message naming the first field out of range.
    pub fn validate(&self) -> std::result::Result<(), String> {
        let check = crate::error::check_range;
        for m in 0..N_MODES {
            check("risk.sequential.theta0", self.theta0[m], -1e3, 1e3)?;
            check("risk.sequential.s2", self.s2[m], 1e-300, 1e30)?;
            check("risk.sequential.info", self.info[m], 1e-300, 1e30)?;
            for j in 0..N_SIZES {
                check("risk.sequential.h", self.h[m][j], 1e-3, 1e9)?;
            }
            check("risk.sequential.wander", self.wander[m], 0.0, 1e3)?;
            check(
                "risk.sequential.reference_se",
                self.reference_se[m],
                0.0,
                1e3,
            )?;
        }
        if let Some(cov) = &self.wander_cov {
            for (k, v) in cov.iter().enumerate() {
                let bound = if PACKED_DIAG.contains(&k) { 0.0 } else { -1e6 };
                check("risk.sequential.wander_cov", *v, bound, 1e6)?;
            }
        }
        for h in self.glr_h.iter().flatten() {
            check("risk.sequential.glr_h", *h, 1e-3, 1e9)?;
        }
        // A variance or wander below 0 (or not a number) would make a trip's clip bound
        // not a number, which f64::clamp refuses with a panic.
        for v in self.trip_var.iter().flatten().flatten() {
            check("risk.sequential.trip_var", *v, 0.0, 1e30)?;
        }
        for w in self.glr_wander.iter().flatten().flatten() {
            check("risk.sequential.glr_wander", *w, 0.0, 1e3)?;
        }
        if let Some(l) = &self.load {
            check("risk.sequential.load.theta", l.theta, -1e3, 1e3)?;
            check("risk.sequential.load.s2", l.s2, 1e-300, 1e30)?;
        }
        Ok(())
    }

    /// The healthy reference of `trips` (pooled θ0, s², mean information); thresholds are
    /// left at `h` for the caller to calibrate. `None` when the signatures are not separable
    /// on these trips.
    pub fn reference(trips: &[TripEvidence], h: f64) -> Option<SequentialConfig> {
        let mut a = [0.0; 6];
        let mut b = [0.0; N_MODES];
        for t in trips {
            for k in 0..6 {
                a[k] += t.xtx[k];
            }
            for m in 0..N_MODES {
                b[m] += t.xtr[m];
            }
        }
        let theta0 = mat_vec(&spd_inverse(&a)?, &b);
        let mut cfg = SequentialConfig {
            theta0,
            s2: [0.0; N_MODES],
            info: [0.0; N_MODES],
            h: [[h; N_SIZES]; N_MODES],
            wander: [0.0; N_MODES],
            reference_se: [0.0; N_MODES],
            load: LoadReference::measure(&theta0, trips),
            wander_cov: None,
            glr_h: Some([h; N_MODES]),
            trip_var: None,
            glr_wander: None,
        };
        let (mut ss, mut si) = ([0.0; N_MODES], [0.0; N_MODES]);
        for t in trips {
            let (score, info) = cfg.score(t);
            for m in 0..N_MODES {
                ss[m] += score[m] * score[m];
                si[m] += info[m];
            }
        }
        let n = trips.len().max(1) as f64;
        for m in 0..N_MODES {
            if !(si[m] > 0.0 && ss[m] > 0.0) {
                return None;
            }
            cfg.s2[m] = ss[m] / si[m];
            cfg.info[m] = si[m] / n;
        }
        cfg.trip_var = Some(cfg.trip_variance(trips));
        cfg.wander = cfg.block_wander(trips);
        cfg.wander_cov = cfg.block_wander_cov(trips);
        // After the blocks' wander, which a length too long for two windows falls back to.
        cfg.glr_wander = Some(cfg.glr_wander(trips));
        cfg.reference_se = cfg.day_spread(trips);
        Some(cfg)
    }

    /// [`SequentialConfig::reference_se`], as the error of a random-effects mean over the
    /// training's calendar days (DerSimonian & Laird, 1986): day d gives y_d = Σscore/ΣI with
    /// noise v_d = s²/I_d; the spread between days beyond that noise is
    /// τ² = max(0, (Q − (n − 1))/(Σw − Σw²/Σw)), Q = Σ w_d (y_d − ȳ_w)², w_d = 1/v_d, and
    /// θ0's error as a new day's level is 1/√Σ 1/(v_d + τ²). Days weigh by their trips, so a
    /// trip past the last midnight is not a day. A training within one day cannot show a
    /// day's level: τ is then the block wander.
    fn day_spread(&self, trips: &[TripEvidence]) -> [f64; N_MODES] {
        let mut out = [0.0; N_MODES];
        // The reference's spread is measured between calendar days of training (and the
        // calibration takes the heating out of each such day with the other days' β).
        let day = |t: &TripEvidence| (t.start / DAY_S).floor();
        for m in 0..N_MODES {
            let mut days: Vec<(f64, f64)> = Vec::new();
            let mut current = None;
            let (mut s, mut i) = (0.0, 0.0);
            for t in trips {
                let d = day(t);
                if current.is_some_and(|c| c != d) && i > 0.0 {
                    days.push((s / i, self.s2[m] / i));
                    (s, i) = (0.0, 0.0);
                }
                current = Some(d);
                let (score, info) = self.score(t);
                s += score[m];
                i += info[m];
            }
            if i > 0.0 {
                days.push((s / i, self.s2[m] / i));
            }
            let tau2 = if days.len() >= 2 {
                let w: Vec<f64> = days.iter().map(|d| 1.0 / d.1).collect();
                let sw: f64 = w.iter().sum();
                let mean = days.iter().zip(&w).map(|(d, w)| w * d.0).sum::<f64>() / sw;
                let q: f64 = days
                    .iter()
                    .zip(&w)
                    .map(|(d, w)| w * (d.0 - mean).powi(2))
                    .sum();
                let c = sw - w.iter().map(|w| w * w).sum::<f64>() / sw;
                ((q - (days.len() - 1) as f64) / c).max(0.0)
            } else {
                self.wander[m] * self.wander[m]
            };
            let precision: f64 = days.iter().map(|d| 1.0 / (d.1 + tau2)).sum();
            out[m] = (1.0 / precision).sqrt();
        }
        out
    }

    /// A trip's healthy score variance per mode as a·info + b, fitted to the training's
    /// squared scores by least squares weighted by the variance itself (iteratively
    /// reweighted, as for any variance function: var(score²) = 2·var² for a Gaussian score),
    /// a and b at least 0:
    ///
    /// ```text
    /// E[score_m²] = a_m·info_m + b_m       info_m = mean x_m² of the trip
    /// ```
    ///
    /// a is the noise of the moving samples, which a trip gathers in proportion to its
    /// length; b what every trip carries whatever its length: the transients at its start and
    /// stop, where the 1 Hz samples blur the acceleration and the channels' lags misalign it.
    /// The pooled s² (b = 0) takes a short trip's error for noise of a long one's kind: on a
    /// simulated 630 kg car a fifth of the trips, the shortest, had s² of 0.27 per unit
    /// information along the motor signature, the longest fifth 0.046; a run of ten short hops
    /// read as a change of 6 standard errors a trip.
    pub fn trip_variance(&self, trips: &[TripEvidence]) -> [[f64; 2]; N_MODES] {
        std::array::from_fn(|m| {
            let data: Vec<(f64, f64)> = trips
                .iter()
                .map(|t| {
                    let (score, info) = self.score(t);
                    (info[m], score[m] * score[m])
                })
                .filter(|(i, q)| *i > 0.0 && q.is_finite())
                .collect();
            let (mut a, mut b) = (self.s2[m], 0.0);
            for _ in 0..TRIP_VARIANCE_PASSES {
                // Normal equations of Σ w·(q − a·i − b)², w = 1/v².
                let (mut sii, mut si, mut s1, mut siq, mut sq) = (0.0, 0.0, 0.0, 0.0, 0.0);
                for &(i, q) in &data {
                    let v = a * i + b;
                    let w = 1.0 / (v * v);
                    sii += w * i * i;
                    si += w * i;
                    s1 += w;
                    siq += w * i * q;
                    sq += w * q;
                }
                let det = sii * s1 - si * si;
                let (na, nb) = if det > 0.0 {
                    ((s1 * siq - si * sq) / det, (sii * sq - si * siq) / det)
                } else {
                    (f64::NAN, f64::NAN)
                };
                (a, b) = if na > 0.0 && nb >= 0.0 {
                    (na, nb)
                } else {
                    // The constraint binds: the pooled fit with b = 0.
                    (self.s2[m], 0.0)
                };
            }
            [a, b]
        })
    }

    /// The healthy wander of each signature's level between consecutive windows of each GLR
    /// length L, beyond their noise: √max(0, mean (y_b − ȳ)² − mean Σv/I_b²) over blocks b
    /// of L trips, y_b = Σ score/I_b, v each trip's variance ([`SequentialConfig::trip_variance`]).
    /// A GLR window of L trips carries the wander of its own scale: a run of odd trips within
    /// an hour (a busy morning's loaded hops) moves a window of twenty more than the blocks of
    /// fifty the CUSUMs' wander is measured on, which average it away.
    pub fn glr_wander(&self, trips: &[TripEvidence]) -> [[f64; GLR_N]; N_MODES] {
        std::array::from_fn(|m| {
            std::array::from_fn(|l| {
                let blocks: Vec<(f64, f64)> = trips
                    .chunks_exact(GLR_LENGTHS[l])
                    .map(|b| {
                        let (s, i, v) = b.iter().fold((0.0, 0.0, 0.0), |(s, i, v), t| {
                            let (score, info) = self.score(t);
                            (s + score[m], i + info[m], v + self.trip_var_of(m, info[m]))
                        });
                        (s / i, v / (i * i))
                    })
                    .collect();
                level_wander(&blocks).unwrap_or(self.wander[m])
            })
        })
    }

    /// What a GLR window of the `l`-th length carries beyond its trips' noise, per unit W²:
    /// the wander of its scale and θ0's error.
    fn glr_floor(&self, m: usize, l: usize) -> f64 {
        let wander = match &self.glr_wander {
            Some(w) => w[m][l],
            None => self.wander[m],
        };
        wander * wander + self.reference_se[m] * self.reference_se[m]
    }

    /// The healthy variance of one trip's score along signature `m` with information `info`.
    fn trip_var_of(&self, m: usize, info: f64) -> f64 {
        match &self.trip_var {
            Some(v) => v[m][0] * info + v[m][1],
            None => self.s2[m] * info,
        }
    }

    /// sd of the single-signature coefficient between blocks of [`WANDER_BLOCK_TRIPS`]
    /// trips, less their own noise: √max(0, mean (y_b − ȳ)² − mean s²/I_b), with
    /// y_b = Σ score/Σ info of block b and I_b its information.
    fn block_wander(&self, trips: &[TripEvidence]) -> [f64; N_MODES] {
        let mut out = [0.0; N_MODES];
        for m in 0..N_MODES {
            let blocks: Vec<(f64, f64)> = trips
                .chunks_exact(WANDER_BLOCK_TRIPS)
                .map(|b| {
                    let (s, i) = b.iter().fold((0.0, 0.0), |(s, i), t| {
                        let (score, info) = self.score(t);
                        (s + score[m], i + info[m])
                    });
                    (s / i, self.s2[m] / i)
                })
                .collect();
            if let Some(w) = level_wander(&blocks) {
                out[m] = w;
            }
        }
        out
    }

    /// Σ_w, the joint wander: the covariance of the three coefficients fitted jointly on
    /// each block of [`WANDER_BLOCK_TRIPS`] trips, θ_b = W_b⁻¹·S_b, less their mean noise
    /// s²·W_b⁻¹ (s² the largest of the three), its positive semi-definite part
    /// ([`crate::linalg::psd_part3`]). `None` with fewer than [`MIN_WANDER_BLOCKS`] blocks.
    fn block_wander_cov(&self, trips: &[TripEvidence]) -> Option<[f64; 6]> {
        let s2 = self.largest_s2();
        let mut thetas: Vec<[f64; N_MODES]> = Vec::new();
        let mut noise = [[0.0; N_MODES]; N_MODES];
        for block in trips.chunks_exact(WANDER_BLOCK_TRIPS) {
            let mut sums = Cusum::default();
            for t in block {
                sums.add(&self.score(t).0, &t.xtx);
            }
            let Some(inv) = spd_inverse(&sums.w) else {
                continue;
            };
            let theta = mat_vec(&inv, &sums.s);
            if !theta.iter().all(|v| v.is_finite()) {
                continue;
            }
            thetas.push(theta);
            for i in 0..N_MODES {
                for j in 0..N_MODES {
                    noise[i][j] += s2 * inv[i][j];
                }
            }
        }
        if thetas.len() < MIN_WANDER_BLOCKS {
            return None;
        }
        let n = thetas.len() as f64;
        let mean: [f64; N_MODES] =
            std::array::from_fn(|m| thetas.iter().map(|t| t[m]).sum::<f64>() / n);
        let excess: [[f64; N_MODES]; N_MODES] = std::array::from_fn(|i| {
            std::array::from_fn(|j| {
                let spread = thetas
                    .iter()
                    .map(|t| (t[i] - mean[i]) * (t[j] - mean[j]))
                    .sum::<f64>()
                    / (n - 1.0);
                spread - noise[i][j] / n
            })
        });
        Some(pack(&crate::linalg::psd_part3(excess)))
    }

    /// A trip's score per mode: mean(x_m·r_U) − (mean(x·xᵀ)·θ0)_m.
    pub(crate) fn trip_score(&self, t: &TripEvidence) -> [f64; N_MODES] {
        self.score(t).0
    }

    /// What a trip's CUSUM increments take from its x·xᵀ alone ([`TripWeights`]).
    pub(crate) fn weights(&self, xtx: &[f64; 6]) -> TripWeights {
        let (healthy, info) = self.healthy_and_info(xtx);
        TripWeights {
            healthy,
            root: std::array::from_fn(|m| (self.s2[m] * info[m]).sqrt()),
            reference: std::array::from_fn(|m| REFERENCE_Z * self.reference_se[m] * info[m]),
            nu: std::array::from_fn(|m| {
                std::array::from_fn(|j| self.delta(m, j) * (info[m] / self.s2[m]).sqrt())
            }),
        }
    }

    /// (x·xᵀ·θ0)_m, the healthy part of a trip's score, and its information (x·xᵀ)_mm.
    fn healthy_and_info(&self, xtx: &[f64; 6]) -> ([f64; N_MODES], [f64; N_MODES]) {
        let x = unpack(xtx);
        let mut healthy = [0.0; N_MODES];
        let mut info = [0.0; N_MODES];
        for m in 0..N_MODES {
            healthy[m] = (0..N_MODES).map(|j| x[m][j] * self.theta0[j]).sum();
            info[m] = x[m][m];
        }
        (healthy, info)
    }

    /// Each CUSUM's increment ν·u − ν²/2 for one trip's score, per mode and size, with the
    /// trip's [`TripWeights`]: in standardised units u = score/(s·√info) (clipped),
    /// ν = δ·√info/s; the reference size counts only the score beyond [`REFERENCE_Z`] of
    /// θ0's error.
    fn increments(&self, score: &[f64; N_MODES], w: &TripWeights) -> [[f64; N_SIZES]; N_MODES] {
        std::array::from_fn(|m| {
            let root = w.root[m];
            let standardised = |score: f64| {
                if root > 0.0 {
                    (score / root).clamp(-CLIP, CLIP)
                } else {
                    0.0
                }
            };
            let u = standardised(score[m]);
            let u_beyond = standardised(score[m] - w.reference[m]);
            std::array::from_fn(|j| {
                let u = if j == REFERENCE_SIZE { u_beyond } else { u };
                gaussian_llr(w.nu[m][j], u)
            })
        })
    }

    /// A trip's score per mode for its regression sums x·r and its [`TripWeights`]:
    /// mean(x_m·r_U) − (mean(x·xᵀ)·θ0)_m.
    fn score_of(xtr: &[f64; N_MODES], w: &TripWeights) -> [f64; N_MODES] {
        std::array::from_fn(|m| xtr[m] - w.healthy[m])
    }

    /// Score and information of one trip per mode.
    fn score(&self, t: &TripEvidence) -> ([f64; N_MODES], [f64; N_MODES]) {
        let (healthy, info) = self.healthy_and_info(&t.xtx);
        (std::array::from_fn(|m| t.xtr[m] - healthy[m]), info)
    }
}

/// What a trip's CUSUM increments take from its x·xᵀ alone, per mode (and size): the healthy
/// part of its score (x·xᵀ·θ0), s·√info, the reference's allowance z·se0·info and ν. The
/// monitor forms them once per trip; the calibration's bootstraps, which draw each healthy
/// trip thousands of times with its score moved by an hour's level but its x·xᵀ unchanged,
/// form them once per trip of the record (their fifteen square roots were most of a
/// bootstrapped trip's decision).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct TripWeights {
    healthy: [f64; N_MODES],
    root: [f64; N_MODES],
    reference: [f64; N_MODES],
    nu: [[f64; N_SIZES]; N_MODES],
}

/// The window's sums weighted by its time τ (days since its first trip), for the line
/// θ + β·τ through its trips.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SlopeSums {
    /// Start of the window's first trip (s).
    #[serde(with = "exact")]
    pub t0: f64,
    /// τ of the window's last trip (days).
    #[serde(with = "exact")]
    pub tau_end: f64,
    /// Σ τ·score, per mode.
    #[serde(with = "exact::array")]
    pub s1: [f64; N_MODES],
    /// Σ τ·x·xᵀ (packed upper triangle).
    #[serde(with = "exact::array")]
    pub w1: [f64; 6],
    /// Σ τ²·x·xᵀ (packed upper triangle).
    #[serde(with = "exact::array")]
    pub w2: [f64; 6],
    /// The further sums of each signature's curve alone; `None` in a window a state saved
    /// before they were kept had begun (its named drift is then read from the line).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub curve: Option<CurveSums>,
}

/// The sums beyond [`SlopeSums`]' that the curve θ + β·τ + γ·τ² of one signature alone
/// needs (`alone_curve`): its 3×3 normal equations take Σ τᵏ·x_m² for k up to 4 and
/// Σ τᵏ·score_m for k up to 2.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CurveSums {
    /// Σ τ²·score, per mode.
    #[serde(with = "exact::array")]
    pub s2: [f64; N_MODES],
    /// Σ τ³·x_m², per mode.
    #[serde(with = "exact::array")]
    pub w3: [f64; N_MODES],
    /// Σ τ⁴·x_m², per mode.
    #[serde(with = "exact::array")]
    pub w4: [f64; N_MODES],
}

impl SlopeSums {
    /// The sums of a window whose first trip started at `t0`, before any trip is added.
    fn starting(t0: f64) -> SlopeSums {
        SlopeSums {
            t0,
            curve: Some(CurveSums::default()),
            ..SlopeSums::default()
        }
    }

    /// Whether the window spans [`SLOPE_MIN_DAYS`], enough time for its line (false for a
    /// time that is not a number).
    fn spans_line(&self) -> bool {
        self.tau_end >= SLOPE_MIN_DAYS
    }

    /// Adds a trip that started at `start` with its score and x·xᵀ, τ days after the window's
    /// first trip.
    fn add(&mut self, start: f64, score: &[f64; N_MODES], xtx: &[f64; 6]) {
        let tau = (start - self.t0) / DAY_S;
        self.tau_end = tau;
        for i in 0..N_MODES {
            self.s1[i] += tau * score[i];
        }
        for k in 0..6 {
            self.w1[k] += tau * xtx[k];
            self.w2[k] += tau * tau * xtx[k];
        }
        if let Some(cu) = &mut self.curve {
            let tau2 = tau * tau;
            for m in 0..N_MODES {
                let x2 = xtx[PACKED_DIAG[m]];
                cu.s2[m] += tau2 * score[m];
                cu.w3[m] += tau2 * tau * x2;
                cu.w4[m] += tau2 * tau2 * x2;
            }
        }
    }
}

/// One CUSUM with the sums of the window it holds as changed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Cusum {
    /// G: the log-likelihood ratio of the change against none, maximised over its start.
    #[serde(with = "exact")]
    pub g: f64,
    /// Trips in the window (since G last left 0).
    pub trips: u32,
    /// Σ score over the window, per mode.
    #[serde(with = "exact::array")]
    pub s: [f64; N_MODES],
    /// Σ x·xᵀ over the window (packed upper triangle).
    #[serde(with = "exact::array")]
    pub w: [f64; 6],
    /// The time-weighted sums of the window; `None` in a window a state saved before they
    /// were kept had begun (its drift is then the window's mean until the window restarts).
    #[serde(default)]
    pub slope: Option<SlopeSums>,
    /// Σ load score over the window (V² per unit λ); 0 in a window a state saved before it
    /// was kept had begun.
    #[serde(with = "exact", default)]
    pub load_score: f64,
    /// Σ mean x_load² over the window.
    #[serde(with = "exact", default)]
    pub load_info: f64,
}

impl Cusum {
    /// Adds one trip's score and x·xᵀ to the window's sums.
    fn add(&mut self, score: &[f64; N_MODES], xtx: &[f64; 6]) {
        for (s, x) in self.s.iter_mut().zip(score) {
            *s += x;
        }
        for (w, x) in self.w.iter_mut().zip(xtx) {
            *w += x;
        }
    }
}

/// What the sequential decision concluded after one trip.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Decision {
    /// max G/h over the bank: at least 1 when a change is detected.
    #[serde(with = "exact")]
    pub ratio: f64,
    /// The mode the leading window's likelihoods point at.
    pub mode: FaultMode,
    /// Drift of the leading window (motor, brake, friction; relative units), NaN when the
    /// window does not separate the signatures or the ratio is below the caller's
    /// `drift_from` ([`Sequential::push`]).
    #[serde(with = "exact::array")]
    pub drift: [f64; N_MODES],
    /// Standard errors of those drifts.
    #[serde(with = "exact::array")]
    pub drift_se: [f64; N_MODES],
    /// Trips in the leading window.
    pub window_trips: u32,
    /// Signature of the leading CUSUM (the one nearest its threshold).
    pub lead_signature: FaultMode,
    /// Its change size ν, in standard errors of one trip; when the GLR leads, the size its
    /// window shows.
    pub lead_size: f64,
    /// Whether the window-limited GLR leads ([`Sequential::glr`]) rather than a CUSUM.
    #[serde(default)]
    pub lead_glr: bool,
    /// The bound the leading statistic clipped each trip's score at, in standard deviations
    /// of a trip: [`CLIP`], or the GLR window's own where nearly all its trips showed the
    /// change ([`Glr::bound`]).
    #[serde(with = "exact", default = "clip")]
    pub lead_bound: f64,
    /// The CUSUMs' own largest G/h (`ratio` is the larger of it and the GLR's z²/h); 0 in
    /// decisions saved before it was kept.
    #[serde(with = "exact", default)]
    pub cusum_ratio: f64,
    /// Log-likelihood ratio of each signature alone (motor, brake, friction) against no
    /// change on the leading window, z_m²/2: the evidence the mode is named from, and the
    /// reason when it is `unknown` (the best does not lead the runner-up by ln
    /// [`ISOLATION_ODDS`]).
    #[serde(with = "exact::array", default)]
    pub isolation: [f64; N_MODES],
    /// The same for the load cell's zero (z_L²/2): `sensor` is named when it leads.
    #[serde(with = "exact", default)]
    pub isolation_load: f64,
    /// The load cell's zero offset the leading window shows alone (share of the rated load,
    /// + when the cell reads high), NaN without a load reference.
    #[serde(with = "exact", default)]
    pub load_offset: f64,
    /// The mode the machine signatures alone point at on the leading window (`unknown` when
    /// none leads by the odds): the decision's when the load cell's zero is ruled out.
    #[serde(default)]
    pub machine_mode: FaultMode,
    /// When the leading window's first trip began (s); NaN when it is not known (a window a
    /// state saved before it was kept had begun).
    #[serde(with = "exact", default = "crate::exact::nan")]
    pub window_start: f64,
    /// Log-likelihood ratio of the three signatures together against the named mode's alone
    /// on the trips the drifts are read from, χ²/2 of χ² on two degrees of freedom (three
    /// signatures against one): how far those trips depart from one mode's change. The
    /// drifts' standard errors are widened by √misfit where that exceeds 1 (the Birge ratio
    /// √(χ²/2)). 0 while no drifts are read (and in decisions saved before it was kept).
    #[serde(with = "exact", default)]
    pub misfit: f64,
}

impl Decision {
    /// Whether only the window-limited GLR holds a change: it leads and no CUSUM has crossed
    /// (such a crossing must stand before it raises: [`crate::alarm::GLR_HOLD_S`]).
    pub fn glr_alone(&self) -> bool {
        self.lead_glr && self.cusum_ratio < 1.0
    }
}

/// Trips kept for the change point of a window's drift: the block size the healthy wander is
/// measured on ([`WANDER_BLOCK_TRIPS`]); an hour or two of a busy car, a morning of a quiet
/// one.
pub const RECENT_TRIPS: usize = WANDER_BLOCK_TRIPS;

/// The shortest run of trips a change point may leave after it: a suffix of one or two odd
/// trips is not a level, and the odds a shorter suffix must beat the whole window by keep
/// noise from choosing one. Five: the GLR decides a large step once its shortest window
/// holds it, which can be after eight of its trips, and a change point held at ten read
/// such steps a fifth low (the window's two healthy trips), 2 standard errors and more.
pub const CHANGE_POINT_MIN_TRIPS: usize = 5;

/// One trip's score and x·xᵀ, as the recent block keeps them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RecentTrip {
    /// Score per mode.
    #[serde(with = "exact::array")]
    pub score: [f64; N_MODES],
    /// x·xᵀ (packed upper triangle).
    #[serde(with = "exact::array")]
    pub xtx: [f64; 6],
    /// The score as the GLR sums it: clipped to ±[`CLIP`] of the trip's healthy sd
    /// (0 in a state saved before it was kept, which then adds nothing to a GLR window).
    #[serde(with = "exact::array", default)]
    pub clipped: [f64; N_MODES],
    /// The trip's load score and Σ mean x_load² (a GLR window's load-cell hypothesis).
    #[serde(with = "exact::array", default)]
    pub load: [f64; 2],
    /// Start of the trip (s); NaN in a state saved before it was kept.
    #[serde(with = "exact", default = "crate::exact::nan")]
    pub start: f64,
}

impl RecentTrip {
    /// The trip of `score`, x·xᵀ `xtx`, load score and information `load`, started at
    /// `start`, with its variance and score clipped for the GLR.
    fn new(
        cfg: &SequentialConfig,
        score: [f64; N_MODES],
        xtx: [f64; 6],
        load: [f64; 2],
        start: f64,
    ) -> RecentTrip {
        let var: [f64; N_MODES] = std::array::from_fn(|m| cfg.trip_var_of(m, xtx[PACKED_DIAG[m]]));
        RecentTrip {
            score,
            xtx,
            clipped: std::array::from_fn(|m| {
                // Clipped only beyond the bound: its square root is taken for the few trips
                // that reach it.
                if score[m] * score[m] <= CLIP * CLIP * var[m] {
                    score[m]
                } else {
                    let bound = CLIP * var[m].sqrt();
                    score[m].clamp(-bound, bound)
                }
            }),
            load,
            start,
        }
    }

    /// Adds `sign` (1 or −1) to the count of trips beyond the clip, high, and that times this
    /// trip's information to their information, along each signature along which it is.
    fn add_high(&self, high: &mut [f64; N_MODES], high_info: &mut [f64; N_MODES], sign: f64) {
        for m in 0..N_MODES {
            if self.clipped[m] < self.score[m] {
                high[m] += sign;
                high_info[m] += sign * self.xtx[PACKED_DIAG[m]];
            }
        }
    }
}

/// Window lengths of the window-limited GLR, in trips (the newest last), each about 1.5
/// times the one before, up to the recent block ([`RECENT_TRIPS`]). Lai's GLR maximises over
/// every length; a change of length L is seen by a window between L/√q and L·√q on a grid of
/// ratio q, which keeps about 1/√q ≈ four fifths of its z², for a tenth of the evaluations
/// (three lengths of the 31 from twenty to fifty). The shortest is twenty: on the field-like evaluation windows of ten and
/// fifteen were crossed on healthy days by runs of five to ten odd trips (a busy morning's
/// short hops on the 40-floor car, 5 to 17 standard errors each), which twenty dilute below
/// the threshold, and a window must hold the information of twenty mean trips as well
/// ([`glr`]).
pub const GLR_LENGTHS: [usize; GLR_N] = [20, 30, 50];

/// Number of the GLR's window lengths.
pub const GLR_N: usize = 3;

const _: () = assert!(GLR_LENGTHS[0] >= CHANGE_POINT_MIN_TRIPS);
const _: () = assert!(GLR_LENGTHS[GLR_LENGTHS.len() - 1] <= RECENT_TRIPS);

/// The CUSUM bank of one elevator: one per mode and size.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Sequential {
    /// The CUSUMs, per mode and size.
    pub bank: [[Cusum; N_SIZES]; N_MODES],
    /// The last [`RECENT_TRIPS`] usable trips, newest last; empty in a state saved before it
    /// was kept (a change point is then looked for only among the trips kept since).
    #[serde(default)]
    pub recent: std::collections::VecDeque<RecentTrip>,
    /// The window-limited GLR after the last trip, per mode ([`Sequential::glr`]); zeros in a
    /// state saved before it was kept.
    #[serde(default)]
    pub glr: [Glr; N_MODES],
    /// The sums of the GLR's windows over the recent trips, kept as trips come and go;
    /// `None` until the first trip (and in a state saved before they were kept), when they
    /// are summed from the recent trips.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub glr_sums: Option<[GlrSums; GLR_N]>,
}

/// The sums of one GLR window, per mode: Σ clipped score, Σ information, Σ each trip's own
/// variance ([`glr`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct GlrSums {
    /// Σ clipped score.
    #[serde(with = "exact::array")]
    pub s: [f64; N_MODES],
    /// Σ info.
    #[serde(with = "exact::array")]
    pub w: [f64; N_MODES],
    /// Σ v.
    #[serde(with = "exact::array")]
    pub v: [f64; N_MODES],
    /// The trips beyond the clip, high, along each signature: a window where they are
    /// [`CONSISTENT_SHARE`] of its trips, or carry that share of its information, is read at
    /// its own bound ([`glr`]). NaN in a state saved before it was kept, when it is counted
    /// anew from the recent trips, as is `high_info`.
    #[serde(with = "exact::array", default = "crate::exact::nan_array")]
    pub high: [f64; N_MODES],
    /// Σ info of those trips.
    #[serde(with = "exact::array", default = "crate::exact::nan_array")]
    pub high_info: [f64; N_MODES],
}

impl GlrSums {
    /// Adds the trip `r` (`sign` 1) or takes it out (−1).
    #[inline]
    fn add(&mut self, cfg: &SequentialConfig, r: &RecentTrip, sign: f64) {
        for m in 0..N_MODES {
            let info = r.xtx[PACKED_DIAG[m]];
            self.s[m] += sign * r.clipped[m];
            self.w[m] += sign * info;
            self.v[m] += sign * cfg.trip_var_of(m, info);
        }
        r.add_high(&mut self.high, &mut self.high_info, sign);
    }
}

/// The window-limited GLR of one signature: the largest z² over the windows of
/// [`GLR_LENGTHS`] ending at the last trip, and that window's length.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Glr {
    /// z² of the best window (0 when no window's score rose).
    #[serde(with = "exact")]
    pub z2: f64,
    /// Its length in trips.
    pub trips: u32,
    /// The bound its trips' scores were clipped at, in standard deviations of a trip:
    /// [`CLIP`], or the window's own where nearly all its trips showed the change
    /// (`own_bound_sum`); [`CLIP`] in a state saved before it was kept.
    #[serde(with = "exact", default = "clip")]
    pub bound: f64,
}

/// [`CLIP`], the default bound of a window saved before its bound was kept.
pub fn clip() -> f64 {
    CLIP
}

impl Sequential {
    /// Takes one usable trip and returns the decision; its drifts are estimated only when
    /// the leading G/h is at least `drift_from` (NaN below: the risk tracker reports them from
    /// its release ratio on, and a healthy trip's window would spend most of the step, and of
    /// the calibration's ten bootstrapped years, on a drift nobody reads).
    pub fn push(&mut self, cfg: &SequentialConfig, t: &TripEvidence, drift_from: f64) -> Decision {
        let w = cfg.weights(&t.xtx);
        let score = SequentialConfig::score_of(&t.xtr, &w);
        let load_score = cfg.load.map_or(0.0, |l| l.score(&cfg.theta0, t));
        let llr = cfg.increments(&score, &w);
        let mut lead = (0usize, 0usize, 0.0f64);
        for m in 0..N_MODES {
            for j in 0..N_SIZES {
                let c = &mut self.bank[m][j];
                c.g += llr[m][j];
                if c.g <= 0.0 {
                    *c = Cusum::default();
                    continue;
                }
                if c.trips == 0 {
                    c.slope = Some(SlopeSums::starting(t.start));
                }
                c.trips = c.trips.saturating_add(1);
                c.add(&score, &t.xtx);
                c.load_score += load_score;
                c.load_info += t.load.ll;
                if let Some(sl) = &mut c.slope {
                    sl.add(t.start, &score, &t.xtx);
                }
                let r = c.g / cfg.h[m][j];
                if r > lead.2 {
                    lead = (m, j, r);
                }
            }
        }
        self.remember(
            cfg,
            RecentTrip::new(cfg, score, t.xtx, [load_score, t.load.ll], t.start),
        );
        // The GLR leads when it is nearer its threshold than every CUSUM: its window is the
        // recent trips it found changed.
        let glr_window = self
            .glr_lead(cfg)
            .filter(|g| g.1 > lead.2)
            .map(|(m, r)| (m, r, self.suffix(self.glr[m].trips as usize)));
        let (c, ratio, signature, size, start) = match &glr_window {
            Some((m, r, window)) => {
                let k = PACKED_DIAG[*m];
                let size = if window.w[k] > 0.0 {
                    window.s[*m] / window.w[k] / cfg.trip_se(*m)
                } else {
                    f64::NAN
                };
                let start = self.recent[self.recent.len() - window.trips as usize].start;
                (window, *r, *m, size, start)
            }
            None => {
                let c = &self.bank[lead.0][lead.1];
                let start = c.slope.map_or(f64::NAN, |sl| sl.t0);
                (c, lead.2, lead.0, SIZES[lead.1], start)
            }
        };
        let (mode, machine_mode, isolation, isolation_load) = if c.trips > 0 {
            isolate(cfg, c)
        } else {
            (FaultMode::Unknown, FaultMode::Unknown, [0.0; N_MODES], 0.0)
        };
        let (drift, drift_se, misfit) = if ratio >= drift_from {
            // A window without a line (under SLOPE_MIN_DAYS) reports its level since the
            // change point the recent trips show, which is the window's own start unless a
            // later one explains them better; a window with a line reports the line's level
            // now, unless a step among the recent trips explains it better.
            let read_as = leaning(machine_mode, &isolation);
            let m = if read_as.is_machine() {
                read_as as usize
            } else {
                signature
            };
            // The GLR's window is at most the recent block: on a ramp that began hours
            // before, the line of the mode's own CUSUM window reads where it stands now.
            let c = match &glr_window {
                Some(_) => self.bank[m]
                    .iter()
                    .filter(|b| b.slope.is_some_and(|sl| sl.spans_line()))
                    .max_by_key(|b| b.trips)
                    .unwrap_or(c),
                None => c,
            };
            let since = if c.slope.is_some_and(|sl| sl.spans_line()) {
                self.step_beyond_trend(c, m, cfg.s2[m])
            } else {
                self.since_change(c, m, cfg.s2[m])
            };
            drifts(cfg, since.as_ref().unwrap_or(c), read_as)
        } else {
            ([f64::NAN; N_MODES], [f64::NAN; N_MODES], 0.0)
        };
        Decision {
            ratio,
            mode,
            isolation,
            drift,
            drift_se,
            window_trips: c.trips,
            lead_signature: MACHINE_MODES[signature],
            lead_size: size,
            lead_glr: glr_window.is_some(),
            lead_bound: glr_window.as_ref().map_or(CLIP, |g| self.glr[g.0].bound),
            cusum_ratio: lead.2,
            isolation_load,
            machine_mode,
            window_start: start,
            misfit,
            load_offset: if cfg.load.is_some() && c.load_info > 0.0 {
                -c.load_score / c.load_info
            } else {
                f64::NAN
            },
        }
    }

    /// Keeps `trip` as the newest of the recent block and updates the GLR ([`Sequential::glr`]).
    fn remember(&mut self, cfg: &SequentialConfig, trip: RecentTrip) {
        if cfg.glr_h.is_some() {
            let recent = &self.recent;
            let sums = self.glr_sums.get_or_insert_with(|| {
                std::array::from_fn(|l| {
                    let mut w = GlrSums::default();
                    for r in recent.iter().rev().take(GLR_LENGTHS[l]) {
                        w.add(cfg, r, 1.0);
                    }
                    w
                })
            });
            let lost = |w: &GlrSums| w.high.iter().chain(&w.high_info).any(|h| h.is_nan());
            if sums.iter().any(lost) {
                for (l, w) in sums.iter_mut().enumerate() {
                    (w.high, w.high_info) = ([0.0; N_MODES], [0.0; N_MODES]);
                    for r in recent.iter().rev().take(GLR_LENGTHS[l]) {
                        r.add_high(&mut w.high, &mut w.high_info, 1.0);
                    }
                }
            }
            let n = recent.len();
            for (l, w) in sums.iter_mut().enumerate() {
                w.add(cfg, &trip, 1.0);
                if n >= GLR_LENGTHS[l] {
                    w.add(cfg, &recent[n - GLR_LENGTHS[l]], -1.0);
                }
            }
        }
        while self.recent.len() >= RECENT_TRIPS {
            self.recent.pop_front();
        }
        self.recent.push_back(trip);
        if let (Some(_), Some(sums)) = (cfg.glr_h, &self.glr_sums) {
            self.glr = glr(cfg, sums, &self.recent);
        }
    }

    /// The mode whose GLR is nearest its threshold, with its z²/h; `None` without GLR
    /// thresholds or while no window rose.
    fn glr_lead(&self, cfg: &SequentialConfig) -> Option<(usize, f64)> {
        let h = cfg.glr_h?;
        let (m, r) = (0..N_MODES)
            .map(|m| (m, self.glr[m].z2 / h[m]))
            .fold((0, 0.0f64), |a, b| if b.1 > a.1 { b } else { a });
        (r > 0.0).then_some((m, r))
    }

    /// The last `n` recent trips as one window, with its time-weighted sums for the line
    /// when their start times are known (a window spanning the night reads where a ramp
    /// stands now, not its mean: [`SLOPE_MIN_DAYS`]).
    fn suffix(&self, n: usize) -> Cusum {
        let first = self.recent.len().saturating_sub(n);
        let t0 = self.recent.get(first).map_or(f64::NAN, |r| r.start);
        let mut c = Cusum {
            slope: t0.is_finite().then(|| SlopeSums::starting(t0)),
            ..Cusum::default()
        };
        for r in self.recent.iter().skip(first) {
            c.add(&r.score, &r.xtx);
            c.load_score += r.load[0];
            c.load_info += r.load[1];
            c.trips += 1;
            if let Some(sl) = &mut c.slope {
                sl.add(r.start, &r.score, &r.xtx);
            }
        }
        c
    }

    /// Advances the CUSUMs' G by one usable trip (its x·r and the [`TripWeights`] of its x·xᵀ)
    /// as [`Sequential::push`] does, and returns the ratio its decision would carry (max G/h
    /// over the bank), without the windows' sums, the isolation or the drifts: all that the
    /// calibration's bootstraps read of their ten years of trips, where the rest was most of
    /// the decision's cost. A bank advanced this way holds G alone (its windows stay empty),
    /// so it is not one whose decisions are read.
    pub(crate) fn advance_g(
        &mut self,
        cfg: &SequentialConfig,
        xtr: &[f64; N_MODES],
        xtx: &[f64; 6],
        w: &TripWeights,
    ) -> f64 {
        let score = SequentialConfig::score_of(xtr, w);
        let llr = cfg.increments(&score, w);
        let mut ratio = 0.0f64;
        for m in 0..N_MODES {
            for j in 0..N_SIZES {
                let c = &mut self.bank[m][j];
                c.g += llr[m][j];
                if c.g <= 0.0 {
                    c.g = 0.0;
                    continue;
                }
                ratio = ratio.max(c.g / cfg.h[m][j]);
            }
        }
        self.remember(cfg, RecentTrip::new(cfg, score, *xtx, [0.0; 2], f64::NAN));
        ratio.max(self.glr_lead(cfg).map_or(0.0, |g| g.1))
    }

    /// The trips of window `c` since its most likely change point for signature `m`, as a
    /// window without time (its drift is its mean), when that point lies among the recent
    /// trips after the window's start and explains them better than the whole window by
    /// [`ISOLATION_ODDS`]; `None` when the whole window stands. `s2` is the signature's
    /// healthy noise per unit information.
    ///
    /// Window-limited GLR for a shift of unknown size (Lai, 1995): the change point is the
    /// start k of the suffix that maximises S_k²/W_k (S_k, W_k: the suffix's score and
    /// information along m), twice s² times the log-likelihood ratio of a shift from trip k
    /// on; a CUSUM's window starts where its G last left zero, which on a large step is often
    /// a few healthy trips early (a Kd step of +25 % on the 40-floor car: ten of its 52 trips
    /// were before the onset and the window's mean read +19.7 %). The odds keep a shorter
    /// suffix from winning on noise alone, which would read a homogeneous window high.
    fn since_change(&self, c: &Cusum, m: usize, s2: f64) -> Option<Cusum> {
        let k = PACKED_DIAG[m];
        let whole = step_ess(c.s[m], c.w[k]);
        self.latest_step(c, m, false)
            .filter(|b| b.0 - whole >= change_margin(s2))
            .map(|b| b.1)
    }

    /// The trips of window `c`, whose time spans a line ([`SLOPE_MIN_DAYS`]), since the
    /// change point the recent trips show for signature `m`, when a level from that point on
    /// (none before it) explains the window better than its trend ([`alone_trend`]) does, by
    /// [`ISOLATION_ODDS`]; `None` when the trend stands. A ramp reads as a trend; a step
    /// decided hours into a window that healthy wander held open does not: a step of 4
    /// standard errors after ten hours at +0.4 read 1.0 on the line (test
    /// `a_step_after_hours_of_wander_reads_its_level_and_a_ramp_its_line`), and the
    /// week-long suite's Kd steps of +5 % read +6.3 % where their step reads +5.6 %.
    fn step_beyond_trend(&self, c: &Cusum, m: usize, s2: f64) -> Option<Cusum> {
        let trend = alone_trend(c, m).map_or(0.0, |l| l.ess);
        self.latest_step(c, m, true)
            .filter(|b| b.0 - trend >= change_margin(s2))
            .map(|b| b.1)
    }

    /// The suffix of window `c` among the recent trips, at least [`CHANGE_POINT_MIN_TRIPS`]
    /// long (and shorter than the window unless `whole`), whose rise along signature `m`
    /// explains most ([`step_ess`]), with that sum; `None` when there is none.
    fn latest_step(&self, c: &Cusum, m: usize, whole: bool) -> Option<(f64, Cusum)> {
        let k = PACKED_DIAG[m];
        let mut best: Option<(f64, Cusum)> = None;
        let mut suffix = Cusum::default();
        let n = self.recent.len().min(c.trips as usize);
        for (len, r) in self.recent.iter().rev().take(n).enumerate() {
            suffix.add(&r.score, &r.xtx);
            suffix.trips = len as u32 + 1;
            let full = len + 1 == c.trips as usize;
            if len + 1 >= CHANGE_POINT_MIN_TRIPS && (whole || !full) {
                let g = step_ess(suffix.s[m], suffix.w[k]);
                if best.as_ref().map_or(true, |b| g > b.0) {
                    best = Some((g, suffix));
                }
            }
        }
        best
    }

    /// G now, per mode and size.
    pub fn g(&self) -> [[f64; N_SIZES]; N_MODES] {
        self.bank.map(|row| row.map(|c| c.g))
    }
}

/// The sd of a level between blocks beyond their own noise, √max(0, mean (y_b − ȳ)² −
/// mean v_b) over the blocks' levels y_b and noise variances v_b (those not finite left
/// out); `None` with fewer than two blocks.
fn level_wander(blocks: &[(f64, f64)]) -> Option<f64> {
    let blocks: Vec<(f64, f64)> = blocks
        .iter()
        .copied()
        .filter(|(y, v)| y.is_finite() && v.is_finite())
        .collect();
    if blocks.len() < 2 {
        return None;
    }
    let n = blocks.len() as f64;
    let mean = blocks.iter().map(|b| b.0).sum::<f64>() / n;
    let spread = blocks.iter().map(|b| (b.0 - mean).powi(2)).sum::<f64>() / (n - 1.0);
    let noise = blocks.iter().map(|b| b.1).sum::<f64>() / n;
    Some((spread - noise).max(0.0).sqrt())
}

/// The sum of squares a rise of one level explains on trips of score sum `s` and
/// information `w` along one signature, S₊²/W: twice s² times the log-likelihood ratio of
/// that level against none (a fall explains nothing: only rises are degradations).
fn step_ess(s: f64, w: f64) -> f64 {
    if w > 0.0 {
        s.max(0.0).powi(2) / w
    } else {
        0.0
    }
}

/// How much more of a window's sum of squares a change point must explain than the
/// alternative, for noise s² per unit information: the log-likelihood ratio of
/// [`ISOLATION_ODDS`].
fn change_margin(s2: f64) -> f64 {
    2.0 * s2 * ISOLATION_ODDS.ln()
}

/// The mode whose signature alone explains the window best, when it does so by the odds of
/// [`ISOLATION_ODDS`], with each signature's log-likelihood ratio z²/2 and the load cell
/// zero's; only rises (positive scores) are degradations of the machine, the cell's zero may
/// drift either way. The cell's zero is named (`sensor`) when it explains the window better
/// than the best machine mode by those odds; short of that, the machine modes are weighed
/// among themselves (returned second, whatever the cell's zero did). On a car that runs
/// mostly lighter than its counterweight a drive fault fits a zero offset almost as well as
/// its own signature (a Kd step on the evaluation's 630 kg car: 38.5 against 36.2); the odds
/// asked of the machine against the cell as well left most drive faults there `unknown`. The cell has a
/// witness of its own that the machine lacks, the parked zero check, and the monitor lets it
/// decide between the two ([`crate::sensor::SensorCheck::load_zero_shift`]).
fn isolate(cfg: &SequentialConfig, c: &Cusum) -> (FaultMode, FaultMode, [f64; N_MODES], f64) {
    let w = unpack(&c.w);
    let mut z2 = [0.0; N_MODES];
    for m in 0..N_MODES {
        let s = c.s[m].max(0.0);
        z2[m] = if w[m][m] > 0.0 {
            s * s / (cfg.s2[m] * w[m][m])
        } else {
            0.0
        };
    }
    let noise_best = z2.iter().fold(0.0f64, |a, &b| a.max(b));
    let wander = cfg
        .wander_cov
        .as_ref()
        .map(|sigma| Wander::new(&w, sigma, c));
    if let Some(wander) = &wander {
        for m in 0..N_MODES {
            z2[m] = wander.alone(cfg.s2[m], m);
        }
    }
    let z2_load = match &cfg.load {
        Some(l) if c.load_info > 0.0 => c.load_score.powi(2) / (l.s2 * c.load_info),
        _ => 0.0,
    };
    let mut order = MACHINE_MODES;
    order.sort_by(|a, b| z2[*b as usize].total_cmp(&z2[*a as usize]));
    let (best, second) = (z2[order[0] as usize], z2[order[1] as usize]);
    let odds = 2.0 * ISOLATION_ODDS.ln();
    let machine = if best - second >= odds {
        order[0]
    } else {
        FaultMode::Unknown
    };
    let rubs = |m: FaultMode| m == FaultMode::Friction || m == FaultMode::Brake;
    let machine = if rubs(order[0])
        && rubs(order[1])
        && machine != FaultMode::Brake
        && brake_beyond_friction(cfg, c, &w, wander.as_ref()) >= odds
    {
        FaultMode::Brake
    } else {
        machine
    };
    let mode = if z2_load - noise_best >= odds {
        FaultMode::Sensor
    } else {
        machine
    };
    (mode, machine, z2.map(|z| 0.5 * z), 0.5 * z2_load)
}

/// What the brake's signature adds to friction's on a window, in z² (twice the log-likelihood
/// ratio): z² of the two fitted jointly less z² of friction alone, 0 unless the joint fit
/// puts a positive drag on the brake. A dragging brake rubs a little going up too, so its
/// window carries some of the friction signature, and on a window where both rose the
/// friction signature alone can fit better than the brake's alone (the isolation's rule): on
/// the evaluation the friction CUSUM crossed first on most brake faults and named them
/// `friction`. The brake's own mark is its asymmetry (down and decelerating travel), which a
/// rise of friction in both directions does not have; when that asymmetric part explains the
/// window beyond friction by [`ISOLATION_ODDS`], the brake is named. Both scores share the
/// larger of the two healthy noise factors s².
fn brake_beyond_friction(
    cfg: &SequentialConfig,
    c: &Cusum,
    w: &[[f64; N_MODES]; N_MODES],
    wander: Option<&Wander>,
) -> f64 {
    let (b, f) = (FaultMode::Brake as usize, FaultMode::Friction as usize);
    if let Some(wander) = wander {
        return wander.beyond(cfg.s2[b].max(cfg.s2[f]), b, f);
    }
    let det = w[b][b] * w[f][f] - w[b][f] * w[b][f];
    if !(det > 0.0 && w[f][f] > 0.0) {
        return 0.0;
    }
    let (sb, sf) = (c.s[b], c.s[f]);
    let drag = (w[f][f] * sb - w[b][f] * sf) / det;
    if drag <= 0.0 {
        return 0.0;
    }
    let rub = (w[b][b] * sf - w[b][f] * sb) / det;
    let s2 = cfg.s2[b].max(cfg.s2[f]);
    let joint = (drag * sb + rub * sf) / s2;
    let friction_alone = sf.max(0.0).powi(2) / (s2 * w[f][f]);
    joint - friction_alone
}

/// A window's scores S = Σ score and information W = Σ x·xᵀ weighed against the healthy
/// noise and wander together: cov(S) = V = s²·W + (B/n)·W·Σ_w·W over n trips (the noise
/// grows with the trips; the wander with their square within one block of B, which no number
/// of its trips averages away, and with the blocks over many, which wander independently).
/// A hypothesis that the window's change lies along the columns A of W (the signatures it
/// names) is tested by its generalised least squares: z² = gᵀ·M⁻¹·g with g = Aᵀ·V⁻¹·S and
/// M = Aᵀ·V⁻¹·A. With Σ_w = 0 this is the noise-only z² of the isolation's notes. The
/// wander's share is formed once for the isolation's four tests, which differ only in s².
struct Wander {
    /// W.
    w: [[f64; N_MODES]; N_MODES],
    /// S.
    s: [f64; N_MODES],
    /// (B/n)·W·Σ_w·W.
    wsw: [[f64; N_MODES]; N_MODES],
}

impl Wander {
    fn new(w: &[[f64; N_MODES]; N_MODES], sigma: &[f64; 6], c: &Cusum) -> Wander {
        let sig = window_wander(sigma, c.trips);
        let wsw = std::array::from_fn(|i| {
            std::array::from_fn(|j| {
                (0..N_MODES)
                    .map(|k| w[i][k] * (0..N_MODES).map(|l| sig[k][l] * w[l][j]).sum::<f64>())
                    .sum()
            })
        });
        Wander { w: *w, s: c.s, wsw }
    }

    /// V⁻¹ for noise of factor `s2`; zero where V is singular, which then passes no test.
    fn v_inv(&self, s2: f64) -> [[f64; N_MODES]; N_MODES] {
        let v =
            std::array::from_fn(|i| std::array::from_fn(|j| s2 * self.w[i][j] + self.wsw[i][j]));
        spd_inverse(&pack(&v)).unwrap_or([[0.0; N_MODES]; N_MODES])
    }

    /// z² of signature `m` alone against noise of factor `s2`, 0 unless its coefficient rose.
    fn alone(&self, s2: f64, m: usize) -> f64 {
        let v_inv = self.v_inv(s2);
        let a = self.w[m];
        let (g, info) = (form(&v_inv, &a, &self.s), form(&v_inv, &a, &a));
        if g > 0.0 && info > 0.0 {
            g * g / info
        } else {
            0.0
        }
    }

    /// z² of signatures `b` and `f` jointly less z² of `f` alone, against noise of factor
    /// `s2`; 0 unless the joint fit puts a positive coefficient on `b`
    /// ([`brake_beyond_friction`]).
    fn beyond(&self, s2: f64, b: usize, f: usize) -> f64 {
        let v_inv = self.v_inv(s2);
        let (ab, af) = (self.w[b], self.w[f]);
        let (mbb, mbf, mff) = (
            form(&v_inv, &ab, &ab),
            form(&v_inv, &ab, &af),
            form(&v_inv, &af, &af),
        );
        let (gb, gf) = (form(&v_inv, &ab, &self.s), form(&v_inv, &af, &self.s));
        let det = mbb * mff - mbf * mbf;
        if !(det > 0.0 && mff > 0.0) {
            return 0.0;
        }
        let drag = (mff * gb - mbf * gf) / det;
        if drag <= 0.0 {
            return 0.0;
        }
        let rub = (mbb * gf - mbf * gb) / det;
        drag * gb + rub * gf - gf.max(0.0).powi(2) / mff
    }
}

/// The joint wander Σ_w (packed) as it moves the mean coefficients of a window of `trips`
/// trips: the blocks of B = [`WANDER_BLOCK_TRIPS`] wander independently of each other, so
/// a window of n trips carries B/n of one block's, all of it within one block.
fn window_wander(sigma: &[f64; 6], trips: u32) -> [[f64; N_MODES]; N_MODES] {
    let blocks = (f64::from(trips) / WANDER_BLOCK_TRIPS as f64).max(1.0);
    unpack(sigma).map(|row| row.map(|v| v / blocks))
}

/// The window-limited GLR of a change of unknown size along each signature alone (Lai,
/// 1995), over the windows of [`GLR_LENGTHS`] ending at the newest of the `recent` trips, from their running `sums`:
///
/// ```text
/// window of the last n trips:  S = Σ clipped score_m,  W = Σ info_m
///   its coefficient θ = S/W, var S = Σ v + f_m·W²     v = a_m·info + b_m: each trip's healthy
///                                                      variance (trip_variance); f_m: the
///                                                      healthy wander and θ0's error
///                                                      (SequentialConfig::floor_var), which
///                                                      no number of the window's trips
///                                                      averages away
///   z² = S²/(Σ v + f_m·W²)  when S > 0, else 0        Glr: the largest over n, and its n
/// ```
///
/// A window whose trips beyond the clip are [`CONSISTENT_SHARE`] of its trips, or carry that
/// share of its information, sums its scores clipped at its own bound instead
/// (`own_bound_sum`), from the `recent` trips: [`GlrSums::high`] and
/// [`GlrSums::high_info`], kept with the sums, say which.
///
/// Why beside the CUSUMs: a CUSUM of size ν in units of one trip's standard error gains at
/// most ν·CLIP − ν²/2 a trip, and its threshold is set by the bootstrap's healthy hours,
/// which wander together: where that wander is a sizeable share of a trip's error, a run of
/// healthy hours a little above the training's level piles up as much G as a large fault's
/// first hour (a 40-floor car with its drive off at rest, 3 days of training: the motor's
/// size 1/2 threshold at 186, where the four days after the training reached 5.6), and a
/// Kd step of +25 %, 5 to 10 standard errors on every trip, waited 117 trips for it. The GLR
/// weighs a window against the noise and the wander together, so a change many times the
/// wander is decided within the shortest window, and its threshold, bootstrapped from the
/// same hours, is one of z² (of the order of 2·ln of the windows a year).
pub fn glr(
    cfg: &SequentialConfig,
    sums: &[GlrSums; GLR_N],
    recent: &std::collections::VecDeque<RecentTrip>,
) -> [Glr; N_MODES] {
    let mut out = [Glr::default(); N_MODES];
    for m in 0..N_MODES {
        // The best window as (S², var S, length), compared by cross-multiplication: one
        // division for the mode, not one per window.
        let (mut s2_best, mut v_best, mut n_best, mut b_best) = (0.0, 1.0, 0, CLIP);
        for (l, win) in sums.iter().enumerate() {
            let n = GLR_LENGTHS[l];
            if recent.len() < n {
                break;
            }
            // No trip beyond the clip (a healthy window, nearly always): no share to weigh.
            let own = win.high[m] > 0.0
                && (consistent(win.high[m], n as f64) || consistent(win.high_info[m], win.w[m]));
            let (s, bound) = if own {
                own_bound_sum(cfg, recent, n, m)
            } else {
                (win.s[m], CLIP)
            };
            let w = win.w[m];
            let v = win.v[m] + cfg.glr_floor(m, l) * w * w;
            let informed = w >= GLR_LENGTHS[0] as f64 * cfg.info[m];
            if informed && s > 0.0 && v > 0.0 && (n_best == 0 || s * s * v_best > s2_best * v) {
                (s2_best, v_best, n_best, b_best) = (s * s, v, n, bound);
            }
        }
        if let Some((s, v, bound)) = step_window(cfg, recent, m) {
            if n_best == 0 || s * s * v_best > s2_best * v {
                (s2_best, v_best, n_best, b_best) = (s * s, v, STEP_WINDOW_TRIPS, bound);
            }
        }
        if n_best > 0 {
            out[m] = Glr {
                z2: s2_best / v_best,
                trips: n_best as u32,
                bound: b_best,
            };
        }
    }
    out
}

/// Trips of the GLR's step window: the last eight, read only where the change shows on
/// every one of them (`step_window`). The shortest of [`GLR_LENGTHS`] is twenty, and a
/// window of twenty is `consistent` only once fifteen of its trips show the change: a Kd
/// step of +25 % on the 630 kg car, far beyond the clip on every trip from its first, was
/// decided on its sixteenth trip, 3.8 hours into a residential evening, where the oracle
/// floor (its first trip's information already exceeds ln ARL0) had it in 0.6 hours. Eight
/// trips in a row beyond the clip: what a step of several standard errors gives within the
/// hour of a busy car, and not what a run of odd short hops gives (they carry little
/// information, and the window must hold eight mean trips' worth).
pub const STEP_WINDOW_TRIPS: usize = 8;

/// The most the step window's trips may scatter about one level, χ² with
/// [`STEP_WINDOW_TRIPS`] − 1 = 7 degrees of freedom: its 99.9th percentile. A step moves
/// every trip's score by its size times the trip's information, so its trips lie on one line
/// within their noise; a model meeting traffic its training never showed does not: after the
/// paper's 3 hours of training, the 40-floor car's morning rush on day 8 (full cars up, empty
/// down, voltage residuals of −18 to +12 V) put eight trips in a row beyond the clip along the
/// motor signature and raised a false `motor` advisory, its trips scattered about their level
/// far beyond their noise.
pub const STEP_WINDOW_CHI2: f64 = 24.32;

const _: () = assert!(STEP_WINDOW_TRIPS >= CHANGE_POINT_MIN_TRIPS);
const _: () = assert!(STEP_WINDOW_TRIPS < GLR_LENGTHS[0]);

/// The GLR's step window along signature `m`, as (S, var S, bound), when it is read: the last
/// [`STEP_WINDOW_TRIPS`] of the `recent` trips, every one of them beyond the clip, holding
/// the information of as many mean trips as it has trips, and lying on one level within
/// their noise ([`STEP_WINDOW_CHI2`]); its score then summed at its own
/// bound (`own_bound_sum`), its variance the trips' own and the wander of the shortest of
/// [`GLR_LENGTHS`] (a window shorter than that wanders more, but a change beyond the clip on
/// every trip is many times either). Every trip, where the longer windows take three
/// quarters ([`CONSISTENT_SHARE`]): with six of eight, the field bench's 40-floor car
/// raised a false `friction` advisory from its full cars going up on a busy morning (load
/// 80-96 %, the voltage 5-12 V above the model on five trips in a row, a load its 3-day
/// training had rarely seen). A brake's drag shows beyond the clip only on the long trips
/// that carry its information, which eight trips cannot tell from a few odd ones; the
/// windows of twenty and more decide it. `None` otherwise, as on nearly every healthy
/// window.
fn step_window(
    cfg: &SequentialConfig,
    recent: &std::collections::VecDeque<RecentTrip>,
    m: usize,
) -> Option<(f64, f64, f64)> {
    let n = STEP_WINDOW_TRIPS;
    if recent.len() < n {
        return None;
    }
    // Σ info, Σ v, and for one level θ through the trips' scores (score = θ·info + noise
    // of variance v): Σ score·info/v, Σ info²/v and Σ score²/v.
    let (mut high, mut w, mut v) = (0.0, 0.0, 0.0);
    let (mut si, mut ii, mut ss) = (0.0, 0.0, 0.0);
    for r in recent.range(recent.len() - n..) {
        let info = r.xtx[PACKED_DIAG[m]];
        let var = cfg.trip_var_of(m, info);
        w += info;
        v += var;
        if r.clipped[m] < r.score[m] {
            high += 1.0;
        }
        if var > 0.0 {
            si += r.score[m] * info / var;
            ii += info * info / var;
            ss += r.score[m] * r.score[m] / var;
        }
    }
    // The trips' misfit to one level: χ² with n − 1 degrees of freedom for a step.
    let misfit = if ii > 0.0 {
        ss - si * si / ii
    } else {
        f64::INFINITY
    };
    let read = high == n as f64 && w >= n as f64 * cfg.info[m] && misfit <= STEP_WINDOW_CHI2;
    if !read {
        return None;
    }
    let (s, bound) = own_bound_sum(cfg, recent, n, m);
    let v = v + cfg.glr_floor(m, 0) * w * w;
    (s > 0.0 && v > 0.0).then_some((s, v, bound))
}

/// The share of a GLR window's trips, or of its information, that trips beyond the clip
/// along a signature must make before the window is read at its own bound
/// (`own_bound_sum`): three quarters. The clip bounds what a few odd trips can add (the runs
/// of five to ten odd hops of a busy morning that [`GLR_LENGTHS`] and [`CLIP`] were set
/// against are at most half of the shortest window's trips, and short hops carry less than
/// their share of its information), but where nearly every trip shows a change beyond it,
/// the clip censors the change itself: a Kd step of +25 % on the 1000 kg car, 7 to 13
/// standard errors on every trip, counted 3 a trip, and its window of twenty reached its
/// threshold's 1.08 only after all twenty of its trips, and raised an hour later
/// ([`crate::alarm::GLR_HOLD_S`]). Either share: a brake's
/// drag shows beyond the clip on the trips that carry its information (8 of 20 trips of the
/// 40-floor car, 90 % of the information), a Kd step on the 630 kg car's evening trips on 15
/// of 20 while the window's longer trips from before it held 30 % of the information.
pub const CONSISTENT_SHARE: (u32, u32) = (3, 4);

/// Whether `part`, the trips of a window beyond the clip or their information, is at least
/// [`CONSISTENT_SHARE`] of the window's `whole`.
fn consistent(part: f64, whole: f64) -> bool {
    let (a, b) = CONSISTENT_SHARE;
    part * f64::from(b) >= whole * f64::from(a) && whole > 0.0
}

/// The GLR score of a window of the last `n` of the `recent` trips along signature `m` that
/// is [`consistent`], and the bound it was clipped at: each trip's score clipped to ±B of
/// its own sd, where B is the window's median standardised score, each trip weighed by its
/// information (at least [`CLIP`], as three quarters of it is beyond that): the Huber bound
/// taken from the window, which no minority of odd trips can move, at the level of the
/// change its majority shows. The median and not the rank that three quarters reach: a
/// window that has just become consistent holds the weakest of its changed trips there,
/// which read a step back at the clip. Healthy windows almost never get here, the
/// bootstrap's draws included, and it runs the same code.
fn own_bound_sum(
    cfg: &SequentialConfig,
    recent: &std::collections::VecDeque<RecentTrip>,
    n: usize,
    m: usize,
) -> (f64, f64) {
    // Each trip's standardised score u, its sd and its information.
    let mut trips = [(0.0, 0.0, 0.0); RECENT_TRIPS];
    for (t, r) in trips.iter_mut().zip(recent.range(recent.len() - n..)) {
        let info = r.xtx[PACKED_DIAG[m]];
        let sd = cfg.trip_var_of(m, info).sqrt();
        *t = (r.score[m] / sd, sd, info);
    }
    let trips = &trips[..n];
    let mut by_score = [(0.0, 0.0, 0.0); RECENT_TRIPS];
    let by_score = &mut by_score[..n];
    by_score.copy_from_slice(trips);
    by_score.sort_unstable_by(|a, b| b.0.total_cmp(&a.0));
    let half = 0.5 * by_score.iter().map(|t| t.2).sum::<f64>();
    let mut reached = 0.0;
    let mut bound = CLIP;
    for &(u, _, info) in by_score.iter() {
        reached += info;
        if reached >= half {
            bound = u.max(CLIP);
            break;
        }
    }
    let sum = trips
        .iter()
        .map(|&(u, sd, _)| u.clamp(-bound, bound) * sd)
        .sum();
    (sum, bound)
}

/// uᵀ·A·v for a 3×3 matrix A.
fn form(a: &[[f64; N_MODES]; N_MODES], u: &[f64; N_MODES], v: &[f64; N_MODES]) -> f64 {
    (0..N_MODES)
        .map(|i| u[i] * (0..N_MODES).map(|j| a[i][j] * v[j]).sum::<f64>())
        .sum()
}

/// The machine mode a window's drifts are read under: the one its isolation named, or, while
/// none leads by the odds, the one it leans to (the largest log-likelihood ratio of a
/// signature alone, `isolation`); `unknown` only when no signature rose. Read jointly, three
/// near-collinear signatures split one small change on a short window into large opposite
/// drifts: on a healthy quiet car (800 kg, 150 trips a day) the trips' rows read friction
/// +18 % and a drag of −274 N on one trip and +3.6 % and −11 N on the next, as the naming
/// came and went. Under the likeliest mode the same window reads one drift of its size; the
/// event still says `unknown`, and its evidence gives each signature's likelihood.
fn leaning(named: FaultMode, isolation: &[f64; N_MODES]) -> FaultMode {
    if named.is_machine() {
        return named;
    }
    let (m, best) = isolation
        .iter()
        .enumerate()
        .fold((0, 0.0f64), |a, (m, &z)| if z > a.1 { (m, z) } else { a });
    if best > 0.0 {
        MACHINE_MODES[m]
    } else {
        FaultMode::Unknown
    }
}

/// The three drifts of a window read under the machine mode `machine_mode` (the one its
/// isolation named or leans to, [`leaning`]): that mode's from its signature alone and the
/// other two from what it leaves, their standard errors widened by the window's misfit to
/// that mode ([`misfit_llr`]), which is returned third; all three jointly when it is
/// `unknown` (misfit 0: three coefficients leave none).
fn drifts(
    cfg: &SequentialConfig,
    c: &Cusum,
    machine_mode: FaultMode,
) -> ([f64; N_MODES], [f64; N_MODES], f64) {
    let (mut drift, mut drift_se) = window_drift(cfg, c);
    if !machine_mode.is_machine() {
        return (drift, drift_se, 0.0);
    }
    let m = machine_mode as usize;
    (drift[m], drift_se[m]) = alone_drift(cfg, c, m);
    for (i, d, se) in remainder_drifts(cfg, c, m).into_iter().flatten() {
        (drift[i], drift_se[i]) = (d, se);
    }
    let misfit = misfit_llr(cfg, c, m);
    let scale = (2.0 * misfit / MISFIT_DOF).max(1.0).sqrt();
    for se in &mut drift_se {
        *se *= scale;
    }
    (drift, drift_se, misfit)
}

/// Degrees of freedom of the named mode's misfit on a window: three signatures against one.
const MISFIT_DOF: f64 = (N_MODES - 1) as f64;

/// How far a window read under machine mode `m` departs from that signature alone: the
/// log-likelihood ratio χ²/2 of the three signatures' joint estimate against the best change
/// along m alone,
///
///   θ̂ = W⁻¹·S,  Σ = s²·W⁻¹ + Σ_w·B/n + diag(se0²),  χ² = min_δ (θ̂ − δ·e_m)ᵀ·Σ⁻¹·(θ̂ − δ·e_m)
///
/// s² the largest of the three noise factors, Σ_w the joint wander between blocks of B
/// trips averaged over the window's n (as the isolation weighs it, [`Wander`]; each mode's
/// wander alone where the model has no Σ_w) and se0 θ0's own error; χ² has [`MISFIT_DOF`]
/// degrees of freedom. Where χ²/ν exceeds 1 the drifts' standard errors are widened by the
/// Birge ratio √(χ²/ν) ([`drifts`]), the factor that reconciles a fit's stated errors with
/// its scatter. A real fault is never exactly its signature, and a drift read along it is
/// off by the part of the departure its signature shares: on the field bench a Kd step of
/// +25 % on the 40-floor car read +21.0 ± 0.8 % with a brake drag of −165 ± 70 N beside it.
/// A standard error that leaves the departure out states a precision the window itself
/// shows it does not have; a window within its noise and wander of its signature keeps its
/// standard errors. 0 where the window's joint estimate is not determined.
fn misfit_llr(cfg: &SequentialConfig, c: &Cusum, m: usize) -> f64 {
    let Some(inv) = spd_inverse(&c.w) else {
        return 0.0;
    };
    let s2 = cfg.largest_s2();
    let theta = mat_vec(&inv, &c.s);
    let floor: [[f64; N_MODES]; N_MODES] = match &cfg.wander_cov {
        Some(w) => {
            let w = window_wander(w, c.trips);
            std::array::from_fn(|i| {
                std::array::from_fn(|j| {
                    w[i][j]
                        + if i == j {
                            cfg.reference_se[i] * cfg.reference_se[i]
                        } else {
                            0.0
                        }
                })
            })
        }
        None => std::array::from_fn(|i| {
            std::array::from_fn(|j| if i == j { cfg.floor_var(i) } else { 0.0 })
        }),
    };
    let sigma: [[f64; N_MODES]; N_MODES] =
        std::array::from_fn(|i| std::array::from_fn(|j| s2 * inv[i][j] + floor[i][j]));
    let Some(p) = spd_inverse(&pack(&sigma)) else {
        return 0.0;
    };
    let pt = mat_vec(&p, &theta);
    let whole: f64 = theta.iter().zip(&pt).map(|(a, b)| a * b).sum();
    let chi2 = whole - pt[m] * pt[m] / p[m][m];
    if chi2.is_finite() {
        0.5 * chi2.max(0.0)
    } else {
        0.0
    }
}

/// Joint estimate of the three drifts on a window, now (its line's level at the last trip)
/// or, when the window's time does not determine a slope, its mean; standard errors from the
/// healthy per-mode noise (the largest of the three s², the conservative choice for a joint
/// fit), the healthy wander of each coefficient and θ0's own error
/// ([`SequentialConfig::floor_var`]).
fn window_drift(cfg: &SequentialConfig, c: &Cusum) -> ([f64; N_MODES], [f64; N_MODES]) {
    let s2 = cfg.largest_s2();
    let se = |var: f64, m: usize| (s2 * var + cfg.floor_var(m)).sqrt();
    if let Some(now) = c.slope.as_ref().and_then(|sl| line_now(c, sl)) {
        return (now.0, std::array::from_fn(|m| se(now.1[m], m)));
    }
    let Some(inv) = spd_inverse(&c.w) else {
        return ([f64::NAN; N_MODES], [f64::NAN; N_MODES]);
    };
    (
        mat_vec(&inv, &c.s),
        std::array::from_fn(|m| se(inv[m][m], m)),
    )
}

/// The drift of signature `m` alone on a window (its trend's level at the last trip, or the
/// window's mean when its time does not determine one), with its standard error: the named
/// mode's drift. A real fault is never exactly its signature (a dragging brake rubs a little
/// going up too), and on the short window of a decision the joint fit of three
/// near-collinear signatures spreads that misfit over all three: on the evaluation a brake
/// step on the 630 kg car read a drag of 551 ± 40 N against 300 N, with friction −34 % and
/// Kd −11 %. Once the isolation has said which mode changed, the estimate under that
/// hypothesis is its signature's alone; the others are what it leaves
/// ([`remainder_drifts`]).
///
/// The trend is the line's level moved by the curve's bend as far as the bend stands out of
/// its noise ([`bend_shrunk`]). A window that healthy wander held open for hours before a
/// ramp began holds flat trips and then rising ones, and a line through both reads the
/// ramp's level now low: on the field bench a Kd ramp of +50 % over 3 days on the 630 kg car
/// was decided on a window of 105 flat trips and 56 on the ramp, whose line read
/// +6.4 ± 1.1 % where the ramp stood at +8.9 %. A curve bends where the ramp begins and where
/// an exponential one steepens, at about 1.5 times the line's standard error (at the end of
/// n evenly spread trips the line's variance is 4/n of a trip's, the curve's 9/n), and it
/// follows hour-to-hour wander more than the line does. Weighing the line, every step and
/// every ramp from an hour by their likelihoods was tried first and read exponential ramps
/// high: a ramp from its likeliest hour extrapolates its steepest part (docs/EVALUATION-HISTORY.md, *The field bench*).
fn alone_drift(cfg: &SequentialConfig, c: &Cusum, m: usize) -> (f64, f64) {
    let k = PACKED_DIAG[m];
    let (a, s) = (c.w[k], c.s[m]);
    let moving = moving_wander(cfg, m);
    let read = |t: &AloneTrend| (t.level, alone_var(cfg, m, t.var, moving));
    if let Some(line) = alone_line(c, m) {
        let (level, var) = match alone_curve(c, m) {
            Some(curve) => {
                let v_d = (curve.var - line.var).max(0.0) * (cfg.s2[m] + moving);
                bend_shrunk(read(&line), read(&curve), v_d)
            }
            None => read(&line),
        };
        return (level, var.sqrt());
    }
    if a > 0.0 {
        (s / a, alone_var(cfg, m, 1.0 / a, 0.0).sqrt())
    } else {
        (f64::NAN, f64::NAN)
    }
}

/// The trend of signature `m` alone through a window's trips (τ days since its first
/// trip), when its time spans one ([`SLOPE_MIN_DAYS`]): its curve or its line.
struct AloneTrend {
    /// The trend's level at the window's last trip.
    level: f64,
    /// Its variance per unit s².
    var: f64,
    /// The sum of squares the trend explains, c·N⁻¹·c over its normal equations N and its
    /// sums c (for the line θ·S + β·S_τ).
    ess: f64,
}

/// [`AloneTrend`] of signature `m` on window `c` that a step among its recent trips is weighed
/// against ([`Sequential::step_beyond_trend`]): the curve θ + β·τ + γ·τ² ([`alone_curve`])
/// where the window keeps its sums and they are regular, else the line θ + β·τ
/// ([`alone_line`]); `None` without either.
fn alone_trend(c: &Cusum, m: usize) -> Option<AloneTrend> {
    alone_curve(c, m).or_else(|| alone_line(c, m))
}

/// The curve θ + β·τ + γ·τ² of signature `m` alone through a window's trips, read at its
/// last trip, when its time spans a line and the curve's 3×3 normal equations are regular.
fn alone_curve(c: &Cusum, m: usize) -> Option<AloneTrend> {
    let sl = c.slope.filter(SlopeSums::spans_line)?;
    let cu = sl.curve?;
    let k = PACKED_DIAG[m];
    let normal = [c.w[k], sl.w1[k], sl.w2[k], sl.w2[k], cu.w3[m], cu.w4[m]];
    let inv = spd_inverse(&normal)?;
    let rhs = [c.s[m], sl.s1[m], cu.s2[m]];
    let t = sl.tau_end;
    let e = [1.0, t, t * t];
    // With (θ, β, γ) = N⁻¹·rhs: the level is eᵀN⁻¹rhs, its variance eᵀN⁻¹e and the sum it
    // explains rhsᵀN⁻¹rhs.
    Some(AloneTrend {
        level: form(&inv, &e, &rhs),
        var: form(&inv, &e, &e),
        ess: form(&inv, &rhs, &rhs),
    })
}

/// The level between a window's line and its curve, each given as (level, variance): the
/// curve's bend d = curve − line shrunk towards the line by its own noise v_d,
///
///   level = line + w·d,  w = max(0, 1 − v_d/d²),
///   var = (1 − w)·var_line + w·var_curve + w·(1 − w)·d²
///
/// (the positive-part shrinkage of James and Stein, its variance the two readings'
/// mixture). v_d is the variance of d where the line is right: the curve nests the line, so
/// it is the difference of their variances per unit s², times the noise and the wander that
/// moves within the window ([`moving_wander`]). A bend well beyond it, a ramp that began
/// inside the window, reads as the curve; a bend within it stays near the line. The curve
/// alone read a Kd step of +10 % 2.2 standard errors low on a day of synthetic trips whose
/// Kd swings ±3 % a day with the temperature (test
/// `a_step_is_decided_within_tens_of_trips_with_its_mode_and_size`).
fn bend_shrunk(line: (f64, f64), curve: (f64, f64), v_d: f64) -> (f64, f64) {
    let d = curve.0 - line.0;
    let w = if d * d > v_d {
        1.0 - v_d / (d * d)
    } else {
        0.0
    };
    (
        line.0 + w * d,
        (1.0 - w) * line.1 + w * curve.1 + w * (1.0 - w) * d * d,
    )
}

/// The line θ + β·τ of signature `m` alone, [`alone_trend`]'s where the window keeps no
/// curve (a window a state saved before the curve was kept had begun).
fn alone_line(c: &Cusum, m: usize) -> Option<AloneTrend> {
    let sl = c.slope.filter(SlopeSums::spans_line)?;
    let k = PACKED_DIAG[m];
    let (a, s) = (c.w[k], c.s[m]);
    let (b, d, t) = (sl.w1[k], sl.w2[k], sl.tau_end);
    let det = a * d - b * b;
    if det.is_nan() || det <= 0.0 {
        return None;
    }
    let theta = (d * s - b * sl.s1[m]) / det;
    let beta = (a * sl.s1[m] - b * s) / det;
    Some(AloneTrend {
        level: theta + beta * t,
        var: (d - 2.0 * t * b + t * t * a) / det,
        ess: theta * s + beta * sl.s1[m],
    })
}

/// The drifts of the two other signatures on what the named mode `m` leaves of a window: the
/// window's mean less `m`'s own mean coefficient, each of the two alone on that remainder,
/// with the standard error of a signature alone ([`alone_drift`]'s, without the line);
/// `None` when either has no information. Under the named mode nothing else changed, and what
/// the others show here is what the data say beyond it, one mode at a time: the joint fit of
/// all three gave them their share of the named fault's misfit instead (a brake step read
/// friction −34 % and Kd −11 %), and a joint fit of the two on the remainder split it into
/// large opposite drifts where their signatures are near-collinear (a healthy 1600 kg car of
/// 8 floors, its motor advisory: friction +38.8 ± 5.9 % and a drag of −828 ± 143 N; each
/// alone −2.4 ± 5.6 % and −379 ± 141 N).
fn remainder_drifts(cfg: &SequentialConfig, c: &Cusum, m: usize) -> Option<[(usize, f64, f64); 2]> {
    let w = unpack(&c.w);
    if w[m][m].is_nan() || w[m][m] <= 0.0 {
        return None;
    }
    let own = c.s[m] / w[m][m];
    let (i, j) = match m {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    };
    if !(w[i][i] > 0.0 && w[j][j] > 0.0) {
        return None;
    }
    let alone = |k: usize| {
        let rest = c.s[k] - w[k][m] * own;
        (
            k,
            rest / w[k][k],
            alone_var(cfg, k, 1.0 / w[k][k], 0.0).sqrt(),
        )
    };
    Some([alone(i), alone(j)])
}

/// The healthy wander that moves within a window whose time spans a trend, as a variance
/// per unit of a reading's variance per unit s² (beside the noise s²): w²·I_block, I_block
/// the mean information along `m` of a block of [`WANDER_BLOCK_TRIPS`] trips.
///
/// Each block stands off by its own wander, and a reading at the window's end weighs the
/// blocks unequally: over B blocks a line's end carries about 4/B of one block's wander
/// variance, a curve's 9/B, a mean 1/B, which `var`·w²·I_block estimates.
/// [`SequentialConfig::floor_var`] counts one block's wander whole; a reading takes the
/// larger of the two ([`alone_var`]). A window that spans a trend spans a quarter of a day
/// ([`SLOPE_MIN_DAYS`]), often the night between an evening and a morning, so its hours stand
/// off by their own wander however few trips it holds. Counting the trips' noise alone, the
/// curve's bend read linear and exponential ramps of the field bench 2.0-2.2 standard errors
/// high, and on 3-day trainings a half-size exponential brake ramp 168 ± 56 N where it stood
/// at 50 N (the line: 94 ± 53 N). It does not cover every bend that is not a fault's: on the
/// week-long suite a half-size friction ramp on the 1600 kg car reads 110 ± 32 N where it
/// stands at 46 N (the line: 64 ± 22 N). That window held about 480 trips from 07:12 to
/// 14:00 of one day, a 50-trip block being 40 minutes of that busy car, and its bend stood
/// 2.7 times v_d. It is not a bend the healthy trips show: a week of that car's training,
/// read in windows of a quarter day to a day from every block, bends no more than v_d
/// predicts along any signature (README, Limits), and counting such a bend in v_d
/// changed no reading of the suites.
fn moving_wander(cfg: &SequentialConfig, m: usize) -> f64 {
    let block = WANDER_BLOCK_TRIPS as f64 * cfg.info[m];
    cfg.wander[m] * cfg.wander[m] * block
}

/// The variance of signature `m`'s drift read alone, its variance per unit s² being `var`:
/// the mode's own healthy noise, its wander (one block's, or `moving`·`var` where that is
/// more, [`moving_wander`]) and θ0's error ([`SequentialConfig::floor_var`]).
fn alone_var(cfg: &SequentialConfig, m: usize, var: f64, moving: f64) -> f64 {
    let beyond_one_block = (moving * var - cfg.wander[m] * cfg.wander[m]).max(0.0);
    cfg.s2[m] * var + cfg.floor_var(m) + beyond_one_block
}

/// A window whose line needs at least this many days between its first and last trip: a
/// slope over an hour or two would be the busy hour's, not the fault's. A quarter of a day
/// lets the line span the night between an evening and a morning: a 3-day Kd ramp from
/// evening onset was decided next morning on a window of 0.46 d, whose mean read +4.2 % where
/// the ramp stood at +8.6 % (its line +7.5 %). Shorter windows report their level since their
/// change point ([`Sequential::push`]).
pub const SLOPE_MIN_DAYS: f64 = 0.25;

/// The level θ + β·τ_end of the window's line through its trips, per mode, and its variance
/// per unit s²: (θ, β) solves the 6×6 normal equations of the regressors (x, τ·x); `None`
/// when the window is too short in time or they are singular.
fn line_now(c: &Cusum, sl: &SlopeSums) -> Option<([f64; N_MODES], [f64; N_MODES])> {
    if !sl.spans_line() {
        return None;
    }
    let (w0, w1, w2) = (unpack(&c.w), unpack(&sl.w1), unpack(&sl.w2));
    let mut normal = SquareMatrix::zeros(2 * N_MODES);
    for i in 0..N_MODES {
        for j in 0..N_MODES {
            *normal.at(i, j) = w0[i][j];
            *normal.at(i, j + N_MODES) = w1[i][j];
            *normal.at(i + N_MODES, j) = w1[i][j];
            *normal.at(i + N_MODES, j + N_MODES) = w2[i][j];
        }
    }
    let chol = normal.cholesky()?;
    let rhs: Vec<f64> = c.s.iter().chain(&sl.s1).copied().collect();
    let coef = chol.cholesky_solve(&rhs);
    let inv = chol.cholesky_inverse();
    let t = sl.tau_end;
    let level = std::array::from_fn(|m| coef[m] + t * coef[m + N_MODES]);
    let var = std::array::from_fn(|m| {
        let (a, b) = (m, m + N_MODES);
        inv.get(a, a) + 2.0 * t * inv.get(a, b) + t * t * inv.get(b, b)
    });
    Some((level, var))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    const MOTOR: usize = FaultMode::Motor as usize;

    /// One trip's information x·xᵀ (packed): the three signatures overlap, as they do on a
    /// real car (correlations 0.5-0.8).
    const XTX: [f64; 6] = [1.0, 0.5, 0.6, 0.6, 0.3, 0.8];

    /// A healthy wander that moves the motor coefficient up and the brake's down together.
    const WANDER_DIR: [f64; N_MODES] = [1.0, -1.0, 0.0];

    fn matvec(p: &[f64; 6], v: &[f64; N_MODES]) -> [f64; N_MODES] {
        mat_vec(&unpack(p), v)
    }

    /// A decision of unit noise, information and level 0, without wander or reference error.
    fn unit_config() -> SequentialConfig {
        SequentialConfig {
            theta0: [0.0; N_MODES],
            s2: [1.0; N_MODES],
            info: [1.0; N_MODES],
            h: [[10.0; N_SIZES]; N_MODES],
            wander: [0.0; N_MODES],
            reference_se: [0.0; N_MODES],
            load: None,
            wander_cov: None,
            glr_h: None,
            trip_var: None,
            glr_wander: None,
        }
    }

    /// A trip whose coefficients stand at `theta`, with noise of variance s²·x·xᵀ on its
    /// scores (s² = 1).
    fn trip(start: f64, theta: &[f64; N_MODES], rng: &mut Rng) -> TripEvidence {
        trip_with(&XTX, start, theta, rng)
    }

    /// [`trip`] with the information `xtx`.
    fn trip_with(
        xtx: &[f64; 6],
        start: f64,
        theta: &[f64; N_MODES],
        rng: &mut Rng,
    ) -> TripEvidence {
        // Cholesky factor of x·xᵀ, for noise with that covariance.
        let mut a = crate::linalg::SquareMatrix::zeros(N_MODES);
        for (i, row) in unpack(xtx).iter().enumerate() {
            for (j, v) in row.iter().enumerate() {
                *a.at(i, j) = *v;
            }
        }
        let l = a.cholesky().expect("x·xᵀ is positive definite");
        let z = [rng.normal(), rng.normal(), rng.normal()];
        let mean = matvec(xtx, theta);
        TripEvidence {
            start,
            end: start + 20.0,
            n: 20,
            direction: if rng.uniform(0.0, 1.0) < 0.5 { 1 } else { -1 },
            mean_e_u: 0.0,
            mean_e_f: 0.0,
            xtx: *xtx,
            xtr: std::array::from_fn(|i| {
                mean[i] + (0..=i).map(|k| l.get(i, k) * z[k]).sum::<f64>()
            }),
            rr: 1.0,
            plausible: true,
            thermal: Default::default(),
            load: Default::default(),
        }
    }

    /// A window of `trips` trips whose coefficients moved by `theta`, without noise.
    fn window(trips: u32, theta: &[f64; N_MODES]) -> Cusum {
        let mut c = Cusum {
            trips,
            ..Cusum::default()
        };
        for _ in 0..trips {
            c.add(&matvec(&XTX, theta), &XTX);
        }
        c
    }

    #[test]
    fn the_joint_wander_is_measured_along_the_direction_the_blocks_move() {
        // 400 blocks of 50 trips whose coefficients sit at a level of sd 0.3 along
        // WANDER_DIR, over trips of unit noise (a block's joint estimate has a noise of sd
        // 0.21-0.24 per coefficient: the wander is about as large).
        let mut rng = Rng::new(5);
        let sd = 0.3;
        let mut trips = Vec::new();
        for b in 0..400 {
            let level = sd * rng.normal();
            let theta = WANDER_DIR.map(|d| d * level);
            for k in 0..WANDER_BLOCK_TRIPS {
                trips.push(trip(
                    (b * WANDER_BLOCK_TRIPS + k) as f64 * 100.0,
                    &theta,
                    &mut rng,
                ));
            }
        }
        let cfg = SequentialConfig::reference(&trips, 10.0).expect("separable");
        let c = unpack(&cfg.wander_cov.expect("400 blocks"));
        let var = sd * sd;
        assert!((c[0][0] / var - 1.0).abs() < 0.3, "{c:?}");
        assert!((c[1][1] / var - 1.0).abs() < 0.3, "{c:?}");
        let corr = c[0][1] / (c[0][0] * c[1][1]).sqrt();
        assert!(
            corr < -0.8,
            "the two move together, against each other: {corr}"
        );
        assert!(c[2][2] < 0.3 * var, "friction does not wander: {c:?}");
    }

    #[test]
    fn a_window_that_moved_as_the_healthy_wander_does_names_no_mode() {
        let mut cfg = unit_config();
        let sd = 0.3;
        let sigma = WANDER_DIR.map(|d| d * sd);
        let wander_cov = pack(&sigma.map(|a| sigma.map(|b| a * b)));
        // Three blocks' worth of trips, moved by two of the wander's standard deviations along
        // its direction: on the trips' noise alone that is a clear motor rise.
        let excursion = window(150, &WANDER_DIR.map(|d| 2.0 * sd * d));
        let (_, machine, ..) = isolate(&cfg, &excursion);
        assert_eq!(machine, FaultMode::Motor, "the noise alone names it");
        cfg.wander_cov = Some(wander_cov);
        let (_, machine, z, _) = isolate(&cfg, &excursion);
        assert_eq!(machine, FaultMode::Unknown, "the wander explains it: {z:?}");
        // A rise of the motor coefficient alone, as large, is still the motor's.
        let mut rise = [0.0; N_MODES];
        rise[MOTOR] = 2.0 * sd;
        let (_, machine, z, _) = isolate(&cfg, &window(150, &rise));
        assert_eq!(machine, FaultMode::Motor, "{z:?}");
        // And the wander averages out of a long window: over 40 blocks the same excursion is
        // named by the noise again.
        let (_, machine, z, _) = isolate(&cfg, &window(2000, &WANDER_DIR.map(|d| 2.0 * sd * d)));
        assert_eq!(machine, FaultMode::Motor, "{z:?}");
    }

    #[test]
    fn the_other_modes_read_alone_on_what_the_named_one_leaves() {
        // A motor rise over 100 trips, where the brake and friction signatures are nearly
        // collinear (0.95) and the window's scores carry a small opposite wobble along them
        // (as the noise does): fitted jointly the two read about ±0.4, large and opposite;
        // alone on what the motor leaves, each reads its own ±0.02.
        let cfg = unit_config();
        let xtx = [1.0, 0.3, 0.3, 1.0, 0.95, 1.0];
        let (b, f) = (FaultMode::Brake as usize, FaultMode::Friction as usize);
        let mut c = Cusum::default();
        for _ in 0..100 {
            c.add(&matvec(&xtx, &[1.0, 0.0, 0.0]), &xtx);
        }
        c.trips = 100;
        c.s[b] += 2.0;
        c.s[f] -= 2.0;
        let (drift, se, _) = drifts(&cfg, &c, FaultMode::Motor);
        assert!((drift[MOTOR] - 1.0).abs() < 1e-12, "{drift:?}");
        assert!((drift[b] - 0.02).abs() < 1e-9, "{drift:?}");
        assert!((drift[f] + 0.02).abs() < 1e-9, "{drift:?}");
        assert!(
            (se[b] - 0.1).abs() < 1e-9,
            "one signature's SE over 100 trips: {se:?}"
        );
        // The joint fit of all three on the same window, for comparison.
        let joint = drifts(&cfg, &c, FaultMode::Unknown).0;
        assert!(joint[b] > 0.3 && joint[f] < -0.3, "{joint:?}");
    }

    #[test]
    fn an_unnamed_window_reads_one_drift_not_three_opposite_ones() {
        // Windows of 20 noisy trips after a friction rise of 0.8 (one trip's noise is 1):
        // too few to name the mode on most of them. The signatures correlate as on a quiet
        // 800 kg car of the simulator (motor-brake 0.79, brake-friction 0.67, motor-friction
        // 0.16). Read jointly, they split the rise into large opposite drifts; read under the
        // signature the window leans to, it is one drift and the others are what it leaves.
        let xtx = [1.0, 0.785, 0.157, 1.0, 0.666, 1.0];
        let cfg = unit_config();
        let friction = FaultMode::Friction as usize;
        let mut rise = [0.0; N_MODES];
        rise[friction] = 0.8;
        let mut rng = Rng::new(11);
        let spread =
            |d: [f64; N_MODES]| (0..N_MODES).map(|m| (d[m] - rise[m]).powi(2)).sum::<f64>();
        let (mut unnamed, mut joint_spread, mut read_spread) = (0, 0.0, 0.0);
        for w in 0..400 {
            let mut seq = Sequential::default();
            let mut d = Decision::default();
            for k in 0..20 {
                let t = trip_with(&xtx, f64::from(w * 20 + k) * 100.0, &rise, &mut rng);
                d = seq.push(&cfg, &t, 0.0);
            }
            if d.machine_mode.is_machine() {
                continue;
            }
            unnamed += 1;
            assert!(leaning(d.machine_mode, &d.isolation).is_machine(), "{d:?}");
            let j = SIZES
                .iter()
                .position(|&v| v == d.lead_size)
                .expect("a size of the bank");
            let window = &seq.bank[d.lead_signature as usize][j];
            joint_spread += spread(drifts(&cfg, window, FaultMode::Unknown).0);
            read_spread += spread(d.drift);
        }
        assert!(
            unnamed > 100,
            "most windows leave the mode unnamed: {unnamed}"
        );
        assert!(
            read_spread < 0.5 * joint_spread,
            "summed squared errors of the three drifts over {unnamed} unnamed windows: \
             {read_spread} as the decision reads them, {joint_spread} read jointly"
        );
    }

    #[test]
    fn a_hand_edited_glr_variance_or_wander_out_of_range_is_refused() {
        let mut cfg = unit_config();
        cfg.trip_var = Some([[0.5, 2.0]; N_MODES]);
        cfg.glr_wander = Some([[0.01; GLR_N]; N_MODES]);
        cfg.validate().expect("fitted values are valid");
        for bad in [-1.0, f64::NAN, f64::INFINITY] {
            let mut c = cfg.clone();
            c.trip_var = Some([[0.5, bad]; N_MODES]);
            let err = c
                .validate()
                .expect_err("a variance out of range is refused");
            assert!(err.contains("risk.sequential.trip_var"), "{err}");
            let mut c = cfg.clone();
            c.glr_wander = Some([[bad; GLR_N]; N_MODES]);
            let err = c.validate().expect_err("a wander out of range is refused");
            assert!(err.contains("risk.sequential.glr_wander"), "{err}");
        }
    }

    #[test]
    fn a_trips_variance_is_told_apart_into_its_length_and_its_ends() {
        // Scores of variance a·info + b with a = 0.5, b = 2 over trips of information 1 to
        // 100: the reweighted fit finds both within a few percent, where the pooled s² (b = 0)
        // would put a short trip's noise at twice its size and a long one's at half.
        let mut rng = Rng::new(7);
        let cfg = unit_config();
        let trips: Vec<TripEvidence> = (0..4000)
            .map(|k| {
                let info = rng.uniform(1.0, 100.0);
                let sd = (0.5 * info + 2.0f64).sqrt();
                let mut t = trip_with(
                    &[info, 0.0, 0.0, info, 0.0, info],
                    k as f64,
                    &[0.0; 3],
                    &mut rng,
                );
                t.xtr = std::array::from_fn(|_| sd * rng.normal());
                t
            })
            .collect();
        for [a, b] in cfg.trip_variance(&trips) {
            assert!(
                (a - 0.5).abs() < 0.05 && (b - 2.0).abs() < 0.4,
                "a {a}, b {b}"
            );
        }
    }

    #[test]
    fn a_large_step_is_decided_by_the_shortest_window_the_cusums_by_far_later() {
        // A step of four standard errors a trip along the motor signature, with CUSUM
        // thresholds as a wandering car's bootstrap sets them (h = 60 for the size 1/2): the
        // GLR decides once its shortest window holds the step, the CUSUMs alone some forty
        // trips later; its window is the step's and its drift the step's within 2 SE.
        let mut cfg = unit_config();
        cfg.h = [[60.0; N_SIZES]; N_MODES];
        cfg.glr_h = Some([30.0; N_MODES]);
        cfg.wander = [0.1; N_MODES];
        let step = [4.0, 0.0, 0.0];
        let first = |cfg: &SequentialConfig| {
            let mut rng = Rng::new(11);
            let mut seq = Sequential::default();
            for k in 0..200 {
                seq.push(cfg, &trip(f64::from(k), &[0.0; 3], &mut rng), 0.5);
            }
            (0..200)
                .map(|k| seq.push(cfg, &trip(f64::from(200 + k), &step, &mut rng), 0.5))
                .enumerate()
                .find(|(_, d)| d.ratio >= 1.0)
                .expect("the step must be decided")
        };
        let (k, d) = first(&cfg);
        assert!(
            k < GLR_LENGTHS[0] + 5,
            "the GLR decided {k} trips after the step"
        );
        assert_eq!(d.lead_signature, FaultMode::Motor);
        assert_eq!(d.mode, FaultMode::Motor, "{d:?}");
        assert!(
            (d.drift[MOTOR] - step[MOTOR]).abs() < 2.0 * d.drift_se[MOTOR],
            "drift {} ± {}",
            d.drift[MOTOR],
            d.drift_se[MOTOR]
        );
        let (k_cusum, _) = first(&SequentialConfig { glr_h: None, ..cfg });
        assert!(
            k_cusum > k + 30,
            "the CUSUMs alone decided after {k_cusum} trips"
        );
    }

    /// A GLR threshold of 60, CUSUMs that never decide, and a healthy wander of half a trip's
    /// standard error (sd 1) along every signature.
    fn wandering_glr_config() -> SequentialConfig {
        let mut cfg = unit_config();
        cfg.h = [[1e9; N_SIZES]; N_MODES];
        cfg.glr_h = Some([60.0; N_MODES]);
        cfg.wander = [0.5; N_MODES];
        cfg
    }

    /// The first trip (counted from 0) of `run` after 200 healthy ones at which the decision
    /// crosses under [`wandering_glr_config`], where the clipped window of twenty tops out at
    /// z² = (20·3)²/(20 + 0.25·20²) = 30: only a window read at its own bound can cross.
    fn first_crossing(run: &[[f64; N_MODES]]) -> Option<(usize, Decision)> {
        let trips: Vec<_> = run.iter().map(|theta| (XTX, *theta)).collect();
        first_crossing_of(&trips)
    }

    /// [`first_crossing`] of trips each with its own information x·xᵀ.
    fn first_crossing_of(run: &[([f64; 6], [f64; N_MODES])]) -> Option<(usize, Decision)> {
        let cfg = wandering_glr_config();
        let mut rng = Rng::new(17);
        let mut seq = Sequential::default();
        for k in 0..200 {
            seq.push(&cfg, &trip(f64::from(k), &[0.0; 3], &mut rng), 0.5);
        }
        run.iter()
            .enumerate()
            .map(|(k, (xtx, theta))| {
                let t = trip_with(xtx, 200.0 + k as f64, theta, &mut rng);
                (k, seq.push(&cfg, &t, 0.5))
            })
            .find(|(_, d)| d.ratio >= 1.0)
    }

    #[test]
    fn a_step_on_every_trip_is_read_at_its_own_bound_and_a_run_of_odd_trips_is_not() {
        // A step of 10 standard errors a trip: once the step window's eight trips all show
        // it, on one level within their noise, the window is read at its median (10), far past the threshold and past twice
        // it, so it raises at once (crate::alarm::GLR_STRONG_RATIO); clipped at 3 it could
        // never have crossed here, and the shortest window of twenty would have waited for
        // fifteen of its trips.
        let step = vec![[10.0, 0.0, 0.0]; 40];
        let (k, d) = first_crossing(&step).expect("the step must be decided");
        assert_eq!(k + 1, STEP_WINDOW_TRIPS, "decided on trip {k}");
        assert!(d.lead_glr && d.lead_signature == FaultMode::Motor, "{d:?}");
        assert_eq!(d.window_trips as usize, STEP_WINDOW_TRIPS);
        assert!(d.ratio >= 2.0, "ratio {}", d.ratio);
        assert!((d.lead_bound - 10.0).abs() < 1.5, "bound {}", d.lead_bound);
        // Runs of fourteen odd short hops of 15 standard errors (a fifth of a mean trip's
        // information each) among healthy trips, a busy morning's odd hops, longer than
        // any seen: never three quarters of a longer window's trips or information, and
        // never a step window's eight mean trips of information, so nothing crosses.
        let short = XTX.map(|v| 0.2 * v);
        let odd_hop = [15.0 / 0.2f64.sqrt(), 0.0, 0.0];
        let hops: Vec<_> = (0..400)
            .map(|k| {
                if k % 40 < 14 {
                    (short, odd_hop)
                } else {
                    (XTX, [0.0; N_MODES])
                }
            })
            .collect();
        assert!(first_crossing_of(&hops).is_none());
        // Runs of seven odd trips of the mean information, one short of the step window:
        // each counts 3 in the longer windows, and nothing crosses either.
        let odd: Vec<[f64; N_MODES]> = (0..400)
            .map(|k| [if k % 40 < 7 { 15.0 } else { 0.0 }, 0.0, 0.0])
            .collect();
        assert!(first_crossing(&odd).is_none());
        // Runs of fourteen odd trips all beyond the clip, but at 5 and 25 standard errors in
        // turn (a model meeting traffic its training never showed): no one level, so the
        // step window is not read, and fourteen are short of a longer window's share.
        let scattered: Vec<[f64; N_MODES]> = (0..400)
            .map(|k| {
                let level = match k % 40 {
                    i if i < 14 && i % 2 == 0 => 5.0,
                    i if i < 14 => 25.0,
                    _ => 0.0,
                };
                [level, 0.0, 0.0]
            })
            .collect();
        assert!(first_crossing(&scattered).is_none());
    }

    #[test]
    fn a_state_without_the_windows_counts_recounts_them_and_decides_alike() {
        // A state saved before the counts of trips beyond the clip were kept: they are
        // counted from its recent trips at the next trip, and the GLR is the one the counts
        // kept all along give, to the bit.
        let cfg = wandering_glr_config();
        let mut rng = Rng::new(3);
        let mut kept = Sequential::default();
        for k in 0..120 {
            let level = if k < 90 { 0.0 } else { 6.0 };
            kept.push(&cfg, &trip(f64::from(k), &[level, 0.0, 0.0], &mut rng), 0.5);
        }
        // As a state saved before reads back: the field missing, so NaN.
        let mut json: serde_json::Value = serde_json::to_value(&kept).expect("serialises");
        for w in json["glr_sums"].as_array_mut().expect("the sums are kept") {
            let w = w.as_object_mut().expect("an object");
            w.remove("high");
            w.remove("high_info");
        }
        let mut recounted: Sequential = serde_json::from_value(json).expect("reads back");
        assert!(recounted
            .glr_sums
            .is_some_and(|s| s[0].high[MOTOR].is_nan()));
        let t = trip(120.0, &[6.0, 0.0, 0.0], &mut rng);
        let a = kept.push(&cfg, &t, 0.5);
        let b = recounted.push(&cfg, &t, 0.5);
        let high = |s: &Sequential| s.glr_sums.map(|w| w.map(|w| (w.high, w.high_info)));
        assert_eq!(high(&kept), high(&recounted));
        assert_eq!(kept.glr, recounted.glr);
        assert!(
            a.lead_glr && a.ratio.to_bits() == b.ratio.to_bits(),
            "{a:?}"
        );
        // Every trip of the shortest window is beyond the clip: all its information.
        let w = kept.glr_sums.expect("kept")[0];
        assert!(
            w.high[MOTOR] == 20.0 && (w.high_info[MOTOR] - w.w[MOTOR]).abs() < 1e-9,
            "{w:?}"
        );
    }

    #[test]
    fn a_window_that_departs_from_its_signature_says_so_in_its_standard_errors() {
        // Read as a motor fault, a window that moved along the motor signature alone keeps
        // its standard errors; one that also moved along friction (a fault that is not
        // exactly its signature) reads a motor drift off by the part of friction's the two
        // signatures share, and its standard errors widen until they cover it.
        let cfg = unit_config();
        let exact = window(400, &[0.5, 0.0, 0.0]);
        let (d, se, misfit) = drifts(&cfg, &exact, FaultMode::Motor);
        assert!(misfit < 1e-9, "{misfit}");
        assert!((d[MOTOR] - 0.5).abs() < 1e-12 && (se[MOTOR] - 0.05).abs() < 1e-12);

        let departs = window(400, &[0.5, 0.0, -0.3]);
        let plain = alone_drift(&cfg, &departs, MOTOR);
        assert!(
            (plain.0 - 0.5).abs() > 2.0 * plain.1,
            "the misfit must show: {plain:?}"
        );
        let (d, se, misfit) = drifts(&cfg, &departs, FaultMode::Motor);
        assert_eq!(d[MOTOR], plain.0);
        // Widened by the Birge ratio √(χ²/2) = √misfit.
        assert!(misfit > 1.0);
        assert!(
            (se[MOTOR] / plain.1 - misfit.sqrt()).abs() < 1e-9,
            "{} against {} (misfit {misfit})",
            se[MOTOR],
            plain.1
        );
        assert!(
            (d[MOTOR] - 0.5).abs() < 2.0 * se[MOTOR],
            "drift {} ± {}",
            d[MOTOR],
            se[MOTOR]
        );
        // Where the healthy blocks wander that far along friction, the departure is within
        // the wander of a window of eight blocks, and nothing widens.
        let wandering = SequentialConfig {
            wander_cov: Some([0.0, 0.0, 0.0, 0.0, 0.0, 1.0]),
            ..cfg
        };
        assert!(misfit_llr(&wandering, &departs, MOTOR) <= 0.5 * MISFIT_DOF);
    }

    /// The first decision of a car whose trips, 2 minutes apart, stand at `level(k)` along
    /// the motor signature from trip 0, with CUSUM thresholds no window reaches: the GLR
    /// decides, and its drift is read on the motor CUSUM's window when that spans a line.
    fn decided_after(level: impl Fn(usize) -> f64) -> (usize, Decision) {
        decided_after_every(120.0, level)
    }

    /// [`decided_after`] with trips `spacing` seconds apart.
    fn decided_after_every(spacing: f64, level: impl Fn(usize) -> f64) -> (usize, Decision) {
        let mut cfg = unit_config();
        cfg.h = [[1e9; N_SIZES]; N_MODES];
        cfg.glr_h = Some([60.0; N_MODES]);
        cfg.wander = [0.05; N_MODES];
        let mut rng = Rng::new(5);
        let mut seq = Sequential::default();
        (0..2000)
            .map(|k| {
                let t = trip(spacing * k as f64, &[level(k), 0.0, 0.0], &mut rng);
                (k, seq.push(&cfg, &t, 0.5))
            })
            .find(|(_, d)| d.ratio >= 1.0)
            .expect("the change must be decided")
    }

    #[test]
    fn a_step_after_hours_of_wander_reads_its_level_and_a_ramp_its_line() {
        // Ten hours at +0.4 standard errors a trip, which keeps the motor's CUSUM of size 1/2
        // open all along, then a step of 4: the GLR decides within its shortest windows, and
        // the drift is the step's level, not the 10-hour window's line (which reads it
        // about half).
        let (k, d) = decided_after(|k| if k < 300 { 0.4 } else { 4.0 });
        assert!((300..300 + GLR_LENGTHS[1]).contains(&k), "decided at {k}");
        assert!(d.lead_glr);
        assert!(
            (d.drift[MOTOR] - 4.0).abs() < 2.0 * d.drift_se[MOTOR],
            "step: drift {} ± {}",
            d.drift[MOTOR],
            d.drift_se[MOTOR]
        );
        // A ramp from 0 by 1 standard error an hour: it reads where the ramp stands.
        let ramp = |k: usize| k as f64 / 30.0;
        let (k, d) = decided_after(ramp);
        assert!(
            (d.drift[MOTOR] - ramp(k)).abs() < 2.0 * d.drift_se[MOTOR],
            "ramp at {k}: drift {} ± {}",
            d.drift[MOTOR],
            d.drift_se[MOTOR]
        );
    }

    #[test]
    fn a_ramp_that_begins_hours_into_a_held_window_reads_where_it_stands() {
        // A trip every 5 minutes; 105 trips (nearly 9 hours) at +0.4 standard errors a trip
        // hold the motor's CUSUM window open, then a ramp of 1 standard error an hour begins
        // and is decided 29 trips in, as on the field bench's traced case (105 flat trips,
        // then 56 on the ramp). The window's line through the flat hours and the ramp read
        // it at 1.74 ± 0.25 where it stood at 2.82; its curve 2.10 ± 0.54, and the line's
        // level moved by the curve's shrunk bend ([`bend_shrunk`]) 2.06 ± 0.66.
        let level = |k: usize| 0.4 + (k.saturating_sub(105) as f64) / 12.0;
        let (k, d) = decided_after_every(300.0, level);
        assert!(k > 105, "decided at {k}");
        assert!(
            (d.drift[MOTOR] - level(k)).abs() < 2.0 * d.drift_se[MOTOR],
            "ramp at {k}: drift {} ± {} where it stands at {}",
            d.drift[MOTOR],
            d.drift_se[MOTOR],
            level(k)
        );
    }

    #[test]
    fn short_hops_decide_nothing_until_they_hold_a_windows_information() {
        // Fifty trips of a fifth of the mean information whose scores read five standard
        // deviations high each: no GLR window holds the information of its shortest length
        // in mean trips, so none is weighed; the same scores on trips of the mean
        // information are a change.
        let mut cfg = unit_config();
        cfg.glr_h = Some([30.0; N_MODES]);
        let run = |info: f64| {
            let mut seq = Sequential::default();
            let xtx = [info, 0.0, 0.0, info, 0.0, info];
            for k in 0..RECENT_TRIPS {
                let mut t = trip_with(&xtx, k as f64, &[0.0; 3], &mut Rng::new(k as u64));
                t.xtr = [5.0 * info.sqrt(), 0.0, 0.0];
                seq.push(&cfg, &t, f64::INFINITY);
            }
            seq.glr[MOTOR]
        };
        assert_eq!(run(0.2).z2, 0.0);
        let full = run(1.0);
        assert!(
            full.z2 > 30.0 && full.trips as usize == RECENT_TRIPS,
            "{full:?}"
        );
    }
}
