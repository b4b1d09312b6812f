#!/usr/bin/env bash
# Regenerates every figure of docs/BENCHMARKS.md (and README.md's outputs) from an EMPTY tree
# cache, in the page's order, and keeps the raw outputs with the commit they were measured at.
# The plots the page shows are copied into docs/benchmarks/.
#
#   scripts/figures.sh                      # everything (about 1 to 2 hours on 2 cores)
#   scripts/figures.sh --only trees,run     # some sections
#   scripts/figures.sh --list               # the sections and the figures each one feeds
#
# Options: --only S1,S2  --skip S1,S2  --out DIR (default target/figures/<commit>)
#          --reps N (repeated runs for medians: tree builds, bunny runs; default 5)
# Environment: CARGO_TARGET_DIR (as for cargo), BRADSHAW_DIR (the Sphere-Tree Construction
# Toolkit's bunny .sph files; default: assets/peers/bradshaw, in the repository).
#
# Every command runs with HAPTIC6D_CACHE set to a fresh temporary directory, so no tree from an
# earlier builder or an edited cache can feed a figure. Each command's stdout and stderr go to
# OUT/<section>/<name>.out and .err; OUT/commands.tsv lists every command with its exit code and
# wall time; OUT/meta.txt records the commit (git rev-parse --short HEAD), whether the work tree
# was clean, the toolchain and the machine (CPU, cores, load average before and after).
# Measure on a quiet machine: the timings are wall clock.
set -uo pipefail

SECTIONS="meta build run frame bench studies peer_tune qp collide trees scaling spheretree doors stability viewer"

describe() {
  cat <<'EOF'
section     command(s)                                          figures it regenerates
meta        git, rustc, /proc                                   the commit and machine every figure is stated at
build       cargo build --release (haptic6d, udp_client)         -
trees       haptic6d tree build / tree eval (tight d4, d3,       README "Build and measure a sphere-tree" block;
            octree d4; toolkit files with --centre);             docs/benchmarks/trees.md leaf and all-levels tables,
            cargo test build_bunny build_bradshaw_fit             build times (median of --reps builds); BENCHMARKS.md
                                                                  "Sphere-trees" section
run         haptic6d run bunny (cold, then --reps runs),         README "Run a scene" block; docs/benchmarks/render.md
            --trajectory into active-set and pqp,               bunny, other-solver, --realtime, spline and start-up
            --realtime; run spline (dual, active-set)           tables; BENCHMARKS.md 1 kHz period-error row
frame       haptic6d run bunny|spline, back to back and paced;   BENCHMARKS.md "Current figures", "Frame time on the
            --budget-us 1000000 work counts; per_frame_min.py;   built-in scenes" and "Tight built-ins on the mesh";
            run spline-tight|probe (4 runs, no deadline)          docs/benchmarks/timing_*.png
bench       haptic6d bench --quick --scenes bunny;               README "Reproduce the paper" rows; BENCHMARKS.md
            haptic6d bench (full)                                replay, pairs and depth tables, the peer table and
                                                                  its plots (docs/benchmarks/peer/), friction's cost
studies     haptic6d bench --studies contact|speed|friction|zoo, BENCHMARKS.md contact, hand-speed, friction and
            back to back, --realtime, --helper-thread,          scene zoo sections;
            --face-caps off                                      docs/benchmarks/friction_curve.png
peer_tune   haptic6d bench --peer-tune (minutes)                 docs/benchmarks/peer/peer_tune.md
scaling     build_scaling sphere|torus; cargo test build_open    BENCHMARKS.md and trees.md large and open meshes
doors       cargo bench -p haptic6d-capi --bench door;           BENCHMARKS.md "Devices and the doors"
            crates/python/bench/overhead.py (if the module is
            importable)
stability   haptic6d stability                                   BENCHMARKS.md closed-loop stability table
qp          cargo run -p qp --example qp_table -- --reps 9;      docs/benchmarks/qp.md tables; BENCHMARKS.md QP rows,
            reduce_table; cargo bench -p qp --bench solvers      the reduction table and the paper-claims paragraph
collide     cargo bench -p collide --bench traversal             docs/benchmarks/collide.md; BENCHMARKS.md traversal row
            (+ COLLIDE_BENCH_TREE=hubbard --quick)
spheretree  cargo bench -p spheretree --bench build              docs/benchmarks/trees.md criterion times
viewer      haptic6d serve + udp_client (--ping 5000; 1 kHz     docs/benchmarks/viewer.md round trip, loop, priority
            push with --record; priority runs); run --trajectory and recording-replay figures
            on the recording
EOF
}

