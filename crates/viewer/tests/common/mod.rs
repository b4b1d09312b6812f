//! Test scenes. `small_scene`: a real render scene (trees built here) for the pipeline tests.
//! `Floor`: a test double for the transport tests: a point tool above the floor `z >= 0`
//! (the god-object is the device pose with z clamped), so expected wrenches are known exactly.
//! The shipped `serve` path uses the real render pipeline; this only exercises transport.
#![allow(dead_code)]

use collide::Pose;
use engine::safety::SafetyParams;
use mesh::TriMesh;
use scene::{Coupling, Motion, Scene, SolverSpec};
use spheretree::{Sphere, SphereTree};
use viewer::{ContactPair, FrameState, NamedMesh, SceneGeometry, Simulation};

/// Translational stiffness of the floor (N/mm).
pub const KT: f64 = 1.0;

pub struct Floor {
    graphic: Pose,
}

impl Floor {
    pub fn new() -> Self {
        Self {
            graphic: Pose::from_array([0.0, 0.0, 10.0, 0.0, 0.0, 0.0]),
        }
    }
}

fn square(z: f64, half: f64) -> TriMesh {
    TriMesh {
        vertices: vec![
            [-half, -half, z],
            [half, -half, z],
            [half, half, z],
            [-half, half, z],
        ],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
    }
}

impl Simulation for Floor {
    fn scene(&self) -> SceneGeometry {
        SceneGeometry {
            name: "floor".into(),
            tool: NamedMesh {
                name: "tool".into(),
                mesh: square(0.0, 1.0),
                pose: [0.0; 6],
            },
            objects: vec![NamedMesh {
                name: "floor".into(),
                mesh: square(0.0, 100.0),
                pose: [0.0; 6],
            }],
            kt: KT,
            kr: 1000.0,
            max_force: 20.0,
            friction: false,
        }
    }

    fn start_pose(&self) -> Pose {
        Pose::from_array([0.0, 0.0, 10.0, 0.0, 0.0, 0.0])
    }

    fn step(&mut self, device: &Pose, out: &mut FrameState) {
        let mut g = *device;
        let contact = g.q[2] < 0.0;
        if contact {
            g.q[2] = 0.0;
        }
        self.graphic = g;
        out.graphic = g.to_array();
        out.force = [0.0, 0.0, KT * (g.q[2] - device.q[2])];
        out.torque = [0.0; 3];
        out.pairs = u32::from(contact);
        out.penetration_mm = 0.0;
        if contact {
            out.push_contact(ContactPair {
                tool_centre: [g.q[0], g.q[1], g.q[2] + 1.0],
                tool_radius: 1.0,
                object_centre: [g.q[0], g.q[1], -1.0],
                object_radius: 1.0,
            });
        }
    }

    fn reset(&mut self, pose: &Pose) {
        self.graphic = *pose;
    }
}

/// Tool: root r = 9 at the origin, leaves r = 3 at x = ±5 (levels 2, branching 2).
/// Floor: root r = 45 at z = -20, four leaves r = 20 at (±15, ±15, -20) (levels 2, branching 4);
/// the floor's top is z = 0.
pub fn small_scene() -> Scene {
    let tool = SphereTree::from_slots(
        2,
        2,
        vec![
            Sphere::new([0.0, 0.0, 0.0], 9.0),
            Sphere::new([-5.0, 0.0, 0.0], 3.0),
            Sphere::new([5.0, 0.0, 0.0], 3.0),
        ],
    )
    .unwrap();
    let mut slots = vec![Sphere::new([0.0, 0.0, -20.0], 45.0)];
    for (x, y) in [(-15.0, -15.0), (15.0, -15.0), (-15.0, 15.0), (15.0, 15.0)] {
        slots.push(Sphere::new([x, y, -20.0], 20.0));
    }
    let floor = SphereTree::from_slots(2, 4, slots).unwrap();
    Scene {
        name: "two-spheres-over-floor".into(),
        tool,
        tool_mesh: None,
        objects: vec![(floor, Pose::identity())],
        object_meshes: vec![None],
        coupling: Coupling::default(),
        solver: SolverSpec::default(),
        safety: SafetyParams::default(),
        start: Pose::from_array([0.0, 0.0, 30.0, 0.0, 0.0, 0.0]),
        rate_hz: 1000.0,
        motion: Motion::Hold,
        goal: None,
        device: Default::default(),
        load_log: Vec::new(),
        object_friction: Vec::new(),
        tool_friction: None,
    }
}
