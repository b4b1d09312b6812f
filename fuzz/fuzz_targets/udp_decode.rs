//! UDP bridge datagram decoder: never panics; an accepted POSE carries only finite numbers.
#![no_main]

use libfuzzer_sys::fuzz_target;
use viewer::protocol::{decode, Message};

fuzz_target!(|data: &[u8]| {
    if let Ok(Message::Pose(p)) = decode(data) {
        assert!(p.q.iter().all(|v| v.is_finite()));
    }
});
