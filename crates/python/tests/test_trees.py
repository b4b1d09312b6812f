"""Sphere-trees from Python: built as `haptic6d tree build` builds them, measured as
`haptic6d tree eval` measures them, saved, read back and given to the engine."""

import json
import math

import numpy as np
import pytest

import haptic6d
from conftest import BUNNY_OBJ, run_cli


@pytest.fixture(scope="module")
def octree():
    return haptic6d.build_tree(BUNNY_OBJ, depth=3, method="octree")


def test_build_equals_the_command_line(octree, tmp_path):
    out = tmp_path / "cli.sph"
    run_cli("tree", "build", str(BUNNY_OBJ), "--depth", "3", "--method", "octree", "-o", str(out))
    cli = haptic6d.Tree.load(out)
    # .sph stores fewer digits than a double: compare at its precision.
    np.testing.assert_allclose(octree.spheres(), cli.spheres(), rtol=1e-6, atol=1e-9)
    assert (octree.levels, octree.branching) == (4, 8)
    assert octree.spheres_per_level == cli.spheres_per_level
    assert octree.leaves == octree.spheres_per_level[-1] > 0
    info = octree.build_info
    assert info["method"] == "octree" and info["triangles"] > 1000
    assert cli.build_info is None


def test_save_and_load_round_trip(octree, tmp_path):
    p = tmp_path / "t.sph"
    octree.save(p)
    back = haptic6d.Tree.load(str(p))
    np.testing.assert_allclose(back.spheres(), octree.spheres(), rtol=1e-6, atol=1e-9)
    assert back.spheres().shape == (len(octree.spheres()), 4)


def test_eval_equals_the_command_line(octree, tmp_path):
    p = tmp_path / "t.sph"
    octree.save(p)
    ours = haptic6d.eval_tree(p, BUNNY_OBJ, samples=3000)
    cli = json.loads(
        run_cli("tree", "eval", str(p), "--mesh", str(BUNNY_OBJ), "--samples", "3000", "--json").stdout
    )
    assert len(ours["per_level"]) == len(cli["per_level"]) == 4
    for a, b in zip(ours["per_level"], cli["per_level"]):
        for key, v in b.items():
            assert a[key] == pytest.approx(v, rel=1e-12, abs=1e-12), key
    assert ours["parents_contain_children"] == cli["parents_contain_children"]
    assert ours["inside_test"] == cli["inside_test"] == "pseudo-normal"
    # A Tree object gives the same figures as its file.
    direct = haptic6d.eval_tree(octree, BUNNY_OBJ, samples=3000)
    for a, b in zip(direct["per_level"], ours["per_level"]):
        assert a["count"] == b["count"]
        assert a["coverage"] == pytest.approx(b["coverage"], abs=1e-3)


def test_bad_build_arguments_read_as_the_command_line_flags(tmp_path):
    with pytest.raises(haptic6d.InputError, match=r"^branching=1 is too small"):
        haptic6d.build_tree(BUNNY_OBJ, branching=1)
    with pytest.raises(haptic6d.InputError, match="needs more than 16777216 slots"):
        haptic6d.build_tree(BUNNY_OBJ, depth=30)
    with pytest.raises(haptic6d.InputError, match="unknown build method `fast`"):
        haptic6d.build_tree(BUNNY_OBJ, method="fast")
    with pytest.raises(haptic6d.InputError, match="unknown inside test `inner`"):
        haptic6d.build_tree(BUNNY_OBJ, inside="inner")
    with pytest.raises(haptic6d.InputError, match=r"^seed=-1: must be 0 or more$"):
        haptic6d.build_tree(BUNNY_OBJ, seed=-1)
    with pytest.raises(haptic6d.FileError, match="nothere.obj"):
        haptic6d.build_tree(tmp_path / "nothere.obj")
    with pytest.raises(haptic6d.InputError, match=r"^samples=0"):
        haptic6d.eval_tree(tmp_path / "x.sph", BUNNY_OBJ, samples=0)


def test_an_engine_from_trees_stops_the_tool_on_the_object(octree, tmp_path):
    p = tmp_path / "tool.sph"
    octree.save(p)
    # The bunny mesh is about 0.15 units across: scale the motion to its size.
    spheres = octree.spheres()
    root = spheres[0]
    r = root[3]
    above = (root[0], root[1], root[2] + 3 * r, 0.0, 0.0, 0.0)
    e = haptic6d.Engine.from_trees(p, [(octree, (0, 0, 0, 0, 0, 0))], start=above, kt=1.0)
    assert e.name == "trees" and len(e.load_log) == 2
    # The hand moves straight down through the object; the tool must stay out.
    n = 2000
    traj = np.zeros((n, 7))
    traj[:, 0] = np.arange(n) / 1000.0
    traj[:, 1:4] = above[:3]
    traj[:, 3] = np.linspace(above[2], root[2], n)
    cols = e.run(traj)
    assert cols["pairs"].max() > 0
    assert cols["penetration_mm"].max() < 0.01
    assert cols["zg"][-1] > cols["zh"][-1] + 1e-3
    # The spring pushes the hand back up.
    assert cols["fz"][-1] > 0
    assert all(math.isfinite(v) for v in cols["fz"])
