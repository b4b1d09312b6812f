//! The `peer` study of `haptic6d bench` (`haptic6d bench --peer`): haptic6d side by side with
//! what users pick instead, 6-DoF virtual coupling on a physics engine, on the same recorded
//! device input in the same run: rapier3d ([`peer::PeerTool`]) and MuJoCo
//! ([`peer::mujoco`], its Python package in a venv of its own, when installed).
//!
//! Cases (each the device trajectory of a built-in scene or of the plate study):
//! - **bunny**: the bunny scene's script (slide on the back, the deep base-on-base push);
//! - **spline**: the splined shaft onto the hub face, turned until the keys align, inserted;
//! - **plate**: the puck and the ball pressed 1 mm onto the frictionless plate and slid;
//! - **thin plate**: the ball pushed at 100 and 2000 mm/s onto a 1 mm plate, the hand going
//!   10 or 40 mm below it ([`THIN_PUSH_MM`]; the tunnelling case).
//!
//! Per case and engine (haptic6d with the dual solver, rapier with [`PeerParams::tuned`],
//! MuJoCo with [`MujocoOptions::tuned`]): frame time p50 / p99 / max (one thread, frames back
//! to back; MuJoCo's is the time of its `mj_step` calls, measured in Python), the **mesh-level**
//! penetration ([`peer::MeshPenetration`]: tool and object meshes, the same query for both
//! engines, so haptic6d's sphere-tree approximation shows too), tunnelling events (thin plate),
//! drag while sliding (plate), force jitter (p99 of the frame-to-frame |ΔF| in the case's
//! steady-contact windows) and whether the spline insertion reaches its depth.

use std::time::Instant;

use anyhow::{bail, Context, Result};
use collide::Pose;
use engine::step::GodObject;
use engine::SolverKind;
use mesh::TriMesh;
use peer::mujoco::{MujocoCase, MujocoEnv, MujocoOptions};
use peer::{
    convex_pieces, MeshPenetration, ObjectShape, PeerFrame, PeerParams, PeerScene, PeerTool,
    ToolShape,
};
use scene::cache::TreeCache;
use scene::scenes::plate::{self, PlateTool, SpeedMotion};
use scene::stats::Summary;
use scene::trajectory::{Ease, Script};
use scene::{Goal, Motion, Scene, TreeParams};
use serde::Serialize;

/// Thickness of the thin plate, mm.
pub const THIN_PLATE_MM: f64 = 1.0;

/// How far below the thin plate's top face the hand goes, mm (kt × this = the push, N): a
/// firm push, and a hand pressed through the wall as when a device saturates.
pub const THIN_PUSH_MM: [f64; 2] = [10.0, 40.0];

/// Surface samples per mesh of the penetration measure (beside every vertex).
const PENETRATION_SAMPLES: usize = 2000;

/// Voxel resolution of the peer's convex decomposition of the tool (parry's default).
const TOOL_DECOMPOSITION_RESOLUTION: u32 = 64;

/// Voxel resolution of the convex decomposition of a non-convex object for MuJoCo, whose mesh
/// geoms collide as their convex hulls (parry's default, as for the tool).
const OBJECT_DECOMPOSITION_RESOLUTION: u32 = 64;

/// An engine of the peer study beside haptic6d.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PeerEngine {
    /// rapier3d-f64 ([`peer::PeerTool`]).
    Rapier,
    /// MuJoCo's Python package ([`peer::mujoco`]).
    Mujoco,
}

impl PeerEngine {
    /// The engine's name in the tables and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Self::Rapier => "rapier",
            Self::Mujoco => "mujoco",
        }
    }

    /// The engine called `name` (`rapier` or `mujoco`).
    pub fn parse(name: &str) -> Result<Self> {
        match name {
            "rapier" => Ok(Self::Rapier),
            "mujoco" => Ok(Self::Mujoco),
            _ => bail!("no peer engine `{name}` (engines: rapier, mujoco)"),
        }
    }
}

/// Frames replayed of the bunny script with `--quick` (approach and the start of the slide).
const QUICK_BUNNY_FRAMES: usize = 1500;

/// One engine's run of one case.
#[derive(Serialize, Clone, Debug)]
pub struct PeerRow {
    /// The case: scene and motion.
    pub case: String,
    /// `haptic6d`, `rapier` or `mujoco`.
    pub engine: String,
    /// Frames replayed.
    pub frames: usize,
    /// Frame time, µs (haptic6d: the whole step; rapier: the coupling force and one step;
    /// MuJoCo: its `mj_step` calls of the frame, timed in Python).
    pub step_us: Summary,
    /// Contact rows (haptic6d: leaf pairs of the first pass) or contact points (rapier's solver
    /// contacts, MuJoCo's `ncon`) per frame.
    pub contacts: Summary,
    /// Mesh-level penetration per frame, mm (infinite from the frame a run blew up).
    pub penetration_mm: Summary,
    /// Times the tool went through the thin plate (its centre below the plate's underside).
    pub tunnelling_events: Option<usize>,
    /// Mean force opposing the slide at constant speed, N (plate cases).
    pub drag_n: Option<f64>,
    /// p99 of |F_k - F_{k-1}| over the steady-contact frames, N.
    pub jitter_p99_n: Option<f64>,
    /// Deepest `z` of the tool origin, mm, and whether it reached the insertion target
    /// (spline).
    pub insertion: Option<(f64, bool)>,
}

/// Time windows `[t0, t1)` (s) of a slide at constant speed, and the hand's direction along
/// `x` (+1 or -1) in each.
type SlideWindows = (Vec<(f64, f64)>, Vec<f64>);

/// One frame of a plot series: time (s), mesh penetration (mm), force on the hand (N).
pub type TracePoint = (f64, f64, f64);

/// What is measured on a case beside time and penetration.
#[derive(Clone, Debug, Default)]
struct Checks {
    /// Time windows `[t0, t1)` (s) of steady contact, for the jitter.
    steady: Vec<(f64, f64)>,
    /// Slide windows (s) and the hand's direction along `x` in each, for the drag.
    slide: Option<SlideWindows>,
    /// Insertion goal.
    goal: Option<Goal>,
    /// Thin plate: the tool's centre (tool frame, mm) and the plate's underside `z` (mm).
    tunnel: Option<([f64; 3], f64)>,
}

/// A case: a scene with its device motion, how many frames, what to check.
struct Case {
    name: String,
    scene: Scene,
    frames: usize,
    checks: Checks,
}

/// One engine's frames: times (s), tool poses, hand wrenches, frame times, contacts.
#[derive(Default)]
struct Track {
    t: Vec<f64>,
    q_tool: Vec<[f64; 6]>,
    wrench: Vec<[f64; 6]>,
    step_us: Vec<f64>,
    contacts: Vec<f64>,
}

