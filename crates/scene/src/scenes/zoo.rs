//! The scene zoo: generated and real-mesh scenes beyond the built-ins, each with a scripted hand
//! that presses, slides, twists and withdraws. It is the measuring stick of the frame step: the
//! bench (`haptic6d bench --studies zoo`) reports frame times, degraded frames, drag and
//! penetration per scene, and the zoo test checks every scene with no deadline.
//!
//! Every scene is addressable by name (`zoo/slot`, ...: [`ZOO`]) wherever a built-in name is
//! (`haptic6d run zoo/slot`). Lengths are mm, angles rad, `+z` up except in the bunny scenes
//! (`+y` up, as the bundled bunny). Trees come from the tree cache with the builders the
//! built-ins use (tight, branching 8); solver settings are the defaults a scene file gets
//! (face caps off, 1 ms budget).
//!
//! The script of a stroke ([`ZooPhases`] holds its times): rest in free space, approach to
//! 0.5 mm short of the first contact (found on the trees, so the press depth is exact), press
//! past it and rest, slide out and back through the pressed pose, twist (rotation offsets of
//! the Euler angles) out and back, withdraw to the start and rest.

use collide::Pose;
use mesh::generate;
use mesh::TriMesh;
use spheretree::SphereTree;

use super::plate::{ball_mesh, box_mesh};
use super::spline_mesh::SplineParams;
use crate::cache::TreeCache;
use crate::trajectory::{Ease, Script};
use crate::SceneError;
use crate::{Coupling, Motion, Scene, SolverSpec, TreeParams};
use engine::safety::SafetyParams;

/// Every zoo scene: its name and what it exercises.
pub const ZOO: &[(&str, &str)] = &[
    (
        "zoo/sphere-on-sphere",
        "convex on convex: a 16 mm ball on a 50 mm ball, a single small contact",
    ),
    (
        "zoo/cube-corner",
        "a 20 mm cube pushed into the corner of a floor and two walls: three faces at once",
    ),
    (
        "zoo/cube-edge",
        "a 20 mm cube on one edge on a 120 mm plate: a line contact, rocked about the edge",
    ),
    (
        "zoo/thin-plate",
        "a 10 mm ball stabbed at 1 m/s at a 1 mm plate, the hand ending 8 mm below it: tunnelling",
    ),
    (
        "zoo/slot",
        "a 3 mm blade in a 6 mm slot (1.5 mm each side): both walls and the bottom at once, yaw jams",
    ),
    (
        "zoo/keyed-shaft",
        "a one-key shaft (16 mm) rests misaligned on its hub, turns until the key aligns, drops in (1 mm clearance) and twists against the keyway",
    ),
    (
        "zoo/gears",
        "two 12-tooth spur gears in mesh (1 mm tip clearance): teeth against teeth when twisted",
    ),
    (
        "zoo/sphere-field",
        "a 30 mm puck on a field of 36 small balls (36 objects): many objects in one contact",
    ),
    (
        "zoo/big-tool",
        "an 80 mm ball (the tool) on a 10 mm cube: a tool much larger than the object",
    ),
    (
        "zoo/probe-bumps",
        "a 40 mm long, 1.6 mm thick probe (dental-probe-like) dragged over a bumpy surface",
    ),
    (
        "zoo/torus-link",
        "a ring threaded through a ring (two chain links): non-convex with a hole on both sides",
    ),
    (
        "zoo/bracket",
        "a 6 mm peg in the inner corner of an L-shaped bracket: a line contact on two faces",
    ),
    (
        "zoo/bunny-probe",
        "a 6 mm ball probe on the Stanford bunny: a real scanned surface, a small contact",
    ),
    (
        "zoo/bunny-on-plate",
        "the Stanford bunny as the tool on a 120 mm plate: a real mesh tool, a wide contact",
    ),
];

/// Whether `name` is a zoo scene's name.
pub fn is_zoo(name: &str) -> bool {
    ZOO.iter().any(|(n, _)| *n == name)
}

