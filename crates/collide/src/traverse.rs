//! Simultaneous descent of a posed tool tree and static object trees: every overlapping leaf
//! pair, allocation-free per query.

use nalgebra::Vector3;

use crate::packed::Sphere32;
use crate::{CollideError, PackedTree, Pose};

/// One leaf pair found by the traversal, with the geometry the constraints need.
///
/// The pair is reported when `gap <= margin`, `gap = |c - o| - (r_tool + r_object)` measured at
/// the query pose (`c` = the tool sphere's centre in the world), or, for an object leaf with a
/// face cut that stands for the pair ([`LeafPair::on_face`]), the tool sphere's height above
/// the face.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeafPair {
    /// Index of the object tree in the slice given to the query (0 for [`overlap_tree_tree`]).
    pub object: u32,
    /// Slot of the tool leaf in the tool's [`spheretree::SphereTree`].
    pub tool_slot: u32,
    /// Slot of the object leaf in the object's [`spheretree::SphereTree`].
    pub object_slot: u32,
    /// Centre of the tool leaf sphere in the tool frame (mm): `p_in_tool`.
    pub p_in_tool: [f64; 3],
    /// Radius of the tool leaf sphere (mm).
    pub r_tool: f64,
    /// Centre of the object leaf sphere in the world (mm), the object's fixed pose applied.
    pub o_in_world: [f64; 3],
    /// Radius of the object leaf sphere (mm).
    pub r_object: f64,
    /// The gap at the query pose (mm; negative = penetration depth): on the face
    /// (`on_face`), `normal . c - offset - r_tool`, else `|c - o| - (r_tool + r_object)`.
    pub gap: f64,
    /// The face cut of the pair, if any (docs/DESIGN.md §Face caps): the object node lies below
    /// `normal . x <= offset`. With [`LeafPair::on_face`] the pair stands for the face's
    /// half-space; without, for the *lens* `B ∩ H` (the object sphere cut by the plane).
    pub face: Option<FacePlane>,
    /// True when the pair stands for `face`'s half-space: the tool centre was on the outer side
    /// of the cut's plane, its foot in the cut's disc (on the face). Every stand-in (sphere,
    /// lens, half-space) contains the object node's part of the surface, so each gives a safe
    /// constraint; the half-space and the lens are exact above the face (no sphere bump).
    pub on_face: bool,
}

/// What a leaf pair stands for on the object's side ([`LeafPair::stand_in`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StandIn {
    /// The object sphere.
    Sphere,
    /// The face's half-space (the tool above the face).
    HalfSpace(FacePlane),
    /// The object sphere cut by the face's plane (`B ∩ H`, convex).
    Lens(FacePlane),
}

impl LeafPair {
    /// True when the pair stands for its face's half-space ([`LeafPair::on_face`] with a cut).
    #[inline]
    pub fn stands_for_face(&self) -> bool {
        self.on_face && self.face.is_some()
    }

    /// What the pair stands for.
    #[inline]
    pub fn stand_in(&self) -> StandIn {
        match (self.on_face, self.face) {
            (true, Some(f)) => StandIn::HalfSpace(f),
            (false, Some(f)) => StandIn::Lens(f),
            _ => StandIn::Sphere,
        }
    }

    /// The pair's gap (mm) with the tool at `pose`: the tool sphere against what the pair
    /// stands for (the face's half-space, the lens or the object sphere).
    #[inline]
    pub fn gap_at(&self, pose: &Pose) -> f64 {
        self.contact_at(pose).1
    }

    /// With the tool at `pose`: the point of the tool sphere nearest what the pair stands for
    /// (world, mm), the gap (mm) and the unit normal pointing from the object to the tool.
    pub fn contact_at(&self, pose: &Pose) -> ([f64; 3], f64, [f64; 3]) {
        self.contact_posed(&pose.rotation_matrix(), &pose.translation())
    }

    /// [`LeafPair::contact_at`] for the pose's rotation matrix and translation (mm), computed
    /// once for many pairs.
    #[inline]
    pub fn contact_posed(
        &self,
        rotation: &nalgebra::Matrix3<f64>,
        translation: &Vector3<f64>,
    ) -> ([f64; 3], f64, [f64; 3]) {
        let c = rotation * Vector3::from(self.p_in_tool) + translation;
        let sphere = || {
            let u = c - Vector3::from(self.o_in_world);
            let d = u.norm();
            let n = if d > 0.0 { u / d } else { Vector3::z() };
            (d - (self.r_tool + self.r_object), n)
        };
        let (gap, n) = match self.stand_in() {
            StandIn::HalfSpace(f) => {
                let n = Vector3::from(f.normal);
                (n.dot(&c) - f.offset - self.r_tool, n)
            }
            StandIn::Lens(f) => match f.lens_distance(self.o_in_world, self.r_object, c.into()) {
                Some((d, n)) => (d - self.r_tool, Vector3::from(n)),
                None => sphere(),
            },
            StandIn::Sphere => sphere(),
        };
        ((c - n * self.r_tool).into(), gap, n.into())
    }
}

/// The plane of a face a pair stands for (world): unit outward `normal`, `offset` (mm); the
/// object is below `normal . x = offset`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FacePlane {
    /// Unit outward normal.
    pub normal: [f64; 3],
    /// The plane's offset `normal . x` (mm).
    pub offset: f64,
}

impl FacePlane {
    /// True when `other` is this plane to 1e-9 (normal components and offset, mm): one face
    /// met through different nodes, whose caps differ in rounding.
    #[inline(always)]
    pub fn coincides(&self, other: &FacePlane) -> bool {
        (self.offset - other.offset).abs() <= 1e-9
            && (0..3).all(|k| (self.normal[k] - other.normal[k]).abs() <= 1e-9)
    }

    /// Signed distance (mm) from the world point `w` to the lens `B(o, r) ∩ H` (the ball cut by
    /// this plane), with the unit direction from the lens's nearest point to `w` (the
    /// distance's gradient; inside, the normal of the nearer boundary). `None` when the plane
    /// misses the ball's interior (`|n . o - offset| >= r`): the lens is then the ball or
    /// empty.
    ///
    /// Outside, the nearest point is one of: the ball's radial projection (if below the
    /// plane), the plane's foot (if in the ball), or the rim circle; each lies in the lens and
    /// the true projection is among them, so the least of their distances is exact.
    #[inline]
    pub fn lens_distance(&self, o: [f64; 3], r: f64, w: [f64; 3]) -> Option<(f64, [f64; 3])> {
        let n = Vector3::from(self.normal);
        let (o, w) = (Vector3::from(o), Vector3::from(w));
        let h_o = n.dot(&o) - self.offset;
        // (NaN fails too.)
        if h_o.abs() >= r || h_o.is_nan() {
            return None;
        }
        let h = n.dot(&w) - self.offset;
        let q = w - o;
        let dq = q.norm();
        let radial = if dq > 0.0 { q / dq } else { n };
        let sd_ball = dq - r;
        if h <= 0.0 && sd_ball <= 0.0 {
            // Inside both: the nearer boundary (the intersection's signed distance).
            return Some(if h >= sd_ball {
                (h, self.normal)
            } else {
                (sd_ball, radial.into())
            });
        }
        // The rim circle: centre on the plane under `o`, radius `rho`.
        let rho = (r * r - h_o * h_o).max(0.0).sqrt();
        let u = q - n * (h - h_o); // w's offset from the rim's centre, along the plane
        let l = u.norm();
        let along = if l > 0.0 {
            u / l
        } else {
            radial - n * n.dot(&radial)
        };
        let to_rim = u - along * rho + n * h; // w minus its nearest rim point
        let mut best = (to_rim.norm(), to_rim);
        if h > 0.0 && l <= rho {
            // The foot lies on the flat disc.
            best = (h, n * h);
        }
        if sd_ball > 0.0 && n.dot(&(o + radial * r)) - self.offset <= 0.0 && sd_ball < best.0 {
            best = (sd_ball, radial * sd_ball);
        }
        let (d, v) = best;
        let dir = if d > 0.0 { v / d } else { n };
        Some((d, dir.into()))
    }
}

