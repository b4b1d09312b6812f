//! Sphere-trees for the engine: read from `.sph` files, built from meshes (through the tree
//! cache, as scene files do), or built and measured as `haptic6d tree build` and
//! `haptic6d tree eval` do, with the same checks and messages (flags named as keywords).

use std::path::Path;
use std::time::Instant;

use mesh::{load_mesh, InsideTest, LoadedMesh, TriMesh};
use scene::cache::TreeCache;
use scene::TreeParams;
use spheretree::build::{build_tree_with_report, BuildMethod, BuildParams};
use spheretree::eval::{evaluate_fit, FitParams, LevelFit, TOOLKIT_SIZE};
use spheretree::sph::{bbox_centre, read_sph, translate_tree, write_sph};
use spheretree::{slot_count, SphereTree};

use crate::{Failure, FailureKind};

/// Largest tree built (slots), as on the command line: beyond it memory and time explode.
pub const MAX_SLOTS: usize = 1 << 24;

/// Most coverage samples of the fit measure, as on the command line.
pub const MAX_SAMPLES: usize = 10_000_000;

/// Reads a `.sph` tree (mm, as the engine takes it) and makes every parent contain its
/// children (pruning needs it; trees from other tools may not keep the rule).
pub fn read_tree(path: &Path) -> Result<SphereTree, Failure> {
    let mut tree = read_sph(path)?;
    if !tree.spheres().iter().any(|s| s.is_used()) {
        return Err(Failure::value(format!(
            "{}: the tree has no used sphere (every radius is negative)",
            path.display()
        )));
    }
    tree.enforce_containment();
    Ok(tree)
}

/// Writes `tree` as a `.sph` file (atomically: an existing file is replaced only on success).
pub fn save_tree(tree: &SphereTree, path: &Path) -> Result<(), Failure> {
    Ok(write_sph(tree, path)?)
}

/// The tree of a body given by a path: a `.sph` file is read; any other file is loaded as a
/// mesh (OBJ, STL, PLY; mm) and its tree built with the scene files' defaults (depth 4,
/// branching 8, tight) or fetched from `cache`. `label` (`tool`, `object 2`) starts the
/// errors, as in a scene file's.
pub fn tree_for_path(
    path: &Path,
    label: &str,
    cache: &TreeCache,
    log: &mut Vec<String>,
) -> Result<SphereTree, Failure> {
    body_for_path(path, label, cache, log).map(|(tree, _)| tree)
}

/// [`tree_for_path`] with the mesh the tree was built from (`None` for a `.sph` file), for the
/// mesh geometry mode.
pub fn body_for_path(
    path: &Path,
    label: &str,
    cache: &TreeCache,
    log: &mut Vec<String>,
) -> Result<(SphereTree, Option<TriMesh>), Failure> {
    let is_sph = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("sph"));
    let prefix = |f: Failure| Failure {
        kind: f.kind,
        message: format!("{label}: {}", f.message),
    };
    if is_sph {
        let tree = read_tree(path).map_err(prefix)?;
        log.push(format!("{label}: tree read from {}", path.display()));
        return Ok((tree, None));
    }
    let mesh = load_mesh(path).map_err(|e| prefix(e.into()))?.mesh;
    let params = TreeParams {
        depth: 4,
        branching: 8,
        method: BuildMethod::default(),
    };
    let tree =
        scene::tree_for_mesh(&mesh, params, cache, label, log).map_err(|e| prefix(e.into()))?;
    Ok((tree, Some(mesh)))
}

/// Parses an inside-test name: `auto` (`None`: pseudo-normal on a closed mesh, winding number
/// on an open one), `pseudo-normal`, `winding-number`.
pub fn parse_inside(name: &str) -> Result<Option<InsideTest>, Failure> {
    match name.trim().to_ascii_lowercase().as_str() {
        "auto" => Ok(None),
        "pseudo-normal" => Ok(Some(InsideTest::PseudoNormal)),
        "winding-number" => Ok(Some(InsideTest::WindingNumber)),
        _ => Err(Failure::value(format!(
            "inside: unknown inside test `{name}`; expected one of: auto, pseudo-normal, winding-number"
        ))),
    }
}

