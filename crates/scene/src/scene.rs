//! Scenes: the TOML scene file (docs/DESIGN.md §Formats) and the loaded scene (trees in mm,
//! poses, coupling, solver, safety limits, device motion).
//!
//! A scene file names one tool and any number of objects, each by `mesh = "file"` (OBJ, STL,
//! PLY; a sphere-tree is built and cached, see [`crate::cache`]) or `tree = "file.sph"`
//! (Bradshaw format). `scale` maps file units to mm (about the file's own origin). Relative
//! paths are relative to the scene file.
//!
//! ```toml
//! [tool]
//! mesh = "bunny.obj"
//! scale = 10.0
//! depth = 4
//! start = [0, 0, 120, 0, 0, 0]
//!
//! [[object]]
//! mesh = "bunny.obj"
//! scale = 10.0
//! pose = [0, 0, 0, 0, 0, 0]
//!
//! [coupling]
//! kt = 1.0      # N/mm
//! kr = 1000.0   # N·mm/rad
//!
//! [solver]
//! kind = "dual" # dual | pqp | active-set
//!
//! [device]
//! trajectory = "path.csv"  # optional; else the device holds the start pose
//! rate_hz = 1000.0
//! kind = "replay"          # replay | emulator
//! calibration = { scale = 1.0, rotation = [0, 0, 0], offset = [0, 0, 0] }
//! timeout_s = 0.1
//!
//! [device.emulator]        # the emulated hand, with kind = "emulator"
//! mass_kg = 0.1
//! hand_stiffness_n_per_mm = 0.3
//! hand_damping_ns_per_mm = 0.002
//! push_n = [0, 0, -1]
//! push_after_s = 0.3
//! ```

use std::path::{Path, PathBuf};
use std::time::Instant;

use collide::{ConstraintForm, Pose, RotationCoordinates};
use engine::config::SettingError;
use engine::{Engine, EngineConfig};
use mesh::TriMesh;
use serde::{Deserialize, Serialize};
use spheretree::build::BuildMethod;
use spheretree::caps::CapParams;
use spheretree::SphereTree;

use crate::cache::{tree_key, CacheOutcome, TreeCache};
use crate::device::{Calibration, DeviceConfig, DeviceKind, DeviceSettings, EmulatorParams};
use crate::trajectory::{Script, Trajectory};
use crate::SceneError;
use engine::safety::SafetyParams;
use engine::{Friction, SolverKind};

/// One body of a scene file: where its geometry comes from and how it is placed.
#[derive(Clone, Debug, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct BodySpec {
    /// Mesh file (OBJ, STL, PLY); a tree is built from it. Exclusive with `tree`.
    pub mesh: Option<String>,
    /// Sphere-tree file (`.sph`). Exclusive with `mesh`.
    pub tree: Option<String>,
    /// File units to mm (default 1).
    pub scale: Option<f64>,
    /// Tree depth when building from a mesh (default 4).
    pub depth: Option<u32>,
    /// Tree branching when building from a mesh (default 8).
    pub branching: Option<u32>,
    /// Builder (`tight`, the default, or `octree`) when building from a mesh.
    #[serde(default, with = "build_method_name")]
    pub method: Option<BuildMethod>,
    /// Tool only: start configuration `[x, y, z, gamma, beta, alpha]` (mm, rad).
    pub start: Option<[f64; 6]>,
    /// Objects only: fixed pose `[x, y, z, gamma, beta, alpha]` (mm, rad).
    pub pose: Option<[f64; 6]>,
    /// Coulomb friction of the body's material: `friction = { static = 0.4, kinetic = 0.3 }`
    /// (dimensionless; `kinetic` defaults to `static`). Objects default to frictionless; a tool
    /// without one takes each object's coefficients alone, with one the geometric mean.
    pub friction: Option<FrictionSpec>,
}

/// A material's Coulomb friction as written in a scene file.
#[derive(Clone, Copy, Debug, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct FrictionSpec {
    /// Static coefficient (dimensionless).
    #[serde(rename = "static")]
    pub static_mu: f64,
    /// Kinetic coefficient (dimensionless, at most `static`; default `static`).
    pub kinetic: Option<f64>,
}

impl FrictionSpec {
    /// The engine's coefficients.
    pub fn friction(&self) -> Friction {
        Friction {
            static_mu: self.static_mu,
            kinetic_mu: self.kinetic.unwrap_or(self.static_mu),
        }
    }
}

/// The virtual coupling between device and graphic tool: `G = diag(kt, kt, kt, kr, kr, kr)`.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize, Serialize)]
#[serde(default, deny_unknown_fields)]
pub struct Coupling {
    /// Translational stiffness, N/mm.
    pub kt: f64,
    /// Rotational stiffness, N·mm/rad.
    pub kr: f64,
    /// Rotation coordinates of the QP and the spring torque: `rotation-vector` (default; the
    /// physical torque `kr log(R_g R_h^T)`) or `euler` (the paper's angle differences).
    #[serde(with = "by_name")]
    pub rotation: RotationCoordinates,
}

impl Default for Coupling {
    fn default() -> Self {
        Self {
            kt: 1.0,
            kr: 1000.0,
            rotation: RotationCoordinates::RotationVector,
        }
    }
}

