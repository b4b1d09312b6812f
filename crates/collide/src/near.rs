//! Which part of the tool is near the objects: the box (tool frame) of the leaf centres of the
//! tool's nodes that come within a margin of some object node.
//!
//! A tool turning about its origin moves each leaf centre by at most the angle times its
//! distance from the axis, so a bound over *all* leaves is set by the farthest one (a shaft's
//! far end, 50 mm from a contact at its tip). Only leaves near an object can touch after a
//! small motion: with the box of those leaves' centres, a region's motion bound is the turn
//! times their lever arm, and the rest of the tool need only stay within the wider margin.

use crate::{PackedTree, Pose};

/// Entries of the fixed descent stacks: a descent holds at most (levels × children) nodes
/// (6 × 8 for the trees here); a fuller stack ends the descent on the safe side (near).
const STACK: usize = 128;

/// The box (tool frame, mm: lowest and highest corner) holding the centre of every tool leaf
/// whose sphere is within `margin` (mm) of an object's leaf sphere with the tool at
/// `world_from_tool`, or `None` when no tool leaf is.
///
/// The descent stops at tool level `tool_level` and object level `object_level` (0 = the root;
/// a leaf above them stops there): a tool node within `margin` of an object node at that level
/// counts as near whole, its leaves' box taken from [`PackedTree::leaf_box`]. Parents contain
/// their children, so a leaf outside the box is farther than `margin` from every object leaf
/// (the answer is conservative: it may hold leaves that are not near, never misses one).
///
/// At most `max_tests` sphere tests are made: past them every tool leaf not yet decided
/// counts as near (the answer is then the box of the whole tool).
///
/// # Real-time
/// No allocation, no panic; at most `max_tests` sphere tests (~3 ns each).
pub fn near_box(
    tool: &PackedTree,
    world_from_tool: &Pose,
    objects: &[PackedTree],
    margin: f64,
    tool_level: u32,
    object_level: u32,
    max_tests: usize,
) -> Option<([f64; 3], [f64; 3])> {
    if tool.is_empty() {
        return None;
    }
    let rot = world_from_tool.rotation_matrix();
    let t = world_from_tool.translation();
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    let mut any = false;
    let mut take = |n: usize| {
        let (c, h) = tool.leaf_box(n);
        for k in 0..3 {
            lo[k] = lo[k].min(c[k] - h[k]);
            hi[k] = hi[k].max(c[k] + h[k]);
        }
        any = true;
    };
    let mut stack = [(0u32, 0u32); STACK];
    let mut len = 1;
    let mut tests = 0;
    while len > 0 {
        len -= 1;
        let (n, level) = stack[len];
        let n = n as usize;
        if tests > max_tests {
            // Out of tests: the whole tool is near (its root's box holds every leaf).
            take(0);
            break;
        }
        let p = rot * nalgebra::Vector3::from(tool.center(n)) + t;
        if !objects.iter().any(|o| {
            object_near(
                o,
                &p.into(),
                tool.radius(n),
                margin,
                object_level,
                &mut tests,
            )
        }) {
            continue;
        }
        let children = tool.children(n);
        if children.is_empty() || level >= tool_level || len + children.len() > STACK {
            take(n);
            continue;
        }
        for c in children {
            stack[len] = (c as u32, level + 1);
            len += 1;
        }
    }
    any.then_some((lo, hi))
}

