//! The web server on loopback: the page and three.js routes, the scene JSON, and the WebSocket
//! (state stream, pose input, contacts on demand, recording), over the real render pipeline.

mod common;

use std::net::SocketAddr;
use std::sync::Arc;
use std::time::Duration;

use futures_util::{SinkExt, StreamExt};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio_tungstenite::tungstenite::Message;
use viewer::server::{self, WebParams};
use viewer::{HapticLoop, LoopParams, RenderSim};

async fn start(
    record_dir: &std::path::Path,
) -> (
    Arc<HapticLoop>,
    SocketAddr,
    tokio::sync::oneshot::Sender<()>,
) {
    let haptic = Arc::new(
        HapticLoop::spawn(
            RenderSim::new(&common::small_scene()).unwrap(),
            &LoopParams::default(),
        )
        .unwrap(),
    );
    let listener = server::bind("127.0.0.1:0".parse().unwrap()).await.unwrap();
    let addr = listener.local_addr().unwrap();
    let router = server::router(
        haptic.clone(),
        WebParams {
            record_dir: record_dir.to_path_buf(),
            ..WebParams::default()
        },
    );
    let (tx, rx) = tokio::sync::oneshot::channel::<()>();
    tokio::spawn(server::run(listener, router, async {
        let _ = rx.await;
    }));
    (haptic, addr, tx)
}

/// A bare HTTP/1.1 GET; returns (status code, body).
async fn get(addr: SocketAddr, path: &str) -> (u16, String) {
    let mut s = tokio::net::TcpStream::connect(addr).await.unwrap();
    let req = format!("GET {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n");
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
    let (_haptic, addr, stop) = start(dir.path()).await;
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
    let (haptic, addr, stop) = start(dir.path()).await;
    let (mut ws, _) = tokio_tungstenite::connect_async(format!("ws://{addr}/ws"))
        .await
        .unwrap();
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
