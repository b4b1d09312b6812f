//! [`Engine`]: the god-object step followed by the safety filter, behind one call per frame.

use collide::{ConstraintForm, LeafPair, Pose, RotationCoordinates};
use qp::SolverKind;
use spheretree::SphereTree;

use crate::safety::{Safety, SafetyEvents, SafetyParams};
use crate::step::{
    FrameOutput, FrameStatus, Friction, FrictionState, GodObject, Heuristics, Tuning,
};
use crate::{EngineError, Geometry, MeshRef};

/// Every setting of the engine, checked once by [`Engine::new`] against the ranges in
/// [`crate::config`] (the same ranges a scene file's keys are checked against).
///
/// [`EngineConfig::default`] is the project's default and a scene file's: stiffness 1 N/mm and
/// 1000 N·mm/rad, the exact dual solver, distance constraints, rotation-vector coordinates, up
/// to 7 re-linearisation passes within a 1 ms budget. [`EngineConfig::paper`] is the paper's
/// method (one pass, PQP, squared constraints, Euler coordinates).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EngineConfig {
    /// Translational stiffness of the virtual coupling, N/mm.
    pub kt: f64,
    /// Rotational stiffness of the virtual coupling, N·mm/rad.
    pub kr: f64,
    /// Rotation coordinates of the QP variable and of the spring torque.
    pub rotation: RotationCoordinates,
    /// Constraint form: the signed distance (mm) or the paper's squared distance (mm²).
    pub form: ConstraintForm,
    /// QP solver.
    pub solver: SolverKind,
    /// Extra detect + solve passes per frame (0 = the paper's single pass).
    pub relinearize: u32,
    /// Penetration tolerated before another pass, mm.
    pub penetration_tol_mm: f64,
    /// Detection skin added to the motion bound, mm.
    pub skin_mm: f64,
    /// Largest motion of any tool sphere in one pass, mm (caps the detection margin).
    pub max_margin_mm: f64,
    /// Time budget of one frame's step, µs: no pass starts that would end past it.
    pub budget_us: f64,
    /// Leaf pairs stored per pass, pairs (reserved up front; more are dropped and counted).
    pub max_pairs: usize,
    /// Constraint reduction: an exact solver works on a few representative rows plus every
    /// row its answer violates, until none is ([`qp::RowGeneration`]; the full problem's
    /// optimum from tens of rows instead of thousands). `false` solves every row.
    pub reduce_rows: bool,
    /// A second thread shares the large traversals of the frame ([`collide::overlap_shared`]):
    /// it takes half of each while the frame's thread descends the other, about halving the
    /// detection time of dense contacts and tight holes, and spins (a core's worth) for a few
    /// ms after each; it also runs the free-space probes and builds the neighbour lists of
    /// flat-on-flat contacts in the background ([`collide::BackgroundList`]). The answers are
    /// the same with it or without it; with lists in use, frames may take other regions (its
    /// lists are ready sooner) and differ within the convergence tolerance, or where the
    /// problem has more than one local answer. Default `false`.
    pub helper_thread: bool,
    /// Face caps: an object node whose tree carries [`spheretree::FaceCap`]s stands for its
    /// sphere cut by a face's half-space where the tool is above the face, so a tool above a
    /// flat face meets the plane, not a layer of sphere bumps (docs/DESIGN.md §Face caps).
    /// Default `false` (whole spheres, the paper's trees): on faces broken by concave
    /// features (the spline hub's slots) the caps' discs leave sphere bumps between them that
    /// the plane does not see, and the step can rest on the plane where a bump stands.
    pub face_caps: bool,
    /// Device limits applied to every wrench sent.
    pub safety: SafetyParams,
    /// The geometry the step keeps the tool out of: the leaf spheres (default, the paper's) or
    /// the parts' meshes where the engine is given them ([`Geometry`]).
    pub geometry: Geometry,
    /// The frame step's heuristics, each switchable ([`Heuristics`]; all on by default). For
    /// measuring and testing the step: not a scene-file setting.
    pub heuristics: Heuristics,
    /// The frame step's tuned values ([`Tuning`]; measured across the scene zoo). For
    /// measuring and testing the step: not a scene-file setting.
    pub tuning: Tuning,
}

impl Default for EngineConfig {
    fn default() -> Self {
        Self {
            kt: 1.0,
            kr: 1000.0,
            rotation: RotationCoordinates::RotationVector,
            form: ConstraintForm::Distance,
            solver: SolverKind::Dual,
            relinearize: 7,
            penetration_tol_mm: 0.002,
            skin_mm: 0.02,
            max_margin_mm: 2.0,
            budget_us: 1000.0,
            max_pairs: 16_384,
            reduce_rows: true,
            helper_thread: false,
            face_caps: false,
            safety: SafetyParams::default(),
            geometry: Geometry::Spheres,
            heuristics: Heuristics::ALL,
            tuning: Tuning::DEFAULT,
        }
    }
}

