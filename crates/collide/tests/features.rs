//! Mesh features against brute force: over every triangle pair of two meshes that do not meet,
//! the least distance of the candidate nearest feature pairs ([`feature_contacts`]) is the
//! least triangle distance, to 1e-9 mm; every candidate's distance is that of its two points,
//! each on its own feature; and a contact of many triangle pairs holds few feature pairs.

use std::collections::HashMap;

use collide::{
    feature_contacts, triangle_distance, EdgeKind, Feature, FeatureContact, MeshFeatures,
    PlacedFeatures, Pose, Triangle,
};
use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

type V = Vector3<f64>;

/// A generated mesh's triangles.
fn triangles(m: &mesh::TriMesh) -> Vec<Triangle> {
    m.triangles
        .iter()
        .map(|t| t.map(|v| m.vertices[v as usize]))
        .collect()
}

/// A box of half sides `h` about the origin, two triangles a face.
fn box_mesh(h: [f64; 3]) -> Vec<Triangle> {
    triangles(&mesh::generate::grid_box([0.0; 3], h, 1))
}

/// A ball of radius `r` about the origin with `n` segments about its axis and `n / 2` rings:
/// fans of slivers meet at its poles.
fn ball_mesh(r: f64, n: u32) -> Vec<Triangle> {
    triangles(&mesh::generate::uv_sphere(r, n / 2, n))
}

/// An L-shaped prism (not convex: one concave edge along its height), `h` mm high.
fn l_prism(h: f64) -> Vec<Triangle> {
    let outline = [
        [0.0, 0.0],
        [2.0, 0.0],
        [2.0, 1.0],
        [1.0, 1.0],
        [1.0, 2.0],
        [0.0, 2.0],
    ];
    triangles(&mesh::generate::extrude(
        &outline.map(|p| p.map(|x| 5.0 * x)),
        0.0,
        h,
    ))
}

fn placed(tris: &[Triangle], pose: &Pose) -> Vec<Triangle> {
    let (rot, t) = (pose.rotation_matrix(), pose.translation());
    tris.iter()
        .map(|tri| tri.map(|p| (rot * V::from(p) + t).into()))
        .collect()
}

fn random_pose(rng: &mut ChaCha8Rng, spread: f64) -> Pose {
    Pose::from_array([
        rng.random_range(-spread..spread),
        rng.random_range(-spread..spread),
        rng.random_range(-spread..spread),
        rng.random_range(-3.2..3.2),
        rng.random_range(-1.5..1.5),
        rng.random_range(-3.2..3.2),
    ])
}

/// The distance of `p` from the feature `f` of the mesh whose placed triangles are `tris`.
fn off_feature(p: &[f64; 3], f: Feature, mesh: &MeshFeatures, points: &[[f64; 3]]) -> f64 {
    let at = |v: u32| V::from(points[v as usize]);
    let p = V::from(*p);
    match f {
        Feature::Vertex(v) => (p - at(v)).norm(),
        Feature::Edge(e) => {
            let [a, b] = mesh.edge(e).ends.map(at);
            let s = ((p - a).dot(&(b - a)) / (b - a).norm_squared()).clamp(0.0, 1.0);
            (p - (a + (b - a) * s)).norm()
        }
        Feature::Face(g) => {
            let tri = mesh.face(g).map(|v| points[v as usize]);
            triangle_distance(&tri, &[p.into(), p.into(), p.into()]).distance
        }
    }
}

