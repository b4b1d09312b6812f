//! The god-object step: one haptic frame (docs/DESIGN.md, "The frame step").
//!
//! Given the device configuration `q_h` and the last graphic configuration `q_g_prev`, a frame
//! makes one or more **passes** from a linearisation pose `q_lin` (first `q_g_prev`):
//!
//! 1. **Region.** A tool point `p` (tool frame) moving from `(R_a, t_a)` to `(R_b, t_b)` moves
//!    by at most `|t_b - t_a| + θ |p|` (`θ` the angle of `R_b R_a^T`); with `reach` the largest
//!    `|p|` over tool leaf centres, `|Δt| + θ · reach` bounds every sphere's motion. A region
//!    lists every leaf pair within `allowance + skin` at `q_lin`: every pair that can touch
//!    while no sphere moves more than the allowance. The allowance follows the last frame's
//!    motion, is capped by `max_margin_mm` and by the pair density (dense contacts take smaller
//!    regions); when it does not reach the hand a **trust box** (12 rows) keeps the iterates
//!    inside it. An empty region is remembered as a free-space proof that spares later
//!    traversals near the same pose.
//! 2. **Constrain**: rows `J dq >= d` linearized at `q_lin` ([`collide::Linearization`]), in
//!    rotation-vector coordinates by default (a local rotation increment about `q_lin`, world
//!    axes: no Euler singularity, any representation of `R_h` gives the same frame) or the
//!    paper's Euler coordinates.
//! 3. **Solve** `min 1/2 dq^T G dq` with the chosen solver, warm-started from the last active
//!    pairs; map the answer back to a configuration `q_new`.
//! 4. **Verify**: an answer that left its region is discarded and the region detected again,
//!    wider. Otherwise the listed pairs' exact gaps at `q_new` give the deepest overlap and how
//!    far the rows holding the tool are still open in truth.
//! 5. **Iterate**: penetrating, or held by rows that are open, re-linearise at `q_new` on the
//!    same pairs; free and converged but stopped by the trust box, detect a new region from
//!    `q_new`; otherwise the frame has reached the constrained optimum.
//! 6. **Force** from the spring between `q_g` and `q_h`: `F = kt (t_g - t_h)` (N) and
//!    `T = kr log(R_g R_h^T)` (N·mm, world axes; the exact gradient of the spring energy
//!    `kr/2 |log(R_g R_h^T)|^2`), or the paper's `kr (euler_g - euler_h)` in Euler coordinates.
//!
//! A hand in motion takes a **path region** instead of a ball: the pairs along the motion
//! predicted for the tool (it keeps last frame's offset from the hand), with a slab about the
//! path as its trust region; a detected region is reused by later frames while the tool and
//! its prediction stay inside it.
//!
//! The stages live in their own files: `detect.rs` (regions, prediction, free-space proof),
//! `constrain.rs` (rows and trust regions), `solve.rs` (the QP and its warm start),
//! `measure.rs` (exact gaps, the spring wrench); this file holds the state and the pass loop.
//!
//! Passes stop at `1 + relinearize` or when the next one would overrun `budget_us`. A frame that
//! stops before the optimum is **lagging**: it returns the last pose proven free (never a
//! penetrating one) and says so in its [`Frame::status`](crate::Frame::status). A frame that fails (non-finite input,
//! solver breakdown, a capped or infeasible QP) keeps the last safe `q_g`.

use std::time::{Duration, Instant};

use collide::{
    rotation_exp, rotation_log, BackgroundList, CentreBox, CollideWorkspace, FaceSlab,
    FreeSpaceProbe, LeafPair, Linearization, ListStatus, NeighbourList, PackedTree, Pose,
    ProbeStatus, RotationCoordinates, Sweep, TraversalTeam,
};
use nalgebra::{Matrix3, Vector3};
use qp::{Problem, RowGeneration, Solver, Status};
use spheretree::SphereTree;

use crate::{EngineConfig, EngineError, Geometry, MeshRef};

mod constrain;
mod density;
mod detect;
mod frame;
mod friction;
mod heuristics;
mod measure;
mod narrow;
mod plan;
mod reference;
mod solve;
mod state;

use narrow::{Meshes, TriPair};
use state::*;

use frame::Flow;

pub use friction::{Friction, FrictionState};
pub use heuristics::Heuristics;
pub use solve::ReductionAudit;

use measure::rotation_angle;
pub use measure::spring_wrench;

/// How a frame ended.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FrameStatus {
    /// Solved: the constrained optimum (within the penetration tolerance).
    #[default]
    Ok,
    /// The QP answer violates its linearized constraints beyond the solver tolerance (its KKT
    /// certificate), e.g. PQP stopped early; its `q_g` was used.
    Inexact,
    /// More pairs than `max_pairs` even in the smallest region: no answer was proven, the last
    /// pose proven free is kept (the tool lags, it never penetrates).
    PairOverflow,
    /// Passes or budget ran out before the optimum: `q_g` is the last pose proven free on the
    /// way to it (the tool lags the hand this frame, it never penetrates).
    Lagging,
    /// The frame failed (non-finite input or numerical breakdown): the last safe `q_g` kept.
    KeptLastSafe,
}

impl FrameStatus {
    /// The name written in `frames.csv`: `ok`, `inexact`, `pair-overflow`, `lagging`,
    /// `kept-last-safe`.
    pub fn name(&self) -> &'static str {
        match self {
            Self::Ok => "ok",
            Self::Inexact => "inexact",
            Self::PairOverflow => "pair-overflow",
            Self::Lagging => "lagging",
            Self::KeptLastSafe => "kept-last-safe",
        }
    }
}

/// The result of one step: a [`Frame`](crate::Frame) whose `wrench` and `raw_wrench` are both
/// the spring wrench (before the safety layer), with `t = 0` and `safety = 0`;
/// [`Engine::step`](crate::Engine::step) fills in the time and the safety layer's result.
pub type FrameOutput = crate::Frame;

/// A leaf pair whose exact gap (mm) at the answer is at most this is counted as touching
/// ([`Frame::contacts`](crate::Frame::contacts)).
pub const TOUCH_MM: f64 = 0.01;

