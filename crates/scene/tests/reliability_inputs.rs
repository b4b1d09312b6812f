//! Malformed scene TOML and trajectory CSV: truncated, wrong counts, NaN/inf, huge values,
//! wrong types, empty, binary garbage. Every one gives a one-line error naming the file (and
//! the line, for the CSV and for TOML syntax errors) and never panics; a scene whose numbers
//! would overflow downstream (huge scale on huge trees) is refused or stays finite.

mod common;

use std::path::PathBuf;

use scene::cache::TreeCache;
use scene::trajectory::{Trajectory, TRAJECTORY_HEADER};
use scene::{load_scene_file, SceneSpec};

#[track_caller]
fn csv_err(text: &str, line: usize, needle: &str) {
    let e = match Trajectory::parse_csv(text, "dev.csv") {
        Ok(t) => panic!("accepted {text:?}: {} rows", t.len()),
        Err(e) => e.to_string(),
    };
    assert!(!e.contains('\n'), "{e:?}");
    assert!(
        e.starts_with(&format!("dev.csv:{line}: ")),
        "line {line}: {e}"
    );
    assert!(e.to_lowercase().contains(needle), "`{needle}` not in {e}");
}

#[test]
fn trajectory_csv_malformed() {
    let h = TRAJECTORY_HEADER;
    csv_err("", 1, "empty");
    csv_err("\n\n", 1, "empty");
    csv_err("t,x,y,z\n", 1, "header");
    csv_err("time,x,y,z,gamma,beta,alpha\n0,0,0,0,0,0,0\n", 1, "header");
    csv_err(&format!("{h}\n"), 1, "no data");
    // Wrong counts.
    csv_err(&format!("{h}\n0,0,0,0,0,0\n"), 2, "6 fields");
    csv_err(&format!("{h}\n0,0,0,0,0,0,0,0\n"), 2, "more than 7");
    csv_err(&format!("{h}\n0,0,0,0,0,0,0\n0.001,1,2"), 3, "3 fields");
    // Wrong types.
    csv_err(&format!("{h}\n0,0,0,x,0,0,0\n"), 2, "not a number");
    csv_err(&format!("{h}\n0,0,0,,0,0,0\n"), 2, "not a number");
    csv_err(&format!("{h}\n0;0;0;0;0;0;0\n"), 2, "not a number");
    // Non-finite and overflowing values.
    for bad in ["nan", "NaN", "inf", "-inf", "1e400", "-1e999"] {
        csv_err(
            &format!("{h}\n0,0,0,0,0,0,0\n0.001,0,{bad},0,0,0,0\n"),
            3,
            "finite",
        );
    }
    // Time going backwards.
    csv_err(
        &format!("{h}\n1,0,0,0,0,0,0\n0.5,0,0,0,0,0,0\n"),
        3,
        "backwards",
    );
    // Binary garbage.
    let garbage: String = (0..512u32)
        .map(|i| char::from((i.wrapping_mul(2_654_435_761) >> 24) as u8))
        .collect();
    let e = Trajectory::parse_csv(&garbage, "dev.csv")
        .unwrap_err()
        .to_string();
    assert!(!e.contains('\n') && e.starts_with("dev.csv:"), "{e}");
}

#[test]
fn trajectory_csv_tolerates_what_it_should() {
    let h = TRAJECTORY_HEADER;
    // CRLF line ends, spaces, comments, blank lines, upper-case header, huge finite values.
    let text = format!(
        "{}\r\n0, 0,0,0,0,0,0\r\n\r\n# pause\n0.001,1e300,0,0,0,0,0\n",
        h.to_uppercase()
    );
    let t = Trajectory::parse_csv(&text, "ok.csv").unwrap();
    assert_eq!(t.len(), 2);
    assert_eq!(t.samples[1].q[0], 1e300);
}

struct Dir(PathBuf);

