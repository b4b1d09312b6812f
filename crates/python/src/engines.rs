//! Engines made from a scene (built-in or TOML file, as `haptic6d run` loads it) or from trees
//! given one by one, with keyword settings on top ([`EngineOptions`]).

use std::path::Path;

use collide::Pose;
use engine::Engine;
use mesh::TriMesh;
use scene::cache::TreeCache;
use scene::trajectory::Trajectory;
use scene::{load_scene_file, Scene};
use spheretree::SphereTree;

use crate::options::{check_pose, EngineOptions, Settings};
use crate::{Failure, FailureKind};

/// An engine and what the door keeps beside it.
pub struct Made {
    /// The engine, reset at the start pose (or a free pose near it).
    pub engine: Engine,
    /// Its settings and frame rate.
    pub settings: Settings,
    /// The scene name or `trees`, for messages.
    pub label: String,
    /// The scene's device trajectory (scenes only).
    pub trajectory: Option<Trajectory>,
    /// How each tree was obtained (one line each).
    pub load_log: Vec<String>,
}

/// A built-in scene by name, or a scene file by path, as `haptic6d run` takes it (same
/// messages); trees from `cache`.
pub fn load_scene(name: &str, cache: &TreeCache) -> Result<Scene, Failure> {
    if scene::scenes::is_builtin(name) {
        return Ok(scene::scenes::builtin(name, cache)?);
    }
    let path = Path::new(name);
    if !path.exists() {
        if scene::scenes::is_builtin_family(name) {
            return Ok(scene::scenes::builtin(name, cache)?);
        }
        return Err(Failure::file(scene::scenes::no_such_scene(name)));
    }
    Ok(load_scene_file(path, cache)?)
}

/// Wraps an engine error under `label`, as a scene's engine errors read.
fn engine_error(label: &str, source: engine::EngineError) -> Failure {
    Failure::from(scene::SceneError::Engine {
        file: label.to_string(),
        source,
    })
}

/// The engine of `scene` with `options` over the scene's own settings; a refused keyword is
/// named as `haptic6d run` names its flags (`budget_us = 0: must be ...`).
pub fn from_scene(scene: Scene, options: &EngineOptions) -> Result<Made, Failure> {
    let settings = options.apply(scene.engine_config(), scene.rate_hz)?;
    // The scene's meshes go with its trees, so that `[solver] geometry = "mesh"` holds here
    // as it does in `haptic6d run`.
    let (tool_mesh, object_meshes) = scene.mesh_refs();
    let mut engine = Engine::with_meshes(
        &scene.tool,
        tool_mesh,
        &scene.objects,
        &object_meshes,
        settings.config,
    )
    .map_err(|e| engine_error(&scene.name, e))?;
    let mut load_log = scene.load_log.clone();
    note_geometry(&engine, &settings, &mut load_log);
    scene.apply_friction(&mut engine).map_err(Failure::from)?;
    engine
        .reset(&scene.start)
        .map_err(|e| engine_error(&scene.name, e))?;
    Ok(Made {
        engine,
        settings,
        trajectory: Some(scene.trajectory()),
        load_log,
        label: scene.name,
    })
}

/// Says in the load log when the mesh geometry was asked for and the leaf spheres are used
/// (a body without its mesh: a `Tree` or a `.sph` file), as `haptic6d run` says it.
fn note_geometry(engine: &Engine, settings: &Settings, log: &mut Vec<String>) {
    if settings.config.geometry == engine::Geometry::Mesh
        && engine.geometry() != engine::Geometry::Mesh
    {
        log.push(
            "geometry: mesh asked, but a body has no mesh (a Tree or a .sph file): the leaf spheres are used"
                .into(),
        );
    }
}

