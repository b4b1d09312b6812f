//! `pqp`: the paper's parallel QP method (Brand and Chen's multiplicative update on the dual).
//!
//! **The dual and its signs.** The Lagrangian of `min 1/2 dq^T G dq  s.t.  J dq >= d` is
//! `L = 1/2 dq^T G dq - y^T (J dq - d)`, `y >= 0`. Stationarity gives `dq = G^{-1} J^T y`;
//! substituting, the dual function is `d^T y - 1/2 y^T Q y` with `Q = J G^{-1} J^T`, so the
//! dual problem is
//!
//! ```text
//! min F(y) = 1/2 y^T Q y - y^T d   s.t.  y >= 0,
//! ```
//!
//! whose KKT conditions are `y >= 0`, `Q y - d >= 0` (this is `J dq - d`, the primal
//! slack) and `y_k (Q y - d)_k = 0`. The update is Brand–Chen's for `min 1/2 y^T Q y + h^T y`
//! with `h = -d`: `y_k <- y_k (h^-_k + (Q^- y)_k) / (h^+_k + (Q^+ y)_k)`, where `h^+ = max(h, 0)
//! = max(-d, 0) = d^-` and `h^- = d^+`, i.e.
//!
//! ```text
//! y_k <- y_k (d^+_k + (Q^- y)_k) / (d^-_k + (Q^+ y)_k),   d^+ = max(d, 0), d^- = max(-d, 0),
//! Q^+ = max(Q, 0) + diag(r),  Q^- = max(-Q, 0) + diag(r),  r_k = max(Q_kk, sum_j max(-Q_kj, 0)).
//! ```
//!
//! Since `Q^+ - Q^- = Q` and `d^+ - d^- = d`, a fixed point with `y_k > 0` has
//! `(Q y)_k = d_k` (an active constraint), and a row whose ratio stays below 1 is driven to
//! `y_k -> 0` (an inactive one, `(Q y)_k > d_k`): the fixed points satisfy the dual KKT
//! conditions. Iterates stay positive, so the method cannot set a multiplier to exactly zero
//! and converges linearly at best.
//!
//! **Stopping.** The paper stops when the decrease `F(y_{k}) - F(y_{k+1})` falls below 0.01
//! (absolute, in the objective's units) from `y_0 = 0.001`: [`PqpParams::paper`]. That rule
//! does not bound the constraint violation: an answer whose [`crate::Kkt`] certificate shows a
//! violation above [`PqpParams::violation_tol`] is reported [`Status::Inexact`], not
//! [`Status::Solved`]. [`PqpParams::tight`] stops instead on a relative KKT test (violation and duality gap). Each iteration is O(N^2) (`Q` is dense, formed once
//! per solve in O(6 N^2)); the workspace holds `Q`, `N^2` numbers.

use crate::basis::{scaled, DIM};
use crate::dual::inv_sqrt;
use crate::problem::{dot6, Problem};
use crate::solution::{Solution, Status};

/// Tuning of the PQP solver. Presets: [`PqpParams::paper`] (the default) and
/// [`PqpParams::tight`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PqpParams {
    /// Initial multiplier of every row (the paper: 0.001).
    pub y0: f64,
    /// Stop when the dual objective decreases by less than this in one iteration (the paper:
    /// 0.01, in the units of the objective, N·mm in the haptic step). `0` disables the rule.
    pub min_decrease: f64,
    /// If set, stop when the relative KKT test holds instead: every violation
    /// `(d_k - J_k dq) / |n_k| <= kkt_tol |z|` and `|y^T (J dq - d)| <= kkt_tol |z|^2`, with
    /// `z = G^{1/2} dq`, `n_k = G^{-1/2} J_k^T` (both dimensionless tolerances).
    pub kkt_tol: Option<f64>,
    /// Feasibility tolerance of the answer, in the units of `d` (mm for the distance rows of
    /// the haptic step, mm or rad for its trust-region rows): when the stopping rule holds
    /// but the certificate's [`crate::Kkt::max_violation`] exceeds it, the solve reports
    /// [`Status::Inexact`] instead of [`Status::Solved`]. Both presets: `1e-3`.
    pub violation_tol: f64,
    /// Cap on the number of multiplicative updates.
    pub max_iterations: u32,
    /// Start from the last solve's multipliers (floored at `warm_floor`) when `N` is
    /// unchanged (the rows are assumed to be in the same order).
    pub warm_start: bool,
    /// Smallest warm-start multiplier: the update is multiplicative, so a zero could never
    /// grow again.
    pub warm_floor: f64,
}

