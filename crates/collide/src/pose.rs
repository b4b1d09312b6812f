//! Tool configurations `q = (x, y, z, gamma, beta, alpha)` (mm, rad) and their rigid transforms.
//!
//! `R(q) = Rz(alpha) · Ry(beta) · Rx(gamma)` (the paper's matrix (6)), and
//! `world_from_tool(p) = R(q) p + (x, y, z)`.

use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3, Vector6};

/// A 6-D configuration `q = (x, y, z, gamma, beta, alpha)`: translation in mm, Euler angles in
/// rad with `R = Rz(alpha) Ry(beta) Rx(gamma)`.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Pose {
    /// `(x, y, z, gamma, beta, alpha)`: mm, mm, mm, rad, rad, rad.
    pub q: Vector6<f64>,
}

impl Pose {
    /// The identity configuration (all zeros).
    pub fn identity() -> Self {
        Self {
            q: Vector6::zeros(),
        }
    }

    /// From `[x, y, z, gamma, beta, alpha]` (mm, rad).
    pub fn from_array(q: [f64; 6]) -> Self {
        Self {
            q: Vector6::from(q),
        }
    }

    /// As `[x, y, z, gamma, beta, alpha]` (mm, rad).
    pub fn to_array(&self) -> [f64; 6] {
        self.q.into()
    }

    /// Translation `(x, y, z)` in mm.
    #[inline]
    pub fn translation(&self) -> Vector3<f64> {
        Vector3::new(self.q[0], self.q[1], self.q[2])
    }

    /// `R(q) = Rz(alpha) Ry(beta) Rx(gamma)`, bit for bit [`rotation_zyx`]'s: from a memo of
    /// the few matrices this thread made last (by the angles' bits) where its angles are there,
    /// else made and kept there.
    #[inline]
    pub fn rotation_matrix(&self) -> Matrix3<f64> {
        RotationMemo::rotation(self.q[3], self.q[4], self.q[5])
    }

    /// `world_from_tool` as an isometry.
    pub fn to_isometry(&self) -> Isometry3<f64> {
        let rot = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(
            self.rotation_matrix(),
        ));
        Isometry3::from_parts(Translation3::from(self.translation()), rot)
    }

    /// The configuration of an isometry (Euler angles with `beta` in `[-pi/2, pi/2]`).
    pub fn from_isometry(iso: &Isometry3<f64>) -> Self {
        // nalgebra's euler_angles returns (roll, pitch, yaw) for R = Rz(yaw) Ry(pitch) Rx(roll).
        let (gamma, beta, alpha) = iso.rotation.euler_angles();
        let t = iso.translation.vector;
        Self {
            q: Vector6::new(t.x, t.y, t.z, gamma, beta, alpha),
        }
    }

    /// The configuration of a translation (mm) and a rotation matrix, with Euler angles as in
    /// [`Pose::from_isometry`] (`beta` in `[-pi/2, pi/2]`; at `beta = ±pi/2` one of the many
    /// equivalent `(gamma, alpha)` pairs). `rotation_matrix()` of the result reproduces `rot`
    /// (to rounding) for every proper rotation, so no orientation is lost.
    pub fn from_translation_rotation(t: &Vector3<f64>, rot: &Matrix3<f64>) -> Self {
        let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(*rot));
        let (gamma, beta, alpha) = q.euler_angles();
        Self {
            q: Vector6::new(t.x, t.y, t.z, gamma, beta, alpha),
        }
    }

    /// True when all six numbers are finite.
    #[inline]
    pub fn is_finite(&self) -> bool {
        self.q.iter().all(|v| v.is_finite())
    }
}

/// The rotation vector (axis times angle, rad, angle in `[0, pi]`) of a rotation matrix: the
/// inverse of [`rotation_exp`]. Accurate at every angle: `atan2` of the sine and cosine, so
/// tiny angles (where `acos` loses digits) keep theirs.
///
/// Up to a quarter turn the matrix's skew part (`2 sin(angle)` times the axis) and trace
/// (`1 + 2 cos(angle)`) give both at once: the step's motion bounds take hundreds of these a
/// frame, nearly all of small turns, and the quaternion this reads beyond cost a third more
/// (the bunny's mesh frames spent a tenth of their time here). Beyond a quarter turn the
/// skew part shrinks toward `pi`, and its axis with it; there the unit quaternion keeps the
/// axis.
#[inline]
pub fn rotation_log(rot: &Matrix3<f64>) -> Vector3<f64> {
    let twice_cos = rot.m11 + rot.m22 + rot.m33 - 1.0;
    if twice_cos > 0.0 {
        let twice_sin_axis = Vector3::new(rot.m32 - rot.m23, rot.m13 - rot.m31, rot.m21 - rot.m12);
        let twice_sin = twice_sin_axis.norm();
        // angle / (2 sin), with its limit 1 / (2 cos) as the sine goes to 0.
        let scale = if twice_sin > 1e-8 {
            twice_sin.atan2(twice_cos) / twice_sin
        } else {
            (1.0 - twice_sin * twice_sin / (3.0 * twice_cos * twice_cos)) / twice_cos
        };
        return twice_sin_axis * scale;
    }
    rotation_log_by_quaternion(rot)
}

