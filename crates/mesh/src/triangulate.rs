//! Splitting a polygon (a face of a file, or the loop around a hole) into triangles.
//!
//! Small polygons are split by a fan from their first vertex. A fan of a large polygon is a
//! set of long slivers that all meet at one vertex: the box of every sliver reaches across
//! the polygon, so a bounding-volume hierarchy cannot separate them and every distance or
//! winding-number query near the polygon tests all of them (quadratic offline cost). Large
//! polygons are therefore split level by level instead: each pass clips every other vertex
//! as an ear `(v[i], v[i+1], v[i+2])`, halving the polygon, so the triangles of a pass are
//! about twice the size of the previous pass's and each stays local to its stretch of the
//! boundary. A point then lies in the boxes of a few triangles per pass, `O(log n)` in all.

/// Polygons with at most this many vertices are split by a fan from their first vertex
/// (quads and other small faces are split as they always were).
pub const FAN_MAX_VERTICES: usize = 16;

/// Appends to `out` the `poly.len() - 2` triangles of `poly` (vertex indices, in order),
/// oriented like the polygon.
///
/// `flat(t)` tells a zero-area triangle: such an ear is not clipped (its middle vertex stays
/// for a later pass), so collinear runs along the boundary mostly end up inside triangles
/// of non-zero area. A pass that clips less than a quarter of the vertices is followed by
/// one that clips every other vertex regardless, so the cost stays `O(n)`; the caller drops
/// the zero-area triangles that remain, as it does for any face. Polygons of up to
/// [`FAN_MAX_VERTICES`] vertices get the fan from their first vertex.
pub fn triangulate_polygon(poly: &[u32], flat: impl Fn([u32; 3]) -> bool, out: &mut Vec<[u32; 3]>) {
    if poly.len() < 3 {
        return;
    }
    if poly.len() <= FAN_MAX_VERTICES {
        fan(poly, out);
        return;
    }
    let mut current = poly.to_vec();
    let mut next = Vec::with_capacity(current.len() / 2 + 2);
    let mut avoid_flat = true;
    while current.len() > 3 {
        next.clear();
        let m = current.len();
        let mut i = 0;
        while i + 2 < m {
            let ear = [current[i], current[i + 1], current[i + 2]];
            next.push(current[i]);
            if avoid_flat && flat(ear) {
                // Keep the middle vertex; try the ear that starts there.
                i += 1;
            } else {
                out.push(ear);
                i += 2;
            }
        }
        next.extend_from_slice(&current[i..]);
        // A pass held back by long collinear runs is followed by one that clips regardless,
        // so the number of passes stays logarithmic.
        avoid_flat = m - next.len() >= m / 4;
        std::mem::swap(&mut current, &mut next);
    }
    out.push([current[0], current[1], current[2]]);
}

/// The fan from the first vertex: `(p0, p[k], p[k+1])` for every `k`.
fn fan(poly: &[u32], out: &mut Vec<[u32; 3]>) {
    for k in 1..poly.len() - 1 {
        out.push([poly[0], poly[k], poly[k + 1]]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    /// Every edge of the result is used once in each direction, except the polygon's own
    /// edges, used once in the polygon's direction: a consistently oriented disk.
    fn assert_disk(poly: &[u32], tris: &[[u32; 3]]) {
        assert_eq!(tris.len(), poly.len() - 2);
        let mut uses: HashMap<(u32, u32), i32> = HashMap::new();
        for t in tris {
            for k in 0..3 {
                *uses.entry((t[k], t[(k + 1) % 3])).or_default() += 1;
            }
        }
        for k in 0..poly.len() {
            let e = (poly[k], poly[(k + 1) % poly.len()]);
            assert_eq!(uses.remove(&e), Some(1), "boundary edge {e:?}");
        }
        for (&(a, b), &n) in &uses {
            assert_eq!(n, 1, "edge {a}->{b} used {n} times");
            assert_eq!(uses.get(&(b, a)), Some(&1), "edge {a}->{b} has no twin");
        }
    }

    #[test]
    fn small_polygons_keep_the_fan_and_large_ones_form_a_disk() {
        let mut out = Vec::new();
        triangulate_polygon(&[0, 1, 2, 3], |_| false, &mut out);
        assert_eq!(out, vec![[0, 1, 2], [0, 2, 3]]);
        for n in [17u32, 18, 31, 64, 1000, 1025] {
            let poly: Vec<u32> = (0..n).collect();
            let mut out = Vec::new();
            triangulate_polygon(&poly, |_| false, &mut out);
            assert_disk(&poly, &out);
        }
    }

    #[test]
    fn a_midpoint_on_an_edge_is_not_clipped_as_a_flat_ear() {
        // A regular 40-gon with a midpoint inserted on every third edge.
        let mut pts: Vec<[f64; 2]> = Vec::new();
        let corner = |k: u32| {
            let a = f64::from(k) * std::f64::consts::TAU / 40.0;
            [a.cos(), a.sin()]
        };
        for k in 0..40 {
            let (p, q) = (corner(k), corner(k + 1));
            pts.push(p);
            if k % 3 == 0 {
                pts.push([(p[0] + q[0]) / 2.0, (p[1] + q[1]) / 2.0]);
            }
        }
        let flat = |t: [u32; 3]| {
            let [a, b, c] = t.map(|i| pts[i as usize]);
            ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])).abs() < 1e-12
        };
        let poly: Vec<u32> = (0..pts.len() as u32).collect();
        let mut out = Vec::new();
        triangulate_polygon(&poly, flat, &mut out);
        assert_disk(&poly, &out);
        assert!(out.iter().all(|&t| !flat(t)), "a flat triangle was made");
    }
}
