//! On-disk cache of sphere-trees built from meshes, keyed by a hash of the mesh content and the
//! build parameters, so a second run of a scene starts without rebuilding.
//!
//! Location: `$HAPTIC6D_CACHE` if set, else `$XDG_CACHE_HOME/haptic6d`, else
//! `~/.cache/haptic6d`. Files are `tree-<hash>.bin` (a small binary format: magic, levels,
//! branching, then `x y z r` as little-endian f64 per slot), written atomically. A corrupt or
//! unreadable entry is rebuilt, never trusted.

use std::path::{Path, PathBuf};

use mesh::TriMesh;
use spheretree::{Sphere, SphereTree};

use crate::RenderError;

const MAGIC: &[u8; 8] = b"H6DTREE1";

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
}

/// The cache key of a tree built from `mesh` (mm) with build parameters described by
/// `params` (any stable text, e.g. `"depth=4 branching=8 method=Tight"`).
pub fn tree_key(mesh: &TriMesh, params: &str) -> String {
    // Two differently seeded FNV streams make a 128-bit key: accidental collisions are moot.
    let mut a = Fnv64::default();
    let mut b = Fnv64(0x6c62_272e_07bb_0142);
    for h in [&mut a, &mut b] {
        h.write(b"haptic6d-tree-v1\0");
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
        let dir = std::env::var_os("HAPTIC6D_CACHE")
            .map(PathBuf::from)
            .or_else(|| {
                std::env::var_os("XDG_CACHE_HOME").map(|d| PathBuf::from(d).join("haptic6d"))
            })
            .or_else(|| {
                std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cache").join("haptic6d"))
            });
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
                if let Some(tree) = decode(&bytes) {
                    return Ok((tree, CacheOutcome::Hit));
                }
            }
            let tree = build()?;
            let _ = crate::io::write_atomic(&path, &encode(&tree));
            return Ok((tree, CacheOutcome::Built));
        }
        Ok((build()?, CacheOutcome::Built))
    }
}

/// Serialises a tree in the cache format.
pub fn encode(tree: &SphereTree) -> Vec<u8> {
    let mut out = Vec::with_capacity(16 + tree.len() * 32);
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&tree.levels().to_le_bytes());
    out.extend_from_slice(&tree.branching().to_le_bytes());
    for s in tree.spheres() {
        for c in s.center {
            out.extend_from_slice(&c.to_le_bytes());
        }
        out.extend_from_slice(&s.radius.to_le_bytes());
    }
    out
}

/// Reads a tree in the cache format; `None` if the bytes are not a valid tree.
pub fn decode(bytes: &[u8]) -> Option<SphereTree> {
    let rest = bytes.strip_prefix(MAGIC.as_slice())?;
    let levels = u32::from_le_bytes(rest.get(0..4)?.try_into().ok()?);
    let branching = u32::from_le_bytes(rest.get(4..8)?.try_into().ok()?);
    let n = spheretree::slot_count(levels, branching)?;
    let body = rest.get(8..)?;
    if body.len() != n.checked_mul(32)? {
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
    SphereTree::from_slots(levels, branching, spheres).ok()
}

/// Errors when the cache directory itself is unusable (reported, never fatal for a run).
pub fn check_writable(dir: &Path) -> Result<(), RenderError> {
    std::fs::create_dir_all(dir).map_err(|e| RenderError::Io {
        path: dir.display().to_string(),
        msg: format!("{e}; set HAPTIC6D_CACHE to a writable directory"),
    })
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

    #[test]
    fn encode_decode_round_trip_and_rejects_garbage() {
        let t = small_tree();
        let bytes = encode(&t);
        assert_eq!(decode(&bytes), Some(t));
        assert_eq!(decode(&bytes[..bytes.len() - 1]), None);
        assert_eq!(decode(b"nonsense"), None);
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
