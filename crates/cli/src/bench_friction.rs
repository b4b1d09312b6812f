//! The `friction` study of `haptic6d bench`: Coulomb stick and slip (docs/DESIGN.md,
//! "Friction").
//!
//! - **push**: the puck pressed 1 mm onto a plate with `mu_s = 0.4`, `mu_k = 0.3`, then the hand
//!   moves once at a constant speed: 20 mm along `x` (10–500 mm/s) or 0.5 rad about the vertical
//!   axis (1–10 rad/s). On the **ideal flat** (a one-sphere plate: [`plate::flat_scene`]) the
//!   friction law is measured alone: the force (torque) at breakaway against `mu_s N`
//!   (`mu_s N rho`, with the contact's torsional radius `rho`) and while sliding against
//!   `mu_k N` (`mu_k N rho`). On the **tree plate** (the plate's own sphere-tree, a layer of
//!   bumps) the same push shows what the hand feels along the motion on a surface made of
//!   spheres: the bumps' slopes add to and take from the friction. On the **mesh plate** the
//!   puck's and the plate's own box meshes touch (the mesh geometry mode): two flat faces, so
//!   any departure from the law comes from how the contact's triangle pairs make its patch. The
//!   **tilted mesh plate** is the mesh plate turned 0.3 rad about `(1, 2, 0)` with the pushes
//!   carried with it ([`plate::tilted_scene`]): no face or edge along a world axis.
//! - **cost**: frame time with friction against the same run frictionless, on the bunny and on
//!   the puck sliding over the tree plate at 200 mm/s.
//! - **spline**: the splined shaft with friction on the hub: whether the insertion still reaches
//!   its goal, and the twist the hand needs at alignment.
//!
//! Per push (dual solver, frames back to back): `N` (mean normal force while the hand moves),
//! breakaway and sliding force (or torque) and their error against the law, the largest
//! departure from the sliding level after breakaway (`ripple`), frames stuck and slipping, the
//! deepest penetration and frame time.

use anyhow::{anyhow, Result};
use collide::rotation_log;
use engine::step::{FrameOutput, FrictionState};
use engine::{Friction, Pose};
use nalgebra::{Matrix3, Vector3};
use scene::cache::TreeCache;
use scene::scenes::plate::{self, PlateTool, SpeedMotion};
use scene::stats::Summary;
use scene::Scene;
use serde::Serialize;

/// The coefficients of the study's plate.
pub const PLATE_FRICTION: Friction = Friction {
    static_mu: 0.4,
    kinetic_mu: 0.3,
};

/// One push of the friction study.
#[derive(Serialize, Clone, Debug)]
pub struct PushRow {
    /// `ideal flat`, `tree plate` or `mesh plate`.
    pub surface: String,
    /// `slide` or `turn`.
    pub motion: String,
    /// Hand speed: mm/s (slide) or rad/s (turn).
    pub speed: f64,
    /// Mean normal force while the hand moves, N.
    pub normal_n: f64,
    /// Torsional radius of the contact the friction used, mm (turns).
    pub rho_mm: f64,
    /// Largest force (N) or torque (N·mm) against the motion up to the first slip.
    pub breakaway: f64,
    /// What Coulomb's law gives for it: `mu_s N` (or `mu_s N rho`).
    pub breakaway_law: f64,
    /// Mean force (or torque) against the motion over the second half of the motion.
    pub sliding: f64,
    /// `mu_k N` (or `mu_k N rho`).
    pub sliding_law: f64,
    /// Largest departure (N or N·mm) of the force against the motion from the sliding law after
    /// the breakaway frame, while the hand moves.
    pub ripple: f64,
    /// Hand displacement (mm or rad) at the first slip.
    pub breakaway_at: f64,
    /// Frames that stuck and that slipped while the hand moved.
    pub stick_frames: usize,
    /// Frames that slipped.
    pub slip_frames: usize,
    /// Deepest overlap, mm.
    pub max_penetration_mm: f64,
    /// Whole step per frame, µs.
    pub total_us: Summary,
    /// (hand displacement, force against the motion) per frame while the hand moves (for the
    /// stick–slip plot; not in the JSON).
    #[serde(skip)]
    pub curve: Vec<(f64, f64)>,
}

/// Frame time with and without friction on the same run.
#[derive(Serialize, Clone, Debug)]
pub struct CostRow {
    /// Scene.
    pub scene: String,
    /// Whole step per frame without friction, µs.
    pub frictionless_us: Summary,
    /// Whole step per frame with friction, µs.
    pub friction_us: Summary,
    /// Frames that stuck and that slipped.
    pub stick_frames: usize,
    /// Frames that slipped.
    pub slip_frames: usize,
}