impl Coupling {
    /// The diagonal of `G` (N/mm ×3, N·mm/rad ×3).
    pub fn g(&self) -> [f64; 6] {
        [self.kt, self.kt, self.kt, self.kr, self.kr, self.kr]
    }
}

/// How the god-object step detects, constrains and solves.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize, Serialize)]
#[serde(default, deny_unknown_fields)]
pub struct SolverSpec {
    /// The QP solver: `dual` (default), `pqp` or `active-set`.
    #[serde(with = "by_name")]
    pub kind: SolverKind,
    /// Constraint form: `distance` (default) or `squared` (the paper's).
    #[serde(with = "by_name")]
    pub form: ConstraintForm,
    /// Extra detect + solve passes per frame: from the new `q_g` while the measured penetration
    /// exceeds `penetration_tol_mm`, or while the per-pass motion cap keeps the tool short of
    /// the optimum (0 = the paper's single pass).
    pub relinearize: u32,
    /// Penetration tolerated before a re-linearisation pass, mm.
    pub penetration_tol_mm: f64,
    /// Fixed detection skin added to the motion bound, mm.
    pub skin_mm: f64,
    /// Largest motion of any tool sphere in one pass, mm: caps the detection margin (and so
    /// the pair count) when the hand is far from the graphic tool; see [`engine::step`].
    pub max_margin_mm: f64,
    /// Time budget of one frame's step, µs: no pass starts that would end past it.
    pub budget_us: f64,
    /// Constraint reduction for the exact solvers (a working set of rows, every row checked;
    /// the full problem's answer): `true` (default) or `false` to solve every row.
    pub reduce_rows: bool,
    /// A second thread shares the frame's large traversals (the same frames, detection about
    /// twice as fast in dense contacts; it spins a core for a few ms after each):
    /// `false` (default) or `true`.
    pub helper_thread: bool,
    /// Face caps: object nodes on flat faces stand for the face, not their sphere's bulge
    /// (docs/DESIGN.md §Face caps): `false` (default: whole spheres, the paper's trees) or
    /// `true` (the built-in plate scenes).
    pub face_caps: bool,
    /// What the tool touches: `spheres` (default: the trees' leaf spheres, the paper's model)
    /// or `mesh` (the parts' own triangles, the trees as the bounding hierarchy; needs every
    /// body built from a mesh, else the run keeps spheres and says so).
    #[serde(with = "by_name")]
    pub geometry: engine::Geometry,
    /// The frame step's heuristic switches ([`engine::Heuristics`], all on): for the bench's
    /// ablation study and the tests, not a key of the scene file.
    #[serde(skip)]
    pub heuristics: engine::Heuristics,
    /// The frame step's tuned values ([`engine::Tuning`], the shipped ones): for the bench's
    /// tuning study and the tests, not a key of the scene file.
    #[serde(skip)]
    pub tuning: engine::Tuning,
}

impl Default for SolverSpec {
    fn default() -> Self {
        Self {
            kind: SolverKind::Dual,
            form: ConstraintForm::Distance,
            relinearize: 7,
            penetration_tol_mm: 0.002,
            skin_mm: 0.02,
            max_margin_mm: 2.0,
            budget_us: 1000.0,
            reduce_rows: true,
            helper_thread: false,
            face_caps: false,
            geometry: engine::Geometry::Spheres,
            heuristics: engine::Heuristics::ALL,
            tuning: engine::Tuning::DEFAULT,
        }
    }
}

/// The device section of a scene file.
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(default, deny_unknown_fields)]
pub struct DeviceSpec {
    /// Which device: `replay` (default) or `emulator`.
    #[serde(with = "by_name")]
    pub kind: DeviceKind,
    /// Trajectory CSV to replay (relative to the scene file); none = hold the start pose. With
    /// `kind = "emulator"`, the emulated hand's intention.
    pub trajectory: Option<String>,
    /// Haptic rate, Hz.
    pub rate_hz: f64,
    /// Device frame to scene frame: `{ scale = 1.0, rotation = [0, 0, 0], offset = [0, 0, 0] }`
    /// (scene mm per device mm, rotation vector in rad, mm).
    pub calibration: Calibration,
    /// No pose for this long releases the wrench (to zero through the rate limit), s.
    pub timeout_s: f64,
    /// The emulated hand (`[device.emulator]`).
    pub emulator: EmulatorParams,
}

impl Default for DeviceSpec {
    fn default() -> Self {
        Self {
            kind: DeviceKind::Replay,
            trajectory: None,
            rate_hz: 1000.0,
            calibration: Calibration::default(),
            timeout_s: DeviceSettings::default().timeout_s,
            emulator: EmulatorParams::default(),
        }
    }
}

impl DeviceSpec {
    /// The device settings of the section.
    pub fn config(&self) -> DeviceConfig {
        DeviceConfig {
            kind: self.kind,
            settings: DeviceSettings {
                calibration: self.calibration,
                timeout_s: self.timeout_s,
            },
            emulator: self.emulator,
        }
    }
}

/// A scene file, as parsed.
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SceneSpec {
    /// The tool (held by the device).
    pub tool: BodySpec,
    /// The static objects.
    #[serde(default)]
    pub object: Vec<BodySpec>,
    /// Coupling stiffness.
    #[serde(default)]
    pub coupling: Coupling,
    /// Solver settings.
    #[serde(default)]
    pub solver: SolverSpec,
    /// Safety limits.
    #[serde(default)]
    pub safety: SafetyParams,
    /// Device input.
    #[serde(default)]
    pub device: DeviceSpec,
}

