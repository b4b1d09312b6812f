//! The `ablation` study of `haptic6d bench`: the frame step's heuristics
//! ([`engine::Heuristics`]) turned off one at a time, and all together, on every built-in and
//! zoo scene, with the shipped settings (dual solver, 1 ms budget, one thread, frames back to
//! back). One row per configuration, summed or compared over the scenes:
//!
//! - frames over 1 ms and degraded frames (lagging, pair overflow, kept last safe), summed;
//! - the whole-step time's p99 per scene, as the geometric mean of its ratio to the shipped
//!   step's (all on) and the worst scene's p99 (µs);
//! - detection work, node pairs split and neighbour-list entries tested over all frames, as a
//!   ratio to the shipped step's (machine-independent: the same input gives the same counts);
//! - the deepest overlap at the graphic pose (mm, the engine's measure);
//! - drag while the hand slides the tool pressed, the mean over the zoo scenes (N).
//!
//! A heuristic pays where turning it off raises the times, the work or the degraded frames;
//! one whose row matches the shipped step's does not pay on these scenes.
//! `--quick` runs the reduced zoo ([`crate::bench_zoo::QUICK_SCENES`]).

use anyhow::Result;
use engine::step::FrameOutput;
use engine::{Heuristics, SolverKind};
use scene::cache::TreeCache;
use scene::scenes::zoo;
use scene::stats::Summary;
use serde::Serialize;

/// One scene under one configuration.
#[derive(Serialize, Clone, Debug)]
pub struct AblationScene {
    /// Scene name.
    pub scene: String,
    /// Whole step per frame, µs.
    pub total_us: Summary,
    /// Frames over 1 ms.
    pub over_1ms: usize,
    /// Lagging, pair-overflow and kept-last-safe frames.
    pub degraded: usize,
    /// Node pairs split and neighbour-list entries tested, over all frames.
    pub splits: u64,
    pub scanned: u64,
    /// Deepest leaf overlap at the graphic pose, mm.
    pub max_penetration_mm: f64,
    /// Mean force opposing the tool's motion while the hand slides it pressed, N (zoo scenes;
    /// `None` for the built-ins, which have no slide phase).
    pub drag_n: Option<f64>,
}

/// One configuration's row.
#[derive(Serialize, Clone, Debug)]
pub struct AblationRow {
    /// `shipped` (all on), `no <switch>` or `none` (all off).
    pub config: String,
    /// Frames over 1 ms, summed over the scenes.
    pub over_1ms: usize,
    /// Degraded frames, summed.
    pub degraded: usize,
    /// Geometric mean over the scenes of p99 / the shipped step's p99.
    pub p99_ratio: f64,
    /// Geometric mean over the scenes of the mean frame time / the shipped step's.
    pub mean_ratio: f64,
    /// The largest p99 (µs) and its scene.
    pub worst_p99_us: f64,
    pub worst_scene: String,
    /// Node pairs split and list entries tested, over all scenes, / the shipped step's.
    pub splits_ratio: f64,
    pub scanned_ratio: f64,
    /// Deepest overlap over all scenes, mm.
    pub max_penetration_mm: f64,
    /// Mean drag over the zoo scenes, N.
    pub drag_n: f64,
    /// Per scene.
    pub scenes: Vec<AblationScene>,
}

/// The configurations, in order: the shipped step, each switch off, all off.
fn configurations() -> Vec<(String, Heuristics)> {
    let mut c = vec![("shipped".to_string(), Heuristics::ALL)];
    // The study replays the leaf spheres, where the mesh mode's switches do nothing.
    for name in Heuristics::NAMES
        .into_iter()
        .filter(|n| !Heuristics::mesh_only(n))
    {
        if let Some(h) = Heuristics::without(name) {
            c.push((format!("no {name}"), h));
        }
    }
    c.push(("none".to_string(), Heuristics::NONE));
    c
}

