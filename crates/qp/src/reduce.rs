//! Constraint reduction: solve a large problem on a small working set of its rows.
//!
//! A dense contact lists thousands of rows (one per overlapping leaf-sphere pair), yet at most
//! six are active at the optimum of a 6-variable QP, and neighbouring leaves give near-copies
//! of the same row. [`RowGeneration`] solves the problem on a few **representative** rows —
//! the caller's warm-start and must-keep rows, and of each group of rows with nearly the same
//! contact normal the one the hand violates most — then checks *every* row at the answer and
//! adds the most violated ones, until none is violated (row generation, or lazy constraints).
//!
//! # Guarantee
//! The reduced problem is a relaxation of the full one (fewer rows), so its optimum is no
//! higher; an answer of it that satisfies every row of the full problem is therefore the full
//! problem's optimum. The loop stops only when every row holds to the dual solver's relative
//! feasibility test at [`RowGeneration::tol`], so the answer is the full problem's optimum
//! to that tolerance: same `dq`, same force, a [`Kkt`](crate::Kkt) certificate over all rows
//! (multipliers of the rows left out are 0). If the working set would outgrow
//! [`RowGeneration::max_rows`] or the rounds run out, the full problem is solved instead.

use crate::problem::{dot6, Problem};
use crate::solution::{Solution, Status};
use crate::solver::Solver;

/// Normal-direction bins per axis of a cube face (6 faces): rows whose translational normals
/// fall in the same bin are one group, of which one representative starts in the working set.
const BINS_PER_FACE_AXIS: usize = 4;

/// Number of normal-direction groups.
const GROUPS: usize = 6 * BINS_PER_FACE_AXIS * BINS_PER_FACE_AXIS;

/// What the last [`RowGeneration::solve`] did (for frame logs and benches).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ReductionStats {
    /// Rows of the full problem.
    pub rows: usize,
    /// Rows of the last problem actually solved (= `rows` when it was not reduced).
    pub working_rows: usize,
    /// Solves run (1 when not reduced).
    pub rounds: u32,
    /// True when the full problem was solved (small, or the reduction gave up).
    pub full: bool,
}

/// Row generation around a [`Solver`]: see the [module docs](self). Create once, reuse every
/// frame; it grows to the largest problem seen and never shrinks.
#[derive(Debug, Clone)]
pub struct RowGeneration {
    /// Problems of at most this many rows are solved whole (a small problem gains nothing).
    pub min_rows: usize,
    /// Most rows added to the working set per round (the most violated first).
    pub add_per_round: usize,
    /// Largest working set before giving up and solving the full problem.
    pub max_rows: usize,
    /// Most rounds before giving up and solving the full problem.
    pub max_rounds: u32,
    /// Relative feasibility tolerance of the check over all rows (as the dual solver's:
    /// row `k` is violated when `d_k - J_k dq > tol (|d_k| + |J_k| |dq|)`).
    pub tol: f64,
    /// Original indices of the working rows.
    selected: Vec<usize>,
    /// `in_set[k]`: row `k` is in the working set.
    in_set: Vec<bool>,
    sub_j: Vec<[f64; 6]>,
    sub_d: Vec<f64>,
    /// Warm start of the next sub-solve, as working-set positions.
    warm: Vec<usize>,
    /// Multipliers over all rows, and the active rows as original indices.
    y: Vec<f64>,
    active: Vec<usize>,
    /// Candidates to add this round: (violation, row).
    worst: Vec<(f64, usize)>,
    stats: ReductionStats,
}

impl Default for RowGeneration {
    fn default() -> Self {
        Self::new()
    }
}

impl RowGeneration {
    /// Defaults: reduce problems above 64 rows, add up to 16 rows a round, at most 12 rounds
    /// and 400 working rows, tolerance `1e-9`.
    pub fn new() -> Self {
        Self {
            min_rows: 64,
            add_per_round: 16,
            max_rows: 400,
            max_rounds: 12,
            tol: 1e-9,
            selected: Vec::new(),
            in_set: Vec::new(),
            sub_j: Vec::new(),
            sub_d: Vec::new(),
            warm: Vec::new(),
            y: Vec::new(),
            active: Vec::new(),
            worst: Vec::new(),
            stats: ReductionStats::default(),
        }
    }

    /// Reserves room for problems of up to `n` rows (and the solver's workspace for them):
    /// solves of such problems then allocate nothing.
    pub fn reserve(&mut self, solver: &mut Solver, n: usize) {
        solver.reserve(n);
        let w = self.max_rows.min(n);
        self.selected.reserve(w.saturating_sub(self.selected.len()));
        if self.in_set.len() < n {
            self.in_set.resize(n, false);
            self.y.resize(n, 0.0);
        }
        self.sub_j.reserve(w.saturating_sub(self.sub_j.len()));
        self.sub_d.reserve(w.saturating_sub(self.sub_d.len()));
        self.warm.reserve(6);
        self.active.reserve(6);
        self.worst
            .reserve((self.add_per_round + GROUPS).saturating_sub(self.worst.len()));
    }

