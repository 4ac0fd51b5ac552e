//! Stage 4, the default stage-2 solver: L-BFGS (Nocedal & Wright, Alg. 7.4 and 7.5) with a
//! backtracking Armijo line search.
//!
//! ```text
//! d = −H·∇f                        two-loop recursion over the last M pairs (s, y),
//!                                  H₀ = (sᵀy/yᵀy)·I, or I/‖∇f‖ before the first pair
//! x ← x + t·d,  t = 1, ½, ¼, …     first t with f(x + t·d) ≤ f(x) + c₁·t·∇fᵀd
//! ```
//!
//! (A diagonal preconditioner scaled θ by its Gauss-Newton curvature while θ and the network
//! were fitted together; with θ held in stage 2 the network's weights need none.)
//!
//! A pair (s, y) enters the memory only when sᵀy > 10⁻¹²·‖s‖·‖y‖ (the curvature condition);
//! a direction that is not a descent direction clears the memory and restarts from steepest
//! descent.
//!
//! Stopping rule: after `max_iter` iterations; or when the last 50 iterations gained less than
//! 10⁻⁴ of the loss (past that the network only polishes noise); or when ‖∇f‖ < 10⁻⁹; or when
//! the line search finds no acceptable step in 40 halvings (that iteration is not counted).
//! Which of the four it was comes back as a [`Stop`], and the model file states it.

use crate::model::optim::{IterObserver, Problem, Stop};

/// M: pairs (s, y) kept in the memory. The network's loss has many directions of different
/// curvature, and ten pairs (the textbook's 3-20) forget them fast: at the default 1500
/// iterations on a week of 1 Hz data, thirty pairs end at a 3.3 % lower loss (RMS r_U 1.505
/// -> 1.463 V), sixty at about the same again; a pair costs two dot products and two updates of
/// 379 numbers per iteration, against a pass over thousands of samples.
const MEMORY: usize = 30;
/// c₁ of the Armijo condition: the share of the predicted decrease a step must achieve.
const ARMIJO_C1: f64 = 1e-4;
/// Halvings of the step the line search tries before it gives up.
const MAX_HALVINGS: usize = 40;
/// Curvature condition: a pair enters the memory only when sᵀy > this·‖s‖·‖y‖.
const MIN_CURVATURE: f64 = 1e-12;
/// Floor of ‖∇f‖ where the steepest-descent direction is normalised by it.
const MIN_GRAD_NORM: f64 = 1e-12;
/// Iterations over which the plateau test measures the gain.
pub const PLATEAU: usize = 50;
/// Relative gain over [`PLATEAU`] iterations below which the loss has converged.
pub const PLATEAU_GAIN: f64 = 1e-4;
/// ‖∇f‖ below which the minimum is reached.
pub const GRAD_TOL: f64 = 1e-9;

/// Minimises `problem` from `x0` for at most `max_iter` iterations, calling `on_iter` after
/// each accepted step; returns the iterations run, the final x and why it stopped.
pub fn minimise<P: Problem>(
    problem: &P,
    x0: &[f64],
    max_iter: usize,
    on_iter: IterObserver<'_, P::Stats>,
) -> (usize, Vec<f64>, Stop) {
    let n = x0.len();
    let mut x = x0.to_vec();
    let mut g = vec![0.0; n];
    let (mut f, _) = problem.eval(&x, Some(&mut g));
    let mut memory = Memory::default();
    let mut gn = vec![0.0; n];
    let mut xn = vec![0.0; n];
    let mut recent: Vec<f64> = Vec::with_capacity(PLATEAU + 1);
    for it in 1..=max_iter {
        let mut d = memory.direction(&g);
        let mut slope = dot(&g, &d);
        if slope >= 0.0 {
            // Not a descent direction: restart from steepest descent.
            memory.clear();
            d = g.iter().map(|v| -v / norm(&g).max(MIN_GRAD_NORM)).collect();
            slope = dot(&g, &d);
        }
        let step = LineSearch {
            x: &x,
            d: &d,
            f,
            slope,
        };
        let Some((fnew, st)) = step.run(problem, &mut xn, &mut gn) else {
            return (it - 1, x, Stop::LineSearch);
        };
        let s: Vec<f64> = (0..n).map(|i| xn[i] - x[i]).collect();
        let y: Vec<f64> = (0..n).map(|i| gn[i] - g[i]).collect();
        memory.push(s, y);
        x.copy_from_slice(&xn);
        g.copy_from_slice(&gn);
        f = fnew;
        on_iter(it, f, st, &x);
        recent.push(f);
        if recent.len() > PLATEAU {
            let old = recent.remove(0);
            if (old - f) < PLATEAU_GAIN * f.abs() {
                return (it, x, Stop::Plateau);
            }
        }
        if norm(&g) < GRAD_TOL {
            return (it, x, Stop::Gradient);
        }
    }
    (max_iter, x, Stop::Budget)
}

