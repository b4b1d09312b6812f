//! The safety invariants for any settings: over the whole config space — every
//! numeric key of a scene, each drawn from its valid range or from values that break it (NaN,
//! ±inf, negative, 1e12, a wrapping `relinearize`) — either the settings are refused with a
//! one-line error naming a bad key, by the scene file and by the API alike, or a short scripted
//! press into an object, with jitter, sends a wrench that is finite, within the clamp, never
//! pushes the hand into the object, and changes by at most the rate limit per frame.
//!
//! Then one regression test per settings failure an adversarial pass found, each through the
//! scene file and through the API. `FUZZ_CASES=N` sets the proptest cases (default 40: the
//! suite runs in CI on 2 cores).

mod common;

use collide::Pose;
use engine::config::{self, Range};
use engine::safety::norm3;
use engine::safety::{Safety, SafetyParams};
use proptest::prelude::*;
use scene::device::ReplayDevice;
use scene::rt::{run_frames, run_loop, FrameRecord, LoopParams, Pacing};
use scene::trajectory::{TrajSample, Trajectory};
use scene::{Coupling, Motion, Scene, SceneSpec, SolverSpec};
use spheretree::{Sphere, SphereTree};

/// Centre and radius of the object: a ball whose top is at z = 0 (mm).
const BALL_C: [f64; 3] = [0.0, 0.0, -100.0];
const BALL_R: f64 = 100.0;

/// A tool of two 2 mm leaves at x = ±1 mm under a 3 mm root.
fn tool_tree() -> SphereTree {
    let spheres = vec![
        Sphere::new([0.0; 3], 3.0),
        Sphere::new([-1.0, 0.0, 0.0], 2.0),
        Sphere::new([1.0, 0.0, 0.0], 2.0),
    ];
    SphereTree::from_slots(2, 2, spheres).unwrap()
}

fn ball_tree() -> SphereTree {
    SphereTree::from_slots(1, 2, vec![Sphere::new(BALL_C, BALL_R)]).unwrap()
}

/// Every numeric setting of a scene.
#[derive(Clone, Debug)]
struct Settings {
    safety: SafetyParams,
    coupling: Coupling,
    solver: SolverSpec,
    rate_hz: f64,
}

fn scene(s: &Settings) -> Scene {
    Scene {
        name: "safety.toml".into(),
        tool: tool_tree(),
        tool_mesh: None,
        objects: vec![(ball_tree(), Pose::identity())],
        object_meshes: vec![None],
        coupling: s.coupling,
        solver: s.solver,
        safety: s.safety,
        start: Pose::from_array([0.0, 0.0, 10.0, 0.0, 0.0, 0.0]),
        rate_hz: s.rate_hz,
        motion: Motion::Hold,
        goal: None,
        device: Default::default(),
        load_log: Vec::new(),
        object_friction: Vec::new(),
        tool_friction: None,
    }
}

/// A number as a TOML float (TOML spells the non-finite ones `nan`, `inf`, `-inf`).
fn toml_f64(v: f64) -> String {
    if v.is_nan() {
        "nan".into()
    } else if v.is_infinite() {
        if v > 0.0 { "inf" } else { "-inf" }.into()
    } else {
        format!("{v:?}")
    }
}

/// The same settings as a scene file.
fn toml(s: &Settings) -> String {
    let f = toml_f64;
    format!(
        "[tool]\ntree = \"tool.sph\"\nstart = [0, 0, 10, 0, 0, 0]\n\n[[object]]\ntree = \"ball.sph\"\n\n\
         [coupling]\nkt = {}\nkr = {}\n\n\
         [solver]\nrelinearize = {}\npenetration_tol_mm = {}\nskin_mm = {}\nmax_margin_mm = {}\nbudget_us = {}\n\n\
         [safety]\nmax_force_n = {}\nmax_torque_nmm = {}\nmax_force_step_n = {}\nmax_torque_step_nmm = {}\nsoft_start_s = {}\n\n\
         [device]\nrate_hz = {}\n",
        f(s.coupling.kt),
        f(s.coupling.kr),
        s.solver.relinearize,
        f(s.solver.penetration_tol_mm),
        f(s.solver.skin_mm),
        f(s.solver.max_margin_mm),
        f(s.solver.budget_us),
        f(s.safety.max_force_n),
        f(s.safety.max_torque_nmm),
        f(s.safety.max_force_step_n),
        f(s.safety.max_torque_step_nmm),
        f(s.safety.soft_start_s),
        f(s.rate_hz),
    )
}

