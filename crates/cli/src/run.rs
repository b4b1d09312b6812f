//! `haptic6d run SCENE [--trajectory FILE.csv] [--solver dual|pqp|active-set|pqp-parallel] --out DIR`:
//! runs the haptic pipeline over a device trajectory and writes `DIR/frames.csv`,
//! `DIR/summary.json`, `DIR/trajectory.csv` (the device input, for replay into any solver) and
//! the plots `DIR/pairs.png`, `DIR/timing.png`, `DIR/force.png`.

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::Instant;

use anyhow::{bail, Context, Result};
use clap::Args;
use engine::config;
use engine::setting::Setting;
use engine::{ConstraintForm, Friction, RotationCoordinates, SolverKind};
use scene::cache::TreeCache;
use scene::device::DeviceKind;
use scene::report::{run_frames_csv, summarize, tree_infos, MeshPenetrationReport, RunSummary};
use scene::rt::{run_loop, LoopParams, Pacing};
use scene::trajectory::Trajectory;
use scene::{load_scene_file, Motion, Scene};

use crate::progress::Progress;

/// Arguments of `haptic6d run`.
#[derive(Args, Debug)]
pub struct RunArgs {
    /// A built-in scene (`bunny`, `spline`, `plate`, `spline-tight`, `probe`, a zoo scene such
    /// as `zoo/slot`) or a scene file (.toml).
    pub scene: String,
    /// Device trajectory CSV (`t,x,y,z,gamma,beta,alpha`, one row per frame) to replay instead
    /// of the scene's own motion.
    #[arg(long)]
    pub trajectory: Option<PathBuf>,
    /// The device: replay (default: the scene's trajectory, or --trajectory, open loop),
    /// emulator (a mass-spring-damper hand following that trajectory, closed loop with the
    /// wrench; its parameters from the scene's `[device.emulator]`), haply (a Haply Inverse3
    /// through its Inverse Service; in a build with the `haply` feature) or udp (a device
    /// program speaking the UDP protocol); the live ones are paced in real time. Default: the
    /// scene's `[device] kind`.
    #[arg(long)]
    pub device: Option<String>,
    /// The Haply Inverse Service's WebSocket address (with --device haply).
    #[arg(long, value_name = "URL", default_value = "ws://localhost:10001/")]
    pub haply_url: String,
    /// Where to listen for a device program speaking the UDP protocol (with --device udp; the
    /// protocol of `haptic6d serve`'s bridge, docs/VIEWER.md).
    #[arg(long, value_name = "ADDR", default_value = "127.0.0.1:8081")]
    pub udp_listen: std::net::SocketAddr,
    /// Stop after this many seconds of frames (default: the length of the device motion; a
    /// live device runs for the scene's trajectory length unless given).
    #[arg(long)]
    pub duration: Option<f64>,
    /// QP solver: dual (default, exact), pqp (the paper's), active-set (the paper's baseline),
    /// pqp-parallel (the paper's PQP vectorized and on one thread per core).
    #[arg(long)]
    pub solver: Option<String>,
    /// Output directory (created if missing). The run is written beside it and moved into
    /// place as a whole at the end: a failed run leaves a previous run there untouched.
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
    /// Largest motion of any tool sphere per pass, mm (caps the detection margin).
    #[arg(long)]
    pub max_margin: Option<f64>,
    /// Time budget of one frame's step, µs (no pass starts that would end past it).
    #[arg(long)]
    pub budget_us: Option<f64>,
    /// A second thread shares the frame's large traversals (the same frames; it spins a core
    /// for a few ms after each).
    #[arg(long)]
    pub helper_thread: bool,
    /// What the tool touches: spheres (default: the trees' leaf spheres, the paper's model) or
    /// mesh (the parts' own triangles; needs every body built from a mesh; docs/DESIGN.md
    /// §Mesh-exact contact).
    #[arg(long)]
    pub geometry: Option<String>,
    /// Face caps on object trees: on or off (default: the scene's; docs/DESIGN.md §Face caps).
    #[arg(long, value_parser = crate::parse_on_off)]
    pub face_caps: Option<bool>,
    /// Heuristics of the frame step to switch off (comma-separated, as `bench --studies
    /// ablation` names them, e.g. `mesh-near-fill,lever`), to see what each one does.
    #[arg(long, value_delimiter = ',', value_name = "NAME")]
    pub without: Vec<String>,
    /// Tuned values of the frame step to set (comma-separated `name=value`, as `bench
    /// --tuning-values` names them, e.g. `near-fill-share=0.1`).
    #[arg(long, value_delimiter = ',', value_name = "NAME=VALUE")]
    pub tuning: Vec<String>,
    /// Rotation coordinates: rotation-vector (default) or euler (the paper's).
    #[arg(long)]
    pub rotation: Option<String>,
    /// Coulomb friction on every object: STATIC or STATIC,KINETIC (e.g. 0.4,0.3; kinetic
    /// defaults to static). Overrides the scene's; 0 turns it off.
    #[arg(long, value_name = "STATIC[,KINETIC]", value_parser = friction_arg)]
    pub friction: Option<Friction>,
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

/// `--device NAME` (`run` and `serve`): the device kind, or none given.
pub(crate) fn device_arg(name: Option<&str>) -> Result<Option<DeviceKind>> {
    name.map(DeviceKind::parse_setting)
        .transpose()
        .context("--device")
}

/// The Haply Inverse3 at the Inverse Service `ws_url` (its HTTP address on the same host and
/// port).
#[cfg(feature = "haply")]
pub(crate) fn haply_device(ws_url: &str) -> Result<Box<dyn scene::device::Device>> {
    let http_url = ws_url
        .replacen("wss://", "https://", 1)
        .replacen("ws://", "http://", 1)
        .trim_end_matches('/')
        .to_string();
    Ok(Box::new(haply_device::HaplyInverse3::new(
        haply_device::HaplyParams {
            ws_url: ws_url.to_string(),
            http_url,
            ..Default::default()
        },
    )))
}

/// Without the `haply` feature: says how to build with it.
#[cfg(not(feature = "haply"))]
pub(crate) fn haply_device(_ws_url: &str) -> Result<Box<dyn scene::device::Device>> {
    bail!("--device haply: this haptic6d was built without the Haply Inverse3; build it with `cargo build --release -p haptic6d --features haply` (needs libssl-dev)")
}

/// `--friction STATIC[,KINETIC]`: the coefficients, checked against their ranges.
pub(crate) fn friction_arg(text: &str) -> Result<Friction, String> {
    let mut parts = text.split(',').map(str::trim);
    let number = |p: Option<&str>| -> Result<Option<f64>, String> {
        p.map(|p| {
            p.parse::<f64>().map_err(|_| {
                format!("`{p}` is not a number (STATIC or STATIC,KINETIC, e.g. 0.4,0.3)")
            })
        })
        .transpose()
    };
    let static_mu = number(parts.next())?.unwrap_or(f64::NAN);
    let kinetic_mu = number(parts.next())?.unwrap_or(static_mu);
    if parts.next().is_some() {
        return Err("at most two numbers: STATIC,KINETIC".into());
    }
    let f = Friction {
        static_mu,
        kinetic_mu,
    };
    f.validate("--friction").map_err(|e| e.to_string())?;
    Ok(f)
}

/// A built-in scene by name, or a scene file (TOML) by path; shared by `run` and `serve`.
pub(crate) fn load_scene(name: &str, cache: &TreeCache) -> Result<Scene> {
    if scene::scenes::is_builtin(name) {
        return Ok(scene::scenes::builtin(name, cache)?);
    }
    let path = Path::new(name);
    if !path.exists() {
        if scene::scenes::is_builtin_family(name) {
            return Ok(scene::scenes::builtin(name, cache)?);
        }
        bail!("{}", scene::scenes::no_such_scene(name));
    }
    Ok(load_scene_file(path, cache)?)
}

/// The files a run writes into its `--out` folder.
const RUN_FILES: [&str; 6] = [
    "frames.csv",
    "summary.json",
    "trajectory.csv",
    "pairs.png",
    "timing.png",
    "force.png",
];

/// Test hook: when set to one of [`RUN_FILES`] (or `plots`), the run fails just after writing
/// that output into its staging folder, as a full disk would. Tests use it to show that a
/// failure midway leaves the previous run intact.
const FAIL_HOOK: &str = "HAPTIC6D_TEST_FAIL_RUN_OUTPUT";

fn fail_hook(stage: &str) -> Result<()> {
    if std::env::var(FAIL_HOOK).is_ok_and(|v| v == stage) {
        bail!("simulated failure after writing {stage} ({FAIL_HOOK})");
    }
    Ok(())
}

/// A run's outputs are written into a fresh staging folder beside `--out` and put in place as
/// a whole at the end ([`Staging::commit`]), so a failure midway (disk full, a plot that cannot
/// be written) never leaves new files beside old ones: the previous run stays as it was. The
/// staging folder is removed when the run fails (on drop).
struct Staging {
    /// `--out`.
    out: PathBuf,
    /// The staging folder `.<name>.new-<pid>-<ns>` beside `out`.
    tmp: PathBuf,
    /// Where the previous run is parked during the swap: `.<name>.old-<pid>-<ns>`.
    backup: PathBuf,
    /// Entries of the previous `--out` that are not a run's (kept with `--force`).
    foreign: Vec<std::ffi::OsString>,
    committed: bool,
}

impl Staging {
    /// Checks `out` (a folder, or missing; holding only a previous run's files unless `force`)
    /// and creates the staging folder beside it, which also proves the place writable before
    /// the run starts.
    fn new(out: &Path, force: bool) -> Result<Self> {
        let name = out
            .file_name()
            .with_context(|| format!("--out {}: name a folder", out.display()))?
            .to_string_lossy()
            .into_owned();
        let parent = match out.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let mut foreign = Vec::new();
        match std::fs::symlink_metadata(out) {
            Ok(m) if m.is_dir() => {
                for e in
                    std::fs::read_dir(out).with_context(|| format!("reading {}", out.display()))?
                {
                    let e = e.with_context(|| format!("reading {}", out.display()))?;
                    let n = e.file_name();
                    if !RUN_FILES.iter().any(|r| n == std::ffi::OsStr::new(r)) {
                        foreign.push(n);
                        continue;
                    }
                    // A run's name that is not a regular file (a folder, a link) is the
                    // user's, not a previous run's: replacing it would lose it.
                    let kind = e
                        .file_type()
                        .with_context(|| format!("reading {}", out.display()))?;
                    if !kind.is_file() {
                        bail!(
                            "--out {}: {} is {}, not a file of a previous run; move it away (nothing was written)",
                            out.display(),
                            out.join(&n).display(),
                            if kind.is_dir() { "a folder" } else if kind.is_symlink() { "a symbolic link" } else { "not a regular file" }
                        );
                    }
                }
                let visible: Vec<String> = foreign
                    .iter()
                    .map(|n| n.to_string_lossy().into_owned())
                    .filter(|n| !n.starts_with('.'))
                    .collect();
                if !visible.is_empty() && !force {
                    bail!(
                        "--out {} already holds other files ({}); choose an empty directory or pass --force",
                        out.display(),
                        visible.join(", ")
                    );
                }
            }
            Ok(m) if m.file_type().is_symlink() => bail!(
                "--out {} is a symbolic link; a run replaces its folder as a whole, so give the folder itself",
                out.display()
            ),
            Ok(_) => bail!("--out {} exists and is not a directory", out.display()),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => return Err(e).with_context(|| format!("--out {}", out.display())),
        }
        std::fs::create_dir_all(&parent)
            .with_context(|| format!("creating {}", parent.display()))?;
        remove_stale_staging(&parent, &name);
        let stamp = format!(
            "{}-{}",
            std::process::id(),
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_nanos())
        );
        let tmp = parent.join(format!(".{name}.new-{stamp}"));
        std::fs::create_dir(&tmp).with_context(|| {
            format!(
                "--out {}: cannot create a staging folder beside it ({})",
                out.display(),
                tmp.display()
            )
        })?;
        *INTERRUPTED_STAGING
            .lock()
            .unwrap_or_else(|p| p.into_inner()) = Some(tmp.clone());
        remove_staging_on_interrupt();
        Ok(Self {
            out: out.to_path_buf(),
            backup: parent.join(format!(".{name}.old-{stamp}")),
            tmp,
            foreign,
            committed: false,
        })
    }