/// Every candidate of two meshes' triangle pairs within `reach` (mm), each once by its
/// features, the least triangle distance and the triangle pairs within the reach; each mesh
/// given by its features, its triangles where they stand and the pose that put them there.
fn candidates(
    a: (&MeshFeatures, &[Triangle], &Pose),
    b: (&MeshFeatures, &[Triangle], &Pose),
    reach: f64,
) -> (HashMap<(Feature, Feature), FeatureContact>, f64, usize) {
    let (mut pa, mut pb) = (Vec::new(), Vec::new());
    a.0.place(a.2, &mut pa);
    b.0.place(b.2, &mut pb);
    let (fa, fb) = (
        PlacedFeatures {
            mesh: a.0,
            points: &pa,
        },
        PlacedFeatures {
            mesh: b.0,
            points: &pb,
        },
    );
    let mut found = HashMap::new();
    let mut least = f64::INFINITY;
    let mut within = 0;
    for (i, ta) in a.1.iter().enumerate() {
        for (j, tb) in b.1.iter().enumerate() {
            let d = triangle_distance(ta, tb);
            least = least.min(if d.meet { 0.0 } else { d.distance });
            if d.distance > reach {
                continue;
            }
            within += 1;
            feature_contacts(fa, i as u32, fb, j as u32, reach, 0.0, |c| {
                // Each candidate's points are on its features, its distance theirs.
                assert!(off_feature(&c.on_a, c.a, a.0, &pa) < 1e-9, "{c:?}");
                assert!(off_feature(&c.on_b, c.b, b.0, &pb) < 1e-9, "{c:?}");
                let between = (V::from(c.on_a) - V::from(c.on_b)).norm();
                assert!((between - c.distance).abs() < 1e-12, "{c:?}");
                found.insert((c.a, c.b), c);
            });
        }
    }
    (found, least, within)
}

#[test]
fn the_least_candidate_is_the_meshes_distance_for_every_pose() {
    let shapes: [(&str, Vec<Triangle>); 3] = [
        ("box", box_mesh([4.0, 3.0, 2.0])),
        ("ball", ball_mesh(5.0, 12)),
        ("L prism", l_prism(6.0)),
    ];
    let mut rng = ChaCha8Rng::seed_from_u64(42);
    let still = Pose::identity();
    let (mut checked, mut apart) = (0, 0);
    for (name_a, a) in &shapes {
        for (name_b, b) in &shapes {
            let (fa, fb) = (MeshFeatures::new(a), MeshFeatures::new(b));
            for _ in 0..60 {
                let pose = random_pose(&mut rng, 16.0);
                let a_placed = placed(a, &pose);
                let (found, least, _) =
                    candidates((&fa, &a_placed, &pose), (&fb, b, &still), f64::INFINITY);
                if least <= 1e-6 {
                    continue; // meeting: no nearest pair to find
                }
                let best = found
                    .values()
                    .map(|c| c.distance)
                    .fold(f64::INFINITY, f64::min);
                assert!(
                    (best - least).abs() <= 1e-9,
                    "{name_a} against {name_b}: {best} against {least}"
                );
                apart += 1;
            }
            checked += 1;
        }
    }
    assert!(checked == 9 && apart > 200, "{apart} poses apart");
}

/// Two meshes, each placed by a pose, and their gap (mm).
type Case<'a> = (&'a [Triangle], &'a [Triangle], Pose, Pose, f64);

