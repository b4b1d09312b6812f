//! One validation of every numeric setting, wherever it comes from: a scene file's TOML keys,
//! a command-line flag, or a struct built through the Rust API.
//!
//! Each setting has one [`Range`] (or [`IntRange`]) here, with physically meaningful bounds and
//! a unit. The scene parser, the command line, [`EngineConfig::validate`] and the
//! `validate()` methods of [`SafetyParams`] and the haptic loop's settings all
//! check against these same ranges, so a value refused in one place is refused everywhere. A refused value gives a
//! one-line [`SettingError`] naming the key, the value and the accepted range, e.g.
//! `[safety] max_force_n = NaN: must be a finite number in (0, 100] N`.
//!
//! Why bounds at all: the device is a motor in a person's hand. A NaN or negative force limit
//! disables the clamp or reverses it, a huge re-linearisation count wraps `1 + n`, a rate of
//! 1e-30 Hz panics in `Duration`, and 1e12 Hz asks for terabytes of frame records.

use std::fmt;

use crate::safety::SafetyParams;
use crate::EngineConfig;

/// A setting outside its accepted range. Displays as one line:
/// `KEY = VALUE: must be EXPECTED`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SettingError {
    /// The key as the user wrote it: `[safety] max_force_n` (scene file and API) or a
    /// command-line flag such as `--rate`.
    pub key: String,
    /// The value given, as text (`NaN`, `-10`, `4294967295`).
    pub value: String,
    /// What is accepted, with the unit: `a finite number in (0, 100] N`.
    pub expected: String,
}

impl fmt::Display for SettingError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} = {}: must be {}",
            self.key, self.value, self.expected
        )
    }
}

impl std::error::Error for SettingError {}

/// The accepted range of a real-valued setting: finite, between `lo` and `hi` (`lo` excluded
/// when `lo_open`), in `unit`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Range {
    /// The key in a scene file: `[section] name`.
    pub key: &'static str,
    /// Lower bound (in `unit`).
    pub lo: f64,
    /// The lower bound itself is refused (`(lo, hi]`), e.g. for a limit that must be > 0.
    pub lo_open: bool,
    /// Upper bound, included (in `unit`).
    pub hi: f64,
    /// The unit, for the message (`N`, `mm`, `Hz`, ...).
    pub unit: &'static str,
}

impl Range {
    /// True when `v` is finite and inside the range.
    pub fn contains(&self, v: f64) -> bool {
        v.is_finite()
            && (if self.lo_open {
                v > self.lo
            } else {
                v >= self.lo
            })
            && v <= self.hi
    }

    /// The range as text: `a finite number in (0, 100] N`.
    pub fn expected(&self) -> String {
        format!(
            "a finite number in {}{}, {}] {}",
            if self.lo_open { "(" } else { "[" },
            self.lo,
            self.hi,
            self.unit
        )
    }

    /// Checks `v` under the range's own key (scene file, API).
    pub fn check(&self, v: f64) -> Result<(), SettingError> {
        self.check_as(self.key, v)
    }

    /// Checks `v`, naming it `key` in the error (e.g. a command-line flag).
    pub fn check_as(&self, key: &str, v: f64) -> Result<(), SettingError> {
        if self.contains(v) {
            Ok(())
        } else {
            Err(SettingError {
                key: key.to_string(),
                value: show(v),
                expected: self.expected(),
            })
        }
    }
}

/// The accepted range of an integer setting: `lo..=hi`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct IntRange {
    /// The key in a scene file: `[section] name`.
    pub key: &'static str,
    /// Smallest accepted value.
    pub lo: u64,
    /// Largest accepted value.
    pub hi: u64,
    /// What one unit is, for the message (`passes`, `samples`).
    pub unit: &'static str,
}

impl IntRange {
    /// Checks `v` under the range's own key.
    pub fn check(&self, v: u64) -> Result<(), SettingError> {
        self.check_as(self.key, v)
    }

    /// Checks `v`, naming it `key` in the error.
    pub fn check_as(&self, key: &str, v: u64) -> Result<(), SettingError> {
        if (self.lo..=self.hi).contains(&v) {
            Ok(())
        } else {
            Err(SettingError {
                key: key.to_string(),
                value: v.to_string(),
                expected: format!("an integer in {}..={} {}", self.lo, self.hi, self.unit)
                    .trim_end()
                    .to_string(),
            })
        }
    }
}

