//! Traversal equals brute force on random trees and poses; unused slots never produce pairs;
//! several objects; no allocation per query.

mod common;

use std::collections::HashSet;

use collide::{
    collect_pairs, overlap_swept, overlap_tree_tree, rotation_exp, CollideWorkspace, LeafPair,
    PackedTree, Pose, Sweep,
};
use common::{brute_force_gaps, random_tree, TreeShape};
use proptest::prelude::*;
use spheretree::{Sphere, SphereTree};

const EXTENT: f64 = 50.0;
/// Rounding band around the margin (mm) where the two computations may disagree.
const TIE: f64 = 1e-9;

/// Checks that `found` (pairs of object `obj_id`) is exactly the brute-force set: every pair
/// with gap < margin - TIE found once, every found pair has gap <= margin + TIE, its geometry is
/// right and its slots are leaves.
fn check_against_brute_force(
    tool: &SphereTree,
    world_from_tool: &Pose,
    object: &SphereTree,
    world_from_object: &Pose,
    margin: f64,
    obj_id: u32,
    found: &[LeafPair],
) {
    let brute = brute_force_gaps(tool, world_from_tool, object, world_from_object);
    let gaps: std::collections::HashMap<(u32, u32), f64> =
        brute.iter().map(|&(t, o, g)| ((t, o), g)).collect();
    let mut seen = HashSet::new();
    for p in found.iter().filter(|p| p.object == obj_id) {
        assert!(
            seen.insert((p.tool_slot, p.object_slot)),
            "duplicate pair {p:?}"
        );
        assert!(
            tool.is_leaf(p.tool_slot as usize),
            "tool slot not a leaf: {p:?}"
        );
        assert!(
            object.is_leaf(p.object_slot as usize),
            "object slot not a leaf: {p:?}"
        );
        let g = gaps[&(p.tool_slot, p.object_slot)];
        assert!(
            g <= margin + TIE,
            "reported pair has gap {g} > margin {margin}: {p:?}"
        );
        assert!((g - p.gap).abs() < 1e-9, "gap {} vs brute force {g}", p.gap);
        let ts = tool.sphere(p.tool_slot as usize);
        assert_eq!(p.p_in_tool, ts.center);
        assert_eq!(p.r_tool, ts.radius);
        assert_eq!(p.r_object, object.sphere(p.object_slot as usize).radius);
        let o = common::to_world(
            world_from_object,
            &object.sphere(p.object_slot as usize).center,
        );
        assert!(common::dist(&o, &p.o_in_world) < 1e-9);
    }
    for &(t, o, g) in &brute {
        if g < margin - TIE {
            assert!(
                seen.contains(&(t, o)),
                "missed pair ({t}, {o}) with gap {g}, margin {margin}"
            );
        }
    }
}

fn shape(levels: u32, branching: u32, p_used: f64, p_early_leaf: f64) -> TreeShape {
    TreeShape {
        levels,
        branching,
        extent: EXTENT,
        p_used,
        p_early_leaf,
    }
}

fn pose_strategy(reach: f64) -> impl Strategy<Value = Pose> {
    (
        -reach..reach,
        -reach..reach,
        -reach..reach,
        -3.2f64..3.2,
        -1.6f64..1.6,
        -3.2f64..3.2,
    )
        .prop_map(|(x, y, z, g, b, a)| Pose::from_array([x, y, z, g, b, a]))
}

/// How to place the tool near contact: orientation (three Euler angles, rad), which tool leaf
/// and which object leaf to bring together (fractions of the leaf lists), and the offset
/// between their centres (a direction and a fraction of the sum of their radii).
#[derive(Clone, Copy, Debug)]
struct NearContact {
    angles: [f64; 3],
    tool_leaf: f64,
    object_leaf: f64,
    direction: [f64; 3],
    depth: f64,
}

fn near_contact_strategy() -> impl Strategy<Value = NearContact> {
    (
        (-3.2f64..3.2, -1.6f64..1.6, -3.2f64..3.2),
        0.0f64..1.0,
        0.0f64..1.0,
        proptest::array::uniform3(-1.0f64..1.0),
        0.0f64..0.95,
    )
        .prop_map(
            |((g, b, a), tool_leaf, object_leaf, direction, depth)| NearContact {
                angles: [g, b, a],
                tool_leaf,
                object_leaf,
                direction,
                depth,
            },
        )
}

