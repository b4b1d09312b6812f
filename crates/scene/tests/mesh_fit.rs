//! The mesh geometry mode against the sphere envelope on small generated fits: a round peg of
//! radius 2 mm at each clearance of the fit study (0.5, 0.2, 0.1, 0.05 and 0.02 mm radial)
//! jams at the hole's mouth on the leaf spheres
//! (their envelope stands off the cylinder by more than the gap) and goes to full depth on the
//! parts' own triangles, whose rows keep every triangle pair apart. No deadline, so the frames
//! are the same on a loaded machine.

mod common;

use common::test_cache;
use engine::Geometry;
use scene::scenes::fit::{self, FitOutcome, FitParams};

/// A short peg and block: radius 2 mm, inserted 3.5 mm, depth-3 trees.
fn small_fit(clearance_mm: f64) -> FitParams {
    FitParams {
        radius_mm: 2.0,
        clearance_mm,
        peg_length_mm: 7.0,
        block_height_mm: 5.0,
        depth_mm: 3.5,
        tree_depth: 3,
        ..FitParams::default()
    }
}

/// The fit inserted with `geometry`, no deadline: its outcome, after checking every frame is
/// finite and, in the mesh mode, that the step used the meshes.
fn insert(p: &FitParams, geometry: Geometry) -> FitOutcome {
    let mut f = fit::fit_scene(p, &test_cache()).unwrap();
    f.scene.solver.budget_us = engine::config::BUDGET_US.hi;
    f.scene.solver.geometry = geometry;
    assert_eq!(f.scene.geometry(), geometry);
    let frames = common::replay(&f.scene);
    for fr in &frames {
        assert!(fr.q_g.iter().chain(&fr.wrench).all(|v| v.is_finite()));
    }
    f.outcome(&frames)
}

fn check(clearance_mm: f64) {
    check_fit(small_fit(clearance_mm));
}

fn check_fit(p: FitParams) {
    let clearance_mm = p.clearance_mm;
    let spheres = insert(&p, Geometry::Spheres);
    assert!(
        !spheres.full_depth && spheres.depth_reached_mm < 0.5 * p.depth_mm,
        "{clearance_mm} mm: the leaf spheres let the peg in: {spheres:?}"
    );
    let mesh = insert(&p, Geometry::Mesh);
    assert!(
        mesh.full_depth,
        "{clearance_mm} mm: the mesh mode jams: {mesh:?}"
    );
}

#[test]
fn a_round_peg_at_0_5_mm_clearance_jams_on_spheres_and_goes_in_on_the_mesh() {
    check(0.5);
}

#[test]
fn a_round_peg_at_0_2_mm_clearance_jams_on_spheres_and_goes_in_on_the_mesh() {
    check(0.2);
}

#[test]
fn a_round_peg_at_0_1_mm_clearance_jams_on_spheres_and_goes_in_on_the_mesh() {
    check(0.1);
}

#[test]
fn a_round_peg_at_0_05_mm_clearance_jams_on_spheres_and_goes_in_on_the_mesh() {
    check(0.05);
}

#[test]
fn a_round_peg_at_0_02_mm_clearance_jams_on_spheres_and_goes_in_on_the_mesh() {
    check(0.02);
}

/// A cylinder slid at 50 mm/s over a block's 90° edge and back, on the mesh: the force turns
/// with the contact without jumps (at most 0.5 N from one frame to the next outside contact
/// onsets), the tool does not catch on the edge on the way back (it trails the hand by no more
/// than a millimetre), and the triangles never meet. No deadline.
#[test]
fn a_cylinder_slid_over_a_sharp_edge_on_the_mesh_turns_the_force_without_jumps() {
    let mut s = fit::sharp_edge_scene(50.0, &test_cache()).unwrap();
    s.solver.budget_us = engine::config::BUDGET_US.hi;
    s.solver.geometry = Geometry::Mesh;
    assert_eq!(s.geometry(), Geometry::Mesh);
    let frames = common::replay(&s);
    let dt = 1.0 / s.rate_hz;
    let force =
        scene::report::force_report_of(frames.iter().enumerate().map(|(k, f)| (k as f64 * dt, f)));
    assert_eq!(force.non_finite_frames, 0);
    assert!(
        force.max_force_jump_n <= 0.5,
        "largest force jump {:.3} N at {:.3} s",
        force.max_force_jump_n,
        force.max_force_jump_t
    );
    // Pressed 0.5 mm by a 1 N/mm spring: the force on the flat is 0.5 N, not a snag's.
    assert!(
        force.max_force_n < 1.0,
        "force max {:.2} N",
        force.max_force_n
    );
    let trail = frames
        .windows(2)
        .filter(|w| w[1].q_h[0] < w[0].q_h[0])
        .map(|w| w[1].q_g[0] - w[1].q_h[0])
        .fold(0.0, f64::max);
    assert!(
        trail < 1.0,
        "the tool trails the hand by {trail:.2} mm on the way back"
    );
    assert!(frames.iter().all(|f| f.penetration_mm == 0.0));
}

/// A splined shaft (six keys) at 0.05 mm on its root circle and on the keys' sides.
#[test]
fn a_splined_peg_at_0_05_mm_clearance_jams_on_spheres_and_goes_in_on_the_mesh() {
    check_fit(FitParams {
        shape: fit::FitShape::Splined,
        ..small_fit(0.05)
    });
}
