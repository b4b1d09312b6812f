//! The UDP device bridge on loopback (127.0.0.1 only): pose in, wrench out, sequence numbers,
//! ownership, and the timeout that zeroes force when a client stops sending.

mod common;

use std::net::UdpSocket;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use viewer::protocol::{self, flags, Header, Kind, PoseMsg, POSE_LEN};
use viewer::{BridgeClient, BridgeParams, HapticLoop, LoopParams, UdpBridge};

fn start(timeout_ms: u64) -> (HapticLoop, UdpBridge) {
    let haptic = HapticLoop::spawn(common::Floor::new(), &LoopParams::default()).unwrap();
    let bridge = UdpBridge::spawn(
        &BridgeParams {
            addr: "127.0.0.1:0".parse().unwrap(),
            timeout: Duration::from_millis(timeout_ms),
        },
        haptic.input().clone(),
        haptic.state().clone(),
    )
    .unwrap();
    (haptic, bridge)
}

/// Sends `q` every millisecond until a WRENCH acknowledging a pose that the loop has applied
/// (not released) arrives, or 3 s pass.
fn drive_until_wrench(client: &mut BridgeClient, q: [f64; 6]) -> protocol::WrenchMsg {
    drive(client, q).0
}

/// As [`drive_until_wrench`], also returning the instant just before the last POSE was sent.
fn drive(client: &mut BridgeClient, q: [f64; 6]) -> (protocol::WrenchMsg, Instant) {
    let end = Instant::now() + Duration::from_secs(3);
    while Instant::now() < end {
        let sent = Instant::now();
        client.send_pose(q).unwrap();
        std::thread::sleep(Duration::from_millis(1));
        if let Some(w) = client.poll().unwrap() {
            if w.header.flags & flags::RELEASED == 0 && w.force[2] != 0.0 {
                return (w, sent);
            }
        }
    }
    panic!("no applied wrench within 3 s");
}

#[test]
fn pose_in_wrench_out_pushes_the_device_out_of_the_floor() {
    let (haptic, bridge) = start(200);
    let mut client =
        BridgeClient::connect(bridge.local_addr(), Duration::from_millis(200)).unwrap();
    let w = drive_until_wrench(&mut client, [1.0, 2.0, -5.0, 0.0, 0.0, 0.0]);
    // The floor's god-object sits at z = 0: force = kt * (0 - (-5)) = +5 N along z.
    assert!((w.force[2] - 5.0 * common::KT).abs() < 1e-12, "{w:?}");
    assert_eq!(w.force[0], 0.0);
    assert_eq!(w.graphic[2], 0.0);
    assert_eq!(w.pairs, 1);
    assert!(w.header.flags & flags::CONTACT != 0);
    assert!(w.header.ack >= 1 && w.header.ack <= client_seq_upper_bound());
    let (f, _) = client.wrench(Instant::now());
    assert!((f[2] - 5.0).abs() < 1e-12);
    assert!(client.round_trip().is_some());
    let s = haptic.state().latest();
    assert_eq!(s.source, viewer::InputSource::Udp as u8);
    assert_eq!(s.device[2], -5.0);
    assert!(bridge.stats().accepted.load(Ordering::Relaxed) >= 1);
}

fn client_seq_upper_bound() -> u32 {
    // drive_until_wrench sends at most ~3000 poses.
    10_000
}

#[test]
fn client_that_stops_sending_gets_zero_force_after_the_timeout() {
    let (haptic, bridge) = start(100);
    let mut client =
        BridgeClient::connect(bridge.local_addr(), Duration::from_millis(100)).unwrap();
    let (_, last_send) = drive(&mut client, [0.0, 0.0, -8.0, 0.0, 0.0, 0.0]);
    let s = haptic.state().latest();
    assert!(s.force[2] > 7.9, "force while the client sends: {s:?}");
    assert!(!s.released);

    // The client goes silent. Within the timeout plus a few frames, the loop must release the
    // device: held at the graphic pose, zero force, zero torque.
    let deadline = last_send + Duration::from_millis(100 + 500);
    let released = loop {
        let s = haptic.state().latest();
        if s.released {
            break s;
        }
        assert!(
            Instant::now() < deadline,
            "not released 600 ms after the last POSE"
        );
        std::thread::sleep(Duration::from_millis(2));
    };
    let silent_for = last_send.elapsed();
    assert!(
        silent_for >= Duration::from_millis(100),
        "released after {silent_for:?}, before the 100 ms timeout"
    );
    assert_eq!(released.force, [0.0; 3]);
    assert_eq!(released.torque, [0.0; 3]);
    assert_eq!(released.device, released.graphic);
    // The bridge noticed and freed itself for another client.
    let end = Instant::now() + Duration::from_secs(1);
    while bridge.stats().timeouts.load(Ordering::Relaxed) == 0 {
        assert!(Instant::now() < end, "bridge never counted the timeout");
        std::thread::sleep(Duration::from_millis(5));
    }
    // The client side also renders zero once its own timeout passes without a WRENCH.
    let (f, t) = client.wrench(Instant::now() + Duration::from_millis(150));
    assert_eq!((f, t), ([0.0; 3], [0.0; 3]));
}

