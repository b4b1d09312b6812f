//! Generated test meshes of any size: spheres, tori, boxes, and the damaged meshes people
//! bring (open, holed, self-intersecting), for tests and the build-time studies.
//!
//! Entry points: [`uv_sphere`], [`torus`], [`grid_box`], [`open_box`], [`two_boxes`],
//! [`remove_fraction`]; for the scene zoo's parts [`lathe`], [`rod`], [`extrude`],
//! [`height_field_block`]. Every mesh is counter-clockwise seen from outside; sizes are in the
//! mesh's own (arbitrary) units.

use crate::TriMesh;
use std::f64::consts::PI;

/// A sphere of `radius` centred on the origin with `rings` (≥ 2) latitude bands and
/// `segments` (≥ 3) longitude segments: `2 · segments · (rings − 1)` triangles, closed.
pub fn uv_sphere(radius: f64, rings: u32, segments: u32) -> TriMesh {
    let rings = rings.max(2);
    let segments = segments.max(3);
    let mut vertices = vec![[0.0, 0.0, radius]];
    for i in 1..rings {
        let theta = PI * i as f64 / rings as f64;
        for j in 0..segments {
            let phi = 2.0 * PI * j as f64 / segments as f64;
            vertices.push([
                radius * theta.sin() * phi.cos(),
                radius * theta.sin() * phi.sin(),
                radius * theta.cos(),
            ]);
        }
    }
    vertices.push([0.0, 0.0, -radius]);
    let south = (vertices.len() - 1) as u32;
    let ring = |i: u32, j: u32| 1 + (i - 1) * segments + j % segments;
    let mut triangles = Vec::with_capacity(2 * (segments * (rings - 1)) as usize);
    for j in 0..segments {
        triangles.push([0, ring(1, j), ring(1, j + 1)]);
        triangles.push([south, ring(rings - 1, j + 1), ring(rings - 1, j)]);
    }
    for i in 1..rings - 1 {
        for j in 0..segments {
            let (a, b) = (ring(i, j), ring(i, j + 1));
            let (c, d) = (ring(i + 1, j), ring(i + 1, j + 1));
            triangles.push([a, c, d]);
            triangles.push([a, d, b]);
        }
    }
    TriMesh {
        vertices,
        triangles,
    }
}

/// A sphere of `radius` with about `triangles` triangles (at least 12; see [`uv_sphere`]).
pub fn sphere_with_triangles(radius: f64, triangles: usize) -> TriMesh {
    // 2 · s · (r − 1) triangles with s = 2r: r ≈ sqrt(n / 4).
    let rings = ((triangles as f64 / 4.0).sqrt().round() as u32).max(2);
    uv_sphere(radius, rings, 2 * rings)
}

/// A torus about the z axis: tube centre-line radius `major`, tube radius `minor`
/// (< `major`), `around` (≥ 3) segments along the ring and `tube` (≥ 3) around the tube:
/// `2 · around · tube` triangles, closed.
pub fn torus(major: f64, minor: f64, around: u32, tube: u32) -> TriMesh {
    let around = around.max(3);
    let tube = tube.max(3);
    let mut vertices = Vec::with_capacity((around * tube) as usize);
    for i in 0..around {
        let u = 2.0 * PI * i as f64 / around as f64;
        for j in 0..tube {
            let v = 2.0 * PI * j as f64 / tube as f64;
            let r = major + minor * v.cos();
            vertices.push([r * u.cos(), r * u.sin(), minor * v.sin()]);
        }
    }
    let id = |i: u32, j: u32| (i % around) * tube + j % tube;
    let mut triangles = Vec::with_capacity(2 * (around * tube) as usize);
    for i in 0..around {
        for j in 0..tube {
            let (a, b) = (id(i, j), id(i + 1, j));
            let (c, d) = (id(i, j + 1), id(i + 1, j + 1));
            triangles.push([a, b, d]);
            triangles.push([a, d, c]);
        }
    }
    TriMesh {
        vertices,
        triangles,
    }
}

