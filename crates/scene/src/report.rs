//! What a run writes: `frames.csv` (columns in docs/DESIGN.md §Formats) and the summary behind
//! `summary.json`.

use engine::safety::norm3;
use std::fmt::Write as _;

use serde::Serialize;

use crate::rt::{FrameRecord, LoopStats};
use crate::stats::Summary;
use crate::Goal;
use engine::step::FrameStatus;

/// The header of `frames.csv`.
pub const FRAMES_HEADER: &str = "t,xh,yh,zh,gh,bh,ah,xg,yg,zg,gg,bg,ag,fx,fy,fz,tx,ty,tz,pairs,cd_us,opt_us,total_us,iters,penetration_mm,passes,status,splits,scanned,ahead_us";

/// The header of the `frames.csv` that `haptic6d run` writes: [`FRAMES_HEADER`] (the engine's
/// columns, as [`frames_csv`] writes them) and then [`MESH_PENETRATION_COLUMN`].
pub const RUN_FRAMES_HEADER: &str = "t,xh,yh,zh,gh,bh,ah,xg,yg,zg,gg,bg,ag,fx,fy,fz,tx,ty,tz,pairs,cd_us,opt_us,total_us,iters,penetration_mm,passes,status,splits,scanned,ahead_us,mesh_penetration_mm";

/// The last column of `haptic6d run`'s `frames.csv`: the mesh-level penetration of the tool
/// mesh into the object meshes at the graphic pose, mm; empty on frames not measured.
pub const MESH_PENETRATION_COLUMN: &str = "mesh_penetration_mm";

/// `frames.csv` text with the engine's columns ([`FRAMES_HEADER`]): one row per frame; the
/// force/torque columns are the wrench sent to the device (after the safety layer).
pub fn frames_csv(frames: &[FrameRecord]) -> String {
    let mut s = String::with_capacity(256 * (frames.len() + 1));
    s.push_str(FRAMES_HEADER);
    s.push('\n');
    for f in frames {
        frame_fields(&mut s, f);
        s.push('\n');
    }
    s
}

/// `frames.csv` text as `haptic6d run` writes it ([`RUN_FRAMES_HEADER`]): the engine's columns,
/// then the mesh-level penetration of each frame (mm; `mesh_mm[k]`, an empty field where it is
/// `None` or missing).
pub fn run_frames_csv(frames: &[FrameRecord], mesh_mm: &[Option<f64>]) -> String {
    let mut s = String::with_capacity(264 * (frames.len() + 1));
    s.push_str(RUN_FRAMES_HEADER);
    s.push('\n');
    for (k, f) in frames.iter().enumerate() {
        frame_fields(&mut s, f);
        s.push(',');
        if let Some(d) = mesh_mm.get(k).copied().flatten() {
            let _ = write!(s, "{d}");
        }
        s.push('\n');
    }
    s
}

/// The engine's columns of one frame (no line end).
fn frame_fields(s: &mut String, f: &FrameRecord) {
    let o = &f.frame;
    let _ = write!(s, "{}", f.t);
    for v in o.q_h.iter().chain(o.q_g.iter()).chain(o.wrench.iter()) {
        let _ = write!(s, ",{v}");
    }
    let _ = write!(
        s,
        ",{},{:.3},{:.3},{:.3},{},{},{},{},{},{},{:.3}",
        o.pairs,
        o.cd_us,
        o.opt_us,
        o.total_us,
        o.iterations,
        o.penetration_mm,
        o.passes,
        o.status.name(),
        o.splits,
        o.scanned,
        o.ahead_us
    );
}

/// Outcome of a scene's goal.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct GoalReport {
    /// What was expected.
    pub kind: String,
    /// Target `z` of the tool origin, mm.
    pub target_z_mm: f64,
    /// Lowest `z` the graphic tool reached, mm.
    pub reached_z_mm: f64,
    /// True when the target was reached (within tolerance).
    pub success: bool,
}

/// Force and torque extremes and continuity (raw step output, before the safety layer).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct ForceReport {
    /// Largest force magnitude, N.
    pub max_force_n: f64,
    /// Largest torque magnitude, N·mm.
    pub max_torque_nmm: f64,
    /// Largest change of the force between consecutive frames, excluding frames where contact
    /// starts (previous force zero), N.
    pub max_force_jump_n: f64,
    /// Time of that largest jump, s.
    pub max_force_jump_t: f64,
    /// Largest change including contact onsets, N.
    pub max_force_jump_any_n: f64,
    /// Number of contact onsets (force goes from zero to non-zero).
    pub contact_onsets: usize,
    /// Frames with a non-finite output (should be 0).
    pub non_finite_frames: usize,
}

