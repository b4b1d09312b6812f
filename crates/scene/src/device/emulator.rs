//! [`Emulator`]: a mass–spring–damper hand holding a device, for people without hardware and
//! for closed-loop tests.

use collide::Pose;
use engine::config::{
    SettingError, EMU_HAND_DAMPING, EMU_HAND_STIFFNESS, EMU_MASS_KG, EMU_PUSH_AFTER_S, EMU_PUSH_N,
};
use serde::{Deserialize, Serialize};

use super::{Capabilities, Device, DeviceSample, Reading};
use crate::trajectory::Trajectory;

/// The emulated device and hand (`[device.emulator]` in a scene file).
///
/// The handle (mass `m`, position `x`, mm, device frame) moves under the wrench's force `F_e`
/// (held over each frame, as a device's amplifier holds it), the hand's spring toward the
/// intention's target `x_t` and its damping, and the hand's push `P`:
/// `m ẍ = F_e + k_h (x_t − x) − b_h ẋ + P(t)` (N; `ẍ` in m/s², so `ẍ_mm = 1000 F / m`).
/// The hand holds the target's orientation rigidly, so the emulator renders forces only: its
/// torque axes are reported as unrendered.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize, Serialize)]
#[serde(default, deny_unknown_fields)]
pub struct EmulatorParams {
    /// Moving mass of the device's handle and the hand, kg.
    pub mass_kg: f64,
    /// Stiffness of the hand's grip toward its target, N/mm.
    pub hand_stiffness_n_per_mm: f64,
    /// Damping of the hand, N·s/mm.
    pub hand_damping_ns_per_mm: f64,
    /// The hand's push once it starts, N (device frame).
    pub push_n: [f64; 3],
    /// When the push starts, s; it ramps from zero over [`PUSH_RAMP_S`].
    pub push_after_s: f64,
}

/// Fewest integration substeps per frame.
pub const MIN_SUBSTEPS: u32 = 20;

/// How long the hand's push takes to build up, s (a person does not push as a step).
pub const PUSH_RAMP_S: f64 = 0.1;

impl Default for EmulatorParams {
    /// A light grip on a desktop device: 0.1 kg, 0.3 N/mm, 0.002 N·s/mm (2 N·s/m), no push.
    fn default() -> Self {
        Self {
            mass_kg: 0.1,
            hand_stiffness_n_per_mm: 0.3,
            hand_damping_ns_per_mm: 0.002,
            push_n: [0.0; 3],
            push_after_s: 0.0,
        }
    }
}

impl EmulatorParams {
    /// Checks every parameter against its range in [`engine::config`]; the first bad one is
    /// named.
    pub fn validate(&self) -> Result<(), SettingError> {
        EMU_MASS_KG.check(self.mass_kg)?;
        EMU_HAND_STIFFNESS.check(self.hand_stiffness_n_per_mm)?;
        EMU_HAND_DAMPING.check(self.hand_damping_ns_per_mm)?;
        for &p in &self.push_n {
            EMU_PUSH_N.check(p)?;
        }
        EMU_PUSH_AFTER_S.check(self.push_after_s)
    }

    /// The push at time `t` (s), N.
    pub fn push_at(&self, t: f64) -> [f64; 3] {
        let s = ((t - self.push_after_s) / PUSH_RAMP_S).clamp(0.0, 1.0);
        self.push_n.map(|p| p * s)
    }
}

/// A device moved by an emulated hand: closed loop with the wrench it is sent.
///
/// The hand's intention is a trajectory of targets, one row per frame (device frame, mm and
/// rad); the run ends with it. Each [`Device::read`] integrates the dynamics of
/// [`EmulatorParams`] over one frame period in substeps short enough for the hand's own
/// spring and damper (semi-implicit Euler), with the force last written held constant.
#[derive(Clone, Debug)]
pub struct Emulator {
    params: EmulatorParams,
    targets: Trajectory,
    dt: f64,
    substeps: u32,
    x: [f64; 3],
    v: [f64; 3],
    force: [f64; 3],
    frame: usize,
}

