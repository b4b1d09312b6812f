//! The `plate` scene: a tool pressed onto a frictionless flat plate and slid or turned at a
//! ladder of hand speeds (the benchmark of how the step follows a fast hand).
//!
//! - The **plate** (world frame): a 120 × 120 × 10 mm box, top face at `z = 0`, centred on the
//!   `z` axis; tree depth 4 (the flat face is a layer of spheres a few mm apart: a bumpy
//!   surface, as every sphere-tree makes of a flat face).
//! - The **tools** (tool frame, their lowest point at the origin, so `z = 0` touches):
//!   [`PlateTool::Puck`], a 40 × 40 × 10 mm box, tree depth 4 (a flat-on-flat contact of
//!   hundreds of pairs), and [`PlateTool::Ball`], a 10 mm ball, tree depth 3.
//!
//! [`speed_script`] makes the device motion of one benchmark row: approach, press
//! [`PRESS_MM`] into the plate, then strokes at a constant speed (slide along `x`, or turn about
//! the vertical axis), reversing at the ends; [`SpeedRun::steady`] says which frames are at the
//! constant speed.

use collide::Pose;
use mesh::TriMesh;
use nalgebra::{Matrix3, Vector3};

use crate::cache::TreeCache;
use crate::trajectory::{Ease, Script};
use crate::SceneError;
use crate::{Coupling, Motion, Scene, SolverSpec, TreeParams};
use engine::safety::SafetyParams;

/// Plate size `(x, y, z)`, mm.
pub const PLATE_SIZE_MM: [f64; 3] = [120.0, 120.0, 10.0];

/// Puck size `(x, y, z)`, mm.
pub const PUCK_SIZE_MM: [f64; 3] = [40.0, 40.0, 10.0];

/// Ball radius, mm.
pub const BALL_RADIUS_MM: f64 = 5.0;

/// How far below the plate's top face the hand presses, mm (1 N at kt = 1 N/mm).
pub const PRESS_MM: f64 = 1.0;

/// Frames after each reversal that are not counted as constant speed (the hand's velocity
/// flips there).
pub const SETTLE_FRAMES: usize = 20;

/// The tool of the plate scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlateTool {
    /// A 40 × 40 × 10 mm box lying flat.
    Puck,
    /// The same box, its tree one level deeper (depth 5, leaves of about 0.3 mm): its face on
    /// the plate is a flat-on-flat contact of thousands of leaf pairs.
    DensePuck,
    /// A 10 mm ball.
    Ball,
}

impl PlateTool {
    /// The name used in tables: `puck`, `dense puck` or `ball`.
    pub fn name(&self) -> &'static str {
        match self {
            Self::Puck => "puck",
            Self::DensePuck => "dense puck",
            Self::Ball => "ball",
        }
    }

    /// Its tree depth: 4 for the puck, 3 for the ball (leaves of about 1 mm), 5 for the dense
    /// puck.
    pub fn depth(&self) -> u32 {
        match self {
            Self::Puck => 4,
            Self::DensePuck => 5,
            Self::Ball => 3,
        }
    }

    /// The tool mesh in its own frame (lowest point at the origin), mm.
    pub fn mesh(&self) -> TriMesh {
        match self {
            Self::Puck | Self::DensePuck => {
                let [sx, sy, sz] = PUCK_SIZE_MM;
                box_mesh([-sx / 2.0, -sy / 2.0, 0.0], [sx / 2.0, sy / 2.0, sz])
            }
            Self::Ball => ball_mesh([0.0, 0.0, BALL_RADIUS_MM], BALL_RADIUS_MM, 48),
        }
    }
}

/// The motion of one benchmark row.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SpeedMotion {
    /// Slide along `x` at this speed, mm/s.
    Slide(f64),
    /// Turn about the vertical axis at this rate, rad/s.
    Turn(f64),
}

/// A closed box mesh between the corners `lo` and `hi` (mm), outward-facing triangles.
pub fn box_mesh(lo: [f64; 3], hi: [f64; 3]) -> TriMesh {
    let mut mesh = TriMesh::default();
    for i in 0..8u32 {
        mesh.vertices.push([
            if i & 4 != 0 { hi[0] } else { lo[0] },
            if i & 2 != 0 { hi[1] } else { lo[1] },
            if i & 1 != 0 { hi[2] } else { lo[2] },
        ]);
    }
    // Corner index = 4 x + 2 y + z; each face as two triangles, counter-clockwise seen from
    // outside.
    let quads: [[u32; 4]; 6] = [
        [0, 1, 3, 2], // x = lo
        [4, 6, 7, 5], // x = hi
        [0, 4, 5, 1], // y = lo
        [2, 3, 7, 6], // y = hi
        [0, 2, 6, 4], // z = lo
        [1, 5, 7, 3], // z = hi
    ];
    for [a, b, c, d] in quads {
        mesh.triangles.push([a, b, c]);
        mesh.triangles.push([a, c, d]);
    }
    mesh
}

