//! The haptic-frame calls of the C door allocate nothing: the bunny trajectory replayed twice
//! through `h6d_engine_step` (the second time counted), with `h6d_engine_contacts` (a buffer
//! too small included), `h6d_engine_counters`, `h6d_engine_frame_work` and a NaN pose (its
//! error message) on the way.

use std::ffi::CString;
use std::ptr::null_mut;

use haptic6d::*;

#[global_allocator]
static GLOBAL: devkit::CountingAllocator = devkit::CountingAllocator;

#[test]
fn the_counter_sees_an_allocation() {
    let (v, n) = devkit::count_allocations(|| std::hint::black_box(vec![1u8; 64]));
    drop(v);
    assert!(n.events() >= 1);
}

#[test]
fn stepping_through_the_door_does_not_allocate() {
    let cache =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target/haptic6d-test-cache");
    let scene_rs = scene::scenes::builtin("bunny", &scene::cache::TreeCache::at(&cache)).unwrap();
    let traj = scene_rs.trajectory();
    // The same scene through the door (its trees from the same cache).
    let name = CString::new("bunny").unwrap();
    let mut scene = null_mut();
    let mut engine = null_mut();
    // SAFETY: valid pointers throughout.
    unsafe {
        std::env::set_var("HAPTIC6D_CACHE", &cache);
        assert_eq!(
            h6d_scene_load(name.as_ptr(), &mut scene),
            0,
            "{}",
            last_error()
        );
        assert_eq!(
            h6d_scene_engine(scene, std::ptr::null(), &mut engine),
            0,
            "{}",
            last_error()
        );
        h6d_scene_destroy(scene);
    }
    let mut contacts = vec![H6dContact::default(); 64];
    let mut replay = |engine: *mut H6dEngine| {
        let mut w = [0.0; 6];
        let mut q_g = [0.0; 6];
        let mut info = H6dFrameInfo::default();
        let mut count = 0usize;
        let mut counters = H6dCounters::default();
        let mut max_pairs = 0usize;
        let mut work = H6dFrameWork::default();
        let mut splits = 0u64;
        // SAFETY: valid pointers.
        unsafe {
            assert_eq!(
                h6d_engine_reset(engine, traj.samples[0].q.as_ptr(), null_mut()),
                0
            );
            for (i, s) in traj.samples.iter().enumerate() {
                let st = h6d_engine_step(
                    engine,
                    i as f64 * 1e-3,
                    s.q.as_ptr(),
                    w.as_mut_ptr(),
                    q_g.as_mut_ptr(),
                    &mut info,
                );
                assert_eq!(st, 0);
                // Small buffers on purpose: the BUFFER_TOO_SMALL message is written too.
                let cap = if i % 2 == 0 { contacts.len() } else { 1 };
                h6d_engine_contacts(engine, contacts.as_mut_ptr(), cap, &mut count);
                max_pairs = max_pairs.max(count);
                h6d_engine_counters(engine, &mut counters);
                assert_eq!(h6d_engine_frame_work(engine, &mut work), 0);
                assert!(work.margin_mm.is_finite() && work.qp_violation_mm.is_finite());
                splits += u64::from(work.splits);
            }
            let nan = [f64::NAN; 6];
            assert_eq!(
                h6d_engine_step(
                    engine,
                    9.0,
                    nan.as_ptr(),
                    w.as_mut_ptr(),
                    q_g.as_mut_ptr(),
                    &mut info
                ),
                H6dStatus::InvalidArgument as i32
            );
        }
        assert!(splits > 0, "no detection work reported");
        (max_pairs, counters.frames)
    };
    replay(engine); // warm-up: buffers grow to the trajectory's largest contact
    let ((max_pairs, frames), counts) = devkit::count_allocations(|| replay(engine));
    assert!(
        max_pairs > 64,
        "the trajectory must overflow the contacts buffer: {max_pairs}"
    );
    assert_eq!(frames as usize, traj.samples.len());
    assert_eq!(counts.events(), 0, "{counts:?} over {frames} frames");
    assert!(last_error().contains("q_h[0] = NaN"), "{}", last_error());
    // SAFETY: live engine, freed once.
    unsafe { h6d_engine_destroy(engine) };
}
