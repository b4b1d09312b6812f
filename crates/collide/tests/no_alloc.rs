//! Thousands of queries and constraint fills allocate nothing once the workspace and buffers
//! are sized (a counting global allocator, on this thread only).

mod common;

use collide::{
    collect_pairs, fill_constraints, CollideWorkspace, ConstraintForm, PackedTree, Pose,
};
use common::{random_tree, TreeShape};

#[global_allocator]
static GLOBAL: devkit::CountingAllocator = devkit::CountingAllocator;

#[test]
fn queries_do_not_allocate() {
    let shape = TreeShape {
        levels: 4,
        branching: 8,
        extent: 50.0,
        p_used: 0.7,
        p_early_leaf: 0.05,
    };
    let tool = PackedTree::new(&random_tree(1, shape)).unwrap();
    let objects = vec![
        PackedTree::new(&random_tree(2, shape)).unwrap(),
        PackedTree::with_pose(
            &random_tree(3, shape),
            &Pose::from_array([30.0, 0.0, 0.0, 0.5, 0.0, 0.0]),
        )
        .unwrap(),
    ];
    let mut ws = CollideWorkspace::for_trees(&tool, &objects);
    let cap = tool.leaf_count() * objects.iter().map(|o| o.leaf_count()).sum::<usize>();
    let mut pairs = Vec::with_capacity(cap);
    let mut rows = vec![[0.0; 6]; cap];
    let mut rhs = vec![0.0; cap];
    let (total, counts) = devkit::count_allocations(|| {
        let mut total = 0;
        for i in 0..3000 {
            let s = i as f64 * 0.01;
            let q_h = Pose::from_array([20.0 * s.sin(), 10.0 * s.cos(), 5.0, s, 0.3 * s, -s]);
            let q_g = Pose::from_array([20.0 * s.sin() + 0.1, 10.0 * s.cos(), 5.0, s, 0.3 * s, -s]);
            let n = collect_pairs(&tool, &q_h, &objects, 0.5, &mut ws, &mut pairs).unwrap();
            fill_constraints(
                ConstraintForm::Squared,
                &q_g,
                &q_h,
                &pairs,
                &mut rows,
                &mut rhs,
            )
            .unwrap();
            total += n;
        }
        total
    });
    assert!(
        total > 1000,
        "the poses should produce contacts, got {total}"
    );
    assert_eq!(
        counts.allocations, 0,
        "queries allocated {} times",
        counts.allocations
    );
}

/// A warm-up reads every node's chunk once, top levels first, and allocates nothing.
#[test]
fn warming_reads_every_chunk_and_allocates_nothing() {
    let shape = TreeShape {
        levels: 5,
        branching: 8,
        extent: 50.0,
        p_used: 0.9,
        p_early_leaf: 0.0,
    };
    let tree = PackedTree::new(&random_tree(4, shape)).unwrap();
    let chunks = tree.len().div_ceil(collide::WARM_CHUNK_NODES);
    assert!(chunks > 2, "{} nodes: too few to need chunks", tree.len());
    let (read, counts) = devkit::count_allocations(|| {
        let mut acc = 0u32;
        let read = (0..chunks + 3)
            .filter(|&k| tree.warm_chunk(k, &mut acc))
            .count();
        std::hint::black_box(acc);
        read
    });
    assert_eq!(read, chunks);
    assert_eq!(counts.events(), 0);
}
