//! The Bradshaw `.sph` format (Sphere-Tree Construction Toolkit), read and write.
//!
//! Entry points:
//! - [`read_sph`] / [`parse_sph`]: a file / a string to a [`SphereTree`].
//! - [`write_sph`] (atomic: temp file beside the target, then rename) / [`to_sph_string`].
//! - [`translate_tree`] and [`bbox_centre`]: move a tree between the mesh's own frame and the
//!   toolkit's frame (the toolkit centres its output on the mesh's bounding-box centre).
//!
//! # Format
//! ```text
//! levels branching
//! x y z r [occupancy]                        one line per slot, breadth-first
//! x y z r [occupancy] ax ay az ar [errdec]   a line may carry an auxiliary sphere
//! ...
//! Options :                                  optional trailer, ignored
//! ```
//! The first line holds the number of levels (`depth + 1`) and the branching `B`; then come
//! exactly `sum_{l < levels} B^l` slot lines in the breadth-first order of [`SphereTree`].
//! A slot line holds 4, 5, 9 or 10 numbers; the first four are the sphere (centre, radius, in
//! the file's units), the rest (occupancy, auxiliary sphere, error decrease) are read and
//! ignored. A radius `<= 0` marks an unused slot. Blank lines between slots are skipped, and
//! everything after the last slot (the toolkit's `Options :` and `Evaluation :` blocks, sample
//! counts, ...) is ignored.
//!
//! The writer emits `x y z r 1` per used slot and `0 0 0 -1 1` per unused one, with the
//! shortest decimal form that reads back to the same `f64`, so a write/read round trip is exact.
//!
//! ```
//! use spheretree::sph::{parse_sph, to_sph_string, translate_tree};
//!
//! // A root and two of its eight children, the rest unused, as the toolkit would write it
//! // (centred on the mesh's bounding-box centre, here (10, 0, 0)).
//! let text = "2 8\n0 0 0 2 1\n-1 0 0 1 1\n1 0 0 1 1\n".to_string()
//!     + &"0 0 0 -1 1\n".repeat(6)
//!     + "Options :\n\tdepth : 1\n";
//! let mut tree = parse_sph(&text, "example.sph")?;
//! assert_eq!((tree.levels(), tree.branching(), tree.used_on_level(1)), (2, 8, 2));
//! translate_tree(&mut tree, [10.0, 0.0, 0.0]); // back to the mesh's own frame
//! assert_eq!(tree.sphere(1).center, [9.0, 0.0, 0.0]);
//! assert_eq!(parse_sph(&to_sph_string(&tree)?, "round trip")?, tree);
//! # Ok::<(), spheretree::sph::SphError>(())
//! ```
//!
//! Files written by the toolkit do **not** keep the bounding rule of this crate (a parent
//! need not contain its children); call [`SphereTree::enforce_containment`] on a tree read
//! from such a file before using it for pruning.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use crate::{slot_count, Sphere, SphereTree};

/// Errors of `.sph` reading and writing. Each message names the file (and line) and says
/// what to fix.
#[derive(Debug, thiserror::Error)]
pub enum SphError {
    /// The file could not be read.
    #[error("cannot read sphere-tree file {path}: {error}")]
    Read {
        /// The file.
        path: PathBuf,
        /// The OS error (part of the message, not a separate source).
        error: std::io::Error,
    },
    /// The text is not a valid `.sph` file.
    #[error("{source_name}:{line}: {message}")]
    Parse {
        /// The file name (or another label given to [`parse_sph`]).
        source_name: String,
        /// 1-based line number.
        line: usize,
        /// What is wrong and how to fix it.
        message: String,
    },
    /// The file could not be written; an existing file at the path is left untouched.
    #[error(
        "cannot write sphere-tree file {path}: {error} (any existing file there is unchanged)"
    )]
    Write {
        /// The target file.
        path: PathBuf,
        /// The OS error (part of the message, not a separate source).
        error: std::io::Error,
    },
    /// The tree cannot be written faithfully.
    #[error("cannot write slot {slot}: {message}")]
    Unwritable {
        /// The slot index (breadth-first).
        slot: usize,
        /// What is wrong and how to fix it.
        message: String,
    },
}

