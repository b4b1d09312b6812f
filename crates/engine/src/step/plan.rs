//! The region stages of a pass: **plan** a region (its size, and whether a ball, a slab or a
//! path), **list** its leaf pairs (from a free-space proof, a probe, a neighbour list, the
//! last ball's own pairs, or a traversal), **adopt** it (count it, choose its trust region,
//! keep it for later frames).

use super::frame::{Flow, FrameWork};
use super::*;

/// A pass whose tool moved less than this share of the region's allowance did not move: its
/// way is no guide to a turned trust box.
const STILL_PASS_SHARE: f64 = 1e-3;

/// A mesh-mode region of fewer triangle pairs has its rows, solve and check within the
/// budget's reserve for them ([`Tuning::detect_reserve`]: a ball on a ball's pole, 2 048
/// pairs, takes 300–650 µs; 256 pairs under 100 µs), and its cost per pair is not a guide
/// (the solve's own cost spread over few pairs).
pub(super) const ROWS_RESERVE_MIN_PAIRS: usize = 256;

/// A thin path ([`Heuristics::mesh_thin_paths`]) is taken only where its turn leaves at least
/// this share of the standoff room for its width: a tool turning faster than that toward the
/// wall is better held by balls.
const THIN_PATH_LEAST_SHARE: f64 = 0.25;

/// A fall seen in a held pass ([`Heuristics::mesh_region_falls`]) takes its path only where
/// the path, kept off a wall standing near, is at least this share of
/// [`Tuning::path_width_min_mm`] wide.
const FALL_LEAST_WIDTH_SHARE: f64 = 0.25;

/// How a falling tool's path goes ([`GodObject::predicted_sweep`]).
#[derive(Clone, Copy, Debug)]
pub(super) enum Fall {
    /// Straight to the goal.
    Straight,
    /// On along this step (mm, world), as far as the way to the goal goes along it: the step
    /// of a falling path its trust region held.
    Along(Vector3<f64>),
}

/// A region as planned before its pairs are listed.
#[derive(Clone, Copy, Debug)]
pub(super) struct RegionPlan {
    /// How far the goal is from `q_lin`: translation and rotation parts (mm, largest sphere
    /// motion) and their sum.
    need_t: f64,
    need_r: f64,
    need: f64,
    /// The ball allowance that keeps the pair count near [`Tuning::ball_pair_target`], mm.
    dense_cap: f64,
    /// How far the tool may move inside the neighbour list in use, mm.
    list_room: f64,
    /// The ball's motion allowance (a slab's slide along its face), mm.
    allowed: f64,
    /// The region does not reach the goal: a trust region keeps the iterates in it.
    trust: bool,
    /// A slab region: face normal, width across and slide along the face (mm).
    slab: Option<(Vector3<f64>, f64, f64)>,
    /// The slab was listed by a traversal (its pairs are the slab's).
    slab_used: bool,
    /// A path region: the sweep and its largest sphere motion (mm).
    sweep: Option<(Sweep, f64)>,
    /// The path is a falling tool's ([`Fall`]).
    fall_path: bool,
    /// The room (mm) a wall standing a little off the tool leaves a ball, where it holds the
    /// ball short of the rest of its allowance ([`GodObject::standoff_allow`]).
    standoff: Option<f64>,
    /// The last ball's own pairs serve (no detection).
    recentred: bool,
    /// Width about the path (a path region) or the allowance (a ball), mm.
    width: f64,
    /// Largest sphere motion anywhere in the region, mm.
    extent: f64,
    /// How far (mm) the free-space proofs reach about `q_lin`.
    free_slack: f64,
}

impl GodObject {
    /// Detect: plan a region at the pass's `q_lin`, list its pairs, adopt it.
    pub(super) fn detect_stage(
        &mut self,
        f: &mut FrameWork,
        out: &mut FrameOutput,
        pass: u32,
    ) -> Flow {
        let t0 = Instant::now();
        let mut plan = self.plan_region(f);
        let mut listed = self.list_pairs(f, &mut plan, pass);
        let slab_face = self.settle_slab(&mut plan);
        if plan.trust && self.detector.pairs.is_empty() && listed.is_ok() {
            listed = self.confirm_trust(f, &mut plan);
        }
        f.clock.detect_s += t0.elapsed().as_secs_f64();
        if listed.is_err() {
            return Flow::Fail;
        }
        f.progress.solved_current = false;
        if self.run.regions.interrupted {
            // The frame's time is up before the region was listed: nothing from it is
            // proven; the frame ends at its last proven pose (lagging).
            return Flow::Stop;
        }
        self.adopt_region(f, out, &plan, slab_face)
    }

