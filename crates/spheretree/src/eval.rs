//! The fit measure (docs/DESIGN.md §The fit measure), comparable with the Sphere-Tree
//! Construction Toolkit.
//!
//! Entry point: [`evaluate_fit`] → one [`LevelFit`] per level.
//!
//! The mesh is scaled about its bounding-box centre so that its longest side is 2000 (the
//! toolkit's units); the tree, given in the mesh's own frame, is mapped the same way. For each
//! used sphere, 42 points `c + r·u` (u: the 12 icosahedron vertices and the 30 normalised edge
//! midpoints) and 162 points (one more subdivision) are tested; the sphere's error is the
//! largest distance to the surface from a point that lies *outside* the mesh (0 if none
//! does); outside is told by the pseudo-normal on a closed mesh and by the generalised
//! winding number on an open one ([`FitParams::inside`]), whose holes are first closed by
//! fans ([`solid_query`]). Coverage is the fraction of seeded random surface samples (of the
//! surface that exists) inside the union of the
//! level's spheres; the largest gap is the largest distance from an uncovered sample to the
//! nearest sphere surface.

#![allow(clippy::needless_range_loop)] // xyz loops read better indexed

use crate::{Sphere, SphereTree};
pub(crate) use mesh::vec3::{add, dist, dist2, scale, sub};
use mesh::{sample_surface, InsideTest, MeshQuery, TriMesh};
use rayon::prelude::*;
use std::sync::OnceLock;

/// Most triangles one signed-distance query of the measure tests before the winding number
/// decides the side instead (more than any mesh of fewer triangles needs, so small meshes such
/// as the bunny are measured exactly as by unbounded queries).
const EVAL_QUERY_BUDGET: usize = 8192;

/// The toolkit's scale: the mesh's longest bounding-box side maps to this many units.
pub const TOOLKIT_SIZE: f64 = 2000.0;

/// Options of [`evaluate_fit`].
#[derive(Clone, Debug, PartialEq)]
pub struct FitParams {
    /// Number of random surface samples for the coverage measure (default 100 000).
    pub coverage_samples: usize,
    /// Seed of the coverage samples (ChaCha8; default 2026).
    pub seed: u64,
    /// How a sphere point is found outside the mesh; `None` (default) picks
    /// [`InsideTest::for_mesh`] (the pseudo-normal on closed meshes, the generalised winding
    /// number on open ones, whose coverage is then over the surface that exists).
    pub inside: Option<InsideTest>,
}

impl Default for FitParams {
    fn default() -> Self {
        Self {
            coverage_samples: 100_000,
            seed: 2026,
            inside: None,
        }
    }
}

/// The fit of one level of a tree, in toolkit units (mesh longest side = 2000).
#[derive(Clone, Debug, PartialEq)]
pub struct LevelFit {
    /// Level (0 = root).
    pub level: u32,
    /// Number of used spheres on the level.
    pub count: usize,
    /// Largest sphere error with the 42-point set (toolkit units).
    pub worst: f64,
    /// Mean sphere error with the 42-point set (toolkit units).
    pub mean: f64,
    /// Largest sphere error with the 162-point set (toolkit units).
    pub worst162: f64,
    /// Mean sphere error with the 162-point set (toolkit units).
    pub mean162: f64,
    /// Fraction (0..=1) of the surface samples inside the union of the level's spheres.
    pub coverage: f64,
    /// Number of surface samples outside every sphere of the level.
    pub uncovered: usize,
    /// Largest distance from an uncovered sample to the nearest sphere surface (toolkit
    /// units; 0 when everything is covered).
    pub largest_gap: f64,
}

/// The toolkit frame of `mesh`: `(bbox centre, scale)` with `p_toolkit = (p - centre) * scale`;
/// `None` for an empty or flat-to-a-point mesh.
pub fn toolkit_frame(mesh: &TriMesh) -> Option<([f64; 3], f64)> {
    let (lo, hi) = mesh.aabb()?;
    let centre = [
        0.5 * (lo[0] + hi[0]),
        0.5 * (lo[1] + hi[1]),
        0.5 * (lo[2] + hi[2]),
    ];
    let longest = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(hi[2] - lo[2]);
    if longest <= 0.0 || !longest.is_finite() {
        return None;
    }
    Some((centre, TOOLKIT_SIZE / longest))
}

