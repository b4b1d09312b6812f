//! A frame's working state ([`FrameWork`]) and the stages that run around its regions: start,
//! reuse of the last region, solve and verify a pass, conclude, advance the run. The region
//! stages (plan, list, adopt) are in `plan.rs`.

use super::*;

/// A ball held by its trust region whose pass went at least this share of its width straight
/// toward the goal shows a falling tool ([`Heuristics::mesh_region_falls`]): a ball stopped by
/// contacts, or by a turn, goes less far along the way. (A path held by its trust region is
/// followed by a longer one.)
const FALL_REGION_SHARE: f64 = 0.25;

/// An answer no farther than this (mm, every point of the tool) from its linearisation pose is
/// taken as that pose in the mesh mode: far below any tolerance of the step.
const STILL_ANSWER_MM: f64 = 1e-9;

/// What a stage tells the pass loop of [`GodObject::step`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Flow {
    /// Go on: the rest of this pass, or the next pass.
    Go,
    /// This pass ends here; the next one starts (a region to detect again).
    Next,
    /// No more passes: the frame ends at its last pose proven free (or at the optimum).
    Stop,
    /// The frame failed (non-finite numbers, a solver breakdown): the last safe pose is kept.
    Fail,
}

/// Time of the frame so far: its deadline for traversals, its longest pass, and where it went.
#[derive(Clone, Copy, Debug)]
pub(super) struct FrameClock {
    /// When the frame started.
    pub(super) start: Instant,
    /// No traversal runs past this ([`Tuning::detect_reserve`] of the budget is kept for the last
    /// pass's rows, solve and check).
    pub(super) deadline: Instant,
    /// When the current pass started.
    pub(super) pass_start: Instant,
    /// The longest pass so far, µs.
    pub(super) longest_pass_us: f64,
    /// Time in detection and in rows and solves, s.
    pub(super) detect_s: f64,
    pub(super) solve_s: f64,
    /// When the last mesh-mode region was adopted, and its triangle pairs: the rest of its
    /// pass is their rows, solve and check.
    pub(super) rows_from: Option<(Instant, usize)>,
}

impl FrameClock {
    fn new(start: Instant, budget_us: f64, detect_reserve: f64) -> Self {
        let reserve = Duration::from_secs_f64((1.0 - detect_reserve) * budget_us.max(0.0) * 1e-6);
        Self {
            start,
            deadline: start + reserve,
            pass_start: start,
            longest_pass_us: 0.0,
            detect_s: 0.0,
            solve_s: 0.0,
            rows_from: None,
        }
    }

    /// Whether another pass fits in `budget_us`: the time so far plus [`Tuning::pass_headroom`] times
    /// the longest pass (a new region's traversal may cost more than any pass so far; the
    /// deadline stops one that overruns).
    pub(super) fn room_for_pass(&self, budget_us: f64, pass_headroom: f64) -> bool {
        self.elapsed_us() + pass_headroom * self.longest_pass_us <= budget_us
    }

    /// Time since the frame started, µs.
    pub(super) fn elapsed_us(&self) -> f64 {
        self.start.elapsed().as_secs_f64() * 1e6
    }

    /// Counts the current pass's time toward the longest pass.
    pub(super) fn end_pass(&mut self) {
        let pass_us = self.pass_start.elapsed().as_secs_f64() * 1e6;
        self.longest_pass_us = self.longest_pass_us.max(pass_us);
    }
}

/// What the frame has reached so far.
#[derive(Clone, Copy, Debug)]
pub(super) struct Progress {
    /// The last pose proven free on the way (the last frame's `q_g` at first) and its overlap
    /// (mm, within the tolerance).
    pub(super) q_safe: Pose,
    pub(super) pen_safe: f64,
    /// The last answer verified inside its region and its overlap (mm): an inexact solver's
    /// answer is used even when it overlaps.
    pub(super) last_answer: Option<(Pose, f64)>,
    /// The constrained optimum was reached.
    pub(super) reached: bool,
    /// Some pair list overflowed the pair storage.
    pub(super) overflowed: bool,
    /// `out.pairs` holds the frame's first pair list.
    pub(super) listed: bool,
    /// The last solve was on the current pair list (its multipliers are the contact's).
    pub(super) solved_current: bool,
    /// A solve ran in this frame.
    pub(super) solved_in_frame: bool,
}

