//! Fuzzing the mesh loader (OBJ, STL ASCII/binary, PLY ASCII/binary LE/BE) with proptest:
//! random bytes, and structured mutations of valid files (truncation, byte flips, inserted
//! garbage, numbers replaced by NaN / inf / huge / negative / non-numbers, lines deleted or
//! duplicated). The property, for every input: `load_mesh_bytes` returns (no panic, no hang),
//! an error is one line naming the file, and a mesh it accepts is valid (finite vertices,
//! indices in range, at least one triangle).
//!
//! Cases per property: 256 by default (a few seconds in CI); `FUZZ_CASES=200000` runs longer.

use std::path::Path;

use mesh::{load_mesh_bytes, LoadedMesh, MeshError};
use proptest::prelude::*;
use proptest::test_runner::Config;

fn cases() -> u32 {
    std::env::var("FUZZ_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(256)
}

fn config() -> Config {
    Config {
        cases: cases(),
        failure_persistence: None,
        ..Config::default()
    }
}

// ---------------------------------------------------------------------------------------------
// Valid seeds: a tetrahedron and a cube in every format.

fn tet() -> (Vec<[f64; 3]>, Vec<Vec<u32>>) {
    (
        vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ],
        vec![vec![0, 2, 1], vec![0, 1, 3], vec![0, 3, 2], vec![1, 2, 3]],
    )
}

