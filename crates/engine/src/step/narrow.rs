//! The mesh geometry mode's narrow phase (docs/DESIGN.md §Mesh-exact contact): the triangle
//! pairs that can touch in a region, their rows at the linearisation pose (nearest features,
//! exact distance), their exact distances at an answer, and the last free pose on the way to an
//! answer where triangles meet.
//!
//! The pairs come from the bodies' triangle trees ([`collide::TriangleTree`]), descended
//! together down to the pairs within a margin: a pair that can touch anywhere in a region is
//! within the region's extent plus the skin at its centre (no tool point moves farther than the
//! motion bound, whose reach covers the mesh's corners), so the step's guarantees carry over
//! from spheres to triangles. The sphere-trees' top levels, grown to hold the triangles
//! ([`collide::MeshLeaves`]), still answer "free" for the whole step.

use collide::{triangle_distance, triangle_distance_from, NearestEdges, Triangle, TriangleTree};

use super::*;

/// A pair of triangles: the object (index), the tool's triangle and the object's triangle
/// (their bounds on distance are kept beside the list: `Detector::near_apart`,
/// `Detector::near_gaps`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct TriPair {
    pub(super) object: u32,
    pub(super) tool: u32,
    pub(super) part: u32,
}

/// A near-list pair's directional gap: with the tool's translation at `t` (mm) and the list's
/// turn offset at `turn` (mm, `Detector::near_turn`), the pair's triangles lie at least
/// `way · t + level - turn` (mm) apart along the fixed world direction `way` (unit). It moves
/// with the tool's translation along `way` only (and the turn), so a tool sliding along a wall
/// keeps its gaps to the wall, where the motion bound of the way would pose the pair again
/// frame after frame ([`GodObject::narrow_phase_along`]).
///
/// The object's triangle lies wholly below `high` (mm) along `way`, so the gap at any pose is
/// also the tool's triangle's lowest corner along `way` less `high`: [`PairGap::exact_at`]
/// measures that from the tool's own corners, with no turn offset, where the turns summed
/// since the gap was taken (the whole tool's, not the pair's) have worn it down.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct PairGap {
    way: [f64; 3],
    level: f64,
    high: f64,
    /// An upper bound (mm) on the pair's distance, less the list's offset
    /// (`Detector::near_offset`): the exact distance the last filter that measured it found,
    /// less the offset then (infinite where none is known). With the offset now added, it
    /// holds at the last filter's centre: the offset grows by the way there, as the lower
    /// bounds shrink by it. A pair whose upper bound is within a region's margin is near, and
    /// its distance is measured without the gap's and the separation's tests, which can only
    /// find it apart: a tight fit's contacts, thousands a region. Kept here, beside the gap
    /// the filter reads first, rather than in a list of its own: one more cache line read a
    /// pair cost the pegs at 0.05 mm 3 % of their frames' time.
    upper: f64,
}

impl PairGap {
    /// No directional gap known.
    pub(super) const NONE: Self = Self {
        way: [0.0; 3],
        level: f64::NEG_INFINITY,
        high: f64::INFINITY,
        upper: f64::INFINITY,
    };

    /// A gap of `gap` (mm) along `way` (unit, world) with the tool's triangle at `corners`
    /// (world, mm), its translation at `t` (mm) and the turn offset at `turn` (mm); lowered by
    /// a rounding's worth.
    fn new(gap: f64, way: [f64; 3], corners: &Triangle, t: &Vector3<f64>, turn: f64) -> Self {
        let lowest = lowest_along(&way, corners);
        Self {
            way,
            level: gap - dot(&way, t.as_ref()) + turn - GAP_ROUNDING_MM,
            high: lowest - gap,
            upper: f64::INFINITY,
        }
    }

    /// The same gap taken at the turn offset `new` (mm) of another list where this one's is
    /// `old` (both summed to the same pose).
    fn relevelled(&self, old: f64, new: f64) -> Self {
        Self {
            level: self.level - old + new,
            ..*self
        }
    }

    /// Whether a gap is known.
    fn is_known(&self) -> bool {
        self.level > f64::NEG_INFINITY
    }

    /// The least gap (mm) with the tool's translation at `t` (mm) moved along `path` (mm) by
    /// any share of it, and the turn offset at `turn` (mm).
    fn at(&self, t: &Vector3<f64>, path: &Vector3<f64>, turn: f64) -> f64 {
        dot(&self.way, t.as_ref()) + dot(&self.way, path.as_ref()).min(0.0) + self.level - turn
    }

    /// [`PairGap::at`] for a region with no path (`t` the tool's translation, mm, as an array):
    /// one dot product fewer, for a filter's thousands of pairs.
    fn at_centre(&self, t: &[f64; 3], turn: f64) -> f64 {
        dot(&self.way, t) + self.level - turn
    }

    /// The gap (mm) with the tool at `(rot, t)` whose triangle has the corners `in_tool` (tool
    /// frame, mm), not moved along a path: its lowest corner along the way less `high`,
    /// lowered by a rounding's worth. Taken as the pair's gap at the current turn offset
    /// `turn` (mm), it is its new level.
    fn exact_at(
        &mut self,
        in_tool: &Triangle,
        rot: &Matrix3<f64>,
        t: &Vector3<f64>,
        turn: f64,
    ) -> f64 {
        let way = Vector3::from(self.way);
        let in_tool_way: [f64; 3] = (rot.transpose() * way).into();
        let gap = lowest_along(&in_tool_way, in_tool) + way.dot(t) - self.high - GAP_ROUNDING_MM;
        self.level = self.level.max(gap - way.dot(t) + turn);
        gap
    }
}

/// Where a ball region takes a new near list ([`Detector::inherit_near`]): the ball's centre's
/// translation (mm), and the turn offsets (mm) of the old list and of the new one summed to it.
pub(super) struct InheritedTurns {
    at: Vector3<f64>,
    old: f64,
    new: f64,
}

/// The least of the corners of `t` along `way`.
fn lowest_along(way: &[f64; 3], t: &Triangle) -> f64 {
    dot(way, &t[0]).min(dot(way, &t[1])).min(dot(way, &t[2]))
}

/// How far (mm) the triangle `a` lies beyond the triangle `b` along `way`: the least of
/// `a`'s corners along it less the greatest of `b`'s (negative where they overlap along it).
fn projected_gap(a: &Triangle, b: &Triangle, way: &[f64; 3]) -> f64 {
    let lowest = dot(way, &a[0]).min(dot(way, &a[1])).min(dot(way, &a[2]));
    let highest = dot(way, &b[0]).max(dot(way, &b[1])).max(dot(way, &b[2]));
    lowest - highest
}

/// Taken off every directional gap (mm): the roundings of its level, of a few products of
/// translations of at most metres, stay far below it.
const GAP_ROUNDING_MM: f64 = 1e-9;

/// The world direction (unit) a translation of the tool along which widens the gap found
/// `along` ([`PosedTriangle::separation_upto_along`]) between the posed tool triangle `tool`
/// and triangle `i` of `part`: ±1 the object's normal, the tool's triangle in front of its
/// plane (+) or behind it (−); ±2 the tool's normal, the object's triangle in front (+) or
/// behind (−); ±3, ±4, ±5 the world's x, y, z, the tool's box above (+) or below (−); 6, 7, 8
/// away from the tool's edge 0, 1, 2 (its outward normal reversed: the object lies beyond
/// it); 9, 10, 11 the outward normal of the object's edge 0, 1, 2 (the tool lies beyond it).
fn gap_way(along: i8, tool: &PosedTriangle, part: &TriangleTree, i: u32) -> [f64; 3] {
    let side = f64::from(along.signum());
    match along.abs() {
        1 => part.plane(i).0.map(|v| side * v),
        2 => tool.normal.map(|v| -side * v),
        k @ 3..=5 => {
            let mut e = [0.0; 3];
            e[usize::from(k.unsigned_abs()) - 3] = side;
            e
        }
        k @ 6..=8 => tool.edges[usize::from(k.unsigned_abs()) - 6].0.map(|v| -v),
        k => part.edges(i)[usize::from(k.unsigned_abs()).saturating_sub(9).min(2)].0,
    }
}

/// The meshes of the mesh geometry mode: the tool's triangles in their box tree (tool frame)
/// and each object's (world).
pub(super) struct Meshes {
    pub(super) tool: TriangleTree,
    pub(super) objects: Vec<TriangleTree>,
}

/// Two faces count as lying flat on each other when both are within this angle's cosine of the
/// contact plane (1°): a face tilted more lifts a 1 mm facet's far edge past the touch
/// distance ([`TOUCH_MM`], 0.01 mm; `sin 1° · 1 mm` = 0.017 mm), so it touches along an edge or
/// a corner, not over an area.
const FLAT_CONTACT_COS: f64 = 0.999_847_695_156_391_2;

/// A near list over its pair target reaches half as far next time only where that would
/// leave at most this share of its pairs (by their listed separations).
const NEAR_THIN_SHARE: f64 = 0.75;

/// Time a list taken in a paced loop's wait may need for each pair of the old and the new list,
/// ns ([`GodObject::take_near_list_in_wait`]): its inheritance took ~55 µs for 5 500 pairs
/// each (`spline-tight`), ~5 ns a pair; twice that and more, so that the wait ends on time.
const TAKE_NS_PER_PAIR: u64 = 12;

/// The list built ahead starts once the tool has used this share of the current one (its
/// sweep, or its extra reach off it): later, the pose it is centred at is guessed from nearer;
/// earlier, it has more frames to be built in.
const NEAR_AHEAD_START: f64 = 0.5;

/// Frames the list in use must still last for a paced frame to leave the next list's
/// building to the loop's wait ([`GodObject::near_slice_us`]): one wait, of a few hundred
/// microseconds, and one to spare.
const NEAR_IDLE_LEFT_FRAMES: f64 = 2.0;

/// The running quantile's step in the log of the frames' own work
/// ([`Heuristics::mesh_fill_own_level`]): up this times the share below it after a frame
/// above, down this times [`Tuning::own_above_share`] after one below, so that it settles
/// where that share of the frames lies above it. At 0.1 and a share of 0.05, a level eight
/// times too high comes down in ~420 frames, one eight times too low goes up in ~22 frames
/// of work above it.
const OWN_LEVEL_RATE: f64 = 0.1;

/// A budget past this (µs) is no haptic frame's (the per-frame minima run with none): the fill
/// level stays the fixed share there, so that frames do not depend on the clock and are the
/// same run after run.
const OWN_LEVEL_MAX_BUDGET_US: f64 = 10_000.0;

/// Frames the list in use must still hold for [`Heuristics::mesh_slice_ceiling`] to keep the
/// next list's slice under its ceiling: one to take the next list in, and one to spare.
const NEAR_CEILING_LEFT_FRAMES: f64 = 2.0;

/// Lists begun without a near part after one that did not pay
/// ([`Tuning::near_part_pays`]), or whose noting was given up: the noting's box tests (about
/// as many as the descent's own where it does not pay) spared on each, while the tool's
/// motion changes little from list to list (a shaft sliding down its hole).
pub(crate) const NEAR_PART_REST_LISTS: u32 = 8;

/// Least growth (times the margin) a ball's slow growth is measured for
/// ([`Heuristics::mesh_slow_growth`]): a list that reaches less farther is about to be
/// replaced.
const SLOW_GROWTH_LEAST: f64 = 1.25;

/// Width (mm) and count of the bins the near list's pair bounds are counted in, each region,
/// for the distance within which it holds a ball's pair target ([`GodObject::standoff_allow`]):
/// a 0.0025 mm grain up to 0.1 mm, on the stack.
const STANDOFF_BIN_MM: f64 = 0.0025;
const STANDOFF_BINS: usize = 40;

/// The least share of the row target a tilted row keeps ([`Heuristics::mesh_tilted_targets`]):
/// a half keeps every answer's triangles apart by a rounding's many times over, and lets a face
/// resting at the target beside an edge off it by up to `√3` times the target slide over in one
/// pass (the cosine 1/2 at 60°).
const TILTED_TARGET_LEAST: f64 = 0.5;

/// The filter reads the clock (24 ns) once per this many near-list pairs: at most ~25 µs of
/// exact distances between reads, and a skip loop as fast as without the clock (read at every
/// 64th pair, it cost 2 µs of a 5 000-pair list's filter).
const FILTER_CLOCK_PAIRS: usize = 256;

/// How far the tool has used a near list ([`GodObject::near_use`]): its motion bound off the
/// list's span (mm), its share along the sweep (0 to 1), and the frames until it is spent.
struct NearUse {
    used: f64,
    along: f64,
    left: f64,
}

/// Bisections of a step whose end has meeting triangles, toward the last free pose on it.
const BACKTRACK_STEPS: u32 = 8;

impl GodObject {
    /// The geometry the step keeps the tool out of: [`Geometry::Mesh`] when it was asked for
    /// and every body came with its mesh, else [`Geometry::Spheres`].
    pub fn geometry(&self) -> Geometry {
        if self.bodies.meshes.is_some() {
            Geometry::Mesh
        } else {
            Geometry::Spheres
        }
    }

    /// In the mesh mode, how many triangles the narrow phase holds for the tool and for each
    /// object (after flat faces were merged, [`collide::merge_flat_faces`]); `None` on the
    /// leaf spheres.
    pub fn mesh_triangle_counts(&self) -> Option<(usize, Vec<usize>)> {
        let meshes = self.bodies.meshes.as_ref()?;
        Some((
            meshes.tool.len(),
            meshes.objects.iter().map(TriangleTree::len).collect(),
        ))
    }

    /// How many constraint rows the region's list gives (before the trust region's): one per
    /// leaf pair, or per triangle pair in the mesh mode.
    pub(super) fn listed_rows(&self) -> usize {
        if self.bodies.meshes.is_some() {
            self.detector.contacts.len()
        } else {
            self.detector.pairs.len()
        }
    }

    /// The mesh mode's row target (mm): rows keep every triangle pair this far apart, so an
    /// answer's triangles do not meet by a rounding.
    pub(super) fn mesh_gap(&self) -> f64 {
        self.params.penetration_tol_mm.max(1e-6)
    }

    /// Narrow phase: the triangle pairs within `margin` (mm) of each other with the tool at
    /// `center` (and some farther apart), into `detector.contacts` (those past its capacity
    /// counted in `run.regions.dropped`, so the region is shrunk as for pairs). Nothing in
    /// sphere mode, or when the region lists no leaf pair (the grown leaves hold the
    /// triangles, so no triangle is near then either).
    ///
    /// The pairs come from the near list, the pairs within a wider margin of a recent pose
    /// (listed again, by descending the triangle trees, when it no longer covers the region):
    /// a pair within `margin` at `center` is within `margin` plus the motion bound from the
    /// list's pose there, or from the last region that filtered it, whose centre the pairs'
    /// bounds are then left at.
    pub(super) fn narrow_phase(&mut self, center: &Pose, margin: f64) {
        self.narrow_phase_along(center, margin, &Vector3::zeros());
    }

    /// [`GodObject::narrow_phase`] for a path region: the triangle pairs within `margin` (mm)
    /// of each other with the tool at `center` moved along `path` (mm, the world's axes) by
    /// any share of it, rather than every pair within the path's length of the centre (a
    /// tool falling into a tight hole: 11 000 pairs of the hole's wall within 1.8 mm, a few
    /// hundred along the way). The path's turn is the caller's to add to `margin`.
    pub(super) fn narrow_phase_along(&mut self, center: &Pose, margin: f64, path: &Vector3<f64>) {
        self.narrow_phase_by(center, margin, path, None);
    }

    /// [`GodObject::narrow_phase_along`] within the frame's time: a near list's descent or its
    /// filter still running at `deadline` stops there, and `run.regions.interrupted` says so
    /// (nothing of the region is proven). The frame then ends at its last proven pose, and the
    /// next frame's region there goes on: the list under way is kept, and so are the pairs'
    /// bounds and exact distances the filter reached (a first contact's wide list of ~10 000
    /// pairs costs 1–2 ms to list and up to 1.5 ms to filter: frames within the budget, not
    /// one frame over it).
    pub(super) fn narrow_phase_by(
        &mut self,
        center: &Pose,
        margin: f64,
        path: &Vector3<f64>,
        deadline: Option<Instant>,
    ) {
        if self.bodies.meshes.is_none() {
            return;
        }
        let previous = self.detector.keep_checked_distances();
        // Every pose of the region is within the margin of the path, within its length of the
        // centre.
        self.run.regions.contacts_at = Some((*center, margin + path.norm()));
        self.run.regions.slow_growth_to = None;
        if self.detector.pairs.is_empty() {
            // Free space: no wall stands near.
            self.run.regions.near_standoff = f64::INFINITY;
            return;
        }
        if !self.near_list_for(center, margin, path, deadline) {
            self.run.regions.interrupted = true;
            self.run.regions.contacts_at = None;
            return;
        }
        let swept = *path != Vector3::zeros();
        let farthest = |bound: &dyn Fn(&Pose) -> f64| farthest_on_path(center, path, bound);
        let Some(meshes) = &self.bodies.meshes else {
            return;
        };
        // No point of the tool is farther than the motion bound from where it was on the
        // list's span: a pair listed farther apart than that beyond the margin stays out of
        // it, and is not posed again.
        // Each filter leaves every pair's bound at its own centre (`near_bounds_at`): the next
        // region, a short way on, skips a pair the filter found apart by more than that way
        // beyond its margin, where the way back to the list's pose would not.
        let anchored = self.params.heuristics.mesh_near_list;
        let moved = match self.run.regions.near_bounds_at.filter(|_| anchored) {
            Some(at) => farthest(&|q| self.list_motion_bound(&at, q)),
            None => self
                .run
                .regions
                .near_at
                .map_or(0.0, |span| farthest(&|q| self.span_bound(&span, q))),
        };
        // Each pair's directional gap moves with the translation along its direction only,
        // and with the turn; the turns are summed from filter to filter (as the motion bounds
        // are) from where the list was listed, where each pair's first one was taken (the tool
        // off the object's plane). With `directions`, a filter that finds a pair apart keeps the
        // box's or plane's gap that showed it.
        let last_centre = self
            .run
            .regions
            .near_bounds_at
            .filter(|_| anchored)
            .or(self.run.regions.near_listed_at);
        let turned = last_centre.map_or(f64::INFINITY, |at| {
            self.list_turn_bound(&at.rotation_matrix(), &center.rotation_matrix())
        });
        let turn = if anchored {
            self.detector.near_turn += turned;
            self.detector.near_turn
        } else {
            turned
        };
        let directions =
            anchored && turn.is_finite() && self.params.heuristics.mesh_pair_directions;
        let (rot, t) = (center.rotation_matrix(), center.translation());
        let detector = &mut self.detector;
        let mut posed_count = 0u64;
        let mut direct_count = 0u64;
        // The exact distances measured here, counted: how far off the tool a dense wall
        // stands ([`GodObject::standoff_allow`]).
        let mut bins = [0u32; STANDOFF_BINS];
        let mut measured = 0usize;
        // Pairs within the margin (and below, those a ball twice as wide could hold).
        let mut within = 0usize;
        let mut count = |apart: f64| {
            measured += 1;
            within += usize::from(apart <= margin);
            let bin = (apart.max(0.0) / STANDOFF_BIN_MM) as usize;
            if let Some(n) = bins.get_mut(bin) {
                *n += 1;
            }
        };
        // The distances the check of an answer measured here (the last region's pairs, from
        // this same list) are this region's own: faces lying on each other measure hundreds.
        // A path region takes them too (a tilted peg pushed down its hole): measured at its
        // centre, they are the distances its own filter would measure there.
        let reuse =
            previous.at == Some((rot, t)) && detector.reuse_list == Some(detector.near_generation);
        let mut from_check = 0;
        let mut tools = detector.tool_poses.at(&rot, &t, path);
        let mut stopped_at = None;
        // The bounds are kept less the list's offset: moving every one to this centre is
        // adding `moved` to the offset, and the pairs it leaves beyond the margin are passed
        // over without a write (a tight fit's list of 10 000 pairs, a few hundred near).
        let offset = if anchored {
            detector.near_offset += moved;
            detector.near_offset
        } else {
            moved
        };
        let keep = |bound: f64| bound + offset;
        // Each chunk in two passes: a tight one over its bounds and gaps that passes over the
        // pairs they hold beyond the margin (a tight fit's wall, moving along it: thousands a
        // region, a few nanoseconds each) and notes the rest, then the rest, each as below.
        // In one loop with the rest's work, a tilting peg's filters took a sixth longer (112
        // against 94 ms a run).
        let mut rest = [(0u16, 0.0f64); FILTER_CLOCK_PAIRS];
        let mut held_at = [0u16; FILTER_CLOCK_PAIRS];
        let tt: [f64; 3] = t.into();
        for (k, bounds) in detector
            .near_apart
            .chunks_mut(FILTER_CLOCK_PAIRS)
            .enumerate()
        {
            if deadline.is_some_and(|d| Instant::now() >= d) {
                stopped_at = Some(k * FILTER_CLOCK_PAIRS);
                break;
            }
            let first = k * FILTER_CLOCK_PAIRS;
            let gaps = &detector.near_gaps[first..first + bounds.len()];
            // The pairs past their kept bound, then those of them past their gap too, noted
            // without a branch: a wall's pairs fall either way at random (with a branch each,
            // the tilted pegs' and `spline-tight`'s heaviest frames were 4–8 % heavier).
            let mut past = 0;
            for (j, kept) in bounds.iter().enumerate() {
                // (A chunk is at most 256 pairs, and `past` at most `j` here.)
                held_at[past] = j as u16;
                past += usize::from(*kept - offset <= margin);
            }
            let mut held = 0;
            for &j in &held_at[..past] {
                let j = usize::from(j);
                let gap = &gaps[j];
                // (A ball region has no path to read: without it the tilted pegs' heaviest
                // frames were 4–10 % lighter.)
                let here = if swept {
                    gap.at(&t, path, turn)
                } else {
                    gap.at_centre(&tt, turn)
                };
                let apart = here > margin;
                if anchored {
                    let kept = &mut bounds[j];
                    let raised = kept.max(keep(here));
                    *kept = if apart { raised } else { *kept };
                }
                rest[held] = (j as u16, here);
                held += usize::from(!apart);
            }
            for &(j, gap_here) in &rest[..held] {
                let j = usize::from(j);
                let kept = &mut bounds[j];
                let i = first + j;
                let gap = &mut detector.near_gaps[i];
                let mut here = gap_here;
                // Measured within the margin, and not moved farther than the rest of it since:
                // near still, whatever its gap or separation (the contacts of a tight fit,
                // thousands a region); its distance is measured at once.
                let near = anchored && gap.upper + offset <= margin;
                // Measured within the margin by the last filter that measured it: most likely
                // near again (a tight fit's contacts under a moving tool, ~1 000 a region), so
                // its distance is measured first, and the separation, which can only show it
                // apart, only where the distance does.
                let was_near = !swept && anchored && gap.upper + offset - moved <= margin;
                if directions && gap.is_known() && !near {
                    // Worn down by the whole tool's turns: the pair's own corners tell.
                    let in_tool = meshes.tool.triangle(detector.near[i].tool);
                    here = gap.exact_at(in_tool, &rot, &t, turn)
                        + dot(&gap.way, path.as_ref()).min(0.0);
                }
                if here > margin {
                    if anchored {
                        *kept = kept.max(keep(here));
                    }
                    continue;
                }
                let c = &detector.near[i];
                let index = i as u32;
                while from_check < detector.reuse_from.len()
                    && detector.reuse_from[from_check] < index
                {
                    from_check += 1;
                }
                let checked = (reuse
                    && detector.reuse_from.get(from_check) == Some(&index)
                    && detector.reuse_known[from_check])
                    .then(|| detector.reuse_nearest[from_check]);
                // Along a path a pair measured beyond the margin may still come within it: it
                // is held against the path's bound first, as a pair measured afresh is.
                let d = match checked {
                    Some(d) if !swept || d.meet || d.distance <= margin => d,
                    _ => {
                        posed_count += 1;
                        let tool = tools.get(&meshes.tool, c.tool);
                        let part_tree = &meshes.objects[c.object as usize];
                        let measured_first = (was_near && !near).then(|| {
                            triangle_distance_from(
                                &tool.corners,
                                part_tree.triangle(c.part),
                                &mut detector.near_edges[i],
                            )
                        });
                        let (apart, along) = if near {
                            direct_count += 1;
                            (0.0, 0)
                        } else if measured_first.is_some_and(|d| d.meet || d.distance <= margin) {
                            (0.0, 0)
                        } else {
                            // Along a path: the least over it (a bound at the centre too).
                            tool.separation_upto_along(part_tree, c.part, margin, true)
                        };
                        if apart > margin {
                            if anchored {
                                *kept = keep(apart);
                            }
                            if directions && along != 0 {
                                let way = gap_way(along, tool, part_tree, c.part);
                                detector.near_gaps[i] =
                                    PairGap::new(apart, way, &tool.corners, &t, turn);
                            }
                            continue;
                        }
                        let d = checked.or(measured_first).unwrap_or_else(|| {
                            triangle_distance_from(
                                &tool.corners,
                                part_tree.triangle(c.part),
                                &mut detector.near_edges[i],
                            )
                        });
                        if directions && d.distance > margin {
                            // Apart beyond the margin: along the way from the object's nearest
                            // point to the tool's, the two lie that far apart (measured on their
                            // corners, not taken on trust).
                            let way = Vector3::from(d.on_a) - Vector3::from(d.on_b);
                            let way: [f64; 3] = (way / d.distance).into();
                            let part = part_tree.triangle(c.part);
                            let gap = projected_gap(&tool.corners, part, &way);
                            if gap > margin {
                                detector.near_gaps[i] =
                                    PairGap::new(gap, way, &tool.corners, &t, turn);
                            }
                        }
                        d
                    }
                };
                let distance = if d.meet { 0.0 } else { d.distance };
                count(distance);
                if anchored {
                    *kept = keep(distance);
                    detector.near_gaps[i].upper = distance - offset;
                }
                if d.distance <= margin || swept {
                    // The near list is no longer than the contacts' storage.
                    detector.contacts.push(*c);
                    detector.contact_from.push(index);
                    detector.contact_nearest.push(d);
                    detector.nearest_known.push(true);
                }
            }
        }
        // (The pairs a filter stopped at the deadline did not reach keep their bounds, moved to
        // this centre with the offset as every other's.)
        detector.nearest_at = Some((rot, t));
        detector.contacts_list = Some(detector.near_generation);
        self.run.regions.near_bounds_at = Some(*center);
        self.run.counts.near_posed += posed_count;
        self.run.counts.near_direct += direct_count;
        self.run.counts.frame_scanned += stopped_at.unwrap_or(self.detector.near.len()) as u64;
        if stopped_at.is_some() {
            // Out of time: nothing of the region is proven. The distances measured so far
            // serve the next frame's region here (the frame ends at its last proven pose, where
            // the next one starts), as an answer's check's do.
            self.run.regions.interrupted = true;
            self.run.regions.contacts_at = None;
            return;
        }
        let target = self.params.tuning.ball_pair_target;
        // A ball that held more than its target, and at least the thinning share of the pairs
        // one up to twice as wide could hold (by their bounds here, as far as the list
        // reaches): a smaller ball sheds few of its pairs, a wider one gains few.
        if !swept && within as f64 > target && self.params.heuristics.mesh_slow_growth {
            let reach = self
                .run
                .regions
                .near_at
                .map_or(0.0, |span| span.reach - self.span_bound(&span, center));
            let wide = (2.0 * margin).min(reach);
            if wide >= SLOW_GROWTH_LEAST * margin {
                let wider = self.detector.near_pairs_within(offset, wide);
                if within as f64 >= NEAR_THIN_SHARE * wider as f64 {
                    self.run.regions.slow_growth_to = Some(wide);
                }
            }
        }
        // A region that measured a ball's pair target finds where the wall stands; one kept
        // short of it that measured under half the target leaves that as found (a new list
        // too: the wall is where the tool is, not where a list was listed, and each reset
        // listed the wall whole once a list); one that measured more found the tool on
        // something nearer than the wall (a face it was pushed onto), where a smaller ball no
        // longer halves the work.
        if (measured as f64) >= 0.5 * target && (measured as f64) < target {
            self.run.regions.near_standoff = f64::INFINITY;
        } else if measured as f64 >= target {
            // A wall: a step in the count, under half the target nearer than it (a spread of
            // distances, a curved contact, gives a smaller ball no saving).
            self.run.regions.near_standoff = f64::INFINITY;
            let mut held = 0.0;
            for (i, &n) in bins.iter().enumerate() {
                let nearer = held;
                held += f64::from(n);
                if held >= target {
                    if nearer < 0.5 * target {
                        self.run.regions.near_standoff = i as f64 * STANDOFF_BIN_MM;
                    }
                    break;
                }
            }
        }
    }

