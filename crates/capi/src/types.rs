//! The C structs and enums: settings, frame information, contacts, counters, and their
//! conversions from and to the engine's Rust types.

use engine::safety::SafetyParams;
use engine::{ConstraintForm, Counters, EngineConfig, Frame, FrameStatus, LeafPair};
use engine::{RotationCoordinates, SolverKind};

use crate::status::{Failure, H6dStatus};

/// QP solver of the god-object step (`H6dConfig::solver`).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum H6dSolver {
    /// Goldfarb–Idnani dual active-set: exact, the default.
    Dual = 0,
    /// The paper's parallel QP (multiplicative updates).
    Pqp = 1,
    /// The paper's primal active-set baseline.
    ActiveSet = 2,
    /// The paper's PQP vectorized and split over worker threads (one per core, spawned when
    /// the engine is created): the serial PQP's iterates up to rounding.
    PqpParallel = 3,
}

/// Constraint form (`H6dConfig::form`).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum H6dForm {
    /// Signed distance between leaf spheres, mm: the default.
    Distance = 0,
    /// The paper's squared distance, mm².
    Squared = 1,
}

/// Rotation coordinates of the QP variable and the spring torque (`H6dConfig::rotation`).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum H6dRotation {
    /// Rotation vector about the current orientation: the default.
    RotationVector = 0,
    /// The paper's Euler angles `(gamma, beta, alpha)`.
    Euler = 1,
}

/// How a frame ended (`H6dFrameInfo::status`).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum H6dFrameStatus {
    /// Solved: the constrained optimum within the penetration tolerance.
    Ok = 0,
    /// The QP answer violates its linearised constraints beyond the solver's tolerance (e.g.
    /// PQP stopped early); its pose was used.
    Inexact = 1,
    /// More leaf pairs than `max_pairs`: the last pose proven free was kept.
    PairOverflow = 2,
    /// Passes or time budget ran out: the tool lags the hand this frame, never penetrating.
    Lagging = 3,
    /// The frame failed (non-finite input, numerical breakdown): the last safe pose was kept.
    KeptLastSafe = 4,
}

/// `H6dFrameInfo::safety` bit: the force was clamped to `max_force_n`.
pub const H6D_SAFETY_FORCE_CLAMP: u32 = 1;
/// `H6dFrameInfo::safety` bit: the torque was clamped to `max_torque_nmm`.
pub const H6D_SAFETY_TORQUE_CLAMP: u32 = 2;
/// `H6dFrameInfo::safety` bit: the change of force or torque was rate-limited.
pub const H6D_SAFETY_RATE_LIMIT: u32 = 4;
/// `H6dFrameInfo::safety` bit: the frame was non-finite; the last safe wrench was sent.
pub const H6D_SAFETY_NAN_GUARD: u32 = 8;
/// `H6dFrameInfo::safety` bit: the soft-start ramp scaled the wrench.
pub const H6D_SAFETY_SOFT_START: u32 = 16;

// Literals above so cbindgen writes them into the header; the engine's own flags, checked.
const _: () = {
    use engine::safety::flags;
    assert!(H6D_SAFETY_FORCE_CLAMP == flags::FORCE_CLAMP as u32);
    assert!(H6D_SAFETY_TORQUE_CLAMP == flags::TORQUE_CLAMP as u32);
    assert!(H6D_SAFETY_RATE_LIMIT == flags::RATE_LIMIT as u32);
    assert!(H6D_SAFETY_NAN_GUARD == flags::NAN_GUARD as u32);
    assert!(H6D_SAFETY_SOFT_START == flags::SOFT_START as u32);
};

