//! The flat, breadth-first sphere-tree type and its indexing.
//!
//! A tree with branching `B` and `levels` levels is a *full* B-ary tree stored in breadth-first
//! order: node `n`'s children are `n*B+1 ..= n*B+B`, level `l` holds slots
//! `(B^l - 1)/(B - 1) .. (B^(l+1) - 1)/(B - 1)`. A slot may be unused (no geometry there);
//! unused slots have a negative radius.
//!
//! Bounding rule kept by every builder of this crate and checked by [`SphereTree::validate`]:
//! each used parent sphere **contains** every used child sphere
//! (`|c_child - c_parent| + r_child <= r_parent + tol`). This is what makes pruning on parent
//! overlap exact: if two parents do not overlap, no pair of their descendants can.

use crate::TreeError;

/// A sphere: centre (mm, or the mesh's units) and radius (same units). `radius < 0` marks an
/// unused slot.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    /// Centre, in the tree's frame (mesh units).
    pub center: [f64; 3],
    /// Radius, in the tree's frame's units; negative for an unused slot.
    pub radius: f64,
}

impl Sphere {
    /// The marker stored in unused slots.
    pub const UNUSED: Sphere = Sphere {
        center: [0.0; 3],
        radius: -1.0,
    };

    /// A sphere at `center` with `radius` (units of the tree's frame).
    pub fn new(center: [f64; 3], radius: f64) -> Self {
        Self { center, radius }
    }

    /// True when the slot holds geometry (`radius >= 0`).
    #[inline]
    pub fn is_used(&self) -> bool {
        self.radius >= 0.0
    }
}

/// A node's face cap: the node stands for its sphere cut by the half-space
/// `normal . x <= offset` (tree frame), because every point of the mesh's surface inside the
/// node's sphere lies in that half-space (docs/DESIGN.md §Face caps). A node may have up to
/// [`MAX_CAPS`]; they hold for its whole subtree, and its children carry them too.
///
/// On a flat face this makes the node's outer boundary the face itself instead of the sphere's
/// bulge: a tool sliding over the face meets a plane, not a layer of sphere bumps.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaceCap {
    /// Unit outward normal of the face (tree frame).
    pub normal: [f64; 3],
    /// The plane's offset `normal . x` (mm, tree frame units); the solid side is below it.
    pub offset: f64,
    /// Centre of a disc on the face (mm, tree frame; on the plane).
    pub center: [f64; 3],
    /// Radius (mm) of that disc, which lies inside the mesh's flat face: a point above the
    /// plane whose foot falls in it is above the face itself.
    pub reach: f64,
}

/// Most face caps one node carries.
pub const MAX_CAPS: usize = 2;

impl FaceCap {
    /// True when the cap is usable: finite numbers, a unit normal (to `1e-9`), `reach >= 0`.
    pub fn is_valid(&self) -> bool {
        let n = self.normal;
        let len2 = n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
        n.iter().chain(&self.center).all(|v| v.is_finite())
            && (len2 - 1.0).abs() <= 2e-9
            && self.offset.is_finite()
            && self.reach.is_finite()
            && self.reach >= 0.0
    }
}

/// A full B-ary sphere-tree stored flat in breadth-first order (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct SphereTree {
    branching: u32,
    levels: u32,
    spheres: Vec<Sphere>,
    /// Face caps by slot (empty: none; else one list per slot, at most [`MAX_CAPS`] each).
    caps: Vec<Vec<FaceCap>>,
}

/// Number of slots in a full tree with `levels` levels and branching `branching`
/// (`sum_{l < levels} B^l`), or `None` on overflow.
pub fn slot_count(levels: u32, branching: u32) -> Option<usize> {
    let b = branching as usize;
    if b < 2 {
        // Closed form: the loop below would run `levels` (up to 2^32) times without overflowing.
        return Some(if b == 0 { levels.min(1) } else { levels } as usize);
    }
    let mut total: usize = 0;
    let mut width: usize = 1;
    for _ in 0..levels {
        total = total.checked_add(width)?;
        width = width.checked_mul(b)?;
    }
    Some(total)
}

impl SphereTree {
    /// A tree of `levels` levels, branching `branching`, with every slot unused.
    ///
    /// Errors if `levels == 0`, `branching < 2` or the slot count overflows.
    pub fn new_unused(levels: u32, branching: u32) -> Result<Self, TreeError> {
        let n = Self::check_shape(levels, branching)?;
        Ok(Self {
            branching,
            levels,
            spheres: vec![Sphere::UNUSED; n],
            caps: Vec::new(),
        })
    }

