//! The `probe` scene: a periodontal probe slid down a gingival pocket to its floor, on the
//! parts' own triangles ([`engine::Geometry::Mesh`]): the pocket is 0.1 mm wider than the
//! probe's tip, less than the leaf spheres' overhang.
//!
//! Parts (generated closed meshes, mm; `+z` up, the pocket's mouth at `z = 0`):
//! - the **probe** (tool frame): a rod of radius [`ProbeParams::tip_radius_mm`] with a
//!   hemispherical tip whose lowest point is the tool's origin, tapering higher up to a thicker
//!   shank, along `+z`;
//! - the **tooth** (world): a block whose face towards `+x` is the root surface, curved about
//!   the tooth's axis (a cylinder of [`ProbeParams::tooth_radius_mm`], its nearest line at
//!   `x = -width / 2`) and cut by shallow grooves running round the tooth, standing
//!   [`ProbeParams::crown_height_mm`] above the mouth;
//! - the **gingiva** (world): a block whose face towards `-x` follows the tooth's curve
//!   [`ProbeParams::pocket_width_mm`] farther out, its top at the mouth;
//! - the **pocket floor** (world): a slab closing the pocket at `z = -depth`, reaching into
//!   both walls.
//!
//! All three are rigid. The pocket is narrowest (its width) on the grooves' crests at `y = 0`.
//!
//! The script ([`ProbePhases`] holds its times): rest above the pocket, bring the tip to just
//! above the mouth, lean it against the tooth, slide it down the root surface past the floor
//! (the floor stops the tip: a light press), hold, come away from the tooth while drawing it
//! out, return to the start and rest. The goal is the tip at the floor.

use std::f64::consts::PI;

use collide::Pose;
use engine::safety::SafetyParams;
use mesh::generate;
use mesh::TriMesh;

use super::plate::box_mesh;
use crate::cache::TreeCache;
use crate::trajectory::{Ease, Script};
use crate::{Coupling, Goal, Motion, Scene, SceneError, SolverSpec, TreeParams};

/// The scene's name.
pub const NAME: &str = "probe";

/// The tip counts as at the pocket's floor within this of it, mm.
pub const GOAL_TOL_MM: f64 = 0.05;

/// Height of the tip above the mouth at the start and end of the script, mm.
pub const START_HEIGHT_MM: f64 = 5.0;

/// Height of the tip above the mouth where the hand leans it against the tooth, mm.
pub const ENTRY_HEIGHT_MM: f64 = 0.5;

/// Sides of the probe's cross-section (its flats stand 1.9 % of the radius inside the circle:
/// 0.245 mm at the default tip).
pub const PROBE_SEGMENTS: u32 = 16;

/// Largest spacing of the root surface's grid, mm (eight samples a groove at the default
/// 1 mm period).
pub const TOOTH_GRID_MM: f64 = 0.125;

/// Largest spacing of the gingiva's grid, mm (the smooth curve sags 0.002 mm between samples
/// at the default tooth radius).
pub const GINGIVA_GRID_MM: f64 = 0.25;

/// Depth of the sphere-trees (tight, branching 8): the mesh mode keeps only their roots, the
/// sphere geometry (`--geometry spheres`) their leaves.
pub const TREE_DEPTH: u32 = 4;

