//! The whole pipeline on the built-in scenes: penetration bound, no NaN, force continuity,
//! contact sizes, insertion with every exact solver, the NaN guard and start-up.

mod common;

use collide::Pose;
use engine::step::FrameStatus;
use engine::{EngineError, SolverKind};
use scene::device::ReplayDevice;
use scene::report::{force_report, summarize};
use scene::rt::{run_loop, FrameRecord, LoopParams};
use scene::trajectory::Trajectory;
use scene::{Goal, Scene};

fn run(scene: &Scene, kind: SolverKind, traj: &Trajectory) -> Vec<FrameRecord> {
    let mut scene = scene.clone();
    scene.solver.kind = kind;
    // The answers are checked, not the speed: no deadline a busy test machine could reach
    // (CI runs test binaries side by side on two cores) cuts a frame's passes short.
    scene.solver.budget_us = engine::config::BUDGET_US.hi;
    let mut engine = scene.engine().unwrap();
    engine.reset(&Pose::from_array(traj.samples[0].q)).unwrap();
    let mut dev = ReplayDevice::new(traj.clone());
    run_loop(&mut engine, &mut dev, &LoopParams::default())
        .unwrap()
        .frames
}

#[test]
fn bunny_dual_meets_penetration_continuity_and_contact_targets() {
    let scene = scene::scenes::builtin("bunny", &common::test_cache()).unwrap();
    let traj = scene.trajectory();
    let frames = run(&scene, SolverKind::Dual, &traj);
    assert_eq!(frames.len(), traj.len());
    let f = force_report(&frames);
    assert_eq!(f.non_finite_frames, 0);
    assert!(
        f.max_force_jump_n <= 0.5,
        "force jump {} N at t = {}",
        f.max_force_jump_n,
        f.max_force_jump_t
    );
    let pen = frames
        .iter()
        .map(|r| r.frame.penetration_mm)
        .fold(0.0, f64::max);
    assert!(pen <= 0.01, "penetration {pen} mm");
    // Every frame solved, or (at most 0.1 % of frames, the degraded-frame budget) safely short
    // of the optimum when its passes ran out.
    let failed: Vec<(f64, FrameStatus, u32)> = frames
        .iter()
        .filter(|r| !matches!(r.frame.status, FrameStatus::Ok | FrameStatus::Lagging))
        .map(|r| (r.t, r.frame.status, r.frame.passes))
        .collect();
    assert!(failed.is_empty(), "frames not solved: {failed:?}");
    let lagging = frames
        .iter()
        .filter(|r| r.frame.status == FrameStatus::Lagging)
        .count();
    assert!(
        lagging * 1000 <= frames.len(),
        "{lagging} of {} frames lagging",
        frames.len()
    );
    // The script's phases: slide (small contact), then push (large contact) with ~10 N. The
    // contact's size is the number of leaf pairs touching at the answer (a region lists more:
    // its size follows its shape, a path along a sliding hand or a ball around a resting one).
    use scene::scenes::bunny::{PUSH_PHASE_S, SLIDE_PHASE_S};
    let mut slide: Vec<u32> = frames
        .iter()
        .filter(|f| f.t >= SLIDE_PHASE_S.0 && f.t <= SLIDE_PHASE_S.1 && f.frame.contacts > 0)
        .map(|f| f.frame.contacts)
        .collect();
    slide.sort_unstable();
    let slide_median = slide.get(slide.len() / 2).copied().unwrap_or(0);
    let push: Vec<u32> = frames
        .iter()
        .filter(|f| f.t >= PUSH_PHASE_S.0 && f.t <= PUSH_PHASE_S.1)
        .map(|f| f.frame.contacts)
        .collect();
    let (push_min, push_max) = (
        push.iter().copied().min().unwrap_or(0),
        push.iter().copied().max().unwrap_or(0),
    );
    assert!(
        slide_median > 0 && slide_median < 50,
        "slide contacts median {slide_median}"
    );
    // The push keeps a multi-region contact in every frame, several times the slide's.
    assert!(
        push_min >= 3 * slide_median,
        "push contacts {push_min}..{push_max}, slide median {slide_median}"
    );
    assert!(f.max_force_n > 5.0, "max force {} N", f.max_force_n);
    // The graphic tool ends where the hand is (free space again).
    let last = frames.last().unwrap();
    for k in 0..6 {
        assert!((last.frame.q_g[k] - last.frame.q_h[k]).abs() < 1e-9);
    }
}

fn axial_force_at(frames: &[FrameRecord], t: f64) -> f64 {
    frames
        .iter()
        .min_by(|a, b| (a.t - t).abs().total_cmp(&(b.t - t).abs()))
        .map(|f| f.frame.raw_wrench[2])
        .unwrap()
}

/// The run summary of a spline replay (distance form, no device or safety statistics).
fn spline_summary(
    scene: &Scene,
    kind: SolverKind,
    frames: &[FrameRecord],
) -> scene::report::RunSummary {
    summarize(
        "spline",
        kind.name(),
        "distance",
        frames,
        &Default::default(),
        scene.goal,
        vec![],
        0.0,
    )
}

