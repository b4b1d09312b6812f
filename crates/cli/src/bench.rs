//! `haptic6d bench [--quick] [--out DIR] [--studies replay,scaling,speed,contact,friction,peer,zoo,ablation,fit]
//! [--peer [rapier,mujoco]]`: the paper's experiments, every solver on identical input, plus
//! scaling, hand-speed, contact and friction studies, and the comparison with the
//! virtual-coupling peers (rapier3d, and MuJoCo when its Python environment is installed).
//!
//! 1. **Replay.** For each scene (`bunny`, `spline`) the scene's device trajectory is recorded
//!    once and replayed into a fresh god-object per solver (`pqp` as in the paper, the
//!    `active-set` baseline, the default `dual`). Per solver: mean / p50 / p99 of collision
//!    detection, optimisation and total frame time, iterations (mean, max), pairs per frame,
//!    deepest penetration, and the force difference from the exact (`dual`) run frame by frame.
//! 2. **Pairs.** Total frame time against the number of contact pairs (10 … 5000): the bunny
//!    replay's frame with the most pairs, its detection skin grown until the QP holds the
//!    target number of rows, then timed cold (fresh warm start) many times per solver.
//! 3. **Depth.** The bunny trajectory replayed with trees of depth 3 … 6.
//! 4. **Speed.** Drag, lag, penetration and frame time of a tool pressed onto a frictionless
//!    plate and slid at 50–1000 mm/s or turned at 1–10 rad/s ([`crate::bench_speed`]).
//! 5. **Contact.** Flat on flat and the spline's phases: pairs, times, degraded frames
//!    ([`crate::bench_contact`]).
//! 6. **Peer.** haptic6d against virtual coupling on rapier3d and on MuJoCo on the same device
//!    input: frame time, mesh-level penetration, tunnelling, drag, jitter, insertion
//!    ([`crate::bench_peer`]; `--peer` runs it alone, `--peer-setup` installs MuJoCo's
//!    environment).
//! 7. **Zoo.** Every scene of the scene zoo with the shipped settings: frame times, degraded
//!    frames, drag, penetration (the engine's and mesh-level), pairs ([`crate::bench_zoo`];
//!    four scenes with `--quick`; also written to `DIR/zoo.md`).
//! 8. **Ablation.** The frame step's heuristics off one at a time, and all off, over the
//!    built-ins and the zoo: frames over 1 ms, degraded frames, p99, detection work,
//!    penetration, drag ([`crate::bench_ablation`]; the reduced zoo with `--quick`; also
//!    written to `DIR/ablation.md`).
//! 9. **Fit.** Generated pegs lowered into holes at radial clearances 0.5–0.02 mm (round and
//!    splined, two radii, with and without chamfers, straight and tilted): depth reached,
//!    force, degraded frames, frame times, mesh-level penetration, per geometry mode
//!    ([`crate::bench_fit`]; four rows with `--quick`; also written to `DIR/fit.md`).
//!
//! **Tuning** (`--studies tuning`, not in the default set): each of the frame step's tuned
//! values halved and doubled over the built-ins and the zoo ([`crate::bench_tuning`];
//! `--tuning-values` chooses some; `DIR/tuning.md`).
//!
//! **PQP scaling** (`--studies pqp-scaling`, not in the default set): the paper's PQP serial,
//! vectorized and on two threads against the active sets on QPs of real frames and generated
//! ones of 50 … 20 000 rows ([`crate::bench_pqp`]; `DIR/pqp_scaling.md`).
//!
//! Output: a table on stdout, `DIR/bench.json`, `DIR/bench.md`, and the plots
//! `DIR/bench_pairs_<scene>.png`, `DIR/bench_time_<scene>.png`, `DIR/bench_cost.png`,
//! `DIR/bench_scaling_pairs.png`, `DIR/bench_scaling_depth.png`, `DIR/bench_speed_drag.png`,
//! `DIR/bench_peer_<case>.png`.
//!
//! Timings are the engine's own per-stage counters (`FrameOutput`), one thread, frames computed
//! back to back (no pacing), so they measure the work of a frame, not the loop.

use engine::safety::norm3;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Context, Result};
use clap::Args;
use collide::Pose;
use engine::step::{FrameOutput, GodObject};
use engine::Counters;
use engine::SolverKind;
use scene::cache::TreeCache;
use scene::report::{tree_infos, TreeInfo};

use crate::bench_report::{BenchReport, DepthPoint, PairsPoint, ReplayRow, SceneReplays};
use scene::stats::Summary;
use scene::{Motion, Scene, TreeParams};

