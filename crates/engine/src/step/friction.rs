//! Friction: Coulomb stick and slip of the graphic tool (docs/DESIGN.md, "Friction").
//!
//! The friction-cone god-object (Salisbury et al.'s, in six dimensions), decided at the start of
//! each frame from the contact the last frame ended in: its normal `n` (the direction of the
//! contact rows' resultant force), its coefficients (the rows' multiplier-weighted mean), and
//! the patch's torsional radius `rho` (the touching pairs' mean distance from their centroid
//! across `n`: `2/3 a` for a disc of radius `a`, the torsional friction of uniform pressure).
//!
//! With the tool at `q_prev` and the hand at `q_h`, the spring pulls the tool with
//! `F = kt (t_h - t_prev)` and `T = kr log(R_h R_prev^T)`. The contact holds its normal part,
//! `N = -F·n` (no friction when the hand pulls away, `N <= 0`); friction must hold the rest, the
//! tangential force `F_t = F - (F·n) n` and the twist `T_n = T·n`, whose size on the limit
//! surface is `phi = sqrt(|F_t|² + (T_n / rho)²)`.
//!
//! - **Stick** while `phi <= mu N`: the tool stays at `q_prev` (a pose proven free already); no
//!   detection or solve is needed.
//! - **Slip** otherwise: the frame's frictionless step runs toward a goal held back from the hand
//!   by the friction, `t_goal = t_h - k F_t / kt` and `R_goal = exp(-(k T_n / kr) n) R_h` with
//!   `k = mu N / phi`. On a flat contact the answer then feels exactly `mu N` along the pull
//!   (and `mu N rho` of twist): the spring's tangential part toward the goal is zero at the
//!   answer, and toward the hand it is `k (F_t, T_n)`, of size `k phi = mu N` on the limit surface.
//!
//! `mu` is the static coefficient while the tool sticks (so the force at breakaway is `mu_s N`)
//! and the kinetic one while it slides (the hysteresis that keeps the stick/slip boundary from
//! chattering). The force on the hand is always the spring `G (q_g - q_h)`, and the goal lies
//! between the hand and the tool: friction never pushes the hand harder than the spring it
//! stretched. The answer of a slipping frame is proven free as every frame's is.

use super::*;

/// Coulomb friction coefficients of a material, or of a tool–object pair (dimensionless).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Friction {
    /// Static coefficient: a sticking tool breaks away when the tangential force exceeds
    /// `static_mu · N`.
    pub static_mu: f64,
    /// Kinetic coefficient: a sliding tool is held back by `kinetic_mu · N` (at most
    /// `static_mu`).
    pub kinetic_mu: f64,
}

impl Friction {
    /// No friction (the default).
    pub const NONE: Friction = Friction {
        static_mu: 0.0,
        kinetic_mu: 0.0,
    };

    /// True when both coefficients are zero.
    pub fn is_none(&self) -> bool {
        self.static_mu == 0.0 && self.kinetic_mu == 0.0
    }

    /// The coefficients of a tool of material `tool` on an object of material `self`: the
    /// object's alone when the tool has none given, else the geometric mean of each
    /// coefficient (as Bullet and Box2D mix them).
    pub fn with_tool(&self, tool: Option<Friction>) -> Friction {
        match tool {
            None => *self,
            Some(t) => Friction {
                static_mu: (self.static_mu * t.static_mu).sqrt(),
                kinetic_mu: (self.kinetic_mu * t.kinetic_mu).sqrt(),
            },
        }
    }

    /// Checks both coefficients against [`crate::config::FRICTION_STATIC`] and
    /// [`crate::config::FRICTION_KINETIC`], and `kinetic_mu <= static_mu`; `what` names the
    /// material in the message (`[[object]] 2 friction`).
    pub fn validate(&self, what: &str) -> Result<(), crate::config::SettingError> {
        use crate::config::{FRICTION_KINETIC, FRICTION_STATIC};
        FRICTION_STATIC.check_as(&format!("{what}.static"), self.static_mu)?;
        FRICTION_KINETIC.check_as(&format!("{what}.kinetic"), self.kinetic_mu)?;
        if self.kinetic_mu > self.static_mu {
            return Err(crate::config::SettingError {
                key: format!("{what}.kinetic"),
                value: self.kinetic_mu.to_string(),
                expected: format!("at most the static coefficient {}", self.static_mu),
            });
        }
        Ok(())
    }
}

/// What friction did in a frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FrictionState {
    /// No friction acted (frictionless materials, friction off, or no contact).
    #[default]
    None,
    /// The tool stuck: it stayed where it was.
    Stick,
    /// The tool slid, held back by the kinetic (or, breaking away, the static) friction.
    Slip,
}

