//! Built-in scenes (`bunny`, `spline`, `plate`, `spline-tight`, `probe`) and the mesh loading
//! they share with scene files.
//!
//! - [`builtin`]: a built-in scene by name, trees built (or fetched from the cache).
//! - [`bunny`]: bunny tool against a bunny object, depth 4, ~100 mm.
//! - [`spline_mesh::SplineParams`]: the splined shaft and hub meshes of the `spline` scene
//!   (1 mm clearance) and of `spline-tight` (0.1 mm, [`spline_scene::tight_scene`]).
//! - [`probe`]: a periodontal probe slid down a 0.6 mm pocket to its floor.
//! - [`plate`]: a puck or ball pressed onto a flat plate and slid or turned at hand speeds.
//! - [`zoo`]: the scene zoo (`zoo/slot`, `zoo/gears`, ...), scripted strokes on many shapes.
//! - [`fit`]: generated pegs and holes at a chosen clearance, for clearance studies.

pub mod bunny;
pub mod fit;
pub mod plate;
pub mod probe;
pub mod spline_mesh;
pub mod zoo;

use std::path::Path;

use collide::{overlap_tree_trees, CollideWorkspace, PackedTree, Pose};
use mesh::TriMesh;

use crate::cache::TreeCache;
use crate::Scene;
use crate::SceneError;

/// Names of the built-in scenes.
pub const BUILTIN_NAMES: &[&str] = &["bunny", "spline", "plate", "spline-tight", "probe"];

/// The built-ins whose geometry is the parts' own triangles (`[solver] geometry = "mesh"`):
/// fits tighter than the leaf spheres' overhang, on which the spheres jam.
pub const MESH_BUILTIN_NAMES: &[&str] = &["spline-tight", "probe"];

/// The built-ins whose geometry is the leaf spheres: [`BUILTIN_NAMES`] without
/// [`MESH_BUILTIN_NAMES`], for studies of the sphere geometry.
pub fn sphere_builtin_names() -> impl Iterator<Item = &'static str> {
    BUILTIN_NAMES
        .iter()
        .copied()
        .filter(|n| !MESH_BUILTIN_NAMES.contains(n))
}

/// Whether `name` names a built-in scene: one of [`BUILTIN_NAMES`], of the zoo
/// ([`zoo::ZOO`]) or a clearance-study row ([`fit::study_params`]).
pub fn is_builtin(name: &str) -> bool {
    BUILTIN_NAMES.contains(&name) || zoo::is_zoo(name) || fit::study_params(name).is_some()
}

/// Whether `name` is of a family of built-ins (`zoo/…`, `fit/…`): a name there that is not a
/// scene gets the family's own error from [`builtin`], not a missing file's.
pub fn is_builtin_family(name: &str) -> bool {
    name.starts_with("zoo/") || name.starts_with("fit/")
}

/// The one-line error for `name`, neither a built-in scene nor a file (every door's same
/// words).
pub fn no_such_scene(name: &str) -> String {
    format!(
        "no built-in scene or scene file named `{name}` (built-in: {}, zoo/..., fit/...; files end in .toml)",
        BUILTIN_NAMES.join(", ")
    )
}

