//! What the tool touches: the sphere envelope of the trees (the paper's model) or the parts'
//! own meshes ([`Geometry`]), and the meshes a god-object is given ([`MeshRef`]).

use crate::setting::Setting;

/// The geometry the frame step keeps the tool out of.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Geometry {
    /// The leaf spheres of the trees (the paper's model): the tool touches their envelope,
    /// which stands up to a leaf's overhang off the parts.
    #[default]
    Spheres,
    /// The parts' own triangles: each body's triangles in a box tree give the pairs near each
    /// other, and each pair a row (nearest features, exact distances); the sphere-trees' roots,
    /// grown to hold the triangles, still prove free space. Needs the tool's and every
    /// object's mesh; without them the step keeps spheres
    /// ([`crate::step::GodObject::geometry`] says which it uses).
    Mesh,
}

impl Geometry {
    /// The name in scene files and on the command line: `spheres` or `mesh`.
    pub fn name(self) -> &'static str {
        match self {
            Geometry::Spheres => "spheres",
            Geometry::Mesh => "mesh",
        }
    }
}

impl Setting for Geometry {
    const WHAT: &'static str = "geometry";
    const ALL: &'static [Self] = &[Geometry::Spheres, Geometry::Mesh];
    const ALIASES: &'static [(&'static str, Self)] =
        &[("sphere", Geometry::Spheres), ("meshes", Geometry::Mesh)];
    fn setting_name(self) -> &'static str {
        self.name()
    }
}

/// A body's triangle mesh as the god-object takes it: vertices in the body's tree frame (mm)
/// and triangles as vertex indices.
#[derive(Clone, Copy, Debug)]
pub struct MeshRef<'a> {
    /// Vertex positions, mm (the frame of the body's sphere-tree).
    pub vertices: &'a [[f64; 3]],
    /// Triangles as indices into `vertices`.
    pub triangles: &'a [[u32; 3]],
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_names_parse_back() {
        for g in Geometry::ALL {
            assert_eq!(Geometry::parse_setting(g.name()).unwrap(), *g);
        }
        let e = Geometry::parse_setting("voxels").unwrap_err().to_string();
        assert!(e.contains("spheres, mesh"), "{e}");
    }
}
