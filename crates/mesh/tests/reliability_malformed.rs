//! Malformed mesh files, format by format (OBJ, STL ASCII/binary, PLY ASCII/binary): truncated,
//! wrong counts, NaN/inf, huge values, wrong types, empty, binary garbage. Every one must give
//! a one-line error that names the file (and the line, for line-based text formats) and never
//! panic. Regression tests for bugs the fuzzer found are at the end, named after what broke.

use std::path::{Path, PathBuf};

use mesh::{load_mesh, load_mesh_bytes};

struct Dir(PathBuf);

impl Dir {
    fn new(tag: &str) -> Self {
        let d = std::env::temp_dir().join(format!(
            "haptic6d-reliability-mesh-{tag}-{}",
            std::process::id()
        ));
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

/// Loads `bytes` from a real file named `name`, expects an error, checks it is one line and
/// names the file and every `needles` (case-insensitive); returns the message.
#[track_caller]
fn expect_err(d: &Dir, name: &str, bytes: impl AsRef<[u8]>, needles: &[&str]) -> String {
    let p = d.write(name, bytes);
    let e = match load_mesh(&p) {
        Ok(l) => panic!("{name}: accepted malformed input: {:?}", l.report),
        Err(e) => e.to_string(),
    };
    assert!(!e.contains('\n'), "{name}: multi-line error: {e:?}");
    assert!(
        e.contains(&p.display().to_string()),
        "{name}: error does not name the file: {e}"
    );
    let lower = e.to_lowercase();
    for n in needles {
        assert!(
            lower.contains(&n.to_lowercase()),
            "{name}: `{n}` not in: {e}"
        );
    }
    e
}

/// The outcome of loading input that may or may not be acceptable: an `Err` is one line and
/// names the file; an `Ok` is a usable mesh — at least one triangle, every vertex finite,
/// every index in range, no degenerate triangle. Never a non-finite mesh.
#[track_caller]
fn assert_error_or_finite_mesh(
    outcome: Result<mesh::LoadedMesh, mesh::MeshError>,
    name: &str,
) -> Option<mesh::TriMesh> {
    match outcome {
        Err(e) => {
            let e = e.to_string();
            assert!(!e.contains('\n') && e.contains(name), "{name}: {e}");
            None
        }
        Ok(l) => {
            let m = l.mesh;
            assert!(!m.triangles.is_empty(), "{name}: accepted with no triangle");
            for (i, v) in m.vertices.iter().enumerate() {
                assert!(
                    v.iter().all(|c| c.is_finite()),
                    "{name}: vertex {i} is not finite: {v:?}"
                );
            }
            for (k, t) in m.triangles.iter().enumerate() {
                assert!(
                    t.iter().all(|&i| (i as usize) < m.vertices.len()),
                    "{name}: triangle {k} indexes past the vertices: {t:?}"
                );
                let [a, b, c] = t.map(|i| m.vertices[i as usize]);
                // Edges scaled by the largest coordinate difference, so that a finite, huge
                // triangle is measurable without overflow.
                let e = |p: [f64; 3], q: [f64; 3]| [q[0] - p[0], q[1] - p[1], q[2] - p[2]];
                let (ab, ac, bc) = (e(a, b), e(a, c), e(b, c));
                let s = ab
                    .iter()
                    .chain(&ac)
                    .chain(&bc)
                    .fold(0.0f64, |m, x| m.max(x.abs()));
                assert!(
                    s > 0.0 && s.is_finite(),
                    "{name}: triangle {k} has no extent"
                );
                let (u, w, z) = (ab.map(|x| x / s), ac.map(|x| x / s), bc.map(|x| x / s));
                let n = [
                    u[1] * w[2] - u[2] * w[1],
                    u[2] * w[0] - u[0] * w[2],
                    u[0] * w[1] - u[1] * w[0],
                ];
                let d = |v: [f64; 3]| v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
                let longest_sq = d(u).max(d(w)).max(d(z));
                // The loader's contract (mesh::validate): height above 1e-12 x longest edge;
                // 1e-13 here leaves room for rounding.
                let rel_height = d(n).sqrt() / longest_sq;
                assert!(
                    rel_height.is_finite() && rel_height > 1e-13,
                    "{name}: triangle {k} is degenerate (height / longest edge {rel_height:e})"
                );
            }
            Some(m)
        }
    }
}

const TET_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";

fn ply_header(enc: &str, nv: &str, nf: &str) -> String {
    format!(
        "ply\nformat {enc} 1.0\nelement vertex {nv}\nproperty float x\nproperty float y\nproperty float z\nelement face {nf}\nproperty list uchar int vertex_indices\nend_header\n"
    )
}

const TET_PLY_BODY: &str = "0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";

fn stl_ascii_tri(v: [&str; 3]) -> String {
    format!(
        "solid t\nfacet normal 0 0 0\nouter loop\nvertex {}\nvertex {}\nvertex {}\nendloop\nendfacet\nendsolid t\n",
        v[0], v[1], v[2]
    )
}

fn stl_binary(tris: &[[[f32; 3]; 3]], declared: u32) -> Vec<u8> {
    let mut b = vec![0u8; 80];
    b.extend(declared.to_le_bytes());
    for t in tris {
        b.extend([0u8; 12]);
        for p in t {
            for c in p {
                b.extend(c.to_le_bytes());
            }
        }
        b.extend([0u8; 2]);
    }
    b
}

const TRI: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];

#[test]
fn sanity_valid_files_load() {
    let d = Dir::new("valid");
    assert!(load_mesh(&d.write("t.obj", TET_OBJ)).is_ok());
    let ply = ply_header("ascii", "4", "4") + TET_PLY_BODY;
    assert!(load_mesh(&d.write("t.ply", ply)).is_ok());
    assert!(load_mesh(&d.write("t.stl", stl_ascii_tri(["0 0 0", "1 0 0", "0 1 0"]))).is_ok());
    assert!(load_mesh(&d.write("b.stl", stl_binary(&[TRI], 1))).is_ok());
}

#[test]
fn empty_files() {
    let d = Dir::new("empty");
    for name in ["e.obj", "e.stl", "e.ply"] {
        expect_err(&d, name, "", &[]);
    }
    // Whitespace only, comments only, vertices without faces.
    expect_err(&d, "ws.obj", "\n\n   \n", &["empty"]);
    expect_err(&d, "c.obj", "# nothing\n", &["empty"]);
    expect_err(&d, "v.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n", &["no face"]);
    expect_err(&d, "h.ply", ply_header("ascii", "0", "0"), &[]);
    expect_err(&d, "z.stl", stl_binary(&[], 0), &[]);
    expect_err(&d, "s.stl", "solid x\nendsolid x\n", &[]);
}

#[test]
fn obj_malformed_lines_are_located() {
    let d = Dir::new("obj");
    // Wrong types, wrong counts, bad references: the error names the line.
    expect_err(
        &d,
        "t1.obj",
        "v 0 0 0\nv 1 x 0\nv 0 1 0\nf 1 2 3\n",
        &["line 2"],
    );
    expect_err(
        &d,
        "t2.obj",
        "v 0 0 0\nv 1 0\nv 0 1 0\nf 1 2 3\n",
        &["line 2"],
    );
    expect_err(
        &d,
        "t3.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n",
        &["line 4", "vertex 4"],
    );
    expect_err(
        &d,
        "t4.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n",
        &["line 4"],
    );
    expect_err(
        &d,
        "t5.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 b 3\n",
        &["line 4"],
    );
    expect_err(
        &d,
        "t6.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n",
        &["line 4"],
    );
    expect_err(
        &d,
        "t7.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -9 1 2\n",
        &["line 4"],
    );
    // Huge index.
    expect_err(
        &d,
        "t8.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99999999999999999999\n",
        &["line 4"],
    );
    // Truncated mid-line (the last face keeps one corner).
    expect_err(&d, "t9.obj", &TET_OBJ[..TET_OBJ.len() - 5], &["line 8"]);
}

#[test]
fn obj_non_finite_and_huge_coordinates() {
    let d = Dir::new("objnan");
    for bad in ["nan", "NaN", "inf", "-inf", "1e400"] {
        let text = format!("v 0 0 0\nv 1 {bad} 0\nv 0 1 0\nf 1 2 3\n");
        expect_err(&d, "n.obj", text, &["line 2"]);
    }
    // Large but finite coordinates are the user's units: accepted.
    let text = "v 0 0 0\nv 1e100 0 0\nv 0 1e100 0\nf 1 2 3\n";
    let l = load_mesh_bytes(text.as_bytes(), Path::new("big.obj")).unwrap();
    assert_eq!(l.mesh.triangles.len(), 1);
    // Near f64::MAX the area overflows: the triangle may be dropped as degenerate, but the
    // outcome is an error, never a panic or a non-finite mesh.
    let text = "v 0 0 0\nv 1e300 0 0\nv 0 1e300 0\nf 1 2 3\n";
    assert_error_or_finite_mesh(
        load_mesh_bytes(text.as_bytes(), Path::new("huge.obj")),
        "huge.obj",
    );
}

#[test]
fn stl_ascii_malformed() {
    let d = Dir::new("stla");
    expect_err(
        &d,
        "a1.stl",
        stl_ascii_tri(["0 0 0", "1 x 0", "0 1 0"]),
        &[],
    );
    expect_err(&d, "a2.stl", stl_ascii_tri(["0 0 0", "1 0", "0 1 0"]), &[]);
    expect_err(
        &d,
        "a3.stl",
        stl_ascii_tri(["0 0 0", "1 nan 0", "0 1 0"]),
        &[],
    );
    expect_err(
        &d,
        "a4.stl",
        stl_ascii_tri(["0 0 0", "1 inf 0", "0 1 0"]),
        &[],
    );
    // Truncated after the second vertex.
    let full = stl_ascii_tri(["0 0 0", "1 0 0", "0 1 0"]);
    let cut = &full[..full.find("vertex 0 1 0").unwrap()];
    expect_err(&d, "a5.stl", cut, &[]);
    // A facet of two vertices.
    let two = full.replace("vertex 0 1 0\n", "");
    expect_err(&d, "a6.stl", two, &[]);
}

#[test]
fn stl_binary_malformed() {
    let d = Dir::new("stlb");
    // Shorter than the header.
    expect_err(&d, "b1.stl", vec![7u8; 40], &["84-byte header"]);
    // Count says 2, one triangle present (truncated).
    expect_err(&d, "b2.stl", stl_binary(&[TRI], 2), &["truncated"]);
    // Count says 4 billion.
    expect_err(&d, "b3.stl", stl_binary(&[TRI], u32::MAX), &["truncated"]);
    // NaN and inf coordinates.
    let mut t = TRI;
    t[1][1] = f32::NAN;
    expect_err(&d, "b4.stl", stl_binary(&[t], 1), &["non-finite"]);
    t[1][1] = f32::INFINITY;
    expect_err(&d, "b5.stl", stl_binary(&[t], 1), &["non-finite"]);
    // Binary garbage of the right size for 3 triangles: must not panic (may load or fail).
    let mut g = stl_binary(&[TRI; 3], 3);
    for (i, b) in g.iter_mut().enumerate().skip(84) {
        *b = (i as u32).wrapping_mul(2_654_435_761).to_le_bytes()[3];
    }
    let p = d.write("b6.stl", &g);
    // Measured: it loads, one of the three triangles surviving (the others degenerate).
    let garbage = assert_error_or_finite_mesh(load_mesh(&p), "b6.stl");
    assert!(
        garbage.is_some(),
        "b6.stl: garbage that loaded before now fails"
    );
}

#[test]
fn ply_malformed() {
    let d = Dir::new("ply");
    // Wrong counts: more vertices/faces declared than present.
    expect_err(
        &d,
        "p1.ply",
        ply_header("ascii", "5", "4") + TET_PLY_BODY,
        &["element"],
    );
    expect_err(
        &d,
        "p2.ply",
        ply_header("ascii", "4", "9") + TET_PLY_BODY,
        &["element `face`"],
    );
    // Wrong types in the body.
    expect_err(
        &d,
        "p3.ply",
        ply_header("ascii", "4", "4") + &TET_PLY_BODY.replace("1 0 0\n", "1 zz 0\n"),
        &["element `vertex`"],
    );
    // Face index out of range / negative.
    expect_err(
        &d,
        "p4.ply",
        ply_header("ascii", "4", "4") + &TET_PLY_BODY.replace("3 1 2 3", "3 1 2 7"),
        &["vertex 7"],
    );
    expect_err(
        &d,
        "p5.ply",
        ply_header("ascii", "4", "4") + &TET_PLY_BODY.replace("3 1 2 3", "3 1 2 -1"),
        &["-1"],
    );
    // Missing x property, missing face list.
    let no_x = ply_header("ascii", "4", "4").replace("property float x\n", "");
    expect_err(
        &d,
        "p6.ply",
        no_x + "0 0\n0 0\n1 0\n0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n",
        &[],
    );
    // Header without end_header, unknown format, bad magic.
    expect_err(
        &d,
        "p7.ply",
        "ply\nformat ascii 1.0\nelement vertex 3\n",
        &["header"],
    );
    expect_err(
        &d,
        "p8.ply",
        "ply\nformat utf16 1.0\nend_header\n",
        &["header"],
    );
    expect_err(&d, "p9.ply", "plx\n", &[]);
    // Binary truncated.
    let mut b = ply_header("binary_little_endian", "3", "1").into_bytes();
    b.extend([0u8; 20]);
    expect_err(&d, "p10.ply", b, &["element `vertex`"]);
    // Binary NaN coordinate.
    let mut b = ply_header("binary_little_endian", "3", "1").into_bytes();
    for c in [0.0f32, 0.0, 0.0, 1.0, f32::NAN, 0.0, 0.0, 1.0, 0.0] {
        b.extend(c.to_le_bytes());
    }
    b.push(3);
    for i in [0i32, 1, 2] {
        b.extend(i.to_le_bytes());
    }
    expect_err(&d, "p11.ply", b, &["non-finite"]);
}

#[test]
fn binary_garbage_under_every_extension() {
    let d = Dir::new("garbage");
    let garbage: Vec<u8> = (0..4096u32)
        .map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8)
        .collect();
    for name in ["g.obj", "g.stl", "g.ply", "g.xyz"] {
        expect_err(&d, name, &garbage, &[]);
    }
}

