//! The tight builder (default): patches of dense surface samples, one optimised sphere each.
//!
//! 1. Per triangle, the local thickness (shrinking ball); draw `B^depth * samples_per_leaf`
//!    seeded surface samples with density `thickness^-adaptivity`, so thin parts get more,
//!    smaller patches.
//! 2. Top-down, split each node's samples into B equal-count, compact groups on
//!    `(position, w · normal)` (`w = 0` by default; [`partition::split`]); the groups at the
//!    last level are the leaf patches.
//! 3. Fit each leaf (in parallel): the centre `c` minimises
//!    `r(c) + sd(c) + size_weight · r(c)`, where `r(c)` is the radius that covers the patch
//!    and `sd` the signed distance to the mesh (negative inside). `r + sd` bounds the
//!    protrusion of the ball out of the mesh from above (the ball `B(c, -sd)` lies inside),
//!    so lowering it pushes the centre inward, towards the medial axis, as far as pays.
//! 4. Error feedback (`refine_passes`): multiply each triangle's density by its leaf's
//!    protrusion bound over the mean and redo steps 1–3, evening the errors out.
//! 5. Check coverage on a second, denser sample set; each uncovered sample joins the nearby
//!    same-facing leaf that needs the least growth, and those leaves are refitted.
//! 6. Parents contain their children; among such spheres, the one protruding least out of the
//!    mesh (same objective as the leaves, started from the smallest enclosing sphere).

#![allow(clippy::needless_range_loop)] // xyz loops read better indexed

use super::enclose::nelder_mead;
use super::{fill_parents, partition, BuildParams};
use crate::eval::{dist, dist2, SphereGrid};
use crate::{Sphere, SphereTree, TreeError};
use mesh::vec3::{cross, dot, sub};
use mesh::{sample_surface, sample_surface_weighted, InsideTest, MeshQuery, TriMesh};
use rayon::prelude::*;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Rounds of coverage repair.
const REPAIR_ROUNDS: usize = 4;
/// Clamp of the local thickness used for the sampling density (toolkit units).
const THICK_MIN: f64 = 10.0;
const THICK_MAX: f64 = 250.0;
/// Error floor (toolkit units) of the feedback pass, so error-free regions keep samples.
const FEEDBACK_FLOOR: f64 = 1.0;
/// Fewest coverage-check samples (twice the default of the fit measure).
const MIN_CHECK: usize = 200_000;
/// Largest number of training samples (memory bound for deep trees).
const MAX_SAMPLES: usize = 4_000_000;
/// Progress when the tight builder starts (after the inside test is chosen).
const QUERY_START: f64 = 0.01;
/// Progress when the query structure is built (a serial pass over the triangles).
const QUERY_READY: f64 = 0.05;
/// Progress when the thickness step (one query series per triangle) is done.
const THICKNESS_SHARE: f64 = 0.15;
/// Most triangles one closest-point query of the thickness step tests (see
/// [`shrinking_ball`]); the bundled bunny and spline meshes need at most 1024 (checked for
/// the bunny by a test).
const QUERY_BUDGET: usize = 1024;
/// Fewest triangles one thickness query may test however large the mesh.
const MIN_QUERY_BUDGET: usize = 64;
/// Triangle tests the thickness step spends per query series, over all triangles: the
/// per-query budget is this over the triangle count, within
/// `MIN_QUERY_BUDGET..=QUERY_BUDGET`, so the step stays linear in the triangle count (exact
/// queries from a ball of fixed size test more triangles the finer the mesh). Meshes of up
/// to 16 384 triangles get the full [`QUERY_BUDGET`].
const THICKNESS_TESTS: usize = 1 << 24;

