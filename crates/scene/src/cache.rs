//! On-disk cache of sphere-trees built from meshes, keyed by a hash of the mesh content, the
//! build parameters, the builder's version ([`spheretree::build::BUILDER_VERSION`]) and the
//! entry format's version ([`FORMAT_VERSION`]), so a second run of a scene starts without
//! rebuilding and a tree from an older builder is never reused.
//!
//! Location: `$HAPTIC6D_CACHE` if set (an empty variable counts as unset), else `$XDG_CACHE_HOME/haptic6d`, else
//! `~/.cache/haptic6d`. Files are `tree-<key>.bin`, written atomically, in a small binary
//! format (all integers and numbers little-endian):
//!
//! ```text
//! magic "H6DTREE4" | key length u32 | key bytes | levels u32 | branching u32
//! | per slot: x y z r as f64 (mm)
//! | cap count u32 | per cap, by non-decreasing slot: slot u32 | nx ny nz offset cx cy cz reach
//!   as f64
//! | content hash u64 = FNV-1a 64 of every byte before it
//! ```
//!
//! The caps are the tree's face caps ([`spheretree::FaceCap`]: unit normal, offset, disc
//! centre and reach in mm; at most [`spheretree::MAX_CAPS`] per slot); a tree without caps
//! stores a count of 0 (and reads back without caps).
//!
//! A corrupt, truncated, renamed (key mismatch) or edited (content hash mismatch) entry, or one
//! whose numbers are not finite, whose parents do not contain their children, or whose caps
//! are invalid ([`spheretree::FaceCap::is_valid`]), on an unused slot, repeated, too many for a
//! slot or out of order, is
//! rebuilt, never trusted. The hash guards against accidents (a disk error, a hand edit, a copy under
//! the wrong name), not against someone who recomputes it.

use std::path::{Path, PathBuf};

use mesh::TriMesh;
use spheretree::{FaceCap, Sphere, SphereTree};

/// Version of the cache entry format (the digit in the magic); folded into every key.
/// 3: face caps after the spheres; 4: several caps per slot, each with its disc's centre.
pub const FORMAT_VERSION: u32 = 4;

const MAGIC: &[u8; 8] = b"H6DTREE4";

/// Bytes of one stored cap: slot u32 and eight f64.
const CAP_BYTES: usize = 4 + 8 * 8;

/// FNV-1a, 64-bit: a stable (toolchain-independent) content hash.
#[derive(Clone, Copy, Debug)]
pub struct Fnv64(u64);

impl Default for Fnv64 {
    fn default() -> Self {
        Self(0xcbf2_9ce4_8422_2325)
    }
}

impl Fnv64 {
    /// Feeds bytes.
    pub fn write(&mut self, bytes: &[u8]) {
        for b in bytes {
            self.0 ^= u64::from(*b);
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }

    /// The hash so far.
    pub fn finish(&self) -> u64 {
        self.0
    }

    /// The FNV-1a 64 hash of `bytes` (the content hash of a cache entry).
    pub fn hash(bytes: &[u8]) -> u64 {
        let mut h = Self::default();
        h.write(bytes);
        h.finish()
    }
}

/// The cache key of a tree built from `mesh` (mm) with build parameters described by
/// `params` (any stable text, e.g. `"depth=4 branching=8 method=Tight"`) by today's builder
/// ([`spheretree::build::BUILDER_VERSION`]) in today's entry format ([`FORMAT_VERSION`]).
pub fn tree_key(mesh: &TriMesh, params: &str) -> String {
    key_for_builder(mesh, params, spheretree::build::BUILDER_VERSION)
}

/// [`tree_key`] for a given builder version.
fn key_for_builder(mesh: &TriMesh, params: &str, builder_version: u32) -> String {
    // Two differently seeded FNV streams make a 128-bit key: accidental collisions are moot.
    let mut a = Fnv64::default();
    let mut b = Fnv64(0x6c62_272e_07bb_0142);
    for h in [&mut a, &mut b] {
        h.write(b"haptic6d-tree\0");
        h.write(&FORMAT_VERSION.to_le_bytes());
        h.write(&builder_version.to_le_bytes());
        h.write(&(params.len() as u64).to_le_bytes());
        h.write(params.as_bytes());
        h.write(&(mesh.vertices.len() as u64).to_le_bytes());
        for v in &mesh.vertices {
            for c in v {
                h.write(&c.to_le_bytes());
            }
        }
        h.write(&(mesh.triangles.len() as u64).to_le_bytes());
        for t in &mesh.triangles {
            for i in t {
                h.write(&i.to_le_bytes());
            }
        }
    }
    format!("{:016x}{:016x}", a.finish(), b.finish())
}

/// Called with a label (which tree) and the completed fraction `0..=1` of a tree build.
pub type BuildProgress = std::sync::Arc<dyn Fn(&str, f64) + Send + Sync>;

/// A directory of cached trees (and an optional progress report for the builds it runs).
#[derive(Clone)]
pub struct TreeCache {
    dir: Option<PathBuf>,
    progress: Option<BuildProgress>,
}

impl std::fmt::Debug for TreeCache {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TreeCache")
            .field("dir", &self.dir)
            .field("progress", &self.progress.is_some())
            .finish()
    }
}

