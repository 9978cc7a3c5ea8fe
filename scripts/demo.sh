#!/usr/bin/env bash
# Sets up, builds and runs the default scene (the paper's box grasp).
# Extra arguments go to `graspsim run`, e.g. scripts/demo.sh --out out/
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/build.sh release --target graspsim
exec build/release/graspsim run "$@"
