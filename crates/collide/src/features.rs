//! Mesh features: a triangle mesh's vertices, edges and faces with their topology, and the
//! pairs of features of two meshes that can hold their nearest points (docs/design-notes.md
//! §Toward feature-level pairs).
//!
//! A triangle pair's distance is the least of fifteen feature distances (its six corners over
//! the other's face, its nine edge pairs); a mesh's vertex is in some six triangles and an edge
//! in two, so a contact of many triangle pairs holds each feature pair many times (the ball on
//! a ball's pole: 2 048 triangle pairs, one vertex pair). [`FeatureContacts`] names each
//! candidate by its features, so that a caller keeps each once, and culls those that cannot be
//! nearest: a vertex counts against a face only over the face's inside and in front of it,
//! against an edge only within the edge's outward wedge, against a vertex only within each
//! other's cone; two edges only where both are convex and their nearest points are inside
//! both. A flat or concave edge is never needed: where it holds the nearest points, so does a
//! face. Over the triangle pairs of two meshes that do not meet, the least distance of the
//! candidates is the meshes' distance.

use std::collections::HashMap;

use nalgebra::Vector3;

use crate::pose::Pose;
use crate::triangle::Triangle;

type V = Vector3<f64>;

/// How far (mm) a point may stand outside a feature's region and still count as in it: the
/// regions are closed, so that a point on their common border (the meshes' nearest points
/// there) counts in each, and roundings do not drop it from all.
pub const FEATURE_SLACK_MM: f64 = 1e-9;

/// A mesh feature, by its index in [`MeshFeatures`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Feature {
    /// A vertex.
    Vertex(u32),
    /// An edge.
    Edge(u32),
    /// A face (a triangle).
    Face(u32),
}

/// What an edge is between its faces.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EdgeKind {
    /// The faces meet at an outward fold: the edge can hold a nearest point of its own.
    Convex,
    /// The faces lie in one plane (within [`FEATURE_SLACK_MM`]).
    Flat,
    /// The faces meet at an inward fold: its faces hold whatever it would.
    Concave,
    /// One face only (an open mesh's rim), or more than two: taken as convex.
    Boundary,
}

/// An edge: its two vertices (the lower index first), the faces it borders (the second
/// `u32::MAX` at a boundary) and its kind.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Edge {
    /// Its ends (vertex indices, the lower first).
    pub ends: [u32; 2],
    /// The faces on either side (`u32::MAX` for none).
    pub faces: [u32; 2],
    /// Convex, flat, concave or a boundary.
    pub kind: EdgeKind,
}

impl Edge {
    /// Whether the edge may hold nearest points of its own (convex or a boundary).
    pub fn can_be_nearest(&self) -> bool {
        matches!(self.kind, EdgeKind::Convex | EdgeKind::Boundary)
    }
}

/// A triangle mesh's features: its vertices (corners equal bit for bit are one), its faces
/// (the triangles, counter-clockwise seen from outside), its edges and each vertex's
/// neighbours. Built once (allocates); read without allocating. A triangle without area stands
/// as its points and edges, one with a corner that is not a number gives no candidates;
/// indices out of range are the caller's to check (they panic).
#[derive(Clone, Debug)]
pub struct MeshFeatures {
    points: Vec<[f64; 3]>,
    faces: Vec<[u32; 3]>,
    /// Face `f`'s edge `k` runs from its corner `k` to corner `k + 1`.
    face_edges: Vec<[u32; 3]>,
    edges: Vec<Edge>,
    /// Vertex `v`'s neighbours are `neighbours[first[v]..first[v + 1]]`.
    first: Vec<u32>,
    neighbours: Vec<u32>,
}