    /// Forgets the staging folder for the interrupt handler: it is committed or removed.
    fn disown(&self) {
        let mut slot = INTERRUPTED_STAGING
            .lock()
            .unwrap_or_else(|p| p.into_inner());
        if slot.as_deref() == Some(self.tmp.as_path()) {
            *slot = None;
        }
    }

    /// The staging folder to write the run into.
    fn dir(&self) -> &Path {
        &self.tmp
    }

    /// Puts the staged run in place as a whole: the user's own files in the old folder
    /// (`--force`) move into the new one, the old folder is parked, the new one renamed in,
    /// the old one removed. Any failure undoes what was done: the previous run stays intact.
    fn commit(mut self) -> Result<()> {
        // An interrupt waits until the run is in place (or the commit is undone).
        let _hold = INTERRUPTED_STAGING
            .lock()
            .unwrap_or_else(|p| p.into_inner());
        self.commit_held()
    }

    fn commit_held(&mut self) -> Result<()> {
        if std::fs::symlink_metadata(&self.out).is_err() {
            std::fs::rename(&self.tmp, &self.out)
                .with_context(|| format!("moving the run into {}", self.out.display()))?;
            self.committed = true;
            return Ok(());
        }
        let mut moved = 0;
        let mut result = Ok(());
        for n in &self.foreign {
            if let Err(e) = std::fs::rename(self.out.join(n), self.tmp.join(n)) {
                result = Err(e).with_context(|| {
                    format!("keeping {} in the new run", self.out.join(n).display())
                });
                break;
            }
            moved += 1;
        }
        if result.is_ok() {
            result = std::fs::rename(&self.out, &self.backup)
                .with_context(|| format!("moving the previous run {} aside", self.out.display()));
            if result.is_ok() {
                if let Err(e) = std::fs::rename(&self.tmp, &self.out) {
                    let _ = std::fs::rename(&self.backup, &self.out);
                    result = Err(e)
                        .with_context(|| format!("moving the run into {}", self.out.display()));
                } else {
                    self.committed = true;
                    if let Err(e) = std::fs::remove_dir_all(&self.backup) {
                        eprintln!(
                            "warning: the previous run is kept in {}: cannot remove it: {e}",
                            self.backup.display()
                        );
                    }
                    return Ok(());
                }
            }
        }
        // Undo: the user's files go back where they were.
        for n in &self.foreign[..moved] {
            let _ = std::fs::rename(self.tmp.join(n), self.out.join(n));
        }
        result
    }
}