/// Options of [`build`] (the flags of `haptic6d tree build`).
#[derive(Clone, Debug, PartialEq)]
pub struct BuildOptions {
    /// Depth (levels = depth + 1).
    pub depth: i64,
    /// Branching factor.
    pub branching: i64,
    /// Builder name: `tight` or `octree`.
    pub method: String,
    /// Seed of the builder's random surface samples.
    pub seed: u64,
    /// Inside test name ([`parse_inside`]).
    pub inside: String,
    /// Centre the tree on the mesh's bounding box, as the Sphere-Tree Construction Toolkit.
    pub bradshaw_frame: bool,
}

impl Default for BuildOptions {
    fn default() -> Self {
        Self {
            depth: 4,
            branching: 8,
            method: "tight".into(),
            seed: 1,
            inside: "auto".into(),
            bradshaw_frame: false,
        }
    }
}

/// What [`build`] did besides the tree.
#[derive(Clone, Debug, PartialEq)]
pub struct BuildInfo {
    /// The mesh file.
    pub mesh: String,
    /// Mesh vertices and triangles (after loading: welded, degenerate ones dropped).
    pub vertices: usize,
    /// See `vertices`.
    pub triangles: usize,
    /// Builder name.
    pub method: &'static str,
    /// The inside test the tight builder used (`None` for the octree builder).
    pub inside_test: Option<&'static str>,
    /// Holes closed by fans for the winding-number queries.
    pub holes_closed: usize,
    /// Centre of the mesh's bounding box (mesh units); the tree was shifted by minus this
    /// when built in the toolkit's frame.
    pub bbox_centre: [f64; 3],
    /// Build time, s.
    pub seconds: f64,
}

/// Loads a mesh for the tree tools; errors name the file.
fn load(path: &Path) -> Result<LoadedMesh, Failure> {
    Ok(load_mesh(path)?)
}

/// Checks the build options as `haptic6d tree build` checks its flags, before any work.
pub fn check_build(o: &BuildOptions) -> Result<(u32, u32, BuildMethod), Failure> {
    let branching = u32::try_from(o.branching)
        .ok()
        .filter(|&b| b >= 2)
        .ok_or_else(|| {
            Failure::value(format!(
                "branching={} is too small: use 2 or more (8 is usual)",
                o.branching
            ))
        })?;
    let too_big = || {
        Failure::value(format!(
            "depth={} with branching={} needs more than {MAX_SLOTS} slots: choose a smaller depth or branching",
            o.depth, o.branching
        ))
    };
    let depth = u32::try_from(o.depth).map_err(|_| {
        if o.depth < 0 {
            Failure::value(format!("depth={}: must be 0 or more", o.depth))
        } else {
            too_big()
        }
    })?;
    match slot_count(depth.saturating_add(1), branching) {
        Some(n) if n <= MAX_SLOTS => {}
        _ => return Err(too_big()),
    }
    let method: BuildMethod = o
        .method
        .trim()
        .to_ascii_lowercase()
        .parse()
        .map_err(|e: spheretree::TreeError| Failure::value(format!("method: {e}")))?;
    if method == BuildMethod::Octree && branching < 8 {
        return Err(Failure::value(format!(
            "the octree builder needs branching=8 or more (got {branching}): use method=\"tight\""
        )));
    }
    Ok((depth, branching, method))
}

