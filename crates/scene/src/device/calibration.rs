//! [`Calibration`]: the device frame to the scene frame.

use collide::{rotation_exp, Pose};
use engine::config::{SettingError, CAL_OFFSET_MM, CAL_ROTATION, CAL_SCALE};
use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

/// The map from the device frame to the scene frame (`[device] calibration = { scale = 1.0,
/// rotation = [0, 0, 0], offset = [0, 0, 0] }` in a scene file).
///
/// A handle at position `p_dev` (mm) and orientation `R_dev` is at
/// `p_scene = offset + scale · R · p_dev` with orientation `R · R_dev` in the scene, where
/// `R = exp(rotation)`. The wrench goes back rotated, not scaled: `F_dev = Rᵀ F`,
/// `T_dev = Rᵀ T`, so the safety layer's limits hold at the handle (a rotation keeps
/// magnitudes) and the stiffness felt at the handle is `scale · kt` N per mm of device motion.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize, Serialize)]
#[serde(default, deny_unknown_fields)]
pub struct Calibration {
    /// Scene mm per device mm (workspace scaling).
    pub scale: f64,
    /// Rotation from the device axes to the scene axes, as a rotation vector (axis × angle),
    /// rad.
    pub rotation: [f64; 3],
    /// Scene position of the device frame's origin, mm.
    pub offset: [f64; 3],
}

impl Default for Calibration {
    /// The identity: device frame = scene frame.
    fn default() -> Self {
        Self {
            scale: 1.0,
            rotation: [0.0; 3],
            offset: [0.0; 3],
        }
    }
}

impl Calibration {
    /// Checks the scale, rotation and offset against their ranges in [`engine::config`]; the
    /// first bad one is named.
    pub fn validate(&self) -> Result<(), SettingError> {
        CAL_SCALE.check(self.scale)?;
        for &r in &self.rotation {
            CAL_ROTATION.check(r)?;
        }
        for &o in &self.offset {
            CAL_OFFSET_MM.check(o)?;
        }
        Ok(())
    }

    /// True for the identity map: poses pass through untouched (angles keep their range).
    pub fn is_identity(&self) -> bool {
        *self == Self::default()
    }

    /// `R`, the rotation from device axes to scene axes.
    pub fn rotation_matrix(&self) -> Matrix3<f64> {
        rotation_exp(&Vector3::from(self.rotation))
    }

    /// The scene pose of a device pose (mm, rad).
    pub fn to_scene(&self, r: &Matrix3<f64>, q_dev: &Pose) -> Pose {
        if self.is_identity() {
            return *q_dev;
        }
        let t = Vector3::from(self.offset) + self.scale * (r * q_dev.translation());
        Pose::from_translation_rotation(&t, &(r * q_dev.rotation_matrix()))
    }

    /// The device pose of a scene pose (the inverse of [`Calibration::to_scene`]).
    pub fn to_device(&self, r: &Matrix3<f64>, q_scene: &Pose) -> Pose {
        if self.is_identity() {
            return *q_scene;
        }
        let t = r.transpose() * (q_scene.translation() - Vector3::from(self.offset)) / self.scale;
        Pose::from_translation_rotation(&t, &(r.transpose() * q_scene.rotation_matrix()))
    }

    /// The device-frame wrench of a scene-frame wrench `[F (N); T (N·mm)]`: both rotated by
    /// `Rᵀ`, not scaled.
    pub fn wrench_to_device(&self, r: &Matrix3<f64>, w: &[f64; 6]) -> [f64; 6] {
        if self.is_identity() {
            return *w;
        }
        let f = r.transpose() * Vector3::new(w[0], w[1], w[2]);
        let t = r.transpose() * Vector3::new(w[3], w[4], w[5]);
        [f.x, f.y, f.z, t.x, t.y, t.z]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn to_device_inverts_to_scene_and_the_wrench_keeps_its_magnitude() {
        let cal = Calibration {
            scale: 2.5,
            rotation: [0.3, -0.2, 1.1],
            offset: [10.0, -4.0, 100.0],
        };
        cal.validate().unwrap();
        let r = cal.rotation_matrix();
        let q = Pose::from_array([3.0, -7.0, 12.0, 0.2, -0.4, 0.9]);
        let back = cal.to_device(&r, &cal.to_scene(&r, &q));
        let rot_err = (back.rotation_matrix() - q.rotation_matrix()).norm();
        assert!((back.translation() - q.translation()).norm() < 1e-9);
        assert!(rot_err < 1e-12, "{rot_err}");
        // A device motion of 1 mm along x moves the scene tool 2.5 mm along R x.
        let q2 = Pose::from_array([4.0, -7.0, 12.0, 0.2, -0.4, 0.9]);
        let d = cal.to_scene(&r, &q2).translation() - cal.to_scene(&r, &q).translation();
        assert!((d - 2.5 * r.column(0)).norm() < 1e-9);
        let w = [1.0, 2.0, -3.0, 40.0, 0.0, -5.0];
        let wd = cal.wrench_to_device(&r, &w);
        let n = |v: &[f64]| engine::safety::norm3(v);
        assert!((n(&wd[0..3]) - n(&w[0..3])).abs() < 1e-12);
        assert!((n(&wd[3..6]) - n(&w[3..6])).abs() < 1e-12);
    }

    #[test]
    fn out_of_range_values_are_named() {
        let bad = Calibration {
            scale: 0.0,
            ..Calibration::default()
        };
        assert_eq!(
            bad.validate().unwrap_err().to_string(),
            "[device] calibration.scale = 0: must be a finite number in [0.001, 1000] scene mm per device mm"
        );
        let bad = Calibration {
            rotation: [0.0, f64::NAN, 0.0],
            ..Calibration::default()
        };
        assert!(bad
            .validate()
            .unwrap_err()
            .to_string()
            .starts_with("[device] calibration.rotation = NaN"));
    }
}
