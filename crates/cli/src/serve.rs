//! `haptic6d serve [SCENE]`: the interactive viewer. The haptic loop (the engine: god-object step
//! and safety filter) runs at 1 kHz on its own thread; a web server shows the scene live and
//! takes the device pose from the page (mouse, keys, gamepad) or from the UDP device bridge.

use std::net::{IpAddr, SocketAddr};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use crate::run::load_scene;
use anyhow::{bail, Context, Result};
use clap::Args;
use scene::cache::TreeCache;
use scene::device::DeviceKind;
use viewer::server::{self, WebParams};
use viewer::{BridgeParams, DeviceBridge, HapticLoop, Pacing, SceneSim, UdpBridge};

/// Arguments of `haptic6d serve`.
#[derive(Args, Debug)]
pub struct ServeArgs {
    /// Built-in scene (`bunny`, `spline`, `plate`, `spline-tight`, `probe`, a zoo scene such as
    /// `zoo/slot`) or a scene file (.toml).
    #[arg(default_value = "bunny")]
    pub scene: String,
    /// Web server port (0 picks a free one; the URL is printed).
    #[arg(long, default_value_t = 8080)]
    pub port: u16,
    /// Address to listen on (web and UDP). The default keeps everything on this machine.
    #[arg(long, default_value = "127.0.0.1")]
    pub bind: IpAddr,
    /// UDP device bridge port (0 picks a free one; see docs/VIEWER.md for the protocol).
    #[arg(long, default_value_t = 8081)]
    pub udp_port: u16,
    /// Do not start the UDP device bridge.
    #[arg(long)]
    pub no_udp: bool,
    /// A UDP device silent this long is released (zero force) and its session ends, ms
    /// (10 to 10000).
    #[arg(long, default_value_t = viewer::protocol::DEFAULT_TIMEOUT_MS)]
    pub udp_timeout_ms: u64,
    /// Record the device trajectory of the whole session to this CSV
    /// (`t,x,y,z,gamma,beta,alpha`; replay with `haptic6d run SCENE --trajectory FILE`).
    /// Written to a temporary file beside it and moved into place when the server stops
    /// (Ctrl-C, SIGTERM, --duration); an existing FILE is refused unless --force.
    #[arg(long, value_name = "FILE.csv")]
    pub record: Option<PathBuf>,
    /// Let --record replace an existing file (when the recording ends, not before).
    #[arg(long)]
    pub force: bool,
    /// Let the page start and stop recordings (off by default: the record button is hidden
    /// and the server ignores the page's record commands).
    #[arg(long)]
    pub allow_page_recording: bool,
    /// Directory for recordings started from the page (with --allow-page-recording).
    #[arg(long, default_value = ".")]
    pub record_dir: PathBuf,
    /// Another origin (`http(s)://host[:port]`) whose pages may use the server, e.g. when it
    /// is reached through a host name or a proxy; repeatable. The served address itself
    /// (127.0.0.1, localhost and the IPv6 loopback, with the port) is always allowed; any
    /// other Host or Origin is refused (403).
    #[arg(long, value_name = "URL")]
    pub allow_origin: Vec<String>,
    /// Haptic rate, Hz (100 to 20000).
    #[arg(long, default_value_t = 1000.0)]
    pub rate: f64,
    /// The haptic thread's real-time priority (`SCHED_FIFO`, 1-99). Asked for by default,
    /// as `haptic6d run` does, so that the frames keep their period while the page and the
    /// server run beside them; best effort: without the privilege the thread runs at normal
    /// priority and the start-up line says so.
    #[arg(long, value_name = "PRIORITY", default_value_t = DEFAULT_RT_PRIORITY)]
    pub rt_priority: i32,
    /// Keep the haptic thread at normal priority.
    #[arg(long, conflicts_with = "rt_priority")]
    pub no_rt_priority: bool,
    /// State stream rate to the page, Hz (1 to 240).
    #[arg(long, default_value_t = 60.0)]
    pub display_hz: f64,
    /// Stop after this many seconds (at most 30 days; default: run until Ctrl-C or SIGTERM).
    #[arg(long)]
    pub duration: Option<f64>,
    /// Print a machine-readable summary (JSON) on stdout when the server stops.
    #[arg(long)]
    pub json: bool,
    /// A device driving the loop through the device trait, beside the page and the UDP bridge:
    /// replay (the scene's trajectory, at the loop rate) or haply (a Haply Inverse3 through its
    /// Inverse Service, in a build with the `haply` feature). While it drives the loop the page
    /// watches.
    #[arg(long)]
    pub device: Option<String>,
    /// The Haply Inverse Service's WebSocket address (with --device haply).
    #[arg(long, value_name = "URL", default_value = "ws://localhost:10001/")]
    pub haply_url: String,
    /// Coulomb friction on every object: STATIC or STATIC,KINETIC (e.g. 0.4,0.3); the page
    /// then shows a friction switch.
    #[arg(long, value_name = "STATIC[,KINETIC]", value_parser = crate::run::friction_arg)]
    pub friction: Option<engine::Friction>,
}

