//! What the C door costs per frame: `h6d_engine_step` against `engine::Engine::step` on the
//! same input, in the same run (target: at most 1 µs more per frame, median).
//!
//! - `free`: the tool in free space, the cheapest frame, where the door's share is largest;
//! - `bunny`: the bunny scene's whole trajectory (approach, contacts, slides; 8601 frames)
//!   from a reset per iteration; per frame = the time / 8601 (criterion's throughput line).
//!
//! - `paired` (printed first): both engines step the bunny trajectory in lockstep, each frame
//!   timed on both sides (alternating which goes first); the median of the per-frame
//!   differences. Load on a shared machine hits both sides of a pair alike, where it can hit
//!   one criterion bench and not the other.
//!
//! `cargo bench -p haptic6d-capi --bench door`; criterion's medians in
//! `target/criterion/door-*/*/new/estimates.json` (`median.point_estimate`, ns).

use std::ffi::CString;
use std::hint::black_box;
use std::ptr::null_mut;
use std::time::Instant;

use criterion::{criterion_group, Criterion, Throughput};
use engine::{Engine, Pose};
use haptic6d::{h6d_engine_destroy, h6d_engine_reset, h6d_engine_step, h6d_scene_destroy};
use haptic6d::{h6d_scene_engine, h6d_scene_load, last_error, H6dEngine, H6dFrameInfo};

/// The bunny scene's engine twice: the Rust one, and the same scene through the C door.
fn engines() -> (Engine, *mut H6dEngine, Vec<[f64; 6]>) {
    let cache =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target/haptic6d-test-cache");
    // Before any thread starts: the door's scene load reads the cache location from it.
    std::env::set_var("HAPTIC6D_CACHE", &cache);
    let scene = scene::scenes::builtin("bunny", &scene::cache::TreeCache::at(&cache)).unwrap();
    let poses = scene.trajectory().samples.iter().map(|s| s.q).collect();
    let rust = scene.engine().unwrap();
    let name = CString::new("bunny").unwrap();
    let mut s = null_mut();
    let mut door = null_mut();
    // SAFETY: valid pointers.
    unsafe {
        assert_eq!(h6d_scene_load(name.as_ptr(), &mut s), 0, "{}", last_error());
        assert_eq!(
            h6d_scene_engine(s, std::ptr::null(), &mut door),
            0,
            "{}",
            last_error()
        );
        h6d_scene_destroy(s);
    }
    (rust, door, poses)
}

fn bench(c: &mut Criterion) {
    let (mut rust, door, poses) = engines();
    let free = [0.0, 0.0, 400.0, 0.0, 0.0, 0.0]; // far above the object, mm
    let mut w = [0.0; 6];
    let mut q_g = [0.0; 6];
    let mut info = H6dFrameInfo::default();

    let mut g = c.benchmark_group("door-free");
    rust.reset(&Pose::from_array(free)).unwrap();
    // SAFETY: live engine, valid pointers.
    unsafe { h6d_engine_reset(door, free.as_ptr(), null_mut()) };
    let mut t = 0.0;
    g.bench_function("rust", |b| {
        b.iter(|| {
            t += 1e-3;
            black_box(rust.step(t, &Pose::from_array(black_box(free))).wrench)
        })
    });
    let mut t = 0.0;
    g.bench_function("c", |b| {
        b.iter(|| {
            t += 1e-3;
            // SAFETY: live engine, valid pointers.
            unsafe {
                h6d_engine_step(
                    door,
                    t,
                    black_box(free.as_ptr()),
                    w.as_mut_ptr(),
                    q_g.as_mut_ptr(),
                    &mut info,
                )
            };
            black_box(w)
        })
    });
    g.finish();

    // One iteration is the whole replay from a reset: the same work every iteration (a
    // frame's cost depends on where it is in the trajectory), divided into frames by the
    // throughput.
    let mut g = c.benchmark_group("door-bunny");
    g.sample_size(10)
        .measurement_time(std::time::Duration::from_secs(6))
        .throughput(Throughput::Elements(poses.len() as u64));
    g.bench_function("rust", |b| {
        b.iter(|| {
            rust.reset(&Pose::from_array(poses[0])).unwrap();
            for (i, q) in poses.iter().enumerate() {
                black_box(rust.step(i as f64 * 1e-3, &Pose::from_array(*q)).wrench);
            }
        })
    });
    g.bench_function("c", |b| {
        b.iter(|| {
            // SAFETY: live engine, valid pointers.
            unsafe {
                h6d_engine_reset(door, poses[0].as_ptr(), null_mut());
                for (i, q) in poses.iter().enumerate() {
                    h6d_engine_step(
                        door,
                        i as f64 * 1e-3,
                        q.as_ptr(),
                        w.as_mut_ptr(),
                        q_g.as_mut_ptr(),
                        &mut info,
                    );
                    black_box(w);
                }
            }
        })
    });
    g.finish();
    // SAFETY: live engine, freed once.
    unsafe { h6d_engine_destroy(door) };
}