/// The names of the zoo scenes, in [`ZOO`] order.
pub fn names() -> impl Iterator<Item = &'static str> {
    ZOO.iter().map(|(n, _)| *n)
}

/// When a zoo scene's script does what, s from the start of the script.
#[derive(Clone, Debug, PartialEq)]
pub struct ZooPhases {
    /// Times when the hand is far from every object (the tool must follow it exactly), s.
    pub free_s: Vec<(f64, f64)>,
    /// The rest right after the press: the hand past the first contact, so the tool must
    /// touch, s.
    pub pressed_s: (f64, f64),
    /// The slide out and back while pressed, s.
    pub slide_s: (f64, f64),
    /// The twist out and back while pressed, s.
    pub twist_s: (f64, f64),
    /// How far past the first contact the hand presses, mm.
    pub press_mm: f64,
    /// Objects the tool touches at once in the pressed rest (at least): three in the corner,
    /// several balls of the field, one elsewhere.
    pub touching_objects: usize,
}

/// A zoo scene and the times of its script's phases.
#[derive(Clone, Debug)]
pub struct ZooScene {
    /// The scene (its motion is the script).
    pub scene: Scene,
    /// The script's phases.
    pub phases: ZooPhases,
}

/// The zoo scene `name` (one of [`ZOO`]), trees from `cache` or built.
pub fn zoo_scene(name: &str, cache: &TreeCache) -> Result<ZooScene, SceneError> {
    let z = match name {
        "zoo/sphere-on-sphere" => sphere_on_sphere(cache),
        "zoo/cube-corner" => cube_corner(cache),
        "zoo/cube-edge" => cube_edge(cache),
        "zoo/thin-plate" => thin_plate(cache),
        "zoo/slot" => slot(cache),
        "zoo/keyed-shaft" => keyed_shaft(cache),
        "zoo/gears" => gears(cache),
        "zoo/sphere-field" => sphere_field(cache),
        "zoo/big-tool" => big_tool(cache),
        "zoo/probe-bumps" => probe_bumps(cache),
        "zoo/torus-link" => torus_link(cache),
        "zoo/bracket" => bracket(cache),
        "zoo/bunny-probe" => bunny_probe(cache),
        "zoo/bunny-on-plate" => bunny_on_plate(cache),
        _ => Err(SceneError::Unknown {
            what: "zoo scene",
            name: name.to_string(),
            expected: names().collect::<Vec<_>>().join(", "),
        }),
    }?;
    z.scene.validate()?;
    Ok(z)
}

/// Tree parameters of the built-ins' builder at `depth`.
fn tight(depth: u32) -> TreeParams {
    TreeParams {
        depth,
        branching: 8,
        method: spheretree::build::BuildMethod::Tight,
    }
}

/// An object of a scene being assembled: its mesh (object frame), tree depth and pose.
struct Part<'a> {
    mesh: &'a TriMesh,
    depth: u32,
    pose: Pose,
}

/// A tool tree from an object tree of the same mesh: the same spheres without the face caps
/// (one build serves both, as in the `bunny` scene).
fn without_caps(tree: &SphereTree, label: &str) -> Result<SphereTree, SceneError> {
    let mut t = tree.clone();
    t.set_caps(Vec::new())
        .map_err(|e| SceneError::caused(label, "cannot drop the tool's face caps", e))?;
    Ok(t)
}

