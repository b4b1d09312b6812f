//! Long runs: a seeded random device motion at 1 kHz over a thin plate and a block, with
//! rotations, pushes into contact and fast sweeps. Every frame: penetration <= 0.01 mm, finite
//! output within the device limits. Over the run: memory flat (no allocation in the frame loop
//! after warm-up; live heap bytes and RSS unchanged).
//!
//! - `long_run_30_s_in_ci`: 30 000 frames (30 s of haptic time), in CI.
//! - `long_run_10_min`: 600 000 frames (10 min), `#[ignore]`d; run it with
//!   `cargo test --release -p scene --test reliability_longrun -- --ignored --nocapture`.
//!
//! Frames run through [`run_frames`] in chunks of 1000 into a reused record buffer, so the
//! memory of the test itself does not grow with the run length.

use collide::Pose;
use devkit::Rng;
use engine::safety::SafetyParams;
use engine::step::FrameStatus;
use mesh::TriMesh;
use scene::device::{Device, DeviceSample, Reading};
use scene::rt::{run_frames, FrameRecord, LoopParams};
use scene::{Coupling, Motion, Scene, SolverSpec};
use spheretree::build::{build_tree, BuildParams};
use spheretree::SphereTree;

/// Counts allocations and live heap bytes of the thread running the frames (the test
/// harness's own threads, e.g. its "running for over 60 seconds" notice, are not counted).
#[global_allocator]
static GLOBAL: devkit::CountingAllocator = devkit::CountingAllocator;

/// Resident set size of this process, bytes (Linux; 0 elsewhere).
fn rss_bytes() -> u64 {
    std::fs::read_to_string("/proc/self/statm")
        .ok()
        .and_then(|s| s.split_whitespace().nth(1)?.parse::<u64>().ok())
        .map_or(0, |pages| pages * 4096)
}

fn box_mesh(c: [f64; 3], h: [f64; 3]) -> TriMesh {
    let vertices = (0..8)
        .map(|i| {
            [
                c[0] + if i & 1 == 0 { -h[0] } else { h[0] },
                c[1] + if i & 2 == 0 { -h[1] } else { h[1] },
                c[2] + if i & 4 == 0 { -h[2] } else { h[2] },
            ]
        })
        .collect();
    let quads: [[u32; 4]; 6] = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    TriMesh {
        vertices,
        triangles: quads
            .iter()
            .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
            .collect(),
    }
}

fn octree(mesh: &TriMesh, depth: u32) -> SphereTree {
    build_tree(mesh, &BuildParams::fastest_build(depth), &|_| {}).unwrap()
}

/// Tool: a 30 x 6 x 6 mm bar (so rotations move its ends); objects: a 0.5 mm plate at z = 0
/// and a 40 mm block beside it.
fn scene() -> Scene {
    let tool = octree(&box_mesh([0.0; 3], [15.0, 3.0, 3.0]), 3);
    let plate = octree(&box_mesh([0.0; 3], [60.0, 60.0, 0.25]), 4);
    let block = octree(&box_mesh([90.0, 0.0, 20.0], [20.0, 20.0, 20.0]), 4);
    Scene {
        name: "reliability long run".into(),
        tool,
        tool_mesh: None,
        objects: vec![(plate, Pose::identity()), (block, Pose::identity())],
        object_meshes: vec![None, None],
        coupling: Coupling::default(),
        solver: SolverSpec::default(),
        safety: SafetyParams::default(),
        start: Pose::from_array([0.0, 0.0, 60.0, 0.0, 0.0, 0.0]),
        rate_hz: 1000.0,
        motion: Motion::Hold,
        goal: None,
        device: Default::default(),
        load_log: Vec::new(),
        object_friction: Vec::new(),
        tool_friction: None,
    }
}

/// A seeded random device: it moves toward random waypoints (x, y over the plate and the
/// block, z from 40 mm above to 15 mm into the objects, angles up to ±0.6 rad) with smooth
/// starts and stops; one segment in ten is a fast sweep (20–50 ms). Produces frames on the fly
/// (no storage), `frames` in all.
struct RandomDevice {
    rng: Rng,
    frame: usize,
    frames: usize,
    from: [f64; 6],
    to: [f64; 6],
    seg_start: usize,
    seg_len: usize,
}

impl RandomDevice {
    fn new(seed: u64, frames: usize, start: [f64; 6]) -> Self {
        let mut d = Self {
            rng: Rng::new(seed),
            frame: 0,
            frames,
            from: start,
            to: start,
            seg_start: 0,
            seg_len: 1,
        };
        d.next_segment();
        d
    }

    fn next_segment(&mut self) {
        let r = &mut self.rng;
        self.from = self.to;
        let over_block = r.unit() < 0.3;
        let (x, y, top) = if over_block {
            (r.range(75.0, 105.0), r.range(-15.0, 15.0), 40.0)
        } else {
            (r.range(-50.0, 50.0), r.range(-50.0, 50.0), 0.0)
        };
        let z = top + r.range(-15.0, 40.0);
        self.to = [
            x,
            y,
            z,
            r.range(-0.6, 0.6),
            r.range(-0.6, 0.6),
            r.range(-0.6, 0.6),
        ];
        self.seg_len = if r.unit() < 0.1 {
            20 + (r.next_u64() % 30) as usize
        } else {
            200 + (r.next_u64() % 800) as usize
        };
        self.seg_start = self.frame;
    }
}

