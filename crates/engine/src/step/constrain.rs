//! Constrain: the linearized rows of the listed pairs and the trust region (a box, or a slab
//! about a path) that keeps a pass inside its detected region.

use super::*;

/// Shares of a turned trust box's rotation budget (mm of motion) about the turn's own axis,
/// taken by the tool's arm about it, and about each axis across it, taken by the reach:
/// `0.6 + sqrt(2) · 0.28 < 1`, so no point moves farther than in the box.
const TURN_ALONG_BY_ARM: f64 = 0.6;
const TURN_ACROSS_BY_ARM: f64 = 0.28;

/// Largest half-width (rad) of a trust box's turn about its axis: the linearised rows hold
/// the contact's planes only so far.
const MAX_TRUST_TURN_RAD: f64 = 0.5;

/// Two unit vectors completing the unit `d` to an orthonormal basis.
fn complement(d: &[f64; 3]) -> ([f64; 3], [f64; 3]) {
    let d = Vector3::from(*d);
    // Cross with the axis least along `d`.
    let axis = if d.x.abs() <= d.y.abs() && d.x.abs() <= d.z.abs() {
        Vector3::x()
    } else if d.y.abs() <= d.z.abs() {
        Vector3::y()
    } else {
        Vector3::z()
    };
    let e1 = d.cross(&axis).normalize();
    let e2 = d.cross(&e1);
    (e1.into(), e2.into())
}

/// A trust region's rows, `rows[i] . dq >= rhs[i]` for `i < len`: two per axis, six axes.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct TrustRows {
    pub(super) rows: [[f64; 6]; 12],
    pub(super) rhs: [f64; 12],
    pub(super) len: usize,
}

impl TrustRows {
    /// Adds the two rows `lo <= row . dq <= hi`.
    fn push_slab(&mut self, row: &[f64; 6], lo: f64, hi: f64) {
        let n = self.len;
        self.rows[n] = *row;
        self.rhs[n] = lo;
        self.rows[n + 1] = row.map(|v| -v);
        self.rhs[n + 1] = -hi;
        self.len += 2;
    }

    /// Adds the rows `|u . (dq - base)| <= w` for each `(u, w)` of `axes`, `u` in the
    /// translation part of `dq` (`part` 0) or its rotation part (`part` 3).
    fn push_turned(&mut self, part: usize, axes: [([f64; 3], f64); 3], base: &[f64; 6]) {
        for (u, w) in axes {
            let mut row = [0.0; 6];
            row[part..part + 3].copy_from_slice(&u);
            let c = u[0] * base[part] + u[1] * base[part + 1] + u[2] * base[part + 2];
            self.push_slab(&row, c - w, c + w);
        }
    }

    /// Whether `dq` lies inside every row.
    pub(super) fn hold(&self, dq: &[f64; 6]) -> bool {
        (0..self.len).all(|i| (0..6).map(|k| self.rows[i][k] * dq[k]).sum::<f64>() >= self.rhs[i])
    }
}

impl GodObject {
    /// The way from `from` to `to` as the regions measure it: the translation (mm) and the
    /// rotation's angle times the tool's reach (mm, the farthest a tool point turns).
    pub(super) fn way_to(&self, from: &Pose, to: &Pose) -> (f64, f64) {
        let t = (to.translation() - from.translation()).norm();
        let r = rotation_angle(&to.rotation_matrix(), &from.rotation_matrix()) * self.bodies.reach;
        (t, r)
    }

    /// The linearization of the current pair list at `q_lin` for the device pose `q_h`.
    pub(super) fn linearization(&self, q_lin: &Pose, q_h: &Pose) -> Option<Linearization> {
        Linearization::with_coordinates(self.params.form, self.params.rotation, q_lin, q_h).ok()
    }

    /// Fills rows for the region's list from `lin` (a row per leaf pair, or per triangle pair
    /// in the mesh mode), plus the trust region when given, about the variable's values `base`
    /// at the region's centre and `end` at the end of its path. Returns the row count.
    pub(super) fn fill_rows(
        &mut self,
        lin: &Linearization,
        trust: Option<(Trust, [f64; 6], [f64; 6])>,
    ) -> usize {
        let mut n = 0;
        if self.bodies.meshes.is_some() {
            n = self.fill_mesh_rows(lin);
        } else {
            for (pair, (row, d)) in self
                .detector
                .pairs
                .iter()
                .zip(self.qp.rows.iter_mut().zip(self.qp.rhs.iter_mut()))
            {
                let (j, rhs) = lin.row(pair);
                *row = j;
                *d = rhs;
                n += 1;
            }
        }
        if let Some((trust, base, end)) = trust {
            let t = self.trust_rows(trust, &base, &end);
            self.qp.rows[n..n + t.len].copy_from_slice(&t.rows[..t.len]);
            self.qp.rhs[n..n + t.len].copy_from_slice(&t.rhs[..t.len]);
            n += t.len;
        }
        n
    }