impl EngineConfig {
    /// The paper's method: a single pass, the multiplicative-update PQP, squared-distance
    /// constraints and Euler-angle coordinates; everything else as [`EngineConfig::default`].
    pub fn paper() -> Self {
        Self {
            rotation: RotationCoordinates::Euler,
            form: ConstraintForm::Squared,
            solver: SolverKind::Pqp,
            relinearize: 0,
            reduce_rows: false,
            ..Self::default()
        }
    }

    /// The diagonal of the coupling stiffness `G = diag(kt, kt, kt, kr, kr, kr)`: N/mm ×3,
    /// N·mm/rad ×3.
    pub fn g(&self) -> [f64; 6] {
        [self.kt, self.kt, self.kt, self.kr, self.kr, self.kr]
    }
}

/// One frame's result: what to send to the device, where the graphic tool is, and what the
/// frame did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Frame {
    /// Time given to [`Engine::step`], s.
    pub t: f64,
    /// Device (hand) configuration `[x, y, z, gamma, beta, alpha]` (mm, rad).
    pub q_h: [f64; 6],
    /// Graphic (god-object) tool configuration after the frame (mm, rad): draw the tool here.
    pub q_g: [f64; 6],
    /// The wrench to send to the device `[F; T]`, after the safety layer: N and N·mm (world
    /// axes). Always finite.
    pub wrench: [f64; 6],
    /// The spring wrench before the safety layer: N and N·mm.
    pub raw_wrench: [f64; 6],
    /// What the safety layer did ([`crate::safety::flags`] bit set; 0 = nothing).
    pub safety: u8,
    /// How the step ended.
    pub status: FrameStatus,
    /// Leaf pairs in the frame's first QP (its first pair list; a path region that overflowed
    /// the pair storage is not one); triangle pairs in the mesh geometry mode.
    pub pairs: u32,
    /// Constraint rows in the frame's largest solve, after reduction (trust-region rows
    /// included; see [`EngineConfig::reduce_rows`]), rows.
    pub rows: u32,
    /// Leaf pairs (triangle pairs in the mesh geometry mode) touching at `q_g` (gap within
    /// [`crate::step::TOUCH_MM`]): the contact's size.
    pub contacts: u32,
    /// Solver iterations, summed over passes.
    pub iterations: u32,
    /// Passes made (detect + solve).
    pub passes: u32,
    /// Time in collision detection, µs.
    pub cd_us: f64,
    /// Time building constraint rows and solving, µs.
    pub opt_us: f64,
    /// Time of the whole step (without the safety layer), µs.
    pub total_us: f64,
    /// Part of `total_us` the frame spent on lists for later frames: the next neighbour
    /// list's or mesh near list's slice, built ahead of need, µs. `total_us - ahead_us` is
    /// the frame's own work.
    pub ahead_us: f64,
    /// Detection work of the frame: node pairs split by its traversals, its free-space probe
    /// slices and its neighbour-list build slices (a build also counts the pairs it lists), in
    /// node pairs. The bounded near-part search is not counted. Unlike the times, the counts
    /// do not depend on the machine: on one thread, with no deadline cutting a traversal
    /// short, the same input gives the same counts, so frame-step variants can be compared by
    /// them. Work a helper thread did in the background is counted when this frame reads it.
    pub splits: u32,
    /// Neighbour-list entries the frame tested (each a leaf-pair gap at the pose, ~10× cheaper
    /// than a node pair split), entries; in the mesh geometry mode, with the near-list triangle
    /// pairs its regions filtered. Machine-independent as [`Frame::splits`].
    pub scanned: u32,
    /// Deepest leaf–leaf overlap at `q_g`, mm (0 when free).
    pub penetration_mm: f64,
    /// Largest linearised-constraint violation reported by the solver, mm (distance form).
    pub qp_violation: f64,
    /// Detection margin of the first pass, mm.
    pub margin_mm: f64,
    /// What friction did: nothing, stick or slip.
    pub friction: FrictionState,
}

impl Frame {
    /// The frame made of a step's output, the time and the safety layer's result.
    pub fn new(t: f64, out: &FrameOutput, wrench: [f64; 6], safety: u8) -> Self {
        Self {
            t,
            wrench,
            raw_wrench: out.wrench,
            safety,
            ..*out
        }
    }
}

