//! Recording the device trajectory into the trajectory CSV (`t,x,y,z,gamma,beta,alpha`, one
//! row per haptic frame, s / mm / rad), replayable with `haptic6d run SCENE --trajectory FILE`.
//!
//! The haptic thread pushes one [`Sample`] per frame into a wait-free ring while a recording
//! runs; a writer thread turns them into CSV rows. `t` is `frame_index * dt` counted from the
//! first recorded frame, so a replay at the same rate sees the same poses frame for frame.
//!
//! Nothing a user has is lost: the rows go to a temporary file beside the target
//! (`.NAME.PID-K.partial`, created new), written in whole rows only and flushed every 20 ms;
//! when the recording stops the file is synced and renamed onto the target. An existing target
//! is refused unless overwriting was asked for, and even then it is untouched until the end.

use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU64, Ordering};
use std::sync::mpsc;
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

use crate::error::ViewerError;

/// One recorded frame: which recording it belongs to, the loop's frame index, the device pose.
#[derive(Clone, Copy, Debug)]
pub struct Sample {
    /// Recording session (incremented at every start).
    pub session: u32,
    /// Haptic frame index.
    pub frame: u64,
    /// Device configuration (mm, rad).
    pub q: [f64; 6],
}

/// What a finished recording wrote.
#[derive(Clone, Debug, PartialEq)]
pub struct RecordingSummary {
    /// The CSV file.
    pub path: PathBuf,
    /// Data rows written (= haptic frames recorded).
    pub rows: u64,
    /// Frames lost because the writer fell behind (the ring was full).
    pub dropped: u64,
}

struct Shared {
    recording: AtomicBool,
    session: AtomicU32,
    dropped: AtomicU64,
    current: Mutex<Option<PathBuf>>,
}

enum Control {
    Start {
        session: u32,
        path: PathBuf,
        tmp: PathBuf,
        overwrite: bool,
        file: RowWriter,
    },
    Stop {
        reply: mpsc::Sender<Result<RecordingSummary, ViewerError>>,
    },
    Quit,
}

/// The haptic thread's end: pushes samples while a recording runs.
pub struct RecordTx {
    producer: rtrb::Producer<Sample>,
    shared: Arc<Shared>,
}

impl RecordTx {
    /// Records `q` for frame `frame` if a recording runs; returns whether it is recording.
    ///
    /// # Real-time
    /// Wait-free: two atomic loads and one ring push; no allocation; a full ring drops the
    /// sample and counts it.
    #[inline]
    pub fn record(&mut self, frame: u64, q: [f64; 6]) -> bool {
        if !self.shared.recording.load(Ordering::Acquire) {
            return false;
        }
        let session = self.shared.session.load(Ordering::Acquire);
        if self.producer.push(Sample { session, frame, q }).is_err() {
            self.shared.dropped.fetch_add(1, Ordering::Relaxed);
        }
        true
    }
}

/// Controls recordings and owns the writer thread.
pub struct Recorder {
    shared: Arc<Shared>,
    control: Mutex<mpsc::Sender<Control>>,
    writer: Option<JoinHandle<()>>,
}

/// Ring capacity: 4 s of frames at 1 kHz.
const RING: usize = 4096;

impl Recorder {
    /// A recorder (writer thread started, idle) and the haptic thread's end. `dt` is the haptic
    /// period (s) used for the `t` column.
    pub fn new(dt: f64) -> Result<(Self, RecordTx), ViewerError> {
        let (producer, consumer) = rtrb::RingBuffer::new(RING);
        let shared = Arc::new(Shared {
            recording: AtomicBool::new(false),
            session: AtomicU32::new(0),
            dropped: AtomicU64::new(0),
            current: Mutex::new(None),
        });
        let (tx, rx) = mpsc::channel();
        let writer_shared = shared.clone();
        let writer = std::thread::Builder::new()
            .name("haptic6d-recorder".into())
            .spawn(move || writer_loop(consumer, rx, dt, writer_shared))
            .map_err(ViewerError::Thread)?;
        Ok((
            Self {
                shared: shared.clone(),
                control: Mutex::new(tx),
                writer: Some(writer),
            },
            RecordTx { producer, shared },
        ))
    }

