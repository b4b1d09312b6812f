//! The free-space question asked in slices ([`FreeSpaceProbe`]), in two streams that a
//! [`TraversalTeam`]'s helper thread can run side by side.

use crate::team::{self, JobState, TraversalTeam};
use crate::traverse::{clean_margin, descend_as_queried, CollideWorkspace, SPLITS_PER_CHECK};
use crate::{CollideError, LeafPair, PackedTree, Pose, Sweep};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicU8, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

/// Node-pair splits the helper runs on a stream between two releases of its lock, in a
/// background probe (~2–5 µs): the caller's thread can take a stream over at any time.
const BACKGROUND_SLICE_SPLITS: usize = 64;

/// Longest the caller waits for a stream's lock when restarting the probe (the helper holds
/// it for one background slice at a time).
const RESTART_WAIT: Duration = Duration::from_micros(50);

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
    /// Status and splits as of the last slice, readable without the stream's lock.
    published: Arc<Published>,
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
            published: Arc::new(Published::default()),
            ws: CollideWorkspace::for_trees(tool, objects),
            parity,
            object: 0,
            end: usize::MAX,
            resume: false,
            status: ProbeStatus::Idle,
        }
    }

    fn start(&mut self, tool: &PackedTree, pose: &Pose, sweep: Option<&Sweep>) {
        self.ws.start(tool, pose, sweep);
        self.object = 0;
        self.end = usize::MAX;
        self.resume = false;
        self.status = ProbeStatus::Running;
        self.publish();
    }

    /// At most `budget` node-pair splits (plus each object's serial start, at most a few tens),
    /// stopping early past `deadline`; the stream's status (also published).
    pub(crate) fn advance(
        &mut self,
        tool: &PackedTree,
        objects: &[PackedTree],
        margin: f64,
        budget: usize,
        deadline: Option<Instant>,
    ) -> ProbeStatus {
        let status = self.advance_unpublished(tool, objects, margin, budget, deadline);
        self.publish();
        status
    }

    fn publish(&self) {
        let shown = &self.published;
        shown
            .status
            .store(status_code(self.status), Ordering::Release);
        shown.splits.store(self.splits(), Ordering::Release);
    }

    fn advance_unpublished(
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
                let d = team::descend_until_shareable(
                    tool,
                    o,
                    id,
                    &std::cell::Cell::new(margin),
                    ws,
                    &mut stop_at_first,
                );
                if d.count > 0 {
                    self.status = ProbeStatus::Touching;
                    return self.status;
                }
                if d.finished {
                    self.object += 1;
                    continue;
                }
                team::keep_half(&mut ws.stack, self.parity, |_| {});
                self.resume = true;
            }
            loop {
                let slice = budget.min(SPLITS_PER_CHECK);
                if slice == 0 {
                    return self.status;
                }
                let mut left = slice;
                let d = descend_as_queried(
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
    taker.publish();
}

/// What a stream shows without its lock: its status and splits after its last slice, and
/// whether the caller's thread wants it (the helper then leaves it alone).
#[derive(Debug, Default)]
pub(crate) struct Published {
    status: AtomicU8,
    splits: AtomicUsize,
    wanted: AtomicBool,
}

fn status_code(s: ProbeStatus) -> u8 {
    match s {
        ProbeStatus::Idle => 0,
        ProbeStatus::Running => 1,
        ProbeStatus::Free => 2,
        ProbeStatus::Touching => 3,
    }
}

fn status_of(code: u8) -> ProbeStatus {
    match code {
        1 => ProbeStatus::Running,
        2 => ProbeStatus::Free,
        3 => ProbeStatus::Touching,
        _ => ProbeStatus::Idle,
    }
}

/// A probe the helper runs in the background: both streams to their ends, in short slices,
/// while the probe is still the one it was given (its generation unchanged).
pub(crate) struct ProbeJob {
    streams: [Arc<Mutex<ProbeStream>>; 2],
    published: [Arc<Published>; 2],
    generation: Arc<AtomicU64>,
    expected: u64,
    margin: f64,
}

impl ProbeJob {
    /// Runs the streams until both are finished, one finds a pair, the probe is restarted or
    /// `quit` says so.
    pub(crate) fn run(&self, tool: &PackedTree, objects: &[PackedTree], quit: &dyn Fn() -> bool) {
        loop {
            if self.generation.load(Ordering::Acquire) != self.expected || quit() {
                return;
            }
            if let (Ok(mut a), Ok(mut b)) = (self.streams[0].try_lock(), self.streams[1].try_lock())
            {
                rebalance(&mut a, &mut b, tool);
            }
            let mut running = false;
            for (stream, shown) in self.streams.iter().zip(&self.published) {
                if shown.wanted.load(Ordering::Acquire) {
                    // The caller's thread is taking this one over.
                    running |=
                        status_of(shown.status.load(Ordering::Acquire)) == ProbeStatus::Running;
                    continue;
                }
                let Ok(mut s) = stream.try_lock() else {
                    // The caller's thread has it.
                    running = true;
                    continue;
                };
                if s.status == ProbeStatus::Running {
                    s.advance(tool, objects, self.margin, BACKGROUND_SLICE_SPLITS, None);
                }
                match s.status {
                    ProbeStatus::Touching => return,
                    ProbeStatus::Running => running = true,
                    _ => {}
                }
            }
            if !running {
                return;
            }
        }
    }
}

/// The question of [`crate::any_pair_within`] asked in slices: "is any leaf pair within
/// `margin` of touching at this pose?", answered over several calls of at most a given number
/// of node-pair splits each, so a long traversal (a tool inside a tight hole: thousands of
/// node pairs, none touching) can run a slice per haptic frame ahead of the time its answer is
/// needed. The work is split in two streams (the halves of [`crate::overlap_shared`],
/// rebalanced when one finishes), each with its own workspace (the pose stays fixed between
/// slices). With a [`TraversalTeam`] whose helper is free, the helper runs both streams in the
/// background instead ([`FreeSpaceProbe::advance_shared`]).
#[derive(Debug)]
pub struct FreeSpaceProbe {
    streams: [Arc<Mutex<ProbeStream>>; 2],
    published: [Arc<Published>; 2],
    /// Each stream's status and splits as last read (the helper may hold one).
    seen: [(ProbeStatus, usize); 2],
    /// Bumped by every start: a background job of an older probe stops.
    generation: Arc<AtomicU64>,
    /// The background job running this probe on the helper, by number.
    background: Option<u64>,
    pose: Pose,
    /// The probe's straight path (translation, mm; zero for a probe at a pose).
    path: [f64; 3],
    margin: f64,
    status: ProbeStatus,
}

impl std::fmt::Debug for ProbeJob {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ProbeJob").finish_non_exhaustive()
    }
}

