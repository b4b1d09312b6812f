//! The god-object step: one haptic frame (docs/DESIGN.md, "The frame step").
//!
//! Given the device configuration `q_h` and the last graphic configuration `q_g_prev`, a frame
//! makes one or more **passes** from a linearisation pose `q_lin` (first `q_g_prev`):
//!
//! 1. **Region.** A tool point `p` (tool frame) moving from `(R_a, t_a)` to `(R_b, t_b)` moves
//!    by at most `|t_b - t_a| + θ |p|` (`θ` the angle of `R_b R_a^T`); with `reach` the largest
//!    `|p|` over tool leaf centres, `|Δt| + θ · reach` bounds every sphere's motion. A region
//!    lists every leaf pair within `allowance + skin` at `q_lin`: every pair that can touch
//!    while no sphere moves more than the allowance. The allowance follows the last frame's
//!    motion, is capped by `max_margin_mm` and by the pair density (dense contacts take smaller
//!    regions); when it does not reach the hand a **trust box** (12 rows) keeps the iterates
//!    inside it. An empty region is remembered as a free-space proof that spares later
//!    traversals near the same pose.
//! 2. **Constrain**: rows `J dq >= d` linearized at `q_lin` ([`collide::Linearization`]), in
//!    rotation-vector coordinates by default (a local rotation increment about `q_lin`, world
//!    axes: no Euler singularity, any representation of `R_h` gives the same frame) or the
//!    paper's Euler coordinates.
//! 3. **Solve** `min 1/2 dq^T G dq` with the chosen solver, warm-started from the last active
//!    pairs; map the answer back to a configuration `q_new`.
//! 4. **Verify**: an answer that left its region is discarded and the region detected again,
//!    wider. Otherwise the listed pairs' exact gaps at `q_new` give the deepest overlap and how
//!    far the rows holding the tool are still open in truth.
//! 5. **Iterate**: penetrating, or held by rows that are open, re-linearise at `q_new` on the
//!    same pairs; free and converged but stopped by the trust box, detect a new region from
//!    `q_new`; otherwise the frame has reached the constrained optimum.
//! 6. **Force** from the spring between `q_g` and `q_h`: `F = kt (t_g - t_h)` (N) and
//!    `T = kr log(R_g R_h^T)` (N·mm, world axes; the exact gradient of the spring energy
//!    `kr/2 |log(R_g R_h^T)|^2`), or the paper's `kr (euler_g - euler_h)` in Euler coordinates.
//!
//! A hand in motion takes a **path region** instead of a ball: the pairs along the motion
//! predicted for the tool (it keeps last frame's offset from the hand), with a slab about the
//! path as its trust region; a detected region is reused by later frames while the tool and
//! its prediction stay inside it.
//!
//! The stages live in their own files: `detect.rs` (regions, prediction, free-space proof),
//! `constrain.rs` (rows and trust regions), `solve.rs` (the QP and its warm start),
//! `measure.rs` (exact gaps, the spring wrench); this file holds the state and the pass loop.
//!
//! Passes stop at `1 + relinearize` or when the next one would overrun `budget_us`. A frame that
//! stops before the optimum is **lagging**: it returns the last pose proven free (never a
//! penetrating one) and says so in its [`Frame::status`](crate::Frame::status). A frame that fails (non-finite input,
//! solver breakdown, a capped or infeasible QP) keeps the last safe `q_g`.

use std::time::{Duration, Instant};

use collide::{
    rotation_exp, rotation_log, BackgroundList, CentreBox, CollideWorkspace, FaceSlab,
    FreeSpaceProbe, LeafPair, Linearization, ListStatus, NeighbourList, PackedTree, Pose,
    ProbeStatus, RotationCoordinates, Sweep, TraversalTeam, TriangleTree,
};
use nalgebra::{Matrix3, Vector3};
use qp::{Problem, RowGeneration, Solver, Status};
use spheretree::SphereTree;

use crate::{EngineConfig, EngineError, Geometry, MeshRef};

mod constrain;
mod density;
mod detect;
mod frame;
mod friction;
mod heuristics;
mod measure;
mod narrow;
mod plan;
mod reference;
mod solve;
mod state;
mod tuning;

use narrow::{Meshes, PairGap, ToolPoses, TriPair};
use state::*;
pub use tuning::TOUCH_MM;
use tuning::*;

