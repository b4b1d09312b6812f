//! Scene TOML parser: never panics; errors are one line naming the file; accepted scenes have
//! finite positive stiffness and rate.
#![no_main]

use libfuzzer_sys::fuzz_target;
use scene::SceneSpec;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    match SceneSpec::parse(&text, "f.toml") {
        Ok(s) => {
            assert!(s.coupling.kt > 0.0 && s.coupling.kt.is_finite());
            assert!(s.coupling.kr > 0.0 && s.coupling.kr.is_finite());
            assert!(s.device.rate_hz > 0.0 && s.device.rate_hz.is_finite());
        }
        Err(e) => {
            let m = e.to_string();
            assert!(!m.contains('\n') && m.starts_with("f.toml"), "{m}");
        }
    }
});
