//! Criterion bench of the QP solvers on identical seeded instances (see
//! `tests/common/mod.rs`: `bench_set`, `bench_sequence`), N in {10, 50, 200, 1000, 2000}.
//!
//! Each iteration solves the next instance of the set (cycling), so the time is the mean over
//! the set. `dual_warm` walks a slowly moving 16-frame sequence back and forth, warm-starting
//! from the last active set.
//!
//! Two measurements of the same benchmarks: `qp/...` in wall-clock time (criterion's
//! default) and `qp_cpu/...` in this thread's CPU time (`CLOCK_THREAD_CPUTIME_ID`), which
//! excludes the time the thread is preempted on a busy machine (it still includes cache and
//! hyper-thread contention). Run: `cargo bench -p qp --bench solvers` (both), or
//! `-- qp_cpu` / `-- 'qp/'` for one.

#[path = "../tests/common/mod.rs"]
mod common;

use std::hint::black_box;
use std::time::Duration;

use criterion::measurement::{Measurement, ValueFormatter, WallTime};
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use qp::{ActiveSetWorkspace, DualWorkspace, PqpParams, PqpWorkspace};

/// Instances per size.
const SET: usize = 16;

/// This thread's CPU time (Linux: `clock_gettime(CLOCK_THREAD_CPUTIME_ID)`), in ns.
struct ThreadCpu;

fn thread_cpu_ns() -> f64 {
    devkit::thread_cpu_time().as_secs_f64() * 1e9
}

impl Measurement for ThreadCpu {
    type Intermediate = f64;
    type Value = f64;
    fn start(&self) -> f64 {
        thread_cpu_ns()
    }
    fn end(&self, i: f64) -> f64 {
        thread_cpu_ns() - i
    }
    fn add(&self, a: &f64, b: &f64) -> f64 {
        a + b
    }
    fn zero(&self) -> f64 {
        0.0
    }
    fn to_f64(&self, v: &f64) -> f64 {
        *v
    }
    fn formatter(&self) -> &dyn ValueFormatter {
        &CpuFormatter
    }
}

/// Formats CPU nanoseconds like criterion's wall time (ns, µs, ms, s).
struct CpuFormatter;

impl ValueFormatter for CpuFormatter {
    fn scale_values(&self, typical: f64, values: &mut [f64]) -> &'static str {
        let (div, unit) = if typical < 1e3 {
            (1.0, "ns cpu")
        } else if typical < 1e6 {
            (1e3, "µs cpu")
        } else if typical < 1e9 {
            (1e6, "ms cpu")
        } else {
            (1e9, "s cpu")
        };
        for v in values {
            *v /= div;
        }
        unit
    }
    fn scale_throughputs(&self, _typical: f64, t: &Throughput, values: &mut [f64]) -> &'static str {
        if let Throughput::Elements(n) = t {
            for v in values {
                *v = *n as f64 * 1e9 / *v;
            }
        }
        "elem/s cpu"
    }
    fn scale_for_machines(&self, _values: &mut [f64]) -> &'static str {
        "ns cpu"
    }
}

fn solvers_wall(c: &mut Criterion<WallTime>) {
    solvers(c, "qp", true);
}

fn solvers_cpu(c: &mut Criterion<ThreadCpu>) {
    solvers(c, "qp_cpu", false);
}

/// The benchmarks, named `{prefix}/n{N}/{solver}/{N}`; `tight` adds PQP with the tight stop.
fn solvers<M: Measurement>(c: &mut Criterion<M>, prefix: &str, tight: bool) {
    for n in common::BENCH_SIZES {
        let set = common::bench_set(n, SET);
        let seq = common::bench_sequence(n);
        let mut g = c.benchmark_group(format!("{prefix}/n{n}"));
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
        if tight && n <= 200 {
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

criterion_group!(wall, solvers_wall);
criterion_group! {
    name = cpu;
    config = Criterion::default().with_measurement(ThreadCpu);
    targets = solvers_cpu
}
criterion_main!(wall, cpu);
