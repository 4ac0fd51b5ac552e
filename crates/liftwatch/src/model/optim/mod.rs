//! Stage 4, the solvers of the fit: what minimises the objectives of [`loss`](crate::model::loss).
//!
//! ```text
//! Problem:   x ∈ ℝⁿ ↦ (f(x), ∇f(x))     a smooth objective over a flat parameter vector
//! Solver:    x₀ ↦ x̂ ≈ argmin f          given a problem, a start and an iteration budget
//! ```
//!
//! The seam follows argmin's split of problem (`core/problem.rs`) and solver
//! (`solver/quasinewton/lbfgs.rs`), reduced to what the fit needs: one trait, [`Problem`],
//! that [`lbfgs`] and [`adam`] take, implemented by the hybrid loss
//! [`Objective`]. [`gauss_newton`] solves the one least-squares
//! problem of stage 1, the voltage equation, and assembles its own normal equations.

pub mod adam;
pub mod gauss_newton;
pub mod lbfgs;

use serde::{Deserialize, Serialize};

use crate::model::loss::{HeldTheta, LossStats, Objective};

/// Why a stage-2 solver stopped. Stated in the model file (`fit.stage2_stop`), so a fit its
/// budget cut short is told apart from one that converged.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Stop {
    /// The iteration budget ran out (`TrainConfig::epochs`; Adam always runs it out).
    Budget,
    /// The last [`lbfgs::PLATEAU`] iterations gained less than [`lbfgs::PLATEAU_GAIN`] of the
    /// loss: converged as far as the loss can tell.
    Plateau,
    /// The gradient's norm fell below [`lbfgs::GRAD_TOL`]: at a minimum.
    Gradient,
    /// The line search found no step that lowers the loss: at a minimum within rounding, or
    /// stuck.
    LineSearch,
}

impl Stop {
    /// True for the criteria of convergence, false when something else stopped the solver.
    pub fn converged(self) -> bool {
        matches!(self, Stop::Plateau | Stop::Gradient)
    }
}

/// A smooth objective over a flat parameter vector: value and gradient.
pub trait Problem {
    /// What each evaluation reports beside the value (for progress lines and plots).
    type Stats;

    /// f(x), and ∇f(x) written into `grad` (of the length of `x`) when given.
    fn eval(&self, x: &[f64], grad: Option<&mut [f64]>) -> (f64, Self::Stats);
}

impl Problem for Objective<'_> {
    type Stats = LossStats;

    fn eval(&self, x: &[f64], grad: Option<&mut [f64]>) -> (f64, LossStats) {
        Objective::eval(self, x, grad)
    }
}

impl Problem for HeldTheta<'_> {
    type Stats = LossStats;

    fn eval(&self, x: &[f64], grad: Option<&mut [f64]>) -> (f64, LossStats) {
        HeldTheta::eval(self, x, grad)
    }
}

/// Called after every iteration with (iteration, value, statistics, parameters).
pub type IterObserver<'a, S> = &'a mut dyn FnMut(usize, f64, S, &[f64]);
