//! `haptic6d stability`: the closed-loop study with the emulated hand. For each scene and
//! rate, the largest coupling stiffness `kt` whose steady 1 N press is stable, and the force
//! ripple of the press at kt = 1 N/mm (criterion and model: docs/DESIGN.md §Devices).

use anyhow::{Context, Result};
use clap::Args;
use scene::cache::TreeCache;
use scene::stability::{largest_stable_kt, press, KtSearch, PressParams, PressResult};
use serde::Serialize;

/// Arguments of `haptic6d stability`.
#[derive(Args, Debug)]
pub struct StabilityArgs {
    /// Scenes, comma separated: plate (the puck pressed down onto the plate), bunny (the bunny
    /// pressed down onto the bunny).
    #[arg(long, default_value = "plate,bunny", value_delimiter = ',')]
    pub scenes: Vec<String>,
    /// Loop rates, Hz, comma separated.
    #[arg(long, default_value = "1000,4000", value_delimiter = ',')]
    pub rates: Vec<f64>,
    /// Geometric bisections after the doubling ladder (each halves the bracket's ratio).
    #[arg(long, default_value_t = 5)]
    pub bisections: u32,
    /// Print the results as JSON on stdout.
    #[arg(long)]
    pub json: bool,
}

/// One scene's results.
#[derive(Serialize)]
struct SceneResult {
    scene: String,
    press: PressParams,
    at_1_n_per_mm: Vec<PressResult>,
    searches: Vec<KtSearch>,
}

/// The press direction (into the object) of a built-in scene.
fn direction(name: &str) -> Result<[f64; 3]> {
    match name {
        "plate" => Ok([0.0, 0.0, -1.0]),
        "bunny" => Ok([0.0, -1.0, 0.0]),
        other => crate::usage_bail!("--scenes: unknown scene `{other}`; expected plate or bunny"),
    }
}

/// Runs `haptic6d stability`.
pub fn run(args: StabilityArgs) -> Result<()> {
    for &r in &args.rates {
        engine::config::RATE_HZ.check_as("--rates", r)?;
    }
    if args.bisections > 20 {
        crate::usage_bail!(
            "--bisections = {}: must be an integer in 0..=20",
            args.bisections
        );
    }
    let dirs = args
        .scenes
        .iter()
        .map(|s| direction(s.trim()))
        .collect::<Result<Vec<_>>>()?;
    let cache = TreeCache::from_env();
    let mut out = Vec::new();
    for (name, dir) in args.scenes.iter().zip(dirs) {
        let name = name.trim();
        let sc = scene::scenes::builtin(name, &cache)?;
        let p = PressParams::along(dir);
        let mut r = SceneResult {
            scene: name.to_string(),
            press: p,
            at_1_n_per_mm: Vec::new(),
            searches: Vec::new(),
        };
        for &rate in &args.rates {
            r.at_1_n_per_mm
                .push(press(&sc, &p, 1.0, rate).with_context(|| format!("{name} at {rate} Hz"))?);
            r.searches.push(
                largest_stable_kt(&sc, &p, rate, 0.5, args.bisections)
                    .with_context(|| format!("{name} at {rate} Hz"))?,
            );
        }
        if !args.json {
            print_human(&r);
        }
        out.push(r);
    }
    if args.json {
        println!("{}", serde_json::to_string_pretty(&out)?);
    }
    Ok(())
}

fn print_human(r: &SceneResult) {
    let h = &r.press.hand;
    println!(
        "{}: {} N press along {:?}; hand {} kg, {} N/mm, {} N·s/mm; stable = in the last {} s every frame in contact and force ripple p99 <= {} N",
        r.scene, r.press.push_n, r.press.direction, h.mass_kg, h.hand_stiffness_n_per_mm,
        h.hand_damping_ns_per_mm, r.press.window_s, r.press.ripple_limit_n
    );
    for p in &r.at_1_n_per_mm {
        println!(
            "  kt 1 N/mm at {:>5.0} Hz: mean force {:.3} N, ripple p99 {:.4} N, peak-to-peak {:.4} N, {}",
            p.rate_hz,
            p.mean_force_n,
            p.ripple_p99_n,
            p.peak_to_peak_n,
            if p.stable { "stable" } else { "UNSTABLE" }
        );
    }
    for s in &r.searches {
        let show = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.2}"));
        println!(
            "  {:>5.0} Hz: largest stable kt {} N/mm (smallest unstable {}; {} presses)",
            s.rate_hz,
            show(s.largest_stable_kt),
            show(s.smallest_unstable_kt),
            s.presses.len()
        );
    }
}