/// The tool pose that puts the chosen tool leaf's centre at `depth * (r_t + r_o)` from the
/// chosen object leaf's centre (object at `world_from_object`): those two leaves overlap, so
/// at least one pair is in contact, and their neighbours are near it.
fn pose_near_contact(
    tool: &SphereTree,
    object: &SphereTree,
    world_from_object: &Pose,
    c: &NearContact,
) -> Pose {
    let pick = |t: &SphereTree, f: f64| {
        let leaves: Vec<usize> = t.leaves().collect();
        leaves[((f * leaves.len() as f64) as usize).min(leaves.len() - 1)]
    };
    let (lt, lo) = (pick(tool, c.tool_leaf), pick(object, c.object_leaf));
    let (st, so) = (tool.sphere(lt), object.sphere(lo));
    let n = common::dist(&c.direction, &[0.0; 3]);
    let u = if n > 1e-6 {
        c.direction.map(|v| v / n)
    } else {
        [1.0, 0.0, 0.0]
    };
    let d = c.depth * (st.radius + so.radius);
    let o = common::to_world(world_from_object, &so.center);
    let target = [o[0] + d * u[0], o[1] + d * u[1], o[2] + d * u[2]];
    let [g, b, a] = c.angles;
    let rotated = Pose::from_array([0.0, 0.0, 0.0, g, b, a]).transform_point(&st.center);
    Pose::from_array([
        target[0] - rotated[0],
        target[1] - rotated[1],
        target[2] - rotated[2],
        g,
        b,
        a,
    ])
}

/// `tree` with every used centre moved by up to `amount` mm per axis (seeded), parents then
/// grown to contain their children again: a different tree of the same layout.
fn jittered(tree: &SphereTree, seed: u64, amount: f64) -> SphereTree {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0x7177);
    let mut t = tree.clone();
    for s in t.spheres_mut().iter_mut().filter(|s| s.is_used()) {
        for c in &mut s.center {
            *c += rng.random_range(-amount..amount);
        }
    }
    t.enforce_containment();
    t
}

