//! The on-disk tree cache is an input too: a corrupt, truncated, renamed or hand-edited entry
//! must be rebuilt, never trusted. Seeded fuzzing of `cache::decode` (random bytes and
//! mutations of valid entries, with and without a recomputed content hash) and regressions for
//! what it found.

use devkit::Rng;
use scene::cache::{decode, encode, CacheOutcome, Fnv64, TreeCache};
use spheretree::{Sphere, SphereTree};

const KEY: &str = "0123456789abcdef0123456789abcdef";

fn tree() -> SphereTree {
    let mut t = SphereTree::new_unused(3, 2).unwrap();
    let s = t.spheres_mut();
    s[0] = Sphere::new([0.0, 0.0, 0.0], 4.0);
    s[1] = Sphere::new([-1.0, 0.0, 0.0], 2.5);
    s[2] = Sphere::new([1.0, 0.0, 0.0], 2.5);
    s[3] = Sphere::new([-1.5, 0.0, 0.0], 1.0);
    s[5] = Sphere::new([1.5, 0.5, 0.0], 1.0);
    t
}

/// Byte offset of the first slot in an entry: after the magic (8 bytes), the key length (4),
/// the key and the shape (levels and branching, 4 each).
fn slots_offset(_entry: &[u8]) -> usize {
    8 + 4 + KEY.len() + 8
}

/// Byte offset of `field` (0..3 centre, 3 radius) of `slot` in an entry.
fn field_offset(entry: &[u8], slot: usize, field: usize) -> usize {
    slots_offset(entry) + 32 * slot + 8 * field
}

/// Recomputes the content hash of an edited entry, as someone who knows the format would:
/// what is left to reject it is the decoder's own checks.
fn reseal(entry: &mut [u8]) {
    let n = entry.len();
    if n >= 8 {
        let h = Fnv64::hash(&entry[..n - 8]);
        entry[n - 8..].copy_from_slice(&h.to_le_bytes());
    }
}

/// The entry with every used leaf radius scaled by `factor` (finite numbers, wrong geometry).
fn with_leaf_radii_scaled(entry: &[u8], factor: f64) -> Vec<u8> {
    let mut bad = entry.to_vec();
    let t = tree();
    for leaf in t.leaves() {
        let o = field_offset(entry, leaf, 3);
        let r = f64::from_le_bytes(bad[o..o + 8].try_into().unwrap());
        bad[o..o + 8].copy_from_slice(&(r * factor).to_le_bytes());
    }
    bad
}

/// A decoded tree is usable by the haptic loop: every used sphere finite with radius > 0, and
/// every used child inside its parent (pruning relies on it).
#[track_caller]
fn assert_usable(t: &SphereTree, what: &str) {
    for (i, s) in t.spheres().iter().enumerate() {
        if s.is_used() {
            assert!(
                s.radius.is_finite() && s.center.iter().all(|c| c.is_finite()),
                "{what}: slot {i} is non-finite but was trusted: {s:?}"
            );
        }
    }
    let tol = 1e-9 * t.spheres()[0].radius.abs().max(1.0);
    assert!(
        t.validate(tol).is_ok(),
        "{what}: a tree breaking containment was trusted: {:?}",
        t.validate(tol)
    );
}

#[test]
fn cache_entry_with_non_finite_sphere_is_rejected_not_trusted() {
    let good = encode(KEY, &tree());
    assert_eq!(decode(KEY, &good), Some(tree()));
    for (field, value) in [(0, f64::NAN), (3, f64::INFINITY), (1, f64::NEG_INFINITY)] {
        let mut bad = good.clone();
        let o = field_offset(&good, 1, field);
        bad[o..o + 8].copy_from_slice(&value.to_le_bytes());
        assert_eq!(
            decode(KEY, &bad),
            None,
            "slot 1 field {field} = {value}: the content hash did not reject the edit"
        );
        // With a valid hash the finiteness check alone must reject it.
        reseal(&mut bad);
        assert_eq!(
            decode(KEY, &bad),
            None,
            "slot 1 field {field} = {value}: a non-finite sphere with a valid hash was trusted"
        );
    }
}

/// An edited cache entry: leaf radii ×0.01 (finite, plausible numbers) gave "penetration 0 mm" on
/// the wrong geometry. The content hash rejects the edit and the tree is rebuilt.
#[test]
fn cache_entry_with_edited_finite_radii_is_rebuilt_not_trusted() {
    let dir = tempfile::tempdir().unwrap();
    let cache = TreeCache::at(dir.path());
    let build = || Ok::<_, String>(tree());
    let (_, first) = cache.get_or_build(KEY, build).unwrap();
    assert_eq!(first, CacheOutcome::Built);
    let path = dir.path().join(format!("tree-{KEY}.bin"));
    let good = std::fs::read(&path).unwrap();
    assert_eq!(decode(KEY, &good), Some(tree()));

    let edited = with_leaf_radii_scaled(&good, 0.01);
    // The edit decodes to a different, well-formed tree were it not for the hash.
    let mut resealed = edited.clone();
    reseal(&mut resealed);
    let wrong = decode(KEY, &resealed).expect("a resealed, well-formed edit decodes");
    assert_ne!(wrong, tree());
    assert_eq!(decode(KEY, &edited), None, "edited radii were trusted");

    std::fs::write(&path, &edited).unwrap();
    let (t, outcome) = cache.get_or_build(KEY, build).unwrap();
    assert_eq!(outcome, CacheOutcome::Built, "an edited entry was trusted");
    assert_eq!(t, tree());
    assert_eq!(
        std::fs::read(&path).unwrap(),
        good,
        "the edit was not replaced"
    );
    // Once rebuilt, the entry is trusted again.
    let (_, again) = cache.get_or_build(KEY, build).unwrap();
    assert_eq!(again, CacheOutcome::Hit);
}

