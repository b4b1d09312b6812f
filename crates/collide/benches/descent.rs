//! The triangle trees' descent (the mesh mode's listing of triangle pairs near each other,
//! `TriangleTree::near_leaf_pairs` and `descend`): a round peg 15 mm long, 256 facets round,
//! in a hole 0.05 mm wider and 50 mm deep, every leaf pair within a margin of 0.15 mm listed
//! (the peg's whole side is near the wall: a tight fit's near list), at rest and swept 0.2 mm
//! down the hole. Then the light contact of the built-in bunny scene, whose lists are short but
//! listed anew every few frames while the tool turns: the bunny (`assets/bunny.obj`, scaled to
//! ~100 mm as the scene does) beside a turned copy of itself, margin 0.75 mm, with no pair
//! within it and with ~50 pairs.
//!
//! Run: `cargo bench -p collide --bench descent` (add `-- --quick` for a short run).

use std::f64::consts::TAU;
use std::hint::black_box;

use collide::{Pose, Triangle, TriangleTree};
use criterion::{BenchmarkId, Criterion};
use nalgebra::Vector3;

/// The side of a cylinder of radius `r` (mm) along z from 0 to `len`, `round` facets round and
/// `rings` along.
fn cylinder(r: f64, round: usize, rings: usize, len: f64) -> Vec<Triangle> {
    let p = |i: usize, j: usize| {
        let a = i as f64 / round as f64 * TAU;
        [r * a.cos(), r * a.sin(), j as f64 * len / rings as f64]
    };
    let mut out = Vec::with_capacity(2 * round * rings);
    for i in 0..round {
        for j in 0..rings {
            out.push([p(i, j), p(i + 1, j), p(i + 1, j + 1)]);
            out.push([p(i, j), p(i + 1, j + 1), p(i, j + 1)]);
        }
    }
    out
}

fn bench(c: &mut Criterion) {
    let peg = TriangleTree::build(&cylinder(10.0, 256, 12, 15.0), &Pose::identity());
    let hole = TriangleTree::build(&cylinder(10.05, 256, 40, 50.0), &Pose::identity());
    let mut stack = TriangleTree::stack_for(&peg, &hole);
    // 5 mm in, 0.01 mm off the axis and tilted 1 mrad.
    let q = Pose::from_array([0.01, 0.0, 5.0, 0.001, 0.0, 0.0]);
    let mut group = c.benchmark_group("descent");
    group.sample_size(20);
    for (name, sweep) in [
        ("peg in hole", Vector3::zeros()),
        ("peg in hole, swept", Vector3::new(0.0, 0.0, -0.2)),
    ] {
        group.bench_function(BenchmarkId::new("leaf pairs", name), |b| {
            b.iter(|| triangle_pairs(&peg, &hole, &q, &sweep, 0.15, &mut stack))
        });
    }
    group.finish();

    // A longer peg of long facets (a machined part's flat faces merged) 5 mm into a hole with a
    // top face: the near part of the tool noted, and not.
    let peg = TriangleTree::build(&cylinder(10.0, 256, 1, 40.0), &Pose::identity());
    let mut block = cylinder(10.05, 256, 1, 50.0);
    block.extend(annulus(10.05, 20.0, 256, 50.0));
    let block = TriangleTree::build(&block, &Pose::identity());
    let mut stack = TriangleTree::stack_for(&peg, &block);
    let q = Pose::from_array([0.01, 0.0, 45.0, 0.02, 0.0, 0.0]);
    let (rot, t) = (q.rotation_matrix(), q.translation());
    let mut group = c.benchmark_group("near part");
    group.sample_size(20);
    for (name, wide) in [("not noted", f64::NEG_INFINITY), ("noted", 1.05)] {
        group.bench_function(BenchmarkId::new("peg at the mouth", name), |b| {
            b.iter(|| {
                let mut pairs = 0usize;
                TriangleTree::start_descent(&mut stack);
                stack.note_near_part(wide, f64::INFINITY);
                peg.descend(
                    black_box(&rot),
                    black_box(&t),
                    &Vector3::zeros(),
                    &block,
                    0.25,
                    &mut stack,
                    usize::MAX,
                    |tools, parts, _| {
                        pairs += tools.len() * parts.len();
                        true
                    },
                );
                (pairs, stack.near_part())
            })
        });
    }
    group.finish();

    // The bunny beside a copy of itself turned (0.1, 0.2, 0) rad, moved along x by a share of
    // its width: 0.86 leaves no triangle pair within the margin, 0.84 ~50.
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../assets/bunny.obj");
    let bunny_mesh = mesh::load_mesh(std::path::Path::new(path))
        .expect("assets/bunny.obj")
        .mesh;
    let bunny: Vec<Triangle> = bunny_mesh
        .triangles
        .iter()
        .map(|t| std::array::from_fn(|c| bunny_mesh.vertices[t[c] as usize].map(|v| 10.0 * v)))
        .collect();
    let width = bunny
        .iter()
        .flatten()
        .map(|p| p[0])
        .fold(f64::NEG_INFINITY, f64::max)
        - bunny
            .iter()
            .flatten()
            .map(|p| p[0])
            .fold(f64::INFINITY, f64::min);
    let bunny = TriangleTree::build(&bunny, &Pose::identity());
    let mut stack = TriangleTree::stack_for(&bunny, &bunny);
    let mut group = c.benchmark_group("light contact");
    group.sample_size(50);
    for (name, share) in [
        ("bunny beside a bunny, none within", 0.86),
        ("bunny on a bunny", 0.84),
    ] {
        let q = Pose::from_array([share * width, 0.05 * width, 0.0, 0.1, 0.2, 0.0]);
        group.bench_function(BenchmarkId::new("leaf pairs", name), |b| {
            b.iter(|| triangle_pairs(&bunny, &bunny, &q, &Vector3::zeros(), 0.75, &mut stack))
        });
    }
    group.finish();
}

/// A whole descent of `tool` at `q` swept by `sweep` (mm) against `object` within `margin`
/// (mm): the triangle pairs of the leaf pairs it visits.
fn triangle_pairs(
    tool: &TriangleTree,
    object: &TriangleTree,
    q: &Pose,
    sweep: &Vector3<f64>,
    margin: f64,
    stack: &mut collide::TreePairStack,
) -> usize {
    let (rot, t) = (q.rotation_matrix(), q.translation());
    let mut pairs = 0usize;
    TriangleTree::start_descent(stack);
    tool.descend(
        black_box(&rot),
        black_box(&t),
        sweep,
        object,
        margin,
        stack,
        usize::MAX,
        |tools, parts, _| {
            pairs += tools.len() * parts.len();
            true
        },
    );
    pairs
}

/// A flat ring at height `z` (mm) from radius `r0` to `r1`, `round` facets round, facing up.
fn annulus(r0: f64, r1: f64, round: usize, z: f64) -> Vec<Triangle> {
    let p = |r: f64, i: usize| {
        let a = i as f64 / round as f64 * TAU;
        [r * a.cos(), r * a.sin(), z]
    };
    (0..round)
        .flat_map(|i| {
            [
                [p(r0, i), p(r1, i), p(r1, i + 1)],
                [p(r0, i), p(r1, i + 1), p(r0, i + 1)],
            ]
        })
        .collect()
}

criterion::criterion_group!(benches, bench);
criterion::criterion_main!(benches);