/// Every setting of an engine. Start from `h6d_config_default()` (or `h6d_scene_config()`)
/// and change fields; the engine checks each against the same range as a scene file's key
/// (a value outside it gives `H6D_STATUS_INVALID_ARGUMENT` naming the key and the range).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct H6dConfig {
    /// Translational stiffness of the virtual coupling, N/mm.
    pub kt: f64,
    /// Rotational stiffness of the virtual coupling, N·mm/rad.
    pub kr: f64,
    /// QP solver: an `H6dSolver` value.
    pub solver: u32,
    /// Constraint form: an `H6dForm` value.
    pub form: u32,
    /// Rotation coordinates: an `H6dRotation` value.
    pub rotation: u32,
    /// Extra detect + solve passes per frame (0 = the paper's single pass), passes.
    pub relinearize: u32,
    /// Penetration tolerated before another pass, mm.
    pub penetration_tol_mm: f64,
    /// Detection skin added to the motion bound, mm.
    pub skin_mm: f64,
    /// Largest motion of any tool sphere in one pass, mm.
    pub max_margin_mm: f64,
    /// Time budget of one frame's step, µs: no pass starts that would end past it.
    pub budget_us: f64,
    /// Leaf pairs stored per pass (reserved when the engine is made), pairs.
    pub max_pairs: u64,
    /// Largest force magnitude sent, N.
    pub max_force_n: f64,
    /// Largest torque magnitude sent, N·mm.
    pub max_torque_nmm: f64,
    /// Largest change of the force between two frames, N per frame.
    pub max_force_step_n: f64,
    /// Largest change of the torque between two frames, N·mm per frame.
    pub max_torque_step_nmm: f64,
    /// Duration of the soft start (the wrench ramps from 0 to full), s.
    pub soft_start_s: f64,
}

impl From<&EngineConfig> for H6dConfig {
    fn from(c: &EngineConfig) -> Self {
        Self {
            kt: c.kt,
            kr: c.kr,
            solver: match c.solver {
                SolverKind::Dual => H6dSolver::Dual,
                SolverKind::Pqp => H6dSolver::Pqp,
                SolverKind::ActiveSet => H6dSolver::ActiveSet,
                SolverKind::PqpParallel => H6dSolver::PqpParallel,
            } as u32,
            form: match c.form {
                ConstraintForm::Distance => H6dForm::Distance,
                ConstraintForm::Squared => H6dForm::Squared,
            } as u32,
            rotation: match c.rotation {
                RotationCoordinates::RotationVector => H6dRotation::RotationVector,
                RotationCoordinates::Euler => H6dRotation::Euler,
            } as u32,
            relinearize: c.relinearize,
            penetration_tol_mm: c.penetration_tol_mm,
            skin_mm: c.skin_mm,
            max_margin_mm: c.max_margin_mm,
            budget_us: c.budget_us,
            max_pairs: c.max_pairs as u64,
            max_force_n: c.safety.max_force_n,
            max_torque_nmm: c.safety.max_torque_nmm,
            max_force_step_n: c.safety.max_force_step_n,
            max_torque_step_nmm: c.safety.max_torque_step_nmm,
            soft_start_s: c.safety.soft_start_s,
        }
    }
}

impl H6dConfig {
    /// The engine's settings, every enum value and range checked (the engine's own
    /// [`EngineConfig::validate`], so the ranges are the scene file's).
    pub(crate) fn to_engine(self) -> Result<EngineConfig, Failure> {
        let solver = match self.solver {
            0 => SolverKind::Dual,
            1 => SolverKind::Pqp,
            2 => SolverKind::ActiveSet,
            3 => SolverKind::PqpParallel,
            v => {
                return Err(bad_enum(
                    "solver",
                    v,
                    "H6D_SOLVER_DUAL (0), H6D_SOLVER_PQP (1), H6D_SOLVER_ACTIVE_SET (2), H6D_SOLVER_PQP_PARALLEL (3)",
                ))
            }
        };
        let form = match self.form {
            0 => ConstraintForm::Distance,
            1 => ConstraintForm::Squared,
            v => {
                return Err(bad_enum(
                    "form",
                    v,
                    "H6D_FORM_DISTANCE (0), H6D_FORM_SQUARED (1)",
                ))
            }
        };
        let rotation = match self.rotation {
            0 => RotationCoordinates::RotationVector,
            1 => RotationCoordinates::Euler,
            v => {
                return Err(bad_enum(
                    "rotation",
                    v,
                    "H6D_ROTATION_ROTATION_VECTOR (0), H6D_ROTATION_EULER (1)",
                ))
            }
        };
        // A count past usize (32-bit targets) is out of range anyway: saturate so the range
        // check names it.
        let max_pairs = usize::try_from(self.max_pairs).unwrap_or(usize::MAX);
        let config = EngineConfig {
            kt: self.kt,
            kr: self.kr,
            rotation,
            form,
            solver,
            relinearize: self.relinearize,
            penetration_tol_mm: self.penetration_tol_mm,
            skin_mm: self.skin_mm,
            max_margin_mm: self.max_margin_mm,
            budget_us: self.budget_us,
            max_pairs,
            // Not in the C struct (its layout is the ABI): the engine's default, reduction on.
            reduce_rows: EngineConfig::default().reduce_rows,
            helper_thread: EngineConfig::default().helper_thread,
            face_caps: EngineConfig::default().face_caps,
            heuristics: EngineConfig::default().heuristics,
            tuning: EngineConfig::default().tuning,
            geometry: EngineConfig::default().geometry,
            safety: SafetyParams {
                max_force_n: self.max_force_n,
                max_torque_nmm: self.max_torque_nmm,
                max_force_step_n: self.max_force_step_n,
                max_torque_step_nmm: self.max_torque_step_nmm,
                soft_start_s: self.soft_start_s,
            },
        };
        match config.validate() {
            Ok(()) => Ok(config),
            // The one failure with owned text: made on set-up, never in the haptic frame.
            Err(e) => Err(Failure::new(
                H6dStatus::InvalidArgument,
                format!("config: {e}"),
            )),
        }
    }
}

