//! Detect: the regions of a frame (a ball about a pose, or a path along the predicted
//! motion) and their leaf pairs, the prediction, the free-space proof and its background probe.

use super::plan::Fall;
use super::*;

impl GodObject {
    /// Collects pairs at `q` within `margin` into `self.detector.pairs` (at most `max_pairs`; the rest
    /// are counted in `self.run.regions.dropped`); returns the smallest gap seen (mm, +inf if none).
    pub(super) fn detect(&mut self, q: &Pose, margin: f64) -> Result<f64, collide::CollideError> {
        self.detect_along(q, None, margin, None, None)
    }

    /// [`GodObject::detect`], or with a sweep for a path region: the pairs that come within
    /// `margin` (mm) of touching along it from `q`. With a `deadline`, a traversal still
    /// running then stops and `self.run.regions.interrupted` says so (the list is not complete).
    pub(super) fn detect_along(
        &mut self,
        q: &Pose,
        sweep: Option<&Sweep>,
        margin: f64,
        deadline: Option<Instant>,
        slab: Option<FaceSlab>,
    ) -> Result<f64, collide::CollideError> {
        self.detect_proving(q, sweep, margin, 0.0, deadline, slab)
            .map(|(gap, _)| gap)
    }

    /// [`GodObject::detect_along`] that also proves free space beyond the pairs it lists, up
    /// to `proof` mm ([`collide::overlap_shared_proving`]; at a pose without a slab, else
    /// none): the least gap and the proven margin (mm; `margin` where nothing more is proven).
    pub(super) fn detect_proving(
        &mut self,
        q: &Pose,
        sweep: Option<&Sweep>,
        margin: f64,
        proof: f64,
        deadline: Option<Instant>,
        slab: Option<FaceSlab>,
    ) -> Result<(f64, f64), collide::CollideError> {
        self.run.regions.cached = None;
        self.detector.pairs.clear();
        self.run.regions.dropped = 0;
        self.run.regions.interrupted = false;
        self.run.regions.pairs_question = None;
        let pairs = &mut self.detector.pairs;
        let dropped = &mut self.run.regions.dropped;
        let mut min_gap = f64::INFINITY;
        self.detector.face_stamp = self.detector.face_stamp.wrapping_add(1);
        if self.detector.face_stamp == 0 {
            self.detector.face_seen.iter_mut().for_each(|s| *s = (0, 0));
            self.detector.face_stamp = 1;
        }
        let (seen, stamp) = (&mut self.detector.face_seen, self.detector.face_stamp);
        let mut collect = |p: &LeafPair| {
            min_gap = min_gap.min(p.gap);
            keep_pair(p, pairs, dropped, seen, stamp);
        };
        self.run.lists.frame_detections += 1;
        // Inside the neighbour list: its pairs tested at `q` are the traversal's, and the list
        // proves free space as far as it reaches (every pair it does not hold is that far).
        let listed = if proof > margin && sweep.is_none() && slab.is_none() {
            self.ahead.neighbours.filter_proving(q, margin, proof, |p| {
                collect(p);
                true
            })
        } else {
            self.ahead
                .neighbours
                .filter(q, sweep, margin, |p| {
                    collect(p);
                    true
                })
                .map(|n| (n, margin))
        };
        if let Some((_, proven)) = listed {
            self.run.counts.frame_scanned += self.ahead.neighbours.len() as u64;
            self.run.counts.regions_filtered += 1;
            self.run.lists.list_served = self.run.lists.list_served.saturating_add(1);
            if sweep.is_none() && slab.is_none() && self.run.regions.dropped == 0 {
                self.run.regions.pairs_question = Some((*q, margin));
            }
            return Ok((min_gap, proven));
        }
        self.run.counts.regions_traversed += 1;
        // The shared traversal's order is the same with or without the helper, so the
        // frames are too.
        let (t, proven) = if proof > margin && sweep.is_none() && slab.is_none() {
            collide::overlap_shared_proving(
                &self.bodies.tool,
                q,
                &self.bodies.objects,
                margin,
                proof,
                &mut self.detector.ws,
                self.detector.team.as_ref(),
                deadline,
                collect,
            )?
        } else {
            let t = collide::overlap_shared(
                &self.bodies.tool,
                q,
                sweep,
                &self.bodies.objects,
                margin,
                slab,
                &mut self.detector.ws,
                self.detector.team.as_ref(),
                deadline,
                collect,
            )?;
            (t, margin)
        };
        self.run.counts.frame_splits += self.detector.ws.stats().node_pairs_split as u64;
        self.run.regions.dropped += t.unreported;
        self.run.regions.interrupted = !t.complete;
        if sweep.is_none() && slab.is_none() && self.run.regions.dropped == 0 && t.complete {
            self.run.regions.pairs_question = Some((*q, margin));
        }
        if !self.detector.pairs.is_empty() {
            // What a region's traversal costs in this contact (a neighbour list must beat it).
            let splits = self.detector.ws.stats().node_pairs_split as f64;
            self.run.lists.splits_per_region =
                0.9 * self.run.lists.splits_per_region + 0.1 * splits;
        }
        Ok((min_gap, proven))
    }

    /// True when some leaf pair is within `margin` (mm) of touching at `q`; stops at the first
    /// one, so a large margin (a fast hand) stays cheap. Stores no pair. Past the `deadline`
    /// without an answer: true (the safe side: the step then keeps a trust region).
    pub(super) fn any_within(
        &mut self,
        q: &Pose,
        margin: f64,
        deadline: Option<Instant>,
    ) -> Result<bool, collide::CollideError> {
        let mut any = false;
        let listed = self.ahead.neighbours.filter(q, None, margin, |_| {
            any = true;
            false
        });
        if listed.is_some() {
            self.run.counts.frame_scanned += self.ahead.neighbours.len() as u64;
            return Ok(any);
        }
        let any = collide::any_pair_within_until(
            &self.bodies.tool,
            q,
            &self.bodies.objects,
            margin,
            &mut self.detector.ws,
            || deadline.is_none_or(|d| Instant::now() < d),
        );
        self.run.counts.frame_splits += self.detector.ws.stats().node_pairs_split as u64;
        any.map(|a| a.unwrap_or(true))
    }

    /// Where this frame's answer is expected, as a motion from `q_lin`: the hand keeps last
    /// frame's offset from the graphic tool (`hand_offset`), so the tool moves as the hand
    /// did. A falling tool ([`Fall`]) goes its way toward the hand instead. `None` when that
    /// motion is shorter than [`Tuning::min_sweep_mm`]; scaled down to `cap` mm. Returns the
    /// sweep and its largest sphere motion (mm).
    pub(super) fn predicted_sweep(
        &self,
        q_lin: &Pose,
        q_h: &Pose,
        cap: f64,
        fall: Option<Fall>,
    ) -> Option<(Sweep, f64)> {
        let way = q_h.translation() - q_lin.translation();
        let (v, w) = match fall {
            Some(Fall::Straight) => (way, Vector3::zeros()),
            Some(Fall::Along(step)) => {
                let along = step.normalize();
                (along * way.dot(&along).max(0.0), Vector3::zeros())
            }
            None => self.expected_motion(q_lin, q_h),
        };
        let length = v.norm() + w.norm() * self.bodies.reach;
        if length.is_nan() || length < self.params.tuning.min_sweep_mm {
            return None;
        }
        // At least `Tuning::path_min_mm` long, so a slow hand's next frames reuse the region.
        let scale = (self.params.tuning.path_min_mm / length)
            .max(1.0)
            .min(cap / length);
        let sweep = Sweep {
            translation: (v * scale).into(),
            rotation: (w * scale).into(),
        };
        Some((sweep, length * scale))
    }

    /// The motion from `q_lin` to the pose the tool is expected at for the hand at `q_h`
    /// ([`GodObject::predicted_pose`]): translation (mm, world) and rotation vector (rad).
    fn expected_motion(&self, q_lin: &Pose, q_h: &Pose) -> (Vector3<f64>, Vector3<f64>) {
        let q_pred = self.predicted_pose(q_h);
        (
            q_pred.translation() - q_lin.translation(),
            rotation_log(&(q_pred.rotation_matrix() * q_lin.rotation_matrix().transpose())),
        )
    }

    /// A thin path's sweep ([`Heuristics::mesh_thin_paths`]): from `q_lin` to the pose the tool
    /// is expected at for the hand at `q_h`, however short, within `cap` (mm); with its largest
    /// sphere motion and the turn bound of its rotation (mm). `None` where the tool is not
    /// expected to move.
    pub(super) fn thin_sweep(
        &self,
        q_lin: &Pose,
        q_h: &Pose,
        cap: f64,
    ) -> Option<(Sweep, f64, f64)> {
        let (v, w) = self.expected_motion(q_lin, q_h);
        let length = v.norm() + w.norm() * self.bodies.reach;
        if !(length > 0.0 && length.is_finite()) {
            return None;
        }
        let scale = (cap / length).min(1.0);
        let sweep = Sweep {
            translation: (v * scale).into(),
            rotation: (w * scale).into(),
        };
        let r = q_lin.rotation_matrix();
        let turn = self.turn_bound(&r, &(rotation_exp(&(w * scale)) * r));
        Some((sweep, length * scale, turn))
    }