impl SceneSpec {
    /// Parses scene TOML; `source` names the file in errors.
    pub fn parse(text: &str, source: &str) -> Result<Self, SceneError> {
        let spec: SceneSpec = toml::from_str(text)
            .map_err(|e| SceneError::caused(source, "invalid scene file", TomlError(e)))?;
        let err = |msg: String| SceneError::scene(source, msg);
        if spec.object.is_empty() {
            return Err(err(
                "no [[object]]: add at least one object to collide with".into(),
            ));
        }
        check_body(&spec.tool, "[tool]").map_err(err)?;
        if spec.tool.pose.is_some() {
            return Err(err(
                "[tool] has `pose`; the tool's initial configuration is `start`".into(),
            ));
        }
        if let Some(f) = &spec.tool.friction {
            f.friction()
                .validate("[tool] friction")
                .map_err(|e| err(e.to_string()))?;
        }
        for (i, o) in spec.object.iter().enumerate() {
            let name = format!("[[object]] #{}", i + 1);
            check_body(o, &name).map_err(err)?;
            if let Some(f) = &o.friction {
                f.friction()
                    .validate(&format!("{name} friction"))
                    .map_err(|e| err(e.to_string()))?;
            }
            if o.start.is_some() {
                return Err(err(format!(
                    "{name} has `start`; objects are placed with `pose`"
                )));
            }
        }
        // Every numeric setting against its one range (engine::config), first bad key named.
        let setting = |e: SettingError| err(e.to_string());
        spec.coupling.validate().map_err(setting)?;
        spec.solver.validate().map_err(setting)?;
        spec.safety.validate().map_err(setting)?;
        engine::config::RATE_HZ
            .check(spec.device.rate_hz)
            .map_err(setting)?;
        spec.device.config().validate().map_err(setting)?;
        Ok(spec)
    }
}

impl Coupling {
    /// Checks `kt` and `kr` ([`engine::config::KT`], [`engine::config::KR`]).
    pub fn validate(&self) -> Result<(), SettingError> {
        engine::config::KT.check(self.kt)?;
        engine::config::KR.check(self.kr)
    }
}

impl SolverSpec {
    /// Checks the numeric solver settings against their ranges in [`engine::config`].
    pub fn validate(&self) -> Result<(), SettingError> {
        engine::config::RELINEARIZE.check(u64::from(self.relinearize))?;
        engine::config::PENETRATION_TOL_MM.check(self.penetration_tol_mm)?;
        engine::config::SKIN_MM.check(self.skin_mm)?;
        engine::config::MAX_MARGIN_MM.check(self.max_margin_mm)?;
        engine::config::BUDGET_US.check(self.budget_us)
    }
}

/// An enumerated setting written as its name (`kind = "dual"`), through the engine's one name
/// table ([`engine::setting`]).
mod by_name {
    use engine::setting::Setting;
    use serde::{de::Error, Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer, T: Setting>(v: &T, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(v.setting_name())
    }

    pub fn deserialize<'de, D: Deserializer<'de>, T: Setting>(d: D) -> Result<T, D::Error> {
        let name = String::deserialize(d)?;
        T::parse_setting(&name).map_err(D::Error::custom)
    }
}

/// The tree builder written as its name (`method = "octree"`), through `BuildMethod`'s own
/// names.
mod build_method_name {
    use serde::{de::Error, Deserialize, Deserializer, Serializer};
    use spheretree::build::BuildMethod;

    pub fn serialize<S: Serializer>(v: &Option<BuildMethod>, s: S) -> Result<S::Ok, S::Error> {
        match v {
            Some(v) => s.serialize_str(v.name()),
            None => s.serialize_none(),
        }
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Option<BuildMethod>, D::Error> {
        let name = String::deserialize(d)?;
        name.trim()
            .to_ascii_lowercase()
            .parse()
            .map(Some)
            .map_err(D::Error::custom)
    }
}

/// A TOML parse error shown on one line (toml's own display draws the line with a caret
/// below it), with the original kept as its source.
#[derive(Debug)]
struct TomlError(toml::de::Error);

impl std::fmt::Display for TomlError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        // toml quotes the offending line: a 400 KB line would make a 400 KB message. Long
        // words are cut, and the whole is kept to one readable line.
        const WORD: usize = 60;
        const TOTAL: usize = 400;
        let text = self.0.to_string();
        let mut written = 0;
        for (i, w) in text.split_whitespace().enumerate() {
            if written >= TOTAL {
                return f.write_str(" …");
            }
            let cut = w.char_indices().nth(WORD).map(|(at, _)| &w[..at]);
            let sep = if i == 0 { "" } else { " " };
            match cut {
                Some(head) => write!(f, "{sep}{head}…")?,
                None => write!(f, "{sep}{w}")?,
            }
            written += w.len().min(WORD) + 1;
        }
        Ok(())
    }
}

impl std::error::Error for TomlError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        None // the text above is the whole of it
    }
}

