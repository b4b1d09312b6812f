//! A neighbour list answers every query it covers with exactly the traversal's pairs (and
//! gaps, bit for bit), also at the edge of its cover; built in slices it is the one-shot list;
//! a list past its capacity is unusable.

mod common;

use collide::{
    rotation_exp, BackgroundList, ListStatus, NeighbourList, PackedTree, Pose, Sweep, TraversalTeam,
};
use common::{dense_shape, pair_key, random_pose, random_tree, traversal_keys, PairKey};

fn trees() -> (PackedTree, Vec<PackedTree>) {
    let tool = PackedTree::new(&random_tree(21, dense_shape())).unwrap();
    let objects = vec![
        PackedTree::new(&random_tree(22, dense_shape())).unwrap(),
        PackedTree::with_pose(
            &random_tree(23, dense_shape()),
            &Pose::from_array([40.0, 0.0, 0.0, 0.3, 0.0, 0.1]),
        )
        .unwrap(),
    ];
    (tool, objects)
}

fn build(
    list: &mut NeighbourList,
    tool: &PackedTree,
    objects: &[PackedTree],
    center: &Pose,
    margin: f64,
    slice: usize,
) -> ListStatus {
    list.start(tool, center, margin).unwrap();
    let mut calls = 0;
    while list.status() == ListStatus::Building {
        list.advance(tool, objects, slice, None);
        calls += 1;
        assert!(calls < 1_000_000, "the build does not end");
    }
    list.status()
}

/// `center` moved by `dt` along a random unit direction and turned by `turn` rad about a
/// random axis (world axes).
fn moved(center: &Pose, rng: &mut devkit::Rng, dt: f64, turn: f64) -> Pose {
    let unit = |rng: &mut devkit::Rng| {
        let v = nalgebra::Vector3::new(
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
        );
        v / v.norm().max(1e-9)
    };
    let t = center.translation() + unit(rng) * dt;
    let r = rotation_exp(&(unit(rng) * turn)) * center.rotation_matrix();
    Pose::from_translation_rotation(&t, &r)
}

#[test]
fn a_covered_query_gets_exactly_the_traversals_pairs() {
    let (tool, objects) = trees();
    let mut list = NeighbourList::for_trees(&tool, &objects, 1 << 18);
    let mut ws = collide::CollideWorkspace::for_trees(&tool, &objects);
    let mut rng = devkit::Rng::new(7);
    let (mut covered, mut edge, mut dense, mut refused) = (0, 0, 0, 0);
    for i in 0..60 {
        let center = random_pose(&mut rng, [-5.0, 45.0], 5.0);
        let big = rng.range(0.5, 2.0);
        assert_eq!(
            build(&mut list, &tool, &objects, &center, big, 1 << 30),
            ListStatus::Ready
        );
        for j in 0..20 {
            let margin = rng.range(0.0, 0.5 * big);
            let sweep = Sweep {
                translation: [rng.range(-0.2, 0.2), rng.range(-0.2, 0.2), 0.0],
                rotation: [0.0, 0.0, rng.range(-0.005, 0.005)],
            };
            let sw = (j % 3 == 0).then_some(&sweep);
            // A motion from the centre that uses up a random share of the list's slack, or a
            // little more than all of it.
            let q0 = moved(&center, &mut rng, 0.0, 0.0);
            let room = list.slack(&q0, sw, margin);
            let share = if j % 5 == 4 {
                rng.range(1.02, 1.5)
            } else {
                rng.range(0.0, 1.0)
            };
            let (dt, turn) = if room > 0.0 {
                let mix = rng.range(0.0, 1.0);
                (
                    share * room * mix,
                    share * room * (1.0 - mix) / tool.reach(),
                )
            } else {
                (0.0, 0.0)
            };
            let q = moved(&center, &mut rng, dt, turn);
            let mut traversed = traversal_keys(&tool, &q, sw, &objects, margin, &mut ws);
            let mut filtered = Vec::new();
            let answer = list.filter(&q, sw, margin, |p| {
                filtered.push(pair_key(p));
                true
            });
            assert_eq!(answer.is_some(), list.covers(&q, sw, margin));
            let Some(n) = answer else {
                assert!(filtered.is_empty());
                refused += 1;
                continue;
            };
            assert_eq!(n, filtered.len());
            traversed.sort_unstable();
            filtered.sort_unstable();
            assert_eq!(filtered, traversed, "centre {i}, query {j}");
            covered += 1;
            edge += usize::from(list.slack(&q, sw, margin) < 0.05 * big);
            dense += usize::from(traversed.len() > 20);
        }
    }
    assert!(covered > 600, "{covered} covered queries");
    assert!(edge > 50, "{edge} queries near the edge of the cover");
    assert!(dense > 100, "{dense} queries with more than 20 pairs");
    assert!(refused > 100, "{refused} queries refused");
}

