//! Face caps of a tree's nodes from its mesh ([`face_caps`]): the nodes on flat faces get
//! the face's plane ([`FaceCap`]), so the face is a plane to the tool instead of a layer of
//! sphere bumps. Inner nodes are capped by the same rule; a cap on an inner node lets its face
//! stand for its whole subtree (docs/DESIGN.md §Face caps).
//!
//! The rule, for a node sphere `B(C, R)` (tree frame = mesh frame, mesh units):
//!
//! 1. Gather every triangle that meets the closed ball (exact point–triangle distance
//!    `<= R`, plus a few `flat_tol` so rounding never drops one: gathering more is only
//!    stricter).
//! 2. Candidates are the *facets* of those triangles: the mesh split into connected patches of
//!    coplanar, same-facing triangles (neighbours across a shared edge, each one's vertices
//!    within `flat_tol` of the other's plane; every patch is then checked against one plane,
//!    that of its largest triangle, and split into single triangles if it drifts from it by
//!    more than `flat_tol`, so slow curvature cannot chain into a "flat" patch). A facet's
//!    score is the exact area of its triangles inside the ball (each triangle clipped by the
//!    disc its plane cuts from the ball). Facets are tried in order of score (ties: the lowest
//!    facet first); the first [`MAX_CAPS`] accepted by steps 3–4 with a reach above 0 are
//!    the node's own caps.
//! 3. A facet's plane `n . x = d` is kept only if
//!    - it covers at least [`CapParams::min_cover`] of that disc (a face, not one small
//!      triangle of a tessellated curved surface: a sphere mesh gets no caps),
//!    - **every** vertex of **every** gathered triangle satisfies `n . v <= d + flat_tol` (all
//!      the surface inside the ball lies below the plane: triangles are convex hulls of their
//!      vertices). Convex edges pass (the side faces go down); concave edges and bumps fail.
//!    - it cuts the sphere: `|n . C - offset| < R`.
//!
//!    The offset is `max(d, max n . v)` over those vertices, so containment holds exactly.
//! 4. `reach`: if the foot `C'` of `C` on the plane lies in a triangle of the facet (projected
//!    on the plane), the distance from `C'` to the nearest boundary edge of the facet (an edge
//!    not shared, in the opposite direction, with another triangle of the same facet;
//!    vertices are matched by exact position, so unwelded meshes work); else 0. The disc of
//!    that radius holds no boundary point of the facet and contains `C'`, so it lies in the
//!    facet: a point above the plane whose foot is in the disc is above the face. The facet
//!    is the *connected* coplanar patch, a subset of all the mesh's coplanar triangles, so the
//!    reach is conservative (never larger than the brief's union of all coplanar triangles).
//!    The disc's centre is stored with the cap (`FaceCap::center`). A cap whose reach is 0 is
//!    dropped: no tool point is ever above its face.
//! 5. A node's caps hold for its whole subtree (every sphere inside its sphere meets only
//!    surface below them); the collision code adds an ancestor's caps to the leaves whose
//!    balls its plane crosses (`collide::PackedTree`, at packing), so they are not repeated
//!    here.
//!
//! Cost: a uniform grid over the triangles' bounding boxes finds the triangles near each node;
//! nodes run in parallel (rayon). The reach scans the winning facet's boundary edges
//! (`O(boundary edges)` per capped node). The output depends only on the input (no
//! randomness, per-node results in slot order).

#![allow(clippy::needless_range_loop)] // per-triangle tables read better indexed

use mesh::vec3::{cross, dot, norm, scale, sub};
use mesh::TriMesh;
use rayon::prelude::*;

use crate::{FaceCap, SphereTree, MAX_CAPS};

/// Version of the face-cap rule: bumped whenever [`face_caps`] gives different caps for the
/// same input (fold it into any cache key of capped trees).
pub const CAPS_VERSION: u32 = 4;