/// Frames counted since [`Engine::reset`] (or [`Engine::new`]), by outcome.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct Counters {
    /// Frames stepped.
    pub frames: u64,
    /// Frames that kept the last safe pose ([`FrameStatus::KeptLastSafe`]).
    pub kept_last_safe: u64,
    /// Frames whose pair list overflowed ([`FrameStatus::PairOverflow`]).
    pub pair_overflows: u64,
    /// Frames whose QP answer violated a constraint beyond the solver's tolerance
    /// ([`FrameStatus::Inexact`]).
    pub inexact: u64,
    /// Frames that ended short of the optimum, safe ([`FrameStatus::Lagging`]).
    pub lagging: u64,
    /// What the safety layer did.
    pub safety: SafetyEvents,
}

impl Counters {
    /// Counts one frame's status.
    pub fn record(&mut self, status: FrameStatus) {
        self.frames += 1;
        match status {
            FrameStatus::KeptLastSafe => self.kept_last_safe += 1,
            FrameStatus::PairOverflow => self.pair_overflows += 1,
            FrameStatus::Inexact => self.inexact += 1,
            FrameStatus::Lagging => self.lagging += 1,
            FrameStatus::Ok => {}
        }
    }

    /// Counts the statuses of `statuses` (safety events stay zero).
    pub fn of(statuses: impl IntoIterator<Item = FrameStatus>) -> Self {
        let mut c = Self::default();
        statuses.into_iter().for_each(|s| c.record(s));
        c
    }
}

/// The haptic engine: the god-object step (detect, constrain, solve, force) followed by the
/// safety layer, one call per frame. See the crate docs for a whole integration.
pub struct Engine {
    god: GodObject,
    config: EngineConfig,
    /// What the run so far left: made fresh by both [`Engine::new`] and [`Engine::reset`].
    run: EngineRun,
}

/// The engine's state of one run around the god-object's: the safety layer's soft start and
/// rate-limit memory, the last frame, the counters.
struct EngineRun {
    safety: Safety,
    frame: Frame,
    counters: Counters,
}

impl EngineRun {
    /// The state before any frame.
    fn fresh(config: &EngineConfig) -> Self {
        Self {
            safety: Safety::new(config.safety),
            frame: Frame::default(),
            counters: Counters::default(),
        }
    }
}

impl Engine {
    /// An engine for the tool tree (tool frame, mm) against the object trees (object frame,
    /// mm, each with its fixed pose): checks `config`, packs the trees and reserves every
    /// buffer. Allocates; call before the haptic loop starts. Then call [`Engine::reset`].
    pub fn new(
        tool: &SphereTree,
        objects: &[(SphereTree, Pose)],
        config: EngineConfig,
    ) -> Result<Self, EngineError> {
        Self::with_meshes(tool, None, objects, &[], config)
    }

