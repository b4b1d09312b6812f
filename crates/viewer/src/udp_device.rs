//! [`UdpDevice`]: the UDP device protocol (docs/VIEWER.md) as a [`Device`], so that a device
//! program written for `haptic6d serve`'s bridge also drives `haptic6d run --device udp` (a
//! live session recorded like any run). The same server side as the bridge
//! (`bridge::UdpEndpoint`): one client session at a time, HELLO / POSE / BYE, every
//! POSE and HELLO answered with a WRENCH.

use std::net::{SocketAddr, UdpSocket};
use std::sync::Arc;
use std::time::{Duration, Instant};

use collide::Pose;
use scene::device::{Device, DeviceSample, Reading};
use scene::SceneError;

use crate::bridge::{Answer, BridgeStats, SessionTarget, UdpEndpoint};

/// Datagrams handled per [`Device::read`] at most (the rest wait for the next frame): a flood
/// cannot hold the haptic frame.
const MAX_DATAGRAMS_PER_READ: usize = 16;

/// The device side of a session: the newest pose and the wrench to answer with.
#[derive(Default)]
struct DeviceTarget {
    /// Newest pose applied, and a count of them.
    pose: Option<Pose>,
    seq: u64,
    /// The wrench last written (N, N·mm), answered to the next POSE.
    wrench: [f64; 6],
    /// A session is driving the device.
    live: bool,
    /// Sessions ended so far (BYE, a new HELLO, a timeout): each becomes a release frame of
    /// the loop, even when the next session's first POSE arrives within the same frame.
    releases: u64,
}

impl SessionTarget for DeviceTarget {
    fn drive(&mut self, pose: Pose, _now: Instant, _timeout: Duration) -> bool {
        self.pose = Some(pose);
        self.seq += 1;
        self.live = true;
        true
    }

    fn release(&mut self) {
        self.live = false;
        self.wrench = [0.0; 6];
        self.releases += 1;
    }

    fn answer(&self, applied: bool) -> Answer {
        Answer {
            ours: applied && self.live,
            force: [self.wrench[0], self.wrench[1], self.wrench[2]],
            torque: [self.wrench[3], self.wrench[4], self.wrench[5]],
            // The device does not see the graphic pose or the pairs: its own pose stands in.
            graphic: self.pose.map_or([0.0; 6], |p| p.to_array()),
            pairs: 0,
        }
    }
}

/// A device program speaking the UDP protocol, as a [`Device`].
pub struct UdpDevice {
    addr: SocketAddr,
    timeout: Duration,
    endpoint: Option<UdpEndpoint<DeviceTarget>>,
    stats: Arc<BridgeStats>,
    last_seq: u64,
    /// Session ends already told to the loop as [`Reading::Released`].
    releases_told: u64,
    t0: Instant,
}

impl UdpDevice {
    /// A device listening on `addr` (port 0 picks a free one) once opened; a client silent for
    /// `timeout` loses its session.
    pub fn new(addr: SocketAddr, timeout: Duration) -> Self {
        Self {
            addr,
            timeout,
            endpoint: None,
            stats: Arc::new(BridgeStats::default()),
            last_seq: 0,
            releases_told: 0,
            t0: Instant::now(),
        }
    }

    /// The bound address once opened (useful with port 0).
    pub fn local_addr(&self) -> Option<SocketAddr> {
        self.endpoint
            .as_ref()
            .and_then(|e| e.socket.local_addr().ok())
    }

    /// The protocol's counters (as the bridge's).
    pub fn stats(&self) -> &BridgeStats {
        &self.stats
    }
}

impl Device for UdpDevice {
    fn name(&self) -> &str {
        "udp"
    }

    /// Binds the address (non-blocking). A bad or busy address is a one-line error.
    fn open(&mut self) -> Result<(), SceneError> {
        let err = |e| SceneError::caused("udp", format!("cannot listen on {}", self.addr), e);
        let socket = UdpSocket::bind(self.addr).map_err(err)?;
        socket.set_nonblocking(true).map_err(err)?;
        self.endpoint = Some(UdpEndpoint::new(
            socket,
            self.timeout,
            Arc::clone(&self.stats),
            DeviceTarget::default(),
        ));
        self.t0 = Instant::now();
        Ok(())
    }

    /// Ends the session (the client is answered no more).
    fn close(&mut self) {
        if let Some(e) = &mut self.endpoint {
            e.end();
        }
        self.endpoint = None;
    }

    /// Handles the datagrams waiting (at most a few per frame; each POSE is answered with the
    /// last wrench written) and gives the newest pose once, [`Reading::Pending`] otherwise. A
    /// session that ended since the last read is [`Reading::Released`] first, so the loop
    /// releases the wrench and the next session starts with the soft start.
    fn read(&mut self, _frame: usize, _t: f64) -> Reading {
        let Some(e) = &mut self.endpoint else {
            return Reading::Pending;
        };
        let mut buf = [0u8; 512];
        e.check_timeout(Instant::now());
        for _ in 0..MAX_DATAGRAMS_PER_READ {
            if !e.receive_one(&mut buf) {
                break;
            }
        }
        let target = &e.target;
        if target.releases != self.releases_told {
            self.releases_told = target.releases;
            return Reading::Released;
        }
        match target.pose {
            Some(pose) if target.seq != self.last_seq && target.live => {
                self.last_seq = target.seq;
                Reading::Pose(DeviceSample::new(self.t0.elapsed().as_secs_f64(), pose))
            }
            _ => Reading::Pending,
        }
    }

    /// Keeps the wrench for the answers to the next POSEs.
    fn write_wrench(&mut self, wrench: &[f64; 6]) {
        if let Some(e) = &mut self.endpoint {
            e.target.wrench = *wrench;
        }
    }
}
