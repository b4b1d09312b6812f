//! Safety through the command line: settings out of range (scene keys and flags alike) are
//! one-line errors naming the key; `tree build -o` never replaces a device, a directory, a fifo
//! or its own input, and checks the output before the build; `run` replaces a previous run as
//! a whole or not at all; the octree builder handles open meshes; `tree eval` refuses what it
//! cannot measure; a device node is never read as a mesh.

use std::path::Path;
use std::process::Command;

mod common;
use common::{
    haptic6d, haptic6d_env, one_line_failure, snapshot, success, Dir, CUBE_OBJ, SMALL_SPH,
};

fn scene_toml(extra: &str) -> String {
    format!(
        "[tool]\ntree = \"tool.sph\"\nstart = [0, 0, 10, 0, 0, 0]\n\n[[object]]\ntree = \"object.sph\"\n{extra}"
    )
}

/// A folder with the two trees, a press trajectory and a good scene; returns it and the scene.
fn run_fixture(tag: &str) -> (Dir, String, String) {
    let d = Dir::new(tag);
    d.write("tool.sph", SMALL_SPH);
    d.write("object.sph", SMALL_SPH);
    let mut traj = String::from("t,x,y,z,gamma,beta,alpha\n");
    for i in 0..200 {
        let z = 10.0 - 0.05 * f64::from(i);
        traj += &format!("{},0,0,{z},0,0,0\n", f64::from(i) * 1e-3);
    }
    let traj = d.write("press.csv", traj);
    let scene = d.write("good.toml", scene_toml(""));
    (d, scene, traj)
}

#[test]
fn out_of_range_settings_are_refused_from_the_scene_file_and_the_flags() {
    let (d, scene, traj) = run_fixture("settings");
    let out = d.path("out");
    success(&haptic6d(&[
        "run",
        &scene,
        "--trajectory",
        &traj,
        "--out",
        &out,
        "--no-plots",
    ]));
    let before = snapshot(Path::new(&out));
    // The settings failures of `crates/scene/tests/safety.rs`, through the scene file.
    let keys = [
        (
            "[safety]\nmax_force_n = nan\n",
            "[safety] max_force_n = NaN: must be a finite number in (0, 100] N",
        ),
        (
            "[safety]\nmax_force_n = -10.0\n",
            "[safety] max_force_n = -10",
        ),
        (
            "[safety]\nmax_torque_nmm = inf\n",
            "[safety] max_torque_nmm = inf",
        ),
        (
            "[safety]\nmax_force_step_n = 0.0\n",
            "[safety] max_force_step_n = 0",
        ),
        ("[solver]\nskin_mm = -1000.0\n", "[solver] skin_mm = -1000"),
        (
            "[solver]\nrelinearize = 4294967295\n",
            "[solver] relinearize = 4294967295: must be an integer in 0..=16",
        ),
        ("[solver]\nbudget_us = 0.0\n", "[solver] budget_us = 0"),
        ("[device]\nrate_hz = 1e-30\n", "[device] rate_hz = 1e-30"),
        ("[device]\nrate_hz = 1e12\n", "[device] rate_hz = 1e12"),
        ("[coupling]\nkt = 1e300\n", "[coupling] kt = 1e300"),
        (
            "friction = { static = 0.2, kinetic = 0.5 }\n",
            "[[object]] #1 friction.kinetic = 0.5: must be at most the static coefficient 0.2",
        ),
    ];
    for (i, (extra, needle)) in keys.iter().enumerate() {
        let name = format!("bad{i}.toml");
        let s = d.write(&name, scene_toml(extra));
        let line = one_line_failure(&haptic6d(&["run", &s, "--out", &out, "--no-plots"]));
        assert!(
            line.contains(&name) && line.contains(needle),
            "`{needle}` not in: {line}"
        );
        assert_eq!(snapshot(Path::new(&out)), before, "{line}");
    }
    // The same ranges for the flags, named as flags.
    let flags: [(&[&str], &str); 10] = [
        (
            &["--friction", "0.3,0.4"],
            "--friction.kinetic = 0.4: must be at most the static coefficient 0.3",
        ),
        (&["--friction=-1"], "--friction.static = -1: must be"),
        (&["--friction", "abc"], "`abc` is not a number"),
        (&["--friction", "0.1,0.1,0.1"], "at most two numbers"),
        (
            &["--relinearize", "4294967295"],
            "--relinearize = 4294967295: must be an integer in 0..=16",
        ),
        (
            &["--rate", "1e-30"],
            "--rate = 1e-30: must be a finite number in [100, 20000] Hz",
        ),
        (&["--rate", "1e7"], "--rate = 10000000"),
        (&["--rate", "NaN"], "--rate = NaN"),
        (&["--skin=-1000"], "--skin = -1000"),
        (&["--max-margin", "inf"], "--max-margin = inf"),
    ];
    for (args, needle) in flags {
        let mut a = vec!["run", &scene, "--out", &out, "--no-plots"];
        a.extend_from_slice(args);
        let line = one_line_failure(&haptic6d(&a));
        assert!(line.contains(needle), "`{needle}` not in: {line}");
        assert_eq!(snapshot(Path::new(&out)), before, "{line}");
    }
    // In range: friction from the file and from the flag run.
    let rough = d.write(
        "rough.toml",
        scene_toml("friction = { static = 0.5, kinetic = 0.4 }\n"),
    );
    success(&haptic6d(&[
        "run",
        &rough,
        "--trajectory",
        &traj,
        "--out",
        &out,
        "--no-plots",
        "--force",
    ]));
    success(&haptic6d(&[
        "run",
        &scene,
        "--trajectory",
        &traj,
        "--out",
        &out,
        "--no-plots",
        "--force",
        "--friction",
        "0.4,0.3",
    ]));
    // In range: --relinearize 16 and --skin 0 run.
    success(&haptic6d(&[
        "run",
        &scene,
        "--trajectory",
        &traj,
        "--out",
        &out,
        "--no-plots",
        "--relinearize",
        "16",
        "--skin",
        "0",
    ]));
}

