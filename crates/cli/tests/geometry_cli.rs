//! `run --geometry`: the mesh mode where every body has a mesh (summary and first line say so),
//! the spheres with a note where one has none, and a one-line error for an unknown name.

mod common;

use common::{haptic6d, one_line_failure, success, Dir, SMALL_SPH};

fn summary(dir: &Dir, name: &str) -> serde_json::Value {
    let text = std::fs::read_to_string(dir.0.join(name).join("summary.json")).unwrap();
    serde_json::from_str(&text).unwrap()
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