/// A node's face cut in the frame its tree is packed in (world for objects): the half-space
/// `normal . x <= offset` holds all of the mesh's surface inside the node's sphere, and the disc
/// of radius `reach` about `center` on the plane lies on the face ([`spheretree::FaceCap`] with
/// the object's pose applied).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaceCut {
    /// Unit outward normal of the face.
    pub normal: [f64; 3],
    /// The plane's offset `normal . x` (mm).
    pub offset: f64,
    /// Centre of the disc on the face (mm).
    pub center: [f64; 3],
    /// Radius of the disc (mm).
    pub reach: f64,
}

impl FaceCut {
    /// The cut's plane.
    #[inline(always)]
    pub fn plane(&self) -> FacePlane {
        FacePlane {
            normal: self.normal,
            offset: self.offset,
        }
    }

    /// Height (mm) of the world point `w` above the plane, and the squared distance (mm²) of its
    /// foot from the disc's centre.
    #[inline(always)]
    pub(crate) fn place(&self, w: [f64; 3]) -> (f64, f64) {
        let n = self.normal;
        let x = [
            w[0] - self.center[0],
            w[1] - self.center[1],
            w[2] - self.center[2],
        ];
        let along = n[0] * x[0] + n[1] * x[1] + n[2] * x[2];
        let height = n[0] * w[0] + n[1] * w[1] + n[2] * w[2] - self.offset;
        (
            height,
            x[0] * x[0] + x[1] * x[1] + x[2] * x[2] - along * along,
        )
    }

    /// The face's gap for a tool sphere at world centre `w` (radius `r_tool`, mm), when the
    /// pair stands for the half-space: `w` is on the outer side of the plane and its foot lies
    /// in the disc. `None`: not above the face.
    #[inline(always)]
    pub(crate) fn gap(&self, w: [f64; 3], r_tool: f64) -> Option<f64> {
        let (height, lateral2) = self.place(w);
        (height >= 0.0 && lateral2 <= self.reach * self.reach).then_some(height - r_tool)
    }

    /// True when a whole tool node (ball at world centre `w`, radius `r`, mm) is above the
    /// face by more than `margin` (mm) with its foot disc inside the cut's disc, `inset` (mm)
    /// from its rim: every tool leaf inside it stands for the face's half-space with a gap
    /// beyond the margin (and still does after sliding `inset` along the face), so no pair
    /// under the two is reported.
    #[inline(always)]
    pub(crate) fn clears(&self, w: [f64; 3], r: f64, margin: f64, inset: f64) -> bool {
        let room = self.reach - r - inset;
        if room < 0.0 {
            return false;
        }
        let (height, lateral2) = self.place(w);
        height - r > margin && lateral2 <= room * room
    }

    /// True when the foot of the world point `w` lies in the disc, `inset` (mm) from its rim.
    #[inline(always)]
    pub(crate) fn holds_foot(&self, w: [f64; 3], inset: f64) -> bool {
        let room = self.reach - inset;
        room >= 0.0 && self.place(w).1 <= room * room
    }

    /// [`FaceCut::clears`] for a tool node's leaf box (tighter than its ball on flat parts):
    /// the box's lowest point, over the sweep if any, above the face by more than `margin`
    /// (mm), and every point's foot in the disc, `inset` (mm) from its rim. The box holds every leaf sphere under the
    /// node, so each of them clears the face.
    #[inline(always)]
    pub(crate) fn clears_box(&self, b: &PosedBox, margin: f64, inset: f64) -> bool {
        let n = self.normal;
        let dot = |a: &[f64; 3]| n[0] * a[0] + n[1] * a[1] + n[2] * a[2];
        let depth: f64 = (0..3).map(|k| dot(&b.axes[k]).abs() * b.half[k]).sum();
        let along = dot(&b.disp);
        let (height, lateral2) = self.place(b.center);
        let lowest = height - depth + along.min(0.0) - b.spread;
        if lowest <= margin {
            return false;
        }
        let d = &b.disp;
        let h = &b.half;
        let stray = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt()
            + (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
            + b.spread;
        let room = self.reach - stray - inset;
        room >= 0.0 && lateral2 <= room * room
    }
}

/// A tool node's leaf box as posed (and swept) by the workspace, for the face-cut prune: its
/// world centre, the tool axes in the world, its half-extents (mm), and in a swept query the
/// centre's displacement and the spread of displacements inside it.
pub(crate) struct PosedBox {
    center: [f64; 3],
    axes: [[f64; 3]; 3],
    half: [f64; 3],
    disp: [f64; 3],
    spread: f64,
}

#[inline(always)]
fn posed_box<const SWEPT: bool>(ws: &CollideWorkspace, tool: &PackedTree, n: usize) -> PosedBox {
    let (ct, half) = (tool.box_center[n], tool.box_half[n]);
    let r = &ws.rot;
    let center: [f64; 3] =
        std::array::from_fn(|i| r[i][0] * ct[0] + r[i][1] * ct[1] + r[i][2] * ct[2] + ws.t[i]);
    let axes = std::array::from_fn(|k| [r[0][k], r[1][k], r[2][k]]);
    let (disp, spread) = if SWEPT {
        let (v, w) = (ws.sweep.translation, ws.sweep.rotation);
        let x = [
            center[0] - ws.t[0],
            center[1] - ws.t[1],
            center[2] - ws.t[2],
        ];
        let diag = (half[0] * half[0] + half[1] * half[1] + half[2] * half[2]).sqrt();
        (
            [
                v[0] + w[1] * x[2] - w[2] * x[1],
                v[1] + w[2] * x[0] - w[0] * x[2],
                v[2] + w[0] * x[1] - w[1] * x[0],
            ],
            ws.sweep_turn * diag,
        )
    } else {
        ([0.0; 3], 0.0)
    };
    PosedBox {
        center,
        axes,
        half,
        disp,
        spread,
    }
}

/// A slab region's margins for face pairs ([`crate::overlap_shared`]): a tool sliding along a
/// face moves its spheres far along it and little across it, and the gap of a sphere to a
/// face's half-space changes only with the motion across. So a half-space pair of a face with
/// this normal is kept within `margin` (plus `tangent` per unit of normal difference, for
/// faces turned from it) instead of the query's whole margin, which then covers the slide.
/// Only where no other plane can stand for the pair after a slide of up to `tangent`: a leaf
/// whose cuts are one plane, an inner node with one plane whose disc holds the tool node's
/// foot `tangent` from its rim; every other pair keeps the query's margin.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaceSlab {
    /// Unit normal of the faces (world).
    pub normal: [f64; 3],
    /// Margin of their half-space pairs, mm (at most the query's).
    pub margin: f64,
    /// Largest slide along the face the region allows, mm.
    pub tangent: f64,
}

impl FaceSlab {
    /// The margin (mm, at most `m`) of a half-space pair of a face with unit normal `n`: a
    /// slide by `tangent` moves a point across that face by at most `tangent · |n - normal|`
    /// more than across this one.
    #[inline(always)]
    pub fn margin_for(&self, n: &[f64; 3], m: f64) -> f64 {
        let d = [
            n[0] - self.normal[0],
            n[1] - self.normal[1],
            n[2] - self.normal[2],
        ];
        let diff = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        (self.margin + self.tangent * diff).min(m)
    }

    /// True when a pair of a tool sphere at `w` (radius `r_tool`) and a node with `cuts` is
    /// beyond the slab's margin for good: some cut holds the tool above its face by more than
    /// [`FaceSlab::margin_for`] its normal, and still stands for the pair after any allowed
    /// slide (the stand-in is then that half-space or a tighter one: never nearer). Where the
    /// cuts are one plane that holds anywhere (past the disc the pair stands for the lens or
    /// sphere inside the plane's half-space); else the foot must stay in the disc, `tangent`
    /// from its rim (another plane's half-space could stand for it past the rim).
    #[inline(always)]
    pub(crate) fn lets_go(
        slab: Option<&FaceSlab>,
        cuts: &[FaceCut],
        w: [f64; 3],
        r_tool: f64,
        m: f64,
    ) -> bool {
        let Some(s) = slab else {
            return false;
        };
        let inset = if one_plane(cuts) { 0.0 } else { s.tangent };
        cuts.iter().any(|c| {
            c.holds_foot(w, inset)
                && c.gap(w, r_tool)
                    .is_some_and(|g| g > s.margin_for(&c.normal, m))
        })
    }
}