#[test]
fn a_list_built_in_slices_is_the_one_shot_list() {
    let (tool, objects) = trees();
    let mut whole = NeighbourList::for_trees(&tool, &objects, 1 << 18);
    let mut sliced = NeighbourList::for_trees(&tool, &objects, 1 << 18);
    let center = Pose::from_array([20.0, 1.0, -2.0, 0.1, -0.2, 0.3]);
    assert_eq!(
        build(&mut whole, &tool, &objects, &center, 1.0, usize::MAX),
        ListStatus::Ready
    );
    assert_eq!(
        build(&mut sliced, &tool, &objects, &center, 1.0, 7),
        ListStatus::Ready
    );
    assert!(whole.len() > 100, "{} pairs", whole.len());
    assert_eq!(whole.splits(), sliced.splits());
    let all = |l: &NeighbourList| {
        let mut v = Vec::new();
        l.filter(&center, None, 1.0, |p| {
            v.push(pair_key(p));
            true
        })
        .unwrap();
        v
    };
    assert_eq!(all(&whole), all(&sliced));
    assert_eq!(all(&whole).len(), whole.len());
}

#[test]
fn a_list_past_its_capacity_is_unusable_and_a_bad_pose_is_refused() {
    let (tool, objects) = trees();
    let mut list = NeighbourList::for_trees(&tool, &objects, 10);
    let center = Pose::from_array([20.0, 1.0, -2.0, 0.1, -0.2, 0.3]);
    assert_eq!(
        build(&mut list, &tool, &objects, &center, 1.0, 64),
        ListStatus::Overflowed
    );
    assert!(!list.covers(&center, None, 0.0));
    assert_eq!(list.filter(&center, None, 0.0, |_| true), None);
    let bad = Pose::from_array([f64::NAN, 0.0, 0.0, 0.0, 0.0, 0.0]);
    assert!(list.start(&tool, &bad, 1.0).is_err());
    assert_eq!(list.status(), ListStatus::Overflowed);
}

/// A pair just outside the list (its gap at the list's pose is the list's margin plus
/// 0.001 mm), approached by each kind of motion the cover accounts for, up to the edge of the
/// cover: the filter still agrees with the traversal (the pair must not be reported by the
/// traversal while the list claims to cover the query). A cover that undercounted any one
/// motion (translation, turn, a sweep's translation or turn) would let the traversal find the
/// pair and the filter miss it.
#[test]
fn the_cover_counts_every_motion_at_its_edge() {
    use spheretree::{Sphere, SphereTree};
    let mut t = SphereTree::new_unused(2, 2).unwrap();
    t.spheres_mut()[0] = Sphere::new([0.0; 3], 11.0);
    t.spheres_mut()[1] = Sphere::new([10.0, 0.0, 0.0], 1.0);
    t.spheres_mut()[2] = Sphere::new([-10.0, 0.0, 0.0], 1.0);
    let tool = PackedTree::new(&t).unwrap();
    let big = 0.5;
    let eps = 0.001;
    let object =
        SphereTree::from_slots(1, 8, vec![Sphere::new([10.0, 2.0 + big + eps, 0.0], 1.0)]).unwrap();
    let objects = vec![PackedTree::new(&object).unwrap()];
    let mut list = NeighbourList::for_trees(&tool, &objects, 16);
    let mut ws = collide::CollideWorkspace::for_trees(&tool, &objects);
    let center = Pose::identity();
    assert_eq!(
        build(&mut list, &tool, &objects, &center, big, 64),
        ListStatus::Ready
    );
    assert!(list.is_empty());
    let turned = |a: f64| Pose::from_array([0.0, 0.0, 0.0, 0.0, 0.0, a]);
    let shifted = |d: f64| Pose::from_array([0.0, d, 0.0, 0.0, 0.0, 0.0]);
    let mut checked = 0;
    for size in [0.001, 0.01, 0.05, 0.2] {
        let along = Sweep {
            translation: [0.0, size, 0.0],
            rotation: [0.0; 3],
        };
        let about = Sweep {
            translation: [0.0; 3],
            rotation: [0.0, 0.0, size / 11.0],
        };
        let cases: [(Pose, Option<&Sweep>); 4] = [
            (shifted(size), None),
            (turned(size / 11.0), None),
            (center, Some(&along)),
            (center, Some(&about)),
        ];
        for (q, sw) in cases {
            // The largest margin the list covers at this query.
            let margin = list.slack(&q, sw, 0.0);
            if margin < 0.0 {
                continue;
            }
            let traversed = traversal_keys(&tool, &q, sw, &objects, margin, &mut ws).len();
            assert_eq!(list.filter(&q, sw, margin, |_| true), Some(traversed));
            assert_eq!(traversed, 0, "size {size}, sweep {sw:?}");
            checked += 1;
        }
    }
    assert_eq!(checked, 16);
}

