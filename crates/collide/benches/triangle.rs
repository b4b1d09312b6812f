//! The exact triangle–triangle distance (the mesh mode's narrow phase): `triangle_distance`,
//! which stops at a face contact or a separating slab, and `triangle_distance_from` with each
//! pair's nearest edges kept from its last measure (as a sliding contact's are), against
//! `triangle_distance_all_features`, which measures all fifteen feature pairs, on five sets of
//! 1 024 pairs: a face over a face 0.01–0.1 mm apart (a tight fit's walls, a box on a plate),
//! two fans meeting at their apexes (a ball's pole on another's), skew edges crossing at a
//! small gap (a cube's edge on another's), slivers of faces lying on each other 50 mm from
//! the origin, and random pairs 0–3 mm apart.
//!
//! A second group times `feature_contacts` (the candidate nearest feature pairs of a triangle
//! pair of two meshes, at a slack of 0 and of 0.05 mm) against the distance on the same pairs:
//! a ball's pole fan over another's (2 048 pairs, 0.1 mm apart, turned a little) and a box's
//! face over a box's (its faces cut 8 × 8, 0.05 mm apart, slid and turned a little).
//!
//! Run: `cargo bench -p collide --bench triangle` (add `-- --quick` for a short run).

use std::f64::consts::TAU;
use std::hint::black_box;

use collide::{
    feature_contacts, triangle_distance, triangle_distance_all_features, triangle_distance_from,
    MeshFeatures, NearestEdges, PlacedFeatures, Pose, Triangle,
};
use criterion::{BenchmarkId, Criterion, Throughput};
use mesh::generate::{grid_box, uv_sphere};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const PAIRS: usize = 1024;

fn random_triangle(rng: &mut ChaCha8Rng, centre: [f64; 3], size: f64) -> Triangle {
    std::array::from_fn(|_| std::array::from_fn(|k| centre[k] + size * rng.random_range(-1.0..1.0)))
}

/// A face over a face: random triangles in `z = 0` and copies slid about in `z = gap`.
fn faces(rng: &mut ChaCha8Rng) -> Vec<(Triangle, Triangle)> {
    (0..PAIRS)
        .map(|_| {
            let mut a = random_triangle(rng, [0.0; 3], 1.0);
            a.iter_mut().for_each(|p| p[2] = 0.0);
            let (dx, dy, gap) = (
                rng.random_range(-0.5..0.5),
                rng.random_range(-0.5..0.5),
                rng.random_range(0.01..0.1),
            );
            let b = a.map(|p| [p[0] + dx, p[1] + dy, gap]);
            (a, b)
        })
        .collect()
}

/// Fans meeting at their apexes: the triangles of a 32-sided cone's tip against a 64-sided
/// one's above it, as a ball's pole meets another's.
fn apexes(rng: &mut ChaCha8Rng) -> Vec<(Triangle, Triangle)> {
    let fan = |n: usize, k: usize, z: f64, rise: f64| -> Triangle {
        let at = |i: usize| {
            let a = TAU * (i % n) as f64 / n as f64;
            [a.cos(), a.sin(), z + rise]
        };
        [[0.0, 0.0, z], at(k), at(k + 1)]
    };
    (0..PAIRS)
        .map(|_| {
            let gap = rng.random_range(0.0..0.05);
            (
                fan(32, rng.random_range(0..32), 0.0, -0.05),
                fan(64, rng.random_range(0..64), gap, 0.05),
            )
        })
        .collect()
}

/// Skew edges: thin triangles along `x` below and along `y` above, crossing at a small gap.
fn edges(rng: &mut ChaCha8Rng) -> Vec<(Triangle, Triangle)> {
    (0..PAIRS)
        .map(|_| {
            let (s, gap) = (rng.random_range(-0.3..0.3), rng.random_range(0.01..0.1));
            let a = [[-1.0, s, 0.0], [1.0, s, 0.0], [0.0, s, -1.0]];
            let b = [[s, -1.0, gap], [s, 1.0, gap], [0.0, s, 1.0 + gap]];
            (a, b)
        })
        .collect()
}

/// Slivers far out: long thin triangles (merged flat faces) in parallel planes 0.01–0.1 mm
/// apart, crossing in projection (no corner over the other face), 50 mm from the origin, as a
/// splined shaft's flanks lie on its hub's.
fn slivers(rng: &mut ChaCha8Rng) -> Vec<(Triangle, Triangle)> {
    (0..PAIRS)
        .map(|_| {
            let (long, gap) = (rng.random_range(10.0..40.0), rng.random_range(0.01..0.1));
            let (c, s) = (0.6f64, 0.8f64);
            // Turned about z by (c, s) and lifted 50 mm out along both x and z.
            let place =
                |p: [f64; 3]| [c * p[0] - s * p[1] + 50.0, s * p[0] + c * p[1], p[2] + 50.0];
            let a = [[-long, -0.5, 0.0], [long, -0.3, 0.0], [long, 0.4, 0.0]].map(place);
            let b = [[-0.6, -long, gap], [0.3, long, gap], [0.5, long, gap]].map(place);
            (a, b)
        })
        .collect()
}

