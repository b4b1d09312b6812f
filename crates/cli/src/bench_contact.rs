//! The `contact` study of `haptic6d bench`: large and tight contacts, where detection and the
//! QP hold hundreds to thousands of pairs.
//!
//! - **flat on flat**: the plate scene's puck pressed 1 mm onto the plate, resting, then slid
//!   at 50 mm/s ([`scene::scenes::plate`]); again with the dense puck (its tree a level
//!   deeper: thousands of pairs).
//! - **spline**: the built-in splined shaft and hub, by phase of its script: on the hub's face
//!   with the keys misaligned, turning until they align, inserting, and the frames inside the
//!   hole with no pair at all (the tight 1 mm clearance).
//!
//! Per row (dual solver, one thread, frames back to back): pairs of the first region (p50,
//! max), the rows the constraint reduction solved (p50, max), detection / optimisation /
//! whole-step time (p50, p99, max), passes, degraded frames (lagging, pair overflow, kept last
//! safe) and the deepest penetration. A second replay audits the reduction: every reduced QP
//! solved in full as well, on the same rows, and the largest difference of the answers'
//! forces (N, and relative to the full answer's force) per phase.

use anyhow::Result;
use collide::Pose;
use engine::step::{FrameOutput, ReductionAudit};
use engine::SolverKind;
use scene::cache::TreeCache;
use scene::scenes::plate::{self, PlateTool, SpeedMotion};
use scene::stats::Summary;
use scene::Scene;
use serde::Serialize;

/// One row of the contact study.
#[derive(Serialize, Clone, Debug)]
pub struct ContactRow {
    /// Scene.
    pub scene: String,
    /// Phase of the scene's motion.
    pub phase: String,
    /// Frames in the phase.
    pub frames: usize,
    /// Pairs of the first region per frame.
    pub pairs: Summary,
    /// Rows of the frame's largest solve after constraint reduction.
    pub rows: Summary,
    /// Reduced QPs audited against a full solve of the same rows (second replay).
    pub audited_solves: u64,
    /// Largest force difference of reduced against full answers, N.
    pub max_force_diff_n: f64,
    /// Largest force difference relative to the full answer's force (forces of 0.1 N and
    /// more).
    pub max_force_diff_rel: f64,
    /// Detection time per frame, µs.
    pub cd_us: Summary,
    /// Rows and QP time per frame, µs.
    pub opt_us: Summary,
    /// Whole step per frame, µs.
    pub total_us: Summary,
    /// Passes per frame.
    pub passes: Summary,
    /// Node pairs split per frame ([`engine::Frame::splits`]): the detection work the times
    /// show, without the machine's noise.
    pub splits: Summary,
    /// Neighbour-list entries tested per frame ([`engine::Frame::scanned`]).
    pub scanned: Summary,
    /// Frames that ended lagging, with a pair overflow, or kept the last safe pose.
    pub degraded_frames: usize,
    /// Deepest overlap, mm.
    pub max_penetration_mm: f64,
}

/// How the speed and contact studies replay their scenes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ReplayMode {
    /// With the detection helper thread (`[solver] helper_thread`).
    pub helper_thread: bool,
    /// Face caps on object trees (`[solver] face_caps`), or the scene's own setting.
    pub face_caps: Option<bool>,
    /// Frames paced at the scene's rate on the wall clock (as a device loop runs them), on a
    /// `SCHED_FIFO` thread when the privilege allows, instead of back to back. A helper's
    /// background work (free-space probes) only has time to run between paced frames.
    pub realtime: bool,
}