/// A row whose linearized gap at the answer is below this (mm) holds the tool.
const TIGHT_MM: f64 = 1e-6;

/// The frame has reached the optimum when no holding row is open by more than this in truth
/// (mm): a further pass would move the tool by about this much.
const CONVERGED_MM: f64 = 0.005;

/// Leaf pairs a detected region aims at: a dense contact takes smaller regions (more passes)
/// rather than one region of tens of thousands of rows.
const PAIR_TARGET: f64 = 1500.0;

/// Leaf pairs a ball region aims at in a dense contact (paths and free-space probes keep
/// [`PAIR_TARGET`]). A ball region is detected again every few frames of a turning or pressed
/// contact, and a dense one's cost grows faster than its life: measured on the spline's
/// alignment (shaft spun on the hub's face), 500 pairs against 1 500 took its frames over
/// 250 µs from 64 to 6 (cost model fitted to measured frames; measured p99 401 → 249 µs,
/// docs/design-notes.md §Regions, trust boxes and passes).
const BALL_PAIR_TARGET: f64 = 500.0;

/// Least allowance (mm) the pair density may give a ball region: a dense contact's regions
/// may be thinner than [`MIN_ALLOW_MM`] (the spline's alignment: ~0.1 mm of margin holds
/// 1 500 pairs of its bumpy faces).
const DENSE_MIN_ALLOW_MM: f64 = 0.03;

/// Margin (mm) of a detection made in free space: an empty result proves free space this far,
/// and later frames near the same pose skip their traversals.
const FREE_PROBE_MM: f64 = 0.3;

/// How much less than the proven gap (mm) a free-space proof from a proving traversal claims:
/// a pair may lie at the gap itself.
const PROOF_ROUNDING_MM: f64 = 1e-6;

/// Margin (mm) of a background probe: wider than a frame's own proof, since its cost is spread
/// over frames and a wider proof lasts longer per node pair split (measured in the spline's
/// hole: 0.4 mm costs ~20 % more than 0.3 mm and covers ~40 % more of the way).
const BACKGROUND_PROBE_MM: f64 = 0.4;

/// Least margin (mm) of a background probe. A probe that finds a pair within its margin (a
/// tool turning in a tight groove: the spline's keys 0.1–0.4 mm from the keyways' flanks)
/// proves nothing; the next one asks for less ([`PROBE_MARGIN_SHRINK`]), down to this.
const BACKGROUND_PROBE_MIN_MM: f64 = 0.05;

/// Frames of the tool's motion a background probe's margin must hold beyond the frame's own
/// need, or it is not started (a proof that lasts fewer frames than its slices take is no
/// use: fresh traversals serve).
const PROBE_MIN_USABLE_FRAMES: f64 = 2.0;

/// Node pairs a background free-space probe aims to split per frame (~15–25 µs): it starts
/// early enough to finish at this pace before the current proof runs out.
const PROBE_SLICE_SPLITS: usize = 800;

/// A running background probe at a pose is paced to finish this many frames before the
/// free-space proofs run out (at the tool's last motion); one along a path within
/// [`PROBE_FINISH_WITHIN`] of their horizon, less these frames. Spread over the whole horizon,
/// the spline's keys turning in their grooves split at most 775 node pairs a frame, against
/// 1 948 finishing within half of it; a path probe paced over the whole horizon (the
/// withdrawal, 20 000 node pairs, the hand speeding up) fell behind its time-capped slices and
/// finished 4 000 in one frame.
const PROBE_FINISH_SPARE_FRAMES: f64 = 2.0;

/// Share of the proofs' horizon (frames) a running background probe along a path is paced to
/// finish within (the horizon is measured at the last frame's motion, and a hand speeding up
/// shortens it). At half, the spline's first path probe into the hole (estimated at four times
/// a probe at a pose: 8 460 node pairs, 3 439 in fact) ran 530 a frame, and 49 frames in the
/// hole split over 350; at three quarters 15 do, the hole splits 16 % fewer node pairs in all
/// (no probe finishes late: no traversal replaces one), and its frames' per-frame minimum over
/// 10 runs drops at p99 from 41.2 to 34.5 µs, at most from 89 to 69 µs.
const PROBE_FINISH_WITHIN: f64 = 0.75;

/// A new background probe's first slice is this share of its paced slice (when the proofs
/// last more than 2 frames): it meets its part of the trees out of cache, and its node pairs
/// cost 2–3 times the next slices' (per-frame minimum of 30 runs of the spline: 372 node pairs
/// in 61 µs, then 350 in 42; 210 in 57, then 203 in 34). In the spline's hole the largest frame
/// splits 566 node pairs instead of 775 and 10 frames split over 350 instead of 15.
const PROBE_FIRST_SLICE_SHARE: f64 = 0.5;

/// A running background probe is paced for this many times its estimated cost.
const PROBE_ESTIMATE_SPARE: f64 = 1.25;

/// Share of the frame's budget a background probe's slice may take while the free-space
/// proofs still serve the next two frames (30 µs at 1 kHz): its node pairs are counted ahead of
/// time at a pose probe's cost, and a path probe's cost ~3 times as much (measured: 2 330
/// node pairs of a path probe in the spline's hole took 736 µs).
const PROBE_SLICE_MAX_SHARE: f64 = 0.03;

/// Share of the frame's budget a background probe's slice may take when the proofs run out
/// within two frames (100 µs at 1 kHz). A probe still unfinished when they do is carried on
/// to the frame's deadline, or replaced by a fresh traversal if it does not cover the tool.
const PROBE_SLICE_URGENT_SHARE: f64 = 0.1;

/// Node pairs between two clock reads when a probe is finished within a frame's deadline.
const PROBE_FINISH_SLICE_SPLITS: usize = 256;

/// Fewest node pairs a running probe splits in a frame.
const PROBE_MIN_SLICE_SPLITS: usize = 300;

/// Most node pairs a background probe splits in one frame (~100–250 µs), when its proof is
/// about to run out.
const PROBE_MAX_SLICE_SPLITS: usize = 5000;

/// A tool sliding at least this far per frame (mm, without turning) gets background probes
/// along its way ([`collide::FreeSpaceProbe::start_along`]) instead of at a pose.
const PATH_PROBE_MIN_STEP_MM: f64 = 0.005;

