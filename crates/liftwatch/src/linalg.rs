//! Small dense linear algebra for the fit: symmetric positive-definite solves and inverses, and
//! the positive semi-definite part of a 3×3 covariance.
//!
//! Written by hand: the fit's normal equations are at most a few dozen unknowns, where a
//! Cholesky factorisation is twenty lines and a linear-algebra crate would cost more
//! compile time than all of liftwatch.

/// A dense square matrix stored row-major.
#[derive(Clone, Debug, PartialEq)]
pub struct SquareMatrix {
    n: usize,
    a: Vec<f64>,
}

impl SquareMatrix {
    /// The n×n zero matrix.
    pub fn zeros(n: usize) -> Self {
        SquareMatrix {
            n,
            a: vec![0.0; n * n],
        }
    }

    /// Order of the matrix.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Element (i, j).
    pub fn get(&self, i: usize, j: usize) -> f64 {
        self.a[i * self.n + j]
    }

    /// Mutable element (i, j).
    pub fn at(&mut self, i: usize, j: usize) -> &mut f64 {
        &mut self.a[i * self.n + j]
    }

    /// uᵀ·A·u: the variance of uᵀ·x when A is the covariance of x.
    pub fn quad_form(&self, u: &[f64]) -> f64 {
        (0..self.n)
            .map(|i| u[i] * (0..self.n).map(|j| self.get(i, j) * u[j]).sum::<f64>())
            .sum()
    }

    /// Adds `w·g·gᵀ` (a rank-one update of normal equations).
    pub fn add_outer(&mut self, g: &[f64], w: f64) {
        for i in 0..self.n {
            let wi = w * g[i];
            if wi == 0.0 {
                continue;
            }
            let row = &mut self.a[i * self.n..(i + 1) * self.n];
            for (r, gj) in row.iter_mut().zip(g) {
                *r += wi * gj;
            }
        }
    }

    /// Lower-triangular Cholesky factor L with A = L·Lᵀ, or `None` when A is not positive definite.
    pub fn cholesky(&self) -> Option<SquareMatrix> {
        let n = self.n;
        let mut l = SquareMatrix::zeros(n);
        for j in 0..n {
            let mut d = self.get(j, j);
            for k in 0..j {
                d -= l.get(j, k) * l.get(j, k);
            }
            if !(d > 0.0 && d.is_finite()) {
                return None;
            }
            let d = d.sqrt();
            *l.at(j, j) = d;
            for i in j + 1..n {
                let mut s = self.get(i, j);
                for k in 0..j {
                    s -= l.get(i, k) * l.get(j, k);
                }
                *l.at(i, j) = s / d;
            }
        }
        Some(l)
    }

    /// Solves A·x = b given the Cholesky factor `self` = L of A.
    pub fn cholesky_solve(&self, b: &[f64]) -> Vec<f64> {
        let n = self.n;
        let mut y = b.to_vec();
        for i in 0..n {
            for k in 0..i {
                y[i] -= self.get(i, k) * y[k];
            }
            y[i] /= self.get(i, i);
        }
        for i in (0..n).rev() {
            for k in i + 1..n {
                y[i] -= self.get(k, i) * y[k];
            }
            y[i] /= self.get(i, i);
        }
        y
    }

    /// The inverse of A given the Cholesky factor `self` = L of A.
    pub fn cholesky_inverse(&self) -> SquareMatrix {
        let n = self.n;
        let mut inv = SquareMatrix::zeros(n);
        let mut e = vec![0.0; n];
        for j in 0..n {
            e.iter_mut().for_each(|x| *x = 0.0);
            e[j] = 1.0;
            for (i, x) in self.cholesky_solve(&e).into_iter().enumerate() {
                *inv.at(i, j) = x;
            }
        }
        inv
    }
}