/// [`rotation_log`] through the unit quaternion and `atan2`: accurate at every angle, the
/// axis too near `pi`.
fn rotation_log_by_quaternion(rot: &Matrix3<f64>) -> Vector3<f64> {
    let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(*rot));
    let (mut w, mut v) = (q.w, q.imag());
    if w < 0.0 {
        // q and -q are the same rotation; this one has the angle in [0, pi].
        w = -w;
        v = -v;
    }
    let n = v.norm();
    // angle = 2 atan2(n, w); scale = angle / n, with its limit 2 / w as n -> 0.
    let scale = if n > 1e-8 {
        2.0 * n.atan2(w) / n
    } else {
        2.0 / w * (1.0 - n * n / (3.0 * w * w))
    };
    v * scale
}

/// An axis-aligned box (tool frame, mm) holding points of a tool, typically its leaf centres:
/// a turn moves them by at most the angle times their largest distance from the turn's axis,
/// which for a long tool turning about its own axis is far less than the angle times its reach
/// (`spline-tight`'s shaft, 13 mm in radius and 50 mm long, about its axis).
///
/// It also keeps the points' largest distance from each of the tool frame's three axes: a tool
/// built about one of them (a shaft along its `z`) turns about it by its true radius, where the
/// box's corners are farther by up to `sqrt(2)` (a round shaft's square box).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CentreBox {
    /// Least corner (tool frame, mm).
    pub lo: Vector3<f64>,
    /// Greatest corner (tool frame, mm).
    pub hi: Vector3<f64>,
    /// The points' largest distance (mm) from the tool frame's `x`, `y` and `z` axes through
    /// its origin: no more than the box's corners'.
    pub radial: Vector3<f64>,
    /// Whether [`CentreBox::arm`] bounds a turn about the tool's axes by `radial` too, or by
    /// the corners alone (as the leaf spheres' step was tuned: there the tighter arm changed
    /// the zoo's work both ways, and its cost showed on the bunny's 18 µs frames).
    pub axis_arms: bool,
}

impl CentreBox {
    /// The box of the given points (tool frame, mm); the origin alone for none.
    pub fn of_points(points: impl IntoIterator<Item = [f64; 3]>) -> Self {
        let mut points = points.into_iter().map(Vector3::from);
        let Some(first) = points.next() else {
            return Self::of_box(Vector3::zeros(), Vector3::zeros());
        };
        let radial_of =
            |c: &Vector3<f64>| Vector3::new(c.y.hypot(c.z), c.x.hypot(c.z), c.x.hypot(c.y));
        let (lo, hi, radial) = points
            .fold((first, first, radial_of(&first)), |(lo, hi, radial), c| {
                (lo.inf(&c), hi.sup(&c), radial.sup(&radial_of(&c)))
            });
        Self {
            lo,
            hi,
            radial,
            axis_arms: true,
        }
    }

    /// The box from `lo` to `hi` (tool frame, mm) and any points inside it: the distances
    /// from the axes are the corners'.
    pub fn of_box(lo: Vector3<f64>, hi: Vector3<f64>) -> Self {
        let far = lo.abs().sup(&hi.abs());
        let radial = Vector3::new(far.y.hypot(far.z), far.x.hypot(far.z), far.x.hypot(far.y));
        Self {
            lo,
            hi,
            radial,
            axis_arms: false,
        }
    }

    /// The same box with [`CentreBox::axis_arms`] set to `on`.
    pub fn with_axis_arms(self, on: bool) -> Self {
        Self {
            axis_arms: on,
            ..self
        }
    }

    /// Corner `c` (0–7: bit 0 x, bit 1 y, bit 2 z high).
    pub fn corner(&self, c: usize) -> Vector3<f64> {
        Vector3::new(
            if c & 1 == 0 { self.lo.x } else { self.hi.x },
            if c & 2 == 0 { self.lo.y } else { self.hi.y },
            if c & 4 == 0 { self.lo.z } else { self.hi.z },
        )
    }

