//! Closed-loop stability of the virtual coupling with the emulated hand ([`Emulator`]): a
//! steady press, and the largest coupling stiffness that holds it.
//!
//! - [`press`]: the hand approaches a scene object along a direction, pushes, and holds; the
//!   normal force in the last [`PressParams::window_s`] gives the force ripple.
//! - [`largest_stable_kt`]: the stiffest `kt` whose press is stable, by a doubling ladder then
//!   bisection.
//!
//! **Stable** means, in the steady window: the tool touches in every frame (the normal force
//! never drops to zero, no bouncing) and the force ripple — the 99th percentile of
//! `|F_n − mean F_n|` — is at most [`PressParams::ripple_limit_n`] (0.05 N by default, the
//! issue's target). A growing or sustained oscillation fails one or both.

use collide::Pose;
use serde::Serialize;

use crate::device::{Emulator, EmulatorParams, LinkStats};
use crate::rt::{run_frames, FrameRecord, LoopParams, Pacing};
use crate::trajectory::{Ease, Script};
use crate::{Scene, SceneError};

/// The press: where, how hard, how long, and the stability threshold.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct PressParams {
    /// Unit direction of the press (into the object), scene frame.
    pub direction: [f64; 3],
    /// The hand's push once in contact, N.
    pub push_n: f64,
    /// Time for the hand's target to reach the contact pose from the start, s.
    pub approach_s: f64,
    /// Whole press, s.
    pub duration_s: f64,
    /// The steady window at the end of the press, s.
    pub window_s: f64,
    /// Largest force ripple (p99 of `|F_n − mean|`) of a stable press, N.
    pub ripple_limit_n: f64,
    /// The emulated hand (its push is set from `direction` and `push_n`).
    pub hand: EmulatorParams,
    /// The rotational stiffness follows the translational one, `kr = kr_per_kt · kt`
    /// (N·mm/rad per N/mm), so the coupling `G` is scaled as a whole; with `kr` fixed, a stiff
    /// `kt` lets the god-object tilt instead of holding the hand (a softer wall than `kt`).
    pub kr_per_kt: f64,
}

impl PressParams {
    /// A 1 N press along `direction`: 0.2 s approach, push from 0.25 s (ramped over 0.1 s),
    /// 1.5 s in all, the last 0.5 s judged against 0.05 N; the default hand; `kr = 1000 kt`
    /// (the default coupling's ratio).
    pub fn along(direction: [f64; 3]) -> Self {
        Self {
            direction,
            push_n: 1.0,
            approach_s: 0.2,
            duration_s: 1.5,
            window_s: 0.5,
            ripple_limit_n: 0.05,
            hand: EmulatorParams::default(),
            kr_per_kt: 1000.0,
        }
    }
}

/// What one press measured.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct PressResult {
    /// Coupling stiffness, N/mm.
    pub kt: f64,
    /// Loop rate, Hz.
    pub rate_hz: f64,
    /// Frames run.
    pub frames: usize,
    /// Mean normal force in the steady window, N.
    pub mean_force_n: f64,
    /// Force ripple: p99 of `|F_n − mean|` in the steady window, N.
    pub ripple_p99_n: f64,
    /// Peak-to-peak normal force in the steady window, N.
    pub peak_to_peak_n: f64,
    /// Frames of the steady window without force (the tool off the surface).
    pub free_frames: usize,
    /// RMS of `F_n − mean` in the second half of the window over the first half: above 1 the
    /// oscillation grows.
    pub growth: f64,
    /// Stable by the module's criterion.
    pub stable: bool,
    /// What the device link did (torques the emulator does not render are counted here).
    pub link: LinkStats,
}

/// Runs one press of `scene` at coupling stiffness `kt` (N/mm) and loop rate `rate_hz` (Hz),
/// frames back to back (simulated time). The hand starts at the scene's start pose.
pub fn press(
    scene: &Scene,
    p: &PressParams,
    kt: f64,
    rate_hz: f64,
) -> Result<PressResult, SceneError> {
    let mut sc = scene.clone();
    sc.coupling.kt = kt;
    sc.coupling.kr = (p.kr_per_kt * kt).clamp(engine::config::KR.lo, engine::config::KR.hi);
    sc.rate_hz = rate_hz;
    sc.validate()?;
    let d = p.direction;
    let start = sc.start;
    let gap = crate::scenes::distance_to_contact(&sc, &start, d, 500.0)?.ok_or_else(|| {
        SceneError::scene(
            &sc.name,
            format!("the tool never touches anything moving along {d:?} from its start"),
        )
    })?;
    let mut contact = start.to_array();
    for k in 0..3 {
        contact[k] += d[k] * gap;
    }
    let script = Script::starting_at(start.to_array())
        .then(p.approach_s, contact, Ease::Smooth)
        .hold((p.duration_s - p.approach_s).max(0.0));
    let hand = EmulatorParams {
        push_n: d.map(|c| c * p.push_n),
        push_after_s: p.approach_s + 0.05,
        ..p.hand
    };
    let mut emulator = Emulator::new(hand, script.to_trajectory(rate_hz), rate_hz);
    let mut engine = sc.engine()?;
    engine
        .reset(&Pose::from_array(start.to_array()))
        .map_err(|source| SceneError::Engine {
            file: sc.name.clone(),
            source,
        })?;
    let params = LoopParams {
        pacing: Pacing {
            rate_hz,
            ..Pacing::default()
        },
        device: sc.device.settings,
        ..LoopParams::default()
    };
    let mut records: Vec<FrameRecord> = Vec::with_capacity(emulator_frames(&script, rate_hz));
    let (frames, link) = run_frames(&mut engine, &mut emulator, &params, &mut records);
    let window = ((p.window_s * rate_hz).round() as usize).clamp(2, records.len().max(2));
    let fn_of = |r: &FrameRecord| -(0..3).map(|k| r.frame.wrench[k] * d[k]).sum::<f64>();
    let tail: Vec<f64> = records
        .iter()
        .skip(records.len().saturating_sub(window))
        .map(fn_of)
        .collect();
    let mut r = measure(&tail, p.ripple_limit_n);
    r.kt = kt;
    r.rate_hz = rate_hz;
    r.frames = frames;
    r.link = link;
    Ok(r)
}

