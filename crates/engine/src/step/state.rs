//! The god-object's state, grouped by what it serves: the bodies, the detection buffers,
//! the work kept ahead (probes, neighbour lists), the QP's buffers, the materials, and the run
//! state ([`RunState`]: everything learnt while running, replaced whole by a reset).

use super::*;

/// The bodies as the step sees them (fixed after construction).
pub(super) struct Bodies {
    /// The tool's packed tree (tool frame, mm) and the objects' (placed, mm).
    pub(super) tool: PackedTree,
    pub(super) objects: Vec<PackedTree>,
    /// Some object has face cuts (then no neighbour lists are kept).
    pub(super) faces: bool,
    /// Largest distance of a tool leaf centre from the tool origin, mm.
    pub(super) reach: f64,
    /// Box of the tool's leaf centres (tool frame, mm; with the mesh's corners in the mesh
    /// mode): a turn about an axis moves them by at most the angle times their largest
    /// distance from it ([`CentreBox::turn_bound`]).
    pub(super) centres: CentreBox,
    /// The meshes of the mesh geometry mode (`None`: the leaf spheres are the geometry).
    pub(super) meshes: Option<Meshes>,
}

impl Bodies {
    /// How far (mm) a point of the box `part` (tool frame) moves at most when the tool turns
    /// from `r_a` to `r_b`: its own arm's bound, no more than the whole tool's.
    pub(super) fn part_turn_bound(
        &self,
        part: Option<&CentreBox>,
        r_a: &Matrix3<f64>,
        r_b: &Matrix3<f64>,
    ) -> f64 {
        // The turn read once for every bound below (each reads the same `r_b r_a^T`).
        let w = rotation_log(&(r_b * r_a.transpose()));
        let whole = self.turn_bound_by(r_a, &w);
        part.map_or(whole, |p| {
            p.turn_bound_by(r_a, &w)
                .min(w.norm() * p.reach())
                .min(whole)
        })
    }

    /// [`GodObject::turn_bound`]: how far (mm) a point of the tool moves at most when it turns
    /// from `r_a` to `r_b`.
    pub(super) fn turn_bound(&self, r_a: &Matrix3<f64>, r_b: &Matrix3<f64>) -> f64 {
        self.turn_bound_by(r_a, &rotation_log(&(r_b * r_a.transpose())))
    }

    /// [`Bodies::turn_bound`] of the turn `w` (rotation vector, world, rad) from `r_a`.
    fn turn_bound_by(&self, r_a: &Matrix3<f64>, w: &Vector3<f64>) -> f64 {
        self.centres
            .turn_bound_by(r_a, w)
            .min(w.norm() * self.reach)
    }
}

