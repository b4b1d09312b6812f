//! The MuJoCo peer: the same virtual coupling as [`crate::PeerTool`], run by MuJoCo's Python
//! package in a virtual environment of its own.
//!
//! The bench writes a case to a folder ([`MujocoCase::write`]: the convex pieces as OBJ files,
//! the hand's poses per frame, the coupling, one or more option sets), runs the shipped script
//! ([`SCRIPT`], `crates/peer/mujoco/peer_mujoco.py`) on it with the environment's Python, and
//! reads back per frame the tool pose, the coupling force on the hand and the time of the
//! frame's `mj_step` calls ([`MujocoCase::run`]). The measures are then taken in Rust, as for
//! the other engines.
//!
//! The environment ([`MujocoEnv`]) is a venv in haptic6d's cache folder with [`MUJOCO_VERSION`]
//! and [`NUMPY_VERSION`] from PyPI (pinned), made by [`MujocoEnv::install`]; nothing is
//! installed system-wide.

use std::path::{Path, PathBuf};
use std::process::Command;

use collide::Pose;
use mesh::TriMesh;
use serde::Serialize;

use crate::{PeerFrame, PeerParams};

/// The MuJoCo release the peer installs and was tuned on (PyPI's `mujoco`).
pub const MUJOCO_VERSION: &str = "4.0.1";

/// The numpy release installed beside it.
pub const NUMPY_VERSION: &str = "2.4.6";

/// The peer's script, shipped in the binary and written beside each case.
pub const SCRIPT: &str = include_str!("../mujoco/peer_mujoco.py");

/// Metres per millimetre.
const M_PER_MM: f64 = 1e-3;

/// Numbers per frame in the script's output.
const OUT_STRIDE: usize = 16;

/// Why the MuJoCo peer could not run.
#[derive(Debug, thiserror::Error)]
pub enum MujocoError {
    /// A file or process could not be made or read.
    #[error("{path}: {why}")]
    Io {
        /// The file, folder or program.
        path: PathBuf,
        /// What went wrong.
        why: String,
    },
    /// The script failed (its last error line).
    #[error("MuJoCo peer: {0}")]
    Script(String),
    /// The script's output has the wrong size.
    #[error("{path}: {got} numbers, expected {expected}")]
    BadOutput {
        /// The output file.
        path: PathBuf,
        /// Numbers read.
        got: usize,
        /// Numbers expected (frames × 16).
        expected: usize,
    },
}

fn io_err(path: &Path, e: impl std::fmt::Display) -> MujocoError {
    MujocoError::Io {
        path: path.to_path_buf(),
        why: e.to_string(),
    }
}

/// MuJoCo's own settings of one run (its XML `option` and the geoms' contact attributes).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct MujocoOptions {
    /// MuJoCo steps per haptic frame (`timestep` = 1 / (rate × substeps)).
    pub substeps: u32,
    /// The constraint solver's iterations per step (`option iterations`, MuJoCo's default 100).
    pub iterations: u32,
    /// The solver: `Newton` (MuJoCo's default), `CG` or `PGS`.
    pub solver: &'static str,
    /// Friction cone: `pyramidal` (MuJoCo's default) or `elliptic`.
    pub cone: &'static str,
    /// Post-solve iterations that remove friction slip (`option noslip_iterations`; 0 = off).
    pub noslip_iterations: u32,
    /// Contact dimensionality: 1 = frictionless normal only (as haptic6d), 3 = with friction.
    pub condim: u32,
    /// Sliding friction coefficient (with `condim` 3).
    pub friction: f64,
    /// `solref`: the contact's time constant, s, and damping ratio.
    pub solref: [f64; 2],
    /// `solimp`: impedance `dmin`, `dmax`, transition width (m), midpoint, power.
    pub solimp: [f64; 5],
    /// Contact margin: contacts become active this far before touching, m.
    pub margin_m: f64,
    /// Integrator: `Euler` (MuJoCo's default), `implicitfast`, `implicit` or `RK4`.
    pub integrator: &'static str,
    /// MuJoCo's `multiccd`: several contact points per pair of convex meshes instead of one
    /// (on by default since MuJoCo 4, where it became a disable flag).
    pub multiccd: bool,
}

impl MujocoOptions {
    /// MuJoCo's defaults, frictionless (condim 1), one step per frame.
    pub fn defaults() -> Self {
        Self {
            substeps: 1,
            iterations: 100,
            solver: "Newton",
            cone: "pyramidal",
            noslip_iterations: 0,
            condim: 1,
            friction: 0.0,
            solref: [0.02, 1.0],
            solimp: [0.9, 0.95, 0.001, 0.5, 2.0],
            margin_m: 0.0,
            integrator: "Euler",
            multiccd: true,
        }
    }

