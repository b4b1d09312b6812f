//! Closing the holes of an open mesh for inside/outside and distance queries: each connected
//! set of boundary edges (edges with one triangle) is closed by a fan of triangles to its
//! centroid, or, when it is one long simple loop, by the level-by-level triangulation of
//! [`crate::triangulate`] (a fan of thousands of slivers meeting at the centroid would make
//! every query near the hole test all of them). The fans are a membrane over each hole, so a sphere bulging out through a hole
//! is seen as leaving the solid, as it would through the missing surface.

use crate::triangulate::{triangulate_polygon, FAN_MAX_VERTICES};
use crate::vec3::{cross, norm2, sub};
use crate::TriMesh;
use std::collections::HashMap;

impl TriMesh {
    /// The mesh with every hole closed by a fan to the centroid of its boundary (a hole
    /// bounded by one simple loop of more than [`FAN_MAX_VERTICES`] edges: by triangles
    /// spanning the loop itself, no new vertex), and the number of holes closed (0 for a
    /// closed mesh: then the mesh is returned unchanged).
    ///
    /// A hole is a connected set of boundary edges (edges used by exactly one triangle;
    /// edges shared by 3 or more triangles are not holes), connected through shared vertices.
    /// Each boundary edge `a → b` gets the triangle `b, a, centroid`, oriented like the
    /// missing neighbour. Fans of non-planar or touching holes may cross the surface: query
    /// the result with the generalised winding number ([`crate::InsideTest::WindingNumber`]),
    /// which does not mind.
    pub fn with_holes_closed(&self) -> (TriMesh, usize) {
        let nv = self.vertices.len();
        // Undirected edge → (uses, the directed edge of its first use).
        let mut edges: HashMap<(u32, u32), (u32, (u32, u32))> =
            HashMap::with_capacity(self.triangles.len() * 3 / 2 + 1);
        for t in &self.triangles {
            if t.iter().any(|&k| k as usize >= nv) {
                continue;
            }
            for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
                let e = edges.entry((a.min(b), a.max(b))).or_insert((0, (a, b)));
                e.0 += 1;
            }
        }
        let mut boundary: Vec<(u32, u32)> = edges
            .values()
            .filter(|(uses, _)| *uses == 1)
            .map(|(_, directed)| *directed)
            .collect();
        if boundary.is_empty() {
            return (self.clone(), 0);
        }
        // Deterministic order whatever the hash map's.
        boundary.sort_unstable();
        // Union-find over the boundary vertices.
        let mut parent: HashMap<u32, u32> = HashMap::new();
        fn find(parent: &mut HashMap<u32, u32>, v: u32) -> u32 {
            let mut root = v;
            while let Some(&p) = parent.get(&root) {
                if p == root {
                    break;
                }
                root = p;
            }
            // Path compression.
            let mut x = v;
            while x != root {
                let next = parent[&x];
                parent.insert(x, root);
                x = next;
            }
            root
        }
        for &(a, b) in &boundary {
            parent.entry(a).or_insert(a);
            parent.entry(b).or_insert(b);
            let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
            if ra != rb {
                parent.insert(ra.max(rb), ra.min(rb));
            }
        }
        // Per hole: the mean of its boundary vertices (each counted once).
        let mut sums: HashMap<u32, ([f64; 3], usize)> = HashMap::new();
        let mut vertices: Vec<u32> = parent.keys().copied().collect();
        vertices.sort_unstable();
        for v in vertices {
            let root = find(&mut parent, v);
            let e = sums.entry(root).or_insert(([0.0; 3], 0));
            for k in 0..3 {
                e.0[k] += self.vertices[v as usize][k];
            }
            e.1 += 1;
        }
        let mut roots: Vec<u32> = sums.keys().copied().collect();
        roots.sort_unstable();
        let mut edges_of: HashMap<u32, Vec<(u32, u32)>> = HashMap::with_capacity(roots.len());
        for &(a, b) in &boundary {
            let root = find(&mut parent, a);
            edges_of.entry(root).or_default().push((a, b));
        }
        let mut out = self.clone();
        for root in &roots {
            let edges = &edges_of[root];
            if edges.len() > FAN_MAX_VERTICES {
                if let Some(ring) = simple_loop(edges) {
                    // The membrane runs the loop backwards, like the missing neighbours.
                    let reversed: Vec<u32> = ring.iter().rev().copied().collect();
                    let flat = |t: [u32; 3]| {
                        let [a, b, c] = t.map(|k| self.vertices[k as usize]);
                        norm2(cross(sub(b, a), sub(c, a))) == 0.0
                    };
                    triangulate_polygon(&reversed, flat, &mut out.triangles);
                    continue;
                }
            }
            let (s, n) = sums[root];
            out.vertices.push(s.map(|x| x / n as f64));
            let c = (out.vertices.len() - 1) as u32;
            for &(a, b) in edges {
                out.triangles.push([b, a, c]);
            }
        }
        (out, roots.len())
    }
}

/// The vertices of `edges` in loop order when the directed edges form one simple cycle
/// (every vertex left once and entered once, all on one walk), else `None`.
fn simple_loop(edges: &[(u32, u32)]) -> Option<Vec<u32>> {
    let mut next: HashMap<u32, u32> = HashMap::with_capacity(edges.len());
    for &(a, b) in edges {
        if next.insert(a, b).is_some() {
            return None;
        }
    }
    let start = edges.iter().map(|e| e.0).min()?;
    let mut ring = Vec::with_capacity(edges.len());
    let mut v = start;
    loop {
        ring.push(v);
        v = *next.get(&v)?;
        if v == start {
            break;
        }
        if ring.len() >= edges.len() {
            return None;
        }
    }
    (ring.len() == edges.len()).then_some(ring)
}

#[cfg(test)]
mod tests {
    use crate::generate;

    #[test]
    fn holes_are_closed_and_closed_meshes_untouched() {
        let closed = generate::uv_sphere(1.0, 12, 24);
        assert_eq!(closed.with_holes_closed(), (closed.clone(), 0));
        // The open box gets its lid back: a closed mesh again.
        let open = generate::open_box([1.0; 3], 3);
        let (lidded, holes) = open.with_holes_closed();
        assert_eq!(holes, 1);
        assert_eq!(lidded.triangles.len(), open.triangles.len() + 12);
        lidded.check_closed().unwrap();
        let centre = lidded.vertices.last().unwrap();
        assert!(centre[0].abs() < 1e-12 && centre[1].abs() < 1e-12 && centre[2] == 1.0);
        // Scattered holes (neighbouring ones merge, some touch at a vertex, so the result
        // need not be a manifold): one fan triangle per boundary edge, and the winding number
        // is back to 1 inside where the holes let it drop.
        let holed = generate::remove_fraction(&closed, 0.03, 5);
        let (filled, holes) = holed.with_holes_closed();
        assert!(holes > 0);
        let removed = closed.triangles.len() - holed.triangles.len();
        let added = filled.triangles.len() - holed.triangles.len();
        assert!(
            added >= removed && added <= 3 * removed,
            "{added} vs {removed}"
        );
        let wn = crate::InsideTest::WindingNumber;
        let before = crate::MeshQuery::with_inside_test(&holed, wn).winding_number([0.0; 3]);
        let after = crate::MeshQuery::with_inside_test(&filled, wn).winding_number([0.0; 3]);
        assert!(
            before < 0.99 && (after - 1.0).abs() < 0.03,
            "{before} {after}"
        );
    }
}
