//! A device program for the haptic6d UDP bridge (protocol v2, docs/VIEWER.md), standing in for
//! a real device SDK loop (OpenHaptics, Force Dimension, libnifalcon): it learns where the tool
//! is (a PROBE), opens a session (HELLO), then streams POSEs at 1 kHz moving the tool along one axis and back
//! (a raised cosine), and renders the WRENCHes it gets back — here it prints them and keeps
//! round-trip statistics. With no WRENCH for `--timeout` ms it renders zero force.
//!
//! Run against a server: `haptic6d serve bunny` in one terminal, then
//! `cargo run --release -p viewer --example udp_client -- --axis y --seconds 6`.
//!
//! Options: `--server ADDR` (127.0.0.1:8081), `--axis x|y|z` (y), `--distance MM` (signed; default 80 mm
//! toward the world origin, where the built-in scenes put the object),
//! `--seconds S` (6), `--rate HZ` (1000), `--timeout MS` (100), `--ping N` (0: instead of
//! moving, send N PROBEs one at a time and report the raw loopback round trip).

use std::net::SocketAddr;
use std::time::{Duration, Instant};

use viewer::protocol::flags;
use viewer::BridgeClient;

struct Opts {
    server: SocketAddr,
    axis: usize,
    distance: Option<f64>,
    seconds: f64,
    rate: f64,
    timeout_ms: u64,
    ping: usize,
}

fn parse() -> Result<Opts, String> {
    let mut o = Opts {
        server: "127.0.0.1:8081".parse().map_err(|e| format!("{e}"))?,
        axis: 1,
        distance: None,
        seconds: 6.0,
        rate: 1000.0,
        timeout_ms: 100,
        ping: 0,
    };
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut i = 0;
    while i < args.len() {
        let v = args
            .get(i + 1)
            .ok_or_else(|| format!("{} needs a value", args[i]))?;
        let num = |v: &str| v.parse::<f64>().map_err(|e| format!("{}: {e}", args[i]));
        match args[i].as_str() {
            "--server" => o.server = v.parse().map_err(|e| format!("--server: {e}"))?,
            "--axis" => {
                o.axis = match v.as_str() {
                    "x" => 0,
                    "y" => 1,
                    "z" => 2,
                    _ => return Err("--axis must be x, y or z".into()),
                }
            }
            "--distance" => o.distance = Some(num(v)?),
            "--seconds" => o.seconds = num(v)?,
            "--rate" => o.rate = num(v)?,
            "--timeout" => o.timeout_ms = num(v)? as u64,
            "--ping" => o.ping = num(v)? as usize,
            other => return Err(format!("unknown option {other} (see the file's header)")),
        }
        i += 2;
    }
    if !(o.rate > 0.0 && o.seconds > 0.0) {
        return Err("--rate and --seconds must be positive".into());
    }
    Ok(o)
}

fn percentile(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    sorted[((sorted.len() - 1) as f64 * p).round() as usize]
}