// ---------------------------------------------------------------------------------------------
// Regressions found by tests/fuzz_mesh.rs (ply-rs panics or loops on these headers).

#[test]
fn ply_element_count_overflowing_u64_is_an_error_not_a_panic() {
    let d = Dir::new("reg1");
    let e = expect_err(
        &d,
        "r1.ply",
        ply_header("ascii", "18446744073709551616", "4") + TET_PLY_BODY,
        &["header line 3", "too large"],
    );
    assert!(e.contains("18446744073709551616"), "{e}");
}

#[test]
fn ply_format_version_overflowing_u64_is_an_error_not_a_panic() {
    let d = Dir::new("reg2");
    let text =
        ply_header("ascii", "4", "4").replace("1.0", "99999999999999999999.0") + TET_PLY_BODY;
    expect_err(&d, "r2.ply", text, &["header line 2", "too large"]);
}

#[test]
fn ply_element_count_larger_than_file_is_an_error_not_a_hang() {
    // An element without properties and a count of 10^11: ply-rs would push 10^11 empty
    // elements (hours, then out of memory).
    let d = Dir::new("reg3");
    let text = "ply\nformat binary_little_endian 1.0\nelement pad 99999999999\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
    expect_err(&d, "r3.ply", text, &["header line 3", "does not fit"]);
}

