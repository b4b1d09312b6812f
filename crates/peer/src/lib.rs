//! The baselines haptic6d is compared with: 6-DoF **virtual coupling** on a physics engine, as
//! CHAI3D's ODE/Bullet tool examples, iMSTK and OpenSurgSim's tool coupler do it, on rapier3d
//! (in Rust, below) and on MuJoCo ([`mujoco`]: its Python package, run in a venv of its own).
//!
//! The tool is a dynamic rigid body with the tool mesh as its collider; the objects are fixed
//! colliders; every haptic frame the device pose pulls the tool through a 6-DoF spring-damper
//! (the same stiffness `kt`, `kr` as haptic6d's coupling, a damping on the *relative* velocity)
//! and rapier steps once at the haptic rate. The force on the hand is the coupling force.
//!
//! - [`PeerScene`]: the rapier shapes of a tool and its objects (built once: a convex
//!   decomposition takes seconds).
//! - [`PeerTool`]: one run of the coupled tool ([`PeerTool::step`] per device frame).
//! - [`PeerParams`]: the tuned parameters, [`PeerParams::tuned`] the defaults that the tuning
//!   search in docs/BENCHMARKS.md chose.
//! - [`MeshPenetration`]: the independent, mesh-level penetration measure applied to
//!   haptic6d's graphic tool and to each peer's tool.
//! - [`convex_pieces`]: a mesh as the convex pieces an engine without concave collision gets
//!   (MuJoCo's mesh geoms).
//!
//! Units: the public API speaks haptic6d's units (mm, rad, N, N·mm, s); inside, rapier works
//! in SI (m, kg, N, N·m), as its users set it up.
//!
//! Nothing in the real-time crates depends on this crate: only the bench does.

pub mod mujoco;
mod penetration;
mod tool;

pub use penetration::MeshPenetration;
pub use tool::{
    convex_pieces, ObjectShape, PeerError, PeerFrame, PeerParams, PeerScene, PeerTool, ToolShape,
};
