//! The Haply Inverse3 as a haptic6d [`Device`], through Haply's official Rust client
//! ([`haply`]) of the Inverse Service (the local service that owns the device; its WebSocket
//! carries the device state out and the cursor force in).
//!
//! The Inverse3 is a 3-DoF force device: it reports its cursor position (m) and renders a
//! cursor force (N). A VerseGrip, when one is connected, adds the handle's orientation (a
//! quaternion) and its button. So the pose has six coordinates but the wrench has three: the
//! torque is not rendered. [`HaplyInverse3::capabilities`] says so, and the device link zeroes
//! and counts it ([`scene::device::DeviceLink`]); the viewer and `frames.csv` still show it.
//!
//! Threads: the client is asynchronous (tokio). [`HaplyInverse3::open`] starts one thread with
//! its own runtime, which connects, keeps the latest reading, and sends the latest force once
//! per period. The haptic loop never waits for it: [`Device::read`] and
//! [`Device::write_wrench`] only try a lock that the service thread holds for a copy. A reading
//! not yet there is [`Reading::Pending`]; a service that stops answering becomes a device
//! timeout, and the link ramps the wrench to zero through the safety layer's rate limit.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, TryLockError};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use collide::Pose;
use haply::device_model::{Force, ForceInput};
use haply::HaplyDevice;
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use scene::device::{Capabilities, Device, DeviceSample, Reading};
use scene::SceneError;

/// Where the Inverse Service listens, and how the client paces itself.
#[derive(Clone, Debug, PartialEq)]
pub struct HaplyParams {
    /// The service's HTTP base address.
    pub http_url: String,
    /// The service's WebSocket address.
    pub ws_url: String,
    /// How long [`HaplyInverse3::open`] waits for the service and a first Inverse3 reading.
    pub connect_timeout: Duration,
    /// How often the service thread sends the latest force (and takes the latest reading).
    pub period: Duration,
    /// With no new state from the service for this long, the service thread gives up: it
    /// closes the connection (the device then reads as silent; the link releases the wrench).
    pub stale_after: Duration,
}

impl Default for HaplyParams {
    /// The Inverse Service on this machine (Haply's default port 10001), 1 kHz.
    fn default() -> Self {
        Self {
            http_url: "http://localhost:10001".into(),
            ws_url: "ws://localhost:10001/".into(),
            connect_timeout: Duration::from_secs(3),
            period: Duration::from_millis(1),
            stale_after: Duration::from_secs(1),
        }
    }
}

/// The latest reading the service thread has taken.
#[derive(Clone, Copy, Debug, Default)]
struct Latest {
    /// Counts fresh readings (0 = none yet).
    seq: u64,
    /// Seconds since the device was opened.
    t: f64,
    /// Cursor position, mm.
    position_mm: [f64; 3],
    /// Handle orientation (VerseGrip), a unit quaternion `[w, x, y, z]`; identity without one.
    orientation: [f64; 4],
    button: bool,
}

/// What the haptic loop and the service thread share (each holds the lock for a copy).
#[derive(Debug, Default)]
struct Shared {
    latest: Latest,
    /// The force to send, N (device frame).
    force: [f64; 3],
    /// Commands the service thread sent, and the last force in them (for reports and tests).
    sent: u64,
    /// Why the service thread stopped, if it did.
    error: Option<String>,
}

/// The Haply Inverse3 (with a VerseGrip when present) as a [`Device`].
pub struct HaplyInverse3 {
    params: HaplyParams,
    shared: Arc<Mutex<Shared>>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
    last_seq: u64,
}

impl HaplyInverse3 {
    /// A device for the Inverse Service at `params` (nothing is connected until
    /// [`Device::open`]).
    pub fn new(params: HaplyParams) -> Self {
        Self {
            params,
            shared: Arc::new(Mutex::new(Shared::default())),
            stop: Arc::new(AtomicBool::new(false)),
            thread: None,
            last_seq: 0,
        }
    }

    /// Commands sent to the service so far, and why the service thread stopped (if it did).
    pub fn status(&self) -> (u64, Option<String>) {
        let s = self.shared.lock().unwrap_or_else(|p| p.into_inner());
        (s.sent, s.error.clone())
    }
}

impl Drop for HaplyInverse3 {
    fn drop(&mut self) {
        self.close();
    }
}

impl Device for HaplyInverse3 {
    fn name(&self) -> &str {
        "haply"
    }

