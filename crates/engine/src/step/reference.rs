//! The reference step: the frame step with none of its heuristics, the yardstick the shipped
//! step is tested against.

use super::*;

impl GodObject {
    /// One frame of the **reference step** for the device pose `q_h`: each pass detects one
    /// ball region about its linearisation pose, as wide as the way to the hand (up to
    /// `max_margin_mm`; an axis-aligned trust box when capped), by a full traversal; solves the
    /// QP from a cold start; verifies the answer inside its region and its exact gaps; and
    /// re-linearises until the optimum or `1 + relinearize` passes. No region is reused, no
    /// neighbour list, free-space proof or probe is kept, no deadline stops a traversal or a
    /// solve, and friction is not applied. It answers the question [`GodObject::step`] answers
    /// (the constrained optimum nearest the hand from the last `q_g`), slowly and plainly:
    /// tests compare the two. It forgets any region the shipped step cached, so the two may be
    /// interleaved on one god-object.
    ///
    /// Allocation-free; not bounded in time (a test and bench tool, not for a device loop).
    pub fn reference_step(&mut self, q_h: &Pose) -> FrameOutput {
        let t_start = Instant::now();
        let mut out = FrameOutput {
            q_h: q_h.to_array(),
            ..FrameOutput::default()
        };
        if !self.run.motion.started {
            self.run.motion.q_g = *q_h;
            self.run.motion.started = true;
        }
        if !q_h.is_finite() || q_h.q.iter().any(|v| v.abs() > 1e6) {
            return self.keep_last_safe(out, q_h, t_start);
        }
        let p = self.params;
        let (skin, cap, tol) = (
            p.skin_mm.max(0.0),
            p.max_margin_mm.max(1e-3),
            p.penetration_tol_mm,
        );
        self.run.regions.cached = None;
        self.run.solve.warm_len = 0;
        let (mut q_lin, mut allow) = (self.run.motion.q_g, cap);
        let (mut q_safe, mut pen_safe) = (self.run.motion.q_g, self.run.motion.pen_g);
        let mut last_answer = None;
        let (mut reached, mut overflowed) = (false, false);
        for pass in 0..p.relinearize.saturating_add(1) {
            out.passes = pass + 1;
            let (need_t, need_r) = self.way_to(&q_lin, q_h);
            let need = need_t + need_r;
            let allowed = need.min(allow);
            if self.detect(&q_lin, allowed + skin).is_err() {
                return self.keep_last_safe(out, q_h, t_start);
            }
            if self.run.regions.dropped == 0 {
                self.narrow_phase(&q_lin, allowed + skin);
            }
            if self.run.regions.dropped > 0 {
                // More leaf or triangle pairs than the storage holds: a smaller ball (the list
                // must be whole).
                overflowed = true;
                allow = 0.25 * allowed;
                if allow < MIN_OVERFLOW_ALLOW_MM {
                    break;
                }
                continue;
            }
            let n_pairs = self.listed_rows();
            if out.passes == 1 {
                out.pairs = n_pairs as u32;
                out.margin_mm = allowed + skin;
            }
            let capped = need > allowed;
            if n_pairs == 0 && !capped {
                (q_safe, pen_safe, out.contacts, reached) = (*q_h, 0.0, 0, true);
                break;
            }
            let Some(lin) = self.linearization(&q_lin, q_h) else {
                return self.keep_last_safe(out, q_h, t_start);
            };
            let trust = capped.then(|| self.trust_box(allowed, need_t, need_r, self.bodies.reach));
            let centre = lin.variable(&q_lin);
            let n = self.fill_rows(&lin, trust.map(|t| (t, centre, centre)));
            let Some((dq, iters, status, viol)) = self.solve(n, n_pairs, &lin.delta()) else {
                return self.keep_last_safe(out, q_h, t_start);
            };
            out.iterations += iters;
            out.qp_violation = viol;
            out.rows = out.rows.max(n as u32);
            let q_new = lin.configuration(&dq);
            if matches!(status, Status::Infeasible | Status::MaxIterations) || !q_new.is_finite() {
                return self.keep_last_safe(out, q_h, t_start);
            }
            if status != Status::Solved && out.status == FrameStatus::Ok {
                out.status = FrameStatus::Inexact;
            }
            let moved = self.motion_bound(&q_lin, &q_new);
            if moved > allowed + skin {
                // Left its region (pairs may be missing on the way): detect again, wider.
                allow = (1.25 * moved).min(cap);
                continue;
            }
            let mesh = self.bodies.meshes.is_some();
            let (pen, slack, touching) = if mesh {
                self.mesh_gaps_at(&q_lin, &q_new, &dq, n_pairs)
            } else {
                self.gaps_at(&q_new, &dq, n_pairs)
            };
            if mesh && pen > tol {
                // Triangles meet at the answer: on from the last free pose on the way.
                let Some((q_back, _)) = self.last_free_on_the_way(&lin, &dq) else {
                    break;
                };
                (q_safe, pen_safe, q_lin, allow) = (q_back, 0.0, q_back, cap);
                last_answer = Some((q_back, 0.0));
                continue;
            }
            last_answer = Some((q_new, pen));
            if pen <= tol {
                (q_safe, pen_safe, out.contacts) = (q_new, pen, touching);
            }
            let binds = trust.is_some_and(|t| self.trust_binds(t, n_pairs, n, &dq));
            if pen <= tol && slack <= CONVERGED_MM && !binds {
                reached = true;
                break;
            }
            (q_lin, allow) = (q_new, cap);
        }
        if !reached {
            out.status = match (p.solver.is_exact(), last_answer) {
                (false, Some((q, pen))) if !overflowed => {
                    (q_safe, pen_safe) = (q, pen);
                    FrameStatus::Inexact
                }
                _ if overflowed => FrameStatus::PairOverflow,
                _ => FrameStatus::Lagging,
            };
        }
        self.end_reference_frame(out, q_h, (q_safe, pen_safe), t_start)
    }

    /// Ends a reference frame at the pose `safe` (its overlap, mm): the god-object moves there
    /// and the spring to the hand `q_h` is the wrench.
    fn end_reference_frame(
        &mut self,
        mut out: FrameOutput,
        q_h: &Pose,
        (q_safe, pen_safe): (Pose, f64),
        t_start: Instant,
    ) -> FrameOutput {
        let p = self.params;
        self.run.regions.cached = None;
        self.run.motion.q_g = q_safe;
        self.run.motion.pen_g = pen_safe;
        self.run.motion.contacts_g = out.contacts;
        out.penetration_mm = pen_safe;
        out.q_g = q_safe.to_array();
        out.wrench = spring_wrench(&p.g(), p.rotation, &q_safe, q_h);
        out.raw_wrench = out.wrench;
        out.total_us = t_start.elapsed().as_secs_f64() * 1e6;
        out
    }
}
