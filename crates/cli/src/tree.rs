//! `haptic6d tree build` and `haptic6d tree eval`.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Context, Result};
use clap::{Args, Subcommand, ValueEnum};
use mesh::{load_mesh, InsideTest, LoadedMesh};
use serde_json::json;
use spheretree::build::{build_tree_with_report, BuildMethod, BuildParams};
use spheretree::eval::{evaluate_fit, FitParams, LevelFit, TOOLKIT_SIZE};
use spheretree::sph::{bbox_centre, read_sph, translate_tree, write_sph};
use spheretree::{slot_count, SphereTree};

use crate::progress::Progress;

/// Largest tree the command line builds (slots); beyond it memory and time explode.
const MAX_SLOTS: usize = 1 << 24;

/// Most coverage samples `tree eval` takes (10^7: about a minute on the bunny).
const MAX_SAMPLES: usize = 10_000_000;

/// `haptic6d tree ...`
#[derive(Subcommand)]
pub enum TreeCommand {
    /// Build a sphere-tree from a mesh (OBJ, STL, PLY) and write it as a Bradshaw .sph file.
    Build(BuildArgs),
    /// Measure how tightly a .sph tree fits a mesh, per level (the toolkit's measure).
    Eval(EvalArgs),
}

/// How inside is told from outside (tight builder and fit measure).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Inside {
    /// Pseudo-normal on a closed mesh, generalised winding number on an open one.
    Auto,
    /// The closest feature's pseudo-normal: exact on a closed mesh whose parts do not cross.
    PseudoNormal,
    /// The generalised winding number: open, holed, non-manifold, self-intersecting meshes.
    WindingNumber,
}

impl Inside {
    fn test(self) -> Option<InsideTest> {
        match self {
            Inside::Auto => None,
            Inside::PseudoNormal => Some(InsideTest::PseudoNormal),
            Inside::WindingNumber => Some(InsideTest::WindingNumber),
        }
    }
}

/// Why the automatic choice fell on the inside test `used` for `mesh`, for the report.
fn inside_reason(mesh: &mesh::TriMesh, chosen: Inside, used: InsideTest) -> String {
    if chosen != Inside::Auto {
        return "as asked".into();
    }
    use mesh::MeshError;
    match (used, mesh.check_closed()) {
        (InsideTest::PseudoNormal, _) => "the mesh is closed".into(),
        (_, Err(MeshError::BoundaryEdge { a, b, .. })) => {
            format!("the mesh is open: edge ({a}, {b}) borders a hole")
        }
        (_, Err(MeshError::NonManifoldEdge { a, b, count, .. })) => {
            format!("the mesh is non-manifold: edge ({a}, {b}) has {count} triangles")
        }
        (_, Err(MeshError::FlippedEdge { a, b, .. })) => {
            format!("the mesh is not consistently oriented at edge ({a}, {b})")
        }
        (_, Err(e)) => e.to_string(),
        (_, Ok(())) => "as asked".into(),
    }
}

/// `--method`: a builder by its name (`tight`, `octree`), through `BuildMethod`'s own names.
fn parse_method(name: &str) -> Result<BuildMethod, String> {
    name.trim()
        .to_ascii_lowercase()
        .parse()
        .map_err(|e: spheretree::TreeError| e.to_string())
}

