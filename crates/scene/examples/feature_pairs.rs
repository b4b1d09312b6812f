//! What a feature-level narrow phase would hold where the mesh mode holds triangle pairs: at
//! the tool poses of a run (its `frames.csv`), the triangle pairs within a list's reach and
//! within a region's margin, their distinct nearest feature pairs, and the candidate nearest
//! feature pairs of [`collide::feature_contacts`] within a slack of their regions (a vertex over a face's inside, against an
//! edge in its wedge or a vertex in its cone; two convex edges nearest between their ends),
//! each counted once however many triangle pairs share it.
//!
//! ```text
//! cargo run --release -p scene --example feature_pairs -- SCENE FRAMES_CSV REACH MARGIN SLACK T...
//! ```
//!
//! `SCENE` a built-in (`spline-tight`, `fit/round-r10-c0.05-tilted`, `zoo/sphere-on-sphere`,
//! …), `FRAMES_CSV` a run of it (`haptic6d run SCENE --geometry mesh --out DIR`), `REACH` and
//! `MARGIN` in mm, `SLACK` how far (mm) a pair may stand outside its features' regions (the
//! motion they may become nearest over), then the frames' times (s). The meshes are taken with their flat faces
//! merged, as the mesh mode takes them. A measuring tool for the design (docs/design-notes.md),
//! not part of the engine: it allocates freely.

use std::collections::{HashMap, HashSet};

use collide::{
    feature_contacts, merge_flat_faces, triangle_distance, Feature, MeshFeatures, PlacedFeatures,
    Pose, Triangle, TriangleTree,
};
use nalgebra::{Matrix3, Vector3};
use scene::{cache::TreeCache, scenes};

type V = Vector3<f64>;

/// The feature of face `f` of `mesh` (corners placed at `points`) the point `q` on it lies
/// at: a corner, an edge or the inside, by its barycentric coordinates within `tol` of zero.
fn feature_at(q: &[f64; 3], mesh: &MeshFeatures, points: &[[f64; 3]], f: u32, tol: f64) -> Feature {
    let ids = mesh.face(f);
    let [a, b, c] = ids.map(|v| V::from(points[v as usize]));
    let q = V::from(*q);
    let n = (b - a).cross(&(c - a));
    let area = n.norm_squared();
    let bary = [
        (c - b).cross(&(q - b)).dot(&n) / area,
        (a - c).cross(&(q - c)).dot(&n) / area,
        (b - a).cross(&(q - a)).dot(&n) / area,
    ];
    let zero: Vec<usize> = (0..3).filter(|&k| bary[k].abs() <= tol).collect();
    match zero.as_slice() {
        [i, j] => Feature::Vertex(ids[3 - i - j]),
        [i] => Feature::Edge(mesh.face_edges(f)[(i + 1) % 3]),
        _ => Feature::Face(f),
    }
}

fn main() {
    if let Err(e) = run() {
        eprintln!("feature_pairs: {e}");
        std::process::exit(2);
    }
}

/// A number (mm or s) from the argument `what` names.
fn number(arg: &str, what: &str) -> Result<f64, String> {
    arg.parse()
        .ok()
        .filter(|x: &f64| x.is_finite())
        .ok_or_else(|| format!("{what} must be a finite number, not `{arg}`"))
}

