//! Generated pegs and holes for clearance studies: a peg (round, or splined as the `spline`
//! scene's shaft) lowered by a scripted hand into a block with a through hole a radial
//! `clearance` wider, to full depth, then withdrawn.
//!
//! Both parts are extrusions along `z` of a star-shaped polar profile `r(theta)`, as the
//! splined shaft and hub of [`super::spline_mesh`] (whose profile generator the splined case
//! reuses, with its `clearance`), with rings at chosen heights whose radius is offset: the
//! peg's tip rings are pulled in towards the axis (a chamfer of `peg_chamfer_mm` at 45°), the
//! hole's mouth rings are pushed out (a chamfer of `hole_chamfer_mm`). The round profile is a
//! regular polygon fine enough that its facets lie within [`MAX_SAGITTA_MM`] of the circle, and
//! the hole's polygon has the same angles: its vertices are exactly `clearance` farther from
//! the axis than the peg's. Meshes are closed and consistently oriented.
//!
//! Frames: the peg in the tool frame, its tip (centre of the tip face) at the origin, along
//! `+z`; the block in the world, its top face (the hole's mouth) at `z = 0`, the hole along
//! `z` down to `z = -block_height_mm`. The tool's `z` is therefore the depth of the tip below
//! the mouth, negated. Lengths mm, angles rad, speeds mm/s, times s.
//!
//! The script ([`FitPhases`] holds its times): rest in free space 10 mm above the mouth (tilted
//! by `tilt_rad` about `x` for a tilted approach), approach to 1 mm above the mouth, enter to
//! [`ENTER_MM`] below it while the tilt straightens, insert to full depth, hold, withdraw
//! straight to the start, rest. Trees come from the tree cache with the zoo's builder (tight,
//! branching 8, depth [`FitParams::tree_depth`]); solver settings are a scene file's defaults.

use std::f64::consts::PI;

use collide::Pose;
use engine::safety::SafetyParams;
use engine::step::{FrameOutput, FrameStatus};
use mesh::TriMesh;
use serde::Serialize;

use super::spline_mesh::SplineParams;
use crate::cache::TreeCache;
use crate::stats::Summary;
use crate::trajectory::{Ease, Script};
use crate::{Coupling, Goal, Motion, Scene, SceneError, SolverSpec, TreeParams};

/// Largest distance between a facet of the round profile and the circle it approximates, mm
/// (far below the smallest clearance studied, 0.02 mm).
pub const MAX_SAGITTA_MM: f64 = 0.001;

/// Largest spacing of the rings along `z`, mm (as the splined shaft's).
pub const MAX_RING_SPACING_MM: f64 = 2.5;

/// Height of the tip above the mouth at the start and end of the script, mm.
pub const START_HEIGHT_MM: f64 = 10.0;

/// Height of the tip above the mouth at the end of the approach, mm.
pub const APPROACH_HEIGHT_MM: f64 = 1.0;

/// Depth below the mouth at which the hand has straightened a tilted approach, mm.
pub const ENTER_MM: f64 = 3.0;

/// The tool's tip counts as at full depth within this of it, mm.
pub const FULL_DEPTH_TOL_MM: f64 = 0.1;

/// The peg's cross-section.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum FitShape {
    /// A circle of radius `radius_mm`.
    Round,
    /// The splined shaft of [`SplineParams`] (six keys), root radius `radius_mm`, keys
    /// `0.3 · radius_mm` high.
    Splined,
}

impl FitShape {
    /// `round` or `splined`.
    pub fn name(self) -> &'static str {
        match self {
            FitShape::Round => "round",
            FitShape::Splined => "splined",
        }
    }
}

