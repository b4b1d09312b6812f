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

pub(crate) use crate::vec3::{add, cross, dot, norm, norm2, scale as scale_v, sub};
use crate::TriMesh;
use std::sync::atomic::{AtomicU64, Ordering};

/// Largest number of triangles in a hierarchy leaf.
const LEAF_SIZE: usize = 4;
/// Traversal stack depth; the median-split hierarchy of 2^32 triangles is 32 deep.
const STACK: usize = 64;

/// Work of every [`MeshQuery`] of this process: hierarchy nodes visited plus triangles tested
/// (or solid angles taken) by its closest-point and winding-number queries.
static QUERY_WORK: AtomicU64 = AtomicU64::new(0);

/// Hierarchy nodes visited plus triangles tested by every [`MeshQuery`] query of this process
/// so far (all threads): a count of the queries' cost that does not depend on the machine, so
/// that tests can check how a builder's cost grows with the mesh without timing it.
pub fn query_work() -> u64 {
    QUERY_WORK.load(Ordering::Relaxed)
}

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
    /// Per node, the far-field expansion of its triangles' winding number.
    dipoles: Vec<Dipole>,
    skipped: usize,
    inside: InsideTest,
}

/// How [`MeshQuery::signed_distance`] and [`MeshQuery::is_inside`] tell inside from outside.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum InsideTest {
    /// The angle-weighted pseudo-normal of the closest feature (Bærentzen & Aanæs 2005):
    /// exact and cheap on a closed, consistently oriented 2-manifold whose parts do not pass
    /// through each other; only a local guess elsewhere.
    #[default]
    PseudoNormal,
    /// The generalised winding number (Jacobson et al. 2013) at least 1/2: the solid angle
    /// the surface subtends, summed over the triangles (far clusters by their dipole, as in
    /// Barill et al. 2018). Robust on open, holed, non-manifold and self-intersecting meshes;
    /// several times slower.
    WindingNumber,
}

impl InsideTest {
    /// The test suited to `mesh`: [`InsideTest::PseudoNormal`] when it is closed and
    /// consistently oriented ([`TriMesh::check_closed`]), else [`InsideTest::WindingNumber`].
    pub fn for_mesh(mesh: &TriMesh) -> Self {
        if mesh.check_closed().is_ok() {
            InsideTest::PseudoNormal
        } else {
            InsideTest::WindingNumber
        }
    }

    /// A short name for reports (`pseudo-normal`, `winding-number`).
    pub fn name(self) -> &'static str {
        match self {
            InsideTest::PseudoNormal => "pseudo-normal",
            InsideTest::WindingNumber => "winding-number",
        }
    }
}

/// Far-field expansion of a cluster of triangles: seen from farther than `BETA · radius` from
/// `centre`, their solid angle is that of a dipole `area_normal` at `centre`.
#[derive(Clone, Copy, Debug, Default)]
struct Dipole {
    /// Area-weighted centroid of the triangles.
    centre: [f64; 3],
    /// Sum of the triangles' vector areas (half the cross products; outward).
    area_normal: [f64; 3],
    /// Largest distance from `centre` to a vertex of the cluster.
    radius: f64,
}

/// Clusters farther than this many radii use their dipole (error a few 0.1 % of the
/// cluster's own solid angle, far below the 1/2 threshold).
const BETA: f64 = 2.5;

impl MeshQuery {
    /// Builds the query structure for `mesh` (mesh units). Triangles with an out-of-range
    /// index or (near-)zero area are skipped and counted in [`MeshQuery::skipped`]. A mesh with
    /// no usable triangle gives a structure whose queries return `None` / `+inf` / `false`.
    pub fn new(mesh: &TriMesh) -> Self {
        Self::with_progress(mesh, InsideTest::PseudoNormal, &|_| {})
    }