/// Frames of the tool's steady motion a background probe's path covers, within
/// [`PATH_PROBE_MIN_MM`, `PATH_PROBE_MAX_MM`] (measured in the spline's hole, on the way out: a
/// 3 mm path costs 1.7 times a probe at a pose and covers 11 times the way, 6 mm 1.7 and 21
/// times; on the way in, 3 mm 3.9 and 11 times; 150 frames gave an in-hole p99 as low as 250
/// or 400).
const PATH_PROBE_FRAMES: f64 = 150.0;
const PATH_PROBE_MIN_MM: f64 = 0.5;
const PATH_PROBE_MAX_MM: f64 = 10.0;

/// Node pairs a probe along a path aims to split per frame, and the fewest it splits (a swept
/// node pair costs ~70 ns against ~40 for one at a pose: ~25 µs and ~10 µs).
const PATH_PROBE_SLICE_SPLITS: usize = 350;
const PATH_PROBE_MIN_SLICE_SPLITS: usize = 150;

/// A probe along a path starts when the proofs have this many times its expected slices of
/// frames left (a path's cost varies more with where it runs than a ball's: one that starts
/// late ends in long slices).
/// (Measured in the spline's hole, one thread: 1.5 → in-hole p99 99–102 µs, 3 → 91–95,
/// 5 → 66–87, 8 → 95–110: earlier still keeps a probe running in more frames.)
const PATH_PROBE_LEAD: f64 = 5.0;

/// A background probe starts at the latest when the free-space proof has this many frames of
/// slack left (earlier when the last probe needed more slices).
const PROBE_LEAD_FRAMES: f64 = 8.0;

/// How far past the pose where the current free-space proofs run out a probe is placed, as a
/// share of a proof's usable radius: a tool moving on as it did crosses the new proof's ball
/// instead of leaving it from its centre (a proof covers ~1.7 times as much of the way).
const PROBE_AHEAD: f64 = 0.7;

/// A background probe that proved free space lets the next one ask for this many times its
/// margin (up to [`BACKGROUND_PROBE_MM`]): a tool that left a tight groove gets its wide
/// proofs back within a few probes.
const PROBE_MARGIN_GROWTH: f64 = 1.5;

/// Frames the free-space proofs must serve a tool, at its last motion, for it to count as at
/// rest (a second at 1 kHz): then a background probe widens its proof.
const REST_HORIZON_FRAMES: f64 = 1000.0;

/// A tool at rest gets a wider proof when the proofs about it reach less than this share of
/// the next probe's margin.
const PROBE_WIDEN_RATIO: f64 = 0.8;

/// A background probe that touched lets the next one ask for this share of its margin.
const PROBE_MARGIN_SHRINK: f64 = 0.7;

/// A pass starts only if the frame's time so far plus this many times its longest pass stays
/// within `budget_us` (measured: 1.5 kept the puck at 1 m/s lagging in ~220 frames of 1 341, 1.25
/// in ~130, with the spline's worst frame under 1 ms either way now that traversals and solves
/// stop at the deadline; 1.0 let more passes start that the deadline then cut).
const PASS_HEADROOM: f64 = 1.25;

/// Share of the frame budget kept after the last traversal may run for that pass's rows,
/// solve and check: a traversal still running at `(1 - DETECT_RESERVE) · budget_us` stops,
/// and the frame ends lagging at its last proven pose.
const DETECT_RESERVE: f64 = 0.15;

/// First margin (mm) of a neighbour list; later ones follow the pairs the last one held.
const LIST_MARGIN_MM: f64 = 0.6;

/// Bounds (mm) of a neighbour list's margin.
const LIST_MIN_MM: f64 = 0.3;
const LIST_MAX_MM: f64 = 2.0;

/// On the frame's own thread a neighbour list is built only when its cost per frame of its
/// life is at most this many times the traversals it would spare (measured on the puck at
/// 50 mm/s, p99: 0.7 → 203 µs, 1.0 → 191, 1.5 → 149, no limit → 145, no lists → 182: a list
/// also spares the second regions of a frame and keeps later frames cheap, which the count
/// does not see; the limit only keeps lists out where they clearly cost more).
const LIST_PAYOFF: f64 = 1.5;

/// Neighbour lists are kept only where a region's traversal splits at least this many node
/// pairs (~30 µs). Measured on the bunny (regions of 60–170 splits): lists everywhere raised
/// its p99 from 20–31 to 32–39 µs; with this floor they come only in its heavier contacts,
/// and its p99 is 17–18 µs.
const LIST_MIN_REGION_SPLITS: f64 = 800.0;

/// On the frame's own thread, a neighbour list is built only while the last ones answered at
/// least this many times their build's work in regions (regions answered times a region's
/// node pairs; running mean over the lists taken). [`LIST_PAYOFF`]'s prediction misses that a
/// list in use shrinks the regions to fit inside it (more regions, each cheaper to answer):
/// in the spline's alignment, lists built every ~20 frames answered 0.5–2 times their work
/// by this count, and without them the run split 32 % fewer node pairs in all. With this
/// floor the spline splits 13 % fewer (the alignment 17 %), the bunny's frames are unchanged
/// (its lists answer 10–85 times their work), and the puck on a plate without face caps
/// turning at 1 rad/s halves its median frame (docs/design-notes.md §Neighbour lists).
const LIST_MIN_YIELD: f64 = 2.0;

/// The yield assumed before any list has been used: a contact's first list is tried.
const LIST_FIRST_YIELD: f64 = 10.0;

/// Per frame with no list building, the yield recovers by this factor (2 from 0.8 in ~46
/// frames), so a contact whose lists did not pay tries one again soon: after the spline's
/// drop, where lists answer the shaft's turn in the keyways (at 1.005 the list came late
/// there, and one frame split 2 310 node pairs instead of 775).
const LIST_YIELD_RECOVERY: f64 = 1.02;

/// Pairs a neighbour list aims at (filtering them costs ~1 ns each).
const LIST_TARGET_PAIRS: f64 = 3000.0;

/// Most pairs a neighbour list holds; a build past it is dropped and the margin shrunk.
const LIST_MAX_PAIRS: usize = 8192;