impl Drop for Staging {
    fn drop(&mut self) {
        self.disown();
        if !self.committed {
            let _ = std::fs::remove_dir_all(&self.tmp);
        }
    }
}

/// The staging folder of the run in progress, removed if the run is interrupted (SIGINT,
/// SIGTERM). Locked by [`Staging::commit`] so an interrupt never cuts the swap in half.
static INTERRUPTED_STAGING: Mutex<Option<PathBuf>> = Mutex::new(None);

/// On SIGINT or SIGTERM (once installed, for the rest of the process): removes the staging
/// folder of the run in progress, says so, and exits with 130. A watcher thread waits for
/// the signal, so the cleanup runs outside the signal handler.
fn remove_staging_on_interrupt() {
    static INSTALLED: std::sync::Once = std::sync::Once::new();
    INSTALLED.call_once(|| {
        let watcher = std::thread::Builder::new()
            .name("haptic6d-interrupt".into())
            .spawn(|| {
                let Ok(runtime) = tokio::runtime::Builder::new_current_thread()
                    .enable_io()
                    .build()
                else {
                    return;
                };
                runtime.block_on(async {
                    let Ok(mut term) =
                        tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate())
                    else {
                        return;
                    };
                    tokio::select! {
                        r = tokio::signal::ctrl_c() => if r.is_err() { return },
                        _ = term.recv() => {}
                    }
                    let staging = INTERRUPTED_STAGING
                        .lock()
                        .unwrap_or_else(|p| p.into_inner())
                        .take();
                    if let Some(tmp) = staging {
                        let _ = std::fs::remove_dir_all(&tmp);
                    }
                    eprintln!("error: interrupted: the run was not written (--out is as it was)");
                    std::process::exit(130);
                });
            });
        if let Err(e) = watcher {
            eprintln!("warning: an interrupted run will leave its staging folder behind: {e}");
        }
    });
}

