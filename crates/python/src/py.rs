//! The PyO3 bindings: the `haptic6d` module. Arguments are converted and checked here, the
//! work is done by the Rust core, and every refusal becomes a `haptic6d.InputError` (a
//! `ValueError`) or `haptic6d.FileError` (an `OSError`) with the core's one-line message. No
//! path here unwraps or indexes unchecked, so nothing reaches Python as a panic.

use std::path::PathBuf;

use collide::Pose;
use mesh::TriMesh;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::{PyByteArray, PyBytes, PyDict, PyList, PyString, PyTuple, PyType};
use scene::cache::TreeCache;
use scene::trajectory::Trajectory;
use spheretree::SphereTree;

use crate::engines::{self, Made};
use crate::options::{check_pose, EngineOptions};
use crate::replay::{self, Column};
use crate::trees::{self, BuildInfo, BuildOptions, EvalOptions};
use crate::{Failure, FailureKind};

/// `haptic6d.Haptic6dError`, `InputError`, `FileError`: made once, in the module's set-up.
static BASE_ERROR: PyOnceLock<Py<PyType>> = PyOnceLock::new();
static INPUT_ERROR: PyOnceLock<Py<PyType>> = PyOnceLock::new();
static FILE_ERROR: PyOnceLock<Py<PyType>> = PyOnceLock::new();

/// The Python exception of a refused call.
fn raise(py: Python<'_>, f: Failure) -> PyErr {
    let ty = match f.kind {
        FailureKind::Value => INPUT_ERROR.get(py),
        FailureKind::File => FILE_ERROR.get(py),
    };
    match ty {
        Some(t) => PyErr::from_type(t.bind(py).clone(), f.message),
        // Only before the module is set up, which cannot happen for a call into it.
        None => PyValueError::new_err(f.message),
    }
}

/// An `InputError` with `message`.
fn input_error(py: Python<'_>, message: String) -> PyErr {
    raise(py, Failure::value(message))
}

/// Makes the exception classes: `Haptic6dError(Exception)`, and under it
/// `InputError(Haptic6dError, ValueError)` and `FileError(Haptic6dError, OSError)`, so callers
/// can catch this module's errors alone or by their built-in kind.
fn add_errors(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    let builtins = py.import("builtins")?;
    let make_type = builtins.getattr("type")?;
    let make = |name: &str, bases: Bound<'_, PyTuple>, doc: &str| -> PyResult<Py<PyType>> {
        let ns = PyDict::new(py);
        ns.set_item("__module__", "haptic6d")?;
        ns.set_item("__doc__", doc)?;
        let t = make_type.call1((name, bases, ns))?;
        m.add(name, &t)?;
        Ok(t.cast_into::<PyType>()?.unbind())
    };
    let base = make(
        "Haptic6dError",
        PyTuple::new(py, [builtins.getattr("Exception")?])?,
        "Every error raised by haptic6d: a one-line message naming the file or argument and what is wrong.",
    )?;
    let input = make(
        "InputError",
        PyTuple::new(py, [base.bind(py).as_any().clone(), builtins.getattr("ValueError")?])?,
        "Bad input: a malformed scene or tree file, a setting out of range, an unknown name, an array of the wrong shape, a non-finite pose.",
    )?;
    let file = make(
        "FileError",
        PyTuple::new(
            py,
            [base.bind(py).as_any().clone(), builtins.getattr("OSError")?],
        )?,
        "A file that cannot be found, read or written.",
    )?;
    // A second import of the module in one process keeps the first classes.
    let _ = BASE_ERROR.set(py, base);
    let _ = INPUT_ERROR.set(py, input);
    let _ = FILE_ERROR.set(py, file);
    Ok(())
}

/// A pose argument: a sequence of six numbers (tuple, list, 1-D array), mm and rad, finite and
/// within range; `what` names it in errors.
fn pose_arg(what: &str, obj: &Bound<'_, PyAny>) -> PyResult<[f64; 6]> {
    let py = obj.py();
    let bad = || {
        input_error(
            py,
            format!(
                "{what}: expected 6 numbers (x, y, z mm; gamma, beta, alpha rad), got {}",
                describe(obj)
            ),
        )
    };
    let mut q = [0.0; 6];
    // Tuples first: the per-frame call's common case, read without the generic protocol.
    if let Ok(t) = obj.cast::<PyTuple>() {
        if t.len() != 6 {
            return Err(bad());
        }
        for (k, v) in q.iter_mut().enumerate() {
            *v = t.get_item(k)?.extract::<f64>().map_err(|_| bad())?;
        }
    } else if let Ok(l) = obj.cast::<PyList>() {
        if l.len() != 6 {
            return Err(bad());
        }
        for (k, v) in q.iter_mut().enumerate() {
            *v = l.get_item(k)?.extract::<f64>().map_err(|_| bad())?;
        }
    } else {
        if obj.is_instance_of::<PyString>() || obj.len().ok() != Some(6) {
            return Err(bad());
        }
        for (k, v) in q.iter_mut().enumerate() {
            *v = obj
                .get_item(k)
                .and_then(|x| x.extract::<f64>())
                .map_err(|_| bad())?;
        }
    }
    check_pose(what, &q).map_err(|f| raise(py, f))?;
    Ok(q)
}