/// Options of [`face_caps`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CapParams {
    /// Flatness tolerance as a fraction of the mesh's bounding-box diagonal (default `1e-6`,
    /// i.e. 1.7e-4 mm on the 120 mm plate): vertices within this distance of a plane count as
    /// on it (facets), and surface up to this far above a cap's plane is accepted (the offset
    /// is then raised to contain it exactly).
    pub rel_flat_tol: f64,
    /// Least fraction (0..=1, default 0.5) of the disc the cap's plane cuts from the leaf
    /// sphere that the winning facet must cover. Leaves on a face's interior cover all of it,
    /// along a box edge about half or more; a single small triangle of a tessellated curved
    /// surface covers little, so curved meshes get no caps.
    pub min_cover: f64,
}

impl Default for CapParams {
    fn default() -> Self {
        Self {
            rel_flat_tol: 1e-6,
            min_cover: 0.5,
        }
    }
}

impl CapParams {
    /// The absolute flatness tolerance for `mesh` (mesh units): [`CapParams::rel_flat_tol`]
    /// times the bounding-box diagonal; 0 for an empty mesh.
    pub fn flat_tol(&self, mesh: &TriMesh) -> f64 {
        mesh.aabb()
            .map(|(lo, hi)| self.rel_flat_tol.max(0.0) * norm(sub(hi, lo)))
            .unwrap_or(0.0)
    }
}

/// The face caps of `tree`'s nodes from `mesh` (both in the same frame and units): one list
/// per slot, ready for [`SphereTree::set_caps`]: each node's own caps (module docs), best
/// first, up to [`MAX_CAPS`]. Deterministic.
pub fn face_caps(mesh: &TriMesh, tree: &SphereTree, params: &CapParams) -> Vec<Vec<FaceCap>> {
    let n = tree.len();
    if mesh.triangles.is_empty() || mesh.vertices.is_empty() {
        return vec![Vec::new(); n];
    }
    let tol = params.flat_tol(mesh);
    let tris = Tris::new(mesh);
    let facets = Facets::new(&tris, tol);
    let leaf_r: Vec<f64> = tree.leaves().map(|l| tree.sphere(l).radius).collect();
    let grid = Grid::new(&tris, &leaf_r);
    (0..n)
        .into_par_iter()
        .map(|slot| {
            let s = tree.sphere(slot);
            if !s.is_used() {
                return Vec::new();
            }
            node_caps(&tris, &facets, &grid, s.center, s.radius, tol, params)
        })
        .collect()
}

/// The caps of one node sphere `B(c, r)`: every facet the rule accepts (module docs, steps
/// 1–4) with a reach above 0, most area inside the ball first, at most [`MAX_CAPS`].
fn node_caps(
    tris: &Tris,
    facets: &Facets,
    grid: &Grid,
    c: [f64; 3],
    r: f64,
    tol: f64,
    params: &CapParams,
) -> Vec<FaceCap> {
    if r.is_nan() || r <= 0.0 {
        return Vec::new();
    }
    // 1. Triangles meeting the ball (a little inflated: more is only stricter).
    let reach_r = r + 4.0 * tol;
    let mut near = grid.query(c, reach_r);
    near.retain(|&t| tri_dist2(c, &tris.v[t as usize]) <= reach_r * reach_r);
    if near.is_empty() {
        return Vec::new();
    }
    // 2. Facet scores: the area of each facet's triangles inside the ball. `near` is sorted,
    // so the sums are in a fixed order.
    let mut scores: Vec<(u32, f64)> = near
        .iter()
        .filter_map(|&t| {
            let f = facets.of_tri[t as usize];
            (f != NO_FACET).then(|| (f, clipped_area(tris, t as usize, c, r)))
        })
        .collect();
    scores.sort_by_key(|&(f, _)| f);
    let mut sums: Vec<(u32, f64)> = Vec::new();
    for &(f, a) in &scores {
        match sums.last_mut() {
            Some((g, sum)) if *g == f => *sum += a,
            _ => sums.push((f, a)),
        }
    }
    // Most area first; ties keep the lower facet id.
    sums.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
    sums.iter()
        .filter_map(|&(f, area)| facet_cap(tris, facets, &near, f, area, c, r, tol, params))
        .filter(|cap| cap.reach > 0.0)
        .take(MAX_CAPS)
        .collect()
}

