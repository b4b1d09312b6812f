//! Builders on the bundled bunny: valid trees (every parent contains its children), coverage
//! at every level, the tight targets at depth 4, determinism for a seed, clear errors.

mod build_util;

use mesh::TriMesh;
use spheretree::build::{build_tree, BuildMethod, BuildParams};
use spheretree::eval::{evaluate_fit, FitParams, LevelFit};
use spheretree::TreeError;

fn report(name: &str, fit: &[LevelFit]) {
    for l in fit {
        eprintln!(
            "{name} L{} n={} worst={:.1} mean={:.2} worst162={:.1} mean162={:.2} cov={:.4}% gap={:.2}",
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
}

#[test]
fn octree_depth4_is_valid_and_covers_everything() {
    let mesh = build_util::bunny();
    let tree = build_tree(&mesh, &BuildParams::fastest_build(4), &|_| {}).unwrap();
    tree.validate(0.0).unwrap();
    assert_eq!(tree.len(), 4681);
    let fit = evaluate_fit(&tree, &mesh, &FitParams::default());
    report("octree", &fit);
    for l in &fit {
        assert_eq!(l.coverage, 1.0, "level {}", l.level);
    }
    let leaf = fit.last().unwrap();
    // Same cells as the toolkit's octree (783 leaves), but each leaf bounds only the surface
    // inside its cell: tighter than the toolkit's 211 / 113.
    assert!((700..900).contains(&leaf.count), "{leaf:?}");
    assert!(leaf.worst < 211.0 && leaf.mean < 113.0, "{leaf:?}");
}

#[test]
fn tight_depth3_is_valid_covers_every_level_and_is_deterministic() {
    let mesh = build_util::bunny();
    let params = BuildParams::tightest(3);
    let progress_calls = std::sync::atomic::AtomicUsize::new(0);
    let tree = build_tree(&mesh, &params, &|f| {
        assert!((0.0..=1.0).contains(&f));
        progress_calls.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    })
    .unwrap();
    assert!(progress_calls.into_inner() >= 2);
    tree.validate(0.0).unwrap();
    assert_eq!(tree.len(), 585);
    let fit = evaluate_fit(&tree, &mesh, &FitParams::default());
    report("tight-d3", &fit);
    for l in &fit {
        assert!(l.coverage >= 0.999, "level {}: {l:?}", l.level);
    }
    let leaf = fit.last().unwrap();
    assert_eq!(leaf.count, 512);
    // Equal-budget patches of this size cannot match the toolkit's adaptive medial tree at
    // depth 3 on the worst sphere; the mean is a regression guard.
    assert!(leaf.mean < 18.0, "{leaf:?}");

    // Same seed, same tree, whatever the number of threads.
    let again = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| build_tree(&mesh, &params, &|_| {}).unwrap());
    assert_eq!(tree, again, "same seed, same tree");
    let other = build_tree(
        &mesh,
        &BuildParams {
            seed: 99,
            ..params.clone()
        },
        &|_| {},
    )
    .unwrap();
    assert_ne!(tree, other, "the seed drives the samples");
    other.validate(0.0).unwrap();
}

#[test]
fn tight_depth4_meets_the_targets() {
    let mesh = build_util::bunny();
    let tree = build_tree(&mesh, &BuildParams::default(), &|_| {}).unwrap();
    tree.validate(0.0).unwrap();
    let fit = evaluate_fit(&tree, &mesh, &FitParams::default());
    report("tight-d4", &fit);
    for l in &fit {
        assert!(l.coverage >= 0.999, "level {}: {l:?}", l.level);
    }
    let leaf = fit.last().unwrap();
    // The targets (toolkit units): worst <= 25, mean <= 5, coverage >= 99.9 %.
    assert!(leaf.mean <= 5.0, "{leaf:?}");
    assert!(leaf.worst <= 25.0, "{leaf:?}");
    assert!(leaf.coverage >= 0.999, "{leaf:?}");
}

#[test]
fn bad_inputs_are_refused_with_a_reason() {
    let empty = TriMesh::default();
    let e = build_tree(&empty, &BuildParams::default(), &|_| {}).unwrap_err();
    assert!(matches!(e, TreeError::Build(_)), "{e}");
    let mesh = build_util::bunny();
    let e = build_tree(
        &mesh,
        &BuildParams {
            branching: 4,
            method: BuildMethod::Octree,
            depth: 2,
            ..BuildParams::default()
        },
        &|_| {},
    )
    .unwrap_err();
    assert!(e.to_string().contains("branching >= 8"), "{e}");
    // The tight builder takes any branching.
    let t = build_tree(
        &mesh,
        &BuildParams {
            branching: 4,
            depth: 2,
            ..BuildParams::default()
        },
        &|_| {},
    )
    .unwrap();
    t.validate(0.0).unwrap();
    assert_eq!(t.used_on_level(2), 16);
    // Depth 0: a single sphere around the whole mesh, for both builders.
    for method in [BuildMethod::Tight, BuildMethod::Octree] {
        let one = build_tree(
            &mesh,
            &BuildParams {
                depth: 0,
                method,
                ..BuildParams::default()
            },
            &|_| {},
        )
        .unwrap();
        one.validate(0.0).unwrap();
        assert_eq!(one.len(), 1);
        let fit = evaluate_fit(&one, &mesh, &FitParams::default());
        assert_eq!(fit[0].coverage, 1.0, "{method:?}: {:?}", fit[0]);
    }
    assert!("medial".parse::<BuildMethod>().is_err());
    assert_eq!(
        "octree".parse::<BuildMethod>().unwrap(),
        BuildMethod::Octree
    );
}

#[test]
fn builds_are_frame_and_scale_invariant() {
    // The same bunny in millimetres and moved far away: the tree moves and scales with it, and
    // the fit (in toolkit units) is the same.
    let mesh = build_util::bunny();
    let moved = TriMesh {
        vertices: mesh
            .vertices
            .iter()
            .map(|v| [v[0] * 25.4 + 1e4, v[1] * 25.4 - 3e3, v[2] * 25.4 + 7.0])
            .collect(),
        triangles: mesh.triangles.clone(),
    };
    for method in [BuildMethod::Tight, BuildMethod::Octree] {
        let params = BuildParams {
            depth: 2,
            method,
            ..BuildParams::default()
        };
        let a = build_tree(&mesh, &params, &|_| {}).unwrap();
        let b = build_tree(&moved, &params, &|_| {}).unwrap();
        b.validate(0.0).unwrap();
        let fa = evaluate_fit(&a, &mesh, &FitParams::default());
        let fb = evaluate_fit(&b, &moved, &FitParams::default());
        for (x, y) in fa.iter().zip(&fb) {
            assert_eq!(x.count, y.count, "{method:?}");
            assert!(
                (x.mean - y.mean).abs() <= 0.02 * x.mean.max(1.0),
                "{x:?} vs {y:?}"
            );
            assert!((x.coverage - y.coverage).abs() <= 0.001, "{x:?} vs {y:?}");
        }
        // The root sphere maps with the mesh.
        let (ra, rb) = (a.sphere(0), b.sphere(0));
        assert!((rb.radius - 25.4 * ra.radius).abs() <= 0.02 * rb.radius);
        assert!((rb.center[0] - (25.4 * ra.center[0] + 1e4)).abs() <= 0.05 * rb.radius);
    }
}
