//! Face cuts: an object leaf with a [`spheretree::FaceCap`] stands for its sphere cut by the
//! face's half-space. Checked against an independent brute force, against the exact distance
//! to the cut leaf (safe and complete), for flatness (no sphere bumps), through neighbour
//! lists, and its constraint rows against finite differences; slab regions (a thin margin for
//! half-space pairs) against a traversal at every pose the slab allows.

mod common;

use collide::{
    overlap_shared, overlap_tree_trees, pair_constraint_value, CollideWorkspace, ConstraintForm,
    FaceSlab, LeafPair, Linearization, ListStatus, NeighbourList, PackedTree, Pose,
    RotationCoordinates, StandIn,
};
use common::{dist, random_tree, to_world, TreeShape};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use spheretree::{FaceCap, Sphere, SphereTree};

/// Half-width of the square plate's top face (mm).
const HALF: f64 = 8.0;
/// Grid of leaves on the face: `GRID` x `GRID`, spacing `2 HALF / GRID`.
const GRID: usize = 16;

/// A plate's top face as a 3-level tree (root, 16 blocks of 4x4, 256 leaves) in its own frame:
/// leaves on a grid over `[-HALF, HALF]^2`, centres a little above or below the face `z = 0`
/// (so some spheres bulge far above it), radii enough to cover the face; every leaf capped by
/// `z <= 0` with its reach to the face's edge. `seed` varies the centres and radii.
fn capped_plate(seed: u64) -> SphereTree {
    plate(seed, false)
}

/// [`capped_plate`], with the blocks and the root capped too when `inner` (every leaf under
/// them is below the face, so their face may stand for their subtree).
fn plate(seed: u64, inner: bool) -> SphereTree {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let spacing = 2.0 * HALF / GRID as f64;
    let mut tree = SphereTree::new_unused(3, 16).unwrap();
    let mut caps = vec![Vec::new(); tree.len()];
    let mut blocks = Vec::new();
    for block in 0..16usize {
        let (bi, bj) = (block % 4, block / 4);
        let mut members = Vec::new();
        for k in 0..16usize {
            let (i, j) = (bi * 4 + k % 4, bj * 4 + k / 4);
            let x = -HALF + spacing * (i as f64 + 0.5);
            let y = -HALF + spacing * (j as f64 + 0.5);
            let z = rng.random_range(-0.3..0.3) * spacing;
            let r = spacing * rng.random_range(0.75..1.0);
            let slot = 1 + 16 + block * 16 + k;
            let foot_to_edge = (HALF - x.abs()).min(HALF - y.abs());
            caps[slot] = vec![FaceCap {
                normal: [0.0, 0.0, 1.0],
                offset: 0.0,
                center: [x, y, 0.0],
                reach: foot_to_edge,
            }];
            members.push((slot, [x, y, z], r));
        }
        let s = enclosing(&members.iter().map(|m| (m.1, m.2)).collect::<Vec<_>>());
        tree.spheres_mut()[1 + block] = s;
        if inner {
            caps[1 + block] = vec![FaceCap {
                normal: [0.0, 0.0, 1.0],
                offset: 0.0,
                center: [s.center[0], s.center[1], 0.0],
                reach: (HALF - s.center[0].abs()).min(HALF - s.center[1].abs()),
            }];
        }
        blocks.push((s.center, s.radius));
        for (slot, c, r) in members {
            tree.spheres_mut()[slot] = Sphere::new(c, r);
        }
    }
    tree.spheres_mut()[0] = enclosing(&blocks);
    if inner {
        let c = tree.sphere(0).center;
        caps[0] = vec![FaceCap {
            normal: [0.0, 0.0, 1.0],
            offset: 0.0,
            center: [c[0], c[1], 0.0],
            reach: (HALF - c[0].abs()).min(HALF - c[1].abs()),
        }];
    }
    tree.set_caps(caps).unwrap();
    tree
}

/// A sphere around the mean of `spheres` enclosing them all.
fn enclosing(spheres: &[([f64; 3], f64)]) -> Sphere {
    let n = spheres.len() as f64;
    let c: [f64; 3] = std::array::from_fn(|k| spheres.iter().map(|s| s.0[k]).sum::<f64>() / n);
    let r = spheres
        .iter()
        .map(|s| dist(&c, &s.0) + s.1)
        .fold(0.0, f64::max);
    Sphere::new(c, r * (1.0 + 1e-12))
}

