//! The viewer's error type.

use std::path::PathBuf;

/// Everything that can go wrong setting up or running the viewer.
#[derive(Debug, thiserror::Error)]
pub enum ViewerError {
    /// A socket could not be bound.
    #[error("cannot bind {what} on {addr}: {source} (pick another port with --port / --udp-port, or stop the program using it)")]
    Bind {
        /// Which server ("web" or "UDP bridge").
        what: &'static str,
        /// The address asked for.
        addr: String,
        /// The OS error.
        source: std::io::Error,
    },
    /// The haptic thread could not be started.
    #[error("cannot start the haptic thread: {0} (the system is out of threads or memory)")]
    Thread(std::io::Error),
    /// A recording file could not be created or written.
    #[error("cannot record to {path}: {source} (check the directory exists and is writable)")]
    Record {
        /// The CSV file.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// The recording's file exists and overwriting was not asked for.
    #[error("{path} already exists; choose another file or pass --force to replace it when the recording ends")]
    RecordExists {
        /// The CSV file.
        path: PathBuf,
    },
    /// A finished recording could not be moved onto its file; the rows are kept elsewhere.
    #[error("cannot put the recording in place at {path}: {source}; the rows are kept in {kept}")]
    RecordNotMoved {
        /// The CSV file asked for.
        path: PathBuf,
        /// The temporary file holding the complete recording.
        kept: PathBuf,
        /// The OS error (or `AlreadyExists` when the file appeared meanwhile).
        source: std::io::Error,
    },
    /// A recording was asked to stop while none runs.
    #[error("no recording is running (start one with --record FILE or the page's Record button)")]
    NotRecording,
    /// The recorder's writer thread is gone.
    #[error("the recorder's writer thread stopped unexpectedly; restart `haptic6d serve`")]
    RecorderGone,
    /// The scene cannot be driven (the engine refused a tree or the start pose).
    #[error(transparent)]
    Scene(#[from] scene::SceneError),
    /// A setting is unusable (the text names the flag and what is wrong).
    #[error("{0}")]
    Params(String),
    /// A setting is outside its range (the haptic rate, spin or priority).
    #[error(transparent)]
    Setting(#[from] engine::config::SettingError),
    /// Serving failed.
    #[error("web server failed: {0}")]
    Serve(std::io::Error),
}

/// A number for an error message: plain when of ordinary size, in scientific notation when
/// tiny or huge (`1e-30`, not thirty zeros).
pub fn show_number(x: f64) -> String {
    if x != 0.0 && x.is_finite() && (x.abs() < 1e-4 || x.abs() >= 1e9) {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}
