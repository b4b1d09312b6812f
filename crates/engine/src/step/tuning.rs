//! The frame step's numbers, of three kinds:
//!
//! - **Tolerances and definitions** (`TOUCH_MM`, `CONVERGED_MM`, …): what the step promises,
//!   set from the penetration and convergence tolerances, not tuned.
//! - **Slices of the budget** (`IDLE_*`, `*_SLICE_*`, `*_SHARE`, `*_STEPS`): how much work runs
//!   between two looks at the clock, or what share of the 1 ms budget a background task may
//!   take; each is a time (written next to it) turned into units of work at their measured
//!   cost, so that no slice overruns the frame.
//! - **Tuned trade-offs** ([`Tuning`]): how much work a region, a list or a probe takes on
//!   against how long it serves. They change how much work frames do, never what they answer
//!   (tested: every one halved, or doubled, the step still answers as the reference step).
//!   Each is measured across the built-ins and the scene zoo by halving and doubling it
//!   (`haptic6d bench --studies tuning`; the table in docs/BENCHMARKS.md §The step's tuned
//!   values), and its comment gives what that measured.
//!
//! Constants are grouped by the heuristic (switch, [`Heuristics`](super::Heuristics)) they
//! belong to. What each heuristic pays across the zoo is the ablation table in
//! docs/BENCHMARKS.md.

// ---- Convergence, contact and start ----

/// A leaf pair whose exact gap (mm) at the answer is at most this is counted as touching
/// ([`Frame::contacts`](crate::Frame::contacts)).
pub const TOUCH_MM: f64 = 0.01;

/// A row whose linearized gap at the answer is below this (mm) holds the tool.
pub(super) const TIGHT_MM: f64 = 1e-6;

/// The frame has reached the optimum when no holding row is open by more than this in truth
/// (mm): a further pass would move the tool by about this much.
pub(super) const CONVERGED_MM: f64 = 0.005;

/// Projection passes a reset makes toward a free pose before it gives up: each moves the tool
/// out of the overlaps it lists, so a start a few leaf sizes deep takes a few.
pub(super) const RESET_SEARCH_PASSES: usize = 100;

// ---- The budget: passes, deadline, the paced loop's wait ----

/// Node pairs (probe) or units of list work a paced loop's wait runs between clock reads
/// ([`GodObject::idle`](super::GodObject::idle)): ~10–40 µs, so the wait ends within that of its limit.
pub(super) const IDLE_SLICE_SPLITS: usize = 128;

/// The end of a paced loop's wait kept for warming the caches, µs ([`GodObject::idle`](super::GodObject::idle)).
pub(super) const IDLE_WARM_US: u64 = 60;

/// A wait of at least this (µs) before a frame builds most of the next neighbour list: a list
/// is then kept wherever it lasts, its build no longer weighed against the traversals it
/// spares (at 1 kHz the wait is ~380 µs; design-notes §The paced loop).
pub(super) const IDLE_FOR_LISTS_US: u64 = 200;

// ---- Region size (`density-sizing`, overflow) ----

/// Below this allowance (mm) an overflowing pair list ends the frame (lagging, safe).
pub(super) const MIN_OVERFLOW_ALLOW_MM: f64 = 0.005;

// ---- Path regions (`path-regions`) ----

// ---- Slab regions (`slab-regions`) ----

// ---- The near part of the tool (`lever`) ----

/// Tool and object levels at which the near part of the tool is decided (the `lever` heuristic's near part of the tool): 512
/// nodes of a tree of branching 8 (a long tool on a face: ~5 500 sphere tests).
pub(super) const LEVER_LEVEL: u32 = 3;

/// Most sphere tests spent finding the near part of the tool (~7 ns each with the descent:
/// ~37 µs, once every ~15 regions).
pub(super) const LEVER_MAX_TESTS: usize = 8_000;

// ---- Free-space proofs and background probes (`free-space-proofs`, `background-probes`) ----

/// How much less than the proven gap (mm) a free-space proof from a proving traversal claims:
/// a pair may lie at the gap itself.
pub(super) const PROOF_ROUNDING_MM: f64 = 1e-6;

/// Share of the frame's budget a background probe's slice may take while the free-space
/// proofs still serve the next two frames (30 µs at 1 kHz): its node pairs are counted ahead of
/// time at a pose probe's cost, and a path probe's cost ~3 times as much.
pub(super) const PROBE_SLICE_MAX_SHARE: f64 = 0.03;

/// Share of the frame's budget a background probe's slice may take when the proofs run out
/// within two frames (100 µs at 1 kHz). A probe still unfinished when they do is carried on
/// to the frame's deadline, or replaced by a fresh traversal if it does not cover the tool.
pub(super) const PROBE_SLICE_URGENT_SHARE: f64 = 0.1;

/// Node pairs between two clock reads when a probe is finished within a frame's deadline.
pub(super) const PROBE_FINISH_SLICE_SPLITS: usize = 256;

/// Fewest node pairs a running probe splits in a frame.
pub(super) const PROBE_MIN_SLICE_SPLITS: usize = 300;

/// Most node pairs a background probe splits in one frame (~100–250 µs), when its proof is
/// about to run out.
pub(super) const PROBE_MAX_SLICE_SPLITS: usize = 5000;

/// Node pairs a probe along a path aims to split per frame, and the fewest it splits (a swept
/// node pair costs ~70 ns against ~40 for one at a pose: ~25 µs and ~10 µs).
pub(super) const PATH_PROBE_SLICE_SPLITS: usize = 350;

pub(super) const PATH_PROBE_MIN_SLICE_SPLITS: usize = 150;

// ---- Neighbour lists (`neighbour-lists`) ----

/// Per frame with no list building, the yield recovers by this factor (2 from 0.8 in ~46
/// frames), so a contact whose lists did not pay tries one again soon.
pub(super) const LIST_YIELD_RECOVERY: f64 = 1.02;

/// Most pairs a neighbour list holds; a build past it is dropped and the margin shrunk.
pub(super) const LIST_MAX_PAIRS: usize = 8192;

/// Most work (node pairs split plus pairs listed, [`collide::NeighbourList::work`]) a frame
/// spends building the next neighbour list on its own thread (~50–100 µs): a list late for
/// its use costs the traversals it would have spared, a long slice costs the frame.
pub(super) const LIST_MAX_SLICE_WORK: usize = 1280;

