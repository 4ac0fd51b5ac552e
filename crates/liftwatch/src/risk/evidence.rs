//! Stage 6, per-trip evidence: the trip-mean residuals and each trip's share of the
//! fault-signature regression (normal equations of r_U on the signatures, per sample 1/n),
//! and the two helpers on their packed 3×3 matrices (`unpack`, `spd_inverse`) that the tracker
//! and the sequential decision both use.
//!
//! ```text
//! x_motor = φ(s)·Kd·s·F_pred    x_brake = φ(s)·Kd·F_c·1[s = −1 or decel]    x_fric = φ(s)·Kd·(F_c + c·|v|)
//! per trip: mean e_U, mean e_F, mean w·x·xᵀ, mean w·x·r_U, mean w·r_U²
//!           w = σ²/(σ² + (Ke·Δ²v/8)² + (Δ²U/8)²), the fit's interpolation weight of the sample
//!
//! winding temperature (healthy, predicted): a first-order lag of the copper losses with the
//! winding's time constant τ (identified per elevator, [`crate::calibrate`]) and the daily
//! cycle of the machine room around it:
//!   H ← e^(−Δt/τ)·H + (1 − e^(−Δt/τ))·(F_pred/F_ref)²   Δt at most HEAT_INPUT_SPAN_S; a row
//!                                        of unknown input adds the recent one ([`Heating`])
//!   basis b = (H, cos ωt, sin ωt),  ω = 2π/day
//!   x_heat,k = x_motor·b_k                the voltage of Kd·(1 + Σ β_k·b_k): copper's
//!                                        resistance follows its temperature, the losses
//!                                        I²R ∝ F² through the winding's thermal lag plus the
//!                                        ambient's daily swing
//!   per trip: mean x·x_heat,k, mean x_heat,k·x_heat,l, mean x_heat,k·r_U
//!
//! the load cell's zero, the one sensor fault that moves the machine evidence:
//!   x_load = φ(s)·Kd·s·Q·(g + a)          ∂U_pred/∂λ: a reading high by Δλ (share of the
//!                                        rated load Q) adds Q·(g + a)·Δλ to the expected force,
//!                                        so r_U = −x_load·Δλ
//!   per trip: mean x_load·x, mean x_load², mean x_load·x_heat,k, mean x_load·r_U
//! ```
//!
//! The coefficients β_k are identified on the healthy trips beside the signatures
//! ([`crate::calibrate`]) and taken out of every trip before any decision
//! ([`TripEvidence::without_heating`]): a busy hour warms the winding and raises Kd by a few
//! per cent, and a motor signature that does not know it sees a fault in the morning rush.
//!
//! ```text
//! the signatures at the winding's present Kd (models calibrated with the levels θ_h):
//!   k = 1 + θ_h,motor + Σ β_k·b̄_k          b̄: the trip's mean basis; θ_h: the signatures'
//!                                        healthy levels in the regression that found β
//!   r_U → r_U − Σ β_k·x_heat,k − Σ θ_h,m·x_m,   x_m → k·x_m
//! ```
//!
//! A degradation's voltage passes through the Kd the winding has at that moment: a Kd step of
//! +25 % is +25 % of a cool winding's Kd at night and of a warm one's at noon, and a drag force
//! is multiplied by either. Against the fit's Kd (the training's mean winding) the field-like
//! evaluation's +25 % steps read +22.5 to +23.1 % at a night-time first advisory, 2.7
//! standard errors short; against the present Kd, +23.5 to +24.7 %. The healthy levels go
//! out with the heating because a level left in the residual would be divided by k and
//! wander with the winding: scaling without taking them out named fewer brakes on every
//! suite and raised a false `friction` advisory with week-long trainings.

use crate::sample::DAY_S;
use serde::{Deserialize, Serialize};

