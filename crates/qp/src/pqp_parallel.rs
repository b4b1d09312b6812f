//! `pqp-parallel`: the paper's PQP ([`crate::pqp`]) with its multiplicative update computed
//! the way the method was chosen for — many multipliers per instruction, and over threads.
//!
//! **Same iteration, other arithmetic.** The update, its start, its stop and its answer are
//! those of [`crate::PqpWorkspace`] (same [`PqpParams`]); only the products `Q^+ y` and
//! `Q^- y` are computed differently, so the iterates equal the serial ones up to rounding
//! (tested to `1e-12` relative, `crates/qp/tests/pqp_parallel.rs`):
//!
//! - `Q = N N^T` has rank 6 (`N` the scaled rows), so `Q y = N (N^T y)` costs O(12 N);
//! - `Q^+ y` and `Q^- y` are `(|Q| y ± Q y) / 2 + r .* y`, so the one O(N²) product left is
//!   `|Q| y`, with `|Q|` symmetric: only its strict upper triangle is read, each entry used
//!   twice (`acc_a += |q_ab| y_b` and `col_b += |q_ab| y_a`), which halves both the work per
//!   iteration and the `O(6 N²)` work of forming it;
//! - the triangle is cut in **panels** of 4 rows × 8 columns. Up to
//!   [`ParallelPqpWorkspace::max_stored_rows`] rows (default [`MAX_STORED_ROWS`], a 16 MB
//!   triangle) the entries are formed once per solve and stored, laid out `[chunk][row][lane]`
//!   and padded with zeros (below the diagonal, past the last row), so the inner loop is
//!   `chunks_exact` over 32 numbers with no branch and no remainder. Above it the stored
//!   triangle no longer fits the caches and streaming it from memory bounds the product, so
//!   every iteration **recomputes** the entries from the scaled rows packed `[chunk][component]
//!   [lane]` (`q_ab` a 6-term multiply-add, then `|q_ab|`; the working set is the rows, `y` and
//!   the column sums, `8 N` numbers): twice the work of the stored product, no memory
//!   traffic, no `N²` memory. Both paths form each entry by the same multiply-adds in the same
//!   order, so they give the same iterates bit for bit (tested);
//! - the compiler turns the loops into fused multiply-adds of 8 lanes (AVX-512) or 4 (AVX2),
//!   chosen at run time on x86-64 (the same code compiled for the baseline elsewhere); both
//!   give the same numbers bit for bit (tested);
//! - the panels are split into blocks of equal area of the triangle, 4 per thread, which the
//!   calling thread and persistent workers claim until none is left; each block keeps its
//!   own panels, row sums and column sums, and the caller adds them in block order after each
//!   iteration (O(N) per block), so the sums do not depend on which thread ran which block.
//!
//! **Threads.** Workers are spawned when the workspace is created with
//! [`ParallelPqpWorkspace::with_threads`] (or on the first reserve or solve of one made with
//! [`ParallelPqpWorkspace::new`]), never in a solve; between iterations they spin for a few
//! tens of microseconds, then park until the next solve; they exit when the workspace is
//! dropped. Below [`ParallelPqpWorkspace::min_parallel_rows`] rows the caller does the whole
//! product alone (waking a worker costs more than it saves).
//!
//! Memory: `N²/2` numbers of panels up to [`ParallelPqpWorkspace::max_stored_rows`] rows (a
//! serial [`crate::PqpWorkspace`] holds `N²`), none above; plus O(N) per block.

use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, RwLock};
use std::thread::JoinHandle;

use crate::basis::{scaled, DIM};
use crate::dual::inv_sqrt;
use crate::pqp::PqpParams;
use crate::problem::{dot6, Problem};
use crate::solution::{Solution, Status};

/// Rows per panel.
const R: usize = 4;
/// Columns (multipliers) per chunk of a panel: two 4-wide vectors.
pub const LANES: usize = 8;
/// Spins of a worker waiting for the next iteration before it parks (a few tens of µs).
const SPINS: u32 = 20_000;
/// Blocks of the triangle per thread in a parallel product: each thread claims blocks until
/// none is left, so a thread the system deschedules delays the others by one block at most.
const BLOCKS_PER_THREAD: usize = 4;
/// Default of [`ParallelPqpWorkspace::max_stored_rows`], in rows: the stored triangle is then
/// 16 MB (half the L3 cache of the machine measured); from 2 500 rows recomputing the entries
/// was faster than streaming them on it (`cargo run --release -p qp --example
/// pqp_iteration`).
pub const MAX_STORED_ROWS: usize = 2000;

/// What the parts compute when the caller posts a job.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    /// Fill the part's panels with `|q_ab|` and sum `max(-q_ab, 0)` by row and column.
    Form,
    /// Row and column sums of `|q_ab| y`.
    Product,
}