    /// The options the tuning search chose (docs/BENCHMARKS.md, the peer section): 8 steps
    /// per frame, the stiffest `solref` MuJoCo accepts at that step (time constant twice the
    /// timestep) with a damping ratio of 0.5, a stiff narrow `solimp`, one contact point per
    /// convex pair (`multiccd` off); frictionless.
    pub fn tuned() -> Self {
        Self {
            substeps: 8,
            solref: [0.00025, 0.5],
            solimp: [0.95, 0.99, 0.0001, 0.5, 2.0],
            multiccd: false,
            ..Self::defaults()
        }
    }
}

/// The Python environment that runs the MuJoCo peer.
#[derive(Clone, Debug)]
pub struct MujocoEnv {
    /// The venv's folder.
    pub venv: PathBuf,
}

impl MujocoEnv {
    /// The environment in haptic6d's cache folder `cache_dir` (`<cache>/mujoco-<version>`).
    pub fn in_cache(cache_dir: &Path) -> Self {
        Self {
            venv: cache_dir.join(format!("mujoco-{MUJOCO_VERSION}")),
        }
    }

    /// The venv's Python.
    pub fn python(&self) -> PathBuf {
        self.venv.join("bin").join("python")
    }

    /// The MuJoCo version the environment imports, or why it cannot run (one line).
    pub fn probe(&self) -> Result<String, String> {
        let python = self.python();
        if !python.exists() {
            return Err(format!("no Python environment at {}", self.venv.display()));
        }
        let out = Command::new(&python)
            .args(["-c", "import mujoco, numpy; print(mujoco.__version__)"])
            .output()
            .map_err(|e| format!("{}: {e}", python.display()))?;
        if !out.status.success() {
            let err = String::from_utf8_lossy(&out.stderr);
            let last = err.lines().last().unwrap_or("").trim().to_string();
            return Err(format!("{}: {last}", python.display()));
        }
        Ok(String::from_utf8_lossy(&out.stdout).trim().to_string())
    }

    /// Makes the venv with `python3 -m venv` and installs the pinned `mujoco` and `numpy` from
    /// PyPI into it (needs the network once; about 200 MB).
    pub fn install(&self) -> Result<(), MujocoError> {
        if !self.python().exists() {
            run(Command::new("python3").args(["-m", "venv"]).arg(&self.venv))?;
        }
        run(Command::new(self.python()).args([
            "-m",
            "pip",
            "install",
            "-q",
            "--disable-pip-version-check",
            &format!("mujoco=={MUJOCO_VERSION}"),
            &format!("numpy=={NUMPY_VERSION}"),
        ]))
    }
}

fn run(cmd: &mut Command) -> Result<(), MujocoError> {
    let program = PathBuf::from(cmd.get_program());
    let out = cmd.output().map_err(|e| io_err(&program, e))?;
    if out.status.success() {
        return Ok(());
    }
    let err = String::from_utf8_lossy(&out.stderr);
    let last = err
        .lines()
        .rev()
        .find(|l| !l.trim().is_empty())
        .unwrap_or("failed without a message");
    Err(MujocoError::Script(last.trim().to_string()))
}

/// One case for the MuJoCo peer: the tool's and objects' convex pieces, the hand's poses.
pub struct MujocoCase<'a> {
    /// The tool's convex pieces in the tool frame, mm.
    pub tool: &'a [TriMesh],
    /// Each object's convex pieces in its own frame (mm) and its pose (mm, rad).
    pub objects: &'a [(Vec<TriMesh>, Pose)],
    /// The hand's pose per frame (mm, rad); the tool starts at the first.
    pub hand: &'a [Pose],
    /// The coupling (stiffness, damping ratio, mass, rate; rapier's own fields are unused).
    pub coupling: PeerParams,
}

/// A pose as `[x, y, z]` m and the quaternion `[w, x, y, z]`.
fn pose_si(q: &Pose) -> ([f64; 3], [f64; 4]) {
    let iso = q.to_isometry();
    let t = iso.translation.vector * M_PER_MM;
    let r = iso.rotation;
    ([t.x, t.y, t.z], [r.w, r.i, r.j, r.k])
}