impl Emulator {
    /// An emulator at `rate_hz` (frames per second) whose hand follows `targets` (row `i` is
    /// frame `i`'s target), starting at rest at the first target. `params` and `rate_hz` should
    /// have passed their checks (an out-of-range rate is taken as 1 kHz).
    pub fn new(params: EmulatorParams, targets: Trajectory, rate_hz: f64) -> Self {
        let rate = if engine::config::RATE_HZ.contains(rate_hz) {
            rate_hz
        } else {
            1000.0
        };
        let dt = 1.0 / rate;
        // Substeps: at least 20 per frame, so the handle moves while the frame's force is held
        // (one semi-implicit Euler step per frame would move it as if the force acted at the
        // frame's start and hide the energy a held force feeds a sampled wall: Colgate's
        // b > K T / 2), and h·ω ≤ 0.1 for the hand's spring, h·b/m ≤ 0.1 for its damper (k in
        // N/mm is 1000 N/m).
        let m = params.mass_kg.max(1e-6);
        let omega = (1000.0 * params.hand_stiffness_n_per_mm / m).sqrt();
        let damp = 1000.0 * params.hand_damping_ns_per_mm / m;
        let rate_max = omega.max(damp).max(1.0);
        let substeps = ((dt * rate_max / 0.1).ceil() as u32).clamp(MIN_SUBSTEPS, 10_000);
        let x0 = targets
            .samples
            .first()
            .map_or([0.0; 3], |s| [s.q[0], s.q[1], s.q[2]]);
        Self {
            params,
            targets,
            dt,
            substeps,
            x: x0,
            v: [0.0; 3],
            force: [0.0; 3],
            frame: 0,
        }
    }

    /// The handle's velocity, mm/s.
    pub fn velocity(&self) -> [f64; 3] {
        self.v
    }

    /// Advances the handle by one frame period toward frame `frame`'s target.
    fn integrate(&mut self, target: &[f64; 6], t: f64) {
        let p = &self.params;
        let h = self.dt / f64::from(self.substeps);
        let push = p.push_at(t);
        let inv_m = 1000.0 / p.mass_kg.max(1e-6); // mm/s² per N
        for _ in 0..self.substeps {
            for k in 0..3 {
                let f = self.force[k] + p.hand_stiffness_n_per_mm * (target[k] - self.x[k])
                    - p.hand_damping_ns_per_mm * self.v[k]
                    + push[k];
                self.v[k] += h * inv_m * f;
                self.x[k] += h * self.v[k];
            }
        }
        // A runaway (a wrench far beyond any device) is stopped rather than sent on as NaN.
        if !self.x.iter().chain(&self.v).all(|c| c.is_finite()) {
            self.x = [target[0], target[1], target[2]];
            self.v = [0.0; 3];
        }
    }
}

impl Device for Emulator {
    fn name(&self) -> &str {
        "emulator"
    }

    /// Forces only: the emulated hand holds the orientation rigidly.
    fn capabilities(&self) -> Capabilities {
        Capabilities {
            axes: [true, true, true, false, false, false],
            ..Capabilities::default()
        }
    }

    fn read(&mut self, frame: usize, _t: f64) -> Reading {
        let Some(target) = self.targets.samples.get(frame).map(|s| s.q) else {
            return Reading::Ended;
        };
        let t = frame as f64 * self.dt;
        // Frame 0 is the rest pose; every later frame first moves the handle one period.
        while self.frame < frame {
            self.frame += 1;
            self.integrate(&target, t);
        }
        let q = [
            self.x[0], self.x[1], self.x[2], target[3], target[4], target[5],
        ];
        Reading::Pose(DeviceSample::new(t, Pose::from_array(q)))
    }

    fn write_wrench(&mut self, wrench: &[f64; 6]) {
        if wrench[0..3].iter().all(|w| w.is_finite()) {
            self.force = [wrench[0], wrench[1], wrench[2]];
        }
    }