/// Largest `.sph` file read, bytes (256 MiB: far beyond a depth-7 tree).
pub const MAX_SPH_BYTES: u64 = 256 << 20;

/// Reads a `.sph` file (see the module docs for the format). Errors name the file and line.
pub fn read_sph(path: &Path) -> Result<SphereTree, SphError> {
    // Bounded read: a device node or a huge file is refused, not read until memory runs out.
    let bytes = mesh::read_input(path, MAX_SPH_BYTES).map_err(|error| SphError::Read {
        path: path.to_path_buf(),
        error,
    })?;
    // The toolkit's trailer is free text; do not fail on stray non-UTF-8 bytes there.
    let text = String::from_utf8_lossy(&bytes);
    parse_sph(&text, &path.display().to_string())
}

/// Parses the text of a `.sph` file; `source_name` labels error messages (usually the path).
pub fn parse_sph(text: &str, source_name: &str) -> Result<SphereTree, SphError> {
    let err = |line: usize, message: String| SphError::Parse {
        source_name: source_name.to_string(),
        line,
        message,
    };
    // A byte-order mark (as some editors save UTF-8) is not part of the header.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty());

    let Some((hline, header)) = lines.next() else {
        return Err(err(
            1,
            "empty file: expected a first line `levels branching` (e.g. `5 8`)".into(),
        ));
    };
    let fields: Vec<&str> = header.split_whitespace().collect();
    let parse_u32 = |s: &str| s.parse::<u32>().ok();
    let (levels, branching) = match fields.as_slice() {
        [l, b] => match (parse_u32(l), parse_u32(b)) {
            (Some(l), Some(b)) => (l, b),
            _ => {
                return Err(err(
                    hline,
                    format!("bad header `{header}`: expected two whole numbers `levels branching` (e.g. `5 8`)"),
                ))
            }
        },
        _ => {
            return Err(err(
                hline,
                format!(
                    "bad header `{header}`: expected exactly two whole numbers `levels branching` (e.g. `5 8`)"
                ),
            ))
        }
    };
    if levels == 0 || branching < 2 {
        return Err(err(
            hline,
            format!("bad tree shape: levels {levels}, branching {branching} (need levels >= 1 and branching >= 2)"),
        ));
    }
    let n_slots = match slot_count(levels, branching) {
        Some(n) if n <= u32::MAX as usize => n,
        _ => {
            return Err(err(
                hline,
                format!(
                "tree too large: levels {levels}, branching {branching} give more than 2^32 slots"
            ),
            ))
        }
    };

    // Do not trust the header for the allocation: a truncated file with a huge header would
    // otherwise reserve gigabytes before failing.
    let mut spheres = Vec::with_capacity(n_slots.min(1 << 20));
    let mut last_line = hline;
    for (lineno, line) in lines.by_ref() {
        last_line = lineno;
        let mut nums = [0.0f64; 10];
        let mut count = 0usize;
        for tok in line.split_whitespace() {
            if count == nums.len() {
                count += 1;
                break;
            }
            let v: f64 = tok.parse().map_err(|_| {
                err(
                    lineno,
                    format!(
                        "slot {}: `{tok}` is not a number (a slot line is `x y z r [occupancy]`)",
                        spheres.len()
                    ),
                )
            })?;
            if !v.is_finite() {
                return Err(err(
                    lineno,
                    format!("slot {}: `{tok}` is not a finite number", spheres.len()),
                ));
            }
            nums[count] = v;
            count += 1;
        }
        if !matches!(count, 4 | 5 | 9 | 10) {
            let found = if count > nums.len() {
                "more than 10".to_string()
            } else {
                count.to_string()
            };
            return Err(err(
                lineno,
                format!(
                    "slot {}: expected 4, 5, 9 or 10 numbers (`x y z r [occupancy] [aux sphere]`), found {found}",
                    spheres.len()
                ),
            ));
        }
        let r = nums[3];
        spheres.push(if r > 0.0 {
            Sphere::new([nums[0], nums[1], nums[2]], r)
        } else {
            Sphere::UNUSED
        });
        if spheres.len() == n_slots {
            break;
        }
    }
    if spheres.len() < n_slots {
        return Err(err(
            last_line,
            format!(
                "file ends after {} of {n_slots} slots (levels {levels}, branching {branching}); \
                 the file is truncated or its header is wrong",
                spheres.len()
            ),
        ));
    }
    // Everything after the last slot is the toolkit's free-form trailer: ignored.
    SphereTree::from_slots(levels, branching, spheres).map_err(|e| err(hline, e.to_string()))
}

