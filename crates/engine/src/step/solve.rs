//! Solve: the QP of a pass with the chosen solver, warm-started from the pairs active in the
//! last solve.

use super::*;

impl GodObject {
    /// Solves the QP on the first `n` rows; `dq0` is the (feasible when free) start
    /// `q_lin - q_h` for the primal active-set solver. `None` on a numerical failure.
    pub(super) fn solve(
        &mut self,
        n: usize,
        dq0: &[f64; 6],
    ) -> Option<([f64; 6], u32, Status, f64)> {
        let p = Problem::new(self.params.g(), &self.rows[..n], &self.rhs[..n]).ok()?;
        self.solver.set_warm_start(&self.warm_idx[..self.warm_len]);
        let s = self.solver.solve(&p, dq0);
        if s.status == Status::NumericalError {
            return None;
        }
        Some((s.dq, s.iterations, s.status, s.kkt.max_violation))
    }

    /// Maps the remembered active pairs onto the rows of the current pair list.
    pub(super) fn map_warm_start(&mut self) {
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
    pub(super) fn remember_active(&mut self, n_pairs: usize) {
        let mut m = 0;
        for &i in self.solver.active_set() {
            if i < n_pairs && m < 6 {
                let p = &self.pairs[i];
                self.warm[m] = (p.object, p.tool_slot, p.object_slot);
                m += 1;
            }
        }
        self.warm_len = m;
    }
}
