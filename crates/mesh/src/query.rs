//! Geometric queries on a triangle mesh: closest point, unsigned and signed distance, and a
//! robust inside test, accelerated by a bounding-volume hierarchy over the triangles.
//!
//! Entry points:
//! - [`MeshQuery::new`] builds the hierarchy (offline, `O(n log n)`).
//! - [`MeshQuery::closest_point`], [`MeshQuery::distance`], [`MeshQuery::signed_distance`],
//!   [`MeshQuery::is_inside`].
//!
//! The sign comes from the angle-weighted pseudo-normal of the closest feature (face, edge or
//! vertex; Bærentzen & Aanæs 2005), which is exact for a closed, consistently oriented
//! 2-manifold such as the bundled bunny. On open or non-manifold meshes the sign is only a
//! local guess; check the mesh is closed first.
//!
//! Why our own hierarchy rather than parry's: it is ~200 lines, has no heavy dependency
//! (parry pulls in a large crate graph), works in f64 on our own [`TriMesh`], and gives us the
//! closest *feature*, which the pseudo-normal sign needs.

#![allow(clippy::needless_range_loop)] // xyz loops read better indexed

use crate::TriMesh;

/// Largest number of triangles in a hierarchy leaf.
const LEAF_SIZE: usize = 4;
/// Traversal stack depth; the median-split hierarchy of 2^32 triangles is 32 deep.
const STACK: usize = 64;

/// Which feature of the triangle the closest point lies on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Feature {
    /// Vertex `k` (0, 1 or 2) of the triangle.
    Vertex(u8),
    /// Edge from vertex `k` to vertex `(k + 1) % 3`.
    Edge(u8),
    /// The triangle's interior.
    Face,
}

/// The result of a closest-point query.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClosestPoint {
    /// The closest point on the surface (mesh units).
    pub point: [f64; 3],
    /// Euclidean distance from the query to `point` (mesh units).
    pub distance: f64,
    /// Index of the triangle in the input mesh.
    pub triangle: u32,
    /// The feature of that triangle where `point` lies.
    pub feature: Feature,
    /// Outward angle-weighted pseudo-normal of that feature (unit length).
    pub normal: [f64; 3],
}

#[derive(Clone, Copy, Debug)]
struct Node {
    lo: [f64; 3],
    hi: [f64; 3],
    /// Leaf: first index into `order`; inner: index of the left child (right = left + 1).
    first: u32,
    /// Leaf: number of triangles (> 0); inner: 0.
    count: u32,
}

#[derive(Clone, Copy, Debug)]
struct Tri {
    v: [[f64; 3]; 3],
    /// Index in the input mesh.
    id: u32,
    /// Unit face normal.
    n: [f64; 3],
    /// Pseudo-normals of the edges (k -> k+1).
    en: [[f64; 3]; 3],
    /// Pseudo-normals of the vertices.
    vn: [[f64; 3]; 3],
}

/// A triangle mesh prepared for distance queries (a bounding-volume hierarchy over its
/// non-degenerate triangles plus the pseudo-normals of every face, edge and vertex).
///
/// Offline only: built once, then queried from many threads (`Sync`).
#[derive(Clone, Debug)]
pub struct MeshQuery {
    tris: Vec<Tri>,
    nodes: Vec<Node>,
    skipped: usize,
}

