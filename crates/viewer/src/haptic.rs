//! The haptic thread: steps a [`Simulation`] at a fixed rate (1 kHz by default) on a named
//! thread, reading the device pose from an [`InputHub`] and publishing every frame's
//! [`FrameState`] to a [`StateHub`], both lock-free on this side.

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use collide::Pose;

use crate::error::ViewerError;
use crate::hub::{InputHub, InputReader, InputSource, StateHub, StatePublisher};
use crate::recorder::{RecordTx, Recorder, RecordingSummary};
use crate::sim::{FrameState, SceneGeometry, Simulation};

/// Haptic loop settings.
#[derive(Clone, Debug)]
pub struct LoopParams {
    /// Frame rate (Hz); 1000 by default.
    pub rate_hz: f64,
    /// How long before a deadline the thread stops sleeping and spins (µs); trades CPU for
    /// timing precision. 150 by default.
    pub spin_us: u64,
}

impl Default for LoopParams {
    fn default() -> Self {
        Self {
            rate_hz: 1000.0,
            spin_us: 150,
        }
    }
}

/// A running haptic loop: the thread, its input and output hubs, and the recorder.
pub struct HapticLoop {
    input: Arc<InputHub>,
    state: Arc<StateHub>,
    recorder: Recorder,
    scene: Arc<SceneGeometry>,
    start: Pose,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
    period: Duration,
}

impl HapticLoop {
    /// Starts the haptic thread (named `haptic6d-haptic`) stepping `sim`. The device starts
    /// released at the simulation's start pose.
    pub fn spawn<S: Simulation>(mut sim: S, params: &LoopParams) -> Result<Self, ViewerError> {
        if !(params.rate_hz.is_finite() && params.rate_hz > 0.0 && params.rate_hz <= 100_000.0) {
            return Err(ViewerError::Params(format!(
                "rate {} Hz is outside (0, 100000]",
                params.rate_hz
            )));
        }
        let period = Duration::from_secs_f64(1.0 / params.rate_hz);
        let scene = Arc::new(sim.scene());
        let start = sim.start_pose();
        sim.reset(&start);
        let mut initial = FrameState {
            device: start.to_array(),
            graphic: start.to_array(),
            ..FrameState::default()
        };
        initial.released = true;
        let (input, reader) = InputHub::new();
        let input = Arc::new(input);
        let (state, publisher) = StateHub::new(&initial);
        let (recorder, record_tx) = Recorder::new(period.as_secs_f64())?;
        let stop = Arc::new(AtomicBool::new(false));
        let worker = Worker {
            reader,
            publisher,
            record_tx,
            input: input.clone(),
            stop: stop.clone(),
            period,
            spin: Duration::from_micros(params.spin_us),
            start,
            state: initial,
        };
        let thread = std::thread::Builder::new()
            .name("haptic6d-haptic".into())
            .spawn(move || worker.run(sim))
            .map_err(ViewerError::Thread)?;
        Ok(Self {
            input,
            state: Arc::new(state),
            recorder,
            scene,
            start,
            stop,
            thread: Some(thread),
            period,
        })
    }

    /// Where device poses go in.
    pub fn input(&self) -> &Arc<InputHub> {
        &self.input
    }

    /// Where frame states come out.
    pub fn state(&self) -> &Arc<StateHub> {
        &self.state
    }

    /// The static scene geometry.
    pub fn scene(&self) -> &Arc<SceneGeometry> {
        &self.scene
    }

    /// The simulation's start pose (mm, rad).
    pub fn start_pose(&self) -> Pose {
        self.start
    }

    /// The haptic period.
    pub fn period(&self) -> Duration {
        self.period
    }

    /// Starts recording the device trajectory to `path` (trajectory CSV).
    pub fn start_recording(&self, path: &Path) -> Result<(), ViewerError> {
        self.recorder.start(path)
    }

    /// Stops the running recording and waits for the file to be complete.
    pub fn stop_recording(&self) -> Result<RecordingSummary, ViewerError> {
        self.recorder.stop()
    }

    /// The file being recorded to, if a recording runs.
    pub fn recording_path(&self) -> Option<std::path::PathBuf> {
        self.recorder.current_path()
    }

    /// Waits until the haptic thread has published a frame driven by an input command with
    /// sequence number `seq` or later, or `timeout` passes; returns that state.
    pub fn wait_for_input(&self, seq: u64, timeout: Duration) -> Option<FrameState> {
        let end = Instant::now() + timeout;
        loop {
            let s = self.state.latest();
            if s.input_seq >= seq {
                return Some(s);
            }
            if Instant::now() > end {
                return None;
            }
            std::thread::sleep(self.period);
        }
    }

    /// Stops the haptic thread and waits for it.
    pub fn shutdown(mut self) {
        self.halt();
    }

    fn halt(&mut self) {
        self.stop.store(true, Ordering::Release);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for HapticLoop {
    fn drop(&mut self) {
        self.halt();
    }
}

struct Worker {
    reader: InputReader,
    publisher: StatePublisher,
    record_tx: RecordTx,
    input: Arc<InputHub>,
    stop: Arc<AtomicBool>,
    period: Duration,
    spin: Duration,
    start: Pose,
    state: FrameState,
}

impl Worker {
    fn run<S: Simulation>(mut self, mut sim: S) {
        let mut resets_seen = self.input.reset_count();
        let mut next = Instant::now();
        let mut window_max = 0.0f64;
        let window = (1.0 / self.period.as_secs_f64()).round().max(1.0) as u64;
        let dt = self.period.as_secs_f64();
        let mut frame: u64 = 0;
        while !self.stop.load(Ordering::Acquire) {
            let resets = self.input.reset_count();
            if resets != resets_seen {
                resets_seen = resets;
                sim.reset(&self.start);
                self.state.graphic = self.start.to_array();
            }
            let cmd = self.reader.latest();
            let now = Instant::now();
            let live = cmd.is_live(now);
            // Released: hold the device at the graphic pose, so the spring (and force) is zero.
            let device = if live {
                cmd.pose
            } else {
                Pose::from_array(self.state.graphic)
            };
            let s = &mut self.state;
            s.frame = frame;
            s.t = frame as f64 * dt;
            s.device = device.to_array();
            s.contacts.clear();
            s.released = !live;
            s.source = if live {
                cmd.source as u8
            } else {
                InputSource::None as u8
            };
            s.input_seq = cmd.seq;
            s.contacts_requested = self.input.contacts_wanted();
            let t0 = Instant::now();
            sim.step(&device, s);
            let frame_us = t0.elapsed().as_secs_f64() * 1e6;
            if !live {
                s.force = [0.0; 3];
                s.torque = [0.0; 3];
            }
            s.frame_us = frame_us;
            window_max = window_max.max(frame_us);
            if frame.is_multiple_of(window) {
                s.frame_us_max = window_max;
                window_max = 0.0;
            }
            s.recording = self.record_tx.record(frame, s.device);
            self.publisher.publish(s);
            frame += 1;

            // Pace: sleep until shortly before the next deadline, then spin.
            next += self.period;
            let now = Instant::now();
            if now > next + self.period {
                // More than a whole period late: count it and re-anchor instead of bursting.
                self.state.overruns += 1;
                next = now;
                continue;
            }
            if now > next {
                self.state.overruns += 1;
                continue;
            }
            let left = next - now;
            if left > self.spin {
                std::thread::sleep(left - self.spin);
            }
            while Instant::now() < next {
                std::thread::yield_now();
            }
        }
    }
}