/// True when every cut lies in the first one's plane, to 1e-9 (an ancestor's cut repeats it
/// with another disc; caps fitted on different nodes of one face differ in rounding).
#[inline(always)]
fn one_plane(cuts: &[FaceCut]) -> bool {
    cuts.first()
        .is_none_or(|first| cuts.iter().all(|c| c.plane().coincides(&first.plane())))
}

/// The face that stands for a tool sphere at `w` (radius `r_tool`, mm) against a node with
/// `cuts`: of those it is above, the one it is highest above (the node lies below all of
/// them, so the largest gap is the tightest safe one), with that gap.
#[inline(always)]
pub(crate) fn face_gap(cuts: &[FaceCut], w: [f64; 3], r_tool: f64) -> Option<(f64, &FaceCut)> {
    let mut best: Option<(f64, &FaceCut)> = None;
    for cut in cuts {
        if let Some(g) = cut.gap(w, r_tool) {
            if best.is_none_or(|(b, _)| g > b) {
                best = Some((g, cut));
            }
        }
    }
    best
}

/// What a leaf pair stands for, decided at the query pose for a tool sphere at world centre
/// `w` (radius `r_tool`) and an object leaf `B(o, r_object)` with `cuts`, `d2 = |w - o|^2`
/// (mm): its gap, its cut's plane and whether it stands for the half-space.
///
/// Above a cut's disc the face's half-space (the highest such cut, [`face_gap`]); else, of the
/// cuts whose plane crosses the ball, the lens `B ∩ H` farthest from the tool (every lens holds
/// the node's surface, so the farthest is the tightest safe one; its gap is at least the
/// sphere's); else the sphere. A lens depends only on the pose, not on where a region was
/// detected: a pose proven free against a face's half-space is free against the lenses of the
/// face's nodes too, so a later region never finds the accepted pose inside a bump.
#[inline(always)]
pub(crate) fn leaf_stand_in(
    cuts: &[FaceCut],
    o: [f64; 3],
    r_object: f64,
    w: [f64; 3],
    r_tool: f64,
    d2: f64,
) -> (f64, Option<FacePlane>, bool) {
    if cuts.is_empty() {
        return (d2.sqrt() - (r_tool + r_object), None, false);
    }
    if let Some((g, cut)) = face_gap(cuts, w, r_tool) {
        return (g, Some(cut.plane()), true);
    }
    let mut best: Option<(f64, FacePlane)> = None;
    for (k, cut) in cuts.iter().enumerate() {
        let plane = cut.plane();
        // Ancestors' cuts repeat a plane with other discs: one lens per plane.
        if cuts[..k]
            .iter()
            .any(|c| c.normal == cut.normal && c.offset == cut.offset)
        {
            continue;
        }
        if let Some((d, _)) = plane.lens_distance(o, r_object, w) {
            if best.is_none_or(|(b, _)| d > b) {
                best = Some((d, plane));
            }
        }
    }
    match best {
        Some((d, plane)) => (d - r_tool, Some(plane), false),
        None => (d2.sqrt() - (r_tool + r_object), None, false),
    }
}

/// Caller-owned scratch memory for the traversal: the descent stack and a cache of posed tool
/// centres (transformed lazily, a node's children all at once when it is first split).
///
/// Grow-only: a query grows it only when given a tree larger than any seen before (create it
/// with [`CollideWorkspace::for_trees`] to never allocate in the haptic frame).
#[derive(Clone, Debug, Default)]
pub struct CollideWorkspace {
    pub(crate) stack: Vec<(u32, u32)>,
    /// The node pairs a shared traversal sets aside as its second half
    /// ([`crate::overlap_shared`]).
    pub(crate) second: Vec<(u32, u32)>,
    /// Tool centres in the world (mm), valid for a node when its parent's stamp is current.
    wx: Vec<f64>,
    wy: Vec<f64>,
    wz: Vec<f64>,
    /// Each posed tool node's pruning sphere in `f32` (mm, world): its sphere at the pose, or
    /// in a swept query the sphere around its whole sweep (path midpoint, radius grown by half
    /// the path and the spread of displacements).
    test32: Vec<Sphere32>,
    /// Report every leaf pair the sphere test passes, also those of a cut leaf whose face is
    /// beyond the margin (a neighbour list keeps them: the tool may leave the face's reach
    /// before the list's next query, and then the sphere stands for the pair).
    pub(crate) keep_sphere_pairs: bool,
    /// The slab margins of the current query at a pose ([`FaceSlab`]; none in other queries).
    pub(crate) slab: Option<FaceSlab>,
    /// `children_posed[n] == epoch` when `n`'s children are posed for the current query.
    children_posed: Vec<u32>,
    epoch: u32,
    rot: [[f64; 3]; 3],
    /// `|R|` element-wise, for box projections.
    abs_rot: [[f64; 3]; 3],
    t: [f64; 3],
    /// Leaf box of each posed tool node, as the box tests use it (mm, `f32`; its rounding is
    /// covered by the tests' allowance): centre in the world, half-extents along the world axes (`|R| e`) and along
    /// the tool's axes (`e`), each grown to hold the box's sweep in a swept query.
    box32: Vec<ToolBox32>,
    /// `R` and `|R|` in `f32`, for the box tests.
    rot32: [[f32; 3]; 3],
    abs_rot32: [[f32; 3]; 3],
    /// Swept queries: each posed tool centre's displacement over the sweep (mm, world,
    /// `v + w x (c - t)`), the midpoint of its path and half the path's length (mm).
    path: Vec<Path>,
    /// The current query's sweep (zero for a query at a pose), and whether the query is swept
    /// (then `disp`, `mid` and `half_path` are kept for every posed node).
    sweep: Sweep,
    pub(crate) swept: bool,
    /// `|w|` of the sweep (rad): a node sphere of radius `r` moves within `|w| r` of its
    /// centre's displacement.
    sweep_turn: f64,
    pub(crate) stats: TraversalStats,
}

/// A straight motion of the tool away from the query pose, for [`overlap_swept`]: the poses
/// `Q(s) = (t + s v, exp(s [w]x) R)` for `s` in `[0, 1]`, the rotation about the tool origin.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Sweep {
    /// Translation `v` of the tool origin over the whole motion, world axes (mm).
    pub translation: [f64; 3],
    /// Rotation vector `w` of the whole motion about the tool origin, world axes (rad).
    pub rotation: [f64; 3],
}

impl Sweep {
    /// Length of the rotation (rad).
    pub fn angle(&self) -> f64 {
        let w = &self.rotation;
        (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt()
    }

    /// True when every number is finite.
    pub fn is_finite(&self) -> bool {
        self.translation
            .iter()
            .chain(self.rotation.iter())
            .all(|v| v.is_finite())
    }
}

/// Work done by the last query (counters, for benches and frame logs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TraversalStats {
    /// Node pairs taken off the descent stack and split.
    pub node_pairs_split: usize,
    /// Sphere–sphere overlap tests run (root tests included).
    pub sphere_tests: usize,
    /// Tool nodes whose world centre was computed.
    pub tool_nodes_posed: usize,
    /// Node pairs whose spheres overlap but whose leaf boxes do not (pruned without a split).
    pub box_pruned: usize,
    /// Node pairs settled by a face cut without a split: a tool node clear above the face, or
    /// a tool leaf above a cut inner node (one pair for its subtree, or none).
    pub face_pruned: usize,
}

impl CollideWorkspace {
    /// An empty workspace; the first query sizes it (allocates).
    pub fn new() -> Self {
        Self::default()
    }

    /// A workspace sized for `tool` against every tree in `objects`: queries on these trees
    /// never allocate.
    pub fn for_trees(tool: &PackedTree, objects: &[PackedTree]) -> Self {
        let mut ws = Self::new();
        for o in objects {
            ws.reserve(tool, o);
        }
        if objects.is_empty() {
            ws.reserve(tool, tool);
        }
        ws
    }

    /// True when the workspace holds `tool`'s posed nodes without growing.
    pub(crate) fn sized_for(&self, tool: &PackedTree) -> bool {
        self.wx.len() >= tool.len()
    }