/// Work a frame grants the next neighbour list's build when a helper thread builds it
/// (~300 µs of the helper's time): the list is then ready a frame or two after it starts.
pub(super) const LIST_HELPER_WORK_PER_FRAME: usize = 8192;

/// The narrowest reach beyond the region's margin worth a near list, as a share of
/// [`Tuning::near_list_mm`] (two quarterings): after lists that overflowed their storage (a
/// tight fit, its whole wall near) quartered the reach below this,
/// the narrow phase lists the region's own margin only, and tries a wider list again (doubled)
/// on the next region.
pub(super) const NEAR_LIST_MIN_SHARE: f64 = 1.0 / 16.0;

/// Box pairs tested between two looks at the clock while building a near list ahead (a few µs).
pub(super) const NEAR_AHEAD_STEPS: usize = 64;

/// Levels of each sphere-tree the mesh mode keeps (grown to hold the triangles) above the
/// triangles' own box trees. Deeper levels only add pairs: a tool touching the parts sits
/// inside the leaves' envelope, so every leaf pair within a leaf's overhang is listed. Measured
/// on the 14 zoo scenes in the mesh mode with no deadline, keeping 1, 2 or 3 levels: with one
/// the mean detection and solve times were the least or equal on every scene (e.g. the big tool
/// 31 and 97 µs a frame against 149 and 355 with two and 104 and 264 with three).
pub(super) const MESH_SPHERE_LEVELS: u32 = 1;