/// A peg, its hole and the hand's stroke (mm, rad, mm/s).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct FitParams {
    /// The peg's cross-section.
    pub shape: FitShape,
    /// Peg radius (round) or root radius (splined), mm.
    pub radius_mm: f64,
    /// Radial clearance between peg and hole (and lateral, on a spline's keys), mm.
    pub clearance_mm: f64,
    /// Peg length, mm.
    pub peg_length_mm: f64,
    /// Chamfer at the peg's tip (45°, this long radially and axially), mm; 0 for none.
    pub peg_chamfer_mm: f64,
    /// Chamfer at the hole's mouth (45°), mm; 0 for none.
    pub hole_chamfer_mm: f64,
    /// Block height (the through hole's length), mm.
    pub block_height_mm: f64,
    /// Full insertion depth: the tip this far below the mouth, mm.
    pub depth_mm: f64,
    /// Tilt of the peg about `x` at the start of the approach (straightened on entering), rad.
    pub tilt_rad: f64,
    /// Mean hand speed while entering and inserting (peak 1.5 times it), mm/s.
    pub speed_mm_s: f64,
    /// Depth of both sphere-trees.
    pub tree_depth: u32,
}

impl Default for FitParams {
    /// A round peg of radius 10 mm, 40 mm long, in a 30 mm block at 0.5 mm clearance, no
    /// chamfers, straight, inserted 20 mm at 12 mm/s, depth-4 trees (a scene file's default).
    fn default() -> Self {
        Self {
            shape: FitShape::Round,
            radius_mm: 10.0,
            clearance_mm: 0.5,
            peg_length_mm: 40.0,
            peg_chamfer_mm: 0.0,
            hole_chamfer_mm: 0.0,
            block_height_mm: 30.0,
            depth_mm: 20.0,
            tilt_rad: 0.0,
            speed_mm_s: 12.0,
            tree_depth: 4,
        }
    }
}

impl FitParams {
    /// A short name: `fit/round-r10-c0.5` with `-chamfer` and `-tilted` where they apply.
    pub fn name(&self) -> String {
        let mut s = format!(
            "fit/{}-r{}-c{}",
            self.shape.name(),
            self.radius_mm,
            self.clearance_mm
        );
        if self.peg_chamfer_mm > 0.0 || self.hole_chamfer_mm > 0.0 {
            s.push_str("-chamfer");
        }
        if self.tilt_rad != 0.0 {
            s.push_str("-tilted");
        }
        s
    }