/// Builds a sphere-tree of the mesh at `path` as `haptic6d tree build` does (in the mesh's
/// own frame and units, or the toolkit's frame with `bradshaw_frame`).
pub fn build(path: &Path, o: &BuildOptions) -> Result<(SphereTree, BuildInfo), Failure> {
    let (depth, branching, method) = check_build(o)?;
    let inside = parse_inside(&o.inside)?;
    let loaded = load(path)?;
    let mesh = &loaded.mesh;
    let params = BuildParams {
        depth,
        branching,
        method,
        seed: o.seed,
        inside,
        ..BuildParams::default()
    };
    let start = Instant::now();
    let (mut tree, report) = build_tree_with_report(mesh, &params, &|_| {}).map_err(|e| {
        let f = Failure::chain(FailureKind::Value, &e);
        Failure::value(format!(
            "building a sphere-tree of {}: {}",
            path.display(),
            f.message
        ))
    })?;
    let seconds = start.elapsed().as_secs_f64();
    let (lo, hi) = mesh
        .aabb()
        .ok_or_else(|| Failure::value(format!("{}: the mesh has no vertices", path.display())))?;
    let centre = bbox_centre(lo, hi);
    if o.bradshaw_frame {
        translate_tree(&mut tree, centre.map(|c| -c));
    }
    let info = BuildInfo {
        mesh: path.display().to_string(),
        vertices: mesh.vertices.len(),
        triangles: mesh.triangles.len(),
        method: method.name(),
        inside_test: report.inside.map(|t| t.name()),
        holes_closed: report.holes_closed,
        bbox_centre: centre,
        seconds,
    };
    Ok((tree, info))
}

/// Options of [`eval`] (the flags of `haptic6d tree eval`).
#[derive(Clone, Debug, PartialEq)]
pub struct EvalOptions {
    /// Random surface samples for the coverage measure.
    pub samples: i64,
    /// Seed of the coverage samples.
    pub seed: u64,
    /// Inside test name ([`parse_inside`]).
    pub inside: String,
    /// The tree is centred on the mesh's bounding box (toolkit files): shift it back first.
    pub centre: bool,
}

impl Default for EvalOptions {
    fn default() -> Self {
        Self {
            samples: 100_000,
            seed: 2026,
            inside: "auto".into(),
            centre: false,
        }
    }
}

/// The fit of a tree to a mesh, per level, in toolkit units (mesh longest side = 2000).
#[derive(Clone, Debug, PartialEq)]
pub struct EvalReport {
    /// Per level, root first.
    pub levels: Vec<LevelFit>,
    /// Mesh vertices and triangles.
    pub vertices: usize,
    /// See `vertices`.
    pub triangles: usize,
    /// The inside test used.
    pub inside_test: &'static str,
    /// Every parent contains its children (within 1e-9 of the toolkit size).
    pub parents_contain_children: bool,
    /// Largest amount a child pokes out of its parent, toolkit units (0 when contained).
    pub max_child_excess: f64,
    /// Measure time, s.
    pub seconds: f64,
}

/// The largest amount by which a child sphere pokes out of its parent, in the tree's units
/// (0 when every parent contains its children).
fn containment_excess(tree: &SphereTree) -> f64 {
    let mut worst: f64 = 0.0;
    for n in 1..tree.len() {
        let Some(p) = tree.parent(n) else { continue };
        let (c, p) = (tree.sphere(n), tree.sphere(p));
        if c.is_used() && p.is_used() {
            let d = (0..3)
                .map(|k| (c.center[k] - p.center[k]).powi(2))
                .sum::<f64>()
                .sqrt();
            worst = worst.max(d + c.radius - p.radius);
        }
    }
    worst
}

/// Checks the measure's options as `haptic6d tree eval` checks its flags, before any work:
/// the sample count and the inside test.
pub fn check_eval(o: &EvalOptions) -> Result<(usize, Option<InsideTest>), Failure> {
    let samples = usize::try_from(o.samples)
        .ok()
        .filter(|s| (1..=MAX_SAMPLES).contains(s))
        .ok_or_else(|| {
            Failure::value(format!(
                "samples={}: must be an integer in 1..={MAX_SAMPLES}",
                o.samples
            ))
        })?;
    Ok((samples, parse_inside(&o.inside)?))
}

