//! Small dense QP solvers for the god-object step of 6-DoF haptic rendering.
#![warn(missing_docs)]
// Index loops over the 6 coordinates and the ≤ 6 active rows read like the maths they implement.
#![allow(clippy::needless_range_loop)]

mod basis;
pub mod dual;
mod problem;
mod solution;

pub use dual::{DualParams, DualWorkspace};
pub use problem::Problem;
pub use solution::{Kkt, Solution, Status};

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
}