impl PqpParams {
    /// The paper: `y0 = 0.001`, stop on a decrease below 0.01, at most 1000 iterations, cold.
    pub fn paper() -> Self {
        Self {
            y0: 1e-3,
            min_decrease: 0.01,
            kkt_tol: None,
            violation_tol: 1e-3,
            max_iterations: 1000,
            warm_start: false,
            warm_floor: 1e-9,
        }
    }

    /// A KKT-based stop at relative tolerance `1e-6`, at most 5000 iterations, warm-started.
    pub fn tight() -> Self {
        Self {
            y0: 1e-3,
            min_decrease: 0.0,
            kkt_tol: Some(1e-6),
            violation_tol: 1e-3,
            max_iterations: 5000,
            warm_start: true,
            warm_floor: 1e-9,
        }
    }
}

impl Default for PqpParams {
    fn default() -> Self {
        Self::paper()
    }
}

/// Caller-owned scratch memory of the PQP solver: the dense `Q` (N² numbers) and a few
/// N-vectors. Grows to the largest `N` solved and never shrinks; once warmed up to a given `N`
/// a solve allocates nothing.
#[derive(Debug, Clone, Default)]
pub struct PqpWorkspace {
    /// Parameters used by [`PqpWorkspace::solve`].
    pub params: PqpParams,
    q: Vec<f64>,
    rows: Vec<[f64; DIM]>,
    norms: Vec<f64>,
    r: Vec<f64>,
    y: Vec<f64>,
    qp: Vec<f64>,
    qm: Vec<f64>,
}

impl PqpWorkspace {
    /// A workspace with the paper's parameters; allocates nothing until the first solve.
    pub fn new() -> Self {
        Self::default()
    }

    /// A workspace with the given parameters.
    pub fn with_params(params: PqpParams) -> Self {
        Self {
            params,
            ..Self::default()
        }
    }

    /// Reserves room for problems of up to `n` rows (`n²` numbers for `Q`).
    pub fn reserve(&mut self, n: usize) {
        fn grow<T>(v: &mut Vec<T>, n: usize) {
            v.reserve(n.saturating_sub(v.len()));
        }
        grow(&mut self.q, n * n);
        grow(&mut self.rows, n);
        grow(&mut self.norms, n);
        grow(&mut self.r, n);
        grow(&mut self.y, n);
        grow(&mut self.qp, n);
        grow(&mut self.qm, n);
    }

    /// The multipliers `y` (one per row, all `> 0`) of the last solve.
    pub fn multipliers(&self) -> &[f64] {
        &self.y
    }