/// An entry copied or renamed under another key is that other tree, not this one.
#[test]
fn cache_entry_under_another_key_is_rebuilt() {
    let dir = tempfile::tempdir().unwrap();
    let cache = TreeCache::at(dir.path());
    let other = "ffffffffffffffffffffffffffffffff";
    let mut small = SphereTree::new_unused(1, 2).unwrap();
    small.spheres_mut()[0] = Sphere::new([9.0, 9.0, 9.0], 0.5);
    cache
        .get_or_build(other, || Ok::<_, String>(small.clone()))
        .unwrap();
    std::fs::copy(
        dir.path().join(format!("tree-{other}.bin")),
        dir.path().join(format!("tree-{KEY}.bin")),
    )
    .unwrap();
    let (t, outcome) = cache.get_or_build(KEY, || Ok::<_, String>(tree())).unwrap();
    assert_eq!(
        outcome,
        CacheOutcome::Built,
        "another key's entry was trusted"
    );
    assert_eq!(t, tree());
}

#[test]
fn corrupt_cache_entry_is_rebuilt() {
    let dir = tempfile::tempdir().unwrap();
    let cache = TreeCache::at(dir.path());
    let build = || Ok::<_, String>(tree());
    let (_, first) = cache.get_or_build(KEY, build).unwrap();
    assert_eq!(first, CacheOutcome::Built);
    let path = dir.path().join(format!("tree-{KEY}.bin"));
    let good = std::fs::read(&path).unwrap();
    let mut nan = good.clone();
    let o = slots_offset(&good);
    nan[o..o + 8].copy_from_slice(&f64::NAN.to_le_bytes());
    // A child moved out of its parent, with a valid hash: containment is checked.
    let mut poking = good.clone();
    let o = field_offset(&good, 3, 0);
    poking[o..o + 8].copy_from_slice(&(-3.5f64).to_le_bytes());
    reseal(&mut poking);
    for (what, corrupt) in [
        ("truncated", good[..good.len() / 2].to_vec()),
        ("garbage", b"garbage".to_vec()),
        ("empty", Vec::new()),
        ("NaN", nan),
        ("radii x0.01", with_leaf_radii_scaled(&good, 0.01)),
        ("child outside its parent", poking),
    ] {
        std::fs::write(&path, &corrupt).unwrap();
        let (t, outcome) = cache.get_or_build(KEY, build).unwrap();
        assert_eq!(
            outcome,
            CacheOutcome::Built,
            "{what}: a corrupt entry was trusted"
        );
        assert_eq!(t, tree());
        // The rebuilt entry replaced the corrupt one.
        assert_eq!(std::fs::read(&path).unwrap(), good, "{what}");
    }
}

#[test]
fn fuzz_decode_random_and_mutated_entries() {
    let cases: u64 = std::env::var("FUZZ_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(20_000);
    let good = encode(KEY, &tree());
    let shape_at = slots_offset(&good) - 8;
    let specials = [
        f64::NAN,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::MAX,
        0.0,
        -1.0,
    ];
    let mut r = Rng::new(0xCAC4E);
    let (mut resealed_decoded, mut resealed_cases) = (0u64, 0u64);
    for case in 0..cases {
        let random = case % 4 == 0;
        let mut b: Vec<u8> = if random {
            (0..r.below(400)).map(|_| r.next_u64() as u8).collect()
        } else {
            good.clone()
        };
        for _ in 0..1 + r.below(3) {
            let n = b.len();
            match r.below(5) {
                0 => b.truncate(r.below(n + 1)),
                1 if n > 0 => {
                    let i = r.below(n);
                    b[i] ^= 1 + r.below(255) as u8;
                }
                2 if n >= 8 => {
                    let o = r.below(n - 7);
                    b[o..o + 8].copy_from_slice(&specials[r.below(specials.len())].to_le_bytes());
                }
                3 if n >= shape_at + 8 => {
                    // Levels / branching words.
                    let o = shape_at + 4 * r.below(2);
                    b[o..o + 4].copy_from_slice(&(r.next_u64() as u32 % 40).to_le_bytes());
                }
                _ => b.extend((0..1 + r.below(40)).map(|_| r.next_u64() as u8)),
            }
        }
        // Half the mutated entries get a valid hash, so the structural checks are exercised.
        let resealed = !random && case % 2 == 1;
        if resealed {
            reseal(&mut b);
            resealed_cases += 1;
        }
        match decode(KEY, &b) {
            Some(t) => {
                assert_usable(&t, &format!("case {case}"));
                resealed_decoded += u64::from(resealed && b != good);
                assert!(
                    resealed || b == good,
                    "case {case}: a mutated entry passed the content hash"
                );
            }
            None => assert!(b != good, "case {case}: the intact entry was rejected"),
        }
    }
    // The resealed mutations did reach the structural checks (some are valid trees).
    if cases >= 1000 {
        assert!(
            resealed_decoded > 0 && resealed_decoded < resealed_cases,
            "{resealed_decoded} of {resealed_cases} resealed mutations decoded"
        );
    }
}
