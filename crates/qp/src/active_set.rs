//! `active-set`: the primal active-set method, warm-started from a feasible point (the
//! paper's baseline, after Wang et al. 2013, which starts from the last graphic
//! configuration).
//!
//! In the scaled space `z = G^{1/2} dq` (objective `1/2 |z|^2`, rows `n_k = G^{-1/2} J_k^T`),
//! from a feasible `z` with a working set `W` of independent active rows (initially empty):
//!
//! 1. Equality-constrained step: `p = -(I - Q Q^T) z`, the move to the minimum on the
//!    affine set `{n_k · z = d_k, k in W}`.
//! 2. If `p = 0`: multipliers `lambda = R^{-1} Q^T z`. All `>= 0`: optimal. Otherwise drop the
//!    most negative one.
//! 3. Else the ratio test over rows not in `W` with `n_k · p < 0` gives the longest feasible
//!    step `alpha <= 1`; move, and add the blocking row to `W`.
//!
//! Each iteration is O(12N). If the given start violates the constraints (the linearization
//! at the last graphic pose is not exactly satisfied there when that pose penetrates a
//! little), phase 1 replaces it by the nearest feasible point in the `G` norm, found by the
//! dual solver on the shifted problem; its iterations are counted.

use crate::basis::{scaled, Basis, DIM};
use crate::dual::{inv_sqrt, DualParams, DualWorkspace};
use crate::problem::{dot6, Problem};
use crate::solution::{Solution, Status};

/// Tuning of the primal active-set solver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ActiveSetParams {
    /// Relative tolerance for feasibility of the start, for "the step is zero" (`|p| <= tol
    /// |z|`) and for "a multiplier is negative" (`lambda_k |n_k| < -tol |z|`).
    pub tol: f64,
    /// Relative dependence tolerance: rows whose scaled normal is within `dep_tol` (relative)
    /// of the span of the working set do not block a step.
    pub dep_tol: f64,
    /// Cap on the number of iterations (phase 1 included).
    pub max_iterations: u32,
}

impl Default for ActiveSetParams {
    fn default() -> Self {
        Self {
            tol: 1e-11,
            dep_tol: 1e-11,
            max_iterations: 500,
        }
    }
}

/// Caller-owned scratch memory of the primal active-set solver. Grows to the largest `N`
/// solved and never shrinks; once warmed up to a given `N`, a solve allocates nothing.
#[derive(Debug, Clone, Default)]
pub struct ActiveSetWorkspace {
    /// Parameters used by [`ActiveSetWorkspace::solve`].
    pub params: ActiveSetParams,
    basis: Basis,
    y: Vec<f64>,
    shifted: Vec<f64>,
    phase1: DualWorkspace,
    phase1_used: bool,
}

impl ActiveSetWorkspace {
    /// A workspace with default parameters; allocates nothing until the first solve.
    pub fn new() -> Self {
        Self::default()
    }

    /// A workspace with the given parameters.
    pub fn with_params(params: ActiveSetParams) -> Self {
        Self {
            params,
            ..Self::default()
        }
    }

    /// Reserves room for problems of up to `n` rows, so that later solves do not allocate.
    pub fn reserve(&mut self, n: usize) {
        self.y.reserve(n.saturating_sub(self.y.len()));
        self.shifted.reserve(n.saturating_sub(self.shifted.len()));
        self.phase1.reserve(n);
    }

    /// The multipliers `y` (one per row) of the last solve.
    pub fn multipliers(&self) -> &[f64] {
        &self.y
    }

    /// Row indices of the final working set of the last solve (at most 6).
    pub fn active_set(&self) -> &[usize] {
        self.basis.indices()
    }

    /// Whether the last solve needed phase 1 (its start was infeasible).
    pub fn used_phase1(&self) -> bool {
        self.phase1_used
    }