use super::{RiskConfig, BRAKE, FRICTION, MOTOR, N_MODES};
use crate::elevator::G;
use crate::exact;
use crate::features::{FeatureRow, Phase};
use crate::model::train::{
    interpolation_weight_of, TrainingRow, TrainingRows, INTERPOLATION_NOISE_SHARE,
};
use crate::model::{HybridModel, PhysParams, Prediction};
use crate::residual::{PredictionCache, Residuals};

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
    /// The trip's share of the winding-temperature regressors x_heat; zero in evidence
    /// written before they were kept (or with another basis), which then carries no heating.
    #[serde(default)]
    pub thermal: HeatEvidence,
    /// The trip's share of the load-cell zero's regressor x_load; zero in evidence written
    /// before it was kept, which then cannot tell a load-cell zero from the drive.
    #[serde(default)]
    pub load: LoadEvidence,
}

/// A trip's means of the load-cell zero's regressor x_load = ∂U_pred/∂λ against the
/// signatures, itself, the heating basis and r_U: the alternative the isolation weighs
/// against the machine modes ([`crate::risk::sequential`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LoadEvidence {
    /// Mean of x_load·x_m per signature m (V² per unit λ).
    pub xm: [f64; N_MODES],
    /// Mean of x_load² (V² per unit λ²).
    pub ll: f64,
    /// Mean of x_load·x_heat,k (V² per unit λ).
    pub xh: [f64; N_HEAT],
    /// Mean of x_load·r_U (V² per unit λ).
    pub lr: f64,
}

/// A trip's means of the winding-temperature regressors x_heat,k = x_motor·b_k against the
/// signatures, each other and r_U.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct HeatEvidence {
    /// Mean of x_m·x_heat,k per basis term k and signature m (V²).
    pub xh: [[f64; N_MODES]; N_HEAT],
    /// Mean of x_heat,k·x_heat,l (V²).
    pub hh: [[f64; N_HEAT]; N_HEAT],
    /// Mean of x_heat,k·r_U (V²).
    pub hr: [f64; N_HEAT],
    /// b̄: mean of the basis b_k over the trip's moving samples (1); zero in evidence written
    /// before it was kept.
    #[serde(default)]
    pub b: [f64; N_HEAT],
}

impl HeatEvidence {
    /// Σ β_k·b̄_k: the relative rise of Kd the heating β gives the trip's mean basis.
    pub fn warmth(&self, beta: &[f64; N_HEAT]) -> f64 {
        beta.iter().zip(&self.b).map(|(beta, b)| beta * b).sum()
    }
}

impl TripEvidence {
    /// True when the trip counts as machine evidence.
    pub fn usable(&self, cfg: &RiskConfig) -> bool {
        self.plausible && self.n >= cfg.min_trip_samples && self.mean_e_u.is_finite()
    }

    /// The trip with the healthy heating of the winding taken out of its residual:
    /// r_U − Σ β_k·x_heat,k in every sum over r_U; and, when the healthy `levels` θ_h of the
    /// signatures are given ([`Winding::levels`]), those taken out too, r_U − Σ θ_h,m·x_m,
    /// and every signature made the winding's present Kd, k·x with k = 1 + θ_h,motor +
    /// Σ β_k·b_k. β = 0 without levels leaves the trip as it is.
    pub fn without_heating(
        &self,
        beta: &[f64; N_HEAT],
        levels: Option<&[f64; N_MODES]>,
    ) -> TripEvidence {
        let mut t = self.clone();
        if beta.iter().all(|b| *b == 0.0) && levels.is_none() {
            return t;
        }
        let h = &self.thermal;
        let mut rr = self.rr;
        for k in 0..N_HEAT {
            for m in 0..N_MODES {
                t.xtr[m] -= beta[k] * h.xh[k][m];
            }
            rr -= 2.0 * beta[k] * h.hr[k];
            t.load.lr -= beta[k] * self.load.xh[k];
            for l in 0..N_HEAT {
                rr += beta[k] * h.hh[k][l] * beta[l];
                t.thermal.hr[k] -= beta[l] * h.hh[k][l];
            }
        }
        t.rr = rr.max(0.0);
        if let Some(levels) = levels {
            t.follow_the_winding(beta, levels);
        }
        t
    }

