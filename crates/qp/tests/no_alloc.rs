//! Thousands of solves under an allocation counter: once a workspace has seen the largest N,
//! no solver allocates, and the workspaces stop growing.
//!
//! (A counting allocator of our own rather than `assert_no_alloc`, whose release-mode
//! features would clash with other crates' choice under workspace feature unification.)

mod common;

use qp::{PqpParams, Solver, SolverKind, Status};

#[global_allocator]
static GLOBAL: devkit::CountingAllocator = devkit::CountingAllocator;

/// Allocations made by `f` on this thread.
fn allocations<R>(f: impl FnOnce() -> R) -> (R, usize) {
    let (r, counts) = devkit::count_allocations(f);
    (r, counts.allocations)
}

#[test]
fn counter_sees_allocations() {
    let (_, n) = allocations(|| std::hint::black_box(vec![1u8; 64]));
    assert!(n >= 1);
}

#[test]
fn warmed_up_solves_do_not_allocate() {
    // A haptic-like stream whose N varies frame to frame, below the warm-up size.
    let mut r = common::rng(11);
    let frames: Vec<common::Instance> = (0..400)
        .map(|f| common::haptic(1 + (f * 37) % 300, 1 + f % 7, 0.05, &mut r))
        .collect();
    for kind in SolverKind::ALL {
        let mut s = Solver::new(kind);
        if kind.is_pqp() {
            // The paper's stop, warm-started (exercises the warm path too).
            s.pqp.params = PqpParams {
                warm_start: true,
                ..PqpParams::paper()
            };
            s.pqp_parallel.params = s.pqp.params;
        }
        s.reserve(300);
        // Phase 1 of the active-set solver has its own buffers: warm them up too.
        s.solve(&frames[0].problem(), &[0.0; 6]);
        let mut solved = 0;
        let (_, n) = allocations(|| {
            for _ in 0..5 {
                for inst in &frames {
                    // Start at the device pose: infeasible when any d_k > 0 (phase 1 runs).
                    let sol = s.solve(&inst.problem(), &[0.0; 6]);
                    // Inexact: PQP's stop held with violation left (still a full solve).
                    solved += matches!(sol.status, Status::Solved | Status::Inexact) as usize;
                }
            }
        });
        assert_eq!(n, 0, "{kind}: {n} allocations in 2000 warmed-up solves");
        assert!(solved > 1000, "{kind}: only {solved} solved");
    }
}