impl MeshQuery {
    /// Builds the query structure for `mesh` (mesh units). Triangles with an out-of-range
    /// index or (near-)zero area are skipped and counted in [`MeshQuery::skipped`]. A mesh with
    /// no usable triangle gives a structure whose queries return `None` / `+inf` / `false`.
    pub fn new(mesh: &TriMesh) -> Self {
        let nv = mesh.vertices.len();
        let scale = mesh.aabb().map(|(lo, hi)| norm(sub(hi, lo))).unwrap_or(0.0);
        let area_eps = (scale * 1e-12).powi(2);

        // Usable triangles with their unit normals.
        let mut good: Vec<(u32, [u32; 3], [f64; 3])> = Vec::with_capacity(mesh.triangles.len());
        for (i, t) in mesh.triangles.iter().enumerate() {
            if t.iter().any(|&k| k as usize >= nv) {
                continue;
            }
            let [a, b, c] = t.map(|k| mesh.vertices[k as usize]);
            let cr = cross(sub(b, a), sub(c, a));
            let len = norm(cr);
            if len <= area_eps || !len.is_finite() {
                continue;
            }
            good.push((i as u32, *t, scale_v(cr, 1.0 / len)));
        }
        let skipped = mesh.triangles.len() - good.len();

        // Vertex pseudo-normals (angle-weighted) and edge pseudo-normals (sum of the faces).
        let mut vnorm = vec![[0.0; 3]; nv];
        let mut edges: std::collections::HashMap<(u32, u32), [f64; 3]> =
            std::collections::HashMap::with_capacity(good.len() * 2);
        for &(_, t, n) in &good {
            for k in 0..3 {
                let p = mesh.vertices[t[k] as usize];
                let q = mesh.vertices[t[(k + 1) % 3] as usize];
                let r = mesh.vertices[t[(k + 2) % 3] as usize];
                let angle = angle_between(sub(q, p), sub(r, p));
                vnorm[t[k] as usize] = add(vnorm[t[k] as usize], scale_v(n, angle));
                let key = (t[k].min(t[(k + 1) % 3]), t[k].max(t[(k + 1) % 3]));
                let e = edges.entry(key).or_insert([0.0; 3]);
                *e = add(*e, n);
            }
        }
        let tris: Vec<Tri> = good
            .iter()
            .map(|&(id, t, n)| {
                let v = t.map(|k| mesh.vertices[k as usize]);
                let mut en = [[0.0; 3]; 3];
                for (k, e) in en.iter_mut().enumerate() {
                    let key = (t[k].min(t[(k + 1) % 3]), t[k].max(t[(k + 1) % 3]));
                    *e = unit_or(edges[&key], n);
                }
                let vn = t.map(|k| unit_or(vnorm[k as usize], n));
                Tri { v, id, n, en, vn }
            })
            .collect();

        let mut q = MeshQuery {
            tris,
            nodes: Vec::new(),
            skipped,
        };
        q.build();
        q
    }

    /// Number of input triangles skipped (bad index or zero area).
    pub fn skipped(&self) -> usize {
        self.skipped
    }

    /// Number of triangles in the hierarchy.
    pub fn triangle_count(&self) -> usize {
        self.tris.len()
    }

    fn build(&mut self) {
        if self.tris.is_empty() {
            return;
        }
        let mut centroids: Vec<[f64; 3]> = self
            .tris
            .iter()
            .map(|t| scale_v(add(add(t.v[0], t.v[1]), t.v[2]), 1.0 / 3.0))
            .collect();
        let n = self.tris.len();
        self.nodes.reserve(2 * n / LEAF_SIZE + 1);
        self.nodes.push(Node {
            lo: [0.0; 3],
            hi: [0.0; 3],
            first: 0,
            count: 0,
        });
        // Iterative build: (node index, range start, range end).
        let mut work = vec![(0usize, 0usize, n)];
        while let Some((ni, s, e)) = work.pop() {
            let (lo, hi) = bounds(&self.tris[s..e]);
            self.nodes[ni].lo = lo;
            self.nodes[ni].hi = hi;
            if e - s <= LEAF_SIZE {
                self.nodes[ni].first = s as u32;
                self.nodes[ni].count = (e - s) as u32;
                continue;
            }
            // Split at the median centroid along the longest axis of the centroid bounds.
            let (clo, chi) = point_bounds(&centroids[s..e]);
            let ext = sub(chi, clo);
            let axis = if ext[0] >= ext[1] && ext[0] >= ext[2] {
                0
            } else if ext[1] >= ext[2] {
                1
            } else {
                2
            };
            let mid = (s + e) / 2;
            let mut idx: Vec<usize> = (s..e).collect();
            idx.select_nth_unstable_by(mid - s, |&a, &b| {
                centroids[a][axis].total_cmp(&centroids[b][axis])
            });
            let tri_part: Vec<Tri> = idx.iter().map(|&i| self.tris[i]).collect();
            let cen_part: Vec<[f64; 3]> = idx.iter().map(|&i| centroids[i]).collect();
            self.tris[s..e].copy_from_slice(&tri_part);
            centroids[s..e].copy_from_slice(&cen_part);
            let left = self.nodes.len();
            for _ in 0..2 {
                self.nodes.push(Node {
                    lo: [0.0; 3],
                    hi: [0.0; 3],
                    first: 0,
                    count: 0,
                });
            }
            self.nodes[ni].first = left as u32;
            self.nodes[ni].count = 0;
            work.push((left, s, mid));
            work.push((left + 1, mid, e));
        }
    }

