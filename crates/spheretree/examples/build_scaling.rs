//! Build time, peak memory and fit of the tight builder (depth 4, branching 8) against the
//! triangle count, on generated closed spheres and tori: one markdown table row per mesh.
//!
//! `cargo run --release -p spheretree --example build_scaling -- sphere|torus N...`
//!
//! Progress (when each tenth of the build was reached) goes to stderr.
use spheretree::build::{build_tree_with_report, BuildParams};
use spheretree::eval::{evaluate_fit, FitParams};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

/// Peak resident memory of this process so far (MiB), from `/proc/self/status` (Linux).
fn peak_rss_mib() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}

fn main() {
    let mut args = std::env::args().skip(1);
    let shape = args.next().unwrap_or_else(|| "sphere".into());
    println!("| mesh | triangles | build (s) | peak RSS (MiB) | fit measure (s) | leaves | worst | mean | coverage % |");
    println!("|---|---|---|---|---|---|---|---|---|");
    for n in args {
        let n: usize = n.parse().expect("a triangle count");
        let mesh = match shape.as_str() {
            "torus" => mesh::generate::torus_with_triangles(n),
            "sphere" => mesh::generate::sphere_with_triangles(1.0, n),
            other => panic!("unknown shape `{other}`: use sphere or torus"),
        };
        let t0 = Instant::now();
        let next = AtomicUsize::new(1);
        let (tree, _) = build_tree_with_report(&mesh, &BuildParams::default(), &|f| {
            let tenth = next.load(Ordering::Relaxed);
            if f >= tenth as f64 / 10.0 {
                next.store(tenth + 1, Ordering::Relaxed);
                eprintln!("  {f:.2} at {:.1} s", t0.elapsed().as_secs_f64());
            }
        })
        .expect("build");
        let build_s = t0.elapsed().as_secs_f64();
        let rss = peak_rss_mib().map_or("—".into(), |m| format!("{m:.0}"));
        let t1 = Instant::now();
        let fit = evaluate_fit(&tree, &mesh, &FitParams::default());
        let eval_s = t1.elapsed().as_secs_f64();
        let leaf = fit.last().expect("a leaf level");
        println!(
            "| {shape} | {} | {build_s:.1} | {rss} | {eval_s:.1} | {} | {:.2} | {:.2} | {:.3} |",
            mesh.triangles.len(),
            leaf.count,
            leaf.worst,
            leaf.mean,
            100.0 * leaf.coverage
        );
    }
}
