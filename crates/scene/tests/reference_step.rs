//! The shipped frame step against the reference step
//! ([`engine::step::GodObject::reference_step`]: one full-width ball region per pass, no
//! reuse, lists, proofs, probes or deadline), frame by frame on a reduced scene zoo, with every
//! heuristic on and with each one off in turn ([`engine::Heuristics`]).
//!
//! Each compared frame starts both steps from the shipped step's own previous pose and hand,
//! friction off and no deadline. The shipped step must never penetrate; where both reach the
//! optimum, its answer must be the reference's within [`AGREE_MM`], or no farther from the
//! hand (its spring energy at most [`ENERGY_SLACK`] above the reference's: on bumpy sphere
//! surfaces both stop within the convergence tolerance of a constrained optimum, from their
//! own sequences of linearisations, and these are not unique). A few frames may find another
//! local optimum of the non-convex contact ([`OTHER_OPTIMA_SHARE`]; the thin plate's edge),
//! within [`OTHER_OPTIMUM_EXCESS`] of the reference's energy.
//!
//! `cargo test --release -p scene --test reference_step -- --ignored` runs the whole zoo and
//! the built-ins.

mod common;

use collide::{rotation_log, Pose};
use engine::{FrameStatus, Geometry, Heuristics, Tuning};
use std::time::{Duration, Instant};

/// How far apart (mm, largest tool-sphere motion) two answers count as the same: a few times
/// the convergence tolerance (0.005 mm of open rows) plus the penetration tolerance.
const AGREE_MM: f64 = 0.02;

/// How much higher the shipped answer's spring energy may be than the reference's, as a share
/// of it, where the two differ by more than [`AGREE_MM`].
const ENERGY_SLACK: f64 = 0.01;

/// Share of compared frames that may end at another local optimum, and how much higher its
/// energy may be (share of the reference's).
const OTHER_OPTIMA_SHARE: f64 = 0.002;
const OTHER_OPTIMUM_EXCESS: f64 = 0.06;

/// The reduced zoo of the tests: a curved mesh tool, a thin plate, an edge, a keyed shaft, a
/// gear pair, a probe over bumps, a large tool and the capped plate (slab regions).
const SCENES: &[&str] = &[
    "bunny",
    "plate",
    "zoo/thin-plate",
    "zoo/cube-edge",
    "zoo/keyed-shaft",
    "zoo/gears",
    "zoo/probe-bumps",
    "zoo/big-tool",
];

/// What one scene's comparison found.
#[derive(Debug, Default)]
struct Agreement {
    compared: usize,
    /// Frames farther than [`AGREE_MM`] from the reference's answer.
    apart: usize,
    /// Of those, frames higher in energy than [`ENERGY_SLACK`] allows, and the largest excess.
    worse: usize,
    worst_excess: f64,
    /// Frames the reference answered and the shipped step did not (stopped short: lagging or
    /// kept at its last safe pose).
    short: usize,
}

/// How far apart two poses are: translation plus the turn's angle times the tool's reach, mm.
fn distance(a: &[f64; 6], b: &[f64; 6], reach: f64) -> f64 {
    let (pa, pb) = (Pose::from_array(*a), Pose::from_array(*b));
    let dt = (pa.translation() - pb.translation()).norm();
    let turn = rotation_log(&(pa.rotation_matrix() * pb.rotation_matrix().transpose())).norm();
    dt + turn * reach
}

/// The spring's energy from the wrench it sends, up to the factor 1/2: `|F|²/kt + |T|²/kr`.
fn energy(w: &[f64; 6], kt: f64, kr: f64) -> f64 {
    (0..3).map(|i| w[i] * w[i] / kt).sum::<f64>() + (3..6).map(|i| w[i] * w[i] / kr).sum::<f64>()
}

