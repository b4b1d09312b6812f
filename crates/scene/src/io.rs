//! Small file helpers: atomic writes (through `mesh::write_atomic`), the parent folder created.

use std::path::Path;

use crate::SceneError;

/// Writes `bytes` to `path` atomically: a temporary file next to it is written, flushed and
/// renamed over `path`, so a reader never sees a half-written file and a crash never leaves one.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), SceneError> {
    let io_err = |source: std::io::Error| SceneError::Io {
        path: path.display().to_string(),
        source,
    };
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(io_err)?;
    }
    mesh::write_atomic(path, bytes).map_err(io_err)
}
