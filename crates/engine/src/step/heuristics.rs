//! Switches of the frame step's heuristics ([`Heuristics`]).

/// The frame step's heuristics, each with a switch. Every one makes frames cheaper on some
/// contacts; none may change what a frame answers beyond the convergence tolerance: with any of
/// them off the step stays exact and safe (tested on the scene zoo), and the bench's ablation
/// study (`haptic6d bench --studies ablation`) measures what each one pays across the zoo.
///
/// All on by default. Not a scene-file setting: a tool for measuring and testing the step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Heuristics {
    /// Reuse the last frame's region while the tool stays well inside it (no traversal).
    pub region_reuse: bool,
    /// Path regions: the pairs along the motion predicted for the tool (its offset from the
    /// hand kept), with a thin slab about the path as the trust region, instead of a ball as
    /// wide as the motion.
    pub path_regions: bool,
    /// Slab regions for a tool held by one flat face (face caps): the face's pairs within a
    /// thin margin across it, the rest within the slide along it.
    pub slab_regions: bool,
    /// Size regions by the pair density seen near the tool, so that a dense contact takes
    /// smaller regions (more passes) rather than one of tens of thousands of rows.
    pub density_sizing: bool,
    /// Free-space proofs: an empty detection proves free space about its pose, and later
    /// frames near it skip their traversals. Off, the background probes are off too (a probe
    /// is a proof made ahead).
    pub free_space_proofs: bool,
    /// Background probes: the next free-space proof computed a slice per frame ahead of need.
    pub background_probes: bool,
    /// Neighbour lists: every leaf pair within a wide margin of a pose near the tool, built a
    /// slice per frame ahead of need, filtered instead of traversed.
    pub neighbour_lists: bool,
    /// The near part of the tool: a ball region in contact bounds a turn by the lever arm of
    /// the leaves near the objects, not the whole tool's reach.
    pub lever: bool,
    /// Re-centre a ball on the last ball's own pairs (a small list) after a reused region's
    /// trust region stopped the answer.
    pub recentre: bool,
    /// A ball's trust box turned to the expected motion (and to a creeping pass's way), rather
    /// than the paper's axis-aligned box.
    pub turned_trust: bool,
    /// Warm-start each solve from the pairs active at the last answer.
    pub warm_start: bool,
    /// The mesh mode's near list: the triangle pairs within a wider margin of a recent pose,
    /// filtered for each region it covers instead of descending the triangle trees again.
    pub mesh_near_list: bool,
    /// The mesh mode's far rows: a triangle pair too far apart to meet anywhere in the region
    /// gets an empty row instead of its exact distance.
    pub mesh_far_rows: bool,
    /// The mesh mode's flat faces: neighbouring triangles in one plane making one convex
    /// polygon are cut again into the fewest triangles at set-up (the surface unchanged), so a
    /// flat face cut into a grid or rings gives a few pairs instead of many.
    pub mesh_flat_faces: bool,
    /// The mesh mode's face splits: a node of the triangle trees holding two faces of a part
    /// (normals more than 45° apart) is split between the faces at set-up, not at its median,
    /// so that a face's boxes are as flat as the face: a box's top and sides in one box tilt
    /// up into a tool resting on the top.
    pub mesh_face_splits: bool,
    /// The mesh mode's tilted targets: a triangle pair's row keeps its triangles apart by the
    /// row target times the cosine between its nearest direction and the nearer face's normal
    /// (at least half the target), so that a tool face resting at the target beside an object
    /// face's edge slides over it in one pass, instead of halving its way there pass after
    /// pass.
    pub mesh_tilted_targets: bool,
    /// The mesh mode's pair directions: a near-list pair a region's filter found apart keeps
    /// the gap of the box, plane or edge that showed it, along that fixed direction of the
    /// world, and the next filters drop it while the tool's translation along that direction
    /// (and its turn) leave the gap beyond their margin, or while the gap measured again on
    /// the tool triangle's own corners does, rather than posing it again: a peg going down
    /// its hole moves along the wall, not toward it.
    pub mesh_pair_directions: bool,
    /// The mesh mode's thin paths: a tool held short of a wall by its standoff room (the
    /// wall's pairs kept out of its balls) moves along a path as thin as that room, however
    /// slow the hand, rather than in balls no wider than the room, several a frame.
    pub mesh_thin_paths: bool,
    /// The mesh mode's held press: a ball's turned trust box is shared between translation
    /// and turn as the tool is predicted to move, where it reached its optimum in the last
    /// frame (the rest of the way to the hand is then a press its contacts hold, which it
    /// will not follow), rather than by the larger of that share and the way's.
    pub mesh_held_press: bool,
    /// The mesh mode's list inheritance: a new near list takes, for each pair it shares with
    /// the list it replaces, that list's lower bound on the pair's distance (less the motion
    /// bound from where it was found to the new list's span) and its nearest edges, so that
    /// its first filter does not pose again every pair the old list's filters had found apart
    /// (faces lying on each other: ~4 500 pairs a new list, apart sideways).
    pub mesh_list_inherit: bool,
    /// The mesh mode's frame fill: the next near list's slice fills the frame up to
    /// [`Tuning::near_fill_share`](crate::Tuning::near_fill_share) of the budget, or is the pace
    /// its descent needs to be done in time where that is more, rather than a full
    /// [`Tuning::near_ahead_share`](crate::Tuning::near_ahead_share) added to whatever the
    /// frame's own work took: a frame that filtered a tight fit's list does not also take a
    /// full slice while the next list is on time. Paced (the loop's wait given to the
    /// engine), the wait builds the list ahead while the list in use lasts.
    pub mesh_near_fill: bool,
    /// The mesh mode's bound answers: an answer stopped by its trust region goes on in a new
    /// region about it at once, even where rows holding it are still open in truth, rather
    /// than first re-linearising on the same pairs, whose trust region stops it where it is
    /// (a shaft turned on its hub's face, its keys' edges crossing the keyways': nine in ten
    /// such passes did not move the tool).
    pub mesh_bound_detects: bool,
    /// The mesh mode's region falls: a tool whose last pass went straight toward the goal
    /// until its trust region (not its contacts) held it, in this frame or at the end of the
    /// last, takes the straight way there as a path (the fall of a tool left behind), rather
    /// than waiting for a frame's step of [`Tuning::fall_min_step_mm`](crate::Tuning::fall_min_step_mm):
    /// balls the pair density keeps small creep where the tool falls free.
    pub mesh_region_falls: bool,
    /// The mesh mode's slow growth: a ball that held more than
    /// [`Tuning::ball_pair_target`](crate::Tuning::ball_pair_target) triangle pairs within its
    /// margin, at least 3/4 of those the near list's bounds put within a ball up to twice as
    /// wide, may be followed by one that wide, rather than be shrunk toward the target by the
    /// pair density's power law, which no smaller ball would meet: a pole's fan of triangles
    /// on another's holds ~2 000 pairs at any margin, and balls at the dense floor moved the
    /// tool 0.017 mm a pass, 1.8 mm behind the hand.
    pub mesh_slow_growth: bool,
    /// The mesh mode's near part: a near list's descent notes the part of the tool within
    /// [`Tuning::near_part_mm`](crate::Tuning::near_part_mm) beyond its reach of the objects
    /// (a box in the tool frame), and its pairs' bounds and gaps wear by that part's motion,
    /// not the whole tool's: a tilted peg straightening in a hole's mouth turns about its tip,
    /// where the wall is, on an arm of ~10 mm, its whole 40 mm on one of ~41. The list serves
    /// while the near part moves less than its reach beyond a region's margin, and the rest of
    /// the tool less than that and the near part's margin. Noted again only where the last
    /// near part lengthened its list's use ([`Tuning::near_part_pays`](crate::Tuning::near_part_pays)).
    pub mesh_near_part: bool,
    /// The mesh mode's near part given up part-way: a near list's descent stops noting its
    /// near part once that reaches from the tool origin
    /// [`Tuning::near_part_pays`](crate::Tuning::near_part_pays) of the whole tool's reach,
    /// less by the share of the descent's box tests the noting has taken (its break-even: a
    /// list serves about inversely to its near part's arm), and the next lists are listed
    /// without one, as after a near part that did not pay. The bunny turning against its own
    /// mesh is near along ~0.8 of its reach, and the noting took about as many tests as the
    /// list's own descent.
    pub mesh_near_part_give_up: bool,
    /// The mesh mode's slice ceiling: the next near list's slice never takes a frame past
    /// [`Tuning::near_ceiling_share`](crate::Tuning::near_ceiling_share) of the budget while
    /// the list in use still holds the last region's margin for two more frames at the last
    /// frame's pace; only a list in use about to be spent takes its slice whatever the frame
    /// took. A tight fit's lists are taken late (its regions are narrower than the one a list
    /// was listed for, so a list serves past its extra reach), and the next one then starts
    /// with its pace asking for a full slice in frames already heavy with a filter.
    pub mesh_slice_ceiling: bool,
    /// The mesh mode's fill level follows the frames' own work: the next near list's slice
    /// fills a frame up to a running quantile of the frames' own work
    /// ([`Tuning::own_above_share`](crate::Tuning::own_above_share)), at most
    /// [`Tuning::near_fill_share`](crate::Tuning::near_fill_share) of the budget, or gives the
    /// pace its descent needs where that is more, rather than filling every frame to the fixed
    /// share: a scene whose frames take 20 µs is not lifted to 200 by the lists ahead.
    pub mesh_fill_own_level: bool,
    /// The mesh mode's list ahead taken in the loop's wait: in a paced loop
    /// ([`Engine::idle`](crate::Engine::idle)), the next near list, once built, replaces
    /// the one in use there as soon as it holds the regions at least as long (by its reach past
    /// their margin, at the tool's pace), rather than in the frame whose region the old one no
    /// longer holds. Taking a list inherits what the old one knew of its pairs: ~55 µs for a
    /// tight fit's 5 500 pairs, paid by every frame that took one (`spline-tight`'s heaviest).
    pub mesh_idle_take: bool,
}

