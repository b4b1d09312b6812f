//! One entry point for the four solvers.

use crate::active_set::ActiveSetWorkspace;
use crate::dual::DualWorkspace;
use crate::pqp::{PqpParams, PqpWorkspace};
use crate::pqp_parallel::{available_threads, ParallelPqpWorkspace};
use crate::problem::Problem;
use crate::solution::Solution;

/// Which algorithm [`Solver`] runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum SolverKind {
    /// Goldfarb–Idnani dual active-set, exact, warm-started from the last active set
    /// (the default).
    #[default]
    Dual,
    /// Primal active-set from a feasible start (the paper's baseline).
    ActiveSet,
    /// The paper's multiplicative-update PQP (its stopping rule by default).
    Pqp,
    /// The same PQP iteration vectorized and split over persistent threads (one per core):
    /// the serial iterates up to rounding.
    PqpParallel,
}

impl SolverKind {
    /// All kinds, in a fixed order.
    pub const ALL: [SolverKind; 4] = [
        SolverKind::Dual,
        SolverKind::ActiveSet,
        SolverKind::Pqp,
        SolverKind::PqpParallel,
    ];

    /// The command-line name: `dual`, `active-set`, `pqp`, `pqp-parallel`.
    pub fn name(self) -> &'static str {
        match self {
            SolverKind::Dual => "dual",
            SolverKind::ActiveSet => "active-set",
            SolverKind::Pqp => "pqp",
            SolverKind::PqpParallel => "pqp-parallel",
        }
    }

    /// True for solvers that return the exact QP optimum (within tolerance); the paper's PQP
    /// (serial or parallel) stops early by design.
    pub fn is_exact(self) -> bool {
        !self.is_pqp()
    }

    /// True for the paper's PQP, serial or parallel.
    pub fn is_pqp(self) -> bool {
        matches!(self, SolverKind::Pqp | SolverKind::PqpParallel)
    }
}

impl std::fmt::Display for SolverKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for SolverKind {
    type Err = crate::QpError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "dual" => Ok(SolverKind::Dual),
            "active-set" | "activeset" | "active_set" => Ok(SolverKind::ActiveSet),
            "pqp" => Ok(SolverKind::Pqp),
            "pqp-parallel" | "pqp_parallel" => Ok(SolverKind::PqpParallel),
            _ => Err(crate::QpError::UnknownSolver(s.to_string())),
        }
    }
}

/// A solver of the chosen kind with its caller-owned workspaces (create once, reuse every
/// frame). The workspaces are public for their parameters and warm-start controls.
#[derive(Debug, Clone)]
pub struct Solver {
    /// The algorithm used by [`Solver::solve`].
    pub kind: SolverKind,
    /// For [`SolverKind::Dual`]: start from the last solve's active set (default `true`).
    pub warm_start: bool,
    /// Workspace of the dual solver.
    pub dual: DualWorkspace,
    /// Workspace of the primal active-set solver.
    pub active_set: ActiveSetWorkspace,
    /// Workspace of the PQP solver (its `params` choose the stop rule).
    pub pqp: PqpWorkspace,
    /// Workspace of the parallel PQP solver (its `params` choose the stop rule). Its worker
    /// threads are spawned by [`Solver::new`] for [`SolverKind::PqpParallel`], otherwise by
    /// its first reserve or solve.
    pub pqp_parallel: ParallelPqpWorkspace,
    /// A copy of the last problem solved, while recording ([`Solver::record`]).
    recorded: Option<Box<RecordedProblem>>,
}

/// An owned copy of a [`Problem`] (see [`Solver::record`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RecordedProblem {
    /// The diagonal of `G`.
    pub g: [f64; 6],
    /// The rows `J`.
    pub j: Vec<[f64; 6]>,
    /// The right-hand sides `d`.
    pub d: Vec<f64>,
}

impl RecordedProblem {
    /// A view of the copy.
    pub fn problem(&self) -> Option<Problem<'_>> {
        Problem::new(self.g, &self.j, &self.d).ok()
    }
}

impl Default for Solver {
    /// The default: [`SolverKind::Dual`], warm-started.
    fn default() -> Self {
        Self::new(SolverKind::Dual)
    }
}

