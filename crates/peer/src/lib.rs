//! The baseline haptic6d is compared with: 6-DoF **virtual coupling** on the rapier3d physics
//! engine, as CHAI3D's ODE/Bullet tool examples, iMSTK and OpenSurgSim's tool coupler do it.
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
//! - [`MeshPenetration`]: the independent, mesh-level penetration measure applied to both
//!   haptic6d's graphic tool and the peer's tool.
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