fn check_body(b: &BodySpec, name: &str) -> Result<(), String> {
    match (&b.mesh, &b.tree) {
        (None, None) => {
            return Err(format!(
                "{name} needs `mesh = \"file.obj\"` or `tree = \"file.sph\"`"
            ))
        }
        (Some(_), Some(_)) => return Err(format!("{name} has both `mesh` and `tree`; keep one")),
        _ => {}
    }
    if let Some(s) = b.scale {
        if !(s > 0.0 && s.is_finite()) {
            return Err(format!("{name} scale = {s}: must be a finite number > 0"));
        }
    }
    if let Some(d) = b.depth {
        if !(1..=7).contains(&d) {
            return Err(format!("{name} depth = {d}: use 1..=7 (4 is the paper's)"));
        }
    }
    if let Some(br) = b.branching {
        if !(2..=16).contains(&br) {
            return Err(format!(
                "{name} branching = {br}: use 2..=16 (8 is the default)"
            ));
        }
    }
    if let Some(q) = &b.start {
        engine::config::check_pose(&format!("{name} start"), q).map_err(|e| e.to_string())?;
    }
    if let Some(q) = &b.pose {
        engine::config::check_pose(&format!("{name} pose"), q).map_err(|e| e.to_string())?;
    }
    Ok(())
}

/// Where a scene's device motion comes from.
#[derive(Clone, Debug, PartialEq)]
pub enum Motion {
    /// A keyframe script (built-in scenes).
    Script(Script),
    /// A recorded trajectory.
    Trajectory(Trajectory),
    /// No motion given: the device holds the start pose.
    Hold,
}

/// What a scene expects to happen (checked by tests and reported by `haptic6d run`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Goal {
    /// The graphic tool's `z` must reach at most `target_z_mm` (an insertion).
    InsertZ {
        /// Target `z` of the tool origin, mm.
        target_z_mm: f64,
        /// Tolerance, mm.
        tol_mm: f64,
    },
}

/// Build parameters of a tree built from a mesh.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TreeParams {
    /// Depth (levels - 1).
    pub depth: u32,
    /// Branching factor.
    pub branching: u32,
    /// The builder.
    pub method: BuildMethod,
}

/// A loaded scene: everything the step and the loop need, in mm.
#[derive(Clone, Debug)]
pub struct Scene {
    /// Name (built-in name or file path).
    pub name: String,
    /// The tool's tree in the tool frame, mm.
    pub tool: SphereTree,
    /// The tool mesh in the tool frame, mm (when built from a mesh).
    pub tool_mesh: Option<TriMesh>,
    /// Objects: tree in the object frame (mm) and its fixed pose.
    pub objects: Vec<(SphereTree, Pose)>,
    /// Object meshes in their object frames, mm (when built from meshes).
    pub object_meshes: Vec<Option<TriMesh>>,
    /// Coupling stiffness.
    pub coupling: Coupling,
    /// Solver settings.
    pub solver: SolverSpec,
    /// Safety limits.
    pub safety: SafetyParams,
    /// Tool start configuration.
    pub start: Pose,
    /// Haptic rate, Hz.
    pub rate_hz: f64,
    /// Device motion.
    pub motion: Motion,
    /// Expected outcome, if any.
    pub goal: Option<Goal>,
    /// The device: kind, calibration, timeout, emulator.
    pub device: DeviceConfig,
    /// How each tree was obtained (one line each: cache hit, built in N s, read from file).
    pub load_log: Vec<String>,
    /// Friction of each object's material, in the order of `objects` (missing entries:
    /// frictionless).
    pub object_friction: Vec<Friction>,
    /// Friction of the tool's material (`None`: each object's coefficients alone).
    pub tool_friction: Option<Friction>,
}

impl Scene {
    /// Checks every setting of the scene against its range ([`engine::config`]): coupling,
    /// solver, safety limits, rate, start and object poses. Scene files are checked when
    /// parsed; call this again after changing a loaded scene (command-line overrides, API).
    pub fn validate(&self) -> Result<(), SceneError> {
        let err = |e: SettingError| SceneError::caused(&self.name, "setting out of range", e);
        self.coupling.validate().map_err(err)?;
        self.solver.validate().map_err(err)?;
        self.safety.validate().map_err(err)?;
        engine::config::RATE_HZ.check(self.rate_hz).map_err(err)?;
        self.device.validate().map_err(err)?;
        engine::config::check_pose("[tool] start", &self.start.to_array()).map_err(err)?;
        for (i, (_, p)) in self.objects.iter().enumerate() {
            engine::config::check_pose(&format!("[[object]] #{} pose", i + 1), &p.to_array())
                .map_err(err)?;
        }
        Ok(())
    }

    /// The engine's settings from the scene's coupling, solver and safety sections.
    pub fn engine_config(&self) -> EngineConfig {
        EngineConfig {
            kt: self.coupling.kt,
            kr: self.coupling.kr,
            rotation: self.coupling.rotation,
            form: self.solver.form,
            solver: self.solver.kind,
            relinearize: self.solver.relinearize,
            penetration_tol_mm: self.solver.penetration_tol_mm,
            skin_mm: self.solver.skin_mm,
            max_margin_mm: self.solver.max_margin_mm,
            budget_us: self.solver.budget_us,
            reduce_rows: self.solver.reduce_rows,
            helper_thread: self.solver.helper_thread,
            face_caps: self.solver.face_caps,
            geometry: self.solver.geometry,
            heuristics: self.solver.heuristics,
            tuning: self.solver.tuning,
            safety: self.safety,
            ..EngineConfig::default()
        }
    }

