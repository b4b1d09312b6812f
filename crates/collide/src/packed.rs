//! [`PackedTree`]: a sphere-tree repacked for traversal (used slots only, SoA, children
//! contiguous, leaf flag precomputed).

use nalgebra::Vector3;
use spheretree::SphereTree;

use crate::{CollideError, FaceCut, Pose};

/// A sphere in single precision (mm): the traversal's pruning test.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C, align(16))]
pub(crate) struct Sphere32 {
    pub(crate) c: [f32; 3],
    pub(crate) r: f32,
}

/// What a split needs of a node besides its sphere: its children and its leaf box (packing
/// frame, mm; half-extents rounded up), in 32 bytes.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C, align(32))]
pub(crate) struct Node32 {
    pub(crate) first_child: u32,
    pub(crate) child_count: u32,
    pub(crate) box_c: [f32; 3],
    pub(crate) box_h: [f32; 3],
}

/// `v` in `f32`, never below `v` (a radius or half-extent that stays conservative).
#[inline]
pub(crate) fn round_up(v: f64) -> f32 {
    let f = v as f32;
    if (f as f64) < v {
        f.next_up()
    } else {
        f
    }
}

/// Nodes per chunk of [`PackedTree::warm_chunk`] (~80 kB: a few µs from memory).
pub const WARM_CHUNK_NODES: usize = 1024;

/// `node_of_slot` of an unused slot.
const NO_NODE: u32 = u32::MAX;

/// A [`SphereTree`] repacked for fast traversal.
///
/// Only used slots are kept, renumbered breadth-first so that the used children of every node
/// are contiguous (`first_child[n] .. first_child[n] + child_count[n]`). Centres and radii are
/// stored as separate arrays (structure of arrays). A node with `child_count == 0` is a leaf in
/// the sense of [`SphereTree::is_leaf`] (a used slot with no used child), whichever level it sits
/// on. [`PackedTree::slot`] maps a packed node back to its slot in the original tree.
///
/// Object trees are packed with their fixed pose applied (`world_from_object`), so their
/// centres are in world coordinates; tool trees are packed in the tool frame and posed at query
/// time.
///
/// The bounding rule "each parent contains its children" is checked on construction; it makes
/// pruning by parent overlap exact.
#[derive(Clone, Debug)]
pub struct PackedTree {
    pub(crate) x: Vec<f64>,
    pub(crate) y: Vec<f64>,
    pub(crate) z: Vec<f64>,
    pub(crate) r: Vec<f64>,
    pub(crate) first_child: Vec<u32>,
    pub(crate) child_count: Vec<u32>,
    pub(crate) slot: Vec<u32>,
    /// Axis-aligned box (packing frame) of every leaf sphere under a node: centre and
    /// half-extents, mm. Much tighter than the node's sphere on flat parts, where a sphere
    /// bulges far beyond the face it covers; the traversal uses it to prune node pairs.
    pub(crate) box_center: Vec<[f64; 3]>,
    pub(crate) box_half: Vec<[f64; 3]>,
    /// The traversal's hot data in single precision, one record per node so that a split
    /// reads its children's spheres from consecutive memory (half the bytes of the `f64`
    /// arrays): centres rounded to nearest, radii and box half-extents rounded up. Tests in
    /// `f32` are made conservative by [`PackedTree::round_slack`]; every reported pair is
    /// decided in `f64`.
    pub(crate) sphere32: Vec<Sphere32>,
    pub(crate) node32: Vec<Node32>,
    /// The largest `|coordinate| + radius` of any node in the packing frame (mm): the scale of
    /// the `f32` rounding errors.
    pub(crate) extent: f64,
    /// The face cut of every node (world for objects, tool frame for the tool), from the
    /// tree's [`spheretree::FaceCap`]s; `None` where the leaf has none (and on inner nodes).
    /// Empty when no leaf is cut.
    pub(crate) cut_of: Vec<[u32; 2]>,
    /// The cuts `cut_of` points into (a range per node); 8 bytes per node keep the hot loop's
    /// lookups in cache.
    pub(crate) cut_list: Vec<FaceCut>,
    /// Each node's own cuts (from its tree's caps), by the same scheme; a leaf's cuts in use
    /// (`cut_of`) add its ancestors' whose planes cross it ([`PackedTree::fit_face_cuts`]).
    own_cut_of: Vec<[u32; 2]>,
    own_cuts: Vec<FaceCut>,
    /// The packed node of every used slot of the original tree (`u32::MAX` for unused ones),
    /// when the tree has cuts: a neighbour list finds a pair's cuts by its object slot.
    pub(crate) node_of_slot: Vec<u32>,
    pub(crate) leaf_count: usize,
    pub(crate) max_children: usize,
    pub(crate) levels: u32,
}

