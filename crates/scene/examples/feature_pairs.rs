//! What a feature-level narrow phase would hold where the mesh mode holds triangle pairs: at
//! the tool poses of a run (its `frames.csv`), the triangle pairs within a list's reach and
//! within a region's margin, against the vertex–face and edge–edge pairs that are nearest
//! features there (a vertex over a face's inside, two convex edges nearest between their
//! ends), each counted once however many triangle pairs share it.
//!
//! ```text
//! cargo run --release -p scene --example feature_pairs -- SCENE FRAMES_CSV REACH MARGIN T...
//! ```
//!
//! `SCENE` a built-in (`spline-tight`, `fit/round-r10-c0.05-tilted`, `zoo/sphere-on-sphere`,
//! …), `FRAMES_CSV` a run of it (`haptic6d run SCENE --geometry mesh --out DIR`), `REACH` and
//! `MARGIN` in mm, then the frames' times (s). The meshes are taken with their flat faces
//! merged, as the mesh mode takes them. A measuring tool for the design (docs/design-notes.md),
//! not part of the engine: it allocates freely.

use std::collections::{HashMap, HashSet};

use collide::{merge_flat_faces, triangle_distance, Pose, Triangle, TriangleTree};
use nalgebra::{Matrix3, Vector3};
use scene::{cache::TreeCache, scenes};

type V = Vector3<f64>;

/// A surface with its topology: vertices by their coordinates' bits, faces, and for each
/// edge (its two vertex ids, the lower first) whether it is convex.
struct Surface {
    points: Vec<V>,
    faces: Vec<[u32; 3]>,
    convex_edges: HashSet<(u32, u32)>,
}

impl Surface {
    fn new(triangles: &[Triangle]) -> Self {
        let mut ids: HashMap<[u64; 3], u32> = HashMap::new();
        let mut points = Vec::new();
        let mut faces = Vec::new();
        for t in triangles {
            let mut f = [0u32; 3];
            for (k, p) in t.iter().enumerate() {
                let key = p.map(f64::to_bits);
                f[k] = *ids.entry(key).or_insert_with(|| {
                    points.push(V::from(*p));
                    (points.len() - 1) as u32
                });
            }
            faces.push(f);
        }
        let mut by_edge: HashMap<(u32, u32), Vec<usize>> = HashMap::new();
        for (i, f) in faces.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (f[k], f[(k + 1) % 3]);
                by_edge.entry((a.min(b), a.max(b))).or_default().push(i);
            }
        }
        let mut s = Self {
            points,
            faces,
            convex_edges: HashSet::new(),
        };
        for (edge, fs) in by_edge {
            // An edge of one face (a hole's rim, an open mesh) counts as convex; one of two
            // faces is convex where the second face's far corner lies behind the first's plane.
            let convex = match fs.as_slice() {
                [f1, f2] => {
                    let (n, d) = s.plane(*f1);
                    let far = s.faces[*f2]
                        .iter()
                        .find(|&&v| v != edge.0 && v != edge.1)
                        .map_or(0.0, |&v| n.dot(&s.points[v as usize]) - d);
                    far < -1e-9
                }
                _ => true,
            };
            if convex {
                s.convex_edges.insert(edge);
            }
        }
        s
    }

    fn plane(&self, f: usize) -> (V, f64) {
        let [a, b, c] = self.faces[f].map(|v| self.points[v as usize]);
        let n = (b - a).cross(&(c - a)).normalize();
        (n, n.dot(&a))
    }
}

/// The distance (mm) from `p` to face `f` of `s` where `p` lies over the face's inside (its
/// projection within the face, by `slack` mm) and in front of it; else `None`.
fn vertex_face(p: &V, s: &Surface, f: usize, slack: f64) -> Option<f64> {
    let (n, d) = s.plane(f);
    let h = n.dot(p) - d;
    if h < -1e-9 {
        return None;
    }
    let q = p - n * h;
    let corners = s.faces[f].map(|v| s.points[v as usize]);
    for k in 0..3 {
        let (a, b) = (corners[k], corners[(k + 1) % 3]);
        let inward = n.cross(&(b - a)).normalize();
        if inward.dot(&(q - a)) < -slack {
            return None;
        }
    }
    Some(h)
}