    /// What the last solve did.
    pub fn stats(&self) -> ReductionStats {
        self.stats
    }

    /// Multipliers of the last solve, one per row of the full problem (0 for rows never in
    /// the working set).
    pub fn multipliers(&self) -> &[f64] {
        &self.y[..self.stats.rows.min(self.y.len())]
    }

    /// Rows (original indices) active at the last answer.
    pub fn active_set(&self) -> &[usize] {
        &self.active
    }

    /// Solves `p` with `solver` on a working set of its rows (see the [module docs](self)).
    /// `keep` are rows always in the working set (e.g. a trust region's), `warm` rows likely
    /// active (the last frame's): both start it, with the representatives. `dq0` is passed to
    /// the solver as in [`Solver::solve`].
    ///
    /// # Real-time
    /// Allocation-free after [`RowGeneration::reserve`] for `p.len()` rows; no panic; bounded
    /// by `max_rounds` sub-solves plus at most one full solve.
    pub fn solve(
        &mut self,
        solver: &mut Solver,
        p: &Problem<'_>,
        dq0: &[f64; 6],
        keep: &[usize],
        warm: &[usize],
    ) -> Solution {
        let n = p.len();
        if n <= self.min_rows || self.in_set.len() < n || !solver.kind.is_exact() {
            return self.solve_full(solver, p, dq0, warm);
        }
        self.selected.clear();
        for &k in keep.iter().chain(warm) {
            if !self.add(k, n) {
                return self.give_up(solver, p, dq0, warm);
            }
        }
        // A warm start is usually most of the answer: the first check then finds what is
        // missing for less than grouping every row would cost.
        if warm.is_empty() {
            self.add_representatives(p);
        }
        self.stats = ReductionStats {
            rows: n,
            working_rows: self.selected.len(),
            rounds: 0,
            full: false,
        };
        self.warm.clear();
        for (pos, &k) in self.selected.iter().enumerate() {
            if warm.contains(&k) {
                self.warm.push(pos);
            }
        }
        loop {
            if self.stats.rounds >= self.max_rounds {
                return self.give_up(solver, p, dq0, warm);
            }
            self.stats.rounds += 1;
            self.sub_j.clear();
            self.sub_d.clear();
            for &k in &self.selected {
                self.sub_j.push(p.j()[k]);
                self.sub_d.push(p.d()[k]);
            }
            let Ok(sub) = Problem::new(*p.g(), &self.sub_j, &self.sub_d) else {
                return self.give_up(solver, p, dq0, warm);
            };
            solver.set_warm_start(&self.warm);
            let sol = solver.solve(&sub, dq0);
            if sol.status != Status::Solved {
                return self.give_up(solver, p, dq0, warm);
            }
            self.stats.working_rows = self.selected.len();
            // Every row at the answer: the worst violated ones join the working set.
            let dq_norm = dot6(&sol.dq, &sol.dq).sqrt();
            self.worst.clear();
            let mut max_violation = 0.0f64;
            for (k, (row, &d)) in p.j().iter().zip(p.d()).enumerate() {
                let v = d - dot6(row, &sol.dq);
                // Most rows hold with room to spare: the tolerance (a square root) only for
                // the others.
                if v > 0.0 {
                    max_violation = max_violation.max(v);
                    if v > self.tol * (d.abs() + dot6(row, row).sqrt() * dq_norm) && !self.in_set[k]
                    {
                        self.push_worst(v, k);
                    }
                }
            }
            if self.worst.is_empty() {
                return self.finish(solver, p, sol, max_violation);
            }
            self.warm.clear();
            self.warm
                .extend(solver.active_set().iter().copied().filter(|&i| i < n));
            for i in 0..self.worst.len() {
                let k = self.worst[i].1;
                if !self.add(k, n) {
                    return self.give_up(solver, p, dq0, warm);
                }
            }
        }
    }

    /// Adds row `k` to the working set (once); false when the set is full (`max_rows`).
    fn add(&mut self, k: usize, n: usize) -> bool {
        if k >= n || self.in_set[k] {
            return true;
        }
        if self.selected.len() >= self.max_rows.min(self.selected.capacity()) {
            return false;
        }
        self.in_set[k] = true;
        self.selected.push(k);
        true
    }

    /// Keeps the `add_per_round` largest violations seen so far in `worst`.
    fn push_worst(&mut self, v: f64, k: usize) {
        if self.worst.len() < self.add_per_round {
            self.worst.push((v, k));
            return;
        }
        let (min_i, min_v) =
            self.worst
                .iter()
                .enumerate()
                .fold(
                    (0, f64::INFINITY),
                    |(mi, mv), (i, &(w, _))| {
                        if w < mv {
                            (i, w)
                        } else {
                            (mi, mv)
                        }
                    },
                );
        if v > min_v {
            self.worst[min_i] = (v, k);
        }
    }