/// The detection's buffers: the traversal workspace, the helper thread and the pair list.
pub(super) struct Detector {
    pub(super) ws: CollideWorkspace,
    /// The helper thread that shares large traversals ([`EngineConfig::helper_thread`]).
    pub(super) team: Option<TraversalTeam>,
    /// The leaf pairs of the current region.
    pub(super) pairs: Vec<LeafPair>,
    /// By tool slot: the detection (`face_stamp`) and index in `pairs` of the tool leaf's last
    /// half-space pair, so the same face met through several object leaves is kept once.
    pub(super) face_seen: Vec<(u32, u32)>,
    pub(super) face_stamp: u32,
    /// The mesh mode's triangle pairs of the current region (the rows' order), and their
    /// distances at the last linearisation pose (mm).
    pub(super) contacts: Vec<TriPair>,
    pub(super) contact_gaps: Vec<f64>,
    /// The tool point (tool frame, mm) each of those rows holds off the object: where its
    /// multiplier's force acts (friction's centre of pressure).
    pub(super) contact_points: Vec<[f64; 3]>,
    /// The distance (mm) each row keeps its pair apart ([`Heuristics::mesh_tilted_targets`]).
    pub(super) row_targets: Vec<f64>,
    /// The mesh mode's triangle pairs within a wider margin ([`Tuning::near_list_mm`])
    /// of a recent pose: the narrow phase filters them while they cover its region.
    pub(super) near: Vec<TriPair>,
    /// A lower bound (mm) on each of `near`'s pair's distance (same order) at the last region
    /// that filtered the list (or on its span, as listed), plus `near_offset`; each filter
    /// moves every bound to its own centre by adding the motion bound of the way to the
    /// offset.
    pub(super) near_apart: Vec<f64>,
    pub(super) near_offset: f64,
    /// Each of `near`'s pairs' directional gap (same order), and the sum of the turn bounds
    /// (mm) from filter to filter since the list was taken that they are taken less.
    pub(super) near_gaps: Vec<PairGap>,
    pub(super) near_turn: f64,
    /// Each of `near`'s pairs' nearest edges where last measured (same order): tried first
    /// the next time ([`collide::triangle_distance_from`]).
    pub(super) near_edges: Vec<collide::NearestEdges>,
    /// Each of `near`'s pairs' rank in the descent's order ([`TriangleTree::descend`], the
    /// objects' one after another; rising along the list): a new list is merged with the one
    /// it replaces by them ([`Heuristics::mesh_list_inherit`]).
    pub(super) near_ranks: Vec<u64>,
    /// Exact distances of `contacts` (same order) with the tool at one pose (rotation,
    /// translation): where the narrow phase listed them, or the last answer checked. Rows
    /// linearised at that pose reuse them.
    pub(super) contact_nearest: Vec<collide::TriangleDistance>,
    /// Which of `contact_nearest` hold the exact distance at `nearest_at`: the narrow phase
    /// measures every pair it keeps, the check of an answer those it needs.
    pub(super) nearest_known: Vec<bool>,
    pub(super) nearest_at: Option<(Matrix3<f64>, Vector3<f64>)>,
    /// Where each of `contacts` stands in `near` (ascending), and which near list that was
    /// (`near_generation`, counted up each time `near` is listed or replaced).
    pub(super) contact_from: Vec<u32>,
    pub(super) contacts_list: Option<u64>,
    pub(super) near_generation: u64,
    /// The last region's `contact_nearest`, `nearest_known` and `contact_from`, kept while the
    /// next region is filtered: at the answer the check measured, they are its own.
    pub(super) reuse_nearest: Vec<collide::TriangleDistance>,
    pub(super) reuse_known: Vec<bool>,
    pub(super) reuse_from: Vec<u32>,
    /// The near list (`near_generation`) whose positions `reuse_from` names.
    pub(super) reuse_list: Option<u64>,
    /// The tool's triangles posed at the pose being measured (empty in sphere mode).
    pub(super) tool_poses: ToolPoses,
    /// The tool's triangles posed for the near list under way (its span's pose and sweep).
    pub(super) list_poses: ToolPoses,
    /// The near list under way ([`NearAhead`]), and the stack its descent of the triangle
    /// trees is on (reserved for the deepest pair of trees).
    pub(super) next_near: Vec<TriPair>,
    pub(super) next_apart: Vec<f64>,
    pub(super) next_gaps: Vec<PairGap>,
    pub(super) next_ranks: Vec<u64>,
    /// Room for a new list's nearest edges while they are drawn from the old list's.
    pub(super) next_edges: Vec<collide::NearestEdges>,
    pub(super) next_stack: collide::TreePairStack,
}

impl Detector {
    /// The near list's pairs whose kept bound, less `offset` (mm: the list's offset where the
    /// bounds are taken), is at most `within` (mm).
    pub(super) fn near_pairs_within(&self, offset: f64, within: f64) -> usize {
        self.near_apart
            .iter()
            .filter(|&&kept| kept - offset <= within)
            .count()
    }

