#!/usr/bin/env bash
# Sets up, builds and runs the whole test suite: the release build of every test
# (with the fuzz targets, ASan+UBSan builds of every parser of outside input), the
# AddressSanitizer build of the engine's tests (label "core"), and the
# ThreadSanitizer build of the threaded tests (label "threads": receiver, mailbox,
# live, record). The sanitizer builds are clang's (CMakePresets.json); each stage
# prints its time.
# GRASPSIM_TEST_PRESETS overrides the list, e.g. GRASPSIM_TEST_PRESETS=release.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
presets="${GRASPSIM_TEST_PRESETS:-release asan tsan}"
jobs="$(nproc)"
# ctest with the given arguments; when a test fails, its own output (from the
# build's LastTest.log) is printed last, where a log's tail shows it
run_ctest() {
  local dir="$1"
  shift
  if ctest "$@"; then return 0; fi
  local failed="$dir/Testing/Temporary/LastTestsFailed.log"
  if [ -f "$failed" ]; then
    while IFS=: read -r _ name; do
      echo "=== output of the failed test $name ==="
      awk -v n="$name" '!p && /^[0-9]+\/[0-9]+ Test: / && substr($0, index($0, "Test: ") + 6) == n {p = 1}
                         p {print} p && index($0, "\"" n "\" end time:") == 1 {exit}' \
        "$dir/Testing/Temporary/LastTest.log" | tail -n 120
    done <"$failed"
  fi
  return 1
}
for preset in $presets; do
  echo "=== $preset ==="
  start=$SECONDS
  if [ "$preset" = tsan ]; then
    scripts/build.sh tsan --target graspsim tracking_tests
    # the threaded tests (receiver, mailboxes, live, record, replay, signals); the determinism
    # tests render through OSMesa, whose llvmpipe threads are not instrumented: they run in
    # the release and asan builds
    run_ctest build/tsan --preset tsan -j "$jobs" -L threads -E '^Determinism\.'
  elif [ "$preset" = asan ]; then
    # the engine (core: no I/O, every index and buffer of the step) under ASan; the
    # parsers of outside input are the fuzz targets' ASan+UBSan builds (release stage),
    # and the commands' threads are the tsan stage's. A sanitized build of every library above core
    # and render/ as well took CI past its time. The long scale checks (minutes of
    # simulation each under ASan) run in the release build only.
    scripts/build.sh asan --target core_tests
    run_ctest build/asan --preset asan -j "$jobs" -L core -E '^Scale\.(EveryMassTimesK|HeavyOnLightStacks).*$'
  else
    scripts/build.sh "$preset"
    run_ctest "build/$preset" --preset "$preset" -j "$jobs"
  fi
  echo "=== $preset: $((SECONDS - start)) s ==="
done