/// Runs the study over the built-ins and the zoo (the reduced zoo with `quick`).
pub fn ablation_study(cache: &TreeCache, quick: bool) -> Result<Vec<AblationRow>> {
    let names: Vec<&str> = if quick {
        crate::bench_zoo::QUICK_SCENES.to_vec()
    } else {
        // The sphere-mode built-ins only: the study replays the leaf spheres.
        scene::scenes::sphere_builtin_names()
            .chain(zoo::names())
            .collect()
    };
    // Each scene built once; its phases (for drag) where it is a zoo scene.
    let mut scenes = Vec::with_capacity(names.len());
    for name in &names {
        let phases = if zoo::is_zoo(name) {
            Some(zoo::zoo_scene(name, cache)?.phases)
        } else {
            None
        };
        scenes.push((scene::scenes::builtin(name, cache)?, phases));
    }
    let mut rows: Vec<AblationRow> = Vec::new();
    for (config, heuristics) in configurations() {
        let mut per_scene = Vec::with_capacity(scenes.len());
        for (s, phases) in &scenes {
            let mut s = s.clone();
            s.solver.heuristics = heuristics;
            let (times, frames, _) =
                crate::bench_contact::replay_audited(&s, SolverKind::Dual, false, false)?;
            per_scene.push(scene_result(&s.name, &times, &frames, phases.as_ref()));
        }
        let row = summarize(config, per_scene, rows.first());
        eprintln!(
            "bench: ablation {}: {} over 1 ms, {} degraded, p99 x{:.2}, work x{:.2}",
            row.config, row.over_1ms, row.degraded, row.p99_ratio, row.splits_ratio
        );
        rows.push(row);
    }
    Ok(rows)
}

pub(crate) fn scene_result(
    name: &str,
    times: &[f64],
    frames: &[FrameOutput],
    phases: Option<&zoo::ZooPhases>,
) -> AblationScene {
    let drag = phases.map(|p| crate::bench_zoo::slide_drag(times, frames, p.slide_s));
    AblationScene {
        scene: name.to_string(),
        total_us: Summary::of(frames.iter().map(|f| f.total_us)),
        over_1ms: frames.iter().filter(|f| f.total_us > 1000.0).count(),
        degraded: frames.iter().filter(|f| f.status.is_degraded()).count(),
        splits: frames.iter().map(|f| u64::from(f.splits)).sum(),
        scanned: frames.iter().map(|f| u64::from(f.scanned)).sum(),
        max_penetration_mm: frames.iter().map(|f| f.penetration_mm).fold(0.0, f64::max),
        drag_n: drag,
    }
}

pub(crate) fn summarize(
    config: String,
    scenes: Vec<AblationScene>,
    shipped: Option<&AblationRow>,
) -> AblationRow {
    let base = shipped.map_or(&scenes, |r| &r.scenes);
    let ratio = |a: f64, b: f64| if b > 0.0 { a / b } else { 1.0 };
    let geo_mean = |f: fn(&AblationScene) -> f64| {
        let log_sum: f64 = scenes
            .iter()
            .zip(base)
            .map(|(s, b)| ratio(f(s), f(b)).max(1e-9).ln())
            .sum();
        (log_sum / scenes.len().max(1) as f64).exp()
    };
    let worst = scenes
        .iter()
        .max_by(|a, b| a.total_us.p99.total_cmp(&b.total_us.p99));
    let total =
        |v: &[AblationScene], f: fn(&AblationScene) -> u64| v.iter().map(f).sum::<u64>() as f64;
    let drags: Vec<f64> = scenes.iter().filter_map(|s| s.drag_n).collect();
    AblationRow {
        config,
        over_1ms: scenes.iter().map(|s| s.over_1ms).sum(),
        degraded: scenes.iter().map(|s| s.degraded).sum(),
        p99_ratio: geo_mean(|s| s.total_us.p99),
        mean_ratio: geo_mean(|s| s.total_us.mean),
        worst_p99_us: worst.map_or(0.0, |w| w.total_us.p99),
        worst_scene: worst.map_or_else(String::new, |w| w.scene.clone()),
        splits_ratio: ratio(total(&scenes, |s| s.splits), total(base, |s| s.splits)),
        scanned_ratio: ratio(total(&scenes, |s| s.scanned), total(base, |s| s.scanned)),
        max_penetration_mm: scenes
            .iter()
            .map(|s| s.max_penetration_mm)
            .fold(0.0, f64::max),
        drag_n: Summary::of(drags).mean,
        scenes,
    }
}

/// The study as a markdown table.
pub fn ablation_markdown(rows: &[AblationRow]) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "| configuration | frames > 1 ms | degraded | p99 / shipped (geo. mean) | worst p99 µs (scene) | node pairs / shipped | list entries / shipped | max pen. mm | drag N |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|");
    for r in rows {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {:.2} | {:.0} ({}) | {:.2} | {:.2} | {:.4} | {:.3} |",
            r.config,
            r.over_1ms,
            r.degraded,
            r.p99_ratio,
            r.worst_p99_us,
            r.worst_scene,
            r.splits_ratio,
            r.scanned_ratio,
            r.max_penetration_mm,
            r.drag_n
        );
    }
    s
}
