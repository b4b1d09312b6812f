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
    /// A recording was asked to stop while none runs.
    #[error("no recording is running (start one with --record FILE or the page's Record button)")]
    NotRecording,
    /// The recorder's writer thread is gone.
    #[error("the recorder's writer thread stopped unexpectedly; restart `haptic6d serve`")]
    RecorderGone,
    /// The loop parameters are unusable.
    #[error("invalid loop parameter: {0}")]
    Params(String),
    /// Serving failed.
    #[error("web server failed: {0}")]
    Serve(std::io::Error),
}
