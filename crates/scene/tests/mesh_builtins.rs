//! The built-ins that run on the parts' own triangles, `spline-tight` and `probe`: their parts
//! and trees, and their goals checked as `haptic6d run` checks them (the run loop, then
//! [`scene::report::summarize`] with the scene's goal). Each goal is reached in the mesh mode
//! and missed on the leaf spheres of the same trees, whose overhang is wider than the gap.
//!
//! No deadline (the frames do not depend on the machine's load); `spline-tight` is replayed on
//! its insertion alone, keys aligned, since its turn on the hub's face takes seconds of frames
//! without a deadline.

mod common;

use collide::Pose;
use engine::Geometry;
use mesh::TriMesh;
use scene::device::ReplayDevice;
use scene::report::{summarize, GoalReport};
use scene::rt::{run_loop, FrameRecord, LoopParams};
use scene::scenes::probe::{self, ProbeParams};
use scene::scenes::{spline_scene, BUILTIN_NAMES, MESH_BUILTIN_NAMES};
use scene::trajectory::{Ease, Script};
use scene::{Goal, Motion, Scene};
use spheretree::SphereTree;

/// `scene` replayed through the run loop up to `until_s` (s of its motion) with no deadline in
/// `geometry`: the goal's report and the frames.
fn run_goal(scene: &Scene, geometry: Geometry, until_s: f64) -> (GoalReport, Vec<FrameRecord>) {
    let mut scene = scene.clone();
    scene.solver.budget_us = engine::config::BUDGET_US.hi;
    scene.solver.geometry = geometry;
    assert_eq!(scene.geometry(), geometry, "{}: meshes missing", scene.name);
    let mut traj = scene.trajectory();
    traj.samples.retain(|s| s.t <= until_s);
    let mut engine = scene.engine().unwrap();
    engine.reset(&Pose::from_array(traj.samples[0].q)).unwrap();
    let mut device = ReplayDevice::new(traj);
    let report = run_loop(&mut engine, &mut device, &LoopParams::default()).unwrap();
    let summary = summarize(
        &scene.name,
        "dual",
        "distance",
        &report.frames,
        &report.stats,
        scene.goal,
        Vec::new(),
        0.0,
    );
    for r in &report.frames {
        let f = &r.frame;
        assert!(
            f.q_g.iter().chain(&f.wrench).all(|v| v.is_finite()),
            "{}: a non-finite frame at t = {}",
            scene.name,
            r.t
        );
        assert!(
            f.penetration_mm <= scene.solver.penetration_tol_mm + 1e-12,
            "{}: penetration {} mm at t = {}",
            scene.name,
            f.penetration_mm,
            r.t
        );
    }
    (summary.goal.expect("the scene has a goal"), report.frames)
}

/// A tree that keeps the bounding rule, of the given depth, whose root holds every vertex of
/// its mesh.
fn assert_sane_tree(tree: &SphereTree, mesh: &TriMesh, depth: u32, what: &str) {
    tree.validate(1e-9)
        .unwrap_or_else(|e| panic!("{what}: {e}"));
    assert_eq!(tree.depth(), depth, "{what}");
    assert!(tree.leaves().count() > 8, "{what}: too few leaves");
    let root = tree.sphere(0);
    for v in &mesh.vertices {
        let d = (0..3)
            .map(|k| (v[k] - root.center[k]).powi(2))
            .sum::<f64>()
            .sqrt();
        assert!(
            d <= root.radius + 1e-9,
            "{what}: vertex {v:?} outside the root"
        );
    }
}

fn assert_closed(m: &TriMesh, what: &str) {
    m.check_closed().unwrap_or_else(|e| panic!("{what}: {e}"));
    assert!(m.signed_volume() > 0.0, "{what}: normals point inwards");
}

