//! Detect: the regions of a frame (a ball about a pose, or a path along the predicted
//! motion) and their leaf pairs, the prediction, the free-space proof and its background probe.

use super::*;

impl GodObject {
    /// Collects pairs at `q` within `margin` into `self.pairs` (at most `max_pairs`; the rest
    /// are counted in `self.dropped`); returns the smallest gap seen (mm, +inf if none).
    pub(super) fn detect(&mut self, q: &Pose, margin: f64) -> Result<f64, collide::CollideError> {
        self.detect_along(q, None, margin, None)
    }

    /// [`GodObject::detect`], or with a sweep for a path region: the pairs that come within
    /// `margin` (mm) of touching along it from `q`. With a `deadline`, a traversal still
    /// running then stops and `self.interrupted` says so (the list is not complete).
    pub(super) fn detect_along(
        &mut self,
        q: &Pose,
        sweep: Option<&Sweep>,
        margin: f64,
        deadline: Option<Instant>,
    ) -> Result<f64, collide::CollideError> {
        self.cached = None;
        self.pairs.clear();
        self.dropped = 0;
        self.interrupted = false;
        let pairs = &mut self.pairs;
        let dropped = &mut self.dropped;
        let mut min_gap = f64::INFINITY;
        let collect = |p: &LeafPair| {
            min_gap = min_gap.min(p.gap);
            if pairs.len() < pairs.capacity() {
                pairs.push(*p);
            } else {
                *dropped += 1;
            }
        };
        let t = overlap_until(
            &self.tool,
            q,
            sweep,
            &self.objects,
            margin,
            &mut self.ws,
            collect,
            || deadline.is_none_or(|d| Instant::now() < d),
        )?;
        self.interrupted = !t.complete;
        Ok(min_gap)
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
        collide::any_pair_within_until(&self.tool, q, &self.objects, margin, &mut self.ws, || {
            deadline.is_none_or(|d| Instant::now() < d)
        })
        .map(|a| a.unwrap_or(true))
    }