/// Dimensions of the probe, the pocket and the hand's stroke (mm, mm/s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProbeParams {
    /// Radius of the probe's working end and of its hemispherical tip, mm.
    pub tip_radius_mm: f64,
    /// Length of the thin working end from the tip to where it starts to taper, mm.
    pub working_length_mm: f64,
    /// Length of the taper to the shank, mm.
    pub taper_length_mm: f64,
    /// Radius of the shank, mm.
    pub shank_radius_mm: f64,
    /// Whole length of the probe, mm.
    pub probe_length_mm: f64,
    /// Width of the pocket between the grooves' crests and the gingiva at `y = 0`, mm.
    pub pocket_width_mm: f64,
    /// Depth of the pocket's floor below the mouth, mm.
    pub pocket_depth_mm: f64,
    /// Length of the pocket along the tooth (`y`), mm.
    pub pocket_length_mm: f64,
    /// Radius of the root surface's curve about the tooth's axis (parallel to `z`), mm.
    pub tooth_radius_mm: f64,
    /// Depth of the grooves in the root surface, mm.
    pub groove_depth_mm: f64,
    /// Period of the grooves along `z`, mm.
    pub groove_period_mm: f64,
    /// Height of the tooth above the mouth, mm.
    pub crown_height_mm: f64,
    /// How far past the tooth's surface the hand leans the probe while sliding, mm (the
    /// coupling turns it into a light sideways push).
    pub lean_mm: f64,
    /// How far below the floor the hand goes at the bottom, mm (a press of the coupling's
    /// stiffness times this).
    pub press_mm: f64,
    /// Mean hand speed down the pocket, mm/s.
    pub slide_speed_mm_s: f64,
}

impl Default for ProbeParams {
    /// A 0.5 mm probe tip in a 0.6 mm pocket 4 mm deep along a 4 mm root curve with
    /// 0.03 mm grooves every mm; leaning 0.1 mm, pressing 0.25 mm (0.25 N at the default
    /// coupling, a probing force), sliding at 3 mm/s.
    fn default() -> Self {
        Self {
            tip_radius_mm: 0.25,
            working_length_mm: 8.0,
            taper_length_mm: 2.0,
            shank_radius_mm: 0.6,
            probe_length_mm: 16.0,
            pocket_width_mm: 0.6,
            pocket_depth_mm: 4.0,
            pocket_length_mm: 6.0,
            tooth_radius_mm: 4.0,
            groove_depth_mm: 0.03,
            groove_period_mm: 1.0,
            crown_height_mm: 2.0,
            lean_mm: 0.1,
            press_mm: 0.25,
            slide_speed_mm_s: 3.0,
        }
    }
}

/// How far below the floor the walls reach (into the floor slab), mm.
const BELOW_FLOOR_MM: f64 = 1.5;

/// Least thickness of the tooth and gingiva blocks behind their faces, mm.
const WALL_MM: f64 = 3.0;

