//! A neighbour list (a Verlet list, as molecular dynamics keeps one): every leaf pair within a
//! wide margin `M` of touching at a pose `c`, built once (in slices, spread over frames) and
//! then filtered instead of traversed while the queries stay near `c`.
//!
//! **Why it is exact.** No tool leaf centre moves more than `b = |t_q - t_c| + θ · arm`
//! between `c` and a pose `q` (`R_q R_c^T = exp(θ û)`, `arm` the largest distance of the
//! box of the tool's leaf centres from the axis `û` through the tool origin,
//! [`CentreBox::turn_bound`]: a shaft turning about its own axis moves its centres by its
//! radius per radian, not its reach). A pair whose gap at `q` is at most `m` has a gap of at most `m + b`
//! at `c`; so while `b + m <= M` it is in the list, and testing the listed pairs at `q` gives
//! exactly the pairs a traversal at `q` would report. A swept query (the pairs that come within
//! `m` along a [`Sweep`] from `q`) needs `M` to cover the sweep too: its translation `|v|`, its
//! turn over the tool's reach, the arc allowance and the turn's growth of a leaf's radius
//! ([`NeighbourList::covers`]).
//!
//! Flat-on-flat contacts are where it pays: their trees' inner spheres overlap across the
//! whole face, so a traversal splits a thousand node pairs to find a hundred leaf pairs, while
//! testing a few thousand listed pairs costs a few microseconds.

use crate::probe::lock_by;
use crate::team::{self, JobState, TraversalTeam};
use crate::traverse::{
    arc_allowance, clean_margin, descend_as_queried, leaf_stand_in, segment_dist2, CollideWorkspace,
};
use crate::{CentreBox, CollideError, FaceCut, LeafPair, PackedTree, Pose, Sweep};

use std::sync::atomic::{AtomicU64, AtomicU8, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// Work (node pairs split plus pairs listed) between two clock reads while a list is built
/// against a deadline, and of the helper's slices.
const SPLITS_PER_CLOCK: usize = 128;

/// State of a [`NeighbourList`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ListStatus {
    /// Nothing built (or cleared).
    Empty,
    /// Started, not finished: call [`NeighbourList::advance`] again.
    Building,
    /// Complete: queries it [`covers`](NeighbourList::covers) can be answered by
    /// [`NeighbourList::filter`].
    Ready,
    /// More pairs than its capacity: unusable (build again with a smaller margin).
    Overflowed,
}

/// The listed pairs in structure-of-arrays form, for the filter: tool centre (tool frame,
/// mm), object centre (world, mm), both radii (mm).
#[derive(Clone, Debug)]
struct Columns {
    px: Vec<f64>,
    py: Vec<f64>,
    pz: Vec<f64>,
    ox: Vec<f64>,
    oy: Vec<f64>,
    oz: Vec<f64>,
    r_tool: Vec<f64>,
    r_object: Vec<f64>,
    /// The object node's face cuts: a range of `cuts` (8 bytes a pair, the cuts themselves
    /// only where there are some).
    face: Vec<[u32; 2]>,
    cuts: Vec<FaceCut>,
}

impl Columns {
    /// Room for `capacity` pairs and `cuts` face cuts, resident ([`crate::touch_pages`]).
    fn with_capacity(capacity: usize, cuts: usize) -> Self {
        let column = || Vec::with_capacity(capacity);
        let mut columns = Self {
            px: column(),
            py: column(),
            pz: column(),
            ox: column(),
            oy: column(),
            oz: column(),
            r_tool: column(),
            r_object: column(),
            face: Vec::with_capacity(capacity),
            cuts: Vec::with_capacity(cuts),
        };
        for c in columns.all() {
            crate::touch_pages(c);
        }
        crate::touch_pages(&mut columns.face);
        crate::touch_pages(&mut columns.cuts);
        columns
    }

    fn all(&mut self) -> [&mut Vec<f64>; 8] {
        [
            &mut self.px,
            &mut self.py,
            &mut self.pz,
            &mut self.ox,
            &mut self.oy,
            &mut self.oz,
            &mut self.r_tool,
            &mut self.r_object,
        ]
    }