    /// Where this frame's answer is expected, as a motion from `q_lin`: the hand keeps last
    /// frame's offset from the graphic tool (`hand_offset`), so the tool moves as the hand
    /// did. `None` when that motion is shorter than [`MIN_SWEEP_MM`]; scaled down to `cap` mm.
    /// Returns the sweep and its largest sphere motion (mm).
    pub(super) fn predicted_sweep(
        &self,
        q_lin: &Pose,
        q_h: &Pose,
        cap: f64,
    ) -> Option<(Sweep, f64)> {
        let q_pred = self.predicted_pose(q_h);
        let v = q_pred.translation() - q_lin.translation();
        let w = rotation_log(&(q_pred.rotation_matrix() * q_lin.rotation_matrix().transpose()));
        let length = v.norm() + w.norm() * self.reach;
        if length.is_nan() || length < MIN_SWEEP_MM {
            return None;
        }
        // At least PATH_MIN_MM long, so a slow hand's next frames reuse the region.
        let scale = (PATH_MIN_MM / length).max(1.0).min(cap / length);
        let sweep = Sweep {
            translation: (v * scale).into(),
            rotation: (w * scale).into(),
        };
        Some((sweep, length * scale))
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
            return self.motion_bound(&region.center, q);
        }
        let base = lin.variable(&region.center);
        let end = lin.variable(&region.end());
        let reach2 = self.reach.max(1e-9).powi(2);
        let (mut along, mut len2) = (0.0, 0.0);
        for k in 0..6 {
            let d = (end[k] - base[k]) * if k < 3 { 1.0 } else { reach2 };
            along += (dq[k] - base[k]) * d;
            len2 += (end[k] - base[k]) * d;
        }
        let s = if len2 > 0.0 {
            (along / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let on_path = lin.configuration(&std::array::from_fn(|k| base[k] + s * (end[k] - base[k])));
        self.motion_bound(&on_path, q)
    }

    /// Width (mm) of a path region: twice the recent prediction error, within bounds.
    pub(super) fn path_width(&self) -> f64 {
        (2.0 * self.prediction_error).clamp(PATH_WIDTH_MIN_MM, PATH_WIDTH_MAX_MM)
    }

    /// Where the graphic tool is expected for the device pose `q_h`: at last frame's offset
    /// from the hand ([`GodObject::hand_offset`]).
    pub(super) fn predicted_pose(&self, q_h: &Pose) -> Pose {
        let (off_t, off_w) = self.hand_offset;
        Pose::from_translation_rotation(
            &(q_h.translation() - off_t),
            &(rotation_exp(&-off_w) * q_h.rotation_matrix()),
        )
    }

    /// Deepest overlap (mm, >= 0) of the tool at `q`, using `self.pairs` as scratch.
    pub fn penetration_at(&mut self, q: &Pose) -> f64 {
        match self.detect(q, 0.0) {
            Ok(g) if g.is_finite() => (-g).max(0.0),
            Ok(_) => 0.0,
            Err(_) => f64::INFINITY,
        }
    }

    /// Keeps the free-space proof ahead of the tool without a long traversal in any one frame:
    /// when the current proof has only a few frames of slack left (`slack` mm at the tool's
    /// last motion per frame), a probe starts at `q`; each frame runs one slice of it
    /// ([`PROBE_SLICE_SPLITS`] node pairs); a finished free probe becomes the proof if it
    /// leaves more slack at `q` than the current one.
    pub(super) fn tend_probe(&mut self, q: &Pose, slack: f64) {
        // Frames the current proof still lasts at the tool's speed, and the slice that finishes
        // a probe as long as the last one within them.
        let frames_left = slack / self.last_motion.max(1e-4);
        if self.probe.status() == ProbeStatus::Running {
            let left = self.probe_splits.saturating_sub(self.probe.splits()) as f64;
            let slice = (left / (frames_left - 1.0).max(1.0))
                .clamp(PROBE_SLICE_SPLITS as f64, PROBE_MAX_SLICE_SPLITS as f64);
            self.probe
                .advance(&self.tool, &self.objects, slice as usize);
        }
        match self.probe.status() {
            ProbeStatus::Free => {
                self.probe_splits = self.probe.splits();
                let (_, pose, radius) = self.probe.take();
                let new_slack = radius - self.motion_bound(&pose, q);
                let old_slack = self.free_radius - self.motion_bound(&self.free_center, q);
                if new_slack > old_slack {
                    self.free_center = pose;
                    self.free_radius = radius;
                }
            }
            ProbeStatus::Touching => {
                self.probe.take();
            }
            ProbeStatus::Idle => {
                // Where a whole proof costs less than a slice (open space), renewing it when
                // it runs out is cheaper than probing ahead.
                let worth_it = self.probe_splits > PROBE_SLICE_SPLITS;
                let lead = self.probe_splits as f64 / PROBE_SLICE_SPLITS as f64 + 2.0;
                if worth_it && frames_left < lead.max(PROBE_LEAD_FRAMES) {
                    // Probe where the tool will be halfway through the probe's slices (it
                    // keeps moving as it did last frame), so the answer is fresh on arrival.
                    let frames = (self.probe_splits as f64 / PROBE_NOMINAL_SLICE_SPLITS as f64)
                        .clamp(1.0, PROBE_LEAD_FRAMES);
                    let mut ahead = *q;
                    for k in 0..3 {
                        ahead.q[k] += 0.5 * frames * self.last_step[k];
                    }
                    let _ = self.probe.start(&self.tool, &ahead, FREE_PROBE_MM);
                }
            }
            ProbeStatus::Running => {}
        }
    }

    /// The motion bound (mm) of any tool leaf centre between `a` and `b`:
    /// `|t_b - t_a| + angle(R_b R_a^T) · reach`.
    pub(super) fn motion_bound(&self, a: &Pose, b: &Pose) -> f64 {
        let dt = (b.translation() - a.translation()).norm();
        let th = rotation_angle(&b.rotation_matrix(), &a.rotation_matrix());
        dt + th * self.reach
    }
}
