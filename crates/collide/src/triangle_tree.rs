//! A bounding-box hierarchy over a body's own triangles: the mesh geometry mode's narrow phase
//! lists the triangle pairs within a margin of each other by descending two of them at once
//! (docs/DESIGN.md §Mesh-exact contact).
//!
//! Each node holds an oriented box in its body's frame, along the principal axes of its
//! triangles' corners (a patch of a curved wall gets a box as thin as the patch's bulge, where
//! an axis-aligned one would be as thick as the patch is wide across the axes). With the tool
//! placed, a tool node's box is tested against an object node's on the three axes of each box
//! (the separating axis theorem's face axes; the nine cross products of edges, which the full
//! test adds, cost more than the pairs they prune: see [`posed_boxes_apart`]). The object's box is
//! grown by the margin on every side, which holds the margin's ball around it, so no pair of
//! triangles within the margin is ever pruned. Boxes, not spheres: a long thin facet of a machined part
//! (a cylinder's side) has a sphere as wide as its length, but a box as thin as the facet.

use nalgebra::{Matrix3, Vector3};

use crate::triangle::Triangle;
use crate::Pose;

/// A descent's pose for its near part ([`TreePairStack::note`]): the inverse of the tool's
/// rotation and its absolute values, the world point at the tool origin half-way along the
/// sweep, and the half sweep's reach along the tool's axes (mm).
struct ToolFrame {
    inverse: Matrix3<f64>,
    inverse_abs: Matrix3<f64>,
    origin_in_tool: Vector3<f64>,
    sweep_half: Vector3<f64>,
}

/// A rank's flag for a node pair a descent tests for the near part alone
/// ([`TreePairStack::note_near_part`]): apart by the margin, not by the near part's.
const NOTING_ONLY: u64 = 1 << 63;

/// Half the longest side (mm) of an object box whose cut of a tool box the near part takes
/// ([`TreePairStack::cut`]); a larger one is split first: a wide flat face under a tilted tool
/// would cut its box by little.
const NEAR_PART_GRAIN_MM: f64 = 1.0;

/// Triangles per leaf at most: a leaf pair measures up to this squared many triangle pairs,
/// against one box test per node pair above it.
pub const LEAF_TRIANGLES: usize = 4;

/// One node: a box (centre and half extents, mm, along the columns of `axes`, the body's
/// frame) over `under` triangles: a leaf's own, `first..first + under` of the tree's, where
/// there are at most [`LEAF_TRIANGLES`]; else its two children's, nodes `first` and
/// `first + 1` (a median split gives the first half of them, rounded down; a split between
/// faces, [`face_split`], any share). 128 bytes: two cache lines.
#[derive(Clone, Copy, Debug, PartialEq)]
struct BoxNode {
    center: [f64; 3],
    axes: Matrix3<f64>,
    half: [f64; 3],
    first: u32,
    under: u32,
}

// Two cache lines a node: the descent reads one node pair per box test.
const _: () = assert!(std::mem::size_of::<BoxNode>() == 128);

impl BoxNode {
    /// True for a leaf (its triangles its own).
    #[inline]
    fn is_leaf(&self) -> bool {
        self.under as usize <= LEAF_TRIANGLES
    }

    /// Its box's box along the frame's axes (lowest and highest corner), mm.
    fn frame_bounds(&self) -> ([f64; 3], [f64; 3]) {
        let reach: [f64; 3] = std::array::from_fn(|k| {
            (0..3)
                .map(|j| self.axes[(k, j)].abs() * self.half[j])
                .sum::<f64>()
        });
        (
            std::array::from_fn(|k| self.center[k] - reach[k]),
            std::array::from_fn(|k| self.center[k] + reach[k]),
        )
    }
}

/// A body's triangles in a box hierarchy (the body's frame: the tool's own, or an object's
/// placed in the world), for [`TriangleTree::near_leaf_pairs`].
#[derive(Clone, Debug)]
pub struct TriangleTree {
    nodes: Vec<BoxNode>,
    /// Leaf by leaf.
    triangles: Vec<Triangle>,
    /// Each triangle's plane: unit normal and offset (`n · p = d` on it; all zero for a
    /// degenerate triangle), mm.
    planes: Vec<([f64; 3], f64)>,
    /// Each triangle's box along the frame's axes (lowest and highest corner), mm.
    bounds: Vec<([f64; 3], [f64; 3])>,
    /// Each triangle's edges' outward normals in its plane (unit) and offsets (`m · p = e` on
    /// the edge, the triangle on `m · p <= e`), mm; all zero for a degenerate triangle.
    edges: Vec<[([f64; 3], f64); 3]>,
    /// Each triangle's index in the mesh it came from.
    origin: Vec<u32>,
    /// Each node's box along the frame's axes (lowest and highest corner), mm: what a descent
    /// notes of the tool's near part ([`TreePairStack::note_near_part`]).
    node_bounds: Vec<([f64; 3], [f64; 3])>,
    /// Each node: a leaf whose facets turn more than 45° apart ([`FACES_APART_COS`]: a box's
    /// top and its side), whose box is far wider than any of them; a descent tests a tool leaf
    /// against each of its facets' boxes before visiting the pair.
    faces_apart: Vec<bool>,
    depth: usize,
}

/// Two facets of a leaf whose normals meet at more than 45° (this cosine) lie on different
/// faces of a part ([`TriangleTree::descend`]); the facets of a curved surface at the usual
/// tessellations turn a few degrees from one to the next.
const FACES_APART_COS: f64 = std::f64::consts::FRAC_1_SQRT_2;

/// What a descent of two trees works on, reserved once ([`TriangleTree::stack_for`]) so that
/// [`TriangleTree::near_leaf_pairs`] and [`TriangleTree::descend`] never allocate: the stack
/// of node pairs still to test (a tool node, an object node and the rank of their first
/// triangle pair, [`TriangleTree::descend`]), and the tool's boxes posed for the descent under
/// way. A tool box is tested against many object boxes: posed once, its test takes one matrix
/// product, not two.
#[derive(Clone, Debug)]
pub struct TreePairStack {
    pairs: Vec<(u32, u32, u64)>,
    /// Tool node `i`'s axes and centre in the world where `stamp[i] == current`.
    posed: Vec<(Matrix3<f64>, Vector3<f64>)>,
    stamp: Vec<u32>,
    current: u32,
    /// The margin (mm) within which the descents note the tool's near part (none noted at
    /// `-inf`), and the box of what they noted (tool frame, mm; empty with `lo > hi`).
    near_wide: f64,
    near_lo: [f64; 3],
    near_hi: [f64; 3],
    /// The noting is given up once the near part reaches this far (mm) from the tool origin,
    /// less by its share of the tests ([`TreePairStack::note_near_part`]; never at `inf`).
    give_up_past: f64,
    /// Box pairs the descents tested since the noting began, and those of them tested for the
    /// near part alone.
    tested: u64,
    tested_noting: u64,
    /// The noting was given up part-way.
    gave_up: bool,
}

impl Default for TreePairStack {
    /// An empty stack with no room reserved, noting no near part.
    fn default() -> Self {
        Self {
            pairs: Vec::new(),
            posed: Vec::new(),
            stamp: Vec::new(),
            current: 1,
            near_wide: f64::NEG_INFINITY,
            near_lo: [f64::INFINITY; 3],
            near_hi: [f64::NEG_INFINITY; 3],
            give_up_past: f64::INFINITY,
            tested: 0,
            tested_noting: 0,
            gave_up: false,
        }
    }
}

impl TreePairStack {
    /// Node pairs the stack holds at most without growing.
    pub fn capacity(&self) -> usize {
        self.pairs.capacity()
    }

    /// True when no node pair is left to test.
    pub fn is_empty(&self) -> bool {
        self.pairs.is_empty()
    }

    /// From now on, the descents on this stack (over any objects, until the next call) note
    /// the *near part* of the tool: a box (tool frame) holding every point of the tool within
    /// `wide` (mm, more than the descents' margin) of some object triangle anywhere on their
    /// sweep. A box pair apart by the margin but not by `wide` is followed down for the near
    /// part alone (no leaf pair of it visited) to the tool's leaves, the object's boxes split
    /// while large; each such leaf pair, and each leaf pair visited, notes its tool triangles'
    /// boxes, each cut to where it may be within `wide` of the object's box (seen in the tool
    /// frame). A tool point within `wide` of an object triangle lies in both boxes of one such
    /// pair.
    ///
    /// A near part is worth its tests only while it is well inside the tool: the noting is
    /// given up (no near part, [`TreePairStack::gave_up_noting`]) once some corner of it is
    /// `give_up_past / (1 + share)` (mm) or farther from the tool origin, `share` the tests
    /// made for the near part alone per test of the descents so far (`inf`: never given up).
    pub fn note_near_part(&mut self, wide: f64, give_up_past: f64) {
        self.near_wide = wide;
        self.near_lo = [f64::INFINITY; 3];
        self.near_hi = [f64::NEG_INFINITY; 3];
        self.give_up_past = give_up_past;
        self.tested = 0;
        self.tested_noting = 0;
        self.gave_up = false;
    }

    /// The near part noted since [`TreePairStack::note_near_part`] (lowest and highest corner,
    /// tool frame, mm): `None` where none is noted or the noting was given up, `Some` of an
    /// empty box (`lo > hi`) where no tool triangle was near.
    pub fn near_part(&self) -> Option<([f64; 3], [f64; 3])> {
        (self.near_wide > f64::NEG_INFINITY).then_some((self.near_lo, self.near_hi))
    }

