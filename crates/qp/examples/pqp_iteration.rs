//! Time per PQP iteration of the serial solver and of the parallel one with its entries of
//! `|Q|` stored or recomputed, on 1 and 2 threads, on generated contact-like QPs.
//!
//! `cargo run --release -p qp --example pqp_iteration -- [N ...]` prints one line per `N`:
//! median µs per iteration (`(t(K) - t(0)) / K`, `K` iterations forced, so forming `Q` is
//! not counted) and the speed-ups over the serial solver. The default `N` are 1 000 … 20 000.

use std::time::Instant;

use qp::{ParallelPqpWorkspace, PqpParams, PqpWorkspace, Problem};

/// A contact-like QP: 6 patches of nearly parallel normals with lever arms of 5–60 mm, the
/// haptic weights (`G = diag(1, 1, 1, 1000, 1000, 1000)`).
fn generated(n: usize, seed: u64) -> (Vec<[f64; 6]>, Vec<f64>) {
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
    let centres: Vec<([f64; 3], [f64; 3])> = (0..6)
        .map(|_| {
            let nrm = dir(&mut unit);
            let c = dir(&mut unit);
            let rad = 5.0 + 55.0 * unit();
            (nrm, [c[0] * rad, c[1] * rad, c[2] * rad])
        })
        .collect();
    let (mut j, mut d) = (Vec::with_capacity(n), Vec::with_capacity(n));
    for k in 0..n {
        let (nc, c) = centres[k % 6];
        let jit = dir(&mut unit);
        let mut v = [0.0; 3];
        for i in 0..3 {
            v[i] = nc[i] + 0.05 * jit[i];
        }
        let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        v.iter_mut().for_each(|x| *x /= l);
        let m = [
            c[1] * v[2] - c[2] * v[1],
            c[2] * v[0] - c[0] * v[2],
            c[0] * v[1] - c[1] * v[0],
        ];
        j.push([v[0], v[1], v[2], m[0], m[1], m[2]]);
        d.push(-2.0 * unit() + 0.5);
    }
    (j, d)
}

fn forced(k: u32) -> PqpParams {
    PqpParams {
        min_decrease: f64::NEG_INFINITY,
        max_iterations: k,
        ..PqpParams::paper()
    }
}

/// Median µs per iteration of `solve` with `set(K)` applied.
fn per_iteration(mut solve: impl FnMut(u32) -> f64, k: u32, reps: usize) -> f64 {
    let med = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let t0 = med((0..reps).map(|_| solve(0)).collect());
    let tk = med((0..reps).map(|_| solve(k)).collect());
    (tk - t0) / f64::from(k)
}

fn main() {
    let args: Vec<usize> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let sizes = if args.is_empty() {
        vec![1000, 2000, 3000, 5000, 10000, 20000]
    } else {
        args
    };
    println!("N | serial | stored 1T | recomputed 1T | stored 2T | recomputed 2T | µs per iteration, median");
    for n in sizes {
        let (j, d) = generated(n, 45);
        let g = [1.0, 1.0, 1.0, 1000.0, 1000.0, 1000.0];
        let Ok(p) = Problem::new(g, &j, &d) else {
            continue;
        };
        let k = if n >= 2000 { 10 } else { 30 };
        let reps = if n >= 10000 { 3 } else { 7 };
        let serial = if n <= 10000 {
            let mut w = PqpWorkspace::new();
            per_iteration(
                |k| {
                    w.params = forced(k);
                    let t = Instant::now();
                    w.solve(&p);
                    t.elapsed().as_secs_f64() * 1e6
                },
                k,
                reps,
            )
        } else {
            f64::NAN
        };
        let par = |threads: usize, stored: bool| {
            let mut w = ParallelPqpWorkspace::with_threads(PqpParams::paper(), threads);
            w.max_stored_rows = if stored { usize::MAX } else { 0 };
            w.reserve(n);
            per_iteration(
                |k| {
                    w.params = forced(k);
                    let t = Instant::now();
                    w.solve(&p);
                    t.elapsed().as_secs_f64() * 1e6
                },
                k,
                reps,
            )
        };
        let s1 = par(1, true);
        let r1 = par(1, false);
        let s2 = par(2, true);
        let r2 = par(2, false);
        println!(
            "{n} | {serial:.0} | {s1:.0} ({:.2}×) | {r1:.0} ({:.2}×) | {s2:.0} ({:.2}× of 1T) | {r2:.0} ({:.2}× of 1T)",
            serial / s1,
            serial / r1,
            s1 / s2,
            r1 / r2
        );
    }
}