#[test]
fn obj_face_with_fewer_than_three_corners_is_an_error_not_dropped() {
    // tobj reads `f 1 2` as a line and `f 1` as a point; with lines and points ignored the face
    // vanished silently (a truncated file loaded as a mesh with a hole).
    let d = Dir::new("reg4");
    let text = TET_OBJ.replace("f 2 3 4\n", "f 2 3\n");
    expect_err(&d, "r4.obj", text, &["line 8", "2 vertices"]);
    expect_err(
        &d,
        "r5.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n",
        &["line 4"],
    );
}

#[test]
fn obj_non_finite_vertex_error_names_the_line() {
    let d = Dir::new("reg5");
    let text = TET_OBJ.replace("v 0 1 0", "v 0 nan 0");
    expect_err(&d, "r6.obj", text, &["line 3", "finite"]);
}

// ---------------------------------------------------------------------------------------------
// Safety and security: each failure an adversarial pass found, as a regression test.

#[test]
fn ply_count_after_75_kb_of_comments_is_checked_against_the_file_size() {
    // The count check used to read only the first 64 KiB of the header: a count of 10^11
    // behind 75 KB of comments reached ply-rs (allocation abort, rc 134).
    let d = Dir::new("i14a");
    let comments = "comment padding padding padding padding padding padding\n".repeat(1400);
    assert!(comments.len() > 75_000);
    let text = ply_header("ascii", "99999999999", "4").replace(
        "format ascii 1.0\n",
        &format!("format ascii 1.0\n{comments}"),
    ) + TET_PLY_BODY;
    expect_err(
        &d,
        "c.ply",
        &text,
        &["header line 1403", "99999999999", "does not fit"],
    );
    // Binary too, and a count past 64 bits behind the comments (ply-rs panicked).
    let bin = ply_header("binary_little_endian", "99999999999", "4").replace(
        "format binary_little_endian 1.0\n",
        &format!("format binary_little_endian 1.0\n{comments}"),
    );
    expect_err(&d, "b.ply", bin.as_bytes(), &["vertex", "does not fit"]);
    let big = ply_header("ascii", "184467440737095516160", "4").replace(
        "format ascii 1.0\n",
        &format!("format ascii 1.0\n{comments}"),
    );
    expect_err(&d, "o.ply", big + TET_PLY_BODY, &["too large"]);
}