fn main() {
    let o = match parse() {
        Ok(o) => o,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(2);
        }
    };
    let timeout = Duration::from_millis(o.timeout_ms);
    let mut client = match BridgeClient::connect(o.server, timeout) {
        Ok(c) => c,
        Err(e) => {
            eprintln!("error: cannot open a UDP socket: {e}");
            std::process::exit(1);
        }
    };

    // Where is the tool? Probe until the server answers (2 s).
    let t_probe = Instant::now();
    let start = loop {
        let _ = client.probe();
        std::thread::sleep(Duration::from_millis(20));
        if let Ok(Some(w)) = client.poll() {
            break w.graphic;
        }
        if t_probe.elapsed() > Duration::from_secs(2) {
            eprintln!(
                "error: no answer from a haptic6d bridge at {} (is `haptic6d serve` running?)",
                o.server
            );
            std::process::exit(1);
        }
    };
    if o.ping > 0 {
        ping(&mut client, o.ping);
        return;
    }
    match client.open_session(Duration::from_secs(1)) {
        Ok(true) => {}
        Ok(false) => {
            eprintln!(
                "error: the bridge at {} did not grant a session (another device program owns it?)",
                o.server
            );
            std::process::exit(1);
        }
        Err(e) => {
            eprintln!("error: cannot send HELLO: {e}");
            std::process::exit(1);
        }
    }
    let distance = o
        .distance
        .unwrap_or(if start[o.axis] > 0.0 { -80.0 } else { 80.0 });
    println!(
        "tool at {start:?}; moving {} mm along {} and back over {} s",
        distance,
        ["x", "y", "z"][o.axis],
        o.seconds
    );

    let period = Duration::from_secs_f64(1.0 / o.rate);
    let t0 = Instant::now();
    let mut next = t0;
    let mut rtt_us = Vec::new();
    let mut last_print = t0;
    let mut max_force = 0.0f64;
    let mut frames = 0u64;
    let mut zero_frames = 0u64;
    loop {
        let t = t0.elapsed().as_secs_f64();
        if t > o.seconds {
            break;
        }
        // Raised cosine: 0 -> distance -> 0.
        let s = 0.5 * (1.0 - (2.0 * std::f64::consts::PI * t / o.seconds).cos());
        let mut q = start;
        q[o.axis] += distance * s;
        if let Err(e) = client.send_pose(q) {
            eprintln!("warning: send failed: {e}");
        }
        if let Ok(Some(_)) = client.poll() {
            if let Some(r) = client.round_trip() {
                rtt_us.push(r.as_secs_f64() * 1e6);
            }
        }
        if !client.has_session() {
            // Timed out (e.g. this program stalled): the server dropped the session. A real
            // device program would re-engage deliberately; here, open a new one (the force
            // ramps up from zero again).
            let _ = client.hello();
        }
        // What a device loop would command to its motors:
        let (force, torque) = client.wrench(Instant::now());
        let f = force.iter().map(|v| v * v).sum::<f64>().sqrt();
        max_force = max_force.max(f);
        frames += 1;
        if f == 0.0 {
            zero_frames += 1;
        }
        if last_print.elapsed() > Duration::from_millis(250) {
            last_print = Instant::now();
            let fl = client.last().map_or(0, |(_, w)| w.header.flags);
            println!(
                "t {t:5.2} s  q[{}] {:8.2} mm  F ({:7.2} {:7.2} {:7.2}) N  T ({:8.1} {:8.1} {:8.1}) N·mm  pairs {:3}{}",
                o.axis,
                q[o.axis],
                force[0], force[1], force[2],
                torque[0], torque[1], torque[2],
                client.last().map_or(0, |(_, w)| w.pairs),
                if fl & flags::RELEASED != 0 { "  (released)" } else { "" }
            );
        }
        next += period;
        let now = Instant::now();
        if next > now {
            std::thread::sleep(next - now);
        } else {
            next = now;
        }
    }
    let _ = client.bye();
    rtt_us.sort_by(f64::total_cmp);
    println!(
        "{frames} frames in {:.2} s ({:.0} Hz); largest |F| {max_force:.2} N; zero-force frames {zero_frames}",
        t0.elapsed().as_secs_f64(),
        frames as f64 / t0.elapsed().as_secs_f64()
    );
    println!(
        "round trip (POSE sent -> WRENCH received) over {} replies: p50 {:.0} µs, p99 {:.0} µs, max {:.0} µs",
        rtt_us.len(),
        percentile(&rtt_us, 0.5),
        percentile(&rtt_us, 0.99),
        rtt_us.last().copied().unwrap_or(f64::NAN)
    );
}

/// Sends `n` PROBEs one at a time, each waiting (spinning) for its answer; prints the raw
/// POSE-to-WRENCH round trip (µs).
fn ping(client: &mut BridgeClient, n: usize) {
    let mut rtt_us = Vec::with_capacity(n);
    let mut lost = 0;
    for _ in 0..n {
        let t = Instant::now();
        let seq = client.probe().unwrap_or(0);
        loop {
            match client.poll() {
                Ok(Some(w)) if w.header.ack == seq => {
                    rtt_us.push(t.elapsed().as_secs_f64() * 1e6);
                    break;
                }
                _ if t.elapsed() > Duration::from_millis(100) => {
                    lost += 1;
                    break;
                }
                _ => std::hint::spin_loop(),
            }
        }
    }
    rtt_us.sort_by(f64::total_cmp);
    println!(
        "ping: {} answered, {lost} lost; round trip p50 {:.1} µs, p99 {:.1} µs, max {:.1} µs",
        rtt_us.len(),
        percentile(&rtt_us, 0.5),
        percentile(&rtt_us, 0.99),
        rtt_us.last().copied().unwrap_or(f64::NAN)
    );
}