/// Removes staging folders `.NAME.new-PID-NS` beside `--out` that an earlier run left when it
/// was killed or crashed: only when that process is gone and the folder holds nothing but
/// what a run writes (its files and their temporary files), so nothing of the user's is
/// touched.
fn remove_stale_staging(parent: &Path, name: &str) {
    let Ok(entries) = std::fs::read_dir(parent) else {
        return;
    };
    let prefix = format!(".{name}.new-");
    for e in entries.flatten() {
        let file_name = e.file_name();
        let Some(rest) = file_name.to_str().and_then(|n| n.strip_prefix(&prefix)) else {
            continue;
        };
        let Some((pid, stamp)) = rest.split_once('-') else {
            continue;
        };
        if pid.parse::<u32>().is_err() || stamp.parse::<u128>().is_err() {
            continue;
        }
        // Without /proc there is no telling whether the writer still runs: keep the folder.
        if !Path::new("/proc/self").exists() || Path::new("/proc").join(pid).exists() {
            continue;
        }
        if e.file_type().is_ok_and(|t| t.is_dir()) && holds_only_run_files(&e.path()) {
            let _ = std::fs::remove_dir_all(e.path());
        }
    }
}

/// True when `dir` holds only regular files named as a run's outputs or their temporary
/// files (`.frames.csv.tmp-…`, `.pairs.png.tmp….png`).
fn holds_only_run_files(dir: &Path) -> bool {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return false;
    };
    entries.into_iter().all(|e| {
        let Ok(e) = e else { return false };
        let n = e.file_name();
        let Some(n) = n.to_str() else { return false };
        let ours = RUN_FILES.iter().any(|r| {
            n == *r
                || n.strip_prefix('.')
                    .and_then(|t| t.strip_prefix(r))
                    .is_some_and(|t| t.starts_with(".tmp"))
        });
        ours && e.file_type().is_ok_and(|t| t.is_file())
    })
}

