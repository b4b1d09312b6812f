//! The engine handle: made from a scene (`h6d_scene_engine`, in `scene.rs`) or from files
//! (`h6d_engine_from_files`), then reset, stepped once per haptic frame, read, destroyed.

use scene::error_chain;
use std::ffi::c_char;
use std::path::Path;

use engine::{Engine, EngineConfig, EngineError, Pose};
use scene::cache::TreeCache;
use scene::TreeParams;
use spheretree::SphereTree;

use crate::status::{door, fail, non_null, Failure, H6dStatus};
use crate::types::{H6dBody, H6dConfig, H6dContact, H6dCounters, H6dFrameInfo, H6dFrameWork};

/// An engine behind an opaque pointer. One thread at a time: the engine holds no lock (the
/// step must not wait), so a handle shared between threads needs the caller's own hand-over.
pub struct H6dEngine {
    pub(crate) engine: Engine,
    /// A panic was caught inside a call on this handle: its state may be half-updated, so
    /// every later call refuses it.
    poisoned: bool,
}

impl H6dEngine {
    /// A handle owning `engine`, as the raw pointer handed to C.
    pub(crate) fn into_raw(engine: Engine) -> *mut H6dEngine {
        Box::into_raw(Box::new(H6dEngine {
            engine,
            poisoned: false,
        }))
    }
}

/// Runs `body` on the engine behind `handle` through the door: NULL and poisoned handles are
/// refused, a panic poisons the handle.
///
/// # Safety
/// `handle` is NULL or a live pointer from this library, used by no other thread meanwhile.
unsafe fn with_engine(
    call: &str,
    handle: *mut H6dEngine,
    body: impl FnOnce(&mut Engine) -> Result<(), H6dStatus>,
) -> i32 {
    door(
        call,
        || {
            non_null(call, "engine", handle)?;
            // SAFETY: non-NULL, and live and unshared by the caller's contract.
            let h = unsafe { &mut *handle };
            if h.poisoned {
                return Err(fail!(
                    call,
                    Panic,
                    "this engine was poisoned by an earlier panic inside it; destroy it and make a new one"
                ));
            }
            body(&mut h.engine)
        },
        || {
            if !handle.is_null() {
                // SAFETY: as above; the body's borrow ended with the unwind.
                unsafe { (*handle).poisoned = true };
            }
        },
    )
}

/// Six numbers read from a caller's array (mm, rad).
///
/// # Safety
/// `p` points to 6 readable doubles.
unsafe fn read6(p: *const f64) -> [f64; 6] {
    // SAFETY: the caller's contract; `[f64; 6]` has the alignment of `f64`.
    unsafe { p.cast::<[f64; 6]>().read() }
}

/// Writes six numbers to a caller's array when it is not NULL.
///
/// # Safety
/// `p` is NULL or points to 6 writable doubles.
unsafe fn write6(p: *mut f64, v: &[f64; 6]) {
    if !p.is_null() {
        // SAFETY: the caller's contract.
        unsafe { p.cast::<[f64; 6]>().write(*v) };
    }
}

/// An engine error as a failure: settings are the caller's argument, the rest the engine's
/// refusal. The message is the error and its causes on one line.
pub(crate) fn engine_failure(e: &EngineError) -> Failure {
    let status = match e {
        EngineError::Setting(_) => H6dStatus::InvalidArgument,
        _ => H6dStatus::Engine,
    };
    Failure::new(status, error_chain(e))
}

/// A NUL-terminated UTF-8 argument as text.
///
/// # Safety
/// `p` is NULL or points to a NUL-terminated string.
pub(crate) unsafe fn text_arg<'a>(
    call: &str,
    name: &str,
    p: *const c_char,
) -> Result<&'a str, H6dStatus> {
    non_null(call, name, p)?;
    // SAFETY: non-NULL and NUL-terminated by the caller's contract.
    let s = unsafe { std::ffi::CStr::from_ptr(p) };
    s.to_str()
        .map_err(|e| fail!(call, InvalidArgument, "`{name}` is not UTF-8 text ({e})"))
}

