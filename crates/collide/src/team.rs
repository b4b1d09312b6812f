//! Large traversals shared with a second thread.
//!
//! [`overlap_shared`] answers the question of [`crate::overlap_until`] in a fixed order that
//! does not depend on threads: a short serial descent from the roots (until at least
//! [`SHARE_MIN_PAIRS`] node pairs wait on the stack), then every second waiting node pair is set
//! aside as the *second half*; the caller's thread descends the first half, then the second
//! half is descended, and its leaf pairs are reported after the first half's. With a
//! [`TraversalTeam`], the team's helper thread takes the second half while the caller works
//! on the first; without one (or when the helper is asleep or still busy), the caller's thread
//! takes it afterwards itself. Either way the same pairs are reported in the same order, so
//! frames do not depend on whether a helper ran.
//!
//! The helper spins while traversals keep coming (for [`SPIN_WINDOW`] after the last one), so
//! a haptic frame hands it work without a wake-up; idle longer, it parks. A second half it has
//! not claimed by the time the caller is done is taken back, and a helper that has not
//! finished by the caller's deadline leaves the traversal incomplete (the caller's deadline
//! rule then applies, as for any stopped traversal).
//!
//! Measured (docs/design-notes.md §The helper thread): with the helper spinning, the spline's in-hole
//! traversal and its dense alignment contact take 0.46–0.53 of the serial time; with a
//! parked helper (woken per traversal, as a thread pool's sleeping workers are) only
//! traversals over ~150 µs gain, the rest lose the ~30–60 µs wake-up.

use crate::neighbours::ListJob;
use crate::probe::ProbeJob;
use crate::traverse::{
    arc_allowance, clean_margin, descend_as_queried, CollideWorkspace, Descent, FaceSlab, LeafPair,
    SPLITS_PER_CHECK,
};
use crate::{CollideError, PackedTree, Pose, Sweep};
use std::cell::Cell;
use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// Node pairs waiting on the stack before the traversal is split in two halves.
pub const SHARE_MIN_PAIRS: usize = 16;

/// Most node pairs the serial start splits looking for [`SHARE_MIN_PAIRS`] waiting ones.
pub(crate) const SHARE_MAX_START_SPLITS: usize = 64;

/// Shortest time the caller waits for the helper's half after finishing its own, beyond
/// which it descends that half itself (the helper was held up).
pub(crate) const MIN_GRACE: Duration = Duration::from_micros(20);

/// How long the helper keeps spinning after the last traversal handed to the team (a haptic
/// frame comes every millisecond; a tool in contact traverses most frames).
pub const SPIN_WINDOW: Duration = Duration::from_millis(3);

/// How a shared traversal ended ([`overlap_shared`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SharedTraversal {
    /// Leaf pairs found (reported ones plus `unreported`).
    pub pairs: usize,
    /// Leaf pairs the helper found beyond its buffer's capacity ([`TraversalTeam::new`]):
    /// not reported to `visit`, so the list is short by this many (treat as an overflow).
    pub unreported: usize,
    /// False when the deadline stopped it (or the helper did not finish by then): some leaf
    /// pairs may be missing.
    pub complete: bool,
    /// True when the helper descended a second half (false: the caller's thread did all).
    pub helped: bool,
}

// Helper states.
const IDLE: u32 = 0;
const POSTED: u32 = 1;
const CLAIMED: u32 = 2;
const DONE: u32 = 3;
const QUIT: u32 = 4;

/// The second half of one traversal, or a slice of a probe's second stream, as handed to the
/// helper, and what it found.
struct Work {
    /// A probe to run in the background (else a traversal's half).
    probe: Option<ProbeJob>,
    /// A neighbour list to build in the background (else a traversal's half).
    list: Option<ListJob>,
    pose: Pose,
    sweep: Option<Sweep>,
    /// Margin of the descent (mm, allowances included).
    margin: f64,
    /// Slab margins of face pairs ([`FaceSlab`]).
    slab: Option<FaceSlab>,
    object: usize,
    deadline: Option<Instant>,
    entries: Vec<(u32, u32)>,
    ws: CollideWorkspace,
    pairs: Vec<LeafPair>,
    unreported: usize,
    complete: bool,
}

struct Shared {
    state: AtomicU32,
    /// Number of the last job posted (the caller tells its own jobs by it).
    job: AtomicU64,
    /// Nanoseconds since `epoch` until which the helper spins (then parks).
    awake_until_ns: AtomicU64,
    sleeping: AtomicBool,
    epoch: Instant,
    work: Mutex<Work>,
}