/// The unit directions of the icosphere with `subdivisions` subdivisions (0 → 12, 1 → 42,
/// 2 → 162), each set a prefix of the next.
pub fn icosphere_directions(subdivisions: u32) -> Vec<[f64; 3]> {
    let phi = (1.0 + 5f64.sqrt()) / 2.0;
    let mut verts: Vec<[f64; 3]> = Vec::new();
    for &(a, b) in &[(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)] {
        verts.push([0.0, a, b * phi]);
        verts.push([a, b * phi, 0.0]);
        verts.push([b * phi, 0.0, a]);
    }
    // Faces: triples of vertices pairwise at the edge length 2.
    let is_edge = |i: usize, j: usize, v: &[[f64; 3]]| (dist(v[i], v[j]) - 2.0).abs() < 1e-9;
    let mut faces: Vec<[usize; 3]> = Vec::new();
    for i in 0..12 {
        for j in i + 1..12 {
            for k in j + 1..12 {
                if is_edge(i, j, &verts) && is_edge(j, k, &verts) && is_edge(i, k, &verts) {
                    faces.push([i, j, k]);
                }
            }
        }
    }
    let mut verts: Vec<[f64; 3]> = verts.into_iter().map(unit).collect();
    for _ in 0..subdivisions {
        let mut mid: std::collections::BTreeMap<(usize, usize), usize> = Default::default();
        let mut next = Vec::with_capacity(faces.len() * 4);
        for f in &faces {
            let mut m = [0usize; 3];
            for e in 0..3 {
                let (a, b) = (f[e], f[(e + 1) % 3]);
                let key = (a.min(b), a.max(b));
                m[e] = *mid.entry(key).or_insert_with(|| {
                    let p = unit(scale(add(verts[a], verts[b]), 0.5));
                    verts.push(p);
                    verts.len() - 1
                });
            }
            next.push([f[0], m[0], m[2]]);
            next.push([f[1], m[1], m[0]]);
            next.push([f[2], m[2], m[1]]);
            next.push(m);
        }
        faces = next;
    }
    verts
}

fn directions_162() -> &'static [[f64; 3]] {
    static DIRS: OnceLock<Vec<[f64; 3]>> = OnceLock::new();
    DIRS.get_or_init(|| icosphere_directions(2))
}

/// Error of one sphere (toolkit frame): `(error with the first 42 points, with all 162)`.
/// Exposed for the builders, which optimise against the same measure.
pub fn sphere_error(q: &MeshQuery, s: &Sphere) -> (f64, f64) {
    let dirs = directions_162();
    // The ball lies inside when its centre is deeper than its radius.
    let sd_c = q.signed_distance_budgeted(s.center, EVAL_QUERY_BUDGET);
    if sd_c.is_some_and(|d| d <= -s.radius) {
        return (0.0, 0.0);
    }
    let mut e42: f64 = 0.0;
    let mut e162: f64 = 0.0;
    for (i, u) in dirs.iter().enumerate() {
        let p = add(s.center, scale(*u, s.radius));
        let d = match q.signed_distance_budgeted(p, EVAL_QUERY_BUDGET) {
            Some(d) => d,
            // Nearly equidistant to much of the mesh (deep inside a fine sphere): only an
            // outside point counts, and the winding number says which side cheaply.
            None if q.winding_number(p) >= 0.5 => continue,
            None => q.signed_distance(p),
        };
        if d > 0.0 {
            e162 = e162.max(d);
            if i < 42 {
                e42 = e42.max(d);
            }
        }
    }
    (e42, e162)
}

