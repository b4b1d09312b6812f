//! Solve: the QP of a pass with the chosen solver, warm-started from the pairs active in the
//! last solve.

use super::*;

/// What [`GodObject::audit_reduction`] measured: reduced solves against full solves of the
/// same QP (the force of the answer, `G dq`: N and N·mm).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ReductionAudit {
    /// Reduced solves compared.
    pub solves: u64,
    /// Rows of the full problems and of the working sets, summed (for means).
    pub rows: u64,
    /// Working-set rows, summed.
    pub working_rows: u64,
    /// Largest `|F_reduced - F_full|`, N.
    pub max_force_diff_n: f64,
    /// Largest `|T_reduced - T_full|`, N·mm.
    pub max_torque_diff_nmm: f64,
    /// Largest `|F_reduced - F_full| / |F_full|` over solves with `|F_full| >= 0.1 N`.
    pub max_force_rel: f64,
}

impl GodObject {
    /// Solves the QP on the first `n` rows (the pairs' rows, then the trust region's from
    /// `n_pairs`); `dq0` is the (feasible when free) start `q_lin - q_h` for the primal
    /// active-set solver. With `reduce_rows` an exact solver works on a reduced set of rows
    /// ([`RowGeneration`]: the full problem's answer, every row checked), the trust region's
    /// always among them. `None` on a numerical failure.
    pub(super) fn solve(
        &mut self,
        n: usize,
        n_pairs: usize,
        dq0: &[f64; 6],
    ) -> Option<([f64; 6], u32, Status, f64)> {
        let p = Problem::new(self.params.g(), &self.qp.rows[..n], &self.qp.rhs[..n]).ok()?;
        let warm = &self.run.solve.warm_idx[..self.run.solve.warm_len];
        let s = if self.params.reduce_rows {
            let mut keep = [0usize; 12];
            let trust = n.saturating_sub(n_pairs).min(12);
            for (i, k) in keep.iter_mut().enumerate().take(trust) {
                *k = n_pairs + i;
            }
            let s = self
                .qp
                .rows_solver
                .solve(&mut self.qp.solver, &p, dq0, &keep[..trust], warm);
            if let Some(audit) = self.qp.audit.as_mut() {
                let stats = self.qp.rows_solver.stats();
                let (full_solver, acc) = &mut **audit;
                full_solver.set_warm_start(&[]);
                let full = full_solver.solve(&p, dq0);
                if s.status == Status::Solved && full.status == Status::Solved {
                    let g = self.params.g();
                    let diff = |a: usize| {
                        (a..a + 3)
                            .map(|k| (g[k] * (s.dq[k] - full.dq[k])).powi(2))
                            .sum::<f64>()
                            .sqrt()
                    };
                    let force: f64 = (0..3)
                        .map(|k| (g[k] * full.dq[k]).powi(2))
                        .sum::<f64>()
                        .sqrt();
                    acc.solves += 1;
                    acc.rows += stats.rows as u64;
                    acc.working_rows += stats.working_rows as u64;
                    acc.max_force_diff_n = acc.max_force_diff_n.max(diff(0));
                    acc.max_torque_diff_nmm = acc.max_torque_diff_nmm.max(diff(3));
                    if force >= 0.1 {
                        acc.max_force_rel = acc.max_force_rel.max(diff(0) / force);
                    }
                }
            }
            s
        } else {
            self.qp
                .rows_solver
                .solve_full(&mut self.qp.solver, &p, dq0, warm)
        };
        if s.status == Status::NumericalError {
            return None;
        }
        Some((s.dq, s.iterations, s.status, s.kkt.max_violation))
    }

    /// Maps the remembered active pairs onto the rows of the current pair list.
    pub(super) fn map_warm_start(&mut self) {
        if !self.params.heuristics.warm_start {
            self.run.solve.warm_len = 0;
            return;
        }
        let mut m = 0;
        for w in 0..self.run.solve.warm_len {
            let id = self.run.solve.warm[w];
            if self.bodies.meshes.is_some() {
                let found = self
                    .detector
                    .contacts
                    .iter()
                    .position(|c| (c.object, c.tool, c.part) == id);
                if let Some(i) = found {
                    self.run.solve.warm_idx[m] = i;
                    m += 1;
                }
                continue;
            }
            if let Some(i) = self
                .detector
                .pairs
                .iter()
                .position(|p| (p.object, p.tool_slot, p.object_slot) == id)
            {
                self.run.solve.warm_idx[m] = i;
                m += 1;
            }
        }
        self.run.solve.warm_len = m;
    }

    /// Remembers the identities of the active pairs of the last solve.
    pub(super) fn remember_active(&mut self, n_pairs: usize) {
        let mut m = 0;
        // The one face whose half-space pairs alone hold the tool, if so.
        let mut face: Option<[f64; 3]> = None;
        let mut one_face = true;
        let mesh = self.bodies.meshes.is_some();
        for &i in self.qp.rows_solver.active_set() {
            if i >= n_pairs {
                continue;
            }
            if let Some(c) = self.detector.contacts.get(i).filter(|_| mesh) {
                if m < 6 {
                    self.run.solve.warm[m] = (c.object, c.tool, c.part);
                    m += 1;
                }
                one_face = false;
                continue;
            }
            let Some(p) = self.detector.pairs.get(i) else {
                continue;
            };
            if m < 6 {
                self.run.solve.warm[m] = (p.object, p.tool_slot, p.object_slot);
                m += 1;
            }
            match (p.stands_for_face(), p.face) {
                (true, Some(f)) if face.is_none_or(|n| n == f.normal) => face = Some(f.normal),
                _ => one_face = false,
            }
        }
        self.run.solve.warm_len = m;
        self.run.regions.contact_face = face.filter(|_| one_face).map(Vector3::from);
    }
}