/// Arguments of `haptic6d bench`.
#[derive(Args, Debug)]
pub struct BenchArgs {
    /// A smoke-test run (< 1 minute): the first 1500 frames of each trajectory, fewer
    /// repetitions, pair targets up to 1000, depths 3–4 only and four zoo scenes.
    #[arg(long)]
    pub quick: bool,
    /// Output directory for bench.json, bench.md and the plots (created if missing; only the
    /// bench's own files are replaced).
    #[arg(long, short, default_value = "bench-out")]
    pub out: PathBuf,
    /// Scenes to replay (comma-separated built-in names).
    #[arg(long, value_delimiter = ',', default_value = "bunny,spline")]
    pub scenes: Vec<String>,
    /// Tree depths of the depth study (default 3,4,5; 3,4 with --quick). Each new depth builds
    /// (then caches) a bunny tree: depth 6 takes minutes.
    #[arg(long, value_delimiter = ',')]
    pub depths: Option<Vec<u32>>,
    /// Wall-time budget of one solver's replay, s (a replay past it stops and is reported as
    /// partial). Default 120, or 8 with --quick.
    #[arg(long)]
    pub budget: Option<f64>,
    /// The speed and contact studies with the detection helper thread (`[solver]
    /// helper_thread`): a second thread shares the frames' large traversals.
    #[arg(long)]
    pub helper_thread: bool,
    /// Face caps in the speed and contact studies: on or off (default: each scene's; the
    /// plate scenes have them, docs/DESIGN.md §Face caps).
    #[arg(long, value_parser = crate::parse_on_off)]
    pub face_caps: Option<bool>,
    /// The speed and contact studies paced at the scene's rate on the wall clock (as a device
    /// loop runs them, on a `SCHED_FIFO` thread when the privilege allows) instead of frames
    /// back to back; the helper thread's background work runs between frames.
    #[arg(long)]
    pub realtime: bool,
    /// Skip the scaling studies (pairs and depth).
    #[arg(long)]
    pub no_scaling: bool,
    /// Studies to run (comma-separated): replay, scaling, speed, contact, friction, peer, zoo,
    /// pqp-scaling (not by default: the serial, vectorized and threaded PQP on 50 to 20 000
    /// rows, minutes), tuning (not by default: each tuned value of the step halved and doubled
    /// over the built-ins and the zoo, some four minutes a pass),
    /// ablation, fit (with --quick, a reduced zoo of four scenes and four fit rows).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "replay,scaling,speed,contact,friction,peer,zoo,ablation,fit"
    )]
    pub studies: Vec<String>,
    /// The tuned values the tuning study scales (comma-separated names of `engine::Tuning`,
    /// e.g. `pair-target,list-payoff`); all when not given.
    #[arg(long, value_delimiter = ',')]
    pub tuning_values: Vec<String>,
    /// Values the tuning study starts from instead of the shipped ones (comma-separated
    /// `name=value`, e.g. `near-ahead-share=0.3`), to compare a candidate with its neighbours.
    #[arg(long, value_delimiter = ',', value_name = "NAME=VALUE")]
    pub tuning_base: Vec<String>,
    /// Passes of the tuning study over all its configurations; each scene keeps its quickest
    /// pass, so a slow spell of a shared machine does not read as a costly value.
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u32).range(1..=10))]
    pub tuning_passes: u32,
    /// What the tool touches in the speed, zoo and fit studies (comma-separated): spheres (the
    /// trees' leaf spheres, the default), mesh (the parts' own triangles), or both; each scene
    /// is replayed once per mode, every row naming its mode.
    #[arg(long, value_delimiter = ',', default_value = "spheres")]
    pub geometry: Vec<String>,
    /// Only the comparison with the virtual-coupling peers (as `--studies peer`). Alone, it runs
    /// rapier, and MuJoCo when its environment is installed (`--peer-setup`); `--peer rapier`,
    /// `--peer mujoco` or `--peer rapier,mujoco` choose (MuJoCo's environment is then installed
    /// first if missing).
    #[arg(
        long,
        conflicts_with = "studies",
        num_args = 0..=1,
        value_delimiter = ',',
        default_missing_value = "",
        value_name = "ENGINES"
    )]
    pub peer: Option<Vec<String>>,
    /// The peer's tuning search instead of the studies, for `rapier` (alone, the default) or
    /// `mujoco`: writes peer_tune.md and peer_tune.json, or peer_tune_mujoco.md and
    /// peer_tune_mujoco.json (minutes).
    #[arg(
        long,
        conflicts_with_all = ["studies", "peer"],
        num_args = 0..=1,
        default_missing_value = "rapier",
        value_name = "ENGINE"
    )]
    pub peer_tune: Option<String>,
    /// Installs MuJoCo's Python environment for the peer study and exits: a venv in the cache
    /// folder (`<cache>/mujoco-<version>`) with the pinned `mujoco` and `numpy` from PyPI.
    #[arg(long, conflicts_with_all = ["studies", "peer", "peer_tune"])]
    pub peer_setup: bool,
    /// Skip the PNG plots.
    #[arg(long)]
    pub no_plots: bool,
    /// Print the whole result as JSON on stdout instead of the tables.
    #[arg(long)]
    pub json: bool,
}

