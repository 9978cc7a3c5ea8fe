#!/usr/bin/env bash
# Sets up, builds and runs the whole test suite: the release build (with the
# fuzz targets), the ASan+UBSan build of every test, and the ThreadSanitizer
# build of the threaded tests (label "threads": receiver, mailbox, live, record).
# GRASPSIM_TEST_PRESETS overrides the list, e.g. GRASPSIM_TEST_PRESETS=release.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
presets="${GRASPSIM_TEST_PRESETS:-release asan tsan}"
jobs="$(nproc)"
for preset in $presets; do
  echo "=== $preset ==="
  start=$SECONDS
  if [ "$preset" = tsan ]; then
    scripts/build.sh tsan --target graspsim tracking_tests
    # the threaded tests (receiver, mailboxes, live, record, replay, signals); the determinism
    # tests render through OSMesa, whose llvmpipe threads are not instrumented: they run in
    # the release and asan builds
    ctest --preset tsan -j "$jobs" -L threads -E '^Determinism\.'
  elif [ "$preset" = asan ]; then
    scripts/build.sh asan
    # every unit and integration test; the four sweeps that replay whole benchmark
    # matrices (minutes each under ASan) run in the release build only
    ctest --preset asan -j "$jobs" -E '^(Stress\.QuickMatrix|Tradeoff\.QuickSweeps|BenchScaling\.QuickSeriesAndFittedSlopes|BenchSkip\.QuickRunShowsEachSkip)$'
  else
    scripts/build.sh "$preset"
    ctest --preset "$preset" -j "$jobs"
  fi
  echo "=== $preset: $((SECONDS - start)) s ==="
done
