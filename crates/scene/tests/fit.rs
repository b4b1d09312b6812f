//! Generated pegs and holes (`scene::scenes::fit`): the meshes are closed and of the stated
//! clearance, and with the shipped settings and no deadline a round peg goes in at 1.0 mm
//! clearance but jams at 0.2 mm on depth-4 trees: the tool touches the leaves' envelope,
//! which sticks out beyond the cylinder by more than the gap.

mod common;

use std::collections::HashMap;

use common::test_cache;
use mesh::TriMesh;
use scene::scenes::fit::{self, FitParams, FitShape};

/// Every directed edge appears once and its reverse once: closed, consistently oriented.
fn assert_watertight(m: &TriMesh, what: &str) {
    let mut edges: HashMap<(u32, u32), u32> = HashMap::new();
    for t in &m.triangles {
        for k in 0..3 {
            *edges.entry((t[k], t[(k + 1) % 3])).or_default() += 1;
        }
    }
    for (&(a, b), &n) in &edges {
        assert_eq!(n, 1, "{what}: edge {a}->{b} used {n} times");
        assert_eq!(
            edges.get(&(b, a)),
            Some(&1),
            "{what}: edge {a}->{b} has no twin"
        );
    }
    assert!(m.check_closed().is_ok(), "{what}: not closed");
}

fn radial(v: &[f64; 3]) -> f64 {
    v[0].hypot(v[1])
}

#[test]
fn pegs_and_blocks_are_watertight_and_the_hole_is_the_clearance_wider() {
    for shape in [FitShape::Round, FitShape::Splined] {
        for chamfer in [0.0f64, 1.0] {
            for (r, c) in [(10.0, 0.02), (10.0, 0.5), (3.0, 0.05)] {
                let p = FitParams {
                    shape,
                    radius_mm: r,
                    clearance_mm: c,
                    peg_chamfer_mm: chamfer.min(0.3 * r),
                    hole_chamfer_mm: chamfer.min(0.3 * r),
                    ..FitParams::default()
                };
                let name = p.name();
                let (peg, block) = (p.peg_mesh(), p.block_mesh());
                assert_watertight(&peg, &format!("{name} peg"));
                assert_watertight(&block, &format!("{name} block"));
                assert!(
                    peg.signed_volume() > 0.0 && block.signed_volume() > 0.0,
                    "{name}"
                );
                if shape == FitShape::Round {
                    // The peg's wall (above the chamfer) at r, the hole's wall (below the
                    // mouth's chamfer) at r + c, read from the vertices.
                    let peg_r = peg
                        .vertices
                        .iter()
                        .filter(|v| v[2] > p.peg_chamfer_mm + 1e-9)
                        .map(radial)
                        .fold(0.0, f64::max);
                    let hole_r = block
                        .vertices
                        .iter()
                        .filter(|v| v[2] < -p.hole_chamfer_mm - 1e-9)
                        .map(radial)
                        .filter(|&d| d < 2.0 * r)
                        .fold(f64::INFINITY, f64::min);
                    assert!((peg_r - r).abs() < 1e-9, "{name}: peg radius {peg_r}");
                    assert!(
                        (hole_r - peg_r - c).abs() < 1e-9,
                        "{name}: hole radius {hole_r}, clearance {}",
                        hole_r - peg_r
                    );
                    // The facets stay within the sagitta of the circles: the gap between the
                    // polygons is the clearance within it, at any angle.
                    let n = f64::from(p.round_segments());
                    let sagitta = (r + c) * (1.0 - (std::f64::consts::PI / n).cos());
                    assert!(sagitta <= fit::MAX_SAGITTA_MM, "{name}: sagitta {sagitta}");
                    // The chamfers: the tip face is c smaller, the mouth c wider.
                    let tip_r = peg
                        .vertices
                        .iter()
                        .filter(|v| v[2] == 0.0)
                        .map(radial)
                        .fold(0.0, f64::max);
                    assert!(
                        (tip_r - (r - p.peg_chamfer_mm)).abs() < 1e-9,
                        "{name}: tip {tip_r}"
                    );
                    let mouth_r = block
                        .vertices
                        .iter()
                        .filter(|v| v[2] == 0.0)
                        .map(radial)
                        .fold(f64::INFINITY, f64::min);
                    assert!(
                        (mouth_r - (r + c + p.hole_chamfer_mm)).abs() < 1e-9,
                        "{name}: mouth {mouth_r}"
                    );
                }
            }
        }
    }
}

/// The scene of a straight round peg, radius 10 mm, at `clearance_mm`, with the shipped
/// settings and no deadline; its outcome.
fn insert_round_peg(clearance_mm: f64) -> fit::FitOutcome {
    let p = FitParams {
        clearance_mm,
        ..FitParams::default()
    };
    let mut f = fit::fit_scene(&p, &test_cache()).unwrap();
    f.scene.solver.budget_us = engine::config::BUDGET_US.hi;
    let frames = common::replay(&f.scene);
    let tol = f.scene.solver.penetration_tol_mm;
    for fr in &frames {
        assert!(fr.q_g.iter().chain(&fr.wrench).all(|v| v.is_finite()));
        assert!(
            fr.penetration_mm <= tol + 1e-12,
            "penetration {}",
            fr.penetration_mm
        );
    }
    // Back in free space at the end: the tool is on the hand.
    let last = frames.last().unwrap();
    let lag = (0..6)
        .map(|k| (last.q_g[k] - last.q_h[k]).abs())
        .fold(0.0, f64::max);
    assert!(
        lag < 1e-6,
        "clearance {clearance_mm}: the tool stayed {lag} from the hand"
    );
    f.outcome(&frames)
}

#[test]
fn a_round_peg_at_1_mm_clearance_inserts_to_full_depth() {
    let o = insert_round_peg(1.0);
    assert!(o.full_depth, "{o:?}");
    assert!(
        (o.depth_reached_mm - FitParams::default().depth_mm).abs() < 1e-6,
        "{o:?}"
    );
}

#[test]
fn a_round_peg_at_0_2_mm_clearance_jams_on_the_sphere_envelope() {
    let o = insert_round_peg(0.2);
    assert!(!o.full_depth, "{o:?}");
    assert!(
        o.depth_reached_mm < 0.5 * FitParams::default().depth_mm,
        "{o:?}"
    );
    // The hand presses on: the spring pulls the tool down, the block holds it.
    assert!(o.force_max_n > 5.0, "{o:?}");
}
