//! Helpers shared by the command-line tests: running the binary, the one-line error check, a
//! snapshot of a folder, and small input files.
#![allow(dead_code)]

use std::path::Path;
use std::process::{Command, Output};

/// Runs the `haptic6d` binary with `args`.
pub fn haptic6d(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_haptic6d"))
        .args(args)
        .output()
        .expect("the haptic6d binary runs")
}

/// Asserts a failure with exactly one non-empty line on stderr (warnings aside) and no panic;
/// returns the line.
#[track_caller]
pub fn one_line_failure(o: &Output) -> String {
    assert!(
        !o.status.success(),
        "expected failure, stdout: {}",
        String::from_utf8_lossy(&o.stdout)
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!err.contains("panicked"), "{err}");
    let lines: Vec<&str> = err
        .lines()
        .filter(|l| !l.trim().is_empty() && !l.starts_with("warning:"))
        .collect();
    assert_eq!(lines.len(), 1, "expected one line on stderr, got: {err}");
    lines[0].to_string()
}

/// Every file under `dir` (relative path, contents), sorted.
pub fn snapshot(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                let rel = p.strip_prefix(dir).unwrap().display().to_string();
                out.push((rel, std::fs::read(&p).unwrap()));
            }
        }
    }
    out.sort();
    out
}

/// A closed unit cube (quads) as OBJ text.
pub const CUBE_OBJ: &str =
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 0 0 1\nv 1 0 1\nv 0 1 1\nv 1 1 1\n\
f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n";

/// A 2-level tree (root + 2 used children) in the `.sph` format.
pub const SMALL_SPH: &str = "2 2\n0 0 0 2 1\n-1 0 0 1 1\n1 0 0 1 1\n";
