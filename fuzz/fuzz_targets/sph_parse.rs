//! `.sph` reader: never panics; errors are `file:line: ...` on one line; accepted trees are
//! finite and survive a write/read round trip unchanged.
#![no_main]

use libfuzzer_sys::fuzz_target;
use spheretree::sph::{parse_sph, to_sph_string};

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    match parse_sph(&text, "f.sph") {
        Ok(t) => {
            let back = to_sph_string(&t).expect("an accepted tree is writable");
            assert_eq!(parse_sph(&back, "rt").expect("round trip"), t);
        }
        Err(e) => {
            let m = e.to_string();
            assert!(!m.contains('\n') && m.starts_with("f.sph:"), "{m}");
        }
    }
});