fn raw_pose(seq: u32, q: [f64; 6]) -> [u8; POSE_LEN] {
    let mut buf = [0u8; POSE_LEN];
    PoseMsg {
        header: Header {
            kind: Kind::Pose,
            flags: 0,
            seq,
            ack: 0,
            time_us: 0,
        },
        q,
    }
    .encode(&mut buf);
    buf
}

#[test]
fn stale_duplicate_and_malformed_datagrams_are_dropped() {
    let (haptic, bridge) = start(500);
    let sock = UdpSocket::bind("127.0.0.1:0").unwrap();
    sock.set_read_timeout(Some(Duration::from_secs(2))).unwrap();
    let server = bridge.local_addr();
    let mut reply = [0u8; 256];

    sock.send_to(&raw_pose(10, [0.0, 0.0, -3.0, 0.0, 0.0, 0.0]), server)
        .unwrap();
    let (n, _) = sock.recv_from(&mut reply).unwrap();
    let protocol::Message::Wrench(w) = protocol::decode(&reply[..n]).unwrap() else {
        panic!("not a wrench")
    };
    assert_eq!(w.header.ack, 10);

    // Older and duplicate sequence numbers: dropped, no reply, pose unchanged.
    sock.send_to(&raw_pose(9, [0.0, 0.0, -50.0, 0.0, 0.0, 0.0]), server)
        .unwrap();
    sock.send_to(&raw_pose(10, [0.0, 0.0, -60.0, 0.0, 0.0, 0.0]), server)
        .unwrap();
    // Garbage.
    sock.send_to(b"hello, bridge", server).unwrap();
    // A newer one is applied and answered.
    sock.send_to(&raw_pose(11, [0.0, 0.0, -4.0, 0.0, 0.0, 0.0]), server)
        .unwrap();
    let (n, _) = sock.recv_from(&mut reply).unwrap();
    let protocol::Message::Wrench(w) = protocol::decode(&reply[..n]).unwrap() else {
        panic!("not a wrench")
    };
    assert_eq!(
        w.header.ack, 11,
        "the reply must acknowledge the newest pose"
    );
    assert_eq!(bridge.stats().stale.load(Ordering::Relaxed), 2);
    assert_eq!(bridge.stats().malformed.load(Ordering::Relaxed), 1);
    assert_eq!(haptic.input().last().pose.q[2], -4.0);
}

#[test]
fn a_second_client_is_refused_while_the_first_is_live_and_bye_frees_the_bridge() {
    let (haptic, bridge) = start(2000);
    let mut first = BridgeClient::connect(bridge.local_addr(), Duration::from_millis(500)).unwrap();
    drive_until_wrench(&mut first, [0.0, 0.0, -2.0, 0.0, 0.0, 0.0]);

    let mut second =
        BridgeClient::connect(bridge.local_addr(), Duration::from_millis(500)).unwrap();
    second.send_pose([0.0, 0.0, -9.0, 0.0, 0.0, 0.0]).unwrap();
    let end = Instant::now() + Duration::from_secs(2);
    let w = loop {
        if let Some(w) = second.poll().unwrap() {
            break w;
        }
        assert!(Instant::now() < end, "no answer to the second client");
        std::thread::sleep(Duration::from_millis(1));
    };
    assert!(w.header.flags & flags::BUSY != 0);
    assert_eq!(w.force, [0.0; 3]);
    assert_eq!(second.wrench(Instant::now()), ([0.0; 3], [0.0; 3]));
    assert_eq!(haptic.input().last().pose.q[2], -2.0);

    // BYE releases at once (well before the 2 s timeout) and lets the second client in.
    first.bye().unwrap();
    let end = Instant::now() + Duration::from_millis(500);
    while !haptic.state().latest().released {
        assert!(Instant::now() < end, "BYE did not release the device");
        std::thread::sleep(Duration::from_millis(2));
    }
    let w = drive_until_wrench(&mut second, [0.0, 0.0, -9.0, 0.0, 0.0, 0.0]);
    assert!((w.force[2] - 9.0).abs() < 1e-12);
}

#[test]
fn a_probe_reports_the_graphic_pose_without_driving_the_tool() {
    let (haptic, bridge) = start(200);
    let mut client =
        BridgeClient::connect(bridge.local_addr(), Duration::from_millis(200)).unwrap();
    let seq = client.probe().unwrap();
    let end = Instant::now() + Duration::from_secs(2);
    let w = loop {
        if let Some(w) = client.poll().unwrap() {
            break w;
        }
        assert!(Instant::now() < end, "no answer to the probe");
        std::thread::sleep(Duration::from_millis(1));
    };
    assert_eq!(w.header.ack, seq);
    assert!(w.header.flags & flags::RELEASED != 0);
    assert_eq!(
        w.graphic,
        [0.0, 0.0, 10.0, 0.0, 0.0, 0.0],
        "the Floor's start pose"
    );
    assert_eq!(w.force, [0.0; 3]);
    std::thread::sleep(Duration::from_millis(20));
    let s = haptic.state().latest();
    assert!(
        s.released && s.source == 0,
        "a probe must not drive the tool: {s:?}"
    );
    assert_eq!(bridge.stats().accepted.load(Ordering::Relaxed), 0);
}
