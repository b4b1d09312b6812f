//! Collision detection between posed sphere-trees, and the linearized non-penetration
//! constraints of the haptic QP (docs/DESIGN.md §Collision detection, §Constraints).
//!
//! Entry points:
//! - [`Pose`]: the tool configuration `q = (x, y, z, gamma, beta, alpha)` (mm, rad),
//!   `R = Rz(alpha) Ry(beta) Rx(gamma)`; [`rotation_zyx_partials`] its exact derivatives.
//! - [`PackedTree`]: a [`spheretree::SphereTree`] repacked for traversal (objects with their
//!   fixed pose applied).
//! - [`overlap_tree_tree`], [`overlap_tree_trees`], [`collect_pairs`]: every leaf pair whose
//!   gap is at most a margin (mm), through a visit closure or a reusable buffer, with a
//!   caller-owned [`CollideWorkspace`]; [`LeafPair`] carries the geometry of the pair;
//!   [`TraversalStats`] counts the work; [`PackedTree::sweep_margin`] gives the anti-tunnelling
//!   margin for the motion from `q_g_prev` to `q_h`; [`overlap_swept`] the pairs that can
//!   touch along a straight motion ([`Sweep`]), without the isotropic margin's excess.
//! - [`NeighbourList`]: every leaf pair within a wide margin of a pose, filtered instead of
//!   traversed while later queries stay inside its cover (exactly the traversal's pairs);
//!   [`BackgroundList`] builds the next one in slices, or on a [`TraversalTeam`]'s helper.
//! - Face cuts ([`FaceCut`], from a tree's [`spheretree::FaceCap`]s): above a flat face a pair
//!   stands for the face's half-space ([`LeafPair::on_face`], [`FacePlane`]), exact and without
//!   sphere bumps; elsewhere a cut leaf stands for its sphere cut by the plane (the lens,
//!   [`StandIn`]); a cut inner node's face stands for its subtree (docs/DESIGN.md §Face caps).
//!   A [`FaceSlab`] in [`overlap_shared`] keeps a face's half-space pairs within a thinner
//!   margin than the rest (a tool sliding on the face: its gaps to the face change only with
//!   the motion across it).
//! - [`ConstraintForm`], [`Linearization`], [`fill_constraints`]: rows `J dq >= d`.
//!
//! ```
//! use collide::{collect_pairs, fill_constraints, CollideWorkspace, ConstraintForm, PackedTree, Pose};
//! use spheretree::{Sphere, SphereTree};
//!
//! // A two-level tree: a root and two leaves along x (mm).
//! let mut tree = SphereTree::new_unused(2, 2).unwrap();
//! tree.spheres_mut()[0] = Sphere::new([0.0; 3], 2.0);
//! tree.spheres_mut()[1] = Sphere::new([-1.0, 0.0, 0.0], 1.0);
//! tree.spheres_mut()[2] = Sphere::new([1.0, 0.0, 0.0], 1.0);
//! let tool = PackedTree::new(&tree).unwrap();
//! let objects = [PackedTree::new(&tree).unwrap()];
//! let mut ws = CollideWorkspace::for_trees(&tool, &objects);
//! let mut pairs = Vec::with_capacity(16);
//! let q_h = Pose::from_array([3.5, 0.0, 0.0, 0.0, 0.0, 0.0]);
//! collect_pairs(&tool, &q_h, &objects, 0.0, &mut ws, &mut pairs).unwrap();
//! assert_eq!(pairs.len(), 1); // tool's left leaf against the object's right leaf
//! assert!((pairs[0].gap - -0.5).abs() < 1e-12);
//! let (mut rows, mut rhs) = (vec![[0.0; 6]; 16], vec![0.0; 16]);
//! let n = fill_constraints(ConstraintForm::Distance, &q_h, &q_h, &pairs, &mut rows, &mut rhs).unwrap();
//! assert_eq!(n, 1);
//! assert!((rows[0][0] - 1.0).abs() < 1e-12 && (rhs[0] - 0.5).abs() < 1e-12); // push +x by 0.5 mm
//! ```
#![warn(missing_docs)]
// Index loops over the 6 coordinates read like the maths they implement.
#![allow(clippy::needless_range_loop)]

mod constraint;
mod contact_area;
mod features;
mod flat_faces;
mod mesh_leaves;
mod near;
mod neighbours;
mod packed;
mod pages;
mod pose;
mod probe;
mod team;
mod traverse;
mod triangle;
mod triangle_tree;

pub use constraint::{
    constraint_value, fill_constraints, pair_constraint_value, ConstraintForm, Linearization,
    RotationCoordinates, DEGENERATE_DISTANCE,
};
pub use contact_area::{flat_overlap, AreaMoment};
pub use features::{
    feature_contacts, Edge, EdgeKind, Feature, FeatureContact, MeshFeatures, PlacedFeatures,
    FEATURE_SLACK_MM,
};
pub use flat_faces::{merge_flat_faces, FlatFaces, FLAT_TOLERANCE_MM};
pub use mesh_leaves::{MeshLeaves, MeshLeavesError};
pub use near::near_box;
pub use neighbours::{BackgroundList, ListStatus, NeighbourList};
pub use packed::{PackedTree, WARM_CHUNK_NODES};
pub use pages::{touch_pages, PAGE_BYTES};
pub use pose::{rotation_exp, rotation_log, rotation_zyx, rotation_zyx_partials, CentreBox, Pose};
pub use probe::{FreeSpaceProbe, ProbeStatus};
pub use team::{
    overlap_shared, overlap_shared_proving, SharedTraversal, TraversalTeam, SHARE_MIN_PAIRS,
    SPIN_WINDOW,
};
pub use traverse::{
    any_pair_within, any_pair_within_until, collect_pairs, overlap_swept, overlap_tree_tree,
    overlap_tree_trees, overlap_until, CollideWorkspace, FaceCut, FacePlane, FaceSlab, LeafPair,
    StandIn, Sweep, Traversal, TraversalStats,
};
pub use triangle::{
    closest_on_triangle, triangle_distance, triangle_distance_all_features, triangle_distance_from,
    NearestEdges, Triangle, TriangleDistance,
};
pub use triangle_tree::{bounds_of, edges_of, TreePairStack, TriangleTree, LEAF_TRIANGLES};

/// Errors of this crate.
#[derive(Debug, thiserror::Error)]
pub enum CollideError {
    /// A pose holds a NaN or infinite number.
    #[error("pose is not finite; check the device input or the scene's pose (all six numbers must be finite)")]
    NonFinitePose,
    /// The sphere-tree breaks an invariant the traversal relies on.
    #[error("sphere-tree cannot be used for collision detection: {0} (for files that do not keep 'parent contains children', call SphereTree::enforce_containment first)")]
    InvalidTree(String),
    /// The helper thread still holds the probe's second stream (a slice it ran past its
    /// deadline): the probe cannot restart until it lets go.
    #[error("the detection helper thread is still busy with the last probe; try again next frame")]
    Busy,
    /// A caller buffer is too short for the rows.
    #[error("constraint buffers too short: {needed} pairs, {rows} rows, {rhs} right-hand sides; size them to the pair count")]
    BufferTooSmall {
        /// Rows needed (number of pairs).
        needed: usize,
        /// Length of the row buffer.
        rows: usize,
        /// Length of the right-hand-side buffer.
        rhs: usize,
    },
}