impl PackedTree {
    /// Packs `tree` in its own frame (identity pose): use this for the tool, and for objects
    /// whose pose is the identity.
    ///
    /// Errors if the root is unused, a value is not finite, a used slot has an unused parent,
    /// or a parent does not contain a child (beyond `1e-9` relative to the root radius; call
    /// [`SphereTree::enforce_containment`] first on trees from files that do not keep that rule).
    pub fn new(tree: &SphereTree) -> Result<Self, CollideError> {
        Self::with_pose(tree, &Pose::identity())
    }

    /// Packs `tree` with the fixed pose `world_from_object` (mm, rad) applied to its centres.
    /// Same errors as [`PackedTree::new`].
    pub fn with_pose(tree: &SphereTree, world_from_object: &Pose) -> Result<Self, CollideError> {
        if !world_from_object.is_finite() {
            return Err(CollideError::NonFinitePose);
        }
        let root_r = tree.spheres().first().map_or(0.0, |s| s.radius);
        let tol = 1e-9 * root_r.abs().max(1.0);
        tree.validate(tol)
            .map_err(|e| CollideError::InvalidTree(e.to_string()))?;

        let rot = world_from_object.rotation_matrix();
        let t = world_from_object.translation();
        let n_used = tree.spheres().iter().filter(|s| s.is_used()).count();
        let mut packed = PackedTree {
            x: Vec::with_capacity(n_used),
            y: Vec::with_capacity(n_used),
            z: Vec::with_capacity(n_used),
            r: Vec::with_capacity(n_used),
            first_child: Vec::with_capacity(n_used),
            child_count: Vec::with_capacity(n_used),
            slot: Vec::with_capacity(n_used),
            box_center: Vec::new(),
            box_half: Vec::new(),
            sphere32: Vec::new(),
            node32: Vec::new(),
            extent: 0.0,
            cut_of: Vec::new(),
            cut_list: Vec::new(),
            own_cut_of: Vec::new(),
            own_cuts: Vec::new(),
            node_of_slot: Vec::new(),
            leaf_count: 0,
            max_children: 0,
            levels: tree.levels(),
        };
        // Breadth-first over used slots: the queue is the packed order itself.
        packed.push_slot(tree, 0, &rot, &t);
        let mut head = 0;
        while head < packed.slot.len() {
            let s = packed.slot[head] as usize;
            let first = packed.slot.len() as u32;
            let mut count = 0u32;
            for c in tree.children(s) {
                if tree.sphere(c).is_used() {
                    packed.push_slot(tree, c, &rot, &t);
                    count += 1;
                }
            }
            packed.first_child[head] = if count > 0 { first } else { 0 };
            packed.child_count[head] = count;
            packed.max_children = packed.max_children.max(count as usize);
            if count == 0 {
                packed.leaf_count += 1;
            }
            head += 1;
        }
        packed.compute_boxes();
        packed.compute_single();
        packed.own_cut_of = std::mem::take(&mut packed.cut_of);
        packed.own_cuts = std::mem::take(&mut packed.cut_list);
        packed.fit_face_cuts();
        Ok(packed)
    }

