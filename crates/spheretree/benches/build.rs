//! Build and fit-measure times on the bundled bunny (depth 4, branching 8).
//!
//! `cargo bench -p spheretree --bench build`

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use spheretree::build::{build_tree, BuildMethod, BuildParams};
use spheretree::eval::{evaluate_fit, FitParams};
use std::path::PathBuf;

fn bunny() -> mesh::TriMesh {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../assets/bunny.obj");
    mesh::load_mesh(&path).expect("assets/bunny.obj").mesh
}

fn bench_build(c: &mut Criterion) {
    let mesh = bunny();
    let mut g = c.benchmark_group("bunny_d4");
    g.sample_size(10);
    for method in [BuildMethod::Octree, BuildMethod::Tight] {
        let params = BuildParams {
            method,
            ..BuildParams::default()
        };
        g.bench_function(format!("build_{}", method.name()), |b| {
            b.iter(|| build_tree(black_box(&mesh), &params, &|_| {}).expect("build"))
        });
    }
    let tree = build_tree(&mesh, &BuildParams::default(), &|_| {}).expect("build");
    g.bench_function("evaluate_fit_tight", |b| {
        b.iter(|| evaluate_fit(black_box(&tree), &mesh, &FitParams::default()))
    });
    g.finish();
}

criterion_group!(benches, bench_build);
criterion_main!(benches);
