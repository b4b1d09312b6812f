//! Flat faces merged: the neighbouring triangles of a mesh that lie in one plane and together
//! make one convex polygon are cut again into the fewest triangles, the surface unchanged
//! (docs/DESIGN.md §Mesh-exact contact).
//!
//! A machined part's mesh often cuts a flat face into many triangles (a cylinder's facets into
//! rings along its length, a box's sides into a grid): every triangle pair of two such faces
//! lying on each other is a pair the narrow phase lists, filters and measures, and a row the
//! solver takes, where the faces are two. The polygon's corners are the merged triangles' outer
//! corners less those on a straight side; its triangles are every point of the old ones and
//! no other, so every distance the narrow phase measures is the same. Set-up only: allocates.

use std::collections::HashMap;

use crate::triangle::Triangle;

/// What [`merge_flat_faces`] did: the triangles to use and how many flat faces it merged.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FlatFaces {
    /// The mesh's triangles, each merged face's cut anew (its first triangle's place in the
    /// list), the others as given, mm.
    pub triangles: Vec<Triangle>,
    /// Faces merged (each of at least three triangles, now at most half as many).
    pub merged_faces: usize,
}

/// Farthest a corner may lie off a merged face's plane, and off the straight side it is dropped
/// from, mm: roundings of the coordinates, far below any distance the engine tells apart
/// (its penetration tolerance is 0.005 mm).
pub const FLAT_TOLERANCE_MM: f64 = 1e-9;

/// The triangles of `vertices` (mm) and `triangles` (indices) with every flat face merged:
/// neighbours across an edge that exactly two triangles share, walked in opposite directions
/// (the mesh's orientation agrees), whose corners all lie within [`FLAT_TOLERANCE_MM`] of one
/// plane with the same facing, are one face; a face of at least three triangles whose outline
/// is one loop, convex once the corners on its straight sides are dropped, and whose area the
/// new triangles keep, is cut into a strip of `corners − 2` triangles where that halves the
/// count at least. Anything else (a face with a hole, a bent outline, a degenerate triangle) is
/// kept as given. Indices out of range are the caller's to check (they panic).
pub fn merge_flat_faces(vertices: &[[f64; 3]], triangles: &[[u32; 3]]) -> FlatFaces {
    let corner = |t: usize, k: usize| vertices[triangles[t][k] as usize];
    let normals: Vec<Option<[f64; 3]>> = (0..triangles.len())
        .map(|t| {
            unit(cross(
                sub(corner(t, 1), corner(t, 0)),
                sub(corner(t, 2), corner(t, 0)),
            ))
        })
        .collect();

    // Directed edges: a manifold edge is walked once each way.
    let mut directed: HashMap<(u32, u32), Vec<usize>> = HashMap::new();
    for (t, tri) in triangles.iter().enumerate() {
        for k in 0..3 {
            directed
                .entry((tri[k], tri[(k + 1) % 3]))
                .or_default()
                .push(t);
        }
    }
    let mut parent: Vec<usize> = (0..triangles.len()).collect();
    for (t, tri) in triangles.iter().enumerate() {
        let Some(nt) = normals[t] else { continue };
        for k in 0..3 {
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            if a > b {
                continue; // each undirected edge once
            }
            let (Some(ab), Some(ba)) = (directed.get(&(a, b)), directed.get(&(b, a))) else {
                continue;
            };
            if ab.len() != 1 || ba.len() != 1 {
                continue;
            }
            let u = ba[0];
            let Some(nu) = normals[u] else { continue };
            // Same facing, and each far corner on the other's plane.
            let far_u = triangles[u].into_iter().find(|&i| i != a && i != b);
            let far_t = tri[(k + 2) % 3];
            let on_plane = |n: [f64; 3], at: [f64; 3], i: u32| {
                dot(n, sub(vertices[i as usize], at)).abs() <= FLAT_TOLERANCE_MM
            };
            if dot(nt, nu) > 0.5
                && far_u.is_some_and(|i| on_plane(nt, corner(t, 0), i))
                && on_plane(nu, corner(u, 0), far_t)
            {
                union(&mut parent, t, u);
            }
        }
    }

    let mut faces: HashMap<usize, Vec<usize>> = HashMap::new();
    for t in 0..triangles.len() {
        let root = find(&mut parent, t);
        faces.entry(root).or_default().push(t);
    }
    // The triangles that replace each merged face, keyed by the face's first triangle.
    let mut replaced: HashMap<usize, Vec<Triangle>> = HashMap::new();
    let mut dropped = vec![false; triangles.len()];
    for members in faces.values() {
        if members.len() < 3 {
            continue;
        }
        let Some(cut) = recut(vertices, triangles, members, &normals) else {
            continue;
        };
        let first = *members.iter().min().expect("a face has triangles");
        for &t in members {
            dropped[t] = true;
        }
        replaced.insert(first, cut);
    }
    let mut out = Vec::with_capacity(triangles.len());
    for t in 0..triangles.len() {
        if let Some(cut) = replaced.get(&t) {
            out.extend_from_slice(cut);
        } else if !dropped[t] {
            out.push([corner(t, 0), corner(t, 1), corner(t, 2)]);
        }
    }
    FlatFaces {
        triangles: out,
        merged_faces: replaced.len(),
    }
}