/// A short description of a Python value for messages: its type and, for sized values, length.
fn describe(obj: &Bound<'_, PyAny>) -> String {
    let ty = obj
        .get_type()
        .name()
        .map(|n| n.to_string())
        .unwrap_or_else(|_| "?".into());
    match obj.len() {
        Ok(n) if !obj.is_instance_of::<PyString>() => format!("{ty} of length {n}"),
        _ => ty,
    }
}

/// A path argument (`str` or `os.PathLike`).
fn path_arg(what: &str, obj: &Bound<'_, PyAny>) -> PyResult<PathBuf> {
    obj.extract::<PathBuf>().map_err(|_| {
        input_error(
            obj.py(),
            format!(
                "{what}: expected a path (str or os.PathLike), got {}",
                describe(obj)
            ),
        )
    })
}

/// A real keyword value.
fn real(key: &str, v: &Bound<'_, PyAny>) -> PyResult<f64> {
    v.extract::<f64>().map_err(|_| {
        input_error(
            v.py(),
            format!("{key}: expected a number, got {}", describe(v)),
        )
    })
}

/// An integer keyword value.
fn integer(key: &str, v: &Bound<'_, PyAny>) -> PyResult<i64> {
    v.extract::<i64>().map_err(|_| {
        input_error(
            v.py(),
            format!("{key}: expected an integer, got {}", describe(v)),
        )
    })
}

/// A name keyword value.
fn name(key: &str, v: &Bound<'_, PyAny>) -> PyResult<String> {
    v.extract::<String>().map_err(|_| {
        input_error(
            v.py(),
            format!("{key}: expected a name (str), got {}", describe(v)),
        )
    })
}

/// The keyword settings of the engine constructors, in the order of the stubs.
const SETTING_KEYS: [&str; 18] = [
    "kt",
    "kr",
    "solver",
    "form",
    "rotation",
    "geometry",
    "relinearize",
    "penetration_tol_mm",
    "skin_mm",
    "max_margin_mm",
    "budget_us",
    "max_pairs",
    "max_force_n",
    "max_torque_nmm",
    "max_force_step_n",
    "max_torque_step_nmm",
    "soft_start_s",
    "rate_hz",
];

/// The keyword settings as [`EngineOptions`]; an unknown keyword is refused with the list.
fn engine_options(settings: Option<&Bound<'_, PyDict>>) -> PyResult<EngineOptions> {
    let mut o = EngineOptions::default();
    let Some(d) = settings else { return Ok(o) };
    for (k, v) in d.iter() {
        let key: String = k.extract()?;
        if v.is_none() {
            continue;
        }
        match key.as_str() {
            "kt" => o.kt = Some(real(&key, &v)?),
            "kr" => o.kr = Some(real(&key, &v)?),
            "solver" => o.solver = Some(name(&key, &v)?),
            "form" => o.form = Some(name(&key, &v)?),
            "rotation" => o.rotation = Some(name(&key, &v)?),
            "geometry" => o.geometry = Some(name(&key, &v)?),
            "relinearize" => o.relinearize = Some(integer(&key, &v)?),
            "penetration_tol_mm" => o.penetration_tol_mm = Some(real(&key, &v)?),
            "skin_mm" => o.skin_mm = Some(real(&key, &v)?),
            "max_margin_mm" => o.max_margin_mm = Some(real(&key, &v)?),
            "budget_us" => o.budget_us = Some(real(&key, &v)?),
            "max_pairs" => o.max_pairs = Some(integer(&key, &v)?),
            "max_force_n" => o.max_force_n = Some(real(&key, &v)?),
            "max_torque_nmm" => o.max_torque_nmm = Some(real(&key, &v)?),
            "max_force_step_n" => o.max_force_step_n = Some(real(&key, &v)?),
            "max_torque_step_nmm" => o.max_torque_step_nmm = Some(real(&key, &v)?),
            "soft_start_s" => o.soft_start_s = Some(real(&key, &v)?),
            "rate_hz" => o.rate_hz = Some(real(&key, &v)?),
            _ => {
                return Err(input_error(
                    d.py(),
                    format!(
                        "unknown setting `{key}`; expected one of: {}",
                        SETTING_KEYS.join(", ")
                    ),
                ))
            }
        }
    }
    Ok(o)
}