    /// [`MeshQuery::with_inside_test`], calling `progress` with the completed fraction
    /// (`0..=1`) as it goes: a few seconds for millions of triangles.
    pub fn with_progress(mesh: &TriMesh, inside: InsideTest, progress: &dyn Fn(f64)) -> Self {
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
        progress(0.1);

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
        progress(0.3);
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
            dipoles: Vec::new(),
            skipped,
            inside,
        };
        progress(0.4);
        q.build(&|f| progress(0.4 + 0.55 * f));
        q.build_dipoles();
        progress(1.0);
        q
    }

    /// [`MeshQuery::new`] with the given inside test for [`MeshQuery::signed_distance`] and
    /// [`MeshQuery::is_inside`].
    pub fn with_inside_test(mesh: &TriMesh, inside: InsideTest) -> Self {
        Self::with_progress(mesh, inside, &|_| {})
    }

    /// The inside test in use.
    pub fn inside_test(&self) -> InsideTest {
        self.inside
    }

    /// Fills `dipoles` bottom-up (children always come after their parent in `nodes`).
    fn build_dipoles(&mut self) {
        let mut d = vec![Dipole::default(); self.nodes.len()];
        for i in (0..self.nodes.len()).rev() {
            let node = self.nodes[i];
            let (centre, area_normal, area) = if node.count > 0 {
                let s = node.first as usize;
                let mut c = [0.0; 3];
                let mut an = [0.0; 3];
                let mut area = 0.0;
                for t in &self.tris[s..s + node.count as usize] {
                    let vec_area = scale_v(cross(sub(t.v[1], t.v[0]), sub(t.v[2], t.v[0])), 0.5);
                    let a = norm(vec_area);
                    let centroid = scale_v(add(add(t.v[0], t.v[1]), t.v[2]), 1.0 / 3.0);
                    c = add(c, scale_v(centroid, a));
                    an = add(an, vec_area);
                    area += a;
                }
                (c, an, area)
            } else {
                let (l, r) = (node.first as usize, node.first as usize + 1);
                let (al, ar) = (d[l].radius, d[r].radius); // areas, stashed in `radius` below
                (
                    add(scale_v(d[l].centre, al), scale_v(d[r].centre, ar)),
                    add(d[l].area_normal, d[r].area_normal),
                    al + ar,
                )
            };
            let centre = if area > 0.0 {
                scale_v(centre, 1.0 / area)
            } else {
                scale_v(add(node.lo, node.hi), 0.5)
            };
            // The area is kept in `radius` until the parent has read it (second pass below).
            d[i] = Dipole {
                centre,
                area_normal,
                radius: area,
            };
        }
        // Radius: the farthest box corner bounds the farthest vertex.
        for (i, node) in self.nodes.iter().enumerate() {
            let c = d[i].centre;
            let far: [f64; 3] =
                std::array::from_fn(|k| (c[k] - node.lo[k]).abs().max((node.hi[k] - c[k]).abs()));
            d[i].radius = norm(far);
        }
        self.dipoles = d;
    }

    /// The generalised winding number of the surface around `p` (mesh units): 1 inside and 0
    /// outside a closed, outward-oriented mesh, 2 where two closed parts overlap, in between
    /// near the holes of an open one. Exact solid angles for nearby triangles, dipoles for
    /// clusters farther than 2.5 of their radii; `0` without triangles.
    pub fn winding_number(&self, p: [f64; 3]) -> f64 {
        if self.nodes.is_empty() {
            return 0.0;
        }
        let mut total = 0.0;
        let mut stack = [0u32; STACK];
        let mut sp = 1usize;
        let mut work = 0u64;
        while sp > 0 {
            sp -= 1;
            let i = stack[sp] as usize;
            let node = &self.nodes[i];
            let dp = &self.dipoles[i];
            let r = sub(dp.centre, p);
            let d2 = norm2(r);
            work += 1;
            if d2 > (BETA * dp.radius).powi(2) {
                total += dot(r, dp.area_normal) / (d2 * d2.sqrt());
            } else if node.count > 0 {
                let s = node.first as usize;
                work += u64::from(node.count);
                for t in &self.tris[s..s + node.count as usize] {
                    total += solid_angle(p, &t.v);
                }
            } else if sp + 2 <= STACK {
                stack[sp] = node.first;
                stack[sp + 1] = node.first + 1;
                sp += 2;
            }
        }
        QUERY_WORK.fetch_add(work, Ordering::Relaxed);
        total / (4.0 * std::f64::consts::PI)
    }

    /// Number of input triangles skipped (bad index or zero area).
    pub fn skipped(&self) -> usize {
        self.skipped
    }

    /// Number of triangles in the hierarchy.
    pub fn triangle_count(&self) -> usize {
        self.tris.len()
    }

    /// The hierarchy; `progress` gets the fraction of triangles placed in leaves.
    fn build(&mut self, progress: &dyn Fn(f64)) {
        if self.tris.is_empty() {
            return;
        }
        let mut placed = 0usize;
        // Centroids by input position; `order` is the arrangement being built, applied to
        // `tris` once at the end (moving whole triangles at every level cost O(n log n)
        // copies of 240 bytes).
        let centroids: Vec<[f64; 3]> = self
            .tris
            .iter()
            .map(|t| scale_v(add(add(t.v[0], t.v[1]), t.v[2]), 1.0 / 3.0))
            .collect();
        let n = self.tris.len();
        let mut order: Vec<u32> = (0..n as u32).collect();
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
            let (lo, hi) = bounds(order[s..e].iter().map(|&i| &self.tris[i as usize]));
            self.nodes[ni].lo = lo;
            self.nodes[ni].hi = hi;
            if e - s <= LEAF_SIZE {
                self.nodes[ni].first = s as u32;
                self.nodes[ni].count = (e - s) as u32;
                let before = placed;
                placed += e - s;
                if placed >> 16 != before >> 16 {
                    progress(placed as f64 / n as f64);
                }
                continue;
            }
            // Split at the median centroid along the longest axis of the centroid bounds.
            let (clo, chi) = point_bounds(order[s..e].iter().map(|&i| &centroids[i as usize]));
            let ext = sub(chi, clo);
            let axis = if ext[0] >= ext[1] && ext[0] >= ext[2] {
                0
            } else if ext[1] >= ext[2] {
                1
            } else {
                2
            };
            let mid = (s + e) / 2;
            order[s..e].select_nth_unstable_by(mid - s, |&a, &b| {
                centroids[a as usize][axis].total_cmp(&centroids[b as usize][axis])
            });
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
        self.tris = order.iter().map(|&i| self.tris[i as usize]).collect();
    }

    /// The closest point of the surface to `p` (mesh units), with its triangle, feature and
    /// outward pseudo-normal; `None` for a mesh without usable triangles.
    pub fn closest_point(&self, p: [f64; 3]) -> Option<ClosestPoint> {
        self.closest_within(p, f64::INFINITY)
    }

    /// Like [`MeshQuery::closest_point`] but only searches within `max_dist` of `p`; `None`
    /// when no surface point is that close.
    pub fn closest_within(&self, p: [f64; 3], max_dist: f64) -> Option<ClosestPoint> {
        self.closest_budgeted(p, max_dist, usize::MAX).0
    }

    /// Like [`MeshQuery::closest_within`] but stops after testing `max_tests` triangles; the
    /// flag says whether the search completed. When it did not, the point returned is the
    /// nearest among the triangles tested (nearer subtrees first), so it is a surface point
    /// within `max_dist` but not necessarily the closest one. Gives the same answer as
    /// [`MeshQuery::closest_within`] whenever it completes: the cost of a query from a point
    /// nearly equidistant to many triangles (the centre of a finely tessellated sphere) is
    /// bounded this way.
    pub fn closest_budgeted(
        &self,
        p: [f64; 3],
        max_dist: f64,
        max_tests: usize,
    ) -> (Option<ClosestPoint>, bool) {
        if self.nodes.is_empty() {
            return (None, true);
        }
        let mut best_d2 = if max_dist.is_finite() {
            max_dist * max_dist
        } else {
            f64::INFINITY
        };
        let mut best: Option<(usize, [f64; 3], Feature)> = None;
        let mut stack = [0u32; STACK];
        let mut sp = 0usize;
        let mut tests = 0usize;
        let mut complete = true;
        if box_dist2(&self.nodes[0], p) <= best_d2 {
            stack[0] = 0;
            sp = 1;
        }
        let mut visited = 0u64;
        while sp > 0 {
            sp -= 1;
            let node = &self.nodes[stack[sp] as usize];
            visited += 1;
            if box_dist2(node, p) > best_d2 {
                continue;
            }
            if node.count > 0 {
                if tests >= max_tests {
                    complete = false;
                    break;
                }
                let s = node.first as usize;
                tests += node.count as usize;
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
        QUERY_WORK.fetch_add(visited + tests as u64, Ordering::Relaxed);
        let Some((ti, q, f)) = best else {
            return (None, complete);
        };
        let t = &self.tris[ti];
        let normal = match f {
            Feature::Face => t.n,
            Feature::Edge(k) => t.en[k as usize],
            Feature::Vertex(k) => t.vn[k as usize],
        };
        let found = ClosestPoint {
            point: q,
            distance: best_d2.sqrt(),
            triangle: t.id,
            feature: f,
            normal,
        };
        (Some(found), complete)
    }

    /// Unsigned distance from `p` to the surface (mesh units); `+inf` without triangles.
    pub fn distance(&self, p: [f64; 3]) -> f64 {
        self.closest_point(p).map_or(f64::INFINITY, |c| c.distance)
    }

    /// Signed distance from `p` to the surface (mesh units): negative inside, positive
    /// outside, the side told by the [`InsideTest`] in use; `+inf` without triangles.
    pub fn signed_distance(&self, p: [f64; 3]) -> f64 {
        self.signed_from(p, self.closest_point(p))
    }

    /// [`MeshQuery::signed_distance`] if the closest point is found within `max_tests`
    /// triangle tests (see [`MeshQuery::closest_budgeted`]), else `None`.
    pub fn signed_distance_budgeted(&self, p: [f64; 3], max_tests: usize) -> Option<f64> {
        match self.closest_budgeted(p, f64::INFINITY, max_tests) {
            (found, true) => Some(self.signed_from(p, found)),
            (_, false) => None,
        }
    }

    fn signed_from(&self, p: [f64; 3], closest: Option<ClosestPoint>) -> f64 {
        match closest {
            Some(c) => {
                let inside = match self.inside {
                    InsideTest::PseudoNormal => dot(sub(p, c.point), c.normal) < 0.0,
                    // On the surface itself the winding number jumps: call it outside.
                    InsideTest::WindingNumber => c.distance > 0.0 && self.winding_number(p) >= 0.5,
                };
                if inside {
                    -c.distance
                } else {
                    c.distance
                }
            }
            None => f64::INFINITY,
        }
    }

    /// True when `p` is strictly inside the mesh by the [`InsideTest`] in use (points on the
    /// surface count as outside).
    pub fn is_inside(&self, p: [f64; 3]) -> bool {
        self.signed_distance(p) < 0.0
    }
}

/// Signed solid angle of triangle `v` seen from `p` (Van Oosterom & Strackee 1983): positive
/// when `p` is on the side its counter-clockwise normal points away from.
fn solid_angle(p: [f64; 3], v: &[[f64; 3]; 3]) -> f64 {
    let [a, b, c] = v.map(|x| sub(x, p));
    let (la, lb, lc) = (norm(a), norm(b), norm(c));
    let num = dot(a, cross(b, c));
    let den = la * lb * lc + dot(a, b) * lc + dot(b, c) * la + dot(c, a) * lb;
    2.0 * num.atan2(den)
}

fn bounds<'a>(tris: impl Iterator<Item = &'a Tri>) -> ([f64; 3], [f64; 3]) {
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

fn point_bounds<'a>(ps: impl Iterator<Item = &'a [f64; 3]>) -> ([f64; 3], [f64; 3]) {
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

    #[test]
    fn winding_number_is_one_inside_zero_outside_and_matches_brute_force() {
        let closed = crate::generate::uv_sphere(1.0, 30, 60);
        let holed = crate::generate::remove_fraction(&closed, 0.05, 3);
        let open = crate::generate::open_box([1.0; 3], 4);
        let two = crate::generate::two_boxes(3);
        let mut state = 7u64;
        let mut rnd = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64) * 3.0 - 1.5
        };
        for m in [&closed, &holed, &open, &two] {
            let q = MeshQuery::with_inside_test(m, InsideTest::WindingNumber);
            for _ in 0..400 {
                let p = [rnd(), rnd(), rnd()];
                let fast = q.winding_number(p);
                let exact = winding(m, p);
                // First-order far field: a few hundredths at worst, near the surface.
                assert!((fast - exact).abs() < 0.05, "{p:?}: {fast} vs {exact}");
                if (exact - 0.5).abs() > 0.05 {
                    assert_eq!(fast >= 0.5, exact >= 0.5, "{p:?}: {fast} vs {exact}");
                }
            }
        }
        let q = MeshQuery::with_inside_test(&closed, InsideTest::WindingNumber);
        assert!((q.winding_number([0.1, 0.2, 0.3]) - 1.0).abs() < 0.03);
        assert!(q.winding_number([1.5, 0.0, 0.0]).abs() < 0.03);
        // The open box: its centre sees 5/6 of the sphere of directions covered.
        let q = MeshQuery::with_inside_test(&open, InsideTest::WindingNumber);
        assert!((q.winding_number([0.0; 3]) - 5.0 / 6.0).abs() < 0.03);
        assert!(q.is_inside([0.0, 0.0, 0.5]));
        assert!(!q.is_inside([0.0, 0.0, 1.3]));
        assert!(q.signed_distance([0.0, 0.0, -0.5]) < 0.0);
        // Two boxes through each other: 2 where both hold the point; the pseudo-normal gets
        // the inside of one box wrong next to a face of the other.
        let q = MeshQuery::with_inside_test(&two, InsideTest::WindingNumber);
        let both = [0.3, 0.3, 0.3];
        assert!((q.winding_number(both) - 2.0).abs() < 0.05);
        assert!(q.signed_distance(both) < 0.0);
        // Inside the long box only, nearest to a face of the other one, from outside it.
        let one = [0.55, 0.0, 0.0];
        assert!((q.winding_number(one) - 1.0).abs() < 0.05);
        assert!(q.signed_distance(one) < 0.0);
        assert!(MeshQuery::new(&two).signed_distance(one) > 0.0);
        assert_eq!(InsideTest::for_mesh(&closed), InsideTest::PseudoNormal);
        assert_eq!(InsideTest::for_mesh(&holed), InsideTest::WindingNumber);
    }

    #[test]
    fn a_budgeted_query_agrees_when_it_completes() {
        let m = crate::generate::uv_sphere(1.0, 40, 80);
        let q = MeshQuery::new(&m);
        // The centre is equidistant from every triangle: a small budget runs out.
        let (cut, complete) = q.closest_budgeted([0.0; 3], f64::INFINITY, 16);
        assert!(!complete);
        assert!(cut.is_some());
        let (full, complete) = q.closest_budgeted([0.0; 3], f64::INFINITY, usize::MAX);
        assert!(complete);
        assert_eq!(full, q.closest_point([0.0; 3]));
        let p = [0.3, 0.9, 0.1];
        assert_eq!(
            q.closest_budgeted(p, f64::INFINITY, 64),
            (q.closest_point(p), true)
        );
    }
}