impl FrictionState {
    /// A number for other languages and wire formats: 0 none, 1 stick, 2 slip.
    pub fn code(&self) -> u8 {
        match self {
            Self::None => 0,
            Self::Stick => 1,
            Self::Slip => 2,
        }
    }

    /// The name: `none`, `stick`, `slip`.
    pub fn name(&self) -> &'static str {
        match self {
            Self::None => "none",
            Self::Stick => "stick",
            Self::Slip => "slip",
        }
    }
}

/// The contact a frame ended in, as friction needs it in the next frame.
#[derive(Clone, Copy, Debug)]
pub(super) struct Patch {
    /// Unit normal (world), the direction the contact pushes the tool.
    normal: Vector3<f64>,
    /// Centre of pressure: the contact points weighted by their normal forces (world, mm, at
    /// `q_g`).
    centroid: Vector3<f64>,
    /// Torsional radius, mm: the touching pairs' mean distance from the centre of pressure
    /// across the normal.
    rho: f64,
    friction: Friction,
}

/// True for a number above zero (false for zero, negative or NaN).
fn positive(x: f64) -> bool {
    x > 0.0
}

/// Below this torsional radius (mm) the contact is a point: twisting about its normal is free.
const POINT_CONTACT_MM: f64 = 1e-6;

impl GodObject {
    /// Friction per object as set (the pair's coefficients come from these and the tool's).
    pub fn friction(&self, object: usize) -> Option<Friction> {
        self.materials.object_friction.get(object).copied()
    }

    /// Sets the friction of object `object` (0-based index in the objects given to
    /// [`GodObject::new`]). Errors on an index out of range or coefficients out of their
    /// ranges.
    pub fn set_friction(&mut self, object: usize, f: Friction) -> Result<(), EngineError> {
        f.validate(&format!("[[object]] {} friction", object + 1))?;
        let n = self.materials.object_friction.len();
        let slot = self
            .materials
            .object_friction
            .get_mut(object)
            .ok_or(EngineError::NoSuchObject { object, objects: n })?;
        *slot = f;
        Ok(())
    }

    /// Sets the tool's material friction (`None`: the objects' coefficients alone).
    pub fn set_tool_friction(&mut self, f: Option<Friction>) -> Result<(), EngineError> {
        if let Some(f) = f {
            f.validate("[tool] friction")?;
        }
        self.materials.tool_friction = f;
        Ok(())
    }

    /// The contact the last frame ended in, as friction sees it: its unit normal (world) and
    /// torsional radius (mm); `None` without a frictional contact.
    pub fn friction_contact(&self) -> Option<([f64; 3], f64)> {
        self.run.friction.patch.map(|p| (p.normal.into(), p.rho))
    }

    /// Turns friction on or off without forgetting the coefficients (off: the frictionless
    /// step, frame for frame).
    pub fn set_friction_enabled(&mut self, on: bool) {
        self.materials.friction_on = on;
        self.run.friction.sliding = false;
        self.run.friction.patch = None;
    }

    /// True when friction is on, the rotation coordinates are rotation vectors (friction's
    /// twist is a rotation about the contact normal) and some object has a non-zero
    /// coefficient.
    pub fn friction_active(&self) -> bool {
        self.materials.friction_on
            && self.params.rotation == RotationCoordinates::RotationVector
            && self
                .materials
                .object_friction
                .iter()
                .any(|f| !f.with_tool(self.materials.tool_friction).is_none())
    }