fn run() -> Result<(), String> {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 7 {
        return Err("usage: feature_pairs SCENE FRAMES_CSV REACH MARGIN SLACK T...".into());
    }
    let (name, frames) = (&args[1], &args[2]);
    let reach = number(&args[3], "REACH (mm)")?;
    let margin = number(&args[4], "MARGIN (mm)")?;
    let slack = number(&args[5], "SLACK (mm)")?;
    let times = args[6..]
        .iter()
        .map(|t| number(t, "a time (s)"))
        .collect::<Result<Vec<f64>, String>>()?;
    let scene = scenes::builtin(name, &TreeCache::from_env())
        .map_err(|e| format!("{name}: {}", scene::error_chain(&e)))?;
    let merged = |m: &mesh::TriMesh| merge_flat_faces(&m.vertices, &m.triangles).triangles;
    let not_meshed = || format!("{name}: every body must be built from a mesh");
    let tool_mesh = scene.tool_mesh.as_ref().ok_or_else(not_meshed)?;
    let tool_tris = merged(tool_mesh);
    let tool_tree = TriangleTree::build(&tool_tris, &Pose::identity());
    let tool_features = MeshFeatures::new(&tool_tris);
    let objects: Vec<(Vec<Triangle>, TriangleTree, MeshFeatures)> = scene
        .object_meshes
        .iter()
        .zip(&scene.objects)
        .map(|(m, (_, pose))| {
            let tris = merged(m.as_ref().ok_or_else(not_meshed)?);
            let (rot, t) = (pose.rotation_matrix(), pose.translation());
            let placed: Vec<Triangle> = tris
                .iter()
                .map(|tri| tri.map(|p| (rot * V::from(p) + t).into()))
                .collect();
            let tree = TriangleTree::build(&tris, pose);
            let features = MeshFeatures::new(&placed);
            Ok((placed, tree, features))
        })
        .collect::<Result<_, String>>()?;

    let text = std::fs::read_to_string(frames).map_err(|e| format!("{frames}: {e}"))?;
    let mut lines = text.lines();
    let head: Vec<&str> = lines
        .next()
        .ok_or_else(|| format!("{frames}: empty, a run's frames.csv expected"))?
        .split(',')
        .collect();
    let mut cols = [0usize; 7];
    for (c, n) in cols
        .iter_mut()
        .zip(["t", "xg", "yg", "zg", "gg", "bg", "ag"])
    {
        *c = head
            .iter()
            .position(|h| *h == n)
            .ok_or_else(|| format!("{frames}: no column `{n}` (a run's frames.csv expected)"))?;
    }
    let rows: Vec<Vec<f64>> = lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            cols.iter()
                .map(|&c| f.get(c).and_then(|x| x.parse().ok()).unwrap_or(f64::NAN))
                .collect()
        })
        .collect();

    println!(
        "| t (s) | triangle pairs listed | within {reach} mm | within {margin} mm | their nearest feature pairs | candidate feature pairs (slack {slack} mm) within {reach} mm | within {margin} mm |"
    );
    println!("|---|---|---|---|---|---|---|");
    for &time in &times {
        let row = rows
            .iter()
            .min_by(|a, b| (a[0] - time).abs().total_cmp(&(b[0] - time).abs()))
            .ok_or_else(|| format!("{frames}: no frames"))?;
        let pose = Pose::from_array([row[1], row[2], row[3], row[4], row[5], row[6]]);
        let (rot, t): (Matrix3<f64>, V) = (pose.rotation_matrix(), pose.translation());
        let posed: Vec<Triangle> = tool_tris
            .iter()
            .map(|tri| tri.map(|p| (rot * V::from(p) + t).into()))
            .collect();
        let mut tool_points = Vec::new();
        tool_features.place(&pose, &mut tool_points);
        let tool = PlacedFeatures {
            mesh: &tool_features,
            points: &tool_points,
        };
        let (mut listed, mut within, mut rows_tri) = (0usize, 0usize, 0usize);
        let mut features: HashMap<(usize, Feature, Feature), f64> = HashMap::new();
        let mut nearest: HashSet<(usize, Feature, Feature)> = HashSet::new();
        for (k, (placed, tree, object_features)) in objects.iter().enumerate() {
            // Built from its triangles where they stand: its own points are placed.
            let object_points = object_features.points();
            let object = PlacedFeatures {
                mesh: object_features,
                points: object_points,
            };
            let mut stack = TriangleTree::stack_for(&tool_tree, tree);
            let mut pairs = Vec::new();
            tool_tree.near_leaf_pairs(&rot, &t, tree, reach, &mut stack, |ts, ps| {
                for a in ts {
                    for b in ps.clone() {
                        pairs.push((tool_tree.origin(a), tree.origin(b)));
                    }
                }
                true
            });
            for (a, b) in pairs {
                listed += 1;
                let near = triangle_distance(&posed[a as usize], &placed[b as usize]);
                if near.distance > reach {
                    continue;
                }
                within += 1;
                if near.distance <= margin {
                    rows_tri += 1;
                    nearest.insert((
                        k,
                        feature_at(&near.on_a, &tool_features, &tool_points, a, 1e-7),
                        feature_at(&near.on_b, object_features, object_points, b, 1e-7),
                    ));
                }
                feature_contacts(tool, a, object, b, reach, slack, |c| {
                    features.insert((k, c.a, c.b), c.distance);
                });
            }
        }
        let f_reach = features.values().filter(|&&d| d <= reach).count();
        let f_margin = features.values().filter(|&&d| d <= margin).count();
        println!(
            "| {:.3} | {listed} | {within} | {rows_tri} | {} | {f_reach} | {f_margin} |",
            row[0],
            nearest.len()
        );
    }
    Ok(())
}
