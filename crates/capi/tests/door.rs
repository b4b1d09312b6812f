//! Bad input through the C door: NULL pointers, missing and malformed files, settings out of
//! range, NaN poses, a contacts buffer too small. Each gives its status and a one-line message
//! naming the call and what is wrong; nothing crashes, and the engine stays usable.
//!
//! The entry points are called from Rust exactly as C calls them (raw pointers, status codes).

use std::ffi::{CStr, CString};
use std::path::Path;
use std::ptr::{null, null_mut};

use haptic6d::*;
use spheretree::{Sphere, SphereTree};

fn message() -> String {
    // SAFETY: never NULL, NUL-terminated.
    unsafe { CStr::from_ptr(h6d_last_error_message()) }
        .to_str()
        .unwrap()
        .to_string()
}

/// Asserts `status` is `want` and the message holds every part of `parts`, on one line.
#[track_caller]
fn expect(status: i32, want: H6dStatus, parts: &[&str]) {
    let m = message();
    assert_eq!(
        H6dStatus::from_code(status),
        Some(want),
        "status {status}, message: {m}"
    );
    for p in parts {
        assert!(m.contains(p), "`{p}` not in the message: {m}");
    }
    assert!(!m.contains('\n'), "one line: {m}");
}

fn c(s: &str) -> CString {
    CString::new(s).unwrap()
}

/// A one-sphere `.sph` tree of radius `r` mm at the origin, written into `dir`.
fn sph(dir: &Path, name: &str, r: f64) -> CString {
    let tree = SphereTree::from_slots(1, 2, vec![Sphere::new([0.0; 3], r)]).unwrap();
    let path = dir.join(name);
    spheretree::sph::write_sph(&tree, &path).unwrap();
    c(path.to_str().unwrap())
}

fn body(path: &CString, pose: [f64; 6]) -> H6dBody {
    H6dBody {
        path: path.as_ptr(),
        scale: 1.0,
        pose,
    }
}

/// A 5 mm tool sphere above a 20 mm object sphere, the tool at z = 40 mm.
fn spheres(dir: &Path) -> *mut H6dEngine {
    let tool = sph(dir, "tool.sph", 5.0);
    let object = sph(dir, "object.sph", 20.0);
    let mut engine = null_mut();
    let start = [0.0, 0.0, 40.0, 0.0, 0.0, 0.0];
    // SAFETY: valid pointers throughout.
    let s = unsafe {
        h6d_engine_from_files(
            &body(&tool, [0.0; 6]),
            &body(&object, [0.0; 6]),
            1,
            null(),
            start.as_ptr(),
            &mut engine,
        )
    };
    expect(s, H6dStatus::Ok, &[]);
    assert!(!engine.is_null());
    engine
}

/// Frame `i` (1 ms apart) of the tool pressed down into the object of [`spheres`] at 0.1 mm a
/// frame from z = 40 mm; the frame must succeed.
///
/// # Safety
/// `engine` is a live engine.
unsafe fn press_frame(
    engine: *mut H6dEngine,
    i: usize,
    w: &mut [f64; 6],
    q_g: &mut [f64; 6],
    info: &mut H6dFrameInfo,
) {
    let q = [0.0, 0.0, 40.0 - 0.1 * i as f64, 0.0, 0.0, 0.0];
    // SAFETY: the caller's engine; the other pointers are valid references.
    let s = unsafe {
        h6d_engine_step(
            engine,
            i as f64 * 1e-3,
            q.as_ptr(),
            w.as_mut_ptr(),
            q_g.as_mut_ptr(),
            info,
        )
    };
    expect(s, H6dStatus::Ok, &[]);
}

