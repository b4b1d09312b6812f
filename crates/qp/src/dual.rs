//! `dual`: the Goldfarb–Idnani dual active-set method on the 6-D primal (the default solver).
//!
//! In the scaled space `z = G^{1/2} dq` the objective is `1/2 |z|^2` and row `k` is
//! `n_k = G^{-1/2} J_k^T`. The method starts from the unconstrained minimum `z = 0` (or from
//! the last frame's active set, see [`DualWorkspace::solve`]) and keeps `z` optimal for the
//! constraints in its active set `A` (at most 6 independent normals) with multipliers `u >= 0`:
//!
//! 1. Scan all rows (O(6N)); pick the most violated one, by distance in the scaled space,
//!    `p = argmax (d_k - n_k·z) / |n_k|`. None violated beyond the tolerance: optimal.
//! 2. Step direction: `w = (I - Q Q^T) n_p` (the part of `n_p` not spanned by `A`) moves `z`;
//!    `r = R^{-1} Q^T n_p` is how the active multipliers change. Full step
//!    `t2 = (d_p - n_p·z) / |w|^2`, partial step `t1 = min_{r_j > 0} u_j / r_j`.
//!    If `t2 <= t1`: take it and add `p` to `A`. Otherwise take `t1` and drop the blocking
//!    constraint, then repeat step 2. If `n_p` is (numerically) in the span of `A` and no
//!    `r_j > 0`, the constraints are infeasible.
//!
//! Degenerate rows (many nearly identical constraints) are handled by treating `n_p` as
//! dependent when `|w| <= dep_tol |n_p|`: then only multipliers move (a pure dual step) and the
//! dependent constraint replaces one of the active ones. The active set never holds two
//! constraints whose normals are that close to parallel.

use crate::basis::{scaled, Basis, DIM};
use crate::problem::{dot6, Problem};
use crate::solution::{Solution, Status};

/// Tuning of the dual active-set solver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DualParams {
    /// Relative feasibility tolerance: row `k` counts as violated when
    /// `d_k - J_k dq > tol (|d_k| + |n_k| |z|)` (dimensionless).
    pub tol: f64,
    /// Relative dependence tolerance: a row whose scaled normal has a part orthogonal to the
    /// active normals smaller than `dep_tol` times its length is treated as dependent.
    pub dep_tol: f64,
    /// Cap on the number of active-set changes.
    pub max_iterations: u32,
}

impl Default for DualParams {
    fn default() -> Self {
        Self {
            tol: 1e-11,
            dep_tol: 1e-11,
            max_iterations: 500,
        }
    }
}

/// Caller-owned scratch memory and warm-start state of the dual active-set solver.
///
/// Grows to the largest `N` solved and never shrinks; once warmed up to a given `N`, a solve
/// allocates nothing.
#[derive(Debug, Clone, Default)]
pub struct DualWorkspace {
    /// Parameters used by [`DualWorkspace::solve`].
    pub params: DualParams,
    basis: Basis,
    y: Vec<f64>,
    hint: [usize; DIM],
    hint_len: usize,
}

impl DualWorkspace {
    /// A workspace with default parameters; allocates nothing until the first solve.
    pub fn new() -> Self {
        Self::default()
    }

    /// A workspace with the given parameters.
    pub fn with_params(params: DualParams) -> Self {
        Self {
            params,
            ..Self::default()
        }
    }

    /// Reserves room for problems of up to `n` rows, so that later solves do not allocate.
    pub fn reserve(&mut self, n: usize) {
        self.y.reserve(n.saturating_sub(self.y.len()));
    }

    /// The multipliers `y` (one per row, `>= 0`) of the last solve.
    pub fn multipliers(&self) -> &[f64] {
        &self.y
    }

    /// Row indices of the active set at the end of the last solve (at most 6).
    pub fn active_set(&self) -> &[usize] {
        self.basis.indices()
    }

    /// Sets the rows to try as the initial active set of the next warm solve (at most 6 are
    /// kept; indices out of range are ignored at solve time). Use it when the rows of the new
    /// problem are a permutation of the last ones (e.g. pairs matched by id).
    pub fn set_warm_start(&mut self, rows: &[usize]) {
        self.hint_len = rows.len().min(DIM);
        self.hint[..self.hint_len].copy_from_slice(&rows[..self.hint_len]);
    }

    /// Forgets the warm-start hint (the next warm solve starts cold).
    pub fn clear_warm_start(&mut self) {
        self.hint_len = 0;
    }

