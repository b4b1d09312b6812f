//! Criterion bench of the QP solvers on identical seeded instances (see
//! `tests/common/mod.rs`: `bench_set`, `bench_sequence`), N in {10, 50, 200, 1000, 2000}.
//!
//! Each iteration solves the next instance of the set (cycling), so the time is the mean over
//! the set. `dual_warm` walks a slowly moving 64-frame sequence back and forth, warm-starting
//! from the last active set. Run: `cargo bench -p qp --bench solvers`.

#[path = "../tests/common/mod.rs"]
mod common;

use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use qp::{ActiveSetWorkspace, DualWorkspace, PqpParams, PqpWorkspace};

/// Instances per size.
const SET: usize = 16;

fn solvers(c: &mut Criterion) {
    for n in common::BENCH_SIZES {
        let set = common::bench_set(n, SET);
        let seq = common::bench_sequence(n);
        let mut g = c.benchmark_group(format!("qp/n{n}"));
        g.sample_size(if n >= 1000 { 10 } else { 30 })
            .warm_up_time(Duration::from_millis(300))
            .measurement_time(Duration::from_millis(if n >= 1000 { 1500 } else { 800 }));

        let mut ws = DualWorkspace::new();
        let mut i = 0;
        g.bench_function(BenchmarkId::new("dual_cold", n), |b| {
            b.iter(|| {
                i += 1;
                black_box(ws.solve(&set[i % SET].problem(), false))
            })
        });

        let mut ws = DualWorkspace::new();
        let mut i = 0;
        g.bench_function(BenchmarkId::new("dual_warm", n), |b| {
            b.iter(|| {
                i += 1;
                let inst = &seq[common::ping_pong(i, seq.len())];
                black_box(ws.solve(&inst.problem(), true))
            })
        });

        let mut ws = ActiveSetWorkspace::new();
        let mut i = 0;
        g.bench_function(BenchmarkId::new("active_set", n), |b| {
            b.iter(|| {
                i += 1;
                let inst = &set[i % SET];
                black_box(ws.solve(&inst.problem(), &inst.dq0))
            })
        });

        let mut ws = PqpWorkspace::with_params(PqpParams::paper());
        let mut i = 0;
        g.bench_function(BenchmarkId::new("pqp_paper", n), |b| {
            b.iter(|| {
                i += 1;
                black_box(ws.solve(&set[i % SET].problem()))
            })
        });

        // The tight stop needs thousands of O(N^2) iterations: too slow to sample at large N
        // (the table example times it once per instance there).
        if n <= 200 {
            let mut ws = PqpWorkspace::with_params(PqpParams {
                warm_start: false,
                ..PqpParams::tight()
            });
            let mut i = 0;
            g.bench_function(BenchmarkId::new("pqp_tight", n), |b| {
                b.iter(|| {
                    i += 1;
                    black_box(ws.solve(&set[i % SET].problem()))
                })
            });
        }

        let mut i = 0;
        g.bench_function(BenchmarkId::new("clarabel", n), |b| {
            b.iter(|| {
                i += 1;
                black_box(common::clarabel_with(&set[i % SET], false).ok())
            })
        });
        g.finish();
    }
}

criterion_group!(benches, solvers);
criterion_main!(benches);
