//! The coupled tool: a rapier3d rigid body pulled by a 6-DoF spring-damper toward the device.
//!
//! rapier speaks glam (`DVec3`, `DQuat`, its `Pose`); haptic6d speaks nalgebra: the two meet
//! in [`to_rapier`] and [`from_rapier`] only.

use std::time::Instant;

use collide::{rotation_log, Pose};
use mesh::TriMesh;
use nalgebra::{Isometry3, Point3, Quaternion, Translation3, UnitQuaternion, Vector3};
use rapier3d_f64::math::{Pose as RPose, Rotation as RRotation, Vector as RVector};
use rapier3d_f64::parry::shape::TriMeshFlags;
use rapier3d_f64::parry::transformation::vhacd::VHACDParameters;
use rapier3d_f64::prelude::*;

/// Metres per millimetre: the public API is in mm, rapier runs in SI.
const M_PER_MM: f64 = 1e-3;

/// Why a peer scene could not be built.
#[derive(Debug, thiserror::Error)]
pub enum PeerError {
    /// A mesh has no vertex or no triangle.
    #[error("{what}: empty mesh")]
    EmptyMesh {
        /// Which mesh (`tool`, `object 0`, ...).
        what: String,
    },
    /// rapier refused a triangle mesh.
    #[error("{what}: {why}")]
    BadMesh {
        /// Which mesh.
        what: String,
        /// rapier's reason.
        why: String,
    },
    /// The convex hull of a mesh is degenerate (flat or a single point).
    #[error("{what}: degenerate convex hull")]
    DegenerateHull {
        /// Which mesh.
        what: String,
    },
    /// A parameter is out of its range.
    #[error("peer parameter {name} = {value}: {why}")]
    BadParameter {
        /// Parameter name.
        name: &'static str,
        /// Its value.
        value: f64,
        /// What it must be.
        why: &'static str,
    },
}

/// How the tool mesh becomes a rapier collider.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ToolShape {
    /// VHACD convex decomposition (parry's) at this voxel resolution (parry's default is 64):
    /// convex parts against the objects, what rapier's users pick for a dynamic concave body.
    ConvexDecomposition {
        /// Voxels along the longest side.
        resolution: u32,
    },
    /// One convex hull of the whole mesh (exact for convex tools: the puck, the ball).
    ConvexHull,
    /// The convex hull when the mesh is convex (its hull holds no more than 0.1 % more volume),
    /// else the convex decomposition at this resolution: what a careful user picks per tool
    /// (VHACD splits even a ball into parts that leave dents in its surface).
    HullIfConvex {
        /// Voxels along the longest side of the decomposition.
        resolution: u32,
    },
    /// The triangle mesh itself (trimesh against trimesh: thousands of contact points at
    /// contact onset, steps of 100+ ms on the bunny).
    TriMesh,
}

/// How an object mesh becomes a fixed rapier collider.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ObjectShape {
    /// The triangle mesh; a trimesh has no inside, so a tool pulled through its surface stays
    /// through.
    TriMesh {
        /// parry's `FIX_INTERNAL_EDGES` (no bumps when sliding over triangle edges).
        fix_internal_edges: bool,
    },
    /// VHACD convex decomposition at this voxel resolution.
    ConvexDecomposition {
        /// Voxels along the longest side.
        resolution: u32,
    },
}

