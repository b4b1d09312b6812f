//! The viewer's haptic frame allocates nothing: thousands of frames of the real pipeline
//! (contact, contacts listed for display, recording on, state published) under a counting global
//! allocator armed only on this thread and only inside `ManualFrames::step`.

mod common;

use collide::Pose;
use viewer::{HapticLoop, InputSource, Pacing, SceneSim};

#[global_allocator]
static GLOBAL: devkit::CountingAllocator = devkit::CountingAllocator;

/// Device pose of frame `k` of a 1000-frame cycle: down from 20 mm to 15 mm into the floor and
/// back up, with a little sideways motion and twist.
fn pose(k: usize) -> Pose {
    let s = (k % 1000) as f64 / 1000.0;
    let depth = 35.0 * (std::f64::consts::PI * s).sin();
    Pose::from_array([2.0 * s, -s, 20.0 - depth, 0.02 * s, 0.0, 0.1 * s])
}

#[test]
fn a_warmed_up_frame_allocates_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let sim = SceneSim::new(&common::small_scene()).unwrap();
    let (handle, mut frames) = HapticLoop::manual(sim, &Pacing::default()).unwrap();
    handle.input().want_contacts(true);
    handle
        .start_recording(&dir.path().join("rec.csv"), false)
        .unwrap();
    let mut max_pairs = 0;
    let mut listed = 0;
    // Warm-up: one full cycle grows every buffer to its working size.
    for k in 0..1000 {
        handle
            .input()
            .submit(InputSource::Script, pose(k), None)
            .unwrap();
        frames.step();
    }
    let mut allocations = 0;
    for k in 0..3000 {
        handle
            .input()
            .submit(InputSource::Script, pose(k), None)
            .unwrap();
        let ((pairs, contacts, recording, released), counts) = devkit::count_allocations(|| {
            let s = frames.step();
            (s.pairs, s.contacts.len(), s.recording, s.released)
        });
        allocations += counts.events();
        max_pairs = max_pairs.max(pairs);
        listed = listed.max(contacts);
        assert!(recording && !released);
    }
    assert_eq!(
        allocations, 0,
        "the haptic frame allocated {allocations} times"
    );
    // The frames did exercise contact, the contact list and the recorder.
    assert!(
        max_pairs > 0 && listed > 0,
        "pairs {max_pairs}, listed {listed}"
    );
    let summary = handle.stop_recording().unwrap();
    assert_eq!(summary.rows + summary.dropped, 4000);
    // Reading the state from another thread meanwhile did not disturb it.
    assert_eq!(handle.state().latest().frame, 3999);
}