/// Arguments of `haptic6d tree build`.
#[derive(Args)]
pub struct BuildArgs {
    /// The mesh: OBJ, STL (ASCII or binary) or PLY (ASCII or binary).
    pub mesh: PathBuf,
    /// Depth of the tree (levels = depth + 1).
    #[arg(long, default_value_t = 4)]
    pub depth: u32,
    /// Branching factor (children per sphere).
    #[arg(long, default_value_t = 8)]
    pub branch: u32,
    /// Builder: `tight` (default) or `octree` (fast).
    #[arg(long, default_value = "tight", value_parser = parse_method)]
    pub method: BuildMethod,
    /// Output .sph file (written atomically; an existing file is replaced only on success).
    #[arg(short = 'o', long = "output", value_name = "OUT.sph")]
    pub output: PathBuf,
    /// Write the tree centred on the mesh's bounding-box centre, as the Sphere-Tree
    /// Construction Toolkit does (default: the mesh's own frame).
    #[arg(long)]
    pub bradshaw_frame: bool,
    /// Seed of the builder's random surface samples (same seed, same tree).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Inside test of the tight builder: `auto` (pseudo-normal on a closed mesh, winding
    /// number on an open one), `pseudo-normal`, or `winding-number` (also for closed meshes
    /// whose parts pass through each other).
    #[arg(long, value_enum, default_value_t = Inside::Auto)]
    pub inside: Inside,
    /// Print a machine-readable summary (JSON) on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Arguments of `haptic6d tree eval`.
#[derive(Args)]
pub struct EvalArgs {
    /// The sphere-tree (.sph, Bradshaw format).
    pub tree: PathBuf,
    /// The mesh the tree should bound.
    #[arg(long)]
    pub mesh: PathBuf,
    /// The tree is centred on the mesh's bounding-box centre (files from the Sphere-Tree
    /// Construction Toolkit, or `tree build --bradshaw-frame`): shift it back first.
    #[arg(long)]
    pub centre: bool,
    /// Random surface samples for the coverage measure.
    #[arg(long, default_value_t = 100_000)]
    pub samples: usize,
    /// Seed of the coverage samples.
    #[arg(long, default_value_t = 2026)]
    pub seed: u64,
    /// Inside test of the measure: `auto` (pseudo-normal on a closed mesh, winding number on
    /// an open one), `pseudo-normal` or `winding-number`.
    #[arg(long, value_enum, default_value_t = Inside::Auto)]
    pub inside: Inside,
    /// Print a machine-readable summary (JSON) on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Runs a `tree` subcommand.
pub fn run(cmd: TreeCommand) -> Result<()> {
    match cmd {
        TreeCommand::Build(args) => build(&args),
        TreeCommand::Eval(args) => eval(&args),
    }
}

/// Loads a mesh, warning on stderr about what was cleaned.
fn load(path: &Path) -> Result<LoadedMesh> {
    // MeshError messages already name the file.
    let loaded = load_mesh(path)?;
    let r = &loaded.report;
    if r.degenerate_dropped > 0 {
        eprintln!(
            "warning: {}: dropped {} degenerate triangle(s) (repeated vertex or zero area)",
            path.display(),
            r.degenerate_dropped
        );
    }
    Ok(loaded)
}

fn build(args: &BuildArgs) -> Result<()> {
    if args.branch < 2 {
        bail!(
            "--branch {} is too small: use 2 or more (8 is usual)",
            args.branch
        );
    }
    let levels = args.depth.saturating_add(1);
    match slot_count(levels, args.branch) {
        Some(n) if n <= MAX_SLOTS => {}
        _ => bail!(
            "--depth {} with --branch {} needs more than {MAX_SLOTS} slots: choose a smaller depth or branching",
            args.depth,
            args.branch
        ),
    }
    if args.method == BuildMethod::Octree && args.branch < 8 {
        bail!(
            "the octree builder needs --branch 8 or more (got {}): use --method tight",
            args.branch
        );
    }
    // Before the (possibly long) build: the output must be a place a file can be written.
    check_output(&args.output, &args.mesh)?;
    let loaded = load(&args.mesh)?;
    let mesh = &loaded.mesh;
    let params = BuildParams {
        depth: args.depth,
        branching: args.branch,
        method: args.method,
        seed: args.seed,
        inside: args.inside.test(),
        ..BuildParams::default()
    };

    let progress = Progress::fraction(params.method.name());
    let start = Instant::now();
    let built = build_tree_with_report(mesh, &params, &|f| progress.set_fraction(f));
    let seconds = start.elapsed().as_secs_f64();
    progress.finish();
    let (mut tree, report) =
        built.with_context(|| format!("building a sphere-tree of {}", args.mesh.display()))?;
    let inside = report.inside.map(|t| {
        let mut reason = inside_reason(mesh, args.inside, t);
        if report.holes_closed > 0 {
            reason += &format!("; {} hole(s) closed by fans for it", report.holes_closed);
        }
        (t, reason)
    });

    let (lo, hi) = mesh
        .aabb()
        .context("the mesh has no vertices (cannot happen after loading)")?;
    let centre = bbox_centre(lo, hi);
    if args.bradshaw_frame {
        translate_tree(&mut tree, centre.map(|c| -c));
    }
    write_sph(&tree, &args.output)?;

    let used: Vec<usize> = (0..tree.levels()).map(|l| tree.used_on_level(l)).collect();
    if args.json {
        let summary = json!({
            "command": "tree build",
            "mesh": args.mesh.display().to_string(),
            "mesh_format": loaded.report.format.to_string(),
            "vertices": mesh.vertices.len(),
            "triangles": mesh.triangles.len(),
            "degenerate_dropped": loaded.report.degenerate_dropped,
            "duplicates_welded": loaded.report.duplicates_welded,
            "method": params.method.name(),
            "inside_test": inside.as_ref().map(|(t, _)| t.name()),
            "inside_reason": inside.as_ref().map(|(_, r)| r.as_str()),
            "holes_closed": report.holes_closed,
            "depth": args.depth,
            "branching": args.branch,
            "levels": tree.levels(),
            "slots": tree.len(),
            "used_per_level": used,
            "leaves": tree.leaves().count(),
            "frame": if args.bradshaw_frame { "bradshaw" } else { "mesh" },
            "bbox_centre": centre,
            "seed": args.seed,
            "build_seconds": seconds,
            "output": args.output.display().to_string(),
        });
        println!("{summary}");
    } else {
        if let Some((test, reason)) = &inside {
            println!("inside test: {} ({reason})", test.name());
        }
        println!(
            "wrote {}: {} tree of {} ({} vertices, {} triangles), depth {}, branching {}, \
             spheres per level {}, built in {:.2} s{}",
            args.output.display(),
            params.method.name(),
            args.mesh.display(),
            mesh.vertices.len(),
            mesh.triangles.len(),
            args.depth,
            args.branch,
            used.iter()
                .map(|n| n.to_string())
                .collect::<Vec<_>>()
                .join("/"),
            seconds,
            if args.bradshaw_frame {
                format!(
                    " (centred on the mesh's bounding box: shifted by -({:.6}, {:.6}, {:.6}))",
                    centre[0], centre[1], centre[2]
                )
            } else {
                String::new()
            }
        );
    }
    Ok(())
}

/// Refuses an output that exists and is not a regular file (a symbolic link, a device node,
/// a directory, a fifo: [`mesh::check_output_file`], the rule of every file the tools
/// write), that is the input itself (same path or the same file through another name), or
/// whose directory cannot be written; checked before the build so a long build never ends
/// in such an error.
fn check_output(output: &Path, input: &Path) -> Result<()> {
    let shown = output.display();
    mesh::check_output_file(output).with_context(|| format!("-o {shown}"))?;
    if std::fs::metadata(output).is_ok() && same_file(output, input) {
        bail!(
            "-o {shown} is the input mesh {}: give another output file",
            input.display()
        );
    }
    let dir = match output.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    if !dir.is_dir() {
        bail!("-o {shown}: the directory {} does not exist", dir.display());
    }
    // Writable? Create and remove a probe file where the atomic write will put its temp file.
    let probe = dir.join(format!(".haptic6d-probe-{}", std::process::id()));
    std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&probe)
        .with_context(|| format!("-o {shown}: cannot write in {}", dir.display()))?;
    let _ = std::fs::remove_file(&probe);
    Ok(())
}

/// True when `a` and `b` name the same existing file (same device and inode on Unix; the
/// same canonical path elsewhere).
fn same_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        if let (Ok(x), Ok(y)) = (std::fs::metadata(a), std::fs::metadata(b)) {
            return x.dev() == y.dev() && x.ino() == y.ino();
        }
    }
    matches!(
        (std::fs::canonicalize(a), std::fs::canonicalize(b)),
        (Ok(x), Ok(y)) if x == y
    )
}