    /// Checks the dimensions: a one-line error naming the first that is out of range.
    pub fn validate(&self) -> Result<(), SceneError> {
        let name = self.name();
        let bad = |msg: String| Err(SceneError::scene(&name, msg));
        let positive = [
            ("radius_mm", self.radius_mm),
            ("clearance_mm", self.clearance_mm),
            ("peg_length_mm", self.peg_length_mm),
            ("block_height_mm", self.block_height_mm),
            ("depth_mm", self.depth_mm),
            ("speed_mm_s", self.speed_mm_s),
        ];
        for (key, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return bad(format!("{key} = {v}: must be a positive number"));
            }
        }
        for (key, v) in [
            ("peg_chamfer_mm", self.peg_chamfer_mm),
            ("hole_chamfer_mm", self.hole_chamfer_mm),
        ] {
            if !(v.is_finite() && v >= 0.0 && v < 0.5 * self.radius_mm) {
                return bad(format!(
                    "{key} = {v}: must be at least 0 and less than half the radius ({} mm)",
                    0.5 * self.radius_mm
                ));
            }
        }
        if !(self.tilt_rad.is_finite() && self.tilt_rad.abs() <= 0.3) {
            return bad(format!(
                "tilt_rad = {}: must be within ±0.3 rad",
                self.tilt_rad
            ));
        }
        if self.depth_mm + ENTER_MM > self.peg_length_mm {
            return bad(format!(
                "depth_mm = {}: the peg ({} mm) must stick out of the mouth by {ENTER_MM} mm at full depth",
                self.depth_mm, self.peg_length_mm
            ));
        }
        if self.depth_mm <= ENTER_MM || self.depth_mm >= self.block_height_mm {
            return bad(format!(
                "depth_mm = {}: must lie between {ENTER_MM} mm and the block height ({} mm)",
                self.depth_mm, self.block_height_mm
            ));
        }
        if self.peg_chamfer_mm >= self.peg_length_mm || self.hole_chamfer_mm >= self.block_height_mm
        {
            return bad("a chamfer longer than its part".into());
        }
        if !(1..=7).contains(&self.tree_depth) {
            return bad(format!("tree_depth = {}: must be 1..=7", self.tree_depth));
        }
        Ok(())
    }

    /// The splined shaft's parameters for this peg (splined shape): six keys `0.3 · radius`
    /// high, the shaft's clearance, arcs sampled every 1.5°.
    pub fn spline(&self) -> SplineParams {
        SplineParams {
            root_radius: self.radius_mm,
            key_height: 0.3 * self.radius_mm,
            clearance: self.clearance_mm,
            shaft_length: self.peg_length_mm,
            hub_height: self.block_height_mm,
            max_arc_step: 1.5f64.to_radians(),
            max_ring_spacing: MAX_RING_SPACING_MM,
            ..SplineParams::default()
        }
    }

    /// Sides of the round profile's polygon: enough for [`MAX_SAGITTA_MM`] on the hole's
    /// circle, a multiple of 8, at least 32.
    pub fn round_segments(&self) -> u32 {
        let r = self.radius_mm + self.clearance_mm;
        let half_step = (1.0 - MAX_SAGITTA_MM / r).clamp(-1.0, 1.0).acos();
        let n = (PI / half_step.max(1e-6)).ceil() as u32;
        n.clamp(32, 4096).div_ceil(8) * 8
    }

    /// The polar profile `(theta, r)` of the peg (`hole = false`) or of the hole, angles
    /// increasing in `[0, 2 pi)`, radii mm.
    pub fn profile(&self, hole: bool) -> Vec<(f64, f64)> {
        match self.shape {
            FitShape::Round => {
                let n = self.round_segments();
                let r = self.radius_mm + if hole { self.clearance_mm } else { 0.0 };
                (0..n)
                    .map(|i| (2.0 * PI * f64::from(i) / f64::from(n), r))
                    .collect()
            }
            FitShape::Splined => self.spline().profile(hole),
        }
    }

    /// Radius of the block's outer wall, mm: 10 mm (or the radius, if larger) outside the
    /// hole's widest point.
    pub fn block_radius_mm(&self) -> f64 {
        let widest = self.profile(true).iter().map(|p| p.1).fold(0.0, f64::max);
        widest + self.hole_chamfer_mm + self.radius_mm.max(10.0)
    }

    /// The peg mesh in the tool frame (tip at `z = 0`, along `+z`), mm.
    pub fn peg_mesh(&self) -> TriMesh {
        let c = self.peg_chamfer_mm;
        // Pulled in by c at the tip, 0 from z = c on.
        let stations = stations(0.0, self.peg_length_mm, (c > 0.0).then_some(c), |z| {
            (c - z).max(0.0)
        });
        let prof = self.profile(false);
        let rings: Vec<Vec<(f64, f64)>> = stations
            .iter()
            .map(|&(_, inset)| prof.iter().map(|&(a, r)| (a, r - inset)).collect())
            .collect();
        let zs: Vec<f64> = stations.iter().map(|s| s.0).collect();
        solid_of_rings(&zs, &rings)
    }

    /// The block mesh in the world (mouth at `z = 0`, through hole down to
    /// `z = -block_height_mm`), mm.
    pub fn block_mesh(&self) -> TriMesh {
        let c = self.hole_chamfer_mm;
        let h = self.block_height_mm;
        let stations = stations(-h, 0.0, (c > 0.0).then_some(-c), |z| (z + c).max(0.0));
        let prof = self.profile(true);
        let outer = self.block_radius_mm();
        let zs: Vec<f64> = stations.iter().map(|s| s.0).collect();
        let inner: Vec<Vec<(f64, f64)>> = stations
            .iter()
            .map(|&(_, grow)| prof.iter().map(|&(a, r)| (a, r + grow)).collect())
            .collect();
        tube_of_rings(&zs, &inner, outer)
    }
}