    /// How far (mm, largest sphere motion) the pose `q` (variable `dq` of `lin`) is from
    /// `region`: from its centre, or from the nearest pose on its path (found in the variable,
    /// rotations scaled by reach).
    pub(super) fn distance_from_region(
        &self,
        lin: &Linearization,
        region: &Region,
        q: &Pose,
        dq: &[f64; 6],
    ) -> f64 {
        if region.sweep.is_none() {
            return match &region.lever {
                None => self.motion_bound(&region.center, q),
                Some(lever) => self.lever_bound(lever, region, q),
            };
        }
        let (base, end) = (lin.variable(&region.center), lin.variable(&region.end()));
        let s = self.path_share(lin, region, dq);
        let on_path = lin.configuration(&std::array::from_fn(|k| base[k] + s * (end[k] - base[k])));
        self.motion_bound(&on_path, q)
    }

    /// How far along a path region's path (0 at its centre, 1 at its end) the nearest point to
    /// the variable `dq` is (rotations scaled by the tool's reach); 0 for a ball.
    pub(super) fn path_share(&self, lin: &Linearization, region: &Region, dq: &[f64; 6]) -> f64 {
        if region.sweep.is_none() {
            return 0.0;
        }
        let base = lin.variable(&region.center);
        let end = lin.variable(&region.end());
        let reach2 = self.bodies.reach.max(1e-9).powi(2);
        let (mut along, mut len2) = (0.0, 0.0);
        for k in 0..6 {
            let d = (end[k] - base[k]) * if k < 3 { 1.0 } else { reach2 };
            along += (dq[k] - base[k]) * d;
            len2 += (end[k] - base[k]) * d;
        }
        if len2 > 0.0 {
            (along / len2).clamp(0.0, 1.0)
        } else {
            0.0
        }
    }

    /// How far (mm) a tool leaf centre moves at most across a face with unit normal `n`
    /// between the poses `a` and `b`: the translation's part along `n`, plus the turn's tilt of
    /// `n` times the reach (a turn `w` moves `x` by `(R - I) x`, whose part along `n` is at
    /// most `|n × w| |x|`: a turn about `n` moves nothing across the face).
    pub(super) fn across_bound(&self, n: &Vector3<f64>, a: &Pose, b: &Pose) -> f64 {
        let dt = b.translation() - a.translation();
        let w = rotation_log(&(b.rotation_matrix() * a.rotation_matrix().transpose()));
        n.dot(&dt).abs() + n.cross(&w).norm() * self.bodies.reach
    }

    /// The widths of a slab region (mm: across the face, along it) for a tool held by one
    /// flat face (`run.regions.contact_face`), or `None` where a ball serves as well: the
    /// slide along the face as a ball region would take it (`need`, `allow`, `cap`), at least
    /// [`Tuning::slab_slide_mm`]; across it 1.5 times last frame's motion across plus
    /// [`Tuning::slab_across_min_mm`], within the pair density's allowance `dense_cap` (the face's
    /// pairs grow with this margin, not the slide's). Only where the face's margin is at most
    /// half the slide's, and not while slabs rest after a failure ([`Tuning::slab_rest_frames`]).
    pub(super) fn slab_widths(
        &self,
        need: f64,
        allow: f64,
        cap: f64,
        dense_cap: f64,
    ) -> Option<(Vector3<f64>, f64, f64)> {
        if self.run.regions.slab_rest > 0 {
            return None;
        }
        let n = self.run.regions.contact_face?;
        let step = Vector3::from(self.run.motion.last_step);
        let turn = Vector3::from(self.run.motion.last_turn);
        let across = n.dot(&step).abs() + n.cross(&turn).norm() * self.bodies.reach;
        let slide = need
            .min(allow.max(self.params.tuning.slab_slide_mm))
            .min(cap);
        let face = (1.5 * across + self.params.tuning.slab_across_min_mm)
            .min(dense_cap.max(self.params.tuning.slab_across_min_mm))
            .min(slide);
        (face <= 0.5 * slide).then_some((n, face, slide))
    }

    /// Width (mm) of a path region: twice the recent prediction error, within bounds.
    pub(super) fn path_width(&self) -> f64 {
        (2.0 * self.run.motion.prediction_error).clamp(
            self.params.tuning.path_width_min_mm,
            self.params.tuning.path_width_max_mm,
        )
    }

    /// Where the graphic tool is expected for the device pose `q_h`: at last frame's offset
    /// from the hand (`run.motion.hand_offset`).
    pub(super) fn predicted_pose(&self, q_h: &Pose) -> Pose {
        let (off_t, off_w) = self.run.motion.hand_offset;
        Pose::from_translation_rotation(
            &(q_h.translation() - off_t),
            &(rotation_exp(&-off_w) * q_h.rotation_matrix()),
        )
    }

    /// Deepest overlap (mm, >= 0) of the tool at `q`, using the region's buffers as scratch.
    /// In the mesh mode the triangles' overlap has no depth: 0 when no triangles meet, else
    /// infinity.
    pub fn penetration_at(&mut self, q: &Pose) -> f64 {
        let depth = match self.detect(q, 0.0) {
            Ok(g) if g.is_finite() => (-g).max(0.0),
            Ok(_) => 0.0,
            Err(_) => return f64::INFINITY,
        };
        if self.bodies.meshes.is_none() {
            return depth;
        }
        self.narrow_phase(q, 0.0);
        if self.mesh_meets(None, q) {
            f64::INFINITY
        } else {
            0.0
        }
    }

    /// Where the tool at `q` is `frames` frames on if it keeps moving as it did over the last
    /// frame: its translation continued along the last step, its rotation turned on by the
    /// last turn (about the tool origin). A schedule's guess, not a bound.
    pub(super) fn pose_ahead(&self, q: &Pose, frames: f64) -> Pose {
        let t = q.translation() + Vector3::from(self.run.motion.last_step) * frames;
        let turn = Vector3::from(self.run.motion.last_turn) * frames;
        let r = rotation_exp(&turn) * q.rotation_matrix();
        if t.iter().all(|v| v.is_finite()) && r.iter().all(|v| v.is_finite()) {
            Pose::from_translation_rotation(&t, &r)
        } else {
            *q
        }
    }

    /// Slack (mm) of the free-space proofs at `q`: how much farther than `q` the better one
    /// proves free space (negative when neither reaches `q`).
    pub(super) fn free_slack(&self, q: &Pose) -> f64 {
        if !self.params.heuristics.free_space_proofs {
            return f64::NEG_INFINITY;
        }
        self.run
            .proofs
            .free
            .iter()
            .map(|p| p.radius - self.proof_distance(p, q))
            .fold(f64::NEG_INFINITY, f64::max)
    }

    /// The motion bound (mm) of the tool at `q` from the nearest pose of `proof`'s path: the
    /// distance of `q`'s translation from the path's segment plus the turn's
    /// ([`GodObject::turn_bound`]).
    pub(super) fn proof_distance(&self, proof: &FreeProof, q: &Pose) -> f64 {
        segment_distance(&(q.translation() - proof.center.translation()), &proof.path)
            + self.turn_bound(&proof.center.rotation_matrix(), &q.rotation_matrix())
    }