    /// Whether the noting begun by [`TreePairStack::note_near_part`] was given up part-way:
    /// its near part reached too far from the tool origin to pay for its tests.
    pub fn gave_up_noting(&self) -> bool {
        self.gave_up
    }

    /// The part of the tool box `tool` (tool frame, mm) that may be within the near part's
    /// margin of the object box `object` (the world's axes, mm): the tool box cut by the
    /// object box grown by the margin and swept back along the tool's sweep, seen in the tool
    /// frame (`frame`); `None` where nothing of it is, or the near part holds it already. A
    /// long facet's box beside a wall is cut to the stretch of it along the wall.
    #[inline]
    fn cut(
        &self,
        (lo, hi): &([f64; 3], [f64; 3]),
        (olo, ohi): &([f64; 3], [f64; 3]),
        frame: &ToolFrame,
    ) -> Option<[(f64, f64); 3]> {
        let mut cut = [(0.0, 0.0); 3];
        let mut held = true;
        for k in 0..3 {
            let row = frame.inverse.row(k);
            let abs = frame.inverse_abs.row(k);
            let (mut c, mut h) = (-frame.origin_in_tool[k], frame.sweep_half[k]);
            for j in 0..3 {
                c += row[j] * 0.5 * (olo[j] + ohi[j]);
                h += abs[j] * (0.5 * (ohi[j] - olo[j]) + self.near_wide);
            }
            let (l, u) = (lo[k].max(c - h), hi[k].min(c + h));
            if l > u {
                return None;
            }
            held &= self.near_lo[k] <= l && u <= self.near_hi[k];
            cut[k] = (l, u);
        }
        (!held).then_some(cut)
    }

    /// Adds `cut` ([`TreePairStack::cut`]) to the near part.
    #[inline]
    fn note(&mut self, cut: &[(f64, f64); 3]) {
        for (k, &(l, u)) in cut.iter().enumerate() {
            self.near_lo[k] = self.near_lo[k].min(l);
            self.near_hi[k] = self.near_hi[k].max(u);
        }
        // The farthest corner from the tool origin against the break-even reach: a list's use
        // lasts about inversely to its near part's arm, which must make up for the share of
        // the descent's tests spent finding it.
        let far2: f64 = (0..3)
            .map(|k| self.near_lo[k].abs().max(self.near_hi[k].abs()).powi(2))
            .sum();
        let share = self.tested_noting as f64 / self.tested.max(1) as f64;
        let limit = self.give_up_past / (1.0 + share);
        if far2 >= limit * limit {
            self.near_wide = f64::NEG_INFINITY;
            self.gave_up = true;
        }
    }

    /// Empties it and forgets every posed box (the next descent may be at another pose).
    fn restart(&mut self) {
        self.pairs.clear();
        self.current = self.current.wrapping_add(1);
        if self.current == 0 {
            // The stamps came round: none may pass for current.
            self.stamp.iter_mut().for_each(|s| *s = 0);
            self.current = 1;
        }
    }

    /// Tool node `i` (`node`) posed at `(rot, t)`: its axes and centre in the world.
    #[inline]
    fn posed(
        &mut self,
        i: u32,
        node: &BoxNode,
        rot: &Matrix3<f64>,
        t: &Vector3<f64>,
    ) -> (Matrix3<f64>, Vector3<f64>) {
        let i = i as usize;
        if self.stamp[i] != self.current {
            self.posed[i] = (rot * node.axes, rot * Vector3::from(node.center) + t);
            self.stamp[i] = self.current;
        }
        self.posed[i]
    }
}

impl TriangleTree {
    /// The hierarchy of `triangles` (mm), each placed by `pose` (the identity for a tool):
    /// a node of a few triangles on two faces of a part (normals more than 45° apart: a
    /// box's top and its sides) split between the faces, any other at the median centre
    /// along its box's longest side, down to [`LEAF_TRIANGLES`] a leaf.
    /// Allocates; not real-time. An empty list gives an empty tree.
    pub fn build(triangles: &[Triangle], pose: &Pose) -> Self {
        Self::build_split(triangles, pose, true)
    }

    /// [`TriangleTree::build`], splitting between faces only with `face_splits` (else every
    /// node at its median, as the mesh mode's switch `mesh-face-splits` off does).
    pub fn build_split(triangles: &[Triangle], pose: &Pose, face_splits: bool) -> Self {
        let (rot, t) = (pose.rotation_matrix(), pose.translation());
        let placed: Vec<Triangle> = triangles
            .iter()
            .map(|tri| tri.map(|p| (rot * Vector3::from(p) + t).into()))
            .collect();
        let mut order: Vec<u32> = (0..placed.len() as u32).collect();
        // A split between faces may leave leaves of one triangle: at most one node a triangle
        // and one between each two.
        let mut nodes = Vec::with_capacity(2 * placed.len());
        let mut depth = 0;
        if !placed.is_empty() {
            let normals: Vec<Vector3<f64>> = placed
                .iter()
                .map(|t| Vector3::from(plane_of(t).0))
                .collect();
            let splitter = Splitter {
                tris: &placed,
                normals: &normals,
                face_splits,
            };
            nodes.push(box_of(&placed, &order));
            splitter.split(&mut order, 0, 0, &mut nodes, 1, &mut depth);
        }
        let triangles: Vec<Triangle> = order.iter().map(|&i| placed[i as usize]).collect();
        let planes = triangles.iter().map(plane_of).collect();
        let bounds = triangles.iter().map(bounds_of).collect();
        let edges = triangles.iter().map(edges_of).collect();
        let node_bounds = nodes.iter().map(BoxNode::frame_bounds).collect();
        let faces_apart = nodes
            .iter()
            .map(|n| {
                if !n.is_leaf() {
                    return false;
                }
                let normals: Vec<[f64; 3]> = (n.first..n.first + n.under)
                    .map(|i| plane_of(&triangles[i as usize]).0)
                    .filter(|m| *m != [0.0; 3])
                    .collect();
                normals.iter().any(|a| {
                    normals
                        .iter()
                        .any(|b| a[0] * b[0] + a[1] * b[1] + a[2] * b[2] < FACES_APART_COS)
                })
            })
            .collect();
        Self {
            nodes,
            triangles,
            planes,
            bounds,
            edges,
            origin: order,
            node_bounds,
            faces_apart,
            depth,
        }
    }

    /// Triangle `i` (in leaf order), mm, the tree's frame.
    #[inline]
    pub fn triangle(&self, i: u32) -> &Triangle {
        &self.triangles[i as usize]
    }

    /// Triangle `i`'s plane (in leaf order): its unit normal and offset `d`, `n · p = d` on
    /// it, mm; all zero for a degenerate triangle.
    #[inline]
    pub fn plane(&self, i: u32) -> ([f64; 3], f64) {
        self.planes[i as usize]
    }

    /// Triangle `i`'s box along the tree's frame axes (in leaf order): its lowest and highest
    /// corner, mm.
    #[inline]
    pub fn bounds(&self, i: u32) -> &([f64; 3], [f64; 3]) {
        &self.bounds[i as usize]
    }

    /// Triangle `i`'s edges (in leaf order): for the edge from corner `k` to corner `k + 1`,
    /// its outward normal in the triangle's plane (unit) and offset, `m · p = e` on the edge
    /// and the triangle on `m · p <= e`, mm; all zero for a degenerate triangle.
    #[inline]
    pub fn edges(&self, i: u32) -> &[([f64; 3], f64); 3] {
        &self.edges[i as usize]
    }

    /// The mesh's own index of triangle `i` (in leaf order).
    #[inline]
    pub fn origin(&self, i: u32) -> u32 {
        self.origin[i as usize]
    }

    /// How many triangles there are.
    pub fn len(&self) -> usize {
        self.triangles.len()
    }

