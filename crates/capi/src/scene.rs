//! The scene handle: a built-in scene or a scene file loaded once, read for its settings,
//! start pose and rate, and turned into engines.

use std::ffi::c_char;
use std::path::Path;

use engine::Engine;
use scene::cache::TreeCache;
use scene::{Scene, SceneError};

use crate::engine::{engine_failure, text_arg, H6dEngine};
use crate::status::{door, fail, non_null, Failure, H6dStatus};
use crate::types::H6dConfig;
use scene::error_chain;

/// A loaded scene (trees in mm, settings, start pose, device rate) behind an opaque pointer.
/// Read-only after loading: it may be read from several threads at once.
pub struct H6dScene {
    scene: Scene,
}

/// A scene error as a failure: which status, and the message with its causes on one line.
fn scene_failure(e: &SceneError) -> Failure {
    let status = match e {
        SceneError::Io { .. } | SceneError::ThreadStart(_) | SceneError::ThreadPanicked => {
            H6dStatus::Io
        }
        SceneError::Trajectory { .. } | SceneError::Scene { .. } | SceneError::Unknown { .. } => {
            H6dStatus::Scene
        }
        SceneError::Setting(_) => H6dStatus::InvalidArgument,
        SceneError::Engine { source, .. } => return engine_failure(source),
    };
    Failure::new(status, error_chain(e))
}

/// Runs `body` on the scene behind `handle` through the door (NULL refused).
///
/// # Safety
/// `handle` is NULL or a live scene from this library.
unsafe fn with_scene(
    call: &str,
    handle: *const H6dScene,
    body: impl FnOnce(&Scene) -> Result<(), H6dStatus>,
) -> i32 {
    door(
        call,
        || {
            non_null(call, "scene", handle)?;
            // SAFETY: non-NULL and live by the caller's contract; read-only.
            body(unsafe { &(*handle).scene })
        },
        || {},
    )
}

/// Loads a scene: a built-in one (`"bunny"`, `"spline"`, `"plate"`, `"spline-tight"`,
/// `"probe"`) or a scene file (`.toml`, paths inside it relative to the file). Trees are built
/// from meshes or read from the tree cache (`$HAPTIC6D_CACHE`, else `~/.cache/haptic6d`): the
/// first load of a built-in scene takes seconds, later ones milliseconds. Call it before the
/// haptic loop.
///
/// On success `*out` is the scene (free it with `h6d_scene_destroy`); on failure `*out` is
/// NULL: `H6D_STATUS_IO` for a missing or unreadable file, `H6D_STATUS_SCENE` for a malformed
/// one or an unknown name, with a message naming the file and what is wrong.
///
/// # Safety
/// `name` is NULL or NUL-terminated; `out` points to a writable pointer.
#[no_mangle]
pub unsafe extern "C" fn h6d_scene_load(name: *const c_char, out: *mut *mut H6dScene) -> i32 {
    const CALL: &str = "h6d_scene_load";
    door(
        CALL,
        || {
            non_null(CALL, "out", out)?;
            // SAFETY: writable by the caller's contract; NULL until a scene exists.
            unsafe { out.write(std::ptr::null_mut()) };
            // SAFETY: NULL or NUL-terminated.
            let name = unsafe { text_arg(CALL, "name", name)? };
            let cache = TreeCache::from_env();
            let path = Path::new(name);
            let loaded = if scene::scenes::is_builtin(name)
                || (scene::scenes::is_builtin_family(name) && !path.is_file())
            {
                scene::scenes::builtin(name, &cache)
            } else {
                if !path.is_file() {
                    return Err(fail!(CALL, Io, "{}", scene::scenes::no_such_scene(name)));
                }
                scene::load_scene_file(path, &cache)
            };
            let scene = loaded.map_err(|e| scene_failure(&e).report(CALL))?;
            // SAFETY: writable by the caller's contract.
            unsafe { out.write(Box::into_raw(Box::new(H6dScene { scene }))) };
            Ok(())
        },
        || {},
    )
}

/// Writes the scene's engine settings (its coupling, solver and safety sections) to `*out`:
/// change fields and pass it to `h6d_scene_engine`.
///
/// # Safety
/// `scene` is NULL or a live scene; `out` points to a writable `H6dConfig`.
#[no_mangle]
pub unsafe extern "C" fn h6d_scene_config(scene: *const H6dScene, out: *mut H6dConfig) -> i32 {
    const CALL: &str = "h6d_scene_config";
    // SAFETY: the caller's contract.
    unsafe {
        with_scene(CALL, scene, |s| {
            non_null(CALL, "out", out)?;
            out.write(H6dConfig::from(&s.engine_config()));
            Ok(())
        })
    }
}