#[test]
fn null_pointers_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let engine = spheres(dir.path());
    let q = [0.0, 0.0, 40.0, 0.0, 0.0, 0.0];
    let mut w = [0.0; 6];
    let mut count = 0usize;
    // SAFETY: every non-NULL pointer is valid; the NULL ones are what is tested.
    unsafe {
        let mut scene = null_mut();
        expect(
            h6d_scene_load(null(), &mut scene),
            H6dStatus::NullArgument,
            &["h6d_scene_load", "`name` is NULL"],
        );
        assert!(scene.is_null());
        expect(
            h6d_scene_load(c("bunny").as_ptr(), null_mut()),
            H6dStatus::NullArgument,
            &["`out` is NULL"],
        );
        expect(
            h6d_scene_config(null(), &mut std::mem::zeroed()),
            H6dStatus::NullArgument,
            &["h6d_scene_config", "`scene`"],
        );
        expect(
            h6d_engine_step(
                null_mut(),
                0.0,
                q.as_ptr(),
                w.as_mut_ptr(),
                null_mut(),
                null_mut(),
            ),
            H6dStatus::NullArgument,
            &["h6d_engine_step", "`engine` is NULL"],
        );
        expect(
            h6d_engine_step(engine, 0.0, null(), w.as_mut_ptr(), null_mut(), null_mut()),
            H6dStatus::NullArgument,
            &["`q_h` is NULL"],
        );
        expect(
            h6d_engine_step(engine, 0.0, q.as_ptr(), null_mut(), null_mut(), null_mut()),
            H6dStatus::NullArgument,
            &["`wrench` is NULL"],
        );
        expect(
            h6d_engine_reset(engine, null(), null_mut()),
            H6dStatus::NullArgument,
            &["h6d_engine_reset", "`start` is NULL"],
        );
        expect(
            h6d_engine_contacts(engine, null_mut(), 0, null_mut()),
            H6dStatus::NullArgument,
            &["`count` is NULL"],
        );
        expect(
            h6d_engine_contacts(engine, null_mut(), 4, &mut count),
            H6dStatus::NullArgument,
            &["`contacts` is NULL"],
        );
        expect(
            h6d_engine_counters(engine, null_mut()),
            H6dStatus::NullArgument,
            &["h6d_engine_counters", "`out` is NULL"],
        );
        expect(
            h6d_engine_frame_work(engine, null_mut()),
            H6dStatus::NullArgument,
            &["h6d_engine_frame_work", "`out` is NULL"],
        );
        expect(
            h6d_engine_config(engine, null_mut()),
            H6dStatus::NullArgument,
            &["h6d_engine_config"],
        );
        expect(
            h6d_config_default(null_mut()),
            H6dStatus::NullArgument,
            &["h6d_config_default"],
        );
        let mut out = null_mut();
        expect(
            h6d_engine_from_files(null(), null(), 0, null(), q.as_ptr(), &mut out),
            H6dStatus::NullArgument,
            &["`tool` is NULL"],
        );
        let tool = sph(dir.path(), "t.sph", 1.0);
        expect(
            h6d_engine_from_files(
                &body(&tool, [0.0; 6]),
                null(),
                2,
                null(),
                q.as_ptr(),
                &mut out,
            ),
            H6dStatus::NullArgument,
            &["`objects` is NULL"],
        );
        expect(
            h6d_engine_from_files(
                &H6dBody {
                    path: null(),
                    scale: 1.0,
                    pose: [0.0; 6],
                },
                null(),
                0,
                null(),
                q.as_ptr(),
                &mut out,
            ),
            H6dStatus::NullArgument,
            &["`tool.path` is NULL"],
        );
        assert!(out.is_null());
        // Destroying NULL is allowed.
        expect(h6d_engine_destroy(null_mut()), H6dStatus::Ok, &[]);
        expect(h6d_scene_destroy(null_mut()), H6dStatus::Ok, &[]);
        // The engine still works after all that.
        expect(
            h6d_engine_step(
                engine,
                0.0,
                q.as_ptr(),
                w.as_mut_ptr(),
                null_mut(),
                null_mut(),
            ),
            H6dStatus::Ok,
            &[],
        );
        h6d_engine_destroy(engine);
    }
}

