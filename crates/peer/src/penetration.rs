//! Mesh-level penetration: how deep the tool *mesh* at a pose is inside the object meshes, the
//! same query for haptic6d's graphic tool and the peer's body (so haptic6d's sphere-tree
//! approximation error shows too, and the peer's convex decomposition's).

use collide::Pose;
use mesh::{sample_surface, InsideTest, MeshQuery, TriMesh};
use nalgebra::{Isometry3, Point3};

/// Surface samples per mm² beside the vertices (about 1.4 mm apart): a 5 mm ball 0.5 mm into
/// a flat face covers a disc of 2.2 mm radius, which then holds several samples.
const SAMPLES_PER_MM2: f64 = 0.5;

/// At most this many samples per mesh come from the density (a bound on the cost per frame).
const MAX_DENSITY_SAMPLES: usize = 50_000;

fn surface_area_mm2(mesh: &TriMesh) -> f64 {
    let n = mesh.vertices.len();
    mesh.triangles
        .iter()
        .filter(|t| t.iter().all(|&k| (k as usize) < n))
        .map(|t| {
            let [a, b, c] = t.map(|k| {
                let v = mesh.vertices[k as usize];
                nalgebra::Vector3::new(v[0], v[1], v[2])
            });
            0.5 * (b - a).cross(&(c - a)).norm()
        })
        .sum()
}

/// One mesh prepared for the measure: its distance query, its probe points (vertices and
/// surface samples) and its bounding box, all in its own frame (mm).
#[derive(Clone, Debug)]
struct Probed {
    query: MeshQuery,
    points: Vec<Point3<f64>>,
    lo: [f64; 3],
    hi: [f64; 3],
}

impl Probed {
    fn new(mesh: &TriMesh, min_samples: usize, seed: u64) -> Self {
        let samples = min_samples
            .max(((surface_area_mm2(mesh) * SAMPLES_PER_MM2) as usize).min(MAX_DENSITY_SAMPLES));
        let mut points: Vec<Point3<f64>> = mesh
            .vertices
            .iter()
            .map(|v| Point3::new(v[0], v[1], v[2]))
            .collect();
        points.extend(
            sample_surface(mesh, samples, seed)
                .into_iter()
                .map(|(p, _)| Point3::new(p[0], p[1], p[2])),
        );
        let (lo, hi) = mesh.aabb().unwrap_or(([0.0; 3], [0.0; 3]));
        Self {
            query: MeshQuery::with_inside_test(mesh, InsideTest::for_mesh(mesh)),
            points,
            lo,
            hi,
        }
    }

    fn contains_box(&self, p: &Point3<f64>) -> bool {
        (0..3).all(|k| p[k] > self.lo[k] && p[k] < self.hi[k])
    }

    /// The centre of the bounding box and the radius of the ball about it that holds the box
    /// (own frame, mm).
    fn ball(&self) -> (Point3<f64>, f64) {
        let c = Point3::from((Point3::from(self.lo).coords + Point3::from(self.hi).coords) / 2.0);
        let r = (Point3::from(self.hi) - Point3::from(self.lo)).norm() / 2.0;
        (c, r)
    }

    /// How far (mm) the point `p` (own frame) lies outside the bounding box (0 inside).
    fn box_distance(&self, p: &Point3<f64>) -> f64 {
        (0..3)
            .map(|k| (self.lo[k] - p[k]).max(p[k] - self.hi[k]).max(0.0).powi(2))
            .sum::<f64>()
            .sqrt()
    }

    /// Deepest of `other`'s probe points (mapped into this mesh's frame by `here_from_other`)
    /// inside this mesh, mm (0 when none is inside).
    fn deepest_of(&self, other: &Probed, here_from_other: &Isometry3<f64>) -> f64 {
        let mut deepest: f64 = 0.0;
        for p in &other.points {
            let q = here_from_other * p;
            if self.contains_box(&q) {
                let d = self.query.signed_distance([q.x, q.y, q.z]);
                deepest = deepest.max(-d);
            }
        }
        deepest
    }
}

/// The independent penetration measure: at a tool pose, the deepest tool probe point inside
/// an object mesh and the deepest object probe point inside the tool mesh (mm). Probe points
/// are every vertex plus area-weighted surface samples (0.5 per mm², at least the number asked
/// for, at most 50 000 from the density), so a flat face pushed into another shows between
/// vertices too. Inside is told by pseudo-normals on closed meshes, by the winding number on
/// open ones ([`InsideTest::for_mesh`]). Depth is the distance to the nearest surface, so
/// inside a plate of thickness `h` a tool point reads at most `h / 2`; the plate's own points
/// inside the tool read the full depth.
#[derive(Clone, Debug)]
pub struct MeshPenetration {
    tool: Probed,
    objects: Vec<(Probed, Isometry3<f64>)>,
}

impl MeshPenetration {
    /// The measure for a tool mesh (tool frame, mm) and object meshes (own frames, mm, placed
    /// at their poses), with at least `samples` surface samples per mesh beside its vertices.
    pub fn new(tool: &TriMesh, objects: &[(&TriMesh, Pose)], samples: usize) -> Self {
        Self {
            tool: Probed::new(tool, samples, 1),
            objects: objects
                .iter()
                .enumerate()
                .map(|(i, (m, pose))| (Probed::new(m, samples, 2 + i as u64), pose.to_isometry()))
                .collect(),
        }
    }