    /// The scene's engine, reset at the scene's start pose (or a free pose near it:
    /// [`engine::Engine::reset`]).
    /// Allocates; call before the haptic loop.
    pub fn engine(&self) -> Result<Engine, SceneError> {
        let (tool_mesh, object_meshes) = self.mesh_refs();
        let mut engine = Engine::with_meshes(
            &self.tool,
            tool_mesh,
            &self.objects,
            &object_meshes,
            self.engine_config(),
        )
        .map_err(|source| SceneError::Engine {
            file: self.name.clone(),
            source,
        })?;
        self.apply_friction(&mut engine)?;
        engine
            .reset(&self.start)
            .map_err(|source| SceneError::Engine {
                file: self.name.clone(),
                source,
            })?;
        Ok(engine)
    }

    /// Gives `engine` (made for this scene's objects) the scene's friction.
    pub fn apply_friction(&self, engine: &mut Engine) -> Result<(), SceneError> {
        let err = |source| SceneError::Engine {
            file: self.name.clone(),
            source,
        };
        engine.set_tool_friction(self.tool_friction).map_err(err)?;
        for (i, f) in self.object_friction.iter().enumerate() {
            engine.set_friction(i, *f).map_err(err)?;
        }
        Ok(())
    }

    /// The bodies' meshes as the engine takes them (the mesh geometry mode uses them):
    /// [`engine::Engine::with_meshes`]'s `tool_mesh` and `object_meshes`.
    pub fn mesh_refs(
        &self,
    ) -> (
        Option<engine::MeshRef<'_>>,
        Vec<Option<engine::MeshRef<'_>>>,
    ) {
        fn as_ref(m: &TriMesh) -> engine::MeshRef<'_> {
            engine::MeshRef {
                vertices: &m.vertices,
                triangles: &m.triangles,
            }
        }
        (
            self.tool_mesh.as_ref().map(as_ref),
            self.object_meshes
                .iter()
                .map(|m| m.as_ref().map(as_ref))
                .collect(),
        )
    }

    /// True when every body has its mesh (the tool and each object), so that the mesh geometry
    /// mode can run; false where a tree was read from a `.sph` file alone.
    pub fn has_meshes(&self) -> bool {
        self.tool_mesh.is_some() && self.object_meshes.iter().all(Option::is_some)
    }

    /// The geometry the engine will keep the tool out of: the mesh mode where it is asked for
    /// and every body has its mesh, else the leaf spheres.
    pub fn geometry(&self) -> engine::Geometry {
        if self.solver.geometry == engine::Geometry::Mesh && self.has_meshes() {
            engine::Geometry::Mesh
        } else {
            engine::Geometry::Spheres
        }
    }

    /// The god-object step alone (no safety layer), for tools that measure it.
    pub fn god_object(&self) -> Result<engine::step::GodObject, SceneError> {
        let err = |source| SceneError::Engine {
            file: self.name.clone(),
            source,
        };
        let (tool_mesh, object_meshes) = self.mesh_refs();
        let mut god = engine::step::GodObject::with_meshes(
            &self.tool,
            tool_mesh,
            &self.objects,
            &object_meshes,
            self.engine_config(),
        )
        .map_err(err)?;
        god.set_tool_friction(self.tool_friction).map_err(err)?;
        for (i, f) in self.object_friction.iter().enumerate() {
            god.set_friction(i, *f).map_err(err)?;
        }
        Ok(god)
    }

    /// The device trajectory (the script sampled at the scene rate, the recorded one, or the
    /// start pose held for one second).
    pub fn trajectory(&self) -> Trajectory {
        match &self.motion {
            Motion::Script(s) => s.to_trajectory(self.rate_hz),
            Motion::Trajectory(t) => t.clone(),
            Motion::Hold => Script::starting_at(self.start.to_array())
                .hold(1.0)
                .to_trajectory(self.rate_hz),
        }
    }
}

/// Builds (or fetches from `cache`) the tree of `mesh` (mm) with `params`, logging what
/// happened into `log` under `label`. No face caps: the tool's tree (see
/// [`object_tree_for_mesh`] for objects).
pub fn tree_for_mesh(
    mesh: &TriMesh,
    params: TreeParams,
    cache: &TreeCache,
    label: &str,
    log: &mut Vec<String>,
) -> Result<SphereTree, SceneError> {
    tree_for_mesh_with(mesh, params, cache, label, log, false)
}

/// [`tree_for_mesh`] for an object: the tree also gets its leaves' face caps
/// ([`spheretree::caps::face_caps`], default [`CapParams`]), computed with the build and
/// cached with the tree; the log line says how many leaves were capped.
pub fn object_tree_for_mesh(
    mesh: &TriMesh,
    params: TreeParams,
    cache: &TreeCache,
    label: &str,
    log: &mut Vec<String>,
) -> Result<SphereTree, SceneError> {
    tree_for_mesh_with(mesh, params, cache, label, log, true)
}