    /// Remembers the contact the frame ended in at `q`, from its last solve over the listed
    /// pairs (or forgets it when there is none): the rows' multipliers, each times the length
    /// of its row's translational part, are the contact forces (N) along the rows' normals;
    /// they give the normal (their resultant's direction), the coefficients (their weighted
    /// mean) and the centre of pressure; the pairs touching at `q` give the patch's spread.
    pub(super) fn remember_patch(&mut self, q: &Pose) {
        self.run.friction.patch = None;
        // A pair's contact point at q: on the tool sphere, toward what the pair stands for
        // (the object sphere or its face); and its gap.
        let (rot, t) = (q.rotation_matrix(), q.translation());
        // Row i's contact point and gap at q, and its object: a leaf pair's (on the tool
        // sphere, toward what the pair stands for), or a triangle pair's nearest tool point.
        let mesh = self.bodies.meshes.is_some();
        let point = |i: usize| -> Option<(Vector3<f64>, f64, u32)> {
            if mesh {
                let object = self.detector.contacts.get(i)?.object;
                let (at, gap) = self.mesh_contact_point(i, &rot, &t)?;
                Some((at, gap, object))
            } else {
                let p = self.detector.pairs.get(i)?;
                let (at, gap, _) = p.contact_posed(&rot, &t);
                Some((Vector3::from(at), gap, p.object))
            }
        };
        let y = self.qp.rows_solver.multipliers();
        let n_pairs = self.listed_rows().min(y.len());
        let (mut total, mut resultant, mut centre) = (0.0, Vector3::zeros(), Vector3::zeros());
        let (mut mu_s, mut mu_k) = (0.0, 0.0);
        for (i, &lambda) in y.iter().enumerate().take(n_pairs) {
            if !positive(lambda) {
                continue;
            }
            let Some((at, _, object)) = point(i) else {
                continue;
            };
            let row = &self.qp.rows[i];
            let normal = Vector3::new(row[0], row[1], row[2]);
            let force = lambda * normal.norm();
            let f = self
                .materials
                .object_friction
                .get(object as usize)
                .copied()
                .unwrap_or_default()
                .with_tool(self.materials.tool_friction);
            total += force;
            mu_s += force * f.static_mu;
            mu_k += force * f.kinetic_mu;
            resultant += normal * lambda;
            centre += at * force;
        }
        if !positive(total) || !positive(resultant.norm()) || (mu_s == 0.0 && mu_k == 0.0) {
            return;
        }
        let n = resultant / resultant.norm();
        let centre = centre / total;
        // Faces lying flat on each other (the mesh mode): the patch is the area they share,
        // under a uniform pressure.
        if let Some((area, moment)) = self.flat_contact_area(q, &n, &centre) {
            self.run.friction.patch = Some(Patch {
                normal: n,
                centroid: centre,
                rho: moment / area,
                friction: Friction {
                    static_mu: mu_s / total,
                    kinetic_mu: mu_k / total,
                },
            });
            return;
        }
        let (mut spread, mut count) = (0.0, 0usize);
        for i in 0..self.listed_rows() {
            let Some((c, gap, _)) = point(i) else {
                continue;
            };
            if gap <= TOUCH_MM {
                let r = c - centre;
                spread += (r - n * r.dot(&n)).norm();
                count += 1;
            }
        }
        self.run.friction.patch = Some(Patch {
            normal: n,
            centroid: centre,
            rho: if count > 0 {
                spread / count as f64
            } else {
                0.0
            },
            friction: Friction {
                static_mu: mu_s / total,
                kinetic_mu: mu_k / total,
            },
        });
    }

    /// Where this frame's step goes for the hand at `hand`: the hand itself (no contact, or the
    /// hand pulls away), nowhere (the tool sticks: [`FrictionState::Stick`]), or a goal held
    /// back from the hand by the friction ([`FrictionState::Slip`]).
    pub(super) fn friction_goal(&mut self, hand: &Pose) -> (Pose, FrictionState) {
        let Some(patch) = self.run.friction.patch else {
            self.run.friction.sliding = false;
            return (*hand, FrictionState::None);
        };
        let (kt, kr) = (self.params.kt, self.params.kr);
        let r_g = self.run.motion.q_g.rotation_matrix();
        let r_h = hand.rotation_matrix();
        let f = (hand.translation() - self.run.motion.q_g.translation()) * kt;
        let torque = rotation_log(&(r_h * r_g.transpose())) * kr;
        let n = patch.normal;
        let normal_force = -f.dot(&n);
        let mu = if self.run.friction.sliding {
            patch.friction.kinetic_mu
        } else {
            patch.friction.static_mu
        };
        if !positive(normal_force) || !positive(mu) {
            self.run.friction.sliding = false;
            return (*hand, FrictionState::None);
        }
        let f_t = f + n * normal_force;
        // The twist friction must hold: the spring's moment about the patch's centroid, along
        // the normal.
        let twist = if patch.rho > POINT_CONTACT_MM {
            (torque + (self.run.motion.q_g.translation() - patch.centroid).cross(&f)).dot(&n)
        } else {
            0.0
        };
        let phi = (f_t.norm_squared() + (twist / patch.rho.max(POINT_CONTACT_MM)).powi(2)).sqrt();
        let limit = mu * normal_force;
        // Inside the cone the goal takes the whole pull away (the contact does not slide; the
        // tool may still settle along the normal and tilt); outside, what friction holds.
        let (k, state) = if phi <= limit {
            self.run.friction.sliding = false;
            (1.0, FrictionState::Stick)
        } else {
            self.run.friction.sliding = true;
            (limit / phi, FrictionState::Slip)
        };
        // Held back by k of the pull: the force by k F_t, the turn about n by k of the spring's
        // torque about n (with the force's shift, the moment about the centre of pressure then
        // drops by k of `twist` as well).
        let turn = if patch.rho > POINT_CONTACT_MM {
            torque.dot(&n)
        } else {
            0.0
        };
        let goal = Pose::from_translation_rotation(
            &(hand.translation() - f_t * (k / kt)),
            &(rotation_exp(&(n * (-k * turn / kr))) * r_h),
        );
        if !goal.is_finite() {
            self.run.friction.sliding = false;
            return (*hand, FrictionState::None);
        }
        (goal, state)
    }
}