impl Shared {
    fn now_ns(&self) -> u64 {
        self.epoch.elapsed().as_nanos() as u64
    }
}

/// A helper thread that takes the second half of large traversals ([`overlap_shared`]). It
/// keeps its own copies of the trees and a pair buffer, sized at creation, so handing it work
/// never allocates. Dropping the team stops and joins the thread.
pub struct TraversalTeam {
    shared: Arc<Shared>,
    handle: Option<JoinHandle<()>>,
}

impl std::fmt::Debug for TraversalTeam {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TraversalTeam").finish_non_exhaustive()
    }
}

impl TraversalTeam {
    /// Starts the helper thread for traversals of `tool` against `objects` (its own copies:
    /// pass the trees every [`overlap_shared`] with this team will use). It keeps at most
    /// `pair_capacity` leaf pairs of a second half; more are counted in
    /// [`SharedTraversal::unreported`]. Errors when the thread cannot be started.
    pub fn new(
        tool: &PackedTree,
        objects: &[PackedTree],
        pair_capacity: usize,
    ) -> std::io::Result<Self> {
        let ws = CollideWorkspace::for_trees(tool, objects);
        let stack_cap = ws.stack.capacity();
        let shared = Arc::new(Shared {
            state: AtomicU32::new(IDLE),
            job: AtomicU64::new(0),
            awake_until_ns: AtomicU64::new(0),
            sleeping: AtomicBool::new(false),
            epoch: Instant::now(),
            work: Mutex::new(Work {
                probe: None,
                list: None,
                pose: Pose::identity(),
                sweep: None,
                margin: 0.0,
                slab: None,
                object: 0,
                deadline: None,
                entries: Vec::with_capacity(stack_cap),
                ws,
                pairs: Vec::with_capacity(pair_capacity),
                unreported: 0,
                complete: true,
            }),
        });
        let (tool, objects) = (tool.clone(), objects.to_vec());
        let inner = shared.clone();
        let handle = std::thread::Builder::new()
            .name("haptic6d-traversal".into())
            .spawn(move || helper_loop(&inner, &tool, &objects))?;
        Ok(Self {
            shared,
            handle: Some(handle),
        })
    }

    /// Keeps the helper spinning for [`SPIN_WINDOW`] from now, waking it if it parked: call it
    /// every frame while work for it may come (the traversals and probes that use the team
    /// call it themselves). Cheap: an atomic store, and a wake-up only after a pause.
    ///
    /// # Real-time
    /// No allocation; at most one `futex` wake.
    pub fn keep_awake(&self) {
        let s = &self.shared;
        s.awake_until_ns.store(
            s.now_ns() + SPIN_WINDOW.as_nanos() as u64,
            Ordering::Release,
        );
        if s.sleeping.load(Ordering::Acquire) {
            if let Some(h) = &self.handle {
                h.thread().unpark();
            }
        }
    }
}

impl Drop for TraversalTeam {
    fn drop(&mut self) {
        self.shared.state.store(QUIT, Ordering::Release);
        if let Some(h) = self.handle.take() {
            h.thread().unpark();
            let _ = h.join();
        }
    }
}

/// Puts the calling thread in Linux's `SCHED_IDLE` class: it runs only on time no other
/// thread wants, so the operating system's own work goes to the helper's core rather than
/// preempting the frame's thread (measured: with a helper spinning at normal priority, frames
/// of the bench's replays were stalled for 2.5–3.2 ms by other tasks). Best effort.
fn run_only_on_idle_time() {
    #[cfg(target_os = "linux")]
    // SAFETY: plain FFI calls on the calling thread with a valid, initialised parameter.
    unsafe {
        let param = libc::sched_param { sched_priority: 0 };
        let _ = libc::pthread_setschedparam(libc::pthread_self(), libc::SCHED_IDLE, &param);
    }
}

