//! Stage 4, what the fit says about θ: standard errors and which parameters the data decided.
//!
//! ```text
//! σ̂_U  = 1.4826·MAD(U − U_phys(θ̂) − δU)                 robust noise of the final voltage fit
//! H    = Σ_i w_i·(∂U_phys/∂θ)ᵢᵀ(∂U_phys/∂θ)ᵢ/σ̂_U² + w_P·diag(1/τ_k²)
//! Cov  = H⁻¹,   se_k = √Cov_kk,   determined ⇔ se_k < τ_k/3
//! se(c) = √(∇cᵀ·Cov·∇c)  for the identifiable combinations Ke + Kd·c and Ke + α_down·Kd·c
//! ```
//!
//! The samples are taken as independent, so the standard errors are lower bounds where the
//! residuals within a trip are correlated; the network is held fixed.

use serde::{Deserialize, Serialize};

use crate::linalg::SquareMatrix;
use crate::model::loss::{Obs, Prior};
use crate::model::net::ResidualNet;
use crate::model::optim::lbfgs::PLATEAU;
use crate::model::optim::Stop;
use crate::model::physics::{PhysParams, N_PHYS};
use crate::model::train::TrainPoint;
use crate::stats::robust_sigma;

/// Floor of σ̂_U (V), so that a perfect fit gives a finite covariance.
const MIN_SIGMA_V: f64 = 1e-6;
/// A parameter is the data's when they narrowed its prior width at least this many times.
const DETERMINED_NARROWING: f64 = 3.0;
/// A combination is determined when its standard error is below this share of its value.
const DETERMINED_COMBINATION: f64 = 0.05;
/// The channel latency (s) for which the m0 warning states the inertia it fakes: 10 ms.
const LATENCY_STEP_S: f64 = 0.01;

/// What the data say about one parameter.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ParamReport {
    /// Name as in [`PhysParams::NAMES`], or a combination such as `ke + kd*c_visc`.
    pub name: String,
    /// Unit.
    pub unit: String,
    /// Identified value.
    pub value: f64,
    /// Standard error from the Gauss-Newton covariance (samples taken as independent, so a
    /// lower bound where residuals within a trip are correlated).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub std_error: Option<f64>,
    /// Prior width τ; none for combinations of parameters.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub prior_sd: Option<f64>,
    /// True when the data narrowed the prior at least threefold: the value is the data's.
    pub determined: bool,
    /// The value with the speed reading's noise taken out of stage 1 (errors in variables,
    /// [`crate::model::optim::gauss_newton`]): the physical constant, where `value` is what
    /// predicts the voltage best from readings as noisy as the training's, and what the
    /// model predicts with. `None` when no speed noise was measured.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub corrected: Option<f64>,
    /// Standard error from the spread of stage 1's θ fitted on each quarter of the training's
    /// motion alone (batch means, sd/√4): what the data determine when their residuals are
    /// correlated in time or θ moves through the training, which `std_error` does not see.
    /// `None` for combinations and parameters the prior decides, in models fitted before it
    /// was kept, and where a quarter cannot be fitted alone.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub quarters_se: Option<f64>,
}

/// What set a parameter's value ([`ParamReport::decided_by`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DecidedBy {
    /// The data narrowed the prior at least threefold.
    Data,
    /// The prior, which the data hardly narrowed.
    Prior,
    /// Held at 0 by the fit's own test: the loss asymmetry ε of a drive whose free fit put it
    /// within its noise of 0 (`EPS_HELD_SD`), the lossless drive of MODEL.md. The data
    /// decided it, though no standard error of the held fit says so.
    Held,
}

impl DecidedBy {
    /// The word of the fit's JSON summary (`decided_by`).
    pub fn code(self) -> &'static str {
        match self {
            DecidedBy::Data => "data",
            DecidedBy::Prior => "prior",
            DecidedBy::Held => "held",
        }
    }

    /// The words of the fit's table and the report's parameter panels.
    pub fn words(self) -> &'static str {
        match self {
            DecidedBy::Data => "data",
            DecidedBy::Prior => "prior (weakly identifiable)",
            DecidedBy::Held => "data: held at 0, no asymmetry beyond its noise",
        }
    }
}