    /// Solves `p` by the multiplicative update, stopping by `params` (see the module docs).
    ///
    /// Returns [`Status::Solved`] when the stopping rule held and the answer violates no
    /// constraint by more than `params.violation_tol` ([`crate::Kkt::max_violation`]),
    /// [`Status::Inexact`] when the rule held but the violation is larger (the paper's rule
    /// bounds the objective decrease, not the violation), [`Status::Infeasible`] when the multipliers
    /// prove that no feasible point lies within `1e4` times the problem's own length scale
    /// (`max_k |d_k| / |n_k|`, in the `G` norm) or a zero row has `d_k > 0`,
    /// [`Status::MaxIterations`] otherwise (an infeasible problem often ends so: the
    /// multipliers grow only slowly).
    ///
    /// # Real-time
    /// Allocates only if `p.len()` exceeds every earlier `N`; never panics; O(6N²) to form
    /// `Q`, then at most `params.max_iterations` iterations of O(N²).
    pub fn solve(&mut self, p: &Problem<'_>) -> Solution {
        let n = p.len();
        let prm = self.params;
        let warm = prm.warm_start && self.y.len() == n;
        if !warm {
            self.y.clear();
            self.y.resize(n, prm.y0);
        } else {
            for v in &mut self.y {
                *v = if v.is_finite() {
                    v.max(prm.warm_floor)
                } else {
                    prm.y0
                };
            }
        }
        if n == 0 {
            return Solution::zero(Status::Solved);
        }
        let (j, d) = (p.j(), p.d());
        let isg = inv_sqrt(p.g());

        // Scaled rows, their norms, Q = N N^T (symmetric), r.
        self.rows.clear();
        self.rows.extend(j.iter().map(|row| scaled(row, &isg)));
        self.norms.clear();
        self.norms
            .extend(self.rows.iter().map(|v| dot6(v, v).sqrt()));
        self.q.clear();
        self.q.resize(n * n, 0.0);
        // Row by row (sequential writes; the symmetric half is recomputed rather than
        // written with a stride of N).
        for (a, qrow) in self.q.chunks_exact_mut(n).enumerate() {
            let ra = self.rows[a];
            for (qv, rb) in qrow.iter_mut().zip(&self.rows) {
                *qv = dot6(&ra, rb);
            }
        }
        self.r.clear();
        for a in 0..n {
            let row = &self.q[a * n..(a + 1) * n];
            let neg: f64 = row.iter().map(|&v| (-v).max(0.0)).sum();
            self.r.push(row[a].max(neg));
        }
        self.qp.clear();
        self.qp.resize(n, 0.0);
        self.qm.clear();
        self.qm.resize(n, 0.0);
        let length_scale = d
            .iter()
            .zip(&self.norms)
            .map(|(&dk, &nk)| if nk > 0.0 { dk.abs() / nk } else { 0.0 })
            .fold(0.0f64, f64::max);

        let mut iterations = 0u32;
        let mut f_prev = f64::INFINITY;
        let status = loop {
            // Q+ y and Q- y in one pass over Q; then F(y) and the stopping tests.
            let (mut yqy, mut dy) = (0.0f64, 0.0f64);
            // max(q, 0) = (|q| + q) / 2 and max(-q, 0) = (|q| - q) / 2: two branch-free
            // products per row, (Q y)_a and (|Q| y)_a.
            for a in 0..n {
                let (qy, absy) = row_products(&self.q[a * n..(a + 1) * n], &self.y);
                let ry = self.r[a] * self.y[a];
                self.qp[a] = 0.5 * (absy + qy) + ry;
                self.qm[a] = 0.5 * (absy - qy) + ry;
                yqy += self.y[a] * qy;
                dy += d[a] * self.y[a];
            }
            let f = 0.5 * yqy - dy;
            if !f.is_finite() {
                break Status::NumericalError;
            }
            let zn = yqy.max(0.0).sqrt();
            if dy > 0.0 && dy > zn * 1e4 * length_scale {
                // For any feasible x: d^T y <= y^T J x <= |z_y| |x|_G, so no feasible point
                // lies within 1e4 length scales.
                break Status::Infeasible;
            }
            if let Some(tol) = prm.kkt_tol {
                // slack_k = (Q y)_k - d_k = J_k dq - d_k.
                let mut ok = (yqy - dy).abs() <= tol * yqy.max(0.0);
                if ok {
                    for a in 0..n {
                        let s = self.qp[a] - self.qm[a] - d[a];
                        if -s > tol * zn * self.norms[a] {
                            ok = false;
                            break;
                        }
                    }
                }
                if ok {
                    break Status::Solved;
                }
            } else if f_prev - f < prm.min_decrease {
                break Status::Solved;
            }
            if iterations >= prm.max_iterations {
                break Status::MaxIterations;
            }
            iterations += 1;
            f_prev = f;
            let mut zero_row_violated = false;
            for a in 0..n {
                let num = d[a].max(0.0) + self.qm[a];
                let den = (-d[a]).max(0.0) + self.qp[a];
                if den > 0.0 {
                    self.y[a] *= num / den;
                } else {
                    // den = 0 only for a zero row with d_k >= 0: 0 >= d_k > 0 is impossible.
                    zero_row_violated |= num > 0.0;
                }
            }
            if zero_row_violated {
                break Status::Infeasible;
            }
        };
        let mut zsum = [0.0f64; DIM];
        for (v, &yv) in self.rows.iter().zip(&self.y) {
            for i in 0..DIM {
                zsum[i] += yv * v[i];
            }
        }
        let dq: [f64; 6] = std::array::from_fn(|i| zsum[i] * isg[i]);
        let mut sol = Solution::finish(p, dq, &self.y, status, iterations);
        // The stopping rule is not a feasibility test (the paper's is a decrease test): the
        // certificate decides whether the answer is exact.
        // (A NaN tolerance certifies nothing.)
        let within = matches!(
            sol.kkt.max_violation.partial_cmp(&prm.violation_tol),
            Some(std::cmp::Ordering::Less | std::cmp::Ordering::Equal)
        );
        if sol.status == Status::Solved && !within {
            sol.status = Status::Inexact;
        }
        sol
    }
}

/// `(sum_j q_j y_j, sum_j |q_j| y_j)` with four independent accumulators each.
#[inline]
fn row_products(q: &[f64], y: &[f64]) -> (f64, f64) {
    let mut s = [0.0f64; 4];
    let mut a = [0.0f64; 4];
    let (qc, yc) = (q.chunks_exact(4), y.chunks_exact(4));
    let (qr, yr) = (qc.remainder(), yc.remainder());
    for (qq, yy) in qc.zip(yc) {
        for i in 0..4 {
            s[i] += qq[i] * yy[i];
            a[i] += qq[i].abs() * yy[i];
        }
    }
    let mut st = (s[0] + s[1]) + (s[2] + s[3]);
    let mut at = (a[0] + a[1]) + (a[2] + a[3]);
    for (&qq, &yy) in qr.iter().zip(yr) {
        st += qq * yy;
        at += qq.abs() * yy;
    }
    (st, at)
}