/// Read by every part during a job; written by the caller between jobs.
#[derive(Debug)]
struct Input {
    /// Rows `N`.
    n: usize,
    /// `N` rounded up to a whole number of chunks (and of panels).
    np: usize,
    /// The scaled rows, structure of arrays: `cols[i][k]` is component `i` of row `k`;
    /// zero past `n`.
    cols: [Vec<f64>; DIM],
    /// The same rows packed by chunk, `[chunk][component][lane]` (`DIM * LANES` numbers a
    /// chunk), read when the entries are recomputed; zero past `n`.
    packed: Vec<f64>,
    /// The multipliers, zero past `n`.
    y: Vec<f64>,
    /// What to compute.
    phase: Phase,
    /// The instruction set of the kernels.
    isa: Isa,
    /// The entries of `|Q|` are kept in the parts' panels (else recomputed every product).
    stored: bool,
}

/// Instruction set the kernels are compiled for (chosen at run time).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Isa {
    /// The build's baseline (SSE2 on x86-64).
    Base,
    /// AVX2 + FMA: 4 lanes an instruction.
    Avx2,
    /// AVX-512 (F, VL) + FMA: 8 lanes an instruction, 32 registers.
    Avx512,
}

/// One thread's share: the panels of rows `[blo, bhi) * R` and its sums.
#[derive(Debug, Default)]
struct Part {
    /// First and one-past-last panel (block of `R` rows).
    blo: usize,
    bhi: usize,
    /// Its panels, one after another.
    panels: Vec<f64>,
    /// Row sums of its rows (indices `blo * R .. bhi * R`, the rest unused), length `np`.
    acc: Vec<f64>,
    /// Column sums, length `np`.
    col: Vec<f64>,
}

/// A part and who computes it: the job's number is claimed by the first of its worker and
/// the caller to swap it in (the caller takes the part of a worker that has not started, so a
/// descheduled worker delays nothing), and marked finished when its sums are written.
#[derive(Debug, Default)]
struct Slot {
    part: Mutex<Part>,
    claimed: AtomicU64,
    finished: AtomicU64,
}

impl Slot {
    /// True when this call claims job `e` of the part (jobs only move forward: a worker
    /// that wakes late for an old job claims nothing).
    fn claim(&self, e: u64) -> bool {
        self.claimed.fetch_max(e, Ordering::AcqRel) < e
    }
}

#[derive(Debug)]
struct Shared {
    input: RwLock<Input>,
    parts: Vec<Slot>,
    /// Blocks of the posted job (the first `blocks` of `parts`).
    blocks: AtomicUsize,
    /// Threads in all (the caller's included).
    threads: usize,
    /// Jobs posted so far.
    epoch: AtomicU64,
    stop: AtomicBool,
    /// Workers that have started (their thread's own set-up, which allocates, is done).
    started: AtomicU64,
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    // A part never panics while holding its lock; a poisoned lock still holds plain numbers.
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// Workspace of the parallel PQP solver: the same method and parameters as
/// [`crate::PqpWorkspace`], the update vectorized and split over persistent threads (see the
/// module docs). Grows to the largest `N` solved and never shrinks; once warmed up to a
/// given `N` a solve allocates nothing, in any thread.
pub struct ParallelPqpWorkspace {
    /// Parameters (stop rule, start, iteration cap) used by [`ParallelPqpWorkspace::solve`].
    pub params: PqpParams,
    /// Below this many rows the calling thread computes the whole product alone.
    pub min_parallel_rows: usize,
    /// Up to this many rows the entries of `|Q|` are formed once per solve and stored
    /// (`N²/2` numbers, 8 bytes each); above it they are recomputed from the scaled rows in
    /// every iteration (no `N²` memory: the stored triangle no longer fits the caches there
    /// and streaming it from memory costs more than the 6 multiply-adds of an entry). Both
    /// give the same numbers, bit for bit.
    pub max_stored_rows: usize,
    /// Use the vector code (AVX-512 or AVX2, with FMA) when the CPU has it (default `true`;
    /// `false` runs the same code compiled for the baseline instruction set).
    pub simd: bool,
    /// Allow the AVX-512 code when the CPU has it (default `true`; `false` stops at AVX2).
    /// Both compute the same numbers, bit for bit (the same multiply-adds in the same order,
    /// 8 lanes an instruction instead of 4).
    pub avx512: bool,
    threads: usize,
    shared: Arc<Shared>,
    workers: Vec<JoinHandle<()>>,
    /// Jobs posted (mirrors `shared.epoch`).
    posted: u64,
    y: Vec<f64>,
    norms: Vec<f64>,
    diag: Vec<f64>,
    r: Vec<f64>,
    absy: Vec<f64>,
    qp: Vec<f64>,
    qm: Vec<f64>,
    /// Panels assigned to each part at the current `N`, and whether the workers take part.
    bounds: Vec<(usize, usize)>,
}

impl std::fmt::Debug for ParallelPqpWorkspace {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ParallelPqpWorkspace")
            .field("params", &self.params)
            .field("threads", &self.threads)
            .field("workers_running", &self.workers.len())
            .field("min_parallel_rows", &self.min_parallel_rows)
            .field("max_stored_rows", &self.max_stored_rows)
            .field("simd", &self.simd)
            .field("avx512", &self.avx512)
            .finish_non_exhaustive()
    }
}

