//! The viewer driving the real render pipeline ([`viewer::SceneSim`]: god-object step + safety
//! filter) on a small scene built here: a two-sphere tool above a floor of four spheres. Also
//! recording from the loop and replaying the CSV through render's trajectory reader and step.

use std::time::{Duration, Instant};

use collide::Pose;
use engine::safety::{Safety, SafetyParams};
use scene::trajectory::Trajectory;
use viewer::{HapticLoop, InputSource, Pacing, SceneSim};

mod common;
use common::small_scene;

/// The lowest height a tool leaf sphere (r = 3) centred above (x, y) can reach without
/// overlapping a floor leaf sphere (r = 20): centre distance 23 to every floor centre.
fn tool_leaf_rest_z(x: f64, y: f64) -> f64 {
    [
        (-15.0f64, -15.0f64),
        (15.0, -15.0),
        (-15.0, 15.0),
        (15.0, 15.0),
    ]
    .iter()
    .filter_map(|&(cx, cy)| {
        let d2 = (x - cx).powi(2) + (y - cy).powi(2);
        (d2 < 529.0).then(|| -20.0 + (529.0 - d2).sqrt())
    })
    .fold(f64::NEG_INFINITY, f64::max)
}

fn wait_until(
    haptic: &HapticLoop,
    what: &str,
    f: impl Fn(&viewer::FrameState) -> bool,
) -> viewer::FrameState {
    let end = Instant::now() + Duration::from_secs(5);
    loop {
        let s = haptic.state().latest();
        if f(&s) {
            return s;
        }
        assert!(
            Instant::now() < end,
            "timed out waiting for {what}; last state {s:?}"
        );
        std::thread::sleep(Duration::from_millis(2));
    }
}

#[test]
fn pushing_into_the_floor_gives_an_upward_force_and_no_penetration() {
    let sim = SceneSim::new(&small_scene()).unwrap();
    let scene = sim.scene_geometry().clone();
    assert_eq!(scene.objects.len(), 1);
    assert!(
        !scene.tool.mesh.triangles.is_empty(),
        "tree-only bodies get a sphere mesh"
    );
    let haptic = HapticLoop::spawn(sim, &Pacing::default()).unwrap();
    // Free space first: device = graphic, zero force.
    let seq = haptic
        .input()
        .submit(
            InputSource::Script,
            Pose::from_array([0.0, 0.0, 20.0, 0.0, 0.0, 0.0]),
            None,
        )
        .unwrap();
    haptic.wait_for_input(seq, Duration::from_secs(5)).unwrap();
    let s = wait_until(&haptic, "free-space settle", |s| {
        (s.graphic[2] - 20.0).abs() < 1e-9 && s.force == [0.0; 3]
    });
    assert_eq!(s.pairs, 0);
    assert_eq!(s.graphic, s.device);
    // Walk the device down in 1 mm steps to 12 mm below the floor's top.
    for k in 0..=35 {
        let z = 20.0 - k as f64;
        let seq = haptic
            .input()
            .submit(
                InputSource::Script,
                Pose::from_array([0.0, 0.0, z, 0.0, 0.0, 0.0]),
                None,
            )
            .unwrap();
        haptic.wait_for_input(seq, Duration::from_secs(5)).unwrap();
    }
    // Let the safety layer's rate limit and soft start settle.
    std::thread::sleep(Duration::from_millis(100));
    let s = haptic.state().latest();
    assert_eq!(s.device[2], -15.0);
    // The tool's leaves (r = 3 at x = ±5) rest on the floor's spheres (symmetric: no tilt).
    let rest = tool_leaf_rest_z(5.0, 0.0);
    assert!(
        (s.graphic[2] - rest).abs() < 0.05,
        "graphic tool at z = {}, rest at {rest}",
        s.graphic[2]
    );
    assert!(
        s.graphic[3..].iter().all(|a| a.abs() < 1e-6),
        "{:?}",
        s.graphic
    );
    assert!(
        s.penetration_mm < 0.05,
        "penetration {} mm",
        s.penetration_mm
    );
    assert!(s.pairs > 0);
    // Force = kt (z_g - z_h) upward (kt = 1 N/mm), within the device limit.
    let expected = (s.graphic[2] - s.device[2]).min(SafetyParams::default().max_force_n);
    assert!(s.force[2] > 9.0, "{:?}", s.force);
    assert!(
        (s.force[2] - expected).abs() < 1e-6,
        "{} vs {expected}",
        s.force[2]
    );
    assert!(s.force[0].abs() < 1e-6 && s.force[1].abs() < 1e-6);
}

