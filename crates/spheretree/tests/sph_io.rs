//! `.sph` reader/writer: round trips, malformed input, atomic writes, and every file the
//! Bradshaw toolkit produced for the bunny (`assets/peers/bradshaw/`).

use std::path::{Path, PathBuf};

use spheretree::sph::{
    bbox_centre, parse_sph, read_sph, to_sph_string, translate_tree, write_sph, SphError,
};
use spheretree::{Sphere, SphereTree};

/// A small deterministic tree with unused slots and awkward values (tiny, huge, negative).
fn sample_tree() -> SphereTree {
    let mut t = SphereTree::new_unused(3, 3).unwrap();
    let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut next = || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        (x >> 11) as f64 / (1u64 << 53) as f64
    };
    let n = t.len();
    for i in 0..n {
        if i % 4 == 3 {
            continue; // leave some unused
        }
        let c = [next() * 2.0 - 1.0, next() * 1e-7, -next() * 1e5];
        t.spheres_mut()[i] = Sphere::new(c, next() + 1e-12);
    }
    // Unused slots under used parents and a used slot under an unused parent both survive.
    t
}

fn temp_dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("haptic6d-sph-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn round_trip_is_exact() {
    let t = sample_tree();
    let text = to_sph_string(&t).unwrap();
    let back = parse_sph(&text, "mem").unwrap();
    assert_eq!(back, t);

    let dir = temp_dir("rt");
    let path = dir.join("tree.sph");
    write_sph(&t, &path).unwrap();
    assert_eq!(read_sph(&path).unwrap(), t);
    // Overwriting an existing file works and leaves no temporary file behind.
    write_sph(&t, &path).unwrap();
    let names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, vec![std::ffi::OsString::from("tree.sph")]);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn failed_write_keeps_the_old_file() {
    let dir = temp_dir("keep");
    let path = dir.join("tree.sph");
    std::fs::write(&path, "old contents").unwrap();
    let mut bad = sample_tree();
    bad.spheres_mut()[0].radius = 0.0; // unwritable
    let e = write_sph(&bad, &path).unwrap_err();
    assert!(matches!(e, SphError::Unwritable { slot: 0, .. }), "{e}");
    assert_eq!(std::fs::read_to_string(&path).unwrap(), "old contents");
    // A target in a missing directory fails cleanly too.
    let e = write_sph(&sample_tree(), &dir.join("missing/tree.sph")).unwrap_err();
    assert!(matches!(e, SphError::Write { .. }), "{e}");
    assert!(e.to_string().contains("missing"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[track_caller]
fn parse_err(text: &str) -> String {
    match parse_sph(text, "bad.sph") {
        Ok(t) => panic!("expected an error, parsed {} slots", t.len()),
        Err(e) => {
            let msg = e.to_string();
            assert!(msg.starts_with("bad.sph:"), "{msg}");
            assert!(!msg.contains('\n'), "one line: {msg}");
            msg
        }
    }
}

#[test]
fn malformed_files_name_file_and_line() {
    assert!(parse_err("").contains("empty file"));
    assert!(parse_err("5\n").contains("bad header"));
    assert!(parse_err("x 8\n").contains("bad header"));
    assert!(parse_err("0 8\n").contains("bad tree shape"));
    assert!(parse_err("2 1\n").contains("bad tree shape"));
    assert!(parse_err("40 8\n").contains("too large"));
    // Truncated: 3 slots needed, 2 given; the error points at the last line read.
    let m = parse_err("2 2\n0 0 0 1\n0 0 0 1\n");
    assert!(
        m.starts_with("bad.sph:3:") && m.contains("2 of 3 slots"),
        "{m}"
    );
    // Wrong number of fields on line 3.
    let m = parse_err("2 2\n0 0 0 1\n0 0 1\n0 0 0 1\n");
    assert!(m.starts_with("bad.sph:3:") && m.contains("found 3"), "{m}");
    let m = parse_err("2 2\n0 0 0 1\n0 0 0 1 1 1 1\n0 0 0 1\n");
    assert!(m.contains("found 7"), "{m}");
    let m = parse_err("1 2\n0 0 0 1 1 1 1 1 1 1 1 1\n");
    assert!(m.contains("more than 10"), "{m}");
    // Not numbers, not finite.
    let m = parse_err("1 2\n0 0 zero 1\n");
    assert!(m.starts_with("bad.sph:2:") && m.contains("`zero`"), "{m}");
    let m = parse_err("1 2\n0 NaN 0 1\n");
    assert!(m.contains("finite"), "{m}");
    let m = parse_err("1 2\n0 0 0 inf\n");
    assert!(m.contains("finite"), "{m}");
}

#[test]
fn missing_file_names_the_path() {
    let e = read_sph(Path::new("/nonexistent/dir/tree.sph")).unwrap_err();
    assert!(e.to_string().contains("/nonexistent/dir/tree.sph"), "{e}");
}

#[test]
fn translate_moves_used_spheres_only() {
    let mut t = sample_tree();
    let orig = t.clone();
    let c = bbox_centre([-1.0, 0.0, 2.0], [3.0, 4.0, 4.0]);
    assert_eq!(c, [1.0, 2.0, 3.0]);
    translate_tree(&mut t, c);
    for (a, b) in t.spheres().iter().zip(orig.spheres()) {
        if b.is_used() {
            for ((&after, &before), &shift) in a.center.iter().zip(&b.center).zip(&c) {
                assert!((after - before - shift).abs() <= 1e-9 * (1.0 + before.abs()));
            }
            assert_eq!(a.radius, b.radius);
        } else {
            assert_eq!(a, b);
        }
    }
}

/// The toolkit's files, in the repository (`assets/peers/bradshaw/`).
fn bradshaw_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/peers/bradshaw")
}

/// The five files the toolkit built for the bunny; a missing one fails the test.
const BRADSHAW_FILES: [&str; 5] = [
    "bunny-grid-d3.sph",
    "bunny-grid-d4-guarded.sph",
    "bunny-hubbard.sph",
    "bunny-medial-d3.sph",
    "bunny-octree.sph",
];

#[test]
fn reads_every_bradshaw_file() {
    let dir = bradshaw_dir();
    for path in BRADSHAW_FILES.map(|f| dir.join(f)) {
        let path = &path;
        let text = std::fs::read_to_string(path)
            .unwrap_or_else(|e| panic!("{}: {e} (part of the repository)", path.display()));
        let first = text.lines().next().unwrap();
        let t = read_sph(path).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(format!("{} {}", t.levels(), t.branching()), first.trim());
        assert_eq!(t.branching(), 8);
        assert!(t.sphere(0).is_used(), "{}: unused root", path.display());
        // Each used slot's line in the file has r > 0; count them independently of the reader.
        let used_in_file = text
            .lines()
            .skip(1)
            .take(t.len())
            .filter(|l| {
                l.split_whitespace()
                    .nth(3)
                    .and_then(|r| r.parse::<f64>().ok())
                    .is_some_and(|r| r > 0.0)
            })
            .count();
        let used = t.spheres().iter().filter(|s| s.is_used()).count();
        assert_eq!(used, used_in_file, "{}", path.display());

        // Structure: every used slot has a used parent?
        let orphans = (1..t.len())
            .filter(|&n| t.sphere(n).is_used() && !t.sphere(t.parent(n).unwrap()).is_used())
            .count();
        // Containment: the toolkit does not keep it; count the children poking out, then repair.
        let poking = (1..t.len())
            .filter(|&n| {
                let (c, p) = (t.sphere(n), t.sphere(t.parent(n).unwrap()));
                let d = (0..3)
                    .map(|k| (c.center[k] - p.center[k]).powi(2))
                    .sum::<f64>()
                    .sqrt();
                c.is_used() && p.is_used() && d + c.radius > p.radius * (1.0 + 1e-9)
            })
            .count();
        let mut fixed = t.clone();
        let growth = fixed.enforce_containment();
        let root_r = t.sphere(0).radius;
        let leaves = (0..t.levels())
            .map(|l| t.used_on_level(l).to_string())
            .collect::<Vec<_>>()
            .join("/");
        eprintln!(
            "{}: levels {}, used per level {leaves}, orphans {orphans}, children poking out of their parent {poking}, \
             largest radius growth to enforce containment {growth:.4} ({:.2} % of the root radius)",
            path.file_name().unwrap().to_string_lossy(),
            t.levels(),
            100.0 * growth / root_r
        );
        if orphans == 0 {
            fixed
                .validate(1e-9 * root_r)
                .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        }
        // Writing and reading back keeps the tree.
        let back = parse_sph(&to_sph_string(&t).unwrap(), "rt").unwrap();
        assert_eq!(back, t);
    }
}