/// Replays `name` in `geometry` with `heuristics` and `tuning`, comparing every `stride`-th
/// frame with the reference; with `wait`, each frame followed by that much of a paced loop's
/// wait given to the engine (`GodObject::idle`).
fn compare(
    name: &str,
    geometry: Geometry,
    heuristics: Heuristics,
    tuning: Tuning,
    stride: usize,
    wait: Option<Duration>,
) -> Agreement {
    let cache = common::test_cache();
    let mut s = scene::scenes::builtin(name, &cache).unwrap();
    s.solver.budget_us = engine::config::BUDGET_US.hi;
    s.solver.geometry = geometry;
    assert_eq!(s.geometry(), geometry, "{name}");
    s.solver.heuristics = heuristics;
    s.solver.tuning = tuning;
    let (tol, kt, kr) = (s.solver.penetration_tol_mm, s.coupling.kt, s.coupling.kr);
    let traj = s.trajectory();
    let mut shipped = s.god_object().unwrap();
    shipped.set_friction_enabled(false);
    let mut reference = s.god_object().unwrap();
    shipped.reset(&Pose::from_array(traj.samples[0].q)).unwrap();
    let reach = shipped.reach();
    let mut a = Agreement::default();
    for (k, sample) in traj.samples.iter().enumerate() {
        let q_h = Pose::from_array(sample.q);
        let prev = shipped.q_g();
        let f = shipped.step(&q_h);
        if let Some(wait) = wait {
            shipped.idle(Instant::now() + wait);
        }
        assert!(
            f.q_g.iter().chain(&f.wrench).all(|v| v.is_finite()),
            "{name}: frame {k} is not finite with {heuristics:?}"
        );
        assert!(
            f.penetration_mm <= tol + 1e-12,
            "{name}: frame {k} penetrates {:.4} mm with {heuristics:?}",
            f.penetration_mm
        );
        if k % stride != 0 {
            continue;
        }
        assert_eq!(
            reference.reset(&prev).unwrap().q,
            prev.q,
            "{name}: frame {k}"
        );
        let r = reference.reference_step(&q_h);
        assert!(
            r.penetration_mm <= tol + 1e-12,
            "{name}: the reference penetrates at frame {k}"
        );
        if r.status == FrameStatus::Ok && f.status != FrameStatus::Ok {
            a.short += 1;
        }
        if f.status != FrameStatus::Ok || r.status != FrameStatus::Ok {
            continue;
        }
        a.compared += 1;
        if distance(&f.q_g, &r.q_g, reach) <= AGREE_MM {
            continue;
        }
        a.apart += 1;
        let (es, er) = (energy(&f.wrench, kt, kr), energy(&r.wrench, kt, kr));
        if es > er * (1.0 + ENERGY_SLACK) + 1e-9 {
            a.worse += 1;
            a.worst_excess = a.worst_excess.max(es / er - 1.0);
        }
    }
    a
}

/// Checks every scene of `scenes` with `heuristics` on the leaf spheres.
fn check(scenes: &[&str], heuristics: Heuristics, stride: usize) {
    check_in(scenes, Geometry::Spheres, heuristics, stride);
}

/// Checks every scene of `scenes` in `geometry` with `heuristics`.
fn check_in(scenes: &[&str], geometry: Geometry, heuristics: Heuristics, stride: usize) {
    check_tuned(scenes, geometry, heuristics, Tuning::DEFAULT, stride);
}

/// Checks every scene of `scenes` in `geometry` with `heuristics` and `tuning`.
fn check_tuned(
    scenes: &[&str],
    geometry: Geometry,
    heuristics: Heuristics,
    tuning: Tuning,
    stride: usize,
) {
    check_waiting(scenes, geometry, heuristics, tuning, stride, None);
}

/// [`check_tuned`] with each frame followed by `wait` given to the engine (a paced loop's).
fn check_waiting(
    scenes: &[&str],
    geometry: Geometry,
    heuristics: Heuristics,
    tuning: Tuning,
    stride: usize,
    wait: Option<Duration>,
) {
    for name in scenes {
        let a = compare(name, geometry, heuristics, tuning, stride, wait);
        eprintln!("{name} (waiting {wait:?}): {a:?}");
        if geometry == Geometry::Mesh {
            assert!(
                a.short as f64 <= MESH_SHORT_SHARE * (a.compared + a.short) as f64,
                "{name} with {heuristics:?}: {} frames short where the reference answers",
                a.short
            );
        }
        assert!(
            a.compared > 0,
            "{name}: no frame where both reach the optimum"
        );
        assert!(
            a.worse as f64 <= OTHER_OPTIMA_SHARE * a.compared as f64
                && a.worst_excess <= OTHER_OPTIMUM_EXCESS,
            "{name} with {heuristics:?}: {} of {} frames end farther from the hand than the \
             reference (energy up to {:.1} % higher)",
            a.worse,
            a.compared,
            100.0 * a.worst_excess
        );
    }
}

/// Every heuristic but `name`.
fn without(name: &str) -> Heuristics {
    Heuristics::without(name).unwrap()
}

#[test]
fn the_shipped_step_answers_as_the_reference() {
    check(SCENES, Heuristics::ALL, 1);
}

#[test]
fn every_heuristic_off_in_turn_stays_exact_and_safe_regions() {
    for name in [
        "region-reuse",
        "path-regions",
        "slab-regions",
        "density-sizing",
    ] {
        check(SCENES, without(name), 4);
    }
}

