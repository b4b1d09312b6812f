"""haptic6d: 6-DoF haptic rendering with sphere-trees and small QPs.

Units everywhere: lengths mm, angles rad, forces N, torques N·mm, times s (timings µs).
A pose is 6 numbers (x, y, z mm; gamma, beta, alpha rad). Every refusal raises an
``InputError`` (a ``ValueError``) or a ``FileError`` (an ``OSError``), both ``Haptic6dError``,
with the command line's one-line message.
"""

import os
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

#: The column names of ``Engine.run``'s result, as in frames.csv.
COLUMNS: Tuple[str, ...]

Path = Union[str, "os.PathLike[str]"]
Pose = Sequence[float]
Wrench = Tuple[float, float, float, float, float, float]
PoseTuple = Tuple[float, float, float, float, float, float]

class Haptic6dError(Exception):
    """Every error raised by haptic6d."""

class InputError(Haptic6dError, ValueError):
    """Bad input: a malformed scene or tree file, a setting out of range, an unknown name,
    an array of the wrong shape, a non-finite pose."""

class FileError(Haptic6dError, OSError):
    """A file that cannot be found, read or written."""

class FrameInfo:
    """What one frame did."""

    t: float
    """Safety-layer time of the frame, s."""
    status: str
    """How the step ended: ok, inexact, pair-overflow, lagging, kept-last-safe."""
    pairs: int
    """Leaf pairs in the first pass's QP."""
    contacts: int
    """Leaf pairs touching at the graphic pose (the contact's size)."""
    passes: int
    """Passes made (detect + solve)."""
    iterations: int
    """Solver iterations, summed over passes."""
    penetration_mm: float
    """Deepest leaf-leaf overlap at the graphic pose, mm (0 when free)."""
    cd_us: float
    """Time in collision detection, µs."""
    opt_us: float
    """Time building constraints and solving, µs."""
    total_us: float
    """Time of the whole step (without the safety layer), µs."""
    rows: int
    """Constraint rows in the frame's largest solve, after reduction (trust-region rows
    included)."""
    splits: int
    """Detection work: node pairs split by the frame's traversals, probe slices and
    neighbour-list build slices; machine-independent (one thread, no deadline reached)."""
    scanned: int
    """Neighbour-list entries the frame tested (each ~10x cheaper than a split)."""
    margin_mm: float
    """Detection margin of the frame's first pass, mm."""
    safety: int
    """What the safety layer did (bit set; 0 = nothing)."""
    friction: str
    """What friction did: none, stick or slip."""

class Tree:
    """A sphere-tree (mm for the engine): from ``build_tree`` or ``Tree.load``; saved as .sph;
    passed to ``Engine.from_trees``."""

    @staticmethod
    def load(path: Path) -> "Tree":
        """Reads a .sph file (Bradshaw format)."""
    def save(self, path: Path) -> None:
        """Writes the tree as a .sph file (atomically)."""
    @property
    def levels(self) -> int:
        """Levels (depth + 1)."""
    @property
    def depth(self) -> int:
        """Depth (levels - 1)."""
    @property
    def branching(self) -> int:
        """Branching factor."""
    @property
    def leaves(self) -> int:
        """Used leaf spheres."""
    @property
    def spheres_per_level(self) -> List[int]:
        """Used spheres per level, root first."""
    def spheres(self) -> npt.NDArray[np.float64]:
        """Every slot breadth-first, shape (slots, 4): x, y, z, radius (a negative radius marks
        an unused slot)."""
    @property
    def build_info(self) -> Optional[Dict[str, Any]]:
        """What the build did (mesh, vertices, triangles, method, inside_test, holes_closed,
        bbox_centre, seconds), or None for a tree read from a file."""

TreeLike = Union[Tree, Path]