/// The `.sph` text of `tree` (see the module docs). Errors if a used slot has radius 0 (the
/// toolkit would read it as unused) or a non-finite value.
pub fn to_sph_string(tree: &SphereTree) -> Result<String, SphError> {
    let mut out = String::with_capacity(tree.len() * 48 + 16);
    // Writing to a String cannot fail.
    let _ = writeln!(out, "{} {}", tree.levels(), tree.branching());
    for (slot, s) in tree.spheres().iter().enumerate() {
        if !s.is_used() {
            out.push_str("0 0 0 -1 1\n");
            continue;
        }
        if !(s.center.iter().all(|v| v.is_finite()) && s.radius.is_finite()) {
            return Err(SphError::Unwritable {
                slot,
                message: format!(
                    "non-finite sphere {s:?}; fix the builder or mark the slot unused"
                ),
            });
        }
        if s.radius == 0.0 {
            return Err(SphError::Unwritable {
                slot,
                message: "a used sphere of radius 0 would read back as unused; give it a positive radius or mark it unused".into(),
            });
        }
        let [x, y, z] = s.center;
        let _ = writeln!(out, "{x} {y} {z} {} 1", s.radius);
    }
    Ok(out)
}

/// Writes `tree` to `path` in `.sph` format, atomically: the text goes to a temporary file in
/// the same directory, which is then renamed over `path`. On any failure the temporary file is
/// removed and an existing file at `path` is left as it was.
pub fn write_sph(tree: &SphereTree, path: &Path) -> Result<(), SphError> {
    let text = to_sph_string(tree)?;
    mesh::write_atomic(path, text.as_bytes()).map_err(|error| SphError::Write {
        path: path.to_path_buf(),
        error,
    })
}

/// Moves every used sphere of `tree` by `offset` (same units as the tree). Unused slots are
/// left as they are.
///
/// The toolkit writes trees centred on the mesh's bounding-box centre `c`: to bring such a tree
/// into the mesh's own frame, translate by `+c`; to write a tree in the toolkit's frame,
/// translate by `-c` (see [`bbox_centre`]).
pub fn translate_tree(tree: &mut SphereTree, offset: [f64; 3]) {
    for s in tree.spheres_mut() {
        if s.is_used() {
            for (c, o) in s.center.iter_mut().zip(offset) {
                *c += o;
            }
        }
    }
}

/// The centre of the axis-aligned box `(lo, hi)`: the origin of the toolkit's frame when
/// `(lo, hi)` is the mesh's bounding box.
pub fn bbox_centre(lo: [f64; 3], hi: [f64; 3]) -> [f64; 3] {
    [
        0.5 * (lo[0] + hi[0]),
        0.5 * (lo[1] + hi[1]),
        0.5 * (lo[2] + hi[2]),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_minimal_file_with_trailer_and_aux_lines() {
        let text = "2 2\n0 0 0 2 1\n\n-1 0 0 1 1 -1 0 0 1 0.5\n0 0 0 -1\nOptions :\n\tdepth : 1\n";
        let t = parse_sph(text, "mem").unwrap();
        assert_eq!(t.levels(), 2);
        assert_eq!(t.branching(), 2);
        assert_eq!(t.sphere(1).center, [-1.0, 0.0, 0.0]);
        assert!(!t.sphere(2).is_used());
    }

    #[test]
    fn zero_radius_is_unused() {
        let t = parse_sph("1 8\n1 2 3 0\n", "mem").unwrap();
        assert!(!t.sphere(0).is_used());
    }
}