/// The fit measure (docs/DESIGN.md §The fit measure) for every level of `tree` against `mesh`
/// (see the module docs). `tree` is in the mesh's own frame; all results are in toolkit units.
/// Parallel (rayon). A mesh with no usable triangle yields infinite errors; an empty mesh an
/// empty vector.
pub fn evaluate_fit(tree: &SphereTree, mesh: &TriMesh, params: &FitParams) -> Vec<LevelFit> {
    let Some((centre, s)) = toolkit_frame(mesh) else {
        return Vec::new();
    };
    let m = mesh.scaled_about(centre, s);
    let inside = params.inside.unwrap_or_else(|| InsideTest::for_mesh(&m));
    let (q, _) = solid_query(&m, inside);
    let spheres: Vec<Sphere> = tree
        .spheres()
        .iter()
        .map(|sp| Sphere {
            center: scale(sub(sp.center, centre), s),
            radius: if sp.is_used() { sp.radius * s } else { -1.0 },
        })
        .collect();
    let errors: Vec<(f64, f64)> = spheres
        .par_iter()
        .map(|sp| {
            if sp.is_used() {
                sphere_error(&q, sp)
            } else {
                (0.0, 0.0)
            }
        })
        .collect();
    let samples: Vec<[f64; 3]> = sample_surface(&m, params.coverage_samples, params.seed)
        .into_iter()
        .map(|(p, _)| p)
        .collect();

    (0..tree.levels())
        .map(|level| {
            let range = tree.level_range(level);
            let used: Vec<usize> = range.filter(|&n| spheres[n].is_used()).collect();
            let count = used.len();
            let (mut worst, mut sum, mut worst162, mut sum162) = (0.0f64, 0.0, 0.0f64, 0.0);
            for &n in &used {
                let (a, b) = errors[n];
                worst = worst.max(a);
                worst162 = worst162.max(b);
                sum += a;
                sum162 += b;
            }
            let level_spheres: Vec<Sphere> = used.iter().map(|&n| spheres[n]).collect();
            let (uncovered, largest_gap) = coverage(&level_spheres, &samples);
            let denom = count.max(1) as f64;
            LevelFit {
                level,
                count,
                worst,
                mean: sum / denom,
                worst162,
                mean162: sum162 / denom,
                coverage: if samples.is_empty() {
                    1.0
                } else {
                    1.0 - uncovered as f64 / samples.len() as f64
                },
                uncovered,
                largest_gap,
            }
        })
        .collect()
}

/// The query structure telling inside from outside of `mesh` with `inside`, and the number
/// of holes closed for it. With the winding number the holes are closed first
/// ([`TriMesh::with_holes_closed`]), so distances (and protrusions) count from the membrane
/// over a hole as from the missing surface; surface samples still come from `mesh` itself.
pub fn solid_query(mesh: &TriMesh, inside: InsideTest) -> (MeshQuery, usize) {
    solid_query_with_progress(mesh, inside, &|_| {})
}

/// [`solid_query`], calling `progress` with the completed fraction as it goes.
pub(crate) fn solid_query_with_progress(
    mesh: &TriMesh,
    inside: InsideTest,
    progress: &dyn Fn(f64),
) -> (MeshQuery, usize) {
    match inside {
        InsideTest::PseudoNormal => (MeshQuery::with_progress(mesh, inside, progress), 0),
        InsideTest::WindingNumber => {
            let (closed, holes) = mesh.with_holes_closed();
            (MeshQuery::with_progress(&closed, inside, progress), holes)
        }
    }
}

/// A uniform grid over a point set that lists, per occupied cell, the spheres touching it.
pub(crate) struct SphereGrid {
    lo: [f64; 3],
    h: f64,
    dims: [usize; 3],
    /// Cell → slot in `start` (`u32::MAX` = no point there).
    cell_slot: Vec<u32>,
    start: Vec<u32>,
    items: Vec<u32>,
}

