//! The seam between the viewer and a haptic simulation: [`Simulation`] takes a device pose and
//! fills a [`FrameState`]; [`SceneGeometry`] is what the page draws.

use collide::Pose;
use mesh::TriMesh;
use serde::Serialize;

/// Most contact pairs a [`FrameState`] carries for display; pairs beyond are counted in
/// [`FrameState::pairs`] but not listed.
pub const MAX_DISPLAY_CONTACTS: usize = 256;

/// One active contact pair, for display: the tool leaf sphere (posed at the graphic pose) and
/// the object leaf sphere, both in world coordinates.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct ContactPair {
    /// Tool sphere centre in the world at the graphic pose (mm).
    pub tool_centre: [f64; 3],
    /// Tool sphere radius (mm).
    pub tool_radius: f64,
    /// Object sphere centre in the world (mm).
    pub object_centre: [f64; 3],
    /// Object sphere radius (mm).
    pub object_radius: f64,
}

/// The state of one haptic frame, as the viewer shows it and the UDP bridge sends it.
///
/// Created once with capacity for [`MAX_DISPLAY_CONTACTS`] contacts and then overwritten
/// frame after frame without allocating.
#[derive(Debug, PartialEq, Serialize)]
pub struct FrameState {
    /// Frame counter since the loop started.
    pub frame: u64,
    /// Time since the loop started (s), `frame * dt`.
    pub t: f64,
    /// Device (haptic tool) configuration `(x, y, z, gamma, beta, alpha)` (mm, rad).
    pub device: [f64; 6],
    /// Graphic tool (god-object) configuration (mm, rad).
    pub graphic: [f64; 6],
    /// Force on the device (N), world frame.
    pub force: [f64; 3],
    /// Torque on the device (N·mm), world frame.
    pub torque: [f64; 3],
    /// Number of active contact pairs (constraint rows) this frame.
    pub pairs: u32,
    /// Deepest overlap of a tool leaf sphere with an object leaf sphere at the graphic pose (mm),
    /// 0 when none; reported by the simulation.
    pub penetration_mm: f64,
    /// Collision detection time (µs) as the simulation measured it (0 if not reported).
    pub cd_us: f64,
    /// QP solve time (µs) as the simulation measured it (0 if not reported).
    pub opt_us: f64,
    /// Wall time of the whole step as the loop measured it (µs).
    pub frame_us: f64,
    /// Largest `frame_us` over the last second of frames (µs).
    pub frame_us_max: f64,
    /// Frames whose step overran the period since the loop started.
    pub overruns: u64,
    /// True when no input source is live (none yet, or the UDP device timed out): the device
    /// is then held at the graphic pose and force and torque are zero.
    pub released: bool,
    /// Which input drove this frame: 0 none, 1 page, 2 UDP bridge, 3 scripted/test, 4 the
    /// device bridge.
    pub source: u8,
    /// Sequence number of the input command that drove this frame.
    pub input_seq: u64,
    /// The engagement of that command ([`crate::hub::DeviceCommand::engagement`]): when it
    /// changes between live frames, a new engagement began and the simulation restarts its
    /// output filters from zero.
    pub engagement: u64,
    /// True while the device trajectory is being recorded to CSV.
    pub recording: bool,
    /// Set by the loop before the step: a viewer wants the contact list this frame. A
    /// simulation may skip listing contacts when false.
    pub contacts_requested: bool,
    /// Set by the loop before the step: friction is wanted (the page's friction switch; on
    /// unless a page turned it off). A simulation without friction ignores it.
    pub friction_on: bool,
    /// What friction did this frame, as the simulation reports it: 0 nothing, 1 stick, 2 slip.
    pub friction: u8,
    /// Up to [`MAX_DISPLAY_CONTACTS`] active contact pairs.
    pub contacts: Vec<ContactPair>,
}

impl Default for FrameState {
    fn default() -> Self {
        Self {
            frame: 0,
            t: 0.0,
            device: [0.0; 6],
            graphic: [0.0; 6],
            force: [0.0; 3],
            torque: [0.0; 3],
            pairs: 0,
            penetration_mm: 0.0,
            cd_us: 0.0,
            opt_us: 0.0,
            frame_us: 0.0,
            frame_us_max: 0.0,
            overruns: 0,
            released: true,
            source: 0,
            input_seq: 0,
            engagement: 0,
            recording: false,
            contacts_requested: false,
            friction_on: true,
            friction: 0,
            contacts: Vec::with_capacity(MAX_DISPLAY_CONTACTS),
        }
    }
}

impl Clone for FrameState {
    /// A copy whose contact list keeps room for [`MAX_DISPLAY_CONTACTS`] (so later copies into
    /// it do not allocate).
    fn clone(&self) -> Self {
        let mut c = self.shallow();
        c.contacts = Vec::with_capacity(MAX_DISPLAY_CONTACTS.max(self.contacts.len()));
        c.contacts.extend_from_slice(&self.contacts);
        c
    }
}

