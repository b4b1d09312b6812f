//! The solver × N table of docs/benchmarks/qp.md: median µs, iterations, max violation and
//! objective gap, on the same seeded instances as the criterion bench.
//!
//! Run: `cargo run -p qp --release --example qp_table [-- --reps 15 --set 16 --tight-large 1]`.
//!
//! Timing: each solve is repeated `reps` times (after one untimed warm-up solve) and the
//! median of all per-solve times over the set is reported (robust to preemption on a busy
//! machine, unlike a mean over batches); the criterion bench is the reference for speed, this
//! table adds the accuracy columns. The objective gap is relative to the exact optimum (the
//! dual solver, whose certified duality gap is checked here too), over the instances whose
//! optimum is not 0.

#[path = "../tests/common/mod.rs"]
mod common;

use std::time::Instant;

use qp::{ActiveSetWorkspace, DualWorkspace, PqpParams, PqpWorkspace, Solution, Status};

struct Row {
    name: &'static str,
    n: usize,
    times_us: Vec<f64>,
    iters: Vec<u32>,
    max_viol: f64,
    gaps: Vec<f64>,
    not_solved: usize,
}

impl Row {
    fn new(name: &'static str, n: usize) -> Self {
        Row {
            name,
            n,
            times_us: Vec::new(),
            iters: Vec::new(),
            max_viol: 0.0,
            gaps: Vec::new(),
            not_solved: 0,
        }
    }

    /// `gap` is `None` when the optimum is 0 (no relative gap).
    fn add(&mut self, times: &mut Vec<f64>, iters: u32, viol: f64, gap: Option<f64>, solved: bool) {
        self.times_us.append(times);
        self.iters.push(iters);
        self.max_viol = self.max_viol.max(viol);
        self.gaps.extend(gap);
        self.not_solved += (!solved) as usize;
    }
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    if v.is_empty() {
        f64::NAN
    } else {
        v[v.len() / 2]
    }
}

/// Times `reps` runs of `f` (after one warm-up), returning the last result and the times.
fn timed<R>(reps: usize, mut f: impl FnMut() -> R) -> (R, Vec<f64>) {
    let mut r = f();
    let mut t = Vec::with_capacity(reps);
    for _ in 0..reps {
        let s = Instant::now();
        r = std::hint::black_box(f());
        t.push(s.elapsed().as_secs_f64() * 1e6);
    }
    (r, t)
}

