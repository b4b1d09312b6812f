//! The triangles of a body's mesh that each leaf of its sphere-tree covers, each leaf grown to
//! hold its triangles whole: the grown tree's free-space answers then hold for the mesh too
//! (docs/DESIGN.md §Mesh-exact contact).

use nalgebra::Vector3;
use spheretree::SphereTree;

use crate::triangle::Triangle;
use crate::Pose;

/// A body's triangles by sphere-tree leaf, in the frame its tree is packed in (the tool's own
/// frame; an object's placed in the world).
#[derive(Clone, Debug)]
pub struct MeshLeaves {
    triangles: Vec<Triangle>,
    /// Each triangle's bounding sphere: centre (mm) and radius (mm).
    bounds: Vec<([f64; 3], f64)>,
    /// By tree slot, the range of `leaf_triangles` that holds the leaf's triangles.
    start: Vec<u32>,
    leaf_triangles: Vec<u32>,
}

/// Why a mesh cannot be attached to a tree.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum MeshLeavesError {
    /// A triangle names a vertex the mesh does not have.
    #[error("triangle {triangle} names vertex {vertex}, but the mesh has {vertices} vertices")]
    BadIndex {
        /// The triangle (0-based).
        triangle: usize,
        /// The vertex index it names.
        vertex: u32,
        /// How many vertices there are.
        vertices: usize,
    },
    /// A vertex is not finite.
    #[error("vertex {0} is not finite")]
    NotFinite(usize),
    /// The tree has no leaf to hold the triangles.
    #[error("the sphere-tree has no leaves")]
    NoLeaves,
}

/// Longest-edge splits of one triangle at most (a triangle 4 096 times a leaf's size).
const MAX_SPLIT_DEPTH: u32 = 24;

impl MeshLeaves {
    /// Attaches a mesh (`vertices` in the tree's frame, mm; `triangles` as vertex indices) to
    /// the leaves of `tree`, placed at `pose` (the identity for a tool). Triangles larger than
    /// the tree's median leaf are split along their longest edges (the same surface); each
    /// belongs to the one leaf that needs the least growth to contain it whole, and that leaf
    /// grows to contain it (a ball holding a triangle's corners holds the triangle). Returns
    /// the grown tree (parents grown to contain their children; the tree's frame), whose leaf
    /// pairs then hold every pair of triangles that can touch, and the triangles by leaf (in
    /// the placed frame). Allocates; not real-time.
    pub fn attach(
        tree: &SphereTree,
        vertices: &[[f64; 3]],
        triangles: &[[u32; 3]],
        pose: &Pose,
    ) -> Result<(SphereTree, Self), MeshLeavesError> {
        if let Some(i) = vertices
            .iter()
            .position(|p| p.iter().any(|x| !x.is_finite()))
        {
            return Err(MeshLeavesError::NotFinite(i));
        }
        let mut own = Vec::with_capacity(triangles.len());
        for (i, tri) in triangles.iter().enumerate() {
            let corner = |k: usize| {
                vertices
                    .get(tri[k] as usize)
                    .copied()
                    .ok_or(MeshLeavesError::BadIndex {
                        triangle: i,
                        vertex: tri[k],
                        vertices: vertices.len(),
                    })
            };
            own.push([corner(0)?, corner(1)?, corner(2)?]);
        }
        let leaves: Vec<usize> = tree.leaves().collect();
        if leaves.is_empty() {
            return Err(MeshLeavesError::NoLeaves);
        }
        let mut radii: Vec<f64> = leaves.iter().map(|&n| tree.spheres()[n].radius).collect();
        radii.sort_by(f64::total_cmp);
        // Pieces half a median leaf across grow their leaves little.
        let target = 0.5 * radii[radii.len() / 2];
        let mut pieces = Vec::with_capacity(own.len());
        for t in &own {
            split_to(t, target, MAX_SPLIT_DEPTH, &mut pieces);
        }
        let mut grown = tree.clone();
        let mut owner = Vec::with_capacity(pieces.len());
        let mut near = Vec::new();
        for t in &pieces {
            let (bc, br) = bounding_sphere(t);
            near.clear();
            touching_leaves(tree, 0, &bc, br, &mut near);
            let need = |slot: usize| {
                let c = tree.spheres()[slot].center;
                t.iter().map(|p| dist(p, &c)).fold(0.0, f64::max) - tree.spheres()[slot].radius
            };
            let candidates: &[usize] = if near.is_empty() { &leaves } else { &near };
            let best = candidates
                .iter()
                .copied()
                .min_by(|&a, &b| need(a).total_cmp(&need(b)))
                .unwrap_or(leaves[0]);
            let sphere = &mut grown.spheres_mut()[best];
            let c = sphere.center;
            let reach = t.iter().map(|p| dist(p, &c)).fold(0.0, f64::max);
            // A rounding's room, so that the corners are inside in floating point too.
            sphere.radius = sphere.radius.max(reach * (1.0 + 1e-12) + 1e-9);
            owner.push(best);
        }
        grown.enforce_containment();
        let (rot, tr) = (pose.rotation_matrix(), pose.translation());
        let place = |p: &[f64; 3]| -> [f64; 3] { (rot * Vector3::from(*p) + tr).into() };
        let placed: Vec<Triangle> = pieces.iter().map(|t| t.map(|p| place(&p))).collect();
        let mut by_leaf: Vec<Vec<u32>> = vec![Vec::new(); tree.len()];
        for (i, &slot) in owner.iter().enumerate() {
            by_leaf[slot].push(i as u32);
        }
        let mut start = Vec::with_capacity(tree.len() + 1);
        let mut leaf_triangles = Vec::with_capacity(placed.len());
        for list in &by_leaf {
            start.push(leaf_triangles.len() as u32);
            leaf_triangles.extend_from_slice(list);
        }
        start.push(leaf_triangles.len() as u32);
        let bounds = placed.iter().map(bounding_sphere).collect();
        Ok((
            grown,
            Self {
                triangles: placed,
                bounds,
                start,
                leaf_triangles,
            },
        ))
    }

