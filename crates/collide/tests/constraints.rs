//! Constraint rows: J equals central finite differences of C (both forms), the right-hand side
//! is the linearization `d = J (q_lin - q_h) - C(q_lin)`, and the two forms agree to first order
//! at contact.

use collide::{
    constraint_value, fill_constraints, ConstraintForm, LeafPair, Linearization, Pose,
    RotationCoordinates,
};
use proptest::prelude::*;

fn pose_strategy() -> impl Strategy<Value = Pose> {
    (
        -100.0f64..100.0,
        -100.0f64..100.0,
        -100.0f64..100.0,
        -3.2f64..3.2,
        -1.5f64..1.5,
        -3.2f64..3.2,
    )
        .prop_map(|(x, y, z, g, b, a)| Pose::from_array([x, y, z, g, b, a]))
}

fn point() -> impl Strategy<Value = [f64; 3]> {
    proptest::array::uniform3(-60.0f64..60.0)
}

fn pair(p: [f64; 3], rt: f64, o: [f64; 3], ro: f64) -> LeafPair {
    LeafPair {
        object: 0,
        tool_slot: 0,
        object_slot: 0,
        p_in_tool: p,
        r_tool: rt,
        o_in_world: o,
        r_object: ro,
        gap: 0.0,
        face: None,
        on_face: false,
    }
}

/// Central differences of `C` at `pose`, step `h` (mm or rad).
fn finite_difference(
    form: ConstraintForm,
    pose: &Pose,
    p: &[f64; 3],
    rt: f64,
    o: &[f64; 3],
    ro: f64,
) -> [f64; 6] {
    let h = 1e-5;
    let mut g = [0.0; 6];
    for (k, gk) in g.iter_mut().enumerate() {
        let mut plus = *pose;
        let mut minus = *pose;
        plus.q[k] += h;
        minus.q[k] -= h;
        *gk = (constraint_value(form, &plus, p, rt, o, ro)
            - constraint_value(form, &minus, p, rt, o, ro))
            / (2.0 * h);
    }
    g
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn gradient_equals_central_differences(
        pose in pose_strategy(),
        p in point(),
        o in point(),
        rt in 0.1f64..10.0,
        ro in 0.1f64..10.0,
        squared in any::<bool>(),
    ) {
        let form = if squared { ConstraintForm::Squared } else { ConstraintForm::Distance };
        let lin = Linearization::new(form, &pose, &pose).unwrap();
        let (c, j) = lin.value_gradient(&p, rt, &o, ro);
        // Keep away from the distance form's kink at coincident centres.
        let c_world = pose.transform_point(&p);
        let dist = ((c_world[0] - o[0]).powi(2) + (c_world[1] - o[1]).powi(2) + (c_world[2] - o[2]).powi(2)).sqrt();
        prop_assume!(dist > 1.0);
        prop_assert!((c - constraint_value(form, &pose, &p, rt, &o, ro)).abs() <= 1e-9 * c.abs().max(1.0));
        let fd = finite_difference(form, &pose, &p, rt, &o, ro);
        let norm = j.iter().map(|v| v * v).sum::<f64>().sqrt();
        for k in 0..6 {
            prop_assert!(
                (j[k] - fd[k]).abs() <= 1e-6 * norm,
                "form {:?}, component {}: J {} vs FD {} (|J| {})", form, k, j[k], fd[k], norm
            );
        }
    }

    #[test]
    fn rhs_is_the_linearization(
        q_lin in pose_strategy(),
        q_h in pose_strategy(),
        p in point(),
        o in point(),
        rt in 0.1f64..10.0,
        ro in 0.1f64..10.0,
        squared in any::<bool>(),
    ) {
        let form = if squared { ConstraintForm::Squared } else { ConstraintForm::Distance };
        let pairs = [pair(p, rt, o, ro)];
        let mut rows = [[0.0; 6]; 1];
        let mut rhs = [0.0; 1];
        prop_assert_eq!(fill_constraints(form, &q_lin, &q_h, &pairs, &mut rows, &mut rhs).unwrap(), 1);
        // Linearized C at q = q_h + dq must be J dq - d for any dq: C(q_lin) + J (q - q_lin).
        let c_lin = constraint_value(form, &q_lin, &p, rt, &o, ro);
        let dq = [0.3, -0.2, 0.1, 0.01, -0.02, 0.03];
        let mut lhs = 0.0;
        let mut lin = c_lin;
        for k in 0..6 {
            lhs += rows[0][k] * dq[k];
            lin += rows[0][k] * (q_h.q[k] + dq[k] - q_lin.q[k]);
        }
        let scale = c_lin.abs().max(1.0) + rows[0].iter().map(|v| v.abs()).sum::<f64>() * 10.0;
        prop_assert!((lhs - rhs[0] - lin).abs() <= 1e-9 * scale, "{} vs {}", lhs - rhs[0], lin);
    }
}