    /// Of each group of rows with nearly the same translational normal, the one most
    /// violated at the hand (`dq = 0`: the largest `d_k / |J_k|`), if any is.
    fn add_representatives(&mut self, p: &Problem<'_>) {
        let mut best = [(0.0f64, usize::MAX); GROUPS];
        for (k, (row, &d)) in p.j().iter().zip(p.d()).enumerate() {
            if d <= 0.0 {
                continue;
            }
            // (d / |J|)², compared without a square root.
            let len2 = dot6(row, row);
            if len2 <= 0.0 {
                continue;
            }
            let score = d * d / len2;
            let g = normal_group(&[row[0], row[1], row[2]]);
            if score > best[g].0 {
                best[g] = (score, k);
            }
        }
        let n = p.len();
        for &(_, k) in &best {
            if k != usize::MAX && !self.add(k, n) {
                break;
            }
        }
    }

    /// The full problem, unreduced, with the solver's multipliers and active set kept as by
    /// [`RowGeneration::solve`] (so callers read them from here either way).
    ///
    /// # Real-time
    /// As [`Solver::solve`].
    pub fn solve_full(
        &mut self,
        solver: &mut Solver,
        p: &Problem<'_>,
        dq0: &[f64; 6],
        warm: &[usize],
    ) -> Solution {
        let n = p.len();
        self.stats = ReductionStats {
            rows: n,
            working_rows: n,
            rounds: 1,
            full: true,
        };
        self.clear_set();
        solver.set_warm_start(warm);
        let sol = solver.solve(p, dq0);
        let y = solver.multipliers();
        let n = p.len().min(self.y.len());
        for k in 0..n {
            self.y[k] = y.get(k).copied().unwrap_or(0.0);
        }
        self.active.clear();
        self.active
            .extend(solver.active_set().iter().copied().take(6));
        sol
    }

    fn give_up(
        &mut self,
        solver: &mut Solver,
        p: &Problem<'_>,
        dq0: &[f64; 6],
        warm: &[usize],
    ) -> Solution {
        let rounds = self.stats.rounds;
        let sol = self.solve_full(solver, p, dq0, warm);
        self.stats.rounds = rounds + 1;
        sol
    }

    /// The reduced answer as the full problem's: multipliers scattered to all rows, the KKT
    /// certificate over all of them.
    fn finish(
        &mut self,
        solver: &Solver,
        p: &Problem<'_>,
        mut sol: Solution,
        max_violation: f64,
    ) -> Solution {
        let n = p.len();
        for v in &mut self.y[..n] {
            *v = 0.0;
        }
        let y = solver.multipliers();
        for (pos, &k) in self.selected.iter().enumerate() {
            self.y[k] = y.get(pos).copied().unwrap_or(0.0);
        }
        self.active.clear();
        for &pos in solver.active_set().iter().take(6) {
            if let Some(&k) = self.selected.get(pos) {
                self.active.push(k);
            }
        }
        self.clear_set();
        // The rows left out have multiplier 0: stationarity, dual feasibility,
        // complementarity and the duality gap are the working set's; feasibility is the
        // check over every row.
        sol.kkt.max_violation = sol.kkt.max_violation.max(max_violation).max(0.0);
        sol
    }

    fn clear_set(&mut self) {
        for &k in &self.selected {
            if let Some(s) = self.in_set.get_mut(k) {
                *s = false;
            }
        }
        self.selected.clear();
    }
}

/// The group of a translational normal `v`: the cube face its largest component points to,
/// and a `BINS_PER_FACE_AXIS²` grid on that face. A zero normal (a pure-rotation row) is
/// group 0.
fn normal_group(v: &[f64; 3]) -> usize {
    let a = [v[0].abs(), v[1].abs(), v[2].abs()];
    let axis = if a[0] >= a[1] && a[0] >= a[2] {
        0
    } else if a[1] >= a[2] {
        1
    } else {
        2
    };
    let m = a[axis];
    // Also a NaN component: group 0.
    if m.is_nan() || m <= 0.0 {
        return 0;
    }
    let face = 2 * axis + usize::from(v[axis] < 0.0);
    let (u, w) = (v[(axis + 1) % 3] / m, v[(axis + 2) % 3] / m);
    let bin = |x: f64| {
        (((x + 1.0) * 0.5 * BINS_PER_FACE_AXIS as f64) as usize).min(BINS_PER_FACE_AXIS - 1)
    };
    (face * BINS_PER_FACE_AXIS + bin(u)) * BINS_PER_FACE_AXIS + bin(w)
}