/// The spline with and without friction.
#[derive(Serialize, Clone, Debug)]
pub struct SplineRow {
    /// Static and kinetic coefficient on the hub.
    pub friction: [f64; 2],
    /// Lowest `z` of the shaft's origin, mm (the goal: -20).
    pub reached_z_mm: f64,
    /// Largest twist torque about the shaft's axis the hand felt, N·mm.
    pub max_twist_nmm: f64,
    /// Largest axial force, N.
    pub max_axial_n: f64,
    /// Deepest overlap, mm.
    pub max_penetration_mm: f64,
    /// Whole step per frame, µs.
    pub total_us: Summary,
}

/// The whole study.
#[derive(Serialize, Clone, Debug, Default)]
pub struct FrictionStudy {
    /// Pushes on the ideal flat, the tree plate and the mesh plate.
    pub pushes: Vec<PushRow>,
    /// Frame time with friction against without.
    pub cost: Vec<CostRow>,
    /// The spline with friction.
    pub spline: Vec<SplineRow>,
}

/// Steps the scene's god-object (its friction applied) through its device motion.
fn replay(scene: &Scene) -> Result<(Vec<f64>, Vec<FrameOutput>, Option<f64>)> {
    let traj = scene.trajectory();
    let mut god = scene.god_object()?;
    let first = traj
        .samples
        .first()
        .map(|s| Pose::from_array(s.q))
        .ok_or_else(|| anyhow!("{}: empty device motion", scene.name))?;
    god.reset(&first)?;
    let (mut times, mut out) = (Vec::new(), Vec::new());
    let mut rho = None;
    for s in &traj.samples {
        times.push(s.t);
        out.push(god.step(&Pose::from_array(s.q)));
        if let Some((_, r)) = god.friction_contact() {
            rho = Some(r);
        }
    }
    Ok((times, out, rho))
}

/// Runs the study (`quick`: fewer speeds, no spline).
pub fn friction_study(cache: &TreeCache, quick: bool) -> Result<FrictionStudy> {
    let slides: &[f64] = if quick {
        &[10.0, 500.0]
    } else {
        &[10.0, 50.0, 100.0, 500.0]
    };
    let turns: &[f64] = if quick { &[3.0] } else { &[1.0, 3.0, 10.0] };
    let mut study = FrictionStudy::default();
    for surface in [
        Surface::IdealFlat,
        Surface::TreePlate,
        Surface::MeshPlate,
        Surface::TiltedMeshPlate,
    ] {
        let motions = slides
            .iter()
            .map(|&v| SpeedMotion::Slide(v))
            .chain(turns.iter().map(|&w| SpeedMotion::Turn(w)));
        for motion in motions {
            if surface == Surface::TreePlate && matches!(motion, SpeedMotion::Turn(_)) {
                continue;
            }
            study.pushes.push(push(cache, surface, motion)?);
        }
    }
    // Cost: the same runs with friction on and off.
    let slide = plate::speed_script(PlateTool::Puck, SpeedMotion::Slide(200.0), 1000.0, 0.5);
    let mut puck = plate::scene(cache, PlateTool::Puck, slide.script)?;
    let mut bunny = scene::scenes::builtin("bunny", cache)?;
    for (name, sc) in [
        ("puck on the tree plate, 200 mm/s", &mut puck),
        ("bunny", &mut bunny),
    ] {
        let (_, plain, _) = replay(sc)?;
        sc.object_friction = vec![PLATE_FRICTION; sc.objects.len()];
        let (_, rough, _) = replay(sc)?;
        study.cost.push(CostRow {
            scene: name.into(),
            frictionless_us: Summary::of(plain.iter().map(|o| o.total_us)),
            friction_us: Summary::of(rough.iter().map(|o| o.total_us)),
            stick_frames: count(&rough, FrictionState::Stick),
            slip_frames: count(&rough, FrictionState::Slip),
        });
    }
    if !quick {
        let mut spline = scene::scenes::builtin("spline", cache)?;
        for f in [
            Friction::NONE,
            Friction {
                static_mu: 0.3,
                kinetic_mu: 0.2,
            },
        ] {
            spline.object_friction = vec![f; spline.objects.len()];
            let (_, out, _) = replay(&spline)?;
            study.spline.push(SplineRow {
                friction: [f.static_mu, f.kinetic_mu],
                reached_z_mm: out.iter().map(|o| o.q_g[2]).fold(f64::INFINITY, f64::min),
                max_twist_nmm: out
                    .iter()
                    .map(|o| o.raw_wrench[5].abs())
                    .fold(0.0, f64::max),
                max_axial_n: out
                    .iter()
                    .map(|o| o.raw_wrench[2].abs())
                    .fold(0.0, f64::max),
                max_penetration_mm: out.iter().map(|o| o.penetration_mm).fold(0.0, f64::max),
                total_us: Summary::of(out.iter().map(|o| o.total_us)),
            });
        }
    }
    Ok(study)
}

