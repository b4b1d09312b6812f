//! [`SceneSim`]: the real haptic pipeline behind the viewer — the [`engine::Engine`] (the
//! god-object step followed by the safety filter), exactly the frame body of `haptic6d run`,
//! and the contact pairs it found, for display.

use collide::{PackedTree, Pose};
use engine::{Engine, FrameStatus};
use mesh::TriMesh;
use scene::Scene;

use crate::error::ViewerError;
use crate::simulation::{ContactPair, FrameState, NamedMesh, SceneGeometry, Simulation};

/// A loaded scene (`scene::Scene`) driven through its engine, for the viewer.
pub struct SceneSim {
    engine: Engine,
    geometry: SceneGeometry,
    start: Pose,
    /// Pairs whose gap at the graphic pose is within this (mm) are listed as contacts.
    contact_margin: f64,
    /// The engagement driving the engine since the last release ([`FrameState::engagement`]),
    /// `None` while released: the safety layer's soft start and rate limit run from the first
    /// frame of each engagement.
    engaged: Option<u64>,
    /// Frames whose step kept the last safe pose (numerical failure), since start.
    pub kept_last_safe: u64,
    /// Whether the engine's friction is on (the page's switch, as last applied).
    friction_on: bool,
}

impl SceneSim {
    /// Packs the scene's trees, reserves every buffer and seats the god-object at the scene's
    /// start pose (or a free pose near it). Allocates; call before the loop starts.
    pub fn new(scene: &Scene) -> Result<Self, ViewerError> {
        let engine = scene.engine()?;
        let start = engine.q_g();
        let tool_mesh = scene.tool_mesh.clone().unwrap_or_else(|| {
            PackedTree::new(&scene.tool)
                .map(|p| leaves_mesh(&p))
                .unwrap_or_default()
        });
        let objects = scene
            .objects
            .iter()
            .zip(&scene.object_meshes)
            .enumerate()
            .map(|(i, ((tree, pose), m))| NamedMesh {
                name: format!("object {}", i + 1),
                mesh: m.clone().unwrap_or_else(|| {
                    PackedTree::new(tree)
                        .map(|p| leaves_mesh(&p))
                        .unwrap_or_default()
                }),
                pose: pose.to_array(),
            })
            .collect();
        let geometry = SceneGeometry {
            name: scene.name.clone(),
            tool: NamedMesh {
                name: "tool".into(),
                mesh: tool_mesh,
                pose: [0.0; 6],
            },
            objects,
            kt: scene.coupling.kt,
            kr: scene.coupling.kr,
            max_force: scene.safety.max_force_n,
            friction: scene.object_friction.iter().any(|f| !f.is_none()),
        };
        Ok(Self {
            engine,
            geometry,
            start,
            contact_margin: scene.solver.skin_mm.max(0.05),
            engaged: None,
            kept_last_safe: 0,
            friction_on: true,
        })
    }
}

impl SceneSim {
    /// The geometry the page draws (meshes in mm; sphere meshes for tree-only bodies).
    pub fn scene_geometry(&self) -> &SceneGeometry {
        &self.geometry
    }
}

impl Simulation for SceneSim {
    fn scene(&self) -> SceneGeometry {
        self.geometry.clone()
    }

    fn start_pose(&self) -> Pose {
        self.start
    }

    /// Every engagement (the first live frame after a release, a time-out, a new UDP session or
    /// a reset, even one whose release the loop never saw as a released frame) restarts the
    /// safety filter: its soft start runs again from that frame and its rate limit starts from
    /// zero, so the force never jumps when a device (re-)engages.
    ///
    /// # Real-time
    /// [`Engine::step`] (no allocation, bounded); when contacts are requested, the engine's
    /// pairs within the contact margin at the graphic pose go into the pre-sized contact list.
    fn step(&mut self, device: &Pose, out: &mut FrameState) {
        if out.released {
            self.engaged = None;
        } else if self.engaged != Some(out.engagement) {
            // A new engagement: the filter starts again from zero, its soft start from this
            // frame.
            self.engine.restart_safety();
            self.engaged = Some(out.engagement);
        }
        if out.friction_on != self.friction_on {
            self.friction_on = out.friction_on;
            self.engine.set_friction_enabled(out.friction_on);
        }
        let f = *self.engine.step(out.t, device);
        out.friction = f.friction.code();
        if f.status == FrameStatus::KeptLastSafe {
            self.kept_last_safe += 1;
        }
        out.graphic = f.q_g;
        out.force = [f.wrench[0], f.wrench[1], f.wrench[2]];
        out.torque = [f.wrench[3], f.wrench[4], f.wrench[5]];
        out.pairs = f.pairs;
        out.penetration_mm = f.penetration_mm;
        out.cd_us = f.cd_us;
        out.opt_us = f.opt_us;
        if out.contacts_requested {
            let q_g = Pose::from_array(f.q_g);
            for p in self.engine.contacts() {
                let tool_centre = q_g.transform_point(&p.p_in_tool);
                if p.gap_at(&q_g) <= self.contact_margin {
                    out.push_contact(ContactPair {
                        tool_centre,
                        tool_radius: p.r_tool,
                        object_centre: p.o_in_world,
                        object_radius: p.r_object,
                    });
                }
            }
        }
    }

    /// [`Engine::idle`]: the background detection work, then the collision trees into cache.
    fn idle(&mut self, until: std::time::Instant) {
        self.engine.idle(until);
    }

    fn reset(&mut self, pose: &Pose) {
        if let Ok(p) = self.engine.reset(pose) {
            self.start = p;
        }
        // Whether or not a free pose was found, the force restarts from zero.
        self.engaged = None;
    }
}

/// A low-poly mesh (an octahedron per leaf sphere) standing in for a body given by its tree only.
fn leaves_mesh(tree: &PackedTree) -> TriMesh {
    let mut m = TriMesh::default();
    for n in tree.leaves() {
        let c = tree.center(n);
        let r = tree.radius(n);
        let base = m.vertices.len() as u32;
        for (k, s) in [(0, r), (0, -r), (1, r), (1, -r), (2, r), (2, -r)] {
            let mut v = c;
            v[k] += s;
            m.vertices.push(v);
        }
        // +x 0, -x 1, +y 2, -y 3, +z 4, -z 5; counter-clockwise from outside.
        for t in [
            [0, 2, 4],
            [2, 1, 4],
            [1, 3, 4],
            [3, 0, 4],
            [2, 0, 5],
            [1, 2, 5],
            [3, 1, 5],
            [0, 3, 5],
        ] {
            m.triangles.push([base + t[0], base + t[1], base + t[2]]);
        }
    }
    m
}