/// Where the passes go next: the linearisation pose, the region and its trust region, and
/// how the next region is sized.
#[derive(Clone, Copy, Debug)]
pub(super) struct Course {
    /// The linearisation pose of the next pass.
    pub(super) q_lin: Pose,
    /// The region whose pairs `GodObject::pairs` holds, and the trust region that keeps the
    /// iterates inside it (`None`: the region reaches the goal).
    pub(super) region: Region,
    pub(super) trust: Option<Trust>,
    /// The next pass detects a region (else it solves again on the same pairs).
    pub(super) detect_now: bool,
    /// Motion allowance of the next detected region, mm: 1.5 times the last frame's motion
    /// (a hand in steady motion stays inside it); a region whose trust region binds grows it,
    /// an answer that left its region widens it, an overflowing pair list shrinks it.
    pub(super) allow: f64,
    /// Path regions (along the predicted motion) are tried until one overflows.
    pub(super) path_regions: bool,
    /// The region is last frame's, reused without a traversal.
    pub(super) reused: bool,
    /// The last pass's answer was bound by a reused region's trust region.
    pub(super) reused_bound: bool,
    /// A ball was re-centred on its own pairs in this frame (once a frame: one that binds too
    /// is followed by a detection).
    pub(super) recentred_in_frame: bool,
    /// Least length (mm) of the next path region: a path whose trust region stopped the
    /// answer is followed by one twice as long, or by a ball where the pair density allows no
    /// such path (a turning tool's path is measured at the whole tool's reach, a ball's turn
    /// at its near part's).
    pub(super) min_path_len: f64,
    /// Where the last pass started, when it crept (its answer within [`Tuning::creep_share`] of its
    /// region's width).
    pub(super) crept_from: Option<Pose>,
    /// The last pass, a ball, was held by its trust region, not by contacts, having gone at
    /// least a quarter of its width straight toward the goal
    /// ([`Heuristics::mesh_region_falls`]): the tool falls free where the regions' sizes, not
    /// the parts, hold it back.
    pub(super) fell: bool,
    /// The region is a falling tool's path ([`GodObject::predicted_sweep`]).
    pub(super) fall_path: bool,
    /// The step (mm, world) of this frame's last falling path that its trust region held:
    /// the frame's next falling paths go along it.
    pub(super) fall_along: Option<Vector3<f64>>,
}

/// A frame's working state, carried from stage to stage: plain values, on the stack.
#[derive(Clone, Copy, Debug)]
pub(super) struct FrameWork {
    /// The device pose: the spring's end.
    pub(super) hand: Pose,
    /// Where the passes go: the hand, or friction's goal held back from it.
    pub(super) goal: Pose,
    /// Friction applies to this frame, and what it did.
    pub(super) friction: bool,
    pub(super) friction_state: FrictionState,
    /// The settings as the frame uses them: skin (mm), margin cap (mm), penetration
    /// tolerance (mm), passes.
    pub(super) skin: f64,
    pub(super) cap: f64,
    pub(super) tol: f64,
    pub(super) max_passes: u32,
    pub(super) clock: FrameClock,
    pub(super) progress: Progress,
    pub(super) course: Course,
}

impl GodObject {
    /// Start: the frame's working state for the device pose `hand` and the goal, from the
    /// last frame's answer.
    pub(super) fn start_frame(&self, hand: Pose, goal: Pose, start: Instant) -> FrameWork {
        let p = &self.params;
        let cap = p.max_margin_mm.max(1e-3);
        let max_passes = p.relinearize.saturating_add(1);
        let q_g = self.run.motion.q_g;
        FrameWork {
            hand,
            goal,
            friction: false,
            friction_state: FrictionState::None,
            skin: p.skin_mm.max(0.0),
            cap,
            tol: p.penetration_tol_mm,
            max_passes,
            clock: FrameClock::new(start, p.budget_us, p.tuning.detect_reserve),
            progress: Progress {
                q_safe: q_g,
                pen_safe: 0.0,
                last_answer: None,
                reached: false,
                overflowed: false,
                listed: false,
                solved_current: false,
                solved_in_frame: false,
            },
            course: Course {
                q_lin: q_g,
                region: Region::ball(q_g, 0.0),
                trust: None,
                detect_now: true,
                // A single pass (the paper's step) has no second chance: its region covers
                // the whole way to the hand, up to the cap.
                allow: if max_passes == 1 {
                    cap
                } else {
                    (1.5 * self.run.motion.last_motion + self.params.tuning.min_allow_mm).min(cap)
                },
                path_regions: p.relinearize > 0
                    && p.rotation == RotationCoordinates::RotationVector,
                reused: false,
                reused_bound: false,
                recentred_in_frame: false,
                min_path_len: 0.0,
                crept_from: None,
                fell: false,
                fall_path: false,
                fall_along: None,
            },
        }
    }