/// Work (node pairs split plus pairs listed) the first neighbour list is expected to cost
/// (its slices' size), and the node pairs it is expected to split (its cost as
/// [`LIST_PAYOFF`] weighs it).
const LIST_FIRST_WORK: usize = 8000;
const LIST_FIRST_SPLITS: usize = 5000;

/// A neighbour list is built only when it would serve at least this many frames at the
/// tool's current motion (a fast tool outruns it: its regions are traversed).
const LIST_MIN_LIFE_FRAMES: f64 = 3.0;

/// Most work (node pairs split plus pairs listed, [`collide::NeighbourList::work`]) a frame
/// spends building the next neighbour list on its own thread (~50–100 µs): a list late for
/// its use costs the traversals it would have spared, a long slice costs the frame. (Counted
/// in splits alone, the same slice took 140–430 µs in the spline's grooves, where a list
/// holds 3 500 pairs for 5 000 splits.)
const LIST_MAX_SLICE_WORK: usize = 1280;

/// Work a frame grants the next neighbour list's build when a helper thread builds it
/// (~300 µs of the helper's time): the list is then ready a frame or two after it starts.
const LIST_HELPER_WORK_PER_FRAME: usize = 8192;

/// Node pairs (probe) or units of list work a paced loop's wait runs between clock reads
/// ([`GodObject::idle`]): ~10–40 µs, so the wait ends within that of its limit.
const IDLE_SLICE_SPLITS: usize = 128;

/// The end of a paced loop's wait kept for warming the caches, µs ([`GodObject::idle`]).
const IDLE_WARM_US: u64 = 60;

/// A wait of at least this (µs) before a frame builds most of the next neighbour list: a list
/// is then kept wherever it lasts, its build no longer weighed against the traversals it
/// spares (paced spline, 14 runs each: whole p99 min / second 203 / 297 against 308 / 311 µs,
/// the median within the spread). At 1 kHz the wait is ~380 µs.
const IDLE_FOR_LISTS_US: u64 = 200;

/// Smallest motion allowance of a detected region, mm.
const MIN_ALLOW_MM: f64 = 0.1;

/// A ball region's own pairs serve the next region about a pose it still covers by at least
/// this share of the allowance wanted (else a fresh detection pays).
const RECENTRE_SHARE: f64 = 0.5;

/// … and by at least this many times the motion predicted for the tool this frame (a tool
/// about to move farther, as the spline's shaft dropping 2 mm, needs a detection anyway).
const RECENTRE_MOTION_SPARE: f64 = 2.0;

/// Below this allowance (mm) an overflowing pair list ends the frame (lagging, safe).
const MIN_OVERFLOW_ALLOW_MM: f64 = 0.005;

/// A predicted motion shorter than this (mm, largest sphere motion) takes a ball region: a
/// path region pays off only for a hand in motion.
const MIN_SWEEP_MM: f64 = 0.1;

/// Largest pair list reused from an earlier frame: a list about [`PAIR_TARGET`] costs ~20 µs to
/// solve again, ~150 µs to find again (measured on the dense puck at 50 mm/s: p50 150–195 µs
/// at 400, 35–42 at 2 000; the spline's p99 the same over three runs each). (Deterministic:
/// a rule on measured times would make frames depend on the machine.)
const REUSE_MAX_PAIRS: usize = 2000;

/// A path region is taken only while its length plus width stays within this many times the
/// allowance that keeps a ball region near [`PAIR_TARGET`] pairs (measured: at 1, the spline's
/// worst frame drops under 1 ms but the puck at 1 m/s lags in a third of its frames; at 2,
/// both hold up; at 3, the spline's worst frame is back over 1 ms).
const PATH_DENSITY_FACTOR: f64 = 2.0;

/// A path region reaches at least this far ahead (mm, largest sphere motion; at most
/// `max_margin_mm`), so that a slow hand's next frames reuse it.
const PATH_MIN_MM: f64 = 0.2;

/// How far (mm) the iterates of a path region may stray from the predicted path: twice the
/// recent prediction error, within these bounds (a tool riding over the bumps of a sphere-tree
/// surface strays by a few tenths of a millimetre).
const PATH_WIDTH_MIN_MM: f64 = 0.1;
const PATH_WIDTH_MAX_MM: f64 = 0.4;

/// A slab region (a tool held by one flat face) allows a slide along the face of at least this
/// much (mm): its face's pairs do not grow with it, only with the margin across (measured,
/// the puck at 200 mm/s and turning at 10 rad/s: p50 3–4 µs at 1 mm against 16–23 at
/// 0.5 mm, p99 the same; at 2 mm no better).
const SLAB_SLIDE_MM: f64 = 1.0;

/// Least margin (mm) across the face of a slab region, over 1.5 times last frame's motion
/// across it.
const SLAB_ACROSS_MIN_MM: f64 = 0.03;

/// Frames without slab regions after one that failed (stopped at the deadline, overflowed, or
/// listed more than [`SLAB_MAX_PAIRS`] pairs or split more than [`SLAB_MAX_SPLITS`] node
/// pairs: the other pairs within the slide, of faces whose discs are too small or of the
/// tool's own bumps, can be many, and the tool's leaves near a face broken by slots are let
/// go only one by one), doubled after each failure in a row up to [`SLAB_REST_MAX_FRAMES`].
const SLAB_REST_FRAMES: u32 = 100;
const SLAB_REST_MAX_FRAMES: u32 = 12_800;

/// A slab region is small by design (the dense puck's: 52 pairs); one past these failed to be.
const SLAB_MAX_PAIRS: usize = 500;
const SLAB_MAX_SPLITS: usize = 8_000;

/// How much farther (mm) than a ball region's margin the rest of the tool is from the objects
/// ([`Lever`]): a turn about the contact (the spline's shaft spinning and rocking on its tip)
/// is bounded by the near leaves' lever arm, not the far end's reach, while the far end moves
/// less than this.
const LEVER_MARGIN_MM: f64 = 0.8;

/// Tool and object levels at which the near part of the tool is decided ([`Lever`]): 512
/// nodes of a tree of branching 8 (the spline's shaft on its hub: 5 300–5 600 sphere tests).
const LEVER_LEVEL: u32 = 3;