impl Clone for ParallelPqpWorkspace {
    /// A new workspace with the same settings and thread count (its own workers, empty
    /// buffers).
    fn clone(&self) -> Self {
        let mut w = Self::inert(self.params, self.threads);
        w.min_parallel_rows = self.min_parallel_rows;
        w.max_stored_rows = self.max_stored_rows;
        w.simd = self.simd;
        w.avx512 = self.avx512;
        if !self.workers.is_empty() {
            w.spawn();
        }
        w
    }
}

impl Default for ParallelPqpWorkspace {
    fn default() -> Self {
        Self::new()
    }
}

impl Drop for ParallelPqpWorkspace {
    fn drop(&mut self) {
        self.shared.stop.store(true, Ordering::SeqCst);
        self.shared.epoch.fetch_add(1, Ordering::SeqCst);
        for w in &self.workers {
            w.thread().unpark();
        }
        for w in self.workers.drain(..) {
            let _ = w.join();
        }
    }
}

/// Threads the machine offers (at least 1).
pub fn available_threads() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

impl ParallelPqpWorkspace {
    /// The paper's parameters, one thread per core ([`available_threads`]); the workers are
    /// spawned by the first [`ParallelPqpWorkspace::reserve`] or solve. Use
    /// [`ParallelPqpWorkspace::with_threads`] to spawn them now.
    pub fn new() -> Self {
        Self::inert(PqpParams::paper(), available_threads())
    }

    /// `params`, `threads` threads in all (the caller's and `threads - 1` workers, spawned
    /// here; `0` counts as 1).
    pub fn with_threads(params: PqpParams, threads: usize) -> Self {
        let mut w = Self::inert(params, threads.max(1));
        w.spawn();
        w
    }

    fn inert(params: PqpParams, threads: usize) -> Self {
        let threads = threads.max(1);
        let shared = Arc::new(Shared {
            input: RwLock::new(Input {
                n: 0,
                np: 0,
                cols: Default::default(),
                packed: Vec::new(),
                y: Vec::new(),
                phase: Phase::Product,
                isa: Isa::Base,
                stored: true,
            }),
            parts: (0..threads * BLOCKS_PER_THREAD)
                .map(|_| Slot::default())
                .collect(),
            blocks: AtomicUsize::new(1),
            threads,
            epoch: AtomicU64::new(0),
            stop: AtomicBool::new(false),
            started: AtomicU64::new(0),
        });
        Self {
            params,
            min_parallel_rows: 384,
            max_stored_rows: MAX_STORED_ROWS,
            simd: true,
            avx512: true,
            threads,
            shared,
            workers: Vec::new(),
            posted: 0,
            y: Vec::new(),
            norms: Vec::new(),
            diag: Vec::new(),
            r: Vec::new(),
            absy: Vec::new(),
            qp: Vec::new(),
            qm: Vec::new(),
            bounds: vec![(0, 0); threads * BLOCKS_PER_THREAD],
        }
    }

    fn spawn(&mut self) {
        if !self.workers.is_empty() {
            return;
        }
        for t in 1..self.threads {
            let shared = Arc::clone(&self.shared);
            let seen = self.posted;
            let handle = std::thread::Builder::new()
                .name(format!("pqp-{t}"))
                .spawn(move || worker(shared, t, seen));
            match handle {
                Ok(h) => self.workers.push(h),
                // No thread: run with those that started (the caller alone at worst).
                Err(_) => break,
            }
        }
        // Wait until every worker runs, so that no thread set-up happens during a solve.
        while self.shared.started.load(Ordering::Acquire) < self.workers.len() as u64 {
            std::thread::yield_now();
        }
    }

    /// Threads that share a large solve (the caller's included).
    pub fn threads(&self) -> usize {
        1 + self.workers.len().min(self.threads - 1)
    }

    /// True when this build and CPU run vector code (AVX-512 or AVX2, with FMA) and
    /// [`Self::simd`] allows it.
    pub fn simd_active(&self) -> bool {
        self.isa() != Isa::Base
    }