#[test]
fn contacts_are_listed_only_when_requested() {
    let haptic =
        HapticLoop::spawn(SceneSim::new(&small_scene()).unwrap(), &Pacing::default()).unwrap();
    for k in 0..=30 {
        let seq = haptic
            .input()
            .submit(
                InputSource::Script,
                Pose::from_array([0.0, 0.0, 20.0 - k as f64, 0.0, 0.0, 0.0]),
                None,
            )
            .unwrap();
        haptic.wait_for_input(seq, Duration::from_secs(5)).unwrap();
    }
    let s = wait_until(&haptic, "contact", |s| s.pairs > 0);
    assert!(s.contacts.is_empty(), "nobody asked for contacts");
    haptic.input().want_contacts(true);
    let s = wait_until(&haptic, "contacts listed", |s| !s.contacts.is_empty());
    for c in &s.contacts {
        assert!(c.tool_radius == 3.0 && c.object_radius == 20.0, "{c:?}");
        let d = ((c.tool_centre[0] - c.object_centre[0]).powi(2)
            + (c.tool_centre[1] - c.object_centre[1]).powi(2)
            + (c.tool_centre[2] - c.object_centre[2]).powi(2))
        .sqrt();
        assert!(
            d > 23.0 - 0.05 && d < 23.0 + 0.5,
            "listed pair is not in contact: distance {d}"
        );
    }
    haptic.input().want_contacts(false);
    wait_until(&haptic, "contacts no longer listed", |s| {
        s.contacts.is_empty()
    });
}

#[test]
fn a_recording_replays_through_render_frame_for_frame() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("rec.csv");
    let haptic =
        HapticLoop::spawn(SceneSim::new(&small_scene()).unwrap(), &Pacing::default()).unwrap();
    haptic.start_recording(&path, false).unwrap();
    let mut sent = Vec::new();
    for k in 0..=40 {
        let q = [
            0.1 * k as f64,
            0.0,
            25.0 - k as f64,
            0.0,
            0.0,
            0.002 * k as f64,
        ];
        let seq = haptic
            .input()
            .submit(InputSource::Script, Pose::from_array(q), None)
            .unwrap();
        haptic.wait_for_input(seq, Duration::from_secs(5)).unwrap();
        sent.push(q);
    }
    std::thread::sleep(Duration::from_millis(20));
    let summary = haptic.stop_recording().unwrap();
    assert_eq!(summary.path, path);
    assert_eq!(summary.dropped, 0);
    assert!(summary.rows > 41, "{summary:?}");

    // Render's own reader (what `haptic6d run --trajectory` uses) accepts it.
    let traj = Trajectory::read_csv(&path).unwrap();
    assert_eq!(traj.len() as u64, summary.rows);
    for w in traj.samples.windows(2) {
        assert!(
            (w[1].t - w[0].t - 0.001).abs() < 1e-9,
            "t must advance one period per row"
        );
    }
    // Every commanded pose shows up, in order.
    let mut i = 0;
    for s in &traj.samples {
        if i < sent.len() && s.q == sent[i] {
            i += 1;
        }
    }
    assert_eq!(
        i,
        sent.len(),
        "not every commanded pose was recorded in order"
    );

    // Replay offline through the same frame body (god-object step + safety): the tool ends
    // resting on the floor with an upward force, never penetrating.
    let scene = small_scene();
    let mut god = scene.god_object().unwrap();
    god.reset(&scene.start).unwrap();
    let mut safety = Safety::new(scene.safety);
    let mut last = None;
    for (k, s) in traj.samples.iter().enumerate() {
        let out = god.step(&Pose::from_array(s.q));
        assert!(
            out.penetration_mm < 0.05,
            "frame {k}: penetration {}",
            out.penetration_mm
        );
        last = Some(safety.filter(s.t, out.wrench).0);
    }
    let w = last.unwrap();
    assert!(w[2] > 5.0, "replayed final force {w:?}");
}

