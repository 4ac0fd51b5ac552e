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

    /// Predicts voltage and force for one feature row, the network evaluated at the row's own
    /// (v, λ, a).
    pub fn predict(&self, x: &FeatureRow) -> Prediction {
        self.predict_with(x, self.net.forward(x.v, x.lambda, x.a))
    }
}
