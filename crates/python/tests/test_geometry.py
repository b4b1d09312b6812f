"""What the tool touches, chosen from Python as `[solver] geometry` chooses it in a scene file:
the parts' own triangles where every body came from a mesh, else the leaf spheres (and the
load log says so)."""

import math

import pytest

import haptic6d
from conftest import BUNNY_OBJ

FAR = (0, 0, 300, 0, 0, 0)


def test_engines_from_meshes_touch_the_meshes_when_asked():
    e = haptic6d.Engine.from_trees(str(BUNNY_OBJ), [str(BUNNY_OBJ)], start=FAR, geometry="mesh")
    assert e.geometry == "mesh" and e.settings()["geometry"] == "mesh"
    # Lowered onto the object: every frame finite, the tool held out of it.
    for z in (120, 80, 60):
        w, q, info = e.step((0, 0, z, 0, 0, 0))
        assert all(math.isfinite(v) for v in w + q) and info.penetration_mm == 0.0
    plain = haptic6d.Engine.from_trees(str(BUNNY_OBJ), [str(BUNNY_OBJ)], start=FAR)
    assert plain.geometry == "spheres" and plain.settings()["geometry"] == "spheres"


def test_a_tree_without_its_mesh_keeps_the_spheres_and_says_so():
    tree = haptic6d.build_tree(BUNNY_OBJ, depth=3)
    e = haptic6d.Engine.from_trees(tree, [str(BUNNY_OBJ)], start=FAR, geometry="mesh")
    assert e.geometry == "spheres"
    assert any(line.startswith("geometry: mesh asked") for line in e.load_log)


def test_a_scene_takes_the_geometry_keyword():
    assert haptic6d.Engine.from_scene("zoo/cube-edge").geometry == "spheres"
    assert haptic6d.Engine.from_scene("zoo/cube-edge", geometry="mesh").geometry == "mesh"


def test_an_unknown_geometry_is_refused_by_name():
    with pytest.raises(haptic6d.InputError, match=r"^geometry: "):
        haptic6d.Engine.from_trees(str(BUNNY_OBJ), [str(BUNNY_OBJ)], geometry="voxels")