/// The last [`MEMORY`] pairs s = Δx, y = Δ∇f with ρ = 1/sᵀy.
#[derive(Default)]
struct Memory {
    s: Vec<Vec<f64>>,
    y: Vec<Vec<f64>>,
    rho: Vec<f64>,
}

impl Memory {
    /// d = −H·g by the two-loop recursion.
    fn direction(&self, g: &[f64]) -> Vec<f64> {
        let mut d: Vec<f64> = g.iter().map(|v| -v).collect();
        let k = self.s.len();
        let mut alpha = vec![0.0; k];
        for i in (0..k).rev() {
            alpha[i] = self.rho[i] * dot(&self.s[i], &d);
            axpy(-alpha[i], &self.y[i], &mut d);
        }
        let gamma = if k > 0 {
            dot(&self.s[k - 1], &self.y[k - 1]) / dot(&self.y[k - 1], &self.y[k - 1])
        } else {
            1.0 / norm(g).max(MIN_GRAD_NORM)
        };
        d.iter_mut().for_each(|v| *v *= gamma);
        for (i, alpha_i) in alpha.into_iter().enumerate() {
            let beta = self.rho[i] * dot(&self.y[i], &d);
            axpy(alpha_i - beta, &self.s[i], &mut d);
        }
        d
    }

    /// Keeps the pair when it satisfies the curvature condition, dropping the oldest when full.
    fn push(&mut self, s: Vec<f64>, y: Vec<f64>) {
        let sy = dot(&s, &y);
        if sy > MIN_CURVATURE * norm(&s) * norm(&y) {
            if self.s.len() == MEMORY {
                self.s.remove(0);
                self.y.remove(0);
                self.rho.remove(0);
            }
            self.s.push(s);
            self.y.push(y);
            self.rho.push(1.0 / sy);
        }
    }

    fn clear(&mut self) {
        self.s.clear();
        self.y.clear();
        self.rho.clear();
    }
}

/// A backtracking search along `d` from `x`, where f = `f` and ∇fᵀd = `slope`.
struct LineSearch<'a> {
    x: &'a [f64],
    d: &'a [f64],
    f: f64,
    slope: f64,
}

impl LineSearch<'_> {
    /// The value and statistics at the first step t = 1, ½, ¼, … that meets the Armijo
    /// condition, with the point in `xn` and its gradient in `gn`; `None` after
    /// [`MAX_HALVINGS`] failures.
    fn run<P: Problem>(
        &self,
        problem: &P,
        xn: &mut [f64],
        gn: &mut [f64],
    ) -> Option<(f64, P::Stats)> {
        let mut step = 1.0;
        for _ in 0..MAX_HALVINGS {
            for ((xn_i, x_i), d_i) in xn.iter_mut().zip(self.x).zip(self.d) {
                *xn_i = x_i + step * d_i;
            }
            let (fnew, st) = problem.eval(xn, Some(&mut *gn));
            if fnew.is_finite() && fnew <= self.f + ARMIJO_C1 * step * self.slope {
                return Some((fnew, st));
            }
            step *= 0.5;
        }
        None
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn norm(a: &[f64]) -> f64 {
    dot(a, a).sqrt()
}

/// y ← y + a·x.
fn axpy(a: f64, x: &[f64], y: &mut [f64]) {
    for (yi, xi) in y.iter_mut().zip(x) {
        *yi += a * xi;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// f(x) = Σ c_i·(x_i − 1)² with curvatures c_i spread over six decades.
    struct Valley;

    impl Problem for Valley {
        type Stats = ();
        fn eval(&self, x: &[f64], grad: Option<&mut [f64]>) -> (f64, ()) {
            let c = |i: usize| 10f64.powi(i as i32 - 3);
            if let Some(g) = grad {
                for (i, gi) in g.iter_mut().enumerate() {
                    *gi = 2.0 * c(i) * (x[i] - 1.0);
                }
            }
            let f = x
                .iter()
                .enumerate()
                .map(|(i, v)| c(i) * (v - 1.0).powi(2))
                .sum();
            (f, ())
        }
    }

    #[test]
    fn lbfgs_finds_the_bottom_of_an_ill_conditioned_valley_and_stops_early() {
        let x0 = vec![0.0; 7];
        let mut seen = 0;
        let (it, x, stop) = minimise(&Valley, &x0, 500, &mut |_, _, _, _| seen += 1);
        assert!(it < 500 && it == seen, "{it} iterations, {seen} observed");
        assert!(stop.converged(), "{stop:?}");
        for v in &x {
            assert!((v - 1.0).abs() < 1e-4, "{x:?}");
        }
        // Three iterations are not enough: the budget stops it, and says so.
        let (it, _, stop) = minimise(&Valley, &x0, 3, &mut |_, _, _, _| {});
        assert_eq!((it, stop), (3, Stop::Budget));
    }
}