    /// The rows `row . dq >= rhs` of the trust region `trust` about the variable's values
    /// `base` at the region's centre and `end` at the end of its path.
    pub(super) fn trust_rows(&self, trust: Trust, base: &[f64; 6], end: &[f64; 6]) -> TrustRows {
        let mut t = TrustRows::default();
        match trust {
            Trust::Box(w_t, w_r) => {
                for k in 0..6 {
                    let w = if k < 3 { w_t } else { w_r };
                    let mut e = [0.0; 6];
                    e[k] = 1.0;
                    t.push_slab(&e, base[k] - w, base[k] + w);
                }
            }
            Trust::Oriented {
                dir,
                along,
                across,
                turn,
                rot,
                rot_across,
            } => {
                // Translation in the basis (dir, e1, e2); rotation in (turn, f1, f2), or per
                // component without a turn.
                let (e1, e2) = complement(&dir);
                t.push_turned(0, [(dir, along), (e1, across), (e2, across)], base);
                if turn == [0.0; 3] {
                    for k in 3..6 {
                        let mut e = [0.0; 6];
                        e[k] = 1.0;
                        t.push_slab(&e, base[k] - rot, base[k] + rot);
                    }
                } else {
                    let (f1, f2) = complement(&turn);
                    t.push_turned(3, [(turn, rot), (f1, rot_across), (f2, rot_across)], base);
                }
            }
            Trust::Slab {
                normal,
                across,
                along,
                spin,
                tilt,
            } => {
                // Translation and rotation each in the basis (normal, e1, e2).
                let (e1, e2) = complement(&normal);
                t.push_turned(0, [(normal, across), (e1, along), (e2, along)], base);
                t.push_turned(3, [(normal, spin), (e1, tilt), (e2, tilt)], base);
            }
            Trust::Path(a) => self.push_path_trust(&mut t, a, base, end),
        }
        t
    }

    /// Writes into `t` the trust rows of a path region: the variable within `a` of the segment
    /// from `base` to `end` (rotations scaled by the tool's reach).
    fn push_path_trust(&self, t: &mut TrustRows, a: f64, base: &[f64; 6], end: &[f64; 6]) {
        // In the variable scaled by reach for rotations (a sphere's motion is at most
        // sqrt(2) times the scaled norm): one direction along the path, five across it
        // (Gram-Schmidt on the unit vectors but the one most along the path).
        let reach = self.bodies.reach.max(1e-9);
        let scale = |k: usize| if k < 3 { 1.0 } else { reach };
        let mut d = [0.0; 6];
        for k in 0..6 {
            d[k] = (end[k] - base[k]) * scale(k);
        }
        let len = d.iter().map(|v| v * v).sum::<f64>().sqrt();
        let mut basis = [[0.0; 6]; 6];
        let skip = if len > 1e-12 {
            basis[0] = d.map(|v| v / len);
            (0..6)
                .max_by(|&i, &j| basis[0][i].abs().total_cmp(&basis[0][j].abs()))
                .unwrap_or(0)
        } else {
            basis[0][0] = 1.0;
            0
        };
        for (m, j) in (1..).zip((0..6).filter(|&j| j != skip)) {
            let mut v = [0.0; 6];
            v[j] = 1.0;
            for b in &basis[..m] {
                let dot: f64 = (0..6).map(|k| v[k] * b[k]).sum();
                for k in 0..6 {
                    v[k] -= dot * b[k];
                }
            }
            let nv = v.iter().map(|x| x * x).sum::<f64>().sqrt();
            basis[m] = v.map(|x| x / nv);
        }
        for (i, u) in basis.iter().enumerate() {
            let mut row = [0.0; 6];
            for k in 0..6 {
                row[k] = u[k] * scale(k);
            }
            let c: f64 = (0..6).map(|k| row[k] * base[k]).sum();
            let far = if i == 0 { len } else { 0.0 };
            t.push_slab(&row, c - a, c + far + a);
        }
    }