    /// Solves `p` starting from `dq0` (mm, rad), which should satisfy `J dq0 >= d`, e.g.
    /// `q_g_prev - q_h`. An infeasible `dq0` is first projected onto the feasible set
    /// (phase 1); if that fails the status says why ([`Status::Infeasible`] included).
    ///
    /// # Real-time
    /// Allocates only if `p.len()` exceeds every earlier `N`; never panics; at most
    /// `params.max_iterations` iterations of O(12N) each.
    pub fn solve(&mut self, p: &Problem<'_>, dq0: &[f64; 6]) -> Solution {
        let n = p.len();
        self.basis.clear();
        self.y.clear();
        self.y.resize(n, 0.0);
        self.phase1_used = false;
        if n == 0 {
            return Solution::zero(Status::Solved);
        }
        if dq0.iter().any(|v| !v.is_finite()) {
            return Solution::zero(Status::NumericalError);
        }
        let prm = self.params;
        let (j, d, g) = (p.j(), p.d(), p.g());
        let isg = inv_sqrt(g);
        let sg: [f64; DIM] = std::array::from_fn(|i| g[i].sqrt());
        let mut iterations = 0u32;

        // Phase 1 if the start is infeasible: nearest feasible point in the G norm.
        let mut x = *dq0;
        let z0: [f64; DIM] = std::array::from_fn(|i| x[i] * sg[i]);
        let z0n = dot6(&z0, &z0).sqrt();
        let mut infeasible_start = false;
        for (row, &dk) in j.iter().zip(d) {
            let s = dot6(row, &x) - dk;
            if s < 0.0 {
                let nk = scaled(row, &isg);
                if -s > prm.tol * (dk.abs() + dot6(&nk, &nk).sqrt() * z0n) {
                    infeasible_start = true;
                    break;
                }
            }
        }
        if infeasible_start {
            self.phase1_used = true;
            self.shifted.clear();
            self.shifted
                .extend(j.iter().zip(d).map(|(row, &dk)| dk - dot6(row, dq0)));
            let shifted = match Problem::new(*g, j, &self.shifted) {
                Ok(q) => q,
                Err(_) => return Solution::zero(Status::NumericalError),
            };
            self.phase1.params = DualParams {
                tol: prm.tol,
                dep_tol: prm.dep_tol,
                max_iterations: prm.max_iterations,
            };
            let e = self.phase1.solve(&shifted, false);
            iterations += e.iterations;
            if e.status != Status::Solved {
                return Solution::finish(p, x, &self.y, e.status, iterations);
            }
            for i in 0..DIM {
                x[i] += e.dq[i];
            }
        }

        let (status, z) = self.run(p, x, &mut iterations);
        for c in 0..self.basis.k {
            self.y[self.basis.idx[c]] = self.basis.u[c];
        }
        let dq: [f64; 6] = std::array::from_fn(|i| z[i] * isg[i]);
        Solution::finish(p, dq, &self.y, status, iterations)
    }

    fn run(&mut self, p: &Problem<'_>, x0: [f64; DIM], iterations: &mut u32) -> (Status, [f64; 6]) {
        let prm = self.params;
        let (j, d, g) = (p.j(), p.d(), p.g());
        let isg = inv_sqrt(g);
        let b = &mut self.basis;
        let mut z: [f64; DIM] = std::array::from_fn(|i| x0[i] * g[i].sqrt());
        loop {
            if *iterations >= prm.max_iterations {
                return (Status::MaxIterations, z);
            }
            *iterations += 1;
            let zn = dot6(&z, &z).sqrt();
            if !zn.is_finite() {
                return (Status::NumericalError, z);
            }
            let (h, w) = b.split(&z);
            let wn = dot6(&w, &w).sqrt();
            if wn <= prm.tol * zn {
                // Stationary on the working set: check the multipliers.
                let lam = b.r_solve(&h);
                let mut worst = usize::MAX;
                let mut worst_v = -prm.tol * zn;
                for c in 0..b.k {
                    b.u[c] = lam[c];
                    let v = lam[c] * dot6(&b.n[c], &b.n[c]).sqrt();
                    if v < worst_v {
                        worst_v = v;
                        worst = c;
                    }
                }
                if worst == usize::MAX {
                    for c in 0..b.k {
                        b.u[c] = b.u[c].max(0.0);
                    }
                    return (Status::Solved, z);
                }
                b.remove(worst);
                continue;
            }
            // Ratio test along p = -w.
            let px: [f64; DIM] = std::array::from_fn(|i| -w[i] * isg[i]);
            let x: [f64; DIM] = std::array::from_fn(|i| z[i] * isg[i]);
            let mut alpha = 1.0f64;
            let mut block = usize::MAX;
            for (k, (row, &dk)) in j.iter().zip(d).enumerate() {
                let ap = dot6(row, &px);
                if ap < 0.0 {
                    let s = (dot6(row, &x) - dk).max(0.0);
                    if s < -alpha * ap {
                        // Candidate blocker: skip rows (numerically) parallel to W's span.
                        let nk = scaled(row, &isg);
                        if -ap > prm.dep_tol * dot6(&nk, &nk).sqrt() * wn && !b.contains(k) {
                            alpha = s / -ap;
                            block = k;
                        }
                    }
                }
            }
            for i in 0..DIM {
                z[i] -= alpha * w[i];
            }
            if block != usize::MAX && !b.push(block, &scaled(&j[block], &isg), 0.0, 0.0) {
                return (Status::NumericalError, z);
            }
        }
    }
}
