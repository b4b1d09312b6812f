//! The tight builder (default): patches of dense surface samples, one optimised sphere each.
//!
//! 1. Draw `B^depth * samples_per_leaf` seeded surface samples with normals.
//! 2. Top-down, split each node's samples into B balanced, compact groups on
//!    `(position, w · normal)` ([`partition::split`]); the groups at the last level are the
//!    leaf patches.
//! 3. Fit each leaf (in parallel): the centre `c` minimises
//!    `r(c) + sd(c) + size_weight · r(c)`, where `r(c)` is the radius that covers the patch
//!    and `sd` the signed distance to the mesh (negative inside). `r + sd` bounds the
//!    protrusion of the ball out of the mesh from above (the ball `B(c, -sd)` lies inside),
//!    so lowering it pushes the centre inward, towards the medial axis, as far as pays.
//! 4. Check coverage on a second, denser sample set; each uncovered sample joins the patch of
//!    its nearest same-facing training sample, and those leaves are refitted (a few rounds).
//! 5. Parents are the smallest spheres enclosing their children.

#![allow(clippy::needless_range_loop)] // xyz loops read better indexed

use super::enclose::nelder_mead;
use super::{fill_parents, partition, BuildParams};
use crate::eval::{dist, dist2, SphereGrid};
use crate::{Sphere, SphereTree, TreeError};
use mesh::{sample_surface, MeshQuery, TriMesh};
use rayon::prelude::*;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Rounds of coverage repair.
const REPAIR_ROUNDS: usize = 4;
/// Largest number of training samples (memory bound for deep trees).
const MAX_SAMPLES: usize = 4_000_000;