    /// Makes the contacts' kept exact distances those of the tool at `(rot, t)`: none known
    /// where they were measured elsewhere.
    pub(super) fn hold_distances_at(&mut self, rot: Matrix3<f64>, t: Vector3<f64>) {
        if self.nearest_at != Some((rot, t)) {
            self.nearest_at = Some((rot, t));
            self.nearest_known.iter_mut().for_each(|k| *k = false);
        }
    }

    /// Empties the region's contacts and keeps their exact distances (and where they were
    /// measured) for the next region's filter ([`Detector::reuse_nearest`]); returns where
    /// they hold.
    pub(super) fn keep_checked_distances(&mut self) -> CheckedDistances {
        self.reuse_list = self.contacts_list.take();
        let kept = CheckedDistances {
            at: self.nearest_at.take(),
        };
        std::mem::swap(&mut self.contact_nearest, &mut self.reuse_nearest);
        std::mem::swap(&mut self.nearest_known, &mut self.reuse_known);
        std::mem::swap(&mut self.contact_from, &mut self.reuse_from);
        self.contacts.clear();
        self.contact_nearest.clear();
        self.nearest_known.clear();
        self.contact_from.clear();
        kept
    }

    /// The buffers, reserved once for `cap` leaf pairs (and as many triangle pairs in the mesh
    /// mode, with `meshes`), a tool of `tool_slots` sphere slots, the traversal workspace `ws`
    /// and the helper thread's `team`.
    pub(super) fn new(
        ws: CollideWorkspace,
        team: Option<TraversalTeam>,
        cap: usize,
        tool_slots: usize,
        meshes: Option<&Meshes>,
    ) -> Self {
        let contacts_cap = if meshes.is_some() { cap } else { 0 };
        let next_stack = meshes.map_or_else(collide::TreePairStack::default, |m| {
            m.objects
                .iter()
                .map(|o| TriangleTree::stack_for(&m.tool, o))
                .max_by_key(collide::TreePairStack::capacity)
                .unwrap_or_default()
        });
        let mut detector = Self {
            ws,
            team,
            pairs: Vec::with_capacity(cap),
            face_seen: vec![(0, 0); tool_slots],
            face_stamp: 0,
            contacts: Vec::with_capacity(contacts_cap),
            near: Vec::with_capacity(contacts_cap),
            next_near: Vec::with_capacity(contacts_cap),
            next_apart: Vec::with_capacity(contacts_cap),
            near_apart: Vec::with_capacity(contacts_cap),
            near_offset: 0.0,
            near_gaps: Vec::with_capacity(contacts_cap),
            next_gaps: Vec::with_capacity(contacts_cap),
            near_turn: 0.0,
            near_edges: Vec::with_capacity(contacts_cap),
            near_ranks: Vec::with_capacity(contacts_cap),
            next_ranks: Vec::with_capacity(contacts_cap),
            next_edges: Vec::with_capacity(contacts_cap),
            contact_nearest: Vec::with_capacity(contacts_cap),
            nearest_known: Vec::with_capacity(contacts_cap),
            nearest_at: None,
            contact_from: Vec::with_capacity(contacts_cap),
            contacts_list: None,
            near_generation: 0,
            reuse_nearest: Vec::with_capacity(contacts_cap),
            reuse_known: Vec::with_capacity(contacts_cap),
            reuse_from: Vec::with_capacity(contacts_cap),
            reuse_list: None,
            tool_poses: ToolPoses::new(meshes.map_or(0, |m| m.tool.len())),
            list_poses: ToolPoses::new(meshes.map_or(0, |m| m.tool.len())),
            next_stack,
            contact_gaps: vec![0.0; contacts_cap],
            contact_points: vec![[0.0; 3]; contacts_cap],
            row_targets: vec![0.0; contacts_cap],
        };
        detector.touch_pages();
        detector
    }