/// The haptic thread's `SCHED_FIFO` priority unless told otherwise: the one `haptic6d run`
/// asks for, the middle of the range, above every normal thread and leaving room above it
/// for a device driver's own real-time threads.
const DEFAULT_RT_PRIORITY: i32 = 50;

/// Longest `--duration` (s): 30 days.
const MAX_DURATION_S: f64 = 30.0 * 86_400.0;

/// Checks every flag before anything starts; the error names the flag and what is wrong.
/// Returns the run time limit.
/// The haptic loop's pacing from the flags.
fn pacing(args: &ServeArgs) -> Pacing {
    Pacing {
        rate_hz: args.rate,
        rt_priority: (!args.no_rt_priority).then_some(args.rt_priority),
        ..Pacing::default()
    }
}

fn validate(args: &ServeArgs) -> Result<Option<Duration>> {
    let duration = match args.duration {
        None => None,
        Some(d) if d.is_finite() && d > 0.0 && d <= MAX_DURATION_S => {
            Some(Duration::try_from_secs_f64(d).context("--duration")?)
        }
        Some(d) => bail!(
            "--duration must be a number of seconds in (0, {MAX_DURATION_S}] (30 days), got {}",
            viewer::error::show_number(d)
        ),
    };
    // The rate under the flag's name; then the loop's settings as the loop checks them.
    engine::config::RATE_HZ.check_as("--rate", args.rate)?;
    pacing(args).validate()?;
    if !args.no_udp {
        BridgeParams {
            addr: SocketAddr::new(args.bind, args.udp_port),
            timeout: Duration::from_millis(args.udp_timeout_ms),
        }
        .validate()?;
    }
    WebParams {
        display_hz: args.display_hz,
        record_dir: args.record_dir.clone(),
        addr: SocketAddr::new(args.bind, args.port),
        allowed_origins: args.allow_origin.clone(),
        allow_page_recording: args.allow_page_recording,
    }
    .validate()?;
    if args.force && args.record.is_none() {
        bail!("--force applies to --record FILE, which is not given");
    }
    if let Some(path) = &args.record {
        match std::fs::symlink_metadata(path) {
            Ok(m) if !m.file_type().is_file() => {
                bail!("--record {} exists and is not a regular file", path.display())
            }
            Ok(_) if !args.force => bail!(
                "--record {} already exists; choose another file or pass --force to replace it when the recording ends",
                path.display()
            ),
            _ => {}
        }
        let dir = match path.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => std::path::Path::new("."),
        };
        if !dir.is_dir() {
            bail!(
                "--record {}: the directory {} does not exist",
                path.display(),
                dir.display()
            );
        }
    }
    Ok(duration)
}

/// Resolves when the server should stop: after `duration`, on Ctrl-C (SIGINT) or on SIGTERM.
async fn stop_signal(duration: Option<Duration>) {
    let limit = async {
        match duration {
            Some(d) => tokio::time::sleep(d).await,
            None => std::future::pending().await,
        }
    };
    #[cfg(unix)]
    let term = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(_) => std::future::pending().await,
        }
    };
    #[cfg(not(unix))]
    let term = std::future::pending::<()>();
    tokio::select! {
        _ = limit => {}
        _ = term => {}
        r = tokio::signal::ctrl_c() => {
            if r.is_err() {
                // No Ctrl-C handler could be installed: rely on the other two.
                std::future::pending::<()>().await;
            }
        }
    }
}

