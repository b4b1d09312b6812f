"""The MuJoCo peer of haptic6d's bench: 6-DoF virtual coupling on MuJoCo.

A free body (the tool, its convex pieces as mesh geoms) is pulled by a 6-DoF spring-damper
toward the recorded hand pose; the objects are fixed mesh geoms (their convex pieces). Every
haptic frame MuJoCo steps `substeps` times with `timestep = 1 / (rate_hz * substeps)`, the
coupling force recomputed before each step from the body's state. Units inside: SI (m, kg, N,
N·m), as MuJoCo's users set it up.

Usage: python peer_mujoco.py CASE_DIR     (runs the case, writes CASE_DIR/out_<k>.bin)
       python peer_mujoco.py --version    (prints the MuJoCo version)

CASE_DIR/case.json (written by `haptic6d bench`):
  rate_hz             haptic rate, Hz
  frames              number of hand poses in hand.bin
  coupling            kt N/m, kr N·m/rad, c N·s/m, cr N·m·s/rad, mass kg, inertia kg·m²
  tool                [OBJ file, ...]: the tool's convex pieces in the tool frame, m
  objects             [{"pieces": [OBJ file, ...], "pos": [x, y, z] m, "quat": [w, x, y, z]}]
  start               [x, y, z, qw, qx, qy, qz]: the tool's first pose, m
  runs                [{options}, ...]: one run per entry, on the same input
    substeps, iterations, solver ("Newton", "CG", "PGS"), cone ("pyramidal", "elliptic"),
    noslip_iterations, condim, friction, solref [timeconst s, dampratio],
    solimp [dmin, dmax, width m, midpoint, power], margin m, integrator, multiccd (bool)
CASE_DIR/hand.bin   frames x 7 float64 (little-endian): x, y, z m, qw, qx, qy, qz
CASE_DIR/out_<k>.bin, one per run: frames x 16 float64:
  x, y, z m, qw, qx, qy, qz (the tool after the frame), wrench on the hand (F N, T N·m, world
  axes, the coupling force of the frame's last step), step µs (wall time of the frame's
  mj_step calls, measured with time.perf_counter_ns around them only: the coupling force's
  Python arithmetic is not counted), contacts (MuJoCo's ncon after the frame), 0, 0.
"""

import json
import math
import os
import sys
import time

import numpy as np


def fail(msg):
    print(f"peer_mujoco: {msg}", file=sys.stderr)
    sys.exit(2)


def rotation_log(q):
    """The rotation vector (axis x angle, rad) of the unit quaternion q = (w, x, y, z)."""
    w, x, y, z = q
    if w < 0.0:
        w, x, y, z = -w, -x, -y, -z
    s = math.sqrt(x * x + y * y + z * z)
    if s < 1e-12:
        return np.array([2.0 * x, 2.0 * y, 2.0 * z])
    angle = 2.0 * math.atan2(s, w)
    return np.array([x, y, z]) * (angle / s)


def qmul(a, b):
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    )


def qconj(a):
    return (a[0], -a[1], -a[2], -a[3])


def quat_rotate(q, v):
    w, x, y, z = q
    r = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )
    return r @ v


def fmt(v):
    return " ".join(repr(float(x)) for x in v)