#[test]
fn missing_and_malformed_files_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let start = [0.0; 6];
    let mut scene = null_mut();
    let mut engine = null_mut();
    let missing = dir.path().join("missing.toml");
    let garbage = dir.path().join("garbage.toml");
    std::fs::write(&garbage, "[tool\nmesh = ").unwrap();
    let no_mesh = dir.path().join("no_mesh.toml");
    std::fs::write(
        &no_mesh,
        "[tool]\nmesh = \"nowhere.obj\"\n[[object]]\nmesh = \"nowhere.obj\"\n",
    )
    .unwrap();
    let bad_sph = dir.path().join("bad.sph");
    std::fs::write(&bad_sph, "1 8\n0 0 zero 1\n").unwrap();
    let bad_sph = c(bad_sph.to_str().unwrap());
    let no_sph = c(dir.path().join("none.sph").to_str().unwrap());
    // SAFETY: valid pointers.
    unsafe {
        expect(
            h6d_scene_load(c(missing.to_str().unwrap()).as_ptr(), &mut scene),
            H6dStatus::Io,
            &["missing.toml", "no built-in scene or scene file"],
        );
        expect(
            h6d_scene_load(c("teapot").as_ptr(), &mut scene),
            H6dStatus::Io,
            &["`teapot`", "bunny, spline, plate"],
        );
        expect(
            h6d_scene_load(c(garbage.to_str().unwrap()).as_ptr(), &mut scene),
            H6dStatus::Scene,
            &["garbage.toml"],
        );
        expect(
            h6d_scene_load(c(no_mesh.to_str().unwrap()).as_ptr(), &mut scene),
            H6dStatus::Scene,
            &["no_mesh.toml", "nowhere.obj"],
        );
        assert!(scene.is_null());
        expect(
            h6d_engine_from_files(
                &body(&no_sph, [0.0; 6]),
                null(),
                0,
                null(),
                start.as_ptr(),
                &mut engine,
            ),
            H6dStatus::Io,
            &["tool: cannot read", "none.sph"],
        );
        expect(
            h6d_engine_from_files(
                &body(&bad_sph, [0.0; 6]),
                null(),
                0,
                null(),
                start.as_ptr(),
                &mut engine,
            ),
            H6dStatus::Scene,
            &["tool", "bad.sph"],
        );
        let tool = sph(dir.path(), "tool.sph", 5.0);
        let objects = [body(&tool, [0.0; 6]), body(&bad_sph, [0.0; 6])];
        expect(
            h6d_engine_from_files(
                &body(&tool, [0.0; 6]),
                objects.as_ptr(),
                2,
                null(),
                start.as_ptr(),
                &mut engine,
            ),
            H6dStatus::Scene,
            &["objects[1]", "bad.sph"],
        );
        let mut scaled = body(&tool, [0.0; 6]);
        scaled.scale = f64::NAN;
        expect(
            h6d_engine_from_files(&scaled, null(), 0, null(), start.as_ptr(), &mut engine),
            H6dStatus::InvalidArgument,
            &["tool.scale = NaN"],
        );
        let bad_pose = [body(&tool, [0.0, f64::INFINITY, 0.0, 0.0, 0.0, 0.0])];
        expect(
            h6d_engine_from_files(
                &body(&tool, [0.0; 6]),
                bad_pose.as_ptr(),
                1,
                null(),
                start.as_ptr(),
                &mut engine,
            ),
            H6dStatus::InvalidArgument,
            &["objects[0].pose"],
        );
        let invalid_utf8 = [0xffu8, 0xfe, 0];
        expect(
            h6d_scene_load(invalid_utf8.as_ptr().cast(), &mut scene),
            H6dStatus::InvalidArgument,
            &["`name` is not UTF-8"],
        );
        assert!(engine.is_null());
    }
}

#[test]
fn settings_out_of_range_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let tool = sph(dir.path(), "tool.sph", 5.0);
    let start = [0.0; 6];
    let mut engine = null_mut();
    // SAFETY: valid pointers.
    unsafe {
        let mut config = std::mem::zeroed();
        expect(h6d_config_default(&mut config), H6dStatus::Ok, &[]);
        assert_eq!(config, H6dConfig::from(&engine::EngineConfig::default()));
        for (edit, part) in [
            (
                (|c: &mut H6dConfig| c.kt = f64::NAN) as fn(&mut H6dConfig),
                "kt = NaN",
            ),
            (|c| c.budget_us = -1.0, "budget_us = -1"),
            (|c| c.max_force_n = 1e9, "max_force_n"),
            (|c| c.solver = 7, "solver = 7"),
            (|c| c.form = 2, "form = 2"),
            (|c| c.rotation = u32::MAX, "rotation = 4294967295"),
            (|c| c.max_pairs = u64::MAX, "max_pairs"),
        ] {
            let mut bad = config;
            edit(&mut bad);
            expect(
                h6d_engine_from_files(
                    &body(&tool, [0.0; 6]),
                    null(),
                    0,
                    &bad,
                    start.as_ptr(),
                    &mut engine,
                ),
                H6dStatus::InvalidArgument,
                &["h6d_engine_from_files: config", part],
            );
            assert!(engine.is_null());
        }
        // A good config is the engine's, read back.
        config.solver = H6dSolver::ActiveSet as u32;
        config.kt = 2.5;
        expect(
            h6d_engine_from_files(
                &body(&tool, [0.0; 6]),
                null(),
                0,
                &config,
                start.as_ptr(),
                &mut engine,
            ),
            H6dStatus::Ok,
            &[],
        );
        let mut back = std::mem::zeroed();
        expect(h6d_engine_config(engine, &mut back), H6dStatus::Ok, &[]);
        assert_eq!(back, config);
        h6d_engine_destroy(engine);
    }
}

