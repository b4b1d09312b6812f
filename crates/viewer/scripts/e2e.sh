#!/usr/bin/env bash
# End-to-end test of `haptic6d serve` in headless Chromium: opens the page, drives the tool into
# the object with the keyboard, checks force and non-penetration, contacts and recording, and
# saves a screenshot (crates/viewer/web/e2e-out/viewer.png, or $E2E_OUT).
# Needs Debian's chromium (`apt-get install -y chromium`) and the test's npm package
# (playwright-core: `npm ci` in crates/viewer/web, done here when missing; the page itself needs
# nothing installed, three.js is vendored). Builds the release binary if needed.
set -euo pipefail
root="$(cd "$(dirname "$0")/../../.." && pwd)"
web="$root/crates/viewer/web"
chromium="${CHROMIUM:-/usr/bin/chromium}"
if [ ! -x "$chromium" ]; then
  echo "e2e: $chromium not found; install it with: apt-get install -y chromium" >&2
  exit 1
fi
if [ ! -d "$web/node_modules/playwright-core" ]; then
  (cd "$web" && npm ci --no-audit --no-fund)
fi
bin="${HAPTIC6D_BIN:-${CARGO_TARGET_DIR:-$root/target}/release/haptic6d}"
if [ ! -x "$bin" ]; then
  (cd "$root" && cargo build --release -p haptic6d)
fi
exec node "$web/e2e.mjs" --bin "$bin" --out "${E2E_OUT:-$web/e2e-out}"
