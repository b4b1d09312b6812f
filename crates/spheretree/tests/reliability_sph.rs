//! Malformed `.sph` files (truncated, wrong counts, NaN/inf, huge values, wrong types, empty,
//! binary garbage): every one gives a one-line `file:line: ...` error and never panics. And
//! `write_sph` never loses what is already on disk: a failed write leaves the old file as it
//! was, and no temporary file is left behind.

use std::path::PathBuf;

use spheretree::sph::{parse_sph, read_sph, write_sph};
use spheretree::{Sphere, SphereTree};

struct Dir(PathBuf);

impl Dir {
    fn new(tag: &str) -> Self {
        let d = std::env::temp_dir().join(format!(
            "haptic6d-reliability-sph-{tag}-{}",
            std::process::id()
        ));
        std::fs::create_dir_all(&d).unwrap();
        Dir(d)
    }
    fn entries(&self) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(&self.0)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }
}

impl Drop for Dir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// A valid 2-level binary tree (3 slots).
const GOOD: &str = "2 2\n0 0 0 2 1\n-1 0 0 1 1\n1 0 0 1 1\n";

/// Parses, expects an error on `line` containing every needle; returns the message.
#[track_caller]
fn expect_err(text: &str, line: usize, needles: &[&str]) -> String {
    let e = match parse_sph(text, "t.sph") {
        Ok(t) => panic!("accepted {text:?} as {t:?}"),
        Err(e) => e.to_string(),
    };
    assert!(!e.contains('\n'), "multi-line: {e:?}");
    assert!(
        e.starts_with(&format!("t.sph:{line}: ")),
        "expected t.sph:{line}: in {e}"
    );
    for n in needles {
        assert!(e.contains(n), "`{n}` not in {e}");
    }
    e
}

#[test]
fn empty_and_whitespace() {
    expect_err("", 1, &["empty"]);
    expect_err("\n\n  \n", 1, &["empty"]);
}

#[test]
fn bad_headers() {
    expect_err("2\n", 1, &["header"]);
    expect_err("2 2 2\n", 1, &["header"]);
    expect_err("two 2\n", 1, &["header"]);
    expect_err("-2 2\n", 1, &["header"]);
    expect_err("2.5 2\n", 1, &["header"]);
    expect_err("0 8\n", 1, &["levels"]);
    expect_err("2 1\n", 1, &["branching"]);
    expect_err("2 0\n", 1, &["branching"]);
    expect_err("99999999999 8\n", 1, &["header"]);
    // Huge shapes are refused before any allocation.
    expect_err("40 8\n", 1, &["too large"]);
    expect_err("4294967295 4294967295\n", 1, &["too large"]);
    expect_err("2 4294967295\n", 1, &["too large"]);
}

#[test]
fn truncated_and_wrong_counts() {
    // One slot missing: the error points at the last line read.
    expect_err("2 2\n0 0 0 2 1\n-1 0 0 1 1\n", 3, &["truncated", "2 of 3"]);
    // Header promising a large tree with a few lines: a quick error, no huge allocation.
    expect_err("10 8\n0 0 0 2 1\n", 2, &["1 of"]);
    // Cut in the middle of a line.
    expect_err("2 2\n0 0 0 2 1\n-1 0 0 1 1\n1 0", 4, &["found 2"]);
    // Wrong number of fields on a slot line.
    expect_err("2 2\n0 0 0 2 1\n-1 0 0\n1 0 0 1 1\n", 3, &["found 3"]);
    expect_err("2 2\n0 0 0 2 1 2 3\n-1 0 0 1\n1 0 0 1\n", 2, &["found 7"]);
    expect_err(
        "2 2\n0 0 0 2 1 1 1 1 1 1 1 1\n-1 0 0 1\n1 0 0 1\n",
        2,
        &["more than 10"],
    );
}

#[test]
fn non_numbers_and_non_finite() {
    for (bad, needle) in [
        ("x", "not a number"),
        ("0x10", "not a number"),
        ("1,5", "not a number"),
        ("nan", "finite"),
        ("NaN", "finite"),
        ("inf", "finite"),
        ("-inf", "finite"),
        ("1e400", "finite"),
    ] {
        let text = GOOD.replace("-1 0 0 1 1", &format!("-1 {bad} 0 1 1"));
        expect_err(&text, 3, &[needle]);
        let text = GOOD.replace("-1 0 0 1 1", &format!("-1 0 0 {bad} 1"));
        expect_err(&text, 3, &[needle]);
    }
}