#[test]
fn a_nan_pose_is_refused_and_the_wrench_stays_safe() {
    let dir = tempfile::tempdir().unwrap();
    let engine = spheres(dir.path());
    let mut w = [f64::NAN; 6];
    let mut q_g = [f64::NAN; 6];
    let mut info = H6dFrameInfo::default();
    // SAFETY: valid pointers.
    unsafe {
        // Press into the object so the wrench is not zero, then send NaN.
        for i in 0..200 {
            press_frame(engine, i, &mut w, &mut q_g, &mut info);
        }
        assert!(w[2] > 1.0, "pushed up: {w:?}");
        let kept = q_g;
        let nan = [0.0, 0.0, f64::NAN, 0.0, 0.0, 0.0];
        expect(
            h6d_engine_step(
                engine,
                0.2,
                nan.as_ptr(),
                w.as_mut_ptr(),
                q_g.as_mut_ptr(),
                &mut info,
            ),
            H6dStatus::InvalidArgument,
            &["h6d_engine_step", "q_h[2] = NaN", "last safe pose"],
        );
        assert!(w.iter().all(|v| v.is_finite()), "{w:?}");
        assert_eq!(q_g, kept);
        assert_eq!(info.status, H6dFrameStatus::KeptLastSafe as u32);
        let q = [0.0, 0.0, 20.0, 0.0, 0.0, 0.0];
        expect(
            h6d_engine_step(
                engine,
                f64::INFINITY,
                q.as_ptr(),
                w.as_mut_ptr(),
                null_mut(),
                null_mut(),
            ),
            H6dStatus::InvalidArgument,
            &["t = inf"],
        );
        assert!(w.iter().all(|v| v.is_finite()), "{w:?}");
        // The next good frame is fine.
        expect(
            h6d_engine_step(
                engine,
                0.3,
                q.as_ptr(),
                w.as_mut_ptr(),
                null_mut(),
                &mut info,
            ),
            H6dStatus::Ok,
            &[],
        );
        assert!(w.iter().all(|v| v.is_finite()));
        let mut counters = H6dCounters::default();
        expect(
            h6d_engine_counters(engine, &mut counters),
            H6dStatus::Ok,
            &[],
        );
        assert_eq!(counters.frames, 203);
        assert!(counters.kept_last_safe >= 1);
        // A NaN start is refused, the engine unchanged.
        expect(
            h6d_engine_reset(engine, nan.as_ptr(), null_mut()),
            H6dStatus::InvalidArgument,
            &["h6d_engine_reset", "start[2] = NaN"],
        );
        let start = [0.0, 0.0, 40.0, 0.0, 0.0, 0.0];
        expect(
            h6d_engine_reset(engine, start.as_ptr(), q_g.as_mut_ptr()),
            H6dStatus::Ok,
            &[],
        );
        assert_eq!(q_g, start);
        h6d_engine_destroy(engine);
    }
}