fn arg(name: &str, default: usize) -> usize {
    let args: Vec<String> = std::env::args().collect();
    args.iter()
        .position(|a| a == name)
        .and_then(|i| args.get(i + 1))
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

fn main() {
    let reps = arg("--reps", 15);
    let set_len = arg("--set", 16);
    let tight_large = arg("--tight-large", 1);
    let mut rows: Vec<Row> = Vec::new();
    for n in common::BENCH_SIZES {
        let set = common::bench_set(n, set_len);
        let mut r_dual = Row::new("dual (cold)", n);
        let mut r_warm = Row::new("dual (warm, sequence)", n);
        let mut r_as = Row::new("active-set", n);
        let mut r_pp = Row::new("pqp (paper stop)", n);
        let mut r_pt = Row::new("pqp (tight stop)", n);
        let mut r_cl = Row::new("clarabel (defaults)", n);
        let tight_reps = if n >= 1000 { 1 } else { reps.min(5) };
        for (k, inst) in set.iter().enumerate() {
            let p = inst.problem();
            let mut dual = DualWorkspace::new();
            let (exact, mut t) = timed(reps, || dual.solve(&p, false));
            assert_eq!(
                exact.status,
                Status::Solved,
                "dual must solve the bench set"
            );
            assert!(exact.kkt.duality_gap <= 1e-9 * exact.objective);
            let f = exact.objective;
            let gap = |s: &Solution| (f > 0.0).then(|| (s.objective - f) / f);
            r_dual.add(
                &mut t,
                exact.iterations,
                exact.kkt.max_violation,
                Some(0.0),
                true,
            );

            let mut ws = ActiveSetWorkspace::new();
            let (s, mut t) = timed(reps, || ws.solve(&p, &inst.dq0));
            let ok = s.status == Status::Solved;
            r_as.add(&mut t, s.iterations, s.kkt.max_violation, gap(&s), ok);

            let mut ws = PqpWorkspace::with_params(PqpParams::paper());
            let (s, mut t) = timed(reps, || ws.solve(&p));
            let ok = s.status == Status::Solved;
            r_pp.add(&mut t, s.iterations, s.kkt.max_violation, gap(&s), ok);

            // The tight stop costs seconds per solve at large N: the first `tight_large`
            // instances there.
            if n < 1000 || k < tight_large {
                let mut ws = PqpWorkspace::with_params(PqpParams {
                    warm_start: false,
                    ..PqpParams::tight()
                });
                let (s, mut t) = timed(tight_reps, || ws.solve(&p));
                let ok = s.status == Status::Solved;
                r_pt.add(&mut t, s.iterations, s.kkt.max_violation, gap(&s), ok);
            }

            let (c, mut t) = timed(reps.min(5), || common::clarabel_with(inst, false));
            match c {
                Ok((x, fc, it)) => {
                    let viol = inst
                        .j
                        .iter()
                        .zip(&inst.d)
                        .map(|(r, d)| d - (0..6).map(|i| r[i] * x[i]).sum::<f64>())
                        .fold(0.0, f64::max);
                    let g = (f > 0.0).then(|| (fc - f) / f);
                    r_cl.add(&mut t, it, viol, g, true);
                }
                Err(_) => r_cl.add(&mut t, 0, f64::NAN, None, false),
            }
        }
        // Warm start on the slowly moving sequence (its own instances; gap vs cold dual).
        let seq = common::bench_sequence(n);
        let mut warm = DualWorkspace::new();
        let mut cold = DualWorkspace::new();
        for i in 0..2 * seq.len() {
            let inst = &seq[common::ping_pong(i, seq.len())];
            let p = inst.problem();
            let f = cold.solve(&p, false).objective;
            let g = |o: f64| (f > 0.0).then(|| (o - f) / f);
            // Time a single warm solve per frame (repeating it would start from its own answer).
            let s0 = Instant::now();
            let s = std::hint::black_box(warm.solve(&p, true));
            let mut t = vec![s0.elapsed().as_secs_f64() * 1e6];
            let ok = s.status == Status::Solved;
            r_warm.add(
                &mut t,
                s.iterations,
                s.kkt.max_violation,
                g(s.objective),
                ok,
            );
        }
        rows.extend([r_dual, r_warm, r_as, r_pp, r_pt, r_cl]);
    }

    println!("| solver | N | median µs | iterations mean / max | max violation (mm) | instances | objective \\|gap\\| mean / max | not Solved |");
    println!("|---|---:|---:|---:|---:|---:|---:|---:|");
    for r in &mut rows {
        let med = median(&mut r.times_us);
        let it_mean = r.iters.iter().map(|&v| v as f64).sum::<f64>() / r.iters.len() as f64;
        let it_max = r.iters.iter().copied().max().unwrap_or(0);
        let g_mean = r.gaps.iter().map(|g| g.abs()).sum::<f64>() / r.gaps.len().max(1) as f64;
        let g_max = r.gaps.iter().map(|g| g.abs()).fold(0.0, f64::max);
        println!(
            "| {} | {} | {:.1} | {:.1} / {} | {:.2e} | {} | {:.2e} / {:.2e} | {} |",
            r.name,
            r.n,
            med,
            it_mean,
            it_max,
            r.max_viol,
            r.iters.len(),
            g_mean,
            g_max,
            r.not_solved
        );
    }
}