/// At contact (`|c - o| = r_t + r_o`) the squared row is the distance row times `2 (r_t + r_o)`.
#[test]
fn forms_agree_at_contact() {
    let q = Pose::from_array([1.0, 2.0, 3.0, 0.3, -0.4, 0.5]);
    let q_h = Pose::from_array([1.5, 2.0, 2.0, 0.35, -0.4, 0.45]);
    let p = [4.0, -1.0, 2.0];
    let c = q.transform_point(&p);
    let (rt, ro) = (1.5, 2.5);
    let o = [c[0] + 4.0, c[1], c[2]]; // distance 4 = rt + ro
    let sq = Linearization::new(ConstraintForm::Squared, &q, &q_h)
        .unwrap()
        .row(&pair(p, rt, o, ro));
    let di = Linearization::new(ConstraintForm::Distance, &q, &q_h)
        .unwrap()
        .row(&pair(p, rt, o, ro));
    for k in 0..6 {
        assert!(
            (sq.0[k] - 8.0 * di.0[k]).abs() < 1e-9,
            "{k}: {:?} {:?}",
            sq.0,
            di.0
        );
    }
    assert!((sq.1 - 8.0 * di.1).abs() < 1e-9);
    // The distance form's translational part is the unit contact normal (-x: o is at +x).
    assert!((di.0[0] + 1.0).abs() < 1e-12 && di.0[1].abs() < 1e-12 && di.0[2].abs() < 1e-12);
}

#[test]
fn coincident_centres_still_give_a_usable_row() {
    let q = Pose::from_array([0.0, 0.0, 10.0, 0.0, 0.0, 0.0]);
    let o = q.transform_point(&[1.0, 2.0, 3.0]);
    for form in [ConstraintForm::Squared, ConstraintForm::Distance] {
        let (j, d) =
            Linearization::new(form, &q, &q)
                .unwrap()
                .row(&pair([1.0, 2.0, 3.0], 1.0, o, 1.0));
        assert!(j.iter().all(|v| v.is_finite()) && d.is_finite());
        assert!(
            j[..3].iter().map(|v| v * v).sum::<f64>() > 0.5,
            "{form:?}: {j:?}"
        );
        assert!(d > 0.0, "deep penetration must ask to move: {d}");
    }
}

#[test]
fn short_buffers_are_an_error() {
    let pairs = [pair([0.0; 3], 1.0, [3.0, 0.0, 0.0], 1.0); 3];
    let mut rows = [[0.0; 6]; 2];
    let mut rhs = [0.0; 3];
    let q = Pose::identity();
    assert!(fill_constraints(
        ConstraintForm::Distance,
        &q,
        &q,
        &pairs,
        &mut rows,
        &mut rhs
    )
    .is_err());
    let bad = Pose::from_array([0.0, f64::INFINITY, 0.0, 0.0, 0.0, 0.0]);
    let mut rows = [[0.0; 6]; 3];
    assert!(fill_constraints(
        ConstraintForm::Distance,
        &bad,
        &q,
        &pairs,
        &mut rows,
        &mut rhs
    )
    .is_err());
}