fn tree_for_mesh_with(
    mesh: &TriMesh,
    params: TreeParams,
    cache: &TreeCache,
    label: &str,
    log: &mut Vec<String>,
    with_caps: bool,
) -> Result<SphereTree, SceneError> {
    let method = params.method;
    let bp = spheretree::build::BuildParams {
        depth: params.depth,
        branching: params.branching,
        method,
        ..Default::default()
    };
    let cp = CapParams::default();
    // Capped and uncapped trees of one mesh are different entries; the cap rule's version and
    // options are part of the key so a changed rule never reuses old caps.
    let key_params = if with_caps {
        format!(
            "{bp:?} face_caps v{} {cp:?}",
            spheretree::caps::CAPS_VERSION
        )
    } else {
        format!("{bp:?}")
    };
    let key = tree_key(mesh, &key_params);
    let t0 = Instant::now();
    let mut caps_s = None;
    let (tree, outcome) = cache.get_or_build(&key, || {
        let mut tree = spheretree::build::build_tree(mesh, &bp, &|f| cache.report(label, f))
            .map_err(|e| SceneError::caused(label, "building the sphere-tree failed", e))?;
        if with_caps {
            let t1 = Instant::now();
            let caps = spheretree::caps::face_caps(mesh, &tree, &cp);
            // A tree without any cap stays uncapped (it then reads back equal from the cache).
            if caps.iter().any(|c| !c.is_empty()) {
                tree.set_caps(caps)
                    .map_err(|e| SceneError::caused(label, "face caps rejected", e))?;
            }
            caps_s = Some(t1.elapsed().as_secs_f64());
        }
        Ok::<_, SceneError>(tree)
    })?;
    let dt = t0.elapsed().as_secs_f64();
    let mut line = match outcome {
        CacheOutcome::Hit => format!("{label}: tree from cache ({dt:.3} s)"),
        CacheOutcome::Built => format!(
            "{label}: tree built, depth {} branching {} {:?} ({dt:.2} s)",
            params.depth, params.branching, method
        ),
    };
    if with_caps {
        let capped = tree.leaves().filter(|&n| !tree.cap(n).is_empty()).count();
        let leaves = tree.leaves().count();
        line += &format!(
            ", {} of {} leaves face-capped",
            grouped(capped),
            grouped(leaves)
        );
        if let Some(s) = caps_s {
            line += &format!(" (caps {s:.3} s)");
        }
    }
    log.push(line);
    Ok(tree)
}

/// The load log's line on the mesh mode's triangles: each body's as given and as the narrow
/// phase holds them after flat faces were merged (`counts`:
/// [`engine::step::GodObject::mesh_triangle_counts`]), e.g. `mesh: triangles as given → with flat
/// faces merged: tool 10 752 → 448; object 1 10 880 → 960`.
pub fn mesh_triangles_line(scene: &Scene, counts: &(usize, Vec<usize>)) -> String {
    let given = |m: &Option<TriMesh>| m.as_ref().map_or(0, |m| m.triangles.len());
    let mut line = format!(
        "mesh: triangles as given → with flat faces merged: tool {} → {}",
        grouped(given(&scene.tool_mesh)),
        grouped(counts.0)
    );
    for (i, (m, n)) in scene.object_meshes.iter().zip(&counts.1).enumerate() {
        line.push_str(&format!(
            "; object {} {} → {}",
            i + 1,
            grouped(given(m)),
            grouped(*n)
        ));
    }
    line
}

/// `n` with its digits in groups of three separated by spaces (`4 096`), for the load log.
pub fn grouped(n: usize) -> String {
    let digits = n.to_string();
    let mut out = String::new();
    for (i, ch) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push(' ');
        }
        out.push(ch);
    }
    out
}

/// Scales a tree's centres and radii by `s` (file units to mm).
pub fn scale_tree(tree: &mut SphereTree, s: f64) {
    for sp in tree.spheres_mut() {
        if sp.is_used() {
            sp.center = sp.center.map(|c| c * s);
            sp.radius *= s;
        }
    }
}

fn resolve(base: &Path, p: &str) -> PathBuf {
    let p = Path::new(p);
    if p.is_absolute() {
        p.to_path_buf()
    } else {
        base.join(p)
    }
}

/// Loads one body of a scene file; `object` says it is an object (its tree built from a mesh
/// gets face caps; the tool's does not, and trees read from `.sph` files never do).
fn load_body(
    b: &BodySpec,
    base: &Path,
    file: &str,
    label: &str,
    object: bool,
    cache: &TreeCache,
    log: &mut Vec<String>,
) -> Result<(SphereTree, Option<TriMesh>), SceneError> {
    let scale = b.scale.unwrap_or(1.0);
    let err = |msg: String| SceneError::scene(file, msg);
    if let Some(t) = &b.tree {
        let path = resolve(base, t);
        let mut tree = spheretree::sph::read_sph(&path).map_err(|e| {
            SceneError::caused(
                file,
                format!("{label}: cannot read tree {}", path.display()),
                e,
            )
        })?;
        scale_tree(&mut tree, scale);
        let finite = tree
            .spheres()
            .iter()
            .all(|s| s.radius.is_finite() && s.center.iter().all(|c| c.is_finite()));
        if !finite {
            return Err(err(format!(
                "{label}: scale = {scale} makes the tree {} overflow (non-finite spheres); check `scale` (file units to mm)",
                path.display()
            )));
        }
        tree.enforce_containment();
        log.push(format!("{label}: tree read from {}", path.display()));
        return Ok((tree, None));
    }
    let m = b.mesh.as_deref().unwrap_or_default();
    let path = resolve(base, m);
    let raw = crate::scenes::load_mesh_file(&path).map_err(|e| {
        SceneError::caused(
            file,
            format!("{label}: cannot load mesh {}", path.display()),
            e,
        )
    })?;
    let mesh = raw.scaled_about([0.0; 3], scale);
    if !mesh.vertices.iter().flatten().all(|c| c.is_finite()) {
        return Err(err(format!(
            "{label}: scale = {scale} makes the mesh {} overflow (non-finite vertices); check `scale` (file units to mm)",
            path.display()
        )));
    }
    let params = TreeParams {
        depth: b.depth.unwrap_or(4),
        branching: b.branching.unwrap_or(8),
        method: b.method.unwrap_or_default(),
    };
    let tree =
        tree_for_mesh_with(&mesh, params, cache, label, log, object).map_err(|e| match e {
            SceneError::Scene { msg, source, .. } => SceneError::Scene {
                file: file.to_string(),
                msg: format!("{label}: {msg}"),
                source,
            },
            other => other,
        })?;
    Ok((tree, Some(mesh)))
}

