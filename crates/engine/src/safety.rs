//! The safety layer between the god-object and the device: force/torque clamp (device
//! limits), rate limit, NaN guard and soft start.
//!
//! The filter works on the wrench `[F; T]` (N, N·mm) sent to the device; the step itself keeps
//! the graphic tool at its last safe pose when a frame fails (see [`crate::step`]).

/// Limits of the device and of the force rendering.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(default, deny_unknown_fields))]
pub struct SafetyParams {
    /// Largest force magnitude sent, N.
    pub max_force_n: f64,
    /// Largest torque magnitude sent, N·mm.
    pub max_torque_nmm: f64,
    /// Largest change of the force between two frames, N per frame.
    pub max_force_step_n: f64,
    /// Largest change of the torque between two frames, N·mm per frame.
    pub max_torque_step_nmm: f64,
    /// Duration of the soft start (the wrench ramps linearly from 0 to full), s.
    pub soft_start_s: f64,
}

impl Default for SafetyParams {
    fn default() -> Self {
        Self {
            max_force_n: 40.0,
            max_torque_nmm: 4000.0,
            max_force_step_n: 2.0,
            max_torque_step_nmm: 200.0,
            soft_start_s: 0.05,
        }
    }
}

/// Per-frame flags saying what the safety layer did (bit set).
pub mod flags {
    /// The force was clamped to `max_force_n`.
    pub const FORCE_CLAMP: u8 = 1;
    /// The torque was clamped to `max_torque_nmm`.
    pub const TORQUE_CLAMP: u8 = 2;
    /// The force or torque change was rate-limited.
    pub const RATE_LIMIT: u8 = 4;
    /// The frame produced a non-finite result; the last safe output was kept.
    pub const NAN_GUARD: u8 = 8;
    /// The soft-start ramp scaled the output.
    pub const SOFT_START: u8 = 16;
}

/// Counts of safety events over a run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct SafetyEvents {
    /// Frames whose force was clamped.
    pub force_clamps: u64,
    /// Frames whose torque was clamped.
    pub torque_clamps: u64,
    /// Frames whose output change was rate-limited.
    pub rate_limits: u64,
    /// Frames that failed (non-finite) and kept the last safe output.
    pub nan_frames: u64,
    /// Frames scaled by the soft start.
    pub soft_start_frames: u64,
}

impl SafetyEvents {
    /// Adds one frame's flags.
    pub fn record(&mut self, f: u8) {
        self.force_clamps += u64::from(f & flags::FORCE_CLAMP != 0);
        self.torque_clamps += u64::from(f & flags::TORQUE_CLAMP != 0);
        self.rate_limits += u64::from(f & flags::RATE_LIMIT != 0);
        self.nan_frames += u64::from(f & flags::NAN_GUARD != 0);
        self.soft_start_frames += u64::from(f & flags::SOFT_START != 0);
    }
}

/// The stateful safety filter.
#[derive(Clone, Debug)]
pub struct Safety {
    params: SafetyParams,
    /// The limits passed [`SafetyParams::validate`]; when not, every output is zero.
    valid: bool,
    /// Time of the first filtered frame: the soft start runs from there, whatever the clock's
    /// origin (a recording may start at a negative or large time).
    t0: Option<f64>,
    last: [f64; 6],
    events: SafetyEvents,
}