/// The frame step's tuned values: trade-offs of work against work, set by measurement
/// across the scene zoo (`haptic6d bench --studies tuning`: each halved and doubled in turn; the
/// table is in docs/BENCHMARKS.md §Tuning). For measuring and testing the step, like
/// [`Heuristics`](super::Heuristics): not a scene-file setting. The values change how much work a frame does, never
/// what it answers beyond the convergence tolerance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tuning {
    /// A pass starts only if the frame's time so far plus this many times its longest pass stays
    /// within `budget_us`: a new region's traversal may cost more than any pass so far (the
    /// deadline stops one that overruns).
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.00 / ×1.00, p99 ×1.00 /
    /// ×1.01; doubled: 48 degraded frames against 42 (doubling costs more; halving stays within the
    /// runs' spread).
    pub pass_headroom: f64,
    /// Share of the frame budget kept after the last traversal may run for that pass's rows,
    /// solve and check: a traversal still running at `(1 - detect_reserve) · budget_us` stops,
    /// and the frame ends lagging at its last proven pose.
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.00 / ×1.00, p99 ×1.00 /
    /// ×1.00 (both within the runs' spread: not critical on these scenes).
    pub detect_reserve: f64,
    /// Leaf pairs a path region or a free-space probe aims at: a dense contact takes smaller
    /// regions (more passes) rather than one region of tens of thousands of rows.
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.00 / ×1.00, p99 ×1.00 /
    /// ×1.01 (both within the runs' spread: not critical on these scenes).
    pub pair_target: f64,
    /// Leaf pairs a ball region aims at in a dense contact. A ball region in a turning or
    /// pressed contact is detected again every few frames, and a dense one's cost grows faster
    /// than its life: a smaller target than [`Tuning::pair_target`] trades more passes for
    /// cheaper ones.
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×0.98 / ×1.02, p99 ×0.97 /
    /// ×1.04; halved: 48 degraded frames against 42 (both cost more).
    pub ball_pair_target: f64,
    /// Least allowance (mm) the pair density may give a ball region: a dense contact's regions
    /// may be thinner than [`Tuning::min_allow_mm`] (two bumpy faces hold ~1 500 pairs within
    /// ~0.1 mm).
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.01 / ×1.00, p99 ×1.01 /
    /// ×1.00 (both within the runs' spread: not critical on these scenes).
    pub dense_min_allow_mm: f64,
    /// Smallest motion allowance of a detected region, mm.
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.02 / ×1.12, p99 ×0.98 /
    /// ×1.21, node pairs ×1.05 / ×1.06, list entries ×1.50 / ×0.51 (halving is at the edge of the
    /// runs' spread, doubling costs more).
    pub min_allow_mm: f64,
    /// Largest pair list reused from an earlier frame: a list of [`Tuning::pair_target`] pairs
    /// costs ~20 µs to solve again against ~150 µs to find again. (A count, not a rule on
    /// measured times, which would make frames depend on the machine.)
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.00 / ×0.99, p99 ×0.99 /
    /// ×0.99 (both within the runs' spread: not critical on these scenes).
    pub reuse_max_pairs: usize,
    /// A ball region's own pairs serve the next region about a pose it still covers by at least
    /// this share of the allowance wanted (else a fresh detection pays).
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×0.99 / ×1.02, p99 ×1.02 /
    /// ×1.04, node pairs ×0.97 / ×1.09 (halving is at the edge of the runs' spread, doubling costs
    /// more).
    pub recentre_share: f64,
    /// … and by at least this many times the motion predicted for the tool this frame (a tool
    /// about to move farther, e.g. dropping into a hole, needs a detection anyway).
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.00 / ×1.01, p99 ×1.01 /
    /// ×1.01, node pairs ×1.00 / ×1.06 (both within the runs' spread: not critical on these
    /// scenes).
    pub recentre_motion_spare: f64,
    /// A predicted motion shorter than this (mm, largest sphere motion) takes a ball region: a
    /// path region pays off only for a hand in motion.
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.02 / ×1.00, p99 ×1.02 /
    /// ×1.04 (halving is at the edge of the runs' spread, doubling costs more).
    pub min_sweep_mm: f64,
    /// A path region is taken only while its length plus width stays within this many times the
    /// allowance that keeps a ball region near [`Tuning::pair_target`] pairs.
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.00 / ×1.02, p99 ×1.00 /
    /// ×1.03 (doubling costs more; halving stays within the runs' spread).
    pub path_density_factor: f64,
    /// A path region reaches at least this far ahead (mm, largest sphere motion; at most
    /// `max_margin_mm`), so that a slow hand's next frames reuse it.
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.01 / ×0.99, p99 ×1.06 /
    /// ×1.00 (halving costs more; doubling stays within the runs' spread).
    pub path_min_mm: f64,
    /// Least width (mm) of a path region about the predicted path: twice the recent prediction
    /// error, at least this.
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.00 / ×1.00, p99 ×1.01 /
    /// ×1.01 (both within the runs' spread: not critical on these scenes).
    pub path_width_min_mm: f64,
    /// Largest width (mm) of a path region about the predicted path (a tool riding over the
    /// bumps of a sphere-tree surface strays by a few tenths of a millimetre).
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.00 / ×1.00, p99 ×1.00 /
    /// ×1.00 (both within the runs' spread: not critical on these scenes).
    pub path_width_max_mm: f64,
    /// A pass whose answer stayed within this share of its region's width (its motion bound from
    /// the region's centre) crept: its trust box or the contact stopped it well inside its ball,
    /// and the next region's trust box is turned to that pass's motion.
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.01 / ×0.99, p99 ×1.01 /
    /// ×1.00, list entries ×1.01 / ×0.94 (both within the runs' spread: not critical on these
    /// scenes).
    pub creep_share: f64,
    /// A slab region (a tool held by one flat face) allows a slide along the face of at least this
    /// much (mm): its face's pairs do not grow with it, only with the margin across.
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.03 / ×0.98, p99 ×1.02 /
    /// ×0.99 (halving is at the edge of the runs' spread).
    pub slab_slide_mm: f64,
    /// Least margin (mm) across the face of a slab region, over 1.5 times last frame's motion
    /// across it.
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.00 / ×1.02, p99 ×1.01 /
    /// ×1.02 (doubling is at the edge of the runs' spread).
    pub slab_across_min_mm: f64,
    /// How much farther (mm) than a ball region's margin the rest of the tool is from the objects
    /// (the `lever` heuristic's near part of the tool): a turn about the contact (a long tool spinning and rocking on
    /// its tip) is bounded by the near leaves' lever arm, not the far end's reach, while the far
    /// end moves less than this.
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.00 / ×0.99, p99 ×1.01 /
    /// ×0.99 (both within the runs' spread: not critical on these scenes).
    pub lever_margin_mm: f64,
    /// A near part of the tool is found this much (mm) wider than a region needs, and kept for
    /// later regions while the tool stays within it of where it was found (the `lever`
    /// heuristic's near part of the tool).
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.01 / ×0.99, p99 ×1.01 /
    /// ×0.98 (halving is at the edge of the runs' spread).
    pub lever_spare_mm: f64,
    /// Margin (mm) of a detection made in free space: an empty result proves free space this far,
    /// and later frames near the same pose skip their traversals.
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×0.99 / ×1.01, p99 ×0.98 /
    /// ×1.01 (both within the runs' spread: not critical on these scenes).
    pub free_probe_mm: f64,
    /// Margin (mm) of a background probe: wider than a frame's own proof
    /// ([`Tuning::free_probe_mm`]), since its cost is spread over frames and a wider proof lasts
    /// longer per node pair split.
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×0.99 / ×1.00, p99 ×0.98 /
    /// ×1.00 (both within the runs' spread: not critical on these scenes).
    pub background_probe_mm: f64,
    /// Node pairs a background free-space probe aims to split per frame (~15–25 µs): it starts
    /// early enough to finish at this pace before the current proof runs out.
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.01 / ×0.99, p99 ×1.00 /
    /// ×1.00, list entries ×0.93 / ×0.99 (both within the runs' spread: not critical on these
    /// scenes).
    pub probe_slice_splits: usize,
    /// Frames of the tool's steady motion a background probe's path covers, within
    /// [`Tuning::path_probe_min_mm`, `Tuning::path_probe_max_mm`]: where walls run along the motion a path
    /// costs a few times a probe at a pose and covers ten or twenty times the way.
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.00 / ×0.99, p99 ×1.00 /
    /// ×0.99 (both within the runs' spread: not critical on these scenes).
    pub path_probe_frames: f64,
    /// A probe along a path starts when the proofs have this many times its expected slices of
    /// frames left (a path's cost varies more with where it runs than a ball's: one that starts
    /// late ends in long slices).
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.00 / ×1.01, p99 ×1.00 /
    /// ×1.01 (both within the runs' spread: not critical on these scenes).
    pub path_probe_lead: f64,
    /// A background probe starts at the latest when the free-space proof has this many frames of
    /// slack left (earlier when the last probe needed more slices).
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.00 / ×1.00, p99 ×0.99 /
    /// ×1.00 (both within the runs' spread: not critical on these scenes).
    pub probe_lead_frames: f64,
    /// How far past the pose where the current free-space proofs run out a probe is placed, as a
    /// share of a proof's usable radius: a tool moving on as it did crosses the new proof's ball
    /// instead of leaving it from its centre.
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×0.99 / ×1.00, p99 ×0.98 /
    /// ×0.99 (both within the runs' spread: not critical on these scenes).
    pub probe_ahead: f64,
    /// First margin (mm) of a neighbour list; later ones follow the pairs the last one held.
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.00 / ×1.00, p99 ×1.00 /
    /// ×1.01, list entries ×0.95 / ×1.00 (both within the runs' spread: not critical on these
    /// scenes).
    pub list_margin_mm: f64,
    /// On the frame's own thread a neighbour list is built only when its cost per frame of its
    /// life is at most this many times the traversals it would spare (a list also spares the
    /// second regions of a frame and keeps later frames cheap, which the count does not see; the
    /// limit only keeps lists out where they clearly cost more).
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×0.99 / ×1.00, p99 ×0.99 /
    /// ×1.00, list entries ×0.85 / ×0.98 (both within the runs' spread: not critical on these
    /// scenes).
    pub list_payoff: f64,
    /// Neighbour lists are kept only where a region's traversal splits at least this many node
    /// pairs (~30 µs): where regions are cheap a list costs more than it spares.
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.03 / ×0.97, p99 ×1.02 /
    /// ×0.98, list entries ×1.41 / ×0.56 (halving costs more; doubling stays within the runs'
    /// spread).
    pub list_min_region_splits: f64,
    /// On the frame's own thread, a neighbour list is built only while the last ones answered at
    /// least this many times their build's work in regions (regions answered times a region's
    /// node pairs; running mean over the lists taken): [`Tuning::list_payoff`]'s prediction
    /// misses that a list in use shrinks the regions to fit inside it.
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.00 / ×0.99, p99 ×0.98 /
    /// ×0.99, list entries ×1.08 / ×0.89 (both within the runs' spread: not critical on these
    /// scenes).
    pub list_min_yield: f64,
    /// Pairs a neighbour list aims at (filtering them costs ~1 ns each).
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×0.99 / ×1.06, p99 ×1.01 /
    /// ×1.04, node pairs ×0.99 / ×1.10, list entries ×0.49 / ×1.71 (doubling costs more; halving
    /// stays within the runs' spread).
    pub list_target_pairs: f64,
    /// The mesh mode's near list reaches this much (mm) beyond the region's margin: listed once,
    /// it serves the narrow phase of every region it covers (the tool moving up to this much from
    /// where it was listed), so the trees are descended once in several frames.
    ///
    /// Halved / doubled over the zoo in the mesh mode: mean frame time ×1.05 / ×1.02, p99 ×1.04 /
    /// ×1.04; doubled: 3616 degraded frames against 3478 (both cost more).
    pub near_list_mm: f64,
    /// Near-list length aimed at: every region the list serves filters all of it (its plane
    /// bounds, ~30 ns a pair), so 3 000 pairs cost about a tenth of the 1 ms budget a region; a
    /// longer list halves the next one's extra reach, one under a quarter of this doubles it (up
    /// to [`Tuning::near_list_mm`]).
    ///
    /// Halved / doubled over the zoo in the mesh mode: mean frame time ×1.00 / ×1.01, p99 ×1.00 /
    /// ×1.00 (both within the runs' spread: not critical on these scenes).
    pub near_list_pairs: usize,
    /// With [`Heuristics::mesh_near_part`](crate::Heuristics::mesh_near_part), a near list's
    /// near part holds every point of the tool within this much (mm) beyond the list's reach of
    /// the objects: the rest of the tool may move this much farther than the near part before
    /// the list is spent. Wider, more of the tool is near (a longer arm); narrower, a turn of
    /// the whole tool spends the list sooner.
    pub near_part_mm: f64,
    /// With [`Heuristics::mesh_slice_ceiling`](crate::Heuristics::mesh_slice_ceiling), the next
    /// near list's slice takes a frame to this share of the budget at most while the list in
    /// use still holds two more frames: under the p99 target of a quarter of the budget, at
    /// the fill level ([`Tuning::near_fill_share`]). At 0.22 the frames the slices fill sat at
    /// that level instead (`probe` p99 223 against 205 µs, the splined chamfered peg 223
    /// against 204; three runs, the rest within the runs' spread or lower).
    pub near_ceiling_share: f64,
    /// With [`Heuristics::mesh_near_part`](crate::Heuristics::mesh_near_part), a list whose near
    /// part bounded the tool's motion at its end to no less than this share of the whole
    /// tool's bound did not pay for its noting: the next eight lists are listed without one.
    /// With [`Heuristics::mesh_near_part_give_up`](crate::Heuristics::mesh_near_part_give_up),
    /// a descent gives its noting up once the near part reaches this share of the whole tool's
    /// reach from the tool origin, less by the noting's share of the descent's box tests.
    pub near_part_pays: f64,
    /// The next near list is built ahead in slices of at most this share of the frame's budget
    /// (after the frame's own work, never past its deadline): a whole list of a tight fit's wall
    /// costs a few budgets, so it is spread over the frames the current list still serves.
    ///
    /// Halved / doubled over the zoo in the mesh mode: mean frame time ×1.01 / ×1.01, p99 ×1.01 /
    /// ×1.06 (doubling costs more; halving stays within the runs' spread).
    pub near_ahead_share: f64,
    /// With [`Heuristics::mesh_near_fill`](crate::Heuristics::mesh_near_fill), the next near
    /// list's slice fills the frame up to this share of the budget, or gives it the pace its
    /// descent needs to be done in time if that is more (at most
    /// [`Tuning::near_ahead_share`] of the budget either way): a frame's time is then the larger
    /// of its own work and this, not their sum, where the list is on time. A fifth keeps a
    /// frame that builds ahead within a 4 kHz loop's period wherever its own work leaves room.
    ///
    /// Halved / doubled over the built-ins and the zoo in the mesh mode (six passes): mean
    /// frame time ×1.02 / ×0.99, p99 ×1.03 / ×1.00, the shipped values against themselves
    /// ×0.99 / ×0.98 (within the runs' spread: not critical on these scenes; the pegs it is
    /// for are not among them).
    pub near_fill_share: f64,
    /// With [`Heuristics::mesh_fill_own_level`](crate::Heuristics::mesh_fill_own_level), the
    /// share of the frames whose own work the fill level leaves above it (a running quantile
    /// of that work): the slices fill frames up to what the frames' own work already reaches
    /// in its upper tail, so that they do not set the p99 themselves.
    pub own_above_share: f64,
    /// A tool left behind that moved at least this far (mm) in its last frame is falling toward
    /// the hand: its path region is the straight way there.
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.01 / ×1.02, p99 ×1.02 /
    /// ×1.04 (halving is at the edge of the runs' spread, doubling costs more).
    pub fall_min_step_mm: f64,
    /// ... and moved toward the hand: the cosine between its last step and the way to the hand
    /// is at least this (a tool sliding across a face the hand presses into is not falling).
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×0.99 / ×0.99, p99 ×0.99 /
    /// ×0.99 (both within the runs' spread: not critical on these scenes).
    pub fall_min_cos: f64,
    /// Frames without slab regions after one that failed (stopped at the deadline, overflowed, or
    /// listed more than [`Tuning::slab_max_pairs`] pairs or split more than [`Tuning::slab_max_splits`] node
    /// pairs: the other pairs within the slide, of faces whose discs are too small or of the
    /// tool's own bumps, can be many, and the tool's leaves near a face broken by slots are let
    /// go only one by one), doubled after each failure in a row up to [`Tuning::slab_rest_max_frames`].
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.00 / ×1.00, p99 ×1.00 /
    /// ×1.00 (both within the runs' spread: not critical on these scenes).
    pub slab_rest_frames: u32,
    /// Most frames slab regions rest after failures in a row (the rest doubling from
    /// [`Tuning::slab_rest_frames`]).
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.00 / ×1.02, p99 ×1.00 /
    /// ×1.04 (doubling costs more; halving stays within the runs' spread).
    pub slab_rest_max_frames: u32,
    /// Most pairs a slab region may list: it is small by design (a flat contact's: ~50 pairs),
    /// and one past this failed to be.
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.00 / ×0.99, p99 ×1.00 /
    /// ×0.99 (both within the runs' spread: not critical on these scenes).
    pub slab_max_pairs: usize,
    /// Most node pairs a slab region's traversal may split, likewise.
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.00 / ×1.00, p99 ×0.99 /
    /// ×1.01 (both within the runs' spread: not critical on these scenes).
    pub slab_max_splits: usize,
    /// Fewest pairs of a ball region that looks for the near part of the tool: a small contact's
    /// regions are cheap to detect again (a first contact then costs no more than it did).
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.01 / ×0.99, p99 ×1.11 /
    /// ×0.98 (halving costs more; doubling stays within the runs' spread).
    pub lever_min_pairs: usize,
    /// Least margin (mm) of a background probe. A probe that finds a pair within its margin (a
    /// tool turning in a tight groove, 0.1–0.4 mm from its flanks) proves nothing; the next one
    /// asks for less ([`Tuning::probe_margin_shrink`]), down to this.
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×0.99 / ×0.99, p99 ×1.00 /
    /// ×0.98 (both within the runs' spread: not critical on these scenes).
    pub background_probe_min_mm: f64,
    /// Frames of the tool's motion a background probe's margin must hold beyond the frame's own
    /// need, or it is not started (a proof that lasts fewer frames than its slices take is no
    /// use: fresh traversals serve).
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.00 / ×0.99, p99 ×0.99 /
    /// ×0.99 (both within the runs' spread: not critical on these scenes).
    pub probe_min_usable_frames: f64,
    /// A running background probe at a pose is paced to finish this many frames before the
    /// free-space proofs run out (at the tool's last motion); one along a path within
    /// [`Tuning::probe_finish_within`] of their horizon, less these frames (paced over the whole
    /// horizon, a path probe behind a speeding hand falls behind its time-capped slices and
    /// finishes thousands of node pairs in one frame).
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.00 / ×1.00, p99 ×1.00 /
    /// ×1.01 (both within the runs' spread: not critical on these scenes).
    pub probe_finish_spare_frames: f64,
    /// Share of the proofs' horizon (frames) a running background probe along a path is paced to
    /// finish within: the horizon is measured at the last frame's motion, and a hand speeding up
    /// shortens it.
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.00 / ×1.00, p99 ×0.99 /
    /// ×1.01 (both within the runs' spread: not critical on these scenes).
    pub probe_finish_within: f64,
    /// A new background probe's first slice is this share of its paced slice (when the proofs
    /// last more than 2 frames): it meets its part of the trees out of cache, and its node pairs
    /// cost 2–3 times the next slices'.
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.00 / ×1.01, p99 ×1.00 /
    /// ×1.01 (both within the runs' spread: not critical on these scenes).
    pub probe_first_slice_share: f64,
    /// A running background probe is paced for this many times its estimated cost.
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.01 / ×1.01, p99 ×1.04 /
    /// ×1.01 (halving costs more; doubling stays within the runs' spread).
    pub probe_estimate_spare: f64,
    /// A tool sliding at least this far per frame (mm, without turning) gets background probes
    /// along its way ([`collide::FreeSpaceProbe::start_along`]) instead of at a pose.
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.00 / ×1.01, p99 ×1.02 /
    /// ×1.03 (halving is at the edge of the runs' spread, doubling costs more).
    pub path_probe_min_step_mm: f64,
    /// Shortest path (mm) a probe along the tool's way covers ([`Tuning::path_probe_frames`]).
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.00 / ×1.00, p99 ×1.01 /
    /// ×1.01 (both within the runs' spread: not critical on these scenes).
    pub path_probe_min_mm: f64,
    /// Longest path (mm) a probe along the tool's way covers.
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.00 / ×1.00, p99 ×1.00 /
    /// ×1.01 (both within the runs' spread: not critical on these scenes).
    pub path_probe_max_mm: f64,
    /// A background probe that proved free space lets the next one ask for this many times its
    /// margin (up to [`Tuning::background_probe_mm`]): a tool that left a tight gap gets its wide proofs
    /// back within a few probes.
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.00 / ×1.02, p99 ×1.01 /
    /// ×1.03 (doubling is at the edge of the runs' spread).
    pub probe_margin_growth: f64,
    /// Frames the free-space proofs must serve a tool, at its last motion, for it to count as at
    /// rest (a second at 1 kHz): then a background probe widens its proof.
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.06 / ×1.01, p99 ×1.07 /
    /// ×1.04 (both cost more).
    pub rest_horizon_frames: f64,
    /// A tool at rest gets a wider proof when the proofs about it reach less than this share of
    /// the next probe's margin.
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.01 / ×1.01, p99 ×1.02 /
    /// ×1.00 (halving is at the edge of the runs' spread).
    pub probe_widen_ratio: f64,
    /// A background probe that touched lets the next one ask for this share of its margin.
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.01 / ×1.00, p99 ×1.02 /
    /// ×1.04 (halving is at the edge of the runs' spread, doubling costs more).
    pub probe_margin_shrink: f64,
    /// Least margin (mm) of a neighbour list (later ones follow the pairs the last one held).
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×0.99 / ×1.03, p99 ×1.00 /
    /// ×1.02, node pairs ×1.01 / ×1.20, list entries ×0.99 / ×1.11 (doubling costs more; halving
    /// stays within the runs' spread).
    pub list_min_mm: f64,
    /// Largest margin (mm) of a neighbour list.
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×0.99 / ×1.04, p99 ×0.99 /
    /// ×1.06, list entries ×0.85 / ×1.00 (doubling costs more; halving stays within the runs'
    /// spread).
    pub list_max_mm: f64,
    /// The yield assumed before any list has been used: a contact's first list is tried.
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×0.99 / ×1.00, p99 ×1.00 /
    /// ×1.00, list entries ×0.95 / ×0.99 (both within the runs' spread: not critical on these
    /// scenes).
    pub list_first_yield: f64,
    /// Work (node pairs split plus pairs listed) the first neighbour list is expected to cost
    /// (its slices' size), and the node pairs it is expected to split (its cost as
    /// [`Tuning::list_payoff`] weighs it).
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.00 / ×0.99, p99 ×1.00 /
    /// ×0.98 (both within the runs' spread: not critical on these scenes).
    pub list_first_work: usize,
    /// Node pairs the first neighbour list is expected to split.
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.00 / ×1.02, p99 ×1.01 /
    /// ×1.05 (doubling costs more; halving stays within the runs' spread).
    pub list_first_splits: usize,
    /// A neighbour list is built only when it would serve at least this many frames at the
    /// tool's current motion (a fast tool outruns it: its regions are traversed).
    ///
    /// Halved / doubled over the built-ins and the zoo: mean frame time ×1.00 / ×1.00, p99 ×1.01 /
    /// ×1.00 (both within the runs' spread: not critical on these scenes).
    pub list_min_life_frames: f64,
    /// How far ahead (frames at the last frame's speed) the next near list is centred at most: a
    /// slow tool's list centres near it.
    ///
    /// Halved / doubled over the zoo in the mesh mode: mean frame time ×1.00 / ×1.00, p99 ×1.00 /
    /// ×1.01 (both within the runs' spread: not critical on these scenes).
    pub near_ahead_max_frames: f64,
    /// A mesh-mode near list whose extra reach was cut (a tight fit's wall within it) is swept
    /// along the tool's last step times up to this many frames: a tool sliding along a wall
    /// keeps its distances to it while its triangles pass new ones, so a list swept along the
    /// slide serves that many frames where one about the pose alone serves until the tool has
    /// moved its extra reach. A longer sweep lists more pairs, which every region filters, but
    /// leaves the list built ahead more frames to be ready in. (A list whose extra reach would
    /// be spent before the next one's descent is done, a slice a frame, is swept for the
    /// frames that takes, up to this many, whether its reach was cut or not.)
    ///
    /// `spline-tight` at 10 / 20 / 40 / 80 frames (2 runs each): p99 3.6 / 2.9 / 1.6 / 1.5 ms,
    /// frames over 1 ms while the shaft slides in 517–579 / 129–174 / – / 31–84; the quick fit
    /// study's 0.1 mm peg 100 frames over 1 ms at 20, 9 at 80; the mesh zoo unchanged.
    pub near_sweep_frames: f64,
    /// A near list's sweep is at most this long (mm): a fast tool's many frames would list
    /// every pair along a long way (one 6.4 mm sweep of a list about the pose's full reach
    /// overflowed the list's storage and took 5.7 ms), and a fast tool is not served many
    /// frames by any list.
    pub near_sweep_mm: f64,
}

