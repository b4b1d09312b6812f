//! The `speed` study of `haptic6d bench`: how the step follows a fast hand on a frictionless
//! plate (the built-in plate scene, [`scene::scenes::plate`]).
//!
//! Each row presses a tool 1 mm into the plate, then slides it along `x` or turns it about the
//! vertical axis at a constant speed, back and forth. On a frictionless surface the hand should
//! feel no force along the motion and the graphic tool should not lag; per row (exact solvers
//! only, one thread, frames back to back):
//! - **drag**: mean force (N) or torque (N·mm) opposing the motion, over the frames at constant
//!   speed (a few frames after each reversal are left out);
//! - **lag**: mean and largest offset of the graphic tool behind the hand along the motion:
//!   along `x` (mm) or about the vertical axis (rad), over the same frames (the tool also
//!   rides over the sphere-tree's bumps, which tilts it and moves it sideways: not lag);
//! - penetration (all frames), the largest force change between consecutive frames in contact
//!   (contact onsets excluded), frame time p50 / p99 / max, and the frames that ended lagging
//!   or kept the last safe pose.
//!
//! Each row is replayed in each geometry mode of `bench --geometry` (the leaf spheres by
//! default, face-capped on the plate; `mesh`: the ball's and the plate's own triangles).

use anyhow::Result;
use collide::{rotation_log, Pose};
use engine::step::FrameStatus;
use engine::SolverKind;
use scene::cache::TreeCache;
use scene::scenes::plate::{self, PlateTool, SpeedMotion};
use scene::stats::Summary;
use serde::Serialize;

/// One row of the speed study.
#[derive(Serialize, Clone, Debug)]
pub struct SpeedRow {
    /// `puck` or `ball`.
    pub tool: String,
    /// `slide` or `turn`.
    pub motion: String,
    /// Hand speed: mm/s (slide) or rad/s (turn).
    pub speed: f64,
    /// Solver name.
    pub solver: String,
    /// What the tool touched (`spheres` or `mesh`, as `[solver] geometry`).
    pub geometry: String,
    /// Frames stepped.
    pub frames: usize,
    /// Frames at constant speed (where drag and lag are measured).
    pub steady_frames: usize,
    /// Mean force (N, slide) or torque (N·mm, turn) opposing the motion at constant speed.
    pub drag: f64,
    /// Mean lag of the graphic tool behind the hand along the motion at constant speed
    /// (negative: ahead): mm (slide, along x) or rad (turn, about z).
    pub lag_mean: f64,
    /// Largest lag (either sign) along the motion at constant speed: mm or rad.
    pub lag_max: f64,
    /// Deepest overlap over the run, mm.
    pub max_penetration_mm: f64,
    /// Largest force change between consecutive frames in contact (onsets excluded), N.
    pub max_force_jump_n: f64,
    /// Whole step per frame, µs.
    pub total_us: Summary,
    /// Passes per frame.
    pub passes: Summary,
    /// Frames that ended short of the optimum (safe, lagging).
    pub lagging_frames: usize,
    /// Frames that kept the last safe pose.
    pub kept_last_safe: usize,
}

/// The ladder of motions: slides at 50–1000 mm/s, turns at 1–10 rad/s (`quick`: 200 and
/// 1000 mm/s, 10 rad/s).
pub fn motions(quick: bool) -> Vec<SpeedMotion> {
    let (slides, turns): (&[f64], &[f64]) = if quick {
        (&[200.0, 1000.0], &[10.0])
    } else {
        (&[50.0, 200.0, 500.0, 1000.0], &[1.0, 3.0, 10.0])
    };
    slides
        .iter()
        .map(|&v| SpeedMotion::Slide(v))
        .chain(turns.iter().map(|&w| SpeedMotion::Turn(w)))
        .collect()
}

/// Runs the study: every motion of [`motions`] with the puck (and slides with the ball too),
/// for each solver in `solvers`.
pub fn speed_study(
    cache: &TreeCache,
    quick: bool,
    solvers: &[SolverKind],
    geometries: &[engine::Geometry],
    mode: crate::bench_contact::ReplayMode,
) -> Result<Vec<SpeedRow>> {
    let min_steady = if quick { 0.15 } else { 0.5 };
    let mut rows = Vec::new();
    for tool in [PlateTool::Puck, PlateTool::Ball] {
        for motion in motions(quick) {
            if tool == PlateTool::Ball && matches!(motion, SpeedMotion::Turn(_)) {
                // A ball turning about its contact normal feels no torque whatever the step.
                continue;
            }
            let run = plate::speed_script(tool, motion, 1000.0, min_steady);
            let mut scene = plate::scene(cache, tool, run.script.clone())?;
            scene.solver.helper_thread = mode.helper_thread;
            if let Some(on) = mode.face_caps {
                scene.solver.face_caps = on;
            }
            for &geometry in geometries {
                scene.solver.geometry = geometry;
                for &kind in solvers {
                    rows.push(speed_row(&scene, tool, motion, &run, kind, mode.realtime)?);
                }
            }
        }
    }
    Ok(rows)
}

