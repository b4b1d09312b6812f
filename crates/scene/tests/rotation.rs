//! The rotational part of the coupling: the torque is the physical one (the gradient of the
//! rotational spring's energy in world axes), every representation of the same orientation gives
//! the same frame, and the Euler singularity at `beta = ±pi/2` does not exist for the step.

mod common;

use std::f64::consts::{FRAC_PI_2, PI};

use collide::{rotation_exp, rotation_log, Pose, RotationCoordinates};
use engine::step::{spring_wrench, FrameStatus, GodObject};
use nalgebra::Vector3;
use proptest::prelude::*;
use scene::scenes::plate::{self, PlateTool};
use scene::trajectory::{Ease, Script};

const G: [f64; 6] = [1.0, 1.0, 1.0, 1000.0, 1000.0, 1000.0];

/// Spring energy (N·mm) between the graphic pose and the hand pose.
fn energy(q_g: &Pose, t_h: &Vector3<f64>, r_h: &nalgebra::Matrix3<f64>) -> f64 {
    let dt = q_g.translation() - t_h;
    let w = rotation_log(&(q_g.rotation_matrix() * r_h.transpose()));
    0.5 * G[0] * dt.norm_squared() + 0.5 * G[3] * w.norm_squared()
}

fn pose_strategy() -> impl Strategy<Value = Pose> {
    (
        proptest::array::uniform3(-50.0f64..50.0),
        -PI..PI,
        -1.5f64..1.5,
        -PI..PI,
        0u8..3,
    )
        .prop_map(|(t, g, b, a, lock)| {
            let b = match lock {
                1 => FRAC_PI_2,
                2 => -FRAC_PI_2,
                _ => b,
            };
            Pose::from_array([t[0], t[1], t[2], g, b, a])
        })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    /// `[F; T]` on the hand is minus the gradient of the spring energy with respect to the
    /// hand's world-frame translation and rotation (`R_h <- exp([d]x) R_h`), at any
    /// orientations including `beta = ±pi/2` exactly, and angles up to 2.5 rad apart.
    #[test]
    fn torque_is_the_energy_gradient(q_h in pose_strategy(), dt in proptest::array::uniform3(-5.0f64..5.0), w in proptest::array::uniform3(-1.4f64..1.4)) {
        let r_h = q_h.rotation_matrix();
        let r_g = rotation_exp(&Vector3::from(w)) * r_h;
        let t_g = q_h.translation() + Vector3::from(dt);
        let q_g = Pose::from_translation_rotation(&t_g, &r_g);
        let wrench = spring_wrench(&G, RotationCoordinates::RotationVector, &q_g, &q_h);
        let h = 1e-6;
        for k in 0..6 {
            let mut d = Vector3::zeros();
            d[k % 3] = h;
            let (plus, minus) = if k < 3 {
                (energy(&q_g, &(q_h.translation() + d), &r_h), energy(&q_g, &(q_h.translation() - d), &r_h))
            } else {
                (energy(&q_g, &q_h.translation(), &(rotation_exp(&d) * r_h)),
                 energy(&q_g, &q_h.translation(), &(rotation_exp(&-d) * r_h)))
            };
            let grad = (plus - minus) / (2.0 * h);
            let scale = if k < 3 { 1e-6 } else { 1e-3 };
            prop_assert!((wrench[k] + grad).abs() <= scale * wrench[k].abs().max(1.0),
                "component {}: wrench {} vs -dE {}", k, wrench[k], -grad);
        }
    }
}

/// The ball on the plate, pressed 1 mm, its device script turning about `axis` (index 3, 4 or
/// 5 of q) from `from` to `to` rad in `secs` s.
fn ball_turning(index: usize, from: f64, to: f64, secs: f64) -> Vec<Pose> {
    let mut start = [0.0, 0.0, 2.0, 0.0, 0.0, 0.0];
    start[index] = from;
    let mut pressed = start;
    pressed[2] = -plate::PRESS_MM;
    let mut end = pressed;
    end[index] = to;
    let script = Script::starting_at(start)
        .then(0.2, pressed, Ease::Smooth)
        .hold(0.05)
        .then(secs, end, Ease::Linear);
    script
        .to_trajectory(1000.0)
        .samples
        .iter()
        .map(|s| Pose::from_array(s.q))
        .collect()
}

fn run(traj: &[Pose], tool: PlateTool) -> Vec<engine::step::FrameOutput> {
    let cache = common::test_cache();
    let mut scene = plate::scene(&cache, tool, Script::starting_at(traj[0].to_array())).unwrap();
    // Whole spheres: the plate's bumps give the turning puck a contact torque to compare
    // (on a face-capped frictionless plate it turns freely: no torque).
    scene.solver.face_caps = false;
    let mut params = scene.engine_config();
    // Algorithmic behaviour, not timing: no pass is cut by a busy machine (the frames of two
    // runs are compared exactly).
    params.budget_us = 1e6;
    let mut god = GodObject::new(&scene.tool, &scene.objects, params).unwrap();
    god.reset(&traj[0]).unwrap();
    traj.iter().map(|q| god.step(q)).collect()
}

