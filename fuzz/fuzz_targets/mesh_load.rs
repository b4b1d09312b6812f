//! Mesh loader: the first byte picks the extension (OBJ, STL, PLY, unknown = sniffed), the rest
//! is the file. Must never panic; errors are one line naming the file; accepted meshes are
//! valid.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Some((&sel, bytes)) = data.split_first() else {
        return;
    };
    let name = ["f.obj", "f.stl", "f.ply", "f.bin"][usize::from(sel % 4)];
    match mesh::load_mesh_bytes(bytes, Path::new(name)) {
        Ok(l) => {
            assert!(!l.mesh.triangles.is_empty());
            assert!(l.mesh.vertices.iter().flatten().all(|c| c.is_finite()));
            let n = l.mesh.vertices.len();
            assert!(l.mesh.triangles.iter().flatten().all(|&i| (i as usize) < n));
        }
        Err(e) => {
            let m = e.to_string();
            assert!(!m.contains('\n') && m.contains(name), "{m}");
        }
    }
});