    /// The closest point of the surface to `p` (mesh units), with its triangle, feature and
    /// outward pseudo-normal; `None` for a mesh without usable triangles.
    pub fn closest_point(&self, p: [f64; 3]) -> Option<ClosestPoint> {
        self.closest_within(p, f64::INFINITY)
    }

    /// Like [`MeshQuery::closest_point`] but only searches within `max_dist` of `p`; `None`
    /// when no surface point is that close.
    pub fn closest_within(&self, p: [f64; 3], max_dist: f64) -> Option<ClosestPoint> {
        if self.nodes.is_empty() {
            return None;
        }
        let mut best_d2 = if max_dist.is_finite() {
            max_dist * max_dist
        } else {
            f64::INFINITY
        };
        let mut best: Option<(usize, [f64; 3], Feature)> = None;
        let mut stack = [0u32; STACK];
        let mut sp = 0usize;
        if box_dist2(&self.nodes[0], p) <= best_d2 {
            stack[0] = 0;
            sp = 1;
        }
        while sp > 0 {
            sp -= 1;
            let node = &self.nodes[stack[sp] as usize];
            if box_dist2(node, p) > best_d2 {
                continue;
            }
            if node.count > 0 {
                let s = node.first as usize;
                for (i, t) in self.tris[s..s + node.count as usize].iter().enumerate() {
                    let (q, f) = closest_on_triangle(p, &t.v);
                    let d2 = norm2(sub(p, q));
                    if d2 < best_d2 || (best.is_none() && d2 <= best_d2) {
                        best_d2 = d2;
                        best = Some((s + i, q, f));
                    }
                }
            } else {
                let l = node.first as usize;
                let dl = box_dist2(&self.nodes[l], p);
                let dr = box_dist2(&self.nodes[l + 1], p);
                // Push the farther child first so the nearer one is visited first.
                let (near, far, dn, df) = if dl <= dr {
                    (l, l + 1, dl, dr)
                } else {
                    (l + 1, l, dr, dl)
                };
                if df <= best_d2 && sp < STACK {
                    stack[sp] = far as u32;
                    sp += 1;
                }
                if dn <= best_d2 && sp < STACK {
                    stack[sp] = near as u32;
                    sp += 1;
                }
            }
        }
        let (ti, q, f) = best?;
        let t = &self.tris[ti];
        let normal = match f {
            Feature::Face => t.n,
            Feature::Edge(k) => t.en[k as usize],
            Feature::Vertex(k) => t.vn[k as usize],
        };
        Some(ClosestPoint {
            point: q,
            distance: best_d2.sqrt(),
            triangle: t.id,
            feature: f,
            normal,
        })
    }

    /// Unsigned distance from `p` to the surface (mesh units); `+inf` without triangles.
    pub fn distance(&self, p: [f64; 3]) -> f64 {
        self.closest_point(p).map_or(f64::INFINITY, |c| c.distance)
    }

    /// Signed distance from `p` to the surface (mesh units): negative inside the closed mesh,
    /// positive outside; `+inf` without triangles.
    pub fn signed_distance(&self, p: [f64; 3]) -> f64 {
        match self.closest_point(p) {
            Some(c) => {
                if dot(sub(p, c.point), c.normal) < 0.0 {
                    -c.distance
                } else {
                    c.distance
                }
            }
            None => f64::INFINITY,
        }
    }

    /// True when `p` is strictly inside the closed mesh (points on the surface count as
    /// outside).
    pub fn is_inside(&self, p: [f64; 3]) -> bool {
        self.signed_distance(p) < 0.0
    }
}

