"""What the Python door costs, on the bunny scene's trajectory (8601 frames at 1 kHz).

1. `Engine.run()` (the whole replay in Rust, GIL released, columns to numpy) against
   `haptic6d run bunny`'s own loop time (`loop_stats.wall_s` in summary.json): same scene,
   same settings, same frames.
2. `Engine.step()` per call against the Rust step: each call is timed on its own
   (`perf_counter_ns` around it, the timer's own cost measured and taken off) and the Rust
   step's own time (`info.total_us`, measured inside the engine) subtracted; the median over
   every frame of every repeat is what one call from Python adds: argument checks, the
   result tuples and `FrameInfo` (and the safety filter, a few ns, counted as overhead).
   Per-frame medians are robust to the shared machine's hiccups, which whole-run times are
   not; the whole-loop figure is printed too.

Whole runs: medians and minima over --repeats runs. Needs the module installed (`maturin develop --release`) and the
command line built (`cargo build --release -p haptic6d`).

    python crates/python/bench/overhead.py [--repeats 9] [--cli target/release/haptic6d]
"""

import argparse
import json
import os
import pathlib
import statistics
import subprocess
import tempfile
import time

import haptic6d

REPO = pathlib.Path(__file__).resolve().parents[3]


def cli_loop_seconds(cli: pathlib.Path, repeats: int) -> list:
    """`haptic6d run bunny`'s loop wall time, s, per run."""
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(repeats):
            p = subprocess.run(
                [str(cli), "run", "bunny", "--out", os.path.join(tmp, f"r{i}"),
                 "--no-plots", "--json", "--no-rt-priority"],
                capture_output=True, text=True, check=True,
            )
            out.append(json.loads(p.stdout)["loop_stats"]["wall_s"])
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=9)
    target = pathlib.Path(os.environ.get("CARGO_TARGET_DIR", REPO / "target"))
    ap.add_argument("--cli", type=pathlib.Path, default=target / "release" / "haptic6d")
    args = ap.parse_args()

    engine = haptic6d.Engine.from_scene("bunny")
    traj = engine.trajectory()
    n = len(traj)
    poses = [tuple(row[1:]) for row in traj]
    engine.run()  # warm up: caches, page faults

    run_s = []
    for _ in range(args.repeats):
        t0 = time.perf_counter()
        engine.run()
        run_s.append(time.perf_counter() - t0)

    step_s = []
    overhead_ns = []
    timer_ns = []
    clock = time.perf_counter_ns
    for _ in range(args.repeats):
        engine.reset(poses[0])
        step = engine.step
        t0 = time.perf_counter()
        for q in poses:
            step(q)
        step_s.append(time.perf_counter() - t0)
        engine.reset(poses[0])
        for q in poses:
            a = clock()
            _, _, info = step(q)
            b = clock()
            overhead_ns.append((b - a) - info.total_us * 1e3)
            c = clock()
            timer_ns.append(clock() - c)

    cli_s = cli_loop_seconds(args.cli, args.repeats)

    run_med, cli_med = statistics.median(run_s), statistics.median(cli_s)
    step_med = statistics.median(step_s)
    timer = statistics.median(timer_ns)
    per_call = statistics.median(overhead_ns) - timer
    print(f"bunny: {n} frames; {args.repeats} runs each (shared machine: indicative)")
    print(f"  haptic6d run bunny, loop wall_s   median {cli_med * 1e3:7.2f} ms   min {min(cli_s) * 1e3:7.2f} ms")
    print(f"  Engine.run()                      median {run_med * 1e3:7.2f} ms   min {min(run_s) * 1e3:7.2f} ms")
    print(f"  Engine.run() vs the command line  median {100 * (run_med / cli_med - 1):+6.1f} %     min {100 * (min(run_s) / min(cli_s) - 1):+6.1f} %")
    print(f"  Python loop of step(), per call   median {step_med / n * 1e6:7.3f} µs")
    print(f"  step() overhead over the Rust step, per call: median {per_call / 1e3:.3f} µs"
          f" (timer cost {timer:.0f} ns taken off)")

if __name__ == "__main__":
    main()