    /// Work counters of the last query.
    pub fn stats(&self) -> TraversalStats {
        self.stats
    }

    /// Bound on the stack depth of a depth-first descent that splits one node per step: each
    /// step replaces one pair by at most `B` pairs, and a path makes at most
    /// `levels_tool + levels_object` steps.
    fn stack_bound(tool: &PackedTree, object: &PackedTree) -> usize {
        let b = tool.max_children.max(object.max_children).max(1);
        (tool.levels as usize + object.levels as usize + 1) * b + 1
    }

    pub(crate) fn reserve(&mut self, tool: &PackedTree, object: &PackedTree) {
        let need = Self::stack_bound(tool, object);
        if self.stack.capacity() < need {
            self.stack.reserve(need - self.stack.len());
        }
        if self.second.capacity() < need {
            self.second.reserve(need - self.second.len());
        }
        // Resident: the first write to a page of them would be a frame's.
        crate::touch_pages(&mut self.stack);
        crate::touch_pages(&mut self.second);
        let n = tool.len();
        if self.wx.len() < n {
            self.wx.resize(n, 0.0);
            self.wy.resize(n, 0.0);
            self.wz.resize(n, 0.0);
            self.test32.resize(n, Sphere32::default());
            self.box32.resize(n, ToolBox32::default());
            self.path.resize(n, Path::default());
            self.children_posed.resize(n, 0);
        }
    }

    /// Starts a query: sets the pose, invalidates the cache, poses the root.
    fn begin(&mut self, tool: &PackedTree, world_from_tool: &Pose) {
        self.start(tool, world_from_tool, None);
    }

    /// [`CollideWorkspace::begin`] for a swept query: posing a node also gives its centre's
    /// displacement over `sweep`.
    fn begin_swept(&mut self, tool: &PackedTree, world_from_tool: &Pose, sweep: &Sweep) {
        self.start(tool, world_from_tool, Some(sweep));
    }

    pub(crate) fn start(
        &mut self,
        tool: &PackedTree,
        world_from_tool: &Pose,
        sweep: Option<&Sweep>,
    ) {
        self.swept = sweep.is_some();
        self.slab = None;
        self.sweep = sweep.copied().unwrap_or_default();
        self.sweep_turn = self.sweep.angle();
        let m = world_from_tool.rotation_matrix();
        for i in 0..3 {
            for j in 0..3 {
                self.rot[i][j] = m[(i, j)];
                self.abs_rot[i][j] = m[(i, j)].abs();
                self.rot32[i][j] = m[(i, j)] as f32;
                self.abs_rot32[i][j] = m[(i, j)].abs() as f32;
            }
        }
        self.t = [
            world_from_tool.q[0],
            world_from_tool.q[1],
            world_from_tool.q[2],
        ];
        self.epoch = self.epoch.wrapping_add(1);
        if self.epoch == 0 {
            // Wrapped: clear every stamp so none is mistaken for current.
            self.children_posed.iter_mut().for_each(|s| *s = 0);
            self.epoch = 1;
        }
        self.pose_range(tool, 0, 1);
        self.stats = TraversalStats {
            tool_nodes_posed: 1,
            ..TraversalStats::default()
        };
    }

