#!/usr/bin/env bash
# Builds the libFuzzer targets with Debian's clang (ASan + UBSan) and runs one for
# a bounded time from its seed corpus (corpus/TARGET/, kept in the repository).
# Any crash, sanitizer report, timeout, memory blow-up or broken invariant fails
# (non-zero exit) and leaves the input in OUT_DIR/TARGET/ as crash-* or leak-*;
# add it to corpus/TARGET/ (as a regression seed) once fixed.
# Usage: run_fuzz.sh OUT_DIR build
#        run_fuzz.sh OUT_DIR TARGET [SECONDS]      TARGET: dtrack scene mesh lcmlog fclib
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
out="${1:?usage: run_fuzz.sh OUT_DIR build|TARGET [SECONDS]}"
what="${2:?usage: run_fuzz.sh OUT_DIR build|TARGET [SECONDS]}"
seconds="${3:-15}"
cxx="${CLANGXX:-clang++}"
if ! command -v "$cxx" >/dev/null; then
  echo "run_fuzz.sh: $cxx not found (apt-get install clang libclang-rt-14-dev)" >&2
  exit 1
fi
build="$out/build"
if [ "$what" = build ]; then
  launcher=()
  command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
  if [ ! -f "$build/build.ninja" ]; then
    cmake -S "$here" -B "$build" -G Ninja -DCMAKE_CXX_COMPILER="$cxx" -DCMAKE_BUILD_TYPE=None "${launcher[@]}" >/dev/null
  fi
  exec cmake --build "$build"
fi
bin="$build/${what}_fuzz"
[ -x "$bin" ] || { echo "run_fuzz.sh: $bin not built (run_fuzz.sh $out build)" >&2; exit 1; }
[ -d "$here/corpus/$what" ] || { echo "run_fuzz.sh: no seed corpus $here/corpus/$what" >&2; exit 1; }
work="$out/$what"
mkdir -p "$work/corpus"
cp "$here/corpus/$what"/* "$work/corpus/"
dict=()
[ -f "$here/$what.dict" ] && dict=(-dict="$here/$what.dict")
cd "$work"
# third-party leaks we cannot fix (libfclib's reader) are suppressed as in the asan preset
export LSAN_OPTIONS="suppressions=$here/../sanitizers/lsan.supp:print_suppressions=0"
# -rss_limit_mb: a parser that allocates without bound fails; -timeout: one that hangs does
exec "$bin" "${dict[@]}" -max_total_time="$seconds" -max_len=8192 -timeout=10 -rss_limit_mb=1024 \
  -print_final_stats=1 corpus