/// A near part of the tool is found this much (mm) wider than a region needs, and kept for
/// later regions while the tool stays within it of where it was found ([`Lever`]).
const LEVER_SPARE_MM: f64 = 0.5;

/// Most sphere tests spent finding the near part of the tool (~7 ns each with the descent:
/// the spline's shaft on its hub takes 5 300–5 600, ~37 µs, once every ~15 regions).
const LEVER_MAX_TESTS: usize = 8_000;

/// Fewest pairs of a ball region that looks for the near part of the tool: a small contact's
/// regions are cheap to detect again (a first contact then costs no more than it did).
const LEVER_MIN_PAIRS: usize = 100;

/// A pass whose answer stayed within this share of its region's width (its motion bound from
/// the region's centre) crept: its trust box or the contact stopped it well inside its ball,
/// and the next region's trust box is turned to that pass's motion.
const CREEP_SHARE: f64 = 0.5;

/// A tool left behind that moved at least this far (mm) in its last frame is falling toward
/// the hand: its path region is the straight way there.
const FALL_MIN_STEP_MM: f64 = 0.1;

/// ... and moved toward the hand: the cosine between its last step and the way to the hand
/// is at least this (a tool sliding across a face the hand presses into is not falling).
const FALL_MIN_COS: f64 = 0.9;

/// Projection passes a reset makes toward a free pose before it gives up: each moves the tool
/// out of the overlaps it lists, so a start a few leaf sizes deep takes a few.
const RESET_SEARCH_PASSES: usize = 100;

/// The trust region that keeps a pass's iterates inside its detected region.
#[derive(Clone, Copy, Debug)]
enum Trust {
    /// Half-widths per coordinate around the region's centre: translation (mm), rotation (rad).
    Box(f64, f64),
    /// A thin slab around the predicted path (a segment in the QP variable): half-width (mm,
    /// in the variable scaled by `reach` for rotations) along and across it.
    Path(f64),
    /// A box turned to the expected motion: translation half-widths along the unit direction
    /// `dir` and across it (mm); rotation half-widths about the unit axis `turn` (`rot`) and
    /// about the two axes across it (`rot_across`; rad), or `rot` per component where `turn`
    /// is zero (`rot_across` is then `rot`). A ball region lasts longer for a tool sliding along `dir` or turning about
    /// `turn` than in an axis-aligned box of the same ball.
    Oriented {
        dir: [f64; 3],
        along: f64,
        across: f64,
        turn: [f64; 3],
        rot: f64,
        rot_across: f64,
    },
    /// A slab region's box, turned to the face's unit `normal`: translation half-widths
    /// across the face (`normal`) and along it (each of two axes), rotation half-widths about
    /// `normal` (`spin`) and about the two axes along the face (`tilt`; mm and rad).
    Slab {
        normal: [f64; 3],
        across: f64,
        along: f64,
        spin: f64,
        tilt: f64,
    },
}

/// A free-space proof: no leaf pair is within `radius` (mm) of touching with the tool at
/// `center`, or anywhere on its straight slide by `path` (mm, world, the same rotation), so
/// none is within `m` at a pose `q` while `b(path, q) + m <= radius`, `b` the motion bound
/// from the nearest pose on the path ([`GodObject::proof_distance`]).
#[derive(Clone, Copy, Debug)]
struct FreeProof {
    center: Pose,
    path: Vector3<f64>,
    /// mm; 0 = no proof.
    radius: f64,
}

impl FreeProof {
    fn none() -> Self {
        FreeProof {
            center: Pose::identity(),
            path: Vector3::zeros(),
            radius: 0.0,
        }
    }
}

/// A detected region: every leaf pair that can touch while each tool sphere stays within
/// `width` mm of where it is on the way from `center` along `sweep` (a ball of radius `width`
/// about `center` without a sweep) is in the pair list.
#[derive(Clone, Copy, Debug)]
struct Region {
    center: Pose,
    sweep: Option<Sweep>,
    /// Largest sphere motion along the sweep, mm (0 without one).
    length: f64,
    width: f64,
    /// A slab region: the face's unit normal and the region's width across it (mm; `width`
    /// is then the slide along it).
    slab: Option<(Vector3<f64>, f64)>,
    /// A ball region's near part of the tool: the only leaves that can touch within a wider
    /// margin, so a turn is bounded by their lever arm ([`Lever`]).
    lever: Option<Lever>,
}

/// The part of the tool near the objects at a ball region's centre: the box (tool frame, mm)
/// of every leaf centre within `width + skin + LEVER_MARGIN_MM` of an object
/// ([`collide::near_box`]). A pose is in the region while those leaves move at most
/// `width + skin` and every other leaf at most that plus [`LEVER_MARGIN_MM`]
/// ([`GodObject::distance_from_region`]).
#[derive(Clone, Copy, Debug)]
struct Lever {
    /// The box of the near leaves' centres (tool frame, mm).
    near: CentreBox,
    /// The largest distance (mm) of a box corner from the tool origin: a turn by `θ` moves
    /// the near leaves by at most `θ` times it.
    reach: f64,
}

impl Lever {
    /// The reach (mm) a ball region's trust box takes for its rotation part, allowing a motion
    /// of `allowed` mm (skin `skin`): the near leaves' reach, or more where the whole tool
    /// (`tool_reach`) turned that far would move more than [`LEVER_MARGIN_MM`] plus the skin.
    fn trust_reach(&self, tool_reach: f64, allowed: f64, skin: f64) -> f64 {
        self.reach
            .max(allowed * tool_reach / (LEVER_MARGIN_MM + skin))
            .min(tool_reach)
    }
}

impl Region {
    /// A ball region of motion allowance `width` (mm) about `center`.
    fn ball(center: Pose, width: f64) -> Self {
        Region {
            center,
            sweep: None,
            length: 0.0,
            width,
            slab: None,
            lever: None,
        }
    }

    /// The pose at the end of the sweep (the centre without one).
    fn end(&self) -> Pose {
        match &self.sweep {
            None => self.center,
            Some(s) => Pose::from_translation_rotation(
                &(self.center.translation() + Vector3::from(s.translation)),
                &(rotation_exp(&Vector3::from(s.rotation)) * self.center.rotation_matrix()),
            ),
        }
    }

