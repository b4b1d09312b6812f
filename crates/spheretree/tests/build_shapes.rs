//! Builders on simple closed shapes other than the bunny: a thin plate (the two sides are
//! 1/50 of the size apart) and a sphere. Trees are valid and cover every level.

use mesh::TriMesh;
use spheretree::build::{build_tree, BuildMethod, BuildParams};
use spheretree::eval::{evaluate_fit, icosphere_directions, FitParams};

fn boxed(hx: f64, hy: f64, hz: f64) -> TriMesh {
    let v = |x: f64, y: f64, z: f64| [x * hx, y * hy, z * hz];
    TriMesh {
        vertices: vec![
            v(-1.0, -1.0, -1.0),
            v(1.0, -1.0, -1.0),
            v(1.0, 1.0, -1.0),
            v(-1.0, 1.0, -1.0),
            v(-1.0, -1.0, 1.0),
            v(1.0, -1.0, 1.0),
            v(1.0, 1.0, 1.0),
            v(-1.0, 1.0, 1.0),
        ],
        triangles: vec![
            [0, 2, 1],
            [0, 3, 2],
            [4, 5, 6],
            [4, 6, 7],
            [0, 1, 5],
            [0, 5, 4],
            [2, 3, 7],
            [2, 7, 6],
            [1, 2, 6],
            [1, 6, 5],
            [0, 4, 7],
            [0, 7, 3],
        ],
    }
}

/// A sphere of radius 5 triangulated from the 162-point icosphere (convex hull by brute
/// force: a triangle is a face when no point lies beyond its plane).
fn ball() -> TriMesh {
    let p: Vec<[f64; 3]> = icosphere_directions(2)
        .iter()
        .map(|u| [5.0 * u[0], 5.0 * u[1], 5.0 * u[2]])
        .collect();
    let mut triangles = Vec::new();
    // Faces of the icosphere: triples of mutual near neighbours.
    let d = |a: usize, b: usize| {
        ((p[a][0] - p[b][0]).powi(2) + (p[a][1] - p[b][1]).powi(2) + (p[a][2] - p[b][2]).powi(2))
            .sqrt()
    };
    let edge = (1..p.len()).map(|j| d(0, j)).fold(f64::INFINITY, f64::min) * 1.3;
    for a in 0..p.len() {
        for b in a + 1..p.len() {
            if d(a, b) > edge {
                continue;
            }
            for c in b + 1..p.len() {
                if d(a, c) > edge || d(b, c) > edge {
                    continue;
                }
                // Orient outward.
                let (u, w) = (
                    [p[b][0] - p[a][0], p[b][1] - p[a][1], p[b][2] - p[a][2]],
                    [p[c][0] - p[a][0], p[c][1] - p[a][1], p[c][2] - p[a][2]],
                );
                let n = [
                    u[1] * w[2] - u[2] * w[1],
                    u[2] * w[0] - u[0] * w[2],
                    u[0] * w[1] - u[1] * w[0],
                ];
                let out = n[0] * p[a][0] + n[1] * p[a][1] + n[2] * p[a][2] > 0.0;
                triangles.push(if out {
                    [a as u32, b as u32, c as u32]
                } else {
                    [a as u32, c as u32, b as u32]
                });
            }
        }
    }
    assert_eq!(triangles.len(), 320);
    TriMesh {
        vertices: p,
        triangles,
    }
}

#[test]
fn thin_plate_and_ball_build_valid_covering_trees() {
    for (name, mesh) in [("plate", boxed(50.0, 30.0, 1.0)), ("ball", ball())] {
        mesh.check_closed().unwrap();
        for method in [BuildMethod::Tight, BuildMethod::Octree] {
            let params = BuildParams {
                depth: 3,
                method,
                ..BuildParams::default()
            };
            let tree = build_tree(&mesh, &params, &|_| {}).unwrap();
            tree.validate(0.0).unwrap();
            let fit = evaluate_fit(&tree, &mesh, &FitParams::default());
            for l in &fit {
                eprintln!("{name} {method:?} {l:?}");
                assert!(
                    l.coverage >= 0.999,
                    "{name} {method:?} level {}: {l:?}",
                    l.level
                );
            }
            let leaf = fit.last().unwrap();
            if method == BuildMethod::Tight {
                // Plate: 2000 x 1200 x 40 toolkit units. 512 spheres centred on the mid-plane
                // each cover >= 2.4e6 / 512 units^2 of it, a disc of radius >= 39 (42 for a
                // hexagonal covering), so the protrusion is at least
                // sqrt(42^2 + 20^2) - 20 = 26.5; allow 1.5x that on average.
                // Ball: convex, every leaf can sit deep inside; small errors.
                let (worst, mean) = if name == "plate" {
                    (70.0, 40.0)
                } else {
                    (20.0, 5.0)
                };
                assert!(leaf.worst < worst, "{name}: {leaf:?}");
                assert!(leaf.mean < mean, "{name}: {leaf:?}");
            }
        }
    }
}