/// Writes the project's default settings (stiffness 1 N/mm and 1000 N·mm/rad, the exact dual
/// solver, distance constraints, rotation-vector coordinates, up to 7 re-linearisation passes
/// within a 1000 µs budget, the default device limits) to `*out`.
///
/// # Safety
/// `out` is NULL or points to a writable `H6dConfig`.
#[no_mangle]
pub unsafe extern "C" fn h6d_config_default(out: *mut H6dConfig) -> i32 {
    const CALL: &str = "h6d_config_default";
    door(
        CALL,
        || {
            non_null(CALL, "out", out)?;
            // SAFETY: non-NULL and writable by the caller's contract.
            unsafe { out.write(H6dConfig::from(&EngineConfig::default())) };
            Ok(())
        },
        || {},
    )
}

/// Makes an engine from sphere-tree or mesh files: the tool, `n_objects` objects (each with
/// its fixed pose), the settings `config` (NULL: `h6d_config_default()`), reset at `start`
/// (`[x, y, z, gamma, beta, alpha]`, mm and rad; when `start` is in collision, a free pose near
/// it, within the coupling's stretch at the force limit, `max_force_n / kt`). Allocates and may build trees (seconds for a large mesh; cached in
/// `$HAPTIC6D_CACHE`, else `~/.cache/haptic6d`): call it before the haptic loop.
///
/// On success `*out` is the new engine (free it with `h6d_engine_destroy`); on failure
/// `*out` is NULL and the message names the body, the file and what is wrong.
///
/// # Safety
/// `tool` points to an `H6dBody`; `objects` to `n_objects` of them (may be NULL when
/// `n_objects` is 0); their paths are NUL-terminated; `config` is NULL or points to an
/// `H6dConfig`; `start` points to 6 doubles; `out` to a writable pointer.
#[no_mangle]
pub unsafe extern "C" fn h6d_engine_from_files(
    tool: *const H6dBody,
    objects: *const H6dBody,
    n_objects: usize,
    config: *const H6dConfig,
    start: *const f64,
    out: *mut *mut H6dEngine,
) -> i32 {
    const CALL: &str = "h6d_engine_from_files";
    door(
        CALL,
        || {
            non_null(CALL, "out", out)?;
            // SAFETY: writable by the caller's contract; NULL until an engine exists.
            unsafe { out.write(std::ptr::null_mut()) };
            non_null(CALL, "tool", tool)?;
            non_null(CALL, "start", start)?;
            if n_objects > 0 {
                non_null(CALL, "objects", objects)?;
            }
            let config = if config.is_null() {
                EngineConfig::default()
            } else {
                // SAFETY: non-NULL, points to an H6dConfig.
                unsafe { *config }.to_engine().map_err(|f| f.report(CALL))?
            };
            // SAFETY: 6 readable doubles.
            let start = unsafe { read6(start) };
            engine::config::check_pose("start", &start)
                .map_err(|e| fail!(CALL, InvalidArgument, "{e}"))?;
            let cache = TreeCache::from_env();
            // SAFETY: points to an H6dBody.
            let tool_tree = unsafe { load_body(CALL, "tool", &*tool, &cache)? };
            let mut trees = Vec::with_capacity(n_objects);
            for i in 0..n_objects {
                // SAFETY: `objects` holds `n_objects` bodies.
                let body = unsafe { &*objects.add(i) };
                let label = format!("objects[{i}]");
                engine::config::check_pose(&format!("{label}.pose"), &body.pose)
                    .map_err(|e| fail!(CALL, InvalidArgument, "{e}"))?;
                // SAFETY: its path is NULL or NUL-terminated.
                let tree = unsafe { load_body(CALL, &label, body, &cache)? };
                trees.push((tree, Pose::from_array(body.pose)));
            }
            let mut engine = Engine::new(&tool_tree, &trees, config)
                .map_err(|e| engine_failure(&e).report(CALL))?;
            engine
                .reset(&Pose::from_array(start))
                .map_err(|e| engine_failure(&e).report(CALL))?;
            // SAFETY: writable by the caller's contract.
            unsafe { out.write(H6dEngine::into_raw(engine)) };
            Ok(())
        },
        || {},
    )
}

