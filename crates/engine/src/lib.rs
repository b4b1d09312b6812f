//! haptic6d's real-time engine: one object, [`Engine`], that a haptic servo loop calls once per
//! tick — device pose in, safe wrench out.
//!
//! A frame detects the leaf pairs of the tool's sphere-tree against the objects' trees, builds
//! linearised non-penetration constraints, solves a small QP for the constrained (god-object)
//! pose, computes the virtual-coupling spring wrench and passes it through the safety layer
//! (clamp, rate limit, NaN guard, soft start). Everything is sized in [`Engine::new`]; a frame
//! never allocates, never panics and never outputs NaN.
//!
//! The whole integration, with trees built elsewhere (a scene file through the `scene` crate,
//! or `spheretree::build::build_tree` on your meshes):
//!
//! ```
//! use engine::{Engine, EngineConfig, Pose};
//! use spheretree::{Sphere, SphereTree};
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! // A one-sphere tool of radius 5 mm and a one-sphere object of radius 20 mm at the origin.
//! let tool = SphereTree::from_slots(1, 2, vec![Sphere::new([0.0; 3], 5.0)])?;
//! let object = SphereTree::from_slots(1, 2, vec![Sphere::new([0.0; 3], 20.0)])?;
//! let mut engine = Engine::new(&tool, &[(object, Pose::identity())], EngineConfig::default())?;
//! engine.reset(&Pose::from_array([0.0, 0.0, 40.0, 0.0, 0.0, 0.0]))?;
//! for tick in 0..100 {
//!     let t = tick as f64 * 1e-3; // s
//!     // The device moves the hand down through the object; the tool stops on its surface.
//!     let hand = Pose::from_array([0.0, 0.0, 40.0 - 0.5 * tick as f64, 0.0, 0.0, 0.0]);
//!     let frame = engine.step(t, &hand);
//!     let _send_to_device = frame.wrench; // [Fx, Fy, Fz] N, [Tx, Ty, Tz] N·mm
//! }
//! // The hand ended 9.5 mm below the object's centre; the tool rests on top of the object,
//! // its centre 5 + 20 mm from the object's (within the penetration tolerance, 0.002 mm) ...
//! let frame = engine.frame();
//! let (z_g, z_h) = (frame.q_g[2], 40.0 - 0.5 * 99.0);
//! assert!((z_g - 25.0).abs() <= 0.002, "{z_g}");
//! assert!(frame.q_g.iter().enumerate().all(|(k, v)| k == 2 || v.abs() < 1e-9));
//! // ... and the device gets the coupling spring, kt (z_g - z_h) = 1 N/mm x 34.5 mm, up.
//! assert!((frame.wrench[2] - (z_g - z_h)).abs() < 1e-9);
//! assert!(frame.wrench.iter().enumerate().all(|(k, v)| k == 2 || v.abs() < 1e-9));
//! # Ok(())
//! # }
//! ```
//!
//! Modules, for the parts an application may want on their own:
//! - [`step`]: the god-object step (one frame without the safety layer) and its parameters.
//! - [`safety`]: the force/torque clamp, rate limit, NaN guard and soft start.
//! - [`config`]: the accepted range of every numeric setting, shared with scene files and the
//!   command line.
//! - [`setting`]: the one name table of each enumerated setting (solver, constraint form,
//!   rotation coordinates).
#![warn(missing_docs)]
// Index loops over the 6 coordinates read like the maths they implement.
#![allow(clippy::needless_range_loop)]
#![cfg_attr(not(test), warn(clippy::unwrap_used, clippy::expect_used))]

pub mod config;
mod engine;
mod geometry;
pub mod safety;
pub mod setting;
pub mod step;

pub use collide::{ConstraintForm, LeafPair, Pose, RotationCoordinates};
pub use engine::{Counters, Engine, EngineConfig, Frame};
pub use geometry::{Geometry, MeshRef};
pub use qp::SolverKind;
pub use step::{FrameStatus, Friction, FrictionState, Heuristics, Tuning};

/// Errors of the engine. Each message says what to fix; the cause is kept as the source.
#[derive(Debug, thiserror::Error)]
pub enum EngineError {
    /// A setting is outside its accepted range ([`config`]).
    #[error(transparent)]
    Setting(#[from] config::SettingError),
    /// A sphere-tree cannot be used for collision detection.
    #[error("{body}")]
    Tree {
        /// Which tree: `tool tree` or `object N` (1-based).
        body: String,
        /// Why it cannot be used.
        #[source]
        source: collide::CollideError,
    },
    /// The start configuration is in collision and no free pose was found nearby.
    #[error("the start pose is in collision and no free pose was found within {searched_mm} mm; move `start` away from the objects")]
    NoFreeStart {
        /// Search radius, mm.
        searched_mm: f64,
    },
    /// A body's mesh cannot be attached to its tree (the mesh geometry mode).
    #[error("{body}: {source}")]
    Mesh {
        /// Which mesh: `tool mesh` or `object N mesh` (1-based).
        body: String,
        /// Why.
        #[source]
        source: collide::MeshLeavesError,
    },
    /// The mesh geometry mode was asked for with the squared constraint form.
    #[error("geometry = \"mesh\" needs form = \"distance\" (the squared form has no meaning between triangles)")]
    MeshNeedsDistance,
    /// The detection helper thread ([`EngineConfig::helper_thread`]) could not be started.
    #[error("cannot start the detection helper thread: {0} (set `[solver] helper_thread = false` to detect on one thread)")]
    HelperThread(String),
    /// An object index beyond the scene's objects.
    #[error("object {} does not exist: the scene has {objects} object(s)", object + 1)]
    NoSuchObject {
        /// The index given (0-based; shown 1-based).
        object: usize,
        /// How many objects there are.
        objects: usize,
    },
}