/// A closed latitude–longitude ball mesh of `radius` (mm) about `center`, `segments` around
/// (at least 8) and `segments / 2` rings from pole to pole.
pub fn ball_mesh(center: [f64; 3], radius: f64, segments: u32) -> TriMesh {
    use std::f64::consts::PI;
    let around = segments.max(8);
    let rings = around / 2;
    let mut mesh = TriMesh::default();
    let at = |theta: f64, phi: f64| {
        [
            center[0] + radius * theta.sin() * phi.cos(),
            center[1] + radius * theta.sin() * phi.sin(),
            center[2] + radius * theta.cos(),
        ]
    };
    mesh.vertices.push(at(0.0, 0.0));
    for j in 1..rings {
        let theta = PI * f64::from(j) / f64::from(rings);
        for i in 0..around {
            mesh.vertices
                .push(at(theta, 2.0 * PI * f64::from(i) / f64::from(around)));
        }
    }
    let south = mesh.vertices.len() as u32;
    mesh.vertices.push(at(PI, 0.0));
    let v = |j: u32, i: u32| 1 + (j - 1) * around + (i % around);
    for i in 0..around {
        mesh.triangles.push([0, v(1, i), v(1, i + 1)]);
        mesh.triangles
            .push([south, v(rings - 1, i + 1), v(rings - 1, i)]);
    }
    for j in 1..rings - 1 {
        for i in 0..around {
            mesh.triangles.push([v(j, i), v(j + 1, i), v(j + 1, i + 1)]);
            mesh.triangles.push([v(j, i), v(j + 1, i + 1), v(j, i + 1)]);
        }
    }
    mesh
}

/// The plate mesh in the world frame (top face at `z = 0`), mm.
pub fn plate_mesh() -> TriMesh {
    let [sx, sy, sz] = PLATE_SIZE_MM;
    box_mesh([-sx / 2.0, -sy / 2.0, -sz], [sx / 2.0, sy / 2.0, 0.0])
}

/// A device script for one row, and the frames at constant speed.
#[derive(Clone, Debug, PartialEq)]
pub struct SpeedRun {
    /// The device motion.
    pub script: Script,
    /// Time ranges `[t0, t1)` (s) where the hand moves at the row's constant speed, after
    /// [`SETTLE_FRAMES`] frames at each reversal.
    pub steady: Vec<(f64, f64)>,
    /// Unit direction of the hand's motion in each steady range: `+1` or `-1` along `x` (slide)
    /// or about `z` (turn).
    pub direction: Vec<f64>,
}

/// The device motion of one benchmark row at `rate_hz`: from 2 mm above the plate, press
/// [`PRESS_MM`] in (0.2 s) and rest (0.1 s), then strokes at constant speed — slides of
/// ±`35 - tool half-width / 2` mm about the centre, or turns of ±1 rad — for at least
/// `min_steady_s` of motion and at least two strokes.
pub fn speed_script(
    tool: PlateTool,
    motion: SpeedMotion,
    rate_hz: f64,
    min_steady_s: f64,
) -> SpeedRun {
    let start = [0.0, 0.0, 2.0, 0.0, 0.0, 0.0];
    let pressed = [0.0, 0.0, -PRESS_MM, 0.0, 0.0, 0.0];
    let mut script = Script::starting_at(start)
        .then(0.2, pressed, Ease::Smooth)
        .hold(0.1);
    let (axis, amplitude, speed) = match motion {
        SpeedMotion::Slide(v) => {
            let half = match tool {
                PlateTool::Puck | PlateTool::DensePuck => PUCK_SIZE_MM[0] / 2.0,
                PlateTool::Ball => BALL_RADIUS_MM,
            };
            (
                0usize,
                PLATE_SIZE_MM[0] / 2.0 - half - 5.0,
                v.abs().max(1e-3),
            )
        }
        SpeedMotion::Turn(w) => (5usize, 1.0, w.abs().max(1e-6)),
    };
    // Half a stroke out to +amplitude, then full strokes between the ends.
    let settle = SETTLE_FRAMES as f64 / rate_hz;
    let mut steady = Vec::new();
    let mut direction = Vec::new();
    let mut t = script.duration();
    let mut at = pressed;
    let mut target = amplitude;
    let mut moving = 0.0;
    let mut strokes = 0;
    while moving < min_steady_s || strokes < 3 {
        let dist = (target - at[axis]).abs();
        let dur = dist / speed;
        let mut next = at;
        next[axis] = target;
        script = script.then(dur, next, Ease::Linear);
        if strokes > 0 && dur > settle {
            steady.push((t + settle, t + dur));
            direction.push(target.signum());
            moving += dur - settle;
        }
        t += dur;
        at = next;
        target = -target;
        strokes += 1;
    }
    // Back to the centre and up.
    let mut centre = at;
    centre[axis] = 0.0;
    let script = script
        .then((at[axis].abs() / speed).max(0.01), centre, Ease::Linear)
        .then(0.2, start, Ease::Smooth);
    SpeedRun {
        script,
        steady,
        direction,
    }
}