impl Tuning {
    /// The shipped values.
    pub const DEFAULT: Self = Self {
        pass_headroom: 1.25,
        detect_reserve: 0.15,
        pair_target: 1500.0,
        ball_pair_target: 500.0,
        dense_min_allow_mm: 0.03,
        min_allow_mm: 0.1,
        reuse_max_pairs: 2000,
        recentre_share: 0.5,
        recentre_motion_spare: 2.0,
        min_sweep_mm: 0.1,
        path_density_factor: 2.0,
        path_min_mm: 0.2,
        path_width_min_mm: 0.1,
        path_width_max_mm: 0.4,
        creep_share: 0.5,
        slab_slide_mm: 1.0,
        slab_across_min_mm: 0.03,
        lever_margin_mm: 0.8,
        lever_spare_mm: 0.5,
        free_probe_mm: 0.3,
        background_probe_mm: 0.4,
        probe_slice_splits: 800,
        path_probe_frames: 150.0,
        path_probe_lead: 5.0,
        probe_lead_frames: 8.0,
        probe_ahead: 0.7,
        list_margin_mm: 0.6,
        list_payoff: 1.5,
        list_min_region_splits: 800.0,
        list_min_yield: 2.0,
        list_target_pairs: 3000.0,
        near_list_mm: 0.25,
        near_list_pairs: 3000,
        near_part_mm: 0.8,
        near_ceiling_share: 0.2,
        near_part_pays: 0.9,
        near_ahead_share: 0.15,
        near_fill_share: 0.2,
        own_above_share: 0.05,
        fall_min_step_mm: 0.1,
        fall_min_cos: 0.9,
        slab_rest_frames: 100,
        slab_rest_max_frames: 12_800,
        slab_max_pairs: 500,
        slab_max_splits: 8_000,
        lever_min_pairs: 100,
        background_probe_min_mm: 0.05,
        probe_min_usable_frames: 2.0,
        probe_finish_spare_frames: 2.0,
        probe_finish_within: 0.75,
        probe_first_slice_share: 0.5,
        probe_estimate_spare: 1.25,
        path_probe_min_step_mm: 0.005,
        path_probe_min_mm: 0.5,
        path_probe_max_mm: 10.0,
        probe_margin_growth: 1.5,
        rest_horizon_frames: 1000.0,
        probe_widen_ratio: 0.8,
        probe_margin_shrink: 0.7,
        list_min_mm: 0.3,
        list_max_mm: 2.0,
        list_first_yield: 10.0,
        list_first_work: 8000,
        list_first_splits: 5000,
        list_min_life_frames: 3.0,
        near_ahead_max_frames: 50.0,
        near_sweep_frames: 80.0,
        near_sweep_mm: 4.0,
    };