    /// Takes the healthy levels θ_h out of the residual, then scales every signature by the
    /// winding's present Kd over the fit's, the trip's k = 1 + θ_h,motor + Σ β_k·b̄_k (b̄ its
    /// mean basis): x → k·x in every sum that holds one. The residual's sums must already
    /// have the heating taken out. k is taken constant within a trip: the lag moves by a
    /// trip's length over τ (under 1 % of its range for a half-minute trip and τ of 45 min),
    /// the ambient cycle by less.
    fn follow_the_winding(&mut self, beta: &[f64; N_HEAT], levels: &[f64; N_MODES]) {
        let xtx = unpack(&self.xtx);
        let along =
            |row: &[f64; N_MODES]| -> f64 { (0..N_MODES).map(|m| levels[m] * row[m]).sum() };
        let moved = xtx.map(|row| along(&row));
        self.rr = (self.rr - 2.0 * along(&self.xtr) + along(&moved)).max(0.0);
        for i in 0..N_MODES {
            self.xtr[i] -= moved[i];
        }
        for k in 0..N_HEAT {
            self.thermal.hr[k] -= along(&self.thermal.xh[k]);
        }
        self.load.lr -= along(&self.load.xm);
        let k = 1.0 + levels[MOTOR] + self.thermal.warmth(beta);
        self.xtx = self.xtx.map(|v| k * k * v);
        self.xtr = self.xtr.map(|v| k * v);
        self.load.xm = self.load.xm.map(|v| k * v);
        for row in &mut self.thermal.xh {
            *row = row.map(|v| k * v);
        }
    }

    /// Mean squared regression residual of the trip for coefficients θ (V²).
    pub(crate) fn fit_error(&self, theta: &[f64; N_MODES]) -> f64 {
        fit_error(&self.xtx, &self.xtr, self.rr, theta)
    }
}

/// Mean squared regression residual of a trip with sums x·xᵀ, x·r and r² for coefficients θ
/// (V²): r² − 2θ·(x·r) + θᵀ(x·xᵀ)θ, never below 0.
pub(crate) fn fit_error(
    xtx: &[f64; 6],
    xtr: &[f64; N_MODES],
    rr: f64,
    theta: &[f64; N_MODES],
) -> f64 {
    let xtx = unpack(xtx);
    let mut q = rr;
    for i in 0..N_MODES {
        q -= 2.0 * theta[i] * xtr[i];
        for j in 0..N_MODES {
            q += theta[i] * xtx[i][j] * theta[j];
        }
    }
    q.max(0.0)
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

/// The forces the drift coefficients are shares of (N): the brake's is a share of F_c, the
/// friction's of the friction force at the rated speed, F_c + c·v_r, both of
/// [`friction_reference`].
///
/// A change of friction shows in the voltage as a force, and its newtons are what the data
/// determine: the coefficient times the force it scales, whatever that force is. Its share in
/// percent is only as good as the fitted friction level, which the voltage pins through the
/// up/down asymmetry (1 − α_down)·Kd·F alone, so a tenth of a volt of direction-dependent
/// timing error moves it by a hundred newtons (a simulated 630 kg car fits 435 N at rated
/// speed against a true 357 N, and its friction steps read 0.3-0.6 of the truth in percent).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DriftScale {
    /// Newtons per unit of the brake coefficient: the reference F_c.
    pub brake_n: f64,
    /// Newtons per unit of the friction coefficient: the reference friction at rated speed.
    pub friction_n: f64,
}

impl DriftScale {
    /// The scale of `model`'s drift coefficients.
    pub fn of(model: &HybridModel) -> Self {
        let (f_c, c_visc) = friction_reference(model);
        DriftScale {
            brake_n: f_c,
            friction_n: f_c + c_visc * model.elevator.rated_speed_mps,
        }
    }
}

