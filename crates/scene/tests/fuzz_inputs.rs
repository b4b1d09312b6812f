//! Fuzzing the scene crate's text inputs, the scene TOML and the trajectory CSV: random text
//! and structured mutations of valid files (truncation, tokens replaced by NaN / inf / huge /
//! negative / wrong types, lines deleted or duplicated, garbage inserted). The property: the
//! parser returns (no panic), an error is one line naming the file (and, for the CSV, the
//! line), and what it accepts is finite and in range.
//!
//! A seeded generator (SplitMix64) drives the cases, so a failure prints its case number and
//! reproduces exactly. Cases per property: 2000 by default (about a second); `FUZZ_CASES=200000`
//! runs longer.

use devkit::Rng;
use scene::trajectory::{Trajectory, TRAJECTORY_HEADER};
use scene::SceneSpec;

fn cases() -> u64 {
    std::env::var("FUZZ_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(2000)
}

const TOKENS: &[&str] = &[
    "nan",
    "inf",
    "-inf",
    "1e308",
    "-1e308",
    "1e400",
    "0",
    "-0",
    "-1",
    "99999999999999999999",
    "x",
    "",
    "\"s\"",
    "[1, 2]",
    "true",
    "{}",
    ",",
    "=",
    "[",
    "]",
    "#",
    "\"",
    "é",
    "\u{0}",
    "[[object]]",
    "[tool]",
    "tree",
    "mesh",
    "0x10",
    "1_000",
    "+inf",
    "-nan",
];

/// Applies 1..=3 random mutations to `text`.
fn mutate(rng: &mut Rng, text: &str) -> String {
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    for _ in 0..1 + rng.below(3) {
        let n = lines.len();
        match rng.below(6) {
            0 => {
                // Truncate at a character.
                let joined = lines.join("\n");
                let chars: Vec<char> = joined.chars().collect();
                let cut = rng.below(chars.len() + 1);
                lines = chars[..cut]
                    .iter()
                    .collect::<String>()
                    .lines()
                    .map(str::to_string)
                    .collect();
            }
            1 if n > 0 => {
                // Replace one token (split on spaces and commas) of one line.
                let i = rng.below(n);
                let mut toks: Vec<String> = lines[i]
                    .split_inclusive([' ', ','])
                    .map(str::to_string)
                    .collect();
                if !toks.is_empty() {
                    let k = rng.below(toks.len());
                    let sep = if toks[k].ends_with([' ', ',']) {
                        toks[k].pop().map(String::from).unwrap_or_default()
                    } else {
                        String::new()
                    };
                    toks[k] = format!("{}{sep}", TOKENS[rng.below(TOKENS.len())]);
                }
                lines[i] = toks.concat();
            }
            2 if n > 0 => {
                lines.remove(rng.below(n));
            }
            3 if n > 0 => {
                let i = rng.below(n);
                let l = lines[i].clone();
                lines.insert(i, l);
            }
            4 => {
                let len = rng.below(24);
                let s: String = (0..len)
                    .map(|_| char::from((rng.next_u64() % 128) as u8))
                    .collect();
                let i = rng.below(n + 1);
                lines.insert(i, s);
            }
            _ => {
                let i = rng.below(n + 1);
                lines.insert(i, TOKENS[rng.below(TOKENS.len())].to_string());
            }
        }
    }
    lines.join("\n") + "\n"
}

fn random_text(rng: &mut Rng, alphabet: &[u8]) -> String {
    let len = rng.below(300);
    (0..len)
        .map(|_| char::from(alphabet[rng.below(alphabet.len())]))
        .collect()
}

fn check_csv(text: &str, case: u64) {
    match Trajectory::parse_csv(text, "f.csv") {
        Ok(t) => {
            assert!(!t.is_empty(), "case {case}");
            for w in t.samples.windows(2) {
                assert!(w[1].t >= w[0].t, "case {case}: time goes backwards");
            }
            for s in &t.samples {
                assert!(
                    s.t.is_finite() && s.q.iter().all(|v| v.is_finite()),
                    "case {case}: non-finite sample accepted: {s:?} from {text:?}"
                );
            }
        }
        Err(e) => {
            let m = e.to_string();
            assert!(!m.contains('\n'), "case {case}: multi-line {m:?}");
            let rest = m
                .strip_prefix("f.csv:")
                .unwrap_or_else(|| panic!("case {case}: error does not start with the file: {m}"));
            let line: String = rest.chars().take_while(char::is_ascii_digit).collect();
            assert!(
                line.parse::<usize>().is_ok_and(|l| l >= 1),
                "case {case}: no line in {m}"
            );
        }
    }
}

fn check_scene(text: &str, case: u64) {
    match SceneSpec::parse(text, "f.toml") {
        Ok(s) => {
            let pos = |v: f64| v > 0.0 && v.is_finite();
            assert!(
                pos(s.coupling.kt) && pos(s.coupling.kr),
                "case {case}: {s:?}"
            );
            assert!(pos(s.device.rate_hz), "case {case}: {s:?}");
            for b in std::iter::once(&s.tool).chain(&s.object) {
                assert!(b.mesh.is_some() != b.tree.is_some(), "case {case}");
                if let Some(sc) = b.scale {
                    assert!(pos(sc), "case {case}: scale {sc}");
                }
                for q in [b.start, b.pose].into_iter().flatten() {
                    assert!(q.iter().all(|v| v.is_finite()), "case {case}: {q:?}");
                }
            }
        }
        Err(e) => {
            let m = e.to_string();
            assert!(!m.contains('\n'), "case {case}: multi-line {m:?}");
            assert!(m.starts_with("f.toml"), "case {case}: {m}");
        }
    }
}

fn valid_csv() -> String {
    let mut s = format!("{TRAJECTORY_HEADER}\n");
    for i in 0..8 {
        let t = i as f64 * 1e-3;
        s += &format!(
            "{t},{},{},{},0.1,-0.2,{}\n",
            i,
            -i,
            100 - i,
            0.01 * i as f64
        );
    }
    s
}

const VALID_SCENE: &str = r#"
[tool]
mesh = "bunny.obj"
scale = 10.0
depth = 4
start = [0, 0, 120, 0, 0, 0]

[[object]]
tree = "bunny.sph"
scale = 10.0
pose = [0, 0, 0, 0, 0, 0]

[coupling]
kt = 1.0
kr = 1000.0

[solver]
kind = "dual"
relinearize = 3

[device]
rate_hz = 1000.0
"#;

#[test]
fn seeds_are_valid() {
    assert_eq!(Trajectory::parse_csv(&valid_csv(), "v").unwrap().len(), 8);
    SceneSpec::parse(VALID_SCENE, "v").unwrap();
}

#[test]
fn trajectory_csv_random_and_mutated() {
    let mut rng = Rng::new(0x7261_6A65);
    let seed = valid_csv();
    for case in 0..cases() {
        let text = if case % 4 == 0 {
            random_text(&mut rng, b"0123456789.,-+eE naif\n\r\t#xyz")
        } else {
            mutate(&mut rng, &seed)
        };
        check_csv(&text, case);
    }
}

#[test]
fn scene_toml_random_and_mutated() {
    let mut rng = Rng::new(0x7363_656E);
    for case in 0..cases() {
        let text = if case % 4 == 0 {
            random_text(
                &mut rng,
                b"[]=\".,0123456789 \nabcdefghijklmnopqrstuvwxyz_#{}",
            )
        } else {
            mutate(&mut rng, VALID_SCENE)
        };
        check_scene(&text, case);
    }
}
