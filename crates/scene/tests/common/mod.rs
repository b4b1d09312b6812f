//! Shared helpers of the scene integration tests.
#![allow(dead_code)]

use std::path::PathBuf;

use scene::cache::TreeCache;

/// A tree cache shared by the tests of one checkout (target dir), so trees are built once.
pub fn test_cache() -> TreeCache {
    let dir = std::env::var_os("HAPTIC6D_CACHE")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            PathBuf::from(env!("CARGO_MANIFEST_DIR"))
                .join("..")
                .join("..")
                .join("target")
                .join("haptic6d-test-cache")
        });
    TreeCache::at(dir)
}

/// Steps the scene's god-object (its friction applied) through its device motion: every
/// frame's output.
pub fn replay(scene: &scene::Scene) -> Vec<engine::step::FrameOutput> {
    let traj = scene.trajectory();
    let mut god = scene.god_object().unwrap();
    god.reset(&collide::Pose::from_array(traj.samples[0].q))
        .unwrap();
    traj.samples
        .iter()
        .map(|s| god.step(&collide::Pose::from_array(s.q)))
        .collect()
}

/// The deepest overlap of the scene's tool with its objects at a pose, measured here (leaf
/// pairs at margin 0), not by the engine: `overlap(q)` in mm, 0 when free.
pub fn overlap_of(scene: &scene::Scene) -> impl FnMut(&collide::Pose) -> f64 {
    let (tool, objects) = packed(scene);
    let mut ws = collide::CollideWorkspace::for_trees(&tool, &objects);
    move |q| (-scene::scenes::min_gap(&tool, &objects, q, 0.0, &mut ws)).max(0.0)
}

/// The scene's tool and objects packed as the engine packs them (objects placed, with their
/// face caps).
pub fn packed(scene: &scene::Scene) -> (collide::PackedTree, Vec<collide::PackedTree>) {
    let tool = collide::PackedTree::new(&scene.tool).unwrap();
    let objects = scene
        .objects
        .iter()
        .map(|(t, p)| collide::PackedTree::with_pose(t, p).unwrap())
        .collect();
    (tool, objects)
}

/// An error and its sources on one line, `a: b: c`, as the command line prints them.
pub fn chain(e: &dyn std::error::Error) -> String {
    scene::error_chain(e)
}