#[test]
fn the_sphere_mode_built_ins_are_the_others() {
    let spheres: Vec<&str> = scene::scenes::sphere_builtin_names().collect();
    assert_eq!(spheres, ["bunny", "spline", "plate"]);
    for name in BUILTIN_NAMES {
        assert_ne!(
            spheres.contains(name),
            MESH_BUILTIN_NAMES.contains(name),
            "{name}"
        );
    }
    // The mesh-mode ones are checked by their own tests below (each tree built once).
    let cache = common::test_cache();
    for name in &spheres {
        let s = scene::scenes::builtin(name, &cache).unwrap();
        assert_eq!(s.solver.geometry, Geometry::Spheres, "{name}");
    }
}

/// The built-in `name` runs on the mesh and has a goal.
fn assert_mesh_built_in(s: &Scene, name: &str) {
    assert!(MESH_BUILTIN_NAMES.contains(&name), "{name}");
    assert_eq!(s.name, name);
    assert_eq!(s.solver.geometry, Geometry::Mesh, "{name}");
    assert_eq!(s.geometry(), Geometry::Mesh, "{name}: meshes missing");
    assert!(s.goal.is_some(), "{name} has no goal");
}

/// `spline-tight`: the spline's shaft, hand and goal with a hole 0.1 mm wider than the shaft;
/// its insertion, keys aligned, reaches the goal on the mesh and jams on the spheres.
#[test]
fn spline_tight_is_the_spline_at_a_tenth_of_a_millimetre_and_goes_in_on_the_mesh() {
    let cache = common::test_cache();
    let spline = scene::scenes::builtin("spline", &cache).unwrap();
    let tight = scene::scenes::builtin("spline-tight", &cache).unwrap();
    // The same shaft, hand and goal depth; only the hub's hole and the geometry differ.
    assert_eq!(tight.tool_mesh, spline.tool_mesh);
    assert_eq!(tight.motion, spline.motion);
    assert_eq!(tight.start, spline.start);
    let target = |s: &Scene| match s.goal {
        Some(Goal::InsertZ { target_z_mm, .. }) => target_z_mm,
        None => f64::NAN,
    };
    assert_eq!(target(&tight), -spline_scene::INSERT_DEPTH_MM);
    assert_eq!(target(&spline), target(&tight));
    assert_eq!(spline.solver.geometry, Geometry::Spheres);
    // The hole's root circle: the shaft's root radius plus the clearance.
    let hole_root = |s: &Scene| {
        s.object_meshes[0]
            .as_ref()
            .unwrap()
            .vertices
            .iter()
            .map(|v| v[0].hypot(v[1]))
            .fold(f64::INFINITY, f64::min)
    };
    let p = spline_scene::tight_params();
    assert!((hole_root(&tight) - p.root_radius - 0.1).abs() < 1e-9);
    assert!((hole_root(&spline) - p.root_radius - 1.0).abs() < 1e-9);
    let shaft = tight.tool_mesh.as_ref().unwrap();
    let hub = tight.object_meshes[0].as_ref().unwrap();
    assert_closed(shaft, "shaft");
    assert_closed(hub, "hub");
    assert_sane_tree(&tight.tool, shaft, spline_scene::TREE_DEPTH, "shaft tree");
    assert_sane_tree(
        &tight.objects[0].0,
        hub,
        spline_scene::TREE_DEPTH,
        "hub tree",
    );
    assert_mesh_built_in(&tight, "spline-tight");

    let mut scene = tight;
    // The scene's insertion with the keys aligned from the start: 1 mm above the face, down to
    // the goal's depth at 21 mm/s mean, a short hold.
    let at = |z: f64| [0.0, 0.0, z, 0.0, 0.0, 0.0];
    let script = Script::starting_at(at(1.0))
        .hold(0.05)
        .then(1.0, at(-spline_scene::INSERT_DEPTH_MM), Ease::Smooth)
        .hold(0.1);
    let end = script.duration();
    scene.start = Pose::from_array(at(1.0));
    scene.motion = Motion::Script(script);
    let (mesh, _) = run_goal(&scene, Geometry::Mesh, end);
    assert!(mesh.success, "the mesh mode does not insert: {mesh:?}");
    let (spheres, _) = run_goal(&scene, Geometry::Spheres, end);
    assert!(
        !spheres.success && spheres.reached_z_mm > -1.0,
        "the leaf spheres let the shaft in at 0.1 mm: {spheres:?}"
    );
}

