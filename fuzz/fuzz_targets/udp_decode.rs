//! UDP bridge datagram decoder: never panics; an accepted POSE or WRENCH carries only finite
//! numbers; an accepted POSE re-encodes to the same bytes, an accepted WRENCH to a datagram
//! that decodes to the same message (its 4 reserved trailing bytes are written as zero).
#![no_main]

use libfuzzer_sys::fuzz_target;
use viewer::protocol::{decode, Message, POSE_LEN, WRENCH_LEN};

fuzz_target!(|data: &[u8]| {
    match decode(data) {
        Ok(Message::Pose(p)) => {
            assert!(p.q.iter().all(|v| v.is_finite()));
            let mut back = [0u8; POSE_LEN];
            let n = p.encode(&mut back);
            assert_eq!(&back[..n], data, "POSE does not round-trip");
        }
        Ok(Message::Wrench(w)) => {
            assert!(w
                .force
                .iter()
                .chain(&w.torque)
                .chain(&w.graphic)
                .all(|v| v.is_finite()));
            let mut back = [0u8; WRENCH_LEN];
            let n = w.encode(&mut back);
            assert_eq!(&back[..n - 4], &data[..n - 4], "WRENCH does not round-trip");
            assert_eq!(decode(&back[..n]), Ok(Message::Wrench(w)));
        }
        _ => {}
    }
});