/// The solvers compared, in table order.
const SOLVERS: [SolverKind; 4] = [
    SolverKind::Pqp,
    SolverKind::PqpParallel,
    SolverKind::ActiveSet,
    SolverKind::Dual,
];

/// Frames replayed per scene in `--quick` mode.
const QUICK_FRAMES: usize = 1500;

/// Runs `haptic6d bench`.
pub fn run(mut args: BenchArgs) -> Result<()> {
    let t0 = Instant::now();
    // The peer engines asked for by name (none: every engine available).
    let mut peer_engines = Vec::new();
    if let Some(names) = &args.peer {
        for name in names.iter().filter(|n| !n.is_empty()) {
            let Ok(engine) = crate::bench_peer::PeerEngine::parse(name) else {
                crate::usage_bail!("--peer: no peer engine `{name}` (engines: rapier, mujoco)");
            };
            if !peer_engines.contains(&engine) {
                peer_engines.push(engine);
            }
        }
        args.studies = vec!["peer".into()];
    }
    for name in &args.scenes {
        if !scene::scenes::BUILTIN_NAMES.contains(&name.as_str()) {
            bail!(
                "--scenes: no built-in scene `{name}` (built-in: {})",
                scene::scenes::BUILTIN_NAMES.join(", ")
            );
        }
    }
    for study in &args.studies {
        if ![
            "replay",
            "scaling",
            "speed",
            "contact",
            "friction",
            "peer",
            "zoo",
            "ablation",
            "fit",
            "pqp-scaling",
            "tuning",
        ]
        .contains(&study.as_str())
        {
            crate::usage_bail!("--studies: no study `{study}` (studies: replay, scaling, speed, contact, friction, peer, zoo, ablation, fit, pqp-scaling, tuning)");
        }
    }
    let mut geometries = Vec::new();
    for g in &args.geometry {
        let g = <engine::Geometry as engine::setting::Setting>::parse_setting(g)
            .context("--geometry")?;
        if !geometries.contains(&g) {
            geometries.push(g);
        }
    }
    let wants = |name: &str| args.studies.iter().any(|s| s == name);
    let mode = crate::bench_contact::ReplayMode {
        helper_thread: args.helper_thread,
        realtime: args.realtime,
        face_caps: args.face_caps,
    };
    if args.realtime && !scene::rt::set_realtime_priority(50) {
        eprintln!("bench: SCHED_FIFO refused (no privilege?); paced frames at normal priority");
    }
    let scenes: &[String] = if wants("replay") { &args.scenes } else { &[] };
    prepare_out_dir(&args.out)?;
    let cache = TreeCache::from_env();
    if args.peer_setup {
        let env = crate::bench_peer::mujoco_env(&cache, true)?;
        println!("bench: MuJoCo peer ready in {}", env.venv.display());
        return Ok(());
    }
    if let Some(engine) = &args.peer_tune {
        let Ok(engine) = crate::bench_peer::PeerEngine::parse(engine) else {
            crate::usage_bail!("--peer-tune: no peer engine `{engine}` (engines: rapier, mujoco)");
        };
        let (md, json, stem) = match engine {
            crate::bench_peer::PeerEngine::Rapier => {
                let rows = crate::bench_peer::peer_tune(&cache)?;
                let md = crate::bench_peer::tune_markdown(&rows);
                (md, serde_json::to_string_pretty(&rows)?, "peer_tune")
            }
            crate::bench_peer::PeerEngine::Mujoco => {
                let env = crate::bench_peer::mujoco_env(&cache, true)?;
                let rows = crate::bench_peer::peer_tune_mujoco(&cache, &env)?;
                let md = crate::bench_peer::tune_mujoco_markdown(&rows);
                (md, serde_json::to_string_pretty(&rows)?, "peer_tune_mujoco")
            }
        };
        scene::io::write_atomic(&args.out.join(format!("{stem}.md")), md.as_bytes())?;
        scene::io::write_atomic(&args.out.join(format!("{stem}.json")), json.as_bytes())?;
        print!("{md}");
        return Ok(());
    }
    // Quick mode keeps the device's real speed (every frame) and shortens the run instead:
    // striding frames would make the hand ten times faster and change what is measured.
    let window = if args.quick { QUICK_FRAMES } else { usize::MAX };
    let budget = args.budget.unwrap_or(if args.quick { 8.0 } else { 120.0 });
    if budget.is_nan() || budget <= 0.0 {
        crate::usage_bail!("--budget {budget}: must be a positive number of seconds");
    }
    if let Some(d) = args
        .depths
        .iter()
        .flatten()
        .find(|&&d| !(1..=7).contains(&d))
    {
        crate::usage_bail!("--depths: depth {d} is out of range (1 to 7)");
    }
    let mut report = BenchReport {
        mode: if args.quick { "quick" } else { "full" }.into(),
        machine: machine_description(),
        helper_thread: args.helper_thread,
        realtime: args.realtime,
        face_caps: args.face_caps,
        ..Default::default()
    };

    let mut bunny: Option<(Scene, Vec<FrameOutput>)> = None;
    let mut replays: Vec<SceneReplays> = Vec::new();
    for name in scenes {
        let scene = scene::scenes::builtin(name, &cache)
            .with_context(|| format!("loading the built-in scene `{name}`"))?;
        let trees = tree_infos(&scene);
        for t in &trees {
            eprintln!("bench: {name}: {}", t.describe());
        }
        report.trees.push((name.clone(), trees));
        let traj = recorded_trajectory(&scene, window);
        eprintln!(
            "bench: {name}: {} frames x {} solvers",
            traj.len(),
            SOLVERS.len()
        );
        let planned = traj.len();
        let mut runs = Vec::new();
        for kind in SOLVERS {
            let t = Instant::now();
            let frames = replay(&scene, kind, &traj, budget)?;
            let wall = t.elapsed().as_secs_f64();
            eprintln!("bench: {name} / {}: {wall:.1} s", kind.name());
            runs.push((kind, frames, wall));
        }
        let dual = runs
            .iter()
            .find(|(k, _, _)| *k == SolverKind::Dual)
            .map(|(_, f, _)| f.clone())
            .unwrap_or_default();
        for (kind, frames, wall) in &runs {
            let mut row = replay_row(name, *kind, frames, &dual, *wall);
            row.planned_frames = planned;
            report.replay.push(row);
        }
        if name == "bunny" {
            bunny = Some((scene.clone(), dual.clone()));
        }
        replays.push((
            name.clone(),
            runs.into_iter().map(|(k, f, _)| (k, f)).collect(),
        ));
    }

    if !args.no_scaling && wants("scaling") {
        let (scene, dual_frames) = match bunny {
            Some(b) => b,
            None => {
                let scene = scene::scenes::builtin("bunny", &cache)?;
                let traj = recorded_trajectory(&scene, window);
                let frames = replay(&scene, SolverKind::Dual, &traj, f64::INFINITY)?;
                (scene, frames)
            }
        };
        let targets: &[usize] = if args.quick {
            &[10, 50, 200, 1000]
        } else {
            &[10, 50, 200, 1000, 2000, 5000]
        };
        let reps = if args.quick { 20 } else { 200 };
        eprintln!("bench: pairs study, targets {targets:?}, {reps} repetitions");
        report.scaling_pairs = pairs_study(&scene, &dual_frames, targets, reps)?;
        let default_depths: &[u32] = if args.quick { &[3, 4] } else { &[3, 4, 5] };
        let depths = args.depths.as_deref().unwrap_or(default_depths);
        eprintln!("bench: depth study, depths {depths:?}");
        report.scaling_depth = depth_study(&scene, depths, window, budget, &cache)?;
    }
    if wants("speed") {
        let solvers: &[SolverKind] = if args.quick {
            &[SolverKind::Dual]
        } else {
            &[SolverKind::Dual, SolverKind::ActiveSet]
        };
        eprintln!("bench: speed study (plate scene)");
        report.speed =
            crate::bench_speed::speed_study(&cache, args.quick, solvers, &geometries, mode)?;
    }
    if wants("contact") {
        eprintln!("bench: contact study (flat on flat, spline phases)");
        report.contact = crate::bench_contact::contact_study(&cache, args.quick, mode)?;
    }
    if wants("friction") {
        eprintln!("bench: friction study (pushes, cost, spline)");
        report.friction = Some(crate::bench_friction::friction_study(&cache, args.quick)?);
    }
    let mut peer_traces = Vec::new();
    if wants("peer") {
        use crate::bench_peer::PeerEngine;
        // Asked by name: MuJoCo's environment is installed when missing; by default MuJoCo runs
        // when its environment is there, and one line says why not otherwise.
        let mut engines = peer_engines.clone();
        let mut env = None;
        if engines.is_empty() {
            engines.push(PeerEngine::Rapier);
            match crate::bench_peer::mujoco_env(&cache, false) {
                Ok(e) => {
                    engines.push(PeerEngine::Mujoco);
                    env = Some(e);
                }
                Err(why) => eprintln!("bench: MuJoCo peer skipped: {why:#}"),
            }
        } else if engines.contains(&PeerEngine::Mujoco) {
            env = Some(crate::bench_peer::mujoco_env(&cache, true)?);
        }
        let names: Vec<&str> = engines.iter().map(|e| e.name()).collect();
        eprintln!(
            "bench: peer study (virtual coupling on {})",
            names.join(" and ")
        );
        (report.peer, peer_traces) =
            crate::bench_peer::peer_study(&cache, args.quick, &engines, env.as_ref())?;
    }
    if wants("zoo") {
        eprintln!("bench: zoo study (every zoo scene, shipped settings)");
        report.zoo = crate::bench_zoo::zoo_study(&cache, args.quick, &geometries)?;
        let md = format!(
            "# haptic6d bench: scene zoo ({}), {}\n\n{}",
            report.mode,
            report.machine,
            crate::bench_zoo::zoo_markdown(&report.zoo)
        );
        scene::io::write_atomic(&args.out.join("zoo.md"), md.as_bytes())?;
    }
    if wants("pqp-scaling") {
        eprintln!("bench: pqp-scaling study (serial, vectorized, threaded PQP; active sets)");
        report.pqp_scaling = crate::bench_pqp::pqp_study(&cache, args.quick)?;
        let md = format!(
            "# haptic6d bench: PQP scaling ({}), {}\n\n{}",
            report.mode,
            report.machine,
            crate::bench_pqp::pqp_markdown(&report.pqp_scaling)
        );
        scene::io::write_atomic(&args.out.join("pqp_scaling.md"), md.as_bytes())?;
    }
    if wants("ablation") {
        eprintln!("bench: ablation study (each heuristic of the step off in turn)");
        report.ablation = crate::bench_ablation::ablation_study(&cache, args.quick)?;
        let md = format!(
            "# haptic6d bench: heuristics ablation ({}), {}\n\n{}",
            report.mode,
            report.machine,
            crate::bench_ablation::ablation_markdown(&report.ablation)
        );
        scene::io::write_atomic(&args.out.join("ablation.md"), md.as_bytes())?;
    }
    if wants("tuning") {
        for name in &args.tuning_values {
            if !engine::Tuning::NAMES.contains(&name.as_str()) {
                crate::usage_bail!(
                    "--tuning-values: no tuned value `{name}` (values: {})",
                    engine::Tuning::NAMES.join(", ")
                );
            }
        }
        let base = crate::tuning_with(engine::Tuning::DEFAULT, &args.tuning_base, "--tuning-base")?;
        eprintln!("bench: tuning study (each tuned value of the step halved and doubled)");
        report.tuning = crate::bench_tuning::tuning_study(
            &cache,
            args.quick,
            base,
            &args.tuning_values,
            args.tuning_passes as usize,
        )?;
        let md = format!(
            "# haptic6d bench: the step's tuned values ({}), {}\n\n{}",
            report.mode,
            report.machine,
            crate::bench_tuning::tuning_markdown(&report.tuning)
        );
        scene::io::write_atomic(&args.out.join("tuning.md"), md.as_bytes())?;
    }
    if wants("fit") {
        eprintln!("bench: fit study (pegs into holes at 0.5-0.02 mm clearance, shipped settings)");
        report.fit = crate::bench_fit::fit_study(&cache, args.quick, &geometries)?;
        report.edge = crate::bench_fit::edge_study(&cache, args.quick, &geometries)?;
        let md = format!(
            "# haptic6d bench: pegs and holes ({}), {}\n\n{}\n## A cylinder over a sharp edge\n\n{}",
            report.mode,
            report.machine,
            crate::bench_fit::fit_markdown(&report.fit),
            crate::bench_fit::edge_markdown(&report.edge)
        );
        scene::io::write_atomic(&args.out.join("fit.md"), md.as_bytes())?;
    }
    report.wall_s = t0.elapsed().as_secs_f64();

    let md = markdown(&report);
    let json = serde_json::to_string_pretty(&report)?;
    scene::io::write_atomic(&args.out.join("bench.json"), json.as_bytes())?;
    scene::io::write_atomic(&args.out.join("bench.md"), md.as_bytes())?;
    if !args.no_plots {
        crate::bench_plot::write_bench_plots(&args.out, &replays, &report)?;
        crate::bench_peer::write_peer_plots(&args.out, &peer_traces)?;
    }
    if args.json {
        println!("{json}");
    } else {
        print!("{md}");
        println!(
            "\nwrote {}/bench.json, bench.md and plots",
            args.out.display()
        );
    }
    Ok(())
}

