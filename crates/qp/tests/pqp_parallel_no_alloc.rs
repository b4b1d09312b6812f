//! The parallel PQP allocates nothing in a solve, in any thread: once reserved for the largest
//! `N`, a stream of solves of varying size (threaded and not) makes no allocation in the
//! caller or in the workers, and spawns no thread, whether the entries of `|Q|` are stored or
//! recomputed.
//!
//! The counter here is global (every thread), unlike `devkit::count_allocations` (this
//! thread only), so the workers' allocations count too; the file holds one test, so no other
//! test allocates meanwhile.

mod common;

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

use qp::{ParallelPqpWorkspace, PqpParams, Solver, SolverKind, Status};

struct Counting;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn warmed_up_parallel_solves_allocate_nothing_in_any_thread() {
    let mut r = common::rng(12);
    // Sizes on both sides of the parallel threshold, not multiples of the lane width.
    let frames: Vec<common::Instance> = (0..120)
        .map(|f| common::haptic(1 + (f * 97) % 1500, 1 + f % 7, 0.05, &mut r))
        .collect();
    let mut s = Solver::new(SolverKind::PqpParallel);
    s.pqp_parallel.params = PqpParams {
        warm_start: true,
        ..PqpParams::paper()
    };
    assert!(s.pqp_parallel.threads() >= 1);
    // Frames up to 700 rows store the entries of |Q|, larger ones recompute them.
    s.pqp_parallel.max_stored_rows = 700;
    s.reserve(1500);
    s.solve(&frames[0].problem(), &[0.0; 6]);
    let before = ALLOCATIONS.load(Ordering::SeqCst);
    let mut solved = 0;
    for _ in 0..2 {
        for inst in &frames {
            let sol = s.solve(&inst.problem(), &[0.0; 6]);
            solved += matches!(sol.status, Status::Solved | Status::Inexact) as usize;
        }
    }
    let n = ALLOCATIONS.load(Ordering::SeqCst) - before;
    assert_eq!(n, 0, "{n} allocations in 240 warmed-up solves");
    assert!(solved > 200, "only {solved} solved");

    // One thread and two, each reserved for the largest frame only, entries stored (the
    // caller's block then holds the whole triangle) and recomputed.
    for (threads, stored) in [(1, usize::MAX), (1, 0), (2, usize::MAX), (2, 0)] {
        let mut w = ParallelPqpWorkspace::with_threads(PqpParams::paper(), threads);
        w.max_stored_rows = stored;
        w.reserve(1500);
        let before = ALLOCATIONS.load(Ordering::SeqCst);
        for inst in &frames {
            w.solve(&inst.problem());
        }
        let n = ALLOCATIONS.load(Ordering::SeqCst) - before;
        assert_eq!(
            n, 0,
            "{n} allocations in 120 solves after reserve, {threads} threads, max_stored_rows {stored}"
        );
    }
}
