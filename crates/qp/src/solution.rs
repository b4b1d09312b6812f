//! What a solve returns: status, iterations and the KKT certificate.

use crate::problem::{dot6, Problem};

/// How a solve ended. An outcome, not an error: every solver returns one of these and never
/// panics.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Status {
    /// The solver's stopping rule was met (for `dual` and `active-set`: optimal to the
    /// tolerances; for `pqp`: its stopping rule held *and* the answer is feasible to
    /// [`crate::PqpParams::violation_tol`], otherwise it reports [`Status::Inexact`]).
    Solved,
    /// The solver's stopping rule was met but its answer violates a constraint by more than
    /// the solver's feasibility tolerance: [`Kkt::max_violation`] (units of `d`, mm in the
    /// haptic step) is above it. `dq` is the last iterate, finite, usable as an approximation
    /// only. Reported by `pqp` (see [`crate::PqpParams::violation_tol`]); with the paper's stop
    /// it is the usual outcome of a problem with active constraints.
    Inexact,
    /// The iteration cap was reached; `dq` is the last iterate.
    MaxIterations,
    /// The constraints have no common solution (the dual is unbounded); `dq` is the last
    /// iterate, finite but not feasible.
    Infeasible,
    /// Non-finite data or a numerical breakdown; `dq` is zero.
    NumericalError,
}

/// The KKT certificate of a returned `dq` with multipliers `y` (one per row):
/// `G dq = J^T y` (stationarity), `J dq >= d` (primal feasibility), `y >= 0` (dual
/// feasibility), `y_k (J_k dq - d_k) = 0` (complementarity).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Kkt {
    /// `max_k max(d_k - J_k dq, 0)`, in the units of `d` (mm for the distance form).
    pub max_violation: f64,
    /// `min_k y_k` (0 when `N = 0`); negative means a wrong-signed multiplier.
    pub min_multiplier: f64,
    /// `max_k |y_k (J_k dq - d_k)|`, in units of the objective (N·mm in the haptic step).
    pub complementarity: f64,
    /// `max_i |(G dq - J^T y)_i|` (units of `G dq`: N and N·mm in the haptic step).
    pub stationarity: f64,
    /// `1/2 dq^T G dq - D(y+)`, the primal objective minus the dual objective
    /// `D(y) = d^T y - 1/2 (J^T y)^T G^{-1} (J^T y)` at `y+ = max(y, 0)`. Weak duality makes
    /// `D(y+)` a lower bound on the optimum, so for a feasible `dq` this bounds the objective
    /// error: `0 <= f(dq) - f* <= duality_gap` (units of the objective).
    pub duality_gap: f64,
}

impl Kkt {
    /// The certificate of `dq` with multipliers `y` (`y.len()` must equal `p.len()`; extra
    /// or missing entries are read as 0). Returns `None` if any residual is not finite.
    ///
    /// # Real-time
    /// Allocates nothing, never panics, O(18N).
    pub fn compute(p: &Problem<'_>, dq: &[f64; 6], y: &[f64]) -> Option<Kkt> {
        let g = p.g();
        let mut jty = [0.0f64; 6];
        let mut viol = 0.0f64;
        let mut miny = f64::INFINITY;
        let mut comp = 0.0f64;
        let mut jty_plus = [0.0f64; 6];
        let mut dty_plus = 0.0f64;
        let mut finite = true;
        for (k, (row, &dk)) in p.j().iter().zip(p.d()).enumerate() {
            let yk = y.get(k).copied().unwrap_or(0.0);
            let s = dot6(row, dq) - dk;
            if yk != 0.0 {
                let yp = yk.max(0.0);
                dty_plus += dk * yp;
                for i in 0..6 {
                    jty[i] += yk * row[i];
                    jty_plus[i] += yp * row[i];
                }
            }
            finite &= s.is_finite() && yk.is_finite();
            viol = viol.max(-s);
            miny = miny.min(yk);
            comp = comp.max((yk * s).abs());
        }
        let mut stat = 0.0f64;
        let mut dual = dty_plus;
        for i in 0..6 {
            dual -= 0.5 * jty_plus[i] * jty_plus[i] / g[i];
            let r = g[i] * dq[i] - jty[i];
            finite &= r.is_finite();
            stat = stat.max(r.abs());
        }
        if !finite {
            return None;
        }
        Some(Kkt {
            max_violation: viol,
            min_multiplier: if p.is_empty() { 0.0 } else { miny },
            complementarity: comp,
            stationarity: stat,
            duality_gap: p.objective(dq) - dual,
        })
    }
}