/// Creates `dir` if missing; refuses a path that exists and is not a directory.
fn prepare_out_dir(dir: &Path) -> Result<()> {
    if dir.exists() && !dir.is_dir() {
        bail!("--out {} exists and is not a directory", dir.display());
    }
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))
}

/// The scene's device trajectory as poses, its first `window` frames (identical input for all
/// solvers).
fn recorded_trajectory(scene: &Scene, window: usize) -> Vec<Pose> {
    scene
        .trajectory()
        .samples
        .iter()
        .take(window)
        .map(|s| Pose::from_array(s.q))
        .collect()
}

/// Replays `traj` into a fresh god-object with solver `kind`, stopping early (a partial run,
/// reported as such) once `budget_s` of wall time is spent: PQP's O(N^2) frames at thousands
/// of pairs would otherwise take hours.
fn replay(
    scene: &Scene,
    kind: SolverKind,
    traj: &[Pose],
    budget_s: f64,
) -> Result<Vec<FrameOutput>> {
    let mut params = scene.engine_config();
    params.solver = kind;
    let mut god = GodObject::new(&scene.tool, &scene.objects, params)?;
    let Some(first) = traj.first() else {
        return Ok(Vec::new());
    };
    god.reset(first)?;
    let t0 = Instant::now();
    let mut frames = Vec::with_capacity(traj.len());
    for q in traj {
        frames.push(god.step(q));
        if t0.elapsed().as_secs_f64() > budget_s {
            break;
        }
    }
    Ok(frames)
}