    /// Plan: the region's size from the way to the goal, the cap, the pair density and the
    /// neighbour list's room; a slab for a tool held by one flat face, a path for a hand in
    /// motion, or the last ball's own pairs.
    fn plan_region(&self, f: &mut FrameWork) -> RegionPlan {
        let (q_lin, goal, skin, cap) = (f.course.q_lin, f.goal, f.skin, f.cap);
        let (need_t, need_r) = self.way_to(&q_lin, &goal);
        let need = need_t + need_r;
        // Dense contacts (flat on flat) hold many pairs per mm of margin: keep the expected
        // count near the target by taking smaller regions (more passes).
        let h = self.params.heuristics;
        let dense_cap = if h.density_sizing {
            let by_density = self
                .run
                .regions
                .density
                .margin_for(self.params.tuning.ball_pair_target);
            // Pairs that grew slower than the margin: a smaller ball sheds few of them, a
            // wider one gains few ([`Heuristics::mesh_slow_growth`]).
            let slow = self
                .run
                .regions
                .slow_growth_to
                .filter(|_| h.mesh_slow_growth)
                .unwrap_or(0.0);
            by_density.max(slow) - skin
        } else {
            f64::INFINITY
        };
        let mut allowed = need
            .min(f.course.allow)
            .min(cap)
            .min(dense_cap.max(self.dense_floor()));
        let mut standoff = None;
        if h.density_sizing {
            let room = self.standoff_allow(skin);
            if room < allowed {
                standoff = Some(room);
                allowed = room;
            }
        }
        // Inside a neighbour list a region costs a filter, not a traversal: one that stays
        // inside it (and a trust region) beats a wider one traversed.
        let list_room = self.ahead.neighbours.slack(&q_lin, None, skin);
        if list_room >= self.params.tuning.min_allow_mm {
            allowed = allowed.min(list_room);
        }
        let mut trust = need > allowed;
        // A tool held by one flat face: a slab region (its face's half-space pairs within a
        // thin margin across the face, every other pair within the slide along it).
        let slab = if h.slab_regions && f.course.path_regions && self.bodies.faces {
            self.slab_widths(need, f.course.allow, cap, dense_cap)
        } else {
            None
        };
        if let Some((_, _, slide)) = slab {
            allowed = slide;
            trust = true;
        }
        let mut plan = RegionPlan {
            need_t,
            need_r,
            need,
            dense_cap,
            list_room,
            allowed,
            trust,
            slab,
            slab_used: false,
            sweep: None,
            fall_path: false,
            standoff,
            recentred: false,
            width: 0.0,
            extent: 0.0,
            free_slack: 0.0,
        };
        let path_width = self.plan_path(f, &mut plan);
        self.plan_recentre(f, &mut plan);
        plan.width = if plan.sweep.is_some() {
            path_width
        } else {
            plan.allowed
        };
        plan.extent = plan.sweep.map_or(0.0, |(_, len)| len) + plan.width;
        plan.free_slack = self.free_slack(&q_lin);
        plan
    }

    /// Least allowance (mm) the pair density may give a ball region: [`Tuning::dense_min_allow_mm`],
    /// or less after a ball that overflowed the storage (a peg 0.05 mm from its hole's whole
    /// wall: the floor and the skin list the wall, frame after frame).
    pub(super) fn dense_floor(&self) -> f64 {
        self.params
            .tuning
            .dense_min_allow_mm
            .min(self.run.regions.overflow_floor)
    }

    /// Largest ball allowance (mm) that keeps a wall standing a little off the tool out of the
    /// region, where the dense floor would take it in: a peg centred in a hole 0.05 mm wider
    /// has the hole's whole wall (some 4 000 triangle pairs) at 0.05 mm, and the floor and the
    /// skin (0.03 + 0.02 mm) listed it whole each pass (1.1 ms of exact distances) where a
    /// ball a little smaller lists none. The near list's last filter counted its pairs' bounds
    /// by distance: a ball whose allowance, its centre's way from there (no more than its
    /// allowance again) and the skin stay within the distance that held the pair target
    /// holds fewer. Pairs touching (a face lying on another) give no room: the dense floor
    /// then stands, as it does where the room is past it. Unbounded otherwise.
    pub(super) fn standoff_allow(&self, skin: f64) -> f64 {
        let room = 0.5 * (self.run.regions.near_standoff - skin);
        if room >= MIN_OVERFLOW_ALLOW_MM && room < self.dense_floor() {
            room
        } else {
            f64::INFINITY
        }
    }