#[test]
fn degenerate_contacts_keep_their_nearest_pair() {
    // A ball's pole right over another's (a vertex over a vertex), a box face over a box face
    // (faces parallel, edges parallel), a box's edge across another's (edges touching), and
    // a corner right over a corner.
    let ball = ball_mesh(5.0, 16);
    let cube = box_mesh([3.0, 3.0, 3.0]);
    let quarter = std::f64::consts::FRAC_PI_4;
    let root2 = 2f64.sqrt();
    let at = |q: [f64; 6]| Pose::from_array(q);
    let still = at([0.0; 6]);
    // (tool, object, the tool's pose, the object's, their gap in mm)
    let cases: [Case<'_>; 5] = [
        (
            &ball,
            &ball,
            at([0.0, 0.0, 10.25, 0.0, 0.0, 0.0]),
            still,
            0.25,
        ),
        (&cube, &cube, at([1.0, 0.5, 6.5, 0.0, 0.0, 0.0]), still, 0.5),
        (&cube, &cube, at([0.0, 0.0, 6.5, 0.0, 0.0, 0.0]), still, 0.5),
        (
            &cube,
            &cube,
            at([0.0, 0.0, 6.0 * root2 + 0.1, quarter, 0.0, 0.0]),
            at([0.0, 0.0, 0.0, 0.0, quarter, 0.0]),
            0.1,
        ),
        (
            &cube,
            &cube,
            at([6.1, 6.1, 6.1, 0.0, 0.0, 0.0]),
            still,
            0.03f64.sqrt(),
        ),
    ];
    for (k, (a, b, pose, object_pose, gap)) in cases.into_iter().enumerate() {
        let (fa, fb) = (MeshFeatures::new(a), MeshFeatures::new(b));
        let (a_placed, b_placed) = (placed(a, &pose), placed(b, &object_pose));
        let (found, least, _) =
            candidates((&fa, &a_placed, &pose), (&fb, &b_placed, &object_pose), 1.0);
        let best = found
            .values()
            .map(|c| c.distance)
            .fold(f64::INFINITY, f64::min);
        assert!(
            (least - gap).abs() < 1e-9,
            "case {k}: the gap {least}, not {gap}"
        );
        assert!(
            (best - least).abs() <= 1e-9,
            "case {k}: {best} against {least}"
        );
    }
}

#[test]
fn a_ball_resting_on_a_ball_s_pole_is_one_vertex_pair() {
    // Fans of 32 and 64 slivers meet at the poles: 2 048 triangle pairs within 0.4 mm hold
    // one nearest feature pair, the two poles.
    let (tool, ball) = (ball_mesh(8.0, 32), ball_mesh(25.0, 64));
    let (ft, fb) = (MeshFeatures::new(&tool), MeshFeatures::new(&ball));
    let raised = Pose::from_array([0.0, 0.0, 33.1, 0.0, 0.0, 0.0]);
    let tool_placed = placed(&tool, &raised);
    let (found, least, within) = candidates(
        (&ft, &tool_placed, &raised),
        (&fb, &ball, &Pose::identity()),
        0.2,
    );
    assert!((least - 0.1).abs() < 1e-9);
    assert!(within >= 2_048, "{within} triangle pairs");
    let nearest: Vec<_> = found
        .values()
        .filter(|c| c.distance <= 0.1 + 1e-9)
        .collect();
    assert_eq!(nearest.len(), 1, "{nearest:?}");
    assert!(matches!(
        (nearest[0].a, nearest[0].b),
        (Feature::Vertex(_), Feature::Vertex(_))
    ));
    eprintln!("{} candidates of {within} triangle pairs", found.len());
    assert!(found.len() < within / 20, "{} candidates", found.len());
}

#[test]
fn edges_are_convex_flat_or_concave_as_their_faces_fold() {
    let kinds = |tris: &[Triangle]| {
        let m = MeshFeatures::new(tris);
        let (_, edges, _) = m.counts();
        let mut n = [0usize; 4];
        for e in 0..edges as u32 {
            n[match m.edge(e).kind {
                EdgeKind::Convex => 0,
                EdgeKind::Flat => 1,
                EdgeKind::Concave => 2,
                EdgeKind::Boundary => 3,
            }] += 1;
        }
        n
    };
    // A box: 12 convex edges, 6 flat diagonals.
    assert_eq!(kinds(&box_mesh([1.0, 2.0, 3.0])), [12, 6, 0, 0]);
    // The L prism: 17 convex edges (the caps' six sides twice, five of the six verticals),
    // one concave vertical, and the caps' flat fan edges and the sides' diagonals.
    let l = kinds(&l_prism(6.0));
    assert_eq!((l[0], l[2], l[3]), (17, 1, 0), "{l:?}");
    // An open mesh's rim: one triangle has three boundary edges.
    assert_eq!(kinds(&box_mesh([1.0; 3])[..1]), [0, 0, 0, 3]);
}