    /// True without triangles.
    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }

    /// Levels from the root to the deepest leaf (1 for a single leaf; 0 when empty).
    pub fn depth(&self) -> usize {
        self.depth
    }

    /// Every corner (mm, the tree's frame).
    pub fn corners(&self) -> impl Iterator<Item = [f64; 3]> + '_ {
        self.triangles.iter().flatten().copied()
    }

    /// A stack deep enough for any descent of `a` (the tool) against `b`, with room for the
    /// tool's posed boxes (allocates; once).
    pub fn stack_for(a: &Self, b: &Self) -> TreePairStack {
        let mut stack = TreePairStack {
            pairs: Vec::with_capacity(a.depth + b.depth + 2),
            posed: vec![(Matrix3::zeros(), Vector3::zeros()); a.nodes.len()],
            stamp: vec![0; a.nodes.len()],
            ..TreePairStack::default()
        };
        // Resident from the start ([`crate::touch_pages`]): a zeroed buffer's pages are mapped
        // at their first write, which would be a frame's.
        crate::touch_pages(&mut stack.pairs);
        crate::touch_pages(&mut stack.posed);
        crate::touch_pages(&mut stack.stamp);
        stack
    }

    /// Calls `visit(tool_triangles, object_triangles)` with the leaf ranges of every leaf pair
    /// of `self` (the tool, placed at `(rot, t)`: world = rot · p + t) and `object` (its frame
    /// the world) whose boxes are within `margin` (mm) of each other; every pair of triangles
    /// within `margin` is in one such leaf pair (some farther apart are too). `stack` is
    /// [`TriangleTree::stack_for`]'s; nothing is allocated. Stops early when `visit` returns
    /// false.
    pub fn near_leaf_pairs(
        &self,
        rot: &Matrix3<f64>,
        t: &Vector3<f64>,
        object: &Self,
        margin: f64,
        stack: &mut TreePairStack,
        mut visit: impl FnMut(std::ops::Range<u32>, std::ops::Range<u32>) -> bool,
    ) {
        Self::start_descent(stack);
        self.descend(
            rot,
            t,
            &Vector3::zeros(),
            object,
            margin,
            stack,
            usize::MAX,
            |tools, parts, _| visit(tools, parts),
        );
    }

    /// Sets `stack` for a descent from the two roots ([`TriangleTree::descend`]).
    pub fn start_descent(stack: &mut TreePairStack) {
        stack.restart();
        stack.pairs.push((0, 0, 0));
    }

    /// Goes on with the descent `stack` holds ([`TriangleTree::start_descent`], then earlier
    /// calls with the same trees, pose, sweep and margin), testing at most `steps` box pairs, as
    /// [`TriangleTree::near_leaf_pairs`] but with the tool swept: every leaf pair whose boxes
    /// come within `margin` with the tool at `(rot, t + s · sweep)` for some `s` in `[0, 1]`
    /// (`sweep` in mm, the world's axes; zero for the pose alone). Returns true when the
    /// descent is over (every leaf pair visited, or `visit` returned false); false leaves the
    /// rest on the stack.
    ///
    /// `visit(tools, parts, rank)` also gets the leaf pair's rank: every triangle pair of the
    /// two trees has a place in the order a descent visits them, whatever it prunes and
    /// wherever the tool is (the node to split is chosen by size alone), and triangle pair
    /// `(i, j)` of this leaf pair is at `rank + (i - tools.start) · parts.len() + (j -
    /// parts.start)`. Ranks rise as a descent goes on, so two lists of the same trees' pairs,
    /// listed in order at different poses, are merged in one walk.
    #[allow(clippy::too_many_arguments)]
    pub fn descend(
        &self,
        rot: &Matrix3<f64>,
        t: &Vector3<f64>,
        sweep: &Vector3<f64>,
        object: &Self,
        margin: f64,
        stack: &mut TreePairStack,
        steps: usize,
        mut visit: impl FnMut(std::ops::Range<u32>, std::ops::Range<u32>, u64) -> bool,
    ) -> bool {
        let swept = sweep.iter().any(|&v| v != 0.0);
        if self.nodes.is_empty() || object.nodes.is_empty() {
            stack.pairs.clear();
            return true;
        }
        // A stack made for a smaller tool has no room for this one's boxes: they are posed at
        // each test instead (the same pairs, more slowly).
        let keep_posed = stack.posed.len() >= self.nodes.len();
        let inverse = rot.transpose();
        let frame = ToolFrame {
            inverse,
            inverse_abs: inverse.abs(),
            origin_in_tool: inverse * (t + 0.5 * sweep),
            sweep_half: (inverse * sweep).abs() * 0.5,
        };
        for _ in 0..steps {
            let Some((a, b, rank)) = stack.pairs.pop() else {
                return true;
            };
            let (na, nb) = (&self.nodes[a as usize], &object.nodes[b as usize]);
            // The tool box in the object box's axes: its rotation and centre.
            let (axes, centre) = if keep_posed {
                stack.posed(a, na, rot, t)
            } else {
                (rot * na.axes, rot * Vector3::from(na.center) + t)
            };
            let half = na.half;
            let noting_only = rank & NOTING_ONLY != 0;
            stack.tested += 1;
            stack.tested_noting += u64::from(noting_only);
            let apart = noting_only
                || posed_boxes_apart(
                    (&nb.axes, &nb.center, &nb.half),
                    (&axes, &centre, &half),
                    swept.then_some(sweep),
                    margin,
                );
            if apart {
                // Apart by the margin: only the near part may still want it, where the two are
                // within its margin (no cut: nothing of the tool box there, or all of it noted
                // already).
                let noting = stack.near_wide > margin;
                // (A pair apart by the margin costs the near part its cut and its second test.)
                stack.tested_noting += u64::from(noting && !noting_only);
                let wanted = noting
                    && stack
                        .cut(
                            &self.node_bounds[a as usize],
                            &object.node_bounds[b as usize],
                            &frame,
                        )
                        .is_some()
                    && !posed_boxes_apart(
                        (&nb.axes, &nb.center, &nb.half),
                        (&axes, &centre, &half),
                        swept.then_some(sweep),
                        stack.near_wide,
                    );
                if wanted {
                    // Down to the tool's leaves, cut triangle by triangle; the object's boxes
                    // split while large (seen at a slant from the tool, a large one cuts
                    // little).
                    if !nb.is_leaf() && longest(&nb.half) > NEAR_PART_GRAIN_MM {
                        let second = object.second_under(nb);
                        push_object_children(&mut stack.pairs, nb, second, a, na, NOTING_ONLY);
                    } else if !na.is_leaf() {
                        let second = self.second_under(na);
                        push_tool_children(&mut stack.pairs, na, second, b, nb, NOTING_ONLY);
                    } else {
                        self.note_cut(stack, na, &object.node_bounds[b as usize], &frame);
                    }
                }
                continue;
            }
            match (na.is_leaf(), nb.is_leaf()) {
                (true, true) => {
                    if stack.near_wide > f64::NEG_INFINITY {
                        let object_bounds = &object.node_bounds[b as usize];
                        let cut = stack.cut(&self.node_bounds[a as usize], object_bounds, &frame);
                        if cut.is_some() {
                            self.note_cut(stack, na, object_bounds, &frame);
                        }
                    }
                    let (tools, parts) =
                        (na.first..na.first + na.under, nb.first..nb.first + nb.under);
                    // An object leaf of facets of different faces (a box's top and its sides)
                    // has a box far wider than they are: a tool leaf near that box may be apart
                    // from each of its facets, along the object's axes.
                    if object.faces_apart[b as usize] {
                        let (lo, hi) = leaf_bounds(&axes, &centre, &na.half, sweep, margin);
                        let near = |j: u32| {
                            let (low, high) = object.bounds(j);
                            (0..3).all(|k| low[k] <= hi[k] && lo[k] <= high[k])
                        };
                        if !parts.clone().any(near) {
                            continue;
                        }
                    }
                    if !visit(tools, parts, rank) {
                        stack.pairs.clear();
                        return true;
                    }
                }
                // Descend the larger box (by its longest side), or the one that is not a leaf.
                (leaf_a, leaf_b) => {
                    if leaf_b || (!leaf_a && longest(&na.half) >= longest(&nb.half)) {
                        let second = self.second_under(na);
                        push_tool_children(&mut stack.pairs, na, second, b, nb, rank);
                    } else {
                        let second = object.second_under(nb);
                        push_object_children(&mut stack.pairs, nb, second, a, na, rank);
                    }
                }
            }
        }
        stack.is_empty()
    }
}

impl TriangleTree {
    /// The triangles below inner node `node`'s second child: its rank's share after the
    /// first's (read from the child, whose node is popped next).
    #[inline]
    fn second_under(&self, node: &BoxNode) -> u32 {
        self.nodes[node.first as usize + 1].under
    }

    /// Notes in the near part the part of each triangle of the tool leaf `leaf` near an object
    /// box `object` ([`TreePairStack::cut`]): cut one by one, since a leaf of a few long facets
    /// of different faces has a box far wider than they are.
    fn note_cut(
        &self,
        stack: &mut TreePairStack,
        leaf: &BoxNode,
        object: &([f64; 3], [f64; 3]),
        frame: &ToolFrame,
    ) {
        for i in leaf.first..leaf.first + leaf.under {
            if let Some(cut) = stack.cut(&self.bounds[i as usize], object, frame) {
                stack.note(&cut);
            }
        }
    }
}

/// The box of a triangle's corners along the frame's axes: lowest and highest corner, mm.
pub fn bounds_of(t: &Triangle) -> ([f64; 3], [f64; 3]) {
    let lo = std::array::from_fn(|k| t[0][k].min(t[1][k]).min(t[2][k]));
    let hi = std::array::from_fn(|k| t[0][k].max(t[1][k]).max(t[2][k]));
    (lo, hi)
}

/// The outward normals (unit, in its plane) and offsets of the edges of `t`, from corner `k` to
/// corner `k + 1`: `t` lies on `m · p <= e`. Zeros for a degenerate triangle or edge.
pub fn edges_of(t: &Triangle) -> [([f64; 3], f64); 3] {
    let (n, _) = plane_of(t);
    let n = Vector3::from(n);
    std::array::from_fn(|k| {
        let (a, b) = (Vector3::from(t[k]), Vector3::from(t[(k + 1) % 3]));
        let m = (b - a).cross(&n);
        let len = m.norm();
        if len <= 0.0 || !len.is_finite() {
            return ([0.0; 3], 0.0);
        }
        let m = m / len;
        (m.into(), m.dot(&a))
    })
}

/// The plane of `t`: unit normal (right-handed about its corners) and offset, or zeros for a
/// degenerate triangle.
fn plane_of(t: &Triangle) -> ([f64; 3], f64) {
    let (a, b, c) = (
        Vector3::from(t[0]),
        Vector3::from(t[1]),
        Vector3::from(t[2]),
    );
    let n = (b - a).cross(&(c - a));
    let len = n.norm();
    if len <= 0.0 || !len.is_finite() {
        return ([0.0; 3], 0.0);
    }
    let n = n / len;
    (n.into(), n.dot(&a))
}