/// The paired measurement: median and quartiles of `c - rust` per frame, ns, over `rounds`
/// replays of the bunny trajectory.
fn paired(rounds: usize) {
    let (mut rust, door, poses) = engines();
    let mut w = [0.0; 6];
    let mut q_g = [0.0; 6];
    let mut info = H6dFrameInfo::default();
    let mut diffs = Vec::with_capacity(rounds * poses.len());
    let mut rust_ns = Vec::with_capacity(rounds * poses.len());
    for _ in 0..rounds {
        rust.reset(&Pose::from_array(poses[0])).unwrap();
        // SAFETY: live engine, valid pointers.
        unsafe { h6d_engine_reset(door, poses[0].as_ptr(), null_mut()) };
        for (i, q) in poses.iter().enumerate() {
            let t = i as f64 * 1e-3;
            let mut time_rust = || {
                let t0 = Instant::now();
                black_box(rust.step(t, &Pose::from_array(*q)).wrench);
                t0.elapsed().as_nanos() as f64
            };
            let mut time_c = || {
                let t0 = Instant::now();
                // SAFETY: live engine, valid pointers.
                unsafe {
                    h6d_engine_step(
                        door,
                        t,
                        q.as_ptr(),
                        w.as_mut_ptr(),
                        q_g.as_mut_ptr(),
                        &mut info,
                    )
                };
                black_box(w);
                t0.elapsed().as_nanos() as f64
            };
            let (r, c) = if i % 2 == 0 {
                let r = time_rust();
                (r, time_c())
            } else {
                let c = time_c();
                (time_rust(), c)
            };
            diffs.push(c - r);
            rust_ns.push(r);
        }
    }
    // SAFETY: live engine, freed once.
    unsafe { h6d_engine_destroy(door) };
    let q = |v: &mut Vec<f64>, p: f64| {
        v.sort_by(f64::total_cmp);
        v[((v.len() - 1) as f64 * p) as usize]
    };
    println!(
        "door-paired: {} frames; Engine::step median {:.0} ns; h6d_engine_step - Engine::step per frame: median {:.0} ns (quartiles {:.0} / {:.0} ns)",
        diffs.len(),
        q(&mut rust_ns, 0.5),
        q(&mut diffs, 0.5),
        q(&mut diffs, 0.25),
        q(&mut diffs, 0.75),
    );
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .sample_size(60)
        .warm_up_time(std::time::Duration::from_secs(1))
        .measurement_time(std::time::Duration::from_secs(3));
    targets = bench
}
fn main() {
    // `cargo bench --no-run` builds this; `cargo test --benches` runs it once with `--bench`
    // absent: keep that quick.
    let full = std::env::args().any(|a| a == "--bench");
    paired(if full { 5 } else { 1 });
    benches();
    Criterion::default().configure_from_args().final_summary();
}