/// The plate's fixed pose: tilted and moved, so the cuts must follow it.
fn plate_pose() -> Pose {
    Pose::from_array([3.0, -2.0, 1.0, 0.3, -0.2, 0.7])
}

/// A point `(u, v, h)` in the plate's frame (on the face for `h = 0`) in the world.
fn on_plate(u: f64, v: f64, h: f64) -> [f64; 3] {
    to_world(&plate_pose(), &[u, v, h])
}

/// The world face of the plate: unit normal and offset.
fn world_face() -> ([f64; 3], f64) {
    let o = on_plate(0.0, 0.0, 0.0);
    let z = on_plate(0.0, 0.0, 1.0);
    let n = [z[0] - o[0], z[1] - o[1], z[2] - o[2]];
    (n, n[0] * o[0] + n[1] * o[1] + n[2] * o[2])
}

fn dot(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The reference rule, written from the definition: the pair passes the sphere test; above the
/// face (within the leaf's reach) it stands for the half-space; else, where the face's plane
/// crosses the leaf's ball, for the lens (the ball cut by the plane, its distance from
/// [`distance_to_cut_leaf`]); either is kept only within the margin; else the sphere.
/// Each entry: tool and object slots, gap, the stand-in.
fn reference_pairs(
    tool: &SphereTree,
    q: &Pose,
    plate: &SphereTree,
    margin: f64,
) -> Vec<(u32, u32, f64, Stand)> {
    let (n, d) = world_face();
    let mut out = Vec::new();
    for t in tool.leaves() {
        let ts = tool.sphere(t);
        let w = to_world(q, &ts.center);
        for o in plate.leaves() {
            let os = plate.sphere(o);
            let c = to_world(&plate_pose(), &os.center);
            let centre_gap = dist(&w, &c) - ts.radius - os.radius;
            if centre_gap > margin {
                continue;
            }
            let cap = plate.cap(o)[0];
            let height = dot(&n, &w) - d;
            let x = [w[0] - c[0], w[1] - c[1], w[2] - c[2]];
            let lateral2 = dot(&x, &x) - dot(&n, &x).powi(2);
            if height >= 0.0 && lateral2 <= cap.reach * cap.reach {
                let gap = height - ts.radius;
                if gap <= margin {
                    out.push((t as u32, o as u32, gap, Stand::HalfSpace));
                }
            } else if (dot(&n, &c) - d).abs() < os.radius {
                let gap = distance_to_cut_leaf(w, ts.radius, c, os.radius);
                if gap <= margin {
                    out.push((t as u32, o as u32, gap, Stand::Lens));
                }
            } else {
                out.push((t as u32, o as u32, centre_gap, Stand::Sphere));
            }
        }
    }
    out.sort_by_key(|a| (a.0, a.1));
    out
}

/// What the reference rule says a pair stands for.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Stand {
    HalfSpace,
    Lens,
    Sphere,
}

fn traversal_pairs(
    tool: &PackedTree,
    q: &Pose,
    objects: &[PackedTree],
    margin: f64,
    ws: &mut CollideWorkspace,
) -> Vec<LeafPair> {
    let mut pairs = Vec::new();
    overlap_tree_trees(tool, q, objects, margin, ws, |p| pairs.push(*p)).unwrap();
    pairs.sort_by_key(|a| (a.tool_slot, a.object_slot));
    pairs
}

/// True when `leaf` is `slot` or lies under it in `tree`.
fn is_under(tree: &SphereTree, slot: usize, leaf: usize) -> bool {
    let mut n = Some(leaf);
    while let Some(k) = n {
        if k == slot {
            return true;
        }
        n = tree.parent(k);
    }
    false
}

fn small_tool(seed: u64) -> SphereTree {
    random_tree(
        seed,
        TreeShape {
            levels: 3,
            branching: 8,
            extent: 3.0,
            p_used: 0.8,
            p_early_leaf: 0.05,
        },
    )
}

/// A tool pose over the plate: its origin at `(u, v)` on the face, `h` above it, turned.
fn pose_over(rng: &mut ChaCha8Rng, extent: f64) -> Pose {
    let p = on_plate(
        rng.random_range(-HALF - 2.0..HALF + 2.0),
        rng.random_range(-HALF - 2.0..HALF + 2.0),
        rng.random_range(-1.0..extent + 1.5),
    );
    Pose::from_array([
        p[0],
        p[1],
        p[2],
        rng.random_range(-3.0..3.0),
        rng.random_range(-1.5..1.5),
        rng.random_range(-3.0..3.0),
    ])
}

