//! The `tuning` study of `haptic6d bench`: each of the frame step's tuned values
//! ([`engine::Tuning`]) halved and doubled in turn, every other value shipped, over the
//! built-ins and the zoo with the shipped settings (dual solver, 1 ms budget, one thread,
//! frames back to back). The mesh mode's values (`near-*`) are replayed on the zoo in the mesh
//! mode, the rest on the leaf spheres, each mode against its own shipped row.
//!
//! Per configuration, as the ablation study measures it ([`crate::bench_ablation`]): frames
//! over 1 ms and degraded frames (summed), p99 against the shipped step's (geometric mean over
//! the scenes), detection work against the shipped step's (node pairs split plus list entries
//! tested: machine-independent), deepest overlap and drag. A value is well chosen where neither
//! neighbour is better on these figures; one whose neighbours match it on every figure does
//! not matter on these scenes. `--quick` runs the reduced zoo ([`crate::bench_zoo::QUICK_SCENES`]).
//!
//! Times on a shared machine come in slow spells of tens of seconds, long enough to make a
//! dozen configurations in a row look costly; `--tuning-passes` (2 by default) replays every
//! configuration once per pass and keeps each scene's quickest pass.

use anyhow::Result;
use engine::{Geometry, SolverKind, Tuning};
use scene::cache::TreeCache;
use scene::scenes::zoo;
use serde::Serialize;

use crate::bench_ablation::{scene_result, summarize, AblationRow, AblationScene};

/// The factors each value is scaled by.
pub const FACTORS: [f64; 2] = [0.5, 2.0];

/// One tuned value: the shipped value, and the study's rows at [`FACTORS`].
#[derive(Serialize, Clone, Debug)]
pub struct TuningRow {
    /// The value's name ([`Tuning::NAMES`]).
    pub name: String,
    /// The shipped value.
    pub value: f64,
    /// The geometry mode it was replayed in (`spheres` or `mesh`).
    pub geometry: String,
    /// The rows at each factor of [`FACTORS`], in order.
    pub scaled: Vec<AblationRow>,
}

/// The study: the shipped row per geometry mode, then one [`TuningRow`] per tuned value.
#[derive(Serialize, Clone, Debug, Default)]
pub struct TuningStudy {
    /// The shipped step on the leaf spheres and on the meshes.
    pub shipped: Vec<AblationRow>,
    /// The shipped step again after the scaled ones (at the end of each pass), against the
    /// first: the run-to-run spread a scaled value's figures must exceed to mean anything
    /// (times only; the counts repeat).
    pub again: Vec<AblationRow>,
    /// One per tuned value.
    pub rows: Vec<TuningRow>,
}

/// Whether a tuned value acts only in the mesh mode.
fn mesh_only(name: &str) -> bool {
    name.starts_with("near-")
}

/// Per scene, the figures of the pass with the least mean frame time: other work on the machine
/// only ever adds time, so the quickest pass is the closest to the step's own cost (the counts
/// differ between passes only where a deadline cut work short).
fn quickest(passes: Vec<Vec<AblationScene>>) -> Vec<AblationScene> {
    let mut passes = passes.into_iter();
    let mut best = passes.next().unwrap_or_default();
    for pass in passes {
        for (b, s) in best.iter_mut().zip(pass) {
            if s.total_us.mean < b.total_us.mean {
                *b = s;
            }
        }
    }
    best
}

