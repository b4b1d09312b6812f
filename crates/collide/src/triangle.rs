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
    let (d1, d2, r) = (q1 - p1, q2 - p2, p1 - p2);
    let (a, e, f) = (d1.norm_squared(), d2.norm_squared(), d2.dot(&r));
    if a <= 0.0 && e <= 0.0 {
        return (*p1, *p2);
    }
    let (s, t) = if a <= 0.0 {
        (0.0, (f / e).clamp(0.0, 1.0))
    } else {
        let c = d1.dot(&r);
        if e <= 0.0 {
            ((-c / a).clamp(0.0, 1.0), 0.0)
        } else {
            let b = d1.dot(&d2);
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
    (p1 + d1 * s, p2 + d2 * t)
}

/// Where the segment `p q` crosses the triangle `(a, b, c)`, if it does (a point of both).
fn segment_crosses(p: &V, q: &V, a: &V, b: &V, c: &V) -> Option<V> {
    let n = (b - a).cross(&(c - a));
    if n.norm_squared() <= DEGENERATE_AREA2 {
        return None;
    }
    let (dp, dq) = (n.dot(&(p - a)), n.dot(&(q - a)));
    if (dp > 0.0 && dq > 0.0) || (dp < 0.0 && dq < 0.0) || dp == dq {
        // Both on one side, or in the plane (then an edge-edge or vertex case finds it).
        return None;
    }
    let x = p + (q - p) * (dp / (dp - dq));
    // Inside when x is on the inner side of all three edges.
    let inside = |u: &V, w: &V| n.dot(&(w - u).cross(&(x - u))) >= 0.0;
    (inside(a, b) && inside(b, c) && inside(c, a)).then_some(x)
}

/// The exact distance between the triangles `a` and `b` and their nearest points.
///
/// # Real-time
/// No allocation, no panic, constant time (15 feature pairs and 6 edge crossings).
pub fn triangle_distance(a: &Triangle, b: &Triangle) -> TriangleDistance {
    let (pa, pb) = (a.map(|p| v(&p)), b.map(|p| v(&p)));
    // An edge of one crossing the other: they meet. (Only where its corners are not all on
    // one side of the other's plane.)
    for (s, t) in [(&pa, &pb), (&pb, &pa)] {
        let n = (t[1] - t[0]).cross(&(t[2] - t[0]));
        let side = s.map(|p| n.dot(&(p - t[0])));
        if side.iter().all(|&d| d > 0.0) || side.iter().all(|&d| d < 0.0) {
            continue;
        }
        for k in 0..3 {
            if let Some(x) = segment_crosses(&s[k], &s[(k + 1) % 3], &t[0], &t[1], &t[2]) {
                return TriangleDistance {
                    distance: 0.0,
                    on_a: x.into(),
                    on_b: x.into(),
                    meet: true,
                };
            }
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
    let distance = best.0.sqrt();
    TriangleDistance {
        distance,
        on_a: best.1.into(),
        on_b: best.2.into(),
        meet: distance == 0.0,
    }
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