/// A value for a one-line message: plain for everyday magnitudes, `1e300` style otherwise
/// (the plain form of 1e300 is 301 digits).
fn show(v: f64) -> String {
    let a = v.abs();
    if v.is_finite() && a != 0.0 && !(1e-4..1e9).contains(&a) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

const fn open(key: &'static str, lo: f64, hi: f64, unit: &'static str) -> Range {
    Range {
        key,
        lo,
        lo_open: true,
        hi,
        unit,
    }
}

const fn closed(key: &'static str, lo: f64, hi: f64, unit: &'static str) -> Range {
    Range {
        key,
        lo,
        lo_open: false,
        hi,
        unit,
    }
}

// Safety limits. Device forces above 100 N or torques above 10 N·m are beyond any desktop
// haptic device (a Phantom Premium 6-DoF gives about 22 N and 0.5 N·m).

/// `[safety] max_force_n`: largest force sent, N.
pub const MAX_FORCE_N: Range = open("[safety] max_force_n", 0.0, 100.0, "N");
/// `[safety] max_torque_nmm`: largest torque sent, N·mm.
pub const MAX_TORQUE_NMM: Range = open("[safety] max_torque_nmm", 0.0, 10_000.0, "N·mm");
/// `[safety] max_force_step_n`: largest force change per frame, N.
pub const MAX_FORCE_STEP_N: Range = open("[safety] max_force_step_n", 0.0, 100.0, "N");
/// `[safety] max_torque_step_nmm`: largest torque change per frame, N·mm.
pub const MAX_TORQUE_STEP_NMM: Range = open("[safety] max_torque_step_nmm", 0.0, 10_000.0, "N·mm");
/// `[safety] soft_start_s`: soft-start ramp, s (0 = none).
pub const SOFT_START_S: Range = closed("[safety] soft_start_s", 0.0, 10.0, "s");

// Coupling. Below these the spring is too weak to feel and the QP's metric degenerates; above
// them no device renders the stiffness stably.

/// `[coupling] kt`: translational stiffness, N/mm.
pub const KT: Range = closed("[coupling] kt", 1e-3, 100.0, "N/mm");
/// `[coupling] kr`: rotational stiffness, N·mm/rad.
pub const KR: Range = closed("[coupling] kr", 1e-1, 1e6, "N·mm/rad");

// Solver.

/// `[solver] relinearize`: extra detect + solve passes per frame (bounded: each costs a
/// traversal and a QP solve inside the 1 ms frame).
pub const RELINEARIZE: IntRange = IntRange {
    key: "[solver] relinearize",
    lo: 0,
    hi: 16,
    unit: "passes",
};
/// `[solver] penetration_tol_mm`: penetration tolerated before another pass, mm.
pub const PENETRATION_TOL_MM: Range = closed("[solver] penetration_tol_mm", 0.0, 1.0, "mm");
/// `[solver] skin_mm`: detection skin, mm (negative would shrink the margin below the motion
/// bound and let the tool jump through objects).
pub const SKIN_MM: Range = closed("[solver] skin_mm", 0.0, 10.0, "mm");
/// `[solver] max_margin_mm`: largest motion of any tool sphere per pass, mm (the detection
/// margin's cap: a huge one would enumerate every pair of the scene in one frame).
pub const MAX_MARGIN_MM: Range = open("[solver] max_margin_mm", 0.0, 50.0, "mm");
/// `[solver] budget_us`: time budget of one frame's step, µs (at most a second: a frame longer
/// than that is a stalled device).
pub const BUDGET_US: Range = open("[solver] budget_us", 0.0, 1e6, "µs");
/// Leaf pairs stored per pass (API only; storage is reserved up front).
pub const MAX_PAIRS: IntRange = IntRange {
    key: "max_pairs",
    lo: 1,
    hi: 1 << 20,
    unit: "pairs",
};

// Device and loop.

/// `[device] rate_hz`: haptic rate, Hz. Below 100 Hz contact is not rendered stably; above
/// 20 kHz no device samples and one frame cannot finish.
pub const RATE_HZ: Range = closed("[device] rate_hz", 100.0, 20_000.0, "Hz");
/// `spin_us` of the real-time loop (API only): spin before a deadline, µs.
pub const SPIN_US: Range = closed("spin_us", 0.0, 10_000.0, "µs");
/// `max_frames` of the loop (API only): frame records reserved.
pub const MAX_FRAMES: IntRange = IntRange {
    key: "max_frames",
    lo: 1,
    hi: 100_000_000,
    unit: "frames",
};
/// `[device] timeout_s`: a device that delivers no pose for this long is released (the wrench
/// goes to zero through the rate limit), s.
pub const DEVICE_TIMEOUT_S: Range = open("[device] timeout_s", 0.0, 10.0, "s");
/// `[device] calibration.scale`: scene mm per device mm (workspace scaling).
pub const CAL_SCALE: Range = closed(
    "[device] calibration.scale",
    1e-3,
    1e3,
    "scene mm per device mm",
);
/// `[device] calibration.rotation`: each component of the device-to-scene rotation vector, rad.
pub const CAL_ROTATION: Range = closed(
    "[device] calibration.rotation",
    -std::f64::consts::TAU,
    std::f64::consts::TAU,
    "rad",
);
/// `[device] calibration.offset`: each component of the scene position of the device origin, mm.
pub const CAL_OFFSET_MM: Range = closed("[device] calibration.offset", -1e6, 1e6, "mm");
/// `[device.emulator] mass_kg`: moving mass of the emulated device and hand, kg.
pub const EMU_MASS_KG: Range = closed("[device.emulator] mass_kg", 0.005, 10.0, "kg");
/// `[device.emulator] hand_stiffness_n_per_mm`: stiffness of the emulated hand's grip toward its
/// target, N/mm.
pub const EMU_HAND_STIFFNESS: Range = closed(
    "[device.emulator] hand_stiffness_n_per_mm",
    0.0,
    10.0,
    "N/mm",
);
/// `[device.emulator] hand_damping_ns_per_mm`: damping of the emulated hand, N·s/mm.
pub const EMU_HAND_DAMPING: Range = closed(
    "[device.emulator] hand_damping_ns_per_mm",
    0.0,
    1.0,
    "N·s/mm",
);
/// `[device.emulator] push_n`: each component of the emulated hand's push, N.
pub const EMU_PUSH_N: Range = closed("[device.emulator] push_n", -100.0, 100.0, "N");
/// `[device.emulator] push_after_s`: when the emulated hand starts pushing, s.
pub const EMU_PUSH_AFTER_S: Range = closed("[device.emulator] push_after_s", 0.0, 1e4, "s");

/// `[[object]] friction.static` (and `[tool] friction.static`): static Coulomb coefficient.
pub const FRICTION_STATIC: Range = closed("friction.static", 0.0, 5.0, "");
/// `[[object]] friction.kinetic` (and `[tool] friction.kinetic`): kinetic Coulomb coefficient
/// (at most the static one).
pub const FRICTION_KINETIC: Range = closed("friction.kinetic", 0.0, 5.0, "");

/// Largest `|coordinate|` of a start or object pose, mm or rad (the step refuses device
/// readings beyond it too).
pub const POSE_ABS: f64 = 1e6;

impl SafetyParams {
    /// Checks every limit against its range ([`MAX_FORCE_N`], ...); the first bad one is named.
    pub fn validate(&self) -> Result<(), SettingError> {
        MAX_FORCE_N.check(self.max_force_n)?;
        MAX_TORQUE_NMM.check(self.max_torque_nmm)?;
        MAX_FORCE_STEP_N.check(self.max_force_step_n)?;
        MAX_TORQUE_STEP_NMM.check(self.max_torque_step_nmm)?;
        SOFT_START_S.check(self.soft_start_s)
    }
}

impl EngineConfig {
    /// Checks every numeric setting against its range, with the same ranges as the scene file;
    /// the first bad one is named.
    pub fn validate(&self) -> Result<(), SettingError> {
        KT.check(self.kt)?;
        KR.check(self.kr)?;
        RELINEARIZE.check(u64::from(self.relinearize))?;
        PENETRATION_TOL_MM.check(self.penetration_tol_mm)?;
        SKIN_MM.check(self.skin_mm)?;
        MAX_MARGIN_MM.check(self.max_margin_mm)?;
        BUDGET_US.check(self.budget_us)?;
        MAX_PAIRS.check(self.max_pairs as u64)?;
        self.tuning.validate()?;
        self.safety.validate()
    }
}

/// Checks a pose array (start or object pose): finite, each coordinate within [`POSE_ABS`].
pub fn check_pose(key: &str, q: &[f64; 6]) -> Result<(), SettingError> {
    if q.iter().all(|v| v.is_finite() && v.abs() <= POSE_ABS) {
        return Ok(());
    }
    Err(SettingError {
        key: key.to_string(),
        value: format!("{q:?}"),
        expected: format!("six finite numbers within ±{POSE_ABS} (mm, mm, mm, rad, rad, rad)"),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_name_key_value_and_range() {
        let e = MAX_FORCE_N.check(f64::NAN).unwrap_err().to_string();
        assert_eq!(
            e,
            "[safety] max_force_n = NaN: must be a finite number in (0, 100] N"
        );
        let e = RATE_HZ.check_as("--rate", 1e7).unwrap_err().to_string();
        assert_eq!(
            e,
            "--rate = 10000000: must be a finite number in [100, 20000] Hz"
        );
        let e = KT.check(1e300).unwrap_err().to_string();
        assert!(e.starts_with("[coupling] kt = 1e300: "), "{e}");
        let e = KT.check(-1e-300).unwrap_err().to_string();
        assert!(e.starts_with("[coupling] kt = -1e-300: "), "{e}");
        let e = RELINEARIZE
            .check(u64::from(u32::MAX))
            .unwrap_err()
            .to_string();
        assert!(e.contains("4294967295") && e.contains("0..=16"), "{e}");
    }

    #[test]
    fn bounds_are_inclusive_or_open_as_declared() {
        assert!(!MAX_FORCE_N.contains(0.0));
        assert!(MAX_FORCE_N.contains(100.0));
        assert!(!MAX_FORCE_N.contains(100.000001));
        assert!(SKIN_MM.contains(0.0));
        assert!(!SKIN_MM.contains(-1e-12));
        for v in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            assert!(!SOFT_START_S.contains(v));
        }
    }

    #[test]
    fn defaults_are_valid() {
        SafetyParams::default().validate().unwrap();
        crate::EngineConfig::default().validate().unwrap();
    }
}
