//! The device layer in the loop: a device that stops answering mid-press (the wrench goes to
//! zero through the rate limit, the loop runs every frame, the soft start applies again when
//! poses resume), the calibration applied both ways, unrendered axes zeroed.

// Index loops over frame ranges read like the timeline they check.
#![allow(clippy::needless_range_loop)]

mod common;

use collide::Pose;
use engine::safety::{flags, norm3};
use scene::device::{
    link_flags, Calibration, Capabilities, Device, DeviceConfig, DeviceKind, DeviceLink,
    DeviceSettings, Reading, ReplayDevice,
};
use scene::rt::{run_frames, FrameRecord, LoopParams};
use scene::trajectory::{Ease, Script, Trajectory};

/// A device that gives no pose for frames `from..to` and otherwise reads `inner`; it keeps
/// every wrench it is sent (storage reserved up front).
struct Silent<D> {
    inner: D,
    from: usize,
    to: usize,
    sent: Vec<[f64; 6]>,
}

impl<D: Device> Device for Silent<D> {
    fn name(&self) -> &str {
        "silent"
    }
    fn capabilities(&self) -> Capabilities {
        self.inner.capabilities()
    }
    fn read(&mut self, frame: usize, t: f64) -> Reading {
        if (self.from..self.to).contains(&frame) {
            return Reading::Pending;
        }
        self.inner.read(frame, t)
    }
    fn write_wrench(&mut self, w: &[f64; 6]) {
        self.sent.push(*w);
    }
    fn frames(&self) -> Option<usize> {
        self.inner.frames()
    }
}

/// The plate scene, its press: from 2 mm above, 15 mm into the plate in 0.2 s, held 1 s
/// (15 N at kt = 1 N/mm), the frame budget unlimited.
fn press() -> (scene::Scene, Trajectory) {
    let mut sc = scene::scenes::builtin("plate", &common::test_cache()).unwrap();
    // No pass cut by the clock: runs compared frame by frame must not depend on the machine's
    // load.
    sc.solver.budget_us = engine::config::BUDGET_US.hi;
    let traj = Script::starting_at([0.0, 0.0, 2.0, 0.0, 0.0, 0.0])
        .then(0.2, [0.0, 0.0, -15.0, 0.0, 0.0, 0.0], Ease::Smooth)
        .hold(1.0)
        .to_trajectory(1000.0);
    (sc, traj)
}

fn run(
    sc: &scene::Scene,
    dev: &mut impl Device,
    settings: DeviceSettings,
    frames: usize,
) -> Vec<FrameRecord> {
    let mut engine = sc.engine().unwrap();
    let params = LoopParams {
        device: settings,
        ..LoopParams::default()
    };
    let mut records = Vec::with_capacity(frames);
    run_frames(&mut engine, dev, &params, &mut records);
    records
}

#[test]
fn a_device_silent_mid_press_releases_the_wrench_through_the_rate_limit_and_soft_starts_again() {
    let (sc, traj) = press();
    let n = traj.len();
    let (from, to) = (500, 800); // 300 ms without a pose, from a steady 15 N press
    let mut dev = Silent {
        inner: ReplayDevice::new(traj),
        from,
        to,
        sent: Vec::with_capacity(n),
    };
    let rec = run(&sc, &mut dev, DeviceSettings::default(), n);
    // The loop ran every frame, one wrench sent per frame, all finite.
    assert_eq!(rec.len(), n);
    assert_eq!(dev.sent.len(), n);
    assert!(rec
        .iter()
        .all(|r| r.frame.wrench.iter().all(|w| w.is_finite())));
    let step = sc.safety.max_force_step_n;
    let fz = |i: usize| rec[i].frame.wrench[2];
    assert!(fz(from - 1) > 14.0, "not pressing: {}", fz(from - 1));
    // Never a force step above the rate limit, across the silence and the resumption.
    for i in 1..n {
        let d = [0, 1, 2].map(|k| rec[i].frame.wrench[k] - rec[i - 1].frame.wrench[k]);
        assert!(
            norm3(&d) <= step + 1e-9,
            "frame {i}: force step {} N",
            norm3(&d)
        );
    }
    // Up to the timeout (100 frames at 1 kHz) the last pose is held: same wrench.
    for i in from..from + 100 {
        assert_eq!(rec[i].link, link_flags::HELD, "frame {i}");
        assert!((fz(i) - fz(from - 1)).abs() < 1e-9, "frame {i}");
    }
    // Then released: down to zero by steps of the rate limit, then zero until poses resume.
    let down = (fz(from - 1) / step).ceil() as usize;
    for i in from + 101..to {
        assert_eq!(rec[i].link, link_flags::RELEASED, "frame {i}");
        assert!(rec[i].frame.safety & flags::RATE_LIMIT != 0 || fz(i) == 0.0);
    }
    assert!(fz(from + 100 + down) == 0.0, "{}", fz(from + 100 + down));
    assert!(fz(from + 100 + down - 2) > 0.0);
    assert!(rec[from + 101..to]
        .iter()
        .all(|r| r.frame.raw_wrench == [0.0; 6]));
    // Resumed: the soft start ramps the press back.
    assert_eq!(rec[to].link, link_flags::RESUMED);
    assert!(rec[to].frame.safety & flags::SOFT_START != 0);
    assert!(fz(to) < step + 1e-9);
    assert!((fz(n - 1) - fz(from - 1)).abs() < 0.1, "{}", fz(n - 1));
}