/// The positive semi-definite part of a symmetric 3×3 matrix: its eigen-decomposition with
/// the negative eigenvalues set to zero (the nearest PSD matrix in the Frobenius norm). A
/// covariance estimated as a difference (a spread less the noise that explains part of it)
/// can come out indefinite where a direction's spread is all noise; that direction has no
/// excess, not a negative one. Cyclic Jacobi rotations: a 3×3 converges to rounding in a few
/// sweeps.
pub fn psd_part3(a: [[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let mut d = a;
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for _sweep in 0..50 {
        let off = d[0][1].powi(2) + d[0][2].powi(2) + d[1][2].powi(2);
        let scale = d[0][0].powi(2) + d[1][1].powi(2) + d[2][2].powi(2);
        // Converged (or not a number, which no rotation mends).
        if off <= 1e-30 * scale || off.is_nan() {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if d[p][q] == 0.0 {
                continue;
            }
            let theta = (d[q][q] - d[p][p]) / (2.0 * d[p][q]);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let t = if theta == 0.0 { 1.0 } else { t };
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            // D ← Jᵀ·D·J, V ← V·J with the rotation J in the (p, q) plane.
            for row in &mut d {
                let (dkp, dkq) = (row[p], row[q]);
                row[p] = c * dkp - s * dkq;
                row[q] = s * dkp + c * dkq;
            }
            let (row_p, row_q) = (d[p], d[q]);
            for k in 0..3 {
                d[p][k] = c * row_p[k] - s * row_q[k];
                d[q][k] = s * row_p[k] + c * row_q[k];
            }
            for row in &mut v {
                let (vp, vq) = (row[p], row[q]);
                row[p] = c * vp - s * vq;
                row[q] = s * vp + c * vq;
            }
        }
    }
    let lambda = [d[0][0].max(0.0), d[1][1].max(0.0), d[2][2].max(0.0)];
    std::array::from_fn(|i| {
        std::array::from_fn(|j| (0..3).map(|k| v[i][k] * lambda[k] * v[j][k]).sum())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_psd_part_keeps_a_covariance_and_drops_a_negative_direction() {
        // A covariance comes back as it is.
        let c = [[4.0, 2.0, 0.6], [2.0, 5.0, 1.0], [0.6, 1.0, 3.0]];
        let got = psd_part3(c);
        for i in 0..3 {
            for j in 0..3 {
                assert!((got[i][j] - c[i][j]).abs() < 1e-12, "{got:?}");
            }
        }
        // diag(2, −1, 0.5) rotated: the −1 direction goes, the others stay.
        let (cs, sn) = (0.6f64, 0.8f64);
        let r = [[cs, -sn, 0.0], [sn, cs, 0.0], [0.0, 0.0, 1.0]];
        let rot = |l: [f64; 3]| -> [[f64; 3]; 3] {
            std::array::from_fn(|i| {
                std::array::from_fn(|j| (0..3).map(|k| r[i][k] * l[k] * r[j][k]).sum())
            })
        };
        let got = psd_part3(rot([2.0, -1.0, 0.5]));
        let want = rot([2.0, 0.0, 0.5]);
        for i in 0..3 {
            for j in 0..3 {
                assert!(
                    (got[i][j] - want[i][j]).abs() < 1e-12,
                    "{got:?} against {want:?}"
                );
            }
        }
    }

    #[test]
    fn cholesky_solves_and_inverts_a_known_system() {
        let mut a = SquareMatrix::zeros(3);
        for (i, row) in [[4.0, 2.0, 0.6], [2.0, 5.0, 1.0], [0.6, 1.0, 3.0]]
            .iter()
            .enumerate()
        {
            for (j, v) in row.iter().enumerate() {
                *a.at(i, j) = *v;
            }
        }
        let l = a.cholesky().unwrap();
        let x = l.cholesky_solve(&[1.0, 2.0, 3.0]);
        for i in 0..3 {
            let ax: f64 = (0..3).map(|j| a.get(i, j) * x[j]).sum();
            assert!((ax - [1.0, 2.0, 3.0][i]).abs() < 1e-12);
        }
        let inv = l.cholesky_inverse();
        for i in 0..3 {
            for j in 0..3 {
                let p: f64 = (0..3).map(|k| a.get(i, k) * inv.get(k, j)).sum();
                assert!((p - f64::from(u8::from(i == j))).abs() < 1e-12);
            }
        }
        *a.at(2, 2) = -1.0;
        assert!(a.cholesky().is_none());
    }
}
