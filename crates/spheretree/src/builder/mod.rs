//! Sphere-tree builders.
//!
//! Entry point: [`build_tree`]`(mesh, &`[`BuildParams`]`, progress)` with a [`BuildMethod`]:
//! - [`BuildMethod::Tight`] (default): recursive balanced clustering of dense surface samples
//!   (denser where the mesh is thin, then where the first leaves erred) into B patches per
//!   node; each leaf sphere covers its patch while protruding as little as possible out of
//!   the mesh (centre optimised inward against an upper bound of the protrusion, then checked
//!   against a denser sample set so coverage holds); parents contain their children and,
//!   among such spheres, protrude least out of the mesh.
//! - [`BuildMethod::Octree`]: the fast one: cells of an octree on the bounding cube that meet
//!   the surface, each leaf bounding the surface clipped to its cell (full coverage by
//!   construction), parents the smallest spheres enclosing their children.
//!
//! Rule kept by every builder: each used parent sphere **contains** each used child sphere
//! (checked by [`SphereTree::validate`]). All builders work in the toolkit frame (mesh scaled
//! about its bounding-box centre to longest side 2000) and return the tree in the mesh's own
//! frame and units.

#![allow(clippy::needless_range_loop)] // xyz loops read better indexed

mod enclose;
mod octree;
mod partition;
mod tight;

pub use enclose::enclosing_sphere;

use crate::eval::toolkit_frame;
use crate::{Sphere, SphereTree, TreeError};
use mesh::{InsideTest, TriMesh};

/// Version of the builders' output: bumped whenever a builder gives a different tree for the
/// same [`BuildParams`] (fold it into any cache key of built trees). 3: bounded queries
/// (trees of fine meshes change; the bundled bunny's and spline's do not) and open meshes in
/// the tight builder.
pub const BUILDER_VERSION: u32 = 3;

/// Most triangles one signed-distance query of a parent fit may test; more than any mesh
/// of fewer triangles can need, so the bundled meshes (at most 7488 triangles) are fitted
/// exactly as without a bound.
const PARENT_QUERY_BUDGET: usize = 8192;

/// Which builder [`build_tree`] runs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum BuildMethod {
    /// Octree cells meeting the surface, circumscribed spheres: fast, full coverage, loose.
    Octree,
    /// Clustered surface patches with optimised leaf spheres: tight (the default).
    #[default]
    Tight,
}

impl BuildMethod {
    /// The name used on the command line (`octree`, `tight`).
    pub fn name(self) -> &'static str {
        match self {
            BuildMethod::Octree => "octree",
            BuildMethod::Tight => "tight",
        }
    }
}

impl std::str::FromStr for BuildMethod {
    type Err = TreeError;
    fn from_str(s: &str) -> Result<Self, TreeError> {
        match s {
            "octree" => Ok(BuildMethod::Octree),
            "tight" => Ok(BuildMethod::Tight),
            other => Err(TreeError::Build(format!(
                "unknown build method `{other}`: use `tight` or `octree`"
            ))),
        }
    }
}