impl ParamReport {
    /// What set the value: the data, the prior, or the fit's test that held it.
    pub fn decided_by(&self) -> DecidedBy {
        let held = self.name == PhysParams::NAMES[PhysParams::EPS]
            && self.prior_sd.is_some_and(|sd| sd <= EPS_HELD_SD);
        if held {
            DecidedBy::Held
        } else if self.determined {
            DecidedBy::Data
        } else {
            DecidedBy::Prior
        }
    }
}

/// One draw of the network's initial weights stage 2 ran from, and where it ended.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Stage2Draw {
    /// Seed of its initial weights (`fit --seed` of a fit that draws once gives this network).
    pub seed: u64,
    /// Iterations it ran.
    pub iterations: usize,
    /// Its final loss.
    #[serde(with = "crate::exact")]
    pub loss: f64,
    /// Whether it was the one carried on.
    pub kept: bool,
}

/// Why stage 2 stopped, and how far its loss still fell at the end.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Stage2Stop {
    /// Why the solver stopped.
    pub reason: Stop,
    /// Relative fall of the loss over the last [`PLATEAU`] iterations (or as many as
    /// ran), (L_{k−PLATEAU} − L_k)/L_k: below
    /// [`PLATEAU_GAIN`](crate::model::optim::lbfgs::PLATEAU_GAIN) the network has converged
    /// as far as the loss can tell; above it, the budget stopped a loss still falling by this
    /// share every [`PLATEAU`] iterations.
    #[serde(with = "crate::exact")]
    pub recent_gain: f64,
}

impl Stage2Stop {
    /// One line for people: how many iterations ran, why they stopped, and how much the loss
    /// still fell at the end.
    pub fn describe(&self, iterations: usize) -> String {
        let gain = 100.0 * self.recent_gain;
        let window = PLATEAU;
        match self.reason {
            Stop::Budget => format!(
                "Stage 2 ran its budget of {iterations} iterations, the loss still falling {gain:.2} % over the last {window} (not converged; --epochs sets the budget)"
            ),
            Stop::Plateau => format!(
                "Stage 2 converged after {iterations} iterations: the loss fell {gain:.4} % over the last {window}"
            ),
            Stop::Gradient => {
                format!("Stage 2 converged after {iterations} iterations: the gradient vanished")
            }
            Stop::LineSearch => format!(
                "Stage 2 stopped after {iterations} iterations: no step lowered the loss any more"
            ),
        }
    }
}

/// Everything the fit found besides the model itself.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct FitSummary {
    /// Moving samples used.
    pub moving_samples: usize,
    /// Standstill samples used.
    pub standstill_samples: usize,
    /// σ_v: the speed reading's noise measured on the cruising samples, what the `corrected`
    /// values of [`ParamReport`] take out (m/s; [`crate::model::train::speed_noise_of`]); 0 when
    /// too few showed it and in models written before it was measured.
    #[serde(default)]
    pub speed_noise_mps: f64,
    /// Per parameter and identifiable combination: value, standard error, determined or not.
    pub parameters: Vec<ParamReport>,
    /// Training history, thinned to at most a few hundred points.
    pub history: Vec<TrainPoint>,
    /// Final RMS of r_U over moving samples (V).
    pub rms_u_v: f64,
    /// Final RMS of r_F over moving samples (N).
    pub rms_f_n: f64,
    /// Loss after stage 1 and at the end.
    pub loss_stage1: f64,
    /// Final loss.
    pub loss_final: f64,
    /// Stage-2 iterations run.
    pub iterations: usize,
    /// How stage 2 ended; `None` when it did not run (`epochs` 0) and in models written
    /// before it was kept.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stage2_stop: Option<Stage2Stop>,
    /// The draws of the network stage 2 ran from, where it drew several
    /// ([`TrainConfig::draws`](super::TrainConfig::draws)); empty with one and in models
    /// written before draws were kept.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub draws: Vec<Stage2Draw>,
    /// Warnings about what the data could not determine.
    pub warnings: Vec<String>,
}

