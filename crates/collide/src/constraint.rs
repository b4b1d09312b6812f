//! Linearized non-penetration constraints `J dq >= d` for the haptic QP (docs/DESIGN.md
//! §Constraints).
//!
//! For a pair with tool sphere centre `p` (tool frame), radius `r_t`, object sphere centre `o`
//! (world), radius `r_o`, and `c(q) = R(q) p + (x, y, z)`:
//! - [`ConstraintForm::Squared`] (the paper's): `C(q) = |c(q) - o|^2 - (r_t + r_o)^2` (mm²);
//! - [`ConstraintForm::Distance`] (default): `C(q) = |c(q) - o| - (r_t + r_o)` (mm), the signed
//!   gap.
//!
//! Both are linearized at `q_lin` (= `q_g_prev`): `C(q_lin) + J (q - q_lin) >= 0` with
//! `J = dC/dq` (1×6, exact partials of `R`), written as `J dq >= d` with `dq = q - q_h`:
//! `d = J (q_lin - q_h) - C(q_lin)`.
//!
//! Why the distance form is the default: since `C_sq = (D - s)(D + s)` with `D = |c - o|`,
//! `s = r_t + r_o`, the squared row equals `2D` times `(D - s)(D + s)/(2D) + dD/dq · dq >= 0`;
//! near contact (`D ≈ s`) the factor `(D + s)/(2D) ≈ 1`, so both forms give the same feasible
//! half-space to first order, but the distance rows have unit-norm translational part (the
//! contact normal) instead of a scale of `2D` mm, which keeps the QP's dual well scaled across
//! sphere sizes. Far from contact the squared form's half-space is looser.
//!
//! Rotation coordinates ([`RotationCoordinates`]):
//! - `Euler` (the paper's): the QP variable is `dq = q - q_h` in `(x, y, z, gamma, beta, alpha)`;
//!   `q_lin - q_h` is taken component-wise, so the caller keeps the angles continuous between
//!   frames, and the metric is singular at `beta = ±pi/2`.
//! - `RotationVector` (default of the step): the rotation is a local increment `w` about the
//!   linearisation pose, `R = exp([w]x) R_lin`, and the variable is
//!   `dq = (t - t_h, w - w_h)` with `w_h = log(R_h R_lin^T)`. Its partials are
//!   `d(R p)/dw_k = e_k x (R p)`: the world axes, the same at every orientation, so the QP
//!   has no singularity and any representation of `R_h` gives the same rows.

use nalgebra::{Matrix3, Vector3};

use crate::{CollideError, FacePlane, LeafPair, Pose, StandIn};

/// Which constraint function the rows linearize (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum ConstraintForm {
    /// The paper's `C = |c - o|^2 - (r_t + r_o)^2` (mm²); `J` in mm (translation) and mm²/rad.
    Squared,
    /// The signed gap `C = |c - o| - (r_t + r_o)` (mm); `J` unitless (translation) and mm/rad.
    #[default]
    Distance,
}

/// The coordinates of the rotational part of the QP variable (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum RotationCoordinates {
    /// Euler angle differences `(gamma, beta, alpha) - (gamma_h, beta_h, alpha_h)` (the paper's).
    Euler,
    /// A rotation vector about the linearisation pose, in world axes (rad).
    #[default]
    RotationVector,
}

/// Below this centre distance (mm) the direction `c - o` is undefined; see
/// [`Linearization::value_gradient`].
pub const DEGENERATE_DISTANCE: f64 = 1e-9;

/// Everything about `q_lin` and `q_h` that all rows of a frame share: `R(q_lin)`, its three
/// partials, the translation and `q_lin - q_h`. Build once per frame, then call
/// [`Linearization::row`] per pair.
#[derive(Clone, Copy, Debug)]
pub struct Linearization {
    form: ConstraintForm,
    coords: RotationCoordinates,
    rot: Matrix3<f64>,
    /// World axes of the three rotational coordinates (Euler rates, or `e_x, e_y, e_z` for a
    /// rotation vector) (gamma, beta, alpha): `dR/dtheta_k = [w_k]x R`.
    axes: [Vector3<f64>; 3],
    t: Vector3<f64>,
    /// The Euler angles of `q_lin` (rad), to map an Euler-coordinate answer back.
    euler_lin: [f64; 3],
    delta: [f64; 6],
}

impl Linearization {
    /// Linearization of `form` at `q_lin` (mm, rad) for the QP variable `dq = q - q_h`.
    /// Errors on a non-finite pose.
    ///
    /// # Real-time
    /// No allocation, no panic, constant time.
    pub fn new(form: ConstraintForm, q_lin: &Pose, q_h: &Pose) -> Result<Self, CollideError> {
        Self::with_coordinates(form, RotationCoordinates::Euler, q_lin, q_h)
    }

