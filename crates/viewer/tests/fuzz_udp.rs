//! Fuzzing the UDP bridge decoder: random datagrams (0 to 300 bytes) and structured mutations
//! of valid POSE, WRENCH, BYE and HELLO datagrams (truncated, extended, bytes flipped, NaN / inf
//! written into the payload, wrong magic, version or kind). The property: `decode` returns (no
//! panic), a decoded POSE or WRENCH carries only finite numbers, and a decoded POSE encodes back
//! to the same bytes.
//!
//! A seeded generator (SplitMix64) drives the cases; a failure prints its case number and
//! reproduces exactly. Cases: 20 000 by default (well under a second); `FUZZ_CASES=2000000`
//! runs longer.

use devkit::Rng;
use viewer::protocol::{
    self, decode, encode_bye, encode_hello, Header, Kind, Message, PoseMsg, WrenchMsg, BYE_LEN,
    HEADER_LEN, HELLO_LEN, POSE_LEN, WRENCH_LEN,
};

fn header(kind: Kind, r: &mut Rng) -> Header {
    Header {
        kind,
        flags: r.next_u64() as u16,
        seq: r.next_u64() as u32,
        ack: r.next_u64() as u32,
        time_us: r.next_u64(),
    }
}

fn valid(r: &mut Rng) -> Vec<u8> {
    match r.below(4) {
        0 => {
            let mut b = [0u8; POSE_LEN];
            let q = [0.0, 1.5, -2.0, 0.1, -0.2, 3.0];
            PoseMsg {
                header: header(Kind::Pose, r),
                q,
            }
            .encode(&mut b);
            b.to_vec()
        }
        1 => {
            let mut b = [0u8; WRENCH_LEN];
            WrenchMsg {
                header: header(Kind::Wrench, r),
                force: [1.0, 2.0, 3.0],
                torque: [-4.0, 5.0, 6.0],
                graphic: [0.0; 6],
                pairs: r.next_u64() as u32,
            }
            .encode(&mut b);
            b.to_vec()
        }
        2 => {
            let mut b = [0u8; BYE_LEN];
            encode_bye(r.next_u64() as u32, &mut b);
            b.to_vec()
        }
        _ => {
            let mut b = [0u8; HELLO_LEN];
            encode_hello(r.next_u64() as u32, r.next_u64(), &mut b);
            b.to_vec()
        }
    }
}

const SPECIAL: [f64; 6] = [
    f64::NAN,
    f64::INFINITY,
    f64::NEG_INFINITY,
    f64::MAX,
    f64::MIN_POSITIVE,
    -0.0,
];

fn mutate(r: &mut Rng, mut b: Vec<u8>) -> Vec<u8> {
    for _ in 0..1 + r.below(3) {
        let n = b.len();
        match r.below(7) {
            0 => b.truncate(r.below(n + 1)),
            1 => {
                let extra = 1 + r.below(64);
                b.extend((0..extra).map(|_| r.next_u64() as u8));
            }
            2 if n > 0 => {
                let i = r.below(n);
                b[i] ^= 1 + r.below(255) as u8;
            }
            3 if n >= HEADER_LEN + 8 => {
                // A special number into one payload field.
                let fields = (n - HEADER_LEN) / 8;
                let o = HEADER_LEN + 8 * r.below(fields);
                b[o..o + 8].copy_from_slice(&SPECIAL[r.below(SPECIAL.len())].to_le_bytes());
            }
            4 if n > 4 => b[4] = r.next_u64() as u8,
            5 if n > 5 => b[5] = r.next_u64() as u8,
            _ if n > 0 => {
                let i = r.below(n.min(4));
                b[i] = r.next_u64() as u8;
            }
            _ => {}
        }
    }
    b
}

fn check(b: &[u8], case: u64) {
    match decode(b) {
        Ok(Message::Pose(p)) => {
            assert!(p.q.iter().all(|v| v.is_finite()), "case {case}: {p:?}");
            let mut back = [0u8; POSE_LEN];
            p.encode(&mut back);
            assert_eq!(&back[..], b, "case {case}: POSE does not round-trip");
        }
        Ok(Message::Wrench(w)) => {
            assert!(
                w.force
                    .iter()
                    .chain(&w.torque)
                    .chain(&w.graphic)
                    .all(|v| v.is_finite()),
                "case {case}: {w:?}"
            );
        }
        Ok(Message::Bye(h)) => assert_eq!(h.kind, Kind::Bye, "case {case}"),
        Ok(Message::Hello(h)) => {
            assert_eq!(h.kind, Kind::Hello, "case {case}");
            assert_eq!(b.len(), HELLO_LEN, "case {case}");
        }
        Err(e) => {
            let m = e.to_string();
            assert!(!m.is_empty() && !m.contains('\n'), "case {case}: {m:?}");
        }
    }
}

#[test]
fn decode_random_and_mutated_datagrams() {
    let cases: u64 = std::env::var("FUZZ_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(20_000);
    let mut r = Rng::new(0x7564_7066);
    let (mut accepted, mut rejected) = (0u64, 0u64);
    for case in 0..cases {
        let b = if case % 3 == 0 {
            let len = r.below(300);
            let mut b: Vec<u8> = (0..len).map(|_| r.next_u64() as u8).collect();
            // Half of the random ones get a valid magic and version to reach the kind checks.
            if case % 2 == 0 && b.len() >= 5 {
                b[..4].copy_from_slice(b"H6DB");
                b[4] = protocol::VERSION;
            }
            b
        } else {
            let v = valid(&mut r);
            mutate(&mut r, v)
        };
        check(&b, case);
        if decode(&b).is_ok() {
            accepted += 1;
        } else {
            rejected += 1;
        }
    }
    // The mutations reach both outcomes.
    assert!(accepted > 0 && rejected > 0, "{accepted} / {rejected}");
}
