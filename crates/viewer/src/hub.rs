//! Lock-free hand-over between the haptic thread and everyone else.
//!
//! - [`InputHub`]: many writers (page connections, the UDP bridge) → the haptic thread. The
//!   writers serialise among themselves with a mutex; the haptic thread reads the latest
//!   [`DeviceCommand`] from a triple buffer without locking.
//! - [`StateHub`]: the haptic thread → many readers (WebSocket streams, the UDP bridge). The
//!   haptic thread publishes every frame into a triple buffer without locking; readers share
//!   the output end behind a mutex.

use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use collide::Pose;

use crate::simulation::FrameState;

/// Who is driving the device pose.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[repr(u8)]
pub enum InputSource {
    /// Nobody: the device is held at the graphic pose (zero force).
    #[default]
    None = 0,
    /// The web page (mouse, keys, gamepad).
    Page = 1,
    /// The UDP device bridge.
    Udp = 2,
    /// A program using the library directly (tests, scripts).
    Script = 3,
    /// A device driven through the device trait ([`crate::DeviceBridge`]: a Haply Inverse3, a
    /// replay).
    Device = 4,
}

/// The latest device pose and where it came from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DeviceCommand {
    /// Device configuration (mm, rad).
    pub pose: Pose,
    /// Who sent it.
    pub source: InputSource,
    /// Increases by one with every accepted command.
    pub seq: u64,
    /// Which engagement this command belongs to: a new number whenever a source starts to
    /// drive after a release, after its last command expired, or in place of another source,
    /// however soon after. The haptic thread restarts the safety filter (soft start, rate
    /// limit from zero) whenever the number changes, so a release followed within the same
    /// frame by a new session still ramps the force from zero.
    pub engagement: u64,
    /// After this instant the command is stale: the haptic thread releases the device (holds
    /// it at the graphic pose, zero force). `None` = never stale.
    pub expires: Option<Instant>,
}

impl Default for DeviceCommand {
    fn default() -> Self {
        Self {
            pose: Pose::identity(),
            source: InputSource::None,
            seq: 0,
            engagement: 0,
            expires: None,
        }
    }
}

impl DeviceCommand {
    /// True when this command drives the device at `now` (a source is set and it has not expired).
    #[inline]
    pub fn is_live(&self, now: Instant) -> bool {
        self.source != InputSource::None && self.expires.is_none_or(|e| now < e)
    }
}

/// Why a command was not accepted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Rejected {
    /// Another source is live and has priority (a live UDP device outranks the page).
    Busy(InputSource),
    /// The pose has a NaN or infinite component.
    NotFinite,
}

/// Many writers → the haptic thread: the latest [`DeviceCommand`].
pub struct InputHub {
    writer: Mutex<Writer>,
    resets: AtomicU64,
    contact_viewers: AtomicUsize,
    friction_off: AtomicBool,
}

struct Writer {
    input: triple_buffer::Input<DeviceCommand>,
    last: DeviceCommand,
}

impl Writer {
    /// No source drives from now on; the pose is kept (the next engagement is a new one).
    fn let_go(&mut self) {
        let cmd = DeviceCommand {
            source: InputSource::None,
            seq: self.last.seq + 1,
            expires: None,
            ..self.last
        };
        self.last = cmd;
        self.input.write(cmd);
    }
}

/// The haptic thread's end of an [`InputHub`].
pub struct InputReader {
    output: triple_buffer::Output<DeviceCommand>,
}

impl InputReader {
    /// The latest command.
    ///
    /// # Real-time
    /// Wait-free, no allocation, no panic.
    #[inline]
    pub fn latest(&mut self) -> DeviceCommand {
        *self.output.read()
    }
}

impl InputHub {
    /// A hub and the haptic thread's reader; no command yet (the device is released).
    pub fn new() -> (Self, InputReader) {
        let (input, output) = triple_buffer::triple_buffer(&DeviceCommand::default());
        (
            Self {
                writer: Mutex::new(Writer {
                    input,
                    last: DeviceCommand::default(),
                }),
                resets: AtomicU64::new(0),
                contact_viewers: AtomicUsize::new(0),
                friction_off: AtomicBool::new(false),
            },
            InputReader { output },
        )
    }

    /// Submits a device pose from `source`, stale after `expires`. A live physical device (UDP
    /// or the device bridge) outranks the page: page poses are rejected while one drives the
    /// loop. Returns the command's sequence number.
    pub fn submit(
        &self,
        source: InputSource,
        pose: Pose,
        expires: Option<Instant>,
    ) -> Result<u64, Rejected> {
        if !pose.is_finite() {
            return Err(Rejected::NotFinite);
        }
        let mut w = self.writer.lock().unwrap_or_else(|p| p.into_inner());
        let now = Instant::now();
        let physical = matches!(w.last.source, InputSource::Udp | InputSource::Device);
        if source == InputSource::Page && physical && w.last.is_live(now) {
            return Err(Rejected::Busy(w.last.source));
        }
        // The same source still driving continues its engagement; anything else starts one.
        let continues = w.last.source == source && w.last.is_live(now);
        let cmd = DeviceCommand {
            pose,
            source,
            seq: w.last.seq + 1,
            engagement: w.last.engagement + u64::from(!continues),
            expires,
        };
        w.last = cmd;
        w.input.write(cmd);
        Ok(cmd.seq)
    }