/// The plate scene with `tool` and the device motion `script` (trees from `cache` or built).
pub fn scene(cache: &TreeCache, tool: PlateTool, script: Script) -> Result<Scene, SceneError> {
    let plate = plate_mesh();
    let tool_mesh = tool.mesh();
    let mut log = Vec::new();
    let plate_tree = crate::object_tree_for_mesh(
        &plate,
        TreeParams {
            depth: 4,
            branching: 8,
            method: spheretree::build::BuildMethod::Tight,
        },
        cache,
        "plate",
        &mut log,
    )?;
    let tool_tree = crate::tree_for_mesh(
        &tool_mesh,
        TreeParams {
            depth: tool.depth(),
            branching: 8,
            method: spheretree::build::BuildMethod::Tight,
        },
        cache,
        tool.name(),
        &mut log,
    )?;
    let start = Pose::from_array(script.sample(0.0));
    Ok(Scene {
        name: format!("plate ({})", tool.name()),
        tool: tool_tree,
        tool_mesh: Some(tool_mesh),
        objects: vec![(plate_tree, Pose::identity())],
        object_meshes: vec![Some(plate)],
        coupling: Coupling::default(),
        // The plate's faces are large rectangles: face caps make them planes (docs/DESIGN.md
        // §Face caps).
        solver: SolverSpec {
            face_caps: true,
            ..SolverSpec::default()
        },
        safety: SafetyParams::default(),
        start,
        rate_hz: 1000.0,
        motion: Motion::Script(script),
        goal: None,
        device: Default::default(),
        load_log: log,
        object_friction: Vec::new(),
        tool_friction: None,
    })
}

/// Radius (mm) of the one sphere that stands for an ideally flat plate: over the 120 mm plate
/// its surface departs from the plane `z = 0` by at most `60² / (2 · 1e5)` = 0.018 mm, and over
/// a 40 mm puck's footprint by 0.002 mm.
pub const FLAT_RADIUS_MM: f64 = 1.0e5;

/// An ideally flat plate: a one-sphere tree whose top touches `z = 0` at the origin (radius
/// [`FLAT_RADIUS_MM`]). A sphere-tree of a real plate makes its face a layer of spheres
/// (bumps a few millimetres apart); this one has none, so it measures a contact law (friction)
/// without the tree's bumps in the figures.
pub fn flat_plate_tree() -> Result<spheretree::SphereTree, SceneError> {
    let top = spheretree::Sphere::new([0.0, 0.0, -FLAT_RADIUS_MM], FLAT_RADIUS_MM);
    spheretree::SphereTree::from_slots(1, 8, vec![top])
        .map_err(|e| SceneError::caused("flat plate", "cannot make its tree", e))
}

/// [`scene`] with the ideally flat plate ([`flat_plate_tree`]) in place of the plate's tree
/// (the plate's mesh is still what the viewer draws).
pub fn flat_scene(cache: &TreeCache, tool: PlateTool, script: Script) -> Result<Scene, SceneError> {
    let mut scene = scene(cache, tool, script)?;
    scene.name = format!("flat plate ({})", tool.name());
    scene.objects[0].0 = flat_plate_tree()?;
    Ok(scene)
}

