//! The `fit` study of `haptic6d bench`: generated pegs lowered into holes
//! ([`scene::scenes::fit`]) at radial clearances 0.5, 0.2, 0.1, 0.05 and 0.02 mm, replayed with
//! the shipped settings (dual solver, 1 ms budget, one thread, frames back to back), one row per
//! case, clearance and geometry mode.
//!
//! Cases: a round peg of radius 10 mm with and without chamfers (1 mm at the tip and the
//! mouth), approached straight and tilted by [`fit::STUDY_TILT_RAD`]; a round peg of radius 3 mm
//! (0.5 mm chamfers) straight and tilted; the splined shaft (root radius 10 mm, six keys) with
//! and without chamfers, straight and tilted. The hand enters and inserts at 12 mm/s mean
//! (18 mm/s peak) to 20 mm below the mouth, holds, withdraws.
//!
//! Per row: how deep the tip got below the mouth and whether it reached full depth; the largest
//! force; lagging and degraded frames; whole-step time p50 / p99 / max and frames over 1 ms;
//! the engine's deepest leaf overlap; the mesh-level penetration of the peg mesh into the block
//! mesh at the graphic pose ([`peer::MeshPenetration`], on every [`MESH_STRIDE`]-th frame near
//! or in contact); the tree sizes.
//!
//! Every row names the geometry mode the engine used (`[solver] geometry`); the modes replayed
//! are `bench --geometry`'s (the leaf spheres by default).
//!
//! `--quick` replays [`QUICK_ROWS`] rows. Every row is a built-in scene by its name
//! (`haptic6d run fit/round-r10-c0.05 --geometry mesh`).

use anyhow::Result;
use engine::setting::Setting;
use engine::SolverKind;
use scene::cache::TreeCache;
use scene::scenes::fit::{self, StudyCase, STUDY_CASES, STUDY_CLEARANCES_MM};
use serde::Serialize;

/// Mesh-level penetration is measured on every this many frames, where the tool may touch the
/// block by the parts alone ([`crate::run::mesh_depths`], whatever the geometry mode; a peg in
/// its hole puts all its probe points in the block's box: about 1.5 ms a frame on 2 cores).
pub const MESH_STRIDE: usize = 5;

/// The rows of `--quick`: (index into the cases, clearance mm).
pub const QUICK_ROWS: &[(usize, f64)] = &[(2, 0.5), (2, 0.1), (5, 0.2), (8, 0.5)];

/// One row: a case at one clearance in one geometry mode.
#[derive(Serialize, Clone, Debug)]
pub struct FitRow {
    /// Scene name (`fit/round-r10-c0.5-chamfer-tilted`, ...).
    pub scene: String,
    /// `round` or `splined`.
    pub shape: String,
    /// Peg radius (round) or root radius (splined), mm.
    pub radius_mm: f64,
    /// Chamfer at the peg's tip and the hole's mouth, mm (0: none).
    pub chamfer_mm: f64,
    /// `straight` or `tilted`.
    pub approach: String,
    /// Radial clearance, mm.
    pub clearance_mm: f64,
    /// Geometry the engine used (`spheres` or `mesh`, as `[solver] geometry`; `spheres` where
    /// the mesh mode was asked for and a mesh is missing).
    pub geometry: String,
    /// Frames replayed.
    pub frames: usize,
    /// Used leaves of the peg's tree.
    pub tool_leaves: usize,
    /// Used leaves of the block's tree.
    pub object_leaves: usize,
    /// Full insertion depth asked for, mm.
    pub full_depth_mm: f64,
    /// What the replay did: depth reached, full depth, force, degraded frames, times.
    pub outcome: fit::FitOutcome,
    /// Frames whose step took more than 1000 µs.
    pub over_1ms: usize,
    /// Deepest leaf–leaf overlap at the graphic pose (the engine's measure), mm.
    pub max_penetration_mm: f64,
    /// Deepest penetration of the peg mesh into the block mesh or the reverse at the graphic
    /// pose over the frames measured (independent of the trees), mm.
    pub mesh_penetration_mm: f64,
    /// Frames measured at the mesh level (every [`MESH_STRIDE`]-th frame, where the parts'
    /// boxes may touch).
    pub mesh_frames: usize,
    /// Wall time of the replay (without the mesh measure), s.
    pub wall_s: f64,
}

