use collide::Pose;
use render::cache::TreeCache;
use render::scenes::plate::{self, PlateTool, SpeedMotion};
use render::step::{GodObject, StepParams};
fn main() {
    if std::env::args().nth(1).as_deref() == Some("stats") {
        stats();
        return;
    }
    let args: Vec<String> = std::env::args().collect();
    let tool = if args[1] == "ball" {
        PlateTool::Ball
    } else {
        PlateTool::Puck
    };
    let v: f64 = args[3].parse().unwrap();
    let motion = if args[2] == "slide" {
        SpeedMotion::Slide(v)
    } else {
        SpeedMotion::Turn(v)
    };
    let run = plate::speed_script(tool, motion, 1000.0, 0.15);
    let cache = TreeCache::from_env();
    let scene = plate::scene(&cache, tool, run.script.clone()).unwrap();
    let mut params = StepParams::from_scene(&scene);
    if let Some(r) = args.get(4) {
        params.relinearize = r.parse().unwrap();
    }
    if let Some(b) = args.get(5) {
        params.budget_us = b.parse().unwrap();
    }
    let mut god = GodObject::new(&scene, params).unwrap();
    let traj = scene.trajectory();
    god.reset(&Pose::from_array(traj.samples[0].q)).unwrap();
    for (i, s) in traj.samples.iter().enumerate() {
        let o = god.step(&Pose::from_array(s.q));
        if i % 5 == 0 && i > 280 && i < 600 {
            println!("{i} xh {:.2} xg {:.2} ah {:.3} ag {:.3} zg {:.3} pairs {} passes {} it {} {:?} cd {:.0} opt {:.0} tot {:.0} margin {:.3} fx {:.3}",
                o.q_h[0], o.q_g[0], o.q_h[5], o.q_g[5], o.q_g[2], o.pairs, o.passes, o.iterations, o.status, o.cd_us, o.opt_us, o.total_us, o.margin_mm, o.wrench[0]);
        }
    }
}
#[allow(dead_code)]
pub fn stats() {
    let cache = TreeCache::from_env();
    let run = plate::speed_script(PlateTool::Puck, SpeedMotion::Slide(200.0), 1000.0, 0.15);
    let scene = plate::scene(&cache, PlateTool::Puck, run.script.clone()).unwrap();
    let tool = collide::PackedTree::new(&scene.tool).unwrap();
    let objs =
        vec![collide::PackedTree::with_pose(&scene.objects[0].0, &scene.objects[0].1).unwrap()];
    let mut ws = collide::CollideWorkspace::for_trees(&tool, &objs);
    let q = Pose::from_array([0.0, 0.0, 1.0, 0.0, 0.0, 0.0]);
    for m in [0.0, 0.12, 0.5, 1.0, 2.0] {
        let t = std::time::Instant::now();
        let mut n = 0;
        for _ in 0..100 {
            n = 0;
            collide::overlap_tree_trees(&tool, &q, &objs, m, &mut ws, |_| n += 1).unwrap();
        }
        println!(
            "margin {m}: pairs {n} {:?} {:.1} us",
            ws.stats(),
            t.elapsed().as_secs_f64() * 1e4
        );
    }
}