/// Pushes the children of tool node `parent` (`second_under` triangles below its second)
/// against object node `other` (`other_node`), the pair's first triangle pair at `rank`: the
/// second child is popped first, so its pairs come first. A pop pushes two pairs a level
/// deeper on one side, leaving one behind per level, so the stack never holds more than the
/// two trees' depths together: its reserve is not outgrown.
fn push_tool_children(
    stack: &mut Vec<(u32, u32, u64)>,
    parent: &BoxNode,
    second_under: u32,
    other: u32,
    other_node: &BoxNode,
    rank: u64,
) {
    let after = u64::from(second_under) * u64::from(other_node.under);
    stack.push((parent.first, other, rank + after));
    stack.push((parent.first + 1, other, rank));
}

/// [`push_tool_children`] with the object's node split, against tool node `other`.
fn push_object_children(
    stack: &mut Vec<(u32, u32, u64)>,
    parent: &BoxNode,
    second_under: u32,
    other: u32,
    other_node: &BoxNode,
    rank: u64,
) {
    let after = u64::from(other_node.under) * u64::from(second_under);
    stack.push((other, parent.first, rank + after));
    stack.push((other, parent.first + 1, rank));
}

fn longest(h: &[f64; 3]) -> f64 {
    h[0].max(h[1]).max(h[2])
}

/// True when the tool's box (axes the columns of `a.0`, centre `a.1`, half extents `a.2`,
/// posed in the world) swept along `sweep` (mm, the world's axes) when given, and the object's
/// box (`b`, likewise; its frame the world) grown by `margin` on every side are apart along one
/// of their six face axes.
///
/// A conservative test: the nine cross products of the boxes' edges, the rest of the
/// separating axis theorem, are left out. Most box pairs a descent meets are not apart (two
/// walls within the margin, box after box), and for those all fifteen axes were computed to
/// prune few pairs: a pair the edges alone would part is pruned at its leaves by its
/// triangles' own tests, and the list is the same. Per-frame minima with no deadline, three
/// runs: every scene of the mesh zoo, the built-ins and the fit study's pegs lighter or equal
/// (the frames' time −0.4 to −11 %, their p99 0 to −19 %).
///
/// The sweep adds its own reach on each axis: the swept box is the box about its middle
/// position plus half the sweep either way. Grown into the tool box's half extents instead
/// (the box that holds the swept one), a slide along a face reached down into the face by the
/// box's tilt: a ball's leaves, whose boxes tilt with its surface, swept 4 mm along a plate
/// reached up to 2 mm farther across it.
///
/// Axis by axis, each product taken as its axis needs it, inlined in the descent: a pair apart
/// along the object box's first axis costs a third of the whole test. The descent bench's
/// light contacts took 10–13 % less time than with the turn and offset taken whole first, the
/// peg at a hole's mouth ~5 %, the peg in its hole (most box pairs not apart) the same
/// (`cargo bench -p collide --bench descent`, three runs alternated); the same rounding's
/// room, so the same answers (a run's frames alike).
#[inline(always)]
fn posed_boxes_apart(
    (b_axes, b_centre, hb): (&Matrix3<f64>, &[f64; 3], &[f64; 3]),
    (a_axes, a_centre, ha): (&Matrix3<f64>, &Vector3<f64>, &[f64; 3]),
    sweep: Option<&Vector3<f64>>,
    margin: f64,
) -> bool {
    // The centres' offset (world), the swept box about its middle position.
    let mut d = a_centre - Vector3::from(*b_centre);
    if let Some(s) = sweep {
        d += 0.5 * s;
    }
    // |turn| with a rounding's room, row by row: turn[(i, j)] is the object's axis i along the
    // tool's axis j.
    let mut abs_turn = [[0.0f64; 3]; 3];
    for (i, row) in abs_turn.iter_mut().enumerate() {
        let u = b_axes.column(i);
        for (j, entry) in row.iter_mut().enumerate() {
            *entry = u.dot(&a_axes.column(j)).abs() + 1e-12;
        }
        let ra = ha[0] * row[0] + ha[1] * row[1] + ha[2] * row[2];
        let swept = sweep.map_or(0.0, |s| 0.5 * u.dot(s).abs());
        if u.dot(&d).abs() > hb[i] + margin + ra + swept {
            return true;
        }
    }
    for j in 0..3 {
        let v = a_axes.column(j);
        let rb = (hb[0] + margin) * abs_turn[0][j]
            + (hb[1] + margin) * abs_turn[1][j]
            + (hb[2] + margin) * abs_turn[2][j];
        let swept = sweep.map_or(0.0, |s| 0.5 * v.dot(s).abs());
        if v.dot(&d).abs() > ha[j] + swept + rb {
            return true;
        }
    }
    false
}

/// The least and greatest coordinates (the object's frame, mm) of the tool box of `axes`,
/// `centre` and `half`, swept along `sweep`, grown by `margin`.
fn leaf_bounds(
    axes: &Matrix3<f64>,
    centre: &Vector3<f64>,
    half: &[f64; 3],
    sweep: &Vector3<f64>,
    margin: f64,
) -> ([f64; 3], [f64; 3]) {
    let reach = axes.abs() * Vector3::from(*half);
    let lo = std::array::from_fn(|k| centre[k] + sweep[k].min(0.0) - reach[k] - margin);
    let hi = std::array::from_fn(|k| centre[k] + sweep[k].max(0.0) + reach[k] + margin);
    (lo, hi)
}

/// The box of the triangles `order` names: along the principal axes of their corners (the
/// eigenvectors of the corners' covariance), just holding every corner, mm.
fn box_of(tris: &[Triangle], order: &[u32]) -> BoxNode {
    let corners = || {
        order
            .iter()
            .flat_map(|&i| tris[i as usize].iter().map(|p| Vector3::from(*p)))
    };
    let n = (3 * order.len()).max(1) as f64;
    let mean = corners().fold(Vector3::zeros(), |s, p| s + p) / n;
    let cov = corners().fold(Matrix3::zeros(), |s, p| {
        let e = p - mean;
        s + e * e.transpose()
    }) / n;
    let axes = if cov.iter().all(|x| x.is_finite()) {
        let eig = nalgebra::SymmetricEigen::new(cov);
        let mut axes = eig.eigenvectors;
        // A right-handed frame (the test needs only unit, orthogonal axes, but a rotation
        // reads better).
        if axes.determinant() < 0.0 {
            axes.set_column(2, &(-axes.column(2)));
        }
        axes
    } else {
        Matrix3::identity()
    };
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for p in corners() {
        let local = axes.transpose() * p;
        for k in 0..3 {
            lo[k] = lo[k].min(local[k]);
            hi[k] = hi[k].max(local[k]);
        }
    }
    let mid = Vector3::from(std::array::from_fn::<f64, 3, _>(|k| 0.5 * (lo[k] + hi[k])));
    BoxNode {
        center: (axes * mid).into(),
        axes,
        half: std::array::from_fn(|k| 0.5 * (hi[k] - lo[k])),
        first: 0,
        under: order.len() as u32,
    }
}

/// Two faces' triangles are told apart by their normals' projections on an axis where these
/// fall into two groups this far apart (2 sin 22.5°): every normal of one group then turns
/// more than 45° ([`FACES_APART_COS`]) from every normal of the other, whatever the axis.
const FACE_GAP: f64 = 0.765_366_864_730_18;

/// A node of at most this many triangles is split between faces ([`face_split`]); a larger
/// one at its median.
const FACE_SPLIT_MAX_TRIANGLES: usize = 16;

/// What the build splits: the placed triangles and their unit normals (zero for a degenerate
/// triangle), and whether a node of two faces is split between them ([`face_split`]).
struct Splitter<'a> {
    tris: &'a [Triangle],
    normals: &'a [Vector3<f64>],
    face_splits: bool,
}

impl Splitter<'_> {
    /// Makes node `node` (whose triangles are `order`, the tree's `start..start +
    /// order.len()`) a leaf or splits it, children appended as a pair: between faces where
    /// [`face_split`] finds two, else at the median centre along the box's longest axis.
    fn split(
        &self,
        order: &mut [u32],
        start: usize,
        node: usize,
        nodes: &mut Vec<BoxNode>,
        level: usize,
        depth: &mut usize,
    ) {
        *depth = (*depth).max(level);
        if order.len() <= LEAF_TRIANGLES {
            nodes[node].first = start as u32;
            return;
        }
        let axes = nodes[node].axes;
        let cut = if self.face_splits && order.len() <= FACE_SPLIT_MAX_TRIANGLES {
            face_split(self.normals, order, &axes)
        } else {
            None
        };
        let cut = cut.unwrap_or_else(|| {
            let half = nodes[node].half;
            let long = (0..3)
                .max_by(|&a, &b| half[a].total_cmp(&half[b]))
                .unwrap_or(0);
            let along = axes.column(long).into_owned();
            let key = |i: u32| -> f64 {
                let t = &self.tris[i as usize];
                (Vector3::from(t[0]) + Vector3::from(t[1]) + Vector3::from(t[2])).dot(&along)
            };
            let mid = order.len() / 2;
            order.select_nth_unstable_by(mid, |&a, &b| key(a).total_cmp(&key(b)));
            mid
        });
        let first = nodes.len();
        let (left, right) = order.split_at_mut(cut);
        nodes.push(box_of(self.tris, left));
        nodes.push(box_of(self.tris, right));
        nodes[node].first = first as u32;
        self.split(left, start, first, nodes, level + 1, depth);
        self.split(right, start + cut, first + 1, nodes, level + 1, depth);
    }
}

