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
pub use train::{FitSummary, TrainConfig, DEFAULT_DRAWS};

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
    pub fn predict_with(&self, x: &FeatureRow, du_df: [f64; 2]) -> Prediction {
        let q = PhysParams::relative_height(x.floor, self.elevator.floors);
        self.predict_at(x, q, du_df)
    }

    /// [`HybridModel::predict_with`] with the relative height `q` of the row's floor given
    /// ([`PhysParams::relative_height`] of `x.floor`; a caller that keeps it between rows
    /// spares its division).
    pub fn predict_at(&self, x: &FeatureRow, q: f64, [du, df]: [f64; 2]) -> Prediction {
        let p = &self.parameters;
        let m_r = self.elevator.rated_load_kg;
        let f_phys = p.force(x.s, x.v, x.lambda, x.a, q, m_r);
        Prediction {
            u_pred: p.voltage(x.s, x.v, f_phys) + du,
            f_pred: f_phys + df,
            f_u: p.force_from_voltage(x.s, x.v, x.voltage, f_phys),
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
        (0.0, rest_lambda(rest_lambda_grid(x.lambda)), 0.0)
    } else {
        (x.v, x.lambda, x.a)
    }
}

/// Steps of λ per unit of rated load at rest: λ to 0.1 % of the rated load. The door-closed
/// reference is a running mean that moves in the last digits with every sample; the
/// correction does not.
pub const REST_LAMBDA_STEPS: f64 = 1000.0;

/// λ at rest on its grid, in grid steps: λ·1000 rounded (an integer as a float). What a memo
/// of outputs at rest keys on ([`crate::residual::PredictionCache`]): one multiplication,
/// where the λ the network sees ([`rest_lambda`]) costs a division more.
pub fn rest_lambda_grid(lambda: f64) -> f64 {
    round_half_away(lambda * REST_LAMBDA_STEPS)
}

/// The network's λ at rest from its grid steps ([`rest_lambda_grid`]).
pub fn rest_lambda(steps: f64) -> f64 {
    steps / REST_LAMBDA_STEPS
}

/// 2⁵²: from here on in magnitude every float is an integer.
const INTEGRAL_FLOATS: f64 = 4_503_599_627_370_496.0;

/// `y.round()` (halves away from zero) to the bit, without the call to `round` that the
/// baseline x86-64 target makes: the truncation toward zero, one more away from zero when the
/// fraction it dropped is a half or more (the fraction of a float is a float, so `y − t` is
/// exact), the sign of `y` kept (−0.3 rounds to −0). A float of 2⁵² or more in magnitude, ±∞
/// and NaN are their own rounding.
pub fn round_half_away(y: f64) -> f64 {
    if y.is_nan() || y.abs() >= INTEGRAL_FLOATS {
        return y;
    }
    let t = (y as i64) as f64;
    let f = y - t;
    let r = if f >= 0.5 {
        t + 1.0
    } else if f <= -0.5 {
        t - 1.0
    } else {
        t
    };
    r.copysign(y)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_half_away_is_the_bits_of_round() {
        let mut rng = crate::rng::Rng::new(9);
        let mut ys = vec![
            0.0,
            -0.0,
            0.3,
            -0.3,
            0.5,
            -0.5,
            1.5,
            -1.5,
            2.5,
            -2.5,
            0.499_999_999_999_999_94,
            -0.499_999_999_999_999_94,
            4_503_599_627_370_495.5,
            -4_503_599_627_370_495.5,
            4_503_599_627_370_496.0,
            9.0e15,
            1e300,
            -1e300,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
            952.000_000_000_000_1,
            999.499_999_999_999_9,
        ];
        for _ in 0..100_000 {
            // λ·1000 as the monitor meets it, and halves on and around the grid.
            let y = rng.uniform(-3000.0, 3000.0);
            ys.extend([y, y.trunc() + 0.5, y.trunc() - 0.5]);
        }
        for y in ys {
            assert_eq!(round_half_away(y).to_bits(), y.round().to_bits(), "{y:e}");
        }
        assert!(round_half_away(f64::NAN).is_nan());
    }
}
