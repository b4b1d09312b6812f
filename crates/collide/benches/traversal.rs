//! Bunny vs bunny (4681 slots each, depth 4, B 8): our traversal against a brute-force loop and
//! against parry3d-f64's QBVH simultaneous traversal of two compounds of balls, at poses giving
//! ~50, ~200, ~1000 and ~5000 leaf pairs; then p50/p99 of individually timed queries.
//!
//! Criterion's figures are thread CPU time (`iter_custom` + `CLOCK_THREAD_CPUTIME_ID`), so they
//! hold on a shared, loaded machine; the table at the end adds wall-clock p50/p99/max of
//! individually timed queries.
//!
//! Run: `cargo bench -p collide --bench traversal` (add `-- --quick` for a short run; set
//! `COLLIDE_BENCH_TREE=hubbard` for the Bradshaw toolkit's hubbard tree).

use std::hint::black_box;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use collide::{
    collect_pairs, fill_constraints, overlap_tree_tree, CollideWorkspace, ConstraintForm,
    PackedTree, Pose,
};
use criterion::{BenchmarkId, Criterion};
use parry3d_f64::bounding_volume::BoundingVolume;
use parry3d_f64::math::{Pose as ParryPose, Rotation as ParryRotation, Vector as ParryVector};
use parry3d_f64::partitioning::BvhNode;
use parry3d_f64::shape::{Compound, SharedShape};
use spheretree::build::{build_tree, BuildParams};
use spheretree::SphereTree;

/// Mesh units -> mm (the bunny is ~10 units across: ~100 mm).
const SCALE: f64 = 10.0;
/// Fixed rotation of the tool in every scenario (rad), so the two bunnies are not aligned.
const ROT: [f64; 3] = [0.4, -0.3, 0.8];
const TARGETS: [usize; 4] = [50, 200, 1000, 5000];

fn repo_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The bunny tree, in mm: `spheretree::build::build_tree` (default tight builder, depth 4, B 8)
/// on assets/bunny.obj scaled by 10 (~100 mm). With `COLLIDE_BENCH_TREE=hubbard`, the Bradshaw
/// toolkit's hubbard tree (assets/peers/bradshaw/bunny-hubbard.sph) instead, containment
/// enforced.
fn bunny_tree() -> (SphereTree, String) {
    let mut tree;
    let source;
    if std::env::var("COLLIDE_BENCH_TREE").as_deref() == Ok("hubbard") {
        let path = repo_root().join("assets/peers/bradshaw/bunny-hubbard.sph");
        tree = spheretree::sph::read_sph(&path)
            .unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
        source = "Bradshaw toolkit hubbard tree bunny-hubbard.sph".to_string();
    } else {
        let path = repo_root().join("assets/bunny.obj");
        let mesh = mesh::load_mesh(&path)
            .unwrap_or_else(|e| panic!("cannot load {}: {e}", path.display()))
            .mesh;
        let params = BuildParams::default();
        let t0 = Instant::now();
        tree = build_tree(&mesh, &params, &|_| {}).expect("bunny tree build");
        source = format!(
            "build_tree({}, depth {}, B {}) on assets/bunny.obj, built in {:.1} s",
            params.method.name(),
            params.depth,
            params.branching,
            t0.elapsed().as_secs_f64()
        );
    }
    for s in tree.spheres_mut() {
        if s.is_used() {
            s.center = s.center.map(|v| v * SCALE);
            s.radius *= SCALE;
        }
    }
    let growth = tree.enforce_containment();
    (
        tree,
        format!("{source}, x{SCALE} to mm (containment enforced: max growth {growth:.3} mm)"),
    )
}

fn pose_at(offset: f64) -> Pose {
    Pose::from_array([offset, 0.0, 0.0, ROT[0], ROT[1], ROT[2]])
}

fn count(tool: &PackedTree, obj: &PackedTree, pose: &Pose, ws: &mut CollideWorkspace) -> usize {
    overlap_tree_tree(tool, pose, obj, 0.0, ws, |_| {}).unwrap_or(0)
}

/// Bisection on the x offset (mm) for a pose with about `target` leaf pairs.
fn find_offset(
    tool: &PackedTree,
    obj: &PackedTree,
    target: usize,
    ws: &mut CollideWorkspace,
) -> (f64, usize) {
    let (mut lo, mut hi) = (0.0, 2.0 * (tool.radius(0) + obj.radius(0)));
    let mut best = (hi, count(tool, obj, &pose_at(hi), ws));
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        let n = count(tool, obj, &pose_at(mid), ws);
        if n.abs_diff(target) < best.1.abs_diff(target) {
            best = (mid, n);
        }
        if n >= target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    best
}

