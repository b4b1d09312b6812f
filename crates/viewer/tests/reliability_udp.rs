//! The UDP bridge under malformed traffic (loopback): a flood of garbage, truncated, NaN and
//! wrong-version datagrams between valid POSEs. The bridge keeps serving, counts every bad
//! datagram as malformed, never applies a non-finite pose, and the next valid POSE is applied
//! and acknowledged. A client that stops sending is released (zero force): see
//! `udp_bridge.rs::client_that_stops_sending_gets_zero_force_after_the_timeout`.

mod common;

use devkit::Rng;
use std::net::UdpSocket;
use std::sync::atomic::Ordering;
use std::time::Duration;

use viewer::protocol::{self, decode, Header, Kind, PoseMsg, POSE_LEN};
use viewer::{BridgeParams, HapticLoop, Pacing, UdpBridge};

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

/// One bad datagram, always undecodable: random bytes, or a POSE (with a newer sequence
/// number) made invalid by a NaN / inf field, truncation, extension, version or kind.
fn bad_datagram(r: &mut Rng, seq: u32) -> Vec<u8> {
    let mut b = raw_pose(seq, [0.0, 0.0, -80.0, 0.0, 0.0, 0.0]).to_vec();
    match r.next_u64() % 7 {
        0 => {
            let o = 24 + 8 * (r.next_u64() % 6) as usize;
            b[o..o + 8].copy_from_slice(&f64::NAN.to_le_bytes());
        }
        1 => {
            let o = 24 + 8 * (r.next_u64() % 6) as usize;
            b[o..o + 8].copy_from_slice(&f64::NEG_INFINITY.to_le_bytes());
        }
        2 => b.truncate((r.next_u64() % POSE_LEN as u64) as usize),
        3 => b.extend([0u8; 9]),
        4 => {
            // Any version but the one spoken.
            b[4] = (r.next_u64() % 255) as u8;
            if b[4] == protocol::VERSION {
                b[4] = 255;
            }
        }
        5 => b[5] = [0u8, 4, 9, 255][(r.next_u64() % 4) as usize],
        _ => {
            let len = (r.next_u64() % 1500) as usize;
            b = (0..len).map(|_| r.next_u64() as u8).collect();
        }
    }
    assert!(decode(&b).is_err(), "the generator made a valid datagram");
    b
}

#[test]
fn garbage_flood_is_counted_and_never_applied() {
    let haptic = HapticLoop::spawn(common::Floor::new(), &Pacing::default()).unwrap();
    let bridge = UdpBridge::spawn(
        &BridgeParams {
            addr: "127.0.0.1:0".parse().unwrap(),
            timeout: Duration::from_millis(2000),
        },
        haptic.input().clone(),
        haptic.state().clone(),
    )
    .unwrap();
    let server = bridge.local_addr();
    let sock = UdpSocket::bind("127.0.0.1:0").unwrap();
    sock.set_read_timeout(Some(Duration::from_secs(2))).unwrap();
    let mut reply = [0u8; 256];
    let mut recv_wrench = |sock: &UdpSocket| loop {
        let (n, _) = sock.recv_from(&mut reply).expect("the bridge answers");
        if let Ok(protocol::Message::Wrench(w)) = decode(&reply[..n]) {
            return w;
        }
    };
    let mut hello = [0u8; protocol::HELLO_LEN];
    protocol::encode_hello(0, 0, &mut hello);
    sock.send_to(&hello, server).unwrap();
    let w = recv_wrench(&sock);
    assert!(w.header.flags & protocol::flags::SESSION != 0, "{w:?}");

    sock.send_to(&raw_pose(1, [0.0, 0.0, -3.0, 0.0, 0.0, 0.0]), server)
        .unwrap();
    assert_eq!(recv_wrench(&sock).header.ack, 1);

    let mut r = Rng::new(0xF100D);
    let mut sent_bad = 0u64;
    for (round, seq) in (0..20).zip(2u32..) {
        for _ in 0..50 {
            sock.send_to(&bad_datagram(&mut r, seq + 1000), server)
                .unwrap();
            sent_bad += 1;
        }
        // Pace the flood so loopback does not drop datagrams, then a valid pose: applied and
        // acknowledged, with the loop's force from that pose (finite, the floor's spring).
        std::thread::sleep(Duration::from_millis(5));
        let z = -1.0 - f64::from(round % 5);
        sock.send_to(&raw_pose(seq, [0.0, 0.0, z, 0.0, 0.0, 0.0]), server)
            .unwrap();
        let w = recv_wrench(&sock);
        assert_eq!(w.header.ack, seq, "round {round}");
        assert!(w.force.iter().chain(&w.torque).all(|v| v.is_finite()));
        let q = haptic.input().last().pose.q;
        assert!(q.iter().all(|v| v.is_finite()), "{q:?}");
        assert!(q[2] > -10.0, "a bad pose was applied: {q:?}");
    }
    let malformed = bridge.stats().malformed.load(Ordering::Relaxed);
    // Every bad datagram that arrived was counted; loopback may drop a few under load.
    assert!(
        malformed <= sent_bad && malformed >= sent_bad * 9 / 10,
        "{malformed} of {sent_bad} counted"
    );
    assert_eq!(bridge.stats().accepted.load(Ordering::Relaxed), 21);
    bridge.shutdown();
    drop(haptic);
}