#[test]
fn a_run_failing_midway_leaves_the_previous_run_intact() {
    let (d, scene, traj) = run_fixture("atomic");
    let out = d.path("out");
    success(&haptic6d(&[
        "run",
        &scene,
        "--trajectory",
        &traj,
        "--out",
        &out,
    ]));
    let before = snapshot(Path::new(&out));
    assert_eq!(
        before.len(),
        6,
        "{:?}",
        before.iter().map(|f| &f.0).collect::<Vec<_>>()
    );
    // A different run (another trajectory) failing after each output in turn.
    let short = d.write(
        "short.csv",
        "t,x,y,z,gamma,beta,alpha\n0,0,0,10,0,0,0\n0.001,0,0,9,0,0,0\n",
    );
    let names_before = d.names();
    for stage in ["frames.csv", "trajectory.csv", "summary.json", "plots"] {
        let o = haptic6d_env(
            &["run", &scene, "--trajectory", &short, "--out", &out],
            &[("HAPTIC6D_TEST_FAIL_RUN_OUTPUT", stage)],
            None,
        );
        let line = one_line_failure(&o);
        assert!(line.contains("simulated failure"), "{line}");
        assert_eq!(
            snapshot(Path::new(&out)),
            before,
            "after {stage}: a mix of runs"
        );
        assert_eq!(
            d.names(),
            names_before,
            "after {stage}: staging left behind"
        );
    }
    // The same run without the hook replaces the whole folder: no old plot is left beside
    // the new files.
    success(&haptic6d(&[
        "run",
        &scene,
        "--trajectory",
        &short,
        "--out",
        &out,
        "--no-plots",
    ]));
    let after = snapshot(Path::new(&out));
    let names: Vec<&str> = after.iter().map(|f| f.0.as_str()).collect();
    assert_eq!(names, ["frames.csv", "summary.json", "trajectory.csv"]);
    assert_eq!(d.names(), names_before);
    // With --force, the user's own files in the folder are kept.
    d.write("out/notes.txt", "mine");
    success(&haptic6d(&[
        "run",
        &scene,
        "--trajectory",
        &traj,
        "--out",
        &out,
        "--no-plots",
        "--force",
    ]));
    assert_eq!(
        std::fs::read_to_string(d.0.join("out/notes.txt")).unwrap(),
        "mine"
    );
    // --out naming a file is refused before anything runs.
    let f = d.write("file.txt", "x");
    let line = one_line_failure(&haptic6d(&["run", &scene, "--out", &f]));
    assert!(line.contains("not a directory"), "{line}");
}