    /// A path region for a hand in motion that the ball cannot follow: the pairs along the
    /// motion predicted for the tool (a sliding contact holds far fewer along its path than
    /// within the path's length all around). Within [`Tuning::path_density_factor`] times the
    /// pair-density cap of a path, length and width together (a wide path through a dense
    /// contact costs more than a second pass). Returns the path's width (mm).
    fn plan_path(&self, f: &FrameWork, plan: &mut RegionPlan) -> f64 {
        let (q_lin, goal) = (f.course.q_lin, f.goal);
        let h = self.params.heuristics;
        let path_cap = if h.density_sizing {
            (self
                .run
                .regions
                .density
                .path_margin_for(self.params.tuning.pair_target)
                - f.skin)
                .max(self.params.tuning.min_allow_mm)
                .min(f.cap)
        } else {
            f.cap
        };
        // A tool left behind while falling (the last frame ran out before its optimum with
        // the tool moving on toward the goal): its path is the straight way there, or, once
        // such a path was held by its trust slab in this frame (the way runs through a face
        // the tool is pressed on: the hand a few millimetres ahead of a fast slide and 1 mm
        // into the face is within the falling cone, and each pass went 0.13 mm where the hand
        // went 1 mm a frame), along the step that pass made, as far as the way goes along it.
        // In the mesh mode also a tool whose last pass (in this frame, or the
        // last frame's) went straight toward the goal until its trust region held it
        // ([`Course::fell`]): balls the pair density keeps small creep a few hundredths of a
        // millimetre a pass where the tool falls free (a shaft dropping 2 mm into its keyways
        // as they align). Such a fall is taken only where the falling path keeps a wall
        // standing off the tool out and is still a quarter of the least path width (below), or
        // no wall stands near: a peg 0.02 mm from its hole's wall, its balls held by their
        // trust regions on the way down, would list the whole wall along the path frame after
        // frame, or slide down a path too thin to centre it in.
        let wall = self.run.regions.near_standoff - f.skin;
        let falls_clear =
            0.5 * wall >= FALL_LEAST_WIDTH_SHARE * self.params.tuning.path_width_min_mm;
        let fall = {
            let step = Vector3::from(self.run.motion.last_step);
            let way = goal.translation() - q_lin.translation();
            let toward =
                step.dot(&way) >= self.params.tuning.fall_min_cos * step.norm() * way.norm();
            let falls = falls_clear && f.course.fell
                || self.run.motion.behind
                    && toward
                    && (step.norm() >= self.params.tuning.fall_min_step_mm
                        || falls_clear && self.run.motion.fell);
            falls.then_some(match f.course.fall_along {
                Some(held) => Fall::Along(held),
                None => Fall::Straight,
            })
        };
        let falling = fall.is_some();
        // A falling path's width: the least, or in the mesh mode with thin paths as thin as
        // keeps out a wall that stands a little off the tool along the way (the keyways' walls
        // 0.1 mm off the dropping shaft's keys: ~2 300 pairs a path at the least width, ~150
        // at half the wall's distance less the skin).
        let path_width = if falling {
            let min_width = self.params.tuning.path_width_min_mm;
            if h.mesh_thin_paths && self.bodies.meshes.is_some() && wall > 0.0 {
                (0.5 * wall).min(min_width)
            } else {
                min_width
            }
        } else {
            self.path_width()
        };
        // A tool kept short of a wall by its standoff room: a path as thin as the room, along
        // the motion however slow, so that a peg sliding down a tight hole takes one pass a
        // frame instead of a ball's few. Not for a tool left behind: a ball there goes on with
        // the distances a region stopped at the deadline measured (a path measures anew).
        if let Some(room) = plan.standoff.filter(|_| {
            h.mesh_thin_paths
                && h.path_regions
                && plan.trust
                && f.course.path_regions
                && plan.slab.is_none()
                && !self.run.motion.behind
                && self.bodies.meshes.is_some()
        }) {
            if let Some((sweep, len, turn)) = self.thin_sweep(&q_lin, &goal, f.cap) {
                let width = room - turn;
                // Only where the motion outruns a ball of the room (else one ball a frame
                // serves, and is reused where a path is filtered anew).
                if len > room
                    && width >= THIN_PATH_LEAST_SHARE * room
                    && len >= f.course.min_path_len
                {
                    plan.sweep = Some((sweep, len));
                    return width;
                }
            }
        }
        if h.path_regions && plan.trust && f.course.path_regions && plan.slab.is_none() {
            // A falling tool's path goes the whole way to the goal (within the cap): its pairs
            // come in at the leading edges, not by the density of paths per mm of width.
            let length_cap = if falling { f.cap } else { path_cap };
            plan.sweep = self
                .predicted_sweep(&q_lin, &goal, length_cap, fall)
                .filter(|&(_, len)| {
                    path_width <= plan.dense_cap.max(self.params.tuning.min_allow_mm)
                        && len + path_width <= self.params.tuning.path_density_factor * length_cap
                        && (falling || len >= f.course.min_path_len)
                });
            plan.fall_path = falling && plan.sweep.is_some();
        }
        path_width
    }