    /// Connects to the Inverse Service, waits for the first Inverse3 reading (at most
    /// [`HaplyParams::connect_timeout`]) and starts sending the force. Blocks; call before the
    /// loop. Errors in one line: the service is not there, or no Inverse3 is connected to it.
    fn open(&mut self) -> Result<(), SceneError> {
        if self.thread.is_some() {
            return Ok(());
        }
        self.stop.store(false, Ordering::Release);
        let (params, shared, stop) = (
            self.params.clone(),
            Arc::clone(&self.shared),
            Arc::clone(&self.stop),
        );
        let thread = std::thread::Builder::new()
            .name("haply-service".into())
            .spawn(move || service_thread(&params, &shared, &stop))
            .map_err(|e| SceneError::caused("haply", "cannot start the service thread", e))?;
        self.thread = Some(thread);
        let end = Instant::now() + self.params.connect_timeout;
        loop {
            {
                let s = self.shared.lock().unwrap_or_else(|p| p.into_inner());
                if let Some(e) = &s.error {
                    let msg = format!("{e} ({})", self.params.ws_url);
                    drop(s);
                    self.close();
                    return Err(SceneError::scene("haply", msg));
                }
                if s.latest.seq > 0 {
                    return Ok(());
                }
            }
            if Instant::now() >= end {
                self.close();
                return Err(SceneError::scene(
                    "haply",
                    format!(
                        "no Inverse3 reading from the Inverse Service at {} within {:.1} s; is the service running and the device connected?",
                        self.params.ws_url,
                        self.params.connect_timeout.as_secs_f64()
                    ),
                ));
            }
            std::thread::sleep(Duration::from_millis(5));
        }
    }

    /// Sends a zero force and stops the service thread (waits for it).
    fn close(&mut self) {
        if let Ok(mut s) = self.shared.lock() {
            s.force = [0.0; 3];
        }
        self.stop.store(true, Ordering::Release);
        if let Some(t) = self.thread.take() {
            // The thread ends within a period and the client's shutdown (bounded); a thread
            // that still has not ended after a second is left to end on its own.
            let end = Instant::now() + Duration::from_secs(1);
            while !t.is_finished() && Instant::now() < end {
                std::thread::sleep(Duration::from_millis(2));
            }
            if t.is_finished() {
                let _ = t.join();
            }
        }
    }

    /// Three force axes (the Inverse3 renders no torque), in its own frame (mm here).
    fn capabilities(&self) -> Capabilities {
        Capabilities {
            axes: [true, true, true, false, false, false],
            ..Capabilities::default()
        }
    }

    /// The newest reading the service thread has taken, once: [`Reading::Pending`] until a new
    /// one arrives (or while the service thread holds the lock for its copy).
    fn read(&mut self, _frame: usize, _t: f64) -> Reading {
        let latest = match self.shared.try_lock() {
            Ok(s) => s.latest,
            Err(TryLockError::WouldBlock) => return Reading::Pending,
            Err(TryLockError::Poisoned(p)) => p.into_inner().latest,
        };
        if latest.seq == self.last_seq {
            return Reading::Pending;
        }
        self.last_seq = latest.seq;
        let [w, x, y, z] = latest.orientation;
        let rot = UnitQuaternion::from_quaternion(Quaternion::new(w, x, y, z));
        let pose = Pose::from_translation_rotation(
            &Vector3::from(latest.position_mm),
            &rot.to_rotation_matrix().into_inner(),
        );
        Reading::Pose(DeviceSample {
            t: latest.t,
            pose,
            buttons: u32::from(latest.button),
        })
    }

    /// Keeps the force (N) for the service thread's next command; the torque is not rendered.
    fn write_wrench(&mut self, wrench: &[f64; 6]) {
        let force = [wrench[0], wrench[1], wrench[2]];
        match self.shared.try_lock() {
            Ok(mut s) => s.force = force,
            Err(TryLockError::Poisoned(p)) => p.into_inner().force = force,
            // The service thread is copying: this frame's force goes with the next one.
            Err(TryLockError::WouldBlock) => {}
        }
    }
}

