//! The `zoo` study of `haptic6d bench`: every scene of the scene zoo
//! ([`scene::scenes::zoo`]) replayed with the shipped settings (dual solver, 1 ms budget, one
//! thread, frames back to back), one row per scene.
//!
//! Per row: frames; whole-step time p50 / p99 / max and the frames over 1 ms; degraded frames
//! (lagging, pair overflow, kept last safe); drag, the mean force opposing the graphic tool's
//! motion while the hand slides it pressed (N; frames where the tool moves faster than
//! [`DRAG_MIN_SPEED`]; a frictionless contact's force is normal to the tool's motion, so what
//! shows is the trees' bumps and the step's lag);
//! the engine's deepest leaf overlap at the graphic pose; the mesh-level penetration of the
//! tool mesh into the object meshes at the graphic pose ([`peer::MeshPenetration`], on every
//! [`MESH_STRIDE`]-th frame where the tool may touch an object by the parts' boxes alone) and,
//! on the same frames, how deep the hand's pose is in
//! the objects by the same measure (what the god-object kept the tool out of); the largest
//! first-region pair count and touching pairs; the largest force; the largest rotation of the
//! tool behind the hand while twisting (rad: how much of the twist the objects block); how far
//! the tool is from the hand at the end, back in free space (more than 0: it stayed caught, a
//! jam); and the tree sizes.
//!
//! `--quick` replays a reduced zoo ([`QUICK_SCENES`]).

use anyhow::Result;
use engine::step::{FrameOutput, FrameStatus};
use engine::SolverKind;
use scene::cache::TreeCache;
use scene::scenes::zoo::{self, ZooScene};
use scene::stats::Summary;
use serde::Serialize;

/// The scenes of the reduced zoo of `--quick`.
pub const QUICK_SCENES: &[&str] = &[
    "zoo/sphere-on-sphere",
    "zoo/thin-plate",
    "zoo/slot",
    "zoo/torus-link",
];

/// Tool speed below which a sliding frame does not count towards drag, mm/s (its direction
/// is noise at the ends of the strokes and where the tool is held).
pub const DRAG_MIN_SPEED: f64 = 5.0;

/// Mesh-level penetration is measured on every this many frames (each measure walks every
/// probe point of the meshes; none where the parts' boxes keep apart, whose depth is 0).
pub const MESH_STRIDE: usize = 5;

/// Surface samples per mesh of the mesh-level measure, beside its vertices (the measure adds
/// more on large meshes: 0.5 per mm²).
const MESH_SAMPLES: usize = 2000;

/// One zoo scene's row.
#[derive(Serialize, Clone, Debug)]
pub struct ZooRow {
    /// Scene name.
    pub scene: String,
    /// What the tool touched (`spheres` or `mesh`, as `[solver] geometry`).
    pub geometry: String,
    /// Frames replayed.
    pub frames: usize,
    /// Used leaves of the tool's tree.
    pub tool_leaves: usize,
    /// Used leaves of all object trees together.
    pub object_leaves: usize,
    /// Objects in the scene.
    pub objects: usize,
    /// Whole step per frame, µs.
    pub total_us: Summary,
    /// Frames whose step took more than 1000 µs.
    pub over_1ms: usize,
    /// Frames that ended lagging.
    pub lagging: usize,
    /// Frames that ended lagging, with a pair overflow, or kept the last safe pose.
    pub degraded: usize,
    /// Mean force opposing the graphic tool's motion while the hand slides it pressed, N.
    pub drag_n: f64,
    /// Deepest leaf–leaf overlap at the graphic pose (the engine's measure), mm.
    pub max_penetration_mm: f64,
    /// Deepest tool-mesh point inside an object mesh or the reverse at the graphic pose
    /// (independent of the trees), mm; `None` when a mesh is missing.
    pub mesh_penetration_mm: Option<f64>,
    /// Deepest the hand's pose goes into the objects by the same mesh-level measure, mm (what
    /// the tool was kept out of); `None` when a mesh is missing.
    pub hand_depth_mm: Option<f64>,
    /// Largest pair count of a frame's first region.
    pub pairs_max: u32,
    /// Largest count of touching leaf pairs.
    pub contacts_max: u32,
    /// Largest force the spring sent, N.
    pub force_max_n: f64,
    /// Largest rotation of the graphic tool behind the hand during the twist, rad.
    pub twist_lag_max_rad: f64,
    /// Distance of the graphic tool from the hand at the last frame, after the withdrawal into
    /// free space, mm: more than 0 means the tool stayed caught (jammed).
    pub end_lag_mm: f64,
    /// Wall time of the replay (without the mesh measure), s.
    pub wall_s: f64,
}