/// A scene of `tool` (its tree given) and `parts`; objects sharing one mesh (the same
/// reference) and depth share one tree.
fn assemble(
    name: &str,
    tool_mesh: &TriMesh,
    tool: SphereTree,
    parts: &[Part<'_>],
    cache: &TreeCache,
    mut log: Vec<String>,
) -> Result<Scene, SceneError> {
    let mut built: Vec<(*const TriMesh, u32, SphereTree)> = Vec::new();
    let mut objects = Vec::with_capacity(parts.len());
    for (i, p) in parts.iter().enumerate() {
        let key = (p.mesh as *const TriMesh, p.depth);
        let tree = match built.iter().find(|b| (b.0, b.1) == key) {
            Some(b) => b.2.clone(),
            None => {
                let label = format!("{name} object {}", i + 1);
                let t =
                    crate::object_tree_for_mesh(p.mesh, tight(p.depth), cache, &label, &mut log)?;
                built.push((key.0, key.1, t.clone()));
                t
            }
        };
        objects.push((tree, p.pose));
    }
    Ok(Scene {
        name: name.into(),
        tool,
        tool_mesh: Some(tool_mesh.clone()),
        objects,
        object_meshes: parts.iter().map(|p| Some(p.mesh.clone())).collect(),
        coupling: Coupling::default(),
        solver: SolverSpec::default(),
        safety: SafetyParams::default(),
        start: Pose::identity(),
        rate_hz: 1000.0,
        motion: Motion::Hold,
        goal: None,
        device: Default::default(),
        load_log: log,
        object_friction: Vec::new(),
        tool_friction: None,
    })
}

/// [`assemble`] with the tool's tree built from `tool_mesh` at `tool_depth`.
fn assemble_built(
    name: &str,
    tool_mesh: &TriMesh,
    tool_depth: u32,
    parts: &[Part<'_>],
    cache: &TreeCache,
) -> Result<Scene, SceneError> {
    let mut log = Vec::new();
    let tool = crate::tree_for_mesh(
        tool_mesh,
        tight(tool_depth),
        cache,
        &format!("{name} tool"),
        &mut log,
    )?;
    assemble(name, tool_mesh, tool, parts, cache, log)
}

/// The generic stroke: where the tool starts, the way it approaches, how far it presses, the
/// slide and the twist.
struct Stroke {
    /// Start pose (free space), mm and rad.
    start: [f64; 6],
    /// Approach direction (need not be unit).
    dir: [f64; 3],
    /// Press past the first contact, mm.
    press_mm: f64,
    /// Duration of the press from 0.5 mm short of contact, s.
    press_s: f64,
    /// Slide offset from the pressed pose (out to `+slide`, back through it to `-slide`), mm.
    slide: [f64; 3],
    /// Twist offset of `(gamma, beta, alpha)` from the pressed pose, out and back, rad.
    twist: [f64; 3],
}

impl Stroke {
    fn new(start: [f64; 6], dir: [f64; 3], press_mm: f64) -> Self {
        Self {
            start,
            dir,
            press_mm,
            press_s: 0.3,
            slide: [0.0; 3],
            twist: [0.0; 3],
        }
    }
    fn slide(mut self, s: [f64; 3]) -> Self {
        self.slide = s;
        self
    }
    fn twist(mut self, w: [f64; 3]) -> Self {
        self.twist = w;
        self
    }
    fn press_s(mut self, s: f64) -> Self {
        self.press_s = s;
        self
    }
}

/// Distance (mm) from `from` along `dir` (unit) to the first contact of the scene's trees.
fn contact_distance(scene: &Scene, from: [f64; 6], dir: [f64; 3]) -> Result<f64, SceneError> {
    super::distance_to_contact(scene, &Pose::from_array(from), dir, 300.0)?.ok_or_else(|| {
        SceneError::scene(&scene.name, "the scripted approach never reaches an object")
    })
}

fn unit(v: [f64; 3]) -> [f64; 3] {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt().max(1e-12);
    v.map(|c| c / n)
}

/// `q` moved by `d` (mm) and turned by `w` (rad, Euler offsets).
fn offset(q: [f64; 6], d: [f64; 3], w: [f64; 3]) -> [f64; 6] {
    let mut r = q;
    for k in 0..3 {
        r[k] += d[k];
        r[3 + k] += w[k];
    }
    r
}

/// Gives `scene` the stroke's script (approach distance measured on its trees) and returns the
/// zoo scene.
fn stroke(mut scene: Scene, s: &Stroke) -> Result<ZooScene, SceneError> {
    let dir = unit(s.dir);
    let c = contact_distance(&scene, s.start, dir)?;
    let along = |mm: f64| offset(s.start, dir.map(|d| d * mm), [0.0; 3]);
    let pressed = along(c + s.press_mm);
    let neg = |v: [f64; 3]| v.map(|x| -x);
    let rest = 0.2;
    let mut script = Script::starting_at(s.start)
        .hold(rest)
        .then(0.4, along(c - 0.5), Ease::Smooth)
        .then(s.press_s, pressed, Ease::Smooth);
    let t_pressed = script.duration();
    script = script.hold(0.2);
    let slide0 = script.duration();
    script = script
        .then(0.5, offset(pressed, s.slide, [0.0; 3]), Ease::Smooth)
        .then(0.8, offset(pressed, neg(s.slide), [0.0; 3]), Ease::Smooth)
        .then(0.4, pressed, Ease::Smooth);
    let twist0 = script.duration();
    script = script
        .then(0.4, offset(pressed, [0.0; 3], s.twist), Ease::Smooth)
        .then(0.6, offset(pressed, [0.0; 3], neg(s.twist)), Ease::Smooth)
        .then(0.3, pressed, Ease::Smooth);
    let twist1 = script.duration();
    script = script.then(0.4, s.start, Ease::Smooth).hold(0.3);
    let end = script.duration();
    scene.start = Pose::from_array(s.start);
    scene.motion = Motion::Script(script);
    Ok(ZooScene {
        scene,
        phases: ZooPhases {
            free_s: vec![(0.0, rest), (end - 0.2, end)],
            pressed_s: (t_pressed, t_pressed + 0.2),
            slide_s: (slide0, twist0),
            twist_s: (twist0, twist1),
            press_mm: s.press_mm,
            touching_objects: 1,
        },
    })
}

/// A ball of `radius` (mm) whose lowest point along `-axis` is the tool origin, so a twist
/// rolls it about its contact.
fn ball_tool(radius: f64, axis: usize, segments: u32) -> TriMesh {
    let mut c = [0.0; 3];
    c[axis] = radius;
    ball_mesh(c, radius, segments)
}

fn sphere_on_sphere(cache: &TreeCache) -> Result<ZooScene, SceneError> {
    let object = ball_mesh([0.0; 3], 25.0, 64);
    let tool = ball_tool(8.0, 2, 32);
    let parts = [Part {
        mesh: &object,
        depth: 4,
        pose: Pose::identity(),
    }];
    let scene = assemble_built("zoo/sphere-on-sphere", &tool, 3, &parts, cache)?;
    let s = Stroke::new([0.0, 0.0, 50.0, 0.0, 0.0, 0.0], [0.0, 0.0, -1.0], 1.0)
        .slide([15.0, 5.0, 0.0])
        .twist([0.3, 0.2, 0.5]);
    stroke(scene, &s)
}

fn cube_corner(cache: &TreeCache) -> Result<ZooScene, SceneError> {
    // The corner at the origin: a floor below z = 0 and walls behind x = 0 and y = 0, three
    // boxes meeting along their edges.
    let floor = box_mesh([0.0, 0.0, -10.0], [60.0, 60.0, 0.0]);
    let wall_x = box_mesh([-10.0, 0.0, -10.0], [0.0, 60.0, 50.0]);
    let wall_y = box_mesh([0.0, -10.0, -10.0], [60.0, 0.0, 50.0]);
    let tool = box_mesh([-10.0; 3], [10.0; 3]);
    let at = |m| Part {
        mesh: m,
        depth: 4,
        pose: Pose::identity(),
    };
    let parts = [at(&floor), at(&wall_x), at(&wall_y)];
    let scene = assemble_built("zoo/cube-corner", &tool, 4, &parts, cache)?;
    let s = Stroke::new([30.0, 30.0, 30.0, 0.0, 0.0, 0.0], [-1.0, -1.0, -1.0], 1.0)
        .slide([0.0, 0.0, 6.0])
        .twist([0.0, 0.0, 0.3]);
    let mut z = stroke(scene, &s)?;
    z.phases.touching_objects = 3;
    Ok(z)
}

fn cube_edge(cache: &TreeCache) -> Result<ZooScene, SceneError> {
    let plate = super::plate::plate_mesh();
    let tool = box_mesh([-10.0; 3], [10.0; 3]);
    let parts = [Part {
        mesh: &plate,
        depth: 4,
        pose: Pose::identity(),
    }];
    let scene = assemble_built("zoo/cube-edge", &tool, 4, &parts, cache)?;
    // Turned 45 degrees about x: the edge along x is lowest, 10 sqrt 2 mm below the centre.
    let s = Stroke::new(
        [0.0, 0.0, 30.0, std::f64::consts::FRAC_PI_4, 0.0, 0.0],
        [0.0, 0.0, -1.0],
        1.0,
    )
    .slide([20.0, 10.0, 0.0])
    .twist([0.3, 0.1, 0.4]);
    stroke(scene, &s)
}

/// Thickness of the thin plate, mm.
pub const THIN_PLATE_MM: f64 = 1.0;

fn thin_plate(cache: &TreeCache) -> Result<ZooScene, SceneError> {
    let plate = box_mesh([-40.0, -40.0, -THIN_PLATE_MM], [40.0, 40.0, 0.0]);
    let tool = ball_tool(5.0, 2, 32);
    let parts = [Part {
        mesh: &plate,
        depth: 4,
        pose: Pose::identity(),
    }];
    let scene = assemble_built("zoo/thin-plate", &tool, 3, &parts, cache)?;
    // 8.5 mm in 8.5 ms: the hand crosses the plate within two frames at 1 m/s.
    let s = Stroke::new([0.0, 0.0, 20.0, 0.0, 0.0, 0.0], [0.0, 0.0, -1.0], 8.0)
        .press_s(0.0085)
        .slide([20.0, 10.0, 0.0])
        .twist([0.2, 0.2, 0.5]);
    let mut z = stroke(scene, &s)?;
    // The linear stab (a smooth one would start and end at rest).
    if let Motion::Script(script) = &mut z.scene.motion {
        if let Some(k) = script.keys.get_mut(3) {
            k.ease = Ease::Linear;
        }
    }
    Ok(z)
}

/// Width of the slot, mm.
pub const SLOT_WIDTH_MM: f64 = 6.0;
/// Thickness of the blade in the slot, mm.
pub const BLADE_MM: f64 = 3.0;

fn slot(cache: &TreeCache) -> Result<ZooScene, SceneError> {
    // A U outline (x across, y up) extruded along z, then stood up (gamma = pi/2 maps the
    // outline's y onto world z): the slot runs along world y, its mouth at z = 0, 12 mm deep.
    let w = SLOT_WIDTH_MM / 2.0;
    let outline = [
        [-20.0, -20.0],
        [20.0, -20.0],
        [20.0, 0.0],
        [w, 0.0],
        [w, -12.0],
        [-w, -12.0],
        [-w, 0.0],
        [-20.0, 0.0],
    ];
    let block = generate::extrude(&outline, -15.0, 15.0);
    let b = BLADE_MM / 2.0;
    let blade = box_mesh([-b, -8.0, 0.0], [b, 8.0, 24.0]);
    let parts = [Part {
        mesh: &block,
        depth: 4,
        pose: Pose::from_array([0.0, 0.0, 0.0, std::f64::consts::FRAC_PI_2, 0.0, 0.0]),
    }];
    let scene = assemble_built("zoo/slot", &blade, 4, &parts, cache)?;
    let s = Stroke::new([0.0, 0.0, 20.0, 0.0, 0.0, 0.0], [0.0, 0.0, -1.0], 1.0)
        .slide([0.0, 6.0, 0.0])
        .twist([0.0, 0.0, 0.3]);
    stroke(scene, &s)
}

/// The keyed shaft and its hub: one key, 1 mm clearance all round (radial and on the key's
/// sides). With depth-4 trees (a scene file's default) 1 mm passes; 0.75 mm and 0.5 mm do not
/// (the shaft stops 2.0 and 0.3 mm into the hole: the leaves' bulge fills the gap).
pub fn keyed_params() -> SplineParams {
    SplineParams {
        keys: 1,
        root_radius: 8.0,
        key_height: 3.0,
        key_half_angle: 15f64.to_radians(),
        clearance: 1.0,
        shaft_length: 40.0,
        hub_radius: 20.0,
        hub_height: 25.0,
        ..SplineParams::default()
    }
}

fn keyed_shaft(cache: &TreeCache) -> Result<ZooScene, SceneError> {
    let p = keyed_params();
    let shaft = p.shaft_mesh();
    let hub = p.hub_mesh();
    let parts = [Part {
        mesh: &hub,
        depth: 4,
        pose: Pose::identity(),
    }];
    let mut scene = assemble_built("zoo/keyed-shaft", &shaft, 4, &parts, cache)?;
    // Rest on the hub's face with the key a quarter turn off its keyway, slide on the face,
    // turn until the key aligns (the shaft drops), insert, twist the key against the keyway's
    // sides, withdraw.
    let off = std::f64::consts::FRAC_PI_2;
    let above = 15.0;
    let at = |x: f64, z: f64, alpha: f64| [x, 0.0, z, 0.0, 0.0, alpha];
    let start = at(0.0, above, off);
    let press = 1.0;
    let insert = 15.0;
    let rest = 0.2;
    let script =
        Script::starting_at(start)
            .hold(rest)
            .then(0.5, at(0.0, -press, off), Ease::Smooth);
    let t_pressed = script.duration();
    let script = script.hold(0.2);
    let slide0 = script.duration();
    let script = script
        .then(0.3, at(0.6, -press, off), Ease::Smooth)
        .then(0.5, at(-0.6, -press, off), Ease::Smooth)
        .then(0.3, at(0.0, -press, off), Ease::Smooth)
        .then(1.0, at(0.0, -press, 0.0), Ease::Smooth)
        .then(0.8, at(0.0, -insert, 0.0), Ease::Smooth);
    let twist0 = script.duration();
    let script = script
        .then(0.4, at(0.0, -insert, 0.15), Ease::Smooth)
        .then(0.6, at(0.0, -insert, -0.15), Ease::Smooth)
        .then(0.3, at(0.0, -insert, 0.0), Ease::Smooth);
    let twist1 = script.duration();
    let script = script
        .then(0.8, at(0.0, above, 0.0), Ease::Smooth)
        .hold(0.3);
    let end = script.duration();
    scene.start = Pose::from_array(start);
    scene.motion = Motion::Script(script);
    scene.goal = Some(crate::Goal::InsertZ {
        target_z_mm: -insert,
        tol_mm: 0.5,
    });
    Ok(ZooScene {
        scene,
        phases: ZooPhases {
            free_s: vec![(0.0, rest), (end - 0.2, end)],
            pressed_s: (t_pressed, t_pressed + 0.2),
            slide_s: (slide0, twist0),
            twist_s: (twist0, twist1),
            press_mm: press,
            touching_objects: 1,
        },
    })
}

fn gears(cache: &TreeCache) -> Result<ZooScene, SceneError> {
    let p = SplineParams {
        keys: 12,
        root_radius: 12.0,
        key_height: 3.0,
        key_half_angle: 5f64.to_radians(),
        shaft_length: 20.0,
        ..SplineParams::default()
    };
    let gear = p.shaft_mesh();
    let mut log = Vec::new();
    let object = crate::object_tree_for_mesh(&gear, tight(4), cache, "zoo/gears", &mut log)?;
    let tool = without_caps(&object, "zoo/gears")?;
    let parts = [Part {
        mesh: &gear,
        depth: 4,
        pose: Pose::identity(),
    }];
    let scene = assemble("zoo/gears", &gear, tool, &parts, cache, log)?;
    // Axes parallel, the tool's teeth half a pitch round so they face the object's gaps; in
    // mesh the tips clear the other gear's root by 1 mm.
    let half_pitch = 0.5 * p.pitch();
    let s = Stroke::new(
        [50.0, 0.0, 4.0, 0.0, 0.0, half_pitch],
        [-1.0, 0.0, 0.0],
        0.5,
    )
    .slide([0.0, 0.0, 6.0])
    .twist([0.0, 0.0, 0.2]);
    stroke(scene, &s)
}

/// Balls in the sphere field: a square grid of this many a side.
pub const FIELD_SIDE: usize = 6;

fn sphere_field(cache: &TreeCache) -> Result<ZooScene, SceneError> {
    let ball = ball_mesh([0.0, 0.0, 3.0], 3.0, 16);
    let spacing = 10.0;
    let c = 0.5 * (FIELD_SIDE as f64 - 1.0) * spacing;
    let mut parts = Vec::with_capacity(FIELD_SIDE * FIELD_SIDE);
    for i in 0..FIELD_SIDE {
        for j in 0..FIELD_SIDE {
            parts.push(Part {
                mesh: &ball,
                depth: 3,
                pose: Pose::from_array([
                    i as f64 * spacing - c,
                    j as f64 * spacing - c,
                    0.0,
                    0.0,
                    0.0,
                    0.0,
                ]),
            });
        }
    }
    let puck = box_mesh([-15.0, -15.0, 0.0], [15.0, 15.0, 5.0]);
    let scene = assemble_built("zoo/sphere-field", &puck, 4, &parts, cache)?;
    let s = Stroke::new([3.0, 2.0, 25.0, 0.0, 0.0, 0.0], [0.0, 0.0, -1.0], 1.0)
        .slide([12.0, 6.0, 0.0])
        .twist([0.1, 0.1, 0.5]);
    let mut z = stroke(scene, &s)?;
    // The puck covers nine balls; the trees' bumps decide which hold it.
    z.phases.touching_objects = 3;
    Ok(z)
}

fn big_tool(cache: &TreeCache) -> Result<ZooScene, SceneError> {
    let cube = box_mesh([-5.0, -5.0, -10.0], [5.0, 5.0, 0.0]);
    let ball = ball_tool(40.0, 2, 96);
    let parts = [Part {
        mesh: &cube,
        depth: 3,
        pose: Pose::identity(),
    }];
    let scene = assemble_built("zoo/big-tool", &ball, 4, &parts, cache)?;
    let s = Stroke::new([0.0, 0.0, 20.0, 0.0, 0.0, 0.0], [0.0, 0.0, -1.0], 1.0)
        .slide([8.0, 3.0, 0.0])
        .twist([0.15, 0.1, 0.4]);
    stroke(scene, &s)
}

/// Height of the bumps of the bumpy surface (peak to valley: twice this), mm.
pub const BUMP_MM: f64 = 1.0;
/// Period of the bumps along x and y, mm.
pub const BUMP_PERIOD_MM: f64 = 8.0;

fn probe_bumps(cache: &TreeCache) -> Result<ZooScene, SceneError> {
    let k = 2.0 * std::f64::consts::PI / BUMP_PERIOD_MM;
    let surface = generate::height_field_block(30.0, 30.0, -8.0, 60, |x, y| {
        BUMP_MM * (k * x).sin() * (k * y).sin()
    });
    let probe = generate::rod(0.8, 40.0, 16);
    let parts = [Part {
        mesh: &surface,
        depth: 4,
        pose: Pose::identity(),
    }];
    let scene = assemble_built("zoo/probe-bumps", &probe, 3, &parts, cache)?;
    // Held 20 degrees off vertical, as a probe is; twists pivot it on its tip.
    let s = Stroke::new([0.0, 0.0, 15.0, 0.35, 0.0, 0.0], [0.0, 0.0, -1.0], 0.5)
        .slide([12.0, 4.0, 0.0])
        .twist([0.2, 0.2, 0.6]);
    stroke(scene, &s)
}

fn torus_link(cache: &TreeCache) -> Result<ZooScene, SceneError> {
    let object = generate::torus(20.0, 4.0, 64, 24);
    let ring = generate::torus(14.0, 3.0, 64, 16);
    let parts = [Part {
        mesh: &object,
        depth: 4,
        pose: Pose::identity(),
    }];
    let scene = assemble_built("zoo/torus-link", &ring, 4, &parts, cache)?;
    // The tool ring stood up in the xz plane (gamma = pi/2) round the object's tube at
    // (20, 0, 0), 7 mm clear of it; pulled along +x its inner side meets the tube.
    let s = Stroke::new(
        [20.0, 0.0, 0.0, std::f64::consts::FRAC_PI_2, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        1.0,
    )
    .slide([0.0, 0.0, 6.0])
    .twist([0.0, 0.3, 0.3]);
    stroke(scene, &s)
}

fn bracket(cache: &TreeCache) -> Result<ZooScene, SceneError> {
    // Legs 8 mm thick, 40 mm long, 30 mm tall; the inner corner is the vertical edge at
    // (8, 8).
    let outline = [
        [0.0, 0.0],
        [40.0, 0.0],
        [40.0, 8.0],
        [8.0, 8.0],
        [8.0, 40.0],
        [0.0, 40.0],
    ];
    let l = generate::extrude(&outline, 0.0, 30.0);
    let peg = generate::rod(3.0, 20.0, 24);
    let parts = [Part {
        mesh: &l,
        depth: 4,
        pose: Pose::identity(),
    }];
    let scene = assemble_built("zoo/bracket", &peg, 3, &parts, cache)?;
    let s = Stroke::new([25.0, 25.0, 5.0, 0.0, 0.0, 0.0], [-1.0, -1.0, 0.0], 1.0)
        .slide([0.0, 0.0, 4.0])
        .twist([0.25, -0.25, 0.4]);
    stroke(scene, &s)
}

/// The bunny's object tree (the `bunny` scene's: depth 4, face caps) and its mesh, mm.
fn bunny_object(
    cache: &TreeCache,
    log: &mut Vec<String>,
) -> Result<(TriMesh, SphereTree), SceneError> {
    let mesh = super::bunny::bunny_mesh_mm()?;
    let tree = crate::object_tree_for_mesh(&mesh, tight(4), cache, "bunny", log)?;
    Ok((mesh, tree))
}

fn bunny_probe(cache: &TreeCache) -> Result<ZooScene, SceneError> {
    let mut log = Vec::new();
    let (bunny, tree) = bunny_object(cache, &mut log)?;
    let ball = ball_tool(3.0, 1, 24);
    let tool = crate::tree_for_mesh(&ball, tight(3), cache, "zoo/bunny-probe tool", &mut log)?;
    let mut scene = assemble("zoo/bunny-probe", &ball, tool, &[], cache, log)?;
    scene.objects = vec![(tree, Pose::identity())];
    scene.object_meshes = vec![Some(bunny)];
    let s = Stroke::new([0.0, 120.0, 0.0, 0.0, 0.0, 0.0], [0.0, -1.0, 0.0], 0.5)
        .slide([20.0, 0.0, 10.0])
        .twist([0.3, 0.5, 0.3]);
    stroke(scene, &s)
}

fn bunny_on_plate(cache: &TreeCache) -> Result<ZooScene, SceneError> {
    let mut log = Vec::new();
    let (bunny, tree) = bunny_object(cache, &mut log)?;
    let tool = without_caps(&tree, "zoo/bunny-on-plate")?;
    let plate = super::plate::plate_mesh();
    let parts = [Part {
        mesh: &plate,
        depth: 4,
        pose: Pose::identity(),
    }];
    let scene = assemble("zoo/bunny-on-plate", &bunny, tool, &parts, cache, log)?;
    // The bunny upright (its +y turned onto +z) above the plate.
    let s = Stroke::new(
        [0.0, 0.0, 120.0, std::f64::consts::FRAC_PI_2, 0.0, 0.0],
        [0.0, 0.0, -1.0],
        2.0,
    )
    .slide([15.0, 10.0, 0.0])
    .twist([0.1, 0.1, 0.5]);
    stroke(scene, &s)
}
