//! The free-space question asked in slices ([`FreeSpaceProbe`]), in two streams that a
//! [`TraversalTeam`]'s helper thread can run side by side.

use crate::team::{self, TraversalTeam, SHARE_MAX_START_SPLITS, SHARE_MIN_PAIRS};
use crate::traverse::{clean_margin, descend_budgeted, CollideWorkspace, SPLITS_PER_CHECK};
use crate::{CollideError, LeafPair, PackedTree, Pose};
use std::sync::{Arc, Mutex};
use std::time::Instant;

/// State of a [`FreeSpaceProbe`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProbeStatus {
    /// No probe started (or the last one was taken).
    Idle,
    /// Started, not finished: call [`FreeSpaceProbe::advance`] again.
    Running,
    /// Finished: no leaf pair within the probe's margin at its pose.
    Free,
    /// Finished: some leaf pair is within the margin.
    Touching,
}

/// One of the probe's two streams: for each object, the same short serial start from the
/// roots as [`crate::overlap_shared`], then every second waiting node pair (`parity` 0: the
/// first, 1: the second) descended in slices.
#[derive(Clone, Debug)]
pub(crate) struct ProbeStream {
    ws: CollideWorkspace,
    parity: usize,
    object: usize,
    /// Objects from `end` on are the other stream's (after a rebalance).
    end: usize,
    resume: bool,
    status: ProbeStatus,
}

impl ProbeStream {
    fn new(tool: &PackedTree, objects: &[PackedTree], parity: usize) -> Self {
        Self {
            ws: CollideWorkspace::for_trees(tool, objects),
            parity,
            object: 0,
            end: usize::MAX,
            resume: false,
            status: ProbeStatus::Idle,
        }
    }

    fn start(&mut self, tool: &PackedTree, pose: &Pose) {
        self.ws.start(tool, pose, None);
        self.object = 0;
        self.end = usize::MAX;
        self.resume = false;
        self.status = ProbeStatus::Running;
    }

    /// At most `budget` node-pair splits (plus each object's serial start, at most a few tens),
    /// stopping early past `deadline`; the stream's status.
    pub(crate) fn advance(
        &mut self,
        tool: &PackedTree,
        objects: &[PackedTree],
        margin: f64,
        mut budget: usize,
        deadline: Option<Instant>,
    ) -> ProbeStatus {
        if self.status != ProbeStatus::Running {
            return self.status;
        }
        let ws = &mut self.ws;
        let mut stop_at_first = |_: &LeafPair| false;
        while let Some(o) = objects.get(self.object).filter(|_| self.object < self.end) {
            let id = self.object as u32;
            ws.reserve(tool, o);
            if !self.resume {
                let mut one = 1;
                let mut d = descend_budgeted::<false, _>(
                    tool,
                    o,
                    id,
                    margin,
                    ws,
                    &mut stop_at_first,
                    false,
                    &mut one,
                );
                let mut splits = 1;
                while !d.finished
                    && ws.stack.len() < SHARE_MIN_PAIRS
                    && splits < SHARE_MAX_START_SPLITS
                {
                    let mut one = 1;
                    d = descend_budgeted::<false, _>(
                        tool,
                        o,
                        id,
                        margin,
                        ws,
                        &mut stop_at_first,
                        true,
                        &mut one,
                    );
                    splits += 1;
                }
                if d.count > 0 {
                    self.status = ProbeStatus::Touching;
                    return self.status;
                }
                if d.finished {
                    self.object += 1;
                    continue;
                }
                let mut k = 0;
                ws.stack.retain(|_| {
                    k += 1;
                    (k - 1) % 2 == self.parity
                });
                self.resume = true;
            }
            loop {
                let slice = budget.min(SPLITS_PER_CHECK);
                if slice == 0 {
                    return self.status;
                }
                let mut left = slice;
                let d = descend_budgeted::<false, _>(
                    tool,
                    o,
                    id,
                    margin,
                    ws,
                    &mut stop_at_first,
                    true,
                    &mut left,
                );
                budget -= slice - left;
                if d.count > 0 {
                    self.status = ProbeStatus::Touching;
                    return self.status;
                }
                if d.finished {
                    break;
                }
                if deadline.is_some_and(|t| Instant::now() >= t) {
                    return self.status;
                }
            }
            self.object += 1;
            self.resume = false;
        }
        self.status = ProbeStatus::Free;
        self.status
    }