fn replay_row(
    scene: &str,
    kind: SolverKind,
    frames: &[FrameOutput],
    dual: &[FrameOutput],
    wall_s: f64,
) -> ReplayRow {
    let diff = |range: std::ops::Range<usize>| {
        Summary::of(frames.iter().zip(dual).map(|(f, d)| {
            let e: Vec<f64> = range.clone().map(|k| f.wrench[k] - d.wrench[k]).collect();
            norm3(&e)
        }))
    };
    let counts = Counters::of(frames.iter().map(|f| f.status));
    ReplayRow {
        scene: scene.into(),
        solver: kind.name().into(),
        frames: frames.len(),
        planned_frames: frames.len(),
        cd_us: Summary::of(frames.iter().map(|f| f.cd_us)),
        opt_us: Summary::of(frames.iter().map(|f| f.opt_us)),
        total_us: Summary::of(frames.iter().map(|f| f.total_us)),
        iterations: Summary::of(frames.iter().map(|f| f64::from(f.iterations))),
        pairs: Summary::of(frames.iter().map(|f| f64::from(f.pairs))),
        max_penetration_mm: frames.iter().map(|f| f.penetration_mm).fold(0.0, f64::max),
        force_diff_n: diff(0..3),
        torque_diff_nmm: diff(3..6),
        inexact_frames: counts.inexact,
        kept_last_safe_frames: counts.kept_last_safe,
        lagging_frames: counts.lagging,
        wall_s,
    }
}