    /// Fills the leaf-sphere boxes bottom-up (children come after their parent in the packed
    /// order, so a reverse sweep sees every child before its parent).
    fn compute_boxes(&mut self) {
        let n = self.len();
        let mut lo = vec![[f64::INFINITY; 3]; n];
        let mut hi = vec![[f64::NEG_INFINITY; 3]; n];
        for i in (0..n).rev() {
            if self.child_count[i] == 0 {
                let c = [self.x[i], self.y[i], self.z[i]];
                for k in 0..3 {
                    lo[i][k] = c[k] - self.r[i];
                    hi[i][k] = c[k] + self.r[i];
                }
            } else {
                for ch in self.children(i) {
                    for k in 0..3 {
                        lo[i][k] = lo[i][k].min(lo[ch][k]);
                        hi[i][k] = hi[i][k].max(hi[ch][k]);
                    }
                }
            }
        }
        self.box_center = (0..n)
            .map(|i| std::array::from_fn(|k| 0.5 * (lo[i][k] + hi[i][k])))
            .collect();
        self.box_half = (0..n)
            .map(|i| std::array::from_fn(|k| 0.5 * (hi[i][k] - lo[i][k])))
            .collect();
    }

    /// Fills the `f32` records of the nodes and the tree's extent.
    fn compute_single(&mut self) {
        self.sphere32 = (0..self.len())
            .map(|i| Sphere32 {
                c: [self.x[i] as f32, self.y[i] as f32, self.z[i] as f32],
                r: round_up(self.r[i]),
            })
            .collect();
        self.node32 = (0..self.len())
            .map(|i| Node32 {
                first_child: self.first_child[i],
                child_count: self.child_count[i],
                box_c: self.box_center[i].map(|v| v as f32),
                box_h: self.box_half[i].map(round_up),
            })
            .collect();
        self.extent = (0..self.len())
            .map(|i| self.x[i].abs().max(self.y[i].abs()).max(self.z[i].abs()) + self.r[i])
            .fold(0.0, f64::max);
    }

    /// An allowance (mm) that makes a sphere test in `f32` conservative for trees of extent
    /// `extent` (mm, coordinates plus radii, [`PackedTree`] packing frames or posed): about
    /// 80 units in the last place of the largest number involved, far above the rounding of
    /// the centres, the difference, the squares and their sum (a few units each).
    #[inline]
    pub(crate) fn round_slack(extent: f64) -> f64 {
        1e-5 * extent.max(1.0)
    }

    /// The axis-aligned box (packing frame) of all leaf spheres under node `n`: centre and
    /// half-extents, mm.
    #[inline]
    pub fn leaf_box(&self, n: usize) -> ([f64; 3], [f64; 3]) {
        (self.box_center[n], self.box_half[n])
    }

    fn push_slot(
        &mut self,
        tree: &SphereTree,
        s: usize,
        rot: &nalgebra::Matrix3<f64>,
        t: &Vector3<f64>,
    ) {
        let sp = tree.sphere(s);
        let c = rot * Vector3::from(sp.center) + t;
        let caps = tree.cap(s);
        if !caps.is_empty() {
            if self.cut_of.is_empty() {
                self.cut_of = vec![[0, 0]; self.x.len()];
                self.node_of_slot = vec![NO_NODE; tree.len()];
                for (n, &slot) in self.slot.iter().enumerate() {
                    self.node_of_slot[slot as usize] = n as u32;
                }
            }
            let first = self.cut_list.len() as u32;
            for cap in caps {
                let n = rot * Vector3::from(cap.normal);
                let c = rot * Vector3::from(cap.center) + t;
                self.cut_list.push(FaceCut {
                    normal: n.into(),
                    // n_w . (R x + t) = n . x + n_w . t.
                    offset: cap.offset + n.dot(t),
                    center: c.into(),
                    reach: cap.reach,
                });
            }
            self.cut_of.push([first, self.cut_list.len() as u32]);
        } else if !self.cut_of.is_empty() {
            self.cut_of.push([0, 0]);
        }
        if !self.node_of_slot.is_empty() {
            self.node_of_slot[s] = self.x.len() as u32;
        }
        self.x.push(c.x);
        self.y.push(c.y);
        self.z.push(c.z);
        self.r.push(sp.radius);
        self.first_child.push(0);
        self.child_count.push(0);
        self.slot.push(s as u32);
    }

    /// The face cuts of packed node `n` (world for objects packed with their pose).
    #[inline]
    pub fn face_cuts(&self, n: usize) -> &[FaceCut] {
        self.cuts(n)
    }

