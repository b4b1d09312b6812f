//! Each built-in scene's motion (bunny, spline, plate) replayed through `haptic6d run`'s loop
//! (one [`engine::Engine::step`] per frame), every frame checked against what a god-object
//! frame must be, measured here and not by the engine:
//!
//! - the tool is free: its deepest leaf overlap at `q_g`, from a traversal of the trees at
//!   margin 0, is within the penetration tolerance;
//! - a solved frame holds the tool back from the hand only by a contact: where `q_g` is not the
//!   hand's pose, some leaf pair at `q_g` is within touching distance;
//! - the raw wrench is the coupling spring, `F = kt (t_g - t_h)` and `T = kr log(R_g R_h^T)`,
//!   written out here from the rotation matrices;
//! - the wrench sent is the raw one where the safety layer did nothing, and otherwise within
//!   its force and torque limits and rate limits.
//!
//! The frame budget is raised to its largest value so that no pass is cut by the clock: the
//! frames are then the solved ones the checks expect, whatever the machine's load.

mod common;

use collide::{CollideWorkspace, PackedTree, Pose};
use engine::{EngineConfig, Frame, FrameStatus};
use nalgebra::{Matrix3, Rotation3, Vector3};
use scene::device::ReplayDevice;
use scene::rt::{run_loop, LoopParams};
use scene::Scene;

/// A frame held back from the hand is touching when a leaf pair at `q_g` is at most this far
/// apart (mm): the step stops when no holding row is open by more than its convergence
/// tolerance (5 µm), and counts pairs within 10 µm as touching.
const HELD_GAP_MM: f64 = engine::step::TOUCH_MM;

/// A graphic pose within this of the hand's, per coordinate (mm, rad), is the hand's: the
/// step's rounding through its QP coordinates, not a contact.
const AT_HAND: f64 = 1e-12;

/// How far (mm, rad) the coupling's stretch measured here may differ from the engine's: its
/// translation is the same subtraction; the rotation's logarithm is written another way here,
/// and the two round differently (measured: up to 4e-12 rad on the spline's turns).
const SPRING_MM_TOL: f64 = 1e-9;
const SPRING_RAD_TOL: f64 = 1e-10;

fn scene(name: &str) -> Scene {
    let mut scene = scene::scenes::builtin(name, &common::test_cache()).unwrap();
    scene.solver.budget_us = engine::config::BUDGET_US.hi;
    scene
}

/// The scene's trees packed as the engine packs them (face caps dropped unless turned on).
fn packed(scene: &Scene) -> (PackedTree, Vec<PackedTree>) {
    let (tool, mut objects) = common::packed(scene);
    if !scene.engine_config().face_caps {
        objects.iter_mut().for_each(|o| o.drop_face_cuts());
    }
    (tool, objects)
}

/// What the frames are checked against: the trees, a workspace and the settings.
struct Checker {
    tool: PackedTree,
    objects: Vec<PackedTree>,
    ws: CollideWorkspace,
    config: EngineConfig,
}

impl Checker {
    fn new(scene: &Scene) -> Self {
        let (tool, objects) = packed(scene);
        let ws = CollideWorkspace::for_trees(&tool, &objects);
        Self {
            tool,
            objects,
            ws,
            config: scene.engine_config(),
        }
    }

    /// The smallest leaf-pair gap at `q` among pairs within `margin` (mm; infinite if none).
    fn min_gap(&mut self, q: &Pose, margin: f64) -> f64 {
        scene::scenes::min_gap(&self.tool, &self.objects, q, margin, &mut self.ws)
    }

    /// Checks `frame` (after `prev`, the frame before it if any); says what is wrong.
    fn check(&mut self, frame: &Frame, prev: Option<&Frame>) -> Result<(), String> {
        let q_g = Pose::from_array(frame.q_g);
        let q_h = Pose::from_array(frame.q_h);
        if !q_g.is_finite() || !frame.wrench.iter().all(|v| v.is_finite()) {
            return Err("not finite".into());
        }
        let tol = self.config.penetration_tol_mm;
        let overlap = (-self.min_gap(&q_g, 0.0)).max(0.0);
        if overlap > tol + 1e-9 {
            return Err(format!("the tool overlaps an object by {overlap} mm"));
        }
        // (A pose the step rounded through its coordinates is the hand's.)
        let at_hand = (0..6).all(|k| (frame.q_g[k] - frame.q_h[k]).abs() <= AT_HAND);
        if frame.status == FrameStatus::Ok && !at_hand {
            let gap = self.min_gap(&q_g, HELD_GAP_MM);
            if gap > HELD_GAP_MM {
                return Err(format!(
                    "held back from the hand with no contact (nearest pair over {HELD_GAP_MM} mm \
                     away)"
                ));
            }
        }
        let spring = self.spring(&q_g, &q_h);
        for k in 0..6 {
            let tol = if k < 3 {
                self.config.kt * SPRING_MM_TOL
            } else {
                self.config.kr * SPRING_RAD_TOL
            };
            if (frame.raw_wrench[k] - spring[k]).abs() > tol {
                return Err(format!(
                    "raw wrench {:?} is not the spring {spring:?}",
                    frame.raw_wrench
                ));
            }
        }
        self.check_sent(frame, prev)
    }

