//! The tight builder on 1 M-triangle generated meshes (a sphere and a torus), depth 4: a
//! valid tree that covers the surface, with a moving progress report. Each build takes
//! 10–20 s of a 2-core machine (minutes when it is shared), so these are `#[ignore]`d (kept
//! out of CI) and run by hand:
//!
//! `cargo test -p spheretree --release --test build_large -- --ignored --nocapture`
//!
//! What CI checks instead: that the build's work grows about linearly with the triangle count
//! (`tests/build_work.rs`, counted, not timed). The published build times are measured by the
//! `build_scaling` example (docs/BENCHMARKS.md gives the command); a test does not time them.

use mesh::{generate, TriMesh};
use spheretree::build::{build_tree, BuildParams};
use spheretree::eval::{evaluate_fit, FitParams};
use std::sync::Mutex;
use std::time::Instant;

fn build_large(name: &str, mesh: &TriMesh) {
    assert!(mesh.triangles.len() >= 990_000, "{}", mesh.triangles.len());
    let t0 = Instant::now();
    // (fraction, seconds) at every progress report.
    let reports: Mutex<Vec<(f64, f64)>> = Mutex::new(Vec::new());
    let tree = build_tree(mesh, &BuildParams::default(), &|f| {
        reports
            .lock()
            .unwrap()
            .push((f, t0.elapsed().as_secs_f64()));
    })
    .unwrap();
    let seconds = t0.elapsed().as_secs_f64();
    tree.validate(0.0).unwrap();
    let reports = reports.into_inner().unwrap();
    // The progress moves: no silent stretch longer than a fifth of the build.
    let (longest_silence, from, to) = reports
        .windows(2)
        .map(|w| (w[1].1 - w[0].1, w[0].0, w[1].0))
        .fold((0.0, 0.0, 0.0), |a, b| if b.0 > a.0 { b } else { a });
    let fit = evaluate_fit(&tree, mesh, &FitParams::default());
    let leaf = fit.last().unwrap();
    eprintln!(
        "{name}: {} triangles, {seconds:.1} s, {} progress reports (longest silence {longest_silence:.1} s, from {from:.3} to {to:.3}), leaf {leaf:?}",
        mesh.triangles.len(),
        reports.len()
    );
    assert!(reports.len() > 100, "{}", reports.len());
    assert!(
        longest_silence <= 0.2 * seconds,
        "{longest_silence} of {seconds}"
    );
    assert!(leaf.coverage >= 0.999, "{leaf:?}");
    assert_eq!(leaf.count, 4096);
}

#[test]
#[ignore = "minutes per build: run by hand (see the module docs)"]
fn a_million_triangle_sphere() {
    build_large("sphere", &generate::sphere_with_triangles(1.0, 1_000_000));
}

#[test]
#[ignore = "minutes per build: run by hand (see the module docs)"]
fn a_million_triangle_torus() {
    build_large("torus", &generate::torus_with_triangles(1_000_000));
}