#[test]
fn traversal_matches_the_reference_rule() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let (mut on_face, mut on_lens, mut on_sphere, mut dropped) = (0, 0, 0usize, 0);
    for seed in 0..4 {
        let plate = capped_plate(seed);
        let objects = [PackedTree::with_pose(&plate, &plate_pose()).unwrap()];
        assert_eq!(objects[0].face_cut_count(), GRID * GRID);
        let tool_tree = small_tool(100 + seed);
        let tool = PackedTree::new(&tool_tree).unwrap();
        let mut ws = CollideWorkspace::for_trees(&tool, &objects);
        for _ in 0..150 {
            let q = pose_over(&mut rng, 3.0);
            let margin = [0.0, 0.05, 0.5, 2.0][rng.random_range(0..4)];
            let got = traversal_pairs(&tool, &q, &objects, margin, &mut ws);
            let want = reference_pairs(&tool_tree, &q, &plate, margin);
            let mut uncut = objects[0].clone();
            uncut.drop_face_cuts();
            dropped += traversal_pairs(&tool, &q, std::slice::from_ref(&uncut), margin, &mut ws)
                .len()
                - got.len();
            assert_eq!(got.len(), want.len(), "pose {q:?}, margin {margin}");
            for (g, w) in got.iter().zip(&want) {
                assert_eq!((g.tool_slot, g.object_slot), (w.0, w.1));
                let stand = match g.stand_in() {
                    StandIn::HalfSpace(_) => Stand::HalfSpace,
                    StandIn::Lens(_) => Stand::Lens,
                    StandIn::Sphere => Stand::Sphere,
                };
                assert_eq!(stand, w.3);
                if stand == Stand::Lens && w.2 <= -ts_radius(&tool_tree, g.tool_slot) {
                    // The tool centre inside the lens: the reference says only that.
                    assert!(g.gap <= w.2 + 1e-9, "{} inside", g.gap);
                } else {
                    assert!((g.gap - w.2).abs() <= 1e-9, "{} vs {}", g.gap, w.2);
                }
                match stand {
                    Stand::HalfSpace => on_face += 1,
                    Stand::Lens => on_lens += 1,
                    Stand::Sphere => on_sphere += 1,
                }
            }
        }
    }
    // Both face stand-ins are exercised (every leaf's ball crosses the face, so none keeps its
    // sphere), and the cut drops pairs the spheres alone would report.
    assert!(
        on_face > 1000 && on_lens > 1000 && dropped > 1000,
        "{on_face} {on_lens} {on_sphere} {dropped}"
    );
}

fn ts_radius(tree: &SphereTree, slot: u32) -> f64 {
    tree.sphere(slot as usize).radius
}

/// The exact distance (mm) from a tool sphere to a cut leaf (ball `c, r` cut by the world
/// face): project on the ball; if that is above the face, the nearest point is on the disc.
fn distance_to_cut_leaf(w: [f64; 3], rt: f64, c: [f64; 3], r: f64) -> f64 {
    let (n, d) = world_face();
    let u = [w[0] - c[0], w[1] - c[1], w[2] - c[2]];
    let du = dot(&u, &u).sqrt();
    let on_ball = if du <= r {
        w
    } else {
        std::array::from_fn(|k| c[k] + u[k] * r / du)
    };
    let nearest = if dot(&n, &on_ball) <= d {
        on_ball
    } else {
        // Foot of `w` on the plane, clamped to the disc where the plane cuts the ball.
        let h = dot(&n, &w) - d;
        let foot: [f64; 3] = std::array::from_fn(|k| w[k] - h * n[k]);
        let hc = dot(&n, &c) - d;
        let centre: [f64; 3] = std::array::from_fn(|k| c[k] - hc * n[k]);
        let rho = (r * r - hc * hc).max(0.0).sqrt();
        let v = [
            foot[0] - centre[0],
            foot[1] - centre[1],
            foot[2] - centre[2],
        ];
        let dv = dot(&v, &v).sqrt();
        if dv <= rho {
            foot
        } else {
            std::array::from_fn(|k| centre[k] + v[k] * rho / dv)
        }
    };
    let inside = du <= r && dot(&n, &w) <= d;
    let e = dist(&w, &nearest);
    if inside {
        -rt
    } else {
        e - rt
    }
}