impl Dir {
    fn new(tag: &str) -> Self {
        let d = std::env::temp_dir().join(format!(
            "haptic6d-reliability-render-{tag}-{}",
            std::process::id()
        ));
        std::fs::create_dir_all(&d).unwrap();
        Dir(d)
    }
    fn write(&self, name: &str, text: impl AsRef<[u8]>) -> PathBuf {
        let p = self.0.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }
}

impl Drop for Dir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

const SPH: &str = "2 2\n0 0 0 2 1\n-1 0 0 1 1\n1 0 0 1 1\n";

fn scene(extra: &str) -> String {
    format!(
        "[tool]\ntree = \"tool.sph\"\nstart = [0, 0, 10, 0, 0, 0]\n\n[[object]]\ntree = \"object.sph\"\npose = [0, 0, 0, 0, 0, 0]\n{extra}"
    )
}

#[track_caller]
fn scene_err(text: &str, needle: &str) -> String {
    let e = match SceneSpec::parse(text, "s.toml") {
        Ok(s) => panic!("accepted {text:?}: {s:?}"),
        Err(e) => common::chain(&e),
    };
    assert!(!e.contains('\n'), "{e:?}");
    assert!(e.starts_with("s.toml: "), "{e}");
    assert!(e.contains(needle), "`{needle}` not in {e}");
    e
}

#[test]
fn scene_toml_malformed() {
    assert!(SceneSpec::parse(&scene(""), "s.toml").is_ok());
    // Empty, truncated, syntax errors (TOML reports the line).
    scene_err("", "tool");
    scene_err("[tool]\ntree = \"a.sph\"\n[[object]]\ntree = \"b", "line 4");
    scene_err("[tool\n", "line 1");
    scene_err(&scene("[coupling]\nkt = \n"), "line 9");
    // Wrong types.
    scene_err(&scene("[coupling]\nkt = \"stiff\"\n"), "kt");
    scene_err(&scene("[coupling]\nkt = [1.0]\n"), "kt");
    scene_err(
        &scene("").replace("start = [0, 0, 10, 0, 0, 0]", "start = [0, 0, 10]"),
        "start",
    );
    scene_err(
        &scene("").replace("start = [0, 0, 10, 0, 0, 0]", "start = \"up\""),
        "start",
    );
    scene_err(&scene("[solver]\nkind = 3\n"), "kind");
    scene_err(&scene("[tool]\nmesh = \"x.obj\"\n"), "tool");
    // Non-finite and out-of-range numbers (TOML has nan and inf literals).
    scene_err(&scene("[coupling]\nkt = nan\n"), "kt");
    scene_err(&scene("[coupling]\nkr = inf\n"), "[coupling] kr = inf");
    scene_err(&scene("[coupling]\nkt = -1.0\n"), "kt");
    scene_err(&scene("[device]\nrate_hz = nan\n"), "rate_hz");
    scene_err(&scene("[device]\nrate_hz = 0\n"), "rate_hz");
    scene_err(
        &scene("").replace(
            "start = [0, 0, 10, 0, 0, 0]",
            "start = [0, 0, nan, 0, 0, 0]",
        ),
        "finite",
    );
    scene_err(
        &scene("").replace("pose = [0, 0, 0, 0, 0, 0]", "pose = [inf, 0, 0, 0, 0, 0]"),
        "finite",
    );
    scene_err(
        &scene("").replace("[tool]\n", "[tool]\nscale = nan\n"),
        "scale",
    );
    scene_err(
        &scene("").replace("[tool]\n", "[tool]\ndepth = 99999999999\n"),
        "depth",
    );
    scene_err(
        &scene("").replace("[tool]\n", "[tool]\ndepth = -1\n"),
        "depth",
    );
    // Unknown keys and sections.
    scene_err(&scene("[coupling]\nkx = 1.0\n"), "kx");
    scene_err(&scene("[telemetry]\non = true\n"), "telemetry");
    // Binary garbage.
    let garbage: String = (0..512u32)
        .map(|i| char::from((i.wrapping_mul(2_654_435_761) >> 24) as u8))
        .collect();
    scene_err(&garbage, "");
}