/// Measures how tightly `tree` fits the mesh at `path`, as `haptic6d tree eval` does. `label`
/// names the tree in errors.
pub fn eval(
    tree: &SphereTree,
    label: &str,
    path: &Path,
    o: &EvalOptions,
) -> Result<EvalReport, Failure> {
    let (samples, chosen) = check_eval(o)?;
    if !tree.spheres().iter().any(|s| s.is_used()) {
        return Err(Failure::value(format!(
            "{label}: the tree has no used sphere (every radius is negative); nothing to measure"
        )));
    }
    let loaded = load(path)?;
    let mesh = &loaded.mesh;
    let inside = chosen.unwrap_or_else(|| InsideTest::for_mesh(mesh));
    let (lo, hi) = mesh
        .aabb()
        .ok_or_else(|| Failure::value(format!("{}: the mesh has no vertices", path.display())))?;
    let mut tree = tree.clone();
    if o.centre {
        translate_tree(&mut tree, bbox_centre(lo, hi));
    }
    let longest = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
    let to_toolkit = if longest > 0.0 {
        TOOLKIT_SIZE / longest
    } else {
        1.0
    };
    let excess = containment_excess(&tree) * to_toolkit;
    let params = FitParams {
        coverage_samples: samples,
        seed: o.seed,
        inside: Some(inside),
    };
    let start = Instant::now();
    let levels = evaluate_fit(&tree, mesh, &params);
    Ok(EvalReport {
        levels,
        vertices: mesh.vertices.len(),
        triangles: mesh.triangles.len(),
        inside_test: inside.name(),
        parents_contain_children: excess <= 1e-9 * TOOLKIT_SIZE,
        max_child_excess: excess.max(0.0),
        seconds: start.elapsed().as_secs_f64(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn assets() -> std::path::PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets")
    }

    #[test]
    fn build_options_are_checked_as_the_command_line_flags() {
        let bad = |o: BuildOptions| check_build(&o).unwrap_err().message;
        let d = BuildOptions::default;
        assert_eq!(
            bad(BuildOptions {
                branching: 1,
                ..d()
            }),
            "branching=1 is too small: use 2 or more (8 is usual)"
        );
        assert!(bad(BuildOptions { depth: 12, ..d() }).contains("needs more than 16777216 slots"));
        assert!(bad(BuildOptions { depth: -1, ..d() }).starts_with("depth=-1"));
        assert!(bad(BuildOptions {
            method: "fast".into(),
            ..d()
        })
        .contains("unknown build method `fast`"));
        assert!(bad(BuildOptions {
            method: "octree".into(),
            branching: 4,
            ..d()
        })
        .starts_with("the octree builder needs branching=8"));
        assert!(check_build(&d()).is_ok());
    }

    #[test]
    fn a_built_tree_saves_reads_back_and_measures() {
        let mesh = assets().join("bunny.obj");
        let o = BuildOptions {
            depth: 2,
            method: "octree".into(),
            ..Default::default()
        };
        let (tree, info) = build(&mesh, &o).unwrap();
        assert_eq!(tree.levels(), 3);
        assert_eq!(info.method, "octree");
        assert!(info.triangles > 1000);
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("b.sph");
        save_tree(&tree, &p).unwrap();
        let back = read_tree(&p).unwrap();
        assert_eq!(back.levels(), 3);
        let fit = eval(
            &back,
            "b.sph",
            &mesh,
            &EvalOptions {
                samples: 2000,
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!(fit.levels.len(), 3);
        // The octree builder covers the whole surface at every level.
        assert!(fit.levels.iter().all(|l| l.coverage > 0.999), "{fit:?}");
        assert!(fit.parents_contain_children);
    }

    #[test]
    fn missing_files_are_file_errors_naming_the_file() {
        let e = read_tree(Path::new("/nonexistent/t.sph")).unwrap_err();
        assert_eq!(e.kind, FailureKind::File);
        assert!(e.message.contains("/nonexistent/t.sph"), "{}", e.message);
        let e = build(Path::new("/nonexistent/m.obj"), &BuildOptions::default()).unwrap_err();
        assert_eq!(e.kind, FailureKind::File);
        assert!(e.message.contains("/nonexistent/m.obj"), "{}", e.message);
        let mut log = Vec::new();
        let e = tree_for_path(
            Path::new("/nonexistent/m.obj"),
            "object 1",
            &TreeCache::disabled(),
            &mut log,
        )
        .unwrap_err();
        assert!(e.message.starts_with("object 1: "), "{}", e.message);
    }
}