/// Memory a run needs per frame, bytes: its record (kept for the whole run, the outputs are
/// written at the end) and the text of its `frames.csv` and `trajectory.csv` rows.
const BYTES_PER_FRAME: usize = std::mem::size_of::<scene::rt::FrameRecord>() + 640;

/// Refuses, before anything is allocated, a run whose recording cannot fit in `available`
/// bytes of memory (when known): a day at 1 kHz needs tens of GB. A usage error naming the
/// longest `--duration` that fits.
fn check_recording_fits(
    frames: usize,
    rate_hz: f64,
    duration: Option<f64>,
    available: Option<u64>,
) -> Result<()> {
    let Some(available) = available else {
        return Ok(());
    };
    let need = frames as u64 * BYTES_PER_FRAME as u64;
    if need <= available {
        return Ok(());
    }
    let gb = |b: u64| b as f64 / 1e9;
    let longest_s = (available / BYTES_PER_FRAME as u64) as f64 / rate_hz;
    let what = match duration {
        Some(d) => format!("--duration {d} s at {rate_hz} Hz"),
        None => "the trajectory".to_string(),
    };
    crate::usage_bail!(
        "{what} records {frames} frames, about {:.1} GB with the output files, more than the {:.1} GB of memory available; give a --duration of at most {:.0} s",
        gb(need),
        gb(available),
        longest_s.floor()
    );
}

