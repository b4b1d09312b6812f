//! The shared traversal lists exactly the plain traversal's pairs, in the same order with or
//! without a helper thread; a deadline stops it; dropping the team stops its thread.

mod common;

use collide::{
    overlap_shared, overlap_shared_proving, CollideWorkspace, PackedTree, Pose, Sweep,
    TraversalTeam,
};
use common::{dense_shape, pair_key, random_pose, random_tree, traversal_keys, PairKey};
use std::time::{Duration, Instant};

#[allow(clippy::too_many_arguments)]
fn shared(
    tool: &PackedTree,
    pose: &Pose,
    sweep: Option<&Sweep>,
    objects: &[PackedTree],
    margin: f64,
    ws: &mut CollideWorkspace,
    team: Option<&TraversalTeam>,
    deadline: Option<Instant>,
) -> (collide::SharedTraversal, Vec<PairKey>) {
    let mut found = Vec::new();
    let t = overlap_shared(
        tool,
        pose,
        sweep,
        objects,
        margin,
        None,
        ws,
        team,
        deadline,
        |p| found.push(pair_key(p)),
    )
    .unwrap();
    (t, found)
}

#[test]
fn shared_traversal_is_the_traversal_in_one_order_with_or_without_a_helper() {
    let tree = random_tree(11, dense_shape());
    let tool = PackedTree::new(&tree).unwrap();
    let objects = vec![
        PackedTree::new(&random_tree(12, dense_shape())).unwrap(),
        PackedTree::with_pose(
            &random_tree(13, dense_shape()),
            &Pose::from_array([40.0, 0.0, 0.0, 0.3, 0.0, 0.1]),
        )
        .unwrap(),
    ];
    let team = TraversalTeam::new(&tool, &objects, 1 << 16).unwrap();
    let mut ws = CollideWorkspace::for_trees(&tool, &objects);
    let mut rng = devkit::Rng::new(5);
    let mut helped = 0;
    let mut dense = 0;
    for i in 0..400 {
        let pose = random_pose(&mut rng, [-5.0, 45.0], 5.0);
        let sweep = Sweep {
            translation: [rng.range(-2.0, 2.0), rng.range(-2.0, 2.0), 0.0],
            rotation: [0.0, 0.0, rng.range(-0.05, 0.05)],
        };
        let sw = (i % 3 == 0).then_some(&sweep);
        let margin = rng.range(0.0, 1.0);
        let plain = traversal_keys(&tool, &pose, sw, &objects, margin, &mut ws);
        let (alone, by_one) = shared(&tool, &pose, sw, &objects, margin, &mut ws, None, None);
        let (with, by_two) = shared(
            &tool,
            &pose,
            sw,
            &objects,
            margin,
            &mut ws,
            Some(&team),
            None,
        );
        assert!(alone.complete && with.complete && !alone.helped);
        assert_eq!((alone.unreported, with.unreported), (0, 0));
        assert_eq!(alone.pairs, by_one.len());
        // The same pairs (and gaps, bit for bit) as the plain traversal ...
        let (mut a, mut b) = (plain.clone(), by_one.clone());
        a.sort_unstable();
        b.sort_unstable();
        assert_eq!(a, b, "query {i}");
        // ... and the same sequence whether the helper took the second half or not.
        assert_eq!(by_one, by_two, "query {i}");
        helped += usize::from(with.helped);
        dense += usize::from(plain.len() > 50);
    }
    assert!(
        dense > 20,
        "{dense} dense queries: the case does not exercise sharing"
    );
    if std::thread::available_parallelism().map_or(1, |n| n.get()) >= 2 {
        // On a loaded machine the helper thread may not have been scheduled during any of
        // those queries; it must still take a second half when given the time: the same dense
        // query again, for up to 5 s, each answer still the one without a helper.
        let pose = Pose::from_array([0.3, -0.2, 0.1, 0.01, 0.0, 0.01]);
        let (_, alone) = shared(&tool, &pose, None, &objects, 0.5, &mut ws, None, None);
        let end = std::time::Instant::now() + std::time::Duration::from_secs(5);
        while helped == 0 && std::time::Instant::now() < end {
            let (with, by_two) = shared(
                &tool,
                &pose,
                None,
                &objects,
                0.5,
                &mut ws,
                Some(&team),
                None,
            );
            assert_eq!(by_two, alone);
            helped += usize::from(with.helped);
        }
        assert!(helped > 0, "the helper never took a second half");
    }
}

#[test]
fn a_deadline_stops_the_shared_traversal_with_a_subset() {
    let tree = random_tree(21, dense_shape());
    let tool = PackedTree::new(&tree).unwrap();
    let objects = vec![PackedTree::new(&random_tree(21, dense_shape())).unwrap()];
    let team = TraversalTeam::new(&tool, &objects, 1 << 16).unwrap();
    let mut ws = CollideWorkspace::for_trees(&tool, &objects);
    let pose = Pose::from_array([0.3, -0.2, 0.1, 0.01, 0.0, 0.01]);
    let (full, all) = shared(&tool, &pose, None, &objects, 0.5, &mut ws, None, None);
    assert!(full.complete && all.len() > 100, "{full:?}");
    for team in [None, Some(&team)] {
        let past = Instant::now() - Duration::from_millis(1);
        let (t, some) = shared(&tool, &pose, None, &objects, 0.5, &mut ws, team, Some(past));
        assert!(!t.complete, "{t:?}");
        assert!(some.len() < all.len());
        assert!(some.iter().all(|p| all.contains(p)));
    }
}