    /// Reuse: last frame's region, while the tool is well inside it (no traversal in the first
    /// pass). Its trust region keeps the answer inside; one that binds starts a new region (a
    /// wrong guess costs a small solve, not a traversal). A large list costs more to solve
    /// again than a small region to detect ([`Tuning::reuse_max_pairs`]). A path region is
    /// reused only while the tool is in the first half of its path, and no region whose trust
    /// region stopped the last answer in it.
    pub(super) fn reuse_region(&mut self, f: &mut FrameWork, out: &mut FrameOutput) {
        let reusable = self.params.heuristics.region_reuse
            && f.course.path_regions
            && self.detector.pairs.len() <= self.params.tuning.reuse_max_pairs;
        let Some((cached, trust)) = self.run.regions.cached.filter(|_| reusable) else {
            return;
        };
        let q_lin = f.course.q_lin;
        let Some(lin) = self.linearization(&q_lin, &f.goal) else {
            return;
        };
        let depth = self.distance_from_region(&lin, &cached, &q_lin, &lin.delta());
        let across_ok = cached
            .slab
            .is_none_or(|(n, w)| self.across_bound(&n, &cached.center, &q_lin) <= 0.5 * w);
        // A path region whose path the tool has gone more than half of binds its trust region
        // soon: where the tool has reached its end, at once, and would hold it there frame
        // after frame (a tight fit's thousands of rows, whose one solve takes the frame).
        let path_left = self.path_share(&lin, &cached, &lin.delta()) <= 0.5;
        // A region whose trust region stopped the last answer in it (a turn the box holds
        // tighter than the region's motion bound) would stop the tool there again at once, and
        // where its one solve takes most of the frame, frame after frame.
        let room = !self.run.regions.cached_bound;
        // In the mesh mode, the tool going on for a frame as it went in the last stays inside
        // the trust region: else the answer stops at its edge and a new region follows in the
        // same frame, its filter, rows and check of hundreds of exact distances on top of the
        // reused one's (a shaft turned about its axis on its hub's face, whose trust region
        // holds the turn by the shaft's arm to a frame's way: two passes every frame). On the
        // leaf spheres a bound reused region is followed by a ball re-centred on its own pairs,
        // which costs less than a new region (the bunny's work +10 % with this test there).
        // Taken last: only for a region that passes the rest.
        let goes_on = || {
            self.bodies.meshes.is_none() || {
                let ahead = lin.variable(&self.pose_ahead(&q_lin, 1.0));
                self.trust_rows(
                    trust,
                    &lin.variable(&cached.center),
                    &lin.variable(&cached.end()),
                )
                .hold(&ahead)
            }
        };
        if depth <= 0.5 * cached.width && across_ok && path_left && room && goes_on() {
            f.course.region = cached;
            f.course.fall_path = false;
            f.course.trust = Some(trust);
            f.course.detect_now = false;
            f.course.reused = true;
            f.progress.listed = true;
            out.pairs = self.listed_rows() as u32;
            out.margin_mm = cached.width + f.skin;
            self.map_warm_start();
        }
    }