only=""
skip=""
out=""
reps=5
while [ $# -gt 0 ]; do
  case "$1" in
    --only) only="${2:?--only needs a list}"; shift 2 ;;
    --skip) skip="${2:?--skip needs a list}"; shift 2 ;;
    --out) out="${2:?--out needs a directory}"; shift 2 ;;
    --reps) reps="${2:?--reps needs a number}"; shift 2 ;;
    --list) describe; exit 0 ;;
    -h|--help) sed -n '2,20p' "$0"; exit 0 ;;
    *) echo "figures.sh: unknown option $1 (see --help)" >&2; exit 2 ;;
  esac
done
case "$reps" in ''|*[!0-9]*|0) echo "figures.sh: --reps $reps: give a positive integer" >&2; exit 2 ;; esac
for s in ${only//,/ } ${skip//,/ }; do
  case " $SECTIONS " in *" $s "*) ;; *) echo "figures.sh: unknown section $s (sections: $SECTIONS)" >&2; exit 2 ;; esac
done

root="$(cd "$(dirname "$0")/.." && pwd)"
cd "$root" || exit 1
commit="$(git rev-parse --short HEAD)"
dirty=""
git diff --quiet HEAD -- || dirty="-dirty"
out="${out:-$root/target/figures/$commit$dirty}"
mkdir -p "$out"
out="$(cd "$out" && pwd)"
target="${CARGO_TARGET_DIR:-$root/target}"
bin="$target/release/haptic6d"
udp_client="$target/release/examples/udp_client"

cache="$(mktemp -d "${TMPDIR:-/tmp}/haptic6d-figures-cache.XXXXXX")"
export HAPTIC6D_CACHE="$cache"
trap 'rm -rf "$cache"' EXIT

bradshaw="${BRADSHAW_DIR:-}"
if [ -z "$bradshaw" ]; then
  for d in assets/peers/bradshaw; do
    if [ -d "$d" ]; then bradshaw="$(cd "$d" && pwd)"; break; fi
  done
fi

wanted() {
  if [ -n "$only" ]; then case ",$only," in *",$1,"*) ;; *) return 1 ;; esac; fi
  case ",$skip," in *",$1,"*) return 1 ;; esac
  return 0
}

failures=0
printf 'section\tname\texit\twall_s\tcommand\n' > "$out/commands.tsv"
# fig SECTION NAME CMD...: runs CMD, stdout/stderr to OUT/SECTION/NAME.{out,err}.
fig() {
  local section="$1" name="$2"; shift 2
  mkdir -p "$out/$section"
  echo "figures: [$section] $name: $*" >&2
  local t0 t1 rc
  t0="$EPOCHREALTIME"
  "$@" > "$out/$section/$name.out" 2> "$out/$section/$name.err"
  rc=$?
  t1="$EPOCHREALTIME"
  printf '%s\t%s\t%s\t%s\t%s\n' "$section" "$name" "$rc" "$(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.2f", b - a }')" "$*" >> "$out/commands.tsv"
  if [ "$rc" -ne 0 ]; then
    failures=$((failures + 1))
    echo "figures: [$section] $name FAILED (exit $rc): see $out/$section/$name.err" >&2
  fi
  return "$rc"
}