    /// Linearization of `form` at `q_lin` (mm, rad) in the given rotation coordinates (see the
    /// module docs). Errors on a non-finite pose.
    ///
    /// # Real-time
    /// No allocation, no panic, constant time.
    pub fn with_coordinates(
        form: ConstraintForm,
        coords: RotationCoordinates,
        q_lin: &Pose,
        q_h: &Pose,
    ) -> Result<Self, CollideError> {
        if !q_lin.is_finite() || !q_h.is_finite() {
            return Err(CollideError::NonFinitePose);
        }
        let q = &q_lin.q;
        let mut delta = [0.0; 6];
        for (k, d) in delta.iter_mut().enumerate() {
            *d = q_lin.q[k] - q_h.q[k];
        }
        // R = Rz(alpha) Ry(beta) Rx(gamma): dR/dalpha = [e_z]x R, dR/dbeta = [Rz e_y]x R,
        // dR/dgamma = [Rz Ry e_x]x R (exact, any angles). So d(R p)/dtheta_k = w_k x (R p) and
        // g . (w_k x R p) = w_k . (R p x g).
        let (sb, cb) = q[4].sin_cos();
        let (sa, ca) = q[5].sin_cos();
        let rot = q_lin.rotation_matrix();
        let axes = match coords {
            RotationCoordinates::Euler => [
                Vector3::new(ca * cb, sa * cb, -sb),
                Vector3::new(-sa, ca, 0.0),
                Vector3::new(0.0, 0.0, 1.0),
            ],
            RotationCoordinates::RotationVector => {
                // w = 0 at q_lin, so the rotational part of q_lin - q_h is -w_h.
                let w_h = crate::pose::rotation_log(&(q_h.rotation_matrix() * rot.transpose()));
                delta[3] = -w_h.x;
                delta[4] = -w_h.y;
                delta[5] = -w_h.z;
                [Vector3::x(), Vector3::y(), Vector3::z()]
            }
        };
        Ok(Self {
            form,
            coords,
            rot,
            axes,
            t: q_lin.translation(),
            euler_lin: [q[3], q[4], q[5]],
            delta,
        })
    }

    /// The linearisation pose's rotation (`R(q_lin)`, bit for bit `q_lin.rotation_matrix()`)
    /// and translation (mm).
    pub fn pose_parts(&self) -> (Matrix3<f64>, Vector3<f64>) {
        (self.rot, self.t)
    }

    /// The form being linearized.
    pub fn form(&self) -> ConstraintForm {
        self.form
    }

    /// The rotation coordinates of the variable.
    pub fn coordinates(&self) -> RotationCoordinates {
        self.coords
    }

    /// `q_lin - q_h` in this linearization's coordinates (mm, rad): the value of the QP
    /// variable at the linearisation pose.
    pub fn delta(&self) -> [f64; 6] {
        self.delta
    }

    /// The QP variable's value (mm, rad) at the configuration `q`, the inverse of
    /// [`Linearization::configuration`] (rotation vectors: `log(R_q R_lin^T) - w_h`, exact for
    /// angles below pi).
    ///
    /// # Real-time
    /// No allocation, no panic, constant time.
    pub fn variable(&self, q: &Pose) -> [f64; 6] {
        let mut v = [0.0; 6];
        for k in 0..3 {
            v[k] = q.q[k] - self.t[k] + self.delta[k];
        }
        match self.coords {
            RotationCoordinates::Euler => {
                for k in 3..6 {
                    v[k] = q.q[k] - self.euler_lin[k - 3] + self.delta[k];
                }
            }
            RotationCoordinates::RotationVector => {
                let w = crate::pose::rotation_log(&(q.rotation_matrix() * self.rot.transpose()));
                for k in 3..6 {
                    v[k] = w[k - 3] + self.delta[k];
                }
            }
        }
        v
    }

    /// The configuration whose QP variable is `dq` (mm, rad): `q_h + dq` in Euler coordinates;
    /// `t_h + dq_t` and `exp([dq_w + w_h]x) R_lin` for a rotation vector.
    ///
    /// # Real-time
    /// No allocation, no panic, constant time.
    pub fn configuration(&self, dq: &[f64; 6]) -> Pose {
        // Both coordinates give the translation t_lin + (dq_t - delta_t).
        let t = self.t
            + Vector3::new(
                dq[0] - self.delta[0],
                dq[1] - self.delta[1],
                dq[2] - self.delta[2],
            );
        match self.coords {
            RotationCoordinates::Euler => {
                let mut q = [0.0; 6];
                q[..3].copy_from_slice(t.as_slice());
                for k in 3..6 {
                    q[k] = self.euler_lin[k - 3] + dq[k] - self.delta[k];
                }
                Pose::from_array(q)
            }
            RotationCoordinates::RotationVector => {
                let w = Vector3::new(
                    dq[3] - self.delta[3],
                    dq[4] - self.delta[4],
                    dq[5] - self.delta[5],
                );
                let rot = crate::pose::rotation_exp(&w) * self.rot;
                Pose::from_translation_rotation(&t, &rot)
            }
        }
    }

