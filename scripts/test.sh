#!/usr/bin/env bash
# Sets up, builds and runs the whole test suite: the release build, then the
# sanitizer builds of the unit and integration tests.
# GRASPSIM_TEST_PRESETS overrides the list, e.g. GRASPSIM_TEST_PRESETS=release.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
presets="${GRASPSIM_TEST_PRESETS:-release asan}"
jobs="$(nproc)"
for preset in $presets; do
  echo "=== $preset ==="
  scripts/build.sh "$preset"
  ctest --preset "$preset" -j "$jobs"
done