/// What one frame did (besides the wrench and pose that [`PyEngine::step`] returns).
#[pyclass(name = "FrameInfo", module = "haptic6d", frozen, get_all)]
struct FrameInfo {
    /// Safety-layer time of the frame, s.
    t: f64,
    /// How the step ended: `ok`, `inexact`, `pair-overflow`, `lagging`, `kept-last-safe`.
    status: &'static str,
    /// Leaf pairs in the first pass's QP.
    pairs: u32,
    /// Leaf pairs touching at the graphic pose (the contact's size).
    contacts: u32,
    /// Passes made (detect + solve).
    passes: u32,
    /// Solver iterations, summed over passes.
    iterations: u32,
    /// Deepest leaf-leaf overlap at the graphic pose, mm (0 when free).
    penetration_mm: f64,
    /// Time in collision detection, µs.
    cd_us: f64,
    /// Time building constraints and solving, µs.
    opt_us: f64,
    /// Time of the whole step (without the safety layer), µs.
    total_us: f64,
    /// Constraint rows in the frame's largest solve, after reduction (trust-region rows
    /// included), rows.
    rows: u32,
    /// Detection work: node pairs split by the frame's traversals, probe slices and
    /// neighbour-list build slices. Unlike the times it does not depend on the machine (one
    /// thread, no deadline reached): compare frame-step variants by it.
    splits: u32,
    /// Neighbour-list entries the frame tested (each ~10× cheaper than a split), entries.
    scanned: u32,
    /// Detection margin of the frame's first pass, mm.
    margin_mm: f64,
    /// What the safety layer did (bit set; 0 = nothing).
    safety: u8,
    /// What friction did: `none`, `stick` or `slip`.
    friction: &'static str,
}

#[pymethods]
impl FrameInfo {
    fn __repr__(&self) -> String {
        format!(
            "FrameInfo(status='{}', pairs={}, contacts={}, passes={}, iterations={}, splits={}, penetration_mm={}, total_us={:.3})",
            self.status,
            self.pairs,
            self.contacts,
            self.passes,
            self.iterations,
            self.splits,
            self.penetration_mm,
            self.total_us
        )
    }
}

/// A sphere-tree (mm for the engine): built by `build_tree`, read by `Tree.load`, saved as
/// `.sph`, and passed to `Engine.from_trees`.
#[pyclass(name = "Tree", module = "haptic6d", frozen)]
struct PyTree {
    tree: SphereTree,
    info: Option<BuildInfo>,
    source: String,
}

#[pymethods]
impl PyTree {
    /// Reads a `.sph` file (Bradshaw format).
    #[staticmethod]
    fn load(py: Python<'_>, path: &Bound<'_, PyAny>) -> PyResult<Self> {
        let path = path_arg("path", path)?;
        let tree = py
            .detach(|| trees::read_tree(&path))
            .map_err(|f| raise(py, f))?;
        Ok(Self {
            tree,
            info: None,
            source: path.display().to_string(),
        })
    }

    /// Writes the tree as a `.sph` file (atomically: an existing file is replaced only on
    /// success).
    fn save(&self, py: Python<'_>, path: &Bound<'_, PyAny>) -> PyResult<()> {
        let path = path_arg("path", path)?;
        py.detach(|| trees::save_tree(&self.tree, &path))
            .map_err(|f| raise(py, f))
    }

    /// Levels (depth + 1).
    #[getter]
    fn levels(&self) -> u32 {
        self.tree.levels()
    }

    /// Depth (levels - 1).
    #[getter]
    fn depth(&self) -> u32 {
        self.tree.depth()
    }

    /// Branching factor.
    #[getter]
    fn branching(&self) -> u32 {
        self.tree.branching()
    }

    /// Used leaf spheres.
    #[getter]
    fn leaves(&self) -> usize {
        self.tree.leaves().count()
    }

    /// Used spheres per level, root first.
    #[getter]
    fn spheres_per_level(&self) -> Vec<usize> {
        (0..self.tree.levels())
            .map(|l| self.tree.used_on_level(l))
            .collect()
    }

    /// Every slot, breadth-first, as an array of shape (slots, 4): centre x, y, z and radius
    /// (tree units; a negative radius marks an unused slot).
    fn spheres<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let flat: Vec<f64> = self
            .tree
            .spheres()
            .iter()
            .flat_map(|s| [s.center[0], s.center[1], s.center[2], s.radius])
            .collect();
        f64_array(py, &flat)?.call_method1("reshape", ((self.tree.len(), 4),))
    }

    /// What the build did (mesh, vertices, triangles, method, inside_test, holes_closed,
    /// bbox_centre, seconds), or None for a tree read from a file.
    #[getter]
    fn build_info<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        let Some(i) = &self.info else { return Ok(None) };
        let d = PyDict::new(py);
        d.set_item("mesh", &i.mesh)?;
        d.set_item("vertices", i.vertices)?;
        d.set_item("triangles", i.triangles)?;
        d.set_item("method", i.method)?;
        d.set_item("inside_test", i.inside_test)?;
        d.set_item("holes_closed", i.holes_closed)?;
        d.set_item("bbox_centre", i.bbox_centre.to_vec())?;
        d.set_item("seconds", i.seconds)?;
        Ok(Some(d))
    }

    fn __repr__(&self) -> String {
        format!(
            "Tree(levels={}, branching={}, leaves={}, source='{}')",
            self.tree.levels(),
            self.tree.branching(),
            self.tree.leaves().count(),
            self.source
        )
    }
}