/// Runs the study: every zoo scene, or the [`QUICK_SCENES`] with `quick`.
pub fn zoo_study(
    cache: &TreeCache,
    quick: bool,
    geometries: &[engine::Geometry],
) -> Result<Vec<ZooRow>> {
    let names: Vec<&str> = if quick {
        QUICK_SCENES.to_vec()
    } else {
        zoo::names().collect()
    };
    let mut rows = Vec::with_capacity(names.len() * geometries.len());
    for name in names {
        let z = zoo::zoo_scene(name, cache)?;
        for line in &z.scene.load_log {
            eprintln!("bench: {line}");
        }
        for &mode in geometries {
            let mut z = z.clone();
            z.scene.solver.geometry = mode;
            let t0 = std::time::Instant::now();
            let (times, frames, _) =
                crate::bench_contact::replay_audited(&z.scene, SolverKind::Dual, false, false)?;
            let wall_s = t0.elapsed().as_secs_f64();
            let row = zoo_row(&z, &times, &frames, wall_s);
            eprintln!(
                "bench: {name} ({}): {} frames, p99 {:.1} µs, max {:.1} µs, {} degraded ({wall_s:.1} s)",
                row.geometry,
                row.frames,
                row.total_us.p99,
                row.total_us.max,
                row.degraded
            );
            rows.push(row);
        }
    }
    Ok(rows)
}

