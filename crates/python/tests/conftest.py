"""Shared fixtures: the repository, the command line built beside the module, and one
`haptic6d run bunny` whose frames.csv the Python replay is compared with."""

import csv
import os
import pathlib
import subprocess

import numpy as np
import pytest

REPO = pathlib.Path(__file__).resolve().parents[3]
BUNNY_OBJ = REPO / "assets" / "bunny.obj"
# The largest frame budget: no pass is cut by the clock, so a frame depends on its input
# alone and two runs agree value for value (crates/scene/tests/engine_replay.rs).
BUDGET_US = 1_000_000.0
# frames.csv's wall-clock columns, left out of comparisons.
TIMING_COLUMNS = ("cd_us", "opt_us", "total_us", "ahead_us")

# frames.csv's columns that `haptic6d run` measures after the run, beyond the engine's frame
# (the replay has none of them): not read.
RUN_ONLY_COLUMNS = ("mesh_penetration_mm",)


def cli_path() -> pathlib.Path:
    """The `haptic6d` binary of this checkout (CARGO_TARGET_DIR or target/, release)."""
    target = pathlib.Path(os.environ.get("CARGO_TARGET_DIR", REPO / "target"))
    exe = target / "release" / "haptic6d"
    if not exe.exists():
        pytest.fail(f"{exe} not found: build it first (cargo build --release -p haptic6d)")
    return exe


def run_cli(*args: str, check: bool = True) -> subprocess.CompletedProcess:
    """Runs the command line; with `check`, fails the test on a non-zero exit."""
    p = subprocess.run(
        [str(cli_path()), *args], capture_output=True, text=True, timeout=600
    )
    if check and p.returncode != 0:
        pytest.fail(f"haptic6d {' '.join(args)} failed: {p.stderr}")
    return p


def read_frames_csv(path: pathlib.Path) -> dict:
    """frames.csv as columns: floats, except `status` (names); the run-only columns left out."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    header, body = rows[0], rows[1:]
    cols = {}
    for k, name in enumerate(header):
        if name in RUN_ONLY_COLUMNS:
            continue
        values = [r[k] for r in body]
        cols[name] = np.array(values) if name == "status" else np.array(values, dtype=float)
    return cols


@pytest.fixture(scope="session")
def cli_bunny(tmp_path_factory) -> dict:
    """`haptic6d run bunny --budget-us 1000000`: its frames.csv columns and trajectory."""
    out = tmp_path_factory.mktemp("cli") / "bunny"
    run_cli(
        "run", "bunny", "--budget-us", str(int(BUDGET_US)), "--out", str(out),
        "--no-plots", "--no-rt-priority",
    )
    frames = read_frames_csv(out / "frames.csv")
    traj = np.loadtxt(out / "trajectory.csv", delimiter=",", skiprows=1, ndmin=2)
    return {"frames": frames, "trajectory": traj, "dir": out}