machine() {
  echo "cpu: $(grep -m1 'model name' /proc/cpuinfo 2>/dev/null | cut -d: -f2- | sed 's/^ //')"
  echo "cores: $(nproc 2>/dev/null)"
  echo "load average: $(cut -d' ' -f1-3 /proc/loadavg 2>/dev/null)"
}

{
  echo "commit: $commit$dirty ($(git log -1 --format='%H %cd' --date=iso))"
  echo "date: $(date -u +%Y-%m-%dT%H:%M:%SZ)"
  echo "rustc: $(rustc --version 2>/dev/null)"
  echo "tree cache: fresh, empty ($cache)"
  echo "bradshaw files: ${bradshaw:-not found (toolkit rows of trees.md not regenerated)}"
  echo "sections: ${only:-all}${skip:+ minus $skip}"
  machine
} > "$out/meta.txt"

if wanted build || wanted trees || wanted run || wanted frame || wanted bench || wanted studies || wanted peer_tune || wanted stability || wanted viewer; then
  fig build haptic6d cargo build --release -p haptic6d || { echo "figures: the build failed" >&2; exit 1; }
fi

docs_bench="$root/docs/benchmarks"
# publish SRC DEST: copies a plot the page shows into docs/benchmarks/ (when the run made it).
publish() {
  if [ -f "$1" ]; then mkdir -p "$(dirname "$2")"; cp "$1" "$2"; else echo "figures: no $1 to publish" >&2; fi
}

if wanted frame; then
  f="$out/frame"
  mkdir -p "$f"
  # BENCHMARKS.md "Frame time on the built-in scenes": 10 runs each back to back, 6 paced.
  for i in $(seq 1 10); do
    fig frame "bunny-$i" "$bin" run bunny --out "$f/bunny-$i"
    fig frame "spline-$i" "$bin" run spline --out "$f/spline-$i"
  done
  for i in $(seq 1 6); do
    fig frame "bunny-rt-$i" "$bin" run bunny --realtime --out "$f/bunny-rt-$i" --no-plots
    fig frame "spline-rt-$i" "$bin" run spline --realtime --out "$f/spline-rt-$i" --no-plots
  done
  fig frame spline-helper "$bin" run spline --helper-thread --out "$f/spline-helper" --no-plots
  # Work counts: no deadline, the same on any machine.
  for s in spline bunny plate; do
    fig frame "counts-$s" "$bin" run "$s" --budget-us 1000000 --out "$f/counts-$s" --no-plots
  done
  # BENCHMARKS.md "Tight built-ins on the mesh": 3 runs each with the shipped budget, one at
  # normal priority (no real-time throttling of the back-to-back thread), then one with no
  # deadline (does the goal need more time than the budget gives?).
  for i in 1 2 3; do
    fig frame "spline-tight-$i" "$bin" run spline-tight --out "$f/spline-tight-$i" --no-plots
    fig frame "probe-$i" "$bin" run probe --out "$f/probe-$i" --no-plots
  done
  for s in spline-tight probe; do
    fig frame "nort-$s" "$bin" run "$s" --no-rt-priority --out "$f/nort-$s" --no-plots
  done
  for s in spline-tight probe; do
    fig frame "nodeadline-$s" "$bin" run "$s" --budget-us 1000000 --out "$f/nodeadline-$s" --no-plots
  done
  # The per-frame minimum over 20 deterministic runs.
  fig frame per-frame-min-spline python3 scripts/per_frame_min.py --runs 20 --bin "$bin" spline
  fig frame per-frame-min-bunny python3 scripts/per_frame_min.py --runs 20 --bin "$bin" bunny
  publish "$f/bunny-1/timing.png" "$docs_bench/timing_bunny.png"
  publish "$f/spline-1/timing.png" "$docs_bench/timing_spline.png"
fi

