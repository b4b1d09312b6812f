//! Closed loop with the emulated hand (`scene::device::Emulator`): on the plate, a 1 N press
//! at kt = 1 N/mm holds contact without oscillation; a very stiff coupling at a low rate is
//! detected as unstable.

mod common;

use scene::stability::{press, PressParams};
use scene::Scene;

fn plate() -> Scene {
    scene::scenes::builtin("plate", &common::test_cache()).unwrap()
}

#[test]
fn plate_press_at_1_n_per_mm_holds_contact_without_oscillation() {
    let sc = plate();
    let p = PressParams::along([0.0, 0.0, -1.0]);
    let r = press(&sc, &p, 1.0, 1000.0).unwrap();
    eprintln!("{r:?}");
    assert!(r.stable, "{r:?}");
    assert_eq!(r.free_frames, 0, "{r:?}");
    assert!(r.ripple_p99_n <= 0.05, "{r:?}");
    // Equilibrium: push 1 N = engine force + hand spring; the engine carries
    // kt / (kt + k_h) of it (k_h = 0.3 N/mm), within the sphere-tree's bumps.
    let expect = 1.0 / (1.0 + p.hand.hand_stiffness_n_per_mm);
    assert!(
        (r.mean_force_n - expect).abs() < 0.05,
        "{r:?}, expected {expect}"
    );
}

#[test]
fn a_stiff_coupling_at_a_low_rate_is_detected_as_unstable() {
    let sc = plate();
    let p = PressParams::along([0.0, 0.0, -1.0]);
    let r = press(&sc, &p, 50.0, 200.0).unwrap();
    eprintln!("{r:?}");
    assert!(!r.stable, "{r:?}");
}
