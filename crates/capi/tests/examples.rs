//! The C and C++ examples (`examples/c/servo_loop.c`, `examples/cpp/servo_loop.cpp`), built
//! with the system compilers (`cc`, `c++`, or `$CC`, `$CXX`) against `libhaptic6d.a`, replay
//! the bunny scene's trajectory and send the wrenches `haptic6d run` sends on the same
//! trajectory (its `frames.csv`), to 1e-9, and draw the tool at the same pose. The C one also
//! runs under AddressSanitizer (leaks included).
//!
//! The frame budget is the largest on both sides (`--budget-us 1000000`), so no pass is cut by
//! the clock and a frame's outcome depends on its input only (as in the scene crate's
//! `engine_replay` test).
//!
//! The reference is `haptic6d run`'s loop in process (`scene::rt::run_loop`, `frames_csv`),
//! and the `haptic6d` binary itself when it was built into the same target folder (`cargo
//! test --workspace` builds it).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use scene::cache::TreeCache;
use scene::device::ReplayDevice;
use scene::report::frames_csv;
use scene::rt::{run_loop, LoopParams, Pacing};
use scene::trajectory::Trajectory;
use scene::Motion;

/// Absolute tolerance of a wrench (N, N·mm) or pose (mm, rad) component.
const TOL: f64 = 1e-9;
/// The largest frame budget, µs (`engine::config::BUDGET_US.hi`), as the examples' argument.
const BUDGET: &str = "1000000";

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The tree cache the scene crate's tests share (trees are built once per checkout).
fn cache_dir() -> PathBuf {
    std::env::var_os("HAPTIC6D_CACHE")
        .map(PathBuf::from)
        .unwrap_or_else(|| repo().join("target").join("haptic6d-test-cache"))
}

/// `target/<profile>/`: this test runs from its `deps/` folder.
fn profile_dir() -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    exe.parent().unwrap().parent().unwrap().to_path_buf()
}

/// `libhaptic6d.a`, built by cargo with this test (the lib's crate types include staticlib).
fn static_lib() -> PathBuf {
    let dir = profile_dir();
    [dir.join("deps/libhaptic6d.a"), dir.join("libhaptic6d.a")]
        .into_iter()
        .find(|p| p.is_file())
        .unwrap_or_else(|| {
            panic!(
                "libhaptic6d.a not found in {}; build it with `cargo build -p haptic6d-capi`",
                dir.display()
            )
        })
}

/// Compiles `source` with `compiler` (`$var` when set) and `extra` flags against the static
/// library; returns the executable.
fn compile(var: &str, compiler: &str, source: &str, extra: &[&str], out: &Path) -> PathBuf {
    let cc = std::env::var(var).unwrap_or_else(|_| compiler.to_string());
    let output = Command::new(&cc)
        .args(extra)
        .arg("-Wall")
        .arg("-Wextra")
        .arg("-Werror")
        .arg("-I")
        .arg(repo().join("crates/capi/include"))
        .arg(repo().join(source))
        .arg(static_lib())
        .args(["-lpthread", "-ldl", "-lm", "-o"])
        .arg(out)
        .output()
        .unwrap_or_else(|e| panic!("cannot run the compiler `{cc}` (set ${var}): {e}"));
    assert!(
        output.status.success(),
        "{cc} {source} failed:\n{}",
        String::from_utf8_lossy(&output.stderr)
    );
    out.to_path_buf()
}

fn run(exe: &Path, args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut cmd = Command::new(exe);
    cmd.args(args).env("HAPTIC6D_CACHE", cache_dir());
    for (k, v) in env {
        cmd.env(k, v);
    }
    cmd.output()
        .unwrap_or_else(|e| panic!("cannot run {}: {e}", exe.display()))
}

/// One frame: time, wrench (N, N·mm) and graphic pose (mm, rad).
#[derive(Debug)]
struct Row {
    t: f64,
    values: [f64; 12],
}