/// A push of the friction study: from rest, pressed [`PRESS_MM`] into the plate, the hand moves
/// once at a constant speed (`Slide`: 20 mm along `x`; `Turn`: 0.5 rad about the vertical
/// axis) and rests again. Returns the script and the time `[t0, t1)` (s) of the motion.
pub fn push_script(motion: SpeedMotion) -> (Script, (f64, f64)) {
    let start = [0.0, 0.0, 2.0, 0.0, 0.0, 0.0];
    let pressed = [0.0, 0.0, -PRESS_MM, 0.0, 0.0, 0.0];
    let script = Script::starting_at(start)
        .then(0.2, pressed, Ease::Smooth)
        .hold(0.1);
    let t0 = script.duration();
    let mut end = pressed;
    let duration = match motion {
        SpeedMotion::Slide(v) => {
            end[0] = 20.0;
            20.0 / v.abs().max(1e-3)
        }
        SpeedMotion::Turn(w) => {
            end[5] = 0.5;
            0.5 / w.abs().max(1e-6)
        }
    };
    let script = script.then(duration, end, Ease::Linear).hold(0.1);
    (script, (t0, t0 + duration))
}

/// The tilt of the tilted plate: 0.3 rad (17°) about the axis `(1, 2, 0)`, so neither the
/// plate's faces nor its edges run along a world axis, and a slide along the plate's own `x`
/// goes down its slope and across it.
pub fn plate_tilt() -> Matrix3<f64> {
    collide::rotation_exp(&(Vector3::new(1.0, 2.0, 0.0).normalize() * 0.3))
}

/// `script` carried by the rotation `tilt` about the world origin (the plate's top centre):
/// each pose's position is turned, and its orientation turned after its own. Sampled at
/// `rate_hz` into linear keyframes: Euler angles interpolated between the script's own far
/// keyframes would not keep a turn about the plate's normal a turn about the tilted normal.
pub fn tilted_script(script: &Script, tilt: &Matrix3<f64>, rate_hz: f64) -> Script {
    let carry = |q: [f64; 6]| {
        let pose = Pose::from_array(q);
        let turned = Pose::from_translation_rotation(
            &(tilt * pose.translation()),
            &(tilt * pose.rotation_matrix()),
        );
        turned.to_array()
    };
    let trajectory = script.to_trajectory(rate_hz);
    let mut samples = trajectory.samples.iter();
    let Some(first) = samples.next() else {
        return Script::default();
    };
    let mut out = Script::starting_at(carry(first.q));
    let mut last = (first.t, out.last_q());
    for s in samples {
        let mut q = carry(s.q);
        // Euler angles continuous with the last keyframe's: the conversion picks one of the
        // equivalent triples, and a jump of 2 pi between two keyframes is no motion.
        for k in 3..6 {
            let turns = ((q[k] - last.1[k]) / std::f64::consts::TAU).round();
            q[k] -= turns * std::f64::consts::TAU;
        }
        out = out.then(s.t - last.0, q, Ease::Linear);
        last = (s.t, q);
    }
    out
}

/// [`scene`] with the plate turned by `tilt` about the world origin and `script` (given as on
/// the level plate) carried with it ([`tilted_script`]): the same pushes on a plate whose faces
/// meet no world axis.
pub fn tilted_scene(
    cache: &TreeCache,
    tool: PlateTool,
    script: &Script,
    tilt: &Matrix3<f64>,
) -> Result<Scene, SceneError> {
    let rate_hz = 1000.0;
    let mut scene = scene(cache, tool, tilted_script(script, tilt, rate_hz))?;
    scene.name = format!("tilted plate ({})", tool.name());
    scene.objects[0].1 = Pose::from_translation_rotation(&Vector3::zeros(), tilt);
    scene.rate_hz = rate_hz;
    Ok(scene)
}

/// The built-in `plate` scene: the puck slid at 200 mm/s, then turned at 3 rad/s.
pub fn builtin(cache: &TreeCache) -> Result<Scene, SceneError> {
    let slide = speed_script(PlateTool::Puck, SpeedMotion::Slide(200.0), 1000.0, 0.5);
    let turn = speed_script(PlateTool::Puck, SpeedMotion::Turn(3.0), 1000.0, 0.5);
    // Slide, then the turn's keyframes after it (both start and end at the same rest pose).
    let mut script = slide.script;
    for w in turn.script.keys.windows(2) {
        script = script.then(w[1].t - w[0].t, w[1].q, w[1].ease);
    }
    scene(cache, PlateTool::Puck, script)
}
