"""Bad input raises a haptic6d exception with the command line's one-line message, and never
crashes the interpreter."""

import math
import subprocess
import sys

import numpy as np
import pytest

import haptic6d
from conftest import BUNNY_OBJ, run_cli


@pytest.fixture(scope="module")
def bunny():
    return haptic6d.Engine.from_scene("bunny")


def one_line(e: BaseException) -> str:
    text = str(e)
    assert "\n" not in text and text, repr(text)
    return text


def test_the_exception_classes():
    assert issubclass(haptic6d.InputError, haptic6d.Haptic6dError)
    assert issubclass(haptic6d.InputError, ValueError)
    assert issubclass(haptic6d.FileError, haptic6d.Haptic6dError)
    assert issubclass(haptic6d.FileError, OSError)
    assert not issubclass(haptic6d.InputError, OSError)


def test_a_missing_scene_file(tmp_path):
    missing = tmp_path / "nothere.toml"
    with pytest.raises(haptic6d.FileError) as e:
        haptic6d.Engine.from_scene(missing)
    cli = run_cli("run", str(missing), "--out", str(tmp_path / "o"), check=False)
    assert cli.returncode != 0
    assert "error: " + one_line(e.value) == cli.stderr.strip()


def test_a_malformed_scene_file(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[tool\nmesh = 3\n")
    with pytest.raises(haptic6d.InputError) as e:
        haptic6d.Engine.from_scene(str(bad))
    msg = one_line(e.value)
    assert msg.startswith(str(bad) + ": ")
    cli = run_cli("run", str(bad), "--out", str(tmp_path / "o"), check=False)
    assert "error: " + msg == cli.stderr.strip()


def test_a_scene_whose_mesh_is_missing(tmp_path):
    scene = tmp_path / "s.toml"
    scene.write_text(
        '[tool]\nmesh = "gone.obj"\n\n[[object]]\nmesh = "gone.obj"\n'
    )
    with pytest.raises(haptic6d.Haptic6dError) as e:
        haptic6d.Engine.from_scene(scene)
    msg = one_line(e.value)
    assert str(tmp_path / "gone.obj") in msg and msg.startswith(str(scene))


def test_a_setting_out_of_range_reads_as_on_the_command_line(tmp_path):
    with pytest.raises(haptic6d.InputError) as e:
        haptic6d.Engine.from_scene("bunny", budget_us=0)
    cli = run_cli(
        "run", "bunny", "--budget-us", "0", "--out", str(tmp_path / "o"), check=False
    )
    # The same message, naming the keyword where the command line names its flag.
    assert "error: " + one_line(e.value) == cli.stderr.strip().replace("--budget-us", "budget_us")
    with pytest.raises(haptic6d.InputError, match=r"^kt = NaN: must be"):
        haptic6d.Engine.from_trees(str(BUNNY_OBJ), [str(BUNNY_OBJ)], kt=math.nan)


def test_an_unknown_solver_and_keyword():
    with pytest.raises(haptic6d.InputError) as e:
        haptic6d.Engine.from_scene("bunny", solver="newton")
    assert one_line(e.value) == (
        "solver: unknown solver `newton`; expected one of: dual, pqp, active-set, pqp-parallel"
    )
    with pytest.raises(haptic6d.InputError, match="unknown setting `stiffness`"):
        haptic6d.Engine.from_scene("bunny", stiffness=3)
    with pytest.raises(haptic6d.InputError, match="kt: expected a number, got str"):
        haptic6d.Engine.from_scene("bunny", kt="stiff")


@pytest.mark.parametrize(
    "traj, needle",
    [
        (np.zeros((10, 6)), "got shape (10, 6)"),
        (np.zeros((2, 7, 1)), "got shape (2, 7, 1)"),
        (np.zeros((0, 7)), "got shape (0, 7)"),
        (np.zeros(7), "got shape (7)"),
        ([["a"] * 7], "not an array of numbers"),
    ],
)
def test_a_trajectory_of_the_wrong_shape(bunny, traj, needle):
    with pytest.raises(haptic6d.InputError) as e:
        bunny.run(traj)
    assert needle in one_line(e.value)


def test_non_finite_and_backwards_trajectories(bunny):
    traj = bunny.trajectory()[:100].copy()
    bad = traj.copy()
    bad[42, 5] = math.nan
    with pytest.raises(haptic6d.InputError, match=r"^trajectory row 42: beta = NaN is not finite$"):
        bunny.run(bad)
    bad = traj.copy()
    bad[10, 0] = -1.0
    with pytest.raises(haptic6d.InputError, match="trajectory row 10: time -1 goes backwards"):
        bunny.run(bad)
    # The engine is still usable after a refusal.
    assert len(bunny.run(traj)["t"]) == 100


def test_bad_poses_are_refused_and_the_engine_goes_on(bunny):
    q0 = tuple(bunny.trajectory()[0, 1:])
    bunny.reset(q0)
    for bad in [
        (0, 0, math.nan, 0, 0, 0),
        (0, 0, math.inf, 0, 0, 0),
        [1, 2, 3],
        "abcdef",
        None,
        (0, 0, 0, 0, 0, "x"),
        (0, 0, 1e300, 0, 0, 0),
    ]:
        with pytest.raises(haptic6d.InputError) as e:
            bunny.step(bad)
        assert one_line(e.value).startswith("q_h")
    with pytest.raises(haptic6d.InputError, match="^t = NaN: must be a finite time in s$"):
        bunny.step(q0, t=math.nan)
    with pytest.raises(haptic6d.InputError, match="^q"):
        bunny.reset([0.0] * 5)
    # Nothing was stepped by the refused calls.
    assert bunny.frames == 0
    w, q, info = bunny.step(q0)
    assert all(math.isfinite(v) for v in w + q) and info.status == "ok"


def test_a_missing_or_malformed_tree_file(tmp_path):
    with pytest.raises(haptic6d.FileError) as e:
        haptic6d.Engine.from_trees(tmp_path / "tool.sph", [str(BUNNY_OBJ)])
    msg = one_line(e.value)
    assert msg.startswith("tool: ") and str(tmp_path / "tool.sph") in msg
    bad = tmp_path / "bad.sph"
    bad.write_text("3 8\n1 2 3\n")
    with pytest.raises(haptic6d.InputError) as e:
        haptic6d.Engine.from_trees(str(BUNNY_OBJ), [bad])
    assert one_line(e.value).startswith("object 1: ")
    with pytest.raises(haptic6d.InputError, match="objects: no object"):
        haptic6d.Engine.from_trees(str(BUNNY_OBJ), [])
    with pytest.raises(haptic6d.InputError, match="objects: expected a list"):
        haptic6d.Engine.from_trees(str(BUNNY_OBJ), str(BUNNY_OBJ))
    with pytest.raises(haptic6d.InputError, match="tool: expected a Tree"):
        haptic6d.Engine.from_trees(42, [str(BUNNY_OBJ)])
    with pytest.raises(haptic6d.InputError, match=r"objects\[0\] pose"):
        haptic6d.Engine.from_trees(str(BUNNY_OBJ), [(str(BUNNY_OBJ), (0, 0, math.nan, 0, 0, 0))])


def test_an_engine_from_trees_has_no_scene_trajectory():
    e = haptic6d.Engine.from_trees(str(BUNNY_OBJ), [str(BUNNY_OBJ)], start=(0, 0, 300, 0, 0, 0))
    assert e.trajectory() is None
    with pytest.raises(haptic6d.InputError, match="no scene trajectory"):
        e.run()


BATTERY = r"""
import math, numpy as np, haptic6d as h
e = h.Engine.from_scene("bunny")
calls = [
    lambda: e.step((math.nan,) * 6),
    lambda: e.step(object()),
    lambda: e.run(np.full((5, 7), math.nan)),
    lambda: e.run(np.zeros((3, 3))),
    lambda: e.run("trajectory"),
    lambda: e.reset((0, 0, 0, math.inf, 0, 0)),
    lambda: h.Engine.from_scene("/nonexistent/x.toml"),
    lambda: h.Engine.from_scene("bunny", relinearize=-5),
    lambda: h.Engine.from_scene("bunny", max_pairs=2**62),
    lambda: h.Engine.from_trees(None, None),
    lambda: h.build_tree("/nonexistent.obj"),
    lambda: h.build_tree(h.__file__, depth=2, method="octree"),
    lambda: h.eval_tree("/nonexistent.sph", "/nonexistent.obj"),
    lambda: h.Tree.load(h.__file__),
]
for c in calls:
    try:
        c()
    except h.Haptic6dError:
        pass
    else:
        raise SystemExit(f"no error from call {calls.index(c)}")
w, q, info = e.step(tuple(e.trajectory()[0, 1:]))
print("alive", info.status)
"""


def test_a_battery_of_bad_calls_never_crashes_the_interpreter():
    p = subprocess.run(
        [sys.executable, "-c", BATTERY], capture_output=True, text=True, timeout=300
    )
    assert p.returncode == 0, p.stderr
    assert p.stdout.strip() == "alive ok"
    assert "panic" not in p.stderr.lower()


def test_friction_is_set_per_object_and_bad_values_are_named():
    engine = haptic6d.Engine.from_scene("bunny")
    with pytest.raises(haptic6d.InputError, match="object 2 does not exist"):
        engine.set_friction(1, 0.4)
    with pytest.raises(haptic6d.InputError, match="at most the static coefficient 0.3"):
        engine.set_friction(0, 0.3, 0.4)
    with pytest.raises(haptic6d.InputError, match="static = NaN"):
        engine.set_friction(0, math.nan)
    engine.set_friction(0, 0.4, 0.3)
    traj = engine.trajectory()
    engine.reset(tuple(traj[0, 1:]))
    seen = set()
    for row in traj[:4000]:
        _, _, info = engine.step(tuple(row[1:]))
        seen.add(info.friction)
    assert {"stick", "slip"} <= seen, seen
    # Off: the frictionless frames (no friction reported).
    engine.set_friction_enabled(False)
    engine.reset(tuple(traj[0, 1:]))
    assert {engine.step(tuple(row[1:]))[2].friction for row in traj[:4000]} == {"none"}
