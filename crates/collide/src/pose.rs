//! Tool configurations `q = (x, y, z, gamma, beta, alpha)` (mm, rad) and their rigid transforms.
//!
//! `R(q) = Rz(alpha) · Ry(beta) · Rx(gamma)` (the paper's matrix (6)), and
//! `world_from_tool(p) = R(q) p + (x, y, z)`.

use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3, Vector6};

/// A 6-D configuration `q = (x, y, z, gamma, beta, alpha)`: translation in mm, Euler angles in
/// rad with `R = Rz(alpha) Ry(beta) Rx(gamma)`.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Pose {
    /// `(x, y, z, gamma, beta, alpha)`: mm, mm, mm, rad, rad, rad.
    pub q: Vector6<f64>,
}

impl Pose {
    /// The identity configuration (all zeros).
    pub fn identity() -> Self {
        Self {
            q: Vector6::zeros(),
        }
    }

    /// From `[x, y, z, gamma, beta, alpha]` (mm, rad).
    pub fn from_array(q: [f64; 6]) -> Self {
        Self {
            q: Vector6::from(q),
        }
    }

    /// As `[x, y, z, gamma, beta, alpha]` (mm, rad).
    pub fn to_array(&self) -> [f64; 6] {
        self.q.into()
    }

    /// Translation `(x, y, z)` in mm.
    #[inline]
    pub fn translation(&self) -> Vector3<f64> {
        Vector3::new(self.q[0], self.q[1], self.q[2])
    }

    /// `R(q) = Rz(alpha) Ry(beta) Rx(gamma)`.
    #[inline]
    pub fn rotation_matrix(&self) -> Matrix3<f64> {
        rotation_zyx(self.q[3], self.q[4], self.q[5])
    }

    /// `world_from_tool` as an isometry.
    pub fn to_isometry(&self) -> Isometry3<f64> {
        let rot = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(
            self.rotation_matrix(),
        ));
        Isometry3::from_parts(Translation3::from(self.translation()), rot)
    }

    /// The configuration of an isometry (Euler angles with `beta` in `[-pi/2, pi/2]`).
    pub fn from_isometry(iso: &Isometry3<f64>) -> Self {
        // nalgebra's euler_angles returns (roll, pitch, yaw) for R = Rz(yaw) Ry(pitch) Rx(roll).
        let (gamma, beta, alpha) = iso.rotation.euler_angles();
        let t = iso.translation.vector;
        Self {
            q: Vector6::new(t.x, t.y, t.z, gamma, beta, alpha),
        }
    }

    /// The configuration of a translation (mm) and a rotation matrix, with Euler angles as in
    /// [`Pose::from_isometry`] (`beta` in `[-pi/2, pi/2]`; at `beta = ±pi/2` one of the many
    /// equivalent `(gamma, alpha)` pairs). `rotation_matrix()` of the result reproduces `rot`
    /// (to rounding) for every proper rotation, so no orientation is lost.
    pub fn from_translation_rotation(t: &Vector3<f64>, rot: &Matrix3<f64>) -> Self {
        let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(*rot));
        let (gamma, beta, alpha) = q.euler_angles();
        Self {
            q: Vector6::new(t.x, t.y, t.z, gamma, beta, alpha),
        }
    }

    /// True when all six numbers are finite.
    #[inline]
    pub fn is_finite(&self) -> bool {
        self.q.iter().all(|v| v.is_finite())
    }
}

/// The rotation vector (axis times angle, rad, angle in `[0, pi]`) of a rotation matrix: the
/// inverse of [`rotation_exp`]. Accurate at every angle: through the unit quaternion and
/// `atan2`, so neither tiny angles (where `acos` loses digits) nor angles near `pi` degrade.
#[inline]
pub fn rotation_log(rot: &Matrix3<f64>) -> Vector3<f64> {
    let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(*rot));
    let (mut w, mut v) = (q.w, q.imag());
    if w < 0.0 {
        // q and -q are the same rotation; this one has the angle in [0, pi].
        w = -w;
        v = -v;
    }
    let n = v.norm();
    // angle = 2 atan2(n, w); scale = angle / n, with its limit 2 / w as n -> 0.
    let scale = if n > 1e-8 {
        2.0 * n.atan2(w) / n
    } else {
        2.0 / w * (1.0 - n * n / (3.0 * w * w))
    };
    v * scale
}

/// The rotation matrix `exp([w]x)` of a rotation vector `w` (axis times angle, rad).
#[inline]
pub fn rotation_exp(w: &Vector3<f64>) -> Matrix3<f64> {
    *Rotation3::from_scaled_axis(*w).matrix()
}