    /// Re-centre: outside a list, after a reused ball's trust region stopped the last answer,
    /// the last ball's own pairs serve as a small list: every pair within `m` of touching at
    /// `c` is held, so a ball of `m - skin - b(c, q_lin)` about `q_lin` needs no detection.
    fn plan_recentre(&self, f: &mut FrameWork, plan: &mut RegionPlan) {
        if !self.params.heuristics.recentre {
            return;
        }
        let q_lin = f.course.q_lin;
        let own_room = match self.run.regions.pairs_question {
            Some((c, m))
                if plan.sweep.is_none()
                    && plan.list_room < self.params.tuning.min_allow_mm
                    && !self.detector.pairs.is_empty() =>
            {
                m - f.skin - self.motion_bound(&c, &q_lin)
            }
            _ => f64::NEG_INFINITY,
        };
        plan.recentred = f.course.path_regions
            && plan.slab.is_none()
            && !f.course.recentred_in_frame
            && f.course.reused_bound
            && own_room
                >= (self.params.tuning.recentre_share * plan.allowed)
                    .max(self.params.tuning.dense_min_allow_mm)
            && own_room
                >= self.params.tuning.recentre_motion_spare
                    * self.motion_bound(&q_lin, &self.predicted_pose(&f.goal));
        if plan.recentred {
            plan.allowed = plan.allowed.min(own_room);
            plan.trust = plan.need > plan.allowed;
            f.course.recentred_in_frame = true;
        }
    }

    /// List: the planned region's pairs into `self.detector.pairs`, by the cheapest means that proves
    /// them complete. Returns the least gap (mm; +inf where nothing was traversed).
    fn list_pairs(
        &mut self,
        f: &FrameWork,
        plan: &mut RegionPlan,
        pass: u32,
    ) -> Result<f64, collide::CollideError> {
        let (q_lin, skin, deadline) = (f.course.q_lin, f.skin, f.clock.deadline);
        let used = plan.extent + skin;
        if used <= plan.free_slack {
            // Free space proven by an earlier empty detection: no pair within a proof's radius
            // at its centre, so none within `m` of q_lin while `b(centre, q_lin) + m <= radius`.
            self.run.regions.cached = None;
            self.detector.pairs.clear();
            self.run.regions.dropped = 0;
            if pass == 0 {
                self.tend_probe(&q_lin, plan.allowed + skin, deadline);
            }
            Ok(f64::INFINITY)
        } else if let Some((path, _)) = plan.sweep {
            self.ahead.probe.cancel();
            self.detect_along(&q_lin, Some(&path), plan.width + skin, Some(deadline), None)
        } else if plan.recentred {
            // The pairs are held already: no detection.
            self.run.counts.regions_filtered += 1;
            Ok(f64::INFINITY)
        } else if let Some(free) = if self.ahead.neighbours.covers(&q_lin, None, used) {
            // A neighbour list answers it for a filter: no probe is finished for it.
            None
        } else {
            self.finish_probe(&q_lin, used, deadline)
        } {
            // The background probe covers this pose: finished now, it proves free space (no
            // pair); out of time, the frame ends here and the next one carries on with it (a
            // traversal too long for one frame's budget is spread over several instead of
            // never finishing).
            self.run.regions.cached = None;
            self.detector.pairs.clear();
            self.run.regions.dropped = 0;
            self.run.regions.interrupted = !free;
            Ok(f64::INFINITY)
        } else {
            // A full traversal gives a fresh answer; an unfinished background probe is dropped.
            self.ahead.probe.cancel();
            self.traverse_region(f, plan)
        }
    }

