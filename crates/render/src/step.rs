//! The god-object step: one haptic frame (docs/DESIGN.md §The frame step).
//!
//! Given the device configuration `q_h` and the last graphic configuration `q_g_prev`:
//!
//! 1. **Detect** at `q_g_prev` every leaf pair whose gap is at most a margin `m` that bounds how
//!    far any tool sphere can move toward `q_h`. With `Δt = t_h - t_g` and `θ` the angle of
//!    `R_h R_g^T`, a tool point `p` (tool frame) moves by
//!    `|R_h p + t_h - R_g p - t_g| <= |Δt| + |(R_h R_g^T - I) R_g p| <= |Δt| + 2 sin(θ/2) |p|
//!    <= |Δt| + θ |p|`, and a sphere's gap to a static sphere changes by at most its centre's
//!    displacement; so `m = |Δt| + θ · reach + skin` (`reach` = largest `|p|` over tool leaf
//!    centres) finds every pair that can touch anywhere on the way to `q_h`. `m` is capped
//!    (`max_margin_mm`); when the cap binds, a per-axis trust region around `q_g_prev` is added
//!    to the QP (12 rows, half-widths chosen so the capped margin still bounds the motion), so
//!    `q_g` cannot leave the region whose pairs were found: no tunnelling through thin parts.
//! 2. **Constrain**: rows `J dq >= d` linearized at `q_g_prev` (collide's
//!    [`collide::Linearization`]), distance form by default.
//! 3. **Solve** `min 1/2 dq^T G dq` with the chosen solver, warm-started from the last frame's
//!    active pairs; `q_g = q_h + dq*`.
//! 4. **Measure** the deepest leaf–leaf overlap at `q_g`; while it exceeds the tolerance and
//!    passes remain, **re-linearize** at the new `q_g` (detect + solve again).
//! 5. **Force** `[F; T] = G (q_g - q_h)`: the spring pulls the hand toward the graphic tool,
//!    out of the object.
//!
//! A frame that fails (non-finite input, solver breakdown) keeps the last safe `q_g` and says
//! so in [`FrameOutput::status`].

use std::time::Instant;

use collide::{
    overlap_tree_trees, CollideWorkspace, ConstraintForm, LeafPair, Linearization, PackedTree, Pose,
};
use nalgebra::Matrix3;
use qp::{Problem, Solver, Status};

use crate::scene::{Scene, SolverKind};
use crate::RenderError;

/// Parameters of the step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepParams {
    /// Diagonal of `G`: kt (N/mm) ×3, kr (N·mm/rad) ×3.
    pub g: [f64; 6],
    /// Constraint form.
    pub form: ConstraintForm,
    /// QP solver.
    pub solver: SolverKind,
    /// Maximum extra detect + solve passes per frame.
    pub relinearize: u32,
    /// Penetration (mm) above which another pass is made.
    pub penetration_tol_mm: f64,
    /// Skin added to the detection margin, mm.
    pub skin_mm: f64,
    /// Trust-region half-width per translation axis when the margin is capped, mm.
    pub trust_mm: f64,
    /// Trust-region half-width per Euler angle when the margin is capped, rad.
    pub trust_rad: f64,
    /// Largest number of leaf pairs per pass (storage reserved up front; more are dropped and
    /// counted, never allocated).
    pub max_pairs: usize,
}

impl StepParams {
    /// Parameters from a scene's coupling and solver settings.
    pub fn from_scene(scene: &Scene) -> Self {
        Self {
            g: scene.coupling.g(),
            form: scene.solver.form.form(),
            solver: scene.solver.kind,
            relinearize: scene.solver.relinearize,
            penetration_tol_mm: scene.solver.penetration_tol_mm,
            skin_mm: scene.solver.skin_mm,
            trust_mm: scene.solver.trust_mm,
            trust_rad: scene.solver.trust_rad,
            max_pairs: 16_384,
        }
    }
}

/// How a frame ended.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FrameStatus {
    /// Solved.
    #[default]
    Ok,
    /// The QP stopped with a status other than solved, capped or infeasible (those keep the
    /// last safe pose); its `q_g` was used.
    Inexact,
    /// More pairs than `max_pairs`: some were dropped.
    PairOverflow,
    /// The frame failed (non-finite input or numerical breakdown): the last safe `q_g` kept.
    KeptLastSafe,
}