    #[inline(always)]
    pub(crate) fn pose_range(&mut self, tool: &PackedTree, first: usize, end: usize) {
        let r = self.rot;
        let t = self.t;
        let (px, py, pz) = (
            &tool.x[first..end],
            &tool.y[first..end],
            &tool.z[first..end],
        );
        let wx = &mut self.wx[first..end];
        let wy = &mut self.wy[first..end];
        let wz = &mut self.wz[first..end];
        for i in 0..px.len() {
            let (x, y, z) = (px[i], py[i], pz[i]);
            wx[i] = r[0][0] * x + r[0][1] * y + r[0][2] * z + t[0];
            wy[i] = r[1][0] * x + r[1][1] * y + r[1][2] * z + t[1];
            wz[i] = r[2][0] * x + r[2][1] * y + r[2][2] * z + t[2];
        }
        let a = self.abs_rot;
        let (v, w) = (self.sweep.translation, self.sweep.rotation);
        // Displacement along the sweep's tangent of a world point `p`: v + w x (p - t).
        let displacement = |p: [f64; 3]| {
            let (x, y, z) = (p[0] - t[0], p[1] - t[1], p[2] - t[2]);
            [
                v[0] + w[1] * z - w[2] * y,
                v[1] + w[2] * x - w[0] * z,
                v[2] + w[0] * y - w[1] * x,
            ]
        };
        for i in first..end {
            let (ct, et) = (&tool.box_center[i], &tool.box_half[i]);
            let mut c = [0.0; 3];
            let mut world_half = [0.0; 3];
            for k in 0..3 {
                c[k] = r[k][0] * ct[0] + r[k][1] * ct[1] + r[k][2] * ct[2] + t[k];
                world_half[k] = a[k][0] * et[0] + a[k][1] * et[1] + a[k][2] * et[2];
            }
            let mut tool_half = *et;
            if self.swept {
                // The box swept along its centre's displacement D: centred halfway, grown by
                // |D| / 2 per axis and by |w| times its half diagonal (the spread of
                // displacements inside it).
                let d = displacement(c);
                let spread =
                    self.sweep_turn * (et[0] * et[0] + et[1] * et[1] + et[2] * et[2]).sqrt();
                for k in 0..3 {
                    c[k] += 0.5 * d[k];
                    world_half[k] += 0.5 * d[k].abs() + spread;
                    let along_tool_axis = r[0][k] * d[0] + r[1][k] * d[1] + r[2][k] * d[2];
                    tool_half[k] += 0.5 * along_tool_axis.abs() + spread;
                }
                let centre = [self.wx[i], self.wy[i], self.wz[i]];
                let d = displacement(centre);
                let path = Path {
                    disp: d,
                    mid: std::array::from_fn(|k| centre[k] + 0.5 * d[k]),
                    half: 0.5 * (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt(),
                };
                self.path[i] = path;
                self.test32[i] = Sphere32 {
                    c: path.mid.map(|v| v as f32),
                    r: (tool.r[i] * (1.0 + self.sweep_turn) + path.half) as f32,
                };
            } else {
                self.test32[i] = Sphere32 {
                    c: [self.wx[i] as f32, self.wy[i] as f32, self.wz[i] as f32],
                    r: tool.sphere32[i].r,
                };
            }
            self.box32[i] = ToolBox32 {
                c: c.map(|v| v as f32),
                world_half: world_half.map(|v| v as f32),
                tool_half: tool_half.map(|v| v as f32),
            };
        }
    }

    #[inline(always)]
    fn pose_children(&mut self, tool: &PackedTree, n: usize) {
        if self.children_posed[n] != self.epoch {
            self.children_posed[n] = self.epoch;
            let f = tool.first_child[n] as usize;
            let e = f + tool.child_count[n] as usize;
            self.pose_range(tool, f, e);
            self.stats.tool_nodes_posed += e - f;
        }
    }
}

/// Every leaf pair of `tool` (posed by `world_from_tool`, mm/rad) and `object` (packed in the
/// world) whose gap is at most `margin` (mm): overlapping pairs for `margin = 0`, plus pairs
/// that come within `margin` of touching (anti-tunnelling: take `margin` at least the largest
/// displacement of any tool point between `q_g_prev` and `q_h`). Calls `visit` once per pair
/// (order unspecified); returns the number of pairs.
///
/// A negative or NaN `margin` is taken as 0. Errors only on a non-finite pose.
///
/// # Real-time
/// Allocation-free when `ws` was made by [`CollideWorkspace::for_trees`] for these trees (else
/// the first query sizes it). No panics. Bounded: visits each node pair at most once.
pub fn overlap_tree_tree<F: FnMut(&LeafPair)>(
    tool: &PackedTree,
    world_from_tool: &Pose,
    object: &PackedTree,
    margin: f64,
    ws: &mut CollideWorkspace,
    mut visit: F,
) -> Result<usize, CollideError> {
    if !world_from_tool.is_finite() {
        return Err(CollideError::NonFinitePose);
    }
    ws.reserve(tool, object);
    ws.begin(tool, world_from_tool);
    Ok(descend(
        tool,
        object,
        0,
        clean_margin(margin),
        ws,
        &mut |p: &LeafPair| {
            visit(p);
            true
        },
    ))
}

/// [`overlap_tree_tree`] against several object trees (each packed with its own fixed pose);
/// [`LeafPair::object`] is the index in `objects`. The tool is posed once for all of them.
///
/// # Real-time
/// As [`overlap_tree_tree`].
pub fn overlap_tree_trees<F: FnMut(&LeafPair)>(
    tool: &PackedTree,
    world_from_tool: &Pose,
    objects: &[PackedTree],
    margin: f64,
    ws: &mut CollideWorkspace,
    mut visit: F,
) -> Result<usize, CollideError> {
    if !world_from_tool.is_finite() {
        return Err(CollideError::NonFinitePose);
    }
    for o in objects {
        ws.reserve(tool, o);
    }
    ws.begin(tool, world_from_tool);
    Ok(descend_all(
        tool,
        objects,
        clean_margin(margin),
        ws,
        &mut visit,
    ))
}

/// Descends `tool` (posed in `ws`) against every object in turn; the pair count.
fn descend_all<F: FnMut(&LeafPair)>(
    tool: &PackedTree,
    objects: &[PackedTree],
    m: f64,
    ws: &mut CollideWorkspace,
    visit: &mut F,
) -> usize {
    let mut total = 0;
    for (i, o) in objects.iter().enumerate() {
        total += descend(tool, o, i as u32, m, ws, &mut |p: &LeafPair| {
            visit(p);
            true
        });
    }
    total
}

/// Every leaf pair of `tool` and `objects` that comes within `margin` (mm) of touching at some
/// pose of the straight motion `sweep` away from `world_from_tool` (the poses
/// `Q(s) = (t + s v, exp(s [w]x) R)`, `s` in `[0, 1]`). Reported pairs carry their geometry and
/// gap at `world_from_tool`; [`LeafPair::object`] is the index in `objects`.
///
/// Each tool sphere is tested as the capsule its centre sweeps along the motion's tangent
/// `v + w x (c - t)`, its radius grown by `|w| r` (the spread of displacements inside it) and
/// the margin by `reach (e^|w| - 1 - |w|)` (how far the arc leaves its tangent: `reach |w|^2 / 2`
/// to second order, a little more for a large turn), so the answer is
/// conservative: no pair that can come within `margin` on the way is missed, and a pair far
/// from the path is not listed. For a hand sliding over a flat face this lists the pairs along
/// the path instead of every pair within the motion's length (an isotropic margin).
///
/// Errors on a non-finite pose or sweep; a negative or NaN `margin` is taken as 0.
///
/// # Real-time
/// As [`overlap_tree_tree`].
#[allow(clippy::too_many_arguments)]
pub fn overlap_swept<F: FnMut(&LeafPair)>(
    tool: &PackedTree,
    world_from_tool: &Pose,
    sweep: &Sweep,
    objects: &[PackedTree],
    margin: f64,
    ws: &mut CollideWorkspace,
    mut visit: F,
) -> Result<usize, CollideError> {
    if !world_from_tool.is_finite() || !sweep.is_finite() {
        return Err(CollideError::NonFinitePose);
    }
    for o in objects {
        ws.reserve(tool, o);
    }
    ws.begin_swept(tool, world_from_tool, sweep);
    let turn = sweep.angle();
    let m = clean_margin(margin) + arc_allowance(tool.reach(), turn);
    Ok(descend_all(tool, objects, m, ws, &mut visit))
}

/// True when some leaf pair of `tool` (posed by `world_from_tool`) and `objects` has a gap of
/// at most `margin` (mm). Stops at the first such pair, so it stays cheap for a large margin
/// where [`overlap_tree_trees`] would enumerate thousands of pairs (a fast hand far from the
/// graphic tool).
///
/// # Real-time
/// As [`overlap_tree_tree`]; usually far fewer node pairs are visited.
pub fn any_pair_within(
    tool: &PackedTree,
    world_from_tool: &Pose,
    objects: &[PackedTree],
    margin: f64,
    ws: &mut CollideWorkspace,
) -> Result<bool, CollideError> {
    if !world_from_tool.is_finite() {
        return Err(CollideError::NonFinitePose);
    }
    for o in objects {
        ws.reserve(tool, o);
    }
    ws.begin(tool, world_from_tool);
    let m = clean_margin(margin);
    for (i, o) in objects.iter().enumerate() {
        if descend(tool, o, i as u32, m, ws, &mut |_: &LeafPair| false) > 0 {
            return Ok(true);
        }
    }
    Ok(false)
}

/// Node pairs split between two calls of a deadline traversal's `keep_going`: a few µs of
/// work (a swept split of a dense contact costs up to ~1 µs), against ~25 ns per clock read.
pub(crate) const SPLITS_PER_CHECK: usize = 32;

/// How a traversal with a deadline ended ([`overlap_until`], [`any_pair_within_until`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Traversal {
    /// Leaf pairs reported (all of them when `complete`).
    pub pairs: usize,
    /// False when `keep_going` stopped it: some leaf pairs may be missing.
    pub complete: bool,
}

/// [`overlap_tree_trees`] (no `sweep`) or [`overlap_swept`] that can be stopped: `keep_going`
/// is asked every few hundred node-pair splits (a few µs of work) and a `false` ends the
/// traversal there, reported as incomplete. A haptic frame gives it its deadline, so that no
/// traversal, however dense the contact, runs past the frame's time budget.
///
/// # Real-time
/// As [`overlap_tree_tree`]; bounded by `keep_going` as well.
#[allow(clippy::too_many_arguments)]
pub fn overlap_until<F: FnMut(&LeafPair), G: FnMut() -> bool>(
    tool: &PackedTree,
    world_from_tool: &Pose,
    sweep: Option<&Sweep>,
    objects: &[PackedTree],
    margin: f64,
    ws: &mut CollideWorkspace,
    mut visit: F,
    keep_going: G,
) -> Result<Traversal, CollideError> {
    if !world_from_tool.is_finite() || !sweep.is_none_or(Sweep::is_finite) {
        return Err(CollideError::NonFinitePose);
    }
    for o in objects {
        ws.reserve(tool, o);
    }
    let m = match sweep {
        None => {
            ws.begin(tool, world_from_tool);
            clean_margin(margin)
        }
        Some(sw) => {
            ws.begin_swept(tool, world_from_tool, sw);
            let turn = sw.angle();
            clean_margin(margin) + arc_allowance(tool.reach(), turn)
        }
    };
    Ok(descend_all_until(
        tool,
        objects,
        m,
        ws,
        &mut |p: &LeafPair| {
            visit(p);
            true
        },
        keep_going,
    ))
}

/// [`any_pair_within`] that can be stopped as [`overlap_until`]: `None` when `keep_going`
/// stopped it before an answer.
///
/// # Real-time
/// As [`any_pair_within`]; bounded by `keep_going` as well.
pub fn any_pair_within_until<G: FnMut() -> bool>(
    tool: &PackedTree,
    world_from_tool: &Pose,
    objects: &[PackedTree],
    margin: f64,
    ws: &mut CollideWorkspace,
    keep_going: G,
) -> Result<Option<bool>, CollideError> {
    if !world_from_tool.is_finite() {
        return Err(CollideError::NonFinitePose);
    }
    for o in objects {
        ws.reserve(tool, o);
    }
    ws.begin(tool, world_from_tool);
    let t = descend_all_until(
        tool,
        objects,
        clean_margin(margin),
        ws,
        &mut |_: &LeafPair| false,
        keep_going,
    );
    Ok(if t.pairs > 0 {
        Some(true)
    } else if t.complete {
        Some(false)
    } else {
        None
    })
}

