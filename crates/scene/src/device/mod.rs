//! Haptic devices behind one trait, in the spirit of CHAI3D's `cGenericHapticDevice`.
//!
//! Entry points:
//! - [`Device`]: open/close, read a pose (mm, rad, time stamp, buttons), write a wrench (N,
//!   N·mm), [`Capabilities`] (rendered axes, limits, workspace).
//! - [`Calibration`]: the device frame to the scene frame (scale, rotation, offset), applied in
//!   one place, [`DeviceLink`], which also zeroes the axes a device cannot render and releases
//!   the wrench when the device stops answering ([`DeviceSettings::timeout_s`]).
//! - Implementations: [`ReplayDevice`] (a recorded trajectory), [`ScriptedDevice`] (keyframes),
//!   [`Emulator`] (a mass–spring–damper hand, closed loop with the wrench).
//!
//! (Live device poses reach `haptic6d serve` through its UDP bridge; the viewer's recorder,
//! `serve --record`, writes them into the trajectory CSV that [`ReplayDevice`] replays.)

mod calibration;
mod emulator;
mod link;

pub use calibration::Calibration;
pub use emulator::{Emulator, EmulatorParams, MIN_SUBSTEPS, PUSH_RAMP_S};
pub use link::{link_flags, DeviceLink, DeviceSettings, LinkRead, LinkStats};

use collide::Pose;
use serde::Serialize;

use crate::trajectory::{Script, Trajectory};

/// Which device a run uses (`[device] kind`, `haptic6d run --device`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DeviceKind {
    /// Replays the scene's trajectory (or `--trajectory`), open loop.
    #[default]
    Replay,
    /// The emulated hand ([`Emulator`]) follows the scene's trajectory as its intention,
    /// closed loop with the wrench.
    Emulator,
    /// A Haply Inverse3 (with a VerseGrip) through the Inverse Service: made by the
    /// `haptic6d-haply` crate (`haply_device::HaplyInverse3`), which the command line includes
    /// when built with its `haply` feature.
    Haply,
    /// A device program speaking the UDP protocol of `haptic6d serve`'s bridge (docs/VIEWER.md):
    /// made by the viewer crate (`viewer::UdpDevice`).
    Udp,
}

impl engine::setting::Setting for DeviceKind {
    const WHAT: &'static str = "device";
    const ALL: &'static [Self] = &[
        DeviceKind::Replay,
        DeviceKind::Emulator,
        DeviceKind::Haply,
        DeviceKind::Udp,
    ];
    fn setting_name(self) -> &'static str {
        match self {
            DeviceKind::Replay => "replay",
            DeviceKind::Emulator => "emulator",
            DeviceKind::Haply => "haply",
            DeviceKind::Udp => "udp",
        }
    }
}

/// A scene's device: which one, how it is linked (calibration, timeout) and the emulator's
/// parameters.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DeviceConfig {
    /// Which device.
    pub kind: DeviceKind,
    /// Calibration and timeout.
    pub settings: DeviceSettings,
    /// The emulated hand (used when `kind` is [`DeviceKind::Emulator`]).
    pub emulator: EmulatorParams,
}

impl DeviceConfig {
    /// Checks the link settings and the emulator's parameters against their ranges.
    pub fn validate(&self) -> Result<(), engine::config::SettingError> {
        self.settings.validate()?;
        self.emulator.validate()
    }

    /// The device of `kind` for a run whose device motion (scene frame, one row per frame at
    /// `rate_hz`) is `trajectory`: a replay of it, or the emulated hand with it as its
    /// intention (mapped into the device frame through the calibration). Allocates. A live
    /// device ([`DeviceKind::Haply`], [`DeviceKind::Udp`]) is made by its own crate: an error
    /// here.
    pub fn make(
        &self,
        kind: DeviceKind,
        trajectory: Trajectory,
        rate_hz: f64,
    ) -> Result<Box<dyn Device>, crate::SceneError> {
        // The trajectory is the scene-frame motion; the device reports device-frame poses,
        // which the link maps back through the same calibration.
        let cal = &self.settings.calibration;
        let r = cal.rotation_matrix();
        let mut t = trajectory;
        for s in &mut t.samples {
            s.q = cal.to_device(&r, &Pose::from_array(s.q)).to_array();
        }
        match kind {
            DeviceKind::Replay => Ok(Box::new(ReplayDevice::new(t))),
            DeviceKind::Emulator => Ok(Box::new(Emulator::new(self.emulator, t, rate_hz))),
            DeviceKind::Haply => Err(crate::SceneError::scene(
                "haply",
                "the Haply Inverse3 is made by the haptic6d-haply crate (haply_device::HaplyInverse3)",
            )),
            DeviceKind::Udp => Err(crate::SceneError::scene(
                "udp",
                "a UDP device is made by the viewer crate (viewer::UdpDevice)",
            )),
        }
    }
}