    /// The widest vector code this CPU runs: `"avx512"`, `"avx2"` or `"base"` (the build's
    /// baseline, also when [`Self::simd`] is off).
    pub fn simd_name(&self) -> &'static str {
        match self.isa() {
            Isa::Avx512 => "avx512",
            Isa::Avx2 => "avx2",
            Isa::Base => "base",
        }
    }

    fn isa(&self) -> Isa {
        match (self.simd, detect_isa()) {
            (false, _) => Isa::Base,
            (true, Isa::Avx512) if !self.avx512 => Isa::Avx2,
            (true, isa) => isa,
        }
    }

    /// The multipliers `y` (one per row, all `> 0`) of the last solve.
    pub fn multipliers(&self) -> &[f64] {
        &self.y
    }

    /// Reserves room for problems of up to `n` rows (about `m²/2` numbers of panels over all
    /// threads, `m = min(n, max_stored_rows)`: set [`Self::max_stored_rows`] first) and spawns
    /// the workers if they are not running.
    pub fn reserve(&mut self, n: usize) {
        self.spawn();
        fn grow<T>(v: &mut Vec<T>, n: usize) {
            v.reserve(n.saturating_sub(v.len()));
        }
        let np = padded(n);
        for v in [
            &mut self.y,
            &mut self.norms,
            &mut self.diag,
            &mut self.r,
            &mut self.absy,
            &mut self.qp,
            &mut self.qm,
        ] {
            grow(v, np);
        }
        {
            let mut input = self.shared.input.write().unwrap_or_else(|e| e.into_inner());
            for c in &mut input.cols {
                grow(c, np);
            }
            grow(&mut input.packed, np * DIM);
            grow(&mut input.y, np);
        }
        // Each part: its equal-area share at `n` plus two full-width panels of slack (the
        // share of a smaller `N` is never larger), and the caller's part the whole triangle
        // below the parallel threshold; panels only up to the largest stored `N`.
        let np_all = np;
        let np = padded(n.min(self.max_stored_rows));
        let nb = np / R;
        let chunks = np / LANES;
        let total = triangle_chunks(nb, chunks) * R * LANES;
        let slack = 2 * chunks * R * LANES;
        let serial_max = {
            let m = padded(n.min(self.min_parallel_rows));
            triangle_chunks(m / R, m / LANES) * R * LANES
        };
        // The blocks of the largest product: one thread (whose `spawn` settled) alone takes
        // the whole triangle.
        let blocks = if self.threads() > 1 {
            self.threads() * BLOCKS_PER_THREAD
        } else {
            1
        };
        for (t, slot) in self.shared.parts.iter().enumerate() {
            let mut part = lock(&slot.part);
            let mut need = total / blocks + slack;
            if t == 0 {
                need = need.max(serial_max);
            }
            grow(&mut part.panels, need.min(total));
            grow(&mut part.acc, np_all);
            grow(&mut part.col, np_all);
        }
    }

    /// Solves `p` by the multiplicative update, stopping by `params`, exactly as
    /// [`crate::PqpWorkspace::solve`] does (same statuses, same answer up to rounding).
    ///
    /// # Real-time
    /// Allocates only if `p.len()` exceeds every earlier `N` (see
    /// [`ParallelPqpWorkspace::reserve`]), in no thread; spawns nothing once the workers run;
    /// never panics; O(4 N²) to form the panels (or the row sums of `max(-Q, 0)` when the
    /// entries are recomputed), then at most `params.max_iterations` iterations of O(N²)
    /// (O(4 N²) recomputed), both split over the threads.
    pub fn solve(&mut self, p: &Problem<'_>) -> Solution {
        self.spawn();
        let n = p.len();
        let prm = self.params;
        let warm = prm.warm_start && self.y.len() == n;
        if !warm {
            self.y.clear();
            self.y.resize(n, prm.y0);
        } else {
            for v in &mut self.y {
                *v = if v.is_finite() {
                    v.max(prm.warm_floor)
                } else {
                    prm.y0
                };
            }
        }
        if n == 0 {
            return Solution::zero(Status::Solved);
        }
        let (j, d) = (p.j(), p.d());
        let isg = inv_sqrt(p.g());
        let np = padded(n);
        let isa = self.isa();
        let parallel = n >= self.min_parallel_rows && self.threads() > 1;
        let stored = n <= self.max_stored_rows;
        self.assign(np, parallel, stored);

        // The scaled rows (structure of arrays), their norms, the diagonal of Q.
        self.norms.clear();
        self.diag.clear();
        {
            let mut input = self.shared.input.write().unwrap_or_else(|e| e.into_inner());
            input.n = n;
            input.np = np;
            input.isa = isa;
            input.stored = stored;
            input.phase = Phase::Form;
            for c in &mut input.cols {
                c.clear();
                c.resize(np, 0.0);
            }
            input.packed.clear();
            input.packed.resize(np * DIM, 0.0);
            for (k, row) in j.iter().enumerate() {
                let v = scaled(row, &isg);
                let base = (k / LANES) * DIM * LANES + k % LANES;
                for i in 0..DIM {
                    input.cols[i][k] = v[i];
                    input.packed[base + i * LANES] = v[i];
                }
                let qq = dot6(&v, &v);
                self.diag.push(qq);
                self.norms.push(qq.sqrt());
            }
            input.y.clear();
            input.y.resize(np, 0.0);
        }
        // Panels, and r_k = max(Q_kk, sum_j max(-Q_kj, 0)) from the parts' sums.
        self.run(parallel);
        self.gather(n);
        self.r.clear();
        self.r.extend(
            self.diag
                .iter()
                .zip(&self.absy)
                .map(|(&qq, &neg)| qq.max(neg)),
        );
        self.qp.clear();
        self.qp.resize(n, 0.0);
        self.qm.clear();
        self.qm.resize(n, 0.0);
        let length_scale = d
            .iter()
            .zip(&self.norms)
            .map(|(&dk, &nk)| if nk > 0.0 { dk.abs() / nk } else { 0.0 })
            .fold(0.0f64, f64::max);

        let mut iterations = 0u32;
        let mut f_prev = f64::INFINITY;
        let status = loop {
            // |Q| y off the diagonal over the threads; Q y = N (N^T y) here.
            {
                let mut input = self.shared.input.write().unwrap_or_else(|e| e.into_inner());
                input.phase = Phase::Product;
                input.y[..n].copy_from_slice(&self.y);
            }
            self.run(parallel);
            self.gather(n);
            let w = {
                let input = self.shared.input.read().unwrap_or_else(|e| e.into_inner());
                let mut w = [0.0f64; DIM];
                for i in 0..DIM {
                    w[i] = input.cols[i][..n]
                        .iter()
                        .zip(&self.y)
                        .map(|(c, y)| c * y)
                        .sum();
                }
                // Q y, row by row, into qp for now.
                for (k, out) in self.qp.iter_mut().enumerate() {
                    let row: [f64; DIM] = std::array::from_fn(|i| input.cols[i][k]);
                    *out = dot6(&row, &w);
                }
                w
            };
            let _ = w;
            let (mut yqy, mut dy) = (0.0f64, 0.0f64);
            for a in 0..n {
                let qy = self.qp[a];
                let absy = self.absy[a] + self.diag[a] * self.y[a];
                let ry = self.r[a] * self.y[a];
                self.qp[a] = 0.5 * (absy + qy) + ry;
                self.qm[a] = 0.5 * (absy - qy) + ry;
                yqy += self.y[a] * qy;
                dy += d[a] * self.y[a];
            }
            let f = 0.5 * yqy - dy;
            if !f.is_finite() {
                break Status::NumericalError;
            }
            let zn = yqy.max(0.0).sqrt();
            if dy > 0.0 && dy > zn * 1e4 * length_scale {
                // As in the serial solver: no feasible point within 1e4 length scales.
                break Status::Infeasible;
            }
            if let Some(tol) = prm.kkt_tol {
                let mut ok = (yqy - dy).abs() <= tol * yqy.max(0.0);
                if ok {
                    for a in 0..n {
                        let s = self.qp[a] - self.qm[a] - d[a];
                        if -s > tol * zn * self.norms[a] {
                            ok = false;
                            break;
                        }
                    }
                }
                if ok {
                    break Status::Solved;
                }
            } else if f_prev - f < prm.min_decrease {
                break Status::Solved;
            }
            if iterations >= prm.max_iterations {
                break Status::MaxIterations;
            }
            iterations += 1;
            f_prev = f;
            if update(&mut self.y, d, &self.qp, &self.qm) {
                break Status::Infeasible;
            }
        };
        let zsum: [f64; DIM] = {
            let input = self.shared.input.read().unwrap_or_else(|e| e.into_inner());
            std::array::from_fn(|i| {
                input.cols[i][..n]
                    .iter()
                    .zip(&self.y)
                    .map(|(c, y)| c * y)
                    .sum()
            })
        };
        let dq: [f64; 6] = std::array::from_fn(|i| zsum[i] * isg[i]);
        let mut sol = Solution::finish(p, dq, &self.y, status, iterations);
        let within = matches!(
            sol.kkt.max_violation.partial_cmp(&prm.violation_tol),
            Some(std::cmp::Ordering::Less | std::cmp::Ordering::Equal)
        );
        if sol.status == Status::Solved && !within {
            sol.status = Status::Inexact;
        }
        sol
    }

    /// Splits the `np / R` panels between the parts by equal area of the triangle (all to
    /// the caller's part unless `parallel`) and sizes every part's buffers (its panels only
    /// when `stored`).
    fn assign(&mut self, np: usize, parallel: bool, stored: bool) {
        let nb = np / R;
        let chunks = np / LANES;
        let parts = if parallel {
            self.threads() * BLOCKS_PER_THREAD
        } else {
            1
        };
        self.shared.blocks.store(parts, Ordering::Relaxed);
        let total = triangle_chunks(nb, chunks);
        let mut start = 0usize;
        let mut cost = 0usize;
        for t in 0..self.bounds.len() {
            if t >= parts {
                self.bounds[t] = (nb, nb);
                continue;
            }
            let target = total * (t + 1) / parts;
            let mut end = start;
            while end < nb && (cost < target || t + 1 == parts) {
                cost += chunks - (end * R) / LANES;
                end += 1;
            }
            self.bounds[t] = (start, end);
            start = end;
        }
        for (t, slot) in self.shared.parts.iter().enumerate() {
            let mut part = lock(&slot.part);
            let (blo, bhi) = self.bounds[t];
            part.blo = blo;
            part.bhi = bhi;
            let len: usize = if stored {
                (blo..bhi).map(|b| chunks - (b * R) / LANES).sum::<usize>() * R * LANES
            } else {
                0
            };
            part.panels.clear();
            part.panels.resize(len, 0.0);
            part.acc.clear();
            part.acc.resize(np, 0.0);
            part.col.clear();
            part.col.resize(np, 0.0);
        }
    }

    /// Runs the posted phase: every block, claimed by the caller and (when `parallel`) the
    /// workers.
    fn run(&mut self, parallel: bool) {
        let helpers = if parallel { self.workers.len() } else { 0 };
        if helpers == 0 {
            let input = self.shared.input.read().unwrap_or_else(|e| e.into_inner());
            compute(&input, &mut lock(&self.shared.parts[0].part));
            return;
        }
        self.posted += 1;
        self.shared.epoch.store(self.posted, Ordering::Release);
        for w in &self.workers {
            w.thread().unpark();
        }
        let e = self.posted;
        let blocks = self.shared.blocks.load(Ordering::Relaxed);
        let input = self.shared.input.read().unwrap_or_else(|e| e.into_inner());
        // Blocks no worker has claimed yet: the caller computes them.
        claim_and_compute(&self.shared, &input, e, 0, blocks);
        for slot in &self.shared.parts[..blocks] {
            let mut spins = 0u32;
            while slot.finished.load(Ordering::Acquire) != e {
                spins = spins.saturating_add(1);
                if spins < SPINS {
                    std::hint::spin_loop();
                } else {
                    std::thread::yield_now();
                }
            }
        }
    }

    /// `absy[k]` = the parts' row and column sums for row `k` (off the diagonal).
    fn gather(&mut self, n: usize) {
        self.absy.clear();
        self.absy.resize(n, 0.0);
        for (t, slot) in self.shared.parts.iter().enumerate() {
            let (blo, bhi) = self.bounds[t];
            let part = lock(&slot.part);
            if blo < bhi {
                let (lo, hi) = ((blo * R).min(n), (bhi * R).min(n));
                for (o, a) in self.absy[lo..hi].iter_mut().zip(&part.acc[lo..hi]) {
                    *o += a;
                }
                // Columns only receive sums from rows above them.
                let from = ((blo * R) / LANES * LANES).min(n);
                for (o, c) in self.absy[from..].iter_mut().zip(&part.col[from..n]) {
                    *o += c;
                }
            }
        }
    }
}