fn bad_enum(field: &str, v: u32, expected: &str) -> Failure {
    Failure::new(
        H6dStatus::InvalidArgument,
        format!("config: {field} = {v}: must be one of {expected}"),
    )
}

/// What one frame did, besides the wrench and the pose (`h6d_engine_step`'s `info`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct H6dFrameInfo {
    /// Time given to the step, s.
    pub t: f64,
    /// How the step ended: an `H6dFrameStatus` value.
    pub status: u32,
    /// What the safety layer did: `H6D_SAFETY_*` bits (0 = nothing).
    pub safety: u32,
    /// Leaf pairs in the first pass's QP.
    pub pairs: u32,
    /// Leaf pairs touching at the graphic pose: the contact's size.
    pub contacts: u32,
    /// Passes made (detect + solve).
    pub passes: u32,
    /// Solver iterations, summed over passes.
    pub iterations: u32,
    /// Deepest leaf–leaf overlap at the graphic pose, mm (0 when free).
    pub penetration_mm: f64,
    /// Time in collision detection, µs.
    pub cd_us: f64,
    /// Time building constraint rows and solving, µs.
    pub opt_us: f64,
    /// Time of the whole step (without the safety layer), µs.
    pub total_us: f64,
    /// The spring wrench before the safety layer `[Fx, Fy, Fz, Tx, Ty, Tz]`: N and N·mm.
    pub raw_wrench: [f64; 6],
    /// What friction did: 0 nothing, 1 the tool stuck, 2 it slipped.
    pub friction: u32,
}

impl From<&Frame> for H6dFrameInfo {
    fn from(f: &Frame) -> Self {
        Self {
            t: f.t,
            status: frame_status(f.status) as u32,
            safety: u32::from(f.safety),
            pairs: f.pairs,
            contacts: f.contacts,
            passes: f.passes,
            iterations: f.iterations,
            penetration_mm: f.penetration_mm,
            cd_us: f.cd_us,
            opt_us: f.opt_us,
            total_us: f.total_us,
            raw_wrench: f.raw_wrench,
            friction: u32::from(f.friction.code()),
        }
    }
}

/// The work of the last frame (`h6d_engine_frame_work`): kept apart from `H6dFrameInfo`, whose
/// layout callers already compile against.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct H6dFrameWork {
    /// Node pairs split by the frame's traversals, free-space probe slices and neighbour-list
    /// build slices. Unlike the times it does not depend on the machine (one thread, no
    /// deadline reached): frame-step variants can be compared by it.
    pub splits: u32,
    /// Neighbour-list entries the frame tested (each ~10× cheaper than a split), entries.
    pub scanned: u32,
    /// Constraint rows in the frame's largest solve, after reduction (trust-region rows
    /// included), rows.
    pub rows: u32,
    /// Detection margin of the frame's first pass, mm.
    pub margin_mm: f64,
    /// Largest linearised-constraint violation the solver reported, mm.
    pub qp_violation_mm: f64,
}

impl From<&Frame> for H6dFrameWork {
    fn from(f: &Frame) -> Self {
        Self {
            splits: f.splits,
            scanned: f.scanned,
            rows: f.rows,
            margin_mm: f.margin_mm,
            qp_violation_mm: f.qp_violation,
        }
    }
}