/// Every reported gap is at most the true distance to the cut leaf (a safe constraint), and
/// every leaf pair whose cut leaf comes within the margin is reported.
#[test]
fn pairs_are_safe_and_complete() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let plate = capped_plate(3);
    let objects = [PackedTree::with_pose(&plate, &plate_pose()).unwrap()];
    let tool_tree = small_tool(5);
    let tool = PackedTree::new(&tool_tree).unwrap();
    let mut ws = CollideWorkspace::for_trees(&tool, &objects);
    let mut near = 0;
    for _ in 0..300 {
        let q = pose_over(&mut rng, 3.0);
        let margin = [0.0, 0.2, 1.0][rng.random_range(0..3)];
        let got = traversal_pairs(&tool, &q, &objects, margin, &mut ws);
        for t in tool_tree.leaves() {
            let ts = tool_tree.sphere(t);
            let w = to_world(&q, &ts.center);
            for o in plate.leaves() {
                let os = plate.sphere(o);
                let c = to_world(&plate_pose(), &os.center);
                let truth = distance_to_cut_leaf(w, ts.radius, c, os.radius);
                let found = got
                    .iter()
                    .find(|p| p.tool_slot == t as u32 && p.object_slot == o as u32);
                if let Some(p) = found {
                    assert!(p.gap <= truth + 1e-9, "gap {} > distance {truth}", p.gap);
                }
                if truth <= margin {
                    near += 1;
                    assert!(
                        found.is_some(),
                        "missed a pair {truth} mm away (margin {margin})"
                    );
                }
            }
        }
    }
    assert!(near > 500, "{near}");
}

/// A ball sliding over the face at a constant height sees the same gap everywhere with the
/// cuts; without them it rides over the spheres' bumps. (It keeps 3 mm from the face's edges:
/// there the leaves' reach is short and their spheres stand for them, bumps and all.)
#[test]
fn a_ball_slides_over_a_cut_face_without_bumps() {
    let plate = capped_plate(1);
    let mut objects = [PackedTree::with_pose(&plate, &plate_pose()).unwrap()];
    let mut ball = SphereTree::new_unused(1, 2).unwrap();
    ball.spheres_mut()[0] = Sphere::new([0.0; 3], 0.5);
    let tool = PackedTree::new(&ball).unwrap();
    let mut ws = CollideWorkspace::for_trees(&tool, &objects);
    let spread = |objects: &[PackedTree], ws: &mut CollideWorkspace| {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for k in 0..=400 {
            let u = -HALF + 3.0 + (2.0 * HALF - 6.0) * f64::from(k) / 400.0;
            let p = on_plate(u, 0.37 * u, 0.6);
            let q = Pose::from_array([p[0], p[1], p[2], 0.0, 0.0, 0.0]);
            let gap = traversal_pairs(&tool, &q, objects, 2.0, ws)
                .iter()
                .map(|p| p.gap)
                .fold(f64::INFINITY, f64::min);
            lo = lo.min(gap);
            hi = hi.max(gap);
        }
        (lo, hi)
    };
    let (lo, hi) = spread(&objects, &mut ws);
    assert!(
        (lo - 0.1).abs() < 1e-9 && (hi - 0.1).abs() < 1e-9,
        "{lo} {hi}"
    );
    objects[0].drop_face_cuts();
    let (lo, hi) = spread(&objects, &mut ws);
    assert!(
        hi - lo > 0.05,
        "the spheres alone should be bumpy: {lo} {hi}"
    );
}

/// A neighbour list over a cut face reports exactly the traversal's pairs, to the bit, also
/// where the tool leaves a face's reach or rises above the margin.
#[test]
fn neighbour_lists_filter_cut_leaves_exactly() {
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    let plate = capped_plate(2);
    let objects = [PackedTree::with_pose(&plate, &plate_pose()).unwrap()];
    let tool_tree = small_tool(9);
    let tool = PackedTree::new(&tool_tree).unwrap();
    let mut ws = CollideWorkspace::for_trees(&tool, &objects);
    let mut list = NeighbourList::for_trees(&tool, &objects, 100_000);
    let mut checked = 0;
    for _ in 0..40 {
        let c = pose_over(&mut rng, 3.0);
        let big = 1.5;
        list.start(&tool, &c, big).unwrap();
        assert_eq!(
            list.advance(&tool, &objects, usize::MAX, None),
            ListStatus::Ready
        );
        for _ in 0..20 {
            let mut q = c;
            for k in 0..3 {
                q.q[k] += rng.random_range(-0.3..0.3);
            }
            for k in 3..6 {
                q.q[k] += rng.random_range(-0.02..0.02);
            }
            let margin = rng.random_range(0.0..0.5);
            let mut filtered = Vec::new();
            let Some(_) = list.filter(&q, None, margin, |p| {
                filtered.push(common::pair_key(p));
                true
            }) else {
                continue;
            };
            let want = common::traversal_keys(&tool, &q, None, &objects, margin, &mut ws);
            filtered.sort_unstable();
            let mut want = want;
            want.sort_unstable();
            assert_eq!(filtered, want);
            checked += 1;
        }
    }
    assert!(checked > 300, "{checked}");
}