/// The brute-force reference: all leaf pairs, leaves as flat arrays, tool leaves transformed
/// once per query into a reused buffer.
struct Brute {
    tool: Vec<[f64; 4]>,
    obj: Vec<[f64; 4]>,
    posed: Vec<[f64; 4]>,
}

impl Brute {
    fn new(tool: &PackedTree, obj: &PackedTree) -> Self {
        let leaves = |t: &PackedTree| -> Vec<[f64; 4]> {
            t.leaves()
                .map(|n| {
                    let c = t.center(n);
                    [c[0], c[1], c[2], t.radius(n)]
                })
                .collect()
        };
        let tool = leaves(tool);
        let posed = tool.clone();
        Self {
            tool,
            obj: leaves(obj),
            posed,
        }
    }

    fn query(&mut self, pose: &Pose, mut visit: impl FnMut(usize, usize, f64)) -> usize {
        let r = pose.rotation_matrix();
        let t = pose.translation();
        for (p, s) in self.posed.iter_mut().zip(&self.tool) {
            for k in 0..3 {
                p[k] = r[(k, 0)] * s[0] + r[(k, 1)] * s[1] + r[(k, 2)] * s[2] + t[k];
            }
            p[3] = s[3];
        }
        let mut n = 0;
        for (i, a) in self.posed.iter().enumerate() {
            for (j, b) in self.obj.iter().enumerate() {
                let d2 = (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2);
                let s = a[3] + b[3];
                if d2 <= s * s {
                    visit(i, j, d2);
                    n += 1;
                }
            }
        }
        n
    }
}

/// parry3d-f64: each tree's leaves as a `Compound` of `Ball`s (parry builds its own BVH over
/// their AABBs); the query is parry's simultaneous BVH traversal (`Bvh::leaf_pairs`, each tool
/// node's AABB transformed by the relative pose, as parry's own composite-composite contacts do),
/// followed by the exact ball-ball test on each AABB-overlapping leaf pair.
struct Parry {
    tool: Compound,
    obj: Compound,
    tool_balls: Vec<[f64; 4]>,
    obj_balls: Vec<[f64; 4]>,
}

impl Parry {
    fn new(brute: &Brute) -> Self {
        let compound = |balls: &[[f64; 4]]| {
            Compound::new(
                balls
                    .iter()
                    .map(|b| {
                        (
                            ParryPose::translation(b[0], b[1], b[2]),
                            SharedShape::ball(b[3]),
                        )
                    })
                    .collect(),
            )
        };
        Self {
            tool: compound(&brute.tool),
            obj: compound(&brute.obj),
            tool_balls: brute.tool.clone(),
            obj_balls: brute.obj.clone(),
        }
    }

    fn query(&mut self, pose: &Pose, visit: impl FnMut(u32, u32, f64)) -> usize {
        self.query_counting(pose, visit).0
    }

    /// Pairs found, and leaf pairs whose AABBs overlapped (the exact tests run).
    fn query_counting(
        &mut self,
        pose: &Pose,
        mut visit: impl FnMut(u32, u32, f64),
    ) -> (usize, usize) {
        let world_from_tool = pose.to_isometry();
        let (t, q) = (world_from_tool.translation.vector, world_from_tool.rotation);
        let relative = ParryPose::from_parts(
            ParryVector::new(t.x, t.y, t.z),
            ParryRotation::from_xyzw(q.i, q.j, q.k, q.w),
        );
        let (tb, ob) = (&self.tool_balls, &self.obj_balls);
        let mut n = 0;
        let mut candidates = 0;
        // Left: the object (world); right: the tool, AABBs mapped by world_from_tool.
        let pairs = self
            .obj
            .bvh()
            .leaf_pairs(self.tool.bvh(), |o: &BvhNode, t: &BvhNode| {
                o.aabb().intersects(&t.aabb().transform_by(&relative))
            });
        for (o, t) in pairs {
            candidates += 1;
            let a = tb[t as usize];
            let c = world_from_tool * nalgebra::Point3::new(a[0], a[1], a[2]);
            let b = ob[o as usize];
            let d2 = (c.x - b[0]).powi(2) + (c.y - b[1]).powi(2) + (c.z - b[2]).powi(2);
            let s = a[3] + b[3];
            if d2 <= s * s {
                visit(t, o, d2);
                n += 1;
            }
        }
        (n, candidates)
    }
}

struct Scenario {
    target: usize,
    offset: f64,
    pairs: usize,
}