/// A shaft (leaf rings of radius 2 mm at both ends, 40 mm apart) turning about its own axis
/// inside a ring of object spheres: the cover counts the turn on the shaft's radius, not its
/// reach, so a list answers turns up to seven times longer than the reach alone allows, and
/// answers them exactly (the traversal's pairs), up to and past the edge of its cover.
#[test]
fn a_shaft_turning_about_its_axis_stays_covered_on_its_radius() {
    use spheretree::{Sphere, SphereTree};
    let mut shaft = SphereTree::new_unused(2, 8).unwrap();
    shaft.spheres_mut()[0] = Sphere::new([0.0; 3], 22.0);
    for k in 0..8 {
        let a = std::f64::consts::FRAC_PI_2 * (k % 4) as f64;
        let z = if k < 4 { 20.0 } else { -20.0 };
        shaft.spheres_mut()[1 + k] = Sphere::new([2.0 * a.cos(), 2.0 * a.sin(), z], 1.0);
    }
    let tool = PackedTree::new(&shaft).unwrap();
    // Object spheres (radius 1) on the leaves' circle at the ends, each 0.02–0.6 mm ahead of
    // a leaf (the chord 2 + gap), so turns one way bring them in.
    let mut rng = devkit::Rng::new(5);
    let mut ring = SphereTree::new_unused(2, 8).unwrap();
    ring.spheres_mut()[0] = Sphere::new([0.0; 3], 30.0);
    for k in 0..8 {
        let z = if k < 4 { 20.0 } else { -20.0 };
        let ahead = 2.0 * ((2.0 + rng.range(0.02, 0.6)) / 4.0).asin();
        let a = std::f64::consts::FRAC_PI_2 * (k % 4) as f64 + ahead;
        ring.spheres_mut()[1 + k] = Sphere::new([2.0 * a.cos(), 2.0 * a.sin(), z], 1.0);
    }
    let objects = vec![PackedTree::new(&ring).unwrap()];
    let mut list = NeighbourList::for_trees(&tool, &objects, 64);
    let mut ws = collide::CollideWorkspace::for_trees(&tool, &objects);
    let (center, big) = (Pose::identity(), 0.5);
    assert_eq!(
        build(&mut list, &tool, &objects, &center, big, 64),
        ListStatus::Ready
    );
    // The leaves' box's corners (a list bounds turns by the corners, `CentreBox::axis_arms`).
    let arm = 8f64.sqrt();
    let (mut covered, mut past_reach, mut with_pairs, mut refused) = (0, 0, 0, 0);
    for _ in 0..400 {
        let margin = rng.range(0.0, 0.3);
        // Up to 1.2 times the turn the radius allows, either way about the axis.
        let turn = rng.range(-1.2, 1.2) * (big - margin) / arm;
        let q = Pose::from_array([0.0, 0.0, 0.0, 0.0, 0.0, turn]);
        let mut traversed = traversal_keys(&tool, &q, None, &objects, margin, &mut ws);
        let mut filtered = Vec::new();
        let answer = list.filter(&q, None, margin, |p| {
            filtered.push(pair_key(p));
            true
        });
        let Some(n) = answer else {
            refused += 1;
            continue;
        };
        assert_eq!(n, filtered.len());
        traversed.sort_unstable();
        filtered.sort_unstable();
        assert_eq!(filtered, traversed, "turn {turn}, margin {margin}");
        covered += 1;
        past_reach += usize::from(turn.abs() * tool.reach() > big);
        with_pairs += usize::from(!traversed.is_empty());
    }
    assert!(covered > 250, "{covered} covered");
    assert!(
        past_reach > 100,
        "{past_reach} covered past the reach's bound"
    );
    assert!(with_pairs > 20, "{with_pairs} covered with pairs");
    assert!(refused > 30, "{refused} refused");
}