impl Track {
    /// Records one frame: time (s), tool pose (mm, rad), wrench (N, N·mm), step time (µs),
    /// contact count.
    fn push(&mut self, t: f64, q_tool: [f64; 6], wrench: [f64; 6], step_us: f64, contacts: u32) {
        self.t.push(t);
        self.q_tool.push(q_tool);
        self.wrench.push(wrench);
        self.step_us.push(step_us);
        self.contacts.push(f64::from(contacts));
    }
}

fn ours(scene: &Scene, frames: usize) -> Result<Track> {
    let traj = scene.trajectory();
    let mut params = scene.engine_config();
    params.solver = SolverKind::Dual;
    let mut god = GodObject::new(&scene.tool, &scene.objects, params)?;
    let first = traj.samples.first().map(|s| Pose::from_array(s.q));
    god.reset(&first.unwrap_or_default())?;
    let mut track = Track::default();
    for s in traj.samples.iter().take(frames) {
        let out = god.step(&Pose::from_array(s.q));
        track.push(s.t, out.q_g, out.wrench, out.total_us, out.pairs);
    }
    Ok(track)
}

/// MuJoCo's environment in the cache folder, checked by importing MuJoCo in it; with `install`,
/// made first when it does not run (the network is needed once).
pub fn mujoco_env(cache: &TreeCache, install: bool) -> Result<MujocoEnv> {
    let dir = cache
        .dir()
        .context("no cache folder for MuJoCo's environment (set HAPTIC6D_CACHE)")?;
    let env = MujocoEnv::in_cache(dir);
    match env.probe() {
        Ok(_) => Ok(env),
        Err(why) if install => {
            eprintln!(
                "bench: installing MuJoCo {} into {} ({why})",
                peer::mujoco::MUJOCO_VERSION,
                env.venv.display()
            );
            env.install()?;
            env.probe()
                .map_err(|e| anyhow::anyhow!("MuJoCo's environment does not run: {e}"))?;
            Ok(env)
        }
        Err(why) => bail!("{why} (`haptic6d bench --peer-setup` installs it)"),
    }
}

/// The scene's meshes as the peer's shapes: the tool as its convex hull when it is convex
/// (puck, ball) or decomposed into convex parts (bunny, spline shaft), the objects as fixed
/// triangle meshes with fixed internal edges.
fn peer_scene(scene: &Scene) -> Result<PeerScene> {
    let (tool, objects) = meshes(scene)?;
    Ok(PeerScene::new(
        tool,
        &objects,
        ToolShape::HullIfConvex {
            resolution: TOOL_DECOMPOSITION_RESOLUTION,
        },
        ObjectShape::TriMesh {
            fix_internal_edges: true,
        },
    )?)
}

fn meshes(scene: &Scene) -> Result<(&TriMesh, Vec<(&TriMesh, Pose)>)> {
    let tool = scene
        .tool_mesh
        .as_ref()
        .with_context(|| format!("{}: the peer needs the tool mesh", scene.name))?;
    let objects = scene
        .object_meshes
        .iter()
        .zip(&scene.objects)
        .map(|(m, (_, pose))| {
            m.as_ref()
                .map(|m| (m, *pose))
                .with_context(|| format!("{}: the peer needs every object mesh", scene.name))
        })
        .collect::<Result<Vec<_>>>()?;
    Ok((tool, objects))
}

/// The peer's parameters for `scene`: the tuned ones with the scene's coupling and rate.
pub fn peer_params(scene: &Scene) -> PeerParams {
    PeerParams {
        kt_n_per_mm: scene.coupling.kt,
        kr_nmm_per_rad: scene.coupling.kr,
        rate_hz: scene.rate_hz,
        ..PeerParams::tuned()
    }
}

/// MuJoCo's pieces of a scene: the tool's as rapier's collider (its hull or its VHACD parts),
/// each object as its hull when convex, else its VHACD parts (MuJoCo collides a mesh geom as
/// its convex hull), with the objects' poses.
type MujocoPieces = (Vec<TriMesh>, Vec<(Vec<TriMesh>, Pose)>);

fn mujoco_pieces(scene: &Scene, shapes: &PeerScene) -> Result<MujocoPieces> {
    let (_, objects) = meshes(scene)?;
    let mut out = Vec::new();
    for (i, (mesh, pose)) in objects.iter().enumerate() {
        let pieces = convex_pieces(
            mesh,
            OBJECT_DECOMPOSITION_RESOLUTION,
            &format!("object {i}"),
        )
        .with_context(|| format!("{}: object {i}", scene.name))?;
        out.push((pieces, *pose));
    }
    Ok((shapes.tool_pieces(), out))
}

/// The tracks of MuJoCo runs of `scene` (one per option set) on its first `frames` frames,
/// the case written into a temporary folder.
fn mujoco_tracks(
    scene: &Scene,
    pieces: &MujocoPieces,
    coupling: PeerParams,
    frames: usize,
    env: &MujocoEnv,
    runs: &[MujocoOptions],
) -> Result<Vec<Track>> {
    let traj = scene.trajectory();
    let samples: Vec<_> = traj.samples.iter().take(frames).collect();
    let hand: Vec<Pose> = samples.iter().map(|s| Pose::from_array(s.q)).collect();
    let dir = tempfile::Builder::new()
        .prefix("haptic6d-mujoco-")
        .tempdir()
        .context("a temporary folder for the MuJoCo case")?;
    let case = MujocoCase {
        tool: &pieces.0,
        objects: &pieces.1,
        hand: &hand,
        coupling,
    };
    let results = case
        .run(env, dir.path(), runs)
        .with_context(|| format!("{}: MuJoCo peer", scene.name))?;
    Ok(results
        .into_iter()
        .map(|frames| track_of(samples.iter().map(|s| s.t), &frames))
        .collect())
}

fn track_of(times: impl Iterator<Item = f64>, frames: &[PeerFrame]) -> Track {
    let mut track = Track::default();
    for (t, out) in times.zip(frames) {
        track.push(t, out.q_tool, out.wrench, out.step_us, out.contacts);
    }
    track
}

fn theirs(scene: &Scene, shapes: &PeerScene, params: PeerParams, frames: usize) -> Result<Track> {
    let traj = scene.trajectory();
    let first = traj.samples.first().map(|s| Pose::from_array(s.q));
    let mut tool = PeerTool::new(shapes, params, &first.unwrap_or_default())?;
    let mut track = Track::default();
    for s in traj.samples.iter().take(frames) {
        let out = tool.step(&Pose::from_array(s.q));
        track.push(s.t, out.q_tool, out.wrench, out.step_us, out.contacts);
    }
    Ok(track)
}

fn in_windows(t: f64, windows: &[(f64, f64)]) -> Option<usize> {
    windows.iter().position(|&(a, b)| t >= a && t < b)
}

