//! Reliability of the god-object step and the haptic loop on a programmatic scene: a thin
//! plate (thinner than its leaf spheres' radius) and a small tool.
//!
//! - Anti-tunnelling: device motions straight through the plate in one or a few frames; the
//!   graphic tool stays on the near side in every frame.
//! - Device faults: a NaN row, a 100 mm jump in one frame, a stall: the loop runs every frame,
//!   the wrench sent is finite, bounded by the device limits and rate-limited, and the summary
//!   counts what happened.
//! - Solver faults: absurd stiffness (wrench overflows to infinity) and a QP capped at one
//!   iteration never reach the device as non-finite or unsafe output.

mod common;

use collide::Pose;
use engine::safety::norm3;
use engine::safety::SafetyParams;
use engine::step::FrameStatus;
use engine::SolverKind;
use mesh::TriMesh;
use scene::device::ReplayDevice;
use scene::report::summarize;
use scene::rt::{run_loop, FrameRecord, LoopParams, LoopStats};
use scene::trajectory::{TrajSample, Trajectory};
use scene::{Coupling, Motion, Scene, SolverSpec};
use spheretree::build::{build_tree, BuildParams};
use spheretree::{Sphere, SphereTree};

/// Plate half-size in x and y, mm.
const HALF: f64 = 60.0;

/// A closed box mesh `[-hx, hx] x [-hy, hy] x [-hz, hz]` (mm).
fn box_mesh(hx: f64, hy: f64, hz: f64) -> TriMesh {
    scene::scenes::plate::box_mesh([-hx, -hy, -hz], [hx, hy, hz])
}

/// The plate's sphere-tree (octree builder, depth 3) and the smallest leaf radius, mm.
fn plate_tree(thickness: f64) -> (SphereTree, f64) {
    let mesh = box_mesh(HALF, HALF, 0.5 * thickness);
    let tree = build_tree(&mesh, &BuildParams::fastest_build(3), &|_| {}).unwrap();
    let min_leaf = tree
        .leaves()
        .map(|n| tree.sphere(n))
        .filter(|s| s.is_used())
        .map(|s| s.radius)
        .fold(f64::INFINITY, f64::min);
    (tree, min_leaf)
}

/// A small tool: a root of radius 3 mm around two leaves of radius 2 mm at x = ±1 mm.
fn tool_tree() -> SphereTree {
    let mut spheres = vec![Sphere::new([0.0; 3], 3.0)];
    spheres.push(Sphere::new([-1.0, 0.0, 0.0], 2.0));
    spheres.push(Sphere::new([1.0, 0.0, 0.0], 2.0));
    SphereTree::from_slots(2, 2, spheres).unwrap()
}

fn scene(object: SphereTree, solver: SolverSpec, coupling: Coupling) -> Scene {
    Scene {
        name: "reliability plate".into(),
        tool: tool_tree(),
        tool_mesh: None,
        objects: vec![(object, Pose::identity())],
        object_meshes: vec![None],
        coupling,
        solver,
        safety: SafetyParams::default(),
        start: Pose::from_array([0.0, 0.0, 40.0, 0.0, 0.0, 0.0]),
        rate_hz: 1000.0,
        motion: Motion::Hold,
        goal: None,
        device: Default::default(),
        load_log: Vec::new(),
        object_friction: Vec::new(),
        tool_friction: None,
    }
}

/// The top of the plate's sphere layer (largest `z + r` over its leaves), mm.
fn sphere_top(tree: &SphereTree) -> f64 {
    tree.leaves()
        .map(|n| tree.sphere(n))
        .filter(|s| s.is_used())
        .map(|s| s.center[2] + s.radius)
        .fold(f64::NEG_INFINITY, f64::max)
}

/// A trajectory from `keys` (frame index, configuration), linear between keys, 1 kHz.
fn keyed(keys: &[(usize, [f64; 6])]) -> Trajectory {
    let mut samples = Vec::new();
    for w in keys.windows(2) {
        let ((i0, a), (i1, b)) = (w[0], w[1]);
        for i in i0..i1 {
            let s = (i - i0) as f64 / (i1 - i0) as f64;
            let mut q = [0.0; 6];
            for k in 0..6 {
                q[k] = a[k] + (b[k] - a[k]) * s;
            }
            samples.push(TrajSample {
                t: i as f64 * 1e-3,
                q,
            });
        }
    }
    let (il, ql) = *keys.last().unwrap();
    samples.push(TrajSample {
        t: il as f64 * 1e-3,
        q: ql,
    });
    Trajectory { samples }
}