/// `spline-tight` with its hand lowered from 0.5 mm above the hub's face to 2 mm into it at the
/// keys' misalignment `from` (rad), held 0.05 s, turned to `to` over 0.3 s at a steady pace, and
/// held `hold` s; with the script's length (s).
fn pressed_and_turned(from: f64, to: f64, hold: f64) -> (Scene, f64) {
    let mut scene = scene::scenes::builtin("spline-tight", &common::test_cache()).unwrap();
    let at = |alpha: f64| [0.0, 0.0, -spline_scene::PRESS_MM, 0.0, 0.0, alpha];
    let above = [0.0, 0.0, 0.5, 0.0, 0.0, from];
    let script = Script::starting_at(above)
        .then(0.1, at(from), Ease::Smooth)
        .hold(0.05)
        .then(0.3, at(to), Ease::Linear)
        .hold(hold);
    let end = script.duration();
    scene.start = Pose::from_array(above);
    scene.motion = Motion::Script(script);
    (scene, end)
}

/// `spline-tight`'s turn on the hub's face, keys misaligned: the hand 2 mm into the face turns
/// the shaft at the scene's pace. The keys' edges cross the keyways' edges, whose rows stay open
/// in truth where a trust region stops the answer; re-linearising on the same pairs then stops
/// it where it is. With the bound answer going to a new region at once, fewer frames take
/// three passes or more, and the shaft turns as far.
#[test]
fn a_shaft_turned_on_its_hubs_face_goes_on_from_a_bound_answer_in_a_new_region() {
    let half_pitch = 0.5 * spline_scene::tight_params().pitch();
    // A quarter of the way to the keys' alignment at the scene's steepest pace (half a pitch
    // over 1.2 s, smoothed).
    let (scene, end) = pressed_and_turned(half_pitch, 0.75 * half_pitch, 0.0);
    let turned = |bound_detects: bool| {
        let mut s = scene.clone();
        s.solver.heuristics.mesh_bound_detects = bound_detects;
        let (_, frames) = run_goal(&s, Geometry::Mesh, end);
        let heavy = frames.iter().filter(|r| r.frame.passes >= 3).count();
        let last = frames.last().unwrap().frame.q_g;
        (heavy, last)
    };
    let (heavy_on, last_on) = turned(true);
    let (heavy_off, last_off) = turned(false);
    assert!(
        heavy_off >= 10 && 2 * heavy_on <= heavy_off,
        "frames of three passes or more: {heavy_on} going on from a bound answer, {heavy_off} re-linearising first"
    );
    // Both end at the hand's turn, resting on the face.
    for last in [last_on, last_off] {
        assert!((last[5] - 0.75 * half_pitch).abs() < 1e-3, "{last:?}");
        assert!(last[2].abs() < 0.01, "{last:?}");
    }
}

/// `spline-tight`'s drop: the shaft pressed 2 mm onto the hub's face and turned until its keys
/// come over the keyways falls 2 mm at once. Balls kept small by the dense face contact creep
/// a few hundredths of a millimetre a pass; a pass that went straight toward the hand until its
/// trust region held it starts the fall's straight path in the same frame. The drop's first
/// frame goes more than half the way (without: under a quarter, waiting for a frame's step of
/// 0.1 mm), and the shaft reaches the hand's depth in the next.
#[test]
fn a_shaft_whose_keys_come_over_the_keyways_falls_in_its_first_frame() {
    let quarter_pitch = 0.25 * spline_scene::tight_params().pitch();
    let (scene, end) = pressed_and_turned(quarter_pitch, 0.0, 0.05);
    let drop = |falls: bool| {
        let mut s = scene.clone();
        s.solver.heuristics.mesh_region_falls = falls;
        let (_, frames) = run_goal(&s, Geometry::Mesh, end);
        let start = frames
            .iter()
            .position(|r| r.frame.q_g[2] < -0.01)
            .expect("the shaft never dropped");
        let reached = frames[start..]
            .iter()
            .position(|r| r.frame.q_g[2] < -1.9)
            .expect("the shaft never reached the hand's depth");
        (frames[start].frame.q_g[2], reached + 1)
    };
    let (first_on, frames_on) = drop(true);
    let (first_off, _) = drop(false);
    assert!(
        first_on < -1.0 && first_off > -0.5,
        "the drop's first frame: to z = {first_on} mm falling from a held pass, {first_off} \
         waiting for a step"
    );
    assert!(frames_on <= 2, "the drop took {frames_on} frames");
}