/// The engine of `tool` against `objects` (trees in mm, each object with its fixed pose, and
/// the meshes they were built from where known, for the mesh geometry mode), with `options`
/// over [`engine::EngineConfig::default`] at 1 kHz, reset at `start`.
pub fn from_trees(
    (tool, tool_mesh): (&SphereTree, Option<&TriMesh>),
    objects: &[(SphereTree, Pose)],
    object_meshes: &[Option<TriMesh>],
    start: [f64; 6],
    options: &EngineOptions,
    mut load_log: Vec<String>,
) -> Result<Made, Failure> {
    let settings = options.apply(engine::EngineConfig::default(), 1000.0)?;
    if objects.is_empty() {
        return Err(Failure::value(
            "objects: no object given; pass at least one tree, .sph file or mesh",
        ));
    }
    for (i, (_, pose)) in objects.iter().enumerate() {
        check_pose(&format!("objects[{i}] pose"), &pose.to_array())?;
    }
    check_pose("start", &start)?;
    fn as_ref(m: &TriMesh) -> engine::MeshRef<'_> {
        engine::MeshRef {
            vertices: &m.vertices,
            triangles: &m.triangles,
        }
    }
    let meshes: Vec<Option<engine::MeshRef<'_>>> = object_meshes
        .iter()
        .map(|m| m.as_ref().map(as_ref))
        .collect();
    let mut engine = Engine::with_meshes(
        tool,
        tool_mesh.map(as_ref),
        objects,
        &meshes,
        settings.config,
    )
    .map_err(|e| Failure::chain(FailureKind::Value, &e))?;
    note_geometry(&engine, &settings, &mut load_log);
    engine
        .reset(&Pose::from_array(start))
        .map_err(|e| Failure::chain(FailureKind::Value, &e))?;
    Ok(Made {
        engine,
        settings,
        label: "trees".into(),
        trajectory: None,
        load_log,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_scene_that_asks_for_the_mesh_geometry_gets_it() {
        let cache = TreeCache::disabled();
        for (asked, got) in [
            (engine::Geometry::Spheres, engine::Geometry::Spheres),
            (engine::Geometry::Mesh, engine::Geometry::Mesh),
        ] {
            let mut scene = scene::scenes::builtin("zoo/cube-edge", &cache).unwrap();
            scene.solver.geometry = asked;
            let made = from_scene(scene, &EngineOptions::default()).unwrap();
            assert_eq!(made.engine.geometry(), got);
        }
    }

    #[test]
    fn an_unknown_scene_is_a_file_error_naming_the_built_in_ones() {
        let e = load_scene("nothere.toml", &TreeCache::disabled())
            .err()
            .unwrap();
        assert_eq!(e.kind, FailureKind::File);
        assert_eq!(
            e.message,
            "no built-in scene or scene file named `nothere.toml` (built-in: bunny, spline, plate, spline-tight, probe, zoo/..., fit/...; files end in .toml)"
        );
    }

    #[test]
    fn a_malformed_scene_file_is_a_value_error_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("bad.toml");
        std::fs::write(&p, "[tool\n").unwrap();
        let e = load_scene(p.to_str().unwrap(), &TreeCache::disabled())
            .err()
            .unwrap();
        assert_eq!(e.kind, FailureKind::Value);
        assert!(
            e.message.starts_with(&p.display().to_string()),
            "{}",
            e.message
        );
        assert!(!e.message.contains('\n'));
    }

    #[test]
    fn trees_need_an_object_and_finite_poses() {
        use spheretree::Sphere;
        let tool = SphereTree::from_slots(1, 2, vec![Sphere::new([0.0; 3], 5.0)]).unwrap();
        let object = SphereTree::from_slots(1, 2, vec![Sphere::new([0.0; 3], 20.0)]).unwrap();
        let o = EngineOptions::default();
        let e = from_trees((&tool, None), &[], &[], [0.0; 6], &o, vec![])
            .err()
            .unwrap();
        assert!(e.message.starts_with("objects: no object"), "{}", e.message);
        let mut start = [0.0, 0.0, 40.0, 0.0, 0.0, 0.0];
        start[3] = f64::NAN;
        let objs = [(object, Pose::identity())];
        let e = from_trees((&tool, None), &objs, &[None], start, &o, vec![])
            .err()
            .unwrap();
        assert!(e.message.starts_with("start = "), "{}", e.message);
        let made = from_trees(
            (&tool, None),
            &objs,
            &[None],
            [0.0, 0.0, 40.0, 0.0, 0.0, 0.0],
            &o,
            vec![],
        );
        assert!(made.is_ok());
    }
}
