//! haptic6d's Python door: the real-time [`engine::Engine`], scene replays and the sphere-tree
//! builder and fit measure, as the `haptic6d` Python module.
//!
//! Two layers:
//! - the Rust core, always built and unit-tested by `cargo test` without Python:
//!   [`options`] (keyword settings to an [`engine::EngineConfig`], checked against the ranges
//!   of [`engine::config`]), [`replay`] (a whole trajectory through the engine, as
//!   `haptic6d run` does it), [`trees`] (trees from `.sph` files or meshes, `build_tree`,
//!   `eval_tree`) and [`error`] (one-line messages, as the command line prints them, sorted
//!   into value and file errors);
//! - the PyO3 bindings (`py`, behind the `python` feature that maturin turns on): classes and
//!   functions that convert arguments, call the core and raise Python exceptions.
//!
//! Units everywhere: mm, rad, N, N·mm, s, µs.
#![warn(missing_docs)]
#![cfg_attr(not(test), warn(clippy::unwrap_used, clippy::expect_used))]

pub mod engines;
pub mod error;
pub mod options;
pub mod replay;
pub mod trees;

#[cfg(feature = "python")]
mod py;

pub use error::{Failure, FailureKind};