use frame::Flow;

pub use friction::{Friction, FrictionState};
pub use heuristics::Heuristics;
pub use solve::ReductionAudit;
pub use tuning::Tuning;

use measure::rotation_angle;
pub use measure::spring_wrench;

/// How a frame ended.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FrameStatus {
    /// Solved: the constrained optimum (within the penetration tolerance).
    #[default]
    Ok,
    /// The QP answer violates its linearized constraints beyond the solver tolerance (its KKT
    /// certificate), e.g. PQP stopped early; its `q_g` was used.
    Inexact,
    /// More pairs than `max_pairs` even in the smallest region: no answer was proven, the last
    /// pose proven free is kept (the tool lags, it never penetrates).
    PairOverflow,
    /// Passes or budget ran out before the optimum: `q_g` is the last pose proven free on the
    /// way to it (the tool lags the hand this frame, it never penetrates).
    Lagging,
    /// The frame failed (non-finite input or numerical breakdown): the last safe `q_g` kept.
    KeptLastSafe,
}

impl FrameStatus {
    /// The frame ended short of a proven optimum: lagging, with a pair overflow, or with the
    /// last safe pose kept (what the bench counts as degraded).
    pub fn is_degraded(&self) -> bool {
        matches!(
            self,
            Self::Lagging | Self::PairOverflow | Self::KeptLastSafe
        )
    }

    /// The name written in `frames.csv`: `ok`, `inexact`, `pair-overflow`, `lagging`,
    /// `kept-last-safe`.
    pub fn name(&self) -> &'static str {
        match self {
            Self::Ok => "ok",
            Self::Inexact => "inexact",
            Self::PairOverflow => "pair-overflow",
            Self::Lagging => "lagging",
            Self::KeptLastSafe => "kept-last-safe",
        }
    }
}

/// The result of one step: a [`Frame`](crate::Frame) whose `wrench` and `raw_wrench` are both
/// the spring wrench (before the safety layer), with `t = 0` and `safety = 0`;
/// [`Engine::step`](crate::Engine::step) fills in the time and the safety layer's result.
pub type FrameOutput = crate::Frame;

/// The trust region that keeps a pass's iterates inside its detected region.
#[derive(Clone, Copy, Debug)]
enum Trust {
    /// Half-widths per coordinate around the region's centre: translation (mm), rotation (rad).
    Box(f64, f64),
    /// A thin slab around the predicted path (a segment in the QP variable): half-width (mm,
    /// in the variable scaled by `reach` for rotations) along and across it.
    Path(f64),
    /// A box turned to the expected motion: translation half-widths along the unit direction
    /// `dir` and across it (mm); rotation half-widths about the unit axis `turn` (`rot`) and
    /// about the two axes across it (`rot_across`; rad), or `rot` per component where `turn`
    /// is zero (`rot_across` is then `rot`). A ball region lasts longer for a tool sliding along `dir` or turning about
    /// `turn` than in an axis-aligned box of the same ball.
    Oriented {
        dir: [f64; 3],
        along: f64,
        across: f64,
        turn: [f64; 3],
        rot: f64,
        rot_across: f64,
    },
    /// A slab region's box, turned to the face's unit `normal`: translation half-widths
    /// across the face (`normal`) and along it (each of two axes), rotation half-widths about
    /// `normal` (`spin`) and about the two axes along the face (`tilt`; mm and rad).
    Slab {
        normal: [f64; 3],
        across: f64,
        along: f64,
        spin: f64,
        tilt: f64,
    },
}

/// A free-space proof: no leaf pair is within `radius` (mm) of touching with the tool at
/// `center`, or anywhere on its straight slide by `path` (mm, world, the same rotation), so
/// none is within `m` at a pose `q` while `b(path, q) + m <= radius`, `b` the motion bound
/// from the nearest pose on the path ([`GodObject::proof_distance`]).
#[derive(Clone, Copy, Debug)]
struct FreeProof {
    center: Pose,
    path: Vector3<f64>,
    /// mm; 0 = no proof.
    radius: f64,
}

impl FreeProof {
    fn none() -> Self {
        FreeProof {
            center: Pose::identity(),
            path: Vector3::zeros(),
            radius: 0.0,
        }
    }
}