    fn push(&mut self, p: &LeafPair, cuts: &[FaceCut]) {
        let values = [
            p.p_in_tool[0],
            p.p_in_tool[1],
            p.p_in_tool[2],
            p.o_in_world[0],
            p.o_in_world[1],
            p.o_in_world[2],
            p.r_tool,
            p.r_object,
        ];
        for (column, v) in self.all().into_iter().zip(values) {
            column.push(v);
        }
        // Within the reserved room (the caller checks `has_room`).
        let first = self.cuts.len();
        let room = self.cuts.capacity() - first;
        self.cuts.extend_from_slice(&cuts[..cuts.len().min(room)]);
        self.face.push([first as u32, self.cuts.len() as u32]);
    }

    /// True when `n` more cuts fit in the reserved room.
    fn has_room(&self, n: usize) -> bool {
        self.cuts.capacity() - self.cuts.len() >= n
    }

    fn clear(&mut self) {
        self.all().into_iter().for_each(Vec::clear);
        self.face.clear();
        self.cuts.clear();
    }
}

/// Every leaf pair within a margin of touching at one pose, kept to answer later queries near
/// that pose without a traversal (see the module docs for the guarantee).
///
/// # Real-time
/// All storage is reserved by [`NeighbourList::for_trees`]: building, covering and filtering
/// never allocate and never panic.
#[derive(Clone, Debug)]
pub struct NeighbourList {
    ws: CollideWorkspace,
    center: Pose,
    /// mm.
    margin: f64,
    status: ListStatus,
    /// The object being descended, and whether its descent is under way (resume its stack).
    object: usize,
    resume: bool,
    pairs: Vec<LeafPair>,
    /// The listed pairs' geometry, for the filter.
    columns: Columns,
    /// The tool's reach (mm), the box of its leaf centres (tool frame, mm) and its largest
    /// leaf radius (mm), for [`NeighbourList::covers`].
    reach: f64,
    centres: CentreBox,
    leaf_radius: f64,
}

impl NeighbourList {
    /// An empty list for `tool` against `objects`, holding at most `capacity` pairs
    /// (allocates; not real-time).
    pub fn for_trees(tool: &PackedTree, objects: &[PackedTree], capacity: usize) -> Self {
        let leaf_radius = tool.leaves().map(|n| tool.radius(n)).fold(0.0, f64::max);
        let cuts_per_pair = objects.iter().map(|o| o.max_leaf_cuts()).max().unwrap_or(0);
        let mut pairs = Vec::with_capacity(capacity);
        crate::touch_pages(&mut pairs);
        Self {
            ws: {
                let mut ws = CollideWorkspace::for_trees(tool, objects);
                ws.keep_sphere_pairs = true;
                ws
            },
            center: Pose::identity(),
            margin: 0.0,
            status: ListStatus::Empty,
            object: 0,
            resume: false,
            pairs,
            // A leaf carries its own cuts and its ancestors' crossing it: room for every pair's
            // leaf to carry as many as any leaf does (a list whose cuts did not fit would
            // overflow, as one with too many pairs).
            columns: Columns::with_capacity(capacity, capacity * cuts_per_pair),
            reach: tool.reach(),
            // By the box's corners, as the leaf spheres' step was tuned (`CentreBox::axis_arms`).
            centres: CentreBox::of_points(tool.leaves().map(|n| tool.center(n)))
                .with_axis_arms(false),
            leaf_radius,
        }
    }

    /// Starts a new list of the pairs within `margin` (mm) of touching with the tool at
    /// `center`; [`NeighbourList::advance`] builds it. The old list is dropped.
    pub fn start(
        &mut self,
        tool: &PackedTree,
        center: &Pose,
        margin: f64,
    ) -> Result<(), CollideError> {
        if !center.is_finite() {
            return Err(CollideError::NonFinitePose);
        }
        self.clear();
        self.center = *center;
        self.margin = clean_margin(margin);
        self.ws.start(tool, center, None);
        self.status = ListStatus::Building;
        Ok(())
    }

    /// Forgets the list (status [`ListStatus::Empty`]).
    pub fn clear(&mut self) {
        self.status = ListStatus::Empty;
        self.object = 0;
        self.resume = false;
        self.pairs.clear();
        self.columns.clear();
    }