impl SphereGrid {
    /// Grid over `points` with about `res` cells on the longest side; lists the spheres
    /// that touch each cell holding a point.
    pub(crate) fn new(points: &[[f64; 3]], spheres: &[Sphere], res: usize) -> Self {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in points {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        if points.is_empty() {
            lo = [0.0; 3];
            hi = [0.0; 3];
        }
        let longest = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(hi[2] - lo[2]);
        let h = (longest / res.max(1) as f64).max(1e-12);
        let dims = [0, 1, 2].map(|k| (((hi[k] - lo[k]) / h).floor() as usize + 1).max(1));
        let ncell = dims[0] * dims[1] * dims[2];
        let mut cell_slot = vec![u32::MAX; ncell];
        let mut occupied = 0u32;
        for p in points {
            let c = Self::cell_of(lo, h, dims, *p);
            if cell_slot[c] == u32::MAX {
                cell_slot[c] = occupied;
                occupied += 1;
            }
        }
        // Per sphere, the occupied cells it touches (counted, then filled).
        let touching = |sp: &Sphere, f: &mut dyn FnMut(usize)| {
            let r = sp.radius;
            let a = [0, 1, 2].map(|k| (((sp.center[k] - r - lo[k]) / h).floor()).max(0.0));
            let b = [0, 1, 2].map(|k| ((sp.center[k] + r - lo[k]) / h).floor());
            if (0..3).any(|k| b[k] < 0.0 || a[k] > (dims[k] - 1) as f64) {
                return;
            }
            let a = a.map(|v| v as usize);
            let b = [0, 1, 2].map(|k| (b[k] as usize).min(dims[k] - 1));
            for i in a[0]..=b[0] {
                for j in a[1]..=b[1] {
                    for l in a[2]..=b[2] {
                        let c = (i * dims[1] + j) * dims[2] + l;
                        if cell_slot[c] == u32::MAX {
                            continue;
                        }
                        // Sphere vs cell box.
                        let cl = [i, j, l];
                        let mut d2 = 0.0;
                        for k in 0..3 {
                            let bl = lo[k] + cl[k] as f64 * h;
                            let bh = bl + h;
                            let d = (bl - sp.center[k]).max(0.0).max(sp.center[k] - bh);
                            d2 += d * d;
                        }
                        if d2 <= r * r {
                            f(cell_slot[c] as usize);
                        }
                    }
                }
            }
        };
        let mut count = vec![0u32; occupied as usize + 1];
        for sp in spheres {
            touching(sp, &mut |slot| count[slot + 1] += 1);
        }
        for i in 1..count.len() {
            count[i] += count[i - 1];
        }
        let start = count.clone();
        let mut fill = count;
        let mut items = vec![0u32; *start.last().unwrap_or(&0) as usize];
        for (si, sp) in spheres.iter().enumerate() {
            touching(sp, &mut |slot| {
                items[fill[slot] as usize] = si as u32;
                fill[slot] += 1;
            });
        }
        SphereGrid {
            lo,
            h,
            dims,
            cell_slot,
            start,
            items,
        }
    }

    fn cell_of(lo: [f64; 3], h: f64, dims: [usize; 3], p: [f64; 3]) -> usize {
        let idx =
            [0, 1, 2].map(|k| (((p[k] - lo[k]) / h).floor().max(0.0) as usize).min(dims[k] - 1));
        (idx[0] * dims[1] + idx[1]) * dims[2] + idx[2]
    }

    /// Indices of the spheres touching the cell of `p` (empty if `p` is not a grid point's
    /// cell).
    pub(crate) fn candidates(&self, p: [f64; 3]) -> &[u32] {
        let c = Self::cell_of(self.lo, self.h, self.dims, p);
        let slot = self.cell_slot[c];
        if slot == u32::MAX {
            return &[];
        }
        let slot = slot as usize;
        &self.items[self.start[slot] as usize..self.start[slot + 1] as usize]
    }
}

/// `(uncovered count, largest gap)` of `samples` against the union of `spheres`.
pub(crate) fn coverage(spheres: &[Sphere], samples: &[[f64; 3]]) -> (usize, f64) {
    if samples.is_empty() {
        return (0, 0.0);
    }
    let grid = SphereGrid::new(samples, spheres, 64);
    let uncovered: Vec<[f64; 3]> = samples
        .par_iter()
        .filter(|p| {
            !grid.candidates(**p).iter().any(|&i| {
                let sp = &spheres[i as usize];
                dist2(sp.center, **p) <= sp.radius * sp.radius
            })
        })
        .copied()
        .collect();
    let gap = uncovered
        .par_iter()
        .map(|p| {
            spheres
                .iter()
                .map(|sp| dist(sp.center, *p) - sp.radius)
                .fold(f64::INFINITY, f64::min)
        })
        .reduce(|| 0.0, f64::max);
    (uncovered.len(), gap)
}

#[inline]
pub(crate) fn unit(a: [f64; 3]) -> [f64; 3] {
    let l = dist(a, [0.0; 3]);
    scale(a, 1.0 / l)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cube(half: f64) -> TriMesh {
        let v = |x: f64, y: f64, z: f64| [x * half, y * half, z * half];
        TriMesh {
            vertices: vec![
                v(-1.0, -1.0, -1.0),
                v(1.0, -1.0, -1.0),
                v(1.0, 1.0, -1.0),
                v(-1.0, 1.0, -1.0),
                v(-1.0, -1.0, 1.0),
                v(1.0, -1.0, 1.0),
                v(1.0, 1.0, 1.0),
                v(-1.0, 1.0, 1.0),
            ],
            triangles: vec![
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
            ],
        }
    }

    fn one_sphere(center: [f64; 3], r: f64) -> SphereTree {
        SphereTree::from_slots(1, 8, vec![Sphere::new(center, r)]).unwrap()
    }

    #[test]
    fn icosphere_counts_and_prefixes() {
        let d0 = icosphere_directions(0);
        let d1 = icosphere_directions(1);
        let d2 = icosphere_directions(2);
        assert_eq!((d0.len(), d1.len(), d2.len()), (12, 42, 162));
        assert_eq!(&d1[..12], &d0[..]);
        assert_eq!(&d2[..42], &d1[..]);
        for u in &d2 {
            assert!((dist(*u, [0.0; 3]) - 1.0).abs() < 1e-12);
        }
        // Distinct points.
        for i in 0..d2.len() {
            for j in i + 1..d2.len() {
                assert!(dist(d2[i], d2[j]) > 0.1);
            }
        }
    }

    #[test]
    fn a_sphere_inside_a_cube_has_no_error() {
        // Cube of side 2000 (already toolkit units): a sphere of radius 900 at the centre.
        let m = cube(1000.0);
        let fit = evaluate_fit(&one_sphere([0.0; 3], 900.0), &m, &FitParams::default());
        assert_eq!(fit.len(), 1);
        assert_eq!(fit[0].count, 1);
        assert_eq!(fit[0].worst, 0.0);
        assert_eq!(fit[0].worst162, 0.0);
        // It covers no surface sample: the gap is the distance from a corner, 1000*sqrt(3)-900.
        assert_eq!(fit[0].coverage, 0.0);
        assert!(fit[0].largest_gap < 1000.0 * 3f64.sqrt() - 900.0 + 1e-6);
        assert!(fit[0].largest_gap > 700.0);
    }

    #[test]
    fn a_sphere_poking_out_of_a_face_by_h_has_error_h() {
        // The cube is side 2 in mesh units (scale 1000 to toolkit units). (0, 0, 1) is one of
        // the 42 directions (the midpoint of the icosahedron edge (0, +-1, phi)), so a sphere
        // whose top pokes out of the +z face by h has error exactly h at both resolutions.
        let dirs = icosphere_directions(1);
        assert!(dirs.iter().any(|u| dist(*u, [0.0, 0.0, 1.0]) < 1e-12));
        let m = cube(1.0);
        for h in [0.0123, 0.05, 0.2] {
            let r = 0.3;
            let t = one_sphere([0.1, -0.2, 1.0 - r + h], r);
            let fit = evaluate_fit(&t, &m, &FitParams::default());
            assert!(
                (fit[0].worst - h * 1000.0).abs() < 1e-6,
                "{h}: {:?}",
                fit[0]
            );
            assert!(
                (fit[0].worst162 - h * 1000.0).abs() < 1e-6,
                "{h}: {:?}",
                fit[0]
            );
            assert!(fit[0].mean > 0.0 && fit[0].mean <= fit[0].worst);
        }
    }

    #[test]
    fn coverage_counts_uncovered_samples_and_the_gap() {
        let m = cube(1.0);
        // Two spheres covering the x<0 and x>0 halves fully vs one covering only x<0.
        let full = SphereTree::from_slots(
            2,
            2,
            vec![
                Sphere::new([0.0; 3], 2.0),
                Sphere::new([-0.5, 0.0, 0.0], 1.6),
                Sphere::new([0.5, 0.0, 0.0], 1.6),
            ],
        )
        .unwrap();
        let fit = evaluate_fit(&full, &m, &FitParams::default());
        assert_eq!(fit[1].coverage, 1.0);
        assert_eq!(fit[1].largest_gap, 0.0);
        let half = SphereTree::from_slots(
            2,
            2,
            vec![
                Sphere::new([0.0; 3], 2.0),
                Sphere::new([-0.5, 0.0, 0.0], 1.6),
                Sphere::UNUSED,
            ],
        )
        .unwrap();
        let fit = evaluate_fit(&half, &m, &FitParams::default());
        assert_eq!(fit[1].count, 1);
        // The +x face (1/6 of the area) and parts of the side faces are uncovered.
        assert!(
            fit[1].coverage < 0.8 && fit[1].coverage > 0.3,
            "{:?}",
            fit[1]
        );
        // Farthest corner (1, 1, 1): distance to (-0.5, 0, 0) minus 1.6, in toolkit units.
        let corner_gap = (dist([1.0, 1.0, 1.0], [-0.5, 0.0, 0.0]) - 1.6) * 1000.0;
        assert!(fit[1].largest_gap <= corner_gap + 1e-6);
        assert!(fit[1].largest_gap > 0.9 * corner_gap);
    }
}