    /// A traversal for the region: in free space a little wider, so that an empty answer
    /// proves free space for several frames ([`Tuning::free_probe_mm`]).
    fn traverse_region(
        &mut self,
        f: &FrameWork,
        plan: &mut RegionPlan,
    ) -> Result<f64, collide::CollideError> {
        let (q_lin, skin, deadline) = (f.course.q_lin, f.skin, f.clock.deadline);
        let (allowed, h) = (plan.allowed, self.params.heuristics);
        let in_free_space = self.detector.pairs.is_empty();
        let probe = if in_free_space {
            // No wider than a dense contact just left allows.
            let dense = if h.density_sizing {
                self.run
                    .regions
                    .density
                    .probe_margin_for(self.params.tuning.pair_target)
            } else {
                f64::INFINITY
            };
            let wide = (allowed + skin).max(self.params.tuning.free_probe_mm.min(dense));
            // Within a neighbour list, no wider than it reaches (a filter, not a traversal:
            // its proof goes as far anyway), short of its edge by a rounding so that the list
            // covers it.
            let room = self.ahead.neighbours.slack(&q_lin, None, 0.0) - PROOF_ROUNDING_MM;
            if room >= allowed + skin {
                wide.min(room)
            } else {
                wide
            }
        } else {
            allowed + skin
        };
        let face_slab = plan.slab.map(|(n, across, slide)| FaceSlab {
            normal: n.into(),
            margin: across + skin,
            tangent: slide + skin,
        });
        plan.slab_used = face_slab.is_some();
        let traversed_before = self.run.counts.regions_traversed;
        let d = self.detect_along(&q_lin, None, probe, Some(deadline), face_slab);
        let proven = probe;
        // Only a complete traversal proves free space (one the deadline stopped may have
        // missed pairs).
        if d.is_ok() && self.detector.pairs.is_empty() && !self.run.regions.interrupted {
            // (A pair may lie at the proven gap itself.)
            let radius = proven - PROOF_ROUNDING_MM;
            self.add_free_proof(q_lin, Vector3::zeros(), radius, &q_lin, probe);
            // What a proof costs here: a background probe pays off only where it is more than
            // a slice. (A list's proof costs no traversal.)
            if self.run.counts.regions_traversed > traversed_before {
                self.run.proofs.probe_splits = self.detector.ws.stats().node_pairs_split;
            }
            // The background probes ask for what the surfaces allow here: a proof short of the
            // widest asked met a pair (asking for more would come back touching); one as wide
            // as asked found room.
            self.run.proofs.probe_margin =
                if proven < self.params.tuning.free_probe_mm - PROOF_ROUNDING_MM {
                    proven.max(self.params.tuning.background_probe_min_mm)
                } else {
                    self.run
                        .proofs
                        .probe_margin
                        .max(proven.min(self.params.tuning.background_probe_mm))
                };
        } else if h.probes() && d.is_ok() && self.detector.pairs.is_empty() {
            // Stopped before an answer: the same question goes to the background probe, which
            // the next frames finish (the tool waits here meanwhile).
            let _ = self.ahead.probe.start(&self.bodies.tool, &q_lin, probe);
        }
        d
    }