/// The face of `members` cut into a strip over its convex outline, or `None` where it must be
/// kept as given (see [`merge_flat_faces`]).
fn recut(
    vertices: &[[f64; 3]],
    triangles: &[[u32; 3]],
    members: &[usize],
    normals: &[Option<[f64; 3]>],
) -> Option<Vec<Triangle>> {
    let normal = normals[members[0]]?;
    let origin = vertices[triangles[members[0]][0] as usize];
    let mut area = 0.0;
    let mut inner: HashMap<(u32, u32), u32> = HashMap::new();
    for &t in members {
        let tri = triangles[t];
        let p = tri.map(|i| vertices[i as usize]);
        if p.iter()
            .any(|&q| dot(normal, sub(q, origin)).abs() > FLAT_TOLERANCE_MM)
        {
            return None; // a gentle bend, each step within the tolerance
        }
        area += dot(normal, cross(sub(p[1], p[0]), sub(p[2], p[0]))) / 2.0;
        for k in 0..3 {
            *inner.entry((tri[k], tri[(k + 1) % 3])).or_default() += 1;
        }
    }
    // The outline: edges not walked back by another member.
    let mut next: HashMap<u32, u32> = HashMap::new();
    for (&(a, b), &n) in &inner {
        if n != 1 {
            return None;
        }
        if inner.contains_key(&(b, a)) {
            continue;
        }
        if next.insert(a, b).is_some() {
            return None; // two outline edges leave one corner: not one simple loop
        }
    }
    let &start = next.keys().min()?;
    let mut outline = vec![start];
    let mut at = next[&start];
    while at != start {
        if outline.len() > next.len() {
            return None;
        }
        outline.push(at);
        at = *next.get(&at)?;
    }
    if outline.len() != next.len() {
        return None; // more than one loop: a face with a hole
    }
    let mut poly: Vec<[f64; 3]> = outline.iter().map(|&i| vertices[i as usize]).collect();
    // Drop the corners on a straight side (repeat: dropping one may straighten no other, but
    // runs of them go one by one).
    let mut i = 0;
    while poly.len() > 3 && i < poly.len() {
        let n = poly.len();
        let (prev, here, next) = (poly[(i + n - 1) % n], poly[i], poly[(i + 1) % n]);
        let side = sub(next, prev);
        let len = norm(side);
        let off = norm(cross(side, sub(here, prev))) / len.max(f64::MIN_POSITIVE);
        let along = dot(side, sub(here, prev));
        if len > 0.0 && off <= FLAT_TOLERANCE_MM && along > 0.0 && along < len * len {
            poly.remove(i);
            i = i.saturating_sub(1);
        } else {
            i += 1;
        }
    }
    let n = poly.len();
    if n < 3 || 2 * (n - 2) > members.len() {
        return None;
    }
    // Convex: every corner turns the outline's way by more than the tolerance.
    for i in 0..n {
        let (prev, here, next) = (poly[(i + n - 1) % n], poly[i], poly[(i + 1) % n]);
        let turn = dot(normal, cross(sub(here, prev), sub(next, here)));
        if turn <= FLAT_TOLERANCE_MM * (norm(sub(here, prev)) + norm(sub(next, here))) {
            return None;
        }
    }
    // A strip that zig-zags from both ends: better shaped than a fan from one corner.
    let order: Vec<usize> = (0..n)
        .map(|k| if k % 2 == 0 { k / 2 } else { n - 1 - k / 2 })
        .collect();
    let mut cut = Vec::with_capacity(n - 2);
    for w in order.windows(3) {
        let (a, b, c) = (poly[w[0]], poly[w[1]], poly[w[2]]);
        // Keep the outline's orientation (the strip alternates).
        let tri = if dot(normal, cross(sub(b, a), sub(c, a))) >= 0.0 {
            [a, b, c]
        } else {
            [a, c, b]
        };
        cut.push(tri);
    }
    let new_area: f64 = cut
        .iter()
        .map(|t| dot(normal, cross(sub(t[1], t[0]), sub(t[2], t[0]))) / 2.0)
        .sum();
    let size = cut
        .iter()
        .flat_map(|t| t.iter())
        .map(|&p| norm(sub(p, origin)))
        .fold(1.0, f64::max);
    if (new_area - area).abs() > 1e-9 * size * size || new_area <= 0.0 {
        return None;
    }
    Some(cut)
}