#[test]
fn a_small_helper_buffer_counts_what_it_could_not_report() {
    let tree = random_tree(31, dense_shape());
    let tool = PackedTree::new(&tree).unwrap();
    let objects = vec![PackedTree::new(&random_tree(31, dense_shape())).unwrap()];
    let team = TraversalTeam::new(&tool, &objects, 4).unwrap();
    let mut ws = CollideWorkspace::for_trees(&tool, &objects);
    let pose = Pose::from_array([0.3, -0.2, 0.1, 0.01, 0.0, 0.01]);
    let (_, all) = shared(&tool, &pose, None, &objects, 0.5, &mut ws, None, None);
    for _ in 0..200 {
        let (t, listed) = shared(
            &tool,
            &pose,
            None,
            &objects,
            0.5,
            &mut ws,
            Some(&team),
            None,
        );
        assert_eq!(t.pairs, all.len());
        assert_eq!(listed.len() + t.unreported, all.len());
        assert_eq!(t.unreported > 0, t.helped, "{t:?}");
    }
}

#[test]
fn dropping_the_team_stops_its_thread() {
    let tree = random_tree(41, dense_shape());
    let tool = PackedTree::new(&tree).unwrap();
    let objects = vec![PackedTree::new(&random_tree(42, dense_shape())).unwrap()];
    // Each drop joins the helper: a helper that did not stop would hang this thread.
    let (done, finished) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let mut ws = CollideWorkspace::for_trees(&tool, &objects);
        for k in 0..20 {
            let team = TraversalTeam::new(&tool, &objects, 64).unwrap();
            // Some teams are dropped busy or spinning, some parked.
            if k % 2 == 0 {
                let pose = Pose::from_array([0.3, -0.2, 0.1, 0.01, 0.0, 0.01]);
                shared(
                    &tool,
                    &pose,
                    None,
                    &objects,
                    0.5,
                    &mut ws,
                    Some(&team),
                    None,
                );
            }
            drop(team);
        }
        let _ = done.send(());
    });
    assert!(
        finished.recv_timeout(Duration::from_secs(30)).is_ok(),
        "dropping a team did not stop its helper thread"
    );
}

/// A proving traversal reports exactly the plain traversal's pairs within its margin, and
/// proves the least gap beyond it (or its proof margin when no pair is that near), with or
/// without a helper: checked against the plain traversal at the proof margin.
#[test]
fn a_proving_traversal_lists_the_margin_and_proves_the_nearest_gap_beyond() {
    let tool = PackedTree::new(&random_tree(41, dense_shape())).unwrap();
    let objects = vec![PackedTree::new(&random_tree(42, dense_shape())).unwrap()];
    let team = TraversalTeam::new(&tool, &objects, 1 << 16).unwrap();
    let mut ws = CollideWorkspace::for_trees(&tool, &objects);
    let mut rng = devkit::Rng::new(7);
    let (mut narrowed, mut empty) = (0, 0);
    for i in 0..300 {
        // From a few pairs within the margins to none (the random clouds overlap nearer).
        let pose = random_pose(&mut rng, [40.0, 100.0], 3.0);
        let margin = rng.range(0.0, 0.3);
        let proof = margin + rng.range(0.0, 1.0);
        let wide = traversal_keys(&tool, &pose, None, &objects, proof, &mut ws);
        let gap = |k: &PairKey| f64::from_bits(k.3);
        let mut within: Vec<PairKey> = wide.iter().copied().filter(|k| gap(k) <= margin).collect();
        within.sort_unstable();
        let nearest_beyond = wide
            .iter()
            .map(gap)
            .filter(|&g| g > margin)
            .fold(proof, f64::min);
        for helper in [None, Some(&team)] {
            let mut found = Vec::new();
            let (t, proven) = overlap_shared_proving(
                &tool,
                &pose,
                &objects,
                margin,
                proof,
                &mut ws,
                helper,
                None,
                |p| found.push(pair_key(p)),
            )
            .unwrap();
            assert!(t.complete);
            assert_eq!(t.pairs, found.len());
            found.sort_unstable();
            assert_eq!(found, within, "query {i}");
            assert_eq!(proven, nearest_beyond, "query {i}");
        }
        narrowed += usize::from(nearest_beyond < proof);
        empty += usize::from(within.is_empty());
    }
    assert!(
        narrowed > 30 && empty > 30,
        "{narrowed} narrowed, {empty} empty"
    );
}

/// Bad input to a proving traversal: a non-finite pose is an error; a NaN or negative margin
/// is taken as 0, and a NaN proof margin gives the plain traversal (nothing proven beyond).
#[test]
fn a_proving_traversal_takes_bad_margins_as_the_plain_query_and_rejects_a_bad_pose() {
    let tool = PackedTree::new(&random_tree(51, dense_shape())).unwrap();
    let objects = vec![PackedTree::new(&random_tree(52, dense_shape())).unwrap()];
    let mut ws = CollideWorkspace::for_trees(&tool, &objects);
    let pose = Pose::from_array([60.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
    let bad = Pose::from_array([f64::NAN, 0.0, 0.0, 0.0, 0.0, 0.0]);
    let prove = |ws: &mut CollideWorkspace, q: &Pose, m: f64, proof: f64| {
        overlap_shared_proving(&tool, q, &objects, m, proof, ws, None, None, |_| {})
    };
    assert!(matches!(
        prove(&mut ws, &bad, 0.1, 0.3),
        Err(collide::CollideError::NonFinitePose)
    ));
    let at_zero = traversal_keys(&tool, &pose, None, &objects, 0.0, &mut ws).len();
    for m in [f64::NAN, -1.0] {
        let (t, proven) = prove(&mut ws, &pose, m, f64::NAN).unwrap();
        assert!(t.complete);
        assert_eq!(t.pairs, at_zero);
        assert_eq!(proven, 0.0);
    }
}
