//! `haptic6d tree build|eval` end to end: exit status, one-line errors, written trees, JSON.

use std::path::Path;
use std::process::{Command, Output};

mod common;
use common::Dir;

use serde_json::Value;
use spheretree::sph::read_sph;

fn haptic6d(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_haptic6d"))
        .args(args)
        .output()
        .expect("the haptic6d binary runs")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Asserts a failure with exactly one line on stderr, `error: ...`, and returns that line.
#[track_caller]
fn one_line_failure(o: &Output) -> String {
    assert!(
        !o.status.success(),
        "expected failure, stdout: {}",
        stdout(o)
    );
    let err = stderr(o);
    let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "expected one line on stderr, got: {err}");
    assert!(lines[0].starts_with("error: "), "{err}");
    lines[0].to_string()
}

fn bunny() -> &'static str {
    static PATH: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    PATH.get_or_init(|| {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../assets/bunny.obj")
            .display()
            .to_string()
    })
}

/// A unit cube as OBJ quads (counter-clockwise from outside); `skip` leaves one face out.
fn cube_obj(skip: Option<usize>) -> String {
    let mut s = String::new();
    for i in 0..8 {
        s += &format!("v {} {} {}\n", i & 1, (i >> 1) & 1, (i >> 2) & 1);
    }
    let quads = [
        [1, 3, 4, 2],
        [5, 6, 8, 7],
        [1, 2, 6, 5],
        [3, 7, 8, 4],
        [1, 5, 7, 3],
        [2, 4, 8, 6],
    ];
    for (k, q) in quads.iter().enumerate() {
        if Some(k) != skip {
            s += &format!("f {} {} {} {}\n", q[0], q[1], q[2], q[3]);
        }
    }
    s
}

#[test]
fn bad_mesh_path_fails_with_one_line() {
    let d = Dir::new("badpath");
    let out = d.path("out.sph");
    let o = haptic6d(&["tree", "build", "/nonexistent/mesh.obj", "-o", &out]);
    let line = one_line_failure(&o);
    assert!(line.contains("/nonexistent/mesh.obj"), "{line}");
    assert!(!Path::new(&out).exists());
    let o = haptic6d(&["tree", "eval", "/nonexistent/tree.sph", "--mesh", bunny()]);
    assert!(one_line_failure(&o).contains("/nonexistent/tree.sph"));
}