impl Device for RandomDevice {
    fn name(&self) -> &str {
        "random"
    }

    fn read(&mut self, _frame: usize, _t: f64) -> Reading {
        if self.frame >= self.frames {
            return Reading::Ended;
        }
        if self.frame >= self.seg_start + self.seg_len {
            self.next_segment();
        }
        let s = (self.frame - self.seg_start) as f64 / self.seg_len as f64;
        let s = s * s * (3.0 - 2.0 * s);
        let mut q = [0.0; 6];
        for (k, v) in q.iter_mut().enumerate() {
            *v = self.from[k] + (self.to[k] - self.from[k]) * s;
        }
        let t = self.frame as f64 * 1e-3;
        self.frame += 1;
        Reading::Pose(DeviceSample::new(t, Pose::from_array(q)))
    }
}

/// What a long run measured.
#[derive(Debug, Default)]
struct LongRun {
    frames: usize,
    max_penetration_mm: f64,
    contact_frames: usize,
    max_pairs: u32,
    kept_last_safe: usize,
    inexact: usize,
    max_force_n: f64,
    max_total_us: f64,
    allocs_in_loop: u64,
    live_bytes_growth: i64,
    rss_before: u64,
    rss_after: u64,
    wall_s: f64,
}

fn long_run(frames: usize, seed: u64) -> LongRun {
    let sc = scene();
    let mut engine = sc.engine().unwrap();
    engine.reset(&sc.start).unwrap();
    let params = LoopParams::default();
    let mut records: Vec<FrameRecord> = Vec::with_capacity(1000);
    let mut dev = RandomDevice::new(seed, frames, sc.start.to_array());
    let mut r = LongRun::default();
    let t0 = std::time::Instant::now();
    let mut chunk = 0;
    loop {
        records.clear();
        // Counters are read after a warm-up chunk (first contacts size the solver's storage).
        if chunk == 1 {
            r.rss_before = rss_bytes();
        }
        let (n, counts) = devkit::count_allocations(|| {
            run_frames(&mut engine, &mut dev, &params, &mut records).0
        });
        if chunk >= 1 {
            r.allocs_in_loop += counts.allocations as u64;
            r.live_bytes_growth += counts.live_bytes;
        }
        for f in &records {
            let i = r.frames;
            assert!(
                f.frame.penetration_mm <= 0.01,
                "frame {i}: penetration {} mm at q_h {:?} q_g {:?}",
                f.frame.penetration_mm,
                f.frame.q_h,
                f.frame.q_g
            );
            assert!(
                f.frame.wrench.iter().all(|v| v.is_finite())
                    && f.frame.q_g.iter().all(|v| v.is_finite()),
                "frame {i}: non-finite output {:?}",
                f.frame.wrench
            );
            let fn_ =
                (f.frame.wrench[0].powi(2) + f.frame.wrench[1].powi(2) + f.frame.wrench[2].powi(2))
                    .sqrt();
            assert!(fn_ <= sc.safety.max_force_n + 1e-9, "frame {i}: {fn_} N");
            r.max_penetration_mm = r.max_penetration_mm.max(f.frame.penetration_mm);
            r.max_force_n = r.max_force_n.max(fn_);
            r.max_pairs = r.max_pairs.max(f.frame.pairs);
            r.max_total_us = r.max_total_us.max(f.frame.total_us);
            r.contact_frames += usize::from(f.frame.pairs > 0);
            r.kept_last_safe += usize::from(f.frame.status == FrameStatus::KeptLastSafe);
            r.inexact += usize::from(f.frame.status == FrameStatus::Inexact);
            r.frames += 1;
        }
        chunk += 1;
        if n < records.capacity() {
            break;
        }
    }
    r.rss_after = rss_bytes();
    r.wall_s = t0.elapsed().as_secs_f64();
    r
}

#[track_caller]
fn check(r: &LongRun, frames: usize) {
    eprintln!("{r:#?}");
    assert_eq!(r.frames, frames);
    // The motion does reach contact, often.
    assert!(r.contact_frames > frames / 5, "{r:?}");
    assert_eq!(r.allocs_in_loop, 0, "allocations in the frame loop");
    assert_eq!(r.live_bytes_growth, 0, "live heap bytes grew");
    // RSS may move by a few pages (stack, allocator bookkeeping), not with the run length.
    assert!(
        r.rss_after <= r.rss_before + (1 << 20),
        "RSS grew from {} to {}",
        r.rss_before,
        r.rss_after
    );
}

#[test]
fn long_run_30_s_in_ci() {
    let frames = 30_000;
    check(&long_run(frames, 0x5EED_0030), frames);
}

#[test]
#[ignore = "10 minutes of haptic frames (600 000); run by hand, see the module docs"]
fn long_run_10_min() {
    let frames = 600_000;
    check(&long_run(frames, 0x5EED_0600), frames);
}