fn emulator_frames(script: &Script, rate_hz: f64) -> usize {
    script.to_trajectory(rate_hz).len()
}

/// The steady-window measures of a normal-force series (N).
fn measure(f: &[f64], limit: f64) -> PressResult {
    if f.is_empty() {
        return PressResult::default();
    }
    let n = f.len() as f64;
    let mean = f.iter().sum::<f64>() / n;
    let mut dev: Vec<f64> = f.iter().map(|x| (x - mean).abs()).collect();
    dev.sort_by(f64::total_cmp);
    let p99 = dev[((0.99 * (dev.len() - 1) as f64).round() as usize).min(dev.len() - 1)];
    let (lo, hi) = f
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
            (a.min(x), b.max(x))
        });
    let free = f.iter().filter(|&&x| x <= 1e-9).count();
    let rms = |s: &[f64]| {
        (s.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / s.len().max(1) as f64).sqrt()
    };
    let (a, b) = f.split_at(f.len() / 2);
    let growth = if rms(a) > 1e-12 { rms(b) / rms(a) } else { 1.0 };
    PressResult {
        mean_force_n: mean,
        ripple_p99_n: p99,
        peak_to_peak_n: hi - lo,
        free_frames: free,
        growth,
        stable: free == 0 && p99 <= limit && p99.is_finite(),
        ..PressResult::default()
    }
}

/// The search for the stiffest stable coupling at one rate.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct KtSearch {
    /// Loop rate, Hz.
    pub rate_hz: f64,
    /// The stiffest stable `kt` found, N/mm (`None`: not even the ladder's first rung).
    pub largest_stable_kt: Option<f64>,
    /// The softest unstable `kt` found, N/mm (`None`: stable up to the engine's largest `kt`).
    pub smallest_unstable_kt: Option<f64>,
    /// Every press run, in order.
    pub presses: Vec<PressResult>,
}

/// The stiffest stable coupling: presses at `kt = from, 2·from, 4·from, …` up to the
/// engine's largest `kt` ([`engine::config::KT`]) until one is unstable, then `bisections`
/// geometric bisections between the last stable and the first unstable rung.
/// Assumes stability is lost once as `kt` grows (the coupling's usual behaviour).
pub fn largest_stable_kt(
    scene: &Scene,
    p: &PressParams,
    rate_hz: f64,
    from: f64,
    bisections: u32,
) -> Result<KtSearch, SceneError> {
    let mut s = KtSearch {
        rate_hz,
        ..KtSearch::default()
    };
    let top = engine::config::KT.hi;
    let mut kt = from.clamp(engine::config::KT.lo, top);
    loop {
        let r = press(scene, p, kt, rate_hz)?;
        s.presses.push(r);
        if !r.stable {
            s.smallest_unstable_kt = Some(kt);
            break;
        }
        s.largest_stable_kt = Some(kt);
        if kt >= top {
            return Ok(s);
        }
        kt = (2.0 * kt).min(top);
    }
    if let (Some(mut lo), Some(mut hi)) = (s.largest_stable_kt, s.smallest_unstable_kt) {
        for _ in 0..bisections {
            let mid = (lo * hi).sqrt();
            let r = press(scene, p, mid, rate_hz)?;
            s.presses.push(r);
            if r.stable {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        s.largest_stable_kt = Some(lo);
        s.smallest_unstable_kt = Some(hi);
    }
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn measure_flags_ripple_and_bouncing() {
        let steady: Vec<f64> = (0..500)
            .map(|i| 1.0 + 0.01 * (i as f64 * 0.3).sin())
            .collect();
        let r = measure(&steady, 0.05);
        assert!(r.stable && r.ripple_p99_n <= 0.0101 && (r.mean_force_n - 1.0).abs() < 1e-3);
        let buzzing: Vec<f64> = (0..500)
            .map(|i| 1.0 + 0.2 * (i as f64 * 0.3).sin())
            .collect();
        assert!(!measure(&buzzing, 0.05).stable);
        let bouncing: Vec<f64> = (0..500)
            .map(|i| if i % 50 < 5 { 0.0 } else { 1.0 })
            .collect();
        let r = measure(&bouncing, 0.05);
        assert!(!r.stable && r.free_frames == 50);
        let growing: Vec<f64> = (0..500)
            .map(|i| 1.0 + 1e-3 * (i as f64 / 50.0).exp() * (i as f64 * 0.5).sin())
            .collect();
        assert!(measure(&growing, 0.05).growth > 2.0);
    }
}