#[test]
fn default_form_is_distance() {
    assert_eq!(ConstraintForm::default(), ConstraintForm::Distance);
}

/// The rotational part of J equals `g · (dR/dtheta_k) p` with the explicit partial matrices.
#[test]
fn rotational_gradient_matches_partial_matrices() {
    use collide::rotation_zyx_partials;
    use nalgebra::Vector3;
    let q = Pose::from_array([3.0, -2.0, 1.0, 1.1, -0.7, 2.9]);
    let p = [4.0, -1.0, 2.0];
    let o = [10.0, 3.0, -4.0];
    let lin = Linearization::new(ConstraintForm::Squared, &q, &q).unwrap();
    let (_, j) = lin.value_gradient(&p, 1.0, &o, 2.0);
    let c = Vector3::from(q.transform_point(&p));
    let g = (c - Vector3::from(o)) * 2.0;
    let d = rotation_zyx_partials(q.q[3], q.q[4], q.q[5]);
    for k in 0..3 {
        let expect = g.dot(&(d[k] * Vector3::from(p)));
        assert!(
            (j[3 + k] - expect).abs() < 1e-9 * expect.abs().max(1.0),
            "{k}: {} vs {expect}",
            j[3 + k]
        );
    }
}

/// `C` with the tool rotated by `exp([w]x)` about the world axes and shifted by `dt`.
fn rotated_value(
    pose: &Pose,
    dt: [f64; 3],
    w: [f64; 3],
    p: &[f64; 3],
    rt: f64,
    o: &[f64; 3],
    ro: f64,
) -> f64 {
    // Straight from the matrix: a round trip through Euler angles near beta = ±pi/2 would
    // lose more digits than the finite difference has.
    let rot = collide::rotation_exp(&nalgebra::Vector3::from(w)) * pose.rotation_matrix();
    let t = pose.translation() + nalgebra::Vector3::from(dt);
    let c = rot * nalgebra::Vector3::from(*p) + t;
    (c - nalgebra::Vector3::from(*o)).norm() - (rt + ro)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    /// Rotation-vector rows: `J` equals central differences of `C` under world-axis translations
    /// and rotations, at any orientation, including `beta = ±pi/2` exactly (where the Euler
    /// partials are singular).
    #[test]
    fn rotation_vector_gradient_equals_central_differences(
        pose in pose_strategy(),
        lock in 0u8..3,
        p in point(),
        o in point(),
        rt in 0.1f64..10.0,
        ro in 0.1f64..10.0,
    ) {
        let mut pose = pose;
        match lock {
            1 => pose.q[4] = std::f64::consts::FRAC_PI_2,
            2 => pose.q[4] = -std::f64::consts::FRAC_PI_2,
            _ => {}
        }
        let lin = Linearization::with_coordinates(
            ConstraintForm::Distance, RotationCoordinates::RotationVector, &pose, &pose,
        ).unwrap();
        let (c, j) = lin.value_gradient(&p, rt, &o, ro);
        let c_world = pose.transform_point(&p);
        let dist = ((c_world[0] - o[0]).powi(2) + (c_world[1] - o[1]).powi(2) + (c_world[2] - o[2]).powi(2)).sqrt();
        prop_assume!(dist > 1.0);
        prop_assert!((c - constraint_value(ConstraintForm::Distance, &pose, &p, rt, &o, ro)).abs() <= 1e-9 * c.abs().max(1.0));
        let h = 1e-6;
        let norm = j.iter().map(|v| v * v).sum::<f64>().sqrt();
        for k in 0..6 {
            let (mut dt, mut w) = ([0.0; 3], [0.0; 3]);
            if k < 3 { dt[k] = h } else { w[k - 3] = h }
            let plus = rotated_value(&pose, dt, w, &p, rt, &o, ro);
            let (mut dt, mut w) = ([0.0; 3], [0.0; 3]);
            if k < 3 { dt[k] = -h } else { w[k - 3] = -h }
            let minus = rotated_value(&pose, dt, w, &p, rt, &o, ro);
            let fd = (plus - minus) / (2.0 * h);
            prop_assert!((j[k] - fd).abs() <= 1e-5 * norm.max(1.0), "component {}: J {} vs FD {}", k, j[k], fd);
        }
    }

    /// The variable's value at `q_lin` is `delta()`, `configuration(delta())` gives `q_lin` back,
    /// and `configuration(0)` is the device pose `q_h` (any orientation, both coordinates).
    #[test]
    fn configuration_inverts_the_variable(q_lin in pose_strategy(), q_h in pose_strategy(), euler in any::<bool>()) {
        let coords = if euler { RotationCoordinates::Euler } else { RotationCoordinates::RotationVector };
        let lin = Linearization::with_coordinates(ConstraintForm::Distance, coords, &q_lin, &q_h).unwrap();
        let at_lin = lin.configuration(&lin.delta());
        prop_assert!((at_lin.translation() - q_lin.translation()).norm() < 1e-9);
        prop_assert!((at_lin.rotation_matrix() - q_lin.rotation_matrix()).norm() < 1e-9);
        // `variable` inverts `configuration`.
        let dq = [0.4, -0.3, 0.2, 0.05, -0.02, 0.03];
        let back = lin.variable(&lin.configuration(&dq));
        // The rotation vector of the increment must be below pi for the log to return it.
        let d = lin.delta();
        let inc = ((dq[3] - d[3]).powi(2) + (dq[4] - d[4]).powi(2) + (dq[5] - d[5]).powi(2)).sqrt();
        for k in 0..if euler || inc < 3.0 { 6 } else { 3 } {
            prop_assert!((back[k] - dq[k]).abs() < 1e-8, "{}: {} vs {}", k, back[k], dq[k]);
        }
        let at_h = lin.configuration(&[0.0; 6]);
        prop_assert!((at_h.translation() - q_h.translation()).norm() < 1e-9);
        // Rotation vectors reach q_h's orientation up to the angle-pi ambiguity of the log.
        let r = at_h.rotation_matrix() * q_h.rotation_matrix().transpose();
        let angle = collide::rotation_log(&r).norm();
        prop_assert!(angle < 1e-7, "off by {} rad", angle);
    }
}

