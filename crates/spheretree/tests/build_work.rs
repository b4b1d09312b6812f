//! The tight builder's cost grows about linearly with the triangle count: the premise of the
//! published build times of 1 M- and 2 M-triangle meshes (docs/BENCHMARKS.md, measured by
//! `cargo run --release -p spheretree --example build_scaling -- sphere 10000 100000 1000000
//! 2000000`). Counted, not timed: the mesh queries' work ([`mesh::query::query_work`], nodes
//! visited plus triangles tested), which is most of a large mesh's build and does not depend
//! on the machine. A build whose queries grew faster than the mesh (a query budget that does
//! not shrink with the triangle count, a search that scans the whole mesh) fails here long
//! before a 1 M-triangle build would take minutes.
//!
//! One test in this file: the work counter is the process's, and another test's queries
//! running alongside would be counted too.

use mesh::generate;
use spheretree::build::{build_tree, BuildParams};

/// Mesh query work of a default build of a sphere of about `triangles` triangles.
fn build_work(triangles: usize) -> (usize, u64) {
    let mesh = generate::sphere_with_triangles(1.0, triangles);
    let before = mesh::query::query_work();
    let tree = build_tree(&mesh, &BuildParams::default(), &|_| {}).unwrap();
    let work = mesh::query::query_work() - before;
    tree.validate(0.0).unwrap();
    (mesh.triangles.len(), work)
}

#[test]
fn build_work_grows_about_linearly_with_the_triangles() {
    let builds = [50_000, 150_000, 450_000].map(build_work);
    for (n, w) in builds {
        eprintln!(
            "{n} triangles: query work {w} ({:.0} a triangle)",
            w as f64 / n as f64
        );
    }
    // Linear, with the queries' logarithmic depth as slack: each threefold mesh costs at most
    // 3 x 1.25 times as much (a part of the work, shaping and checking the leaves, depends on
    // the tree's size alone, so the growth is below linear at these sizes).
    for [(na, wa), (nb, wb)] in [[builds[0], builds[1]], [builds[1], builds[2]]] {
        let growth = (wb as f64 / wa as f64) / (nb as f64 / na as f64);
        assert!(
            growth <= 1.25,
            "{na} -> {nb} triangles: work {wa} -> {wb} ({growth:.2} times linear)"
        );
    }
    // The work each added triangle brings does not grow with the mesh (it would triple from
    // one step to the next if a part of the build were quadratic).
    let marginal =
        |(na, wa): (usize, u64), (nb, wb): (usize, u64)| (wb - wa) as f64 / (nb - na) as f64;
    let (first, second) = (
        marginal(builds[0], builds[1]),
        marginal(builds[1], builds[2]),
    );
    assert!(
        second <= 1.25 * first,
        "work per added triangle {first:.0} then {second:.0}"
    );
}