/// The multiplicative update `y_k <- y_k (d+_k + qm_k) / (d-_k + qp_k)`; true when a zero row
/// has `d_k > 0` (infeasible). Branch-free, so it vectorizes.
fn update(y: &mut [f64], d: &[f64], qp: &[f64], qm: &[f64]) -> bool {
    let mut zero_row_violated = false;
    for (((yk, &dk), &p), &m) in y.iter_mut().zip(d).zip(qp).zip(qm) {
        let num = dk.max(0.0) + m;
        let den = (-dk).max(0.0) + p;
        // den = 0 only for a zero row with d_k >= 0: 0 >= d_k > 0 is impossible.
        let ok = den > 0.0;
        *yk *= if ok { num / den } else { 1.0 };
        zero_row_violated |= !ok & (num > 0.0);
    }
    zero_row_violated
}

/// `n` rounded up to whole chunks.
fn padded(n: usize) -> usize {
    n.div_ceil(LANES) * LANES
}

/// Chunks in all panels of the triangle: panel `b` spans chunks `(b R) / LANES ..`.
fn triangle_chunks(nb: usize, chunks: usize) -> usize {
    (0..nb).map(|b| chunks - (b * R) / LANES).sum()
}

/// The widest kernels this CPU runs.
fn detect_isa() -> Isa {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::is_x86_feature_detected as has;
        if has!("avx512f") && has!("avx512vl") && has!("avx2") && has!("fma") {
            return Isa::Avx512;
        }
        if has!("avx2") && has!("fma") {
            return Isa::Avx2;
        }
    }
    Isa::Base
}