/// The load-cell zero's regressor of one moving sample of predicted force `f_pred`:
/// ∂U_pred/∂λ = Γ·Kd·s·Q·(g + a) (V per unit of λ, the load as a share of the rated load Q):
/// the inertia and the weight of a load that the cell reads but the car does not carry. The
/// network's share of ∂U/∂λ is left out: it corrects the physics by a few per cent.
pub fn load_signature(model: &HybridModel, x: &FeatureRow, f_pred: f64) -> f64 {
    let p = &model.parameters;
    p.gain(x.s, f_pred) * p.kd * f64::from(x.s) * model.elevator.rated_load_kg * (G + x.a)
}

/// The fault-signature regressors of one moving sample (V per unit coefficient);
/// `friction` is [`friction_reference`] of `model`, computed once by the caller. Each is a
/// force times Γ·Kd at the sample's predicted force `f_pred`: the slope of its power's flow
/// ([`crate::model::PhysParams::gain`]), as a change of force moves the voltage there.
pub fn signature(
    model: &HybridModel,
    friction: (f64, f64),
    x: &FeatureRow,
    f_pred: f64,
) -> [f64; N_MODES] {
    let p = &model.parameters;
    let (f_c, c_visc) = friction;
    let phi_kd = p.gain(x.s, f_pred) * p.kd;
    let s = f64::from(x.s);
    let braking = x.s == -1 || x.phase == Phase::Decelerating;
    let mut out = [0.0; N_MODES];
    out[MOTOR] = phi_kd * s * f_pred;
    out[BRAKE] = if braking { phi_kd * f_c } else { 0.0 };
    out[FRICTION] = phi_kd * (f_c + c_visc * x.v.abs());
    out
}

/// Regressors of the winding-temperature basis: the lag H of the copper losses and the two
/// phases of the daily ambient cycle.
pub const N_HEAT: usize = 3;

/// Index of the lag H in the basis; the daily harmonic follows it.
pub const HEAT_LAG: usize = 0;

/// The winding time constant a model without an identified one assumes (s): 45 min, the
/// middle of the 30-60 min of traction machines (MODEL.md).
pub const DEFAULT_WINDING_TAU_S: f64 = 2700.0;

/// Length of the ambient cycle (s): the machine room warms and cools with the day.
pub const AMBIENT_PERIOD_S: f64 = DAY_S;

/// The winding's healthy temperature response, identified by the calibration.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Winding {
    /// τ: thermal time constant of the lag H (s).
    pub tau_s: f64,
    /// β_k: relative change of Kd per unit of each basis term (H, cos ωt, sin ωt):
    /// Kd·(1 + Σ β_k·b_k). β_H is the rise at a steady force F_ref (copper: 0.39 %/K times the
    /// winding's rise there in K); (β_cos, β_sin) the machine room's daily swing. 0 when the
    /// training did not show it (and in models fitted before it was kept, which then take no
    /// heating out).
    pub beta: [f64; N_HEAT],
    /// Standard errors of β on the training (1); 0 when β was not identified.
    pub beta_se: [f64; N_HEAT],
    /// θ_h: the signatures' healthy levels in the joint regression that identified β. Given,
    /// they are taken out of every trip beside the heating, and every signature is scaled by
    /// the winding's present Kd over the fit's, k = 1 + θ_h,motor + Σ β_k·b_k
    /// ([`TripEvidence::without_heating`], the module's notes): a motor coefficient is then a
    /// relative change of the Kd the winding has, a drag or friction coefficient a force.
    /// `None` in models calibrated before they were kept, whose thresholds expect the fit's Kd.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub levels: Option<[f64; N_MODES]>,
}

impl Default for Winding {
    fn default() -> Self {
        Winding {
            tau_s: DEFAULT_WINDING_TAU_S,
            beta: [0.0; N_HEAT],
            beta_se: [0.0; N_HEAT],
            levels: None,
        }
    }
}

impl Winding {
    /// The steady rise of Kd at a continuous force F_ref (1).
    pub fn steady_rise(&self) -> f64 {
        self.beta[HEAT_LAG]
    }

