//! The web server on loopback: the page and three.js routes, the scene JSON, and the WebSocket
//! (state stream, pose input, contacts on demand, recording), over the real render pipeline;
//! and its security: Host and Origin checks (DNS rebinding, cross-origin pages), one page
//! owning the device at a time, recording from the page only when allowed.

mod common;

use std::net::SocketAddr;
use std::sync::Arc;
use std::time::Duration;

use futures_util::{SinkExt, StreamExt};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio_tungstenite::tungstenite::Message;
use viewer::server::{self, WebParams};
use viewer::{HapticLoop, Pacing, SceneSim};

async fn start(
    record_dir: &std::path::Path,
    allow_page_recording: bool,
) -> (
    Arc<HapticLoop>,
    SocketAddr,
    tokio::sync::oneshot::Sender<()>,
) {
    let haptic = Arc::new(
        HapticLoop::spawn(
            SceneSim::new(&common::small_scene()).unwrap(),
            &Pacing::default(),
        )
        .unwrap(),
    );
    let listener = server::bind("127.0.0.1:0".parse().unwrap()).await.unwrap();
    let addr = listener.local_addr().unwrap();
    let router = server::router(
        haptic.clone(),
        WebParams {
            record_dir: record_dir.to_path_buf(),
            addr,
            allow_page_recording,
            ..WebParams::default()
        },
    )
    .unwrap();
    let (tx, rx) = tokio::sync::oneshot::channel::<()>();
    tokio::spawn(server::run(listener, router, async {
        let _ = rx.await;
    }));
    (haptic, addr, tx)
}

/// A bare HTTP/1.1 GET; returns (status code, body).
async fn get(addr: SocketAddr, path: &str) -> (u16, String) {
    get_as(addr, path, &addr.to_string(), None).await
}