/// The cap facet `f` (with `area` inside the ball) gives node sphere `B(c, r)`, if the rule
/// accepts it (module docs, steps 3–4); `near` are the triangles meeting the ball.
#[allow(clippy::too_many_arguments)]
fn facet_cap(
    tris: &Tris,
    facets: &Facets,
    near: &[u32],
    f: u32,
    area: f64,
    c: [f64; 3],
    r: f64,
    tol: f64,
    params: &CapParams,
) -> Option<FaceCap> {
    let facet = &facets.list[f as usize];
    let nrm = facet.normal;
    // 3. Covers enough of the disc the plane cuts from the ball.
    let h = dot(nrm, c) - facet.offset;
    let disc = std::f64::consts::PI * (r * r - h * h);
    if disc.is_nan() || disc <= 0.0 || area < params.min_cover * disc {
        return None;
    }
    // All the surface in the ball lies below the plane (up to tol, then exactly).
    let mut offset = facet.offset;
    for &t in near {
        for v in &tris.v[t as usize] {
            let e = dot(nrm, *v);
            if e > facet.offset + tol {
                return None;
            }
            offset = offset.max(e);
        }
    }
    let h = dot(nrm, c) - offset;
    if h.is_nan() || h.abs() >= r {
        return None;
    }
    // 4. Reach: the foot must lie on the facet; then the distance to its boundary.
    let foot = [dot(facet.u, c), dot(facet.v, c)];
    let on_face = near.iter().any(|&t| {
        facets.of_tri[t as usize] == f && {
            let [a, b, d] = tris.v[t as usize].map(|p| [dot(facet.u, p), dot(facet.v, p)]);
            in_triangle_2d(foot, a, b, d)
        }
    });
    let reach = if on_face {
        facet
            .boundary
            .iter()
            .map(|&[a, b]| seg_dist2_2d(foot, a, b))
            .fold(f64::INFINITY, f64::min)
            .sqrt()
    } else {
        0.0
    };
    // A facet without boundary cannot be (a closed surface is not flat); 0 stays safe.
    let reach = if reach.is_finite() { reach } else { 0.0 };
    let foot_height = dot(nrm, c) - offset;
    Some(FaceCap {
        normal: nrm,
        offset,
        center: std::array::from_fn(|k| c[k] - foot_height * nrm[k]),
        reach,
    })
}

/// Per-triangle geometry: vertices, unit normal (zero when degenerate), offset, and the
/// vertex ids welded by exact position.
struct Tris {
    v: Vec<[[f64; 3]; 3]>,
    normal: Vec<[f64; 3]>,
    offset: Vec<f64>,
    area: Vec<f64>,
    ids: Vec<[u32; 3]>,
}

impl Tris {
    fn new(mesh: &TriMesh) -> Self {
        let weld = weld_by_position(&mesh.vertices);
        let diag2 = mesh
            .aabb()
            .map(|(lo, hi)| dot(sub(hi, lo), sub(hi, lo)))
            .unwrap_or(0.0);
        let m = mesh.triangles.len();
        let mut out = Tris {
            v: Vec::with_capacity(m),
            normal: Vec::with_capacity(m),
            offset: Vec::with_capacity(m),
            area: Vec::with_capacity(m),
            ids: Vec::with_capacity(m),
        };
        for t in &mesh.triangles {
            let p = t.map(|k| {
                mesh.vertices
                    .get(k as usize)
                    .copied()
                    .unwrap_or([f64::NAN; 3])
            });
            let ids = t.map(|k| weld.get(k as usize).copied().unwrap_or(u32::MAX));
            let cr = cross(sub(p[1], p[0]), sub(p[2], p[0]));
            let len = norm(cr);
            let finite = p.iter().flatten().all(|x| x.is_finite());
            // Degenerate (or broken) triangles have no plane: they join no facet but still
            // count in the containment test through their vertices.
            let (n, d) = if finite && len > 1e-14 * diag2 {
                let n = scale(cr, 1.0 / len);
                (n, dot(n, p[0]))
            } else {
                ([0.0; 3], 0.0)
            };
            out.v.push(p);
            out.normal.push(n);
            out.offset.push(d);
            out.area.push(if n == [0.0; 3] { 0.0 } else { 0.5 * len });
            out.ids.push(ids);
        }
        out
    }