    /// The largest distance (mm) of a corner from the tool origin.
    pub fn reach(&self) -> f64 {
        (0..8).map(|c| self.corner(c).norm()).fold(0.0, f64::max)
    }

    /// The largest distance (mm) of a point of the box, the tool at rotation `r`, from the
    /// unit world axis `u` through the tool origin: `|u × R p|` is convex in `p`, so its
    /// largest value over the box is at a corner.
    pub fn corner_arm(&self, r: &Matrix3<f64>, u: &Vector3<f64>) -> f64 {
        let a = r.transpose() * u;
        (0..8)
            .map(|c| a.cross(&self.corner(c)).norm_squared())
            .fold(0.0, f64::max)
            .sqrt()
    }

    /// The largest distance (mm) of a point held, the tool at rotation `r`, from the unit
    /// world axis `u` through the tool origin: [`CentreBox::corner_arm`], or with
    /// [`CentreBox::axis_arms`] the least of that and a bound about each tool axis `e`. With `a = R^T u` and a point `p = s e + q`, `q ⊥ e`,
    /// `|s|` at most the box's extent along `e` and `|q|` the points' distance from `e`:
    /// `|a × p| <= |s| |a × e| + |q|`.
    pub fn arm(&self, r: &Matrix3<f64>, u: &Vector3<f64>) -> f64 {
        if !self.axis_arms {
            return self.corner_arm(r, u);
        }
        let a = r.transpose() * u;
        let along = self.lo.abs().sup(&self.hi.abs());
        (0..3)
            .map(|k| along[k] * (1.0 - a[k] * a[k]).max(0.0).sqrt() + self.radial[k])
            .fold(self.corner_arm(r, u), f64::min)
    }

    /// How far (mm) a point held moves at most when the tool turns from `r_a` to `r_b`
    /// (about its origin): with `R_b R_a^T = exp(θ û)`, a point `x = R_a p` moves by
    /// `2 sin(θ/2) |û × x| <= θ |û × x|`, and so does every point of the shortest turn between
    /// them. `θ · reach` (the box's) where the axis is not defined (a non-finite input).
    pub fn turn_bound(&self, r_a: &Matrix3<f64>, r_b: &Matrix3<f64>) -> f64 {
        self.turn_bound_by(r_a, &rotation_log(&(r_b * r_a.transpose())))
    }

    /// [`CentreBox::turn_bound`] of the turn `w` (rotation vector, world, rad) from `r_a`,
    /// `r_b = exp(w) r_a`: for a caller that needs the turn for more than one bound.
    pub fn turn_bound_by(&self, r_a: &Matrix3<f64>, w: &Vector3<f64>) -> f64 {
        let th = w.norm();
        if th == 0.0 {
            0.0
        } else if th.is_finite() {
            th * self.arm(r_a, &(w / th))
        } else {
            f64::INFINITY
        }
    }
}

/// The rotation matrix `exp([w]x)` of a rotation vector `w` (axis times angle, rad).
#[inline]
pub fn rotation_exp(w: &Vector3<f64>) -> Matrix3<f64> {
    *Rotation3::from_scaled_axis(*w).matrix()
}

/// `Rz(alpha) · Ry(beta) · Rx(gamma)` (rad).
#[inline]
pub fn rotation_zyx(gamma: f64, beta: f64, alpha: f64) -> Matrix3<f64> {
    let (sg, cg) = gamma.sin_cos();
    let (sb, cb) = beta.sin_cos();
    let (sa, ca) = alpha.sin_cos();
    Matrix3::new(
        ca * cb,
        ca * sb * sg - sa * cg,
        ca * sb * cg + sa * sg,
        sa * cb,
        sa * sb * sg + ca * cg,
        sa * sb * cg - ca * sg,
        -sb,
        cb * sg,
        cb * cg,
    )
}

/// The rotation matrices a thread made last, each under its three angles' bits: a frame of
/// the engine asks for ~40 of a handful of poses (the hand's, the last answer's, a region's
/// centre, a list's pose: its motion bounds, its linearisations), and three sines and cosines
/// each were ~17 % of the bunny's mesh frames' samples. [`MEMO_SLOTS`] slots, each angle
/// triple in one of them (by a hash of the bits); a triple found there gives the matrix
/// [`rotation_zyx`] made of it, so nothing changes but the time. Per thread, so nothing is shared or locked; no slot
/// needs dropping, so a thread's memo is never torn down under it (and, were it, the matrix is
/// made as before).
struct RotationMemo;