fn force_step(a: &[f64; 6], b: &[f64; 6]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// The measures of one engine's track on a case.
fn measure(
    case: &str,
    c: &Checks,
    engine: &str,
    track: &Track,
    depth: &MeshPenetration,
) -> (PeerRow, Vec<f64>) {
    // A run that blew up (MuJoCo's state went non-finite) is infinitely deep from then on.
    let finite = |q: &[f64; 6]| q.iter().all(|x| x.is_finite());
    let blew_up = !track.q_tool.iter().all(finite);
    let penetration: Vec<f64> = track
        .q_tool
        .iter()
        .map(|q| {
            if finite(q) {
                depth.depth_mm(&Pose::from_array(*q))
            } else {
                f64::INFINITY
            }
        })
        .collect();
    let jitter = (!c.steady.is_empty()).then(|| {
        if blew_up {
            return f64::INFINITY;
        }
        let steps = (1..track.t.len())
            .filter(|&k| {
                in_windows(track.t[k], &c.steady).is_some()
                    && in_windows(track.t[k - 1], &c.steady).is_some()
            })
            .map(|k| force_step(&track.wrench[k], &track.wrench[k - 1]));
        Summary::of(steps).p99
    });
    let drag = c.slide.as_ref().map(|(windows, dirs)| {
        let along = track
            .t
            .iter()
            .zip(&track.wrench)
            .filter_map(|(&t, w)| in_windows(t, windows).map(|i| -w[0] * dirs[i]));
        Summary::of(along).mean
    });
    let insertion = c.goal.map(
        |Goal::InsertZ {
             target_z_mm,
             tol_mm,
         }| {
            let reached = track
                .q_tool
                .iter()
                .map(|q| q[2])
                .fold(f64::INFINITY, f64::min);
            (reached, reached <= target_z_mm + tol_mm)
        },
    );
    let tunnelling = c.tunnel.map(|(centre, underside)| {
        let mut events = 0;
        let mut through = false;
        for q in &track.q_tool {
            let below = Pose::from_array(*q).transform_point(&centre)[2] < underside;
            events += usize::from(below && !through);
            through = below;
        }
        events
    });
    let row = PeerRow {
        case: case.into(),
        engine: engine.into(),
        frames: track.t.len(),
        step_us: Summary::of(track.step_us.iter().copied()),
        contacts: Summary::of(track.contacts.iter().copied()),
        penetration_mm: Summary::of(penetration.iter().copied()),
        tunnelling_events: tunnelling,
        drag_n: drag,
        jitter_p99_n: jitter,
        insertion,
    };
    (row, penetration)
}

/// Per-frame series of one case for the plots: per engine, time (s), mesh penetration (mm)
/// and the force on the hand (N).
pub struct PeerTrace {
    /// The case.
    pub case: String,
    /// `(engine, its frames)`.
    pub engines: Vec<(String, Vec<TracePoint>)>,
}

fn trace_of(track: &Track, penetration: &[f64]) -> Vec<TracePoint> {
    track
        .t
        .iter()
        .zip(penetration)
        .zip(&track.wrench)
        .map(|((&t, &p), w)| (t, p, (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt()))
        .collect()
}

/// The thin plate (world frame, top face at `z = 0`), mm.
fn thin_plate_mesh() -> TriMesh {
    plate::box_mesh([-40.0, -40.0, -THIN_PLATE_MM], [40.0, 40.0, 0.0])
}

/// The ball pushed onto the thin plate at `speed` (mm/s): from 10 mm above, down to `push` mm
/// below the top face at constant speed, held 0.2 s, back up.
fn thin_plate_case(cache: &TreeCache, speed: f64, push: f64) -> Result<Case> {
    let mut scene = plate::scene(
        cache,
        PlateTool::Ball,
        Script::starting_at([0.0; 6]).hold(0.1),
    )?;
    let mesh = thin_plate_mesh();
    let mut log = Vec::new();
    let tree = scene::tree_for_mesh(
        &mesh,
        TreeParams {
            depth: 4,
            branching: 8,
            method: spheretree::build::BuildMethod::Tight,
        },
        cache,
        "thin plate",
        &mut log,
    )?;
    let above = [0.0, 0.0, 10.0, 0.0, 0.0, 0.0];
    let below = [0.0, 0.0, -push, 0.0, 0.0, 0.0];
    let script = Script::starting_at(above)
        .hold(0.05)
        .then((10.0 + push) / speed, below, Ease::Linear)
        .hold(0.2)
        .then(0.3, above, Ease::Smooth);
    scene.name = format!("thin plate (ball, {speed} mm/s, {push} mm)");
    scene.objects = vec![(tree, Pose::identity())];
    scene.object_meshes = vec![Some(mesh)];
    scene.start = Pose::from_array(above);
    scene.motion = Motion::Script(script);
    scene.load_log.extend(log);
    let r = plate::BALL_RADIUS_MM;
    Ok(Case {
        name: format!("thin plate, ball at {speed} mm/s, hand {push} mm below"),
        scene,
        frames: usize::MAX,
        checks: Checks {
            tunnel: Some(([0.0, 0.0, r], -THIN_PLATE_MM)),
            ..Checks::default()
        },
    })
}

fn plate_case(cache: &TreeCache, tool: PlateTool, speed: f64, quick: bool) -> Result<Case> {
    let run = plate::speed_script(
        tool,
        SpeedMotion::Slide(speed),
        1000.0,
        if quick { 0.15 } else { 0.5 },
    );
    let scene = plate::scene(cache, tool, run.script.clone())?;
    Ok(Case {
        name: format!("plate, {} slid at {speed} mm/s", tool.name()),
        scene,
        frames: usize::MAX,
        checks: Checks {
            steady: run.steady.clone(),
            slide: Some((run.steady, run.direction)),
            ..Checks::default()
        },
    })
}

fn cases(cache: &TreeCache, quick: bool) -> Result<Vec<Case>> {
    let mut out = Vec::new();
    let bunny = scene::scenes::builtin("bunny", cache)?;
    let (slide, push) = (
        scene::scenes::bunny::SLIDE_PHASE_S,
        scene::scenes::bunny::PUSH_PHASE_S,
    );
    out.push(Case {
        name: "bunny".into(),
        scene: bunny,
        frames: if quick {
            QUICK_BUNNY_FRAMES
        } else {
            usize::MAX
        },
        checks: Checks {
            steady: vec![slide, push],
            ..Checks::default()
        },
    });
    let spline = scene::scenes::builtin("spline", cache)?;
    let goal = spline.goal;
    // The script's phases (scene::scenes::spline_scene): on the face 0.5-0.7 s, turning
    // 0.7-1.9 s, resting 1.9-2.1 s.
    out.push(Case {
        name: "spline".into(),
        scene: spline,
        frames: usize::MAX,
        checks: Checks {
            steady: vec![(0.55, 2.1)],
            goal,
            ..Checks::default()
        },
    });
    let slides: &[(PlateTool, f64)] = if quick {
        &[(PlateTool::Puck, 200.0), (PlateTool::Ball, 1000.0)]
    } else {
        &[
            (PlateTool::Puck, 200.0),
            (PlateTool::Puck, 1000.0),
            (PlateTool::Ball, 200.0),
            (PlateTool::Ball, 1000.0),
        ]
    };
    for &(tool, speed) in slides {
        out.push(plate_case(cache, tool, speed, quick)?);
    }
    let [firm, through] = THIN_PUSH_MM;
    let pushes: &[(f64, f64)] = if quick {
        &[(2000.0, firm), (100.0, through)]
    } else {
        &[
            (100.0, firm),
            (2000.0, firm),
            (100.0, through),
            (2000.0, through),
        ]
    };
    for &(speed, push) in pushes {
        out.push(thin_plate_case(cache, speed, push)?);
    }
    Ok(out)
}

/// Runs the study: every case with haptic6d (dual) and each of `engines` (shorter runs with
/// `quick`; `mujoco` is the environment MuJoCo runs in, needed when `engines` holds it): the
/// rows and, per case, the series for the plots.
pub fn peer_study(
    cache: &TreeCache,
    quick: bool,
    engines: &[PeerEngine],
    mujoco: Option<&MujocoEnv>,
) -> Result<(Vec<PeerRow>, Vec<PeerTrace>)> {
    let mut rows = Vec::new();
    let mut traces = Vec::new();
    for case in cases(cache, quick)? {
        let t0 = Instant::now();
        let (tool, objects) = meshes(&case.scene)?;
        let depth = MeshPenetration::new(tool, &objects, PENETRATION_SAMPLES);
        let shapes = peer_scene(&case.scene)?;
        let setup = t0.elapsed().as_secs_f64();
        let a = ours(&case.scene, case.frames)?;
        let (ours_row, ours_pen) = measure(&case.name, &case.checks, "haptic6d", &a, &depth);
        rows.push(ours_row);
        let mut engines_traces = vec![("haptic6d".to_string(), trace_of(&a, &ours_pen))];
        for &engine in engines {
            let track = match engine {
                PeerEngine::Rapier => {
                    theirs(&case.scene, &shapes, peer_params(&case.scene), case.frames)?
                }
                PeerEngine::Mujoco => {
                    let env = mujoco.context("the MuJoCo peer needs its Python environment")?;
                    let pieces = mujoco_pieces(&case.scene, &shapes)?;
                    let coupling = peer_params(&case.scene);
                    let mut tracks = mujoco_tracks(
                        &case.scene,
                        &pieces,
                        coupling,
                        case.frames,
                        env,
                        &[MujocoOptions::tuned()],
                    )?;
                    tracks.pop().context("MuJoCo returned no run")?
                }
            };
            if a.t.len() != track.t.len() {
                bail!(
                    "{}: the replays of haptic6d and {} differ in length",
                    case.name,
                    engine.name()
                );
            }
            let (row, pen) = measure(&case.name, &case.checks, engine.name(), &track, &depth);
            rows.push(row);
            engines_traces.push((engine.name().to_string(), trace_of(&track, &pen)));
        }
        traces.push(PeerTrace {
            case: case.name.clone(),
            engines: engines_traces,
        });
        eprintln!(
            "bench: peer: {}: {} frames, {} convex parts, {:.1} s (setup {setup:.1} s)",
            case.name,
            a.t.len(),
            shapes.tool_parts,
            t0.elapsed().as_secs_f64()
        );
    }
    Ok((rows, traces))
}

/// One point of the peer's tuning search: its parameters and its rows on the tuning cases.
#[derive(Serialize, Clone, Debug)]
pub struct TuneRow {
    /// 1: the grid over mass, contact frequency and length unit; 2: damping, iterations and
    /// CCD around the best of stage 1.
    pub stage: u32,
    /// Tool mass, kg.
    pub mass_kg: f64,
    /// Coupling damping ratio.
    pub damping_ratio: f64,
    /// Rapier's length unit (m).
    pub length_unit: f64,
    /// Rapier's contact natural frequency, Hz.
    pub contact_hz: f64,
    /// Rapier's solver iterations.
    pub solver_iterations: usize,
    /// CCD on the tool body.
    pub ccd: bool,
    /// The peer's rows on the tuning cases.
    pub rows: Vec<PeerRow>,
}

/// The score of a point of a tuning search, from its rows on the tuning cases.
pub trait TuneScore {
    /// The rows of the point on the tuning cases.
    fn tune_rows(&self) -> &[PeerRow];

    /// Deepest mesh penetration over the cases, mm (infinite when a run blew up).
    fn worst_penetration_mm(&self) -> f64 {
        self.tune_rows()
            .iter()
            .map(|r| r.penetration_mm.max)
            .fold(0.0, f64::max)
    }

    /// Largest force jitter over the cases, N (infinite when a run blew up).
    fn worst_jitter_n(&self) -> f64 {
        self.tune_rows()
            .iter()
            .filter_map(|r| r.jitter_p99_n)
            .map(|j| if j.is_finite() { j } else { f64::INFINITY })
            .fold(0.0, f64::max)
    }

    /// Whether the spline insertion succeeded.
    fn inserted(&self) -> bool {
        self.tune_rows()
            .iter()
            .any(|r| r.insertion.is_some_and(|(_, ok)| ok))
    }

    /// Tunnelling events over the cases.
    fn tunnels(&self) -> usize {
        self.tune_rows()
            .iter()
            .filter_map(|r| r.tunnelling_events)
            .sum()
    }

    /// Task failures: the spline not inserted, plus tunnelling events.
    fn failures(&self) -> usize {
        usize::from(!self.inserted()) + self.tunnels()
    }

    /// Whether the point holds the tool off the surface by design (a contact margin): its
    /// penetration then says nothing of the gap it leaves, which no measure here sees.
    fn standoff(&self) -> bool {
        false
    }

    /// The order of preference: a stable run (jitter below [`TUNE_JITTER_LIMIT_N`]) first,
    /// then no standoff, then fewer task failures, then the shallower worst penetration.
    fn rank(&self) -> (bool, bool, usize, f64) {
        (
            self.worst_jitter_n() > TUNE_JITTER_LIMIT_N,
            self.standoff(),
            self.failures(),
            self.worst_penetration_mm(),
        )
    }
}

impl TuneScore for TuneRow {
    fn tune_rows(&self) -> &[PeerRow] {
        &self.rows
    }
}

/// A tuning point whose force jitter (p99 of |ΔF| per frame in steady contact) exceeds this on
/// some case is unstable for a user's hand, N (haptic6d's own is below 0.6 N on every case).
pub const TUNE_JITTER_LIMIT_N: f64 = 1.0;

/// The cases of both tuning searches: the bunny (first 1500 frames), the spline, the ball slid
/// at 1000 mm/s and the thin plate (2000 mm/s to 10 mm below, 100 mm/s to 40 mm below).
fn tune_cases(cache: &TreeCache) -> Result<Vec<Case>> {
    let spline = scene::scenes::builtin("spline", cache)?;
    let goal = spline.goal;
    let bunny = scene::scenes::builtin("bunny", cache)?;
    Ok(vec![
        Case {
            name: "bunny".into(),
            scene: bunny,
            frames: QUICK_BUNNY_FRAMES,
            checks: Checks {
                steady: vec![scene::scenes::bunny::SLIDE_PHASE_S],
                ..Checks::default()
            },
        },
        Case {
            name: "spline".into(),
            scene: spline,
            frames: usize::MAX,
            checks: Checks {
                steady: vec![(0.55, 2.1)],
                goal,
                ..Checks::default()
            },
        },
        plate_case(cache, PlateTool::Ball, 1000.0, true)?,
        thin_plate_case(cache, 2000.0, THIN_PUSH_MM[0])?,
        thin_plate_case(cache, 100.0, THIN_PUSH_MM[1])?,
    ])
}

/// The tuning search of the peer (`haptic6d bench --peer-tune`): the peer alone on the bunny
/// (first 1500 frames), the spline, the ball slid at 1000 mm/s and the thin plate (2000 mm/s
/// to 10 mm below, 100 mm/s to 40 mm below); stage 1 is a grid over mass × contact frequency × length unit (damping ratio 1,
/// 4 iterations), stage 2 varies damping, iterations and CCD around stage 1's best.
pub fn peer_tune(cache: &TreeCache) -> Result<Vec<TuneRow>> {
    let cases = tune_cases(cache)?;
    let mut prepared = Vec::new();
    for case in &cases {
        let (tool, objects) = meshes(&case.scene)?;
        let depth = MeshPenetration::new(tool, &objects, PENETRATION_SAMPLES);
        prepared.push((peer_scene(&case.scene)?, depth));
    }
    let run = |stage: u32, p: PeerParams| -> Result<TuneRow> {
        let t0 = Instant::now();
        let mut rows = Vec::new();
        for (case, (shapes, depth)) in cases.iter().zip(&prepared) {
            let params = PeerParams {
                kt_n_per_mm: case.scene.coupling.kt,
                kr_nmm_per_rad: case.scene.coupling.kr,
                rate_hz: case.scene.rate_hz,
                ..p
            };
            let track = theirs(&case.scene, shapes, params, case.frames)?;
            rows.push(measure(&case.name, &case.checks, "rapier", &track, depth).0);
        }
        let row = TuneRow {
            stage,
            mass_kg: p.mass_kg,
            damping_ratio: p.damping_ratio,
            length_unit: p.length_unit,
            contact_hz: p.contact_natural_frequency_hz,
            solver_iterations: p.solver_iterations,
            ccd: p.ccd,
            rows,
        };
        eprintln!(
            "bench: peer tune: mass {} kg, zeta {}, length unit {}, contact {} Hz, {} iterations, ccd {}: worst pen. {:.3} mm, jitter {:.3} N, inserted {}, tunnels {} ({:.1} s)",
            p.mass_kg,
            p.damping_ratio,
            p.length_unit,
            p.contact_natural_frequency_hz,
            p.solver_iterations,
            p.ccd,
            row.worst_penetration_mm(),
            row.worst_jitter_n(),
            row.inserted(),
            row.tunnels(),
            t0.elapsed().as_secs_f64()
        );
        Ok(row)
    };
    let mut out = Vec::new();
    let base = PeerParams {
        damping_ratio: 1.0,
        solver_iterations: 4,
        ccd: false,
        ..PeerParams::tuned()
    };
    for mass_kg in [0.01, 0.05, 0.2] {
        for contact_natural_frequency_hz in [30.0, 100.0, 300.0] {
            for length_unit in [1.0, 0.1, 0.01] {
                out.push(run(
                    1,
                    PeerParams {
                        mass_kg,
                        contact_natural_frequency_hz,
                        length_unit,
                        ..base
                    },
                )?);
            }
        }
    }
    let best = out
        .iter()
        .min_by(|a, b| {
            a.rank()
                .partial_cmp(&b.rank())
                .unwrap_or(std::cmp::Ordering::Equal)
        })
        .map(|r| PeerParams {
            mass_kg: r.mass_kg,
            contact_natural_frequency_hz: r.contact_hz,
            length_unit: r.length_unit,
            ..base
        })
        .unwrap_or(base);
    for damping_ratio in [0.3, 0.5, 2.0] {
        out.push(run(
            2,
            PeerParams {
                damping_ratio,
                ..best
            },
        )?);
    }
    for solver_iterations in [8, 16] {
        out.push(run(
            2,
            PeerParams {
                solver_iterations,
                ..best
            },
        )?);
    }
    out.push(run(2, PeerParams { ccd: true, ..best })?);
    Ok(out)
}

/// Writes a tuning table's header: the `columns`, then one "pen. mm / step µs p50" column per
/// case of `cases` (the first point's rows), and the separator line.
fn tune_header(s: &mut String, columns: &[&str], cases: &[PeerRow]) {
    use std::fmt::Write as _;
    let _ = write!(s, "|");
    for c in columns {
        let _ = write!(s, " {c} |");
    }
    for c in cases {
        let _ = write!(s, " {}: pen. mm / step µs p50 |", c.case);
    }
    let _ = writeln!(s);
    let _ = writeln!(s, "|{}", "---|".repeat(columns.len() + cases.len()));
}

/// One point of MuJoCo's tuning search: its options and its rows on the tuning cases.
#[derive(Serialize, Clone, Debug)]
pub struct MujocoTuneRow {
    /// 1: the grid over substeps, `solref` time constant, `solimp` and `multiccd`; 2: solver, iterations,
    /// damping ratio, margin, integrator, cone and noslip around the best of stage 1.
    pub stage: u32,
    /// MuJoCo's options.
    pub options: MujocoOptions,
    /// MuJoCo's rows on the tuning cases.
    pub rows: Vec<PeerRow>,
}

impl TuneScore for MujocoTuneRow {
    fn tune_rows(&self) -> &[PeerRow] {
        &self.rows
    }

    fn standoff(&self) -> bool {
        self.options.margin_m > 0.0
    }
}

/// `solimp` with a narrow transition (0.1 mm) to a stiffer impedance (0.95 … 0.99).
const SOLIMP_STIFF: [f64; 5] = [0.95, 0.99, 0.0001, 0.5, 2.0];

/// MuJoCo's tuning search (`haptic6d bench --peer-tune mujoco`) on the cases of
/// [`peer_tune`], the coupling as rapier's ([`PeerParams::tuned`]: the same mass and damping):
/// stage 1 is a grid over substeps per frame (1, 2, 4, 8) × `solref` time constant (MuJoCo's
/// 20 ms, 5 ms, and twice the timestep, the stiffest MuJoCo accepts) × `solimp` (MuJoCo's
/// default, [`SOLIMP_STIFF`]), frictionless (condim 1); stage 2 varies, around stage 1's best,
/// the solver (CG, PGS), the iterations (10), the `solref` damping ratio (0.5, 2), a 0.5 mm
/// margin, the implicitfast integrator, and friction's settings (condim 3 with the least
/// friction MuJoCo keeps, pyramidal and elliptic cones, 10 noslip iterations).
pub fn peer_tune_mujoco(cache: &TreeCache, env: &MujocoEnv) -> Result<Vec<MujocoTuneRow>> {
    let cases = tune_cases(cache)?;
    let mut points: Vec<(u32, MujocoOptions)> = Vec::new();
    let base = MujocoOptions::defaults();
    for substeps in [1, 4, 8] {
        let dt = 1e-3 / f64::from(substeps);
        for timeconst in [0.02, 0.005, 2.0 * dt] {
            for solimp in [base.solimp, SOLIMP_STIFF] {
                for multiccd in [false, true] {
                    points.push((
                        1,
                        MujocoOptions {
                            substeps,
                            solref: [timeconst, 1.0],
                            solimp,
                            multiccd,
                            ..base
                        },
                    ));
                }
            }
        }
    }
    let mut out = run_mujoco_points(&cases, env, &points)?;
    let best = out
        .iter()
        .min_by(|a, b| {
            a.rank()
                .partial_cmp(&b.rank())
                .unwrap_or(std::cmp::Ordering::Equal)
        })
        .map_or(base, |r| r.options);
    let stage2 = [
        MujocoOptions {
            solver: "CG",
            ..best
        },
        MujocoOptions {
            solver: "PGS",
            ..best
        },
        MujocoOptions {
            iterations: 10,
            ..best
        },
        MujocoOptions {
            solref: [best.solref[0], 0.5],
            ..best
        },
        MujocoOptions {
            solref: [best.solref[0], 2.0],
            ..best
        },
        MujocoOptions {
            margin_m: 0.0005,
            ..best
        },
        MujocoOptions {
            integrator: "implicitfast",
            ..best
        },
        MujocoOptions {
            condim: 3,
            friction: 1e-5,
            ..best
        },
        MujocoOptions {
            condim: 3,
            friction: 1e-5,
            cone: "elliptic",
            ..best
        },
        MujocoOptions {
            condim: 3,
            friction: 1e-5,
            noslip_iterations: 10,
            ..best
        },
    ];
    let points: Vec<(u32, MujocoOptions)> = stage2.into_iter().map(|o| (2, o)).collect();
    out.extend(run_mujoco_points(&cases, env, &points)?);
    Ok(out)
}

/// Every point of `points` on every case (one MuJoCo process per case, all points in it).
fn run_mujoco_points(
    cases: &[Case],
    env: &MujocoEnv,
    points: &[(u32, MujocoOptions)],
) -> Result<Vec<MujocoTuneRow>> {
    let options: Vec<MujocoOptions> = points.iter().map(|p| p.1).collect();
    let mut out: Vec<MujocoTuneRow> = points
        .iter()
        .map(|&(stage, options)| MujocoTuneRow {
            stage,
            options,
            rows: Vec::new(),
        })
        .collect();
    for case in cases {
        let t0 = Instant::now();
        let (tool, objects) = meshes(&case.scene)?;
        let depth = MeshPenetration::new(tool, &objects, PENETRATION_SAMPLES);
        let shapes = peer_scene(&case.scene)?;
        let pieces = mujoco_pieces(&case.scene, &shapes)?;
        let tracks = mujoco_tracks(
            &case.scene,
            &pieces,
            peer_params(&case.scene),
            case.frames,
            env,
            &options,
        )?;
        for (row, track) in out.iter_mut().zip(&tracks) {
            row.rows
                .push(measure(&case.name, &case.checks, "mujoco", track, &depth).0);
        }
        eprintln!(
            "bench: peer tune (MuJoCo): {}: {} points, {:.1} s",
            case.name,
            points.len(),
            t0.elapsed().as_secs_f64()
        );
    }
    Ok(out)
}

/// MuJoCo's tuning search as a markdown table, best first.
pub fn tune_mujoco_markdown(rows: &[MujocoTuneRow]) -> String {
    use std::fmt::Write as _;
    let mut sorted: Vec<&MujocoTuneRow> = rows.iter().collect();
    sorted.sort_by(|a, b| {
        a.rank()
            .partial_cmp(&b.rank())
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    let mut s = String::new();
    tune_header(
        &mut s,
        &[
            "stage",
            "substeps",
            "solref s, ratio",
            "solimp",
            "multiccd",
            "solver",
            "iterations",
            "integrator",
            "margin mm",
            "condim",
            "cone",
            "noslip",
            "worst pen. mm",
            "worst jitter N",
            "spline inserted",
            "tunnels",
        ],
        rows.first().map(|r| r.rows.as_slice()).unwrap_or_default(),
    );
    for r in sorted {
        let o = &r.options;
        let _ = write!(
            s,
            "| {} | {} | {}, {} | {:?} | {} | {} | {} | {} | {} | {} | {} | {} | {:.3} | {:.3} | {} | {} |",
            r.stage,
            o.substeps,
            o.solref[0],
            o.solref[1],
            o.solimp,
            if o.multiccd { "on" } else { "off" },
            o.solver,
            o.iterations,
            o.integrator,
            o.margin_m * 1e3,
            o.condim,
            o.cone,
            o.noslip_iterations,
            r.worst_penetration_mm(),
            r.worst_jitter_n(),
            if r.inserted() { "yes" } else { "no" },
            r.tunnels(),
        );
        for c in &r.rows {
            let _ = write!(s, " {:.3} / {:.0} |", c.penetration_mm.max, c.step_us.p50);
        }
        let _ = writeln!(s);
    }
    s
}

/// The tuning search as a markdown table, best first.
pub fn tune_markdown(rows: &[TuneRow]) -> String {
    use std::fmt::Write as _;
    let mut sorted: Vec<&TuneRow> = rows.iter().collect();
    sorted.sort_by(|a, b| {
        a.rank()
            .partial_cmp(&b.rank())
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    let mut s = String::new();
    tune_header(
        &mut s,
        &[
            "stage",
            "mass kg",
            "ζ",
            "length unit",
            "contact Hz",
            "iterations",
            "CCD",
            "worst pen. mm",
            "worst jitter N",
            "spline inserted",
            "tunnels",
        ],
        rows.first().map(|r| r.rows.as_slice()).unwrap_or_default(),
    );
    for r in sorted {
        let _ = write!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} | {:.3} | {:.3} | {} | {} |",
            r.stage,
            r.mass_kg,
            r.damping_ratio,
            r.length_unit,
            r.contact_hz,
            r.solver_iterations,
            if r.ccd { "on" } else { "off" },
            r.worst_penetration_mm(),
            r.worst_jitter_n(),
            if r.inserted() { "yes" } else { "no" },
            r.tunnels(),
        );
        for c in &r.rows {
            let _ = write!(s, " {:.3} / {:.0} |", c.penetration_mm.max, c.step_us.p50);
        }
        let _ = writeln!(s);
    }
    s
}

/// Writes `bench_peer_<case>.png` per case into `dir`: mesh penetration (top) and the force on
/// the hand (bottom) against time, every engine.
pub fn write_peer_plots(dir: &std::path::Path, traces: &[PeerTrace]) -> Result<()> {
    use crate::plot::{chart, register_font, render_png, Series};
    use plotters::prelude::*;
    register_font();
    let colors = [
        RGBColor(44, 160, 44),
        RGBColor(214, 39, 40),
        RGBColor(31, 119, 180),
    ];
    for trace in traces {
        let slug: String = trace
            .case
            .chars()
            .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
            .collect::<String>()
            .split('_')
            .filter(|w| !w.is_empty())
            .collect::<Vec<_>>()
            .join("_");
        let series = |pick: fn(&TracePoint) -> f64| -> Vec<Series<'_>> {
            trace
                .engines
                .iter()
                .zip(colors)
                .map(|((name, values), color)| Series {
                    label: name,
                    color,
                    values: values.iter().map(|v| (v.0, pick(v))).collect(),
                })
                .collect()
        };
        render_png(&dir.join(format!("bench_peer_{slug}.png")), 640, |root| {
            let (top, bottom) = root.split_vertically(320);
            chart(
                &top,
                &format!("{}: mesh penetration", trace.case),
                "time s",
                "mm",
                &series(|v| v.1),
            )?;
            chart(
                &bottom,
                &format!("{}: force on the hand", trace.case),
                "time s",
                "|F| N",
                &series(|v| v.2),
            )
        })?;
    }
    Ok(())
}

fn opt(v: Option<f64>, digits: usize) -> String {
    v.map_or_else(|| "–".into(), |x| format!("{x:.digits$}"))
}

/// The study as a markdown table.
pub fn peer_markdown(rows: &[PeerRow]) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "| case | engine | frames | step µs p50 / p99 / max | contacts p50 / max | mesh pen. mm p99 / max | tunnelling | drag N | jitter p99 N | insertion (deepest z mm) |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|---|");
    for r in rows {
        let insertion = r.insertion.map_or_else(
            || "–".into(),
            |(z, ok)| format!("{} ({z:.2})", if ok { "yes" } else { "no" }),
        );
        let _ = writeln!(
            s,
            "| {} | {} | {} | {:.1} / {:.1} / {:.1} | {:.0} / {:.0} | {:.4} / {:.4} | {} | {} | {} | {} |",
            r.case,
            r.engine,
            r.frames,
            r.step_us.p50,
            r.step_us.p99,
            r.step_us.max,
            r.contacts.p50,
            r.contacts.max,
            r.penetration_mm.p99,
            r.penetration_mm.max,
            r.tunnelling_events.map_or_else(|| "–".into(), |n| n.to_string()),
            opt(r.drag_n, 4),
            opt(r.jitter_p99_n, 4),
            insertion,
        );
    }
    s
}

/// The engines of `rows` in their order of appearance.
fn engines_of(rows: &[PeerRow]) -> Vec<&str> {
    let mut engines: Vec<&str> = Vec::new();
    for r in rows {
        if !engines.contains(&r.engine.as_str()) {
            engines.push(&r.engine);
        }
    }
    engines
}

/// Who did best on one measure: the engines whose score (lower is better) is the lowest, as
/// printed (`digits` decimals), or `tie` when all share it.
fn best_of(scores: &[(&str, Option<f64>)], digits: usize) -> String {
    let shown: Vec<(&str, f64)> = scores
        .iter()
        .filter_map(|&(e, v)| v.map(|v| (e, format!("{v:.digits$}").parse().unwrap_or(v))))
        .collect();
    let Some(best) = shown.iter().map(|s| s.1).min_by(|a, b| a.total_cmp(b)) else {
        return "–".into();
    };
    let winners: Vec<&str> = shown.iter().filter(|s| s.1 == best).map(|s| s.0).collect();
    if winners.len() == shown.len() && shown.len() > 1 {
        "tie".into()
    } else {
        winners.join(", ")
    }
}

/// The study as one table per measure row with a column per engine (haptic6d, rapier,
/// MuJoCo) and the engine that did best (lowest p99 frame time, shallowest deepest
/// penetration, fewest tunnellings, drag nearest zero, lowest jitter, insertion reached).
pub fn peer_columns_markdown(rows: &[PeerRow]) -> String {
    use std::fmt::Write as _;
    let engines = engines_of(rows);
    let mut s = String::new();
    let _ = writeln!(s, "| case | measure | {} | best |", engines.join(" | "));
    let _ = writeln!(s, "|---|---|{}---|", "---|".repeat(engines.len()));
    let mut cases: Vec<&str> = Vec::new();
    for r in rows {
        if !cases.contains(&r.case.as_str()) {
            cases.push(&r.case);
        }
    }
    for case in cases {
        let of: Vec<&PeerRow> = engines
            .iter()
            .filter_map(|e| rows.iter().find(|r| r.case == case && r.engine == *e))
            .collect();
        let mut line = |measure: &str, cell: &dyn Fn(&PeerRow) -> String, best: String| {
            let cells: Vec<String> = of.iter().map(|r| cell(r)).collect();
            let _ = writeln!(s, "| {case} | {measure} | {} | {best} |", cells.join(" | "));
        };
        let score = |f: &dyn Fn(&PeerRow) -> Option<f64>| -> Vec<(&str, Option<f64>)> {
            of.iter().map(|r| (r.engine.as_str(), f(r))).collect()
        };
        line(
            "frame µs p50 / p99 / max",
            &|r| {
                format!(
                    "{:.1} / {:.1} / {:.0}",
                    r.step_us.p50, r.step_us.p99, r.step_us.max
                )
            },
            best_of(&score(&|r| Some(r.step_us.p99)), 1),
        );
        line(
            "mesh pen. mm p99 / max",
            &|r| format!("{:.4} / {:.4}", r.penetration_mm.p99, r.penetration_mm.max),
            best_of(&score(&|r| Some(r.penetration_mm.max)), 4),
        );
        if of.iter().any(|r| r.tunnelling_events.is_some()) {
            line(
                "tunnelling",
                &|r| {
                    r.tunnelling_events
                        .map_or_else(|| "–".into(), |n| n.to_string())
                },
                best_of(&score(&|r| r.tunnelling_events.map(|n| n as f64)), 0),
            );
        }
        if of.iter().any(|r| r.drag_n.is_some()) {
            line(
                "drag N",
                &|r| opt(r.drag_n, 4),
                best_of(&score(&|r| r.drag_n.map(f64::abs)), 4),
            );
        }
        if of.iter().any(|r| r.jitter_p99_n.is_some()) {
            line(
                "jitter p99 N",
                &|r| opt(r.jitter_p99_n, 4),
                best_of(&score(&|r| r.jitter_p99_n), 4),
            );
        }
        if of.iter().any(|r| r.insertion.is_some()) {
            line(
                "inserted (deepest z mm)",
                &|r| {
                    r.insertion.map_or_else(
                        || "–".into(),
                        |(z, ok)| format!("{} ({z:.2})", if ok { "yes" } else { "no" }),
                    )
                },
                best_of(
                    &score(&|r| r.insertion.map(|(_, ok)| if ok { 0.0 } else { 1.0 })),
                    0,
                ),
            );
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thin_plate_is_thin_and_its_script_goes_through_it() {
        let m = thin_plate_mesh();
        let (lo, hi) = m.aabb().unwrap();
        assert!((hi[2] - lo[2] - THIN_PLATE_MM).abs() < 1e-12);
        let script = Script::starting_at([0.0, 0.0, 10.0, 0.0, 0.0, 0.0]).then(
            0.01,
            [0.0, 0.0, -THIN_PUSH_MM[0], 0.0, 0.0, 0.0],
            Ease::Linear,
        );
        assert!(script.sample(0.01)[2] < lo[2]);
    }

    /// The thin plate pressed through by a hand 40 mm below it: haptic6d's tool stays on top
    /// with no mesh penetration; the peer with rapier's default contact frequency (30 Hz) and a
    /// light tool goes through (a configuration of the tuning search), the tuned peer does not.
    #[test]
    fn thin_plate_holds_haptic6d_and_the_tuned_peer_but_a_soft_peer_tunnels() {
        let cache = TreeCache::disabled();
        let case = thin_plate_case(&cache, 100.0, THIN_PUSH_MM[1]).unwrap();
        let (tool, objects) = meshes(&case.scene).unwrap();
        let depth = MeshPenetration::new(tool, &objects, PENETRATION_SAMPLES);
        let shapes = peer_scene(&case.scene).unwrap();
        let run = |params: PeerParams| {
            let track = theirs(&case.scene, &shapes, params, case.frames).unwrap();
            measure(&case.name, &case.checks, "peer", &track, &depth).0
        };
        let ours_track = ours(&case.scene, case.frames).unwrap();
        let (ours_row, _) = measure(&case.name, &case.checks, "haptic6d", &ours_track, &depth);
        assert_eq!(ours_row.tunnelling_events, Some(0));
        assert!(ours_row.penetration_mm.max < 0.01, "{ours_row:?}");
        let tuned = run(peer_params(&case.scene));
        assert_eq!(tuned.tunnelling_events, Some(0), "{tuned:?}");
        assert!(tuned.penetration_mm.max > 0.0, "{tuned:?}");
        let soft = run(PeerParams {
            mass_kg: 0.01,
            length_unit: 0.1,
            solver_iterations: 4,
            contact_natural_frequency_hz: 30.0,
            ..peer_params(&case.scene)
        });
        assert_eq!(soft.tunnelling_events, Some(1), "{soft:?}");
    }

    /// MuJoCo's peer (where its environment is installed: `haptic6d bench --peer-setup`): the
    /// puck, free, follows the hand; pressed 1 mm into the plate it rests on it and the hand
    /// feels about kt × 1 mm; the case's files and the script's output go through the same
    /// path as the study's.
    #[test]
    fn mujoco_peer_follows_the_hand_and_rests_on_the_plate() {
        let env = match mujoco_env(&TreeCache::from_env(), false) {
            Ok(env) => env,
            Err(why) => {
                println!("MuJoCo peer test skipped: {why:#}");
                return;
            }
        };
        let plate = plate::box_mesh([-60.0, -60.0, -10.0], [60.0, 60.0, 0.0]);
        let puck = plate::box_mesh([-20.0, -20.0, 0.0], [20.0, 20.0, 10.0]);
        let objects = [(
            convex_pieces(&plate, OBJECT_DECOMPOSITION_RESOLUTION, "plate").unwrap(),
            Pose::identity(),
        )];
        let tool = convex_pieces(&puck, TOOL_DECOMPOSITION_RESOLUTION, "puck").unwrap();
        assert_eq!((tool.len(), objects[0].0.len()), (1, 1));
        let above = Pose::from_array([0.0, 0.0, 2.0, 0.0, 0.0, 0.0]);
        let free = Pose::from_array([5.0, -3.0, 20.0, 0.1, -0.05, 0.2]);
        let pressed = Pose::from_array([0.0, 0.0, -1.0, 0.0, 0.0, 0.0]);
        let mut hand = vec![above];
        hand.extend(std::iter::repeat_n(free, 1000));
        hand.extend(std::iter::repeat_n(pressed, 1000));
        let case = MujocoCase {
            tool: &tool,
            objects: &objects,
            hand: &hand,
            coupling: PeerParams::tuned(),
        };
        let dir = tempfile::tempdir().unwrap();
        let runs = case
            .run(&env, dir.path(), &[MujocoOptions::tuned()])
            .unwrap();
        let frames = &runs[0];
        assert_eq!(frames.len(), hand.len());
        let followed = &frames[1000];
        for k in 0..6 {
            assert!(
                (followed.q_tool[k] - free.q[k]).abs() < 1e-3,
                "axis {k}: {:?}",
                followed.q_tool
            );
        }
        assert_eq!(followed.contacts, 0);
        let rest = frames.last().unwrap();
        assert!(
            rest.q_tool[2] < 0.01 && rest.q_tool[2] > -0.2,
            "{:?}",
            rest.q_tool
        );
        assert!((rest.wrench[2] - 1.0).abs() < 0.2, "{:?}", rest.wrench);
        assert!(rest.contacts > 0);
        assert!(rest.step_us > 0.0);
    }

    #[test]
    fn measures_count_tunnelling_insertion_drag_and_jitter_from_the_track() {
        let checks = Checks {
            steady: vec![(0.0, 1.0)],
            slide: Some((vec![(0.0, 1.0)], vec![1.0])),
            goal: Some(Goal::InsertZ {
                target_z_mm: -5.0,
                tol_mm: 0.5,
            }),
            tunnel: Some(([0.0, 0.0, 1.0], -2.0)),
        };
        // z goes 0, -4, 0, -4.6: the centre (1 mm above the origin) dips below -2 twice.
        let zs = [0.0, -4.0, 0.0, -4.6];
        let track = Track {
            t: vec![0.0, 0.001, 0.002, 0.003],
            q_tool: zs.iter().map(|&z| [0.0, 0.0, z, 0.0, 0.0, 0.0]).collect(),
            wrench: [-1.0, -1.5, -1.0, -1.0]
                .iter()
                .map(|&fx| [fx, 0.0, 0.0, 0.0, 0.0, 0.0])
                .collect(),
            step_us: vec![1.0; 4],
            contacts: vec![0.0; 4],
        };
        let block = plate::box_mesh([-1.0, -1.0, -10.0], [1.0, 1.0, -9.0]);
        let depth = MeshPenetration::new(&block, &[(&block, Pose::identity())], 0);
        let (row, _) = measure("synthetic", &checks, "test", &track, &depth);
        assert_eq!(row.tunnelling_events, Some(2));
        assert_eq!(row.insertion, Some((-4.6, true)));
        assert!((row.drag_n.unwrap() - 1.125).abs() < 1e-12);
        assert!((row.jitter_p99_n.unwrap() - 0.5).abs() < 1e-12);
    }
}