/// Length of the 3-vector in `v[0..3]` (a force in N, a torque in N·mm): the one magnitude the
/// safety layer, the reports and the tests share. `v` must hold at least three numbers.
pub fn norm3(v: &[f64]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// Scales the 3-vector `v` so its norm is at most `limit`; true when it did.
fn clamp3(v: &mut [f64], limit: f64) -> bool {
    let n = norm3(v);
    if n > limit && n > 0.0 {
        let s = limit / n;
        v.iter_mut().for_each(|x| *x *= s);
        true
    } else {
        false
    }
}

impl Safety {
    /// A filter with these limits; the last output starts at zero.
    ///
    /// Limits that fail [`SafetyParams::validate`] (NaN, negative, absurdly large) do not
    /// disable or reverse the clamp: such a filter sends zero in every frame, flagged as a
    /// force and torque clamp. Use [`Safety::try_new`] to be told instead.
    pub fn new(params: SafetyParams) -> Self {
        Self {
            params,
            valid: params.validate().is_ok(),
            t0: None,
            last: [0.0; 6],
            events: SafetyEvents::default(),
        }
    }

    /// A filter with these limits, or the error naming the first limit out of its range.
    pub fn try_new(params: SafetyParams) -> Result<Self, crate::config::SettingError> {
        params.validate()?;
        Ok(Self::new(params))
    }

    /// The limits.
    pub fn params(&self) -> &SafetyParams {
        &self.params
    }

    /// Event counts so far.
    pub fn events(&self) -> SafetyEvents {
        self.events
    }

    /// Starts the soft start again from the next filtered frame, keeping the rate limit's
    /// memory of the last output (e.g. when a device answers again after a timeout): the
    /// wrench ramps up from where it is, never by a step larger than the rate limit.
    pub fn restart_soft_start(&mut self) {
        self.t0 = None;
    }

    /// Filters the raw wrench `[F (N); T (N·mm)]` of the frame at time `t` (s; the soft start
    /// counts from the first frame's `t`) and returns the wrench to send plus the flags of what
    /// was done.
    ///
    /// # Real-time
    /// No allocation, no panic, constant time. The output is always finite, within the limits,
    /// and within the rate limit of the previous output.
    pub fn filter(&mut self, t: f64, raw: [f64; 6]) -> ([f64; 6], u8) {
        let mut f = 0u8;
        if !self.valid {
            let f = flags::FORCE_CLAMP | flags::TORQUE_CLAMP;
            self.events.record(f);
            return ([0.0; 6], f);
        }
        let t = if t.is_finite() { t } else { 0.0 };
        let t0 = *self.t0.get_or_insert(t);
        let t = t - t0;
        if !raw.iter().all(|v| v.is_finite()) {
            f |= flags::NAN_GUARD;
            self.events.record(f);
            return (self.last, f);
        }
        let mut w = raw;
        if clamp3(&mut w[0..3], self.params.max_force_n) {
            f |= flags::FORCE_CLAMP;
        }
        if clamp3(&mut w[3..6], self.params.max_torque_nmm) {
            f |= flags::TORQUE_CLAMP;
        }
        if self.params.soft_start_s > 0.0 && t < self.params.soft_start_s {
            let s = (t / self.params.soft_start_s).clamp(0.0, 1.0);
            w.iter_mut().for_each(|x| *x *= s);
            f |= flags::SOFT_START;
        }
        let mut dw = [0.0; 6];
        for k in 0..6 {
            dw[k] = w[k] - self.last[k];
        }
        let limited_f = clamp3(&mut dw[0..3], self.params.max_force_step_n);
        let limited_t = clamp3(&mut dw[3..6], self.params.max_torque_step_nmm);
        if limited_f || limited_t {
            f |= flags::RATE_LIMIT;
            for k in 0..6 {
                w[k] = self.last[k] + dw[k];
            }
        }
        self.last = w;
        self.events.record(f);
        (w, f)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn no_ramp() -> SafetyParams {
        SafetyParams {
            soft_start_s: 0.0,
            // The largest accepted steps: no rate limiting in these tests.
            max_force_step_n: 100.0,
            max_torque_step_nmm: 10_000.0,
            ..SafetyParams::default()
        }
    }

    #[test]
    fn clamps_force_and_torque_keeping_direction() {
        let mut s = Safety::new(no_ramp());
        let (w, f) = s.filter(1.0, [0.0, 300.0, 400.0, 0.0, 0.0, -9000.0]);
        assert!((norm3(&w[0..3]) - 40.0).abs() < 1e-9);
        assert!((w[1] / w[2] - 0.75).abs() < 1e-12);
        assert!((w[5] + 4000.0).abs() < 1e-9);
        assert_eq!(f, flags::FORCE_CLAMP | flags::TORQUE_CLAMP);
    }

    #[test]
    fn nan_keeps_last_safe_output() {
        let mut s = Safety::new(no_ramp());
        let (w0, _) = s.filter(1.0, [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
        let (w1, f) = s.filter(1.001, [f64::NAN, 0.0, 0.0, 0.0, 0.0, 0.0]);
        assert_eq!(w0, w1);
        assert_eq!(f, flags::NAN_GUARD);
        assert_eq!(s.events().nan_frames, 1);
    }

    #[test]
    fn invalid_limits_send_zero_never_a_reversed_or_unclamped_force() {
        for bad in [f64::NAN, -10.0, 0.0, f64::INFINITY, 1e9] {
            let p = SafetyParams {
                max_force_n: bad,
                ..no_ramp()
            };
            assert!(Safety::try_new(p)
                .unwrap_err()
                .to_string()
                .contains("max_force_n"));
            let mut s = Safety::new(p);
            for t in [0.0, 1.0, 2.0] {
                let (w, f) = s.filter(t, [0.0, 0.0, 110.9, 0.0, 0.0, 5.0]);
                assert_eq!(w, [0.0; 6], "max_force_n = {bad}");
                assert_ne!(f & flags::FORCE_CLAMP, 0);
            }
        }
    }

    #[test]
    fn soft_start_counts_from_the_first_frame_whatever_the_clock_origin() {
        for t0 in [-5.0, 0.0, 1e6] {
            let mut s = Safety::new(SafetyParams {
                soft_start_s: 0.01,
                max_force_step_n: 100.0,
                ..SafetyParams::default()
            });
            let (w, _) = s.filter(t0, [10.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
            assert_eq!(w[0], 0.0);
            let (w, f) = s.filter(t0 + 0.02, [10.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
            assert_eq!((w[0], f), (10.0, 0), "t0 = {t0}");
        }
    }

    #[test]
    fn restarted_soft_start_ramps_from_the_last_output_without_a_step() {
        let p = SafetyParams {
            soft_start_s: 0.01,
            max_force_step_n: 1.0,
            ..SafetyParams::default()
        };
        let mut s = Safety::new(p);
        for k in 0..30 {
            s.filter(k as f64 * 1e-3, [5.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        }
        s.restart_soft_start();
        let mut last = 5.0;
        let mut saw_ramp = false;
        for k in 30..60 {
            let (w, f) = s.filter(k as f64 * 1e-3, [5.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
            assert!(
                (w[0] - last).abs() <= 1.0 + 1e-12,
                "step {} at frame {k}",
                w[0] - last
            );
            saw_ramp |= f & flags::SOFT_START != 0;
            last = w[0];
        }
        assert!(saw_ramp);
        assert!((last - 5.0).abs() < 1e-12);
    }

    #[test]
    fn rate_limit_and_soft_start() {
        let mut s = Safety::new(SafetyParams {
            soft_start_s: 0.1,
            max_force_step_n: 1.0,
            ..SafetyParams::default()
        });
        s.filter(0.0, [0.0; 6]);
        let (w, f) = s.filter(0.05, [10.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        assert!((w[0] - 1.0).abs() < 1e-12, "{w:?}");
        assert_eq!(f, flags::SOFT_START | flags::RATE_LIMIT);
        let (w, f) = s.filter(0.2, [1.5, 0.0, 0.0, 0.0, 0.0, 0.0]);
        assert!((w[0] - 1.5).abs() < 1e-12);
        assert_eq!(f, 0);
    }
}
