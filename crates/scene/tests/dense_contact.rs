//! A dense flat-on-flat contact: the dense puck (tree depth 5, leaves of ~0.3 mm) pressed onto
//! the capped plate and slid. Every leaf of its face lies within a few tenths of a millimetre
//! of the plate, so a region's pair count grows as a high power of its margin (52 pairs at
//! 0.05 mm, 516 at 0.12, 11 494 at 0.3). Regions must stay near the pair target instead of
//! asking for ten thousand pairs (whose traversal outlasts a frame), and the tool must still
//! rest on the plate and follow the hand.

mod common;

use engine::step::FrameStatus;
use scene::scenes::plate::{self, PlateTool, SpeedMotion, PRESS_MM};

#[test]
fn the_dense_puck_slides_in_regions_of_bounded_size() {
    let run = plate::speed_script(PlateTool::DensePuck, SpeedMotion::Slide(50.0), 1000.0, 0.2);
    let mut scene = plate::scene(
        &common::test_cache(),
        PlateTool::DensePuck,
        run.script.clone(),
    )
    .unwrap();
    // No time budget: the regions do not depend on the machine.
    scene.solver.budget_us = engine::config::BUDGET_US.hi;
    let traj = scene.trajectory();
    let frames = common::replay(&scene);
    let most = frames.iter().map(|o| o.pairs).max().unwrap();
    let touching = frames.iter().filter(|o| o.pairs >= 500).count();
    assert!(
        touching >= 500,
        "only {touching} frames of 500 pairs or more"
    );
    // The pair target is 1 500; a region sized by the linear rule after a small one holds
    // over 10 000.
    assert!(most <= 4500, "a region of {most} pairs");
    for (i, (o, s)) in frames.iter().zip(&traj.samples).enumerate() {
        assert_eq!(o.status, FrameStatus::Ok, "frame {i} at {:.3} s", s.t);
        assert!(
            o.penetration_mm <= 0.01,
            "frame {i}: {} mm",
            o.penetration_mm
        );
    }
    // At constant speed the frictionless puck rests on the plate and keeps up with the hand
    // (within a frame's motion), its spring pushing it down by about the press.
    for &(a, b) in &run.steady {
        for (o, s) in frames.iter().zip(&traj.samples) {
            if s.t >= a && s.t < b {
                assert!(
                    (o.q_g[0] - s.q[0]).abs() <= 0.1,
                    "at {:.3} s: x {} vs {}",
                    s.t,
                    o.q_g[0],
                    s.q[0]
                );
                assert!(
                    o.q_g[2] > s.q[2] + 0.5 * PRESS_MM,
                    "at {:.3} s: z {}",
                    s.t,
                    o.q_g[2]
                );
            }
        }
    }
}
