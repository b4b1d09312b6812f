//! The keyword settings of `Engine.from_trees` and `Engine.from_scene`, mapped onto an
//! [`EngineConfig`] and checked against the same ranges as scene files and command-line flags
//! ([`engine::config`]), so a value refused there is refused here with the same message.

use engine::config::{self, SettingError};
use engine::setting::Setting;
use engine::{ConstraintForm, EngineConfig, RotationCoordinates, SolverKind};

use crate::Failure;

/// Keyword settings; `None` keeps the base value (the scene's, or [`EngineConfig::default`]).
/// Integers are signed so that a negative value gets the setting's own message.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct EngineOptions {
    /// Translational stiffness, N/mm.
    pub kt: Option<f64>,
    /// Rotational stiffness, N·mm/rad.
    pub kr: Option<f64>,
    /// QP solver name: `dual`, `pqp`, `active-set`, `pqp-parallel`.
    pub solver: Option<String>,
    /// Constraint form name: `distance`, `squared`.
    pub form: Option<String>,
    /// Rotation coordinates name: `rotation-vector`, `euler`.
    pub rotation: Option<String>,
    /// What the tool touches: `spheres` (the leaf spheres) or `mesh` (the parts' own
    /// triangles, where every body came from a mesh).
    pub geometry: Option<String>,
    /// Extra detect + solve passes per frame.
    pub relinearize: Option<i64>,
    /// Penetration tolerated before another pass, mm.
    pub penetration_tol_mm: Option<f64>,
    /// Detection skin, mm.
    pub skin_mm: Option<f64>,
    /// Largest motion of a tool sphere per pass, mm.
    pub max_margin_mm: Option<f64>,
    /// Time budget of a frame's step, µs.
    pub budget_us: Option<f64>,
    /// Leaf pairs stored per pass.
    pub max_pairs: Option<i64>,
    /// Largest force sent, N.
    pub max_force_n: Option<f64>,
    /// Largest torque sent, N·mm.
    pub max_torque_nmm: Option<f64>,
    /// Largest force change per frame, N.
    pub max_force_step_n: Option<f64>,
    /// Largest torque change per frame, N·mm.
    pub max_torque_step_nmm: Option<f64>,
    /// Soft-start ramp, s.
    pub soft_start_s: Option<f64>,
    /// Haptic rate, Hz: the safety layer's clock advances `1 / rate_hz` s per frame.
    pub rate_hz: Option<f64>,
}

/// The settings after [`EngineOptions::apply`]: the engine's and the frame rate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    /// The engine's settings (checked).
    pub config: EngineConfig,
    /// Frames per second, Hz (checked).
    pub rate_hz: f64,
}

/// Parses `name` as a setting of type `S`, naming the keyword in the error:
/// `solver: unknown solver `newton`; expected one of: dual, pqp, active-set, pqp-parallel`.
fn parse<S: Setting>(keyword: &str, name: &str) -> Result<S, Failure> {
    S::parse_setting(name).map_err(|e| Failure::value(format!("{keyword}: {e}")))
}

/// A signed integer setting checked against `range` under `key` (a negative value is refused
/// with the range's message).
fn count(key: &str, range: config::IntRange, v: i64) -> Result<u64, SettingError> {
    match u64::try_from(v) {
        Ok(u) => range.check_as(key, u).map(|()| u),
        Err(_) => Err(SettingError {
            key: key.to_string(),
            value: v.to_string(),
            expected: format!("an integer in {}..={} {}", range.lo, range.hi, range.unit),
        }),
    }
}