    /// Puts in `detector.near` a list of every triangle pair that can come within `margin`
    /// (mm) of each other in the region about `center` along `path` (mm): the list in use, the
    /// one under way (finished here), or a new one. Returns false where `deadline` came first
    /// (the list under way is kept for the next frame).
    fn near_list_for(
        &mut self,
        center: &Pose,
        margin: f64,
        path: &Vector3<f64>,
        deadline: Option<Instant>,
    ) -> bool {
        let swept = *path != Vector3::zeros();
        // A ball region's centre, where a list it takes moves its bounds to.
        let ball = (!swept).then_some(center);
        let covered = |span: &NearSpan| {
            farthest_on_path(center, path, &|q| self.span_bound(span, q)) + margin <= span.reach
        };
        if self.params.heuristics.mesh_near_list
            && self.run.regions.near_at.is_some_and(|s| covered(&s))
        {
            return true;
        }
        // The list under way serves only where it holds the whole region, the path's end too.
        let under_way_covers = self
            .run
            .regions
            .near_ahead
            .at
            .is_some_and(|at| covered(&at));
        // Its rest costs less than a new list's whole descent; out of time, the next frame
        // goes on with it.
        if under_way_covers
            && !self.advance_near(deadline)
            && self.run.regions.near_ahead.at.is_some()
        {
            return false;
        }
        let wide_over = |ahead: &NearAhead| {
            ahead.purpose == (NearPurpose::Region { wide: true }) && ahead.done && ahead.dropped > 0
        };
        let resumed_over = under_way_covers && wide_over(&self.run.regions.near_ahead);
        if self.take_near_list(under_way_covers, ball) {
            return true;
        }
        let extra = self.run.regions.near_extra;
        if !resumed_over {
            // A list no wider than the region's own margin is not kept for later regions.
            let wide = self.params.heuristics.mesh_near_list
                && extra >= NEAR_LIST_MIN_SHARE * self.params.tuning.near_list_mm;
            if !wide {
                // The next list reaches farther again.
                self.run.regions.near_extra = (2.0 * extra).min(self.params.tuning.near_list_mm);
            }
            let span = NearSpan {
                at: *center,
                sweep: if swept {
                    (*path).into()
                } else if wide {
                    self.near_sweep()
                } else {
                    [0.0; 3]
                },
                reach: margin + if wide { extra } else { 0.0 },
                near: None,
            };
            self.begin_near(span, NearPurpose::Region { wide });
            if !self.advance_near(deadline) {
                return false;
            }
            if self.take_near_list(true, ball) {
                return true;
            }
        }
        // A wide list past the storage gives way to the region's own pairs, every one past
        // the storage counted (the region shrinks by them); the next list reaches a quarter
        // as far beyond its region.
        self.run.regions.near_extra = 0.25 * extra;
        let own = NearSpan {
            at: *center,
            sweep: (*path).into(),
            reach: margin,
            near: None,
        };
        self.begin_near(own, NearPurpose::Region { wide: false });
        self.advance_near(deadline) && self.take_near_list(true, ball)
    }

    /// Starts a near list for `span` in `detector.next_near` (one under way is dropped).
    fn begin_near(&mut self, span: NearSpan, purpose: NearPurpose) {
        if purpose != NearPurpose::Ahead {
            self.run.counts.near_listed += 1;
        }
        self.run.regions.near_ahead = NearAhead::start(span, purpose);
        self.detector.next_near.clear();
        self.detector.next_apart.clear();
        self.detector.next_gaps.clear();
        self.detector.next_ranks.clear();
        TriangleTree::start_descent(&mut self.detector.next_stack);
        // The list's pairs move with the part of the tool near the objects: its descent notes
        // that part ([`GodObject::span_bound`]).
        // (Not where the last near part did not pay: see `take_near_list`.)
        let regions = &mut self.run.regions;
        let noting = self.params.heuristics.mesh_near_part && regions.near_part_rest == 0;
        regions.near_part_rest = regions.near_part_rest.saturating_sub(1);
        let wide = if noting {
            span.reach + self.params.tuning.near_part_mm
        } else {
            f64::NEG_INFINITY
        };
        let give_up_past = if self.params.heuristics.mesh_near_part_give_up {
            self.params.tuning.near_part_pays * self.bodies.centres.reach()
        } else {
            f64::INFINITY
        };
        self.detector.next_stack.note_near_part(wide, give_up_past);
    }

    /// Goes on descending the tool's triangle tree, swept along the span, against each
    /// object's, for the near list under way, until it is done or `end`; returns whether it is
    /// done. Past the storage a list built ahead is dropped (none this time), a region's wide
    /// list is done (its overflow counted), a region's own list goes on counting.
    fn advance_near(&mut self, end: Option<Instant>) -> bool {
        let Some(meshes) = &self.bodies.meshes else {
            return false;
        };
        let mut ahead = self.run.regions.near_ahead;
        let Some(next) = ahead.at else {
            return false;
        };
        if ahead.done {
            return true;
        }
        let count_all = ahead.purpose == NearPurpose::Region { wide: false };
        let started = Instant::now();
        let (rot, t) = (next.at.rotation_matrix(), next.at.translation());
        let sweep = Vector3::from(next.sweep);
        let detector = &mut self.detector;
        while ahead.object < meshes.objects.len() && end.is_none_or(|e| Instant::now() < e) {
            let object = ahead.object;
            let part_tree = &meshes.objects[object];
            let tool_tree = &meshes.tool;
            // The ranks go on from the objects before this one: one order over every object.
            let before: u64 = meshes.objects[..object]
                .iter()
                .map(|o| o.len() as u64)
                .sum();
            let first_rank = tool_tree.len() as u64 * before;
            let list = &mut detector.next_near;
            let bounds = &mut detector.next_apart;
            let gaps = &mut detector.next_gaps;
            let ranks = &mut detector.next_ranks;
            // Each tool triangle posed once for the list (a tool leaf meets several object
            // leaves), and kept while the descent goes on over frames.
            let mut posed = detector.list_poses.at(&rot, &t, &sweep);
            let mut dropped = 0;
            let visit = |tools: std::ops::Range<u32>, parts: std::ops::Range<u32>, rank: u64| {
                let leaves = LeafTriangles {
                    tool_tree,
                    part_tree,
                    object,
                    tools,
                    parts,
                    rank: first_rank + rank,
                };
                let into = NearInto {
                    list: &mut *list,
                    bounds: &mut *bounds,
                    gaps: &mut *gaps,
                    ranks: &mut *ranks,
                };
                dropped += leaves.push_near(&mut posed, &t, next.reach, into);
                count_all || dropped == 0
            };
            let over = tool_tree.descend(
                &rot,
                &t,
                &sweep,
                part_tree,
                next.reach,
                &mut detector.next_stack,
                NEAR_AHEAD_STEPS,
                visit,
            );
            ahead.dropped += dropped;
            if ahead.dropped > 0 && !count_all {
                if ahead.purpose == NearPurpose::Ahead {
                    // Too many for the storage: no list ahead this time.
                    self.run.regions.near_ahead = NearAhead::IDLE;
                    return false;
                }
                ahead.object = meshes.objects.len();
            } else if over {
                ahead.object += 1;
                TriangleTree::start_descent(&mut detector.next_stack);
            }
        }
        ahead.done = ahead.object >= meshes.objects.len();
        if ahead.done && detector.next_stack.gave_up_noting() {
            // A near part too far out to pay: as one that did not (`take_near_list`).
            self.run.regions.near_part_rest = NEAR_PART_REST_LISTS;
        }
        if ahead.done {
            // Its descent noted its near part (none near: the origin alone, no arm), which
            // the list's span holds from now on.
            ahead.at = Some(NearSpan {
                near: detector.next_stack.near_part().map(|(lo, hi)| {
                    if (0..3).all(|k| lo[k] <= hi[k]) {
                        CentreBox::of_box(Vector3::from(lo), Vector3::from(hi))
                    } else {
                        CentreBox::of_box(Vector3::zeros(), Vector3::zeros())
                    }
                }),
                ..next
            });
        }
        ahead.spent_us += started.elapsed().as_secs_f64() * 1e6;
        self.run.regions.near_ahead = ahead;
        ahead.done
    }

    /// Lists into `detector.near` the triangle pairs within the span's reach (mm) of each other
    /// anywhere on it, at once; returns how many did not fit in the list's storage.
    #[cfg(test)]
    fn list_near(&mut self, span: &NearSpan) -> usize {
        self.begin_near(*span, NearPurpose::Region { wide: false });
        self.advance_near(None);
        let dropped = self.run.regions.near_ahead.dropped;
        self.take_near_list(true, None);
        dropped
    }

    /// The motion bound (mm) of the tool at `q` from the nearest pose on `span`: no point of
    /// the tool is farther than this from where it was there.
    pub(super) fn span_bound(&self, span: &NearSpan, q: &Pose) -> f64 {
        let (near, whole) = self.span_bounds(span, q);
        match &span.near {
            // A pair the list does not hold was beyond its reach on the span; a point of the
            // tool outside the near part, beyond the reach and the near part's margin.
            Some(_) => near.max(whole - self.params.tuning.near_part_mm),
            None => whole,
        }
    }

    /// The motion bounds (mm) of the tool at `q` from the nearest pose on `span`: of the points
    /// of its near part (the whole tool's where none is known), and of the whole tool.
    fn span_bounds(&self, span: &NearSpan, q: &Pose) -> (f64, f64) {
        let off = q.translation() - span.at.translation();
        let off = detect::segment_distance(&off, &Vector3::from(span.sweep));
        let (r_a, r_b) = (span.at.rotation_matrix(), q.rotation_matrix());
        let whole = off + self.turn_bound(&r_a, &r_b);
        let near = off + self.bodies.part_turn_bound(span.near.as_ref(), &r_a, &r_b);
        (near, whole)
    }

    /// How far (mm) a tool triangle of a pair of the list in use moves at most when the tool
    /// turns from `r_a` to `r_b`: the list's near part's turn bound.
    pub(super) fn list_turn_bound(&self, r_a: &Matrix3<f64>, r_b: &Matrix3<f64>) -> f64 {
        let part = self
            .run
            .regions
            .near_at
            .as_ref()
            .and_then(|s| s.near.as_ref());
        self.bodies.part_turn_bound(part, r_a, r_b)
    }

    /// [`GodObject::motion_bound`] for the tool triangles of the list in use's pairs: the
    /// translation plus [`GodObject::list_turn_bound`].
    pub(super) fn list_motion_bound(&self, a: &Pose, b: &Pose) -> f64 {
        let dt = (b.translation() - a.translation()).norm();
        dt + self.list_turn_bound(&a.rotation_matrix(), &b.rotation_matrix())
    }

    /// The sweep (mm) of a new near list: the tool's last step times a number of frames, no
    /// longer than [`Tuning::near_sweep_mm`]. The frames are [`Tuning::near_sweep_frames`]
    /// times the share of the extra reach that was cut (a tight fit's wall within it), or,
    /// where the extra reach alone would be spent at the tool's speed before the next list can
    /// be built ahead, the frames its building takes (at most as many).
    fn near_sweep(&self) -> [f64; 3] {
        let step = Vector3::from(self.run.motion.last_step);
        let tuning = &self.params.tuning;
        let extra = self.run.regions.near_extra;
        let cut = (1.0 - extra / tuning.near_list_mm).clamp(0.0, 1.0);
        // A list built ahead starts once the tool has used its start share of the current one,
        // then takes a slice a frame at the last descent's cost. A peg falling past a hole's
        // wall 0.5 mm away spends an unswept list in 16 frames, while the next one's descent
        // takes 15 slices: every list was listed in a frame of 2 ms. A slow tool's list
        // outlasts its descent and is not swept (a longer list costs every region's filter).
        let to_build = self.near_descent_frames() / NEAR_AHEAD_START;
        let served = extra / self.run.motion.last_motion.max(1e-12);
        let paced = if served < to_build {
            to_build.min(tuning.near_sweep_frames)
        } else {
            0.0
        };
        let frames = (cut * tuning.near_sweep_frames)
            .max(paced)
            .min(tuning.near_sweep_mm / step.norm().max(1e-12));
        let sweep = step * frames;
        if sweep.iter().all(|v| v.is_finite()) {
            sweep.into()
        } else {
            [0.0; 3]
        }
    }

    /// Frames a near list's descent takes built ahead, a slice of
    /// [`Tuning::near_ahead_share`] of the budget a frame, at the last descent's cost.
    fn near_descent_frames(&self) -> f64 {
        let slice_us = self.params.tuning.near_ahead_share * self.params.budget_us;
        self.run.regions.near_descent_us / slice_us.max(1e-9)
    }

    /// Puts the near list under way in place of the current one when it is done and `covers`
    /// the region (every pose of it within the list's reach, less the region's margin, of its
    /// span); returns whether it did. One not done, or one that does not cover the region, is
    /// dropped (a list built ahead is when the current one is spent), and so is a region's
    /// wide list past the storage (false: the region lists its own pairs instead).
    fn take_near_list(&mut self, covers: bool, ball: Option<&Pose>) -> bool {
        let ahead = self.run.regions.near_ahead;
        let Some(at) = ahead.at else {
            return false;
        };
        self.run.regions.near_ahead = NearAhead::IDLE;
        let wide_over = ahead.purpose == (NearPurpose::Region { wide: true }) && ahead.dropped > 0;
        if !ahead.done || !covers || wide_over {
            return false;
        }

        // A list taken by a ball region inherits from the list in use
        // ([`Heuristics::mesh_list_inherit`]), its bounds moved to the ball's centre (below).
        // What the old list knew of its pairs' distances holds at its last filter's centre
        // (its kept bounds less their offset): at the ball's centre, less the motion bound
        // from there. (A path region filters it along its way from the first: moved to one
        // pose of it, the bounds would lose the way's length.)
        // A near part that bounded the tool's motion, where its list is given up, hardly less
        // than the whole tool's did not lengthen its use: the next lists are listed without one.
        if let Some(old) = self.run.regions.near_at.filter(|s| s.near.is_some()) {
            let whole = self.span_bounds(&old, &at.at).1;
            if whole > 0.0
                && self.span_bound(&old, &at.at) >= self.params.tuning.near_part_pays * whole
            {
                self.run.regions.near_part_rest = NEAR_PART_REST_LISTS;
            }
        }
        let heuristics = &self.params.heuristics;
        let inherit = heuristics.mesh_list_inherit && heuristics.mesh_near_list;
        let inherited = self
            .run
            .regions
            .near_bounds_at
            .zip(ball.filter(|_| inherit))
            .map(|(last, centre)| {
                let old_less = self.detector.near_offset + self.list_motion_bound(&last, centre);
                let way = self.span_bound(&at, centre);
                // A list's bounds and gaps hold for the points of its own near part (of the whole
                // tool where it has none). The old list's hold for its near part's points; the
                // rest of the tool was beyond its reach and the near part's margin where it was
                // listed, at the ball's centre at least `off` from the objects. So a bound is
                // taken up to `off`, and a gap only where the old near part holds the new one.
                let old_span = self.run.regions.near_at;
                let old_part = old_span.and_then(|s| s.near);
                let off = old_span
                    .filter(|_| old_part.is_some())
                    .map_or(f64::INFINITY, |s| {
                        s.reach + self.params.tuning.near_part_mm - self.span_bounds(&s, centre).1
                    });
                let nested = match (&at.near, &old_part) {
                    (_, None) => true,
                    (Some(new), Some(old)) => {
                        (0..3).all(|k| old.lo[k] <= new.lo[k] && new.hi[k] <= old.hi[k])
                    }
                    (None, Some(_)) => false,
                };
                let r_centre = centre.rotation_matrix();
                let turn = self.bodies.part_turn_bound(
                    at.near.as_ref(),
                    &at.at.rotation_matrix(),
                    &r_centre,
                );
                // The old list's directional gaps count its turns summed to its last filter,
                // and on to the ball's centre.
                let old_turn = self.detector.near_turn
                    + self.list_turn_bound(&last.rotation_matrix(), &r_centre);
                let turns = InheritedTurns {
                    at: centre.translation(),
                    old: old_turn,
                    new: turn,
                };
                let gaps =
                    self.params.heuristics.mesh_pair_directions && old_turn.is_finite() && nested;
                (*centre, way, (old_less, off), turn, gaps.then_some(turns))
            });
        let detector = &mut self.detector;
        std::mem::swap(&mut detector.near, &mut detector.next_near);
        std::mem::swap(&mut detector.near_apart, &mut detector.next_apart);
        std::mem::swap(&mut detector.near_gaps, &mut detector.next_gaps);
        std::mem::swap(&mut detector.near_ranks, &mut detector.next_ranks);
        detector.near_offset = 0.0;
        self.detector.near_turn = 0.0;
        self.detector.near_generation += 1;
        // The last region's checked distances name the old list's pairs: they name the new
        // one's (a region at the checked answer takes them on its new list too).
        self.detector.carry_reuse_to_new_list();
        self.run.regions.near_bounds_at = None;
        self.run.regions.near_listed_at = Some(at.at);
        match ahead.purpose {
            NearPurpose::Region { wide: false } => {
                // The region's own: not kept for later regions; past the storage it shrinks.
                self.run.regions.near_at = None;
                self.run.regions.dropped += ahead.dropped;
            }
            purpose => {
                if purpose == NearPurpose::Ahead {
                    self.run.counts.near_taken += 1;
                }
                self.run.regions.near_at = Some(at);
                self.run.regions.near_descent_us = ahead.spent_us;
                self.adapt_near_extra(at.reach, self.run.regions.near_extra);
            }
        }
        // (After the extra reach is adapted: that reads the bounds the listing gave, as the
        // next list's descent will.) Within the capacity reserved for the list: no allocation.
        // The inheriting list's bounds are moved to the ball's centre, where it is filtered
        // first: a listed bound holds anywhere on the span, so there less the motion bound
        // from the span's pose; the pairs' directional gaps, taken at the span's turn, count
        // the turn from there on.
        let detector = &mut self.detector;
        let len = detector.near.len();
        detector.next_edges.clear();
        detector.next_edges.resize(len, NearestEdges::NONE);
        if let Some((centre, way, old_less, turn, turns)) = inherited {
            detector.inherit_near(way, old_less, turns.as_ref());
            detector.near_turn = turn;
            self.run.regions.near_bounds_at = Some(centre);
        }
        std::mem::swap(&mut detector.near_edges, &mut detector.next_edges);
        true
    }

