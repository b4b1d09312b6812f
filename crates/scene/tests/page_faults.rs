//! No page fault in the haptic frame: the engine makes the storage it reserves resident when it
//! is made, so a frame that first writes past a buffer's high-water mark (a near list longer
//! than any before it, a region of more rows, a neighbour list's first fill) does not stop
//! while the kernel maps a page. Counted on a fresh engine, without a warm-up pass: the bunny
//! on its leaf spheres (neighbour lists), `probe` on the meshes (near lists, rows, checks).
//! Without the pages touched at set-up the bunny's frames took ~250 faults and `probe`'s ~640.

mod common;

use collide::Pose;

/// Page faults taken inside `Engine::step` over `scene`'s scripted motion on a fresh engine
/// (the first frame left out: the thread's stack grows into its first deep calls there), the
/// most in one frame, and the frames run.
fn faults_in_frames(scene: &scene::Scene) -> (u64, u64, usize) {
    let mut engine = scene.engine().unwrap();
    let traj = scene.trajectory();
    engine.reset(&Pose::from_array(traj.samples[0].q)).unwrap();
    let (mut faults, mut most) = (0, 0);
    for (i, s) in traj.samples.iter().enumerate() {
        let pose = Pose::from_array(s.q);
        let before = devkit::thread_page_faults();
        let _ = engine.step(s.t, &pose);
        let taken = devkit::thread_page_faults() - before;
        if i > 0 {
            faults += taken;
            most = most.max(taken);
        }
    }
    (faults, most, traj.len())
}

#[test]
fn frames_of_a_fresh_engine_take_no_page_fault() {
    let cache = common::test_cache();
    for name in ["bunny", "probe"] {
        let scene = scene::scenes::builtin(name, &cache).unwrap();
        let (faults, most, frames) = faults_in_frames(&scene);
        assert!(frames > 4000, "{name}: {frames} frames");
        // A few stray faults (a page of the stack, of the allocator's own state, of code the
        // machine paged out) are the machine's; hundreds are the engine's buffers.
        assert!(
            faults <= 16 && most <= 4,
            "{name}: {faults} page faults in {frames} frames, {most} in one"
        );
    }
}

/// A buffer touched at set-up ([`collide::touch_pages`]) is then written whole, every element
/// of its capacity, without a fault: elements of a size that does not divide a page, in
/// storage that starts off a page's edge (a large allocation's header), to its last page.
#[test]
fn a_touched_buffer_takes_no_fault_when_written_whole() {
    const CAPACITY: usize = 1 << 18;
    let mut odd: Vec<[u64; 3]> = Vec::with_capacity(CAPACITY);
    odd.extend((0..1000u64).map(|i| [i; 3]));
    collide::touch_pages(&mut odd);
    let mut plain: Vec<f64> = Vec::with_capacity(CAPACITY);
    collide::touch_pages(&mut plain);
    let before = devkit::thread_page_faults();
    odd.resize(odd.capacity(), [7; 3]);
    plain.resize(plain.capacity(), 7.0);
    let faults = devkit::thread_page_faults() - before;
    assert_eq!(
        faults, 0,
        "{faults} page faults writing touched buffers whole"
    );
    assert_eq!(odd[999], [999; 3]);
}
