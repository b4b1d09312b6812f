//! A reset forgets the run: an engine that ran part of a scene's motion and was reset (to the
//! motion's start, or in contact where it stopped) gives, frame for frame, what a freshly made
//! engine reset there gives (the reset's answer, poses, wrenches after the safety layer,
//! statuses, pair and row counts, detection work, friction state), and the same counters and
//! region counts. Anything learnt while running that a reset kept (a warm start, a prediction, a
//! cached region, a free-space proof, a probe's pacing, a neighbour list, friction's stick or
//! slip) would show in these frames.
//!
//! The frame budget is raised to its largest value so that no pass is cut by the clock: a
//! frame's outcome then depends on its input only and two runs compare exactly.

mod common;

use std::time::{Duration, Instant};

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
        ahead_us: 0.0,
        ..*frame
    }
}

/// What a run gave: the reset's answer, the frames (untimed), the counters and the
/// god-object's region counts.
#[derive(Debug, PartialEq)]
struct Run {
    reset: Result<[f64; 6], String>,
    frames: Vec<Frame>,
    counters: Counters,
    regions: (u64, u64),
}

/// Resets `engine` to `start` (default: the hand's pose at sample `from`) and steps the
/// samples `from..to` at 1 kHz.
fn run(
    engine: &mut Engine,
    samples: &[scene::trajectory::TrajSample],
    start: Option<[f64; 6]>,
    from: usize,
    to: usize,
) -> Run {
    let start = start.unwrap_or(samples[from].q);
    let reset = engine
        .reset(&Pose::from_array(start))
        .map(|q| q.to_array())
        .map_err(|e| e.to_string());
    let frames = samples[from..to]
        .iter()
        .enumerate()
        .map(|(i, s)| untimed(engine.step(i as f64 * 1e-3, &Pose::from_array(s.q))))
        .collect();
    Run {
        reset,
        frames,
        counters: *engine.counters(),
        regions: engine.god_object_mut().region_counts(),
    }
}

/// Panics where `again` (after a reset) differs from `fresh`.
fn same(name: &str, what: &str, fresh: &Run, again: &Run) {
    assert_eq!(fresh.reset, again.reset, "{name}, {what}: the reset");
    if let Some((i, (a, b))) = fresh
        .frames
        .iter()
        .zip(&again.frames)
        .enumerate()
        .find(|(_, (a, b))| a != b)
    {
        panic!(
            "{name}, {what}: frame {i} differs from a fresh engine's\n\
             fresh: {a:?}\nreset: {b:?}"
        );
    }
    assert_eq!(
        fresh.frames.len(),
        again.frames.len(),
        "{name}, {what}: frames"
    );
    assert_eq!(fresh.counters, again.counters, "{name}, {what}: counters");
    assert_eq!(
        fresh.regions, again.regions,
        "{name}, {what}: region counts"
    );
}

fn check(name: &str) {
    let scene = scene(name);
    let samples = scene.trajectory().samples;
    let n = samples.len();
    let fresh = run(&mut scene.engine().unwrap(), &samples, None, 0, n);
    assert!(fresh.reset.is_ok(), "{name}: {:?}", fresh.reset);
    let touching: Vec<usize> = (0..n).filter(|&i| fresh.frames[i].contacts > 0).collect();
    assert!(touching.len() > 100, "{name}: the motion hardly touches");
    let mut engine = scene.engine().unwrap();
    // Stopped in the middle of the motion (probes and lists running), then reset to its start.
    for cut in [n / 3, n / 2, 2 * n / 3] {
        run(&mut engine, &samples, None, 0, cut);
        let again = run(&mut engine, &samples, None, 0, n);
        same(
            name,
            &format!("reset to the start after {cut} frames"),
            &fresh,
            &again,
        );
    }
    // Reset where the last run stopped, in contact: at the tool's last, touching, pose, and
    // at the hand's pose there (inside the object: the reset finds a free pose near it, or
    // fails; a short run follows either way). A fresh engine reset there is the reference:
    // the near part of the tool, the pairs, the warm start, the friction patch, the safety
    // layer's ramp and the counters of the last run are all at hand, and must not be used.
    for k in [touching[touching.len() / 4], touching[touching.len() / 2]] {
        for (at, to) in [(Some(fresh.frames[k - 1].q_g), n), (None, (k + 200).min(n))] {
            let fresh_k = run(&mut scene.engine().unwrap(), &samples, at, k, to);
            run(&mut engine, &samples, None, 0, k);
            // A paced loop's wait before the next frame, in which the reset comes.
            engine.idle(Instant::now() + Duration::from_micros(500));
            let again = run(&mut engine, &samples, at, k, to);
            let whence = if at.is_some() {
                "the tool's"
            } else {
                "the hand's"
            };
            same(
                name,
                &format!("reset in contact at frame {k}, at {whence} pose"),
                &fresh_k,
                &again,
            );
        }
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