    /// Half the peak-to-peak daily swing of Kd (1) and the hour of its peak (0-24, in the
    /// timestamps' own clock).
    pub fn ambient_swing(&self) -> (f64, f64) {
        let (c, s) = (self.beta[HEAT_LAG + 1], self.beta[HEAT_LAG + 2]);
        let hour = s.atan2(c).rem_euclid(std::f64::consts::TAU) / std::f64::consts::TAU * 24.0;
        (c.hypot(s), hour)
    }

    /// `trip` with the winding's healthy heating taken out and, where this winding keeps the
    /// signatures' healthy levels, those too and the signatures read at the winding's present
    /// Kd ([`TripEvidence::without_heating`]).
    pub fn take_out(&self, trip: &TripEvidence) -> TripEvidence {
        trip.without_heating(&self.beta, self.levels.as_ref())
    }

    /// True when the training showed any of it.
    pub fn identified(&self) -> bool {
        self.beta.iter().any(|b| *b != 0.0)
    }
}

/// The force the heating is measured in (N): the full-load motoring force (1 − q)·M_r·g of
/// the elevator description, at which a machine's rated winding rise is quoted. H = 1 is a
/// winding that has run at that force for many time constants.
pub fn heating_reference(model: &HybridModel) -> f64 {
    let e = &model.elevator;
    ((1.0 - e.counterweight_ratio()) * e.rated_load_kg * G).max(1.0)
}

/// The longest interval a reading speaks for (s): the winding's input between two rows further
/// apart than this (a log with hours missing, a restart) is unknown, as it is in the empty
/// rows of a gap. A minute: above any row step a winding's lag of 5 min to 8 h can be
/// followed at (a 1 Hz log aligned to 1-30 s), and short against τ.
pub const HEAT_INPUT_SPAN_S: f64 = 60.0;

/// The winding-temperature state: H, a first-order lag of (F_pred/F_ref)² with the winding's
/// time constant τ (no input while the car stands: the drive's losses at rest are small), and
/// the basis b = (H, cos ωt, sin ωt) it gives each sample. The default is a winding at
/// ambient; its first sample finds it long cold, so a monitor started on a moving car takes
/// that car's load as the winding's.
///
/// A sample whose input is not known does not cool the winding: a dropout of the load cell
/// (or of the voltage, without which no prediction is formed) leaves a moving car's force
/// unknown, and a gap of every channel (or of the speed) leaves unknown even whether the car
/// moves. Taking such samples as a car at rest, as
/// this lag once did, let the winding cool in the model while the car ran a busy lunch: after
/// a 13-minute load dropout on a simulated 40-floor car, Kd stood 4 % above the model for
/// half an hour and the motor CUSUM raised a false advisory. Now a moving car of unknown
/// force adds what the recent moving samples added ([`Heating::moving`]), and a sample of
/// unknown motion adds H itself (the lag's own estimate of the recent input), which holds it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Heating {
    /// H (1).
    #[serde(with = "exact")]
    pub h: f64,
    /// Time of the last sample (s), none before the first.
    pub last: Option<f64>,
    /// The input of the recent moving samples whose force is known: a lag of theirs with the
    /// same τ, counted in moving time. 0 before the first (and in states saved before it was
    /// kept).
    #[serde(with = "exact", default)]
    pub moving: f64,
    /// The lag's factor e^(−span/τ) of the last span and τ it was taken for: rows come one
    /// step apart, so one exponential serves nearly every row (the same bits: it is that
    /// call's result). Not part of the state: equal states may hold different memos.
    #[serde(skip)]
    keep: KeepMemo,
}

/// The last e^(−span/τ) of [`Heating::step`], keyed by the bits of span and τ.
#[derive(Clone, Copy, Debug, Default)]
struct KeepMemo(Option<(u64, u64, f64)>);

impl KeepMemo {
    /// e^(−span/τ), from the memo when span and τ are those of the last call.
    fn keep(&mut self, span: f64, tau_s: f64) -> f64 {
        let key = (span.to_bits(), tau_s.to_bits());
        match self.0 {
            Some((s, t, k)) if (s, t) == key => k,
            _ => {
                let k = (-span / tau_s).exp();
                self.0 = Some((key.0, key.1, k));
                k
            }
        }
    }
}