    fn degenerate(&self, t: usize) -> bool {
        self.normal[t] == [0.0; 3]
    }
}

/// For each vertex, the lowest index of a vertex at exactly the same position (`-0.0` and
/// `0.0` alike), so meshes with duplicated vertices share edges.
fn weld_by_position(vertices: &[[f64; 3]]) -> Vec<u32> {
    let key = |i: usize| vertices[i].map(|x| if x == 0.0 { 0u64 } else { x.to_bits() });
    let mut order: Vec<usize> = (0..vertices.len()).collect();
    order.sort_by_key(|&i| (key(i), i));
    let mut out = vec![0u32; vertices.len()];
    let mut k = 0;
    while k < order.len() {
        let first = order[k];
        let mut j = k;
        while j < order.len() && key(order[j]) == key(first) {
            out[order[j]] = first as u32;
            j += 1;
        }
        k = j;
    }
    out
}

const NO_FACET: u32 = u32::MAX;

/// A connected patch of coplanar, same-facing triangles.
struct Facet {
    /// Unit outward normal (that of its largest triangle).
    normal: [f64; 3],
    /// `normal . x` on the plane.
    offset: f64,
    /// In-plane orthonormal axes (`u x v = normal`).
    u: [f64; 3],
    v: [f64; 3],
    /// Boundary edges projected on `(u, v)`.
    boundary: Vec<[[f64; 2]; 2]>,
}

struct Facets {
    of_tri: Vec<u32>,
    list: Vec<Facet>,
}

