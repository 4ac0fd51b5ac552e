//! Stage 6, the tracker: online re-identification of the signature coefficients (recursive
//! least squares with forgetting) and the time-accumulated risks, combined and per mode.
//!
//! ```text
//! θ̂ = A⁻¹b,  A ← λ·A + XᵀX,  b ← λ·b + Xᵀr            per trip, λ = 1 − 1/H
//! z_m = min((θ̂_m − θ0_m) / max(σ_m, k_m·SE_m), ℓ_m / max(σ'_m, SE'_m)),  c_m = ln(1 + max(0, z_m))
//!       ℓ_m = (b_m − (A·θ0)_m)/A_mm, signature m's level alone ([`Rls::alone`])
//! x = max(0, c − τ),  D ← D + 1 if x > 0 else 0,  R ← γ·R + x·exp(κ·min(D, D_max))
//! ```

// Three-by-three matrices and per-mode arrays read best with explicit indices.
#![allow(clippy::needless_range_loop)]

use serde::{Deserialize, Serialize};

use super::evidence::{fit_error, spd_inverse, unpack, PACKED_DIAG};
use super::sequential::{Decision, Sequential, TripWeights};
use super::{RiskConfig, TripEvidence, N_MODES};
use crate::exact;

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
        self.update_sums(&t.xtx, &t.xtr, forget);
    }

    /// Forgets by `forget`, then adds a trip's sums x·xᵀ and x·r.
    fn update_sums(&mut self, xtx: &[f64; 6], xtr: &[f64; N_MODES], forget: f64) {
        for k in 0..6 {
            self.a[k] = forget * self.a[k] + xtx[k];
        }
        for k in 0..N_MODES {
            self.b[k] = forget * self.b[k] + xtr[k];
        }
    }

    /// Each signature's level alone against `theta0`, (b_m − (A·θ0)_m)/A_mm, with its
    /// variance s²/A_mm: what the memory shows along one signature, the way the sequential
    /// decision reads a window ([`super::sequential`]). On a car whose three signatures are
    /// nearly collinear (the 630 kg car, mostly empty) the joint θ̂ splits a small offset of
    /// the healthy level into large opposite drifts (a 3-hour model read Kd −16 %, brake drag
    /// +800 N and friction −270 N on the healthy car), which a one-sided lens takes for a
    /// fault; alone, each signature shows the offset's projection on it, no more. `None` for a
    /// signature without information yet.
    pub fn alone(&self, theta0: &[f64; N_MODES], s2: f64) -> [Option<(f64, f64)>; N_MODES] {
        let m = unpack(&self.a);
        std::array::from_fn(|i| {
            let aii = m[i][i];
            let healthy: f64 = (0..N_MODES).map(|j| m[i][j] * theta0[j]).sum();
            (aii > 0.0).then(|| ((self.b[i] - healthy) / aii, (s2 / aii).sqrt()))
        })
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
        if x > 0.0 {
            self.d = self.d.saturating_add(1);
            let gain = (cfg.kappa * f64::from(self.d).min(cfg.d_max_trips)).exp();
            self.r = cfg.gamma * self.r + x * gain;
        } else {
            // Most healthy trips: nothing to add, and no exponential to take. A risk that has
            // decayed below the smallest normal float is none: left to decay on, it becomes a
            // subnormal number, whose every multiplication takes the processor a slow path of
            // about a hundred cycles (R and its three lenses were a quarter of the
            // calibration's bootstrap, spent on numbers below 1e-308).
            self.d = 0;
            self.r *= cfg.gamma;
            if self.r < f64::MIN_POSITIVE {
                self.r = 0.0;
            }
        }
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
}

/// The trip-level lens of one trip, which no tracker state changes: e_trip and
/// c = ln(1 + e_trip).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct TripLens {
    c: f64,
    e_trip: f64,
}

impl TripLens {
    /// e_trip = √((z_U² + z_F²)/2) of the trip-mean residuals over their healthy spread at
    /// the trip's length (|z_U| without a force residual), and its c.
    fn of(cfg: &RiskConfig, t: &TripEvidence) -> Self {
        let n = f64::from(t.n.max(1));
        let z_u = t.mean_e_u / (cfg.trip_spread_u[0] + cfg.trip_spread_u[1] / n).sqrt();
        let z_f = t.mean_e_f / (cfg.trip_spread_f[0] + cfg.trip_spread_f[1] / n).sqrt();
        let e_trip = if z_f.is_finite() {
            ((z_u * z_u + z_f * z_f) / 2.0).sqrt()
        } else {
            z_u.abs()
        };
        let e = if e_trip.is_finite() { e_trip } else { 0.0 };
        TripLens {
            c: e.ln_1p(),
            e_trip,
        }
    }
}

