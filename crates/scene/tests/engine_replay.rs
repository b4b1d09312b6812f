//! The old path and the new one give the same frames: each built-in scene's trajectory
//! (bunny, spline, plate) is replayed through `haptic6d run`'s frame body as it was before the
//! engine (the god-object step, then the safety filter, as two calls) and through the loop as
//! it is (one [`engine::Engine::step`] per frame), and the `frames.csv` text is compared
//! without its timing columns.
//!
//! The frame budget is raised to its largest value so that no pass is cut by the clock: with
//! it, a frame's outcome depends on its input only and two runs can be compared byte for byte.

mod common;

use collide::Pose;
use engine::safety::Safety;
use scene::device::ReplayDevice;
use scene::report::frames_csv;
use scene::rt::{run_loop, LoopParams};
use scene::Scene;

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
    let mut scene = scene::scenes::builtin(name, &common::test_cache()).unwrap();
    scene.solver.budget_us = engine::config::BUDGET_US.hi;
    scene
}

/// The frame body of `haptic6d run` before the engine, as two calls: `GodObject::step`, then
/// `Safety::filter` on the loop's clock `frame / rate`.
fn old_path(scene: &Scene) -> String {
    let traj = scene.trajectory();
    let mut god = scene.god_object().unwrap();
    god.reset(&Pose::from_array(traj.samples[0].q)).unwrap();
    let mut safety = Safety::new(scene.safety);
    let mut csv = without_timings(scene::report::FRAMES_HEADER);
    let rate = LoopParams::default().pacing.rate_hz;
    for (i, s) in traj.samples.iter().enumerate() {
        let out = god.step(&Pose::from_array(s.q));
        let (sent, _flags) = safety.filter(i as f64 / rate, out.wrench);
        let mut row = format!("{}", s.t);
        for v in out.q_h.iter().chain(out.q_g.iter()).chain(sent.iter()) {
            row.push_str(&format!(",{v}"));
        }
        row.push_str(&format!(
            ",{},{},{},{},{},{},{}\n",
            out.pairs,
            out.iterations,
            out.penetration_mm,
            out.passes,
            out.status.name(),
            out.splits,
            out.scanned
        ));
        csv.push_str(&row);
    }
    csv
}

/// `haptic6d run`'s loop now: one [`engine::Engine::step`] per frame, written by `frames_csv`.
fn new_path(scene: &Scene) -> String {
    let traj = scene.trajectory();
    let mut engine = scene.engine().unwrap();
    engine.reset(&Pose::from_array(traj.samples[0].q)).unwrap();
    let mut device = ReplayDevice::new(traj);
    let report = run_loop(&mut engine, &mut device, &LoopParams::default()).unwrap();
    without_timings(&frames_csv(&report.frames))
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