/// Ring heights from `z0` to `z1` (at most [`MAX_RING_SPACING_MM`] apart) with a ring at
/// `cut` (where a chamfer ends), each with its radial offset `offset(z)`, mm.
fn stations(z0: f64, z1: f64, cut: Option<f64>, offset: impl Fn(f64) -> f64) -> Vec<(f64, f64)> {
    let mut cuts = vec![z0, z1];
    cuts.extend(cut.filter(|&z| z > z0 && z < z1));
    cuts.sort_by(f64::total_cmp);
    let mut zs = Vec::new();
    for w in cuts.windows(2) {
        let n = ((w[1] - w[0]) / MAX_RING_SPACING_MM).ceil().max(1.0) as usize;
        for i in 0..n {
            zs.push(w[0] + (w[1] - w[0]) * i as f64 / n as f64);
        }
    }
    zs.push(z1);
    zs.into_iter().map(|z| (z, offset(z))).collect()
}

/// A closed solid from rings of polar points (`rings[j]` at height `zs[j]`, the same angles on
/// every ring), capped by fans at both ends; normals outwards.
fn solid_of_rings(zs: &[f64], rings: &[Vec<(f64, f64)>]) -> TriMesh {
    let m = rings.first().map_or(0, Vec::len) as u32;
    let last = (rings.len() as u32).saturating_sub(1);
    let mut mesh = TriMesh::default();
    for (z, ring) in zs.iter().zip(rings) {
        for &(a, r) in ring {
            mesh.vertices.push([r * a.cos(), r * a.sin(), *z]);
        }
    }
    let v = |j: u32, i: u32| j * m + (i % m);
    for j in 0..last {
        for i in 0..m {
            mesh.triangles.push([v(j, i), v(j, i + 1), v(j + 1, i + 1)]);
            mesh.triangles.push([v(j, i), v(j + 1, i + 1), v(j + 1, i)]);
        }
    }
    let cb = mesh.vertices.len() as u32;
    mesh.vertices.push([0.0, 0.0, zs[0]]);
    let ct = cb + 1;
    mesh.vertices.push([0.0, 0.0, zs[last as usize]]);
    for i in 0..m {
        mesh.triangles.push([cb, v(0, i + 1), v(0, i)]);
        mesh.triangles.push([ct, v(last, i), v(last, i + 1)]);
    }
    mesh
}

/// A closed block with a through hole: the hole's wall from `inner` rings (at heights `zs`),
/// a cylindrical outer wall of radius `outer` at the same heights and angles, annuli at both
/// ends; normals outwards (into the hole on its wall).
fn tube_of_rings(zs: &[f64], inner: &[Vec<(f64, f64)>], outer: f64) -> TriMesh {
    let m = inner.first().map_or(0, Vec::len) as u32;
    let last = (inner.len() as u32).saturating_sub(1);
    let mut mesh = TriMesh::default();
    for (z, ring) in zs.iter().zip(inner) {
        for &(a, r) in ring {
            mesh.vertices.push([r * a.cos(), r * a.sin(), *z]);
        }
    }
    let outer0 = mesh.vertices.len() as u32;
    for (z, ring) in zs.iter().zip(inner) {
        for &(a, _) in ring {
            mesh.vertices.push([outer * a.cos(), outer * a.sin(), *z]);
        }
    }
    let vin = |j: u32, i: u32| j * m + (i % m);
    let vout = |j: u32, i: u32| outer0 + j * m + (i % m);
    for j in 0..last {
        for i in 0..m {
            mesh.triangles
                .push([vin(j, i), vin(j + 1, i + 1), vin(j, i + 1)]);
            mesh.triangles
                .push([vin(j, i), vin(j + 1, i), vin(j + 1, i + 1)]);
            mesh.triangles
                .push([vout(j, i), vout(j, i + 1), vout(j + 1, i + 1)]);
            mesh.triangles
                .push([vout(j, i), vout(j + 1, i + 1), vout(j + 1, i)]);
        }
    }
    for i in 0..m {
        let (a0, a1, b0, b1) = (
            vin(last, i),
            vin(last, i + 1),
            vout(last, i),
            vout(last, i + 1),
        );
        mesh.triangles.push([a0, b0, b1]);
        mesh.triangles.push([a0, b1, a1]);
        let (a0, a1, b0, b1) = (vin(0, i), vin(0, i + 1), vout(0, i), vout(0, i + 1));
        mesh.triangles.push([a0, b1, b0]);
        mesh.triangles.push([a0, a1, b1]);
    }
    mesh
}