/// The frame of the dual run with the most pairs: its previous graphic pose and device pose.
fn deepest_frame(frames: &[FrameOutput]) -> Option<(Pose, Pose)> {
    let k = (1..frames.len()).max_by_key(|&k| frames[k].pairs)?;
    Some((
        Pose::from_array(frames[k - 1].q_g),
        Pose::from_array(frames[k].q_h),
    ))
}

/// Frame time against pair count: see the module docs.
fn pairs_study(
    scene: &Scene,
    dual_frames: &[FrameOutput],
    targets: &[usize],
    reps: usize,
) -> Result<Vec<PairsPoint>> {
    let (base, q_h) =
        deepest_frame(dual_frames).context("the bunny replay has no frame to scale")?;
    // The frame is fixed; the detection skin grows until the QP holds `target` rows (pairs
    // within the skin are real, inactive constraints: what a larger contact patch adds).
    let pairs_with_skin = |skin: f64| -> Result<u32> {
        let mut params = scene.engine_config();
        params.skin_mm = skin;
        let mut probe = GodObject::new(&scene.tool, &scene.objects, params)?;
        probe.reset(&base)?;
        Ok(probe.step(&q_h).pairs)
    };
    let mut out = Vec::new();
    for &target in targets {
        let (mut lo, mut hi) = (0.0, 1.0);
        while (pairs_with_skin(hi)? as usize) < target && hi < 64.0 {
            lo = hi;
            hi *= 2.0;
        }
        for _ in 0..16 {
            let mid = 0.5 * (lo + hi);
            if (pairs_with_skin(mid)? as usize) < target {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        for kind in SOLVERS {
            let mut params = scene.engine_config();
            params.solver = kind;
            params.skin_mm = hi;
            let mut god = GodObject::new(&scene.tool, &scene.objects, params)?;
            // PQP is O(N^2) per iteration: cap its repetitions at large N so the bench ends.
            let n = if kind.is_pqp() && target > 1000 {
                reps.min(5)
            } else {
                reps
            };
            let mut frames = Vec::with_capacity(n);
            for _ in 0..n {
                god.reset(&base)?;
                frames.push(god.step(&q_h));
            }
            out.push(PairsPoint {
                target,
                pairs: frames.first().map_or(0, |f| f.pairs),
                solver: kind.name().into(),
                total_us: Summary::of(frames.iter().map(|f| f.total_us)),
                opt_us: Summary::of(frames.iter().map(|f| f.opt_us)),
                iterations: Summary::of(frames.iter().map(|f| f64::from(f.iterations))),
            });
        }
    }
    Ok(out)
}

/// The bunny trajectory replayed with trees of each depth.
fn depth_study(
    bunny: &Scene,
    depths: &[u32],
    window: usize,
    budget: f64,
    cache: &TreeCache,
) -> Result<Vec<DepthPoint>> {
    let mesh = scene::scenes::bunny::bunny_mesh_mm()?;
    let traj = recorded_trajectory(bunny, window);
    let mut out = Vec::new();
    for &depth in depths {
        let mut log = Vec::new();
        let params = TreeParams {
            depth,
            branching: 8,
            method: spheretree::build::BuildMethod::Tight,
        };
        let tree = scene::tree_for_mesh(&mesh, params, cache, "bunny", &mut log)?;
        for line in &log {
            eprintln!("bench: depth {depth}: {line}");
        }
        let mut scene = bunny.clone();
        scene.motion = Motion::Hold;
        scene.tool = tree.clone();
        for (t, _) in scene.objects.iter_mut() {
            *t = tree.clone();
        }
        let leaves = tree.leaves().count();
        for kind in SOLVERS {
            let frames = replay(&scene, kind, &traj, budget)?;
            out.push(DepthPoint {
                depth,
                leaves,
                builder_version: spheretree::build::BUILDER_VERSION,
                solver: kind.name().into(),
                pairs: Summary::of(frames.iter().map(|f| f64::from(f.pairs))),
                total_us: Summary::of(frames.iter().map(|f| f.total_us)),
                max_penetration_mm: frames.iter().map(|f| f.penetration_mm).fold(0.0, f64::max),
            });
        }
    }
    Ok(out)
}

/// CPU model and core count, for the record.
fn machine_description() -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|m| m.trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into());
    let cores = std::thread::available_parallelism().map_or(0, |n| n.get());
    format!("{cpu}, {cores} cores")
}