/// The tree of one body file: a `.sph` read and scaled, or a mesh scaled and its tree built or
/// fetched from the cache.
///
/// # Safety
/// `body.path` is NULL or NUL-terminated.
unsafe fn load_body(
    call: &str,
    label: &str,
    body: &H6dBody,
    cache: &TreeCache,
) -> Result<SphereTree, H6dStatus> {
    // SAFETY: the caller's contract.
    let path = unsafe { text_arg(call, &format!("{label}.path"), body.path)? };
    let scale = body.scale;
    if !(scale.is_finite() && scale > 0.0) {
        return Err(fail!(
            call,
            InvalidArgument,
            "{label}.scale = {scale}: must be a finite number > 0 (file units to mm)"
        ));
    }
    let p = Path::new(path);
    if let Err(e) = std::fs::metadata(p) {
        return Err(fail!(call, Io, "{label}: cannot read {path}: {e}"));
    }
    let is_sph = p.extension().is_some_and(|x| x.eq_ignore_ascii_case("sph"));
    let tree = if is_sph {
        let mut tree = spheretree::sph::read_sph(p)
            .map_err(|e| fail!(call, Scene, "{label}: {}", error_chain(&e)))?;
        scene::scale_tree(&mut tree, scale);
        let finite = tree
            .spheres()
            .iter()
            .all(|s| s.radius.is_finite() && s.center.iter().all(|c| c.is_finite()));
        if !finite {
            return Err(fail!(
                call,
                InvalidArgument,
                "{label}: scale = {scale} makes the tree {path} overflow (non-finite spheres)"
            ));
        }
        tree.enforce_containment();
        tree
    } else {
        let mut mesh =
            scene::scenes::load_mesh_file(p).map_err(|e| fail!(call, Scene, "{label}: {e}"))?;
        for v in &mut mesh.vertices {
            *v = v.map(|c| c * scale);
        }
        let params = TreeParams {
            depth: 4,
            branching: 8,
            method: spheretree::build::BuildMethod::Tight,
        };
        scene::tree_for_mesh(&mesh, params, cache, label, &mut Vec::new())
            .map_err(|e| fail!(call, Scene, "{}", error_chain(&e)))?
    };
    Ok(tree)
}

/// Starts a new run with the device at `start` (`[x, y, z, gamma, beta, alpha]`, mm and rad):
/// the graphic tool goes to `start`, or when `start` is in collision to a free pose within
/// `max_force_n / kt` of it (else an error), written to `q_g` when not NULL; the soft start and the counters start again.
/// Allocation-free.
///
/// # Safety
/// `engine` is NULL or a live engine used by no other thread meanwhile; `start` points to 6
/// doubles; `q_g` is NULL or points to 6 writable doubles.
#[no_mangle]
pub unsafe extern "C" fn h6d_engine_reset(
    engine: *mut H6dEngine,
    start: *const f64,
    q_g: *mut f64,
) -> i32 {
    const CALL: &str = "h6d_engine_reset";
    // SAFETY: the caller's contract.
    unsafe {
        with_engine(CALL, engine, |e| {
            non_null(CALL, "start", start)?;
            let start = read6(start);
            if let Some((i, v)) = start.iter().enumerate().find(|(_, v)| !v.is_finite()) {
                return Err(fail!(
                    CALL,
                    InvalidArgument,
                    "start[{i}] = {v}: the start pose must be finite (mm, rad)"
                ));
            }
            let q = e
                .reset(&Pose::from_array(start))
                .map_err(|err| engine_failure(&err).report(CALL))?;
            write6(q_g, &q.to_array());
            Ok(())
        })
    }
}

