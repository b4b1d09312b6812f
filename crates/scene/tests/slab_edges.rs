//! Slab regions at the edges of a capped box: the plate scene's plate, whose top-face nodes
//! near an edge carry the side face's cap too. A region detected with a slab (a thin margin
//! for the top face's half-space pairs) must hold every pair that can overlap while the tool
//! slides along the top face within the query's margin (also off the edge) and moves across
//! it within the slab's: at every such pose, a pair that overlaps in a whole traversal there
//! has a listed pair of the same tool leaf that rejects the pose too (as deep, or past the
//! engine's tolerance). The same check without a slab (the query's margin all round) is the
//! control. (Neither removing the slab's disc inset for nodes with several planes nor for
//! inner nodes fails this test: the inset guards a case this plate's caps do not show.)

mod common;

use collide::{
    overlap_shared, overlap_tree_trees, CollideWorkspace, FaceSlab, LeafPair, PackedTree, Pose,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use scene::scenes::plate::{self, PlateTool, SpeedMotion, PLATE_SIZE_MM};

/// The engine's default penetration tolerance (mm): a pose is accepted when no listed pair
/// overlaps by more.
const TOL: f64 = 0.002;

/// Pairs of `tool` at `q` within `margin`, with `slab` if given.
fn listed(
    tool: &PackedTree,
    q: &Pose,
    objects: &[PackedTree],
    margin: f64,
    slab: Option<FaceSlab>,
    ws: &mut CollideWorkspace,
) -> Vec<LeafPair> {
    let mut pairs = Vec::new();
    overlap_shared(tool, q, None, objects, margin, slab, ws, None, None, |p| {
        pairs.push(*p)
    })
    .unwrap();
    pairs
}

#[test]
fn slab_regions_hold_every_pair_that_can_overlap_at_a_capped_boxs_edges() {
    let run = plate::speed_script(PlateTool::Ball, SpeedMotion::Slide(50.0), 1000.0, 0.1);
    let scene = plate::scene(&common::test_cache(), PlateTool::Ball, run.script).unwrap();
    let (tool, objects) = common::packed(&scene);
    assert!(objects[0].face_cut_count() > 0, "the plate is capped");
    let mut ws = CollideWorkspace::for_trees(&tool, &objects);
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let half = 0.5 * PLATE_SIZE_MM[0];
    let (margin, thin) = (1.0, 0.05);
    let mut overlaps = [0usize; 2];
    let mut worst = [f64::NEG_INFINITY; 2];
    for trial in 0..400 {
        // The ball near an edge or a corner of the top face: over it, or just past it.
        let along: f64 = rng.random_range(-half..half);
        let out: f64 = rng.random_range(-3.0..1.5);
        let corner = trial % 4 == 0;
        let (x, y) = match trial % 2 {
            0 => (
                half + out,
                if corner {
                    half + rng.random_range(-3.0..1.5)
                } else {
                    along
                },
            ),
            _ => (along, -(half + out)),
        };
        let q = Pose::from_array([x, y, rng.random_range(-0.3..0.6), 0.0, 0.0, 0.0]);
        for (k, slab) in [
            Some(FaceSlab {
                normal: [0.0, 0.0, 1.0],
                margin: thin,
                tangent: margin,
            }),
            None,
        ]
        .into_iter()
        .enumerate()
        {
            let list = listed(&tool, &q, &objects, margin, slab, &mut ws);
            let across_limit = if slab.is_some() { thin } else { margin };
            for _ in 0..6 {
                let angle: f64 = rng.random_range(0.0..std::f64::consts::TAU);
                let slide: f64 = rng.random_range(0.0..margin - 1e-6);
                let across: f64 = rng.random_range(-1.0..1.0) * (across_limit - 1e-6);
                let scale = (margin - 1e-6) / (slide + across.abs()).max(margin - 1e-6);
                let mut q2 = q;
                q2.q[0] += scale * slide * angle.cos();
                q2.q[1] += scale * slide * angle.sin();
                q2.q[2] += scale * across;
                let mut hits = Vec::new();
                overlap_tree_trees(&tool, &q2, &objects, 0.0, &mut ws, |p| {
                    if p.gap < -1e-9 {
                        hits.push(*p)
                    }
                })
                .unwrap();
                for hit in hits {
                    overlaps[k] += 1;
                    let deepest = list
                        .iter()
                        .filter(|l| l.tool_slot == hit.tool_slot)
                        .map(|l| l.gap_at(&q2))
                        .fold(f64::INFINITY, f64::min);
                    worst[k] = worst[k].max(deepest - hit.gap);
                    assert!(
                        deepest <= hit.gap.max(-TOL) + 1e-9,
                        "{}: tool leaf {} overlaps by {} at {:?} (slid from {:?}); listed at {deepest}",
                        if slab.is_some() { "slab" } else { "control" },
                        hit.tool_slot,
                        -hit.gap,
                        q2.q,
                        q.q
                    );
                }
            }
        }
    }
    // (Stand-ins differ a little across a cap's rim: measured worst 0.0018 mm, below TOL.)
    assert!(
        worst.iter().all(|&w| w <= TOL),
        "listed pairs shallower than the overlaps by (slab, control) {worst:?} mm"
    );
    assert!(
        overlaps.iter().all(|&n| n > 200),
        "overlaps (slab, control): {overlaps:?}: the case does not test the edges"
    );
}