if wanted trees; then
  mesh=assets/bunny.obj
  t="$out/trees"
  mkdir -p "$t"
  # README block and trees.md "haptic6d tight (default)" row; the build time is the median of
  # --reps builds (each build is deterministic: same seed, same tree).
  fig trees build-tight-d4-1 "$bin" tree build "$mesh" -o "$t/bunny.sph"
  for i in $(seq 2 "$reps"); do
    fig trees "build-tight-d4-$i" "$bin" tree build "$mesh" -o "$t/bunny-build-$i.sph"
  done
  fig trees eval-tight-d4 "$bin" tree eval "$t/bunny.sph" --mesh "$mesh"
  fig trees eval-tight-d4-json "$bin" tree eval "$t/bunny.sph" --mesh "$mesh" --json
  fig trees build-tight-d3 "$bin" tree build "$mesh" --depth 3 -o "$t/bunny-d3.sph"
  fig trees eval-tight-d3 "$bin" tree eval "$t/bunny-d3.sph" --mesh "$mesh"
  fig trees build-octree-d4 "$bin" tree build "$mesh" --method octree -o "$t/bunny-octree.sph"
  fig trees eval-octree-d4 "$bin" tree eval "$t/bunny-octree.sph" --mesh "$mesh"
  if [ -n "$bradshaw" ]; then
    for f in "$bradshaw"/bunny-*.sph; do
      fig trees "eval-toolkit-$(basename "$f" .sph)" "$bin" tree eval "$f" --mesh "$mesh" --centre
    done
  fi
  fig trees cargo-test-build-figures cargo test -p spheretree --release --test build_bunny \
    --test build_bradshaw_fit -- --nocapture --test-threads=1
fi

if wanted run; then
  r="$out/run"
  mkdir -p "$r"
  # The first run builds the bunny tree into the empty cache (start-up figure, cold).
  fig run bunny-cold "$bin" run bunny --out "$r/bunny-cold" --no-plots
  # README "Run a scene" (run 1) and render.md's consecutive bunny runs.
  for i in $(seq 1 "$reps"); do
    fig run "bunny-$i" "$bin" run bunny --out "$r/bunny-$i"
  done
  traj="$r/bunny-1/trajectory.csv"
  fig run bunny-active-set "$bin" run bunny --trajectory "$traj" --solver active-set --out "$r/bunny-active-set" --no-plots
  fig run bunny-pqp "$bin" run bunny --trajectory "$traj" --solver pqp --no-rt-priority --out "$r/bunny-pqp" --no-plots
  fig run bunny-realtime "$bin" run bunny --realtime --out "$r/bunny-rt" --no-plots
  # Spline: the first run builds the depth-5 trees (cold), the others read them.
  fig run spline-dual "$bin" run spline --out "$r/spline-dual"
  fig run spline-active-set "$bin" run spline --solver active-set --out "$r/spline-active-set"
  fig run spline-dual-warm "$bin" run spline --out "$r/spline-dual-warm" --no-plots
fi

if wanted bench; then
  # README's quick rows, then the full bench of BENCHMARKS.md.
  fig bench quick-bunny "$bin" bench --quick --scenes bunny --out "$out/bench/quick-bunny"
  fig bench full "$bin" bench --out "$out/bench/full"
  publish "$out/bench/full/bench.md" "$docs_bench/peer/bench_peer_full.md"
  for png in "$out"/bench/full/bench_peer_*.png; do
    [ -f "$png" ] && publish "$png" "$docs_bench/peer/$(basename "$png")"
  done
fi

if wanted studies; then
  b="$out/studies"
  # BENCHMARKS.md contact, hand-speed and friction sections.
  for i in 1 2 3; do
    fig studies "contact-$i" "$bin" bench --studies contact --out "$b/contact-$i"
  done
  for i in 1 2; do
    fig studies "contact-rt-$i" "$bin" bench --studies contact --realtime --out "$b/contact-rt-$i"
  done
  fig studies contact-helper "$bin" bench --studies contact --helper-thread --out "$b/contact-helper"
  fig studies contact-rt-helper "$bin" bench --studies contact --realtime --helper-thread --out "$b/contact-rt-helper"
  fig studies speed "$bin" bench --studies speed --out "$b/speed"
  fig studies speed-rt "$bin" bench --studies speed --realtime --out "$b/speed-rt"
  fig studies speed-no-caps "$bin" bench --studies speed --face-caps off --out "$b/speed-no-caps"
  fig studies friction "$bin" bench --studies friction --out "$b/friction"
  fig studies zoo "$bin" bench --studies zoo --no-plots --out "$b/zoo"
  publish "$b/friction/bench_friction_curve.png" "$docs_bench/friction_curve.png"