/// The service thread: connect, then once per period take the latest reading and send the
/// latest force, until stopped or the service goes silent.
fn service_thread(params: &HaplyParams, shared: &Mutex<Shared>, stop: &AtomicBool) {
    let fail = |msg: String| {
        if let Ok(mut s) = shared.lock() {
            s.error = Some(msg);
        }
    };
    // Two workers: the client's listener task spins on a closed stream until it is shut down;
    // the other worker keeps the timers of this loop running meanwhile (so the loop notices the
    // silence and shuts it down).
    let rt = match tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
    {
        Ok(rt) => rt,
        Err(e) => return fail(format!("cannot start the client runtime: {e}")),
    };
    rt.block_on(async {
        let connect = HaplyDevice::new(&params.http_url, &params.ws_url);
        let mut device = match tokio::time::timeout(params.connect_timeout, connect).await {
            Ok(Ok(d)) => d,
            Ok(Err(e)) => return fail(format!("cannot connect to the Inverse Service: {e}")),
            Err(_) => return fail("the Inverse Service did not answer".into()),
        };
        let t0 = Instant::now();
        let mut last_stamp = None;
        let mut fresh_at = Instant::now();
        let mut device_id: Option<String> = None;
        let mut seq = 0u64;
        let mut next = Instant::now();
        while !stop.load(Ordering::Acquire) {
            // Paced on this thread's own clock, not the runtime's timers: the client's listener
            // spins on a closed stream and can starve the runtime's time driver until it is
            // shut down (below), which this loop must still get to do. (This thread runs only
            // this loop; the client's tasks run on the runtime's workers.)
            next += params.period;
            let now = Instant::now();
            if next > now {
                std::thread::sleep(next - now);
            } else {
                next = now;
            }
            // The client's cached state: the listener task keeps it from the service's frames.
            let (data, stamp) = {
                let s = device.state.lock().await;
                (s.data.clone(), s.timestamp)
            };
            if last_stamp != Some(stamp) {
                last_stamp = Some(stamp);
                if let Some(inv) = data.inverse3.first() {
                    if let Some(p) = inv.state.cursor_position {
                        fresh_at = Instant::now();
                        device_id = Some(inv.device_id.clone());
                        seq += 1;
                        let grip = data.verse_grip.first().map(|g| &g.state);
                        let q = grip
                            .and_then(|g| g.orientation)
                            .map(|o| {
                                [
                                    f64::from(o.w),
                                    f64::from(o.x),
                                    f64::from(o.y),
                                    f64::from(o.z),
                                ]
                            })
                            .filter(|q| {
                                q.iter().all(|v| v.is_finite()) && q.iter().any(|v| *v != 0.0)
                            })
                            .unwrap_or([1.0, 0.0, 0.0, 0.0]);
                        let position_mm = [p.x, p.y, p.z].map(|v| 1000.0 * f64::from(v));
                        if position_mm.iter().all(|v| v.is_finite()) {
                            if let Ok(mut s) = shared.lock() {
                                s.latest = Latest {
                                    seq,
                                    t: t0.elapsed().as_secs_f64(),
                                    position_mm,
                                    orientation: q,
                                    button: grip.and_then(|g| g.button).unwrap_or(false),
                                };
                            }
                        }
                    }
                }
            }
            if fresh_at.elapsed() > params.stale_after {
                fail(format!(
                    "the Inverse Service sent no state for {:.1} s; closed the connection",
                    params.stale_after.as_secs_f64()
                ));
                break;
            }
            let Some(id) = device_id.clone() else {
                continue;
            };
            let force = shared.lock().map(|s| s.force).unwrap_or([0.0; 3]);
            let force = if force.iter().all(|v| v.is_finite()) {
                force
            } else {
                [0.0; 3]
            };
            let input = ForceInput {
                device_id: id,
                forces: Force {
                    x: force[0] as f32,
                    y: force[1] as f32,
                    z: force[2] as f32,
                },
            };
            match device
                .update_force(vec![input], Some(true), Some(true))
                .await
            {
                Ok(()) => {
                    if let Ok(mut s) = shared.lock() {
                        s.sent += 1;
                    }
                }
                Err(e) => {
                    fail(format!("the Inverse Service connection failed: {e}"));
                    break;
                }
            }
        }
        // Leave the device without force.
        if let Some(id) = device_id {
            let zero = ForceInput {
                device_id: id,
                forces: Force::default(),
            };
            let _ = device
                .update_force(vec![zero], Some(true), Some(true))
                .await;
        }
        // Stops the client's listener (its stop signal comes first in its loop) and closes.
        let _ = device.shutdown().await;
    });
}
