//! `haptic6d serve [SCENE]`: the interactive viewer. The haptic loop (render's god-object step
//! and safety filter) runs at 1 kHz on its own thread; a web server shows the scene live and
//! takes the device pose from the page (mouse, keys, gamepad) or from the UDP device bridge.

use std::net::{IpAddr, SocketAddr};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use crate::run::load_scene;
use anyhow::{bail, Context, Result};
use clap::Args;
use render::cache::TreeCache;
use viewer::server::{self, WebParams};
use viewer::{BridgeParams, HapticLoop, LoopParams, RenderSim, UdpBridge};

/// Arguments of `haptic6d serve`.
#[derive(Args, Debug)]
pub struct ServeArgs {
    /// Built-in scene (`bunny`, `spline`) or a scene file (.toml).
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
    /// A UDP device silent this long is released (zero force), ms.
    #[arg(long, default_value_t = viewer::protocol::DEFAULT_TIMEOUT_MS)]
    pub udp_timeout_ms: u64,
    /// Record the device trajectory of the whole session to this CSV
    /// (`t,x,y,z,gamma,beta,alpha`; replay with `haptic6d run SCENE --trajectory FILE`).
    #[arg(long, value_name = "FILE.csv")]
    pub record: Option<PathBuf>,
    /// Directory for recordings started from the page.
    #[arg(long, default_value = ".")]
    pub record_dir: PathBuf,
    /// Haptic rate, Hz.
    #[arg(long, default_value_t = 1000.0)]
    pub rate: f64,
    /// Run the haptic thread with real-time priority (`SCHED_FIFO` at this priority, 1-99;
    /// best effort: needs the privilege, and a step that overruns then competes hard with the
    /// page and the server on a small machine).
    #[arg(long, value_name = "PRIORITY")]
    pub rt_priority: Option<i32>,
    /// State stream rate to the page, Hz.
    #[arg(long, default_value_t = 60.0)]
    pub display_hz: f64,
    /// Stop after this many seconds (default: run until Ctrl-C).
    #[arg(long)]
    pub duration: Option<f64>,
    /// Print a machine-readable summary (JSON) on stdout when the server stops.
    #[arg(long)]
    pub json: bool,
}

/// Runs `haptic6d serve`.
pub fn run(args: ServeArgs) -> Result<()> {
    if let Some(d) = args.duration {
        if !(d.is_finite() && d > 0.0) {
            bail!("--duration must be a positive number of seconds, got {d}");
        }
    }
    let cache = TreeCache::from_env();
    let scene = load_scene(&args.scene, &cache)
        .with_context(|| format!("cannot load scene `{}`", args.scene))?;
    let sim = RenderSim::new(&scene).context("cannot set up the haptic step")?;
    let haptic = HapticLoop::spawn(
        sim,
        &LoopParams {
            rate_hz: args.rate,
            rt_priority: args.rt_priority,
            ..LoopParams::default()
        },
    )?;
    let haptic = Arc::new(haptic);
    if let Some(path) = &args.record {
        haptic.start_recording(path)?;
    }
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
    let params = WebParams {
        display_hz: args.display_hz,
        record_dir: args.record_dir.clone(),
    };
    let duration = args.duration;
    let json = args.json;
    // With --json, stdout carries only the final summary; the startup lines go to stderr.
    let say = move |line: String| {
        if json {
            eprintln!("{line}");
        } else {
            println!("{line}");
        }
    };
    runtime.block_on(async {
        let listener = server::bind(SocketAddr::new(args.bind, args.port)).await?;
        let local = listener
            .local_addr()
            .context("cannot read the bound address")?;
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
        if let Some(p) = args.rt_priority {
            // The thread sets its priority as it starts; give it a moment before reporting.
            tokio::time::sleep(Duration::from_millis(50)).await;
            say(if haptic.realtime() {
                format!("haptic thread: SCHED_FIFO priority {p}")
            } else {
                format!("haptic thread: SCHED_FIFO priority {p} refused (no privilege?); normal priority")
            });
        }
        let router = server::router(haptic.clone(), params);
        let shutdown = async move {
            match duration {
                Some(d) => tokio::time::sleep(Duration::from_secs_f64(d)).await,
                None => {
                    let _ = tokio::signal::ctrl_c().await;
                }
            }
        };
        server::run(listener, router, shutdown).await?;
        anyhow::Ok(())
    })?;
    if let Some(b) = bridge {
        b.shutdown();
    }
    let recording = if haptic.recording_path().is_some() {
        let s = haptic.stop_recording()?;
        if !args.json {
            println!(
                "recorded {} frames to {} ({} dropped); replay: haptic6d run {} --trajectory {}",
                s.rows,
                s.path.display(),
                s.dropped,
                args.scene,
                s.path.display()
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
        println!("{summary}");
    } else {
        println!(
            "stopped after {} frames ({} overruns, worst step in the last second {:.0} µs)",
            last.frame + 1,
            last.overruns,
            last.frame_us_max
        );
    }
    Ok(())
}