pub(super) fn build(
    m: &TriMesh,
    params: &BuildParams,
    tree: &mut SphereTree,
    progress: &(dyn Fn(f64) + Sync),
) -> Result<(), TreeError> {
    let b = tree.branching() as usize;
    let depth = tree.depth();
    let leaf_slots = tree.level_range(depth).len();
    let n_train = (leaf_slots * params.samples_per_leaf.max(1)).clamp(1000, MAX_SAMPLES);
    let n_check = (leaf_slots * params.check_samples_per_leaf).clamp(1000, MAX_SAMPLES);
    let q = MeshQuery::new(m);
    if q.triangle_count() == 0 {
        return Err(TreeError::Build(
            "every triangle of the mesh is degenerate: give a mesh with area".into(),
        ));
    }
    let train = sample_surface(m, n_train, params.seed);
    let pos: Vec<[f64; 3]> = train.iter().map(|s| s.0).collect();
    let nrm: Vec<[f64; 3]> = train.iter().map(|s| s.1).collect();
    progress(0.05);

    // 2. Top-down partition.
    let mut nodes: Vec<(usize, Vec<u32>)> = vec![(0, (0..pos.len() as u32).collect())];
    for level in 1..=depth {
        nodes = nodes
            .par_iter()
            .flat_map_iter(|(slot, idx)| {
                let w = 0.5 * rms_radius(&pos, idx);
                let groups = partition::split(&pos, &nrm, idx, b, w, 4);
                let slot = *slot;
                groups
                    .into_iter()
                    .enumerate()
                    .map(move |(k, g)| (slot * b + 1 + k, g))
            })
            .collect();
        progress(0.05 + 0.15 * level as f64 / depth.max(1) as f64);
    }

    // 3. Leaf fits.
    let done = AtomicUsize::new(0);
    let total = nodes.len().max(1);
    let fit_all =
        |nodes: &[(usize, Vec<u32>)], extra: &[Vec<[f64; 3]>], start: Option<&[Sphere]>| {
            nodes
                .par_iter()
                .enumerate()
                .map(|(i, (_, idx))| {
                    let mut pts: Vec<[f64; 3]> = idx.iter().map(|&k| pos[k as usize]).collect();
                    pts.extend_from_slice(&extra[i]);
                    let normal = mean_normal(&nrm, idx);
                    let s = fit_leaf(
                        &q,
                        &pts,
                        normal,
                        params.size_weight,
                        params.coverage_margin,
                        start.map(|s| s[i]),
                    );
                    let d = done.fetch_add(1, Ordering::Relaxed) + 1;
                    if d.is_multiple_of(64) {
                        progress(0.2 + 0.5 * (d as f64 / total as f64).min(1.0));
                    }
                    s
                })
                .collect::<Vec<Sphere>>()
        };
    let mut extra: Vec<Vec<[f64; 3]>> = vec![Vec::new(); nodes.len()];
    let mut leaves = fit_all(&nodes, &extra, None);
    progress(0.7);

    // 4. Coverage repair against a denser sample set.
    let check: Vec<([f64; 3], [f64; 3])> =
        sample_surface(m, n_check, params.seed.wrapping_add(0x9e37_79b9_7f4a_7c15));
    let check_pts: Vec<[f64; 3]> = check.iter().map(|s| s.0).collect();
    let owner = owner_of_samples(&nodes, pos.len());
    let near = PointGrid::new(&pos, rms_radius(&pos, &nodes[0].1).max(1e-9) * 2.0);
    for round in 0..REPAIR_ROUNDS {
        let grid = SphereGrid::new(&check_pts, &leaves, 64);
        let uncovered: Vec<usize> = (0..check.len())
            .into_par_iter()
            .filter(|&i| {
                let p = check[i].0;
                !grid.candidates(p).iter().any(|&j| {
                    let s = &leaves[j as usize];
                    dist2(s.center, p) <= s.radius * s.radius
                })
            })
            .collect();
        if uncovered.is_empty() {
            break;
        }
        let mut touched = vec![false; nodes.len()];
        let assigned: Vec<(usize, [f64; 3])> = uncovered
            .par_iter()
            .map(|&i| {
                let (p, n) = check[i];
                let k = near.nearest_facing(&pos, &nrm, p, n);
                (owner[k as usize], p)
            })
            .collect();
        for (leaf, p) in assigned {
            extra[leaf].push(p);
            touched[leaf] = true;
        }
        let idx: Vec<usize> = (0..nodes.len()).filter(|&i| touched[i]).collect();
        let sub_nodes: Vec<(usize, Vec<u32>)> = idx.iter().map(|&i| nodes[i].clone()).collect();
        let sub_extra: Vec<Vec<[f64; 3]>> = idx.iter().map(|&i| extra[i].clone()).collect();
        let sub_start: Vec<Sphere> = idx.iter().map(|&i| leaves[i]).collect();
        let refit = fit_all(&sub_nodes, &sub_extra, Some(&sub_start));
        for (k, &i) in idx.iter().enumerate() {
            leaves[i] = refit[k];
        }
        progress(0.7 + 0.25 * (round + 1) as f64 / REPAIR_ROUNDS as f64);
    }

    // 5. Into the tree; parents enclose children.
    for (i, (slot, _)) in nodes.iter().enumerate() {
        tree.spheres_mut()[*slot] = leaves[i];
    }
    for n in (1..tree.len()).rev() {
        if tree.sphere(n).is_used() {
            if let Some(p) = tree.parent(n) {
                tree.spheres_mut()[p] = Sphere::new([0.0; 3], 0.0);
            }
        }
    }
    if depth == 0 {
        tree.spheres_mut()[0] = leaves[0];
    }
    fill_parents(tree);
    Ok(())
}

/// The leaf sphere for patch points `pts` with mean outward normal `normal`: see the module
/// docs (step 3). `start` (a previous fit) seeds the search.
fn fit_leaf(
    q: &MeshQuery,
    pts: &[[f64; 3]],
    normal: [f64; 3],
    size_weight: f64,
    margin: f64,
    start: Option<Sphere>,
) -> Sphere {
    let cover = |c: [f64; 3]| pts.iter().map(|p| dist2(*p, c)).fold(0.0, f64::max).sqrt();
    let f = |c: [f64; 3]| {
        let r = cover(c);
        r * (1.0 + size_weight) + q.signed_distance(c)
    };
    let n = pts.len().max(1) as f64;
    let mut centroid = [0.0; 3];
    for p in pts {
        for k in 0..3 {
            centroid[k] += p[k] / n;
        }
    }
    let a = cover(centroid).max(1e-6);
    let mut starts = vec![
        inward(centroid, normal, a),
        inward(centroid, normal, 3.0 * a),
    ];
    if let Some(s) = start {
        starts.push(s.center);
    }
    let mut best = centroid;
    let mut best_f = f(centroid);
    for s in starts {
        let c = nelder_mead(&f, s, 0.5 * a, 160, 1e-3);
        let v = f(c);
        if v < best_f {
            best_f = v;
            best = c;
        }
    }
    Sphere::new(best, cover(best) + margin.max(0.0))
}

