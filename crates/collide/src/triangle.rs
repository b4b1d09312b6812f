//! The exact distance between two triangles and their closest points: the narrow phase of the
//! mesh geometry mode (docs/DESIGN.md §Mesh-exact contact).
//!
//! Two disjoint triangles are nearest at a vertex of one against the other (six cases) or at
//! a pair of edges (nine cases); two that meet are at distance zero, and then an edge of one
//! crosses the other or their edges meet. So the distance is the least of those fifteen
//! feature distances, or zero where an edge crosses a triangle. Every case is exact (closed
//! forms on the features' Voronoi regions), and a degenerate triangle (a segment or a point)
//! is its edges.

use nalgebra::Vector3;

/// A triangle: its three corners (mm).
pub type Triangle = [[f64; 3]; 3];

/// The nearest points of two triangles.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleDistance {
    /// Their distance, mm (0 when they meet).
    pub distance: f64,
    /// The nearest point on the first triangle, mm (a common point when they meet).
    pub on_a: [f64; 3],
    /// The nearest point on the second triangle, mm.
    pub on_b: [f64; 3],
    /// The triangles meet (intersect or touch).
    pub meet: bool,
}

/// Twice a triangle's area below this (mm²) makes it a segment for the point case.
const DEGENERATE_AREA2: f64 = 1e-18;

type V = Vector3<f64>;

fn v(p: &[f64; 3]) -> V {
    V::from(*p)
}

/// The point of the triangle `(a, b, c)` nearest to `p` (by its Voronoi regions: a corner, an
/// edge or the face).
pub fn closest_on_triangle(p: &[f64; 3], t: &Triangle) -> [f64; 3] {
    closest_point_triangle(&v(p), &v(&t[0]), &v(&t[1]), &v(&t[2])).into()
}