/// A tree argument: a `Tree`, a `.sph` file or a mesh file (its tree built with depth 4,
/// branching 8, tight, or fetched from the tree cache). `label` starts the errors.
fn tree_arg(
    obj: &Bound<'_, PyAny>,
    label: &str,
    cache: &TreeCache,
    log: &mut Vec<String>,
) -> PyResult<(SphereTree, Option<TriMesh>)> {
    let py = obj.py();
    if let Ok(t) = obj.cast::<PyTree>() {
        log.push(format!("{label}: tree given ({})", t.get().source));
        return Ok((t.get().tree.clone(), None));
    }
    let path = obj.extract::<PathBuf>().map_err(|_| {
        input_error(
            py,
            format!(
                "{label}: expected a Tree, a .sph file or a mesh file, got {}",
                describe(obj)
            ),
        )
    })?;
    py.detach(|| trees::body_for_path(&path, label, cache, log))
        .map_err(|f| raise(py, f))
}

/// The haptic engine: a device pose in, the constrained (god-object) pose and a safe wrench
/// out, one call per frame. Lengths in mm, angles in rad, forces in N, torques in N·mm.
#[pyclass(name = "Engine", module = "haptic6d")]
struct PyEngine {
    made: Made,
    /// Frames stepped since the last reset (the safety layer's default clock).
    frames: u64,
}

impl PyEngine {
    fn new(made: Made) -> Self {
        Self { made, frames: 0 }
    }
}

/// A float64 numpy array over a copy of `v` (a writable bytearray, so the array is too).
fn f64_array<'py>(py: Python<'py>, v: &[f64]) -> PyResult<Bound<'py, PyAny>> {
    let buf = PyByteArray::new_with(py, std::mem::size_of_val(v), |b| {
        for (dst, x) in b.chunks_exact_mut(8).zip(v) {
            dst.copy_from_slice(&x.to_ne_bytes());
        }
        Ok(())
    })?;
    frombuffer(py, buf, "float64")
}

/// An int64 numpy array over a copy of `v`.
fn i64_array<'py>(py: Python<'py>, v: &[i64]) -> PyResult<Bound<'py, PyAny>> {
    let buf = PyByteArray::new_with(py, std::mem::size_of_val(v), |b| {
        for (dst, x) in b.chunks_exact_mut(8).zip(v) {
            dst.copy_from_slice(&x.to_ne_bytes());
        }
        Ok(())
    })?;
    frombuffer(py, buf, "int64")
}

fn frombuffer<'py>(
    py: Python<'py>,
    buf: Bound<'py, PyByteArray>,
    dtype: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let kw = PyDict::new(py);
    kw.set_item("dtype", dtype)?;
    numpy(py)?.call_method("frombuffer", (buf,), Some(&kw))
}

/// numpy, imported when an array is made or read (the per-frame call never needs it).
fn numpy(py: Python<'_>) -> PyResult<Bound<'_, PyModule>> {
    py.import("numpy")
}

/// The values of a trajectory array of shape (N, 7), row-major, as float64.
fn trajectory_values(obj: &Bound<'_, PyAny>) -> PyResult<Vec<f64>> {
    let py = obj.py();
    let kw = PyDict::new(py);
    kw.set_item("dtype", "float64")?;
    let arr = numpy(py)?
        .call_method("ascontiguousarray", (obj,), Some(&kw))
        .map_err(|e| {
            input_error(
                py,
                format!("trajectory: not an array of numbers of shape (N, 7): {e}"),
            )
        })?;
    let shape: Vec<usize> = arr.getattr("shape")?.extract()?;
    if shape.len() != 2 || shape[1] != 7 || shape[0] == 0 {
        let shown = shape
            .iter()
            .map(|n| n.to_string())
            .collect::<Vec<_>>()
            .join(", ");
        return Err(input_error(
            py,
            format!(
                "trajectory: expected an array of shape (N, 7) with N >= 1 (t,x,y,z,gamma,beta,alpha), got shape ({shown})"
            ),
        ));
    }
    let bytes = arr.call_method0("tobytes")?;
    let bytes = bytes.cast::<PyBytes>()?.as_bytes();
    Ok(bytes
        .chunks_exact(8)
        .map(|c| {
            let mut b = [0u8; 8];
            b.copy_from_slice(c);
            f64::from_ne_bytes(b)
        })
        .collect())
}

/// The status names as a numpy string array, made by indexing the few distinct names with a
/// code per frame (a list of one Python string per frame costs ten times more).
fn status_array<'py>(py: Python<'py>, names: &[&'static str]) -> PyResult<Bound<'py, PyAny>> {
    let mut distinct: Vec<&'static str> = Vec::new();
    let mut codes = Vec::with_capacity(names.len());
    for &n in names {
        let code = match distinct.iter().position(|&d| d == n) {
            Some(i) => i,
            None => {
                distinct.push(n);
                distinct.len() - 1
            }
        };
        codes.push(code as i64);
    }
    let table = numpy(py)?.call_method1("array", (distinct,))?;
    table.call_method1("take", (i64_array(py, &codes)?,))
}

/// A trajectory as an array of shape (N, 7).
fn trajectory_array<'py>(py: Python<'py>, t: &Trajectory) -> PyResult<Bound<'py, PyAny>> {
    let flat: Vec<f64> = t
        .samples
        .iter()
        .flat_map(|s| std::iter::once(s.t).chain(s.q))
        .collect();
    f64_array(py, &flat)?.call_method1("reshape", ((t.len(), 7),))
}