/// `probe`: its parts closed and the pocket as wide as stated; the tip reaches the floor on the
/// mesh and rests on it pressed, and stops short on the spheres.
#[test]
fn the_probe_fits_its_pocket_and_reaches_the_floor_on_the_mesh() {
    let p = ProbeParams::default();
    let probe = p.probe_mesh();
    let tooth = p.tooth_mesh();
    let gingiva = p.gingiva_mesh();
    let floor = p.floor_mesh();
    for (m, what) in [
        (&probe, "probe"),
        (&tooth, "tooth"),
        (&gingiva, "gingiva"),
        (&floor, "floor"),
    ] {
        assert_closed(m, what);
    }
    // The probe: its tip's lowest point at the origin, 0.5 mm across along the working end.
    let lowest = probe
        .vertices
        .iter()
        .map(|v| v[2])
        .fold(f64::INFINITY, f64::min);
    assert_eq!(lowest, 0.0);
    let working_radius = probe
        .vertices
        .iter()
        .filter(|v| v[2] <= p.working_length_mm)
        .map(|v| v[0].hypot(v[1]))
        .fold(0.0, f64::max);
    assert!((working_radius - 0.25).abs() < 1e-12, "{working_radius}");
    // The walls: nothing of the tooth beyond its root surface's crests, nothing of the
    // gingiva inside its face, so the pocket is the stated width at its narrowest, y = 0.
    let w = p.pocket_width_mm;
    let beyond_crests = tooth
        .vertices
        .iter()
        .map(|v| v[0] - (p.gingiva_surface_x(v[1]) - w))
        .fold(f64::NEG_INFINITY, f64::max);
    assert!(beyond_crests.abs() < 1e-12, "tooth {beyond_crests}");
    let inside_face = gingiva
        .vertices
        .iter()
        .map(|v| p.gingiva_surface_x(v[1]) - v[0])
        .fold(f64::NEG_INFINITY, f64::max);
    assert!(inside_face.abs() < 1e-12, "gingiva {inside_face}");
    let narrowest = gingiva
        .vertices
        .iter()
        .filter(|v| v[1] == 0.0)
        .map(|v| v[0])
        .fold(f64::INFINITY, f64::min)
        - tooth
            .vertices
            .iter()
            .filter(|v| v[1] == 0.0)
            .map(|v| v[0])
            .fold(f64::NEG_INFINITY, f64::max);
    assert!(
        (narrowest - 0.6).abs() < 1e-12,
        "pocket {narrowest} mm wide"
    );
    // The grooves: the root surface's samples reach their full depth between the crests.
    let deepest = tooth
        .vertices
        .iter()
        .filter(|v| v[1] == 0.0 && v[0] > -1.0)
        .map(|v| -0.5 * w - v[0])
        .fold(0.0, f64::max);
    assert!(
        (deepest - p.groove_depth_mm).abs() < 1e-3,
        "grooves {deepest} mm deep"
    );
    // Heights: the mouth at the gingiva's top, the floor 4 mm below it, the crown above.
    let top = |m: &TriMesh| {
        m.vertices
            .iter()
            .map(|v| v[2])
            .fold(f64::NEG_INFINITY, f64::max)
    };
    assert_eq!(top(&gingiva), 0.0);
    assert_eq!(top(&floor), -p.pocket_depth_mm);
    assert_eq!(top(&tooth), p.crown_height_mm);
    assert!((3.0..=6.0).contains(&p.pocket_depth_mm));

    let ps = probe::probe_scene(&p, &common::test_cache()).unwrap();
    assert_mesh_built_in(&ps.scene, "probe");
    assert_sane_tree(&ps.scene.tool, &probe, probe::TREE_DEPTH, "probe tree");
    let walls = [(&tooth, "tooth"), (&gingiva, "gingiva"), (&floor, "floor")];
    for ((tree, _), (m, what)) in ps.scene.objects.iter().zip(walls) {
        assert_sane_tree(tree, m, probe::TREE_DEPTH, what);
    }

    let (pressed0, pressed1) = ps.phases.pressed_s;
    let (goal, frames) = run_goal(&ps.scene, Geometry::Mesh, pressed1);
    assert!(goal.success, "the probe misses the floor: {goal:?}");
    let floor = -p.pocket_depth_mm;
    // Free above the pocket, the tool is on the hand.
    let rest = ps.phases.free_s[0].1;
    for r in frames.iter().filter(|r| r.t < rest) {
        let f = &r.frame;
        let off = (0..6)
            .map(|k| (f.q_g[k] - f.q_h[k]).abs())
            .fold(0.0, f64::max);
        assert!(
            off < 1e-9,
            "held {off} off the hand in free space at t = {}",
            r.t
        );
    }
    // Pressed: the tip rests on the floor, pushed up by the coupling's stretch below it.
    let kt = ps.scene.coupling.kt;
    for r in frames
        .iter()
        .filter(|r| r.t > pressed0 + 0.05 && r.t < pressed1)
    {
        let f = &r.frame;
        assert!(
            (f.q_g[2] - floor).abs() <= probe::GOAL_TOL_MM,
            "tip at z = {} while pressed (t = {})",
            f.q_g[2],
            r.t
        );
        let push = kt * (f.q_g[2] - f.q_h[2]);
        assert!(
            (f.raw_wrench[2] - push).abs() < 1e-6 && (push - kt * p.press_mm).abs() < 0.01,
            "press {} N at t = {}",
            f.raw_wrench[2],
            r.t
        );
    }
    let (spheres, _) = run_goal(&ps.scene, Geometry::Spheres, pressed1);
    assert!(
        !spheres.success,
        "the leaf spheres let the tip to the floor: {spheres:?}"
    );
}

