//! [`DeviceLink`]: the one place where a device's readings become scene poses and the
//! engine's wrench becomes the device's: calibration, unrendered axes, timeout.

use collide::Pose;
use engine::config::SettingError;
use nalgebra::Matrix3;
use serde::{Deserialize, Serialize};

use super::{Calibration, Capabilities, Device, DeviceSample, Reading};

/// How the loop talks to a device: the calibration and the timeout (`[device]` in a scene
/// file).
#[derive(Clone, Copy, Debug, PartialEq, Deserialize, Serialize)]
#[serde(default, deny_unknown_fields)]
pub struct DeviceSettings {
    /// Device frame to scene frame.
    pub calibration: Calibration,
    /// A device that delivers no pose for this long is released: the wrench goes to zero
    /// through the safety layer's rate limit until poses resume, s.
    pub timeout_s: f64,
}

impl Default for DeviceSettings {
    /// Identity calibration, 0.1 s timeout.
    fn default() -> Self {
        Self {
            calibration: Calibration::default(),
            timeout_s: 0.1,
        }
    }
}

impl DeviceSettings {
    /// Checks the calibration and the timeout against their ranges in [`engine::config`].
    pub fn validate(&self) -> Result<(), SettingError> {
        self.calibration.validate()?;
        engine::config::DEVICE_TIMEOUT_S.check(self.timeout_s)
    }
}

/// Per-frame flags of what the link did (bit set), in `scene::rt::FrameRecord::link`.
pub mod link_flags {
    /// No fresh reading: the last pose was held (within the timeout).
    pub const HELD: u8 = 1;
    /// No reading for longer than the timeout: the wrench is released toward zero.
    pub const RELEASED: u8 = 2;
    /// The first reading after a release: the safety layer's soft start applies again.
    pub const RESUMED: u8 = 4;
    /// A non-zero wrench component on an axis the device cannot render was zeroed.
    pub const MASKED: u8 = 8;
    /// The handle was outside the device's workspace box.
    pub const OUTSIDE_WORKSPACE: u8 = 16;
}

/// Counts of what the link did over a run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct LinkStats {
    /// Frames with a fresh reading.
    pub readings: u64,
    /// Frames that held the last pose (no reading, within the timeout).
    pub held_frames: u64,
    /// Frames released (no reading for longer than the timeout).
    pub released_frames: u64,
    /// Times the device timed out (released after answering).
    pub timeouts: u64,
    /// Frames whose wrench had a non-zero component on an axis the device cannot render.
    pub masked_frames: u64,
    /// Largest force dropped on unrendered axes, N.
    pub max_masked_force_n: f64,
    /// Largest torque dropped on unrendered axes, N·mm.
    pub max_masked_torque_nmm: f64,
    /// Readings outside the device's workspace box.
    pub outside_workspace: u64,
}

/// What the loop does this frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LinkRead {
    /// Step the engine with this scene pose (`flags`: [`link_flags`]; `RESUMED` asks for the
    /// soft start again).
    Step {
        /// The reading, its pose in the scene frame.
        sample: DeviceSample,
        /// [`link_flags`] of this frame.
        flags: u8,
    },
    /// No pose for longer than the timeout (or none yet): release the wrench
    /// ([`engine::Engine::release`]).
    Release,
    /// The device ended: stop.
    Ended,
}

/// A device with its calibration, capabilities and timeout: the loop reads scene poses from
/// it and writes scene wrenches to it.
pub struct DeviceLink<'d, D: Device + ?Sized> {
    device: &'d mut D,
    settings: DeviceSettings,
    caps: Capabilities,
    r: Matrix3<f64>,
    last: Option<DeviceSample>,
    last_t: f64,
    released: bool,
    flags: u8,
    stats: LinkStats,
}