fn cube() -> (Vec<[f64; 3]>, Vec<Vec<u32>>) {
    let v = (0..8)
        .map(|i| [(i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64])
        .collect();
    let f = vec![
        vec![0, 2, 3, 1],
        vec![4, 5, 7, 6],
        vec![0, 1, 5, 4],
        vec![2, 6, 7, 3],
        vec![0, 4, 6, 2],
        vec![1, 3, 7, 5],
    ];
    (v, f)
}

fn obj(v: &[[f64; 3]], f: &[Vec<u32>]) -> Vec<u8> {
    let mut s = String::from("# seed\no body\n");
    for p in v {
        s += &format!("v {} {} {}\n", p[0], p[1], p[2]);
    }
    for face in f {
        s += "f";
        for i in face {
            s += &format!(" {}", i + 1);
        }
        s += "\n";
    }
    s.into_bytes()
}

fn soup(v: &[[f64; 3]], f: &[Vec<u32>]) -> Vec<[[f64; 3]; 3]> {
    f.iter()
        .flat_map(|face| {
            (1..face.len() - 1).map(move |k| {
                [
                    v[face[0] as usize],
                    v[face[k] as usize],
                    v[face[k + 1] as usize],
                ]
            })
        })
        .collect()
}

fn stl_ascii(v: &[[f64; 3]], f: &[Vec<u32>]) -> Vec<u8> {
    let mut s = String::from("solid seed\n");
    for t in soup(v, f) {
        s += "facet normal 0 0 0\nouter loop\n";
        for p in t {
            s += &format!("vertex {} {} {}\n", p[0], p[1], p[2]);
        }
        s += "endloop\nendfacet\n";
    }
    (s + "endsolid seed\n").into_bytes()
}

fn stl_binary(v: &[[f64; 3]], f: &[Vec<u32>]) -> Vec<u8> {
    let tris = soup(v, f);
    let mut b = vec![0u8; 80];
    b.extend((tris.len() as u32).to_le_bytes());
    for t in tris {
        b.extend([0u8; 12]);
        for p in t {
            for c in p {
                b.extend((c as f32).to_le_bytes());
            }
        }
        b.extend([0u8; 2]);
    }
    b
}

fn ply_header(enc: &str, nv: usize, nf: usize) -> String {
    format!(
        "ply\nformat {enc} 1.0\nelement vertex {nv}\nproperty float x\nproperty float y\nproperty float z\nelement face {nf}\nproperty list uchar int vertex_indices\nend_header\n"
    )
}

fn ply_ascii(v: &[[f64; 3]], f: &[Vec<u32>]) -> Vec<u8> {
    let mut s = ply_header("ascii", v.len(), f.len());
    for p in v {
        s += &format!("{} {} {}\n", p[0], p[1], p[2]);
    }
    for face in f {
        s += &face.len().to_string();
        for i in face {
            s += &format!(" {i}");
        }
        s += "\n";
    }
    s.into_bytes()
}

fn ply_binary(v: &[[f64; 3]], f: &[Vec<u32>], big: bool) -> Vec<u8> {
    let enc = if big {
        "binary_big_endian"
    } else {
        "binary_little_endian"
    };
    let mut b = ply_header(enc, v.len(), f.len()).into_bytes();
    for p in v {
        for c in p {
            let c = *c as f32;
            b.extend(if big {
                c.to_be_bytes()
            } else {
                c.to_le_bytes()
            });
        }
    }
    for face in f {
        b.push(face.len() as u8);
        for &i in face {
            let i = i as i32;
            b.extend(if big {
                i.to_be_bytes()
            } else {
                i.to_le_bytes()
            });
        }
    }
    b
}

/// Every seed file: (file name, bytes).
fn seeds() -> Vec<(&'static str, Vec<u8>)> {
    let mut out = Vec::new();
    for (tag, (v, f)) in [("tet", tet()), ("cube", cube())] {
        let leak = |s: String| -> &'static str { Box::leak(s.into_boxed_str()) };
        out.push((leak(format!("{tag}.obj")), obj(&v, &f)));
        out.push((leak(format!("{tag}.stl")), stl_ascii(&v, &f)));
        out.push((leak(format!("{tag}_bin.stl")), stl_binary(&v, &f)));
        out.push((leak(format!("{tag}.ply")), ply_ascii(&v, &f)));
        out.push((leak(format!("{tag}_le.ply")), ply_binary(&v, &f, false)));
        out.push((leak(format!("{tag}_be.ply")), ply_binary(&v, &f, true)));
    }
    out
}

// ---------------------------------------------------------------------------------------------
// The property.

/// Loads `bytes` as `name` and checks the contract; returns the outcome for further checks.
fn check(name: &str, bytes: &[u8]) -> Result<Option<LoadedMesh>, TestCaseError> {
    match load_mesh_bytes(bytes, Path::new(name)) {
        Ok(l) => {
            let m = &l.mesh;
            prop_assert!(!m.triangles.is_empty(), "{name}: accepted with no triangle");
            prop_assert!(
                m.vertices.iter().flatten().all(|c| c.is_finite()),
                "{name}: accepted a non-finite vertex"
            );
            prop_assert!(
                m.triangles
                    .iter()
                    .flatten()
                    .all(|&i| (i as usize) < m.vertices.len()),
                "{name}: index out of range"
            );
            Ok(Some(l))
        }
        Err(e) => {
            check_error(name, &e)?;
            Ok(None)
        }
    }
}

fn check_error(name: &str, e: &MeshError) -> Result<(), TestCaseError> {
    let msg = e.to_string();
    prop_assert!(!msg.contains('\n'), "multi-line error: {msg:?}");
    prop_assert!(
        msg.contains(name),
        "error does not name the file {name}: {msg}"
    );
    Ok(())
}

/// A structured mutation of a valid file.
#[derive(Clone, Debug)]
enum Mutation {
    /// Keep only the first `frac` of the bytes.
    Truncate(f64),
    /// XOR one byte.
    Flip(f64, u8),
    /// Insert bytes at a position.
    Insert(f64, Vec<u8>),
    /// Replace the `k`-th whitespace-separated token with a replacement.
    Token(f64, &'static str),
    /// Delete the line containing the position.
    DeleteLine(f64),
    /// Duplicate the line containing the position.
    DuplicateLine(f64),
    /// Overwrite 4 bytes (binary counts, floats) at a position with a value.
    Word(f64, u32),
}

const TOKENS: &[&str] = &[
    "nan",
    "NaN",
    "inf",
    "-inf",
    "1e308",
    "-1e308",
    "1e39",
    "4294967295",
    "4294967296",
    "18446744073709551616",
    "99999999999",
    "-1",
    "0",
    "-2147483648",
    "x",
    "",
    "1.5",
    "0x10",
    "3 3 3",
    "\u{0}",
    "é",
    "list",
    "property",
    "element",
    "end_header",
    "endsolid",
    "facet",
    "vertex",
];

fn mutation() -> impl Strategy<Value = Mutation> {
    let pos = 0.0..1.0f64;
    prop_oneof![
        pos.clone().prop_map(Mutation::Truncate),
        (pos.clone(), 1u8..=255).prop_map(|(p, b)| Mutation::Flip(p, b)),
        (pos.clone(), prop::collection::vec(any::<u8>(), 1..16))
            .prop_map(|(p, b)| Mutation::Insert(p, b)),
        (pos.clone(), prop::sample::select(TOKENS)).prop_map(|(p, t)| Mutation::Token(p, t)),
        pos.clone().prop_map(Mutation::DeleteLine),
        pos.clone().prop_map(Mutation::DuplicateLine),
        (
            pos,
            prop_oneof![
                Just(u32::MAX),
                Just(0x7fc0_0000),
                Just(0x7f80_0000),
                Just(0x8000_0000),
                any::<u32>()
            ]
        )
            .prop_map(|(p, w)| Mutation::Word(p, w)),
    ]
}

fn at(frac: f64, len: usize) -> usize {
    ((frac * len as f64) as usize).min(len)
}

fn line_bounds(b: &[u8], i: usize) -> (usize, usize) {
    let i = i.min(b.len());
    let start = b[..i]
        .iter()
        .rposition(|&c| c == b'\n')
        .map_or(0, |p| p + 1);
    let end = b[i..]
        .iter()
        .position(|&c| c == b'\n')
        .map_or(b.len(), |p| i + p + 1);
    (start, end)
}

fn apply(mut b: Vec<u8>, m: &Mutation) -> Vec<u8> {
    let n = b.len();
    match m {
        Mutation::Truncate(f) => b.truncate(at(*f, n)),
        Mutation::Flip(f, x) => {
            if n > 0 {
                let i = at(*f, n - 1);
                b[i] ^= x;
            }
        }
        Mutation::Insert(f, bytes) => {
            let i = at(*f, n);
            b.splice(i..i, bytes.iter().copied());
        }
        Mutation::Token(f, t) => {
            // Token boundaries: maximal runs of non-whitespace bytes.
            let starts: Vec<usize> = (0..n)
                .filter(|&i| {
                    !b[i].is_ascii_whitespace() && (i == 0 || b[i - 1].is_ascii_whitespace())
                })
                .collect();
            if !starts.is_empty() {
                let s = starts[at(*f, starts.len() - 1)];
                let e = (s..n).find(|&i| b[i].is_ascii_whitespace()).unwrap_or(n);
                b.splice(s..e, t.bytes());
            }
        }
        Mutation::DeleteLine(f) => {
            let (s, e) = line_bounds(&b, at(*f, n));
            b.drain(s..e);
        }
        Mutation::DuplicateLine(f) => {
            let (s, e) = line_bounds(&b, at(*f, n));
            let line = b[s..e].to_vec();
            b.splice(e..e, line);
        }
        Mutation::Word(f, w) => {
            if n >= 4 {
                let i = at(*f, n - 4);
                b[i..i + 4].copy_from_slice(&w.to_le_bytes());
            }
        }
    }
    b
}

#[test]
fn seeds_are_valid() {
    for (name, bytes) in seeds() {
        let l = load_mesh_bytes(&bytes, Path::new(name)).unwrap_or_else(|e| panic!("{e}"));
        assert!(l.mesh.triangles.len() >= 4, "{name}");
    }
}

proptest! {
    #![proptest_config(config())]

    /// Random bytes under every extension (and none: the format is sniffed).
    #[test]
    fn random_bytes_never_panic(
        bytes in prop::collection::vec(any::<u8>(), 0..512),
        ext in prop::sample::select(&["a.obj", "a.stl", "a.ply", "a.bin", "noext"][..]),
    ) {
        check(ext, &bytes)?;
    }

    /// Random bytes after a valid-looking header, so the parsers get past the magic.
    #[test]
    fn garbage_after_header_never_panics(
        head in prop::sample::select(&[
            "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n",
            "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n",
            "ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty double x\nproperty double y\nproperty double z\nelement face 1\nproperty list int uint vertex_index\nend_header\n",
            "solid x\nfacet normal 0 0 0\nouter loop\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf ",
        ][..]),
        tail in prop::collection::vec(any::<u8>(), 0..256),
    ) {
        let mut bytes = head.as_bytes().to_vec();
        bytes.extend(tail);
        let name = if head.starts_with("ply") { "g.ply" } else if head.starts_with("solid") { "g.stl" } else { "g.obj" };
        check(name, &bytes)?;
    }

    /// One to three structured mutations of a valid file in every format.
    #[test]
    fn mutated_valid_files_never_panic(
        seed in 0usize..12,
        muts in prop::collection::vec(mutation(), 1..4),
    ) {
        let (name, bytes) = seeds().swap_remove(seed);
        let bytes = muts.iter().fold(bytes, apply);
        check(name, &bytes)?;
    }
}