/// A torus (ring radius 1, tube radius 0.35) with about `triangles` triangles (at least 18).
pub fn torus_with_triangles(triangles: usize) -> TriMesh {
    // 2 · a · t triangles with a = 3t (the ring is ~3x longer than the tube's girth).
    let tube = ((triangles as f64 / 6.0).sqrt().round() as u32).max(3);
    torus(1.0, 0.35, 3 * tube, tube)
}

/// The closed box `[-hx, hx] × [-hy, hy] × [-hz, hz]` centred on `centre`, each face a grid of
/// `n × n` squares (`n ≥ 1`, `12 · n²` triangles), vertices shared along the edges.
pub fn grid_box(centre: [f64; 3], half: [f64; 3], n: u32) -> TriMesh {
    box_faces(centre, half, n, &[true; 6])
}

/// [`grid_box`] without its top (+z) face: an open box, `10 · n²` triangles, whose boundary is
/// the square rim of the missing face.
pub fn open_box(half: [f64; 3], n: u32) -> TriMesh {
    box_faces([0.0; 3], half, n, &[true, true, true, true, true, false])
}

/// Two closed [`grid_box`]es that pass through each other (a self-intersecting,
/// non-manifold-as-a-whole mesh, as CAD exports of separate parts often are): a 2×1×1 box
/// and a 1×2×1 box rotated in place, crossing at the origin.
pub fn two_boxes(n: u32) -> TriMesh {
    let mut a = grid_box([0.0; 3], [1.0, 0.5, 0.5], n);
    let b = grid_box([0.0, 0.0, 0.2], [0.5, 1.0, 0.5], n);
    let offset = a.vertices.len() as u32;
    a.vertices.extend_from_slice(&b.vertices);
    a.triangles
        .extend(b.triangles.iter().map(|t| t.map(|k| k + offset)));
    a
}

/// The mesh with a seeded pseudo-random `fraction` (0..=1) of its triangles removed, the
/// holes scattered over the surface (vertices are kept).
pub fn remove_fraction(mesh: &TriMesh, fraction: f64, seed: u64) -> TriMesh {
    // SplitMix64 per triangle index: deterministic and independent of the mesh order of
    // other triangles.
    let keep = |i: usize| {
        let mut z = seed
            .wrapping_add((i as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15))
            .wrapping_add(0x9e37_79b9_7f4a_7c15);
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64 >= fraction
    };
    TriMesh {
        vertices: mesh.vertices.clone(),
        triangles: mesh
            .triangles
            .iter()
            .enumerate()
            .filter(|(i, _)| keep(*i))
            .map(|(_, t)| *t)
            .collect(),
    }
}

/// The faces of a grid box; `faces[k]` says whether face k (−x, +x, −y, +y, −z, +z) is made.
fn box_faces(centre: [f64; 3], half: [f64; 3], n: u32, faces: &[bool; 6]) -> TriMesh {
    let n = n.max(1);
    let mut vertices = Vec::new();
    let mut index = std::collections::HashMap::new();
    let mut vertex = |g: [i64; 3]| -> u32 {
        *index.entry(g).or_insert_with(|| {
            vertices.push(std::array::from_fn(|k| {
                centre[k] + half[k] * (2.0 * g[k] as f64 / n as f64 - 1.0)
            }));
            (vertices.len() - 1) as u32
        })
    };
    let n = n as i64;
    let mut triangles = Vec::new();
    for (face, &made) in faces.iter().enumerate() {
        if !made {
            continue;
        }
        let axis = face / 2;
        let high = face % 2 == 1;
        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
        for i in 0..n {
            for j in 0..n {
                let at = |di: i64, dj: i64| {
                    let mut g = [0i64; 3];
                    g[axis] = if high { n } else { 0 };
                    g[u] = i + di;
                    g[v] = j + dj;
                    g
                };
                let (a, b, c, d) = (
                    vertex(at(0, 0)),
                    vertex(at(1, 0)),
                    vertex(at(1, 1)),
                    vertex(at(0, 1)),
                );
                // (u, v, axis) is right-handed, so a, b, c is counter-clockwise seen from +axis.
                if high {
                    triangles.push([a, b, c]);
                    triangles.push([a, c, d]);
                } else {
                    triangles.push([a, c, b]);
                    triangles.push([a, d, c]);
                }
            }
        }
    }
    TriMesh {
        vertices,
        triangles,
    }
}

