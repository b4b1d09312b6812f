//! Helpers shared by the builder tests: the bundled bunny and the peers' sample files.
#![allow(dead_code)]

use mesh::TriMesh;
use spheretree::eval::toolkit_frame;
use spheretree::SphereTree;
use std::path::PathBuf;

/// Repository root.
pub fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The bundled Stanford bunny (1839 vertices, 3674 triangles, closed).
pub fn bunny() -> TriMesh {
    let loaded = mesh::load_mesh(&repo().join("assets/bunny.obj")).expect("assets/bunny.obj loads");
    loaded.mesh.check_closed().expect("the bunny is closed");
    loaded.mesh
}

/// A Bradshaw toolkit `.sph` file from `assets/peers/bradshaw/` (see its README), moved from
/// the toolkit's bbox-centred frame into `mesh`'s own frame.
pub fn bradshaw_in_mesh_frame(name: &str, mesh: &TriMesh) -> SphereTree {
    let path = repo().join("assets/peers/bradshaw").join(name);
    let mut tree = spheretree::sph::read_sph(&path).unwrap_or_else(|e| panic!("{e}"));
    let (centre, _) = toolkit_frame(mesh).unwrap();
    spheretree::sph::translate_tree(&mut tree, centre);
    tree
}
