#!/usr/bin/env python3
"""The per-frame minimum: a frame's cost without the machine's stalls.

Runs `haptic6d run SCENE --budget-us 1000000` several times. Without a deadline the frames are
deterministic (the same passes, node pairs and answers in every run; checked here), so the least
time each frame took over the runs is its cost on this machine when nothing interrupted it. The
p99 of those minima is far steadier than any single run's p99 on a shared or virtual machine,
whose stalls land on different frames in every run.

    scripts/per_frame_min.py spline                          # 10 runs of the release binary
    scripts/per_frame_min.py --runs 20 bunny
    scripts/per_frame_min.py --base /tmp/old/haptic6d spline # two binaries, random order per pair
    scripts/per_frame_min.py --base target/release/haptic6d spline   # the null test

With --base the two binaries run in a random order within each pair of runs, and their frames
must agree on everything but the times (else the comparison is of different work, and the
script says so). Run the null test (the same binary twice) in the same minutes: its two halves
differ by 0.3 % at p99 on the quiet 2-core machine of docs/BENCHMARKS.md and by up to ~12 % on
a busier one, and a smaller difference than the null test's is not shown by this measure.
Needs only Python 3.
"""

import argparse
import csv
import os
import random
import subprocess
import sys
import tempfile

TIME_COLUMNS = {"cd_us", "opt_us", "total_us", "ahead_us"}


def percentile(values, p):
    v = sorted(values)
    if not v:
        return float("nan")
    k = (len(v) - 1) * p
    lo = int(k)
    hi = min(lo + 1, len(v) - 1)
    return v[lo] + (v[hi] - v[lo]) * (k - lo)


def run_once(binary, scene, extra, out):
    cmd = [binary, "run", scene, "--budget-us", "1000000", "--no-plots", "--out", out] + extra
    done = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    if done.returncode != 0:
        sys.exit(f"per_frame_min: {' '.join(cmd)} failed: {done.stderr.strip().splitlines()[-1:]}")
    with open(os.path.join(out, "frames.csv"), newline="") as f:
        return list(csv.DictReader(f))


def work_of(rows):
    """Everything in a run's frames but the times."""
    return [tuple(v for k, v in r.items() if k not in TIME_COLUMNS) for r in rows]


def summary(name, runs):
    n = len(runs[0])
    least = [min(float(r[i]["total_us"]) for r in runs) for i in range(n)]
    median = [sorted(float(r[i]["total_us"]) for r in runs)[len(runs) // 2] for i in range(n)]
    single = sorted(percentile([float(x["total_us"]) for x in r], 0.99) for r in runs)
    print(
        f"{name}: {len(runs)} runs of {n} frames; per-frame minimum p50 {percentile(least, 0.5):.1f} "
        f"p99 {percentile(least, 0.99):.1f} p99.9 {percentile(least, 0.999):.1f} "
        f"max {max(least):.1f} µs, total {sum(least) / 1000:.1f} ms; per-frame median p99 "
        f"{percentile(median, 0.99):.1f} µs; single runs' p99 {single[0]:.1f} / {single[1]:.1f} / "
        f"{single[len(single) // 2]:.1f} µs (least / second / median)"
    )


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene", help="a built-in scene or a scene file, as for `haptic6d run`")
    ap.add_argument("--runs", type=int, default=10, help="runs of each binary (default 10)")
    ap.add_argument(
        "--bin",
        default=os.path.join("target", "release", "haptic6d"),
        help="the haptic6d binary (default target/release/haptic6d)",
    )
    ap.add_argument("--base", help="a second binary to compare with, run alternately")
    ap.add_argument("extra", nargs="*", help="more `haptic6d run` options, after --")
    args = ap.parse_args()
    if args.runs < 2:
        sys.exit("per_frame_min: --runs must be at least 2")
    binaries = {"bin": args.bin}
    if args.base:
        binaries["base"] = args.base
    for label, path in binaries.items():
        if not os.access(path, os.X_OK):
            sys.exit(f"per_frame_min: {path}: not an executable (--{label})")
    runs = {label: [] for label in binaries}
    with tempfile.TemporaryDirectory(prefix="per_frame_min-") as tmp:
        for i in range(args.runs):
            order = list(binaries)
            random.shuffle(order)
            for label in order:
                out = os.path.join(tmp, f"{label}-{i}")
                runs[label].append(run_once(binaries[label], args.scene, args.extra, out))
    for label, rs in runs.items():
        first = work_of(rs[0])
        if any(work_of(r) != first for r in rs[1:]):
            sys.exit(f"per_frame_min: {binaries[label]}: the runs' frames differ (not deterministic)")
    if args.base and work_of(runs["bin"][0]) != work_of(runs["base"][0]):
        print("note: the two binaries do different work (frames differ): compare the totals")
    for label, rs in runs.items():
        summary(f"{label} ({binaries[label]})", rs)


if __name__ == "__main__":
    main()
