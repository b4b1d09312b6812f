//! The area two flat faces share, for friction's torsional radius in the mesh geometry mode
//! (docs/DESIGN.md §Friction): where a tool triangle lies flat on an object triangle, their
//! contact is the overlap of the two in the contact plane, and a uniform pressure over it
//! resists a twist about a point `c` with the moment `mu p ∫|r - c| dA`.
//!
//! The overlap is the tool triangle clipped by the object's (both convex, projected on the
//! plane), and `∫|r - c| dA` over a polygon has a closed form: the sum over its edges of the
//! signed triangles they make with `c`, each `∫ ρ² dρ dθ` in polar coordinates about `c`.

use nalgebra::{Vector2, Vector3};

use crate::Triangle;

type V2 = Vector2<f64>;

/// A flat contact's share: its area (mm²) and the integral of the distance from a point over
/// it (mm³).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AreaMoment {
    /// Area, mm².
    pub area: f64,
    /// `∫|r - c| dA`, mm³.
    pub abs_moment: f64,
}

/// The overlap of the tool triangle `tool` and the object triangle `part` (world, mm) in the
/// plane normal to `normal` (unit), when both lie flat in it (each face's normal within
/// `flat_cos` of it, as a cosine), and `∫|r - c| dA` over it about `centre` (projected on the
/// plane). `None` when either face is tilted more; a zero area when they do not overlap.
///
/// # Real-time
/// No allocation, no panic (at most 9 vertices, fixed arrays).
pub fn flat_overlap(
    tool: &Triangle,
    part: &Triangle,
    normal: &Vector3<f64>,
    centre: &Vector3<f64>,
    flat_cos: f64,
) -> Option<AreaMoment> {
    let corners = |t: &Triangle| t.map(Vector3::from);
    let (a, b) = (corners(tool), corners(part));
    for t in [&a, &b] {
        let n = (t[1] - t[0]).cross(&(t[2] - t[0]));
        let len = n.norm();
        if len.is_nan() || len <= 0.0 || (n.dot(normal) / len).abs() < flat_cos {
            return None;
        }
    }
    // Plane coordinates about the centre.
    let u = normal.cross(&if normal.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    });
    let u = u / u.norm();
    let w = normal.cross(&u);
    let flat = |p: &Vector3<f64>| V2::new((p - centre).dot(&u), (p - centre).dot(&w));
    let ccw = |t: &[Vector3<f64>; 3]| {
        let mut p = [flat(&t[0]), flat(&t[1]), flat(&t[2])];
        if cross(&(p[1] - p[0]), &(p[2] - p[0])) < 0.0 {
            p.swap(1, 2);
        }
        p
    };
    let (pa, pb) = (ccw(&a), ccw(&b));
    let mut poly = Polygon::from(&pa);
    for k in 0..3 {
        poly = poly.clip(&pb[k], &pb[(k + 1) % 3]);
        if poly.len < 3 {
            return Some(AreaMoment::default());
        }
    }
    Some(poly.area_moment())
}

fn cross(p: &V2, q: &V2) -> f64 {
    p.x * q.y - p.y * q.x
}

/// A convex polygon of at most 9 vertices (a triangle clipped by three half-planes).
struct Polygon {
    v: [V2; 9],
    len: usize,
}

impl Polygon {
    fn from(t: &[V2; 3]) -> Self {
        let mut v = [V2::zeros(); 9];
        v[..3].copy_from_slice(t);
        Self { v, len: 3 }
    }

    /// The part on the left of the line from `p` to `q`.
    fn clip(&self, p: &V2, q: &V2) -> Self {
        let mut out = Self {
            v: [V2::zeros(); 9],
            len: 0,
        };
        let e = q - p;
        let side = |x: &V2| cross(&e, &(x - p));
        for i in 0..self.len {
            let (x, y) = (self.v[i], self.v[(i + 1) % self.len]);
            let (sx, sy) = (side(&x), side(&y));
            if sx >= 0.0 && out.len < 9 {
                out.v[out.len] = x;
                out.len += 1;
            }
            if (sx >= 0.0) != (sy >= 0.0) && out.len < 9 {
                out.v[out.len] = x + (y - x) * (sx / (sx - sy));
                out.len += 1;
            }
        }
        out
    }

