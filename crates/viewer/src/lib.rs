//! haptic6d's interactive viewer and device bridge (`haptic6d serve`).
//!
//! Entry points:
//! - [`Simulation`]: the seam to the haptic engine — a device pose in, a [`FrameState`]
//!   (graphic pose, force, torque, pairs, timings, contacts) out.
//! - [`HapticLoop::spawn`]: steps a simulation at 1 kHz on the named thread
//!   `haptic6d-haptic`; device poses go in through [`InputHub`], states come out through
//!   [`StateHub`], both lock-free on the haptic side; it records trajectories to CSV.
//!   [`HapticLoop::manual`] gives the same frame body ([`ManualFrames`]) without the thread.
//! - [`SceneSim`]: the real pipeline (a scene's [`engine::Engine`]: god-object step + safety
//!   filter) as a [`Simulation`].
//! - [`server::router`]: the axum app (page, scene, WebSocket state stream at display rate),
//!   guarded by [`guard`] (Host/Origin checks) and [`pages`] (one page owns the device).
//! - [`UdpBridge`] / [`BridgeClient`]: the UDP device bridge ([`protocol`], version 1).
#![warn(missing_docs)]

pub mod bridge;
pub mod device_bridge;
pub mod error;
pub mod guard;
pub mod haptic;
pub mod hub;
pub mod pages;
pub mod protocol;
pub mod recorder;
pub mod scene_sim;
pub mod server;
pub mod simulation;
pub mod udp_device;

pub use bridge::{BridgeClient, BridgeParams, BridgeStats, UdpBridge};
pub use device_bridge::DeviceBridge;
pub use error::ViewerError;
pub use haptic::{HapticLoop, ManualFrames};
pub use hub::{DeviceCommand, InputHub, InputSource, Rejected, StateHub};
pub use recorder::RecordingSummary;
pub use scene::rt::Pacing;
pub use scene_sim::SceneSim;
pub use simulation::{
    ContactPair, FrameState, NamedMesh, SceneGeometry, Simulation, MAX_DISPLAY_CONTACTS,
};
pub use udp_device::UdpDevice;