    /// A slab region that failed (stopped at the deadline, overflowed, or larger than a slab
    /// is by design) rests slabs for a while, doubled after each failure in a row. An empty
    /// slab lists nothing within its thin margin either: a ball of that width. Returns the
    /// slab's face (normal, width across, mm) when the region is one.
    fn settle_slab(&mut self, plan: &mut RegionPlan) -> Option<(Vector3<f64>, f64)> {
        if plan.slab_used {
            let run = &mut self.run.regions;
            if run.interrupted
                || run.dropped > 0
                || self.detector.pairs.len() > self.params.tuning.slab_max_pairs
                || self.detector.ws.stats().node_pairs_split > self.params.tuning.slab_max_splits
            {
                run.slab_rest = run.slab_next_rest;
                run.slab_next_rest =
                    (2 * run.slab_next_rest).min(self.params.tuning.slab_rest_max_frames);
            } else {
                run.slab_next_rest = self.params.tuning.slab_rest_frames;
            }
        }
        let face = plan
            .slab
            .filter(|_| plan.slab_used)
            .map(|(n, across, _)| (n, across));
        if let Some((_, across)) = face.filter(|_| self.detector.pairs.is_empty()) {
            plan.allowed = across;
            return None;
        }
        face
    }

    /// Nothing within the allowance: if nothing is within the whole way to the goal either,
    /// the way is free and no trust region is needed (no lag in free space). The check stops
    /// at the first pair; it stores none.
    fn confirm_trust(
        &mut self,
        f: &FrameWork,
        plan: &mut RegionPlan,
    ) -> Result<f64, collide::CollideError> {
        let reach = plan.need + f.skin;
        let near = if reach <= plan.free_slack {
            Ok(false)
        } else {
            self.any_within(&f.course.q_lin, reach, Some(f.clock.deadline))
        };
        plan.trust = matches!(near, Ok(true));
        if !plan.trust {
            plan.allowed = plan.need;
            plan.sweep = None;
        }
        near.map(|_| f64::INFINITY)
    }