#[test]
fn a_small_contacts_buffer_gets_the_count_needed() {
    let dir = tempfile::tempdir().unwrap();
    let engine = spheres(dir.path());
    let mut w = [0.0; 6];
    let mut count = 99usize;
    // SAFETY: valid pointers.
    unsafe {
        expect(
            h6d_engine_contacts(engine, null_mut(), 0, &mut count),
            H6dStatus::Ok,
            &[],
        );
        assert_eq!(count, 0, "free space: no pairs");
        // The tool rests on the object: one leaf pair.
        let q = [0.0, 0.0, 20.0, 0.0, 0.0, 0.0];
        for i in 0..100 {
            h6d_engine_step(
                engine,
                i as f64 * 1e-3,
                q.as_ptr(),
                w.as_mut_ptr(),
                null_mut(),
                null_mut(),
            );
        }
        expect(
            h6d_engine_contacts(engine, null_mut(), 0, &mut count),
            H6dStatus::BufferTooSmall,
            &[
                "h6d_engine_contacts",
                "1 contact pairs do not fit in a buffer of 0",
            ],
        );
        assert_eq!(count, 1);
        let mut buf = [H6dContact::default(); 2];
        expect(
            h6d_engine_contacts(engine, buf.as_mut_ptr(), buf.len(), &mut count),
            H6dStatus::Ok,
            &[],
        );
        assert_eq!(count, 1);
        assert_eq!((buf[0].r_tool_mm, buf[0].r_object_mm), (5.0, 20.0));
        // The gap is at the pass's linearisation pose, within the detection margin.
        assert!(
            buf[0].gap_mm > -0.01 && buf[0].gap_mm < 2.0,
            "touching: {:?}",
            buf[0]
        );
        assert_eq!(
            buf[1],
            H6dContact::default(),
            "nothing written past the count"
        );
        h6d_engine_destroy(engine);
    }
}

#[test]
fn a_start_in_collision_moves_to_the_nearest_free_pose() {
    let dir = tempfile::tempdir().unwrap();
    let engine = spheres(dir.path());
    // The 5 mm tool sphere 1 mm above the 20 mm object sphere's centre: 24 mm deep, within
    // the 40 mm the coupling stretches at the default force limit. The nearest free pose is
    // straight up, where the spheres touch (25 mm apart) with the penetration tolerance
    // (0.002 mm) as the gap the reset aims for.
    let inside = [0.0, 0.0, 1.0, 0.0, 0.0, 0.0];
    let mut q_g = [0.0; 6];
    // SAFETY: valid pointers.
    unsafe {
        let s = h6d_engine_reset(engine, inside.as_ptr(), q_g.as_mut_ptr());
        expect(s, H6dStatus::Ok, &[]);
        let expected = [0.0, 0.0, 25.002, 0.0, 0.0, 0.0];
        for k in 0..6 {
            assert!((q_g[k] - expected[k]).abs() < 1e-9, "{q_g:?}");
        }
        h6d_engine_destroy(engine);
    }
}

/// A unit cube as OBJ text (outward faces).
fn cube_obj() -> String {
    let mut text = String::new();
    for v in 0..8 {
        let (x, y, z) = (v & 1, (v >> 1) & 1, (v >> 2) & 1);
        text += &format!("v {x} {y} {z}\n");
    }
    for f in [
        [1, 3, 4],
        [1, 4, 2],
        [5, 6, 8],
        [5, 8, 7],
        [1, 2, 6],
        [1, 6, 5],
        [3, 7, 8],
        [3, 8, 4],
        [1, 5, 7],
        [1, 7, 3],
        [2, 4, 8],
        [2, 8, 6],
    ] {
        text += &format!("f {} {} {}\n", f[0], f[1], f[2]);
    }
    text
}

/// A scene asking for the mesh geometry gets it through the C door (its settings given or
/// not, since `H6dConfig` has no geometry), and one that does not keeps the leaf spheres;
/// `h6d_engine_geometry` says which.
#[test]
fn a_scene_that_asks_for_the_mesh_geometry_gets_it() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("cube.obj"), cube_obj()).unwrap();
    for (geometry, want) in [("mesh", 1), ("spheres", 0)] {
        let file = dir.path().join(format!("{geometry}.toml"));
        std::fs::write(
            &file,
            format!(
                "[tool]\nmesh = \"cube.obj\"\nscale = 10.0\ndepth = 2\nstart = [0, 0, 40, 0, 0, 0]\n\n\
                 [[object]]\nmesh = \"cube.obj\"\nscale = 10.0\ndepth = 2\n\n\
                 [solver]\ngeometry = \"{geometry}\"\n"
            ),
        )
        .unwrap();
        let mut scene = null_mut();
        let mut config = std::mem::MaybeUninit::<H6dConfig>::uninit();
        // SAFETY: valid pointers; the scene and engines are freed below.
        unsafe {
            expect(
                h6d_scene_load(c(file.to_str().unwrap()).as_ptr(), &mut scene),
                H6dStatus::Ok,
                &[],
            );
            expect(h6d_config_default(config.as_mut_ptr()), H6dStatus::Ok, &[]);
            for settings in [null(), config.as_ptr()] {
                let mut engine = null_mut();
                expect(
                    h6d_scene_engine(scene, settings, &mut engine),
                    H6dStatus::Ok,
                    &[],
                );
                let mut got = -1;
                expect(h6d_engine_geometry(engine, &mut got), H6dStatus::Ok, &[]);
                assert_eq!(
                    got,
                    want,
                    "{geometry}, settings given: {}",
                    !settings.is_null()
                );
                h6d_engine_destroy(engine);
            }
            h6d_scene_destroy(scene);
            expect(
                h6d_engine_geometry(null_mut(), &mut 0),
                H6dStatus::NullArgument,
                &["h6d_engine_geometry"],
            );
        }
    }
}