/// A memo is no part of the state it rides on: every two are equal.
impl PartialEq for KeepMemo {
    fn eq(&self, _: &KeepMemo) -> bool {
        true
    }
}

/// What a sample tells the winding's lag ([`Heating::advance`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum HeatInput {
    /// The car stands: no input.
    Rest,
    /// The car moves with this squared relative force (F/F_ref)².
    Moving(f64),
    /// The car moves, its force unknown (no prediction: the load, the acceleration or the
    /// voltage missing).
    MovingUnknown,
    /// Whether the car moves is not known (no speed).
    Unknown,
}

impl HeatInput {
    /// The input of a row that does not move: a car at rest when its velocity is `known`
    /// (finite), else one whose motion is unknown.
    pub fn still(known: bool) -> HeatInput {
        if known {
            HeatInput::Rest
        } else {
            HeatInput::Unknown
        }
    }

    /// The input of feature row `x` with its prediction (if any); the reference force
    /// `f_ref` ([`heating_reference`]).
    pub fn of_row(f_ref: f64, x: &FeatureRow, p: Option<&Prediction>) -> HeatInput {
        if x.s == 0 || !x.v.is_finite() {
            return HeatInput::still(x.v.is_finite());
        }
        match p {
            Some(p) if p.f_pred.is_finite() => HeatInput::Moving((p.f_pred / f_ref).powi(2)),
            _ => HeatInput::MovingUnknown,
        }
    }
}

impl Heating {
    /// Advances to `time` with `input` held since the last sample (at most
    /// `HEAT_INPUT_SPAN_S` of it; before that the input is unknown and holds H), and returns
    /// the basis at `time` (a `Moving` force that is not finite counts as `MovingUnknown`).
    /// Time that runs backwards or is not finite holds H.
    pub fn advance(&mut self, tau_s: f64, time: f64, input: HeatInput) -> [f64; N_HEAT] {
        self.step(tau_s, time, input);
        self.basis(time)
    }

    /// [`Self::advance`] without the basis: the lag's update alone, for a caller that needs
    /// the basis only on some samples (the monitor: moving ones) and spares the others its
    /// cosine and sine.
    pub fn step(&mut self, tau_s: f64, time: f64, input: HeatInput) {
        if !time.is_finite() {
            return;
        }
        let dt = self.last.map_or(f64::INFINITY, |last| time - last);
        if dt > 0.0 {
            // Within the span the sample speaks for; an interval beyond it held H, so only
            // the span's share of the lag moves.
            let span = if self.last.is_some() {
                dt.min(HEAT_INPUT_SPAN_S)
            } else {
                dt
            };
            let keep = self.keep.keep(span, tau_s);
            let load = match input {
                HeatInput::Rest => Some(0.0),
                HeatInput::Moving(l) if l.is_finite() => {
                    self.moving = keep * self.moving + (1.0 - keep) * l;
                    Some(l)
                }
                // A state saved before `moving` was kept has it at 0 under a warm H: H is
                // then the best guess of the recent input.
                HeatInput::Moving(_) | HeatInput::MovingUnknown => Some(if self.moving > 0.0 {
                    self.moving
                } else {
                    self.h
                }),
                HeatInput::Unknown => None,
            };
            if let Some(load) = load {
                self.h = keep * self.h + (1.0 - keep) * load;
            }
            self.last = Some(time);
        }
    }

    /// The basis at `time` after [`Self::step`] to it: H and the ambient's daily phase
    /// (none at a time that is not finite).
    pub fn basis(&self, time: f64) -> [f64; N_HEAT] {
        if !time.is_finite() {
            return [self.h, 0.0, 0.0];
        }
        let phase = std::f64::consts::TAU * (time / AMBIENT_PERIOD_S).fract();
        [self.h, phase.cos(), phase.sin()]
    }