/// A list proves free space as the proving traversal does: the same pairs within the margin
/// and, where it reaches the proof margin, the same proven margin (the nearest gap beyond);
/// where it reaches less far, a proof no farther than it reaches and than the traversal's.
#[test]
fn a_list_proves_free_space_as_the_proving_traversal_does() {
    let (tool, objects) = trees();
    let mut list = NeighbourList::for_trees(&tool, &objects, 1 << 18);
    let mut ws = collide::CollideWorkspace::for_trees(&tool, &objects);
    let mut rng = devkit::Rng::new(17);
    let (mut same, mut shorter, mut narrowed) = (0, 0, 0);
    for i in 0..40 {
        let center = random_pose(&mut rng, [-5.0, 45.0], 5.0);
        let big = rng.range(0.5, 1.5);
        assert_eq!(
            build(&mut list, &tool, &objects, &center, big, 1 << 30),
            ListStatus::Ready
        );
        for j in 0..15 {
            let dt = rng.range(0.0, 0.3);
            let q = moved(&center, &mut rng, dt, 0.0);
            let margin = rng.range(0.0, 0.2);
            let proof = margin + rng.range(0.0, 1.0);
            let mut found = Vec::new();
            let Some((n, proven)) = list.filter_proving(&q, margin, proof, |p| {
                found.push(pair_key(p));
                true
            }) else {
                assert!(!list.covers(&q, None, margin));
                continue;
            };
            let mut expected = Vec::new();
            let (_, traversal_proven) = collide::overlap_shared_proving(
                &tool,
                &q,
                &objects,
                margin,
                proof,
                &mut ws,
                None,
                None,
                |p| expected.push(pair_key(p)),
            )
            .unwrap();
            assert_eq!(n, found.len());
            found.sort_unstable();
            expected.sort_unstable();
            assert_eq!(found, expected, "centre {i}, query {j}");
            let reach = list.slack(&q, None, 0.0);
            if reach >= proof {
                assert_eq!(proven, traversal_proven, "centre {i}, query {j}");
                same += 1;
                narrowed += usize::from(proven < proof);
            } else {
                assert!(proven <= traversal_proven && proven <= reach.max(margin));
                assert!(proven >= margin);
                shorter += 1;
            }
        }
    }
    assert!(same > 100 && shorter > 50, "{same} same, {shorter} shorter");
    assert!(narrowed > 30, "{narrowed} narrowed by a pair");
}

/// Bad input to a list's proof: a non-finite pose is not covered (nothing reported); a NaN
/// or negative margin is taken as 0, and a NaN proof margin proves nothing beyond the margin.
#[test]
fn a_lists_proof_takes_bad_margins_as_the_plain_filter_and_refuses_a_bad_pose() {
    let (tool, objects) = trees();
    let mut list = NeighbourList::for_trees(&tool, &objects, 1 << 18);
    let center = Pose::from_array([20.0, 1.0, -2.0, 0.1, -0.2, 0.3]);
    assert_eq!(
        build(&mut list, &tool, &objects, &center, 1.0, 1 << 30),
        ListStatus::Ready
    );
    let bad = Pose::from_array([f64::NAN, 0.0, 0.0, 0.0, 0.0, 0.0]);
    let mut visited = 0;
    assert_eq!(
        list.filter_proving(&bad, 0.1, 0.5, |_| {
            visited += 1;
            true
        }),
        None
    );
    assert_eq!(visited, 0);
    let plain = |m: f64| list.filter(&center, None, m, |_| true).unwrap();
    let (n, proven) = list
        .filter_proving(&center, 0.1, f64::NAN, |_| true)
        .unwrap();
    assert_eq!((n, proven), (plain(0.1), 0.1));
    for m in [f64::NAN, -1.0] {
        let (n, proven) = list.filter_proving(&center, m, 0.5, |_| true).unwrap();
        assert_eq!(n, plain(0.0));
        assert!((0.0..=0.5).contains(&proven), "{proven}");
    }
}

/// The pairs of a list, as sorted keys.
fn keys(list: &NeighbourList, at: &Pose, margin: f64) -> Vec<PairKey> {
    let mut v = Vec::new();
    list.filter(at, None, margin, |p| {
        v.push(pair_key(p));
        true
    })
    .unwrap();
    v.sort_unstable();
    v
}