fn write_obj(path: &Path, mesh: &TriMesh) -> Result<(), MujocoError> {
    use std::fmt::Write as _;
    let mut s = String::new();
    for v in &mesh.vertices {
        let _ = writeln!(
            s,
            "v {:e} {:e} {:e}",
            v[0] * M_PER_MM,
            v[1] * M_PER_MM,
            v[2] * M_PER_MM
        );
    }
    for t in &mesh.triangles {
        let _ = writeln!(s, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    std::fs::write(path, s).map_err(|e| io_err(path, e))
}

impl MujocoCase<'_> {
    /// Writes the case into `dir` (created if missing) with one run per entry of `runs`.
    pub fn write(&self, dir: &Path, runs: &[MujocoOptions]) -> Result<(), MujocoError> {
        std::fs::create_dir_all(dir).map_err(|e| io_err(dir, e))?;
        let mut tool = Vec::new();
        for (k, piece) in self.tool.iter().enumerate() {
            let name = format!("tool_{k}.obj");
            write_obj(&dir.join(&name), piece)?;
            tool.push(name);
        }
        let mut objects = Vec::new();
        for (i, (pieces, pose)) in self.objects.iter().enumerate() {
            let mut names = Vec::new();
            for (k, piece) in pieces.iter().enumerate() {
                let name = format!("object{i}_{k}.obj");
                write_obj(&dir.join(&name), piece)?;
                names.push(name);
            }
            let (pos, quat) = pose_si(pose);
            objects.push(serde_json::json!({ "pieces": names, "pos": pos, "quat": quat }));
        }
        let p = &self.coupling;
        let kt = p.kt_n_per_mm / M_PER_MM;
        let kr = p.kr_nmm_per_rad * M_PER_MM;
        let inertia = p.inertia_kg_m2();
        let c = 2.0 * p.damping_ratio * (kt * p.mass_kg).sqrt();
        let cr = 2.0 * p.damping_ratio * (kr * inertia).sqrt();
        let start = self.hand.first().copied().unwrap_or_default();
        let (sp, sq) = pose_si(&start);
        let case = serde_json::json!({
            "rate_hz": p.rate_hz,
            "frames": self.hand.len(),
            "coupling": { "kt": kt, "kr": kr, "c": c, "cr": cr, "mass": p.mass_kg, "inertia": inertia },
            "tool": tool,
            "objects": objects,
            "start": [sp[0], sp[1], sp[2], sq[0], sq[1], sq[2], sq[3]],
            "runs": runs.iter().map(|r| serde_json::json!({
                "substeps": r.substeps,
                "iterations": r.iterations,
                "solver": r.solver,
                "cone": r.cone,
                "noslip_iterations": r.noslip_iterations,
                "condim": r.condim,
                "friction": r.friction,
                "solref": r.solref,
                "solimp": r.solimp,
                "margin": r.margin_m,
                "integrator": r.integrator,
                "multiccd": r.multiccd,
            })).collect::<Vec<_>>(),
        });
        let path = dir.join("case.json");
        std::fs::write(&path, case.to_string()).map_err(|e| io_err(&path, e))?;
        let mut hand = Vec::with_capacity(self.hand.len() * 56);
        for q in self.hand {
            let (t, r) = pose_si(q);
            for x in t.iter().chain(&r) {
                hand.extend_from_slice(&x.to_le_bytes());
            }
        }
        let path = dir.join("hand.bin");
        std::fs::write(&path, hand).map_err(|e| io_err(&path, e))?;
        let path = dir.join("peer_mujoco.py");
        std::fs::write(&path, SCRIPT).map_err(|e| io_err(&path, e))
    }

    /// Writes the case into `dir`, runs every option set of `runs` in `env`, and returns each
    /// run's frames (the tool's pose in mm and rad, the wrench on the hand in N and N·mm, the
    /// contacts, the time of the frame's MuJoCo steps in µs). A run that blew up has NaN poses
    /// from the frame it did.
    pub fn run(
        &self,
        env: &MujocoEnv,
        dir: &Path,
        runs: &[MujocoOptions],
    ) -> Result<Vec<Vec<PeerFrame>>, MujocoError> {
        self.write(dir, runs)?;
        run(Command::new(env.python())
            .arg(dir.join("peer_mujoco.py"))
            .arg(dir))?;
        let frames = self.hand.len();
        let mut out = Vec::with_capacity(runs.len());
        for k in 0..runs.len() {
            let path = dir.join(format!("out_{k}.bin"));
            let bytes = std::fs::read(&path).map_err(|e| io_err(&path, e))?;
            let values: Vec<f64> = bytes
                .chunks_exact(8)
                .map(|b| f64::from_le_bytes(b.try_into().unwrap_or([0; 8])))
                .collect();
            if values.len() != frames * OUT_STRIDE {
                return Err(MujocoError::BadOutput {
                    path,
                    got: values.len(),
                    expected: frames * OUT_STRIDE,
                });
            }
            out.push(values.chunks_exact(OUT_STRIDE).map(frame_of).collect());
        }
        Ok(out)
    }
}

/// One output row as a frame in haptic6d's units (a pose of NaN after a blow-up).
fn frame_of(row: &[f64]) -> PeerFrame {
    let q_tool = if row[..7].iter().all(|x| x.is_finite()) {
        let q = nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
            row[3], row[4], row[5], row[6],
        ));
        let t = nalgebra::Translation3::new(row[0], row[1], row[2]);
        let mut pose = Pose::from_isometry(&nalgebra::Isometry3::from_parts(t, q)).to_array();
        for x in &mut pose[..3] {
            *x /= M_PER_MM;
        }
        pose
    } else {
        [f64::NAN; 6]
    };
    PeerFrame {
        q_tool,
        wrench: [
            row[7],
            row[8],
            row[9],
            row[10] / M_PER_MM,
            row[11] / M_PER_MM,
            row[12] / M_PER_MM,
        ],
        contacts: row[14].max(0.0) as u32,
        step_us: row[13],
    }
}