/// The distance (mm) between segments `(a0, a1)` and `(b0, b1)` where their nearest points
/// are inside both (not at an end); else `None`.
fn edge_edge(a0: &V, a1: &V, b0: &V, b1: &V) -> Option<f64> {
    let (u, v, w) = (a1 - a0, b1 - b0, a0 - b0);
    let (aa, bb, ab, au, bu) = (u.dot(&u), v.dot(&v), u.dot(&v), u.dot(&w), v.dot(&w));
    let den = aa * bb - ab * ab;
    if den <= 1e-12 * aa * bb {
        return None; // parallel: the vertex–face pairs hold them
    }
    let s = (ab * bu - bb * au) / den;
    let t = (aa * bu - ab * au) / den;
    let inside = |x: f64| x > 1e-9 && x < 1.0 - 1e-9;
    (inside(s) && inside(t)).then(|| (w + u * s - v * t).norm())
}

/// The feature of face `f` of `s` the point `q` (on the face) lies at: a corner (kind 0, its
/// vertex), an edge (kind 1, its two vertices) or the inside (kind 2, the face), by its
/// barycentric coordinates within `tol` of zero.
fn feature_at(q: &[f64; 3], s: &Surface, f: usize, tol: f64) -> (u8, u64) {
    let ids = s.faces[f];
    let [a, b, c] = ids.map(|v| s.points[v as usize]);
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
        [i, j] => {
            let k = 3 - i - j;
            (0, u64::from(ids[k]))
        }
        [i] => {
            let (u, v) = (ids[(i + 1) % 3], ids[(i + 2) % 3]);
            (1, (u64::from(u.min(v)) << 32) | u64::from(u.max(v)))
        }
        _ => (2, f as u64),
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 6 {
        eprintln!("usage: feature_pairs SCENE FRAMES_CSV REACH MARGIN T...");
        std::process::exit(2);
    }
    let (name, frames) = (&args[1], &args[2]);
    let reach: f64 = args[3].parse().expect("REACH in mm");
    let margin: f64 = args[4].parse().expect("MARGIN in mm");
    let times: Vec<f64> = args[5..]
        .iter()
        .map(|t| t.parse().expect("a time in s"))
        .collect();
    let scene = scenes::builtin(name, &TreeCache::from_env()).expect("a built-in scene");
    let merged = |m: &mesh::TriMesh| merge_flat_faces(&m.vertices, &m.triangles).triangles;
    let tool_mesh = scene.tool_mesh.as_ref().expect("a tool built from a mesh");
    let tool_tris = merged(tool_mesh);
    let tool_tree = TriangleTree::build(&tool_tris, &Pose::identity());
    let objects: Vec<(Vec<Triangle>, TriangleTree)> = scene
        .object_meshes
        .iter()
        .zip(&scene.objects)
        .map(|(m, (_, pose))| {
            let tris = merged(m.as_ref().expect("objects built from meshes"));
            let (rot, t) = (pose.rotation_matrix(), pose.translation());
            let placed: Vec<Triangle> = tris
                .iter()
                .map(|tri| tri.map(|p| (rot * V::from(p) + t).into()))
                .collect();
            let tree = TriangleTree::build(&tris, pose);
            (placed, tree)
        })
        .collect();

    let text = std::fs::read_to_string(frames).expect("frames.csv");
    let mut lines = text.lines();
    let head: Vec<&str> = lines.next().expect("a header").split(',').collect();
    let col = |n: &str| {
        head.iter()
            .position(|h| *h == n)
            .expect("a column of frames.csv")
    };
    let cols = ["t", "xg", "yg", "zg", "gg", "bg", "ag"].map(col);
    let rows: Vec<Vec<f64>> = lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            cols.iter()
                .map(|&c| f[c].parse().unwrap_or(f64::NAN))
                .collect()
        })
        .collect();

    println!(
        "| t (s) | triangle pairs listed | within {reach} mm | within {margin} mm | their nearest feature pairs | vertex–face and edge–edge pairs within {reach} mm | within {margin} mm |"
    );
    println!("|---|---|---|---|---|---|---|");
    for &time in &times {
        let row = rows
            .iter()
            .min_by(|a, b| (a[0] - time).abs().total_cmp(&(b[0] - time).abs()))
            .expect("frames");
        let pose = Pose::from_array([row[1], row[2], row[3], row[4], row[5], row[6]]);
        let (rot, t): (Matrix3<f64>, V) = (pose.rotation_matrix(), pose.translation());
        let posed: Vec<Triangle> = tool_tris
            .iter()
            .map(|tri| tri.map(|p| (rot * V::from(p) + t).into()))
            .collect();
        let tool = Surface::new(&posed);
        let (mut listed, mut within, mut rows_tri) = (0usize, 0usize, 0usize);
        let mut features: HashMap<(u8, u64, u64), f64> = HashMap::new();
        let mut nearest: HashSet<((u8, u64), (u8, u64))> = HashSet::new();
        for (placed, tree) in &objects {
            let object = Surface::new(placed);
            let mut stack = TriangleTree::stack_for(&tool_tree, tree);
            let mut pairs = Vec::new();
            tool_tree.near_leaf_pairs(&rot, &t, tree, reach, &mut stack, |ts, ps| {
                for a in ts {
                    for b in ps.clone() {
                        pairs.push((tool_tree.origin(a) as usize, tree.origin(b) as usize));
                    }
                }
                true
            });
            for (a, b) in pairs {
                listed += 1;
                let near = triangle_distance(&posed[a], &placed[b]);
                let d = near.distance;
                if d > reach {
                    continue;
                }
                within += 1;
                rows_tri += usize::from(d <= margin);
                if d <= margin {
                    nearest.insert((
                        feature_at(&near.on_a, &tool, a, 1e-7),
                        feature_at(&near.on_b, &object, b, 1e-7),
                    ));
                }
                let (fa, fb) = (tool.faces[a], object.faces[b]);
                let mut note = |key: (u8, u64, u64), d: f64| {
                    features.insert(key, d);
                };
                for &v in &fa {
                    if let Some(h) = vertex_face(&tool.points[v as usize], &object, b, 1e-9) {
                        note((0, u64::from(v), b as u64), h);
                    }
                }
                for &v in &fb {
                    if let Some(h) = vertex_face(&object.points[v as usize], &tool, a, 1e-9) {
                        note((1, u64::from(v), a as u64), h);
                    }
                }
                for i in 0..3 {
                    let ea = (fa[i].min(fa[(i + 1) % 3]), fa[i].max(fa[(i + 1) % 3]));
                    if !tool.convex_edges.contains(&ea) {
                        continue;
                    }
                    for j in 0..3 {
                        let eb = (fb[j].min(fb[(j + 1) % 3]), fb[j].max(fb[(j + 1) % 3]));
                        if !object.convex_edges.contains(&eb) {
                            continue;
                        }
                        let p = |s: &Surface, v: u32| s.points[v as usize];
                        let ends = (
                            p(&tool, ea.0),
                            p(&tool, ea.1),
                            p(&object, eb.0),
                            p(&object, eb.1),
                        );
                        if let Some(d) = edge_edge(&ends.0, &ends.1, &ends.2, &ends.3) {
                            let key = |e: (u32, u32)| (u64::from(e.0) << 32) | u64::from(e.1);
                            note((2, key(ea), key(eb)), d);
                        }
                    }
                }
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
}