/// A closed solid of revolution about the z axis: `profile` lists `(radius, z)` points from the
/// bottom pole to the top pole (first and last radius 0, the others > 0), swept through
/// `segments` (≥ 3) steps: capsules, cylinders with flat ends, cones, probes.
/// `2 · segments · (profile.len() − 2)` triangles.
pub fn lathe(profile: &[(f64, f64)], segments: u32) -> TriMesh {
    let segments = segments.max(3);
    let inner = &profile[1..profile.len().saturating_sub(1).max(1)];
    let rings = inner.len() as u32;
    let mut vertices = vec![[0.0, 0.0, profile.first().map_or(0.0, |p| p.1)]];
    for &(r, z) in inner {
        for j in 0..segments {
            let phi = 2.0 * PI * j as f64 / segments as f64;
            vertices.push([r * phi.cos(), r * phi.sin(), z]);
        }
    }
    vertices.push([0.0, 0.0, profile.last().map_or(0.0, |p| p.1)]);
    let top = (vertices.len() - 1) as u32;
    let ring = |i: u32, j: u32| 1 + i * segments + j % segments;
    let mut triangles = Vec::new();
    for j in 0..segments {
        triangles.push([0, ring(0, j + 1), ring(0, j)]);
        triangles.push([top, ring(rings - 1, j), ring(rings - 1, j + 1)]);
    }
    for i in 0..rings.saturating_sub(1) {
        for j in 0..segments {
            let (a, b) = (ring(i, j), ring(i, j + 1));
            let (c, d) = (ring(i + 1, j), ring(i + 1, j + 1));
            triangles.push([a, b, d]);
            triangles.push([a, d, c]);
        }
    }
    TriMesh {
        vertices,
        triangles,
    }
}

/// A rod along `+z` from its hemispherical tip (lowest point at `z = 0`) to a flat end at
/// `z = length`: `radius`, `segments` (≥ 3) around, the tip in `segments / 4` bands. The shape
/// of a probe or a peg.
pub fn rod(radius: f64, length: f64, segments: u32) -> TriMesh {
    let bands = (segments / 4).max(2);
    let mut profile = vec![(0.0, 0.0)];
    for i in 1..=bands {
        let a = 0.5 * PI * i as f64 / bands as f64;
        profile.push((radius * a.sin(), radius * (1.0 - a.cos())));
    }
    // Rings along the shaft no further apart than 4 radii (long thin triangles split).
    let shaft = (length - radius).max(0.0);
    let steps = ((shaft / (4.0 * radius)).ceil() as u32).max(1);
    for i in 1..=steps {
        profile.push((radius, radius + shaft * i as f64 / steps as f64));
    }
    profile.push((0.0, radius + shaft));
    lathe(&profile, segments)
}

/// A prism: the simple polygon `outline` (counter-clockwise in the xy plane, no repeated
/// point) extruded from `z0` to `z1` (> `z0`), its two caps triangulated by ear clipping, so
/// non-convex outlines (an L, a U, a keyed profile) work.
pub fn extrude(outline: &[[f64; 2]], z0: f64, z1: f64) -> TriMesh {
    let n = outline.len() as u32;
    let mut vertices = Vec::with_capacity(2 * outline.len());
    for z in [z0, z1] {
        vertices.extend(outline.iter().map(|p| [p[0], p[1], z]));
    }
    let mut triangles = Vec::new();
    for [a, b, c] in ear_clip(outline) {
        triangles.push([a, c, b]);
        triangles.push([n + a, n + b, n + c]);
    }
    for i in 0..n {
        let j = (i + 1) % n;
        triangles.push([i, j, n + j]);
        triangles.push([i, n + j, n + i]);
    }
    TriMesh {
        vertices,
        triangles,
    }
}