/// Which sphere-tree a run used: its size and which builder made it, so a figure can be traced
/// to the tree it was measured on.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct TreeInfo {
    /// `tool`, or `object K` (K from 0, in scene order).
    pub role: String,
    /// Used leaf spheres (the spheres whose pairs become constraints).
    pub leaves: usize,
    /// Depth of the tree (levels - 1).
    pub depth: u32,
    /// Branching factor.
    pub branching: u32,
    /// [`spheretree::build::BUILDER_VERSION`] of the builder that made it (trees built from a
    /// mesh, through the cache or not: the cache key includes the version, so a cached tree is
    /// always today's builder's); `None` for a tree read from a `.sph` file.
    pub builder_version: Option<u32>,
}

impl TreeInfo {
    /// One line: `tool 4094 leaves (depth 4, branching 8, builder v2)`.
    pub fn describe(&self) -> String {
        let builder = match self.builder_version {
            Some(v) => format!("builder v{v}"),
            None => "read from a .sph file".into(),
        };
        format!(
            "{} {} leaves (depth {}, branching {}, {builder})",
            self.role, self.leaves, self.depth, self.branching
        )
    }
}

/// The trees of `scene`: the tool's, then each object's.
pub fn tree_infos(scene: &crate::Scene) -> Vec<TreeInfo> {
    let info = |role: String, t: &spheretree::SphereTree, from_mesh: bool| TreeInfo {
        role,
        leaves: t.leaves().count(),
        depth: t.levels().saturating_sub(1),
        branching: t.branching(),
        builder_version: from_mesh.then_some(spheretree::build::BUILDER_VERSION),
    };
    let mut out = vec![info("tool".into(), &scene.tool, scene.tool_mesh.is_some())];
    for (k, (t, _)) in scene.objects.iter().enumerate() {
        let from_mesh = scene.object_meshes.get(k).is_some_and(|m| m.is_some());
        out.push(info(format!("object {k}"), t, from_mesh));
    }
    out
}

/// The content of `summary.json`.
#[derive(Clone, Debug, Serialize)]
pub struct RunSummary {
    /// Scene name or file.
    pub scene: String,
    /// Solver name.
    pub solver: String,
    /// Constraint form.
    pub form: String,
    /// What the tool touched: `spheres` (the trees' leaves) or `mesh` (the parts' triangles).
    pub geometry: String,
    /// Whether every body has its mesh, so that the run could have used the mesh geometry;
    /// filled by the caller (`haptic6d run`), false when not known.
    pub meshes: bool,
    /// Frames run.
    pub frames: usize,
    /// Collision detection time per frame, µs.
    pub cd_us: Summary,
    /// Optimisation (rows + QP) time per frame, µs.
    pub opt_us: Summary,
    /// Whole step per frame, µs.
    pub total_us: Summary,
    /// Part of the step spent on lists for later frames, µs ([`engine::Frame::ahead_us`]).
    pub ahead_us: Summary,
    /// The step less that part: the frame's own work, µs.
    pub own_us: Summary,
    /// Leaf pairs per frame.
    pub pairs: Summary,
    /// Solver iterations per frame (summed over passes).
    pub iterations: Summary,
    /// Passes per frame (1 + re-linearisations).
    pub passes: Summary,
    /// Node pairs split per frame ([`engine::Frame::splits`]): with `scanned`, the
    /// machine-independent twin of `cd_us`.
    pub splits: Summary,
    /// Neighbour-list entries tested per frame ([`engine::Frame::scanned`]).
    pub scanned: Summary,
    /// Measured penetration at `q_g`, mm.
    pub penetration_mm: Summary,
    /// Force/torque extremes and continuity.
    pub force: ForceReport,
    /// Loop statistics (overruns, period error, safety events).
    pub loop_stats: LoopStats,
    /// The scene's goal, if any.
    pub goal: Option<GoalReport>,
    /// How the scene was loaded (cache hits, builds) and how long it took, s.
    pub load: Vec<String>,
    /// Time to load the scene (trees included), s.
    pub load_s: f64,
    /// The trees the run used (leaf counts, builder version); filled by the caller from the
    /// scene ([`tree_infos`]), empty when not known.
    pub trees: Vec<TreeInfo>,
    /// The mesh-level penetration of the tool mesh into the object meshes; filled by the
    /// caller (`haptic6d run`), `None` when the scene has no meshes (a tree read from a `.sph`
    /// file) or it was not measured.
    pub mesh_penetration_mm: Option<MeshPenetrationReport>,
}

