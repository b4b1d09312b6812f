//! The `spline` scene: a splined shaft (tool) inserted into a hub with the matching splined
//! hole (object), both procedurally generated closed meshes ([`crate::scenes::spline_mesh`]).
//! The `spline-tight` scene is the same at 0.1 mm clearance
//! ([`crate::scenes::spline_scene::TIGHT_CLEARANCE_MM`]) instead of 1 mm, on the parts' own
//! triangles ([`engine::Geometry::Mesh`]): at that clearance the leaf spheres' overhang fills
//! the gap and the shaft would jam at the mouth.
//!
//! Scripted device motion (1 kHz): approach with the keys misaligned by half a pitch, come to
//! rest on the hub's top face (hand 2 mm below it: ~2 N axial), rotate until the keys align
//! (the shaft drops in: the axial force vanishes), insert to the target depth, withdraw.

use collide::Pose;

use crate::cache::TreeCache;
use crate::trajectory::{Ease, Script};
use crate::SceneError;
use crate::{Coupling, Goal, Motion, Scene, SolverSpec, TreeParams};
use engine::safety::SafetyParams;

use super::spline_mesh::SplineParams;

/// Depth of the shaft tip below the hub's top face at the end of the insertion, mm.
pub const INSERT_DEPTH_MM: f64 = 20.0;

/// How far below the hub face the hand presses while the keys are misaligned, mm.
pub const PRESS_MM: f64 = 2.0;

/// Radial and lateral clearance of the `spline-tight` scene, mm (a sliding fit of a splined
/// shaft).
pub const TIGHT_CLEARANCE_MM: f64 = 0.1;

/// The `spline-tight` insertion counts as complete with the shaft's tip within this of
/// [`INSERT_DEPTH_MM`], mm (the `spline` scene allows 0.5 mm).
pub const TIGHT_GOAL_TOL_MM: f64 = 0.1;

/// Tree depth of both built-in spline scenes.
pub const TREE_DEPTH: u32 = 5;

/// The shaft and hub of `spline-tight`: the `spline` scene's at [`TIGHT_CLEARANCE_MM`].
pub fn tight_params() -> SplineParams {
    SplineParams {
        clearance: TIGHT_CLEARANCE_MM,
        ..SplineParams::default()
    }
}

/// The `spline` scene with trees of the given depth ([`TREE_DEPTH`] for the built-in).
pub fn scene(cache: &TreeCache, p: &SplineParams, depth: u32) -> Result<Scene, SceneError> {
    assemble("spline", cache, p, depth, 0.5)
}

/// The `spline-tight` scene: the `spline` scene's parts at [`TIGHT_CLEARANCE_MM`] and its
/// script, in the mesh geometry mode, with the goal within [`TIGHT_GOAL_TOL_MM`].
pub fn tight_scene(cache: &TreeCache) -> Result<Scene, SceneError> {
    let mut scene = assemble(
        "spline-tight",
        cache,
        &tight_params(),
        TREE_DEPTH,
        TIGHT_GOAL_TOL_MM,
    )?;
    scene.solver.geometry = engine::Geometry::Mesh;
    Ok(scene)
}

/// A spline scene named `name` of the parts `p`, trees of `depth`, the goal within `tol_mm`
/// (mm) of [`INSERT_DEPTH_MM`]; a scene file's solver settings.
fn assemble(
    name: &str,
    cache: &TreeCache,
    p: &SplineParams,
    depth: u32,
    tol_mm: f64,
) -> Result<Scene, SceneError> {
    let shaft = p.shaft_mesh();
    let hub = p.hub_mesh();
    let mut log = Vec::new();
    let params = TreeParams {
        depth,
        branching: 8,
        method: spheretree::build::BuildMethod::Tight,
    };
    let tool = crate::tree_for_mesh(&shaft, params, cache, &format!("{name} shaft"), &mut log)?;
    let hub_tree =
        crate::object_tree_for_mesh(&hub, params, cache, &format!("{name} hub"), &mut log)?;
    let misaligned = 0.5 * p.pitch();
    let above = 15.0;
    let start = [0.0, 0.0, above, 0.0, 0.0, misaligned];
    let at = |z: f64, alpha: f64| [0.0, 0.0, z, 0.0, 0.0, alpha];
    let script = Script::starting_at(start)
        .then(0.5, at(-PRESS_MM, misaligned), Ease::Smooth)
        .hold(0.2)
        .then(1.2, at(-PRESS_MM, 0.0), Ease::Smooth)
        .hold(0.2)
        .then(1.0, at(-INSERT_DEPTH_MM, 0.0), Ease::Smooth)
        .hold(0.2)
        .then(0.8, at(above, 0.0), Ease::Smooth);
    Ok(Scene {
        name: name.into(),
        tool,
        tool_mesh: Some(shaft),
        objects: vec![(hub_tree, Pose::identity())],
        object_meshes: vec![Some(hub)],
        coupling: Coupling::default(),
        solver: SolverSpec::default(),
        safety: SafetyParams::default(),
        start: Pose::from_array(start),
        rate_hz: 1000.0,
        motion: Motion::Script(script),
        goal: Some(Goal::InsertZ {
            target_z_mm: -INSERT_DEPTH_MM,
            tol_mm,
        }),
        device: Default::default(),
        load_log: log,
        object_friction: Vec::new(),
        tool_friction: None,
    })
}