fn helper_loop(shared: &Shared, tool: &PackedTree, objects: &[PackedTree]) {
    run_only_on_idle_time();
    loop {
        match shared.state.load(Ordering::Acquire) {
            QUIT => return,
            POSTED => {
                if shared
                    .state
                    .compare_exchange(POSTED, CLAIMED, Ordering::AcqRel, Ordering::Acquire)
                    .is_ok()
                {
                    if let Ok(mut work) = shared.work.lock() {
                        let quit = || shared.state.load(Ordering::Acquire) == QUIT;
                        if let Some(job) = work.probe.take() {
                            job.run(tool, objects, &quit);
                            // Kept (not dropped here): the next post replaces it.
                            work.probe = Some(job);
                        } else if let Some(job) = work.list.take() {
                            job.run(tool, objects, &quit);
                            work.list = Some(job);
                        } else {
                            descend_second_half(&mut work, tool, objects);
                        }
                    }
                    // A failed exchange means QUIT came meanwhile.
                    let _ = shared.state.compare_exchange(
                        CLAIMED,
                        DONE,
                        Ordering::AcqRel,
                        Ordering::Acquire,
                    );
                }
            }
            _ => {
                if shared.now_ns() < shared.awake_until_ns.load(Ordering::Acquire) {
                    std::hint::spin_loop();
                } else {
                    shared.sleeping.store(true, Ordering::Release);
                    // Bounded, so a wake-up lost to a race costs at most this.
                    std::thread::park_timeout(Duration::from_millis(5));
                    shared.sleeping.store(false, Ordering::Release);
                }
            }
        }
    }
}

/// The helper's part: the handed node pairs of one object, to the deadline.
fn descend_second_half(work: &mut Work, tool: &PackedTree, objects: &[PackedTree]) {
    let Work {
        pose,
        sweep,
        margin,
        slab,
        object,
        deadline,
        entries,
        ws,
        pairs,
        unreported,
        complete,
        ..
    } = work;
    pairs.clear();
    *unreported = 0;
    *complete = true;
    let Some(obj) = objects.get(*object) else {
        return;
    };
    ws.reserve(tool, obj);
    ws.start(tool, pose, sweep.as_ref());
    ws.slab = *slab;
    // The handed node pairs' tool nodes are posed in the caller's workspace, not in this one.
    for &(t, _) in entries.iter() {
        ws.pose_range(tool, t as usize, t as usize + 1);
    }
    ws.stack.clear();
    ws.stack.extend_from_slice(entries);
    let mut keep = |p: &LeafPair| {
        if pairs.len() < pairs.capacity() {
            pairs.push(*p);
        } else {
            *unreported += 1;
        }
        true
    };
    *complete = descend_to_deadline(
        tool,
        obj,
        *object as u32,
        &Cell::new(*margin),
        ws,
        &mut keep,
        *deadline,
    );
}

/// The serial start of every split traversal: from the roots until [`SHARE_MIN_PAIRS`] node
/// pairs wait on the stack (at most [`SHARE_MAX_START_SPLITS`] splits) or the descent ends;
/// the last call's [`Descent`] (its count: pairs it reported).
pub(crate) fn descend_until_shareable<F: FnMut(&LeafPair) -> bool>(
    tool: &PackedTree,
    obj: &PackedTree,
    obj_id: u32,
    m: &Cell<f64>,
    ws: &mut CollideWorkspace,
    visit: &mut F,
) -> Descent {
    let mut one = 1;
    let mut d = descend_as_queried(tool, obj, obj_id, m.get(), ws, visit, false, &mut one);
    let mut splits = 1;
    while !d.finished && ws.stack.len() < SHARE_MIN_PAIRS && splits < SHARE_MAX_START_SPLITS {
        let mut one = 1;
        d = descend_as_queried(tool, obj, obj_id, m.get(), ws, visit, true, &mut one);
        splits += 1;
    }
    d
}

/// Keeps the waiting node pairs at even (`parity` 0) or odd (1) positions of `stack`, in order,
/// and hands the others to `other`, in order: the two halves of a split traversal.
pub(crate) fn keep_half(
    stack: &mut Vec<(u32, u32)>,
    parity: usize,
    mut other: impl FnMut((u32, u32)),
) {
    let mut k = 0;
    stack.retain(|&e| {
        let mine = k % 2 == parity;
        k += 1;
        if !mine {
            other(e);
        }
        mine
    });
}

/// Descends what waits on `ws`'s stack (resuming) in slices, checking `deadline` between
/// them. True when finished, false when stopped.
fn descend_to_deadline<F: FnMut(&LeafPair) -> bool>(
    tool: &PackedTree,
    obj: &PackedTree,
    obj_id: u32,
    m: &Cell<f64>,
    ws: &mut CollideWorkspace,
    visit: &mut F,
    deadline: Option<Instant>,
) -> bool {
    loop {
        let mut budget = SPLITS_PER_CHECK;
        if descend_as_queried(tool, obj, obj_id, m.get(), ws, visit, true, &mut budget).finished {
            return true;
        }
        if deadline.is_some_and(|t| Instant::now() >= t) {
            return false;
        }
    }
}

