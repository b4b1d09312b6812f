//! A frame's detection work (`engine::Frame::splits` and `scanned`, columns of `frames.csv`)
//! is a count, not a time: with no time budget cutting a traversal short and no helper thread, the
//! same input gives the same counts, frame for frame, on any machine and under any load. That
//! is what makes it the figure to compare two versions of the frame step by on a noisy machine.

mod common;

use collide::Pose;
use engine::Frame;
use scene::scenes::plate::{self, PlateTool, SpeedMotion};

fn dense_puck_sliding() -> scene::Scene {
    let run = plate::speed_script(PlateTool::Puck, SpeedMotion::Slide(200.0), 1000.0, 0.3);
    let mut scene = plate::scene(&common::test_cache(), PlateTool::Puck, run.script).unwrap();
    // On whole spheres the face is a dense contact: traversals, lists and probes all run.
    scene.solver.face_caps = false;
    scene.solver.helper_thread = false;
    scene.solver.budget_us = engine::config::BUDGET_US.hi;
    scene
}

#[test]
fn the_same_input_gives_the_same_work_in_every_frame() {
    let scene = dense_puck_sliding();
    let first: Vec<Frame> = common::replay(&scene);
    let second: Vec<Frame> = common::replay(&scene);
    assert_eq!(first.len(), second.len());
    for (i, (a, b)) in first.iter().zip(&second).enumerate() {
        assert_eq!((a.splits, a.scanned), (b.splits, b.scanned), "frame {i}");
    }
    // The counters count: the contact's frames detect, and a dense region splits hundreds of
    // node pairs.
    let dense: Vec<&Frame> = first.iter().filter(|f| f.pairs >= 200).collect();
    assert!(dense.len() >= 20, "only {} dense frames", dense.len());
    let most = first.iter().map(|f| f.splits).max().unwrap();
    assert!(most >= 500, "largest frame split {most} node pairs");
    // The slide keeps a neighbour list, and frames answered from it test its entries.
    let scanned: u64 = first.iter().map(|f| u64::from(f.scanned)).sum();
    assert!(scanned > 0, "no list entry tested");
    let total: u64 = first.iter().map(|f| u64::from(f.splits)).sum();
    assert!(
        total >= 10 * u64::from(most),
        "{total} node pairs split in all, {most} in one frame"
    );
}

#[test]
fn a_frame_that_detects_nothing_counts_no_work() {
    let scene = dense_puck_sliding();
    let traj = scene.trajectory();
    let mut god = scene.god_object().unwrap();
    god.reset(&Pose::from_array(traj.samples[0].q)).unwrap();
    let out = god.step(&Pose::from_array(traj.samples[0].q));
    assert!(out.splits > 0, "the first frame detects");
    // A device fault keeps the last safe pose without a detection.
    let mut bad = traj.samples[1].q;
    bad[2] = f64::NAN;
    let kept = god.step(&Pose::from_array(bad));
    assert_eq!(kept.status, engine::FrameStatus::KeptLastSafe);
    assert_eq!((kept.splits, kept.scanned), (0, 0));
}

/// A performance check that does not depend on the machine: in the spline's hole (no pair
/// within the frame's margin) no frame splits more than a thousand node pairs. The keys turning
/// in their grooves after the drop, inside a neighbour list, used to finish a background probe
/// in one frame (2 080 node pairs, ~200 µs); paced to the list's life and to the gap
/// its proofs found, the largest such frame splits 775.
#[test]
fn no_frame_in_the_splines_hole_splits_a_long_traversal() {
    let mut scene = scene::scenes::builtin("spline", &common::test_cache()).unwrap();
    scene.solver.helper_thread = false;
    scene.solver.budget_us = engine::config::BUDGET_US.hi;
    let frames = common::replay(&scene);
    let in_hole: Vec<(usize, &Frame)> = frames
        .iter()
        .enumerate()
        .filter(|(_, f)| f.pairs == 0 && f.q_h[2] < 0.0)
        .collect();
    assert!(in_hole.len() > 1000, "{} frames in the hole", in_hole.len());
    let (at, most) = in_hole
        .iter()
        .map(|&(i, f)| (i, f.splits))
        .max_by_key(|&(_, n)| n)
        .unwrap();
    assert!(most <= 1000, "{most} node pairs split in frame {at}");
}

/// A paced loop's wait before each frame (`GodObject::idle`, what `haptic6d run --realtime`
/// calls) takes over the background work the frames would do in slices: in the spline's hole
/// the frames then split far fewer node pairs themselves, and the answers stay exact (no
/// penetration, the insertion reaches its depth).
#[test]
fn the_wait_before_each_frame_takes_the_background_work_off_the_frames() {
    let mut scene = scene::scenes::builtin("spline", &common::test_cache()).unwrap();
    scene.solver.helper_thread = false;
    scene.solver.budget_us = engine::config::BUDGET_US.hi;
    let tol = scene.solver.penetration_tol_mm;
    let alone = common::replay(&scene);
    let traj = scene.trajectory();
    let mut god = scene.god_object().unwrap();
    god.reset(&Pose::from_array(traj.samples[0].q)).unwrap();
    let wait = std::time::Duration::from_micros(300);
    let waited: Vec<Frame> = traj
        .samples
        .iter()
        .map(|s| {
            god.idle(std::time::Instant::now() + wait);
            god.step(&Pose::from_array(s.q))
        })
        .collect();
    let in_hole = |frames: &[Frame]| -> u64 {
        frames
            .iter()
            .filter(|f| f.pairs == 0 && f.q_h[2] < 0.0)
            .map(|f| u64::from(f.splits))
            .sum()
    };
    let (by_frames, with_wait) = (in_hole(&alone), in_hole(&waited));
    assert!(
        2 * with_wait <= by_frames,
        "in the hole the frames split {with_wait} node pairs with the wait, {by_frames} without"
    );
    for (i, f) in waited.iter().enumerate() {
        assert!(
            f.penetration_mm <= tol,
            "frame {i}: {} mm",
            f.penetration_mm
        );
        assert!(f.q_g.iter().all(|v| v.is_finite()), "frame {i}");
    }
    let deepest = waited
        .iter()
        .map(|f| f.q_g[2])
        .fold(f64::INFINITY, f64::min);
    assert!(deepest <= -19.99, "the shaft reached z = {deepest} mm");
}
