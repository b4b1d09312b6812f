//! Collision detection between posed sphere-trees, and the linearized non-penetration
//! constraints of the haptic QP.
//!
//! Entry points:
//! - [`Pose`]: the tool configuration `q = (x, y, z, gamma, beta, alpha)` (mm, rad).
#![warn(missing_docs)]

mod pose;

pub use pose::{rotation_zyx, Pose};
