//! Smallest enclosing sphere of spheres, and the small derivative-free minimiser the builders
//! share.

#![allow(clippy::needless_range_loop)] // xyz loops read better indexed

use crate::eval::{add, dist, scale, sub};
use crate::Sphere;

/// A sphere containing every sphere of `spheres` (same units), close to the smallest one:
/// Bădoiu–Clarkson iterations for a start, then a Nelder–Mead polish of the centre on the
/// convex function `max_i |c - c_i| + r_i`. The radius is computed last from the centre, so
/// containment holds exactly whatever the quality of the centre. Unused spheres are ignored;
/// an empty input gives [`Sphere::UNUSED`].
pub fn enclosing_sphere(spheres: &[Sphere]) -> Sphere {
    let used: Vec<&Sphere> = spheres.iter().filter(|s| s.is_used()).collect();
    let Some(first) = used.first() else {
        return Sphere::UNUSED;
    };
    if used.len() == 1 {
        return **first;
    }
    let f = |c: [f64; 3]| {
        used.iter()
            .map(|s| dist(c, s.center) + s.radius)
            .fold(f64::NEG_INFINITY, f64::max)
    };
    // Start: centroid of the centres, then Bădoiu–Clarkson steps towards the farthest point.
    let mut c = [0.0; 3];
    for s in &used {
        c = add(c, s.center);
    }
    c = scale(c, 1.0 / used.len() as f64);
    for it in 1..=64 {
        let (far, fd) = used
            .iter()
            .map(|s| (s, dist(c, s.center)))
            .max_by(|a, b| (a.1 + a.0.radius).total_cmp(&(b.1 + b.0.radius)))
            .map(|(s, d)| (*s, d))
            .unwrap_or((first, 0.0));
        let dir = if fd > 0.0 {
            scale(sub(far.center, c), 1.0 / fd)
        } else {
            [1.0, 0.0, 0.0]
        };
        let target = add(far.center, scale(dir, far.radius));
        c = add(c, scale(sub(target, c), 1.0 / (it as f64 + 1.0)));
    }
    let step = 0.05 * f(c);
    let c = nelder_mead(&f, c, step, 300, 1e-9 * f(c).abs().max(1e-300));
    Sphere::new(c, f(c))
}

/// Minimises `f` over R^3 from `x0` with a Nelder–Mead simplex of size `step`; stops after
/// `max_evals` evaluations or when the simplex's value spread falls below `ftol`. Returns the
/// best point found.
pub(crate) fn nelder_mead(
    f: &dyn Fn([f64; 3]) -> f64,
    x0: [f64; 3],
    step: f64,
    max_evals: usize,
    ftol: f64,
) -> [f64; 3] {
    let mut pts = [x0; 4];
    for k in 0..3 {
        pts[k + 1][k] += step;
    }
    let mut vals = pts.map(f);
    let mut evals = 4;
    while evals < max_evals {
        // Order best..worst.
        let mut idx = [0usize, 1, 2, 3];
        idx.sort_by(|&a, &b| vals[a].total_cmp(&vals[b]));
        pts = idx.map(|i| pts[i]);
        vals = idx.map(|i| vals[i]);
        if (vals[3] - vals[0]).abs() <= ftol {
            break;
        }
        let cen = scale(add(add(pts[0], pts[1]), pts[2]), 1.0 / 3.0);
        let toward = |t: f64| add(cen, scale(sub(pts[3], cen), t));
        let xr = toward(-1.0);
        let fr = f(xr);
        evals += 1;
        if fr < vals[0] {
            let xe = toward(-2.0);
            let fe = f(xe);
            evals += 1;
            if fe < fr {
                pts[3] = xe;
                vals[3] = fe;
            } else {
                pts[3] = xr;
                vals[3] = fr;
            }
        } else if fr < vals[2] {
            pts[3] = xr;
            vals[3] = fr;
        } else {
            let (xc, fc) = if fr < vals[3] {
                let x = toward(-0.5);
                (x, f(x))
            } else {
                let x = toward(0.5);
                (x, f(x))
            };
            evals += 1;
            if fc < vals[3].min(fr) {
                pts[3] = xc;
                vals[3] = fc;
            } else {
                // Shrink towards the best point.
                for k in 1..4 {
                    pts[k] = add(pts[0], scale(sub(pts[k], pts[0]), 0.5));
                    vals[k] = f(pts[k]);
                }
                evals += 3;
            }
        }
    }
    let best = (0..4)
        .min_by(|&a, &b| vals[a].total_cmp(&vals[b]))
        .unwrap_or(0);
    pts[best]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn encloses_and_is_near_minimal() {
        // Two unit spheres 4 apart: the smallest enclosing sphere has radius 3 at the middle.
        let s = [
            Sphere::new([-2.0, 0.0, 0.0], 1.0),
            Sphere::new([2.0, 0.0, 0.0], 1.0),
        ];
        let e = enclosing_sphere(&s);
        assert!((e.radius - 3.0).abs() < 1e-3, "{e:?}");
        // A small sphere inside a big one: the big one.
        let s = [
            Sphere::new([0.0, 0.0, 0.0], 5.0),
            Sphere::new([1.0, 1.0, 0.0], 1.0),
            Sphere::UNUSED,
        ];
        let e = enclosing_sphere(&s);
        assert!((e.radius - 5.0).abs() < 1e-3, "{e:?}");
        // Regular tetrahedron of points (radius 0): circumradius.
        let t = [
            [1.0, 1.0, 1.0],
            [1.0, -1.0, -1.0],
            [-1.0, 1.0, -1.0],
            [-1.0, -1.0, 1.0],
        ];
        let s: Vec<Sphere> = t.iter().map(|c| Sphere::new(*c, 0.0)).collect();
        let e = enclosing_sphere(&s);
        assert!((e.radius - 3f64.sqrt()).abs() < 1e-3, "{e:?}");
        for x in &s {
            assert!(dist(x.center, e.center) + x.radius <= e.radius + 1e-12);
        }
        assert!(!enclosing_sphere(&[]).is_used());
    }
}