/// When the fit script does what, s from its start.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FitPhases {
    /// Times when the hand is far from the block (the tool must follow it exactly), s.
    pub free_s: Vec<(f64, f64)>,
    /// From the start of the approach to 1 mm above the mouth, s.
    pub approach_s: (f64, f64),
    /// Entering (to [`ENTER_MM`] below the mouth, straightening a tilt) and inserting to full
    /// depth, s.
    pub insert_s: (f64, f64),
    /// The hold at full depth, s.
    pub hold_s: (f64, f64),
    /// The withdrawal to the start, s.
    pub withdraw_s: (f64, f64),
}

/// A peg-in-hole scene: the scene (its motion is the script), its parameters and phases.
#[derive(Clone, Debug)]
pub struct FitScene {
    /// The scene; its goal is the insertion to full depth.
    pub scene: Scene,
    /// The peg, hole and stroke.
    pub params: FitParams,
    /// The script's phases.
    pub phases: FitPhases,
}

/// Tree parameters of the zoo's builder at `depth`.
fn tight(depth: u32) -> TreeParams {
    TreeParams {
        depth,
        branching: 8,
        method: spheretree::build::BuildMethod::Tight,
    }
}

/// The radial clearances of the clearance study (`haptic6d bench --studies fit`), mm.
pub const STUDY_CLEARANCES_MM: [f64; 5] = [0.5, 0.2, 0.1, 0.05, 0.02];

/// Tilt of the study's tilted approaches about `x`, rad (2°).
pub const STUDY_TILT_RAD: f64 = 0.035;

/// One peg of the clearance study before its clearance: shape, radius and chamfers (peg tip
/// and hole mouth alike), mm, and whether it comes in tilted by [`STUDY_TILT_RAD`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StudyCase {
    /// The peg's cross-section.
    pub shape: FitShape,
    /// Peg radius (round) or root radius (splined), mm.
    pub radius_mm: f64,
    /// Chamfer at the peg's tip and at the hole's mouth, mm (0 for none).
    pub chamfer_mm: f64,
    /// Approached tilted.
    pub tilted: bool,
}

impl StudyCase {
    /// The case at `clearance_mm` (the rest as [`FitParams::default`]).
    pub fn params(&self, clearance_mm: f64) -> FitParams {
        FitParams {
            shape: self.shape,
            radius_mm: self.radius_mm,
            clearance_mm,
            peg_chamfer_mm: self.chamfer_mm,
            hole_chamfer_mm: self.chamfer_mm,
            tilt_rad: if self.tilted { STUDY_TILT_RAD } else { 0.0 },
            ..FitParams::default()
        }
    }
}

const fn case(shape: FitShape, radius_mm: f64, chamfer_mm: f64, tilted: bool) -> StudyCase {
    StudyCase {
        shape,
        radius_mm,
        chamfer_mm,
        tilted,
    }
}