#[test]
fn ply_counts_must_fit_the_bytes_each_element_needs() {
    // 4 binary float vertices need 48 bytes; the file holds fewer, although the count (4) is
    // far below the file size the old check compared with.
    let d = Dir::new("i14b");
    let mut b = ply_header("binary_little_endian", "400", "0").into_bytes();
    b.extend([0u8; 100]);
    expect_err(
        &d,
        "s.ply",
        b,
        &["element `vertex` count 400", "at least 12 bytes"],
    );
}

#[test]
fn ascii_ply_with_more_faces_than_declared_is_refused() {
    let d = Dir::new("i15a");
    // 4 faces declared, 8 present: the second half used to be dropped silently.
    let body = TET_PLY_BODY.to_string() + "3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";
    expect_err(
        &d,
        "f.ply",
        ply_header("ascii", "4", "4") + &body,
        &["follow the last element", "4 face"],
    );
    // Trailing blank lines are fine.
    assert!(load_mesh(&d.write(
        "ok.ply",
        ply_header("ascii", "4", "4") + TET_PLY_BODY + "\n\n"
    ))
    .is_ok());
}

#[test]
fn binary_stl_holding_more_triangles_than_its_count_is_refused() {
    let d = Dir::new("i15b");
    const TRI: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    let tris = [TRI; 24];
    expect_err(
        &d,
        "m.stl",
        stl_binary(&tris, 12),
        &[
            "says 12 triangles",
            "room for 24 triangles",
            "count is wrong",
        ],
    );
    expect_err(
        &d,
        "t.stl",
        stl_binary(&tris[..6], 12),
        &["says 12", "truncated"],
    );
}