#[pymethods]
impl PyEngine {
    /// The engine of a built-in scene (`bunny`, `spline`, `plate`, `spline-tight`, `probe`) or
    /// a scene file (.toml), as `haptic6d run` loads it; keyword settings override the
    /// scene's.
    #[staticmethod]
    #[pyo3(signature = (scene, **settings))]
    fn from_scene(
        py: Python<'_>,
        scene: &Bound<'_, PyAny>,
        settings: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let name = path_arg("scene", scene)?.display().to_string();
        let options = engine_options(settings)?;
        let cache = TreeCache::from_env();
        let made = py
            .detach(|| {
                engines::load_scene(&name, &cache).and_then(|s| engines::from_scene(s, &options))
            })
            .map_err(|f| raise(py, f))?;
        Ok(Self::new(made))
    }

    /// The engine of a tool against objects, each a `Tree`, a `.sph` file or a mesh file (mm);
    /// an object may be a pair `(tree, pose)` with its fixed pose. Keyword settings over the
    /// defaults (1 kHz).
    #[staticmethod]
    #[pyo3(signature = (tool, objects, *, start=None, **settings))]
    fn from_trees(
        py: Python<'_>,
        tool: &Bound<'_, PyAny>,
        objects: &Bound<'_, PyAny>,
        start: Option<&Bound<'_, PyAny>>,
        settings: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let options = engine_options(settings)?;
        let start = match start {
            Some(s) => pose_arg("start", s)?,
            None => [0.0; 6],
        };
        if objects.is_instance_of::<PyString>() || objects.cast::<PyTree>().is_ok() {
            return Err(input_error(
                py,
                "objects: expected a list of objects (Tree, .sph file, mesh file, or (one of these, pose))".into(),
            ));
        }
        let cache = TreeCache::from_env();
        let mut log = Vec::new();
        let (tool_tree, tool_mesh) = tree_arg(tool, "tool", &cache, &mut log)?;
        let (mut objs, mut meshes) = (Vec::new(), Vec::new());
        let items = objects.try_iter().map_err(|_| {
            input_error(
                py,
                format!("objects: expected a list, got {}", describe(objects)),
            )
        })?;
        for (i, item) in items.enumerate() {
            let item = item?;
            let label = format!("object {}", i + 1);
            let (body, pose) = match item.cast::<PyTuple>() {
                Ok(t) if t.len() == 2 => (
                    t.get_item(0)?,
                    pose_arg(&format!("objects[{i}] pose"), &t.get_item(1)?)?,
                ),
                _ => (item, [0.0; 6]),
            };
            let (tree, mesh) = tree_arg(&body, &label, &cache, &mut log)?;
            objs.push((tree, Pose::from_array(pose)));
            meshes.push(mesh);
        }
        let made = py
            .detach(|| {
                engines::from_trees(
                    (&tool_tree, tool_mesh.as_ref()),
                    &objs,
                    &meshes,
                    start,
                    &options,
                    log,
                )
            })
            .map_err(|f| raise(py, f))?;
        Ok(Self::new(made))
    }

    /// Starts a new run with the device at `q` (x, y, z mm; gamma, beta, alpha rad): the
    /// graphic tool is placed at `q`, or when `q` is in collision at a free pose near it, within
    /// the coupling's stretch at the force limit (`max_force_n / kt`; else an error) (returned); the safety layer's soft start and the counters start again.
    fn reset<'py>(
        &mut self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyTuple>> {
        let q = pose_arg("q", q)?;
        let placed = self
            .made
            .engine
            .reset(&Pose::from_array(q))
            .map_err(|e| raise(py, Failure::chain(FailureKind::Value, &e)))?;
        self.frames = 0;
        PyTuple::new(py, placed.to_array())
    }

    /// Sets the Coulomb friction of object `object` (0-based): static and kinetic coefficients
    /// (dimensionless, 0..=5, kinetic at most static; kinetic defaults to static). Objects
    /// start frictionless (or as their scene file says).
    #[pyo3(signature = (object, static_mu, kinetic_mu=None))]
    fn set_friction(
        &mut self,
        py: Python<'_>,
        object: usize,
        static_mu: f64,
        kinetic_mu: Option<f64>,
    ) -> PyResult<()> {
        let f = engine::Friction {
            static_mu,
            kinetic_mu: kinetic_mu.unwrap_or(static_mu),
        };
        self.made
            .engine
            .set_friction(object, f)
            .map_err(|e| raise(py, Failure::chain(FailureKind::Value, &e)))
    }