    fn splits(&self) -> usize {
        self.ws.stats.node_pairs_split
    }
}

/// When one stream has finished and the other still has node pairs waiting in an object's
/// descent, hands every second one of them to the finished stream (the halves of a partition
/// rarely cost the same). Depends only on the streams' states, so the work done by later
/// calls is the same with or without a helper thread.
fn rebalance(a: &mut ProbeStream, b: &mut ProbeStream, tool: &PackedTree) {
    let (donor, taker) = match (a.status, b.status) {
        (ProbeStatus::Running, ProbeStatus::Free) => (a, b),
        (ProbeStatus::Free, ProbeStatus::Running) => (b, a),
        _ => return,
    };
    if !donor.resume || donor.ws.stack.len() < 2 {
        return;
    }
    taker.ws.stack.clear();
    let mut k = 0;
    let given = &mut taker.ws.stack;
    donor.ws.stack.retain(|&e| {
        k += 1;
        if k % 2 == 0 {
            given.push(e);
        }
        k % 2 == 1
    });
    // The handed node pairs' tool nodes are posed in the donor's workspace only.
    for i in 0..taker.ws.stack.len() {
        let t = taker.ws.stack[i].0 as usize;
        taker.ws.pose_range(tool, t, t + 1);
    }
    taker.object = donor.object;
    taker.end = donor.object + 1;
    taker.resume = true;
    taker.status = ProbeStatus::Running;
}

/// The question of [`crate::any_pair_within`] asked in slices: "is any leaf pair within
/// `margin` of touching at this pose?", answered over several calls of at most a given number
/// of node-pair splits each, so a long traversal (a tool inside a tight hole: thousands of
/// node pairs, none touching) can run a slice per haptic frame ahead of the time its answer is
/// needed. The work is split in two streams (the halves of [`crate::overlap_shared`]), each
/// given half of every slice; with a [`TraversalTeam`] the helper thread runs the second
/// stream's half while the caller runs the first's. Each stream has its own workspace (the
/// pose stays fixed between slices).
#[derive(Debug)]
pub struct FreeSpaceProbe {
    first: ProbeStream,
    second: Arc<Mutex<ProbeStream>>,
    /// The second stream's status and splits as last read (the helper may hold it).
    second_status: ProbeStatus,
    second_splits: usize,
    pose: Pose,
    margin: f64,
    status: ProbeStatus,
}

impl FreeSpaceProbe {
    /// A probe sized for `tool` against `objects` (allocates; never again for these trees).
    pub fn for_trees(tool: &PackedTree, objects: &[PackedTree]) -> Self {
        Self {
            first: ProbeStream::new(tool, objects, 0),
            second: Arc::new(Mutex::new(ProbeStream::new(tool, objects, 1))),
            second_status: ProbeStatus::Idle,
            second_splits: 0,
            pose: Pose::identity(),
            margin: 0.0,
            status: ProbeStatus::Idle,
        }
    }

    /// Starts a probe of `tool` at `pose` with `margin` (mm), dropping any unfinished one.
    /// Errors on a non-finite pose, or while the helper thread still holds the last probe's
    /// second stream (a slice it ran past its deadline; try again next frame).
    ///
    /// # Real-time
    /// No allocation (after [`FreeSpaceProbe::for_trees`] for these trees), constant time.
    pub fn start(
        &mut self,
        tool: &PackedTree,
        pose: &Pose,
        margin: f64,
    ) -> Result<(), CollideError> {
        if !pose.is_finite() {
            return Err(CollideError::NonFinitePose);
        }
        // Sized for these trees by `for_trees`: posing the root allocates nothing.
        if !self.first.ws.sized_for(tool) {
            return Err(CollideError::InvalidTree(
                "the probe was made for another tool tree".into(),
            ));
        }
        let Ok(mut second) = self.second.try_lock() else {
            return Err(CollideError::Busy);
        };
        second.start(tool, pose);
        drop(second);
        self.first.start(tool, pose);
        self.second_status = ProbeStatus::Running;
        self.second_splits = 0;
        self.pose = *pose;
        self.margin = clean_margin(margin);
        self.status = ProbeStatus::Running;
        Ok(())
    }