/// The report as Markdown tables.
pub fn markdown(r: &BenchReport) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# haptic6d bench ({}), {}\n", r.mode, r.machine);
    if r.helper_thread || r.realtime {
        let _ = writeln!(
            s,
            "Speed and contact studies: {}, {}.\n",
            if r.helper_thread {
                "with the detection helper thread (`--helper-thread`)"
            } else {
                "one thread"
            },
            if r.realtime {
                "frames paced at the scene rate (`--realtime`)"
            } else {
                "frames back to back"
            }
        );
    }
    for (scene, trees) in &r.trees {
        let list: Vec<String> = trees.iter().map(TreeInfo::describe).collect();
        let _ = writeln!(s, "trees of {scene}: {}", list.join("; "));
    }
    if !r.trees.is_empty() {
        let _ = writeln!(s);
    }
    if !r.replay.is_empty() {
        let _ = writeln!(
            s,
            "| scene | solver | frames | cd µs mean / p99 | opt µs mean / p50 / p99 | total µs mean / p99 / max | iters mean / max | pairs mean / max | max pen. mm | ΔF vs dual N mean / max | inexact | kept last safe | lagging |"
        );
        let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|---|---|---|---|");
        for row in &r.replay {
            let _ = writeln!(
                s,
                "| {} | {} | {} | {:.1} / {:.1} | {:.1} / {:.1} / {:.1} | {:.1} / {:.1} / {:.1} | {:.1} / {:.0} | {:.0} / {:.0} | {:.4} | {:.3} / {:.3} | {} | {} | {} |",
                row.scene,
                row.solver,
                if row.frames < row.planned_frames {
                    format!("{} of {} (time budget)", row.frames, row.planned_frames)
                } else {
                    row.frames.to_string()
                },
                row.cd_us.mean,
                row.cd_us.p99,
                row.opt_us.mean,
                row.opt_us.p50,
                row.opt_us.p99,
                row.total_us.mean,
                row.total_us.p99,
                row.total_us.max,
                row.iterations.mean,
                row.iterations.max,
                row.pairs.mean,
                row.pairs.max,
                row.max_penetration_mm,
                row.force_diff_n.mean,
                row.force_diff_n.max,
                row.inexact_frames,
                row.kept_last_safe_frames,
                row.lagging_frames,
            );
        }
    }
    if !r.scaling_pairs.is_empty() {
        let _ = writeln!(
            s,
            "\n## Frame time against contact pairs (bunny, cold frames)\n"
        );
        let _ = writeln!(
            s,
            "| target | pairs | solver | total µs p50 / p99 | opt µs p50 | iters p50 / max |"
        );
        let _ = writeln!(s, "|---|---|---|---|---|---|");
        for p in &r.scaling_pairs {
            let _ = writeln!(
                s,
                "| {} | {} | {} | {:.1} / {:.1} | {:.1} | {:.0} / {:.0} |",
                p.target,
                p.pairs,
                p.solver,
                p.total_us.p50,
                p.total_us.p99,
                p.opt_us.p50,
                p.iterations.p50,
                p.iterations.max
            );
        }
    }
    if !r.scaling_depth.is_empty() {
        let _ = writeln!(s, "\n## Frame time against tree depth (bunny trajectory)\n");
        let _ = writeln!(
            s,
            "| depth | leaves | builder | solver | pairs mean / max | total µs mean / p99 | max pen. mm |"
        );
        let _ = writeln!(s, "|---|---|---|---|---|---|---|");
        for p in &r.scaling_depth {
            let _ = writeln!(
                s,
                "| {} | {} | v{} | {} | {:.0} / {:.0} | {:.1} / {:.1} | {:.4} |",
                p.depth,
                p.leaves,
                p.builder_version,
                p.solver,
                p.pairs.mean,
                p.pairs.max,
                p.total_us.mean,
                p.total_us.p99,
                p.max_penetration_mm
            );
        }
    }
    if !r.speed.is_empty() {
        let _ = writeln!(
            s,
            "\n## Hand speed on a frictionless plate (1 mm press, exact solvers)\n"
        );
        s.push_str(&crate::bench_speed::speed_markdown(&r.speed));
    }
    if !r.contact.is_empty() {
        let _ = writeln!(s, "\n## Large and tight contacts (dual)\n");
        s.push_str(&crate::bench_contact::contact_markdown(&r.contact));
    }
    if let Some(f) = &r.friction {
        let _ = writeln!(s, "\n## Friction: Coulomb stick and slip (dual)\n");
        s.push_str(&crate::bench_friction::friction_markdown(f));
    }
    if !r.peer.is_empty() {
        let _ = writeln!(
            s,
            "\n## haptic6d against virtual coupling on rapier3d and MuJoCo (same device input)\n"
        );
        s.push_str(&crate::bench_peer::peer_markdown(&r.peer));
        let _ = writeln!(s, "\nPer measure, engine by engine:\n");
        s.push_str(&crate::bench_peer::peer_columns_markdown(&r.peer));
    }
    if !r.zoo.is_empty() {
        let _ = writeln!(s, "\n## Scene zoo (dual, shipped settings)\n");
        s.push_str(&crate::bench_zoo::zoo_markdown(&r.zoo));
    }
    if !r.tuning.shipped.is_empty() {
        let _ = writeln!(s, "\n## The step's tuned values, halved and doubled\n");
        s.push_str(&crate::bench_tuning::tuning_markdown(&r.tuning));
    }
    if !r.ablation.is_empty() {
        let _ = writeln!(s, "\n## Heuristics ablation (dual, shipped settings)\n");
        s.push_str(&crate::bench_ablation::ablation_markdown(&r.ablation));
    }
    if !r.fit.is_empty() {
        let _ = writeln!(
            s,
            "\n## Pegs and holes by clearance (dual, shipped settings)\n"
        );
        s.push_str(&crate::bench_fit::fit_markdown(&r.fit));
    }
    if !r.edge.is_empty() {
        let _ = writeln!(
            s,
            "\n## A cylinder over a sharp edge (dual, shipped settings)\n"
        );
        s.push_str(&crate::bench_fit::edge_markdown(&r.edge));
    }
    let _ = writeln!(s, "\nbench wall time: {:.1} s", r.wall_s);
    s
}