fn random(rng: &mut ChaCha8Rng) -> Vec<(Triangle, Triangle)> {
    (0..PAIRS)
        .map(|_| {
            let a = random_triangle(rng, [0.0; 3], 1.0);
            let above = rng.random_range(2.0..5.0);
            let b = random_triangle(rng, [0.0, 0.0, above], 1.0);
            (a, b)
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let sets = [
        ("face over face", faces(&mut rng)),
        ("apex on apex", apexes(&mut rng)),
        ("skew edges", edges(&mut rng)),
        ("slivers far out", slivers(&mut rng)),
        ("random", random(&mut rng)),
    ];
    let mut group = c.benchmark_group("triangle_distance");
    group.throughput(Throughput::Elements(PAIRS as u64));
    for (name, pairs) in &sets {
        // Same answers before timing anything.
        for (a, b) in pairs {
            let (fast, all) = (
                triangle_distance(a, b),
                triangle_distance_all_features(a, b),
            );
            assert!((fast.distance - all.distance).abs() <= 1e-9);
        }
        group.bench_with_input(BenchmarkId::new("early answers", name), pairs, |bch, p| {
            bch.iter(|| {
                p.iter()
                    .map(|(a, b)| triangle_distance(black_box(a), black_box(b)).distance)
                    .sum::<f64>()
            })
        });
        // Measured again with each pair's nearest edges kept from the last measure, as a
        // sliding contact's pairs are frame after frame.
        let mut kept: Vec<NearestEdges> = pairs
            .iter()
            .map(|(a, b)| {
                let mut last = NearestEdges::NONE;
                triangle_distance_from(a, b, &mut last);
                last
            })
            .collect();
        group.bench_with_input(BenchmarkId::new("edges kept", name), pairs, |bch, p| {
            bch.iter(|| {
                p.iter()
                    .zip(kept.iter_mut())
                    .map(|((a, b), last)| {
                        triangle_distance_from(black_box(a), black_box(b), last).distance
                    })
                    .sum::<f64>()
            })
        });
        group.bench_with_input(BenchmarkId::new("all features", name), pairs, |bch, p| {
            bch.iter(|| {
                p.iter()
                    .map(|(a, b)| {
                        triangle_distance_all_features(black_box(a), black_box(b)).distance
                    })
                    .sum::<f64>()
            })
        });
    }
    group.finish();
}

/// A generated mesh's triangles, moved by `shift`.
fn triangles(m: &mesh::TriMesh, shift: [f64; 3]) -> Vec<Triangle> {
    m.triangles
        .iter()
        .map(|t| t.map(|v| std::array::from_fn(|k| m.vertices[v as usize][k] + shift[k])))
        .collect()
}

fn bench_features(c: &mut Criterion) {
    let turned = Pose::from_array([0.02, -0.01, 0.0, 0.0, 0.0, 0.03]);
    let (rot, t) = (turned.rotation_matrix(), turned.translation());
    let place = |tris: Vec<Triangle>| -> Vec<Triangle> {
        tris.iter()
            .map(|tri| tri.map(|p| (rot * nalgebra::Vector3::from(p) + t).into()))
            .collect()
    };
    let cases = [
        (
            "pole on pole",
            place(triangles(&uv_sphere(8.0, 16, 32), [0.0, 0.0, 33.1])),
            triangles(&uv_sphere(25.0, 32, 64), [0.0; 3]),
        ),
        (
            "face on face",
            place(triangles(
                &grid_box([0.0; 3], [4.0; 3], 8),
                [0.3, 0.2, 8.05],
            )),
            triangles(&grid_box([0.0; 3], [4.0; 3], 8), [0.0; 3]),
        ),
    ];
    let mut group = c.benchmark_group("feature_contacts");
    for (name, a, b) in &cases {
        let (fa, fb) = (MeshFeatures::new(a), MeshFeatures::new(b));
        // Built from the triangles where they stand: their own points are placed.
        let (placed_a, placed_b) = (
            PlacedFeatures {
                mesh: &fa,
                points: fa.points(),
            },
            PlacedFeatures {
                mesh: &fb,
                points: fb.points(),
            },
        );
        // The triangle pairs within 0.2 mm.
        let pairs: Vec<(u32, u32)> = (0..a.len() as u32)
            .flat_map(|i| (0..b.len() as u32).map(move |j| (i, j)))
            .filter(|&(i, j)| triangle_distance(&a[i as usize], &b[j as usize]).distance <= 0.2)
            .collect();
        group.throughput(Throughput::Elements(pairs.len() as u64));
        group.bench_with_input(BenchmarkId::new("distance", name), &pairs, |bch, p| {
            bch.iter(|| {
                p.iter()
                    .map(|&(i, j)| {
                        triangle_distance(black_box(&a[i as usize]), &b[j as usize]).distance
                    })
                    .sum::<f64>()
            })
        });
        for slack in [0.0, 0.05] {
            let label = format!("candidates, slack {slack} mm");
            group.bench_with_input(BenchmarkId::new(label, name), &pairs, |bch, p| {
                bch.iter(|| {
                    let mut n = 0usize;
                    for &(i, j) in p {
                        feature_contacts(placed_a, black_box(i), placed_b, j, 0.2, slack, |_| {
                            n += 1
                        });
                    }
                    n
                })
            });
        }
    }
    group.finish();
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    bench(&mut c);
    bench_features(&mut c);
    c.final_summary();
}
