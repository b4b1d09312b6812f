//! The Haply device against a mock Inverse Service written from Haply's published protocol:
//! a WebSocket that sends the device inventory (a full state frame: an Inverse3 and a VerseGrip)
//! on connect, then one state frame per client message, and reads `set_cursor_force` commands.
//! Also a service that stops answering, one that reorders frames, one that sends malformed
//! frames, and one that closes the connection: the force goes to zero within the device
//! timeout, nothing panics, and no read or write waits on the service (each returns within
//! 50 ms even on a loaded machine: they only try a lock the service thread holds for a copy).

use std::net::SocketAddr;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use futures_util::{SinkExt, StreamExt};
use haply_device::{HaplyInverse3, HaplyParams};
use scene::device::{Device, Reading};
use serde_json::{json, Value};
use tokio_tungstenite::tungstenite::Message;

/// How the mock service behaves after the inventory.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Behaviour {
    /// One state frame per client message.
    Answers,
    /// Answers the first `n` messages, then keeps reading without answering.
    FallsSilentAfter(usize),
    /// Sends the frames of earlier messages now and then (positions jump back).
    Reorders,
    /// Every other answer is malformed (not JSON, wrong types, binary, empty).
    Malformed,
    /// Closes the connection after `n` messages.
    ClosesAfter(usize),
}

/// What the mock saw: the forces of the client's `set_cursor_force` commands, in order.
#[derive(Default)]
struct Seen {
    forces: Vec<[f64; 3]>,
    messages: usize,
}

/// The cursor position (m) of the mock's `n`-th state frame: coming down 10 µm per frame from
/// (0.01, -0.02, 0.05).
fn position(n: usize) -> [f64; 3] {
    [0.01, -0.02, 0.05 - 1e-5 * n as f64]
}

/// A state frame of the protocol: the Inverse3's state (cursor position, m) and the
/// VerseGrip's (orientation, a unit quaternion scalar-first; button). The first one carries
/// the devices' `config`, as the service's inventory does.
fn frame(n: usize, inventory: bool) -> String {
    let p = position(n);
    let half = 0.25f64; // a turn of 0.5 rad about z
    let mut inverse3 = json!({
        "device_id": "INV3-MOCK",
        "state": {
            "cursor_position": {"x": p[0], "y": p[1], "z": p[2]},
            "cursor_velocity": {"x": 0.0, "y": 0.0, "z": -0.01},
            "mode": "idle"
        },
        "status": {"calibrated": true, "in_use": true, "power_supply": true, "ready": true, "started": true}
    });
    let mut grip = json!({
        "device_id": "VG-MOCK",
        "state": {
            "orientation": {"w": half.cos(), "x": 0.0, "y": 0.0, "z": half.sin()},
            "button": n % 50 < 25
        },
        "status": {"ready": true}
    });
    if inventory {
        inverse3["config"] = serde_json::to_value(haply::device_model::DeviceConfig::default())
            .expect("the protocol's config serializes");
        grip["config"] = serde_json::to_value(haply::device_model::VGConfig::default())
            .expect("the protocol's config serializes");
    }
    json!({"session_id": 1, "inverse3": [inverse3], "verse_grip": [grip]}).to_string()
}

/// Starts the mock service on a free local port; returns its address and what it sees.
fn start_mock(behaviour: Behaviour) -> (SocketAddr, Arc<Mutex<Seen>>) {
    let seen = Arc::new(Mutex::new(Seen::default()));
    let (tx, rx) = std::sync::mpsc::channel();
    let s = Arc::clone(&seen);
    std::thread::spawn(move || {
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .unwrap();
        rt.block_on(async move {
            let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
            tx.send(listener.local_addr().unwrap()).unwrap();
            let Ok((stream, _)) = listener.accept().await else {
                return;
            };
            let Ok(mut ws) = tokio_tungstenite::accept_async(stream).await else {
                return;
            };
            if ws.send(Message::Text(frame(0, true).into())).await.is_err() {
                return;
            }
            let mut n = 0usize;
            while let Some(msg) = ws.next().await {
                let Ok(Message::Text(text)) = msg else {
                    continue;
                };
                n += 1;
                if let Ok(v) = serde_json::from_str::<Value>(text.as_str()) {
                    let f = &v["inverse3"][0]["commands"]["set_cursor_force"]["vector"];
                    if let (Some(x), Some(y), Some(z)) =
                        (f["x"].as_f64(), f["y"].as_f64(), f["z"].as_f64())
                    {
                        let mut s = s.lock().unwrap();
                        s.forces.push([x, y, z]);
                        s.messages = n;
                    }
                }
                let reply = match behaviour {
                    Behaviour::Answers => Some(Message::Text(frame(n, false).into())),
                    Behaviour::FallsSilentAfter(k) if n > k => None,
                    Behaviour::FallsSilentAfter(_) => Some(Message::Text(frame(n, false).into())),
                    Behaviour::Reorders => {
                        let back = if n.is_multiple_of(7) {
                            n.saturating_sub(5)
                        } else {
                            n
                        };
                        Some(Message::Text(frame(back, false).into()))
                    }
                    Behaviour::Malformed => Some(match n % 8 {
                        1 => Message::Text("{not json".into()),
                        3 => Message::Text(
                            json!({"inverse3": [{"device_id": 5, "state": 7}]})
                                .to_string()
                                .into(),
                        ),
                        5 => Message::Binary(vec![0xff, 0x00, 0x13].into()),
                        7 => Message::Text("".into()),
                        _ => Message::Text(frame(n, false).into()),
                    }),
                    Behaviour::ClosesAfter(k) if n >= k => {
                        let _ = ws.close(None).await;
                        return;
                    }
                    Behaviour::ClosesAfter(_) => Some(Message::Text(frame(n, false).into())),
                };
                if let Some(r) = reply {
                    if ws.send(r).await.is_err() {
                        return;
                    }
                }
            }
        });
    });
    let addr = rx.recv_timeout(Duration::from_secs(5)).unwrap();
    (addr, seen)
}