    /// Makes every buffer's storage resident ([`collide::touch_pages`]): a frame that first
    /// writes past one's high-water mark (a near list longer than any before it) takes no page
    /// fault.
    fn touch_pages(&mut self) {
        use collide::touch_pages as touch;
        touch(&mut self.pairs);
        touch(&mut self.face_seen);
        touch(&mut self.contacts);
        touch(&mut self.near);
        touch(&mut self.next_near);
        touch(&mut self.next_apart);
        touch(&mut self.near_apart);
        touch(&mut self.near_gaps);
        touch(&mut self.next_gaps);
        touch(&mut self.near_edges);
        touch(&mut self.near_ranks);
        touch(&mut self.next_ranks);
        touch(&mut self.next_edges);
        touch(&mut self.contact_nearest);
        touch(&mut self.nearest_known);
        touch(&mut self.contact_from);
        touch(&mut self.reuse_nearest);
        touch(&mut self.reuse_known);
        touch(&mut self.reuse_from);
        touch(&mut self.contact_gaps);
        touch(&mut self.contact_points);
        touch(&mut self.row_targets);
        self.tool_poses.touch_pages();
        self.list_poses.touch_pages();
    }
}

/// Where the distances [`Detector::keep_checked_distances`] kept were measured: the tool's
/// pose (rotation, translation, mm).
pub(super) struct CheckedDistances {
    pub(super) at: Option<(Matrix3<f64>, Vector3<f64>)>,
}

/// The work kept ahead of need, a slice per frame.
pub(super) struct Ahead {
    /// The next free-space proof.
    pub(super) probe: FreeSpaceProbe,
    /// The neighbour list in use: every leaf pair within a wide margin of a pose near the tool,
    /// filtered instead of traversed while a region's query stays inside it.
    pub(super) neighbours: NeighbourList,
    /// The next neighbour list (built by the helper thread, if there is one, on the same
    /// schedule).
    pub(super) next_neighbours: BackgroundList,
}

/// The QP's buffers and solvers.
pub(super) struct QpBuffers {
    /// Constraint rows `J` (mm per QP unit) and right-hand sides `d` (mm), pairs then trust rows.
    pub(super) rows: Vec<[f64; 6]>,
    pub(super) rhs: Vec<f64>,
    pub(super) solver: Solver,
    /// Constraint reduction around the solver (exact solvers, unless turned off): its
    /// multipliers and active set are the frame's, reduced or not.
    pub(super) rows_solver: RowGeneration,
    /// Bench audit of the reduction: a second solver that solves every reduced QP in full
    /// ([`GodObject::audit_reduction`]); none in normal use.
    pub(super) audit: Option<Box<(Solver, ReductionAudit)>>,
}

/// The materials' friction.
pub(super) struct Materials {
    /// Friction of each object's material, and of the tool's (`None`: the objects' alone).
    pub(super) object_friction: Vec<Friction>,
    pub(super) tool_friction: Option<Friction>,
    /// Friction is applied (it can be turned off without forgetting the coefficients).
    pub(super) friction_on: bool,
}

/// Everything the god-object learns while it runs, by stage. [`GodObject::new`] and
/// [`GodObject::reset`] both start from [`RunState::fresh`], so a reset run repeats a fresh
/// engine's frames: nothing carries over.
///
/// Plain values only: the buffers a run fills (pair list, probe, neighbour lists) are owned by
/// [`GodObject`], sized once, and emptied in place by a reset.
#[derive(Clone, Debug)]
pub(super) struct RunState {
    /// The graphic pose and how it moved: the last answer, its motion, the hand's offset from it (the prediction) and its overlap.
    pub(super) motion: Motion,
    /// The regions: the pair list's completeness, the cached region, the pair density, the contact face and its slab regions' rest, the near part of the tool.
    pub(super) regions: RegionMemory,
    /// The solves: the warm start and the time a row costs.
    pub(super) solve: SolveMemory,
    /// The free-space proofs and the background probes' costs and margin.
    pub(super) proofs: ProofMemory,
    /// The neighbour lists' margin, costs and yield, and what they spare.
    pub(super) lists: ListPacing,
    /// The detection work of the frame and of the run.
    pub(super) counts: WorkCounts,
    /// Friction's stick or slip, and the contact it acts in.
    pub(super) friction: FrictionMemory,
}

