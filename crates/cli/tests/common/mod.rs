//! Helpers shared by the command-line tests: running the binary, the one-line error check, a
//! snapshot of a folder, and small input files.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A fresh temporary folder for one test (named after the test binary and `tag`), removed
/// when dropped.
pub struct Dir(pub PathBuf);

impl Dir {
    /// An empty folder `haptic6d-<binary>-<tag>-<pid>` in the system's temporary directory.
    pub fn new(tag: &str) -> Self {
        let bin = std::env::current_exe()
            .ok()
            .and_then(|p| p.file_stem().map(|s| s.to_string_lossy().into_owned()))
            .unwrap_or_default();
        let d = std::env::temp_dir().join(format!("haptic6d-{bin}-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        Dir(d)
    }

    /// The path of `name` inside the folder, as a string.
    pub fn path(&self, name: &str) -> String {
        self.0.join(name).display().to_string()
    }

    /// Writes `bytes` to `name` (creating its folders); returns its path.
    pub fn write(&self, name: &str, bytes: impl AsRef<[u8]>) -> String {
        let p = self.0.join(name);
        if let Some(parent) = p.parent() {
            std::fs::create_dir_all(parent).unwrap();
        }
        std::fs::write(&p, bytes).unwrap();
        p.display().to_string()
    }

    /// Names in the folder itself (not recursive), sorted.
    pub fn names(&self) -> Vec<String> {
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

/// A closed axis-aligned cube of half-size `h` as OBJ text (mm), counter-clockwise from
/// outside.
pub fn box_obj(h: f64) -> String {
    let mut s = String::new();
    for i in 0..8 {
        let x = if i & 1 == 0 { -h } else { h };
        let y = if i & 2 == 0 { -h } else { h };
        let z = if i & 4 == 0 { -h } else { h };
        s += &format!("v {x} {y} {z}\n");
    }
    for f in [
        [1, 3, 4, 2],
        [5, 6, 8, 7],
        [1, 2, 6, 5],
        [3, 7, 8, 4],
        [1, 5, 7, 3],
        [2, 4, 8, 6],
    ] {
        s += &format!(
            "f {} {} {}\nf {} {} {}\n",
            f[0], f[1], f[2], f[0], f[2], f[3]
        );
    }
    s
}

/// Runs the `haptic6d` binary with `args`.
pub fn haptic6d(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_haptic6d"))
        .args(args)
        .output()
        .expect("the haptic6d binary runs")
}

/// Runs `haptic6d args` with the environment variables `env` set, in the folder `cwd` if given.
pub fn haptic6d_env(args: &[&str], env: &[(&str, &str)], cwd: Option<&Path>) -> Output {
    let mut c = Command::new(env!("CARGO_BIN_EXE_haptic6d"));
    c.args(args);
    if let Some(cwd) = cwd {
        c.current_dir(cwd);
    }
    for (k, v) in env {
        c.env(k, v);
    }
    c.output().expect("the haptic6d binary runs")
}

/// Asserts that the command succeeded, showing its stderr if not.
#[track_caller]
pub fn success(o: &Output) {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
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