    /// Solves `p`. With `warm`, the active set of the previous solve (or the rows given to
    /// [`DualWorkspace::set_warm_start`]) is tried first: it is reduced to a dual-feasible set
    /// (independent rows, multipliers `>= 0`) and the method continues from there, so a warm
    /// start never changes the answer, only the work.
    ///
    /// # Real-time
    /// Allocates only if `p.len()` exceeds every earlier `N` (or [`DualWorkspace::reserve`]);
    /// never panics; at most `params.max_iterations` iterations of O(6N) each.
    pub fn solve(&mut self, p: &Problem<'_>, warm: bool) -> Solution {
        let n = p.len();
        let hint = self.hint;
        let hint_len = if warm { self.hint_len } else { 0 };
        self.basis.clear();
        self.y.clear();
        self.y.resize(n, 0.0);
        if n == 0 {
            self.hint_len = 0;
            return Solution::zero(Status::Solved);
        }
        let (status, z, iterations) = self.run(p, &hint[..hint_len]);
        for c in 0..self.basis.k {
            self.y[self.basis.idx[c]] = self.basis.u[c];
        }
        self.hint_len = self.basis.k;
        self.hint[..self.basis.k].copy_from_slice(self.basis.indices());
        let isg = inv_sqrt(p.g());
        let dq: [f64; 6] = std::array::from_fn(|i| z[i] * isg[i]);
        Solution::finish(p, dq, &self.y, status, iterations)
    }

    /// The Goldfarb–Idnani iteration; returns the status, `z` and the iteration count.
    fn run(&mut self, p: &Problem<'_>, hint: &[usize]) -> (Status, [f64; DIM], u32) {
        let prm = self.params;
        let (j, d) = (p.j(), p.d());
        let n = j.len();
        let isg = inv_sqrt(p.g());
        let b = &mut self.basis;
        let mut z = [0.0f64; DIM];

        // Warm start: a dual-feasible active set from the hint.
        for &h in hint {
            if h < n && !b.contains(h) {
                b.push(h, &scaled(&j[h], &isg), 0.0, prm.dep_tol);
            }
        }
        while b.k > 0 {
            let mut da = [0.0; DIM];
            for c in 0..b.k {
                da[c] = d[b.idx[c]];
            }
            let c = b.rt_solve(&da);
            let u = b.r_solve(&c);
            let mut worst = 0;
            for i in 1..b.k {
                if u[i] < u[worst] {
                    worst = i;
                }
            }
            if u[worst] >= 0.0 {
                b.u[..b.k].copy_from_slice(&u[..b.k]);
                z = b.q_mul(&c);
                break;
            }
            if !u[worst].is_finite() {
                b.clear();
                break;
            }
            b.remove(worst);
        }

        let mut iterations = 0u32;
        loop {
            // Step 1: the most violated row.
            let dq: [f64; DIM] = std::array::from_fn(|i| z[i] * isg[i]);
            let zn = dot6(&z, &z).sqrt();
            if !zn.is_finite() {
                return (Status::NumericalError, z, iterations);
            }
            let mut best = usize::MAX;
            let mut best_v = 0.0f64;
            for (k, (row, &dk)) in j.iter().zip(d).enumerate() {
                let s = dot6(row, &dq) - dk;
                if s < 0.0 {
                    let nk = scaled(row, &isg);
                    let nrm = dot6(&nk, &nk).sqrt();
                    if -s > prm.tol * (dk.abs() + nrm * zn) {
                        let v = -s / nrm;
                        // v = inf for a zero row with d_k > 0: picked first, found infeasible.
                        if v > best_v && !b.contains(k) {
                            best = k;
                            best_v = v;
                        }
                    }
                }
            }
            if best == usize::MAX {
                return (Status::Solved, z, iterations);
            }
            let pidx = best;
            let np = scaled(&j[pidx], &isg);
            let np_norm2 = dot6(&np, &np);
            let mut up = 0.0f64;
            // Step 2: move until p is satisfied (then add it) or blocked (then drop).
            loop {
                if iterations >= prm.max_iterations {
                    return (Status::MaxIterations, z, iterations);
                }
                iterations += 1;
                let sp = dot6(&np, &z) - d[pidx];
                let (h, w) = b.split(&np);
                let w2 = dot6(&w, &w);
                let dependent = b.k >= DIM || w2 <= prm.dep_tol * prm.dep_tol * np_norm2;
                let r = b.r_solve(&h);
                let mut t1 = f64::INFINITY;
                let mut block = usize::MAX;
                for c in 0..b.k {
                    if r[c] > 0.0 {
                        let t = b.u[c] / r[c];
                        if t < t1 {
                            t1 = t;
                            block = c;
                        }
                    }
                }
                let t2 = if dependent { f64::INFINITY } else { -sp / w2 };
                if !(t1.is_finite() || t2.is_finite()) {
                    return (
                        if sp.is_finite() {
                            Status::Infeasible
                        } else {
                            Status::NumericalError
                        },
                        z,
                        iterations,
                    );
                }
                let t = t1.min(t2);
                if !dependent {
                    for e in 0..DIM {
                        z[e] += t * w[e];
                    }
                }
                for c in 0..b.k {
                    b.u[c] = (b.u[c] - t * r[c]).max(0.0);
                }
                up += t;
                if t2 <= t1 {
                    if !b.push(pidx, &np, up, 0.0) {
                        return (Status::NumericalError, z, iterations);
                    }
                    break;
                }
                b.u[block] = 0.0;
                b.remove(block);
            }
        }
    }
}

/// `G^{-1/2}` as a 6-vector.
#[inline]
pub(crate) fn inv_sqrt(g: &[f64; DIM]) -> [f64; DIM] {
    std::array::from_fn(|i| 1.0 / g[i].sqrt())
}