impl FitSummary {
    /// Which draw of the network stage 2 kept, against the others, e.g. "the lowest loss of
    /// 2 draws kept, 0.8944 (seed 11051901573049731021), against 0.9138 (seed 1)"; `None`
    /// when it drew once.
    pub fn kept_draw(&self) -> Option<String> {
        let kept = self.draws.iter().find(|d| d.kept)?;
        let others: Vec<String> = self
            .draws
            .iter()
            .filter(|d| !d.kept)
            .map(|d| format!("{:.4} (seed {})", d.loss, d.seed))
            .collect();
        Some(format!(
            "the lowest loss of {} draws kept, {:.4} (seed {}), against {}",
            self.draws.len(),
            kept.loss,
            kept.seed,
            others.join(", ")
        ))
    }
}

/// Standard errors from the Gauss-Newton covariance of the voltage equation at the final θ
/// with the network held fixed, which parameters the data determined, and the covariance
/// itself (`None` when it is singular).
pub(super) fn param_reports(
    data: &[Obs],
    p: &PhysParams,
    net: &ResidualNet,
    prior: &Prior,
    m_r: f64,
    w_p: f64,
) -> (Vec<ParamReport>, Vec<String>, Option<SquareMatrix>) {
    let sigma = robust_sigma(
        data.iter()
            .filter(|o| o.s != 0)
            .map(|o| o.u - o.u_phys(p, m_r) - net.forward(o.v, o.lambda, o.a)[0]),
    )
    .max(MIN_SIGMA_V);
    let mut warnings = Vec::new();
    let Some(cov) = covariance(data, p, prior, m_r, w_p, sigma) else {
        warnings
            .push("the parameter covariance is singular: standard errors are not available".into());
        return (without_errors(p, prior), warnings, None);
    };
    let t = p.to_array();
    let mut reps: Vec<ParamReport> = (0..N_PHYS)
        .map(|k| {
            let se = cov.get(k, k).max(0.0).sqrt();
            let determined = se < prior.sd[k] / DETERMINED_NARROWING;
            if k == PhysParams::EPS && prior.sd[k] <= EPS_HELD_SD {
                warnings.push(
                    "the drive shows no loss asymmetry beyond its noise: loss_asymmetry is held at 0, the lossless drive of MODEL.md".into(),
                );
            } else if !determined {
                warnings.push(format!(
                    "{} is set mostly by its prior (standard error {:.3} {} against prior width {:.3})",
                    PhysParams::NAMES[k],
                    se,
                    PhysParams::UNITS[k],
                    prior.sd[k]
                ));
            }
            ParamReport {
                name: PhysParams::NAMES[k].into(),
                unit: PhysParams::UNITS[k].into(),
                value: t[k],
                std_error: Some(se),
                prior_sd: Some(prior.sd[k]),
                determined,
                corrected: None,
                quarters_se: None,
            }
        })
        .collect();
    reps.extend(combinations(p, &cov));
    // Sensor timing: a relative latency Δτ between the speed and voltage channels adds
    // −Ke·Δτ·s·a to the voltage, the very shape of the inertia term Kd·M0·s·a.
    warnings.push(format!(
        "m0 is an apparent inertia: each 10 ms of latency of the voltage channel behind the speed channel lowers it by {:.0} kg",
        p.ke * LATENCY_STEP_S / p.kd
    ));
    warnings.extend(lagging_voltage_note(p, prior.centre.m0));
    let eps_se = cov.get(PhysParams::EPS, PhysParams::EPS).max(0.0).sqrt();
    warnings.extend(transmission_note(p.loss_asymmetry, eps_se));
    (reps, warnings, Some(cov))
}