fi

if wanted peer_tune; then
  fig peer_tune peer-tune "$bin" bench --peer-tune --out "$out/peer_tune"
  publish "$out/peer_tune/peer_tune.md" "$docs_bench/peer/peer_tune.md"
fi

if wanted qp; then
  fig qp qp_table cargo run -p qp --release --example qp_table -- --reps 9
  fig qp reduce_table cargo run -p qp --release --example reduce_table
  fig qp criterion-solvers cargo bench -p qp --bench solvers
fi

if wanted collide; then
  fig collide criterion-traversal cargo bench -p collide --bench traversal
  fig collide criterion-traversal-hubbard \
    env COLLIDE_BENCH_TREE=hubbard cargo bench -p collide --bench traversal -- --quick
fi

if wanted scaling; then
  fig scaling build-scaling-sphere cargo run --release -p spheretree --example build_scaling -- sphere 10000 100000 1000000 2000000
  fig scaling build-scaling-torus cargo run --release -p spheretree --example build_scaling -- torus 10000 100000 1000000 2000000
  fig scaling build-open cargo test -p spheretree --release --test build_open -- --nocapture
fi

if wanted doors; then
  fig doors capi-door cargo bench -p haptic6d-capi --bench door
  if python3 -c 'import haptic6d' 2>/dev/null; then
    fig doors python-overhead python3 crates/python/bench/overhead.py --repeats 15
  else
    echo "figures: [doors] the Python module is not importable (README: maturin develop); skipped" >&2
  fi
fi

if wanted stability; then
  fig stability stability "$bin" stability
fi

if wanted spheretree; then
  fig spheretree criterion-build cargo bench -p spheretree --bench build
fi

if wanted viewer; then
  v="$out/viewer"
  mkdir -p "$v"
  fig build udp_client cargo build --release -p viewer --example udp_client
  # Round trip: a server for 20 s, the client pings 5000 times.
  "$bin" serve bunny --port 0 --udp-port 18082 --duration 20 > "$v/serve-ping.out" 2> "$v/serve-ping.err" &
  server=$!
  sleep 3
  fig viewer udp-ping "$udp_client" --server 127.0.0.1:18082 --ping 5000
  wait "$server"
  # The 1 kHz device loop, recorded; then the recording replayed through `run`.
  "$bin" serve bunny --port 0 --udp-port 18084 --duration 14 --record "$v/udp-rec.csv" \
    > "$v/serve-loop.out" 2> "$v/serve-loop.err" &
  server=$!
  sleep 3
  fig viewer udp-loop-1khz "$udp_client" --server 127.0.0.1:18084 --axis y --seconds 6
  wait "$server"
  fig viewer replay-recording "$bin" run bunny --trajectory "$v/udp-rec.csv" --out "$v/replay" --no-plots
  # Normal priority against SCHED_FIFO, two 5 s runs each.
  for i in 1 2; do
    fig viewer "serve-normal-$i" "$bin" serve bunny --port 0 --udp-port 0 --duration 5 --json
    fig viewer "serve-fifo-$i" "$bin" serve bunny --port 0 --udp-port 0 --duration 5 --json --rt-priority 10
  done
fi

machine | sed 's/^/after: /' >> "$out/meta.txt"
echo "figures: wrote $out (commit $commit$dirty, $failures failed command(s); see commands.tsv)" >&2
[ "$failures" -eq 0 ]