/// A detected region: every leaf pair that can touch while each tool sphere stays within
/// `width` mm of where it is on the way from `center` along `sweep` (a ball of radius `width`
/// about `center` without a sweep) is in the pair list.
#[derive(Clone, Copy, Debug)]
struct Region {
    center: Pose,
    sweep: Option<Sweep>,
    /// Largest sphere motion along the sweep, mm (0 without one).
    length: f64,
    width: f64,
    /// A slab region: the face's unit normal and the region's width across it (mm; `width`
    /// is then the slide along it).
    slab: Option<(Vector3<f64>, f64)>,
    /// A ball region's near part of the tool: the only leaves that can touch within a wider
    /// margin, so a turn is bounded by their lever arm ([`Lever`]).
    lever: Option<Lever>,
}

/// The part of the tool near the objects at a ball region's centre: the box (tool frame, mm)
/// of every leaf centre within `width + skin +` [`Tuning::lever_margin_mm`] of an object
/// ([`collide::near_box`]). A pose is in the region while those leaves move at most
/// `width + skin` and every other leaf at most that plus [`Tuning::lever_margin_mm`]
/// ([`GodObject::distance_from_region`]).
#[derive(Clone, Copy, Debug)]
struct Lever {
    /// The box of the near leaves' centres (tool frame, mm).
    near: CentreBox,
    /// The largest distance (mm) of a box corner from the tool origin: a turn by `θ` moves
    /// the near leaves by at most `θ` times it.
    reach: f64,
}

impl Lever {
    /// The reach (mm) a ball region's trust box takes for its rotation part, allowing a motion
    /// of `allowed` mm (skin `skin`): the near leaves' reach, or more where the whole tool
    /// (`tool_reach`) turned that far would move more than [`Tuning::lever_margin_mm`] plus the skin.
    fn trust_reach(&self, tool_reach: f64, allowed: f64, skin: f64, lever_margin_mm: f64) -> f64 {
        self.reach
            .max(allowed * tool_reach / (lever_margin_mm + skin))
            .min(tool_reach)
    }
}

impl Region {
    /// A ball region of motion allowance `width` (mm) about `center`.
    fn ball(center: Pose, width: f64) -> Self {
        Region {
            center,
            sweep: None,
            length: 0.0,
            width,
            slab: None,
            lever: None,
        }
    }

    /// The pose at the end of the sweep (the centre without one).
    fn end(&self) -> Pose {
        match &self.sweep {
            None => self.center,
            Some(s) => Pose::from_translation_rotation(
                &(self.center.translation() + Vector3::from(s.translation)),
                &(rotation_exp(&Vector3::from(s.rotation)) * self.center.rotation_matrix()),
            ),
        }
    }

    /// Largest motion of a sphere anywhere in the region from the centre, mm.
    fn extent(&self) -> f64 {
        self.length + self.width
    }
}

/// Warm-start identity of a pair: (object, tool slot, object slot).
type PairId = (u32, u32, u32);

/// The god-object: owns the packed trees, all scratch memory and the graphic configuration.
/// Its state in groups (`step/state.rs`): the settings, the bodies, the detection buffers, the work
/// kept ahead, the QP's buffers, the materials, and what the run learnt.
pub struct GodObject {
    /// The settings ([`EngineConfig`]; the step reads all but the safety limits).
    params: EngineConfig,
    bodies: Bodies,
    detector: Detector,
    ahead: Ahead,
    qp: QpBuffers,
    materials: Materials,
    /// Everything learnt while running: replaced whole by [`GodObject::reset`].
    run: RunState,
}

impl GodObject {
    /// Packs the tool tree (tool frame, mm) and the object trees (object frame, mm, each with
    /// its fixed pose) and reserves every buffer (allocates; not real-time). The leaf spheres
    /// are the geometry ([`Geometry::Spheres`]); [`GodObject::with_meshes`] takes the parts'
    /// meshes too.
    pub fn new(
        tool: &SphereTree,
        objects: &[(SphereTree, Pose)],
        params: EngineConfig,
    ) -> Result<Self, EngineError> {
        Self::with_meshes(tool, None, objects, &[], params)
    }