#[test]
fn binary_garbage() {
    let garbage: Vec<u8> = (0..2048u32)
        .map(|i| (i.wrapping_mul(2_654_435_761) >> 11) as u8)
        .collect();
    let d = Dir::new("garbage");
    let p = d.0.join("g.sph");
    std::fs::write(&p, &garbage).unwrap();
    let e = read_sph(&p).unwrap_err().to_string();
    assert!(
        !e.contains('\n') && e.starts_with(&format!("{}:", p.display())),
        "{e}"
    );
    // A garbage trailer after a complete tree is the toolkit's free text: ignored.
    let mut bytes = GOOD.as_bytes().to_vec();
    bytes.extend(&garbage);
    std::fs::write(&p, &bytes).unwrap();
    assert_eq!(read_sph(&p).unwrap().used_on_level(1), 2);
}

#[test]
fn huge_finite_values_are_kept_exactly() {
    // Finite values are the file's units; the reader keeps them (scenes check their scale).
    let t = parse_sph("1 8\n1e300 -1e300 0 1e300 1\n", "h.sph").unwrap();
    assert_eq!(t.sphere(0).radius, 1e300);
}

#[test]
fn missing_file_is_one_line_naming_it() {
    let e = read_sph(std::path::Path::new("/nonexistent/dir/t.sph"))
        .unwrap_err()
        .to_string();
    assert!(
        !e.contains('\n') && e.contains("/nonexistent/dir/t.sph"),
        "{e}"
    );
}

// ---------------------------------------------------------------------------------------------
// Writing never loses what is on disk.

fn tree() -> SphereTree {
    parse_sph(GOOD, "good").unwrap()
}

#[test]
fn failed_write_keeps_the_existing_file_and_leaves_no_temp() {
    let d = Dir::new("write");
    let target = d.0.join("out.sph");
    write_sph(&tree(), &target).unwrap();
    let before = std::fs::read(&target).unwrap();

    // An unwritable tree (NaN centre): refused before touching the disk.
    let mut bad = tree();
    bad.spheres_mut()[1] = Sphere::new([f64::NAN, 0.0, 0.0], 1.0);
    let e = write_sph(&bad, &target).unwrap_err().to_string();
    assert!(e.contains("slot 1") && !e.contains('\n'), "{e}");
    assert_eq!(std::fs::read(&target).unwrap(), before);

    // A used sphere of radius 0 would read back as unused: refused too.
    let mut zero = tree();
    zero.spheres_mut()[2].radius = 0.0;
    assert!(write_sph(&zero, &target).is_err());
    assert_eq!(std::fs::read(&target).unwrap(), before);

    // The target is a directory: the rename fails, the directory and the old file survive.
    let as_dir = d.0.join("dir.sph");
    std::fs::create_dir(&as_dir).unwrap();
    std::fs::write(as_dir.join("keep"), b"x").unwrap();
    let e = write_sph(&tree(), &as_dir).unwrap_err().to_string();
    assert!(e.contains("unchanged") && !e.contains('\n'), "{e}");
    assert_eq!(std::fs::read(as_dir.join("keep")).unwrap(), b"x");

    // No `.tmp` file left behind by any of the failures.
    assert_eq!(
        d.entries(),
        vec!["dir.sph".to_string(), "out.sph".to_string()]
    );

    // A successful write replaces the file completely (shorter content, no stale tail).
    let small = parse_sph("1 2\n0 0 0 1 1\n", "small").unwrap();
    write_sph(&small, &target).unwrap();
    assert_eq!(read_sph(&target).unwrap(), small);
}

#[test]
fn write_into_a_missing_directory_fails_cleanly() {
    let d = Dir::new("nodir");
    let target = d.0.join("no/such/dir/out.sph");
    let e = write_sph(&tree(), &target).unwrap_err().to_string();
    assert!(!e.contains('\n') && e.contains("out.sph"), "{e}");
    assert!(d.entries().is_empty());
}

#[test]
fn slot_count_of_a_degenerate_branching_is_instant() {
    // `slot_count` is called on untrusted headers (the render cache); with branching 0 or 1
    // it looped `levels` (up to 2^32) times: about a second per call, so these 100 calls took
    // minutes before the fix (a closed form now).
    for _ in 0..100 {
        assert_eq!(spheretree::slot_count(u32::MAX, 1), Some(u32::MAX as usize));
        assert_eq!(spheretree::slot_count(u32::MAX, 0), Some(1));
    }
    assert_eq!(spheretree::slot_count(0, 0), Some(0));
    assert_eq!(spheretree::slot_count(3, 1), Some(3));
    assert_eq!(spheretree::slot_count(3, 2), Some(7));
}