/// Brute-force pairs in contact within `margin` (the ones the traversal must report).
fn brute_force_count(
    tool: &SphereTree,
    world_from_tool: &Pose,
    object: &SphereTree,
    world_from_object: &Pose,
    margin: f64,
) -> usize {
    brute_force_gaps(tool, world_from_tool, object, world_from_object)
        .iter()
        .filter(|&&(_, _, g)| g < margin - TIE)
        .count()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, ..ProptestConfig::default() })]

    /// Poses near contact (a chosen pair of leaves overlaps), so no case compares two empty
    /// sets.
    #[test]
    fn traversal_equals_brute_force(
        seed_t in any::<u64>(),
        seed_o in any::<u64>(),
        levels_t in 1u32..=4,
        levels_o in 1u32..=4,
        b_t in 2u32..=8,
        b_o in 2u32..=8,
        p_used in 0.3f64..1.0,
        p_early in 0.0f64..0.3,
        contact in near_contact_strategy(),
        margin in prop_oneof![Just(0.0), 0.0f64..10.0],
    ) {
        let tool = random_tree(seed_t, shape(levels_t, b_t, p_used, p_early));
        let object = random_tree(seed_o, shape(levels_o, b_o, p_used, p_early));
        let pose = pose_near_contact(&tool, &object, &Pose::identity(), &contact);
        let in_contact = brute_force_count(&tool, &pose, &object, &Pose::identity(), margin);
        prop_assert!(in_contact >= 1, "the case has no pair in contact: {pose:?}");
        let pt = PackedTree::new(&tool).unwrap();
        let po = PackedTree::new(&object).unwrap();
        let mut ws = CollideWorkspace::new();
        let mut found = Vec::new();
        let n = overlap_tree_tree(&pt, &pose, &po, margin, &mut ws, |p| found.push(*p)).unwrap();
        prop_assert_eq!(n, found.len());
        prop_assert!(n >= in_contact);
        check_against_brute_force(&tool, &pose, &object, &Pose::identity(), margin, 0, &found);
    }

    /// Far from the origin (tens of metres, where `f32` keeps ~4 µm), with the margin a hair
    /// above the gap of one of the pairs: the traversal's single-precision pruning loses no
    /// pair at the threshold, plain or swept (a zero sweep is the plain query).
    #[test]
    fn far_from_the_origin_the_threshold_pairs_are_found(
        seed_t in any::<u64>(),
        seed_o in any::<u64>(),
        contact in near_contact_strategy(),
        offset in proptest::array::uniform3(-5e4f64..5e4),
        pick in 0.0f64..1.0,
    ) {
        let tool = random_tree(seed_t, shape(3, 8, 0.9, 0.1));
        let object = random_tree(seed_o, shape(3, 8, 0.9, 0.1));
        let world_from_object = Pose::from_array([offset[0], offset[1], offset[2], 0.3, -0.2, 0.1]);
        let pose = pose_near_contact(&tool, &object, &world_from_object, &contact);
        let mut gaps: Vec<f64> = brute_force_gaps(&tool, &pose, &object, &world_from_object)
            .iter()
            .map(|g| g.2)
            .filter(|g| (0.0..5.0).contains(g))
            .collect();
        prop_assume!(!gaps.is_empty());
        gaps.sort_by(f64::total_cmp);
        // A hair above one pair's gap: f64 decides it in, f32 (errors ~1e-3 mm here) must not
        // prune it.
        let at = gaps[((gaps.len() - 1) as f64 * pick) as usize];
        let margin = at + 1e-6;
        let pt = PackedTree::new(&tool).unwrap();
        let po = PackedTree::with_pose(&object, &world_from_object).unwrap();
        let mut ws = CollideWorkspace::new();
        let mut found = Vec::new();
        overlap_tree_tree(&pt, &pose, &po, margin, &mut ws, |p| found.push(*p)).unwrap();
        // The pair at the threshold itself (gap == margin) must be there too.
        let at_threshold = found.iter().filter(|p| (p.gap - at).abs() < 1e-7).count();
        prop_assert!(at_threshold >= 1, "the pair at gap {at} was pruned");
        check_against_brute_force(&tool, &pose, &object, &world_from_object, margin, 0, &found);
        let mut swept = Vec::new();
        overlap_swept(&pt, &pose, &Sweep::default(), std::slice::from_ref(&po), margin, &mut ws, |p| {
            swept.push(*p)
        })
        .unwrap();
        prop_assert_eq!(found, swept);
    }

    /// Dense contact: a bushy depth-3 tree (512 leaves) nearly superposed on itself or on a
    /// jittered copy, so hundreds of leaf pairs (measured: 1200–2200) are in contact at once.
    #[test]
    fn dense_contacts_equal_brute_force(
        seed in any::<u64>(),
        same_tree in any::<bool>(),
        shift in proptest::array::uniform3(-1.0f64..1.0),
        turn in proptest::array::uniform3(-0.02f64..0.02),
        margin in prop_oneof![Just(0.0), 0.0f64..2.0],
    ) {
        let tool = random_tree(seed, shape(4, 8, 1.0, 0.0));
        let object = if same_tree { tool.clone() } else { jittered(&tool, seed, 1.0) };
        let pose = Pose::from_array([shift[0], shift[1], shift[2], turn[0], turn[1], turn[2]]);
        let in_contact = brute_force_count(&tool, &pose, &object, &Pose::identity(), margin);
        prop_assert!(in_contact >= 500, "only {in_contact} pairs in contact: not a dense case");
        let pt = PackedTree::new(&tool).unwrap();
        let po = PackedTree::new(&object).unwrap();
        let mut ws = CollideWorkspace::new();
        let mut found = Vec::new();
        let n = overlap_tree_tree(&pt, &pose, &po, margin, &mut ws, |p| found.push(*p)).unwrap();
        prop_assert_eq!(n, found.len());
        check_against_brute_force(&tool, &pose, &object, &Pose::identity(), margin, 0, &found);
    }

    #[test]
    fn several_objects_equal_brute_force(
        seeds in proptest::array::uniform4(any::<u64>()),
        contact in near_contact_strategy(),
        which in 0usize..3,
        object_poses in proptest::array::uniform3(pose_strategy(EXTENT)),
        margin in 0.0f64..5.0,
    ) {
        let tool = random_tree(seeds[0], shape(4, 4, 0.7, 0.1));
        let objects: Vec<SphereTree> =
            (1..4).map(|i| random_tree(seeds[i], shape(3, 8, 0.6, 0.1))).collect();
        // Near contact with one object; the others where they fall.
        let pose = pose_near_contact(&tool, &objects[which], &object_poses[which], &contact);
        let in_contact: usize = objects
            .iter()
            .zip(&object_poses)
            .map(|(o, p)| brute_force_count(&tool, &pose, o, p, margin))
            .sum();
        prop_assert!(in_contact >= 1, "the case has no pair in contact");
        let pt = PackedTree::new(&tool).unwrap();
        let packed: Vec<PackedTree> = objects
            .iter()
            .zip(&object_poses)
            .map(|(o, p)| PackedTree::with_pose(o, p).unwrap())
            .collect();
        let mut ws = CollideWorkspace::for_trees(&pt, &packed);
        let mut found = Vec::new();
        let n = collect_pairs(&pt, &pose, &packed, margin, &mut ws, &mut found).unwrap();
        prop_assert_eq!(n, found.len());
        for (i, (o, p)) in objects.iter().zip(&object_poses).enumerate() {
            check_against_brute_force(&tool, &pose, o, p, margin, i as u32, &found);
        }
        // The same query object by object gives the same pairs.
        let mut one_by_one = 0;
        for po in &packed {
            one_by_one += overlap_tree_tree(&pt, &pose, po, margin, &mut ws, |_| {}).unwrap();
        }
        prop_assert_eq!(one_by_one, n);
    }
}