    /// Every region a list serves filters it whole: after a list of more than
    /// [`Tuning::near_list_pairs`] the next reaches half as far beyond its margin (where half
    /// the reach would keep at most [`NEAR_THIN_SHARE`] of its pairs, by their listed bounds:
    /// faces lying flat on each other have nearly all their pairs touching, at any reach),
    /// after one of under a quarter of that twice as far. `reach` is the list's (mm), `extra`
    /// the part of it beyond the regions' margin.
    fn adapt_near_extra(&mut self, reach: f64, extra: f64) {
        let len = self.detector.near.len();
        let halved = reach - 0.5 * extra;
        let within_half = self
            .detector
            .near_pairs_within(self.detector.near_offset, halved);
        let thins = within_half as f64 <= NEAR_THIN_SHARE * len as f64;
        let tuning = &self.params.tuning;
        self.run.regions.near_extra = if len > tuning.near_list_pairs && thins {
            0.5 * extra
        } else if 4 * len < tuning.near_list_pairs {
            (2.0 * extra).min(tuning.near_list_mm)
        } else {
            extra
        };
    }

    /// Builds the next near list a slice at a time (at most `slice_us`, µs, and never past
    /// `deadline`): once the tool has used half the current list (half its sweep, or half its
    /// extra reach off it), a list as wide from the pose the tool is expected at when the
    /// current one is spent, so that it is ready then and no frame pays a whole descent.
    pub(super) fn tend_near(&mut self, q: &Pose, slice_us: f64, deadline: Instant) {
        if self.bodies.meshes.is_none() {
            return;
        }
        // (A slice past any clock's range, or not a number, ends at the deadline.)
        let end = Duration::try_from_secs_f64(slice_us.max(0.0) * 1e-6)
            .ok()
            .and_then(|slice| Instant::now().checked_add(slice))
            .map_or(deadline, |e| e.min(deadline));
        if self.run.regions.near_ahead.at.is_some() {
            // A list under way (ahead, or a region's the frame had no time for) goes on.
            self.advance_near(Some(end));
            return;
        }
        let Some(span) = self
            .run
            .regions
            .near_at
            .filter(|_| self.params.heuristics.mesh_near_list)
        else {
            return;
        };
        let extra = self.run.regions.near_extra;
        let NearUse { used, along, left } = self.near_use(&span, q);
        // The next list starts once the tool has used its start share of this one, or
        // earlier where its descent, a slice a frame at the last one's cost, would not be
        // done by then.
        let build = self.near_descent_frames();
        if used < NEAR_AHEAD_START * extra
            && (span.sweep == [0.0; 3] || along < NEAR_AHEAD_START)
            && left > build / NEAR_AHEAD_START
        {
            return;
        }
        // Centred where the tool is expected when this one is spent.
        let frames = left.min(self.params.tuning.near_ahead_max_frames);
        let next = NearSpan {
            at: self.pose_ahead(q, frames),
            sweep: self.near_sweep(),
            reach: span.reach,
            near: None,
        };
        self.begin_near(next, NearPurpose::Ahead);
        self.advance_near(Some(end));
    }

    /// In a paced loop's wait ([`Heuristics::mesh_idle_take`]): puts the list built ahead, once
    /// done, in place of the one in use with the tool at `q`, where it holds a ball region of
    /// the last region's margin there at least as long as the one in use, and two frames at
    /// least ([`GodObject::near_frames_held`]); inheriting at `q`, as a ball region there would.
    /// Only where the time left before `stop` holds the inheritance at
    /// [`TAKE_NS_PER_PAIR`] for each pair of both lists. Returns whether it did.
    pub(super) fn take_near_list_in_wait(&mut self, q: &Pose, stop: Instant) -> bool {
        if !(self.params.heuristics.mesh_idle_take && self.params.heuristics.mesh_near_list) {
            return false;
        }
        let ahead = self.run.regions.near_ahead;
        let (Some(next), Some(now)) = (ahead.at, self.run.regions.near_at) else {
            return false;
        };
        if ahead.purpose != NearPurpose::Ahead || !ahead.done || ahead.dropped > 0 {
            return false;
        }
        let pairs = (self.detector.near.len() + self.detector.next_near.len()) as u64;
        let needed = Duration::from_nanos(TAKE_NS_PER_PAIR.saturating_mul(pairs));
        if Instant::now()
            .checked_add(needed)
            .is_none_or(|end| end > stop)
        {
            return false;
        }
        let held_next = self.near_frames_held(&next, q);
        if held_next < NEAR_IDLE_LEFT_FRAMES || held_next < self.near_frames_held(&now, q) {
            return false;
        }
        self.take_near_list(true, Some(q))
    }

    /// How far the tool at `q` has used the near list of `span`: its motion bound off the span
    /// (mm), its share along the sweep, and the frames until it is spent (the tool leaves its
    /// reach at the pace its motion bound grows off the sweep, a turn or a step across, or runs
    /// off the sweep's end), at the last frame's pace.
    fn near_use(&self, span: &NearSpan, q: &Pose) -> NearUse {
        let extra = self.run.regions.near_extra;
        let sweep = Vector3::from(span.sweep);
        let len = sweep.norm();
        let along = detect::segment_share(&(q.translation() - span.at.translation()), &sweep);
        let used = self.span_bound(span, q);
        let step = Vector3::from(self.run.motion.last_step);
        let along_speed = if len > 0.0 {
            (step.dot(&sweep) / len).max(0.0)
        } else {
            0.0
        };
        let off_speed = (self.run.motion.last_motion - along_speed).max(1e-9);
        let mut left = (extra - used).max(0.0) / off_speed;
        if along_speed > 0.0 {
            left = left.min((1.0 - along) * len / along_speed);
        }
        NearUse { used, along, left }
    }

    /// The time (µs) this frame gives the next near list's slice when the tool is at `q` and
    /// the frame's own work took `elapsed_us`: a full [`Tuning::near_ahead_share`] of the
    /// budget, or with [`Heuristics::mesh_near_fill`] what is left of
    /// [`Tuning::near_fill_share`] of it, or the pace the list's descent needs to be done in
    /// time if that is more (its rest at the last descent's cost over the start share of the
    /// frames until the list in use is spent: the margin the start rule leaves), at most the
    /// full slice. A region's list under way, wanted now, a list with none in use to outlast,
    /// and one past the last descent's cost take the full slice. A paced frame (the loop's
    /// wait before it given to [`GodObject::idle`]) gives none while the list in use holds
    /// the regions [`NEAR_IDLE_LEFT_FRAMES`] more ([`GodObject::near_frames_held`]): the wait
    /// builds it. With
    /// [`Heuristics::mesh_slice_ceiling`], never past [`Tuning::near_ceiling_share`] of the
    /// budget, the frame's own work included, while the list in use holds
    /// [`NEAR_CEILING_LEFT_FRAMES`] more ([`GodObject::near_frames_held`]).
    pub(super) fn near_slice_us(&self, q: &Pose, elapsed_us: f64) -> f64 {
        let slice = self.near_slice_paced_us(q, elapsed_us);
        if !self.params.heuristics.mesh_slice_ceiling {
            return slice;
        }
        let regions = &self.run.regions;
        let ahead = &regions.near_ahead;
        let in_use = regions
            .near_at
            .filter(|_| self.params.heuristics.mesh_near_list)
            .filter(|_| ahead.at.is_none() || ahead.purpose == NearPurpose::Ahead);
        match in_use {
            Some(span) if self.near_frames_held(&span, q) >= NEAR_CEILING_LEFT_FRAMES => {
                let ceiling = self.params.tuning.near_ceiling_share * self.params.budget_us;
                slice.min((ceiling - elapsed_us).max(0.0))
            }
            _ => slice,
        }
    }

    /// Frames the near list of `span` still holds a region of the last region's margin with
    /// the tool at `q`, at the last frame's pace: its reach less that margin and its use, over
    /// the last frame's motion bound. A list is spent later than its extra reach says where
    /// the regions it serves are narrower than the one it was listed for (a tight fit's).
    fn near_frames_held(&self, span: &NearSpan, q: &Pose) -> f64 {
        let margin = self.run.regions.contacts_at.map_or(0.0, |(_, m)| m);
        let room = span.reach - margin - self.span_bound(span, q);
        room.max(0.0) / self.run.motion.last_motion.max(1e-9)
    }

    /// Notes a frame's own work (µs, before the lists ahead) in the running quantile of
    /// [`Heuristics::mesh_fill_own_level`].
    pub(super) fn note_own_work(&mut self, own_us: f64) {
        let x = own_us.max(0.1).ln();
        let above = self.params.tuning.own_above_share;
        let level = self.run.lists.own_level_ln.get_or_insert(x);
        *level += if x > *level {
            OWN_LEVEL_RATE * (1.0 - above)
        } else {
            -OWN_LEVEL_RATE * above
        };
    }

    /// The level (µs) the next near list's slices fill a frame to: a fixed
    /// [`Tuning::near_fill_share`] of the budget, or with [`Heuristics::mesh_fill_own_level`]
    /// the running quantile of the frames' own work where that is lower.
    fn fill_level_us(&self) -> f64 {
        let budget = self.params.budget_us;
        let fixed = self.params.tuning.near_fill_share * budget;
        match self.run.lists.own_level_ln {
            Some(level)
                if self.params.heuristics.mesh_fill_own_level
                    && budget <= OWN_LEVEL_MAX_BUDGET_US =>
            {
                level.exp().min(fixed)
            }
            _ => fixed,
        }
    }

    /// [`GodObject::near_slice_us`] before its ceiling.
    fn near_slice_paced_us(&self, q: &Pose, elapsed_us: f64) -> f64 {
        let budget = self.params.budget_us;
        let full = self.params.tuning.near_ahead_share * budget;
        let room = self.fill_level_us() - elapsed_us;
        let paced = self.run.lists.idle_given;
        if !self.params.heuristics.mesh_near_fill || (room >= full && !paced) {
            return full;
        }
        let regions = &self.run.regions;
        let ahead = &regions.near_ahead;
        let in_use = regions
            .near_at
            .filter(|_| self.params.heuristics.mesh_near_list);
        let Some(span) =
            in_use.filter(|_| ahead.at.is_none() || ahead.purpose == NearPurpose::Ahead)
        else {
            return full;
        };
        if paced && self.near_frames_held(&span, q) >= NEAR_IDLE_LEFT_FRAMES {
            // A paced loop's wait builds the list ahead ([`GodObject::idle`], hundreds of
            // microseconds a period): the frame leaves it to the wait while the list in use
            // holds the regions, by its reach past their margin (as the ceiling reckons), not
            // by its extra reach alone: once a contact's margin has shrunk below the one it
            // was listed for, that is spent long before the list (the bunny's lists in a
            // paced loop: every frame sliced while the wait stood idle).
            return 0.0;
        }
        let spent = if ahead.at.is_some() {
            ahead.spent_us
        } else {
            0.0
        };
        let rest = regions.near_descent_us - spent;
        if rest <= 0.0 {
            // Past the last descent's cost (or none known): behind, the full slice.
            return full;
        }
        let left = NEAR_AHEAD_START * self.near_use(&span, q).left;
        let needed = rest / left.max(1.0);
        room.max(needed).clamp(0.0, full)
    }

    /// The two triangles of `c` with the tool at `(rot, t)`: the tool's posed, the object's.
    fn posed_pair(
        &self,
        meshes: &Meshes,
        c: &TriPair,
        rot: &Matrix3<f64>,
        t: &Vector3<f64>,
    ) -> (Triangle, Triangle) {
        let tool = PosedTriangle::of(&meshes.tool, c.tool, rot, t).corners;
        (tool, *meshes.objects[c.object as usize].triangle(c.part))
    }

    /// The lower bound of [`PosedTriangle::separation`] for `c` with the tool at `(rot, t)`,
    /// with the two triangles.
    fn posed_separation(
        &self,
        meshes: &Meshes,
        c: &TriPair,
        rot: &Matrix3<f64>,
        t: &Vector3<f64>,
    ) -> (f64, Triangle, Triangle) {
        let part_tree = &meshes.objects[c.object as usize];
        let tool = PosedTriangle::of(&meshes.tool, c.tool, rot, t);
        let bound = tool.separation(part_tree, c.part);
        (bound, tool.corners, *part_tree.triangle(c.part))
    }

    /// The rows of the triangle pairs linearised at `lin`'s pose: for each pair, the plane
    /// through the object's nearest point normal to the way to the tool's, moving with the
    /// tool's nearest point (the distance's value and gradient where the nearest features are
    /// unique), kept at [`GodObject::mesh_gap`]. Returns the row count.
    pub(super) fn fill_mesh_rows(&mut self, lin: &Linearization) -> usize {
        let Some(meshes) = &self.bodies.meshes else {
            return 0;
        };
        // The linearisation pose's own matrix, bit for bit the one an answer checked there was
        // measured at (a pose rebuilt from the variable differs by roundings).
        let q = lin.configuration(&lin.delta());
        let (rot, t) = lin.pose_parts();
        let target = self.mesh_gap();
        // No answer leaves the region (its trust rows), and no point of the tool moves farther
        // from its place at the region's centre than the listing margin: a pair farther apart
        // here than the way back to the centre and out to the region's edge (plus the gap) can
        // hold no answer back. Its row is left empty (never binding) and its distance bound
        // kept for the checks.
        let reach = self
            .run
            .regions
            .contacts_at
            .map_or(f64::INFINITY, |(c, m)| {
                self.motion_bound(&q, &c) + m + target
            });
        // At the pose the narrow phase measured them at (a region's first pass), or the check
        // of the last answer or the last rows did (the next pass or frame linearises there),
        // the exact distances measured there are the rows' own; those measured here are kept
        // for the check of an answer here and the next rows here (a tool at rest).
        self.detector.hold_distances_at(rot, t);
        let far_rows = self.params.heuristics.mesh_far_rows;
        let tilted_targets = self.params.heuristics.mesh_tilted_targets;
        let detector = &mut self.detector;
        // A tool triangle is posed only where its pair's distance is not known, or its row
        // needs its centre (an empty row, meeting triangles).
        let current = detector.contacts_list == Some(detector.near_generation);
        let mut tools = detector.tool_poses.at(&rot, &t, &Vector3::zeros());
        let mut n = 0;
        for c in &detector.contacts {
            let part_tree = &meshes.objects[c.object as usize];
            let part = part_tree.triangle(c.part);
            let known = detector.nearest_known[n].then(|| detector.contact_nearest[n]);
            let bound = match known {
                Some(d) => d.distance,
                None => tools
                    .get(&meshes.tool, c.tool)
                    .separation(part_tree, c.part),
            };
            if far_rows && bound > reach {
                detector.contact_gaps[n] = bound;
                // Never binding: no force acts here.
                let centre = centroid(&tools.get(&meshes.tool, c.tool).corners);
                detector.contact_points[n] = (rot.transpose() * (centre - t)).into();
                self.qp.rows[n] = [0.0; 6];
                self.qp.rhs[n] = -1.0;
                n += 1;
                continue;
            }
            let d = known.unwrap_or_else(|| {
                let tool = &tools.get(&meshes.tool, c.tool).corners;
                let last = near_edges(&mut detector.near_edges, &detector.contact_from, current, n);
                let d = match last {
                    Some(last) => triangle_distance_from(tool, part, last),
                    None => triangle_distance(tool, part),
                };
                detector.contact_nearest[n] = d;
                detector.nearest_known[n] = true;
                d
            });
            detector.contact_gaps[n] = d.distance;
            let (a, b) = (Vector3::from(d.on_a), Vector3::from(d.on_b));
            let normal = if d.distance > 0.0 {
                (a - b) / d.distance
            } else {
                // Meeting triangles have no nearest direction: the object face's normal,
                // turned toward the tool triangle's centre.
                face_normal_toward(part, &centroid(&tools.get(&meshes.tool, c.tool).corners))
            };
            // A tool face resting at the target beside an object face's edge (or the other way
            // round) has its nearest direction tilted toward the edge by `θ`: kept at the
            // target along it, the face's edge may come only part of the way over the other
            // face's each pass, however far the tool is pulled. Kept at `target · cos θ` (what
            // the resting face holds along it) it comes all the way.
            let p_in_tool: [f64; 3] = (rot.transpose() * (a - t)).into();
            detector.contact_points[n] = p_in_tool;
            let (value, j) =
                lin.face_value_gradient(&p_in_tool, 0.0, &normal.into(), normal.dot(&b) + target);
            let jd: f64 = j.iter().zip(&lin.delta()).map(|(x, y)| x * y).sum();
            self.qp.rows[n] = j;
            self.qp.rhs[n] = jd - value;
            n += 1;
        }
        // Tilted targets, in a pass of their own over the rows just made (their row's
        // translation part is its direction): folded into the loop above, the loop's code
        // cost `probe` 70 % of its median frame, the targets switched off too.
        for (i, c) in detector.contacts.iter().enumerate().take(n) {
            let row = &self.qp.rows[i];
            let nearest = Vector3::new(row[0], row[1], row[2]);
            let row_target = if tilted_targets
                && detector.contact_gaps[i] > 0.0
                && nearest != Vector3::zeros()
            {
                let part = meshes.objects[c.object as usize].plane(c.part).0;
                let part_cos = nearest.dot(&Vector3::from(part));
                let tool_cos = -nearest.dot(&(rot * Vector3::from(meshes.tool.plane(c.tool).0)));
                target * part_cos.max(tool_cos).clamp(TILTED_TARGET_LEAST, 1.0)
            } else {
                target
            };
            // The row's value rises by what its target gives up.
            self.qp.rhs[i] -= target - row_target;
            detector.row_targets[i] = row_target;
        }
        n
    }

    /// At the answer `q` (variable `dq`, the first `n` rows): whether any listed triangles
    /// meet (`f64::INFINITY` then, else 0: the mesh mode has no overlap), how far the rows the
    /// answer holds tight are open in truth (mm), and how many triangle pairs touch (exact
    /// distance at most [`TOUCH_MM`]).
    ///
    /// A pair farther apart at the linearisation pose `from` than the tool moves from there to
    /// `q` (the motion bound) cannot touch at `q` and is not measured again, unless its row is
    /// tight. The distances it measures are kept for rows linearised at `q`.
    pub(super) fn mesh_gaps_at(
        &mut self,
        from: &Pose,
        q: &Pose,
        dq: &[f64; 6],
        n: usize,
    ) -> (f64, f64, u32) {
        let moved = self.motion_bound(from, q);
        let Some(meshes) = &self.bodies.meshes else {
            return (0.0, 0.0, 0);
        };
        let (rot, t) = (q.rotation_matrix(), q.translation());
        let (detector, qp) = (&mut self.detector, &self.qp);
        detector.hold_distances_at(rot, t);
        let current = detector.contacts_list == Some(detector.near_generation);
        let mut tools = detector.tool_poses.at(&rot, &t, &Vector3::zeros());
        let (mut meet, mut slack, mut touching) = (false, 0.0f64, 0u32);
        for (i, c) in detector.contacts.iter().enumerate().take(n) {
            let row = &qp.rows[i];
            let lin_gap: f64 = (0..6).map(|k| row[k] * dq[k]).sum::<f64>() - qp.rhs[i];
            let tight = lin_gap <= TIGHT_MM;
            if !tight && detector.contact_gaps[i] - moved > TOUCH_MM {
                continue;
            }
            let d = if detector.nearest_known[i] {
                detector.contact_nearest[i]
            } else {
                let part_tree = &meshes.objects[c.object as usize];
                let tool = tools.get(&meshes.tool, c.tool);
                // A pair apart by more than the touch distance across a face's plane neither
                // meets nor touches: a few products instead of the fifteen features.
                if !tight && tool.separation(part_tree, c.part) > TOUCH_MM {
                    continue;
                }
                let part = part_tree.triangle(c.part);
                let last = near_edges(&mut detector.near_edges, &detector.contact_from, current, i);
                let d = match last {
                    Some(last) => triangle_distance_from(&tool.corners, part, last),
                    None => triangle_distance(&tool.corners, part),
                };
                detector.contact_nearest[i] = d;
                detector.nearest_known[i] = true;
                d
            };
            meet |= d.meet;
            touching += u32::from(d.distance <= TOUCH_MM);
            if tight {
                slack = slack.max(d.distance - detector.row_targets[i] - lin_gap);
            }
        }
        (if meet { f64::INFINITY } else { 0.0 }, slack, touching)
    }

    /// Whether any listed triangles meet with the tool at `q`; with `from`, the linearisation
    /// pose whose distances `contact_gaps` holds, a pair farther apart there than the tool
    /// moves to `q` is not measured again.
    pub(super) fn mesh_meets(&self, from: Option<&Pose>, q: &Pose) -> bool {
        let Some(meshes) = &self.bodies.meshes else {
            return false;
        };
        let (rot, t) = (q.rotation_matrix(), q.translation());
        let moved = from.map(|f| self.motion_bound(f, q));
        self.detector.contacts.iter().enumerate().any(|(i, c)| {
            if moved.is_some_and(|m| self.detector.contact_gaps[i] > m) {
                return false;
            }
            let (bound, tool, part) = self.posed_separation(meshes, c, &rot, &t);
            bound <= 0.0 && triangle_distance(&tool, &part).meet
        })
    }

    /// The last pose on the way from `lin`'s pose (free) to the answer `dq` (in the QP
    /// variable) where no listed triangles meet, by bisection, and its variable; `None` when
    /// even a short step meets (the rows misjudge the contact there).
    pub(super) fn last_free_on_the_way(
        &self,
        lin: &Linearization,
        dq: &[f64; 6],
    ) -> Option<(Pose, [f64; 6])> {
        let from = lin.delta();
        let q_lin = lin.configuration(&from);
        let at = |s: f64| -> [f64; 6] { std::array::from_fn(|k| from[k] + s * (dq[k] - from[k])) };
        let (mut free, mut meets) = (0.0, 1.0);
        for _ in 0..BACKTRACK_STEPS {
            let s = 0.5 * (free + meets);
            if self.mesh_meets(Some(&q_lin), &lin.configuration(&at(s))) {
                meets = s;
            } else {
                free = s;
            }
        }
        (free > 0.0).then(|| {
            let v = at(free);
            (lin.configuration(&v), v)
        })
    }

    /// In the mesh mode, the area (mm²) the touching triangle pairs share where their faces lie
    /// flat in the contact plane (normal `n`, within [`FLAT_CONTACT_COS`]) with the tool at `q`,
    /// and `∫|r - centre| dA` over it (mm³); `None` when no pair does (sphere mode, or contacts
    /// at edges and corners only).
    pub(super) fn flat_contact_area(
        &self,
        q: &Pose,
        n: &Vector3<f64>,
        centre: &Vector3<f64>,
    ) -> Option<(f64, f64)> {
        let meshes = self.bodies.meshes.as_ref()?;
        let (rot, t) = (q.rotation_matrix(), q.translation());
        let (mut area, mut moment) = (0.0, 0.0);
        for c in &self.detector.contacts {
            let (tool, part) = self.posed_pair(meshes, c, &rot, &t);
            let Some(m) = collide::flat_overlap(&tool, &part, n, centre, FLAT_CONTACT_COS) else {
                continue;
            };
            if m.area > 0.0
                && m.abs_moment.is_finite()
                && triangle_distance(&tool, &part).distance <= TOUCH_MM
            {
                area += m.area;
                moment += m.abs_moment;
            }
        }
        (area > 0.0).then_some((area, moment))
    }

