#!/usr/bin/env bash
# Sets up, builds and runs the default scene (the paper's box grasp), then replays
# the shipped tracker session (assets/demo_session.lcmlog) headless.
# Extra arguments go to `graspsim run`, e.g. scripts/demo.sh --out out/
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/build.sh release --target graspsim
build/release/graspsim run "$@"
echo
exec build/release/graspsim replay assets/demo_session.lcmlog
