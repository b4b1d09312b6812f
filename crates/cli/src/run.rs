//! `haptic6d run SCENE [--trajectory FILE.csv] [--solver dual|pqp|active-set] --out DIR`:
//! runs the haptic pipeline over a device trajectory and writes `DIR/frames.csv`,
//! `DIR/summary.json`, `DIR/trajectory.csv` (the device input, for replay into any solver) and
//! the plots `DIR/pairs.png`, `DIR/timing.png`, `DIR/force.png`.

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::Instant;

use anyhow::{bail, Context, Result};
use clap::Args;
use render::cache::TreeCache;
use render::device::ReplayDevice;
use render::report::{frames_csv, summarize, tree_infos, RunSummary};
use render::rt::{run_loop, LoopParams};
use render::safety::Safety;
use render::scene::{load_scene_file, FormSpec, Motion, Scene, SolverKind};
use render::step::{GodObject, StepParams};
use render::trajectory::Trajectory;

use crate::progress::Progress;

/// Arguments of `haptic6d run`.
#[derive(Args, Debug)]
pub struct RunArgs {
    /// A built-in scene (`bunny`, `spline`) or a scene file (.toml).
    pub scene: String,
    /// Device trajectory CSV (`t,x,y,z,gamma,beta,alpha`, one row per frame) to replay instead
    /// of the scene's own motion.
    #[arg(long)]
    pub trajectory: Option<PathBuf>,
    /// QP solver: dual (default, exact), pqp (the paper's), active-set (the paper's baseline).
    #[arg(long)]
    pub solver: Option<String>,
    /// Output directory (created if missing).
    #[arg(long, short)]
    pub out: PathBuf,
    /// Print the summary as JSON on stdout.
    #[arg(long)]
    pub json: bool,
    /// Pace the frames on the wall clock at the scene rate (1 kHz) on the haptic thread,
    /// instead of computing them as fast as possible.
    #[arg(long)]
    pub realtime: bool,
    /// Override the haptic rate, Hz (with --realtime).
    #[arg(long)]
    pub rate: Option<f64>,
    /// Constraint form: distance (default) or squared (the paper's).
    #[arg(long)]
    pub form: Option<String>,
    /// Maximum re-linearisation passes per frame (0 = the paper's single pass).
    #[arg(long)]
    pub relinearize: Option<u32>,
    /// Detection skin added to the motion bound, mm.
    #[arg(long)]
    pub skin: Option<f64>,
    /// Trust region per translation axis per frame, mm (when the hand is far from the tool).
    #[arg(long)]
    pub trust_mm: Option<f64>,
    /// Trust region per Euler angle per frame, rad.
    #[arg(long)]
    pub trust_rad: Option<f64>,
    /// Keep the haptic thread at normal priority (by default it asks for SCHED_FIFO, which
    /// needs the privilege, so that timings are not inflated by preemption).
    #[arg(long)]
    pub no_rt_priority: bool,
    /// Skip the PNG plots.
    #[arg(long)]
    pub no_plots: bool,
    /// Write into OUT even if it holds files that do not look like a previous run.
    #[arg(long)]
    pub force: bool,
}

/// A built-in scene by name, or a scene file (TOML) by path; shared by `run` and `serve`.
pub(crate) fn load_scene(name: &str, cache: &TreeCache) -> Result<Scene> {
    if render::scenes::BUILTIN_NAMES.contains(&name) {
        return Ok(render::scenes::builtin(name, cache)?);
    }
    let path = Path::new(name);
    if !path.exists() {
        bail!(
            "no built-in scene or scene file named `{name}` (built-in: {}; files end in .toml)",
            render::scenes::BUILTIN_NAMES.join(", ")
        );
    }
    Ok(load_scene_file(path, cache)?)
}

/// Refuses to write into a directory holding files that are not a previous run's, unless
/// `force`.
fn check_out_dir(dir: &Path, force: bool) -> Result<()> {
    if !dir.exists() {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        return Ok(());
    }
    if !dir.is_dir() {
        bail!("--out {} exists and is not a directory", dir.display());
    }
    let ours = [
        "frames.csv",
        "summary.json",
        "trajectory.csv",
        "pairs.png",
        "timing.png",
        "force.png",
    ];
    let foreign: Vec<String> = std::fs::read_dir(dir)
        .with_context(|| format!("reading {}", dir.display()))?
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| !ours.contains(&n.as_str()) && !n.starts_with('.'))
        .collect();
    if !foreign.is_empty() && !force {
        bail!(
            "--out {} already holds other files ({}); choose an empty directory or pass --force",
            dir.display(),
            foreign.join(", ")
        );
    }
    Ok(())
}

