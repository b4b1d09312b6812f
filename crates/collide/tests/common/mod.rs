//! Shared test helpers: a random valid sphere-tree generator and a brute-force reference.
#![allow(dead_code)]

use collide::Pose;
use nalgebra::{Point3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use spheretree::{slot_count, Sphere, SphereTree};

/// Shape of a random tree.
#[derive(Clone, Copy, Debug)]
pub struct TreeShape {
    pub levels: u32,
    pub branching: u32,
    /// Half-extent of the root's box (mm).
    pub extent: f64,
    /// Probability that a child slot of an internal node is used.
    pub p_used: f64,
    /// Probability that a used node above the last level has no used child (an early leaf).
    pub p_early_leaf: f64,
}

/// The dense trees the shared-traversal, probe and neighbour-list tests use: 4 levels of 8,
/// 50 mm across, nine slots in ten used.
pub fn dense_shape() -> TreeShape {
    TreeShape {
        levels: 4,
        branching: 8,
        extent: 50.0,
        p_used: 0.9,
        p_early_leaf: 0.02,
    }
}

/// A leaf pair as a comparable key: object, tool slot, object slot and the gap's bits.
pub type PairKey = (u32, u32, u32, u64);

/// The [`PairKey`] of `p`.
pub fn pair_key(p: &collide::LeafPair) -> PairKey {
    (p.object, p.tool_slot, p.object_slot, p.gap.to_bits())
}

/// The plain traversal's pairs of `tool` at `pose` (along `sweep` if given) within `margin`
/// (mm), as keys in the traversal's order: the reference the other queries are checked against.
pub fn traversal_keys(
    tool: &collide::PackedTree,
    pose: &Pose,
    sweep: Option<&collide::Sweep>,
    objects: &[collide::PackedTree],
    margin: f64,
    ws: &mut collide::CollideWorkspace,
) -> Vec<PairKey> {
    let mut keys = Vec::new();
    let keep = |p: &collide::LeafPair| keys.push(pair_key(p));
    match sweep {
        None => collide::overlap_tree_trees(tool, pose, objects, margin, ws, keep),
        Some(s) => collide::overlap_swept(tool, pose, s, objects, margin, ws, keep),
    }
    .unwrap();
    keys
}

/// A random valid tree: spatially coherent centres (children near their parent), leaves with
/// random radii, each parent the enclosing sphere of its children (around its own centre) plus
/// random slack; unused slots hold garbage (random centres, negative radii of any size).
pub fn random_tree(seed: u64, shape: TreeShape) -> SphereTree {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (levels, b) = (shape.levels, shape.branching);
    let n = slot_count(levels, b).unwrap();
    let mut used = vec![false; n];
    let mut centers = vec![[0.0f64; 3]; n];
    let mut level_of = vec![0u32; n];
    let tree0 = SphereTree::new_unused(levels, b).unwrap();
    for l in 0..levels {
        for s in tree0.level_range(l) {
            level_of[s] = l;
        }
    }
    used[0] = true;
    for v in centers[0].iter_mut() {
        *v = rng.random_range(-0.25..0.25) * shape.extent;
    }
    for s in 0..n {
        if !used[s] {
            continue;
        }
        let kids = tree0.children(s);
        if kids.is_empty() || rng.random_bool(shape.p_early_leaf) {
            continue;
        }
        let half = shape.extent / 2f64.powi(level_of[s] as i32 + 1);
        let mut any = false;
        for c in kids.clone() {
            if rng.random_bool(shape.p_used) {
                used[c] = true;
                any = true;
            }
        }
        if !any {
            let c = rng.random_range(kids.clone());
            used[c] = true;
        }
        for c in kids {
            if used[c] {
                let parent = centers[s];
                for (v, pv) in centers[c].iter_mut().zip(parent) {
                    *v = pv + rng.random_range(-half..half);
                }
            }
        }
    }
    let mut spheres = vec![Sphere::UNUSED; n];
    for s in (0..n).rev() {
        if !used[s] {
            let c = [
                rng.random_range(-1.0..1.0) * shape.extent,
                rng.random_range(-1.0..1.0) * shape.extent,
                rng.random_range(-1.0..1.0) * shape.extent,
            ];
            spheres[s] = Sphere::new(c, -rng.random_range(1e-3..10.0 * shape.extent));
            continue;
        }
        let kids: Vec<usize> = tree0.children(s).filter(|&c| used[c]).collect();
        let r = if kids.is_empty() {
            rng.random_range(0.3..1.0) * shape.extent / 2f64.powi(level_of[s] as i32 + 1)
        } else {
            let mut r: f64 = 0.0;
            for &c in &kids {
                let d = dist(&centers[c], &centers[s]);
                r = r.max(d + spheres[c].radius);
            }
            r * (1.0 + rng.random_range(0.0..0.1))
        };
        spheres[s] = Sphere::new(centers[s], r);
    }
    let t = SphereTree::from_slots(levels, b, spheres).unwrap();
    t.validate(1e-9).unwrap();
    t
}

pub fn dist(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// World position of a tree-frame point through nalgebra's isometry (an independent path from
/// the crate's rotation matrix).
pub fn to_world(pose: &Pose, p: &[f64; 3]) -> [f64; 3] {
    let w = pose.to_isometry() * Point3::from(Vector3::from(*p));
    [w.x, w.y, w.z]
}

/// Brute force: every (tool leaf slot, object leaf slot, gap) over all leaf pairs.
pub fn brute_force_gaps(
    tool: &SphereTree,
    world_from_tool: &Pose,
    object: &SphereTree,
    world_from_object: &Pose,
) -> Vec<(u32, u32, f64)> {
    let obj: Vec<(usize, [f64; 3], f64)> = object
        .leaves()
        .map(|s| {
            let sp = object.sphere(s);
            (s, to_world(world_from_object, &sp.center), sp.radius)
        })
        .collect();
    let mut out = Vec::new();
    for t in tool.leaves() {
        let sp = tool.sphere(t);
        let c = to_world(world_from_tool, &sp.center);
        for &(o, oc, or) in &obj {
            out.push((t as u32, o as u32, dist(&c, &oc) - sp.radius - or));
        }
    }
    out
}

/// A random pose for the dense trees' tests: the tool origin at `x` in `[x_lo, x_hi]` mm and
/// `y`, `z` within `across` mm of the axis, each rotation-vector component within 0.3 rad
/// (the draws in that order).
pub fn random_pose(rng: &mut devkit::Rng, x: [f64; 2], across: f64) -> Pose {
    Pose::from_array([
        rng.range(x[0], x[1]),
        rng.range(-across, across),
        rng.range(-across, across),
        rng.range(-0.3, 0.3),
        rng.range(-0.3, 0.3),
        rng.range(-0.3, 0.3),
    ])
}
