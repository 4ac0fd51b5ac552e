//! Small dense linear algebra for the fit: symmetric positive-definite solves and inverses.
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

#[cfg(test)]
mod tests {
    use super::*;

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
