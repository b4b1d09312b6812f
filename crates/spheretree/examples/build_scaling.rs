//! Build time and fit of the tight builder against triangle count (generated spheres and tori).
//!
//! `cargo run --release -p spheretree --example build_scaling -- [sphere|torus] N...`
use spheretree::build::{build_tree, BuildParams};
use spheretree::eval::{evaluate_fit, FitParams};
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let shape = args.first().cloned().unwrap_or_else(|| "sphere".into());
    for n in args.iter().skip(1) {
        let n: usize = n.parse().expect("triangle count");
        let mesh = match shape.as_str() {
            "torus" => mesh::generate::torus_with_triangles(n),
            _ => mesh::generate::sphere_with_triangles(1.0, n),
        };
        let t0 = Instant::now();
        // Progress (to stderr): when each tenth of the build was reached.
        let next = std::sync::atomic::AtomicUsize::new(1);
        let tree = build_tree(&mesh, &BuildParams::default(), &|f| {
            let tenth = next.load(std::sync::atomic::Ordering::Relaxed);
            if f >= tenth as f64 / 10.0 {
                next.store(tenth + 1, std::sync::atomic::Ordering::Relaxed);
                eprintln!("  {f:.2} at {:.1} s", t0.elapsed().as_secs_f64());
            }
        })
        .expect("build");
        let secs = t0.elapsed().as_secs_f64();
        let fit = evaluate_fit(&tree, &mesh, &FitParams::default());
        let leaf = fit.last().unwrap();
        println!(
            "{shape} {} tris: {secs:.2} s, leaves {}, worst {:.2}, mean {:.2}, coverage {:.4}",
            mesh.triangles.len(),
            leaf.count,
            leaf.worst,
            leaf.mean,
            100.0 * leaf.coverage
        );
    }
}