fn worker(shared: Arc<Shared>, t: usize, mut seen: u64) {
    shared.started.fetch_add(1, Ordering::Release);
    loop {
        let mut spins = 0u32;
        let epoch = loop {
            let e = shared.epoch.load(Ordering::Acquire);
            if e != seen {
                break e;
            }
            if spins < SPINS {
                spins += 1;
                std::hint::spin_loop();
            } else {
                // The caller unparks after posting: a post between the load and the park
                // leaves a token, so no wake-up is lost.
                std::thread::park();
            }
        };
        seen = epoch;
        if shared.stop.load(Ordering::Acquire) {
            return;
        }
        let input = shared.input.read().unwrap_or_else(|e| e.into_inner());
        let blocks = shared.blocks.load(Ordering::Relaxed);
        claim_and_compute(&shared, &input, epoch, t * blocks / shared.threads, blocks);
        drop(input);
    }
}

/// Claims and computes the blocks of job `e` that no other thread has claimed, going round
/// from block `first`.
fn claim_and_compute(shared: &Shared, input: &Input, e: u64, first: usize, blocks: usize) {
    for k in 0..blocks {
        let slot = &shared.parts[(first + k) % blocks];
        if slot.claim(e) {
            compute(input, &mut lock(&slot.part));
            slot.finished.store(e, Ordering::Release);
        }
    }
}