fn run(scene: &Scene, traj: &Trajectory) -> (Vec<FrameRecord>, LoopStats) {
    let mut engine = scene.engine().unwrap();
    engine.reset(&Pose::from_array(traj.samples[0].q)).unwrap();
    let mut dev = ReplayDevice::new(traj.clone());
    let r = run_loop(&mut engine, &mut dev, &LoopParams::default()).unwrap();
    (r.frames, r.stats)
}

/// The sent wrench is finite, within the device limits, and changes by at most the rate limit
/// per frame (N, N·mm; small slack for rounding).
#[track_caller]
fn assert_safe_output(frames: &[FrameRecord], p: &SafetyParams) {
    let mut prev = [0.0; 6];
    for (i, f) in frames.iter().enumerate() {
        assert!(
            f.frame.wrench.iter().all(|v| v.is_finite()),
            "frame {i}: {:?}",
            f.frame.wrench
        );
        assert!(
            norm3(&f.frame.wrench[0..3]) <= p.max_force_n + 1e-9,
            "frame {i}"
        );
        assert!(
            norm3(&f.frame.wrench[3..6]) <= p.max_torque_nmm + 1e-6,
            "frame {i}"
        );
        let df = norm3(&[
            f.frame.wrench[0] - prev[0],
            f.frame.wrench[1] - prev[1],
            f.frame.wrench[2] - prev[2],
        ]);
        let dt = norm3(&[
            f.frame.wrench[3] - prev[3],
            f.frame.wrench[4] - prev[4],
            f.frame.wrench[5] - prev[5],
        ]);
        assert!(
            df <= p.max_force_step_n + 1e-9,
            "frame {i}: force step {df} N"
        );
        assert!(
            dt <= p.max_torque_step_nmm + 1e-6,
            "frame {i}: torque step {dt} N·mm"
        );
        prev = f.frame.wrench;
    }
}

// ---------------------------------------------------------------------------------------------
// Anti-tunnelling.

#[test]
fn thin_plate_is_thinner_than_its_leaf_spheres() {
    let (tree, min_leaf) = plate_tree(0.5);
    tree.validate(1e-9).unwrap();
    eprintln!(
        "plate 0.5 mm thick: smallest leaf radius {min_leaf:.3} mm, sphere layer top z = {:.3} mm",
        sphere_top(&tree)
    );
    assert!(
        min_leaf > 0.5,
        "the test needs leaves larger than the plate: {min_leaf}"
    );
}