fn frame_status(s: FrameStatus) -> H6dFrameStatus {
    match s {
        FrameStatus::Ok => H6dFrameStatus::Ok,
        FrameStatus::Inexact => H6dFrameStatus::Inexact,
        FrameStatus::PairOverflow => H6dFrameStatus::PairOverflow,
        FrameStatus::Lagging => H6dFrameStatus::Lagging,
        FrameStatus::KeptLastSafe => H6dFrameStatus::KeptLastSafe,
    }
}

/// One leaf-sphere pair of the last detected region (`h6d_engine_contacts`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct H6dContact {
    /// Index of the object (0-based, in the order the objects were given).
    pub object: u32,
    /// Slot of the tool leaf in the tool's sphere-tree.
    pub tool_slot: u32,
    /// Slot of the object leaf in the object's sphere-tree.
    pub object_slot: u32,
    /// Centre of the tool leaf sphere in the tool frame, mm.
    pub p_in_tool: [f64; 3],
    /// Radius of the tool leaf sphere, mm.
    pub r_tool_mm: f64,
    /// Centre of the object leaf sphere in the world, mm.
    pub o_in_world: [f64; 3],
    /// Radius of the object leaf sphere, mm.
    pub r_object_mm: f64,
    /// Gap between the two spheres at the pass's linearisation pose, mm (negative = overlap).
    pub gap_mm: f64,
}

impl From<&LeafPair> for H6dContact {
    fn from(p: &LeafPair) -> Self {
        Self {
            object: p.object,
            tool_slot: p.tool_slot,
            object_slot: p.object_slot,
            p_in_tool: p.p_in_tool,
            r_tool_mm: p.r_tool,
            o_in_world: p.o_in_world,
            r_object_mm: p.r_object,
            gap_mm: p.gap,
        }
    }
}

/// Frames counted since the last reset, by outcome (`h6d_engine_counters`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct H6dCounters {
    /// Frames stepped.
    pub frames: u64,
    /// Frames that kept the last safe pose (`H6D_FRAME_STATUS_KEPT_LAST_SAFE`).
    pub kept_last_safe: u64,
    /// Frames whose pair list overflowed (`H6D_FRAME_STATUS_PAIR_OVERFLOW`).
    pub pair_overflows: u64,
    /// Frames whose QP answer was inexact (`H6D_FRAME_STATUS_INEXACT`).
    pub inexact: u64,
    /// Frames that ended short of the optimum, safe (`H6D_FRAME_STATUS_LAGGING`).
    pub lagging: u64,
    /// Frames whose force was clamped.
    pub force_clamps: u64,
    /// Frames whose torque was clamped.
    pub torque_clamps: u64,
    /// Frames whose wrench change was rate-limited.
    pub rate_limits: u64,
    /// Frames that were non-finite and sent the last safe wrench.
    pub nan_frames: u64,
    /// Frames scaled by the soft start.
    pub soft_start_frames: u64,
}

impl From<&Counters> for H6dCounters {
    fn from(c: &Counters) -> Self {
        Self {
            frames: c.frames,
            kept_last_safe: c.kept_last_safe,
            pair_overflows: c.pair_overflows,
            inexact: c.inexact,
            lagging: c.lagging,
            force_clamps: c.safety.force_clamps,
            torque_clamps: c.safety.torque_clamps,
            rate_limits: c.safety.rate_limits,
            nan_frames: c.safety.nan_frames,
            soft_start_frames: c.safety.soft_start_frames,
        }
    }
}

/// A sphere-tree or mesh file for `h6d_engine_from_files`.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct H6dBody {
    /// Path of a Bradshaw `.sph` sphere-tree, or of a mesh (`.obj`, `.stl`, `.ply`) whose tree
    /// is built (depth 4, branching 8, the tight builder) or read from the tree cache.
    /// NUL-terminated UTF-8.
    pub path: *const std::ffi::c_char,
    /// File units to mm (1 when the file is in mm).
    pub scale: f64,
    /// The body's fixed pose in the world `[x, y, z, gamma, beta, alpha]` (mm, rad); ignored
    /// for the tool, whose pose is the device's.
    pub pose: [f64; 6],
}