/// Options of [`build_tree`]. Lengths are in toolkit units (mesh longest side = 2000).
#[derive(Clone, Debug, PartialEq)]
pub struct BuildParams {
    /// Depth of the tree (levels = depth + 1; default 4).
    pub depth: u32,
    /// Branching factor B (default 8; the octree needs B >= 8 and leaves the rest unused).
    pub branching: u32,
    /// Which builder (default [`BuildMethod::Tight`]).
    pub method: BuildMethod,
    /// Seed of every random choice (surface samples); the same seed gives the same tree.
    pub seed: u64,
    /// Tight builder: surface samples per leaf slot used to shape the patches (default 32).
    pub samples_per_leaf: usize,
    /// Tight builder: surface samples per leaf slot used to check coverage (default 128; at
    /// least 200 000 in all).
    pub check_samples_per_leaf: usize,
    /// Tight builder: weight of the leaf radius in the leaf objective
    /// `protrusion bound + size_weight * radius` (default 0.02): 0 lets leaf spheres grow
    /// towards the medial axis, larger values keep them small at a little more protrusion.
    pub size_weight: f64,
    /// Tight builder: every leaf radius is grown by this much beyond its patch (toolkit units,
    /// default 1.0) so the thin slivers between neighbouring caps are covered too.
    pub coverage_margin: f64,
    /// Tight builder: how strongly thin parts get more, smaller leaves (default 1.0). Surface
    /// is sampled with density `(1 / local thickness)^adaptivity` (thickness: radius of the
    /// largest inner ball touching there, clamped to 10..250 toolkit units), and patches hold
    /// equal numbers of samples; 0 gives equal-area patches.
    pub adaptivity: f64,
    /// Tight builder: weight of the sample normals against positions when clustering, as a
    /// fraction of the node's RMS radius (default 0: position only, so a patch on a thin
    /// part may take both sides and its sphere sits on the medial axis, which measured
    /// tighter on the bunny than keeping the sides apart: worst 15.1 vs 16.1 at 0.5).
    pub normal_weight: f64,
    /// Tight builder: extra passes that resample each region in proportion to the error of
    /// the leaf covering it and rebuild, evening the leaf errors out (default 1).
    pub refine_passes: usize,
    /// Tight builder: Lloyd (k-means) iterations after each balanced split (default 4).
    pub lloyd_iters: usize,
    /// Tight builder: how inside is told from outside; `None` (default) picks
    /// [`InsideTest::for_mesh`]: the pseudo-normal on closed meshes, the generalised winding
    /// number on open or non-manifold ones. Force [`InsideTest::WindingNumber`] for a closed
    /// mesh whose parts pass through each other.
    pub inside: Option<InsideTest>,
}

impl Default for BuildParams {
    fn default() -> Self {
        Self {
            depth: 4,
            branching: 8,
            method: BuildMethod::Tight,
            seed: 1,
            samples_per_leaf: 32,
            check_samples_per_leaf: 128,
            size_weight: 0.02,
            coverage_margin: 1.0,
            adaptivity: 1.0,
            normal_weight: 0.0,
            lloyd_iters: 4,
            refine_passes: 1,
            inside: None,
        }
    }
}

impl BuildParams {
    /// The fast preset: the octree builder at `depth`.
    pub fn fastest_build(depth: u32) -> Self {
        Self {
            depth,
            method: BuildMethod::Octree,
            ..Self::default()
        }
    }

    /// The tight preset (the default) at `depth`.
    pub fn tightest(depth: u32) -> Self {
        Self {
            depth,
            ..Self::default()
        }
    }
}

/// What [`build_tree_with_report`] did besides the tree.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BuildReport {
    /// The inside test the tight builder used (`None` for the octree builder, which needs
    /// none).
    pub inside: Option<InsideTest>,
    /// Holes closed by fans for the winding-number queries (0 for a closed mesh).
    pub holes_closed: usize,
}

/// Builds a sphere-tree of `mesh` (mesh units; open, holed or non-manifold meshes are fine:
/// see [`BuildParams::inside`]). `progress` is called with the completed fraction in `0..=1`
/// (from worker threads). The result is in the mesh's own frame and passes
/// [`SphereTree::validate`].
///
/// Errors on an empty or degenerate mesh, a bad shape, or an octree with `branching < 8`.
pub fn build_tree(
    mesh: &TriMesh,
    params: &BuildParams,
    progress: &(dyn Fn(f64) + Sync),
) -> Result<SphereTree, TreeError> {
    build_tree_with_report(mesh, params, progress).map(|(tree, _)| tree)
}

