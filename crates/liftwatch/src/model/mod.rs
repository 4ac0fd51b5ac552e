//! Stage 4: the hybrid model, physics plus a correcting network (paper, Sec. 3.2-3.3).
//!
//! ```text
//! U_pred = U_phys(v, λ, a; θ) + δU(x)
//! F_pred = F_phys(v, λ, a; θ) + δF(x)
//! F_U    = (U − U0 − Ke·|v|) / (φ(s)·Kd·s)      the force the measured voltage implies
//! ```
//!
//! [`HybridModel`] holds θ, the network and the healthy residual scales σ and makes the one
//! prediction every later stage uses. [`physics`] holds θ and the equations, [`net`] the
//! network, [`loss`] the training objective and [`train`] the identification. The whole fitted
//! artefact, with every later stage's calibrated settings, is [`crate::fit::FittedModel`].

pub mod loss;
pub mod net;
pub mod optim;
pub mod physics;
pub mod train;

use serde::{Deserialize, Serialize};

use crate::elevator::Elevator;
use crate::features::FeatureRow;

pub use net::ResidualNet;
pub use physics::PhysParams;
pub use train::{FitSummary, TrainConfig};

/// Healthy residual scales σ_U, σ_F from the fit: they make the residuals dimensionless.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ResidualScales {
    /// σ_U: robust standard deviation of r_U on healthy moving samples (V).
    pub sigma_u_v: f64,
    /// σ_F: robust standard deviation of r_F on healthy moving samples (N).
    pub sigma_f_n: f64,
}

/// What the hybrid model predicts for one sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Prediction {
    /// U_pred: predicted motor voltage (V).
    pub u_pred: f64,
    /// F_pred: predicted driving force (N).
    pub f_pred: f64,
    /// F_U: the force the measured voltage implies (N); NaN at rest or without voltage.
    pub f_u: f64,
}

/// The identified hybrid model of one elevator: θ, the correcting network and σ.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HybridModel {
    /// The elevator description the model was fitted for.
    pub elevator: Elevator,
    /// Identified physical parameters θ.
    pub parameters: PhysParams,
    /// The correcting network.
    pub net: ResidualNet,
    /// Healthy residual scales.
    pub scales: ResidualScales,
}

impl HybridModel {
    /// Predicts voltage and force for one feature row, with the network's correction
    /// `[δU, δF]` already evaluated for the row's inputs, and the force implied by its voltage.
    pub fn predict_with(&self, x: &FeatureRow, [du, df]: [f64; 2]) -> Prediction {
        let p = &self.parameters;
        let m_r = self.elevator.rated_load_kg;
        let q = PhysParams::relative_height(x.floor, self.elevator.floors);
        let f_phys = p.force(x.s, x.v, x.lambda, x.a, q, m_r);
        Prediction {
            u_pred: p.voltage(x.s, x.v, f_phys) + du,
            f_pred: f_phys + df,
            f_u: p.force_from_voltage(x.s, x.v, x.voltage),
        }
    }

    /// Predicts voltage and force for one feature row, the network evaluated at the row's
    /// [`net_inputs`].
    pub fn predict(&self, x: &FeatureRow) -> Prediction {
        let (v, lambda, a) = net_inputs(x);
        self.predict_with(x, self.net.forward(v, lambda, a))
    }
}

/// The network's inputs for a row: its own (v, λ, a) while moving; (0, λ, 0) at standstill,
/// λ rounded to 0.001.
///
/// Deviation from a literal reading of the model: below the motion threshold the encoder's
/// speed and the acceleration estimate are noise around zero, the car is held by the brake,
/// and the correction is evaluated at rest. The physics keep the measured v (its Ke·|v| term
/// is not negligible), only the network's inputs are pinned, so that consecutive standstill
/// samples share one forward pass per λ (`residual::PredictionCache`). [`HybridModel::predict`]
/// pins them the same way, and the fit's standstill observations are (0, λ, 0) already: a
/// standstill row a few mm/s from rest is corrected as at rest, inside the rest box of the
/// network's [`net::InputDomain`], not pushed to the slowest speed seen moving.
pub fn net_inputs(x: &FeatureRow) -> (f64, f64, f64) {
    if x.s == 0 {
        // λ to 0.1 % of rated load: the door-closed reference is a running mean that moves in
        // the last digits with every sample; the correction does not.
        (0.0, (x.lambda * 1000.0).round() / 1000.0, 0.0)
    } else {
        (x.v, x.lambda, x.a)
    }
}