/// The study's pegs, each at every clearance of [`STUDY_CLEARANCES_MM`]: a round peg of radius
/// 10 mm with and without 1 mm chamfers, one of 3 mm with 0.5 mm chamfers, the splined shaft
/// (root radius 10 mm, six keys) with and without 1 mm chamfers; each straight and tilted.
pub const STUDY_CASES: [StudyCase; 10] = [
    case(FitShape::Round, 10.0, 0.0, false),
    case(FitShape::Round, 10.0, 0.0, true),
    case(FitShape::Round, 10.0, 1.0, false),
    case(FitShape::Round, 10.0, 1.0, true),
    case(FitShape::Round, 3.0, 0.5, false),
    case(FitShape::Round, 3.0, 0.5, true),
    case(FitShape::Splined, 10.0, 0.0, false),
    case(FitShape::Splined, 10.0, 0.0, true),
    case(FitShape::Splined, 10.0, 1.0, false),
    case(FitShape::Splined, 10.0, 1.0, true),
];

/// The clearance study's row named `name` ([`FitParams::name`], as `fit/round-r10-c0.05`), so
/// that every row is runnable by name (`haptic6d run fit/round-r10-c0.05-chamfer`).
pub fn study_params(name: &str) -> Option<FitParams> {
    STUDY_CASES
        .iter()
        .flat_map(|case| STUDY_CLEARANCES_MM.iter().map(|&c| case.params(c)))
        .find(|p| p.name() == name)
}

/// The peg-in-hole scene of `p`, trees from `cache` or built.
pub fn fit_scene(p: &FitParams, cache: &TreeCache) -> Result<FitScene, SceneError> {
    p.validate()?;
    let name = p.name();
    let peg = p.peg_mesh();
    let block = p.block_mesh();
    let mut log = Vec::new();
    let tool = crate::tree_for_mesh(
        &peg,
        tight(p.tree_depth),
        cache,
        &format!("{name} peg"),
        &mut log,
    )?;
    let block_tree = crate::object_tree_for_mesh(
        &block,
        tight(p.tree_depth),
        cache,
        &format!("{name} block"),
        &mut log,
    )?;
    let at = |z: f64, tilt: f64| [0.0, 0.0, z, tilt, 0.0, 0.0];
    let start = at(START_HEIGHT_MM, p.tilt_rad);
    let rest = 0.2;
    let v = p.speed_mm_s;
    let script = Script::starting_at(start).hold(rest);
    let approach0 = script.duration();
    let script = script.then(0.6, at(APPROACH_HEIGHT_MM, p.tilt_rad), Ease::Smooth);
    let insert0 = script.duration();
    let script = script
        .then(
            (APPROACH_HEIGHT_MM + ENTER_MM) / v,
            at(-ENTER_MM, 0.0),
            Ease::Smooth,
        )
        .then(
            (p.depth_mm - ENTER_MM) / v,
            at(-p.depth_mm, 0.0),
            Ease::Smooth,
        );
    let hold0 = script.duration();
    let script = script.hold(0.3);
    let withdraw0 = script.duration();
    let script = script
        .then(
            (p.depth_mm + START_HEIGHT_MM) / (2.0 * v),
            at(START_HEIGHT_MM, 0.0),
            Ease::Smooth,
        )
        .hold(0.3);
    let end = script.duration();
    let scene = Scene {
        name: name.clone(),
        tool,
        tool_mesh: Some(peg),
        objects: vec![(block_tree, Pose::identity())],
        object_meshes: vec![Some(block)],
        coupling: Coupling::default(),
        solver: SolverSpec::default(),
        safety: SafetyParams::default(),
        start: Pose::from_array(start),
        rate_hz: 1000.0,
        motion: Motion::Script(script),
        goal: Some(Goal::InsertZ {
            target_z_mm: -p.depth_mm,
            tol_mm: FULL_DEPTH_TOL_MM,
        }),
        device: Default::default(),
        load_log: log,
        object_friction: Vec::new(),
        tool_friction: None,
    };
    scene.validate()?;
    Ok(FitScene {
        scene,
        params: *p,
        phases: FitPhases {
            free_s: vec![(0.0, rest), (end - 0.2, end)],
            approach_s: (approach0, insert0),
            insert_s: (insert0, hold0),
            hold_s: (hold0, withdraw0),
            withdraw_s: (withdraw0, end - 0.3),
        },
    })
}