#[test]
fn malformed_and_open_meshes_fail_with_one_line() {
    let d = Dir::new("malformed");
    let nan = d.path("nan.obj");
    std::fs::write(&nan, cube_obj(None).replacen("v 1 0 0", "v 1 nan 0", 1)).unwrap();
    let line = one_line_failure(&haptic6d(&["tree", "build", &nan, "-o", &d.path("a.sph")]));
    assert!(
        line.contains("nan.obj") && line.contains("non-finite"),
        "{line}"
    );

    // An open mesh builds with the tight builder, which says it used the winding number and
    // why; the fit measure takes it too.
    let open = d.path("open.obj");
    std::fs::write(&open, cube_obj(Some(2))).unwrap();
    let tree = d.path("b.sph");
    let o = haptic6d(&["tree", "build", &open, "--depth", "2", "-o", &tree]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        out.contains("inside test: winding-number") && out.contains("hole"),
        "{out}"
    );
    let o = haptic6d(&["tree", "eval", &tree, "--mesh", &open, "--json"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["inside_test"], "winding-number");
    assert!(
        v["per_level"][2]["coverage"].as_f64().unwrap() > 0.99,
        "{v}"
    );

    // An existing output survives a failed build.
    let keep = d.path("keep.sph");
    std::fs::write(&keep, "old").unwrap();
    one_line_failure(&haptic6d(&["tree", "build", &nan, "-o", &keep]));
    assert_eq!(std::fs::read_to_string(&keep).unwrap(), "old");
    // An output in a missing directory fails cleanly, naming it.
    let missing = d.path("no/such/dir/t.sph");
    let line = one_line_failure(&haptic6d(&[
        "tree",
        "build",
        bunny(),
        "--method",
        "octree",
        "--depth",
        "1",
        "-o",
        &missing,
    ]));
    assert!(line.contains("no/such/dir"), "{line}");
}

#[test]
fn usage_errors_are_one_line() {
    let o = haptic6d(&["tree", "build", bunny()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(one_line_failure(&o).contains("--output"));
    let o = haptic6d(&[
        "tree",
        "build",
        bunny(),
        "-o",
        "x.sph",
        "--method",
        "medial",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(one_line_failure(&o).contains("medial"));
    let o = haptic6d(&["tree", "build", bunny(), "-o", "x.sph", "--branch", "1"]);
    assert!(one_line_failure(&o).contains("--branch"));
    let o = haptic6d(&["tree", "build", bunny(), "-o", "x.sph", "--depth", "40"]);
    assert!(one_line_failure(&o).contains("--depth"));
    // Help works and succeeds.
    let o = haptic6d(&["tree", "build", "--help"]);
    assert!(o.status.success());
    assert!(stdout(&o).contains("--bradshaw-frame"));
}

#[test]
fn build_writes_valid_trees_and_json() {
    let d = Dir::new("build");
    for (method, depth) in [("octree", "3"), ("tight", "2")] {
        let out = d.path(&format!("{method}.sph"));
        let o = haptic6d(&[
            "tree",
            "build",
            bunny(),
            "--method",
            method,
            "--depth",
            depth,
            "-o",
            &out,
            "--json",
        ]);
        assert!(o.status.success(), "{method}: {}", stderr(&o));
        let summary: Value = serde_json::from_str(stdout(&o).trim()).expect("valid JSON");
        let tree = read_sph(Path::new(&out)).unwrap();
        assert_eq!(tree.levels(), depth.parse::<u32>().unwrap() + 1);
        assert_eq!(tree.branching(), 8);
        tree.validate(1e-9)
            .unwrap_or_else(|e| panic!("{method}: {e}"));
        assert_eq!(summary["method"], method);
        assert_eq!(summary["triangles"], 3674);
        assert_eq!(summary["slots"], tree.len());
        let used: Vec<usize> = (0..tree.levels()).map(|l| tree.used_on_level(l)).collect();
        assert_eq!(summary["used_per_level"], serde_json::json!(used));
        assert!(summary["build_seconds"].as_f64().unwrap() >= 0.0);
    }
    // Human-readable output names the file.
    let out = d.path("plain.sph");
    let o = haptic6d(&[
        "tree",
        "build",
        bunny(),
        "--method",
        "octree",
        "--depth",
        "2",
        "-o",
        &out,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("plain.sph"));
}

#[test]
fn bradshaw_frame_and_centre_undo_each_other() {
    let d = Dir::new("frame");
    let own = d.path("own.sph");
    let centred = d.path("centred.sph");
    for (path, extra) in [(&own, None), (&centred, Some("--bradshaw-frame"))] {
        let mut args = vec![
            "tree",
            "build",
            bunny(),
            "--method",
            "octree",
            "--depth",
            "2",
            "-o",
            path,
        ];
        args.extend(extra);
        let o = haptic6d(&args);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let a = read_sph(Path::new(&own)).unwrap();
    let b = read_sph(Path::new(&centred)).unwrap();
    // The bunny's bounding-box centre.
    let c = [-0.0048125, 4.8257995, 0.040403];
    for (sa, sb) in a.spheres().iter().zip(b.spheres()) {
        assert_eq!(sa.radius, sb.radius);
        if sa.is_used() {
            for ((&x, &y), &shift) in sa.center.iter().zip(&sb.center).zip(&c) {
                assert!((x - y - shift).abs() < 1e-9);
            }
        }
    }
    let eval = |tree: &str, centre: bool| -> Value {
        let mut args = vec![
            "tree",
            "eval",
            tree,
            "--mesh",
            bunny(),
            "--json",
            "--samples",
            "3000",
        ];
        if centre {
            args.push("--centre");
        }
        let o = haptic6d(&args);
        assert!(o.status.success(), "{}", stderr(&o));
        serde_json::from_str(stdout(&o).trim()).expect("valid JSON")
    };
    let ea = eval(&own, false);
    let eb = eval(&centred, true);
    for (la, lb) in ea["per_level"]
        .as_array()
        .unwrap()
        .iter()
        .zip(eb["per_level"].as_array().unwrap())
    {
        for key in ["count", "coverage", "uncovered"] {
            assert_eq!(la[key], lb[key], "{key}");
        }
        for key in ["worst", "mean", "worst162", "largest_gap"] {
            let (x, y) = (la[key].as_f64().unwrap(), lb[key].as_f64().unwrap());
            assert!((x - y).abs() <= 1e-6 * (1.0 + x.abs()), "{key}: {x} vs {y}");
        }
    }
}

#[test]
fn eval_json_parses_and_matches_the_tree() {
    let d = Dir::new("eval");
    let out = d.path("t.sph");
    let o = haptic6d(&[
        "tree",
        "build",
        bunny(),
        "--method",
        "octree",
        "--depth",
        "3",
        "-o",
        &out,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = haptic6d(&[
        "tree",
        "eval",
        &out,
        "--mesh",
        bunny(),
        "--json",
        "--samples",
        "5000",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: Value = serde_json::from_str(stdout(&o).trim()).expect("valid JSON");
    let tree = read_sph(Path::new(&out)).unwrap();
    let levels = v["per_level"].as_array().unwrap();
    assert_eq!(levels.len(), tree.levels() as usize);
    assert_eq!(v["parents_contain_children"], true);
    for (l, f) in levels.iter().enumerate() {
        assert_eq!(f["level"], l);
        assert_eq!(f["count"], tree.used_on_level(l as u32));
        let cov = f["coverage"].as_f64().unwrap();
        assert!((0.0..=1.0).contains(&cov));
        assert!(f["worst"].as_f64().unwrap() >= f["mean"].as_f64().unwrap());
        assert!(f["worst162"].as_f64().unwrap() >= 0.0);
    }
    // The text table has a header and one row per level.
    let o = haptic6d(&["tree", "eval", &out, "--mesh", bunny(), "--samples", "2000"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    assert!(
        text.contains("coverage %") && text.contains("largest gap"),
        "{text}"
    );
    let rows = text
        .lines()
        .filter(|l| {
            l.split_whitespace()
                .next()
                .is_some_and(|w| w.parse::<u32>().is_ok())
        })
        .count();
    assert_eq!(rows, tree.levels() as usize, "{text}");
}

/// The toolkit's medial tree of the bunny, in the repository (`assets/peers/bradshaw/`).
fn bradshaw_medial() -> String {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../assets/peers/bradshaw/bunny-medial-d3.sph");
    assert!(
        p.is_file(),
        "{} is missing from the repository",
        p.display()
    );
    p.display().to_string()
}

#[test]
fn toolkit_tree_needs_centre() {
    let tree = bradshaw_medial();
    let run = |centre: bool| {
        let mut args = vec![
            "tree",
            "eval",
            &tree,
            "--mesh",
            bunny(),
            "--json",
            "--samples",
            "20000",
        ];
        if centre {
            args.push("--centre");
        }
        let o = haptic6d(&args);
        assert!(o.status.success(), "{}", stderr(&o));
        let v: Value = serde_json::from_str(stdout(&o).trim()).unwrap();
        (v, stderr(&o))
    };
    let (v, err) = run(true);
    let levels = v["per_level"].as_array().unwrap();
    assert_eq!(levels[0]["coverage"], 1.0);
    // docs/DESIGN.md §The fit measure: the toolkit's medial tree covers 98.44 % of the surface
    // at its leaf level.
    let leaf = levels[3]["coverage"].as_f64().unwrap();
    assert!((leaf - 0.9844).abs() < 0.005, "leaf coverage {leaf}");
    assert_eq!(v["parents_contain_children"], false);
    assert!(!err.contains("--centre"), "{err}");
    // Without --centre the tree sits off the mesh, and the command says so.
    let (v, err) = run(false);
    assert!(v["per_level"][0]["coverage"].as_f64().unwrap() < 0.9);
    assert!(err.contains("--centre"), "{err}");
}
