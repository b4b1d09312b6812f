//! Constraint reduction against the full solve, per solver and problem size: a seeded
//! sequence of 200 haptic-like frames (clusters of near-parallel contacts drifting frame to
//! frame, as in a sliding contact), each solved whole and reduced, three times over; the
//! reduced solve warm-started from the last frame's active rows as the frame step does.
//! Prints median and p99 µs of each, the mean working-set size and rounds, and the largest
//! difference of the two answers.
//!
//! ```text
//! cargo run --release -p qp --example reduce_table
//! ```

#[path = "../tests/common/mod.rs"]
mod common;

use std::time::Instant;

use qp::{RowGeneration, Solver, SolverKind, Status};

fn percentile(sorted: &[f64], p: f64) -> f64 {
    sorted[((sorted.len() - 1) as f64 * p).round() as usize]
}

fn main() {
    println!("| solver | rows | full µs p50 / p99 | reduced µs p50 / p99 | working rows mean | rounds mean | max |Δdq| |");
    println!("|---|---|---|---|---|---|---|");
    for kind in [SolverKind::Dual, SolverKind::ActiveSet] {
        for n in [100usize, 300, 1000, 2500] {
            let frames = common::haptic_sequence(n, 200, 9);
            let (mut solver, mut full_solver) = (Solver::new(kind), Solver::new(kind));
            let (mut rows, mut whole) = (RowGeneration::new(), RowGeneration::new());
            rows.reserve(&mut solver, n);
            whole.reserve(&mut full_solver, n);
            let mut full_warm = [0usize; 6];
            let mut full_warm_len = 0;
            let (mut full_us, mut reduced_us) = (Vec::new(), Vec::new());
            let (mut working, mut rounds, mut worst) = (0usize, 0u32, 0.0f64);
            let mut warm = [0usize; 6];
            let mut warm_len = 0;
            for _ in 0..3 {
                for inst in &frames {
                    let p = inst.problem();
                    let t0 = Instant::now();
                    let full = whole.solve_full(
                        &mut full_solver,
                        &p,
                        &inst.dq0,
                        &full_warm[..full_warm_len],
                    );
                    full_us.push(t0.elapsed().as_secs_f64() * 1e6);
                    full_warm_len = whole.active_set().len().min(6);
                    full_warm[..full_warm_len]
                        .copy_from_slice(&whole.active_set()[..full_warm_len]);
                    let t0 = Instant::now();
                    let reduced = rows.solve(&mut solver, &p, &inst.dq0, &[], &warm[..warm_len]);
                    reduced_us.push(t0.elapsed().as_secs_f64() * 1e6);
                    warm_len = rows.active_set().len().min(6);
                    warm[..warm_len].copy_from_slice(&rows.active_set()[..warm_len]);
                    working += rows.stats().working_rows;
                    rounds += rows.stats().rounds;
                    if full.status == Status::Solved && reduced.status == Status::Solved {
                        for k in 0..6 {
                            worst = worst.max((full.dq[k] - reduced.dq[k]).abs());
                        }
                    }
                }
            }
            full_us.sort_by(f64::total_cmp);
            reduced_us.sort_by(f64::total_cmp);
            let m = full_us.len() as f64;
            println!(
                "| {kind} | {n} | {:.2} / {:.2} | {:.2} / {:.2} | {:.1} | {:.2} | {worst:.1e} |",
                percentile(&full_us, 0.5),
                percentile(&full_us, 0.99),
                percentile(&reduced_us, 0.5),
                percentile(&reduced_us, 0.99),
                working as f64 / m,
                rounds as f64 / m,
            );
        }
    }
}