impl Default for Heuristics {
    fn default() -> Self {
        Self::ALL
    }
}

impl Heuristics {
    /// Every heuristic on: the shipped step.
    pub const ALL: Self = Self {
        region_reuse: true,
        path_regions: true,
        slab_regions: true,
        density_sizing: true,
        free_space_proofs: true,
        background_probes: true,
        neighbour_lists: true,
        lever: true,
        recentre: true,
        turned_trust: true,
        warm_start: true,
        mesh_near_list: true,
        mesh_far_rows: true,
        mesh_flat_faces: true,
        mesh_face_splits: true,
        mesh_tilted_targets: true,
        mesh_pair_directions: true,
        mesh_thin_paths: true,
        mesh_held_press: true,
        mesh_list_inherit: true,
        mesh_near_fill: true,
        mesh_bound_detects: true,
        mesh_region_falls: true,
        mesh_slow_growth: true,
        mesh_near_part: true,
        mesh_near_part_give_up: true,
        mesh_slice_ceiling: true,
        mesh_fill_own_level: true,
        mesh_idle_take: true,
    };

    /// Every heuristic off.
    pub const NONE: Self = Self {
        region_reuse: false,
        path_regions: false,
        slab_regions: false,
        density_sizing: false,
        free_space_proofs: false,
        background_probes: false,
        neighbour_lists: false,
        lever: false,
        recentre: false,
        turned_trust: false,
        warm_start: false,
        mesh_near_list: false,
        mesh_far_rows: false,
        mesh_flat_faces: false,
        mesh_face_splits: false,
        mesh_tilted_targets: false,
        mesh_pair_directions: false,
        mesh_thin_paths: false,
        mesh_held_press: false,
        mesh_list_inherit: false,
        mesh_near_fill: false,
        mesh_bound_detects: false,
        mesh_region_falls: false,
        mesh_slow_growth: false,
        mesh_near_part: false,
        mesh_near_part_give_up: false,
        mesh_slice_ceiling: false,
        mesh_fill_own_level: false,
        mesh_idle_take: false,
    };