/// A built-in scene by name (one of [`BUILTIN_NAMES`], a zoo scene such as `zoo/slot` or a
/// clearance-study row such as `fit/round-r10-c0.05`), trees from `cache` or built.
pub fn builtin(name: &str, cache: &TreeCache) -> Result<Scene, SceneError> {
    let scene = match name {
        _ if zoo::is_zoo(name) => zoo::zoo_scene(name, cache)?.scene,
        _ if name.starts_with("fit/") => match fit::study_params(name) {
            Some(p) => fit::fit_scene(&p, cache)?.scene,
            None => {
                return Err(SceneError::Unknown {
                    what: "clearance-study row",
                    name: name.to_string(),
                    expected: "fit/<round|splined>-r<radius>-c<clearance>[-chamfer][-tilted] as \
                               `haptic6d bench --studies fit` names them (fit/round-r10-c0.05, \
                               fit/splined-r10-c0.1-chamfer-tilted, ...)"
                        .to_string(),
                })
            }
        },
        "bunny" => bunny::scene(cache)?,
        "spline" => spline_scene::scene(
            cache,
            &spline_mesh::SplineParams::default(),
            spline_scene::TREE_DEPTH,
        )?,
        "plate" => plate::builtin(cache)?,
        "spline-tight" => spline_scene::tight_scene(cache)?,
        "probe" => probe::probe_scene(&probe::ProbeParams::default(), cache)?.scene,
        _ => {
            return Err(SceneError::Unknown {
                what: "scene",
                name: name.to_string(),
                expected: format!(
                    "{}, a zoo scene ({}), a clearance-study row (fit/round-r10-c0.05, ...) or a scene file (.toml)",
                    BUILTIN_NAMES.join(", "),
                    zoo::names().collect::<Vec<_>>().join(", ")
                ),
            })
        }
    };
    scene.validate()?;
    Ok(scene)
}

/// The `spline` and `spline-tight` scene assembly (meshes from [`spline_mesh`], trees,
/// script).
pub mod spline_scene;

/// Loads a mesh file (OBJ, STL, PLY) through the mesh crate's validated loader.
pub fn load_mesh_file(path: &Path) -> Result<TriMesh, mesh::MeshError> {
    mesh::load_mesh(path).map(|m| m.mesh)
}

/// Smallest gap (mm) between the tool at `q` and the objects, with pairs searched up to
/// `margin` (mm); `+inf` when nothing is within the margin. Offline helper for building
/// scripts.
pub fn min_gap(
    tool: &PackedTree,
    objects: &[PackedTree],
    q: &Pose,
    margin: f64,
    ws: &mut CollideWorkspace,
) -> f64 {
    let mut g = f64::INFINITY;
    let _ = overlap_tree_trees(tool, q, objects, margin, ws, |p| g = g.min(p.gap));
    g
}

/// Distance (mm) the tool can travel from `from` along the unit direction `dir` before it
/// touches an object (bisection on the leaf-level gap), or `None` if it never does within
/// `max_mm`.
pub fn distance_to_contact(
    scene: &Scene,
    from: &Pose,
    dir: [f64; 3],
    max_mm: f64,
) -> Result<Option<f64>, SceneError> {
    let bad = |e: collide::CollideError| SceneError::caused(&scene.name, "unusable tree", e);
    let tool = PackedTree::new(&scene.tool).map_err(bad)?;
    let objects = scene
        .objects
        .iter()
        .map(|(t, p)| PackedTree::with_pose(t, p))
        .collect::<Result<Vec<_>, _>>()
        .map_err(bad)?;
    let mut ws = CollideWorkspace::for_trees(&tool, &objects);
    let at = |s: f64| {
        let mut q = *from;
        for k in 0..3 {
            q.q[k] += dir[k] * s;
        }
        q
    };
    let mut lo = 0.0;
    if min_gap(&tool, &objects, &at(lo), 0.0, &mut ws) <= 0.0 {
        return Ok(Some(0.0));
    }
    // March in steps no larger than the current gap estimate, then bisect.
    let step = 1.0;
    let mut hi = None;
    let mut s = 0.0;
    while s < max_mm {
        s = (s + step).min(max_mm);
        if min_gap(&tool, &objects, &at(s), 0.0, &mut ws) <= 0.0 {
            hi = Some(s);
            break;
        }
        lo = s;
    }
    let Some(mut hi) = hi else { return Ok(None) };
    for _ in 0..50 {
        let mid = 0.5 * (lo + hi);
        if min_gap(&tool, &objects, &at(mid), 0.0, &mut ws) <= 0.0 {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    Ok(Some(lo))
}
