//! Seeded instance generators and the Clarabel oracle, shared by the tests, the bench and the
//! table example (included with `#[path]`).
#![allow(dead_code)]

use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettingsBuilder, DefaultSolver, IPSolver, SolverStatus, SupportedConeT,
};
use qp::Problem;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The haptic weights (docs/DESIGN.md §Units and frames): kt = 1 N/mm, kr = 1000 N·mm/rad.
pub const G_HAPTIC: [f64; 6] = [1.0, 1.0, 1.0, 1000.0, 1000.0, 1000.0];

/// One owned instance plus a point feasible for it (`dq0`, the "last graphic pose").
#[derive(Debug, Clone)]
pub struct Instance {
    pub g: [f64; 6],
    pub j: Vec<[f64; 6]>,
    pub d: Vec<f64>,
    /// A feasible point (`J dq0 >= d`), e.g. `q_g_prev - q_h`.
    pub dq0: [f64; 6],
}

impl Instance {
    pub fn problem(&self) -> Problem<'_> {
        Problem::new(self.g, &self.j, &self.d).expect("generated instances are well formed")
    }
}

pub fn rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed)
}

fn gauss(r: &mut impl Rng) -> f64 {
    // Box–Muller; good enough for test data.
    let u1: f64 = r.random::<f64>().max(1e-300);
    let u2: f64 = r.random();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

fn unit3(r: &mut impl Rng) -> [f64; 3] {
    loop {
        let v = [gauss(r), gauss(r), gauss(r)];
        let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        if n > 1e-6 {
            return [v[0] / n, v[1] / n, v[2] / n];
        }
    }
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn dot(a: &[f64; 6], b: &[f64; 6]) -> f64 {
    (0..6).map(|i| a[i] * b[i]).sum()
}

/// Gaussian rows, random positive weights (log-uniform over 1e-2..1e3), right-hand sides
/// set so that a random point is feasible with random slacks (a quarter of them zero:
/// degenerate vertices).
pub fn random(n: usize, r: &mut impl Rng) -> Instance {
    let g: [f64; 6] = std::array::from_fn(|_| 10f64.powf(r.random_range(-2.0..3.0)));
    let xf: [f64; 6] = std::array::from_fn(|_| 2.0 * gauss(r));
    let mut j = Vec::with_capacity(n);
    let mut d = Vec::with_capacity(n);
    for _ in 0..n {
        let row: [f64; 6] = std::array::from_fn(|_| gauss(r));
        let slack = if r.random_bool(0.25) {
            0.0
        } else {
            r.random_range(0.0..3.0)
        };
        d.push(dot(&row, &xf) - slack);
        j.push(row);
    }
    Instance { g, j, d, dq0: xf }
}

/// Contact-like rows: for each sphere pair a unit normal `n` (object to tool) at a lever arm
/// `c` (tool sphere centre relative to the tool origin, mm), row `[n, c × n]` (the gradient of
/// the signed distance), gap `>= 0` at the last graphic pose, and a device displacement
/// `delta` (mm, rad) into the object: `d = -gap - J delta`, so most `d <= 0` and the
/// penetrated pairs have `d > 0`. `dq0 = -delta` is feasible.
///
/// `clusters` patches of nearly-identical contacts: normals jittered by `spread` (rad) and
/// centres by `spread * 10` mm; `spread = 1e-9` gives nearly redundant rows.
pub fn haptic(n: usize, clusters: usize, spread: f64, r: &mut impl Rng) -> Instance {
    let clusters = clusters.max(1);
    let centres: Vec<([f64; 3], [f64; 3])> = (0..clusters)
        .map(|_| {
            let nrm = unit3(r);
            let c = unit3(r);
            let rad = r.random_range(5.0..60.0);
            (nrm, [c[0] * rad, c[1] * rad, c[2] * rad])
        })
        .collect();
    // Push the device mostly against the normals (penetration of about 0.1-2 mm).
    let mean_n = {
        let mut m = [0.0; 3];
        for (nv, _) in &centres {
            for e in 0..3 {
                m[e] += nv[e];
            }
        }
        m
    };
    let depth = r.random_range(0.1..2.0);
    let mn = (mean_n[0] * mean_n[0] + mean_n[1] * mean_n[1] + mean_n[2] * mean_n[2])
        .sqrt()
        .max(1e-9);
    let delta = [
        -depth * mean_n[0] / mn + 0.3 * gauss(r),
        -depth * mean_n[1] / mn + 0.3 * gauss(r),
        -depth * mean_n[2] / mn + 0.3 * gauss(r),
        0.005 * gauss(r),
        0.005 * gauss(r),
        0.005 * gauss(r),
    ];
    let mut j = Vec::with_capacity(n);
    let mut d = Vec::with_capacity(n);
    for k in 0..n {
        let (n0, c0) = centres[k % clusters];
        let nv = {
            let e = unit3(r);
            let v = [
                n0[0] + spread * e[0],
                n0[1] + spread * e[1],
                n0[2] + spread * e[2],
            ];
            let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            [v[0] / l, v[1] / l, v[2] / l]
        };
        let e = unit3(r);
        let s = (10.0 * spread).min(5.0);
        let c = [c0[0] + s * e[0], c0[1] + s * e[1], c0[2] + s * e[2]];
        let m = cross(c, nv);
        let row = [nv[0], nv[1], nv[2], m[0], m[1], m[2]];
        let gap = if r.random_bool(0.3) {
            0.0
        } else {
            r.random_range(0.0..1.5)
        };
        d.push(-gap - dot(&row, &delta));
        j.push(row);
    }
    Instance {
        g: G_HAPTIC,
        j,
        d,
        dq0: delta.map(|v| -v),
    }
}

/// A slowly moving sequence of haptic instances with the same contact set (same row order):
/// the device drifts by ~0.01 mm per frame and the normals turn by ~1e-4 rad per frame.
pub fn haptic_sequence(n: usize, frames: usize, seed: u64) -> Vec<Instance> {
    let mut r = rng(seed);
    let base = haptic(n, 6, 0.05, &mut r);
    let delta0: [f64; 6] = base.dq0.map(|v| -v);
    let gaps: Vec<f64> = base
        .j
        .iter()
        .zip(&base.d)
        .map(|(row, &dk)| -dk - dot(row, &delta0))
        .collect();
    let drift: [f64; 6] = std::array::from_fn(|i| if i < 3 { 0.01 } else { 1e-5 } * gauss(&mut r));
    let turn: Vec<[f64; 6]> = (0..n)
        .map(|_| std::array::from_fn(|_| 1e-4 * gauss(&mut r)))
        .collect();
    (0..frames)
        .map(|f| {
            let t = f as f64;
            let delta: [f64; 6] = std::array::from_fn(|i| delta0[i] + t * drift[i]);
            let j: Vec<[f64; 6]> = base
                .j
                .iter()
                .zip(&turn)
                .map(|(row, w)| std::array::from_fn(|i| row[i] + t * w[i]))
                .collect();
            let d = j
                .iter()
                .zip(&gaps)
                .map(|(row, &gap)| -gap - dot(row, &delta))
                .collect();
            Instance {
                g: G_HAPTIC,
                j,
                d,
                dq0: delta.map(|v| -v),
            }
        })
        .collect()
}

/// An infeasible instance: a random feasible one plus two opposing rows `a dq >= 1`,
/// `-a dq >= 1` at random positions.
pub fn infeasible(n: usize, r: &mut impl Rng) -> Instance {
    let mut inst = random(n.max(2) - 2, r);
    let a: [f64; 6] = std::array::from_fn(|_| gauss(r));
    let i = r.random_range(0..=inst.j.len());
    inst.j.insert(i, a);
    inst.d.insert(i, 1.0);
    let k = r.random_range(0..=inst.j.len());
    inst.j.insert(k, a.map(|v| -v));
    inst.d.insert(k, 1.0);
    inst
}

/// Clarabel's answer `(dq, objective, tight)`: with tolerances 1e-12 (`tight = true`) or, if
/// that does not reach Solved (nearly redundant rows make the interior point method stall),
/// with its default tolerances (1e-8). `Err(status)` if both fail.
pub fn clarabel(inst: &Instance) -> Result<([f64; 6], f64, bool), SolverStatus> {
    match clarabel_with(inst, true) {
        Ok((x, f, _)) => Ok((x, f, true)),
        Err(_) => clarabel_with(inst, false).map(|(x, f, _)| (x, f, false)),
    }
}

/// Clarabel with tight tolerances (`tight`, the oracle) or its defaults (the bench):
/// `(dq, objective, iterations)` if it reports Solved.
pub fn clarabel_with(inst: &Instance, tight: bool) -> Result<([f64; 6], f64, u32), SolverStatus> {
    let n = inst.j.len();
    // P = G (upper triangle, diagonal), q = 0; J x >= d  <=>  -J x + s = -d, s >= 0.
    let p = CscMatrix::new(6, 6, (0..=6).collect(), (0..6).collect(), inst.g.to_vec());
    let mut colptr = Vec::with_capacity(7);
    let mut rowval = Vec::with_capacity(6 * n);
    let mut nzval = Vec::with_capacity(6 * n);
    colptr.push(0);
    for c in 0..6 {
        for (k, row) in inst.j.iter().enumerate() {
            if row[c] != 0.0 {
                rowval.push(k);
                nzval.push(-row[c]);
            }
        }
        colptr.push(rowval.len());
    }
    let a = CscMatrix::new(n, 6, colptr, rowval, nzval);
    let b: Vec<f64> = inst.d.iter().map(|v| -v).collect();
    let cones = [SupportedConeT::NonnegativeConeT(n)];
    let mut sb = DefaultSettingsBuilder::default();
    sb.verbose(false);
    if tight {
        sb.tol_gap_abs(1e-12)
            .tol_gap_rel(1e-12)
            .tol_feas(1e-12)
            .max_iter(400);
    }
    let settings = sb.build().expect("valid settings");
    let mut s = DefaultSolver::new(&p, &[0.0; 6], &a, &b, &cones, settings)
        .expect("valid problem dimensions");
    s.solve();
    match s.solution.status {
        SolverStatus::Solved => {
            let x: [f64; 6] = std::array::from_fn(|i| s.solution.x[i]);
            let obj = 0.5 * (0..6).map(|i| inst.g[i] * x[i] * x[i]).sum::<f64>();
            Ok((x, obj, s.solution.iterations))
        }
        st => Err(st),
    }
}

/// The sizes of the benchmark table.
pub const BENCH_SIZES: [usize; 5] = [10, 50, 200, 1000, 2000];

/// The seeded benchmark set for size `n`, used by the criterion bench and the table example
/// alike: `count` haptic-like instances with `4 + n/50` contact patches (normals spread by
/// 0.1 rad within a patch, so many rows are nearly redundant).
pub fn bench_set(n: usize, count: usize) -> Vec<Instance> {
    let mut r = rng(0xB3AC_0000 + n as u64);
    (0..count)
        .map(|_| haptic(n, 4 + n / 50, 0.1, &mut r))
        .collect()
}

/// The slowly moving sequence of the warm-start benchmark for size `n`: 16 frames (the
/// same memory footprint as `bench_set`), played forwards then backwards so that every step
/// is a small one.
pub fn bench_sequence(n: usize) -> Vec<Instance> {
    haptic_sequence(n, 16, 0x5E0 + n as u64)
}

/// Index of frame `i` in a ping-pong walk over `len` frames.
pub fn ping_pong(i: usize, len: usize) -> usize {
    if len <= 1 {
        return 0;
    }
    let period = 2 * (len - 1);
    let k = i % period;
    if k < len {
        k
    } else {
        period - k
    }
}