    /// Area and `∫|r| dA` (the origin is the centre).
    fn area_moment(&self) -> AreaMoment {
        let mut m = AreaMoment::default();
        for i in 0..self.len {
            let (p, q) = (self.v[i], self.v[(i + 1) % self.len]);
            let signed = cross(&p, &q);
            m.area += 0.5 * signed;
            m.abs_moment += signed.signum() * edge_abs_moment(&p, &q);
        }
        m
    }
}

/// `∫|r| dA` over the triangle (origin, `p`, `q`), unsigned: in polar coordinates about the
/// origin, `∫ ρ(θ)³/3 dθ` with `ρ = h / cos φ` to the edge's line (at distance `h`, `φ` from
/// its foot), whose primitive is `(h³/6) (sec φ tan φ + ln(sec φ + tan φ))`; with `tan φ = t/h`
/// along the edge, `F(t) = (h t √(h² + t²) + h³ asinh(t/h)) / 6` (`asinh`, not the logarithm
/// of `√(h² + t²) + t`, which cancels to zero far behind the foot).
fn edge_abs_moment(p: &V2, q: &V2) -> f64 {
    let d = q - p;
    let len = d.norm();
    if len.is_nan() || len <= 0.0 {
        return 0.0;
    }
    let e = d / len;
    let (tp, tq) = (p.dot(&e), q.dot(&e));
    let h = (p - e * tp).norm();
    if h.is_nan() || h <= 1e-12 * len {
        return 0.0;
    }
    let f = |t: f64| {
        let s = (h * h + t * t).sqrt();
        (h * t * s + h * h * h * (t / h).asinh()) / 6.0
    };
    f(tq) - f(tp)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    const FLAT: f64 = 0.9998;

    /// A square of side `s` about the origin in `z = z`, as two triangles.
    fn square(s: f64, z: f64) -> [Triangle; 2] {
        let h = s / 2.0;
        [
            [[-h, -h, z], [h, -h, z], [h, h, z]],
            [[-h, -h, z], [h, h, z], [-h, h, z]],
        ]
    }

    #[test]
    fn a_square_on_a_larger_face_shares_its_area_and_mean_radius() {
        let floor: Triangle = [[-50.0, -50.0, 0.0], [50.0, -50.0, 0.0], [0.0, 80.0, 0.0]];
        let (n, c) = (Vector3::z(), Vector3::zeros());
        let mut total = AreaMoment::default();
        for t in square(10.0, 0.005) {
            let m = flat_overlap(&t, &floor, &n, &c, FLAT).unwrap();
            total.area += m.area;
            total.abs_moment += m.abs_moment;
        }
        // The mean distance from a unit square's centre: (√2 + ln(1 + √2)) / 6.
        let mean = (2f64.sqrt() + (1.0 + 2f64.sqrt()).ln()) / 6.0;
        assert!((total.area - 100.0).abs() < 1e-9, "{}", total.area);
        assert!((total.abs_moment / total.area - 10.0 * mean).abs() < 1e-9);
    }

    #[test]
    fn a_disc_of_many_sides_has_two_thirds_of_its_radius() {
        let (n, r, sides) = (Vector3::z(), 7.0, 720);
        let floor: Triangle = [[-50.0, -50.0, 0.0], [50.0, -50.0, 0.0], [0.0, 80.0, 0.0]];
        let mut total = AreaMoment::default();
        for k in 0..sides {
            let at = |i: usize| {
                let a = std::f64::consts::TAU * i as f64 / sides as f64;
                [r * a.cos(), r * a.sin(), 0.0]
            };
            let t: Triangle = [[0.0, 0.0, 0.0], at(k), at(k + 1)];
            let m = flat_overlap(&t, &floor, &n, &Vector3::zeros(), FLAT).unwrap();
            total.area += m.area;
            total.abs_moment += m.abs_moment;
        }
        let rho = total.abs_moment / total.area;
        assert!((rho - 2.0 * r / 3.0).abs() < 1e-4 * r, "{rho}");
    }

    /// Random overlapping triangles about random centres: the area and the moment against a
    /// fine grid of points in the plane.
    #[test]
    fn random_overlaps_match_a_sampled_integral() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(3);
        let tri = |rng: &mut rand::rngs::StdRng| -> Triangle {
            std::array::from_fn(|_| {
                [
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                    0.0,
                ]
            })
        };
        let inside = |t: &Triangle, x: f64, y: f64| {
            let s = |i: usize| {
                let (a, b) = (t[i], t[(i + 1) % 3]);
                (b[0] - a[0]) * (y - a[1]) - (b[1] - a[1]) * (x - a[0])
            };
            let (s0, s1, s2) = (s(0), s(1), s(2));
            (s0 >= 0.0 && s1 >= 0.0 && s2 >= 0.0) || (s0 <= 0.0 && s1 <= 0.0 && s2 <= 0.0)
        };
        for case in 0..20 {
            let (a, b) = (tri(&mut rng), tri(&mut rng));
            let c = [rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)];
            let m =
                flat_overlap(&a, &b, &Vector3::z(), &Vector3::new(c[0], c[1], 0.0), FLAT).unwrap();
            let (n, cell) = (800, 2.0 / 800.0);
            let (mut area, mut moment) = (0.0, 0.0);
            for i in 0..n {
                for j in 0..n {
                    let (x, y) = (
                        -1.0 + (i as f64 + 0.5) * cell,
                        -1.0 + (j as f64 + 0.5) * cell,
                    );
                    if inside(&a, x, y) && inside(&b, x, y) {
                        area += cell * cell;
                        moment += cell * cell * ((x - c[0]).powi(2) + (y - c[1]).powi(2)).sqrt();
                    }
                }
            }
            assert!(
                (m.area - area).abs() < 0.01 * (1.0 + area) * 0.5,
                "case {case}: area {} against {area}",
                m.area
            );
            assert!(
                (m.abs_moment - moment).abs() < 0.01 * (1.0 + moment) * 0.5,
                "case {case}: moment {} against {moment}",
                m.abs_moment
            );
        }
    }

    /// A centre far along an edge's line, behind its foot, and just off it: the moment stays
    /// finite and equals the area times the distance to within the triangle's size.
    #[test]
    fn a_far_centre_on_an_edge_line_gives_a_finite_moment() {
        let t: Triangle = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        for c in [
            [1000.0, 1e-9],
            [1000.0, -1e-9],
            [-1000.0, 1e-12],
            [0.5, 1e-9],
        ] {
            let m =
                flat_overlap(&t, &t, &Vector3::z(), &Vector3::new(c[0], c[1], 0.0), FLAT).unwrap();
            assert!(m.abs_moment.is_finite(), "{c:?}: {m:?}");
            assert!((m.area - 0.5).abs() < 1e-12);
            if c[0].abs() > 10.0 {
                let mean = m.abs_moment / m.area;
                assert!(
                    (mean - c[0].abs()).abs() < 1.0,
                    "{c:?}: mean distance {mean}"
                );
            }
        }
    }

    #[test]
    fn tilted_faces_are_not_flat_contacts() {
        let [t, _] = square(10.0, 0.0);
        let tilted: Triangle = [[-5.0, -5.0, 0.0], [5.0, -5.0, 0.5], [5.0, 5.0, 0.5]];
        assert!(flat_overlap(&tilted, &t, &Vector3::z(), &Vector3::zeros(), FLAT).is_none());
        assert!(flat_overlap(&t, &t, &Vector3::z(), &Vector3::zeros(), FLAT).is_some());
    }
}
