//! Recording the device trajectory into the trajectory CSV (`t,x,y,z,gamma,beta,alpha`, one
//! row per haptic frame, s / mm / rad), replayable with `haptic6d run SCENE --trajectory FILE`.
//!
//! The haptic thread pushes one [`Sample`] per frame into a wait-free ring while a recording
//! runs; a writer thread turns them into CSV rows. `t` is `frame_index * dt` counted from the
//! first recorded frame, so a replay at the same rate sees the same poses frame for frame.

use std::fs::File;
use std::io::{BufWriter, Write};
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
        file: BufWriter<File>,
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

    /// Starts recording to `path` (created or truncated; the header is written at once). A
    /// recording already running is stopped first.
    pub fn start(&self, path: &Path) -> Result<(), ViewerError> {
        if self.is_recording() {
            self.stop()?;
        }
        let err = |source| ViewerError::Record {
            path: path.to_path_buf(),
            source,
        };
        let mut file = BufWriter::new(File::create(path).map_err(err)?);
        writeln!(file, "t,x,y,z,gamma,beta,alpha").map_err(err)?;
        let session = self.shared.session.load(Ordering::Acquire).wrapping_add(1);
        self.control
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .send(Control::Start {
                session,
                path: path.to_path_buf(),
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

struct Open {
    session: u32,
    path: PathBuf,
    file: BufWriter<File>,
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
        let r = writeln!(
            self.file,
            "{t:.6},{},{},{},{},{},{}",
            q[0], q[1], q[2], q[3], q[4], q[5]
        );
        match r {
            Ok(()) => self.rows += 1,
            Err(e) => self.error = Some(e),
        }
    }

    fn finish(mut self, dropped_now: u64) -> Result<RecordingSummary, ViewerError> {
        if self.error.is_none() {
            if let Err(e) = self.file.flush() {
                self.error = Some(e);
            }
        }
        match self.error {
            Some(source) => Err(ViewerError::Record {
                path: self.path,
                source,
            }),
            None => Ok(RecordingSummary {
                path: self.path,
                rows: self.rows,
                dropped: dropped_now - self.dropped_at_start,
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
                file,
            }) => {
                let mut o = Open {
                    session,
                    path,
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
            Err(mpsc::RecvTimeoutError::Timeout) => {}
        }
    }
}
