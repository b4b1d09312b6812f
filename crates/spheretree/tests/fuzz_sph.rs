//! Fuzzing the `.sph` reader with proptest: random text and bytes, and structured mutations of
//! valid files (truncation, tokens replaced by NaN / inf / huge / negative / non-numbers, lines
//! deleted or duplicated, headers changed). The property, for every input: `parse_sph` returns
//! (no panic, no hang, no allocation from an untrusted header), an error is one line
//! `file:line: ...`, and an accepted tree is finite, has positive radii on used slots, and
//! writes back and reads back unchanged.
//!
//! Cases per property: 256 by default (seconds in CI); `FUZZ_CASES=200000` runs longer.

use proptest::prelude::*;
use proptest::test_runner::Config;
use spheretree::sph::{parse_sph, to_sph_string};

fn config() -> Config {
    Config {
        cases: std::env::var("FUZZ_CASES")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(256),
        failure_persistence: None,
        ..Config::default()
    }
}

const NAME: &str = "fuzz/tree.sph";

/// A valid file: `levels` levels of a binary or 8-ary tree, some slots unused, a trailer.
fn valid(levels: u32, branching: u32) -> String {
    let n: usize = (0..levels).map(|l| (branching as usize).pow(l)).sum();
    let mut s = format!("{levels} {branching}\n");
    for i in 0..n {
        if i % 5 == 3 {
            s += "0 0 0 -1 1\n";
        } else {
            let f = i as f64;
            s += &format!("{} {} {} {} 1\n", f * 0.5, -f, f * 0.25, 10.0 / (1.0 + f));
        }
    }
    s + "Options :\n\tdepth : 1\nEvaluation :\n\tmean 0\n"
}

fn check(text: &str) -> Result<(), TestCaseError> {
    match parse_sph(text, NAME) {
        Ok(tree) => {
            for s in tree.spheres() {
                if s.is_used() {
                    prop_assert!(s.radius > 0.0 && s.radius.is_finite(), "{s:?}");
                    prop_assert!(s.center.iter().all(|c| c.is_finite()), "{s:?}");
                }
            }
            let back = to_sph_string(&tree).map_err(|e| TestCaseError::fail(e.to_string()))?;
            let again =
                parse_sph(&back, "round trip").map_err(|e| TestCaseError::fail(e.to_string()))?;
            prop_assert_eq!(again, tree);
        }
        Err(e) => {
            let m = e.to_string();
            prop_assert!(!m.contains('\n'), "multi-line error: {m:?}");
            prop_assert!(m.starts_with(&format!("{NAME}:")), "no file:line in {m}");
            let line: String = m[NAME.len() + 1..]
                .chars()
                .take_while(|c| c.is_ascii_digit())
                .collect();
            prop_assert!(
                line.parse::<usize>().is_ok_and(|l| l >= 1),
                "no line number in {m}"
            );
        }
    }
    Ok(())
}

const TOKENS: &[&str] = &[
    "nan",
    "NaN",
    "inf",
    "-inf",
    "1e308",
    "-1e308",
    "1e400",
    "0",
    "-0",
    "-1",
    "4294967295",
    "4294967296",
    "99999999999999999999",
    "x",
    "",
    "1.5",
    "3 3",
    "2 2 2 2 2 2 2 2 2 2 2",
    "é",
    "Options",
    "\u{0}",
];

#[derive(Clone, Debug)]
enum Mutation {
    Truncate(f64),
    Token(f64, &'static str),
    DeleteLine(f64),
    DuplicateLine(f64),
    Header(u32, u32),
    Insert(f64, String),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    let pos = 0.0..1.0f64;
    prop_oneof![
        pos.clone().prop_map(Mutation::Truncate),
        (pos.clone(), prop::sample::select(TOKENS)).prop_map(|(p, t)| Mutation::Token(p, t)),
        pos.clone().prop_map(Mutation::DeleteLine),
        pos.clone().prop_map(Mutation::DuplicateLine),
        (
            prop_oneof![0u32..12, Just(u32::MAX), any::<u32>()],
            prop_oneof![0u32..10, Just(u32::MAX), any::<u32>()]
        )
            .prop_map(|(l, b)| Mutation::Header(l, b)),
        (pos, "[ -~\n\t]{0,24}").prop_map(|(p, s)| Mutation::Insert(p, s)),
    ]
}

fn at(f: f64, n: usize) -> usize {
    ((f * n as f64) as usize).min(n)
}

fn apply(text: String, m: &Mutation) -> String {
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let n = lines.len();
    match m {
        Mutation::Truncate(f) => {
            let mut cut = at(*f, text.len());
            while !text.is_char_boundary(cut) {
                cut -= 1;
            }
            return text[..cut].to_string();
        }
        Mutation::Token(f, t) => {
            if n > 0 {
                let i = at(*f, n - 1);
                let mut toks: Vec<&str> = lines[i].split_whitespace().collect();
                if !toks.is_empty() {
                    let k = (i * 7 + t.len()) % toks.len();
                    toks[k] = t;
                }
                lines[i] = toks.join(" ");
            }
        }
        Mutation::DeleteLine(f) => {
            if n > 0 {
                lines.remove(at(*f, n - 1));
            }
        }
        Mutation::DuplicateLine(f) => {
            if n > 0 {
                let i = at(*f, n - 1);
                let l = lines[i].clone();
                lines.insert(i, l);
            }
        }
        Mutation::Header(l, b) => {
            if n > 0 {
                lines[0] = format!("{l} {b}");
            }
        }
        Mutation::Insert(f, s) => {
            let i = at(*f, n);
            lines.insert(i, s.clone());
        }
    }
    lines.join("\n") + "\n"
}

#[test]
fn seeds_are_valid() {
    for (l, b) in [(1, 8), (2, 2), (3, 2), (2, 8), (3, 3)] {
        let t = parse_sph(&valid(l, b), NAME).unwrap();
        assert_eq!((t.levels(), t.branching()), (l, b));
    }
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn random_text_never_panics(text in "[0-9 .eE+\\-naif\n\t]{0,300}") {
        check(&text)?;
    }

    #[test]
    fn random_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..400)) {
        check(&String::from_utf8_lossy(&bytes))?;
    }

    #[test]
    fn mutated_valid_files_never_panic(
        shape in prop::sample::select(&[(1u32, 8u32), (2, 2), (3, 2), (2, 8), (3, 3)][..]),
        muts in prop::collection::vec(mutation(), 1..4),
    ) {
        let text = muts.iter().fold(valid(shape.0, shape.1), apply);
        check(&text)?;
    }
}