#[test]
fn tree_build_output_must_be_a_regular_file_other_than_the_input() {
    let d = Dir::new("output");
    let mesh = d.write("same.obj", CUBE_OBJ);
    let build = |o: &str| {
        haptic6d(&[
            "tree", "build", &mesh, "--depth", "2", "--method", "octree", "-o", o,
        ])
    };
    // The input itself, by the same name, another spelling, and a hard link.
    let dotted = format!("{}/./same.obj", d.0.display());
    std::fs::hard_link(&mesh, d.0.join("link.obj")).unwrap();
    for o in [mesh.clone(), dotted, d.path("link.obj")] {
        let line = one_line_failure(&build(&o));
        assert!(line.contains("is the input mesh"), "{line}");
    }
    assert_eq!(std::fs::read_to_string(&mesh).unwrap(), CUBE_OBJ);
    // A directory, a device node, a fifo.
    std::fs::create_dir(d.0.join("dir.sph")).unwrap();
    let line = one_line_failure(&build(&d.path("dir.sph")));
    assert!(line.contains("not a regular file"), "{line}");
    #[cfg(unix)]
    {
        let line = one_line_failure(&build("/dev/null"));
        assert!(
            line.contains("/dev/null") && line.contains("not a regular file"),
            "{line}"
        );
        let fifo = d.path("fifo.sph");
        let made = Command::new("mkfifo").arg(&fifo).status();
        if made.is_ok_and(|s| s.success()) {
            let line = one_line_failure(&build(&fifo));
            assert!(line.contains("not a regular file"), "{line}");
        }
    }
    // A missing directory is found before the build, not after it.
    let line = one_line_failure(&build(&d.path("nowhere/t.sph")));
    assert!(line.contains("does not exist"), "{line}");
    // No probe or temporary file is left behind; a good output is written.
    success(&build(&d.path("good.sph")));
    let names = d.names();
    assert!(names.contains(&"good.sph".to_string()), "{names:?}");
    assert!(!names.iter().any(|n| n.starts_with('.')), "{names:?}");
}

#[test]
fn both_builders_take_open_meshes_and_a_single_triangle() {
    let d = Dir::new("octree");
    let open = CUBE_OBJ.replace("f 2 4 8 6\n", "");
    for (name, text) in [
        ("open.obj", open.as_str()),
        ("tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"),
    ] {
        let mesh = d.write(name, text);
        for (method, depth) in [
            ("octree", "1"),
            ("octree", "2"),
            ("octree", "3"),
            ("tight", "2"),
        ] {
            let out = d.path(&format!("{name}.{method}.{depth}.sph"));
            let o = haptic6d(&[
                "tree", "build", &mesh, "--depth", depth, "--method", method, "-o", &out,
            ]);
            success(&o);
            let t = spheretree::sph::read_sph(Path::new(&out)).unwrap();
            assert!(
                t.leaves().any(|n| t.sphere(n).is_used()),
                "{name} {method} depth {depth}"
            );
        }
    }
}

#[test]
fn tree_eval_refuses_empty_trees_and_unbounded_samples() {
    let d = Dir::new("eval");
    let mesh = d.write("cube.obj", CUBE_OBJ);
    let tree = d.write("t.sph", SMALL_SPH);
    let line = one_line_failure(&haptic6d(&[
        "tree",
        "eval",
        &tree,
        "--mesh",
        &mesh,
        "--samples",
        "1000000000",
    ]));
    assert!(line.contains("--samples 1000000000"), "{line}");
    // A tree whose every sphere is unused used to print `inf` and exit 0.
    let empty = d.write("empty.sph", "2 2\n0 0 0 -1 1\n0 0 0 -1 1\n0 0 0 -1 1\n");
    let o = haptic6d(&["tree", "eval", &empty, "--mesh", &mesh]);
    let line = one_line_failure(&o);
    assert!(
        line.contains("empty.sph") && line.contains("no used sphere"),
        "{line}"
    );
    assert!(!String::from_utf8_lossy(&o.stdout).contains("inf"));
}

#[cfg(unix)]
#[test]
fn a_device_node_is_never_read_as_a_mesh() {
    let d = Dir::new("devzero");
    let link = d.0.join("zero.obj");
    std::os::unix::fs::symlink("/dev/zero", &link).unwrap();
    let out = d.path("t.sph");
    let line = one_line_failure(&haptic6d(&[
        "tree",
        "build",
        &link.display().to_string(),
        "--method",
        "octree",
        "-o",
        &out,
    ]));
    assert!(
        line.contains("zero.obj") && line.contains("not a regular file"),
        "{line}"
    );
}
