//! The parallel PQP's iterates against the serial PQP's: same status, same iteration count,
//! multipliers and `dq` equal to `1e-12` relative (to the largest multiplier and to `|dq|`),
//! on random, haptic-like, infeasible and degenerate problems of 1 to 20 000 rows, with the
//! vectorized and the baseline code, on 1, 2 and 3 threads, with the entries of `|Q|`
//! stored and recomputed in every iteration, after a fixed number of iterations and at the
//! paper's and the KKT stop. Stored and recomputed entries give the same iterates bit for
//! bit.
//!
//! The two compute `Q^+ y` and `Q^- y` with different roundings. A few solves amplify
//! rounding: the serial solver itself, given `d` moved by one ulp, then changes by more than
//! `1e-12` (a row whose multiplier is tiny while `(|Q| y)_k` is not has its ratio decided by
//! a cancellation; warm starts carry such rows in). There the bound is 100 times that
//! sensitivity of the serial solver, measured on the same solve.

mod common;

use common::Instance;
use qp::{ParallelPqpWorkspace, PqpParams, PqpWorkspace, Solution};

/// `max_k |a_k - b_k| / max_k |b_k|` (0 for two empty or zero vectors).
fn rel(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    let scale = b.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let diff = a
        .iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
    if diff == 0.0 {
        0.0
    } else {
        diff / scale
    }
}

/// The instruction sets of a run: the widest the CPU has, AVX2 at most, the baseline.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Isa {
    Widest,
    Avx2,
    Base,
}

/// (threads, instruction set, stored): three threads (more than this machine's cores) on
/// small problems only.
fn configs(n: usize) -> Vec<(usize, Isa, bool)> {
    let mut c = vec![];
    for stored in [true, false] {
        c.extend([
            (1, Isa::Widest, stored),
            (2, Isa::Widest, stored),
            (2, Isa::Avx2, stored),
            (2, Isa::Base, stored),
        ]);
        if n <= 64 {
            c.push((3, Isa::Widest, stored));
        }
    }
    c
}

/// A parallel workspace of `threads` threads whose entries are stored (or recomputed).
fn parallel(params: PqpParams, threads: usize, stored: bool) -> ParallelPqpWorkspace {
    let mut par = ParallelPqpWorkspace::with_threads(params, threads);
    par.max_stored_rows = if stored { usize::MAX } else { 0 };
    par
}

/// `inst` with every right-hand side moved by one ulp.
fn nudged(inst: &Instance) -> Instance {
    let mut i = inst.clone();
    i.d.iter_mut().for_each(|v| *v *= 1.0 + f64::EPSILON);
    i
}

/// The allowed relative difference of multipliers and of `dq`: `1e-12`, or 100 times the
/// serial solver's own change when `d` moves by one ulp (`s`, `ys` against `t`, `yt`).
fn bounds(s: &Solution, ys: &[f64], t: &Solution, yt: &[f64]) -> (f64, f64) {
    (
        (100.0 * rel(yt, ys)).max(1e-12),
        (100.0 * rel(&t.dq, &s.dq)).max(1e-12),
    )
}

/// Solves `inst` serially and in parallel with `params` and checks the two agree.
fn agree(inst: &Instance, params: PqpParams, what: &str) -> Solution {
    let p = inst.problem();
    let mut serial = PqpWorkspace::with_params(params);
    let s = serial.solve(&p);
    let near = nudged(inst);
    let mut other = PqpWorkspace::with_params(params);
    let t = other.solve(&near.problem());
    let bound = bounds(&s, serial.multipliers(), &t, other.multipliers());
    // Per thread count, the first run's multipliers and dq: the vector runs (AVX-512 or
    // AVX2, stored or recomputed) all give the same numbers, bit for bit.
    let mut first: Vec<(usize, Vec<f64>, [f64; 6])> = Vec::new();
    for (threads, isa, stored) in configs(p.len()) {
        let mut par = parallel(params, threads, stored);
        par.simd = isa != Isa::Base;
        par.avx512 = isa == Isa::Widest;
        // Exercise the threads even on small problems.
        par.min_parallel_rows = 1;
        let q = par.solve(&p);
        let tag = format!(
            "{what}, N = {}, {threads} threads, {} ({isa:?}), stored {stored}",
            p.len(),
            par.simd_name()
        );
        check(&s, serial.multipliers(), &q, par.multipliers(), bound, &tag);
        if isa == Isa::Base || !par.simd_active() {
            continue;
        }
        match first.iter().find(|r| r.0 == threads) {
            Some((_, y, dq)) => {
                assert_eq!(y.as_slice(), par.multipliers(), "{tag}: bit for bit");
                assert_eq!(dq, &q.dq, "{tag}: dq bit for bit");
            }
            None => first.push((threads, par.multipliers().to_vec(), q.dq)),
        }
    }
    s
}