/// [`build_tree`], also saying which inside test was used.
pub fn build_tree_with_report(
    mesh: &TriMesh,
    params: &BuildParams,
    progress: &(dyn Fn(f64) + Sync),
) -> Result<(SphereTree, BuildReport), TreeError> {
    let levels = params.depth.checked_add(1).ok_or(TreeError::Shape {
        levels: u32::MAX,
        branching: params.branching,
    })?;
    let mut tree = SphereTree::new_unused(levels, params.branching)?;
    let (centre, scale) = toolkit_frame(mesh).ok_or_else(|| {
        TreeError::Build("the mesh is empty or has no extent: give a mesh with triangles".into())
    })?;
    let m = mesh.scaled_about(centre, scale);
    if m.triangles.is_empty() {
        return Err(TreeError::Build(
            "the mesh has no triangles: give a closed triangle mesh".into(),
        ));
    }
    progress(0.0);
    let mut report = BuildReport {
        inside: None,
        holes_closed: 0,
    };
    match params.method {
        BuildMethod::Octree => octree::build(&m, &mut tree, progress)?,
        BuildMethod::Tight => {
            let inside = params.inside.unwrap_or_else(|| InsideTest::for_mesh(&m));
            progress(0.01);
            report.inside = Some(inside);
            report.holes_closed = tight::build(&m, params, inside, &mut tree, progress)?;
        }
    }
    // Back to the mesh frame. The similarity keeps containment up to rounding; grow parents
    // by that rounding (≤ 1e-12 relative) so validate() holds exactly.
    for s in tree.spheres_mut() {
        if s.is_used() {
            *s = Sphere::new(
                [
                    s.center[0] / scale + centre[0],
                    s.center[1] / scale + centre[1],
                    s.center[2] / scale + centre[2],
                ],
                s.radius / scale,
            );
        }
    }
    tree.enforce_containment();
    progress(1.0);
    Ok((tree, report))
}

/// Fills every internal used slot bottom-up with a sphere containing its used children
/// (toolkit frame). Without `q`: the smallest enclosing sphere. With `q` (the mesh's query
/// structure): among the spheres that contain the children, the one that protrudes least out
/// of the mesh (same objective as the tight leaves: `R(c) + sd(c) + size_weight · R(c)`,
/// `R(c) = max_i |c - c_i| + r_i`), started from the smallest one. Containment holds exactly
/// because the radius is computed from the centre. Slots whose children are all unused stay.
pub(crate) fn fill_parents(tree: &mut SphereTree, q: Option<(&mesh::MeshQuery, f64)>) {
    use rayon::prelude::*;
    for level in (0..tree.depth()).rev() {
        let range = tree.level_range(level);
        let filled: Vec<Option<Sphere>> = range
            .clone()
            .into_par_iter()
            .map(|n| {
                let kids: Vec<Sphere> = tree
                    .children(n)
                    .map(|c| *tree.sphere(c))
                    .filter(|s| s.is_used())
                    .collect();
                if kids.is_empty() {
                    return None;
                }
                let min = enclosing_sphere(&kids);
                let Some((q, size_weight)) = q else {
                    return Some(min);
                };
                let reach = |c: [f64; 3]| {
                    kids.iter()
                        .map(|k| crate::eval::dist(c, k.center) + k.radius)
                        .fold(0.0, f64::max)
                };
                // A centre nearly equidistant to a large part of the mesh (the middle of a
                // fine sphere) makes each signed distance a scan of the mesh: past the budget
                // the parent keeps the smallest enclosing sphere instead.
                let cut = std::sync::atomic::AtomicBool::new(false);
                let f = |c: [f64; 3]| {
                    if cut.load(std::sync::atomic::Ordering::Relaxed) {
                        return 0.0;
                    }
                    let sd = q.signed_distance_budgeted(c, PARENT_QUERY_BUDGET);
                    if sd.is_none() {
                        cut.store(true, std::sync::atomic::Ordering::Relaxed);
                    }
                    reach(c) * (1.0 + size_weight) + sd.unwrap_or(0.0)
                };
                let c = enclose::nelder_mead(&f, min.center, 0.25 * min.radius, 60, 1e-1);
                let best = if f(c) < f(min.center) { c } else { min.center };
                if cut.into_inner() {
                    return Some(min);
                }
                Some(Sphere::new(best, reach(best)))
            })
            .collect();
        for (n, s) in range.zip(filled) {
            if let Some(s) = s {
                tree.spheres_mut()[n] = s;
            }
        }
    }
}