    /// A field's value by its name in [`Tuning::NAMES`] (counts as `f64`).
    pub fn get(&self, name: &str) -> Option<f64> {
        Some(match name {
            "pass-headroom" => self.pass_headroom,
            "detect-reserve" => self.detect_reserve,
            "pair-target" => self.pair_target,
            "ball-pair-target" => self.ball_pair_target,
            "dense-min-allow-mm" => self.dense_min_allow_mm,
            "min-allow-mm" => self.min_allow_mm,
            "reuse-max-pairs" => self.reuse_max_pairs as f64,
            "recentre-share" => self.recentre_share,
            "recentre-motion-spare" => self.recentre_motion_spare,
            "min-sweep-mm" => self.min_sweep_mm,
            "path-density-factor" => self.path_density_factor,
            "path-min-mm" => self.path_min_mm,
            "path-width-min-mm" => self.path_width_min_mm,
            "path-width-max-mm" => self.path_width_max_mm,
            "creep-share" => self.creep_share,
            "slab-slide-mm" => self.slab_slide_mm,
            "slab-across-min-mm" => self.slab_across_min_mm,
            "lever-margin-mm" => self.lever_margin_mm,
            "lever-spare-mm" => self.lever_spare_mm,
            "free-probe-mm" => self.free_probe_mm,
            "background-probe-mm" => self.background_probe_mm,
            "probe-slice-splits" => self.probe_slice_splits as f64,
            "path-probe-frames" => self.path_probe_frames,
            "path-probe-lead" => self.path_probe_lead,
            "probe-lead-frames" => self.probe_lead_frames,
            "probe-ahead" => self.probe_ahead,
            "list-margin-mm" => self.list_margin_mm,
            "list-payoff" => self.list_payoff,
            "list-min-region-splits" => self.list_min_region_splits,
            "list-min-yield" => self.list_min_yield,
            "list-target-pairs" => self.list_target_pairs,
            "near-list-mm" => self.near_list_mm,
            "near-list-pairs" => self.near_list_pairs as f64,
            "near-part-mm" => self.near_part_mm,
            "near-ceiling-share" => self.near_ceiling_share,
            "near-part-pays" => self.near_part_pays,
            "near-ahead-share" => self.near_ahead_share,
            "near-fill-share" => self.near_fill_share,
            "own-above-share" => self.own_above_share,
            "fall-min-step-mm" => self.fall_min_step_mm,
            "fall-min-cos" => self.fall_min_cos,
            "slab-rest-frames" => f64::from(self.slab_rest_frames),
            "slab-rest-max-frames" => f64::from(self.slab_rest_max_frames),
            "slab-max-pairs" => self.slab_max_pairs as f64,
            "slab-max-splits" => self.slab_max_splits as f64,
            "lever-min-pairs" => self.lever_min_pairs as f64,
            "background-probe-min-mm" => self.background_probe_min_mm,
            "probe-min-usable-frames" => self.probe_min_usable_frames,
            "probe-finish-spare-frames" => self.probe_finish_spare_frames,
            "probe-finish-within" => self.probe_finish_within,
            "probe-first-slice-share" => self.probe_first_slice_share,
            "probe-estimate-spare" => self.probe_estimate_spare,
            "path-probe-min-step-mm" => self.path_probe_min_step_mm,
            "path-probe-min-mm" => self.path_probe_min_mm,
            "path-probe-max-mm" => self.path_probe_max_mm,
            "probe-margin-growth" => self.probe_margin_growth,
            "rest-horizon-frames" => self.rest_horizon_frames,
            "probe-widen-ratio" => self.probe_widen_ratio,
            "probe-margin-shrink" => self.probe_margin_shrink,
            "list-min-mm" => self.list_min_mm,
            "list-max-mm" => self.list_max_mm,
            "list-first-yield" => self.list_first_yield,
            "list-first-work" => self.list_first_work as f64,
            "list-first-splits" => self.list_first_splits as f64,
            "list-min-life-frames" => self.list_min_life_frames,
            "near-ahead-max-frames" => self.near_ahead_max_frames,
            "near-sweep-frames" => self.near_sweep_frames,
            "near-sweep-mm" => self.near_sweep_mm,
            _ => return None,
        })
    }

