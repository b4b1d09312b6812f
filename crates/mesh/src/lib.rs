//! Triangle meshes for haptic6d: loading (OBJ, STL, PLY), validation, and geometric queries
//! (closest point, signed distance, inside test, surface sampling). Offline only: nothing here
//! runs in the haptic frame.
//!
//! Entry points:
//! - [`TriMesh`]: an indexed triangle mesh in the file's own units.
//! - [`load_mesh`]: OBJ / STL / PLY file to a validated [`TriMesh`] and a [`LoadReport`];
//!   [`TriMesh::check_closed`] for builders that need a closed 2-manifold;
//!   [`TriMesh::with_holes_closed`] to close an open one for inside queries; [`MeshError`].
//! - [`MeshQuery`]: closest point, signed distance, inside test ([`InsideTest`]: pseudo-normal
//!   for closed meshes, generalised winding number for open or self-intersecting ones).
//! - [`sample_surface`]: area-weighted seeded surface samples with normals.
//! - [`generate`]: spheres, tori and boxes of any size, and damaged (open, holed,
//!   self-intersecting) variants, for tests and studies.
#![warn(missing_docs)]

mod error;
mod holes;
pub mod input;
pub mod load;
pub mod triangulate;
pub mod validate;
pub mod vec3;

pub use error::MeshError;
pub use input::{check_output_file, read_input, write_atomic, MAX_MESH_BYTES};
pub use load::{load_mesh, load_mesh_bytes, LoadReport, LoadedMesh, MeshFormat};

pub mod generate;
pub mod query;
pub mod sample;

pub use query::{ClosestPoint, Feature, InsideTest, MeshQuery};
pub use sample::{sample_surface, sample_surface_weighted, SurfaceSample};

/// An indexed triangle mesh. Coordinates are in the file's own units (scaled to mm by the
/// scene); triangles are counter-clockwise seen from outside.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriMesh {
    /// Vertex positions (mesh units).
    pub vertices: Vec<[f64; 3]>,
    /// Triangles as vertex indices, counter-clockwise from outside.
    pub triangles: Vec<[u32; 3]>,
}

impl TriMesh {
    /// Axis-aligned bounding box `(min, max)` of the vertices (mesh units); `None` when empty.
    pub fn aabb(&self) -> Option<([f64; 3], [f64; 3])> {
        let first = *self.vertices.first()?;
        let mut lo = first;
        let mut hi = first;
        for v in &self.vertices {
            for k in 0..3 {
                lo[k] = lo[k].min(v[k]);
                hi[k] = hi[k].max(v[k]);
            }
        }
        Some((lo, hi))
    }

    /// The same mesh with every vertex mapped by `p -> (p - center) * scale` (a copy).
    pub fn scaled_about(&self, center: [f64; 3], scale: f64) -> TriMesh {
        TriMesh {
            vertices: self
                .vertices
                .iter()
                .map(|v| {
                    [
                        (v[0] - center[0]) * scale,
                        (v[1] - center[1]) * scale,
                        (v[2] - center[2]) * scale,
                    ]
                })
                .collect(),
            triangles: self.triangles.clone(),
        }
    }
}