/// The peer's parameters: the coupling (shared with haptic6d) and rapier's own settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PeerParams {
    /// Translational coupling stiffness, N/mm (haptic6d's `kt`).
    pub kt_n_per_mm: f64,
    /// Rotational coupling stiffness, N·mm/rad (haptic6d's `kr`).
    pub kr_nmm_per_rad: f64,
    /// Damping of the coupling as a fraction of critical damping of the tool's mass on the
    /// spring (1 = critical), applied to the tool's velocity relative to the hand's, so a tool
    /// that follows the hand feels no damping force.
    pub damping_ratio: f64,
    /// Mass of the tool body, kg. Its inertia is isotropic, `mass · kr / kt`, so turning and
    /// sliding have the same natural frequency `sqrt(kt / mass)` on the spring; its centre of
    /// mass is the tool frame's origin, where the spring pulls.
    pub mass_kg: f64,
    /// Haptic rate: one rapier step of `1 / rate_hz` s per device frame, Hz.
    pub rate_hz: f64,
    /// Rapier's `length_unit`: how many simulation units (here metres) a typical object
    /// measures, scaling its allowed penetration (1 mm × length_unit), prediction distance
    /// (2 mm × length_unit) and largest corrective velocity (10 m/s × length_unit).
    pub length_unit: f64,
    /// Rapier's solver iterations per step (its default is 4).
    pub solver_iterations: usize,
    /// Natural frequency of rapier's soft contacts with the fixed objects, Hz (rapier's
    /// `static_contact_softness`, its default 60; set in `contact_softness` too, default 30).
    pub contact_natural_frequency_hz: f64,
    /// Continuous collision detection on the tool body.
    pub ccd: bool,
    /// Coulomb friction coefficient of every collider (0: frictionless, as haptic6d).
    pub friction: f64,
}

impl PeerParams {
    /// The parameters the tuning search chose (docs/BENCHMARKS.md, "Peer: virtual coupling on
    /// rapier3d"), with haptic6d's default coupling (`kt` 1 N/mm, `kr` 1000 N·mm/rad) at 1 kHz.
    pub fn tuned() -> Self {
        Self {
            kt_n_per_mm: 1.0,
            kr_nmm_per_rad: 1000.0,
            damping_ratio: 1.0,
            mass_kg: 0.05,
            rate_hz: 1000.0,
            length_unit: 0.01,
            solver_iterations: 4,
            contact_natural_frequency_hz: 100.0,
            ccd: false,
            friction: 0.0,
        }
    }

    /// Translational stiffness in SI, N/m.
    fn kt_si(&self) -> f64 {
        self.kt_n_per_mm / M_PER_MM
    }

    /// Rotational stiffness in SI, N·m/rad.
    fn kr_si(&self) -> f64 {
        self.kr_nmm_per_rad * M_PER_MM
    }

    /// Isotropic rotational inertia of the tool body, kg·m².
    pub fn inertia_kg_m2(&self) -> f64 {
        self.mass_kg * self.kr_si() / self.kt_si()
    }

    /// Translational damping, N·s/m, and rotational damping, N·m·s/rad.
    fn dampings(&self) -> (f64, f64) {
        let c = 2.0 * self.damping_ratio * (self.kt_si() * self.mass_kg).sqrt();
        let cr = 2.0 * self.damping_ratio * (self.kr_si() * self.inertia_kg_m2()).sqrt();
        (c, cr)
    }

    fn validate(&self) -> Result<(), PeerError> {
        let positive: [(&'static str, f64); 6] = [
            ("kt_n_per_mm", self.kt_n_per_mm),
            ("kr_nmm_per_rad", self.kr_nmm_per_rad),
            ("mass_kg", self.mass_kg),
            ("rate_hz", self.rate_hz),
            ("length_unit", self.length_unit),
            (
                "contact_natural_frequency_hz",
                self.contact_natural_frequency_hz,
            ),
        ];
        for (name, value) in positive {
            if !(value.is_finite() && value > 0.0) {
                return Err(PeerError::BadParameter {
                    name,
                    value,
                    why: "must be a positive number",
                });
            }
        }
        for (name, value) in [
            ("damping_ratio", self.damping_ratio),
            ("friction", self.friction),
        ] {
            if !(value.is_finite() && value >= 0.0) {
                return Err(PeerError::BadParameter {
                    name,
                    value,
                    why: "must be a number >= 0",
                });
            }
        }
        if self.solver_iterations == 0 {
            return Err(PeerError::BadParameter {
                name: "solver_iterations",
                value: 0.0,
                why: "must be at least 1",
            });
        }
        Ok(())
    }
}

/// The rapier shapes of a scene (SI units), built once and shared by the runs on it.
#[derive(Clone)]
pub struct PeerScene {
    tool: SharedShape,
    objects: Vec<(SharedShape, RPose)>,
    /// Convex parts of the tool (1 for a hull, triangles for a trimesh).
    pub tool_parts: usize,
}

impl PeerScene {
    /// The tool's collider as convex meshes in the tool frame, mm: its parts (a decomposition),
    /// its hull, or its triangle mesh (one piece).
    pub fn tool_pieces(&self) -> Vec<TriMesh> {
        part_meshes(&self.tool)
    }
}

impl std::fmt::Debug for PeerScene {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PeerScene")
            .field("tool_parts", &self.tool_parts)
            .field("objects", &self.objects.len())
            .finish()
    }
}