    /// Largest motion of a sphere anywhere in the region from the centre, mm.
    fn extent(&self) -> f64 {
        self.length + self.width
    }
}

/// Warm-start identity of a pair: (object, tool slot, object slot).
type PairId = (u32, u32, u32);

/// The god-object: owns the packed trees, all scratch memory and the graphic configuration.
/// Its state in groups ([`state`]): the settings, the bodies, the detection buffers, the work
/// kept ahead, the QP's buffers, the materials, and what the run learnt.
pub struct GodObject {
    /// The settings ([`EngineConfig`]; the step reads all but the safety limits).
    params: EngineConfig,
    bodies: Bodies,
    detector: Detector,
    ahead: Ahead,
    qp: QpBuffers,
    materials: Materials,
    /// Everything learnt while running: replaced whole by [`GodObject::reset`].
    run: RunState,
}

impl GodObject {
    /// Packs the tool tree (tool frame, mm) and the object trees (object frame, mm, each with
    /// its fixed pose) and reserves every buffer (allocates; not real-time). The leaf spheres
    /// are the geometry ([`Geometry::Spheres`]); [`GodObject::with_meshes`] takes the parts'
    /// meshes too.
    pub fn new(
        tool: &SphereTree,
        objects: &[(SphereTree, Pose)],
        params: EngineConfig,
    ) -> Result<Self, EngineError> {
        Self::with_meshes(tool, None, objects, &[], params)
    }