/// Every leaf pair of `tool` (posed by `world_from_tool`, swept along `sweep` if given) and
/// `objects` within `margin` (mm) of touching, as [`crate::overlap_until`], in the fixed
/// order of the module docs; the second half of each object's descent goes to `team`'s helper
/// when it is free. Stops at `deadline` (then incomplete). With a `slab` (queries at a pose),
/// half-space pairs of its faces are kept within its thinner margin ([`FaceSlab`]).
///
/// # Real-time
/// Allocation-free with `ws` from [`CollideWorkspace::for_trees`] for these trees; never
/// waits for the helper past `deadline`.
#[allow(clippy::too_many_arguments)]
pub fn overlap_shared<F: FnMut(&LeafPair)>(
    tool: &PackedTree,
    world_from_tool: &Pose,
    sweep: Option<&Sweep>,
    objects: &[PackedTree],
    margin: f64,
    slab: Option<FaceSlab>,
    ws: &mut CollideWorkspace,
    team: Option<&TraversalTeam>,
    deadline: Option<Instant>,
    visit: F,
) -> Result<SharedTraversal, CollideError> {
    let query = SharedQuery {
        sweep,
        margin,
        proof_margin: 0.0,
        slab,
        team,
        deadline,
    };
    shared(tool, world_from_tool, objects, &query, ws, visit).map(|(t, _)| t)
}

/// [`overlap_shared`] at a pose that also proves free space beyond the pairs it reports:
/// every leaf pair within `margin` (mm) is reported, and the second value returned is the
/// proven margin, mm: no leaf pair has a gap below it but those reported. It is the least gap
/// of the leaf pairs beyond `margin`, or `proof_margin` when none is within that (never
/// below `margin`). The descent runs at `proof_margin` until it meets a pair beyond
/// `margin`, then at that pair's gap, so it costs about a traversal at the proven margin:
/// where the nearest surface is unknown, one traversal gives the widest proof it allows
/// (with the spline's keys turning 0.1–0.2 mm from the keyways' flanks, a probe of 0.137 mm
/// split 2 148 node pairs where one of 0.044 mm split 1 863). Incomplete (the deadline)
/// proves nothing beyond the pairs within `margin` found so far. A negative or NaN margin is
/// taken as 0; a proof margin not above `margin` gives the plain traversal. Errors only on a
/// non-finite pose.
///
/// # Real-time
/// As [`overlap_shared`].
#[allow(clippy::too_many_arguments)]
pub fn overlap_shared_proving<F: FnMut(&LeafPair)>(
    tool: &PackedTree,
    world_from_tool: &Pose,
    objects: &[PackedTree],
    margin: f64,
    proof_margin: f64,
    ws: &mut CollideWorkspace,
    team: Option<&TraversalTeam>,
    deadline: Option<Instant>,
    visit: F,
) -> Result<(SharedTraversal, f64), CollideError> {
    let query = SharedQuery {
        sweep: None,
        margin,
        proof_margin,
        slab: None,
        team,
        deadline,
    };
    shared(tool, world_from_tool, objects, &query, ws, visit)
}

/// The options of a shared traversal ([`overlap_shared`], [`overlap_shared_proving`]).
struct SharedQuery<'a> {
    sweep: Option<&'a Sweep>,
    margin: f64,
    /// Wider than `margin`: the descent starts at it and narrows to the nearest gap beyond
    /// `margin` (0: a plain traversal).
    proof_margin: f64,
    slab: Option<FaceSlab>,
    team: Option<&'a TraversalTeam>,
    deadline: Option<Instant>,
}