    /// The point row `i` holds (world, mm: the tool point it was linearised at, posed at
    /// `(rot, t)`) and its triangle pair's distance there (mm). The row's own point, not the
    /// pair's nearest point at the pose: where faces lie flat on each other the nearest points
    /// are not unique, and a force must act where its row does.
    pub(super) fn mesh_contact_point(
        &self,
        i: usize,
        rot: &Matrix3<f64>,
        t: &Vector3<f64>,
    ) -> Option<(Vector3<f64>, f64)> {
        let meshes = self.bodies.meshes.as_ref()?;
        let c = self.detector.contacts.get(i)?;
        let (tool, part) = self.posed_pair(meshes, c, rot, t);
        let d = triangle_distance(&tool, &part);
        let at = rot * Vector3::from(*self.detector.contact_points.get(i)?) + t;
        Some((at, d.distance))
    }
}

/// The nearest edges last found for contact `n`'s pair, kept with the near list it came from
/// (none where the contacts are not of the list in use).
fn near_edges<'a>(
    near_edges: &'a mut [NearestEdges],
    contact_from: &[u32],
    current: bool,
    n: usize,
) -> Option<&'a mut NearestEdges> {
    let from = *contact_from.get(n)? as usize;
    current.then(|| near_edges.get_mut(from)).flatten()
}

/// The dot product of two vectors given as arrays (in the order `x, y, z`).
fn dot(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The greatest of `bound` (mm) over the poses of a region about `center` moved along `path`
/// (mm) by any share of it: at the path's ends, the bounds being convex along it.
fn farthest_on_path(center: &Pose, path: &Vector3<f64>, bound: &dyn Fn(&Pose) -> f64) -> f64 {
    let here = bound(center);
    if *path == Vector3::zeros() {
        return here;
    }
    let end =
        Pose::from_translation_rotation(&(center.translation() + path), &center.rotation_matrix());
    here.max(bound(&end))
}

/// How far (mm) the triangle `a` lies wholly on one side of the plane `n · p = d` (unit `n`):
/// positive in front (`n · p > d` at every corner), negative behind, 0 where it touches or
/// crosses it.
fn signed_side_gap(a: &Triangle, n: &[f64; 3], d: f64) -> f64 {
    signed_side_gap_moved(a, n, d, 0.0)
}

/// [`signed_side_gap`] with the points of `a` moved along `n` by any share of `shift` (mm): 0
/// where they touch or cross the plane anywhere on the way (or for a zero normal).
fn signed_side_gap_moved(a: &Triangle, n: &[f64; 3], d: f64, shift: f64) -> f64 {
    let (lo, hi) = side_range(a, n, d);
    let (lo, hi) = (lo + shift.min(0.0), hi + shift.max(0.0));
    if lo > 0.0 {
        lo
    } else if hi < 0.0 {
        hi
    } else {
        0.0
    }
}

/// The least and greatest height (mm) of the corners of `a` over the plane `n · p = d`.
fn side_range(a: &Triangle, n: &[f64; 3], d: f64) -> (f64, f64) {
    let side = a.map(|p| dot(n, &p) - d);
    (
        side[0].min(side[1]).min(side[2]),
        side[0].max(side[1]).max(side[2]),
    )
}

/// A lower bound (mm) on the distance of triangles `a` and `b`: how far `a` lies wholly on one
/// side of `b`'s plane (0 where it touches or crosses it; every point of `b` is in the plane,
/// so no point of `a` is nearer to `b` than to the plane). A few products against the exact
/// distance's fifteen features: it drops the facing pairs of a wall a tight fit slides along.
#[cfg(test)]
fn plane_gap(a: &Triangle, b: &Triangle) -> f64 {
    let t = TriangleTree::build(&[*b], &Pose::identity());
    let (n, d) = t.plane(0);
    signed_side_gap(a, &n, d).abs()
}

/// Near-list pairs read between two clock reads while the caches are warmed
/// ([`Detector::warm_near_chunk`]): about 60 KB, a few µs.
const WARM_NEAR_PAIRS: usize = 1024;

impl Detector {
    /// Reads chunk `k` of the near list's pairs, bounds and gaps (folding them into `acc`);
    /// false past its end.
    pub(super) fn warm_near_chunk(&self, k: usize, acc: &mut u32) -> bool {
        let first = k.saturating_mul(WARM_NEAR_PAIRS);
        let len = self
            .near
            .len()
            .min(self.near_apart.len())
            .min(self.near_gaps.len());
        if first >= len {
            return false;
        }
        let end = (first + WARM_NEAR_PAIRS).min(len);
        let mut a = *acc;
        for i in first..end {
            a = a
                .wrapping_add(self.near[i].tool)
                .wrapping_add(self.near_apart[i].to_bits() as u32)
                .wrapping_add(self.near_gaps[i].level.to_bits() as u32)
                .wrapping_add(self.near_gaps[i].upper.to_bits() as u32);
        }
        *acc = a;
        true
    }

    /// Makes the last region's checked distances (`reuse_*`), which name the pairs of the
    /// list just replaced (now in `next_near`, `next_ranks`), name the same pairs of the list
    /// just taken, by rank; those it does not hold are dropped. Nothing where they name
    /// another list.
    fn carry_reuse_to_new_list(&mut self) {
        if self.reuse_list.map(|l| l + 1) != Some(self.near_generation) {
            return;
        }
        let (old_ranks, new_ranks) = (&self.next_ranks, &self.near_ranks);
        let mut i = 0;
        let mut kept = 0;
        for k in 0..self.reuse_from.len() {
            let Some(&rank) = old_ranks.get(self.reuse_from[k] as usize) else {
                continue;
            };
            while i < new_ranks.len() && new_ranks[i] < rank {
                i += 1;
            }
            if i < new_ranks.len() && new_ranks[i] == rank {
                debug_assert!(self.next_near[self.reuse_from[k] as usize] == self.near[i]);
                self.reuse_from[kept] = i as u32;
                self.reuse_nearest[kept] = self.reuse_nearest[k];
                self.reuse_known[kept] = self.reuse_known[k];
                kept += 1;
            }
        }
        self.reuse_from.truncate(kept);
        self.reuse_nearest.truncate(kept);
        self.reuse_known.truncate(kept);
        self.reuse_list = Some(self.near_generation);
    }

    /// Merges the near list just taken (`near`, its bounds and ranks) with the one it replaced
    /// (in `next_near`, `next_apart` and `next_ranks`, its nearest edges still in
    /// `near_edges`) in one walk by rank: each pair in both takes the old one's nearest edges
    /// (into `next_edges`), and every bound is moved to one pose: the listed ones less `way`
    /// (mm, the motion bound from the new span to it), and each pair in both takes the larger
    /// of that and the old one's less `old_less` (mm, the old bounds' offset and the motion
    /// bound from where they hold to it), and the old upper bound plus `old_less`.
    ///
    /// With `turns`, each pair in both also takes the old one's directional gap where that is
    /// the wider at the pose (`turns.at`), re-levelled from the old list's turn offset there to
    /// the new one's ([`PairGap::relevelled`]): a gap sideways that a filter found, kept, where
    /// the new list knows only the plane's.
    fn inherit_near(
        &mut self,
        way: f64,
        (old_less, cap): (f64, f64),
        turns: Option<&InheritedTurns>,
    ) {
        let old_ranks = &self.next_ranks;
        let old_len = old_ranks
            .len()
            .min(self.next_apart.len())
            .min(self.near_edges.len())
            .min(self.next_gaps.len());
        let mut j = 0;
        let new = self
            .near_ranks
            .iter()
            .zip(self.near_apart.iter_mut().zip(self.near_gaps.iter_mut()));
        for (i, (&rank, (bound, gap))) in new.enumerate() {
            *bound -= way;
            while j < old_len && old_ranks[j] < rank {
                j += 1;
            }
            if j < old_len && old_ranks[j] == rank {
                debug_assert!(self.next_near[j] == self.near[i], "one rank, two pairs");
                self.next_edges[i] = self.near_edges[j];
                *bound = bound.max((self.next_apart[j] - old_less).min(cap));
                let old = &self.next_gaps[j];
                if let Some(turns) = turns.filter(|_| old.is_known()) {
                    let zero = Vector3::zeros();
                    let old_here = old.at(&turns.at, &zero, turns.old);
                    if old_here > gap.at(&turns.at, &zero, turns.new) {
                        *gap = old.relevelled(turns.old, turns.new);
                    }
                }
                gap.upper = self.next_gaps[j].upper + old_less;
            }
        }
    }
}

/// The triangles of a leaf pair of the triangle trees: the tool leaf's and object `object`'s.
struct LeafTriangles<'a> {
    tool_tree: &'a TriangleTree,
    part_tree: &'a TriangleTree,
    object: usize,
    tools: std::ops::Range<u32>,
    parts: std::ops::Range<u32>,
    /// The rank of its first triangle pair ([`TriangleTree::descend`]).
    rank: u64,
}

/// Where a near list under way is pushed: its pairs and, in the same order, their bounds,
/// gaps and ranks.
struct NearInto<'a> {
    list: &'a mut Vec<TriPair>,
    bounds: &'a mut Vec<f64>,
    gaps: &'a mut Vec<PairGap>,
    ranks: &'a mut Vec<u64>,
}

impl LeafTriangles<'_> {
    /// Pushes onto `list` its triangle pairs that no bound puts farther apart than `margin`
    /// (mm) with the tool's triangles `posed` (at a pose of translation `t`, mm, moved along a
    /// sweep by any share of it), with their bounds and gaps; returns how many did not fit in
    /// its storage.
    fn push_near(
        self,
        posed: &mut PosedTools<'_>,
        t: &Vector3<f64>,
        margin: f64,
        into: NearInto<'_>,
    ) -> usize {
        let NearInto {
            list,
            bounds,
            gaps,
            ranks,
        } = into;
        let mut dropped = 0;
        let width = self.parts.len() as u64;
        for tool in self.tools.clone() {
            let tool_tri = posed.get(self.tool_tree, tool);
            let row = self.rank + u64::from(tool - self.tools.start) * width;
            for part in self.parts.clone() {
                let Some(apart) = tool_tri.separation_within(self.part_tree, part, margin, false)
                else {
                    continue;
                };
                if list.len() < list.capacity() {
                    // The tool's triangle off the object's plane where listed (its span's pose,
                    // not swept).
                    let (n, d) = self.part_tree.plane(part);
                    let beyond = signed_side_gap(&tool_tri.corners, &n, d);
                    bounds.push(apart);
                    ranks.push(row + u64::from(part - self.parts.start));
                    gaps.push(if beyond == 0.0 {
                        PairGap::NONE
                    } else {
                        PairGap::new(
                            beyond.abs(),
                            n.map(|v| beyond.signum() * v),
                            &tool_tri.corners,
                            t,
                            0.0,
                        )
                    });
                    list.push(TriPair {
                        object: self.object as u32,
                        tool,
                        part,
                    });
                } else {
                    dropped += 1;
                }
            }
        }
        dropped
    }
}

/// The tool's triangles posed at one pose (and moved along one sweep), each posed the first
/// time it is asked for there: a near list names a few hundred tool triangles thousands of
/// times (faces lying on each other in a turn: 5 000 pairs, 300 tool triangles).
pub(super) struct ToolPoses {
    posed: Vec<PosedTriangle>,
    /// `posed[i]` is at the current pose where `stamp[i] == current`.
    stamp: Vec<u32>,
    current: u32,
    /// The pose (rotation, translation, mm) and sweep (mm) the stamp stands for.
    at: Option<(Matrix3<f64>, Vector3<f64>, Vector3<f64>)>,
}

impl ToolPoses {
    /// Room for a tool of `triangles` triangles, none posed.
    pub(super) fn new(triangles: usize) -> Self {
        Self {
            posed: vec![PosedTriangle::UNPOSED; triangles],
            stamp: vec![0; triangles],
            current: 0,
            at: None,
        }
    }

    /// Makes its storage resident ([`collide::touch_pages`]).
    pub(super) fn touch_pages(&mut self) {
        collide::touch_pages(&mut self.posed);
        collide::touch_pages(&mut self.stamp);
    }

    /// The triangles at `(rot, t)` moved along `sweep` (mm): those posed elsewhere are posed
    /// again when asked for.
    fn at(&mut self, rot: &Matrix3<f64>, t: &Vector3<f64>, sweep: &Vector3<f64>) -> PosedTools<'_> {
        let pose = (*rot, *t, *sweep);
        if self.at != Some(pose) {
            self.at = Some(pose);
            self.current = self.current.wrapping_add(1);
            if self.current == 0 {
                // The stamps came round: none may pass for current.
                self.stamp.iter_mut().for_each(|s| *s = 0);
                self.current = 1;
            }
        }
        PosedTools { poses: self, pose }
    }
}

/// The tool's triangles at one pose ([`ToolPoses::at`]).
pub(super) struct PosedTools<'a> {
    poses: &'a mut ToolPoses,
    pose: (Matrix3<f64>, Vector3<f64>, Vector3<f64>),
}

impl PosedTools<'_> {
    /// Triangle `i` of the tool's `tree`, posed.
    fn get(&mut self, tree: &TriangleTree, i: u32) -> &PosedTriangle {
        let (k, poses) = (i as usize, &mut *self.poses);
        if poses.stamp[k] != poses.current {
            let (rot, t, sweep) = &self.pose;
            poses.posed[k] = PosedTriangle::of(tree, i, rot, t).swept(sweep);
            poses.stamp[k] = poses.current;
        }
        &poses.posed[k]
    }
}

/// A triangle of the tool posed in the world: corners, plane (unit normal, offset) and box
/// along the world axes, mm; and the sweep (mm) it moves along from there, which its box
/// holds, and that sweep's reach along its normal (0 for the pose alone).
#[derive(Clone, Copy, Debug)]
pub(super) struct PosedTriangle {
    pub(super) corners: Triangle,
    normal: [f64; 3],
    offset: f64,
    bounds: ([f64; 3], [f64; 3]),
    /// Its edges' outward normals in its plane (unit) and offsets, as
    /// [`TriangleTree::edges`] gives them, in the world: posed once for the pairs it is in.
    edges: [([f64; 3], f64); 3],
    sweep: [f64; 3],
    rise: f64,
}

impl PosedTriangle {
    /// A placeholder for storage, never measured.
    const UNPOSED: Self = Self {
        corners: [[0.0; 3]; 3],
        normal: [0.0; 3],
        offset: 0.0,
        bounds: ([0.0; 3], [0.0; 3]),
        edges: [([0.0; 3], 0.0); 3],
        sweep: [0.0; 3],
        rise: 0.0,
    };

    /// Triangle `i` of `tree` (the tool frame) with the tool at `(rot, t)`.
    fn of(tree: &TriangleTree, i: u32, rot: &Matrix3<f64>, t: &Vector3<f64>) -> Self {
        let (n, d) = tree.plane(i);
        let n = rot * Vector3::from(n);
        let corners = tree
            .triangle(i)
            .map(|p| (rot * Vector3::from(p) + t).into());
        let in_tool = tree.edges(i);
        let edge = |k: usize| {
            let (m, e) = in_tool[k];
            let m = rot * Vector3::from(m);
            (m.into(), e + m.dot(t))
        };
        Self {
            corners,
            normal: n.into(),
            offset: d + n.dot(t),
            bounds: collide::bounds_of(&corners),
            edges: [edge(0), edge(1), edge(2)],
            sweep: [0.0; 3],
            rise: 0.0,
        }
    }

    /// The triangle moved along `sweep` (mm, world) by any share of it: its bounds hold every
    /// such pose.
    fn swept(mut self, sweep: &Vector3<f64>) -> Self {
        for k in 0..3 {
            self.bounds.0[k] += sweep[k].min(0.0);
            self.bounds.1[k] += sweep[k].max(0.0);
        }
        self.rise = Vector3::from(self.normal).dot(sweep);
        self.sweep = (*sweep).into();
        self
    }

    /// A lower bound (mm) on its distance to triangle `i` of `part` (world): the larger of
    /// how far their boxes along the world axes are apart and how far either lies wholly on
    /// one side of the other's plane. The boxes drop the pairs the planes cannot: in a tight
    /// fit every wall's plane runs through the other part, so a facet far along the wall
    /// from another is on neither side of its plane, yet its box is well apart.
    fn separation(&self, part: &TriangleTree, i: u32) -> f64 {
        self.planes_beyond(part, i, self.box_gap(part, i))
    }

    /// The larger of `boxes` and how far either triangle lies wholly beyond the other's plane
    /// (anywhere on the sweep: the tool's corners move along the part's normal by a share of
    /// the sweep's reach along it, the tool's plane by a share of its rise).
    fn planes_beyond(&self, part: &TriangleTree, i: u32, boxes: f64) -> f64 {
        let (n, d) = part.plane(i);
        let shift = dot(&n, &self.sweep);
        boxes
            .max(signed_side_gap_moved(&self.corners, &n, d, shift).abs())
            .max(
                signed_side_gap_moved(part.triangle(i), &self.normal, self.offset, -self.rise)
                    .abs(),
            )
    }

    /// [`PosedTriangle::planes_beyond`] with the way its bound runs ([`gap_way`]),
    /// `boxes` being the boxes' with theirs.
    fn planes_beyond_along(&self, part: &TriangleTree, i: u32, boxes: (f64, i8)) -> (f64, i8) {
        let (n, d) = part.plane(i);
        let shift = dot(&n, &self.sweep);
        let mut best = boxes;
        let tool_off = signed_side_gap_moved(&self.corners, &n, d, shift);
        if tool_off.abs() > best.0 {
            best = (tool_off.abs(), tool_off.signum() as i8);
        }
        let part_off =
            signed_side_gap_moved(part.triangle(i), &self.normal, self.offset, -self.rise);
        if part_off.abs() > best.0 {
            best = (part_off.abs(), 2 * part_off.signum() as i8);
        }
        best
    }

    /// [`PosedTriangle::separation`] where it is at most `margin` (mm), else `None`: the
    /// boxes, a few comparisons, settle most pairs a wall apart before the planes are taken;
    /// with `edges`, pairs the planes leave within the margin are then held against each
    /// other's edges ([`PosedTriangle::edges_beyond`]). A region's filter takes the edges: a
    /// pair they drop saves its exact distance (a face lying on a fan of slivers, 2 900 pairs
    /// a region, most apart sideways). A near list's descent does not: its pairs are cheap
    /// to keep, and lists cut shorter are rebuilt as often with a wider reach (zoo p99
    /// +20–50 % on three scenes when the descents took them too).
    fn separation_within(
        &self,
        part: &TriangleTree,
        i: u32,
        margin: f64,
        edges: bool,
    ) -> Option<f64> {
        Some(self.separation_upto(part, i, margin, edges)).filter(|&s| s <= margin)
    }

    /// A lower bound (mm) on the pair's distance, as [`PosedTriangle::separation_within`]
    /// takes it: the first of its tests that puts the pair beyond `margin`, or all of them.
    fn separation_upto(&self, part: &TriangleTree, i: u32, margin: f64, edges: bool) -> f64 {
        let boxes = self.box_gap(part, i);
        if boxes > margin {
            return boxes;
        }
        let planes = self.planes_beyond(part, i, boxes);
        if planes > margin || !edges {
            return planes;
        }
        self.edges_beyond(part, i, planes)
    }

    /// [`PosedTriangle::separation_upto`], with the way the bound runs ([`gap_way`]; 0 where
    /// no test put the pair apart).
    fn separation_upto_along(
        &self,
        part: &TriangleTree,
        i: u32,
        margin: f64,
        edges: bool,
    ) -> (f64, i8) {
        let boxes = self.box_gap_along(part, i);
        if boxes.0 > margin {
            return boxes;
        }
        let planes = self.planes_beyond_along(part, i, boxes);
        if planes.0 > margin || !edges {
            return planes;
        }
        self.edges_beyond_along(part, i, planes)
    }

    /// The larger of `bound` and how far either triangle lies wholly beyond one of the other's
    /// edges, across it in that triangle's plane (each such line bounds a half-space holding
    /// its triangle). Faces lying on each other are apart only sideways, where neither plane
    /// nor a box along the world's axes tells them apart: a fan's slivers on a ring of facets.
    fn edges_beyond(&self, part: &TriangleTree, i: u32, bound: f64) -> f64 {
        self.edges_beyond_along(part, i, (bound, 0)).0
    }

    /// [`PosedTriangle::edges_beyond`] with the way its bound runs ([`gap_way`]), `bound`
    /// being the other tests' with theirs.
    fn edges_beyond_along(&self, part: &TriangleTree, i: u32, bound: (f64, i8)) -> (f64, i8) {
        let other = part.triangle(i);
        let mut best = bound;
        for (k, (m, e)) in (6..).zip(&self.edges) {
            if *m != [0.0; 3] {
                // The tool's edge moves along the sweep by a share of its reach along m.
                let reach = dot(m, &self.sweep).max(0.0);
                let gap = lowest_along(m, other) - e - reach;
                if gap > best.0 {
                    best = (gap, k);
                }
            }
        }
        for (k, (m, e)) in (9..).zip(part.edges(i)) {
            if *m != [0.0; 3] {
                let back = dot(m, &self.sweep).min(0.0);
                let gap = lowest_along(m, &self.corners) + back - e;
                if gap > best.0 {
                    best = (gap, k);
                }
            }
        }
        best
    }

    /// How far (mm) its box and triangle `i`'s of `part` are apart along a world axis (0 where
    /// they overlap).
    fn box_gap(&self, part: &TriangleTree, i: u32) -> f64 {
        let ((lo, hi), (part_lo, part_hi)) = (&self.bounds, part.bounds(i));
        (0..3)
            .map(|k| (lo[k] - part_hi[k]).max(part_lo[k] - hi[k]))
            .fold(0.0f64, f64::max)
    }

    /// [`PosedTriangle::box_gap`], with the axis and side it runs along ([`gap_way`]; 0
    /// where the boxes overlap).
    fn box_gap_along(&self, part: &TriangleTree, i: u32) -> (f64, i8) {
        let ((lo, hi), (part_lo, part_hi)) = (&self.bounds, part.bounds(i));
        let mut best = (0.0, 0);
        for k in 0..3 {
            let (above, below) = (lo[k] - part_hi[k], part_lo[k] - hi[k]);
            let axis = 3 + k as i8;
            if above > best.0 {
                best = (above, axis);
            }
            if below > best.0 {
                best = (below, -axis);
            }
        }
        best
    }
}

fn centroid(t: &Triangle) -> Vector3<f64> {
    (Vector3::from(t[0]) + Vector3::from(t[1]) + Vector3::from(t[2])) / 3.0
}