fn find(parent: &mut [usize], mut i: usize) -> usize {
    while parent[i] != i {
        parent[i] = parent[parent[i]];
        i = parent[i];
    }
    i
}

fn union(parent: &mut [usize], a: usize, b: usize) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    if ra != rb {
        parent[ra.max(rb)] = ra.min(rb);
    }
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

/// The unit vector along `a`, or `None` for a (near) zero one (a degenerate triangle).
fn unit(a: [f64; 3]) -> Option<[f64; 3]> {
    let n = norm(a);
    (n > 1e-300 && n.is_finite()).then(|| [a[0] / n, a[1] / n, a[2] / n])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::triangle::closest_on_triangle;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn posed(m: &mesh::TriMesh) -> Vec<Triangle> {
        m.triangles
            .iter()
            .map(|t| t.map(|i| m.vertices[i as usize]))
            .collect()
    }

    fn area(tris: &[Triangle]) -> f64 {
        tris.iter()
            .map(|t| norm(cross(sub(t[1], t[0]), sub(t[2], t[0]))) / 2.0)
            .sum()
    }

    /// Largest distance from a point sampled on one set's triangles (corners, edge midpoints,
    /// random inner points) to the other set's nearest triangle, mm.
    fn farthest_off(from: &[Triangle], to: &[Triangle], rng: &mut ChaCha8Rng) -> f64 {
        let mut worst: f64 = 0.0;
        for t in from {
            let mut points = vec![t[0], t[1], t[2]];
            for _ in 0..6 {
                let (mut u, mut v): (f64, f64) = (rng.random(), rng.random());
                if u + v > 1.0 {
                    (u, v) = (1.0 - u, 1.0 - v);
                }
                points.push(std::array::from_fn(|k| {
                    t[0][k] + u * (t[1][k] - t[0][k]) + v * (t[2][k] - t[0][k])
                }));
            }
            for p in points {
                let d = to
                    .iter()
                    .map(|s| norm(sub(closest_on_triangle(&p, s), p)))
                    .fold(f64::INFINITY, f64::min);
                worst = worst.max(d);
            }
        }
        worst
    }

    fn assert_same_surface(before: &[Triangle], after: &[Triangle]) {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let (a, b) = (area(before), area(after));
        assert!((a - b).abs() <= 1e-9 * a, "area {a} -> {b}");
        let off = farthest_off(before, after, &mut rng).max(farthest_off(after, before, &mut rng));
        assert!(off <= 1e-9, "the surfaces differ by {off} mm");
    }

    #[test]
    fn a_boxs_grid_faces_become_two_triangles_each() {
        let m = mesh::generate::grid_box([1.0, -2.0, 0.5], [3.0, 2.0, 1.0], 5);
        let merged = merge_flat_faces(&m.vertices, &m.triangles);
        assert_eq!(merged.merged_faces, 6);
        assert_eq!(merged.triangles.len(), 12);
        assert_same_surface(&posed(&m), &merged.triangles);
        // Outward as given: each new triangle's normal points away from the box's centre.
        for t in &merged.triangles {
            let n = cross(sub(t[1], t[0]), sub(t[2], t[0]));
            let c = [
                (t[0][0] + t[1][0] + t[2][0]) / 3.0 - 1.0,
                (t[0][1] + t[1][1] + t[2][1]) / 3.0 + 2.0,
                (t[0][2] + t[1][2] + t[2][2]) / 3.0 - 0.5,
            ];
            assert!(dot(n, c) > 0.0, "a merged triangle turned inwards: {t:?}");
        }
    }

    #[test]
    fn a_cylinders_ringed_facets_become_strips_and_its_fan_caps_stay() {
        // 24 facets around, rings every 1 mm along 10 mm: each facet is 20 triangles.
        let profile: Vec<(f64, f64)> = std::iter::once((0.0, 0.0))
            .chain((0..=10).map(|i| (2.0, f64::from(i))))
            .chain([(0.0, 10.0)])
            .collect();
        let m = mesh::generate::lathe(&profile, 24);
        let before = posed(&m);
        let merged = merge_flat_faces(&m.vertices, &m.triangles);
        assert_eq!(merged.merged_faces, 24, "one face per facet");
        // The caps' fans (24 triangles each, a 24-gon's 22 at best) are kept as given.
        let side = before.len() - merged.triangles.len();
        assert_eq!(
            side,
            24 * (20 - 2),
            "{} -> {}",
            before.len(),
            merged.triangles.len()
        );
        assert_same_surface(&before, &merged.triangles);
    }

    #[test]
    fn bent_holed_and_curved_faces_are_kept_as_given() {
        // A sphere: no two neighbours in one plane.
        let s = mesh::generate::uv_sphere(5.0, 12, 16);
        let merged = merge_flat_faces(&s.vertices, &s.triangles);
        assert_eq!(
            (merged.merged_faces, merged.triangles.len()),
            (0, s.triangles.len())
        );
        // An L-shaped flat sheet (a bent outline) and a square frame (a face with a hole):
        // grids of unit squares with cells left out.
        let sheet = |keep: &dyn Fn(u32, u32) -> bool| {
            let mut v = Vec::new();
            for j in 0..=4u32 {
                for i in 0..=4u32 {
                    v.push([f64::from(i), f64::from(j), 0.0]);
                }
            }
            let mut t = Vec::new();
            for j in 0..4u32 {
                for i in 0..4u32 {
                    if keep(i, j) {
                        let c = |a: u32, b: u32| b * 5 + a;
                        t.push([c(i, j), c(i + 1, j), c(i + 1, j + 1)]);
                        t.push([c(i, j), c(i + 1, j + 1), c(i, j + 1)]);
                    }
                }
            }
            (v, t)
        };
        let (v, t) = sheet(&|i, j| i < 2 || j < 2);
        assert_eq!(merge_flat_faces(&v, &t).triangles.len(), t.len(), "the L");
        let (v, t) = sheet(&|i, j| !(1..3).contains(&i) || !(1..3).contains(&j));
        assert_eq!(
            merge_flat_faces(&v, &t).triangles.len(),
            t.len(),
            "the frame"
        );
        let (v, t) = sheet(&|_, _| true);
        let whole = merge_flat_faces(&v, &t);
        assert_eq!(
            (whole.merged_faces, whole.triangles.len()),
            (1, 2),
            "the whole square"
        );
        // The same square bent by 1e-6 mm along its middle: each neighbour pair's corners lie
        // within the tolerance of its plane only where the bend is not.
        let mut bent = v.clone();
        for p in &mut bent {
            p[2] = 1e-6 * (p[0] - 2.0).abs();
        }
        let kept = merge_flat_faces(&bent, &t);
        assert_same_surface(
            &t.iter()
                .map(|x| x.map(|i| bent[i as usize]))
                .collect::<Vec<_>>(),
            &kept.triangles,
        );
        assert_eq!(
            kept.merged_faces, 2,
            "each flat half merged, not across the bend"
        );
    }
}