/// The covariance of θ from the voltage equation's information on `data` at `p` with noise
/// σ = `sigma` (V) and the prior: (Σ w·J·Jᵀ/σ² + w_P·diag(1/τ²))⁻¹, J = ∂U/∂θ; `None` when
/// singular even with the prior.
pub(super) fn covariance(
    data: &[Obs],
    p: &PhysParams,
    prior: &Prior,
    m_r: f64,
    w_p: f64,
    sigma: f64,
) -> Option<SquareMatrix> {
    let mut h = SquareMatrix::zeros(N_PHYS);
    for o in data {
        let j = p
            .du_dtheta(o.s, o.v, o.lambda, o.a, o.q, m_r)
            .map(|v| v / sigma);
        h.add_outer(&j, o.w);
    }
    for k in 0..N_PHYS {
        *h.at(k, k) += w_p / (prior.sd[k] * prior.sd[k]);
    }
    Some(h.cholesky()?.cholesky_inverse())
}

/// τ of ε's prior where stage 1 found no loss asymmetry beyond its noise: ε is held at 0
/// (the lossless drive of MODEL.md), the other parameters fitted as without it.
pub(super) const EPS_HELD_SD: f64 = 1e-9;

/// Standard errors the loss asymmetry must stand from 0 before the fit names the
/// transmission's efficiency: the two-sided 5 % test.
const TRANSMISSION_Z: f64 = 2.0;

/// The note for a loss asymmetry ε that stands out of its standard error `se`: the two slopes
/// it gives the resistive term and the transmission efficiency η = √((1 − ε)/(1 + ε)) that
/// would give them (model::physics). A maintenance engineer reads a gear's wear there.
fn transmission_note(eps: f64, se: f64) -> Option<String> {
    (eps.abs() > TRANSMISSION_Z * se && eps.abs() < 1.0).then(|| {
        format!(
            "the drive's losses follow the power: the resistive term is {:.2} times Kd's slope while the motor drives the car and {:.2} times while the car drives the motor (loss_asymmetry {:.3} ± {:.3}), as a transmission of efficiency η ≈ {:.2} has it",
            1.0 + eps,
            1.0 - eps,
            eps,
            se,
            ((1.0 - eps) / (1.0 + eps)).sqrt()
        )
    })
}

/// Below this share of the M0 the elevator's description makes typical, the fitted M0 is no
/// mass: a real car and its counterweight alone weigh more, so it is timing (the voltage
/// channel lagging the speed channel fakes a negative inertia, and the fit stops M0 at 0).
const IMPLAUSIBLE_M0_SHARE: f64 = 0.5;

/// The note for an M0 too small to be a mass, with the voltage channel's lag behind the speed
/// channel that would explain it: Δτ ≈ Kd·(M0_typical − M0)/Ke. On a simulated 630 kg car
/// whose voltage reading lags its speed reading by 47 ms, M0 came out 0 kg (true 1,983) and
/// this says about 40 ms.
fn lagging_voltage_note(p: &PhysParams, typical_m0: f64) -> Option<String> {
    (p.m0 < IMPLAUSIBLE_M0_SHARE * typical_m0 && p.ke > 0.0).then(|| {
        format!(
            "m0 is {:.0} kg, under half of the {:.0} kg this elevator's description makes typical: not a mass but timing; the voltage channel probably lags the speed channel by about {:.0} ms, which 1 Hz data cannot tell from inertia (check the logger's timestamps)",
            p.m0,
            typical_m0,
            1000.0 * p.kd * (typical_m0 - p.m0) / p.ke
        )
    })
}

/// Sets each report's `corrected` value, parameters and combinations alike, from θ fitted
/// with the speed reading's noise taken out.
pub(super) fn set_corrected(reports: &mut [ParamReport], corrected: &PhysParams) {
    let values: Vec<(&str, f64)> = PhysParams::NAMES
        .into_iter()
        .zip(corrected.to_array())
        .chain(corrected.determined())
        .collect();
    for r in reports {
        r.corrected = values.iter().find(|(n, _)| *n == r.name).map(|(_, v)| *v);
    }
}