    /// Turns friction on or off, keeping the coefficients (off: the frictionless frames).
    fn set_friction_enabled(&mut self, on: bool) {
        self.made.engine.set_friction_enabled(on);
    }

    /// One haptic frame for the device pose `q_h` (6 numbers: mm, rad) at safety-layer time
    /// `t` (s; by default frames since reset / rate_hz, as `run` and `haptic6d run` count).
    /// Returns `(wrench, q_g, info)`: the wrench to send (Fx, Fy, Fz N; Tx, Ty, Tz N·mm),
    /// the graphic tool pose (mm, rad) and a `FrameInfo`.
    #[pyo3(signature = (q_h, t=None))]
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        q_h: &Bound<'py, PyAny>,
        t: Option<f64>,
    ) -> PyResult<Bound<'py, PyTuple>> {
        let q = pose_arg("q_h", q_h)?;
        let t = match t {
            Some(t) if t.is_finite() => t,
            Some(t) => {
                return Err(input_error(
                    py,
                    format!("t = {t}: must be a finite time in s"),
                ))
            }
            None => self.frames as f64 / self.made.settings.rate_hz,
        };
        let f = *self.made.engine.step(t, &Pose::from_array(q));
        self.frames = self.frames.saturating_add(1);
        let info = FrameInfo {
            t: f.t,
            status: f.status.name(),
            pairs: f.pairs,
            contacts: f.contacts,
            passes: f.passes,
            iterations: f.iterations,
            penetration_mm: f.penetration_mm,
            cd_us: f.cd_us,
            opt_us: f.opt_us,
            total_us: f.total_us,
            rows: f.rows,
            splits: f.splits,
            scanned: f.scanned,
            margin_mm: f.margin_mm,
            safety: f.safety,
            friction: f.friction.name(),
        };
        PyTuple::new(
            py,
            [
                PyTuple::new(py, f.wrench)?.into_any(),
                PyTuple::new(py, f.q_g)?.into_any(),
                Bound::new(py, info)?.into_any(),
            ],
        )
    }

    /// Replays a device trajectory (array of shape (N, 7): t s, x y z mm, gamma beta alpha
    /// rad; by default the scene's own) as `haptic6d run` does, in Rust with the GIL
    /// released: reset at the first row, one step per row. Returns a dict of numpy arrays
    /// named as the columns of frames.csv (`t`, `xh`..`ah`, `xg`..`ag`, `fx`..`tz`, `pairs`,
    /// `cd_us`, `opt_us`, `total_us`, `iters`, `penetration_mm`, `passes`, `status`, `splits`,
    /// `scanned`, `ahead_us`).
    #[pyo3(signature = (trajectory=None))]
    fn run<'py>(
        &mut self,
        py: Python<'py>,
        trajectory: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let traj = match trajectory {
            Some(a) => {
                let values = trajectory_values(a)?;
                replay::trajectory_from_rows(&values).map_err(|f| raise(py, f))?
            }
            None => self.made.trajectory.clone().ok_or_else(|| {
                input_error(
                    py,
                    "trajectory: this engine has no scene trajectory; pass an array of shape (N, 7)".into(),
                )
            })?,
        };
        let rate_hz = self.made.settings.rate_hz;
        let made = &mut self.made;
        let records = py
            .detach(|| replay::replay(&mut made.engine, traj, rate_hz, &made.label))
            .map_err(|f| raise(py, f))?;
        self.frames = records.len() as u64;
        let out = PyDict::new(py);
        for (name, col) in replay::columns(&records) {
            let arr = match col {
                Column::Real(v) => f64_array(py, &v)?,
                Column::Count(v) => i64_array(py, &v)?,
                Column::Status(v) => status_array(py, &v)?,
            };
            out.set_item(name, arr)?;
        }
        Ok(out)
    }

    /// The leaf pairs of the last detected region (for display): a list of dicts with
    /// `object`, `tool_slot`, `object_slot`, `p_in_tool` (mm, tool frame), `r_tool` (mm),
    /// `o_in_world` (mm), `r_object` (mm), `gap` (mm; negative = overlap) and `face`: `None`,
    /// or for a pair that stands for a flat face's half-space (docs/DESIGN.md §Face caps) a
    /// tuple `(nx, ny, nz, offset_mm)`, the plane `n . x = offset` in the world. Empty in free
    /// space.
    fn contacts<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        let list = PyList::empty(py);
        for p in self.made.engine.contacts() {
            let d = PyDict::new(py);
            d.set_item("object", p.object)?;
            d.set_item("tool_slot", p.tool_slot)?;
            d.set_item("object_slot", p.object_slot)?;
            d.set_item("p_in_tool", PyTuple::new(py, p.p_in_tool)?)?;
            d.set_item("r_tool", p.r_tool)?;
            d.set_item("o_in_world", PyTuple::new(py, p.o_in_world)?)?;
            d.set_item("r_object", p.r_object)?;
            d.set_item("gap", p.gap)?;
            let face = p
                .face
                .filter(|_| p.on_face)
                .map(|f| (f.normal[0], f.normal[1], f.normal[2], f.offset));
            d.set_item("face", face)?;
            list.append(d)?;
        }
        Ok(list)
    }

    /// Frames counted by outcome since the last reset: `frames`, `kept_last_safe`,
    /// `pair_overflows`, `inexact`, `lagging`, and the safety layer's `force_clamps`,
    /// `torque_clamps`, `rate_limits`, `nan_frames`, `soft_start_frames`.
    fn counters<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let c = self.made.engine.counters();
        let d = PyDict::new(py);
        d.set_item("frames", c.frames)?;
        d.set_item("kept_last_safe", c.kept_last_safe)?;
        d.set_item("pair_overflows", c.pair_overflows)?;
        d.set_item("inexact", c.inexact)?;
        d.set_item("lagging", c.lagging)?;
        d.set_item("force_clamps", c.safety.force_clamps)?;
        d.set_item("torque_clamps", c.safety.torque_clamps)?;
        d.set_item("rate_limits", c.safety.rate_limits)?;
        d.set_item("nan_frames", c.safety.nan_frames)?;
        d.set_item("soft_start_frames", c.safety.soft_start_frames)?;
        Ok(d)
    }

    /// The scene's device trajectory as an array of shape (N, 7) (t s, x y z mm, gamma beta
    /// alpha rad), or None for an engine made from trees.
    fn trajectory<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.made
            .trajectory
            .as_ref()
            .map(|t| trajectory_array(py, t))
            .transpose()
    }

    /// The settings in force, by the keyword names of the constructors.
    fn settings<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        use engine::setting::Setting;
        let c = &self.made.settings.config;
        let d = PyDict::new(py);
        d.set_item("kt", c.kt)?;
        d.set_item("kr", c.kr)?;
        d.set_item("solver", c.solver.setting_name())?;
        d.set_item("form", c.form.setting_name())?;
        d.set_item("rotation", c.rotation.setting_name())?;
        d.set_item("geometry", c.geometry.setting_name())?;
        d.set_item("relinearize", c.relinearize)?;
        d.set_item("penetration_tol_mm", c.penetration_tol_mm)?;
        d.set_item("skin_mm", c.skin_mm)?;
        d.set_item("max_margin_mm", c.max_margin_mm)?;
        d.set_item("budget_us", c.budget_us)?;
        d.set_item("max_pairs", c.max_pairs)?;
        d.set_item("max_force_n", c.safety.max_force_n)?;
        d.set_item("max_torque_nmm", c.safety.max_torque_nmm)?;
        d.set_item("max_force_step_n", c.safety.max_force_step_n)?;
        d.set_item("max_torque_step_nmm", c.safety.max_torque_step_nmm)?;
        d.set_item("soft_start_s", c.safety.soft_start_s)?;
        d.set_item("rate_hz", self.made.settings.rate_hz)?;
        Ok(d)
    }

    /// The graphic tool's current pose (mm, rad).
    #[getter]
    fn q_g<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyTuple>> {
        PyTuple::new(py, self.made.engine.q_g().to_array())
    }

    /// Frames stepped since the last reset.
    #[getter]
    fn frames(&self) -> u64 {
        self.frames
    }

    /// The scene name (or `trees`).
    #[getter]
    fn name(&self) -> &str {
        &self.made.label
    }

    /// What the tool touches: `mesh` (the parts' own triangles) or `spheres` (the leaf
    /// spheres; also when the mesh was asked for and a body has no mesh, which `load_log` says).
    #[getter]
    fn geometry(&self) -> &'static str {
        match self.made.engine.geometry() {
            engine::Geometry::Mesh => "mesh",
            engine::Geometry::Spheres => "spheres",
        }
    }

    /// How each tree was obtained (one line each).
    #[getter]
    fn load_log(&self) -> Vec<String> {
        self.made.load_log.clone()
    }

    fn __repr__(&self) -> String {
        use engine::setting::Setting;
        format!(
            "Engine(name='{}', solver='{}', rate_hz={})",
            self.made.label,
            self.made.settings.config.solver.setting_name(),
            self.made.settings.rate_hz
        )
    }
}

