//! `haptic6d run` end to end: outputs and their formats, replay of the recorded input into
//! another solver on identical input, a user scene file with relative paths, and refusal to
//! write over foreign files.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

mod common;
use common::box_obj;

fn haptic6d(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_haptic6d"))
        .args(args)
        .env("HAPTIC6D_CACHE", cache_dir())
        .output()
        .expect("the haptic6d binary runs")
}

/// Trees shared by the tests of this checkout, so the bunny is built once.
fn cache_dir() -> PathBuf {
    std::env::var_os("HAPTIC6D_CACHE")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target/haptic6d-test-cache")
        })
}

fn temp_dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("haptic6d-run-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The numeric columns of `frames.csv` (all but `status`; an empty field, a frame whose mesh
/// penetration was not measured, reads NaN).
fn csv_rows(path: &Path) -> (String, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap().to_string();
    let status_at = header.split(',').position(|c| c == "status").unwrap();
    let rows = lines
        .map(|l| {
            let fields: Vec<&str> = l.split(',').collect();
            let status = fields[status_at];
            assert!(
                [
                    "ok",
                    "inexact",
                    "pair-overflow",
                    "lagging",
                    "kept-last-safe"
                ]
                .contains(&status),
                "status {status}"
            );
            fields
                .iter()
                .enumerate()
                .filter(|&(k, _)| k != status_at)
                .map(|(_, v)| {
                    if v.is_empty() {
                        f64::NAN
                    } else {
                        v.parse::<f64>().unwrap()
                    }
                })
                .collect()
        })
        .collect();
    (header, rows)
}

#[test]
fn bunny_run_writes_frames_summary_plots_and_replays_identically() {
    let d = temp_dir("bunny");
    let out = d.join("dual");
    // A frame budget no busy test machine reaches: the two solvers are compared on their
    // answers, and a frame cut short by the budget (CI runs test binaries side by side) ends
    // wherever its last pass stopped.
    let o = haptic6d(&[
        "run",
        "bunny",
        "--out",
        out.to_str().unwrap(),
        "--json",
        "--budget-us",
        "1000000",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let summary: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let on_disk: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary, on_disk);
    let (header, rows) = csv_rows(&out.join("frames.csv"));
    assert_eq!(
        header,
        "t,xh,yh,zh,gh,bh,ah,xg,yg,zg,gg,bg,ag,fx,fy,fz,tx,ty,tz,pairs,cd_us,opt_us,total_us,iters,penetration_mm,passes,status,splits,scanned,ahead_us,mesh_penetration_mm"
    );
    assert_eq!(rows.len() as u64, summary["frames"].as_u64().unwrap());
    assert!(rows
        .iter()
        .all(|r| r.len() == 30 && r[..29].iter().all(|v| v.is_finite())));
    // The lists ahead are part of a frame's time (`ahead_us` within `total_us`), and some
    // frames build them (the leaf spheres' neighbour lists, tens of microseconds a slice).
    let (total_at, ahead_at) = (22, 28);
    assert!(rows
        .iter()
        .all(|r| (0.0..=r[total_at]).contains(&r[ahead_at])));
    assert!(rows.iter().any(|r| r[ahead_at] > 10.0));
    let own_p99 = summary["own_us"]["p99"].as_f64().unwrap();
    assert!(own_p99 > 0.0 && own_p99 <= summary["total_us"]["max"].as_f64().unwrap());
    // The bunny scene keeps its meshes: every frame near the other bunny is measured at the
    // mesh level.
    let measured = rows.iter().filter(|r| r[29].is_finite()).count() as u64;
    let mesh = &summary["mesh_penetration_mm"];
    assert_eq!(mesh["frames"].as_u64(), Some(measured));
    assert_eq!(mesh["contact_frames"].as_u64(), Some(measured));
    assert!(measured > 1000, "{measured} frames measured");
    assert!(mesh["max"].as_f64().unwrap() <= 0.01, "{mesh}");
    for key in [
        "cd_us",
        "opt_us",
        "total_us",
        "ahead_us",
        "own_us",
        "pairs",
        "iterations",
        "penetration_mm",
    ] {
        for stat in ["p50", "p99", "max"] {
            assert!(summary[key][stat].is_number(), "{key}.{stat}");
        }
    }
    assert!(summary["penetration_mm"]["max"].as_f64().unwrap() <= 0.01);
    assert!(summary["pairs"]["max"].as_f64().unwrap() > 100.0);
    assert!(summary["loop_stats"]["safety"]["nan_frames"].as_u64() == Some(0));
    for png in ["pairs.png", "timing.png", "force.png"] {
        let bytes = std::fs::read(out.join(png)).unwrap();
        assert!(
            bytes.starts_with(b"\x89PNG\r\n\x1a\n") && bytes.len() > 10_000,
            "{png}"
        );
    }

    // Replay the recorded device input into another solver: identical q_h, every frame.
    let traj = out.join("trajectory.csv");
    let out2 = d.join("active-set");
    let o = haptic6d(&[
        "run",
        "bunny",
        "--trajectory",
        traj.to_str().unwrap(),
        "--solver",
        "active-set",
        "--out",
        out2.to_str().unwrap(),
        "--no-plots",
        "--budget-us",
        "1000000",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (_, rows2) = csv_rows(&out2.join("frames.csv"));
    assert_eq!(rows.len(), rows2.len());
    let mut max_dq: f64 = 0.0;
    for (a, b) in rows.iter().zip(&rows2) {
        assert_eq!(a[0..7], b[0..7], "device input differs at t = {}", a[0]);
        for k in 7..13 {
            max_dq = max_dq.max((a[k] - b[k]).abs());
        }
    }
    // Two exact solvers on identical input agree on the graphic tool: a pass's answer is
    // accepted within 0.005 mm of its linearization's optimum (docs/DESIGN.md §The frame
    // step), so where the two take different passes (a tool dragged along the bunny, held
    // ~1 mm behind the hand) their tools part by up to about that, and meet again.
    assert!(max_dq < 0.01, "dual and active-set differ by {max_dq}");
    let last = |r: &[f64]| r[7..13].to_vec();
    assert_eq!(last(&rows[rows.len() - 1]), last(&rows2[rows2.len() - 1]));
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn a_scene_file_with_relative_paths_runs_and_stops_the_tool_on_the_box() {
    let d = temp_dir("scene");
    std::fs::create_dir_all(d.join("meshes")).unwrap();
    std::fs::write(d.join("meshes/box.obj"), box_obj(10.0)).unwrap();
    // Tool box (20 mm) above an object box (20 mm); the hand goes 5 mm into the object.
    let mut traj = String::from("t,x,y,z,gamma,beta,alpha\n");
    for i in 0..=400 {
        let t = i as f64 * 1e-3;
        let z = 25.0 - 10.0 * (i as f64 / 400.0);
        traj += &format!("{t},0,0,{z},0,0,0\n");
    }
    std::fs::write(d.join("down.csv"), traj).unwrap();
    std::fs::write(
        d.join("scene.toml"),
        "[tool]\nmesh = \"meshes/box.obj\"\ndepth = 2\nstart = [0, 0, 25, 0, 0, 0]\n\n\
         [[object]]\nmesh = \"meshes/box.obj\"\ndepth = 2\n\n\
         [device]\ntrajectory = \"down.csv\"\n",
    )
    .unwrap();
    let out = d.join("out");
    let o = haptic6d(&[
        "run",
        d.join("scene.toml").to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--no-plots",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (_, rows) = csv_rows(&out.join("frames.csv"));
    assert_eq!(rows.len(), 401);
    let last = rows.last().unwrap();
    // The hand ends at z = 15 (5 mm into the object); the graphic tool stays above: its
    // sphere-tree rests on the object's, at or above the mesh contact height z = 20.
    assert!((last[3] - 15.0).abs() < 1e-9);
    assert!(last[9] >= 20.0 - 1e-6, "graphic z {}", last[9]);
    // Spring force pushes the hand up: fz = kt (zg - zh) > 0.
    assert!(last[15] > 4.0, "fz {}", last[15]);
    assert!(rows.iter().all(|r| r[24] <= 0.01), "penetration");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn run_refuses_foreign_files_and_unknown_names() {
    let d = temp_dir("refuse");
    std::fs::write(d.join("notes.txt"), "mine").unwrap();
    let o = haptic6d(&["run", "bunny", "--out", d.to_str().unwrap(), "--no-plots"]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("notes.txt") && err.contains("--force"),
        "{err}"
    );
    assert_eq!(
        std::fs::read_to_string(d.join("notes.txt")).unwrap(),
        "mine"
    );

    let o = haptic6d(&["run", "teapot", "--out", d.join("x").to_str().unwrap()]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("teapot") && err.contains("bunny, spline"),
        "{err}"
    );

    let o = haptic6d(&[
        "run",
        "bunny",
        "--solver",
        "newton",
        "--out",
        d.join("x").to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("newton") && err.contains("dual, pqp, active-set"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn run_measures_the_mesh_penetration_of_a_mesh_scene_and_says_when_it_cannot() {
    let d = temp_dir("mesh-penetration");
    std::fs::write(d.join("box.obj"), box_obj(10.0)).unwrap();
    // Tool box (20 mm) pressed 5 mm past the object box's top face, then lifted clear.
    let mut traj = String::from("t,x,y,z,gamma,beta,alpha\n");
    for i in 0..=600 {
        let t = i as f64 * 1e-3;
        let z = if i <= 400 {
            25.0 - 10.0 * (i as f64 / 400.0)
        } else {
            15.0 + 15.0 * ((i - 400) as f64 / 200.0)
        };
        traj += &format!("{t},0,0,{z},0,0,0\n");
    }
    std::fs::write(d.join("down.csv"), traj).unwrap();
    let scene = |tool: &str| {
        format!(
            "[tool]\n{tool}\nstart = [0, 0, 25, 0, 0, 0]\n\n\
             [[object]]\nmesh = \"box.obj\"\ndepth = 2\n\n\
             [device]\ntrajectory = \"down.csv\"\n"
        )
    };
    std::fs::write(
        d.join("meshes.toml"),
        scene("mesh = \"box.obj\"\ndepth = 2"),
    )
    .unwrap();
    let out = d.join("meshes");
    let o = haptic6d(&[
        "run",
        d.join("meshes.toml").to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--no-plots",
        "--json",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let summary: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let text = std::fs::read_to_string(out.join("frames.csv")).unwrap();
    let header = text.lines().next().unwrap();
    assert!(
        header.ends_with(",scanned,ahead_us,mesh_penetration_mm"),
        "{header}"
    );
    let (_, rows) = csv_rows(&out.join("frames.csv"));
    let zg_at = 9;
    let measured: Vec<&Vec<f64>> = rows.iter().filter(|r| r[29].is_finite()).collect();
    // Measured where the ball holding the tool's box (radius 10√3 mm about its centre) reaches
    // the object's box (top face z = 10): by the parts alone, whatever the engine listed.
    // Empty at the end, the tool's centre 20 mm over that face.
    assert!(measured.len() > 100, "{} frames measured", measured.len());
    assert!(rows.last().unwrap()[29].is_nan());
    for r in &rows {
        let reach = r[zg_at] - 10.0 - 10.0 * 3f64.sqrt();
        if reach.abs() > 1e-6 {
            assert_eq!(r[29].is_finite(), reach < 0.0, "z {}", r[zg_at]);
        }
    }
    // The trees keep the boxes apart: the meshes do not overlap (the tree sits on or above
    // the mesh contact height).
    assert!(measured.iter().all(|r| (0.0..=0.01).contains(&r[29])));
    let mesh = &summary["mesh_penetration_mm"];
    assert_eq!(mesh["frames"].as_u64(), Some(measured.len() as u64));
    assert_eq!(mesh["stride"].as_u64(), Some(1));

    // A tool from a .sph file has no triangles: said in one line, the column left empty.
    std::fs::write(d.join("ball.sph"), "1 8\n0 0 0 10 1\n").unwrap();
    std::fs::write(d.join("sph.toml"), scene("tree = \"ball.sph\"")).unwrap();
    let out = d.join("sph");
    let o = haptic6d(&[
        "run",
        d.join("sph.toml").to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--no-plots",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let err = String::from_utf8_lossy(&o.stderr);
    let first = err.lines().next().unwrap_or_default();
    assert!(
        first.contains("no mesh for the tool") && first.contains("not measured"),
        "{err}"
    );
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("mesh penetration: not measured"),
        "{stdout}"
    );
    let (_, rows) = csv_rows(&out.join("frames.csv"));
    assert!(rows.iter().all(|r| r.len() == 30 && r[29].is_nan()));
    let pairs_at = 19;
    assert!(
        rows.iter().any(|r| r[pairs_at] > 0.0),
        "the ball never reached the box"
    );
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    assert!(summary["mesh_penetration_mm"].is_null());
    let _ = std::fs::remove_dir_all(&d);
}