fn check(s: &Solution, ys: &[f64], q: &Solution, yq: &[f64], bound: (f64, f64), tag: &str) {
    assert_eq!(s.status, q.status, "{tag}: status");
    assert_eq!(s.iterations, q.iterations, "{tag}: iterations");
    let ry = rel(yq, ys);
    assert!(
        ry <= bound.0,
        "{tag}: multipliers differ by {ry:e} (relative), bound {:e}",
        bound.0
    );
    let rdq = rel(&q.dq, &s.dq);
    assert!(
        rdq <= bound.1,
        "{tag}: dq differs by {rdq:e} (relative), bound {:e}",
        bound.1
    );
}

/// Checks at `1e-12` exactly (no sensitivity allowance).
const STRICT: (f64, f64) = (1e-12, 1e-12);

/// A fixed number of iterations (no stop rule): the k-th iterate itself.
fn iterate(k: u32) -> PqpParams {
    PqpParams {
        min_decrease: f64::NEG_INFINITY,
        max_iterations: k,
        ..PqpParams::paper()
    }
}

#[test]
fn iterates_equal_the_serial_ones_on_random_and_haptic_problems() {
    let mut r = common::rng(45);
    for &n in &[1usize, 2, 3, 5, 7, 8, 9, 31, 33, 64, 100, 257, 1000, 1003] {
        let rand = common::random(n, &mut r);
        let hap = common::haptic(n, 1 + n % 5, 0.05, &mut r);
        let redundant = common::haptic(n, 2, 1e-9, &mut r);
        for (inst, what) in [
            (&rand, "random"),
            (&hap, "haptic"),
            (&redundant, "redundant"),
        ] {
            for k in [1, 2, 5, 20, 100] {
                agree(inst, iterate(k), &format!("{what}, {k} iterations"));
            }
            agree(inst, PqpParams::paper(), &format!("{what}, paper's stop"));
            if n <= 257 {
                agree(inst, PqpParams::tight(), &format!("{what}, KKT stop"));
            }
        }
    }
}