impl FreeSpaceProbe {
    /// A probe sized for `tool` against `objects` (allocates; never again for these trees).
    pub fn for_trees(tool: &PackedTree, objects: &[PackedTree]) -> Self {
        let [a, b] = [0, 1].map(|parity| ProbeStream::new(tool, objects, parity));
        let published = [a.published.clone(), b.published.clone()];
        Self {
            streams: [Arc::new(Mutex::new(a)), Arc::new(Mutex::new(b))],
            published,
            seen: [(ProbeStatus::Idle, 0); 2],
            generation: Arc::new(AtomicU64::new(0)),
            background: None,
            pose: Pose::identity(),
            path: [0.0; 3],
            margin: 0.0,
            status: ProbeStatus::Idle,
        }
    }

    /// Starts a probe of `tool` at `pose` with `margin` (mm), dropping any unfinished one.
    /// Errors on a non-finite pose, or when the helper thread holds a stream for longer than a
    /// background slice should take (it was preempted; try again next frame).
    ///
    /// # Real-time
    /// No allocation (after [`FreeSpaceProbe::for_trees`] for these trees); waits at most
    /// ~50 µs for the helper to let go of a stream.
    pub fn start(
        &mut self,
        tool: &PackedTree,
        pose: &Pose,
        margin: f64,
    ) -> Result<(), CollideError> {
        self.start_along(tool, pose, [0.0; 3], margin)
    }