/// Whether a tree came from the cache or was built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CacheOutcome {
    /// Read from the cache.
    Hit,
    /// Built (and stored, when the cache is writable).
    Built,
}

impl TreeCache {
    /// The default cache location (see the module docs); disabled when no home is known.
    pub fn from_env() -> Self {
        // An empty variable counts as unset (the XDG rule), not as the current folder.
        let var = |name: &str| std::env::var_os(name).filter(|v| !v.is_empty());
        let dir = var("HAPTIC6D_CACHE")
            .map(PathBuf::from)
            .or_else(|| var("XDG_CACHE_HOME").map(|d| PathBuf::from(d).join("haptic6d")))
            .or_else(|| var("HOME").map(|h| PathBuf::from(h).join(".cache").join("haptic6d")));
        Self {
            dir,
            progress: None,
        }
    }

    /// The same cache, reporting tree-build progress to `progress`.
    pub fn with_progress(mut self, progress: BuildProgress) -> Self {
        self.progress = Some(progress);
        self
    }

    /// Reports the progress of the build of `label` (no-op without a reporter).
    pub fn report(&self, label: &str, fraction: f64) {
        if let Some(p) = &self.progress {
            p(label, fraction);
        }
    }

    /// A cache in `dir`.
    pub fn at(dir: impl Into<PathBuf>) -> Self {
        Self {
            dir: Some(dir.into()),
            progress: None,
        }
    }

    /// A cache that never stores anything.
    pub fn disabled() -> Self {
        Self {
            dir: None,
            progress: None,
        }
    }

    /// The cache directory, if any.
    pub fn dir(&self) -> Option<&Path> {
        self.dir.as_deref()
    }

    /// The tree for `key`, or `build()` it and store it. A failure to store is not an error
    /// (the run goes on without caching).
    pub fn get_or_build<E>(
        &self,
        key: &str,
        build: impl FnOnce() -> Result<SphereTree, E>,
    ) -> Result<(SphereTree, CacheOutcome), E> {
        if let Some(dir) = &self.dir {
            let path = dir.join(format!("tree-{key}.bin"));
            if let Ok(bytes) = std::fs::read(&path) {
                if let Some(tree) = decode(key, &bytes) {
                    return Ok((tree, CacheOutcome::Hit));
                }
            }
            let tree = build()?;
            let _ = crate::io::write_atomic(&path, &encode(key, &tree));
            return Ok((tree, CacheOutcome::Built));
        }
        Ok((build()?, CacheOutcome::Built))
    }
}

/// Serialises `tree` as the cache entry for `key` (see the module docs for the format).
pub fn encode(key: &str, tree: &SphereTree) -> Vec<u8> {
    let caps: Vec<(usize, &FaceCap)> = tree
        .caps()
        .iter()
        .enumerate()
        .flat_map(|(n, list)| list.iter().map(move |c| (n, c)))
        .collect();
    let mut out = Vec::with_capacity(32 + key.len() + tree.len() * 32 + caps.len() * CAP_BYTES);
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&(key.len() as u32).to_le_bytes());
    out.extend_from_slice(key.as_bytes());
    out.extend_from_slice(&tree.levels().to_le_bytes());
    out.extend_from_slice(&tree.branching().to_le_bytes());
    for s in tree.spheres() {
        for c in s.center {
            out.extend_from_slice(&c.to_le_bytes());
        }
        out.extend_from_slice(&s.radius.to_le_bytes());
    }
    out.extend_from_slice(&(caps.len() as u32).to_le_bytes());
    for (n, c) in caps {
        out.extend_from_slice(&(n as u32).to_le_bytes());
        for x in c
            .normal
            .into_iter()
            .chain([c.offset])
            .chain(c.center)
            .chain([c.reach])
        {
            out.extend_from_slice(&x.to_le_bytes());
        }
    }
    let hash = Fnv64::hash(&out);
    out.extend_from_slice(&hash.to_le_bytes());
    out
}