    /// Builds on for about `budget` units of [work](NeighbourList::work) (node pairs split
    /// plus pairs listed: the pairs of a chunk of a quarter of what is left are counted after
    /// it, so a call may end that chunk's pairs past its budget), stopping early past
    /// `deadline`; the list's status. The same trees as given to [`NeighbourList::for_trees`].
    pub fn advance(
        &mut self,
        tool: &PackedTree,
        objects: &[PackedTree],
        mut budget: usize,
        deadline: Option<Instant>,
    ) -> ListStatus {
        if self.status != ListStatus::Building {
            return self.status;
        }
        let capacity = self.pairs.capacity();
        let mut overflow = false;
        while let Some(o) = objects.get(self.object) {
            let id = self.object as u32;
            self.ws.reserve(tool, o);
            loop {
                // Chunks of a quarter of what is left (the pairs a chunk lists are counted
                // after it): a slice ends within about a quarter of its budget past it.
                let slice = (budget / 4).clamp(budget.min(1), SPLITS_PER_CLOCK);
                if slice == 0 {
                    return self.status;
                }
                let mut left = slice;
                let listed_before = self.pairs.len();
                let (pairs, ws, columns) = (&mut self.pairs, &mut self.ws, &mut self.columns);
                let mut keep = |p: &LeafPair| {
                    let cuts = o.cuts_of_slot(p.object_slot as usize);
                    // A pair whose cuts do not fit would stand for a larger stand-in than the
                    // traversal's: the list overflows instead.
                    if pairs.len() >= capacity || !columns.has_room(cuts.len()) {
                        overflow = true;
                        return false;
                    }
                    pairs.push(*p);
                    columns.push(p, cuts);
                    true
                };
                let d = descend_as_queried(
                    tool,
                    o,
                    id,
                    self.margin,
                    ws,
                    &mut keep,
                    self.resume,
                    &mut left,
                );
                self.resume = true;
                budget = budget.saturating_sub(slice - left + (self.pairs.len() - listed_before));
                if overflow {
                    self.status = ListStatus::Overflowed;
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
        self.status = ListStatus::Ready;
        self.status
    }

    /// The list's status.
    pub fn status(&self) -> ListStatus {
        self.status
    }

    /// The pose and margin (mm) the list was started with.
    pub fn question(&self) -> (Pose, f64) {
        (self.center, self.margin)
    }

    /// Node pairs split by the current (or last) build.
    pub fn splits(&self) -> usize {
        self.ws.stats.node_pairs_split
    }

    /// The build's work so far (its cost once finished): node pairs split plus pairs listed.
    /// Listing a pair costs about what a split does, and at a list's wide margin a dense
    /// contact lists more pairs than it splits node pairs (the spline's grooves: 3 500 pairs
    /// for 5 000 splits), so a budget of splits alone lets a slice run several times longer
    /// there than on a sparse contact.
    pub fn work(&self) -> usize {
        self.ws.stats.node_pairs_split + self.pairs.len()
    }

    /// Pairs listed so far.
    pub fn len(&self) -> usize {
        self.pairs.len()
    }

    /// True when no pair is listed.
    pub fn is_empty(&self) -> bool {
        self.pairs.is_empty()
    }

    /// How far (mm) the list reaches past a query at `q` with `margin` (mm) and `sweep`: its
    /// margin less the largest motion of a tool leaf from the list's pose to `q` and along the
    /// sweep, the query's margin and the sweep's allowances. A query is
    /// [`covered`](NeighbourList::covers) when this is at least 0; `-inf` when the list is not
    /// ready or the input is not finite.
    pub fn slack(&self, q: &Pose, sweep: Option<&Sweep>, margin: f64) -> f64 {
        if self.status != ListStatus::Ready
            || !q.is_finite()
            || sweep.is_some_and(|s| !s.is_finite())
        {
            return f64::NEG_INFINITY;
        }
        let dt = (q.translation() - self.center.translation()).norm();
        // A turn moves the leaf centres by its angle times their arm about its axis.
        let turn_from_center = self
            .centres
            .turn_bound(&self.center.rotation_matrix(), &q.rotation_matrix());
        let mut need = dt + turn_from_center + clean_margin(margin);
        if let Some(s) = sweep {
            let v = s.translation;
            let turn = s.angle();
            // Along the sweep a leaf centre moves at most |v| + |w| reach from its tangent's
            // start; the swept test grows radii by |w| r and the margin by the arc allowance.
            need += (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
                + turn * (self.reach + self.leaf_radius)
                + arc_allowance(self.reach, turn);
        }
        self.margin - need
    }

    /// True when every pair a traversal at `q` (within `margin` mm, along `sweep` if given)
    /// would report is in the list.
    pub fn covers(&self, q: &Pose, sweep: Option<&Sweep>, margin: f64) -> bool {
        self.slack(q, sweep, margin) >= 0.0
    }

    /// The listed pairs that come within `margin` (mm) of touching with the tool at `q` (along
    /// `sweep` from `q`, if given), tested as the traversal tests leaf pairs, so a covered
    /// query gets exactly the traversal's pairs (in the list's order), each with its gap at
    /// `q`. `visit` returns false to stop. Returns the number reported, or `None` when the
    /// list does not [cover](NeighbourList::covers) the query (nothing is reported).
    pub fn filter<F: FnMut(&LeafPair) -> bool>(
        &self,
        q: &Pose,
        sweep: Option<&Sweep>,
        margin: f64,
        visit: F,
    ) -> Option<usize> {
        if !self.covers(q, sweep, margin) {
            return None;
        }
        Some(self.scan(q, sweep, margin, margin, visit).0)
    }

    /// [`NeighbourList::filter`] at `q` (no sweep) that also proves free space beyond the
    /// pairs it reports, in the same pass: up to `proof` mm or as far as the list reaches past
    /// `q`, whichever is less, and no farther than the nearest listed pair beyond `margin`
    /// (every pair the list does not hold is at least that far). Returns the number reported
    /// and the proven margin (mm; at least `margin`'s cleaned value where nothing more is
    /// proven), or `None` when the list does not cover `margin` at `q`. Matches
    /// [`overlap_shared_proving`](crate::overlap_shared_proving) where the list reaches
    /// `proof`.
    pub fn filter_proving<F: FnMut(&LeafPair) -> bool>(
        &self,
        q: &Pose,
        margin: f64,
        proof: f64,
        visit: F,
    ) -> Option<(usize, f64)> {
        if !self.covers(q, None, margin) {
            return None;
        }
        let margin = clean_margin(margin);
        let wide = clean_margin(proof)
            .min(self.slack(q, None, 0.0))
            .max(margin);
        Some(self.scan(q, None, margin, wide, visit))
    }

    /// The filter's pass over the listed pairs: reports those within `margin` (mm) to `visit`
    /// and returns their number and the least gap (mm) of the others within `wide` (at least
    /// `margin`; `wide` where there is none).
    fn scan<F: FnMut(&LeafPair) -> bool>(
        &self,
        q: &Pose,
        sweep: Option<&Sweep>,
        margin: f64,
        wide: f64,
        mut visit: F,
    ) -> (usize, f64) {
        let m = q.rotation_matrix();
        let r: [[f64; 3]; 3] = std::array::from_fn(|i| std::array::from_fn(|j| m[(i, j)]));
        let t = [q.q[0], q.q[1], q.q[2]];
        let sweep = sweep.copied();
        let (grow, m, m_wide) = match &sweep {
            None => (1.0, clean_margin(margin), clean_margin(wide)),
            Some(s) => {
                let arc = arc_allowance(self.reach, s.angle());
                (
                    1.0 + s.angle(),
                    clean_margin(margin) + arc,
                    clean_margin(wide) + arc,
                )
            }
        };
        let m_wide = m_wide.max(m);
        let mut nearest = m_wide;
        let mut count = 0;
        for i in 0..self.pairs.len() {
            let c = &self.columns;
            let (x, y, z) = (c.px[i], c.py[i], c.pz[i]);
            // The traversal's arithmetic, so that the gaps agree to the bit.
            let w = [
                r[0][0] * x + r[0][1] * y + r[0][2] * z + t[0],
                r[1][0] * x + r[1][1] * y + r[1][2] * z + t[1],
                r[2][0] * x + r[2][1] * y + r[2][2] * z + t[2],
            ];
            let d = [w[0] - c.ox[i], w[1] - c.oy[i], w[2] - c.oz[i]];
            let d2 = match &sweep {
                None => d[0] * d[0] + d[1] * d[1] + d[2] * d[2],
                Some(sw) => {
                    let (v, a) = (sw.translation, sw.rotation);
                    let p = [w[0] - t[0], w[1] - t[1], w[2] - t[2]];
                    let disp = [
                        v[0] + a[1] * p[2] - a[2] * p[1],
                        v[1] + a[2] * p[0] - a[0] * p[2],
                        v[2] + a[0] * p[1] - a[1] * p[0],
                    ];
                    segment_dist2(d, disp)
                }
            };
            let base = c.r_tool[i] * grow + c.r_object[i];
            if d2 > (base + m_wide) * (base + m_wide) {
                continue;
            }
            let near = d2 <= (base + m) * (base + m);
            let stand_in = || {
                let [a, b] = c.face[i];
                let cuts = c.cuts.get(a as usize..b as usize).unwrap_or(&[]);
                let d2_here = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
                leaf_stand_in(
                    cuts,
                    self.pairs[i].o_in_world,
                    c.r_object[i],
                    w,
                    c.r_tool[i],
                    d2_here,
                )
            };
            if !near {
                nearest = nearest.min(stand_in().0);
                continue;
            }
            let (gap, face, on_face) = stand_in();
            if sweep.is_none() && face.is_some() && gap > m {
                nearest = nearest.min(gap);
                continue;
            }
            let mut pair = self.pairs[i];
            pair.gap = gap;
            pair.face = face;
            pair.on_face = on_face;
            count += 1;
            if !visit(&pair) {
                break;
            }
        }
        (count, nearest)
    }
}

/// Longest the caller waits for the list's lock held by the helper (it holds it for one
/// slice of [`SPLITS_PER_CLOCK`] units of work at a time).
const LOCK_WAIT: Duration = Duration::from_micros(50);

/// How far a background build is, readable without its lock.
#[derive(Debug, Default)]
struct Published {
    status: AtomicU8,
    work: AtomicUsize,
}

fn status_code(s: ListStatus) -> u8 {
    match s {
        ListStatus::Empty => 0,
        ListStatus::Building => 1,
        ListStatus::Ready => 2,
        ListStatus::Overflowed => 3,
    }
}

fn status_of(code: u8) -> ListStatus {
    match code {
        1 => ListStatus::Building,
        2 => ListStatus::Ready,
        3 => ListStatus::Overflowed,
        _ => ListStatus::Empty,
    }
}

/// The next neighbour list, built a slice per call on the caller's schedule, or ahead of it
/// by a [`TraversalTeam`]'s helper thread.
///
/// **The schedule decides, not the threads.** Each [`BackgroundList::advance`] call grants
/// the build a number of units of work; the list counts as finished at the first call by which
/// the granted work reaches the build's total, whichever thread did it. A helper that runs
/// ahead only spares the caller the work; one that lags is caught up by the caller, as far as
/// the call allows. So for a given schedule of grants the list becomes usable at the same call
/// with or without a helper, unless the helper is held up past what the caller may catch up.
///
/// **Two buffers.** The helper builds in a buffer it shares with the caller (a lock, released
/// between slices of 128 units of work); the caller builds in one of its own,
/// without a lock. A helper that stops making progress while it holds the shared buffer (on a
/// busy machine its `SCHED_IDLE` thread can wait for long) is abandoned: the caller starts the
/// build again in its own buffer, so a starved helper never keeps the lists from coming.
#[derive(Debug)]
pub struct BackgroundList {
    shared: Arc<Mutex<NeighbourList>>,
    own: NeighbourList,
    /// The current build is in `own` (on the caller's thread), else in `shared`.
    in_own: bool,
    published: Arc<Published>,
    /// Bumped at each start: a helper still on an older build stops.
    generation: Arc<AtomicU64>,
    /// The helper's job number, while one was posted for this build.
    job: Option<u64>,
    /// Work granted since the start (node pairs split plus pairs listed).
    granted: usize,
    /// Work done as of the last call (a helper that did none since is held up).
    seen_work: usize,
    center: Pose,
    margin: f64,
    status: ListStatus,
}

/// A build the helper runs in the background: slices of [`SPLITS_PER_CLOCK`] units of work, the
/// lock released between them, to the end or until the build is replaced.
pub(crate) struct ListJob {
    list: Arc<Mutex<NeighbourList>>,
    published: Arc<Published>,
    generation: Arc<AtomicU64>,
    expected: u64,
}

impl std::fmt::Debug for ListJob {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ListJob").finish_non_exhaustive()
    }
}

impl ListJob {
    /// Builds on until the list is finished, replaced, or `quit` says so.
    pub(crate) fn run(&self, tool: &PackedTree, objects: &[PackedTree], quit: &dyn Fn() -> bool) {
        loop {
            if self.generation.load(Ordering::Acquire) != self.expected || quit() {
                return;
            }
            let Ok(mut list) = self.list.try_lock() else {
                // The caller's thread is catching up: let it.
                std::hint::spin_loop();
                continue;
            };
            if self.generation.load(Ordering::Acquire) != self.expected {
                return;
            }
            let status = list.advance(tool, objects, SPLITS_PER_CLOCK, None);
            publish(&self.published, &list);
            if status != ListStatus::Building {
                return;
            }
        }
    }
}

fn publish(shown: &Published, list: &NeighbourList) {
    shown.work.store(list.work(), Ordering::Release);
    shown
        .status
        .store(status_code(list.status()), Ordering::Release);
}

impl BackgroundList {
    /// An empty background list for `tool` against `objects`, holding at most `capacity`
    /// pairs (allocates its two buffers; not real-time).
    pub fn for_trees(tool: &PackedTree, objects: &[PackedTree], capacity: usize) -> Self {
        Self {
            shared: Arc::new(Mutex::new(NeighbourList::for_trees(
                tool, objects, capacity,
            ))),
            own: NeighbourList::for_trees(tool, objects, capacity),
            in_own: true,
            published: Arc::new(Published::default()),
            generation: Arc::new(AtomicU64::new(0)),
            job: None,
            granted: 0,
            seen_work: 0,
            center: Pose::identity(),
            margin: 0.0,
            status: ListStatus::Empty,
        }
    }

    /// Starts building the list of pairs within `margin` (mm) of touching with the tool at
    /// `center`, dropping any unfinished build (a helper on it stops at its next slice).
    /// Errors on a non-finite pose.
    ///
    /// # Real-time
    /// No allocation, no lock (the build starts in the caller's buffer; the first
    /// [`BackgroundList::advance`] with a team hands it to the helper).
    pub fn start(
        &mut self,
        tool: &PackedTree,
        center: &Pose,
        margin: f64,
    ) -> Result<(), CollideError> {
        self.generation.fetch_add(1, Ordering::AcqRel);
        self.job = None;
        self.status = ListStatus::Empty;
        self.own.start(tool, center, margin)?;
        self.in_own = true;
        self.granted = 0;
        self.seen_work = 0;
        self.center = *center;
        self.margin = self.own.margin;
        self.status = ListStatus::Building;
        Ok(())
    }

    /// Stops the build (status [`ListStatus::Empty`]); a helper on it stops at its next slice.
    pub fn cancel(&mut self) {
        self.generation.fetch_add(1, Ordering::AcqRel);
        self.job = None;
        self.status = ListStatus::Empty;
    }

    /// The build's status as the schedule sees it.
    pub fn status(&self) -> ListStatus {
        self.status
    }

    /// The pose and margin (mm) of the build.
    pub fn question(&self) -> (Pose, f64) {
        (self.center, self.margin)
    }

    /// The build's [work](NeighbourList::work) so far (its cost once finished).
    pub fn work(&self) -> usize {
        if self.in_own {
            self.own.work()
        } else {
            self.published.work.load(Ordering::Acquire)
        }
    }

    /// Grants the build `grant` more units of [work](NeighbourList::work) and returns its
    /// status. With `team`,
    /// its helper builds in the background; this call does only what the helper has not
    /// done of the granted work, at most `max_here` of it (a helper held up makes the
    /// list late, never the call long). `objects` (and `tool`) must be the trees of
    /// [`BackgroundList::for_trees`] and the team's. `deadline` stops this call's own work
    /// early (the list may then be late).
    ///
    /// # Real-time
    /// No allocation, no panic; at most `max_here` units of work here, and a wait of at most ~50 µs
    /// for the helper to let go of the shared buffer.
    #[allow(clippy::too_many_arguments)]
    pub fn advance(
        &mut self,
        tool: &PackedTree,
        objects: &[PackedTree],
        grant: usize,
        max_here: usize,
        team: Option<&TraversalTeam>,
        deadline: Option<Instant>,
    ) -> ListStatus {
        if self.status != ListStatus::Building {
            return self.status;
        }
        self.granted = self.granted.saturating_add(grant);
        // Handed to the helper just now: it gets until the next call to show progress.
        let handed = team.is_some_and(|team| self.hand_over(tool, team));
        if !self.in_own && !handed {
            self.advance_shared(tool, objects, max_here, team, deadline);
        }
        if self.in_own {
            let left = self.granted.saturating_sub(self.own.work()).min(max_here);
            if self.own.status() == ListStatus::Building && left > 0 {
                self.own.advance(tool, objects, left, deadline);
            }
            if self.own.status() != ListStatus::Building && self.own.work() <= self.granted {
                self.status = self.own.status();
            }
        }
        self.status
    }

    /// A build not yet begun in the caller's buffer goes to the helper's, if it is free: true
    /// when it was handed over.
    fn hand_over(&mut self, tool: &PackedTree, team: &TraversalTeam) -> bool {
        if !self.in_own || self.own.work() > 0 {
            return false;
        }
        let Ok(mut shared) = self.shared.try_lock() else {
            return false;
        };
        if shared.start(tool, &self.center, self.margin).is_err() {
            return false;
        }
        publish(&self.published, &shared);
        drop(shared);
        let job = ListJob {
            list: self.shared.clone(),
            published: self.published.clone(),
            generation: self.generation.clone(),
            expected: self.generation.load(Ordering::Acquire),
        };
        self.job = team::post_list_job(team, job);
        self.in_own = false;
        self.seen_work = 0;
        true
    }

    /// The helper's build: handed over again if another job came since, caught up here when
    /// the helper made no progress since the last call, abandoned for the caller's own
    /// buffer when the helper holds the shared one and does not let go.
    fn advance_shared(
        &mut self,
        tool: &PackedTree,
        objects: &[PackedTree],
        max_here: usize,
        team: Option<&TraversalTeam>,
        deadline: Option<Instant>,
    ) {
        let mut helper_on_it = false;
        let building =
            status_of(self.published.status.load(Ordering::Acquire)) == ListStatus::Building;
        if let (Some(team), true) = (team, building) {
            let state = self.job.and_then(|id| team::job_state(team, id));
            if matches!(state, Some(JobState::Posted | JobState::Running)) {
                helper_on_it = self.work() > self.seen_work;
            } else {
                let job = ListJob {
                    list: self.shared.clone(),
                    published: self.published.clone(),
                    generation: self.generation.clone(),
                    expected: self.generation.load(Ordering::Acquire),
                };
                self.job = team::post_list_job(team, job);
                helper_on_it = self.job.is_some();
            }
        }
        let shown = status_of(self.published.status.load(Ordering::Acquire));
        if shown == ListStatus::Building && self.work() < self.granted && !helper_on_it {
            match lock_by(&self.shared, Instant::now() + LOCK_WAIT) {
                Some(mut list) => {
                    let left = self.granted.saturating_sub(list.work()).min(max_here);
                    if list.status() == ListStatus::Building && left > 0 {
                        list.advance(tool, objects, left, deadline);
                    }
                    publish(&self.published, &list);
                }
                None => {
                    // The helper holds the buffer and is not running: start again here.
                    self.generation.fetch_add(1, Ordering::AcqRel);
                    self.job = None;
                    if self.own.start(tool, &self.center, self.margin).is_ok() {
                        self.in_own = true;
                    } else {
                        self.status = ListStatus::Empty;
                    }
                    return;
                }
            }
        }
        let shown = status_of(self.published.status.load(Ordering::Acquire));
        self.seen_work = self.work();
        if shown != ListStatus::Building && self.seen_work <= self.granted {
            self.status = shown;
        }
    }

    /// Moves a finished list into `into` (whose old contents take its place here, cleared):
    /// true when it did. The build's status is then [`ListStatus::Empty`].
    ///
    /// # Real-time
    /// No allocation (the two lists' buffers are swapped); waits at most ~50 µs.
    pub fn take(&mut self, into: &mut NeighbourList) -> bool {
        if self.status != ListStatus::Ready {
            return false;
        }
        if self.in_own {
            std::mem::swap(&mut self.own, into);
            self.own.clear();
        } else {
            let Some(mut list) = lock_by(&self.shared, Instant::now() + LOCK_WAIT) else {
                return false;
            };
            std::mem::swap(&mut *list, into);
            list.clear();
            publish(&self.published, &list);
        }
        self.status = ListStatus::Empty;
        self.job = None;
        true
    }
}
