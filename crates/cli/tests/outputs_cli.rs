//! What the command line does with the places it writes and with inputs at the edges: an
//! output that exists and is not a regular file (a symbolic link, a folder, a device) is
//! refused and left as it was; a run never deletes a folder where one of its files goes; an
//! interrupted or crashed run leaves no staging folder behind; a recording larger than the
//! memory is refused before it starts; usage errors exit 2; every error is one short line.

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

mod common;
use common::{haptic6d, haptic6d_env, one_line_failure, success, Dir, CUBE_OBJ, SMALL_SPH};

/// A folder with two small trees, a press trajectory and a scene using them.
fn run_fixture(tag: &str) -> (Dir, String, String) {
    let d = Dir::new(tag);
    d.write("tool.sph", SMALL_SPH);
    d.write("object.sph", SMALL_SPH);
    let mut traj = String::from("t,x,y,z,gamma,beta,alpha\n");
    for i in 0..100 {
        traj += &format!(
            "{},0,0,{},0,0,0\n",
            f64::from(i) * 1e-3,
            10.0 - 0.05 * f64::from(i)
        );
    }
    let traj = d.write("press.csv", traj);
    let scene = d.write(
        "scene.toml",
        "[tool]\ntree = \"tool.sph\"\nstart = [0, 0, 10, 0, 0, 0]\n\n[[object]]\ntree = \"object.sph\"\n",
    );
    (d, scene, traj)
}

fn staging_folders(d: &Dir) -> Vec<String> {
    d.names()
        .into_iter()
        .filter(|n| n.starts_with(".out.new-"))
        .collect()
}

#[cfg(unix)]
#[test]
fn a_symbolic_link_output_is_refused_and_left_as_it_was() {
    let d = Dir::new("link");
    let mesh = d.write("cube.obj", CUBE_OBJ);
    let target = d.write("target.txt", "the user's file\n");
    let link = d.path("tree.sph");
    std::os::unix::fs::symlink(&target, &link).unwrap();
    let o = haptic6d(&["tree", "build", &mesh, "--depth", "2", "-o", &link]);
    let line = one_line_failure(&o);
    assert!(line.contains("symbolic link"), "{line}");
    assert!(std::fs::symlink_metadata(&link)
        .unwrap()
        .file_type()
        .is_symlink());
    assert_eq!(
        std::fs::read_to_string(&target).unwrap(),
        "the user's file\n"
    );
    // A link to nothing, and a link as a run's folder, alike.
    let dangling = d.path("dangling.sph");
    std::os::unix::fs::symlink(d.path("nothing"), &dangling).unwrap();
    let line = one_line_failure(&haptic6d(&[
        "tree", "build", &mesh, "--depth", "2", "-o", &dangling,
    ]));
    assert!(line.contains("symbolic link"), "{line}");
    let (r, scene, traj) = run_fixture("link-run");
    std::fs::create_dir(r.path("real")).unwrap();
    std::os::unix::fs::symlink(r.path("real"), r.path("out")).unwrap();
    let line = one_line_failure(&haptic6d(&[
        "run",
        &scene,
        "--trajectory",
        &traj,
        "--out",
        &r.path("out"),
        "--no-plots",
    ]));
    assert!(line.contains("symbolic link"), "{line}");
    assert!(std::fs::symlink_metadata(r.path("out"))
        .unwrap()
        .file_type()
        .is_symlink());
    assert!(staging_folders(&r).is_empty());
}

#[test]
fn a_folder_where_a_run_file_goes_is_refused_and_kept() {
    let (d, scene, traj) = run_fixture("folder");
    let out = d.path("out");
    let run = |extra: &[&str]| {
        let mut args = vec![
            "run",
            &scene,
            "--trajectory",
            &traj,
            "--out",
            &out,
            "--no-plots",
        ];
        args.extend_from_slice(extra);
        haptic6d(&args)
    };
    success(&run(&[]));
    std::fs::create_dir(d.path("out/pairs.png")).unwrap();
    d.write("out/pairs.png/notes.txt", "x\n");
    for extra in [&[][..], &["--force"][..]] {
        let line = one_line_failure(&run(extra));
        assert!(
            line.contains("pairs.png") && line.contains("a folder"),
            "{line}"
        );
        assert_eq!(
            std::fs::read_to_string(d.path("out/pairs.png/notes.txt")).unwrap(),
            "x\n"
        );
        assert!(Path::new(&d.path("out/frames.csv")).is_file());
    }
    assert!(staging_folders(&d).is_empty());
}