    /// A tree from its flat breadth-first slots; `spheres.len()` must equal
    /// [`slot_count`]`(levels, branching)`.
    pub fn from_slots(
        levels: u32,
        branching: u32,
        spheres: Vec<Sphere>,
    ) -> Result<Self, TreeError> {
        let n = Self::check_shape(levels, branching)?;
        if spheres.len() != n {
            return Err(TreeError::SlotCount {
                expected: n,
                found: spheres.len(),
            });
        }
        Ok(Self {
            branching,
            levels,
            spheres,
            caps: Vec::new(),
        })
    }

    /// The face caps by slot: empty when the tree has none, else one list per slot.
    #[inline]
    pub fn caps(&self) -> &[Vec<FaceCap>] {
        &self.caps
    }

    /// The face caps of slot `n` (empty if none).
    #[inline]
    pub fn cap(&self, n: usize) -> &[FaceCap] {
        self.caps.get(n).map_or(&[], Vec::as_slice)
    }

    /// Sets the face caps (one list per slot; an empty vector removes them). Errors unless
    /// every cap is valid ([`FaceCap::is_valid`]), sits on a used slot, and no slot has more
    /// than [`MAX_CAPS`]. A cap holds for the node's whole subtree: all of the surface inside
    /// its sphere is below the plane.
    pub fn set_caps(&mut self, caps: Vec<Vec<FaceCap>>) -> Result<(), TreeError> {
        if !caps.is_empty() && caps.len() != self.spheres.len() {
            return Err(TreeError::SlotCount {
                expected: self.spheres.len(),
                found: caps.len(),
            });
        }
        for (n, list) in caps.iter().enumerate() {
            if list.len() > MAX_CAPS {
                return Err(TreeError::Invalid(format!(
                    "slot {n} has {} face caps (at most {MAX_CAPS})",
                    list.len()
                )));
            }
            if let Some(cap) = list.iter().find(|c| !c.is_valid()) {
                return Err(TreeError::Invalid(format!(
                    "slot {n} has a bad face cap: {cap:?}"
                )));
            }
            if !list.is_empty() && !self.spheres[n].is_used() {
                return Err(TreeError::Invalid(format!(
                    "slot {n} has a face cap but is unused"
                )));
            }
        }
        self.caps = caps;
        Ok(())
    }

    fn check_shape(levels: u32, branching: u32) -> Result<usize, TreeError> {
        if levels == 0 || branching < 2 {
            return Err(TreeError::Shape { levels, branching });
        }
        match slot_count(levels, branching) {
            Some(n) if n <= u32::MAX as usize => Ok(n),
            _ => Err(TreeError::Shape { levels, branching }),
        }
    }

    /// Branching factor B (children per node).
    #[inline]
    pub fn branching(&self) -> u32 {
        self.branching
    }

    /// Number of levels (`depth + 1`).
    #[inline]
    pub fn levels(&self) -> u32 {
        self.levels
    }

    /// Depth (`levels - 1`): the root is at depth 0.
    #[inline]
    pub fn depth(&self) -> u32 {
        self.levels - 1
    }

    /// All slots, breadth-first.
    #[inline]
    pub fn spheres(&self) -> &[Sphere] {
        &self.spheres
    }

    /// All slots, breadth-first, mutable (builders fill them in).
    #[inline]
    pub fn spheres_mut(&mut self) -> &mut [Sphere] {
        &mut self.spheres
    }

    /// Number of slots (used or not).
    #[inline]
    pub fn len(&self) -> usize {
        self.spheres.len()
    }