/// The reports when the covariance is singular: values and prior widths, nothing determined.
fn without_errors(p: &PhysParams, prior: &Prior) -> Vec<ParamReport> {
    PhysParams::NAMES
        .iter()
        .zip(p.to_array())
        .enumerate()
        .map(|(k, (n, v))| ParamReport {
            name: (*n).into(),
            unit: PhysParams::UNITS[k].into(),
            value: v,
            std_error: None,
            prior_sd: Some(prior.sd[k]),
            determined: false,
            corrected: None,
            quarters_se: None,
        })
        .collect()
}

/// The identifiable combinations: the |v| slope of the voltage up and down (of the lossless
/// slope Γ = φ; ε moves both by ±ε·Kd·c with the power's flow).
fn combinations(p: &PhysParams, cov: &SquareMatrix) -> [ParamReport; 2] {
    let combo = |name: &str, grad: [f64; N_PHYS], value: f64| {
        let se = cov.quad_form(&grad).max(0.0).sqrt();
        ParamReport {
            name: name.into(),
            unit: "V s/m".into(),
            value,
            std_error: Some(se),
            prior_sd: None,
            determined: se < DETERMINED_COMBINATION * value.abs(),
            corrected: None,
            quarters_se: None,
        }
    };
    [
        combo(
            "ke + kd*c_visc",
            [0.0, 0.0, 0.0, p.kd, p.c_visc, 1.0, 0.0, 0.0, 0.0, 0.0],
            p.ke + p.kd * p.c_visc,
        ),
        combo(
            "ke + alpha_down*kd*c_visc",
            [
                0.0,
                0.0,
                0.0,
                p.alpha_down * p.kd,
                p.alpha_down * p.c_visc,
                1.0,
                0.0,
                p.kd * p.c_visc,
                0.0,
                0.0,
            ],
            p.ke + p.alpha_down * p.kd * p.c_visc,
        ),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::elevator::Elevator;

    /// The lag in ms a note states.
    fn stated_ms(note: &str) -> f64 {
        note.split("by about ")
            .nth(1)
            .and_then(|t| t.split(' ').next())
            .and_then(|t| t.parse().ok())
            .expect("the note states the lag in ms")
    }

    #[test]
    fn a_loss_asymmetry_out_of_its_noise_is_read_as_the_transmissions_efficiency() {
        let note = transmission_note(0.162, 0.012).expect("ε at 13 standard errors is noted");
        assert!(note.contains("η ≈ 0.85"), "{note}");
        assert!(
            note.contains("1.16 times") && note.contains("0.84 times"),
            "{note}"
        );
        assert_eq!(
            transmission_note(0.01, 0.012),
            None,
            "ε within its noise is not"
        );
    }

    #[test]
    fn an_m0_too_small_for_a_mass_is_read_as_the_voltage_lagging() {
        let e = Elevator::new(630.0, 1.0, 8);
        let mut p = PhysParams::prior_centre(&e);
        let typical = p.m0;
        assert_eq!(
            lagging_voltage_note(&p, typical),
            None,
            "a typical M0 is a mass"
        );
        // A voltage lagging the speed by Δτ takes Ke·Δτ/Kd off the apparent mass: here 70 %
        // of it, which the note turns back into Δτ.
        let lag_ms = 1000.0 * 0.7 * typical * p.kd / p.ke;
        p.m0 = 0.3 * typical;
        let note = lagging_voltage_note(&p, typical).expect("an M0 far below typical is noted");
        assert!(
            (stated_ms(&note) - lag_ms).abs() <= 0.5,
            "{note} vs {lag_ms:.1} ms"
        );
        // A longer lag stops M0 at its bound of 0: the note's lag is then a lower bound.
        p.m0 = 0.0;
        let note = lagging_voltage_note(&p, typical).expect("M0 at 0 is noted");
        assert!(stated_ms(&note) > lag_ms, "{note}");
        // Just above half of typical, nothing is said.
        p.m0 = 0.51 * typical;
        assert_eq!(lagging_voltage_note(&p, typical), None);
    }
}
