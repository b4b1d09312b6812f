//! The free-space probe asked in slices answers as the "any pair" question does, after the
//! same calls without a helper thread, and the same answer with one running its second stream.

mod common;

use collide::{
    any_pair_within, overlap_swept, CollideWorkspace, FreeSpaceProbe, PackedTree, Pose,
    ProbeStatus, Sweep, TraversalTeam,
};
use common::{random_tree, TreeShape};

fn shape() -> TreeShape {
    TreeShape {
        levels: 4,
        branching: 8,
        extent: 50.0,
        p_used: 1.0,
        p_early_leaf: 0.0,
    }
}

/// The distance along `at` (mm) where the tool just stops touching the objects (bisection
/// over 0–400 mm).
fn clear_from(
    tool: &PackedTree,
    objects: &[PackedTree],
    at: &dyn Fn(f64) -> Pose,
    ws: &mut CollideWorkspace,
) -> f64 {
    let (mut lo, mut hi) = (0.0, 400.0);
    for _ in 0..40 {
        let mid = 0.5 * (lo + hi);
        if any_pair_within(tool, &at(mid), objects, 0.0, ws).unwrap() {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    hi
}

/// Runs the started `probe` in slices of `splits` node pairs (on `team`'s helper if given)
/// until it answers; the answer and the calls it took.
/// Starts a probe with `start`, again while the helper thread still holds one of its streams:
/// `Busy` is the documented answer when the helper was preempted mid-slice (a frame tries
/// again next time), which a loaded machine does to it at any moment.
fn when_free(mut start: impl FnMut() -> Result<(), collide::CollideError>) {
    let end = std::time::Instant::now() + std::time::Duration::from_secs(5);
    loop {
        match start() {
            Ok(()) => return,
            Err(collide::CollideError::Busy) if std::time::Instant::now() < end => {
                std::thread::sleep(std::time::Duration::from_millis(1));
            }
            Err(e) => panic!("the probe did not start: {e}"),
        }
    }
}

fn answer(
    probe: &mut FreeSpaceProbe,
    tool: &PackedTree,
    objects: &[PackedTree],
    splits: usize,
    team: Option<&TraversalTeam>,
) -> (ProbeStatus, usize) {
    let mut calls = 0;
    loop {
        calls += 1;
        let status = match team {
            Some(_) => probe.advance_shared(tool, objects, splits, team, None),
            None => probe.advance(tool, objects, splits),
        };
        if status != ProbeStatus::Running {
            return (status, calls);
        }
    }
}

#[test]
fn probe_in_slices_matches_any_pair_within_with_or_without_a_helper() {
    let tool = PackedTree::new(&random_tree(3, shape())).unwrap();
    let objects = vec![
        PackedTree::new(&random_tree(4, shape())).unwrap(),
        PackedTree::with_pose(
            &random_tree(5, shape()),
            &Pose::from_array([60.0, 0.0, 0.0, 0.0, 0.2, 0.0]),
        )
        .unwrap(),
    ];
    let team = TraversalTeam::new(&tool, &objects, 64).unwrap();
    let mut ws = CollideWorkspace::for_trees(&tool, &objects);
    let mut alone = FreeSpaceProbe::for_trees(&tool, &objects);
    let mut helped = FreeSpaceProbe::for_trees(&tool, &objects);
    let (mut sliced, mut free, mut touching) = (0, 0, 0);
    for k in 0..40 {
        // Along a direction, the distance where the tool just stops touching: poses near it
        // are barely free (deep descents) or barely touching.
        let dir = 0.15 * f64::from(k);
        let at = |s: f64| {
            Pose::from_array([
                s * dir.cos(),
                s * dir.sin(),
                0.0,
                0.1,
                0.2,
                0.05 * f64::from(k),
            ])
        };
        let hi = clear_from(&tool, &objects, &at, &mut ws);
        let x = hi + [0.05, -0.05, 0.6, 2.0][k as usize % 4];
        let q = at(x);
        for margin in [0.0, 0.5, 3.0] {
            let any = any_pair_within(&tool, &q, &objects, margin, &mut ws).unwrap();
            alone.start(&tool, &q, margin).unwrap();
            when_free(|| helped.start(&tool, &q, margin));
            let (status, calls) = answer(&mut alone, &tool, &objects, 2, None);
            // With the helper the answer is the same (after the same calls unless the helper
            // was held up: then its stream catches up later).
            let (with_helper, _) = answer(&mut helped, &tool, &objects, 2, Some(&team));
            assert_eq!(with_helper, status, "x {x}, margin {margin}");
            sliced += usize::from(calls > 2);
            let expected = if any {
                touching += 1;
                ProbeStatus::Touching
            } else {
                free += 1;
                ProbeStatus::Free
            };
            assert_eq!(status, expected, "x {x}, margin {margin}");
            let (taken, pose, m) = alone.take();
            assert_eq!(taken, status);
            assert_eq!((pose, m), (q, margin));
            assert_eq!(alone.status(), ProbeStatus::Idle);
        }
    }
    // Most answers come within the streams' serial start; a few need slices.
    assert!(
        sliced >= 5,
        "only {sliced} probes needed more than two slices"
    );
    assert!(
        free > 10 && touching > 10,
        "{free} free, {touching} touching"
    );
}

/// A probe the helper finished between two calls is seen finished at the next call (its
/// streams' published states are read when its job has ended), not left running.
#[test]
fn a_probe_finished_in_the_background_is_seen_finished() {
    let tool = PackedTree::new(&random_tree(3, shape())).unwrap();
    let objects = vec![PackedTree::new(&random_tree(4, shape())).unwrap()];
    let team = TraversalTeam::new(&tool, &objects, 64).unwrap();
    let mut probe = FreeSpaceProbe::for_trees(&tool, &objects);
    let mut ws = CollideWorkspace::for_trees(&tool, &objects);
    for k in 0..20 {
        let q = Pose::from_array([-60.0 + 6.0 * f64::from(k), 8.0, 0.0, 0.1, 0.2, 0.0]);
        let expected = if any_pair_within(&tool, &q, &objects, 0.5, &mut ws).unwrap() {
            ProbeStatus::Touching
        } else {
            ProbeStatus::Free
        };
        probe.start(&tool, &q, 0.5).unwrap();
        let mut status = probe.advance_shared(&tool, &objects, 2, Some(&team), None);
        for _ in 0..200 {
            if status != ProbeStatus::Running {
                break;
            }
            // Time for the helper to finish the probe in the background between calls.
            std::thread::sleep(std::time::Duration::from_millis(1));
            status = probe.advance_shared(&tool, &objects, 2, Some(&team), None);
        }
        assert_eq!(status, expected, "pose {k}");
    }
}

/// A probe along a straight path answers as the swept traversal does (free exactly when
/// `overlap_swept` finds no pair), with or without the helper, and a free answer holds at
/// every pose sampled along the path.
#[test]
fn a_probe_along_a_path_matches_the_swept_traversal() {
    let tool = PackedTree::new(&random_tree(6, shape())).unwrap();
    let objects = vec![PackedTree::new(&random_tree(7, shape())).unwrap()];
    let team = TraversalTeam::new(&tool, &objects, 64).unwrap();
    let mut ws = CollideWorkspace::for_trees(&tool, &objects);
    let mut alone = FreeSpaceProbe::for_trees(&tool, &objects);
    let mut helped = FreeSpaceProbe::for_trees(&tool, &objects);
    let (mut free, mut touching) = (0, 0);
    for k in 0..60 {
        // Start just clear of the object along a direction, then slide across or away.
        let dir = 0.37 * f64::from(k);
        let at = |s: f64| Pose::from_array([s * dir.cos(), s * dir.sin(), 0.0, 0.1, 0.2, 0.3]);
        let hi = clear_from(&tool, &objects, &at, &mut ws);
        let q = at(hi + 1.0);
        let turn = 0.5 + 0.2 * f64::from(k % 7);
        let length = [0.5, 3.0, 10.0][k as usize % 3];
        let path = [
            length * (dir + turn).cos(),
            length * (dir + turn).sin(),
            0.3 * length,
        ];
        for margin in [0.0, 0.5] {
            let sweep = Sweep {
                translation: path,
                rotation: [0.0; 3],
            };
            let mut swept_pairs = 0;
            overlap_swept(&tool, &q, &sweep, &objects, margin, &mut ws, |_| {
                swept_pairs += 1
            })
            .unwrap();
            alone.start_along(&tool, &q, path, margin).unwrap();
            when_free(|| helped.start_along(&tool, &q, path, margin));
            let (status, _) = answer(&mut alone, &tool, &objects, 3, None);
            let (with_helper, _) = answer(&mut helped, &tool, &objects, 3, Some(&team));
            assert_eq!(with_helper, status);
            assert_eq!(alone.path(), path);
            if swept_pairs == 0 {
                assert_eq!(status, ProbeStatus::Free, "k {k}, margin {margin}");
                free += 1;
                for i in 0..=20 {
                    let s = f64::from(i) / 20.0;
                    let mut p = q;
                    for (a, step) in path.iter().enumerate() {
                        p.q[a] += s * step;
                    }
                    assert!(!any_pair_within(&tool, &p, &objects, margin, &mut ws).unwrap());
                }
            } else {
                assert_eq!(status, ProbeStatus::Touching, "k {k}, margin {margin}");
                touching += 1;
            }
        }
    }
    assert!(
        free > 10 && touching > 10,
        "{free} free, {touching} touching"
    );
}