    /// Releases the device now if `source` is driving it (zero force until the next command).
    pub fn release(&self, source: InputSource) {
        let mut w = self.writer.lock().unwrap_or_else(|p| p.into_inner());
        if w.last.source == source {
            w.let_go();
        }
    }

    /// The last command accepted (whether or not the haptic thread has seen it).
    pub fn last(&self) -> DeviceCommand {
        self.writer.lock().unwrap_or_else(|p| p.into_inner()).last
    }

    /// Asks the haptic thread to re-seat the god-object and the device at the start pose, on
    /// behalf of `source`, which lets go first. Refused while another source drives the device
    /// (a reset would move a hand that a device program holds): a live UDP device or device
    /// bridge is reset only by its own program ending its session.
    pub fn request_reset(&self, source: InputSource) -> Result<(), Rejected> {
        let mut w = self.writer.lock().unwrap_or_else(|p| p.into_inner());
        if w.last.source != source && w.last.is_live(Instant::now()) {
            return Err(Rejected::Busy(w.last.source));
        }
        if w.last.source == source {
            w.let_go();
        }
        // Counted under the writer lock, so no command can slip in between the check and
        // the request.
        self.resets.fetch_add(1, Ordering::Release);
        Ok(())
    }

    /// True while a physical device (the UDP bridge or the device bridge) drives the tool: the
    /// pages then watch.
    pub fn device_drives(&self) -> bool {
        let w = self.writer.lock().unwrap_or_else(|p| p.into_inner());
        matches!(w.last.source, InputSource::Udp | InputSource::Device)
            && w.last.is_live(Instant::now())
    }

    /// One more viewer wants the contact list (`true`) or one fewer (`false`).
    pub fn want_contacts(&self, on: bool) {
        if on {
            self.contact_viewers.fetch_add(1, Ordering::AcqRel);
        } else {
            let _ = self
                .contact_viewers
                .fetch_update(Ordering::AcqRel, Ordering::Acquire, |n| n.checked_sub(1));
        }
    }

    /// Turns friction on or off (the page's switch; on by default).
    pub fn set_friction(&self, on: bool) {
        self.friction_off.store(!on, Ordering::Release);
    }

    /// True unless friction was turned off.
    ///
    /// # Real-time
    /// One atomic load.
    #[inline]
    pub fn friction_wanted(&self) -> bool {
        !self.friction_off.load(Ordering::Acquire)
    }

    /// True while at least one viewer wants the contact list.
    ///
    /// # Real-time
    /// One atomic load.
    #[inline]
    pub fn contacts_wanted(&self) -> bool {
        self.contact_viewers.load(Ordering::Acquire) > 0
    }

    /// How many resets were requested so far (the haptic thread compares with its own count).
    ///
    /// # Real-time
    /// One atomic load.
    #[inline]
    pub fn reset_count(&self) -> u64 {
        self.resets.load(Ordering::Acquire)
    }
}

/// The haptic thread → many readers: the latest [`FrameState`].
pub struct StateHub {
    output: Mutex<triple_buffer::Output<FrameState>>,
}

/// The haptic thread's end of a [`StateHub`].
pub struct StatePublisher {
    input: triple_buffer::Input<FrameState>,
}

impl StatePublisher {
    /// Publishes `state` (copied into the back buffer, reusing its memory).
    ///
    /// # Real-time
    /// Wait-free; no allocation (all buffers are sized for the display contacts at
    /// construction); O(contacts).
    #[inline]
    pub fn publish(&mut self, state: &FrameState) {
        self.input.input_buffer_mut().copy_from(state);
        self.input.publish();
    }
}

impl StateHub {
    /// A hub starting with `initial` and the haptic thread's publisher.
    pub fn new(initial: &FrameState) -> (Self, StatePublisher) {
        let (input, output) = triple_buffer::triple_buffer(initial);
        (
            Self {
                output: Mutex::new(output),
            },
            StatePublisher { input },
        )
    }

    /// Runs `f` on the latest state (blocks other readers, never the haptic thread).
    pub fn with_latest<R>(&self, f: impl FnOnce(&FrameState) -> R) -> R {
        let mut out = self.output.lock().unwrap_or_else(|p| p.into_inner());
        f(out.read())
    }

    /// A copy of the latest state.
    pub fn latest(&self) -> FrameState {
        self.with_latest(|s| s.clone())
    }
}
