//! Measure: exact gaps at an answer (overlap, undershoot, contacts), and the spring wrench on
//! the hand.

use super::*;

/// Angle (rad, in `[0, pi]`) of `a b^T`.
pub(super) fn rotation_angle(a: &Matrix3<f64>, b: &Matrix3<f64>) -> f64 {
    rotation_log(&(a * b.transpose())).norm()
}

/// The spring wrench on the hand `[F; T]` (N, N·mm) pulling it from `q_h` toward `q_g`:
/// `F = kt (t_g - t_h)`; `T = kr log(R_g R_h^T)` (world axes) for rotation vectors, the
/// paper's `kr (euler_g - euler_h)` for Euler coordinates.
pub fn spring_wrench(
    g: &[f64; 6],
    rotation: RotationCoordinates,
    q_g: &Pose,
    q_h: &Pose,
) -> [f64; 6] {
    let mut w = [0.0; 6];
    for k in 0..3 {
        w[k] = g[k] * (q_g.q[k] - q_h.q[k]);
    }
    match rotation {
        RotationCoordinates::Euler => {
            for k in 3..6 {
                w[k] = g[k] * (q_g.q[k] - q_h.q[k]);
            }
        }
        RotationCoordinates::RotationVector => {
            let v = rotation_log(&(q_g.rotation_matrix() * q_h.rotation_matrix().transpose()));
            for k in 3..6 {
                w[k] = g[k] * v[k - 3];
            }
        }
    }
    w
}

impl GodObject {
    /// At `q` (the answer `dq` of the last solve over the first `n_pairs` rows): the deepest
    /// overlap among the listed pairs (mm, >= 0), and the largest amount by which a row that
    /// the answer holds tight (linearized gap ~0) is in truth still open (mm): the
    /// linearization's undershoot, zero at a converged pose; and how many pairs touch (exact
    /// gap at most [`TOUCH_MM`]).
    pub(super) fn gaps_at(&self, q: &Pose, dq: &[f64; 6], n_pairs: usize) -> (f64, f64, u32) {
        let (rot, t) = (q.rotation_matrix(), q.translation());
        let (mut deepest, mut slack, mut touching) = (0.0f64, 0.0f64, 0u32);
        for (i, p) in self.detector.pairs.iter().enumerate().take(n_pairs) {
            let gap = p.contact_posed(&rot, &t).1;
            deepest = deepest.max(-gap);
            touching += u32::from(gap <= TOUCH_MM);
            let row = &self.qp.rows[i];
            let lin_gap: f64 = (0..6).map(|k| row[k] * dq[k]).sum::<f64>() - self.qp.rhs[i];
            if lin_gap <= TIGHT_MM {
                slack = slack.max(gap - lin_gap);
            }
        }
        (deepest, slack, touching)
    }
}