impl Solver {
    /// A solver of `kind` with default parameters (PQP: the paper's). For
    /// [`SolverKind::PqpParallel`] this spawns one worker thread per further core
    /// ([`crate::pqp_parallel::available_threads`]).
    pub fn new(kind: SolverKind) -> Self {
        let pqp_parallel = if kind == SolverKind::PqpParallel {
            ParallelPqpWorkspace::with_threads(PqpParams::paper(), available_threads())
        } else {
            ParallelPqpWorkspace::new()
        };
        Self {
            kind,
            warm_start: true,
            dual: DualWorkspace::new(),
            active_set: ActiveSetWorkspace::new(),
            pqp: PqpWorkspace::new(),
            pqp_parallel,
            recorded: None,
        }
    }

    /// Starts (`true`) or stops keeping a copy of each problem solved, the last one readable
    /// with [`Solver::recorded`]: for benches and tests that replay real frames' QPs. Not for
    /// the frame loop (the copy allocates when a problem is larger than every earlier one).
    pub fn record(&mut self, on: bool) {
        self.recorded = on.then(Box::default);
    }

    /// The last problem solved while recording (`None` when not recording or nothing solved).
    pub fn recorded(&self) -> Option<&RecordedProblem> {
        self.recorded.as_deref().filter(|r| !r.j.is_empty())
    }

    /// Reserves room for problems of up to `n` rows in the workspace of the current kind.
    pub fn reserve(&mut self, n: usize) {
        match self.kind {
            SolverKind::Dual => self.dual.reserve(n),
            SolverKind::ActiveSet => self.active_set.reserve(n),
            SolverKind::Pqp => self.pqp.reserve(n),
            SolverKind::PqpParallel => self.pqp_parallel.reserve(n),
        }
    }

    /// Solves `p`. `dq0` is a start point that should be feasible (`J dq0 >= d`, e.g.
    /// `q_g_prev - q_h`); only [`SolverKind::ActiveSet`] uses it.
    ///
    /// # Real-time
    /// Allocates only when `p.len()` exceeds every earlier `N` (see [`Solver::reserve`]);
    /// never panics; bounded by each solver's iteration cap.
    pub fn solve(&mut self, p: &Problem<'_>, dq0: &[f64; 6]) -> Solution {
        if let Some(r) = self.recorded.as_deref_mut() {
            r.g = *p.g();
            r.j.clear();
            r.j.extend_from_slice(p.j());
            r.d.clear();
            r.d.extend_from_slice(p.d());
        }
        match self.kind {
            SolverKind::Dual => self.dual.solve(p, self.warm_start),
            SolverKind::ActiveSet => self.active_set.solve(p, dq0),
            SolverKind::Pqp => self.pqp.solve(p),
            SolverKind::PqpParallel => self.pqp_parallel.solve(p),
        }
    }

    /// The multipliers (one per row) of the last solve of the current kind.
    pub fn multipliers(&self) -> &[f64] {
        match self.kind {
            SolverKind::Dual => self.dual.multipliers(),
            SolverKind::ActiveSet => self.active_set.multipliers(),
            SolverKind::Pqp => self.pqp.multipliers(),
            SolverKind::PqpParallel => self.pqp_parallel.multipliers(),
        }
    }

    /// Indices of the rows active (held tight) at the answer of the last solve; empty for
    /// [`SolverKind::Pqp`] and [`SolverKind::PqpParallel`], which keep no active set.
    pub fn active_set(&self) -> &[usize] {
        match self.kind {
            SolverKind::Dual => self.dual.active_set(),
            SolverKind::ActiveSet => self.active_set.active_set(),
            SolverKind::Pqp | SolverKind::PqpParallel => &[],
        }
    }

    /// Rows to start the next solve from (the dual solver's warm start; the other kinds
    /// ignore it). An empty slice clears it.
    ///
    /// # Real-time
    /// No allocation (at most 6 rows are kept), no panic.
    pub fn set_warm_start(&mut self, rows: &[usize]) {
        self.dual.set_warm_start(rows);
    }
}
