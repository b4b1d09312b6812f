//! The octree builder: cells of an octree on the mesh's bounding cube that meet the surface.
//!
//! A leaf is the smallest sphere (near-minimal, see [`enclosing_sphere`]) around the part of
//! the surface inside its cell (triangles clipped to the cell), so it covers that part exactly
//! and is never larger than the cell's circumscribed sphere; parents enclose their children.
//! Coverage is therefore complete by construction.

#![allow(clippy::needless_range_loop)] // xyz loops read better indexed

use super::{enclosing_sphere, fill_parents};
use crate::{Sphere, SphereTree, TreeError};
use mesh::vec3::{cross, dot, sub};
use mesh::TriMesh;
use rayon::prelude::*;

/// One octree cell at the current level: slot, centre, half side, triangles meeting it.
struct Cell {
    slot: usize,
    centre: [f64; 3],
    half: f64,
    tris: Vec<u32>,
}

pub(super) fn build(
    m: &TriMesh,
    tree: &mut SphereTree,
    progress: &(dyn Fn(f64) + Sync),
) -> Result<(), TreeError> {
    if tree.branching() < 8 {
        return Err(TreeError::Build(format!(
            "the octree builder needs branching >= 8 (got {}): use --branch 8 or the tight method",
            tree.branching()
        )));
    }
    let (lo, hi) = m
        .aabb()
        .ok_or_else(|| TreeError::Build("the mesh has no vertices".into()))?;
    let centre = [0, 1, 2].map(|k| 0.5 * (lo[k] + hi[k]));
    let half = (0..3).map(|k| 0.5 * (hi[k] - lo[k])).fold(0.0, f64::max) * (1.0 + 1e-9);
    let tri = |t: u32| m.triangles[t as usize].map(|k| m.vertices[k as usize]);
    let b = tree.branching() as usize;
    let depth = tree.depth();
    let mut cells = vec![Cell {
        slot: 0,
        centre,
        half,
        tris: (0..m.triangles.len() as u32).collect(),
    }];
    for level in 1..=depth {
        cells = cells
            .par_iter()
            .flat_map_iter(|c| {
                let h = 0.5 * c.half;
                (0..8).filter_map(move |k| {
                    let cc = [0, 1, 2].map(|a| c.centre[a] + if k >> a & 1 == 1 { h } else { -h });
                    let tris: Vec<u32> = c
                        .tris
                        .iter()
                        .copied()
                        .filter(|&t| tri_box_overlap(&tri(t), cc, h * (1.0 + 1e-9)))
                        .collect();
                    (!tris.is_empty()).then_some(Cell {
                        slot: c.slot * b + 1 + k,
                        centre: cc,
                        half: h,
                        tris,
                    })
                })
            })
            .collect();
        progress(0.8 * level as f64 / depth.max(1) as f64);
    }
    // Leaves: smallest sphere around the surface clipped to the cell.
    let leaves: Vec<(usize, Sphere)> = cells
        .par_iter()
        .map(|c| {
            let mut pts: Vec<Sphere> = Vec::new();
            for &t in &c.tris {
                for p in clip_to_box(&tri(t), c.centre, c.half) {
                    pts.push(Sphere::new(p, 0.0));
                }
            }
            let s = if pts.is_empty() {
                // Touching only (clipped to nothing): the circumscribed sphere.
                Sphere::new(c.centre, c.half * 3f64.sqrt())
            } else {
                enclosing_sphere(&pts)
            };
            (c.slot, s)
        })
        .collect();
    for (slot, s) in leaves {
        // A cell that meets the surface in a single point (a corner of an open mesh or of a
        // lone triangle on its boundary) gets a sphere of radius 0: it covers nothing the
        // neighbouring cells do not, and a used sphere of radius 0 cannot be written to .sph.
        if s.radius > 0.0 {
            tree.spheres_mut()[slot] = s;
        }
    }
    // Mark the path to every leaf used, then enclose bottom-up.
    for n in (1..tree.len()).rev() {
        if tree.sphere(n).is_used() {
            if let Some(p) = tree.parent(n) {
                if !tree.sphere(p).is_used() {
                    tree.spheres_mut()[p] = Sphere::new([0.0; 3], 0.0);
                }
            }
        }
    }
    if depth == 0 {
        tree.spheres_mut()[0] = enclosing_sphere(
            &m.vertices
                .iter()
                .map(|v| Sphere::new(*v, 0.0))
                .collect::<Vec<_>>(),
        );
    }
    fill_parents(tree, None);
    Ok(())
}