/// The load log's mesh line names each body's triangles as given and as merged: the probe's
/// rod (16 facets in rings) keeps one strip of two triangles per facet, the floor slab's grid
/// faces two each, and no body gains any.
#[test]
fn the_mesh_line_reports_each_bodys_triangles_as_given_and_merged() {
    let cache = common::test_cache();
    let s = scene::scenes::builtin("probe", &cache).unwrap();
    let engine = s.engine().unwrap();
    let counts = engine.god_object().mesh_triangle_counts().unwrap();
    let given = |m: &Option<TriMesh>| m.as_ref().unwrap().triangles.len();
    assert!(counts.0 < given(&s.tool_mesh), "{counts:?}");
    for (m, n) in s.object_meshes.iter().zip(&counts.1) {
        assert!(*n <= given(m), "{counts:?}");
    }
    let line = scene::mesh_triangles_line(&s, &counts);
    assert!(
        line.starts_with(&format!(
            "mesh: triangles as given → with flat faces merged: tool {} → {}",
            scene::grouped(given(&s.tool_mesh)),
            scene::grouped(counts.0)
        )),
        "{line}"
    );
    assert_eq!(
        line.matches("; object ").count(),
        s.object_meshes.len(),
        "{line}"
    );
    // The leaf spheres hold no triangles.
    let mut spheres = s.clone();
    spheres.solver.geometry = Geometry::Spheres;
    assert!(spheres
        .engine()
        .unwrap()
        .god_object()
        .mesh_triangle_counts()
        .is_none());
}
