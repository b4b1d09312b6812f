//! Edge cases and properties: empty and infeasible inputs, degenerate rows, non-finite data,
//! warm starts, the PQP fixed point, and proptest agreement between the exact solvers.

mod common;

use proptest::prelude::*;
use qp::{
    ActiveSetWorkspace, DualWorkspace, PqpParams, PqpWorkspace, Problem, QpError, Solver,
    SolverKind, Status,
};

const G: [f64; 6] = common::G_HAPTIC;

fn all_solvers() -> Vec<(SolverKind, Solver)> {
    SolverKind::ALL
        .iter()
        .map(|&k| (k, Solver::new(k)))
        .collect()
}

#[test]
fn empty_problem_gives_zero_step_for_every_solver() {
    let p = Problem::new(G, &[], &[]).unwrap();
    for (k, mut s) in all_solvers() {
        let sol = s.solve(&p, &[1.0; 6]);
        assert_eq!(sol.status, Status::Solved, "{k}");
        assert_eq!(sol.dq, [0.0; 6], "{k}");
        assert_eq!(sol.iterations, 0, "{k}");
        assert!(s.multipliers().is_empty(), "{k}");
    }
}

#[test]
fn problem_rejects_bad_input_with_a_reason() {
    let j = [[1.0; 6]];
    assert_eq!(
        Problem::new(G, &j, &[]).unwrap_err(),
        QpError::LengthMismatch { rows: 1, rhs: 0 }
    );
    let mut g = G;
    g[4] = 0.0;
    assert!(matches!(
        Problem::new(g, &j, &[0.0]),
        Err(QpError::BadWeight { axis: 4, .. })
    ));
    g[4] = f64::NAN;
    assert!(Problem::new(g, &j, &[0.0]).is_err());
    let bad = [[1.0, f64::INFINITY, 0.0, 0.0, 0.0, 0.0]];
    let p = Problem::new(G, &bad, &[0.0]).unwrap();
    assert_eq!(p.validate(), Err(QpError::NonFinite { row: 0 }));
    assert!(QpError::NonFinite { row: 3 }.to_string().contains("row 3"));
    assert_eq!(
        "active-set".parse::<SolverKind>().unwrap(),
        SolverKind::ActiveSet
    );
    assert!("simplex".parse::<SolverKind>().is_err());
}