#[cfg(unix)]
#[test]
fn an_interrupted_run_removes_its_staging_folder() {
    let (d, scene, _) = run_fixture("interrupt");
    let out = d.path("out");
    // A live device (nobody sends poses) runs on the clock until interrupted.
    let child = Command::new(env!("CARGO_BIN_EXE_haptic6d"))
        .args([
            "run",
            &scene,
            "--device",
            "udp",
            "--udp-listen",
            "127.0.0.1:0",
            "--duration",
            "60",
            "--no-rt-priority",
            "--out",
            &out,
        ])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while staging_folders(&d).is_empty() {
        assert!(
            start.elapsed() < Duration::from_secs(30),
            "no staging folder"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    // Time for the run to be under way (the interrupt handler is installed with the folder).
    std::thread::sleep(Duration::from_millis(500));
    let kill = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let o = child.wait_with_output().unwrap();
    assert_eq!(
        o.status.code(),
        Some(130),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(staging_folders(&d).is_empty(), "{:?}", d.names());
    assert!(!Path::new(&out).exists());
}

#[test]
fn a_stale_staging_folder_is_removed_only_when_it_is_a_dead_runs() {
    let (d, scene, traj) = run_fixture("stale");
    // No process has a pid this large (Linux's limit is 2^22).
    let dead = d.path(".out.new-4194399-1");
    std::fs::create_dir(&dead).unwrap();
    d.write(".out.new-4194399-1/frames.csv", "t\n");
    d.write(".out.new-4194399-1/.summary.json.tmp-1-2-0", "{");
    // The same name holding a file no run writes is kept.
    d.write(".out.new-4194399-2/notes.txt", "mine\n");
    // A name that is not a staging folder's is kept.
    d.write(".out.new-mine/frames.csv", "t\n");
    success(&haptic6d(&[
        "run",
        &scene,
        "--trajectory",
        &traj,
        "--out",
        &d.path("out"),
        "--no-plots",
    ]));
    let names = d.names();
    assert!(
        !names.contains(&".out.new-4194399-1".to_string()),
        "{names:?}"
    );
    assert!(
        names.contains(&".out.new-4194399-2".to_string()),
        "{names:?}"
    );
    assert!(names.contains(&".out.new-mine".to_string()), "{names:?}");
}

#[test]
fn a_recording_larger_than_memory_is_a_usage_error_before_the_run() {
    let (d, scene, _) = run_fixture("memory");
    let out = d.path("out");
    let o = haptic6d(&[
        "run",
        &scene,
        "--device",
        "udp",
        "--udp-listen",
        "127.0.0.1:0",
        "--duration",
        "86400",
        "--rate",
        "20000",
        "--out",
        &out,
    ]);
    let line = one_line_failure(&o);
    assert_eq!(o.status.code(), Some(2), "{line}");
    assert!(
        line.contains("--duration") && line.contains("memory"),
        "{line}"
    );
    assert!(staging_folders(&d).is_empty());
    assert!(!Path::new(&out).exists());
}

#[test]
fn an_empty_cache_variable_counts_as_unset() {
    let d = Dir::new("cache-env");
    let home = d.path("home");
    std::fs::create_dir(&home).unwrap();
    let work = d.0.join("work");
    std::fs::create_dir(&work).unwrap();
    d.write("work/cube.obj", CUBE_OBJ);
    let scene = "[tool]\nmesh = \"cube.obj\"\ndepth = 2\nstart = [0, 0, 10, 0, 0, 0]\n\n[[object]]\nmesh = \"cube.obj\"\ndepth = 2\n";
    d.write("work/scene.toml", scene);
    let mut traj = String::from("t,x,y,z,gamma,beta,alpha\n");
    for i in 0..10 {
        traj += &format!("{},0,0,10,0,0,0\n", f64::from(i) * 1e-3);
    }
    d.write("work/t.csv", traj);
    let o = haptic6d_env(
        &[
            "run",
            "scene.toml",
            "--trajectory",
            "t.csv",
            "--out",
            "out",
            "--no-plots",
        ],
        &[
            ("HAPTIC6D_CACHE", ""),
            ("XDG_CACHE_HOME", ""),
            ("HOME", &home),
        ],
        Some(&work),
    );
    success(&o);
    let mut names: Vec<String> = std::fs::read_dir(&work)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["cube.obj", "out", "scene.toml", "t.csv"]);
    assert!(Path::new(&home).join(".cache/haptic6d").is_dir());
}

#[test]
fn a_sph_file_with_a_byte_order_mark_is_read() {
    let d = Dir::new("bom");
    let tree = d.write("tree.sph", format!("\u{feff}{SMALL_SPH}"));
    let mesh = d.write("cube.obj", CUBE_OBJ);
    success(&haptic6d(&[
        "tree",
        "eval",
        &tree,
        "--mesh",
        &mesh,
        "--samples",
        "1000",
    ]));
}

#[test]
fn flag_range_errors_exit_2_with_one_form_of_range() {
    let (d, scene, traj) = run_fixture("usage");
    let out = d.path("out");
    let o = haptic6d(&[
        "run",
        &scene,
        "--trajectory",
        &traj,
        "--out",
        &out,
        "--rate",
        "5",
    ]);
    let line = one_line_failure(&o);
    assert_eq!(o.status.code(), Some(2), "{line}");
    let o = haptic6d(&["run", &scene, "--out", &out, "--duration=-1"]);
    assert_eq!(o.status.code(), Some(2), "{}", one_line_failure(&o));
    // A scene file's key out of range is an input error (exit 1), not a usage error.
    let bad = d.write(
        "bad.toml",
        "[tool]\ntree = \"tool.sph\"\nstart = [0, 0, 10, 0, 0, 0]\n\n[[object]]\ntree = \"object.sph\"\n[safety]\nmax_force_n = -1.0\n",
    );
    let o = haptic6d(&["run", &bad, "--out", &out]);
    assert_eq!(o.status.code(), Some(1), "{}", one_line_failure(&o));
    for p in ["0", "-5", "100"] {
        let flag = format!("--rt-priority={p}");
        let o = haptic6d(&["serve", &flag, "--port", "0"]);
        let line = one_line_failure(&o);
        assert!(line.ends_with("must be an integer in 1..=99"), "{line}");
        assert_eq!(o.status.code(), Some(2), "{line}");
    }
}

#[test]
fn error_lines_are_short_and_clean() {
    let d = Dir::new("messages");
    // An origin without a host says so.
    let line = one_line_failure(&haptic6d(&["serve", "--allow-origin", "http://"]));
    assert!(line.contains("has no host"), "{line}");
    // The PLY parser's internals stay out of the message.
    let ply = d.write(
        "bad.ply",
        "ply\nformat ascii 1.0\ncomment x\nbogus line\nend_header\n",
    );
    let line = one_line_failure(&haptic6d(&["tree", "build", &ply, "-o", &d.path("t.sph")]));
    assert!(line.contains("line 4: cannot parse `bogus line`"), "{line}");
    assert!(
        !line.contains("ParseError") && !line.contains("Custom {"),
        "{line}"
    );
    let ply = d.write(
        "payload.ply",
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 x\n0 1 0\n3 0 1 2\n",
    );
    let line = one_line_failure(&haptic6d(&["tree", "build", &ply, "-o", &d.path("t.sph")]));
    assert!(line.contains("cannot parse `1 0 x`"), "{line}");
    assert!(!line.contains("kind:"), "{line}");
    // A nesting bomb: one readable line, not the whole input quoted.
    let bomb = d.write("bomb.toml", format!("a = {}\n", "[".repeat(200_000)));
    let line = one_line_failure(&haptic6d(&["run", &bomb, "--out", &d.path("o")]));
    assert!(
        line.contains("bomb.toml") && line.len() < 1200,
        "{} bytes",
        line.len()
    );
    // A port in use: the OS error once.
    let taken = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = taken.local_addr().unwrap().port().to_string();
    let line = one_line_failure(&haptic6d(&["serve", "--port", &port]));
    assert_eq!(line.matches("os error").count(), 1, "{line}");
}

/// `bench --peer` and `--peer-tune` take engine names (rapier, mujoco); another name is a usage
/// error (exit 2) that names the flag, the name and the engines, before anything runs.
#[test]
fn bench_refuses_an_unknown_peer_engine() {
    let dir = Dir::new("peer-engine");
    let out = dir.path("out");
    for flag in ["--peer=bullet", "--peer-tune=bullet"] {
        let o = haptic6d(&["bench", flag, "--out", &out]);
        let line = one_line_failure(&o);
        assert_eq!(o.status.code(), Some(2), "{line}");
        assert!(
            line.contains("no peer engine `bullet` (engines: rapier, mujoco)"),
            "{line}"
        );
        assert!(line.contains(flag.split('=').next().unwrap()), "{line}");
    }
}