impl MeshFeatures {
    /// The features of `triangles` (mm, counter-clockwise seen from outside).
    pub fn new(triangles: &[Triangle]) -> Self {
        let mut ids: HashMap<[u64; 3], u32> = HashMap::new();
        let mut points = Vec::new();
        let faces: Vec<[u32; 3]> = triangles
            .iter()
            .map(|t| {
                t.map(|p| {
                    *ids.entry(p.map(f64::to_bits)).or_insert_with(|| {
                        points.push(p);
                        (points.len() - 1) as u32
                    })
                })
            })
            .collect();
        let mut edge_of: HashMap<(u32, u32), u32> = HashMap::new();
        let mut edges: Vec<Edge> = Vec::new();
        let mut face_edges = vec![[0u32; 3]; faces.len()];
        let mut crowded = Vec::new();
        for (f, corners) in faces.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (corners[k], corners[(k + 1) % 3]);
                let key = (a.min(b), a.max(b));
                let e = *edge_of.entry(key).or_insert_with(|| {
                    edges.push(Edge {
                        ends: [key.0, key.1],
                        faces: [f as u32, u32::MAX],
                        kind: EdgeKind::Boundary,
                    });
                    (edges.len() - 1) as u32
                });
                let edge = &mut edges[e as usize];
                if edge.faces[0] != f as u32 {
                    if edge.faces[1] == u32::MAX {
                        edge.faces[1] = f as u32;
                    } else {
                        crowded.push(e);
                    }
                }
                face_edges[f][k] = e;
            }
        }
        let mut mesh = Self {
            points,
            faces,
            face_edges,
            edges,
            first: Vec::new(),
            neighbours: Vec::new(),
        };
        for e in 0..mesh.edges.len() {
            let kind = mesh.kind_of(e);
            mesh.edges[e].kind = kind;
        }
        for e in crowded {
            mesh.edges[e as usize].kind = EdgeKind::Boundary;
        }
        let mut lists = vec![Vec::new(); mesh.points.len()];
        for edge in &mesh.edges {
            lists[edge.ends[0] as usize].push(edge.ends[1]);
            lists[edge.ends[1] as usize].push(edge.ends[0]);
        }
        mesh.first.push(0);
        for list in lists {
            mesh.neighbours.extend(list);
            mesh.first.push(mesh.neighbours.len() as u32);
        }
        mesh
    }

    fn kind_of(&self, e: usize) -> EdgeKind {
        let edge = &self.edges[e];
        if edge.faces[1] == u32::MAX {
            return EdgeKind::Boundary;
        }
        let (n, d) = face_plane(&self.faces[edge.faces[0] as usize].map(|v| self.point(v)));
        let far = self.faces[edge.faces[1] as usize]
            .into_iter()
            .find(|v| !edge.ends.contains(v))
            .map_or(0.0, |v| n.dot(&self.point(v)) - d);
        if far < -FEATURE_SLACK_MM {
            EdgeKind::Convex
        } else if far > FEATURE_SLACK_MM {
            EdgeKind::Concave
        } else {
            EdgeKind::Flat
        }
    }

    fn point(&self, v: u32) -> V {
        V::from(self.points[v as usize])
    }

    /// The vertices (mesh frame, mm).
    pub fn points(&self) -> &[[f64; 3]] {
        &self.points
    }

    /// Face `f`'s corners (vertex indices, counter-clockwise seen from outside).
    pub fn face(&self, f: u32) -> [u32; 3] {
        self.faces[f as usize]
    }

    /// Face `f`'s edges: edge `k` runs from its corner `k` to corner `k + 1`.
    pub fn face_edges(&self, f: u32) -> [u32; 3] {
        self.face_edges[f as usize]
    }

    /// Edge `e`.
    pub fn edge(&self, e: u32) -> &Edge {
        &self.edges[e as usize]
    }

    /// Vertex `v`'s neighbours (the other ends of its edges).
    pub fn neighbours(&self, v: u32) -> &[u32] {
        let (a, b) = (self.first[v as usize], self.first[v as usize + 1]);
        &self.neighbours[a as usize..b as usize]
    }

    /// Its vertices placed by `pose` (world `= R p + t`, mm) into `out`, cleared first (it
    /// allocates only where `out` has too little room).
    pub fn place(&self, pose: &Pose, out: &mut Vec<[f64; 3]>) {
        let (rot, t) = (pose.rotation_matrix(), pose.translation());
        out.clear();
        out.extend(
            self.points
                .iter()
                .map(|p| -> [f64; 3] { (rot * V::from(*p) + t).into() }),
        );
    }

    /// How many faces, edges and vertices.
    pub fn counts(&self) -> (usize, usize, usize) {
        (self.faces.len(), self.edges.len(), self.points.len())
    }
}

/// A mesh's features placed: its topology and its vertices where they are (world, mm).
#[derive(Clone, Copy)]
pub struct PlacedFeatures<'a> {
    /// The mesh's features.
    pub mesh: &'a MeshFeatures,
    /// Its vertices placed (world, mm), in [`MeshFeatures::points`]' order.
    pub points: &'a [[f64; 3]],
}