/// The memory the system can give without swapping (`MemAvailable`, Linux), bytes; `None`
/// where it is not known.
fn available_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// Runs `haptic6d run`.
pub fn run(args: RunArgs) -> Result<()> {
    // Flags are checked against the same ranges as the scene file's keys (engine::config),
    // before anything long starts.
    if let Some(r) = args.rate {
        config::RATE_HZ.check_as("--rate", r)?;
    }
    if let Some(d) = args.duration {
        if !(d.is_finite() && d > 0.0 && d <= 86_400.0) {
            crate::usage_bail!("--duration = {d}: must be a number of seconds in (0, 86400]");
        }
    }
    if let Some(n) = args.relinearize {
        config::RELINEARIZE.check_as("--relinearize", u64::from(n))?;
    }
    for (v, range, name) in [
        (args.skin, config::SKIN_MM, "--skin"),
        (args.max_margin, config::MAX_MARGIN_MM, "--max-margin"),
        (args.budget_us, config::BUDGET_US, "--budget-us"),
    ] {
        if let Some(v) = v {
            range.check_as(name, v)?;
        }
    }
    let solver = args
        .solver
        .as_deref()
        .map(SolverKind::parse_setting)
        .transpose()
        .context("--solver")?;
    let geometry = args
        .geometry
        .as_deref()
        .map(engine::Geometry::parse_setting)
        .transpose()
        .context("--geometry")?;
    let form = args
        .form
        .as_deref()
        .map(ConstraintForm::parse_setting)
        .transpose()
        .context("--form")?;
    let rotation = args
        .rotation
        .as_deref()
        .map(RotationCoordinates::parse_setting)
        .transpose()
        .context("--rotation")?;
    let device_kind = device_arg(args.device.as_deref())?;
    let trajectory = args
        .trajectory
        .as_deref()
        .map(Trajectory::read_csv)
        .transpose()?;
    let staging = Staging::new(&args.out, args.force)?;

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
    if let Some(v) = args.skin {
        scene.solver.skin_mm = v;
    }
    if let Some(v) = args.max_margin {
        scene.solver.max_margin_mm = v;
    }
    if let Some(v) = args.budget_us {
        scene.solver.budget_us = v;
    }
    if args.helper_thread {
        scene.solver.helper_thread = true;
    }
    if let Some(on) = args.face_caps {
        scene.solver.face_caps = on;
    }
    if let Some(g) = geometry {
        scene.solver.geometry = g;
    }
    for name in &args.without {
        let Some(switch) = scene.solver.heuristics.switch_mut(name.trim()) else {
            crate::usage_bail!(
                "--without: no heuristic `{name}` (heuristics: {})",
                engine::Heuristics::NAMES.join(", ")
            );
        };
        *switch = false;
    }
    scene.solver.tuning = crate::tuning_with(scene.solver.tuning, &args.tuning, "--tuning")?;
    if let Some(r) = rotation {
        scene.coupling.rotation = r;
    }
    if let Some(f) = args.friction {
        scene.object_friction = vec![f; scene.objects.len()];
    }
    if let Some(t) = trajectory {
        scene.motion = Motion::Trajectory(t);
    }
    scene.validate()?;
    let mesh_note = missing_meshes(&scene);
    let traj = scene.trajectory();
    let kind = device_kind.unwrap_or(scene.device.kind);
    let max_frames = match args.duration {
        Some(s) => (s * scene.rate_hz).ceil().max(1.0) as usize,
        None => traj.len().max(1),
    };
    check_recording_fits(max_frames, scene.rate_hz, args.duration, available_memory())?;
    let mut device = match kind {
        DeviceKind::Haply => haply_device(&args.haply_url)?,
        DeviceKind::Udp => Box::new(viewer::UdpDevice::new(
            args.udp_listen,
            std::time::Duration::from_secs_f64(scene.device.settings.timeout_s),
        )),
        _ => scene.device.make(kind, traj.clone(), scene.rate_hz)?,
    };
    // The device's limits: its force and torque caps lower the safety layer's, and a coupling
    // stiffer than it renders is refused.
    let caps = device.capabilities();
    scene.safety = caps.limit(&scene.safety);
    caps.check_stiffness(scene.coupling.kt, &scene.device.settings.calibration)
        .with_context(|| format!("{}: device {}", scene.name, device.name()))?;
    let first = traj
        .samples
        .first()
        .map(|s| collide::Pose::from_array(s.q))
        .context("the trajectory has no frame")?;

    let mut engine = scene.engine()?;
    let mesh_line = engine
        .god_object()
        .mesh_triangle_counts()
        .map(|counts| scene::mesh_triangles_line(&scene, &counts));
    engine
        .reset(&first)
        .map_err(|source| scene::SceneError::Engine {
            file: scene.name.clone(),
            source,
        })?;
    let params = LoopParams {
        pacing: Pacing {
            rate_hz: scene.rate_hz,
            rt_priority: if args.no_rt_priority { None } else { Some(50) },
            ..Pacing::default()
        },
        // A live device is paced by the clock, whatever --realtime says.
        realtime: args.realtime || matches!(kind, DeviceKind::Haply | DeviceKind::Udp),
        device: scene.device.settings,
        max_frames,
    };
    let report = run_loop(&mut engine, &mut device, &params)?;

    let mut summary = summarize(
        &scene.name,
        scene.solver.kind.name(),
        scene.solver.form.setting_name(),
        &report.frames,
        &report.stats,
        scene.goal,
        scene.load_log.clone(),
        load_s,
    );
    summary.trees = tree_infos(&scene);
    summary.geometry = scene.geometry().name().into();
    summary.meshes = scene.has_meshes();
    summary.load.extend(mesh_line);
    if scene.solver.geometry != scene.geometry() {
        summary.load.push(format!(
            "geometry: {} asked, but not every body has a mesh (a tree read from a .sph file has no triangles): the leaf spheres are the geometry",
            scene.solver.geometry.name()
        ));
    }
    if !args.without.is_empty() || !args.tuning.is_empty() {
        summary.load.push(format!(
            "step: heuristics off [{}], tuned values set [{}]",
            args.without.join(", "),
            args.tuning.join(", ")
        ));
    }
    let mesh_column = match mesh_penetration(&scene, &report.frames) {
        Some((column, measured)) => {
            summary.mesh_penetration_mm = Some(measured);
            column
        }
        None => Vec::new(),
    };
    let dir = staging.dir();
    scene::io::write_atomic(
        &dir.join("frames.csv"),
        run_frames_csv(&report.frames, &mesh_column).as_bytes(),
    )?;
    fail_hook("frames.csv")?;
    // The device input as the engine saw it (scene frame): for the emulator, where the hand
    // actually went, so the closed-loop run can be replayed open loop into any solver.
    let seen = match kind {
        DeviceKind::Replay => traj,
        DeviceKind::Emulator | DeviceKind::Haply | DeviceKind::Udp => Trajectory {
            samples: report
                .frames
                .iter()
                .map(|r| scene::trajectory::TrajSample {
                    t: r.t,
                    q: r.frame.q_h,
                })
                .collect(),
        },
    };
    scene::io::write_atomic(&dir.join("trajectory.csv"), seen.to_csv_string().as_bytes())?;
    fail_hook("trajectory.csv")?;
    let json = serde_json::to_string_pretty(&summary)?;
    scene::io::write_atomic(&dir.join("summary.json"), json.as_bytes())?;
    fail_hook("summary.json")?;
    if !args.no_plots {
        crate::plot::write_plots(
            dir,
            &report.frames,
            &format!("{} / {}", summary.scene, summary.solver),
        )?;
        fail_hook("plots")?;
    }
    staging.commit()?;
    if let Some(why) = &mesh_note {
        eprintln!("{}: {why}: mesh-level penetration not measured", scene.name);
    }
    let out = &args.out;
    if args.json {
        println!("{json}");
    } else {
        print_human(&summary, out);
    }
    Ok(())
}