fn count(frames: &[FrameOutput], state: FrictionState) -> usize {
    frames.iter().filter(|o| o.friction == state).count()
}

/// What the puck is pushed on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Surface {
    /// A one-sphere plate: the friction law alone.
    IdealFlat,
    /// The plate's sphere-tree (default trees, the leaf spheres).
    TreePlate,
    /// The plate's and the puck's own box meshes (the mesh geometry mode).
    MeshPlate,
    /// The mesh plate tilted ([`plate::plate_tilt`]), the pushes carried with it: the same law
    /// with no face or edge along a world axis.
    TiltedMeshPlate,
}

impl Surface {
    fn name(self) -> &'static str {
        match self {
            Surface::IdealFlat => "ideal flat",
            Surface::TreePlate => "tree plate",
            Surface::MeshPlate => "mesh plate",
            Surface::TiltedMeshPlate => "tilted mesh plate",
        }
    }
}

fn push(cache: &TreeCache, surface: Surface, motion: SpeedMotion) -> Result<PushRow> {
    let (script, (t0, t1)) = plate::push_script(motion);
    let tilt = if surface == Surface::TiltedMeshPlate {
        plate::plate_tilt()
    } else {
        Matrix3::identity()
    };
    let mut sc = match surface {
        Surface::IdealFlat => plate::flat_scene(cache, PlateTool::Puck, script)?,
        Surface::TreePlate | Surface::MeshPlate => plate::scene(cache, PlateTool::Puck, script)?,
        Surface::TiltedMeshPlate => plate::tilted_scene(cache, PlateTool::Puck, &script, &tilt)?,
    };
    if matches!(surface, Surface::MeshPlate | Surface::TiltedMeshPlate) {
        sc.solver.geometry = engine::Geometry::Mesh;
        anyhow::ensure!(
            sc.geometry() == engine::Geometry::Mesh,
            "{}: the mesh plate needs the puck's and the plate's meshes",
            sc.name
        );
    }
    sc.object_friction = vec![PLATE_FRICTION];
    let (times, out, rho) = replay(&sc)?;
    let turn = matches!(motion, SpeedMotion::Turn(_));
    // The plate's normal and the slide's direction (the plate's own `z` and `x`), the force
    // (torque) against the motion, and the hand's displacement along (about) them.
    let (normal, along) = (tilt * Vector3::z(), tilt * Vector3::x());
    let force = |o: &FrameOutput| Vector3::new(o.raw_wrench[0], o.raw_wrench[1], o.raw_wrench[2]);
    let torque = |o: &FrameOutput| Vector3::new(o.raw_wrench[3], o.raw_wrench[4], o.raw_wrench[5]);
    let against = |o: &FrameOutput| {
        if turn {
            -torque(o).dot(&normal)
        } else {
            -force(o).dot(&along)
        }
    };
    let moved = |o: &FrameOutput| {
        let hand = Pose::from_array(o.q_h);
        if turn {
            rotation_log(&(tilt.transpose() * hand.rotation_matrix())).z
        } else {
            hand.translation().dot(&along)
        }
    };
    let moving: Vec<&FrameOutput> = times
        .iter()
        .zip(&out)
        .filter(|(&t, _)| t >= t0 && t < t1)
        .map(|(_, o)| o)
        .collect();
    let normal_n = Summary::of(moving.iter().map(|o| force(o).dot(&normal))).mean;
    let rho_mm = if turn { rho.unwrap_or(0.0) } else { 0.0 };
    let lever = if turn { rho_mm } else { 1.0 };
    let first_slip = moving
        .iter()
        .position(|o| o.friction == FrictionState::Slip)
        .unwrap_or(moving.len());
    let breakaway = moving[..(first_slip + 1).min(moving.len())]
        .iter()
        .map(|o| against(o))
        .fold(0.0, f64::max);
    let second_half = &moving[moving.len() / 2..];
    let sliding = Summary::of(second_half.iter().map(|o| against(o))).mean;
    let sliding_law = PLATE_FRICTION.kinetic_mu * normal_n * lever;
    let ripple = moving
        .iter()
        .skip(first_slip + 1)
        .map(|o| (against(o) - sliding_law).abs())
        .fold(0.0, f64::max);
    let (name, speed) = match motion {
        SpeedMotion::Slide(v) => ("slide", v),
        SpeedMotion::Turn(w) => ("turn", w),
    };
    Ok(PushRow {
        surface: surface.name().into(),
        motion: name.into(),
        speed,
        normal_n,
        rho_mm,
        breakaway,
        breakaway_law: PLATE_FRICTION.static_mu * normal_n * lever,
        sliding,
        sliding_law,
        ripple,
        breakaway_at: moving.get(first_slip).map_or(f64::NAN, |o| moved(o)),
        stick_frames: moving
            .iter()
            .filter(|o| o.friction == FrictionState::Stick)
            .count(),
        slip_frames: moving
            .iter()
            .filter(|o| o.friction == FrictionState::Slip)
            .count(),
        max_penetration_mm: out.iter().map(|o| o.penetration_mm).fold(0.0, f64::max),
        total_us: Summary::of(out.iter().map(|o| o.total_us)),
        curve: moving.iter().map(|o| (moved(o), against(o))).collect(),
    })
}

