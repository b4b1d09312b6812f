"""The Python door gives the command line's frames: `Engine.run` against `haptic6d run`'s
frames.csv, and `Engine.step` against `Engine.run`, frame for frame."""

import numpy as np
import pytest

import haptic6d
from conftest import BUDGET_US, TIMING_COLUMNS


@pytest.fixture(scope="module")
def bunny():
    return haptic6d.Engine.from_scene("bunny", budget_us=BUDGET_US)


def test_columns_are_frames_csv_header(cli_bunny):
    assert haptic6d.COLUMNS == tuple(cli_bunny["frames"].keys())


def test_the_scene_trajectory_is_the_command_line_one(bunny, cli_bunny):
    traj = bunny.trajectory()
    assert traj.shape == cli_bunny["trajectory"].shape
    assert traj.shape[1] == 7 and traj.shape[0] > 1000
    np.testing.assert_array_equal(traj, cli_bunny["trajectory"])


def test_run_equals_the_command_line_frames(bunny, cli_bunny):
    ours = bunny.run()
    theirs = cli_bunny["frames"]
    assert list(ours) == list(theirs)
    for name, col in theirs.items():
        assert len(ours[name]) == len(col), name
        if name in TIMING_COLUMNS:
            assert np.all(np.isfinite(ours[name])) and np.all(ours[name] >= 0), name
        elif name == "status":
            assert list(ours[name]) == list(col)
        else:
            # frames.csv prints each value in its shortest exact form: equal to the bit.
            np.testing.assert_array_equal(ours[name].astype(float), col, err_msg=name)
    # The run touched the object: the comparison is not only of free-space frames.
    force = np.sqrt(ours["fx"] ** 2 + ours["fy"] ** 2 + ours["fz"] ** 2)
    assert ours["pairs"].max() > 0 and force.max() > 1.0


def test_run_of_an_array_equals_run_of_the_scene(bunny, cli_bunny):
    a = bunny.run()
    b = bunny.run(cli_bunny["trajectory"])
    for name in haptic6d.COLUMNS:
        if name not in TIMING_COLUMNS:
            np.testing.assert_array_equal(a[name], b[name], err_msg=name)
    assert bunny.frames == len(a["t"])
    assert bunny.counters()["frames"] == len(a["t"])


def test_step_equals_run_frame_for_frame(bunny):
    traj = bunny.trajectory()
    cols = bunny.run(traj)
    placed = bunny.reset(traj[0, 1:])
    assert placed == tuple(traj[0, 1:])
    assert bunny.frames == 0
    max_contacts = 0
    work = 0
    for i, row in enumerate(traj):
        wrench, q_g, info = bunny.step(tuple(row[1:]))
        expect_w = tuple(cols[n][i] for n in ("fx", "fy", "fz", "tx", "ty", "tz"))
        expect_q = tuple(cols[n][i] for n in ("xg", "yg", "zg", "gg", "bg", "ag"))
        assert wrench == expect_w, f"frame {i}"
        assert q_g == expect_q, f"frame {i}"
        assert info.status == cols["status"][i], f"frame {i}"
        assert (info.pairs, info.iterations, info.passes) == (
            cols["pairs"][i], cols["iters"][i], cols["passes"][i]
        ), f"frame {i}"
        assert (info.splits, info.scanned) == (
            cols["splits"][i], cols["scanned"][i]
        ), f"frame {i}"
        work += info.splits
        assert info.penetration_mm == cols["penetration_mm"][i], f"frame {i}"
        assert info.t == i / 1000.0
        max_contacts = max(max_contacts, info.contacts)
    assert max_contacts > 0 and work > 0
    assert bunny.q_g == expect_q


def test_step_takes_lists_and_arrays_and_reports_contacts(bunny):
    traj = bunny.trajectory()
    cols = bunny.run(traj)
    # The frame with the most pairs: step from a list, then an array, from the same state.
    i = int(np.argmax(cols["pairs"]))
    for make in (list, np.asarray):
        bunny.reset(traj[0, 1:])
        for row in traj[: i + 1]:
            w, q, info = bunny.step(make(row[1:]))
        assert q[2] == cols["zg"][i]
        contacts = bunny.contacts()
        assert len(contacts) > 0
        c = contacts[0]
        assert set(c) == {
            "object", "tool_slot", "object_slot", "p_in_tool", "r_tool",
            "o_in_world", "r_object", "gap", "face",
        }
        assert c["r_tool"] > 0 and len(c["o_in_world"]) == 3


def test_run_twice_gives_the_same_frames(bunny):
    a = bunny.run()
    b = bunny.run()
    for name in haptic6d.COLUMNS:
        if name not in TIMING_COLUMNS:
            np.testing.assert_array_equal(a[name], b[name], err_msg=name)


def test_settings_reach_the_engine():
    e = haptic6d.Engine.from_scene("bunny", solver="active-set", kt=2.0, rate_hz=500)
    s = e.settings()
    assert (s["solver"], s["kt"], s["rate_hz"]) == ("active-set", 2.0, 500.0)
    # The scene's own settings stay where not overridden.
    assert s["kr"] == 1000.0 and s["form"] == "distance"
    # A different solver gives a run of the same length with no penetration beyond the
    # scene's tolerance.
    r = e.run()
    assert len(r["t"]) == len(e.trajectory())
    assert r["penetration_mm"].max() < 0.01
