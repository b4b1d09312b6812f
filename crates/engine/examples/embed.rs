//! The whole integration of haptic6d into a device's servo loop: load the tool's and the
//! object's sphere-trees, make an [`Engine`], then call [`Engine::step`] once per tick and send
//! [`Frame::wrench`] to the device.
//!
//! ```text
//! cargo run --release -p engine --example embed [TOOL.sph OBJECT.sph]
//! ```
//!
//! Trees come from `.sph` files (Bradshaw's format; `haptic6d tree build MESH -o OUT.sph` makes
//! one from an OBJ, STL or PLY mesh), in mm. Without arguments the example uses the toolkit's
//! sample bunny tree (about 10 mm tall) as both tool and object. The device here is a stand-in
//! that presses the tool down onto the object and slides it sideways; a real integration reads
//! the device's pose and writes its force in the same two places.

use std::path::PathBuf;

use engine::{Engine, EngineConfig, Frame, Pose};
use spheretree::SphereTree;

/// Servo rate, Hz.
const RATE_HZ: f64 = 1000.0;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let sample = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../assets/peers/bradshaw/bunny-grid-d3.sph");
    let mut paths = std::env::args().skip(1).map(PathBuf::from);
    let tool_path = paths.next().unwrap_or_else(|| sample.clone());
    let object_path = paths.next().unwrap_or(sample);
    let tool = load_tree(&tool_path)?;
    let object = load_tree(&object_path)?;

    // Set-up (allocates): the object fixed at the origin, the paper's stiffness and the
    // default safety limits (40 N, 4 N·m, soft start).
    let mut engine = Engine::new(
        &tool,
        &[(object, Pose::identity())],
        EngineConfig::default(),
    )?;
    engine.reset(&device_pose(0.0))?;

    // The servo loop (allocation-free, bounded time per tick).
    let mut strongest = 0.0f64;
    for tick in 0..3000 {
        let t = tick as f64 / RATE_HZ;
        let frame: &Frame = engine.step(t, &device_pose(t));
        send_to_device(&frame.wrench);
        let force = frame.wrench[..3].iter().map(|f| f * f).sum::<f64>().sqrt();
        strongest = strongest.max(force);
        if tick % 500 == 0 {
            println!(
                "t {t:.3} s: hand z {:7.3} mm, tool z {:7.3} mm, force {force:6.3} N, {} pairs, {}",
                frame.q_h[2],
                frame.q_g[2],
                frame.pairs,
                frame.status.name()
            );
        }
    }
    println!("strongest force sent: {strongest:.3} N");
    Ok(())
}

/// A sphere-tree from a `.sph` file; parents are grown to contain their children, as the
/// engine requires (files from other tools do not always keep it).
fn load_tree(path: &std::path::Path) -> Result<SphereTree, Box<dyn std::error::Error>> {
    let mut tree = spheretree::sph::read_sph(path)?;
    tree.enforce_containment();
    Ok(tree)
}

/// The stand-in device: 20 mm above the object, down at 10 mm/s for 1.5 s (into the object),
/// then sideways at 5 mm/s. Configuration `[x, y, z, gamma, beta, alpha]` in mm and rad.
fn device_pose(t: f64) -> Pose {
    let down = 10.0 * t.min(1.5);
    let side = 5.0 * (t - 1.5).max(0.0);
    Pose::from_array([side, 0.0, 20.0 - down, 0.0, 0.0, 0.0])
}

/// Where a real integration writes the force `[Fx, Fy, Fz]` (N) and torque `[Tx, Ty, Tz]`
/// (N·mm) to its device.
fn send_to_device(wrench: &[f64; 6]) {
    std::hint::black_box(wrench);
}