    /// Solve: rows linearised at `q_lin` on the region's pairs (with its trust region), the QP
    /// toward the goal, then [`GodObject::check_answer`].
    pub(super) fn solve_pass(&mut self, f: &mut FrameWork, out: &mut FrameOutput) -> Flow {
        let t1 = Instant::now();
        let n_pairs = self.listed_rows();
        if n_pairs == 0 && f.course.trust.is_none() {
            // Free all the way to the goal (the region reaches it and holds no pair): the tool
            // is there, exactly (no rounding through the QP's coordinates).
            f.progress.q_safe = f.goal;
            f.progress.pen_safe = 0.0;
            out.contacts = 0;
            self.run.solve.warm_len = 0;
            f.progress.reached = true;
            return Flow::Stop;
        }
        // A solve that would end past the budget (at twice the usual time per row) is not
        // started: the frame ends at its last proven pose. Never the first solve of a frame
        // that has time left (half its budget), so that a slow spell cannot stop the tool.
        let budget = self.params.budget_us;
        let elapsed_us = (t1 - f.clock.start).as_secs_f64() * 1e6;
        let solve_estimate = 2.0 * self.run.solve.solve_us_per_row * (n_pairs + 12) as f64;
        if elapsed_us + solve_estimate > budget
            && (f.progress.solved_in_frame || elapsed_us > 0.5 * budget)
        {
            return Flow::Stop;
        }
        let q_lin = f.course.q_lin;
        let Some(lin) = self.linearization(&q_lin, &f.goal) else {
            return Flow::Fail;
        };
        // The trust region is about the region's centre (and path), in this pass's coordinates.
        let region = f.course.region;
        let trust = f
            .course
            .trust
            .map(|t| (t, lin.variable(&region.center), lin.variable(&region.end())));
        let n = self.fill_rows(&lin, trust);
        let solved = self.solve(n, n_pairs, &lin.delta());
        out.rows = out
            .rows
            .max(self.qp.rows_solver.stats().working_rows as u32);
        let solve_s = t1.elapsed().as_secs_f64();
        f.clock.solve_s += solve_s;
        // The usual rate: a running mean (one slow solve, e.g. the thread preempted, does not
        // stop later ones).
        let rate = solve_s * 1e6 / n.max(1) as f64;
        self.run.solve.solve_us_per_row = if self.run.solve.solve_us_per_row > 0.0 {
            0.9 * self.run.solve.solve_us_per_row + 0.1 * rate
        } else {
            rate
        };
        f.progress.solved_in_frame = true;
        let Some((dq, iters, status, viol)) = solved else {
            return Flow::Fail;
        };
        self.remember_active(n_pairs);
        f.progress.solved_current = true;
        out.iterations += iters;
        out.qp_violation = viol;
        if matches!(status, Status::Infeasible | Status::MaxIterations) {
            // Infeasible only when q_lin itself penetrates; a capped solve is no answer (it
            // may penetrate): neither reaches the device.
            return Flow::Fail;
        }
        if status != Status::Solved && out.status == FrameStatus::Ok {
            out.status = FrameStatus::Inexact;
        }
        let mut q_new = lin.configuration(&dq);
        if !q_new.is_finite() {
            return Flow::Fail;
        }
        // In the mesh mode an answer within a rounding of the linearisation pose is that pose:
        // its exact distances were measured there (a tool at rest, pressed on a fine mesh,
        // would otherwise measure its ~1 700 pairs again every frame for a 1e-12 mm move).
        if self.bodies.meshes.is_some() && self.motion_bound(&q_lin, &q_new) <= STILL_ANSWER_MM {
            q_new = q_lin;
        }
        self.check_answer(f, out, &lin, (&dq, q_new), (n_pairs, n))
    }