    /// Number of nodes with a face cut.
    pub fn face_cut_count(&self) -> usize {
        self.cut_of.iter().filter(|r| r[1] > r[0]).count()
    }

    /// Forgets the face cuts: every leaf stands for its whole sphere again (the paper's
    /// sphere-trees).
    pub fn drop_face_cuts(&mut self) {
        self.cut_of = Vec::new();
        self.cut_list = Vec::new();
        self.own_cut_of = Vec::new();
        self.own_cuts = Vec::new();
        self.node_of_slot = Vec::new();
    }

    /// Sets each node's cuts in use: an inner node's own (its face stands for its subtree when a
    /// tool leaf is above its disc); a leaf's own, then every ancestor's whose plane crosses
    /// the leaf's ball, without repeats. The leaf's sphere lies inside each ancestor's (trees
    /// keep parents around children), so the ancestor's rule (all surface in its ball below the
    /// plane) holds for the leaf: the plane trims the leaf's lens. The lens then lies inside
    /// every half-space a merged pair above it can stand for, so a pose proven free against one
    /// is free against the other (docs/DESIGN.md §Face caps).
    fn fit_face_cuts(&mut self) {
        self.cut_of = Vec::new();
        self.cut_list = Vec::new();
        if self.own_cut_of.is_empty() {
            return;
        }
        let n = self.len();
        let mut parent = vec![u32::MAX; n];
        for p in 0..n {
            for c in self.children(p) {
                parent[c] = p as u32;
            }
        }
        let mut cut_of = vec![[0u32, 0u32]; n];
        let mut list: Vec<FaceCut> = Vec::new();
        let mut mine: Vec<FaceCut> = Vec::new();
        for node in 0..n {
            mine.clear();
            let [a, b] = self.own_cut_of[node];
            mine.extend_from_slice(&self.own_cuts[a as usize..b as usize]);
            if self.child_count[node] == 0 {
                let c = [self.x[node], self.y[node], self.z[node]];
                let mut up = parent[node];
                while up != u32::MAX {
                    let [a, b] = self.own_cut_of[up as usize];
                    for cut in &self.own_cuts[a as usize..b as usize] {
                        let crosses = cut.place(c).0.abs() < self.r[node];
                        if crosses && !mine.contains(cut) {
                            mine.push(*cut);
                        }
                    }
                    up = parent[up as usize];
                }
            }
            let first = list.len() as u32;
            list.extend_from_slice(&mine);
            cut_of[node] = [first, list.len() as u32];
        }
        self.cut_of = cut_of;
        self.cut_list = list;
    }

    /// Most cuts a leaf carries (its own and its ancestors' crossing it).
    pub(crate) fn max_leaf_cuts(&self) -> usize {
        (0..self.len())
            .filter(|&n| self.child_count[n] == 0)
            .map(|n| self.cuts(n).len())
            .max()
            .unwrap_or(0)
    }

    /// The face cuts of node `n` (the traversal's lookup).
    #[inline(always)]
    pub(crate) fn cuts(&self, n: usize) -> &[FaceCut] {
        match self.cut_of.get(n) {
            Some(&[a, b]) => self.cut_list.get(a as usize..b as usize).unwrap_or(&[]),
            None => &[],
        }
    }

    /// The face cuts of the packed node at `slot` of the original tree.
    pub(crate) fn cuts_of_slot(&self, slot: usize) -> &[FaceCut] {
        match self.node_of_slot.get(slot) {
            Some(&n) if n != NO_NODE => self.cuts(n as usize),
            _ => &[],
        }
    }

    /// Number of packed nodes (= used slots of the original tree).
    #[inline]
    pub fn len(&self) -> usize {
        self.r.len()
    }