pub(super) fn build(
    m: &TriMesh,
    params: &BuildParams,
    inside: InsideTest,
    tree: &mut SphereTree,
    progress: &(dyn Fn(f64) + Sync),
) -> Result<usize, TreeError> {
    let b = tree.branching() as usize;
    let depth = tree.depth();
    let leaf_slots = tree.level_range(depth).len();
    let n_train = (leaf_slots * params.samples_per_leaf.max(1)).clamp(1000, MAX_SAMPLES);
    let n_check = (leaf_slots * params.check_samples_per_leaf).clamp(MIN_CHECK, MAX_SAMPLES);
    let (q, holes) = crate::eval::solid_query_with_progress(m, inside, &|f| {
        progress(QUERY_START + (QUERY_READY - QUERY_START) * f)
    });
    if q.triangle_count() == 0 {
        return Err(TreeError::Build(
            "every triangle of the mesh is degenerate: give a mesh with area".into(),
        ));
    }
    progress(QUERY_READY);
    let thickness = triangle_thickness(m, &q, &|f| {
        progress(QUERY_READY + (THICKNESS_SHARE - QUERY_READY) * f)
    });
    let gamma = params.adaptivity;
    let mut density: Vec<f64> = thickness
        .iter()
        .map(|t| t.clamp(THICK_MIN, THICK_MAX).powf(-gamma))
        .collect();
    let passes = params.refine_passes + 1;
    let mut pass = 0;
    let (pos, nrm, nodes, mut leaves) = loop {
        let span = (0.7 - THICKNESS_SHARE) / passes as f64;
        let lo = THICKNESS_SHARE + span * pass as f64;
        let report = |f: f64| progress(lo + span * f);
        // Feedback passes only estimate errors: a line search and a short polish suffice.
        let polish = if pass + 1 < passes { 16 } else { 100 };
        let (pos, nrm, nodes, leaves) =
            patches_and_fits(m, &q, params, b, depth, n_train, &density, polish, &report);
        pass += 1;
        if pass >= passes {
            break (pos, nrm, nodes, leaves);
        }
        // Error feedback: sample each triangle more densely in proportion to the protrusion
        // bound of the leaf that covers it, so leaf errors even out.
        let err: Vec<f64> = leaves
            .iter()
            .map(|s| (s.radius - params.coverage_margin + q.signed_distance(s.center)).max(0.0))
            .collect();
        let mean_err = err.iter().sum::<f64>() / err.len().max(1) as f64;
        let owner = owner_of_samples(&nodes, pos.len());
        let near = PointGrid::new(&pos, 4.0 * (surface_area(m) / pos.len() as f64).sqrt());
        let nv = m.vertices.len();
        let factor: Vec<f64> = m
            .triangles
            .par_iter()
            .map(|t| {
                if t.iter().any(|&k| k as usize >= nv) {
                    return 1.0;
                }
                let [a, b, c] = t.map(|k| m.vertices[k as usize]);
                let centre = [0, 1, 2].map(|k| (a[k] + b[k] + c[k]) / 3.0);
                let e1 = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
                let e2 = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
                let n = [
                    e1[1] * e2[2] - e1[2] * e2[1],
                    e1[2] * e2[0] - e1[0] * e2[2],
                    e1[0] * e2[1] - e1[1] * e2[0],
                ];
                let k = near.nearest_facing(&pos, &nrm, centre, n);
                (err[owner[k as usize]] + FEEDBACK_FLOOR) / (mean_err + FEEDBACK_FLOOR)
            })
            .collect();
        for (d, f) in density.iter_mut().zip(factor) {
            *d *= f;
        }
    };
    let done = AtomicUsize::new(0);
    let fit_all = |nodes: &[(usize, Vec<u32>)], extra: &[Vec<[f64; 3]>], start: &[Sphere]| {
        nodes
            .par_iter()
            .enumerate()
            .map(|(i, (_, idx))| {
                let mut pts: Vec<[f64; 3]> = idx.iter().map(|&k| pos[k as usize]).collect();
                pts.extend_from_slice(&extra[i]);
                let normal = mean_normal(&nrm, idx);
                done.fetch_add(1, Ordering::Relaxed);
                fit_leaf(
                    &q,
                    &pts,
                    normal,
                    params.size_weight,
                    params.coverage_margin,
                    Some(start[i]),
                    0,
                )
            })
            .collect::<Vec<Sphere>>()
    };
    let mut extra: Vec<Vec<[f64; 3]>> = vec![Vec::new(); nodes.len()];
    progress(0.7);

    // 4. Coverage repair against a denser sample set.
    let check: Vec<([f64; 3], [f64; 3])> =
        sample_surface(m, n_check, params.seed.wrapping_add(0x9e37_79b9_7f4a_7c15));
    let check_pts: Vec<[f64; 3]> = check.iter().map(|s| s.0).collect();
    let owner = owner_of_samples(&nodes, pos.len());
    let leaf_normals: Vec<[f64; 3]> = nodes
        .iter()
        .map(|(_, idx)| mean_normal(&nrm, idx))
        .collect();
    let near = PointGrid::new(&pos, 4.0 * (surface_area(m) / pos.len() as f64).sqrt());
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
                // The nearby leaf facing the same way that needs the least growth, else the
                // patch of the nearest same-facing training sample.
                let near_leaf = grid
                    .candidates(p)
                    .iter()
                    .map(|&j| j as usize)
                    .filter(|&j| dot(leaf_normals[j], n) > 0.3)
                    .map(|j| (dist(leaves[j].center, p) - leaves[j].radius, j))
                    .min_by(|a, b| a.0.total_cmp(&b.0));
                match near_leaf {
                    Some((_, j)) => (j, p),
                    None => (owner[near.nearest_facing(&pos, &nrm, p, n) as usize], p),
                }
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
        let refit = fit_all(&sub_nodes, &sub_extra, &sub_start);
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
    fill_parents(tree, Some((&q, params.size_weight)));
    Ok(holes)
}

