//! The device bridge: a [`scene::device::Device`] (a Haply Inverse3, a replayed trajectory)
//! driving the viewer's haptic loop, as the UDP bridge does for a device program. One thread
//! (`haptic6d-device`) paced at the loop's rate reads the device through a
//! [`DeviceLink`] (calibration, unrendered axes, timeout), hands each scene pose to the input
//! hub (source [`InputSource::Device`], valid for the link's timeout) and writes back the
//! wrench the haptic thread last published. A device that goes silent is released by the hub
//! when its pose expires, so the force goes to zero through the engine's soft start and rate
//! limit on the next engagement (as for the UDP bridge).

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use scene::device::{Device, DeviceLink, DeviceSettings, LinkRead, LinkStats};

use crate::error::ViewerError;
use crate::hub::{InputHub, InputSource, StateHub};

/// A running device bridge; [`DeviceBridge::stop`] ends it and closes the device.
pub struct DeviceBridge {
    name: String,
    stop: Arc<AtomicBool>,
    poses: Arc<AtomicU64>,
    thread: Option<JoinHandle<LinkStats>>,
}

impl DeviceBridge {
    /// Opens `device` (blocking: a device that cannot be opened is a one-line error) and starts
    /// the bridge thread at `rate_hz`, feeding `input` and writing the wrench from `state`.
    pub fn spawn(
        mut device: Box<dyn Device>,
        settings: DeviceSettings,
        rate_hz: f64,
        input: Arc<InputHub>,
        state: Arc<StateHub>,
    ) -> Result<Self, ViewerError> {
        settings
            .validate()
            .map_err(|e| ViewerError::Params(e.to_string()))?;
        if !(rate_hz.is_finite() && rate_hz > 0.0) {
            return Err(ViewerError::Params(format!(
                "device bridge rate {rate_hz} Hz: must be a positive number"
            )));
        }
        let name = device.name().to_string();
        device.open().map_err(|e| {
            ViewerError::Params(format!("device {name}: {}", scene::error_chain(&e)))
        })?;
        let stop = Arc::new(AtomicBool::new(false));
        let poses = Arc::new(AtomicU64::new(0));
        let (stop_t, poses_t) = (Arc::clone(&stop), Arc::clone(&poses));
        let period = Duration::from_secs_f64(1.0 / rate_hz);
        let thread = std::thread::Builder::new()
            .name("haptic6d-device".into())
            .spawn(move || {
                let stats = run(
                    &mut *device,
                    settings,
                    period,
                    &input,
                    &state,
                    &stop_t,
                    &poses_t,
                );
                device.close();
                stats
            })
            .map_err(ViewerError::Thread)?;
        Ok(Self {
            name,
            stop,
            poses,
            thread: Some(thread),
        })
    }

    /// The device's name (`haply`, `replay`).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Poses handed to the haptic loop so far.
    pub fn poses(&self) -> u64 {
        self.poses.load(Ordering::Relaxed)
    }

    /// Stops the bridge, closes the device and gives what the link counted.
    pub fn stop(mut self) -> LinkStats {
        self.stop.store(true, Ordering::Release);
        self.thread
            .take()
            .and_then(|t| t.join().ok())
            .unwrap_or_default()
    }
}

impl Drop for DeviceBridge {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Release);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// The bridge loop: one read and one write per period until stopped or the device ends.
fn run(
    device: &mut dyn Device,
    settings: DeviceSettings,
    period: Duration,
    input: &InputHub,
    state: &StateHub,
    stop: &AtomicBool,
    poses: &AtomicU64,
) -> LinkStats {
    let timeout = Duration::from_secs_f64(settings.timeout_s);
    let mut link = DeviceLink::new(device, settings);
    let t0 = Instant::now();
    let mut next = t0;
    let mut frame = 0usize;
    while !stop.load(Ordering::Acquire) {
        let now = Instant::now();
        match link.read(frame, (now - t0).as_secs_f64()) {
            LinkRead::Step { sample, .. } => {
                if input
                    .submit(InputSource::Device, sample.pose, Some(now + timeout))
                    .is_ok()
                {
                    poses.fetch_add(1, Ordering::Relaxed);
                }
            }
            // The hub releases an expired pose by itself; say so at once when the link does.
            LinkRead::Release => input.release(InputSource::Device),
            LinkRead::Ended => break,
        }
        // The wrench the haptic thread published for this device's pose (zero otherwise).
        let wrench = state.with_latest(|s| {
            if s.released || s.source != InputSource::Device as u8 {
                [0.0; 6]
            } else {
                [
                    s.force[0],
                    s.force[1],
                    s.force[2],
                    s.torque[0],
                    s.torque[1],
                    s.torque[2],
                ]
            }
        });
        link.write(&wrench);
        frame += 1;
        next += period;
        let now = Instant::now();
        if next > now {
            std::thread::sleep(next - now);
        } else {
            next = now;
        }
    }
    input.release(InputSource::Device);
    *link.stats()
}