    /// The triangles (indices) of the leaf in tree slot `slot` (empty for other slots).
    #[inline]
    pub fn of_leaf(&self, slot: u32) -> &[u32] {
        let s = slot as usize;
        match (self.start.get(s), self.start.get(s + 1)) {
            (Some(&a), Some(&b)) => &self.leaf_triangles[a as usize..b as usize],
            _ => &[],
        }
    }

    /// Triangle `i`'s corners (mm, the body's packed frame).
    #[inline]
    pub fn triangle(&self, i: u32) -> &Triangle {
        &self.triangles[i as usize]
    }

    /// Triangle `i`'s bounding sphere: centre and radius, mm.
    #[inline]
    pub fn bound(&self, i: u32) -> ([f64; 3], f64) {
        self.bounds[i as usize]
    }

    /// How many triangles there are.
    pub fn len(&self) -> usize {
        self.triangles.len()
    }

    /// True without triangles.
    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }

    /// The largest distance of a corner from the frame's origin, mm (a tool's reach over its
    /// surface).
    pub fn reach(&self) -> f64 {
        self.triangles
            .iter()
            .flatten()
            .map(|p| dist(p, &[0.0; 3]))
            .fold(0.0, f64::max)
    }

    /// Every corner (mm), for bounds over the surface.
    pub fn corners(&self) -> impl Iterator<Item = [f64; 3]> + '_ {
        self.triangles.iter().flatten().copied()
    }
}

