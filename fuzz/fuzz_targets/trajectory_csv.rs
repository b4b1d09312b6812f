//! Trajectory CSV reader: never panics; errors are `file:line: ...` on one line; accepted
//! trajectories are finite with non-decreasing times.
#![no_main]

use libfuzzer_sys::fuzz_target;
use scene::trajectory::Trajectory;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    match Trajectory::parse_csv(&text, "f.csv") {
        Ok(t) => {
            assert!(!t.samples.is_empty());
            for w in t.samples.windows(2) {
                assert!(w[1].t >= w[0].t);
            }
            assert!(t
                .samples
                .iter()
                .all(|s| s.t.is_finite() && s.q.iter().all(|v| v.is_finite())));
        }
        Err(e) => {
            let m = e.to_string();
            assert!(!m.contains('\n') && m.starts_with("f.csv:"), "{m}");
        }
    }
});