/// Mesh-level penetration is measured on every this many frames near an object (1: every one,
/// [`peer::MeshPenetration::may_touch`]): a frame's measure costs 0.03–1 ms on 2 cores on the
/// built-in and zoo scenes, after the frames (docs/DESIGN.md §Formats).
pub const MESH_STRIDE: usize = 1;

/// Surface samples per mesh of the mesh-level measure beside its vertices (as the bench's zoo
/// study: the measure adds more on large meshes, 0.5 per mm²).
const MESH_SAMPLES: usize = 2000;

/// Why the scene cannot be measured at the mesh level (`None`: the tool and every object
/// have meshes).
fn missing_meshes(scene: &Scene) -> Option<String> {
    let mut without: Vec<String> = Vec::new();
    if scene.tool_mesh.is_none() {
        without.push("the tool".into());
    }
    for k in 0..scene.objects.len() {
        if scene.object_meshes.get(k).is_none_or(|m| m.is_none()) {
            without.push(format!("object {k}"));
        }
    }
    (!without.is_empty()).then(|| {
        format!(
            "no mesh for {} (a tree read from a .sph file has no triangles)",
            without.join(", ")
        )
    })
}

/// The mesh-level penetration ([`peer::MeshPenetration`]) of the scene's tool mesh at each
/// of `poses` (mm, rad) into its object meshes, mm, measured on all cores where the tool may
/// touch an object ([`peer::MeshPenetration::may_touch`]: elsewhere `None`, 0 exactly); `None`
/// when the scene lacks a mesh ([`missing_meshes`]).
pub(crate) fn mesh_depths(scene: &Scene, poses: &[[f64; 6]]) -> Option<Vec<Option<f64>>> {
    let tool = scene.tool_mesh.as_ref()?;
    let objects = scene
        .object_meshes
        .iter()
        .zip(&scene.objects)
        .map(|(m, (_, pose))| m.as_ref().map(|m| (m, *pose)))
        .collect::<Option<Vec<_>>>()?;
    if objects.len() != scene.objects.len() {
        return None;
    }
    if poses.is_empty() {
        return Some(Vec::new());
    }
    let measure = peer::MeshPenetration::new(tool, &objects, MESH_SAMPLES);
    let threads = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .clamp(1, poses.len());
    let per = poses.len().div_ceil(threads);
    std::thread::scope(|s| {
        let handles: Vec<_> = poses
            .chunks(per)
            .map(|part| {
                let measure = &measure;
                s.spawn(move || {
                    part.iter()
                        .map(|q| {
                            let q = collide::Pose::from_array(*q);
                            measure.may_touch(&q).then(|| measure.depth_mm(&q))
                        })
                        .collect::<Vec<Option<f64>>>()
                })
            })
            .collect();
        let mut depths = Vec::with_capacity(poses.len());
        for h in handles {
            depths.extend(h.join().ok()?);
        }
        Some(depths)
    })
}

