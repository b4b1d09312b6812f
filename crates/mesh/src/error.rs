//! The error type of the `mesh` crate.

use std::path::PathBuf;

/// Errors of mesh loading and validation. Every message is one line that names the file (when
/// there is one) and says what is wrong and how to fix it.
#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    /// The file could not be read.
    #[error("cannot read mesh file {path}: {error}")]
    Read {
        /// The file.
        path: PathBuf,
        /// The OS error (part of the message, not a separate source).
        error: std::io::Error,
    },
    /// The file's format is not one this crate reads.
    #[error(
        "{path}: unknown mesh format (extension {extension:?}); use an .obj, .stl or .ply file"
    )]
    UnknownFormat {
        /// The file.
        path: PathBuf,
        /// The file's extension (empty if none).
        extension: String,
    },
    /// The file does not follow its format.
    #[error("{path}: invalid {format} file: {message}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// The format it was read as (e.g. `binary STL`).
        format: String,
        /// What is wrong.
        message: String,
    },
    /// No triangle is left to build a mesh from.
    #[error("{path}: the mesh is empty: {detail}")]
    Empty {
        /// The file.
        path: PathBuf,
        /// What the file did contain.
        detail: String,
    },
    /// A vertex has a NaN or infinite coordinate.
    #[error("{path}: vertex {vertex} has a non-finite coordinate ({x}, {y}, {z}); fix or remove that vertex", x = .position[0], y = .position[1], z = .position[2])]
    NonFinite {
        /// The file.
        path: PathBuf,
        /// 0-based vertex index, in the file's order.
        vertex: usize,
        /// The offending coordinates (file units).
        position: [f64; 3],
    },
    /// A face refers to a vertex that does not exist.
    #[error("{path}: face {face} refers to vertex {index}, but the file has {vertex_count} vertices (indices 0..{vertex_count}); the face list is corrupt")]
    IndexOutOfRange {
        /// The file.
        path: PathBuf,
        /// 0-based face index, in the file's order.
        face: usize,
        /// The bad vertex index (0-based; negative if the file stored a negative number).
        index: i64,
        /// Number of vertices in the file.
        vertex_count: usize,
    },
    /// A face has fewer than three vertices.
    #[error("{path}: face {face} has {count} vertices; a face needs at least 3")]
    ShortFace {
        /// The file.
        path: PathBuf,
        /// 0-based face index, in the file's order.
        face: usize,
        /// Its number of vertices.
        count: usize,
    },
    /// [`crate::TriMesh::check_closed`] on a mesh without triangles.
    #[error("the mesh has no triangles; a closed mesh is required")]
    NoTriangles,
    /// An edge belongs to a single triangle: the mesh has a hole.
    #[error("the mesh is not closed: edge ({a}, {b}) from {pa:?} to {pb:?} (triangle {triangle}) borders a hole; fill the hole (e.g. in MeshLab) so every edge has exactly two triangles")]
    BoundaryEdge {
        /// First vertex index of the edge.
        a: u32,
        /// Second vertex index of the edge.
        b: u32,
        /// Position of `a` (mesh units).
        pa: [f64; 3],
        /// Position of `b` (mesh units).
        pb: [f64; 3],
        /// A triangle that has the edge.
        triangle: usize,
    },
    /// An edge belongs to more than two triangles.
    #[error("the mesh is not manifold: edge ({a}, {b}) from {pa:?} to {pb:?} (triangle {triangle}) is shared by {count} triangles; split or remove the extra sheets so every edge has exactly two triangles")]
    NonManifoldEdge {
        /// First vertex index of the edge.
        a: u32,
        /// Second vertex index of the edge.
        b: u32,
        /// Position of `a` (mesh units).
        pa: [f64; 3],
        /// Position of `b` (mesh units).
        pb: [f64; 3],
        /// A triangle that has the edge.
        triangle: usize,
        /// Number of triangles sharing it.
        count: usize,
    },
    /// Two triangles traverse their shared edge in the same direction.
    #[error("the mesh is not consistently oriented: edge ({a}, {b}) from {pa:?} to {pb:?} (triangle {triangle}) runs the same way in both of its triangles; flip the faces that point inwards")]
    FlippedEdge {
        /// First vertex index of the edge.
        a: u32,
        /// Second vertex index of the edge.
        b: u32,
        /// Position of `a` (mesh units).
        pa: [f64; 3],
        /// Position of `b` (mesh units).
        pb: [f64; 3],
        /// A triangle that has the edge.
        triangle: usize,
    },
}