/// Steps a fresh god-object with `solver` through the scene's device motion: the device times
/// (s) and every frame's output, with every reduced QP also solved in full when `audit` (the
/// frames' times then include the extra solves) and each frame's [`ReductionAudit`]. With
/// `realtime` the frames are paced at the scene's rate (see [`ReplayMode::realtime`]).
pub fn replay_audited(
    scene: &Scene,
    solver: SolverKind,
    audit: bool,
    realtime: bool,
) -> Result<(Vec<f64>, Vec<FrameOutput>, Vec<ReductionAudit>)> {
    let traj = scene.trajectory();
    let mut scene = scene.clone();
    scene.solver.kind = solver;
    let mut god = scene.god_object()?;
    god.audit_reduction(audit);
    let mut audits = Vec::with_capacity(if audit { traj.samples.len() } else { 0 });
    let first = traj
        .samples
        .first()
        .map(|s| Pose::from_array(s.q))
        .unwrap_or_default();
    god.reset(&first)?;
    let mut times = Vec::with_capacity(traj.samples.len());
    let mut out = Vec::with_capacity(traj.samples.len());
    let period = std::time::Duration::from_secs_f64(1.0 / scene.rate_hz.max(1.0));
    let spin = std::time::Duration::from_secs_f64(scene::rt::DEFAULT_SPIN_US * 1e-6);
    let mut pacer = scene::rt::Pacer::new(period, spin).with_nap(scene::rt::loop_nap());
    for s in &traj.samples {
        times.push(s.t);
        if realtime {
            pacer.wait_warming(|until| god.idle(until));
        }
        out.push(god.step(&Pose::from_array(s.q)));
        if realtime {
            pacer.end_frame();
        }
        if audit {
            audits.push(god.take_reduction_audit());
        }
    }
    Ok((times, out, audits))
}

/// Which frames (index, device time in s) a row of the study takes.
type FrameFilter<'a> = dyn Fn(usize, f64) -> bool + 'a;

/// Adds a phase's audit (frames selected by `keep` on the time) to its row.
fn with_audit(
    mut r: ContactRow,
    times: &[f64],
    audits: &[ReductionAudit],
    keep: impl Fn(usize, f64) -> bool,
) -> ContactRow {
    for (i, (t, a)) in times.iter().zip(audits).enumerate() {
        if keep(i, *t) {
            r.audited_solves += a.solves;
            r.max_force_diff_n = r.max_force_diff_n.max(a.max_force_diff_n);
            r.max_force_diff_rel = r.max_force_diff_rel.max(a.max_force_rel);
        }
    }
    r
}

fn row<'a>(
    scene: &str,
    phase: &str,
    frames: impl Iterator<Item = &'a FrameOutput> + Clone,
) -> ContactRow {
    let f = frames.clone();
    ContactRow {
        scene: scene.into(),
        phase: phase.into(),
        frames: f.clone().count(),
        pairs: Summary::of(f.clone().map(|o| f64::from(o.pairs))),
        rows: Summary::of(f.clone().map(|o| f64::from(o.rows))),
        audited_solves: 0,
        max_force_diff_n: 0.0,
        max_force_diff_rel: 0.0,
        cd_us: Summary::of(f.clone().map(|o| o.cd_us)),
        opt_us: Summary::of(f.clone().map(|o| o.opt_us)),
        total_us: Summary::of(f.clone().map(|o| o.total_us)),
        passes: Summary::of(f.clone().map(|o| f64::from(o.passes))),
        splits: Summary::of(f.clone().map(|o| f64::from(o.splits))),
        scanned: Summary::of(f.clone().map(|o| f64::from(o.scanned))),
        degraded_frames: f.clone().filter(|o| o.status.is_degraded()).count(),
        max_penetration_mm: f.map(|o| o.penetration_mm).fold(0.0, f64::max),
    }
}

/// The flat-on-flat rows: `tool` pressed 1 mm onto the plate, resting, then slid at 50 mm/s
/// (the slide shorter with `quick`).
fn flat_on_flat(
    cache: &TreeCache,
    label: &str,
    tool: PlateTool,
    quick: bool,
    mode: ReplayMode,
) -> Result<Vec<ContactRow>> {
    let run = plate::speed_script(
        tool,
        SpeedMotion::Slide(50.0),
        1000.0,
        if quick { 0.3 } else { 1.0 },
    );
    let mut scene = plate::scene(cache, tool, run.script.clone())?;
    scene.solver.helper_thread = mode.helper_thread;
    if let Some(on) = mode.face_caps {
        scene.solver.face_caps = on;
    }
    let (t, frames, _) = replay_audited(&scene, SolverKind::Dual, false, mode.realtime)?;
    let (_, _, audits) = replay_audited(&scene, SolverKind::Dual, true, false)?;
    let rest_end = run.steady.first().map_or(0.3, |s| s.0);
    let resting = |_: usize, ti: f64| ti >= 0.2 && ti < rest_end;
    let sliding = |_: usize, ti: f64| run.steady.iter().any(|&(a, b)| ti >= a && ti < b);
    let pick = |keep: &FrameFilter<'_>| {
        let keep_frame = |(i, (ti, _)): &(usize, (&f64, &FrameOutput))| keep(*i, **ti);
        t.iter()
            .zip(&frames)
            .enumerate()
            .filter(keep_frame)
            .map(|(_, (_, o))| o)
            .collect::<Vec<_>>()
    };
    let mut rows = Vec::new();
    for (phase, keep) in [
        (
            "resting, 1 mm press",
            &resting as &dyn Fn(usize, f64) -> bool,
        ),
        ("sliding 50 mm/s", &sliding),
    ] {
        let r = row(label, phase, pick(keep).into_iter());
        rows.push(with_audit(r, &t, &audits, keep));
    }
    Ok(rows)
}