/// A random seed: 0 or more (taken as signed so that a negative one gets this message rather
/// than an overflow).
fn seed_arg(py: Python<'_>, seed: i64) -> PyResult<u64> {
    u64::try_from(seed).map_err(|_| input_error(py, format!("seed={seed}: must be 0 or more")))
}

/// Builds a sphere-tree of a mesh (OBJ, STL, PLY) as `haptic6d tree build` does; the GIL is
/// released during the build.
#[pyfunction]
#[pyo3(signature = (mesh, *, depth=4, branching=8, method="tight", seed=1, inside="auto", bradshaw_frame=false))]
#[allow(clippy::too_many_arguments)]
fn build_tree(
    py: Python<'_>,
    mesh: &Bound<'_, PyAny>,
    depth: i64,
    branching: i64,
    method: &str,
    seed: i64,
    inside: &str,
    bradshaw_frame: bool,
) -> PyResult<PyTree> {
    let path = path_arg("mesh", mesh)?;
    let seed = seed_arg(py, seed)?;
    let o = BuildOptions {
        depth,
        branching,
        method: method.to_string(),
        seed,
        inside: inside.to_string(),
        bradshaw_frame,
    };
    let (tree, info) = py
        .detach(|| trees::build(&path, &o))
        .map_err(|f| raise(py, f))?;
    Ok(PyTree {
        tree,
        source: format!("built from {}", info.mesh),
        info: Some(info),
    })
}