fn bounds(tris: &[Tri]) -> ([f64; 3], [f64; 3]) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for t in tris {
        for v in &t.v {
            for k in 0..3 {
                lo[k] = lo[k].min(v[k]);
                hi[k] = hi[k].max(v[k]);
            }
        }
    }
    (lo, hi)
}

fn point_bounds(ps: &[[f64; 3]]) -> ([f64; 3], [f64; 3]) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for v in ps {
        for k in 0..3 {
            lo[k] = lo[k].min(v[k]);
            hi[k] = hi[k].max(v[k]);
        }
    }
    (lo, hi)
}

#[inline]
fn box_dist2(n: &Node, p: [f64; 3]) -> f64 {
    let mut d2 = 0.0;
    for k in 0..3 {
        let d = (n.lo[k] - p[k]).max(0.0).max(p[k] - n.hi[k]);
        d2 += d * d;
    }
    d2
}

/// Closest point on triangle `v` to `p` and the feature it lies on (Ericson, Real-Time
/// Collision Detection, 5.1.5: Voronoi regions tested in order).
fn closest_on_triangle(p: [f64; 3], v: &[[f64; 3]; 3]) -> ([f64; 3], Feature) {
    let [a, b, c] = *v;
    let ab = sub(b, a);
    let ac = sub(c, a);
    let ap = sub(p, a);
    let d1 = dot(ab, ap);
    let d2 = dot(ac, ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return (a, Feature::Vertex(0));
    }
    let bp = sub(p, b);
    let d3 = dot(ab, bp);
    let d4 = dot(ac, bp);
    if d3 >= 0.0 && d4 <= d3 {
        return (b, Feature::Vertex(1));
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let t = d1 / (d1 - d3);
        return (add(a, scale_v(ab, t)), Feature::Edge(0));
    }
    let cp = sub(p, c);
    let d5 = dot(ab, cp);
    let d6 = dot(ac, cp);
    if d6 >= 0.0 && d5 <= d6 {
        return (c, Feature::Vertex(2));
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let t = d2 / (d2 - d6);
        return (add(a, scale_v(ac, t)), Feature::Edge(2));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (add(b, scale_v(sub(c, b), t)), Feature::Edge(1));
    }
    let denom = 1.0 / (va + vb + vc);
    let s = vb * denom;
    let t = vc * denom;
    (add(a, add(scale_v(ab, s), scale_v(ac, t))), Feature::Face)
}

