//! Closed loop with the emulated hand (`scene::device::Emulator`): on the plate, a 1 N press
//! at kt = 1 N/mm holds contact without oscillation (ripple p99 ≤ 0.05 N); a coupling four
//! times too stiff for the rate is detected as unstable; the search finds the bound near
//! Colgate's `b > K T / 2`.

mod common;

use scene::stability::{largest_stable_kt, press, PressParams};
use scene::Scene;

fn plate() -> Scene {
    scene::scenes::builtin("plate", &common::test_cache()).unwrap()
}

#[test]
fn plate_press_at_1_n_per_mm_holds_contact_without_oscillation() {
    let sc = plate();
    let p = PressParams::along([0.0, 0.0, -1.0]);
    let r = press(&sc, &p, 1.0, 1000.0).unwrap();
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
    // 16 N/mm at 1 kHz is four times Colgate's bound b > K T / 2 for this hand (b = 2 N·s/m):
    // the press bounces.
    let r = press(&sc, &p, 16.0, 1000.0).unwrap();
    assert!(!r.stable, "{r:?}");
    assert!(r.free_frames > 0 || r.ripple_p99_n > 0.5, "{r:?}");
    // The same at 4 kHz holds (the bound is 16 N/mm there, the press judged within it at 8).
    let r = press(&sc, &p, 8.0, 4000.0).unwrap();
    assert!(r.stable, "{r:?}");
}

#[test]
fn the_largest_stable_kt_on_the_plate_at_1_khz_is_near_colgates_bound() {
    // b > K T / 2 gives 4 N/mm for b = 2 N·s/m at 1 kHz; the hand's spring and the unilateral
    // contact shift it a little, not by a factor of two.
    let sc = plate();
    let p = PressParams::along([0.0, 0.0, -1.0]);
    let s = largest_stable_kt(&sc, &p, 1000.0, 0.5, 3).unwrap();
    let (lo, hi) = (
        s.largest_stable_kt.unwrap(),
        s.smallest_unstable_kt.unwrap(),
    );
    assert!(lo >= 2.0 && hi <= 8.0 && lo < hi, "{lo} .. {hi}");
}