/// A device that reports angles wrapped into (-pi, pi] gives the same frames as one that
/// reports them unwrapped (the torque does not flip, the tool turns the same way).
#[test]
fn wrapped_angles_give_the_same_frames() {
    // The puck pressed onto the plate, turning about the vertical axis through alpha = pi.
    let unwrapped = {
        let start = [0.0, 0.0, 2.0, 0.0, 0.0, 2.6];
        let pressed = [0.0, 0.0, -1.0, 0.0, 0.0, 2.6];
        let end = [0.0, 0.0, -1.0, 0.0, 0.0, 3.8];
        Script::starting_at(start)
            .then(0.2, pressed, Ease::Smooth)
            .hold(0.05)
            .then(0.4, end, Ease::Linear)
            .to_trajectory(1000.0)
            .samples
            .iter()
            .map(|s| Pose::from_array(s.q))
            .collect::<Vec<_>>()
    };
    let wrapped: Vec<Pose> = unwrapped
        .iter()
        .map(|q| {
            let mut w = *q;
            if w.q[5] > PI {
                w.q[5] -= 2.0 * PI;
            }
            w
        })
        .collect();
    assert!(
        wrapped.iter().any(|q| q.q[5] < 0.0),
        "the script must cross pi"
    );
    let a = run(&unwrapped, PlateTool::Puck);
    let b = run(&wrapped, PlateTool::Puck);
    let mut turning = 0;
    for (i, (fa, fb)) in a.iter().zip(&b).enumerate() {
        for k in 0..6 {
            let tol = if k < 3 { 1e-6 } else { 1e-3 };
            assert!(
                (fa.wrench[k] - fb.wrench[k]).abs() <= tol,
                "frame {i}, component {k}: {} vs {}",
                fa.wrench[k],
                fb.wrench[k]
            );
        }
        let ra = Pose::from_array(fa.q_g).rotation_matrix();
        let rb = Pose::from_array(fb.q_g).rotation_matrix();
        assert!((ra - rb).norm() < 1e-6, "frame {i}: graphic tools differ");
        turning += usize::from(fa.wrench[5].abs() > 1.0);
    }
    // The frames compared include real contact torque, not only zeros.
    assert!(turning > 50, "only {turning} frames with torque");
}

/// The ball pressed onto the plate and turned about y through beta = pi/2 gives the same
/// frames as the physically identical turn that stays far from the Euler singularity: the same
/// ball with its tree turned by pi/2 about y beforehand, its hand turning from -0.6 to 0.6 rad.
/// The world geometry is the same at every instant; only the device's Euler angles differ (one
/// run passes through gimbal lock), so the forces must agree.
#[test]
fn turning_through_the_euler_singularity_is_uneventful() {
    let cache = common::test_cache();
    let through = ball_turning(4, FRAC_PI_2 - 0.6, FRAC_PI_2 + 0.6, 0.4);
    let away = ball_turning(4, -0.6, 0.6, 0.4);
    let scene = plate::scene(
        &cache,
        PlateTool::Ball,
        Script::starting_at(through[0].to_array()),
    )
    .unwrap();
    let mut turned = scene.clone();
    let ry = collide::rotation_zyx(0.0, FRAC_PI_2, 0.0);
    for sphere in turned.tool.spheres_mut() {
        if sphere.is_used() {
            sphere.center = (ry * Vector3::from(sphere.center)).into();
        }
    }
    let run_on = |scene: &scene::Scene, traj: &[Pose]| {
        let mut params = scene.engine_config();
        params.budget_us = 1e6;
        let mut god = GodObject::new(&scene.tool, &scene.objects, params).unwrap();
        god.reset(&traj[0]).unwrap();
        traj.iter().map(|q| god.step(q)).collect::<Vec<_>>()
    };
    let a = run_on(&scene, &through);
    let b = run_on(&turned, &away);
    let mut pressed = 0;
    for (i, (fa, fb)) in a.iter().zip(&b).enumerate() {
        assert_eq!(fa.status, fb.status, "frame {i}");
        assert!(
            matches!(fa.status, FrameStatus::Ok),
            "frame {i}: {:?}",
            fa.status
        );
        for k in 0..6 {
            // A frame is exact to its convergence test (0.005 mm, 0.005 N at kt = 1 N/mm): runs
            // whose rounding makes them take other regions (a neighbour list ready a frame
            // apart) may differ by that much.
            let tol = if k < 3 { 5e-3 } else { 0.5 };
            assert!(
                (fa.wrench[k] - fb.wrench[k]).abs() <= tol,
                "frame {i}, component {k}: {} through pi/2 vs {} away from it",
                fa.wrench[k],
                fb.wrench[k]
            );
        }
        assert!(fa.penetration_mm <= 0.01);
        pressed += usize::from(fa.wrench[2] > 0.5);
    }
    assert!(pressed > 300, "only {pressed} frames pressed");
}