    /// These values with one field set by its name in [`Tuning::NAMES`] (a count rounded to
    /// the nearest); `None` for an unknown name. [`Tuning::validate`] checks the result.
    pub fn with(mut self, name: &str, value: f64) -> Option<Self> {
        match name {
            "pass-headroom" => self.pass_headroom = value,
            "detect-reserve" => self.detect_reserve = value,
            "pair-target" => self.pair_target = value,
            "ball-pair-target" => self.ball_pair_target = value,
            "dense-min-allow-mm" => self.dense_min_allow_mm = value,
            "min-allow-mm" => self.min_allow_mm = value,
            "reuse-max-pairs" => self.reuse_max_pairs = value.round() as usize,
            "recentre-share" => self.recentre_share = value,
            "recentre-motion-spare" => self.recentre_motion_spare = value,
            "min-sweep-mm" => self.min_sweep_mm = value,
            "path-density-factor" => self.path_density_factor = value,
            "path-min-mm" => self.path_min_mm = value,
            "path-width-min-mm" => self.path_width_min_mm = value,
            "path-width-max-mm" => self.path_width_max_mm = value,
            "creep-share" => self.creep_share = value,
            "slab-slide-mm" => self.slab_slide_mm = value,
            "slab-across-min-mm" => self.slab_across_min_mm = value,
            "lever-margin-mm" => self.lever_margin_mm = value,
            "lever-spare-mm" => self.lever_spare_mm = value,
            "free-probe-mm" => self.free_probe_mm = value,
            "background-probe-mm" => self.background_probe_mm = value,
            "probe-slice-splits" => self.probe_slice_splits = value.round() as usize,
            "path-probe-frames" => self.path_probe_frames = value,
            "path-probe-lead" => self.path_probe_lead = value,
            "probe-lead-frames" => self.probe_lead_frames = value,
            "probe-ahead" => self.probe_ahead = value,
            "list-margin-mm" => self.list_margin_mm = value,
            "list-payoff" => self.list_payoff = value,
            "list-min-region-splits" => self.list_min_region_splits = value,
            "list-min-yield" => self.list_min_yield = value,
            "list-target-pairs" => self.list_target_pairs = value,
            "near-list-mm" => self.near_list_mm = value,
            "near-list-pairs" => self.near_list_pairs = value.round() as usize,
            "near-part-mm" => self.near_part_mm = value,
            "near-ceiling-share" => self.near_ceiling_share = value,
            "near-part-pays" => self.near_part_pays = value,
            "near-ahead-share" => self.near_ahead_share = value,
            "near-fill-share" => self.near_fill_share = value,
            "own-above-share" => self.own_above_share = value,
            "fall-min-step-mm" => self.fall_min_step_mm = value,
            "fall-min-cos" => self.fall_min_cos = value,
            "slab-rest-frames" => self.slab_rest_frames = value.round() as u32,
            "slab-rest-max-frames" => self.slab_rest_max_frames = value.round() as u32,
            "slab-max-pairs" => self.slab_max_pairs = value.round() as usize,
            "slab-max-splits" => self.slab_max_splits = value.round() as usize,
            "lever-min-pairs" => self.lever_min_pairs = value.round() as usize,
            "background-probe-min-mm" => self.background_probe_min_mm = value,
            "probe-min-usable-frames" => self.probe_min_usable_frames = value,
            "probe-finish-spare-frames" => self.probe_finish_spare_frames = value,
            "probe-finish-within" => self.probe_finish_within = value,
            "probe-first-slice-share" => self.probe_first_slice_share = value,
            "probe-estimate-spare" => self.probe_estimate_spare = value,
            "path-probe-min-step-mm" => self.path_probe_min_step_mm = value,
            "path-probe-min-mm" => self.path_probe_min_mm = value,
            "path-probe-max-mm" => self.path_probe_max_mm = value,
            "probe-margin-growth" => self.probe_margin_growth = value,
            "rest-horizon-frames" => self.rest_horizon_frames = value,
            "probe-widen-ratio" => self.probe_widen_ratio = value,
            "probe-margin-shrink" => self.probe_margin_shrink = value,
            "list-min-mm" => self.list_min_mm = value,
            "list-max-mm" => self.list_max_mm = value,
            "list-first-yield" => self.list_first_yield = value,
            "list-first-work" => self.list_first_work = value.round() as usize,
            "list-first-splits" => self.list_first_splits = value.round() as usize,
            "list-min-life-frames" => self.list_min_life_frames = value,
            "near-ahead-max-frames" => self.near_ahead_max_frames = value,
            "near-sweep-frames" => self.near_sweep_frames = value,
            "near-sweep-mm" => self.near_sweep_mm = value,
            _ => return None,
        }
        Some(self)
    }