/// The mesh-level penetration of a run: the deepest point of the tool mesh inside an object
/// mesh, or of an object mesh inside the tool mesh, at the graphic pose, over the frames
/// measured (independent of the sphere-trees and of the engine's constraint rows).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct MeshPenetrationReport {
    /// Deepest penetration over the measured frames, mm (0 when none was measured).
    pub max: f64,
    /// Frames measured.
    pub frames: usize,
    /// Frames of the run whose tool may touch an object by the parts' bounding boxes alone
    /// (whatever the engine listed), of which every `stride`-th was measured.
    pub contact_frames: usize,
    /// One frame of every this many was measured (1: every one).
    pub stride: usize,
    /// Wall time of the measure (after the run, outside the haptic loop), s.
    pub wall_s: f64,
}

/// Force extremes and continuity of a run (raw wrench, before safety).
pub fn force_report(frames: &[FrameRecord]) -> ForceReport {
    force_report_of(frames.iter().map(|f| (f.t, &f.frame)))
}

/// [`force_report`] of frames given with their device times (s).
pub fn force_report_of<'a>(
    frames: impl IntoIterator<Item = (f64, &'a engine::Frame)>,
) -> ForceReport {
    let mut r = ForceReport::default();
    let mut prev: Option<[f64; 6]> = None;
    for (t, frame) in frames {
        let w = frame.raw_wrench;
        if !w.iter().all(|v| v.is_finite()) || !frame.q_g.iter().all(|v| v.is_finite()) {
            r.non_finite_frames += 1;
            continue;
        }
        r.max_force_n = r.max_force_n.max(norm3(&w[0..3]));
        r.max_torque_nmm = r.max_torque_nmm.max(norm3(&w[3..6]));
        if let Some(p) = prev {
            let jump = norm3(&[w[0] - p[0], w[1] - p[1], w[2] - p[2]]);
            r.max_force_jump_any_n = r.max_force_jump_any_n.max(jump);
            let prev_zero = p.iter().all(|v| *v == 0.0);
            if prev_zero && w.iter().any(|v| *v != 0.0) {
                r.contact_onsets += 1;
            } else if jump > r.max_force_jump_n {
                r.max_force_jump_n = jump;
                r.max_force_jump_t = t;
            }
        }
        prev = Some(w);
    }
    r
}

/// Summarises a run.
#[allow(clippy::too_many_arguments)]
pub fn summarize(
    scene: &str,
    solver: &str,
    form: &str,
    frames: &[FrameRecord],
    loop_stats: &LoopStats,
    goal: Option<Goal>,
    load: Vec<String>,
    load_s: f64,
) -> RunSummary {
    let goal = goal.map(|g| match g {
        Goal::InsertZ {
            target_z_mm,
            tol_mm,
        } => {
            let reached = frames
                .iter()
                .filter(|f| f.frame.status != FrameStatus::KeptLastSafe)
                .map(|f| f.frame.q_g[2])
                .fold(f64::INFINITY, f64::min);
            GoalReport {
                kind: "insert-z".into(),
                target_z_mm,
                reached_z_mm: reached,
                success: reached <= target_z_mm + tol_mm,
            }
        }
    });
    RunSummary {
        scene: scene.into(),
        solver: solver.into(),
        form: form.into(),
        geometry: engine::Geometry::Spheres.name().into(),
        frames: frames.len(),
        cd_us: Summary::of(frames.iter().map(|f| f.frame.cd_us)),
        opt_us: Summary::of(frames.iter().map(|f| f.frame.opt_us)),
        total_us: Summary::of(frames.iter().map(|f| f.frame.total_us)),
        ahead_us: Summary::of(frames.iter().map(|f| f.frame.ahead_us)),
        own_us: Summary::of(frames.iter().map(|f| f.frame.total_us - f.frame.ahead_us)),
        pairs: Summary::of(frames.iter().map(|f| f64::from(f.frame.pairs))),
        iterations: Summary::of(frames.iter().map(|f| f64::from(f.frame.iterations))),
        passes: Summary::of(frames.iter().map(|f| f64::from(f.frame.passes))),
        splits: Summary::of(frames.iter().map(|f| f64::from(f.frame.splits))),
        scanned: Summary::of(frames.iter().map(|f| f64::from(f.frame.scanned))),
        penetration_mm: Summary::of(frames.iter().map(|f| f.frame.penetration_mm)),
        force: force_report(frames),
        loop_stats: loop_stats.clone(),
        goal,
        load,
        load_s,
        trees: Vec::new(),
        mesh_penetration_mm: None,
        meshes: false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_run_header_is_the_engine_header_and_the_mesh_column() {
        assert_eq!(
            RUN_FRAMES_HEADER,
            format!("{FRAMES_HEADER},{MESH_PENETRATION_COLUMN}")
        );
    }
}
