//! Build and fit-measure times on the bundled bunny (depth 4, branching 8).
//!
//! `cargo bench -p spheretree --bench build`

use criterion::{criterion_group, criterion_main, Criterion};
use spheretree::build::{build_tree, BuildMethod, BuildParams};
use spheretree::eval::{evaluate_fit, FitParams};
use std::hint::black_box;
use std::path::PathBuf;
use std::time::Duration;

/// CPU time of this process so far (user + system, all threads, seconds), from
/// `/proc/self/stat` (Linux; clock ticks of 1/100 s). `None` elsewhere.
fn cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the parenthesised command name; utime and stime are fields 14 and 15.
    let rest = &stat[stat.rfind(')')? + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let utime: f64 = f.get(11)?.parse().ok()?;
    let stime: f64 = f.get(12)?.parse().ok()?;
    Some((utime + stime) / 100.0)
}

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
    // The machine is shared: also report the CPU time the build consumes (all threads, user +
    // system, from /proc/self/stat), which does not grow with other people's load the way
    // wall time does. Reported by criterion as a "time".
    if cpu_seconds().is_some() {
        let params = BuildParams::default();
        g.bench_function("build_tight_cpu_time", |b| {
            b.iter_custom(|iters| {
                let c0 = cpu_seconds().unwrap_or(0.0);
                for _ in 0..iters {
                    black_box(build_tree(&mesh, &params, &|_| {}).expect("build"));
                }
                Duration::from_secs_f64((cpu_seconds().unwrap_or(0.0) - c0).max(0.0))
            })
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