impl RunState {
    /// The state before any frame.
    pub(super) fn fresh(tuning: &Tuning) -> Self {
        Self {
            motion: Motion {
                q_g: Pose::identity(),
                started: false,
                last_motion: 0.0,
                last_step: [0.0; 3],
                last_turn: [0.0; 3],
                hand_offset: (Vector3::zeros(), Vector3::zeros()),
                prediction_error: 0.0,
                behind: false,
                fell: false,
                fell_carried: false,
                pen_g: 0.0,
                contacts_g: 0,
            },
            regions: RegionMemory {
                cached: None,
                pairs_question: None,
                dropped: 0,
                interrupted: false,
                density: density::PairDensity::default(),
                contact_face: None,
                lever_cache: None,
                slab_rest: 0,
                slab_next_rest: tuning.slab_rest_frames,
                near_at: None,
                near_part_rest: 0,
                contacts_at: None,
                near_bounds_at: None,
                near_listed_at: None,
                cached_bound: false,
                near_extra: tuning.near_list_mm,
                near_descent_us: 0.0,
                mesh_region_pass_us: 0.0,
                mesh_contact_us: 0.0,
                overflow_floor: f64::INFINITY,
                near_standoff: f64::INFINITY,
                slow_growth_to: None,
                near_ahead: NearAhead::IDLE,
            },
            solve: SolveMemory {
                warm: [(0, 0, 0); 6],
                warm_len: 0,
                warm_idx: [0; 6],
                solve_us_per_row: 0.0,
            },
            proofs: ProofMemory {
                free: [FreeProof::none(); 2],
                probe_splits: 0,
                path_probe_splits: 0,
                probe_margin: tuning.background_probe_mm,
            },
            lists: ListPacing {
                list_margin: tuning.list_margin_mm,
                list_work: tuning.list_first_work,
                list_splits: tuning.list_first_splits,
                list_served: 0,
                list_yield: tuning.list_first_yield,
                splits_per_region: 0.0,
                detections_per_frame: 0.0,
                frame_detections: 0,
                idle_given: false,
                own_level_ln: None,
            },
            counts: WorkCounts {
                frame_splits: 0,
                frame_scanned: 0,
                regions_filtered: 0,
                regions_traversed: 0,
                near_listed: 0,
                near_taken: 0,
                near_posed: 0,
                near_direct: 0,
            },
            friction: FrictionMemory {
                sliding: false,
                patch: None,
            },
        }
    }
}

/// The graphic pose and how it moved: the last answer, its motion, the hand's offset from it (the prediction) and its overlap.
#[derive(Clone, Debug)]
pub(super) struct Motion {
    /// The graphic configuration: the last frame's answer.
    pub(super) q_g: Pose,
    /// A start pose was given (by [`GodObject::reset`] or the first frame's hand).
    pub(super) started: bool,
    /// Motion bound of the graphic tool over the last frame, mm.
    pub(super) last_motion: f64,
    /// Translation of the graphic tool over the last frame, mm.
    pub(super) last_step: [f64; 3],
    /// Turn of the graphic tool over the last frame (rotation vector, world, rad).
    pub(super) last_turn: [f64; 3],
    /// Where the hand was relative to the graphic tool at the end of the last frame:
    /// translation `t_h - t_g` (mm) and rotation `log(R_h R_g^T)` (rad, world axes). A hand in
    /// steady motion keeps it, which predicts where this frame's answer lies.
    pub(super) hand_offset: (Vector3<f64>, Vector3<f64>),
    /// How far (mm, largest sphere motion) the answer lay from the predicted pose, recently
    /// (the last frame's, or slowly forgotten larger ones).
    pub(super) prediction_error: f64,
    /// The last frame ended before the constrained optimum (passes or time ran out).
    pub(super) behind: bool,
    /// The last frame's last pass was held by its region's trust region, not by contacts, on a
    /// way straight toward the goal ([`Course::fell`](super::frame::Course)).
    pub(super) fell: bool,
    /// `fell` was carried through a frame that solved no pass (once only).
    pub(super) fell_carried: bool,
    /// Overlap (mm) and touching pairs at `q_g`, as the last frame measured them.
    pub(super) pen_g: f64,
    pub(super) contacts_g: u32,
}