fn points_si(mesh: &TriMesh) -> Vec<Point3<f64>> {
    mesh.vertices
        .iter()
        .map(|v| Point3::new(v[0], v[1], v[2]) * M_PER_MM)
        .collect()
}

/// A mesh's vertices in SI as rapier's vectors, m.
fn vectors_si(mesh: &TriMesh) -> Vec<RVector> {
    mesh.vertices
        .iter()
        .map(|v| RVector::new(v[0], v[1], v[2]) * M_PER_MM)
        .collect()
}

/// An nalgebra isometry as rapier's pose (same units).
fn to_rapier(iso: &Isometry3<f64>) -> RPose {
    let t = iso.translation.vector;
    let q = iso.rotation;
    RPose::from_parts(
        RVector::new(t.x, t.y, t.z),
        RRotation::from_xyzw(q.i, q.j, q.k, q.w),
    )
}

/// rapier's pose as an nalgebra isometry (same units).
fn from_rapier(pose: &RPose) -> Isometry3<f64> {
    let (t, q) = (pose.translation, pose.rotation);
    Isometry3::from_parts(
        Translation3::new(t.x, t.y, t.z),
        UnitQuaternion::from_quaternion(Quaternion::new(q.w, q.x, q.y, q.z)),
    )
}

/// A rapier vector as an nalgebra one.
fn vec_na(v: RVector) -> Vector3<f64> {
    Vector3::new(v.x, v.y, v.z)
}

/// An nalgebra vector as a rapier one.
fn vec_rapier(v: &Vector3<f64>) -> RVector {
    RVector::new(v.x, v.y, v.z)
}

fn check_mesh(mesh: &TriMesh, what: &str) -> Result<(), PeerError> {
    if mesh.vertices.is_empty() || mesh.triangles.is_empty() {
        return Err(PeerError::EmptyMesh { what: what.into() });
    }
    Ok(())
}

fn decomposition(mesh: &TriMesh, resolution: u32) -> SharedShape {
    let params = VHACDParameters {
        resolution,
        ..VHACDParameters::default()
    };
    SharedShape::convex_decomposition_with_params(&vectors_si(mesh), &mesh.triangles, &params)
}

fn trimesh(mesh: &TriMesh, fix_internal_edges: bool, what: &str) -> Result<SharedShape, PeerError> {
    let flags = if fix_internal_edges {
        TriMeshFlags::FIX_INTERNAL_EDGES
    } else {
        TriMeshFlags::empty()
    };
    SharedShape::trimesh_with_flags(vectors_si(mesh), mesh.triangles.clone(), flags).map_err(|e| {
        PeerError::BadMesh {
            what: what.into(),
            why: e.to_string(),
        }
    })
}

/// Volume enclosed by a closed, outward-oriented mesh, m³ (the divergence theorem over its
/// triangles).
fn enclosed_volume_m3(mesh: &TriMesh) -> f64 {
    let p = points_si(mesh);
    let sixfold: f64 = mesh
        .triangles
        .iter()
        .filter(|t| t.iter().all(|&k| (k as usize) < p.len()))
        .map(|t| {
            let [a, b, c] = t.map(|k| p[k as usize].coords);
            a.dot(&b.cross(&c))
        })
        .sum();
    sixfold / 6.0
}