    /// Runs at most `max_splits` node-pair splits of the started probe (half in each stream);
    /// returns its status. `objects` (and `tool`) must be the trees it was started with.
    ///
    /// # Real-time
    /// No allocation, no panic; at most `max_splits` splits (plus a few tens per object for
    /// each stream's start).
    pub fn advance(
        &mut self,
        tool: &PackedTree,
        objects: &[PackedTree],
        max_splits: usize,
    ) -> ProbeStatus {
        self.advance_shared(tool, objects, max_splits, None, None)
    }

    /// [`FreeSpaceProbe::advance`] with `team`'s helper thread running the second stream's
    /// half meanwhile (when it is free), both stopping early past `deadline`. The answer is the
    /// same as without the helper, after the same calls, unless the helper runs past the
    /// deadline (then its stream catches up in later calls).
    ///
    /// # Real-time
    /// As [`FreeSpaceProbe::advance`]; never waits for the helper past `deadline`.
    pub fn advance_shared(
        &mut self,
        tool: &PackedTree,
        objects: &[PackedTree],
        max_splits: usize,
        team: Option<&TraversalTeam>,
        deadline: Option<Instant>,
    ) -> ProbeStatus {
        if self.status != ProbeStatus::Running {
            return self.status;
        }
        if let Ok(mut second) = self.second.try_lock() {
            rebalance(&mut self.first, &mut second, tool);
            self.second_status = second.status;
        }
        // A stream with nothing left gives its half of the slice to the other.
        let (first_budget, second_budget) = match (self.first.status, self.second_status) {
            (ProbeStatus::Running, ProbeStatus::Running) => {
                (max_splits - max_splits / 2, max_splits / 2)
            }
            (ProbeStatus::Running, _) => (max_splits, 0),
            _ => (0, max_splits),
        };
        let second_running = self.second_status == ProbeStatus::Running;
        if let Some(team) = team {
            team.keep_awake();
        }
        let mut posted = second_running
            && team.is_some_and(|t| {
                team::post_probe(t, &self.second, self.margin, second_budget, deadline)
            });
        let half_start = Instant::now();
        let first = self
            .first
            .advance(tool, objects, self.margin, first_budget, deadline);
        if posted {
            if let Some(team) = team {
                if team::take_back(team) {
                    posted = false;
                } else {
                    // The helper has it: its answer is read from the stream below once done,
                    // within as long again as the first half took (a helper held up is not
                    // waited for: its stream catches up in later calls).
                    let grace = half_start.elapsed().max(team::MIN_GRACE);
                    let until = Instant::now() + grace;
                    let _ = team::wait_done(team, Some(deadline.map_or(until, |d| d.min(until))));
                }
            }
        }
        if let Ok(mut second) = self.second.try_lock() {
            if !posted && second_running && first != ProbeStatus::Touching {
                second.advance(tool, objects, self.margin, second_budget, deadline);
            }
            self.second_status = second.status;
            self.second_splits = second.splits();
        }
        self.status = match (first, self.second_status) {
            (ProbeStatus::Touching, _) | (_, ProbeStatus::Touching) => ProbeStatus::Touching,
            (ProbeStatus::Free, ProbeStatus::Free) => ProbeStatus::Free,
            _ => ProbeStatus::Running,
        };
        self.status
    }

    /// Node pairs split so far by the current (or last) probe (both streams; the second as
    /// last read).
    pub fn splits(&self) -> usize {
        self.first.splits() + self.second_splits
    }

    /// The status, without running anything.
    pub fn status(&self) -> ProbeStatus {
        self.status
    }

    /// Takes a finished answer (the probe becomes idle): the pose and margin (mm) it holds for.
    pub fn take(&mut self) -> (ProbeStatus, Pose, f64) {
        let s = self.status;
        if s != ProbeStatus::Running {
            self.status = ProbeStatus::Idle;
        }
        (s, self.pose, self.margin)
    }

    /// The pose and margin (mm) of the current (or last) probe.
    pub fn question(&self) -> (Pose, f64) {
        (self.pose, self.margin)
    }

    /// Drops an unfinished probe.
    pub fn cancel(&mut self) {
        self.status = ProbeStatus::Idle;
    }
}