    /// The names of the switches (as the bench's ablation study prints them), in order.
    pub const NAMES: [&'static str; 29] = [
        "region-reuse",
        "path-regions",
        "slab-regions",
        "density-sizing",
        "free-space-proofs",
        "background-probes",
        "neighbour-lists",
        "lever",
        "recentre",
        "turned-trust",
        "warm-start",
        "mesh-near-list",
        "mesh-far-rows",
        "mesh-flat-faces",
        "mesh-face-splits",
        "mesh-tilted-targets",
        "mesh-pair-directions",
        "mesh-thin-paths",
        "mesh-held-press",
        "mesh-list-inherit",
        "mesh-near-fill",
        "mesh-bound-detects",
        "mesh-region-falls",
        "mesh-slow-growth",
        "mesh-near-part",
        "mesh-near-part-give-up",
        "mesh-slice-ceiling",
        "mesh-fill-own-level",
        "mesh-idle-take",
    ];

    /// The switch called `name` ([`Heuristics::NAMES`]), for reading and setting.
    pub fn switch_mut(&mut self, name: &str) -> Option<&mut bool> {
        Some(match name {
            "region-reuse" => &mut self.region_reuse,
            "path-regions" => &mut self.path_regions,
            "slab-regions" => &mut self.slab_regions,
            "density-sizing" => &mut self.density_sizing,
            "free-space-proofs" => &mut self.free_space_proofs,
            "background-probes" => &mut self.background_probes,
            "neighbour-lists" => &mut self.neighbour_lists,
            "lever" => &mut self.lever,
            "recentre" => &mut self.recentre,
            "turned-trust" => &mut self.turned_trust,
            "warm-start" => &mut self.warm_start,
            "mesh-near-list" => &mut self.mesh_near_list,
            "mesh-far-rows" => &mut self.mesh_far_rows,
            "mesh-flat-faces" => &mut self.mesh_flat_faces,
            "mesh-face-splits" => &mut self.mesh_face_splits,
            "mesh-tilted-targets" => &mut self.mesh_tilted_targets,
            "mesh-pair-directions" => &mut self.mesh_pair_directions,
            "mesh-thin-paths" => &mut self.mesh_thin_paths,
            "mesh-held-press" => &mut self.mesh_held_press,
            "mesh-list-inherit" => &mut self.mesh_list_inherit,
            "mesh-near-fill" => &mut self.mesh_near_fill,
            "mesh-bound-detects" => &mut self.mesh_bound_detects,
            "mesh-region-falls" => &mut self.mesh_region_falls,
            "mesh-slow-growth" => &mut self.mesh_slow_growth,
            "mesh-near-part" => &mut self.mesh_near_part,
            "mesh-near-part-give-up" => &mut self.mesh_near_part_give_up,
            "mesh-slice-ceiling" => &mut self.mesh_slice_ceiling,
            "mesh-fill-own-level" => &mut self.mesh_fill_own_level,
            "mesh-idle-take" => &mut self.mesh_idle_take,
            _ => return None,
        })
    }

    /// Every heuristic on but `name` ([`Heuristics::NAMES`]); `None` for an unknown name.
    pub fn without(name: &str) -> Option<Self> {
        let mut h = Self::ALL;
        *h.switch_mut(name)? = false;
        Some(h)
    }

    /// True for a switch of the mesh geometry mode only (no effect on the leaf spheres).
    pub fn mesh_only(name: &str) -> bool {
        name.starts_with("mesh-")
    }

    /// Background probes run: they and the free-space proofs they make are both on.
    pub(crate) fn probes(&self) -> bool {
        self.free_space_proofs && self.background_probes
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_name_turns_exactly_its_own_switch_off() {
        for name in Heuristics::NAMES {
            let h = Heuristics::without(name).unwrap();
            let off = Heuristics::NAMES
                .iter()
                .filter(|n| !*h.clone().switch_mut(n).unwrap())
                .collect::<Vec<_>>();
            assert_eq!(off, [&name], "{name}");
        }
        assert!(Heuristics::without("no-such").is_none());
        let mut none = Heuristics::ALL;
        for name in Heuristics::NAMES {
            *none.switch_mut(name).unwrap() = false;
        }
        assert_eq!(none, Heuristics::NONE);
    }
}