/// One reading of a device: time stamp (s), configuration (mm, rad) and buttons.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DeviceSample {
    /// Time of the reading, s since the start of the run (the device's own clock).
    pub t: f64,
    /// Device (haptic tool) configuration `[x, y, z, gamma, beta, alpha]` (mm, rad), in the
    /// device frame.
    pub pose: Pose,
    /// Buttons held, one bit per button (bit 0 = button 0).
    pub buttons: u32,
}

impl DeviceSample {
    /// A reading with no button held.
    pub fn new(t: f64, pose: Pose) -> Self {
        Self {
            t,
            pose,
            buttons: 0,
        }
    }
}

/// What one [`Device::read`] gives.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Reading {
    /// A fresh reading.
    Pose(DeviceSample),
    /// No reading this frame (the device is late or silent); the loop holds the last pose and,
    /// after [`DeviceSettings::timeout_s`], releases the wrench.
    Pending,
    /// The device says its user let go (a device program ended its session): the loop
    /// releases the wrench at once, without waiting for the timeout, and the next reading
    /// re-engages with the soft start.
    Released,
    /// The device has no more input (end of a replay or script); the loop stops.
    Ended,
}

/// What a device can render and where it can move, in the device frame.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Capabilities {
    /// Which of the six wrench axes `[Fx, Fy, Fz, Tx, Ty, Tz]` the device renders; the others
    /// are zeroed before sending (and counted).
    pub axes: [bool; 6],
    /// Largest force the device renders, N.
    pub max_force_n: f64,
    /// Largest torque the device renders, N·mm.
    pub max_torque_nmm: f64,
    /// Largest coupling stiffness the device renders stably, N/mm of device motion.
    pub max_stiffness_n_per_mm: f64,
    /// Workspace box `[lo, hi]` of the handle position, mm (device frame).
    pub workspace_mm: [[f64; 3]; 2],
}

impl Default for Capabilities {
    /// Everything the engine's ranges allow: six axes, 100 N, 10 000 N·mm, 100 N/mm, ±1e6 mm.
    fn default() -> Self {
        Self {
            axes: [true; 6],
            max_force_n: engine::config::MAX_FORCE_N.hi,
            max_torque_nmm: engine::config::MAX_TORQUE_NMM.hi,
            max_stiffness_n_per_mm: engine::config::KT.hi,
            workspace_mm: [
                [-engine::config::POSE_ABS; 3],
                [engine::config::POSE_ABS; 3],
            ],
        }
    }
}

impl Capabilities {
    /// `safety` with its force and torque limits lowered to the device's.
    pub fn limit(&self, safety: &engine::safety::SafetyParams) -> engine::safety::SafetyParams {
        engine::safety::SafetyParams {
            max_force_n: safety.max_force_n.min(self.max_force_n),
            max_torque_nmm: safety.max_torque_nmm.min(self.max_torque_nmm),
            ..*safety
        }
    }

    /// Checks that the stiffness felt at the handle, `kt × scale` (N/mm of device motion), is
    /// within the device's [`Capabilities::max_stiffness_n_per_mm`].
    pub fn check_stiffness(
        &self,
        kt: f64,
        calibration: &Calibration,
    ) -> Result<(), engine::config::SettingError> {
        let felt = kt * calibration.scale;
        if felt <= self.max_stiffness_n_per_mm {
            return Ok(());
        }
        Err(engine::config::SettingError {
            key: "[coupling] kt".into(),
            value: format!("{kt}"),
            expected: format!(
                "at most {} N/mm for this device (kt × calibration scale {} is felt at the handle)",
                self.max_stiffness_n_per_mm / calibration.scale,
                calibration.scale
            ),
        })
    }

    /// True when the position `p` (mm, device frame) is inside the workspace box.
    pub fn in_workspace(&self, p: &[f64]) -> bool {
        (0..3).all(|k| p[k] >= self.workspace_mm[0][k] && p[k] <= self.workspace_mm[1][k])
    }
}

/// A 6-DoF haptic device: the loop opens it, reads a pose and writes a wrench once per frame,
/// and closes it. Poses and wrenches are in the device frame; [`DeviceLink`] maps them to and
/// from the scene.
pub trait Device: Send {
    /// A short name for reports (`replay`, `emulator`).
    fn name(&self) -> &str;

    /// Opens the device (connect, home, enable motors). Called once before the loop. The
    /// default does nothing.
    fn open(&mut self) -> Result<(), crate::SceneError> {
        Ok(())
    }

    /// Closes the device (zero wrench, disable motors). Called once after the loop. The
    /// default does nothing.
    fn close(&mut self) {}

    /// What the device renders and where it moves. The default: [`Capabilities::default`].
    fn capabilities(&self) -> Capabilities {
        Capabilities::default()
    }

