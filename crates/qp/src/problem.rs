//! The problem type: a borrowed view over the caller's `G`, `J` and `d`.

use crate::QpError;

/// One QP instance `min 1/2 dq^T G dq  s.t.  J dq >= d`, borrowed from the caller.
///
/// - `g`: the diagonal of `G` (6 entries, all finite and `> 0`). In the haptic step
///   `G = diag(kt, kt, kt, kr, kr, kr)` with `kt` in N/mm and `kr` in N·mm/rad.
/// - `j`: the `N` constraint rows, each a `[f64; 6]` (row `k` is `J_k`, the gradient of
///   constraint `k` with respect to `q`, in units of `d` per mm for the first three entries
///   and per rad for the last three).
/// - `d`: the `N` right-hand sides (units of the constraint: mm for the distance form,
///   mm² for the paper's squared form).
///
/// Rows and right-hand sides must be finite; a solve on non-finite data returns
/// [`crate::Status::NumericalError`] rather than panicking. `N = 0` is allowed (the solution
/// is `dq = 0`).
#[derive(Debug, Clone, Copy)]
pub struct Problem<'a> {
    g: [f64; 6],
    j: &'a [[f64; 6]],
    d: &'a [f64],
}

impl<'a> Problem<'a> {
    /// A view over `G = diag(g)`, the rows `j` and the right-hand sides `d`.
    ///
    /// Checks (in O(1)) that `j` and `d` have the same length and that every `g` is finite
    /// and positive. It does not scan the rows: use [`Problem::validate`] for that.
    ///
    /// # Real-time
    /// Allocates nothing, never panics, O(1).
    pub fn new(g: [f64; 6], j: &'a [[f64; 6]], d: &'a [f64]) -> Result<Self, QpError> {
        if j.len() != d.len() {
            return Err(QpError::LengthMismatch {
                rows: j.len(),
                rhs: d.len(),
            });
        }
        for (axis, &gi) in g.iter().enumerate() {
            if !(gi.is_finite() && gi > 0.0) {
                return Err(QpError::BadWeight { axis, value: gi });
            }
        }
        Ok(Self { g, j, d })
    }

    /// Checks every row and right-hand side for NaN or infinity (O(N)).
    ///
    /// # Real-time
    /// Allocates nothing, never panics, O(7N).
    pub fn validate(&self) -> Result<(), QpError> {
        for (row, (jr, &dr)) in self.j.iter().zip(self.d).enumerate() {
            if !dr.is_finite() || jr.iter().any(|v| !v.is_finite()) {
                return Err(QpError::NonFinite { row });
            }
        }
        Ok(())
    }

    /// Number of constraints `N`.
    pub fn len(&self) -> usize {
        self.j.len()
    }

    /// `true` when there are no constraints.
    pub fn is_empty(&self) -> bool {
        self.j.is_empty()
    }

    /// The diagonal of `G`.
    pub fn g(&self) -> &[f64; 6] {
        &self.g
    }

    /// The constraint rows `J` (N × 6, row-major).
    pub fn j(&self) -> &'a [[f64; 6]] {
        self.j
    }

    /// The right-hand sides `d` (N).
    pub fn d(&self) -> &'a [f64] {
        self.d
    }

    /// The objective `1/2 dq^T G dq` at `dq` (units of `G` × `dq`², N·mm in the haptic step).
    pub fn objective(&self, dq: &[f64; 6]) -> f64 {
        0.5 * (0..6).map(|i| self.g[i] * dq[i] * dq[i]).sum::<f64>()
    }
}

/// `a · b` for 6-vectors.
#[inline(always)]
pub(crate) fn dot6(a: &[f64; 6], b: &[f64; 6]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3] + a[4] * b[4] + a[5] * b[5]
}