impl EngineOptions {
    /// `base` and `base_rate_hz` with the given settings replaced, every setting checked
    /// ([`EngineConfig::validate`], [`config::RATE_HZ`]). A refused value is named by its
    /// keyword, as the command line names its flags:
    /// `kt = 0: must be a finite number in [0.001, 100] N/mm`.
    pub fn apply(&self, base: EngineConfig, base_rate_hz: f64) -> Result<Settings, Failure> {
        let mut c = base;
        if let Some(s) = &self.solver {
            c.solver = parse::<SolverKind>("solver", s)?;
        }
        if let Some(s) = &self.form {
            c.form = parse::<ConstraintForm>("form", s)?;
        }
        if let Some(s) = &self.rotation {
            c.rotation = parse::<RotationCoordinates>("rotation", s)?;
        }
        if let Some(s) = &self.geometry {
            c.geometry = parse::<engine::Geometry>("geometry", s)?;
        }
        let setting = |e: SettingError| Failure::value(e.to_string());
        // Each given value is checked under its keyword's name first, as the command line
        // checks its flags (`budget_us = 0: must be ...`); then the whole, as a scene's.
        let reals: [(&str, config::Range, Option<f64>, &mut f64); 11] = [
            ("kt", config::KT, self.kt, &mut c.kt),
            ("kr", config::KR, self.kr, &mut c.kr),
            (
                "penetration_tol_mm",
                config::PENETRATION_TOL_MM,
                self.penetration_tol_mm,
                &mut c.penetration_tol_mm,
            ),
            ("skin_mm", config::SKIN_MM, self.skin_mm, &mut c.skin_mm),
            (
                "max_margin_mm",
                config::MAX_MARGIN_MM,
                self.max_margin_mm,
                &mut c.max_margin_mm,
            ),
            (
                "budget_us",
                config::BUDGET_US,
                self.budget_us,
                &mut c.budget_us,
            ),
            (
                "max_force_n",
                config::MAX_FORCE_N,
                self.max_force_n,
                &mut c.safety.max_force_n,
            ),
            (
                "max_torque_nmm",
                config::MAX_TORQUE_NMM,
                self.max_torque_nmm,
                &mut c.safety.max_torque_nmm,
            ),
            (
                "max_force_step_n",
                config::MAX_FORCE_STEP_N,
                self.max_force_step_n,
                &mut c.safety.max_force_step_n,
            ),
            (
                "max_torque_step_nmm",
                config::MAX_TORQUE_STEP_NMM,
                self.max_torque_step_nmm,
                &mut c.safety.max_torque_step_nmm,
            ),
            (
                "soft_start_s",
                config::SOFT_START_S,
                self.soft_start_s,
                &mut c.safety.soft_start_s,
            ),
        ];
        for (key, range, value, slot) in reals {
            if let Some(v) = value {
                range.check_as(key, v).map_err(setting)?;
                *slot = v;
            }
        }
        if let Some(n) = self.relinearize {
            // In range means at most 16: the cast cannot truncate.
            c.relinearize = count("relinearize", config::RELINEARIZE, n).map_err(setting)? as u32;
        }
        if let Some(n) = self.max_pairs {
            let n = count("max_pairs", config::MAX_PAIRS, n).map_err(setting)?;
            c.max_pairs = usize::try_from(n)
                .map_err(|_| Failure::value(format!("max_pairs = {n}: too large")))?;
        }
        c.validate().map_err(setting)?;
        let rate_hz = match self.rate_hz {
            Some(r) => {
                config::RATE_HZ.check_as("rate_hz", r).map_err(setting)?;
                r
            }
            None => base_rate_hz,
        };
        config::RATE_HZ.check(rate_hz).map_err(setting)?;
        Ok(Settings { config: c, rate_hz })
    }
}

/// Checks a pose given from Python: six finite numbers within the accepted range (mm, rad);
/// `what` names it in the error (`q_h`, `start`, `trajectory row 3`).
pub fn check_pose(what: &str, q: &[f64; 6]) -> Result<(), Failure> {
    config::check_pose(what, q).map_err(|e| Failure::value(e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nothing_given_keeps_the_base() {
        let s = EngineOptions::default()
            .apply(EngineConfig::paper(), 500.0)
            .unwrap();
        assert_eq!(s.config, EngineConfig::paper());
        assert_eq!(s.rate_hz, 500.0);
    }

    #[test]
    fn settings_are_replaced_and_names_parsed() {
        let o = EngineOptions {
            kt: Some(2.0),
            solver: Some("Active_Set".into()),
            form: Some("squared".into()),
            rotation: Some("euler".into()),
            relinearize: Some(3),
            budget_us: Some(1e6),
            max_force_n: Some(10.0),
            max_pairs: Some(100),
            ..Default::default()
        };
        let s = o.apply(EngineConfig::default(), 1000.0).unwrap();
        assert_eq!(s.config.kt, 2.0);
        assert_eq!(s.config.solver, SolverKind::ActiveSet);
        assert_eq!(s.config.form, ConstraintForm::Squared);
        assert_eq!(s.config.rotation, RotationCoordinates::Euler);
        assert_eq!(s.config.relinearize, 3);
        assert_eq!(s.config.budget_us, 1e6);
        assert_eq!(s.config.safety.max_force_n, 10.0);
        assert_eq!(s.config.max_pairs, 100);
    }

    #[test]
    fn refusals_carry_the_scene_file_messages() {
        let bad = |o: EngineOptions| {
            o.apply(EngineConfig::default(), 1000.0)
                .unwrap_err()
                .message
        };
        assert_eq!(
            bad(EngineOptions {
                solver: Some("newton".into()),
                ..Default::default()
            }),
            "solver: unknown solver `newton`; expected one of: dual, pqp, active-set, pqp-parallel"
        );
        assert!(bad(EngineOptions {
            kt: Some(f64::NAN),
            ..Default::default()
        })
        .starts_with("kt = NaN: must be"));
        assert!(bad(EngineOptions {
            relinearize: Some(-1),
            ..Default::default()
        })
        .starts_with("relinearize = -1: must be an integer in 0..=16"));
        assert!(bad(EngineOptions {
            rate_hz: Some(0.0),
            ..Default::default()
        })
        .starts_with("rate_hz = 0"));
    }
}
