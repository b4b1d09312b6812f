//! The old path and the new one give the same frames: each built-in scene's trajectory
//! (bunny, spline, plate) is replayed through `haptic6d run`'s loop as it was (the god-object
//! step, then the safety filter, as two calls) and through [`engine::Engine::step`], and the
//! `frames.csv` text is compared without its timing columns.
//!
//! The frame budget is raised to its largest value so that no pass is cut by the clock: with
//! it, a frame's outcome depends on its input only and two runs can be compared byte for byte.

mod common;

use collide::Pose;
use render::device::ReplayDevice;
use render::report::frames_csv;
use render::rt::{run_loop, LoopParams};
use render::safety::Safety;
use render::scene::Scene;

/// Column indices of `frames.csv` that hold wall-clock times (cd_us, opt_us, total_us).
const TIMING_COLUMNS: [usize; 3] = [20, 21, 22];

fn without_timings(csv: &str) -> String {
    let mut out = String::with_capacity(csv.len());
    for line in csv.lines() {
        let kept: Vec<&str> = line
            .split(',')
            .enumerate()
            .filter(|(i, _)| !TIMING_COLUMNS.contains(i))
            .map(|(_, v)| v)
            .collect();
        out.push_str(&kept.join(","));
        out.push('\n');
    }
    out
}

fn scene(name: &str) -> Scene {
    let mut scene = render::scenes::builtin(name, &common::test_cache()).unwrap();
    scene.solver.budget_us = engine::config::BUDGET_US.hi;
    scene
}

/// The loop of `haptic6d run` before the engine: `GodObject::step` then `Safety::filter`.
fn old_path(scene: &Scene) -> String {
    let traj = scene.trajectory();
    let mut god = scene.god_object().unwrap();
    god.reset(&Pose::from_array(traj.samples[0].q)).unwrap();
    let mut safety = Safety::new(scene.safety);
    let mut device = ReplayDevice::new(traj);
    let report = run_loop(&mut god, &mut device, &mut safety, &LoopParams::default()).unwrap();
    without_timings(&frames_csv(&report.frames))
}

/// The same frames through the engine: one call per frame, the safety clock at
/// `frame / rate` as the loop's.
fn new_path(scene: &Scene) -> String {
    let traj = scene.trajectory();
    let mut engine = scene.engine().unwrap();
    engine.reset(&Pose::from_array(traj.samples[0].q)).unwrap();
    let mut csv = without_timings(render::report::FRAMES_HEADER);
    let rate = LoopParams::default().rate_hz;
    for (i, s) in traj.samples.iter().enumerate() {
        let f = engine.step(i as f64 / rate, &Pose::from_array(s.q));
        let mut row = format!("{}", s.t);
        for v in f.q_h.iter().chain(f.q_g.iter()).chain(f.wrench.iter()) {
            row.push_str(&format!(",{v}"));
        }
        row.push_str(&format!(
            ",{},{},{},{},{}\n",
            f.pairs,
            f.iterations,
            f.penetration_mm,
            f.passes,
            f.status.name()
        ));
        csv.push_str(&row);
    }
    csv
}

fn check(name: &str) {
    let scene = scene(name);
    let old = old_path(&scene);
    let new = new_path(&scene);
    assert!(old.lines().count() > 1000, "{name}: too few frames");
    if let Some((i, (a, b))) = old
        .lines()
        .zip(new.lines())
        .enumerate()
        .find(|(_, (a, b))| a != b)
    {
        panic!("{name}: line {} differs\nold: {a}\nnew: {b}", i + 1);
    }
    assert_eq!(old.lines().count(), new.lines().count(), "{name}");
}

#[test]
fn bunny_frames_are_identical_through_the_engine() {
    check("bunny");
}

#[test]
fn spline_frames_are_identical_through_the_engine() {
    check("spline");
}

#[test]
fn plate_frames_are_identical_through_the_engine() {
    check("plate");
}