/// A bare HTTP/1.1 GET with this `Host` and, if given, `Origin`; returns (status code, body).
async fn get_as(addr: SocketAddr, path: &str, host: &str, origin: Option<&str>) -> (u16, String) {
    let mut s = tokio::net::TcpStream::connect(addr).await.unwrap();
    let origin = origin
        .map(|o| format!("Origin: {o}\r\n"))
        .unwrap_or_default();
    let req = format!("GET {path} HTTP/1.1\r\nHost: {host}\r\n{origin}Connection: close\r\n\r\n");
    s.write_all(req.as_bytes()).await.unwrap();
    let mut buf = Vec::new();
    s.read_to_end(&mut buf).await.unwrap();
    let text = String::from_utf8_lossy(&buf).to_string();
    let status: u16 = text[9..12].parse().unwrap();
    let body = text
        .split_once("\r\n\r\n")
        .map(|x| x.1.to_string())
        .unwrap_or_default();
    (status, body)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn page_scene_and_three_routes() {
    let dir = tempfile::tempdir().unwrap();
    let (_haptic, addr, stop) = start(dir.path(), false).await;
    let (code, body) = get(addr, "/").await;
    assert_eq!(code, 200);
    assert!(body.contains("importmap") && body.contains("/vendor/three/three.module.js"));
    let (code, body) = get(addr, "/app.js").await;
    assert_eq!(code, 200);
    assert!(body.contains("from 'three'"));
    let (code, body) = get(addr, "/api/scene").await;
    assert_eq!(code, 200);
    let scene: serde_json::Value = serde_json::from_str(&body).unwrap();
    let pos = scene["tool"]["positions"].as_array().unwrap();
    let idx = scene["tool"]["indices"].as_array().unwrap();
    assert!(!pos.is_empty() && pos.len().is_multiple_of(3) && idx.len().is_multiple_of(3));
    assert!(idx
        .iter()
        .all(|i| (i.as_u64().unwrap() as usize) < pos.len() / 3));
    assert_eq!(scene["objects"].as_array().unwrap().len(), 1);
    assert_eq!(scene["start"][2], 30.0);
    // three.js comes from the binary (no `npm ci`): the module and the core it imports.
    let (code, module) = get(addr, "/vendor/three/three.module.js").await;
    assert_eq!(code, 200);
    assert!(module.contains("from './three.core.js'"));
    let (code, core) = get(addr, "/vendor/three/three.core.js").await;
    assert_eq!(code, 200);
    assert!(core.contains("const REVISION = '"));
    // Only those two names are served: nothing else, nothing from the file system.
    for path in [
        "/vendor/three/..%2F..%2F..%2FCargo.toml",
        "/vendor/three/.hidden.js",
        "/vendor/three/three.webgpu.js",
        "/node_modules/three/build/three.module.js",
    ] {
        let (code, _) = get(addr, path).await;
        assert_eq!(code, 404, "{path}");
    }
    let (code, body) = get(addr, "/api/state").await;
    assert_eq!(code, 200);
    let st: serde_json::Value = serde_json::from_str(&body).unwrap();
    assert_eq!(st["type"], "state");
    assert_eq!(st["released"], true);
    let _ = stop.send(());
}

/// The next message of type `kind`, skipping others.
async fn next_of<S>(ws: &mut S, kind: &str) -> serde_json::Value
where
    S: StreamExt<Item = Result<Message, tokio_tungstenite::tungstenite::Error>> + Unpin,
{
    loop {
        let m = next_json(ws).await;
        if m["type"] == kind {
            return m;
        }
    }
}

async fn next_json<S>(ws: &mut S) -> serde_json::Value
where
    S: StreamExt<Item = Result<Message, tokio_tungstenite::tungstenite::Error>> + Unpin,
{
    loop {
        let m = tokio::time::timeout(Duration::from_secs(5), ws.next())
            .await
            .expect("no message within 5 s")
            .unwrap()
            .unwrap();
        if let Message::Text(t) = m {
            return serde_json::from_str(t.as_str()).unwrap();
        }
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn websocket_streams_state_takes_poses_and_records() {
    let dir = tempfile::tempdir().unwrap();
    let (haptic, addr, stop) = start(dir.path(), true).await;
    let (mut ws, _) = tokio_tungstenite::connect_async(format!("ws://{addr}/ws"))
        .await
        .unwrap();
    let role = next_json(&mut ws).await;
    assert_eq!(role["type"], "role");
    assert_eq!(role["role"], "owner", "the only page owns the device");
    assert_eq!(role["page_recording"], true);
    let first = next_json(&mut ws).await;
    assert_eq!(first["type"], "state");
    assert_eq!(first["device"][2], 30.0);

    // Stream rate: ~60 Hz, so 30 messages take about half a second.
    let t0 = std::time::Instant::now();
    for _ in 0..30 {
        next_json(&mut ws).await;
    }
    let dt = t0.elapsed();
    assert!(
        dt > Duration::from_millis(300) && dt < Duration::from_secs(3),
        "30 states in {dt:?}"
    );

    // Walk the device into the floor; the stream reports the pose, an upward force, no penetration.
    let rec = |on: bool| {
        Message::Text(
            serde_json::json!({"type": "record", "on": on})
                .to_string()
                .into(),
        )
    };
    ws.send(rec(true)).await.unwrap();
    for k in 0..=40 {
        let q = [0.0, 0.0, 25.0 - k as f64, 0.0, 0.0, 0.0];
        let msg = serde_json::json!({"type": "pose", "q": q}).to_string();
        ws.send(Message::Text(msg.into())).await.unwrap();
        tokio::time::sleep(Duration::from_millis(3)).await;
    }
    ws.send(Message::Text(r#"{"type":"contacts","on":true}"#.into()))
        .await
        .unwrap();
    let mut notices = Vec::new();
    let s = loop {
        let m = next_json(&mut ws).await;
        if m["type"] != "state" {
            notices.push(m);
            continue;
        }
        if m["device"][2] == -15.0 && !m["contacts"].as_array().unwrap().is_empty() {
            break m;
        }
    };
    assert_eq!(s["source"], 1, "the page drives the device");
    assert!(s["force"][2].as_f64().unwrap() > 5.0, "{s}");
    assert!(s["penetration_mm"].as_f64().unwrap() < 0.05);
    assert!(s["recording"].as_bool().unwrap());
    assert!(
        notices.iter().any(|n| n["type"] == "recording"),
        "{notices:?}"
    );

    // Stop recording: the notice names the file, which holds the poses sent.
    ws.send(rec(false)).await.unwrap();
    let done = loop {
        let m = next_json(&mut ws).await;
        if m["type"] == "recording" && m["message"].as_str().unwrap().starts_with("recorded") {
            break m;
        }
    };
    let files: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    assert_eq!(files.len(), 1, "{done}");
    let text = std::fs::read_to_string(&files[0]).unwrap();
    assert!(text.starts_with("t,x,y,z,gamma,beta,alpha\n"));
    assert!(
        text.lines().any(|l| l.ends_with(",0,0,-15,0,0,0")),
        "the deepest pose is recorded"
    );
    assert!(done["message"]
        .as_str()
        .unwrap()
        .contains(&files[0].display().to_string()));

    // Bad input gets a one-line error, and the connection stays up.
    ws.send(Message::Text(r#"{"type":"pose","q":[1,2]}"#.into()))
        .await
        .unwrap();
    let err = loop {
        let m = next_json(&mut ws).await;
        if m["type"] == "error" {
            break m;
        }
    };
    assert!(err["message"].as_str().unwrap().contains("bad message"));
    assert_eq!(next_json(&mut ws).await["type"], "state");

    // Release: zero force at once.
    ws.send(Message::Text(r#"{"type":"release"}"#.into()))
        .await
        .unwrap();
    let end = std::time::Instant::now() + Duration::from_secs(5);
    while !haptic.state().latest().released {
        assert!(std::time::Instant::now() < end);
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    assert_eq!(haptic.state().latest().force, [0.0; 3]);
    // Drive again, then close the socket: the page lets go and withdraws its contacts request.
    let q = serde_json::json!({"type": "pose", "q": [0.0, 0.0, -5.0, 0.0, 0.0, 0.0]});
    ws.send(Message::Text(q.to_string().into())).await.unwrap();
    let end = std::time::Instant::now() + Duration::from_secs(5);
    while haptic.state().latest().source != 1 {
        assert!(std::time::Instant::now() < end, "page pose not applied");
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    drop(ws);
    let end = std::time::Instant::now() + Duration::from_secs(5);
    while !haptic.state().latest().released {
        assert!(
            std::time::Instant::now() < end,
            "closing the page did not release the tool"
        );
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    let end = std::time::Instant::now() + Duration::from_secs(5);
    while haptic.input().contacts_wanted() {
        assert!(
            std::time::Instant::now() < end,
            "contacts still requested after disconnect"
        );
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    let _ = stop.send(());
}

fn pose_msg(z: f64) -> Message {
    Message::Text(
        serde_json::json!({"type": "pose", "q": [0.0, 0.0, z, 0.0, 0.0, 0.0]})
            .to_string()
            .into(),
    )
}

/// A foreign Host (DNS rebinding) is refused on every route, and a page of
/// another origin cannot open the WebSocket; the served address and its own origin pass.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn foreign_host_and_origin_are_refused() {
    use tokio_tungstenite::tungstenite::client::IntoClientRequest;
    let dir = tempfile::tempdir().unwrap();
    let (haptic, addr, stop) = start(dir.path(), false).await;
    let port = addr.port();
    for path in ["/", "/api/state", "/api/scene", "/app.js", "/ws"] {
        let (code, body) = get_as(addr, path, &format!("evil.example:{port}"), None).await;
        assert_eq!(code, 403, "{path}: {body}");
        assert!(body.contains("evil.example"), "{body}");
    }
    let (code, _) = get_as(addr, "/api/state", &format!("localhost:{port}"), None).await;
    assert_eq!(code, 200);
    let (code, _) = get_as(addr, "/api/state", "127.0.0.1:1", None).await;
    assert_eq!(code, 403, "another port is another server");
    let own = format!("http://127.0.0.1:{port}");
    let (code, _) = get_as(addr, "/api/state", &addr.to_string(), Some(&own)).await;
    assert_eq!(code, 200);
    let (code, _) = get_as(
        addr,
        "/api/state",
        &addr.to_string(),
        Some("http://evil.example"),
    )
    .await;
    assert_eq!(code, 403);

    // The WebSocket upgrade from another origin: 403, nothing reaches the device.
    let mut req = format!("ws://{addr}/ws").into_client_request().unwrap();
    req.headers_mut()
        .insert("Origin", "http://evil.example".parse().unwrap());
    match tokio_tungstenite::connect_async(req).await {
        Err(tokio_tungstenite::tungstenite::Error::Http(r)) => assert_eq!(r.status(), 403),
        Err(e) => panic!("refused, but not with 403: {e}"),
        Ok(_) => panic!("a cross-origin page opened the WebSocket"),
    }
    // Its own origin may.
    let mut req = format!("ws://{addr}/ws").into_client_request().unwrap();
    req.headers_mut().insert("Origin", own.parse().unwrap());
    let (mut ws, _) = tokio_tungstenite::connect_async(req).await.unwrap();
    assert_eq!(next_of(&mut ws, "role").await["role"], "owner");
    ws.send(pose_msg(20.0)).await.unwrap();
    let end = std::time::Instant::now() + Duration::from_secs(5);
    while haptic.state().latest().device[2] != 20.0 {
        assert!(
            std::time::Instant::now() < end,
            "own-origin pose not applied"
        );
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    let _ = stop.send(());
}

/// Recording from the page is off unless allowed: the command is refused with
/// a notice and no file is created.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn page_recording_is_opt_in() {
    let dir = tempfile::tempdir().unwrap();
    let (haptic, addr, stop) = start(dir.path(), false).await;
    let (mut ws, _) = tokio_tungstenite::connect_async(format!("ws://{addr}/ws"))
        .await
        .unwrap();
    let role = next_of(&mut ws, "role").await;
    assert_eq!(role["page_recording"], false);
    for _ in 0..3 {
        ws.send(Message::Text(r#"{"type":"record","on":true}"#.into()))
            .await
            .unwrap();
        let e = next_of(&mut ws, "error").await;
        assert!(
            e["message"]
                .as_str()
                .unwrap()
                .contains("--allow-page-recording"),
            "{e}"
        );
    }
    assert!(!next_of(&mut ws, "state").await["recording"]
        .as_bool()
        .unwrap());
    assert!(haptic.recording_path().is_none());
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    let _ = stop.send(());
}

async fn wait_for<F: Fn(&viewer::FrameState) -> bool>(haptic: &HapticLoop, what: &str, f: F) {
    let end = std::time::Instant::now() + Duration::from_secs(5);
    while !f(&haptic.state().latest()) {
        assert!(std::time::Instant::now() < end, "{what}");
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
}

/// Page 1 holds the tool pressed into the floor; pages 2 and 3 open as
/// watchers (they get the state; their poses, release and reset are ignored); page 2 closing
/// leaves page 1's hold as it was; page 1 closing releases the tool and makes page 3 the owner,
/// whose poses then drive the device.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn one_page_owns_the_device_and_watchers_cannot_release_it() {
    let dir = tempfile::tempdir().unwrap();
    let (haptic, addr, stop) = start(dir.path(), false).await;
    let url = format!("ws://{addr}/ws");
    let (mut p1, _) = tokio_tungstenite::connect_async(&url).await.unwrap();
    assert_eq!(next_of(&mut p1, "role").await["role"], "owner");
    for k in 0..=40 {
        p1.send(pose_msg(25.0 - k as f64)).await.unwrap();
        tokio::time::sleep(Duration::from_millis(2)).await;
    }
    wait_for(&haptic, "page 1's hold", |s| {
        s.device[2] == -15.0 && s.source == 1 && s.force[2] > 5.0
    })
    .await;
    // Let the graphic tool settle on the floor.
    tokio::time::sleep(Duration::from_millis(400)).await;
    let held = haptic.state().latest().force;

    let (mut p2, _) = tokio_tungstenite::connect_async(&url).await.unwrap();
    let r2 = next_of(&mut p2, "role").await;
    assert_eq!(
        (r2["role"].as_str(), r2["ahead"].as_u64()),
        (Some("watcher"), Some(1))
    );
    let (mut p3, _) = tokio_tungstenite::connect_async(&url).await.unwrap();
    let r3 = next_of(&mut p3, "role").await;
    assert_eq!(
        (r3["role"].as_str(), r3["ahead"].as_u64()),
        (Some("watcher"), Some(2))
    );
    // A watcher sees the stream…
    let st = next_of(&mut p2, "state").await;
    assert_eq!(st["device"][2], -15.0);
    // …but cannot move, release or reset the tool.
    p2.send(pose_msg(10.0)).await.unwrap();
    for cmd in [r#"{"type":"release"}"#, r#"{"type":"reset"}"#] {
        p2.send(Message::Text(cmd.into())).await.unwrap();
        let e = next_of(&mut p2, "error").await;
        assert!(
            e["message"].as_str().unwrap().contains("another page"),
            "{e}"
        );
    }
    // Page 2 closes: page 1 still holds the tool, and nobody's role changed but page 3's rank.
    p2.close(None).await.unwrap();
    drop(p2);
    let r3 = next_of(&mut p3, "role").await;
    assert_eq!(
        (r3["role"].as_str(), r3["ahead"].as_u64()),
        (Some("watcher"), Some(1))
    );
    tokio::time::sleep(Duration::from_millis(100)).await;
    let s = haptic.state().latest();
    assert!(
        !s.released && s.source == 1,
        "page 1's hold was released: {s:?}"
    );
    assert_eq!(s.device[2], -15.0);
    assert!(
        (s.force[2] - held[2]).abs() < 0.5,
        "the force changed from {held:?} to {:?}",
        s.force
    );

    // Page 1 closes: the tool is released, page 3 becomes the owner and drives it.
    drop(p1);
    wait_for(&haptic, "page 1 closing did not release", |s| s.released).await;
    assert_eq!(next_of(&mut p3, "role").await["role"], "owner");
    p3.send(pose_msg(12.0)).await.unwrap();
    wait_for(&haptic, "page 3's pose not applied", |s| {
        s.source == 1 && s.device[2] == 12.0
    })
    .await;
    let _ = stop.send(());
}

/// While a physical device presses the tool into the floor, the page that holds the seat is
/// told it watches (`device: true`), and its reset and release are refused: the device's force
/// and the device pose stay as they were.
async fn the_page_watches_while_the_device_holds(
    haptic: &HapticLoop,
    addr: SocketAddr,
    source: u8,
) {
    wait_for(haptic, "the device pressing", |s| {
        s.source == source && !s.released && s.force[2] > 5.0
    })
    .await;
    let (mut page, _) = tokio_tungstenite::connect_async(format!("ws://{addr}/ws"))
        .await
        .unwrap();
    let role = next_of(&mut page, "role").await;
    assert_eq!(
        (role["role"].as_str(), role["device"].as_bool()),
        (Some("watcher"), Some(true)),
        "{role}"
    );
    // Let the filter's ramp finish, then take the hold.
    tokio::time::sleep(Duration::from_millis(300)).await;
    let held = haptic.state().latest();
    for cmd in [r#"{"type":"reset"}"#, r#"{"type":"release"}"#] {
        page.send(Message::Text(cmd.into())).await.unwrap();
    }
    // Every frame for the next 100 ms: still the device's, still pressing as hard.
    let end = std::time::Instant::now() + Duration::from_millis(100);
    while std::time::Instant::now() < end {
        let s = haptic.state().latest();
        assert!(!s.released && s.source == source, "{s:?}");
        assert!(
            s.force[2] > 0.8 * held.force[2],
            "the force dropped from {:.2} to {:.2} N",
            held.force[2],
            s.force[2]
        );
        assert_eq!(s.device, held.device, "the device pose moved");
        tokio::time::sleep(Duration::from_millis(1)).await;
    }
    // And the page is told why, once for each command.
    for _ in 0..2 {
        let e = tokio::time::timeout(Duration::from_secs(2), next_of(&mut page, "error"))
            .await
            .expect("no refusal within 2 s");
        assert!(
            e["message"].as_str().unwrap().contains("a device drives"),
            "{e}"
        );
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_page_cannot_reset_or_release_a_udp_device() {
    use std::sync::atomic::{AtomicBool, Ordering};
    let dir = tempfile::tempdir().unwrap();
    let (haptic, addr, stop) = start(dir.path(), false).await;
    let bridge = viewer::UdpBridge::spawn(
        &viewer::BridgeParams {
            addr: "127.0.0.1:0".parse().unwrap(),
            timeout: Duration::from_millis(500),
        },
        haptic.input().clone(),
        haptic.state().clone(),
    )
    .unwrap();
    // A device program holding the tool 15 mm into the floor, a POSE every millisecond.
    let done = Arc::new(AtomicBool::new(false));
    let program = {
        let (done, server) = (done.clone(), bridge.local_addr());
        std::thread::spawn(move || {
            let mut c = viewer::BridgeClient::connect(server, Duration::from_millis(500)).unwrap();
            assert!(c.open_session(Duration::from_secs(2)).unwrap());
            while !done.load(Ordering::Acquire) {
                c.send_pose([0.0, 0.0, -15.0, 0.0, 0.0, 0.0]).unwrap();
                let _ = c.poll();
                std::thread::sleep(Duration::from_millis(1));
            }
            c.bye().unwrap();
        })
    };
    the_page_watches_while_the_device_holds(&haptic, addr, 2).await;
    done.store(true, Ordering::Release);
    program.join().unwrap();
    let _ = stop.send(());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_page_cannot_reset_or_release_a_replayed_device() {
    let dir = tempfile::tempdir().unwrap();
    let (haptic, addr, stop) = start(dir.path(), false).await;
    // A replay that presses 15 mm into the floor and holds for 20 s.
    let samples = (0..20_000)
        .map(|i| scene::trajectory::TrajSample {
            t: i as f64 * 1e-3,
            q: [
                0.0,
                0.0,
                20.0 - 35.0 * (i as f64 / 300.0).min(1.0),
                0.0,
                0.0,
                0.0,
            ],
        })
        .collect();
    let bridge = viewer::DeviceBridge::spawn(
        Box::new(scene::device::ReplayDevice::new(
            scene::trajectory::Trajectory { samples },
        )),
        scene::device::DeviceSettings::default(),
        1000.0,
        haptic.input().clone(),
        haptic.state().clone(),
    )
    .unwrap();
    the_page_watches_while_the_device_holds(&haptic, addr, 4).await;
    bridge.stop();
    let _ = stop.send(());
}
