//! Mesh input: a unit cube in every format (ASCII and binary), malformed files, the closed
//! check, and the bundled bunny.

use std::path::{Path, PathBuf};

use mesh::{load_mesh, LoadedMesh, MeshError, MeshFormat, TriMesh};

/// Unit cube corners, vertex `x + 2y + 4z`.
fn cube_vertices() -> Vec<[f64; 3]> {
    (0..8)
        .map(|i| [(i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64])
        .collect()
}

/// Six quads, counter-clockwise seen from outside.
const CUBE_QUADS: [[u32; 4]; 6] = [
    [0, 2, 3, 1],
    [4, 5, 7, 6],
    [0, 1, 5, 4],
    [2, 6, 7, 3],
    [0, 4, 6, 2],
    [1, 3, 7, 5],
];

fn cube_triangles() -> Vec<[u32; 3]> {
    CUBE_QUADS
        .iter()
        .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
        .collect()
}

struct Dir(PathBuf);

impl Dir {
    fn new(tag: &str) -> Self {
        let d = std::env::temp_dir().join(format!("haptic6d-mesh-{tag}-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        Dir(d)
    }
    fn write(&self, name: &str, bytes: impl AsRef<[u8]>) -> PathBuf {
        let p = self.0.join(name);
        std::fs::write(&p, bytes).unwrap();
        p
    }
}

impl Drop for Dir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn obj_text(v: &[[f64; 3]], faces: &[Vec<u32>]) -> String {
    let mut s = String::from("# test\no cube\n");
    for p in v {
        s += &format!("v {} {} {}\n", p[0], p[1], p[2]);
    }
    for f in faces {
        s += "f";
        for i in f {
            s += &format!(" {}", i + 1);
        }
        s += "\n";
    }
    s
}

fn stl_ascii(tris: &[[[f64; 3]; 3]]) -> String {
    let mut s = String::from("solid cube\n");
    for t in tris {
        s += "  facet normal 0 0 0\n    outer loop\n";
        for p in t {
            s += &format!("      vertex {} {} {}\n", p[0], p[1], p[2]);
        }
        s += "    endloop\n  endfacet\n";
    }
    s + "endsolid cube\n"
}

fn stl_binary(tris: &[[[f64; 3]; 3]], header_prefix: &[u8]) -> Vec<u8> {
    let mut b = vec![0u8; 80];
    b[..header_prefix.len()].copy_from_slice(header_prefix);
    b.extend((tris.len() as u32).to_le_bytes());
    for t in tris {
        b.extend([0u8; 12]);
        for p in t {
            for c in p {
                b.extend((*c as f32).to_le_bytes());
            }
        }
        b.extend([0u8; 2]);
    }
    b
}

fn cube_soup() -> Vec<[[f64; 3]; 3]> {
    let v = cube_vertices();
    cube_triangles()
        .iter()
        .map(|t| t.map(|i| v[i as usize]))
        .collect()
}

fn ply_header(format: &str, nv: usize, nf: usize, coord: &str, list: &str) -> String {
    format!(
        "ply\nformat {format} 1.0\ncomment cube\nelement vertex {nv}\nproperty {coord} x\nproperty {coord} y\nproperty {coord} z\nelement face {nf}\nproperty list {list} vertex_indices\nend_header\n"
    )
}

fn ply_ascii(v: &[[f64; 3]], faces: &[Vec<u32>]) -> String {
    let mut s = ply_header("ascii", v.len(), faces.len(), "float", "uchar int");
    for p in v {
        s += &format!("{} {} {}\n", p[0], p[1], p[2]);
    }
    for f in faces {
        s += &f.len().to_string();
        for i in f {
            s += &format!(" {i}");
        }
        s += "\n";
    }
    s
}

fn ply_binary_le(v: &[[f64; 3]], faces: &[Vec<u32>], double: bool) -> Vec<u8> {
    let coord = if double { "double" } else { "float" };
    let mut b = ply_header(
        "binary_little_endian",
        v.len(),
        faces.len(),
        coord,
        "uint8 uint32",
    )
    .into_bytes();
    for p in v {
        for c in p {
            if double {
                b.extend(c.to_le_bytes());
            } else {
                b.extend((*c as f32).to_le_bytes());
            }
        }
    }
    for f in faces {
        b.push(f.len() as u8);
        for i in f {
            b.extend(i.to_le_bytes());
        }
    }
    b
}

fn quads() -> Vec<Vec<u32>> {
    CUBE_QUADS.iter().map(|q| q.to_vec()).collect()
}

fn tris() -> Vec<Vec<u32>> {
    cube_triangles().iter().map(|t| t.to_vec()).collect()
}

#[track_caller]
fn assert_cube(l: &LoadedMesh, format: MeshFormat) {
    assert_eq!(l.report.format, format);
    assert_eq!(l.mesh.vertices.len(), 8, "{:?}", l.report);
    assert_eq!(l.mesh.triangles.len(), 12);
    assert_eq!(l.report.degenerate_dropped, 0);
    l.mesh.check_closed().unwrap();
    assert!(
        (l.mesh.signed_volume() - 1.0).abs() < 1e-12,
        "{}",
        l.mesh.signed_volume()
    );
    assert_eq!(l.mesh.aabb(), Some(([0.0; 3], [1.0; 3])));
}

#[test]
fn cube_in_every_format() {
    let d = Dir::new("formats");
    let v = cube_vertices();

    let l = load_mesh(&d.write("quads.obj", obj_text(&v, &quads()))).unwrap();
    assert_cube(&l, MeshFormat::Obj);
    assert_eq!(l.report.file_faces, 6);
    let l = load_mesh(&d.write("tris.OBJ", obj_text(&v, &tris()))).unwrap();
    assert_cube(&l, MeshFormat::Obj);

    let l = load_mesh(&d.write("cube.stl", stl_ascii(&cube_soup()))).unwrap();
    assert_cube(&l, MeshFormat::StlAscii);
    assert_eq!(l.report.file_vertices, 36);
    assert_eq!(l.report.duplicates_welded, 28);

    let l = load_mesh(&d.write("cube-bin.stl", stl_binary(&cube_soup(), b"binary cube"))).unwrap();
    assert_cube(&l, MeshFormat::StlBinary);
    // Binary files whose header starts with "solid" (common) are still read as binary.
    let l = load_mesh(&d.write("solid-bin.stl", stl_binary(&cube_soup(), b"solid cube"))).unwrap();
    assert_cube(&l, MeshFormat::StlBinary);
    // A bare "solid" first line is valid ASCII.
    let bare = stl_ascii(&cube_soup()).replacen("solid cube", "solid", 1);
    let l = load_mesh(&d.write("bare.stl", bare)).unwrap();
    assert_cube(&l, MeshFormat::StlAscii);

    let l = load_mesh(&d.write("cube.ply", ply_ascii(&v, &quads()))).unwrap();
    assert_cube(&l, MeshFormat::PlyAscii);
    let l = load_mesh(&d.write("cube-tri.ply", ply_ascii(&v, &tris()))).unwrap();
    assert_cube(&l, MeshFormat::PlyAscii);
    let l = load_mesh(&d.write("cube-f.ply", ply_binary_le(&v, &quads(), false))).unwrap();
    assert_cube(&l, MeshFormat::PlyBinaryLittleEndian);
    let l = load_mesh(&d.write("cube-d.ply", ply_binary_le(&v, &tris(), true))).unwrap();
    assert_cube(&l, MeshFormat::PlyBinaryLittleEndian);

    let be = ply_binary_le(&v, &tris(), true);
    let text_end = be.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
    let mut be_bytes = String::from_utf8(be[..text_end].to_vec())
        .unwrap()
        .replace("binary_little_endian", "binary_big_endian")
        .into_bytes();
    for p in &v {
        for c in p {
            be_bytes.extend(c.to_be_bytes());
        }
    }
    for f in tris() {
        be_bytes.push(3);
        for i in f {
            be_bytes.extend(i.to_be_bytes());
        }
    }
    let l = load_mesh(&d.write("cube-be.ply", be_bytes)).unwrap();
    assert_cube(&l, MeshFormat::PlyBinaryBigEndian);
    let alt = ply_ascii(&v, &quads()).replace("vertex_indices", "vertex_index");
    let l = load_mesh(&d.write("cube-alt.ply", alt)).unwrap();
    assert_cube(&l, MeshFormat::PlyAscii);

    // Unknown extension: the content decides.
    let l = load_mesh(&d.write("cube.mesh", ply_binary_le(&v, &tris(), true))).unwrap();
    assert_cube(&l, MeshFormat::PlyBinaryLittleEndian);
    let l = load_mesh(&d.write("cube.txt", obj_text(&v, &tris()))).unwrap();
    assert_cube(&l, MeshFormat::Obj);
}

#[test]
fn obj_objects_are_joined_and_welded() {
    // Two objects, each with its own copies of the shared corners.
    let v = cube_vertices();
    let mut s = String::from("o a\n");
    for p in &v {
        s += &format!("v {} {} {}\n", p[0], p[1], p[2]);
    }
    for q in &CUBE_QUADS[..3] {
        s += &format!("f {} {} {} {}\n", q[0] + 1, q[1] + 1, q[2] + 1, q[3] + 1);
    }
    s += "o b\n";
    for p in &v {
        s += &format!("v {} {} {}\n", p[0], p[1], p[2]);
    }
    for q in &CUBE_QUADS[3..] {
        // Negative (relative) indices, as OBJ allows.
        s += &format!(
            "f {} {} {} {}\n",
            q[0] as i64 - 8,
            q[1] as i64 - 8,
            q[2] as i64 - 8,
            q[3] as i64 - 8
        );
    }
    let d = Dir::new("objects");
    let l = load_mesh(&d.write("two.obj", s)).unwrap();
    assert_cube(&l, MeshFormat::Obj);
}

#[test]
fn degenerate_faces_are_dropped_and_counted() {
    let mut v = cube_vertices();
    v.push([0.5, 0.0, 0.0]); // 8: on the edge 0-1
    let mut faces = tris();
    faces.push(vec![0, 0, 1]); // repeated index
    faces.push(vec![0, 8, 1]); // zero area
    let d = Dir::new("degenerate");
    let l = load_mesh(&d.write("deg.ply", ply_ascii(&v, &faces))).unwrap();
    assert_eq!(l.report.degenerate_dropped, 2);
    assert_eq!(l.report.unreferenced_removed, 1);
    assert_cube(
        &LoadedMesh {
            report: mesh::LoadReport {
                degenerate_dropped: 0,
                ..l.report
            },
            mesh: l.mesh.clone(),
        },
        MeshFormat::PlyAscii,
    );
}

/// Loads `bytes` as `name`, expects an error, checks it is one line naming the file.
#[track_caller]
fn load_err(d: &Dir, name: &str, bytes: impl AsRef<[u8]>) -> (MeshError, String) {
    let p = d.write(name, bytes);
    match load_mesh(&p) {
        Ok(l) => panic!("{name}: expected an error, loaded {:?}", l.report),
        Err(e) => {
            let msg = e.to_string();
            eprintln!("{msg}");
            assert!(msg.contains(name), "{msg}");
            assert!(!msg.contains('\n'), "not one line: {msg}");
            (e, msg)
        }
    }
}

#[test]
fn malformed_files_give_one_line_errors() {
    let d = Dir::new("malformed");
    let v = cube_vertices();

    // Empty.
    let (e, _) = load_err(&d, "empty.obj", "");
    assert!(matches!(e, MeshError::Empty { .. }), "{e}");
    let (e, _) = load_err(&d, "points.obj", "v 0 0 0\nv 1 0 0\n");
    assert!(matches!(e, MeshError::Empty { .. }), "{e}");
    let (e, _) = load_err(&d, "zero.stl", stl_binary(&[], b""));
    assert!(matches!(e, MeshError::Empty { .. }), "{e}");
    let (e, _) = load_err(&d, "empty.stl", "");
    assert!(matches!(e, MeshError::Parse { .. }), "{e}");
    let (e, _) = load_err(
        &d,
        "all-degenerate.obj",
        "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n",
    );
    assert!(matches!(e, MeshError::Empty { .. }), "{e}");

    // Truncated binary STL: header promises 12 triangles.
    let mut bin = stl_binary(&cube_soup(), b"");
    bin.truncate(bin.len() - 30);
    let (e, m) = load_err(&d, "trunc.stl", &bin);
    assert!(
        matches!(e, MeshError::Parse { .. }) && m.contains("12 triangles"),
        "{m}"
    );
    // Truncated ASCII STL.
    let text = stl_ascii(&cube_soup());
    let (e, _) = load_err(&d, "trunc-ascii.stl", &text[..text.len() / 2]);
    assert!(matches!(e, MeshError::Parse { .. }), "{e}");
    // Too short to be anything.
    let (e, _) = load_err(&d, "tiny.stl", "abc");
    assert!(matches!(e, MeshError::Parse { .. }), "{e}");

    // PLY: header says more vertices than the file has.
    let ply = ply_ascii(&v, &tris()).replace("element vertex 8", "element vertex 9");
    let (e, _) = load_err(&d, "count.ply", ply);
    assert!(matches!(e, MeshError::Parse { .. }), "{e}");
    // PLY: binary truncated.
    let mut b = ply_binary_le(&v, &tris(), false);
    b.truncate(b.len() - 7);
    let (e, m) = load_err(&d, "trunc.ply", b);
    assert!(
        matches!(e, MeshError::Parse { .. }) && m.contains("face"),
        "{m}"
    );
    // PLY: no face element at all / missing coordinates.
    let (e, _) = load_err(
        &d,
        "noface.ply",
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n",
    );
    assert!(matches!(e, MeshError::Empty { .. }), "{e}");
    let (_, m) = load_err(
        &d,
        "noz.ply",
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n0 0\n",
    );
    assert!(m.contains("`z`"), "{m}");
    let (e, _) = load_err(&d, "garbage.ply", "ply\nthis is not a header\n");
    assert!(matches!(e, MeshError::Parse { .. }), "{e}");

    // NaN / infinite coordinates.
    let mut bad = v.clone();
    bad[5] = [1.0, f64::NAN, 1.0];
    let (e, m) = load_err(&d, "nan.ply", ply_binary_le(&bad, &tris(), true));
    assert!(
        matches!(e, MeshError::NonFinite { vertex: 5, .. }) && m.contains("vertex 5"),
        "{m}"
    );
    let (_, m) = load_err(&d, "nan.obj", obj_text(&bad, &tris()));
    assert!(m.contains("line 8") && m.contains("finite"), "{m}");
    let mut soup = cube_soup();
    soup[3][1][2] = f64::INFINITY;
    let (_, m) = load_err(&d, "inf.stl", stl_binary(&soup, b""));
    assert!(
        m.contains("triangle 3, corner 1") && m.contains("non-finite"),
        "{m}"
    );

    // Out-of-range indices.
    let mut faces = tris();
    faces[7][2] = 8;
    let (e, m) = load_err(&d, "index.ply", ply_ascii(&v, &faces));
    assert!(
        matches!(
            e,
            MeshError::IndexOutOfRange {
                face: 7,
                index: 8,
                vertex_count: 8,
                ..
            }
        ),
        "{m}"
    );
    let (e, m) = load_err(&d, "index.obj", obj_text(&v, &faces));
    // Line 2 + 8 vertices + 7 faces before it: the bad face is on line 18.
    assert!(
        matches!(e, MeshError::Parse { .. }) && m.contains("line 18"),
        "{m}"
    );
    let (_, m) = load_err(&d, "badv.obj", "v 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    assert!(m.contains("line 1") && m.contains("three numbers"), "{m}");
    let (_, m) = load_err(&d, "zero.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n");
    assert!(m.contains("line 4"), "{m}");
    let (e, _) = load_err(
        &d,
        "neg.ply",
        ply_ascii(&v, &tris()).replace("3 0 2 3", "3 0 -2 3"),
    );
    assert!(
        matches!(e, MeshError::IndexOutOfRange { index: -2, .. }),
        "{e}"
    );
    // A face of two vertices.
    let mut faces = tris();
    faces[0] = vec![0, 1];
    let (e, _) = load_err(&d, "short.ply", ply_ascii(&v, &faces));
    assert!(
        matches!(
            e,
            MeshError::ShortFace {
                face: 0,
                count: 2,
                ..
            }
        ),
        "{e}"
    );

    // Unknown format, missing file.
    let (e, _) = load_err(&d, "notes.xyz", "hello");
    assert!(matches!(e, MeshError::UnknownFormat { .. }), "{e}");
    let e = load_mesh(Path::new("/nonexistent/bunny.obj")).unwrap_err();
    assert!(e.to_string().contains("/nonexistent/bunny.obj"), "{e}");
}

#[test]
fn check_closed_names_the_first_bad_edge() {
    let v = cube_vertices();
    let closed = TriMesh {
        vertices: v.clone(),
        triangles: cube_triangles(),
    };
    closed.check_closed().unwrap();

    // A hole: drop the first triangle (0, 2, 3); the next one, (0, 3, 1), now has edge (0, 3)
    // on the hole.
    let mut open = closed.clone();
    open.triangles.remove(0);
    match open.check_closed() {
        Err(MeshError::BoundaryEdge { a, b, pa, pb, .. }) => {
            assert_eq!((a.min(b), a.max(b)), (0, 3));
            assert_eq!(pa, v[a as usize]);
            assert_eq!(pb, v[b as usize]);
        }
        other => panic!("{other:?}"),
    }
    let msg = open.check_closed().unwrap_err().to_string();
    assert!(
        msg.contains("not closed") && msg.contains("(0, 3)"),
        "{msg}"
    );

    // A flipped triangle.
    let mut flipped = closed.clone();
    flipped.triangles[4].swap(1, 2);
    assert!(matches!(
        flipped.check_closed(),
        Err(MeshError::FlippedEdge { .. })
    ));

    // A fin: a third triangle on edge (0, 1).
    let mut fin = closed.clone();
    fin.vertices.push([0.5, -1.0, 0.0]);
    fin.triangles.push([0, 1, 8]);
    fin.triangles.push([1, 0, 8]);
    match fin.check_closed() {
        Err(MeshError::NonManifoldEdge { a, b, count, .. }) => {
            assert_eq!((a.min(b), a.max(b)), (0, 1));
            assert_eq!(count, 4);
        }
        other => panic!("{other:?}"),
    }
    assert!(matches!(
        TriMesh::default().check_closed(),
        Err(MeshError::NoTriangles)
    ));
}

fn bunny_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/bunny.obj")
}

#[test]
fn bundled_bunny_loads_closed() {
    let l = load_mesh(&bunny_path()).unwrap();
    assert_eq!(l.report.format, MeshFormat::Obj);
    assert_eq!(l.mesh.vertices.len(), 1839);
    assert_eq!(l.mesh.triangles.len(), 3674);
    assert_eq!(l.report.degenerate_dropped, 0);
    assert_eq!(l.report.duplicates_welded, 0);
    l.mesh.check_closed().unwrap();
    assert!(
        l.mesh.signed_volume() > 0.0,
        "bunny triangles must face outwards"
    );
    // Euler characteristic of a sphere: V - E + F = 2 with E = 3F/2.
    let (v, f) = (l.mesh.vertices.len() as i64, l.mesh.triangles.len() as i64);
    assert_eq!(v - 3 * f / 2 + f, 2);
}

#[test]
fn bunny_survives_stl_and_ply_round_trips() {
    let bunny = load_mesh(&bunny_path()).unwrap().mesh;
    let soup: Vec<[[f64; 3]; 3]> = bunny
        .triangles
        .iter()
        .map(|t| t.map(|i| bunny.vertices[i as usize]))
        .collect();
    let d = Dir::new("bunny");
    for (name, bytes) in [
        ("bunny.stl", stl_binary(&soup, b"solid bunny")),
        ("bunny-ascii.stl", stl_ascii(&soup).into_bytes()),
        (
            "bunny.ply",
            ply_binary_le(
                &bunny.vertices,
                &bunny
                    .triangles
                    .iter()
                    .map(|t| t.to_vec())
                    .collect::<Vec<_>>(),
                true,
            ),
        ),
    ] {
        let l = load_mesh(&d.write(name, bytes)).unwrap();
        assert_eq!(l.mesh.vertices.len(), 1839, "{name}");
        assert_eq!(l.mesh.triangles.len(), 3674, "{name}");
        l.mesh
            .check_closed()
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        let rel = (l.mesh.signed_volume() - bunny.signed_volume()).abs() / bunny.signed_volume();
        assert!(rel < 1e-5, "{name}: volume off by {rel}");
    }
}