    /// True when there is no node (never: the root is always used).
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.r.is_empty()
    }

    /// Number of leaves (used slots without used children).
    #[inline]
    pub fn leaf_count(&self) -> usize {
        self.leaf_count
    }

    /// Levels of the original tree (`depth + 1`).
    #[inline]
    pub fn levels(&self) -> u32 {
        self.levels
    }

    /// Largest number of used children of any node.
    #[inline]
    pub fn max_children(&self) -> usize {
        self.max_children
    }

    /// Slot index in the original [`SphereTree`] of packed node `n`.
    #[inline]
    pub fn slot(&self, n: usize) -> usize {
        self.slot[n] as usize
    }

    /// Centre of packed node `n` in the packing frame (mm): the tree's own frame for
    /// [`PackedTree::new`], the world for [`PackedTree::with_pose`].
    #[inline]
    pub fn center(&self, n: usize) -> [f64; 3] {
        [self.x[n], self.y[n], self.z[n]]
    }

    /// Radius of packed node `n` (mm).
    #[inline]
    pub fn radius(&self, n: usize) -> f64 {
        self.r[n]
    }

    /// True when packed node `n` is a leaf.
    #[inline]
    pub fn is_leaf(&self, n: usize) -> bool {
        self.child_count[n] == 0
    }

    /// Packed indices of `n`'s used children (empty for a leaf).
    #[inline]
    pub fn children(&self, n: usize) -> std::ops::Range<usize> {
        let f = self.first_child[n] as usize;
        f..f + self.child_count[n] as usize
    }

    /// An upper bound (mm) on how far any point of this tree's geometry moves while the
    /// configuration goes along the straight segment from `a` to `b` (mm, rad), measured from
    /// either end: `|t_a - t_b| + (|dgamma| + |dbeta| + |dalpha|) * rho`, with `rho` the largest
    /// distance from the tool origin to a point in the root sphere (each partial of `R` has
    /// spectral norm 1, so `R` is 1-Lipschitz in each angle).
    ///
    /// Use it as the traversal margin at `b = q_h` with `a = q_g_prev` (anti-tunnelling): every
    /// leaf pair that touches anywhere on the segment has gap at most this at `q_h`. Valid for a
    /// tree packed with [`PackedTree::new`] (the tool's own frame).
    ///
    /// # Real-time
    /// No allocation, no panic, constant time.
    pub fn sweep_margin(&self, a: &Pose, b: &Pose) -> f64 {
        let d = a.q - b.q;
        let dt = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        dt + (d[3].abs() + d[4].abs() + d[5].abs()) * self.reach()
    }

    /// Reads chunk `k` (nodes `k·WARM_CHUNK_NODES ..`, breadth-first: the top levels first) of
    /// the arrays a traversal reads (pruning spheres, node records, centres and radii) into the
    /// running checksum `acc`, bringing them into cache. False past the last node.
    ///
    /// # Real-time
    /// No allocation; reads about 80 bytes per node of the chunk.
    pub fn warm_chunk(&self, k: usize, acc: &mut u32) -> bool {
        let first = k.saturating_mul(WARM_CHUNK_NODES);
        if first >= self.sphere32.len() {
            return false;
        }
        let end = (first + WARM_CHUNK_NODES).min(self.sphere32.len());
        let mut a = *acc;
        for n in first..end {
            a = a
                .wrapping_add(self.sphere32[n].r.to_bits())
                .wrapping_add(self.node32[n].first_child)
                .wrapping_add(self.x[n].to_bits() as u32)
                .wrapping_add(self.y[n].to_bits() as u32)
                .wrapping_add(self.z[n].to_bits() as u32)
                .wrapping_add(self.r[n].to_bits() as u32);
        }
        *acc = a;
        true
    }

    /// The largest distance (mm) from the packing frame's origin to a point of the root sphere:
    /// for a tool packed with [`PackedTree::new`], how far any of its geometry lies from the
    /// tool origin (a rotation by `theta` rad moves no point more than `theta * reach`).
    pub fn reach(&self) -> f64 {
        if self.is_empty() {
            0.0
        } else {
            (self.x[0].powi(2) + self.y[0].powi(2) + self.z[0].powi(2)).sqrt() + self.r[0].max(0.0)
        }
    }

    /// Packed indices of all leaves.
    pub fn leaves(&self) -> impl Iterator<Item = usize> + '_ {
        (0..self.len()).filter(move |&n| self.is_leaf(n))
    }
}