/// One part's share of the posted phase.
fn compute(input: &Input, part: &mut Part) {
    if part.blo >= part.bhi {
        return;
    }
    #[cfg(target_arch = "x86_64")]
    match input.isa {
        // SAFETY: `input.isa` is set from `detect_isa`, which checked these features.
        Isa::Avx512 => return unsafe { compute_avx512(input, part) },
        Isa::Avx2 => return unsafe { compute_avx2(input, part) },
        Isa::Base => {}
    }
    compute_body::<false>(input, part);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn compute_avx2(input: &Input, part: &mut Part) {
    compute_body::<true>(input, part);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl,avx2,fma")]
unsafe fn compute_avx512(input: &Input, part: &mut Part) {
    compute_body::<true>(input, part);
}

/// `a * b + c`, fused when `FMA` (compiled where the instruction exists).
#[inline(always)]
fn madd<const FMA: bool>(a: f64, b: f64, c: f64) -> f64 {
    if FMA {
        a.mul_add(b, c)
    } else {
        a * b + c
    }
}

/// `acc + a .* b`, lane by lane.
#[inline(always)]
fn fma_vv<const FMA: bool>(acc: [f64; LANES], a: &[f64; LANES], b: &[f64; LANES]) -> [f64; LANES] {
    let mut out = acc;
    for l in 0..LANES {
        out[l] = madd::<FMA>(a[l], b[l], out[l]);
    }
    out
}

/// `acc + a * s`, lane by lane.
#[inline(always)]
fn fma_vs<const FMA: bool>(acc: [f64; LANES], a: &[f64; LANES], s: f64) -> [f64; LANES] {
    let mut out = acc;
    for l in 0..LANES {
        out[l] = madd::<FMA>(a[l], s, out[l]);
    }
    out
}

/// `q_ab` for the `R` rows `rows` and the chunk `cb` of `LANES` columns (`[component][lane]`),
/// each a 6-term dot product in a fixed order (the same in the stored and recomputed paths).
#[inline(always)]
fn dots<const FMA: bool>(rows: &[[f64; DIM]; R], cb: &[f64; DIM * LANES]) -> [[f64; LANES]; R] {
    let mut out = [[0.0f64; LANES]; R];
    for r in 0..R {
        for l in 0..LANES {
            let mut q = rows[r][0] * cb[l];
            for i in 1..DIM {
                q = madd::<FMA>(rows[r][i], cb[i * LANES + l], q);
            }
            out[r][l] = q;
        }
    }
    out
}

/// `|q_ab|`, as [`dots`].
#[inline(always)]
fn entries<const FMA: bool>(rows: &[[f64; DIM]; R], cb: &[f64; DIM * LANES]) -> [[f64; LANES]; R] {
    dots::<FMA>(rows, cb).map(|row| row.map(f64::abs))
}

/// 1 on the strict upper triangle of the real rows, else 0, for rows `a0 ..` and the chunk
/// of columns from `base`.
#[inline(always)]
fn keep_mask(a0: usize, base: usize, n: usize) -> [[f64; LANES]; R] {
    std::array::from_fn(|r| {
        std::array::from_fn(|l| {
            let bcol = base + l;
            f64::from(u8::from((bcol > a0 + r) & (bcol < n)))
        })
    })
}

/// Adds one chunk's entries `p` to the row sums `s` (`s_r += p_r .* y_c`) and to the column
/// sums `cc` (`cc += p_r y_a` for `r` in order).
#[inline(always)]
fn accumulate<const FMA: bool>(
    s: &mut [[f64; LANES]; R],
    cc: &mut [f64; LANES],
    p: &[[f64; LANES]; R],
    yc: &[f64; LANES],
    ya: &[f64; R],
) {
    for r in 0..R {
        s[r] = fma_vv::<FMA>(s[r], &p[r], yc);
    }
    let mut cv = *cc;
    for r in 0..R {
        cv = fma_vs::<FMA>(cv, &p[r], ya[r]);
    }
    *cc = cv;
}

#[inline(always)]
fn compute_body<const FMA: bool>(input: &Input, part: &mut Part) {
    let (n, np) = (input.n, input.np);
    let chunks = np / LANES;
    let Part {
        blo,
        bhi,
        panels,
        acc,
        col,
        ..
    } = part;
    // Columns receive sums from the part's rows on (what `gather` reads).
    let from = (*blo * R) / LANES * LANES;
    col[from.min(np)..np].iter_mut().for_each(|v| *v = 0.0);
    let mut offset = 0usize;
    for b in *blo..*bhi {
        let a0 = b * R;
        let c0 = a0 / LANES;
        let len = (chunks - c0) * R * LANES;
        let mut s = [[0.0f64; LANES]; R];
        let rows: [[f64; DIM]; R] =
            std::array::from_fn(|r| std::array::from_fn(|i| input.cols[i][a0 + r]));
        let packed = input.packed[c0 * DIM * LANES..np * DIM].chunks_exact(DIM * LANES);
        let cols = col[c0 * LANES..np].chunks_exact_mut(LANES);
        match input.phase {
            Phase::Form => {
                // The panel to fill, or none when the entries are recomputed.
                let panel: &mut [f64] = if input.stored {
                    let p = &mut panels[offset..offset + len];
                    offset += len;
                    p
                } else {
                    &mut []
                };
                let mut out = panel.chunks_exact_mut(R * LANES);
                for (k, (cb, cc)) in packed.zip(cols).enumerate() {
                    // Fixed-size views (the lengths hold by construction), so the compiler
                    // sees whole vectors and no bounds checks.
                    let (Ok(cb), Ok(cc)) = (
                        <&[f64; DIM * LANES]>::try_from(cb),
                        <&mut [f64; LANES]>::try_from(cc),
                    ) else {
                        continue;
                    };
                    let base = (c0 + k) * LANES;
                    let keep = keep_mask(a0, base, n);
                    let q = dots::<FMA>(&rows, cb);
                    let mut cv = *cc;
                    let mut p = [[0.0f64; LANES]; R];
                    for r in 0..R {
                        for l in 0..LANES {
                            let neg = (-q[r][l]).max(0.0) * keep[r][l];
                            p[r][l] = q[r][l].abs() * keep[r][l];
                            s[r][l] += neg;
                            cv[l] += neg;
                        }
                    }
                    *cc = cv;
                    if let Some(pc) = out.next() {
                        for r in 0..R {
                            pc[r * LANES..(r + 1) * LANES].copy_from_slice(&p[r]);
                        }
                    }
                }
            }
            Phase::Product if input.stored => {
                let panel = &panels[offset..offset + len];
                offset += len;
                let ya: [f64; R] = std::array::from_fn(|r| input.y[a0 + r]);
                for (pc, (yc, cc)) in panel
                    .chunks_exact(R * LANES)
                    .zip(input.y[c0 * LANES..np].chunks_exact(LANES).zip(cols))
                {
                    let (Ok(p0), Ok(p1), Ok(p2), Ok(p3), Ok(yc), Ok(cc)) = (
                        <&[f64; LANES]>::try_from(&pc[..LANES]),
                        <&[f64; LANES]>::try_from(&pc[LANES..2 * LANES]),
                        <&[f64; LANES]>::try_from(&pc[2 * LANES..3 * LANES]),
                        <&[f64; LANES]>::try_from(&pc[3 * LANES..]),
                        <&[f64; LANES]>::try_from(yc),
                        <&mut [f64; LANES]>::try_from(cc),
                    ) else {
                        continue;
                    };
                    accumulate::<FMA>(&mut s, cc, &[*p0, *p1, *p2, *p3], yc, &ya);
                }
            }
            Phase::Product => {
                // The entries recomputed from the packed rows (the same numbers the stored
                // path keeps): the working set is the rows, the multipliers and the column
                // sums from `c0` on, `8 N` numbers, which stay in the caches.
                let ya: [f64; R] = std::array::from_fn(|r| input.y[a0 + r]);
                let mut it = packed.zip(input.y[c0 * LANES..np].chunks_exact(LANES).zip(cols));
                // The first chunk holds the diagonal: masked.
                if let Some((cb, (yc, cc))) = it.next() {
                    if let (Ok(cb), Ok(yc), Ok(cc)) = (
                        <&[f64; DIM * LANES]>::try_from(cb),
                        <&[f64; LANES]>::try_from(yc),
                        <&mut [f64; LANES]>::try_from(cc),
                    ) {
                        let keep = keep_mask(a0, c0 * LANES, n);
                        let mut p = entries::<FMA>(&rows, cb);
                        for r in 0..R {
                            for l in 0..LANES {
                                p[r][l] *= keep[r][l];
                            }
                        }
                        accumulate::<FMA>(&mut s, cc, &p, yc, &ya);
                    }
                }
                // The rest lie above the diagonal; past `n` the rows are zero, so are the
                // entries.
                for (cb, (yc, cc)) in it {
                    let (Ok(cb), Ok(yc), Ok(cc)) = (
                        <&[f64; DIM * LANES]>::try_from(cb),
                        <&[f64; LANES]>::try_from(yc),
                        <&mut [f64; LANES]>::try_from(cc),
                    ) else {
                        continue;
                    };
                    let p = entries::<FMA>(&rows, cb);
                    accumulate::<FMA>(&mut s, cc, &p, yc, &ya);
                }
            }
        }
        for r in 0..R {
            let v = &s[r];
            acc[a0 + r] = ((v[0] + v[1]) + (v[2] + v[3])) + ((v[4] + v[5]) + (v[6] + v[7]));
        }
    }
}