/// Asserts that `grad` is the central finite difference of the pair's exact constraint value
/// at `q` (step 1e-6, relative tolerance 1e-5).
fn assert_gradient_is_the_pairs(form: ConstraintForm, q: &Pose, pair: &LeafPair, grad: &[f64; 6]) {
    for (k, &g) in grad.iter().enumerate() {
        let h = 1e-6;
        let (mut plus, mut minus) = (*q, *q);
        plus.q[k] += h;
        minus.q[k] -= h;
        let fd = (pair_constraint_value(form, &plus, pair)
            - pair_constraint_value(form, &minus, pair))
            / (2.0 * h);
        assert!(
            (fd - g).abs() <= 1e-5 * fd.abs().max(1.0),
            "{k}: {fd} vs {g}"
        );
    }
}

/// A face row's value and gradient are the pair's exact value at the linearization pose and
/// its finite-difference gradient, in both forms and both rotation coordinates.
#[test]
fn face_rows_match_finite_differences() {
    let mut rng = ChaCha8Rng::seed_from_u64(31);
    let (n, d) = world_face();
    for _ in 0..200 {
        let q = pose_over(&mut rng, 3.0);
        let pair = LeafPair {
            object: 0,
            tool_slot: 1,
            object_slot: 2,
            p_in_tool: std::array::from_fn(|_| rng.random_range(-3.0..3.0)),
            r_tool: rng.random_range(0.1..1.0),
            o_in_world: [0.0; 3],
            r_object: 1.0,
            gap: 0.0,
            face: Some(collide::FacePlane {
                normal: n,
                offset: d,
            }),
            on_face: true,
        };
        for form in [ConstraintForm::Distance, ConstraintForm::Squared] {
            let lin =
                Linearization::with_coordinates(form, RotationCoordinates::Euler, &q, &q).unwrap();
            let (value, grad) = lin.face_value_gradient(&pair.p_in_tool, pair.r_tool, &n, d);
            let exact = pair_constraint_value(form, &q, &pair);
            assert!((value - exact).abs() <= 1e-9 * exact.abs().max(1.0));
            assert_gradient_is_the_pairs(form, &q, &pair, &grad);
            // The row goes through the pair (row = J, rhs = J (q_lin - q_h) - C).
            let (row, rhs) = lin.row(&pair);
            assert_eq!(row, grad);
            assert!((rhs + value).abs() <= 1e-12 * value.abs().max(1.0));
        }
    }
}

/// A lens row (a leaf whose ball the face's plane crosses, the tool centre not above its disc)
/// is the exact distance's value and finite-difference gradient, in both forms: the plane
/// tangent to the lens at its nearest point.
#[test]
fn lens_rows_match_finite_differences() {
    let mut rng = ChaCha8Rng::seed_from_u64(33);
    let (n, d) = world_face();
    let mut checked = 0;
    for _ in 0..400 {
        let q = pose_over(&mut rng, 3.0);
        let r_object = rng.random_range(0.3..1.5);
        let o = on_plate(
            rng.random_range(-HALF..HALF),
            rng.random_range(-HALF..HALF),
            rng.random_range(-0.9..0.9) * r_object,
        );
        let pair = LeafPair {
            object: 0,
            tool_slot: 1,
            object_slot: 2,
            p_in_tool: std::array::from_fn(|_| rng.random_range(-3.0..3.0)),
            r_tool: rng.random_range(0.1..1.0),
            o_in_world: o,
            r_object,
            gap: 0.0,
            face: Some(collide::FacePlane {
                normal: n,
                offset: d,
            }),
            on_face: false,
        };
        let c = to_world(&q, &pair.p_in_tool);
        let truth = distance_to_cut_leaf(c, 0.0, o, r_object);
        if truth < 1e-3 {
            continue; // inside or on the lens: the distance has a kink there
        }
        assert!((pair.gap_at(&q) - (truth - pair.r_tool)).abs() <= 1e-9);
        for form in [ConstraintForm::Distance, ConstraintForm::Squared] {
            let lin =
                Linearization::with_coordinates(form, RotationCoordinates::Euler, &q, &q).unwrap();
            let (row, rhs) = lin.row(&pair);
            let exact = pair_constraint_value(form, &q, &pair);
            assert!((rhs + exact).abs() <= 1e-9 * exact.abs().max(1.0));
            assert_gradient_is_the_pairs(form, &q, &pair, &row);
        }
        checked += 1;
    }
    assert!(checked > 300, "{checked}");
}

