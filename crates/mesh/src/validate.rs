//! Validation: from raw polygons as read from a file to a clean [`TriMesh`], and the closed
//! 2-manifold check ([`TriMesh::check_closed`]) for builders that need an inside.
//!
//! The cleaning steps [`crate::load_mesh`] applies, in order:
//! 1. every vertex coordinate must be finite, every face index in range, every face at least
//!    3 vertices long (errors);
//! 2. polygons are split into triangles: by a fan from their first vertex, or level by level
//!    for polygons of more than 16 vertices ([`crate::triangulate`]: a fan of a huge polygon
//!    makes every query near it test every sliver);
//! 3. vertices at exactly the same position are welded (STL stores none shared; OBJ groups and
//!    PLY seams often duplicate them);
//! 4. degenerate triangles (a repeated vertex, or zero area: height below `1e-12` times the
//!    longest edge) are dropped and counted;
//! 5. vertices no triangle uses are removed.

use std::collections::HashMap;
use std::path::Path;

use crate::triangulate::triangulate_polygon;
use crate::vec3::{dot, sub};
use crate::{MeshError, TriMesh};

/// Polygons as read from a file, before validation.
#[derive(Clone, Debug, Default)]
pub(crate) struct RawPolygons {
    /// Vertex positions in file order (file units).
    pub vertices: Vec<[f64; 3]>,
    /// All faces' vertex indices, concatenated (may be out of range or negative: checked).
    pub indices: Vec<i64>,
    /// Number of vertices of each face, in file order.
    pub arities: Vec<u32>,
}

/// What cleaning changed, for the load report.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct CleanCounts {
    pub degenerate_dropped: usize,
    pub duplicates_welded: usize,
    pub unreferenced_removed: usize,
}

/// Relative height below which a triangle counts as having zero area.
const ZERO_AREA_REL: f64 = 1e-12;

/// Validates and cleans raw polygons into a triangle mesh (steps in the module docs). `path`
/// names the file in errors.
pub(crate) fn clean_polygons(
    raw: RawPolygons,
    path: &Path,
) -> Result<(TriMesh, CleanCounts), MeshError> {
    let RawPolygons {
        vertices,
        indices,
        arities,
    } = raw;
    if arities.is_empty() {
        return Err(MeshError::Empty {
            path: path.to_path_buf(),
            detail: format!(
                "the file has {} vertices and no face; export the surface as triangles",
                vertices.len()
            ),
        });
    }
    if let Some((i, v)) = vertices
        .iter()
        .enumerate()
        .find(|(_, v)| !v.iter().all(|c| c.is_finite()))
    {
        return Err(MeshError::NonFinite {
            path: path.to_path_buf(),
            vertex: i,
            position: *v,
        });
    }
    let n_vertices = vertices.len();
    if n_vertices > u32::MAX as usize {
        return Err(MeshError::Parse {
            path: path.to_path_buf(),
            format: "mesh".into(),
            message: format!("{n_vertices} vertices is more than this crate supports (2^32 - 1)"),
        });
    }

    // Weld exact duplicates first (so degeneracy is judged on welded indices). -0.0 and 0.0
    // are the same position.
    let key = |v: &[f64; 3]| v.map(|c| if c == 0.0 { 0u64 } else { c.to_bits() });
    let mut first_of: HashMap<[u64; 3], u32> = HashMap::with_capacity(n_vertices);
    let mut remap: Vec<u32> = Vec::with_capacity(n_vertices);
    for (i, v) in vertices.iter().enumerate() {
        let id = *first_of.entry(key(v)).or_insert(i as u32);
        remap.push(id);
    }
    let duplicates_welded = n_vertices - first_of.len();
    drop(first_of);

    // Range-check, fan-triangulate, drop degenerate triangles.
    let mut triangles: Vec<[u32; 3]> = Vec::with_capacity(indices.len() / 3 + 1);
    let mut degenerate_dropped = 0usize;
    let mut split: Vec<[u32; 3]> = Vec::new();
    let mut start = 0usize;
    for (face, &arity) in arities.iter().enumerate() {
        let arity = arity as usize;
        let poly = &indices[start..start + arity];
        start += arity;
        if arity < 3 {
            return Err(MeshError::ShortFace {
                path: path.to_path_buf(),
                face,
                count: arity,
            });
        }
        let mut welded = Vec::with_capacity(arity);
        for &ix in poly {
            if ix < 0 || ix as u64 >= n_vertices as u64 {
                return Err(MeshError::IndexOutOfRange {
                    path: path.to_path_buf(),
                    face,
                    index: ix,
                    vertex_count: n_vertices,
                });
            }
            welded.push(remap[ix as usize]);
        }
        split.clear();
        triangulate_polygon(&welded, |t| is_degenerate(&vertices, t), &mut split);
        degenerate_dropped += (arity - 2) - split.len();
        for &t in &split {
            if is_degenerate(&vertices, t) {
                degenerate_dropped += 1;
            } else {
                triangles.push(t);
            }
        }
    }
    if triangles.is_empty() {
        return Err(MeshError::Empty {
            path: path.to_path_buf(),
            detail: format!(
                "all {} triangles of the file's {} faces are degenerate (repeated vertex or zero area)",
                degenerate_dropped,
                arities.len()
            ),
        });
    }

    // Keep only the vertices in use, in their original order.
    let mut new_index = vec![u32::MAX; n_vertices];
    for t in &triangles {
        for &v in t {
            new_index[v as usize] = 0;
        }
    }
    let mut kept = Vec::new();
    for (i, slot) in new_index.iter_mut().enumerate() {
        if *slot == 0 {
            *slot = kept.len() as u32;
            kept.push(vertices[i]);
        }
    }
    for t in &mut triangles {
        for v in t.iter_mut() {
            *v = new_index[*v as usize];
        }
    }
    let unreferenced_removed = n_vertices - duplicates_welded - kept.len();
    Ok((
        TriMesh {
            vertices: kept,
            triangles,
        },
        CleanCounts {
            degenerate_dropped,
            duplicates_welded,
            unreferenced_removed,
        },
    ))
}