/// Grants `grant` splits per call until the build ends; the number of calls.
fn run_background(
    bg: &mut BackgroundList,
    tool: &PackedTree,
    objects: &[PackedTree],
    grant: usize,
    team: Option<&TraversalTeam>,
) -> usize {
    let mut calls = 0;
    while bg.status() == ListStatus::Building {
        bg.advance(tool, objects, grant, grant, team, None);
        calls += 1;
        assert!(calls < 1_000_000, "the build does not end");
        if team.is_some() {
            // Leave the helper some time, as frames do.
            std::thread::sleep(std::time::Duration::from_micros(50));
        }
    }
    calls
}

/// A slice's budget counts the pairs it lists as well as the node pairs it splits: where a
/// list holds many pairs per split (a dense contact at a list's wide margin), a slice of
/// splits alone runs several times its budget's time.
#[test]
fn a_slice_of_a_dense_list_stays_within_its_work() {
    let (tool, objects) = trees();
    let center = Pose::from_array([20.0, 1.0, -2.0, 0.1, -0.2, 0.3]);
    let mut list = NeighbourList::for_trees(&tool, &objects, 1 << 18);
    list.start(&tool, &center, 3.0).unwrap();
    let budget = 97;
    // Past the budget by at most a quarter chunk's pairs (a few per split), and one split's
    // (at most one pair per child tested).
    let most_children = 32;
    let (mut calls, mut largest) = (0, 0);
    while list.status() == ListStatus::Building {
        let before = list.splits() + list.len();
        list.advance(&tool, &objects, budget, None);
        let done = list.splits() + list.len() - before;
        assert_eq!(list.work(), list.splits() + list.len());
        largest = largest.max(done);
        calls += 1;
        assert!(calls < 1_000_000, "the build does not end");
    }
    assert_eq!(list.status(), ListStatus::Ready);
    // Dense: the list holds at least one pair per two splits (so splits alone would not do).
    assert!(
        2 * list.len() >= list.splits(),
        "{} pairs for {} splits",
        list.len(),
        list.splits()
    );
    assert!(
        largest <= budget + budget / 2 + most_children,
        "a slice did {largest} units of work for a budget of {budget}"
    );
}

#[test]
fn a_background_list_is_the_list_on_its_schedule_with_or_without_a_helper() {
    let (tool, objects) = trees();
    let center = Pose::from_array([20.0, 1.0, -2.0, 0.1, -0.2, 0.3]);
    let mut direct = NeighbourList::for_trees(&tool, &objects, 1 << 18);
    build(&mut direct, &tool, &objects, &center, 1.0, usize::MAX);
    let total = direct.work();
    assert!(
        total > 1000,
        "{total} units of work: too small a build to spread"
    );
    let team = TraversalTeam::new(&tool, &objects, 1 << 16).unwrap();
    for team in [None, Some(&team)] {
        let mut bg = BackgroundList::for_trees(&tool, &objects, 1 << 18);
        bg.start(&tool, &center, 1.0).unwrap();
        let grant = 97;
        let calls = run_background(&mut bg, &tool, &objects, grant, team);
        assert_eq!(bg.status(), ListStatus::Ready);
        assert_eq!(bg.work(), total);
        // Finished at the call by which the grants reached its cost, not before; without a
        // helper exactly then (a held-up helper may make it later).
        let on_schedule = total.div_ceil(grant);
        if team.is_none() {
            assert_eq!(calls, on_schedule);
        } else {
            assert!(
                calls >= on_schedule,
                "{calls} calls, schedule {on_schedule}"
            );
        }
        let mut used = NeighbourList::for_trees(&tool, &objects, 1 << 18);
        assert!(bg.take(&mut used));
        assert_eq!(bg.status(), ListStatus::Empty);
        assert_eq!(keys(&used, &center, 1.0), keys(&direct, &center, 1.0));
        // A restart while the helper works gives the new pose's list.
        let other = Pose::from_array([30.0, -1.0, 1.0, -0.1, 0.2, 0.0]);
        bg.start(&tool, &center, 1.0).unwrap();
        bg.advance(&tool, &objects, 10_000_000, 100, team, None);
        bg.start(&tool, &other, 0.8).unwrap();
        run_background(&mut bg, &tool, &objects, 10_000_000, team);
        assert_eq!(bg.status(), ListStatus::Ready);
        assert!(bg.take(&mut used));
        let mut fresh = NeighbourList::for_trees(&tool, &objects, 1 << 18);
        build(&mut fresh, &tool, &objects, &other, 0.8, usize::MAX);
        assert_eq!(keys(&used, &other, 0.8), keys(&fresh, &other, 0.8));
        assert!(!used.is_empty());
    }
}