/// A value of `r`'s key: mostly inside the range (often at a bound), sometimes one that no
/// range accepts. Returns the value and whether it is bad.
fn value(r: Range) -> impl Strategy<Value = (f64, bool)> {
    let lo = if r.lo_open {
        r.lo + (r.hi - r.lo) * 1e-9
    } else {
        r.lo
    };
    let good = prop_oneof![
        3 => (lo..=r.hi).prop_map(|v| (v, false)),
        1 => Just((lo, false)),
        1 => Just((r.hi, false)),
    ];
    let bad = prop_oneof![
        Just(f64::NAN),
        Just(f64::INFINITY),
        Just(f64::NEG_INFINITY),
        Just(-10.0),
        Just(-1e-300),
        Just(1e12),
        Just(f64::MAX),
    ]
    .prop_map(|v| (v, true));
    prop_oneof![24 => good, 1 => bad]
}

/// `relinearize`: `0..=16`, or a count that wraps `1 + n` or costs seconds per frame.
fn relinearize() -> impl Strategy<Value = (u32, bool)> {
    prop_oneof![
        24 => (0u32..=16).prop_map(|n| (n, false)),
        1 => prop_oneof![Just(u32::MAX), Just(17u32), 17u32..].prop_map(|n| (n, true)),
    ]
}

/// Settings and the keys (scene-file spelling) given a bad value.
fn settings() -> impl Strategy<Value = (Settings, Vec<&'static str>)> {
    (
        (
            value(config::MAX_FORCE_N),
            value(config::MAX_TORQUE_NMM),
            value(config::MAX_FORCE_STEP_N),
            value(config::MAX_TORQUE_STEP_NMM),
            value(config::SOFT_START_S),
        ),
        (value(config::KT), value(config::KR)),
        (
            relinearize(),
            value(config::PENETRATION_TOL_MM),
            value(config::SKIN_MM),
            value(config::MAX_MARGIN_MM),
            value(config::BUDGET_US),
        ),
        value(config::RATE_HZ),
    )
        .prop_map(
            |((f, t, fs, ts, ss), (kt, kr), (rl, pt, sk, tm, tr), rate)| {
                let mut bad = Vec::new();
                for (b, key) in [
                    (f.1, config::MAX_FORCE_N.key),
                    (t.1, config::MAX_TORQUE_NMM.key),
                    (fs.1, config::MAX_FORCE_STEP_N.key),
                    (ts.1, config::MAX_TORQUE_STEP_NMM.key),
                    (ss.1, config::SOFT_START_S.key),
                    (kt.1, config::KT.key),
                    (kr.1, config::KR.key),
                    (rl.1, config::RELINEARIZE.key),
                    (pt.1, config::PENETRATION_TOL_MM.key),
                    (sk.1, config::SKIN_MM.key),
                    (tm.1, config::MAX_MARGIN_MM.key),
                    (tr.1, config::BUDGET_US.key),
                    (rate.1, config::RATE_HZ.key),
                ] {
                    if b {
                        bad.push(key);
                    }
                }
                let s = Settings {
                    safety: SafetyParams {
                        max_force_n: f.0,
                        max_torque_nmm: t.0,
                        max_force_step_n: fs.0,
                        max_torque_step_nmm: ts.0,
                        soft_start_s: ss.0,
                    },
                    coupling: Coupling {
                        kt: kt.0,
                        kr: kr.0,
                        ..Coupling::default()
                    },
                    solver: SolverSpec {
                        relinearize: rl.0,
                        penetration_tol_mm: pt.0,
                        skin_mm: sk.0,
                        max_margin_mm: tm.0,
                        budget_us: tr.0,
                        ..SolverSpec::default()
                    },
                    rate_hz: rate.0,
                };
                (s, bad)
            },
        )
}