/// The regions: the pair list's completeness, the cached region, the pair density, the contact face and its slab regions' rest, the near part of the tool.
#[derive(Clone, Debug)]
pub(super) struct RegionMemory {
    /// The region whose pairs `self.detector.pairs` holds, and the trust region that keeps iterates in
    /// it: the geometry is static, so it stays valid in later frames (temporal coherence).
    pub(super) cached: Option<(Region, Trust)>,
    /// The last answer in the cached region was stopped by its trust region.
    pub(super) cached_bound: bool,
    /// The ball detection that listed `pairs` (its pose and margin, mm), while they are
    /// complete: every pair within that margin of touching there.
    pub(super) pairs_question: Option<(Pose, f64)>,
    /// Leaf pairs of the last detection that did not fit in `pairs` (its list is then not
    /// complete).
    pub(super) dropped: usize,
    /// The frame's time ran out before its region was listed: a traversal, or the mesh mode's
    /// near list or its filter, stopped at the deadline (the list is not complete).
    pub(super) interrupted: bool,
    /// How the pair count grows with the margin near the tool, as last seen (sizes regions).
    pub(super) density: density::PairDensity,
    /// The unit normal of the one flat face whose half-space pairs alone held the tool in the
    /// last solve (a slab region's face), if so.
    pub(super) contact_face: Option<Vector3<f64>>,
    /// The last near part of the tool ([`Lever`]): the pose it was found at, and the margin
    /// (mm) every leaf outside it was beyond there.
    pub(super) lever_cache: Option<(Pose, f64, Option<Lever>)>,
    /// Frames left without slab regions, and the rest after the next failure.
    pub(super) slab_rest: u32,
    pub(super) slab_next_rest: u32,
    /// The mesh mode's near list: where `detector.near` holds (`None`: no list).
    pub(super) near_at: Option<NearSpan>,
    /// Near lists to begin without noting their near part, after one whose near part did not
    /// pay ([`Heuristics::mesh_near_part`]).
    pub(super) near_part_rest: u32,
    /// How far beyond the region's margin the next near list reaches, mm: [`Tuning::near_list_mm`],
    /// quartered each time a list overflows its storage and doubled back each time one fits.
    pub(super) near_extra: f64,
    /// The next near list's building ([`NearAhead`]).
    pub(super) near_ahead: NearAhead,
    /// What the last complete near list's descent cost, µs (in the frame, or its slices ahead
    /// together).
    pub(super) near_descent_us: f64,
    /// What the last pass that listed a new region's triangle pairs cost, µs (the mesh mode's
    /// narrow phase is not stopped by the deadline: a pass starts only where that fits).
    pub(super) mesh_region_pass_us: f64,
    /// What the rows, solve and check of the last mesh-mode region of at least 256 triangle
    /// pairs cost per pair, µs (0: none yet).
    pub(super) mesh_contact_us: f64,
    /// The dense floor after a ball region overflowed the storage (a quarter of its
    /// allowance, mm), doubled back per ball that fits ([`GodObject::dense_floor`]).
    pub(super) overflow_floor: f64,
    /// A lower bound on the distance (mm) within which the near list held
    /// [`Tuning::ball_pair_target`] pairs at the last region that filtered it
    /// (`f64::INFINITY`: fewer pairs, or no list): a tight fit's wall standing a little off
    /// the tool ([`GodObject::standoff_allow`]).
    pub(super) near_standoff: f64,
    /// How wide (mm) a ball may be after the last ball region, whose triangle pairs were
    /// more than its target and grew slower than its margin: up to twice its margin, as far
    /// as the list showed few more ([`Heuristics::mesh_slow_growth`]); `None` otherwise.
    pub(super) slow_growth_to: Option<f64>,
    /// The region centre and margin (mm) `detector.contacts` was listed for.
    pub(super) contacts_at: Option<(Pose, f64)>,
    /// Where the near list's pair bounds hold (the last region that filtered it), or `None`:
    /// they hold on its span, as listed.
    pub(super) near_bounds_at: Option<Pose>,
    /// The pose `detector.near` was listed at (its span's own, not swept): where each pair's
    /// first directional gap ([`PairGap`]) was taken, and the turns summed since start.
    pub(super) near_listed_at: Option<Pose>,
}