#[test]
fn calibration_is_applied_both_ways() {
    let (mut sc, traj) = press();
    let n = traj.len();
    let identity = {
        let mut dev = ReplayDevice::new(traj.clone());
        run(&sc, &mut dev, DeviceSettings::default(), n)
    };
    let cal = Calibration {
        scale: 2.0,
        rotation: [0.0, 0.0, std::f64::consts::FRAC_PI_2],
        offset: [5.0, -3.0, 40.0],
    };
    sc.device = DeviceConfig {
        settings: DeviceSettings {
            calibration: cal,
            ..DeviceSettings::default()
        },
        ..DeviceConfig::default()
    };
    // The replay device reports device-frame poses; the link maps them back to the scene.
    let mut inner = sc
        .device
        .make(DeviceKind::Replay, traj.clone(), sc.rate_hz)
        .unwrap();
    let first = match inner.read(50, 0.0) {
        Reading::Pose(s) => s.pose,
        other => panic!("{other:?}"),
    };
    // Scene (0, 0, z) is device R^T ((0, 0, z) - offset) / 2: (-2.5, 1.5) turned by -90°
    // about z is (1.5, 2.5).
    let q = Pose::from_array(traj.samples[50].q);
    assert!(
        (first.q[0] - 1.5).abs() < 1e-9 && (first.q[1] - 2.5).abs() < 1e-9,
        "{first:?}"
    );
    assert!(
        (first.q[2] - (q.q[2] - 40.0) / 2.0).abs() < 1e-9,
        "{first:?}"
    );
    let mut dev = Silent {
        inner: sc
            .device
            .make(DeviceKind::Replay, traj, sc.rate_hz)
            .unwrap(),
        from: usize::MAX,
        to: usize::MAX,
        sent: Vec::with_capacity(n),
    };
    let calibrated = run(&sc, &mut dev, sc.device.settings, n);
    assert_eq!(calibrated.len(), n);
    let r = cal.rotation_matrix();
    for i in 0..n {
        let (a, b) = (&identity[i].frame, &calibrated[i].frame);
        for k in 0..3 {
            assert!((a.q_h[k] - b.q_h[k]).abs() < 1e-9, "frame {i}");
            assert!((a.wrench[k] - b.wrench[k]).abs() < 1e-6, "frame {i}");
        }
        // Sent to the device: the scene wrench rotated by R^T (x_dev = y_scene,
        // y_dev = -x_scene for +90° about z), not scaled.
        let w = cal.wrench_to_device(&r, &b.wrench);
        assert_eq!(dev.sent[i], w, "frame {i}");
        assert!((w[0] - b.wrench[1]).abs() < 1e-9 && (w[1] + b.wrench[0]).abs() < 1e-9);
    }
}

#[test]
fn axes_a_device_cannot_render_are_zeroed_and_counted() {
    struct ForceOnly(Vec<[f64; 6]>);
    impl Device for ForceOnly {
        fn name(&self) -> &str {
            "force-only"
        }
        fn capabilities(&self) -> Capabilities {
            Capabilities {
                axes: [true, true, true, false, false, false],
                ..Capabilities::default()
            }
        }
        fn read(&mut self, _frame: usize, _t: f64) -> Reading {
            Reading::Pending
        }
        fn write_wrench(&mut self, w: &[f64; 6]) {
            self.0.push(*w);
        }
    }
    let mut dev = ForceOnly(vec![]);
    let mut link = DeviceLink::new(&mut dev, DeviceSettings::default());
    let sent = link.write(&[1.0, 2.0, 3.0, 30.0, 0.0, -40.0]);
    assert_eq!(sent, [1.0, 2.0, 3.0, 0.0, 0.0, 0.0]);
    assert_eq!(link.flags() & link_flags::MASKED, link_flags::MASKED);
    assert_eq!(link.stats().masked_frames, 1);
    assert_eq!(link.stats().max_masked_torque_nmm, 50.0);
    link.write(&[1.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
    assert_eq!(link.stats().masked_frames, 1);

    assert_eq!(dev.0.len(), 2);
}
