//! The fit measure on the Sphere-Tree Construction Toolkit's own bunny trees lands on the
//! figures the toolkit printed for them (docs/DESIGN.md §The fit measure): octree d4 783 leaves,
//! worst 211, mean 113, 100 %; hubbard d4 2650, 162, 12.3, 99.94 %; medial d3 490 leaves,
//! 98.44 %.

mod build_util;

use spheretree::eval::{evaluate_fit, FitParams, LevelFit};

fn leaf_fit(name: &str) -> LevelFit {
    let mesh = build_util::bunny();
    let tree = build_util::bradshaw_in_mesh_frame(name, &mesh);
    let fit = evaluate_fit(&tree, &mesh, &FitParams::default());
    for l in &fit {
        eprintln!(
            "{name} L{} n={} worst={:.1} mean={:.2} worst162={:.1} mean162={:.2} cov={:.4}% gap={:.1}",
            l.level,
            l.count,
            l.worst,
            l.mean,
            l.worst162,
            l.mean162,
            100.0 * l.coverage,
            l.largest_gap
        );
    }
    fit.last().unwrap().clone()
}

fn near(got: f64, want: f64, rel: f64) -> bool {
    (got - want).abs() <= rel * want.abs()
}

#[test]
fn octree_file_matches_the_toolkit() {
    let l = leaf_fit("bunny-octree.sph");
    assert_eq!(l.count, 783);
    assert!(near(l.worst, 211.0, 0.02), "{l:?}");
    assert!(near(l.mean, 113.0, 0.02), "{l:?}");
    assert_eq!(l.coverage, 1.0);
}

#[test]
fn hubbard_file_matches_the_toolkit() {
    let l = leaf_fit("bunny-hubbard.sph");
    assert_eq!(l.count, 2650);
    assert!(near(l.worst, 162.0, 0.03), "{l:?}");
    assert!(near(l.mean, 12.3, 0.03), "{l:?}");
    assert!((l.coverage - 0.9994).abs() < 0.0003, "{l:?}");
}

#[test]
fn medial_file_coverage_matches_the_toolkit() {
    // The toolkit's printed errors for this file (27.7 / 7.1) were taken on a slightly
    // different sphere set (its Evaluation block counts 493 leaves, the file holds 490); the
    // coverage is a property of the file alone and matches.
    let l = leaf_fit("bunny-medial-d3.sph");
    assert_eq!(l.count, 490);
    assert!((l.coverage - 0.9844).abs() < 0.001, "{l:?}");
}