    /// Verify: an answer that left its region is discarded and the region detected again,
    /// wider. Otherwise the listed pairs' exact gaps at the answer give its overlap and how
    /// far the rows holding it are still open in truth: penetrating or held open, the next
    /// pass re-linearises there on the same pairs; free and converged but stopped by the
    /// trust region, it detects a larger region; else the frame has reached the optimum.
    fn check_answer(
        &mut self,
        f: &mut FrameWork,
        out: &mut FrameOutput,
        lin: &Linearization,
        (dq, q_new): (&[f64; 6], Pose),
        (n_pairs, n_rows): (usize, usize),
    ) -> Flow {
        let t2 = Instant::now();
        f.course.fell = false;
        let (q_lin, region) = (f.course.q_lin, f.course.region);
        let moved = self.distance_from_region(lin, &region, &q_new, dq);
        let moved_across = region.slab.map_or(0.0, |(n, across)| {
            self.across_bound(&n, &region.center, &q_new) - across
        });
        if moved > region.width + f.skin || moved_across > f.skin {
            // Pairs that can touch on the way to q_new may be missing: not proven. Detect again
            // from q_lin with a margin covering the motion (a trust region if over the cap).
            f.course.allow = (self.motion_bound(&q_lin, &q_new) * 1.25).min(f.cap);
            f.course.detect_now = true;
            f.clock.detect_s += t2.elapsed().as_secs_f64();
            f.clock.end_pass();
            return Flow::Next;
        }
        // Every pair that can touch between the region's centre and q_new is listed: their
        // exact gaps at q_new give the deepest overlap, and how far the linearisation
        // undershot (an active row whose true gap is open: another pass moves further).
        let (pen, slack, touching) = if self.bodies.meshes.is_some() {
            self.mesh_gaps_at(&q_lin, &q_new, dq, n_pairs)
        } else {
            self.gaps_at(&q_new, dq, n_pairs)
        };
        if self.bodies.meshes.is_some() && pen > f.tol {
            // Triangles meet at the answer (the rows' planes misjudged a curved or turning
            // contact): the last free pose on the way is safe, and the next pass linearises
            // there, where the nearest features are well defined.
            let back = self.last_free_on_the_way(lin, dq).filter(|(q, v)| {
                self.distance_from_region(lin, &region, q, v) <= region.width + f.skin
            });
            f.clock.detect_s += t2.elapsed().as_secs_f64();
            f.clock.end_pass();
            let Some((q_back, _)) = back else {
                return Flow::Stop;
            };
            f.progress.q_safe = q_back;
            f.progress.pen_safe = 0.0;
            f.progress.last_answer = Some((q_back, 0.0));
            f.course.crept_from = None;
            f.course.q_lin = q_back;
            return Flow::Go;
        }
        f.clock.detect_s += t2.elapsed().as_secs_f64();
        f.progress.last_answer = Some((q_new, pen));
        if pen <= f.tol {
            f.progress.q_safe = q_new;
            f.progress.pen_safe = pen;
            out.contacts = touching;
        }
        let binds = f
            .course
            .trust
            .is_some_and(|t| self.trust_binds(t, n_pairs, n_rows, dq));
        if !self.detector.pairs.is_empty() {
            // The region is the one kept for later frames.
            self.run.regions.cached_bound = binds;
        }
        f.clock.end_pass();
        // In the mesh mode a bound answer whose rows are still open goes to a new region at
        // once ([`Heuristics::mesh_bound_detects`]): its next pass linearises at the answer
        // either way.
        let bound_goes_on =
            binds && self.bodies.meshes.is_some() && self.params.heuristics.mesh_bound_detects;
        // A falling path its trust slab held (a tool pressed on a face, left behind a fast
        // hand: the way to the hand runs through the face): the frame's next falling paths go
        // on along the step this pass made.
        if f.course.fall_path && binds && pen <= f.tol {
            let step = q_new.translation() - q_lin.translation();
            if step.norm() > 0.0 {
                f.course.fall_along = Some(step);
            }
        }
        f.course.fell = binds
            && pen <= f.tol
            && region.sweep.is_none()
            && self.bodies.meshes.is_some()
            && self.params.heuristics.mesh_region_falls
            && {
                let step = q_new.translation() - q_lin.translation();
                let way = f.goal.translation() - q_lin.translation();
                step.norm() >= FALL_REGION_SHARE * region.width
                    && step.dot(&way) >= self.params.tuning.fall_min_cos * step.norm() * way.norm()
            };
        let c = &mut f.course;
        if pen <= f.tol && (slack <= CONVERGED_MM || bound_goes_on) {
            if !binds {
                f.progress.reached = true;
                return Flow::Stop;
            }
            // Safe and as far as this region allows: a larger region from here (a region
            // reused from an earlier frame was sized for that frame's motion: this frame's
            // allowance instead).
            if !c.reused {
                c.allow = (2.0 * region.extent())
                    .max(self.params.tuning.min_allow_mm)
                    .min(f.cap);
            }
            c.reused_bound = c.reused;
            if region.sweep.is_some() {
                c.min_path_len = 2.0 * region.length;
            }
            c.reused = false;
            c.detect_now = true;
        }
        // Penetrating or undershooting: re-linearise at q_new (same pairs).
        c.crept_from = (moved < self.params.tuning.creep_share * region.width).then_some(q_lin);
        c.q_lin = q_new;
        Flow::Go
    }