fn shared<F: FnMut(&LeafPair)>(
    tool: &PackedTree,
    world_from_tool: &Pose,
    objects: &[PackedTree],
    query: &SharedQuery<'_>,
    ws: &mut CollideWorkspace,
    mut visit: F,
) -> Result<(SharedTraversal, f64), CollideError> {
    let SharedQuery {
        sweep,
        margin,
        proof_margin,
        slab,
        team,
        deadline,
    } = *query;
    if !world_from_tool.is_finite() || !sweep.is_none_or(Sweep::is_finite) {
        return Err(CollideError::NonFinitePose);
    }
    for o in objects {
        ws.reserve(tool, o);
    }
    ws.start(tool, world_from_tool, sweep);
    ws.slab = slab.filter(|_| sweep.is_none());
    let m = match sweep {
        None => clean_margin(margin),
        Some(sw) => clean_margin(margin) + arc_allowance(tool.reach(), sw.angle()),
    };
    // The descent's margin: the proof's, narrowed to each pair met beyond `m`.
    let proving = sweep.is_none() && clean_margin(proof_margin) > m;
    let descent = Cell::new(if proving {
        clean_margin(proof_margin)
    } else {
        m
    });
    if let Some(team) = team {
        team.keep_awake();
    }
    let mut out = SharedTraversal {
        pairs: 0,
        unreported: 0,
        complete: true,
        helped: false,
    };
    let mut report = |p: &LeafPair| {
        if !proving || p.gap <= m {
            visit(p);
            true
        } else {
            descent.set(descent.get().min(p.gap));
            false
        }
    };
    for (i, obj) in objects.iter().enumerate() {
        let id = i as u32;
        let mut found = 0usize;
        // (A pair beyond `m` narrows the descent; the descent goes on.)
        let mut counted = |p: &LeafPair| {
            found += usize::from(report(p));
            true
        };
        // The serial start: until enough node pairs wait to share.
        let finished = descend_until_shareable(tool, obj, id, &descent, ws, &mut counted).finished;
        if finished {
            out.pairs += found;
            continue;
        }
        // Every second waiting node pair is the second half.
        let CollideWorkspace { stack, second, .. } = ws;
        second.clear();
        keep_half(stack, 0, |e| second.push(e));
        let posted = team.is_some_and(|t| {
            post(
                t,
                world_from_tool,
                sweep,
                descent.get(),
                ws.slab,
                i,
                deadline,
                &ws.second,
            )
        });
        let half_start = Instant::now();
        if !descend_to_deadline(tool, obj, id, &descent, ws, &mut counted, deadline) {
            if posted {
                // The helper may still be on it; its answer is not waited for.
                let _ = team.map(take_back);
            }
            out.pairs += found;
            out.complete = false;
            return Ok((out, m));
        }
        // The helper's answer, if it finishes within a grace period (as long as the caller's
        // own half took): a helper held up (preempted: it runs on idle time only) is not
        // waited for; the caller's thread descends the second half itself instead.
        let mut merged = false;
        if let Some(team) = team.filter(|t| posted && !take_back(t)) {
            let grace = half_start.elapsed().max(MIN_GRACE);
            let until = deadline.map_or(Instant::now() + grace, |d| d.min(Instant::now() + grace));
            if wait_done(team, Some(until)) {
                let done = match team.shared.work.lock() {
                    Ok(work) => {
                        for p in &work.pairs {
                            counted(p);
                        }
                        ws.stats.node_pairs_split += work.ws.stats.node_pairs_split;
                        ws.stats.sphere_tests += work.ws.stats.sphere_tests;
                        ws.stats.tool_nodes_posed += work.ws.stats.tool_nodes_posed;
                        ws.stats.box_pruned += work.ws.stats.box_pruned;
                        ws.stats.face_pruned += work.ws.stats.face_pruned;
                        out.unreported += work.unreported;
                        out.pairs += work.unreported;
                        work.complete
                    }
                    Err(_) => false,
                };
                out.helped = true;
                merged = true;
                if !done {
                    out.pairs += found;
                    out.complete = false;
                    return Ok((out, m));
                }
            }
        }
        if !merged {
            // The caller's thread takes the second half (its nodes are posed here already).
            let CollideWorkspace { stack, second, .. } = ws;
            stack.extend_from_slice(second);
            if !descend_to_deadline(tool, obj, id, &descent, ws, &mut counted, deadline) {
                out.pairs += found;
                out.complete = false;
                return Ok((out, m));
            }
        }
        out.pairs += found;
    }
    // Complete: nothing but the reported pairs lies within the descent's last margin.
    let proven = if proving { descent.get() } else { m };
    Ok((out, proven))
}

/// Hands a background probe `job` to the helper if it is free: the job's number, or `None`.
pub(crate) fn post_probe_job(team: &TraversalTeam, job: ProbeJob) -> Option<u64> {
    let mut work = free_helper(team)?;
    // Replacing the last job's handles only moves reference counts (no allocation).
    work.probe = Some(job);
    work.list = None;
    drop(work);
    post_job(team)
}