/// The result of one frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrameOutput {
    /// Device configuration (mm, rad).
    pub q_h: [f64; 6],
    /// Graphic tool configuration after the frame (mm, rad).
    pub q_g: [f64; 6],
    /// `[F; T] = G (q_g - q_h)`: N and N·mm, before the safety layer.
    pub wrench: [f64; 6],
    /// Leaf pairs in the first pass's QP.
    pub pairs: u32,
    /// Solver iterations, summed over passes.
    pub iterations: u32,
    /// Passes made (1 + re-linearisations).
    pub passes: u32,
    /// Time in collision detection (all traversals), µs.
    pub cd_us: f64,
    /// Time building rows and solving, µs.
    pub opt_us: f64,
    /// Time of the whole step, µs.
    pub total_us: f64,
    /// Deepest leaf–leaf overlap at `q_g`, mm (0 when free).
    pub penetration_mm: f64,
    /// Largest linearized-constraint violation reported by the solver, mm (distance form).
    pub qp_violation: f64,
    /// Detection margin used in the first pass, mm.
    pub margin_mm: f64,
    /// Outcome.
    pub status: FrameStatus,
}

/// Warm-start identity of a pair: (object, tool slot, object slot).
type PairId = (u32, u32, u32);

/// The god-object: owns the packed trees, all scratch memory and the graphic configuration.
pub struct GodObject {
    params: StepParams,
    tool: PackedTree,
    objects: Vec<PackedTree>,
    ws: CollideWorkspace,
    pairs: Vec<LeafPair>,
    dropped: usize,
    rows: Vec<[f64; 6]>,
    rhs: Vec<f64>,
    solver: Solver,
    warm: [PairId; 6],
    warm_len: usize,
    warm_idx: [usize; 6],
    reach: f64,
    q_g: Pose,
    started: bool,
}

fn delta(a: &Pose, b: &Pose) -> [f64; 6] {
    let mut d = [0.0; 6];
    for (k, v) in d.iter_mut().enumerate() {
        *v = a.q[k] - b.q[k];
    }
    d
}

fn rotation_angle(a: &Matrix3<f64>, b: &Matrix3<f64>) -> f64 {
    let r = a * b.transpose();
    let c = ((r.trace() - 1.0) * 0.5).clamp(-1.0, 1.0);
    c.acos()
}

