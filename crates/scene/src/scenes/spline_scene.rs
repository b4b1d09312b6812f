//! The `spline` scene: a splined shaft (tool) inserted into a hub with the matching splined
//! hole (object), both procedurally generated closed meshes ([`crate::scenes::spline_mesh`]).
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

/// The `spline` scene with trees of the given depth (5 for the built-in).
pub fn scene(cache: &TreeCache, p: &SplineParams, depth: u32) -> Result<Scene, SceneError> {
    let shaft = p.shaft_mesh();
    let hub = p.hub_mesh();
    let mut log = Vec::new();
    let params = TreeParams {
        depth,
        branching: 8,
        method: spheretree::build::BuildMethod::Tight,
    };
    let tool = crate::tree_for_mesh(&shaft, params, cache, "spline shaft", &mut log)?;
    let hub_tree = crate::object_tree_for_mesh(&hub, params, cache, "spline hub", &mut log)?;
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
        name: "spline".into(),
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
            tol_mm: 0.5,
        }),
        device: Default::default(),
        load_log: log,
        object_friction: Vec::new(),
        tool_friction: None,
    })
}