impl PlacedFeatures<'_> {
    fn at(&self, v: u32) -> V {
        V::from(self.points[v as usize])
    }

    fn corners(&self, f: u32) -> [V; 3] {
        self.mesh.face(f).map(|v| self.at(v))
    }
}

/// A candidate pair of nearest features, one of each mesh: the features, their distance (mm)
/// and the nearest point on each (world, mm).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FeatureContact {
    /// The first mesh's feature.
    pub a: Feature,
    /// The second mesh's feature.
    pub b: Feature,
    /// Their distance, mm.
    pub distance: f64,
    /// The nearest point on the first mesh's feature (world, mm).
    pub on_a: [f64; 3],
    /// The nearest point on the second mesh's feature (world, mm).
    pub on_b: [f64; 3],
}

/// The candidate nearest feature pairs of face `i` of `a` and face `j` of `b` within `reach`
/// (mm), each given to `visit` (a feature pair shared by several face pairs is given once for
/// each: the caller keeps it once, by its features). A pair counts where its points stand
/// within `slack` (mm, at least [`FEATURE_SLACK_MM`]) of its features' regions: the pairs that
/// may become nearest while the meshes move by up to that much. Allocates nothing.
pub fn feature_contacts(
    a: PlacedFeatures<'_>,
    i: u32,
    b: PlacedFeatures<'_>,
    j: u32,
    reach: f64,
    slack: f64,
    mut visit: impl FnMut(FeatureContact),
) {
    let slack = slack.max(FEATURE_SLACK_MM);
    let mut give = |fa: Feature, fb: Feature, pa: V, pb: V, swap: bool| {
        let distance = (pa - pb).norm();
        if distance <= reach {
            let (a, b, on_a, on_b) = if swap {
                (fb, fa, pb, pa)
            } else {
                (fa, fb, pa, pb)
            };
            visit(FeatureContact {
                a,
                b,
                distance,
                on_a: on_a.into(),
                on_b: on_b.into(),
            });
        }
    };
    for (x, f, y, g, swap) in [(a, i, b, j, false), (b, j, a, i, true)] {
        // x's corners over y's face, and against its convex edges and its corners.
        let face = y.corners(g);
        let (n, d) = face_plane(&face);
        for v in x.mesh.face(f) {
            let p = x.at(v);
            let h = n.dot(&p) - d;
            let foot = p - n * h;
            // Over the inside, in front, and the lowest of its corner toward the face.
            if h >= -slack && over_inside(&p, &face, &n, slack) && in_cone(&foot, x, v, slack) {
                give(Feature::Vertex(v), Feature::Face(g), p, foot, swap);
            }
            for e in y.mesh.face_edges(g) {
                let edge = y.mesh.edge(e);
                if !edge.can_be_nearest() {
                    continue;
                }
                if let Some(q) = nearest_inside_edge(&p, y, edge, slack) {
                    if in_wedge(&(p - q), y, edge, slack) && in_cone(&q, x, v, slack) {
                        give(Feature::Vertex(v), Feature::Edge(e), p, q, swap);
                    }
                }
            }
            if !swap {
                // Corner pairs once: each within the other's cone.
                for w in y.mesh.face(g) {
                    let o = y.at(w);
                    if in_cone(&o, x, v, slack) && in_cone(&p, y, w, slack) {
                        give(Feature::Vertex(v), Feature::Vertex(w), p, o, false);
                    }
                }
            }
        }
    }
    for ea in a.mesh.face_edges(i) {
        let edge_a = a.mesh.edge(ea);
        if !edge_a.can_be_nearest() {
            continue;
        }
        let (a0, a1) = (a.at(edge_a.ends[0]), a.at(edge_a.ends[1]));
        for eb in b.mesh.face_edges(j) {
            let edge_b = b.mesh.edge(eb);
            if !edge_b.can_be_nearest() {
                continue;
            }
            let (b0, b1) = (b.at(edge_b.ends[0]), b.at(edge_b.ends[1]));
            if let Some((pa, pb)) = inside_nearest(&a0, &a1, &b0, &b1, slack) {
                if in_wedge(&(pb - pa), a, edge_a, slack) && in_wedge(&(pa - pb), b, edge_b, slack)
                {
                    give(Feature::Edge(ea), Feature::Edge(eb), pa, pb, false);
                }
            }
        }
    }
}