/// A press into the ball's top: 50 frames above it, 150 frames down to `depth` mm inside
/// (with a sideways jitter of `jitter` mm and 10x that in mrad), 100 frames held, 50 frames
/// back out. Times are `frame / rate_hz`.
fn press(rate_hz: f64, depth: f64, jitter: f64) -> Trajectory {
    let mut samples = Vec::new();
    for i in 0..350usize {
        let z = match i {
            0..50 => 10.0,
            50..200 => 10.0 - (10.0 + depth) * (i - 50) as f64 / 150.0,
            200..300 => -depth,
            _ => -depth + (10.0 + depth) * (i - 300) as f64 / 50.0,
        };
        // Deterministic jitter (a shaking hand).
        let j = |k: usize| jitter * (((i * 7919 + k * 104_729) % 1000) as f64 / 500.0 - 1.0);
        samples.push(TrajSample {
            t: i as f64 / rate_hz,
            q: [j(1), j(2), z, 0.01 * j(3), 0.01 * j(4), 0.01 * j(5)],
        });
    }
    Trajectory { samples }
}

/// The invariants of the sent wrench over a run; `Err` names the frame and what broke.
fn check_frames(frames: &[FrameRecord], p: &SafetyParams) -> Result<(), String> {
    let mut prev = [0.0; 6];
    for (i, f) in frames.iter().enumerate() {
        let w = f.frame.wrench;
        if !w.iter().all(|v| v.is_finite()) {
            return Err(format!("frame {i}: non-finite wrench {w:?}"));
        }
        let (fn_, tn) = (norm3(&w[0..3]), norm3(&w[3..6]));
        if fn_ > p.max_force_n * (1.0 + 1e-12) {
            return Err(format!("frame {i}: force {fn_} N above the clamp"));
        }
        if tn > p.max_torque_nmm * (1.0 + 1e-12) {
            return Err(format!("frame {i}: torque {tn} N·mm above the clamp"));
        }
        let d: Vec<f64> = (0..6).map(|k| w[k] - prev[k]).collect();
        if norm3(&d[0..3]) > p.max_force_step_n * (1.0 + 1e-9) + 1e-12 {
            return Err(format!("frame {i}: force step {} N", norm3(&d[0..3])));
        }
        if norm3(&d[3..6]) > p.max_torque_step_nmm * (1.0 + 1e-9) + 1e-9 {
            return Err(format!("frame {i}: torque step {} N·mm", norm3(&d[3..6])));
        }
        // While the hand's tool is inside the ball, and deeper than the graphic tool, the spring
        // pulls it out: along the outward normal at the graphic tool (the ball is convex), never
        // into it. (Otherwise a tool that lags the hand, in a frame whose passes ran out, may
        // pull it toward the surface: with a hand 0.0047 mm inside the leaves' reach but above
        // the tool, the spring pulls it down.)
        let h = f.frame.q_h;
        let g = f.frame.q_g;
        let n: Vec<f64> = (0..3).map(|k| g[k] - BALL_C[k]).collect();
        let nn = norm3(&n);
        let hand_r = norm3(&[h[0] - BALL_C[0], h[1] - BALL_C[1], h[2] - BALL_C[2]]);
        // (The tool's 2 mm leaves overlap the ball.)
        let hand_in = hand_r < BALL_R + 2.0 && hand_r < nn;
        let into = -(w[0] * n[0] + w[1] * n[1] + w[2] * n[2]) / nn;
        if hand_in && into > 1e-9 * fn_.max(1.0) {
            return Err(format!(
                "frame {i}: the force {:?} pushes {into} N into the object (q_g {g:?})",
                &w[0..3]
            ));
        }
        prev = w;
    }
    Ok(())
}

/// Runs the press through the public loop; the settings must be valid.
fn run(s: &Settings, traj: &Trajectory) -> Result<Vec<FrameRecord>, scene::SceneError> {
    let sc = scene(s);
    let mut engine = sc.engine()?;
    engine.reset(&Pose::from_array(traj.samples[0].q)).unwrap();
    let mut dev = ReplayDevice::new(traj.clone());
    let params = LoopParams {
        pacing: Pacing {
            rate_hz: sc.rate_hz,
            ..Pacing::default()
        },
        ..LoopParams::default()
    };
    Ok(run_loop(&mut engine, &mut dev, &params)?.frames)
}