    /// Starts recording to `path`: the rows go to a new temporary file beside it (header
    /// written at once), renamed onto `path` when the recording stops. An existing `path` is
    /// refused ([`ViewerError::RecordExists`]) unless `overwrite`; a `path` that exists and is
    /// not a regular file is always refused. A recording already running is stopped first.
    pub fn start(&self, path: &Path, overwrite: bool) -> Result<(), ViewerError> {
        check_target(path, overwrite)?;
        if self.is_recording() {
            self.stop()?;
        }
        let err = |source| ViewerError::Record {
            path: path.to_path_buf(),
            source,
        };
        let (tmp, file) = create_temp(path).map_err(err)?;
        let mut file = RowWriter::new(file);
        file.row(format_args!("t,x,y,z,gamma,beta,alpha"));
        if let Err(e) = file.flush_rows() {
            let _ = std::fs::remove_file(&tmp);
            return Err(err(e));
        }
        let session = self.shared.session.load(Ordering::Acquire).wrapping_add(1);
        self.control
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .send(Control::Start {
                session,
                path: path.to_path_buf(),
                tmp,
                overwrite,
                file,
            })
            .map_err(|_| ViewerError::RecorderGone)?;
        *self
            .shared
            .current
            .lock()
            .unwrap_or_else(|p| p.into_inner()) = Some(path.to_path_buf());
        self.shared.session.store(session, Ordering::Release);
        self.shared.recording.store(true, Ordering::Release);
        Ok(())
    }

    /// Stops the running recording, waits until every row is on disk, and says what was written.
    pub fn stop(&self) -> Result<RecordingSummary, ViewerError> {
        if !self.shared.recording.swap(false, Ordering::AcqRel) {
            return Err(ViewerError::NotRecording);
        }
        *self
            .shared
            .current
            .lock()
            .unwrap_or_else(|p| p.into_inner()) = None;
        let (reply, answer) = mpsc::channel();
        self.control
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .send(Control::Stop { reply })
            .map_err(|_| ViewerError::RecorderGone)?;
        answer.recv().map_err(|_| ViewerError::RecorderGone)?
    }

    /// True while a recording runs.
    pub fn is_recording(&self) -> bool {
        self.shared.recording.load(Ordering::Acquire)
    }

    /// The file being recorded to, if any.
    pub fn current_path(&self) -> Option<PathBuf> {
        self.shared
            .current
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .clone()
    }
}

impl Drop for Recorder {
    fn drop(&mut self) {
        if self.is_recording() {
            let _ = self.stop();
        }
        let _ = self
            .control
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .send(Control::Quit);
        if let Some(h) = self.writer.take() {
            let _ = h.join();
        }
    }
}

/// Refuses a target that exists (unless `overwrite`) or is not a regular file.
fn check_target(path: &Path, overwrite: bool) -> Result<(), ViewerError> {
    match std::fs::symlink_metadata(path) {
        Ok(m) if !m.file_type().is_file() => Err(ViewerError::Record {
            path: path.to_path_buf(),
            source: std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                "it exists and is not a regular file",
            ),
        }),
        Ok(_) if !overwrite => Err(ViewerError::RecordExists {
            path: path.to_path_buf(),
        }),
        _ => Ok(()),
    }
}

/// Creates a new temporary file beside `path`: `.NAME.PID-K.partial`.
fn create_temp(path: &Path) -> std::io::Result<(PathBuf, File)> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "recording".into());
    let mut k = 0u32;
    loop {
        let tmp = dir.join(format!(".{name}.{}-{k}.partial", std::process::id()));
        match OpenOptions::new().write(true).create_new(true).open(&tmp) {
            Ok(f) => return Ok((tmp, f)),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists && k < 1000 => k += 1,
            Err(e) => return Err(e),
        }
    }
}

/// Writes CSV rows to a file in whole rows: rows are formatted into a buffer that goes to the
/// file only as a whole, so the file always ends at a row boundary.
struct RowWriter {
    file: File,
    buf: Vec<u8>,
}

/// Buffered bytes that trigger a write (64 KiB ≈ 1 s of rows at 1 kHz).
const ROW_BUF: usize = 64 * 1024;

impl RowWriter {
    fn new(file: File) -> Self {
        Self {
            file,
            buf: Vec::with_capacity(ROW_BUF + 256),
        }
    }

    /// Appends one row (without its newline).
    fn row(&mut self, args: std::fmt::Arguments<'_>) {
        // Writing into a Vec cannot fail.
        let _ = self.buf.write_fmt(args);
        self.buf.push(b'\n');
    }

    fn full(&self) -> bool {
        self.buf.len() >= ROW_BUF
    }

    /// Writes the buffered rows to the file.
    fn flush_rows(&mut self) -> std::io::Result<()> {
        if !self.buf.is_empty() {
            self.file.write_all(&self.buf)?;
            self.buf.clear();
        }
        Ok(())
    }
}

struct Open {
    session: u32,
    path: PathBuf,
    tmp: PathBuf,
    overwrite: bool,
    file: RowWriter,
    first_frame: Option<u64>,
    rows: u64,
    dropped_at_start: u64,
    error: Option<std::io::Error>,
}