/// Triangles (counter-clockwise) covering the simple counter-clockwise polygon `p`. A polygon
/// that is not simple stops the clipping early (fewer triangles: the caller's mesh is then
/// open, which its validation reports).
fn ear_clip(p: &[[f64; 2]]) -> Vec<[u32; 3]> {
    let cross = |a: [f64; 2], b: [f64; 2], c: [f64; 2]| {
        (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
    };
    let mut left: Vec<usize> = (0..p.len()).collect();
    let mut out = Vec::new();
    while left.len() > 3 {
        let m = left.len();
        let ear = (0..m).find(|&i| {
            let (a, b, c) = (left[(i + m - 1) % m], left[i], left[(i + 1) % m]);
            cross(p[a], p[b], p[c]) > 0.0
                && !left.iter().any(|&k| {
                    k != a
                        && k != b
                        && k != c
                        && cross(p[a], p[b], p[k]) >= 0.0
                        && cross(p[b], p[c], p[k]) >= 0.0
                        && cross(p[c], p[a], p[k]) >= 0.0
                })
        });
        let Some(i) = ear else { break };
        let (a, b, c) = (left[(i + m - 1) % m], left[i], left[(i + 1) % m]);
        out.push([a as u32, b as u32, c as u32]);
        left.remove(i);
    }
    if let [a, b, c] = left[..] {
        out.push([a as u32, b as u32, c as u32]);
    }
    out
}

/// A block over `[-hx, hx] × [-hy, hy]` whose top is the height field `z = top(x, y)` sampled
/// on an `n × n` grid (`n ≥ 1`) and whose bottom is flat at `z = bottom` (below every height):
/// a bumpy or wavy surface as a closed solid, `4 n² + 8 n` triangles.
pub fn height_field_block(
    hx: f64,
    hy: f64,
    bottom: f64,
    n: u32,
    top: impl Fn(f64, f64) -> f64,
) -> TriMesh {
    let n = n.max(1);
    let side = n + 1;
    let at = |i: u32, j: u32| {
        (
            -hx + 2.0 * hx * i as f64 / n as f64,
            -hy + 2.0 * hy * j as f64 / n as f64,
        )
    };
    let mut vertices = Vec::with_capacity(2 * (side * side) as usize);
    for level in 0..2 {
        for j in 0..side {
            for i in 0..side {
                let (x, y) = at(i, j);
                vertices.push([x, y, if level == 0 { top(x, y) } else { bottom }]);
            }
        }
    }
    let up = |i: u32, j: u32| j * side + i;
    let down = |i: u32, j: u32| side * side + j * side + i;
    let mut triangles = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let (a, b, c, d) = (up(i, j), up(i + 1, j), up(i + 1, j + 1), up(i, j + 1));
            triangles.push([a, b, c]);
            triangles.push([a, c, d]);
            let (a, b, c, d) = (
                down(i, j),
                down(i + 1, j),
                down(i + 1, j + 1),
                down(i, j + 1),
            );
            triangles.push([a, c, b]);
            triangles.push([a, d, c]);
        }
    }
    // The rim counter-clockwise seen from +z: the outside is to the right of each step.
    let mut rim = Vec::with_capacity(4 * n as usize);
    rim.extend((0..n).map(|i| (i, 0)));
    rim.extend((0..n).map(|j| (n, j)));
    rim.extend((0..n).map(|i| (n - i, n)));
    rim.extend((0..n).map(|j| (0, n - j)));
    for k in 0..rim.len() {
        let (p, q) = (rim[k], rim[(k + 1) % rim.len()]);
        triangles.push([down(p.0, p.1), down(q.0, q.1), up(q.0, q.1)]);
        triangles.push([down(p.0, p.1), up(q.0, q.1), up(p.0, p.1)]);
    }
    TriMesh {
        vertices,
        triangles,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closed_shapes_are_closed_with_the_promised_counts() {
        let s = uv_sphere(2.0, 10, 20);
        assert_eq!(s.triangles.len(), 2 * 20 * 9);
        s.check_closed().unwrap();
        let t = torus(1.0, 0.3, 30, 10);
        assert_eq!(t.triangles.len(), 600);
        t.check_closed().unwrap();
        let b = grid_box([0.0; 3], [1.0, 2.0, 3.0], 4);
        assert_eq!(b.triangles.len(), 12 * 16);
        b.check_closed().unwrap();
        let n = sphere_with_triangles(1.0, 100_000).triangles.len();
        assert!((90_000..110_000).contains(&n), "{n}");
        let n = torus_with_triangles(100_000).triangles.len();
        assert!((90_000..110_000).contains(&n), "{n}");
    }

    #[test]
    fn outward_orientation_gives_positive_volume() {
        let v = grid_box([1.0, 0.0, 0.0], [1.0, 2.0, 3.0], 3).signed_volume();
        assert!((v - 48.0).abs() < 1e-9, "{v}");
        let v = uv_sphere(1.0, 60, 120).signed_volume();
        assert!((v - 4.0 / 3.0 * PI).abs() < 0.01, "{v}");
        let v = torus(1.0, 0.3, 200, 60).signed_volume();
        assert!((v - 2.0 * PI * PI * 0.09).abs() < 0.01, "{v}");
    }

    #[test]
    fn damaged_shapes_are_open() {
        let o = open_box([1.0; 3], 3);
        assert_eq!(o.triangles.len(), 90);
        assert!(o.check_closed().is_err());
        let s = uv_sphere(1.0, 40, 80);
        let holed = remove_fraction(&s, 0.05, 7);
        let removed = s.triangles.len() - holed.triangles.len();
        let want = 0.05 * s.triangles.len() as f64;
        assert!((removed as f64 - want).abs() < 0.3 * want, "{removed}");
        assert!(holed.check_closed().is_err());
        assert_eq!(holed, remove_fraction(&s, 0.05, 7));
        let two = two_boxes(2);
        assert_eq!(two.triangles.len(), 2 * 12 * 4);
    }

    #[test]
    fn lathe_extrude_and_height_field_are_closed_and_outward() {
        let cylinder = lathe(&[(0.0, 0.0), (1.0, 0.0), (1.0, 2.0), (0.0, 2.0)], 400);
        cylinder.check_closed().unwrap();
        let v = cylinder.signed_volume();
        assert!((v - 2.0 * PI).abs() < 1e-3, "{v}");
        let probe = rod(1.0, 10.0, 32);
        probe.check_closed().unwrap();
        assert!(probe.signed_volume() > 0.0);
        let (lo, hi) = probe.aabb().unwrap();
        assert!(lo[2].abs() < 1e-12 && (hi[2] - 10.0).abs() < 1e-12);
        // An L of area 3 (a 2 x 2 square missing its 1 x 1 upper-right quarter), 2 high.
        let l = extrude(
            &[
                [0.0, 0.0],
                [2.0, 0.0],
                [2.0, 1.0],
                [1.0, 1.0],
                [1.0, 2.0],
                [0.0, 2.0],
            ],
            0.0,
            2.0,
        );
        l.check_closed().unwrap();
        let v = l.signed_volume();
        assert!((v - 6.0).abs() < 1e-9, "{v}");
        let bumps = height_field_block(2.0, 3.0, -1.0, 8, |x, _| 0.1 * x);
        bumps.check_closed().unwrap();
        assert_eq!(bumps.triangles.len(), 4 * 64 + 8 * 8);
        let v = bumps.signed_volume();
        assert!((v - 24.0).abs() < 1e-9, "{v}");
    }
}
