//! The detection helper thread (`[solver] helper_thread`) changes how fast a frame is, not what
//! it is: the spline (dense key contacts, the tight hole) and the puck sliding pressed on the
//! plate give bit-identical frames with it on and off (no time budget, so the frames do not
//! depend on the machine).

mod common;

use scene::scenes::plate::{self, PlateTool, SpeedMotion};
use scene::Scene;

fn same_frames(mut scene: Scene) {
    scene.solver.budget_us = engine::config::BUDGET_US.hi;
    scene.solver.helper_thread = false;
    let alone = common::replay(&scene);
    scene.solver.helper_thread = true;
    let helped = common::replay(&scene);
    assert_eq!(alone.len(), helped.len());
    let mut dense = 0;
    for (i, (a, h)) in alone.iter().zip(&helped).enumerate() {
        assert_eq!(a.q_g, h.q_g, "{}: frame {i}", scene.name);
        assert_eq!(a.wrench, h.wrench, "{}: frame {i}", scene.name);
        assert_eq!(
            (a.status, a.pairs, a.passes, a.contacts),
            (h.status, h.pairs, h.passes, h.contacts),
            "{}: frame {i}",
            scene.name
        );
        dense += usize::from(a.pairs >= 200);
    }
    assert!(dense >= 20, "{}: only {dense} dense frames", scene.name);
}

#[test]
fn spline_frames_are_the_same_with_the_helper_thread() {
    same_frames(scene::scenes::builtin("spline", &common::test_cache()).unwrap());
}

#[test]
fn sliding_puck_frames_are_the_same_with_the_helper_thread() {
    let run = plate::speed_script(PlateTool::Puck, SpeedMotion::Slide(200.0), 1000.0, 0.3);
    same_frames(plate::scene(&common::test_cache(), PlateTool::Puck, run.script).unwrap());
}