/// A pose proven free against a merged pair's half-space (decided where a region was detected,
/// kept as the tool moves on) is free against every leaf stand-in beneath it as a later region
/// decides them at that pose. Here only the blocks and the root are cut (the leaves have no caps of their own,
/// and some bulge far above the face): a leaf takes its ancestors' planes that cross its ball,
/// so its lens lies inside the half-space the block stands for. (Were the leaves left with
/// their spheres, a pose accepted against the block could be found penetrating at leaf level
/// in the next region: the spline stalled so at its hub's face.)
#[test]
fn leaf_stand_ins_lie_inside_merged_half_spaces() {
    let mut rng = ChaCha8Rng::seed_from_u64(51);
    let mut flat = plate(5, true);
    let mut caps = flat.caps().to_vec();
    for leaf in flat.leaves() {
        caps[leaf].clear();
    }
    flat.set_caps(caps).unwrap();
    let objects = [PackedTree::with_pose(&flat, &plate_pose()).unwrap()];
    let tool_tree = small_tool(17);
    let tool = PackedTree::new(&tool_tree).unwrap();
    let mut ws = CollideWorkspace::for_trees(&tool, &objects);
    let mut list = NeighbourList::for_trees(&tool, &objects, 100_000);
    let (mut compared, mut lenses) = (0, 0);
    for _ in 0..200 {
        let q = pose_over(&mut rng, 3.0);
        let margin = 1.0;
        let merged: Vec<LeafPair> = traversal_pairs(&tool, &q, &objects, margin, &mut ws)
            .into_iter()
            .filter(|p| !flat.is_leaf(p.object_slot as usize))
            .collect();
        if merged.is_empty() {
            continue;
        }
        // The tool moves on (within a region's reach): a later region decides every leaf pair
        // at the new pose (a list merges nothing, so each keeps its own stand-in; those beyond
        // the filter's margin are farther than any merged pair's gap).
        let mut q2 = q;
        for k in 0..3 {
            q2.q[k] += rng.random_range(-0.8..0.8);
        }
        for k in 3..6 {
            q2.q[k] += rng.random_range(-0.05..0.05);
        }
        let wide = 3.0;
        list.start(&tool, &q, wide + 2.0).unwrap();
        assert_eq!(
            list.advance(&tool, &objects, usize::MAX, None),
            ListStatus::Ready
        );
        let mut leaves = Vec::new();
        list.filter(&q2, None, wide, |p| {
            leaves.push(*p);
            true
        })
        .unwrap();
        for m in &merged {
            let merged_gap = m.gap_at(&q2);
            if merged_gap > wide {
                continue;
            }
            let beneath = leaves.iter().filter(|l| {
                l.tool_slot == m.tool_slot
                    && is_under(&flat, m.object_slot as usize, l.object_slot as usize)
            });
            for l in beneath {
                assert!(
                    l.gap >= merged_gap - 1e-9,
                    "leaf {} at {} under a face at {merged_gap}",
                    l.object_slot,
                    l.gap,
                );
                compared += 1;
                lenses += usize::from(matches!(l.stand_in(), StandIn::Lens(_)));
            }
        }
    }
    assert!(compared > 500 && lenses > 500, "{compared} {lenses}");
}

