//! Every zoo scene replayed with no deadline (`budget_us` at its maximum, so the frames are the
//! same on a loaded machine): finite answers, no penetration beyond the engine's tolerance, the
//! tool on the hand in free space, contact where the script presses (on every object the scene
//! presses at once: the corner's three faces, three balls of the field), and the keyed shaft
//! inserted.

mod common;

use common::test_cache;
use engine::step::FrameOutput;
use scene::scenes::zoo::{self, ZooScene};

/// How far the graphic tool may be from the hand in free space, mm and rad.
const FREE_LAG_MM: f64 = 1e-6;
const FREE_LAG_RAD: f64 = 1e-6;

/// A leaf pair this close at the graphic pose counts as touching, mm: the engine's own
/// contact count's gap.
const TOUCH_MM: f64 = engine::step::TOUCH_MM;

fn in_window(t: f64, w: (f64, f64)) -> bool {
    t >= w.0 && t <= w.1
}

/// The replayed frames and their device times (s).
fn replay(z: &ZooScene) -> (Vec<f64>, Vec<FrameOutput>) {
    let traj = z.scene.trajectory();
    let frames = common::replay(&z.scene);
    (traj.samples.iter().map(|s| s.t).collect(), frames)
}

fn check(name: &str) {
    let mut z = zoo::zoo_scene(name, &test_cache()).unwrap();
    z.scene.solver.budget_us = engine::config::BUDGET_US.hi;
    let tol = z.scene.solver.penetration_tol_mm;
    let (times, frames) = replay(&z);
    assert!(!frames.is_empty(), "{name}: no frame");
    // The trees as the step sees them: whole spheres unless the scene turns face caps on.
    let mut as_stepped = z.scene.clone();
    if !as_stepped.solver.face_caps {
        for (t, _) in &mut as_stepped.objects {
            t.set_caps(Vec::new()).unwrap();
        }
    }
    let (tool, objects) = common::packed(&as_stepped);
    let mut ws = collide::CollideWorkspace::for_trees(&tool, &objects);
    let mut fewest_touched = usize::MAX;
    let mut touched_when_pressed = 0;
    let mut pressed_frames = 0;
    for (t, f) in times.iter().zip(&frames) {
        let finite = f.q_g.iter().chain(&f.wrench).all(|v| v.is_finite());
        assert!(finite, "{name}: non-finite frame at {t:.3} s: {f:?}");
        assert!(
            f.penetration_mm <= tol + 1e-12,
            "{name}: penetration {:.4} mm at {t:.3} s (tolerance {tol} mm)",
            f.penetration_mm
        );
        if z.phases.free_s.iter().any(|&w| in_window(*t, w)) {
            let lag_mm = (0..3)
                .map(|k| (f.q_g[k] - f.q_h[k]).abs())
                .fold(0.0, f64::max);
            let lag_rad = (3..6)
                .map(|k| (f.q_g[k] - f.q_h[k]).abs())
                .fold(0.0, f64::max);
            assert!(
                lag_mm <= FREE_LAG_MM && lag_rad <= FREE_LAG_RAD && f.pairs == 0,
                "{name}: in free space at {t:.3} s the tool is {lag_mm:.2e} mm, {lag_rad:.2e} rad \
                 from the hand ({} pairs)",
                f.pairs
            );
        }
        if in_window(*t, z.phases.pressed_s) {
            pressed_frames += 1;
            let force = (0..3)
                .map(|k| f.wrench[k] * f.wrench[k])
                .sum::<f64>()
                .sqrt();
            // The hand is `press_mm` past the first contact: at kt the spring holds about
            // kt · press_mm; a quarter of it says the tool was stopped by the object.
            if f.contacts > 0 && force >= 0.25 * z.scene.coupling.kt * z.phases.press_mm {
                touched_when_pressed += 1;
            }
            let mut touched = vec![false; objects.len()];
            let q_g = collide::Pose::from_array(f.q_g);
            collide::overlap_tree_trees(&tool, &q_g, &objects, TOUCH_MM, &mut ws, |p| {
                touched[p.object as usize] |= p.gap <= TOUCH_MM;
            })
            .unwrap();
            fewest_touched = fewest_touched.min(touched.iter().filter(|&&t| t).count());
        }
    }
    if let Some(scene::Goal::InsertZ {
        target_z_mm,
        tol_mm,
    }) = z.scene.goal
    {
        let deepest = frames
            .iter()
            .map(|f| f.q_g[2])
            .fold(f64::INFINITY, f64::min);
        assert!(
            deepest <= target_z_mm + tol_mm,
            "{name}: the tool went down to z = {deepest:.2} mm, short of the insertion target \
             {target_z_mm} mm"
        );
    }
    assert!(pressed_frames > 0, "{name}: no frame in the pressed rest");
    assert!(
        fewest_touched >= z.phases.touching_objects,
        "{name}: the pressed tool touched only {fewest_touched} objects at once, expected {}",
        z.phases.touching_objects
    );
    assert_eq!(
        touched_when_pressed, pressed_frames,
        "{name}: the tool touched in only {touched_when_pressed} of the {pressed_frames} \
         frames of the pressed rest"
    );
}

#[test]
fn every_zoo_scene_is_exact_safe_follows_in_free_space_and_touches_when_pressed() {
    let mut failures = Vec::new();
    for name in zoo::names() {
        let t0 = std::time::Instant::now();
        if let Err(e) = std::panic::catch_unwind(|| check(name)) {
            let msg = e
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| e.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            failures.push(msg);
        }
        eprintln!("{name}: {:.2} s", t0.elapsed().as_secs_f64());
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn zoo_names_resolve_as_built_in_scenes() {
    for name in zoo::names() {
        assert!(scene::scenes::is_builtin(name), "{name}");
    }
    assert!(zoo::zoo_scene("zoo/none", &test_cache()).is_err());
    assert!(zoo::ZOO.len() >= 12);
}