/// A healthy trip as the calibration's bootstraps take it, thousands of times over: what no
/// tracker state changes, formed once per trip of the record ([`TripLens`], the decision's
/// [`TripWeights`], whether it is usable). Each draw may move the trip's score by an hour's
/// level ([`RiskTracker::push_risk_levels`]); its x·xᵀ, and so all of this, stays.
pub(crate) struct PreparedTrip<'a> {
    trip: &'a TripEvidence,
    usable: bool,
    lens: TripLens,
    weights: Option<TripWeights>,
}

impl<'a> PreparedTrip<'a> {
    /// `trip` prepared for a tracker of `cfg`: for its trip spreads and shortest usable trip,
    /// and its sequential decision's θ0, s², se0 and pooled information (the thresholds may
    /// change after, as the calibration sets them; nothing else may).
    pub(crate) fn new(cfg: &RiskConfig, trip: &'a TripEvidence) -> Self {
        PreparedTrip {
            trip,
            usable: trip.usable(cfg),
            lens: TripLens::of(cfg, trip),
            weights: cfg.sequential.as_ref().map(|seq| seq.weights(&trip.xtx)),
        }
    }

    /// The trip's x·r with its signature levels moved by `offset` (coefficient units of
    /// each signature alone): each score by its information times the offset, r² left as
    /// it was.
    fn xtr(&self, offset: Option<&[f64; N_MODES]>) -> [f64; N_MODES] {
        let t = self.trip;
        match offset {
            Some(o) => std::array::from_fn(|m| t.xtr[m] + t.xtx[PACKED_DIAG[m]] * o[m]),
            None => t.xtr,
        }
    }
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
    /// The sequential decision ([`super::sequential`]); all zero without one.
    #[serde(default)]
    pub decision: Decision,
}

/// θ̂ of the regression as the last trip left it: the next trip's prediction error needs
/// exactly that estimate, and keeping it saves one 3×3 inversion per trip. Not state: a
/// resumed tracker recomputes it from the same sums, and two trackers are equal whatever
/// their memo holds.
#[derive(Clone, Copy, Debug, Default)]
struct Memo(Option<[f64; N_MODES]>);