    /// The reading for haptic frame `frame` (0-based) at loop time `t` (s).
    ///
    /// # Real-time
    /// Implementations must not allocate or block.
    fn read(&mut self, frame: usize, t: f64) -> Reading;

    /// Sends the wrench `[F (N); T (N·mm)]`, device frame, axes it cannot render already zero.
    /// The default ignores it.
    ///
    /// # Real-time
    /// Implementations must not allocate or block.
    fn write_wrench(&mut self, _wrench: &[f64; 6]) {}

    /// Number of frames this device will produce, when known.
    fn frames(&self) -> Option<usize> {
        None
    }
}

impl<D: Device + ?Sized> Device for Box<D> {
    fn name(&self) -> &str {
        (**self).name()
    }
    fn open(&mut self) -> Result<(), crate::SceneError> {
        (**self).open()
    }
    fn close(&mut self) {
        (**self).close()
    }
    fn capabilities(&self) -> Capabilities {
        (**self).capabilities()
    }
    fn read(&mut self, frame: usize, t: f64) -> Reading {
        (**self).read(frame, t)
    }
    fn write_wrench(&mut self, wrench: &[f64; 6]) {
        (**self).write_wrench(wrench)
    }
    fn frames(&self) -> Option<usize> {
        (**self).frames()
    }
}

/// Replays a trajectory: row `i` is the device configuration of frame `i`.
#[derive(Clone, Debug)]
pub struct ReplayDevice {
    trajectory: Trajectory,
}

impl ReplayDevice {
    /// A device replaying `trajectory` one row per frame.
    pub fn new(trajectory: Trajectory) -> Self {
        Self { trajectory }
    }
}

impl Device for ReplayDevice {
    fn name(&self) -> &str {
        "replay"
    }

    fn read(&mut self, frame: usize, _t: f64) -> Reading {
        match self.trajectory.samples.get(frame) {
            Some(s) => Reading::Pose(DeviceSample::new(s.t, Pose::from_array(s.q))),
            None => Reading::Ended,
        }
    }

    fn frames(&self) -> Option<usize> {
        Some(self.trajectory.len())
    }
}

/// Scripted motion: a keyframe script evaluated at `frame / rate_hz`.
#[derive(Clone, Debug)]
pub struct ScriptedDevice {
    script: Script,
    rate_hz: f64,
}

impl ScriptedDevice {
    /// A device following `script`, sampled at `rate_hz` (frames per second).
    pub fn new(script: Script, rate_hz: f64) -> Self {
        Self { script, rate_hz }
    }
}

impl Device for ScriptedDevice {
    fn name(&self) -> &str {
        "scripted"
    }

    fn read(&mut self, frame: usize, _t: f64) -> Reading {
        let t = frame as f64 / self.rate_hz;
        if t > self.script.duration() + 0.5 / self.rate_hz {
            return Reading::Ended;
        }
        Reading::Pose(DeviceSample::new(
            t,
            Pose::from_array(self.script.sample(t)),
        ))
    }

    fn frames(&self) -> Option<usize> {
        Some((self.script.duration() * self.rate_hz).round() as usize + 1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trajectory::{Ease, TrajSample};

    #[test]
    fn recorded_script_replays_identically() {
        let script = Script::starting_at([0.0, 0.0, 10.0, 0.0, 0.0, 0.0]).then(
            0.02,
            [5.0, 0.0, 0.0, 0.1, 0.2, 0.3],
            Ease::Smooth,
        );
        let mut scripted = ScriptedDevice::new(script, 1000.0);
        let mut live = Vec::new();
        let mut i = 0;
        while let Reading::Pose(s) = scripted.read(i, 0.0) {
            live.push(s);
            i += 1;
        }
        assert_eq!(live.len(), 21);
        let recorded = Trajectory {
            samples: live
                .iter()
                .map(|s| TrajSample {
                    t: s.t,
                    q: s.pose.to_array(),
                })
                .collect(),
        };
        let text = recorded.to_csv_string();
        let mut replay = ReplayDevice::new(Trajectory::parse_csv(&text, "mem").unwrap());
        for (i, s) in live.iter().enumerate() {
            assert_eq!(replay.read(i, 0.0), Reading::Pose(*s));
        }
        assert_eq!(replay.read(live.len(), 0.0), Reading::Ended);
    }

    #[test]
    fn stiffness_beyond_the_device_is_refused_with_the_scale_taken_into_account() {
        let caps = Capabilities {
            max_stiffness_n_per_mm: 2.0,
            ..Capabilities::default()
        };
        let cal = Calibration {
            scale: 4.0,
            ..Calibration::default()
        };
        caps.check_stiffness(0.5, &cal).unwrap();
        let e = caps.check_stiffness(1.0, &cal).unwrap_err().to_string();
        assert!(
            e.starts_with("[coupling] kt = 1: must be at most 0.5 N/mm"),
            "{e}"
        );
    }
}