/// Loads a scene file: parses it, loads meshes/trees (relative to the file), builds or fetches
/// trees, reads the trajectory named in `[device]`.
pub fn load_scene_file(path: &Path, cache: &TreeCache) -> Result<Scene, SceneError> {
    let file = path.display().to_string();
    // Bounded read: a scene file is a few hundred bytes; a device node is refused.
    let text = mesh::read_input(path, 1 << 20)
        .and_then(|b| {
            String::from_utf8(b)
                .map_err(|_| std::io::Error::new(std::io::ErrorKind::InvalidData, "not UTF-8 text"))
        })
        .map_err(|e| SceneError::caused(&file, "cannot read the scene file", e))?;
    let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
    let spec = SceneSpec::parse(text, &file)?;
    let base = path.parent().unwrap_or(Path::new("."));
    let mut log = Vec::new();
    let (tool, tool_mesh) = load_body(&spec.tool, base, &file, "tool", false, cache, &mut log)?;
    let mut objects = Vec::new();
    let mut object_meshes = Vec::new();
    for (i, o) in spec.object.iter().enumerate() {
        let (tree, m) = load_body(
            o,
            base,
            &file,
            &format!("object {}", i + 1),
            true,
            cache,
            &mut log,
        )?;
        objects.push((tree, Pose::from_array(o.pose.unwrap_or([0.0; 6]))));
        object_meshes.push(m);
    }
    let motion = match &spec.device.trajectory {
        Some(t) => Motion::Trajectory(
            Trajectory::read_csv(&resolve(base, t))
                .map_err(|e| SceneError::caused(&file, "[device] trajectory", e))?,
        ),
        None => Motion::Hold,
    };
    Ok(Scene {
        name: file,
        tool,
        tool_mesh,
        objects,
        object_meshes,
        coupling: spec.coupling,
        solver: spec.solver,
        safety: spec.safety,
        start: Pose::from_array(spec.tool.start.unwrap_or([0.0; 6])),
        rate_hz: spec.device.rate_hz,
        motion,
        goal: None,
        device: spec.device.config(),
        load_log: log,
        object_friction: spec
            .object
            .iter()
            .map(|o| o.friction.map_or(Friction::NONE, |f| f.friction()))
            .collect(),
        tool_friction: spec.tool.friction.map(|f| f.friction()),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn object_trees_get_face_caps_and_keep_them_through_the_cache() {
        let dir = tempfile::tempdir().unwrap();
        let cache = TreeCache::at(dir.path());
        let plate = crate::scenes::plate::plate_mesh();
        let params = TreeParams {
            depth: 2,
            branching: 8,
            method: BuildMethod::Octree,
        };
        let mut log = Vec::new();
        let built = object_tree_for_mesh(&plate, params, &cache, "plate", &mut log).unwrap();
        let capped = built.leaves().filter(|&n| !built.cap(n).is_empty()).count();
        assert!(capped > 0);
        assert_eq!(
            built.caps(),
            spheretree::caps::face_caps(&plate, &built, &CapParams::default()).as_slice()
        );
        let again = object_tree_for_mesh(&plate, params, &cache, "plate", &mut log).unwrap();
        assert_eq!(again, built);
        // The tool's tree of the same mesh is another entry, without caps.
        let tool = tree_for_mesh(&plate, params, &cache, "tool", &mut log).unwrap();
        assert!(tool.caps().is_empty());
        let leaves = grouped(built.leaves().count());
        assert!(log[0].contains("tree built") && log[1].contains("tree from cache"));
        for line in &log[..2] {
            let want = format!("{} of {leaves} leaves face-capped", grouped(capped));
            assert!(line.contains(&want), "{line}");
        }
        assert!(log[2].contains("tree built") && !log[2].contains("face-capped"));
        assert_eq!(grouped(4096), "4 096");
        assert_eq!(grouped(1_234_567), "1 234 567");
        assert_eq!(grouped(12), "12");
    }

    const GOOD: &str = r#"
[tool]
mesh = "bunny.obj"
scale = 10.0
depth = 4
start = [0, 0, 120, 0, 0, 0]

[[object]]
mesh = "bunny.obj"
scale = 10.0
depth = 4
pose = [0, 0, 0, 0, 0, 0]

[coupling]
kt = 1.0
kr = 1000.0

[solver]
kind = "dual"
"#;

    #[test]
    fn design_example_parses() {
        let s = SceneSpec::parse(GOOD, "x.toml").unwrap();
        assert_eq!(s.tool.start, Some([0.0, 0.0, 120.0, 0.0, 0.0, 0.0]));
        assert_eq!(s.object.len(), 1);
        assert_eq!(s.solver.kind, SolverKind::Dual);
        assert_eq!(s.coupling.g(), [1.0, 1.0, 1.0, 1000.0, 1000.0, 1000.0]);
    }

    #[test]
    fn errors_are_one_line_and_name_the_file() {
        let cases = [
            (GOOD.replace("kind = \"dual\"", "kind = \"fast\""), "kind"),
            (
                GOOD.replace(
                    "scale = 10.0\ndepth = 4\nstart",
                    "scale = -1.0\ndepth = 4\nstart",
                ),
                "scale",
            ),
            (
                GOOD.replace(
                    "mesh = \"bunny.obj\"\nscale = 10.0\ndepth = 4\nstart",
                    "scale = 10.0\ndepth = 4\nstart",
                ),
                "needs `mesh",
            ),
            (GOOD.replace("[[object]]", "[[objekt]]"), "objekt"),
            (GOOD.replace("kt = 1.0", "kt = 0.0"), "kt"),
            (
                GOOD.replace("depth = 4\nstart", "depth = 40\nstart"),
                "depth",
            ),
            ("[tool]\nmesh = \"a.obj\"\n".to_string(), "no [[object]]"),
            ("[tool\n".to_string(), ""),
        ];
        for (text, needle) in cases {
            let e = crate::error_chain(&SceneSpec::parse(&text, "scenes/my.toml").unwrap_err());

            assert!(e.starts_with("scenes/my.toml: "), "{e}");
            assert!(!e.contains('\n'), "{e}");
            assert!(e.contains(needle), "`{needle}` not in: {e}");
        }
    }

    #[test]
    fn device_section_with_calibration_and_emulator() {
        let text = format!(
            "{GOOD}\n[device]\nkind = \"emulator\"\ntimeout_s = 0.05\ncalibration = {{ scale = 2.0, rotation = [0, 0, 1.5], offset = [0, 0, 100] }}\n\n[device.emulator]\nmass_kg = 0.2\npush_n = [0, 0, -1]\n"
        );
        let s = SceneSpec::parse(&text, "x.toml").unwrap();
        let d = s.device.config();
        assert_eq!(d.kind, DeviceKind::Emulator);
        assert_eq!(d.settings.timeout_s, 0.05);
        assert_eq!(d.settings.calibration.scale, 2.0);
        assert_eq!(d.settings.calibration.offset, [0.0, 0.0, 100.0]);
        assert_eq!(d.emulator.mass_kg, 0.2);
        assert_eq!(d.emulator.hand_stiffness_n_per_mm, 0.3);
        let cases = [
            (
                "kind = \"emulator\"",
                "kind = \"phantom\"",
                "unknown device `phantom`; expected one of: replay, emulator, haply, udp",
            ),
            (
                "scale = 2.0",
                "scale = -2.0",
                "[device] calibration.scale = -2: must be",
            ),
            (
                "rotation = [0, 0, 1.5]",
                "rotation = [0, 0, 100]",
                "[device] calibration.rotation = 100: must be",
            ),
            ("offset = [0, 0, 100]", "offset = [0, 100]", "offset"),
            ("scale = 2.0", "skale = 2.0", "skale"),
            (
                "timeout_s = 0.05",
                "timeout_s = 0",
                "[device] timeout_s = 0: must be",
            ),
            (
                "mass_kg = 0.2",
                "mass_kg = 1e9",
                "[device.emulator] mass_kg = 1e9: must be",
            ),
        ];
        for (from, to, needle) in cases {
            let bad = text.replace(from, to);
            let e = crate::error_chain(&SceneSpec::parse(&bad, "scenes/my.toml").unwrap_err());
            assert!(e.starts_with("scenes/my.toml: "), "{e}");
            assert!(!e.contains('\n'), "{e}");
            assert!(e.contains(needle), "`{needle}` not in: {e}");
        }
    }

    #[test]
    fn missing_mesh_is_reported_with_its_resolved_path() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("s.toml");
        std::fs::write(&p, GOOD.replace("bunny.obj", "nothere.obj")).unwrap();
        let e = load_scene_file(&p, &TreeCache::disabled())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("s.toml")
                && e.contains(&dir.path().join("nothere.obj").display().to_string()),
            "{e}"
        );
    }

    #[test]
    fn scene_file_names_are_the_engine_setting_names() {
        let text = GOOD.replace(
            "kind = \"dual\"",
            "kind = \"active-set\"\nform = \"squared\"",
        );
        let s = SceneSpec::parse(&text, "x.toml").unwrap();
        assert_eq!(s.solver.kind, SolverKind::ActiveSet);
        assert_eq!(s.solver.form, ConstraintForm::Squared);
        let e = crate::error_chain(
            &SceneSpec::parse(&GOOD.replace("\"dual\"", "\"newton\""), "x.toml").unwrap_err(),
        );
        assert!(e.contains("dual, pqp, active-set"), "{e}");
    }
}