impl Facets {
    fn new(tris: &Tris, tol: f64) -> Self {
        let m = tris.v.len();
        // Directed edges (from, to, triangle), sorted: the reverse of an edge is found by
        // binary search.
        let mut edges: Vec<(u32, u32, u32)> = Vec::with_capacity(3 * m);
        for (t, ids) in tris.ids.iter().enumerate() {
            for k in 0..3 {
                edges.push((ids[k], ids[(k + 1) % 3], t as u32));
            }
        }
        edges.sort_unstable();
        let partners = |a: u32, b: u32| {
            let lo = edges.partition_point(|e| (e.0, e.1) < (b, a));
            let hi = edges.partition_point(|e| (e.0, e.1) <= (b, a));
            edges[lo..hi].iter().map(|e| e.2 as usize)
        };
        let coplanar = |i: usize, j: usize| {
            !tris.degenerate(i)
                && !tris.degenerate(j)
                && dot(tris.normal[i], tris.normal[j]) > 0.0
                && tris.v[j]
                    .iter()
                    .all(|p| (dot(tris.normal[i], *p) - tris.offset[i]).abs() <= tol)
                && tris.v[i]
                    .iter()
                    .all(|p| (dot(tris.normal[j], *p) - tris.offset[j]).abs() <= tol)
        };
        let mut uf = UnionFind::new(m);
        for t in 0..m {
            if tris.degenerate(t) {
                continue;
            }
            let ids = tris.ids[t];
            for k in 0..3 {
                for j in partners(ids[k], ids[(k + 1) % 3]) {
                    if j != t && coplanar(t, j) {
                        uf.union(t, j);
                    }
                }
            }
        }
        // Number the patches by their lowest triangle (deterministic).
        let mut of_tri = vec![NO_FACET; m];
        let mut root_id = vec![NO_FACET; m];
        let mut members: Vec<Vec<usize>> = Vec::new();
        for t in 0..m {
            if tris.degenerate(t) {
                continue;
            }
            let r = uf.find(t);
            if root_id[r] == NO_FACET {
                root_id[r] = members.len() as u32;
                members.push(Vec::new());
            }
            of_tri[t] = root_id[r];
            members[root_id[r] as usize].push(t);
        }
        // Each patch against the plane of its largest triangle; one that drifts (chained
        // slow curvature) becomes single triangles.
        let mut groups: Vec<(usize, Vec<usize>)> = Vec::new();
        for tri_list in members {
            let big = tri_list.iter().copied().fold(tri_list[0], |b, t| {
                if tris.area[t] > tris.area[b] {
                    t
                } else {
                    b
                }
            });
            let (n, d) = (tris.normal[big], tris.offset[big]);
            let flat = tri_list.iter().all(|&t| {
                dot(tris.normal[t], n) > 0.0
                    && tris.v[t].iter().all(|p| (dot(n, *p) - d).abs() <= tol)
            });
            if flat {
                groups.push((big, tri_list));
            } else {
                groups.extend(tri_list.into_iter().map(|t| (t, vec![t])));
            }
        }
        for (id, (_, tri_list)) in groups.iter().enumerate() {
            for &t in tri_list {
                of_tri[t] = id as u32;
            }
        }
        let list = groups
            .iter()
            .enumerate()
            .map(|(id, (big, tri_list))| {
                let normal = tris.normal[*big];
                let (u, v) = plane_axes(normal);
                let proj = |p: [f64; 3]| [dot(u, p), dot(v, p)];
                let mut boundary = Vec::new();
                for &t in tri_list {
                    let ids = tris.ids[t];
                    for k in 0..3 {
                        let (a, b) = (ids[k], ids[(k + 1) % 3]);
                        let shared = partners(a, b).any(|j| of_tri[j] == id as u32);
                        if !shared {
                            let p = tris.v[t];
                            boundary.push([proj(p[k]), proj(p[(k + 1) % 3])]);
                        }
                    }
                }
                Facet {
                    normal,
                    offset: tris.offset[*big],
                    u,
                    v,
                    boundary,
                }
            })
            .collect();
        Facets { of_tri, list }
    }
}

struct UnionFind(Vec<usize>);

impl UnionFind {
    fn new(n: usize) -> Self {
        Self((0..n).collect())
    }

    fn find(&mut self, mut x: usize) -> usize {
        while self.0[x] != x {
            self.0[x] = self.0[self.0[x]];
            x = self.0[x];
        }
        x
    }

    fn union(&mut self, a: usize, b: usize) {
        let (ra, rb) = (self.find(a), self.find(b));
        // The lower root wins: the result does not depend on the union order's details.
        if ra != rb {
            let (lo, hi) = (ra.min(rb), ra.max(rb));
            self.0[hi] = lo;
        }
    }
}

/// Orthonormal in-plane axes `(u, v)` with `u x v = n` (`n` unit).
fn plane_axes(n: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let k = (0..3)
        .min_by(|&a, &b| n[a].abs().total_cmp(&n[b].abs()))
        .unwrap_or(0);
    let mut e = [0.0; 3];
    e[k] = 1.0;
    let u = cross(e, n);
    let u = scale(u, 1.0 / norm(u));
    (u, cross(n, u))
}

/// A uniform grid over the triangles' bounding boxes (each triangle listed in every cell its
/// box overlaps), compressed: `start[cell]..start[cell + 1]` indexes `items`.
struct Grid {
    lo: [f64; 3],
    h: f64,
    dims: [usize; 3],
    start: Vec<u32>,
    items: Vec<u32>,
}