/// A pose (mm, rad) as an SI isometry.
fn iso_si(q: &Pose) -> Isometry3<f64> {
    let mut iso = q.to_isometry();
    iso.translation.vector *= M_PER_MM;
    iso
}

/// An SI isometry as a pose (mm, rad).
fn pose_mm(iso: &Isometry3<f64>) -> Pose {
    let scaled = Isometry3::from_parts(
        Translation3::from(iso.translation.vector / M_PER_MM),
        iso.rotation,
    );
    Pose::from_isometry(&scaled)
}

/// The convex pieces of a shape as meshes in its own frame, mm: each part of a compound (at its
/// place in the compound), a convex polyhedron's faces, a triangle mesh as it is.
fn part_meshes(shape: &SharedShape) -> Vec<TriMesh> {
    let as_mesh = |points: &[RVector], triangles: Vec<[u32; 3]>, at: &RPose| TriMesh {
        vertices: points
            .iter()
            .map(|&p| {
                let w = at.transform_point(p) / M_PER_MM;
                [w.x, w.y, w.z]
            })
            .collect(),
        triangles,
    };
    let one = |shape: &SharedShape, at: &RPose| -> Option<TriMesh> {
        if let Some(hull) = shape.as_convex_polyhedron() {
            let (points, triangles) = hull.to_trimesh();
            Some(as_mesh(&points, triangles, at))
        } else {
            shape
                .as_trimesh()
                .map(|t| as_mesh(t.vertices(), t.indices().to_vec(), at))
        }
    };
    match shape.as_compound() {
        Some(compound) => compound
            .shapes()
            .iter()
            .filter_map(|(at, part)| one(part, at))
            .collect(),
        None => one(shape, &RPose::IDENTITY).into_iter().collect(),
    }
}

/// The convex pieces a user of an engine without concave collision gives it for `mesh` (mm):
/// the mesh's convex hull when the mesh is convex (its hull holds no more than 0.1 % more
/// volume), else the VHACD parts at this voxel resolution, as meshes in the mesh's frame, mm
/// (the same rule as [`ToolShape::HullIfConvex`]).
pub fn convex_pieces(
    mesh: &TriMesh,
    resolution: u32,
    what: &str,
) -> Result<Vec<TriMesh>, PeerError> {
    check_mesh(mesh, what)?;
    Ok(part_meshes(&hull_if_convex(mesh, resolution, what)?))
}

/// The hull of a convex mesh, else its VHACD decomposition at `resolution`.
fn hull_if_convex(mesh: &TriMesh, resolution: u32, what: &str) -> Result<SharedShape, PeerError> {
    let hull = SharedShape::convex_hull(&vectors_si(mesh));
    let hull_volume = hull
        .as_ref()
        .map_or(f64::INFINITY, |h| h.mass_properties(1.0).mass());
    if hull_volume <= enclosed_volume_m3(mesh) * 1.001 {
        hull.ok_or_else(|| PeerError::DegenerateHull { what: what.into() })
    } else {
        Ok(decomposition(mesh, resolution))
    }
}

impl PeerScene {
    /// The tool (its own frame, mm) and the objects (each mesh in its own frame, mm, placed
    /// at its pose) as rapier shapes.
    pub fn new(
        tool: &TriMesh,
        objects: &[(&TriMesh, Pose)],
        tool_shape: ToolShape,
        object_shape: ObjectShape,
    ) -> Result<Self, PeerError> {
        check_mesh(tool, "tool")?;
        let (tool_collider, tool_parts) = match tool_shape {
            ToolShape::ConvexDecomposition { resolution } => {
                let shape = decomposition(tool, resolution);
                let parts = shape.as_compound().map_or(1, |c| c.shapes().len());
                (shape, parts)
            }
            ToolShape::ConvexHull => (
                SharedShape::convex_hull(&vectors_si(tool)).ok_or_else(|| {
                    PeerError::DegenerateHull {
                        what: "tool".into(),
                    }
                })?,
                1,
            ),
            ToolShape::HullIfConvex { resolution } => {
                let shape = hull_if_convex(tool, resolution, "tool")?;
                let parts = shape.as_compound().map_or(1, |c| c.shapes().len());
                (shape, parts)
            }
            ToolShape::TriMesh => (trimesh(tool, true, "tool")?, tool.triangles.len()),
        };
        let mut shapes = Vec::with_capacity(objects.len());
        for (i, (mesh, pose)) in objects.iter().enumerate() {
            check_mesh(mesh, &format!("object {i}"))?;
            let what = format!("object {i}");
            let shape = match object_shape {
                ObjectShape::TriMesh { fix_internal_edges } => {
                    trimesh(mesh, fix_internal_edges, &what)?
                }
                ObjectShape::ConvexDecomposition { resolution } => decomposition(mesh, resolution),
            };
            shapes.push((shape, to_rapier(&iso_si(pose))));
        }
        Ok(Self {
            tool: tool_collider,
            objects: shapes,
            tool_parts,
        })
    }
}