/// The result of one solve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Solution {
    /// The step `dq = q_g - q_h` (mm, rad). Always finite (zero on
    /// [`Status::NumericalError`]).
    pub dq: [f64; 6],
    /// How the solve ended.
    pub status: Status,
    /// Iterations taken (solver-specific: dual active-set changes, primal active-set steps,
    /// PQP multiplicative updates).
    pub iterations: u32,
    /// The objective `1/2 dq^T G dq` at `dq`.
    pub objective: f64,
    /// The KKT certificate of `dq` and the returned multipliers.
    pub kkt: Kkt,
}

impl Solution {
    /// The solution of the empty problem (or a failed one): `dq = 0`.
    pub(crate) fn zero(status: Status) -> Self {
        Self {
            dq: [0.0; 6],
            status,
            iterations: 0,
            objective: 0.0,
            kkt: Kkt::default(),
        }
    }

    /// Builds the solution from a certificate the solver computed itself.
    pub(crate) fn with_kkt(
        dq: [f64; 6],
        status: Status,
        iterations: u32,
        objective: f64,
        kkt: Kkt,
    ) -> Self {
        let finite = dq.iter().all(|v| v.is_finite())
            && objective.is_finite()
            && kkt.max_violation.is_finite()
            && kkt.stationarity.is_finite()
            && kkt.duality_gap.is_finite();
        if !finite {
            return Self {
                iterations,
                ..Self::zero(Status::NumericalError)
            };
        }
        Self {
            dq,
            status,
            iterations,
            objective,
            kkt,
        }
    }

    /// Builds the solution, computing objective and certificate; a non-finite `dq` or
    /// certificate turns the status into [`Status::NumericalError`].
    pub(crate) fn finish(
        p: &Problem<'_>,
        dq: [f64; 6],
        y: &[f64],
        status: Status,
        iterations: u32,
    ) -> Self {
        if dq.iter().any(|v| !v.is_finite()) {
            return Self {
                iterations,
                ..Self::zero(Status::NumericalError)
            };
        }
        match Kkt::compute(p, &dq, y) {
            Some(kkt) => Self {
                dq,
                status,
                iterations,
                objective: p.objective(&dq),
                kkt,
            },
            None => Self {
                iterations,
                ..Self::zero(Status::NumericalError)
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn certificate_of_a_known_point() {
        // min 1/2 (x^2 + 4 y^2) s.t. x >= 1, y >= -1: optimum (1, 0) with multipliers (1, 0).
        let g = [1.0, 4.0, 1.0, 1.0, 1.0, 1.0];
        let j = [
            [1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0, 0.0, 0.0, 0.0],
        ];
        let d = [1.0, -1.0];
        let p = Problem::new(g, &j, &d).unwrap();
        let k = Kkt::compute(&p, &[1.0, 0.0, 0.0, 0.0, 0.0, 0.0], &[1.0, 0.0]).unwrap();
        assert_eq!(k.max_violation, 0.0);
        assert_eq!(k.min_multiplier, 0.0);
        assert_eq!(k.complementarity, 0.0);
        assert_eq!(k.stationarity, 0.0);
        assert!(k.duality_gap.abs() < 1e-15);
        // A wrong point: infeasible, wrong multiplier, not stationary.
        let k = Kkt::compute(&p, &[0.5, 0.0, 0.0, 0.0, 0.0, 0.0], &[2.0, -1.0]).unwrap();
        assert_eq!(k.max_violation, 0.5);
        assert_eq!(k.min_multiplier, -1.0);
        assert_eq!(k.complementarity, 1.0); // |2 * (0.5 - 1)| = 1, |-1 * (0 + 1)| = 1
        assert_eq!(k.stationarity, 1.5); // |0.5 - 2| and |0 - (-1)|
                                         // Dual objective at y+ = (2, 0): 2 - 1/2 * 4 = 0; primal 0.125.
        assert!((k.duality_gap - 0.125).abs() < 1e-15);
        assert!(Kkt::compute(&p, &[f64::NAN; 6], &[0.0, 0.0]).is_none());
    }
}