impl FrameState {
    /// Adds a contact pair for display if there is room (returns false, and drops it, when
    /// [`MAX_DISPLAY_CONTACTS`] are already listed).
    ///
    /// # Real-time
    /// Never allocates (the vector was sized at construction), never panics, O(1).
    #[inline]
    pub fn push_contact(&mut self, pair: ContactPair) -> bool {
        if self.contacts.len() < MAX_DISPLAY_CONTACTS {
            self.contacts.push(pair);
            true
        } else {
            false
        }
    }

    /// Copies `other` into `self` reusing `self`'s contact buffer.
    ///
    /// # Real-time
    /// Never allocates while both vectors keep their construction capacity; O(contacts).
    pub fn copy_from(&mut self, other: &FrameState) {
        let contacts = std::mem::take(&mut self.contacts);
        *self = FrameState {
            contacts,
            ..other.shallow()
        };
        self.contacts.clear();
        let n = other.contacts.len().min(MAX_DISPLAY_CONTACTS);
        self.contacts.extend_from_slice(&other.contacts[..n]);
    }

    /// All fields but the contact list (left empty, no allocation).
    fn shallow(&self) -> FrameState {
        FrameState {
            frame: self.frame,
            t: self.t,
            device: self.device,
            graphic: self.graphic,
            force: self.force,
            torque: self.torque,
            pairs: self.pairs,
            penetration_mm: self.penetration_mm,
            cd_us: self.cd_us,
            opt_us: self.opt_us,
            frame_us: self.frame_us,
            frame_us_max: self.frame_us_max,
            overruns: self.overruns,
            released: self.released,
            source: self.source,
            input_seq: self.input_seq,
            engagement: self.engagement,
            recording: self.recording,
            contacts_requested: self.contacts_requested,
            friction_on: self.friction_on,
            friction: self.friction,
            contacts: Vec::new(),
        }
    }

    /// Euclidean norm of the force (N).
    pub fn force_norm(&self) -> f64 {
        self.force.iter().map(|f| f * f).sum::<f64>().sqrt()
    }
}

/// One mesh as the page draws it, in mm.
#[derive(Clone, Debug)]
pub struct NamedMesh {
    /// Display name.
    pub name: String,
    /// The triangles, in mm: world frame for objects, tool frame for the tool.
    pub mesh: TriMesh,
    /// Fixed world pose of an object `(x, y, z, gamma, beta, alpha)` (mm, rad); the vertices
    /// are in the object's own frame. Identity for the tool (posed live).
    pub pose: [f64; 6],
}

/// The static scene the page draws once: object meshes and the tool mesh.
#[derive(Clone, Debug)]
pub struct SceneGeometry {
    /// Scene name (a built-in's such as `bunny` or `probe`, or the scene file's name).
    pub name: String,
    /// The tool, in the tool frame (mm).
    pub tool: NamedMesh,
    /// The static objects (mm).
    pub objects: Vec<NamedMesh>,
    /// Translational stiffness kt (N/mm), for the page's arrow scales.
    pub kt: f64,
    /// Rotational stiffness kr (N·mm/rad).
    pub kr: f64,
    /// Largest force the device may render (N); arrows and plots are scaled to it.
    pub max_force: f64,
    /// True when some object has friction (the page then offers its on/off switch).
    pub friction: bool,
}

/// A haptic simulation the viewer can drive: it takes the device pose each frame and reports
/// the graphic pose, the wrench and the contacts.
///
/// The viewer calls [`Simulation::step`] from its haptic thread at the loop rate; every other
/// method is called once at set-up.
pub trait Simulation: Send + 'static {
    /// The static geometry for the page (called once at set-up; may allocate).
    fn scene(&self) -> SceneGeometry;

    /// The configuration the device starts at (mm, rad); a free pose.
    fn start_pose(&self) -> Pose;

    /// One haptic frame: move the god-object toward `device` and write the graphic pose,
    /// force (N), torque (N·mm), pair count, penetration and timings into `out`. The caller has
    /// already set `out.device`, `out.frame`, `out.t`, `out.released` (no live input: the
    /// caller zeroes the wrench after the step; a simulation with output filters should reset
    /// them so the next engagement starts from zero) and cleared `out.contacts`; contacts are
    /// added with [`FrameState::push_contact`].
    ///
    /// # Real-time
    /// Implementations must not allocate, block or panic, and must finish in bounded time.
    fn step(&mut self, device: &Pose, out: &mut FrameState);

    /// Re-seats the god-object at `pose` (a free configuration), e.g. after the user asks to
    /// reset. Called from the haptic thread between frames.
    fn reset(&mut self, pose: &Pose);

    /// Uses the loop's wait before the next [`Simulation::step`], returning by `until` (called
    /// once per frame as the loop's spin before the deadline begins): background work the
    /// steps would otherwise do in slices, and bringing what the next step reads into cache.
    /// It may change which work the next steps do, not what they answer. The default does
    /// nothing.
    ///
    /// # Real-time
    /// Must not allocate, block or panic.
    fn idle(&mut self, until: std::time::Instant) {
        let _ = until;
    }
}