    /// Advances over feature row `x` with its prediction (if any): the force of a moving
    /// sample heats, a standing car cools, a sample of unknown input holds H or adds the
    /// recent moving input ([`HeatInput::of_row`]). Returns the basis.
    pub fn advance_row(
        &mut self,
        (f_ref, tau_s): (f64, f64),
        x: &FeatureRow,
        p: Option<&Prediction>,
    ) -> [f64; N_HEAT] {
        self.step_row((f_ref, tau_s), x, p);
        self.basis(x.time)
    }

    /// [`Self::advance_row`] without the basis ([`Self::step`]).
    pub fn step_row(&mut self, (f_ref, tau_s): (f64, f64), x: &FeatureRow, p: Option<&Prediction>) {
        self.step(tau_s, x.time, HeatInput::of_row(f_ref, x, p));
    }
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
    #[serde(default)]
    thermal: HeatEvidence,
    #[serde(default)]
    load: LoadEvidence,
}

impl TripAccumulator {
    /// Adds one moving sample with its prediction, residuals and winding-temperature basis
    /// ([`Heating`]); standstill samples and samples without a voltage residual are ignored.
    /// `friction` is [`friction_reference`] of `model`.
    pub fn push(
        &mut self,
        model: &HybridModel,
        friction: (f64, f64),
        x: &FeatureRow,
        (p, r): (&Prediction, &Residuals),
        heating: [f64; N_HEAT],
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
        // Weighted as in the fit: a sample whose instant interpolation blurs (trip edges, jerk
        // phases) carries a voltage error of Ke·|Δ²v|/8 and |Δ²U|/8 that moves with the phase of
        // the channels' clocks over days, and the evidence gives it the little trust the fit
        // does.
        let w = interpolation_weight_of(
            x,
            model.parameters.ke,
            INTERPOLATION_NOISE_SHARE * model.elevator.rated_voltage(),
        );
        let sig = signature(model, friction, x, p.f_pred);
        let x_heat = heating.map(|h| sig[MOTOR] * h);
        let mut k = 0;
        for i in 0..N_MODES {
            self.xtr[i] += w * sig[i] * r.r_u;
            for j in i..N_MODES {
                self.xtx[k] += w * sig[i] * sig[j];
                k += 1;
            }
        }
        for (l, xl) in x_heat.iter().enumerate() {
            self.thermal.b[l] += heating[l];
            for i in 0..N_MODES {
                self.thermal.xh[l][i] += w * sig[i] * xl;
            }
            self.thermal.hr[l] += w * xl * r.r_u;
            for (hh, xq) in self.thermal.hh[l].iter_mut().zip(&x_heat) {
                *hh += w * xl * xq;
            }
        }
        let xl = load_signature(model, x, p.f_pred);
        for m in 0..N_MODES {
            self.load.xm[m] += w * xl * sig[m];
        }
        for (k, xh) in x_heat.iter().enumerate() {
            self.load.xh[k] += w * xl * xh;
        }
        self.load.ll += w * xl * xl;
        self.load.lr += w * xl * r.r_u;
        self.rr += w * r.r_u * r.r_u;
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
            thermal: HeatEvidence {
                xh: a.thermal.xh.map(|row| row.map(|v| v / n)),
                hh: a.thermal.hh.map(|row| row.map(|v| v / n)),
                hr: a.thermal.hr.map(|v| v / n),
                b: a.thermal.b.map(|v| v / n),
            },
            load: LoadEvidence {
                xm: a.load.xm.map(|v| v / n),
                ll: a.load.ll / n,
                xh: a.load.xh.map(|v| v / n),
                lr: a.load.lr / n,
            },
        })
    }
}

/// The healthy trips of a training set, for [`crate::calibrate::calibrate`]: residuals of `rows`
/// with `model`, summed per trip (trips as marked by [`FeatureRow::trip`]), the winding's lag
/// at `tau_s`; a row at rest belongs to no trip, as [`crate::features::FeatureTracker`] makes
/// them. Plausibility of the raw sensors is not checked here: training data are healthy by
/// assumption.
pub fn trip_evidence(model: &HybridModel, rows: &[FeatureRow], tau_s: f64) -> Vec<TripEvidence> {
    trip_evidence_from(
        model,
        &TrainingRows::from_rows(rows.iter().copied()),
        tau_s,
        &[],
    )
}

