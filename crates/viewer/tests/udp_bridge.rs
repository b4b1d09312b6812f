//! The UDP device bridge on loopback (127.0.0.1 only): pose in, wrench out, sequence numbers,
//! sessions and ownership, the timeout that zeroes force when a client stops sending (and its
//! exact bound), stale datagrams after a timeout, and the soft start of a re-engagement.

mod common;

use std::net::UdpSocket;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use viewer::protocol::{self, flags, Header, Kind, PoseMsg, POSE_LEN};
use viewer::{BridgeClient, BridgeParams, HapticLoop, Pacing, SceneSim, UdpBridge};

fn bridge_for(haptic: &HapticLoop, timeout_ms: u64) -> UdpBridge {
    UdpBridge::spawn(
        &BridgeParams {
            addr: "127.0.0.1:0".parse().unwrap(),
            timeout: Duration::from_millis(timeout_ms),
        },
        haptic.input().clone(),
        haptic.state().clone(),
    )
    .unwrap()
}

fn start(timeout_ms: u64) -> (HapticLoop, UdpBridge) {
    let haptic = HapticLoop::spawn(common::Floor::new(), &Pacing::default()).unwrap();
    let bridge = bridge_for(&haptic, timeout_ms);
    (haptic, bridge)
}

/// A client with an open session.
fn session(bridge: &UdpBridge, timeout_ms: u64) -> BridgeClient {
    let mut c =
        BridgeClient::connect(bridge.local_addr(), Duration::from_millis(timeout_ms)).unwrap();
    assert!(
        c.open_session(Duration::from_secs(2)).unwrap(),
        "no session granted"
    );
    c
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
    let mut client = session(&bridge, 200);
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

/// The timeout's bound, stated exactly: a POSE keeps the device driven until the instant the
/// bridge received it plus `--udp-timeout-ms` (the command's `expires`). The loop checks it at
/// the start of every frame: every frame checked before `expires` is driven, the first frame
/// checked at or after it is released (zero force and torque, device held at the graphic pose).
/// So the device is released at most one haptic period (1 ms, plus the thread's wake-up delay)
/// after `expires`, and never before. Frames are stepped here by hand, so the bound is checked
/// frame by frame without depending on the scheduler.
#[test]
fn the_first_frame_checked_after_the_timeout_is_released_and_none_before() {
    let (handle, mut frames) =
        HapticLoop::manual(common::Floor::new(), &Pacing::default()).unwrap();
    let bridge = bridge_for(&handle, 100);
    let mut client = session(&bridge, 100);
    client.send_pose([0.0, 0.0, -8.0, 0.0, 0.0, 0.0]).unwrap();
    let end = Instant::now() + Duration::from_secs(2);
    while handle.input().last().source != viewer::InputSource::Udp {
        assert!(Instant::now() < end, "the POSE was not applied");
        std::thread::sleep(Duration::from_millis(1));
    }
    let cmd = handle.input().last();
    let expires = cmd.expires.expect("a UDP command expires");
    let (mut driven, mut released_at) = (0u32, None);
    while released_at.is_none() {
        assert!(
            Instant::now() < expires + Duration::from_secs(2),
            "never released"
        );
        let before = Instant::now();
        let s = frames.step();
        let after = Instant::now();
        if s.released {
            assert!(
                after >= expires,
                "released {:?} before the timeout",
                expires - after
            );
            assert_eq!((s.force, s.torque), ([0.0; 3], [0.0; 3]));
            assert_eq!(s.device, s.graphic);
            released_at = Some(before);
        } else {
            assert!(
                before < expires,
                "a frame starting {:?} after the timeout still drove the device",
                before - expires
            );
            assert!((s.force[2] - 8.0).abs() < 1e-12, "{:?}", s.force);
            driven += 1;
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    assert!(driven >= 50, "only {driven} frames driven in the 100 ms");
    // The next frames stay released (no refresh came).
    for _ in 0..5 {
        assert!(frames.step().released);
    }
    // The bridge ends the session once it notices; the client renders zero after its own
    // timeout without a WRENCH.
    let end = Instant::now() + Duration::from_secs(1);
    while bridge.stats().timeouts.load(Ordering::Relaxed) == 0 {
        assert!(Instant::now() < end, "bridge never counted the timeout");
        std::thread::sleep(Duration::from_millis(5));
    }
    let (f, t) = client.wrench(Instant::now() + Duration::from_millis(150));
    assert_eq!((f, t), ([0.0; 3], [0.0; 3]));
}

/// The same bound on the real haptic thread, observed from outside: released no earlier than
/// `expires`, and no later than `expires` + 50 ms (one 1 ms period plus the wake-up delays of
/// the haptic thread and of this poller on a shared machine; typically about 1 ms).
#[test]
fn client_that_stops_sending_gets_zero_force_after_the_timeout() {
    let (haptic, bridge) = start(100);
    let mut client = session(&bridge, 100);
    drive(&mut client, [0.0, 0.0, -8.0, 0.0, 0.0, 0.0]);
    let s = haptic.state().latest();
    assert!(s.force[2] > 7.9, "force while the client sends: {s:?}");
    assert!(!s.released);
    // The client goes silent; wait for the bridge to have handled the last POSE.
    std::thread::sleep(Duration::from_millis(5));
    let expires = haptic
        .input()
        .last()
        .expires
        .expect("a UDP command expires");
    let released = loop {
        let now = Instant::now();
        let s = haptic.state().latest();
        if s.released {
            assert!(
                now >= expires,
                "released {:?} before the timeout",
                expires - now
            );
            break s;
        }
        assert!(
            now < expires + Duration::from_millis(50),
            "not released 50 ms after the timeout"
        );
        std::thread::sleep(Duration::from_micros(200));
    };
    assert_eq!(released.force, [0.0; 3]);
    assert_eq!(released.torque, [0.0; 3]);
    assert_eq!(released.device, released.graphic);
}

fn raw_hello(seq: u32) -> [u8; protocol::HELLO_LEN] {
    let mut buf = [0u8; protocol::HELLO_LEN];
    protocol::encode_hello(seq, 0, &mut buf);
    buf
}

fn recv_wrench(sock: &UdpSocket) -> protocol::WrenchMsg {
    let mut reply = [0u8; 256];
    let (n, _) = sock.recv_from(&mut reply).expect("the bridge answers");
    match protocol::decode(&reply[..n]) {
        Ok(protocol::Message::Wrench(w)) => w,
        other => panic!("not a wrench: {other:?}"),
    }
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
    sock.send_to(&raw_hello(5), server).unwrap();
    let w = recv_wrench(&sock);
    assert_eq!(w.header.ack, 5);
    assert!(w.header.flags & flags::SESSION != 0);

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
    let mut first = session(&bridge, 500);
    drive_until_wrench(&mut first, [0.0, 0.0, -2.0, 0.0, 0.0, 0.0]);

    let mut second =
        BridgeClient::connect(bridge.local_addr(), Duration::from_millis(500)).unwrap();
    assert!(
        !second.open_session(Duration::from_secs(2)).unwrap(),
        "a second session was granted while the first is live"
    );
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
    assert!(second.open_session(Duration::from_secs(2)).unwrap());
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

/// After the owner times out, a POSE is never applied without a new session —
/// neither one 500 sequence numbers behind nor a fresh-looking one — and after a new HELLO only
/// POSEs newer than it are applied.
#[test]
fn after_a_timeout_no_pose_is_applied_until_a_new_session() {
    let (haptic, bridge) = start(50);
    let sock = UdpSocket::bind("127.0.0.1:0").unwrap();
    sock.set_read_timeout(Some(Duration::from_secs(2))).unwrap();
    let server = bridge.local_addr();
    sock.send_to(&raw_hello(1000), server).unwrap();
    assert!(recv_wrench(&sock).header.flags & flags::SESSION != 0);
    sock.send_to(&raw_pose(1001, [0.0, 0.0, -2.0, 0.0, 0.0, 0.0]), server)
        .unwrap();
    assert_eq!(recv_wrench(&sock).header.ack, 1001);
    assert_eq!(haptic.input().last().pose.q[2], -2.0);

    // Silence: the session times out.
    let end = Instant::now() + Duration::from_secs(2);
    while bridge.stats().timeouts.load(Ordering::Relaxed) == 0 {
        assert!(Instant::now() < end, "no timeout");
        std::thread::sleep(Duration::from_millis(5));
    }
    let accepted = bridge.stats().accepted.load(Ordering::Relaxed);
    // A delayed datagram 500 behind, then one that looks fresh: neither is applied.
    for (seq, z) in [(501, -40.0), (1002, -30.0)] {
        sock.send_to(&raw_pose(seq, [0.0, 0.0, z, 0.0, 0.0, 0.0]), server)
            .unwrap();
        let w = recv_wrench(&sock);
        assert_eq!(w.header.ack, seq);
        assert!(
            w.header.flags & flags::NO_SESSION != 0 && w.header.flags & flags::RELEASED != 0,
            "{w:?}"
        );
        assert_eq!(w.force, [0.0; 3]);
    }
    assert_eq!(bridge.stats().no_session.load(Ordering::Relaxed), 2);
    assert_eq!(bridge.stats().accepted.load(Ordering::Relaxed), accepted);
    std::thread::sleep(Duration::from_millis(10));
    let s = haptic.state().latest();
    assert!(s.released && s.force == [0.0; 3], "{s:?}");
    assert_ne!(haptic.input().last().source, viewer::InputSource::Udp);

    // A new session at 2000: POSEs from before it are stale, newer ones drive the device.
    sock.send_to(&raw_hello(2000), server).unwrap();
    assert!(recv_wrench(&sock).header.flags & flags::SESSION != 0);
    sock.send_to(&raw_pose(1003, [0.0, 0.0, -40.0, 0.0, 0.0, 0.0]), server)
        .unwrap();
    sock.send_to(&raw_pose(2001, [0.0, 0.0, -3.0, 0.0, 0.0, 0.0]), server)
        .unwrap();
    let w = recv_wrench(&sock);
    assert_eq!(w.header.ack, 2001, "the stale POSE must not be answered");
    assert_eq!(bridge.stats().stale.load(Ordering::Relaxed), 1);
    assert_eq!(haptic.input().last().pose.q[2], -3.0);
}

/// A re-engagement ramps the force up from zero through the soft start and the
/// rate limit, however soon it follows a release. Real render pipeline (safety filter: 2 N per
/// frame, 50 ms soft start), frames stepped by hand: the tool is held 30 mm into the floor,
/// the client says BYE (released) and, one frame later, opens a new session at the same pose.
#[test]
fn re_engaging_ramps_the_force_from_zero() {
    let sim = SceneSim::new(&common::small_scene()).unwrap();
    let (handle, mut frames) = HapticLoop::manual(sim, &Pacing::default()).unwrap();
    let bridge = bridge_for(&handle, 5000);
    let deep = [0.0, 0.0, -30.0, 0.0, 0.0, 0.0];
    let max_step = engine::safety::SafetyParams::default().max_force_step_n;
    let norm = |f: [f64; 3]| (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]).sqrt();

    let mut client = session(&bridge, 5000);
    // One engagement: the force starts at exactly zero and rises by at most 2 N per frame.
    let ramp = |client: &mut BridgeClient, frames: &mut viewer::ManualFrames<SceneSim>| {
        let seq = client.send_pose(deep).unwrap();
        let end = Instant::now() + Duration::from_secs(2);
        while handle.input().last().source != viewer::InputSource::Udp {
            assert!(Instant::now() < end, "POSE {seq} not applied");
            std::thread::sleep(Duration::from_millis(1));
        }
        let mut last = 0.0;
        for k in 0..200 {
            let s = frames.step();
            assert!(!s.released, "frame {k} released");
            let f = norm(s.force);
            if k == 0 {
                assert_eq!(f, 0.0, "the first engaged frame must send zero");
            }
            assert!(
                f - last <= max_step + 1e-9,
                "frame {k}: |F| jumped {last:.3} -> {f:.3} N"
            );
            last = f;
        }
        assert!(last > 10.0, "the hold never built up: {last} N");
    };
    ramp(&mut client, &mut frames);
    // Let go and come straight back: the filter must not resume at the old force.
    client.bye().unwrap();
    let end = Instant::now() + Duration::from_secs(2);
    while handle.input().last().source == viewer::InputSource::Udp {
        assert!(Instant::now() < end, "BYE not handled");
        std::thread::sleep(Duration::from_millis(1));
    }
    let s = frames.step();
    assert!(s.released && s.force == [0.0; 3]);
    assert!(client.open_session(Duration::from_secs(2)).unwrap());
    ramp(&mut client, &mut frames);
}

/// The frames after a new session opened while the old one was pressing, with no haptic frame
/// in between (a HELLO from the owner, or BYE + HELLO, and the first POSE all within one
/// frame): the force drops to exactly zero on the new session's first frame and ramps up from
/// there at the rate limit, as after any release.
fn assert_ramps_from_zero_after(
    frames: &mut viewer::ManualFrames<SceneSim>,
    handle: &HapticLoop,
    seq: u64,
) {
    let end = Instant::now() + Duration::from_secs(2);
    while handle.input().last().seq < seq {
        assert!(Instant::now() < end, "command {seq} not applied");
        std::thread::sleep(Duration::from_millis(1));
    }
    let max_step = engine::safety::SafetyParams::default().max_force_step_n;
    let norm = |f: [f64; 3]| (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]).sqrt();
    let mut last = 0.0;
    for k in 0..200 {
        let s = frames.step();
        let f = norm(s.force);
        if k == 0 {
            assert_eq!(
                f, 0.0,
                "the new session's first frame must send zero, sent {f} N"
            );
        }
        assert!(
            f - last <= max_step + 1e-9,
            "frame {k}: |F| jumped {last:.3} -> {f:.3} N"
        );
        last = f;
    }
    assert!(last > 10.0, "the hold never built up again: {last} N");
}

/// Presses the tool 30 mm into the floor through `client` until the hold has built up.
fn press(
    client: &mut BridgeClient,
    frames: &mut viewer::ManualFrames<SceneSim>,
    handle: &HapticLoop,
    deep: [f64; 6],
) {
    let seq = client.send_pose(deep).unwrap();
    let end = Instant::now() + Duration::from_secs(2);
    while handle.input().last().source != viewer::InputSource::Udp {
        assert!(Instant::now() < end, "POSE {seq} not applied");
        std::thread::sleep(Duration::from_millis(1));
    }
    let mut f = 0.0;
    for _ in 0..200 {
        f = frames.step().force[2];
    }
    assert!(f > 10.0, "the hold never built up: {f} N");
}

/// Waits until the bridge has handled everything `client` sent: its answer to the last
/// datagram (a HELLO or a POSE) has arrived.
fn answered(client: &mut BridgeClient, seq: u32) {
    let end = Instant::now() + Duration::from_secs(2);
    loop {
        client.poll().unwrap();
        if client.last().is_some_and(|(_, w)| w.header.ack == seq) {
            return;
        }
        assert!(Instant::now() < end, "datagram {seq} not answered");
        std::thread::sleep(Duration::from_millis(1));
    }
}

#[test]
fn a_new_session_within_one_frame_still_releases_and_ramps_from_zero() {
    let sim = SceneSim::new(&common::small_scene()).unwrap();
    let (handle, mut frames) = HapticLoop::manual(sim, &Pacing::default()).unwrap();
    let bridge = bridge_for(&handle, 5000);
    let deep = [0.0, 0.0, -30.0, 0.0, 0.0, 0.0];
    let mut client = session(&bridge, 5000);
    press(&mut client, &mut frames, &handle, deep);
    // HELLO from the owner (a new session replaces the old one) and the first POSE, both
    // handled before the haptic thread runs another frame.
    client.hello().unwrap();
    let seq = client.send_pose(deep).unwrap();
    answered(&mut client, seq);
    let applied = handle.input().last().seq;
    assert_ramps_from_zero_after(&mut frames, &handle, applied);

    // The same with BYE + HELLO + POSE.
    client.bye().unwrap();
    client.hello().unwrap();
    let seq = client.send_pose(deep).unwrap();
    answered(&mut client, seq);
    let applied = handle.input().last().seq;
    assert_eq!(handle.input().last().source, viewer::InputSource::Udp);
    assert_ramps_from_zero_after(&mut frames, &handle, applied);
}