/// One slot of [`RotationMemo`]: the angles' bits and their matrix.
#[derive(Clone, Copy)]
struct MemoSlot {
    key: [u64; 3],
    rot: Matrix3<f64>,
}

/// Slots of [`RotationMemo`] (a power of two, at least two).
const MEMO_SLOTS: usize = 8;
const _: () = assert!(MEMO_SLOTS.is_power_of_two() && MEMO_SLOTS >= 2);

thread_local! {
    static ROTATIONS: [std::cell::Cell<Option<MemoSlot>>; MEMO_SLOTS] =
        const { [const { std::cell::Cell::new(None) }; MEMO_SLOTS] };
}

impl RotationMemo {
    /// [`rotation_zyx`] of the angles (rad), from this thread's memo where they are in it.
    #[inline]
    fn rotation(gamma: f64, beta: f64, alpha: f64) -> Matrix3<f64> {
        let key = [gamma.to_bits(), beta.to_bits(), alpha.to_bits()];
        let mixed = (key[0] ^ key[1].rotate_left(21) ^ key[2].rotate_left(42))
            .wrapping_mul(0x9E37_79B9_7F4A_7C15);
        // The hash's top bits, as many as the slots need.
        let slot = (mixed >> (u64::BITS - MEMO_SLOTS.trailing_zeros())) as usize;
        ROTATIONS
            .try_with(|memo| {
                let cell = &memo[slot];
                match cell.get() {
                    Some(found) if found.key == key => found.rot,
                    _ => {
                        let rot = rotation_zyx(gamma, beta, alpha);
                        cell.set(Some(MemoSlot { key, rot }));
                        rot
                    }
                }
            })
            .unwrap_or_else(|_| rotation_zyx(gamma, beta, alpha))
    }
}

/// The exact partial derivatives of `R = Rz(alpha) Ry(beta) Rx(gamma)` with respect to
/// `(gamma, beta, alpha)` (rad): `[dR/dgamma, dR/dbeta, dR/dalpha]`.
pub fn rotation_zyx_partials(gamma: f64, beta: f64, alpha: f64) -> [Matrix3<f64>; 3] {
    let (sg, cg) = gamma.sin_cos();
    let (sb, cb) = beta.sin_cos();
    let (sa, ca) = alpha.sin_cos();
    let rx = Matrix3::new(1.0, 0.0, 0.0, 0.0, cg, -sg, 0.0, sg, cg);
    let ry = Matrix3::new(cb, 0.0, sb, 0.0, 1.0, 0.0, -sb, 0.0, cb);
    let rz = Matrix3::new(ca, -sa, 0.0, sa, ca, 0.0, 0.0, 0.0, 1.0);
    let drx = Matrix3::new(0.0, 0.0, 0.0, 0.0, -sg, -cg, 0.0, cg, -sg);
    let dry = Matrix3::new(-sb, 0.0, cb, 0.0, 0.0, 0.0, -cb, 0.0, -sb);
    let drz = Matrix3::new(-sa, -ca, 0.0, ca, -sa, 0.0, 0.0, 0.0, 0.0);
    [rz * ry * drx, rz * dry * rx, drz * ry * rx]
}

