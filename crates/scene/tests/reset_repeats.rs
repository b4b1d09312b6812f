//! A reset forgets the run: an engine that ran part of a scene's motion and was reset to its
//! start gives, frame for frame, what a freshly made engine gives (poses, wrenches after the
//! safety layer, statuses, pair and row counts, detection work, friction state), and the same
//! counters. Anything learnt while running that a reset kept (a warm start, a prediction, a
//! cached region, a free-space proof, a probe's pacing, a neighbour list, friction's stick or
//! slip) would show in these frames.
//!
//! The frame budget is raised to its largest value so that no pass is cut by the clock: a
//! frame's outcome then depends on its input only and two runs compare exactly.

mod common;

use collide::Pose;
use engine::{Counters, Engine, Frame};
use scene::Scene;

fn scene(name: &str) -> Scene {
    let mut scene = scene::scenes::builtin(name, &common::test_cache()).unwrap();
    scene.solver.budget_us = engine::config::BUDGET_US.hi;
    scene
}

/// The frame without its wall-clock times.
fn untimed(frame: &Frame) -> Frame {
    Frame {
        cd_us: 0.0,
        opt_us: 0.0,
        total_us: 0.0,
        ..*frame
    }
}

/// Resets `engine` to the motion's start and steps the first `frames` samples at 1 kHz: the
/// frames, untimed, the counters and the god-object's region counts.
fn run(
    engine: &mut Engine,
    samples: &[scene::trajectory::TrajSample],
    frames: usize,
) -> (Vec<Frame>, Counters, (u64, u64)) {
    engine.reset(&Pose::from_array(samples[0].q)).unwrap();
    let frames = samples[..frames]
        .iter()
        .enumerate()
        .map(|(i, s)| untimed(engine.step(i as f64 * 1e-3, &Pose::from_array(s.q))))
        .collect();
    let regions = engine.god_object_mut().region_counts();
    (frames, *engine.counters(), regions)
}

fn check(name: &str) {
    let scene = scene(name);
    let samples = scene.trajectory().samples;
    let n = samples.len();
    let fresh = run(&mut scene.engine().unwrap(), &samples, n);
    assert!(
        fresh.0.iter().any(|f| f.contacts > 0),
        "{name}: the motion never touches"
    );
    let mut engine = scene.engine().unwrap();
    // Stopped in the middle of the motion (in contact, probes and lists running), then reset.
    for cut in [n / 3, n / 2, 2 * n / 3] {
        run(&mut engine, &samples, cut);
        let again = run(&mut engine, &samples, n);
        if let Some((i, (a, b))) = fresh
            .0
            .iter()
            .zip(&again.0)
            .enumerate()
            .find(|(_, (a, b))| a != b)
        {
            panic!(
                "{name}, reset after {cut} frames: frame {i} differs from a fresh engine's\n\
                 fresh: {a:?}\nreset: {b:?}"
            );
        }
        assert_eq!(
            fresh.1, again.1,
            "{name}, reset after {cut} frames: counters"
        );
        assert_eq!(
            fresh.2, again.2,
            "{name}, reset after {cut} frames: regions"
        );
    }
}

#[test]
fn bunny_after_a_reset_repeats_a_fresh_engine() {
    check("bunny");
}

#[test]
fn spline_after_a_reset_repeats_a_fresh_engine() {
    check("spline");
}

#[test]
fn plate_after_a_reset_repeats_a_fresh_engine() {
    check("plate");
}