    /// Whether the tool mesh at `tool_pose` (mm, rad) may touch an object: the ball holding
    /// its bounding box reaches an object's bounding box. Where it does not, no probe point of
    /// either lies in the other's box, so [`MeshPenetration::depth_mm`] is 0 exactly: a
    /// selection of poses to measure that rests on the geometry alone, not on any engine's
    /// view of the contact.
    pub fn may_touch(&self, tool_pose: &Pose) -> bool {
        let (centre, radius) = self.tool.ball();
        let world = tool_pose.to_isometry() * centre;
        self.objects.iter().any(|(object, world_from_object)| {
            object.box_distance(&world_from_object.inverse_transform_point(&world)) <= radius
        })
    }

    /// Deepest penetration (mm, >= 0) of the tool mesh at `tool_pose` (mm, rad) into the
    /// objects, either way round.
    pub fn depth_mm(&self, tool_pose: &Pose) -> f64 {
        let world_from_tool = tool_pose.to_isometry();
        let mut deepest: f64 = 0.0;
        for (object, world_from_object) in &self.objects {
            let object_from_tool = world_from_object.inv_mul(&world_from_tool);
            deepest = deepest
                .max(object.deepest_of(&self.tool, &object_from_tool))
                .max(self.tool.deepest_of(object, &object_from_tool.inverse()));
        }
        deepest
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tool::tests::box_mesh;

    #[test]
    fn a_box_pushed_into_a_plate_reads_its_depth_and_a_clear_one_reads_zero() {
        let plate = box_mesh([-60.0, -60.0, -10.0], [60.0, 60.0, 0.0]);
        let puck = box_mesh([-20.0, -20.0, 0.0], [20.0, 20.0, 10.0]);
        let measure = MeshPenetration::new(&puck, &[(&plate, Pose::identity())], 500);
        let at = |z: f64| measure.depth_mm(&Pose::from_array([3.0, -2.0, z, 0.0, 0.0, 0.0]));
        assert_eq!(at(0.5), 0.0);
        assert!((at(-0.7) - 0.7).abs() < 1e-9, "{}", at(-0.7));
        // Tilted by 0.1 rad about x: the lowest edge goes deepest, 20 sin(0.1) below the
        // centre of the bottom face.
        let tilted = measure.depth_mm(&Pose::from_array([0.0, 0.0, 1.0, 0.1, 0.0, 0.0]));
        assert!(
            (tilted - (20.0 * 0.1f64.sin() - 1.0)).abs() < 1e-9,
            "{tilted}"
        );
    }

    /// A pose the bounding boxes keep clear of every object reads 0, and so does every pose
    /// near it that the selection leaves out; one that may touch is selected however far the
    /// tool is from touching inside the boxes.
    #[test]
    fn poses_left_out_by_the_boxes_read_no_depth() {
        let plate = box_mesh([-60.0, -60.0, -10.0], [60.0, 60.0, 0.0]);
        let puck = box_mesh([-20.0, -20.0, 0.0], [20.0, 20.0, 10.0]);
        let measure = MeshPenetration::new(&puck, &[(&plate, Pose::identity())], 500);
        // The puck's box ball: radius |(40, 40, 10)| / 2 = 28.7 mm about (0, 0, 5).
        let radius = (40.0f64.powi(2) * 2.0 + 100.0).sqrt() / 2.0;
        let at = |x: f64, z: f64, turn: f64| Pose::from_array([x, 0.0, z, turn, 0.0, 0.0]);
        assert!(!measure.may_touch(&at(0.0, radius - 5.0 + 0.01, 0.0)));
        assert!(measure.may_touch(&at(0.0, radius - 5.0 - 0.01, 0.0)));
        // Beside the plate's edge and above it.
        assert!(!measure.may_touch(&at(60.0 + radius + 0.01, -5.0, 0.7)));
        assert!(measure.may_touch(&at(60.0 + radius - 0.01, -5.0, 0.7)));
        // Poses left out read 0; a pose pressed in is selected.
        for k in 0..200 {
            let q = at(
                -150.0 + 1.5 * k as f64,
                -30.0 + 0.4 * k as f64,
                0.01 * k as f64,
            );
            if !measure.may_touch(&q) {
                assert_eq!(measure.depth_mm(&q), 0.0, "{:?}", q.to_array());
            }
        }
        assert!(measure.may_touch(&at(3.0, -0.7, 0.0)));
    }

    #[test]
    fn a_plate_corner_inside_the_tool_counts_the_other_way_round() {
        // The tool's vertices are all outside the small block, which lies wholly inside the
        // tool: its corner at the origin is 2 mm from the tool's x = 2 face.
        let block = box_mesh([0.0, 0.0, 0.0], [1.0, 1.0, 1.0]);
        let tool = box_mesh([-10.0, -10.0, -10.0], [2.0, 10.0, 10.0]);
        let measure = MeshPenetration::new(&tool, &[(&block, Pose::identity())], 0);
        assert!((surface_area_mm2(&block) - 6.0).abs() < 1e-12);
        let d = measure.depth_mm(&Pose::identity());
        assert!((d - 2.0).abs() < 1e-9, "{d}");
    }
}