/// The solves: the warm start and the time a row costs.
/// Where a mesh-mode near list holds: every triangle pair within `reach` (mm) of each other
/// with the tool at `at` moved along `sweep` (mm, the world's axes) by any share of it. A tool
/// sliding along a wall keeps its distances to the wall while its triangles pass new ones: a
/// list swept along its motion serves many frames, where one about a pose alone would have to
/// reach past the wall's gap.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct NearSpan {
    pub(super) at: Pose,
    pub(super) sweep: [f64; 3],
    pub(super) reach: f64,
    /// The list's near part of the tool (tool frame), noted by its descent once it is done:
    /// every tool triangle within [`Tuning::near_part_mm`] beyond the reach of some object
    /// triangle on the span. `None`: not known, the whole tool's bound holds.
    pub(super) near: Option<CentreBox>,
}

/// What a mesh-mode near list under way is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum NearPurpose {
    /// Built ahead, a slice a frame, for the regions after the current list is spent; one past
    /// the storage is dropped.
    Ahead,
    /// A region's own list, begun in a frame whose time ran out before it was done and
    /// finished by the next frame's region at the same pose. `wide`: reaching beyond the
    /// region's margin, kept for later regions, stopped at the storage's end; else the
    /// region's alone, every pair past the storage counted (the region shrinks by them).
    Region { wide: bool },
}

/// The mesh mode's near list under way, built a slice at a time into `detector.next_near`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct NearAhead {
    /// Where it will hold (`None`: none under way).
    pub(super) at: Option<NearSpan>,
    /// What it is for.
    pub(super) purpose: NearPurpose,
    /// The object whose tree the descent is in.
    pub(super) object: usize,
    /// Every object descended (or a wide region list stopped at the storage's end).
    pub(super) done: bool,
    /// Pairs that did not fit in the storage.
    pub(super) dropped: usize,
    /// Its slices' time so far, µs.
    pub(super) spent_us: f64,
}

impl NearAhead {
    /// No list under way.
    pub(super) const IDLE: Self = Self {
        at: None,
        purpose: NearPurpose::Ahead,
        object: 0,
        done: false,
        dropped: 0,
        spent_us: 0.0,
    };

    /// A list for `span` about to be descended.
    pub(super) fn start(span: NearSpan, purpose: NearPurpose) -> Self {
        Self {
            at: Some(span),
            purpose,
            ..Self::IDLE
        }
    }
}

#[derive(Clone, Debug)]
pub(super) struct SolveMemory {
    /// The pairs active at the last answer (warm start of the next solve), and their
    /// indices in the current pair list.
    pub(super) warm: [PairId; 6],
    pub(super) warm_len: usize,
    pub(super) warm_idx: [usize; 6],
    /// Rows, trust region and solve time per row, µs: a running mean (to keep a solve from
    /// starting when it would end past the budget).
    pub(super) solve_us_per_row: f64,
}