#[test]
fn iterates_equal_the_serial_ones_on_degenerate_problems() {
    let mut r = common::rng(7);
    let g = common::G_HAPTIC;
    let row = [0.3, -0.8, 0.52, 4.0, -2.0, 1.0];
    let cases: Vec<(Instance, &str)> = vec![
        // Every row the same.
        (
            Instance {
                g,
                j: vec![row; 37],
                d: vec![0.7; 37],
                dq0: [0.0; 6],
            },
            "identical rows",
        ),
        // Zero rows with d <= 0 (harmless) among real ones.
        (
            {
                let mut i = common::haptic(41, 3, 0.05, &mut r);
                for k in (0..41).step_by(5) {
                    i.j[k] = [0.0; 6];
                    i.d[k] = -1.0;
                }
                i
            },
            "zero rows, d <= 0",
        ),
        // A zero row with d > 0: infeasible at once.
        (
            {
                let mut i = common::random(19, &mut r);
                i.j[11] = [0.0; 6];
                i.d[11] = 0.5;
                i
            },
            "zero row, d > 0",
        ),
        // Opposing rows.
        (common::infeasible(50, &mut r), "infeasible"),
        (common::infeasible(1001, &mut r), "infeasible"),
        // All d <= 0: the answer is dq = 0 (multipliers decay).
        (
            {
                let mut i = common::random(203, &mut r);
                i.d.iter_mut().for_each(|d| *d = -d.abs() - 0.1);
                i
            },
            "all inactive",
        ),
        // Rows scaled over twelve orders of magnitude.
        (
            {
                let mut i = common::haptic(120, 4, 0.05, &mut r);
                for (k, (jr, d)) in i.j.iter_mut().zip(&mut i.d).enumerate() {
                    let s = 10f64.powi((k % 13) as i32 - 6);
                    jr.iter_mut().for_each(|v| *v *= s);
                    *d *= s;
                }
                i
            },
            "badly scaled rows",
        ),
    ];
    for (inst, what) in &cases {
        for k in [1, 3, 50] {
            agree(inst, iterate(k), &format!("{what}, {k} iterations"));
        }
        agree(inst, PqpParams::paper(), &format!("{what}, paper's stop"));
        if inst.j.len() <= 257 {
            agree(inst, PqpParams::tight(), &format!("{what}, KKT stop"));
        }
    }
    // N = 0.
    let empty = Instance {
        g,
        j: vec![],
        d: vec![],
        dq0: [0.0; 6],
    };
    agree(&empty, PqpParams::paper(), "empty");
}

#[test]
fn iterates_equal_the_serial_ones_on_large_problems() {
    let mut r = common::rng(99);
    for &(n, k) in &[(5_000usize, 30u32), (20_000, 2)] {
        let inst = common::haptic(n, 6, 0.05, &mut r);
        let p = inst.problem();
        let mut serial = PqpWorkspace::with_params(iterate(k));
        let s = serial.solve(&p);
        let ys = serial.multipliers().to_vec();
        drop(serial);
        for threads in [1, 2] {
            for stored in [true, false] {
                let mut par = parallel(iterate(k), threads, stored);
                let q = par.solve(&p);
                let tag = format!("haptic, N = {n}, {threads} threads, stored {stored}");
                check(&s, &ys, &q, par.multipliers(), STRICT, &tag);
            }
        }
    }
}

#[test]
fn warm_starts_and_changing_sizes_match_the_serial_stream() {
    // A stream of frames whose N changes, warm-started where N repeats: both solvers carry
    // the same multipliers from frame to frame.
    let params = PqpParams {
        warm_start: true,
        ..PqpParams::paper()
    };
    let mut r = common::rng(3);
    let frames: Vec<Instance> = (0..60)
        .map(|f| common::haptic([40, 40, 41, 700, 700, 9][f % 6], 3, 0.05, &mut r))
        .collect();
    let mut serial = PqpWorkspace::with_params(params);
    let mut other = PqpWorkspace::with_params(params);
    let mut par = ParallelPqpWorkspace::with_threads(params, 2);
    par.min_parallel_rows = 32;
    // Frames of 700 rows recompute their entries, the others store them.
    par.max_stored_rows = 100;
    let mut strict = 0;
    for (f, inst) in frames.iter().enumerate() {
        let p = inst.problem();
        let s = serial.solve(&p);
        let t = other.solve(&nudged(inst).problem());
        let q = par.solve(&p);
        let bound = bounds(&s, serial.multipliers(), &t, other.multipliers());
        strict += (bound == STRICT) as usize;
        let tag = format!("frame {f}, N = {}", p.len());
        check(&s, serial.multipliers(), &q, par.multipliers(), bound, &tag);
    }
    // Most frames are held to 1e-12 itself.
    assert!(strict >= 50, "only {strict} of 60 frames at 1e-12");
}

#[test]
fn clones_and_drops_stop_their_workers() {
    let inst = common::haptic(500, 3, 0.05, &mut common::rng(5));
    let a = ParallelPqpWorkspace::with_threads(PqpParams::paper(), 2);
    assert_eq!(a.threads(), 2);
    let mut b = a.clone();
    drop(a);
    b.min_parallel_rows = 1;
    let sol = b.solve(&inst.problem());
    assert!(sol.iterations > 0);
    drop(b);
}