/// One frame of the peer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PeerFrame {
    /// The tool body's configuration after the step (mm, rad), as haptic6d's graphic tool.
    pub q_tool: [f64; 6],
    /// Coupling wrench on the hand `[F; T]`: N and N·mm (world axes), the spring-damper force
    /// of this frame (the force a device would be sent).
    pub wrench: [f64; 6],
    /// Contact points rapier's solver held this frame (within its prediction distance; its
    /// solver manifolds, which are the contact clusters when rapier clusters a pair's points).
    pub contacts: u32,
    /// Time of the frame: the coupling force and one rapier step, µs.
    pub step_us: f64,
}

/// One run of the virtual-coupling tool on a [`PeerScene`].
pub struct PeerTool {
    params: PeerParams,
    /// Translational (N·s/m) and rotational (N·m·s/rad) damping.
    damping: (f64, f64),
    /// rapier's world: the fixed objects and the tool body, no gravity.
    world: PhysicsWorld,
    tool: RigidBodyHandle,
    tool_collider: ColliderHandle,
    /// The device pose of the previous frame (SI), for the hand's velocity.
    last_hand: Option<Isometry3<f64>>,
}

impl PeerTool {
    /// A rapier world with the scene's objects fixed and the tool body at `start` (mm, rad),
    /// at rest.
    pub fn new(scene: &PeerScene, params: PeerParams, start: &Pose) -> Result<Self, PeerError> {
        params.validate()?;
        let mut world = PhysicsWorld::new();
        world.gravity = RVector::ZERO;
        let p = &mut world.integration_parameters;
        p.dt = 1.0 / params.rate_hz;
        p.length_unit = params.length_unit;
        p.num_solver_iterations = params.solver_iterations;
        // The tool only ever touches fixed objects: rapier's contacts with a fixed body use
        // `static_contact_softness` (twice `contact_softness`'s frequency by default); both get
        // the chosen frequency, with rapier's default damping ratio.
        p.contact_softness.natural_frequency = params.contact_natural_frequency_hz;
        p.static_contact_softness.natural_frequency = params.contact_natural_frequency_hz;
        for (shape, pose) in &scene.objects {
            world.insert_collider(
                ColliderBuilder::new(shape.clone())
                    .position(*pose)
                    .friction(params.friction)
                    .restitution(0.0),
                None,
            );
        }
        let inertia = params.inertia_kg_m2();
        let body = RigidBodyBuilder::dynamic()
            .pose(to_rapier(&iso_si(start)))
            .additional_mass_properties(MassProperties::new(
                RVector::ZERO,
                params.mass_kg,
                RVector::splat(inertia),
            ))
            .can_sleep(false)
            .ccd_enabled(params.ccd)
            .build();
        let tool = world.insert_body(body);
        // Density 0: the body's mass and inertia are the coupling's choice above, not the
        // collider's volume.
        let tool_collider = world.insert_collider(
            ColliderBuilder::new(scene.tool.clone())
                .density(0.0)
                .friction(params.friction)
                .restitution(0.0),
            Some(tool),
        );
        Ok(Self {
            params,
            damping: params.dampings(),
            world,
            tool,
            tool_collider,
            last_hand: None,
        })
    }