/// True when the sphere (`center` world, `radius`, mm) is within `margin` of some node of
/// `object` at `level` (or a leaf above it), or the descent's stack runs full (the safe side).
/// Counts its sphere tests in `tests`.
fn object_near(
    object: &PackedTree,
    center: &[f64; 3],
    radius: f64,
    margin: f64,
    level: u32,
    tests: &mut usize,
) -> bool {
    if object.is_empty() {
        return false;
    }
    let gap = |n: usize| {
        let o = object.center(n);
        let d =
            ((center[0] - o[0]).powi(2) + (center[1] - o[1]).powi(2) + (center[2] - o[2]).powi(2))
                .sqrt();
        d - radius - object.radius(n)
    };
    let mut stack = [(0u32, 0u32); STACK];
    let mut len = 1;
    while len > 0 {
        len -= 1;
        let (n, at) = stack[len];
        let n = n as usize;
        *tests += 1;
        // `!(gap <= margin)`: a NaN gap counts as near.
        if gap(n) > margin {
            continue;
        }
        let children = object.children(n);
        if children.is_empty() || at >= level || len + children.len() > STACK {
            return true;
        }
        for c in children {
            stack[len] = (c as u32, at + 1);
            len += 1;
        }
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use spheretree::{Sphere, SphereTree};

    /// A binary tree of 32 leaf spheres of radius `r` along the segment from `a` to `b`
    /// (parents at their children's mean, grown to contain them).
    fn rod(a: [f64; 3], b: [f64; 3], r: f64) -> SphereTree {
        let mut t = SphereTree::new_unused(6, 2).unwrap();
        let leaves = t.level_range(5);
        let n = leaves.len();
        for (i, s) in leaves.enumerate() {
            let f = (i as f64 + 0.5) / n as f64;
            let c = [0, 1, 2].map(|k| a[k] + f * (b[k] - a[k]));
            t.spheres_mut()[s] = Sphere::new(c, r);
        }
        for level in (0..5).rev() {
            for s in t.level_range(level) {
                let kids = t.children(s);
                let m = kids.len() as f64;
                let c =
                    [0, 1, 2].map(|k| kids.clone().map(|j| t.sphere(j).center[k]).sum::<f64>() / m);
                t.spheres_mut()[s] = Sphere::new(c, 0.0);
            }
        }
        t.enforce_containment();
        t
    }

    /// Brute force: the exact box of the centres of tool leaves within `margin` of an object
    /// leaf.
    fn brute(tool: &PackedTree, q: &Pose, objects: &[PackedTree], margin: f64) -> Vec<[f64; 3]> {
        let mut near = Vec::new();
        for tl in tool.leaves() {
            let c = tool.center(tl);
            let p = q.transform_point(&c);
            for o in objects {
                for ol in o.leaves() {
                    let oc = o.center(ol);
                    let d = (0..3).map(|k| (p[k] - oc[k]).powi(2)).sum::<f64>().sqrt();
                    if d - tool.radius(tl) - o.radius(ol) <= margin {
                        near.push(c);
                    }
                }
            }
        }
        near
    }

    #[test]
    fn the_box_holds_every_leaf_near_an_object_at_every_level() {
        let tool = PackedTree::new(&rod([0.0, 0.0, 0.0], [0.0, 0.0, 40.0], 1.0)).unwrap();
        let plate = PackedTree::new(&rod([-20.0, 0.0, -1.0], [20.0, 0.0, -1.0], 1.0)).unwrap();
        let objects = [plate];
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let mut strict = 0;
        for _ in 0..300 {
            let q = Pose::from_array([
                rng.random_range(-3.0..3.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(0.0..3.0),
                rng.random_range(-0.6..0.6),
                rng.random_range(-0.6..0.6),
                rng.random_range(-3.0..3.0),
            ]);
            let margin = rng.random_range(0.0..2.0);
            let want = brute(&tool, &q, &objects, margin);
            for (tl, ol) in [(0, 0), (1, 3), (4, 1), (5, 5), (9, 9)] {
                let got = near_box(&tool, &q, &objects, margin, tl, ol, usize::MAX);
                match got {
                    None => assert!(want.is_empty(), "a near leaf was missed"),
                    Some((lo, hi)) => {
                        for c in &want {
                            for k in 0..3 {
                                assert!(lo[k] <= c[k] && c[k] <= hi[k], "{c:?} outside");
                            }
                        }
                        if tl >= 5 && ol >= 5 && !want.is_empty() {
                            // At the leaves the box is the near leaves' spheres' box.
                            let top = want.iter().map(|c| c[2]).fold(f64::MIN, f64::max);
                            assert!(hi[2] <= top + 1.0 + 1e-9);
                            strict += 1;
                        }
                    }
                }
            }
        }
        assert!(strict > 50, "too few poses near the plate: {strict}");
        // Out of tests, the whole tool is near.
        let q = Pose::from_array([0.0, 0.0, 0.5, 0.0, 0.0, 0.0]);
        let (lo, hi) = near_box(&tool, &q, &objects, 1.0, 5, 5, 3).unwrap();
        let (c, h) = tool.leaf_box(0);
        assert_eq!((lo[2], hi[2]), (c[2] - h[2], c[2] + h[2]));
    }
}