/// Radius of the sharp-edge case's cylinder, mm.
pub const EDGE_CYLINDER_RADIUS_MM: f64 = 5.0;
/// How far below the block's top the hand holds the cylinder's lowest line, mm.
pub const EDGE_PRESS_MM: f64 = 0.5;
/// Where the sharp-edge case's hand slides from and to along `x` (the edge at `x = 0`), mm.
pub const EDGE_SLIDE_FROM_MM: f64 = -30.0;
/// … and the far end of the slide, past the edge, mm.
pub const EDGE_SLIDE_TO_MM: f64 = 15.0;

/// The sharp-edge case: a cylinder (radius [`EDGE_CYLINDER_RADIUS_MM`], 20 mm long, 64 sides,
/// lying along `y`) pressed [`EDGE_PRESS_MM`] into the flat top of a meshed block (its top at
/// `z = 0`, a 90° edge along `y` at `x = 0`), slid at `speed_mm_s` over the edge and off it,
/// and back over it. The hand keeps its height: past the edge the cylinder leaves the block,
/// and on the way back it meets the edge below its axis and rides up over it. What the hand
/// feels should turn with the contact, without jumps.
pub fn sharp_edge_scene(speed_mm_s: f64, cache: &TreeCache) -> Result<Scene, SceneError> {
    if speed_mm_s.is_nan() || speed_mm_s <= 0.0 || speed_mm_s.is_infinite() {
        return Err(SceneError::scene(
            "sharp edge",
            format!("speed {speed_mm_s} mm/s must be a positive number"),
        ));
    }
    let r = EDGE_CYLINDER_RADIUS_MM;
    let ring: Vec<(f64, f64)> = (0..64)
        .map(|i| (2.0 * PI * f64::from(i) / 64.0, r))
        .collect();
    let cylinder = solid_of_rings(&[-10.0, 10.0], &[ring.clone(), ring]);
    let block = super::plate::box_mesh([-60.0, -20.0, -30.0], [0.0, 20.0, 0.0]);
    let name = format!("sharp edge, {speed_mm_s} mm/s");
    let mut log = Vec::new();
    let tool = crate::tree_for_mesh(&cylinder, tight(4), cache, "sharp-edge cylinder", &mut log)?;
    let block_tree =
        crate::object_tree_for_mesh(&block, tight(4), cache, "sharp-edge block", &mut log)?;
    // Turned a quarter about x: the cylinder's axis (z in its own frame) along y.
    let at = |x: f64, z: f64| [x, 0.0, z, std::f64::consts::FRAC_PI_2, 0.0, 0.0];
    let pressed = r - EDGE_PRESS_MM;
    let slide_s = (EDGE_SLIDE_TO_MM - EDGE_SLIDE_FROM_MM) / speed_mm_s;
    let script = Script::starting_at(at(EDGE_SLIDE_FROM_MM, r + 10.0))
        .hold(0.2)
        .then(0.5, at(EDGE_SLIDE_FROM_MM, pressed), Ease::Smooth)
        .hold(0.2)
        .then(slide_s, at(EDGE_SLIDE_TO_MM, pressed), Ease::Linear)
        .hold(0.2)
        .then(slide_s, at(EDGE_SLIDE_FROM_MM, pressed), Ease::Linear)
        .hold(0.2)
        .then(0.5, at(EDGE_SLIDE_FROM_MM, r + 10.0), Ease::Smooth);
    let scene = Scene {
        name,
        tool,
        tool_mesh: Some(cylinder),
        objects: vec![(block_tree, Pose::identity())],
        object_meshes: vec![Some(block)],
        coupling: Coupling::default(),
        solver: SolverSpec::default(),
        safety: SafetyParams::default(),
        start: Pose::from_array(at(EDGE_SLIDE_FROM_MM, r + 10.0)),
        rate_hz: 1000.0,
        motion: Motion::Script(script),
        goal: None,
        device: Default::default(),
        load_log: log,
        object_friction: Vec::new(),
        tool_friction: None,
    };
    scene.validate()?;
    Ok(scene)
}