    /// `C(q_lin)` and `J = dC/dq (q_lin)` for a tool sphere (`p_in_tool`, `r_tool`; mm) and an
    /// object sphere (`o_in_world`, `r_object`; mm).
    ///
    /// When the centres (nearly) coincide (`|c - o| < DEGENERATE_DISTANCE`) the direction
    /// `c - o` is undefined (and the squared form's gradient vanishes); both forms then use the
    /// unit direction `n` from `o` to the tool origin (or `+z` if that too is degenerate), with
    /// the gradient's contact magnitude (`J = [n, n·dR p]`, times `2 (r_t + r_o)` for the squared
    /// form), so the row still pushes the tool out.
    ///
    /// # Real-time
    /// No allocation, no panic, constant time.
    #[inline]
    pub fn value_gradient(
        &self,
        p_in_tool: &[f64; 3],
        r_tool: f64,
        o_in_world: &[f64; 3],
        r_object: f64,
    ) -> (f64, [f64; 6]) {
        let p = Vector3::from(*p_in_tool);
        let o = Vector3::from(*o_in_world);
        let rp = self.rot * p;
        let c = rp + self.t;
        let v = c - o;
        let dist = v.norm();
        let s = r_tool + r_object;
        let (value, dir, scale) = match self.form {
            ConstraintForm::Squared => {
                let value = dist * dist - s * s;
                if dist < DEGENERATE_DISTANCE {
                    (value, self.fallback_direction(&o), 2.0 * s)
                } else {
                    (value, v, 2.0)
                }
            }
            ConstraintForm::Distance => {
                let value = dist - s;
                if dist < DEGENERATE_DISTANCE {
                    (value, self.fallback_direction(&o), 1.0)
                } else {
                    (value, v / dist, 1.0)
                }
            }
        };
        (value, self.gradient(&rp, &(dir * scale)))
    }

    /// `C(q_lin)` and `J = dC/dq (q_lin)` for a tool sphere (`p_in_tool`, `r_tool`; mm) and a
    /// face's half-space `normal . x <= offset` (world; a pair with
    /// [`LeafPair::on_face`]): the distance form is the signed gap
    /// `h - r_tool`, `h = normal . c - offset`; the squared form, which has no meaning for a
    /// plane, is `2 r_tool (h - r_tool)`: the first-order value of `|c - o|^2 - s^2` at
    /// contact, scaled by the tool sphere (the plane's own radius is infinite).
    ///
    /// # Real-time
    /// No allocation, no panic, constant time.
    #[inline]
    pub fn face_value_gradient(
        &self,
        p_in_tool: &[f64; 3],
        r_tool: f64,
        normal: &[f64; 3],
        offset: f64,
    ) -> (f64, [f64; 6]) {
        let n = Vector3::from(*normal);
        let rp = self.rot * Vector3::from(*p_in_tool);
        let gap = n.dot(&(rp + self.t)) - offset - r_tool;
        let scale = match self.form {
            ConstraintForm::Squared => 2.0 * r_tool,
            ConstraintForm::Distance => 1.0,
        };
        (scale * gap, self.gradient(&rp, &(n * scale)))
    }

    /// `C(q_lin)` and `J` for a pair that stands for a lens (the object sphere cut by the face's
    /// plane, [`StandIn::Lens`]): the row of the plane tangent to the lens at its point nearest
    /// the tool sphere's centre ([`Linearization::face_value_gradient`] with that plane), whose
    /// value and gradient are the distance's at `q_lin` (the distance to a convex set is
    /// differentiable outside it, its gradient the unit direction from the nearest point).
    ///
    /// # Real-time
    /// No allocation, no panic, constant time.
    #[inline]
    pub fn lens_value_gradient(&self, pair: &LeafPair, face: &FacePlane) -> (f64, [f64; 6]) {
        let c = self.rot * Vector3::from(pair.p_in_tool) + self.t;
        match face.lens_distance(pair.o_in_world, pair.r_object, c.into()) {
            Some((d, n)) => {
                let n = Vector3::from(n);
                // The tangent plane `n . x = n . c - d` passes through the nearest point.
                self.face_value_gradient(&pair.p_in_tool, pair.r_tool, &n.into(), n.dot(&c) - d)
            }
            None => self.value_gradient(
                &pair.p_in_tool,
                pair.r_tool,
                &pair.o_in_world,
                pair.r_object,
            ),
        }
    }