/// The unit normal and offset of the plane through `t` (counter-clockwise seen from outside).
fn face_plane(t: &[V; 3]) -> (V, f64) {
    let n = (t[1] - t[0]).cross(&(t[2] - t[0]));
    let n = n / n.norm().max(f64::MIN_POSITIVE);
    (n, n.dot(&t[0]))
}

/// Whether `p` stands over the inside of the triangle `t` (normal `n`): within each edge's
/// inward side, by `slack` (mm).
fn over_inside(p: &V, t: &[V; 3], n: &V, slack: f64) -> bool {
    (0..3).all(|k| {
        let (s, e) = (t[k], t[(k + 1) % 3]);
        let inward = n.cross(&(e - s));
        let len = inward.norm();
        len > 0.0 && inward.dot(&(p - s)) >= -slack * len
    })
}

/// The point of `edge` nearest `p` where that is inside the edge (by `slack`, mm); else
/// `None`.
fn nearest_inside_edge(p: &V, mesh: PlacedFeatures<'_>, edge: &Edge, slack: f64) -> Option<V> {
    let (e0, e1) = (mesh.at(edge.ends[0]), mesh.at(edge.ends[1]));
    let dir = e1 - e0;
    let len2 = dir.norm_squared();
    if len2 <= 0.0 {
        return None;
    }
    let s = (p - e0).dot(&dir) / len2;
    let slack = slack / len2.sqrt();
    (s >= -slack && s <= 1.0 + slack).then(|| e0 + dir * s.clamp(0.0, 1.0))
}

/// Whether the way `out` from a point of `edge` stands in the edge's outward wedge: over
/// neither face's inside (no part of it along either face, away from the edge, past `slack`
/// mm).
fn in_wedge(out: &V, mesh: PlacedFeatures<'_>, edge: &Edge, slack: f64) -> bool {
    let e0 = mesh.at(edge.ends[0]);
    let dir = mesh.at(edge.ends[1]) - e0;
    let len2 = dir.norm_squared();
    edge.faces.iter().all(|&f| {
        if f == u32::MAX || len2 <= 0.0 {
            return true;
        }
        // Along the face, away from the edge: toward its third corner, square to the edge.
        let Some(third) = mesh
            .mesh
            .face(f)
            .into_iter()
            .find(|v| !edge.ends.contains(v))
        else {
            return true;
        };
        let to = mesh.at(third) - e0;
        let across = to - dir * (to.dot(&dir) / len2);
        out.dot(&across) <= slack * across.norm()
    })
}

/// Whether `p` stands in vertex `v`'s cone: no nearer to any of its edges' insides than to
/// `v` (the way from `v` to `p` has no part along any edge, past `slack` mm).
fn in_cone(p: &V, mesh: PlacedFeatures<'_>, v: u32, slack: f64) -> bool {
    let o = mesh.at(v);
    mesh.mesh.neighbours(v).iter().all(|&w| {
        let along = mesh.at(w) - o;
        (p - o).dot(&along) <= slack * along.norm()
    })
}

/// The nearest points of the segments `a0 a1` and `b0 b1` where both are inside their
/// segments (by `slack`, mm) and the segments are not parallel; else `None`.
fn inside_nearest(a0: &V, a1: &V, b0: &V, b1: &V, slack: f64) -> Option<(V, V)> {
    let (u, v, w) = (a1 - a0, b1 - b0, a0 - b0);
    let (uu, vv, uv) = (u.dot(&u), v.dot(&v), u.dot(&v));
    let (uw, vw) = (u.dot(&w), v.dot(&w));
    let den = uu * vv - uv * uv;
    if den <= 1e-12 * uu * vv {
        // Parallel: their nearest points include an end, which the corners' pairs hold.
        return None;
    }
    let s = (uv * vw - vv * uw) / den;
    let t = (uu * vw - uv * uw) / den;
    let (sa, sb) = (
        slack / uu.sqrt().max(f64::MIN_POSITIVE),
        slack / vv.sqrt().max(f64::MIN_POSITIVE),
    );
    let inside = |x: f64, slack: f64| x > -slack && x < 1.0 + slack;
    (inside(s, sa) && inside(t, sb))
        .then(|| (a0 + u * s.clamp(0.0, 1.0), b0 + v * t.clamp(0.0, 1.0)))
}
