//! Coulomb friction in the frame step (docs/DESIGN.md, "Friction"):
//!
//! - zero coefficients, or friction turned off, give the frictionless frames exactly;
//! - on an ideally flat plate the force at breakaway is `mu_s N` and while sliding `mu_k N`,
//!   within 2 %, at 10 and 500 mm/s, and the twist torque `mu N rho` turning;
//! - friction never gives the hand more than the spring it stretched: the spring energy at the
//!   new pose, to the current hand, never exceeds the energy at the last pose;
//! - it never penetrates, also pressed and dragged at 2 m/s over a thin plate;
//! - scene files: `friction = { static, kinetic }` per body, refused with one line when wrong.

mod common;

use collide::{rotation_log, Pose};
use engine::step::{FrameOutput, FrictionState};
use engine::{EngineConfig, Friction};
use scene::scenes::plate::{self, PlateTool, SpeedMotion};
use scene::trajectory::{Ease, Script};
use scene::{Motion, Scene, SceneSpec};

const ROUGH: Friction = Friction {
    static_mu: 0.4,
    kinetic_mu: 0.3,
};

/// The frames without their timings (which differ from run to run).
fn untimed(frames: &[FrameOutput]) -> Vec<FrameOutput> {
    frames
        .iter()
        .map(|f| FrameOutput {
            cd_us: 0.0,
            opt_us: 0.0,
            total_us: 0.0,
            ahead_us: 0.0,
            ..*f
        })
        .collect()
}

fn bunny() -> Scene {
    let mut s = scene::scenes::builtin("bunny", &common::test_cache()).unwrap();
    s.solver.budget_us = engine::config::BUDGET_US.hi;
    s
}

#[test]
fn zero_friction_and_friction_off_give_the_frictionless_frames() {
    let plain = bunny();
    let reference = untimed(&common::replay(&plain));
    let mut zero = plain.clone();
    zero.object_friction = vec![Friction::NONE];
    zero.tool_friction = Some(ROUGH);
    assert_eq!(untimed(&common::replay(&zero)), reference);
    // Coefficients set, friction turned off.
    let mut rough = plain.clone();
    rough.object_friction = vec![ROUGH];
    let traj = rough.trajectory();
    let mut god = rough.god_object().unwrap();
    god.set_friction_enabled(false);
    god.reset(&Pose::from_array(traj.samples[0].q)).unwrap();
    let off: Vec<FrameOutput> = traj
        .samples
        .iter()
        .map(|s| god.step(&Pose::from_array(s.q)))
        .collect();
    assert_eq!(untimed(&off), reference);
    // And on, the frames differ: friction acts on this run.
    let on = common::replay(&rough);
    assert!(on.iter().any(|f| f.friction == FrictionState::Stick));
    assert!(on.iter().any(|f| f.friction == FrictionState::Slip));
    assert_ne!(untimed(&on), reference);
}

/// A push on the ideal flat: (mean normal force N, largest force against the motion up to the
/// first slip, mean force against it over the second half of the motion, torsional radius).
fn push(motion: SpeedMotion) -> (f64, f64, f64, f64) {
    push_on(motion, Surface::IdealFlat).0
}

/// What the puck is pushed on.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Surface {
    /// The one-sphere plate.
    IdealFlat,
    /// The plate's and the puck's own box meshes (the mesh geometry mode).
    Mesh,
    /// The mesh plate tilted by [`plate::plate_tilt`], the push carried with it.
    TiltedMesh,
}