impl Pose {
    /// `world_from_tool * p_in_tool` (mm).
    #[inline]
    pub fn transform_point(&self, p_in_tool: &[f64; 3]) -> [f64; 3] {
        let w = self.rotation_matrix() * Vector3::from(*p_in_tool) + self.translation();
        [w.x, w.y, w.z]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every point held by a centre box moves by at most its turn bound, for random points,
    /// turns and boxes; the bound is the angle times the radius for a ring turning about its
    /// axis (the box's corners are `sqrt(2)` farther), never more than the angle times the
    /// box's reach, and a box of a box's corners bounds every point inside it.
    #[test]
    fn a_centre_box_bounds_every_points_turn_on_its_arm() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let v = |rng: &mut rand_chacha::ChaCha8Rng, s: f64| {
            Vector3::new(
                rng.random_range(-s..s),
                rng.random_range(-s..s),
                rng.random_range(-s..s),
            )
        };
        let mut tight = 0;
        for _ in 0..2000 {
            // Points about a random axis of the tool frame, or anywhere.
            let stretch = match rng.random_range(0..4) {
                k @ 0..=2 => Vector3::from_fn(|i, _| if i == k { 30.0 } else { 3.0 }),
                _ => Vector3::repeat(30.0),
            };
            let points: Vec<Vector3<f64>> = (0..12)
                .map(|_| v(&mut rng, 1.0).component_mul(&stretch))
                .collect();
            let held = CentreBox::of_points(points.iter().map(|p| [p.x, p.y, p.z]));
            let boxed = CentreBox::of_box(held.lo, held.hi);
            let r_a = rotation_exp(&v(&mut rng, 3.0));
            let r_b = rotation_exp(&v(&mut rng, 0.3)) * r_a;
            let bound = held.turn_bound(&r_a, &r_b);
            let angle = rotation_log(&(r_b * r_a.transpose())).norm();
            assert!(bound <= angle * held.reach() + 1e-9);
            assert!(bound <= boxed.turn_bound(&r_a, &r_b) + 1e-9);
            let mut largest = 0.0f64;
            for p in &points {
                let moved = (r_b * p - r_a * p).norm();
                assert!(moved <= bound + 1e-9, "{moved} > {bound}");
                largest = largest.max(moved);
            }
            // Any point inside the box, for the box's own bound.
            for _ in 0..8 {
                let t = Vector3::new(
                    rng.random_range(0.0..1.0),
                    rng.random_range(0.0..1.0),
                    rng.random_range(0.0..1.0),
                );
                let p = held.lo + (held.hi - held.lo).component_mul(&t);
                let moved = (r_b * p - r_a * p).norm();
                assert!(moved <= boxed.turn_bound(&r_a, &r_b) + 1e-9);
            }
            tight += usize::from(largest > 0.5 * bound);
        }
        assert!(
            tight > 1000,
            "{tight} of 2000 bounds within twice the motion"
        );
        // A ring of radius 2 mm, 40 mm long, turned 0.1 rad about its own axis: 0.2 mm on its
        // radius, against 0.1 · 2·sqrt(2) on the box's corners and 2 mm on the reach.
        let ring = (0..64).flat_map(|i| {
            let a = f64::from(i) * std::f64::consts::TAU / 64.0;
            [-20.0, 20.0].map(|z| [2.0 * a.cos(), 2.0 * a.sin(), z])
        });
        let shaft = CentreBox::of_points(ring);
        let turned = rotation_exp(&Vector3::new(0.0, 0.0, 0.1));
        let about = shaft.turn_bound(&Matrix3::identity(), &turned);
        assert!((about - 0.1 * 2.0).abs() < 1e-12, "{about}");
        let corners = CentreBox::of_box(shaft.lo, shaft.hi);
        let boxed = corners.turn_bound(&Matrix3::identity(), &turned);
        assert!((boxed - 0.1 * 8f64.sqrt()).abs() < 1e-12, "{boxed}");
        let by_corners = shaft.with_axis_arms(false);
        assert_eq!(by_corners.turn_bound(&Matrix3::identity(), &turned), boxed);
        assert!(about < 0.15 * 0.1 * shaft.reach());
        assert_eq!(shaft.turn_bound(&turned, &turned), 0.0);
        let empty = CentreBox::of_points(std::iter::empty());
        assert_eq!(empty.turn_bound(&Matrix3::identity(), &turned), 0.0);
    }

    #[test]
    fn rotation_matches_product_of_axis_rotations() {
        let (g, b, a) = (0.3, -0.7, 1.9);
        let r = Rotation3::from_axis_angle(&Vector3::z_axis(), a)
            * Rotation3::from_axis_angle(&Vector3::y_axis(), b)
            * Rotation3::from_axis_angle(&Vector3::x_axis(), g);
        assert!((r.matrix() - rotation_zyx(g, b, a)).norm() < 1e-12);
    }

    #[test]
    fn partials_match_finite_differences() {
        let (g, b, a) = (0.3, -0.7, 1.9);
        let d = rotation_zyx_partials(g, b, a);
        let h = 1e-6;
        let fd = [
            (rotation_zyx(g + h, b, a) - rotation_zyx(g - h, b, a)) / (2.0 * h),
            (rotation_zyx(g, b + h, a) - rotation_zyx(g, b - h, a)) / (2.0 * h),
            (rotation_zyx(g, b, a + h) - rotation_zyx(g, b, a - h)) / (2.0 * h),
        ];
        for k in 0..3 {
            assert!(
                (d[k] - fd[k]).norm() < 1e-8,
                "partial {k}: {} vs {}",
                d[k],
                fd[k]
            );
        }
    }