/// One haptic frame at time `t` (s; the soft start counts from the first frame's `t`) for the
/// device pose `q_h` (`[x, y, z, gamma, beta, alpha]`, mm and rad): writes the wrench to send
/// to the device `[Fx, Fy, Fz, Tx, Ty, Tz]` (N, N·mm, world axes; finite and within the
/// safety limits), and, when not NULL, the graphic tool's pose `q_g` (mm, rad: draw the tool
/// there) and what the frame did `info`.
///
/// A NaN or infinite `q_h` or `t` returns `H6D_STATUS_INVALID_ARGUMENT` naming the value, and
/// the outputs are still written: the frame kept the last safe pose and the wrench is safe to
/// send, so a loop that sends it whatever the status stays safe.
///
/// # Real-time
/// No allocation, no lock, no panic, bounded time (at most `1 + relinearize` passes within
/// `budget_us`); error messages are written into a fixed per-thread buffer.
///
/// # Safety
/// `engine` is NULL or a live engine used by no other thread meanwhile; `q_h` points to 6
/// doubles, `wrench` to 6 writable doubles; `q_g` is NULL or points to 6 writable doubles;
/// `info` is NULL or points to a writable `H6dFrameInfo`.
#[no_mangle]
pub unsafe extern "C" fn h6d_engine_step(
    engine: *mut H6dEngine,
    t: f64,
    q_h: *const f64,
    wrench: *mut f64,
    q_g: *mut f64,
    info: *mut H6dFrameInfo,
) -> i32 {
    const CALL: &str = "h6d_engine_step";
    // SAFETY: the caller's contract.
    unsafe {
        with_engine(CALL, engine, |e| {
            non_null(CALL, "q_h", q_h)?;
            non_null(CALL, "wrench", wrench)?;
            let q = read6(q_h);
            let frame = e.step(t, &Pose::from_array(q));
            write6(wrench, &frame.wrench);
            write6(q_g, &frame.q_g);
            if !info.is_null() {
                info.write(H6dFrameInfo::from(frame));
            }
            if let Some((i, v)) = q.iter().enumerate().find(|(_, v)| !v.is_finite()) {
                return Err(fail!(
                    CALL,
                    InvalidArgument,
                    "q_h[{i}] = {v}: the device pose must be finite (mm, rad); the frame kept the last safe pose and wrote a safe wrench"
                ));
            }
            if !t.is_finite() {
                return Err(fail!(
                    CALL,
                    InvalidArgument,
                    "t = {t}: the frame time must be finite (s); the wrench written is safe"
                ));
            }
            Ok(())
        })
    }
}

/// The end of a paced loop's wait of `max_us` µs from now, for `call`; a limit outside 0 to
/// 1 000 000 µs is `H6D_STATUS_INVALID_ARGUMENT` naming it.
fn wait_until(call: &str, max_us: f64) -> Result<std::time::Instant, H6dStatus> {
    if !(0.0..=1e6).contains(&max_us) {
        return Err(fail!(
            call,
            InvalidArgument,
            "max_us = {max_us}: the wait's limit must be within 0 to 1000000 µs"
        ));
    }
    Ok(std::time::Instant::now() + std::time::Duration::from_secs_f64(max_us * 1e-6))
}

/// Brings the engine's collision trees into cache for at most `max_us` µs (0 to 1 000 000),
/// top levels first. A paced device loop calls it as it stops sleeping before a frame's
/// deadline (with the time left until then): the sleep lets the caches go cold, and a frame
/// whose traversal starts from memory is slower (`haptic6d run --realtime` does the same;
/// docs/DESIGN.md §The haptic loop). Changes no state. A `max_us` outside its range returns
/// `H6D_STATUS_INVALID_ARGUMENT` naming it.
///
/// # Real-time
/// No allocation, no lock, no panic; returns within a few µs of `max_us`.
///
/// # Safety
/// `engine` is NULL or a live engine used by no other thread meanwhile.
#[no_mangle]
pub unsafe extern "C" fn h6d_engine_warm_caches(engine: *mut H6dEngine, max_us: f64) -> i32 {
    const CALL: &str = "h6d_engine_warm_caches";
    // SAFETY: the caller's contract.
    unsafe {
        with_engine(CALL, engine, |e| {
            e.warm_caches(wait_until(CALL, max_us)?);
            Ok(())
        })
    }
}