impl ProbeParams {
    /// Checks the dimensions: a one-line error naming the first that is out of range.
    pub fn validate(&self) -> Result<(), SceneError> {
        let bad = |msg: String| Err(SceneError::scene(NAME, msg));
        let positive = [
            ("tip_radius_mm", self.tip_radius_mm),
            ("working_length_mm", self.working_length_mm),
            ("taper_length_mm", self.taper_length_mm),
            ("shank_radius_mm", self.shank_radius_mm),
            ("probe_length_mm", self.probe_length_mm),
            ("pocket_width_mm", self.pocket_width_mm),
            ("pocket_depth_mm", self.pocket_depth_mm),
            ("pocket_length_mm", self.pocket_length_mm),
            ("tooth_radius_mm", self.tooth_radius_mm),
            ("groove_period_mm", self.groove_period_mm),
            ("crown_height_mm", self.crown_height_mm),
            ("slide_speed_mm_s", self.slide_speed_mm_s),
        ];
        for (key, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return bad(format!("{key} = {v}: must be a positive number"));
            }
        }
        for (key, v) in [
            ("groove_depth_mm", self.groove_depth_mm),
            ("lean_mm", self.lean_mm),
            ("press_mm", self.press_mm),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return bad(format!("{key} = {v}: must be at least 0"));
            }
        }
        if self.pocket_length_mm >= 2.0 * self.tooth_radius_mm {
            return bad(format!(
                "pocket_length_mm = {}: must be shorter than the tooth's diameter ({} mm)",
                self.pocket_length_mm,
                2.0 * self.tooth_radius_mm
            ));
        }
        if self.shank_radius_mm < self.tip_radius_mm {
            return bad("the shank must be at least as thick as the tip".into());
        }
        // With the tip at the floor, the taper must start above the crown (a thicker shank
        // would meet the tooth).
        let taper_above_crown =
            self.working_length_mm - self.pocket_depth_mm - self.crown_height_mm;
        if taper_above_crown <= 0.0 {
            return bad(format!(
                "working_length_mm = {}: must exceed the pocket's depth and the crown ({} mm)",
                self.working_length_mm,
                self.pocket_depth_mm + self.crown_height_mm
            ));
        }
        if self.working_length_mm + self.taper_length_mm >= self.probe_length_mm {
            return bad("the working end and taper must be shorter than the probe".into());
        }
        Ok(())
    }

    /// How far the root surface's curve falls back from its nearest line at `y` (mm), mm.
    fn curve_mm(&self, y: f64) -> f64 {
        let r = self.tooth_radius_mm;
        r - (r * r - y * y).max(0.0).sqrt()
    }

    /// The root surface's `x` at `(y, z)` (mm): the curve, less a groove whose crests
    /// (`z` a multiple of the period) lie on the pocket's narrowest width, mm.
    pub fn tooth_surface_x(&self, y: f64, z: f64) -> f64 {
        let groove = (PI * z / self.groove_period_mm).sin().powi(2);
        -0.5 * self.pocket_width_mm - self.curve_mm(y) - self.groove_depth_mm * groove
    }

    /// The gingiva's surface `x` at `y` (mm): the tooth's curve a pocket width farther out.
    pub fn gingiva_surface_x(&self, y: f64) -> f64 {
        0.5 * self.pocket_width_mm - self.curve_mm(y)
    }

    /// The probe mesh in the tool frame (tip's lowest point at the origin, along `+z`), mm.
    pub fn probe_mesh(&self) -> TriMesh {
        let r = self.tip_radius_mm;
        let bands = (PROBE_SEGMENTS / 4).max(2);
        let mut profile = vec![(0.0, 0.0)];
        for i in 1..=bands {
            let a = 0.5 * PI * f64::from(i) / f64::from(bands);
            profile.push((r * a.sin(), r * (1.0 - a.cos())));
        }
        // Rings along the thin end no further apart than 4 radii (no long slivers).
        let straight = (self.working_length_mm - r).max(0.0);
        let steps = ((straight / (4.0 * r)).ceil() as u32).max(1);
        for i in 1..=steps {
            profile.push((r, r + straight * f64::from(i) / f64::from(steps)));
        }
        let shank_start = self.working_length_mm + self.taper_length_mm;
        profile.push((self.shank_radius_mm, shank_start));
        profile.push((self.shank_radius_mm, self.probe_length_mm));
        profile.push((0.0, self.probe_length_mm));
        generate::lathe(&profile, PROBE_SEGMENTS)
    }

    /// The heights the walls span, from the bottom up: `(z_low, z_high)` of the tooth, mm.
    fn tooth_span(&self) -> (f64, f64) {
        (-self.pocket_depth_mm - BELOW_FLOOR_MM, self.crown_height_mm)
    }

    /// The tooth block in the world (its root surface facing `+x`), mm.
    pub fn tooth_mesh(&self) -> TriMesh {
        let (z0, z1) = self.tooth_span();
        let back = -0.5 * self.pocket_width_mm
            - self.curve_mm(0.5 * self.pocket_length_mm)
            - self.groove_depth_mm
            - WALL_MM;
        // A height field over (y, z) whose height is x: the grid's (u, v, h) is the world's
        // (y, z - zc, x), a cyclic turn of the axes (orientation kept).
        let zc = 0.5 * (z0 + z1);
        let n = grid_steps(self.pocket_length_mm.max(z1 - z0), TOOTH_GRID_MM);
        let m = generate::height_field_block(
            0.5 * self.pocket_length_mm,
            0.5 * (z1 - z0),
            back,
            n,
            |u, v| self.tooth_surface_x(u, v + zc),
        );
        map_vertices(m, |[u, v, h]| [h, u, v + zc])
    }

    /// The gingiva block in the world (its face towards `-x`, top at the mouth), mm.
    pub fn gingiva_mesh(&self) -> TriMesh {
        let (z0, z1) = (-self.pocket_depth_mm - BELOW_FLOOR_MM, 0.0);
        let back = 0.5 * self.pocket_width_mm + WALL_MM;
        // The grid's (u, v, h) is the world's (-y, z - zc, -x): a turn (orientation kept).
        let zc = 0.5 * (z0 + z1);
        let n = grid_steps(self.pocket_length_mm.max(z1 - z0), GINGIVA_GRID_MM);
        let m = generate::height_field_block(
            0.5 * self.pocket_length_mm,
            0.5 * (z1 - z0),
            -back,
            n,
            |u, _| -self.gingiva_surface_x(-u),
        );
        map_vertices(m, |[u, v, h]| [-h, -u, v + zc])
    }

    /// The pocket's floor in the world: a slab under `z = -pocket_depth_mm` across the pocket
    /// and into both walls, mm.
    pub fn floor_mesh(&self) -> TriMesh {
        let half = 0.5 * self.pocket_length_mm;
        // 1 mm into each wall beyond the pocket's farthest reach, so no gap is left below it.
        let lo_x = -0.5 * self.pocket_width_mm - self.curve_mm(half) - self.groove_depth_mm - 1.0;
        let hi_x = 0.5 * self.pocket_width_mm + 1.0;
        let top = -self.pocket_depth_mm;
        box_mesh([lo_x, -half, top - 1.0], [hi_x, half, top])
    }
}

