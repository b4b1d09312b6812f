//! The `pqp-scaling` study of `haptic6d bench`: the paper's PQP serial, vectorized (one
//! thread) and vectorized on two threads, against the primal active set and the dual active
//! set, on the same QPs: QPs recorded from real frames (the bunny and spline trajectories
//! replayed with the dual solver on whole problems, `reduce_rows` off, and the bunny's
//! deepest frame with its detection skin grown to 2 000 … 16 000 rows) and generated
//! contact-like ones of N = 50 … 20 000 rows.
//!
//! Per QP and solver: iterations, time per solve (the paper's stop; median and p99 over
//! repetitions, cold: fresh multipliers, no warm active set) and time per PQP iteration
//! (`(t(K) - t(0)) / K` with `K` iterations forced, so the formation of `Q` is not counted),
//! and the speed-up per iteration over the serial PQP. The two parallel variants are one
//! [`qp::ParallelPqpWorkspace`] with 1 and 2 threads (workers spawned before the timing).
//! Written to `DIR/pqp_scaling.md` and the plots `DIR/bench_pqp_iteration.png` and
//! `DIR/bench_pqp_solve.png`.

use std::time::Instant;

use anyhow::{Context, Result};
use collide::Pose;
use engine::step::GodObject;
use engine::SolverKind;
use qp::{
    ActiveSetWorkspace, DualWorkspace, ParallelPqpWorkspace, PqpParams, PqpWorkspace,
    RecordedProblem, Solution,
};
use scene::cache::TreeCache;
use scene::stats::Summary;
use serde::Serialize;

/// The solver columns of the study, in table order.
pub const VARIANTS: [&str; 5] = ["pqp", "pqp-simd", "pqp-parallel", "active-set", "dual"];

/// One QP of the study.
pub struct StudyQp {
    /// Where it comes from (`bunny frame 812`, `generated`).
    pub source: String,
    /// The problem.
    pub qp: RecordedProblem,
}

/// One (QP, solver) cell.
#[derive(Clone, Debug, Serialize)]
pub struct PqpScalingRow {
    /// Where the QP comes from.
    pub source: String,
    /// Rows.
    pub n: usize,
    /// Solver variant ([`VARIANTS`]).
    pub solver: String,
    /// Threads used.
    pub threads: usize,
    /// Iterations of one solve (the paper's stop for the PQP variants).
    pub iterations: u32,
    /// Status of that solve.
    pub status: String,
    /// Time per solve, µs (empty when not run: see `note`).
    pub solve_us: Summary,
    /// Time per PQP iteration, µs (PQP variants only).
    pub iteration_us: Summary,
    /// Why a cell was not run.
    pub note: String,
}

/// Runs the study. `quick`: N up to 2 000, fewer repetitions.
pub fn pqp_study(cache: &TreeCache, quick: bool) -> Result<Vec<PqpScalingRow>> {
    let mut qps = recorded_qps(cache, quick)?;
    let sizes: &[usize] = if quick {
        &[50, 200, 1000, 2000]
    } else {
        &[50, 100, 200, 500, 1000, 2000, 5000, 10000, 20000]
    };
    for (i, &n) in sizes.iter().enumerate() {
        qps.push(StudyQp {
            source: "generated".into(),
            qp: generated(n, 45 + i as u64),
        });
    }
    let budget = if quick { 0.3 } else { 2.0 };
    let mut rows = Vec::new();
    for q in &qps {
        let n = q.qp.j.len();
        eprintln!("bench: pqp-scaling: {} ({n} rows)", q.source);
        for variant in VARIANTS {
            rows.push(measure(q, variant, budget)?);
        }
    }
    Ok(rows)
}