/// Descends `tool` (posed in `ws`) against every object in slices of [`SPLITS_PER_CHECK`]
/// splits, asking `keep_going` between slices; `visit` returning false stops it (complete).
fn descend_all_until<F: FnMut(&LeafPair) -> bool, G: FnMut() -> bool>(
    tool: &PackedTree,
    objects: &[PackedTree],
    m: f64,
    ws: &mut CollideWorkspace,
    visit: &mut F,
    mut keep_going: G,
) -> Traversal {
    let mut pairs = 0;
    let stopped = std::cell::Cell::new(false);
    let mut report = |p: &LeafPair| {
        let go_on = visit(p);
        stopped.set(stopped.get() | !go_on);
        go_on
    };
    for (i, o) in objects.iter().enumerate() {
        let mut resume = false;
        loop {
            let mut budget = SPLITS_PER_CHECK;
            let d = descend_as_queried(tool, o, i as u32, m, ws, &mut report, resume, &mut budget);
            pairs += d.count;
            if stopped.get() {
                return Traversal {
                    pairs,
                    complete: true,
                };
            }
            if d.finished {
                break;
            }
            if !keep_going() {
                return Traversal {
                    pairs,
                    complete: false,
                };
            }
            resume = true;
        }
    }
    Traversal {
        pairs,
        complete: true,
    }
}

/// [`overlap_tree_trees`] collecting into `pairs` (cleared first).
///
/// # Real-time
/// As [`overlap_tree_tree`]; `pairs` grows (allocates) only past its capacity, so reserve it
/// (e.g. `Vec::with_capacity(tool_leaves * 8)`) before the haptic loop.
pub fn collect_pairs(
    tool: &PackedTree,
    world_from_tool: &Pose,
    objects: &[PackedTree],
    margin: f64,
    ws: &mut CollideWorkspace,
    pairs: &mut Vec<LeafPair>,
) -> Result<usize, CollideError> {
    pairs.clear();
    overlap_tree_trees(tool, world_from_tool, objects, margin, ws, |p| {
        pairs.push(*p)
    })
}

/// The leaf box of a posed tool node as the box tests use it (see
/// [`CollideWorkspace`]'s `box32`).
#[derive(Clone, Copy, Debug, Default)]
struct ToolBox32 {
    c: [f32; 3],
    world_half: [f32; 3],
    tool_half: [f32; 3],
}

/// False when the leaf boxes of tool node `t` (an oriented box in the world, as posed by the
/// workspace, swept in a swept query) and object node `o` (axis-aligned), the latter grown by
/// `m` (mm, including the `f32` rounding allowance), are separated along one of the six face
/// axes: no leaf pair under them can be within the margin. Conservative (the nine edge axes
/// are not tested).
#[inline(always)]
fn boxes_may_touch(ws: &CollideWorkspace, t: usize, obj: &PackedTree, o: usize, m: f32) -> bool {
    let tb = &ws.box32[t];
    let ob = &obj.node32[o];
    let (co, eo) = (&ob.box_c, &ob.box_h);
    let d = [tb.c[0] - co[0], tb.c[1] - co[1], tb.c[2] - co[2]];
    // World axes: the tool box projects to its world half-extents.
    for i in 0..3 {
        if d[i].abs() > eo[i] + m + tb.world_half[i] {
            return false;
        }
    }
    // Tool axes: the offset projects to (R^T d)_j, the object box to sum_i |R_ij| (e_i + m).
    let r = &ws.rot32;
    let a = &ws.abs_rot32;
    for j in 0..3 {
        let p = r[0][j] * d[0] + r[1][j] * d[1] + r[2][j] * d[2];
        let ro = a[0][j] * (eo[0] + m) + a[1][j] * (eo[1] + m) + a[2][j] * (eo[2] + m);
        if p.abs() > tb.tool_half[j] + ro {
            return false;
        }
    }
    true
}

/// Bit `i` set when sphere `i` of `spheres` (at most 32 of them) comes within `probe`'s
/// radius of its centre: the branch-free inner loop of a split.
#[inline(always)]
fn hit_mask(spheres: &[Sphere32], probe: Sphere32) -> u32 {
    let mut mask = 0u32;
    for (i, s) in spheres.iter().take(32).enumerate() {
        let (dx, dy, dz) = (
            s.c[0] - probe.c[0],
            s.c[1] - probe.c[1],
            s.c[2] - probe.c[2],
        );
        let d2 = dx * dx + dy * dy + dz * dz;
        let reach = s.r + probe.r;
        mask |= u32::from(d2 <= reach * reach) << i;
    }
    mask
}

/// [`hit_mask`] in a swept query whose sweep is a pure translation `v` (every tool node moves
/// by the same `v`, so each stands for a capsule): the test spheres are the nodes' spheres about
/// their paths' midpoints (radius grown by `half` = `|v| / 2`), and a hit needs the capsule —
/// the segment `mid ± v / 2` with the node's own radius — within the other sphere's reach.
/// The capsules are `spheres` in a tool split, `probe` in an object split: either way the
/// capsule's radius is the grown one less `half`, so one test serves both. Far tighter than
/// the grown spheres for long paths. The `f32` projection may land a hair off the nearest
/// point, which only lengthens the distance by `|v|² δs²` (~1e-12 mm here), far inside the
/// margin's rounding allowance.
#[inline(always)]
fn capsule_mask(spheres: &[Sphere32], probe: Sphere32, v: [f32; 3], vv: f32, half: f32) -> u32 {
    let mut mask = 0u32;
    for (i, s) in spheres.iter().take(32).enumerate() {
        let d = [
            s.c[0] - probe.c[0],
            s.c[1] - probe.c[1],
            s.c[2] - probe.c[2],
        ];
        let along = ((d[0] * v[0] + d[1] * v[1] + d[2] * v[2]) / vv).clamp(-0.5, 0.5);
        let e = [
            d[0] - along * v[0],
            d[1] - along * v[1],
            d[2] - along * v[2],
        ];
        let e2 = e[0] * e[0] + e[1] * e[1] + e[2] * e[2];
        let reach = s.r + probe.r - half;
        mask |= u32::from(e2 <= reach * reach) << i;
    }
    mask
}