#[test]
fn scene_file_errors_name_the_scene_and_the_bad_file_and_line() {
    let d = Dir::new("scene");
    d.write("tool.sph", SPH);
    d.write("object.sph", SPH);
    d.write("nan.sph", SPH.replace("-1 0 0 1 1", "-1 nan 0 1 1"));
    d.write("cut.sph", "3 2\n0 0 0 2 1\n");
    d.write(
        "bad.csv",
        format!("{TRAJECTORY_HEADER}\n0,0,0,10,0,0,0\n0.001,0,0,x,0,0,0\n"),
    );
    d.write("mesh.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 5\n");
    let cache = TreeCache::disabled();
    let cases = [
        (
            "a.toml",
            scene("").replace("object.sph", "nan.sph"),
            "nan.sph:3",
        ),
        (
            "b.toml",
            scene("").replace("tool.sph", "cut.sph"),
            "cut.sph:2",
        ),
        (
            "c.toml",
            scene("").replace("object.sph", "missing.sph"),
            "missing.sph",
        ),
        (
            "d.toml",
            scene("[device]\ntrajectory = \"bad.csv\"\n"),
            "bad.csv:3",
        ),
        (
            "e.toml",
            scene("").replace("tree = \"object.sph\"", "mesh = \"mesh.obj\""),
            "line 4",
        ),
    ];
    for (name, text, needle) in cases {
        let p = d.write(name, text);
        let e = common::chain(&load_scene_file(&p, &cache).unwrap_err());
        assert!(!e.contains('\n'), "{e:?}");
        assert!(e.contains(name), "{name}: scene not named: {e}");
        assert!(e.contains(needle), "{name}: `{needle}` not in {e}");
    }
    // A missing scene file and a directory given as the scene.
    let e = common::chain(&load_scene_file(&d.0.join("none.toml"), &cache).unwrap_err());
    assert!(!e.contains('\n') && e.contains("none.toml"), "{e}");
    let e = common::chain(&load_scene_file(&d.0, &cache).unwrap_err());
    assert!(!e.contains('\n'), "{e}");
}

#[test]
fn scene_scale_overflow_is_an_error_naming_the_scene() {
    // The tree's numbers are finite (1e300) and the scale is finite (1e10), but together they
    // overflow: the scene must refuse to load, not hand infinite spheres to the haptic loop.
    let d = Dir::new("huge");
    d.write("tool.sph", SPH);
    d.write("huge.sph", "1 2\n1e300 0 0 1e300 1\n");
    let p = d.write(
        "h.toml",
        scene("").replace("tree = \"object.sph\"", "tree = \"huge.sph\"\nscale = 1e10"),
    );
    let mesh_case = d.write(
        "m.toml",
        scene("").replace(
            "tree = \"object.sph\"",
            "mesh = \"huge.obj\"\nscale = 1e200\ndepth = 2\nmethod = \"octree\"",
        ),
    );
    d.write(
        "huge.obj",
        "v 0 0 0\nv 1e150 0 0\nv 0 1e150 0\nv 0 0 1e150\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n",
    );
    for p in [p, mesh_case] {
        match load_scene_file(&p, &TreeCache::disabled()) {
            Err(e) => {
                let e = e.to_string();
                assert!(!e.contains('\n') && e.contains(".toml"), "{e}");
            }
            Ok(scene) => {
                for (tree, _) in &scene.objects {
                    for s in tree.spheres().iter().filter(|s| s.is_used()) {
                        assert!(
                            s.radius.is_finite() && s.center.iter().all(|c| c.is_finite()),
                            "non-finite sphere after scaling: {s:?}"
                        );
                    }
                }
            }
        }
    }
}