/// Rows of a CSV by column names: the examples' output or `frames.csv`.
fn rows(csv: &str, what: &str) -> Vec<Row> {
    const COLS: [&str; 12] = [
        "fx", "fy", "fz", "tx", "ty", "tz", "xg", "yg", "zg", "gg", "bg", "ag",
    ];
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap_or_default().split(',').collect();
    let index = |name: &str| {
        header
            .iter()
            .position(|h| *h == name)
            .unwrap_or_else(|| panic!("{what}: no column `{name}` in {header:?}"))
    };
    let t = index("t");
    let idx: Vec<usize> = COLS.iter().map(|c| index(c)).collect();
    lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            let num = |i: usize| -> f64 {
                f[i].parse()
                    .unwrap_or_else(|_| panic!("{what}: `{}` is not a number in `{l}`", f[i]))
            };
            let mut values = [0.0; 12];
            for (v, &i) in values.iter_mut().zip(&idx) {
                *v = num(i);
            }
            Row { t: num(t), values }
        })
        .collect()
}

fn assert_same(got: &[Row], want: &[Row], what: &str) {
    assert_eq!(got.len(), want.len(), "{what}: frame count");
    for (i, (g, w)) in got.iter().zip(want).enumerate() {
        assert_eq!(g.t, w.t, "{what}: frame {i} time");
        for (k, (a, b)) in g.values.iter().zip(&w.values).enumerate() {
            assert!(
                (a - b).abs() <= TOL && a.is_finite(),
                "{what}: frame {i} (t = {}) column {k}: {a} against {b}",
                g.t
            );
        }
    }
}

/// The bunny scene's trajectory written as `haptic6d run` writes `trajectory.csv`, and the
/// frames `haptic6d run --trajectory` makes of it.
struct Reference {
    dir: tempfile::TempDir,
    trajectory: PathBuf,
    frames: Vec<Row>,
}

fn reference() -> Reference {
    let cache = TreeCache::at(cache_dir());
    let mut scene = scene::scenes::builtin("bunny", &cache).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let trajectory = dir.path().join("trajectory.csv");
    scene.trajectory().write_csv(&trajectory).unwrap();
    // What `haptic6d run bunny --trajectory FILE --budget-us 1000000` does.
    let traj = Trajectory::read_csv(&trajectory).unwrap();
    scene.motion = Motion::Trajectory(traj.clone());
    scene.solver.budget_us = engine::config::BUDGET_US.hi;
    assert_eq!(BUDGET.parse::<f64>().unwrap(), engine::config::BUDGET_US.hi);
    let mut engine = scene.engine().unwrap();
    engine
        .reset(&engine::Pose::from_array(traj.samples[0].q))
        .unwrap();
    let params = LoopParams {
        pacing: Pacing {
            rate_hz: scene.rate_hz,
            ..Pacing::default()
        },
        ..LoopParams::default()
    };
    let report = run_loop(&mut engine, &mut ReplayDevice::new(traj), &params).unwrap();
    let frames = rows(&frames_csv(&report.frames), "haptic6d run (in process)");
    assert!(frames.len() > 1000, "too few frames: {}", frames.len());
    assert!(
        frames
            .iter()
            .any(|r| r.values[..3].iter().any(|f| f.abs() > 1.0)),
        "the trajectory never pushes: nothing to compare"
    );
    Reference {
        dir,
        trajectory,
        frames,
    }
}

/// The `haptic6d` binary of this target folder's profile, when built and newer than every
/// source file of the crates it is made of (a binary left from before a change to them would
/// be compared with today's library; `cargo test --workspace` rebuilds it first).
fn haptic6d_binary() -> Option<PathBuf> {
    let p = profile_dir().join(format!("haptic6d{}", std::env::consts::EXE_SUFFIX));
    let built = std::fs::metadata(&p).and_then(|m| m.modified()).ok()?;
    let crates = repo().join("crates");
    let newest = [
        "cli",
        "scene",
        "engine",
        "collide",
        "qp",
        "spheretree",
        "mesh",
    ]
    .iter()
    .filter_map(|c| newest_source(&crates.join(c).join("src")))
    .max()?;
    if newest > built {
        eprintln!(
            "note: {} is older than its sources; compared with haptic6d run in process only",
            p.display()
        );
        return None;
    }
    Some(p)
}

/// The latest modification time of the files under `dir`.
fn newest_source(dir: &Path) -> Option<std::time::SystemTime> {
    std::fs::read_dir(dir)
        .ok()?
        .filter_map(Result::ok)
        .filter_map(|e| {
            let path = e.path();
            if path.is_dir() {
                newest_source(&path)
            } else {
                e.metadata().and_then(|m| m.modified()).ok()
            }
        })
        .max()
}