    /// [`GodObject::new`] with the bodies' meshes (each in its tree's frame, mm): with
    /// `params.geometry` [`Geometry::Mesh`] and a mesh for the tool and every object, the step
    /// keeps the tool out of the parts' triangles, the trees (their leaves grown to hold the
    /// triangles whole: [`collide::MeshLeaves::attach`]) being the bounding hierarchy; with a
    /// mesh missing, or [`Geometry::Spheres`], the leaf spheres are the geometry
    /// ([`GodObject::geometry`] says which). The mesh mode needs the distance form and no face
    /// caps (the triangles are the faces).
    pub fn with_meshes(
        tool: &SphereTree,
        tool_mesh: Option<MeshRef<'_>>,
        objects: &[(SphereTree, Pose)],
        object_meshes: &[Option<MeshRef<'_>>],
        params: EngineConfig,
    ) -> Result<Self, EngineError> {
        params.validate()?; // the same ranges as the scene file (crate::config)
        let bad = |body: String, source: collide::CollideError| EngineError::Tree { body, source };
        let mesh_bad =
            |body: String, source: collide::MeshLeavesError| EngineError::Mesh { body, source };
        let all_meshes = tool_mesh.is_some()
            && object_meshes.len() == objects.len()
            && object_meshes.iter().all(Option::is_some);
        let (mut tool_tree, mut object_trees) = (tool.clone(), objects.to_vec());
        let mut meshes = None;
        if params.geometry == Geometry::Mesh && all_meshes {
            if params.form != collide::ConstraintForm::Distance {
                return Err(EngineError::MeshNeedsDistance);
            }
            let attach = |tree: &SphereTree, m: &MeshRef<'_>, pose: &Pose| {
                collide::MeshLeaves::attach(tree, m.vertices, m.triangles, pose)
            };
            let tm = tool_mesh.as_ref().ok_or(EngineError::MeshNeedsDistance)?;
            let (grown, tool_leaves) =
                attach(tool, tm, &Pose::identity()).map_err(|e| mesh_bad("tool mesh".into(), e))?;
            tool_tree = grown;
            let mut object_leaves = Vec::with_capacity(objects.len());
            for (i, ((t, p), m)) in objects.iter().zip(object_meshes).enumerate() {
                let Some(m) = m else { continue };
                let (grown, leaves) =
                    attach(t, m, p).map_err(|e| mesh_bad(format!("object {} mesh", i + 1), e))?;
                object_trees[i].0 = grown;
                object_leaves.push(leaves);
            }
            meshes = Some(Meshes {
                tool: tool_leaves,
                objects: object_leaves,
            });
        }
        let tool = PackedTree::new(&tool_tree).map_err(|e| bad("tool tree".into(), e))?;
        let objects = object_trees
            .iter()
            .enumerate()
            .map(|(i, (t, p))| {
                let mut packed =
                    PackedTree::with_pose(t, p).map_err(|e| bad(format!("object {}", i + 1), e))?;
                if !params.face_caps || meshes.is_some() {
                    packed.drop_face_cuts();
                }
                Ok::<_, EngineError>(packed)
            })
            .collect::<Result<Vec<_>, _>>()?;
        let reach = tool
            .leaves()
            .map(|n| {
                let c = tool.center(n);
                (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt()
            })
            .fold(0.0, f64::max);
        // In the mesh mode the motion bound covers the triangles' corners too (the narrow
        // phase's bounding spheres move no farther than they).
        let corners = meshes.iter().flat_map(|m| m.tool.corners());
        let reach = meshes.as_ref().map_or(reach, |m| reach.max(m.tool.reach()));
        let centres = CentreBox::of_points(tool.leaves().map(|n| tool.center(n)).chain(corners));
        let ws = CollideWorkspace::for_trees(&tool, &objects);
        let faces = objects.iter().any(|o| o.face_cut_count() > 0);
        let tool_slots = (0..tool.len()).map(|n| tool.slot(n) + 1).max().unwrap_or(0);
        let team = if params.helper_thread {
            let team = TraversalTeam::new(&tool, &objects, params.max_pairs)
                .map_err(|e| EngineError::HelperThread(e.to_string()))?;
            Some(team)
        } else {
            None
        };
        let n_objects = objects.len();
        let probe = FreeSpaceProbe::for_trees(&tool, &objects);
        let list_capacity = params.max_pairs.min(LIST_MAX_PAIRS);
        let neighbours = NeighbourList::for_trees(&tool, &objects, list_capacity);
        let next_neighbours = BackgroundList::for_trees(&tool, &objects, list_capacity);
        let cap = params.max_pairs;
        let contacts_cap = if meshes.is_some() { cap } else { 0 };
        let mut solver = Solver::new(params.solver);
        let mut rows_solver = RowGeneration::new();
        rows_solver.reserve(&mut solver, cap + 12);
        Ok(Self {
            params,
            bodies: Bodies {
                tool,
                objects,
                faces,
                reach,
                centres,
                meshes,
            },
            detector: Detector {
                ws,
                team,
                pairs: Vec::with_capacity(cap),
                face_seen: vec![(0, 0); tool_slots],
                face_stamp: 0,
                contacts: Vec::with_capacity(contacts_cap),
                contact_gaps: vec![0.0; contacts_cap],
            },
            ahead: Ahead {
                probe,
                neighbours,
                next_neighbours,
            },
            qp: QpBuffers {
                rows: vec![[0.0; 6]; cap + 12],
                rhs: vec![0.0; cap + 12],
                solver,
                rows_solver,
                audit: None,
            },
            materials: Materials {
                object_friction: vec![Friction::NONE; n_objects],
                tool_friction: None,
                friction_on: true,
            },
            run: RunState::fresh(),
        })
    }

    /// The settings.
    pub fn params(&self) -> &EngineConfig {
        &self.params
    }

    /// The QP solver and its workspaces, e.g. to change iteration caps or tolerances
    /// (`solver_mut().dual.params.max_iterations`) between frames.
    pub fn solver_mut(&mut self) -> &mut Solver {
        &mut self.qp.solver
    }

    /// The current graphic configuration.
    pub fn q_g(&self) -> Pose {
        self.run.motion.q_g
    }

    /// Largest distance of a tool leaf centre from the tool origin, mm.
    pub fn reach(&self) -> f64 {
        self.bodies.reach
    }

    /// Regions (detections) answered without a traversal (from a neighbour list, or from the
    /// last ball's own pairs), and by a traversal, since the last reset (or since the
    /// god-object was made): how much the lists spare.
    pub fn region_counts(&self) -> (u64, u64) {
        (
            self.run.counts.regions_filtered,
            self.run.counts.regions_traversed,
        )
    }

    /// The leaf pairs of the last detected region (empty in free space).
    pub fn pairs(&self) -> &[LeafPair] {
        &self.detector.pairs
    }

    /// Bench audit of the constraint reduction: with `on`, every reduced QP is also solved in
    /// full by a second solver, on the same rows, and the difference of the two answers'
    /// spring force `G dq` is kept ([`GodObject::take_reduction_audit`]). It costs a full
    /// solve per pass: for measuring, not for a device. Allocates (call outside the loop).
    pub fn audit_reduction(&mut self, on: bool) {
        self.qp.audit = on.then(|| {
            let mut solver = Solver::new(self.params.solver);
            solver.reserve(self.qp.rows.len());
            Box::new((solver, ReductionAudit::default()))
        });
    }

    /// What the audit measured since the last call (zero when it is off), and restarts it.
    pub fn take_reduction_audit(&mut self) -> ReductionAudit {
        self.qp
            .audit
            .as_mut()
            .map_or_else(ReductionAudit::default, |a| std::mem::take(&mut a.1))
    }

    /// Brings the trees' traversal arrays into cache until `until`: a chunk of each tree in
    /// turn, top levels first ([`collide::PackedTree::warm_chunk`]). A paced loop calls it as
    /// its spin before a deadline begins, so that the frame's traversals do not start from
    /// memory that the wait let go cold. Changes no state (frames are the same with or
    /// without it).
    ///
    /// # Real-time
    /// No allocation; returns within one chunk's reads (a few µs) of `until`.
    pub fn warm_caches(&self, until: Instant) {
        let mut acc = 0u32;
        for k in 0.. {
            let mut read = self.bodies.tool.warm_chunk(k, &mut acc);
            for o in &self.bodies.objects {
                read |= o.warm_chunk(k, &mut acc);
            }
            if !read || Instant::now() >= until {
                break;
            }
        }
        std::hint::black_box(acc);
    }

    /// Resets the graphic tool for a new run at the device pose `start`: `q_g = start` if it is
    /// free, else a free pose near it found by repeated projection (each pass: detect at the
    /// current `q`, solve the QP toward `start`, re-measure), within the distance the coupling
    /// stretches at the device's force limit (`max_force_n / kt`, as the largest motion of a
    /// tool sphere from `start`): a start deeper than that, or one whose projection leaves
    /// that distance, is [`EngineError::NoFreeStart`]. Nothing learnt in an earlier run
    /// carries over (warm start, prediction, pair density, cached regions, free-space proofs,
    /// probes, neighbour lists, friction's stick or slip, counts): the frames after a reset are
    /// those of a new god-object reset at the same pose. Allocation-free after `new`.
    pub fn reset(&mut self, start: &Pose) -> Result<Pose, EngineError> {
        self.forget_run();
        if !start.is_finite() {
            return Err(EngineError::NoFreeStart { searched_mm: 0.0 });
        }
        let mut q = *start;
        let tol = self.params.penetration_tol_mm.max(1e-6);
        let mut searched = 0.0f64;
        // A free pose whose spheres are farther from the start than the coupling stretches at
        // the device's force limit is not near it (the device would start clamped, pulled
        // toward a tool it cannot see): the search stays within that.
        let radius = self.params.safety.max_force_n / self.params.kt;
        for _ in 0..RESET_SEARCH_PASSES {
            if self.penetration_at(&q) <= tol {
                self.run.motion.q_g = q;
                self.run.motion.started = true;
                return Ok(q);
            }
            // Push out: linearize at q with the gap target, minimising distance to `start`.
            let margin = self.params.skin_mm.max(0.5);
            if self.detect(&q, margin).is_err() {
                break;
            }
            self.narrow_phase(&q, margin);
            let Some(lin) = self.linearization(&q, start) else {
                break;
            };
            let n = self.fill_rows(&lin, None);
            // Aim for a gap of `tol` rather than 0 so the projection ends strictly outside.
            for d in &mut self.qp.rhs[..n] {
                *d += tol;
            }
            let Some((dq, _, _, _)) = self.solve(n, n, &lin.delta()) else {
                break;
            };
            let next = lin.configuration(&dq);
            if !next.is_finite() {
                break;
            }
            let moved = self.motion_bound(start, &next);
            searched = searched.max(moved.min(radius));
            if moved > radius {
                break;
            }
            q = next;
        }
        Err(EngineError::NoFreeStart {
            searched_mm: searched,
        })
    }

    /// Forgets the run so far: the state learnt while running starts fresh, as in
    /// [`GodObject::new`] ([`RunState::fresh`]), and the buffers a run fills are emptied in
    /// place (their capacity kept: a reset does not allocate). Settings (friction, the
    /// reduction audit) and the trees stay.
    fn forget_run(&mut self) {
        self.run = RunState::fresh();
        self.detector.pairs.clear();
        self.ahead.probe.cancel();
        self.ahead.neighbours.clear();
        self.ahead.next_neighbours.cancel();
    }

    /// One haptic frame for the device configuration `q_h` (see the module docs): start,
    /// reuse last frame's region, then passes of detect (plan, list, adopt a region) and solve
    /// (rows, QP, verify), conclude and advance.
    ///
    /// # Real-time
    /// No allocation (all buffers reserved in [`GodObject::new`]), no panic. Bounded: at most
    /// `1 + relinearize` passes (fewer when `budget_us` would be overrun), each of at most two
    /// traversals and one QP solve (the solver's iteration cap).
    pub fn step(&mut self, q_h: &Pose) -> FrameOutput {
        let t_start = Instant::now();
        self.run.counts.frame_splits = 0;
        self.run.counts.frame_scanned = 0;
        let mut out = FrameOutput {
            q_h: q_h.to_array(),
            ..FrameOutput::default()
        };
        if !self.run.motion.started {
            self.run.motion.q_g = *q_h;
            self.run.motion.started = true;
        }
        // A non-finite or absurd reading (beyond 1e6 mm or rad: `q - q_h` then keeps too few
        // digits for the constraints) is a device fault: keep the last safe pose.
        if !q_h.is_finite() || q_h.q.iter().any(|v| v.abs() > 1e6) {
            return self.keep_last_safe(out, q_h, t_start);
        }
        // Friction: the tool sticks (stays), or the passes go toward a goal held back from the
        // hand by the friction; the wrench is always the spring to the hand.
        let friction = self.friction_active();
        let (goal, friction_state) = if friction {
            self.friction_goal(q_h)
        } else {
            (*q_h, FrictionState::None)
        };
        out.friction = friction_state;
        let mut f = self.start_frame(*q_h, goal, t_start);
        (f.friction, f.friction_state) = (friction, friction_state);
        self.reuse_region(&mut f, &mut out);
        for pass in 0..f.max_passes {
            f.clock.pass_start = Instant::now();
            if pass > 0 && !f.clock.room_for_pass(self.params.budget_us) {
                break;
            }
            out.passes = pass + 1;
            let detected = if f.course.detect_now {
                self.detect_stage(&mut f, &mut out, pass)
            } else {
                Flow::Go
            };
            let flow = match detected {
                Flow::Go => self.solve_pass(&mut f, &mut out),
                other => other,
            };
            match flow {
                Flow::Go | Flow::Next => {}
                Flow::Stop => break,
                Flow::Fail => return self.keep_last_safe(out, q_h, t_start),
            }
        }
        self.conclude(&mut f, &mut out);
        self.advance(&f, &mut out);
        out
    }

    fn keep_last_safe(&mut self, mut out: FrameOutput, q_h: &Pose, t0: Instant) -> FrameOutput {
        out.status = FrameStatus::KeptLastSafe;
        out.q_g = self.run.motion.q_g.to_array();
        self.run.solve.warm_len = 0;
        let w = if q_h.is_finite() {
            spring_wrench(
                &self.params.g(),
                self.params.rotation,
                &self.run.motion.q_g,
                q_h,
            )
        } else {
            [0.0; 6]
        };
        for k in 0..6 {
            out.wrench[k] = if w[k].is_finite() { w[k] } else { 0.0 };
            out.raw_wrench[k] = out.wrench[k];
        }
        out.total_us = t0.elapsed().as_secs_f64() * 1e6;
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use spheretree::Sphere;

    /// A ring of eight small tool spheres about a large one, 0.2 mm from a small object.
    fn ring() -> GodObject {
        let mut tool = SphereTree::new_unused(2, 8).unwrap();
        for k in 0..8 {
            let a = std::f64::consts::FRAC_PI_4 * k as f64;
            tool.spheres_mut()[1 + k] = Sphere::new([12.0 * a.cos(), 12.0 * a.sin(), 0.0], 1.0);
        }
        tool.spheres_mut()[0] = Sphere::new([0.0, 0.0, 0.0], 14.0);
        let mut object = SphereTree::new_unused(1, 8).unwrap();
        object.spheres_mut()[0] = Sphere::new([14.2, 0.0, 0.0], 1.0);
        GodObject::new(
            &tool,
            &[(object, Pose::identity())],
            EngineConfig::default(),
        )
        .unwrap()
    }

    /// After a run pressed into a contact, a reset leaves the run state as a new god-object's
    /// reset at the same pose leaves it, and every buffer as large as it was (a reset does
    /// not allocate).
    #[test]
    fn a_reset_leaves_the_state_of_a_new_god_object() {
        let start = Pose::identity();
        let mut used = ring();
        used.reset(&start).unwrap();
        for i in 0..50 {
            let hand = Pose::from_array([0.02 * i as f64, 0.0, 0.0, 0.0, 0.0, 0.002 * i as f64]);
            used.step(&hand);
        }
        assert!(used.run.motion.contacts_g > 0, "the run ends in contact");
        let capacities = (
            used.detector.pairs.capacity(),
            used.qp.rows.len(),
            used.qp.rhs.len(),
        );
        used.reset(&start).unwrap();
        let mut fresh = ring();
        fresh.reset(&start).unwrap();
        assert_eq!(format!("{:?}", used.run), format!("{:?}", fresh.run));
        assert_eq!(used.detector.pairs, fresh.detector.pairs);
        assert_eq!(
            (
                used.detector.pairs.capacity(),
                used.qp.rows.len(),
                used.qp.rhs.len()
            ),
            capacities
        );
    }
}
