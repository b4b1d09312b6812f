//! The `contact` study of `haptic6d bench`: large and tight contacts, where detection and the
//! QP hold hundreds to thousands of pairs.
//!
//! - **flat on flat**: the plate scene's puck pressed 1 mm onto the plate, resting, then slid
//!   at 50 mm/s ([`scene::scenes::plate`]).
//! - **spline**: the built-in splined shaft and hub, by phase of its script: on the hub's face
//!   with the keys misaligned, turning until they align, inserting, and the frames inside the
//!   hole with no pair at all (the tight 1 mm clearance).
//!
//! Per row (dual solver, one thread, frames back to back): pairs of the first region (p50,
//! max), detection / optimisation / whole-step time (p50, p99, max), passes, degraded frames
//! (lagging, pair overflow, kept last safe) and the deepest penetration.

use anyhow::Result;
use collide::Pose;
use engine::step::{FrameOutput, FrameStatus};
use engine::SolverKind;
use scene::cache::TreeCache;
use scene::scenes::plate::{self, PlateTool, SpeedMotion};
use scene::stats::Summary;
use scene::Scene;
use serde::Serialize;

/// One row of the contact study.
#[derive(Serialize, Clone, Debug)]
pub struct ContactRow {
    /// Scene.
    pub scene: String,
    /// Phase of the scene's motion.
    pub phase: String,
    /// Frames in the phase.
    pub frames: usize,
    /// Pairs of the first region per frame.
    pub pairs: Summary,
    /// Detection time per frame, µs.
    pub cd_us: Summary,
    /// Rows and QP time per frame, µs.
    pub opt_us: Summary,
    /// Whole step per frame, µs.
    pub total_us: Summary,
    /// Passes per frame.
    pub passes: Summary,
    /// Frames that ended lagging, with a pair overflow, or kept the last safe pose.
    pub degraded_frames: usize,
    /// Deepest overlap, mm.
    pub max_penetration_mm: f64,
}

/// Steps a fresh god-object with `solver` through the scene's device motion: the device times
/// (s) and every frame's output.
pub fn replay(scene: &Scene, solver: SolverKind) -> Result<(Vec<f64>, Vec<FrameOutput>)> {
    let traj = scene.trajectory();
    let mut scene = scene.clone();
    scene.solver.kind = solver;
    let mut god = scene.god_object()?;
    let first = traj
        .samples
        .first()
        .map(|s| Pose::from_array(s.q))
        .unwrap_or_default();
    god.reset(&first)?;
    let mut times = Vec::with_capacity(traj.samples.len());
    let mut out = Vec::with_capacity(traj.samples.len());
    for s in &traj.samples {
        times.push(s.t);
        out.push(god.step(&Pose::from_array(s.q)));
    }
    Ok((times, out))
}

fn row<'a>(
    scene: &str,
    phase: &str,
    frames: impl Iterator<Item = &'a FrameOutput> + Clone,
) -> ContactRow {
    let f = frames.clone();
    ContactRow {
        scene: scene.into(),
        phase: phase.into(),
        frames: f.clone().count(),
        pairs: Summary::of(f.clone().map(|o| f64::from(o.pairs))),
        cd_us: Summary::of(f.clone().map(|o| o.cd_us)),
        opt_us: Summary::of(f.clone().map(|o| o.opt_us)),
        total_us: Summary::of(f.clone().map(|o| o.total_us)),
        passes: Summary::of(f.clone().map(|o| f64::from(o.passes))),
        degraded_frames: f
            .clone()
            .filter(|o| {
                matches!(
                    o.status,
                    FrameStatus::Lagging | FrameStatus::PairOverflow | FrameStatus::KeptLastSafe
                )
            })
            .count(),
        max_penetration_mm: f.map(|o| o.penetration_mm).fold(0.0, f64::max),
    }
}

/// Runs the study (the flat-on-flat slide is shorter with `quick`).
pub fn contact_study(cache: &TreeCache, quick: bool) -> Result<Vec<ContactRow>> {
    let mut rows = Vec::new();
    let run = plate::speed_script(
        PlateTool::Puck,
        SpeedMotion::Slide(50.0),
        1000.0,
        if quick { 0.3 } else { 1.0 },
    );
    let scene = plate::scene(cache, PlateTool::Puck, run.script.clone())?;
    let (t, frames) = replay(&scene, SolverKind::Dual)?;
    let pressed = |&(ti, _): &(&f64, &FrameOutput)| *ti >= 0.2;
    let rest_end = run.steady.first().map_or(0.3, |s| s.0);
    rows.push(row(
        "flat on flat",
        "resting, 1 mm press",
        t.iter()
            .zip(&frames)
            .filter(move |p| pressed(p) && *p.0 < rest_end)
            .map(|p| p.1),
    ));
    rows.push(row(
        "flat on flat",
        "sliding 50 mm/s",
        t.iter()
            .zip(&frames)
            .filter(|(ti, _)| run.steady.iter().any(|&(a, b)| **ti >= a && **ti < b))
            .map(|p| p.1),
    ));
    let scene = scene::scenes::builtin("spline", cache)?;
    let (t, frames) = replay(&scene, SolverKind::Dual)?;
    // The script's phases (scene::scenes::spline_scene): approach 0.5 s, rest 0.2 s, turn
    // 1.2 s, rest 0.2 s, insert 1.0 s, rest 0.2 s, withdraw 0.8 s.
    let phase = |a: f64, b: f64| {
        t.iter()
            .zip(&frames)
            .filter(move |(ti, _)| **ti >= a && **ti < b)
            .map(|p| p.1)
    };
    rows.push(row("spline", "on the face", phase(0.5, 0.7)));
    rows.push(row("spline", "alignment (turning)", phase(0.7, 1.9)));
    rows.push(row("spline", "insertion", phase(2.1, 3.3)));
    rows.push(row(
        "spline",
        "in the hole, no pair",
        t.iter()
            .zip(&frames)
            .filter(|(_, o)| o.pairs == 0 && o.q_h[2] < 0.0)
            .map(|p| p.1),
    ));
    rows.push(row("spline", "whole run", frames.iter()));
    Ok(rows)
}

/// The study as a markdown table.
pub fn contact_markdown(rows: &[ContactRow]) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "| scene | phase | frames | pairs p50 / max | cd µs p50 / p99 | opt µs p50 / p99 | total µs p50 / p99 / max | passes mean / max | degraded | max pen. mm |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|---|");
    for r in rows {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {:.0} / {:.0} | {:.1} / {:.1} | {:.1} / {:.1} | {:.1} / {:.1} / {:.1} | {:.2} / {:.0} | {} | {:.4} |",
            r.scene,
            r.phase,
            r.frames,
            r.pairs.p50,
            r.pairs.max,
            r.cd_us.p50,
            r.cd_us.p99,
            r.opt_us.p50,
            r.opt_us.p99,
            r.total_us.p50,
            r.total_us.p99,
            r.total_us.max,
            r.passes.mean,
            r.passes.max,
            r.degraded_frames,
            r.max_penetration_mm,
        );
    }
    s
}