/// [`push`] on `surface`, with the least force against the motion after the first slip; the
/// forces and torques along (about) the plate's own axes.
fn push_on(motion: SpeedMotion, surface: Surface) -> ((f64, f64, f64, f64), f64) {
    let (script, (t0, t1)) = plate::push_script(motion);
    let cache = common::test_cache();
    let tilt = if surface == Surface::TiltedMesh {
        plate::plate_tilt()
    } else {
        nalgebra::Matrix3::identity()
    };
    let mut sc = match surface {
        Surface::IdealFlat => plate::flat_scene(&cache, PlateTool::Puck, script).unwrap(),
        Surface::Mesh => plate::scene(&cache, PlateTool::Puck, script).unwrap(),
        Surface::TiltedMesh => {
            plate::tilted_scene(&cache, PlateTool::Puck, &script, &tilt).unwrap()
        }
    };
    if surface != Surface::IdealFlat {
        sc.solver.geometry = engine::Geometry::Mesh;
        assert_eq!(sc.geometry(), engine::Geometry::Mesh);
    }
    sc.object_friction = vec![ROUGH];
    // No frame budget: the law is checked on the constrained optimum of every frame, whatever
    // else the machine is doing.
    sc.solver.budget_us = engine::config::BUDGET_US.hi;
    let traj = sc.trajectory();
    let mut god = sc.god_object().unwrap();
    god.reset(&Pose::from_array(traj.samples[0].q)).unwrap();
    let turn = matches!(motion, SpeedMotion::Turn(_));
    let mut moving = Vec::new();
    let mut rho = 0.0;
    for s in &traj.samples {
        let f = god.step(&Pose::from_array(s.q));
        assert!(f.penetration_mm <= 0.01, "{f:?}");
        if s.t >= t0 && s.t < t1 {
            moving.push(f);
            rho = god.friction_contact().map_or(0.0, |c| c.1);
        }
    }
    let (normal, along) = (tilt.column(2).into_owned(), tilt.column(0).into_owned());
    let against = |f: &FrameOutput| {
        let w = &f.raw_wrench;
        if turn {
            -nalgebra::Vector3::new(w[3], w[4], w[5]).dot(&normal)
        } else {
            -nalgebra::Vector3::new(w[0], w[1], w[2]).dot(&along)
        }
    };
    let n = moving
        .iter()
        .map(|f| {
            nalgebra::Vector3::new(f.raw_wrench[0], f.raw_wrench[1], f.raw_wrench[2]).dot(&normal)
        })
        .sum::<f64>()
        / moving.len() as f64;
    let slip = moving
        .iter()
        .position(|f| f.friction == FrictionState::Slip)
        .expect("the push never slipped");
    assert!(slip > 0, "slipped at once: no stick phase");
    let breakaway = moving[..=slip].iter().map(against).fold(0.0, f64::max);
    let half = &moving[moving.len() / 2..];
    let sliding = half.iter().map(against).sum::<f64>() / half.len() as f64;
    let least_after = moving[slip..]
        .iter()
        .map(against)
        .fold(f64::INFINITY, f64::min);
    ((n, breakaway, sliding, rho), least_after)
}

/// On meshed faces (a box puck on a box plate, two triangles a face) the law holds as on the
/// ideal flat: breakaway and sliding within 2 %, the torsional radius that of the shared area
/// (a 40 mm square: 0.3826 × 40 mm), and once sliding no frame lets go of the friction.
#[test]
fn on_a_meshed_plate_the_law_holds_sliding_and_turning() {
    law_holds_on(Surface::Mesh);
}

/// The same on the mesh plate tilted so that no face or edge runs along a world axis: the
/// contact's normal, patch and torsional radius come from the parts, not from the axes.
#[test]
fn on_a_tilted_meshed_plate_the_law_holds_sliding_and_turning() {
    law_holds_on(Surface::TiltedMesh);
}