    fn frames(&self) -> Option<usize> {
        Some(self.targets.len())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trajectory::TrajSample;

    fn hold(q: [f64; 6], frames: usize, rate: f64) -> Trajectory {
        Trajectory {
            samples: (0..frames)
                .map(|i| TrajSample {
                    t: i as f64 / rate,
                    q,
                })
                .collect(),
        }
    }

    #[test]
    fn a_constant_force_settles_where_the_hand_spring_balances_it() {
        // 2 N against 0.5 N/mm: 4 mm from the target, damped out within 2 s.
        let p = EmulatorParams {
            hand_stiffness_n_per_mm: 0.5,
            hand_damping_ns_per_mm: 0.01,
            ..EmulatorParams::default()
        };
        let mut e = Emulator::new(p, hold([0.0; 6], 2001, 1000.0), 1000.0);
        let mut z = 0.0;
        for i in 0..=2000 {
            if let Reading::Pose(s) = e.read(i, 0.0) {
                z = s.pose.q[2];
            }
            e.write_wrench(&[0.0, 0.0, 2.0, 0.0, 0.0, 0.0]);
        }
        assert!((z - 4.0).abs() < 1e-3, "z = {z}");
        assert_eq!(e.read(2001, 0.0), Reading::Ended);
    }

    #[test]
    fn free_hand_oscillates_at_its_natural_frequency() {
        // m = 0.1 kg, k = 0.4 N/mm = 400 N/m: omega = 63.2 rad/s, period 99.3 ms. Released
        // 1 mm from its target without damping, the handle first crosses the target at a
        // quarter period.
        let p = EmulatorParams {
            hand_stiffness_n_per_mm: 0.4,
            hand_damping_ns_per_mm: 0.0,
            ..EmulatorParams::default()
        };
        let mut e = Emulator::new(p, hold([0.0; 6], 200, 1000.0), 1000.0);
        e.x = [1.0, 0.0, 0.0];
        let mut crossed = None;
        for i in 0..200 {
            if let Reading::Pose(s) = e.read(i, 0.0) {
                if s.pose.q[0] < 0.0 && crossed.is_none() {
                    crossed = Some(i);
                }
            }
        }
        let quarter_ms = 0.25 * 2.0 * std::f64::consts::PI / (400.0f64 / 0.1).sqrt() * 1e3;
        let c = crossed.unwrap() as f64;
        assert!(
            (c - quarter_ms).abs() <= 1.0,
            "crossed at {c} ms, expected {quarter_ms}"
        );
    }

    /// The emulator pressed by a 1 N push onto an ideal sampled wall `F = K max(0, -z)` at
    /// `z = 0` (the force held over each frame): the peak-to-peak force of the last 0.5 s.
    fn wall_ripple(k: f64, rate: f64) -> f64 {
        let p = EmulatorParams {
            push_n: [0.0, 0.0, -1.0],
            push_after_s: 0.1,
            ..EmulatorParams::default()
        };
        let n = (1.5 * rate) as usize;
        let mut e = Emulator::new(p, hold([0.0; 6], n, rate), rate);
        let mut forces = Vec::new();
        for i in 0..n {
            if let Reading::Pose(s) = e.read(i, 0.0) {
                let f = k * (-s.pose.q[2]).max(0.0);
                e.write_wrench(&[0.0, 0.0, f, 0.0, 0.0, 0.0]);
                forces.push(f);
            }
        }
        let tail = &forces[n - (0.5 * rate) as usize..];
        let (lo, hi) = tail
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(a, b), &f| (a.min(f), b.max(f)));
        hi - lo
    }

    #[test]
    fn an_ideal_sampled_wall_is_stable_below_colgates_bound_and_bounces_above_it() {
        // Colgate & Schenkel: a sampled wall of stiffness K is passive when b > K T / 2. With
        // b = 2 N·s/m the bound is K = 4 N/mm at 1 kHz and 16 N/mm at 4 kHz.
        assert!(wall_ripple(2.0, 1000.0) < 0.01);
        assert!(wall_ripple(8.0, 1000.0) > 0.5);
        assert!(wall_ripple(8.0, 4000.0) < 0.01);
        assert!(wall_ripple(32.0, 4000.0) > 0.5);
    }

    #[test]
    fn push_ramps_in() {
        let p = EmulatorParams {
            push_n: [0.0, 0.0, -2.0],
            push_after_s: 0.5,
            ..EmulatorParams::default()
        };
        assert_eq!(p.push_at(0.4), [0.0, 0.0, 0.0]);
        assert!((p.push_at(0.55)[2] + 1.0).abs() < 1e-9);
        assert_eq!(p.push_at(3.0)[2], -2.0);
        p.validate().unwrap();
        let bad = EmulatorParams { mass_kg: -1.0, ..p };
        assert!(bad
            .validate()
            .unwrap_err()
            .to_string()
            .starts_with("[device.emulator] mass_kg = -1"));
    }
}