impl<'d, D: Device + ?Sized> DeviceLink<'d, D> {
    /// The link of `device` with `settings` (which should have passed
    /// [`DeviceSettings::validate`]; a timeout outside its range is taken as 0.1 s).
    pub fn new(device: &'d mut D, settings: DeviceSettings) -> Self {
        let caps = device.capabilities();
        let mut settings = settings;
        if !engine::config::DEVICE_TIMEOUT_S.contains(settings.timeout_s) {
            settings.timeout_s = DeviceSettings::default().timeout_s;
        }
        Self {
            r: settings.calibration.rotation_matrix(),
            device,
            settings,
            caps,
            last: None,
            last_t: 0.0,
            released: false,
            flags: 0,
            stats: LinkStats::default(),
        }
    }

    /// The device's capabilities.
    pub fn capabilities(&self) -> &Capabilities {
        &self.caps
    }

    /// What the link did so far.
    pub fn stats(&self) -> &LinkStats {
        &self.stats
    }

    /// The flags of the current frame ([`link_flags`]).
    pub fn flags(&self) -> u8 {
        self.flags
    }

    /// Reads frame `frame` at loop time `t` (s): a fresh reading is mapped to the scene; no
    /// reading holds the last pose up to the timeout, then releases.
    ///
    /// # Real-time
    /// No allocation, no panic (beyond the device's own read).
    pub fn read(&mut self, frame: usize, t: f64) -> LinkRead {
        self.flags = 0;
        match self.device.read(frame, t) {
            Reading::Ended => LinkRead::Ended,
            Reading::Pose(s) => {
                if !self.caps.in_workspace(s.pose.q.as_slice()) {
                    self.flags |= link_flags::OUTSIDE_WORKSPACE;
                    self.stats.outside_workspace += 1;
                }
                let scene = DeviceSample {
                    pose: self.settings.calibration.to_scene(&self.r, &s.pose),
                    ..s
                };
                if self.released {
                    self.released = false;
                    self.flags |= link_flags::RESUMED;
                }
                self.stats.readings += 1;
                self.last = Some(scene);
                self.last_t = t;
                LinkRead::Step {
                    sample: scene,
                    flags: self.flags,
                }
            }
            Reading::Released => self.let_go(),
            Reading::Pending => match self.last {
                Some(s) if !self.released && t - self.last_t <= self.settings.timeout_s => {
                    self.flags |= link_flags::HELD;
                    self.stats.held_frames += 1;
                    LinkRead::Step {
                        sample: s,
                        flags: self.flags,
                    }
                }
                _ => {
                    if !self.released && self.last.is_some() {
                        self.stats.timeouts += 1;
                    }
                    self.let_go()
                }
            },
        }
    }

    /// Releases the wrench this frame; the next reading resumes with the soft start.
    fn let_go(&mut self) -> LinkRead {
        self.released = true;
        self.flags |= link_flags::RELEASED;
        self.stats.released_frames += 1;
        LinkRead::Release
    }

    /// Sends the scene-frame wrench `[F (N); T (N·mm)]` (after the safety layer): rotated to
    /// the device frame, axes the device cannot render zeroed (counted), then written.
    /// Returns the wrench written (device frame).
    ///
    /// # Real-time
    /// No allocation, no panic (beyond the device's own write).
    pub fn write(&mut self, wrench: &[f64; 6]) -> [f64; 6] {
        let mut w = self.settings.calibration.wrench_to_device(&self.r, wrench);
        let mut dropped = [0.0; 6];
        for k in 0..6 {
            if !self.caps.axes[k] {
                dropped[k] = w[k];
                w[k] = 0.0;
            }
        }
        if dropped.iter().any(|&d| d != 0.0) {
            self.flags |= link_flags::MASKED;
            self.stats.masked_frames += 1;
            let s = &mut self.stats;
            s.max_masked_force_n = s
                .max_masked_force_n
                .max(engine::safety::norm3(&dropped[0..3]));
            s.max_masked_torque_nmm = s
                .max_masked_torque_nmm
                .max(engine::safety::norm3(&dropped[3..6]));
        }
        self.device.write_wrench(&w);
        w
    }

    /// The last reading's pose in the scene frame, if any.
    pub fn last_pose(&self) -> Option<Pose> {
        self.last.map(|s| s.pose)
    }
}