/// With the inner nodes cut too, a tool leaf above the face gets one pair for a whole block (or
/// the plate): every reported gap is at most the true distance to every cut leaf under the
/// pair's node, every cut leaf within the margin is answered by a pair on it or an ancestor,
/// and the descent splits fewer node pairs (42 % fewer here, where the small tool's own tree is
/// most of the descent).
#[test]
fn inner_cuts_stand_for_their_subtree() {
    let mut rng = ChaCha8Rng::seed_from_u64(41);
    let flat = plate(4, true);
    let objects = [PackedTree::with_pose(&flat, &plate_pose()).unwrap()];
    let leaves_only = [PackedTree::with_pose(&plate(4, false), &plate_pose()).unwrap()];
    let tool_tree = small_tool(13);
    let tool = PackedTree::new(&tool_tree).unwrap();
    let mut ws = CollideWorkspace::for_trees(&tool, &objects);
    let under = |slot: usize, leaf: usize| is_under(&flat, slot, leaf);
    let (mut collapsed, mut near) = (0, 0);
    let (mut splits_inner, mut splits_leaf) = (0, 0);
    for _ in 0..300 {
        let q = pose_over(&mut rng, 3.0);
        let margin = [0.0, 0.2, 1.0][rng.random_range(0..3)];
        let got = traversal_pairs(&tool, &q, &objects, margin, &mut ws);
        splits_inner += ws.stats().node_pairs_split;
        traversal_pairs(&tool, &q, &leaves_only, margin, &mut ws);
        splits_leaf += ws.stats().node_pairs_split;
        collapsed += got
            .iter()
            .filter(|p| !flat.is_leaf(p.object_slot as usize))
            .count();
        for t in tool_tree.leaves() {
            let ts = tool_tree.sphere(t);
            let w = to_world(&q, &ts.center);
            for o in flat.leaves() {
                let os = flat.sphere(o);
                let c = to_world(&plate_pose(), &os.center);
                let truth = distance_to_cut_leaf(w, ts.radius, c, os.radius);
                let mut answering = got
                    .iter()
                    .filter(|p| p.tool_slot == t as u32 && under(p.object_slot as usize, o));
                for p in answering.clone() {
                    assert!(p.gap <= truth + 1e-9, "gap {} > distance {truth}", p.gap);
                }
                if truth <= margin {
                    near += 1;
                    assert!(
                        answering.next().is_some(),
                        "missed {truth} mm (margin {margin})"
                    );
                }
            }
        }
    }
    assert!(near > 500 && collapsed > 500, "{near} {collapsed}");
    assert!(
        4 * splits_inner < 3 * splits_leaf,
        "inner cuts should spare a quarter of the descent: {splits_inner} vs {splits_leaf}"
    );
}

/// The same along straight sweeps: every cut leaf that comes within the margin somewhere on the
/// path is answered by a pair on it or an ancestor, every gap (at the start) is safe, and faces
/// settle node pairs in swept queries too.
#[test]
fn inner_cuts_in_swept_queries() {
    let mut rng = ChaCha8Rng::seed_from_u64(43);
    let flat = plate(5, true);
    let objects = [PackedTree::with_pose(&flat, &plate_pose()).unwrap()];
    let tool_tree = small_tool(17);
    let tool = PackedTree::new(&tool_tree).unwrap();
    let mut ws = CollideWorkspace::for_trees(&tool, &objects);
    let under = |slot: usize, leaf: usize| is_under(&flat, slot, leaf);
    let (mut near, mut settled) = (0, 0);
    for _ in 0..200 {
        let q = pose_over(&mut rng, 3.0);
        let v: [f64; 3] = std::array::from_fn(|_| rng.random_range(-2.0..2.0));
        let sweep = collide::Sweep {
            translation: v,
            rotation: [0.0; 3],
        };
        let margin = [0.0, 0.2][rng.random_range(0..2)];
        let mut got = Vec::new();
        collide::overlap_swept(&tool, &q, &sweep, &objects, margin, &mut ws, |p| {
            got.push(*p)
        })
        .unwrap();
        settled += ws.stats().face_pruned;
        for t in tool_tree.leaves() {
            let ts = tool_tree.sphere(t);
            for o in flat.leaves() {
                let os = flat.sphere(o);
                let c = to_world(&plate_pose(), &os.center);
                let mut answering = got
                    .iter()
                    .filter(|p| p.tool_slot == t as u32 && under(p.object_slot as usize, o));
                let w0 = to_world(&q, &ts.center);
                for p in answering.clone() {
                    let truth = distance_to_cut_leaf(w0, ts.radius, c, os.radius);
                    assert!(p.gap <= truth + 1e-9, "gap {} > distance {truth}", p.gap);
                }
                let closest = (0..=16)
                    .map(|k| {
                        let s = f64::from(k) / 16.0;
                        let w: [f64; 3] = std::array::from_fn(|i| w0[i] + s * v[i]);
                        distance_to_cut_leaf(w, ts.radius, c, os.radius)
                    })
                    .fold(f64::INFINITY, f64::min);
                if closest <= margin {
                    near += 1;
                    assert!(
                        answering.next().is_some(),
                        "missed {closest} mm on the path"
                    );
                }
            }
        }
    }
    assert!(near > 300 && settled > 300, "{near} {settled}");
}

