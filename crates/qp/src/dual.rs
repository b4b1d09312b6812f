//! `dual`: the Goldfarb–Idnani dual active-set method on the 6-D primal (the default solver).
//!
//! In the scaled space `z = G^{1/2} dq` the objective is `1/2 |z|^2` and row `k` is
//! `n_k = G^{-1/2} J_k^T`. The method starts from the unconstrained minimum `z = 0` (or from
//! the last frame's active set, see [`DualWorkspace::solve`]) and keeps `z` optimal for the
//! constraints in its active set `A` (at most 6 independent normals) with multipliers `u >= 0`:
//!
//! 1. Scan all rows (O(6N)); pick the most violated one, by distance in the scaled space,
//!    `p = argmax (d_k - n_k·z) / |n_k|`. None violated beyond the tolerance: optimal.
//!    A scan also keeps the 8 most violated rows of distinct directions (cosine < 0.98) as
//!    candidates; the next step 1 re-checks those first (O(48)) and rescans only when none is
//!    still violated, so optimality is always confirmed by a full scan.
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
use crate::solution::{Kkt, Solution, Status};

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
    /// Per row: `1 / |n_k|` (+inf for a zero row, NaN until first needed).
    inv_n: Vec<f64>,
    /// Per row: `d_k - J_k dq` at the last full scan.
    r: Vec<f64>,
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
        self.inv_n.reserve(n.saturating_sub(self.inv_n.len()));
        self.r.reserve(n.saturating_sub(self.r.len()));
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
        let (status, z, iterations, max_violation) = self.run(p, &hint[..hint_len]);
        let b = &self.basis;
        for c in 0..b.k {
            self.y[b.idx[c]] = b.u[c];
        }
        self.hint_len = b.k;
        self.hint[..b.k].copy_from_slice(b.indices());
        let isg = inv_sqrt(p.g());
        let dq: [f64; 6] = std::array::from_fn(|i| z[i] * isg[i]);
        if status != Status::Solved {
            return Solution::finish(p, dq, &self.y, status, iterations);
        }
        // Optimal: the last scan measured the violation at this dq; the other residuals
        // involve only the (at most 6) rows with y_k != 0.
        let (g, j, d) = (p.g(), p.j(), p.d());
        let mut jty = [0.0f64; DIM];
        let (mut dty, mut comp, mut miny) = (0.0f64, 0.0f64, f64::INFINITY);
        for c in 0..b.k {
            let (row, u) = (&j[b.idx[c]], b.u[c]);
            let sk = dot6(row, &dq) - d[b.idx[c]];
            comp = comp.max((u * sk).abs());
            miny = miny.min(u);
            dty += d[b.idx[c]] * u;
            for i in 0..DIM {
                jty[i] += u * row[i];
            }
        }
        let mut stat = 0.0f64;
        let mut dual = dty;
        for i in 0..DIM {
            stat = stat.max((g[i] * dq[i] - jty[i]).abs());
            dual -= 0.5 * jty[i] * jty[i] / g[i];
        }
        let objective = p.objective(&dq);
        let kkt = Kkt {
            max_violation: max_violation.max(0.0),
            min_multiplier: if b.k < n { miny.min(0.0) } else { miny },
            complementarity: comp,
            stationarity: stat,
            duality_gap: objective - dual,
        };
        Solution::with_kkt(dq, status, iterations, objective, kkt)
    }

    /// The Goldfarb–Idnani iteration; returns the status, `z`, the iteration count and the
    /// largest `d_k - J_k dq` found by the last scan.
    fn run(&mut self, p: &Problem<'_>, hint: &[usize]) -> (Status, [f64; DIM], u32, f64) {
        let prm = self.params;
        let (j, d) = (p.j(), p.d());
        let n = j.len();
        let isg = inv_sqrt(p.g());
        let ig: [f64; DIM] = std::array::from_fn(|i| isg[i] * isg[i]);
        self.inv_n.clear();
        self.inv_n.resize(n, f64::NAN);
        self.r.clear();
        self.r.resize(n, 0.0);
        let (inv_n, rbuf) = (&mut self.inv_n[..], &mut self.r[..]);
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
        let mut cand = [0usize; CAND];
        let mut cand_w = [0.0f64; CAND];
        let mut cand_u = [[0.0f64; DIM]; CAND];
        let mut n_cand = 0;
        let mut last_max_r = f64::NAN;
        loop {
            // Step 1: the most violated row. Row k is violated when its distance in the
            // scaled space, v_k = (d_k - J_k dq) / |n_k|, exceeds tol (|d_k| / |n_k| + |z|);
            // pick the largest w_k = v_k - tol |d_k| / |n_k|. A zero row with d_k > 0 has
            // w_k = +inf.
            let dq: [f64; DIM] = std::array::from_fn(|i| z[i] * isg[i]);
            let zn = dot6(&z, &z).sqrt();
            if !zn.is_finite() {
                return (Status::NumericalError, z, iterations, f64::NAN);
            }
            let limit = prm.tol * zn;
            let mut best = usize::MAX;
            let mut best_w = limit;
            // Re-check the candidates of the last full scan first (O(6 CAND)).
            for &k in &cand[..n_cand] {
                let r = d[k] - dot6(&j[k], &dq);
                if r > 0.0 && !b.contains(k) {
                    let w = (r - prm.tol * d[k].abs()) * inv_n[k];
                    if w > best_w {
                        best = k;
                        best_w = w;
                    }
                }
            }
            if best == usize::MAX {
                // Full scan, keeping the CAND most violated rows as the next candidates.
                n_cand = 0;
                let mut min_pos = 0;
                let mut min_w = f64::INFINITY;
                // Pass 1: r_k = d_k - J_k dq for all rows (tight loop; the maximum with four
                // independent accumulators, NaN flagged without an FP dependency chain).
                let mut acc = [f64::NEG_INFINITY; 4];
                let mut nan = false;
                for ((rows4, d4), out4) in j.chunks(4).zip(d.chunks(4)).zip(rbuf.chunks_mut(4)) {
                    for (i, ((row, &dk), out)) in rows4.iter().zip(d4).zip(out4).enumerate() {
                        let r = dk - dot6(row, &dq);
                        nan |= r.is_nan();
                        acc[i] = acc[i].max(r);
                        *out = r;
                    }
                }
                let max_r = acc[0].max(acc[1]).max(acc[2].max(acc[3]));
                if nan || max_r == f64::INFINITY {
                    return (Status::NumericalError, z, iterations, f64::NAN);
                }
                // Pass 2: the rows with r_k > 0.
                for (k, (row, &dk)) in j.iter().zip(d).enumerate() {
                    let r = rbuf[k];
                    // Only a row with r > 0 can have w_k > 0; its scale is computed once per
                    // solve, when first needed (NaN marks "not yet"; a zero row gets +inf).
                    if r > 0.0 {
                        let mut inv = inv_n[k];
                        if inv.is_nan() {
                            let n2 = norm2_scaled(row, &ig);
                            inv = if n2 > 0.0 {
                                1.0 / n2.sqrt()
                            } else {
                                f64::INFINITY
                            };
                            inv_n[k] = inv;
                        }
                        let w = (r - prm.tol * dk.abs()) * inv;
                        if w > limit && (n_cand < CAND || w > min_w) && !b.contains(k) {
                            // Keep the candidates diverse: a row nearly parallel to a kept
                            // one replaces it if more violated (adding one of a patch of
                            // nearly parallel rows satisfies the rest).
                            let u = unit(&scaled(row, &isg), inv);
                            let mut slot = usize::MAX;
                            for c in 0..n_cand {
                                if dot6(&u, &cand_u[c]) > SAME_DIRECTION {
                                    slot = c;
                                    break;
                                }
                            }
                            if slot != usize::MAX {
                                if w > cand_w[slot] {
                                    cand[slot] = k;
                                    cand_w[slot] = w;
                                    cand_u[slot] = u;
                                }
                            } else if n_cand < CAND {
                                cand[n_cand] = k;
                                cand_w[n_cand] = w;
                                cand_u[n_cand] = u;
                                n_cand += 1;
                            } else {
                                cand[min_pos] = k;
                                cand_w[min_pos] = w;
                                cand_u[min_pos] = u;
                            }
                            if n_cand == CAND {
                                min_pos = 0;
                                for c in 1..CAND {
                                    if cand_w[c] < cand_w[min_pos] {
                                        min_pos = c;
                                    }
                                }
                                min_w = cand_w[min_pos];
                            }
                        }
                    }
                }
                last_max_r = max_r;
                for c in 0..n_cand {
                    if cand_w[c] > best_w {
                        best = cand[c];
                        best_w = cand_w[c];
                    }
                }
                if best == usize::MAX {
                    return (Status::Solved, z, iterations, max_r);
                }
            }
            let pidx = best;
            let np = scaled(&j[pidx], &isg);
            let np_norm2 = dot6(&np, &np);
            let mut up = 0.0f64;
            // Step 2: move until p is satisfied (then add it) or blocked (then drop).
            loop {
                if iterations >= prm.max_iterations {
                    return (Status::MaxIterations, z, iterations, last_max_r);
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
                    let status = if sp.is_finite() {
                        Status::Infeasible
                    } else {
                        Status::NumericalError
                    };
                    return (status, z, iterations, last_max_r);
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
                        return (Status::NumericalError, z, iterations, last_max_r);
                    }
                    break;
                }
                b.u[block] = 0.0;
                b.remove(block);
            }
        }
    }
}

/// Rows kept from a full scan as the next rows to try (most violated first).
const CAND: usize = 8;

/// Cosine above which two candidate rows count as the same direction.
const SAME_DIRECTION: f64 = 0.98;

/// `v * inv` (a unit vector when `inv = 1 / |v|`; zero for a zero row).
#[inline(always)]
fn unit(v: &[f64; DIM], inv: f64) -> [f64; DIM] {
    if inv.is_finite() {
        v.map(|x| x * inv)
    } else {
        [0.0; DIM]
    }
}

/// `|G^{-1/2} row|^2` given `ig = 1 / g`.
#[inline(always)]
fn norm2_scaled(row: &[f64; DIM], ig: &[f64; DIM]) -> f64 {
    row[0] * row[0] * ig[0]
        + row[1] * row[1] * ig[1]
        + row[2] * row[2] * ig[2]
        + row[3] * row[3] * ig[3]
        + row[4] * row[4] * ig[4]
        + row[5] * row[5] * ig[5]
}

/// `G^{-1/2}` as a 6-vector.
#[inline]
pub(crate) fn inv_sqrt(g: &[f64; DIM]) -> [f64; DIM] {
    std::array::from_fn(|i| 1.0 / g[i].sqrt())
}
