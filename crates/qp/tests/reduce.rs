//! Constraint reduction ([`qp::RowGeneration`]): on haptic-like problems with hundreds to
//! thousands of rows (clusters of near-parallel contact normals), the reduced solve gives the
//! full problem's answer — the same `dq` as the full dual solve and as Clarabel, every row
//! satisfied, a KKT certificate over all rows — from a working set of tens of rows; and it
//! allocates nothing once reserved.

mod common;

use qp::{RowGeneration, Solver, SolverKind, Status};

#[global_allocator]
static GLOBAL: devkit::CountingAllocator = devkit::CountingAllocator;

#[test]
fn reduced_answer_is_the_full_answer() {
    let mut r = common::rng(2026);
    let mut reduced_rows = Vec::new();
    for case in 0..300 {
        let n = 100 + (case * 53) % 2500;
        let inst = common::haptic(n, 1 + case % 9, 0.02 + 0.1 * (case % 3) as f64, &mut r);
        let p = inst.problem();
        let mut full = Solver::new(SolverKind::Dual);
        let want = full.solve(&p, &inst.dq0);
        assert_eq!(
            want.status,
            Status::Solved,
            "case {case}: the full solve failed"
        );

        let mut solver = Solver::new(SolverKind::Dual);
        let mut rg = RowGeneration::new();
        rg.reserve(&mut solver, n);
        let got = rg.solve(&mut solver, &p, &inst.dq0, &[], &[]);
        assert_eq!(got.status, Status::Solved, "case {case}");
        let scale = 1.0 + want.dq.iter().map(|v| v.abs()).fold(0.0, f64::max);
        for k in 0..6 {
            assert!(
                (got.dq[k] - want.dq[k]).abs() <= 1e-7 * scale,
                "case {case} (N = {n}): dq[{k}] {} vs full {}",
                got.dq[k],
                want.dq[k]
            );
        }
        // The certificate is over every row: feasible, stationary with the scattered
        // multipliers, which are non-negative.
        assert!(
            got.kkt.max_violation <= 1e-7 * scale,
            "case {case}: {:?}",
            got.kkt
        );
        assert!(
            got.kkt.stationarity <= 1e-6 * scale * 1000.0,
            "case {case}: {:?}",
            got.kkt
        );
        assert!(
            got.kkt.min_multiplier >= -1e-9,
            "case {case}: {:?}",
            got.kkt
        );
        assert_eq!(rg.multipliers().len(), n);
        assert!(rg.active_set().iter().all(|&k| k < n));
        let st = rg.stats();
        assert_eq!(st.rows, n);
        if !st.full {
            reduced_rows.push(st.working_rows as f64 / n as f64);
        }
    }
    // The point of it: most problems are solved on a small share of their rows.
    reduced_rows.sort_by(f64::total_cmp);
    assert!(
        reduced_rows.len() >= 250,
        "only {} reduced",
        reduced_rows.len()
    );
    let median = reduced_rows[reduced_rows.len() / 2];
    assert!(median < 0.2, "median working share {median}");
}

#[test]
fn reduced_answer_matches_clarabel() {
    let mut r = common::rng(7);
    for case in 0..40 {
        let inst = common::haptic(300 + 20 * case, 3, 0.05, &mut r);
        let mut solver = Solver::new(SolverKind::Dual);
        let mut rg = RowGeneration::new();
        rg.reserve(&mut solver, inst.j.len());
        let got = rg.solve(&mut solver, &inst.problem(), &inst.dq0, &[], &[]);
        let (want, _, ok) = common::clarabel(&inst).expect("clarabel solves it");
        assert!(ok);
        for k in 0..6 {
            assert!(
                (got.dq[k] - want[k]).abs() <= 1e-5 * (1.0 + want[k].abs()),
                "case {case}: dq {:?} vs clarabel {want:?}",
                got.dq
            );
        }
    }
}

#[test]
fn kept_rows_stay_and_small_problems_are_solved_whole() {
    let mut r = common::rng(3);
    let inst = common::haptic(500, 4, 0.05, &mut r);
    let mut solver = Solver::new(SolverKind::Dual);
    let mut rg = RowGeneration::new();
    rg.reserve(&mut solver, 500);
    // A row kept by the caller is in the working set even when slack (its multiplier is
    // read back from its original index).
    let keep = [499, 498];
    rg.solve(&mut solver, &inst.problem(), &inst.dq0, &keep, &[]);
    assert!(!rg.stats().full);
    let small = common::haptic(40, 2, 0.05, &mut r);
    rg.solve(&mut solver, &small.problem(), &small.dq0, &[], &[]);
    assert!(rg.stats().full && rg.stats().working_rows == 40);
    // PQP is never reduced (the paper's method, run as published).
    let mut pqp = Solver::new(SolverKind::Pqp);
    rg.reserve(&mut pqp, 500);
    rg.solve(&mut pqp, &inst.problem(), &inst.dq0, &[], &[]);
    assert!(rg.stats().full);
}

#[test]
fn reduced_solves_do_not_allocate() {
    let mut r = common::rng(5);
    let frames: Vec<common::Instance> = (0..200)
        .map(|f| common::haptic(65 + (f * 97) % 2000, 1 + f % 7, 0.05, &mut r))
        .collect();
    let mut solver = Solver::new(SolverKind::Dual);
    let mut rg = RowGeneration::new();
    rg.reserve(&mut solver, 2100);
    let (_, counts) = devkit::count_allocations(|| {
        for inst in &frames {
            rg.solve(&mut solver, &inst.problem(), &inst.dq0, &[], &[]);
        }
    });
    assert_eq!(counts.allocations, 0);
}