/// The mesh-level penetration of the graphic tool at every [`MESH_STRIDE`]-th frame, measured
/// after the run ([`mesh_depths`]) where the tool's bounding box may touch an object's: one
/// entry per frame (mm, `None` where not measured: 0 exactly) and the summary; `None` when the
/// scene lacks a mesh. Which frames are measured rests on the parts alone, not on the engine's
/// own pairs: a frame the engine took for free space is measured as any other.
fn mesh_penetration(
    scene: &Scene,
    frames: &[scene::rt::FrameRecord],
) -> Option<(Vec<Option<f64>>, MeshPenetrationReport)> {
    let t0 = Instant::now();
    let chosen: Vec<usize> = (0..frames.len()).step_by(MESH_STRIDE).collect();
    let poses: Vec<[f64; 6]> = chosen.iter().map(|&k| frames[k].frame.q_g).collect();
    let depths = mesh_depths(scene, &poses)?;
    let mut column = vec![None; frames.len()];
    for (&k, &d) in chosen.iter().zip(&depths) {
        column[k] = d;
    }
    let measured: Vec<f64> = depths.iter().flatten().copied().collect();
    let report = MeshPenetrationReport {
        max: measured.iter().copied().fold(0.0, f64::max),
        frames: measured.len(),
        contact_frames: measured.len(),
        stride: MESH_STRIDE,
        wall_s: t0.elapsed().as_secs_f64(),
    };
    Some((column, report))
}

fn print_human(s: &RunSummary, out: &Path) {
    for l in &s.load {
        eprintln!("{l}");
    }
    println!(
        "{} / {} ({}, {}): {} frames, scene loaded in {:.3} s",
        s.scene, s.solver, s.form, s.geometry, s.frames, s.load_s
    );
    for t in &s.trees {
        println!("  tree: {}", t.describe());
    }
    println!(
        "  total µs  p50 {:.1}  p99 {:.1}  max {:.1}   (cd p99 {:.1}, opt p99 {:.1}; own work p99 {:.1}, lists ahead p99 {:.1})",
        s.total_us.p50,
        s.total_us.p99,
        s.total_us.max,
        s.cd_us.p99,
        s.opt_us.p99,
        s.own_us.p99,
        s.ahead_us.p99
    );
    println!(
        "  pairs p50 {:.0} max {:.0}; iterations p99 {:.0}; penetration max {:.4} mm",
        s.pairs.p50, s.pairs.max, s.iterations.p99, s.penetration_mm.max
    );
    match &s.mesh_penetration_mm {
        Some(m) => println!(
            "  mesh penetration max {:.4} mm ({} of {} frames near an object measured, {:.2} s)",
            m.max, m.frames, m.contact_frames, m.wall_s
        ),
        None => println!("  mesh penetration: not measured (no meshes)"),
    }
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
        "  safety: {} force clamps, {} torque clamps, {} rate limits, {} NaN frames; {} kept-last-safe, {} inexact, {} lagging",
        l.safety.force_clamps, l.safety.torque_clamps, l.safety.rate_limits, l.safety.nan_frames, l.kept_last_safe, l.inexact, l.lagging
    );
    if l.stick_frames + l.slip_frames > 0 {
        println!(
            "  friction: {} frames stuck, {} slipping",
            l.stick_frames, l.slip_frames
        );
    }
    let d = &l.link;
    println!(
        "  device {}: {} readings, {} held, {} released ({} timeouts); {} frames with unrendered axes zeroed (max {:.2} N, {:.1} N·mm)",
        l.device, d.readings, d.held_frames, d.released_frames, d.timeouts, d.masked_frames, d.max_masked_force_n, d.max_masked_torque_nmm
    );
    if let Some(g) = &s.goal {
        println!(
            "  goal {}: target z {:.2} mm, reached {:.3} mm: {}",
            g.kind,
            g.target_z_mm,
            g.reached_z_mm,
            if g.success { "OK" } else { "NOT REACHED" }
        );
        if !g.success && s.meshes && s.geometry == engine::Geometry::Spheres.name() {
            // The leaf spheres stand off the parts by up to a few tenths of a millimetre: a
            // user whose parts fit tighter than that sees a jam with no cause given.
            println!(
                "  the tool touched the leaf spheres, which stand off the parts' surfaces: a fit tighter than they stand off cannot be entered; `--geometry mesh` puts contact on the parts' own triangles"
            );
        }
    }
    println!("  wrote {}", out.display());
}