fn cases() -> u32 {
    std::env::var("FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(40)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(), ..ProptestConfig::default() })]

    #[test]
    fn any_settings_are_refused_naming_a_bad_key_or_render_safely(
        (s, bad) in settings(),
        depth in 0.5f64..8.0,
        jitter in 0.0f64..1.0,
    ) {
        // The scene file and the API decide alike.
        let parsed = SceneSpec::parse(&toml(&s), "safety.toml");
        let sc = scene(&s);
        let api = sc.validate();
        let god = sc.god_object();
        let safety_ok = Safety::try_new(s.safety).is_ok();
        let loop_ok = Pacing { rate_hz: s.rate_hz, ..Pacing::default() }.validate().is_ok();
        if bad.is_empty() {
            prop_assert!(parsed.is_ok(), "{:?}", parsed.err().map(|e| e.to_string()));
            prop_assert!(api.is_ok() && god.is_ok() && safety_ok && loop_ok);
            let frames = run(&s, &press(s.rate_hz, depth, jitter))
                .map_err(|e| TestCaseError::fail(e.to_string()))?;
            prop_assert_eq!(frames.len(), 350);
            check_frames(&frames, &s.safety).map_err(TestCaseError::fail)?;
            // The press is felt unless the limits make it tiny: some force reaches the hand.
            prop_assert!(frames.iter().any(|f| f.frame.wrench[2] > 0.0), "no force at all");
        } else {
            for e in [parsed.err().map(|e| common::chain(&e)), api.err().map(|e| common::chain(&e))] {
                let e = e.ok_or_else(|| TestCaseError::fail(format!("accepted bad {bad:?}")))?;
                prop_assert!(e.starts_with("safety.toml: "), "{}", e);
                prop_assert!(!e.contains('\n'), "{}", e);
                prop_assert!(bad.iter().any(|k| e.contains(&format!("{k} = "))), "{} names none of {:?}", e, bad);
                prop_assert!(e.contains(": must be "), "{}", e);
            }
            // The API refuses too, at whichever struct holds the bad key; and even if a bad
            // safety struct is used anyway, the filter sends nothing rather than a bad force.
            prop_assert!(god.is_err() || !safety_ok || !loop_ok);
            if !safety_ok {
                let mut f = Safety::new(s.safety);
                for t in [0.0, 0.5, 1.0] {
                    prop_assert_eq!(f.filter(t, [0.0, 0.0, 110.9, 0.0, 0.0, 50.0]).0, [0.0; 6]);
                }
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Regression tests, one per settings failure an adversarial pass found.

fn good() -> Settings {
    Settings {
        safety: SafetyParams::default(),
        coupling: Coupling::default(),
        solver: SolverSpec::default(),
        rate_hz: 1000.0,
    }
}

/// The scene file and the API both refuse `s`, naming `key` and its value.
#[track_caller]
fn refused(s: &Settings, needle: &str) {
    let e = common::chain(
        &SceneSpec::parse(&toml(s), "scene.toml").expect_err("the scene file accepted it"),
    );
    assert!(e.starts_with("scene.toml: ") && e.contains(needle), "{e}");
    assert!(!e.contains('\n'), "{e}");
    let e = common::chain(&scene(s).validate().unwrap_err());
    assert!(e.contains(needle), "{e}");
}

#[test]
fn nan_max_force_is_refused_not_unclamped() {
    let mut s = good();
    s.safety.max_force_n = f64::NAN;
    refused(
        &s,
        "[safety] max_force_n = NaN: must be a finite number in (0, 100] N",
    );
    let e = Safety::try_new(s.safety).unwrap_err().to_string();
    assert!(e.contains("max_force_n = NaN"), "{e}");
    // Through the API anyway: the engine refuses to start; a bare filter sends nothing.
    let e = common::chain(&run(&s, &press(1000.0, 3.0, 0.0)).unwrap_err());
    assert!(e.contains("max_force_n"), "{e}");
    let mut f = Safety::new(s.safety);
    assert_eq!(f.filter(1.0, [0.0, 0.0, 110.9, 0.0, 0.0, 0.0]).0, [0.0; 6]);
}

#[test]
fn negative_max_force_is_refused_never_reversed() {
    let mut s = good();
    s.safety.max_force_n = -10.0;
    refused(&s, "[safety] max_force_n = -10");
    let mut f = Safety::new(s.safety);
    for t in [0.0, 0.1, 1.0] {
        let (w, _) = f.filter(t, [0.0, 0.0, 12.0, 0.0, 0.0, 0.0]);
        assert!(w[2] >= 0.0, "{w:?}");
    }
}

#[test]
fn negative_skin_is_refused() {
    let mut s = good();
    s.solver.skin_mm = -1000.0;
    refused(
        &s,
        "[solver] skin_mm = -1000: must be a finite number in [0, 10] mm",
    );
    let sc = scene(&s);
    let e = common::chain(&sc.god_object().err().unwrap());
    assert!(e.contains("skin_mm = -1000"), "{e}");
}

#[test]
fn wrapping_relinearize_is_refused_and_cannot_wrap() {
    let mut s = good();
    s.solver.relinearize = u32::MAX;
    refused(
        &s,
        "[solver] relinearize = 4294967295: must be an integer in 0..=16",
    );
    // The largest accepted count presses without freezing: the tool follows in free space
    // (no force before contact) and the press is felt.
    s.solver.relinearize = 16;
    let frames = run(&s, &press(1000.0, 3.0, 0.2)).unwrap();
    check_frames(&frames, &s.safety).unwrap();
    for f in &frames[..50] {
        assert!(norm3(&f.frame.wrench[0..3]) < 1e-9, "{:?}", f.frame.wrench);
    }
    assert!(
        frames[250].frame.wrench[2] > 1.0,
        "{:?}",
        frames[250].frame.wrench
    );
}

#[test]
fn absurd_rates_are_refused_not_a_panic_or_an_abort() {
    for (rate, shown) in [
        (1e-30, "1e-30"),
        (1e12, "1e12"),
        (1e7, "10000000"),
        (0.0, "0"),
    ] {
        let mut s = good();
        s.rate_hz = rate;
        refused(
            &s,
            &format!("[device] rate_hz = {shown}: must be a finite number in [100, 20000] Hz"),
        );
        let e = Pacing {
            rate_hz: rate,
            ..Pacing::default()
        }
        .validate()
        .unwrap_err()
        .to_string();
        assert!(e.contains("rate_hz"), "{e}");
    }
    // run_frames (no validation of its own) paces a bad rate at 1 kHz instead of panicking in
    // Duration::from_secs_f64.
    let s = good();
    let sc = scene(&s);
    let mut engine = sc.engine().unwrap();
    let traj = press(1000.0, 1.0, 0.0);
    engine.reset(&Pose::from_array(traj.samples[0].q)).unwrap();
    let mut dev = ReplayDevice::new(traj);
    let mut records = Vec::with_capacity(20);
    let params = LoopParams {
        pacing: Pacing {
            rate_hz: 1e-30,
            spin_us: f64::NAN,
            rt_priority: None,
        },
        realtime: true,
        ..LoopParams::default()
    };
    assert_eq!(
        run_frames(&mut engine, &mut dev, &params, &mut records).0,
        20
    );
}

#[test]
fn negative_or_equal_timestamps_do_not_zero_the_force() {
    // The soft start runs on the loop's clock, not the recording's: a column of equal (or
    // negative) times used to hold the force at zero for the whole run.
    for t in [0.0, -3.0] {
        let mut traj = press(1000.0, 3.0, 0.0);
        for smp in &mut traj.samples {
            smp.t = t;
        }
        let frames = run(&good(), &traj).unwrap();
        check_frames(&frames, &SafetyParams::default()).unwrap();
        assert!(
            frames[250].frame.wrench[2] > 1.0,
            "t = {t}: {:?}",
            frames[250].frame.wrench
        );
    }
}