#[test]
fn fast_motion_through_a_thin_plate_never_tunnels() {
    let (plate, min_leaf) = plate_tree(0.5);
    let top = sphere_top(&plate);
    assert!(min_leaf > 0.5 && top < 40.0, "top {top}");
    let above = [5.0, -3.0, 40.0, 0.0, 0.0, 0.0];
    let below = [5.0, -3.0, -40.0, 0.0, 0.0, 0.0];
    let tilted = [-8.0, 12.0, -45.0, 0.4, -0.3, 0.8];
    let motions: Vec<(&str, Trajectory)> = vec![
        // 80 mm in one frame (80 m/s), then held below for 50 frames.
        (
            "one frame",
            keyed(&[(0, above), (5, above), (6, below), (56, below)]),
        ),
        // Through in three frames, then back up.
        (
            "three frames",
            keyed(&[
                (0, above),
                (3, above),
                (6, below),
                (40, below),
                (43, above),
                (50, above),
            ]),
        ),
        // Through with a rotation, in two frames.
        (
            "rotating",
            keyed(&[(0, above), (2, above), (4, tilted), (40, tilted)]),
        ),
        // A hand sliding at 2 m/s (2 mm per frame), pressed 1 mm into the plate's top.
        (
            "sliding at 2 m/s",
            keyed(&[
                (0, [-50.0, 0.0, 40.0, 0.0, 0.0, 0.0]),
                (20, [-50.0, 0.0, top - 1.0, 0.0, 0.0, 0.0]),
                (30, [-50.0, 0.0, top - 1.0, 0.0, 0.0, 0.0]),
                (80, [50.0, 0.0, top - 1.0, 0.0, 0.0, 0.0]),
                (90, [50.0, 0.0, top - 1.0, 0.0, 0.0, 0.0]),
            ]),
        ),
        // Grazing: along the plate inside its sphere layer, 10 mm per frame.
        (
            "grazing",
            keyed(&[
                (0, [-50.0, 0.0, 40.0, 0.0, 0.0, 0.0]),
                (4, [-50.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
                (14, [50.0, 0.0, -1.0, 0.0, 0.0, 0.0]),
                (30, [50.0, 0.0, -1.0, 0.0, 0.0, 0.0]),
            ]),
        ),
    ];
    for relinearize in [0, 3, SolverSpec::default().relinearize] {
        for kind in [SolverKind::Dual, SolverKind::ActiveSet] {
            let spec = SolverSpec {
                kind,
                relinearize,
                // Algorithmic behaviour, not timing: no pass is cut by a busy machine.
                budget_us: 1e6,
                ..SolverSpec::default()
            };
            let sc = scene(plate.clone(), spec, Coupling::default());
            for (name, traj) in &motions {
                let (frames, _) = run(&sc, traj);
                assert_eq!(frames.len(), traj.len(), "{name}");
                for (i, f) in frames.iter().enumerate() {
                    // The tool's leaves (radius 2) must stay on the near side of the plate's
                    // mid-plane: the origin above z = 2 mm at least (it rests on the sphere
                    // layer, which is far above).
                    let zg = f.frame.q_g[2];
                    assert!(
                        zg > 2.0,
                        "{name} ({kind:?}, relinearize {relinearize}) frame {i}: tool at z = {zg} tunnelled (device z = {})",
                        f.frame.q_h[2]
                    );
                    assert!(
                        f.frame.penetration_mm <= 0.01,
                        "{name} ({kind:?}, relinearize {relinearize}) frame {i}: penetration {} mm",
                        f.frame.penetration_mm
                    );
                }
                if *name == "sliding at 2 m/s" && relinearize > 0 {
                    // Frictionless: the tool slid with the hand instead of sticking.
                    let f = &frames[89].frame;
                    assert!(
                        (f.q_g[0] - f.q_h[0]).abs() < 1.0,
                        "{kind:?}, relinearize {relinearize}: tool at x = {} behind the hand at {}",
                        f.q_g[0],
                        f.q_h[0]
                    );
                }
                // Pushed below the plate, the tool rests on top of it: pressed, not free.
                let last = frames.last().unwrap();
                if last.frame.q_h[2] < 0.0 {
                    // Down on the sphere layer (on a sphere's top or, frictionless, slid into
                    // the dimple between spheres ~2.8 mm lower), not hovering above it.
                    assert!(
                        last.frame.q_g[2] < top + 0.1,
                        "{name}: rests at {}",
                        last.frame.q_g[2]
                    );
                    assert!(last.frame.raw_wrench[2] > 1.0, "{name}: no push-back");
                }
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Device faults.

/// Above the plate, then pressing 5 mm into it, held: frames 0..400.
fn press_trajectory(top: f64) -> Trajectory {
    keyed(&[
        (0, [0.0, 0.0, top + 10.0, 0.0, 0.0, 0.0]),
        (100, [0.0, 0.0, top + 10.0, 0.0, 0.0, 0.0]),
        (200, [0.0, 0.0, top - 3.0, 0.0, 0.0, 0.0]),
        (400, [0.0, 0.0, top - 3.0, 0.0, 0.0, 0.0]),
    ])
}

#[test]
fn nan_device_row_keeps_the_loop_running_with_safe_output() {
    let (plate, _) = plate_tree(0.5);
    let top = sphere_top(&plate);
    let sc = scene(plate, SolverSpec::default(), Coupling::default());
    let mut traj = press_trajectory(top);
    // A NaN row and an infinite row while pressing.
    traj.samples[300].q[2] = f64::NAN;
    traj.samples[301].q = [f64::INFINITY; 6];
    let (frames, stats) = run(&sc, &traj);
    assert_eq!(frames.len(), traj.len());
    assert_safe_output(&frames, &sc.safety);
    for i in [300, 301] {
        assert_eq!(
            frames[i].frame.status,
            FrameStatus::KeptLastSafe,
            "frame {i}"
        );
        assert_eq!(frames[i].frame.q_g, frames[299].frame.q_g, "frame {i}");
    }
    // Solved again (or lagging, safe, should a busy test machine preempt the frame past its
    // 1 ms budget): the bad rows cost nothing after them.
    assert!(
        matches!(
            frames[302].frame.status,
            FrameStatus::Ok | FrameStatus::Lagging
        ),
        "{:?}",
        frames[302].frame.status
    );
    assert_eq!(stats.kept_last_safe, 2);
    let s = summarize(
        "plate",
        "dual",
        "distance",
        &frames,
        &stats,
        None,
        vec![],
        0.0,
    );
    assert_eq!(
        s.loop_stats.kept_last_safe, 2,
        "the summary reports the bad frames"
    );
    assert_eq!(s.force.non_finite_frames, 0);
    // summary.json (the serialisation `run` writes) carries the count, not just the field.
    let json: serde_json::Value = serde_json::to_value(&s).unwrap();
    assert_eq!(
        json["loop_stats"]["kept_last_safe"].as_u64(),
        Some(2),
        "summary.json: {}",
        json["loop_stats"]
    );
    assert_eq!(
        json["loop_stats"]["frames"].as_u64(),
        Some(traj.len() as u64)
    );
}

#[test]
fn jump_of_100_mm_in_one_frame_is_clamped_and_rate_limited() {
    let (plate, _) = plate_tree(0.5);
    let top = sphere_top(&plate);
    let sc = scene(plate, SolverSpec::default(), Coupling::default());
    let z0 = top + 10.0;
    // Rest above the plate, then the device reading jumps 100 mm down (through the plate) for
    // 100 frames, then back.
    let traj = keyed(&[
        (0, [0.0, 0.0, z0, 0.0, 0.0, 0.0]),
        (100, [0.0, 0.0, z0, 0.0, 0.0, 0.0]),
        (101, [0.0, 0.0, z0 - 100.0, 0.0, 0.0, 0.0]),
        (200, [0.0, 0.0, z0 - 100.0, 0.0, 0.0, 0.0]),
        (201, [0.0, 0.0, z0, 0.0, 0.0, 0.0]),
        (300, [0.0, 0.0, z0, 0.0, 0.0, 0.0]),
    ]);
    let (frames, stats) = run(&sc, &traj);
    assert_eq!(frames.len(), traj.len());
    assert_safe_output(&frames, &sc.safety);
    // The raw spring force is ~ (100 - 10) N, beyond the 40 N limit: clamped and ramped.
    assert!(frames[150].frame.raw_wrench[2] > sc.safety.max_force_n);
    assert!((frames[150].frame.wrench[2] - sc.safety.max_force_n).abs() < 1e-6);
    assert!(stats.safety.force_clamps > 0 && stats.safety.rate_limits > 0);
    for f in &frames {
        // The tool's 2 mm leaves stay above the plate's mid-plane (it may slide into the
        // dimples between the plate's big leaves, ~2.8 mm below their tops: frictionless).
        assert!(f.frame.q_g[2] > 2.0, "tunnelled: {:?}", f.frame.q_g);
    }
    // Released: the output returns to zero (through the rate limit) and stays there.
    assert!(
        frames[299].frame.wrench.iter().all(|v| v.abs() < 1e-9),
        "{:?}",
        frames[299].frame.wrench
    );
}

#[test]
fn stalled_device_keeps_a_steady_force() {
    let (plate, _) = plate_tree(0.5);
    let top = sphere_top(&plate);
    let sc = scene(plate, SolverSpec::default(), Coupling::default());
    // Pressing, then the device repeats its last reading (same time stamp too) for 2000
    // frames: the loop keeps running and the force holds steady.
    let mut traj = press_trajectory(top);
    let last = *traj.samples.last().unwrap();
    traj.samples.extend(std::iter::repeat_n(last, 2000));
    let (frames, stats) = run(&sc, &traj);
    assert_eq!(frames.len(), traj.len());
    assert_safe_output(&frames, &sc.safety);
    let f0 = frames[450].frame.wrench;
    for f in &frames[450..] {
        for k in 0..6 {
            assert!(
                (f.frame.wrench[k] - f0[k]).abs() < 1e-6,
                "{:?} vs {f0:?}",
                f.frame.wrench
            );
        }
    }
    // The tool rests in the dimple between four big octree leaves (x = y = 0 is a cell
    // corner), ~2.8 mm below the spheres' top, so the hand 3 mm below the top is only
    // ~0.17 mm past the contact: the spring pushes back with ~0.17 N.
    assert!(f0[2] > 0.1, "pressing must push back: {f0:?}");
    assert_eq!(stats.kept_last_safe, 0);
    // The summary says what happened: the 2000 repeated readings are counted as stalled.
    assert_eq!(stats.stalled_frames, 2000, "{stats:?}");
}

// ---------------------------------------------------------------------------------------------
// Solver faults.

#[test]
fn absurd_stiffness_is_refused_and_the_stiffest_accepted_is_safe() {
    // kt, kr of 1e300 / 1e-300 used to be accepted (finite) and overflow the spring; they are
    // now refused wherever they come from (scene, GodObject, the loop), naming the key.
    let (plate, _) = plate_tree(0.5);
    let top = sphere_top(&plate);
    for (kt, kr) in [(1e300, 1e300), (1e-300, 1e-300), (1e300, 1e-300)] {
        let sc = scene(
            plate.clone(),
            SolverSpec::default(),
            Coupling {
                kt,
                kr,
                ..Coupling::default()
            },
        );
        let e = common::chain(&sc.validate().unwrap_err());
        assert!(e.contains("[coupling] kt"), "{e}");
        // The scene names itself; the engine's reason is the error's source.
        let e = common::chain(&sc.god_object().err().expect("refused"));
        assert!(
            e.starts_with(&sc.name) && e.contains("[coupling] kt"),
            "{e}"
        );
    }
    // The stiffest coupling accepted, pressed hard: finite, clamped, rate-limited.
    let stiff = Coupling {
        kt: engine::config::KT.hi,
        kr: engine::config::KR.hi,
        ..Coupling::default()
    };
    let sc = scene(plate, SolverSpec::default(), stiff);
    sc.validate().unwrap();
    // 2 mm deeper than the usual press: a raw spring force of hundreds of N.
    let deep = keyed(&[
        (0, [0.0, 0.0, top + 10.0, 0.0, 0.0, 0.0]),
        (100, [0.0, 0.0, top + 10.0, 0.0, 0.0, 0.0]),
        (200, [0.0, 0.0, top - 5.0, 0.0, 0.0, 0.0]),
        (400, [0.0, 0.0, top - 5.0, 0.0, 0.0, 0.0]),
    ]);
    let (frames, stats) = run(&sc, &deep);
    assert_safe_output(&frames, &sc.safety);
    assert!(
        frames[300].frame.raw_wrench[2] > 100.0,
        "{:?}",
        frames[300].frame
    );
    assert!((norm3(&frames[300].frame.wrench[0..3]) - sc.safety.max_force_n).abs() < 1e-9);
    assert!(stats.safety.force_clamps > 0, "{stats:?}");
    for f in &frames {
        assert!(
            f.frame.q_g.iter().all(|v| v.is_finite()),
            "{:?}",
            f.frame.q_g
        );
    }
}

/// Runs `traj` with every solver's iteration cap set to `cap`.
fn run_capped(scene: &Scene, traj: &Trajectory, cap: u32) -> (Vec<FrameRecord>, LoopStats) {
    let mut engine = scene.engine().unwrap();
    engine.reset(&Pose::from_array(traj.samples[0].q)).unwrap();
    let s = engine.god_object_mut().solver_mut();
    s.dual.params.max_iterations = cap;
    s.active_set.params.max_iterations = cap;
    s.pqp.params.max_iterations = cap;
    let mut dev = ReplayDevice::new(traj.clone());
    let r = run_loop(&mut engine, &mut dev, &LoopParams::default()).unwrap();
    (r.frames, r.stats)
}

#[test]
fn qp_iteration_cap_never_reaches_the_device() {
    // A tilted tool pressed into the plate edge-on activates several constraints at once; with
    // the solver capped at no iteration the QP stops early. The capped answer must not be
    // sent: the frame keeps its last safe pose (no penetration) and the output stays safe.
    let (plate, _) = plate_tree(0.5);
    let top = sphere_top(&plate);
    for kind in [SolverKind::Dual, SolverKind::ActiveSet, SolverKind::Pqp] {
        // One pass per frame, its region the whole way to the hand: many rows at once, so a
        // capped solve happens (the default small regions rarely need two iterations).
        let spec = SolverSpec {
            kind,
            relinearize: 0,
            ..SolverSpec::default()
        };
        let sc = scene(plate.clone(), spec, Coupling::default());
        let traj = keyed(&[
            (0, [0.0, 0.0, top + 10.0, 0.0, 0.0, 0.0]),
            (50, [0.0, 0.0, top + 10.0, 0.0, 0.0, 0.0]),
            (150, [3.0, -2.0, top - 4.0, 0.3, 0.5, 0.2]),
            (250, [-3.0, 2.0, top - 6.0, -0.3, 0.4, -0.2]),
        ]);
        let (frames, stats) = run_capped(&sc, &traj, 0);
        assert_eq!(frames.len(), traj.len());
        assert_safe_output(&frames, &sc.safety);
        // PQP's own stopping rule leaves up to ~0.3 mm of violation (docs/DESIGN.md §The QP and
        // its solvers); the exact solvers must hold the 0.01 mm bound.
        let bound = if kind == SolverKind::Pqp { 0.3 } else { 0.01 };
        for (i, f) in frames.iter().enumerate() {
            assert!(
                f.frame.penetration_mm <= bound,
                "{kind:?} frame {i}: a capped solve reached the device with {} mm penetration",
                f.frame.penetration_mm
            );
            assert!(f.frame.q_g[2] > 2.0, "{kind:?} frame {i}: tunnelled");
        }
        eprintln!(
            "{kind:?}: capped at 0 iterations: {} kept-last-safe, {} inexact of {} frames",
            stats.kept_last_safe,
            stats.inexact,
            frames.len()
        );
        // The cap is what keeps the last safe pose: measured 128-129 of the 251 frames (cap 0: any solve that must change its warm-started
        // active set stops) (every
        // frame of the tilted press, none in free space), and the statistics count exactly
        // the frames that did.
        let kept: Vec<usize> = (0..frames.len())
            .filter(|&i| frames[i].frame.status == FrameStatus::KeptLastSafe)
            .collect();
        assert_eq!(stats.kept_last_safe, kept.len() as u64, "{kind:?}");
        assert!(
            (100..=160).contains(&kept.len()),
            "{kind:?}: {} kept-last-safe frames (measured 128-129)",
            kept.len()
        );
        for &i in &kept {
            assert!(
                frames[i].frame.pairs > 0,
                "{kind:?} frame {i}: kept-last-safe without contact"
            );
            assert_eq!(
                frames[i].frame.q_g,
                frames[i - 1].frame.q_g,
                "{kind:?} frame {i}: a kept frame moved the tool"
            );
        }
        let inexact = frames
            .iter()
            .filter(|f| f.frame.status == FrameStatus::Inexact)
            .count();
        assert_eq!(stats.inexact, inexact as u64, "{kind:?}");
        if kind != SolverKind::Pqp {
            // An exact solver either finishes or hits the cap: never inexact.
            assert_eq!(inexact, 0, "{kind:?}");
        }
        // Without the cap the exact solvers keep nothing: the count above is the cap's.
        if kind != SolverKind::Pqp {
            let (_, free) = run(&sc, &traj);
            assert_eq!(free.kept_last_safe, 0, "{kind:?} uncapped");
        }
    }
}

#[test]
fn fast_rotation_swings_a_long_tool_through_the_plate_never_tunnels() {
    // Rotation alone: an 80 mm bar pivoting about its middle swings its end 35 mm down in one
    // frame, from above the plate's sphere layer to below it (the margin must include
    // angle × reach, not only the translation).
    let (plate, _) = plate_tree(0.5);
    let top = sphere_top(&plate);
    let bar = build_tree(
        &box_mesh(40.0, 2.0, 2.0),
        &BuildParams::fastest_build(3),
        &|_| {},
    )
    .unwrap();
    let leaves: Vec<([f64; 3], f64)> = bar
        .leaves()
        .map(|n| bar.sphere(n))
        .filter(|s| s.is_used())
        .map(|s| (s.center, s.radius))
        .collect();
    let lowest = |q: &[f64; 6]| {
        let pose = Pose::from_array(*q);
        leaves
            .iter()
            .map(|(c, r)| pose.transform_point(c)[2] - r)
            .fold(f64::INFINITY, f64::min)
    };
    let mut sc = scene(plate, SolverSpec::default(), Coupling::default());
    sc.tool = bar;
    // Level, its lowest point 3 mm above the sphere layer; then pitched by 1.2 rad (beta, about
    // y) in one frame, held, and back.
    let z0 = top + 3.0 - lowest(&[0.0; 6]);
    let level = [0.0, 0.0, z0, 0.0, 0.0, 0.0];
    let pitched = [0.0, 0.0, z0, 0.0, 1.2, 0.0];
    assert!(
        lowest(&pitched) < -top,
        "the motion must cross the whole sphere layer"
    );
    for relinearize in [0, 3] {
        let spec = SolverSpec {
            relinearize,
            ..SolverSpec::default()
        };
        sc.solver = spec;
        let traj = keyed(&[
            (0, level),
            (5, level),
            (6, pitched),
            (60, pitched),
            (61, level),
            (80, level),
        ]);
        let (frames, _) = run(&sc, &traj);
        assert_eq!(frames.len(), traj.len());
        assert_safe_output(&frames, &sc.safety);
        for (i, f) in frames.iter().enumerate() {
            // Near side: every leaf of the bar above the plate's mid-plane, and not inside it.
            let low = lowest(&f.frame.q_g);
            assert!(
                low > 0.0,
                "relinearize {relinearize} frame {i}: the bar reached z = {low} (tunnelled)"
            );
            assert!(
                f.frame.penetration_mm <= 0.01,
                "relinearize {relinearize} frame {i}: penetration {}",
                f.frame.penetration_mm
            );
        }
        // Held pitched: the bar rests on the plate with a restoring torque.
        let held = &frames[59];
        assert!(held.frame.q_g[4] < 1.2 - 0.05, "{:?}", held.frame.q_g);
        assert!(
            held.frame.raw_wrench[4].abs() > 1.0,
            "{:?}",
            held.frame.raw_wrench
        );
    }
}

#[test]
fn huge_device_readings_keep_the_output_safe() {
    // Finite but absurd readings (a corrupt encoder count): 1e15 mm (0.075 mm of penetration
    // before readings beyond 1e6 were refused: `q - q_h` kept too few digits), 1e300 mm, 1e6 rad. The
    // frame must not produce NaN (e.g. inf - inf in the spring), the tool must not jump through
    // the plate, and the output stays within the limits.
    let (plate, _) = plate_tree(0.5);
    let top = sphere_top(&plate);
    let sc = scene(plate, SolverSpec::default(), Coupling::default());
    let mut traj = press_trajectory(top);
    traj.samples[250].q[2] = -1e15;
    traj.samples[260].q = [1e300, -1e300, -1e300, 0.0, 0.0, 0.0];
    traj.samples[270].q[4] = 1e6;
    traj.samples[280].q[0] = f64::MAX;
    // Up to the 1e6 plausibility bound: processed normally, still safe; beyond: refused.
    traj.samples[290].q[2] = -1e6;
    traj.samples[300].q = [5e5, -5e5, 1e5, 3e5, -1e5, 9e5];
    traj.samples[310].q = [5e8, -5e8, 1e8, 3e8, -1e8, 9e8];
    traj.samples[320].q[5] = 9e8;
    traj.samples[330].q = [50.0, -50.0, 10.0, 3.0, -1.0, 2.5];
    traj.samples[340].q[3] = 3.0;
    traj.samples[340].q[4] = -1.0;
    traj.samples[340].q[5] = 2.5;
    let (frames, _) = run(&sc, &traj);
    assert_eq!(frames.len(), traj.len());
    assert_safe_output(&frames, &sc.safety);
    for (i, f) in frames.iter().enumerate() {
        assert!(
            f.frame.q_g.iter().all(|v| v.is_finite()),
            "frame {i}: {:?}",
            f.frame.q_g
        );
        assert!(
            f.frame.q_g[2] > 2.0,
            "frame {i}: tunnelled to {:?}",
            f.frame.q_g
        );
        assert!(
            f.frame.penetration_mm <= 0.01,
            "frame {i}: {}",
            f.frame.penetration_mm
        );
    }
    // Back to normal readings: normal contact again (a frame preempted past its budget on a
    // busy test machine may lag, safely).
    assert!(matches!(
        frames[traj.len() - 1].frame.status,
        FrameStatus::Ok | FrameStatus::Lagging
    ));
}

/// A frame budget far below what a traversal near the contact costs: the deadline stops the
/// traversals and the solves, every frame is safe (finite, within the tolerance, never through
/// the plate), the tool still moves where it can, and the stopped frames are counted as lagging.
#[test]
fn a_budget_too_small_for_the_contact_lags_and_stays_safe() {
    let (plate, _) = plate_tree(1.0);
    let top = sphere_top(&plate);
    for budget_us in [0.5, 5.0, 40.0] {
        let solver = SolverSpec {
            budget_us,
            ..SolverSpec::default()
        };
        let sc = scene(plate.clone(), solver, Coupling::default());
        // The overlap measured here, not by the engine (whose measure covers the pairs it
        // listed): a traversal the deadline stopped must not count as a proof of free space.
        let mut overlap = common::overlap_of(&sc);
        // Down through the plate and out below it, slowly, then sideways.
        let traj = keyed(&[
            (0, [0.0, 0.0, top + 20.0, 0.0, 0.0, 0.0]),
            (300, [0.0, 0.0, top - 10.0, 0.0, 0.0, 0.0]),
            (600, [15.0, 5.0, top - 10.0, 0.0, 0.3, 0.0]),
        ]);
        let (frames, stats) = run(&sc, &traj);
        assert_safe_output(&frames, &sc.safety);
        for r in &frames {
            let f = &r.frame;
            assert!(f.penetration_mm <= 0.01, "budget {budget_us}: {f:?}");
            let depth = overlap(&Pose::from_array(f.q_g));
            assert!(
                depth <= 0.01,
                "budget {budget_us}: the tool overlaps the plate by {depth} mm at t = {} s",
                f.t
            );
            // The tool's leaves (radius 2) stay on the near side of the plate's mid-plane.
            assert!(
                f.q_g[2] > 2.0,
                "budget {budget_us}: through the plate {f:?}"
            );
            assert!(f.q_g.iter().all(|v| v.is_finite()));
        }
        // It moved: from 20 mm above the plate toward it.
        let lowest = frames
            .iter()
            .map(|r| r.frame.q_g[2])
            .fold(f64::INFINITY, f64::min);
        assert!(
            lowest < top + 10.0,
            "budget {budget_us}: never came down ({lowest})"
        );
        if budget_us < 10.0 {
            assert!(
                stats.lagging > 0,
                "budget {budget_us}: the deadline never stopped a frame"
            );
        }
    }
}

/// The splined shaft inside its hub, pushed sideways into the wall, at the default budget and
/// at 100 µs (a 10 kHz loop): the traversals there cost hundreds of µs (thousands of node
/// pairs, most without a leaf pair), the deadline stops them, the free-space proofs come from
/// background probes (one that a frame's deadline stopped is carried on by the next frames).
/// The tool must never overlap the hub — checked here, independently of the engine's own
/// measure (a traversal the deadline stopped proves nothing) — and must still reach the wall
/// and be held there.
#[test]
fn pushed_into_the_wall_of_a_tight_hole_the_shaft_never_overlaps_the_hub() {
    for budget_us in [1000.0, 100.0] {
        pushed_into_the_wall(budget_us);
    }
}

fn pushed_into_the_wall(budget_us: f64) {
    let mut sc = scene::scenes::builtin("spline", &common::test_cache()).unwrap();
    sc.solver.budget_us = budget_us;
    let inside = sc
        .trajectory()
        .samples
        .iter()
        .find(|s| s.t >= 2.8)
        .unwrap()
        .q;
    let mut wall = inside;
    wall[0] += 3.0;
    wall[1] += 1.0;
    let traj = keyed(&[(0, inside), (400, wall), (700, wall)]);
    let mut overlap = common::overlap_of(&sc);
    let (frames, _) = run(&sc, &traj);
    for r in &frames {
        let f = &r.frame;
        let depth = overlap(&Pose::from_array(f.q_g));
        assert!(
            depth <= 0.01,
            "budget {budget_us}: the shaft overlaps the hub by {depth} mm at t = {} s ({:?})",
            f.t,
            f.status
        );
    }
    // It moved toward the wall, stopped at it, and the wall holds the hand back.
    let last = &frames[frames.len() - 1].frame;
    assert!(
        last.q_g[0] > inside[0] + 0.3,
        "budget {budget_us}: never reached the wall: {last:?}"
    );
    assert!(
        last.q_g[0] < inside[0] + 2.0,
        "budget {budget_us}: went through the wall: {last:?}"
    );
    assert!(
        last.wrench[0] < -0.5,
        "budget {budget_us}: no force from the wall: {last:?}"
    );
}