/// Uses a paced device loop's wait before the next frame, for at most `max_us` µs (0 to
/// 1 000 000): the background detection work the frames would otherwise do in slices (the next
/// free-space proof, the next neighbour list) runs here, then the collision trees are brought
/// into cache, as [`h6d_engine_warm_caches`] does. Call it as the loop stops sleeping before a
/// frame's deadline, with the time left until then (`haptic6d run --realtime` does the same;
/// docs/DESIGN.md §The haptic loop). The answers stay exact; which frames detect, and so their
/// times, may differ from a loop that does not call it. A `max_us` outside its range returns
/// `H6D_STATUS_INVALID_ARGUMENT` naming it.
///
/// # Real-time
/// No allocation, no panic; returns within ~40 µs of `max_us`.
///
/// # Safety
/// `engine` is NULL or a live engine used by no other thread meanwhile.
#[no_mangle]
pub unsafe extern "C" fn h6d_engine_idle(engine: *mut H6dEngine, max_us: f64) -> i32 {
    const CALL: &str = "h6d_engine_idle";
    // SAFETY: the caller's contract.
    unsafe {
        with_engine(CALL, engine, |e| {
            e.idle(wait_until(CALL, max_us)?);
            Ok(())
        })
    }
}

/// The leaf-sphere pairs of the last detected region (for display): writes their number to
/// `*count` and copies them into `contacts` (room for `capacity`). When `capacity` is too
/// small, returns `H6D_STATUS_BUFFER_TOO_SMALL`, with `*count` the number needed and the
/// first `capacity` pairs copied. `contacts` may be NULL when `capacity` is 0 (to ask the
/// count). Allocation-free.
///
/// # Safety
/// `engine` is NULL or a live engine used by no other thread meanwhile; `contacts` is NULL or
/// points to `capacity` writable `H6dContact`; `count` points to a writable `size_t`.
#[no_mangle]
pub unsafe extern "C" fn h6d_engine_contacts(
    engine: *mut H6dEngine,
    contacts: *mut H6dContact,
    capacity: usize,
    count: *mut usize,
) -> i32 {
    const CALL: &str = "h6d_engine_contacts";
    // SAFETY: the caller's contract.
    unsafe {
        with_engine(CALL, engine, |e| {
            non_null(CALL, "count", count)?;
            if capacity > 0 {
                non_null(CALL, "contacts", contacts)?;
            }
            let pairs = e.contacts();
            count.write(pairs.len());
            for (i, p) in pairs.iter().take(capacity).enumerate() {
                contacts.add(i).write(H6dContact::from(p));
            }
            if pairs.len() > capacity {
                return Err(fail!(
                    CALL,
                    BufferTooSmall,
                    "{} contact pairs do not fit in a buffer of {capacity}; the first {capacity} were copied, pass a buffer of {} or more",
                    pairs.len(),
                    pairs.len()
                ));
            }
            Ok(())
        })
    }
}

/// Sets the Coulomb friction of object `object` (0-based, in the order the objects were
/// given): static and kinetic coefficients (dimensionless, 0..=5, `kinetic_mu <= static_mu`).
/// Objects start frictionless. Between frames, not in the haptic loop (it validates).
///
/// # Safety
/// `engine` is NULL or a live engine used by no other thread meanwhile.
#[no_mangle]
pub unsafe extern "C" fn h6d_engine_set_friction(
    engine: *mut H6dEngine,
    object: u32,
    static_mu: f64,
    kinetic_mu: f64,
) -> i32 {
    const CALL: &str = "h6d_engine_set_friction";
    let friction = engine::Friction {
        static_mu,
        kinetic_mu,
    };
    // SAFETY: the caller's contract.
    unsafe {
        with_engine(CALL, engine, |e| {
            e.set_friction(object as usize, friction)
                .map_err(|err| engine_failure(&err).report(CALL))
        })
    }
}