/// Samples, balanced top-down partition and first leaf fits for a per-triangle sampling
/// `density`: `(positions, normals, leaf (slot, sample indices), leaf spheres)`.
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
fn patches_and_fits(
    m: &TriMesh,
    q: &MeshQuery,
    params: &BuildParams,
    b: usize,
    depth: u32,
    n_train: usize,
    density: &[f64],
    polish_evals: usize,
    progress: &(dyn Fn(f64) + Sync),
) -> (
    Vec<[f64; 3]>,
    Vec<[f64; 3]>,
    Vec<(usize, Vec<u32>)>,
    Vec<Sphere>,
) {
    let train = sample_surface_weighted(m, n_train, params.seed, &|t| density[t]);
    let pos: Vec<[f64; 3]> = train.iter().map(|s| s.0).collect();
    let nrm: Vec<[f64; 3]> = train.iter().map(|s| s.1).collect();
    progress(0.05);
    let mut nodes: Vec<(usize, Vec<u32>)> = vec![(0, (0..pos.len() as u32).collect())];
    for level in 1..=depth {
        nodes = nodes
            .par_iter()
            .flat_map_iter(|(slot, idx)| {
                let w = params.normal_weight * rms_radius(&pos, idx);
                let groups = partition::split(&pos, &nrm, idx, b, w, params.lloyd_iters);
                let slot = *slot;
                groups
                    .into_iter()
                    .enumerate()
                    .map(move |(k, g)| (slot * b + 1 + k, g))
            })
            .collect();
        progress(0.05 + 0.25 * level as f64 / depth.max(1) as f64);
    }
    let done = AtomicUsize::new(0);
    let total = nodes.len().max(1);
    let leaves: Vec<Sphere> = nodes
        .par_iter()
        .map(|(_, idx)| {
            let pts: Vec<[f64; 3]> = idx.iter().map(|&k| pos[k as usize]).collect();
            let normal = mean_normal(&nrm, idx);
            let s = fit_leaf(
                q,
                &pts,
                normal,
                params.size_weight,
                params.coverage_margin,
                None,
                polish_evals,
            );
            let d = done.fetch_add(1, Ordering::Relaxed) + 1;
            if d.is_multiple_of(64) {
                progress(0.3 + 0.7 * (d as f64 / total as f64).min(1.0));
            }
            s
        })
        .collect();
    (pos, nrm, nodes, leaves)
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
    polish_evals: usize,
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
    let (x0, step, evals) = match start {
        // A refit after coverage repair: the patch grew a little, start where it was.
        Some(s) => (s.center, 0.25 * a, 60),
        // A first fit: the best depth along the inward normal, then a 3-D polish.
        None => {
            let mut x0 = centroid;
            let mut f0 = f(centroid);
            for t in [0.5, 1.0, 2.0, 4.0, 8.0] {
                let x = inward(centroid, normal, t * a);
                let v = f(x);
                if v < f0 {
                    f0 = v;
                    x0 = x;
                }
            }
            (x0, 0.5 * a, polish_evals)
        }
    };
    let best = nelder_mead(&f, x0, step, evals, 1e-2);
    Sphere::new(best, cover(best) + margin.max(0.0))
}

/// Per triangle, the radius of the largest ball inside the mesh that touches the triangle's
/// centroid (shrinking-ball iterations on the closest point; toolkit units). `progress` gets
/// the completed fraction.
fn triangle_thickness(m: &TriMesh, q: &MeshQuery, progress: &(dyn Fn(f64) + Sync)) -> Vec<f64> {
    let nv = m.vertices.len();
    let done = AtomicUsize::new(0);
    let total = m.triangles.len().max(1);
    let budget = (THICKNESS_TESTS / total).clamp(MIN_QUERY_BUDGET, QUERY_BUDGET);
    m.triangles
        .par_iter()
        .map(|t| {
            let d = done.fetch_add(1, Ordering::Relaxed) + 1;
            if d.is_multiple_of(4096) {
                progress(d as f64 / total as f64);
            }
            if t.iter().any(|&k| k as usize >= nv) {
                return THICK_MAX;
            }
            let [a, b, c] = t.map(|k| m.vertices[k as usize]);
            let cr = cross(sub(b, a), sub(c, a));
            let l = dist(cr, [0.0; 3]);
            if l <= 0.0 || !l.is_finite() {
                return THICK_MAX;
            }
            let n = cr.map(|x| x / l);
            let p = [0, 1, 2].map(|k| (a[k] + b[k] + c[k]) / 3.0);
            shrinking_ball(q, p, n, 4.0 * THICK_MAX, budget)
        })
        .collect()
}