fn closest_point_triangle(p: &V, a: &V, b: &V, c: &V) -> V {
    let (ab, ac) = (b - a, c - a);
    if ab.cross(&ac).norm_squared() <= DEGENERATE_AREA2 {
        // A segment or a point: the nearest of its edges' nearest points.
        let candidates = [
            closest_point_segment(p, a, b),
            closest_point_segment(p, b, c),
            closest_point_segment(p, c, a),
        ];
        return candidates
            .into_iter()
            .min_by(|x, y| (x - p).norm_squared().total_cmp(&(y - p).norm_squared()))
            .unwrap_or(*a);
    }
    let ap = p - a;
    let (d1, d2) = (ab.dot(&ap), ac.dot(&ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return *a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(&bp), ac.dot(&bp));
    if d3 >= 0.0 && d4 <= d3 {
        return *b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(&cp), ac.dot(&cp));
    if d6 >= 0.0 && d5 <= d6 {
        return *c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    // Inside the face: barycentric coordinates from the three signed areas.
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

fn closest_point_segment(p: &V, a: &V, b: &V) -> V {
    let ab = b - a;
    let len2 = ab.norm_squared();
    if len2 <= 0.0 {
        return *a;
    }
    a + ab * ((p - a).dot(&ab) / len2).clamp(0.0, 1.0)
}

/// The nearest points of the segments `p1 q1` and `p2 q2` (either may be a point).
fn closest_segments(p1: &V, q1: &V, p2: &V, q2: &V) -> (V, V) {
    let (d1, d2) = (q1 - p1, q2 - p2);
    closest_segments_along(p1, &d1, d1.norm_squared(), p2, &d2, d2.norm_squared())
}

/// [`closest_segments`] of `p1 + s d1` and `p2 + t d2` (`s`, `t` in [0, 1]), given each
/// direction's squared length (`a`, `e`): a triangle's edges are measured once for its nine
/// edge pairs.
fn closest_segments_along(p1: &V, d1: &V, a: f64, p2: &V, d2: &V, e: f64) -> (V, V) {
    closest_segments_at(p1, d1, a, p2, d2, e).0
}

/// [`closest_segments_along`] with where the points lie along their segments (`s`, `t`): where
/// one is inside its segment, the way between them is normal to it.
fn closest_segments_at(p1: &V, d1: &V, a: f64, p2: &V, d2: &V, e: f64) -> ((V, V), (f64, f64)) {
    let r = p1 - p2;
    let f = d2.dot(&r);
    if a <= 0.0 && e <= 0.0 {
        return ((*p1, *p2), (0.0, 0.0));
    }
    let (s, t) = if a <= 0.0 {
        (0.0, (f / e).clamp(0.0, 1.0))
    } else {
        let c = d1.dot(&r);
        if e <= 0.0 {
            ((-c / a).clamp(0.0, 1.0), 0.0)
        } else {
            let b = d1.dot(d2);
            let denom = a * e - b * b;
            // Parallel segments (denom 0): any s; start from 0 and let t and s settle.
            let mut s = if denom > 0.0 {
                ((b * f - c * e) / denom).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let mut t = (b * s + f) / e;
            if t < 0.0 {
                t = 0.0;
                s = (-c / a).clamp(0.0, 1.0);
            } else if t > 1.0 {
                t = 1.0;
                s = ((b - c) / a).clamp(0.0, 1.0);
            }
            (s, t)
        }
    };
    ((p1 + d1 * s, p2 + d2 * t), (s, t))
}

/// Where the segment `p q` crosses the triangle `t` (normal `n`, the cross product of its
/// first two edges; `dp`, `dq` the ends' heights over its plane times `|n|`), if it does (a
/// point of both).
fn segment_crosses(p: &V, q: &V, t: &[V; 3], n: &V, dp: f64, dq: f64) -> Option<V> {
    if n.norm_squared() <= DEGENERATE_AREA2 {
        return None;
    }
    if (dp > 0.0 && dq > 0.0) || (dp < 0.0 && dq < 0.0) || dp == dq {
        // Both on one side, or in the plane (then an edge-edge or vertex case finds it).
        return None;
    }
    let x = p + (q - p) * (dp / (dp - dq));
    inside(t, n, &x).then_some(x)
}

/// Whether `x`, a point of the plane of `t` (normal `n` as in [`segment_crosses`]), is inside
/// `t` or on its edges: on the inner side of all three.
#[inline(always)]
fn inside(t: &[V; 3], n: &V, x: &V) -> bool {
    let inner = |u: &V, w: &V| n.dot(&(w - u).cross(&(x - u))) >= 0.0;
    inner(&t[0], &t[1]) && inner(&t[1], &t[2]) && inner(&t[2], &t[0])
}

/// The exact distance between the triangles `a` and `b` and their nearest points.
///
/// The fifteen feature pairs are tried in an order that usually ends early. Edge crossings
/// are tested only where each triangle reaches the other's plane. Where one triangle lies
/// wholly on one side of the other's plane and its nearest corner projects inside the other,
/// that corner and its projection are the nearest points (a face contact). A pair of edges
/// whose nearest points have every corner of each triangle behind the plane through its point
/// normal to the way between them (a separating slab as thick as their distance) is the
/// answer; the pairs are tried nearest the other's plane first (or, where each triangle
/// crosses the other's plane, nearest middles first), and only a pair no farther than those
/// measured before is slab-tested. Otherwise the nearest of the nine edge pairs and of the
/// corners projecting inside the other's face is the answer (a corner nearest to a face's edge
/// is no nearer than its own edges to that edge): the same as
/// [`triangle_distance_all_features`], which measures all fifteen.
///
/// The slab's test allows for the rounding of coordinates far from the origin: faces lying
/// on each other 0.03 mm apart 50 mm out end at their crossing edges, where a test relative
/// to the products alone measured every feature.
///
/// # Real-time
/// No allocation, no panic, constant time (at most 9 edge pairs, 6 corner projections and 6
/// edge crossings).
pub fn triangle_distance(a: &Triangle, b: &Triangle) -> TriangleDistance {
    let mut none = NearestEdges::NONE;
    triangle_distance_from(a, b, &mut none)
}

/// The pair of edges, one of each triangle, whose nearest points were the two triangles'
/// nearest points where [`triangle_distance_from`] last measured them (by a separating slab),
/// if any.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NearestEdges(u8);

impl NearestEdges {
    /// None known: the search starts from the face contacts.
    pub const NONE: Self = Self(0);

    /// Edge `i` of the first triangle (from its corner `i` to `i + 1`) and edge `j` of the
    /// second.
    fn of(i: usize, j: usize) -> Self {
        Self(1 + (3 * i + j) as u8)
    }

    fn edges(self) -> Option<(usize, usize)> {
        let k = usize::from(self.0).checked_sub(1)?;
        (k < 9).then_some((k / 3, k % 3))
    }
}

/// [`triangle_distance`], trying first the pair of edges `last` names (the answer where the
/// two were measured a little way back, as a sliding contact's pairs are frame after frame);
/// leaves in `last` the pair that answers here, or [`NearestEdges::NONE`]. The same distance
/// whatever `last` says (a pair is the answer only where a separating slab shows it); the
/// nearest points, where they are not unique, may be others.
///
/// # Real-time
/// As [`triangle_distance`], and one edge pair more at most.
pub fn triangle_distance_from(
    a: &Triangle,
    b: &Triangle,
    last: &mut NearestEdges,
) -> TriangleDistance {
    let (pa, pb) = (a.map(|p| v(&p)), b.map(|p| v(&p)));
    if let Some((i, j)) = last.edges() {
        let (da, db) = (pa[(i + 1) % 3] - pa[i], pb[(j + 1) % 3] - pb[j]);
        let ((x, y), at) = closest_segments_at(
            &pa[i],
            &da,
            da.norm_squared(),
            &pb[j],
            &db,
            db.norm_squared(),
        );
        if separated_at_edges(&pa, &pb, &x, &y, (i, j), at) {
            return nearest(x, y);
        }
    }
    *last = NearestEdges::NONE;
    let (na, nb) = (
        (pa[1] - pa[0]).cross(&(pa[2] - pa[0])),
        (pb[1] - pb[0]).cross(&(pb[2] - pb[0])),
    );
    // Signed heights (times the normal's length) of each triangle's corners over the other's
    // plane.
    let a_over_b = pa.map(|p| nb.dot(&(p - pb[0])));
    let b_over_a = pb.map(|p| na.dot(&(p - pa[0])));
    // Meeting triangles have a common point in both planes: each has a corner on or across
    // the other's plane.
    let meet_possible = !one_side(&a_over_b) && !one_side(&b_over_a);
    if let Some(x) = meet_possible
        .then(|| crossing(&pa, &pb, &nb, &a_over_b).or_else(|| crossing(&pb, &pa, &na, &b_over_a)))
        .flatten()
    {
        return TriangleDistance {
            distance: 0.0,
            on_a: x.into(),
            on_b: x.into(),
            meet: true,
        };
    }
    // A face contact: one triangle wholly above the other's face.
    if let Some((x, y)) = corner_over_face(&pa, &pb, &nb, &a_over_b) {
        return nearest(x, y);
    }
    if let Some((y, x)) = corner_over_face(&pb, &pa, &na, &b_over_a) {
        return nearest(x, y);
    }
    nearest_features(&pa, &pb, (&na, &b_over_a), (&nb, &a_over_b), last)
}

/// [`triangle_distance`] past its face contacts: the nearest of the nine edge pairs (the first
/// at a separating slab, named in `found`) and of the corners projecting inside the other's
/// face; given each triangle's normal and the other's heights over its plane. Kept apart so
/// that the face contacts' way (over half the pairs of a contact) carries none of its state.
#[inline(never)]
fn nearest_features(
    pa: &[V; 3],
    pb: &[V; 3],
    (na, b_over_a): (&V, &[f64; 3]),
    (nb, a_over_b): (&V, &[f64; 3]),
    found: &mut NearestEdges,
) -> TriangleDistance {
    let edges = |p: &[V; 3]| [p[1] - p[0], p[2] - p[1], p[0] - p[2]];
    let (ea, eb) = (edges(pa), edges(pb));
    let (la, lb) = (ea.map(|e| e.norm_squared()), eb.map(|e| e.norm_squared()));
    let mut best = (f64::INFINITY, pa[0], pb[0]);
    // Where one triangle lies on one side of the other's plane, each one's edges nearest the
    // other's plane first; where each crosses the other's plane (and they do not meet), the
    // pair of edges whose middles are nearest first. The nearest pair is most often the first
    // tried, and a near pair measured early lets the farther ones pass untested.
    let mut order = [0, 1, 2, 3, 4, 5, 6, 7, 8];
    if one_side(a_over_b) || one_side(b_over_a) {
        let (by_a, by_b) = (nearest_edges_first(a_over_b), nearest_edges_first(b_over_a));
        order = std::array::from_fn(|k| 3 * by_a[k / 3] + by_b[k % 3]);
    } else {
        let middle = |p: &[V; 3], e: &[V; 3], k: usize| p[k] + e[k] * 0.5;
        let mut first = (f64::INFINITY, 0);
        for k in 0..9 {
            let d2 = (middle(pa, &ea, k / 3) - middle(pb, &eb, k % 3)).norm_squared();
            if d2 < first.0 {
                first = (d2, k);
            }
        }
        order.swap(0, first.1);
    }
    for k in order {
        let (i, j) = (k / 3, k % 3);
        let ((x, y), at) = closest_segments_at(&pa[i], &ea[i], la[i], &pb[j], &eb[j], lb[j]);
        let d2 = (y - x).norm_squared();
        // Only the nearest pair can be separated by a slab as thick as its distance: a pair
        // farther than one already measured is not tested (faces lying on each other have
        // several at the same distance, to a rounding).
        if d2 <= best.0 * (1.0 + TIE) {
            if separated_at_edges(pa, pb, &x, &y, (i, j), at) {
                *found = NearestEdges::of(i, j);
                return nearest(x, y);
            }
            if d2 < best.0 {
                best = (d2, x, y);
            }
        }
    }
    // A corner against the other's face: only where it projects inside the face. Nearest at
    // an edge of the face, it is no nearer than its own edges to that edge, measured above;
    // a degenerate face is its edges.
    let mut corner_on_face = |s: &[V; 3], t: &[V; 3], n: &V, side: &[f64; 3], flip: bool| {
        let n2 = n.norm_squared();
        if n2 <= DEGENERATE_AREA2 {
            return;
        }
        for k in 0..3 {
            let y = s[k] - n * (side[k] / n2);
            let d2 = (s[k] - y).norm_squared();
            if d2 < best.0 && inside(t, n, &y) {
                best = if flip { (d2, y, s[k]) } else { (d2, s[k], y) };
            }
        }
    };
    corner_on_face(pa, pb, nb, a_over_b, false);
    corner_on_face(pb, pa, na, b_over_a, true);
    nearest(best.1, best.2)
}

/// A triangle's edges (`k` from corner `k` to `k + 1`) by how near they run to a plane, given
/// its corners' heights over it: the sum of their ends' distances.
fn nearest_edges_first(side: &[f64; 3]) -> [usize; 3] {
    let h: [f64; 3] = std::array::from_fn(|k| side[k].abs() + side[(k + 1) % 3].abs());
    let mut order = [0, 1, 2];
    if h[order[1]] < h[order[0]] {
        order.swap(0, 1);
    }
    if h[order[2]] < h[order[1]] {
        order.swap(1, 2);
        if h[order[1]] < h[order[0]] {
            order.swap(0, 1);
        }
    }
    order
}

/// [`separated_at`] for nearest points on edge `i` of `a` and edge `j` of `b`, at `s` and `t`
/// along them: where a point is inside its edge the way between them is normal to that edge
/// (the points are nearest), so the edge's ends lie in the slab's plane and only the third
/// corner is tested.
fn separated_at_edges(
    a: &[V; 3],
    b: &[V; 3],
    x: &V,
    y: &V,
    (i, j): (usize, usize),
    (s, t): (f64, f64),
) -> bool {
    let ends = |k: usize, at: f64| {
        let inside = at > 0.0 && at < 1.0;
        std::array::from_fn(|c| inside && (c == k || c == (k + 1) % 3))
    };
    separated_at(a, b, x, y, ends(i, s), ends(j, t))
}

/// Whether `x` (a point of `a`) and `y` (of `b`) are the triangles' nearest points by a
/// separating slab: every corner of `a` on `x`'s side of the plane through `x` normal to
/// `y - x`, every corner of `b` beyond the one through `y` (then no two points are nearer).
/// A corner in the plane to rounding ([`ROUNDING2`] of the coordinates' size) counts as on it,
/// so parallel faces and edges end here too; so does a corner marked in `in_plane_a` or
/// `in_plane_b` (known to lie in its plane).
fn separated_at(
    a: &[V; 3],
    b: &[V; 3],
    x: &V,
    y: &V,
    in_plane_a: [bool; 3],
    in_plane_b: [bool; 3],
) -> bool {
    let w = y - x;
    let w2 = w.norm_squared();
    let scale2 = x.norm_squared().max(y.norm_squared());
    // `r·w` against its rounding, squared (no roots taken): `r`, `w` and the nearest points
    // are differences of coordinates as large as `scale`, each off by a few of its units in
    // the last place.
    let behind = |r: V, sign: f64| {
        let along = sign * r.dot(&w);
        let r2 = r.norm_squared();
        along <= 0.0 || along * along <= ROUNDING2 * (scale2 + r2) * (r2 + w2)
    };
    w2 > 0.0
        && (0..3).all(|k| in_plane_a[k] || behind(a[k] - x, 1.0))
        && (0..3).all(|k| in_plane_b[k] || behind(b[k] - y, -1.0))
}

/// The square of a rounding's share of a coordinate in the separating slab's test
/// ([`separated_at`]): 64 units in the last place. A corner within it of the slab's plane is
/// taken as in it (at worst the distance is then that share of the coordinates' size over the
/// distance too long: 7e-10 mm for parts 50 mm from the origin 0.03 mm apart).
const ROUNDING2: f64 = (64.0 * f64::EPSILON) * (64.0 * f64::EPSILON);

/// Relative size of a rounding in the early answers' tests (a few units in the last place of
/// the products they compare).
const ROUNDING: f64 = 1e-13;

/// Relative difference of two squared distances taken as a tie.
const TIE: f64 = 1e-9;

/// The answer for the nearest points `x` (on the first triangle) and `y`.
fn nearest(x: V, y: V) -> TriangleDistance {
    let distance = (y - x).norm();
    TriangleDistance {
        distance,
        on_a: x.into(),
        on_b: y.into(),
        meet: distance == 0.0,
    }
}

/// Where an edge of `s` crosses `t` (normal `n`), given the heights `side` of `s`'s corners
/// over `t`'s plane (only where they are not all on one side).
fn crossing(s: &[V; 3], t: &[V; 3], n: &V, side: &[f64; 3]) -> Option<V> {
    if one_side(side) {
        return None;
    }
    (0..3).find_map(|k| segment_crosses(&s[k], &s[(k + 1) % 3], t, n, side[k], side[(k + 1) % 3]))
}

/// Whether a triangle's corners, of heights `side` over a plane, are all strictly on one side
/// of it.
fn one_side(side: &[f64; 3]) -> bool {
    side.iter().all(|&d| d > 0.0) || side.iter().all(|&d| d < 0.0)
}

/// Where `s` lies wholly on one side of `t`'s plane (normal `n`, heights `side` of its
/// corners) and its corner nearest the plane projects inside `t`: that corner and its
/// projection, the two triangles' nearest points (no point of `s` is nearer the plane, and the
/// projection is a point of `t`).
fn corner_over_face(s: &[V; 3], t: &[V; 3], n: &V, side: &[f64; 3]) -> Option<(V, V)> {
    if !one_side(side) {
        return None;
    }
    let n2 = n.norm_squared();
    if n2 <= DEGENERATE_AREA2 {
        return None;
    }
    // Any corner at the least height (to rounding: parallel faces have three) that projects
    // inside `t`.
    let low = side[0].abs().min(side[1].abs()).min(side[2].abs());
    (0..3).find_map(|k| {
        if side[k].abs() > low * (1.0 + ROUNDING) {
            return None;
        }
        let x = s[k];
        let y = x - n * (side[k] / n2);
        inside(t, n, &y).then_some((x, y))
    })
}

/// The exact distance between the triangles `a` and `b` measured on all fifteen feature pairs
/// (after the edge crossings): the yardstick of [`triangle_distance`], which usually stops
/// earlier. Same answer, to rounding; where the nearest points are not unique (parallel faces
/// or edges) either may give other ones at the same distance.
pub fn triangle_distance_all_features(a: &Triangle, b: &Triangle) -> TriangleDistance {
    let (pa, pb) = (a.map(|p| v(&p)), b.map(|p| v(&p)));
    // An edge of one crossing the other: they meet. (Only where its corners are not all on
    // one side of the other's plane.)
    for (s, t) in [(&pa, &pb), (&pb, &pa)] {
        let n = (t[1] - t[0]).cross(&(t[2] - t[0]));
        let side = s.map(|p| n.dot(&(p - t[0])));
        if let Some(x) = crossing(s, t, &n, &side) {
            return TriangleDistance {
                distance: 0.0,
                on_a: x.into(),
                on_b: x.into(),
                meet: true,
            };
        }
    }
    let mut best = (f64::INFINITY, pa[0], pb[0]);
    let mut consider = |x: V, y: V| {
        let d2 = (x - y).norm_squared();
        if d2 < best.0 {
            best = (d2, x, y);
        }
    };
    for i in 0..3 {
        for j in 0..3 {
            let (x, y) = closest_segments(&pa[i], &pa[(i + 1) % 3], &pb[j], &pb[(j + 1) % 3]);
            consider(x, y);
        }
    }
    for k in 0..3 {
        consider(
            pa[k],
            closest_point_triangle(&pa[k], &pb[0], &pb[1], &pb[2]),
        );
        consider(
            closest_point_triangle(&pb[k], &pa[0], &pa[1], &pa[2]),
            pb[k],
        );
    }
    nearest(best.1, best.2)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn random_triangle(rng: &mut rand::rngs::StdRng, centre: [f64; 3], size: f64) -> Triangle {
        std::array::from_fn(|_| {
            std::array::from_fn(|k| centre[k] + size * rng.random_range(-1.0..1.0))
        })
    }

    /// The nearest points certify themselves: `x` minimises `|x - y|` over a triangle exactly
    /// when `(v - x) . (x - y) >= 0` at its three corners `v`, and the pair is the distance's
    /// minimum when both points satisfy it (the problem is convex).
    fn assert_certified(a: &Triangle, b: &Triangle, d: &TriangleDistance, what: &str) {
        let (x, y) = (v(&d.on_a), v(&d.on_b));
        assert!(
            ((x - y).norm() - d.distance).abs() <= 1e-12,
            "{what}: points and distance"
        );
        let on = |p: &V, t: &Triangle| {
            let q = closest_point_triangle(p, &v(&t[0]), &v(&t[1]), &v(&t[2]));
            (q - p).norm()
        };
        assert!(
            on(&x, a) <= 1e-9 && on(&y, b) <= 1e-9,
            "{what}: points on their triangles"
        );
        if d.meet {
            return;
        }
        let dir = x - y;
        for c in a {
            assert!(
                (v(c) - x).dot(&dir) >= -1e-9 * (1.0 + dir.norm()),
                "{what}: not least on a"
            );
        }
        for c in b {
            assert!(
                (v(c) - y).dot(&-dir) >= -1e-9 * (1.0 + dir.norm()),
                "{what}: not least on b"
            );
        }
    }

    /// Whether `d`'s nearest points on `a` and `b` are shown by a separating slab, every
    /// corner tested.
    fn ends_at_slab(a: &Triangle, b: &Triangle, d: &TriangleDistance) -> bool {
        let (pa, pb) = (a.map(|p| v(&p)), b.map(|p| v(&p)));
        separated_at(&pa, &pb, &v(&d.on_a), &v(&d.on_b), [false; 3], [false; 3])
    }

    /// `d` measures `a` against `b` as `all` (all fifteen features) does, to 1e-12 mm of its
    /// size, and its points are certified.
    fn assert_agrees(
        a: &Triangle,
        b: &Triangle,
        d: &TriangleDistance,
        all: &TriangleDistance,
        what: &str,
    ) {
        assert!(
            (d.distance - all.distance).abs() <= 1e-12 * (1.0 + all.distance),
            "{what}: {} against {}",
            d.distance,
            all.distance
        );
        assert_eq!(d.meet, all.meet, "{what}");
        assert_certified(a, b, d, what);
    }

    /// The least distance over a grid of barycentric points of both triangles.
    fn sampled(a: &Triangle, b: &Triangle, n: usize) -> f64 {
        let points = |t: &Triangle| {
            let mut p = Vec::new();
            for i in 0..=n {
                for j in 0..=n - i {
                    let (u, w) = (i as f64 / n as f64, j as f64 / n as f64);
                    p.push(v(&t[0]) * (1.0 - u - w) + v(&t[1]) * u + v(&t[2]) * w);
                }
            }
            p
        };
        let (pa, pb) = (points(a), points(b));
        pa.iter()
            .flat_map(|x| pb.iter().map(move |y| (x - y).norm()))
            .fold(f64::INFINITY, f64::min)
    }

    #[test]
    fn random_triangle_pairs_are_certified_and_never_above_a_sampled_minimum() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(7);
        for case in 0..3000 {
            let gap = rng.random_range(0.0..3.0);
            let a = random_triangle(&mut rng, [0.0; 3], 1.0);
            let b = random_triangle(&mut rng, [gap, 0.3 * gap, 0.0], 1.0);
            let d = triangle_distance(&a, &b);
            assert_certified(&a, &b, &d, &format!("case {case}"));
            if case % 30 == 0 {
                let s = sampled(&a, &b, 40);
                assert!(
                    d.distance <= s + 1e-12,
                    "case {case}: {} above sampled {s}",
                    d.distance
                );
                // The grid's spacing bounds how far its least distance is above the true one.
                assert!(
                    s - d.distance <= 0.15,
                    "case {case}: {} far below sampled {s}",
                    d.distance
                );
            }
            // The distance is symmetric.
            let e = triangle_distance(&b, &a);
            assert!(
                (e.distance - d.distance).abs() <= 1e-12,
                "case {case}: not symmetric"
            );
        }
    }

    /// Pairs where the early answers fire: faces over faces (parallel and tilted, slid about),
    /// fans meeting at a shared corner's image, skew edges, and random pairs. The fast distance
    /// equals the all-features one to rounding, its points certify themselves, and each early
    /// answer is taken on some of them (a wrong early test fails the comparison).
    #[test]
    fn early_answers_equal_the_all_features_distance() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(11);
        let (mut face, mut edge, mut total) = (0, 0, 0);
        for case in 0..4000 {
            let a = random_triangle(&mut rng, [0.0; 3], 1.0);
            let gap = 10f64.powf(rng.random_range(-4.0..0.0));
            let b: Triangle = match case % 4 {
                // A face over a face: b is a slid, slightly turned copy of a lifted along
                // a's normal.
                0 => {
                    let (a0, a1, a2) = (v(&a[0]), v(&a[1]), v(&a[2]));
                    let n = (a1 - a0).cross(&(a2 - a0)).normalize();
                    let shift = V::new(
                        rng.random_range(-0.5..0.5),
                        rng.random_range(-0.5..0.5),
                        rng.random_range(-0.5..0.5),
                    );
                    let tilt = rng.random_range(-0.01..0.01);
                    a.map(|p| {
                        let q = v(&p) + shift - n * shift.dot(&n) + n * gap;
                        (q + n * tilt * (v(&p) - a0).norm()).into()
                    })
                }
                // A fan's corner over another's: b's first corner just above a's first.
                1 => {
                    let mut b = random_triangle(&mut rng, [0.0, 0.0, 1.0], 1.0);
                    b[0] = [a[0][0], a[0][1], a[0][2] + gap];
                    // The rest of b away from a, as the other side of a ball's pole.
                    for c in b.iter_mut().skip(1) {
                        c[2] = a[0][2] + gap + c[2].abs() + 0.1;
                    }
                    b
                }
                _ => {
                    let along = rng.random_range(-2.0..2.0);
                    random_triangle(&mut rng, [along, 0.0, 1.5], 1.0)
                }
            };
            for (x, y) in [(&a, &b), (&b, &a)] {
                let fast = triangle_distance(x, y);
                let all = triangle_distance_all_features(x, y);
                assert_agrees(x, y, &fast, &all, &format!("case {case}"));
                // Which early answer applies (each is a sufficient condition, checked above
                // against the full search).
                let (px, py) = (x.map(|p| v(&p)), y.map(|p| v(&p)));
                let (nx, ny) = (
                    (px[1] - px[0]).cross(&(px[2] - px[0])),
                    (py[1] - py[0]).cross(&(py[2] - py[0])),
                );
                let x_over_y = px.map(|p| ny.dot(&(p - py[0])));
                let y_over_x = py.map(|p| nx.dot(&(p - px[0])));
                if !fast.meet {
                    if corner_over_face(&px, &py, &ny, &x_over_y).is_some()
                        || corner_over_face(&py, &px, &nx, &y_over_x).is_some()
                    {
                        face += 1;
                    } else if ends_at_slab(x, y, &fast) {
                        edge += 1;
                    }
                }
                total += 1;
            }
        }
        // Both early answers are exercised, on a good share of the pairs.
        assert!(
            total == 8000 && face > 500 && edge > 1000,
            "face {face}, edge {edge} of {total}"
        );
    }

    #[test]
    fn any_edge_pair_tried_first_gives_the_same_distance_and_a_slid_pair_keeps_its_edges() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(17);
        let mut named = 0;
        for case in 0..1000 {
            let a = random_triangle(&mut rng, [0.0; 3], 1.0);
            let along = rng.random_range(-1.5..1.5);
            let b = random_triangle(&mut rng, [along, 0.0, 1.2], 1.0);
            let all = triangle_distance_all_features(&a, &b);
            for k in 0..=9u8 {
                let mut last = NearestEdges(k);
                let d = triangle_distance_from(&a, &b, &mut last);
                assert_agrees(&a, &b, &d, &all, &format!("case {case}, tried {k} first"));
                if let Some((i, j)) = last.edges() {
                    // The pair it names is the answer's.
                    let (pa, pb) = (a.map(|p| v(&p)), b.map(|p| v(&p)));
                    let (x, y) =
                        closest_segments(&pa[i], &pa[(i + 1) % 3], &pb[j], &pb[(j + 1) % 3]);
                    assert!(((y - x).norm() - d.distance).abs() <= 1e-12, "case {case}");
                    named += 1;
                }
            }
        }
        assert!(named > 2000, "edge answers named: {named}");
        // Skew edges slid along each other keep their nearest edges frame after frame.
        let mut last = NearestEdges::NONE;
        for step in 0..50 {
            let s = -0.3 + 0.012 * f64::from(step);
            let a = [[-1.0, s, 0.0], [1.0, s, 0.0], [0.0, s, -1.0]];
            let b = [[s, -1.0, 0.05], [s, 1.0, 0.05], [0.0, s, 1.05]];
            let d = triangle_distance_from(&a, &b, &mut last);
            assert!(
                (d.distance - 0.05).abs() <= 1e-12,
                "step {step}: {}",
                d.distance
            );
            assert_eq!(last, NearestEdges::of(0, 0), "step {step}");
        }
    }

    #[test]
    fn faces_lying_on_each_other_far_from_the_origin_end_at_their_edges() {
        // Long thin triangles (as merged flat faces are) in parallel planes a little apart,
        // 50 mm out and turned anyhow, crossing in projection so that no corner lies over
        // the other face: the nearest points are on their edges, and every pair ends at the
        // separating slab there (measured against all fifteen features).
        let mut rng = rand::rngs::StdRng::seed_from_u64(5);
        let mut early = 0;
        for case in 0..500 {
            let gap = 10f64.powf(rng.random_range(-3.0..-1.0));
            let axis = V::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            );
            let turn = nalgebra::Rotation3::new(axis.normalize() * rng.random_range(0.0..3.0));
            let out = V::new(
                rng.random_range(-50.0..50.0),
                rng.random_range(-50.0..50.0),
                rng.random_range(-50.0..50.0),
            );
            let place = |p: [f64; 3]| -> [f64; 3] { (turn * v(&p) + out).into() };
            let long = rng.random_range(10.0..40.0);
            // A thin sliver along x, and one across it along y, above it by `gap`.
            let a = [[-long, -0.5, 0.0], [long, -0.3, 0.0], [long, 0.4, 0.0]].map(place);
            let b = [[-0.6, -long, gap], [0.3, long, gap], [0.5, long, gap]].map(place);
            for (x, y) in [(&a, &b), (&b, &a)] {
                let fast = triangle_distance(x, y);
                let all = triangle_distance_all_features(x, y);
                assert!(
                    (fast.distance - all.distance).abs() <= 1e-9,
                    "case {case}: {} against {}",
                    fast.distance,
                    all.distance
                );
                assert!((fast.distance - gap).abs() <= 1e-9, "case {case}: the gap");
                if ends_at_slab(x, y, &fast) {
                    early += 1;
                }
            }
        }
        assert_eq!(early, 1000, "pairs ended at the slab");
    }

    #[test]
    fn degenerate_cases_are_exact() {
        let t = |p: [[f64; 3]; 3]| p;
        let cases: Vec<(&str, Triangle, Triangle, f64)> = vec![
            // Parallel edges, 0.5 apart, overlapping along their length.
            (
                "parallel edges",
                t([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [1.0, -1.0, 0.0]]),
                t([[0.5, 0.5, 0.0], [2.5, 0.5, 0.0], [1.5, 1.5, 0.0]]),
                0.5,
            ),
            // Coplanar faces, separated.
            (
                "coplanar apart",
                t([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]),
                t([[2.0, 0.0, 0.0], [3.0, 0.0, 0.0], [2.0, 1.0, 0.0]]),
                1.0,
            ),
            // Coplanar faces overlapping: they meet.
            (
                "coplanar overlapping",
                t([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]]),
                t([[0.5, 0.5, 0.0], [3.0, 0.5, 0.0], [0.5, 3.0, 0.0]]),
                0.0,
            ),
            // Parallel faces one above the other (every point of the overlap is nearest).
            (
                "stacked faces",
                t([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]]),
                t([[0.2, 0.2, 0.25], [1.5, 0.2, 0.25], [0.2, 1.5, 0.25]]),
                0.25,
            ),
            // Touching at a vertex.
            (
                "touching vertices",
                t([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]),
                t([[1.0, 0.0, 0.0], [2.0, 0.0, 1.0], [2.0, 1.0, 0.0]]),
                0.0,
            ),
            // A vertex on the other's face.
            (
                "vertex on face",
                t([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]]),
                t([[0.5, 0.5, 0.0], [0.5, 0.5, 1.0], [1.0, 0.5, 1.0]]),
                0.0,
            ),
            // Crossing through each other's interiors.
            (
                "crossing",
                t([[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [0.0, 1.0, 0.0]]),
                t([[0.0, 0.0, -1.0], [0.1, 0.0, 1.0], [0.0, 0.2, 1.0]]),
                0.0,
            ),
            // A vertex above a face's interior.
            (
                "vertex over face",
                t([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]]),
                t([[0.5, 0.5, 0.3], [0.5, 0.5, 2.0], [1.0, 0.5, 2.0]]),
                0.3,
            ),
            // Skew edges crossing at a distance.
            (
                "skew edges",
                t([[-1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, -1.0, -1.0]]),
                t([[0.0, -1.0, 0.7], [0.0, 1.0, 0.7], [0.0, 0.0, 2.0]]),
                0.7,
            ),
            // A degenerate triangle (a segment) above a face.
            (
                "segment triangle",
                t([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]]),
                t([[0.5, 0.5, 0.4], [0.5, 0.5, 0.4], [0.7, 0.5, 0.9]]),
                0.4,
            ),
            // A point triangle.
            (
                "point triangle",
                t([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]]),
                t([[3.0, 0.0, 0.0], [3.0, 0.0, 0.0], [3.0, 0.0, 0.0]]),
                1.0,
            ),
        ];
        for (what, a, b, want) in cases {
            for (x, y) in [(&a, &b), (&b, &a)] {
                let d = triangle_distance(x, y);
                assert!(
                    (d.distance - want).abs() <= 1e-9,
                    "{what}: {} against {want}",
                    d.distance
                );
                assert_eq!(d.meet, want == 0.0, "{what}");
                assert_certified(x, y, &d, what);
            }
        }
    }
}