/// Runs the study: every case at every clearance in every geometry mode of `geometries`, or
/// [`QUICK_ROWS`] with `quick`.
pub fn fit_study(
    cache: &TreeCache,
    quick: bool,
    geometries: &[engine::Geometry],
) -> Result<Vec<FitRow>> {
    let rows: Vec<(StudyCase, f64)> = if quick {
        QUICK_ROWS
            .iter()
            .map(|&(k, c)| (STUDY_CASES[k], c))
            .collect()
    } else {
        STUDY_CASES
            .iter()
            .flat_map(|&case| STUDY_CLEARANCES_MM.iter().map(move |&c| (case, c)))
            .collect()
    };
    let mut out = Vec::with_capacity(rows.len() * geometries.len());
    for (case, clearance) in rows {
        let f = fit::fit_scene(&case.params(clearance), cache)?;
        for line in &f.scene.load_log {
            eprintln!("bench: {line}");
        }
        for &mode in geometries {
            let mut scene = f.scene.clone();
            scene.solver.geometry = mode;
            let t0 = std::time::Instant::now();
            let (_, frames, _) =
                crate::bench_contact::replay_audited(&scene, SolverKind::Dual, false, false)?;
            let wall_s = t0.elapsed().as_secs_f64();
            let outcome = f.outcome(&frames);
            let poses: Vec<[f64; 6]> = frames
                .iter()
                .step_by(MESH_STRIDE)
                .map(|fr| fr.q_g)
                .collect();
            let depths: Vec<f64> = crate::run::mesh_depths(&scene, &poses)
                .unwrap_or_default()
                .into_iter()
                .flatten()
                .collect();
            let leaves = |t: &spheretree::SphereTree| t.leaves().count();
            let row = FitRow {
                scene: scene.name.clone(),
                shape: case.shape.name().into(),
                radius_mm: case.radius_mm,
                chamfer_mm: case.chamfer_mm,
                approach: if case.tilted { "tilted" } else { "straight" }.into(),
                clearance_mm: clearance,
                geometry: scene.geometry().setting_name().into(),
                frames: frames.len(),
                tool_leaves: leaves(&scene.tool),
                object_leaves: scene.objects.iter().map(|(t, _)| leaves(t)).sum(),
                full_depth_mm: f.params.depth_mm,
                over_1ms: frames.iter().filter(|fr| fr.total_us > 1000.0).count(),
                max_penetration_mm: frames
                    .iter()
                    .map(|fr| fr.penetration_mm)
                    .fold(0.0, f64::max),
                mesh_penetration_mm: depths.iter().copied().fold(0.0, f64::max),
                mesh_frames: depths.len(),
                wall_s,
                outcome,
            };
            eprintln!(
                "bench: {} ({}): depth {:.2} of {} mm, force max {:.1} N, p99 {:.1} µs, {} degraded ({wall_s:.1} s)",
                row.scene,
                mode.setting_name(),
                row.outcome.depth_reached_mm,
                row.full_depth_mm,
                row.outcome.force_max_n,
                row.outcome.total_us.p99,
                row.outcome.degraded
            );
            out.push(row);
        }
    }
    Ok(out)
}

/// The study as a markdown table.
pub fn fit_markdown(rows: &[FitRow]) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "| shape | r mm | chamfer mm | approach | clearance mm | geometry | depth reached / full mm | full depth | force max N | lagging / degraded | total µs p50 / p99 / max | frames > 1 ms | max pen. mm (engine) | mesh pen. mm (frames) | leaves tool / block |"
    );
    let _ = writeln!(
        s,
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
    );
    for r in rows {
        let o = &r.outcome;
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {:.2} / {} | {} | {:.1} | {} / {} | {:.1} / {:.1} / {:.1} | {} | {:.4} | {:.4} ({}) | {} / {} |",
            r.shape,
            r.radius_mm,
            r.chamfer_mm,
            r.approach,
            r.clearance_mm,
            r.geometry,
            o.depth_reached_mm,
            r.full_depth_mm,
            if o.full_depth { "yes" } else { "**no**" },
            o.force_max_n,
            o.lagging,
            o.degraded,
            o.total_us.p50,
            o.total_us.p99,
            o.total_us.max,
            r.over_1ms,
            r.max_penetration_mm,
            r.mesh_penetration_mm,
            r.mesh_frames,
            r.tool_leaves,
            r.object_leaves,
        );
    }
    s
}

/// The sharp-edge case's hand speeds, mm/s.
pub const EDGE_SPEEDS_MM_S: [f64; 2] = [50.0, 200.0];