/// Reads the cache entry for `key`; `None` unless the bytes are a valid entry for that key:
/// right magic and key, intact content hash, a slot count matching the shape, every number
/// finite, every used child inside its parent (to `1e-9` of the root radius), and every cap
/// valid, on a used slot, listed once by non-decreasing slot, at most
/// [`spheretree::MAX_CAPS`] per slot.
pub fn decode(key: &str, bytes: &[u8]) -> Option<SphereTree> {
    let (content, hash) = bytes.split_at_checked(bytes.len().checked_sub(8)?)?;
    if Fnv64::hash(content) != u64::from_le_bytes(hash.try_into().ok()?) {
        return None;
    }
    let rest = content.strip_prefix(MAGIC.as_slice())?;
    let key_len = u32::from_le_bytes(rest.get(0..4)?.try_into().ok()?) as usize;
    let rest = rest.get(4..)?;
    if rest.get(..key_len)? != key.as_bytes() {
        return None;
    }
    let rest = rest.get(key_len..)?;
    let levels = u32::from_le_bytes(rest.get(0..4)?.try_into().ok()?);
    let branching = u32::from_le_bytes(rest.get(4..8)?.try_into().ok()?);
    let n = spheretree::slot_count(levels, branching)?;
    let body = rest.get(8..)?;
    let (body, cap_part) = body.split_at_checked(n.checked_mul(32)?)?;
    let cap_count = u32::from_le_bytes(cap_part.get(0..4)?.try_into().ok()?) as usize;
    let cap_body = cap_part.get(4..)?;
    if cap_count > n.checked_mul(spheretree::MAX_CAPS)?
        || cap_body.len() != cap_count.checked_mul(CAP_BYTES)?
    {
        return None;
    }
    let f = |i: usize| f64::from_le_bytes(body[i * 8..i * 8 + 8].try_into().unwrap_or([0; 8]));
    // A corrupt entry must be rebuilt, never trusted: no NaN or infinite number.
    if !(0..4 * n).all(|i| f(i).is_finite()) {
        return None;
    }
    let spheres = (0..n)
        .map(|k| Sphere::new([f(4 * k), f(4 * k + 1), f(4 * k + 2)], f(4 * k + 3)))
        .collect();
    let tree = SphereTree::from_slots(levels, branching, spheres).ok()?;
    // Pruning relies on containment; builders guarantee it exactly (see `build_tree`).
    let tol = 1e-9 * tree.spheres().first()?.radius.abs().max(1.0);
    tree.validate(tol).ok()?;
    if cap_count == 0 {
        return Some(tree);
    }
    let mut caps: Vec<Vec<FaceCap>> = vec![Vec::new(); n];
    let mut last: Option<usize> = None;
    for rec in cap_body.chunks_exact(CAP_BYTES) {
        let slot = u32::from_le_bytes(rec[0..4].try_into().ok()?) as usize;
        let x =
            |k: usize| f64::from_le_bytes(rec[4 + 8 * k..12 + 8 * k].try_into().unwrap_or([0; 8]));
        let cap = FaceCap {
            normal: [x(0), x(1), x(2)],
            offset: x(3),
            center: [x(4), x(5), x(6)],
            reach: x(7),
        };
        // Records by slot, each once: a repeated or shuffled list is not what encode wrote.
        if last.is_some_and(|l| slot < l)
            || slot >= n
            || !cap.is_valid()
            || !tree.sphere(slot).is_used()
            || caps[slot].contains(&cap)
            || caps[slot].len() >= spheretree::MAX_CAPS
        {
            return None;
        }
        last = Some(slot);
        caps[slot].push(cap);
    }
    let mut tree = tree;
    tree.set_caps(caps).ok()?;
    Some(tree)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn small_tree() -> SphereTree {
        let mut t = SphereTree::new_unused(2, 2).unwrap();
        t.spheres_mut()[0] = Sphere::new([0.0, 0.0, 0.0], 2.0);
        t.spheres_mut()[1] = Sphere::new([0.5, 0.25, -0.125], 1.0);
        t
    }

    /// [`small_tree`] with a face cap on its leaf 1.
    fn capped_tree() -> SphereTree {
        let mut t = small_tree();
        let cap = FaceCap {
            normal: [0.0, 0.6, 0.8],
            offset: 0.25,
            center: [0.5, 0.2, 0.16],
            reach: 0.5,
        };
        t.set_caps(vec![vec![], vec![cap], vec![]]).unwrap();
        t
    }

    /// `bytes` with its content hash recomputed (an edit by someone who knows the format).
    fn resealed(mut bytes: Vec<u8>) -> Vec<u8> {
        let n = bytes.len();
        let h = Fnv64::hash(&bytes[..n - 8]);
        bytes[n - 8..].copy_from_slice(&h.to_le_bytes());
        bytes
    }

    #[test]
    fn encode_decode_round_trip_and_rejects_garbage() {
        let t = small_tree();
        let bytes = encode("k1", &t);
        assert_eq!(decode("k1", &bytes), Some(t));
        let t = capped_tree();
        let bytes = encode("k1", &t);
        let back = decode("k1", &bytes).unwrap();
        assert_eq!(back.caps(), t.caps());
        assert_eq!(back, t);
        // The same bytes under another key (a renamed or copied file) are not that key's tree.
        assert_eq!(decode("k2", &bytes), None);
        assert_eq!(decode("k1", &bytes[..bytes.len() - 1]), None);
        assert_eq!(decode("k1", b"nonsense"), None);
        assert_eq!(decode("k1", b""), None);
    }

    #[test]
    fn bad_caps_are_rejected_even_with_a_valid_hash() {
        let bytes = encode("k", &capped_tree());
        // The cap record: slot u32 then nx ny nz offset cx cy cz reach, just before the hash.
        let rec = bytes.len() - 8 - CAP_BYTES;
        let edit = |at: usize, with: &[u8]| {
            let mut b = bytes.clone();
            b[at..at + with.len()].copy_from_slice(with);
            resealed(b)
        };
        // On an unused slot, past the end.
        for slot in [2u32, 3, 1000] {
            assert_eq!(
                decode("k", &edit(rec, &slot.to_le_bytes())),
                None,
                "slot {slot}"
            );
        }
        // A normal that is not unit, a NaN offset, a negative reach.
        assert_eq!(decode("k", &edit(rec + 4, &2.0f64.to_le_bytes())), None);
        assert_eq!(decode("k", &edit(rec + 28, &f64::NAN.to_le_bytes())), None);
        assert_eq!(decode("k", &edit(rec + 60, &(-1.0f64).to_le_bytes())), None);
        // A count that does not match the records.
        let count = rec - 4;
        for c in [0u32, 2, 3, u32::MAX] {
            assert_eq!(
                decode("k", &edit(count, &c.to_le_bytes())),
                None,
                "count {c}"
            );
        }
        // The same record twice (count 2).
        let mut twice = bytes[..bytes.len() - 8].to_vec();
        twice[count..count + 4].copy_from_slice(&2u32.to_le_bytes());
        twice.extend_from_slice(&bytes[rec..rec + CAP_BYTES]);
        twice.extend_from_slice(&[0; 8]);
        assert_eq!(decode("k", &resealed(twice)), None);
        // Intact, it decodes.
        assert_eq!(decode("k", &resealed(bytes.clone())), Some(capped_tree()));
    }

    #[test]
    fn key_depends_on_builder_version() {
        let m = TriMesh {
            vertices: vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            triangles: vec![[0, 1, 2]],
        };
        let v = spheretree::build::BUILDER_VERSION;
        assert_eq!(key_for_builder(&m, "depth=1", v), tree_key(&m, "depth=1"));
        assert_ne!(
            key_for_builder(&m, "depth=1", v - 1),
            tree_key(&m, "depth=1")
        );
        assert_ne!(
            key_for_builder(&m, "depth=1", v + 1),
            tree_key(&m, "depth=1")
        );
    }

    #[test]
    fn second_lookup_hits_and_key_depends_on_content() {
        let dir = tempfile::tempdir().unwrap();
        let cache = TreeCache::at(dir.path());
        let m = TriMesh {
            vertices: vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            triangles: vec![[0, 1, 2]],
        };
        let key = tree_key(&m, "depth=1");
        let mut builds = 0;
        let (a, o1) = cache
            .get_or_build::<()>(&key, || {
                builds += 1;
                Ok(small_tree())
            })
            .unwrap();
        let (b, o2) = cache
            .get_or_build::<()>(&key, || panic!("must hit"))
            .unwrap();
        assert_eq!(
            (o1, o2, builds),
            (CacheOutcome::Built, CacheOutcome::Hit, 1)
        );
        assert_eq!(a, b);
        let mut m2 = m.clone();
        m2.vertices[1][0] = 1.0 + 1e-12;
        assert_ne!(tree_key(&m2, "depth=1"), key);
        assert_ne!(tree_key(&m, "depth=2"), key);
    }
}
