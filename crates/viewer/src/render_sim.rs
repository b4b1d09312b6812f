//! [`RenderSim`]: the real haptic pipeline behind the viewer — render's god-object step
//! ([`render::step::GodObject`]) followed by its safety filter ([`render::safety::Safety`]),
//! exactly the frame body of `haptic6d run`, plus an optional probe that lists the contact
//! pairs for display.

use collide::{overlap_tree_trees, CollideWorkspace, PackedTree, Pose};
use mesh::TriMesh;
use render::safety::Safety;
use render::scene::Scene;
use render::step::{FrameStatus, GodObject, StepParams};

use crate::error::ViewerError;
use crate::sim::{ContactPair, FrameState, NamedMesh, SceneGeometry, Simulation};

/// A loaded render scene driven by the viewer.
pub struct RenderSim {
    god: GodObject,
    safety: Safety,
    geometry: SceneGeometry,
    start: Pose,
    probe_tool: PackedTree,
    probe_objects: Vec<PackedTree>,
    probe_ws: CollideWorkspace,
    probe_margin: f64,
    /// Loop time (s) of the first frame of the current engagement (a live input after a
    /// release); `None` while released. The safety filter's soft start counts from it.
    engaged_at: Option<f64>,
    /// Frames whose step kept the last safe pose (numerical failure), since start.
    pub kept_last_safe: u64,
}

impl RenderSim {
    /// Packs the scene's trees, reserves every buffer and seats the god-object at the scene's
    /// start pose (or the nearest free pose). Allocates; call before the loop starts.
    pub fn new(scene: &Scene) -> Result<Self, ViewerError> {
        let scene_err = |e: render::RenderError| ViewerError::Params(e.to_string());
        let params = StepParams::from_scene(scene);
        let mut god = GodObject::new(scene, params).map_err(scene_err)?;
        let start = god.reset(&scene.start).map_err(scene_err)?;
        let collide_err = |e: collide::CollideError| ViewerError::Params(e.to_string());
        let probe_tool = PackedTree::new(&scene.tool).map_err(collide_err)?;
        let probe_objects = scene
            .objects
            .iter()
            .map(|(t, p)| PackedTree::with_pose(t, p))
            .collect::<Result<Vec<_>, _>>()
            .map_err(collide_err)?;
        let probe_ws = CollideWorkspace::for_trees(&probe_tool, &probe_objects);
        let tool_mesh = scene
            .tool_mesh
            .clone()
            .unwrap_or_else(|| leaves_mesh(&probe_tool));
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
        };
        Ok(Self {
            god,
            safety: Safety::new(scene.safety),
            geometry,
            start,
            probe_tool,
            probe_objects,
            probe_ws,
            probe_margin: scene.solver.skin_mm.max(0.05),
            engaged_at: None,
            kept_last_safe: 0,
        })
    }
}

impl RenderSim {
    /// The geometry the page draws (meshes in mm; sphere meshes for tree-only bodies).
    pub fn scene_geometry(&self) -> &SceneGeometry {
        &self.geometry
    }
}

impl Simulation for RenderSim {
    fn scene(&self) -> SceneGeometry {
        self.geometry.clone()
    }

    fn start_pose(&self) -> Pose {
        self.start
    }

    /// Every engagement (the first live frame after a release, a time-out, a new UDP session or
    /// a reset) restarts the safety filter: its soft start runs again from that frame and its
    /// rate limit starts from zero, so the force never jumps when a device (re-)engages.
    ///
    /// # Real-time
    /// [`GodObject::step`] and [`Safety::filter`] (no allocation, bounded); when contacts are
    /// requested, one more traversal at the graphic pose into the pre-sized contact list.
    fn step(&mut self, device: &Pose, out: &mut FrameState) {
        let f = self.god.step(device);
        if out.released {
            // The loop sends zero while released; the filter must start from zero too.
            self.engaged_at = None;
            self.safety = Safety::new(*self.safety.params());
        }
        let since = if out.released {
            0.0
        } else {
            out.t - *self.engaged_at.get_or_insert(out.t)
        };
        let (sent, _flags) = self.safety.filter(since, f.wrench);
        if f.status == FrameStatus::KeptLastSafe {
            self.kept_last_safe += 1;
        }
        out.graphic = f.q_g;
        out.force = [sent[0], sent[1], sent[2]];
        out.torque = [sent[3], sent[4], sent[5]];
        out.pairs = f.pairs;
        out.penetration_mm = f.penetration_mm;
        out.cd_us = f.cd_us;
        out.opt_us = f.opt_us;
        if out.contacts_requested {
            let q_g = Pose::from_array(f.q_g);
            let contacts = &mut *out;
            let _ = overlap_tree_trees(
                &self.probe_tool,
                &q_g,
                &self.probe_objects,
                self.probe_margin,
                &mut self.probe_ws,
                |p| {
                    contacts.push_contact(ContactPair {
                        tool_centre: q_g.transform_point(&p.p_in_tool),
                        tool_radius: p.r_tool,
                        object_centre: p.o_in_world,
                        object_radius: p.r_object,
                    });
                },
            );
        }
    }

    fn reset(&mut self, pose: &Pose) {
        if let Ok(p) = self.god.reset(pose) {
            self.start = p;
        }
        self.safety = Safety::new(*self.safety.params());
        self.engaged_at = None;
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