fn device_for(addr: SocketAddr) -> HaplyInverse3 {
    HaplyInverse3::new(HaplyParams {
        http_url: format!("http://{addr}"),
        ws_url: format!("ws://{addr}/"),
        connect_timeout: Duration::from_secs(5),
        period: Duration::from_millis(1),
        stale_after: Duration::from_millis(300),
    })
}

/// Steps `device` at about 1 kHz for `frames` frames, writing `force` each frame; returns the
/// poses read and the longest frame (s).
fn drive(device: &mut HaplyInverse3, frames: usize, force: [f64; 6]) -> (Vec<collide::Pose>, f64) {
    let mut poses = Vec::new();
    let mut longest = 0.0f64;
    let t0 = Instant::now();
    for i in 0..frames {
        let start = Instant::now();
        if let Reading::Pose(s) = device.read(i, t0.elapsed().as_secs_f64()) {
            assert!(s.pose.is_finite(), "{s:?}");
            poses.push(s.pose);
        }
        device.write_wrench(&force);
        longest = longest.max(start.elapsed().as_secs_f64());
        std::thread::sleep(Duration::from_micros(900));
    }
    (poses, longest)
}

#[test]
fn poses_come_in_and_forces_go_out() {
    let (addr, seen) = start_mock(Behaviour::Answers);
    let mut device = device_for(addr);
    assert_eq!(
        device.capabilities().axes,
        [true, true, true, false, false, false]
    );
    device.open().unwrap();
    let (poses, longest) = drive(&mut device, 400, [1.5, -0.5, 2.0, 30.0, 30.0, 30.0]);
    assert!(poses.len() > 50, "{} readings", poses.len());
    assert!(
        longest < 0.05,
        "a read or write took {longest} s: it must not wait on the service"
    );
    // Metres in, millimetres out; the VerseGrip's quaternion as the orientation.
    let last = poses.last().unwrap();
    let t = last.translation();
    assert!(
        (t.x - 10.0).abs() < 1e-3 && (t.y + 20.0).abs() < 1e-3,
        "{last:?}"
    );
    assert!(t.z < 50.0 && t.z > 40.0, "{last:?}");
    let r = last.rotation_matrix();
    assert!((r[(1, 0)].atan2(r[(0, 0)]) - 0.5).abs() < 1e-5, "{last:?}");
    // Coming down: later readings are lower.
    assert!(poses.first().unwrap().q[2] > last.q[2]);
    let forces = {
        let s = seen.lock().unwrap();
        assert!(s.messages > 50, "{} commands", s.messages);
        s.forces.clone()
    };
    let f = forces.last().unwrap();
    assert!(
        (f[0] - 1.5).abs() < 1e-6 && (f[1] + 0.5).abs() < 1e-6 && (f[2] - 2.0).abs() < 1e-6,
        "{f:?}"
    );
    // Closing leaves the device without force.
    device.close();
    let f = *seen.lock().unwrap().forces.last().unwrap();
    assert_eq!(f, [0.0; 3]);
    assert_eq!(device.status().1, None);
}

#[test]
fn a_silent_service_is_a_timeout_and_the_loop_keeps_its_rate() {
    let (addr, seen) = start_mock(Behaviour::FallsSilentAfter(100));
    let mut device = device_for(addr);
    device.open().unwrap();
    let (poses, longest) = drive(&mut device, 800, [1.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
    assert!(
        poses.len() >= 50 && poses.len() <= 101,
        "{} readings",
        poses.len()
    );
    assert!(longest < 0.05, "a read or write took {longest} s");
    // The service thread noticed and closed the connection; the device reads as silent.
    let (_, error) = device.status();
    assert!(
        error.as_deref().is_some_and(|e| e.contains("no state")),
        "{error:?}"
    );
    assert!(matches!(device.read(800, 1.0), Reading::Pending));
    device.close();
    assert!(seen.lock().unwrap().messages >= 100);
}

#[test]
fn reordered_malformed_and_closed_services_never_panic() {
    for behaviour in [
        Behaviour::Reorders,
        Behaviour::Malformed,
        Behaviour::ClosesAfter(60),
    ] {
        let (addr, _) = start_mock(behaviour);
        let mut device = device_for(addr);
        device.open().unwrap();
        let (poses, longest) = drive(&mut device, 500, [0.5, 0.5, 0.5, 0.0, 0.0, 0.0]);
        assert!(!poses.is_empty(), "{behaviour:?}");
        assert!(
            longest < 0.05,
            "{behaviour:?}: a read or write took {longest} s"
        );
        for p in &poses {
            let t = p.translation();
            assert!((t.x - 10.0).abs() < 1e-3, "{behaviour:?}: {p:?}");
        }
        if let Behaviour::ClosesAfter(_) = behaviour {
            assert!(
                device.status().1.is_some(),
                "{behaviour:?}: the closed service was not noticed"
            );
        }
        device.close();
    }
}

#[test]
fn no_service_is_a_one_line_error() {
    // A port nothing listens on.
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap();
    drop(listener);
    let mut device = device_for(addr);
    let e = device.open().unwrap_err();
    let msg = scene::error_chain(&e);
    assert!(
        msg.contains("Inverse Service") && !msg.contains('\n'),
        "{msg}"
    );
    assert!(matches!(device.read(0, 0.0), Reading::Pending));
}