/// Radius of the largest ball inside the mesh tangent at surface point `p` (outward normal
/// `n`), at most `r0`: shrink while the closest surface point to the centre is nearer than
/// the radius.
///
/// Each closest-point query tests at most `budget` triangles. A centre nearly
/// equidistant to many triangles (the middle of a finely tessellated sphere or cylinder) would
/// otherwise cost a scan of the whole mesh per triangle, which made this step quadratic. When
/// the budget runs out on a ball larger than [`THICK_MAX`] the ball restarts at `THICK_MAX`
/// (larger thicknesses are clamped to it anyway, and queries that deep stay local); below it,
/// the nearest triangle found so far still shrinks the ball correctly (any surface point
/// inside the ball bounds the largest empty ball from above; a query cut short may miss a
/// closer one and overestimate the thickness, which only thins the sampling there a little).
/// Every query of the bundled meshes completes within the budget, so their trees are the
/// same as with exact queries.
fn shrinking_ball(q: &MeshQuery, p: [f64; 3], n: [f64; 3], r0: f64, budget: usize) -> f64 {
    let mut r = r0;
    for _ in 0..32 {
        let c = inward(p, n, r);
        let (found, complete) = q.closest_budgeted(c, f64::INFINITY, budget);
        let Some(cp) = found else {
            return r;
        };
        if !complete && r > THICK_MAX {
            r = THICK_MAX;
            continue;
        }
        if cp.distance >= r * (1.0 - 1e-6) {
            return r;
        }
        let d = [p[0] - cp.point[0], p[1] - cp.point[1], p[2] - cp.point[2]];
        let along = d[0] * n[0] + d[1] * n[1] + d[2] * n[2];
        let d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        if along <= 1e-12 || d2 <= 1e-18 {
            return r.min(cp.distance.max(1e-9));
        }
        let next = d2 / (2.0 * along);
        if next >= r {
            return r;
        }
        r = next;
    }
    r
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

fn surface_area(m: &TriMesh) -> f64 {
    let nv = m.vertices.len();
    m.triangles
        .iter()
        .filter(|t| t.iter().all(|&k| (k as usize) < nv))
        .map(|t| {
            let [a, b, c] = t.map(|k| m.vertices[k as usize]);
            let cr = cross(sub(b, a), sub(c, a));
            0.5 * dist(cr, [0.0; 3])
        })
        .sum()
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
        let h = h.max(1e-9);
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Every thickness query of the bundled bunny completes within the budget, so its tree
    /// is the one exact queries give.
    #[test]
    fn the_bunny_thickness_queries_fit_the_budget() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/bunny.obj");
        let mesh = mesh::load_mesh(&path).unwrap().mesh;
        let (centre, scale) = crate::eval::toolkit_frame(&mesh).unwrap();
        let m = mesh.scaled_about(centre, scale);
        let q = MeshQuery::new(&m);
        let mut queries = 0;
        for t in &m.triangles {
            let [a, b, c] = t.map(|k| m.vertices[k as usize]);
            let cr = cross(sub(b, a), sub(c, a));
            let n = cr.map(|x| x / dist(cr, [0.0; 3]));
            let p = [0, 1, 2].map(|k| (a[k] + b[k] + c[k]) / 3.0);
            // The exact shrinking ball, checking each query against the budget.
            let mut r = 4.0 * THICK_MAX;
            for _ in 0..32 {
                let centre = inward(p, n, r);
                let (_, complete) = q.closest_budgeted(centre, f64::INFINITY, QUERY_BUDGET);
                assert!(complete, "triangle {t:?}, ball radius {r}");
                queries += 1;
                let cp = q.closest_point(centre).unwrap();
                if cp.distance >= r * (1.0 - 1e-6) {
                    break;
                }
                let d = [p[0] - cp.point[0], p[1] - cp.point[1], p[2] - cp.point[2]];
                let along = dot(d, n);
                let d2 = dot(d, d);
                if along <= 1e-12 || d2 <= 1e-18 || d2 / (2.0 * along) >= r {
                    break;
                }
                r = d2 / (2.0 * along);
            }
        }
        assert!(queries > m.triangles.len());
    }
}