/// Grid steps over `extent` (mm) no wider than `spacing` (mm), at least 1.
fn grid_steps(extent: f64, spacing: f64) -> u32 {
    ((extent / spacing).ceil() as u32).max(1)
}

/// `mesh` with every vertex mapped by `f` (a rigid motion: triangles keep their order).
fn map_vertices(mut mesh: TriMesh, f: impl Fn([f64; 3]) -> [f64; 3]) -> TriMesh {
    for v in &mut mesh.vertices {
        *v = f(*v);
    }
    mesh
}

/// When the probe's script does what, s from its start.
#[derive(Clone, Debug, PartialEq)]
pub struct ProbePhases {
    /// Times when the hand is far from every part (the tool must follow it exactly), s.
    pub free_s: Vec<(f64, f64)>,
    /// The slide down the pocket, from the lean at the mouth to past the floor, s.
    pub slide_s: (f64, f64),
    /// The hold at the floor, the hand past it: the tip must rest on the floor, s.
    pub pressed_s: (f64, f64),
    /// The withdrawal out of the pocket and back to the start, s.
    pub withdraw_s: (f64, f64),
}

/// The probe scene: the scene (its motion is the script), its dimensions and phases.
#[derive(Clone, Debug)]
pub struct ProbeScene {
    /// The scene; its goal is the tip at the pocket's floor.
    pub scene: Scene,
    /// The probe, the pocket and the stroke.
    pub params: ProbeParams,
    /// The script's phases.
    pub phases: ProbePhases,
}

/// Tree parameters of the built-ins' builder at `depth`.
fn tight(depth: u32) -> TreeParams {
    TreeParams {
        depth,
        branching: 8,
        method: spheretree::build::BuildMethod::Tight,
    }
}