/// Hands a background neighbour-list build to the helper if it is free: the job's number, or
/// `None`.
pub(crate) fn post_list_job(team: &TraversalTeam, job: ListJob) -> Option<u64> {
    // Not urgent: a parked helper is woken for it (its wake-up costs the caller nothing), so
    // it need not spin while the tool rests in a contact.
    let mut work = idle_helper(team)?;
    work.list = Some(job);
    work.probe = None;
    drop(work);
    let id = post_job(team);
    if team.shared.sleeping.load(Ordering::Acquire) {
        if let Some(h) = &team.handle {
            h.thread().unpark();
        }
    }
    id
}

/// Posts the job just placed in the work slot: its number, or `None`.
fn post_job(team: &TraversalTeam) -> Option<u64> {
    let id = team.shared.job.fetch_add(1, Ordering::AcqRel) + 1;
    team.shared
        .state
        .compare_exchange(IDLE, POSTED, Ordering::AcqRel, Ordering::Acquire)
        .is_ok()
        .then_some(id)
}

/// Where the job numbered `id` stands: `None` when another job has been posted since.
pub(crate) fn job_state(team: &TraversalTeam, id: u64) -> Option<JobState> {
    let s = &team.shared;
    let state = s.state.load(Ordering::Acquire);
    if s.job.load(Ordering::Acquire) != id {
        return None;
    }
    Some(match state {
        POSTED => JobState::Posted,
        CLAIMED => JobState::Running,
        _ => JobState::Ended,
    })
}

/// Where a posted job stands ([`job_state`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum JobState {
    /// Not claimed by the helper yet.
    Posted,
    /// The helper is on it.
    Running,
    /// Finished (or taken back).
    Ended,
}

/// Waits (spinning) until the helper has finished a claimed job or `deadline` passes (or the
/// helper is gone); true when finished (the helper is idle again).
pub(crate) fn wait_done(team: &TraversalTeam, deadline: Option<Instant>) -> bool {
    let s = &team.shared;
    while s.state.load(Ordering::Acquire) != DONE {
        if deadline.is_some_and(|t| Instant::now() >= t)
            || team.handle.as_ref().is_none_or(|h| h.is_finished())
        {
            return false;
        }
        std::hint::spin_loop();
    }
    s.state.store(IDLE, Ordering::Release);
    true
}

/// The work slot, when the helper is awake and free for a new job (a finished job nobody
/// collected is dropped).
fn free_helper(team: &TraversalTeam) -> Option<std::sync::MutexGuard<'_, Work>> {
    // A helper asleep would take longer to wake than the caller's half takes.
    if team.shared.sleeping.load(Ordering::Acquire) {
        return None;
    }
    idle_helper(team)
}

/// The work slot, when the helper (awake or parked) is free for a new job.
fn idle_helper(team: &TraversalTeam) -> Option<std::sync::MutexGuard<'_, Work>> {
    let s = &team.shared;
    match s.state.load(Ordering::Acquire) {
        IDLE => {}
        DONE => {
            s.state
                .compare_exchange(DONE, IDLE, Ordering::AcqRel, Ordering::Acquire)
                .ok()?;
        }
        _ => return None,
    }
    // The helper locks `work` only after claiming a posted job, so this does not block.
    s.work.try_lock().ok()
}

/// Hands `entries` (one object's second half) to the helper if it is free; true if posted.
#[allow(clippy::too_many_arguments)]
fn post(
    team: &TraversalTeam,
    pose: &Pose,
    sweep: Option<&Sweep>,
    margin: f64,
    slab: Option<FaceSlab>,
    object: usize,
    deadline: Option<Instant>,
    entries: &[(u32, u32)],
) -> bool {
    let Some(mut work) = free_helper(team) else {
        return false;
    };
    if work.entries.capacity() < entries.len() {
        return false;
    }
    work.probe = None;
    work.list = None;
    work.pose = *pose;
    work.sweep = sweep.copied();
    work.margin = margin;
    work.slab = slab;
    work.object = object;
    work.deadline = deadline;
    work.entries.clear();
    work.entries.extend_from_slice(entries);
    drop(work);
    team.shared.job.fetch_add(1, Ordering::AcqRel);
    team.shared
        .state
        .compare_exchange(IDLE, POSTED, Ordering::AcqRel, Ordering::Acquire)
        .is_ok()
}

/// Withdraws a posted, unclaimed job: true when taken back (the caller does it), false when
/// the helper has it.
pub(crate) fn take_back(team: &TraversalTeam) -> bool {
    team.shared
        .state
        .compare_exchange(POSTED, IDLE, Ordering::AcqRel, Ordering::Acquire)
        .is_ok()
}
