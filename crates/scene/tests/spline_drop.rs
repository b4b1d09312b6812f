//! The spline's drop: when the shaft's keys come over the hub's grooves, the hand (2 mm below
//! the face) pulls it down at once, its keys pressed by the hand's turn against the grooves'
//! walls. A tool left behind while falling toward the hand takes the straight way there as its
//! path region, so the fall is one swept region per pass instead of ten small balls through
//! the dense contact with the walls: the drop ends within two frames (no time budget, so the
//! frames do not depend on the machine), and the shaft never enters the hub on the way.

mod common;

#[test]
fn the_shaft_drops_into_the_grooves_within_two_frames() {
    let mut scene = scene::scenes::builtin("spline", &common::test_cache()).unwrap();
    scene.solver.budget_us = engine::config::BUDGET_US.hi;
    let tol = scene.solver.penetration_tol_mm;
    let frames = common::replay(&scene);
    let mut overlap = common::overlap_of(&scene);
    // The drop: from the first frame whose tool is below the face (its tip at z < 0) to the
    // first within 0.1 mm of the hand's depth (z = -2 mm).
    let start = frames
        .iter()
        .position(|f| f.q_g[2] < -0.01)
        .expect("the shaft never dropped");
    let end = frames[start..]
        .iter()
        .position(|f| f.q_g[2] < -1.9)
        .expect("the shaft never reached the hand's depth")
        + start;
    assert!(
        end - start < 2,
        "the drop took {} frames (frames {start}..={end})",
        end - start + 1
    );
    for (i, f) in frames
        .iter()
        .enumerate()
        .take(end + 5)
        .skip(start.saturating_sub(5))
    {
        assert!(f.penetration_mm <= tol);
        let measured = overlap(&collide::Pose::from_array(f.q_g));
        assert!(measured <= tol, "overlap {measured} mm at frame {i}");
    }
}

/// In the alignment the shaft turns on the hub's face: a path region capped by the pair
/// density is short (measured at the whole shaft's reach), so a path that stopped the answer
/// is followed by a longer one or a ball. Five capped paths in a row took 7 passes (~1 ms);
/// now no frame before the drop takes more than 5 (no time budget).
#[test]
fn turning_on_the_face_takes_at_most_five_passes_a_frame() {
    let mut scene = scene::scenes::builtin("spline", &common::test_cache()).unwrap();
    scene.solver.budget_us = engine::config::BUDGET_US.hi;
    let frames = common::replay(&scene);
    let drop = frames
        .iter()
        .position(|f| f.q_g[2] < -0.01)
        .expect("the shaft never dropped");
    let (most, at) = frames[..drop]
        .iter()
        .enumerate()
        .map(|(i, f)| (f.passes, i))
        .max()
        .unwrap();
    assert!(most <= 5, "{most} passes at frame {at}");
}
