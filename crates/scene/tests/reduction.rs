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

#[test]
fn spline_frames_are_the_same_reduced() {
    same_frames(scene::scenes::builtin("spline", &common::test_cache()).unwrap());
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