#[test]
fn obj_texture_and_normal_index_errors_name_the_line() {
    let d = Dir::new("i17a");
    let base = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvt 0 0\nvn 0 0 1\n";
    expect_err(
        &d,
        "t.obj",
        format!("{base}f 1/1 2/1 3/1\nf 1/9 2/1 4/1\n"),
        &["line 8", "texture coordinate (vt) 9", "only 1"],
    );
    expect_err(
        &d,
        "n.obj",
        format!("{base}f 1//1 2//1 3//5\n"),
        &["line 7", "normal (vn) 5"],
    );
    expect_err(
        &d,
        "x.obj",
        format!("{base}f 1/a 2/1 3/1\n"),
        &["line 7", "`a`"],
    );
    // Valid references load.
    let ok = format!("{base}f 1/1/1 3/1/1 2/1/1\nf 1/1/1 2/1/1 4/1/1\nf 1/1/1 4/1/1 3/1/1\nf 2/1/1 3/1/1 4/1/1\n");
    assert!(load_mesh(&d.write("ok.obj", ok)).is_ok());
}

#[test]
fn utf8_bom_does_not_shift_obj_line_numbers() {
    let d = Dir::new("i17b");
    let text = format!("\u{feff}{TET_OBJ}f 1 2 99\n");
    expect_err(&d, "bom.obj", text, &["line 9:", "vertex 99"]);
    // And a BOM'd valid file loads with all four vertices.
    let l = load_mesh(&d.write("ok.obj", format!("\u{feff}{TET_OBJ}"))).unwrap();
    assert_eq!(l.mesh.vertices.len(), 4);
}

#[cfg(unix)]
#[test]
fn dev_zero_and_directories_are_refused_not_read() {
    let e = load_mesh(Path::new("/dev/zero.obj"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("/dev/zero.obj"), "{e}");
    // The device itself, through a symlink with a mesh extension.
    let d = Dir::new("i17c");
    let link = d.0.join("zero.stl");
    std::os::unix::fs::symlink("/dev/zero", &link).unwrap();
    let e = load_mesh(&link).unwrap_err().to_string();
    assert!(
        e.contains("zero.stl") && e.contains("not a regular file"),
        "{e}"
    );
    let e = load_mesh(&d.0).unwrap_err().to_string();
    assert!(e.contains("directory"), "{e}");
}