/// Runs `haptic6d run`.
pub fn run(args: RunArgs) -> Result<()> {
    if let Some(r) = args.rate {
        if !(r > 0.0 && r.is_finite()) {
            bail!("--rate {r}: must be a positive number of Hz (e.g. 1000)");
        }
    }
    let solver = args.solver.as_deref().map(SolverKind::parse).transpose()?;
    let form = match args.form.as_deref() {
        None => None,
        Some("distance") => Some(FormSpec::Distance),
        Some("squared") => Some(FormSpec::Squared),
        Some(other) => bail!("--form {other}: use distance or squared"),
    };
    let trajectory = args
        .trajectory
        .as_deref()
        .map(Trajectory::read_csv)
        .transpose()?;
    check_out_dir(&args.out, args.force)?;

    // One progress bar per tree build (terminal only), replaced when the next tree starts.
    let bar: Arc<Mutex<Option<(String, Progress)>>> = Arc::new(Mutex::new(None));
    let bar_cb = Arc::clone(&bar);
    let cache = TreeCache::from_env().with_progress(Arc::new(move |label: &str, f: f64| {
        if let Ok(mut slot) = bar_cb.lock() {
            if slot.as_ref().is_none_or(|(l, _)| l != label) {
                if let Some((_, old)) = slot.take() {
                    old.finish();
                }
                *slot = Some((label.to_string(), Progress::fraction(label)));
            }
            if let Some((_, p)) = slot.as_ref() {
                p.set_fraction(f);
            }
        }
    }));
    let t0 = Instant::now();
    let mut scene = load_scene(&args.scene, &cache)?;
    let load_s = t0.elapsed().as_secs_f64();
    if let Some((_, p)) = bar.lock().ok().and_then(|mut s| s.take()) {
        p.finish();
    }
    if let Some(k) = solver {
        scene.solver.kind = k;
    }
    if let Some(f) = form {
        scene.solver.form = f;
    }
    if let Some(n) = args.relinearize {
        scene.solver.relinearize = n;
    }
    if let Some(r) = args.rate {
        scene.rate_hz = r;
    }
    for (v, name) in [
        (args.skin, "--skin"),
        (args.trust_mm, "--trust-mm"),
        (args.trust_rad, "--trust-rad"),
    ] {
        if let Some(v) = v {
            if !(v > 0.0 && v.is_finite()) {
                bail!("{name} {v}: must be a positive number");
            }
        }
    }
    if let Some(v) = args.skin {
        scene.solver.skin_mm = v;
    }
    if let Some(v) = args.trust_mm {
        scene.solver.trust_mm = v;
    }
    if let Some(v) = args.trust_rad {
        scene.solver.trust_rad = v;
    }
    if let Some(t) = trajectory {
        scene.motion = Motion::Trajectory(t);
    }
    let traj = scene.trajectory();
    let first = traj
        .samples
        .first()
        .map(|s| collide::Pose::from_array(s.q))
        .context("the trajectory has no frame")?;

    let mut god = GodObject::new(&scene, StepParams::from_scene(&scene))?;
    god.reset(&first)?;
    let mut safety = Safety::new(scene.safety);
    let mut device = ReplayDevice::new(traj.clone());
    let params = LoopParams {
        rate_hz: scene.rate_hz,
        realtime: args.realtime,
        rt_priority: if args.no_rt_priority { None } else { Some(50) },
        ..LoopParams::default()
    };
    let report = run_loop(&mut god, &mut device, &mut safety, &params)?;

    let mut summary = summarize(
        &scene.name,
        scene.solver.kind.name(),
        match scene.solver.form {
            FormSpec::Distance => "distance",
            FormSpec::Squared => "squared",
        },
        &report.frames,
        &report.stats,
        scene.goal,
        scene.load_log.clone(),
        load_s,
    );
    summary.trees = tree_infos(&scene);
    let out = &args.out;
    render::io::write_atomic(
        &out.join("frames.csv"),
        frames_csv(&report.frames).as_bytes(),
    )?;
    render::io::write_atomic(&out.join("trajectory.csv"), traj.to_csv_string().as_bytes())?;
    let json = serde_json::to_string_pretty(&summary)?;
    render::io::write_atomic(&out.join("summary.json"), json.as_bytes())?;
    if !args.no_plots {
        crate::plot::write_plots(
            out,
            &report.frames,
            &format!("{} / {}", summary.scene, summary.solver),
        )?;
    }
    if args.json {
        println!("{json}");
    } else {
        print_human(&summary, out);
    }
    Ok(())
}

fn print_human(s: &RunSummary, out: &Path) {
    for l in &s.load {
        eprintln!("{l}");
    }
    println!(
        "{} / {} ({}): {} frames, scene loaded in {:.3} s",
        s.scene, s.solver, s.form, s.frames, s.load_s
    );
    for t in &s.trees {
        println!("  tree: {}", t.describe());
    }
    println!(
        "  total µs  p50 {:.1}  p99 {:.1}  max {:.1}   (cd p99 {:.1}, opt p99 {:.1})",
        s.total_us.p50, s.total_us.p99, s.total_us.max, s.cd_us.p99, s.opt_us.p99
    );
    println!(
        "  pairs p50 {:.0} max {:.0}; iterations p99 {:.0}; penetration max {:.4} mm",
        s.pairs.p50, s.pairs.max, s.iterations.p99, s.penetration_mm.max
    );
    println!(
        "  force max {:.2} N, torque max {:.1} N·mm, largest force jump {:.3} N (excl. {} contact onsets)",
        s.force.max_force_n, s.force.max_torque_nmm, s.force.max_force_jump_n, s.force.contact_onsets
    );
    let l = &s.loop_stats;
    println!(
        "  haptic thread: {}",
        if l.rt_priority {
            "SCHED_FIFO"
        } else {
            "normal priority"
        }
    );
    if l.realtime {
        println!(
            "  loop {:.0} Hz: period error p50 {:.1} p99 {:.1} max {:.1} µs, {} overruns",
            l.rate_hz,
            l.period_error_us.p50,
            l.period_error_us.p99,
            l.period_error_us.max,
            l.overruns
        );
    }
    println!(
        "  safety: {} force clamps, {} torque clamps, {} rate limits, {} NaN frames; {} kept-last-safe, {} inexact",
        l.safety.force_clamps, l.safety.torque_clamps, l.safety.rate_limits, l.safety.nan_frames, l.kept_last_safe, l.inexact
    );
    if let Some(g) = &s.goal {
        println!(
            "  goal {}: target z {:.2} mm, reached {:.3} mm: {}",
            g.kind,
            g.target_z_mm,
            g.reached_z_mm,
            if g.success { "OK" } else { "NOT REACHED" }
        );
    }
    println!("  wrote {}", out.display());
}