impl PartialEq for Memo {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

/// The risk state of one elevator: re-identification, accumulators and the last assessment.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RiskTracker {
    rls: Rls,
    #[serde(skip)]
    theta: Memo,
    #[serde(with = "exact")]
    s2: f64,
    combined: Accumulator,
    modes: [Accumulator; N_MODES],
    #[serde(default)]
    seq: Sequential,
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
            theta: Memo::default(),
            s2: cfg.prior_s2,
            combined: Accumulator::default(),
            modes: [Accumulator::default(); N_MODES],
            seq: Sequential::default(),
            trips: 0,
            last: TripAssessment::default(),
        }
    }

    /// Updates the re-identification with one trip and forms its statistics.
    pub(crate) fn statistics(&mut self, cfg: &RiskConfig, t: &TripEvidence) -> TripStatistics {
        self.statistics_of(cfg, &t.xtx, &t.xtr, t.rr, TripLens::of(cfg, t))
    }

    /// [`RiskTracker::statistics`] of a trip given as its regression sums and its lens.
    fn statistics_of(
        &mut self,
        cfg: &RiskConfig,
        xtx: &[f64; 6],
        xtr: &[f64; N_MODES],
        rr: f64,
        lens: TripLens,
    ) -> TripStatistics {
        let forget = cfg.forgetting();
        // The regression residual variance, tracked with the same horizon, from the error
        // of the estimate before this trip (a prediction error, so a fault inflates it late).
        let before = self
            .theta
            .0
            .or_else(|| self.rls.estimate(1.0).map(|(theta, _)| theta));
        if let Some(theta) = before {
            self.s2 = forget * self.s2 + (1.0 - forget) * fit_error(xtx, xtr, rr, &theta);
        }
        self.rls.update_sums(xtx, xtr, forget);
        let mut c_modes = [0.0; N_MODES];
        let a = &mut self.last;
        a.e_trip = lens.e_trip;
        let estimate = self.rls.estimate(self.s2);
        self.theta = Memo(estimate.map(|(theta, _)| theta));
        if let Some((theta, var)) = estimate {
            let alone = cfg
                .lens_sd
                .is_some()
                .then(|| self.rls.alone(&cfg.healthy_coef, self.s2));
            for m in 0..N_MODES {
                a.drift[m] = theta[m] - cfg.healthy_coef[m];
                a.drift_se[m] = var[m].sqrt();
                let joint = a.drift[m] / cfg.joint_scale(m, a.drift_se[m]);
                // And no more than the signature's level alone shows: a change both views
                // agree on (the joint drifts attribute it, the level alone rules out a split
                // of near-collinear signatures).
                let z = match alone {
                    Some(levels) => {
                        joint.min(levels[m].map_or(0.0, |(d, se)| d / cfg.alone_scale(m, se)))
                    }
                    None => joint,
                };
                a.z[m] = z.max(0.0);
                // ln(1 + 0) is 0 (and ±0 itself): no logarithm for the common healthy lens.
                c_modes[m] = if a.z[m] > 0.0 { a.z[m].ln_1p() } else { a.z[m] };
            }
        } else {
            a.drift = [f64::NAN; N_MODES];
            a.drift_se = [f64::NAN; N_MODES];
            a.z = [0.0; N_MODES];
        }
        TripStatistics { c: lens.c, c_modes }
    }

    /// Takes one trip of machine evidence (callers pass only plausible trips, with the
    /// winding's heating taken out: [`Winding::take_out`](super::Winding::take_out)) and returns the
    /// updated assessment.
    pub fn push(&mut self, cfg: &RiskConfig, t: &TripEvidence) -> TripAssessment {
        if !t.usable(cfg) {
            return self.last;
        }
        let s = self.statistics(cfg, t);
        self.accumulate(cfg, &s);
        if let Some(seq) = &cfg.sequential {
            let mut d = self.seq.push(seq, t, cfg.release_ratio);
            // While a change is held, its drift is the one measured on the changed trips, not
            // the long memory's lagged fraction of it.
            if d.ratio >= cfg.release_ratio && d.drift.iter().all(|v| v.is_finite()) {
                self.last.drift = d.drift;
                self.last.drift_se = d.drift_se;
            } else {
                // The drifts shown are the long memory's, which no misfit widened.
                d.misfit = 0.0;
            }
            self.last.decision = d;
        }
        self.last
    }

    /// What the calibration's bootstraps read of one prepared trip, in two halves: this one
    /// takes it as [`RiskTracker::push`] does for the risks, its signature levels moved by
    /// `offset` when one is given ([`PreparedTrip`]), and returns R and the per-mode risks
    /// after it; [`RiskTracker::push_decision_levels`] takes it for the decision. The two
    /// halves share no state, so a tracker taking one half and another the other hold the
    /// bits of [`RiskTracker::push`] (the calibration runs them side by side on two threads).
    /// A tracker taken this way is not one whose decisions are read.
    pub(crate) fn push_risk_levels(
        &mut self,
        cfg: &RiskConfig,
        p: &PreparedTrip,
        offset: Option<&[f64; N_MODES]>,
    ) -> (f64, [f64; N_MODES]) {
        if p.usable {
            let xtr = p.xtr(offset);
            let s = self.statistics_of(cfg, &p.trip.xtx, &xtr, p.trip.rr, p.lens);
            self.accumulate(cfg, &s);
        }
        (self.last.risk, self.last.risk_modes)
    }

    /// The decision's half of [`RiskTracker::push_risk_levels`]: advances the sequential
    /// decision's G and GLR windows alone ([`Sequential::advance_g`]; read them with
    /// [`RiskTracker::cusum_g`] and [`RiskTracker::glr_z2`]) and returns its ratio. The
    /// decision's mode, windows and drifts are not formed (its CUSUMs' windows stay empty).
    pub(crate) fn push_decision_levels(
        &mut self,
        cfg: &RiskConfig,
        p: &PreparedTrip,
        offset: Option<&[f64; N_MODES]>,
    ) -> f64 {
        debug_assert_eq!(cfg.sequential.is_some(), p.weights.is_some());
        if p.usable {
            if let (Some(seq), Some(w)) = (&cfg.sequential, &p.weights) {
                let xtr = p.xtr(offset);
                self.last.decision.ratio = self.seq.advance_g(seq, &xtr, &p.trip.xtx, w);
            }
        }
        self.last.decision.ratio
    }

    /// The accumulated risks of one usable trip's statistics, into the latest assessment.
    fn accumulate(&mut self, cfg: &RiskConfig, s: &TripStatistics) {
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
    }

    /// The longest run of trips a CUSUM holds as changed while its G/h is at least the
    /// release ratio (0 when none does, or without a sequential decision): where a change began.
    pub fn held_window_trips(&self, cfg: &RiskConfig) -> u32 {
        let Some(seq) = &cfg.sequential else {
            return 0;
        };
        let mut longest = 0;
        if let Some(h) = seq.glr_h {
            for (g, h) in self.seq.glr.iter().zip(h) {
                if g.z2 >= cfg.release_ratio * h {
                    longest = longest.max(g.trips);
                }
            }
        }
        for (m, row) in self.seq.bank.iter().enumerate() {
            for (j, c) in row.iter().enumerate() {
                if c.g >= cfg.release_ratio * seq.h[m][j] {
                    longest = longest.max(c.trips);
                }
            }
        }
        longest
    }

    /// G of every CUSUM now, per mode and size (for calibration).
    pub fn cusum_g(&self) -> [[f64; super::sequential::N_SIZES]; N_MODES] {
        self.seq.g()
    }

    /// z² of the window-limited GLR now, per mode (for calibration).
    pub fn glr_z2(&self) -> [f64; N_MODES] {
        self.seq.glr.map(|g| g.z2)
    }
}