class Engine:
    """The haptic engine: device pose in, constrained (god-object) pose and safe wrench out.

    Keyword settings (all optional, checked against the scene file's ranges): kt (N/mm),
    kr (N·mm/rad), solver ('dual' | 'pqp' | 'active-set' | 'pqp-parallel'), form ('distance' | 'squared'),
    rotation ('rotation-vector' | 'euler'), relinearize (passes), penetration_tol_mm,
    skin_mm, max_margin_mm, budget_us (µs), max_pairs, max_force_n (N), max_torque_nmm (N·mm),
    max_force_step_n (N), max_torque_step_nmm (N·mm), soft_start_s (s), rate_hz (Hz).
    """

    @staticmethod
    def from_scene(
        scene: Path,
        *,
        kt: Optional[float] = ...,
        kr: Optional[float] = ...,
        solver: Optional[str] = ...,
        form: Optional[str] = ...,
        rotation: Optional[str] = ...,
        geometry: Optional[str] = ...,
        relinearize: Optional[int] = ...,
        penetration_tol_mm: Optional[float] = ...,
        skin_mm: Optional[float] = ...,
        max_margin_mm: Optional[float] = ...,
        budget_us: Optional[float] = ...,
        max_pairs: Optional[int] = ...,
        max_force_n: Optional[float] = ...,
        max_torque_nmm: Optional[float] = ...,
        max_force_step_n: Optional[float] = ...,
        max_torque_step_nmm: Optional[float] = ...,
        soft_start_s: Optional[float] = ...,
        rate_hz: Optional[float] = ...,
    ) -> "Engine":
        """The engine of a built-in scene ('bunny', 'spline', 'plate', 'spline-tight',
        'probe') or a scene file (.toml), as ``haptic6d run`` loads it; settings override the
        scene's."""
    @staticmethod
    def from_trees(
        tool: TreeLike,
        objects: Sequence[Union[TreeLike, Tuple[TreeLike, Pose]]],
        *,
        start: Optional[Pose] = ...,
        kt: Optional[float] = ...,
        kr: Optional[float] = ...,
        solver: Optional[str] = ...,
        form: Optional[str] = ...,
        rotation: Optional[str] = ...,
        geometry: Optional[str] = ...,
        relinearize: Optional[int] = ...,
        penetration_tol_mm: Optional[float] = ...,
        skin_mm: Optional[float] = ...,
        max_margin_mm: Optional[float] = ...,
        budget_us: Optional[float] = ...,
        max_pairs: Optional[int] = ...,
        max_force_n: Optional[float] = ...,
        max_torque_nmm: Optional[float] = ...,
        max_force_step_n: Optional[float] = ...,
        max_torque_step_nmm: Optional[float] = ...,
        soft_start_s: Optional[float] = ...,
        rate_hz: Optional[float] = ...,
    ) -> "Engine":
        """The engine of a tool against objects: each a Tree, a .sph file or a mesh file
        (mm; its tree built at depth 4, branching 8, tight, or read from the tree cache); an
        object may be ``(tree, pose)``. Reset at ``start`` (default the origin)."""
    def reset(self, q: Pose) -> PoseTuple:
        """Starts a new run with the device at ``q``; returns where the tool was placed (``q``,
        or when ``q`` is in collision a free pose near it, within ``max_force_n / kt``; else an
        error)."""
    def set_friction(
        self, object: int, static_mu: float, kinetic_mu: Optional[float] = None
    ) -> None:
        """Sets the Coulomb friction of object ``object`` (0-based): static and kinetic
        coefficients (0..=5, kinetic at most static; default the static one)."""
    def set_friction_enabled(self, on: bool) -> None:
        """Turns friction on or off, keeping the coefficients."""
    def step(
        self, q_h: Pose, t: Optional[float] = None
    ) -> Tuple[Wrench, PoseTuple, FrameInfo]:
        """One frame for the device pose ``q_h``: returns (wrench (Fx, Fy, Fz N; Tx, Ty, Tz
        N·mm), q_g (mm, rad), info). ``t`` is the safety layer's clock in s (default: frames
        since reset / rate_hz)."""
    def run(
        self, trajectory: Optional[npt.ArrayLike] = None
    ) -> Dict[str, npt.NDArray[Any]]:
        """Replays a trajectory of shape (N, 7) (t s, x y z mm, gamma beta alpha rad; default
        the scene's) as ``haptic6d run`` does, GIL released. Returns numpy arrays named as
        frames.csv's columns (``COLUMNS``)."""
    def contacts(self) -> List[Dict[str, Any]]:
        """The leaf pairs of the last detected region: object, tool_slot, object_slot,
        p_in_tool (mm), r_tool (mm), o_in_world (mm), r_object (mm), gap (mm), face (None, or
        (nx, ny, nz, offset_mm) for a pair standing for a flat face's half-space)."""
    def counters(self) -> Dict[str, int]:
        """Frames counted by outcome since the last reset, and safety-layer events."""
    def trajectory(self) -> Optional[npt.NDArray[np.float64]]:
        """The scene's device trajectory, shape (N, 7), or None for an engine from trees."""
    def settings(self) -> Dict[str, Union[float, int, str]]:
        """The settings in force, by keyword name."""
    @property
    def q_g(self) -> PoseTuple:
        """The graphic tool's current pose (mm, rad)."""
    @property
    def frames(self) -> int:
        """Frames stepped since the last reset."""
    @property
    def name(self) -> str:
        """The scene name (or 'trees')."""
    @property
    def load_log(self) -> List[str]:
        """How each tree was obtained, one line each."""
    @property
    def geometry(self) -> str:
        """What the tool touches: 'mesh' (the parts' own triangles) or 'spheres' (the leaf spheres)."""

def build_tree(
    mesh: Path,
    *,
    depth: int = 4,
    branching: int = 8,
    method: str = "tight",
    seed: int = 1,
    inside: str = "auto",
    bradshaw_frame: bool = False,
) -> Tree:
    """Builds a sphere-tree of a mesh (OBJ, STL, PLY) as ``haptic6d tree build`` does, in the
    mesh's units and frame (``bradshaw_frame``: centred on its bounding box)."""

def eval_tree(
    tree: TreeLike,
    mesh: Path,
    *,
    samples: int = 100_000,
    seed: int = 2026,
    inside: str = "auto",
    centre: bool = False,
) -> Dict[str, Any]:
    """Measures how tightly a tree fits a mesh, per level (``per_level``: worst, mean,
    worst162, mean162, coverage, uncovered, largest_gap), in toolkit units (mesh longest side
    = 2000), as ``haptic6d tree eval`` does."""
