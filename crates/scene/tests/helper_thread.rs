//! The detection helper thread (`[solver] helper_thread`) changes how fast a frame is, and
//! where it takes its regions from, not the answer it finds. Where the lists are not worth
//! keeping on one thread (the puck sliding at 200 mm/s outruns them) the answers are
//! bit-identical with it on and off: the tool, the wrench, the status, the passes; a region's
//! pair count may differ (with the helper a list may be ready where alone the last ball's own
//! pairs serve, which hold more pairs than the region needs). With
//! them (the spline's slow turn on the hub) the helper has the next list ready sooner, so
//! frames take other regions (which ones depends on the machine's load): both runs are exact and
//! never penetrate, reach the goal, press with the same force and end at the same pose. No
//! time budget, so no frame is cut by a deadline.

mod common;

use engine::Frame;
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

/// The insertion's answers, with and without the helper: whether the goal is reached and
/// where, the tool's pose at the end, the axial force resting on the face and once dropped
/// in; every frame exact (within the penetration tolerance) and finite. Which frames the
/// helper's lists arrive for depends on the machine's load, so frames are not compared one
/// by one (they may take other regions, a frame or two apart as the keys drop).
#[test]
fn spline_frames_find_the_same_answers_with_the_helper_thread() {
    let scene = scene::scenes::builtin("spline", &common::test_cache()).unwrap();
    let tol = scene.solver.penetration_tol_mm;
    let target_z = match scene.goal {
        Some(scene::Goal::InsertZ { target_z_mm, .. }) => target_z_mm,
        other => panic!("the spline scene's goal is {other:?}"),
    };
    let rate_hz = scene.rate_hz;
    let (alone, helped) = both(scene);
    for frames in [&alone, &helped] {
        for f in frames.iter() {
            assert!(
                f.penetration_mm <= tol,
                "penetration {} mm",
                f.penetration_mm
            );
            assert!(f.q_g.iter().chain(&f.wrench).all(|v| v.is_finite()));
        }
        let deepest = frames
            .iter()
            .map(|f| f.q_g[2])
            .fold(f64::INFINITY, f64::min);
        assert!(
            deepest <= target_z,
            "reached z {deepest} mm, goal {target_z} mm"
        );
    }
    let n = alone.len();
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
    // Resting on the face (keys misaligned) and once dropped in: the same axial force.
    let axial = |f: &[Frame], t: f64| f[((t * rate_hz) as usize).min(f.len() - 1)].raw_wrench[2];
    for t in [0.65, 2.0] {
        let (fa, fh) = (axial(&alone, t), axial(&helped, t));
        assert!(
            (fa - fh).abs() < 0.05,
            "at {t} s: {fa} N alone, {fh} N helped"
        );
    }
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