#[inline]
pub(crate) fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
#[inline]
pub(crate) fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
#[inline]
pub(crate) fn scale_v(a: [f64; 3], s: f64) -> [f64; 3] {
    [a[0] * s, a[1] * s, a[2] * s]
}
#[inline]
pub(crate) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
#[inline]
pub(crate) fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
#[inline]
fn norm2(a: [f64; 3]) -> f64 {
    dot(a, a)
}
#[inline]
pub(crate) fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}
fn unit_or(a: [f64; 3], fallback: [f64; 3]) -> [f64; 3] {
    let l = norm(a);
    if l > 0.0 && l.is_finite() {
        scale_v(a, 1.0 / l)
    } else {
        fallback
    }
}
fn angle_between(a: [f64; 3], b: [f64; 3]) -> f64 {
    norm(cross(a, b)).atan2(dot(a, b))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An axis-aligned cube `[-1, 1]^3`, counter-clockwise from outside.
    pub(crate) fn cube() -> TriMesh {
        let vertices = vec![
            [-1.0, -1.0, -1.0],
            [1.0, -1.0, -1.0],
            [1.0, 1.0, -1.0],
            [-1.0, 1.0, -1.0],
            [-1.0, -1.0, 1.0],
            [1.0, -1.0, 1.0],
            [1.0, 1.0, 1.0],
            [-1.0, 1.0, 1.0],
        ];
        let triangles = vec![
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
        ];
        TriMesh {
            vertices,
            triangles,
        }
    }

    /// Exact signed distance to the cube `[-1, 1]^3`.
    fn cube_sdf(p: [f64; 3]) -> f64 {
        let q = p.map(|x| x.abs() - 1.0);
        let outside = norm(q.map(|x| x.max(0.0)));
        let inside = q[0].max(q[1]).max(q[2]).min(0.0);
        outside + inside
    }

    #[test]
    fn signed_distance_matches_the_analytic_cube() {
        let q = MeshQuery::new(&cube());
        assert_eq!(q.triangle_count(), 12);
        let mut state = 12345u64;
        let mut rnd = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64) * 6.0 - 3.0
        };
        for _ in 0..5000 {
            let p = [rnd(), rnd(), rnd()];
            let got = q.signed_distance(p);
            let want = cube_sdf(p);
            assert!((got - want).abs() < 1e-9, "{p:?}: got {got}, want {want}");
            assert_eq!(q.is_inside(p), want < 0.0);
        }
    }

    #[test]
    fn corner_and_edge_regions_get_the_right_sign() {
        let q = MeshQuery::new(&cube());
        // Just outside a corner and an edge, where face normals alone would disagree.
        assert!(q.signed_distance([1.01, 1.01, 1.01]) > 0.0);
        assert!(q.signed_distance([1.01, 1.01, 0.3]) > 0.0);
        assert!(q.signed_distance([0.99, 0.99, 0.99]) < 0.0);
        let c = q.closest_point([2.0, 2.0, 2.0]).unwrap();
        assert!(matches!(c.feature, Feature::Vertex(_)));
        assert!((c.distance - 3f64.sqrt()).abs() < 1e-12);
        assert!(q.closest_within([3.0, 0.0, 0.0], 1.5).is_none());
        assert!(q.closest_within([3.0, 0.0, 0.0], 2.5).is_some());
    }

    #[test]
    fn degenerate_and_bad_triangles_are_skipped() {
        let mut m = cube();
        m.triangles.push([0, 0, 1]);
        m.triangles.push([0, 1, 99]);
        let q = MeshQuery::new(&m);
        assert_eq!(q.skipped(), 2);
        assert!(q.is_inside([0.0, 0.0, 0.0]));
        let empty = MeshQuery::new(&TriMesh::default());
        assert!(empty.closest_point([0.0; 3]).is_none());
        assert!(!empty.is_inside([0.0; 3]));
    }

    /// Solid-angle winding number of a closed mesh around `p` (1 inside, 0 outside).
    fn winding(m: &TriMesh, p: [f64; 3]) -> f64 {
        let mut total = 0.0;
        for t in &m.triangles {
            let [a, b, c] = t.map(|k| sub(m.vertices[k as usize], p));
            let (la, lb, lc) = (norm(a), norm(b), norm(c));
            let num = dot(a, cross(b, c));
            let den = la * lb * lc + dot(a, b) * lc + dot(b, c) * la + dot(c, a) * lb;
            total += 2.0 * num.atan2(den);
        }
        total / (4.0 * std::f64::consts::PI)
    }

    #[test]
    fn bunny_sign_and_distance_match_brute_force() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/bunny.obj");
        let m = crate::load_mesh(&path).unwrap().mesh;
        let q = MeshQuery::new(&m);
        assert_eq!(q.skipped(), 0);
        let (lo, hi) = m.aabb().unwrap();
        let mut state = 99u64;
        let mut rnd = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut inside = 0;
        for _ in 0..300 {
            let p: [f64; 3] =
                std::array::from_fn(|k| lo[k] + (hi[k] - lo[k]) * (1.2 * rnd() - 0.1));
            let w = winding(&m, p);
            let got = q.signed_distance(p);
            assert_eq!(got < 0.0, w > 0.5, "{p:?}: sd {got}, winding {w}");
            inside += usize::from(w > 0.5);
            // Brute-force unsigned distance.
            let brute = m
                .triangles
                .iter()
                .map(|t| {
                    let v = t.map(|k| m.vertices[k as usize]);
                    norm(sub(p, closest_on_triangle(p, &v).0))
                })
                .fold(f64::INFINITY, f64::min);
            assert!((got.abs() - brute).abs() < 1e-12, "{p:?}: {got} vs {brute}");
        }
        assert!(inside > 30, "the sample reaches inside ({inside})");
    }
}