/// What a replay of a fit scene did.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct FitOutcome {
    /// Deepest the peg's tip (the tool's origin) got below the hole's mouth, mm.
    pub depth_reached_mm: f64,
    /// The tip reached full depth (within [`FULL_DEPTH_TOL_MM`]).
    pub full_depth: bool,
    /// Largest force the spring sent, N.
    pub force_max_n: f64,
    /// Frames that ended lagging.
    pub lagging: usize,
    /// Frames that ended lagging, with a pair overflow, or kept the last safe pose.
    pub degraded: usize,
    /// Whole step per frame, µs.
    pub total_us: Summary,
}

impl FitScene {
    /// The outcome of `frames`, the scene's script replayed (one frame per trajectory sample).
    pub fn outcome(&self, frames: &[FrameOutput]) -> FitOutcome {
        let depth = frames
            .iter()
            .filter(|f| f.status != FrameStatus::KeptLastSafe)
            .map(|f| -f.q_g[2])
            .fold(0.0, f64::max);
        let norm3 = |w: &[f64]| w.iter().map(|x| x * x).sum::<f64>().sqrt();
        FitOutcome {
            depth_reached_mm: depth,
            full_depth: depth >= self.params.depth_mm - FULL_DEPTH_TOL_MM,
            force_max_n: frames
                .iter()
                .map(|f| norm3(&f.wrench[..3]))
                .fold(0.0, f64::max),
            lagging: frames
                .iter()
                .filter(|f| f.status == FrameStatus::Lagging)
                .count(),
            degraded: frames.iter().filter(|f| f.status.is_degraded()).count(),
            total_us: Summary::of(frames.iter().map(|f| f.total_us)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_study_row_is_found_by_its_own_name_and_no_other() {
        let mut names = std::collections::HashSet::new();
        for case in &STUDY_CASES {
            for &c in &STUDY_CLEARANCES_MM {
                let p = case.params(c);
                assert!(names.insert(p.name()), "two rows named {}", p.name());
                assert_eq!(study_params(&p.name()), Some(p));
                assert!(crate::scenes::is_builtin(&p.name()));
            }
        }
        assert_eq!(names.len(), 50);
        assert_eq!(study_params("fit/round-r10-c0.07"), None);
        assert!(!crate::scenes::is_builtin("fit/round-r10-c0.07"));
    }

    #[test]
    fn bad_dimensions_are_one_line_errors() {
        let p = FitParams {
            clearance_mm: -0.1,
            ..FitParams::default()
        };
        let e = p.validate().unwrap_err().to_string();
        assert!(e.contains("clearance_mm") && !e.contains('\n'), "{e}");
        let p = FitParams {
            depth_mm: 45.0,
            ..FitParams::default()
        };
        assert!(p.validate().is_err());
        assert!(FitParams::default().validate().is_ok());
    }

    #[test]
    fn stations_put_a_ring_where_the_chamfer_ends() {
        let s = stations(0.0, 40.0, Some(1.0), |z| (1.0 - z).max(0.0));
        assert_eq!(s[0], (0.0, 1.0));
        assert_eq!(s[1], (1.0, 0.0));
        assert!(s
            .windows(2)
            .all(|w| w[1].0 > w[0].0 && w[1].0 - w[0].0 <= MAX_RING_SPACING_MM + 1e-12));
        assert_eq!(s.last().unwrap().0, 40.0);
        let s = stations(-30.0, 0.0, Some(-0.5), |z| (z + 0.5).max(0.0));
        assert_eq!(s[s.len() - 2], (-0.5, 0.0));
        assert_eq!(s.last().copied(), Some((0.0, 0.5)));
    }
}