/// Runs the study over the built-ins and the zoo (the reduced zoo with `quick`) about `base`
/// (the shipped values, or others to compare), for the values named in `only` (all when
/// empty), in `passes` passes (each scene's quickest kept, [`quickest`]).
pub fn tuning_study(
    cache: &TreeCache,
    quick: bool,
    base: Tuning,
    only: &[String],
    passes: usize,
) -> Result<TuningStudy> {
    let zoo_names: Vec<&str> = if quick {
        crate::bench_zoo::QUICK_SCENES.to_vec()
    } else {
        zoo::names().collect()
    };
    let sphere_names: Vec<&str> = if quick {
        zoo_names.clone()
    } else {
        // The sphere-mode built-ins: the tight ones jam on the leaf spheres by design.
        scene::scenes::sphere_builtin_names()
            .chain(zoo_names.iter().copied())
            .collect()
    };
    let load = |names: &[&str], geometry: Geometry| -> Result<Vec<_>> {
        let mut v = Vec::with_capacity(names.len());
        for name in names {
            let phases = if zoo::is_zoo(name) {
                Some(zoo::zoo_scene(name, cache)?.phases)
            } else {
                None
            };
            let mut s = scene::scenes::builtin(name, cache)?;
            s.solver.geometry = geometry;
            v.push((s, phases));
        }
        Ok(v)
    };
    let names: Vec<&str> = Tuning::NAMES
        .into_iter()
        .filter(|n| only.is_empty() || only.iter().any(|o| o == n))
        .collect();
    let modes: Vec<Geometry> = [Geometry::Spheres, Geometry::Mesh]
        .into_iter()
        .filter(|g| names.iter().any(|n| mesh_only(n) == (*g == Geometry::Mesh)))
        .collect();
    let mut study = TuningStudy::default();
    for mode in modes {
        let scenes = load(
            if mode == Geometry::Mesh {
                &zoo_names
            } else {
                &sphere_names
            },
            mode,
        )?;
        let replay = |tuning: Tuning| -> Result<Vec<AblationScene>> {
            let mut per_scene = Vec::with_capacity(scenes.len());
            for (s, phases) in &scenes {
                let mut s = s.clone();
                s.solver.tuning = tuning;
                let (times, frames, _) =
                    crate::bench_contact::replay_audited(&s, SolverKind::Dual, false, false)?;
                per_scene.push(scene_result(&s.name, &times, &frames, phases.as_ref()));
            }
            Ok(per_scene)
        };
        let say = |row: &AblationRow| {
            eprintln!(
                "bench: tuning {}: {} over 1 ms, {} degraded, mean x{:.2}, p99 x{:.2}, node pairs x{:.2}, list entries x{:.2}",
                row.config,
                row.over_1ms,
                row.degraded,
                row.mean_ratio,
                row.p99_ratio,
                row.splits_ratio,
                row.scanned_ratio
            );
        };
        let geometry = mode.name().to_string();
        let label = if base == Tuning::DEFAULT {
            "shipped"
        } else {
            "base"
        };
        // Every configuration of this mode: (value's name, its value, the factor, the tuning).
        let mut configs = Vec::new();
        for name in names
            .iter()
            .filter(|n| mesh_only(n) == (mode == Geometry::Mesh))
        {
            let value = base.get(name).unwrap_or(f64::NAN);
            for factor in FACTORS {
                match base
                    .with(name, value * factor)
                    .filter(|t| t.validate().is_ok())
                {
                    Some(tuning) => configs.push((*name, value, factor, tuning)),
                    None => eprintln!("bench: tuning {name} x{factor}: out of its range, skipped"),
                }
            }
        }
        // Pass after pass over every configuration: a slow spell of the machine falls on one
        // pass of a configuration, and each scene keeps its quickest pass.
        let (mut shipped_runs, mut again_runs) = (Vec::new(), Vec::new());
        let mut config_runs: Vec<Vec<Vec<AblationScene>>> = vec![Vec::new(); configs.len()];
        for pass in 1..=passes.max(1) {
            let first = replay(base)?;
            let pass_row = summarize(
                format!("{label} ({geometry}), pass {pass}"),
                first.clone(),
                None,
            );
            say(&pass_row);
            shipped_runs.push(first);
            for ((name, _, factor, tuning), runs) in configs.iter().zip(&mut config_runs) {
                let run = replay(*tuning)?;
                say(&summarize(
                    format!("{name} x{factor}, pass {pass}"),
                    run.clone(),
                    Some(&pass_row),
                ));
                runs.push(run);
            }
            again_runs.push(replay(base)?);
        }
        let shipped = summarize(
            format!("{label} ({geometry})"),
            quickest(shipped_runs),
            None,
        );
        let mut runs = config_runs.into_iter();
        let mut k = 0;
        while k < configs.len() {
            let (name, value, _, _) = configs[k];
            let mut scaled = Vec::with_capacity(FACTORS.len());
            while k < configs.len() && configs[k].0 == name {
                let factor = configs[k].2;
                let run = runs.next().unwrap_or_default();
                scaled.push(summarize(
                    format!("{name} x{factor}"),
                    quickest(run),
                    Some(&shipped),
                ));
                k += 1;
            }
            study.rows.push(TuningRow {
                name: name.to_string(),
                value,
                geometry: geometry.clone(),
                scaled,
            });
        }
        study.again.push(summarize(
            format!("{label} again ({geometry})"),
            quickest(again_runs),
            Some(&shipped),
        ));
        study.shipped.push(shipped);
    }
    Ok(study)
}

/// The study as a markdown table: the shipped rows, then each value halved and doubled, its
/// figures against its geometry's shipped row.
pub fn tuning_markdown(study: &TuningStudy) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "| value (geometry) | shipped | scaled | degraded | frames > 1 ms | mean time × | p99 × | node pairs × | list entries × | max pen. mm |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|---|");
    for r in &study.shipped {
        let _ = writeln!(
            s,
            "| {} | | | {} | {} | 1 | 1 (worst {:.0} µs, {}) | 1 | 1 | {:.4} |",
            r.config, r.degraded, r.over_1ms, r.worst_p99_us, r.worst_scene, r.max_penetration_mm
        );
    }
    for r in &study.again {
        let _ = writeln!(s, "| {} | | | {} |", r.config, against_shipped(r));
    }
    for row in &study.rows {
        for (k, r) in row.scaled.iter().enumerate() {
            let factor = r.config.rsplit(" x").next().unwrap_or("");
            let scaled = row.value * factor.parse::<f64>().unwrap_or(f64::NAN);
            let _ = writeln!(
                s,
                "| {} | {} | ×{factor} ({}) | {} |",
                if k == 0 {
                    format!("{} ({})", row.name, row.geometry)
                } else {
                    String::new()
                },
                if k == 0 {
                    format!("{}", row.value)
                } else {
                    String::new()
                },
                round_for_display(scaled),
                against_shipped(r)
            );
        }
    }
    s
}

/// A row's figures against its shipped row, as the table's last seven cells: degraded frames,
/// frames over 1 ms, mean and p99 time ratios, node-pair and list-entry ratios, deepest overlap.
fn against_shipped(r: &AblationRow) -> String {
    format!(
        "{} | {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.4}",
        r.degraded,
        r.over_1ms,
        r.mean_ratio,
        r.p99_ratio,
        r.splits_ratio,
        r.scanned_ratio,
        r.max_penetration_mm
    )
}

/// A scaled value as a person would write it (counts whole, lengths to four significant digits).
fn round_for_display(v: f64) -> String {
    if v >= 100.0 {
        format!("{v:.0}")
    } else {
        format!("{}", (v * 1e4).round() / 1e4)
    }
}