#[test]
fn the_friction_switch_holds_or_frees_a_pressed_tool() {
    let mut scene = small_scene();
    scene.object_friction = vec![engine::Friction {
        static_mu: 2.0,
        kinetic_mu: 1.5,
    }];
    let sim = SceneSim::new(&scene).unwrap();
    assert!(sim.scene_geometry().friction, "the page offers the switch");
    let haptic = HapticLoop::spawn(sim, &Pacing::default()).unwrap();
    let go = |q: [f64; 6]| {
        let seq = haptic
            .input()
            .submit(InputSource::Script, Pose::from_array(q), None)
            .unwrap();
        haptic.wait_for_input(seq, Duration::from_secs(5)).unwrap();
    };
    // Down onto the floor (the tool rests at z = -5.7) and pressed 2 mm into it.
    for k in 0..=56 {
        go([0.0, 0.0, 20.0 - 0.5 * k as f64, 0.0, 0.0, 0.0]);
    }
    let pressed = wait_until(&haptic, "contact", |s| s.pairs > 0 && s.friction != 0);
    let x0 = pressed.graphic[0];
    // The hand moves 2 mm sideways: friction (mu_s = 2) holds the tool where it is.
    for k in 1..=20 {
        go([0.1 * k as f64, 0.0, -8.0, 0.0, 0.0, 0.0]);
    }
    let held = wait_until(&haptic, "the last pose", |s| s.device[0] == 2.0);
    assert!(held.friction_on && held.friction == 1, "{held:?}");
    assert!((held.graphic[0] - x0).abs() < 0.05, "{held:?}");
    // Friction off: the tool slides toward the hand (into the floor's valley, where the
    // curved spheres hold it 0.36 mm on).
    haptic.input().set_friction(false);
    let free = wait_until(&haptic, "the tool to follow", |s| {
        !s.friction_on && s.graphic[0] - x0 > 0.2
    });
    assert_eq!(free.friction, 0, "{free:?}");
}

/// A device that replays a press into the floor and keeps every wrench it is sent.
struct PressDevice {
    inner: scene::device::ReplayDevice,
    sent: std::sync::Arc<std::sync::Mutex<Vec<[f64; 6]>>>,
}

impl scene::device::Device for PressDevice {
    fn name(&self) -> &str {
        "press"
    }
    fn read(&mut self, frame: usize, t: f64) -> scene::device::Reading {
        self.inner.read(frame, t)
    }
    fn write_wrench(&mut self, w: &[f64; 6]) {
        self.sent.lock().unwrap().push(*w);
    }
}

#[test]
fn a_device_drives_the_viewer_through_the_device_bridge() {
    use viewer::DeviceBridge;
    let haptic =
        HapticLoop::spawn(SceneSim::new(&small_scene()).unwrap(), &Pacing::default()).unwrap();
    // Down from 20 mm to z = -8 (the tool rests at -5.7) over 0.5 s, then held 2.5 s.
    let mut samples = Vec::new();
    for i in 0..3000 {
        let z = 20.0 - 28.0 * (i as f64 / 500.0).min(1.0);
        samples.push(scene::trajectory::TrajSample {
            t: i as f64 * 1e-3,
            q: [0.0, 0.0, z, 0.0, 0.0, 0.0],
        });
    }
    let sent = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
    let device = PressDevice {
        inner: scene::device::ReplayDevice::new(Trajectory { samples }),
        sent: sent.clone(),
    };
    let bridge = DeviceBridge::spawn(
        Box::new(device),
        scene::device::DeviceSettings::default(),
        1000.0,
        haptic.input().clone(),
        haptic.state().clone(),
    )
    .unwrap();
    assert_eq!(bridge.name(), "press");
    let s = wait_until(&haptic, "the device pressing", |s| {
        s.source == viewer::InputSource::Device as u8 && s.force[2] > 1.0
    });
    assert!(s.penetration_mm < 0.05, "{s:?}");
    // The page cannot take over while the device drives the loop.
    let taken = haptic.input().submit(
        InputSource::Page,
        Pose::from_array([0.0, 0.0, 50.0, 0.0, 0.0, 0.0]),
        None,
    );
    assert!(taken.is_err(), "{taken:?}");
    // The bridge hands the published wrench to the device on its next frame.
    let end = Instant::now() + Duration::from_secs(5);
    while !sent.lock().unwrap().iter().any(|w| w[2] > 1.0) && Instant::now() < end {
        std::thread::sleep(Duration::from_millis(2));
    }
    let stats = bridge.stop();
    let forces = sent.lock().unwrap().clone();
    // One write per bridge frame, a reading in most of them.
    assert!(stats.readings > 100, "{stats:?}");
    assert!(
        forces.len() as u64 >= stats.readings,
        "{} writes, {stats:?}",
        forces.len()
    );
    assert!(
        forces.iter().any(|w| w[2] > 1.0),
        "the device was never pushed back"
    );
    assert!(forces.iter().all(|w| w.iter().all(|v| v.is_finite())));
    // Stopped: the device no longer drives the loop.
    wait_until(&haptic, "the release", |s| {
        s.source != viewer::InputSource::Device as u8
    });
}