#[test]
fn spline_insertion_succeeds_with_every_exact_solver() {
    let cache = common::test_cache();
    let scene = scene::scenes::builtin("spline", &cache).unwrap();
    let traj = scene.trajectory();
    for kind in [SolverKind::Dual, SolverKind::ActiveSet] {
        let frames = run(&scene, kind, &traj);
        let s = spline_summary(&scene, kind, &frames);
        let goal = s.goal.clone().unwrap();
        assert!(goal.success, "{kind:?}: reached z {} mm", goal.reached_z_mm);
        assert!(
            s.penetration_mm.max <= 0.01,
            "{kind:?}: penetration {} mm",
            s.penetration_mm.max
        );
        assert_eq!(s.force.non_finite_frames, 0);
        // Resting on the face (keys misaligned) the hand presses ~2 N down; once the keys align
        // the shaft drops in and the axial force vanishes.
        let resting = axial_force_at(&frames, 0.65);
        let aligned = axial_force_at(&frames, 2.0);
        assert!(
            resting > 1.5,
            "{kind:?}: axial force while resting {resting} N"
        );
        assert!(
            aligned.abs() < 0.2,
            "{kind:?}: axial force after alignment {aligned} N"
        );
        if let Some(Goal::InsertZ { target_z_mm, .. }) = scene.goal {
            assert!(target_z_mm < -10.0);
        }
    }
}

/// With face caps on, the spline still inserts. Caps decided at a region's pose alone stalled
/// at the hub's top face: a leaf's sphere bulged above the plane the last region had held the
/// tool against, and no
/// later frame could lift out (thousands kept the last safe pose). Now no frame keeps it, the
/// goal is reached, and no accepted pose overlaps the capped hub as a traversal at that very
/// pose decides each pair (not the regions' decisions).
#[test]
fn spline_insertion_succeeds_with_face_caps() {
    let cache = common::test_cache();
    let mut scene = scene::scenes::builtin("spline", &cache).unwrap();
    scene.solver.face_caps = true;
    let traj = scene.trajectory();
    let frames = run(&scene, SolverKind::Dual, &traj);
    let kept = frames
        .iter()
        .filter(|f| f.frame.status == FrameStatus::KeptLastSafe)
        .count();
    assert_eq!(kept, 0, "frames that kept the last safe pose");
    let s = spline_summary(&scene, SolverKind::Dual, &frames);
    let goal = s.goal.clone().unwrap();
    assert!(goal.success, "reached z {} mm", goal.reached_z_mm);
    let mut overlap = common::overlap_of(&scene);
    for f in &frames {
        let depth = overlap(&Pose::from_array(f.frame.q_g));
        assert!(depth <= 0.01, "overlap {depth} mm at t = {} s", f.t);
    }
}

#[test]
fn a_nan_device_frame_keeps_the_last_safe_pose() {
    let scene = scene::scenes::builtin("bunny", &common::test_cache()).unwrap();
    let mut traj = scene.trajectory();
    let i = traj.len() / 2;
    traj.samples[i].q[1] = f64::NAN;
    let frames = run(&scene, SolverKind::Dual, &traj);
    let bad = &frames[i];
    assert_eq!(bad.frame.status, FrameStatus::KeptLastSafe);
    assert_eq!(bad.frame.q_g, frames[i - 1].frame.q_g);
    assert!(bad.frame.wrench.iter().all(|v| v.is_finite()));
    assert!(frames[i + 1].frame.status == FrameStatus::Ok);
}

#[test]
fn start_in_collision_moves_to_a_nearby_free_pose() {
    let scene = scene::scenes::builtin("bunny", &common::test_cache()).unwrap();
    let mut god = scene.god_object().unwrap();
    // The tool exactly on the object: deep overlap.
    let inside = Pose::from_array([0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
    assert!(god.penetration_at(&inside) > 1.0);
    // Start just inside the object (the first hand pose of the push that is > 0.5 mm in): the
    // reset finds a free pose nearby.
    let scene_traj = scene.trajectory();
    let shallow = scene_traj
        .samples
        .iter()
        .filter(|s| s.t >= 5.9)
        .map(|s| Pose::from_array(s.q))
        .find(|q| god.penetration_at(q) > 0.5)
        .unwrap();
    let free = god.reset(&shallow).unwrap();
    assert!(god.penetration_at(&free) <= 0.01);
    let moved = (free.translation() - shallow.translation()).norm();
    assert!(moved < 3.0, "moved {moved} mm");
    // From the exact overlap of tool and object (38 mm deep) no free pose is within what the
    // coupling stretches at the device's force limit: the search stops there, with a clear
    // error (it once came back with a free pose metres away).
    let radius = scene.safety.max_force_n / scene.coupling.kt;
    match god.reset(&inside) {
        Err(EngineError::NoFreeStart { searched_mm }) => assert_eq!(searched_mm, radius),
        other => panic!("{other:?}"),
    }
    let e = god.reset(&inside).unwrap_err().to_string();
    assert!(e.contains("no free pose was found within 40 mm"), "{e}");
    // Free start: q_g = q_h exactly.
    let free = Pose::from_array([0.0, -200.0, 0.0, 0.0, 0.0, 0.0]);
    assert_eq!(god.reset(&free).unwrap(), free);
}
