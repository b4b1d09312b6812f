//! The command line on bad input: every failure is one `error: ...` line naming the offending
//! file (and line, where the format has lines), and nothing already written is lost: a failing
//! `haptic6d tree build` or `haptic6d run` leaves existing outputs byte-for-byte as they were,
//! with no temporary files left behind.

use std::path::Path;

mod common;
use common::{haptic6d, one_line_failure, snapshot, Dir, CUBE_OBJ, SMALL_SPH};

#[test]
fn failing_tree_build_keeps_the_existing_output() {
    let d = Dir::new("build");
    let out = d.write("out/tree.sph", "OLD TREE: must survive\n");
    let bad_meshes = [
        ("nan.obj", CUBE_OBJ.replace("v 1 1 1", "v 1 nan 1"), "line 8"),
        ("short.obj", CUBE_OBJ.replace("f 2 4 8 6\n", "f 2 4\n"), "line 14"),
        ("trunc.stl", "solid x\nfacet normal 0 0 0\nouter loop\nvertex 0 0".into(), ""),
        (
            "count.ply",
            "ply\nformat ascii 1.0\nelement vertex 18446744073709551616\nproperty float x\nend_header\n"
                .into(),
            "line 3",
        ),
        ("empty.obj", String::new(), "empty"),
    ];
    for (name, text, needle) in bad_meshes {
        let mesh = d.write(&format!("in/{name}"), text);
        let before = snapshot(&d.0.join("out"));
        let o = haptic6d(&["tree", "build", &mesh, "--depth", "2", "-o", &out]);
        let line = one_line_failure(&o);
        assert!(
            line.contains(name),
            "{name}: error does not name the file: {line}"
        );
        assert!(line.contains(needle), "{name}: `{needle}` not in: {line}");
        assert_eq!(
            snapshot(&d.0.join("out")),
            before,
            "{name}: the output directory changed"
        );
    }
    // A good build replaces it (and leaves no temporary file).
    let mesh = d.write("in/cube.obj", CUBE_OBJ);
    let o = haptic6d(&[
        "tree", "build", &mesh, "--depth", "2", "--method", "octree", "-o", &out,
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let files = snapshot(&d.0.join("out"));
    assert_eq!(
        files.len(),
        1,
        "{:?}",
        files.iter().map(|f| &f.0).collect::<Vec<_>>()
    );
    assert!(spheretree::sph::read_sph(Path::new(&out)).is_ok());
}

/// A scene file using `tree = "..."` bodies (no build, so it loads instantly).
fn scene_toml(tool: &str, object: &str, extra: &str) -> String {
    format!(
        "[tool]\ntree = \"{tool}\"\nstart = [0, 0, 10, 0, 0, 0]\n\n[[object]]\ntree = \"{object}\"\npose = [0, 0, 0, 0, 0, 0]\n{extra}"
    )
}

#[test]
fn failing_run_keeps_the_existing_outputs() {
    let d = Dir::new("run");
    d.write("tool.sph", SMALL_SPH);
    d.write("object.sph", SMALL_SPH);
    d.write("bad.sph", SMALL_SPH.replace("-1 0 0 1 1", "-1 nan 0 1 1"));
    d.write("short.sph", "3 2\n0 0 0 2 1\n");
    let good_scene = d.write("good.toml", scene_toml("tool.sph", "object.sph", ""));
    let traj = d.write(
        "traj.csv",
        "t,x,y,z,gamma,beta,alpha\n0,0,0,10,0,0,0\n0.001,0,0,9.9,0,0,0\n",
    );
    let out = d.path("out");
    std::fs::create_dir_all(&out).unwrap();
    for f in ["frames.csv", "summary.json", "trajectory.csv"] {
        d.write(&format!("out/{f}"), format!("OLD {f}: must survive\n"));
    }
    let before = snapshot(Path::new(&out));

    let cases: Vec<(Vec<String>, &str, &str)> = vec![
        // Trajectory: wrong header, NaN row, missing field, backwards time, empty.
        (
            vec![d.write("t1.csv", "t,x,y\n0,0,0\n")],
            "t1.csv:1",
            "header",
        ),
        (
            vec![d.write(
                "t2.csv",
                "t,x,y,z,gamma,beta,alpha\n0,0,0,10,0,0,0\n0.001,0,nan,10,0,0,0\n",
            )],
            "t2.csv:3",
            "finite",
        ),
        (
            vec![d.write("t3.csv", "t,x,y,z,gamma,beta,alpha\n0,0,0,10,0,0\n")],
            "t3.csv:2",
            "6 fields",
        ),
        (
            vec![d.write(
                "t4.csv",
                "t,x,y,z,gamma,beta,alpha\n1,0,0,10,0,0,0\n0,0,0,10,0,0,0\n",
            )],
            "t4.csv:3",
            "backwards",
        ),
        (vec![d.write("t5.csv", "")], "t5.csv", "empty"),
        (
            vec![d.write("t6.csv", "t,x,y,z,gamma,beta,alpha\n0,0,0,1e999,0,0,0\n")],
            "t6.csv:2",
            "finite",
        ),
    ];
    for (files, needle_file, needle) in cases {
        let o = haptic6d(&[
            "run",
            &good_scene,
            "--trajectory",
            &files[0],
            "--out",
            &out,
            "--no-plots",
        ]);
        let line = one_line_failure(&o);
        assert!(line.contains(needle_file), "`{needle_file}` not in: {line}");
        assert!(line.contains(needle), "`{needle}` not in: {line}");
        assert_eq!(snapshot(Path::new(&out)), before, "outputs changed: {line}");
    }

    // Scene files: syntax error, wrong type, NaN stiffness, bad tree files, missing file.
    let scenes = [
        ("s1.toml", "[tool\n".to_string(), "s1.toml"),
        (
            "s2.toml",
            scene_toml("tool.sph", "object.sph", "[coupling]\nkt = \"stiff\"\n"),
            "kt",
        ),
        (
            "s3.toml",
            scene_toml("tool.sph", "object.sph", "[coupling]\nkt = nan\n"),
            "kt",
        ),
        (
            "s4.toml",
            scene_toml("tool.sph", "bad.sph", ""),
            "bad.sph:3",
        ),
        (
            "s5.toml",
            scene_toml("short.sph", "object.sph", ""),
            "short.sph:2",
        ),
        (
            "s6.toml",
            scene_toml("tool.sph", "missing.sph", ""),
            "missing.sph",
        ),
        (
            "s7.toml",
            scene_toml("tool.sph", "object.sph", "[device]\nrate_hz = -1.0\n"),
            "rate_hz",
        ),
        (
            "s8.toml",
            scene_toml(
                "tool.sph",
                "object.sph",
                "[device]\ntrajectory = \"t2.csv\"\n",
            ),
            "t2.csv:3",
        ),
    ];
    for (name, text, needle) in scenes {
        let scene = d.write(name, text);
        let o = haptic6d(&["run", &scene, "--out", &out, "--no-plots"]);
        let line = one_line_failure(&o);
        assert!(
            line.contains(name),
            "{name}: error does not name the scene: {line}"
        );
        assert!(line.contains(needle), "{name}: `{needle}` not in: {line}");
        assert_eq!(snapshot(Path::new(&out)), before, "{name}: outputs changed");
    }

    // The good run replaces the outputs (so the checks above could have seen a change).
    let o = haptic6d(&[
        "run",
        &good_scene,
        "--trajectory",
        &traj,
        "--out",
        &out,
        "--no-plots",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let after = snapshot(Path::new(&out));
    assert_eq!(
        after.len(),
        3,
        "{:?}",
        after.iter().map(|f| &f.0).collect::<Vec<_>>()
    );
    assert!(after.iter().all(|(_, bytes)| !bytes.starts_with(b"OLD")));
}