fn dist(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// Splits `t` along its longest edge until each piece's bounding sphere is at most `target`
/// (mm) or `depth` splits are spent, into `out`.
fn split_to(t: &Triangle, target: f64, depth: u32, out: &mut Vec<Triangle>) {
    if depth == 0 || bounding_sphere(t).1 <= target {
        out.push(*t);
        return;
    }
    let len = |i: usize| dist(&t[i], &t[(i + 1) % 3]);
    let k = (0..3)
        .max_by(|&a, &b| len(a).total_cmp(&len(b)))
        .unwrap_or(0);
    let (a, b, c) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
    let m: [f64; 3] = std::array::from_fn(|i| 0.5 * (a[i] + b[i]));
    split_to(&[a, m, c], target, depth - 1, out);
    split_to(&[m, b, c], target, depth - 1, out);
}

/// The used leaves below node `n` whose spheres meet the sphere `(c, r)`, into `out`.
fn touching_leaves(tree: &SphereTree, n: usize, c: &[f64; 3], r: f64, out: &mut Vec<usize>) {
    let s = tree.spheres()[n];
    if !s.is_used() || dist(&s.center, c) > s.radius + r {
        return;
    }
    if tree.is_leaf(n) {
        out.push(n);
        return;
    }
    for child in tree.children(n) {
        touching_leaves(tree, child, c, r, out);
    }
}

/// A sphere about the triangle: centred at its corners' mean, through its farthest corner.
fn bounding_sphere(t: &Triangle) -> ([f64; 3], f64) {
    let c: [f64; 3] = std::array::from_fn(|k| (t[0][k] + t[1][k] + t[2][k]) / 3.0);
    let r = t.iter().map(|p| dist(p, &c)).fold(0.0, f64::max);
    (c, r)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::triangle::closest_on_triangle;
    use spheretree::Sphere;

    /// A square of two triangles in z = 0, and a tree of four leaves over its quarters that
    /// leaves its corners out (radius 0.6 < 0.707).
    fn square() -> (SphereTree, Vec<[f64; 3]>, Vec<[u32; 3]>) {
        let mut tree = SphereTree::new_unused(2, 4).unwrap();
        tree.spheres_mut()[0] = Sphere::new([1.0, 1.0, 0.0], 1.5);
        for (k, (x, y)) in [(0.5, 0.5), (1.5, 0.5), (0.5, 1.5), (1.5, 1.5)]
            .iter()
            .enumerate()
        {
            tree.spheres_mut()[1 + k] = Sphere::new([*x, *y, 0.0], 0.6);
        }
        let v = vec![
            [0.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [2.0, 2.0, 0.0],
            [0.0, 2.0, 0.0],
        ];
        (tree, v, vec![[0, 1, 2], [0, 2, 3]])
    }

    /// Every point of every triangle is inside the leaf that holds it, and every triangle is
    /// held once.
    fn assert_contained(tree: &SphereTree, m: &MeshLeaves, pose: &Pose) {
        let mut held = vec![0; m.len()];
        for slot in tree.leaves() {
            let s = tree.spheres()[slot];
            let c: [f64; 3] =
                (pose.rotation_matrix() * Vector3::from(s.center) + pose.translation()).into();
            for &t in m.of_leaf(slot as u32) {
                held[t as usize] += 1;
                for p in m.triangle(t) {
                    assert!(dist(p, &c) <= s.radius, "corner outside its leaf");
                }
                // The point of the triangle farthest from the centre is a corner: check one
                // interior point too.
                let tri = m.triangle(t);
                let mid: [f64; 3] =
                    std::array::from_fn(|k| (tri[0][k] + tri[1][k] + tri[2][k]) / 3.0);
                assert!(dist(&closest_on_triangle(&mid, tri), &c) <= s.radius);
            }
        }
        assert!(held.iter().all(|&h| h == 1), "{held:?}");
        tree.validate(1e-9).unwrap();
    }

    #[test]
    fn each_piece_is_held_whole_by_one_grown_leaf_and_the_pieces_are_the_surface() {
        let (tree, v, t) = square();
        let (grown, m) = MeshLeaves::attach(&tree, &v, &t, &Pose::identity()).unwrap();
        assert!(
            m.len() > 2,
            "the 2.8 mm triangles split to the 0.6 mm leaves: {}",
            m.len()
        );
        assert_contained(&grown, &m, &Pose::identity());
        // The pieces cover the square's area, no more.
        let area: f64 = (0..m.len() as u32)
            .map(|i| {
                let t = m.triangle(i);
                let (a, b) = (
                    Vector3::from(t[1]) - Vector3::from(t[0]),
                    Vector3::from(t[2]) - Vector3::from(t[0]),
                );
                0.5 * a.cross(&b).norm()
            })
            .sum();
        assert!((area - 4.0).abs() < 1e-12, "{area}");
        // Leaves grow by no more than they must: to the half diagonal of their quarter's pieces.
        for slot in grown.leaves() {
            assert!(
                grown.spheres()[slot].radius <= 1.0,
                "{}",
                grown.spheres()[slot].radius
            );
        }
        assert!((m.reach() - 8f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn a_placed_body_holds_its_triangles_in_the_world_and_bad_meshes_are_refused() {
        let (tree, v, t) = square();
        let pose = Pose::from_array([10.0, 0.0, 0.0, 0.0, 0.0, std::f64::consts::FRAC_PI_2]);
        let (grown, m) = MeshLeaves::attach(&tree, &v, &t, &pose).unwrap();
        assert_contained(&grown, &m, &pose);
        let e = MeshLeaves::attach(&tree, &v, &[[0, 1, 7]], &pose).unwrap_err();
        assert!(e.to_string().contains("names vertex 7"), "{e}");
        let e = MeshLeaves::attach(&tree, &[[f64::NAN, 0.0, 0.0]], &[], &pose).unwrap_err();
        assert_eq!(e, MeshLeavesError::NotFinite(0));
    }
}