#[test]
fn a_triangle_without_area_stands_as_its_point_and_one_not_a_number_gives_nothing() {
    // Against a good triangle 0.1 mm below: a triangle shrunk to a point is that point over
    // the face; one with a corner that is not a number gives no candidate.
    let good = [[[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [0.0, 1.0, 0.0]]];
    let point = [[[0.0, 0.0, 0.1], [0.0, 0.0, 0.1], [0.0, 0.0, 0.1]]];
    let nan = [[[0.0, 0.0, 0.1], [f64::NAN, 0.0, 0.1], [0.0, 1.0, 0.1]]];
    let g = MeshFeatures::new(&good);
    let against = |bad: &[Triangle]| {
        let b = MeshFeatures::new(bad);
        let mut found = Vec::new();
        feature_contacts(
            PlacedFeatures {
                mesh: &b,
                points: b.points(),
            },
            0,
            PlacedFeatures {
                mesh: &g,
                points: g.points(),
            },
            0,
            1.0,
            0.0,
            |c| found.push(c),
        );
        found
    };
    let found = against(&point);
    assert!(!found.is_empty());
    for c in &found {
        assert_eq!((c.a, c.b), (Feature::Vertex(0), Feature::Face(0)), "{c:?}");
        assert!((c.distance - 0.1).abs() < 1e-12, "{c:?}");
    }
    assert_eq!(against(&nan), Vec::new());
}

#[test]
fn every_candidate_is_nearest_where_its_features_meet_their_neighbours() {
    // The culls: from a candidate's point on a vertex, no step along the vertex's edges, and
    // from a point inside an edge no step into its faces, comes nearer the other point.
    let shapes = [box_mesh([4.0, 3.0, 2.0]), ball_mesh(5.0, 12), l_prism(6.0)];
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut steps = 0;
    for a in &shapes {
        for b in &shapes {
            let (fa, fb) = (MeshFeatures::new(a), MeshFeatures::new(b));
            for _ in 0..60 {
                let pose = random_pose(&mut rng, 9.0);
                let a_placed = placed(a, &pose);
                let (found, least, _) =
                    candidates((&fa, &a_placed, &pose), (&fb, b, &Pose::identity()), 3.0);
                if least <= 1e-6 {
                    continue;
                }
                for c in found.values() {
                    for (feature, on, other, mesh, tris) in [
                        (c.a, c.on_a, c.on_b, &fa, a_placed.as_slice()),
                        (c.b, c.on_b, c.on_a, &fb, b.as_slice()),
                    ] {
                        let (p, o) = (V::from(on), V::from(other));
                        let corner = |v: u32| {
                            let (f, k) = (0..tris.len() as u32)
                                .flat_map(|f| (0..3).map(move |k| (f, k)))
                                .find(|&(f, k)| mesh.face(f)[k] == v)
                                .expect("a vertex of some face");
                            V::from(tris[f as usize][k])
                        };
                        let ways: Vec<V> = match feature {
                            Feature::Vertex(v) => {
                                mesh.neighbours(v).iter().map(|&w| corner(w) - p).collect()
                            }
                            Feature::Edge(e) => {
                                let edge = mesh.edge(e);
                                let [e0, e1] = edge.ends.map(corner);
                                let dir = (e1 - e0).normalize();
                                edge.faces
                                    .iter()
                                    .filter(|&&f| f != u32::MAX)
                                    .filter_map(|&f| {
                                        let third = mesh
                                            .face(f)
                                            .into_iter()
                                            .find(|v| !edge.ends.contains(v))?;
                                        let to = corner(third) - e0;
                                        Some(to - dir * to.dot(&dir))
                                    })
                                    .collect()
                            }
                            Feature::Face(_) => Vec::new(),
                        };
                        for way in ways {
                            let step = p + way.normalize() * 1e-4;
                            assert!(
                                (step - o).norm() >= c.distance - 1e-9,
                                "{c:?}: a step along {way:?} comes nearer"
                            );
                            steps += 1;
                        }
                    }
                }
            }
        }
    }
    assert!(steps > 600, "{steps} steps");
}