/// A repeated vertex, or a height below [`ZERO_AREA_REL`] times the longest edge.
fn is_degenerate(vertices: &[[f64; 3]], t: [u32; 3]) -> bool {
    if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
        return true;
    }
    let [a, b, c] = t.map(|i| vertices[i as usize]);
    let ab = sub(b, a);
    let ac = sub(c, a);
    let bc = sub(c, b);
    let cross = [
        ab[1] * ac[2] - ab[2] * ac[1],
        ab[2] * ac[0] - ab[0] * ac[2],
        ab[0] * ac[1] - ab[1] * ac[0],
    ];
    // |cross| = longest edge * height; zero area when height <= rel * longest edge.
    let longest_sq = dot(ab, ab).max(dot(ac, ac)).max(dot(bc, bc));
    dot(cross, cross).sqrt() <= ZERO_AREA_REL * longest_sq
}

impl TriMesh {
    /// The volume the triangles enclose (mesh units cubed), by the divergence theorem: positive
    /// when they are counter-clockwise seen from outside (normals outwards), negative when
    /// inverted. Meaningful for a closed mesh ([`TriMesh::check_closed`]).
    pub fn signed_volume(&self) -> f64 {
        self.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| self.vertices[i as usize]);
                (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
                    + a[2] * (b[0] * c[1] - b[1] * c[0]))
                    / 6.0
            })
            .sum()
    }

    /// Checks that the mesh is a closed, consistently oriented 2-manifold: every edge is
    /// shared by exactly two triangles that run along it in opposite directions. Builders that
    /// need an inside (signed distance, inside tests) call this.
    ///
    /// The error names the first bad edge in triangle order: its vertex indices, their
    /// positions (mesh units) and a triangle that has it. Vertices where two sheets touch at a
    /// single point are not detected (they are harmless for inside tests).
    pub fn check_closed(&self) -> Result<(), MeshError> {
        if self.triangles.is_empty() {
            return Err(MeshError::NoTriangles);
        }
        // Per undirected edge (lo, hi): number of triangles, and how many run lo -> hi.
        let mut edges: HashMap<(u32, u32), (u32, u32)> =
            HashMap::with_capacity(self.triangles.len() * 3 / 2 + 1);
        for t in &self.triangles {
            for (a, b) in tri_edges(t) {
                let e = edges.entry((a.min(b), a.max(b))).or_insert((0, 0));
                e.0 += 1;
                if a < b {
                    e.1 += 1;
                }
            }
        }
        let pos = |v: u32| {
            self.vertices
                .get(v as usize)
                .copied()
                .unwrap_or([f64::NAN; 3])
        };
        for (triangle, t) in self.triangles.iter().enumerate() {
            for (a, b) in tri_edges(t) {
                let (count, forward) = edges[&(a.min(b), a.max(b))];
                let (pa, pb) = (pos(a), pos(b));
                match count {
                    1 => {
                        return Err(MeshError::BoundaryEdge {
                            a,
                            b,
                            pa,
                            pb,
                            triangle,
                        })
                    }
                    2 if forward != 1 => {
                        return Err(MeshError::FlippedEdge {
                            a,
                            b,
                            pa,
                            pb,
                            triangle,
                        })
                    }
                    2 => {}
                    _ => {
                        return Err(MeshError::NonManifoldEdge {
                            a,
                            b,
                            pa,
                            pb,
                            triangle,
                            count: count as usize,
                        })
                    }
                }
            }
        }
        Ok(())
    }
}

#[inline]
fn tri_edges(t: &[u32; 3]) -> [(u32, u32); 3] {
    [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn raw(vertices: Vec<[f64; 3]>, faces: &[&[i64]]) -> RawPolygons {
        RawPolygons {
            vertices,
            indices: faces.iter().flat_map(|f| f.iter().copied()).collect(),
            arities: faces.iter().map(|f| f.len() as u32).collect(),
        }
    }

    #[test]
    fn quad_is_fanned_and_duplicates_welded() {
        let v = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [-0.0, 0.0, 0.0], // same as vertex 0
            [5.0, 5.0, 5.0],  // unused
        ];
        let (m, c) = clean_polygons(raw(v, &[&[4, 1, 2, 3]]), Path::new("q")).unwrap();
        assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(m.vertices.len(), 4);
        assert_eq!(c.duplicates_welded, 1);
        assert_eq!(c.unreferenced_removed, 1);
        assert_eq!(c.degenerate_dropped, 0);
    }

    #[test]
    fn degenerate_triangles_are_dropped() {
        let v = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [2.0, 0.0, 0.0], // collinear with 0 and 1
        ];
        let (m, c) = clean_polygons(
            raw(v, &[&[0, 1, 2], &[0, 0, 2], &[0, 1, 3]]),
            Path::new("d"),
        )
        .unwrap();
        assert_eq!(m.triangles.len(), 1);
        assert_eq!(c.degenerate_dropped, 2);
    }
}