/// A fixed dense case: a bushy tree against itself, slightly moved, has hundreds of pairs in
/// contact, and the traversal finds exactly the brute-force set.
#[test]
fn hundreds_of_pairs_equal_brute_force() {
    let tree = random_tree(2024, shape(4, 8, 1.0, 0.0));
    let pose = Pose::from_array([0.4, -0.3, 0.2, 0.01, -0.01, 0.015]);
    let in_contact = brute_force_count(&tree, &pose, &tree, &Pose::identity(), 0.0);
    assert!(in_contact >= 400, "{in_contact} pairs: not dense");
    let p = PackedTree::new(&tree).unwrap();
    let mut ws = CollideWorkspace::new();
    let mut found = Vec::new();
    let n = overlap_tree_tree(&p, &pose, &p, 0.0, &mut ws, |q| found.push(*q)).unwrap();
    assert_eq!(n, found.len());
    check_against_brute_force(&tree, &pose, &tree, &Pose::identity(), 0.0, 0, &found);
}

/// Unused slots sitting right on the other tree, with radii of any negative size, and used
/// slots beneath nothing, never produce pairs; an early leaf (level 1) does.
#[test]
fn unused_slots_never_produce_pairs() {
    let mut t = SphereTree::new_unused(3, 2).unwrap();
    {
        let s = t.spheres_mut();
        s[0] = Sphere::new([0.0, 0.0, 0.0], 10.0);
        s[1] = Sphere::new([-5.0, 0.0, 0.0], 5.0); // early leaf: children 3, 4 unused
        s[2] = Sphere::new([5.0, 0.0, 0.0], 5.0);
        s[3] = Sphere::new([-5.0, 0.0, 0.0], -1e6); // unused, huge negative radius
        s[4] = Sphere::new([0.0, 0.0, 0.0], -0.0001);
        s[5] = Sphere::new([3.0, 0.0, 0.0], 2.0);
        s[6] = Sphere::new([0.0, 0.0, 0.0], -5.0); // unused inside everything
    }
    t.validate(1e-12).unwrap();
    assert!(t.is_leaf(1) && !t.is_leaf(2) && t.is_leaf(5));
    let p = PackedTree::new(&t).unwrap();
    assert_eq!(p.len(), 4);
    assert_eq!(p.leaf_count(), 2);
    let mut ws = CollideWorkspace::new();
    let mut found = Vec::new();
    // Identity pose: every used sphere overlaps every other; only leaves 1 and 5 pair up.
    let n = overlap_tree_tree(&p, &Pose::identity(), &p, 1.0, &mut ws, |q| {
        found.push((q.tool_slot, q.object_slot))
    })
    .unwrap();
    found.sort();
    assert_eq!(n, 4);
    assert_eq!(found, vec![(1, 1), (1, 5), (5, 1), (5, 5)]);
}

