//! Area-weighted, seeded random sampling of a mesh surface.
//!
//! Entry point: [`sample_surface`].

use crate::query::{cross, norm, scale_v};
use crate::vec3::sub as sub3;
use crate::TriMesh;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A surface sample: `(point, unit outward face normal)`, point in mesh units.
pub type SurfaceSample = ([f64; 3], [f64; 3]);

/// `n` points drawn uniformly (area-weighted) on the surface of `mesh`, each with the unit
/// normal of its triangle (counter-clockwise = outward). The same `seed` gives the same
/// samples on every machine (ChaCha8). Triangles with a bad index or zero area are never
/// drawn; a mesh without any usable triangle gives an empty vector.
pub fn sample_surface(mesh: &TriMesh, n: usize, seed: u64) -> Vec<SurfaceSample> {
    sample_surface_weighted(mesh, n, seed, &|_| 1.0)
}

/// Like [`sample_surface`], but triangle `t` is drawn with a density (samples per unit area)
/// proportional to `density(t)` (a finite value `>= 0`; others count as 0), so some regions
/// can be sampled more densely than others.
pub fn sample_surface_weighted(
    mesh: &TriMesh,
    n: usize,
    seed: u64,
    density: &dyn Fn(usize) -> f64,
) -> Vec<SurfaceSample> {
    let nv = mesh.vertices.len();
    // Cumulative weights of the usable triangles.
    let mut cdf: Vec<f64> = Vec::with_capacity(mesh.triangles.len());
    let mut ids: Vec<usize> = Vec::with_capacity(mesh.triangles.len());
    let mut total = 0.0;
    for (i, t) in mesh.triangles.iter().enumerate() {
        if t.iter().any(|&k| k as usize >= nv) {
            continue;
        }
        let [a, b, c] = t.map(|k| mesh.vertices[k as usize]);
        let area = 0.5 * norm(cross(sub3(b, a), sub3(c, a)));
        let w = area * density(i);
        if w <= 0.0 || !w.is_finite() {
            continue;
        }
        total += w;
        cdf.push(total);
        ids.push(i);
    }
    if ids.is_empty() || n == 0 {
        return Vec::new();
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut out = Vec::with_capacity(n);
    for _ in 0..n {
        let x: f64 = rng.random::<f64>() * total;
        let j = cdf.partition_point(|&c| c < x).min(ids.len() - 1);
        let t = mesh.triangles[ids[j]];
        let [a, b, c] = t.map(|k| mesh.vertices[k as usize]);
        let r1: f64 = rng.random::<f64>();
        let r2: f64 = rng.random::<f64>();
        // Uniform barycentric coordinates (Osada et al. 2002).
        let s = r1.sqrt();
        let (u, v, w) = (1.0 - s, s * (1.0 - r2), s * r2);
        let p = [
            u * a[0] + v * b[0] + w * c[0],
            u * a[1] + v * b[1] + w * c[1],
            u * a[2] + v * b[2] + w * c[2],
        ];
        let cr = cross(sub3(b, a), sub3(c, a));
        out.push((p, scale_v(cr, 1.0 / norm(cr))));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square() -> TriMesh {
        // Two triangles: a unit square in z = 0 (area 1) and a 2x2 square in z = 5 (area 4).
        TriMesh {
            vertices: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [1.0, 1.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 5.0],
                [2.0, 0.0, 5.0],
                [2.0, 2.0, 5.0],
                [0.0, 2.0, 5.0],
            ],
            triangles: vec![[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]],
        }
    }

    #[test]
    fn sampling_is_area_weighted_seeded_and_on_the_surface() {
        let m = square();
        let s = sample_surface(&m, 20000, 7);
        assert_eq!(s.len(), 20000);
        let top = s.iter().filter(|(p, _)| p[2] > 2.5).count() as f64 / 20000.0;
        assert!((top - 0.8).abs() < 0.02, "top fraction {top}");
        for (p, n) in &s {
            assert!(p[2] == 0.0 || (p[2] - 5.0).abs() < 1e-12);
            let lim = if p[2] == 0.0 { 1.0 } else { 2.0 } + 1e-12;
            assert!((0.0..=lim).contains(&p[0]) && (0.0..=lim).contains(&p[1]));
            assert_eq!(*n, [0.0, 0.0, 1.0]);
        }
        // Uniform inside a triangle: mean of the unit square samples is near its centre.
        let bottom: Vec<_> = s.iter().filter(|(p, _)| p[2] == 0.0).collect();
        let mx = bottom.iter().map(|(p, _)| p[0]).sum::<f64>() / bottom.len() as f64;
        assert!((mx - 0.5).abs() < 0.02, "mean x {mx}");
        assert_eq!(s, sample_surface(&m, 20000, 7));
        assert_ne!(s, sample_surface(&m, 20000, 8));
        assert!(sample_surface(&TriMesh::default(), 10, 1).is_empty());
        // Density 4x on the unit square (area 1 vs 4): half the samples land there.
        let w = sample_surface_weighted(&m, 20000, 7, &|t| if t < 2 { 4.0 } else { 1.0 });
        let bottom = w.iter().filter(|(p, _)| p[2] < 2.5).count() as f64 / 20000.0;
        assert!((bottom - 0.5).abs() < 0.02, "bottom fraction {bottom}");
    }
}