/// The real QPs: the frames of the bunny and spline trajectories (the dual solver on whole
/// problems; per scene the largest QP and those nearest 100 and 500 rows) and the bunny's
/// deepest frame with the skin grown until the QP holds 2 000 (and, in full mode, 5 000,
/// 10 000 and 16 000: the step's pair limit) rows.
fn recorded_qps(cache: &TreeCache, quick: bool) -> Result<Vec<StudyQp>> {
    let mut out = Vec::new();
    let window = if quick { 1500 } else { 4000 };
    let mut bunny_deepest: Option<(Pose, Pose)> = None;
    for name in ["bunny", "spline"] {
        let scene = scene::scenes::builtin(name, cache)
            .with_context(|| format!("loading the built-in scene `{name}`"))?;
        let traj: Vec<Pose> = scene
            .trajectory()
            .samples
            .iter()
            .take(window)
            .map(|s| Pose::from_array(s.q))
            .collect();
        let mut params = scene.engine_config();
        params.solver = SolverKind::Dual;
        params.reduce_rows = false;
        let mut god = GodObject::new(&scene.tool, &scene.objects, params)?;
        god.solver_mut().record(true);
        let Some(first) = traj.first() else { continue };
        god.reset(first)?;
        let mut seen: Vec<(usize, RecordedProblem)> = Vec::new();
        let mut prev = god.q_g();
        let mut most = 0u32;
        for (k, q) in traj.iter().enumerate() {
            let f = god.step(q);
            if f.pairs > most {
                most = f.pairs;
                bunny_deepest = (name == "bunny").then_some((prev, *q)).or(bunny_deepest);
            }
            prev = god.q_g();
            if let Some(r) = god.solver_mut().recorded() {
                if r.j.len() >= 20 {
                    seen.push((k, r.clone()));
                }
            }
            god.solver_mut().record(true);
        }
        let mut pick = |target: usize| {
            if let Some(i) = (0..seen.len()).min_by_key(|&i| seen[i].1.j.len().abs_diff(target)) {
                let (k, qp) = seen.swap_remove(i);
                if out.iter().any(|q: &StudyQp| q.qp.j.len() == qp.j.len()) {
                    return;
                }
                out.push(StudyQp {
                    source: format!("{name} frame {k}"),
                    qp,
                });
            }
        };
        pick(100);
        pick(500);
        pick(usize::MAX);
    }
    // The bunny's deepest frame, skin grown.
    if let Some((base, q_h)) = bunny_deepest {
        let scene = scene::scenes::builtin("bunny", cache)?;
        let targets: &[usize] = if quick {
            &[2000]
        } else {
            &[2000, 5000, 10000, 16000]
        };
        let grown = |skin: f64| -> Result<Option<RecordedProblem>> {
            let mut params = scene.engine_config();
            params.solver = SolverKind::Dual;
            params.reduce_rows = false;
            params.skin_mm = skin;
            params.relinearize = 0;
            let mut god = GodObject::new(&scene.tool, &scene.objects, params)?;
            god.reset(&base)?;
            god.solver_mut().record(true);
            god.step(&q_h);
            Ok(god.solver_mut().recorded().cloned())
        };
        let rows = |skin: f64| -> Result<usize> { Ok(grown(skin)?.map_or(0, |r| r.j.len())) };
        for &target in targets {
            let (mut lo, mut hi) = (0.0, 1.0);
            // The scene file's largest skin is 10 mm.
            while rows(hi)? < target && hi < 10.0 {
                lo = hi;
                hi = (hi * 2.0).min(10.0);
            }
            for _ in 0..6 {
                let mid = 0.5 * (lo + hi);
                if rows(mid)? < target {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            if let Some(qp) = grown(hi)? {
                if out.iter().all(|q| q.qp.j.len() != qp.j.len()) {
                    out.push(StudyQp {
                        source: format!("bunny deepest, skin {hi:.2} mm"),
                        qp,
                    });
                }
            }
        }
    }
    Ok(out)
}

/// A generated contact-like QP: `clusters` patches of nearly parallel contact normals with
/// lever arms of 5–60 mm, the hand pushed 0.1–2 mm into them (about a third of the rows
/// violated at `dq = 0`), the haptic weights.
pub fn generated(n: usize, seed: u64) -> RecordedProblem {
    let mut s = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let mut unit = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64
    };
    let dir = |u: &mut dyn FnMut() -> f64| -> [f64; 3] {
        let z = 2.0 * u() - 1.0;
        let t = std::f64::consts::TAU * u();
        let r = (1.0 - z * z).sqrt();
        [r * t.cos(), r * t.sin(), z]
    };
    let clusters = 6;
    let centres: Vec<([f64; 3], [f64; 3])> = (0..clusters)
        .map(|_| {
            let nrm = dir(&mut unit);
            let c = dir(&mut unit);
            let rad = 5.0 + 55.0 * unit();
            (nrm, [c[0] * rad, c[1] * rad, c[2] * rad])
        })
        .collect();
    let push = [0.6, -0.3, 0.8, 0.004, -0.002, 0.003];
    let mut j = Vec::with_capacity(n);
    let mut d = Vec::with_capacity(n);
    for k in 0..n {
        let (nc, cc) = centres[k % clusters];
        let jit = dir(&mut unit);
        let mut nv = [
            nc[0] + 0.05 * jit[0],
            nc[1] + 0.05 * jit[1],
            nc[2] + 0.05 * jit[2],
        ];
        let l = (nv[0] * nv[0] + nv[1] * nv[1] + nv[2] * nv[2]).sqrt();
        nv.iter_mut().for_each(|v| *v /= l);
        let off = dir(&mut unit);
        let c = [
            cc[0] + 0.5 * off[0],
            cc[1] + 0.5 * off[1],
            cc[2] + 0.5 * off[2],
        ];
        let m = [
            c[1] * nv[2] - c[2] * nv[1],
            c[2] * nv[0] - c[0] * nv[2],
            c[0] * nv[1] - c[1] * nv[0],
        ];
        let row = [nv[0], nv[1], nv[2], m[0], m[1], m[2]];
        let gap = 2.0 * unit();
        let along: f64 = (0..6).map(|i| row[i] * push[i]).sum();
        d.push(-gap - along);
        j.push(row);
    }
    RecordedProblem {
        g: [1.0, 1.0, 1.0, 1000.0, 1000.0, 1000.0],
        j,
        d,
    }
}

/// Iterations forced for the per-iteration time.
fn forced(k: u32) -> PqpParams {
    PqpParams {
        min_decrease: f64::NEG_INFINITY,
        max_iterations: k,
        ..PqpParams::paper()
    }
}

/// A solver of one variant, ready to time (workers spawned, buffers reserved).
enum Runner {
    Serial(PqpWorkspace),
    Parallel(ParallelPqpWorkspace),
    ActiveSet(Box<ActiveSetWorkspace>),
    Dual(Box<DualWorkspace>),
}

impl Runner {
    fn new(variant: &str, n: usize) -> Self {
        let mut r = match variant {
            "pqp" => Runner::Serial(PqpWorkspace::new()),
            "pqp-simd" => {
                Runner::Parallel(ParallelPqpWorkspace::with_threads(PqpParams::paper(), 1))
            }
            "pqp-parallel" => {
                Runner::Parallel(ParallelPqpWorkspace::with_threads(PqpParams::paper(), 2))
            }
            "active-set" => Runner::ActiveSet(Box::default()),
            _ => Runner::Dual(Box::default()),
        };
        match &mut r {
            Runner::Serial(w) => w.reserve(n),
            Runner::Parallel(w) => w.reserve(n),
            Runner::ActiveSet(w) => w.reserve(n),
            Runner::Dual(w) => w.reserve(n),
        }
        r
    }

    fn threads(&self) -> usize {
        match self {
            Runner::Parallel(w) => w.threads(),
            _ => 1,
        }
    }

    fn set_params(&mut self, p: PqpParams) {
        match self {
            Runner::Serial(w) => w.params = p,
            Runner::Parallel(w) => w.params = p,
            _ => {}
        }
    }

    fn solve(&mut self, q: &RecordedProblem) -> Option<Solution> {
        let p = q.problem()?;
        Some(match self {
            Runner::Serial(w) => w.solve(&p),
            Runner::Parallel(w) => w.solve(&p),
            // From the device pose (phase 1 when it violates rows), as a cold frame.
            Runner::ActiveSet(w) => w.solve(&p, &[0.0; 6]),
            Runner::Dual(w) => w.solve(&p, false),
        })
    }
}

/// Times `runner` on `q`: at least 3 and at most 200 solves, stopping after `budget` s.
fn timed(runner: &mut Runner, q: &RecordedProblem, budget: f64) -> (Vec<f64>, Option<Solution>) {
    let t0 = Instant::now();
    let mut times = Vec::new();
    let mut last = None;
    while times.len() < 3 || (times.len() < 200 && t0.elapsed().as_secs_f64() < budget) {
        let t = Instant::now();
        last = runner.solve(q);
        times.push(t.elapsed().as_secs_f64() * 1e6);
    }
    (times, last)
}

fn measure(q: &StudyQp, variant: &str, budget: f64) -> Result<PqpScalingRow> {
    let n = q.qp.j.len();
    let mut row = PqpScalingRow {
        source: q.source.clone(),
        n,
        solver: variant.into(),
        threads: 1,
        iterations: 0,
        status: String::new(),
        solve_us: Summary::default(),
        iteration_us: Summary::default(),
        note: String::new(),
    };
    let mut runner = Runner::new(variant, n);
    row.threads = runner.threads();
    let is_pqp = variant.starts_with("pqp");
    // The serial PQP holds N² numbers and takes O(6 N²) per solve to form them: past 10 000
    // rows its paper-stop solve is left out (tens of seconds), its iterations still timed.
    let full_solve = !(variant == "pqp" && n > 10_000);
    if full_solve {
        runner.set_params(PqpParams::paper());
        let (times, sol) = timed(&mut runner, &q.qp, budget);
        row.solve_us = Summary::of(times);
        if let Some(sol) = sol {
            row.iterations = sol.iterations;
            row.status = format!("{:?}", sol.status);
        }
    } else {
        row.note = "solve not run (N² = 3.2 GB, tens of seconds)".into();
    }
    if is_pqp {
        let k: u32 = if n >= 2000 { 10 } else { 30 };
        runner.set_params(forced(0));
        let (t0, _) = timed(&mut runner, &q.qp, budget / 4.0);
        let base = Summary::of(t0).p50;
        runner.set_params(forced(k));
        let (tk, _) = timed(&mut runner, &q.qp, budget / 2.0);
        row.iteration_us = Summary::of(tk.iter().map(|t| ((t - base) / f64::from(k)).max(0.0)));
    }
    Ok(row)
}

/// The study's markdown: one table (solve and iteration times), then where the parallel PQP
/// stands against the dual active set.
pub fn pqp_markdown(rows: &[PqpScalingRow]) -> String {
    let mut s = String::new();
    let w = ParallelPqpWorkspace::new();
    s.push_str(&format!(
        "pqp-simd and pqp-parallel: {} code; the entries of |Q| stored up to {} rows, recomputed every iteration above.\n\n",
        w.simd_name(),
        w.max_stored_rows
    ));
    s.push_str(
        "| QP | N | solver | threads | iterations | solve µs p50 / p99 | iteration µs p50 / p99 | per-iteration speed-up vs pqp |\n",
    );
    s.push_str("|---|---:|---|---:|---:|---:|---:|---:|\n");
    let mut k = 0;
    while k < rows.len() {
        let group: Vec<&PqpScalingRow> = rows[k..]
            .iter()
            .take_while(|r| r.source == rows[k].source && r.n == rows[k].n)
            .collect();
        let serial_it = group
            .iter()
            .find(|r| r.solver == "pqp")
            .map(|r| r.iteration_us.p50)
            .unwrap_or(f64::NAN);
        for r in &group {
            let solve = if r.solve_us.count > 0 {
                format!("{:.1} / {:.1}", r.solve_us.p50, r.solve_us.p99)
            } else {
                "—".into()
            };
            let (it, up) = if r.solver.starts_with("pqp") && r.iteration_us.count > 0 {
                (
                    format!("{:.2} / {:.2}", r.iteration_us.p50, r.iteration_us.p99),
                    format!("{:.2}×", serial_it / r.iteration_us.p50),
                )
            } else {
                ("".into(), "".into())
            };
            let iters = if r.solve_us.count > 0 {
                format!("{} ({})", r.iterations, r.status)
            } else {
                "—".into()
            };
            s.push_str(&format!(
                "| {} | {} | {} | {} | {} | {} | {} | {} |\n",
                r.source, r.n, r.solver, r.threads, iters, solve, it, up
            ));
        }
        k += group.len().max(1);
    }
    s.push('\n');
    s.push_str(&crossover(rows));
    s
}

/// Where the two-thread PQP's solve overtakes the dual solver's (median), if anywhere.
fn crossover(rows: &[PqpScalingRow]) -> String {
    let mut lines = Vec::new();
    let mut wins = Vec::new();
    for r in rows.iter().filter(|r| r.solver == "pqp-parallel") {
        let dual = rows
            .iter()
            .find(|d| d.solver == "dual" && d.source == r.source && d.n == r.n);
        if let Some(d) = dual {
            if r.solve_us.count > 0 && d.solve_us.count > 0 {
                let ratio = r.solve_us.p50 / d.solve_us.p50;
                if ratio < 1.0 {
                    wins.push(format!("{} ({} rows)", r.source, r.n));
                }
                lines.push(ratio);
            }
        }
    }
    let best = lines.iter().copied().fold(f64::INFINITY, f64::min);
    if wins.is_empty() {
        format!(
            "pqp-parallel (2 threads) overtakes the dual active set on none of these QPs: its solve is at best {best:.0}× the dual solver's (median).\n"
        )
    } else {
        format!(
            "pqp-parallel (2 threads) solves faster than the dual active set on: {}.\n",
            wins.join(", ")
        )
    }
}
