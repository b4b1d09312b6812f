//! The detection helper thread (`[solver] helper_thread`) changes how fast a frame is, and
//! where it takes its regions from, not the answer it finds. Where the lists are not worth
//! keeping on one thread (the puck sliding at 200 mm/s outruns them) the answers are
//! bit-identical with it on and off: the tool, the wrench, the status, the passes; a region's
//! pair count may differ (with the helper a list may be ready where alone the last ball's own
//! pairs serve, which hold more pairs than the region needs). With
//! them (the spline's slow turn on the hub) the helper has the next list ready sooner, so
//! frames take other regions: both runs are exact and never penetrate, and their graphic tools
//! agree except for a few frames where the turning shaft has more than one local answer (as
//! its keys drop into the grooves, one run a frame or two ahead of the other), after which
//! they meet again. No time budget, so the frames
//! do not depend on the machine's speed.

mod common;

use engine::{Frame, FrameStatus};
use scene::scenes::plate::{self, PlateTool, SpeedMotion};
use scene::Scene;

fn both(mut scene: Scene) -> (Vec<Frame>, Vec<Frame>) {
    scene.solver.budget_us = engine::config::BUDGET_US.hi;
    scene.solver.helper_thread = false;
    let alone = common::replay(&scene);
    scene.solver.helper_thread = true;
    let helped = common::replay(&scene);
    assert_eq!(alone.len(), helped.len());
    (alone, helped)
}

fn dense(frames: &[Frame]) -> usize {
    frames.iter().filter(|f| f.pairs >= 200).count()
}

#[test]
fn spline_frames_find_the_same_answers_with_the_helper_thread() {
    let scene = scene::scenes::builtin("spline", &common::test_cache()).unwrap();
    let tol = scene.solver.penetration_tol_mm;
    let (alone, helped) = both(scene);
    // Where they part most, the shaft drops 2 mm into the grooves (in a frame or two: a
    // falling tool's path) and one run starts its drop a frame or two before the other: the
    // tools are then apart by at most what the leading one moved in its last two frames.
    let moved = |f: &[Frame], i: usize| {
        let at = |j: usize| f[j].q_g;
        let step = |j: usize| {
            (0..3)
                .map(|k| (at(j)[k] - at(j.saturating_sub(1))[k]).powi(2))
                .sum::<f64>()
                .sqrt()
        };
        step(i) + step(i.saturating_sub(1))
    };
    let (mut apart, mut beyond) = (0, 0.0f64);
    for (i, (a, h)) in alone.iter().zip(&helped).enumerate() {
        assert!(a.penetration_mm <= tol && h.penetration_mm <= tol);
        assert!(a.q_g.iter().chain(&h.q_g).all(|v| v.is_finite()));
        let d = (0..3)
            .map(|k| (a.q_g[k] - h.q_g[k]).abs())
            .fold(0.0, f64::max);
        apart += usize::from(d > 0.01);
        beyond = beyond.max(d - moved(&alone, i).max(moved(&helped, i)));
    }
    let n = alone.len();
    assert!(
        apart * 100 <= n,
        "{apart} of {n} frames more than 0.01 mm apart"
    );
    assert!(
        beyond < 0.05,
        "the tools were {beyond} mm farther apart than the leading one's last two frames moved"
    );
    // The end of the run (withdrawn from the hole): the same pose.
    let (a, h) = (&alone[n - 1], &helped[n - 1]);
    for k in 0..6 {
        assert!(
            (a.q_g[k] - h.q_g[k]).abs() < 1e-6,
            "{:?} against {:?}",
            a.q_g,
            h.q_g
        );
    }
    let degraded = |f: &[Frame]| f.iter().filter(|f| f.status != FrameStatus::Ok).count();
    assert!(degraded(&alone).abs_diff(degraded(&helped)) <= 5);
    assert!(dense(&alone) >= 20, "only {} dense frames", dense(&alone));
}

#[test]
fn sliding_puck_frames_are_the_same_with_the_helper_thread() {
    let run = plate::speed_script(PlateTool::Puck, SpeedMotion::Slide(200.0), 1000.0, 0.3);
    let scene = plate::scene(&common::test_cache(), PlateTool::Puck, run.script).unwrap();
    // With face caps (the plate scene's setting) the contact is light; on whole spheres it is
    // dense and the helper shares the traversals. Both must give the same frames.
    for caps in [true, false] {
        let mut scene = scene.clone();
        scene.solver.face_caps = caps;
        let (alone, helped) = both(scene);
        for (i, (a, h)) in alone.iter().zip(&helped).enumerate() {
            assert_eq!(a.q_g, h.q_g, "frame {i}, caps {caps}");
            assert_eq!(a.wrench, h.wrench, "frame {i}, caps {caps}");
            assert_eq!(
                (a.status, a.passes, a.contacts),
                (h.status, h.passes, h.contacts),
                "frame {i}, caps {caps}"
            );
        }
        if !caps {
            assert!(dense(&alone) >= 20, "only {} dense frames", dense(&alone));
        }
    }
}