fn law_holds_on(surface: Surface) {
    for motion in [SpeedMotion::Slide(10.0), SpeedMotion::Turn(1.0)] {
        let ((n, breakaway, sliding, rho), least) = push_on(motion, surface);
        assert!(n > 0.5, "{motion:?}: pressed with {n} N");
        let turn = matches!(motion, SpeedMotion::Turn(_));
        let lever = if turn { rho } else { 1.0 };
        if turn {
            let square = 40.0 * (2f64.sqrt() + (1.0 + 2f64.sqrt()).ln()) / 6.0;
            assert!((rho - square).abs() < 1e-6, "torsional radius {rho} mm");
        }
        let (want_s, want_k) = (ROUGH.static_mu * n * lever, ROUGH.kinetic_mu * n * lever);
        assert!(
            (breakaway / want_s - 1.0).abs() <= 0.02,
            "{motion:?}: {breakaway} vs {want_s}"
        );
        assert!(
            (sliding / want_k - 1.0).abs() <= 0.02,
            "{motion:?}: {sliding} vs {want_k}"
        );
        assert!(
            least >= 0.9 * want_k,
            "{motion:?}: the force fell to {least} while sliding"
        );
    }
}

#[test]
fn on_a_flat_plate_breakaway_is_mu_s_n_and_sliding_mu_k_n() {
    for v in [10.0, 500.0] {
        let (n, breakaway, sliding, _) = push(SpeedMotion::Slide(v));
        assert!(n > 1.0, "pressed with {n} N");
        let (want_s, want_k) = (ROUGH.static_mu * n, ROUGH.kinetic_mu * n);
        assert!(
            (breakaway / want_s - 1.0).abs() <= 0.02,
            "{v} mm/s: breakaway {breakaway} N against mu_s N = {want_s}"
        );
        assert!(
            (sliding / want_k - 1.0).abs() <= 0.02,
            "{v} mm/s: sliding {sliding} N against mu_k N = {want_k}"
        );
    }
    let (n, breakaway, sliding, rho) = push(SpeedMotion::Turn(3.0));
    assert!(rho > 5.0, "torsional radius {rho} mm for a 40 mm puck");
    let (want_s, want_k) = (ROUGH.static_mu * n * rho, ROUGH.kinetic_mu * n * rho);
    assert!(
        (breakaway / want_s - 1.0).abs() <= 0.02,
        "{breakaway} vs {want_s}"
    );
    assert!(
        (sliding / want_k - 1.0).abs() <= 0.02,
        "{sliding} vs {want_k}"
    );
}

/// Spring energy `1/2 |q - q_h|²_G` (N·mm) of the graphic pose `q` to the hand `q_h`.
fn energy(g: &EngineConfig, q: &Pose, q_h: &Pose) -> f64 {
    let t = (q.translation() - q_h.translation()).norm_squared();
    let w = rotation_log(&(q.rotation_matrix() * q_h.rotation_matrix().transpose())).norm_squared();
    0.5 * (g.kt * t + g.kr * w)
}

#[test]
fn friction_never_gives_the_hand_more_than_the_spring_it_stretched() {
    let cache = common::test_cache();
    let slide = plate::speed_script(PlateTool::Puck, SpeedMotion::Slide(200.0), 1000.0, 0.2);
    let mut scenes = vec![
        bunny(),
        plate::scene(&cache, PlateTool::Puck, slide.script).unwrap(),
    ];
    let mut checked = 0;
    for sc in &mut scenes {
        sc.object_friction = vec![ROUGH; sc.objects.len()];
        sc.solver.budget_us = engine::config::BUDGET_US.hi;
        let cfg = sc.engine_config();
        let frames = common::replay(sc);
        for w in frames.windows(2) {
            let (prev, f) = (&w[0], &w[1]);
            if f.friction == FrictionState::None || f.status != engine::FrameStatus::Ok {
                continue;
            }
            let q_h = Pose::from_array(f.q_h);
            let before = energy(&cfg, &Pose::from_array(prev.q_g), &q_h);
            let after = energy(&cfg, &Pose::from_array(f.q_g), &q_h);
            // Within what the step resolves: its answer is exact to CONVERGED_MM (0.005 mm) of
            // motion, worth |F| · 0.005 mm of energy.
            let force =
                (f.raw_wrench[0].powi(2) + f.raw_wrench[1].powi(2) + f.raw_wrench[2].powi(2))
                    .sqrt();
            assert!(
                after <= before + 0.005 * force + 1e-9,
                "{}: energy {after} N·mm after the frame, {before} before it ({f:?})",
                sc.name
            );
            checked += 1;
        }
    }
    assert!(checked > 1000, "only {checked} frames with friction");
}