fn speed_row(
    scene: &scene::Scene,
    tool: PlateTool,
    motion: SpeedMotion,
    run: &plate::SpeedRun,
    kind: SolverKind,
    realtime: bool,
) -> Result<SpeedRow> {
    let (times, outputs, _) = crate::bench_contact::replay_audited(scene, kind, false, realtime)?;
    let mut drag = Vec::new();
    let mut lag = Vec::new();
    let mut pen: f64 = 0.0;
    let mut jump: f64 = 0.0;
    let mut prev_force: Option<[f64; 3]> = None;
    let (mut lagging, mut kept) = (0, 0);
    for (&t, out) in times.iter().zip(&outputs) {
        let q_h = Pose::from_array(out.q_h);
        lagging += usize::from(out.status == FrameStatus::Lagging);
        kept += usize::from(out.status == FrameStatus::KeptLastSafe);
        pen = pen.max(out.penetration_mm);
        let f = [out.wrench[0], out.wrench[1], out.wrench[2]];
        let fm = (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]).sqrt();
        if let Some(p) = prev_force {
            let pm = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
            if pm > 0.0 && fm > 0.0 {
                let d =
                    ((f[0] - p[0]).powi(2) + (f[1] - p[1]).powi(2) + (f[2] - p[2]).powi(2)).sqrt();
                jump = jump.max(d);
            }
        }
        prev_force = Some(f);
        let Some(i) = run.steady.iter().position(|&(a, b)| t >= a && t < b) else {
            continue;
        };
        let dir = run.direction[i];
        let q_g = Pose::from_array(out.q_g);
        match motion {
            SpeedMotion::Slide(_) => {
                drag.push(-out.wrench[0] * dir);
                // How far the tool is behind the hand along the motion.
                lag.push((q_h.q[0] - q_g.q[0]) * dir);
            }
            SpeedMotion::Turn(_) => {
                drag.push(-out.wrench[5] * dir);
                // How far it is turned behind the hand about the turning (vertical) axis.
                let r = q_h.rotation_matrix() * q_g.rotation_matrix().transpose();
                lag.push(rotation_log(&r)[2] * dir);
            }
        }
    }
    let (name, speed) = match motion {
        SpeedMotion::Slide(v) => ("slide", v),
        SpeedMotion::Turn(w) => ("turn", w),
    };
    let lag_summary = Summary::of(lag.iter().copied());
    Ok(SpeedRow {
        tool: tool.name().into(),
        motion: name.into(),
        speed,
        solver: kind.name().into(),
        geometry: scene.geometry().name().into(),
        frames: outputs.len(),
        steady_frames: drag.len(),
        drag: Summary::of(drag).mean,
        lag_mean: lag_summary.mean,
        lag_max: lag.iter().fold(0.0, |m: f64, v| m.max(v.abs())),
        max_penetration_mm: pen,
        max_force_jump_n: jump,
        total_us: Summary::of(outputs.iter().map(|o| o.total_us)),
        passes: Summary::of(outputs.iter().map(|o| f64::from(o.passes))),
        lagging_frames: lagging,
        kept_last_safe: kept,
    })
}

/// The study as a markdown table.
pub fn speed_markdown(rows: &[SpeedRow]) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "| tool | motion | speed | solver | geometry | frames | drag (N or N·mm) | lag mean / max (mm or rad) | max pen. mm | max ΔF N | total µs p50 / p99 / max | passes mean / max | lagging | kept last safe |"
    );
    let _ = writeln!(
        s,
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
    );
    for r in rows {
        let unit = if r.motion == "slide" { "mm/s" } else { "rad/s" };
        let _ = writeln!(
            s,
            "| {} | {} | {} {unit} | {} | {} | {} | {:.4} | {:.4} / {:.4} | {:.4} | {:.3} | {:.1} / {:.1} / {:.1} | {:.2} / {:.0} | {} | {} |",
            r.tool,
            r.motion,
            r.speed,
            r.solver,
            r.geometry,
            r.frames,
            r.drag,
            r.lag_mean,
            r.lag_max,
            r.max_penetration_mm,
            r.max_force_jump_n,
            r.total_us.p50,
            r.total_us.p99,
            r.total_us.max,
            r.passes.mean,
            r.passes.max,
            r.lagging_frames,
            r.kept_last_safe,
        );
    }
    s
}