/// The free-space proofs and the background probes' costs and margin.
#[derive(Clone, Debug)]
pub(super) struct ProofMemory {
    /// Free-space proofs: poses at which no leaf pair was within a radius (mm). Each spares
    /// traversals while the tool stays near it; two, so that one placed ahead of the tool by a
    /// background probe can be ready before the other runs out.
    pub(super) free: [FreeProof; 2],
    /// Node pairs the last finished probe at a pose, and along a path, split (their costs, to
    /// size the next one's slices).
    pub(super) probe_splits: usize,
    pub(super) path_probe_splits: usize,
    /// Margin (mm) of the next background probe: [`Tuning::background_probe_mm`], shrunk after a
    /// probe that touched ([`Tuning::probe_margin_shrink`]), grown back after one that proved free
    /// space ([`Tuning::probe_margin_growth`]).
    pub(super) probe_margin: f64,
}

/// The neighbour lists' margin, costs and yield, and what they spare.
#[derive(Clone, Debug)]
pub(super) struct ListPacing {
    /// Margin (mm) of the next neighbour list: adapted to the pairs the last one held.
    pub(super) list_margin: f64,
    /// Work of the last finished list (node pairs split plus pairs listed: its cost, to size
    /// the next one's slices), and the node pairs it split (its cost against the traversals
    /// it spares, as [`Tuning::list_payoff`] was measured).
    pub(super) list_work: usize,
    pub(super) list_splits: usize,
    /// Regions the neighbour list in use has answered since it was taken, and what the last
    /// lists spared against their build's work (running mean; [`Tuning::list_min_yield`]).
    pub(super) list_served: u32,
    pub(super) list_yield: f64,
    /// Node pairs a region's traversal splits in the current contact (running mean), and
    /// regions detected per frame (running mean; this frame's count): what a list spares.
    pub(super) splits_per_region: f64,
    pub(super) detections_per_frame: f64,
    pub(super) frame_detections: u32,
    /// The loop gave the engine its wait before this frame ([`GodObject::idle`]): the next
    /// neighbour list is then built mostly there, so one is kept wherever it lasts (its build
    /// no longer costs the frames).
    pub(super) idle_given: bool,
    /// The running quantile ([`Tuning::own_above_share`]) of the frames' own work, as the
    /// natural log of µs; none before the first frame ([`Heuristics::mesh_fill_own_level`]).
    pub(super) own_level_ln: Option<f64>,
}

/// The detection work of the frame and of the run.
#[derive(Clone, Debug)]
pub(super) struct WorkCounts {
    /// This frame's detection work so far: node pairs split (traversals, probes, list builds;
    /// [`crate::Frame::splits`]) and neighbour-list entries tested ([`crate::Frame::scanned`]).
    pub(super) frame_splits: u64,
    pub(super) frame_scanned: u64,
    /// Regions answered from a neighbour list or the last ball's own pairs, and by a
    /// traversal, since the last reset.
    pub(super) regions_filtered: u64,
    pub(super) regions_traversed: u64,
    /// The mesh mode's near lists: listed in a frame's own time, and built ahead and taken.
    pub(super) near_listed: u64,
    pub(super) near_taken: u64,
    /// Near-list pairs the regions' filters posed (their bounds did not settle them), and of
    /// those the ones measured at once, near by their upper bound ([`PairGap::upper`]).
    pub(super) near_posed: u64,
    pub(super) near_direct: u64,
}

/// Friction's stick or slip, and the contact it acts in.
#[derive(Clone, Debug)]
pub(super) struct FrictionMemory {
    /// The tool slid in the last frame with contact (kinetic friction holds it), else it
    /// stuck (static friction).
    pub(super) sliding: bool,
    /// The contact the last frame ended in (for friction), if any.
    pub(super) patch: Option<friction::Patch>,
}