    #[test]
    fn isometry_round_trip() {
        let p = Pose::from_array([1.0, -2.0, 3.0, 0.4, -0.2, 2.5]);
        let back = Pose::from_isometry(&p.to_isometry());
        assert!((back.q - p.q).norm() < 1e-12, "{back:?}");
    }

    /// `rotation_log` inverts `rotation_exp` from tiny angles to just below pi, and
    /// `from_translation_rotation` keeps the orientation at the Euler singularity.
    #[test]
    fn log_exp_round_trip_and_gimbal_lock() {
        for (k, angle) in [
            1e-12,
            1e-7,
            1e-3,
            0.5,
            2.0,
            3.0,
            std::f64::consts::PI - 1e-5,
        ]
        .into_iter()
        .enumerate()
        {
            let axis = Vector3::new(0.3 + k as f64, -0.8, 0.5).normalize();
            let w = axis * angle;
            let back = rotation_log(&rotation_exp(&w));
            assert!(
                (back - w).norm() <= 1e-12 * angle.max(1.0),
                "{angle}: {back:?} vs {w:?}"
            );
        }
        for beta in [
            std::f64::consts::FRAC_PI_2,
            -std::f64::consts::FRAC_PI_2,
            0.3,
        ] {
            let r = rotation_zyx(0.7, beta, -1.2);
            let p = Pose::from_translation_rotation(&Vector3::new(1.0, 2.0, 3.0), &r);
            assert!((p.rotation_matrix() - r).norm() < 1e-9, "beta {beta}");
            assert_eq!(p.translation(), Vector3::new(1.0, 2.0, 3.0));
        }
    }

    /// Up to a quarter turn the log reads the matrix's skew part and trace, beyond it the
    /// quaternion: both agree to rounding on every side of the switch, and each keeps the
    /// digits of tiny turns (relative to the angle, not to one radian).
    #[test]
    fn the_log_from_the_skew_part_is_the_quaternion_s_to_rounding() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(7);
        let quarter = std::f64::consts::FRAC_PI_2;
        for k in 0..20_000 {
            let axis = Vector3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0f64),
            )
            .normalize();
            let angle = match k % 4 {
                0 => 10f64.powf(rng.random_range(-14.0..0.0)),
                1 => quarter + rng.random_range(-1e-6..1e-6),
                2 => rng.random_range(0.0..std::f64::consts::PI - 1e-6),
                _ => quarter * (1.0 + f64::EPSILON * f64::from(rng.random_range(-4..=4))),
            };
            let w = axis * angle;
            let r = rotation_exp(&w);
            let (by_skew, by_quaternion) = (rotation_log(&r), rotation_log_by_quaternion(&r));
            assert!(
                (by_skew - by_quaternion).norm() <= 1e-14 * angle.max(1e-300) + 1e-300,
                "{angle}: {by_skew:?} vs {by_quaternion:?}"
            );
            assert!(
                (by_skew - w).norm() <= 1e-14 * angle,
                "{angle}: {by_skew:?} vs {w:?}"
            );
        }
        assert_eq!(rotation_log(&Matrix3::identity()), Vector3::zeros());
        assert!(rotation_log(&Matrix3::from_element(f64::NAN))
            .iter()
            .all(|v| v.is_nan()));
    }

    /// A pose's matrix, from the memo or made anew, is bit for bit [`rotation_zyx`]'s: poses
    /// asked for again and again among many others (more than the memo's slots), signed zeros
    /// and a non-finite angle included, on two threads.
    #[test]
    fn a_rotation_from_the_memo_is_the_one_made_anew() {
        use rand::{Rng, SeedableRng};
        let check = |seed: u64| {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let mut pool: Vec<[f64; 3]> = (0..40)
                .map(|_| std::array::from_fn(|_| rng.random_range(-3.2..3.2)))
                .collect();
            pool.extend([[0.0, 0.0, 0.0], [-0.0, 0.0, -0.0], [f64::NAN, 0.1, 0.2]]);
            for _ in 0..20_000 {
                let [g, b, a] = pool[rng.random_range(0..pool.len())];
                let from_pose = Pose::from_array([0.0, 0.0, 0.0, g, b, a]).rotation_matrix();
                let made = rotation_zyx(g, b, a);
                let bits = |m: &Matrix3<f64>| m.map(f64::to_bits);
                assert_eq!(bits(&from_pose), bits(&made), "angles {g} {b} {a}");
            }
        };
        let other = std::thread::spawn(move || check(2));
        check(1);
        other.join().unwrap();
    }
}