#[test]
fn every_heuristic_off_in_turn_stays_exact_and_safe_proofs() {
    for name in ["free-space-proofs", "background-probes", "neighbour-lists"] {
        check(SCENES, without(name), 4);
    }
}

#[test]
fn every_heuristic_off_in_turn_stays_exact_and_safe_trust() {
    for name in ["lever", "recentre", "turned-trust", "warm-start"] {
        check(SCENES, without(name), 4);
    }
}

/// The mesh mode's scenes: a slot, an edge and a keyed shaft, every body from a mesh.
const MESH_SCENES: &[&str] = &["zoo/slot", "zoo/cube-edge", "zoo/keyed-shaft"];

/// Share of compared frames the shipped step may leave short where the reference answers, in
/// the mesh mode.
const MESH_SHORT_SHARE: f64 = 0.01;

#[test]
fn in_the_mesh_mode_the_shipped_step_and_each_mesh_switch_off_answer_as_the_reference() {
    for (heuristics, stride) in [
        (Heuristics::ALL, 4),
        (without("mesh-near-list"), 8),
        (without("mesh-far-rows"), 8),
        (without("mesh-flat-faces"), 8),
        (without("mesh-face-splits"), 8),
        (without("mesh-tilted-targets"), 8),
        (without("mesh-pair-directions"), 8),
        (without("mesh-thin-paths"), 8),
        (without("mesh-held-press"), 8),
        (without("mesh-list-inherit"), 8),
        (without("mesh-near-fill"), 8),
        (without("mesh-bound-detects"), 8),
        (without("mesh-region-falls"), 8),
        (without("mesh-slow-growth"), 8),
        (without("mesh-near-part"), 8),
        (without("mesh-near-part-give-up"), 8),
        (without("mesh-slice-ceiling"), 8),
        // (At this budget the fill level is the fixed share either way: the switch times the
        // lists ahead of a haptic budget, not what they list.)
        (without("mesh-fill-own-level"), 8),
    ] {
        check_in(MESH_SCENES, Geometry::Mesh, heuristics, stride);
    }
}

/// Every tuned value scaled by `factor` at once.
fn all_scaled(factor: f64) -> Tuning {
    let mut t = Tuning::DEFAULT;
    for name in Tuning::NAMES {
        t = t.with(name, factor * t.get(name).unwrap()).unwrap();
    }
    t.validate().unwrap();
    t
}

/// The tuned values set how much work a frame does, not what it answers: every one halved,
/// or every one doubled, the step still answers as the reference on both geometries (at the
/// shipped step's own strides: on the keyed shaft's non-convex contact a few frames reach
/// another local optimum, and the share allowed is counted over that many frames).
#[test]
fn every_tuned_value_halved_or_doubled_stays_exact_and_safe() {
    for factor in [0.5, 2.0] {
        let tuning = all_scaled(factor);
        assert_ne!(tuning, Tuning::DEFAULT);
        check_tuned(SCENES, Geometry::Spheres, Heuristics::ALL, tuning, 4);
        check_tuned(MESH_SCENES, Geometry::Mesh, Heuristics::ALL, tuning, 4);
    }
}

#[test]
fn every_heuristic_off_at_once_stays_exact_and_safe() {
    check(SCENES, Heuristics::NONE, 4);
}

/// In a paced loop the wait builds the mesh mode's next near lists and takes them
/// (`mesh-idle-take`): the frames after it answer as the reference too, with the take in the
/// wait and without it. (A wait of 300 µs a frame, as a 1 kHz loop gives after its nap.)
#[test]
fn in_the_mesh_mode_a_paced_loop_answers_as_the_reference_with_its_wait_and_without_the_take() {
    for heuristics in [Heuristics::ALL, without("mesh-idle-take")] {
        let wait = Some(Duration::from_micros(300));
        check_waiting(
            MESH_SCENES,
            Geometry::Mesh,
            heuristics,
            Tuning::DEFAULT,
            4,
            wait,
        );
    }
}

#[test]
fn every_switch_is_among_those_tested_off() {
    let source = include_str!("reference_step.rs");
    for name in Heuristics::NAMES {
        assert!(
            source.contains(&format!("\"{name}\"")),
            "{name} is not tested off"
        );
    }
}

#[test]
#[ignore = "the whole zoo, every frame: minutes"]
fn the_whole_zoo_answers_as_the_reference() {
    let names: Vec<&str> = scene::scenes::sphere_builtin_names()
        .chain(scene::scenes::zoo::names())
        .collect();
    check(&names, Heuristics::ALL, 1);
}
