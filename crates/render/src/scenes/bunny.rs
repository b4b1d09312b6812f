//! The `bunny` scene: a bunny tool against a bunny object, depth-4 trees (4681 slots each),
//! both scaled to ~100 mm (factor 10 on the Stanford bunny shipped in `assets/bunny.obj`,
//! public domain), centred on their bounding boxes; `+y` is up.
//!
//! Scripted device motion (1 kHz): approach from above, touch, slide on the object's back with
//! a light press (a small contact), come back, push deep into the object (a large contact: the
//! graphic tool is held at the surface while the hand goes ~15 mm in), withdraw.

use collide::Pose;
use mesh::TriMesh;

use crate::cache::TreeCache;
use crate::safety::SafetyParams;
use crate::scene::{Coupling, Motion, Scene, SolverSpec, TreeParams};
use crate::trajectory::{Ease, Script};
use crate::RenderError;

/// The bundled bunny (OBJ text, mesh units ~ cm).
pub const BUNNY_OBJ: &str = include_str!("../../assets/bunny.obj");

/// Scale from the bundled file's units to mm.
pub const BUNNY_SCALE: f64 = 10.0;

/// The bundled bunny in mm, centred on its bounding box.
pub fn bunny_mesh_mm() -> Result<TriMesh, RenderError> {
    let raw = mesh::load_mesh_bytes(BUNNY_OBJ.as_bytes(), std::path::Path::new("bunny.obj"))
        .map_err(|e| RenderError::Scene {
            file: "bunny (assets/bunny.obj)".into(),
            msg: e.to_string(),
        })?
        .mesh;
    let (lo, hi) = raw.aabb().ok_or_else(|| RenderError::Scene {
        file: "bunny".into(),
        msg: "empty mesh".into(),
    })?;
    let c = [
        0.5 * (lo[0] + hi[0]),
        0.5 * (lo[1] + hi[1]),
        0.5 * (lo[2] + hi[2]),
    ];
    Ok(raw.scaled_about(c, BUNNY_SCALE))
}

/// The `bunny` scene with its scripted trajectory.
pub fn scene(cache: &TreeCache) -> Result<Scene, RenderError> {
    let mesh = bunny_mesh_mm()?;
    let mut log = Vec::new();
    let params = TreeParams {
        depth: 4,
        branching: 8,
        octree: false,
    };
    let tree = crate::scene::tree_for_mesh(&mesh, params, cache, "bunny", &mut log)?;
    let start = Pose::from_array([0.0, 140.0, 0.0, 0.0, 0.0, 0.0]);
    let mut scene = Scene {
        name: "bunny".into(),
        tool: tree.clone(),
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
        load_log: log,
    };
    let d = crate::scenes::distance_to_contact(&scene, &start, [0.0, -1.0, 0.0], 200.0)?
        .ok_or_else(|| RenderError::Scene {
            file: "bunny".into(),
            msg: "the tool never reaches the object on the way down".into(),
        })?;
    let yc = start.q[1] - d;
    let at = |x: f64, y: f64, z: f64, g: f64| [x, y, z, g, 0.0, 0.0];
    let script = Script::starting_at(start.to_array())
        .then(0.5, at(0.0, yc + 0.5, 0.0, 0.0), Ease::Smooth)
        .then(0.3, at(0.0, yc - 1.0, 0.0, 0.0), Ease::Smooth)
        .then(1.0, at(12.0, yc - 1.0, 0.0, 0.0), Ease::Smooth)
        .then(1.0, at(-12.0, yc - 1.0, 4.0, 0.0), Ease::Smooth)
        .then(0.6, at(0.0, yc - 1.0, 0.0, 0.0), Ease::Smooth)
        .then(0.8, at(0.0, yc - 12.0, 0.0, 0.15), Ease::Smooth)
        .hold(0.3)
        .then(0.8, start.to_array(), Ease::Smooth);
    scene.motion = Motion::Script(script);
    Ok(scene)
}