impl Grid {
    fn new(tris: &Tris, leaf_r: &[f64]) -> Self {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in tris
            .v
            .iter()
            .flatten()
            .filter(|p| p.iter().all(|x| x.is_finite()))
        {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        if !lo[0].is_finite() {
            return Grid {
                lo: [0.0; 3],
                h: 1.0,
                dims: [1; 3],
                start: vec![0, 0],
                items: Vec::new(),
            };
        }
        let diag = norm(sub(hi, lo)).max(f64::MIN_POSITIVE);
        // About two cells per triangle, but no finer than a quarter of the median leaf radius
        // (finer cells only add cells to visit) and at most 256 cells a side.
        let ext = (0..3).map(|k| (hi[k] - lo[k]).max(1e-3 * diag));
        let vol: f64 = ext.product();
        let mut h = (vol / (2.0 * tris.v.len() as f64)).cbrt();
        let mut r = leaf_r.to_vec();
        r.sort_by(f64::total_cmp);
        if let Some(&med) = r.get(r.len() / 2) {
            if med.is_finite() && med > 0.0 {
                h = h.max(0.25 * med);
            }
        }
        h = h.max(diag / 256.0);
        loop {
            let dims = std::array::from_fn(|k| ((hi[k] - lo[k]) / h).floor() as usize + 1);
            let cell_range = |p: &[[f64; 3]; 3]| -> Option<[std::ops::RangeInclusive<usize>; 3]> {
                if !p.iter().flatten().all(|x| x.is_finite()) {
                    return None;
                }
                Some(std::array::from_fn(|k| {
                    let a = p.iter().map(|q| q[k]).fold(f64::INFINITY, f64::min);
                    let b = p.iter().map(|q| q[k]).fold(f64::NEG_INFINITY, f64::max);
                    let c = |x: f64| (((x - lo[k]) / h).floor().max(0.0) as usize).min(dims[k] - 1);
                    c(a)..=c(b)
                }))
            };
            let total: usize = tris
                .v
                .iter()
                .filter_map(cell_range)
                .map(|r| r.iter().map(|x| x.clone().count()).product::<usize>())
                .sum();
            // A few huge triangles over a fine grid: coarsen rather than fill memory.
            if total > 64 * tris.v.len() + (1 << 22) {
                h *= 2.0;
                continue;
            }
            let ncell = dims[0] * dims[1] * dims[2];
            let mut count = vec![0u32; ncell + 1];
            let cell = |i: usize, j: usize, k: usize| (i * dims[1] + j) * dims[2] + k;
            let ranges: Vec<_> = tris.v.iter().map(cell_range).collect();
            for r in ranges.iter().flatten() {
                for i in r[0].clone() {
                    for j in r[1].clone() {
                        for k in r[2].clone() {
                            count[cell(i, j, k) + 1] += 1;
                        }
                    }
                }
            }
            for c in 0..ncell {
                count[c + 1] += count[c];
            }
            let mut fill = count.clone();
            let mut items = vec![0u32; total];
            for (t, r) in ranges.iter().enumerate() {
                let Some(r) = r else { continue };
                for i in r[0].clone() {
                    for j in r[1].clone() {
                        for k in r[2].clone() {
                            let c = cell(i, j, k);
                            items[fill[c] as usize] = t as u32;
                            fill[c] += 1;
                        }
                    }
                }
            }
            return Grid {
                lo,
                h,
                dims,
                start: count,
                items,
            };
        }
    }

    /// The triangles listed in the cells that the box of the ball `B(c, r)` overlaps, sorted,
    /// without repeats.
    fn query(&self, c: [f64; 3], r: f64) -> Vec<u32> {
        let range: [std::ops::RangeInclusive<usize>; 3] = std::array::from_fn(|k| {
            let f = |x: f64| {
                (((x - self.lo[k]) / self.h).floor().max(0.0) as usize).min(self.dims[k] - 1)
            };
            f(c[k] - r)..=f(c[k] + r)
        });
        // A ball wholly outside the grid's box meets nothing (the clamping above would
        // otherwise pick the border cells, which is harmless but wasteful).
        let outside = (0..3)
            .any(|k| c[k] + r < self.lo[k] || c[k] - r > self.lo[k] + self.h * self.dims[k] as f64);
        let mut out = Vec::new();
        if outside || !c.iter().all(|x| x.is_finite()) {
            return out;
        }
        for i in range[0].clone() {
            for j in range[1].clone() {
                for k in range[2].clone() {
                    let cell = (i * self.dims[1] + j) * self.dims[2] + k;
                    let (a, b) = (self.start[cell] as usize, self.start[cell + 1] as usize);
                    out.extend_from_slice(&self.items[a..b]);
                }
            }
        }
        out.sort_unstable();
        out.dedup();
        out
    }
}

/// Squared distance from `p` to the triangle `v` (closest-point regions of Ericson,
/// *Real-Time Collision Detection* §5.1.5; the edges for a degenerate triangle).
fn tri_dist2(p: [f64; 3], v: &[[f64; 3]; 3]) -> f64 {
    let [a, b, c] = *v;
    let ab = sub(b, a);
    let ac = sub(c, a);
    let cr = cross(ab, ac);
    let n2 = dot(cr, cr);
    let scale2 = dot(ab, ab).max(dot(ac, ac));
    if n2.is_nan() || n2 <= 1e-24 * scale2 * scale2 {
        return seg_dist2(p, a, b)
            .min(seg_dist2(p, b, c))
            .min(seg_dist2(p, c, a));
    }
    // Inside the prism over the triangle: the plane distance; else the nearest edge.
    let inside = (0..3).all(|k| {
        let (e0, e1) = (v[k], v[(k + 1) % 3]);
        dot(cross(sub(e1, e0), sub(p, e0)), cr) >= 0.0
    });
    if inside {
        let d = dot(sub(p, a), cr);
        return d * d / n2;
    }
    seg_dist2(p, a, b)
        .min(seg_dist2(p, b, c))
        .min(seg_dist2(p, c, a))
}

fn seg_dist2(p: [f64; 3], a: [f64; 3], b: [f64; 3]) -> f64 {
    let ab = sub(b, a);
    let l2 = dot(ab, ab);
    let t = if l2 > 0.0 {
        (dot(sub(p, a), ab) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let q = sub(p, [a[0] + t * ab[0], a[1] + t * ab[1], a[2] + t * ab[2]]);
    dot(q, q)
}

fn seg_dist2_2d(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let ab = [b[0] - a[0], b[1] - a[1]];
    let ap = [p[0] - a[0], p[1] - a[1]];
    let l2 = ab[0] * ab[0] + ab[1] * ab[1];
    let t = if l2 > 0.0 {
        ((ap[0] * ab[0] + ap[1] * ab[1]) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let q = [ap[0] - t * ab[0], ap[1] - t * ab[1]];
    q[0] * q[0] + q[1] * q[1]
}

fn cross2(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

/// `p` in the closed counter-clockwise triangle `abc` (a clockwise or flat one holds nothing).
fn in_triangle_2d(p: [f64; 2], a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> bool {
    let d = |x: [f64; 2], y: [f64; 2]| [x[0] - y[0], x[1] - y[1]];
    cross2(d(b, a), d(c, a)) > 0.0
        && cross2(d(b, a), d(p, a)) >= 0.0
        && cross2(d(c, b), d(p, b)) >= 0.0
        && cross2(d(a, c), d(p, c)) >= 0.0
}

/// Area of triangle `t` inside the ball `B(c, r)`: the triangle clipped by the disc its plane
/// cuts from the ball (exact, by the signed areas of the disc with the fans from the disc's
/// centre); 0 for a degenerate triangle.
fn clipped_area(tris: &Tris, t: usize, c: [f64; 3], r: f64) -> f64 {
    if tris.degenerate(t) {
        return 0.0;
    }
    let n = tris.normal[t];
    let h = dot(n, c) - tris.offset[t];
    let rho2 = r * r - h * h;
    if rho2.is_nan() || rho2 <= 0.0 {
        return 0.0;
    }
    let (u, v) = plane_axes(n);
    let rel = tris.v[t].map(|p| {
        let q = sub(p, c);
        [dot(u, q), dot(v, q)]
    });
    let rho = rho2.sqrt();
    let sum: f64 = (0..3)
        .map(|k| disc_fan_area(rel[k], rel[(k + 1) % 3], rho))
        .sum();
    sum.abs().min(tris.area[t])
}

/// Signed area of the disc of radius `r` about the origin intersected with the triangle
/// `(0, a, b)` (positive when `a, b` turn counter-clockwise).
fn disc_fan_area(a: [f64; 2], b: [f64; 2], r: f64) -> f64 {
    let sector =
        |x: [f64; 2], y: [f64; 2]| 0.5 * r * r * cross2(x, y).atan2(x[0] * y[0] + x[1] * y[1]);
    let d = [b[0] - a[0], b[1] - a[1]];
    let qa = d[0] * d[0] + d[1] * d[1];
    if qa == 0.0 {
        return 0.0;
    }
    let qb = a[0] * d[0] + a[1] * d[1];
    let qc = a[0] * a[0] + a[1] * a[1] - r * r;
    let disc = qb * qb - qa * qc;
    if disc <= 0.0 {
        return sector(a, b);
    }
    let s = disc.sqrt();
    let (t1, t2) = ((-qb - s) / qa, (-qb + s) / qa);
    if t2 <= 0.0 || t1 >= 1.0 {
        return sector(a, b);
    }
    let (t1, t2) = (t1.max(0.0), t2.min(1.0));
    let p1 = [a[0] + t1 * d[0], a[1] + t1 * d[1]];
    let p2 = [a[0] + t2 * d[0], a[1] + t2 * d[1]];
    let s1 = if t1 > 0.0 { sector(a, p1) } else { 0.0 };
    let s2 = if t2 < 1.0 { sector(p2, b) } else { 0.0 };
    s1 + 0.5 * cross2(p1, p2) + s2
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn disc_area_of_a_triangle_matches_the_closed_forms() {
        let sq = |s: f64| {
            // The square [-s, s]^2 as two triangles about the origin: 4 fans.
            let c = [[-s, -s], [s, -s], [s, s], [-s, s]];
            (0..4)
                .map(|k| disc_fan_area(c[k], c[(k + 1) % 4], 1.0))
                .sum::<f64>()
        };
        // Square inside the disc, disc inside the square.
        assert!((sq(0.5) - 1.0).abs() < 1e-12);
        assert!((sq(2.0) - std::f64::consts::PI).abs() < 1e-12);
        // Square of half-side 1/sqrt(2)·... : the inscribed-corner case, half-side 0.8:
        // disc minus four circular segments beyond |x| = 0.8.
        let seg = |d: f64| (d / 1.0).acos() - d * (1.0 - d * d).sqrt();
        let want = std::f64::consts::PI - 4.0 * seg(0.8);
        assert!((sq(0.8) - want).abs() < 1e-12, "{} vs {want}", sq(0.8));
    }

    #[test]
    fn triangle_distance_regions() {
        let v = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        assert!((tri_dist2([0.2, 0.2, 3.0], &v) - 9.0).abs() < 1e-12);
        assert!((tri_dist2([-1.0, -1.0, 0.0], &v) - 2.0).abs() < 1e-12);
        assert!((tri_dist2([1.0, 1.0, 0.0], &v) - 0.5).abs() < 1e-12);
        assert!((tri_dist2([0.5, -2.0, 1.0], &v) - 5.0).abs() < 1e-12);
    }

    #[test]
    fn welding_joins_exact_duplicates_only() {
        let w = weld_by_position(&[
            [0.0; 3],
            [1.0, 0.0, 0.0],
            [-0.0, 0.0, 0.0],
            [1.0, 1e-300, 0.0],
        ]);
        assert_eq!(w, vec![0, 1, 0, 3]);
    }
}