#[test]
fn separated_trees_give_no_pairs_and_margin_brings_them_in() {
    let tree = random_tree(7, shape(4, 8, 0.8, 0.0));
    let p = PackedTree::new(&tree).unwrap();
    let root_r = tree.sphere(0).radius;
    let far = Pose::from_array([2.0 * root_r + 1.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
    let mut ws = CollideWorkspace::for_trees(&p, std::slice::from_ref(&p));
    assert_eq!(
        overlap_tree_tree(&p, &far, &p, 0.0, &mut ws, |_| {}).unwrap(),
        0
    );
    let n = overlap_tree_tree(&p, &far, &p, 2.0 * root_r, &mut ws, |_| {}).unwrap();
    assert!(n > 0);
}

#[test]
fn non_finite_pose_is_an_error() {
    let tree = random_tree(3, shape(2, 4, 1.0, 0.0));
    let p = PackedTree::new(&tree).unwrap();
    let mut ws = CollideWorkspace::new();
    let bad = Pose::from_array([f64::NAN, 0.0, 0.0, 0.0, 0.0, 0.0]);
    assert!(overlap_tree_tree(&p, &bad, &p, 0.0, &mut ws, |_| {}).is_err());
}

#[test]
fn tree_breaking_containment_is_rejected_until_enforced() {
    let mut t = SphereTree::new_unused(2, 2).unwrap();
    t.spheres_mut()[0] = Sphere::new([0.0; 3], 1.0);
    t.spheres_mut()[1] = Sphere::new([0.5, 0.0, 0.0], 0.7);
    let err = PackedTree::new(&t).unwrap_err().to_string();
    assert!(err.contains("enforce_containment"), "{err}");
    t.enforce_containment();
    PackedTree::new(&t).unwrap();
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// Every point of the tool moves at most `sweep_margin` along the segment, and a pair that
    /// touches somewhere on the segment is found at `q_h` with that margin.
    #[test]
    fn sweep_margin_bounds_motion_along_the_segment(
        seed in any::<u64>(),
        q_prev in pose_strategy(EXTENT),
        dq in proptest::array::uniform6(-0.5f64..0.5),
    ) {
        let tool = random_tree(seed, shape(3, 8, 0.7, 0.1));
        let pt = PackedTree::new(&tool).unwrap();
        let mut q_h = q_prev;
        for (k, d) in dq.iter().enumerate() {
            q_h.q[k] += d * if k < 3 { 20.0 } else { 1.0 };
        }
        let margin = pt.sweep_margin(&q_prev, &q_h);
        let object = random_tree(seed ^ 0x5eed, shape(3, 8, 0.7, 0.1));
        let po = PackedTree::new(&object).unwrap();
        let mut ws = CollideWorkspace::new();
        let mut found = HashSet::new();
        overlap_tree_tree(&pt, &q_h, &po, margin, &mut ws, |p| {
            found.insert((p.tool_slot, p.object_slot));
        })
        .unwrap();
        for i in 0..=20 {
            let s = i as f64 / 20.0;
            let q = Pose { q: q_prev.q + (q_h.q - q_prev.q) * s };
            for leaf in tool.leaves() {
                let p = tool.sphere(leaf).center;
                let moved = common::dist(&q.transform_point(&p), &q_h.transform_point(&p));
                prop_assert!(moved <= margin * (1.0 + 1e-12) + 1e-9, "{moved} > {margin}");
            }
            for (t, o, g) in brute_force_gaps(&tool, &q, &object, &Pose::identity()) {
                if g <= 0.0 {
                    prop_assert!(found.contains(&(t, o)), "pair ({t}, {o}) touches at s = {s} but was not found");
                }
            }
        }
    }
}

/// The pose of `sweep` at `s` in `[0, 1]`: translation `t + s v`, rotation `exp(s [w]x) R`.
fn pose_along(q: &Pose, sweep: &Sweep, s: f64) -> Pose {
    let v = nalgebra::Vector3::from(sweep.translation);
    let w = nalgebra::Vector3::from(sweep.rotation);
    Pose::from_translation_rotation(
        &(q.translation() + v * s),
        &(rotation_exp(&(w * s)) * q.rotation_matrix()),
    )
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// The swept query finds every pair that comes within the margin anywhere along the motion
    /// (sampled at 41 poses; half the sweeps pure translations), reports each pair's true gap at the start pose, and lists no pair
    /// that stays farther from the path than its stated slack (the capsule's growth `|w| r_t`,
    /// the arc's allowance `reach (e^|w| - 1 - |w|)` and the tangent's departure from the arc,
    /// as much again, and the sampling step).
    #[test]
    fn swept_query_covers_the_path_and_nothing_far_from_it(
        seed_t in any::<u64>(),
        seed_o in any::<u64>(),
        levels in 2u32..=4,
        contact in near_contact_strategy(),
        v in proptest::array::uniform3(-8.0f64..8.0),
        // Half the sweeps are pure translations (the capsule test's own path).
        w in prop_oneof![Just([0.0; 3]), proptest::array::uniform3(-0.2f64..0.2)],
        margin in prop_oneof![Just(0.0), 0.0f64..2.0],
    ) {
        let tool = random_tree(seed_t, shape(levels, 6, 0.8, 0.1));
        let object = random_tree(seed_o, shape(levels, 6, 0.8, 0.1));
        let pose = pose_near_contact(&tool, &object, &Pose::identity(), &contact);
        let sweep = Sweep { translation: v, rotation: w };
        let pt = PackedTree::new(&tool).unwrap();
        let objects = [PackedTree::new(&object).unwrap()];
        let mut ws = CollideWorkspace::new();
        let mut found = Vec::new();
        let n = overlap_swept(&pt, &pose, &sweep, &objects, margin, &mut ws, |p| found.push(*p)).unwrap();
        prop_assert_eq!(n, found.len());
        let at_start: std::collections::HashMap<(u32, u32), f64> =
            brute_force_gaps(&tool, &pose, &object, &Pose::identity())
                .into_iter()
                .map(|(t, o, g)| ((t, o), g))
                .collect();
        // Closest approach of every pair over the sampled path.
        let samples = 40;
        let mut closest: std::collections::HashMap<(u32, u32), f64> = Default::default();
        for i in 0..=samples {
            let q = pose_along(&pose, &sweep, f64::from(i) / f64::from(samples));
            for (t, o, g) in brute_force_gaps(&tool, &q, &object, &Pose::identity()) {
                let e = closest.entry((t, o)).or_insert(f64::INFINITY);
                *e = e.min(g);
            }
        }
        let set: HashSet<(u32, u32)> = found.iter().map(|p| (p.tool_slot, p.object_slot)).collect();
        prop_assert_eq!(set.len(), found.len(), "duplicate pairs");
        for (&(t, o), &g) in &closest {
            if g <= margin - TIE {
                prop_assert!(set.contains(&(t, o)), "pair ({t}, {o}) comes within {g} <= {margin} on the way but was not found");
            }
        }
        let turn = sweep.angle();
        let path_step = (v.iter().map(|x| x * x).sum::<f64>().sqrt() + turn * pt.reach())
            / f64::from(samples);
        for p in &found {
            prop_assert!((p.gap - at_start[&(p.tool_slot, p.object_slot)]).abs() < 1e-9);
            // The query raises the margin by the arc's allowance, and tests the centre's tangent
            // segment, which strays from the arc by up to as much again.
            let arc = pt.reach() * (turn.exp_m1() - turn);
            let slack = margin + 2.0 * turn * p.r_tool + 2.0 * arc + path_step + 1e-9;
            let g = closest[&(p.tool_slot, p.object_slot)];
            prop_assert!(g <= slack, "listed pair ({}, {}) stays {g} mm away (slack {slack})", p.tool_slot, p.object_slot);
        }
    }

    /// With no motion the swept query is the plain query: the same pairs.
    #[test]
    fn swept_query_without_motion_is_the_plain_query(
        seed in any::<u64>(),
        contact in near_contact_strategy(),
        margin in 0.0f64..3.0,
    ) {
        let tool = random_tree(seed, shape(3, 6, 0.8, 0.1));
        let object = random_tree(seed ^ 0xab, shape(3, 6, 0.8, 0.1));
        let pose = pose_near_contact(&tool, &object, &Pose::identity(), &contact);
        let pt = PackedTree::new(&tool).unwrap();
        let objects = [PackedTree::new(&object).unwrap()];
        let mut ws = CollideWorkspace::new();
        let mut plain = Vec::new();
        collide::overlap_tree_trees(&pt, &pose, &objects, margin, &mut ws, |p| plain.push(*p)).unwrap();
        let mut swept = Vec::new();
        overlap_swept(&pt, &pose, &Sweep::default(), &objects, margin, &mut ws, |p| swept.push(*p)).unwrap();
        prop_assert_eq!(plain, swept);
    }
}

/// A traversal with a deadline that never comes lists what the plain (and swept) traversal
/// lists; one stopped early says so and lists a subset; the "any pair" question agrees or
/// answers `None`.
#[test]
fn a_traversal_with_a_deadline_is_the_traversal_or_says_it_stopped() {
    let tree = random_tree(2024, shape(4, 8, 1.0, 0.0));
    let object = jittered(&tree, 7, 1.0);
    let pt = PackedTree::new(&tree).unwrap();
    let objects = [PackedTree::new(&object).unwrap()];
    let mut ws = CollideWorkspace::new();
    let ids = |v: &mut Vec<(u32, u32, u32)>| {
        v.sort();
        v.clone()
    };
    for (k, pose) in [
        Pose::from_array([0.4, -0.3, 0.2, 0.01, -0.01, 0.015]),
        Pose::from_array([30.0, 5.0, -3.0, 0.3, 0.2, 0.1]),
        Pose::from_array([200.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
    ]
    .iter()
    .enumerate()
    {
        let sweep = Sweep {
            translation: [1.0, -0.5, 0.2],
            rotation: [0.0, 0.01, 0.02],
        };
        for sw in [None, Some(&sweep)] {
            let mut plain = Vec::new();
            match sw {
                None => collide::overlap_tree_trees(&pt, pose, &objects, 0.3, &mut ws, |p| {
                    plain.push((p.object, p.tool_slot, p.object_slot))
                }),
                Some(s) => overlap_swept(&pt, pose, s, &objects, 0.3, &mut ws, |p| {
                    plain.push((p.object, p.tool_slot, p.object_slot))
                }),
            }
            .unwrap();
            // The deadline traversal, never stopped or stopped at its first check.
            let mut until = |go_on: bool| {
                let mut found = Vec::new();
                let t = collide::overlap_until(
                    &pt,
                    pose,
                    sw,
                    &objects,
                    0.3,
                    &mut ws,
                    |p| found.push((p.object, p.tool_slot, p.object_slot)),
                    || go_on,
                )
                .unwrap();
                (t, found)
            };
            let (t, mut all) = until(true);
            assert!(t.complete && t.pairs == all.len());
            assert_eq!(ids(&mut all), ids(&mut plain), "pose {k}");
            let (t, mut some) = until(false);
            if !t.complete {
                assert!(some.len() < plain.len() || plain.is_empty(), "pose {k}");
            } else {
                assert_eq!(ids(&mut some), ids(&mut plain), "pose {k}");
            }
            assert!(some.iter().all(|p| plain.contains(p)));
        }
        let any = collide::any_pair_within(&pt, pose, &objects, 0.3, &mut ws).unwrap();
        let until =
            collide::any_pair_within_until(&pt, pose, &objects, 0.3, &mut ws, || true).unwrap();
        assert_eq!(until, Some(any), "pose {k}");
        let stopped =
            collide::any_pair_within_until(&pt, pose, &objects, 0.3, &mut ws, || false).unwrap();
        assert!(stopped.is_none() || stopped == Some(any), "pose {k}");
    }
    // The dense pose needs more than one slice, so the early stop is exercised.
    let pose = Pose::from_array([0.4, -0.3, 0.2, 0.01, -0.01, 0.015]);
    let t =
        collide::overlap_until(&pt, &pose, None, &objects, 0.3, &mut ws, |_| {}, || false).unwrap();
    assert!(!t.complete, "{t:?}");
}