#[test]
fn dragged_at_2_m_per_s_over_a_thin_plate_with_friction_never_penetrates() {
    let cache = common::test_cache();
    // The ball pressed 1 mm into the tree plate (10 mm thick) and dragged at 2 m/s.
    let script = Script::starting_at([0.0, 0.0, 2.0, 0.0, 0.0, 0.0])
        .then(0.1, [-40.0, 0.0, -1.0, 0.0, 0.0, 0.0], Ease::Smooth)
        .then(0.04, [40.0, 0.0, -1.0, 0.0, 0.0, 0.0], Ease::Linear)
        .then(0.04, [-40.0, 0.0, -3.0, 0.0, 0.0, 0.0], Ease::Linear);
    let mut sc = plate::scene(&cache, PlateTool::Ball, script).unwrap();
    sc.object_friction = vec![Friction {
        static_mu: 1.0,
        kinetic_mu: 0.8,
    }];
    let frames = common::replay(&sc);
    assert!(frames.iter().any(|f| f.friction == FrictionState::Slip));
    for f in &frames {
        assert!(f.penetration_mm <= 0.01, "{f:?}");
        assert!(f.q_g[2] > -1.0, "the ball went into the plate: {f:?}");
        assert!(f.wrench.iter().all(|v| v.is_finite()));
    }
}

const FILE: &str = r#"
[tool]
tree = "tool.sph"
friction = { static = 0.5 }

[[object]]
tree = "object.sph"
friction = { static = 0.4, kinetic = 0.3 }

[[object]]
tree = "other.sph"
"#;

#[test]
fn scene_files_give_friction_per_body_and_refuse_bad_values() {
    let spec = SceneSpec::parse(FILE, "f.toml").unwrap();
    let tool = spec.tool.friction.unwrap().friction();
    assert_eq!(
        tool,
        Friction {
            static_mu: 0.5,
            kinetic_mu: 0.5
        }
    );
    assert_eq!(spec.object[0].friction.unwrap().friction(), ROUGH);
    assert!(spec.object[1].friction.is_none());
    // The pair's coefficients: the geometric mean with the tool's.
    let pair = ROUGH.with_tool(Some(tool));
    assert!((pair.static_mu - (0.4f64 * 0.5).sqrt()).abs() < 1e-12);
    for (bad, says) in [
        (
            "{ static = 0.3, kinetic = 0.4 }",
            "kinetic = 0.4: must be at most the static",
        ),
        ("{ static = -0.1 }", "friction.static = -0.1: must be"),
        ("{ static = nan }", "friction.static = NaN: must be"),
        ("{ static = 0.3, dynamic = 0.2 }", "unknown field `dynamic`"),
    ] {
        let text = FILE.replace("{ static = 0.4, kinetic = 0.3 }", bad);
        let e = SceneSpec::parse(&text, "f.toml").unwrap_err();
        let msg = common::chain(&e);
        assert!(msg.contains(says), "{bad}: {msg}");
        assert!(msg.starts_with("f.toml"), "{msg}");
        assert!(!msg.contains('\n'), "{msg}");
    }
}

#[test]
fn an_engine_refuses_friction_for_an_object_it_does_not_have() {
    let sc = bunny();
    let mut engine = sc.engine().unwrap();
    let e = engine.set_friction(3, ROUGH).unwrap_err();
    assert_eq!(
        e.to_string(),
        "object 4 does not exist: the scene has 1 object(s)"
    );
    assert!(engine
        .set_friction(
            0,
            Friction {
                static_mu: f64::INFINITY,
                kinetic_mu: 0.1
            }
        )
        .is_err());
    assert!(matches!(
        sc.motion,
        Motion::Script(_) | Motion::Trajectory(_)
    ));
}
