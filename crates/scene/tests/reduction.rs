//! Constraint reduction in the frame step: the spline's large contacts (hundreds to thousands
//! of leaf pairs) and the puck pressed flat on the plate give the same frames with
//! `reduce_rows` on and off — the reduced QP's answer is the full one — while the reduced
//! solves work on a small share of the rows.

mod common;

use scene::scenes::plate::{self, PlateTool, SpeedMotion};
use scene::Scene;

/// Replays `scene` with and without reduction (no time budget: the frames do not depend on
/// the machine) and compares them frame by frame.
fn same_frames(mut scene: Scene) {
    scene.solver.budget_us = engine::config::BUDGET_US.hi;
    scene.solver.reduce_rows = true;
    let reduced = common::replay(&scene);
    scene.solver.reduce_rows = false;
    let full = common::replay(&scene);
    assert_eq!(reduced.len(), full.len());
    let mut dense = 0;
    for (i, (r, f)) in reduced.iter().zip(&full).enumerate() {
        for k in 0..6 {
            assert!(
                (r.q_g[k] - f.q_g[k]).abs() <= 1e-6,
                "{}: frame {i}: q_g {:?} reduced vs {:?} full",
                scene.name,
                r.q_g,
                f.q_g
            );
            assert!(
                (r.wrench[k] - f.wrench[k]).abs() <= 1e-5,
                "{}: frame {i}: wrench {:?} vs {:?}",
                scene.name,
                r.wrench,
                f.wrench
            );
        }
        assert_eq!(r.status, f.status, "{}: frame {i}", scene.name);
        assert!(r.penetration_mm <= 0.01);
        if f.pairs >= 200 {
            dense += 1;
            assert!(
                r.rows < f.rows,
                "{}: frame {i}: {} rows reduced of {} (pairs {})",
                scene.name,
                r.rows,
                f.rows,
                f.pairs
            );
        }
    }
    assert!(dense >= 20, "{}: only {dense} dense frames", scene.name);
}

/// The spline's large contacts, solve by solve: every reduced QP of the run is solved again in
/// full on the same rows (the engine's audit) and gives the same answer. (Frame by frame the
/// two runs part in the alignment: an answer converged to the frame's tolerance, different in
/// its last digits, flips a later region's choice, and the turning shaft on its bumps has more
/// than one local answer; they meet again, as with the helper thread.)
#[test]
fn spline_solves_are_the_same_reduced() {
    let mut scene = scene::scenes::builtin("spline", &common::test_cache()).unwrap();
    scene.solver.budget_us = engine::config::BUDGET_US.hi;
    scene.solver.reduce_rows = true;
    let traj = scene.trajectory();
    let mut god = scene.god_object().unwrap();
    god.reset(&collide::Pose::from_array(traj.samples[0].q))
        .unwrap();
    god.audit_reduction(true);
    let (mut solves, mut rows, mut working) = (0, 0, 0);
    let (mut force, mut torque) = (0.0f64, 0.0f64);
    let mut deepest = f64::INFINITY;
    for s in &traj.samples {
        let f = god.step(&collide::Pose::from_array(s.q));
        assert!(f.penetration_mm <= 0.01);
        let a = god.take_reduction_audit();
        solves += a.solves;
        rows += a.rows;
        working += a.working_rows;
        force = force.max(a.max_force_diff_n);
        torque = torque.max(a.max_torque_diff_nmm);
        deepest = deepest.min(f.q_g[2]);
    }
    assert!(solves >= 1000, "only {solves} reduced solves");
    assert!(force <= 1e-6, "force differs by {force} N");
    assert!(torque <= 1e-4, "torque differs by {torque} N·mm");
    assert!(working * 10 < rows, "{working} working rows of {rows}");
    // Inserted: the shaft's tip 20 mm down.
    assert!((deepest + 20.0).abs() < 1e-3, "deepest {deepest} mm");
}

#[test]
fn pressed_puck_frames_are_the_same_reduced() {
    let run = plate::speed_script(PlateTool::Puck, SpeedMotion::Slide(200.0), 1000.0, 0.3);
    let mut scene = plate::scene(&common::test_cache(), PlateTool::Puck, run.script).unwrap();
    // Whole spheres: the dense contact the reduction is for (with face caps the puck's
    // contact is a few tens of rows of one plane).
    scene.solver.face_caps = false;
    same_frames(scene);
}
