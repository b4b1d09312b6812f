//! Procedural splined shaft and hub (closed triangle meshes, mm) for the `spline` scene.
//!
//! Both parts are extrusions along `z` of a star-shaped polar profile `r(theta)`: a root circle
//! with `keys` rectangular-ish keys (angular sectors with steep ramps), so every cross-section
//! is star-shaped about the axis and caps triangulate as fans or quad strips.
//!
//! - The **shaft** (tool frame): root radius `R`, keys of height `h` and angular half-width
//!   `phi`, from `z = 0` (its tip) to `z = length`.
//! - The **hub** (world frame): a cylinder of radius `hub_radius` from `z = -hub_height` to
//!   `z = 0` with a through hole whose profile is the shaft's grown by `clearance`: root radius
//!   `R + c`, key tops `R + h + c`, keyway half-width `phi + c / R` (so the side gap is at least
//!   `c` at every radius).

use std::f64::consts::PI;

use mesh::TriMesh;

/// Dimensions of the splined shaft and hub (mm, rad).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SplineParams {
    /// Number of keys (and keyways).
    pub keys: u32,
    /// Shaft root (minor) radius, mm.
    pub root_radius: f64,
    /// Key height above the root circle, mm.
    pub key_height: f64,
    /// Key angular half-width, rad.
    pub key_half_angle: f64,
    /// Angular width of the ramp between root and key top, rad (small: near-radial sides).
    pub ramp_angle: f64,
    /// Radial and lateral clearance between shaft and hole, mm.
    pub clearance: f64,
    /// Shaft length, mm.
    pub shaft_length: f64,
    /// Hub outer radius, mm.
    pub hub_radius: f64,
    /// Hub height (hole length), mm.
    pub hub_height: f64,
    /// Largest angular step of the profile sampling on arcs, rad.
    pub max_arc_step: f64,
    /// Largest spacing of the rings along `z`, mm.
    pub max_ring_spacing: f64,
}

impl Default for SplineParams {
    fn default() -> Self {
        Self {
            keys: 6,
            root_radius: 10.0,
            key_height: 3.0,
            key_half_angle: 10f64.to_radians(),
            ramp_angle: 1f64.to_radians(),
            clearance: 1.0,
            shaft_length: 50.0,
            hub_radius: 24.0,
            hub_height: 30.0,
            max_arc_step: 3f64.to_radians(),
            max_ring_spacing: 2.5,
        }
    }
}

impl SplineParams {
    /// Angular pitch between keys, rad.
    pub fn pitch(&self) -> f64 {
        2.0 * PI / f64::from(self.keys.max(1))
    }

    /// Half-width of the hub's keyways, rad.
    pub fn keyway_half_angle(&self) -> f64 {
        self.key_half_angle + self.clearance / self.root_radius
    }

    /// The polar profile `(theta, r)` of the shaft (`grow = 0`) or the hole (`grow = c`),
    /// angles strictly increasing in `[0, 2 pi)`.
    pub fn profile(&self, hole: bool) -> Vec<(f64, f64)> {
        let (c, half) = if hole {
            (self.clearance, self.keyway_half_angle())
        } else {
            (0.0, self.key_half_angle)
        };
        let r0 = self.root_radius + c;
        let r1 = self.root_radius + self.key_height + c;
        let pitch = self.pitch();
        let ramp = self.ramp_angle.min(half);
        let mut out = Vec::new();
        let arc = |out: &mut Vec<(f64, f64)>, a0: f64, a1: f64, r: f64| {
            // Points on [a0, a1] (both ends included).
            let n = ((a1 - a0) / self.max_arc_step).ceil().max(1.0) as usize;
            for i in 0..=n {
                out.push((a0 + (a1 - a0) * i as f64 / n as f64, r));
            }
        };
        for k in 0..self.keys {
            // Key k is centred at theta = k * pitch; the period runs from the key centre on.
            let a = f64::from(k) * pitch;
            arc(&mut out, a, a + half - ramp / 2.0, r1);
            arc(
                &mut out,
                a + half + ramp / 2.0,
                a + pitch - half - ramp / 2.0,
                r0,
            );
            let top_start = a + pitch - half + ramp / 2.0;
            let n = ((half - ramp / 2.0) / self.max_arc_step).ceil().max(1.0) as usize;
            for i in 0..n {
                out.push((
                    top_start + (a + pitch - top_start) * i as f64 / n as f64,
                    r1,
                ));
            }
        }
        out
    }

    /// The shaft mesh in its own frame (tip at `z = 0`, along `+z`), mm.
    pub fn shaft_mesh(&self) -> TriMesh {
        let prof = self.profile(false);
        let m = prof.len() as u32;
        let rings = ((self.shaft_length / self.max_ring_spacing).ceil() as u32).max(1);
        let mut mesh = TriMesh::default();
        for j in 0..=rings {
            let z = self.shaft_length * f64::from(j) / f64::from(rings);
            for &(a, r) in &prof {
                mesh.vertices.push([r * a.cos(), r * a.sin(), z]);
            }
        }
        let v = |j: u32, i: u32| j * m + (i % m);
        for j in 0..rings {
            for i in 0..m {
                mesh.triangles.push([v(j, i), v(j, i + 1), v(j + 1, i + 1)]);
                mesh.triangles.push([v(j, i), v(j + 1, i + 1), v(j + 1, i)]);
            }
        }
        let cb = mesh.vertices.len() as u32;
        mesh.vertices.push([0.0, 0.0, 0.0]);
        let ct = cb + 1;
        mesh.vertices.push([0.0, 0.0, self.shaft_length]);
        for i in 0..m {
            mesh.triangles.push([cb, v(0, i + 1), v(0, i)]);
            mesh.triangles.push([ct, v(rings, i), v(rings, i + 1)]);
        }
        mesh
    }