/// Runs the study (the flat-on-flat slide is shorter with `quick`), replayed as `mode` says.
pub fn contact_study(cache: &TreeCache, quick: bool, mode: ReplayMode) -> Result<Vec<ContactRow>> {
    let mut rows = Vec::new();
    for (label, tool) in [
        ("flat on flat", PlateTool::Puck),
        ("flat on flat, dense", PlateTool::DensePuck),
    ] {
        rows.extend(flat_on_flat(cache, label, tool, quick, mode)?);
    }
    let mut scene = scene::scenes::builtin("spline", cache)?;
    scene.solver.helper_thread = mode.helper_thread;
    if let Some(on) = mode.face_caps {
        scene.solver.face_caps = on;
    }
    let (t, frames, _) = replay_audited(&scene, SolverKind::Dual, false, mode.realtime)?;
    let (_, _, audits) = replay_audited(&scene, SolverKind::Dual, true, false)?;
    // The script's phases (scene::scenes::spline_scene): approach 0.5 s, rest 0.2 s, turn
    // 1.2 s, rest 0.2 s, insert 1.0 s, rest 0.2 s, withdraw 0.8 s.
    let in_hole: Vec<bool> = frames
        .iter()
        .map(|o| o.pairs == 0 && o.q_h[2] < 0.0)
        .collect();
    let phases: [(&str, Box<FrameFilter<'_>>); 5] = [
        ("on the face", Box::new(|_, ti| (0.5..0.7).contains(&ti))),
        (
            "alignment (turning)",
            Box::new(|_, ti| (0.7..1.9).contains(&ti)),
        ),
        ("insertion", Box::new(|_, ti| (2.1..3.3).contains(&ti))),
        ("in the hole, no pair", Box::new(|i, _| in_hole[i])),
        ("whole run", Box::new(|_, _| true)),
    ];
    for (phase, keep) in &phases {
        let picked = t
            .iter()
            .zip(&frames)
            .enumerate()
            .filter(|(i, (ti, _))| keep(*i, **ti))
            .map(|(_, (_, o))| o);
        let r = row("spline", phase, picked);
        rows.push(with_audit(r, &t, &audits, keep));
    }
    Ok(rows)
}

/// The study as a markdown table.
pub fn contact_markdown(rows: &[ContactRow]) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "| scene | phase | frames | pairs p50 / max | rows solved p50 / max | cd µs p50 / p99 | opt µs p50 / p99 | total µs p50 / p99 / max | node pairs split p50 / p99 / max | list entries p50 / max | passes mean / max | degraded | max pen. mm | reduced vs full: solves, max ΔF N (rel.) |"
    );
    let _ = writeln!(
        s,
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
    );
    for r in rows {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {:.0} / {:.0} | {:.0} / {:.0} | {:.1} / {:.1} | {:.1} / {:.1} | {:.1} / {:.1} / {:.1} | {:.0} / {:.0} / {:.0} | {:.0} / {:.0} | {:.2} / {:.0} | {} | {:.4} | {}, {:.1e} ({:.1e}) |",
            r.scene,
            r.phase,
            r.frames,
            r.pairs.p50,
            r.pairs.max,
            r.rows.p50,
            r.rows.max,
            r.cd_us.p50,
            r.cd_us.p99,
            r.opt_us.p50,
            r.opt_us.p99,
            r.total_us.p50,
            r.total_us.p99,
            r.total_us.max,
            r.splits.p50,
            r.splits.p99,
            r.splits.max,
            r.scanned.p50,
            r.scanned.max,
            r.passes.mean,
            r.passes.max,
            r.degraded_frames,
            r.max_penetration_mm,
            r.audited_solves,
            r.max_force_diff_n,
            r.max_force_diff_rel,
        );
    }
    s
}
