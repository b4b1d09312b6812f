//! The committed C header is what cbindgen makes of the crate now: a change to the C API
//! without regenerating `include/haptic6d.h` fails here, with the command that fixes it.

use std::path::Path;

const UPDATE: &str = "H6D_UPDATE_HEADER";

fn generated() -> String {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let config = cbindgen::Config::from_file(dir.join("cbindgen.toml")).unwrap();
    let mut out = Vec::new();
    cbindgen::Builder::new()
        .with_src(dir.join("src").join("lib.rs"))
        .with_config(config)
        .generate()
        .unwrap()
        .write(&mut out);
    String::from_utf8(out).unwrap()
}

#[test]
fn committed_header_is_current() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("include/haptic6d.h");
    let now = generated();
    if std::env::var_os(UPDATE).is_some() {
        std::fs::write(&path, &now).unwrap();
        return;
    }
    let committed = std::fs::read_to_string(&path).unwrap_or_default();
    if committed != now {
        let line = committed
            .lines()
            .zip(now.lines())
            .position(|(a, b)| a != b)
            .map_or(committed.lines().count().min(now.lines().count()), |i| i)
            + 1;
        panic!(
            "crates/capi/include/haptic6d.h is stale (the C API changed; first difference at line {line}); regenerate it with\n    {UPDATE}=1 cargo test --release -p haptic6d-capi --test header\nand commit it"
        );
    }
    // The header declares every entry point the library exports.
    for f in [
        "h6d_engine_step",
        "h6d_scene_load",
        "h6d_last_error_message",
    ] {
        assert!(
            now.contains(&format!("{f}(")),
            "{f} missing from the header"
        );
    }
}