/// Pairs within `margin` of `tool` at `q`, half-space pairs of the face within `slab`'s thinner
/// margin ([`FaceSlab`]).
fn slab_pairs(
    tool: &PackedTree,
    q: &Pose,
    objects: &[PackedTree],
    margin: f64,
    slab: FaceSlab,
    ws: &mut CollideWorkspace,
) -> Vec<LeafPair> {
    let mut pairs = Vec::new();
    overlap_shared(
        tool,
        q,
        None,
        objects,
        margin,
        Some(slab),
        ws,
        None,
        None,
        |p| pairs.push(*p),
    )
    .unwrap();
    pairs.sort_by_key(|a| (a.tool_slot, a.object_slot));
    pairs
}

/// A slab region lists every pair that can overlap while the tool slides along the face within
/// the query's margin and moves across it within the slab's: at any such pose, a leaf pair
/// that overlaps (decided by a traversal there) has a listed pair of the same tool leaf at
/// least as deep. The slab's list is a part of the whole margin's, and much shorter.
#[test]
fn slab_regions_hold_every_pair_that_can_overlap() {
    const HEIGHTS: (f64, f64) = (2.0, 4.0);
    let mut rng = ChaCha8Rng::seed_from_u64(77);
    let flat = plate(9, true);
    let objects = [PackedTree::with_pose(&flat, &plate_pose()).unwrap()];
    let tool = PackedTree::new(&small_tool(23)).unwrap();
    let mut ws = CollideWorkspace::for_trees(&tool, &objects);
    let (normal, _) = world_face();
    let (margin, thin) = (1.0, 0.1);
    let slab = FaceSlab {
        normal,
        margin: thin,
        tangent: margin,
    };
    let (mut overlaps, mut slab_total, mut full_total) = (0, 0, 0);
    for _ in 0..300 {
        // The tool resting near the face, hardly turned (as it slides on it).
        let p = on_plate(
            rng.random_range(-HALF - 2.0..HALF + 2.0),
            rng.random_range(-HALF - 2.0..HALF + 2.0),
            rng.random_range(HEIGHTS.0..HEIGHTS.1),
        );
        let q = Pose::from_array([
            p[0],
            p[1],
            p[2],
            rng.random_range(-0.2..0.2),
            rng.random_range(-0.2..0.2),
            rng.random_range(-3.0..3.0),
        ]);
        let listed = slab_pairs(&tool, &q, &objects, margin, slab, &mut ws);
        let full = traversal_pairs(&tool, &q, &objects, margin, &mut ws);
        for l in &listed {
            assert!(
                full.iter().any(|f| f == l),
                "a slab pair the traversal does not list: {l:?}"
            );
        }
        slab_total += listed.len();
        full_total += full.len();

        for _ in 0..8 {
            // A slide along the face (up to the margin, less a hair) and a move across it
            // (up to the slab's margin, less a hair), no turn.
            let along: f64 = rng.random_range(0.0..margin - 1e-6);
            let across: f64 = rng.random_range(-(thin - 1e-6)..thin - 1e-6);
            let mut dir = [
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            ];
            let dn = dot(&dir, &normal);
            for k in 0..3 {
                dir[k] -= dn * normal[k];
            }
            let len = dot(&dir, &dir).sqrt().max(1e-12);
            let mut q2 = q;
            for k in 0..3 {
                let slide = along * dir[k] / len;
                // Total motion within the margin.
                let scale = (margin - 1e-6) / (along + across.abs()).max(margin - 1e-6);
                q2.q[k] += scale * (slide + across * normal[k]);
            }
            for hit in traversal_pairs(&tool, &q2, &objects, 0.0, &mut ws) {
                if hit.gap >= -1e-9 {
                    continue;
                }
                overlaps += 1;
                let deepest = listed
                    .iter()
                    .filter(|l| l.tool_slot == hit.tool_slot)
                    .map(|l| l.gap_at(&q2))
                    .fold(f64::INFINITY, f64::min);
                assert!(
                    deepest <= hit.gap + 1e-9,
                    "tool leaf {} overlaps by {} at the slid pose; the slab lists it at {deepest}",
                    hit.tool_slot,
                    -hit.gap
                );
            }
        }
    }
    assert!(
        overlaps > 200,
        "only {overlaps} overlaps: the case does not test the slab"
    );
    assert!(
        10 * slab_total < 9 * full_total,
        "the slab lists {slab_total} pairs, the whole margin {full_total}"
    );
}