    /// [`FreeSpaceProbe::start`] for the tool sliding (without turning) from `pose` by
    /// `path` (mm, world): a free answer proves that no leaf pair comes within `margin` of
    /// touching at any pose on the way (the swept query of [`crate::overlap_swept`]). A tool
    /// moving steadily stays inside such a proof for many frames: in the spline's hole a 6 mm
    /// path going out takes 1.7 times as long as a probe at a pose and covers 21 times the way
    /// (a pure translation is tested as capsules).
    pub fn start_along(
        &mut self,
        tool: &PackedTree,
        pose: &Pose,
        path: [f64; 3],
        margin: f64,
    ) -> Result<(), CollideError> {
        if !pose.is_finite() || !path.iter().all(|v| v.is_finite()) {
            return Err(CollideError::NonFinitePose);
        }
        // A background job of the last probe stops at its next slice.
        self.generation.fetch_add(1, Ordering::AcqRel);
        self.background = None;
        let until = Instant::now() + RESTART_WAIT;
        let (Some(mut a), Some(mut b)) = (
            lock_by(&self.streams[0], until),
            lock_by(&self.streams[1], until),
        ) else {
            self.status = ProbeStatus::Idle;
            return Err(CollideError::Busy);
        };
        // Sized for these trees by `for_trees`: posing the root allocates nothing.
        if !a.ws.sized_for(tool) {
            return Err(CollideError::InvalidTree(
                "the probe was made for another tool tree".into(),
            ));
        }
        let sweep = Sweep {
            translation: path,
            rotation: [0.0; 3],
        };
        let sweep = (path != [0.0; 3]).then_some(&sweep);
        a.start(tool, pose, sweep);
        b.start(tool, pose, sweep);
        self.seen = [(ProbeStatus::Running, 0); 2];
        self.pose = *pose;
        self.path = path;
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

    /// [`FreeSpaceProbe::advance`], or with `team` the probe handed to its helper thread,
    /// which runs it in the background while it is free (this call then only reads how far
    /// it is). A call whose helper is busy or asleep runs the slice here. `deadline` stops the
    /// slice early.
    ///
    /// # Real-time
    /// As [`FreeSpaceProbe::advance`]; never waits for the helper.
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
        let mut here = true;
        if let Some(team) = team {
            team.keep_awake();
            let js = self.background.and_then(|id| team::job_state(team, id));
            match js {
                Some(JobState::Running) => {
                    let before = self.splits();
                    if self.read() == ProbeStatus::Running && self.splits() == before {
                        // No slice since the last call: the helper is held up (it runs on idle
                        // time only). This call's slice runs here, on a stream it leaves.
                        return self.advance_now(tool, objects, max_splits, deadline);
                    }
                    return self.status;
                }
                // Not claimed since the last call (the helper was held up): taken back, this
                // call runs a slice here and hands it over again.
                Some(JobState::Posted) if team::take_back(team) => self.background = None,
                Some(JobState::Posted) => return self.read(),
                _ => {
                    // A job that ended has left its streams' states published.
                    self.background = None;
                    if self.read() != ProbeStatus::Running {
                        return self.status;
                    }
                    here = false;
                }
            }
        }
        if here {
            self.slice_here(tool, objects, max_splits, deadline);
        }
        if self.status == ProbeStatus::Running {
            if let Some(team) = team {
                let job = ProbeJob {
                    streams: [self.streams[0].clone(), self.streams[1].clone()],
                    published: [self.published[0].clone(), self.published[1].clone()],
                    generation: self.generation.clone(),
                    expected: self.generation.load(Ordering::Acquire),
                    margin: self.margin,
                };
                self.background = team::post_probe_job(team, job);
                if self.background.is_none() && !here {
                    // The helper is busy or asleep: this call's slice runs here.
                    self.slice_here(tool, objects, max_splits, deadline);
                }
            }
        }
        self.status
    }

