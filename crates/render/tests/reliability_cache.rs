//! The on-disk tree cache is an input too: a corrupt, truncated or hand-edited entry must be
//! rebuilt, never trusted. Seeded fuzzing of `cache::decode` (random bytes and mutations of
//! valid entries) and regressions for what it found.

use render::cache::{decode, encode, CacheOutcome, TreeCache};
use spheretree::{Sphere, SphereTree};

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

/// A decoded tree is usable by the haptic loop: every used sphere finite with radius > 0.
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
}

#[test]
fn cache_entry_with_non_finite_sphere_is_rejected_not_trusted() {
    let good = encode(&tree());
    assert_eq!(decode(&good), Some(tree()));
    // Offsets of slot 1's x and radius (magic, levels, branching, then 4 f64 per slot).
    let header = good.len() - tree().len() * 32;
    for (field, value) in [(0, f64::NAN), (3, f64::INFINITY), (1, f64::NEG_INFINITY)] {
        let mut bad = good.clone();
        let o = header + 32 + 8 * field;
        bad[o..o + 8].copy_from_slice(&value.to_le_bytes());
        if let Some(t) = decode(&bad) {
            assert_usable(&t, &format!("field {field} = {value}"));
        }
    }
}

#[test]
fn corrupt_cache_entry_is_rebuilt() {
    let dir =
        std::env::temp_dir().join(format!("haptic6d-reliability-cache-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let cache = TreeCache::at(&dir);
    let key = "0123456789abcdef0123456789abcdef";
    let build = || Ok::<_, String>(tree());
    let (_, first) = cache.get_or_build(key, build).unwrap();
    assert_eq!(first, CacheOutcome::Built);
    let path = dir.join(format!("tree-{key}.bin"));
    let good = std::fs::read(&path).unwrap();
    let header = good.len() - tree().len() * 32;
    let mut nan = good.clone();
    nan[header..header + 8].copy_from_slice(&f64::NAN.to_le_bytes());
    for corrupt in [
        good[..good.len() / 2].to_vec(),
        b"garbage".to_vec(),
        Vec::new(),
        nan,
    ] {
        std::fs::write(&path, &corrupt).unwrap();
        let (t, outcome) = cache.get_or_build(key, build).unwrap();
        assert_eq!(outcome, CacheOutcome::Built, "a corrupt entry was trusted");
        assert_eq!(t, tree());
        // The rebuilt entry replaced the corrupt one.
        assert_eq!(std::fs::read(&path).unwrap(), good);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

#[test]
fn fuzz_decode_random_and_mutated_entries() {
    let cases: u64 = std::env::var("FUZZ_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(20_000);
    let good = encode(&tree());
    let specials = [
        f64::NAN,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::MAX,
        0.0,
        -1.0,
    ];
    let mut r = Rng(0xCAC4E);
    for case in 0..cases {
        let mut b = if case % 4 == 0 {
            (0..r.below(400)).map(|_| r.next() as u8).collect()
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
                3 if n >= 4 => {
                    // Levels / branching words.
                    let o = (n.min(16) - 4).min(r.below(n - 3));
                    b[o..o + 4].copy_from_slice(&(r.next() as u32 % 40).to_le_bytes());
                }
                _ => b.extend((0..1 + r.below(40)).map(|_| r.next() as u8)),
            }
        }
        if let Some(t) = decode(&b) {
            assert_usable(&t, &format!("case {case}"));
        }
    }
}