/// The unit normal of triangle `t` on the side of `p` (any unit vector for a degenerate one).
fn face_normal_toward(t: &Triangle, p: &Vector3<f64>) -> Vector3<f64> {
    let (a, b, c) = (
        Vector3::from(t[0]),
        Vector3::from(t[1]),
        Vector3::from(t[2]),
    );
    let n = (b - a).cross(&(c - a));
    let len = n.norm();
    if len <= 0.0 {
        return Vector3::z();
    }
    let n = n / len;
    if n.dot(&(p - a)) < 0.0 {
        -n
    } else {
        n
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use spheretree::Sphere;

    impl GodObject {
        /// The leaf pairs within `margin` (mm) of touching at `q`, then their triangle pairs.
        fn detect_triangles(&mut self, q: &Pose, margin: f64) {
            self.detect(q, margin).unwrap();
            self.narrow_phase(q, margin);
        }
    }

    /// A closed box mesh, `half` its half-extents (mm), centred at `c`.
    fn box_mesh(c: [f64; 3], half: [f64; 3]) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
        let v: Vec<[f64; 3]> = (0..8)
            .map(|i| {
                std::array::from_fn(|k| c[k] + if (i >> k) & 1 == 1 { half[k] } else { -half[k] })
            })
            .collect();
        let quads = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        let t = quads
            .iter()
            .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
            .collect();
        (v, t)
    }

    /// A one-leaf tree of radius `r` about `c` (the mesh mode grows it to hold its triangles,
    /// split to half its size).
    fn one_leaf(c: [f64; 3], r: f64) -> SphereTree {
        SphereTree::from_slots(1, 2, vec![Sphere::new(c, r)]).unwrap()
    }

    /// A 4 mm cube tool (its centre at the tool origin) over a 40 x 40 x 2 mm plate whose top is
    /// at z = 0, in the mesh mode.
    fn cube_on_plate() -> (GodObject, Vec<Triangle>, Vec<Triangle>) {
        let plate = box_mesh([0.0, 0.0, -1.0], [20.0, 20.0, 1.0]);
        cube_over(&plate, one_leaf([0.0, 0.0, -1.0], 28.3))
    }

    /// The 4 mm cube tool (one leaf about its centre, the tool origin) over `object` (its
    /// vertices and triangles, world; `tree` its one-leaf tree), in the mesh mode: the god
    /// object and both meshes' triangles.
    fn cube_over(
        object: &(Vec<[f64; 3]>, Vec<[u32; 3]>),
        tree: SphereTree,
    ) -> (GodObject, Vec<Triangle>, Vec<Triangle>) {
        cube_over_storing(object, tree, EngineConfig::default().max_pairs)
    }

    /// [`cube_over`] with storage for `max_pairs` pairs.
    fn cube_over_storing(
        object: &(Vec<[f64; 3]>, Vec<[u32; 3]>),
        tree: SphereTree,
        max_pairs: usize,
    ) -> (GodObject, Vec<Triangle>, Vec<Triangle>) {
        let (tv, tt) = box_mesh([0.0; 3], [2.0; 3]);
        let (pv, pt) = object;
        let params = EngineConfig {
            geometry: Geometry::Mesh,
            max_pairs,
            ..EngineConfig::default()
        };
        let god = GodObject::with_meshes(
            &one_leaf([0.0; 3], 3.5),
            Some(MeshRef {
                vertices: &tv,
                triangles: &tt,
            }),
            &[(tree, Pose::identity())],
            &[Some(MeshRef {
                vertices: pv,
                triangles: pt,
            })],
            params,
        )
        .unwrap();
        let tris = |v: &[[f64; 3]], t: &[[u32; 3]]| -> Vec<Triangle> {
            t.iter().map(|t| t.map(|i| v[i as usize])).collect()
        };
        (god, tris(&tv, &tt), tris(pv, pt))
    }

    /// The least distance between the tool's triangles at `q` and the plate's, over every pair
    /// (negative when some meet).
    fn brute_distance(tool: &[Triangle], plate: &[Triangle], q: &Pose) -> f64 {
        let (r, t) = (q.rotation_matrix(), q.translation());
        let mut best = f64::INFINITY;
        for a in tool {
            let a = a.map(|p| (r * Vector3::from(p) + t).into());
            for b in plate {
                let d = triangle_distance(&a, b);
                if d.meet {
                    return -1.0;
                }
                best = best.min(d.distance);
            }
        }
        best
    }

    /// A square sheet `[-half, half]²` (mm) of `n × n` cells, two triangles each, facing `+z`,
    /// its height `z(x, y)` at the corners.
    fn grid_sheet(
        n: u32,
        half: f64,
        z: impl Fn(f64, f64) -> f64,
    ) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
        let cell = 2.0 * half / f64::from(n);
        let v = (0..=n)
            .flat_map(|i| (0..=n).map(move |j| (i, j)))
            .map(|(i, j)| {
                let (x, y) = (-half + cell * f64::from(i), -half + cell * f64::from(j));
                [x, y, z(x, y)]
            })
            .collect();
        let at = |i: u32, j: u32| i * (n + 1) + j;
        let t = (0..n)
            .flat_map(|i| (0..n).map(move |j| (i, j)))
            .flat_map(|(i, j)| {
                [
                    [at(i, j), at(i + 1, j), at(i + 1, j + 1)],
                    [at(i, j), at(i + 1, j + 1), at(i, j + 1)],
                ]
            })
            .collect();
        (v, t)
    }

    /// The 4 mm cube tool over a wavy 40 x 40 mm sheet of 2 x 2 mm cells (800 triangles), so
    /// that which pairs are near changes as the tool slides.
    fn cube_over_sheet() -> (GodObject, Vec<Triangle>, Vec<Triangle>) {
        cube_over_sheet_storing(EngineConfig::default().max_pairs)
    }

    /// [`cube_over_sheet`] with storage for `max_pairs` pairs.
    fn cube_over_sheet_storing(max_pairs: usize) -> (GodObject, Vec<Triangle>, Vec<Triangle>) {
        let sheet = grid_sheet(20, 20.0, |x, y| 0.3 * (0.4 * x).sin() * (0.3 * y).cos());
        cube_over_storing(&sheet, one_leaf([0.0; 3], 28.3), max_pairs)
    }

    /// A ball over its pair target may be followed by a wider one only where a wider one
    /// would hold few more pairs: a cube resting on a plate has every pair touching (a
    /// smaller ball sheds none of them, a wider one gains none), a cube over a wavy sheet has
    /// its pairs spread past the margin (a wider one gains many).
    #[test]
    fn a_dense_ball_grows_only_where_a_wider_one_would_hold_few_more_pairs() {
        let growth_after_a_dense_ball =
            |(mut god, _, _): (GodObject, Vec<Triangle>, Vec<Triangle>), q: Pose, on: bool| {
                god.params.tuning.ball_pair_target = 2.0;
                god.params.heuristics.mesh_slow_growth = on;
                let margin = 0.1;
                god.detect_triangles(&q, margin);
                assert!(
                    god.detector.contacts.len() > 2,
                    "{}",
                    god.detector.contacts.len()
                );
                god.run.regions.slow_growth_to.map(|wide| wide / margin)
            };
        let resting = Pose::from_array([0.0, 0.0, 2.001, 0.0, 0.0, 0.0]);
        let grown = growth_after_a_dense_ball(cube_on_plate(), resting, true);
        assert!(
            grown.is_some_and(|g| (SLOW_GROWTH_LEAST..=2.0).contains(&g)),
            "{grown:?}"
        );
        assert_eq!(
            growth_after_a_dense_ball(cube_on_plate(), resting, false),
            None
        );
        // Over the sheet, 12 pairs within the margin and 52 within twice it.
        let above = Pose::from_array([0.0, 0.0, 2.28, 0.0, 0.0, 0.0]);
        assert_eq!(
            growth_after_a_dense_ball(cube_over_sheet(), above, true),
            None
        );
    }

    /// A near list longer than its target reaches half as far next time only where that
    /// lists fewer pairs: a cube resting on a plate has every pair touching at any reach, a
    /// cube over a wavy sheet has its pairs spread over the reach.
    #[test]
    fn a_long_near_list_is_shortened_only_where_a_shorter_reach_lists_fewer_pairs() {
        let reach_after_a_long_list =
            |(mut god, _, _): (GodObject, Vec<Triangle>, Vec<Triangle>), q: Pose| {
                god.params.tuning.near_list_pairs = 4;
                let extra = god.run.regions.near_extra;
                god.detect_triangles(&q, 0.1);
                assert!(god.run.regions.near_at.is_some());
                assert!(god.detector.near.len() > 4, "{}", god.detector.near.len());
                god.run.regions.near_extra / extra
            };
        let resting = Pose::from_array([0.0, 0.0, 2.001, 0.0, 0.0, 0.0]);
        assert_eq!(reach_after_a_long_list(cube_on_plate(), resting), 1.0);
        let above = Pose::from_array([0.0, 0.0, 2.45, 0.0, 0.0, 0.0]);
        assert_eq!(reach_after_a_long_list(cube_over_sheet(), above), 0.5);
    }

    /// A wide list that does not fit in the storage is dropped (its descent stopped at the
    /// first pair past it) and the region's own pairs listed instead, every one past the
    /// storage counted (the region shrinks by them).
    #[test]
    fn a_wide_list_past_the_storage_gives_way_to_the_regions_own_pairs_all_counted() {
        let q = Pose::from_array([0.0, 0.0, 2.45, 0.0, 0.0, 0.0]);
        let listed = |max_pairs: usize| {
            let (mut god, _, _) = cube_over_sheet_storing(max_pairs);
            god.detect_triangles(&q, 0.25);
            god
        };
        let whole = listed(EngineConfig::default().max_pairs);
        let wide = whole.detector.near.len();
        assert!(whole.run.regions.near_at.is_some());
        let mut own = listed(EngineConfig::default().max_pairs);
        let span = NearSpan {
            at: q,
            sweep: [0.0; 3],
            reach: 0.25,
            near: None,
        };
        assert_eq!(own.list_near(&span), 0);
        let own_len = own.detector.near.len();
        assert!(4 < own_len && own_len + 4 < wide, "{own_len} of {wide}");
        // Room for the region's own pairs, not the wide list's.
        let roomy = listed(own_len + 2);
        assert!(roomy.run.regions.near_at.is_none());
        assert_eq!(roomy.detector.near.len(), own_len);
        assert_eq!(roomy.run.regions.dropped, 0);
        // Room for neither: every own pair past the storage counted.
        let tight = listed(own_len - 3);
        assert!(tight.run.regions.near_at.is_none());
        assert_eq!(tight.run.regions.dropped, 3);
    }

    /// Along a path the narrow phase lists every pair within the margin of each other with the
    /// tool anywhere on the path (sampled, against all pairs), and far fewer than a ball as
    /// wide as the path.
    #[test]
    fn a_path_lists_every_pair_near_the_tool_anywhere_along_it() {
        let (mut god, _, _) = cube_over_sheet();
        let q = Pose::from_array([-3.0, 1.0, 2.45, 0.0, 0.0, 0.1]);
        let path = Vector3::new(6.0, -2.0, -0.1);
        let margin = 0.2;
        god.detect(&q, path.norm() + margin).unwrap();
        god.narrow_phase_along(&q, margin, &path);
        let listed: std::collections::HashSet<(u32, u32)> = god
            .detector
            .contacts
            .iter()
            .map(|c| (c.tool, c.part))
            .collect();
        let meshes = god.bodies.meshes.as_ref().unwrap();
        let (tool, sheet) = (&meshes.tool, &meshes.objects[0]);
        let mut near = 0;
        for k in 0..=40 {
            let t = q.translation() + path * (f64::from(k) / 40.0);
            let r = q.rotation_matrix();
            for i in 0..tool.len() as u32 {
                let a = tool.triangle(i).map(|p| (r * Vector3::from(p) + t).into());
                for j in 0..sheet.len() as u32 {
                    if triangle_distance(&a, sheet.triangle(j)).distance <= margin {
                        near += 1;
                        assert!(listed.contains(&(i, j)), "{i} {j} at {k}");
                    }
                }
            }
        }
        assert!(near > 0);
        // A ball as wide as the path holds many more.
        let along = god.detector.contacts.len();
        god.narrow_phase(&q, path.norm() + margin);
        let ball = god.detector.contacts.len();
        assert!(3 * along < ball, "{along} of {ball}");
    }

    #[test]
    fn a_list_is_swept_along_the_motion_only_where_its_reach_is_spent_before_the_next_is_built() {
        let (mut god, _, _) = cube_over_sheet();
        let full = god.params.tuning.near_list_mm;
        let slice_us = god.params.tuning.near_ahead_share * god.params.budget_us;
        god.run.regions.near_extra = full;
        // A descent of 15 slices; a tool falling 0.016 mm a frame spends the extra reach in
        // 16 frames, fewer than the 30 from the start share to the next list's completion.
        god.run.regions.near_descent_us = 15.0 * slice_us;
        god.run.motion.last_step = [0.0, 0.0, -0.016];
        god.run.motion.last_motion = 0.016;
        let sweep = Vector3::from(god.near_sweep());
        let frames = 15.0 / NEAR_AHEAD_START;
        assert!((sweep - Vector3::new(0.0, 0.0, -0.016 * frames)).norm() < 1e-12);
        // Ten times slower: its reach outlasts the descent; no sweep.
        god.run.motion.last_step = [0.0, 0.0, -0.0016];
        god.run.motion.last_motion = 0.0016;
        assert_eq!(god.near_sweep(), [0.0; 3]);
        // A cheap descent: no sweep either.
        god.run.motion.last_step = [0.0, 0.0, -0.016];
        god.run.motion.last_motion = 0.016;
        god.run.regions.near_descent_us = slice_us;
        assert_eq!(god.near_sweep(), [0.0; 3]);
    }

    /// The next list's slice fills a frame to its share of the budget while the list is on
    /// time, and is the full slice where its frame is light, where it is behind (past the last
    /// descent's cost, or not done in time at the fill's pace), or with the fill off; paced,
    /// it is left to the loop's wait while the list in use lasts.
    /// A near list taken over the sheet, the tool sliding a thousandth of its extra reach a
    /// frame (a thousand frames left), the last descent two full slices long: the pose, the
    /// extra reach (mm) and the full slice (µs).
    fn sliding_slowly(god: &mut GodObject) -> (Pose, f64, f64) {
        let q = Pose::from_array([0.0, 0.0, 2.4, 0.0, 0.0, 0.0]);
        god.detect_triangles(&q, 0.1);
        assert!(god.run.regions.near_at.is_some());
        let full = god.params.tuning.near_ahead_share * god.params.budget_us;
        let extra = god.run.regions.near_extra;
        god.run.motion.last_step = [1e-3 * extra, 0.0, 0.0];
        god.run.motion.last_motion = 1e-3 * extra;
        god.run.regions.near_descent_us = 2.0 * full;
        (q, extra, full)
    }

    #[test]
    fn a_slice_fills_the_frame_only_while_the_next_list_is_on_time() {
        let (mut god, _, _) = cube_over_sheet();
        // (The ceiling has a test of its own, below.)
        god.params.heuristics.mesh_slice_ceiling = false;
        let (q, extra, full) = sliding_slowly(&mut god);
        let fill = god.params.tuning.near_fill_share * god.params.budget_us;
        // A light frame: the full slice.
        assert_eq!(god.near_slice_us(&q, 10.0), full);
        // A frame that took most of the fill: what is left of it.
        assert!((god.near_slice_us(&q, fill - 20.0) - 20.0).abs() < 1e-9);
        // A frame past the fill, the list on time: its pace (two slices over 500 frames).
        let paced = god.near_slice_us(&q, 2.0 * fill);
        assert!(paced > 0.0 && paced < 0.01 * full, "{paced} µs");
        // Twice as fast, with 500 frames left (250 at the start share): still its pace.
        god.run.motion.last_motion = 2e-3 * extra;
        let faster = god.near_slice_us(&q, 2.0 * fill);
        assert!(
            (faster - 2.0 * paced).abs() < 1e-9 * full,
            "{faster} against {paced}"
        );
        // The descent would not be done in time at the fill's pace: the full slice.
        god.run.motion.last_motion = 0.5 * extra;
        assert_eq!(god.near_slice_us(&q, 2.0 * fill), full);
        // Behind: a list under way past the last descent's cost.
        god.run.motion.last_motion = 1e-3 * extra;
        god.run.regions.near_ahead =
            NearAhead::start(god.run.regions.near_at.unwrap(), NearPurpose::Ahead);
        god.run.regions.near_ahead.spent_us = 3.0 * full;
        assert_eq!(god.near_slice_us(&q, 2.0 * fill), full);
        // Paced (the loop's wait given to the engine): none while the list in use lasts two
        // frames more, light frame or heavy; the usual slice where it is nearly spent.
        god.run.regions.near_ahead = NearAhead::IDLE;
        god.run.lists.idle_given = true;
        assert_eq!(god.near_slice_us(&q, 10.0), 0.0);
        assert_eq!(god.near_slice_us(&q, 2.0 * fill), 0.0);
        god.run.motion.last_motion = 0.9 * extra;
        assert_eq!(god.near_slice_us(&q, 10.0), full);
        assert_eq!(god.near_slice_us(&q, 2.0 * fill), full);
        god.run.motion.last_motion = 1e-3 * extra;
        god.run.lists.idle_given = false;
        // Off: the full slice whatever the frame took, paced or not.
        god.params.heuristics.mesh_near_fill = false;
        assert_eq!(god.near_slice_us(&q, 2.0 * fill), full);
        god.run.lists.idle_given = true;
        assert_eq!(god.near_slice_us(&q, 2.0 * fill), full);
    }

    #[test]
    fn the_fill_level_follows_the_frames_own_work() {
        let (mut god, _, _) = cube_over_sheet();
        god.params.heuristics.mesh_slice_ceiling = false;
        let (q, _, full) = sliding_slowly(&mut god);
        let fill = god.params.tuning.near_fill_share * god.params.budget_us;
        // Before any frame: the fixed fill, so a light frame takes the full slice.
        assert_eq!(god.fill_level_us(), fill);
        assert_eq!(god.near_slice_us(&q, 10.0), full);
        // One frame in ten takes 40 µs of its own, the rest 10: more than a twentieth above
        // 10, so the level settles at 40 and a 10 µs frame is filled to it, not to the fill.
        for i in 0..3000 {
            god.note_own_work(if i % 10 == 0 { 40.0 } else { 10.0 });
        }
        let level = god.fill_level_us();
        assert!((35.0..46.0).contains(&level), "{level} µs");
        let slice = god.near_slice_us(&q, 10.0);
        assert!((slice - (level - 10.0)).abs() < 1e-9, "{slice} µs");
        // One in thirty-three: less than a twentieth above 10, so the level comes down to it
        // and the slice is the list's pace and little more.
        for i in 0..3000 {
            god.note_own_work(if i % 33 == 0 { 40.0 } else { 10.0 });
        }
        let level = god.fill_level_us();
        assert!((9.0..12.0).contains(&level), "{level} µs");
        assert!(god.near_slice_us(&q, 10.0) < 2.5);
        // Never above the fixed fill, however heavy the frames.
        for _ in 0..200 {
            god.note_own_work(5_000.0);
        }
        assert_eq!(god.fill_level_us(), fill);
        // Off, the fixed fill: a light frame takes the full slice.
        for _ in 0..3000 {
            god.note_own_work(10.0);
        }
        assert!(god.fill_level_us() < 11.0);
        god.params.heuristics.mesh_fill_own_level = false;
        assert_eq!(god.near_slice_us(&q, 10.0), full);
        // A budget no haptic frame has (the per-frame minima's): the fixed fill too, so that
        // the frames do not depend on the clock.
        god.params.heuristics.mesh_fill_own_level = true;
        god.params.budget_us = 2.0 * OWN_LEVEL_MAX_BUDGET_US;
        let fill = god.params.tuning.near_fill_share * god.params.budget_us;
        assert_eq!(god.fill_level_us(), fill);
    }

    /// A paced frame leaves the next list to the loop's wait while the list in use holds the
    /// regions by its reach past their margin, though the tool has gone past its extra reach:
    /// the regions have grown narrower than the one it was listed for (a contact settling).
    /// At the listed margin, or in a loop that is not paced, the frame builds it.
    #[test]
    fn a_paced_frame_leaves_the_next_list_to_the_wait_while_it_holds_narrower_regions() {
        let (mut god, _, _) = cube_over_sheet();
        god.params.heuristics.mesh_slice_ceiling = false;
        let (q, _, full) = sliding_slowly(&mut god);
        let span = god.run.regions.near_at.unwrap();
        let (_, listed) = god.run.regions.contacts_at.unwrap();
        let fill = god.params.tuning.near_fill_share * god.params.budget_us;
        // Slid 0.04 mm past the extra reach, along the sheet.
        let past = span.reach - listed + 0.04;
        let slid = Pose::from_array([past, 0.0, 2.4, 0.0, 0.0, 0.0]);
        assert!(god.near_use(&span, &slid).left == 0.0);
        god.run.lists.idle_given = true;
        // Regions of the listed margin: the list is spent, the frame builds the next.
        assert_eq!(god.near_slice_us(&slid, 2.0 * fill), full);
        // Regions 0.08 mm narrower: held 0.04 mm more, 160 frames at this pace.
        let narrow = listed - 0.08;
        god.run.regions.contacts_at = Some((slid, narrow));
        assert!(god.near_frames_held(&span, &slid) > 100.0);
        assert_eq!(god.near_slice_us(&slid, 2.0 * fill), 0.0);
        assert_eq!(god.near_slice_us(&slid, 10.0), 0.0);
        // A loop that is not paced has no wait to build it in: the frame does.
        god.run.lists.idle_given = false;
        assert_eq!(god.near_slice_us(&slid, 2.0 * fill), full);
        // The pose the list was listed at: held at either margin, the wait builds it.
        god.run.lists.idle_given = true;
        assert_eq!(god.near_slice_us(&q, 2.0 * fill), 0.0);
    }

    /// In a paced loop's wait, the list built ahead replaces the one in use once it holds the
    /// regions at least as long (nearer the tool than its centre), not before, nor while it is
    /// under way, nor with the switch off; the region after the take lists every pair within
    /// its margin.
    #[test]
    fn a_list_built_ahead_is_taken_in_the_wait_once_it_holds_as_long_as_the_one_in_use() {
        let (mut god, tool, sheet) = cube_over_sheet();
        let far = Instant::now() + Duration::from_secs(60);
        // The cube's face 0.05 mm over the sheet, sliding slowly along it.
        let q = Pose::from_array([0.0, 0.0, 2.05, 0.0, 0.0, 0.0]);
        god.detect_triangles(&q, 0.1);
        let now = god.run.regions.near_at.unwrap();
        let extra = god.run.regions.near_extra;
        god.run.motion.last_step = [1e-3 * extra, 0.0, 0.0];
        god.run.motion.last_motion = 1e-3 * extra;
        // The next list, centred 0.1 mm on along the sheet.
        let on = Pose::from_array([0.1, 0.0, 2.05, 0.0, 0.0, 0.0]);
        let ahead = NearSpan {
            at: on,
            sweep: [0.0; 3],
            reach: now.reach,
            near: None,
        };
        god.begin_near(ahead, NearPurpose::Ahead);
        // Under way: not taken.
        god.run.regions.near_ahead.done = false;
        assert!(!god.take_near_list_in_wait(&on, far));
        assert!(god.advance_near(None));
        // At the old list's centre the old one holds longer: not taken.
        assert!(!god.take_near_list_in_wait(&q, far));
        assert_eq!(god.run.regions.near_at.unwrap().at, now.at);
        // Switched off: not taken.
        god.params.heuristics.mesh_idle_take = false;
        assert!(!god.take_near_list_in_wait(&on, far));
        god.params.heuristics.mesh_idle_take = true;
        // No time left in the wait: not taken.
        assert!(!god.take_near_list_in_wait(&on, Instant::now()));
        // At the new one's centre: taken, inheriting there.
        assert!(god.take_near_list_in_wait(&on, far));
        assert_eq!(god.run.regions.near_at.unwrap().at, on);
        assert_eq!(god.run.regions.near_ahead.at, None);
        assert_eq!(god.run.regions.near_bounds_at, Some(on));
        // The next region there misses no pair within its margin.
        god.detect_triangles(&on, 0.1);
        assert_eq!(
            god.run.regions.near_at.unwrap().at,
            on,
            "the taken list serves"
        );
        assert!(every_pair_within_kept(&god, &tool, &sheet, &on, 0.1, 0) > 0);
    }

    #[test]
    fn a_slice_keeps_the_frame_under_its_ceiling_while_the_list_in_use_holds() {
        let (mut god, _, _) = cube_over_sheet();
        let (q, extra, full) = sliding_slowly(&mut god);
        let span = god.run.regions.near_at.unwrap();
        let ceiling = god.params.tuning.near_ceiling_share * god.params.budget_us;
        // The next list behind (under way past the last descent's cost): a full slice without
        // the ceiling.
        god.run.regions.near_ahead = NearAhead::start(span, NearPurpose::Ahead);
        god.run.regions.near_ahead.spent_us = 3.0 * full;
        assert!(god.near_frames_held(&span, &q) > 100.0);
        // A light frame: the full slice, under the ceiling.
        assert_eq!(god.near_slice_us(&q, 10.0), full);
        // A frame whose own work took most of the ceiling: what is left under it.
        assert!((god.near_slice_us(&q, ceiling - 30.0) - 30.0).abs() < 1e-9);
        // A frame past it: none.
        assert_eq!(god.near_slice_us(&q, ceiling + 10.0), 0.0);
        // The list in use spent within a frame or two (a frame's motion of its reach): the full
        // slice, whatever the frame took.
        god.run.motion.last_motion = span.reach;
        assert!(god.near_frames_held(&span, &q) < NEAR_CEILING_LEFT_FRAMES);
        assert_eq!(god.near_slice_us(&q, ceiling + 10.0), full);
        // Off: the full slice.
        god.run.motion.last_motion = 1e-3 * extra;
        god.params.heuristics.mesh_slice_ceiling = false;
        assert_eq!(god.near_slice_us(&q, ceiling + 10.0), full);
    }

    #[test]
    fn the_next_list_starts_early_only_where_its_descent_would_not_be_done_in_time() {
        let (mut god, _, _) = cube_over_sheet();
        let far = Instant::now() + Duration::from_secs(1);
        let q0 = Pose::from_array([0.0, 0.0, 2.4, 0.0, 0.0, 0.0]);
        let slice_us = god.params.tuning.near_ahead_share * god.params.budget_us;
        let start = |god: &mut GodObject, descent_slices: f64| {
            god.run.regions.near_at = None;
            god.run.regions.near_ahead = NearAhead::IDLE;
            god.detect_triangles(&q0, 0.1);
            let extra = god.run.regions.near_extra;
            // Turning in place, a tenth of the extra reach a frame: spent in ten frames, a
            // tenth of it used so far.
            god.run.motion.last_step = [0.0; 3];
            god.run.motion.last_turn = [0.0, 0.0, 1e-4];
            god.run.motion.last_motion = 0.1 * extra;
            god.run.regions.near_descent_us = descent_slices * slice_us;
            let turned = Pose::from_array([0.0, 0.0, 2.4, 0.0, 0.0, 0.0]);
            let turned = Pose::from_translation_rotation(
                &turned.translation(),
                &(rotation_exp(&Vector3::new(0.0, 0.0, 0.1 * extra / god.bodies.reach))
                    * turned.rotation_matrix()),
            );
            assert!(god.span_bound(&god.run.regions.near_at.unwrap(), &turned) < 0.5 * extra);
            god.tend_near(&turned, slice_us, far);
            god.run.regions.near_ahead.at.is_some()
        };
        // A descent of two slices fits in the frames left after the start share: it waits.
        assert!(!start(&mut god, 2.0));
        // One of eight slices would not (9 frames left, 16 needed): it starts now.
        assert!(start(&mut god, 8.0));
    }

    /// The 4 mm cube tool over a flat 8 x 8 mm sheet of 0.25 mm cells (2 048 triangles, kept
    /// as cells: flat faces not merged), its top at z = 0: every cell under the cube's bottom
    /// is as far from it as the cube stands off.
    /// A region whose frame has no time left lists nothing and proves nothing; the regions
    /// after it at the same pose, each given a short slice, go on with the list's descent and
    /// then its filter where they stopped (the pairs not reached keep bounds that hold there),
    /// and end with the pairs and distances of regions listed and filtered at once.
    #[test]
    fn a_region_stopped_at_the_deadline_is_finished_by_the_next_ones_there_as_if_at_once() {
        // The cube's face 0.003 mm over a sheet of fine cells, turned: hundreds of pairs
        // touch. Then slid and turned a little, within the list's reach.
        let poses = [
            Pose::from_array([0.0, 0.0, 2.003, 0.0, 0.0, 0.3]),
            Pose::from_array([0.02, -0.01, 2.004, 0.0, 0.0, 0.301]),
        ];
        let margin = 0.05;
        let mut at_once = cube_over_fine_grid();
        let mut god = cube_over_fine_grid();
        let mut filters_stopped = 0;
        for q in &poses {
            at_once.detect(q, 1.0).unwrap();
            at_once.narrow_phase(q, margin);
            assert!(!at_once.run.regions.interrupted);
            assert!(at_once.detector.contacts.len() > 100);
            god.detect(q, 1.0).unwrap();
            god.narrow_phase_by(q, margin, &Vector3::zeros(), Some(Instant::now()));
            assert!(god.run.regions.interrupted);
            assert!(god.detector.contacts.is_empty());
            assert!(god.run.regions.contacts_at.is_none());
            let mut regions = 1;
            while god.run.regions.interrupted {
                assert!(regions < 100_000, "still not done after {regions} regions");
                god.run.regions.interrupted = false;
                let slice = Instant::now() + Duration::from_micros(20);
                god.narrow_phase_by(q, margin, &Vector3::zeros(), Some(slice));
                regions += 1;
                if god.run.regions.interrupted && god.run.regions.near_at.is_some() {
                    filters_stopped += 1;
                }
            }
            assert_eq!(god.run.counts.near_listed, at_once.run.counts.near_listed);
            let names = |god: &GodObject| -> Vec<_> {
                god.detector
                    .near
                    .iter()
                    .map(|c| (c.object, c.tool, c.part))
                    .collect()
            };
            assert!(names(&god) == names(&at_once), "the lists differ");
            assert!(
                god.detector.contacts == at_once.detector.contacts,
                "the pairs kept differ from those kept at once"
            );
            assert!(
                god.detector.contact_nearest == at_once.detector.contact_nearest,
                "the distances differ from those measured at once"
            );
            assert_eq!(god.run.regions.contacts_at, at_once.run.regions.contacts_at);
        }
        assert_eq!(at_once.run.counts.near_listed, 1);
        assert!(
            filters_stopped > 1,
            "the filter was stopped in {filters_stopped} regions"
        );
    }

    /// A region of thousands of triangle pairs listed late in the frame leaves its rows,
    /// solve and check to the next frame where they would end past the budget (at the last
    /// such region's cost per pair), but not early in the frame, and not where they would not
    /// fit in a frame of their own either.
    #[test]
    fn a_large_region_listed_late_leaves_its_rows_to_the_next_frame() {
        let mut god = cube_over_fine_grid();
        let q = Pose::from_array([0.0, 0.0, 2.003, 0.0, 0.0, 0.3]);
        god.detect(&q, 1.0).unwrap();
        god.narrow_phase(&q, 0.05);
        let pairs = god.detector.contacts.len();
        assert!(
            pairs >= super::super::plan::ROWS_RESERVE_MIN_PAIRS,
            "{pairs} pairs"
        );
        let budget = god.params.budget_us;
        // Rows, solve and check at a third of the budget, with the headroom.
        god.run.regions.mesh_contact_us = budget / 3.0 / pairs as f64;
        let frame_at = |god: &GodObject, ago_us: f64| {
            let start = Instant::now() - Duration::from_secs_f64(ago_us * 1e-6);
            god.start_frame(q, q, start)
        };
        assert!(god.rows_past_budget(&frame_at(&god, 0.8 * budget)));
        assert!(!god.rows_past_budget(&frame_at(&god, 0.0)));
        // Rows that would take a whole frame are done here: the tool would never move.
        god.run.regions.mesh_contact_us = budget / pairs as f64;
        assert!(!god.rows_past_budget(&frame_at(&god, 0.8 * budget)));
        // Nor is a small region held back by the cost of the last large one.
        god.run.regions.mesh_contact_us = budget / 3.0 / pairs as f64;
        god.detector
            .contacts
            .truncate(super::super::plan::ROWS_RESERVE_MIN_PAIRS - 1);
        assert!(!god.rows_past_budget(&frame_at(&god, 0.9 * budget)));
    }

    /// A frame's pair count in the mesh mode is its first region's triangle pairs, not the
    /// grown leaves' (one pair here).
    #[test]
    fn a_mesh_frame_counts_its_triangle_pairs() {
        let mut god = cube_over_fine_grid();
        god.params.budget_us = crate::config::BUDGET_US.hi;
        let q = Pose::from_array([0.0, 0.0, 2.003, 0.0, 0.0, 0.3]);
        god.step(&q);
        let out = god.step(&Pose::from_array([0.0, 0.0, 2.0, 0.0, 0.0, 0.3]));
        assert_eq!(god.detector.pairs.len(), 1);
        assert!(out.pairs > 100, "{} pairs", out.pairs);
    }

    fn cube_over_fine_grid() -> GodObject {
        let (v, t) = grid_sheet(32, 4.0, |_, _| 0.0);
        let (tv, tt) = box_mesh([0.0; 3], [2.0; 3]);
        let mut params = EngineConfig {
            geometry: Geometry::Mesh,
            ..EngineConfig::default()
        };
        params.heuristics.mesh_flat_faces = false;
        params.tuning.ball_pair_target = 200.0;
        GodObject::with_meshes(
            &one_leaf([0.0; 3], 3.5),
            Some(MeshRef {
                vertices: &tv,
                triangles: &tt,
            }),
            &[(one_leaf([0.0; 3], 5.7), Pose::identity())],
            &[Some(MeshRef {
                vertices: &v,
                triangles: &t,
            })],
            params,
        )
        .unwrap()
    }

    #[test]
    fn a_wall_a_little_off_keeps_balls_short_of_it_and_touching_faces_keep_the_floor() {
        let skin = EngineConfig::default().skin_mm;
        let allow_at = |gap: f64| {
            let mut god = cube_over_fine_grid();
            let q = Pose::from_array([0.0, 0.0, 2.0 + gap, 0.0, 0.0, 0.0]);
            god.detect_triangles(&q, 0.12);
            assert!(god.detector.near.len() > 500, "{}", god.detector.near.len());
            god.standoff_allow(skin)
        };
        // 0.05 mm off: the dense floor (0.03 mm) and the skin would take in all 512 cells
        // under the cube; a ball that, moved by its allowance again, stays short of them
        // lists none.
        let room = allow_at(0.05);
        assert!(
            room < EngineConfig::default().tuning.dense_min_allow_mm,
            "{room}"
        );
        assert!(2.0 * room + skin <= 0.05, "{room}");
        assert!(2.0 * room + skin >= 0.05 - 2.0 * STANDOFF_BIN_MM, "{room}");
        // Resting on the sheet: a smaller ball holds as many touching pairs; the floor stands.
        assert_eq!(allow_at(0.0005), f64::INFINITY);
        // Far off: the room is past the floor, which already keeps the sheet out.
        assert_eq!(allow_at(0.11), f64::INFINITY);
        // A ball kept short of the wall measures nothing and keeps the room; pushed onto the
        // sheet, its region measures the cells under the cube and gives the floor back.
        let mut god = cube_over_fine_grid();
        let q = Pose::from_array([0.0, 0.0, 2.05, 0.0, 0.0, 0.0]);
        god.detect_triangles(&q, 0.12);
        let room = god.standoff_allow(skin);
        let slid = Pose::from_array([room, 0.0, 2.05, 0.0, 0.0, 0.0]);
        god.narrow_phase(&slid, room + skin);
        assert!(god.detector.contacts.is_empty());
        assert_eq!(god.standoff_allow(skin), room);
        let pressed = Pose::from_array([room, 0.0, 2.0 + room, 0.0, 0.0, 0.0]);
        god.narrow_phase(&pressed, room + skin);
        assert!(!god.detector.contacts.is_empty());
        assert_eq!(god.standoff_allow(skin), f64::INFINITY);
        // A spread of distances is no wall: the cube tilted over the sheet, its bottom from
        // 0.005 to about 0.07 mm off, where a smaller ball holds about as many pairs per
        // millimetre. (The target is every pair, so the count reaches it at the farthest,
        // whose room would be under the floor.)
        let mut god = cube_over_fine_grid();
        let q = Pose::from_array([0.0, 0.0, 2.037, 0.0, 0.016, 0.0]);
        god.detect_triangles(&q, 0.1);
        let near = god.detector.contacts.len();
        assert!(near >= 500, "{near}");
        god.params.tuning.ball_pair_target = near as f64;
        god.narrow_phase(&q, 0.1);
        assert_eq!(god.standoff_allow(skin), f64::INFINITY);
    }

    /// Steps `god` to the hands `hand(i)` for `i` in `0..frames`, `check`ing each frame's
    /// output: how many frames after the first 20 (the motion settled) took more than one
    /// pass, and how many frames those are.
    fn several_passes(
        god: &mut GodObject,
        frames: u32,
        hand: impl Fn(u32) -> Pose,
        check: impl Fn(u32, &FrameOutput),
    ) -> (usize, usize) {
        let (mut counted, mut more) = (0, 0);
        for i in 0..frames {
            let f = god.step(&hand(i));
            check(i, &f);
            if i >= 20 {
                counted += 1;
                more += usize::from(f.passes > 1);
            }
        }
        (more, counted)
    }

    #[test]
    fn a_tool_sliding_just_off_a_wall_takes_one_thin_path_a_frame_where_balls_take_several() {
        // The cube 0.05 mm over a fine sheet (512 cells under it within the dense floor and
        // the skin) slides along it at 0.04 mm a frame: balls held short of the sheet by its
        // standoff room are narrower than a frame's motion.
        let passes = |thin: bool| {
            let mut god = cube_over_fine_grid();
            god.params.heuristics.mesh_thin_paths = thin;
            let hand = |x: f64| Pose::from_array([x, 0.0, 2.05, 0.0, 0.0, 0.0]);
            god.reset(&hand(-2.0)).unwrap();
            several_passes(
                &mut god,
                100,
                |i| hand(-2.0 + 0.04 * f64::from(i)),
                |i, f| {
                    assert_eq!(f.contacts, 0, "frame {i}: the cube stays off the sheet");
                    assert!(f.q_g[2] >= 2.05 - 1e-9, "frame {i}: {}", f.q_g[2]);
                },
            )
        };
        let (thin, frames) = passes(true);
        let (balls, _) = passes(false);
        assert!(
            thin * 20 <= frames,
            "{thin} of {frames} frames took more than one pass"
        );
        assert!(
            balls * 2 >= frames,
            "{balls} of {frames}: balls took one pass a frame"
        );
    }

    #[test]
    fn a_ball_past_the_storage_lowers_the_dense_floor_until_balls_fit_again() {
        let (mut god, tool, sheet) = cube_over_sheet_storing(48);
        let floor = god.params.tuning.dense_min_allow_mm;
        let mut lowest = f64::INFINITY;
        for i in 0..200 {
            // Pressed onto the wavy sheet, where a ball of the floor's size holds more triangle
            // pairs than the storage, then lifted off.
            let (x, z) = if i < 150 {
                (0.0, 2.45 - 0.002 * f64::from(i))
            } else {
                (0.1 * f64::from(i - 150), 6.0)
            };
            let f = god.step(&Pose::from_array([x, 0.0, z, 0.0, 0.0, 0.0]));
            lowest = lowest.min(god.dense_floor());
            let q = Pose::from_array(f.q_g);
            assert!(
                brute_distance(&tool, &sheet, &q) > 0.0,
                "frame {i}: triangles meet"
            );
        }
        assert!(lowest < floor, "no ball overflowed: {lowest}");
        assert_eq!(
            god.dense_floor(),
            floor,
            "balls that fit give the floor back"
        );
    }

    /// A list being built ahead that holds the region but is not done is finished in the
    /// frame and taken, not listed anew; its pairs are the ones a list listed there gives.
    #[test]
    fn a_list_ahead_that_holds_the_region_is_finished_rather_than_listed_anew() {
        let (mut god, _, _) = cube_over_sheet();
        let far = Instant::now() + Duration::from_secs(1);
        let (q0, q1) = (
            Pose::from_array([0.0, 0.0, 2.3, 0.0, 0.0, 0.0]),
            Pose::from_array([0.3, 0.0, 2.3, 0.0, 0.0, 0.0]),
        );
        god.detect_triangles(&q0, 0.1);
        // Started about q1, but no slice of its descent done.
        god.tend_near(&q1, 0.0, far);
        let ahead = god.run.regions.near_ahead;
        assert!(ahead.at.is_some() && !ahead.done);
        let listed = god.run.counts.near_listed;
        // A list taken is judged as one listed: longer than the pair target, the next
        // reaches half as far beyond the margin.
        let extra = god.run.regions.near_extra;
        god.params.tuning.near_list_pairs = 4;
        god.narrow_phase(&q1, 0.15);
        assert_eq!(god.run.counts.near_taken, 1);
        assert_eq!(god.run.counts.near_listed, listed, "no list listed anew");
        assert_eq!(god.run.regions.near_extra, 0.5 * extra);
        let pairs = |god: &GodObject| {
            let mut p: Vec<(u32, u32)> = god
                .detector
                .contacts
                .iter()
                .map(|c| (c.tool, c.part))
                .collect();
            p.sort_unstable();
            p
        };
        let (mut fresh, _, _) = cube_over_sheet();
        fresh.detect_triangles(&q1, 0.15);
        assert!(!pairs(&fresh).is_empty());
        assert_eq!(pairs(&god), pairs(&fresh));
    }

    #[test]
    fn a_list_built_ahead_is_taken_only_for_a_region_it_covers() {
        let (mut god, _, _) = cube_over_sheet();
        let far = Instant::now() + Duration::from_secs(1);
        let (q0, q1) = (
            Pose::from_array([0.0, 0.0, 2.4, 0.0, 0.0, 0.0]),
            Pose::from_array([0.3, 0.0, 2.4, 0.0, 0.0, 0.0]),
        );
        let ahead_at = |god: &mut GodObject| {
            god.run.regions.near_at = None;
            god.run.regions.near_ahead = NearAhead::IDLE;
            god.detect_triangles(&q0, 0.1);
            let wide = god.run.regions.near_at.unwrap().reach;
            // Half the extra reach used: the next list, built whole here, is about q1.
            god.tend_near(&q1, 1e6, far);
            assert!(god.run.regions.near_ahead.done);
            wide
        };
        let wide = ahead_at(&mut god);
        // A region wider than the list built ahead: listed in the frame.
        god.narrow_phase(&q1, wide + 0.05);
        assert_eq!(god.run.counts.near_taken, 0);
        // One it covers: taken.
        ahead_at(&mut god);
        god.narrow_phase(&q1, 0.1);
        assert_eq!(god.run.counts.near_taken, 1);
        assert_eq!(god.run.regions.near_at.unwrap().at, q1);
        // A path region from where it is centred, to a pose past its reach (a tool falling
        // through a thin plate): listed in the frame, the path's end too.
        ahead_at(&mut god);
        let listed = god.run.counts.near_listed;
        god.narrow_phase_along(&q1, 0.1, &Vector3::new(0.0, 0.0, -wide));
        assert_eq!(god.run.counts.near_taken, 1);
        assert_eq!(god.run.counts.near_listed, listed + 1);
    }

    /// Asserts that every pair of the tool's triangles `tool` (tool frame) at `q` and the
    /// object's `object` (world) within `margin` (mm) of each other, measured exactly, is among
    /// the region's pairs (`step` names the step in the message); returns how many there are.
    fn every_pair_within_kept(
        god: &GodObject,
        tool: &[Triangle],
        object: &[Triangle],
        q: &Pose,
        margin: f64,
        step: usize,
    ) -> usize {
        let meshes = god.bodies.meshes.as_ref().unwrap();
        let kept: std::collections::HashSet<(u32, u32)> = god
            .detector
            .contacts
            .iter()
            .map(|c| (meshes.tool.origin(c.tool), meshes.objects[0].origin(c.part)))
            .collect();
        let (r, t) = (q.rotation_matrix(), q.translation());
        let mut within = 0;
        for (i, a) in tool.iter().enumerate() {
            let a = a.map(|p| (r * Vector3::from(p) + t).into());
            for (j, b) in object.iter().enumerate() {
                let d = triangle_distance(&a, b).distance;
                if d <= margin {
                    within += 1;
                    assert!(
                        kept.contains(&(i as u32, j as u32)),
                        "step {step}: triangles {i} and {j} are {d} mm apart (margin {margin}) but not kept"
                    );
                }
            }
        }
        within
    }

    #[test]
    fn the_near_list_gives_every_pair_within_the_margin_as_the_tool_wanders() {
        let (mut god, tool, sheet) = cube_over_sheet();
        // A walk over the sheet, sliding, bobbing and turning, in steps from 1 µm to 0.4 mm,
        // so that the near list is reused, listed again, swept along the last step, and taken
        // from the list built ahead.
        let (mut reused, mut relisted, mut near_pairs, mut swept) = (0, 0, 0, 0);
        // Lists whose near part leaves the cube's top out (it bobs 2–4 mm above the sheet).
        let mut with_part = 0;
        // Lists come out long for this sheet's few hundred pairs: their extra reach shrinks,
        // and they are swept along the motion instead.
        god.params.tuning.near_list_pairs = 60;
        // The cube's bottom reaches as far from its centre as its top, so its near part could
        // never pay and would be given up; this test is of the lists it bounds.
        god.params.heuristics.mesh_near_part_give_up = false;
        let mut q = [0.0, 0.0, 2.6, 0.0, 0.0, 0.0];
        for k in 0..600 {
            // Mostly a steady slide, now and then a jump past any list's reach.
            let step = if k % 37 == 36 {
                0.4
            } else {
                [1e-3, 0.02, 0.05][k % 3]
            };
            let phase = k as f64 * 0.05;
            let was = q;
            q[0] += step * phase.sin();
            q[1] += step * (0.7 * phase).cos();
            q[2] = 2.45 + 0.2 * (1.3 * phase).sin();
            q[3] = 0.1 * phase.sin();
            q[5] += 0.3 * step;
            let pose = Pose::from_array(q);
            let margin = [0.05, 0.2, 0.6][(k / 20) % 3];
            let before = god.run.regions.near_at;
            god.detect_triangles(&pose, margin);
            // The next list built ahead in slices of a few µs (one step's speed known), and
            // lists swept along the last step.
            god.run.motion.last_motion = step;
            god.run.motion.last_step = std::array::from_fn(|i| q[i] - was[i]);
            let far = Instant::now() + Duration::from_secs(1);
            god.tend_near(&pose, 5.0, far);
            if before.is_some() && god.run.regions.near_at == before {
                reused += 1;
            } else {
                relisted += 1;
                swept += usize::from(god.run.regions.near_at.is_some_and(|s| s.sweep != [0.0; 3]));
                with_part += usize::from(
                    god.run
                        .regions
                        .near_at
                        .and_then(|s| s.near)
                        .is_some_and(|p| p.hi.z < 1.0),
                );
            }
            near_pairs += every_pair_within_kept(&god, &tool, &sheet, &pose, margin, k);
        }
        let counts = &god.run.counts;
        assert!(
            reused > 100
                && relisted > 20
                && swept > 10
                && with_part > 10
                && near_pairs > 1000
                && counts.near_taken > 2,
            "reused {reused}, listed {relisted} ({swept} swept, {with_part} with a near part), \
             near pairs {near_pairs}, {} lists taken from ahead and {} listed in the frame",
            counts.near_taken,
            counts.near_listed
        );
        eprintln!(
            "reused {reused}, listed {relisted} ({swept} swept), taken {}, listed in frame {}",
            counts.near_taken, counts.near_listed
        );
    }

    /// A bar 40 mm long (its near end's centre at the tool origin, along the tool's `x`) over a
    /// gently waved sheet with a 1.5 mm step under its far quarter, lowered by turning about
    /// the bottom edge of its near end, held 0.1 mm off the sheet, until it is just over the
    /// step: the near end is the near part of each list, the far quarter comes down on an arm
    /// four times the near part's. A list serves while its near part moves less than its reach
    /// beyond the margin, and the rest of the bar less than that and the near part's margin
    /// more: the far quarter is listed before it comes near (with the near part's bound alone,
    /// its pairs with the step are missed).
    #[test]
    fn a_bar_lowered_about_its_near_end_finds_its_far_end_as_it_comes_down() {
        let (tv, tt) = box_mesh([20.0, 0.0, 0.0], [20.0, 1.0, 1.0]);
        let (pv, pt) = grid_sheet(50, 45.0, |x, y| {
            let step = if (30.0..=38.0).contains(&x) { 1.5 } else { 0.0 };
            step + 0.02 * (0.7 * x).sin() * (0.5 * y).cos()
        });
        let params = EngineConfig {
            geometry: Geometry::Mesh,
            ..EngineConfig::default()
        };
        let mut god = GodObject::with_meshes(
            &one_leaf([20.0, 0.0, 0.0], 20.2),
            Some(MeshRef {
                vertices: &tv,
                triangles: &tt,
            }),
            &[(one_leaf([0.0; 3], 64.0), Pose::identity())],
            &[Some(MeshRef {
                vertices: &pv,
                triangles: &pt,
            })],
            params,
        )
        .unwrap();
        let tris = |v: &[[f64; 3]], t: &[[u32; 3]]| -> Vec<Triangle> {
            t.iter().map(|t| t.map(|i| v[i as usize])).collect()
        };
        let (tool, sheet) = (tris(&tv, &tt), tris(&pv, &pt));
        // A narrow near part: the rest of the bar spends a list soon after it.
        god.params.tuning.near_part_mm = 0.3;
        let pose_at = |a: f64| {
            // Turned by -a about y: the far end up by 40 sin a; the near end's bottom edge,
            // (0, y, -1) in the tool, at height 0.1.
            let (s, c) = a.sin_cos();
            Pose::from_array([-s, 0.0, 0.1 + c, 0.0, -a, 0.0])
        };
        let frames = 400;
        let (mut with_part, mut far_pairs) = (0, 0);
        let mut was = pose_at(0.4);
        for k in 0..=frames {
            let pose = pose_at(0.4 - 0.35 * f64::from(k) / f64::from(frames));
            let margin = [0.05, 0.2][(k / 25) as usize % 2];
            god.detect_triangles(&pose, margin);
            god.run.motion.last_motion = god.motion_bound(&was, &pose);
            god.run.motion.last_step = (pose.translation() - was.translation()).into();
            god.tend_near(&pose, 20.0, Instant::now() + Duration::from_secs(1));
            with_part += usize::from(
                god.run
                    .regions
                    .near_at
                    .and_then(|s| s.near)
                    .is_some_and(|p| p.hi.x < 20.0),
            );
            every_pair_within_kept(&god, &tool, &sheet, &pose, margin, k as usize);
            // Pairs with the step.
            let meshes = god.bodies.meshes.as_ref().unwrap();
            far_pairs += god
                .detector
                .contacts
                .iter()
                .filter(|c| {
                    meshes.objects[0]
                        .triangle(c.part)
                        .iter()
                        .all(|p| p[2] > 1.0)
                })
                .count();
            was = pose;
        }
        // The rule itself: from a list's pose, a turn about the near end that moves the near
        // part by less than the reach but the far end past the reach and the near part's margin
        // spends the list.
        let q0 = pose_at(0.3);
        god.run.regions.near_part_rest = 0;
        god.detect_triangles(&q0, 0.05);
        let span = god.run.regions.near_at.expect("a list");
        let part = span.near.expect("its near part");
        assert!(part.hi.x < 15.0, "{part:?}");
        let (near, whole) = god.span_bounds(&span, &pose_at(0.3 - 0.025));
        assert!(
            near + 0.05 < span.reach && whole - 0.3 + 0.05 > span.reach,
            "{near} {whole}"
        );
        assert!(god.span_bound(&span, &pose_at(0.3 - 0.025)) + 0.05 > span.reach);
        // A turn a fifth as large: the near part's bound, far under the whole bar's.
        let small = pose_at(0.3 - 0.005);
        let (near, whole) = god.span_bounds(&span, &small);
        assert!(near < 0.5 * whole && god.span_bound(&span, &small) == near);
        assert!(
            with_part > 50 && far_pairs > 5,
            "{with_part} frames on a list with a near part, {far_pairs} far pairs kept"
        );
    }

    /// The cube over a 20 mm sheet of 40 × 40 cells gently waved (±0.02 mm), so that no two
    /// cells lie in one plane (flat faces would be cut again into other triangles at set-up),
    /// with room for 20 000 pairs.
    fn cube_over_waved_sheet() -> (GodObject, Vec<Triangle>, Vec<Triangle>) {
        let sheet = grid_sheet(40, 20.0, |x, y| 0.02 * (0.4 * x).sin() * (0.3 * y).cos());
        cube_over_storing(&sheet, one_leaf([0.0; 3], 28.3), 20_000)
    }

    /// A cube gliding over a sheet of fine cells, rocking and turning as it goes: each filter
    /// still gives every triangle pair within its margin (against every pair measured), while
    /// the pairs' directional gaps (the cells' normals, the world's z) spare the posing of the
    /// pairs a slide along the sheet leaves apart; with the gaps off, the filters pose them
    /// again.
    #[test]
    fn a_tool_gliding_over_a_sheet_keeps_its_pairs_apart_by_their_gaps_and_misses_none() {
        let glide = |directions: bool| {
            let (mut god, tool, plate) = cube_over_waved_sheet();
            god.params.heuristics.mesh_pair_directions = directions;
            let mut near_pairs = 0;
            for k in 0..400 {
                let phase = k as f64 * 0.07;
                // 2 mm half-height: the cube's base 0.13 mm over the sheet's mean plane (its
                // cells ±0.02 mm off it), rocked by up to 0.01 rad (its corners up or down by up
                // to 0.03 mm) and turned as it goes.
                let q = Pose::from_array([
                    -12.0 + 0.015 * k as f64,
                    0.5 * phase.sin(),
                    2.13,
                    0.01 * (0.9 * phase).sin(),
                    0.01 * (0.6 * phase).cos(),
                    0.01 * phase,
                ]);
                let margin = 0.1;
                god.detect_triangles(&q, margin);
                near_pairs += every_pair_within_kept(&god, &tool, &plate, &q, margin, k);
            }
            assert!(near_pairs > 500, "{near_pairs} pairs within the margin");
            god.run.counts.near_posed
        };
        let without = glide(false);
        let with = glide(true);
        assert!(
            (with as f64) < 0.7 * without as f64,
            "{with} pairs posed with the directional gaps, {without} without"
        );
    }

    /// Step `k` of the cube sliding over the waved sheet: `along` mm a step along x, swaying
    /// `sway` mm in y, rocked by up to `rock` rad about x and y, turning `twist` rad a step;
    /// its base 0.03 mm over the sheet's mean plane (its cells ±0.02 mm off it).
    fn slide_over_sheet(k: usize, [along, sway, rock, twist]: [f64; 4]) -> [f64; 6] {
        let phase = k as f64 * 0.05;
        [
            -10.0 + along * k as f64,
            sway * phase.sin(),
            2.03,
            rock * (0.9 * phase).sin(),
            rock * (0.6 * phase).cos(),
            twist * k as f64,
        ]
    }

    /// Gives `god` the step from `was` to `q` as its last, and `motion` (mm) as its last
    /// motion bound: what the lists ahead are swept and started by.
    fn note_step(god: &mut GodObject, q: &[f64; 6], was: Option<[f64; 6]>, motion: f64) {
        if let Some(was) = was {
            god.run.motion.last_step = std::array::from_fn(|i| q[i] - was[i]);
            god.run.motion.last_motion = motion;
        }
    }

    /// A cube sliding and turning on a fine sheet, its base just off it: each new near list
    /// takes the old one's bounds and nearest edges for the pairs they share, and its filters
    /// still give every pair within the margin, while posing fewer pairs than lists that start
    /// from their listed bounds.
    #[test]
    fn a_new_near_list_inherits_what_the_old_one_knew_and_misses_no_pair() {
        let slide = |inherit: bool| {
            let (mut god, tool, plate) = cube_over_waved_sheet();
            god.params.heuristics.mesh_list_inherit = inherit;
            let (mut near_pairs, mut was, mut first_posed) = (0, None, 0);
            for k in 0..300 {
                let q = slide_over_sheet(k, [0.02, 0.4, 0.003, 0.004]);
                let pose = Pose::from_array(q);
                let margin = 0.05;
                god.detect(&pose, margin).unwrap();
                let (list, posed) = (god.detector.near_generation, god.run.counts.near_posed);
                god.narrow_phase(&pose, margin);
                if god.detector.near_generation != list {
                    first_posed += god.run.counts.near_posed - posed;
                }
                note_step(&mut god, &q, was, 0.03);
                was = Some(q);
                let far = Instant::now() + Duration::from_secs(1);
                god.tend_near(&pose, 1e6, far);
                near_pairs += every_pair_within_kept(&god, &tool, &plate, &pose, margin, k);
            }
            assert!(near_pairs > 5_000, "{near_pairs} pairs within the margin");
            let counts = &god.run.counts;
            assert!(counts.near_taken > 5, "{} lists taken", counts.near_taken);
            first_posed
        };
        let without = slide(false);
        let with = slide(true);
        assert!(
            (with as f64) < 0.8 * without as f64,
            "a new list's first filter posed {with} pairs with the inheritance, {without} without"
        );
    }

    /// A pair both lists hold takes the larger of its new bound and the old one's less the
    /// old offset, never more than the cap (how far off the objects the old list put the tool
    /// outside its near part), and the old upper bound plus that offset; a pair only the new
    /// list holds keeps its own bound less the way.
    #[test]
    fn an_inherited_bound_is_the_old_ones_less_its_offset_up_to_the_cap() {
        let (mut god, _, _) = cube_over_sheet();
        let q = Pose::from_array([0.0, 0.0, 2.4, 0.0, 0.0, 0.0]);
        god.detect_triangles(&q, 0.1);
        let n = god.detector.near.len();
        assert!(n >= 4, "{n} pairs listed");
        let (way, old_less) = (0.002, 0.5);
        for (cap, expected) in [(0.3, 0.3), (f64::INFINITY, 4.5)] {
            // The new list: every pair 0.01 mm apart as listed. The old list: the same pairs
            // but the last, each 5 mm apart, its upper bound 7 mm.
            let d = &mut god.detector;
            d.near_apart.clear();
            d.near_apart.resize(n, 0.01);
            d.next_near = d.near[..n - 1].to_vec();
            d.next_ranks = d.near_ranks[..n - 1].to_vec();
            d.next_apart = vec![5.0; n - 1];
            d.next_gaps = vec![PairGap::NONE; n - 1];
            for g in &mut d.next_gaps {
                g.upper = 7.0;
            }
            d.near_edges = vec![NearestEdges::NONE; n - 1];
            d.next_edges = vec![NearestEdges::NONE; n];
            d.inherit_near(way, (old_less, cap), None);
            for i in 0..n - 1 {
                let bound = d.near_apart[i];
                assert!((bound - expected).abs() < 1e-12, "cap {cap}: {bound} mm");
                assert!((d.near_gaps[i].upper - 7.5).abs() < 1e-12);
            }
            let own = d.near_apart[n - 1];
            assert!((own - 0.008).abs() < 1e-12, "{own} mm");
        }
    }

    /// A cube sliding and turning just off a waved sheet, its lists built ahead and taken: the
    /// pairs measured near, no farther by the way since, are measured again at once (by their
    /// upper bounds, the ones a new list takes over too), and every filter still gives every
    /// pair within the margin, with its exact distance.
    #[test]
    fn a_pair_measured_near_is_measured_at_once_and_the_filter_misses_nothing() {
        let (mut god, tool, plate) = cube_over_waved_sheet();
        let (mut near_pairs, mut was) = (0, None);
        for k in 0..300 {
            let q = slide_over_sheet(k, [0.01, 0.2, 0.002, 0.002]);
            let pose = Pose::from_array(q);
            let margin = 0.05;
            let direct = god.run.counts.near_direct;
            god.detect_triangles(&pose, margin);
            // Measured at once only where near: each such pair is a contact.
            let direct = god.run.counts.near_direct - direct;
            let contacts = god.detector.contacts.len() as u64;
            assert!(
                direct <= contacts,
                "step {k}: {direct} pairs measured at once, {contacts} near"
            );
            note_step(&mut god, &q, was, 0.015);
            was = Some(q);
            near_pairs += every_pair_within_kept(&god, &tool, &plate, &pose, margin, k);
            let meshes = god.bodies.meshes.as_ref().unwrap();
            let (r, t) = (pose.rotation_matrix(), pose.translation());
            for (c, d) in god
                .detector
                .contacts
                .iter()
                .zip(&god.detector.contact_nearest)
            {
                let a = meshes
                    .tool
                    .triangle(c.tool)
                    .map(|p| (r * Vector3::from(p) + t).into());
                let fresh = triangle_distance(&a, meshes.objects[0].triangle(c.part));
                assert!(
                    (fresh.distance - d.distance).abs() < 1e-12,
                    "step {k}: {} mm kept, {} mm fresh",
                    d.distance,
                    fresh.distance
                );
            }
            let far = Instant::now() + Duration::from_secs(1);
            god.tend_near(&pose, 1e6, far);
        }
        assert!(near_pairs > 5_000, "{near_pairs} pairs within the margin");
        let counts = &god.run.counts;
        assert!(counts.near_taken > 3, "{} lists taken", counts.near_taken);
        assert!(
            counts.near_direct as f64 > 0.3 * counts.near_posed as f64,
            "{} of {} pairs posed measured at once",
            counts.near_direct,
            counts.near_posed
        );
    }

    /// The check of an answer keeps the exact distances it measured, and rows linearised at
    /// that answer (the next pass's or frame's) reuse them: the same rows as measured afresh.
    #[test]
    fn rows_at_a_checked_answer_reuse_its_distances_and_equal_fresh_ones() {
        let (mut god, _, _) = cube_on_plate();
        // The cube's bottom face 0.003 mm over the plate's top: every facing pair touches.
        // Turned about the vertical (a rotation a pose rebuilt from the variable does not
        // reproduce bit for bit).
        let q0 = Pose::from_array([5.0, 5.0, 1.003, 0.0, 0.0, 0.7]);
        let hand = Pose::from_array([4.0, 5.5, 0.0, 0.0, 0.0, 0.2]);
        god.detect_triangles(&q0, 1.0);
        let lin0 = god.linearization(&q0, &hand).unwrap();
        let n = god.fill_rows(&lin0, None);
        let mut dq = lin0.delta();
        dq[0] += 0.001;
        dq[5] += 0.0002;
        let q1 = lin0.configuration(&dq);
        let _ = god.mesh_gaps_at(&q0, &q1, &dq, n);
        let known = god.detector.nearest_known.iter().filter(|k| **k).count();
        assert!(known > 0, "the check measured no pair");
        let lin1 = god.linearization(&q1, &hand).unwrap();
        assert_eq!(
            god.detector.nearest_at,
            Some(lin1.pose_parts()),
            "the next rows are linearised where the check measured"
        );
        let n1 = god.fill_rows(&lin1, None);
        // The rows took the check's distances (a pose rebuilt from the variable, a rounding
        // away, would have measured them all again).
        assert_eq!(god.detector.nearest_at, Some(lin1.pose_parts()));
        assert_eq!(
            god.detector.nearest_known.iter().filter(|k| **k).count(),
            n1,
            "every row's distance is known"
        );
        let reused = (god.qp.rows[..n1].to_vec(), god.qp.rhs[..n1].to_vec());
        god.detector.nearest_at = None;
        let n2 = god.fill_rows(&lin1, None);
        assert_eq!(n1, n2);
        assert_eq!(reused.0, god.qp.rows[..n2].to_vec());
        assert_eq!(reused.1, god.qp.rhs[..n2].to_vec());
    }

    #[test]
    fn a_region_at_a_checked_answer_filters_with_the_checks_distances_equal_to_fresh_ones() {
        // A ball region, and a path region sliding along the sheet: the touching pairs are
        // within the margin, and their distances are taken.
        for path in [Vector3::zeros(), Vector3::new(0.02, -0.01, 0.0)] {
            let (_, kept, posed_reusing, posed_fresh) =
                filters_at_a_checked_answer_as_afresh(&path, 0.05, false);
            assert!(kept > 100, "{kept} pairs within the margin along {path:?}");
            assert!(
                posed_reusing + 100 <= posed_fresh,
                "{posed_reusing} pairs posed reusing the check's distances, {posed_fresh} afresh, along {path:?}"
            );
        }
    }

    /// The same where the region takes a new near list (the old one no longer covering it, as
    /// when a tool moving on is handed the list built ahead): the check named the old list's
    /// pairs, and the new list's same pairs take their distances.
    #[test]
    fn a_region_at_a_checked_answer_on_a_new_list_takes_the_checks_distances() {
        let (god, kept, posed_reusing, posed_fresh) =
            filters_at_a_checked_answer_as_afresh(&Vector3::zeros(), 0.05, true);
        assert!(kept > 100, "{kept} pairs within the margin");
        assert_eq!(god.detector.reuse_list, Some(god.detector.near_generation));
        assert!(
            posed_reusing + 100 <= posed_fresh,
            "{posed_reusing} pairs posed reusing the check's distances, {posed_fresh} afresh"
        );
    }

    /// The region of margin `margin` along `path` (mm) centred at a checked answer, filtered
    /// taking the check's distances and afresh, on two identical engines (a filter leaves
    /// bounds the next one uses), on a `new_list` or the one the check's pairs came from: the
    /// same pairs kept, with the same distances. Returns the engine that took them, the pairs
    /// kept and the pairs posed by each filter.
    fn filters_at_a_checked_answer_as_afresh(
        path: &Vector3<f64>,
        margin: f64,
        new_list: bool,
    ) -> (GodObject, usize, u64, u64) {
        let filtered = |reuse: bool| {
            let mut god = cube_over_fine_grid();
            // The cube's face 0.003 mm over a sheet of fine cells, turned about the vertical:
            // a few hundred facing pairs touch.
            let q0 = Pose::from_array([0.0, 0.0, 2.003, 0.0, 0.0, 0.3]);
            let hand = Pose::from_array([-0.5, 0.2, 0.0, 0.0, 0.0, 0.25]);
            god.detect(&q0, 1.0).unwrap();
            god.narrow_phase(&q0, 0.05);
            let lin0 = god.linearization(&q0, &hand).unwrap();
            let n = god.fill_rows(&lin0, None);
            let mut dq = lin0.delta();
            dq[0] += 0.001;
            dq[5] -= 0.0002;
            let q1 = lin0.configuration(&dq);
            let _ = god.mesh_gaps_at(&q0, &q1, &dq, n);
            let checked = god.detector.nearest_known.iter().filter(|k| **k).count();
            assert!(checked > 100, "the check measured {checked} pairs");
            if !reuse {
                god.detector.nearest_at = None;
            }
            let generation = god.detector.near_generation;
            if new_list {
                // The list in use no longer serves: the region lists a new one.
                god.run.regions.near_at = None;
            }
            // The next region is centred at the answer: the check's distances are its own.
            let posed = god.run.counts.near_posed;
            god.narrow_phase_along(&q1, margin, path);
            let posed = god.run.counts.near_posed - posed;
            assert_eq!(god.detector.near_generation > generation, new_list);
            (god, posed)
        };
        let (reusing, posed_reusing) = filtered(true);
        let (fresh, posed_fresh) = filtered(false);
        let (kept, taken) = (
            &reusing.detector.contacts,
            &reusing.detector.contact_nearest,
        );
        assert!(
            *kept == fresh.detector.contacts,
            "the pairs kept differ from those kept afresh along {path:?}"
        );
        assert!(
            *taken == fresh.detector.contact_nearest,
            "the distances taken differ from those measured afresh along {path:?}"
        );
        let kept = kept.len();
        (reusing, kept, posed_reusing, posed_fresh)
    }

    #[test]
    fn a_region_away_from_a_checked_answer_measures_its_own_distances() {
        let (mut god, ..) = filters_at_a_checked_answer_as_afresh(&Vector3::zeros(), 0.05, false);
        let margin = 0.05;
        // A region anywhere else measures its own.
        let q2 = Pose::from_array([0.0, 0.0, 2.003, 0.0, 0.0, 0.31]);
        god.narrow_phase(&q2, margin);
        let (rot, t) = (q2.rotation_matrix(), q2.translation());
        for (c, d) in god
            .detector
            .contacts
            .iter()
            .zip(&god.detector.contact_nearest)
        {
            let meshes = god.bodies.meshes.as_ref().unwrap();
            let (tool, part) = god.posed_pair(meshes, c, &rot, &t);
            // (The pair's nearest edges from the last region are tried first: the same
            // distance to a rounding, the nearest points perhaps others where not unique.)
            let fresh = triangle_distance(&tool, &part);
            assert!((d.distance - fresh.distance).abs() <= 1e-12 && d.meet == fresh.meet);
        }
    }

    /// Two flat sheets at z = 0 (normals up), `x <= -gap/2` and `x >= gap/2`, 20 mm across.
    fn two_sheets(gap: f64) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
        let h = 0.5 * gap;
        let v = vec![
            [-10.0, -10.0, 0.0],
            [-h, -10.0, 0.0],
            [-h, 10.0, 0.0],
            [-10.0, 10.0, 0.0],
            [h, -10.0, 0.0],
            [10.0, -10.0, 0.0],
            [10.0, 10.0, 0.0],
            [h, 10.0, 0.0],
        ];
        let t = vec![[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]];
        (v, t)
    }

    /// Two blocks 2 mm deep, their tops at z = 0, `x <= -gap/2` and `x >= gap/2`.
    fn two_blocks(gap: f64) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
        let half = [5.0 - 0.25 * gap, 10.0, 1.0];
        let (mut v, mut t) = box_mesh([-5.0 - 0.25 * gap, 0.0, -1.0], half);
        let (v2, t2) = box_mesh([5.0 + 0.25 * gap, 0.0, -1.0], half);
        let base = v.len() as u32;
        v.extend(v2);
        t.extend(t2.iter().map(|tri| tri.map(|i| i + base)));
        (v, t)
    }

    #[test]
    fn a_face_at_the_row_target_beside_an_object_edge_comes_over_it_in_one_solve() {
        // The cube's bottom face at the row target over the left sheet (or block), held level,
        // its right edge a little short of the right one's edge, the hand 0.01 mm to the right
        // and 0.05 mm down. The cube's way to the hand, solve after solve (each linearised at
        // the last answer), as far as 0.01 mm in x.
        let slide = |tilted_targets: bool, blocks: bool, off: f64| {
            let object = if blocks {
                two_blocks(1.0)
            } else {
                two_sheets(1.0)
            };
            let (mut god, tool, object_triangles) =
                cube_over(&object, one_leaf([0.0, 0.0, -1.0], 14.2));
            god.params.heuristics.mesh_tilted_targets = tilted_targets;
            // Held level, as a face resting on many points is.
            god.params.kr = 1e9;
            let g = god.mesh_gap();
            let x0 = 0.5 - off * g - 2.0;
            let mut q = Pose::from_array([x0, 0.0, 2.0 + g, 0.0, 0.0, 0.0]);
            let hand = Pose::from_array([x0 + 0.01, 0.0, 1.95, 0.0, 0.0, 0.0]);
            let mut way = Vec::new();
            for _ in 0..3 {
                god.detect_triangles(&q, 2.0);
                let lin = god.linearization(&q, &hand).unwrap();
                let n = god.fill_rows(&lin, None);
                let (dq, _, status, _) = god.solve(n, n, &lin.delta()).unwrap();
                assert_eq!(status, Status::Solved);
                q = lin.configuration(&dq);
                // Every answer keeps the triangles apart by the least share of the target.
                let apart = brute_distance(&tool, &object_triangles, &q);
                assert!(
                    apart >= TILTED_TARGET_LEAST * g * (1.0 - 1e-6),
                    "{apart} mm apart after {} solves",
                    way.len() + 1
                );
                way.push(q.translation().x - x0);
            }
            (way, off * g)
        };
        // Over sheets (the cube's edge beside a face's edge) and over blocks (its side beside
        // a wall's top too), the edge off by half the target and by the target.
        for blocks in [false, true] {
            for off in [0.5, 1.0] {
                // With the target's share along the tilted direction, the first solve brings
                // the edge over the other edge, the next to the hand.
                let (way, edge) = slide(true, blocks, off);
                assert!(
                    way[0] >= edge * (1.0 - 1e-6) && way[2] >= 0.01 - 1e-6,
                    "with tilted targets {way:?} mm (the edge {edge} mm off, blocks {blocks})"
                );
                // Kept at the whole target along it, the edge comes a share of the way.
                let (way, edge) = slide(false, blocks, off);
                assert!(
                    way[0] < 0.8 * edge,
                    "without tilted targets {way:?} mm (the edge {edge} mm off, blocks {blocks})"
                );
            }
        }
    }

    #[test]
    fn the_mesh_rows_are_the_distance_and_its_gradient() {
        let (mut god, _, _) = cube_on_plate();
        assert_eq!(god.geometry(), Geometry::Mesh);
        // Tilted and turned so that one corner is lowest: the nearest features are unique.
        let q = Pose::from_array([0.3, -0.2, 3.1, 0.31, -0.17, 0.4]);
        let hand = Pose::from_array([0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        god.detect_triangles(&q, 2.0);
        assert!(!god.detector.contacts.is_empty());
        let lin = god.linearization(&q, &hand).unwrap();
        let n = god.fill_rows(&lin, None);
        let target = god.mesh_gap();
        let meshes = god.bodies.meshes.as_ref().unwrap();
        let distance = |c: &TriPair, v: &[f64; 6]| {
            let p = lin.configuration(v);
            let (tool, part) = god.posed_pair(meshes, c, &p.rotation_matrix(), &p.translation());
            triangle_distance(&tool, &part)
        };
        let base = lin.delta();
        let mut checked = 0;
        for (i, c) in god.detector.contacts.iter().enumerate().take(n) {
            let d0 = distance(c, &base);
            // The row's value at the linearisation pose is the distance less its target: the
            // row target, or a share of it down to the least where the nearest direction is
            // tilted off both faces.
            let row = god.qp.rows[i];
            let row_target = god.detector.row_targets[i];
            assert!(
                (TILTED_TARGET_LEAST * target..=target).contains(&row_target),
                "row {i}: target {row_target}"
            );
            let value: f64 = (0..6).map(|k| row[k] * base[k]).sum::<f64>() - god.qp.rhs[i];
            assert!(
                (value - (d0.distance - row_target)).abs() < 1e-9,
                "row {i}: {value} vs {}",
                d0.distance
            );
            // Its gradient, where the nearest features stay the same a step either way.
            let h = 1e-6;
            for k in 0..6 {
                let (mut up, mut down) = (base, base);
                up[k] += h;
                down[k] -= h;
                let fd = (distance(c, &up).distance - distance(c, &down).distance) / (2.0 * h);
                assert!(
                    (fd - row[k]).abs() < 1e-5 * (1.0 + row[k].abs()),
                    "row {i}, coordinate {k}: {} vs {fd}",
                    row[k]
                );
            }
            checked += 1;
        }
        assert!(checked > 0);
    }

    #[test]
    fn pressed_and_twisted_into_a_plate_no_triangles_ever_meet() {
        let (mut god, tool, plate) = cube_on_plate();
        god.reset(&Pose::from_array([0.0, 0.0, 5.0, 0.0, 0.0, 0.0]))
            .unwrap();
        let mut touched = 0;
        for i in 0..600 {
            let s = i as f64 / 600.0;
            // Down 3 mm into the plate by mid-run, twisting, tilting and sliding on.
            let hand = Pose::from_array([
                4.0 * (3.0 * s).sin(),
                2.0 * s,
                5.0 - 8.0 * s.min(0.5) * 2.0,
                0.3 * (7.0 * s).sin(),
                0.2 * (5.0 * s).cos() - 0.2,
                1.5 * s,
            ]);
            let f = god.step(&hand);
            let q = Pose::from_array(f.q_g);
            let d = brute_distance(&tool, &plate, &q);
            assert!(
                d > 0.0,
                "frame {i}: the cube's triangles meet the plate's ({:?})",
                f.status
            );
            if f.contacts > 0 {
                touched += 1;
                assert!(d <= 0.01, "frame {i}: in contact yet {d} mm off");
            }
        }
        assert!(
            touched > 200,
            "the hand presses the cube onto the plate: {touched} frames touch"
        );
    }

    #[test]
    fn a_cube_turned_steadily_on_a_plate_takes_one_pass_a_frame() {
        let (mut god, _, _) = cube_on_plate();
        // No deadline: the passes counted are the step's, not a busy machine's.
        god.params.budget_us = 1e6;
        god.reset(&Pose::from_array([0.0, 0.0, 2.5, 0.0, 0.0, 0.0]))
            .unwrap();
        // Pressed 1 mm into the plate, then turned about the plate's normal at a steady pace
        // that takes each region's trust region about a frame to spend: a reused region would
        // stop the turn at its trust region's edge, and a new region follow in the same frame.
        let hand = |turn: f64| Pose::from_array([0.0, 0.0, 1.0, 0.0, 0.0, turn]);
        for _ in 0..50 {
            god.step(&hand(0.0));
        }
        let (more_passes, frames) = several_passes(
            &mut god,
            400,
            |i| hand(0.004 * f64::from(i)),
            |i, f| assert!(f.contacts > 0, "frame {i}: the cube stays on the plate"),
        );
        assert!(
            more_passes * 20 <= frames,
            "{more_passes} of {frames} turning frames took more than one pass"
        );
    }

    #[test]
    fn a_cube_pressed_hard_and_turned_on_a_dense_sheet_follows_the_turn_in_fewer_passes() {
        // The hand 2 mm into a fine sheet (over 1 000 triangle pairs under the cube: balls at
        // the dense floor) turns the cube about the sheet's normal by 4 mrad a frame: the
        // press is held by the sheet, the turn is the cube's whole way. A trust box shared by
        // the way to the hand gives half its budget to the press, and the turn outruns the
        // rest: a second region in most frames.
        let passes = |held: bool| {
            let mut god = cube_over_fine_grid();
            god.params.heuristics.mesh_held_press = held;
            // No deadline: the passes are the step's, not the machine's.
            god.params.budget_us = 1e6;
            god.reset(&Pose::from_array([0.0, 0.0, 2.5, 0.0, 0.0, 0.0]))
                .unwrap();
            let hand = |turn: f64| Pose::from_array([0.0, 0.0, 0.0, 0.0, 0.0, turn]);
            for _ in 0..50 {
                god.step(&hand(0.0));
            }
            several_passes(
                &mut god,
                300,
                |i| hand(0.004 * f64::from(i)),
                |i, f| {
                    assert!(f.contacts > 0, "frame {i}: the cube stays on the sheet");
                    assert!(f.q_g[2] >= 2.0, "frame {i}: {}", f.q_g[2]);
                },
            )
        };
        let (held, frames) = passes(true);
        let (shared, _) = passes(false);
        assert!(
            held * 3 <= frames,
            "{held} of {frames} frames took more than one pass"
        );
        assert!(
            2 * held <= shared,
            "{held} frames of several passes held, {shared} shared by the way"
        );
    }

    #[test]
    fn rocked_fast_on_a_plate_no_triangles_meet() {
        let (mut god, tool, plate) = cube_on_plate();
        god.reset(&Pose::from_array([0.0, 0.0, 2.5, 0.0, 0.0, 0.0]))
            .unwrap();
        for i in 0..200 {
            // Pressed 1 mm down, rocking about x by up to 0.6 rad at 0.25 rad a frame: each
            // frame's corner sweeps an arc the rows' planes take for a line.
            let angle = 0.6 * ((i as f64) * 0.45).sin();
            let hand = Pose::from_array([0.0, 0.0, 1.0, angle, 0.0, 0.0]);
            let f = god.step(&hand);
            let d = brute_distance(&tool, &plate, &Pose::from_array(f.q_g));
            assert!(
                d > 0.0,
                "frame {i}: the cube's triangles meet the plate's ({:?})",
                f.status
            );
        }
    }

    #[test]
    fn a_step_through_the_plate_is_cut_back_to_the_last_free_pose_on_the_way() {
        let (mut god, tool, plate) = cube_on_plate();
        let q = Pose::from_array([0.0, 0.0, 2.5, 0.0, 0.0, 0.0]);
        god.detect_triangles(&q, 3.0);
        let lin = god
            .linearization(&q, &Pose::from_array([0.0, 0.0, 0.5, 0.0, 0.0, 0.0]))
            .unwrap();
        god.fill_rows(&lin, None);
        // The hand's pose itself: 2 mm down, the cube's bottom 1.5 mm into the plate.
        let through = lin.variable(&Pose::from_array([0.0, 0.0, 0.5, 0.0, 0.0, 0.0]));
        assert!(god.mesh_meets(Some(&q), &lin.configuration(&through)));
        let (back, _) = god.last_free_on_the_way(&lin, &through).unwrap();
        let d = brute_distance(&tool, &plate, &back);
        // Free, and within the bisection's last step (2 mm / 2^8) of the touch.
        assert!(d > 0.0 && d <= 2.0 / 256.0 + 1e-12, "{d}");
        assert!(
            (back.q[2] - 2.0).abs() <= 2.0 / 256.0 + 1e-12,
            "{:?}",
            back.q
        );
    }

    /// Numbers uniform in [-1, 1) from a fixed linear congruential sequence seeded by `seed`.
    fn uniform(seed: u64) -> impl FnMut() -> f64 {
        let mut x = seed;
        move || {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (x >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        }
    }

    /// A pose about the origin from `r` (mm, rad): within 1 mm and turned up to 3 rad.
    fn random_pose(r: &mut impl FnMut() -> f64) -> Pose {
        Pose::from_array([r(), r(), r(), 3.0 * r(), 1.5 * r(), 3.0 * r()])
    }

    /// No sweep for even `k`, else one of up to 0.3 mm along each axis from `r`.
    fn every_other_sweep(r: &mut impl FnMut() -> f64, k: usize) -> Vector3<f64> {
        if k.is_multiple_of(2) {
            Vector3::zeros()
        } else {
            Vector3::new(0.3 * r(), 0.3 * r(), 0.3 * r())
        }
    }

    /// A tree of one triangle, as given (mm).
    fn one_triangle(t: Triangle) -> TriangleTree {
        TriangleTree::build(&[t], &Pose::identity())
    }

    /// The first triangle of `tree` posed where it is (the identity pose).
    fn posed_as_given(tree: &TriangleTree) -> PosedTriangle {
        PosedTriangle::of(tree, 0, &Matrix3::identity(), &Vector3::zeros())
    }

    /// Trees of `n` random triangles each: the tool's corners in the unit cube about the
    /// origin, the part's in one `part_scale` times as wide.
    fn random_trees(
        r: &mut impl FnMut() -> f64,
        n: usize,
        part_scale: f64,
    ) -> (TriangleTree, TriangleTree) {
        let mut triangles = |scale: f64| -> Vec<Triangle> {
            (0..n)
                .map(|_| std::array::from_fn(|_| std::array::from_fn(|_| scale * r())))
                .collect()
        };
        let tools = triangles(1.0);
        let parts = triangles(part_scale);
        (
            TriangleTree::build(&tools, &Pose::identity()),
            TriangleTree::build(&parts, &Pose::identity()),
        )
    }

    /// The bounds that also say which way they run give the same bounds as the listing's own
    /// (kept apart for the listing's speed), swept or not, at every margin; and a pair found
    /// apart lies at least that far apart along the way they name, on its corners.
    #[test]
    fn the_bounds_with_their_way_equal_the_plain_ones_and_hold_along_it() {
        let mut r = uniform(24681357);
        let (tool_tree, part_tree) = random_trees(&mut r, 30, 1.5);
        let mut named = 0;
        for k in 0..40 {
            let q = random_pose(&mut r);
            let (rot, t) = (q.rotation_matrix(), q.translation());
            let sweep = every_other_sweep(&mut r, k);
            for i in 0..tool_tree.len() as u32 {
                let posed = PosedTriangle::of(&tool_tree, i, &rot, &t).swept(&sweep);
                for j in 0..part_tree.len() as u32 {
                    assert_eq!(
                        posed.box_gap(&part_tree, j),
                        posed.box_gap_along(&part_tree, j).0
                    );
                    let boxes = posed.box_gap_along(&part_tree, j);
                    assert_eq!(
                        posed.planes_beyond(&part_tree, j, boxes.0),
                        posed.planes_beyond_along(&part_tree, j, boxes).0
                    );
                    for margin in [0.0, 0.05, 0.3, 2.0] {
                        let (bound, along) =
                            posed.separation_upto_along(&part_tree, j, margin, true);
                        assert_eq!(posed.separation_upto(&part_tree, j, margin, true), bound);
                        if along != 0 && sweep == Vector3::zeros() {
                            named += 1;
                            let way = gap_way(along, &posed, &part_tree, j);
                            let gap = projected_gap(&posed.corners, part_tree.triangle(j), &way);
                            assert!(gap >= bound - 1e-12, "{gap} along {along} under {bound}");
                        }
                    }
                }
            }
        }
        assert!(named > 10_000, "{named} bounds with a way");
    }

    /// A gap taken where a pair was found apart (any of its ways, swept or not), measured
    /// again on the tool's own corners at another pose, never exceeds how far apart the two
    /// triangles lie along its way there (so never their distance), and is that separation
    /// where the first gap was (no sweep).
    #[test]
    fn a_gap_measured_again_on_the_tools_corners_never_exceeds_the_separation() {
        let mut r = uniform(97531);
        let (tool_tree, part_tree) = random_trees(&mut r, 25, 1.5);
        let (mut checked, mut tight) = (0, 0);
        for k in 0..30 {
            let q = random_pose(&mut r);
            let (rot, t) = (q.rotation_matrix(), q.translation());
            let sweep = every_other_sweep(&mut r, k);
            let later = Pose::from_array([
                q.q[0] + 0.2 * r(),
                q.q[1] + 0.2 * r(),
                q.q[2] + 0.2 * r(),
                q.q[3] + 0.3 * r(),
                q.q[4] + 0.3 * r(),
                q.q[5] + 0.3 * r(),
            ]);
            let (rot_b, t_b) = (later.rotation_matrix(), later.translation());
            for i in 0..tool_tree.len() as u32 {
                let posed = PosedTriangle::of(&tool_tree, i, &rot, &t).swept(&sweep);
                let at_b = PosedTriangle::of(&tool_tree, i, &rot_b, &t_b);
                for j in 0..part_tree.len() as u32 {
                    let (apart, along) = posed.separation_upto_along(&part_tree, j, 0.0, true);
                    if along == 0 {
                        continue;
                    }
                    let way = gap_way(along, &posed, &part_tree, j);
                    let mut gap = PairGap::new(apart, way, &posed.corners, &t, 0.0);
                    let in_tool = tool_tree.triangle(i);
                    let part = part_tree.triangle(j);
                    let there = projected_gap(&at_b.corners, part, &way);
                    let again = gap.exact_at(in_tool, &rot_b, &t_b, 0.0);
                    assert!(again <= there + 1e-12, "{again} over {there} along {along}");
                    let distance = triangle_distance(&at_b.corners, part).distance;
                    assert!(
                        again <= distance + 1e-12,
                        "{again} over the distance {distance}"
                    );
                    checked += 1;
                    if sweep == Vector3::zeros() {
                        let here = gap.exact_at(in_tool, &rot, &t, 0.0);
                        let separation = projected_gap(&posed.corners, part, &way);
                        // Less only by the rounding's allowance.
                        assert!(here <= separation, "{here} over {separation}");
                        assert!(
                            separation - here < 2.0 * GAP_ROUNDING_MM,
                            "{here}, {separation}"
                        );
                        tight += 1;
                    }
                }
            }
        }
        assert!(
            checked > 5_000 && tight > 2_000,
            "{checked} gaps, {tight} where taken"
        );
    }

    #[test]
    fn the_plane_gap_never_exceeds_the_distance_and_sees_facing_walls() {
        // A pseudo-random spread of triangle pairs.
        let mut r = uniform(12345);
        for _ in 0..5000 {
            let a: Triangle = std::array::from_fn(|_| std::array::from_fn(|_| r()));
            let off = 2.0 * r();
            let b: Triangle = std::array::from_fn(|_| {
                std::array::from_fn(|k| r() + if k == 2 { off } else { 0.0 })
            });
            let d = triangle_distance(&a, &b).distance;
            assert!(plane_gap(&a, &b) <= d + 1e-12 && plane_gap(&b, &a) <= d + 1e-12);
        }
        // Two facing pieces of parallel walls 0.2 mm apart: the bound is the gap.
        let wall: Triangle = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let facing: Triangle = [[0.2, 0.1, 0.2], [0.9, 0.1, 0.2], [0.2, 0.8, 0.2]];
        assert!((plane_gap(&facing, &wall) - 0.2).abs() < 1e-12);
    }

    /// The separation the narrow phase drops pairs by (boxes and planes) is a lower bound on
    /// the exact distance for posed tool triangles, and the boxes see what the planes cannot:
    /// two facets of one wall far apart along it, each on neither side of the other's plane.
    #[test]
    fn the_separation_never_exceeds_the_distance_and_sees_facets_along_a_wall() {
        let mut r = uniform(987654321);
        let (tool_tree, part_tree) = random_trees(&mut r, 40, 1.5);
        let (mut dropped_by_boxes, mut checked) = (0, 0);
        for _ in 0..50 {
            let q = random_pose(&mut r);
            let (rot, t) = (q.rotation_matrix(), q.translation());
            for i in 0..tool_tree.len() as u32 {
                let posed = PosedTriangle::of(&tool_tree, i, &rot, &t);
                for j in 0..part_tree.len() as u32 {
                    let d = triangle_distance(&posed.corners, part_tree.triangle(j)).distance;
                    let bound = posed.separation(&part_tree, j);
                    let edges = posed.edges_beyond(&part_tree, j, bound);
                    assert!(edges <= d + 1e-12, "bound {edges} over distance {d}");
                    let (n, off) = part_tree.plane(j);
                    let planes = signed_side_gap(&posed.corners, &n, off).abs().max(
                        signed_side_gap(part_tree.triangle(j), &posed.normal, posed.offset).abs(),
                    );
                    dropped_by_boxes += usize::from(bound > 0.1 && planes <= 0.1);
                    checked += 1;
                }
            }
        }
        assert!(
            checked > 50_000 && dropped_by_boxes > 0,
            "{dropped_by_boxes} of {checked}"
        );
        // Two coplanar facets of a wall 10 mm apart along it: on neither side of each other's
        // plane, yet 10 mm apart, and the boxes say so.
        let wall = one_triangle([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
        let along = one_triangle([[11.0, 0.0, 0.0], [12.0, 0.0, 0.0], [11.0, 1.0, 0.0]]);
        let posed = posed_as_given(&along);
        assert!((posed.separation(&wall, 0) - 10.0).abs() < 1e-12);
        // Two coplanar facets side by side across a diagonal, 0.3 mm apart: their boxes
        // overlap and each lies in the other's plane, but not across the other's edge.
        let beside = one_triangle([[1.0, 1.0, 0.0], [0.5, 1.0, 0.0], [1.0, 0.5, 0.0]]);
        let shift = 0.3 * std::f64::consts::FRAC_1_SQRT_2;
        let posed = PosedTriangle::of(
            &beside,
            0,
            &Matrix3::identity(),
            &Vector3::new(shift, shift, 0.0),
        );
        let gap = 1.5 * std::f64::consts::FRAC_1_SQRT_2 - std::f64::consts::FRAC_1_SQRT_2 + 0.3;
        let d = triangle_distance(&posed.corners, wall.triangle(0)).distance;
        let bound = posed.edges_beyond(&wall, 0, posed.separation(&wall, 0));
        assert!((d - gap).abs() < 1e-12 && (bound - gap).abs() < 1e-12);
        assert!(posed.separation_within(&wall, 0, 0.29, true).is_none());
        assert!(posed.box_gap(&wall, 0) == 0.0);
    }

    #[test]
    fn the_swept_separation_never_exceeds_the_distance_anywhere_on_the_sweep() {
        let mut r = uniform(192837465);
        let (tool_tree, part_tree) = random_trees(&mut r, 20, 2.0);
        let (mut apart, mut checked) = (0, 0);
        for _ in 0..30 {
            let q = random_pose(&mut r);
            let (rot, t) = (q.rotation_matrix(), q.translation());
            let sweep = Vector3::new(2.0 * r(), 2.0 * r(), 2.0 * r());
            for i in 0..tool_tree.len() as u32 {
                let swept = PosedTriangle::of(&tool_tree, i, &rot, &t).swept(&sweep);
                for j in 0..part_tree.len() as u32 {
                    let bound = swept.edges_beyond(&part_tree, j, swept.separation(&part_tree, j));
                    let nearest = (0..=16)
                        .map(|k| {
                            let at = t + sweep * (f64::from(k) / 16.0);
                            let a = PosedTriangle::of(&tool_tree, i, &rot, &at).corners;
                            triangle_distance(&a, part_tree.triangle(j)).distance
                        })
                        .fold(f64::INFINITY, f64::min);
                    assert!(
                        bound <= nearest + 1e-12,
                        "bound {bound} over distance {nearest}"
                    );
                    apart += usize::from(bound > 0.0);
                    checked += 1;
                }
            }
        }
        // It still tells most pairs apart.
        assert!(2 * apart > checked, "{apart} of {checked} pairs told apart");
        // A facet sliding along a wall parallel to it keeps its gap however far it slides.
        let wall = one_triangle([[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [0.0, 10.0, 0.0]]);
        let facet = one_triangle([[0.0, 0.0, 0.1], [1.0, 0.0, 0.1], [0.0, 1.0, 0.1]]);
        let posed = posed_as_given(&facet);
        let slid = posed.swept(&Vector3::new(3.0, 2.0, 0.0));
        assert!((slid.separation(&wall, 0) - 0.1).abs() < 1e-12);
    }
}