/// The largest amount by which a child sphere pokes out of its parent (0 when every parent
/// contains its children), in the tree's units.
fn containment_excess(tree: &SphereTree) -> f64 {
    let mut worst: f64 = 0.0;
    for n in 1..tree.len() {
        let (c, p) = match tree.parent(n) {
            Some(p) => (tree.sphere(n), tree.sphere(p)),
            None => continue,
        };
        if !c.is_used() || !p.is_used() {
            continue;
        }
        let d = (0..3)
            .map(|k| (c.center[k] - p.center[k]).powi(2))
            .sum::<f64>()
            .sqrt();
        worst = worst.max(d + c.radius - p.radius);
    }
    worst
}

fn eval(args: &EvalArgs) -> Result<()> {
    // Bounded: the samples are stored (24 bytes each) and measured against every sphere.
    if !(1..=MAX_SAMPLES).contains(&args.samples) {
        crate::usage_bail!(
            "--samples {}: must be an integer in 1..={MAX_SAMPLES}",
            args.samples
        );
    }
    let mut tree = read_sph(&args.tree)?;
    if !tree.spheres().iter().any(|s| s.is_used()) {
        bail!(
            "{}: the tree has no used sphere (every radius is negative); nothing to measure",
            args.tree.display()
        );
    }
    let loaded = load(&args.mesh)?;
    let mesh = &loaded.mesh;
    let inside = args
        .inside
        .test()
        .unwrap_or_else(|| InsideTest::for_mesh(mesh));
    let reason = inside_reason(mesh, args.inside, inside);
    let (lo, hi) = mesh
        .aabb()
        .context("the mesh has no vertices (cannot happen after loading)")?;
    let centre = bbox_centre(lo, hi);
    if args.centre {
        translate_tree(&mut tree, centre);
    }
    let longest = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
    let to_toolkit = if longest > 0.0 {
        TOOLKIT_SIZE / longest
    } else {
        1.0
    };
    let excess = containment_excess(&tree) * to_toolkit;

    let params = FitParams {
        coverage_samples: args.samples,
        seed: args.seed,
        inside: Some(inside),
    };
    let progress = Progress::spinner("measuring fit");
    let start = Instant::now();
    let fits = evaluate_fit(&tree, mesh, &params);
    let seconds = start.elapsed().as_secs_f64();
    progress.finish();

    if args.json {
        let levels: Vec<_> = fits.iter().map(level_json).collect();
        let summary = json!({
            "command": "tree eval",
            "tree": args.tree.display().to_string(),
            "mesh": args.mesh.display().to_string(),
            "levels": tree.levels(),
            "branching": tree.branching(),
            "centred": args.centre,
            "inside_test": inside.name(),
            "inside_reason": reason,
            "units": "toolkit (mesh longest side = 2000)",
            "parents_contain_children": excess <= 1e-9 * TOOLKIT_SIZE,
            "max_child_excess": excess.max(0.0),
            "coverage_samples": args.samples,
            "seed": args.seed,
            "eval_seconds": seconds,
            "per_level": levels,
        });
        println!("{summary}");
    } else {
        println!(
            "{} against {} ({} vertices, {} triangles); levels {}, branching {}{}",
            args.tree.display(),
            args.mesh.display(),
            mesh.vertices.len(),
            mesh.triangles.len(),
            tree.levels(),
            tree.branching(),
            if args.centre {
                " (shifted by the mesh's bounding-box centre)"
            } else {
                ""
            }
        );
        println!(
            "errors in toolkit units (mesh longest side = 2000); coverage over {} surface samples",
            args.samples
        );
        println!("inside test: {} ({reason})", inside.name());
        print!("{}", table(&fits));
        if excess > 1e-9 * TOOLKIT_SIZE {
            println!(
                "note: some children poke out of their parent (by up to {excess:.3}); \
                 pruning needs SphereTree::enforce_containment() on this tree"
            );
        } else {
            println!("every parent contains its children");
        }
        println!("measured in {seconds:.2} s");
    }
    if let Some(root) = fits.first() {
        if root.count > 0 && root.coverage < 0.99 && !args.centre {
            eprintln!(
                "warning: the root covers only {:.1} % of the surface: if the tree comes from the \
                 Sphere-Tree Construction Toolkit (centred on the mesh's bounding box), add --centre",
                100.0 * root.coverage
            );
        }
    }
    Ok(())
}

fn level_json(f: &LevelFit) -> serde_json::Value {
    json!({
        "level": f.level,
        "count": f.count,
        "worst": f.worst,
        "mean": f.mean,
        "worst162": f.worst162,
        "mean162": f.mean162,
        "coverage": f.coverage,
        "uncovered": f.uncovered,
        "largest_gap": f.largest_gap,
    })
}

/// The per-level table of the fit measure (docs/DESIGN.md §The fit measure).
fn table(fits: &[LevelFit]) -> String {
    let mut s = format!(
        "{:>5} {:>7} {:>10} {:>10} {:>10} {:>11} {:>11}\n",
        "level", "count", "worst", "mean", "worst162", "coverage %", "largest gap"
    );
    for f in fits {
        s += &format!(
            "{:>5} {:>7} {:>10.3} {:>10.3} {:>10.3} {:>11.3} {:>11.3}\n",
            f.level,
            f.count,
            f.worst,
            f.mean,
            f.worst162,
            100.0 * f.coverage,
            f.largest_gap
        );
    }
    s
}