    /// True when the answer `dq` sits on the trust region's boundary (rows `from..to`): the
    /// region, not the contact, stopped it.
    pub(super) fn trust_binds(&self, trust: Trust, from: usize, to: usize, dq: &[f64; 6]) -> bool {
        (from..to).any(|i| {
            let width = match trust {
                Trust::Box(w_t, w_r) => {
                    if (i - from) / 2 < 3 {
                        w_t
                    } else {
                        w_r
                    }
                }
                Trust::Path(a) => a,
                Trust::Oriented {
                    along,
                    across,
                    rot,
                    rot_across,
                    ..
                } => match (i - from) / 2 {
                    0 => along,
                    1 | 2 => across,
                    3 => rot,
                    _ => rot_across,
                },
                Trust::Slab {
                    across,
                    along,
                    spin,
                    tilt,
                    ..
                } => match (i - from) / 2 {
                    0 => across,
                    1 | 2 => along,
                    3 => spin,
                    _ => tilt,
                },
            };
            let value: f64 = (0..6).map(|k| self.qp.rows[i][k] * dq[k]).sum();
            value - self.qp.rhs[i] <= 1e-3 * width
        })
    }

    /// The trust box for a pass that may move any tool sphere by at most `allowed` mm from
    /// `q_lin`, when the motion expected needs `need_t` mm of translation and `need_r` mm of
    /// rotation (angle times reach). The budget is shared in proportion to the need (each part keeps at
    /// least a fifth, so the constraints can still push the tool out): translation half-width
    /// `a` per axis moves a point by at most `sqrt(3) a`; rotation half-width `b` per coordinate
    /// by at most `sqrt(3) b reach` (rotation vector) or `3 b reach` (Euler increments).
    /// `reach` is the tool's ([`GodObject::reach`]) or, in a ball region with a near part, the
    /// near leaves' ([`Lever::trust_reach`]).
    pub(super) fn trust_box(&self, allowed: f64, need_t: f64, need_r: f64, reach: f64) -> Trust {
        let need = need_t + need_r;
        let share_t = if need > 0.0 {
            (need_t / need).clamp(0.2, 0.8)
        } else {
            0.5
        };
        let a = allowed * share_t / 3f64.sqrt();
        let per_axis = match self.params.rotation {
            RotationCoordinates::RotationVector => 3f64.sqrt(),
            RotationCoordinates::Euler => 3.0,
        };
        let b = (allowed * (1.0 - share_t) / (per_axis * reach.max(1e-9))).min(0.5);
        Trust::Box(a, b)
    }

    /// [`GodObject::trust_box`] turned to the expected motion: its translation part to the
    /// translation `step` (mm), its rotation part (rotation-vector coordinates) to the turn
    /// `turn` (a rotation vector, rad). Each part's budget (`sqrt(3)` times its half-width
    /// per axis in the box) is split into 0.85 of it along the motion and 0.37 across
    /// (`sqrt(0.85² + 2 · 0.37²) < 1`: no sphere moves farther than in the box), so a tool
    /// sliding along `step` or turning about `turn` goes 0.85 of it instead of `1 / sqrt(3)`;
    /// or the turn goes 0.6 of the rotation budget by the tool's arm about its axis (the tool at
    /// rotation `rot_lin`), where that is farther, and 0.28 across. A part stays axis-aligned
    /// where its motion is too short to give a direction.
    pub(super) fn trust_oriented(
        &self,
        allowed: f64,
        need_t: f64,
        need_r: f64,
        (step, turn): (&Vector3<f64>, &Vector3<f64>),
        reach: f64,
        rot_lin: &Matrix3<f64>,
    ) -> Trust {
        let Trust::Box(a, b) = self.trust_box(allowed, need_t, need_r, reach) else {
            return self.trust_box(allowed, need_t, need_r, reach);
        };
        let (len, angle) = (step.norm(), turn.norm());
        let slides = len.is_finite() && len > 1e-9 * allowed.max(1e-9);
        let turns = self.params.rotation == RotationCoordinates::RotationVector
            && angle.is_finite()
            && angle > 1e-9 * b.max(1e-12);
        // (An axis-aligned part is written in any orthonormal basis with equal widths.)
        let (dir, along, across) = if slides {
            let budget = a * 3f64.sqrt();
            ((step / len).into(), 0.85 * budget, 0.37 * budget)
        } else {
            ([1.0, 0.0, 0.0], a, a)
        };
        let (turn, rot, rot_across) = if turns {
            let axis = turn / angle;
            let budget = b * 3f64.sqrt();
            // About its own axis a turn moves the tool's points by the angle times their
            // distance from the axis (the arm), which is far less than `reach` for a shaft
            // turning in its hole or a disc spinning on a face. With the triangle inequality
            // (`|w × p| <= |w_u| arm + |w_across| reach`) the budget splits into 0.6 about the
            // axis (by the arm) and 0.28 about each axis across (by `reach`): `0.6 + sqrt(2)
            // 0.28 < 1`. Taken where it turns farther than the ball's 0.85 of the budget.
            // The box's corners' arm, not the tighter `CentreBox::arm` of the motion bounds:
            // the split was tuned on it, and the tighter arm let the keyed shaft's reused
            // regions bind more often (frames of three passes 14 -> 23, against 15 -> 4 on
            // `spline-tight`'s turn).
            let arm = self.bodies.centres.corner_arm(rot_lin, &axis).min(reach);
            let by_arm = TURN_ALONG_BY_ARM * budget * reach / arm.max(1e-12);
            if by_arm > 0.85 * budget && arm > 0.0 {
                (
                    axis.into(),
                    by_arm.min(MAX_TRUST_TURN_RAD),
                    TURN_ACROSS_BY_ARM * budget,
                )
            } else {
                (axis.into(), 0.85 * budget, 0.37 * budget)
            }
        } else {
            ([0.0; 3], b, b)
        };
        Trust::Oriented {
            dir,
            along,
            across,
            turn,
            rot,
            rot_across,
        }
    }

