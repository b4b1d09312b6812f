//! `run --geometry`: the mesh mode where every body has a mesh (summary and first line say so),
//! the spheres with a note where one has none, and a one-line error for an unknown name;
//! `run --without` and `--tuning`, the step's switches and tuned values; `bench --geometry` on
//! the speed study.

mod common;

use common::{haptic6d, one_line_failure, success, Dir, SMALL_SPH};

fn summary(dir: &Dir, name: &str) -> serde_json::Value {
    let text = std::fs::read_to_string(dir.0.join(name).join("summary.json")).unwrap();
    serde_json::from_str(&text).unwrap()
}

#[test]
fn a_peg_that_jams_on_the_leaf_spheres_is_told_of_the_mesh_mode() {
    let d = Dir::new("jam-hint");
    // The round peg at 0.05 mm radial clearance jams at the hole's mouth on the spheres.
    let o = haptic6d(&[
        "run",
        "fit/round-r10-c0.05",
        "--no-plots",
        "--out",
        &d.path("spheres"),
    ]);
    success(&o);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("NOT REACHED"), "{out}");
    assert!(out.contains("`--geometry mesh`"), "{out}");
    assert_eq!(summary(&d, "spheres")["meshes"], true);
    // On the mesh, a goal not reached (the run cut short) gets no such hint.
    let o = haptic6d(&[
        "run",
        "fit/round-r10-c0.05",
        "--geometry",
        "mesh",
        "--duration",
        "0.3",
        "--no-plots",
        "--out",
        &d.path("mesh"),
    ]);
    success(&o);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("NOT REACHED"), "{out}");
    assert!(!out.contains("`--geometry mesh`"), "{out}");
}

#[test]
fn run_takes_the_geometry_and_says_which_it_used() {
    let d = Dir::new("geometry");
    // A mesh scene: the parts' triangles.
    let o = haptic6d(&[
        "run",
        "zoo/cube-edge",
        "--geometry",
        "mesh",
        "--duration",
        "0.05",
        "--no-plots",
        "--out",
        &d.path("mesh"),
    ]);
    success(&o);
    assert_eq!(summary(&d, "mesh")["geometry"], "mesh");
    assert!(String::from_utf8_lossy(&o.stdout).contains("(distance, mesh)"));
    // The default is the leaf spheres.
    let o = haptic6d(&[
        "run",
        "zoo/cube-edge",
        "--duration",
        "0.05",
        "--no-plots",
        "--out",
        &d.path("spheres"),
    ]);
    success(&o);
    assert_eq!(summary(&d, "spheres")["geometry"], "spheres");
    // A tool from a .sph file alone has no triangles: spheres, and a note.
    d.write("tool.sph", SMALL_SPH);
    d.write("object.sph", SMALL_SPH);
    let scene = d.write(
        "scene.toml",
        "[tool]\ntree = \"tool.sph\"\nstart = [0, 0, 10, 0, 0, 0]\n\n[[object]]\ntree = \"object.sph\"\n",
    );
    let o = haptic6d(&[
        "run",
        &scene,
        "--geometry",
        "mesh",
        "--duration",
        "0.05",
        "--no-plots",
        "--out",
        &d.path("sph"),
    ]);
    success(&o);
    let s = summary(&d, "sph");
    assert_eq!(s["geometry"], "spheres");
    let load = s["load"].to_string();
    assert!(
        load.contains("mesh asked, but not every body has a mesh"),
        "{load}"
    );
    // An unknown name: one line naming the flag and the choices.
    let o = haptic6d(&[
        "run",
        "zoo/cube-edge",
        "--geometry",
        "voxels",
        "--out",
        &d.path("bad"),
    ]);
    let line = one_line_failure(&o);
    assert!(
        line.contains("--geometry") && line.contains("spheres, mesh"),
        "{line}"
    );
}

/// The `scanned` column of a run's frames.csv, summed: the neighbour lists' entries tested.
fn scanned(dir: &Dir, name: &str) -> u64 {
    let text = std::fs::read_to_string(dir.0.join(name).join("frames.csv")).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = header.iter().position(|h| *h == "scanned").unwrap();
    lines
        .map(|l| l.split(',').nth(col).unwrap().parse::<u64>().unwrap())
        .sum()
}

#[test]
fn run_switches_a_heuristic_off_and_sets_a_tuned_value_and_says_so() {
    let d = Dir::new("without");
    let run = |name: &str, extra: &[&str]| {
        let out = d.path(name);
        let mut args = vec![
            "run",
            "zoo/slot",
            "--duration",
            "1.5",
            "--no-plots",
            "--out",
            &out,
        ];
        args.extend_from_slice(extra);
        success(&haptic6d(&args));
    };
    run("shipped", &[]);
    run(
        "without",
        &[
            "--without",
            "neighbour-lists",
            "--tuning",
            "near-fill-share=0.1",
        ],
    );
    let load = summary(&d, "without")["load"].to_string();
    assert!(
        load.contains("heuristics off [neighbour-lists], tuned values set [near-fill-share=0.1]"),
        "{load}"
    );
    // The slot's frames test neighbour-list entries; without the lists they test none.
    assert!(scanned(&d, "shipped") > 0);
    assert_eq!(scanned(&d, "without"), 0);
    // Unknown names and values out of range: one line naming the flag.
    for (flag, value, says) in [
        ("--without", "mesh-magic", "no heuristic `mesh-magic`"),
        ("--tuning", "no-such=1", "not NAME=NUMBER"),
        ("--tuning", "near-fill-share=2", "share in (0, 1]"),
    ] {
        let o = haptic6d(&["run", "zoo/slot", flag, value, "--out", &d.path("bad")]);
        let line = one_line_failure(&o);
        assert!(line.contains(flag) && line.contains(says), "{line}");
    }
}

#[test]
fn the_speed_study_replays_each_row_in_each_geometry_mode() {
    let d = Dir::new("speed-geometry");
    let o = haptic6d(&[
        "bench",
        "--quick",
        "--studies",
        "speed",
        "--geometry",
        "spheres,mesh",
        "--no-plots",
        "--out",
        &d.path("out"),
    ]);
    success(&o);
    let text = std::fs::read_to_string(d.0.join("out").join("bench.json")).unwrap();
    let report: serde_json::Value = serde_json::from_str(&text).unwrap();
    let rows = report["speed"].as_array().unwrap();
    let mode = |g: &str| rows.iter().filter(|r| r["geometry"] == g).count();
    assert!(mode("spheres") > 0);
    assert_eq!(mode("spheres"), mode("mesh"));
    // Every row keeps the tool out of the plate in both modes.
    for r in rows {
        assert!(r["max_penetration_mm"].as_f64().unwrap() < 1e-6, "{r}");
    }
}