fn check_example(exe: &Path, what: &str, env: &[(&str, &str)]) {
    let r = reference();
    let traj = r.trajectory.to_str().unwrap();
    let out = run(exe, &["bunny", traj, BUDGET], env);
    assert!(
        out.status.success(),
        "{what} failed ({}):\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    let got = rows(&String::from_utf8(out.stdout).unwrap(), what);
    assert_same(&got, &r.frames, &format!("{what} against haptic6d run"));
    if let Some(bin) = haptic6d_binary() {
        let run_dir = r.dir.path().join("run");
        let cli = run(
            &bin,
            &[
                "run",
                "bunny",
                "--trajectory",
                traj,
                "--budget-us",
                BUDGET,
                "--no-plots",
                "--no-rt-priority",
                "--out",
                run_dir.to_str().unwrap(),
            ],
            &[],
        );
        assert!(
            cli.status.success(),
            "{} run failed:\n{}",
            bin.display(),
            String::from_utf8_lossy(&cli.stderr)
        );
        let frames = std::fs::read_to_string(run_dir.join("frames.csv")).unwrap();
        assert_same(
            &got,
            &rows(&frames, "frames.csv"),
            &format!("{what} against {} run", bin.display()),
        );
    }
}

#[test]
fn c_example_sends_the_wrenches_of_haptic6d_run() {
    let dir = tempfile::tempdir().unwrap();
    let exe = compile(
        "CC",
        "cc",
        "examples/c/servo_loop.c",
        &["-std=c11", "-O2"],
        &dir.path().join("servo_loop"),
    );
    check_example(&exe, "servo_loop.c", &[]);
}

#[test]
fn cpp_example_sends_the_wrenches_of_haptic6d_run() {
    let dir = tempfile::tempdir().unwrap();
    let exe = compile(
        "CXX",
        "c++",
        "examples/cpp/servo_loop.cpp",
        &["-std=c++17", "-O2"],
        &dir.path().join("servo_loop_cpp"),
    );
    check_example(&exe, "servo_loop.cpp", &[]);
}

#[test]
fn c_example_is_clean_under_address_sanitizer() {
    let dir = tempfile::tempdir().unwrap();
    let exe = compile(
        "CC",
        "cc",
        "examples/c/servo_loop.c",
        &[
            "-std=c11",
            "-O1",
            "-g",
            "-fsanitize=address",
            "-fno-omit-frame-pointer",
        ],
        &dir.path().join("servo_loop_asan"),
    );
    // Any error report (out-of-bounds access, use after free, leak) fails the run.
    check_example(
        &exe,
        "servo_loop.c under ASan",
        &[("ASAN_OPTIONS", "detect_leaks=1:exitcode=99")],
    );
}

#[test]
fn examples_say_what_is_wrong_with_their_input() {
    let dir = tempfile::tempdir().unwrap();
    let c = compile(
        "CC",
        "cc",
        "examples/c/servo_loop.c",
        &["-std=c11", "-O0"],
        &dir.path().join("servo_loop"),
    );
    let cpp = compile(
        "CXX",
        "c++",
        "examples/cpp/servo_loop.cpp",
        &["-std=c++17", "-O0"],
        &dir.path().join("servo_loop_cpp"),
    );
    let good = dir.path().join("trajectory.csv");
    std::fs::write(&good, "t,x,y,z,gamma,beta,alpha\n0,0,0,140,0,0,0\n").unwrap();
    let bad_scene = dir.path().join("bad.toml");
    std::fs::write(&bad_scene, "[tool]\nmesh = \"nowhere.obj\"\n").unwrap();
    let good = good.to_str().unwrap();
    let cases: [(&[&str], &str); 3] = [
        (
            &["nosuch", good],
            "no built-in scene or scene file named `nosuch`",
        ),
        (&[bad_scene.to_str().unwrap(), good], "bad.toml"),
        (&["bunny", good, "-5"], "budget_us = -5"),
    ];
    for exe in [&c, &cpp] {
        for (args, expected) in &cases {
            let out = run(exe, args, &[]);
            let err = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(1), "{args:?}: {err}");
            assert!(
                err.contains(expected),
                "{args:?}: `{expected}` not in: {err}"
            );
            assert_eq!(err.trim().lines().count(), 1, "{args:?}: one line: {err}");
        }
    }
}