/// The model's predictions of the samples [`trip_evidence`] sums (moving, with a voltage
/// residual) among `moving`, the moving rows, in order: what the passes of the winding's
/// search over its time constants share, made once (a network pass per moving sample, each
/// the same whatever τ is).
pub(crate) fn evidence_predictions(model: &HybridModel, moving: &[FeatureRow]) -> Vec<Prediction> {
    let mut cache = PredictionCache::default();
    moving
        .iter()
        .filter(|x| counts_as_evidence(x))
        .map(|x| cache.predict(model, x))
        .collect()
}

/// [`trip_evidence`] of the rows the fit keeps ([`TrainingRows`]) with the predictions of its
/// samples given in order ([`evidence_predictions`]); samples past their end are predicted
/// here.
pub(crate) fn trip_evidence_from(
    model: &HybridModel,
    rows: &TrainingRows,
    tau_s: f64,
    predictions: &[Prediction],
) -> Vec<TripEvidence> {
    let mut out = Vec::new();
    let mut acc = TripAccumulator::default();
    let mut cache = PredictionCache::default();
    let mut given = predictions.iter();
    let friction = friction_reference(model);
    let thermal = (heating_reference(model), tau_s);
    let mut heating = Heating::default();
    let mut open: Option<u32> = None;
    for row in rows.iter() {
        // A row at rest is in no trip.
        let trip = match row {
            TrainingRow::Moving(x) => x.trip,
            TrainingRow::Still { .. } => None,
        };
        if trip != open {
            out.extend(acc.finish(true));
            open = trip;
        }
        let x = match row {
            TrainingRow::Moving(x) => x,
            TrainingRow::Still { time, known } => {
                heating.step(tau_s, time, HeatInput::still(known));
                continue;
            }
        };
        if counts_as_evidence(x) {
            let p = match given.next() {
                Some(p) => *p,
                None => cache.predict(model, x),
            };
            let r = Residuals::from_prediction(model, x, &p);
            let h = heating.advance_row(thermal, x, Some(&p));
            acc.push(model, friction, x, (&p, &r), h);
        } else {
            heating.step_row(thermal, x, None);
        }
    }
    out.extend(acc.finish(true));
    debug_assert!(predictions.is_empty() || given.next().is_none());
    out
}

/// Whether a feature row is a sample of a trip's evidence: moving, with a voltage residual.
fn counts_as_evidence(x: &FeatureRow) -> bool {
    x.s != 0 && crate::residual::applicable(x)
}

/// Where the diagonal (i, i) of a packed upper triangle lies: the entries [`unpack`] puts on
/// the diagonal.
pub(crate) const PACKED_DIAG: [usize; 3] = [0, 3, 5];

/// The symmetric 3×3 matrix of a packed upper triangle (00, 01, 02, 11, 12, 22).
pub(crate) fn unpack(p: &[f64; 6]) -> [[f64; 3]; 3] {
    [[p[0], p[1], p[2]], [p[1], p[3], p[4]], [p[2], p[4], p[5]]]
}

/// The packed upper triangle of a symmetric 3×3 matrix, [`unpack`]'s inverse.
pub(crate) fn pack(a: &[[f64; 3]; 3]) -> [f64; 6] {
    [a[0][0], a[0][1], a[0][2], a[1][1], a[1][2], a[2][2]]
}

/// A·v for a 3×3 matrix A.
pub(crate) fn mat_vec(a: &[[f64; 3]; 3], v: &[f64; 3]) -> [f64; 3] {
    std::array::from_fn(|i| (0..3).map(|j| a[i][j] * v[j]).sum())
}

/// Inverse of a symmetric positive-definite 3×3 matrix by Cholesky; `None` when it is not.
pub(crate) fn spd_inverse(p: &[f64; 6]) -> Option<[[f64; 3]; 3]> {
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