def model_xml(case, run):
    c = case["coupling"]
    substeps = int(run.get("substeps", 1))
    timestep = 1.0 / (case["rate_hz"] * substeps)
    friction = float(run.get("friction", 0.0))
    assets = []
    tool_geoms = []
    object_bodies = []
    for k, f in enumerate(case["tool"]):
        assets.append(f'<mesh name="tool{k}" file="{f}" inertia="shell"/>')
        tool_geoms.append(f'<geom type="mesh" mesh="tool{k}" mass="0"/>')
    for i, obj in enumerate(case["objects"]):
        geoms = []
        for k, f in enumerate(obj["pieces"]):
            assets.append(f'<mesh name="obj{i}_{k}" file="{f}" inertia="shell"/>')
            geoms.append(f'<geom type="mesh" mesh="obj{i}_{k}"/>')
        object_bodies.append(
            f'<body pos="{fmt(obj["pos"])}" quat="{fmt(obj["quat"])}">{"".join(geoms)}</body>'
        )
    start = case["start"]
    return f"""
<mujoco model="haptic6d peer">
  <compiler inertiafromgeom="false" meshdir="{case["dir"]}"/>
  <option timestep="{timestep!r}" gravity="0 0 0" iterations="{int(run.get("iterations", 100))}"
          solver="{run.get("solver", "Newton")}" cone="{run.get("cone", "pyramidal")}"
          noslip_iterations="{int(run.get("noslip_iterations", 0))}"
          integrator="{run.get("integrator", "Euler")}">
    <flag multiccd="{"enable" if run.get("multiccd", False) else "disable"}"/>
  </option>
  <default>
    <geom condim="{int(run.get("condim", 1))}" friction="{friction!r} 0.005 0.0001"
          solref="{fmt(run.get("solref", [0.02, 1.0]))}"
          solimp="{fmt(run.get("solimp", [0.9, 0.95, 0.001, 0.5, 2]))}"
          margin="{float(run.get("margin", 0.0))!r}"/>
  </default>
  <asset>{"".join(assets)}</asset>
  <worldbody>
    {"".join(object_bodies)}
    <body name="tool" pos="{fmt(start[:3])}" quat="{fmt(start[3:])}">
      <freejoint/>
      <inertial pos="0 0 0" mass="{c["mass"]!r}" diaginertia="{fmt([c["inertia"]] * 3)}"/>
      {"".join(tool_geoms)}
    </body>
  </worldbody>
</mujoco>
"""


def run_case(case, hand, run):
    import mujoco

    try:
        model = mujoco.MjModel.from_xml_string(model_xml(case, run))
    except Exception as e:  # MuJoCo's compiler errors name the mesh or the attribute.
        fail(f"{case['dir']}: the model does not compile: {e}")
    data = mujoco.MjData(model)
    body = model.body("tool").id
    c = case["coupling"]
    kt, kr, cd, crd = c["kt"], c["kr"], c["c"], c["cr"]
    substeps = int(run.get("substeps", 1))
    dt = 1.0 / case["rate_hz"]
    frames = hand.shape[0]
    out = np.zeros((frames, 16))
    prev = None
    step = mujoco.mj_step
    clock = time.perf_counter_ns
    for f in range(frames):
        hp = hand[f, :3]
        hq = tuple(hand[f, 3:])
        if prev is None:
            hv = np.zeros(3)
            hw = np.zeros(3)
        else:
            hv = (hp - prev[:3]) / dt
            hw = rotation_log(qmul(hq, qconj(tuple(prev[3:])))) / dt
        prev = hand[f]
        ns = 0
        for _ in range(substeps):
            p = data.qpos[:3]
            q = tuple(data.qpos[3:7])
            v = data.qvel[:3]
            w = quat_rotate(q, data.qvel[3:6])  # the free joint's angular velocity is local
            force = kt * (hp - p) + cd * (hv - v)
            torque = kr * rotation_log(qmul(hq, qconj(q))) + crd * (hw - w)
            data.xfrc_applied[body, :3] = force
            data.xfrc_applied[body, 3:] = torque
            t0 = clock()
            step(model, data)
            ns += clock() - t0
        if not np.all(np.isfinite(data.qpos)):
            out[f:, :] = np.nan
            break
        out[f, :7] = data.qpos[:7]
        out[f, 7:10] = -force
        out[f, 10:13] = -torque
        out[f, 13] = ns * 1e-3
        out[f, 14] = data.ncon
    return out


def main():
    if len(sys.argv) != 2:
        fail("usage: peer_mujoco.py CASE_DIR | --version")
    if sys.argv[1] == "--version":
        import mujoco

        print(mujoco.__version__)
        return
    case_dir = sys.argv[1]
    path = os.path.join(case_dir, "case.json")
    try:
        with open(path) as f:
            case = json.load(f)
    except (OSError, ValueError) as e:
        fail(f"{path}: {e}")
    case["dir"] = case_dir
    hand_path = os.path.join(case_dir, "hand.bin")
    hand = np.fromfile(hand_path, dtype="<f8")
    if hand.size != 7 * int(case["frames"]):
        fail(f"{hand_path}: {hand.size} numbers, expected 7 x {case['frames']}")
    hand = hand.reshape(-1, 7)
    for k, run in enumerate(case["runs"]):
        out = run_case(case, hand, run)
        out.astype("<f8").tofile(os.path.join(case_dir, f"out_{k}.bin"))


if __name__ == "__main__":
    main()