    /// Frames (at the tool's last motion per frame, continued) until the tool at `q` leaves
    /// `proof` for a frame that needs `used` mm of it: 0 if it already has, infinite for a tool
    /// at rest. A schedule, not a proof: each frame checks its slack exactly.
    pub(super) fn frames_in(&self, proof: &FreeProof, q: &Pose, used: f64) -> f64 {
        let turn = self.turn_bound(&proof.center.rotation_matrix(), &q.rotation_matrix());
        let r = proof.radius - used - turn;
        let p = q.translation() - proof.center.translation();
        if r <= 0.0 || segment_distance(&p, &proof.path) > r {
            return 0.0;
        }
        let step = Vector3::from(self.run.motion.last_step);
        // The motion per frame that is not the translation (turning) uses up the radius too.
        let other = (self.run.motion.last_motion - step.norm()).max(0.0);
        let by_turn = if other > 1e-12 {
            r / other
        } else {
            f64::INFINITY
        };
        let along = if step.norm_squared() > 1e-18 {
            // The distance from the path is convex along the motion: inside now, the exit is
            // where it first exceeds `r` (bisection, after doubling past it).
            let inside = |k: f64| segment_distance(&(p + step * k), &proof.path) <= r;
            let mut hi = 1.0;
            while inside(hi) && hi < 1e9 {
                hi *= 2.0;
            }
            let mut lo = 0.0;
            for _ in 0..40 {
                let mid = 0.5 * (lo + hi);
                if inside(mid) {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            lo
        } else {
            f64::INFINITY
        };
        along.min(by_turn)
    }

    /// Frames (at the tool's last motion per frame, continued) each free-space proof serves a
    /// tool at `q` needing `used` mm: until it leaves the proof, for one it is in; for one
    /// ahead, until it leaves that one after the other hands it over (a frame before the
    /// other runs out); 0 for one it will not enter. A schedule, not a proof.
    pub(super) fn proof_reach(&self, q: &Pose, used: f64) -> [f64; 2] {
        let direct = [0, 1].map(|i| self.frames_in(&self.run.proofs.free[i], q, used));
        let mut reach = direct;
        for (i, j) in [(0, 1), (1, 0)] {
            if direct[j] > 0.0 || !(direct[i] > 1.0 && direct[i].is_finite()) {
                continue;
            }
            let handover = (direct[i] - 1.0).floor();
            let there = self.pose_ahead(q, handover);
            let more = self.frames_in(&self.run.proofs.free[j], &there, used);
            if more > 0.0 {
                reach[j] = handover + more;
            }
        }
        reach
    }

    /// Frames until a tool at `q` needing `used` mm, moving on as it did, leaves the free-space
    /// proofs, handed over from one to the other: [`GodObject::proof_reach`]'s longest.
    pub(super) fn proof_horizon(&self, q: &Pose, used: f64) -> f64 {
        let [a, b] = self.proof_reach(q, used);
        a.max(b)
    }

    /// Keeps `center` (with its `path`)/`radius` as a free-space proof in place of the one
    /// that serves a tool at `q` needing `used` mm the fewest frames ahead.
    pub(super) fn add_free_proof(
        &mut self,
        center: Pose,
        path: Vector3<f64>,
        radius: f64,
        q: &Pose,
        used: f64,
    ) {
        let [a, b] = self.proof_reach(q, used);
        self.run.proofs.free[usize::from(a > b)] = FreeProof {
            center,
            path,
            radius,
        };
    }

    /// Whether a new proof may replace one now without cutting short a proof the tool is in
    /// (both serve it: one now, one ahead). A finished background probe then waits.
    fn proof_slot_free(&self, q: &Pose, used: f64) -> bool {
        let [a, b] = self.proof_reach(q, used);
        let i = usize::from(a > b);
        self.frames_in(&self.run.proofs.free[i], q, used) <= 0.0
            || self.frames_in(&self.run.proofs.free[1 - i], q, used) > 0.0
    }

    /// When the proofs have run out at `q` (a frame needing `used` mm) but the background
    /// probe, unfinished, would cover it: carries the probe on (until the `deadline`) instead
    /// of a fresh traversal, which would cost more than the probe's remaining slices.
    /// `Some(true)`: it finished free (its proof is kept); `Some(false)`: still running at the
    /// deadline (the frame ends; the next one carries on); `None`: no covering probe, or it
    /// found a pair (a traversal is needed).
    pub(super) fn finish_probe(&mut self, q: &Pose, used: f64, deadline: Instant) -> Option<bool> {
        if !self.params.heuristics.probes() || self.ahead.probe.status() != ProbeStatus::Running {
            return None;
        }
        let (center, radius) = self.ahead.probe.question();
        let asked = FreeProof {
            center,
            path: Vector3::from(self.ahead.probe.path()),
            radius,
        };
        if self.proof_distance(&asked, q) + used > radius {
            return None;
        }
        loop {
            // Needed now: this thread works on it too (a helper running it in the background
            // goes on with the other stream).
            let before = self.ahead.probe.splits();
            self.ahead.probe.advance_now(
                &self.bodies.tool,
                &self.bodies.objects,
                PROBE_FINISH_SLICE_SPLITS,
                Some(deadline),
            );
            self.run.counts.frame_splits += self.ahead.probe.splits().saturating_sub(before) as u64;
            if self.ahead.probe.status() != ProbeStatus::Running {
                break;
            }
            if Instant::now() >= deadline {
                return Some(false);
            }
        }
        if self.ahead.probe.status() != ProbeStatus::Free {
            self.ahead.probe.take();
            return None;
        }
        self.note_probe_cost();
        let path = Vector3::from(self.ahead.probe.path());
        let (_, pose, radius) = self.ahead.probe.take();
        self.add_free_proof(pose, path, radius, q, used);
        Some(true)
    }

    /// Remembers the finished probe's cost (node pairs split) for the next of its kind.
    fn note_probe_cost(&mut self) {
        if self.ahead.probe.path() != [0.0; 3] {
            self.run.proofs.path_probe_splits = self.ahead.probe.splits();
        } else {
            self.run.proofs.probe_splits = self.ahead.probe.splits();
        }
    }

    /// Node pairs the next probe along a path is expected to split: the last one's, or before
    /// any, four times a probe at a pose (measured in a tight hole: 1.0–1.5 times the node
    /// pairs of a probe at a pose for 3–6 mm going out, 1.8–4.5 going in).
    fn path_probe_estimate(&self) -> f64 {
        if self.run.proofs.path_probe_splits > 0 {
            self.run.proofs.path_probe_splits as f64
        } else {
            4.0 * self.run.proofs.probe_splits as f64
        }
    }

    /// Keeps the free-space proofs ahead of the tool without a long traversal in any one frame,
    /// for a frame that needs `used` mm at `q`. When the proofs cover fewer frames ahead (at
    /// the tool's last motion per frame) than the next probe needs at [`Tuning::probe_slice_splits`]
    /// per frame, a probe starts where the tool will be when they run out, plus
    /// [`Tuning::probe_ahead`] of a proof's usable radius; each frame runs one slice of it, sized to
    /// finish in time. A finished free probe replaces the proof that runs out first.
    pub(super) fn tend_probe(&mut self, q: &Pose, used: f64, deadline: Instant) {
        if !self.params.heuristics.probes() {
            return;
        }
        if let Some(team) = &self.detector.team {
            // Probes come every few frames here: the helper stays ready for them.
            team.keep_awake();
        }
        let speed = self.run.motion.last_motion.max(1e-4);
        // Inside a neighbour list, a proof that runs out is renewed by filtering the list (a
        // pass over its entries, no traversal): the probe has until the list runs out.
        let list_frames = (self.ahead.neighbours.slack(q, None, used) / speed).max(0.0);
        let horizon = self.proof_horizon(q, used).max(list_frames);
        if self.ahead.probe.status() == ProbeStatus::Running {
            self.probe_slice(horizon, deadline);
        }
        match self.ahead.probe.status() {
            ProbeStatus::Free if !self.proof_slot_free(q, used) => {}
            ProbeStatus::Free => {
                self.note_probe_cost();
                let path = Vector3::from(self.ahead.probe.path());
                let (_, pose, radius) = self.ahead.probe.take();
                self.add_free_proof(pose, path, radius, q, used);
                self.run.proofs.probe_margin = (self.params.tuning.probe_margin_growth * radius)
                    .min(self.params.tuning.background_probe_mm);
            }
            ProbeStatus::Touching => {
                // Something lies within the margin asked: the next probe asks for less.
                let (_, radius) = self.ahead.probe.question();
                self.ahead.probe.take();
                self.run.proofs.probe_margin = (self.params.tuning.probe_margin_shrink * radius)
                    .max(self.params.tuning.background_probe_min_mm);
            }
            ProbeStatus::Idle => self.start_probe(q, used, horizon, list_frames),
            ProbeStatus::Running => {}
        }
    }

    /// One slice of the running background probe, paced from the last probe's cost to finish
    /// a little before the proofs run out (`horizon` frames), and stopped at a share of the
    /// frame's budget or the `deadline`.
    fn probe_slice(&mut self, horizon: f64, deadline: Instant) {
        // The last probe's cost (of the same kind) estimates this one's; one that runs
        // past it (a deeper hole costs more) is given a quarter more at a time. It aims to
        // finish a frame before the proofs run out.
        let (estimate, least) = if self.ahead.probe.path() != [0.0; 3] {
            (self.path_probe_estimate(), PATH_PROBE_MIN_SLICE_SPLITS)
        } else {
            (self.run.proofs.probe_splits as f64, PROBE_MIN_SLICE_SPLITS)
        };
        // Paced to finish a little before the horizon (a probe at a pose), or within three
        // quarters of it (along a path: the horizon is measured at the last frame's motion,
        // and a hand speeding up along the path shortens it), for a quarter more than the
        // estimate, the last probe's cost (a shaft drawn out of its splined hole ran a path
        // probe of 20 300 node pairs on an estimate of 16 300 at the least slice until its
        // last frames, then finished 3 500 of them in one).
        let left = (self.params.tuning.probe_estimate_spare * estimate
            - self.ahead.probe.splits() as f64)
            .max(0.25 * estimate);
        let within = if self.ahead.probe.path() != [0.0; 3] {
            self.params.tuning.probe_finish_within * horizon
                - self.params.tuning.probe_finish_spare_frames
        } else {
            horizon - self.params.tuning.probe_finish_spare_frames
        };
        let mut slice = (left / within.max(1.0)).clamp(least as f64, PROBE_MAX_SLICE_SPLITS as f64);
        // A new probe's first slice meets its part of the trees cold: a smaller one (the
        // later slices make up for it).
        if self.ahead.probe.splits() == 0 && horizon > 2.0 {
            slice *= self.params.tuning.probe_first_slice_share;
        }
        let tt = Instant::now();
        // A slice's node pairs cost 0.05–0.3 µs each (a path's more, a cold tree's more):
        // while the proofs still serve, it also stops at its share of the frame's budget.
        let share = if horizon > 2.0 {
            PROBE_SLICE_MAX_SHARE
        } else {
            PROBE_SLICE_URGENT_SHARE
        };
        let slice_time = share * self.params.budget_us.max(0.0) * 1e-6;
        let slice_deadline = deadline.min(tt + std::time::Duration::from_secs_f64(slice_time));
        let before = self.ahead.probe.splits();
        self.ahead.probe.advance_shared(
            &self.bodies.tool,
            &self.bodies.objects,
            slice as usize,
            self.detector.team.as_ref(),
            Some(slice_deadline),
        );
        self.run.counts.frame_splits += self.ahead.probe.splits().saturating_sub(before) as u64;
    }

    /// Starts the next background probe when the proofs about `q` (`horizon` frames left, for
    /// a frame that needs `used` mm) run out within the probe's expected slices: along the
    /// tool's way for a tool sliding steadily, else at the pose where they run out and beyond.
    fn start_probe(&mut self, q: &Pose, used: f64, horizon: f64, list_frames: f64) {
        let speed = self.run.motion.last_motion.max(1e-4);
        // A tool sliding steadily (without turning) is probed along its way.
        let step = Vector3::from(self.run.motion.last_step);
        let sliding = step.norm() >= self.params.tuning.path_probe_min_step_mm
            && self.run.motion.last_motion <= 1.25 * step.norm();
        // Where a whole proof costs less than a slice (open space), renewing it when
        // it runs out is cheaper than probing ahead; not where a neighbour list
        // renewed the proofs (the tight gap it was built in costs a long traversal
        // once it runs out).
        let worth_it = self.run.proofs.probe_splits > self.params.tuning.probe_slice_splits
            || list_frames > 0.0;
        let (estimate, pace, ahead) = if sliding {
            (
                self.path_probe_estimate(),
                PATH_PROBE_SLICE_SPLITS,
                self.params.tuning.path_probe_lead,
            )
        } else {
            (
                self.run.proofs.probe_splits as f64,
                self.params.tuning.probe_slice_splits,
                1.5,
            )
        };
        let lead = (ahead * estimate / pace as f64 + 2.0).max(self.params.tuning.probe_lead_frames);
        let margin = self.run.proofs.probe_margin;
        let lasts = margin - used >= self.params.tuning.probe_min_usable_frames * speed;
        // A tool at rest in free space has time to spare: a wider proof about it,
        // built a slice a frame, serves the first frames of its next motion while the
        // probes ahead of that motion get going (an insertion that starts from rest in a
        // hole: ~100 µs traversals without one).
        let widen = horizon >= self.params.tuning.rest_horizon_frames
            && self.free_slack(q) + used < self.params.tuning.probe_widen_ratio * margin;
        if worth_it && widen {
            let _ = self.ahead.probe.start(&self.bodies.tool, q, margin);
        } else if worth_it && horizon < lead && lasts {
            if sliding {
                // The probe goes along the tool's way from where the proofs run out
                // (a frame early), for many frames of the same motion.
                let length = (self.params.tuning.path_probe_frames * step.norm()).clamp(
                    self.params.tuning.path_probe_min_mm,
                    self.params.tuning.path_probe_max_mm,
                );
                let mut from = *q;
                for k in 0..3 {
                    from.q[k] += (horizon - 1.0).max(0.0) * step[k];
                }
                let path = step * (length / step.norm());
                let _ = self
                    .ahead
                    .probe
                    .start_along(&self.bodies.tool, &from, path.into(), margin);
            } else {
                // The tool keeps moving (and turning) as it did last frame: the new
                // proof's ball is centred past the point where the current ones run
                // out, so that it takes over a little before and lasts well after.
                let usable = (margin - used).max(0.0);
                let ahead_frames = horizon + self.params.tuning.probe_ahead * usable / speed;
                let ahead = self.pose_ahead(q, ahead_frames);
                let _ = self.ahead.probe.start(&self.bodies.tool, &ahead, margin);
            }
        }
    }

    /// Keeps a neighbour list about the tool while it is in contact and slow enough for one to
    /// last [`Tuning::list_min_life_frames`] (a frame needing `used` mm at `q`): when the list in use
    /// covers fewer frames ahead (at the tool's last motion per frame) than the next build
    /// needs at its pace, the next one starts where the tool is expected half-way through its
    /// life, and each frame builds a slice of it (until the `deadline`), sized to finish in
    /// time. A finished list replaces the one in use; its pair count sets the next margin.
    pub(super) fn tend_neighbours(&mut self, q: &Pose, used: f64, deadline: Instant) {
        if !self.params.heuristics.neighbour_lists {
            return;
        }
        let speed = self.run.motion.last_motion;
        let margin = self.run.lists.list_margin;
        let life = (margin - used).max(0.0) / speed.max(1e-9);
        self.run.lists.detections_per_frame = 0.9 * self.run.lists.detections_per_frame
            + 0.1 * self.run.lists.frame_detections as f64;
        self.run.lists.frame_detections = 0;
        // A list pays where regions are costly to traverse (flat-on-flat contacts: a thousand
        // node pairs per region; not a small curved contact's hundred), and on this thread
        // only where it does not cost clearly more per frame than the regions it spares (a
        // helper builds it on time nobody else wants).
        let spared = self.run.lists.detections_per_frame * self.run.lists.splits_per_region;
        let costs = self.run.lists.list_splits as f64 / life.max(1.0);
        if self.ahead.next_neighbours.status() == ListStatus::Empty {
            self.run.lists.list_yield = (self.run.lists.list_yield * LIST_YIELD_RECOVERY)
                .min(self.params.tuning.list_first_yield);
        }
        let pays = self.run.lists.splits_per_region >= self.params.tuning.list_min_region_splits
            && (self.detector.team.is_some()
                || self.run.lists.idle_given
                || (costs <= self.params.tuning.list_payoff * spared
                    && self.run.lists.list_yield >= self.params.tuning.list_min_yield));
        // A list holds leaf pairs without the faces' merging and pruning: with face caps its
        // build costs the whole-sphere traversal the faces spare, so none is kept (measured on
        // a splined shaft in its hub with caps: p99 579 µs without lists, 727 µs with).
        if self.detector.pairs.is_empty()
            || life < self.params.tuning.list_min_life_frames
            || !pays
            || self.bodies.faces
        {
            // Free space (the proofs serve), too fast for a list to last, or not worth it.
            self.ahead.next_neighbours.cancel();
            return;
        }
        let horizon = if self.ahead.neighbours.status() == ListStatus::Ready {
            let (center, radius) = self.ahead.neighbours.question();
            let list = FreeProof {
                center,
                path: Vector3::zeros(),
                radius,
            };
            self.frames_in(&list, q, used)
        } else {
            0.0
        };
        // With a helper thread the build runs in the background, as fast as it goes (its
        // grant per frame is large); alone, a slice per frame, sized to finish in time.
        let pace = if self.detector.team.is_some() {
            LIST_HELPER_WORK_PER_FRAME
        } else {
            self.params.tuning.probe_slice_splits
        };
        if self.ahead.next_neighbours.status() == ListStatus::Building && Instant::now() < deadline
        {
            let estimate = self.run.lists.list_work as f64;
            let left = (estimate - self.ahead.next_neighbours.work() as f64).max(0.25 * estimate);
            let slice = (left / (horizon - 1.0).max(1.0))
                .clamp(PROBE_MIN_SLICE_SPLITS as f64, LIST_MAX_SLICE_WORK as f64);
            let grant = (slice as usize).max(if self.detector.team.is_some() {
                pace
            } else {
                0
            });
            let before = self.ahead.next_neighbours.work();
            self.ahead.next_neighbours.advance(
                &self.bodies.tool,
                &self.bodies.objects,
                grant,
                slice as usize,
                self.detector.team.as_ref(),
                Some(deadline),
            );
            self.run.counts.frame_splits +=
                self.ahead.next_neighbours.work().saturating_sub(before) as u64;
        }
        match self.ahead.next_neighbours.status() {
            ListStatus::Ready => self.take_next_list(),
            ListStatus::Overflowed => {
                let (_, built) = self.ahead.next_neighbours.question();
                self.run.lists.list_margin = (0.6 * built).max(self.params.tuning.list_min_mm);
                self.run.lists.list_work = self
                    .run
                    .lists
                    .list_work
                    .max(self.ahead.next_neighbours.work());
                self.ahead.next_neighbours.cancel();
            }
            ListStatus::Empty => {
                let frames = self.run.lists.list_work as f64 / pace as f64;
                // (With a helper, measured paced: starting each build as soon as the last
                // list is taken placed it too far ahead, p99 262–319 against 84–133 µs.)
                let lead = 1.5 * frames + 2.0;
                if horizon < lead {
                    let ahead_frames = horizon + 0.5 * life;
                    let mut center = *q;
                    for k in 0..3 {
                        center.q[k] += ahead_frames * self.run.motion.last_step[k];
                    }
                    let _ = self
                        .ahead
                        .next_neighbours
                        .start(&self.bodies.tool, &center, margin);
                }
            }
            ListStatus::Building => {}
        }
    }

    /// A finished next neighbour list replaces the one in use; its pair count sets the next
    /// list's margin.
    fn take_next_list(&mut self) {
        let work = self.ahead.next_neighbours.work();
        let in_use = self.ahead.neighbours.status() == ListStatus::Ready;
        let (served, last_work) = (self.run.lists.list_served, self.run.lists.list_work);
        if self.ahead.next_neighbours.take(&mut self.ahead.neighbours) {
            // What the list it replaces answered, against its work.
            if in_use {
                let answered = served as f64 * self.run.lists.splits_per_region;
                let sample = answered / last_work.max(1) as f64;
                self.run.lists.list_yield = 0.5 * self.run.lists.list_yield + 0.5 * sample;
            }
            self.run.lists.list_served = 0;
            self.run.lists.list_work = work;
            self.run.lists.list_splits = self.ahead.neighbours.splits();
            let n = self.ahead.neighbours.len().max(1) as f64;
            let (_, built) = self.ahead.neighbours.question();
            // Pairs grow about as the margin cubed over a bumpy flat contact.
            self.run.lists.list_margin =
                (built * (self.params.tuning.list_target_pairs / n).cbrt()).clamp(
                    self.params.tuning.list_min_mm,
                    self.params.tuning.list_max_mm,
                );
        }
    }

    /// Uses a paced loop's wait before the next frame (until `until`): the running background
    /// probe, the next neighbour list's build and the mesh mode's near list under way go on here, in slices of 128 node pairs
    /// between clock reads, until 60 µs before `until`; a list finished here is taken at once;
    /// the rest of the wait brings the trees into cache ([`GodObject::warm_caches`]). What the
    /// frames would have done in their own slices is done in time nobody else wants, on this
    /// thread (the helper thread's work, without a second core); a wait of 200 µs or more also
    /// lets the next frame keep a list wherever one lasts, as with the helper. The answers stay
    /// exact (a probe's proof and a list are the same whenever they finish); which frames
    /// detect, and so their times and counts, may differ.
    ///
    /// # Real-time
    /// No allocation, no panic; returns within one slice (~10–40 µs) of `until`.
    pub fn idle(&mut self, until: Instant) {
        self.run.lists.idle_given = until
            .checked_duration_since(Instant::now())
            .is_some_and(|d| d.as_micros() >= u128::from(IDLE_FOR_LISTS_US));
        let stop = until.checked_sub(std::time::Duration::from_micros(IDLE_WARM_US));
        let busy = |now: Instant| stop.is_some_and(|s| now < s);
        while busy(Instant::now()) && self.ahead.probe.status() == ProbeStatus::Running {
            self.ahead.probe.advance_now(
                &self.bodies.tool,
                &self.bodies.objects,
                IDLE_SLICE_SPLITS,
                stop,
            );
        }
        while busy(Instant::now()) && self.ahead.next_neighbours.status() == ListStatus::Building {
            self.ahead.next_neighbours.advance(
                &self.bodies.tool,
                &self.bodies.objects,
                IDLE_SLICE_SPLITS,
                IDLE_SLICE_SPLITS,
                self.detector.team.as_ref(),
                stop,
            );
        }
        if self.ahead.next_neighbours.status() == ListStatus::Ready {
            self.take_next_list();
        }
        if let Some(stop) = stop.filter(|&s| Instant::now() < s) {
            // The mesh mode's near list under way (or the next one ahead, where due).
            let q = self.run.motion.q_g;
            self.tend_near(&q, f64::INFINITY, stop);
            // Done in the wait, it is taken in the wait where it holds as long, and where the
            // wait has time for its inheritance (not bounded by the clock).
            if self.take_near_list_in_wait(&q, stop) {
                self.tend_near(&q, f64::INFINITY, stop);
            }
        }
        self.warm_caches(until);
    }

    /// How far (mm) a tool leaf centre moves at most when the tool turns from `r_a` to `r_b`:
    /// the angle `θ` times the lever arm about the turn's axis `û` (`R_b R_a^T = exp(θ û)`:
    /// a centre `x = R_a p` moves by `2 sin(θ/2) |û × x| <= θ |û × x|`). A shaft turning about
    /// its own axis moves its centres by 17.7 mm per radian, not its reach of 56.5.
    pub(super) fn turn_bound(&self, r_a: &Matrix3<f64>, r_b: &Matrix3<f64>) -> f64 {
        self.bodies.turn_bound(r_a, r_b)
    }

    /// The near part of the tool ([`Lever`]) at `q` for a ball region of margin `margin` (mm),
    /// or `None` where it is most of the tool (then the whole tool's bound serves). The box is
    /// found [`Tuning::lever_spare_mm`] wider than needed and kept while the tool stays within that of
    /// where it was found: a leaf outside it, farther than `M` from the objects there, is
    /// farther than `M - b` at a pose the motion bound `b` away.
    pub(super) fn lever_at(&mut self, q: &Pose, margin: f64) -> Option<Lever> {
        let need = margin + self.params.tuning.lever_margin_mm;
        if let Some((at, found, lever)) = self.run.regions.lever_cache {
            if found - self.motion_bound(&at, q) >= need {
                return lever;
            }
        }
        let found = need + self.params.tuning.lever_spare_mm;
        let lever = collide::near_box(
            &self.bodies.tool,
            q,
            &self.bodies.objects,
            found,
            LEVER_LEVEL,
            LEVER_LEVEL,
            LEVER_MAX_TESTS,
        )
        .and_then(|(lo, hi)| {
            let near = CentreBox::of_box(Vector3::from(lo), Vector3::from(hi));
            let reach = near.reach().min(self.bodies.reach);
            // Worth it only where the near leaves turn on a shorter arm than the tool.
            (reach < 0.9 * self.bodies.reach).then_some(Lever { near, reach })
        });
        self.run.regions.lever_cache = Some((*q, found, lever));
        lever
    }

    /// How far (mm) the pose `q` is from the ball region `region` with the near part `lever`:
    /// the near leaves' motion bound (translation plus the turn times their arm about its
    /// axis), or the whole tool's less [`Tuning::lever_margin_mm`] where that is larger (every other
    /// leaf was that much farther from the objects at the centre).
    pub(super) fn lever_bound(&self, lever: &Lever, region: &Region, q: &Pose) -> f64 {
        let (r_a, r_b) = (region.center.rotation_matrix(), q.rotation_matrix());
        let dt = (q.translation() - region.center.translation()).norm();
        let near = lever.near.turn_bound(&r_a, &r_b);
        let all = dt + self.turn_bound(&r_a, &r_b);
        (dt + near).max(all - self.params.tuning.lever_margin_mm)
    }

    /// The motion bound (mm) of any tool leaf centre between `a` and `b`: the translation
    /// plus the turn's angle times the centres' arm about its axis
    /// ([`GodObject::turn_bound`]; at most `angle(R_b R_a^T) · reach`).
    pub(super) fn motion_bound(&self, a: &Pose, b: &Pose) -> f64 {
        let dt = (b.translation() - a.translation()).norm();
        dt + self.turn_bound(&a.rotation_matrix(), &b.rotation_matrix())
    }
}

/// True when two pairs of the same tool leaf stand for the same face (normals and offsets
/// equal to 1e-9: one plane met through different object leaves).
fn same_face(a: &LeafPair, b: &LeafPair) -> bool {
    match (a.on_face, b.on_face, &a.face, &b.face) {
        (true, true, Some(f), Some(g)) => {
            a.tool_slot == b.tool_slot && a.object == b.object && f.coincides(g)
        }
        _ => false,
    }
}

/// Distance (mm) of the point `p` from the segment from the origin to `path`.
pub(super) fn segment_distance(p: &Vector3<f64>, path: &Vector3<f64>) -> f64 {
    (p - path * segment_share(p, path)).norm()
}

/// Where along the segment from the origin to `path` (0 to 1) the point nearest `p` lies; 0
/// for an empty segment.
pub(super) fn segment_share(p: &Vector3<f64>, path: &Vector3<f64>) -> f64 {
    let len2 = path.norm_squared();
    if len2 > 0.0 {
        (p.dot(path) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// Keeps leaf pair `p` in `pairs` (counted in `dropped` past its capacity). A tool leaf above a
/// face meets it through every object leaf on it and the rows would be the same: one is kept
/// per tool leaf and face (the smallest gap, should the offsets differ by rounding), `seen`
/// marking, per tool slot, the pair kept in this detection (`stamp`).
fn keep_pair(
    p: &LeafPair,
    pairs: &mut Vec<LeafPair>,
    dropped: &mut usize,
    seen: &mut [(u32, u32)],
    stamp: u32,
) {
    if p.stands_for_face() {
        if let Some(mark) = seen.get_mut(p.tool_slot as usize) {
            if mark.0 == stamp {
                if let Some(kept) = pairs.get_mut(mark.1 as usize) {
                    if same_face(kept, p) {
                        if p.gap < kept.gap {
                            *kept = *p;
                        }
                        return;
                    }
                }
            }
            if pairs.len() < pairs.capacity() {
                *mark = (stamp, pairs.len() as u32);
            }
        }
    }
    if pairs.len() < pairs.capacity() {
        pairs.push(*p);
    } else {
        *dropped += 1;
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use spheretree::Sphere;

    /// A shaft-like tool (leaf centres on a cylinder of radius 12 mm, 0–50 mm along z) far
    /// from one object sphere.
    pub(in crate::step) fn shaft() -> GodObject {
        let mut tool = SphereTree::new_unused(2, 8).unwrap();
        for k in 0..8 {
            let a = std::f64::consts::FRAC_PI_4 * k as f64;
            let z = 50.0 * (k % 4) as f64 / 3.0;
            tool.spheres_mut()[1 + k] = Sphere::new([12.0 * a.cos(), 12.0 * a.sin(), z], 1.0);
        }
        tool.spheres_mut()[0] = Sphere::new([0.0, 0.0, 25.0], 40.0);
        let mut object = SphereTree::new_unused(1, 8).unwrap();
        object.spheres_mut()[0] = Sphere::new([500.0, 0.0, 0.0], 1.0);
        GodObject::new(
            &tool,
            &[(object, Pose::identity())],
            EngineConfig::default(),
        )
        .unwrap()
    }

    /// A tool sliding along z at 0.04 mm per frame through two free-space proofs along its
    /// way, the second starting where the first runs out: the proofs serve it until it leaves
    /// the second, and a finished probe waits rather than replace either.
    #[test]
    fn free_space_proofs_hand_the_tool_over_along_its_way() {
        let mut g = shaft();
        let step = 0.04;
        g.run.motion.last_step = [0.0, 0.0, step];
        g.run.motion.last_motion = step;
        let at = |z: f64| Pose::from_array([0.0, 0.0, z, 0.0, 0.0, 0.0]);
        let proof = |z: f64, length: f64| FreeProof {
            center: at(z),
            path: Vector3::new(0.0, 0.0, length),
            radius: 0.3,
        };
        let used = 0.1;
        // The tool at z = 0 in a proof along 0..1 mm (it leaves it near z = 1.2: 30 frames),
        // the next along 1.1..5.1 mm (to z = 5.3: 132 frames in all).
        g.run.proofs.free = [proof(0.0, 1.0), proof(1.1, 4.0)];
        let q = at(0.0);
        let direct = g.frames_in(&g.run.proofs.free[0], &q, used);
        assert!((direct - 30.0).abs() < 0.01, "{direct}");
        // (Before the handover was counted, the horizon was the first proof's 30 frames
        // only, and probes ahead were sized to finish in them.)
        let horizon = g.proof_horizon(&q, used);
        assert!((horizon - 132.0).abs() < 1.01, "{horizon}");
        // A third proof takes neither place while the tool needs both.
        assert!(!g.proof_slot_free(&q, used));
        // Past the first, it takes the first's place.
        let q = at(1.5);
        assert_eq!(g.frames_in(&g.run.proofs.free[0], &q, used), 0.0);
        assert!(g.proof_slot_free(&q, used));
        g.add_free_proof(at(5.2), Vector3::new(0.0, 0.0, 4.0), 0.3, &q, used);
        assert_eq!(g.run.proofs.free[0].center.q[2], 5.2);
        assert_eq!(g.run.proofs.free[1].center.q[2], 1.1);
        // A proof the tool will never enter serves it no frame.
        g.run.proofs.free[0] = proof(-3.0, 1.0);
        assert_eq!(g.proof_reach(&q, used)[0], 0.0);
    }

    /// A tool turning about its axis (no translation) through two free-space proofs, the
    /// second centred where the turn takes it as the first runs out: the schedule counts the
    /// handover (when it continued the translation alone, the second proof served no frame
    /// and probes ahead were sized to finish within the first).
    #[test]
    fn a_turning_tool_is_handed_over_to_the_proof_ahead_of_its_turn() {
        let mut g = shaft();
        let turn = 0.001; // rad per frame: 0.012 mm at the leaves' 12 mm arm
        g.run.motion.last_turn = [0.0, 0.0, turn];
        g.run.motion.last_motion = turn * 12.0;
        let at = |a: f64| Pose::from_array([0.0, 0.0, 0.0, 0.0, 0.0, a]);
        let proof = |a: f64| FreeProof {
            center: at(a),
            path: Vector3::zeros(),
            radius: 0.3,
        };
        let used = 0.06;
        // The first proof serves (0.3 - 0.06) / 0.012 = 20 frames; the second is centred 25
        // frames on.
        g.run.proofs.free = [proof(0.0), proof(25.0 * turn)];
        let q = at(0.0);
        let direct = g.frames_in(&g.run.proofs.free[0], &q, used);
        assert!((direct - 20.0).abs() < 0.01, "{direct}");
        assert_eq!(g.frames_in(&g.run.proofs.free[1], &q, used), 0.0);
        let horizon = g.proof_horizon(&q, used);
        assert!(
            horizon > 30.0,
            "the turn's handover is not counted: {horizon}"
        );
        // The pose ahead is the turn continued (and the step, none here).
        let ahead = g.pose_ahead(&q, 25.0);
        assert!((ahead.q[5] - 25.0 * turn).abs() < 1e-12);
        assert_eq!(ahead.translation(), q.translation());
        // A non-finite guess keeps the pose.
        g.run.motion.last_turn = [f64::NAN, 0.0, 0.0];
        assert_eq!(g.pose_ahead(&q, 3.0), q);
    }

    /// A ring of eight leaves (radius 1 mm, 12 mm from the tool's axis) with one object
    /// sphere `gap` mm beyond the leaf at +x; probes pay (a region's traversal is taken to
    /// cost ten slices).
    fn ring_near_object(gap: f64) -> GodObject {
        let mut tool = SphereTree::new_unused(2, 8).unwrap();
        for k in 0..8 {
            let a = std::f64::consts::FRAC_PI_4 * k as f64;
            tool.spheres_mut()[1 + k] = Sphere::new([12.0 * a.cos(), 12.0 * a.sin(), 0.0], 1.0);
        }
        tool.spheres_mut()[0] = Sphere::new([0.0, 0.0, 0.0], 14.0);
        let mut object = SphereTree::new_unused(1, 8).unwrap();
        object.spheres_mut()[0] = Sphere::new([14.0 + gap, 0.0, 0.0], 1.0);
        let mut g = GodObject::new(
            &tool,
            &[(object, Pose::identity())],
            EngineConfig::default(),
        )
        .unwrap();
        g.run.proofs.probe_splits = 10 * Tuning::DEFAULT.probe_slice_splits;
        g
    }

    /// A tool in free space inside a neighbour list: the list lists its pairs and proves
    /// free space as far as the traversal would (to the nearest pair beyond the margin), for
    /// a filter instead of a traversal.
    #[test]
    fn a_neighbour_list_proves_free_space_as_far_as_the_traversal() {
        let mut g = ring_near_object(0.2);
        // 0.05 mm away from the object: 0.25 mm from it.
        let q = Pose::from_array([-0.05, 0.0, 0.0, 0.0, 0.0, 0.0]);
        let (margin, proof) = (0.05, 0.3);
        let (gap, traversed) = g
            .detect_proving(&q, None, margin, proof, None, None)
            .unwrap();
        assert!(g.detector.pairs.is_empty() && gap.is_infinite());
        assert!((traversed - 0.25).abs() < 1e-9, "{traversed}");
        assert_eq!(g.region_counts(), (0, 1));
        g.ahead
            .neighbours
            .start(&g.bodies.tool, &Pose::identity(), 0.5)
            .unwrap();
        while g.ahead.neighbours.status() == ListStatus::Building {
            g.ahead
                .neighbours
                .advance(&g.bodies.tool, &g.bodies.objects, 1 << 20, None);
        }
        assert_eq!(g.ahead.neighbours.status(), ListStatus::Ready);
        let (gap, listed) = g
            .detect_proving(&q, None, margin, proof, None, None)
            .unwrap();
        assert!(g.detector.pairs.is_empty() && gap.is_infinite());
        assert_eq!(listed, traversed);
        assert_eq!(g.region_counts(), (1, 1));
        // Where the list reaches less far than the proof margin, it proves as far as it
        // reaches (0.5 less the 0.4 mm moved).
        let far = Pose::from_array([-0.4, 0.0, 0.0, 0.0, 0.0, 0.0]);
        let (_, short) = g
            .detect_proving(&far, None, margin, proof, None, None)
            .unwrap();
        assert!((short - 0.1).abs() < 1e-9, "{short}");
        assert_eq!(g.region_counts(), (2, 1));
    }

    /// A neighbour list that answered less than [`Tuning::list_min_yield`] times its build's work
    /// brings the yield below it when the next list replaces it (no list is then built on the
    /// frame's own thread); frames with no list building let the yield recover, up to the
    /// first list's, and a list that answered well brings it back at once.
    #[test]
    fn lists_that_answered_little_stop_the_next_until_the_yield_recovers() {
        let mut g = ring_near_object(0.2);
        let ready_next = |g: &mut GodObject| {
            g.ahead
                .next_neighbours
                .start(&g.bodies.tool, &Pose::identity(), 0.5)
                .unwrap();
            while g.ahead.next_neighbours.status() == ListStatus::Building {
                let (tool, objects) = (&g.bodies.tool, &g.bodies.objects);
                g.ahead
                    .next_neighbours
                    .advance(tool, objects, 1 << 20, 1 << 20, None, None);
            }
            assert_eq!(g.ahead.next_neighbours.status(), ListStatus::Ready);
        };
        // The first list: nothing in use before it, so no sample.
        assert_eq!(g.run.lists.list_yield, Tuning::DEFAULT.list_first_yield);
        ready_next(&mut g);
        g.take_next_list();
        assert_eq!(g.ahead.neighbours.status(), ListStatus::Ready);
        assert_eq!(g.run.lists.list_yield, Tuning::DEFAULT.list_first_yield);
        // The list in use answered `served` regions of 1 000 node pairs for 8 000 units of
        // work; the next one replaces it, from a yield of 1.
        let replace_after = |g: &mut GodObject, served: u32| {
            g.run.lists.list_served = served;
            g.run.lists.splits_per_region = 1000.0;
            g.run.lists.list_work = 8000;
            g.run.lists.list_yield = 1.0;
            ready_next(g);
            g.take_next_list();
            g.run.lists.list_yield
        };
        // 1 region: 0.125.
        let y = replace_after(&mut g, 1);
        assert!((y - 0.5625).abs() < 1e-12, "{y}");
        assert!(g.run.lists.list_yield < Tuning::DEFAULT.list_min_yield);
        assert_eq!(g.run.lists.list_served, 0);
        // Frames with no list building (free space here: no pair) recover it, 2 % a frame:
        // past the floor after ln(2 / 0.5625) / ln(1.02) = 64.1 frames, capped at the first.
        let q = Pose::identity();
        let deadline = Instant::now() + std::time::Duration::from_secs(1);
        assert!(g.detector.pairs.is_empty());
        for _ in 0..64 {
            g.tend_neighbours(&q, 0.05, deadline);
        }
        assert!(
            g.run.lists.list_yield < Tuning::DEFAULT.list_min_yield,
            "{}",
            g.run.lists.list_yield
        );
        g.tend_neighbours(&q, 0.05, deadline);
        assert!(
            g.run.lists.list_yield >= Tuning::DEFAULT.list_min_yield,
            "{}",
            g.run.lists.list_yield
        );
        for _ in 0..200 {
            g.tend_neighbours(&q, 0.05, deadline);
        }
        assert_eq!(g.run.lists.list_yield, Tuning::DEFAULT.list_first_yield);
        // 40 regions: 5, halfway from 1.
        let y = replace_after(&mut g, 40);
        assert!((y - 3.0).abs() < 1e-12, "{y}");
    }

    /// A tool at rest 0.2 mm from an object, with a proof of 0.05 mm about it: background
    /// probes widen the proof (as far as the object allows) while it rests, so its next
    /// motion does not start on traversals.
    #[test]
    fn a_tool_at_rest_gets_a_wider_proof() {
        let mut g = ring_near_object(0.2);
        let q = Pose::identity();
        let used = 0.02;
        g.run.proofs.free[0] = FreeProof {
            center: q,
            path: Vector3::zeros(),
            radius: 0.05,
        };
        let deadline = Instant::now() + std::time::Duration::from_secs(10);
        for _ in 0..40 {
            g.tend_probe(&q, used, deadline);
        }
        let slack = g.free_slack(&q);
        assert!(slack > 0.1 && slack < 0.2, "{slack}");
    }

    /// A tool held 0.2 mm from an object, turning slowly: a background probe at the full
    /// margin touches and proves nothing; the next ones ask for less until one proves free
    /// space, and its proof then serves the tool (with a fixed margin every probe touched).
    #[test]
    fn a_probe_that_touches_asks_for_less_until_one_proves_free_space() {
        let mut g = ring_near_object(0.2);
        g.run.motion.last_motion = 0.002;
        let q = Pose::identity();
        let used = 0.02;
        let deadline = Instant::now() + std::time::Duration::from_secs(10);
        let mut margins = vec![g.run.proofs.probe_margin];
        for _ in 0..40 {
            g.tend_probe(&q, used, deadline);
            if margins.last() != Some(&g.run.proofs.probe_margin) {
                margins.push(g.run.proofs.probe_margin);
            }
            if g.free_slack(&q) > used {
                break;
            }
        }
        assert!(
            g.free_slack(&q) > used,
            "no proof; margins asked {margins:?}"
        );
        let proven = g
            .run
            .proofs
            .free
            .iter()
            .map(|p| p.radius)
            .fold(0.0, f64::max);
        assert!(
            proven < 0.2 && proven > used,
            "{proven} (margins {margins:?})"
        );
        assert_eq!(margins[0], Tuning::DEFAULT.background_probe_mm);
        assert!(margins.len() >= 3, "{margins:?}");
    }

    /// No leaf centre moves farther than the turn's bound, for random turns from random
    /// rotations; a turn about the shaft's own axis is bounded by its radius, not its reach.
    #[test]
    fn turn_bound_holds_every_leaf_centre_and_is_tight_about_the_axis() {
        let g = shaft();
        let centres: Vec<Vector3<f64>> = g
            .bodies
            .tool
            .leaves()
            .map(|n| Vector3::from(g.bodies.tool.center(n)))
            .collect();
        let mut rng = devkit::Rng::new(5);
        let mut axis = || {
            Vector3::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            )
            .normalize()
        };
        for _ in 0..2000 {
            let r_a = rotation_exp(&(axis() * 2.0));
            let turn = axis() * 1.5;
            let r_b = rotation_exp(&turn) * r_a;
            let bound = g.turn_bound(&r_a, &r_b);
            let moved = centres
                .iter()
                .map(|p| (r_b * p - r_a * p).norm())
                .fold(0.0, f64::max);
            assert!(moved <= bound + 1e-9, "moved {moved} > bound {bound}");
            assert!(bound <= turn.norm() * g.reach() + 1e-9);
        }
        // About the shaft's axis (at identity: world z), by 0.1 rad: on the leaf spheres by its
        // box's corners, 12·sqrt(2) out (`CentreBox::axis_arms` is the mesh mode's).
        let about = g.turn_bound(
            &Matrix3::identity(),
            &rotation_exp(&Vector3::new(0.0, 0.0, 0.1)),
        );
        assert!(
            (about - 0.1 * (12.0f64 * 12.0 * 2.0).sqrt()).abs() < 1e-6,
            "{about}"
        );
        assert!(
            about < 0.35 * 0.1 * g.reach(),
            "{about} vs reach {}",
            g.reach()
        );
    }

    /// A probe of 64 leaves (radius 1 mm): a tip ring of radius 1 mm at z = 0 and 7 rings of
    /// radius 12 mm up to z = 50 mm (a ring per level-1 node), over 6 object spheres 0.05 mm
    /// under its tip, with one object sphere 0.15 mm beside the tip and one 1.5 mm beside the
    /// far end.
    fn probe_over_a_plate() -> GodObject {
        let mut tool = SphereTree::new_unused(3, 8).unwrap();
        tool.spheres_mut()[0] = Sphere::new([0.0, 0.0, 25.0], 60.0);
        for ring in 0..8 {
            let (z, radius) = (50.0 * ring as f64 / 7.0, if ring == 0 { 1.0 } else { 12.0 });
            tool.spheres_mut()[1 + ring] = Sphere::new([0.0, 0.0, z], radius + 1.5);
            for k in 0..8 {
                let a = std::f64::consts::FRAC_PI_4 * k as f64;
                tool.spheres_mut()[9 + 8 * ring + k] =
                    Sphere::new([radius * a.cos(), radius * a.sin(), z], 1.0);
            }
        }
        let mut object = SphereTree::new_unused(2, 8).unwrap();
        object.spheres_mut()[0] = Sphere::new([0.0, 0.0, 25.0], 60.0);
        for k in 0..6 {
            let a = std::f64::consts::FRAC_PI_4 * k as f64;
            object.spheres_mut()[1 + k] = Sphere::new([a.cos(), a.sin(), -2.05], 1.0);
        }
        object.spheres_mut()[7] = Sphere::new([0.0, 3.15, 0.0], 1.0);
        object.spheres_mut()[8] = Sphere::new([15.5, 0.0, 50.0], 1.0);
        GodObject::new(
            &tool,
            &[(object, Pose::identity())],
            EngineConfig::default(),
        )
        .unwrap()
    }

    /// A ball's own pairs serve a region re-centred at a pose `q` (`GodObject::step`): every
    /// pair within `m - b(c, q)` of touching at `q` (`b` the motion bound) was listed at `c`
    /// within `m`, for spins about the probe's axis, tilts and slides; a bound that left out
    /// the turn would take pairs the ball does not hold.
    #[test]
    fn a_balls_own_pairs_hold_every_pair_of_a_ball_recentred_within_them() {
        let mut g = probe_over_a_plate();
        let (c, m) = (Pose::identity(), 0.3);
        g.detect_proving(&c, None, m, 0.0, None, None).unwrap();
        assert_eq!(g.run.regions.pairs_question, Some((c, m)));
        let held: std::collections::HashSet<(u32, u32, u32)> = g
            .detector
            .pairs
            .iter()
            .map(|p| (p.object, p.tool_slot, p.object_slot))
            .collect();
        let mut ws = CollideWorkspace::for_trees(&g.bodies.tool, &g.bodies.objects);
        let mut unheld_within = |g: &GodObject, q: &Pose, margin: f64| {
            let (mut pairs, mut unheld) = (0, 0);
            collide::overlap_shared(
                &g.bodies.tool,
                q,
                None,
                &g.bodies.objects,
                margin,
                None,
                &mut ws,
                None,
                None,
                |p| {
                    pairs += 1;
                    unheld += usize::from(!held.contains(&(p.object, p.tool_slot, p.object_slot)));
                },
            )
            .unwrap();
            (pairs, unheld)
        };
        let mut rng = devkit::Rng::new(3);
        let (mut checked, mut with_pairs, mut wider_than_reach, mut turn_matters) = (0, 0, 0, 0);
        for i in 0..4000 {
            let mut r = |a: f64| rng.range(-a, a);
            // Spins about the axis, slides with small turns, mixed turns, and tilts that swing
            // the far end (1.5 mm from an object sphere) toward it.
            let (w, t) = match i % 4 {
                0 => (Vector3::new(0.0, 0.0, r(0.02)), Vector3::zeros()),
                1 => (
                    Vector3::new(r(0.002), r(0.002), r(0.002)),
                    Vector3::new(r(0.1), r(0.1), r(0.1)),
                ),
                2 => (Vector3::new(r(0.004), r(0.004), r(0.01)), Vector3::zeros()),
                _ => (
                    Vector3::new(r(0.002), 0.03 + r(0.006), r(0.002)),
                    Vector3::zeros(),
                ),
            };
            let q = Pose::from_translation_rotation(&t, &rotation_exp(&w));
            // A bound that left out the turn would take pairs the ball does not hold.
            turn_matters += usize::from(unheld_within(&g, &q, m - t.norm()).1 > 0);
            let room = m - g.motion_bound(&c, &q);
            if room <= 0.0 {
                continue;
            }
            let (pairs, unheld) = unheld_within(&g, &q, room);
            assert_eq!(unheld, 0, "pose {i}: a pair within {room} mm not held");
            checked += 1;
            with_pairs += usize::from(pairs > 0);
            wider_than_reach += usize::from(room > m - (t.norm() + w.norm() * g.reach()) + 0.05);
        }
        assert!(
            checked > 2000 && with_pairs > 1000,
            "{checked} checked, {with_pairs} with pairs"
        );
        assert!(
            wider_than_reach > 500,
            "{wider_than_reach} re-centred wider than the reach allows"
        );
        assert!(
            turn_matters > 100,
            "{turn_matters} poses where the turn matters"
        );
    }

    /// A ball region with the near part of the tool keeps its promise: at every pose it admits,
    /// every leaf pair that overlaps was within the region's margin at its centre. A turn
    /// about the contact is admitted beyond the whole tool's bound; a tilt that brings the far
    /// end (1.5 mm from an object) into contact is not.
    #[test]
    fn a_region_with_a_lever_admits_no_pose_where_an_unlisted_pair_overlaps() {
        let mut g = probe_over_a_plate();
        let (width, skin) = (0.1, 0.02);
        let lever = g
            .lever_at(&Pose::identity(), width + skin)
            .expect("a near part");
        // The tip alone is near: its box (4 mm square) reaches 2.9 mm from the origin.
        assert!(
            lever.reach < 0.1 * g.reach(),
            "{} of {}",
            lever.reach,
            g.reach()
        );
        let region = Region {
            center: Pose::identity(),
            sweep: None,
            length: 0.0,
            width,
            slab: None,
            lever: Some(lever),
        };
        let tool: Vec<(Vector3<f64>, f64)> = g
            .bodies
            .tool
            .leaves()
            .map(|n| {
                (
                    Vector3::from(g.bodies.tool.center(n)),
                    g.bodies.tool.radius(n),
                )
            })
            .collect();
        let object: Vec<(Vector3<f64>, f64)> = g.bodies.objects[0]
            .leaves()
            .map(|n| {
                (
                    Vector3::from(g.bodies.objects[0].center(n)),
                    g.bodies.objects[0].radius(n),
                )
            })
            .collect();
        let gap = |q: &Pose, (p, r): &(Vector3<f64>, f64), (o, s): &(Vector3<f64>, f64)| {
            (q.rotation_matrix() * p + q.translation() - o).norm() - r - s
        };
        let mut rng = devkit::Rng::new(11);
        let (mut beyond_reach, mut unlisted_caught) = (0, 0);
        for i in 0..20_000 {
            // Tilts that swing the far end toward its neighbour, spins about the axis, small
            // translations (toward the sphere beside the tip), and all of them mixed.
            let mut r = |a: f64| rng.range(-a, a);
            let (w, t) = match i % 4 {
                0 => (
                    Vector3::new(r(0.005), 0.03 + r(0.03), r(0.005)),
                    Vector3::zeros(),
                ),
                1 => (Vector3::new(r(0.002), r(0.002), r(0.05)), Vector3::zeros()),
                2 => (
                    Vector3::new(r(0.01), r(0.01), r(0.01)),
                    Vector3::new(r(0.05), 0.1 + r(0.1), r(0.05)),
                ),
                _ => (
                    Vector3::new(r(0.06), r(0.06), r(0.05)),
                    Vector3::new(r(0.1), r(0.1), r(0.1)),
                ),
            };
            let q = Pose::from_translation_rotation(&t, &rotation_exp(&w));
            let admitted = g.lever_bound(&lever, &region, &q) <= width + skin;
            let unlisted_overlap = tool.iter().any(|a| {
                object
                    .iter()
                    .any(|b| gap(&q, a, b) < 0.0 && gap(&Pose::identity(), a, b) > width + skin)
            });
            if admitted {
                assert!(
                    !unlisted_overlap,
                    "pose {i} admitted with an unlisted pair overlapping"
                );
                if g.motion_bound(&Pose::identity(), &q) > width + skin {
                    beyond_reach += 1;
                }
            } else if unlisted_overlap {
                unlisted_caught += 1;
            }
        }
        assert!(
            beyond_reach > 100,
            "few turns admitted beyond the reach: {beyond_reach}"
        );
        assert!(
            unlisted_caught > 10,
            "few unlisted contacts tried: {unlisted_caught}"
        );
    }
}