/// The probe scene of `p`, trees from `cache` or built; the built-in `probe` is
/// `probe_scene(&ProbeParams::default(), cache)`.
pub fn probe_scene(p: &ProbeParams, cache: &TreeCache) -> Result<ProbeScene, SceneError> {
    p.validate()?;
    let probe = p.probe_mesh();
    let parts = [
        ("tooth", p.tooth_mesh()),
        ("gingiva", p.gingiva_mesh()),
        ("pocket floor", p.floor_mesh()),
    ];
    let mut log = Vec::new();
    let tool = crate::tree_for_mesh(
        &probe,
        tight(TREE_DEPTH),
        cache,
        &format!("{NAME} probe"),
        &mut log,
    )?;
    let mut objects = Vec::with_capacity(parts.len());
    for (label, mesh) in &parts {
        let tree = crate::object_tree_for_mesh(
            mesh,
            tight(TREE_DEPTH),
            cache,
            &format!("{NAME} {label}"),
            &mut log,
        )?;
        objects.push((tree, Pose::identity()));
    }

    let depth = p.pocket_depth_mm;
    let at = |x: f64, z: f64| [x, 0.0, z, 0.0, 0.0, 0.0];
    let start = at(0.0, START_HEIGHT_MM);
    let rest = 0.2;
    let script = Script::starting_at(start)
        .hold(rest)
        .then(0.6, at(0.0, ENTRY_HEIGHT_MM), Ease::Smooth)
        .then(0.3, at(-p.lean_mm, ENTRY_HEIGHT_MM), Ease::Smooth);
    let slide0 = script.duration();
    let way_down = ENTRY_HEIGHT_MM + depth + p.press_mm;
    let script = script.then(
        way_down / p.slide_speed_mm_s,
        at(-p.lean_mm, -depth - p.press_mm),
        Ease::Smooth,
    );
    let pressed0 = script.duration();
    let script = script.hold(0.3);
    let withdraw0 = script.duration();
    let script = script
        .then(
            (way_down / p.slide_speed_mm_s).max(0.5),
            at(0.0, ENTRY_HEIGHT_MM),
            Ease::Smooth,
        )
        .then(0.4, start, Ease::Smooth);
    let withdraw1 = script.duration();
    let script = script.hold(0.3);
    let end = script.duration();

    let solver = SolverSpec {
        geometry: engine::Geometry::Mesh,
        ..SolverSpec::default()
    };
    let scene = Scene {
        name: NAME.into(),
        tool,
        tool_mesh: Some(probe),
        objects,
        object_meshes: parts.into_iter().map(|(_, m)| Some(m)).collect(),
        coupling: Coupling::default(),
        solver,
        safety: SafetyParams::default(),
        start: Pose::from_array(start),
        rate_hz: 1000.0,
        motion: Motion::Script(script),
        goal: Some(Goal::InsertZ {
            target_z_mm: -depth,
            tol_mm: GOAL_TOL_MM,
        }),
        device: Default::default(),
        load_log: log,
        object_friction: Vec::new(),
        tool_friction: None,
    };
    scene.validate()?;
    Ok(ProbeScene {
        scene,
        params: *p,
        phases: ProbePhases {
            free_s: vec![(0.0, rest), (end - 0.2, end)],
            slide_s: (slide0, pressed0),
            pressed_s: (pressed0, withdraw0),
            withdraw_s: (withdraw0, withdraw1),
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_dimensions_are_one_line_errors() {
        assert!(ProbeParams::default().validate().is_ok());
        let p = ProbeParams {
            pocket_width_mm: 0.0,
            ..ProbeParams::default()
        };
        let e = p.validate().unwrap_err().to_string();
        assert!(e.contains("pocket_width_mm") && !e.contains('\n'), "{e}");
        let p = ProbeParams {
            working_length_mm: 5.0,
            ..ProbeParams::default()
        };
        assert!(p.validate().is_err());
        let p = ProbeParams {
            pocket_length_mm: 9.0,
            ..ProbeParams::default()
        };
        assert!(p.validate().is_err());
    }

    #[test]
    fn the_grooves_crests_are_the_pockets_narrowest_width() {
        let p = ProbeParams::default();
        let crest = p.tooth_surface_x(0.0, -2.0);
        let groove = p.tooth_surface_x(0.0, -2.5);
        assert!((crest + 0.5 * p.pocket_width_mm).abs() < 1e-12, "{crest}");
        assert!(
            (groove - crest + p.groove_depth_mm).abs() < 1e-12,
            "{groove}"
        );
        assert!((p.gingiva_surface_x(0.0) - crest - p.pocket_width_mm).abs() < 1e-12);
        // Away from y = 0 both walls fall back by the same curve.
        let y = 2.0;
        assert!(
            (p.gingiva_surface_x(y) - p.tooth_surface_x(y, -2.0) - p.pocket_width_mm).abs() < 1e-12
        );
        assert!(p.gingiva_surface_x(y) < p.gingiva_surface_x(0.0));
    }
}
