//! Small dense QP solvers for the god-object step of 6-DoF haptic rendering.
//!
//! # The problem
//!
//! ```text
//! minimize    1/2 dq^T G dq
//! subject to  J dq >= d
//! ```
//!
//! with `dq = q - q_h` in R^6 (mm, rad: the step from the device pose to the graphic tool's
//! pose), `G = diag(g)` positive (in the haptic step `diag(kt, kt, kt, kr, kr, kr)`, N/mm and
//! N·mm/rad), `J` the `N × 6` constraint rows and `d` their right-hand sides (one
//! linearized non-penetration constraint per overlapping sphere pair). The objective is the
//! coupling spring's energy (N·mm); the optimum's force is `G dq`. `N = 0` gives `dq = 0`.
//! Every solver also returns multipliers `y >= 0` (one per row, with `G dq = J^T y` at the
//! optimum) and a [`Kkt`] certificate.
//!
//! Internally the solvers work in the scaled space `z = G^{1/2} dq`, where the objective is
//! `1/2 |z|^2` and row `k` is `n_k = G^{-1/2} J_k^T`; relative tolerances refer to it.
//!
//! # Entry points
//!
//! - [`Problem`]: a view over the caller's `g`, `J` (`&[[f64; 6]]`) and `d` (`&[f64]`).
//! - [`Solver`] with [`SolverKind`]: one entry point that dispatches, holding all
//!   workspaces; [`Solver::solve`] returns a [`Solution`] (`dq`, [`Status`], iterations,
//!   objective, [`Kkt`]).
//! - [`RowGeneration`]: constraint reduction around any exact solver — a few representative
//!   rows, then every violated row, until the answer satisfies them all (the full problem's
//!   optimum, solved on tens of rows instead of thousands). See [`reduce`].
//! - The solvers and their caller-owned workspaces (grow, never shrink; no allocation once
//!   warmed up to a given `N`):
//!   - [`DualWorkspace`] (`dual`, the default): Goldfarb–Idnani dual active-set, exact,
//!     O(6N) per iteration, warm start from the last active set. See [`dual`].
//!   - [`ActiveSetWorkspace`] (`active-set`): primal active-set from a feasible start, the
//!     paper's baseline. See [`active_set`].
//!   - [`PqpWorkspace`] (`pqp`): the paper's multiplicative-update dual method, with the
//!     paper's stop ([`PqpParams::paper`]) or a KKT stop ([`PqpParams::tight`]). See [`pqp`]
//!     for the dual problem and the derivation of its signs.
//!   - [`ParallelPqpWorkspace`] (`pqp-parallel`): the same PQP iteration with its update
//!     vectorized (AVX-512 or AVX2 with FMA where the CPU has it), the entries of `|Q|`
//!     recomputed from the rows past 2 000 rows, and split over persistent worker threads;
//!     the serial iterates up to rounding. See [`pqp_parallel`].
//!
//! # Example
//!
//! ```
//! use qp::{Problem, Solver, SolverKind, Status};
//!
//! // Two contacts pushing the tool along +x and +y by 1 mm and 0.5 mm.
//! let g = [1.0, 1.0, 1.0, 1000.0, 1000.0, 1000.0];
//! let j = [[1.0, 0.0, 0.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0, 0.0, 0.0]];
//! let d = [1.0, 0.5];
//! let p = Problem::new(g, &j, &d)?;
//! let mut solver = Solver::new(SolverKind::Dual);
//! let sol = solver.solve(&p, &[0.0; 6]);
//! assert_eq!(sol.status, Status::Solved);
//! assert!((sol.dq[0] - 1.0).abs() < 1e-12 && (sol.dq[1] - 0.5).abs() < 1e-12);
//! assert!(sol.kkt.max_violation < 1e-12 && sol.kkt.min_multiplier >= 0.0);
//! # Ok::<(), qp::QpError>(())
//! ```
#![warn(missing_docs)]
// Index loops over the 6 coordinates and the ≤ 6 active rows read like the maths they implement.
#![allow(clippy::needless_range_loop)]
#![cfg_attr(not(test), warn(clippy::unwrap_used, clippy::expect_used))]

pub mod active_set;
mod basis;
pub mod dual;
pub mod pqp;
pub mod pqp_parallel;
mod problem;
pub mod reduce;
mod solution;
mod solver;

pub use active_set::{ActiveSetParams, ActiveSetWorkspace};
pub use dual::{DualParams, DualWorkspace};
pub use pqp::{PqpParams, PqpWorkspace};
pub use pqp_parallel::ParallelPqpWorkspace;
pub use problem::Problem;
pub use reduce::{ReductionStats, RowGeneration};
pub use solution::{Kkt, Solution, Status};
pub use solver::{RecordedProblem, Solver, SolverKind};

/// Errors of this crate (bad input only; a solve that fails to converge is a [`Status`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum QpError {
    /// `J` and `d` have different lengths.
    #[error("J has {rows} rows but d has {rhs} entries: pass one right-hand side per row")]
    LengthMismatch {
        /// Rows of `J`.
        rows: usize,
        /// Entries of `d`.
        rhs: usize,
    },
    /// A diagonal entry of `G` is not a finite positive number.
    #[error("G[{axis}] = {value}: the weights must be finite and > 0 (e.g. kt = 1 N/mm, kr = 1000 N·mm/rad)")]
    BadWeight {
        /// Axis 0..6.
        axis: usize,
        /// The offending value.
        value: f64,
    },
    /// A row of `J` or an entry of `d` is NaN or infinite.
    #[error("row {row} of J or d is not finite: check the constraint generation")]
    NonFinite {
        /// The first offending row.
        row: usize,
    },
    /// A solver name that is not one of `dual`, `active-set`, `pqp`, `pqp-parallel`.
    #[error("unknown solver `{0}`: use one of dual, active-set, pqp, pqp-parallel")]
    UnknownSolver(String),
}