/// Measures how tightly a tree (a `Tree` or a `.sph` file) fits a mesh, per level, as
/// `haptic6d tree eval` does (toolkit units: mesh longest side = 2000).
#[pyfunction]
#[pyo3(signature = (tree, mesh, *, samples=100_000, seed=2026, inside="auto", centre=false))]
fn eval_tree<'py>(
    py: Python<'py>,
    tree: &Bound<'py, PyAny>,
    mesh: &Bound<'py, PyAny>,
    samples: i64,
    seed: i64,
    inside: &str,
    centre: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let mesh_path = path_arg("mesh", mesh)?;
    let seed = seed_arg(py, seed)?;
    let o = EvalOptions {
        samples,
        seed,
        inside: inside.to_string(),
        centre,
    };
    trees::check_eval(&o).map_err(|f| raise(py, f))?;
    let (t, label) = match tree.cast::<PyTree>() {
        Ok(t) => (t.get().tree.clone(), t.get().source.clone()),
        Err(_) => {
            let p = path_arg("tree", tree)?;
            let t = py
                .detach(|| trees::read_tree(&p))
                .map_err(|f| raise(py, f))?;
            (t, p.display().to_string())
        }
    };
    let r = py
        .detach(|| trees::eval(&t, &label, &mesh_path, &o))
        .map_err(|f| raise(py, f))?;
    let d = PyDict::new(py);
    d.set_item("tree", label)?;
    d.set_item("mesh", mesh_path.display().to_string())?;
    d.set_item("vertices", r.vertices)?;
    d.set_item("triangles", r.triangles)?;
    d.set_item("levels", t.levels())?;
    d.set_item("branching", t.branching())?;
    d.set_item("centred", centre)?;
    d.set_item("inside_test", r.inside_test)?;
    d.set_item("units", "toolkit (mesh longest side = 2000)")?;
    d.set_item("parents_contain_children", r.parents_contain_children)?;
    d.set_item("max_child_excess", r.max_child_excess)?;
    d.set_item("coverage_samples", samples)?;
    d.set_item("seed", seed)?;
    d.set_item("eval_seconds", r.seconds)?;
    let levels = PyList::empty(py);
    for f in &r.levels {
        let l = PyDict::new(py);
        l.set_item("level", f.level)?;
        l.set_item("count", f.count)?;
        l.set_item("worst", f.worst)?;
        l.set_item("mean", f.mean)?;
        l.set_item("worst162", f.worst162)?;
        l.set_item("mean162", f.mean162)?;
        l.set_item("coverage", f.coverage)?;
        l.set_item("uncovered", f.uncovered)?;
        l.set_item("largest_gap", f.largest_gap)?;
        levels.append(l)?;
    }
    d.set_item("per_level", levels)?;
    Ok(d)
}

/// haptic6d: 6-DoF haptic rendering with sphere-trees and small QPs. Units: mm, rad, N, N·mm,
/// s, µs.
#[pymodule]
#[pyo3(name = "haptic6d")]
fn haptic6d_module(m: &Bound<'_, PyModule>) -> PyResult<()> {
    add_errors(m)?;
    m.add_class::<PyEngine>()?;
    m.add_class::<FrameInfo>()?;
    m.add_class::<PyTree>()?;
    m.add_function(wrap_pyfunction!(build_tree, m)?)?;
    m.add_function(wrap_pyfunction!(eval_tree, m)?)?;
    m.add(
        "COLUMNS",
        PyTuple::new(m.py(), replay::column_names().collect::<Vec<_>>())?,
    )?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    // maturin's package re-exports `*`: list the dunder name too.
    m.add(
        "__all__",
        [
            "Engine",
            "FrameInfo",
            "Tree",
            "build_tree",
            "eval_tree",
            "COLUMNS",
            "Haptic6dError",
            "InputError",
            "FileError",
            "__version__",
        ],
    )?;
    Ok(())
}