impl Open {
    fn write(&mut self, s: &Sample, dt: f64) {
        if self.error.is_some() {
            return;
        }
        let first = *self.first_frame.get_or_insert(s.frame);
        let t = (s.frame.saturating_sub(first)) as f64 * dt;
        let q = s.q;
        self.file.row(format_args!(
            "{t:.6},{},{},{},{},{},{}",
            q[0], q[1], q[2], q[3], q[4], q[5]
        ));
        self.rows += 1;
        if self.file.full() {
            self.flush();
        }
    }

    /// Writes the buffered rows (whole rows only); remembers the first error.
    fn flush(&mut self) {
        if self.error.is_none() {
            if let Err(e) = self.file.flush_rows() {
                self.error = Some(e);
            }
        }
    }

    /// Flushes and syncs the temporary file and moves it onto the target.
    fn finish(mut self, dropped_now: u64) -> Result<RecordingSummary, ViewerError> {
        self.flush();
        if self.error.is_none() {
            if let Err(e) = self.file.file.sync_all() {
                self.error = Some(e);
            }
        }
        if let Some(source) = self.error {
            return Err(ViewerError::RecordNotMoved {
                path: self.path,
                kept: self.tmp,
                source,
            });
        }
        drop(self.file);
        let placed = if self.overwrite {
            std::fs::rename(&self.tmp, &self.path)
        } else {
            // No-clobber: a hard link fails if the target appeared meanwhile.
            match std::fs::hard_link(&self.tmp, &self.path) {
                Ok(()) => std::fs::remove_file(&self.tmp),
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => Err(e),
                // A file system without hard links: check, then rename.
                Err(_) if self.path.exists() => Err(std::io::ErrorKind::AlreadyExists.into()),
                Err(_) => std::fs::rename(&self.tmp, &self.path),
            }
        };
        match placed {
            Ok(()) => Ok(RecordingSummary {
                path: self.path,
                rows: self.rows,
                dropped: dropped_now - self.dropped_at_start,
            }),
            Err(source) => Err(ViewerError::RecordNotMoved {
                path: self.path,
                kept: self.tmp,
                source,
            }),
        }
    }
}

fn writer_loop(
    mut consumer: rtrb::Consumer<Sample>,
    control: mpsc::Receiver<Control>,
    dt: f64,
    shared: Arc<Shared>,
) {
    let mut open: Option<Open> = None;
    // Samples of a session whose Start message has not been received yet (the haptic thread
    // may push before this thread sees the message); written when it arrives.
    let mut early: Vec<Sample> = Vec::new();
    let drain = |consumer: &mut rtrb::Consumer<Sample>,
                 open: &mut Option<Open>,
                 early: &mut Vec<Sample>| {
        while let Ok(s) = consumer.pop() {
            match open.as_mut() {
                Some(o) if o.session == s.session => o.write(&s, dt),
                _ => {
                    if early.len() < 4 * RING {
                        early.push(s);
                    }
                }
            }
        }
    };
    loop {
        drain(&mut consumer, &mut open, &mut early);
        match control.recv_timeout(Duration::from_millis(20)) {
            Ok(Control::Start {
                session,
                path,
                tmp,
                overwrite,
                file,
            }) => {
                let mut o = Open {
                    session,
                    path,
                    tmp,
                    overwrite,
                    file,
                    first_frame: None,
                    rows: 0,
                    dropped_at_start: shared.dropped.load(Ordering::Relaxed),
                    error: None,
                };
                for s in early.drain(..).filter(|s| s.session == session) {
                    o.write(&s, dt);
                }
                open = Some(o);
            }
            Ok(Control::Stop { reply }) => {
                // The haptic thread may be inside the frame that saw the flag still set; give it
                // one period to push that sample before the final drain.
                std::thread::sleep(Duration::from_millis(3));
                drain(&mut consumer, &mut open, &mut early);
                early.clear();
                let result = match open.take() {
                    Some(o) => o.finish(shared.dropped.load(Ordering::Relaxed)),
                    None => Err(ViewerError::NotRecording),
                };
                let _ = reply.send(result);
            }
            Ok(Control::Quit) | Err(mpsc::RecvTimeoutError::Disconnected) => {
                drain(&mut consumer, &mut open, &mut early);
                if let Some(o) = open.take() {
                    let _ = o.finish(shared.dropped.load(Ordering::Relaxed));
                }
                return;
            }
            Err(mpsc::RecvTimeoutError::Timeout) => {
                // Whole rows reach the file every tick (20 ms).
                if let Some(o) = open.as_mut() {
                    o.flush();
                }
            }
        }
    }
}
