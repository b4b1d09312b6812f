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
use crate::simulation::{FrameState, SceneGeometry, Simulation};
use scene::rt::Pacing;

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
    realtime: Arc<AtomicBool>,
}

impl HapticLoop {
    /// Starts the haptic thread (named `haptic6d-haptic`) stepping `sim`. The device starts
    /// released at the simulation's start pose.
    pub fn spawn<S: Simulation>(sim: S, params: &Pacing) -> Result<Self, ViewerError> {
        let (mut handle, frames) = Self::manual(sim, params)?;
        let stop = handle.stop.clone();
        let spin = params.spin();
        let priority = params.rt_priority;
        let realtime = handle.realtime.clone();
        let thread = std::thread::Builder::new()
            .name("haptic6d-haptic".into())
            .spawn(move || {
                if let Some(p) = priority {
                    realtime.store(scene::rt::set_realtime_priority(p), Ordering::Release);
                }
                frames.run(&stop, spin)
            })
            .map_err(ViewerError::Thread)?;
        handle.thread = Some(thread);
        Ok(handle)
    }

    /// The loop without its thread: the handle (hubs, recorder) and a [`ManualFrames`] that runs
    /// one frame per call on the caller's thread, unpaced. For tests and offline drivers.
    pub fn manual<S: Simulation>(
        mut sim: S,
        params: &Pacing,
    ) -> Result<(Self, ManualFrames<S>), ViewerError> {
        params.validate()?;
        let period = params.period();
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
        let frames = ManualFrames {
            sim,
            reader,
            publisher,
            record_tx,
            input: input.clone(),
            period,
            start,
            state: initial,
            resets_seen: input.reset_count(),
            frame: 0,
            window_max: 0.0,
            window: (1.0 / period.as_secs_f64()).round().max(1.0) as u64,
        };
        Ok((
            Self {
                input,
                state: Arc::new(state),
                recorder,
                scene,
                start,
                stop,
                thread: None,
                period,
                realtime: Arc::new(AtomicBool::new(false)),
            },
            frames,
        ))
    }

    /// True when the haptic thread obtained the real-time priority it asked for
    /// ([`Pacing::rt_priority`]); set once the thread has started.
    pub fn realtime(&self) -> bool {
        self.realtime.load(Ordering::Acquire)
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

    /// Starts recording the device trajectory to `path` (trajectory CSV). The rows go to a
    /// temporary file beside `path`, renamed onto `path` when the recording stops; an existing
    /// `path` is refused unless `overwrite` (and even then stays intact until the stop).
    pub fn start_recording(&self, path: &Path, overwrite: bool) -> Result<(), ViewerError> {
        self.recorder.start(path, overwrite)
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

/// The haptic frame body without pacing: read the latest command, step the simulation,
/// publish the state, record. [`HapticLoop::spawn`] runs it on the haptic thread; tests run it
/// directly (e.g. under an allocation counter).
pub struct ManualFrames<S: Simulation> {
    sim: S,
    reader: InputReader,
    publisher: StatePublisher,
    record_tx: RecordTx,
    input: Arc<InputHub>,
    period: Duration,
    start: Pose,
    state: FrameState,
    resets_seen: u64,
    frame: u64,
    window_max: f64,
    window: u64,
}

impl<S: Simulation> ManualFrames<S> {
    /// Runs one haptic frame and returns the state it published.
    ///
    /// # Real-time
    /// No allocation, lock or IO of its own (wait-free hand-overs; the contact list is
    /// pre-sized); bounded by the simulation's step. No panic.
    pub fn step(&mut self) -> &FrameState {
        let resets = self.input.reset_count();
        if resets != self.resets_seen {
            self.resets_seen = resets;
            self.sim.reset(&self.start);
            self.state.graphic = self.start.to_array();
        }
        let cmd = self.reader.latest();
        let live = cmd.is_live(Instant::now());
        // Released: hold the device at the graphic pose, so the spring (and force) is zero.
        let device = if live {
            cmd.pose
        } else {
            Pose::from_array(self.state.graphic)
        };
        let frame = self.frame;
        let s = &mut self.state;
        s.frame = frame;
        s.t = frame as f64 * self.period.as_secs_f64();
        s.device = device.to_array();
        s.contacts.clear();
        s.released = !live;
        s.source = if live {
            cmd.source as u8
        } else {
            InputSource::None as u8
        };
        s.input_seq = cmd.seq;
        s.engagement = cmd.engagement;
        s.contacts_requested = self.input.contacts_wanted();
        s.friction_on = self.input.friction_wanted();
        s.friction = 0;
        let t0 = Instant::now();
        self.sim.step(&device, s);
        let frame_us = t0.elapsed().as_secs_f64() * 1e6;
        if !live {
            s.force = [0.0; 3];
            s.torque = [0.0; 3];
        }
        s.frame_us = frame_us;
        self.window_max = self.window_max.max(frame_us);
        if frame.is_multiple_of(self.window) {
            s.frame_us_max = self.window_max;
            self.window_max = 0.0;
        }
        s.recording = self.record_tx.record(frame, s.device);
        self.publisher.publish(s);
        self.frame += 1;
        &self.state
    }

    /// The simulation.
    pub fn sim(&self) -> &S {
        &self.sim
    }

    /// Runs frames paced at the period until `stop` is set, with the same pacing as
    /// `haptic6d run --realtime` ([`scene::rt::Pacer`]).
    fn run(mut self, stop: &AtomicBool, spin: Duration) {
        let mut pacer = scene::rt::Pacer::new(self.period, spin).with_nap(scene::rt::loop_nap());
        while !stop.load(Ordering::Acquire) {
            pacer.wait_warming(|until| self.sim.idle(until));
            self.step();
            if pacer.end_frame() {
                self.state.overruns += 1;
            }
        }
    }
}