    /// [`Engine::new`] with the bodies' meshes (each in its tree's frame, mm), for the mesh
    /// geometry mode ([`GodObject::with_meshes`]).
    pub fn with_meshes(
        tool: &SphereTree,
        tool_mesh: Option<MeshRef<'_>>,
        objects: &[(SphereTree, Pose)],
        object_meshes: &[Option<MeshRef<'_>>],
        config: EngineConfig,
    ) -> Result<Self, EngineError> {
        // Validates the config.
        let god = GodObject::with_meshes(tool, tool_mesh, objects, object_meshes, config)?;
        Ok(Self {
            god,
            config,
            run: EngineRun::fresh(&config),
        })
    }

    /// The geometry the engine keeps the tool out of ([`GodObject::geometry`]): the mesh mode
    /// where it was asked for and every body came with its mesh, else the leaf spheres.
    pub fn geometry(&self) -> Geometry {
        self.god.geometry()
    }

    /// Starts a new run with the device at `start`: the graphic tool is placed at `start`, or
    /// at a free pose near it when `start` is in collision (returned;
    /// [`GodObject::reset`] says how near); the safety layer's soft start and rate limit start
    /// again, the counters from zero. Nothing of an earlier run carries over, whether or not a
    /// free pose is found: the frames that follow are those of a new engine reset at `start`.
    /// Allocation-free.
    pub fn reset(&mut self, start: &Pose) -> Result<Pose, EngineError> {
        let q = self.god.reset(start);
        self.run = EngineRun::fresh(&self.config);
        q
    }

    /// Restarts the safety layer alone (e.g. when a device re-engages): the soft start ramps
    /// again from the next frame and the rate limit starts from a zero wrench.
    pub fn restart_safety(&mut self) {
        self.run.safety = Safety::new(self.config.safety);
    }

    /// Starts the safety layer's soft start again, keeping its rate limit's memory of the last
    /// wrench sent (a device that answers again after a timeout): the wrench ramps back from
    /// where it is, never by a step larger than the rate limit. Allocation-free.
    pub fn restart_soft_start(&mut self) {
        self.run.safety.restart_soft_start();
    }

    /// One frame at time `t` (s) without a device reading (the device timed out): the graphic
    /// tool stays where it is and the wrench sent goes to zero through the safety layer's rate
    /// limit, never by a larger step. The frame's `q_h` is the last one given to
    /// [`Engine::step`]; its raw wrench is zero.
    ///
    /// # Real-time
    /// No allocation, no panic, constant time.
    pub fn release(&mut self, t: f64) -> &Frame {
        let (wrench, flags) = self.run.safety.filter(t, [0.0; 6]);
        self.run.frame = Frame {
            t,
            q_h: self.run.frame.q_h,
            q_g: self.god.q_g().to_array(),
            wrench,
            raw_wrench: [0.0; 6],
            safety: flags,
            ..Frame::default()
        };
        self.run.counters.record(FrameStatus::Ok);
        self.run.counters.safety = self.run.safety.events();
        &self.run.frame
    }

    /// Brings the collision trees (in the mesh mode the near list first) into cache until
    /// `until` ([`GodObject::warm_caches`]): for a paced loop's wait before a frame. Changes no
    /// state.
    ///
    /// # Real-time
    /// No allocation; returns within a few µs of `until`.
    pub fn warm_caches(&self, until: std::time::Instant) {
        self.god.warm_caches(until);
    }

    /// Uses a paced loop's wait before the next frame, until `until` ([`GodObject::idle`]):
    /// the background detection work the frames would do in slices (the next free-space probe,
    /// the next neighbour list) runs here, then the trees are brought into cache. The answers
    /// stay exact; which frames detect may differ from a loop that does not call it.
    ///
    /// # Real-time
    /// No allocation, no panic; returns within ~40 µs of `until`.
    pub fn idle(&mut self, until: std::time::Instant) {
        self.god.idle(until);
    }

    /// One haptic frame at time `t` (s; the safety layer's soft start counts from the first
    /// frame's `t`) for the device configuration `q_h`: returns the frame, whose
    /// [`Frame::wrench`] goes to the device.
    ///
    /// # Real-time
    /// No allocation, no panic, bounded time (at most `1 + relinearize` passes within
    /// `budget_us`), and a finite wrench within the safety limits whatever `q_h` holds.
    pub fn step(&mut self, t: f64, q_h: &Pose) -> &Frame {
        let out = self.god.step(q_h);
        let (wrench, flags) = self.run.safety.filter(t, out.wrench);
        self.run.frame = Frame::new(t, &out, wrench, flags);
        self.run.counters.record(out.status);
        self.run.counters.safety = self.run.safety.events();
        &self.run.frame
    }

    /// The last frame (default before the first [`Engine::step`]).
    pub fn frame(&self) -> &Frame {
        &self.run.frame
    }

    /// The leaf pairs of the last detected region (for display): every pair within the last
    /// pass's detection margin, with its gap (mm) at that pass's linearisation pose. Empty in
    /// free space.
    pub fn contacts(&self) -> &[LeafPair] {
        self.god.pairs()
    }

    /// Frames counted by outcome since the last reset.
    pub fn counters(&self) -> &Counters {
        &self.run.counters
    }

    /// The settings.
    pub fn config(&self) -> &EngineConfig {
        &self.config
    }

    /// The graphic tool's current configuration.
    pub fn q_g(&self) -> Pose {
        self.god.q_g()
    }

    /// Sets the friction of object `object` (0-based index in the objects given to
    /// [`Engine::new`]); every object starts frictionless. Not real-time (validates; call
    /// between frames).
    pub fn set_friction(&mut self, object: usize, friction: Friction) -> Result<(), EngineError> {
        self.god.set_friction(object, friction)
    }

    /// Sets the tool's material friction: `None` (the default) takes each object's
    /// coefficients alone, `Some` the geometric mean of the tool's and the object's.
    pub fn set_tool_friction(&mut self, friction: Option<Friction>) -> Result<(), EngineError> {
        self.god.set_tool_friction(friction)
    }

    /// Turns friction on or off (off: the frictionless step, frame for frame), keeping the
    /// coefficients. Allocation-free.
    pub fn set_friction_enabled(&mut self, on: bool) {
        self.god.set_friction_enabled(on);
    }

    /// The god-object step inside, to read (e.g. the mesh mode's triangle counts).
    pub fn god_object(&self) -> &GodObject {
        &self.god
    }

    /// The god-object step inside, for tools that measure it (benches, tests): e.g. its QP
    /// solver's iteration caps or the penetration at a pose.
    pub fn god_object_mut(&mut self) -> &mut GodObject {
        &mut self.god
    }
}