    /// The hub mesh in the world frame (top face at `z = 0`, hole along `z`), mm.
    pub fn hub_mesh(&self) -> TriMesh {
        let prof = self.profile(true);
        let m = prof.len() as u32;
        let rings = ((self.hub_height / self.max_ring_spacing).ceil() as u32).max(1);
        let mut mesh = TriMesh::default();
        // Inner rings (hole wall), then outer rings (same angles, radius hub_radius).
        for j in 0..=rings {
            let z = -self.hub_height + self.hub_height * f64::from(j) / f64::from(rings);
            for &(a, r) in &prof {
                mesh.vertices.push([r * a.cos(), r * a.sin(), z]);
            }
        }
        let outer0 = mesh.vertices.len() as u32;
        for j in 0..=rings {
            let z = -self.hub_height + self.hub_height * f64::from(j) / f64::from(rings);
            for &(a, _) in &prof {
                mesh.vertices
                    .push([self.hub_radius * a.cos(), self.hub_radius * a.sin(), z]);
            }
        }
        let vin = |j: u32, i: u32| j * m + (i % m);
        let vout = |j: u32, i: u32| outer0 + j * m + (i % m);
        for j in 0..rings {
            for i in 0..m {
                // Hole wall: normals point towards the axis.
                mesh.triangles
                    .push([vin(j, i), vin(j + 1, i + 1), vin(j, i + 1)]);
                mesh.triangles
                    .push([vin(j, i), vin(j + 1, i), vin(j + 1, i + 1)]);
                // Outer wall: normals point away from the axis.
                mesh.triangles
                    .push([vout(j, i), vout(j, i + 1), vout(j + 1, i + 1)]);
                mesh.triangles
                    .push([vout(j, i), vout(j + 1, i + 1), vout(j + 1, i)]);
            }
        }
        for i in 0..m {
            // Top annulus (z = 0, normal +z) and bottom annulus (normal -z).
            let (a0, a1, b0, b1) = (
                vin(rings, i),
                vin(rings, i + 1),
                vout(rings, i),
                vout(rings, i + 1),
            );
            mesh.triangles.push([a0, b0, b1]);
            mesh.triangles.push([a0, b1, a1]);
            let (a0, a1, b0, b1) = (vin(0, i), vin(0, i + 1), vout(0, i), vout(0, i + 1));
            mesh.triangles.push([a0, b1, b0]);
            mesh.triangles.push([a0, a1, b1]);
        }
        mesh
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    /// Every directed edge appears once and its reverse once: closed, consistently oriented.
    fn assert_closed_oriented(m: &TriMesh) {
        let mut edges: HashMap<(u32, u32), u32> = HashMap::new();
        for t in &m.triangles {
            for k in 0..3 {
                *edges.entry((t[k], t[(k + 1) % 3])).or_default() += 1;
            }
        }
        for (&(a, b), &n) in &edges {
            assert_eq!(n, 1, "edge {a}->{b} used {n} times");
            assert_eq!(edges.get(&(b, a)), Some(&1), "edge {a}->{b} has no twin");
        }
    }

    #[test]
    fn meshes_are_closed_with_outward_normals_and_expected_volume() {
        let p = SplineParams::default();
        let (shaft, hub) = (p.shaft_mesh(), p.hub_mesh());
        assert_closed_oriented(&shaft);
        assert_closed_oriented(&hub);
        // Shaft volume: root disc plus keys (sectors of the annulus), up to ramp/arc faceting.
        let keys = f64::from(p.keys);
        let r0 = p.root_radius;
        let r1 = r0 + p.key_height;
        let area = PI * r0 * r0 + keys * p.key_half_angle * (r1 * r1 - r0 * r0);
        let v = shaft.signed_volume();
        let expect = area * p.shaft_length;
        assert!(
            (v - expect).abs() < 0.02 * expect,
            "shaft volume {v} vs {expect}"
        );
        let vh = hub.signed_volume();
        let rh0 = r0 + p.clearance;
        let rh1 = r1 + p.clearance;
        let hole = PI * rh0 * rh0 + keys * p.keyway_half_angle() * (rh1 * rh1 - rh0 * rh0);
        let expect = (PI * p.hub_radius * p.hub_radius - hole) * p.hub_height;
        assert!(
            (vh - expect).abs() < 0.02 * expect,
            "hub volume {vh} vs {expect}"
        );
    }

    #[test]
    fn hole_profile_clears_the_shaft_by_the_clearance() {
        let p = SplineParams::default();
        let shaft = p.profile(false);
        let hole = p.profile(true);
        let r_at = |prof: &[(f64, f64)], a: f64| {
            let n = prof.len();
            for i in 0..n {
                let (a0, r0) = prof[i];
                let (mut a1, r1) = prof[(i + 1) % n];
                if i + 1 == n {
                    a1 += 2.0 * PI;
                }
                if a >= a0 && a <= a1 {
                    return r0 + (r1 - r0) * (a - a0) / (a1 - a0);
                }
            }
            prof[0].1
        };
        for k in 0..3600 {
            let a = f64::from(k) * 2.0 * PI / 3600.0 + 1e-6;
            assert!(
                r_at(&hole, a) >= r_at(&shaft, a) + p.clearance - 1e-9,
                "angle {a}"
            );
        }
    }
}