/// A split of `order` between two faces: where, along one of the node's axes (`axes`'
/// columns) or the frame's, its triangles' normals project into two groups [`FACE_GAP`] or
/// more apart, `order` is sorted along that axis and the count before the gap returned; of
/// several such gaps, the one nearest the middle. `None` where the normals turn gradually
/// (a curved surface: the median split is kept) or lie on one face.
///
/// A node of a box's top and its sides has a box, on the principal axes of their corners, that
/// tilts off all of them and reaches far beyond each face: a tool near one face meets it and
/// is taken down to its leaves. Split between the faces, each face's node is as flat as the
/// face, and a tool near the top meets only the top's.
fn face_split(normals: &[Vector3<f64>], order: &mut [u32], axes: &Matrix3<f64>) -> Option<usize> {
    let n = order.len();
    let mut best: Option<(usize, Vector3<f64>, usize)> = None;
    let candidates = (0..3)
        .map(|k| axes.column(k).into_owned())
        .chain((0..3).map(|k| Vector3::ith(k, 1.0)));
    let mut keys = Vec::with_capacity(n);
    for axis in candidates {
        // A gap of FACE_GAP holds a whole bin half as wide: a quick pass over the bins
        // passes over the axes with none empty between the lowest key and the highest
        // (a curved surface's), with no sort.
        const BINS: usize = 6;
        let bin = |key: f64| (((key + 1.0) / 2.0 * BINS as f64) as usize).min(BINS - 1);
        let mut filled = [false; BINS];
        for &i in order.iter() {
            filled[bin(normals[i as usize].dot(&axis))] = true;
        }
        let (lo, hi) = (
            filled.iter().position(|&f| f).unwrap_or(0),
            filled.iter().rposition(|&f| f).unwrap_or(0),
        );
        if filled[lo..=hi].iter().all(|&f| f) {
            continue;
        }
        keys.clear();
        keys.extend(order.iter().map(|&i| normals[i as usize].dot(&axis)));
        keys.sort_unstable_by(f64::total_cmp);
        for cut in 1..n {
            if keys[cut] - keys[cut - 1] >= FACE_GAP {
                let balance = cut.min(n - cut);
                if best.is_none_or(|(b, _, _)| balance > b) {
                    best = Some((balance, axis, cut));
                }
            }
        }
    }
    let (_, axis, cut) = best?;
    order.sort_unstable_by(|&a, &b| {
        normals[a as usize]
            .dot(&axis)
            .total_cmp(&normals[b as usize].dot(&axis))
    });
    Some(cut)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::triangle::triangle_distance;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A bumpy sheet of `n`×`n` cells, 1 mm each, with long thin facets when `sliver`.
    fn sheet(n: usize, sliver: bool, rng: &mut ChaCha8Rng) -> Vec<Triangle> {
        let sx = if sliver { 8.0 } else { 1.0 };
        let z: Vec<Vec<f64>> = (0..=n)
            .map(|_| (0..=n).map(|_| rng.random_range(-0.3..0.3)).collect())
            .collect();
        let p = |i: usize, j: usize| [i as f64 * sx, j as f64, z[i][j]];
        let mut out = Vec::new();
        for i in 0..n {
            for j in 0..n {
                out.push([p(i, j), p(i + 1, j), p(i + 1, j + 1)]);
                out.push([p(i, j), p(i + 1, j + 1), p(i, j + 1)]);
            }
        }
        out
    }

    /// A small bumpy sheet (the tool) and a larger one (the object), each with long thin
    /// facets in some cases, their trees and a stack for their descents.
    fn sheets(
        case: usize,
        rng: &mut ChaCha8Rng,
    ) -> (
        Vec<Triangle>,
        Vec<Triangle>,
        TriangleTree,
        TriangleTree,
        TreePairStack,
    ) {
        let tool_tris = sheet(4, case.is_multiple_of(2), rng);
        let object_tris = sheet(8, case.is_multiple_of(3), rng);
        let tool = TriangleTree::build(&tool_tris, &Pose::identity());
        let object = TriangleTree::build(&object_tris, &Pose::identity());
        let stack = TriangleTree::stack_for(&tool, &object);
        (tool_tris, object_tris, tool, object, stack)
    }

    fn random_pose(rng: &mut ChaCha8Rng, lift: f64) -> Pose {
        let r = |rng: &mut ChaCha8Rng, s: f64| rng.random_range(-s..s);
        Pose::from_array([
            r(rng, 3.0),
            r(rng, 3.0),
            lift + r(rng, 0.5),
            r(rng, 0.4),
            r(rng, 0.4),
            r(rng, 3.2),
        ])
    }

    /// The triangle pairs (their indices in the meshes given) of the leaf pairs a descent of
    /// `tool` at `q` against `object` visits within `margin` (mm), and how many leaf pairs.
    fn listed_pairs(
        tool: &TriangleTree,
        object: &TriangleTree,
        q: &Pose,
        margin: f64,
        stack: &mut TreePairStack,
    ) -> (std::collections::HashSet<(u32, u32)>, usize) {
        let (rot, t) = (q.rotation_matrix(), q.translation());
        let mut listed = std::collections::HashSet::new();
        let mut visited = 0;
        tool.near_leaf_pairs(&rot, &t, object, margin, stack, |ta, ob| {
            visited += 1;
            for i in ta {
                for j in ob.clone() {
                    listed.insert((tool.origin(i), object.origin(j)));
                }
            }
            true
        });
        (listed, visited)
    }

    /// The twelve facets of the box between `lo` and `hi` (mm).
    fn box_facets(lo: [f64; 3], hi: [f64; 3]) -> Vec<Triangle> {
        let c = |i: usize| -> [f64; 3] {
            std::array::from_fn(|k| if i >> k & 1 == 1 { hi[k] } else { lo[k] })
        };
        // Each face as four corners in order around it.
        let faces = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        faces
            .iter()
            .flat_map(|f| [[c(f[0]), c(f[1]), c(f[2])], [c(f[0]), c(f[2]), c(f[3])]])
            .collect()
    }

    /// A latitude–longitude ball of `radius` (mm) resting on `z = 0` at the origin, `around`
    /// facets round and `around / 2` rings: a fan of slivers at each pole.
    fn ball_facets(radius: f64, around: usize) -> Vec<Triangle> {
        use std::f64::consts::PI;
        let rings = around / 2;
        let at = |i: usize, j: usize| -> [f64; 3] {
            let (th, ph) = (
                PI * i as f64 / rings as f64,
                2.0 * PI * j as f64 / around as f64,
            );
            [
                radius * th.sin() * ph.cos(),
                radius * th.sin() * ph.sin(),
                radius * (1.0 - th.cos()),
            ]
        };
        let mut out = Vec::new();
        for i in 0..rings {
            for j in 0..around {
                let (a, b, c, d) = (at(i, j), at(i, j + 1), at(i + 1, j + 1), at(i + 1, j));
                if i > 0 {
                    out.push([a, b, c]);
                }
                if i + 1 < rings {
                    out.push([a, c, d]);
                }
            }
        }
        out
    }

    /// Every pair (tool triangle, object triangle) within `margin` (mm) of each other with the
    /// tool placed at `q`, by brute force.
    fn pairs_within(
        tool: &[Triangle],
        q: &Pose,
        object: &[Triangle],
        margin: f64,
    ) -> Vec<(u32, u32)> {
        let (rot, t) = (q.rotation_matrix(), q.translation());
        let mut near = Vec::new();
        for (i, a) in tool.iter().enumerate() {
            let a = a.map(|c| (rot * Vector3::from(c) + t).into());
            for (j, b) in object.iter().enumerate() {
                if triangle_distance(&a, b).distance <= margin {
                    near.push((i as u32, j as u32));
                }
            }
        }
        near
    }

    /// The pairs (by the meshes' own indices) a descent from `q` along `sweep` lists within
    /// `margin`, and how many box pairs it tested (one step each).
    fn box_tests(
        tool: &TriangleTree,
        object: &TriangleTree,
        q: &Pose,
        sweep: &Vector3<f64>,
        margin: f64,
        stack: &mut TreePairStack,
    ) -> (std::collections::HashSet<(u32, u32)>, usize) {
        let (rot, t) = (q.rotation_matrix(), q.translation());
        let mut listed = std::collections::HashSet::new();
        TriangleTree::start_descent(stack);
        let mut tests = 0;
        loop {
            tests += 1;
            let done = tool.descend(&rot, &t, sweep, object, margin, stack, 1, |ta, ob, _| {
                for i in ta {
                    for j in ob.clone() {
                        listed.insert((tool.origin(i), object.origin(j)));
                    }
                }
                true
            });
            if done {
                return (listed, tests);
            }
        }
    }

    /// A box's top and sides in one node have a box that tilts off all of them and reaches far
    /// beyond each face. Split between its faces, the top's leaves lie as flat as the top, and a
    /// ball on it, resting, lifted or sliding, is tested against far fewer of the plate's boxes
    /// for the same pairs.
    #[test]
    fn a_box_is_split_between_its_faces_and_a_ball_on_its_top_meets_the_tops_boxes_alone() {
        let plate_tris = box_facets([-60.0, -60.0, -10.0], [60.0, 60.0, 0.0]);
        let by_faces = TriangleTree::build(&plate_tris, &Pose::identity());
        let by_median = TriangleTree::build_split(&plate_tris, &Pose::identity(), false);
        let mut top_leaves = 0;
        for n in by_faces.nodes.iter().filter(|n| n.is_leaf()) {
            let range = n.first..n.first + n.under;
            let tops = range.filter(|&i| by_faces.plane(i).0[2] > 0.99).count();
            if tops > 0 {
                top_leaves += 1;
                assert_eq!(
                    tops, n.under as usize,
                    "a leaf of the top holds other facets"
                );
                assert!(
                    n.half.iter().any(|&h| h < 1e-9),
                    "a leaf of the top is not flat"
                );
            }
        }
        assert_eq!(top_leaves, 1);
        // The median split mixes the top with the sides.
        assert!(by_median.faces_apart.iter().filter(|&&f| f).count() >= 3);
        let ball_tris = ball_facets(5.0, 48);
        let ball = TriangleTree::build(&ball_tris, &Pose::identity());
        let mut stack = TriangleTree::stack_for(&ball, &by_faces);
        let (mut by_faces_tests, mut by_median_tests) = (0, 0);
        for case in 0..12 {
            let x = -30.0 + 5.0 * case as f64;
            let (lift, margin) = [(0.0, 0.05), (0.05, 0.3), (0.3, 1.0)][case % 3];
            let q = Pose::from_array([x, x / 3.0, lift, 0.0, 0.0, 0.1 * case as f64]);
            let sweep = Vector3::new(2.0 * (case % 2) as f64, 0.0, 0.0);
            let (a, tests_a) = box_tests(&ball, &by_faces, &q, &sweep, margin, &mut stack);
            let (b, tests_b) = box_tests(&ball, &by_median, &q, &sweep, margin, &mut stack);
            // Every pair within the margin at the slide's start, by brute force, in both.
            let near = pairs_within(&ball_tris, &q, &plate_tris, margin);
            for pair in &near {
                assert!(
                    a.contains(pair) && b.contains(pair),
                    "case {case}: {pair:?}"
                );
            }
            assert!(!near.is_empty(), "case {case}: nothing near");
            by_faces_tests += tests_a;
            by_median_tests += tests_b;
        }
        eprintln!("box tests: {by_faces_tests} split by faces, {by_median_tests} at medians");
        assert!(
            2 * by_faces_tests < by_median_tests,
            "box pairs tested: {by_faces_tests} split by faces, {by_median_tests} at medians"
        );
    }

    /// A box swept along a face reaches no farther across it than at either end. Grown into
    /// the box's own extents, the sweep reached into the face by the box's tilt: a ball's
    /// boxes, tilted with its surface, slid 4 mm along a plate reached down up to 2 mm farther.
    /// Slid, the ball's lowest ring is the same all the way: the swept descent tests about as
    /// many box pairs as one at the slide's start.
    #[test]
    fn a_box_slid_along_a_face_reaches_no_farther_across_it_than_at_its_ends() {
        let plate_tris = box_facets([-60.0, -60.0, -10.0], [60.0, 60.0, 0.0]);
        let plate = TriangleTree::build(&plate_tris, &Pose::identity());
        let ball = TriangleTree::build(&ball_facets(5.0, 48), &Pose::identity());
        let mut stack = TriangleTree::stack_for(&ball, &plate);
        let (mut swept_tests, mut start_tests) = (0, 0);
        for case in 0..8 {
            let x = -20.0 + 5.0 * case as f64;
            let margin = [0.05, 0.3][case % 2];
            let q = Pose::from_array([x, 1.0, 0.02, 0.0, 0.0, 0.2 * case as f64]);
            let sweep = Vector3::new(4.0, 1.0, 0.0);
            let zero = Vector3::zeros();
            let (swept, tests) = box_tests(&ball, &plate, &q, &sweep, margin, &mut stack);
            let (start, at_start) = box_tests(&ball, &plate, &q, &zero, margin, &mut stack);
            let end_pose =
                Pose::from_translation_rotation(&(q.translation() + sweep), &q.rotation_matrix());
            let (end, _) = box_tests(&ball, &plate, &end_pose, &zero, margin, &mut stack);
            assert!(
                start.is_subset(&swept) && end.is_subset(&swept),
                "case {case}"
            );
            swept_tests += tests;
            start_tests += at_start;
        }
        eprintln!("box tests: {swept_tests} swept, {start_tests} at the start");
        assert!(
            4 * swept_tests < 5 * start_tests,
            "box pairs tested: {swept_tests} swept, {start_tests} at the slide's start"
        );
    }

    /// A leaf of a box's facets spans its faces, and its box is far wider than any of them:
    /// a descent tests a tool leaf against each facet's box before visiting the pair. A bumpy
    /// sheet over a plate's top, at random poses: every pair within the margin listed as brute
    /// force finds it, and fewer leaf pairs visited than without the facets' test.
    #[test]
    fn a_leaf_of_a_boxs_faces_is_visited_only_where_a_facet_is_near() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let plate_tris = box_facets([-60.0, -60.0, -10.0], [60.0, 60.0, 0.0]);
        // Split at medians, its leaves mix its top with its sides.
        let plate = TriangleTree::build_split(&plate_tris, &Pose::identity(), false);
        assert!(plate.faces_apart.iter().any(|&f| f));
        let mut plain = plate.clone();
        plain.faces_apart.fill(false);
        let tool_tris = sheet(6, false, &mut rng);
        let tool = TriangleTree::build(&tool_tris, &Pose::identity());
        let mut stack = TriangleTree::stack_for(&tool, &plate);
        let (mut with, mut without) = (0, 0);
        for case in 0..40 {
            let margin = [0.05, 0.5, 2.0][case % 3];
            let x = rng.random_range(-40.0..40.0);
            let q = Pose::from_array([x, x / 2.0, 0.35 + margin * 0.5, 0.1, -0.05, 0.3]);
            let (listed, visited) = listed_pairs(&tool, &plate, &q, margin, &mut stack);
            with += visited;
            without += listed_pairs(&tool, &plain, &q, margin, &mut stack).1;
            let near = pairs_within(&tool_tris, &q, &plate_tris, margin);
            for (i, j) in &near {
                assert!(
                    listed.contains(&(*i, *j)),
                    "case {case}: triangles {i} and {j} within {margin} mm not listed"
                );
            }
            assert!(
                !near.is_empty() || margin < 0.5,
                "case {case}: nothing near"
            );
        }
        assert!(
            2 * with < without,
            "{with} leaf pairs visited with the facets' test, {without} without"
        );
    }

    #[test]
    fn every_pair_within_the_margin_is_in_a_listed_leaf_pair_as_brute_force_finds_it() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for case in 0..24 {
            let sliver = case % 2 == 1;
            let tool_tris = sheet(5, sliver, &mut rng);
            let object_tris = sheet(7, !sliver, &mut rng);
            let object_pose = Pose::from_array([1.0, -2.0, 0.0, 0.1, 0.0, 0.3]);
            let tool = TriangleTree::build(&tool_tris, &Pose::identity());
            let object = TriangleTree::build(&object_tris, &object_pose);
            let mut stack = TriangleTree::stack_for(&tool, &object);
            let margin = [0.0, 0.05, 0.5, 2.0][case % 4];
            let q = random_pose(&mut rng, 0.8);
            let (listed, _) = listed_pairs(&tool, &object, &q, margin, &mut stack);
            let place = |p: &Pose, tri: &Triangle| -> Triangle {
                tri.map(|c| (p.rotation_matrix() * Vector3::from(c) + p.translation()).into())
            };
            let mut near = 0;
            for (i, a) in tool_tris.iter().enumerate() {
                for (j, b) in object_tris.iter().enumerate() {
                    let d = triangle_distance(&place(&q, a), &place(&object_pose, b));
                    if d.distance <= margin {
                        near += 1;
                        assert!(
                            listed.contains(&(i as u32, j as u32)),
                            "case {case}: triangles {i} and {j} are {} mm apart (margin {margin}) but not listed",
                            d.distance
                        );
                    }
                }
            }
            // The boxes prune: far fewer pairs measured than all of them.
            let all = tool_tris.len() * object_tris.len();
            assert!(
                listed.len() < all / 2 || near > all / 4,
                "case {case}: {} of {all} pairs listed for {near} near ones",
                listed.len()
            );
            assert!(stack.capacity() == tool.depth() + object.depth() + 2);
        }
    }

    #[test]
    fn the_near_part_holds_every_point_of_the_tool_near_an_object_anywhere_on_the_sweep() {
        let mut rng = ChaCha8Rng::seed_from_u64(31);
        let mut smaller = 0;
        for case in 0..16 {
            // Long facets on the tool in half the cases: their leaves are cut to the stretch
            // near the object.
            let (tool_tris, object_tris, tool, object, mut stack) = sheets(case, &mut rng);
            let mut q = random_pose(&mut rng, 0.9);
            // Tilted 0.5–1 rad, so that part of the tool stands off the sheet.
            let mut a = q.to_array();
            a[3] = rng.random_range(0.5..1.0) * if rng.random_bool(0.5) { 1.0 } else { -1.0 };
            q = Pose::from_array(a);
            let (rot, t) = (q.rotation_matrix(), q.translation());
            let r = |rng: &mut ChaCha8Rng| rng.random_range(-1.0..1.0);
            let sweep = if case % 4 < 2 {
                Vector3::zeros()
            } else {
                Vector3::new(r(&mut rng), r(&mut rng), 0.3 * r(&mut rng))
            };
            let margin = [0.02, 0.1, 0.3][case % 3];
            let wide = margin + [0.2, 0.8][case % 2];
            TriangleTree::start_descent(&mut stack);
            stack.note_near_part(wide, f64::INFINITY);
            tool.descend(
                &rot,
                &t,
                &sweep,
                &object,
                margin,
                &mut stack,
                usize::MAX,
                |_, _, _| true,
            );
            let (lo, hi) = stack.near_part().expect("noted");
            let inside =
                |p: &Vector3<f64>| (0..3).all(|k| lo[k] - 1e-9 <= p[k] && p[k] <= hi[k] + 1e-9);
            // Sampled over the tool's triangles and along the sweep: every point within `wide`
            // of an object triangle is in it.
            let mut near_points = 0;
            for step in 0..=6 {
                let at = t + sweep * (f64::from(step) / 6.0);
                for tri in &tool_tris {
                    for (u, v) in (0..=4).flat_map(|u| (0..=4 - u).map(move |v| (u, v))) {
                        let (u, v) = (f64::from(u) / 4.0, f64::from(v) / 4.0);
                        let p = Vector3::from(tri[0]) * (1.0 - u - v)
                            + Vector3::from(tri[1]) * u
                            + Vector3::from(tri[2]) * v;
                        let world: [f64; 3] = (rot * p + at).into();
                        let near = object_tris.iter().any(|b| {
                            let c = crate::triangle::closest_on_triangle(&world, b);
                            (Vector3::from(c) - Vector3::from(world)).norm() <= wide
                        });
                        if near {
                            near_points += 1;
                            assert!(
                                inside(&p),
                                "case {case}: tool point {p:?} within {wide} mm of the object at s = {step}/6 outside the near part {lo:?}..{hi:?}"
                            );
                        }
                    }
                }
            }
            // And it is no bigger than the tool: where part of the tool stands off, smaller.
            let whole = crate::CentreBox::of_points(tool.corners());
            if near_points > 0
                && (0..3).any(|k| lo[k] > whole.lo[k] + 0.5 || hi[k] < whole.hi[k] - 0.5)
            {
                smaller += 1;
            }
        }
        // Nothing within the margin, all of it within the near part's: the whole tool.
        let square = |z: f64, half: f64| -> Vec<Triangle> {
            let p = |x: f64, y: f64| [x * half, y * half, z];
            vec![
                [p(-1.0, -1.0), p(1.0, -1.0), p(1.0, 1.0)],
                [p(-1.0, -1.0), p(1.0, 1.0), p(-1.0, 1.0)],
            ]
        };
        let tool = TriangleTree::build(&square(0.0, 1.0), &Pose::identity());
        let object = TriangleTree::build(&square(-0.5, 3.0), &Pose::identity());
        let mut stack = TriangleTree::stack_for(&tool, &object);
        TriangleTree::start_descent(&mut stack);
        stack.note_near_part(1.0, f64::INFINITY);
        let (rot, t) = (Matrix3::identity(), Vector3::zeros());
        let mut visited = 0;
        tool.descend(
            &rot,
            &t,
            &Vector3::zeros(),
            &object,
            0.1,
            &mut stack,
            usize::MAX,
            |_, _, _| {
                visited += 1;
                true
            },
        );
        assert_eq!(visited, 0);
        let (lo, hi) = stack.near_part().expect("noted");
        assert!(
            lo[0] <= -1.0 && lo[1] <= -1.0 && hi[0] >= 1.0 && hi[1] >= 1.0,
            "{lo:?}..{hi:?}"
        );
        assert!(
            smaller >= 4,
            "the near part was smaller than the tool in {smaller} of 16 cases"
        );
    }

    #[test]
    fn the_noting_is_given_up_where_the_near_part_reaches_far_from_the_tool_origin() {
        // A strip 20 mm long (tool frame x from `start`), a small sheet under its last 2 mm.
        let strip = |start: f64| -> Vec<Triangle> {
            (0..40)
                .flat_map(|i| {
                    let (x0, x1) = (start + 0.5 * f64::from(i), start + 0.5 * f64::from(i + 1));
                    [
                        [[x0, -1.0, 0.0], [x1, -1.0, 0.0], [x1, 1.0, 0.0]],
                        [[x0, -1.0, 0.0], [x1, 1.0, 0.0], [x0, 1.0, 0.0]],
                    ]
                })
                .collect()
        };
        let sheet: Vec<Triangle> = vec![
            [[18.0, -2.0, -0.05], [20.0, -2.0, -0.05], [20.0, 2.0, -0.05]],
            [[18.0, -2.0, -0.05], [20.0, 2.0, -0.05], [18.0, 2.0, -0.05]],
        ];
        let object = TriangleTree::build(&sheet, &Pose::identity());
        // The tool origin at the strip's far end (the near part 17–20 mm from it), then at its
        // near end (placed 20 mm on, the same strip in the world).
        for (start, at, gives_up) in [(0.0, 0.0, true), (-20.0, 20.0, false)] {
            let tool = TriangleTree::build(&strip(start), &Pose::identity());
            let reach = crate::CentreBox::of_points(tool.corners()).reach();
            let (rot, t) = (Matrix3::identity(), Vector3::new(at, 0.0, 0.0));
            let descend = |give_up_past: f64| {
                let mut stack = TriangleTree::stack_for(&tool, &object);
                TriangleTree::start_descent(&mut stack);
                stack.note_near_part(1.0, give_up_past);
                let mut visited = Vec::new();
                tool.descend(
                    &rot,
                    &t,
                    &Vector3::zeros(),
                    &object,
                    0.1,
                    &mut stack,
                    usize::MAX,
                    |tools, parts, rank| {
                        visited.push((tools, parts, rank));
                        true
                    },
                );
                (visited, stack.near_part(), stack.gave_up_noting())
            };
            let (all_visits, all_part, all_gave_up) = descend(f64::INFINITY);
            let (visits, part, gave_up) = descend(0.9 * reach);
            assert!(!all_gave_up && all_part.is_some());
            // The noting never changes the leaf pairs visited.
            assert!(!visits.is_empty());
            assert_eq!(visits, all_visits);
            assert_eq!(gave_up, gives_up, "start {start}");
            if gives_up {
                assert_eq!(part, None);
            } else {
                assert_eq!(part, all_part);
                let (lo, hi) = part.expect("noted");
                assert!(lo[0] >= -5.0 && hi[0] <= 1e-9, "{lo:?}..{hi:?}");
            }
        }
    }

    #[test]
    fn a_swept_descent_lists_every_pair_near_anywhere_on_the_sweep() {
        let mut rng = ChaCha8Rng::seed_from_u64(23);
        for case in 0..12 {
            let (_, _, tool, object, mut stack) = sheets(case, &mut rng);
            let q = random_pose(&mut rng, 0.9);
            let (rot, t) = (q.rotation_matrix(), q.translation());
            let r = |rng: &mut ChaCha8Rng| rng.random_range(-1.5..1.5);
            let sweep = Vector3::new(r(&mut rng), r(&mut rng), 0.4 * r(&mut rng));
            let margin = [0.02, 0.1, 0.4][case % 3];
            let mut listed = std::collections::HashSet::new();
            let mut swept_pairs = 0;
            TriangleTree::start_descent(&mut stack);
            tool.descend(
                &rot,
                &t,
                &sweep,
                &object,
                margin,
                &mut stack,
                usize::MAX,
                |ta, ob, _| {
                    swept_pairs += 1;
                    for i in ta {
                        for j in ob.clone() {
                            listed.insert((i, j));
                        }
                    }
                    true
                },
            );
            let mut at_start = 0;
            tool.near_leaf_pairs(&rot, &t, &object, margin, &mut stack, |_, _| {
                at_start += 1;
                true
            });
            assert!(
                swept_pairs >= at_start,
                "case {case}: the sweep's start is in it"
            );
            // Sampled along the sweep, every pair within the margin is listed.
            for step in 0..=20 {
                let at = t + sweep * (f64::from(step) / 20.0);
                for i in 0..tool.len() as u32 {
                    let a = tool
                        .triangle(i)
                        .map(|c| (rot * Vector3::from(c) + at).into());
                    for j in 0..object.len() as u32 {
                        let d = triangle_distance(&a, object.triangle(j)).distance;
                        assert!(
                            d > margin || listed.contains(&(i, j)),
                            "case {case}: pair ({i}, {j}) {d} mm apart at s = {step}/20 not listed"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn a_descent_in_slices_visits_the_same_leaf_pairs_as_one_whole() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let tool = TriangleTree::build(&sheet(6, true, &mut rng), &Pose::identity());
        let object = TriangleTree::build(&sheet(9, false, &mut rng), &Pose::identity());
        let q = random_pose(&mut rng, 0.6);
        let (rot, t) = (q.rotation_matrix(), q.translation());
        let mut stack = TriangleTree::stack_for(&tool, &object);
        // `steps` box tests of the descent under way, its leaf pairs pushed onto `out`.
        let go_on = |stack: &mut TreePairStack, steps: usize, out: &mut Vec<_>| {
            tool.descend(
                &rot,
                &t,
                &Vector3::zeros(),
                &object,
                0.3,
                stack,
                steps,
                |a, b, rank| {
                    out.push((a, b, rank));
                    true
                },
            )
        };
        let mut whole = Vec::new();
        TriangleTree::start_descent(&mut stack);
        go_on(&mut stack, usize::MAX, &mut whole);
        for steps in [1, 3, 50] {
            let mut sliced = Vec::new();
            TriangleTree::start_descent(&mut stack);
            let mut slices = 0;
            while !go_on(&mut stack, steps, &mut sliced) {
                slices += 1;
            }
            assert_eq!(sliced, whole, "{steps} steps a slice");
            assert!(slices > 0 && stack.capacity() == tool.depth() + object.depth() + 2);
        }
        assert!(!whole.is_empty());
    }

    #[test]
    fn every_pair_keeps_its_rank_at_every_pose_and_a_reused_stack_lists_as_a_fresh_one() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let tool = TriangleTree::build(&sheet(5, true, &mut rng), &Pose::identity());
        // A block under the sheet: its node is split between its faces, not in halves.
        let mut parts = sheet(7, false, &mut rng);
        parts.extend(box_facets([1.0, 1.0, -3.0], [3.0, 2.0, -1.5]));
        let object = TriangleTree::build(&parts, &Pose::identity());
        let uneven = object.nodes.iter().filter(|n| !n.is_leaf()).any(|n| {
            let second = object.second_under(n);
            second != n.under - n.under / 2
        });
        assert!(uneven, "no node split between faces");
        let small_tool = TriangleTree::build(&sheet(1, false, &mut rng), &Pose::identity());
        let mut stack = TriangleTree::stack_for(&tool, &object);
        // The ranks of the triangle pairs a descent at `q` within `margin` lists, in order.
        // One stack for every descent: each start forgets the tool boxes posed for the last.
        let ranked = |stack: &mut TreePairStack, q: &Pose, sweep: Vector3<f64>, margin: f64| {
            let mut out = Vec::new();
            TriangleTree::start_descent(stack);
            tool.descend(
                &q.rotation_matrix(),
                &q.translation(),
                &sweep,
                &object,
                margin,
                stack,
                usize::MAX,
                |tools, parts, rank| {
                    let n = parts.len() as u64;
                    for i in tools.clone() {
                        for j in parts.clone() {
                            let at = u64::from(i - tools.start) * n + u64::from(j - parts.start);
                            out.push(((i, j), rank + at));
                        }
                    }
                    true
                },
            );
            out
        };
        // With a margin past both parts every pair is listed: each rank once, 0 to all - 1.
        let all = ranked(&mut stack, &Pose::identity(), Vector3::zeros(), 1e3);
        let count = tool.len() * object.len();
        assert_eq!(all.len(), count);
        let mut ranks: Vec<u64> = all.iter().map(|p| p.1).collect();
        ranks.sort_unstable();
        assert!(ranks.iter().enumerate().all(|(k, &r)| r == k as u64));
        let rank_of: std::collections::HashMap<(u32, u32), u64> = all.into_iter().collect();
        let mut seen = 0;
        for case in 0..20 {
            let q = random_pose(&mut rng, 0.5);
            let sweep = Vector3::new(0.3, -0.2, 0.1) * (case % 3) as f64;
            let margin = [0.05, 0.3, 1.0][case % 3];
            let listed = ranked(&mut stack, &q, sweep, margin);
            // The same as a descent on a stack that never posed a box, and on one made for a
            // smaller tool (no room to keep this one's boxes posed).
            let mut fresh = TriangleTree::stack_for(&tool, &object);
            assert_eq!(listed, ranked(&mut fresh, &q, sweep, margin), "case {case}");
            let mut small = TriangleTree::stack_for(&small_tool, &object);
            assert_eq!(listed, ranked(&mut small, &q, sweep, margin), "case {case}");
            seen += listed.len();
            for w in listed.windows(2) {
                assert!(w[0].1 < w[1].1, "case {case}: ranks fall from {w:?}");
            }
            for (pair, rank) in &listed {
                assert_eq!(rank_of[pair], *rank, "case {case}: {pair:?}");
            }
        }
        assert!(seen > 1000, "too few pairs listed: {seen}");
    }

    #[test]
    fn a_tree_keeps_every_triangle_once_in_its_frame_and_an_empty_one_lists_nothing() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let tris = sheet(6, false, &mut rng);
        let pose = Pose::from_array([5.0, 0.0, -1.0, 0.0, 0.2, 0.0]);
        let tree = TriangleTree::build(&tris, &pose);
        assert_eq!(tree.len(), tris.len());
        let mut seen: Vec<u32> = (0..tree.len() as u32).map(|i| tree.origin(i)).collect();
        seen.sort_unstable();
        assert!(seen.iter().enumerate().all(|(k, &o)| k as u32 == o));
        for i in 0..tree.len() as u32 {
            let want: Triangle = tris[tree.origin(i) as usize]
                .map(|c| (pose.rotation_matrix() * Vector3::from(c) + pose.translation()).into());
            assert_eq!(*tree.triangle(i), want);
        }
        // Balanced: a median split halves the triangles each level.
        let leaves = tris.len().div_ceil(LEAF_TRIANGLES);
        assert!(tree.depth() <= (leaves as f64).log2().ceil() as usize + 2);
        let empty = TriangleTree::build(&[], &Pose::identity());
        assert!(empty.is_empty() && empty.depth() == 0);
        let mut stack = TriangleTree::stack_for(&tree, &empty);
        let mut called = false;
        tree.near_leaf_pairs(
            &nalgebra::Matrix3::identity(),
            &Vector3::zeros(),
            &empty,
            1.0,
            &mut stack,
            |_, _| {
                called = true;
                true
            },
        );
        assert!(!called);
    }

    /// The box test taken axis by axis answers as the six face axes taken whole do (the turn
    /// and offset in the object box's axes first, as the descent once did), on random boxes,
    /// thin ones, turned, swept or not, at random margins; and a pair it parts has no points
    /// within the margin (sampled in both boxes, along the sweep).
    #[test]
    fn the_box_test_axis_by_axis_parts_boxes_as_the_whole_test_does() {
        // The six face axes, taken whole: `d` and `r` in the object box's axes.
        fn whole(
            b: (&Matrix3<f64>, &Vector3<f64>, &[f64; 3]),
            a: (&Matrix3<f64>, &Vector3<f64>, &[f64; 3]),
            sweep: &Vector3<f64>,
            margin: f64,
        ) -> (bool, f64) {
            let turn = b.0.transpose() * a.0;
            let along = b.0.transpose() * sweep;
            let d = b.0.transpose() * (a.1 - b.1) + 0.5 * along;
            let abs = turn.map(|x| x.abs() + 1e-12);
            let hb = b.2.map(|h| h + margin);
            // The closest call to a verdict (how far the deciding sides are apart).
            let mut closest = f64::INFINITY;
            let mut apart = false;
            for i in 0..3 {
                let ra = (0..3).map(|j| a.2[j] * abs[(i, j)]).sum::<f64>();
                let side = hb[i] + ra + 0.5 * along[i].abs() - d[i].abs();
                closest = closest.min(side.abs());
                apart |= side < 0.0;
            }
            for j in 0..3 {
                let rb = (0..3).map(|i| hb[i] * abs[(i, j)]).sum::<f64>();
                let s = (0..3).map(|i| d[i] * turn[(i, j)]).sum::<f64>();
                let reach = 0.5 * turn.column(j).dot(&along).abs();
                let side = a.2[j] + reach + rb - s.abs();
                closest = closest.min(side.abs());
                apart |= side < 0.0;
            }
            (apart, closest)
        }
        let mut rng = ChaCha8Rng::seed_from_u64(41);
        let (mut parted, mut met) = (0, 0);
        for case in 0..20_000 {
            let turned = |rng: &mut ChaCha8Rng| {
                let r = |rng: &mut ChaCha8Rng| rng.random_range(-3.2..3.2);
                Pose::from_array([0.0, 0.0, 0.0, r(rng), r(rng), r(rng)]).rotation_matrix()
            };
            let (ra, rb) = (turned(&mut rng), turned(&mut rng));
            let half = |rng: &mut ChaCha8Rng| -> [f64; 3] {
                std::array::from_fn(|_| {
                    if rng.random_bool(0.2) {
                        0.0
                    } else {
                        rng.random_range(0.0..2.0)
                    }
                })
            };
            let (ha, hb) = (half(&mut rng), half(&mut rng));
            let ca = Vector3::from(std::array::from_fn::<f64, 3, _>(|_| {
                rng.random_range(-4.0..4.0)
            }));
            let cb = Vector3::from(std::array::from_fn::<f64, 3, _>(|_| {
                rng.random_range(-1.0..1.0)
            }));
            let sweep = if case % 2 == 0 {
                Vector3::zeros()
            } else {
                Vector3::from(std::array::from_fn::<f64, 3, _>(|_| {
                    rng.random_range(-2.0..2.0)
                }))
            };
            let margin = rng.random_range(0.0..0.5);
            let centre_b: [f64; 3] = cb.into();
            let lazy = posed_boxes_apart(
                (&rb, &centre_b, &hb),
                (&ra, &ca, &ha),
                (sweep != Vector3::zeros()).then_some(&sweep),
                margin,
            );
            let (reference, closest) = whole((&rb, &cb, &hb), (&ra, &ca, &ha), &sweep, margin);
            // (A verdict within roundings of its threshold may go either way.)
            if closest > 1e-9 {
                assert_eq!(lazy, reference, "case {case}");
            }
            if !lazy {
                met += 1;
                continue;
            }
            parted += 1;
            let point = |rng: &mut ChaCha8Rng, r: &Matrix3<f64>, c: &Vector3<f64>, h: &[f64; 3]| {
                let local = Vector3::from(std::array::from_fn::<f64, 3, _>(|k| {
                    h[k] * rng.random_range(-1.0..=1.0)
                }));
                c + r * local
            };
            for _ in 0..20 {
                let on_sweep = sweep * rng.random_range(0.0..=1.0);
                let p = point(&mut rng, &ra, &ca, &ha) + on_sweep;
                let q = point(&mut rng, &rb, &cb, &hb);
                assert!(
                    (p - q).norm() > margin - 1e-9,
                    "case {case}: points {} apart, margin {margin}",
                    (p - q).norm()
                );
            }
        }
        // Both verdicts were tested many times.
        assert!(parted > 2_000 && met > 2_000, "parted {parted}, met {met}");
    }
}
