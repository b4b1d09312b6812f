//! What `haptic6d bench` measures, as data: the report written to `bench.json` and read by the
//! tables (`bench.rs`) and the plots (`bench_plot.rs`).

use engine::step::FrameOutput;
use engine::SolverKind;
use scene::report::TreeInfo;
use scene::stats::Summary;
use serde::Serialize;

/// A scene's name and each solver's frames.
pub type SceneReplays = (String, Vec<(SolverKind, Vec<FrameOutput>)>);

/// One solver's replay of one scene.
#[derive(Serialize, Clone, Debug)]
pub struct ReplayRow {
    /// Scene name.
    pub scene: String,
    /// Solver name.
    pub solver: String,
    /// Frames replayed.
    pub frames: usize,
    /// Frames in the trajectory (more than `frames` when the replay hit its time budget).
    pub planned_frames: usize,
    /// Collision detection time per frame, µs.
    pub cd_us: Summary,
    /// Constraint building + QP time per frame, µs.
    pub opt_us: Summary,
    /// Whole frame, µs.
    pub total_us: Summary,
    /// Solver iterations per frame (summed over passes).
    pub iterations: Summary,
    /// Contact pairs per frame.
    pub pairs: Summary,
    /// Deepest leaf–leaf overlap over the run, mm.
    pub max_penetration_mm: f64,
    /// |F - F_dual| per frame, N (0 for dual itself).
    pub force_diff_n: Summary,
    /// |T - T_dual| per frame, N·mm.
    pub torque_diff_nmm: Summary,
    /// Frames whose QP answer violated a constraint beyond the solver's tolerance (the step's
    /// `FrameStatus::Inexact`, counted as in the loop's `LoopStats::inexact`).
    pub inexact_frames: u64,
    /// Frames that kept the last safe pose (the QP was capped, infeasible or failed; counted as
    /// in `LoopStats::kept_last_safe`).
    pub kept_last_safe_frames: u64,
    /// Frames that ended short of the optimum, safe (passes or budget ran out; counted as in
    /// `LoopStats::lagging`).
    pub lagging_frames: u64,
    /// Wall time of the whole replay, s.
    pub wall_s: f64,
}

/// One point of the pairs study.
#[derive(Serialize, Clone, Debug)]
pub struct PairsPoint {
    /// Target pair count.
    pub target: usize,
    /// Pairs actually found.
    pub pairs: u32,
    /// Solver name.
    pub solver: String,
    /// Whole frame, µs (cold warm start).
    pub total_us: Summary,
    /// Optimisation part, µs.
    pub opt_us: Summary,
    /// Iterations.
    pub iterations: Summary,
}

/// One point of the depth study.
#[derive(Serialize, Clone, Debug)]
pub struct DepthPoint {
    /// Tree depth (levels - 1).
    pub depth: u32,
    /// Leaves per tree.
    pub leaves: usize,
    /// Version of the builder that made the trees (`spheretree::build::BUILDER_VERSION`).
    pub builder_version: u32,
    /// Solver name.
    pub solver: String,
    /// Contact pairs per frame.
    pub pairs: Summary,
    /// Whole frame, µs.
    pub total_us: Summary,
    /// Deepest overlap over the run, mm.
    pub max_penetration_mm: f64,
}

/// Everything the bench measured.
#[derive(Serialize, Debug, Default)]
pub struct BenchReport {
    /// `quick` or `full`.
    pub mode: String,
    /// Machine description (cores, CPU model).
    pub machine: String,
    /// The speed and contact studies ran with the detection helper thread.
    pub helper_thread: bool,
    /// The speed and contact studies paced their frames at the scene rate.
    pub realtime: bool,
    /// Face caps forced on or off in the speed and contact studies (`None`: each scene's).
    pub face_caps: Option<bool>,
    /// The trees of each replayed scene: (scene, its trees).
    pub trees: Vec<(String, Vec<TreeInfo>)>,
    /// Replays, per scene and solver.
    pub replay: Vec<ReplayRow>,
    /// Frame time against pair count.
    pub scaling_pairs: Vec<PairsPoint>,
    /// Frame time against tree depth.
    pub scaling_depth: Vec<DepthPoint>,
    /// Drag, lag and frame time against hand speed on the plate.
    pub speed: Vec<crate::bench_speed::SpeedRow>,
    /// Large and tight contacts: flat on flat, the spline's phases.
    pub contact: Vec<crate::bench_contact::ContactRow>,
    /// Coulomb friction: pushes, cost, the spline.
    pub friction: Option<crate::bench_friction::FrictionStudy>,
    /// haptic6d against the virtual-coupling peers (rapier3d, MuJoCo), per case and engine.
    pub peer: Vec<crate::bench_peer::PeerRow>,
    /// The scene zoo, one row per scene.
    pub zoo: Vec<crate::bench_zoo::ZooRow>,
    /// The frame step's heuristics off one at a time, over the built-ins and the zoo.
    pub ablation: Vec<crate::bench_ablation::AblationRow>,
    /// The tuning study (`--studies tuning`).
    pub tuning: crate::bench_tuning::TuningStudy,
    /// The PQP scaling study: serial, vectorized and threaded PQP against the active sets.
    pub pqp_scaling: Vec<crate::bench_pqp::PqpScalingRow>,
    /// Pegs lowered into holes by clearance, per case and geometry mode.
    pub fit: Vec<crate::bench_fit::FitRow>,
    /// The sharp-edge case of the fit study.
    pub edge: Vec<crate::bench_fit::EdgeRow>,
    /// Wall time of the bench, s.
    pub wall_s: f64,
}