    /// [`GodObject::new`] with the bodies' meshes (each in its tree's frame, mm): with
    /// `params.geometry` [`Geometry::Mesh`] and a mesh for the tool and every object, the step
    /// keeps the tool out of the parts' triangles, the trees (their leaves grown to hold the
    /// triangles whole: [`collide::MeshLeaves::attach`]) being the bounding hierarchy; with a
    /// mesh missing, or [`Geometry::Spheres`], the leaf spheres are the geometry
    /// ([`GodObject::geometry`] says which). The mesh mode needs the distance form and no face
    /// caps (the triangles are the faces).
    pub fn with_meshes(
        tool: &SphereTree,
        tool_mesh: Option<MeshRef<'_>>,
        objects: &[(SphereTree, Pose)],
        object_meshes: &[Option<MeshRef<'_>>],
        params: EngineConfig,
    ) -> Result<Self, EngineError> {
        params.validate()?; // the same ranges as the scene file (crate::config)
        let bad = |body: String, source: collide::CollideError| EngineError::Tree { body, source };
        let (tool_tree, object_trees, meshes) =
            attach_meshes(tool, tool_mesh, objects, object_meshes, &params)?;
        let tool = PackedTree::new(&tool_tree).map_err(|e| bad("tool tree".into(), e))?;
        let objects = object_trees
            .iter()
            .enumerate()
            .map(|(i, (t, p))| {
                let mut packed =
                    PackedTree::with_pose(t, p).map_err(|e| bad(format!("object {}", i + 1), e))?;
                if !params.face_caps || meshes.is_some() {
                    packed.drop_face_cuts();
                }
                Ok::<_, EngineError>(packed)
            })
            .collect::<Result<Vec<_>, _>>()?;
        let reach = tool
            .leaves()
            .map(|n| {
                let c = tool.center(n);
                (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt()
            })
            .fold(0.0, f64::max);
        // In the mesh mode the motion bound covers the triangles' corners too (the narrow
        // phase's bounding spheres move no farther than they).
        let corners = meshes.iter().flat_map(|m| m.tool.corners());
        let reach = meshes.as_ref().map_or(reach, |m| {
            m.tool
                .corners()
                .map(|p| Vector3::from(p).norm())
                .fold(reach, f64::max)
        });
        // The axes' arms in the mesh mode only (`CentreBox::axis_arms`).
        let centres = CentreBox::of_points(tool.leaves().map(|n| tool.center(n)).chain(corners))
            .with_axis_arms(meshes.is_some());
        let ws = CollideWorkspace::for_trees(&tool, &objects);
        let faces = objects.iter().any(|o| o.face_cut_count() > 0);
        let tool_slots = (0..tool.len()).map(|n| tool.slot(n) + 1).max().unwrap_or(0);
        let team = if params.helper_thread {
            let team = TraversalTeam::new(&tool, &objects, params.max_pairs)
                .map_err(|e| EngineError::HelperThread(e.to_string()))?;
            Some(team)
        } else {
            None
        };
        let n_objects = objects.len();
        let probe = FreeSpaceProbe::for_trees(&tool, &objects);
        let list_capacity = params.max_pairs.min(LIST_MAX_PAIRS);
        let neighbours = NeighbourList::for_trees(&tool, &objects, list_capacity);
        let next_neighbours = BackgroundList::for_trees(&tool, &objects, list_capacity);
        let cap = params.max_pairs;
        let detector = Detector::new(ws, team, cap, tool_slots, meshes.as_ref());
        let mut solver = Solver::new(params.solver);
        let mut rows_solver = RowGeneration::new();
        rows_solver.reserve(&mut solver, cap + 12);
        Ok(Self {
            params,
            bodies: Bodies {
                tool,
                objects,
                faces,
                reach,
                centres,
                meshes,
            },
            detector,
            ahead: Ahead {
                probe,
                neighbours,
                next_neighbours,
            },
            qp: QpBuffers {
                rows: resident(vec![[0.0; 6]; cap + 12]),
                rhs: resident(vec![0.0; cap + 12]),
                solver,
                rows_solver,
                audit: None,
            },
            materials: Materials {
                object_friction: vec![Friction::NONE; n_objects],
                tool_friction: None,
                friction_on: true,
            },
            run: RunState::fresh(&params.tuning),
        })
    }

    /// The settings.
    pub fn params(&self) -> &EngineConfig {
        &self.params
    }

    /// The QP solver and its workspaces, e.g. to change iteration caps or tolerances
    /// (`solver_mut().dual.params.max_iterations`) between frames.
    pub fn solver_mut(&mut self) -> &mut Solver {
        &mut self.qp.solver
    }

    /// The current graphic configuration.
    pub fn q_g(&self) -> Pose {
        self.run.motion.q_g
    }

    /// Largest distance of a tool leaf centre from the tool origin, mm.
    pub fn reach(&self) -> f64 {
        self.bodies.reach
    }

    /// Regions (detections) answered without a traversal (from a neighbour list, or from the
    /// last ball's own pairs), and by a traversal, since the last reset (or since the
    /// god-object was made): how much the lists spare.
    pub fn region_counts(&self) -> (u64, u64) {
        (
            self.run.counts.regions_filtered,
            self.run.counts.regions_traversed,
        )
    }

    /// The leaf pairs of the last detected region (empty in free space).
    pub fn pairs(&self) -> &[LeafPair] {
        &self.detector.pairs
    }

    /// Bench audit of the constraint reduction: with `on`, every reduced QP is also solved in
    /// full by a second solver, on the same rows, and the difference of the two answers'
    /// spring force `G dq` is kept ([`GodObject::take_reduction_audit`]). It costs a full
    /// solve per pass: for measuring, not for a device. Allocates (call outside the loop).
    pub fn audit_reduction(&mut self, on: bool) {
        self.qp.audit = on.then(|| {
            let mut solver = Solver::new(self.params.solver);
            solver.reserve(self.qp.rows.len());
            Box::new((solver, ReductionAudit::default()))
        });
    }

    /// What the audit measured since the last call (zero when it is off), and restarts it.
    pub fn take_reduction_audit(&mut self) -> ReductionAudit {
        self.qp
            .audit
            .as_mut()
            .map_or_else(ReductionAudit::default, |a| std::mem::take(&mut a.1))
    }

    /// Brings the trees' traversal arrays into cache until `until`: in the mesh mode the near
    /// list first (its pairs' bounds and gaps, which the next region's filter reads whole),
    /// then a chunk of each tree in turn, top levels first
    /// ([`collide::PackedTree::warm_chunk`]). A paced loop calls it as its spin before a
    /// deadline begins, so that the frame's filter and traversals do not start from memory
    /// that the wait let go cold (the next list's descent in the wait reads as much again).
    /// Changes no state (frames are the same with or without it).
    ///
    /// # Real-time
    /// No allocation; returns within one chunk's reads (a few µs) of `until`.
    pub fn warm_caches(&self, until: Instant) {
        let mut acc = 0u32;
        for k in 0.. {
            if !self.detector.warm_near_chunk(k, &mut acc) || Instant::now() >= until {
                break;
            }
        }
        for k in 0.. {
            let mut read = self.bodies.tool.warm_chunk(k, &mut acc);
            for o in &self.bodies.objects {
                read |= o.warm_chunk(k, &mut acc);
            }
            if !read || Instant::now() >= until {
                break;
            }
        }
        std::hint::black_box(acc);
    }

    /// Resets the graphic tool for a new run at the device pose `start`: `q_g = start` if it is
    /// free, else a free pose near it found by repeated projection (each pass: detect at the
    /// current `q`, solve the QP toward `start`, re-measure), within the distance the coupling
    /// stretches at the device's force limit (`max_force_n / kt`, as the largest motion of a
    /// tool sphere from `start`): a start deeper than that, or one whose projection leaves
    /// that distance, is [`EngineError::NoFreeStart`]. Nothing learnt in an earlier run
    /// carries over (warm start, prediction, pair density, cached regions, free-space proofs,
    /// probes, neighbour lists, friction's stick or slip, counts): the frames after a reset are
    /// those of a new god-object reset at the same pose. Allocation-free after `new`.
    pub fn reset(&mut self, start: &Pose) -> Result<Pose, EngineError> {
        self.forget_run();
        if !start.is_finite() {
            return Err(EngineError::NoFreeStart { searched_mm: 0.0 });
        }
        let mut q = *start;
        let tol = self.params.penetration_tol_mm.max(1e-6);
        let mut searched = 0.0f64;
        // A free pose whose spheres are farther from the start than the coupling stretches at
        // the device's force limit is not near it (the device would start clamped, pulled
        // toward a tool it cannot see): the search stays within that.
        let radius = self.params.safety.max_force_n / self.params.kt;
        for _ in 0..RESET_SEARCH_PASSES {
            if self.penetration_at(&q) <= tol {
                self.run.motion.q_g = q;
                self.run.motion.started = true;
                return Ok(q);
            }
            // Push out: linearize at q with the gap target, minimising distance to `start`.
            let margin = self.params.skin_mm.max(0.5);
            if self.detect(&q, margin).is_err() {
                break;
            }
            self.narrow_phase(&q, margin);
            let Some(lin) = self.linearization(&q, start) else {
                break;
            };
            let n = self.fill_rows(&lin, None);
            // Aim for a gap of `tol` rather than 0 so the projection ends strictly outside.
            for d in &mut self.qp.rhs[..n] {
                *d += tol;
            }
            let Some((dq, _, _, _)) = self.solve(n, n, &lin.delta()) else {
                break;
            };
            let next = lin.configuration(&dq);
            if !next.is_finite() {
                break;
            }
            let moved = self.motion_bound(start, &next);
            searched = searched.max(moved.min(radius));
            if moved > radius {
                break;
            }
            q = next;
        }
        Err(EngineError::NoFreeStart {
            searched_mm: searched,
        })
    }

    /// Forgets the run so far: the state learnt while running starts fresh, as in
    /// [`GodObject::new`] ([`RunState::fresh`]), and the buffers a run fills are emptied in
    /// place (their capacity kept: a reset does not allocate). Settings (friction, the
    /// reduction audit) and the trees stay.
    fn forget_run(&mut self) {
        self.run = RunState::fresh(&self.params.tuning);
        self.detector.pairs.clear();
        self.ahead.probe.cancel();
        self.ahead.neighbours.clear();
        self.ahead.next_neighbours.cancel();
    }

    /// One haptic frame for the device configuration `q_h` (see the module docs): start,
    /// reuse last frame's region, then passes of detect (plan, list, adopt a region) and solve
    /// (rows, QP, verify), conclude and advance.
    ///
    /// # Real-time
    /// No allocation (all buffers reserved in [`GodObject::new`]), no panic. Bounded: at most
    /// `1 + relinearize` passes (fewer when `budget_us` would be overrun), each of at most two
    /// traversals and one QP solve (the solver's iteration cap).
    pub fn step(&mut self, q_h: &Pose) -> FrameOutput {
        let t_start = Instant::now();
        self.run.counts.frame_splits = 0;
        self.run.counts.frame_scanned = 0;
        // Whether this frame's time ran out before a region was listed (a region that lists
        // nothing, in proven free space, does not clear it).
        self.run.regions.interrupted = false;
        let mut out = FrameOutput {
            q_h: q_h.to_array(),
            ..FrameOutput::default()
        };
        if !self.run.motion.started {
            self.run.motion.q_g = *q_h;
            self.run.motion.started = true;
        }
        // A non-finite or absurd reading (beyond 1e6 mm or rad: `q - q_h` then keeps too few
        // digits for the constraints) is a device fault: keep the last safe pose.
        if !q_h.is_finite() || q_h.q.iter().any(|v| v.abs() > 1e6) {
            return self.keep_last_safe(out, q_h, t_start);
        }
        // Friction: the tool sticks (stays), or the passes go toward a goal held back from the
        // hand by the friction; the wrench is always the spring to the hand.
        let friction = self.friction_active();
        let (goal, friction_state) = if friction {
            self.friction_goal(q_h)
        } else {
            (*q_h, FrictionState::None)
        };
        out.friction = friction_state;
        let mut f = self.start_frame(*q_h, goal, t_start);
        (f.friction, f.friction_state) = (friction, friction_state);
        self.reuse_region(&mut f, &mut out);
        for pass in 0..f.max_passes {
            f.clock.pass_start = Instant::now();
            // In the mesh mode a new region's pass starts only where one as costly as the last
            // fits (its narrow phase, stopped at the deadline, would leave the frame lagging).
            let new_mesh_region = f.course.detect_now && self.bodies.meshes.is_some();
            let region_pass_us = if new_mesh_region {
                self.run.regions.mesh_region_pass_us
            } else {
                0.0
            };
            if pass > 0
                && (!f
                    .clock
                    .room_for_pass(self.params.budget_us, self.params.tuning.pass_headroom)
                    || f.clock.elapsed_us() + region_pass_us > self.params.budget_us)
            {
                break;
            }
            out.passes = pass + 1;
            let detected = if f.course.detect_now {
                self.detect_stage(&mut f, &mut out, pass)
            } else {
                Flow::Go
            };
            let flow = match detected {
                Flow::Go => self.solve_pass(&mut f, &mut out),
                other => other,
            };
            if new_mesh_region {
                self.run.regions.mesh_region_pass_us =
                    f.clock.pass_start.elapsed().as_secs_f64() * 1e6;
            }
            if let Some((from, pairs)) = f.clock.rows_from.take() {
                self.run.regions.mesh_contact_us =
                    from.elapsed().as_secs_f64() * 1e6 / pairs.max(1) as f64;
            }
            match flow {
                Flow::Go | Flow::Next => {}
                Flow::Stop => break,
                Flow::Fail => return self.keep_last_safe(out, q_h, t_start),
            }
        }
        self.conclude(&mut f, &mut out);
        self.advance(&f, &mut out);
        out
    }

    fn keep_last_safe(&mut self, mut out: FrameOutput, q_h: &Pose, t0: Instant) -> FrameOutput {
        out.status = FrameStatus::KeptLastSafe;
        out.q_g = self.run.motion.q_g.to_array();
        self.run.solve.warm_len = 0;
        let w = if q_h.is_finite() {
            spring_wrench(
                &self.params.g(),
                self.params.rotation,
                &self.run.motion.q_g,
                q_h,
            )
        } else {
            [0.0; 6]
        };
        for k in 0..6 {
            out.wrench[k] = if w[k].is_finite() { w[k] } else { 0.0 };
            out.raw_wrench[k] = out.wrench[k];
        }
        out.total_us = t0.elapsed().as_secs_f64() * 1e6;
        out
    }
}

/// The tool's tree, the objects' placed trees, and the meshes when the mesh mode has them.
type AttachedMeshes = (SphereTree, Vec<(SphereTree, Pose)>, Option<Meshes>);

/// `v` with its storage resident ([`collide::touch_pages`]).
fn resident<T: Copy>(mut v: Vec<T>) -> Vec<T> {
    collide::touch_pages(&mut v);
    v
}

/// In the mesh mode (asked for, and every body with its mesh), the sphere-trees' top levels
/// grown to hold the triangles and the triangles' own box trees; else the trees as given and no
/// meshes.
fn attach_meshes(
    tool: &SphereTree,
    tool_mesh: Option<MeshRef<'_>>,
    objects: &[(SphereTree, Pose)],
    object_meshes: &[Option<MeshRef<'_>>],
    params: &EngineConfig,
) -> Result<AttachedMeshes, EngineError> {
    let mesh_bad =
        |body: String, source: collide::MeshLeavesError| EngineError::Mesh { body, source };
    let all_meshes = tool_mesh.is_some()
        && object_meshes.len() == objects.len()
        && object_meshes.iter().all(Option::is_some);
    let (mut tool_tree, mut object_trees) = (tool.clone(), objects.to_vec());
    let mut meshes = None;
    if params.geometry == Geometry::Mesh && all_meshes {
        if params.form != collide::ConstraintForm::Distance {
            return Err(EngineError::MeshNeedsDistance);
        }
        // The sphere-trees' top levels, grown to hold the triangles, keep the free-space
        // answers true for the parts; the narrow phase finds and measures the triangles
        // themselves through their own box trees.
        let attach = |tree: &SphereTree, m: &MeshRef<'_>, pose: &Pose| {
            let tree = &top_levels(tree, MESH_SPHERE_LEVELS);
            let (grown, _) = collide::MeshLeaves::attach(tree, m.vertices, m.triangles, pose)?;
            let triangles: Vec<collide::Triangle> = if params.heuristics.mesh_flat_faces {
                collide::merge_flat_faces(m.vertices, m.triangles).triangles
            } else {
                m.triangles
                    .iter()
                    .map(|t| t.map(|i| m.vertices[i as usize]))
                    .collect()
            };
            let splits = params.heuristics.mesh_face_splits;
            let tree = TriangleTree::build_split(&triangles, pose, splits);
            Ok::<_, collide::MeshLeavesError>((grown, tree))
        };
        let tm = tool_mesh.as_ref().ok_or(EngineError::MeshNeedsDistance)?;
        let (grown, tool_triangles) =
            attach(tool, tm, &Pose::identity()).map_err(|e| mesh_bad("tool mesh".into(), e))?;
        tool_tree = grown;
        let mut object_triangles = Vec::with_capacity(objects.len());
        for (i, ((t, p), m)) in objects.iter().zip(object_meshes).enumerate() {
            let Some(m) = m else { continue };
            let (grown, tris) =
                attach(t, m, p).map_err(|e| mesh_bad(format!("object {} mesh", i + 1), e))?;
            object_trees[i].0 = grown;
            object_triangles.push(tris);
        }
        meshes = Some(Meshes {
            tool: tool_triangles,
            objects: object_triangles,
        });
    }
    Ok((tool_tree, object_trees, meshes))
}

/// The first `levels` levels of `tree` (all of it when it has no more), its face caps dropped:
/// the mesh mode's bounding hierarchy.
fn top_levels(tree: &SphereTree, levels: u32) -> SphereTree {
    let levels = levels.clamp(1, tree.levels());
    let slots = spheretree::slot_count(levels, tree.branching()).unwrap_or(tree.len());
    SphereTree::from_slots(levels, tree.branching(), tree.spheres()[..slots].to_vec())
        .unwrap_or_else(|_| tree.clone())
}

#[cfg(test)]
mod tests {
    use super::*;
    use spheretree::Sphere;

    /// Last frame's region is reused while the tool is well inside it, but not once its trust
    /// region stopped the last answer in it: the tool would be stopped there again at once.
    #[test]
    fn a_region_whose_trust_region_stopped_the_last_answer_is_not_reused() {
        let mut g = ring();
        let q = Pose::identity();
        let trust = g.trust_box(0.1, 1.0, 1.0, g.bodies.reach);
        g.run.regions.cached = Some((Region::ball(q, 0.1), trust));
        let hand = Pose::from_array([0.5, 0.0, 0.0, 0.0, 0.0, 0.0]);
        for (bound, reused) in [(false, true), (true, false)] {
            g.run.regions.cached_bound = bound;
            let mut f = g.start_frame(hand, hand, Instant::now());
            let mut out = FrameOutput::default();
            g.reuse_region(&mut f, &mut out);
            assert_eq!(f.course.reused, reused, "bound: {bound}");
        }
    }

    /// A ring of eight small tool spheres about a large one, 0.2 mm from a small object.
    fn ring() -> GodObject {
        let mut tool = SphereTree::new_unused(2, 8).unwrap();
        for k in 0..8 {
            let a = std::f64::consts::FRAC_PI_4 * k as f64;
            tool.spheres_mut()[1 + k] = Sphere::new([12.0 * a.cos(), 12.0 * a.sin(), 0.0], 1.0);
        }
        tool.spheres_mut()[0] = Sphere::new([0.0, 0.0, 0.0], 14.0);
        let mut object = SphereTree::new_unused(1, 8).unwrap();
        object.spheres_mut()[0] = Sphere::new([14.2, 0.0, 0.0], 1.0);
        GodObject::new(
            &tool,
            &[(object, Pose::identity())],
            EngineConfig::default(),
        )
        .unwrap()
    }

    /// After a run pressed into a contact, a reset leaves the run state as a new god-object's
    /// reset at the same pose leaves it, and every buffer as large as it was (a reset does
    /// not allocate).
    #[test]
    fn a_reset_leaves_the_state_of_a_new_god_object() {
        let start = Pose::identity();
        let mut used = ring();
        used.reset(&start).unwrap();
        for i in 0..50 {
            let hand = Pose::from_array([0.02 * i as f64, 0.0, 0.0, 0.0, 0.0, 0.002 * i as f64]);
            used.step(&hand);
        }
        assert!(used.run.motion.contacts_g > 0, "the run ends in contact");
        let capacities = (
            used.detector.pairs.capacity(),
            used.qp.rows.len(),
            used.qp.rhs.len(),
        );
        used.reset(&start).unwrap();
        let mut fresh = ring();
        fresh.reset(&start).unwrap();
        assert_eq!(format!("{:?}", used.run), format!("{:?}", fresh.run));
        assert_eq!(used.detector.pairs, fresh.detector.pairs);
        assert_eq!(
            (
                used.detector.pairs.capacity(),
                used.qp.rows.len(),
                used.qp.rhs.len()
            ),
            capacities
        );
    }
}