/// Turns friction on (`on != 0`) or off, keeping the coefficients (off: the frictionless
/// frames). Allocation-free.
///
/// # Safety
/// `engine` is NULL or a live engine used by no other thread meanwhile.
#[no_mangle]
pub unsafe extern "C" fn h6d_engine_set_friction_enabled(engine: *mut H6dEngine, on: i32) -> i32 {
    const CALL: &str = "h6d_engine_set_friction_enabled";
    // SAFETY: the caller's contract.
    unsafe {
        with_engine(CALL, engine, |e| {
            e.set_friction_enabled(on != 0);
            Ok(())
        })
    }
}

/// Writes the frames counted since the last reset, by outcome, to `*out`. Allocation-free.
///
/// # Safety
/// `engine` is NULL or a live engine used by no other thread meanwhile; `out` points to a
/// writable `H6dCounters`.
#[no_mangle]
pub unsafe extern "C" fn h6d_engine_counters(engine: *mut H6dEngine, out: *mut H6dCounters) -> i32 {
    const CALL: &str = "h6d_engine_counters";
    // SAFETY: the caller's contract.
    unsafe {
        with_engine(CALL, engine, |e| {
            non_null(CALL, "out", out)?;
            out.write(H6dCounters::from(e.counters()));
            Ok(())
        })
    }
}

/// Writes the work of the last frame stepped (node pairs split, list entries scanned, rows
/// solved, margin) to `*out`; zeros before the first frame. Allocation-free.
///
/// # Safety
/// `engine` is NULL or a live engine used by no other thread meanwhile; `out` points to a
/// writable `H6dFrameWork`.
#[no_mangle]
pub unsafe extern "C" fn h6d_engine_frame_work(
    engine: *mut H6dEngine,
    out: *mut H6dFrameWork,
) -> i32 {
    const CALL: &str = "h6d_engine_frame_work";
    // SAFETY: the caller's contract.
    unsafe {
        with_engine(CALL, engine, |e| {
            non_null(CALL, "out", out)?;
            out.write(H6dFrameWork::from(e.frame()));
            Ok(())
        })
    }
}

/// Writes the engine's settings to `*out`.
///
/// # Safety
/// `engine` is NULL or a live engine used by no other thread meanwhile; `out` points to a
/// writable `H6dConfig`.
#[no_mangle]
pub unsafe extern "C" fn h6d_engine_config(engine: *mut H6dEngine, out: *mut H6dConfig) -> i32 {
    const CALL: &str = "h6d_engine_config";
    // SAFETY: the caller's contract.
    unsafe {
        with_engine(CALL, engine, |e| {
            non_null(CALL, "out", out)?;
            out.write(H6dConfig::from(e.config()));
            Ok(())
        })
    }
}

/// What the engine's tool touches: writes 0 (the trees' leaf spheres) or 1 (the parts' own
/// meshes: a scene with `[solver] geometry = "mesh"` whose bodies all came from meshes) to
/// `*out`.
///
/// # Safety
/// `engine` is NULL or a live engine used by no other thread meanwhile; `out` points to a
/// writable `int32_t`.
#[no_mangle]
pub unsafe extern "C" fn h6d_engine_geometry(engine: *mut H6dEngine, out: *mut i32) -> i32 {
    const CALL: &str = "h6d_engine_geometry";
    // SAFETY: the caller's contract.
    unsafe {
        with_engine(CALL, engine, |e| {
            non_null(CALL, "out", out)?;
            out.write(match e.geometry() {
                engine::Geometry::Spheres => 0,
                engine::Geometry::Mesh => 1,
            });
            Ok(())
        })
    }
}

/// Frees an engine. NULL is accepted and ignored (so is a poisoned engine: it is freed).
///
/// # Safety
/// `engine` is NULL or a live engine from this library, not used afterwards.
#[no_mangle]
pub unsafe extern "C" fn h6d_engine_destroy(engine: *mut H6dEngine) -> i32 {
    door(
        "h6d_engine_destroy",
        || {
            if !engine.is_null() {
                // SAFETY: made by Box::into_raw in this library, freed once by the contract.
                drop(unsafe { Box::from_raw(engine) });
            }
            Ok(())
        },
        || {},
    )
}