fn inward(c: [f64; 3], n: [f64; 3], t: f64) -> [f64; 3] {
    [c[0] - n[0] * t, c[1] - n[1] * t, c[2] - n[2] * t]
}

fn mean_normal(nrm: &[[f64; 3]], idx: &[u32]) -> [f64; 3] {
    let mut m = [0.0; 3];
    for &i in idx {
        for k in 0..3 {
            m[k] += nrm[i as usize][k];
        }
    }
    let l = dist(m, [0.0; 3]);
    if l > 1e-12 {
        m.map(|x| x / l)
    } else {
        [0.0; 3]
    }
}

fn rms_radius(pos: &[[f64; 3]], idx: &[u32]) -> f64 {
    let n = idx.len().max(1) as f64;
    let mut c = [0.0; 3];
    for &i in idx {
        for k in 0..3 {
            c[k] += pos[i as usize][k] / n;
        }
    }
    (idx.iter().map(|&i| dist2(pos[i as usize], c)).sum::<f64>() / n).sqrt()
}

/// For each training sample, the index (into the leaf list) of the leaf patch holding it.
fn owner_of_samples(nodes: &[(usize, Vec<u32>)], n: usize) -> Vec<usize> {
    let mut owner = vec![0usize; n];
    for (leaf, (_, idx)) in nodes.iter().enumerate() {
        for &i in idx {
            owner[i as usize] = leaf;
        }
    }
    owner
}

/// A hashed uniform grid over points for nearest-neighbour look-ups.
struct PointGrid {
    h: f64,
    cells: std::collections::HashMap<[i64; 3], Vec<u32>>,
}

impl PointGrid {
    fn new(pos: &[[f64; 3]], h: f64) -> Self {
        // Cell size: about 4 samples per cell side on average is plenty; use a fraction of
        // the given scale so look-ups stay local.
        let h = (h / 16.0).max(1e-9);
        let mut cells: std::collections::HashMap<[i64; 3], Vec<u32>> = Default::default();
        for (i, p) in pos.iter().enumerate() {
            cells.entry(Self::key(h, *p)).or_default().push(i as u32);
        }
        PointGrid { h, cells }
    }

    fn key(h: f64, p: [f64; 3]) -> [i64; 3] {
        p.map(|x| (x / h).floor() as i64)
    }

    /// The nearest point whose normal faces the same way as `n` (dot > 0), searching rings
    /// of cells outwards; falls back to the nearest point of any facing.
    fn nearest_facing(&self, pos: &[[f64; 3]], nrm: &[[f64; 3]], p: [f64; 3], n: [f64; 3]) -> u32 {
        let k = Self::key(self.h, p);
        let mut best: Option<(f64, u32)> = None;
        let mut any: Option<(f64, u32)> = None;
        for ring in 0..64i64 {
            for dx in -ring..=ring {
                for dy in -ring..=ring {
                    for dz in -ring..=ring {
                        if dx.abs().max(dy.abs()).max(dz.abs()) != ring {
                            continue;
                        }
                        let Some(list) = self.cells.get(&[k[0] + dx, k[1] + dy, k[2] + dz]) else {
                            continue;
                        };
                        for &i in list {
                            let d = dist2(pos[i as usize], p);
                            let m = nrm[i as usize];
                            if m[0] * n[0] + m[1] * n[1] + m[2] * n[2] > 0.0
                                && best.is_none_or(|b| d < b.0)
                            {
                                best = Some((d, i));
                            }
                            if any.is_none_or(|b| d < b.0) {
                                any = Some((d, i));
                            }
                        }
                    }
                }
            }
            // Everything within `ring * h` of p has been seen.
            let reach = (ring as f64 * self.h).powi(2);
            if let Some((d, i)) = best {
                if d <= reach {
                    return i;
                }
            }
            if ring > 8 {
                if let Some((_, i)) = best.or(any) {
                    return i;
                }
            }
        }
        best.or(any).map_or(0, |b| b.1)
    }
}