    /// Checks that every value is finite and positive, every share at most 1 (the detection
    /// reserve below it) and the path width's bounds in order; the first bad one is named.
    pub fn validate(&self) -> Result<(), crate::config::SettingError> {
        let bad = |name: &str, v: f64, expected: &str| crate::config::SettingError {
            key: format!("tuning {name}"),
            value: format!("{v}"),
            expected: expected.to_string(),
        };
        for name in Self::NAMES {
            let v = self.get(name).unwrap_or(f64::NAN);
            if !(v.is_finite() && v > 0.0) {
                return Err(bad(name, v, "a finite number above 0"));
            }
            if name.ends_with("-share") && v > 1.0 {
                return Err(bad(name, v, "a share in (0, 1]"));
            }
        }
        if self.detect_reserve >= 1.0 {
            return Err(bad("detect-reserve", self.detect_reserve, "below 1"));
        }
        // Bounds that clamp a value must stay in order.
        for (low, lo, high, hi) in [
            (
                "path-width-min-mm",
                self.path_width_min_mm,
                "path-width-max-mm",
                self.path_width_max_mm,
            ),
            (
                "path-probe-min-mm",
                self.path_probe_min_mm,
                "path-probe-max-mm",
                self.path_probe_max_mm,
            ),
            (
                "list-min-mm",
                self.list_min_mm,
                "list-max-mm",
                self.list_max_mm,
            ),
            (
                "background-probe-min-mm",
                self.background_probe_min_mm,
                "background-probe-mm",
                self.background_probe_mm,
            ),
            (
                "slab-rest-frames",
                f64::from(self.slab_rest_frames),
                "slab-rest-max-frames",
                f64::from(self.slab_rest_max_frames),
            ),
        ] {
            if lo > hi {
                return Err(bad(low, lo, &format!("at most {high} ({hi})")));
            }
        }
        Ok(())
    }