    /// [`FreeSpaceProbe::advance`] when the answer is needed now: the caller's thread runs
    /// the slice on whichever stream the helper is not holding (the helper, if it runs the
    /// probe in the background, goes on with the other).
    ///
    /// # Real-time
    /// As [`FreeSpaceProbe::advance`]; never waits for the helper.
    pub fn advance_now(
        &mut self,
        tool: &PackedTree,
        objects: &[PackedTree],
        max_splits: usize,
        deadline: Option<Instant>,
    ) -> ProbeStatus {
        if self.status != ProbeStatus::Running {
            return self.status;
        }
        self.read();
        // The first stream still running is taken over (the helper, if it runs the probe,
        // leaves it after its current slice and goes on with the other).
        let Some(k) = (0..2).find(|&k| self.seen[k].0 == ProbeStatus::Running) else {
            return self.combine();
        };
        let shown = &self.published[k];
        shown.wanted.store(true, Ordering::Release);
        let until = deadline.unwrap_or_else(|| Instant::now() + RESTART_WAIT);
        if let Some(mut s) = lock_by(&self.streams[k], until) {
            s.advance(tool, objects, self.margin, max_splits, deadline);
        }
        shown.wanted.store(false, Ordering::Release);
        self.read()
    }

    /// One slice on the caller's thread: rebalanced, half in each running stream (all in the
    /// one still running); a stream the helper holds is skipped.
    fn slice_here(
        &mut self,
        tool: &PackedTree,
        objects: &[PackedTree],
        max_splits: usize,
        deadline: Option<Instant>,
    ) -> ProbeStatus {
        let [a, b] = &self.streams;
        let (mut a, mut b) = (a.try_lock().ok(), b.try_lock().ok());
        if let (Some(a), Some(b)) = (a.as_deref_mut(), b.as_deref_mut()) {
            rebalance(a, b, tool);
        }
        let running = |s: &Option<MutexGuard<'_, ProbeStream>>, seen: (ProbeStatus, usize)| {
            s.as_ref().map_or(seen.0, |s| s.status) == ProbeStatus::Running
        };
        let (ra, rb) = (running(&a, self.seen[0]), running(&b, self.seen[1]));
        let share = if ra && rb { max_splits / 2 } else { max_splits };
        for (k, s) in [&mut a, &mut b].into_iter().enumerate() {
            if let Some(s) = s {
                if s.status == ProbeStatus::Running {
                    let budget = if k == 0 {
                        max_splits - share * usize::from(ra && rb)
                    } else {
                        share
                    };
                    s.advance(tool, objects, self.margin, budget, deadline);
                }
                self.seen[k] = (s.status, s.splits());
            }
        }
        drop((a, b));
        self.combine()
    }

    /// The streams' states as far as they can be read now.
    fn read(&mut self) -> ProbeStatus {
        for (k, shown) in self.published.iter().enumerate() {
            self.seen[k] = (
                status_of(shown.status.load(Ordering::Acquire)),
                shown.splits.load(Ordering::Acquire),
            );
        }
        self.combine()
    }

    fn combine(&mut self) -> ProbeStatus {
        self.status = match (self.seen[0].0, self.seen[1].0) {
            (ProbeStatus::Touching, _) | (_, ProbeStatus::Touching) => ProbeStatus::Touching,
            (ProbeStatus::Free, ProbeStatus::Free) => ProbeStatus::Free,
            _ => ProbeStatus::Running,
        };
        if self.status != ProbeStatus::Running {
            // A background job still on it stops at its next slice.
            self.generation.fetch_add(1, Ordering::AcqRel);
            self.background = None;
        }
        self.status
    }

    /// Node pairs split so far by the current (or last) probe (both streams, as last read).
    pub fn splits(&self) -> usize {
        self.seen[0].1 + self.seen[1].1
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

    /// The straight path (translation, mm, world) of the current (or last) probe from its
    /// pose: zero for a probe at a pose ([`FreeSpaceProbe::start_along`]).
    pub fn path(&self) -> [f64; 3] {
        self.path
    }

    /// Drops an unfinished probe (a background job of it stops at its next slice).
    pub fn cancel(&mut self) {
        self.generation.fetch_add(1, Ordering::AcqRel);
        self.background = None;
        self.status = ProbeStatus::Idle;
    }
}

/// The lock of `m`, trying until `until`.
pub(crate) fn lock_by<T>(m: &Mutex<T>, until: Instant) -> Option<MutexGuard<'_, T>> {
    loop {
        if let Ok(s) = m.try_lock() {
            return Some(s);
        }
        if Instant::now() >= until {
            return None;
        }
        std::hint::spin_loop();
    }
}