/// The sharp-edge case ([`fit::sharp_edge_scene`]) at one speed in one geometry mode.
#[derive(Serialize, Clone, Debug)]
pub struct EdgeRow {
    /// Hand speed along the slide, mm/s.
    pub speed_mm_s: f64,
    /// The geometry mode the engine used.
    pub geometry: String,
    /// Largest change of the force between frames outside contact onsets, N.
    pub max_force_jump_n: f64,
    /// When it happened, s, and where the hand was along the slide then (mm, the edge at 0).
    pub max_force_jump_t: f64,
    pub max_force_jump_x_mm: f64,
    /// Contact onsets (the force from zero).
    pub contact_onsets: usize,
    /// Largest force, N.
    pub max_force_n: f64,
    /// Farthest the tool trailed the hand along the slide on the way back over the edge, mm (a
    /// tool caught on the edge trails by the hand's whole travel).
    pub max_trail_back_mm: f64,
    /// Lagging, pair-overflow and kept-last-safe frames.
    pub degraded: usize,
    /// Whole step per frame, µs; frames over 1 ms.
    pub total_us: scene::stats::Summary,
    pub over_1ms: usize,
    /// Mesh-level penetration of the cylinder into the block at the graphic pose, mm (every
    /// frame where the parts' boxes may touch).
    pub mesh_penetration_mm: f64,
}

/// Replays the sharp-edge case at each speed of [`EDGE_SPEEDS_MM_S`] (the first only with
/// `quick`) in each geometry mode.
pub fn edge_study(
    cache: &TreeCache,
    quick: bool,
    geometries: &[engine::Geometry],
) -> Result<Vec<EdgeRow>> {
    let speeds = if quick {
        &EDGE_SPEEDS_MM_S[..1]
    } else {
        &EDGE_SPEEDS_MM_S[..]
    };
    let mut out = Vec::new();
    for &speed in speeds {
        let base = fit::sharp_edge_scene(speed, cache)?;
        for &mode in geometries {
            let mut scene = base.clone();
            scene.solver.geometry = mode;
            let (times, frames, _) =
                crate::bench_contact::replay_audited(&scene, SolverKind::Dual, false, false)?;
            let force = scene::report::force_report_of(times.iter().copied().zip(&frames));
            let at_jump = times
                .iter()
                .position(|&t| t >= force.max_force_jump_t)
                .map_or(f64::NAN, |k| frames[k].q_h[0]);
            // On the way back (the hand moving toward -x), the tool trails when it stays at
            // larger x than the hand.
            let back = frames.windows(2).filter(|w| w[1].q_h[0] < w[0].q_h[0]);
            let max_trail_back_mm = back.map(|w| w[1].q_g[0] - w[1].q_h[0]).fold(0.0, f64::max);
            let poses: Vec<[f64; 6]> = frames.iter().map(|fr| fr.q_g).collect();
            let depths: Vec<f64> = crate::run::mesh_depths(&scene, &poses)
                .unwrap_or_default()
                .into_iter()
                .flatten()
                .collect();
            let row = EdgeRow {
                speed_mm_s: speed,
                geometry: scene.geometry().setting_name().into(),
                max_force_jump_n: force.max_force_jump_n,
                max_force_jump_t: force.max_force_jump_t,
                max_force_jump_x_mm: at_jump,
                contact_onsets: force.contact_onsets,
                max_force_n: force.max_force_n,
                max_trail_back_mm,
                degraded: frames.iter().filter(|f| f.status.is_degraded()).count(),
                total_us: scene::stats::Summary::of(frames.iter().map(|f| f.total_us)),
                over_1ms: frames.iter().filter(|f| f.total_us > 1000.0).count(),
                mesh_penetration_mm: depths.iter().copied().fold(0.0, f64::max),
            };
            eprintln!(
                "bench: sharp edge {speed} mm/s ({}): largest force jump {:.3} N at x {:.2} mm, trail {:.2} mm",
                row.geometry, row.max_force_jump_n, row.max_force_jump_x_mm, row.max_trail_back_mm
            );
            out.push(row);
        }
    }
    Ok(out)
}

/// The sharp-edge rows as a markdown table.
pub fn edge_markdown(rows: &[EdgeRow]) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "| speed mm/s | geometry | largest force jump N (hand at x mm) | contact onsets | force max N | trail on the way back mm | degraded | total µs p50 / p99 / max | frames > 1 ms | mesh pen. mm |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|---|");
    for r in rows {
        let _ = writeln!(
            s,
            "| {} | {} | {:.3} ({:.2}) | {} | {:.2} | {:.2} | {} | {:.1} / {:.1} / {:.1} | {} | {:.4} |",
            r.speed_mm_s,
            r.geometry,
            r.max_force_jump_n,
            r.max_force_jump_x_mm,
            r.contact_onsets,
            r.max_force_n,
            r.max_trail_back_mm,
            r.degraded,
            r.total_us.p50,
            r.total_us.p99,
            r.total_us.max,
            r.over_1ms,
            r.mesh_penetration_mm
        );
    }
    s
}
