//! Haptic devices behind one trait: trajectory replay and scripted motion. (Live device poses
//! are recorded by the viewer's recorder, `haptic6d serve --record`, into the trajectory CSV
//! that [`ReplayDevice`] replays.)

use collide::Pose;

use crate::trajectory::{Script, Trajectory};

/// One reading of a device: time (s) and configuration (mm, rad).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DeviceSample {
    /// Time of the reading, s since the start of the run.
    pub t: f64,
    /// Device (haptic tool) configuration.
    pub pose: Pose,
}

/// A 6-DoF haptic device: reads a configuration each frame and receives the wrench.
pub trait Device: Send {
    /// The device configuration for haptic frame `frame` (0-based), at wall/simulated time
    /// `t` (s). `None` when the device has no more input (end of a replay or script).
    ///
    /// # Real-time
    /// Implementations must not allocate or block.
    fn read(&mut self, frame: usize, t: f64) -> Option<DeviceSample>;

    /// Sends the wrench `[F (N); T (N·mm)]` to the device. The default ignores it.
    ///
    /// # Real-time
    /// Implementations must not allocate or block.
    fn send(&mut self, _wrench: &[f64; 6]) {}

    /// Number of frames this device will produce, when known.
    fn frames(&self) -> Option<usize> {
        None
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
    fn read(&mut self, frame: usize, _t: f64) -> Option<DeviceSample> {
        self.trajectory.samples.get(frame).map(|s| DeviceSample {
            t: s.t,
            pose: Pose::from_array(s.q),
        })
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
    fn read(&mut self, frame: usize, _t: f64) -> Option<DeviceSample> {
        let t = frame as f64 / self.rate_hz;
        if t > self.script.duration() + 0.5 / self.rate_hz {
            return None;
        }
        Some(DeviceSample {
            t,
            pose: Pose::from_array(self.script.sample(t)),
        })
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
        while let Some(s) = scripted.read(i, 0.0) {
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
            assert_eq!(replay.read(i, 0.0), Some(*s));
        }
        assert_eq!(replay.read(live.len(), 0.0), None);
    }
}
