//! Stage 4, the paper's optimiser: Adam (Kingma & Ba, 2015), full batch.
//!
//! ```text
//! g_t = ∇f(x_{t−1})
//! m_t = β₁·m_{t−1} + (1 − β₁)·g_t          first moment
//! v_t = β₂·v_{t−1} + (1 − β₂)·g_t²         second moment
//! x_t = x_{t−1} − η·(m_t/(1 − β₁ᵗ)) / (√(v_t/(1 − β₂ᵗ)) + ε)
//! ```
//!
//! Stopping rule: none but the budget; it runs exactly `epochs` epochs, as the paper trains.

use crate::model::optim::{IterObserver, Problem};

/// β₁: decay of the first-moment (mean gradient) estimate, Kingma & Ba's default.
const BETA1: f64 = 0.9;
/// β₂: decay of the second-moment (mean squared gradient) estimate, Kingma & Ba's default.
const BETA2: f64 = 0.999;
/// ε: keeps the step finite where the second moment is zero, Kingma & Ba's default.
const EPSILON: f64 = 1e-8;

/// Minimises `problem` from `x` in place with learning rate `lr` for `epochs` epochs, calling
/// `on_iter` after each; returns the epochs run.
pub fn minimise<P: Problem>(
    problem: &P,
    x: &mut [f64],
    epochs: usize,
    lr: f64,
    on_iter: IterObserver<'_, P::Stats>,
) -> usize {
    let (b1, b2, eps) = (BETA1, BETA2, EPSILON);
    let n = x.len();
    let (mut m, mut v, mut g) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    for t in 1..=epochs {
        let (f, st) = problem.eval(x, Some(&mut g));
        let (c1, c2) = (1.0 - b1.powi(t as i32), 1.0 - b2.powi(t as i32));
        for i in 0..n {
            m[i] = b1 * m[i] + (1.0 - b1) * g[i];
            v[i] = b2 * v[i] + (1.0 - b2) * g[i] * g[i];
            x[i] -= lr * (m[i] / c1) / ((v[i] / c2).sqrt() + eps);
        }
        on_iter(t, f, st, x);
    }
    epochs
}

#[cfg(test)]
mod tests {
    use super::*;

    /// f(x) = Σ (x_i − i)², minimum at x_i = i.
    struct Bowl;

    impl Problem for Bowl {
        type Stats = ();
        fn eval(&self, x: &[f64], grad: Option<&mut [f64]>) -> (f64, ()) {
            if let Some(g) = grad {
                for (i, gi) in g.iter_mut().enumerate() {
                    *gi = 2.0 * (x[i] - i as f64);
                }
            }
            (
                x.iter()
                    .enumerate()
                    .map(|(i, v)| (v - i as f64).powi(2))
                    .sum(),
                (),
            )
        }
    }

    #[test]
    fn adam_runs_its_whole_budget_and_reaches_the_bottom_of_a_bowl() {
        let mut x = vec![0.0; 3];
        let mut calls = 0;
        let run = minimise(&Bowl, &mut x, 3000, 0.01, &mut |_, _, _, _| calls += 1);
        assert_eq!((run, calls), (3000, 3000));
        for (i, v) in x.iter().enumerate() {
            assert!((v - i as f64).abs() < 1e-3, "x_{i} = {v}");
        }
    }
}