#[test]
fn a_mesh_body_builds_its_tree() {
    let dir = tempfile::tempdir().unwrap();
    // A 10 mm cube (in cm, scaled by 10) as the object, a sphere tree as the tool.
    let obj = dir.path().join("cube.obj");
    std::fs::write(&obj, cube_obj()).unwrap();
    let obj = c(obj.to_str().unwrap());
    let tool = sph(dir.path(), "tool.sph", 2.0);
    let mut cube = body(&obj, [0.0; 6]);
    cube.scale = 10.0;
    let start = [5.0, 5.0, 30.0, 0.0, 0.0, 0.0];
    let mut engine = null_mut();
    let mut w = [0.0; 6];
    let mut q_g = [0.0; 6];
    // SAFETY: valid pointers.
    unsafe {
        expect(
            h6d_engine_from_files(
                &body(&tool, [0.0; 6]),
                &cube,
                1,
                null(),
                start.as_ptr(),
                &mut engine,
            ),
            H6dStatus::Ok,
            &[],
        );
        // The hand goes 5 mm into the cube's top face (z = 10 mm): the tool stays on it.
        let q = [5.0, 5.0, 7.0, 0.0, 0.0, 0.0];
        for i in 0..300 {
            h6d_engine_step(
                engine,
                i as f64 * 1e-3,
                q.as_ptr(),
                w.as_mut_ptr(),
                q_g.as_mut_ptr(),
                null_mut(),
            );
        }
        assert!(
            q_g[2] > 11.0 && q_g[2] < 13.0,
            "resting on the top face: {q_g:?}"
        );
        assert!(w[2] > 3.0, "pushed up: {w:?}");
        h6d_engine_destroy(engine);
    }
}

#[test]
fn the_message_belongs_to_the_thread() {
    // SAFETY: valid pointers.
    unsafe {
        let mut scene = null_mut();
        h6d_scene_load(c("teapot").as_ptr(), &mut scene);
        std::thread::spawn(|| {
            assert_eq!(message(), "", "a new thread has no error");
            h6d_config_default(null_mut());
            assert!(message().contains("h6d_config_default"));
        })
        .join()
        .unwrap();
        assert!(message().contains("teapot"), "{}", message());
    }
}

#[test]
fn status_names_match_the_header() {
    for code in 0..8 {
        let status = H6dStatus::from_code(code).unwrap();
        // SAFETY: static NUL-terminated strings.
        let name = unsafe { CStr::from_ptr(h6d_status_name(code)) };
        assert_eq!(name, status.name());
        let header = include_str!("../include/haptic6d.h");
        assert!(header.contains(&format!("{} = {code},", name.to_str().unwrap())));
    }
    // SAFETY: as above.
    let unknown = unsafe { CStr::from_ptr(h6d_status_name(42)) };
    assert_eq!(unknown, c"unknown status");
}