    /// Adopt: count the listed region (the frame's first list, the pair density), shrink
    /// after an overflow, or make it the pass's region with its trust region and keep it for
    /// later frames.
    fn adopt_region(
        &mut self,
        f: &mut FrameWork,
        out: &mut FrameOutput,
        plan: &RegionPlan,
        slab_face: Option<(Vector3<f64>, f64)>,
    ) -> Flow {
        let (q_lin, skin) = (f.course.q_lin, f.skin);
        // The frame's pair count is its first list (a path region that overflowed is none:
        // the next one is); in the mesh mode its triangle pairs, once listed below.
        let first_list = !f.progress.listed;
        if !f.progress.listed && (self.run.regions.dropped == 0 || plan.sweep.is_none()) {
            f.progress.listed = true;
            out.pairs = self.detector.pairs.len() as u32;
            out.margin_mm = if plan.sweep.is_some() {
                plan.width
            } else {
                plan.allowed
            } + skin;
        }
        // Pairs against margin, remembered for the next choice. (A path region's count over
        // its width overstates the density all around: the safe side, smaller balls after it.)
        let margin = match (slab_face, plan.sweep) {
            (Some((_, across)), _) => across,
            (None, Some(_)) => plan.width,
            (None, None) => plan.allowed,
        } + skin;
        // The mesh mode's triangle pairs that can touch in the region (more than the storage
        // holds count as dropped: the region shrinks as for leaf pairs).
        let t0 = Instant::now();
        let deadline = Some(f.clock.deadline);
        match plan.sweep {
            // Along a path: every pose of the region is within its width (and the skin) of a
            // pose on the path, turned at most by the path's turn.
            Some((path, _)) => {
                let r = q_lin.rotation_matrix();
                let turn = self.turn_bound(&r, &(rotation_exp(&path.rotation.into()) * r));
                let along = Vector3::from(path.translation);
                self.narrow_phase_by(&q_lin, plan.width + skin + turn, &along, deadline);
            }
            None => {
                self.narrow_phase_by(&q_lin, plan.allowed + skin, &Vector3::zeros(), deadline);
            }
        }
        f.clock.detect_s += t0.elapsed().as_secs_f64();
        if self.run.regions.interrupted {
            // The frame's time is up before the region's triangle pairs were listed: as for a
            // traversal, the frame ends at its last proven pose and the next one goes on.
            return Flow::Stop;
        }
        if first_list && f.progress.listed && self.bodies.meshes.is_some() {
            out.pairs = self.listed_rows() as u32;
        }
        if self.rows_past_budget(f) {
            // Their rows, solve and check would end past the budget: the next frame's region
            // here takes the distances measured and has the time for them.
            return Flow::Stop;
        }
        if !plan.recentred {
            // The rows the region gives (leaf pairs, or triangle pairs in the mesh mode).
            let count = self.listed_rows() + self.run.regions.dropped;
            self.run
                .regions
                .density
                .record(margin, count, plan.sweep.is_some());
        }
        if self.run.regions.dropped > 0 {
            // More pairs than the storage holds: the list is not complete, so no answer from
            // it is proven. A smaller region (fewer pairs) next pass; after a path, balls.
            f.progress.overflowed = true;
            if plan.sweep.is_some() {
                f.course.path_regions = false;
                return Flow::Next;
            }
            f.course.allow = 0.25 * plan.allowed;
            // The next frames' balls start no larger (the dense floor would list it again).
            self.run.regions.overflow_floor = f.course.allow.max(MIN_OVERFLOW_ALLOW_MM);
            f.clock.end_pass();
            if f.course.allow < MIN_OVERFLOW_ALLOW_MM {
                return Flow::Stop;
            }
            return Flow::Next;
        }
        // A ball that fits, or free space, lets the floor grow back (doubled, to the tuned
        // floor).
        if plan.sweep.is_none() || self.detector.pairs.is_empty() {
            let floor = &mut self.run.regions.overflow_floor;
            *floor = (2.0 * *floor).min(self.params.tuning.dense_min_allow_mm);
        }
        let region = match plan.sweep {
            Some((path, length)) => Region {
                center: q_lin,
                sweep: Some(path),
                length,
                width: plan.width,
                slab: None,
                lever: None,
            },
            None => Region {
                center: q_lin,
                sweep: None,
                length: 0.0,
                width: plan.allowed,
                slab: slab_face,
                // A ball in contact: how far its near leaves may turn.
                lever: if self.params.heuristics.lever
                    && f.course.path_regions
                    && slab_face.is_none()
                    && self.detector.pairs.len() >= self.params.tuning.lever_min_pairs
                {
                    self.lever_at(&q_lin, plan.allowed + skin)
                } else {
                    None
                },
            },
        };
        // The trust region's rotation is bounded by the near leaves' arm.
        let lever_reach = region.lever.map_or(self.bodies.reach, |l| {
            l.trust_reach(
                self.bodies.reach,
                plan.allowed,
                skin,
                self.params.tuning.lever_margin_mm,
            )
        });
        let trust = plan
            .trust
            .then(|| self.trust_for(f, plan, slab_face, lever_reach));
        if !self.detector.pairs.is_empty() {
            // Reused in later frames with a trust region (even where this pass needs none:
            // the hand will have moved).
            let keep = trust.unwrap_or_else(|| self.trust_box(plan.allowed, 1.0, 1.0, lever_reach));
            self.run.regions.cached = Some((region, keep));
            self.run.regions.cached_bound = false;
        }
        f.course.region = region;
        f.course.fall_path = plan.fall_path;
        f.course.trust = trust;
        f.course.detect_now = false;
        self.map_warm_start();
        if self.bodies.meshes.is_some() && self.detector.contacts.len() >= ROWS_RESERVE_MIN_PAIRS {
            f.clock.rows_from = Some((Instant::now(), self.detector.contacts.len()));
        }
        Flow::Go
    }

    /// Whether the mesh-mode region just listed would have its rows, solve and check end past
    /// the budget, at [`Tuning::pass_headroom`] times the cost per triangle pair of the last
    /// region of at least [`ROWS_RESERVE_MIN_PAIRS`] (as a pass is started only where 1.25
    /// times the longest fits); never where they would not fit in a frame of their own either
    /// (then the frame runs over rather than the tool never moving).
    pub(super) fn rows_past_budget(&self, f: &FrameWork) -> bool {
        let pairs = self.detector.contacts.len();
        if self.bodies.meshes.is_none() || pairs < ROWS_RESERVE_MIN_PAIRS {
            return false;
        }
        let rest =
            self.params.tuning.pass_headroom * pairs as f64 * self.run.regions.mesh_contact_us;
        let budget = self.params.budget_us;
        f.clock.elapsed_us() + rest > budget
            && rest < (1.0 - self.params.tuning.detect_reserve) * budget
    }