/// The same orientation in another Euler representation (gamma + 2 pi, or the gimbal-lock
/// twin) gives the same rotation-vector rows.
#[test]
fn rotation_vector_rows_ignore_the_euler_representation() {
    use std::f64::consts::PI;
    let q_lin = Pose::from_array([1.0, 2.0, 3.0, 0.2, -0.3, 0.4]);
    let q_h = Pose::from_array([1.5, 2.0, 2.0, 0.3, -0.2, 0.5]);
    let mut q_h_wrapped = q_h;
    q_h_wrapped.q[3] += 2.0 * PI;
    q_h_wrapped.q[5] -= 2.0 * PI;
    // (gamma, beta, alpha) and (gamma + pi, pi - beta, alpha + pi) are the same rotation.
    let twin = Pose::from_array([1.5, 2.0, 2.0, 0.3 + PI, PI + 0.2, 0.5 + PI]);
    assert!((twin.rotation_matrix() - q_h.rotation_matrix()).norm() < 1e-12);
    let pr = pair([5.0, 0.0, -1.0], 1.0, [6.0, 2.0, 0.5], 2.0);
    let rows = |h: &Pose| {
        Linearization::with_coordinates(
            ConstraintForm::Distance,
            RotationCoordinates::RotationVector,
            &q_lin,
            h,
        )
        .unwrap()
        .row(&pr)
    };
    let (j0, d0) = rows(&q_h);
    for other in [q_h_wrapped, twin] {
        let (j, d) = rows(&other);
        assert!((d - d0).abs() < 1e-9, "{d} vs {d0}");
        for k in 0..6 {
            assert!((j[k] - j0[k]).abs() < 1e-12);
        }
    }
}