#[test]
fn friction_is_set_per_object_and_bad_values_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let engine = spheres(dir.path());
    // SAFETY: valid pointers.
    unsafe {
        expect(
            h6d_engine_set_friction(engine, 0, 0.4, 0.3),
            H6dStatus::Ok,
            &[],
        );
        expect(
            h6d_engine_set_friction(engine, 1, 0.4, 0.3),
            H6dStatus::Engine,
            &["h6d_engine_set_friction", "object 2 does not exist"],
        );
        expect(
            h6d_engine_set_friction(engine, 0, 0.3, 0.4),
            H6dStatus::InvalidArgument,
            &["kinetic = 0.4", "at most the static coefficient 0.3"],
        );
        expect(
            h6d_engine_set_friction(engine, 0, f64::NAN, 0.1),
            H6dStatus::InvalidArgument,
            &["static = NaN"],
        );
        // Pressed onto the sphere's top and pulled sideways: the frame reports what friction
        // did.
        let mut reset_q = [0.0; 6];
        h6d_engine_reset(
            engine,
            [0.0, 0.0, 40.0, 0.0, 0.0, 0.0].as_ptr(),
            reset_q.as_mut_ptr(),
        );
        let (mut wrench, mut info) = ([0.0; 6], H6dFrameInfo::default());
        let mut stuck = 0;
        for k in 0..400 {
            let z = (40.0 - 0.1 * k as f64).max(24.0);
            let x = if k > 200 {
                0.002 * (k - 200) as f64
            } else {
                0.0
            };
            let q = [x, 0.0, z, 0.0, 0.0, 0.0];
            let s = h6d_engine_step(
                engine,
                k as f64 * 1e-3,
                q.as_ptr(),
                wrench.as_mut_ptr(),
                null_mut(),
                &mut info,
            );
            expect(s, H6dStatus::Ok, &[]);
            stuck += usize::from(info.friction == 1);
        }
        assert!(stuck > 50, "{stuck} frames stuck");
        expect(
            h6d_engine_set_friction_enabled(engine, 0),
            H6dStatus::Ok,
            &[],
        );
        h6d_engine_destroy(engine);
    }
}

/// A paced loop's call before each frame (`h6d_engine_warm_caches`, `h6d_engine_idle`): the
/// engine and a limit, µs.
type WaitCall = unsafe extern "C" fn(*mut H6dEngine, f64) -> i32;

/// The press's frames (wrench, graphic pose, penetration mm), with `before`'s call (and its
/// name) made with a 100 µs limit before each frame, or without; with it, a bad limit and a
/// NULL engine must be refused with messages naming the call.
fn press_with(dir: &Path, before: Option<(WaitCall, &str)>) -> Vec<([f64; 6], [f64; 6], f64)> {
    let engine = spheres(dir);
    let (mut w, mut q_g, mut info) = ([0.0; 6], [0.0; 6], H6dFrameInfo::default());
    let mut frames = Vec::new();
    // SAFETY: valid pointers.
    unsafe {
        for i in 0..200 {
            if let Some((call, _)) = before {
                expect(call(engine, 100.0), H6dStatus::Ok, &[]);
            }
            press_frame(engine, i, &mut w, &mut q_g, &mut info);
            frames.push((w, q_g, info.penetration_mm));
        }
        if let Some((call, name)) = before {
            for bad in [f64::NAN, -1.0, 2e6] {
                expect(
                    call(engine, bad),
                    H6dStatus::InvalidArgument,
                    &[name, "max_us"],
                );
            }
            expect(
                call(null_mut(), 10.0),
                H6dStatus::NullArgument,
                &[name, "engine"],
            );
        }
        h6d_engine_destroy(engine);
    }
    frames
}

#[test]
fn warming_the_caches_changes_no_frame_and_a_bad_limit_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let plain = press_with(dir.path(), None);
    assert!(plain.last().unwrap().1[2] > 1.0, "pushed up");
    let warmed = press_with(
        dir.path(),
        Some((h6d_engine_warm_caches, "h6d_engine_warm_caches")),
    );
    assert_eq!(plain, warmed);
}

#[test]
fn the_wait_before_a_frame_keeps_the_answers_exact_and_a_bad_limit_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let plain = press_with(dir.path(), None);
    let waited = press_with(dir.path(), Some((h6d_engine_idle, "h6d_engine_idle")));
    for (i, f) in waited.iter().enumerate() {
        assert!(f.2 <= 0.01, "frame {i}: {} mm", f.2);
    }
    // The same press, the same resting pose (the wait changes which frames detect, not the
    // answer).
    let (a, b) = (plain.last().unwrap().1, waited.last().unwrap().1);
    assert!(a[2] > 1.0, "pushed up");
    for k in 0..6 {
        assert!((a[k] - b[k]).abs() < 1e-3, "{a:?} against {b:?}");
    }
}