    /// The trust region of an adopted region that does not reach the goal: the slab's box, a
    /// thin slab about the path (half-width `a` keeps every sphere within `sqrt(12) a` of the
    /// path), a box turned to the expected motion, or the paper's axis-aligned box.
    fn trust_for(
        &self,
        f: &FrameWork,
        plan: &RegionPlan,
        slab_face: Option<(Vector3<f64>, f64)>,
        lever_reach: f64,
    ) -> Trust {
        match (slab_face, plan.sweep) {
            (Some((n, across)), _) => self.trust_slab(&n, across, plan.allowed),
            (None, Some(_)) => Trust::Path(plan.width / 12f64.sqrt()),
            (None, None) if f.course.path_regions && self.params.heuristics.turned_trust => {
                self.trust_turned(f, plan, lever_reach)
            }
            (None, None) => {
                self.trust_box(plan.allowed, plan.need_t, plan.need_r, self.bodies.reach)
            }
        }
    }

    /// A ball's trust box turned to the expected motion: each part (translation, rotation)
    /// gets the larger of its shares of the need and of the predicted motion (the hand's press
    /// into a surface is need the tool will not follow; a turn it follows may be a small part
    /// of the need). A tool that crept in this frame's last pass (stopped well inside its
    /// ball: the contact, not the hand, sets its way) goes on as it went; else (or where that
    /// pass did not move) as predicted, turning on as in the last frame.
    fn trust_turned(&self, f: &FrameWork, plan: &RegionPlan, lever_reach: f64) -> Trust {
        let q_lin = f.course.q_lin;
        let q_pred = self.predicted_pose(&f.goal);
        let pred_t = (q_pred.translation() - q_lin.translation()).norm();
        let pred_r =
            rotation_angle(&q_pred.rotation_matrix(), &q_lin.rotation_matrix()) * self.bodies.reach;
        let share = |t: f64, r: f64| {
            if t + r > 0.0 {
                (t / (t + r)).clamp(0.2, 0.8)
            } else {
                0.5
            }
        };
        let (s_need, s_pred) = (share(plan.need_t, plan.need_r), share(pred_t, pred_r));
        // A tool that reached its optimum in the last frame holds what is left of the way to
        // the hand against its contacts (the hand pressing a shaft onto its hub's face while
        // turning it): the prediction, at that offset, is its way, and the press's share
        // would starve the turn it follows (two passes a frame). Where this frame's passes
        // have already moved it, that motion shares too (the press let go: a shaft dropping
        // into its keyways as they align). A tool left behind may still go the whole way:
        // the larger of the shares of the need and of the prediction. In the mesh mode only:
        // there a second region costs a filter and hundreds of exact distances, on the leaf
        // spheres a ball re-centred on its own pairs (the spheres' zoo lost as much as it won).
        let held = self.params.heuristics.mesh_held_press
            && self.bodies.meshes.is_some()
            && !self.run.motion.behind;
        let (mut t, mut r) = if held {
            let q_g = self.run.motion.q_g;
            let frame_step = (q_lin.translation() - q_g.translation()).norm();
            let frame_turn =
                rotation_angle(&q_lin.rotation_matrix(), &q_g.rotation_matrix()) * lever_reach;
            if frame_step + frame_turn > STILL_PASS_SHARE * plan.allowed {
                let s_frame = share(frame_step, frame_turn);
                (s_pred.max(s_frame), (1.0 - s_pred).max(1.0 - s_frame))
            } else {
                (s_pred, 1.0 - s_pred)
            }
        } else {
            (s_need.max(s_pred), (1.0 - s_need).max(1.0 - s_pred))
        };
        // A pass that did not move at all (it started on its trust region's edge) tells no way.
        let crept = f.course.crept_from.and_then(|from| {
            let pass_step = q_lin.translation() - from.translation();
            let pass_turn =
                rotation_log(&(q_lin.rotation_matrix() * from.rotation_matrix().transpose()));
            (pass_step.norm() + pass_turn.norm() * lever_reach > STILL_PASS_SHARE * plan.allowed)
                .then_some((pass_step, pass_turn))
        });
        let (step, turn) = if let Some((pass_step, pass_turn)) = crept {
            let s_pass = share(pass_step.norm(), pass_turn.norm() * lever_reach);
            t = t.max(s_pass);
            r = r.max(1.0 - s_pass);
            (pass_step, pass_turn)
        } else {
            (
                q_pred.translation() - q_lin.translation(),
                Vector3::from(self.run.motion.last_turn),
            )
        };
        self.trust_oriented(
            plan.allowed,
            t,
            r,
            (&step, &turn),
            lever_reach,
            &q_lin.rotation_matrix(),
        )
    }
}