    /// Every field's name: the field's with dashes, as the tuning study names it.
    pub const NAMES: [&'static str; 68] = [
        "pass-headroom",
        "detect-reserve",
        "pair-target",
        "ball-pair-target",
        "dense-min-allow-mm",
        "min-allow-mm",
        "reuse-max-pairs",
        "recentre-share",
        "recentre-motion-spare",
        "min-sweep-mm",
        "path-density-factor",
        "path-min-mm",
        "path-width-min-mm",
        "path-width-max-mm",
        "creep-share",
        "slab-slide-mm",
        "slab-across-min-mm",
        "lever-margin-mm",
        "lever-spare-mm",
        "free-probe-mm",
        "background-probe-mm",
        "probe-slice-splits",
        "path-probe-frames",
        "path-probe-lead",
        "probe-lead-frames",
        "probe-ahead",
        "list-margin-mm",
        "list-payoff",
        "list-min-region-splits",
        "list-min-yield",
        "list-target-pairs",
        "near-list-mm",
        "near-list-pairs",
        "near-part-mm",
        "near-ceiling-share",
        "near-part-pays",
        "near-ahead-share",
        "near-fill-share",
        "own-above-share",
        "fall-min-step-mm",
        "fall-min-cos",
        "slab-rest-frames",
        "slab-rest-max-frames",
        "slab-max-pairs",
        "slab-max-splits",
        "lever-min-pairs",
        "background-probe-min-mm",
        "probe-min-usable-frames",
        "probe-finish-spare-frames",
        "probe-finish-within",
        "probe-first-slice-share",
        "probe-estimate-spare",
        "path-probe-min-step-mm",
        "path-probe-min-mm",
        "path-probe-max-mm",
        "probe-margin-growth",
        "rest-horizon-frames",
        "probe-widen-ratio",
        "probe-margin-shrink",
        "list-min-mm",
        "list-max-mm",
        "list-first-yield",
        "list-first-work",
        "list-first-splits",
        "list-min-life-frames",
        "near-ahead-max-frames",
        "near-sweep-frames",
        "near-sweep-mm",
    ];
}

impl Default for Tuning {
    fn default() -> Self {
        Self::DEFAULT
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_name_reads_and_sets_its_own_field() {
        for name in Tuning::NAMES {
            let v = Tuning::DEFAULT.get(name).unwrap();
            let t = Tuning::DEFAULT.with(name, 2.0 * v).unwrap();
            assert_eq!(t.get(name), Some(2.0 * v), "{name}");
            // No other field moved.
            for other in Tuning::NAMES.iter().filter(|o| **o != name) {
                assert_eq!(
                    t.get(other),
                    Tuning::DEFAULT.get(other),
                    "{name} moved {other}"
                );
            }
        }
        assert_eq!(Tuning::DEFAULT.get("pair_target"), None);
        assert_eq!(Tuning::DEFAULT.with("no-such-value", 1.0), None);
    }

    #[test]
    fn bad_values_are_refused_by_name() {
        assert!(Tuning::DEFAULT.validate().is_ok());
        for (name, value, says) in [
            ("pair-target", 0.0, "above 0"),
            ("lever-margin-mm", f64::NAN, "above 0"),
            ("creep-share", 1.5, "share"),
            ("detect-reserve", 1.0, "below 1"),
            ("path-width-min-mm", 0.5, "at most path-width-max-mm"),
        ] {
            let e = Tuning::DEFAULT
                .with(name, value)
                .unwrap()
                .validate()
                .unwrap_err();
            let text = e.to_string();
            assert!(text.contains(name) && text.contains(says), "{text}");
        }
    }
}