    /// The parameters of this run.
    pub fn params(&self) -> &PeerParams {
        &self.params
    }

    /// One haptic frame: the spring-damper pulls the tool toward the device pose `q_hand`
    /// (mm, rad) and rapier steps once.
    pub fn step(&mut self, q_hand: &Pose) -> PeerFrame {
        let t0 = Instant::now();
        let hand = iso_si(q_hand);
        let dt = self.world.integration_parameters.dt;
        // The hand's velocity by finite difference (zero on the first frame).
        let (hand_v, hand_w) = match &self.last_hand {
            Some(prev) => (
                (hand.translation.vector - prev.translation.vector) / dt,
                rotation_log(
                    &(hand.rotation * prev.rotation.inverse())
                        .to_rotation_matrix()
                        .into_inner(),
                ) / dt,
            ),
            None => (Vector3::zeros(), Vector3::zeros()),
        };
        self.last_hand = Some(hand);
        let (c, cr) = self.damping;
        let kt = self.params.kt_si();
        let kr = self.params.kr_si();
        let body = &mut self.world.bodies[self.tool];
        let at = from_rapier(body.position());
        let force = kt * (hand.translation.vector - at.translation.vector)
            + c * (hand_v - vec_na(body.linvel()));
        let turn = (hand.rotation * at.rotation.inverse())
            .to_rotation_matrix()
            .into_inner();
        let torque = kr * rotation_log(&turn) + cr * (hand_w - vec_na(body.angvel()));
        // Forces and torques persist in rapier until reset: this frame's coupling only.
        body.reset_forces(true);
        body.reset_torques(true);
        body.add_force(vec_rapier(&force), true);
        body.add_torque(vec_rapier(&torque), true);
        self.world.step();
        let contacts = self
            .world
            .narrow_phase
            .contact_pairs_with(self.tool_collider)
            .flat_map(|pair| pair.solver_manifolds().iter())
            .map(|m| m.data.solver_contacts.len())
            .sum::<usize>();
        let step_us = t0.elapsed().as_secs_f64() * 1e6;
        let q_tool = pose_mm(&from_rapier(self.world.bodies[self.tool].position())).to_array();
        // The hand feels the reaction of the coupling force: N, and N·m to N·mm.
        PeerFrame {
            q_tool,
            wrench: [
                -force.x,
                -force.y,
                -force.z,
                -torque.x / M_PER_MM,
                -torque.y / M_PER_MM,
                -torque.z / M_PER_MM,
            ],
            contacts: u32::try_from(contacts).unwrap_or(u32::MAX),
            step_us,
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A closed box mesh between `lo` and `hi` (mm), outward triangles.
    pub(crate) fn box_mesh(lo: [f64; 3], hi: [f64; 3]) -> TriMesh {
        let mut mesh = TriMesh::default();
        for i in 0..8u32 {
            mesh.vertices.push([
                if i & 4 != 0 { hi[0] } else { lo[0] },
                if i & 2 != 0 { hi[1] } else { lo[1] },
                if i & 1 != 0 { hi[2] } else { lo[2] },
            ]);
        }
        for [a, b, c, d] in [
            [0, 1, 3, 2],
            [4, 6, 7, 5],
            [0, 4, 5, 1],
            [2, 3, 7, 6],
            [0, 2, 6, 4],
            [1, 5, 7, 3],
        ] {
            mesh.triangles.push([a, b, c]);
            mesh.triangles.push([a, c, d]);
        }
        mesh
    }

    pub(crate) fn plate_and_puck() -> (TriMesh, TriMesh) {
        (
            box_mesh([-60.0, -60.0, -10.0], [60.0, 60.0, 0.0]),
            box_mesh([-20.0, -20.0, 0.0], [20.0, 20.0, 10.0]),
        )
    }

    /// The puck's hull against the plate's trimesh (internal edges fixed).
    fn puck_on_plate() -> PeerScene {
        let (plate, puck) = plate_and_puck();
        PeerScene::new(
            &puck,
            &[(&plate, Pose::identity())],
            ToolShape::ConvexHull,
            ObjectShape::TriMesh {
                fix_internal_edges: true,
            },
        )
        .unwrap()
    }

    #[test]
    fn free_tool_follows_the_hand_and_the_hand_feels_no_force_at_rest() {
        let scene = puck_on_plate();
        let start = Pose::from_array([0.0, 0.0, 30.0, 0.0, 0.0, 0.0]);
        let mut tool = PeerTool::new(&scene, PeerParams::tuned(), &start).unwrap();
        let goal = Pose::from_array([5.0, -3.0, 40.0, 0.1, -0.05, 0.2]);
        let mut last = tool.step(&start);
        for _ in 0..2000 {
            last = tool.step(&goal);
        }
        for k in 0..6 {
            assert!(
                (last.q_tool[k] - goal.q[k]).abs() < 1e-3,
                "axis {k}: {:?}",
                last.q_tool
            );
            assert!(last.wrench[k].abs() < 1e-2, "axis {k}: {:?}", last.wrench);
        }
        assert_eq!(last.contacts, 0);
    }

    #[test]
    fn pressed_tool_rests_on_the_plate_and_pushes_the_hand_up_with_kt_times_depth() {
        let scene = puck_on_plate();
        let start = Pose::from_array([0.0, 0.0, 2.0, 0.0, 0.0, 0.0]);
        let mut tool = PeerTool::new(&scene, PeerParams::tuned(), &start).unwrap();
        let pressed = Pose::from_array([0.0, 0.0, -1.0, 0.0, 0.0, 0.0]);
        let mut last = tool.step(&start);
        for _ in 0..1000 {
            last = tool.step(&pressed);
        }
        // The tool rests on the plate (rapier lets it sink by less than its allowed error,
        // 1 mm x length_unit), and the hand 1 mm below feels ~kt x 1 mm upward.
        assert!(
            last.q_tool[2] < 0.01 && last.q_tool[2] > -0.2,
            "{:?}",
            last.q_tool
        );
        assert!((last.wrench[2] - 1.0).abs() < 0.2, "{:?}", last.wrench);
        assert!(last.contacts > 0);
    }

    #[test]
    fn a_convex_tool_gets_its_hull_and_a_concave_one_its_parts() {
        let (plate, puck) = plate_and_puck();
        let shape = ToolShape::HullIfConvex { resolution: 32 };
        let objects = [(&plate, Pose::identity())];
        let fix = ObjectShape::TriMesh {
            fix_internal_edges: true,
        };
        assert_eq!(
            PeerScene::new(&puck, &objects, shape, fix)
                .unwrap()
                .tool_parts,
            1
        );
        // An L of two boxes (one closed mesh): concave, so decomposed.
        let mut ell = box_mesh([0.0, 0.0, 0.0], [30.0, 10.0, 10.0]);
        let upright = box_mesh([0.0, 10.0, 0.0], [10.0, 30.0, 10.0]);
        let base = ell.vertices.len() as u32;
        ell.vertices.extend(upright.vertices);
        ell.triangles
            .extend(upright.triangles.iter().map(|t| t.map(|k| k + base)));
        assert!((enclosed_volume_m3(&ell) - 5e-6).abs() < 1e-12);
        assert!(
            PeerScene::new(&ell, &objects, shape, fix)
                .unwrap()
                .tool_parts
                > 1
        );
    }

    #[test]
    fn bad_parameters_are_refused() {
        let scene = puck_on_plate();
        let bad = PeerParams {
            mass_kg: 0.0,
            ..PeerParams::tuned()
        };
        assert!(PeerTool::new(&scene, bad, &Pose::identity()).is_err());
        assert!(PeerScene::new(
            &TriMesh::default(),
            &[],
            ToolShape::ConvexHull,
            ObjectShape::TriMesh {
                fix_internal_edges: true
            }
        )
        .is_err());
    }
}