    /// The coupling spring between the graphic tool and the hand: `F = kt (t_g - t_h)` (N),
    /// `T = kr log(R_g R_h^T)` (N·mm, world axes).
    fn spring(&self, q_g: &Pose, q_h: &Pose) -> [f64; 6] {
        let f = (q_g.translation() - q_h.translation()) * self.config.kt;
        let r: Matrix3<f64> = q_g.rotation_matrix() * q_h.rotation_matrix().transpose();
        let t: Vector3<f64> = Rotation3::from_matrix_unchecked(r).scaled_axis() * self.config.kr;
        [f.x, f.y, f.z, t.x, t.y, t.z]
    }

    /// The wrench sent: the raw one where the safety layer did nothing, else within its limits.
    fn check_sent(&self, frame: &Frame, prev: Option<&Frame>) -> Result<(), String> {
        let s = &self.config.safety;
        let norm = |w: &[f64]| w.iter().map(|v| v * v).sum::<f64>().sqrt();
        if frame.safety == 0 && frame.wrench != frame.raw_wrench {
            return Err(
                "the safety layer did nothing, yet the wrench sent is not the raw one".into(),
            );
        }
        if norm(&frame.wrench[..3]) > s.max_force_n * (1.0 + 1e-12) {
            return Err(format!("force {:?} over the limit", &frame.wrench[..3]));
        }
        if norm(&frame.wrench[3..]) > s.max_torque_nmm * (1.0 + 1e-12) {
            return Err(format!("torque {:?} over the limit", &frame.wrench[3..]));
        }
        let last = prev.map_or([0.0; 6], |p| p.wrench);
        let step: Vec<f64> = (0..6).map(|k| frame.wrench[k] - last[k]).collect();
        if norm(&step[..3]) > s.max_force_step_n * (1.0 + 1e-9) {
            return Err(format!("force changed by {:?} in a frame", &step[..3]));
        }
        if norm(&step[3..]) > s.max_torque_step_nmm * (1.0 + 1e-9) {
            return Err(format!("torque changed by {:?} in a frame", &step[3..]));
        }
        Ok(())
    }
}

/// The scene's motion through `haptic6d run`'s loop: every frame.
fn replay(scene: &Scene) -> Vec<Frame> {
    let traj = scene.trajectory();
    let mut engine = scene.engine().unwrap();
    engine.reset(&Pose::from_array(traj.samples[0].q)).unwrap();
    let mut device = ReplayDevice::new(traj);
    let report = run_loop(&mut engine, &mut device, &LoopParams::default()).unwrap();
    report.frames.iter().map(|r| r.frame).collect()
}

fn check(name: &str) {
    let scene = scene(name);
    let frames = replay(&scene);
    assert!(frames.len() > 1000, "{name}: too few frames");
    let held = frames
        .iter()
        .filter(|f| f.status == FrameStatus::Ok && f.q_g != f.q_h)
        .count();
    assert!(
        held > 100,
        "{name}: the motion hardly presses ({held} frames)"
    );
    let mut checker = Checker::new(&scene);
    for (i, f) in frames.iter().enumerate() {
        if let Err(e) = checker.check(f, i.checked_sub(1).map(|p| &frames[p])) {
            panic!("{name}: frame {i} (t = {} s): {e}\n{f:?}", f.t);
        }
    }
}

#[test]
fn bunny_frames_are_god_object_frames() {
    check("bunny");
}

#[test]
fn spline_frames_are_god_object_frames() {
    check("spline");
}

#[test]
fn plate_frames_are_god_object_frames() {
    check("plate");
}

/// The checks catch a wrong frame: a tool pushed into the object, a tool held back in free
/// space, a spring of the wrong sign, a wrench sent past the rate limit.
#[test]
fn the_checks_catch_wrong_frames() {
    let scene = scene("bunny");
    let frames = replay(&scene);
    let mut checker = Checker::new(&scene);
    // The first frame whose hand is pressed over a millimetre into the object, and the frame
    // before it.
    let depth = |f: &Frame| {
        (Pose::from_array(f.q_h).translation() - Pose::from_array(f.q_g).translation()).norm()
    };
    let i = frames
        .iter()
        .position(|f| f.status == FrameStatus::Ok && f.contacts > 0 && depth(f) > 1.0)
        .unwrap();
    let (good, prev) = (frames[i], frames[i - 1]);
    checker.check(&good, Some(&prev)).unwrap();
    // Halfway from the god-object to the hand (which presses into the object).
    let mut pushed = good;
    let q = |k: usize| 0.5 * (good.q_g[k] + good.q_h[k]);
    pushed.q_g = std::array::from_fn(q);
    let mut free = frames[0];
    free.q_g[0] += 1.0;
    let mut flipped = good;
    flipped.raw_wrench.iter_mut().for_each(|w| *w = -*w);
    let mut jump = good;
    jump.wrench[0] = prev.wrench[0] + 2.0 * scene.safety.max_force_step_n;
    jump.safety = engine::safety::flags::RATE_LIMIT;
    for (frame, before, caught) in [
        (pushed, Some(&prev), "overlaps"),
        (free, None, "no contact"),
        (flipped, Some(&prev), "not the spring"),
        (jump, Some(&prev), "changed by"),
    ] {
        let e = checker.check(&frame, before).unwrap_err();
        assert!(e.contains(caught), "expected `{caught}`: {e}");
    }
}