    /// True when the tree has no slot (never, for a validly shaped tree).
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.spheres.is_empty()
    }

    /// The sphere in slot `n`.
    #[inline]
    pub fn sphere(&self, n: usize) -> &Sphere {
        &self.spheres[n]
    }

    /// Slot range of level `level` (0 = root). Empty if `level >= levels`.
    pub fn level_range(&self, level: u32) -> std::ops::Range<usize> {
        if level >= self.levels {
            return self.len()..self.len();
        }
        let start = slot_count(level, self.branching).unwrap_or(0);
        let end = slot_count(level + 1, self.branching).unwrap_or(0);
        start..end
    }

    /// The level of slot `n`.
    pub fn level_of(&self, n: usize) -> u32 {
        let mut level = 0;
        while self.level_range(level).end <= n {
            level += 1;
        }
        level
    }

    /// Slot range of `n`'s children; empty when `n` is on the last level.
    #[inline]
    pub fn children(&self, n: usize) -> std::ops::Range<usize> {
        let b = self.branching as usize;
        let first = n * b + 1;
        if first >= self.len() {
            return self.len()..self.len();
        }
        first..first + b
    }

    /// Parent slot of `n` (`None` for the root).
    #[inline]
    pub fn parent(&self, n: usize) -> Option<usize> {
        if n == 0 {
            None
        } else {
            Some((n - 1) / self.branching as usize)
        }
    }

    /// True when slot `n` is used and has no used child: a leaf of the geometry. Leaves are
    /// usually on the last level, but a file (e.g. from the Bradshaw toolkit) may stop a branch
    /// early.
    #[inline]
    pub fn is_leaf(&self, n: usize) -> bool {
        self.spheres[n].is_used() && self.children(n).all(|c| !self.spheres[c].is_used())
    }

    /// Indices of all leaves ([`SphereTree::is_leaf`]).
    pub fn leaves(&self) -> impl Iterator<Item = usize> + '_ {
        (0..self.len()).filter(move |&n| self.is_leaf(n))
    }

    /// Checks the structural invariants: finite centres and radii, a used root, every used
    /// non-root slot has a used parent, and every parent contains its children up to
    /// `tol` (same units as the tree). Builders call this after every build.
    pub fn validate(&self, tol: f64) -> Result<(), TreeError> {
        if !self.spheres.first().is_some_and(|s| s.is_used()) {
            return Err(TreeError::Invalid("the root slot is unused".into()));
        }
        for (n, s) in self.spheres.iter().enumerate() {
            if !s.center.iter().all(|v| v.is_finite()) || !s.radius.is_finite() {
                return Err(TreeError::Invalid(format!("slot {n} is not finite: {s:?}")));
            }
            if !s.is_used() {
                continue;
            }
            if let Some(p) = self.parent(n) {
                let ps = &self.spheres[p];
                if !ps.is_used() {
                    return Err(TreeError::Invalid(format!(
                        "slot {n} is used but its parent {p} is not"
                    )));
                }
                let d = dist(&s.center, &ps.center);
                if d + s.radius > ps.radius + tol {
                    return Err(TreeError::Invalid(format!(
                        "slot {n} pokes out of its parent {p} by {:.6}",
                        d + s.radius - ps.radius
                    )));
                }
            }
        }
        Ok(())
    }

    /// Makes every parent contain its children (growing parents bottom-up, never moving
    /// centres). Used on trees read from files that do not keep that rule, so pruning stays
    /// exact. Returns the largest growth applied to any radius.
    pub fn enforce_containment(&mut self) -> f64 {
        let mut max_growth: f64 = 0.0;
        for n in (0..self.len()).rev() {
            let Some(p) = self.parent(n) else { continue };
            let s = self.spheres[n];
            if !s.is_used() || !self.spheres[p].is_used() {
                continue;
            }
            let need = dist(&s.center, &self.spheres[p].center) + s.radius;
            if need > self.spheres[p].radius {
                max_growth = max_growth.max(need - self.spheres[p].radius);
                self.spheres[p].radius = need;
            }
        }
        max_growth
    }

    /// Number of used slots on `level`.
    pub fn used_on_level(&self, level: u32) -> usize {
        self.spheres[self.level_range(level)]
            .iter()
            .filter(|s| s.is_used())
            .count()
    }
}

#[inline]
fn dist(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slot_counts_match_design() {
        assert_eq!(slot_count(5, 8), Some(4681));
        assert_eq!(slot_count(1, 8), Some(1));
        assert_eq!(slot_count(3, 2), Some(7));
    }

    #[test]
    fn indexing_is_breadth_first() {
        let t = SphereTree::new_unused(3, 8).unwrap();
        assert_eq!(t.children(0), 1..9);
        assert_eq!(t.children(1), 9..17);
        assert_eq!(t.children(9), 73..73);
        assert_eq!(t.parent(16), Some(1));
        assert_eq!(t.level_range(2), 9..73);
        assert_eq!(t.level_of(8), 1);
        assert_eq!(t.level_of(9), 2);
    }

    #[test]
    fn validate_catches_a_child_outside_its_parent() {
        let mut t = SphereTree::new_unused(2, 2).unwrap();
        t.spheres_mut()[0] = Sphere::new([0.0; 3], 1.0);
        t.spheres_mut()[1] = Sphere::new([0.5, 0.0, 0.0], 0.6);
        assert!(t.validate(1e-9).is_err());
        let growth = t.enforce_containment();
        assert!((growth - 0.1).abs() < 1e-12);
        t.validate(1e-9).unwrap();
        assert!(t.is_leaf(1));
        assert!(!t.is_leaf(2));
        assert!(!t.is_leaf(0));
    }

    #[test]
    fn bad_shapes_are_rejected() {
        assert!(SphereTree::new_unused(0, 8).is_err());
        assert!(SphereTree::new_unused(3, 1).is_err());
        assert!(SphereTree::from_slots(2, 2, vec![Sphere::UNUSED; 2]).is_err());
    }
}