/// Squared distance from the origin to the segment `x + s D`, `s` in `[0, 1]` (mm²): with `x`
/// a tool centre minus an object centre at the query pose and `D` the tool centre's
/// displacement over the sweep, the closest the two centres come on the way.
#[inline(always)]
pub(crate) fn segment_dist2(x: [f64; 3], d: [f64; 3]) -> f64 {
    let dd = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    let xd = x[0] * d[0] + x[1] * d[1] + x[2] * d[2];
    let s = if dd > 0.0 {
        (-xd / dd).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let e = [x[0] + s * d[0], x[1] + s * d[1], x[2] + s * d[2]];
    e[0] * e[0] + e[1] * e[1] + e[2] * e[2]
}

/// How far (mm) a point at most `reach` mm from the tool origin strays from its tangent
/// segment over a rotation of `turn` rad: `|exp(s W) x - (I + s W) x| <= (e^turn - 1 - turn) |x|`
/// for `s` in `[0, 1]` (the series' remainder), `reach turn^2 / 2` to second order.
#[inline]
pub(crate) fn arc_allowance(reach: f64, turn: f64) -> f64 {
    reach * (turn.exp_m1() - turn).max(0.0)
}

#[inline]
pub(crate) fn clean_margin(margin: f64) -> f64 {
    if margin > 0.0 && margin.is_finite() {
        margin
    } else {
        0.0
    }
}

/// The descent proper. Pairs on the stack overlap (within the margin) and have at least one
/// internal node; the larger internal sphere is split, its children are tested against the
/// other sphere, and leaf–leaf hits are reported at once instead of being pushed.
#[inline(never)]
fn descend<F: FnMut(&LeafPair) -> bool>(
    tool: &PackedTree,
    obj: &PackedTree,
    obj_id: u32,
    m: f64,
    ws: &mut CollideWorkspace,
    visit: &mut F,
) -> usize {
    let mut unlimited = usize::MAX;
    descend_as_queried(tool, obj, obj_id, m, ws, visit, false, &mut unlimited).count
}

/// [`descend_budgeted`], swept or not as the workspace's query was started.
#[allow(clippy::too_many_arguments)]
#[inline]
pub(crate) fn descend_as_queried<F: FnMut(&LeafPair) -> bool>(
    tool: &PackedTree,
    obj: &PackedTree,
    obj_id: u32,
    m: f64,
    ws: &mut CollideWorkspace,
    visit: &mut F,
    resume: bool,
    budget: &mut usize,
) -> Descent {
    if ws.swept {
        descend_budgeted::<true, F>(tool, obj, obj_id, m, ws, visit, resume, budget)
    } else {
        descend_budgeted::<false, F>(tool, obj, obj_id, m, ws, visit, resume, budget)
    }
}

/// How a budgeted descent ended.
pub(crate) struct Descent {
    /// Leaf pairs reported.
    pub(crate) count: usize,
    /// True when the descent is complete (or stopped by `visit`); false when the budget ran out
    /// with node pairs left on the stack (resume with `resume = true`).
    pub(crate) finished: bool,
}

/// The path of a posed tool centre over a swept query: its displacement, the path's midpoint
/// (world) and half its length (mm).
#[derive(Clone, Copy, Debug, Default)]
struct Path {
    disp: [f64; 3],
    mid: [f64; 3],
    half: f64,
}

/// True when a tool node moving along `path` comes within `s` (mm) of the point `o` (world),
/// with `x` = its centre minus `o` at the pose: first the sphere around the path's midpoint
/// (cheap, rejects most), then the exact distance to the path.
#[inline(always)]
fn swept_within(path: &Path, o: [f64; 3], x: [f64; 3], s: f64) -> bool {
    let m = &path.mid;
    let y = [m[0] - o[0], m[1] - o[1], m[2] - o[2]];
    let bound = s + path.half;
    if y[0] * y[0] + y[1] * y[1] + y[2] * y[2] > bound * bound {
        return false;
    }
    segment_dist2(x, path.disp) <= s * s
}

/// [`descend`] splitting at most `budget` node pairs (decremented), so a long descent can be
/// spread over several calls: with `resume` the stack left in `ws` by the last call is
/// continued instead of starting from the roots. With `SWEPT`, a tool node stands for its
/// sphere swept along its centre's displacement (a capsule whose radius grows by `|w| r` for
/// the spread of displacements inside it); `m` must then include the sweep's curvature
/// allowance.
#[allow(clippy::too_many_arguments)]
#[inline(never)]
pub(crate) fn descend_budgeted<const SWEPT: bool, F: FnMut(&LeafPair) -> bool>(
    tool: &PackedTree,
    obj: &PackedTree,
    obj_id: u32,
    m: f64,
    ws: &mut CollideWorkspace,
    visit: &mut F,
    resume: bool,
    budget: &mut usize,
) -> Descent {
    let mut count = 0usize;
    let done = |count: usize| Descent {
        count,
        finished: true,
    };
    if tool.is_empty() || obj.is_empty() {
        return done(0);
    }
    // A tool sphere's radius as tested: grown by the spread of displacements inside it.
    let grow = if SWEPT { 1.0 + ws.sweep_turn } else { 1.0 };
    // The margin of the f32 pruning tests, grown by their rounding allowance (posed tool
    // coordinates are at most |t| + sqrt(3) times the tool's extent, path midpoints half a
    // sweep farther).
    let t_inf = ws.t[0].abs().max(ws.t[1].abs()).max(ws.t[2].abs());
    let posed = 2.0 * tool.extent + t_inf;
    let v = ws.sweep.translation;
    let swept = if SWEPT {
        (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt() + ws.sweep_turn * posed
    } else {
        0.0
    };
    let m32 = (m + PackedTree::round_slack(posed + swept + obj.extent + m)) as f32;
    // A sweep that is a pure translation: every tool node stands for a capsule along the same
    // `v`, tested as such in `f32` (its direction, squared length, and half length rounded
    // down so the capsule's radius, the grown one less it, is never short).
    let capsule = (SWEPT && ws.sweep_turn == 0.0)
        .then(|| {
            let v = ws.sweep.translation.map(|x| x as f32);
            let vv = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
            (vv > 0.0).then(|| (v, vv, 0.5 * vv.sqrt() * (1.0 - 1e-5)))
        })
        .flatten();
    // Faces settle node pairs (prune, merge a subtree into one pair), except in a neighbour
    // list's build, which keeps every leaf pair the spheres pass.
    let use_faces = !ws.keep_sphere_pairs;
    let drop_far_faces = !SWEPT && use_faces;
    // A slab region's thin margin for half-space pairs (queries at a pose only).
    let slab = ws.slab.filter(|_| drop_far_faces);
    let slab = slab.as_ref();
    // The leaf pair (tool node `t` at world centre `w`, object node `o`, `x = w - o`,
    // `d2 = |x|^2`) if it is to be reported: a cut leaf whose face stands for it is reported
    // only when the face comes within the margin (a swept query keeps every pair its sphere
    // test passed).
    // Returns None when the pair is not reported, else what `visit` returned.
    let report = |t: usize, o: usize, w: [f64; 3], d2: f64, visit: &mut F| {
        let oc = [obj.x[o], obj.y[o], obj.z[o]];
        let cuts = obj.cuts(o);
        let (gap, face, on_face) = leaf_stand_in(cuts, oc, obj.r[o], w, tool.r[t], d2);
        if drop_far_faces
            && face.is_some()
            && (gap > m || (on_face && FaceSlab::lets_go(slab, cuts, w, tool.r[t], m)))
        {
            return None;
        }
        Some(visit(&LeafPair {
            object: obj_id,
            tool_slot: tool.slot[t],
            object_slot: obj.slot[o],
            p_in_tool: [tool.x[t], tool.y[t], tool.z[t]],
            r_tool: tool.r[t],
            o_in_world: oc,
            r_object: obj.r[o],
            gap,
            face,
            on_face,
        }))
    };
    // A tool node (moving along `path`) within `s` of the object centre `o`, `x` apart at the
    // pose (d2 = |x|²).
    let near = |path: &Path, o: [f64; 3], x: [f64; 3], d2: f64, s: f64| {
        if SWEPT {
            swept_within(path, o, x, s)
        } else {
            d2 <= s * s
        }
    };

    if !resume {
        ws.stats.sphere_tests += 1;
        let o = [obj.x[0], obj.y[0], obj.z[0]];
        let x = [ws.wx[0] - o[0], ws.wy[0] - o[1], ws.wz[0] - o[2]];
        let d2 = x[0] * x[0] + x[1] * x[1] + x[2] * x[2];
        if !near(&ws.path[0], o, x, d2, tool.r[0] * grow + obj.r[0] + m) {
            return done(0);
        }
        if tool.child_count[0] == 0 && obj.child_count[0] == 0 {
            let w = [ws.wx[0], ws.wy[0], ws.wz[0]];
            return match report(0, 0, w, d2, visit) {
                Some(_) => done(1),
                None => done(0),
            };
        }
        ws.stack.clear();
        ws.stack.push((0, 0));
    }
    loop {
        if *budget == 0 {
            return Descent {
                count,
                finished: ws.stack.is_empty(),
            };
        }
        let Some((t, o)) = ws.stack.pop() else {
            return done(count);
        };
        *budget -= 1;
        let (t, o) = (t as usize, o as usize);
        let (tn, on) = (tool.node32[t], obj.node32[o]);
        let tc = tn.child_count as usize;
        let oc = on.child_count as usize;
        ws.stats.node_pairs_split += 1;
        // Children are pruned in f32 against the other node (conservative by `m32`); a swept
        // hit is then tested against its exact path, and a leaf pair decided in f64.
        // Split the larger internal node: its children against the other node.
        // Above a cut object node, split the tool instead: its leaves then meet the node's
        // face, which stands for the node's whole subtree.
        let over_face = || {
            let cuts = obj.cuts(o);
            !cuts.is_empty() && face_gap(cuts, [ws.wx[t], ws.wy[t], ws.wz[t]], 0.0).is_some()
        };
        let tool_split = tc != 0
            && (oc == 0 || tool.sphere32[t].r >= obj.sphere32[o].r || (use_faces && over_face()));
        let (f, e, probe) = if tool_split {
            ws.pose_children(tool, t);
            let os = obj.sphere32[o];
            (tn.first_child, tn.first_child + tn.child_count, os)
        } else {
            (
                on.first_child,
                on.first_child + on.child_count,
                ws.test32[t],
            )
        };
        let (f, e) = (f as usize, e as usize);
        ws.stats.sphere_tests += e - f;
        let probe = Sphere32 {
            c: probe.c,
            r: probe.r + m32,
        };
        for base in (f..e).step_by(32) {
            let end = (base + 32).min(e);
            let mut mask = match (tool_split, capsule) {
                (true, None) => hit_mask(&ws.test32[base..end], probe),
                (false, None) => hit_mask(&obj.sphere32[base..end], probe),
                (true, Some((v, vv, half))) => {
                    capsule_mask(&ws.test32[base..end], probe, v, vv, half)
                }
                (false, Some((v, vv, half))) => {
                    capsule_mask(&obj.sphere32[base..end], probe, v, vv, half)
                }
            };
            while mask != 0 {
                let c = base + mask.trailing_zeros() as usize;
                mask &= mask - 1;
                let (ti, oi) = if tool_split { (c, o) } else { (t, c) };
                let leaf_pair = tool.node32[ti].child_count == 0 && obj.node32[oi].child_count == 0;
                // (Inner pairs of a translation sweep were tested as capsules already.)
                if (SWEPT && capsule.is_none()) || leaf_pair {
                    let oc3 = [obj.x[oi], obj.y[oi], obj.z[oi]];
                    let x = [ws.wx[ti] - oc3[0], ws.wy[ti] - oc3[1], ws.wz[ti] - oc3[2]];
                    let d2 = x[0] * x[0] + x[1] * x[1] + x[2] * x[2];
                    if !near(&ws.path[ti], oc3, x, d2, tool.r[ti] * grow + obj.r[oi] + m) {
                        continue;
                    }
                    if leaf_pair {
                        let w = [ws.wx[ti], ws.wy[ti], ws.wz[ti]];
                        if let Some(go_on) = report(ti, oi, w, d2, visit) {
                            count += 1;
                            if !go_on {
                                return done(count);
                            }
                        }
                        continue;
                    }
                }
                if use_faces {
                    let cuts = obj.cuts(oi);
                    if !cuts.is_empty() {
                        // A cut node: its faces stand for its whole subtree (every surface
                        // point under it is below each plane).
                        let oc3 = [obj.x[oi], obj.y[oi], obj.z[oi]];
                        let w = [ws.wx[ti], ws.wy[ti], ws.wz[ti]];
                        let x = [w[0] - oc3[0], w[1] - oc3[1], w[2] - oc3[2]];
                        let d2 = x[0] * x[0] + x[1] * x[1] + x[2] * x[2];
                        let r = tool.r[ti];
                        if tool.node32[ti].child_count != 0 {
                            // The tool node's ball (around its whole path in a swept query).
                            let (cw, cr) = if SWEPT {
                                (ws.path[ti].mid, r * grow + ws.path[ti].half)
                            } else {
                                (w, r)
                            };
                            // The node's posed box only where its ball does not clear.
                            let mut tool_box: Option<PosedBox> = None;
                            // (A slab's thin margin where the node's cuts are one plane.)
                            // A slab's thinner margin for a face, where its disc holds the
                            // node's foot after the slide too (leaves beneath may have other
                            // planes' caps, which could stand for them past its rim).
                            let mut clears = |c: &FaceCut, fm: f64, inset: f64| {
                                c.clears(cw, cr, fm, inset)
                                    || c.clears_box(
                                        tool_box.get_or_insert_with(|| {
                                            posed_box::<SWEPT>(ws, tool, ti)
                                        }),
                                        fm,
                                        inset,
                                    )
                            };
                            if cuts.iter().any(|c| {
                                clears(c, m, 0.0)
                                    || slab.is_some_and(|s| {
                                        clears(c, s.margin_for(&c.normal, m), s.tangent)
                                    })
                            }) {
                                ws.stats.face_pruned += 1;
                                continue;
                            }
                        } else if !leaf_pair {
                            // A tool leaf above a face (at both ends of its path in a swept
                            // query, so all along it): one pair for the subtree if the face
                            // comes within the margin, else none.
                            let closest = if SWEPT {
                                let v = ws.path[ti].disp;
                                let w1 = [w[0] + v[0], w[1] + v[1], w[2] + v[2]];
                                cuts.iter()
                                    .filter_map(|c| Some(c.gap(w, r)?.min(c.gap(w1, r)?)))
                                    .reduce(f64::max)
                            } else {
                                // Tested in f64 as a leaf pair is.
                                let s = r + obj.r[oi] + m;
                                face_gap(cuts, w, r).map(|(g, _)| {
                                    if d2 <= s * s {
                                        g
                                    } else {
                                        f64::INFINITY
                                    }
                                })
                            };
                            if let Some(closest) = closest {
                                if closest <= m && !FaceSlab::lets_go(slab, cuts, w, r, m) {
                                    if let Some(go_on) = report(ti, oi, w, d2, visit) {
                                        count += 1;
                                        if !go_on {
                                            return done(count);
                                        }
                                    }
                                }
                                ws.stats.face_pruned += 1;
                                continue;
                            }
                        }
                    }
                }
                if boxes_may_touch(ws, ti, obj, oi, m32) {
                    ws.stack.push((ti as u32, oi as u32));
                } else {
                    ws.stats.box_pruned += 1;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use spheretree::{Sphere, SphereTree};

    fn small_tree() -> SphereTree {
        let mut t = SphereTree::new_unused(3, 2).unwrap();
        let s = t.spheres_mut();
        s[0] = Sphere::new([0.0; 3], 4.0);
        s[1] = Sphere::new([-2.0, 0.0, 0.0], 2.0);
        s[2] = Sphere::new([2.0, 0.0, 0.0], 2.0);
        s[3] = Sphere::new([-3.0, 0.0, 0.0], 1.0);
        s[4] = Sphere::new([-1.0, 0.0, 0.0], 1.0);
        s[5] = Sphere::new([1.0, 0.0, 0.0], 1.0);
        s[6] = Sphere::new([3.0, 0.0, 0.0], 1.0);
        t
    }

    /// `any_pair_within` agrees with the full enumeration, including for margins that reach
    /// every leaf pair.
    #[test]
    fn any_pair_within_matches_enumeration() {
        let tree = PackedTree::new(&small_tree()).unwrap();
        let objects = std::slice::from_ref(&tree);
        let mut ws = CollideWorkspace::for_trees(&tree, objects);
        for k in 0..60 {
            let x = -12.0 + 0.4 * f64::from(k);
            let q = Pose::from_array([x, 0.3, -0.2, 0.1, 0.2, 0.05 * f64::from(k)]);
            for margin in [0.0, 0.5, 3.0, 50.0] {
                let mut n = 0;
                overlap_tree_trees(&tree, &q, objects, margin, &mut ws, |_| n += 1).unwrap();
                let any = any_pair_within(&tree, &q, objects, margin, &mut ws).unwrap();
                assert_eq!(any, n > 0, "x {x}, margin {margin}");
            }
        }
    }

    /// A probe run in slices of a few splits answers as `any_pair_within` does.
    #[test]
    fn epoch_wrap_keeps_the_cache_correct() {
        let tree = PackedTree::new(&small_tree()).unwrap();
        let a = Pose::from_array([5.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        let far = Pose::from_array([100.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        let c = Pose::from_array([-5.5, 0.5, 0.0, 0.0, 0.0, 0.3]);
        let run = |ws: &mut CollideWorkspace, q: &Pose| {
            let mut v = Vec::new();
            overlap_tree_tree(&tree, q, &tree, 0.0, ws, |p| {
                v.push((p.tool_slot, p.object_slot))
            })
            .unwrap();
            v.sort();
            v
        };
        let expected_c = run(&mut CollideWorkspace::new(), &c);
        assert!(!expected_c.is_empty());
        let mut ws = CollideWorkspace::for_trees(&tree, std::slice::from_ref(&tree));
        assert_eq!(ws.epoch, 0);
        // Epoch 1: pose `a` stamps the root's children as posed at epoch 1.
        assert!(!run(&mut ws, &a).is_empty());
        // Jump to the wrap; the query at u32::MAX touches nothing but the root.
        ws.epoch = u32::MAX - 1;
        assert!(run(&mut ws, &far).is_empty());
        // The next query runs at epoch 1 again: it must not reuse `a`'s posed centres.
        assert_eq!(run(&mut ws, &c), expected_c, "epoch {}", ws.epoch);
        assert_eq!(ws.epoch, 1);
    }
}