/// Writes the scene's tool start pose `[x, y, z, gamma, beta, alpha]` (mm, rad) to `start`.
///
/// # Safety
/// `scene` is NULL or a live scene; `start` points to 6 writable doubles.
#[no_mangle]
pub unsafe extern "C" fn h6d_scene_start(scene: *const H6dScene, start: *mut f64) -> i32 {
    const CALL: &str = "h6d_scene_start";
    // SAFETY: the caller's contract.
    unsafe {
        with_scene(CALL, scene, |s| {
            non_null(CALL, "start", start)?;
            start.cast::<[f64; 6]>().write(s.start.to_array());
            Ok(())
        })
    }
}

/// Writes the scene's haptic rate to `*rate_hz`, Hz (frame `i` of a replay is at `i / rate_hz`
/// s, as `haptic6d run` steps it).
///
/// # Safety
/// `scene` is NULL or a live scene; `rate_hz` points to a writable double.
#[no_mangle]
pub unsafe extern "C" fn h6d_scene_rate_hz(scene: *const H6dScene, rate_hz: *mut f64) -> i32 {
    const CALL: &str = "h6d_scene_rate_hz";
    // SAFETY: the caller's contract.
    unsafe {
        with_scene(CALL, scene, |s| {
            non_null(CALL, "rate_hz", rate_hz)?;
            rate_hz.write(s.rate_hz);
            Ok(())
        })
    }
}

/// Makes the scene's engine with the settings `config` (NULL: the scene's own), reset at the
/// scene's start pose (or a free pose near it). Allocates: call it before the haptic loop.
/// The engine owns copies of the trees and meshes: the scene may be destroyed afterwards.
/// What the tool touches is the scene's `[solver] geometry` either way (`H6dConfig` has no
/// such field): its meshes where it asks for them and every body has one, else the leaf
/// spheres (`h6d_engine_geometry` says which).
///
/// On success `*out` is the engine (free it with `h6d_engine_destroy`); on failure `*out` is
/// NULL and the message names the setting or what the engine refused.
///
/// # Safety
/// `scene` is NULL or a live scene; `config` is NULL or points to an `H6dConfig`; `out`
/// points to a writable pointer.
#[no_mangle]
pub unsafe extern "C" fn h6d_scene_engine(
    scene: *const H6dScene,
    config: *const H6dConfig,
    out: *mut *mut H6dEngine,
) -> i32 {
    const CALL: &str = "h6d_scene_engine";
    // SAFETY: the caller's contract.
    unsafe {
        with_scene(CALL, scene, |s| {
            non_null(CALL, "out", out)?;
            out.write(std::ptr::null_mut());
            let config = if config.is_null() {
                s.engine_config()
            } else {
                let mut c = (*config).to_engine().map_err(|f| f.report(CALL))?;
                c.geometry = s.solver.geometry;
                c
            };
            let (tool_mesh, object_meshes) = s.mesh_refs();
            let mut engine =
                Engine::with_meshes(&s.tool, tool_mesh, &s.objects, &object_meshes, config)
                    .map_err(|e| {
                        Failure::new(
                            engine_failure(&e).status,
                            format!("{}: {}", s.name, error_chain(&e)),
                        )
                        .report(CALL)
                    })?;
            s.apply_friction(&mut engine).map_err(|e| {
                Failure::new(H6dStatus::InvalidArgument, error_chain(&e)).report(CALL)
            })?;
            engine.reset(&s.start).map_err(|e| {
                Failure::new(
                    engine_failure(&e).status,
                    format!("{}: {}", s.name, error_chain(&e)),
                )
                .report(CALL)
            })?;
            out.write(H6dEngine::into_raw(engine));
            Ok(())
        })
    }
}

/// Frees a scene. NULL is accepted and ignored. Engines made from it live on.
///
/// # Safety
/// `scene` is NULL or a live scene from this library, not used afterwards.
#[no_mangle]
pub unsafe extern "C" fn h6d_scene_destroy(scene: *mut H6dScene) -> i32 {
    door(
        "h6d_scene_destroy",
        || {
            if !scene.is_null() {
                // SAFETY: made by Box::into_raw in this library, freed once by the contract.
                drop(unsafe { Box::from_raw(scene) });
            }
            Ok(())
        },
        || {},
    )
}