    /// The 1×6 gradient of a constraint whose derivative with respect to the tool point
    /// `R p + t` is `g`, with `rp = R p` (mm): `[g, axes_k . (rp x g)]`.
    #[inline]
    fn gradient(&self, rp: &Vector3<f64>, g: &Vector3<f64>) -> [f64; 6] {
        let m = rp.cross(g);
        [
            g.x,
            g.y,
            g.z,
            self.axes[0].dot(&m),
            self.axes[1].dot(&m),
            self.axes[2].dot(&m),
        ]
    }

    fn fallback_direction(&self, o: &Vector3<f64>) -> Vector3<f64> {
        let v = self.t - o;
        let n = v.norm();
        if n >= DEGENERATE_DISTANCE {
            v / n
        } else {
            Vector3::z()
        }
    }

    /// The row `(J, d)` of `J dq >= d` for one pair: `d = J (q_lin - q_h) - C(q_lin)`.
    ///
    /// # Real-time
    /// No allocation, no panic, constant time.
    #[inline]
    pub fn row(&self, pair: &LeafPair) -> ([f64; 6], f64) {
        let (c, j) = match pair.stand_in() {
            StandIn::HalfSpace(f) => {
                self.face_value_gradient(&pair.p_in_tool, pair.r_tool, &f.normal, f.offset)
            }
            StandIn::Lens(f) => self.lens_value_gradient(pair, &f),
            StandIn::Sphere => self.value_gradient(
                &pair.p_in_tool,
                pair.r_tool,
                &pair.o_in_world,
                pair.r_object,
            ),
        };
        let jd: f64 = j.iter().zip(&self.delta).map(|(a, b)| a * b).sum();
        (j, jd - c)
    }
}

/// The exact (not linearized) constraint value `C(q)` of `form` at `pose` (mm, rad) for a tool
/// sphere (`p_in_tool`, `r_tool`) and an object sphere (`o_in_world`, `r_object`), all mm.
pub fn constraint_value(
    form: ConstraintForm,
    pose: &Pose,
    p_in_tool: &[f64; 3],
    r_tool: f64,
    o_in_world: &[f64; 3],
    r_object: f64,
) -> f64 {
    let c = pose.rotation_matrix() * Vector3::from(*p_in_tool) + pose.translation();
    let dist = (c - Vector3::from(*o_in_world)).norm();
    let s = r_tool + r_object;
    match form {
        ConstraintForm::Squared => dist * dist - s * s,
        ConstraintForm::Distance => dist - s,
    }
}

/// The exact constraint value `C(q)` of `form` at `pose` (mm, rad) for a pair: its object
/// sphere's ([`constraint_value`]) or, for a face's half-space or lens ([`LeafPair::stand_in`]),
/// its gap scaled as the face rows are ([`Linearization::face_value_gradient`]).
pub fn pair_constraint_value(form: ConstraintForm, pose: &Pose, pair: &LeafPair) -> f64 {
    if pair.face.is_some() {
        // A half-space or a lens: the distance form's gap, scaled as the face rows are.
        let gap = pair.gap_at(pose);
        match form {
            ConstraintForm::Squared => 2.0 * pair.r_tool * gap,
            ConstraintForm::Distance => gap,
        }
    } else {
        constraint_value(
            form,
            pose,
            &pair.p_in_tool,
            pair.r_tool,
            &pair.o_in_world,
            pair.r_object,
        )
    }
}

/// Fills `rows[k]` (`J_k`) and `rhs[k]` (`d_k`) of `J dq >= d` (`dq = q - q_h`), linearized at
/// `q_lin`, for every pair; returns the number of rows written (`pairs.len()`).
///
/// Errors, writing nothing, if a buffer is shorter than `pairs` or a pose is not finite.
///
/// # Real-time
/// No allocation, no panic, O(pairs).
pub fn fill_constraints(
    form: ConstraintForm,
    q_lin: &Pose,
    q_h: &Pose,
    pairs: &[LeafPair],
    rows: &mut [[f64; 6]],
    rhs: &mut [f64],
) -> Result<usize, CollideError> {
    if rows.len() < pairs.len() || rhs.len() < pairs.len() {
        return Err(CollideError::BufferTooSmall {
            needed: pairs.len(),
            rows: rows.len(),
            rhs: rhs.len(),
        });
    }
    let lin = Linearization::new(form, q_lin, q_h)?;
    for ((pair, row), d) in pairs.iter().zip(rows.iter_mut()).zip(rhs.iter_mut()) {
        let (j, dk) = lin.row(pair);
        *row = j;
        *d = dk;
    }
    Ok(pairs.len())
}