/// `Rz(alpha) · Ry(beta) · Rx(gamma)` (rad).
#[inline]
pub fn rotation_zyx(gamma: f64, beta: f64, alpha: f64) -> Matrix3<f64> {
    let (sg, cg) = gamma.sin_cos();
    let (sb, cb) = beta.sin_cos();
    let (sa, ca) = alpha.sin_cos();
    Matrix3::new(
        ca * cb,
        ca * sb * sg - sa * cg,
        ca * sb * cg + sa * sg,
        sa * cb,
        sa * sb * sg + ca * cg,
        sa * sb * cg - ca * sg,
        -sb,
        cb * sg,
        cb * cg,
    )
}

/// The exact partial derivatives of `R = Rz(alpha) Ry(beta) Rx(gamma)` with respect to
/// `(gamma, beta, alpha)` (rad): `[dR/dgamma, dR/dbeta, dR/dalpha]`.
pub fn rotation_zyx_partials(gamma: f64, beta: f64, alpha: f64) -> [Matrix3<f64>; 3] {
    let (sg, cg) = gamma.sin_cos();
    let (sb, cb) = beta.sin_cos();
    let (sa, ca) = alpha.sin_cos();
    let rx = Matrix3::new(1.0, 0.0, 0.0, 0.0, cg, -sg, 0.0, sg, cg);
    let ry = Matrix3::new(cb, 0.0, sb, 0.0, 1.0, 0.0, -sb, 0.0, cb);
    let rz = Matrix3::new(ca, -sa, 0.0, sa, ca, 0.0, 0.0, 0.0, 1.0);
    let drx = Matrix3::new(0.0, 0.0, 0.0, 0.0, -sg, -cg, 0.0, cg, -sg);
    let dry = Matrix3::new(-sb, 0.0, cb, 0.0, 0.0, 0.0, -cb, 0.0, -sb);
    let drz = Matrix3::new(-sa, -ca, 0.0, ca, -sa, 0.0, 0.0, 0.0, 0.0);
    [rz * ry * drx, rz * dry * rx, drz * ry * rx]
}

impl Pose {
    /// `world_from_tool * p_in_tool` (mm).
    #[inline]
    pub fn transform_point(&self, p_in_tool: &[f64; 3]) -> [f64; 3] {
        let w = self.rotation_matrix() * Vector3::from(*p_in_tool) + self.translation();
        [w.x, w.y, w.z]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotation_matches_product_of_axis_rotations() {
        let (g, b, a) = (0.3, -0.7, 1.9);
        let r = Rotation3::from_axis_angle(&Vector3::z_axis(), a)
            * Rotation3::from_axis_angle(&Vector3::y_axis(), b)
            * Rotation3::from_axis_angle(&Vector3::x_axis(), g);
        assert!((r.matrix() - rotation_zyx(g, b, a)).norm() < 1e-12);
    }

    #[test]
    fn partials_match_finite_differences() {
        let (g, b, a) = (0.3, -0.7, 1.9);
        let d = rotation_zyx_partials(g, b, a);
        let h = 1e-6;
        let fd = [
            (rotation_zyx(g + h, b, a) - rotation_zyx(g - h, b, a)) / (2.0 * h),
            (rotation_zyx(g, b + h, a) - rotation_zyx(g, b - h, a)) / (2.0 * h),
            (rotation_zyx(g, b, a + h) - rotation_zyx(g, b, a - h)) / (2.0 * h),
        ];
        for k in 0..3 {
            assert!(
                (d[k] - fd[k]).norm() < 1e-8,
                "partial {k}: {} vs {}",
                d[k],
                fd[k]
            );
        }
    }

    #[test]
    fn isometry_round_trip() {
        let p = Pose::from_array([1.0, -2.0, 3.0, 0.4, -0.2, 2.5]);
        let back = Pose::from_isometry(&p.to_isometry());
        assert!((back.q - p.q).norm() < 1e-12, "{back:?}");
    }

    /// `rotation_log` inverts `rotation_exp` from tiny angles to just below pi, and
    /// `from_translation_rotation` keeps the orientation at the Euler singularity.
    #[test]
    fn log_exp_round_trip_and_gimbal_lock() {
        for (k, angle) in [
            1e-12,
            1e-7,
            1e-3,
            0.5,
            2.0,
            3.0,
            std::f64::consts::PI - 1e-5,
        ]
        .into_iter()
        .enumerate()
        {
            let axis = Vector3::new(0.3 + k as f64, -0.8, 0.5).normalize();
            let w = axis * angle;
            let back = rotation_log(&rotation_exp(&w));
            assert!(
                (back - w).norm() <= 1e-12 * angle.max(1.0),
                "{angle}: {back:?} vs {w:?}"
            );
        }
        for beta in [
            std::f64::consts::FRAC_PI_2,
            -std::f64::consts::FRAC_PI_2,
            0.3,
        ] {
            let r = rotation_zyx(0.7, beta, -1.2);
            let p = Pose::from_translation_rotation(&Vector3::new(1.0, 2.0, 3.0), &r);
            assert!((p.rotation_matrix() - r).norm() < 1e-9, "beta {beta}");
            assert_eq!(p.translation(), Vector3::new(1.0, 2.0, 3.0));
        }
    }
}