    /// The trust box of a slab region across the face with unit normal `n` (`across`, mm) and
    /// sliding along it (`slide`, mm): every tool sphere moves at most `across` across the face
    /// (translation half of it, tilts the other half: a turn `w` moves a point across by at
    /// most `|n × w| reach`) and at most `slide` in all (the rest of the slide shared by
    /// translation along the face and spin about `n`, in proportion to last frame's, each
    /// keeping 0.3 of it at least).
    pub(super) fn trust_slab(&self, n: &Vector3<f64>, across: f64, slide: f64) -> Trust {
        let reach = self.bodies.reach.max(1e-9);
        let t_across = 0.5 * across;
        let tilt = 0.5 * across / (2f64.sqrt() * reach);
        let step = Vector3::from(self.run.motion.last_step);
        let turn = Vector3::from(self.run.motion.last_turn);
        let (moved, spun) = (step.norm(), n.dot(&turn).abs() * reach);
        let share_t = if moved + spun > 0.0 {
            (moved / (moved + spun)).clamp(0.3, 0.7)
        } else {
            0.5
        };
        // |dt| <= sqrt(t_across² + 2 along²) <= slide · share_t and
        // |w| reach <= sqrt(spin² + 2 tilt²) reach <= slide · (1 - share_t).
        let (budget_t, budget_r) = (slide * share_t, slide * (1.0 - share_t));
        let along = ((budget_t * budget_t - t_across * t_across).max(0.0) / 2.0).sqrt();
        let spin = ((budget_r / reach).powi(2) - 2.0 * tilt * tilt)
            .max(0.0)
            .sqrt();
        Trust::Slab {
            normal: (*n).into(),
            across: t_across,
            along,
            spin,
            tilt,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::step::detect::tests::shaft;

    /// The trust rows written for `trust` about zero, as (row, half-width) per axis: each
    /// axis is written as `u . dq >= -w` and `-u . dq >= -w`.
    fn axes(g: &mut GodObject, trust: Trust) -> (Vec<([f64; 6], f64)>, usize) {
        let q = Pose::identity();
        let lin = g.linearization(&q, &q).unwrap();
        let n = g.fill_rows(&lin, Some((trust, [0.0; 6], [0.0; 6])));
        let axes = (0..n / 2)
            .map(|k| {
                let (lo, hi) = (g.qp.rhs[2 * k], -g.qp.rhs[2 * k + 1]);
                assert!((lo + hi).abs() < 1e-12, "the box is centred on its base");
                (g.qp.rows[2 * k], 0.5 * (hi - lo))
            })
            .collect();
        (axes, n)
    }

    fn norm(v: &[f64]) -> f64 {
        v.iter().map(|x| x * x).sum::<f64>().sqrt()
    }

    /// Turned to any translation and any turn, or to neither, at any share of translation
    /// against rotation, no corner of the box moves a point of the tool (its centres' box)
    /// within `reach` of its origin by more than the region allows (`|dt| + |w_u| arm +
    /// |w_across| reach`, and the exact motion of such points), and the box reaches its
    /// budget's `0.85` along the motion it is turned to, or `0.6` of it by the arm about the
    /// turn's axis where that is farther (a shaft about its own axis); at every corner the box
    /// binds.
    #[test]
    fn a_turned_box_moves_no_point_farther_than_its_ball_and_goes_farther_along_its_way() {
        let mut g = shaft();
        let centres = g.bodies.centres;
        let allowed = 0.11;
        let dirs = [
            Vector3::zeros(),
            Vector3::new(0.0, 0.0, -0.012),
            Vector3::new(0.53, 0.47, 0.71),
            Vector3::new(-1e-3, 2e-3, 5e-4),
        ];
        let mut by_arm = 0;
        // A near part's reach (the arm about z is larger) and more than the whole tool's.
        for reach in [22.9, 60.0] {
            let points: Vec<Vector3<f64>> = (0..8)
                .map(|c| centres.corner(c))
                .chain([Vector3::new(12.0, 0.0, 0.0), Vector3::new(0.0, -12.0, 20.0)])
                .map(|p| p * (reach / p.norm()).min(1.0))
                .collect();
            for step in &dirs {
                for turn in &dirs {
                    for (need_t, need_r) in [(1.0, 0.0), (0.2, 1.8), (0.5, 0.5), (0.0, 0.0)] {
                        let trust = g.trust_oriented(
                            allowed,
                            need_t,
                            need_r,
                            (step, turn),
                            reach,
                            &Matrix3::identity(),
                        );
                        let (axes, n) = axes(&mut g, trust);
                        assert_eq!(axes.len(), 6);
                        let axis = turn.normalize();
                        let arm = centres.corner_arm(&Matrix3::identity(), &axis).min(reach);
                        for signs in 0..64u32 {
                            let mut dq = [0.0; 6];
                            for (k, (u, w)) in axes.iter().enumerate() {
                                let s = if signs >> k & 1 == 1 { 1.0 } else { -1.0 };
                                for (d, x) in dq.iter_mut().zip(u) {
                                    *d += s * w * x;
                                }
                            }
                            let dt = norm(&dq[..3]);
                            let w = Vector3::new(dq[3], dq[4], dq[5]);
                            // Two bounds on a point's motion: by the turn's norm, and by its
                            // parts about the axis (by the arm) and across (by the reach).
                            let mut bound = dt + w.norm() * reach;
                            if turn.norm() > 0.0 {
                                let about = w.dot(&axis);
                                bound = bound.min(
                                    dt + about.abs() * arm + (w - axis * about).norm() * reach,
                                );
                            }
                            assert!(bound <= allowed * (1.0 + 1e-9), "{trust:?}: {bound}");
                            let turned = rotation_exp(&w);
                            for p in &points {
                                let moved = Vector3::new(dq[0], dq[1], dq[2]) + turned * p - p;
                                assert!(moved.norm() <= allowed * (1.0 + 1e-9), "{trust:?}");
                            }
                            assert!(g.trust_binds(trust, 0, n, &dq));
                        }
                        let share_t = (need_t / (need_t + need_r)).clamp(0.2, 0.8);
                        let share_t = if need_t + need_r > 0.0 { share_t } else { 0.5 };
                        if step.norm() > 0.0 {
                            // Along the step: 0.85 of the translation budget.
                            let along = axes[..3]
                                .iter()
                                .map(|(u, w)| w * (u[0] * step.x + u[1] * step.y + u[2] * step.z))
                                .map(f64::abs)
                                .fold(0.0, f64::max)
                                / step.norm();
                            assert!(
                                (along - 0.85 * allowed * share_t).abs() < 1e-12,
                                "{trust:?}"
                            );
                        }
                        if turn.norm() > 0.0 {
                            let about = axes[3..]
                                .iter()
                                .map(|(u, w)| w * (u[3] * turn.x + u[4] * turn.y + u[5] * turn.z))
                                .map(f64::abs)
                                .fold(0.0, f64::max)
                                / turn.norm();
                            let budget = (allowed * (1.0 - share_t) / reach).min(0.5 * 3f64.sqrt());
                            let arm_turn = 0.6 * budget * reach / arm;
                            let want = if arm_turn > 0.85 * budget {
                                by_arm += 1;
                                arm_turn
                            } else {
                                0.85 * budget
                            };
                            assert!((about - want).abs() < 1e-12, "{trust:?}");
                        }
                    }
                }
            }
        }
        // The shaft turning about its own axis with the whole tool's reach goes by its arm.
        assert!(by_arm > 0);
    }
}