#[test]
fn non_finite_data_is_a_numerical_error_not_a_panic() {
    let j = [
        [1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        [f64::NAN, 1.0, 0.0, 0.0, 0.0, 0.0],
    ];
    let d = [1.0, 1.0];
    let p = Problem::new(G, &j, &d).unwrap();
    for (k, mut s) in all_solvers() {
        let sol = s.solve(&p, &[2.0, 2.0, 0.0, 0.0, 0.0, 0.0]);
        assert_eq!(sol.status, Status::NumericalError, "{k}: {sol:?}");
        assert!(sol.dq.iter().all(|v| v.is_finite()), "{k}");
    }
    let d = [f64::NAN, 0.0];
    let j = [[1.0, 0.0, 0.0, 0.0, 0.0, 0.0]; 2];
    let p = Problem::new(G, &j, &d).unwrap();
    for (k, mut s) in all_solvers() {
        let sol = s.solve(&p, &[0.0; 6]);
        assert_eq!(sol.status, Status::NumericalError, "{k}: {sol:?}");
    }
}

#[test]
fn infeasible_instances_are_reported() {
    let mut pqp_detected = 0;
    for seed in 0..30u64 {
        let inst = common::infeasible(2 + (seed as usize * 7) % 60, &mut common::rng(seed));
        let p = inst.problem();
        let d = DualWorkspace::new().solve(&p, false);
        assert_eq!(d.status, Status::Infeasible, "dual seed {seed}");
        let a = ActiveSetWorkspace::new().solve(&p, &[0.0; 6]);
        assert_eq!(a.status, Status::Infeasible, "active-set seed {seed}");
        // The paper's stop may fire on an infeasible problem: the certificate tells.
        let q = PqpWorkspace::new().solve(&p);
        assert!(q.kkt.max_violation > 0.1, "pqp seed {seed}: {q:?}");
        let t = PqpWorkspace::with_params(PqpParams::tight()).solve(&p);
        assert!(
            matches!(t.status, Status::Infeasible | Status::MaxIterations),
            "pqp tight seed {seed}: {t:?}"
        );
        assert!(t.kkt.max_violation > 0.1, "pqp tight seed {seed}: {t:?}");
        pqp_detected += (t.status == Status::Infeasible) as usize;
        for s in [d, a, q, t] {
            assert!(s.dq.iter().all(|v| v.is_finite()));
        }
    }
    // PQP's divergence test is a bound that its slowly growing multipliers rarely reach
    // within the cap: most end with MaxIterations (and a large violation).
    println!("pqp tight flagged {pqp_detected}/30 as infeasible, the rest MaxIterations");
}

#[test]
fn zero_rows_are_ignored_or_infeasible() {
    let j = [[0.0; 6], [1.0, 0.0, 0.0, 0.0, 0.0, 0.0]];
    let p = Problem::new(G, &j, &[-1.0, 0.5]).unwrap();
    for (k, mut s) in all_solvers() {
        if k.is_pqp() {
            s.pqp.params = PqpParams::tight();
            s.pqp_parallel.params = PqpParams::tight();
        }
        let sol = s.solve(&p, &[1.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        assert_eq!(sol.status, Status::Solved, "{k}");
        assert!((sol.dq[0] - 0.5).abs() < 1e-5, "{k}: {sol:?}");
    }
    let p = Problem::new(G, &j, &[1e-3, 0.5]).unwrap();
    for (k, mut s) in all_solvers() {
        let sol = s.solve(&p, &[1.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        assert_eq!(sol.status, Status::Infeasible, "{k}: {sol:?}");
    }
}

/// Hundreds of identical and nearly identical rows (a flat contact patch): the exact solvers
/// keep at most one of each near-duplicate in the active set and stay exact.
#[test]
fn many_duplicate_rows_are_handled() {
    let mut j = Vec::new();
    let mut d = Vec::new();
    let base = [0.0, 0.0, 1.0, 10.0, -5.0, 0.0];
    for k in 0..500 {
        let eps = if k % 2 == 0 { 0.0 } else { 1e-13 * k as f64 };
        j.push([eps, 0.0, 1.0, 10.0, -5.0 + eps, 0.0]);
        d.push(0.7 - 1e-14 * (k % 3) as f64);
    }
    j.push([1.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
    d.push(0.2);
    let p = Problem::new(G, &j, &d).unwrap();
    // Minimum: 1/2 |z|^2 with n·z = 0.7 on the scaled base row plus x >= 0.2.
    let isg: Vec<f64> = G.iter().map(|g| 1.0 / g.sqrt()).collect();
    let n2: f64 = (0..6).map(|i| (base[i] * isg[i]).powi(2)).sum();
    let f_exp = 0.5 * 0.7 * 0.7 / n2 + 0.5 * 0.2 * 0.2;
    let mut dual = DualWorkspace::new();
    let s = dual.solve(&p, false);
    assert_eq!(s.status, Status::Solved);
    assert!(
        (s.objective - f_exp).abs() < 1e-9 * f_exp,
        "{s:?} vs {f_exp}"
    );
    assert!(dual.active_set().len() <= 2, "{:?}", dual.active_set());
    let s2 = ActiveSetWorkspace::new().solve(&p, &[1.0, 0.0, 1.0, 0.0, 0.0, 0.0]);
    assert_eq!(s2.status, Status::Solved);
    assert!((s2.objective - f_exp).abs() < 1e-9 * f_exp, "{s2:?}");
}

#[test]
fn warm_start_gives_the_cold_answer_with_less_work() {
    let seq = common::haptic_sequence(200, 60, 42);
    let mut warm = DualWorkspace::new();
    let mut cold = DualWorkspace::new();
    let (mut it_warm, mut it_cold) = (0, 0);
    for inst in &seq {
        let p = inst.problem();
        let w = warm.solve(&p, true);
        let c = cold.solve(&p, false);
        assert_eq!(w.status, Status::Solved);
        assert!((w.objective - c.objective).abs() <= 1e-10 * c.objective.max(1e-12));
        it_warm += w.iterations;
        it_cold += c.iterations;
    }
    assert!(it_warm * 2 < it_cold, "warm {it_warm} vs cold {it_cold}");
    // A hint that is nonsense (out of range, duplicated, wrong sign) changes nothing.
    let p = seq[0].problem();
    warm.set_warm_start(&[9999, 3, 3, 0, 1, 2]);
    let w = warm.solve(&p, true);
    let c = cold.solve(&p, false);
    assert!((w.objective - c.objective).abs() <= 1e-10 * c.objective);
}

/// The render crate re-orders rows between frames and maps the last active rows onto the new
/// order with `set_warm_start`: same answer, no more work than cold.
#[test]
fn warm_start_hint_survives_a_row_permutation() {
    let seq = common::haptic_sequence(300, 8, 77);
    let mut warm = DualWorkspace::new();
    let mut cold = DualWorkspace::new();
    let (mut it_warm, mut it_cold) = (0, 0);
    let mut prev_active: Vec<usize> = Vec::new(); // indices into the unpermuted rows
    for (f, inst) in seq.iter().enumerate() {
        // Reverse-rotate the rows by a frame-dependent shift.
        let n = inst.j.len();
        let shift = 37 * f % n;
        let perm: Vec<usize> = (0..n).map(|k| (k + shift) % n).collect();
        let j: Vec<[f64; 6]> = perm.iter().map(|&k| inst.j[k]).collect();
        let d: Vec<f64> = perm.iter().map(|&k| inst.d[k]).collect();
        let p = Problem::new(inst.g, &j, &d).unwrap();
        let hint: Vec<usize> = prev_active.iter().map(|&k| (k + n - shift) % n).collect();
        warm.set_warm_start(&hint);
        let w = warm.solve(&p, true);
        let c = cold.solve(&p, false);
        assert_eq!(w.status, Status::Solved);
        assert!((w.objective - c.objective).abs() <= 1e-10 * c.objective.max(1e-12));
        if f > 0 {
            it_warm += w.iterations;
            it_cold += c.iterations;
        }
        prev_active = warm.active_set().iter().map(|&k| perm[k]).collect();
    }
    assert!(it_warm * 2 < it_cold, "warm {it_warm} vs cold {it_cold}");
}

#[test]
fn pqp_tight_stop_converges_to_the_optimum() {
    for seed in 0..10u64 {
        let inst = common::haptic(30, 4, 0.3, &mut common::rng(500 + seed));
        let p = inst.problem();
        let exact = DualWorkspace::new().solve(&p, false);
        let mut ws = PqpWorkspace::with_params(PqpParams {
            max_iterations: 200_000,
            kkt_tol: Some(1e-8),
            ..PqpParams::tight()
        });
        let s = ws.solve(&p);
        assert_eq!(s.status, Status::Solved, "seed {seed}: {s:?}");
        let rel = (s.objective - exact.objective).abs() / exact.objective;
        assert!(rel < 1e-6, "seed {seed}: rel gap {rel:e}");
        assert!(ws.multipliers().iter().all(|&y| y >= 0.0));
        // Warm start from the converged multipliers: a few iterations to undo the floor.
        let again = ws.solve(&p);
        assert!(
            again.iterations <= 20 && again.iterations < s.iterations,
            "{again:?}"
        );
    }
}

/// The paper reports 6 iterations on average and 10 at most (its own scenes). On these 40
/// seeded haptic-like instances (N = 100) the paper's stop measured mean 9.9, max 29, min 3,
/// every answer `Inexact` with 0.09–0.38 mm of violation: the bounds below are that
/// measurement with a small margin, so a change of the update or of the stop shows here.
#[test]
fn pqp_paper_stop_takes_10_iterations_on_average_and_stops_inexact() {
    let mut total = 0u32;
    let (mut worst, mut least) = (0u32, u32::MAX);
    let mut ws = PqpWorkspace::new();
    for seed in 0..40u64 {
        let inst = common::haptic(100, 10, 0.2, &mut common::rng(seed));
        let s = ws.solve(&inst.problem());
        // The stop is a decrease test: the certificate shows the violation it leaves.
        assert_eq!(s.status, Status::Inexact, "seed {seed}: {s:?}");
        let v = s.kkt.max_violation;
        assert!(
            (0.05..=0.5).contains(&v),
            "seed {seed}: violation {v} mm outside the measured 0.09-0.38"
        );
        total += s.iterations;
        worst = worst.max(s.iterations);
        least = least.min(s.iterations);
    }
    let mean = f64::from(total) / 40.0;
    assert!(
        (8.0..=12.0).contains(&mean) && (25..=35).contains(&worst) && least >= 2,
        "mean {mean} max {worst} min {least} (measured 9.9 / 29 / 3)"
    );
}

/// `Inexact` is decided by the certificate: the same stop with a tolerance above the
/// violation reports `Solved`; the tight KKT stop reaches it.
#[test]
fn pqp_inexact_is_the_certificate_violation_beyond_the_tolerance() {
    let inst = common::haptic(100, 10, 0.2, &mut common::rng(7));
    let p = inst.problem();
    let paper = PqpWorkspace::new().solve(&p);
    assert_eq!(paper.status, Status::Inexact, "{paper:?}");
    assert!(paper.kkt.max_violation > PqpParams::paper().violation_tol);
    let lenient = PqpWorkspace::with_params(PqpParams {
        violation_tol: 2.0 * paper.kkt.max_violation,
        ..PqpParams::paper()
    })
    .solve(&p);
    assert_eq!(lenient.status, Status::Solved, "{lenient:?}");
    assert_eq!(lenient.dq, paper.dq);
    let tight = PqpWorkspace::with_params(PqpParams {
        max_iterations: 200_000,
        ..PqpParams::tight()
    })
    .solve(&p);
    assert_eq!(tight.status, Status::Solved, "{tight:?}");
    assert!(tight.kkt.max_violation <= PqpParams::tight().violation_tol);
    // A NaN tolerance never certifies anything.
    let nan = PqpWorkspace::with_params(PqpParams {
        violation_tol: f64::NAN,
        ..PqpParams::paper()
    })
    .solve(&p);
    assert_eq!(nan.status, Status::Inexact);
}

#[test]
fn solution_force_balances_contact_forces() {
    // G dq = J^T y: the spring force equals the sum of contact forces.
    let inst = common::haptic(80, 5, 0.1, &mut common::rng(3));
    let mut s = Solver::new(SolverKind::Dual);
    let sol = s.solve(&inst.problem(), &inst.dq0);
    let y = s.multipliers();
    for i in 0..6 {
        let f: f64 = inst.j.iter().zip(y).map(|(r, y)| r[i] * y).sum();
        assert!(
            (G[i] * sol.dq[i] - f).abs() < 1e-9 * (1.0 + f.abs()),
            "axis {i}"
        );
    }
}

fn small_instance() -> impl Strategy<Value = (Vec<[f64; 6]>, Vec<f64>, [f64; 6], [f64; 6])> {
    (0usize..25).prop_flat_map(|n| {
        (
            prop::collection::vec(prop::array::uniform6(-3.0f64..3.0), n),
            prop::collection::vec(0.0f64..2.0, n),
            prop::array::uniform6(-2.0f64..2.0),
            prop::array::uniform6(-2.0f64..3.0),
        )
            .prop_map(|(j, slack, x, lg)| {
                // Feasible by construction: d = J x - slack.
                let d = j
                    .iter()
                    .zip(&slack)
                    .map(|(r, s)| (0..6).map(|i| r[i] * x[i]).sum::<f64>() - s)
                    .collect();
                (j, d, x, lg.map(|v| 10f64.powf(v)))
            })
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn exact_solvers_agree_and_certify((j, d, x, g) in small_instance()) {
        let p = Problem::new(g, &j, &d).unwrap();
        let a = DualWorkspace::new().solve(&p, false);
        let b = ActiveSetWorkspace::new().solve(&p, &x);
        prop_assert_eq!(a.status, Status::Solved);
        prop_assert_eq!(b.status, Status::Solved);
        let scale = a.objective.max(1e-12);
        prop_assert!((a.objective - b.objective).abs() <= 1e-9 * scale, "{:?} {:?}", a, b);
        for s in [a, b] {
            prop_assert!(s.kkt.min_multiplier >= 0.0);
            prop_assert!(s.kkt.duality_gap <= 1e-9 * scale, "{:?}", s.kkt);
            let dmax = d.iter().fold(1e-12f64, |m, v| m.max(v.abs()));
            prop_assert!(s.kkt.max_violation <= 1e-9 * dmax, "{:?}", s.kkt);
        }
    }
}