/// CPU time of this thread (µs): unlike wall time it does not count the time the thread was
/// preempted, so it stays meaningful on a loaded machine.
fn thread_cpu_us() -> f64 {
    devkit::thread_cpu_time().as_secs_f64() * 1e6
}

/// Thread CPU time of `iters` calls of `f`, for criterion's `iter_custom`: criterion's
/// statistics then describe CPU time, not wall time inflated by preemption on a shared machine.
fn cpu_time<R>(iters: u64, mut f: impl FnMut() -> R) -> Duration {
    let t0 = thread_cpu_us();
    for _ in 0..iters {
        black_box(f());
    }
    Duration::from_secs_f64((thread_cpu_us() - t0).max(0.0) * 1e-6)
}

/// Mean thread CPU time per call of `f` (µs) over `n` calls.
fn cpu_mean(f: &mut dyn FnMut() -> usize, n: usize) -> f64 {
    let t0 = thread_cpu_us();
    for _ in 0..n {
        black_box(f());
    }
    (thread_cpu_us() - t0) / n as f64
}

fn percentiles(mut v: Vec<f64>) -> (f64, f64, f64) {
    v.sort_by(|a, b| a.total_cmp(b));
    let at = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
    (at(0.5), at(0.99), v[v.len() - 1])
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    let (tree, source) = bunny_tree();
    let tool = PackedTree::new(&tree).expect("tool tree");
    let obj = PackedTree::new(&tree).expect("object tree");
    let mut ws = CollideWorkspace::for_trees(&tool, std::slice::from_ref(&obj));
    let mut brute = Brute::new(&tool, &obj);
    let mut parry = Parry::new(&brute);
    println!("tree: {source}");
    println!(
        "slots {}, used {}, leaves {}; tool rotation (gamma, beta, alpha) = {ROT:?} rad, offset along x",
        tree.len(),
        tool.len(),
        tool.leaf_count()
    );

    let scenarios: Vec<Scenario> = TARGETS
        .iter()
        .map(|&target| {
            let (offset, pairs) = find_offset(&tool, &obj, target, &mut ws);
            let pose = pose_at(offset);
            // All three methods must agree on the pair count.
            let b = brute.query(&pose, |_, _, _| {});
            let (p, candidates) = parry.query_counting(&pose, |_, _, _| {});
            overlap_tree_tree(&tool, &pose, &obj, 0.0, &mut ws, |_| {}).expect("query");

            let st = ws.stats();
            assert_eq!((b, p), (pairs, pairs), "brute force / parry disagree at offset {offset}");
            println!(
                "target ~{target}: offset {offset:.4} mm -> {pairs} leaf pairs (brute force and parry agree); \
                 collide: {} node pairs split, {} sphere tests, {} tool nodes posed; \
                 parry: {candidates} exact ball tests after its AABB tests",
                st.node_pairs_split,
                st.sphere_tests,
                st.tool_nodes_posed
            );
            Scenario { target, offset, pairs }
        })
        .collect();

    let mut group = c.benchmark_group("bunny_vs_bunny");
    for s in &scenarios {
        let pose = pose_at(s.offset);
        let id = format!("{}pairs", s.pairs);
        group.bench_with_input(BenchmarkId::new("collide", &id), &pose, |b, pose| {
            b.iter_custom(|iters| {
                cpu_time(iters, || {
                    let mut acc = 0.0;
                    let n = overlap_tree_tree(&tool, black_box(pose), &obj, 0.0, &mut ws, |p| {
                        acc += p.gap
                    });
                    black_box((n, acc))
                })
            })
        });
        group.bench_with_input(BenchmarkId::new("parry_qbvh", &id), &pose, |b, pose| {
            b.iter_custom(|iters| {
                cpu_time(iters, || {
                    let mut acc = 0.0;
                    let n = parry.query(black_box(pose), |_, _, d2| acc += d2);
                    black_box((n, acc))
                })
            })
        });
    }
    group.finish();

    // Constraint rows for the pairs of each scenario (linearized at a pose 0.1 mm / 1 mrad away).
    let mut group = c.benchmark_group("constraint_rows");
    let objects = std::slice::from_ref(&obj);
    let mut pairs = Vec::with_capacity(8192);
    let mut rows = vec![[0.0; 6]; 8192];
    let mut rhs = vec![0.0; 8192];
    for s in &scenarios {
        let q_h = pose_at(s.offset);
        let mut q_lin = q_h;
        q_lin.q[0] += 0.1;
        q_lin.q[5] += 1e-3;
        collect_pairs(&tool, &q_h, objects, 0.0, &mut ws, &mut pairs).expect("pairs");
        for (name, form) in [
            ("distance", ConstraintForm::Distance),
            ("squared", ConstraintForm::Squared),
        ] {
            let id = format!("{}pairs", pairs.len());
            group.bench_with_input(BenchmarkId::new(name, &id), &pairs, |b, pairs| {
                b.iter_custom(|iters| {
                    cpu_time(iters, || {
                        let n = fill_constraints(
                            form,
                            black_box(&q_lin),
                            &q_h,
                            pairs,
                            &mut rows,
                            &mut rhs,
                        );
                        black_box((n.ok(), rhs[0]))
                    })
                })
            });
        }
    }
    group.finish();

    let mut group = c.benchmark_group("bunny_vs_bunny_brute");
    group.sample_size(10);
    for s in &scenarios {
        let pose = pose_at(s.offset);
        let id = format!("{}pairs", s.pairs);
        group.bench_with_input(BenchmarkId::new("brute_force", &id), &pose, |b, pose| {
            b.iter_custom(|iters| {
                cpu_time(iters, || {
                    let mut acc = 0.0;
                    let n = brute.query(black_box(pose), |_, _, d2| acc += d2);
                    black_box((n, acc))
                })
            })
        });
    }
    group.finish();

    // Individually timed queries: p50 / p99 / max (µs), one thread.
    let runs = if std::env::args().any(|a| a == "--quick") {
        200
    } else {
        3000
    };
    println!("\nper-query timings over {runs} queries each (µs): p50 / p99 / max");
    println!("| pairs | collide p50 | collide p99 | collide max | collide CPU mean | parry p50 | parry p99 | parry CPU mean | brute CPU mean | parry/collide (CPU) | brute/collide (CPU) | rows p50 distance | rows p50 squared |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for s in &scenarios {
        let pose = pose_at(s.offset);
        let time = |f: &mut dyn FnMut() -> usize, n: usize| -> Vec<f64> {
            (0..n)
                .map(|_| {
                    let t0 = Instant::now();
                    black_box(f());
                    t0.elapsed().as_secs_f64() * 1e6
                })
                .collect()
        };
        let ours = percentiles(time(
            &mut || {
                overlap_tree_tree(&tool, black_box(&pose), &obj, 0.0, &mut ws, |p| {
                    black_box(p);
                })
                .unwrap_or(0)
            },
            runs,
        ));
        let theirs = percentiles(time(
            &mut || {
                parry.query(black_box(&pose), |_, _, d2| {
                    black_box(d2);
                })
            },
            runs,
        ));
        let brute_n = (runs / 100).max(5);
        let ours_cpu = cpu_mean(
            &mut || {
                overlap_tree_tree(&tool, black_box(&pose), &obj, 0.0, &mut ws, |p| {
                    black_box(p);
                })
                .unwrap_or(0)
            },
            runs,
        );
        let theirs_cpu = cpu_mean(
            &mut || {
                parry.query(black_box(&pose), |_, _, d2| {
                    black_box(d2);
                })
            },
            runs / 10,
        );
        let brute_cpu = cpu_mean(
            &mut || {
                brute.query(black_box(&pose), |_, _, d2| {
                    black_box(d2);
                })
            },
            brute_n,
        );
        let mut q_lin = pose;
        q_lin.q[0] += 0.1;
        q_lin.q[5] += 1e-3;
        collect_pairs(&tool, &pose, objects, 0.0, &mut ws, &mut pairs).expect("pairs");
        let mut rows_p50 = [0.0; 2];
        for (k, form) in [ConstraintForm::Distance, ConstraintForm::Squared]
            .into_iter()
            .enumerate()
        {
            rows_p50[k] = percentiles(time(
                &mut || {
                    fill_constraints(form, black_box(&q_lin), &pose, &pairs, &mut rows, &mut rhs)
                        .unwrap_or(0)
                },
                runs,
            ))
            .0;
        }
        println!(
            "| {} (~{}) | {:.2} | {:.2} | {:.0} | {:.2} | {:.1} | {:.1} | {:.1} | {:.0} | {:.1}x | {:.0}x | {:.2} | {:.2} |",
            s.pairs,
            s.target,
            ours.0,
            ours.1,
            ours.2,
            ours_cpu,
            theirs.0,
            theirs.1,
            theirs_cpu,
            brute_cpu,
            theirs_cpu / ours_cpu,
            brute_cpu / ours_cpu,
            rows_p50[0],
            rows_p50[1]
        );
    }
    c.final_summary();
}
