//! The `bunny` scene: a bunny tool against a bunny object, depth-4 trees (4681 slots each),
//! both scaled to ~100 mm (factor 10 on the Stanford bunny shipped in `assets/bunny.obj`,
//! public domain), centred on their bounding boxes; `+y` is up.
//!
//! Scripted device motion (1 kHz, ~9 s): the tool approaches from above, touches the object's
//! back and slides on it with a light press ([`SLIDE_PRESS_MM`]: a small contact, < 50 pairs);
//! it withdraws, goes round through free space to below the object while turning upside down,
//! approaches from below and pushes [`PUSH_MM`] past the first contact: flat base on flat base,
//! a large contact (> 100 pairs, ~10 N; the graphic tool stays on the surface while the hand
//! goes in); then it withdraws.

use collide::Pose;
use mesh::TriMesh;

use crate::cache::TreeCache;
use crate::trajectory::{Ease, Script};
use crate::SceneError;
use crate::{Coupling, Motion, Scene, SolverSpec, TreeParams};
use engine::safety::SafetyParams;

/// The bundled bunny (OBJ text, mesh units ~ cm).
pub const BUNNY_OBJ: &str = include_str!("../../assets/bunny.obj");

/// How far the hand presses past the first contact while sliding on top, mm.
pub const SLIDE_PRESS_MM: f64 = 1.0;

/// Lateral offset of the way round the object (free space), mm.
pub const AROUND_MM: f64 = 160.0;

/// Start and end of the slide phase in the script, s.
pub const SLIDE_PHASE_S: (f64, f64) = (0.8, 3.4);

/// Start and end of the held deep push in the script, s (the last 0.2 s of the push + hold).
pub const PUSH_PHASE_S: (f64, f64) = (7.3, 7.8);

/// How far the hand goes past the first contact in the push, mm.
pub const PUSH_MM: f64 = 12.8;

/// Scale from the bundled file's units to mm.
pub const BUNNY_SCALE: f64 = 10.0;

/// The bundled bunny in mm, centred on its bounding box.
pub fn bunny_mesh_mm() -> Result<TriMesh, SceneError> {
    let raw = mesh::load_mesh_bytes(BUNNY_OBJ.as_bytes(), std::path::Path::new("bunny.obj"))
        .map_err(|e| SceneError::caused("bunny (assets/bunny.obj)", "cannot load the mesh", e))?
        .mesh;
    let (lo, hi) = raw
        .aabb()
        .ok_or_else(|| SceneError::scene("bunny", "empty mesh"))?;
    let c = [
        0.5 * (lo[0] + hi[0]),
        0.5 * (lo[1] + hi[1]),
        0.5 * (lo[2] + hi[2]),
    ];
    Ok(raw.scaled_about(c, BUNNY_SCALE))
}

/// The `bunny` scene with its scripted trajectory.
pub fn scene(cache: &TreeCache) -> Result<Scene, SceneError> {
    let mesh = bunny_mesh_mm()?;
    let mut log = Vec::new();
    let params = TreeParams {
        depth: 4,
        branching: 8,
        method: spheretree::build::BuildMethod::Tight,
    };
    // One build for both: the object keeps the face caps, the tool's copy drops them.
    let tree = crate::object_tree_for_mesh(&mesh, params, cache, "bunny", &mut log)?;
    let mut tool_tree = tree.clone();
    tool_tree
        .set_caps(Vec::new())
        .map_err(|e| SceneError::caused("bunny", "cannot drop the tool's face caps", e))?;
    // Slide on top: the tool upright above the object. Push from below: the tool upside down
    // (gamma = pi) under the object, flat base against flat base.
    let level = std::f64::consts::PI;
    let start = Pose::from_array([0.0, 140.0, 0.0, 0.0, 0.0, 0.0]);
    let below = Pose::from_array([0.0, -140.0, 0.0, level, 0.0, 0.0]);
    let mut scene = Scene {
        name: "bunny".into(),
        tool: tool_tree,
        tool_mesh: Some(mesh.clone()),
        objects: vec![(tree, Pose::identity())],
        object_meshes: vec![Some(mesh)],
        coupling: Coupling::default(),
        solver: SolverSpec::default(),
        safety: SafetyParams::default(),
        start,
        rate_hz: 1000.0,
        motion: Motion::Hold,
        goal: None,
        device: Default::default(),
        load_log: log,
        object_friction: Vec::new(),
        tool_friction: None,
    };
    let contact = |from: &Pose, dir: [f64; 3]| {
        crate::scenes::distance_to_contact(&scene, from, dir, 200.0)?
            .ok_or_else(|| SceneError::scene("bunny", "the tool never reaches the object"))
    };
    let y_top = start.q[1] - contact(&start, [0.0, -1.0, 0.0])?;
    let y_bottom = below.q[1] + contact(&below, [0.0, 1.0, 0.0])?;
    let at = |x: f64, y: f64, z: f64, g: f64| [x, y, z, g, 0.0, 0.0];
    let script = Script::starting_at(start.to_array())
        // Approach from above to 0.5 mm short of contact, press 1 mm in.
        .then(0.5, at(0.0, y_top + 0.5, 0.0, 0.0), Ease::Smooth)
        .then(0.3, at(0.0, y_top - SLIDE_PRESS_MM, 0.0, 0.0), Ease::Smooth)
        // Slide on the object's back (small contact).
        .then(1.0, at(8.0, y_top - SLIDE_PRESS_MM, 2.0, 0.0), Ease::Smooth)
        .then(
            1.0,
            at(-8.0, y_top - SLIDE_PRESS_MM, -2.0, 0.0),
            Ease::Smooth,
        )
        .then(0.6, at(0.0, y_top - SLIDE_PRESS_MM, 0.0, 0.0), Ease::Smooth)
        // Withdraw and go round (free space) to below the object, turning the tool over.
        .then(0.5, start.to_array(), Ease::Smooth)
        .then(0.5, at(AROUND_MM, start.q[1], 0.0, 0.0), Ease::Smooth)
        .then(1.0, at(AROUND_MM, below.q[1], 0.0, level), Ease::Smooth)
        .then(0.5, below.to_array(), Ease::Smooth)
        // Approach from below, then push PUSH_MM past the first contact: base on base.
        .then(0.8, at(0.0, y_bottom - 0.5, 0.0, level), Ease::Smooth)
        .then(0.8, at(0.0, y_bottom + PUSH_MM, 0.0, level), Ease::Smooth)
        .hold(0.3)
        // Withdraw.
        .then(0.8, below.to_array(), Ease::Smooth);
    scene.motion = Motion::Script(script);
    Ok(scene)
}
