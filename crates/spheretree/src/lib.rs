//! Hierarchical sphere-trees: the flat breadth-first tree type, builders, Bradshaw `.sph` IO
//! and the fit measure.
//!
//! The builders, the fit measure and `.sph` IO are behind the default feature `offline` (they
//! need `mesh` and `rayon`); the real-time crates use the tree type alone
//! (`default-features = false`).
//!
//! Entry points:
//! - [`SphereTree`], [`Sphere`]: the tree (flat, breadth-first, branching B, unused slots).
//! - [`sph`]: the Bradshaw `.sph` format ([`sph::read_sph`], [`sph::write_sph`]).
//! - [`build::build_tree`]: sphere-trees from a closed mesh (tight or octree builder).
//! - [`caps::face_caps`]: the leaves' face caps ([`FaceCap`]) from the mesh.
//! - [`eval::evaluate_fit`]: the fit measure (docs/DESIGN.md §The fit measure), per level, in
//!   toolkit units.
#![warn(missing_docs)]

// The builders live in `src/builder/`, not `src/build/`: tools and global gitignores take a
// `build/` directory for build output. The public path stays `spheretree::build`.
#[cfg(feature = "offline")]
#[path = "builder/mod.rs"]
pub mod build;
#[cfg(feature = "offline")]
pub mod caps;
#[cfg(feature = "offline")]
pub mod eval;
#[cfg(feature = "offline")]
pub mod sph;
mod tree;

pub use tree::{slot_count, FaceCap, Sphere, SphereTree, MAX_CAPS};

/// Errors of this crate.
#[derive(Debug, thiserror::Error)]
pub enum TreeError {
    /// The tree shape is impossible.
    #[error("bad tree shape: levels {levels}, branching {branching} (need levels >= 1, branching >= 2, fewer than 2^32 slots)")]
    Shape {
        /// Levels requested.
        levels: u32,
        /// Branching requested.
        branching: u32,
    },
    /// The number of slots does not match the shape.
    #[error("expected {expected} slots for this shape, found {found}")]
    SlotCount {
        /// Slots required by the shape.
        expected: usize,
        /// Slots supplied.
        found: usize,
    },
    /// A builder could not build a tree from this input.
    #[error("cannot build the sphere-tree: {0}")]
    Build(String),
    /// A structural invariant does not hold.
    #[error("invalid sphere-tree: {0}")]
    Invalid(String),
}