impl GodObject {
    /// Packs the scene's trees and reserves every buffer (allocates; not real-time).
    pub fn new(scene: &Scene, params: StepParams) -> Result<Self, RenderError> {
        let bad = |what: &str, e: collide::CollideError| RenderError::Scene {
            file: scene.name.clone(),
            msg: format!("{what}: {e}"),
        };
        let tool = PackedTree::new(&scene.tool).map_err(|e| bad("tool tree", e))?;
        let objects = scene
            .objects
            .iter()
            .enumerate()
            .map(|(i, (t, p))| {
                PackedTree::with_pose(t, p).map_err(|e| bad(&format!("object {}", i + 1), e))
            })
            .collect::<Result<Vec<_>, _>>()?;
        let reach = tool
            .leaves()
            .map(|n| {
                let c = tool.center(n);
                (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt()
            })
            .fold(0.0, f64::max);
        let ws = CollideWorkspace::for_trees(&tool, &objects);
        let cap = params.max_pairs;
        let mut solver = Solver::new(match params.solver {
            SolverKind::Dual => qp::SolverKind::Dual,
            SolverKind::ActiveSet => qp::SolverKind::ActiveSet,
            SolverKind::Pqp => qp::SolverKind::Pqp,
        });
        solver.reserve(cap + 12);
        Ok(Self {
            params,
            tool,
            objects,
            ws,
            pairs: Vec::with_capacity(cap),
            dropped: 0,
            rows: vec![[0.0; 6]; cap + 12],
            rhs: vec![0.0; cap + 12],
            solver,
            warm: [(0, 0, 0); 6],
            warm_len: 0,
            warm_idx: [0; 6],
            reach,
            q_g: Pose::identity(),
            started: false,
        })
    }

    /// The parameters.
    pub fn params(&self) -> &StepParams {
        &self.params
    }

    /// The QP solver and its workspaces, e.g. to change iteration caps or tolerances
    /// (`solver_mut().dual.params.max_iterations`) between frames.
    pub fn solver_mut(&mut self) -> &mut Solver {
        &mut self.solver
    }

    /// The current graphic configuration.
    pub fn q_g(&self) -> Pose {
        self.q_g
    }

    /// Largest distance of a tool leaf centre from the tool origin, mm.
    pub fn reach(&self) -> f64 {
        self.reach
    }

    /// Collects pairs at `q` within `margin` into `self.pairs` (at most `max_pairs`; the rest
    /// are counted in `self.dropped`); returns the smallest gap seen (mm, +inf if none).
    fn detect(&mut self, q: &Pose, margin: f64) -> Result<f64, collide::CollideError> {
        self.pairs.clear();
        self.dropped = 0;
        let pairs = &mut self.pairs;
        let dropped = &mut self.dropped;
        let mut min_gap = f64::INFINITY;
        overlap_tree_trees(&self.tool, q, &self.objects, margin, &mut self.ws, |p| {
            min_gap = min_gap.min(p.gap);
            if pairs.len() < pairs.capacity() {
                pairs.push(*p);
            } else {
                *dropped += 1;
            }
        })?;
        Ok(min_gap)
    }

    /// Deepest overlap (mm, >= 0) among the stored pairs with the tool at `q`.
    fn penetration_of_pairs(&self, q: &Pose) -> f64 {
        let rot = q.rotation_matrix();
        let t = q.translation();
        let mut deepest: f64 = 0.0;
        for p in &self.pairs {
            let c = rot * nalgebra::Vector3::from(p.p_in_tool) + t;
            let o = nalgebra::Vector3::from(p.o_in_world);
            let gap = (c - o).norm() - (p.r_tool + p.r_object);
            deepest = deepest.max(-gap);
        }
        deepest
    }

    /// True when some leaf pair is within `margin` (mm) of touching at `q`; stops at the first
    /// one, so a large margin (a fast hand) stays cheap. Stores no pair.
    fn any_within(&mut self, q: &Pose, margin: f64) -> Result<bool, collide::CollideError> {
        collide::any_pair_within(&self.tool, q, &self.objects, margin, &mut self.ws)
    }

    /// The largest motion (mm) of any tool leaf centre inside the trust region: `sqrt(3)`
    /// times the per-axis translation plus the rotation angle bound (sum of the three Euler
    /// steps) times the reach.
    fn trust_bound(&self) -> f64 {
        3f64.sqrt() * self.params.trust_mm + 3.0 * self.params.trust_rad * self.reach
    }

    /// Deepest overlap (mm, >= 0) of the tool at `q`, using `self.pairs` as scratch.
    pub fn penetration_at(&mut self, q: &Pose) -> f64 {
        match self.detect(q, 0.0) {
            Ok(g) if g.is_finite() => (-g).max(0.0),
            Ok(_) => 0.0,
            Err(_) => f64::INFINITY,
        }
    }

    /// The motion bound (mm) of any tool leaf centre between `a` and `b`.
    fn motion_bound(&self, a: &Pose, b: &Pose) -> f64 {
        let dt = (b.translation() - a.translation()).norm();
        let th = rotation_angle(&b.rotation_matrix(), &a.rotation_matrix());
        dt + th * self.reach
    }

    /// Resets the graphic tool for a new run at the device pose `start`: `q_g = start` if it is
    /// free, else the nearest free pose found by repeated projection (each pass: detect at the
    /// current `q`, solve the QP toward `start`, re-measure). Allocation-free after `new`.
    pub fn reset(&mut self, start: &Pose) -> Result<Pose, RenderError> {
        if !start.is_finite() {
            return Err(RenderError::NoFreeStart { searched_mm: 0.0 });
        }
        self.warm_len = 0;
        let mut q = *start;
        let tol = self.params.penetration_tol_mm.max(1e-6);
        let mut searched = 0.0f64;
        for _ in 0..100 {
            if self.penetration_at(&q) <= tol {
                self.q_g = q;
                self.started = true;
                return Ok(q);
            }
            // Push out: linearize at q with the gap target, minimising distance to `start`.
            let margin = self.params.skin_mm.max(0.5);
            if self.detect(&q, margin).is_err() {
                break;
            }
            let n = self.fill_rows(&q, start, false, 0.0);
            // Aim for a gap of `tol` rather than 0 so the projection ends strictly outside.
            for d in &mut self.rhs[..n] {
                *d += tol;
            }
            let dq0 = delta(&q, start);
            let Some((dq, _, _, _)) = self.solve(n, &dq0) else {
                break;
            };
            let mut next = *start;
            for k in 0..6 {
                next.q[k] += dq[k];
            }
            // Step at least a little beyond to escape flat minima of the linearization.
            searched = searched.max((next.translation() - start.translation()).norm());
            if !next.is_finite() {
                break;
            }
            q = next;
        }
        Err(RenderError::NoFreeStart {
            searched_mm: searched,
        })
    }

    /// Fills rows for `self.pairs` linearized at `q_lin` toward `q_h`, plus the trust-region box
    /// around `q_lin` when `trust` is set. Returns the row count.
    fn fill_rows(&mut self, q_lin: &Pose, q_h: &Pose, trust: bool, _margin: f64) -> usize {
        let Ok(lin) = Linearization::new(self.params.form, q_lin, q_h) else {
            return 0;
        };
        let mut n = 0;
        for (pair, (row, d)) in self
            .pairs
            .iter()
            .zip(self.rows.iter_mut().zip(self.rhs.iter_mut()))
        {
            let (j, rhs) = lin.row(pair);
            *row = j;
            *d = rhs;
            n += 1;
        }
        if trust {
            for k in 0..6 {
                let w = if k < 3 {
                    self.params.trust_mm
                } else {
                    self.params.trust_rad
                };
                let base = q_lin.q[k] - q_h.q[k];
                // dq_k >= base - w  and  -dq_k >= -(base + w).
                let mut e = [0.0; 6];
                e[k] = 1.0;
                self.rows[n] = e;
                self.rhs[n] = base - w;
                e[k] = -1.0;
                self.rows[n + 1] = e;
                self.rhs[n + 1] = -(base + w);
                n += 2;
            }
        }
        n
    }

    /// Solves the QP on the first `n` rows; `dq0` is the (feasible when free) start
    /// `q_lin - q_h` for the primal active-set solver. `None` on a numerical failure.
    fn solve(&mut self, n: usize, dq0: &[f64; 6]) -> Option<([f64; 6], u32, Status, f64)> {
        let p = Problem::new(self.params.g, &self.rows[..n], &self.rhs[..n]).ok()?;
        if self.warm_len > 0 {
            self.solver
                .dual
                .set_warm_start(&self.warm_idx[..self.warm_len]);
        } else {
            self.solver.dual.clear_warm_start();
        }
        let s = self.solver.solve(&p, dq0);
        if s.status == Status::NumericalError {
            return None;
        }
        Some((s.dq, s.iterations, s.status, s.kkt.max_violation))
    }

    /// Maps the remembered active pairs onto the rows of the current pair list.
    fn map_warm_start(&mut self) {
        let mut m = 0;
        for w in 0..self.warm_len {
            let id = self.warm[w];
            if let Some(i) = self
                .pairs
                .iter()
                .position(|p| (p.object, p.tool_slot, p.object_slot) == id)
            {
                self.warm_idx[m] = i;
                m += 1;
            }
        }
        self.warm_len = m;
    }

    /// Remembers the identities of the active pairs of the last solve.
    fn remember_active(&mut self, n_pairs: usize) {
        let active = match self.solver.kind {
            qp::SolverKind::Dual => self.solver.dual.active_set(),
            qp::SolverKind::ActiveSet => self.solver.active_set.active_set(),
            qp::SolverKind::Pqp => &[],
        };
        let mut m = 0;
        for &i in active {
            if i < n_pairs && m < 6 {
                let p = &self.pairs[i];
                self.warm[m] = (p.object, p.tool_slot, p.object_slot);
                m += 1;
            }
        }
        self.warm_len = m;
    }

    /// One haptic frame for the device configuration `q_h` (see the module docs).
    ///
    /// # Real-time
    /// No allocation (all buffers reserved in [`GodObject::new`]), no panic. Bounded: at most
    /// `1 + relinearize` passes of two traversals and one QP solve (the solver's iteration cap).
    pub fn step(&mut self, q_h: &Pose) -> FrameOutput {
        let t_start = Instant::now();
        let mut out = FrameOutput {
            q_h: q_h.to_array(),
            ..FrameOutput::default()
        };
        if !self.started {
            self.q_g = *q_h;
            self.started = true;
        }
        let q_prev = self.q_g;
        // A non-finite or absurd reading (beyond 1e6 mm or rad: `q - q_h` then keeps too few
        // digits for the constraints) is a device fault: keep the last safe pose.
        if !q_h.is_finite() || q_h.q.iter().any(|v| v.abs() > 1e6) {
            return self.keep_last_safe(out, q_h, t_start);
        }
        let mut q_lin = q_prev;
        let mut cd = 0.0;
        let mut opt = 0.0;
        let mut q_new = q_prev;
        let max_passes = 1 + self.params.relinearize;
        for pass in 0..max_passes {
            let t0 = Instant::now();
            let bound = self.motion_bound(&q_lin, q_h);
            let cap = self.trust_bound();
            let mut trust = bound > cap;
            let margin = bound.min(cap) + self.params.skin_mm;
            let mut detected = self.detect(&q_lin, margin);
            if trust && self.pairs.is_empty() && detected.is_ok() {
                // Nothing within the capped margin: if nothing is within the full motion bound
                // either, the way to q_h is free and no trust region is needed (no lag in free
                // space). The check only tracks the smallest gap; it stores no pair.
                let near = self.any_within(&q_lin, bound + self.params.skin_mm);
                trust = matches!(near, Ok(true));
                detected = near.map(|_| f64::INFINITY);
            }
            cd += t0.elapsed().as_secs_f64();
            if detected.is_err() {
                return self.keep_last_safe(out, q_h, t_start);
            }
            if self.dropped > 0 {
                out.status = FrameStatus::PairOverflow;
            }
            let t1 = Instant::now();
            let n_pairs = self.pairs.len();
            if pass == 0 {
                out.pairs = n_pairs as u32;
                out.margin_mm = margin;
            }
            self.map_warm_start();
            let n = self.fill_rows(&q_lin, q_h, trust, margin);
            let solved = self.solve(n, &delta(&q_lin, q_h));
            opt += t1.elapsed().as_secs_f64();
            let Some((dq, iters, status, viol)) = solved else {
                return self.keep_last_safe(out, q_h, t_start);
            };
            self.remember_active(n_pairs);
            out.iterations += iters;
            out.qp_violation = viol;
            if matches!(status, Status::Infeasible | Status::MaxIterations) {
                // Infeasible only when q_lin itself penetrates; a capped solve is no answer
                // (it may penetrate): neither reaches the device, keep the last safe pose.
                return self.keep_last_safe(out, q_h, t_start);
            }
            if status != Status::Solved && out.status == FrameStatus::Ok {
                out.status = FrameStatus::Inexact;
            }
            for k in 0..6 {
                q_new.q[k] = q_h.q[k] + dq[k];
            }
            if !q_new.is_finite() {
                return self.keep_last_safe(out, q_h, t_start);
            }
            out.passes = pass + 1;
            // Measure the penetration at the new configuration.
            let t2 = Instant::now();
            // The pair list is complete for q_new when no tool sphere moved farther than the
            // margin since q_lin: then the exact gaps of the listed pairs give the deepest
            // overlap without another traversal.
            let pen = if self.motion_bound(&q_lin, &q_new) <= margin && self.dropped == 0 {
                self.penetration_of_pairs(&q_new)
            } else {
                self.penetration_at(&q_new)
            };
            cd += t2.elapsed().as_secs_f64();
            out.penetration_mm = pen;
            if pen <= self.params.penetration_tol_mm {
                break;
            }
            q_lin = q_new;
        }
        self.q_g = q_new;
        out.q_g = q_new.to_array();
        for k in 0..6 {
            out.wrench[k] = self.params.g[k] * (q_new.q[k] - q_h.q[k]);
        }
        out.cd_us = cd * 1e6;
        out.opt_us = opt * 1e6;
        out.total_us = t_start.elapsed().as_secs_f64() * 1e6;
        out
    }

    fn keep_last_safe(&mut self, mut out: FrameOutput, q_h: &Pose, t0: Instant) -> FrameOutput {
        out.status = FrameStatus::KeptLastSafe;
        out.q_g = self.q_g.to_array();
        self.warm_len = 0;
        for k in 0..6 {
            let w = self.params.g[k] * (self.q_g.q[k] - q_h.q[k]);
            out.wrench[k] = if w.is_finite() { w } else { 0.0 };
        }
        out.total_us = t0.elapsed().as_secs_f64() * 1e6;
        out
    }
}