fn norm3(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// Drag: the mean force opposing the graphic tool's motion over the frames of `slide_s` (s)
/// where the tool moves faster than [`DRAG_MIN_SPEED`], N (`times` in s, one per frame).
pub fn slide_drag(times: &[f64], frames: &[FrameOutput], slide_s: (f64, f64)) -> f64 {
    let mut drag = Vec::new();
    for k in 1..frames.len() {
        let (t, f, prev) = (times[k], &frames[k], &frames[k - 1]);
        let dt = t - times[k - 1];
        if t >= slide_s.0 && t <= slide_s.1 && dt > 0.0 {
            let v: Vec<f64> = (0..3).map(|i| (f.q_g[i] - prev.q_g[i]) / dt).collect();
            let speed = norm3(&v);
            if speed > DRAG_MIN_SPEED {
                drag.push(-(0..3).map(|i| f.wrench[i] * v[i]).sum::<f64>() / speed);
            }
        }
    }
    Summary::of(drag).mean
}

fn zoo_row(z: &ZooScene, times: &[f64], frames: &[FrameOutput], wall_s: f64) -> ZooRow {
    let in_window = |t: f64, w: (f64, f64)| t >= w.0 && t <= w.1;
    let mut twist_lag: f64 = 0.0;
    for (t, f) in times.iter().zip(frames).skip(1) {
        let t = *t;
        if in_window(t, z.phases.twist_s) {
            let lag = (3..6)
                .map(|i| (f.q_g[i] - f.q_h[i]).abs())
                .fold(0.0, f64::max);
            twist_lag = twist_lag.max(lag);
        }
    }
    let leaves = |t: &spheretree::SphereTree| t.leaves().count();
    let mesh_depths = mesh_penetration(z, frames);
    ZooRow {
        scene: z.scene.name.clone(),
        geometry: z.scene.geometry().name().into(),
        frames: frames.len(),
        tool_leaves: leaves(&z.scene.tool),
        object_leaves: z.scene.objects.iter().map(|(t, _)| leaves(t)).sum(),
        objects: z.scene.objects.len(),
        total_us: Summary::of(frames.iter().map(|f| f.total_us)),
        over_1ms: frames.iter().filter(|f| f.total_us > 1000.0).count(),
        lagging: frames
            .iter()
            .filter(|f| f.status == FrameStatus::Lagging)
            .count(),
        degraded: frames.iter().filter(|f| f.status.is_degraded()).count(),
        drag_n: slide_drag(times, frames, z.phases.slide_s),
        max_penetration_mm: frames.iter().map(|f| f.penetration_mm).fold(0.0, f64::max),
        mesh_penetration_mm: mesh_depths.map(|d| d.0),
        hand_depth_mm: mesh_depths.map(|d| d.1),
        pairs_max: frames.iter().map(|f| f.pairs).max().unwrap_or(0),
        contacts_max: frames.iter().map(|f| f.contacts).max().unwrap_or(0),
        force_max_n: frames
            .iter()
            .map(|f| norm3(&f.wrench[..3]))
            .fold(0.0, f64::max),
        twist_lag_max_rad: twist_lag,
        end_lag_mm: frames.last().map_or(0.0, |f| {
            norm3(&(0..3).map(|i| f.q_g[i] - f.q_h[i]).collect::<Vec<_>>())
        }),
        wall_s,
    }
}

/// The deepest mesh-level penetration over every [`MESH_STRIDE`]-th frame of the graphic tool
/// and of the hand, mm.
fn mesh_penetration(z: &ZooScene, frames: &[FrameOutput]) -> Option<(f64, f64)> {
    let tool = z.scene.tool_mesh.as_ref()?;
    let objects = z
        .scene
        .object_meshes
        .iter()
        .zip(&z.scene.objects)
        .map(|(m, (_, pose))| m.as_ref().map(|m| (m, *pose)))
        .collect::<Option<Vec<_>>>()?;
    let measure = peer::MeshPenetration::new(tool, &objects, MESH_SAMPLES);
    // Where the tool's box keeps clear of every object's, the depth is 0 exactly: which frames
    // are measured rests on the parts alone, not on the engine's contacts.
    let depth = |q: &[f64; 6]| {
        let q = collide::Pose::from_array(*q);
        if measure.may_touch(&q) {
            measure.depth_mm(&q)
        } else {
            0.0
        }
    };
    Some(
        frames
            .iter()
            .step_by(MESH_STRIDE)
            .map(|f| (depth(&f.q_g), depth(&f.q_h)))
            .fold((0.0, 0.0), |a, b| (a.0.max(b.0), a.1.max(b.1))),
    )
}

/// The study as a markdown table.
pub fn zoo_markdown(rows: &[ZooRow]) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "| scene | geometry | leaves tool / objects (objects) | frames | total µs p50 / p99 / max | frames > 1 ms | lagging / degraded | drag N | max pen. mm (engine) | mesh pen. mm (hand's depth) | pairs max | touching max | force max N | twist lag max rad | end lag mm |"
    );
    let _ = writeln!(
        s,
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
    );
    for r in rows {
        let _ = writeln!(
            s,
            "| {} | {} | {} / {} ({}) | {} | {:.1} / {:.1} / {:.1} | {} | {} / {} | {:.3} | {:.4} | {} | {} | {} | {:.2} | {:.3} | {:.3} |",
            r.scene,
            r.geometry,
            r.tool_leaves,
            r.object_leaves,
            r.objects,
            r.frames,
            r.total_us.p50,
            r.total_us.p99,
            r.total_us.max,
            r.over_1ms,
            r.lagging,
            r.degraded,
            r.drag_n,
            r.max_penetration_mm,
            match (r.mesh_penetration_mm, r.hand_depth_mm) {
                (Some(g), Some(h)) => format!("{g:.3} ({h:.1})"),
                _ => "–".to_string(),
            },
            r.pairs_max,
            r.contacts_max,
            r.force_max_n,
            r.twist_lag_max_rad,
            r.end_lag_mm,
        );
    }
    s
}