/// The polygon of triangle `t` clipped to the axis-aligned box (`centre`, `half`), as its
/// vertices (Sutherland–Hodgman against the six planes).
fn clip_to_box(t: &[[f64; 3]; 3], centre: [f64; 3], half: f64) -> Vec<[f64; 3]> {
    let mut poly: Vec<[f64; 3]> = t.to_vec();
    for axis in 0..3 {
        for sign in [1.0, -1.0] {
            let bound = centre[axis] + sign * half;
            // Inside: sign * (p[axis] - bound) <= 0.
            let inside = |p: &[f64; 3]| sign * (p[axis] - bound) <= 0.0;
            let mut out = Vec::with_capacity(poly.len() + 2);
            for i in 0..poly.len() {
                let a = poly[i];
                let b = poly[(i + 1) % poly.len()];
                let (ia, ib) = (inside(&a), inside(&b));
                if ia {
                    out.push(a);
                }
                if ia != ib {
                    let t = (bound - a[axis]) / (b[axis] - a[axis]);
                    let mut p = [0.0; 3];
                    for k in 0..3 {
                        p[k] = a[k] + t * (b[k] - a[k]);
                    }
                    p[axis] = bound;
                    out.push(p);
                }
            }
            poly = out;
            if poly.is_empty() {
                return poly;
            }
        }
    }
    poly
}

/// Separating-axis test of a triangle against an axis-aligned box (Akenine-Möller 2001):
/// the 3 box axes, the triangle normal, and the 9 edge × axis cross products.
fn tri_box_overlap(t: &[[f64; 3]; 3], centre: [f64; 3], half: f64) -> bool {
    let v = t.map(|p| [p[0] - centre[0], p[1] - centre[1], p[2] - centre[2]]);
    // Box axes.
    for k in 0..3 {
        let mn = v[0][k].min(v[1][k]).min(v[2][k]);
        let mx = v[0][k].max(v[1][k]).max(v[2][k]);
        if mn > half || mx < -half {
            return false;
        }
    }
    let e = [sub(v[1], v[0]), sub(v[2], v[1]), sub(v[0], v[2])];
    // Edge cross axes.
    for edge in &e {
        for k in 0..3 {
            let mut axis = [0.0; 3];
            axis[k] = 1.0;
            let a = cross(*edge, axis);
            let p = v.map(|x| dot(x, a));
            let r = half * (a[0].abs() + a[1].abs() + a[2].abs());
            let mn = p[0].min(p[1]).min(p[2]);
            let mx = p[0].max(p[1]).max(p[2]);
            if mn > r || mx < -r {
                return false;
            }
        }
    }
    // Triangle plane.
    let n = cross(e[0], e[1]);
    let d = dot(n, v[0]);
    let r = half * (n[0].abs() + n[1].abs() + n[2].abs());
    d.abs() <= r
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn triangle_box_overlap_cases() {
        let t = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        assert!(tri_box_overlap(&t, [0.2, 0.2, 0.0], 0.1));
        assert!(!tri_box_overlap(&t, [0.2, 0.2, 0.5], 0.1));
        // Beyond the hypotenuse: the box axes overlap but an edge axis separates.
        assert!(!tri_box_overlap(&t, [0.7, 0.7, 0.0], 0.15));
        assert!(tri_box_overlap(&t, [0.5, 0.5, 0.0], 0.05));
    }

    #[test]
    fn clipping_keeps_the_part_in_the_box() {
        let t = [[-1.0, -1.0, 0.0], [3.0, -1.0, 0.0], [-1.0, 3.0, 0.0]];
        let p = clip_to_box(&t, [0.0; 3], 0.5);
        // The square [-0.5, 0.5]^2 is entirely inside the triangle.
        assert_eq!(p.len(), 4);
        for q in &p {
            assert!(q[0].abs() <= 0.5 + 1e-12 && q[1].abs() <= 0.5 + 1e-12);
        }
        assert!(clip_to_box(&t, [0.0, 0.0, 2.0], 0.5).is_empty());
    }
}