/// The study as markdown tables.
pub fn friction_markdown(study: &FrictionStudy) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "Pushes (mu_s = {}, mu_k = {}; slides in N, turns in N·mm):\n",
        PLATE_FRICTION.static_mu, PLATE_FRICTION.kinetic_mu
    );
    let _ = writeln!(
        s,
        "| surface | motion | speed | N (N) | rho mm | breakaway / mu_s N (rho) | error | sliding / mu_k N (rho) | error | ripple | stick / slip frames | max pen. mm | total µs p50 / p99 / max |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let pct = |a: f64, b: f64| 100.0 * (a / b - 1.0);
    for r in &study.pushes {
        let unit = if r.motion == "slide" { "mm/s" } else { "rad/s" };
        let _ = writeln!(
            s,
            "| {} | {} | {} {unit} | {:.4} | {:.2} | {:.4} / {:.4} | {:+.2} % | {:.4} / {:.4} | {:+.2} % | {:.4} | {} / {} | {:.4} | {:.1} / {:.1} / {:.1} |",
            r.surface,
            r.motion,
            r.speed,
            r.normal_n,
            r.rho_mm,
            r.breakaway,
            r.breakaway_law,
            pct(r.breakaway, r.breakaway_law),
            r.sliding,
            r.sliding_law,
            pct(r.sliding, r.sliding_law),
            r.ripple,
            r.stick_frames,
            r.slip_frames,
            r.max_penetration_mm,
            r.total_us.p50,
            r.total_us.p99,
            r.total_us.max,
        );
    }
    let _ = writeln!(
        s,
        "\nFrame time with friction (mu_s = 0.4, mu_k = 0.3 on every object):\n"
    );
    let _ = writeln!(
        s,
        "| scene | frictionless µs p50 / p99 | with friction µs p50 / p99 | p99 ratio | stick / slip frames |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|");
    for r in &study.cost {
        let _ = writeln!(
            s,
            "| {} | {:.1} / {:.1} | {:.1} / {:.1} | {:.2} | {} / {} |",
            r.scene,
            r.frictionless_us.p50,
            r.frictionless_us.p99,
            r.friction_us.p50,
            r.friction_us.p99,
            r.friction_us.p99 / r.frictionless_us.p99,
            r.stick_frames,
            r.slip_frames,
        );
    }
    if !study.spline.is_empty() {
        let _ = writeln!(s, "\nThe spline with friction on the hub:\n");
        let _ = writeln!(
            s,
            "| mu_s / mu_k | lowest z mm | max twist N·mm | max axial N | max pen. mm | total µs p50 / p99 / max |"
        );
        let _ = writeln!(s, "|---|---|---|---|---|---|");
        for r in &study.spline {
            let _ = writeln!(
                s,
                "| {} / {} | {:.3} | {:.2} | {:.3} | {:.4} | {:.1} / {:.1} / {:.1} |",
                r.friction[0],
                r.friction[1],
                r.reached_z_mm,
                r.max_twist_nmm,
                r.max_axial_n,
                r.max_penetration_mm,
                r.total_us.p50,
                r.total_us.p99,
                r.total_us.max,
            );
        }
    }
    s
}
