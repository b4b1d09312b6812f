//! The active set of at most 6 independent constraint normals, with a thin QR factorisation
//! `N_A = Q R` kept by Gram–Schmidt with re-orthogonalisation (k ≤ 6, so a rebuild costs a few
//! hundred flops).
//!
//! All vectors here live in the scaled space `z = G^{1/2} dq`, where the objective is
//! `1/2 |z|^2` and row `k` becomes `n_k = G^{-1/2} J_k^T`.

use crate::problem::dot6;

/// Dimension of the primal space.
pub(crate) const DIM: usize = 6;

/// Active constraints (row indices, scaled normals, multipliers) and the QR of their normals.
#[derive(Debug, Clone, Default)]
pub(crate) struct Basis {
    /// Number of active constraints (≤ 6).
    pub k: usize,
    /// Row indices of the active constraints.
    pub idx: [usize; DIM],
    /// Scaled normals of the active constraints.
    pub n: [[f64; DIM]; DIM],
    /// Multipliers of the active constraints.
    pub u: [f64; DIM],
    /// Orthonormal columns `q_0 .. q_{k-1}`.
    q: [[f64; DIM]; DIM],
    /// Upper triangular `R`, `r[i][j]` for `i <= j`: `n_j = sum_i q_i r[i][j]`.
    r: [[f64; DIM]; DIM],
}

impl Basis {
    pub fn clear(&mut self) {
        self.k = 0;
    }

    pub fn contains(&self, i: usize) -> bool {
        self.idx[..self.k].contains(&i)
    }

    pub fn indices(&self) -> &[usize] {
        &self.idx[..self.k]
    }

    /// Splits `v` into its component in span(Q) (coefficients `h = Q^T v`) and the orthogonal
    /// remainder `w = v - Q h` (classical Gram–Schmidt applied twice).
    pub fn split(&self, v: &[f64; DIM]) -> ([f64; DIM], [f64; DIM]) {
        let mut h = [0.0; DIM];
        let mut w = *v;
        for _pass in 0..2 {
            for c in 0..self.k {
                let a = dot6(&self.q[c], &w);
                h[c] += a;
                for i in 0..DIM {
                    w[i] -= a * self.q[c][i];
                }
            }
        }
        (h, w)
    }

    /// Appends constraint `i` with scaled normal `v` and multiplier `u` if `v` is independent
    /// of the active normals: `|w| > dep_tol |v|`. Returns `false` (and changes nothing) if it
    /// is dependent or the set is full.
    pub fn push(&mut self, i: usize, v: &[f64; DIM], u: f64, dep_tol: f64) -> bool {
        if self.k >= DIM {
            return false;
        }
        let (h, w) = self.split(v);
        let rho = dot6(&w, &w).sqrt();
        let vn = dot6(v, v).sqrt();
        if !(rho > dep_tol * vn && rho > 0.0) {
            return false;
        }
        let k = self.k;
        for c in 0..k {
            self.r[c][k] = h[c];
        }
        self.r[k][k] = rho;
        for c in k + 1..DIM {
            self.r[c][k] = 0.0;
        }
        for e in 0..DIM {
            self.q[k][e] = w[e] / rho;
        }
        self.idx[k] = i;
        self.n[k] = *v;
        self.u[k] = u;
        self.k = k + 1;
        true
    }

    /// Removes the active constraint at position `pos` and refactorises. A column that became
    /// numerically dependent during the rebuild (it cannot in exact arithmetic) is dropped too.
    pub fn remove(&mut self, pos: usize) {
        if pos >= self.k {
            return;
        }
        let old_k = self.k;
        let idx = self.idx;
        let n = self.n;
        let u = self.u;
        self.k = 0;
        for c in 0..old_k {
            if c != pos {
                self.push(idx[c], &n[c], u[c], 0.0);
            }
        }
    }

    /// Solves `R x = h` for the first `k` entries (back substitution).
    pub fn r_solve(&self, h: &[f64; DIM]) -> [f64; DIM] {
        let mut x = [0.0; DIM];
        for i in (0..self.k).rev() {
            let mut s = h[i];
            for j in i + 1..self.k {
                s -= self.r[i][j] * x[j];
            }
            x[i] = s / self.r[i][i];
        }
        x
    }

    /// Solves `R^T x = b` for the first `k` entries (forward substitution).
    pub fn rt_solve(&self, b: &[f64; DIM]) -> [f64; DIM] {
        let mut x = [0.0; DIM];
        for i in 0..self.k {
            let mut s = b[i];
            for j in 0..i {
                s -= self.r[j][i] * x[j];
            }
            x[i] = s / self.r[i][i];
        }
        x
    }

    /// `Q c` for the first `k` coefficients.
    pub fn q_mul(&self, c: &[f64; DIM]) -> [f64; DIM] {
        let mut z = [0.0; DIM];
        for col in 0..self.k {
            for e in 0..DIM {
                z[e] += c[col] * self.q[col][e];
            }
        }
        z
    }
}

/// Row `row` of `J` in the scaled space: `G^{-1/2} J_k^T`.
#[inline(always)]
pub(crate) fn scaled(row: &[f64; DIM], isg: &[f64; DIM]) -> [f64; DIM] {
    [
        row[0] * isg[0],
        row[1] * isg[1],
        row[2] * isg[2],
        row[3] * isg[3],
        row[4] * isg[4],
        row[5] * isg[5],
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn qr_reproduces_columns_and_rejects_dependent() {
        let mut b = Basis::default();
        let v0 = [1.0, 2.0, 0.0, 0.0, 1.0, 0.0];
        let v1 = [0.0, 1.0, 3.0, 0.0, 0.0, -1.0];
        assert!(b.push(7, &v0, 0.5, 1e-12));
        assert!(b.push(9, &v1, 0.25, 1e-12));
        let dep = [2.0, 5.0, 3.0, 0.0, 2.0, -1.0]; // 2 v0 + v1
        assert!(!b.push(3, &dep, 0.0, 1e-12));
        assert_eq!(b.indices(), &[7, 9]);
        // Q R = N column by column.
        for j in 0..2 {
            let mut c = [0.0; DIM];
            for i in 0..=j {
                c[i] = b.r[i][j];
            }
            let col = b.q_mul(&c);
            for e in 0..DIM {
                assert!((col[e] - b.n[j][e]).abs() < 1e-14);
            }
        }
        // R x = h round trip.
        let (h, w) = b.split(&dep);
        assert!(dot6(&w, &w) < 1e-24);
        let x = b.r_solve(&h);
        assert!((x[0] - 2.0).abs() < 1e-12 && (x[1] - 1.0).abs() < 1e-12);
        b.remove(0);
        assert_eq!(b.indices(), &[9]);
        assert_eq!(b.u[0], 0.25);
    }
}