/// Runs `haptic6d serve`.
pub fn run(args: ServeArgs) -> Result<()> {
    let duration = validate(&args)?;
    let cache = TreeCache::from_env();
    let mut scene = load_scene(&args.scene, &cache)
        .with_context(|| format!("cannot load scene `{}`", args.scene))?;
    if let Some(f) = args.friction {
        scene.object_friction = vec![f; scene.objects.len()];
    }
    let device_kind = crate::run::device_arg(args.device.as_deref())?;
    let sim = SceneSim::new(&scene).context("cannot set up the haptic step")?;
    let haptic = HapticLoop::spawn(sim, &pacing(&args))?;
    let haptic = Arc::new(haptic);
    let device_bridge = match device_kind {
        None => None,
        Some(kind) => {
            let device = match kind {
                DeviceKind::Haply => crate::run::haply_device(&args.haply_url)?,
                DeviceKind::Replay => {
                    scene
                        .device
                        .make(kind, scene.trajectory(), args.rate)?
                }
                DeviceKind::Emulator => bail!(
                    "--device emulator: the emulated hand runs closed loop with `haptic6d run`, not in the viewer"
                ),
                DeviceKind::Udp => bail!(
                    "--device udp: serve takes UDP devices on its own bridge (--udp-port)"
                ),
            };
            Some(DeviceBridge::spawn(
                device,
                scene.device.settings,
                args.rate,
                haptic.input().clone(),
                haptic.state().clone(),
            )?)
        }
    };
    let bridge = if args.no_udp {
        None
    } else {
        Some(UdpBridge::spawn(
            &BridgeParams {
                addr: SocketAddr::new(args.bind, args.udp_port),
                timeout: Duration::from_millis(args.udp_timeout_ms),
            },
            haptic.input().clone(),
            haptic.state().clone(),
        )?)
    };
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .context("cannot start the async runtime")?;
    let json = args.json;
    // With --json, stdout carries only the final summary; the startup lines go to stderr.
    let say = move |line: String| report(json, &line);
    runtime.block_on(async {
        let listener = server::bind(SocketAddr::new(args.bind, args.port)).await?;
        let local = listener
            .local_addr()
            .context("cannot read the bound address")?;
        let router = server::router(
            haptic.clone(),
            WebParams {
                display_hz: args.display_hz,
                record_dir: args.record_dir.clone(),
                addr: local,
                allowed_origins: args.allow_origin.clone(),
                allow_page_recording: args.allow_page_recording,
            },
        )?;
        // Every port is bound: only now is the recording's file created (beside the target;
        // the target itself is only replaced when the recording ends).
        if let Some(path) = &args.record {
            haptic.start_recording(path, args.force)?;
        }
        say(format!(
            "haptic6d serve: scene {} at {:.0} Hz; open http://{local}/",
            scene.name, args.rate
        ));
        if let Some(b) = &bridge {
            say(format!(
                "UDP device bridge on {} (protocol v{}, timeout {} ms)",
                b.local_addr(),
                viewer::protocol::VERSION,
                args.udp_timeout_ms
            ));
        }
        if let Some(d) = &device_bridge {
            say(format!("device {} drives the loop (the page watches while it does)", d.name()));
        }
        if args.no_rt_priority {
            say("haptic thread: normal priority (--no-rt-priority)".to_string());
        } else {
            let p = args.rt_priority;
            // The thread sets its priority as it starts; give it a moment before reporting.
            tokio::time::sleep(Duration::from_millis(50)).await;
            say(if haptic.realtime() {
                format!("haptic thread: SCHED_FIFO priority {p}")
            } else {
                format!(
                    "haptic thread: SCHED_FIFO priority {p} not granted (needs root, CAP_SYS_NICE or an rtprio limit); normal priority"
                )
            });
        }
        let (stop_tx, stop_rx) = tokio::sync::oneshot::channel::<()>();
        let serving = server::run(listener, router, async move {
            let _ = stop_rx.await;
        });
        tokio::pin!(serving);
        tokio::select! {
            r = &mut serving => r?,
            _ = stop_signal(duration) => {
                let _ = stop_tx.send(());
                // Open pages may hold connections: give them a moment, then stop regardless.
                if let Ok(r) = tokio::time::timeout(Duration::from_secs(2), &mut serving).await {
                    r?;
                }
            }
        }
        anyhow::Ok(())
    })?;
    if let Some(b) = bridge {
        b.shutdown();
    }
    if let Some(d) = device_bridge {
        let link = d.stop();
        if !args.json {
            report(
                false,
                &format!(
                    "device: {} readings, {} held, {} released ({} timeouts)",
                    link.readings, link.held_frames, link.released_frames, link.timeouts
                ),
            );
        }
    }
    let recording = if haptic.recording_path().is_some() {
        let s = haptic.stop_recording()?;
        if !args.json {
            report(
                false,
                &format!(
                    "recorded {} frames to {} ({} dropped); replay: haptic6d run {} --trajectory {}",
                    s.rows,
                    s.path.display(),
                    s.dropped,
                    args.scene,
                    s.path.display()
                ),
            );
        }
        Some(s)
    } else {
        None
    };
    let last = haptic.state().latest();
    if args.json {
        let summary = serde_json::json!({
            "scene": scene.name,
            "rate_hz": args.rate,
            "frames": last.frame + 1,
            "overruns": last.overruns,
            "realtime_priority": haptic.realtime(),
            "worst_step_last_second_us": last.frame_us_max,
            "recording": recording.map(|r| serde_json::json!({
                "path": r.path.display().to_string(),
                "rows": r.rows,
                "dropped": r.dropped,
            })),
        });
        report(false, &summary.to_string());
    } else {
        report(
            false,
            &format!(
                "stopped after {} frames ({} overruns, worst step in the last second {:.0} µs)",
                last.frame + 1,
                last.overruns,
                last.frame_us_max
            ),
        );
    }
    Ok(())
}

/// Prints one line of the server's report on stdout, or stderr when `to_stderr`. A reader that
/// went away (`haptic6d serve … | head -1`) must not stop a server that drives a device, so
/// write errors are ignored rather than raised as `println!` would (a panic on a broken pipe).
fn report(to_stderr: bool, line: &str) {
    use std::io::Write;
    let _ = if to_stderr {
        writeln!(std::io::stderr(), "{line}")
    } else {
        writeln!(std::io::stdout(), "{line}")
    };
}
