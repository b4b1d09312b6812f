//! Shared helpers of the scene integration tests.
#![allow(dead_code)]

use std::path::PathBuf;

use scene::cache::TreeCache;

/// A tree cache shared by the tests of one checkout (target dir), so trees are built once.
pub fn test_cache() -> TreeCache {
    let dir = std::env::var_os("HAPTIC6D_CACHE")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            PathBuf::from(env!("CARGO_MANIFEST_DIR"))
                .join("..")
                .join("..")
                .join("target")
                .join("haptic6d-test-cache")
        });
    TreeCache::at(dir)
}

/// An error and its sources on one line, `a: b: c`, as the command line prints them.
pub fn chain(e: &dyn std::error::Error) -> String {
    scene::error_chain(e)
}