    /// Conclude: the frame's status when the passes ended short of the optimum, and friction's
    /// bound on the answer.
    pub(super) fn conclude(&mut self, f: &mut FrameWork, out: &mut FrameOutput) {
        let p = &mut f.progress;
        if !p.reached {
            match (self.params.solver.is_exact(), p.last_answer) {
                // The paper's PQP stops inexact by design: as in the paper, its last answer is
                // used, with whatever overlap it has (reported, and marked Inexact).
                (false, Some((q, pen))) if !p.overflowed => {
                    p.q_safe = q;
                    p.pen_safe = pen;
                    out.status = FrameStatus::Inexact;
                }
                // An exact step that ran out of passes: the last pose proven free.
                _ if p.overflowed => out.status = FrameStatus::PairOverflow,
                _ => out.status = FrameStatus::Lagging,
            }
        }
        if f.friction_state != FrictionState::None {
            // Friction never gives the hand more than the spring it stretched: an answer that
            // would raise the spring's energy to the hand (the goal's normal a little off the
            // surface's) keeps the last pose, which is free.
            let g = self.params.g();
            let energy = |q: &Pose| {
                let w = spring_wrench(&g, self.params.rotation, q, &f.hand);
                (0..6).map(|k| w[k] * w[k] / g[k]).sum::<f64>()
            };
            if energy(&p.q_safe) > energy(&self.run.motion.q_g) {
                p.q_safe = self.run.motion.q_g;
                p.pen_safe = self.run.motion.pen_g;
                out.contacts = self.run.motion.contacts_g;
            }
        }
    }

    /// Advance: the run state moves to the frame's answer (motion, prediction, friction's
    /// patch), the next neighbour list is tended, and the output is filled in.
    pub(super) fn advance(&mut self, f: &FrameWork, out: &mut FrameOutput) {
        let (q_safe, goal) = (f.progress.q_safe, f.goal);
        if f.friction && f.progress.solved_current {
            self.remember_patch(&q_safe);
        } else if f.friction && out.contacts == 0 && f.progress.reached {
            self.run.friction.patch = None;
        }
        let q_g = self.run.motion.q_g;
        let last_motion = self.motion_bound(&q_g, &q_safe);
        let error = self.motion_bound(&self.predicted_pose(&goal), &q_safe);
        self.run.regions.slab_rest = self.run.regions.slab_rest.saturating_sub(1);
        let m = &mut self.run.motion;
        m.pen_g = f.progress.pen_safe;
        m.behind = !f.progress.reached;
        // A frame that ended before any pass was solved (its region's listing stopped at the
        // deadline) keeps the last frame's fall, once: the next frame goes on with that
        // region's list under way; a second such frame drops the fall.
        let carried = m.fell && !m.fell_carried && !f.progress.solved_in_frame;
        m.fell = m.behind && (f.course.fell || carried);
        m.fell_carried = carried && !f.course.fell;
        m.contacts_g = out.contacts;
        m.last_motion = last_motion;
        for k in 0..3 {
            m.last_step[k] = q_safe.q[k] - q_g.q[k];
        }
        m.last_turn =
            rotation_log(&(q_safe.rotation_matrix() * q_g.rotation_matrix().transpose())).into();

        m.prediction_error = error.max(0.9 * m.prediction_error);
        m.q_g = q_safe;
        m.hand_offset = (
            goal.translation() - q_safe.translation(),
            rotation_log(&(goal.rotation_matrix() * q_safe.rotation_matrix().transpose())),
        );
        // In contact, the next frames' regions come from a neighbour list kept ahead.
        let used = out.margin_mm.max(self.params.tuning.min_allow_mm + f.skin);
        let own_us = f.clock.elapsed_us();
        self.note_own_work(own_us);
        self.tend_neighbours(&q_safe, used, f.clock.deadline);
        let slice_us = self.near_slice_us(&q_safe, f.clock.elapsed_us());
        self.tend_near(&q_safe, slice_us, f.clock.deadline);
        self.run.lists.idle_given = false;
        out.penetration_mm = f.progress.pen_safe;
        out.q_g = q_safe.to_array();
        out.wrench = spring_wrench(&self.params.g(), self.params.rotation, &q_safe, &f.hand);
        out.raw_wrench = out.wrench;
        out.cd_us = f.clock.detect_s * 1e6;
        out.opt_us = f.clock.solve_s * 1e6;
        out.splits = self.run.counts.frame_splits.min(u64::from(u32::MAX)) as u32;
        out.scanned = self.run.counts.frame_scanned.min(u64::from(u32::MAX)) as u32;
        out.total_us = f.clock.elapsed_us();
        out.ahead_us = out.total_us - own_us;
    }
}
